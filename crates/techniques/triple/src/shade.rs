//! The shading kernel: Eq. 7 as the top-only product
//! `B = Σ_c L̄_c V̄_c ρ̂_c` over the level-`m` cells, with every factor
//! interpolated on the fly (spherical-wavelets-triple-product-2006 §3.3):
//! the lighting from six table entries around the point's frame
//! ([`crate::lighting::LightTable::lookup`]), the visibility from the
//! triangle's three vertices (barycentric), the BRDF term from four views
//! ([`crate::brdf_table::BrdfTable::lookup`]).
//!
//! Eight cells at a time in fixed-size arrays (which the compiler keeps in
//! vector registers); a tap of zero weight is skipped. Per cell and RGB
//! channel: 6 lighting + 4 BRDF multiply-adds, 3 for visibility shared by
//! the channels, 2 for the product — [`FMA_PER_CELL`].

use crate::lighting::Tap;
use crate::storage::{Cells, F16Cells, F32Cells, Planes, U8Cells};
use glam::Vec3;

/// Multiply-adds per cell of one shaded point with six lighting taps, three
/// visibility taps and four BRDF taps: `3 + 3·(6 + 4 + 2)`.
pub const FMA_PER_CELL: usize = 39;

/// Multiply-adds per cell of one pixel under
/// [`crate::method::Shading::Interpolated`]: the three vertices' lighting
/// and BRDF functions and visibility interpolated, `3 + 3·(3 + 3 + 2)`.
pub const FMA_PER_CELL_INTERPOLATED: usize = 27;

/// Multiply-adds per cell of one vertex's functions under
/// [`crate::method::Shading::Interpolated`] (six lighting and four BRDF
/// taps per channel, [`blend_function`]): `3·(6 + 4)`.
pub const FMA_PER_VERTEX_CELL: usize = 30;

/// Bytes read per cell: six lighting, four BRDF entries (RGB) and three
/// visibility values, f32.
pub const BYTES_PER_CELL: usize = 4 * (3 * (6 + 4) + 3);

/// `Σ_c L̄_c V̄_c ρ̂_c` (RGB) for one point; `vis` are the visibility
/// planes with up to four rows (plane offsets: a triangle's three vertices,
/// or four texels of a visibility texture) and their weights
/// (`None` = visible everywhere). Each tap's weight carries its plane's
/// scale ([`crate::storage`]).
///
/// On x86-64 with AVX2, FMA and F16C (detected at run time) the kernel runs
/// compiled for them, with f16 lighting converted by `vcvtph2ps`; otherwise
/// [`shade_point_portable`]. Both compute the same sums (tested).
#[inline]
#[must_use]
pub fn shade_point(
    light: &Planes,
    ltaps: &[Tap; 6],
    brdf: &Planes,
    btaps: &[Tap; 4],
    vis: Option<(&Planes, [usize; 4], [f32; 4])>,
    light_stride: usize,
    stride: usize,
) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    if relight_isa::avx2() {
        // SAFETY: the CPU has AVX2, FMA and F16C (checked just above).
        return unsafe { x86::shade_point(light, ltaps, brdf, btaps, vis, light_stride, stride) };
    }
    shade_point_portable(light, ltaps, brdf, btaps, vis, light_stride, stride)
}

/// [`shade_point`] compiled for the baseline ISA (the path other CPUs take,
/// and the reference the fast one is tested against).
#[inline]
#[must_use]
pub fn shade_point_portable(
    light: &Planes,
    ltaps: &[Tap; 6],
    brdf: &Planes,
    btaps: &[Tap; 4],
    vis: Option<(&Planes, [usize; 4], [f32; 4])>,
    light_stride: usize,
    stride: usize,
) -> Vec3 {
    dispatch!(
        F16Cells,
        false,
        light,
        ltaps,
        brdf,
        btaps,
        vis,
        light_stride,
        stride
    )
}

