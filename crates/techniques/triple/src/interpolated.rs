//! §3.3's per-pixel form as a cubic in the barycentrics: per covered
//! triangle, the tensor `T[a][b][v] = Σ_c L_a,c ρ_b,c V_v,c` of its vertices'
//! lighting, BRDF and visibility functions, so that a pixel's Eq. 7 with the
//! interpolated functions `L_p = Σ_a λ_a L_a`, `ρ_p = Σ_b λ_b ρ_b`,
//! `V_p = Σ_v λ_v V_v` is
//!
//! `B_p = Σ_c L_p,c ρ_p,c V_p,c = Σ_{a,b,v} λ_a λ_b λ_v T[a][b][v]`
//!
//! exactly (the product is trilinear in the three functions), per RGB
//! channel. The 27 terms of that sum are only ten distinct cubic monomials
//! `λ_i λ_j λ_k` (i ≤ j ≤ k, [`MONOMIALS`]), so a triangle keeps per channel
//! the ten coefficients `C_m = Σ_{(a,b,v) sorts to m} T[a][b][v]`: the 27
//! products of a cell go into ten sums instead of 27, a quarter of the
//! memory and of the horizontal sums, and a pixel evaluates a cubic of ten
//! terms. A triangle costs `3·(9 + 27)` multiply-adds per cell
//! ([`FMA_PER_TRIANGLE_CELL`]), once per frame for each triangle some pixel
//! shows; each pixel then costs [`FMA_PER_PIXEL`] whatever the number of
//! cells, instead of [`crate::shade::FMA_PER_CELL_INTERPOLATED`] per cell.
//! At n = 80 (64 padded cells) a triangle pays for itself from about four
//! pixels. Objects with visibility textures (whose visibility is not a
//! vertex function) keep the per-pixel kernel.

use glam::Vec3;
use rayon::prelude::*;

/// Multiply-adds per cell of one triangle's tensor: per channel, nine
/// `L_a ρ_b` products and 27 dot products with the visibility.
pub const FMA_PER_TRIANGLE_CELL: usize = 3 * (9 + 27);

/// Multiply-adds per pixel: the six quadratic and ten cubic monomials,
/// then ten per channel.
pub const FMA_PER_PIXEL: usize = 6 + 10 + 3 * 10;

/// The ten cubic monomials `λ_i λ_j λ_k`, i ≤ j ≤ k, of the barycentrics, in
/// the order of a triangle's coefficients.
pub const MONOMIALS: [[usize; 3]; 10] = [
    [0, 0, 0],
    [0, 0, 1],
    [0, 0, 2],
    [0, 1, 1],
    [0, 1, 2],
    [0, 2, 2],
    [1, 1, 1],
    [1, 1, 2],
    [1, 2, 2],
    [2, 2, 2],
];

/// Coefficients per triangle: ten per channel.
const COEFFS: usize = 3 * MONOMIALS.len();

/// `MONOMIAL_OF[a][b][v]`: the index in [`MONOMIALS`] of `(a, b, v)` sorted.
const MONOMIAL_OF: [[[usize; 3]; 3]; 3] = monomial_of();

const fn monomial_of() -> [[[usize; 3]; 3]; 3] {
    let mut out = [[[0; 3]; 3]; 3];
    let mut m = 0;
    while m < MONOMIALS.len() {
        let [i, j, k] = MONOMIALS[m];
        // Every ordering of (i, j, k).
        let perms = [
            [i, j, k],
            [i, k, j],
            [j, i, k],
            [j, k, i],
            [k, i, j],
            [k, j, i],
        ];
        let mut p = 0;
        while p < perms.len() {
            let [a, b, v] = perms[p];
            out[a][b][v] = m;
            p += 1;
        }
        m += 1;
    }
    out
}

/// One object's vertex functions (f32 rows of three channel planes of
/// `padded` cells; visibility one plane per vertex, `None`: V ≡ 1).
pub struct ObjectFunctions<'a> {
    pub indices: &'a [[u32; 3]],
    pub light: &'a [f32],
    pub brdf: &'a [f32],
    /// A spatially varying blend's second BRDF.
    pub second: Option<&'a [f32]>,
    pub vis: Option<&'a [f32]>,
}

/// The tensors of the covered triangles of one frame (module docs).
#[derive(Default)]
pub struct TriangleTables {
    /// First global triangle id per object, and the total.
    offsets: Vec<usize>,
    /// Per global triangle: its tensor's index, or `u32::MAX`.
    slot: Vec<u32>,
    /// Per built triangle, `[channel][monomial]` ([`MONOMIALS`]); of the
    /// second BRDF after them when an object has one (`second_base`).
    terms: Vec<[f32; COEFFS]>,
    /// Where a triangle's second-BRDF tensor sits: `terms[second_base + slot]`.
    second_base: usize,
    /// Triangles built in the last frame.
    built: usize,
}

