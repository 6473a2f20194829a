//! relight-ndf: frequency-domain normal-map filtering (Han, Sun, Ramamoorthi
//! & Grinspun 2007, "Frequency domain normal map filtering"; Sun's thesis
//! §5.1, `sun-thesis-2008.txt`).
//!
//! # The idea
//! A MIP texel covers many normals; shading it with their average is wrong
//! (the surface flattens, highlights alias and keep their gloss). Its
//! *normal distribution function* γ(n) convolved with the BRDF's
//! `f(n·ω)` is the texel's effective BRDF (eqs. 5.1–5.6), and in SH the
//! convolution is a product per band: `ρ^eff_lm = ρ̂_l γ_lm` (eq. 5.7).
//!
//! # Representations (bake, no IO)
//! * [`sh_ndf::ShNdfPyramid`]: SH coefficients of the NDF per texel; level 0
//!   is the SH of a delta, coarser levels are exact box averages.
//! * [`pyramid::VmfPyramid`]: `J` vMF lobes per texel fitted by spherical EM
//!   ([`em`]), slots coherent parent → children, stored so linear filtering
//!   is the moment-matching merge.
//! * [`MeanPyramid`]: the mean normal per texel, for the baselines
//!   (unnormalized / normalized MIP, Toksvig).
//! * [`lean::LeanPyramid`]: LEAN mapping's 5 moments per texel (Olano &
//!   Baker 2010), the fourth baseline.
//! * [`field`]: the bilinearly interpolated, renormalised normal field that
//!   plain normal mapping shades; the method builds its SH and vMF pyramids
//!   from it (the builders take any normals).
//! * [`vmf`]: the lobe, `A(κ)` and its inverse, `A_l(κ)` by backward recurrence.
//! * [`effective`]: effective BRDFs (Lambert; Blinn–Phong `s′ = κs/(κ+s)`;
//!   GGX/Beckmann `α′² = α² + 2/κ`) and the baselines.
//! * [`mask`]: Lambert's view mask (a normal facing away from the viewer
//!   shades zero) from the NDF's mean and covariance: correlated with the
//!   light under a point light, the seen part of the NDF under environment
//!   light.
//! * [`seen_lanes`]: that environment mask for eight NDFs at once (pixels,
//!   or with `NdfOptions::probe_masks` their footprints' probes), bit for bit
//!   the scalar form, which the method's rows batch their SH pixels into.
//!
//! # Runtime
//! [`method::NdfMethod`] (`--method ndf`) shades per pixel with the MIP
//! level from the uv footprint (`relight_render::raster::barycentric_derivatives`).
//!
//! # Conventions
//! Normals in tangent space (+X tangent, +Y bitangent "green up", +Z out),
//! the `relight_render::NormalMap` convention; uv → texel `x = u·W − ½`,
//! wrap-around. SH as in `relight-sh` (real, orthonormal, Condon–Shortley).

pub mod bench;
pub mod effective;
pub mod em;
pub mod export;
pub mod field;
pub mod lean;
pub mod mask;
pub mod method;
pub mod pyramid;
pub mod seen_lanes;
pub mod sh_ndf;
pub mod verify;
pub mod vmf;

pub use effective::{Baseline, NdfBrdf};
pub use lean::{LeanPyramid, LeanTexel};
pub use method::{NDF_METHOD_NAME, NdfFilter, NdfMethod, NdfOptions, VmfTaps, colour_of};
pub use pyramid::{VmfBakeOptions, VmfPyramid};
pub use sh_ndf::ShNdfPyramid;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

pub use relight_render::texture::bilinear_taps as taps;

/// The MIP level of a uv footprint: `log2` of the longer screen axis of the
/// footprint in level-0 texels, `ρ = max(|∂uv/∂x|, |∂uv/∂y|)` scaled by
/// `(W, H)` (the OpenGL rule), clamped at 0.
#[inline]
#[must_use]
pub fn lod_of(duv_dx: Vec2, duv_dy: Vec2, width: usize, height: usize) -> f32 {
    let s = Vec2::new(width as f32, height as f32);
    let rho = (duv_dx * s).length().max((duv_dy * s).length());
    if rho > 1.0 { rho.log2() } else { 0.0 }
}

/// Most probes of an anisotropic [`Footprint`]: 4 (8 cost 35 % more per
/// SH Lambert frame on the horizon plane and moved its screen-level errors
/// by ≤ 4e-4: sh 0.0918 → 0.0919, vmf/lambert 0.0850 → 0.0849, vmf/blinn:64
/// 0.2937 both, `relight verify ndf --quick`).
pub const MAX_PROBES: usize = 4;

