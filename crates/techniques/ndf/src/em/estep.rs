//! The E-step of [`super::fit_em`] over structure-of-arrays samples, with
//! the M-step's sums: the bake's hot loop (`relight bench ndf`'s vMF bake
//! row).
//!
//! Samples are taken [`BLOCK`] at a time. For each lobe `k` the block's log
//! terms `ℓ_ik = c_k + κ_k μ_k·x_i` are one affine map over the block, their
//! exponentials `e^{ℓ_ik − m_i}` come from [`exp_nonpositive`] (a
//! branch-free polynomial, so the loop vectorizes; `libm`'s `exp` was a
//! third of the bake), and the sums `Σ w r`, `Σ w r x` run in four lanes per
//! lobe. Padding samples carry weight 0 and add nothing.
//!
//! The kernel is compiled twice ([`estep`]): for the baseline target and,
//! where the CPU has them, for AVX2 + FMA. Its multiply–adds are explicit
//! `mul_add`s, which are exactly rounded everywhere (an FMA instruction in
//! the AVX2 copy, `libm`'s `fma` in the baseline one), so both copies give
//! the same bits (tested): a bake does not depend on the CPU it ran on.

/// Samples per block, and the padding of a fit's samples: the fits of
/// level 2 read 16 normals each (4 × 4 texels of the 2× field).
pub const BLOCK: usize = 16;

/// Terms more than 60 nats below a sample's largest are 0 in the sum (they
/// are below `e^−60 ≈ 9e-27` of the largest, which is 1, so they are 0 to
/// f64 in it); their exponentials are not taken.
const NEGLIGIBLE: f64 = -60.0;

/// `e^d` for `d ∈ [−708, 0]`, relative error below 1e-15 (tested against
/// `f64::exp`), branch-free: `d = k ln 2 + r` with `k` rounded by the
/// `1.5·2⁵²` shifter (no `round` instruction needed on the baseline target),
/// `ln 2` split in Cody & Waite's two parts (fdlibm's), and `e^r`,
/// `|r| ≤ ln 2 / 2`, by its Taylor polynomial to `r¹²` (truncation
/// `|r|¹³/13! < 2e-16`), then `2^k` put into the exponent bits.
#[inline(always)]
#[must_use]
pub fn exp_nonpositive(d: f64) -> f64 {
    const SHIFTER: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²
    // fdlibm's split of ln 2: `LN2_HI` has 32 significant bits, so `k·LN2_HI`
    // is exact for the `|k| ≤ 1022` here.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    let d = if d > -708.0 { d } else { -708.0 };
    let t = d * std::f64::consts::LOG2_E + SHIFTER;
    let kf = t - SHIFTER;
    // `t`'s low mantissa bits hold `k` (offset by the shifter's).
    let k = (t.to_bits() as i64).wrapping_sub(SHIFTER.to_bits() as i64);
    let r = kf.mul_add(-LN2_LO, kf.mul_add(-LN2_HI, d));
    // 1/n!, n = 12 … 2 (correctly rounded quotients).
    const C: [f64; 11] = [
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
    ];
    let mut p = C[0];
    for c in &C[1..] {
        p = p.mul_add(r, *c);
    }
    let er = p.mul_add(r, 1.0).mul_add(r, 1.0);
    er * f64::from_bits((k + 1023).wrapping_shl(52) as u64)
}

/// The samples of one fit as structure of arrays, padded with weight-0
/// samples to a whole number of [`BLOCK`]s.
#[derive(Clone, Debug, Default)]
pub struct SoaSamples {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub w: Vec<f64>,
}

impl SoaSamples {
    /// From unit `samples` and their weights (> 0).
    #[must_use]
    pub fn new(samples: &[glam::DVec3], weights: &[f64]) -> Self {
        let n = samples.len().min(weights.len()).div_ceil(BLOCK) * BLOCK;
        let mut s = Self {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![0.0; n],
            w: vec![0.0; n],
        };
        for (i, (p, &w)) in samples.iter().zip(weights).enumerate() {
            (s.x[i], s.y[i], s.z[i], s.w[i]) = (p.x, p.y, p.z, w);
        }
        s
    }
}

/// Per-lobe inputs of one E-step: `c_k = ln α_k + ln C(κ_k) − κ_k` (−∞ for
/// an empty lobe) and `κ_k μ_k`.
#[derive(Clone, Debug, Default)]
pub struct LobeTerms {
    pub c: Vec<f64>,
    pub kmu: Vec<[f64; 3]>,
}

/// What one E-step gives: the log-likelihood's sum `Σ w (m + ln s)` and, per
/// lobe, `Σ w r` and `Σ w r x`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EStepSums {
    pub ll: f64,
    pub sum_w: Vec<f64>,
    pub sum_x: Vec<[f64; 3]>,
}

/// Work buffers of [`estep`], sized once per fit.
#[derive(Clone, Debug, Default)]
pub struct EStepScratch {
    /// `J × BLOCK` log terms, then responsibilities' numerators.
    terms: Vec<f64>,
    /// Per lane of 4: `Σ w r`, `Σ w r x`, `Σ w r y`, `Σ w r z`, per lobe.
    lanes: Vec<[[f64; 4]; 4]>,
}