/// One point's function from weighted table entries: `out[ch·padded + c] =
/// Σ_t w_t s_t · planes[t.offset + ch·plane_stride + c]` for the three
/// channel planes (`s_t` the entry plane's scale, [`crate::storage`]), for
/// `c < padded`; cells from `plane_stride` on (an unpadded lighting plane's
/// neighbour, [`crate::lighting`]) are set to 0. These are the per-vertex
/// functions that [`crate::method::Shading::Interpolated`] interpolates per
/// pixel (§3.3's pseudocode). Runs with F16C where [`shade_point`] does;
/// both copies compute the same sums (tested).
pub fn blend_function(
    planes: &Planes,
    taps: &[Tap],
    plane_stride: usize,
    padded: usize,
    out: &mut [f32],
) {
    #[cfg(target_arch = "x86_64")]
    if relight_isa::avx2() {
        // SAFETY: the CPU has AVX2, FMA and F16C (checked just above).
        return unsafe { x86::blend_function(planes, taps, plane_stride, padded, out) };
    }
    blend_function_portable(planes, taps, plane_stride, padded, out);
}

/// [`blend_function`] compiled for the baseline ISA.
pub fn blend_function_portable(
    planes: &Planes,
    taps: &[Tap],
    plane_stride: usize,
    padded: usize,
    out: &mut [f32],
) {
    blend_dispatch!(F16Cells, false, planes, taps, plane_stride, padded, out);
}

macro_rules! blend_dispatch {
    ($f16:ident, $fused:literal, $planes:expr, $taps:expr, $ps:expr, $padded:expr, $out:expr) => {
        match $planes {
            Planes::F32(v) => blend_with::<$fused, _>(&F32Cells(v), $taps, $ps, $padded, $out),
            Planes::F16(v) => blend_with::<$fused, _>(&$f16(v), $taps, $ps, $padded, $out),
            Planes::U8 { codes, scales } => blend_with::<$fused, _>(
                &U8Cells {
                    codes,
                    scales,
                    stride: $ps,
                },
                $taps,
                $ps,
                $padded,
                $out,
            ),
        }
    };
}
use blend_dispatch;

/// `a·b + c`, fused in the AVX2 + FMA copies (`F`; a separate multiply and
/// add in the portable one, where `f32::mul_add` would be a libm call).
#[inline(always)]
fn madd<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// Taps [`blend_with`] sums in registers per pass over a channel.
const MAX_REGISTER_TAPS: usize = 8;

#[inline(always)]
fn blend_with<const F: bool, C: Cells>(
    cells: &C,
    taps: &[Tap],
    plane_stride: usize,
    padded: usize,
    out: &mut [f32],
) {
    for (ch, o) in out.chunks_exact_mut(padded).take(3).enumerate() {
        // Per pass up to MAX_REGISTER_TAPS taps' offsets and scaled weights,
        // then per 8-cell chunk those taps into one accumulator (no
        // read-modify-write of `o` per tap); a later pass (more taps) goes on
        // from the stored sums: the same sums, in tap order.
        let mut live_taps = taps.iter().filter(|t| t.weight != 0.0);
        let mut first = true;
        loop {
            let mut live = [(0usize, 0.0f32); MAX_REGISTER_TAPS];
            let mut n = 0;
            for t in live_taps.by_ref().take(MAX_REGISTER_TAPS) {
                let base = t.offset as usize + ch * plane_stride;
                live[n] = (base, t.weight * cells.scale(base));
                n += 1;
            }
            if n == 0 && !first {
                break;
            }
            for (b, o8) in o.chunks_exact_mut(8).enumerate() {
                let mut acc = if first {
                    [0.0f32; 8]
                } else {
                    o8.try_into().expect("8 cells")
                };
                for &(base, w) in &live[..n] {
                    let s = cells.load8(base + 8 * b);
                    for i in 0..8 {
                        acc[i] = madd::<F>(w, s[i], acc[i]);
                    }
                }
                o8.copy_from_slice(&acc);
            }
            first = false;
            if n < MAX_REGISTER_TAPS {
                break;
            }
        }
        if plane_stride < padded {
            o[plane_stride..].fill(0.0);
        }
    }
}