/// Levels by which a [`Footprint`] reads finer than its variance-matched
/// level, chosen on measurement: at the matched level the screen scenes
/// lost contrast against the reference (dark pixels too bright, bright ones
/// too dark). Half a level lowered the screen-level error of both
/// representations on the sphere and of SH on the plane, on the scenes'
/// map and on two maps the verify does not use. A kernel-only model would
/// have gone the other way, so the representations' own loss of contrast
/// at coarser levels is part of it (figures, and the one row it did not
/// help, vMF on the plane: `docs/ndf.md`).
pub const LEVEL_BIAS: f32 = 0.5;

/// An anisotropic uv footprint as trilinear probes along its major axis
/// (the scheme of hardware anisotropic filtering): `n = ⌈major/minor⌉`
/// probes (at most [`MAX_PROBES`]) spread evenly over the major axis
/// `∂uv/∂x` or `∂uv/∂y` (the longer in texels), each at the level that
/// covers `ρ = max(major/n, minor)` texels. Every representation here
/// filters linearly (SH coefficients, packed vMF moments, mean normals,
/// LEAN's moments), so the probes' mean *is* the footprint's
/// representation.
///
/// # The level
/// The screen-level truth is the pixel's box (ρ texels wide) over the
/// bilinearly interpolated level 0: variance `ρ²/12 + 1/6` per axis (in
/// texels²). A level-k texel is a box of `2^k` fine texels and bilinear
/// interpolation between level-k texels adds a tent of half-width `2^k`:
/// variance `4^k (1/12 + 1/6) = 4^k/4`. Equal variances give
/// `k = ½ log2((ρ² + 2)/3)` — 0 at ρ = 1, `log2 ρ − 0.79` for large ρ —
/// where the OpenGL rule's `log2 ρ` ([`lod_of`]) blurs twice as wide. The
/// probes read [`LEVEL_BIAS`] below that (clamped at 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub probes: [Vec2; MAX_PROBES],
    /// Probes in use (≥ 1).
    pub count: usize,
    /// The level every probe reads.
    pub lod: f32,
    /// The share of plain normal mapping in the pixel's NDF: the delta at
    /// the bilinearly interpolated, renormalised normal (what the reference
    /// shades). 1 when the footprint's major axis is within a texel
    /// (magnified: the pixel sees one interpolated normal, where bilinear
    /// filtering of level 0 would mix the four texels' deltas instead),
    /// falling linearly to 0 at two texels, past which the probes alone
    /// hold the NDF. The SH and vMF representations shade the mixture
    /// `plain · δ(n_interp) + (1 − plain) · NDF(probes)` (SH coefficients
    /// blended, or one more vMF lobe, a delta): level 0 equals plain normal
    /// mapping (issue 14) with no seam where the footprint crosses a texel.
    /// 0 where the footprint is unknown ([`Self::point`]).
    pub plain: f32,
}

impl Footprint {
    /// One probe at `uv`, level `lod`.
    #[must_use]
    pub fn point(uv: Vec2, lod: f32) -> Self {
        let mut probes = [uv; MAX_PROBES];
        probes[0] = uv;
        Self {
            probes,
            count: 1,
            lod,
            plain: 0.0,
        }
    }

    /// [`Footprint::plain`] of a major axis `major2` texels² long.
    #[inline(always)]
    fn plain_of(major2: f32) -> f32 {
        if major2 <= 1.0 {
            1.0
        } else if major2 < 4.0 {
            2.0 - major2.sqrt()
        } else {
            0.0
        }
    }

    /// The footprint of a pixel at `uv` with screen derivatives `duv_dx`,
    /// `duv_dy` on a `width × height` map (type docs); isotropic or
    /// magnified footprints get one probe.
    ///
    /// In squared lengths, without a square root: `n = ⌈major/minor⌉` is
    /// `1 + #{k ∈ 1..4 : major² > k² minor²}` and the level reads
    /// `ρ² = max(major²/n², minor²)` ([`Self::of_lengths`], the form with
    /// lengths, up to f32 rounding: tested). Squares past f32's range take
    /// that form.
    #[inline(always)]
    #[must_use]
    pub fn of(uv: Vec2, duv_dx: Vec2, duv_dy: Vec2, width: usize, height: usize) -> Self {
        let s = Vec2::new(width as f32, height as f32);
        let (qx, qy) = ((duv_dx * s).length_squared(), (duv_dy * s).length_squared());
        let (major2, minor2, axis) = if qx >= qy {
            (qx, qy, duv_dx)
        } else {
            (qy, qx, duv_dy)
        };
        if !(major2.is_finite() && minor2.is_finite()) {
            return Self::of_lengths(uv, duv_dx, duv_dy, width, height);
        }
        if major2 <= 1.0 {
            return Self {
                plain: 1.0,
                ..Self::point(uv, 0.0)
            };
        }
        let q2 = major2 / minor2.max(1e-12);
        let n = 1 + usize::from(q2 > 1.0) + usize::from(q2 > 4.0) + usize::from(q2 > 9.0);
        const _: () = assert!(MAX_PROBES == 4, "the count above stops at 4");
        let rho2 = (major2 / (n * n) as f32).max(minor2);
        let lod = if rho2 > 1.0 {
            (0.5 * ((rho2 + 2.0) / 3.0).log2() - LEVEL_BIAS).max(0.0)
        } else {
            0.0
        };
        let mut probes = [uv; MAX_PROBES];
        for (p, o) in probes.iter_mut().zip(&PROBE_OFFSETS[n]).take(n) {
            *p = uv + axis * *o;
        }
        Self {
            probes,
            count: n,
            lod,
            plain: Self::plain_of(major2),
        }
    }

