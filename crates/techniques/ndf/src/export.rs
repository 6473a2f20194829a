//! The engine bake behind `relight ndf bake` (no IO here): a MIP chain of
//! unit normals plus one roughness (or exponent) per texel that folds the
//! texel's normal spread into the BRDF, the optional vMF lobe chain, and
//! each level's error against the texel-level ground truth.
//!
//! # The single-lobe chain
//! Texel `t` of level `k` has mean normal `m` (the box average of its fine
//! normals, [`crate::MeanPyramid`]). Its normal is `m/|m|`; its spread is the
//! one vMF lobe of that mean, `κ = A⁻¹(|m|)` ([`crate::vmf::kappa_from_resultant`],
//! the exact inverse rather than Toksvig's `|m|/(1 − |m|)`), folded into the
//! BRDF as in [`crate::effective`]: `α′ = √(α² + 2/κ)` for GGX and Beckmann,
//! `s′ = κ s/(κ + s)` for Blinn–Phong. Level 0 has `|m| = 1`, κ at the clamp,
//! so `α′ = α` (plain normal mapping).
//!
//! # The multi-lobe chain
//! The [`VmfPyramid`]'s packed lobes `(α, α A(κ) μ)`, `J` per texel, as they
//! are stored: filtering them linearly is the moment-matching merge.

use crate::effective::{Baseline, NdfBrdf, shade_baseline, shade_lobe, shade_mixture};
use crate::lean::{LeanTexel, shade_lean};
use crate::pyramid::{ShadeLobe, VmfPyramid, unpack};
use crate::sh_ndf::level_size;
use crate::verify::{directions, footprint_normals};
use crate::vmf::{KAPPA_MAX, kappa_from_resultant, mean_resultant};
use crate::{Linear, MeanPyramid, NdfError};
use glam::Vec3;
use relight_render::NormalMap;
use serde::Serialize;

/// One level of the single-lobe chain.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineLevel {
    pub width: usize,
    pub height: usize,
    /// Unit tangent-space normals (+Y green up), row-major.
    pub normals: Vec<Vec3>,
    /// `α′` (GGX, Beckmann: linear roughness, not the perceptual `√α′`) or
    /// the exponent `s′` (Blinn–Phong), per texel.
    pub roughness: Vec<f32>,
}

/// The whole bake.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineChain {
    pub brdf: NdfBrdf,
    /// Level 0 (the map's size) first, down to 1 × 1.
    pub levels: Vec<EngineLevel>,
    /// The vMF lobe chain, when asked for.
    pub vmf: Option<VmfPyramid>,
}

/// `1/κ` of the one lobe whose mean resultant is `r` (0 at the clamp).
#[must_use]
pub fn inv_kappa_of_resultant(r: f32) -> f32 {
    if f64::from(r) >= mean_resultant(KAPPA_MAX) {
        return 0.0;
    }
    (1.0 / kappa_from_resultant(f64::from(r))) as f32
}

/// The BRDF with its lobe widened by `1/κ` (module docs), as an engine
/// shades it: `ggx:α′`, `beckmann:α′` or `blinn:s′`.
#[must_use]
pub fn widened(brdf: NdfBrdf, inv_kappa: f32) -> NdfBrdf {
    match brdf {
        NdfBrdf::Lambert => NdfBrdf::Lambert,
        NdfBrdf::Blinn { s } => NdfBrdf::Blinn {
            s: s / (1.0 + s * inv_kappa),
        },
        NdfBrdf::Ggx { alpha } => NdfBrdf::Ggx {
            alpha: (alpha * alpha + 2.0 * inv_kappa).sqrt(),
        },
        NdfBrdf::Beckmann { alpha } => NdfBrdf::Beckmann {
            alpha: (alpha * alpha + 2.0 * inv_kappa).sqrt(),
        },
    }
}

/// The gain an engine's *normalized* Blinn–Phong of exponent `s′` needs to
/// equal the widened lobe: the convolution keeps the amplitude `(s′/s)·c(s)`
/// ([`crate::effective::shade_lobe`]), a normalized lobe has `c(s′)`, so the
/// gain is `(s′/s) c(s) / c(s′)` (≈ `s′/(s′ + 6)` for large `s`; 1 at
/// level 0). Without it a widened lobe is too bright by `1/gain`.
#[must_use]
pub fn blinn_gain(s: f32, s_prime: f32) -> f32 {
    use relight_brdf::phong::blinn_phong_normalization as c;
    (s_prime / s) * c(s) / c(s_prime)
}

/// The map's value of a widened BRDF (`α′` or `s′`).
fn parameter(b: NdfBrdf) -> f32 {
    match b {
        NdfBrdf::Lambert => 0.0,
        NdfBrdf::Blinn { s } => s,
        NdfBrdf::Ggx { alpha } | NdfBrdf::Beckmann { alpha } => alpha,
    }
}

/// The BRDF an engine shades at a texel with stored `parameter` `p`.
#[must_use]
pub fn with_parameter(brdf: NdfBrdf, p: f32) -> NdfBrdf {
    match brdf {
        NdfBrdf::Lambert => NdfBrdf::Lambert,
        NdfBrdf::Blinn { .. } => NdfBrdf::Blinn { s: p },
        NdfBrdf::Ggx { .. } => NdfBrdf::Ggx { alpha: p },
        NdfBrdf::Beckmann { .. } => NdfBrdf::Beckmann { alpha: p },
    }
}

