//! [`crate::mask::seen_sh9`]'s two steps for [`LANES`] NDFs at once: the
//! environment light's view mask of an SH NDF, the part of a pixel's frame
//! that cost the most (about 30 % of an SH Lambert frame, one pixel at a
//! time, in scalar code between table lookups).
//!
//! [`seen_moments_lanes`] takes each NDF's moments and its seen part's
//! moments (one lane per NDF: a footprint's probes each get a lane, and the
//! method averages a pixel's probes' moments), [`sh9_of_seen_moments_lanes`]
//! turns moments into bands 0–2 (one lane per pixel). Inputs are stored by
//! coefficient (`gamma[i][lane]`), and every step is a loop over the lanes
//! with no branch and no call, which the compiler turns into 8-wide (AVX2)
//! or 2 × 4-wide (SSE2) vector code; the scalar form's early returns (a
//! delta, `|α| > 6`) become selects. Each lane computes the same f32
//! operations in the same order as [`crate::mask::ShMoments::of_sh`],
//! [`crate::mask::seen_moments`] and [`crate::mask::sh9_of_seen_moments`]
//! (the exponential is [`crate::effective::exp_neg`] in both), so a lane
//! equals the scalar form bit for bit (tested), and both copies of the
//! pixel loop give the same image.

/// Pixels per call.
pub const LANES: usize = 8;

/// One value per lane.
pub type Lanes = [f32; LANES];

/// The constants of the moments and the mask, looked up once per batch
/// (each lives behind a `OnceLock` in [`crate::mask`] and
/// [`crate::effective`]).
#[derive(Clone, Copy, Debug)]
pub struct SeenTables {
    /// Band 1 at the three axes ([`crate::effective::mean_normal_of_sh`]).
    axes: [[f32; 3]; 3],
    /// `∫ p_j y_i` for the quadratic monomials ([`ShMoments::of_sh`]).
    proj: [[f32; 9]; 6],
    /// `y_i` as a quadratic form ([`crate::mask::seen_sh9_with`]).
    quad: [[f32; 9]; 9],
}

impl SeenTables {
    /// The tables.
    #[must_use]
    pub fn get() -> Self {
        Self {
            axes: *crate::effective::band1_axes(),
            proj: *crate::mask::monomial_projections(),
            quad: *crate::mask::quadratic_forms(),
        }
    }
}

/// `v[l] = f(l)` over the lanes.
#[inline(always)]
fn lanes(f: impl Fn(usize) -> f32) -> Lanes {
    let mut v = [0.0; LANES];
    for (l, v) in v.iter_mut().enumerate() {
        *v = f(l);
    }
    v
}