    /// [`Self::of`] in lengths (the type docs' form as written).
    #[must_use]
    pub fn of_lengths(uv: Vec2, duv_dx: Vec2, duv_dy: Vec2, width: usize, height: usize) -> Self {
        let s = Vec2::new(width as f32, height as f32);
        let (lx, ly) = ((duv_dx * s).length(), (duv_dy * s).length());
        let (major, minor, axis) = if lx >= ly {
            (lx, ly, duv_dx)
        } else {
            (ly, lx, duv_dy)
        };
        let level = |rho: f32| {
            if rho > 1.0 {
                (0.5 * ((rho * rho + 2.0) / 3.0).log2() - LEVEL_BIAS).max(0.0)
            } else {
                0.0
            }
        };
        if !(major.is_finite() && minor.is_finite()) {
            return Self::point(uv, 0.0);
        }
        if major <= 1.0 {
            return Self {
                plain: 1.0,
                ..Self::point(uv, 0.0)
            };
        }
        let n = ceil_positive(major / minor.max(1e-6)).clamp(1, MAX_PROBES);
        let lod = level((major / n as f32).max(minor));
        let mut probes = [uv; MAX_PROBES];
        for (p, o) in probes.iter_mut().zip(&PROBE_OFFSETS[n]).take(n) {
            *p = uv + axis * *o;
        }
        Self {
            probes,
            count: n,
            lod,
            plain: (2.0 - major).clamp(0.0, 1.0),
        }
    }

    /// The probes in use.
    #[must_use]
    pub fn probes(&self) -> &[Vec2] {
        &self.probes[..self.count]
    }
}

/// `(i + ½)/n − ½`, probe `i`'s place along the major axis of a footprint
/// of `n` probes: a table (the same f32 values) instead of a division per
/// probe.
const PROBE_OFFSETS: [[f32; MAX_PROBES]; MAX_PROBES + 1] = {
    let mut t = [[0.0f32; MAX_PROBES]; MAX_PROBES + 1];
    let mut n = 1;
    while n <= MAX_PROBES {
        let mut i = 0;
        while i < n {
            t[n][i] = (i as f32 + 0.5) / n as f32 - 0.5;
            i += 1;
        }
        n += 1;
    }
    t
};

/// `⌈q⌉` of a finite `q ≥ 0` as `usize`, without the `ceilf` call that
/// `f32::ceil` compiles to on baseline x86-64 (no `roundss`): truncation is
/// exact below 2^24, every larger f32 is an integer, and past `usize` both
/// saturate (tested against
/// `ceil`).
#[inline]
fn ceil_positive(q: f32) -> usize {
    let t = q as usize;
    if (t as f32) < q {
        t.saturating_add(1)
    } else {
        t
    }
}

/// [`taps`] (bilinear, wrap-around) on a grid whose sides are both powers
/// of two: the wrap is a mask (for in-range coordinates too), so there is
/// no range test per probe; the same taps and weights as [`taps`] (tested).
/// Falls back to [`taps`] past its exact range (|coordinate| ≥ 2^23).
#[inline(always)]
fn taps_pow2(width: usize, height: usize, uv: Vec2) -> [(usize, f32); 4] {
    let fx = uv.x * width as f32 - 0.5;
    let fy = uv.y * height as f32 - 0.5;
    const EXACT: f32 = 8_388_608.0;
    if !(fx.abs() < EXACT && fy.abs() < EXACT) {
        return taps(width, height, uv);
    }
    let floor = |v: f32| {
        let i = v as i64;
        if (i as f32) > v { i - 1 } else { i }
    };
    let (ix, iy) = (floor(fx), floor(fy));
    let (tx, ty) = (fx - ix as f32, fy - iy as f32);
    let (mx, my) = (width as i64 - 1, height as i64 - 1);
    let (xa, ya) = ((ix & mx) as usize, (iy & my) as usize);
    let (xb, yb) = (((ix + 1) & mx) as usize, ((iy + 1) & my) as usize);
    [
        (ya * width + xa, (1.0 - tx) * (1.0 - ty)),
        (ya * width + xb, tx * (1.0 - ty)),
        (yb * width + xa, (1.0 - tx) * ty),
        (yb * width + xb, tx * ty),
    ]
}

