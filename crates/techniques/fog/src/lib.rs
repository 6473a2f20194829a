//! Analytic single-scattering fog (Sun, Ramamoorthi, Narasimhan & Nayar
//! 2005; Sun 2008, chapter 3): glows around point lights, dimmed and
//! widened highlights and brightened shadows in a homogeneous medium, as
//! easy to use as OpenGL fog (one coefficient β) and evaluated in real time
//! on the CPU rasterizer.
//!
//! # Pipeline
//! 1. [`special`]: exact special functions F, Fᵏ, G_n (adaptive quadrature)
//!    and the scaled tail H̃ that the tables store (why: no cancellation).
//! 2. [`table`]: [`FogTables`] — 2D tables with bilinear/nearest lookup.
//! 3. [`model`]: the per-pixel complete model L = e^{−T_vp} L_p + L_a
//!    (eq. 3.29) for any number of isotropic point lights, phase functions
//!    as polynomials in cos α.
//! 4. [`render`]: [`render_fog`] on relight-render's rasterizer (pass 1:
//!    visibility buffer; pass 2: [`shade`], the data-oriented per-pixel
//!    evaluation — structure-of-arrays batches per row, one branch-free loop
//!    per light, AVX2 gathers where the CPU has them, the cheap [`fast`]
//!    exp/log/atan), plus classic OpenGL fog for comparison.
//! 5. [`psf`]: the airlight point-spread function (eq. 3.30–3.32), its zonal
//!    SH coefficients and the convolutions of environment maps and BRDFs
//!    (eq. 3.34–3.37).
//! 6. [`verify`] and [`mod@bench`]: `relight verify fog` / `relight bench fog`
//!    (the Monte Carlo ground truth is the reference renderer's,
//!    `relight_render::reference`, sampled along the same rays).
//! 7. [`method`]: [`FogRelighter`], the method interface's `fog` — point
//!    lights by the analytic model plus the environment by its
//!    foggy version (§3.6.4, with the fog ball's own kernel), for a whole scene.
//! 8. [`view_segment`]: the scene's medium is a ball, not all of space — the
//!    model from each view ray's entry into it (the eye may be outside), and
//!    the chord table that scales the environment's glow and each view
//!    segment's scattering ([`view_segment::ChordGlow`]); the ball's own
//!    environment kernel is [`psf::ball_convolution_weights`], and
//!    [`ball_light`] scales a surface's light for its place in the ball.
//!
//! # Citation
//! B. Sun, "Mathematical Models for Real-Time Rendering", PhD thesis,
//! Columbia University 2008, chapter 3 (equation numbers in the docs refer
//! to it).

pub mod ball_light;
pub mod bench;
pub mod env_vertex;
pub mod fast;
pub mod method;
pub mod model;
pub mod psf;
pub mod quad;
pub mod render;
pub mod shade;
mod simd;
pub mod special;
pub mod table;
pub mod verify;
pub mod view_segment;
pub mod work;

pub use bench::{BenchRow, bench_fog, bench_fog_scene};
pub use env_vertex::EnvShading;
pub use method::{EnvGlow, FogOptions, FogRelighter};
pub use model::{FogMaterial, FogModel, Phase, PointLight};
use relight_render::Numbered;
pub use render::{
    FogMode, FogObject, FogSettings, default_scene_lights, render_fog, scene_objects,
};
pub use table::{FogTables, Interp, MAX_TABLE_SIZE, Table2, TableImage};
pub use verify::{VerifyRow, verify_fog};

/// Errors of the fog crate: bad input, named.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum FogError {
    #[error(
        "table size {size} is out of range: need 2…{} samples per axis",
        crate::table::MAX_TABLE_SIZE
    )]
    TableSize { size: usize },
    #[error("scattering coefficient β = {beta} is invalid: need a finite β ≥ 0")]
    Beta { beta: f32 },
    #[error("single-scattering albedo {albedo} is invalid: need 0 ≤ albedo ≤ 1")]
    Albedo { albedo: f32 },
    #[error(
        "{}: intensity {intensity:?} is invalid: need finite components ≥ 0",
        Numbered::point_light(*.index)
    )]
    Intensity { index: usize, intensity: [f32; 3] },
    #[error(
        "{}: position {position:?} is not finite",
        Numbered::point_light(*.index)
    )]
    LightPosition { index: usize, position: [f32; 3] },
    #[error(
        "{} at {position:?} lies inside closed geometry ({}); move it outside the mesh",
        Numbered::point_light(*.index),
        Numbered::object(*.object)
    )]
    LightInsideGeometry {
        index: usize,
        position: [f32; 3],
        object: usize,
    },
    #[error(
        "the eye at {eye} is {depth} mean free paths (β × distance) outside the fog ball of radius \
         {radius}; beyond {} the model's terms underflow f32: move the eye closer",
        crate::view_segment::MAX_EYE_DEPTH
    )]
    EyeFarOutsideBall {
        eye: glam::Vec3,
        radius: f32,
        depth: f32,
    },
    #[error("{what} = {value} is invalid: distances must be finite and > 0")]
    Distance { what: &'static str, value: f64 },
    #[error(
        "no G table for Phong exponent {n}: build the tables with FogTables::build_with(size, degree, &[{n}])"
    )]
    MissingPhongTable { n: u32 },
    #[error("Phong exponent {n} is invalid: need 1..=4096")]
    PhongExponent { n: u32 },
    #[error(
        "phase polynomial degree {degree} exceeds the tabulated degree {max} (or the phase is empty)"
    )]
    PhaseDegree { degree: u32, max: u32 },
    #[error("Henyey–Greenstein asymmetry g = {g} is invalid: need −1 < g < 1")]
    Asymmetry { g: f32 },
    #[error(
        "{}: material index invalid or mesh has no triangles",
        Numbered::object(*.object)
    )]
    Object { object: usize },
    #[error("rasterizer: {0}")]
    Raster(#[from] relight_render::raster::RasterError),
    #[error("cancelled")]
    Cancelled,
}

impl From<relight_render::Cancelled> for FogError {
    fn from(_: relight_render::Cancelled) -> Self {
        Self::Cancelled
    }
}
