//! [`EnvMap`]: RGB radiance (or any spherical RGB function) stored on a [`Param`].
//!
//! # Operations
//!
//! | operation | definition |
//! |---|---|
//! | [`EnvMap::eval`] | `L(d) = Σ_k w_k L_{t_k}` with the seam-aware bilinear footprint [`Param::bilinear`] |
//! | [`EnvMap::integral`] | `∫ L dω ≈ Σ_i L_i Ω_i` with the exact texel solid angles `Ω_i` |
//! | [`EnvMap::resample`] | `L'_j = Σ_s Ω_{j,s} L(d_{j,s}) / Σ_s Ω_{j,s}` over `ss²` uv cells `s` of target texel `j` |
//! | [`EnvMap::rotated`] | the same with `L(R⁻¹ d_{j,s})` (`R = world_from_old`) |
//!
//! # Why resampling weights by exact cell solid angles
//!
//! A target texel is the *mean* of the radiance over its solid angle. Splitting
//! it into `ss × ss` equal uv cells and weighting each cell's bilinear lookup by
//! the cell's exact solid angle (not by the texel-centre Jacobian, and not one
//! point sample per texel) makes the estimate converge to that mean as `ss`
//! grows, keeps constants exactly constant (the weights are normalised), and
//! preserves `∫ L dω` up to the bilinear filtering of the source. Choose `ss` so
//! that a cell is no larger than a source texel (e.g. `ss = ⌈2 · source
//! resolution / target resolution⌉`); the cost is `ss²` lookups per target
//! texel, parallel over target rows.

use crate::param::Param;
use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

/// Largest radiance (or emitted intensity) relight takes as it is: far above
/// any measured radiance (an unclipped sun in an HDR probe is ~10⁵–10⁸), and
/// small enough that a sum over 2²⁶ texels and its square stay finite in f32
/// (10¹² · 2²⁶ ≈ 7·10¹⁹; its square 10²⁴ per sample). Image loaders clamp
/// texels above it with a warning; scene files refuse light intensities
/// above it.
pub const MAX_RADIANCE: f32 = 1e12;

/// An RGB function on the sphere, one linear `Vec3` per texel of `param`.
///
/// Radiance units are whatever the source file used (relight treats them as
/// W·sr⁻¹·m⁻² up to a constant).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// The texel layout.
    pub param: Param,
    /// `param.len()` texels in texel order.
    pub texels: Vec<Vec3>,
}

impl EnvMap {
    /// A map from texels; `None` when the count does not match `param` or
    /// `param` is invalid ([`Param::validate`]: a zero size).
    #[must_use]
    pub fn try_new(param: Param, texels: Vec<Vec3>) -> Option<Self> {
        (param.validate().is_ok() && texels.len() == param.len()).then_some(Self { param, texels })
    }

    /// The all-zero map (a scene lit by its lights alone; the scene files'
    /// `builtin = "black"`), on an 8 × 4 lat-long grid (any size holds zero
    /// exactly; this one is the verify scenes' since they began).
    #[must_use]
    pub fn black() -> Self {
        let param = Param::LatLong {
            width: 8,
            height: 4,
        };
        Self {
            param,
            texels: vec![Vec3::ZERO; param.len()],
        }
    }

    /// Whether every texel is `+0.0` in every channel ([`EnvMap::black`], a
    /// scene lit by its lights alone). Every lookup of such a map returns
    /// exactly `+0.0` (bilinear weights are non-negative), so a caller may
    /// skip its lookups bit for bit. Per frame, so cheap for a real map: the
    /// last and middle texels (the nadir and the horizon of a lat-long map,
    /// where a map with a black sky is lit) are read first, and the scan
    /// stops at the first other texel.
    #[must_use]
    pub fn is_black(&self) -> bool {
        let zero = |t: &Vec3| t.to_array().iter().all(|v| v.to_bits() == 0);
        let n = self.texels.len();
        [n.saturating_sub(1), n / 2]
            .iter()
            .filter_map(|&i| self.texels.get(i))
            .all(zero)
            && self.texels.iter().all(zero)
    }

    /// A 64-bit fingerprint of the map's parameterization and every texel's
    /// bits (FNV-1a over 32-bit words, in six interleaved streams folded at
    /// the end, with the texel count: one stream was a chain of dependent
    /// multiplies, ≈ 0.6 ms per lighting change of the default scene):
    /// equal maps give equal fingerprints. Methods key what they derive
    /// from a map (its SH projection) on it, so a lighting change that only
    /// turns the map or moves a light derives nothing again.
    #[must_use]
    pub fn fingerprint(&self) -> u64 {
        const PRIME: u64 = 0x0000_0100_0000_01b3;
        const BASIS: u64 = 0xcbf2_9ce4_8422_2325;
        let fnv = |h: u64, w: u64| (h ^ w).wrapping_mul(PRIME);
        let mut h = BASIS;
        for b in format!("{:?}", self.param).bytes() {
            h = fnv(h, u64::from(b));
        }
        // Two texels (six words) per step, one stream per word.
        let mut lanes = [BASIS; 6];
        let pairs = self.texels.chunks_exact(2);
        let rest = pairs.remainder();
        let word = |t: &Vec3, k: usize| u64::from(t[k].to_bits());
        for p in pairs {
            for (k, l) in lanes.iter_mut().enumerate() {
                *l = fnv(*l, word(&p[k / 3], k % 3));
            }
        }
        for t in rest {
            for (k, l) in lanes.iter_mut().take(3).enumerate() {
                *l = fnv(*l, word(t, k));
            }
        }
        lanes
            .iter()
            .fold(fnv(h, self.texels.len() as u64), |h, &l| fnv(h, l))
    }