/// [`taps_pow2`] for the four probe slots of a [`Footprint`] at once, one
/// SSE2 lane per probe (SSE2 is part of x86-64).
#[cfg(target_arch = "x86_64")]
mod sse2 {
    use super::{MAX_PROBES, Vec2};
    use std::arch::x86_64::*;

    /// `[tap][probe]` texel indices and weights.
    pub(super) type ProbeTaps = ([[i32; 4]; 4], [[f32; 4]; 4]);

    /// `[tap][probe]` texel indices and weights (× `wk`) of the bilinear
    /// taps of `probes` on a `width × height` grid whose sides are powers of
    /// two: the taps of [`super::taps_pow2`] bit for bit (the same f32
    /// operations lane by lane; the floor in i32, exact below 2^23 as the
    /// i64 one). `None` where a coordinate leaves that range or the grid
    /// has 2^31 texels or more: the caller takes the scalar path.
    #[inline(always)]
    pub(super) fn probe_taps_pow2(
        probes: &[Vec2; MAX_PROBES],
        width: usize,
        height: usize,
        wk: f32,
    ) -> Option<ProbeTaps> {
        const _: () = assert!(MAX_PROBES == 4, "one SSE lane per probe");
        if width.checked_mul(height)? > i32::MAX as usize {
            return None;
        }
        // SAFETY: SSE2 is in the x86-64 baseline; the stores write arrays
        // of four 32-bit lanes.
        unsafe {
            let xs = _mm_setr_ps(probes[0].x, probes[1].x, probes[2].x, probes[3].x);
            let ys = _mm_setr_ps(probes[0].y, probes[1].y, probes[2].y, probes[3].y);
            let half = _mm_set1_ps(0.5);
            let fx = _mm_sub_ps(_mm_mul_ps(xs, _mm_set1_ps(width as f32)), half);
            let fy = _mm_sub_ps(_mm_mul_ps(ys, _mm_set1_ps(height as f32)), half);
            // |f| < 2^23 in every lane (false for NaN).
            let abs = _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff));
            let exact = _mm_set1_ps(8_388_608.0);
            let ok = _mm_and_ps(
                _mm_cmplt_ps(_mm_and_ps(fx, abs), exact),
                _mm_cmplt_ps(_mm_and_ps(fy, abs), exact),
            );
            if _mm_movemask_ps(ok) != 0xf {
                return None;
            }
            // Truncate, then one less where that rounded up (negatives).
            let floor = |f: __m128| {
                let i = _mm_cvttps_epi32(f);
                let up = _mm_cmpgt_ps(_mm_cvtepi32_ps(i), f);
                _mm_add_epi32(i, _mm_castps_si128(up))
            };
            let (ix, iy) = (floor(fx), floor(fy));
            let tx = _mm_sub_ps(fx, _mm_cvtepi32_ps(ix));
            let ty = _mm_sub_ps(fy, _mm_cvtepi32_ps(iy));
            let one = _mm_set1_epi32(1);
            let (mx, my) = (
                _mm_set1_epi32(width as i32 - 1),
                _mm_set1_epi32(height as i32 - 1),
            );
            let xa = _mm_and_si128(ix, mx);
            let xb = _mm_and_si128(_mm_add_epi32(ix, one), mx);
            let shift = _mm_cvtsi32_si128(width.trailing_zeros() as i32);
            let ra = _mm_sll_epi32(_mm_and_si128(iy, my), shift);
            let rb = _mm_sll_epi32(_mm_and_si128(_mm_add_epi32(iy, one), my), shift);
            let onef = _mm_set1_ps(1.0);
            let (ux, uy) = (_mm_sub_ps(onef, tx), _mm_sub_ps(onef, ty));
            let wk = _mm_set1_ps(wk);
            let mut index = [[0i32; 4]; 4];
            let mut weight = [[0.0f32; 4]; 4];
            let taps = [
                (_mm_add_epi32(ra, xa), _mm_mul_ps(ux, uy)),
                (_mm_add_epi32(ra, xb), _mm_mul_ps(tx, uy)),
                (_mm_add_epi32(rb, xa), _mm_mul_ps(ux, ty)),
                (_mm_add_epi32(rb, xb), _mm_mul_ps(tx, ty)),
            ];
            for (t, (i, w)) in taps.into_iter().enumerate() {
                _mm_storeu_si128(index[t].as_mut_ptr().cast(), i);
                _mm_storeu_ps(weight[t].as_mut_ptr(), _mm_mul_ps(w, wk));
            }
            Some((index, weight))
        }
    }
}

