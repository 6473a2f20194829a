//! The TOML scene-file format: the serde structs that mirror the file, the
//! defaults of every optional key, and parsing with one-line errors.
//!
//! **The format is documented in one place, `docs/scene-format.md`**: every
//! key with its type, units, frame and default, and complete examples. This
//! module holds no second copy of that table; a test
//! (`crates/scene/tests/it/docs.rs`) fails when a key accepted here is missing
//! from the document or documented but not accepted.
//!
//! The structs only describe the file's shape (names and types). Values are
//! checked, and paths resolved against the scene file's folder, when
//! [`crate::load_scene_file`] turns a [`SceneFile`] into a
//! [`relight_render::Scene`].
//!
//! # Errors
//! Syntax and type errors come back as one line,
//! `FILE: line L, column C: KEY: MESSAGE`, where `KEY` is the dotted path of
//! the offending key with 1-based indices into arrays of tables
//! (`object[2].scale`); value errors from the loader read
//! `FILE: KEY: MESSAGE`. The keys of older files (`[fog]`, `[[light]]`) are
//! rejected with the name of their replacement.

use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::fmt;
use std::path::Path;

use crate::SceneError;

// ---------------------------------------------------------------------------
// Defaults: each optional key's default lives here and only here
// (docs/scene-format.md names these constants).

/// `[environment]` with neither `file` nor `builtin`: this built-in map.
pub const DEFAULT_ENVIRONMENT: &str = "studio";
/// Names accepted by `[environment] builtin`.
pub const BUILTIN_ENVIRONMENTS: [&str; 2] = ["studio", "black"];
/// `[environment] scale`: radiance multiplier.
pub const DEFAULT_ENV_SCALE: f32 = 1.0;
/// `rotate` keys everywhere: yaw, pitch, roll in degrees.
pub const DEFAULT_ROTATE_DEG: [f32; 3] = [0.0; 3];
/// `translate` keys everywhere (scene units).
pub const DEFAULT_TRANSLATE: [f32; 3] = [0.0; 3];
/// `scale` keys of objects and keyframes (uniform).
pub const DEFAULT_OBJECT_SCALE: f32 = 1.0;
/// `[[object]] brdf` (a `relight_brdf::BrdfSpec` string).
pub const DEFAULT_BRDF: &str = "lambert";
/// `[camera] fov` and the framing camera's field of view (vertical, degrees).
pub const DEFAULT_FOV_DEG: f32 = 40.0;
/// `[camera] up`, unless the view is vertical ([`DEFAULT_CAMERA_UP_VERTICAL`]).
pub const DEFAULT_CAMERA_UP: [f32; 3] = [0.0, 1.0, 0.0];
/// `[camera] up` when `|view · Y| > VERTICAL_NORMAL_COS` (a camera looking
/// straight down or up): the image's top towards −Z, the default camera's
/// forward direction.
pub const DEFAULT_CAMERA_UP_VERTICAL: [f32; 3] = [0.0, 0.0, -1.0];
/// `[camera] size` (pixels, width × height) when neither the file nor the
/// caller gives one.
pub const DEFAULT_IMAGE_SIZE: [usize; 2] = [960, 540];
/// Largest accepted image side (pixels).
pub const MAX_IMAGE_SIDE: usize = 16_384;
/// `[[point_light]] color`: multiplies `intensity`.
pub const DEFAULT_LIGHT_COLOR: [f32; 3] = [1.0; 3];
/// `[[area_light]] up` when the normal is not within [`VERTICAL_NORMAL_COS`]
/// of ±Y.
pub const DEFAULT_AREA_UP: [f32; 3] = [0.0, 1.0, 0.0];
/// `[[area_light]] up` when `|normal · Y| > VERTICAL_NORMAL_COS` (a floor or
/// ceiling light).
pub const DEFAULT_AREA_UP_VERTICAL: [f32; 3] = [0.0, 0.0, 1.0];
/// Cosine beyond which an area light's normal counts as vertical (≈ 2.6°).
pub const VERTICAL_NORMAL_COS: f32 = 0.999;
/// `[medium] albedo`: single-scattering albedo σ_s/σ_t.
pub const DEFAULT_MEDIUM_ALBEDO: f32 = 1.0;
/// `[medium] radius`: the fog ball's radius about the origin (scene units).
pub const DEFAULT_MEDIUM_RADIUS: f32 = 10.0;
/// Top-level `visibility`: false is the unshadowed reflection integral.
pub const DEFAULT_VISIBILITY: bool = false;

// ---------------------------------------------------------------------------
// The file's shape.

