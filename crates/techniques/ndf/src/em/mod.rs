//! Spherical EM for mixtures of vMF lobes (Banerjee, Dhillon, Ghosh & Sra
//! 2005, "soft-movMF"), on weighted unit samples.
//!
//! # Algorithm
//! With lobes `(α_j, μ_j, κ_j)` and samples `x_i` of weight `w_i`:
//! * **E-step:** `r_ij = α_j γ(x_i; μ_j, κ_j) / Σ_k α_k γ(x_i; μ_k, κ_k)`
//!   (log-sum-exp in f64, vectorized over samples: [`estep`]).
//! * **M-step:** `α_j = Σ_i w_i r_ij / Σ_i w_i`, `R_j = Σ_i w_i r_ij x_i`,
//!   `μ_j = R_j/|R_j|`, `κ_j = A⁻¹(|R_j| / Σ_i w_i r_ij)`
//!   ([`crate::vmf::kappa_from_resultant`]), clamped to
//!   [[`KAPPA_MIN`], [`KAPPA_MAX`]]. The expected complete-data
//!   log-likelihood is concave in κ (its derivative `r̄ − A(κ)` falls), so
//!   the clamp is the constrained maximum and every iteration still does not
//!   decrease the log-likelihood. A lobe with no responsibility keeps its
//!   direction and κ and gets `α = 0`.
//! * **Stopping rule:** stop after the first iteration whose weighted mean
//!   log-likelihood rises by at most [`EmOptions::tol`] nats per sample, or
//!   after [`EmOptions::max_iter`] iterations.
//! * **Start:** either given lobes (the parent texel's, which keeps slots
//!   coherent down the pyramid) or [`seed_lobes`]: spherical k-means++
//!   (first centre and every D²-draw from a SplitMix64 of fixed seed
//!   [`EM_SEED`]), so the output is deterministic.

pub mod estep;

use crate::vmf::{KAPPA_MAX, KAPPA_MIN, Vmf, kappa_from_resultant, norm};
use estep::{EStepScratch, EStepSums, LobeTerms, SoaSamples};
use glam::DVec3;

/// Seed of the k-means++ start.
pub const EM_SEED: u64 = 0x6a09_e667_f3bc_c908;

/// Stopping rule of [`fit_em`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmOptions {
    /// Largest number of iterations. Default 60.
    pub max_iter: usize,
    /// Stop when the mean log-likelihood per unit weight rises by at most
    /// this many nats. Default 1e-6.
    pub tol: f64,
}

impl Default for EmOptions {
    fn default() -> Self {
        Self {
            max_iter: 60,
            tol: 1e-6,
        }
    }
}

/// One lobe of a mixture: weight and vMF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    /// Mixture weight α ∈ [0, 1] (the weights sum to 1).
    pub alpha: f64,
    pub vmf: Vmf,
}

/// What [`fit_em`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct EmTrace {
    /// Mean log-likelihood per unit weight before the first and after each
    /// iteration (non-decreasing).
    pub log_likelihood: Vec<f64>,
}

/// SplitMix64, the fixed-seed generator of [`seed_lobes`].
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `j` starting lobes for `samples` (weighted): spherical k-means++ centres
/// (D² ∝ `1 − μ·x`), then one hard-assignment step for α and κ.
#[must_use]
pub fn seed_lobes(samples: &[DVec3], weights: &[f64], j: usize) -> Vec<Lobe> {
    let mut rng = SplitMix(EM_SEED);
    let total: f64 = weights.iter().sum();
    let pick = |rng: &mut SplitMix, score: &dyn Fn(usize) -> f64, sum: f64| -> usize {
        let mut t = rng.next_f64() * sum;
        for i in 0..samples.len() {
            t -= score(i);
            if t <= 0.0 {
                return i;
            }
        }
        samples.len() - 1
    };
    let mut centres = vec![samples[pick(&mut rng, &|i| weights[i], total)]];
    let mut dist: Vec<f64> = samples.iter().map(|x| 1.0 - centres[0].dot(*x)).collect();
    while centres.len() < j {
        let sum: f64 = dist.iter().zip(weights).map(|(d, w)| d * w).sum();
        let c = if sum > 1e-12 {
            samples[pick(&mut rng, &|i| dist[i] * weights[i], sum)]
        } else {
            centres[0]
        };
        for (d, x) in dist.iter_mut().zip(samples) {
            *d = d.min(1.0 - c.dot(*x));
        }
        centres.push(c);
    }
    let mut sum_w = vec![0.0f64; j];
    let mut sum_x = vec![DVec3::ZERO; j];
    for (x, w) in samples.iter().zip(weights) {
        let best = (0..j)
            .max_by(|&a, &b| centres[a].dot(*x).total_cmp(&centres[b].dot(*x)))
            .unwrap_or(0);
        sum_w[best] += w;
        sum_x[best] += *x * *w;
    }
    (0..j)
        .map(|k| {
            let r = if sum_w[k] > 0.0 {
                sum_x[k].length() / sum_w[k]
            } else {
                0.0
            };
            Lobe {
                alpha: sum_w[k] / total.max(1e-300),
                vmf: Vmf {
                    mu: sum_x[k].try_normalize().unwrap_or(centres[k]),
                    kappa: kappa_from_resultant(r).min(KAPPA_MAX),
                },
            }
        })
        .collect()
}