/// Most texel taps of one level of a [`Footprint`]: 4 per probe.
pub const MAX_LEVEL_TAPS: usize = MAX_PROBES * 4;

/// The texel taps of a [`Footprint`] on one pyramid, level by level, in
/// the order [`Footprint::for_each_tap`] visits them: `levels[j]` is read
/// at `index[j][..len[j]]` with `weight[j][..len[j]]`, for `j < count`.
/// Fixed-size (no allocation), so a sampler can run its own loop over them
/// with its accumulators in registers instead of behind a closure.
#[derive(Clone, Copy, Debug)]
pub struct FootprintTaps {
    /// The levels read (at most two).
    pub levels: [usize; 2],
    /// Levels in use (1 or 2).
    pub count: usize,
    /// Texel index within the level, per tap.
    pub index: [[u32; MAX_LEVEL_TAPS]; 2],
    /// Weight per tap: the probe mean's `1/count` × trilinear.
    pub weight: [[f32; MAX_LEVEL_TAPS]; 2],
    /// Taps per level.
    pub len: [usize; 2],
}

impl FootprintTaps {
    /// The taps of level slot `j` (`j < count`) as `(texel, weight)`.
    #[inline]
    pub fn level(&self, j: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        self.index[j][..self.len[j]]
            .iter()
            .zip(&self.weight[j][..self.len[j]])
            .map(|(i, w)| (*i as usize, *w))
    }
}

impl Footprint {
    /// Every texel tap of the footprint ([`FootprintTaps`]): the bilinear
    /// taps of each probe at the two levels about `lod` (clamped to
    /// `0..levels`; `dims(k)` is level k's size), the weights the probe
    /// mean's `1/count` times the trilinear ones — the taps that the
    /// per-probe [`sample_pyramid`] averaged, without a buffer per probe.
    #[inline]
    #[must_use]
    pub fn taps(&self, levels: usize, dims: impl Fn(usize) -> (usize, usize)) -> FootprintTaps {
        let (lv, count) = self.level_weights(levels);
        let mut out = FootprintTaps {
            levels: [lv[0].0, lv[1].0],
            count,
            index: [[0; MAX_LEVEL_TAPS]; 2],
            weight: [[0.0; MAX_LEVEL_TAPS]; 2],
            len: [0; 2],
        };
        for (j, &(k, wk)) in lv.iter().enumerate().take(count) {
            let mut n = 0;
            self.visit_level(dims(k), wk, |i, w| {
                out.index[j][n] = i as u32;
                out.weight[j][n] = w;
                n += 1;
            });
            out.len[j] = n;
        }
        out
    }

    /// The levels of [`Self::taps`] as `(level, weight)` (the probe mean's
    /// `1/count` times the trilinear weight), and how many are read: the
    /// level below `lod` (clamped to `0..levels`) and, when `lod` is not an
    /// integer below the top, the one above.
    #[inline(always)]
    #[must_use]
    pub fn level_weights(&self, levels: usize) -> ([(usize, f32); 2], usize) {
        self.level_weights_times(levels, 1.0 / self.count as f32)
    }

    /// [`Self::level_weights`] of one probe (without the probes' `1/count`):
    /// a probe's own trilinear sample.
    #[inline(always)]
    #[must_use]
    pub fn probe_level_weights(&self, levels: usize) -> ([(usize, f32); 2], usize) {
        self.level_weights_times(levels, 1.0)
    }

    /// The trilinear levels' weights times `w`.
    #[inline(always)]
    fn level_weights_times(&self, levels: usize, w: f32) -> ([(usize, f32); 2], usize) {
        let top = (levels - 1) as f32;
        let lod = self.lod.clamp(0.0, top);
        // `lod ≥ 0` (or NaN, which casts to 0 either way): truncation is
        // the floor, without a `floorf` call.
        let k0 = lod as usize;
        let t = lod - k0 as f32;
        let first = (k0, (1.0 - t) * w);
        if t > 0.0 && k0 + 1 < levels {
            ([first, (k0 + 1, t * w)], 2)
        } else {
            ([first, first], 1)
        }
    }

