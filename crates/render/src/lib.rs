//! The image stage of relight: a perspective camera, a tiled parallel
//! software rasterizer (the runtime of every real-time technique), a BVH for
//! ray casting (visibility, ambient occlusion) and the Monte Carlo
//! ground-truth renderer that judges every `relight verify`.
//!
//! **Architecture invariant:** no file IO; images leave through
//! `relight-assets`.

pub mod bvh;
pub mod camera;
pub mod cull;
pub mod image;
pub mod light_field;
pub mod method;
mod numbering;
mod object_raster;
pub mod progress;
pub mod raster;
pub mod reference;
pub mod sampling;
pub mod scene;
mod scene_coarse;
mod scene_lighting;
pub mod texture;
pub mod verify_row;

pub use camera::{Camera, CameraRays};
pub use image::Image;
pub use light_field::LightField;
pub use method::{
    Coverage, FrameRequest, FrameTimings, MethodError, Noise, Relighter, Rendered, SceneFeature,
    Support, check_scene, render_frame,
};
pub use numbering::Numbered;
pub use progress::{Cancelled, NoProgress, Progress};
pub use raster::{
    Background, CullMode, DrawCall, Fragment, GBuffer, RasterBenchRow, RasterError, RasterOptions,
    RasterStats, Rasterizer, VertexAttributes, bench_raster,
};
pub use scene::{Animation, AreaLight, BrdfBlend, Keyframe, Medium, Object, PointLight, Scene};
pub use scene_coarse::{
    COARSE_SHARE_OF_BLOCKER, COARSE_SHARE_OF_SCENE, CoarseObject, REFINED_MAX_VERTICES,
    REFINED_SHARE_OF_LIMIT, RefinedObject,
};
pub use texture::{NormalMap, Texture, TextureError};
pub use verify_row::VerifyRow;

pub use bvh::{BvhParts, Hit, SceneBvh, ShadingPoint, ambient_occlusion, vertex_ambient_occlusion};
pub use reference::{
    EnvLight, LightSampling, MediumMode, RadianceEstimate, ReferenceBenchRow, ReferenceError,
    ReferenceImage, ReferenceOptions, ReferenceRenderer, bench_reference, reference_radiance_at,
    render_reference, render_reference_with,
};
pub use reference::{GiImage, GiOptions, GiTracer, render_gi_reference};
pub use sampling::{EnvFilter, EnvSampler, Rng};