/// [`crate::mask::ShMoments::of_sh`] then [`crate::mask::seen_moments`] of
/// `gamma` (bands 0–2 by coefficient: lane `l`'s NDF is `gamma[·][l]`) seen
/// from `wo` (x y z by lane, the tangent frame): the seen part's moments
/// into `e` and its share into `share`. Lanes a caller does not use may
/// hold any finite values.
#[inline(always)]
pub fn seen_moments_lanes(
    t: &SeenTables,
    gamma: &[Lanes; 9],
    wo: &[Lanes; 3],
    e: &mut [Lanes; 9],
    share: &mut Lanes,
) {
    let g = gamma;
    // `ShMoments::of_sh`: the mean from band 1, then E[n nᵀ] from bands 0, 2.
    let k = 4.0 * std::f32::consts::PI / 3.0;
    let mut m = [[0.0; LANES]; 3];
    for ((a, m), (i, j)) in t.axes.iter().zip(&mut m).zip(crate::effective::AXIS_TERMS) {
        *m = lanes(|l| g[i][l] * a[j] * k);
    }
    let pairs = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
    // `ShMoments::of_sh`'s sparse rows (`mask::PROJ_TERMS`), written out:
    // a loop over an index list kept these lanes from vectorizing.
    let p = &t.proj;
    let second = [
        lanes(|l| g[0][l] * p[0][0] + g[6][l] * p[0][6] + g[8][l] * p[0][8]),
        lanes(|l| g[0][l] * p[1][0] + g[6][l] * p[1][6] + g[8][l] * p[1][8]),
        lanes(|l| g[0][l] * p[2][0] + g[6][l] * p[2][6]),
        lanes(|l| g[4][l] * p[3][4]),
        lanes(|l| g[7][l] * p[4][7]),
        lanes(|l| g[5][l] * p[5][5]),
    ];
    let mut c = [[0.0; LANES]; 6];
    for ((c, s), &(i, j)) in c.iter_mut().zip(&second).zip(&pairs) {
        *c = lanes(|l| s[l] - m[i][l] * m[j][l]);
    }
    // `mask::seen_moments`.
    let mu = lanes(|l| m[0][l] * wo[0][l] + m[1][l] * wo[1][l] + m[2][l] * wo[2][l]);
    let cw = [
        lanes(|l| c[0][l] * wo[0][l] + c[3][l] * wo[1][l] + c[4][l] * wo[2][l]),
        lanes(|l| c[3][l] * wo[0][l] + c[1][l] * wo[1][l] + c[5][l] * wo[2][l]),
        lanes(|l| c[4][l] * wo[0][l] + c[5][l] * wo[1][l] + c[2][l] * wo[2][l]),
    ];
    let s2 = lanes(|l| wo[0][l] * cw[0][l] + wo[1][l] * cw[1][l] + wo[2][l] * cw[2][l]);
    // The scalar form's `s2 ≤ 1e-10` (a delta) and `|α| > 6` returns: the
    // whole NDF where the mean faces the viewer, nothing elsewhere (1, 0;
    // −1: neither).
    let inv_s = lanes(|l| 1.0 / s2[l].max(1e-10).sqrt());
    let alpha = lanes(|l| mu[l] * inv_s[l]);
    let whole = lanes(|l| {
        let delta = s2[l] <= 1e-10;
        let front = if delta { mu[l] > 0.0 } else { alpha[l] > 0.0 };
        if delta || alpha[l].abs() > 6.0 {
            if front { 1.0 } else { 0.0 }
        } else {
            -1.0
        }
    });
    // `effective::normal_cdf_pdf(α)` for |α| ≤ 6 (clamped: those lanes
    // take `whole`).
    let mut cdf = [0.0; LANES];
    let mut pdf = [0.0; LANES];
    for l in 0..LANES {
        (cdf[l], pdf[l]) = crate::effective::normal_cdf_pdf_within_6(alpha[l].clamp(-6.0, 6.0));
    }
    // No `array::map` or `from_fn` here: a closure they fail to inline is
    // compiled for the baseline target, outside the caller's AVX2 copy.
    let gg = [
        lanes(|l| cw[0][l] * inv_s[l]),
        lanes(|l| cw[1][l] * inv_s[l]),
        lanes(|l| cw[2][l] * inv_s[l]),
    ];
    // Values computed first, then plain `if` selects: blends, not branches.
    for (i, e) in e.iter_mut().take(3).enumerate() {
        let v = lanes(|l| m[i][l] * cdf[l] + gg[i][l] * pdf[l]);
        *e = lanes(|l| {
            let w = whole[l];
            let kept = if w > 0.5 { m[i][l] } else { 0.0 };
            if w < -0.5 { v[l] } else { kept }
        });
    }
    for (p, e) in e.iter_mut().skip(3).enumerate() {
        let (i, j) = pairs[p];
        let v = lanes(|l| {
            (c[p][l] + m[i][l] * m[j][l]) * cdf[l]
                + (m[i][l] * gg[j][l] + gg[i][l] * m[j][l]) * pdf[l]
                - gg[i][l] * gg[j][l] * alpha[l] * pdf[l]
        });
        let all = lanes(|l| c[p][l] + m[i][l] * m[j][l]);
        *e = lanes(|l| {
            let w = whole[l];
            let kept = if w > 0.5 { all[l] } else { 0.0 };
            if w < -0.5 { v[l] } else { kept }
        });
    }
    *share = lanes(|l| if whole[l] >= 0.0 { whole[l] } else { cdf[l] });
}

