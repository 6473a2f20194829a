//! Value checks for scene-file keys: each returns the checked value or a
//! [`SceneError::Invalid`] naming the file and the key.

use crate::SceneError;
use glam::{Vec2, Vec3};
use std::path::Path;

/// Names the scene file in errors; `key` arguments are dotted key paths.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub file: &'a Path,
}

impl Ctx<'_> {
    pub fn context(&self, key: &str) -> String {
        format!("{}: {key}", self.file.display())
    }

    pub fn err(&self, key: &str, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            context: self.context(key),
            message: message.into(),
        }
    }

    pub fn file_err(&self, key: &str, source: relight_assets::AssetError) -> SceneError {
        SceneError::File {
            context: self.context(key),
            source,
        }
    }

    /// A finite scalar.
    pub fn finite(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(key, format!("must be a finite number (got {v})")))
        }
    }

    /// A finite vector.
    pub fn vec3(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(Vec3::from(v))
        } else {
            Err(self.err(key, format!("must be finite numbers (got {v:?})")))
        }
    }

    /// A finite, non-zero direction, normalised.
    pub fn direction(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let d = self.vec3(key, v)?;
        d.try_normalize()
            .filter(|_| d.length() > 1e-6)
            .ok_or_else(|| self.err(key, format!("must be a non-zero direction (got {v:?})")))
    }

    /// A finite scalar `> 0`.
    pub fn positive(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(key, format!("must be a finite number > 0 (got {v})")))
        }
    }

    /// A finite scalar `≥ 0`.
    pub fn non_negative(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.err(key, format!("must be a finite number ≥ 0 (got {v})")))
        }
    }

    /// Finite RGB with every channel `≥ 0`.
    pub fn rgb(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
            Ok(Vec3::from(v))
        } else {
            Err(self.err(
                key,
                format!("must be finite and ≥ 0 in every channel (got {v:?})"),
            ))
        }
    }

    /// An emitted intensity: RGB with every channel in `0 ≤ v ≤`
    /// [`relight_sphere::MAX_RADIANCE`] (larger values overflow f32 in
    /// the renderers' sums).
    pub fn emission(&self, key: &str, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let rgb = self.rgb(key, v)?;
        if rgb.max_element() <= relight_sphere::MAX_RADIANCE {
            Ok(rgb)
        } else {
            Err(self.err(
                key,
                format!(
                    "must be ≤ {:e} in every channel (got {v:?})",
                    relight_sphere::MAX_RADIANCE
                ),
            ))
        }
    }

    /// A finite size with both sides `> 0`.
    pub fn size2(&self, key: &str, v: [f32; 2]) -> Result<Vec2, SceneError> {
        if v.iter().all(|x| x.is_finite() && *x > 0.0) {
            Ok(Vec2::from(v))
        } else {
            Err(self.err(
                key,
                format!("both sides must be finite and > 0 (got {v:?})"),
            ))
        }
    }

    /// Yaw, pitch, roll in degrees (finite).
    pub fn angles(&self, key: &str, v: [f32; 3]) -> Result<[f32; 3], SceneError> {
        self.vec3(key, v).map(|_| v)
    }
}