/// The one dispatch of both copies: a monomorphised kernel for all-f32 and
/// for all-compact tables (f16 lighting read by `$f16`), [`AnyCells`] for
/// the mixed forms.
macro_rules! dispatch {
    ($f16:ident, $fused:literal, $light:expr, $ltaps:expr, $brdf:expr, $btaps:expr, $vis:expr, $ls:expr, $stride:expr) => {{
        let (ls, stride) = ($ls, $stride);
        match ($light, $brdf) {
            (Planes::F32(l), Planes::F32(b)) => with_vis::<$fused, _, _>(
                &F32Cells(l),
                $ltaps,
                &F32Cells(b),
                $btaps,
                $vis,
                ls,
                stride,
            ),
            (Planes::F16(l), Planes::U8 { codes, scales }) => with_vis::<$fused, _, _>(
                &$f16(l),
                $ltaps,
                &U8Cells {
                    codes,
                    scales,
                    stride,
                },
                $btaps,
                $vis,
                ls,
                stride,
            ),
            (l, b) => with_vis::<$fused, _, _>(
                &AnyCells::of(l, ls),
                $ltaps,
                &AnyCells::of(b, stride),
                $btaps,
                $vis,
                ls,
                stride,
            ),
        }
    }};
}
use dispatch;

/// The AVX2 + FMA + F16C copy of the kernel.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{AnyCells, Cells, F32Cells, Planes, Tap, U8Cells, Vec3, blend_with, with_vis};
    use std::arch::x86_64::{__m128i, _mm_loadu_si128, _mm256_cvtph_ps, _mm256_storeu_ps};

    /// f16 planes converted eight at a time by `vcvtph2ps`; only built
    /// inside [`shade_point`], which runs with F16C.
    struct F16cCells<'a>(&'a [u16]);

    impl Cells for F16cCells<'_> {
        #[inline(always)]
        fn load8(&self, offset: usize) -> [f32; 8] {
            let s = &self.0[offset..offset + 8];
            let mut out = [0.0f32; 8];
            // SAFETY: `s` holds eight u16 (16 bytes, unaligned load); this
            // type is only used inside `shade_point` below, compiled with
            // and called only after detecting F16C.
            unsafe {
                let h = _mm_loadu_si128(s.as_ptr().cast::<__m128i>());
                _mm256_storeu_ps(out.as_mut_ptr(), _mm256_cvtph_ps(h));
            }
            out
        }
        #[inline(always)]
        fn scale(&self, _: usize) -> f32 {
            1.0
        }
    }

    /// [`super::shade_point_portable`] compiled for AVX2 + FMA + F16C.
    ///
    /// # Safety
    /// The CPU must have AVX2, FMA and F16C ([`available`]).
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) unsafe fn shade_point(
        light: &Planes,
        ltaps: &[Tap; 6],
        brdf: &Planes,
        btaps: &[Tap; 4],
        vis: Option<(&Planes, [usize; 4], [f32; 4])>,
        light_stride: usize,
        stride: usize,
    ) -> Vec3 {
        super::dispatch!(
            F16cCells,
            true,
            light,
            ltaps,
            brdf,
            btaps,
            vis,
            light_stride,
            stride
        )
    }
    /// [`super::blend_function_portable`] compiled for AVX2 + FMA + F16C.
    ///
    /// # Safety
    /// The CPU must have AVX2, FMA and F16C ([`available`]).
    #[target_feature(enable = "avx2,fma,f16c")]
    pub(super) unsafe fn blend_function(
        planes: &Planes,
        taps: &[Tap],
        plane_stride: usize,
        padded: usize,
        out: &mut [f32],
    ) {
        super::blend_dispatch!(F16cCells, true, planes, taps, plane_stride, padded, out);
    }
}

