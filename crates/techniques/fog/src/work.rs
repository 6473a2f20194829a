//! The arithmetic of one fog frame, counted from the kernels' own loops
//! ([`relight_render::method::Relighter::frame_work`], for `relight bench
//! frames`). As there, every f32 lane operation counts one (a multiply-add,
//! a compare, a blend, a square root or a division alike; the divisions
//! cost the machine 4–8 FMA slots each, so the count is a lower bound of
//! the time the work needs at the FMA rate).
//!
//! # Per (sample, light) evaluation of the AVX2 kernel (`simd::surface_run`)
//! Counted per eight lanes from its source, then per lane:
//! * geometry (light vector, distances, e^{−T_sp}, the ray's offset and
//!   distance h, u, w): ≈ 60;
//! * the eye's tail from its table (half angle, `atan`, coordinate,
//!   interpolation): ≈ 56;
//! * the surface point's tail (half angle, `atan`, corner and tail taps,
//!   the N · q · R product): ≈ 105;
//! * the airlight difference and its test: ≈ 7;
//! * the surface terms (two G lookups, the Phong power by `log2`/`exp2`,
//!   the diffuse and specular sums, three channels added): ≈ 165.
//!
//! ≈ 393 per eight lanes: [`SURFACE_EVAL_OPS`] per lane. A sample of the
//! fog ball's edge behind an empty pixel runs the first four parts only
//! ([`EDGE_EVAL_OPS`]), and so does each sample's entry into the ball
//! when the eye is outside it ([`crate::view_segment`]); the pixels where
//! the two tails cancel add the 6-point segment quadrature (≈ 250 per
//! eight lanes), which depends on the view and is not counted.
//!
//! # The environment part ([`crate::env_vertex`])
//! Per visible vertex side: the transfer lookup and window (2 N² per
//! channel), the ZYZ rotation ([`relight_sh::rotation::ZyzRotation`]: three
//! Z rotations of 2 n² + 4 n and two fixed X matrices of `x_nonzeros` each)
//! and three dot products (3 N²), N² = n². Per covered sample: the
//! interpolated radiance and position (18), the distance and direction (9),
//! the chord (≈ 22), two bilinear reads of the chord table (24), e^{−βD}
//! (12) and the blend (9): [`ENV_SAMPLE_OPS`]. Per shaded empty sample: the
//! lat-long lookup (≈ 40) and, in a medium, the chord's weights (≈ 46) and
//! the filtered SH part (the basis, ≈ 2 N², and three dot products).

/// Lane operations of one (covered sample, light) evaluation (module docs).
pub const SURFACE_EVAL_OPS: f64 = 49.0;
/// Lane operations of one (ball-edge sample, light) airlight evaluation.
pub const EDGE_EVAL_OPS: f64 = 29.0;
/// Lane operations of the environment pass per covered sample.
pub const ENV_SAMPLE_OPS: f64 = 94.0;
/// Lane operations of a lat-long environment lookup.
const ENV_LOOKUP_OPS: f64 = 40.0;
/// Lane operations of an empty sample's chord weights in a medium.
const CHORD_OPS: f64 = 46.0;

/// What one frame shades, for [`frame_ops`].
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameCounts {
    /// Samples an object covers.
    pub covered: usize,
    /// Empty samples the point-light pass shades (the ball's edge; 0
    /// without a medium).
    pub edge: usize,
    /// Samples whose medium starts at the ball's entry (the eye outside
    /// it): one more airlight evaluation each.
    pub entries: usize,
    /// Empty samples the environment pass shades.
    pub background: usize,
    /// Point lights.
    pub lights: usize,
    /// Visible vertex sides shaded by the environment part.
    pub vertex_sides: usize,
    /// SH order of the environment part (0: no environment part).
    pub env_order: usize,
    /// Non-zeros of one fixed X matrix of the ZYZ rotation at `env_order`.
    pub x_nonzeros: usize,
    /// Whether the background adds the medium's filtered SH part.
    pub filtered_background: bool,
}

/// The frame's lane operations (module docs).
#[must_use]
pub fn frame_ops(c: &FrameCounts) -> f64 {
    let l = c.lights as f64;
    let lights =
        c.covered as f64 * l * SURFACE_EVAL_OPS + (c.edge + c.entries) as f64 * l * EDGE_EVAL_OPS;
    if c.env_order == 0 {
        return lights;
    }
    let n = c.env_order as f64;
    let nn = n * n;
    let rotation = 3.0 * (2.0 * nn + 4.0 * n) + 2.0 * c.x_nonzeros as f64;
    let side = 2.0 * nn + rotation + 3.0 * nn;
    let background = ENV_LOOKUP_OPS
        + if c.filtered_background {
            CHORD_OPS + 2.0 * nn + 3.0 * nn
        } else {
            0.0
        };
    lights
        + c.vertex_sides as f64 * side
        + c.covered as f64 * ENV_SAMPLE_OPS
        + c.background as f64 * background
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The count adds the parts it names: doubling the lights doubles the
    /// point-light part only; no environment part, no environment count.
    #[test]
    fn frame_ops_adds_its_parts() {
        let base = FrameCounts {
            covered: 1000,
            edge: 100,
            entries: 30,
            background: 200,
            lights: 2,
            vertex_sides: 50,
            env_order: 6,
            x_nonzeros: 100,
            filtered_background: true,
        };
        let lights = 1000.0 * 2.0 * SURFACE_EVAL_OPS + 130.0 * 2.0 * EDGE_EVAL_OPS;
        let twice = FrameCounts { lights: 4, ..base };
        assert!((frame_ops(&twice) - frame_ops(&base) - lights).abs() < 1e-6);
        let no_env = FrameCounts {
            env_order: 0,
            ..base
        };
        assert!((frame_ops(&no_env) - lights).abs() < 1e-6);
        let side = 2.0 * 36.0 + 3.0 * (72.0 + 24.0) + 200.0 + 3.0 * 36.0;
        let env = 50.0 * side + 1000.0 * ENV_SAMPLE_OPS + 200.0 * (40.0 + 46.0 + 5.0 * 36.0);
        assert!((frame_ops(&base) - lights - env).abs() < 1e-6);
    }
}