/// Runs EM on `lobes` in place (module docs) over `samples` with `weights`
/// (> 0). Returns the log-likelihood trace.
pub fn fit_em(samples: &[DVec3], weights: &[f64], lobes: &mut [Lobe], opts: &EmOptions) -> EmTrace {
    fit_em_on(samples, weights, lobes, opts, true)
}

/// [`fit_em`], with `simd` allowing the AVX2 + FMA E-step ([`estep`]);
/// both give the same bits.
#[doc(hidden)]
pub fn fit_em_on(
    samples: &[DVec3],
    weights: &[f64],
    lobes: &mut [Lobe],
    opts: &EmOptions,
    simd: bool,
) -> EmTrace {
    let j = lobes.len();
    let total: f64 = weights.iter().sum();
    let soa = SoaSamples::new(samples, weights);
    let mut terms = LobeTerms {
        c: vec![0.0; j],
        kmu: vec![[0.0; 3]; j],
    };
    let mut scratch = EStepScratch::default();
    let mut sums = EStepSums::default();
    let mut trace = Vec::with_capacity(opts.max_iter + 1);
    let mut prev = f64::NEG_INFINITY;
    for it in 0..=opts.max_iter {
        for (k, l) in lobes.iter().enumerate() {
            // One `ln` per lobe: `ln(α C(κ)) − κ`.
            terms.c[k] = if l.alpha > 0.0 {
                (l.alpha * norm(l.vmf.kappa)).ln() - l.vmf.kappa
            } else {
                f64::NEG_INFINITY
            };
            terms.kmu[k] = (l.vmf.mu * l.vmf.kappa).to_array();
        }
        estep::estep(&soa, &terms, &mut scratch, &mut sums, simd);
        let ll = sums.ll / total;
        trace.push(ll);
        if it == opts.max_iter || (it > 0 && ll - prev <= opts.tol) {
            break;
        }
        prev = ll;
        for (k, l) in lobes.iter_mut().enumerate() {
            let sum_w = sums.sum_w[k];
            if sum_w <= 1e-12 * total {
                l.alpha = 0.0;
                continue;
            }
            l.alpha = sum_w / total;
            let sum_x = DVec3::from_array(sums.sum_x[k]);
            let len = sum_x.length();
            if len > 0.0 {
                l.vmf.mu = sum_x / len;
            }
            l.vmf.kappa = kappa_from_resultant(len / sum_w).clamp(KAPPA_MIN, KAPPA_MAX);
        }
    }
    EmTrace {
        log_likelihood: trace,
    }
}

/// Mean log-likelihood per unit weight of `samples` under `lobes`.
#[must_use]
pub fn log_likelihood(samples: &[DVec3], weights: &[f64], lobes: &[Lobe]) -> f64 {
    let total: f64 = weights.iter().sum();
    samples
        .iter()
        .zip(weights)
        .map(|(x, w)| {
            let p: f64 = lobes.iter().map(|l| l.alpha * l.vmf.density(*x)).sum();
            w * p.max(1e-300).ln()
        })
        .sum::<f64>()
        / total
}