    /// Visits the bilinear taps of every probe on one level of size `dims`,
    /// in [`Self::taps`]' order: `add(texel, weight × wk)`. Inlined into a
    /// sampler's own loop, its accumulators stay in registers and no tap
    /// list is written.
    #[inline(always)]
    pub fn visit_level(&self, dims: (usize, usize), wk: f32, mut add: impl FnMut(usize, f32)) {
        let (lw, lh) = dims;
        if lw.is_power_of_two() && lh.is_power_of_two() {
            #[cfg(target_arch = "x86_64")]
            if let Some((index, weight)) = sse2::probe_taps_pow2(&self.probes, lw, lh, wk) {
                for p in 0..self.count {
                    for t in 0..4 {
                        add(index[t][p] as usize, weight[t][p]);
                    }
                }
                return;
            }
            for p in self.probes() {
                for (i, wt) in taps_pow2(lw, lh, *p) {
                    add(i, wt * wk);
                }
            }
        } else {
            for p in self.probes() {
                for (i, wt) in taps(lw, lh, *p) {
                    add(i, wt * wk);
                }
            }
        }
    }

    /// Each probe's four bilinear taps on one level of size `dims`, weights
    /// times `wk` (the first [`Self::count`] are set): [`Self::visit_level`]'s
    /// taps, the same products, a probe at a time. An array, not a visitor:
    /// a visitor closure was left out of line (outside the caller's AVX2
    /// copy, 17 % of a frame with a mask per probe).
    #[inline(always)]
    pub fn level_taps(&self, dims: (usize, usize), wk: f32) -> [[(usize, f32); 4]; MAX_PROBES] {
        let (lw, lh) = dims;
        let mut out = [[(0, 0.0); 4]; MAX_PROBES];
        if lw.is_power_of_two() && lh.is_power_of_two() {
            #[cfg(target_arch = "x86_64")]
            if let Some((index, weight)) = sse2::probe_taps_pow2(&self.probes, lw, lh, wk) {
                for (p, o) in out.iter_mut().enumerate().take(self.count) {
                    for (t, tap) in o.iter_mut().enumerate() {
                        *tap = (index[t][p] as usize, weight[t][p]);
                    }
                }
                return out;
            }
            for (o, p) in out.iter_mut().zip(self.probes()) {
                *o = taps_pow2(lw, lh, *p);
                for (_, w) in o.iter_mut() {
                    *w *= wk;
                }
            }
        } else {
            for (o, p) in out.iter_mut().zip(self.probes()) {
                *o = taps(lw, lh, *p);
                for (_, w) in o.iter_mut() {
                    *w *= wk;
                }
            }
        }
        out
    }

    /// Visits every texel tap of the footprint: `add(level, texel, weight)`
    /// for the taps of [`Self::taps`], in order.
    #[inline]
    pub fn for_each_tap(
        &self,
        levels: usize,
        dims: impl Fn(usize) -> (usize, usize),
        mut add: impl FnMut(usize, usize, f32),
    ) {
        let t = self.taps(levels, dims);
        for j in 0..t.count {
            for (i, w) in t.level(j) {
                add(t.levels[j], i, w);
            }
        }
    }
}

/// The mean over `fp`'s probes of a linear pyramid ([`sample_pyramid`]).
#[must_use]
pub fn sample_footprint<T: Linear>(levels: &[(usize, usize, Vec<T>)], fp: &Footprint) -> T {
    let t = fp.taps(levels.len(), |k| (levels[k].0, levels[k].1));
    let mut acc = T::ZERO;
    for j in 0..t.count {
        let texels = &levels[t.levels[j]].2;
        for (i, w) in t.level(j) {
            acc = acc.add_scaled(w, texels[i]);
        }
    }
    acc
}

/// A per-texel quantity that MIP-filters linearly (box averages and
/// trilinear taps are weighted sums): the mean normal, LEAN's moments.
pub trait Linear: Copy + Send + Sync {
    const ZERO: Self;
    /// `self + w·x`.
    #[must_use]
    fn add_scaled(self, w: f32, x: Self) -> Self;
}

impl Linear for Vec3 {
    const ZERO: Self = Vec3::ZERO;
    #[inline]
    fn add_scaled(self, w: f32, x: Self) -> Self {
        self + x * w
    }
}

