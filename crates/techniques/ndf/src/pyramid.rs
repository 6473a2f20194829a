//! The vMF-mixture MIP pyramid (Han et al. 2007 §4): `J` lobes per texel,
//! every level fitted by spherical EM ([`crate::em`]) to the fine normals
//! under the texel (all of them, or a stratified sample past
//! [`VmfBakeOptions::max_samples`]).
//!
//! # Coherent slots
//! The fit runs top-down: the 1 × 1 level starts from k-means++
//! ([`crate::em::seed_lobes`]); every finer texel starts from its parent's
//! lobes, slot by slot, so slot `j` of a texel and slot `j` of its parent and
//! neighbours describe the same cluster of normals. Level 0 holds one lobe
//! (the texel's normal, κ at [`KAPPA_MAX`], i.e. a delta: plain normal
//! mapping) in the slot of its level-1 parent whose lobe is most responsible
//! for that normal; the other slots have α = 0.
//!
//! # Storage: linear filtering is the moment-matching merge
//! A lobe is stored as 4 f32: `(α, α·r·μ)` with `r = A(κ)` its mean
//! resultant length (`E[n] = r μ` under the lobe). A weighted average of two
//! texels' slot `j` is then `(Σ w α, Σ w α r μ)`: the merged weight and the
//! merged lobe's first moment, from which `μ = m/|m|`, `r = |m|/α` and
//! `κ = A⁻¹(r)` — the vMF matching the mean of the merged normals (Han et
//! al. §4.3). So bilinear and trilinear filtering of the raw texels are
//! meaningful.

use crate::em::{EmOptions, Lobe, fit_em, seed_lobes};
use crate::sh_ndf::{level_count, level_size};
use crate::vmf::{KAPPA_MAX, Vmf, mean_resultant};
use glam::{DVec3, Vec3, Vec4};
use rayon::prelude::*;

/// The first bytes of [`VmfPyramid::to_bytes`], with the format's version:
/// bump it when the layout or the fit changes (`002`: the CRC-32 trailer,
/// and the vectorized E-step's rounding).
const CACHE_MAGIC: &[u8; 8] = b"RLVMF002";

/// Largest number of lobes per texel.
pub const MAX_LOBES: usize = 8;

/// Settings of the vMF bake.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VmfBakeOptions {
    /// Lobes per texel J (1..=[`MAX_LOBES`]). Default 6 (the thesis' figures).
    pub lobes: usize,
    /// EM stopping rule at the 1 × 1 level (the start from k-means++).
    pub root: EmOptions,
    /// EM stopping rule below it (started from the parent, so it converges
    /// in few iterations). Default 20 iterations, 1e-5 nats.
    pub child: EmOptions,
    /// Most normals one texel's fit reads: a larger footprint is sampled
    /// one normal per block of a square grid (stratified, at hashed places),
    /// so that every level past `√max_samples` texels a side costs a
    /// fraction of the one below. Default 1024 (a 32 × 32 grid);
    /// `usize::MAX` reads every normal.
    pub max_samples: usize,
}

impl Default for VmfBakeOptions {
    fn default() -> Self {
        Self {
            lobes: 6,
            root: EmOptions::default(),
            child: EmOptions {
                max_iter: 20,
                tol: 1e-5,
            },
            max_samples: 1024,
        }
    }
}

/// One level: `J` packed lobes per texel (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct VmfLevel {
    pub width: usize,
    pub height: usize,
    /// `lobes[(y·width + x)·J + j] = (α, α r μ)`.
    pub lobes: Vec<Vec4>,
}

/// [`VmfPyramid::sample_footprint`] for `J` lobes: `out[j] = Σ w · lobe_j`
/// over the footprint's taps, in [`crate::Footprint::taps`]' order.
#[inline(always)]
fn sample_taps<const J: usize>(levels: &[VmfLevel], fp: &crate::Footprint, out: &mut [Vec4]) {
    // Plain f32 lanes rather than `Vec4`s (glam's are 128-bit registers):
    // the AVX2 copy then adds two lobes per 256-bit operation.
    let mut acc = [[0.0f32; 4]; J];
    let (lv, count) = fp.level_weights(levels.len());
    for &(k, wk) in &lv[..count] {
        let l = &levels[k];
        let (texels, _) = l.lobes.as_chunks::<J>();
        fp.visit_level((l.width, l.height), wk, |i, w| {
            for (a, v) in acc.iter_mut().zip(&texels[i]) {
                let v: &[f32; 4] = v.as_ref();
                for c in 0..4 {
                    a[c] += v[c] * w;
                }
            }
        });
    }
    for (o, a) in out[..J].iter_mut().zip(acc) {
        *o = Vec4::from_array(a);
    }
}

