//! Scene-file lights and medium → [`PointLight`], [`AreaLight`], [`Medium`]
//! (units and frames: `relight_render::scene`; keys: `docs/scene-format.md`).
//!
//! # Area-light orientation
//! The light's frame `(x̂, ŷ, ẑ)` (columns of `world_from_light`, ẑ the
//! emitting side) comes from one of:
//! * `normal` (+ optional `up`): `ẑ = normalize(normal)`,
//!   `ŷ = normalize(up − (up·ẑ) ẑ)`, `x̂ = ŷ × ẑ`, so the texture appears
//!   upright, `up` towards its top, seen from the lit side. The default `up`
//!   is [`DEFAULT_AREA_UP`] (+Y), or [`DEFAULT_AREA_UP_VERTICAL`] (+Z) when
//!   `|ẑ·Y| > VERTICAL_NORMAL_COS` (floor and ceiling lights);
//! * `rotate` (yaw, pitch, roll in degrees): `world_from_light =
//!   rotation_from_yaw_pitch_roll(rotate)`; `[0, 0, 0]` emits towards +Z,
//!   `[0, 90, 0]` straight down, `[90, 0, 0]` towards +X.

use crate::check::Ctx;
use crate::file::{
    AreaLightDesc, DEFAULT_AREA_UP, DEFAULT_AREA_UP_VERTICAL, DEFAULT_LIGHT_COLOR,
    DEFAULT_MEDIUM_ALBEDO, DEFAULT_MEDIUM_RADIUS, LIGHT_FIELD_BUILTINS, LightFieldDesc, MediumDesc,
    PointLightDesc, VERTICAL_NORMAL_COS,
};
use crate::textures::load_texture;
use crate::{SceneError, rotation_from_yaw_pitch_roll};
use glam::{Mat3, Vec3};
use relight_render::{AreaLight, LightField, Medium, PointLight, Texture};
use std::path::Path;
use std::sync::Arc;

/// Smallest `|up × normal|` (unit vectors) accepted: `up` within ≈ 0.06° of
/// the normal leaves the light's spin undefined.
const MIN_UP_SINE: f32 = 1e-3;

pub(crate) fn point_light(
    cx: Ctx,
    key: &str,
    d: &PointLightDesc,
) -> Result<PointLight, SceneError> {
    let position = cx.vec3(&format!("{key}.position"), d.position)?;
    let intensity = cx.emission(&format!("{key}.intensity"), d.intensity.0)?;
    let color = cx.rgb(
        &format!("{key}.color"),
        d.color.unwrap_or(DEFAULT_LIGHT_COLOR),
    )?;
    Ok(PointLight::new(position, intensity * color))
}

/// The light's frame from `normal` (+ `up`) or `rotate` (module docs).
fn orientation(cx: Ctx, key: &str, d: &AreaLightDesc) -> Result<Mat3, SceneError> {
    match (d.normal, d.rotate) {
        (Some(_), Some(_)) => {
            Err(cx.err(key, "give either `normal` (+ `up`) or `rotate`, not both"))
        }
        (None, None) => Err(cx.err(
            key,
            "needs an orientation: `normal` (+ optional `up`) or `rotate`",
        )),
        (None, Some(r)) => {
            if d.up.is_some() {
                return Err(cx.err(
                    &format!("{key}.up"),
                    "`up` goes with `normal`, not with `rotate`",
                ));
            }
            let r = cx.angles(&format!("{key}.rotate"), r)?;
            Ok(rotation_from_yaw_pitch_roll(r))
        }
        (Some(n), None) => {
            let z = cx.direction(&format!("{key}.normal"), n)?;
            let up = match d.up {
                Some(u) => cx.direction(&format!("{key}.up"), u)?,
                None if z.y.abs() > VERTICAL_NORMAL_COS => Vec3::from(DEFAULT_AREA_UP_VERTICAL),
                None => Vec3::from(DEFAULT_AREA_UP),
            };
            if up.cross(z).length() < MIN_UP_SINE {
                return Err(cx.err(
                    &format!("{key}.up"),
                    format!("degenerate orientation: up {up} is parallel to the normal {z}"),
                ));
            }
            let y = (up - z * up.dot(z)).normalize();
            Ok(Mat3::from_cols(y.cross(z), y, z))
        }
    }
}

pub(crate) fn area_light(
    cx: Ctx,
    key: &str,
    d: &AreaLightDesc,
    resolve: impl Fn(&str) -> std::path::PathBuf,
    warnings: &mut Vec<String>,
) -> Result<AreaLight, SceneError> {
    let center = cx.vec3(&format!("{key}.center"), d.center)?;
    let size = cx.size2(&format!("{key}.size"), d.size)?;
    let world_from_light = orientation(cx, key, d)?;
    let intensity = cx.emission(&format!("{key}.intensity"), d.intensity.0)?;
    let texture = match &d.texture {
        Some(t) => {
            let k = format!("{key}.texture");
            let path = resolve(t);
            let (tex, w) =
                load_texture(Path::new(&path)).map_err(|source| SceneError::Texture {
                    context: cx.context(&k),
                    source,
                })?;
            warnings.extend(w);
            Some(Arc::new(tex))
        }
        None => None,
    };
    let (texture, light_field) = match &d.light_field {
        None => (texture, None),
        Some(lf) => {
            let field = light_field(cx, key, lf, texture, &resolve, warnings)?;
            (None, Some(Arc::new(field)))
        }
    };
    Ok(AreaLight {
        center,
        size,
        world_from_light,
        intensity,
        texture,
        light_field,
    })
}

