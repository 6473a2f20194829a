//! §3.3's per-pixel form as a cubic in the barycentrics: per covered
//! triangle, the tensor `T[a][b][v] = Σ_c L_a,c ρ_b,c V_v,c` of its vertices'
//! lighting, BRDF and visibility functions, so that a pixel's Eq. 7 with the
//! interpolated functions `L_p = Σ_a λ_a L_a`, `ρ_p = Σ_b λ_b ρ_b`,
//! `V_p = Σ_v λ_v V_v` is
//!
//! `B_p = Σ_c L_p,c ρ_p,c V_p,c = Σ_{a,b,v} λ_a λ_b λ_v T[a][b][v]`
//!
//! exactly (the product is trilinear in the three functions), per RGB
//! channel. A triangle's 27 terms cost `3·(9 + 27)` multiply-adds per cell
//! ([`FMA_PER_TRIANGLE_CELL`]), once per frame for each triangle some pixel
//! shows; each pixel then costs [`FMA_PER_PIXEL`] whatever the number of
//! cells, instead of [`crate::shade::FMA_PER_CELL_INTERPOLATED`] per cell.
//! At n = 80 (64 padded cells) a triangle pays for itself from about four
//! pixels. Objects with visibility textures (whose visibility is not a
//! vertex function) keep the per-pixel kernel.

use glam::Vec3;
use rayon::prelude::*;
use relight_render::raster::NO_TRIANGLE;

/// Multiply-adds per cell of one triangle's tensor: per channel, nine
/// `L_a ρ_b` products and 27 dot products with the visibility.
pub const FMA_PER_TRIANGLE_CELL: usize = 3 * (9 + 27);

/// Multiply-adds per pixel: nine `λ_a λ_b`, then 27 per channel.
pub const FMA_PER_PIXEL: usize = 9 + 3 * 27;

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
    /// Per built triangle, `[channel][a][b][v]`; of the second BRDF after
    /// them when an object has one (`second_base`).
    terms: Vec<[f32; 81]>,
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
        let mut list: Vec<(usize, usize)> = Vec::new();
        for &id in triangle_ids {
            if id == NO_TRIANGLE {
                continue;
            }
            let id = id as usize;
            if id >= total || self.slot[id] != u32::MAX {
                continue;
            }
            let d = self.offsets.partition_point(|&o| o <= id) - 1;
            if objects[d].is_none() {
                continue;
            }
            self.slot[id] = list.len() as u32;
            list.push((d, id - self.offsets[d]));
        }
        let any_second = objects.iter().flatten().any(|o| o.second.is_some());
        self.built = list.len();
        self.second_base = if any_second { list.len() } else { 0 };
        // Every tensor of the frame is written whole below: the buffer only
        // grows (zeroing 324 bytes per triangle each frame was ≈ 8 MB of
        // `memset` at 512 × 384), and entries past this frame's are unread.
        let needed = list.len() * if any_second { 2 } else { 1 };
        if self.terms.len() < needed {
            self.terms.resize(needed, [0.0; 81]);
        }
        let (first, second) = self.terms[..needed].split_at_mut(list.len());
        let fma = fma_path();
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
                        None => *t = [0.0; 81],
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
        let lam = [l.x, l.y, l.z];
        let mut out = [0.0f32; 3];
        for (ch, o) in out.iter_mut().enumerate() {
            let mut sum = 0.0;
            for a in 0..3 {
                for b in 0..3 {
                    let tv = &t[ch * 27 + a * 9 + b * 3..][..3];
                    let inner = tv[0] * lam[0] + tv[1] * lam[1] + tv[2] * lam[2];
                    sum += lam[a] * lam[b] * inner;
                }
            }
            *o = sum;
        }
        Some(Vec3::from_array(out))
    }
}

/// Whether this CPU runs [`tensor`]'s AVX2 + FMA copy (cached by the
/// standard library).
#[inline]
fn fma_path() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `T[ch][a][b][v] = Σ_c L_a ρ_b V_v` of triangle `tri` (module docs),
/// through the AVX2 + FMA copy where `fma` ([`fma_path`]): the default
/// x86-64 target has only 4-lane SSE and no fused multiply-add, and this loop
/// was half of a 512 × 384 interpolated frame.
fn tensor(x: &TensorInput<'_>, t: &mut [f32; 81], fma: bool) {
    #[cfg(target_arch = "x86_64")]
    if fma {
        // SAFETY: AVX2 and FMA were detected at run time (`fma_path`).
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
unsafe fn tensor_fma(x: &TensorInput<'_>, t: &mut [f32; 81]) {
    tensor_body::<true>(x, t);
}

/// `a · b + c`, fused where `F`.
#[inline(always)]
fn madd<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// The tensor in 8-cell chunks: per channel and pair `(a, b)` the product
/// `L_a ρ_b` once, then its dot products with the three visibilities
/// (the [`FMA_PER_TRIANGLE_CELL`] count).
#[inline(always)]
fn tensor_body<const F: bool>(x: &TensorInput<'_>, t: &mut [f32; 81]) {
    let &TensorInput {
        o,
        brdf,
        tri,
        padded,
    } = x;
    let row = 3 * padded;
    let vis = o
        .vis
        .map(|v| tri.map(|i| &v[i as usize * padded..(i as usize + 1) * padded]));
    for ch in 0..3 {
        for (a, &ia) in tri.iter().enumerate() {
            let la = &o.light[ia as usize * row + ch * padded..][..padded];
            for (b, &ib) in tri.iter().enumerate() {
                let rb = &brdf[ib as usize * row + ch * padded..][..padded];
                let out = &mut t[ch * 27 + a * 9 + b * 3..][..3];
                match &vis {
                    Some(v) => {
                        let mut acc = [[0.0f32; 8]; 3];
                        let chunks = la
                            .chunks_exact(8)
                            .zip(rb.chunks_exact(8))
                            .zip(v[0].chunks_exact(8))
                            .zip(v[1].chunks_exact(8))
                            .zip(v[2].chunks_exact(8));
                        for ((((l8, r8), v0), v1), v2) in chunks {
                            for i in 0..8 {
                                let lr = l8[i] * r8[i];
                                acc[0][i] = madd::<F>(lr, v0[i], acc[0][i]);
                                acc[1][i] = madd::<F>(lr, v1[i], acc[1][i]);
                                acc[2][i] = madd::<F>(lr, v2[i], acc[2][i]);
                            }
                        }
                        for k in 0..3 {
                            out[k] = acc[k].iter().sum();
                        }
                    }
                    None => {
                        let mut acc = [0.0f32; 8];
                        for (l8, r8) in la.chunks_exact(8).zip(rb.chunks_exact(8)) {
                            for i in 0..8 {
                                acc[i] = madd::<F>(l8[i], r8[i], acc[i]);
                            }
                        }
                        out.fill(acc.iter().sum());
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        if !fma_path() {
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
            let (mut fast, mut slow) = ([0.0f32; 81], [0.0f32; 81]);
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