/// The pyramid.
#[derive(Clone, Debug, PartialEq)]
pub struct VmfPyramid {
    pub lobes: usize,
    /// Level 0 first.
    pub levels: Vec<VmfLevel>,
}

/// Packs a lobe as `(α, α A(κ) μ)`.
#[must_use]
pub fn pack(l: &Lobe) -> Vec4 {
    let m = l.vmf.mu * (l.alpha * mean_resultant(l.vmf.kappa));
    Vec4::new(l.alpha as f32, m.x as f32, m.y as f32, m.z as f32)
}

/// A decoded lobe for shading: weight, unit axis and `1/κ` (0 at the clamp).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadeLobe {
    pub alpha: f32,
    pub mu: Vec3,
    pub inv_kappa: f32,
}

impl ShadeLobe {
    /// The lobe's mean normal `A(κ) μ` (`μ` for a delta).
    #[inline]
    #[must_use]
    pub fn mean_normal(&self) -> Vec3 {
        if self.inv_kappa <= 0.0 {
            return self.mu;
        }
        self.mu * mean_resultant(f64::from(1.0 / self.inv_kappa)) as f32
    }
}

/// Unpacks a (possibly filtered) lobe; `None` when its weight is below 1e-6.
/// κ from the first moment by [`crate::vmf::kappa_estimate`]; a lobe at the
/// clamp's resultant (or beyond) is a delta (`inv_kappa = 0`).
#[inline]
#[must_use]
pub fn unpack(p: Vec4) -> Option<ShadeLobe> {
    if p.x <= 1e-6 {
        return None;
    }
    let m = Vec3::new(p.y, p.z, p.w) / p.x;
    let r = m.length();
    if r <= 0.0 {
        return None;
    }
    // f32 holds `1 − r` to ~1e-7: a resultant within half the clamp's
    // distance of 1 more (κ ≳ ⅔ KAPPA_MAX) is the clamped lobe.
    let r_clamp = 1.0 - 1.5 / KAPPA_MAX as f32;
    let inv_kappa = if r >= r_clamp {
        0.0
    } else {
        1.0 / crate::vmf::kappa_estimate(r)
    };
    Some(ShadeLobe {
        alpha: p.x,
        mu: m / r,
        inv_kappa,
    })
}

/// [`unpack`] with three divisions where it takes eight (`1/α`, `1/r`, and
/// `1/κ` as `(1 − r²)/(r (3 − r²))` clamped as [`crate::vmf::kappa_estimate`]
/// clamps κ): the renderer's per-pixel form, the same lobe up to f32
/// rounding (tested).
#[inline]
#[must_use]
pub fn unpack_fast(p: Vec4) -> Option<ShadeLobe> {
    if p.x <= 1e-6 {
        return None;
    }
    let m = Vec3::new(p.y, p.z, p.w) * (1.0 / p.x);
    let r = m.length();
    if r.is_nan() {
        return unpack(p);
    }
    if r <= 0.0 {
        return None;
    }
    let r_clamp = 1.0 - 1.5 / KAPPA_MAX as f32;
    let inv_kappa = if r >= r_clamp {
        0.0
    } else {
        // `r < r_clamp` is below `kappa_estimate`'s cap on r.
        let r2 = r * r;
        ((1.0 - r2) / (r * (3.0 - r2)))
            .clamp(1.0 / KAPPA_MAX as f32, 1.0 / crate::vmf::KAPPA_MIN as f32)
    };
    Some(ShadeLobe {
        alpha: p.x,
        mu: m * (1.0 / r),
        inv_kappa,
    })
}

