//! The SH normal distribution per MIP texel (Han et al. 2007 §3;
//! thesis §5.1.2, eq. 5.7: `ρ^eff_lm(q) = ρ̂_l γ_lm(q)`).
//!
//! # Construction
//! * Level 0: the NDF of one texel is a delta at its normal `n`, whose SH
//!   coefficients are `γ_lm = y_lm(n)`.
//! * Level k: texel `(i, j)` covers the fine texels `[i·2^k, (i+1)·2^k) ×
//!   [j·2^k, (j+1)·2^k)` (cut at the map's edge). NDFs mix linearly, so its
//!   NDF is the mean of its children's weighted by the fine texels each
//!   covers — exactly the box average of the level-0 deltas.
//! * Since every NDF integrates to 1, `γ_00 = 1/√(4π)` at every texel of
//!   every level (tested).
//!
//! # Order per BRDF
//! The clamped cosine's Funk–Hecke factors `Λ_l` (π, 2π/3, π/4, 0, −π/24, …)
//! fall as `l^{−5/2}`: 3 bands (9 coefficients) hold Lambert to ~1–3 % under
//! environment light (Ramamoorthi & Hanrahan 2001). A glossy lobe of
//! Blinn–Phong exponent `s` is a vMF of κ ≈ s, whose `A_l` stays near 1 up
//! to `l ≈ √s`: it needs about `√(2s)`–`2√s` bands (s = 64: ~12–16 bands,
//! 144–256 coefficients per texel), which is why glossy BRDFs use the vMF
//! representation ([`crate::pyramid`]) instead.

use glam::Vec3;
use rayon::prelude::*;

/// One MIP level of SH NDF coefficients: `order²` f32 per texel, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct ShNdfLevel {
    pub width: usize,
    pub height: usize,
    /// `coeffs[(y·width + x)·order² + i]`, index `i = l(l+1)+m`.
    pub coeffs: Vec<f32>,
    /// Fine texels under each texel (the box weight).
    pub counts: Vec<u32>,
}

/// The SH NDF MIP pyramid of a normal map (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ShNdfPyramid {
    /// SH bands n (n² coefficients per texel).
    pub order: usize,
    /// Level 0 first, down to 1 × 1.
    pub levels: Vec<ShNdfLevel>,
}

/// The size of level `k` of a `w × h` map: `⌈w/2^k⌉ × ⌈h/2^k⌉`.
#[must_use]
pub fn level_size(w: usize, h: usize, k: usize) -> (usize, usize) {
    (w.div_ceil(1 << k).max(1), h.div_ceil(1 << k).max(1))
}

/// Levels of a full chain down to 1 × 1.
#[must_use]
pub fn level_count(w: usize, h: usize) -> usize {
    let mut k = 0;
    while level_size(w, h, k) != (1, 1) {
        k += 1;
    }
    k + 1
}