    /// The map with every texel `f(direction)`.
    #[must_use]
    pub fn from_fn(param: Param, f: impl Fn(Vec3) -> Vec3 + Sync) -> Self {
        let texels = (0..param.len())
            .into_par_iter()
            .map(|i| f(param.dir_from_texel(i)))
            .collect();
        Self { param, texels }
    }

    /// Bilinearly interpolated value in direction `d`.
    #[must_use]
    pub fn eval(&self, d: Vec3) -> Vec3 {
        let b = self.param.bilinear(d);
        (0..4)
            .map(|k| self.texels[b.texels[k] as usize] * b.weights[k])
            .sum()
    }

    /// Area-correct resampling onto another parameterization: each target
    /// texel is the solid-angle-weighted mean of `supersample²` bilinear
    /// lookups spread over the target texel.
    ///
    /// The target texel is split into `supersample × supersample` equal uv
    /// cells; each cell contributes the bilinear lookup at its centre weighted
    /// by the cell's *exact* solid angle ([`Param::uv_rect_solid_angle`]). A
    /// constant map therefore stays exactly constant and `∫ L dω` is preserved
    /// up to the filtering error. `supersample = 0` is treated as 1. Parallel
    /// over target rows (rayon).
    #[must_use]
    pub fn resample(&self, target: Param, supersample: usize) -> EnvMap {
        self.resample_with(target, supersample, |d| d)
    }

    /// ∫ L dω per channel (sum of texel × exact solid angle), f64.
    #[must_use]
    pub fn integral_f64(&self) -> DVec3 {
        self.texels
            .iter()
            .enumerate()
            .map(|(i, t)| t.as_dvec3() * self.param.texel_solid_angle(i))
            .sum()
    }

    /// ∫ L dω per channel (sum of texel × exact solid angle).
    #[must_use]
    pub fn integral(&self) -> Vec3 {
        self.integral_f64().as_vec3()
    }

    /// The map rotated: `out(d) = self(rot⁻¹ d)` (a rotation `world_from_old` of the lighting).
    ///
    /// Same parameterization as `self`, resampled area-correctly like
    /// [`EnvMap::resample`]. `world_from_old` must be a rotation (orthonormal).
    #[must_use]
    pub fn rotated(&self, world_from_old: glam::Mat3, supersample: usize) -> EnvMap {
        let old_from_world = world_from_old.as_dmat3().transpose();
        self.resample_with(self.param, supersample, move |d| old_from_world * d)
    }

    /// Bilinear lookup in f64 (weights renormalised).
    #[must_use]
    pub fn eval_f64(&self, d: DVec3) -> DVec3 {
        let b = self.param.bilinear_f64(d);
        let mut acc = DVec3::ZERO;
        let mut wsum = 0.0;
        for k in 0..4 {
            acc += self.texels[b.texels[k]].as_dvec3() * b.weights[k];
            wsum += b.weights[k];
        }
        acc / wsum
    }

    /// Resampling core: target texel = solid-angle-weighted mean over
    /// `ss²` cells of `self` looked up at `src_from_target(d)`.
    fn resample_with(
        &self,
        target: Param,
        supersample: usize,
        src_from_target: impl Fn(DVec3) -> DVec3 + Sync,
    ) -> EnvMap {
        let ss = supersample.max(1);
        let w = target.width();
        let mut texels = vec![Vec3::ZERO; target.len()];
        texels
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(row, out)| {
                for (col, o) in out.iter_mut().enumerate() {
                    let i = row * w + col;
                    let (lo, hi) = target.texel_uv_rect(i);
                    let step = (hi - lo) / ss as f64;
                    let mut acc = DVec3::ZERO;
                    let mut wsum = 0.0;
                    for sy in 0..ss {
                        for sx in 0..ss {
                            let a = lo + step * DVec2::new(sx as f64, sy as f64);
                            let b = lo + step * DVec2::new((sx + 1) as f64, (sy + 1) as f64);
                            let omega = if ss == 1 {
                                target.texel_solid_angle(i)
                            } else {
                                target.uv_rect_solid_angle(a, b)
                            };
                            let d = src_from_target(target.dir_from_uv(0.5 * (a + b)));
                            let bl = self.param.bilinear_f64(d);
                            for k in 0..4 {
                                let wk = omega * bl.weights[k];
                                acc += self.texels[bl.texels[k]].as_dvec3() * wk;
                                wsum += wk;
                            }
                        }
                    }
                    *o = if wsum > 0.0 {
                        (acc / wsum).as_vec3()
                    } else {
                        Vec3::ZERO
                    };
                }
            });
        EnvMap {
            param: target,
            texels,
        }
    }
}