/// A parsed scene file (format: `docs/scene-format.md`).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Top level: shadows on or off (default [`DEFAULT_VISIBILITY`]).
    pub visibility: Option<bool>,
    #[serde(default)]
    pub environment: EnvironmentDesc,
    pub camera: Option<CameraDesc>,
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectDesc>,
    #[serde(default, rename = "point_light")]
    pub point_lights: Vec<PointLightDesc>,
    #[serde(default, rename = "area_light")]
    pub area_lights: Vec<AreaLightDesc>,
    pub medium: Option<MediumDesc>,
    pub render: Option<RenderDesc>,
}

/// `[environment]`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentDesc {
    pub file: Option<String>,
    pub builtin: Option<String>,
    pub rotate: Option<[f32; 3]>,
    pub scale: Option<f32>,
}

/// `[camera]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub fov: Option<f32>,
    pub size: Option<[usize; 2]>,
}

/// `[[object]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDesc {
    pub mesh: Option<String>,
    pub builtin: Option<String>,
    pub brdf: Option<String>,
    pub translate: Option<[f32; 3]>,
    pub scale: Option<f32>,
    pub rotate: Option<[f32; 3]>,
    pub normal_map: Option<String>,
    pub blend: Option<BlendDesc>,
    #[serde(default, rename = "keyframe")]
    pub keyframes: Vec<KeyframeDesc>,
}

/// `[object.blend]`: a second BRDF blended in by a weight texture.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlendDesc {
    pub brdf: String,
    pub weight: String,
}

/// `[[object.keyframe]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyframeDesc {
    pub time: f32,
    pub translate: Option<[f32; 3]>,
    pub rotate: Option<[f32; 3]>,
    pub scale: Option<f32>,
}

/// `[[point_light]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightDesc {
    pub position: [f32; 3],
    pub intensity: Rgb,
    pub color: Option<[f32; 3]>,
}

/// `[[area_light]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AreaLightDesc {
    pub center: [f32; 3],
    pub size: [f32; 2],
    pub normal: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    pub rotate: Option<[f32; 3]>,
    pub intensity: Rgb,
    pub texture: Option<String>,
    pub light_field: Option<LightFieldDesc>,
}

/// `[area_light.light_field]`: radiance by direction too
/// (`relight_render::LightField`): `tiles` (an image of `views × views`
/// tiles) or `builtin` ([`LIGHT_FIELD_BUILTINS`]).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightFieldDesc {
    pub tiles: Option<String>,
    pub builtin: Option<String>,
    pub views: usize,
    pub extent: f32,
}

/// Names accepted by `[area_light.light_field] builtin`.
pub const LIGHT_FIELD_BUILTINS: [&str; 1] = ["prism"];

/// `[medium]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    pub beta: f32,
    pub albedo: Option<f32>,
    pub radius: Option<f32>,
}

/// `[render]`: defaults for `relight render` (the CLI validates `method`
/// and owns the defaults of its options).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    pub method: Option<String>,
    pub spp: Option<u32>,
}

/// An RGB value written as one number (grey) or an `[r, g, b]` array.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rgb(pub [f32; 3]);

impl<'de> Deserialize<'de> for Rgb {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Rgb;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an [r, g, b] array of numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Rgb, E> {
                Ok(Rgb([v as f32; 3]))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Rgb, E> {
                Ok(Rgb([v as f32; 3]))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Rgb, E> {
                Ok(Rgb([v as f32; 3]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Rgb, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, v) in c.iter_mut().enumerate() {
                    *v = seq
                        .next_element::<f32>()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(Rgb(c))
            }
        }
        d.deserialize_any(V)
    }
}

// ---------------------------------------------------------------------------
// Parsing.

/// Keys of the old format and what replaced them.
const REMOVED_KEYS: [(&str, &str); 2] = [
    (
        "fog",
        "`[fog]` was replaced by `[medium]` (keys beta, albedo, radius)",
    ),
    (
        "light",
        "`[[light]]` was replaced by `[[point_light]]` (keys position, intensity, color)",
    ),
];

/// Parses scene-file text; `path` names the file in errors.
///
/// # Errors
/// [`SceneError::Parse`]: a TOML syntax error, an unknown key, a value of
/// the wrong type, a missing required key, or a removed key — one line
/// naming the file, the position and the key.
pub fn parse_scene_file(text: &str, path: &Path) -> Result<SceneFile, SceneError> {
    let table: toml::Table = text.parse().map_err(|e| parse_error(text, path, &e))?;
    for (key, why) in REMOVED_KEYS {
        if table.contains_key(key) {
            let line = header_line(text, key).unwrap_or(1);
            return Err(SceneError::Parse {
                path: path.into(),
                message: format!("line {line}: {key}: {why}"),
            });
        }
    }
    toml::from_str(text).map_err(|e| parse_error(text, path, &e))
}

/// The 1-based line of the first `[key]` / `[[key]]` header or `key =`.
fn header_line(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            let l = strip_comment(l).trim();
            let name = l.trim_start_matches('[').trim_end_matches(']').trim();
            (l.starts_with('[') && name == key)
                || l.split_once('=').is_some_and(|(k, _)| k.trim() == key)
        })
        .map(|i| i + 1)
}