impl EngineChain {
    /// Bakes the chain of `map` for a glossy `brdf` (Lambert has no lobe to
    /// widen), with `vmf` the lobe chain if wanted.
    ///
    /// # Errors
    /// Lambert.
    pub fn bake(map: &NormalMap, brdf: NdfBrdf, vmf: Option<VmfPyramid>) -> Result<Self, NdfError> {
        if brdf == NdfBrdf::Lambert {
            return Err(NdfError::InvalidParameter {
                what: "brdf",
                why: "the engine bake widens a glossy lobe: give ggx:α, beckmann:α or blinn:s"
                    .into(),
            });
        }
        let mean = MeanPyramid::build(map.width, map.height, &map.texels);
        let levels = mean
            .levels
            .iter()
            .map(|(w, h, m)| EngineLevel {
                width: *w,
                height: *h,
                normals: m.iter().map(|v| v.normalize_or(Vec3::Z)).collect(),
                roughness: m
                    .iter()
                    .map(|v| parameter(widened(brdf, inv_kappa_of_resultant(v.length()))))
                    .collect(),
            })
            .collect();
        Ok(Self { brdf, levels, vmf })
    }
}

/// One level's errors against exact shading over the fine normals.
#[derive(Clone, Debug, Serialize)]
pub struct LevelError {
    pub level: usize,
    pub width: usize,
    pub height: usize,
    /// Texels sampled.
    pub texels: usize,
    /// Relative RMS of the single-lobe chain (normal + roughness).
    pub single_lobe: f64,
    /// The same for the vMF lobe chain, when baked.
    pub vmf: Option<f64>,
    /// Baselines beside: the normalized mean normal at the BRDF's own
    /// roughness, Toksvig and LEAN.
    pub normalized_mip: f64,
    pub toksvig: f64,
    /// LEAN mapping (the 5 moments of the footprint, [`crate::lean`]).
    pub lean: f64,
}

/// Each level's relative RMS error against the ground truth (exact shading
/// averaged over the fine texels under the texel, 8 light × 8 view
/// directions at elevations 15°–75°), on up to `texels_per_level` texels
/// spread over the level. The single-lobe chain is shaded as an engine
/// would: the BRDF at the stored normal with the stored roughness (Blinn
/// times [`blinn_gain`]).
#[must_use]
pub fn level_errors(
    map: &NormalMap,
    chain: &EngineChain,
    texels_per_level: usize,
) -> Vec<LevelError> {
    let lights = directions(0.2);
    let views = directions(1.7);
    let brdf = chain.brdf;
    chain
        .levels
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let count = l.width * l.height;
            let t = texels_per_level.clamp(1, count);
            let mut acc = [[0.0f64; 2]; 5];
            for s in 0..t {
                let ti = s * count / t + (count / t) / 2;
                let (x, y) = (ti % l.width, ti / l.width);
                let (fine, wts) = footprint_normals(map, k, x, y);
                let total: f32 = wts.iter().sum();
                let m: Vec3 = fine.iter().zip(&wts).map(|(n, w)| *n * *w).sum::<Vec3>() / total;
                let lean = fine.iter().zip(&wts).fold(LeanTexel::ZERO, |a, (n, w)| {
                    a.add_scaled(*w / total, LeanTexel::of_normal(*n))
                });
                let n = l.normals[ti];
                let engine = with_parameter(brdf, l.roughness[ti]);
                let lobes: Vec<ShadeLobe> = chain
                    .vmf
                    .as_ref()
                    .map(|v| v.texel(k, x, y).iter().filter_map(|p| unpack(*p)).collect())
                    .unwrap_or_default();
                for wi in lights {
                    for wo in views {
                        let truth = fine
                            .iter()
                            .zip(&wts)
                            .map(|(f, w)| w * shade_lobe(brdf, *f, 0.0, wo, wi))
                            .sum::<f32>()
                            / total;
                        let gain = match (brdf, engine) {
                            (NdfBrdf::Blinn { s }, NdfBrdf::Blinn { s: sp }) => blinn_gain(s, sp),
                            _ => 1.0,
                        };
                        let reps = [
                            gain * shade_lobe(engine, n, 0.0, wo, wi),
                            shade_mixture(brdf, &lobes, wo, wi),
                            shade_baseline(brdf, Baseline::Normalized, m, wo, wi),
                            shade_baseline(brdf, Baseline::Toksvig, m, wo, wi),
                            shade_lean(brdf, &lean, wo, wi),
                        ];
                        for (a, r) in acc.iter_mut().zip(reps) {
                            a[0] += f64::from((r - truth).powi(2));
                            a[1] += f64::from(truth * truth);
                        }
                    }
                }
            }
            let err = |i: usize| (acc[i][0] / acc[i][1].max(1e-300)).sqrt();
            let (width, height) = level_size(chain.levels[0].width, chain.levels[0].height, k);
            LevelError {
                level: k,
                width,
                height,
                texels: t,
                single_lobe: err(0),
                vmf: chain.vmf.as_ref().map(|_| err(1)),
                normalized_mip: err(2),
                toksvig: err(3),
                lean: err(4),
            }
        })
        .collect()
}