impl TriangleTables {
    /// Builds the tensors of every triangle `triangle_ids` (the G-buffer's
    /// global ids) shows, for the objects given (`None`: the object keeps
    /// the per-pixel kernel); `padded` cells per plane.
    pub fn build(
        &mut self,
        triangle_ids: &[u32],
        objects: &[Option<ObjectFunctions<'_>>],
        padded: usize,
    ) {
        self.offsets.clear();
        let mut total = 0;
        for o in objects {
            self.offsets.push(total);
            total += o.as_ref().map_or(0, |o| o.indices.len());
        }
        self.offsets.push(total);
        self.slot.clear();
        self.slot.resize(total, u32::MAX);
        // Mark the covered triangles, then number them in mesh order: the
        // tensors then read the vertex functions in the mesh's order, not
        // the screen's (rows revisit a triangle's vertices far apart).
        const COVERED: u32 = 0;
        for &id in triangle_ids {
            // `NO_TRIANGLE` (u32::MAX) is past every slot.
            if let Some(s) = self.slot.get_mut(id as usize) {
                *s = COVERED;
            }
        }
        let mut list: Vec<(usize, usize)> = Vec::new();
        for (d, o) in objects.iter().enumerate() {
            let range = self.offsets[d]..self.offsets[d + 1];
            if o.is_none() {
                self.slot[range].fill(u32::MAX);
                continue;
            }
            for (tri, s) in self.slot[range].iter_mut().enumerate() {
                if *s == COVERED {
                    *s = list.len() as u32;
                    list.push((d, tri));
                }
            }
        }
        let any_second = objects.iter().flatten().any(|o| o.second.is_some());
        self.built = list.len();
        self.second_base = if any_second { list.len() } else { 0 };
        // Every tensor of the frame is written whole below: the buffer only
        // grows (zeroing it each frame was megabytes of `memset` at
        // 512 × 384), and entries past this frame's are unread.
        let needed = list.len() * if any_second { 2 } else { 1 };
        if self.terms.len() < needed {
            self.terms.resize(needed, [0.0; COEFFS]);
        }
        let (first, second) = self.terms[..needed].split_at_mut(list.len());
        let fma = relight_isa::avx2();
        first
            .par_iter_mut()
            .zip(&list)
            .with_min_len(16)
            .for_each(|(t, &(d, tri))| {
                let o = objects[d].as_ref().expect("listed objects have functions");
                let x = TensorInput {
                    o,
                    brdf: o.brdf,
                    tri: o.indices[tri],
                    padded,
                };
                tensor(&x, t, fma);
            });
        if any_second {
            second
                .par_iter_mut()
                .zip(&list)
                .with_min_len(16)
                .for_each(|(t, &(d, tri))| {
                    let o = objects[d].as_ref().expect("listed objects have functions");
                    match o.second {
                        Some(brdf) => {
                            let x = TensorInput {
                                o,
                                brdf,
                                tri: o.indices[tri],
                                padded,
                            };
                            tensor(&x, t, fma);
                        }
                        None => *t = [0.0; COEFFS],
                    }
                });
        }
    }

    /// Triangles built in the last frame.
    #[must_use]
    pub fn built(&self) -> usize {
        self.built
    }

    /// Whether global triangle `id` has a tensor this frame.
    #[must_use]
    pub fn covers(&self, id: u32) -> bool {
        self.slot.get(id as usize).is_some_and(|&s| s != u32::MAX)
    }

    /// `B_p` (RGB) of the pixel at barycentrics `l` of object `draw`'s
    /// triangle `triangle`, and of the second BRDF when `second`; `None`
    /// when the triangle has no tensor (the per-pixel kernel shades it).
    #[inline]
    #[must_use]
    pub fn shade(&self, draw: usize, triangle: usize, l: Vec3, second: bool) -> Option<Vec3> {
        let id = self.offsets.get(draw)? + triangle;
        let s = *self.slot.get(id)?;
        if s == u32::MAX {
            return None;
        }
        let k = if second {
            self.second_base + s as usize
        } else {
            s as usize
        };
        let t = &self.terms[k];
        let q = [
            l.x * l.x,
            l.x * l.y,
            l.x * l.z,
            l.y * l.y,
            l.y * l.z,
            l.z * l.z,
        ];
        let mono = [
            q[0] * l.x,
            q[0] * l.y,
            q[0] * l.z,
            q[1] * l.y,
            q[1] * l.z,
            q[2] * l.z,
            q[3] * l.y,
            q[3] * l.z,
            q[4] * l.z,
            q[5] * l.z,
        ];
        let mut out = [0.0f32; 3];
        for (ch, o) in out.iter_mut().enumerate() {
            let c = &t[ch * MONOMIALS.len()..][..MONOMIALS.len()];
            *o = c.iter().zip(&mono).map(|(c, m)| c * m).sum();
        }
        Some(Vec3::from_array(out))
    }
}

/// `T[ch][a][b][v] = Σ_c L_a ρ_b V_v` of triangle `tri` (module docs),
/// through the AVX2 + FMA copy where `fma` ([`relight_isa::avx2`]): the default
/// x86-64 target has only 4-lane SSE and no fused multiply-add, and this loop
/// was half of a 512 × 384 interpolated frame.
fn tensor(x: &TensorInput<'_>, t: &mut [f32; COEFFS], fma: bool) {
    #[cfg(target_arch = "x86_64")]
    if fma {
        // SAFETY: AVX2 and FMA were detected at run time (`relight_isa::avx2`).
        unsafe { tensor_fma(x, t) };
        return;
    }
    let _ = fma;
    tensor_body::<false>(x, t);
}

/// What [`tensor`] reads for one triangle: the object's functions, the
/// BRDF's rows (its first or its blend's second), the triangle's vertices
/// and the padded cells per channel (rows are `3 · padded` long).
struct TensorInput<'a> {
    o: &'a ObjectFunctions<'a>,
    brdf: &'a [f32],
    tri: [u32; 3],
    padded: usize,
}