impl ShNdfPyramid {
    /// Builds the pyramid of `width × height` unit tangent-space normals at
    /// `order` bands (1..=[`relight_sh::MAX_ORDER`], checked by the caller).
    #[must_use]
    pub fn build(width: usize, height: usize, normals: &[Vec3], order: usize) -> Self {
        let nn = order * order;
        let mut coeffs = vec![0.0f32; width * height * nn];
        coeffs
            .par_chunks_mut(nn)
            .zip(normals.par_iter())
            .for_each(|(c, n)| relight_sh::eval_sh_into(order, n.to_array(), c));
        let mut levels = vec![ShNdfLevel {
            width,
            height,
            coeffs,
            counts: vec![1; width * height],
        }];
        while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) {
            let next = downsample(levels.last().expect("non-empty"), nn);
            levels.push(next);
        }
        Self { order, levels }
    }

    /// Coefficients of texel `(x, y)` of level `k`.
    #[must_use]
    pub fn texel(&self, k: usize, x: usize, y: usize) -> &[f32] {
        let nn = self.order * self.order;
        let l = &self.levels[k];
        let i = y * l.width + x;
        &l.coeffs[i * nn..(i + 1) * nn]
    }

    /// Trilinear lookup at `uv` (the [`relight_render::NormalMap`] uv
    /// convention, wrap-around) and fractional level `lod` ∈ [0, levels−1],
    /// written into `out` (`order²`). Linear filtering of the coefficients is
    /// exact filtering of the NDF.
    pub fn sample(&self, uv: glam::Vec2, lod: f32, out: &mut [f32]) {
        if self.order == 3 && out.len() >= 9 {
            // Lambert's order, with fixed-size loops the compiler unrolls.
            let o9 = self.sample9(uv, lod);
            out[..9].copy_from_slice(&o9);
            return;
        }
        let nn = self.order * self.order;
        let out = &mut out[..nn];
        out.fill(0.0);
        let top = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, top);
        let k0 = lod.floor() as usize;
        let t = lod - k0 as f32;
        let mut add = |k: usize, wk: f32| {
            let l = &self.levels[k];
            for (i, w) in crate::taps(l.width, l.height, uv) {
                let c = &l.coeffs[i * nn..(i + 1) * nn];
                let w = w * wk;
                for (o, v) in out.iter_mut().zip(c) {
                    *o += w * v;
                }
            }
        };
        add(k0, 1.0 - t);
        if t > 0.0 && k0 + 1 < self.levels.len() {
            add(k0 + 1, t);
        }
    }

    /// The mean of [`Self::sample`] over an anisotropic footprint's probes
    /// into `out` (`order²` entries; SH coefficients filter linearly).
    #[inline(always)]
    pub fn sample_footprint(&self, fp: &crate::Footprint, out: &mut [f32]) {
        let nn = self.order * self.order;
        let out = &mut out[..nn];
        out.fill(0.0);
        if nn == 9 {
            // Lambert's order: the accumulators in registers (8 lanes and
            // one scalar: one 256-bit lane group in an AVX2 caller, two
            // 128-bit ones in the baseline), each tap `acc += c·w` as the
            // generic loop, the taps visited as they are computed.
            let (mut a, mut c8) = ([0.0f32; 8], 0.0f32);
            let (lv, count) = fp.level_weights(self.levels.len());
            for &(k, wk) in &lv[..count] {
                let l = &self.levels[k];
                let (texels, _) = l.coeffs.as_chunks::<9>();
                fp.visit_level((l.width, l.height), wk, |i, w| {
                    let c = &texels[i];
                    for j in 0..8 {
                        a[j] += c[j] * w;
                    }
                    c8 += w * c[8];
                });
            }
            out[..8].copy_from_slice(&a);
            out[8] = c8;
            return;
        }
        let taps = fp.taps(self.levels.len(), |k| {
            (self.levels[k].width, self.levels[k].height)
        });
        for j in 0..taps.count {
            let coeffs = &self.levels[taps.levels[j]].coeffs;
            for (i, w) in taps.level(j) {
                let c = &coeffs[i * nn..(i + 1) * nn];
                for (o, v) in out.iter_mut().zip(c) {
                    *o += w * v;
                }
            }
        }
    }

    /// Each probe's own bands 0–2 into `out[p]` for `p < fp.count` (its
    /// trilinear sample, not divided by the count; any order, bands 0–2 read).
    /// Their mean is [`Self::sample_footprint`]'s (to rounding); the
    /// method masks each probe's NDF on its own (`crate::method`, module
    /// docs), since the mask is not linear in the NDF.
    #[inline(always)]
    pub fn sample_probes9(&self, fp: &crate::Footprint, out: &mut [[f32; 9]; crate::MAX_PROBES]) {
        let nn = self.order * self.order;
        for o in out.iter_mut().take(fp.count) {
            *o = [0.0; 9];
        }
        let (lv, count) = fp.probe_level_weights(self.levels.len());
        for &(k, wk) in &lv[..count] {
            let l = &self.levels[k];
            let taps = fp.level_taps((l.width, l.height), wk);
            for (o, taps) in out.iter_mut().zip(&taps[..fp.count]) {
                // The probe's four taps summed in registers, then added.
                let mut a = [0.0f32; 9];
                for &(i, w) in taps {
                    let c = &l.coeffs[i * nn..i * nn + 9];
                    for j in 0..9 {
                        a[j] += c[j] * w;
                    }
                }
                for (o, a) in o.iter_mut().zip(a) {
                    *o += a;
                }
            }
        }
    }

    /// [`Self::sample`] for order 3 (9 coefficients per texel).
    #[inline]
    fn sample9(&self, uv: glam::Vec2, lod: f32) -> [f32; 9] {
        let mut out = [0.0f32; 9];
        let top = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, top);
        let k0 = lod.floor() as usize;
        let t = lod - k0 as f32;
        let mut add = |k: usize, wk: f32| {
            let l = &self.levels[k];
            for (i, w) in crate::taps(l.width, l.height, uv) {
                let c: &[f32; 9] = l.coeffs[i * 9..i * 9 + 9].try_into().expect("9 per texel");
                let w = w * wk;
                for j in 0..9 {
                    out[j] += w * c[j];
                }
            }
        };
        add(k0, 1.0 - t);
        if t > 0.0 && k0 + 1 < self.levels.len() {
            add(k0 + 1, t);
        }
        out
    }

    /// Bytes of coefficients over the whole chain.
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.levels
            .iter()
            .map(|l| (l.coeffs.len() * 4 + l.counts.len() * 4) as u64)
            .sum()
    }
}

/// The next coarser level: each texel the fine-count-weighted mean of its
/// (up to four) children.
fn downsample(l: &ShNdfLevel, nn: usize) -> ShNdfLevel {
    let (w, h) = (l.width.div_ceil(2), l.height.div_ceil(2));
    let mut coeffs = vec![0.0f32; w * h * nn];
    let mut counts = vec![0u32; w * h];
    coeffs
        .par_chunks_mut(nn * w)
        .zip(counts.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (row, crow))| {
            for x in 0..w {
                let dst = &mut row[x * nn..(x + 1) * nn];
                let mut total = 0u32;
                for cy in 2 * y..(2 * y + 2).min(l.height) {
                    for cx in 2 * x..(2 * x + 2).min(l.width) {
                        let i = cy * l.width + cx;
                        let c = l.counts[i];
                        total += c;
                        for (d, v) in dst.iter_mut().zip(&l.coeffs[i * nn..(i + 1) * nn]) {
                            *d += c as f32 * v;
                        }
                    }
                }
                let inv = 1.0 / total as f32;
                for d in dst.iter_mut() {
                    *d *= inv;
                }
                crow[x] = total;
            }
        });
    ShNdfLevel {
        width: w,
        height: h,
        coeffs,
        counts,
    }
}
