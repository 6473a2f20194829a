//! Scenes: the embedded default scene ([`embedded`], generated in code, no
//! files) and TOML scene files ([`file`](mod@file), format in `docs/scene-format.md`)
//! that load into the one scene model, [`relight_render::Scene`]:
//! environment and its rotation, meshes with BRDFs, normal maps, BRDF blends
//! and keyframed motion, point and area lights, a homogeneous medium,
//! visibility and a camera.
//!
//! | module | what |
//! |---|---|
//! | [`file`](mod@file) | the TOML structs, every default, parsing with one-line errors |
//! | [`load`] | scene file → [`relight_render::Scene`]: environment, objects, camera |
//! | `lights` | point lights, area lights (orientation) and the medium |
//! | `textures` | image files → [`relight_render::Texture`] / [`relight_render::NormalMap`] |
//! | [`embedded`] | the default scene, built-in meshes, the framing camera |
//! | [`studio`] | the procedural studio environment |

mod check;
pub mod embedded;
mod error;
pub mod file;
mod lights;
pub mod load;
pub mod studio;
mod textures;

pub use embedded::{
    BUILTIN_MESHES, FLOOR_BRDF, FLOOR_HALF_SIDE, STUDIO_HEIGHT, builtin_mesh, default_camera,
    default_scene, floor_mesh, framing_camera, with_brdf,
};
pub use error::SceneError;
pub use file::{SceneFile, parse_scene_file};
pub use load::{
    LoadedScene, default_camera_up, load_environment, load_mesh, load_scene_file, load_scene_text,
};
pub use relight_sphere::rotation_from_yaw_pitch_roll;
pub use studio::{
    SUN_RADIANCE, SUN_RADIUS_DEG, studio_environment, studio_radiance, studio_sun_direction,
    studio_sun_irradiance,
};
pub use textures::{TextureFileError, load_normal_map, load_texture, load_weight_texture};