fn strip_comment(line: &str) -> &str {
    // Good enough for locating headers and keys: a `#` inside a quoted
    // string on a header or key line is not expected.
    line.split_once('#').map_or(line, |(a, _)| a)
}

/// One line: `line L, column C: KEY: MESSAGE` (the path is added by
/// [`SceneError::Parse`]'s display).
fn parse_error(text: &str, path: &Path, e: &toml::de::Error) -> SceneError {
    let message = e.message().replace('\n', "; ");
    let Some(span) = e.span() else {
        return SceneError::Parse {
            path: path.into(),
            message,
        };
    };
    let start = span.start.min(text.len());
    let before = &text[..start];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    let key = key_path_at(text, line);
    SceneError::Parse {
        path: path.into(),
        message: if key.is_empty() {
            format!("line {line}, column {col}: {message}")
        } else {
            format!("line {line}, column {col}: {key}: {message}")
        },
    }
}

/// The dotted key path (1-based array indices) in force at 1-based `line`:
/// the last table header above it plus the key assigned on the line.
fn key_path_at(text: &str, line: usize) -> String {
    let mut counts: Vec<(String, usize)> = Vec::new();
    let mut table = String::new();
    let mut key = String::new();
    for (i, raw) in text.lines().take(line).enumerate() {
        let l = strip_comment(raw).trim();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.strip_suffix("]]")) {
            let name = name.trim().to_string();
            counts.retain(|(n, _)| !n.starts_with(&format!("{name}.")));
            match counts.iter_mut().find(|(n, _)| *n == name) {
                Some((_, c)) => *c += 1,
                None => counts.push((name.clone(), 1)),
            }
            table = indexed(&name, &counts);
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            table = indexed(name.trim(), &counts);
        }
        if i + 1 == line {
            key = l
                .split_once('=')
                .map(|(k, _)| k.trim().to_string())
                .unwrap_or_default();
        }
    }
    match (table.is_empty(), key.is_empty()) {
        (true, _) => key,
        (false, true) => table,
        (false, false) => format!("{table}.{key}"),
    }
}

/// `object.keyframe` → `object[2].keyframe[1]` with the current counts.
fn indexed(name: &str, counts: &[(String, usize)]) -> String {
    let mut out = String::new();
    let mut prefix = String::new();
    for (i, part) in name.split('.').enumerate() {
        if i > 0 {
            prefix.push('.');
            out.push('.');
        }
        prefix.push_str(part.trim());
        out.push_str(part.trim());
        if let Some((_, c)) = counts.iter().find(|(n, _)| *n == prefix) {
            out.push_str(&format!("[{c}]"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_paths_count_arrays_of_tables() {
        let text = "visibility = true\n[[object]]\nbuiltin = \"sphere\"\n[[object.keyframe]]\ntime = 0\n[[object]]\n[[object.keyframe]]\n[[object.keyframe]]\ntime = 1\n[object.blend]\nbrdf = 1\n";
        assert_eq!(key_path_at(text, 1), "visibility");
        assert_eq!(key_path_at(text, 3), "object[1].builtin");
        assert_eq!(key_path_at(text, 5), "object[1].keyframe[1].time");
        assert_eq!(key_path_at(text, 9), "object[2].keyframe[2].time");
        assert_eq!(key_path_at(text, 11), "object[2].blend.brdf");
    }

    #[test]
    fn rgb_is_a_number_or_a_triple() {
        #[derive(Deserialize)]
        struct T {
            a: Rgb,
            b: Rgb,
        }
        let t: T = toml::from_str("a = 2\nb = [0.5, 1, 2.5]").unwrap();
        assert_eq!(t.a, Rgb([2.0; 3]));
        assert_eq!(t.b, Rgb([0.5, 1.0, 2.5]));
        for bad in [
            "a = [1, 2]\nb = 1",
            "a = [1, 2, 3, 4]\nb = 1",
            "a = \"x\"\nb = 1",
        ] {
            let e = toml::from_str::<T>(bad).err().unwrap();
            assert!(e.message().contains("[r, g, b]"), "{bad}: {}", e.message());
        }
    }
}