/// [`tensor_body`] compiled for AVX2 and FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn tensor_fma(x: &TensorInput<'_>, t: &mut [f32; COEFFS]) {
    tensor_body::<true>(x, t);
}

/// `a · b + c`, fused where `F`.
#[inline(always)]
fn madd<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// The ten coefficients per channel (module docs) in 8-cell chunks: per
/// chunk the three visibilities are loaded once for the channels, and per
/// channel and pair `(a, b)` the product `L_a ρ_b` once, then its three
/// multiply-adds with the visibilities into the monomials' sums (the
/// [`FMA_PER_TRIANGLE_CELL`] count).
#[inline(always)]
fn tensor_body<const F: bool>(x: &TensorInput<'_>, t: &mut [f32; COEFFS]) {
    let &TensorInput {
        o,
        brdf,
        tri,
        padded,
    } = x;
    debug_assert_eq!(padded % 8, 0, "cells are padded to whole chunks");
    let row = 3 * padded;
    let vis = o
        .vis
        .map(|v| tri.map(|i| &v[i as usize * padded..][..padded]));
    let chunk = |f: &[f32], s: usize| -> [f32; 8] { f[s..s + 8].try_into().expect("8 cells") };
    t.fill(0.0);
    for ch in 0..3 {
        let la = tri.map(|i| &o.light[i as usize * row + ch * padded..][..padded]);
        let rb = tri.map(|i| &brdf[i as usize * row + ch * padded..][..padded]);
        let out = &mut t[ch * MONOMIALS.len()..][..MONOMIALS.len()];
        match &vis {
            Some(v) => {
                let mut acc = [[0.0f32; 8]; MONOMIALS.len()];
                for s in (0..padded).step_by(8) {
                    let (l8, r8, v8) = (
                        la.map(|f| chunk(f, s)),
                        rb.map(|f| chunk(f, s)),
                        v.map(|f| chunk(f, s)),
                    );
                    for a in 0..3 {
                        for b in 0..3 {
                            let lr: [f32; 8] = std::array::from_fn(|i| l8[a][i] * r8[b][i]);
                            for (w, vw) in v8.iter().enumerate() {
                                let m = &mut acc[MONOMIAL_OF[a][b][w]];
                                for i in 0..8 {
                                    m[i] = madd::<F>(lr[i], vw[i], m[i]);
                                }
                            }
                        }
                    }
                }
                for (o, a) in out.iter_mut().zip(&acc) {
                    *o = a.iter().sum();
                }
            }
            // V ≡ 1: T[a][b][v] = Σ_c L_a ρ_b for every v.
            None => {
                for a in 0..3 {
                    for b in 0..3 {
                        let mut acc = [0.0f32; 8];
                        for (l8, r8) in la[a].chunks_exact(8).zip(rb[b].chunks_exact(8)) {
                            for i in 0..8 {
                                acc[i] = madd::<F>(l8[i], r8[i], acc[i]);
                            }
                        }
                        let p: f32 = acc.iter().sum();
                        for w in 0..3 {
                            out[MONOMIAL_OF[a][b][w]] += p;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_render::raster::NO_TRIANGLE;

    /// One object's functions without a blend.
    fn functions<'a>(
        indices: &'a [[u32; 3]],
        light: &'a [f32],
        brdf: &'a [f32],
        vis: Option<&'a [f32]>,
    ) -> ObjectFunctions<'a> {
        ObjectFunctions {
            indices,
            light,
            brdf,
            second: None,
            vis,
        }
    }

    /// The cubic form equals Eq. 7 with the three functions interpolated
    /// first (random functions, random barycentrics, with and without
    /// visibility).
    #[test]
    fn the_cubic_is_the_product_of_interpolated_functions() {
        let padded = 16;
        let row = 3 * padded;
        let mut x = 0x2545_f491_u32;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 10_000) as f32 / 10_000.0
        };
        let light: Vec<f32> = (0..4 * row).map(|_| rnd()).collect();
        let brdf: Vec<f32> = (0..4 * row).map(|_| rnd()).collect();
        let vis: Vec<f32> = (0..4 * padded).map(|_| rnd()).collect();
        let indices = [[0u32, 1, 2], [1, 3, 2]];
        for with_vis in [false, true] {
            let o = functions(&indices, &light, &brdf, with_vis.then_some(&vis[..]));
            let mut tables = TriangleTables::default();
            // Triangle 1 covered, triangle 0 not.
            tables.build(&[NO_TRIANGLE, 1, 1], &[Some(o)], padded);
            assert_eq!(tables.built(), 1);
            assert!(tables.shade(0, 0, Vec3::splat(1.0 / 3.0), false).is_none());
            let tri = indices[1].map(|i| i as usize);
            for _ in 0..20 {
                let (u, v) = (rnd(), rnd());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                let lam = [1.0 - u - v, u, v];
                let got = tables
                    .shade(0, 1, Vec3::from_array(lam), false)
                    .expect("built");
                for ch in 0..3 {
                    let mut want = 0.0f64;
                    for c in 0..padded {
                        let mix = |f: &[f32], stride: usize, off: usize| -> f64 {
                            (0..3)
                                .map(|a| {
                                    f64::from(lam[a]) * f64::from(f[tri[a] * stride + off + c])
                                })
                                .sum()
                        };
                        let vp = if with_vis { mix(&vis, padded, 0) } else { 1.0 };
                        want += mix(&light, row, ch * padded) * mix(&brdf, row, ch * padded) * vp;
                    }
                    let g = f64::from(got[ch]);
                    assert!(
                        (g - want).abs() <= 1e-5 * want.abs().max(1.0),
                        "{ch}: {g} vs {want}"
                    );
                }
            }
        }
    }

    /// The AVX2 + FMA tensor equals the portable one to rounding (under CI
    /// a CPU without them fails rather than compare the portable copy with
    /// itself).
    #[test]
    fn fma_tensor_matches_the_portable_tensor() {
        if !relight_isa::avx2() {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI: no AVX2 + FMA on this CPU, so the fast tensor is not tested"
            );
            return;
        }
        let padded = 24;
        let row = 3 * padded;
        let f = |k: usize, n: usize| -> Vec<f32> {
            (0..n)
                .map(|i| ((i * 7919 + k * 104_729) % 1000) as f32 / 1000.0 - 0.2)
                .collect()
        };
        let (light, brdf, vis) = (f(1, 3 * row), f(2, 3 * row), f(3, 3 * padded));
        let indices = [[0u32, 2, 1]];
        for with_vis in [false, true] {
            let o = functions(&indices, &light, &brdf, with_vis.then_some(&vis[..]));
            let (mut fast, mut slow) = ([0.0f32; COEFFS], [0.0f32; COEFFS]);
            let x = TensorInput {
                o: &o,
                brdf: &brdf,
                tri: indices[0],
                padded,
            };
            tensor(&x, &mut fast, true);
            tensor(&x, &mut slow, false);
            for (i, (a, b)) in fast.iter().zip(&slow).enumerate() {
                assert!((a - b).abs() <= 1e-5 * b.abs().max(1.0), "{i}: {a} vs {b}");
            }
            assert!(slow.iter().any(|v| v.abs() > 0.1), "a vacuous tensor");
        }
    }
}