#[inline(always)]
fn with_vis<const F: bool, L: Cells, B: Cells>(
    light: &L,
    ltaps: &[Tap; 6],
    brdf: &B,
    btaps: &[Tap; 4],
    vis: Option<(&Planes, [usize; 4], [f32; 4])>,
    ls: usize,
    stride: usize,
) -> Vec3 {
    match vis {
        None => kernel::<F, L, B, F32Cells>(light, ltaps, brdf, btaps, None, ls, stride),
        Some((Planes::F32(v), rows, w)) => kernel::<F, _, _, _>(
            light,
            ltaps,
            brdf,
            btaps,
            Some((&F32Cells(v), rows, w)),
            ls,
            stride,
        ),
        Some((Planes::U8 { codes, scales }, rows, w)) => kernel::<F, _, _, _>(
            light,
            ltaps,
            brdf,
            btaps,
            Some((
                &U8Cells {
                    codes,
                    scales,
                    stride,
                },
                rows,
                w,
            )),
            ls,
            stride,
        ),
        Some((v, rows, w)) => kernel::<F, _, _, _>(
            light,
            ltaps,
            brdf,
            btaps,
            Some((&AnyCells::of(v, stride), rows, w)),
            ls,
            stride,
        ),
    }
}

/// Live taps with each channel's plane scale folded into the weight.
#[inline(always)]
fn scaled_taps<const N: usize, C: Cells>(
    cells: &C,
    taps: &[Tap; N],
    stride: usize,
) -> ([[(usize, f32); N]; 3], usize) {
    let mut out = [[(0usize, 0.0f32); N]; 3];
    let mut n = 0;
    for t in taps {
        if t.weight != 0.0 {
            for (ch, row) in out.iter_mut().enumerate() {
                let o = t.offset as usize + ch * stride;
                row[n] = (o, t.weight * cells.scale(o));
            }
            n += 1;
        }
    }
    (out, n)
}

#[inline(always)]
fn kernel<const F: bool, L: Cells, B: Cells, V: Cells>(
    light: &L,
    ltaps: &[Tap; 6],
    brdf: &B,
    btaps: &[Tap; 4],
    vis: Option<(&V, [usize; 4], [f32; 4])>,
    light_stride: usize,
    stride: usize,
) -> Vec3 {
    let (lt, nl) = scaled_taps(light, ltaps, light_stride);
    let (bt, nb) = scaled_taps(brdf, btaps, stride);
    let vis = vis.map(|(cells, rows, w)| {
        let mut vw = [0.0f32; 4];
        for a in 0..4 {
            vw[a] = if w[a] != 0.0 {
                w[a] * cells.scale(rows[a])
            } else {
                0.0
            };
        }
        (cells, rows, vw)
    });
    let mut acc = [[0.0f32; 8]; 3];
    let mut base = 0;
    while base < stride {
        let mut v = [0.0f32; 8];
        match &vis {
            Some((cells, rows, w)) => {
                for a in 0..4 {
                    if w[a] != 0.0 {
                        let s = cells.load8(rows[a] + base);
                        for i in 0..8 {
                            v[i] = madd::<F>(w[a], s[i], v[i]);
                        }
                    }
                }
            }
            None => v = [1.0; 8],
        }
        for (ch, acc) in acc.iter_mut().enumerate() {
            let mut l = [0.0f32; 8];
            for &(o, w) in &lt[ch][..nl] {
                let s = light.load8(o + base);
                for i in 0..8 {
                    l[i] = madd::<F>(w, s[i], l[i]);
                }
            }
            let mut r = [0.0f32; 8];
            for &(o, w) in &bt[ch][..nb] {
                let s = brdf.load8(o + base);
                for i in 0..8 {
                    r[i] = madd::<F>(w, s[i], r[i]);
                }
            }
            for i in 0..8 {
                acc[i] = madd::<F>(l[i] * v[i], r[i], acc[i]);
            }
        }
        base += 8;
    }
    Vec3::new(
        acc[0].iter().sum(),
        acc[1].iter().sum(),
        acc[2].iter().sum(),
    )
}

