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
use glam::Vec3;

/// Multiply-adds per cell of one shaded point with six lighting taps, three
/// visibility taps and four BRDF taps: `3 + 3·(6 + 4 + 2)`.
pub const FMA_PER_CELL: usize = 39;

/// Bytes read per cell: six lighting, four BRDF entries (RGB) and three
/// visibility values, f32.
pub const BYTES_PER_CELL: usize = 4 * (3 * (6 + 4) + 3);

#[inline]
fn live<const N: usize>(taps: &[Tap; N]) -> ([Tap; N], usize) {
    let mut out = [Tap::default(); N];
    let mut n = 0;
    for t in taps {
        if t.weight != 0.0 {
            out[n] = *t;
            n += 1;
        }
    }
    (out, n)
}

/// `Σ_c L̄_c V̄_c ρ̂_c` (RGB) for one point; `vis` are up to three vertex
/// visibility rows with weights (`None` = visible everywhere).
#[inline]
#[must_use]
pub fn shade_point(
    light: &[f32],
    ltaps: &[Tap; 6],
    brdf: &[f32],
    btaps: &[Tap; 4],
    vis: Option<([&[f32]; 3], [f32; 3])>,
    stride: usize,
) -> Vec3 {
    let (lt, nl) = live(ltaps);
    let (bt, nb) = live(btaps);
    let mut acc = [[0.0f32; 8]; 3];
    let mut base = 0;
    while base < stride {
        let mut v = [0.0f32; 8];
        match vis {
            Some((rows, w)) => {
                for a in 0..3 {
                    if w[a] != 0.0 {
                        let s = &rows[a][base..base + 8];
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
            for t in &lt[..nl] {
                let o = t.offset as usize + ch * stride + base;
                let s = &light[o..o + 8];
                for i in 0..8 {
                    l[i] += t.weight * s[i];
                }
            }
            let mut r = [0.0f32; 8];
            for t in &bt[..nb] {
                let o = t.offset as usize + ch * stride + base;
                let s = &brdf[o..o + 8];
                for i in 0..8 {
                    r[i] += t.weight * s[i];
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
