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

/// Bytes read per cell: six lighting, four BRDF entries (RGB) and three
/// visibility values, f32.
pub const BYTES_PER_CELL: usize = 4 * (3 * (6 + 4) + 3);

/// `Σ_c L̄_c V̄_c ρ̂_c` (RGB) for one point; `vis` are the visibility
/// planes with up to three vertex rows (plane offsets) and their weights
/// (`None` = visible everywhere). Each tap's weight carries its plane's
/// scale ([`crate::storage`]).
#[inline]
#[must_use]
pub fn shade_point(
    light: &Planes,
    ltaps: &[Tap; 6],
    brdf: &Planes,
    btaps: &[Tap; 4],
    vis: Option<(&Planes, [usize; 3], [f32; 3])>,
    stride: usize,
) -> Vec3 {
    match (light, brdf) {
        (Planes::F32(l), Planes::F32(b)) => {
            with_vis(&F32Cells(l), ltaps, &F32Cells(b), btaps, vis, stride)
        }
        (Planes::F16(l), Planes::U8 { codes, scales }) => with_vis(
            &F16Cells(l),
            ltaps,
            &U8Cells {
                codes,
                scales,
                stride,
            },
            btaps,
            vis,
            stride,
        ),
        (l, b) => with_vis(
            &AnyCells::of(l, stride),
            ltaps,
            &AnyCells::of(b, stride),
            btaps,
            vis,
            stride,
        ),
    }
}

#[inline(always)]
fn with_vis<L: Cells, B: Cells>(
    light: &L,
    ltaps: &[Tap; 6],
    brdf: &B,
    btaps: &[Tap; 4],
    vis: Option<(&Planes, [usize; 3], [f32; 3])>,
    stride: usize,
) -> Vec3 {
    match vis {
        None => kernel::<L, B, F32Cells>(light, ltaps, brdf, btaps, None, stride),
        Some((Planes::F32(v), rows, w)) => kernel(
            light,
            ltaps,
            brdf,
            btaps,
            Some((&F32Cells(v), rows, w)),
            stride,
        ),
        Some((Planes::U8 { codes, scales }, rows, w)) => kernel(
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
            stride,
        ),
        Some((v, rows, w)) => kernel(
            light,
            ltaps,
            brdf,
            btaps,
            Some((&AnyCells::of(v, stride), rows, w)),
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
fn kernel<L: Cells, B: Cells, V: Cells>(
    light: &L,
    ltaps: &[Tap; 6],
    brdf: &B,
    btaps: &[Tap; 4],
    vis: Option<(&V, [usize; 3], [f32; 3])>,
    stride: usize,
) -> Vec3 {
    let (lt, nl) = scaled_taps(light, ltaps, stride);
    let (bt, nb) = scaled_taps(brdf, btaps, stride);
    let vis = vis.map(|(cells, rows, w)| {
        let mut vw = [0.0f32; 3];
        for a in 0..3 {
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
                for a in 0..3 {
                    if w[a] != 0.0 {
                        let s = cells.load8(rows[a] + base);
                        for i in 0..8 {
                            v[i] += w[a] * s[i];
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
                    l[i] += w * s[i];
                }
            }
            let mut r = [0.0f32; 8];
            for &(o, w) in &bt[ch][..nb] {
                let s = brdf.load8(o + base);
                for i in 0..8 {
                    r[i] += w * s[i];
                }
            }
            for i in 0..8 {
                acc[i] += l[i] * v[i] * r[i];
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
