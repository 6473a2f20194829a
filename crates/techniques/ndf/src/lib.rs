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
//! * [`vmf`]: the lobe, `A(κ)` and its inverse, `A_l(κ)` by backward recurrence.
//! * [`effective`]: effective BRDFs (Lambert; Blinn–Phong `s′ = κs/(κ+s)`;
//!   GGX/Beckmann `α′² = α² + 2/κ`) and the baselines.
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
pub mod lean;
pub mod method;
pub mod pyramid;
pub mod sh_ndf;
pub mod verify;
pub mod vmf;

pub use effective::{Baseline, NdfBrdf};
pub use lean::{LeanPyramid, LeanTexel};
pub use method::{NDF_METHOD_NAME, NdfFilter, NdfMethod, NdfOptions};
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
/// where the OpenGL rule's `log2 ρ` ([`lod_of`]) blurs twice as wide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub probes: [Vec2; MAX_PROBES],
    /// Probes in use (≥ 1).
    pub count: usize,
    /// The level every probe reads.
    pub lod: f32,
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
        }
    }

    /// The footprint of a pixel at `uv` with screen derivatives `duv_dx`,
    /// `duv_dy` on a `width × height` map (type docs); isotropic or
    /// magnified footprints get one probe.
    #[must_use]
    pub fn of(uv: Vec2, duv_dx: Vec2, duv_dy: Vec2, width: usize, height: usize) -> Self {
        let s = Vec2::new(width as f32, height as f32);
        let (lx, ly) = ((duv_dx * s).length(), (duv_dy * s).length());
        let (major, minor, axis) = if lx >= ly {
            (lx, ly, duv_dx)
        } else {
            (ly, lx, duv_dy)
        };
        let level = |rho: f32| {
            if rho > 1.0 {
                0.5 * ((rho * rho + 2.0) / 3.0).log2()
            } else {
                0.0
            }
        };
        if !(major.is_finite() && minor.is_finite()) || major <= 1.0 {
            return Self::point(uv, 0.0);
        }
        let n = ((major / minor.max(1e-6)).ceil() as usize).clamp(1, MAX_PROBES);
        let lod = level((major / n as f32).max(minor));
        let mut probes = [uv; MAX_PROBES];
        for (i, p) in probes.iter_mut().enumerate().take(n) {
            *p = uv + axis * ((i as f32 + 0.5) / n as f32 - 0.5);
        }
        Self {
            probes,
            count: n,
            lod,
        }
    }

    /// The probes in use.
    #[must_use]
    pub fn probes(&self) -> &[Vec2] {
        &self.probes[..self.count]
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
        let top = (levels - 1) as f32;
        let lod = self.lod.clamp(0.0, top);
        let k0 = lod.floor() as usize;
        let t = lod - k0 as f32;
        let w = 1.0 / self.count as f32;
        let mut out = FootprintTaps {
            levels: [k0, k0],
            count: 1,
            index: [[0; MAX_LEVEL_TAPS]; 2],
            weight: [[0.0; MAX_LEVEL_TAPS]; 2],
            len: [0; 2],
        };
        // A nested function, not a closure: it is inlined into the samplers.
        #[inline(always)]
        fn level(
            out: &mut FootprintTaps,
            j: usize,
            probes: &[Vec2],
            dims: (usize, usize),
            wk: f32,
        ) {
            let (lw, lh) = dims;
            let mut n = 0;
            for p in probes {
                for (i, wt) in taps(lw, lh, *p) {
                    out.index[j][n] = i as u32;
                    out.weight[j][n] = wt * wk;
                    n += 1;
                }
            }
            out.len[j] = n;
        }
        level(&mut out, 0, self.probes(), dims(k0), (1.0 - t) * w);
        if t > 0.0 && k0 + 1 < levels {
            level(&mut out, 1, self.probes(), dims(k0 + 1), t * w);
            out.levels[1] = k0 + 1;
            out.count = 2;
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