/// A footprint with at most `J` distinct normals is represented exactly: one
/// delta (κ at the clamp) per distinct normal, with weight its share, each in
/// the free slot whose parent lobe explains it best (greedy, heaviest
/// normal first); the other slots keep the parent's lobe with α = 0.
fn exact_deltas(
    samples: &[DVec3],
    weights: &[f64],
    parent: Option<&[Lobe]>,
    j: usize,
) -> Vec<Lobe> {
    let total: f64 = weights.iter().sum();
    let mut out: Vec<Lobe> = match parent {
        Some(p) => p.iter().map(|l| Lobe { alpha: 0.0, ..*l }).collect(),
        None => (0..j)
            .map(|_| Lobe {
                alpha: 0.0,
                vmf: Vmf {
                    mu: DVec3::Z,
                    kappa: KAPPA_MAX,
                },
            })
            .collect(),
    };
    let mut taken = vec![false; j];
    let mut order: Vec<usize> = (0..samples.len()).collect();
    order.sort_by(|&a, &b| weights[b].total_cmp(&weights[a]).then(a.cmp(&b)));
    for i in order {
        let n = samples[i];
        let score = |k: usize| match parent {
            Some(p) if p[k].alpha > 0.0 => p[k].alpha.ln() + p[k].vmf.density(n).max(1e-300).ln(),
            Some(p) => -1e300 + p[k].vmf.mu.dot(n),
            None => -(k as f64),
        };
        let slot = (0..j)
            .filter(|&k| !taken[k])
            .max_by(|&a, &b| score(a).total_cmp(&score(b)))
            .expect("at most j samples");
        taken[slot] = true;
        out[slot] = Lobe {
            alpha: weights[i] / total,
            vmf: Vmf {
                mu: n,
                kappa: KAPPA_MAX,
            },
        };
    }
    out
}

/// The fine-texel rectangle under texel `(x, y)` of level `k`.
fn footprint(w: usize, h: usize, k: usize, x: usize, y: usize) -> (usize, usize, usize, usize) {
    let s = 1usize << k;
    (x * s, (x * s + s).min(w), y * s, (y * s + s).min(h))
}