/// The box-average MIP chain of `width × height` texels, level 0 first,
/// down to 1 × 1. A coarse texel is the average of the fine texels under it
/// (odd sizes: the edge texels count by the fine texels they cover), so it
/// is exactly the mean over its footprint.
#[must_use]
pub fn box_pyramid<T: Linear>(
    width: usize,
    height: usize,
    texels: Vec<T>,
) -> Vec<(usize, usize, Vec<T>)> {
    let mut levels = vec![(width, height, texels)];
    let mut counts = vec![1.0f32; width * height];
    while let Some((w, h, m)) = levels.last().filter(|(w, h, _)| *w > 1 || *h > 1) {
        let (w, h) = (*w, *h);
        let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
        let mut next = vec![T::ZERO; nw * nh];
        let mut nc = vec![0.0f32; nw * nh];
        next.par_iter_mut()
            .zip(nc.par_iter_mut())
            .enumerate()
            .for_each(|(i, (d, c))| {
                let (x, y) = (i % nw, i / nw);
                let mut s = T::ZERO;
                for cy in 2 * y..(2 * y + 2).min(h) {
                    for cx in 2 * x..(2 * x + 2).min(w) {
                        let j = cy * w + cx;
                        s = s.add_scaled(counts[j], m[j]);
                        *c += counts[j];
                    }
                }
                *d = T::ZERO.add_scaled(1.0 / *c, s);
            });
        levels.push((nw, nh, next));
        counts = nc;
    }
    levels
}

/// Trilinear lookup in a [`box_pyramid`] at `uv` (wrap-around) and level
/// `lod` (clamped to the chain).
#[inline]
#[must_use]
pub fn sample_pyramid<T: Linear>(levels: &[(usize, usize, Vec<T>)], uv: Vec2, lod: f32) -> T {
    let top = (levels.len() - 1) as f32;
    let lod = lod.clamp(0.0, top);
    let k0 = lod.floor() as usize;
    let t = lod - k0 as f32;
    let at = |k: usize, wk: f32, acc: T| {
        let (w, h, m) = &levels[k];
        taps(*w, *h, uv)
            .iter()
            .fold(acc, |a, &(i, wt)| a.add_scaled(wt * wk, m[i]))
    };
    if t > 0.0 && k0 + 1 < levels.len() {
        at(k0 + 1, t, at(k0, 1.0 - t, T::ZERO))
    } else {
        at(k0, 1.0, T::ZERO)
    }
}

/// Mean normal per texel per level (unnormalized: `|m| ≤ 1` measures the
/// spread), box averages of the fine normals as [`ShNdfPyramid`].
#[derive(Clone, Debug, PartialEq)]
pub struct MeanPyramid {
    /// `(width, height, means)` from level 0 down to 1 × 1.
    pub levels: Vec<(usize, usize, Vec<Vec3>)>,
}

impl MeanPyramid {
    /// Builds it from `width × height` unit normals.
    #[must_use]
    pub fn build(width: usize, height: usize, normals: &[Vec3]) -> Self {
        Self {
            levels: box_pyramid(width, height, normals.to_vec()),
        }
    }

    /// Trilinear lookup (exact averaging: the mean normal is linear).
    #[inline]
    #[must_use]
    pub fn sample(&self, uv: Vec2, lod: f32) -> Vec3 {
        sample_pyramid(&self.levels, uv, lod)
    }

    /// The mean over an anisotropic footprint's probes.
    #[must_use]
    pub fn sample_footprint(&self, fp: &Footprint) -> Vec3 {
        sample_footprint(&self.levels, fp)
    }
}