/// [`crate::mask::sh9_of_seen_moments`] by lanes: `y[i][l]` from `e[·][l]`.
#[inline(always)]
pub fn sh9_of_seen_moments_lanes(t: &SeenTables, e: &[Lanes; 9], y: &mut [Lanes; 9]) {
    // `mask::sh9_of_seen_moments`' sparse rows (`mask::QUAD_TERMS`),
    // written out as there.
    let q = &t.quad;
    *y = [
        lanes(|l| e[3][l] * q[0][3] + e[4][l] * q[0][4] + e[5][l] * q[0][5]),
        lanes(|l| e[1][l] * q[1][1]),
        lanes(|l| e[2][l] * q[2][2]),
        lanes(|l| e[0][l] * q[3][0]),
        lanes(|l| e[6][l] * q[4][6]),
        lanes(|l| e[8][l] * q[5][8]),
        lanes(|l| e[3][l] * q[6][3] + e[4][l] * q[6][4] + e[5][l] * q[6][5]),
        lanes(|l| e[7][l] * q[7][7]),
        lanes(|l| e[3][l] * q[8][3] + e[4][l] * q[8][4]),
    ];
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::{ShMoments, seen_moments, sh9_of_seen_moments};
    use glam::Vec3;

    /// NDFs from deltas (one normal), narrow and broad clusters, and
    /// grazing views: every branch of the scalar form.
    #[test]
    fn lanes_equal_the_scalar_form_bit_for_bit() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let t = SeenTables::get();
        let mut branches = [0usize; 3];
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for batch in 0..400 {
            let mut gamma = [[0.0; LANES]; 9];
            let mut wo = [[0.0; LANES]; 3];
            let mut scalar_in = Vec::new();
            for l in 0..LANES {
                // A cluster of `count` normals about an axis, of spread `w`.
                let axis = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() + 0.05).normalize();
                let spread = [0.0, 0.02, 0.3, 1.2][(batch + l) % 4];
                let count = if spread == 0.0 { 1 } else { 16 };
                let mut g = [0.0f32; 9];
                for _ in 0..count {
                    let n = (axis + spread * Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5))
                        .normalize_or(Vec3::Z);
                    let mut y = [0.0f32; 9];
                    relight_sh::eval_sh_into(3, n.to_array(), &mut y);
                    for (g, y) in g.iter_mut().zip(y) {
                        *g += y / count as f32;
                    }
                }
                let w = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() * 0.6).normalize_or(Vec3::Z);
                for i in 0..9 {
                    gamma[i][l] = g[i];
                }
                for i in 0..3 {
                    wo[i][l] = w[i];
                }
                scalar_in.push((g, w));
            }
            let mut e = [[0.0; LANES]; 9];
            let mut share = [0.0; LANES];
            seen_moments_lanes(&t, &gamma, &wo, &mut e, &mut share);
            let mut y = [[0.0; LANES]; 9];
            sh9_of_seen_moments_lanes(&t, &e, &mut y);
            for (l, (g, w)) in scalar_in.iter().enumerate() {
                let (se, ss) = seen_moments(&ShMoments::of_sh(g), *w);
                let le: Vec<f32> = e.iter().map(|v| v[l]).collect();
                let ly: Vec<f32> = y.iter().map(|v| v[l]).collect();
                assert_eq!(bits(&le), bits(&se), "batch {batch} lane {l}: moments");
                assert_eq!(share[l].to_bits(), ss.to_bits(), "batch {batch} lane {l}");
                let sy = sh9_of_seen_moments(&se);
                assert_eq!(bits(&ly), bits(&sy), "batch {batch} lane {l}: bands");
                let branch = if ss == 1.0 {
                    0
                } else if ss == 0.0 {
                    1
                } else {
                    2
                };
                branches[branch] += 1;
            }
        }
        assert!(
            branches.iter().all(|&b| b > 100),
            "every branch exercised: {branches:?}"
        );
    }
}