/// A 64-bit hash of a texel position (splitmix64 of `x`, `y`), placing the
/// stratified samples of [`VmfBakeOptions::max_samples`].
fn stratum_hash(x: usize, y: usize) -> u64 {
    let mut z = (x as u64) << 32 ^ (y as u64) ^ 0x9e37_79b9_7f4a_7c15;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Per-thread buffers: unique normals and weights of one footprint.
#[derive(Default)]
struct Scratch {
    ids: Vec<u32>,
    samples: Vec<DVec3>,
    weights: Vec<f64>,
}

impl VmfPyramid {
    /// Fits the pyramid of `width × height` unit normals (module docs).
    /// Identical normals are merged into weighted samples first (8-bit normal
    /// maps repeat them), which changes nothing but the cost.
    #[must_use]
    pub fn build(width: usize, height: usize, normals: &[Vec3], opts: &VmfBakeOptions) -> Self {
        let j = opts.lobes.clamp(1, MAX_LOBES);
        // Unique normals by bit pattern.
        let mut order: Vec<u32> = (0..normals.len() as u32).collect();
        let key = |i: u32| {
            let n = normals[i as usize];
            (n.x.to_bits(), n.y.to_bits(), n.z.to_bits())
        };
        order.par_sort_unstable_by_key(|&i| key(i));
        let mut id = vec![0u32; normals.len()];
        let mut unique: Vec<DVec3> = Vec::new();
        for (k, &i) in order.iter().enumerate() {
            if k == 0 || key(order[k - 1]) != key(i) {
                unique.push(normals[i as usize].as_dvec3());
            }
            id[i as usize] = (unique.len() - 1) as u32;
        }
        let nl = level_count(width, height);
        let mut fitted: Vec<Vec<Lobe>> = Vec::with_capacity(nl);
        let mut levels: Vec<VmfLevel> = Vec::with_capacity(nl);
        for k in (1..nl).rev() {
            let (lw, lh) = level_size(width, height, k);
            let parent = fitted.last();
            let lobes: Vec<Lobe> = (0..lw * lh)
                .into_par_iter()
                .with_min_len(1)
                .map_init(Scratch::default, |s, t| {
                    let (x, y) = (t % lw, t / lw);
                    let (x0, x1, y0, y1) = footprint(width, height, k, x, y);
                    s.ids.clear();
                    let area = (x1 - x0) * (y1 - y0);
                    if area <= opts.max_samples.max(1) {
                        for yy in y0..y1 {
                            s.ids
                                .extend_from_slice(&id[yy * width + x0..yy * width + x1]);
                        }
                    } else {
                        // One normal per b × b block, at a hashed place in it
                        // (stratified, deterministic).
                        let b = (area as f64 / opts.max_samples as f64).sqrt().ceil() as usize;
                        for by in (y0..y1).step_by(b) {
                            for bx in (x0..x1).step_by(b) {
                                let h = stratum_hash(bx, by);
                                let ox = (h as usize) % b.min(x1 - bx);
                                let oy = ((h >> 32) as usize) % b.min(y1 - by);
                                s.ids.push(id[(by + oy) * width + bx + ox]);
                            }
                        }
                    }
                    s.ids.sort_unstable();
                    s.samples.clear();
                    s.weights.clear();
                    for (i, &u) in s.ids.iter().enumerate() {
                        if i > 0 && s.ids[i - 1] == u {
                            *s.weights.last_mut().expect("pushed") += 1.0;
                        } else {
                            s.samples.push(unique[u as usize]);
                            s.weights.push(1.0);
                        }
                    }
                    let parent_lobes = parent.map(|p| {
                        let (pw, _) = level_size(width, height, k + 1);
                        let pi = (y / 2) * pw + x / 2;
                        &p[pi * j..(pi + 1) * j]
                    });
                    if s.samples.len() <= j {
                        return exact_deltas(&s.samples, &s.weights, parent_lobes, j);
                    }
                    let (mut start, em) = match parent_lobes {
                        Some(p) => (p.to_vec(), &opts.child),
                        None => (seed_lobes(&s.samples, &s.weights, j), &opts.root),
                    };
                    // A slot the parent left empty restarts at unit weight share
                    // so the child can use it; EM sets it back to 0 if unused.
                    for l in &mut start {
                        if l.alpha <= 0.0 {
                            l.alpha = 1e-3;
                        }
                    }
                    let sum: f64 = start.iter().map(|l| l.alpha).sum();
                    for l in &mut start {
                        l.alpha /= sum;
                    }
                    fit_em(&s.samples, &s.weights, &mut start, em);
                    start
                })
                .flatten_iter()
                .collect();
            levels.push(VmfLevel {
                width: lw,
                height: lh,
                lobes: lobes.iter().map(pack).collect(),
            });
            fitted.push(lobes);
        }
        // Level 0: one delta per texel in the slot its parent explains best.
        let mut level0 = vec![Vec4::ZERO; width * height * j];
        let parent = fitted.last();
        let (pw, _) = level_size(width, height, 1);
        level0.par_chunks_mut(j).enumerate().for_each(|(i, dst)| {
            let (x, y) = (i % width, i / width);
            let n = normals[i].as_dvec3();
            let slot = match parent {
                Some(p) => {
                    let pi = (y / 2) * pw + x / 2;
                    let lobes = &p[pi * j..(pi + 1) * j];
                    (0..j)
                        .max_by(|&a, &b| {
                            let s = |l: &Lobe| {
                                if l.alpha > 0.0 {
                                    l.alpha.ln() + l.vmf.density(n).max(1e-300).ln()
                                } else {
                                    f64::NEG_INFINITY
                                }
                            };
                            s(&lobes[a]).total_cmp(&s(&lobes[b]))
                        })
                        .unwrap_or(0)
                }
                None => 0,
            };
            dst[slot] = pack(&Lobe {
                alpha: 1.0,
                vmf: Vmf {
                    mu: n,
                    kappa: KAPPA_MAX,
                },
            });
        });
        levels.push(VmfLevel {
            width,
            height,
            lobes: level0,
        });
        levels.reverse();
        Self { lobes: j, levels }
    }

    /// Trilinear lookup of the packed lobes at `uv` (wrap-around) and level
    /// `lod` into `out` (`J` entries): moment-matching merges (module docs).
    #[inline]
    pub fn sample(&self, uv: glam::Vec2, lod: f32, out: &mut [Vec4]) {
        let j = self.lobes;
        let out = &mut out[..j];
        out.fill(Vec4::ZERO);
        let top = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, top);
        let k0 = lod.floor() as usize;
        let t = lod - k0 as f32;
        let mut add = |k: usize, wk: f32| {
            let l = &self.levels[k];
            for (i, w) in crate::taps(l.width, l.height, uv) {
                for (o, v) in out.iter_mut().zip(&l.lobes[i * j..(i + 1) * j]) {
                    *o += *v * (w * wk);
                }
            }
        };
        add(k0, 1.0 - t);
        if t > 0.0 && k0 + 1 < self.levels.len() {
            add(k0 + 1, t);
        }
    }

    /// The mean of [`Self::sample`] over an anisotropic footprint's probes
    /// into `out` (`J` entries; packed moments filter linearly).
    ///
    /// Compiled for AVX2 + FMA where the CPU has them (the caller's pixel
    /// loop does not inline the eight lobe counts' copies), else for the
    /// baseline; both do the same f32 operations (no contraction): the
    /// same bits.
    #[inline]
    pub fn sample_footprint(&self, fp: &crate::Footprint, out: &mut [Vec4]) {
        self.sample_footprint_on(fp, out, true);
    }

    /// [`Self::sample_footprint`], with `simd` allowing the AVX2 + FMA copy
    /// (off only in the test that compares the two).
    #[inline]
    pub fn sample_footprint_on(&self, fp: &crate::Footprint, out: &mut [Vec4], simd: bool) {
        #[cfg(target_arch = "x86_64")]
        if simd && relight_sh::isa() >= relight_sh::Isa::Avx2 {
            // SAFETY: the CPU has AVX2 and FMA (checked above).
            unsafe { self.sample_footprint_avx2(fp, out) };
            return;
        }
        let _ = simd;
        self.sample_footprint_body(fp, out);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn sample_footprint_avx2(&self, fp: &crate::Footprint, out: &mut [Vec4]) {
        self.sample_footprint_body(fp, out);
    }

    #[inline(always)]
    fn sample_footprint_body(&self, fp: &crate::Footprint, out: &mut [Vec4]) {
        let j = self.lobes;
        let out = &mut out[..j];
        out.fill(Vec4::ZERO);
        // The lobe count as a constant: the accumulators stay in registers.
        match j {
            1 => sample_taps::<1>(&self.levels, fp, out),
            2 => sample_taps::<2>(&self.levels, fp, out),
            3 => sample_taps::<3>(&self.levels, fp, out),
            4 => sample_taps::<4>(&self.levels, fp, out),
            5 => sample_taps::<5>(&self.levels, fp, out),
            6 => sample_taps::<6>(&self.levels, fp, out),
            7 => sample_taps::<7>(&self.levels, fp, out),
            _ => sample_taps::<8>(&self.levels, fp, out),
        }
    }

    /// Packed lobes of texel `(x, y)` of level `k`.
    #[must_use]
    pub fn texel(&self, k: usize, x: usize, y: usize) -> &[Vec4] {
        let l = &self.levels[k];
        let i = y * l.width + x;
        &l.lobes[i * self.lobes..(i + 1) * self.lobes]
    }

    /// The pyramid as bytes (the disk cache's format, little-endian): the
    /// magic `RLVMF002`, `J` and the level count as u32, then per level its
    /// width and height (u32) and `width·height·J` packed lobes (4 × f32),
    /// then the CRC-32 of everything before it (u32).
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(16 + self.bytes() as usize + 8 * self.levels.len());
        out.extend_from_slice(CACHE_MAGIC);
        out.extend_from_slice(&(self.lobes as u32).to_le_bytes());
        out.extend_from_slice(&(self.levels.len() as u32).to_le_bytes());
        for l in &self.levels {
            out.extend_from_slice(&(l.width as u32).to_le_bytes());
            out.extend_from_slice(&(l.height as u32).to_le_bytes());
            for v in &l.lobes {
                for c in v.to_array() {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// Reads [`Self::to_bytes`]; `None` for anything else (wrong magic or
    /// version, a CRC that does not match, sizes that do not add up, a chain
    /// that does not halve to 1 × 1).
    #[must_use]
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        let (b, crc) = b.split_at_checked(b.len().checked_sub(4)?)?;
        if crc32fast::hash(b).to_le_bytes() != crc {
            return None;
        }
        let mut at = 0usize;
        let mut take = |n: usize| -> Option<&[u8]> {
            let s = b.get(at..at.checked_add(n)?)?;
            at += n;
            Some(s)
        };
        if take(8)? != CACHE_MAGIC {
            return None;
        }
        let rd = |s: &[u8]| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize;
        let j = rd(take(4)?);
        let nl = rd(take(4)?);
        if !(1..=MAX_LOBES).contains(&j) || nl == 0 || nl > 40 {
            return None;
        }
        let mut levels = Vec::with_capacity(nl);
        for k in 0..nl {
            let (w, h) = (rd(take(4)?), rd(take(4)?));
            let n = w.checked_mul(h)?.checked_mul(j)?;
            let raw = take(n.checked_mul(16)?)?;
            let lobes = raw
                .chunks_exact(16)
                .map(|c| {
                    let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                    Vec4::new(f(0), f(4), f(8), f(12))
                })
                .collect();
            if k > 0 {
                let first: &VmfLevel = &levels[0];
                if level_size(first.width, first.height, k) != (w, h) {
                    return None;
                }
            }
            levels.push(VmfLevel {
                width: w,
                height: h,
                lobes,
            });
        }
        let l0: &VmfLevel = &levels[0];
        if level_count(l0.width, l0.height) != nl || at != b.len() {
            return None;
        }
        Some(Self { lobes: j, levels })
    }

    /// Bytes over the whole chain.
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.levels
            .iter()
            .map(|l| (l.lobes.len() * 16) as u64)
            .sum()
    }
}