/// Errors of the NDF crate, each naming its input.
#[derive(Debug, thiserror::Error)]
pub enum NdfError {
    #[error("normal map: {0}")]
    Texture(#[from] relight_render::TextureError),
    #[error("invalid parameter `{what}`: {why}")]
    InvalidParameter { what: &'static str, why: String },
    #[error(transparent)]
    Raster(#[from] relight_render::raster::RasterError),
    #[error(transparent)]
    Sh(#[from] relight_sh::ShError),
    #[error("NDF rendering cancelled")]
    Cancelled,
}

impl From<relight_render::Cancelled> for NdfError {
    fn from(_: relight_render::Cancelled) -> Self {
        Self::Cancelled
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_positive_is_ceil() {
        let mut q = 0.0f32;
        for v in [
            0.0,
            1e-7,
            0.5,
            1.0,
            1.0 + f32::EPSILON,
            2.5,
            3.0,
            3.999_999,
            4.0,
        ] {
            assert_eq!(ceil_positive(v), v.ceil() as usize, "{v}");
        }
        for v in [8_388_607.5f32, 16_777_216.0, 1e12, 1e30] {
            assert_eq!(ceil_positive(v), v.ceil() as usize, "{v}");
        }
        while q < 70.0 {
            assert_eq!(ceil_positive(q), q.ceil() as usize, "{q}");
            q += 0.013;
        }
    }

    #[test]
    fn footprints_in_squares_are_the_footprints_in_lengths() {
        // Same probe count (away from a ratio at an integer, where rounding
        // may tip it), same probes, level and plain share within 2e-6.
        let mut rng = crate::vmf::Xorshift(0x005e_ed0f_f00f);
        let mut worst = 0.0f32;
        let mut tipped = 0;
        for k in 0..200_000 {
            let scale = [1e-4, 3e-3, 0.05, 2.0][k % 4];
            let mut r = || ((rng.next_f64() * 2.0 - 1.0) * scale) as f32;
            let (dx, dy) = (Vec2::new(r(), r()), Vec2::new(r(), r()));
            let uv = Vec2::new(0.3, 0.7);
            let (a, b) = (
                Footprint::of(uv, dx, dy, 512, 256),
                Footprint::of_lengths(uv, dx, dy, 512, 256),
            );
            if a.count != b.count {
                let s = Vec2::new(512.0, 256.0);
                let (lx, ly) = ((dx * s).length(), (dy * s).length());
                let ratio = lx.max(ly) / lx.min(ly).max(1e-6);
                assert!((ratio - ratio.round()).abs() < 1e-5, "{ratio}: {a:?} {b:?}");
                tipped += 1;
                continue;
            }
            assert_eq!(a.probes, b.probes);
            worst = worst
                .max((a.lod - b.lod).abs())
                .max((a.plain - b.plain).abs());
        }
        assert!(worst <= 2e-6, "level differs by {worst}");
        assert!(tipped < 10, "{tipped} counts tipped");
        // Past f32's squares: the lengths' form.
        let big = Vec2::new(1e30, 0.0);
        assert_eq!(
            Footprint::of(Vec2::ZERO, big, Vec2::Y, 64, 64),
            Footprint::of_lengths(Vec2::ZERO, big, Vec2::Y, 64, 64)
        );
    }

    #[test]
    fn visited_taps_are_the_per_probe_taps() {
        // `visit_level` (the SSE2 lanes on x86-64) against `taps` per probe
        // times the level weight, bit for bit, on footprints of 1–4 probes
        // that wrap, and past the 2^23 bound (the scalar path).
        let mut rng = crate::vmf::Xorshift(0x0ddb_a11c_afef_00d1);
        for (w, h) in [(1, 1), (4, 2), (64, 64), (512, 512), (48, 64), (3, 5)] {
            for k in 0..3000 {
                let scale = [1.0, 20.0, 3e3, 1e5][k % 4];
                let mut r = || ((rng.next_f64() * 2.0 - 1.0) * scale) as f32;
                let uv = Vec2::new(r(), r());
                let (dx, dy) = (Vec2::new(r(), r()) * 0.01, Vec2::new(r(), r()) * 0.002);
                let fp = Footprint::of(uv, dx, dy, w, h);
                let wk = 0.37;
                let mut got = Vec::new();
                fp.visit_level((w, h), wk, |i, x| got.push((i, x.to_bits())));
                let want: Vec<(usize, u32)> = fp
                    .probes()
                    .iter()
                    .flat_map(|p| taps(w, h, *p))
                    .map(|(i, x)| (i, (x * wk).to_bits()))
                    .collect();
                assert_eq!(got, want, "{w}×{h} {fp:?}");
            }
        }
    }

    #[test]
    fn power_of_two_taps_are_the_general_taps() {
        // Every wrap case: inside, one texel beyond either edge, many tiles
        // out (both signs), near the exactness bound and past it.
        let mut rng = crate::vmf::Xorshift(0x1234_5678_9abc_def1);
        for (w, h) in [(1, 1), (1, 4), (2, 2), (8, 4), (64, 64), (512, 512)] {
            for _ in 0..4000 {
                let scale = [1.0, 3.0, 40.0, 2e4][(rng.next_f64() * 4.0) as usize];
                let u = ((rng.next_f64() * 2.0 - 1.0) * scale) as f32;
                let v = ((rng.next_f64() * 2.0 - 1.0) * scale) as f32;
                let uv = Vec2::new(u, v);
                assert_eq!(taps_pow2(w, h, uv), taps(w, h, uv), "{w}×{h} at {uv}");
            }
            for uv in [
                Vec2::ZERO,
                Vec2::ONE,
                Vec2::new(-0.5 / w as f32, 1.0 - 0.5 / h as f32),
                Vec2::new(1e9, -1e9),
                Vec2::new(f32::NAN, 0.3),
            ] {
                let (a, b) = (taps_pow2(w, h, uv), taps(w, h, uv));
                for (p, q) in a.iter().zip(&b) {
                    assert_eq!(p.0, q.0, "{w}×{h} at {uv}");
                    assert_eq!(p.1.to_bits(), q.1.to_bits(), "{w}×{h} at {uv}");
                }
            }
        }
    }
}
