//! TOML scene files.
//!
//! ```toml
//! [environment]
//! file = "../../shared/data/hdri/park.exr"  # or: builtin = "studio"
//! rotate = [30.0, 0.0, 0.0]                 # yaw, pitch, roll in degrees (optional)
//! scale = 1.0                               # radiance multiplier (optional)
//!
//! [camera]                                  # optional: default frames the objects
//! eye = [0.0, 1.0, 4.0]
//! target = [0.0, 0.5, 0.0]
//! fov = 40.0                                # vertical, degrees
//! size = [960, 540]
//!
//! [[object]]
//! mesh = "../../shared/data/mesh/bunny.obj" # or: builtin = "sphere" | "torus" | "knot" | "ground"
//! brdf = "ggx:0.2"
//! translate = [0.0, 0.0, 0.0]
//! scale = 1.0
//! rotate = [0.0, 0.0, 0.0]                  # yaw, pitch, roll in degrees
//!
//! [render]                                  # optional defaults for `relight render`
//! method = "reference"
//! spp = 64
//!
//! [fog]                                     # optional, for `--method fog`
//! beta = 0.04
//! [[light]]
//! position = [1.0, 2.0, 1.0]
//! intensity = 20.0
//! ```
//!
//! Relative paths are resolved against the scene file's folder.

use serde::Deserialize;

/// A parsed scene file (see the module docs for the format).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    #[serde(default)]
    pub environment: EnvironmentDesc,
    pub camera: Option<CameraDesc>,
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectDesc>,
    pub render: Option<RenderDesc>,
    pub fog: Option<FogDesc>,
    #[serde(default, rename = "light")]
    pub lights: Vec<LightDesc>,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentDesc {
    pub file: Option<String>,
    pub builtin: Option<String>,
    pub rotate: Option<[f32; 3]>,
    pub scale: Option<f32>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub fov: Option<f32>,
    pub size: Option<[usize; 2]>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDesc {
    pub mesh: Option<String>,
    pub builtin: Option<String>,
    pub brdf: Option<String>,
    pub translate: Option<[f32; 3]>,
    pub scale: Option<f32>,
    pub rotate: Option<[f32; 3]>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    pub method: Option<String>,
    pub spp: Option<u32>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FogDesc {
    pub beta: f32,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDesc {
    pub position: [f32; 3],
    pub intensity: f32,
    pub color: Option<[f32; 3]>,
}