/// `[area_light.light_field]`: tiles read from a file, or a built-in field
/// over the light's `texture` (white without one).
fn light_field(
    cx: Ctx,
    key: &str,
    d: &LightFieldDesc,
    texture: Option<Arc<Texture>>,
    resolve: &impl Fn(&str) -> std::path::PathBuf,
    warnings: &mut Vec<String>,
) -> Result<LightField, SceneError> {
    let k = format!("{key}.light_field");
    let extent = cx.positive(&format!("{k}.extent"), d.extent)?;
    if !(1..=64).contains(&d.views) {
        return Err(cx.err(
            &format!("{k}.views"),
            format!("must be 1…64 views per axis (got {})", d.views),
        ));
    }
    match (&d.tiles, &d.builtin) {
        (Some(tiles), None) => {
            if texture.is_some() {
                return Err(cx.err(
                    &format!("{key}.texture"),
                    "a light with `light_field.tiles` takes its radiance from the tiles; drop `texture`",
                ));
            }
            let tk = format!("{k}.tiles");
            let path = resolve(tiles);
            let (image, w) =
                load_texture(Path::new(&path)).map_err(|source| SceneError::Texture {
                    context: cx.context(&tk),
                    source,
                })?;
            warnings.extend(w);
            LightField::from_tiles(&image, d.views, extent).map_err(|e| cx.err(&tk, e))
        }
        (None, Some(name)) if name == "prism" => {
            let base = match texture {
                Some(t) => (*t).clone(),
                None => Texture::constant(Vec3::ONE).expect("white is a valid texel"),
            };
            Ok(LightField::prism(&base, d.views, extent))
        }
        (None, Some(name)) => Err(cx.err(
            &format!("{k}.builtin"),
            format!(
                "unknown built-in light field `{name}` (built-ins: {})",
                LIGHT_FIELD_BUILTINS.join(", ")
            ),
        )),
        _ => Err(cx.err(
            &k,
            "give exactly one of `tiles` (an image of views × views tiles) and `builtin`",
        )),
    }
}

pub(crate) fn medium(cx: Ctx, d: &MediumDesc) -> Result<Medium, SceneError> {
    let beta = cx.non_negative("medium.beta", d.beta)?;
    let albedo = cx.finite("medium.albedo", d.albedo.unwrap_or(DEFAULT_MEDIUM_ALBEDO))?;
    if !(0.0..=1.0).contains(&albedo) {
        return Err(cx.err(
            "medium.albedo",
            format!("must lie in [0, 1] (got {albedo})"),
        ));
    }
    let radius = cx.positive("medium.radius", d.radius.unwrap_or(DEFAULT_MEDIUM_RADIUS))?;
    Ok(Medium {
        beta,
        albedo,
        radius,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::file::Rgb;

    fn desc(
        normal: Option<[f32; 3]>,
        up: Option<[f32; 3]>,
        rotate: Option<[f32; 3]>,
    ) -> AreaLightDesc {
        AreaLightDesc {
            center: [0.0; 3],
            size: [1.0, 1.0],
            normal,
            up,
            rotate,
            intensity: Rgb([1.0; 3]),
            texture: None,
            light_field: None,
        }
    }

    /// The frame is a proper rotation with ẑ = normal and ŷ towards `up`,
    /// and `rotate = [0, 90, 0]` gives the same down-facing light as
    /// `normal = [0, -1, 0]` with the default up (checked both ways).
    #[test]
    fn orientation_is_a_rotation_with_the_normal_on_z() {
        let cx = Ctx {
            file: Path::new("t.toml"),
        };
        for (n, up) in [
            ([0.3, -0.2, 0.9], None),
            ([0.0, -1.0, 0.0], None),
            ([1.0, 0.0, 0.0], Some([0.0, 1.0, 1.0])),
        ] {
            let m = orientation(cx, "area_light[1]", &desc(Some(n), up, None)).unwrap();
            assert!((m.determinant() - 1.0).abs() < 1e-5);
            assert!((m.transpose() * m - Mat3::IDENTITY).abs_diff_eq(Mat3::ZERO, 1e-5));
            assert!((m.z_axis - Vec3::from(n).normalize()).length() < 1e-6);
            let u = Vec3::from(up.unwrap_or(if n[1].abs() > 0.99 {
                DEFAULT_AREA_UP_VERTICAL
            } else {
                DEFAULT_AREA_UP
            }));
            assert!(m.y_axis.dot(u) > 0.0 && m.x_axis.dot(u).abs() < 1e-6);
        }
        let a = orientation(cx, "k", &desc(Some([0.0, -1.0, 0.0]), None, None)).unwrap();
        let b = orientation(cx, "k", &desc(None, None, Some([0.0, 90.0, 0.0]))).unwrap();
        assert!((b.z_axis - Vec3::NEG_Y).length() < 1e-6, "{}", b.z_axis);
        assert!(a.abs_diff_eq(b, 1e-6), "{a} vs {b}");
    }
}
