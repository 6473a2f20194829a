//! The embedded studio environment: a high-dynamic-range lat-long map
//! generated in code, all-frequency on purpose.
//!
//! | feature | where (world, +Y up) | radiance (linear RGB) |
//! |---|---|---|
//! | sky gradient | upper hemisphere, horizon → zenith | (1.0, 0.95, 0.9) → (0.25, 0.4, 0.8) |
//! | ground | lower hemisphere | (0.12, 0.1, 0.08), darkening towards the nadir |
//! | sun | disc of angular radius [`SUN_RADIUS_DEG`] = 1.5° at elevation 40°, azimuth 30° | [`SUN_RADIANCE`] = (3000, 2700, 2300) |
//! | key area light | rectangle, azimuth −70°…−40°, elevation 15°…35° | (12, 12, 11) |
//! | rim area light | rectangle, azimuth 140°…165°, elevation 5°…50° | (4, 5, 9) |
//!
//! # The sun's energy
//! The disc subtends Ω = 2π(1 − cos 1.5°) = 2.153·10⁻³ sr, so it delivers
//! E⊥ = L·Ω = (6.46, 5.81, 4.95) of irradiance at normal incidence
//! ([`studio_sun_irradiance`]) and E⊥·sin 40° = (4.15, 3.74, 3.18) on the
//! floor of the default scene, against ≈ 1.5 from the whole sky: the sun is
//! the key light, and objects under it cast hard shadows (where a method
//! renders visibility). The map has a dynamic range of ~10⁴ and sharp edges,
//! the hard case for SH and the showcase of wavelets. The lighting is
//! box-filtered over each texel (4×4 supersampling) so the map has no
//! aliasing at any resolution; a test checks that the filtered map keeps the
//! sun's Ω·L to 2 %.

use glam::Vec3;
use relight_sphere::{EnvMap, Param};

/// Angular radius of the studio sun's disc, degrees.
pub const SUN_RADIUS_DEG: f32 = 1.5;

/// Radiance of the studio sun's disc (linear RGB).
pub const SUN_RADIANCE: Vec3 = Vec3::new(3000.0, 2700.0, 2300.0);

/// Irradiance the studio sun delivers at normal incidence, `L·Ω` with
/// `Ω = 2π(1 − cos r)` the disc's solid angle (linear RGB).
#[must_use]
pub fn studio_sun_irradiance() -> Vec3 {
    let omega = std::f32::consts::TAU * (1.0 - SUN_RADIUS_DEG.to_radians().cos());
    SUN_RADIANCE * omega
}

/// Sun direction of the studio environment (unit, world).
#[must_use]
pub fn studio_sun_direction() -> Vec3 {
    dir_from_az_el(30f32.to_radians(), 40f32.to_radians())
}

/// World direction from azimuth (radians, from +X towards +Z... see
/// [`az_el_from_dir`]) and elevation above the horizon (radians).
fn dir_from_az_el(az: f32, el: f32) -> Vec3 {
    Vec3::new(el.cos() * az.cos(), el.sin(), el.cos() * az.sin())
}

/// Azimuth in (−π, π] (atan2(z, x)) and elevation in [−π/2, π/2] of a unit direction.
fn az_el_from_dir(d: Vec3) -> (f32, f32) {
    (d.z.atan2(d.x), d.y.clamp(-1.0, 1.0).asin())
}

/// Radiance of the studio environment in the unit direction `d` (no filtering).
#[must_use]
pub fn studio_radiance(d: Vec3) -> Vec3 {
    let (az, el) = az_el_from_dir(d);
    let sun = studio_sun_direction();
    let sun_cos = SUN_RADIUS_DEG.to_radians().cos();
    if d.dot(sun) >= sun_cos {
        return SUN_RADIANCE;
    }
    let deg = |x: f32| x.to_radians();
    let in_rect = |az0: f32, az1: f32, el0: f32, el1: f32| {
        az >= deg(az0) && az <= deg(az1) && el >= deg(el0) && el <= deg(el1)
    };
    if in_rect(-70.0, -40.0, 15.0, 35.0) {
        return Vec3::new(12.0, 12.0, 11.0);
    }
    if in_rect(140.0, 165.0, 5.0, 50.0) {
        return Vec3::new(4.0, 5.0, 9.0);
    }
    if el >= 0.0 {
        let t = (el / deg(90.0)).powf(0.6);
        Vec3::new(1.0, 0.95, 0.9).lerp(Vec3::new(0.25, 0.4, 0.8), t)
    } else {
        let t = (-el / deg(90.0)).sqrt();
        Vec3::new(0.12, 0.1, 0.08).lerp(Vec3::new(0.05, 0.045, 0.04), t)
    }
}

/// The studio environment as a `2h × h` lat-long map, each texel the
/// solid-angle mean of 4×4 samples of [`studio_radiance`].
#[must_use]
pub fn studio_environment(height: usize) -> EnvMap {
    let param = Param::LatLong {
        width: 2 * height,
        height,
    };
    let ss = 4usize;
    let texels = (0..param.len())
        .map(|i| {
            let (w, h) = (param.width() as f64, param.height() as f64);
            let (col, row) = ((i % param.width()) as f64, (i / param.width()) as f64);
            let mut sum = Vec3::ZERO;
            let mut wsum = 0.0f32;
            for sy in 0..ss {
                for sx in 0..ss {
                    let uv = glam::DVec2::new(
                        (col + (sx as f64 + 0.5) / ss as f64) / w,
                        (row + (sy as f64 + 0.5) / ss as f64) / h,
                    );
                    let d = param.dir_from_uv(uv).as_vec3();
                    // Lat-long texel area density ∝ sin θ = sqrt(1 − y²).
                    let weight = (1.0 - d.y * d.y).max(0.0).sqrt();
                    sum += studio_radiance(d) * weight;
                    wsum += weight;
                }
            }
            if wsum > 0.0 {
                sum / wsum
            } else {
                studio_radiance(param.dir_from_texel(i))
            }
        })
        .collect();
    EnvMap { param, texels }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_filtered_map_keeps_the_suns_energy() {
        let e = studio_sun_irradiance();
        assert!((e.x - 6.46).abs() < 0.01, "{e}");
        let env = studio_environment(crate::STUDIO_HEIGHT);
        let sun = studio_sun_direction();
        // Texels within 4° of the sun: the disc, its filtered rim, and a
        // sliver of sky (≈ 1 × 0.015 sr, under 0.3 % of the sun's 6.46).
        let near = (4.0f32).to_radians().cos();
        let mut sum = Vec3::ZERO;
        for (i, t) in env.texels.iter().enumerate() {
            if env.param.dir_from_texel(i).dot(sun) >= near {
                sum += *t * env.param.texel_solid_angle(i) as f32;
            }
        }
        let rel = (sum - e).abs() / e;
        assert!(rel.max_element() < 0.02, "map {sum} vs disc {e}");
    }
}