/// One E-step over `s` with `lobes`' terms into `out` (module docs);
/// `simd` allows the AVX2 + FMA copy where the CPU has it.
pub fn estep(
    s: &SoaSamples,
    lobes: &LobeTerms,
    scratch: &mut EStepScratch,
    out: &mut EStepSums,
    simd: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if simd && relight_sh::isa() >= relight_sh::Isa::Avx2 {
        // SAFETY: the CPU has AVX2 and FMA (`isa` checked them).
        unsafe { estep_avx2(s, lobes, scratch, out) };
        return;
    }
    let _ = simd;
    estep_body(s, lobes, scratch, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn estep_avx2(
    s: &SoaSamples,
    lobes: &LobeTerms,
    scratch: &mut EStepScratch,
    out: &mut EStepSums,
) {
    estep_body(s, lobes, scratch, out);
}

#[inline(always)]
// The four-lane sums index `acc[·][l]` and the block's arrays by one index:
// the shape the vectorizer turns into one register per sum.
#[allow(clippy::needless_range_loop)]
fn estep_body(s: &SoaSamples, lobes: &LobeTerms, scratch: &mut EStepScratch, out: &mut EStepSums) {
    let j = lobes.c.len();
    scratch.terms.resize(j * BLOCK, 0.0);
    scratch.lanes.clear();
    scratch.lanes.resize(j, [[0.0; 4]; 4]);
    let mut ll = 0.0;
    // The `ln s` of unit-weight samples are summed as the log of their
    // product (s ∈ [1, J], flushed before it could overflow): one `ln` per
    // ~100 samples instead of one each.
    let mut prod = 1.0f64;
    let n = s.w.len() / BLOCK * BLOCK;
    for b0 in (0..n).step_by(BLOCK) {
        let (xs, ys, zs, ws) = (
            &s.x[b0..b0 + BLOCK],
            &s.y[b0..b0 + BLOCK],
            &s.z[b0..b0 + BLOCK],
            &s.w[b0..b0 + BLOCK],
        );
        let mut m = [f64::NEG_INFINITY; BLOCK];
        for (k, row) in scratch.terms.chunks_exact_mut(BLOCK).enumerate() {
            let (c, [kx, ky, kz]) = (lobes.c[k], lobes.kmu[k]);
            for i in 0..BLOCK {
                let t = kx.mul_add(xs[i], ky.mul_add(ys[i], kz.mul_add(zs[i], c)));
                row[i] = t;
                m[i] = if t > m[i] { t } else { m[i] };
            }
        }
        let mut sum = [0.0f64; BLOCK];
        for row in scratch.terms.chunks_exact_mut(BLOCK) {
            for i in 0..BLOCK {
                let d = row[i] - m[i];
                let e = exp_nonpositive(if d > NEGLIGIBLE { d } else { NEGLIGIBLE });
                row[i] = if d > NEGLIGIBLE { e } else { 0.0 };
                sum[i] += row[i];
            }
        }
        let mut inv = [0.0f64; BLOCK];
        for i in 0..BLOCK {
            let w = ws[i];
            if w == 1.0 {
                ll += m[i];
                prod *= sum[i];
                if prod > 1e250 {
                    ll += prod.ln();
                    prod = 1.0;
                }
            } else if w > 0.0 {
                ll += w * (m[i] + sum[i].ln());
            }
            inv[i] = w / sum[i];
        }
        for (row, acc) in scratch.terms.chunks_exact(BLOCK).zip(&mut scratch.lanes) {
            for q in 0..BLOCK / 4 {
                for l in 0..4 {
                    let i = 4 * q + l;
                    let r = row[i] * inv[i];
                    acc[0][l] += r;
                    acc[1][l] = r.mul_add(xs[i], acc[1][l]);
                    acc[2][l] = r.mul_add(ys[i], acc[2][l]);
                    acc[3][l] = r.mul_add(zs[i], acc[3][l]);
                }
            }
        }
    }
    ll += prod.ln();
    let fold = |a: &[f64; 4]| (a[0] + a[1]) + (a[2] + a[3]);
    out.ll = ll;
    out.sum_w.clear();
    out.sum_x.clear();
    for acc in &scratch.lanes {
        out.sum_w.push(fold(&acc[0]));
        out.sum_x
            .push([fold(&acc[1]), fold(&acc[2]), fold(&acc[3])]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_matches_libm_to_a_few_ulps() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let d = -60.0 * f64::from(i) / 200_000.0;
            let (got, want) = (exp_nonpositive(d), d.exp());
            worst = worst.max((got / want - 1.0).abs());
        }
        for d in [-700.0, -500.5, -100.25, -1e-300, 0.0] {
            let (got, want) = (exp_nonpositive(d), f64::exp(d));
            worst = worst.max((got / want - 1.0).abs());
        }
        assert!(worst < 1e-15, "relative error {worst:e}");
        assert_eq!(exp_nonpositive(0.0), 1.0);
        // Below the clamp it stays finite and tiny, never NaN.
        assert!(exp_nonpositive(f64::NEG_INFINITY) < 1e-300);
    }
}