/// Any plane form, decoded per load (the combinations the method does not
/// build: kept total, not fast).
enum AnyCells<'a> {
    F32(F32Cells<'a>),
    F16(F16Cells<'a>),
    U8(U8Cells<'a>),
}

impl<'a> AnyCells<'a> {
    fn of(p: &'a Planes, stride: usize) -> Self {
        match p {
            Planes::F32(v) => Self::F32(F32Cells(v)),
            Planes::F16(v) => Self::F16(F16Cells(v)),
            Planes::U8 { codes, scales } => Self::U8(U8Cells {
                codes,
                scales,
                stride,
            }),
        }
    }
}

impl Cells for AnyCells<'_> {
    fn load8(&self, offset: usize) -> [f32; 8] {
        match self {
            Self::F32(c) => c.load8(offset),
            Self::F16(c) => c.load8(offset),
            Self::U8(c) => c.load8(offset),
        }
    }
    fn scale(&self, plane_offset: usize) -> f32 {
        match self {
            Self::F32(c) => c.scale(plane_offset),
            Self::F16(c) => c.scale(plane_offset),
            Self::U8(c) => c.scale(plane_offset),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::storage::Planes;

    /// The run-time-selected kernel against the portable one, in every
    /// storage, with and without visibility; under CI the fast path must
    /// exist (a CPU without it would compare the portable path with itself).
    #[test]
    fn fast_kernel_matches_the_portable_one() {
        #[cfg(target_arch = "x86_64")]
        if !relight_isa::avx2() {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI runs on a CPU without AVX2+FMA+F16C: the fast kernel is untested"
            );
            eprintln!("no AVX2+FMA+F16C here: the fast kernel is not tested");
            return;
        }
        let stride = 80;
        let mut x = 0x2545_f491_u32;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 10_000) as f32 / 10_000.0
        };
        let light: Vec<f32> = (0..12 * 3 * stride).map(|_| 5.0 * rnd()).collect();
        let brdf: Vec<f32> = (0..8 * 3 * stride).map(|_| rnd()).collect();
        let vis: Vec<f32> = (0..6 * stride).map(|_| rnd()).collect();
        let tap = |o: usize, w: f32| Tap {
            offset: (o * 3 * stride) as u32,
            weight: w,
        };
        let lt = [
            tap(0, 0.3),
            tap(3, 0.2),
            tap(5, 0.0),
            tap(7, 0.25),
            tap(9, 0.1),
            tap(11, 0.15),
        ];
        let bt = [tap(1, 0.4), tap(2, 0.3), tap(6, 0.2), tap(7, 0.1)];
        for (l, b, v) in [
            (
                Planes::F32(light.clone()),
                Planes::F32(brdf.clone()),
                Planes::F32(vis.clone()),
            ),
            (
                Planes::f16(&light),
                Planes::u8(&brdf, stride),
                Planes::u8(&vis, stride),
            ),
            (
                Planes::f16(&light),
                Planes::F32(brdf.clone()),
                Planes::F32(vis.clone()),
            ),
        ] {
            for rows in [
                None,
                Some((
                    &v,
                    [0, stride, 4 * stride, 5 * stride],
                    [0.4, 0.3, 0.2, 0.1],
                )),
            ] {
                let fast = shade_point(&l, &lt, &b, &bt, rows, stride, stride);
                let slow = shade_point_portable(&l, &lt, &b, &bt, rows, stride, stride);
                assert!(
                    (fast - slow).abs().max_element() <= 1e-5 * slow.abs().max_element(),
                    "{fast} vs {slow}"
                );
            }
        }
    }

    /// Lighting planes stored unpadded (`crate::lighting`'s layout) shade
    /// exactly as padded ones: the kernel's last load of a plane reads the
    /// next plane's first cells, which meet the BRDF's zero padding; in
    /// every storage and both kernels.
    #[test]
    fn unpadded_lighting_equals_padded() {
        let (cells, stride) = (58, 64);
        let entries = 5;
        let mut x = 0x9e37_79b9_u32;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 10_000) as f32 / 10_000.0
        };
        let mut padded = vec![0.0f32; entries * 3 * stride];
        let mut dense = vec![0.0f32; entries * 3 * cells + stride - cells];
        for p in 0..entries * 3 {
            for c in 0..cells {
                let v = 40.0 * rnd();
                padded[p * stride + c] = v;
                dense[p * cells + c] = v;
            }
        }
        let mut brdf = vec![0.0f32; 2 * 3 * stride];
        for p in 0..2 * 3 {
            for c in 0..cells {
                brdf[p * stride + c] = rnd();
            }
        }
        let vis: Vec<f32> = (0..3 * stride).map(|_| rnd()).collect();
        let taps = |entry_len: usize, w: [f32; 6]| {
            let mut t = [Tap::default(); 6];
            for (i, w) in w.into_iter().enumerate() {
                t[i] = Tap {
                    offset: ((i % entries) * entry_len) as u32,
                    weight: w,
                };
            }
            t
        };
        let w = [0.3, 0.1, 0.2, 0.15, 0.25, 0.0];
        let bt = [
            Tap {
                offset: 0,
                weight: 0.6,
            },
            Tap {
                offset: (3 * stride) as u32,
                weight: 0.4,
            },
            Tap::default(),
            Tap::default(),
        ];
        for half in [false, true] {
            let lp = Planes::lighting(padded.clone(), half);
            let ld = Planes::lighting(dense.clone(), half);
            for b in [Planes::F32(brdf.clone()), Planes::u8(&brdf, stride)] {
                for v in [
                    None,
                    Some((
                        &Planes::F32(vis.clone()),
                        [0, stride, 2 * stride, 0],
                        [0.5, 0.3, 0.2, 0.0],
                    )),
                ] {
                    for kernel in [shade_point, shade_point_portable] {
                        let want = kernel(&lp, &taps(3 * stride, w), &b, &bt, v, stride, stride);
                        let got = kernel(&ld, &taps(3 * cells, w), &b, &bt, v, cells, stride);
                        assert!(want.max_element() > 1.0, "{want}");
                        assert!(
                            (got - want).abs().max_element() <= 1e-6 * want.max_element(),
                            "half {half}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }

    /// A vertex function is the weighted sum of its entries' planes (every
    /// storage, plane scales folded in), zero past an unpadded plane's own
    /// cells, and both copies agree; also with more taps than
    /// [`MAX_REGISTER_TAPS`].
    #[test]
    fn blend_function_sums_entries() {
        let (cells, padded) = (58, 64);
        let mut x = 0x1234_5678_u32;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 10_000) as f32 / 10_000.0
        };
        let taps = [
            Tap {
                offset: 0,
                weight: 0.5,
            },
            Tap {
                offset: 0,
                weight: 0.0,
            },
            Tap {
                offset: 0,
                weight: 0.2,
            },
        ];
        for (stride, planes) in [
            (
                cells,
                Planes::F32((0..4 * 3 * cells + padded).map(|_| rnd()).collect()),
            ),
            (
                cells,
                Planes::f16(
                    &(0..4 * 3 * cells + padded)
                        .map(|_| rnd())
                        .collect::<Vec<_>>(),
                ),
            ),
            (
                padded,
                Planes::u8(
                    &(0..4 * 3 * padded).map(|_| rnd()).collect::<Vec<_>>(),
                    padded,
                ),
            ),
        ] {
            for many in [false, true] {
                let mut taps = taps.to_vec();
                taps[0].offset = (3 * stride) as u32;
                taps[2].offset = (9 * stride) as u32;
                if many {
                    taps.extend((0..=9).map(|k| Tap {
                        offset: (k * stride) as u32,
                        weight: 0.05 * k as f32 - 0.1,
                    }));
                    assert!(taps.len() > MAX_REGISTER_TAPS);
                }
                let mut fast = vec![f32::NAN; 3 * padded];
                let mut slow = vec![f32::NAN; 3 * padded];
                blend_function(&planes, &taps, stride, padded, &mut fast);
                blend_function_portable(&planes, &taps, stride, padded, &mut slow);
                for ch in 0..3 {
                    for c in 0..padded {
                        let want = if c < stride.min(cells) || stride == padded {
                            taps.iter()
                                .map(|t| {
                                    t.weight
                                        * planes.get(t.offset as usize + ch * stride + c, stride)
                                })
                                .sum::<f32>()
                        } else {
                            0.0
                        };
                        let i = ch * padded + c;
                        assert!(
                            (slow[i] - want).abs() <= 1e-6,
                            "{ch} {c}: {} vs {want}",
                            slow[i]
                        );
                        assert!(
                            (fast[i] - slow[i]).abs() <= 1e-6,
                            "{ch} {c}: {} vs {}",
                            fast[i],
                            slow[i]
                        );
                    }
                }
            }
        }
    }
}
