//! Relighting with a light field (thesis §4.5.3, eq. 4.37), which the
//! thesis derives but does not implement.
//!
//! # The light
//! A [`LightField`] gives the light's radiance by point and by emitted
//! slope `σ` (its module docs): `A × A` views, piecewise constant in `σ`
//! over `[−e, e]²`. In the angular coordinate `τ = (σ + e)/(2e) ∈ [0, 1]²`
//! the views are cell means, so the standard 2D Haar transform over the
//! views (`A` a power of two) and over each view's uv (order `n`, as the
//! plain light, [`crate::light`]) gives the field's 4D coefficients
//!
//! ```text
//!   F(p, τ) = Σ_i Σ_j F_ij Φ_i(p) Ψ_j(τ)      (i spatial, j angular)
//! ```
//!
//! # Propagation (eq. 4.37 by Lemma 1)
//! A vertex sees face point `t` (the face of [`crate::face`]) along the
//! direction whose emitted slope is `σ(t) = (−S(t₁ − ½), S(t₂ − ½))`, the
//! same for every vertex (the face is aligned with the light's plane), at
//! texture point `s t + o`. Its incident light is `L(t) = Σ_j P_j(t) Ψ_j(τ(t))`
//! with `P_j(t) = Σ_i F_ij Φ_i(s t + o)`: the plain affine propagation
//! (eq. 4.35) of the field's angular slice `j`. With `T` the transport,
//!
//! ```text
//!   B = ∫ L T dt = Σ_j ⟨P_j, Ψ_j ∘ τ · T⟩ = Σ_j Σ_k (P_j)_k (G_j)_k,
//!   G_j = Haar(w_j ⊙ pixels(T)),
//! ```
//!
//! which is eq. 4.37's `Σ_ij F_ij Σ_k D_ijk T_k` with the affine tripling
//! coefficients factored as `D_ijk = Σ_l D_il C_ljk` (Lemma 1, eq. 4.14):
//! the product `C_ljk` of the angular atom with the transport is taken in
//! the face's pixel domain, where `T` is constant per cell. `w_j` is the
//! mean of `Ψ_j ∘ τ` over each face cell: exact when the views' cells fall
//! on face cells (`2e/A` a multiple of `S/n`, the grid's edges on face
//! edges, as for the default face 4, order 32 and `e = 1` or `2`), else the
//! cell's mean of the angular atom (the error `relight verify nearfield`
//! measures against quadrature). Slopes past `e` get nothing, as the light
//! emits nothing there.
//!
//! So each vertex runs the fused kernel ([`crate::propagate::shade_vertex`])
//! once per kept angular slice `j`, against `G_j`, computed per vertex from
//! the transport's pixels (two transforms of `n²` per slice); the slices
//! share the vertex's ACC rows and target mask, which depend on its map
//! only (the kernel's scratch keeps them while the map is the same). Compression
//! keeps the field's largest 4D coefficients, as many as the source fraction
//! keeps of a plain light (`fraction · n²`), DC first, ties coarse first in
//! angle then in space: a field that does not vary with direction keeps the
//! plain light's terms, in one slice.

use crate::light::{
    LIGHT_SUBSAMPLES, LightCoeffs, Ranking, SourceTerms, cells_of, coarse_key, count_of,
    support_width, terms_of,
};
use crate::propagate::{Kernel, Primitives, VertexMap, VertexScratch, shade_vertex};
use relight_affine::standard::{forward_1d, forward_2d, inverse_1d, inverse_2d};
use relight_render::{AreaLight, LightField};

/// Midpoint samples per face cell for the angular atoms' cell means.
const ATOM_SAMPLES: usize = 64;

/// One kept angular slice: its 2D angular index `(j₁, j₂)` and the spatial
/// source terms `F_{·j}`.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldTerm {
    pub j: [usize; 2],
    pub source: SourceTerms,
}

/// A light field's compressed coefficients and its angular atoms on the
/// face (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldSource {
    pub terms: Vec<FieldTerm>,
    /// Face-cell means of the angular atoms along t₁: `[j₁ · n + c₁]`.
    wx: Vec<f32>,
    /// The same along t₂: `[j₂ · n + c₂]`.
    wy: Vec<f32>,
    /// The angular atoms along t₁ as operators on coefficients, `[j₁]`.
    ox: Vec<AxisOp>,
    /// The same along t₂, `[j₂]`.
    oy: Vec<AxisOp>,
    n: usize,
}

/// Multiplication by one angular atom's face-cell means `w` along one face
/// axis, as an operator on the `n` Haar coefficients (`H diag(w) H⁻¹`).
///
/// When `w` is constant on the `c` dyadic blocks of `n/c` cells (the views'
/// edges on face cells), the operator is block diagonal: a wavelet finer
/// than the blocks (index `k ≥ c`) lies inside one block and is only
/// scaled by its value; the `c` coarser atoms are constant on blocks, so
/// their product is too, a `c × c` matrix among them. Otherwise (`c = n`)
/// the slice takes the pixel domain.
#[derive(Clone, Debug, PartialEq)]
enum AxisOp {
    Blocks {
        c: usize,
        /// `[k · c + k']`: coarse coefficient `k` of the product from coarse
        /// coefficient `k'`.
        coarse: Vec<f32>,
        /// `[k]`, `k ≥ c`: the value of `w` on the block holding atom `k`.
        fine: Vec<f32>,
    },
    Pixels,
}

/// Coarse block counts up to which [`AxisOp::Blocks`] beats the pixel
/// domain (`c² n` against about `5 n²` per axis).
const MAX_BLOCKS: usize = 8;

impl AxisOp {
    /// The operator of cell means `w` (`n` of them, a power of two).
    fn of(w: &[f32]) -> Self {
        let n = w.len();
        let Some(c) = (0..=n.ilog2())
            .map(|b| 1usize << b)
            .find(|&c| w.chunks_exact(n / c).all(|b| b.iter().all(|&x| x == b[0])))
            .filter(|&c| c <= MAX_BLOCKS.min(n / 2))
        else {
            return Self::Pixels;
        };
        let block = |k: usize| w[k * (n / c)];
        // Column k' of the coarse matrix: atom k' at order c to block
        // values, times w's, back to coefficients.
        let mut coarse = vec![0.0f32; c * c];
        let (mut v, mut tmp) = (vec![0.0f64; c], vec![0.0f64; c]);
        for k2 in 0..c {
            v.fill(0.0);
            v[k2] = 1.0;
            inverse_1d(&mut v, &mut tmp);
            for (b, x) in v.iter_mut().enumerate() {
                *x *= f64::from(block(b));
            }
            forward_1d(&mut v, &mut tmp);
            for k in 0..c {
                coarse[k * c + k2] = v[k] as f32;
            }
        }
        // Atom k ≥ c of level l and offset t covers cells
        // [t n/2^l, (t+1) n/2^l), inside block ⌊t c/2^l⌋.
        let fine = (0..n)
            .map(|k| {
                if k < c {
                    return 0.0;
                }
                let level = 1usize << k.ilog2();
                block((k - level) * c / level)
            })
            .collect();
        Self::Blocks { c, coarse, fine }
    }
}

/// The value of 1D atom `j` (the layout of [`relight_affine::standard`]: 0
/// the box, `2^l + t` the wavelet of level `l` and offset `t`, positive on
/// its first half) at `x`, zero outside `[0, 1)`.
fn atom(j: usize, x: f64) -> f64 {
    if !(0.0..1.0).contains(&x) {
        return 0.0;
    }
    if j == 0 {
        return 1.0;
    }
    let level = 1usize << j.ilog2();
    let t = (j - level) as f64;
    let y = x * level as f64 - t;
    let amp = (level as f64).sqrt();
    if (0.0..0.5).contains(&y) {
        amp
    } else if (0.5..1.0).contains(&y) {
        -amp
    } else {
        0.0
    }
}

impl FieldSource {
    /// The coefficients of `light`'s field at spatial order `n` (views
    /// box-averaged at order `coarse ≤ n`, as [`LightCoeffs::of_at`]),
    /// compressed by `ranking` to the count `fraction` keeps of a plain
    /// light's `n²` ([`count_of`]), and the angular atoms on the face of
    /// side `face`.
    ///
    /// # Errors
    /// A view count that is not a power of two (the angular Haar basis).
    pub fn of(
        light: &AreaLight,
        field: &LightField,
        [n, coarse]: [usize; 2],
        face: f64,
        fraction: f64,
        ranking: Ranking,
    ) -> Result<Self, String> {
        let a = field.views();
        if !a.is_power_of_two() {
            return Err(format!(
                "the light field's {a} × {a} views: the angular Haar basis needs a power of two per axis"
            ));
        }
        let coarse = coarse.min(n);
        // Spatial coefficients of every view, radiance × intensity.
        let views: Vec<LightCoeffs> = (0..a * a)
            .map(|v| {
                let tex = field.view(v % a, v / a);
                let cells = cells_of(coarse, LIGHT_SUBSAMPLES, &|uv| {
                    tex.sample(uv) * light.intensity
                });
                LightCoeffs::of_cells(&cells, n, coarse)
            })
            .collect();
        // The angular transform per spatial coefficient and channel: slice
        // j = j₂ · A + j₁ of `slices`.
        let mut slices: Vec<LightCoeffs> = (0..a * a)
            .map(|_| LightCoeffs {
                n,
                c: [vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]],
            })
            .collect();
        let mut grid = vec![0.0; a * a];
        for c in 0..3 {
            for k in 0..n * n {
                for (g, v) in grid.iter_mut().zip(&views) {
                    *g = v.c[c][k];
                }
                forward_2d(&mut grid, a);
                for (s, &g) in slices.iter_mut().zip(&grid) {
                    s.c[c][k] = g;
                }
            }
        }
        // Rank all 4D coefficients together: DC first, then magnitude,
        // ties coarse first in angle, then in space.
        let mut all: Vec<(f64, usize, usize)> = Vec::new();
        for (j, s) in slices.iter().enumerate() {
            let w = match ranking {
                Ranking::Magnitude => 1.0,
                Ranking::AreaWeighted => (support_width(j % a) * support_width(j / a)).sqrt(),
            };
            all.extend(
                crate::light::ranked(s, ranking, w)
                    .into_iter()
                    .map(|(m, k)| (m, j, k)),
            );
        }
        let key = |j: usize, k: usize| (coarse_key(j % a, j / a), coarse_key(k % n, k / n));
        all.sort_by(|x, y| {
            y.0.total_cmp(&x.0)
                .then_with(|| key(x.1, x.2).cmp(&key(y.1, y.2)))
        });
        if let Some(p) = all.iter().position(|&(_, j, k)| j == 0 && k == 0) {
            let dc = all.remove(p);
            all.insert(0, dc);
        }
        // The plain light's budget (`count_of`), spent over the 4D terms.
        all.truncate(count_of(fraction, n));
        let mut kept: Vec<Vec<usize>> = vec![Vec::new(); a * a];
        for &(_, j, k) in &all {
            kept[j].push(k);
        }
        let terms = kept
            .into_iter()
            .enumerate()
            .filter(|(_, k)| !k.is_empty())
            .map(|(j, k)| FieldTerm {
                j: [j % a, j / a],
                source: terms_of(&slices[j], k),
            })
            .collect();
        // The atoms' cell means on the face: τ₁ = (−S(t₁ − ½) + e)/(2e),
        // τ₂ = (S(t₂ − ½) + e)/(2e).
        let e = f64::from(field.extent());
        let means = |sign: f64| -> Vec<f32> {
            let mut w = vec![0.0f32; a * n];
            for j in 0..a {
                for c in 0..n {
                    let sum: f64 = (0..ATOM_SAMPLES)
                        .map(|q| {
                            let t = (c as f64 + (q as f64 + 0.5) / ATOM_SAMPLES as f64) / n as f64;
                            atom(j, (sign * face * (t - 0.5) + e) / (2.0 * e))
                        })
                        .sum();
                    w[j * n + c] = (sum / ATOM_SAMPLES as f64) as f32;
                }
            }
            w
        };
        let (wx, wy) = (means(-1.0), means(1.0));
        let ops = |w: &[f32]| w.chunks_exact(n).map(AxisOp::of).collect();
        Ok(Self {
            terms,
            ox: ops(&wx),
            oy: ops(&wy),
            wx,
            wy,
            n,
        })
    }

    /// Retained 4D coefficients.
    #[must_use]
    pub fn len(&self) -> usize {
        self.terms.iter().map(|t| t.source.len()).sum()
    }

    /// True when nothing is retained.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Operations of one [`shade_vertex_field`] call on a transport of
    /// `channels`: per slice `G_j` (block operators: `n c_x² + n c_y² + 2n²`;
    /// the pixel domain: the weighting and a forward transform, `≈ 5 n²`,
    /// after one inverse transform of the transport, `≈ 4 n²`) and the
    /// kernel (`shade`, the kernel's own count).
    #[must_use]
    pub fn shade_fma(&self, channels: usize, shade: impl Fn(&SourceTerms) -> usize) -> usize {
        let (n, nn) = (self.n, self.n * self.n);
        let mut pixels = false;
        let slices: usize = self
            .terms
            .iter()
            .map(|t| {
                let g = match (&self.ox[t.j[0]], &self.oy[t.j[1]]) {
                    (AxisOp::Blocks { c: cx, .. }, AxisOp::Blocks { c: cy, .. }) => {
                        n * (cx * cx + cy * cy) + 2 * nn
                    }
                    _ => {
                        pixels = true;
                        5 * nn
                    }
                };
                channels * g + shade(&t.source)
            })
            .sum();
        slices + if pixels { channels * 4 * nn } else { 0 }
    }
}

/// Per-thread scratch of [`shade_vertex_field`].
#[derive(Clone, Debug, Default)]
pub struct FieldScratch {
    pixels: Vec<f64>,
    grid: Vec<f64>,
    u: Vec<f32>,
    g: Vec<f32>,
}

/// `B[c] = Σ_j Σ_k (P_j)_k (G_j)_k` for one vertex (module docs): the
/// vertex's transport `v.transport` (`channels` blocks of `n²`, layout
/// `k₂ · n + k₁`) to pixels once, then per kept slice `G_j` and the fused
/// kernel with the slice's source terms and `targets` target terms.
#[must_use]
pub fn shade_vertex_field(
    primitives: &Primitives,
    field: &FieldSource,
    targets: usize,
    v: &VertexMap,
    channels: usize,
    sc: &mut VertexScratch,
    fs: &mut FieldScratch,
) -> [f32; 3] {
    let n = field.n;
    let nn = n * n;
    debug_assert_eq!(v.transport.len(), channels * nn);
    fs.pixels.clear();
    fs.grid.resize(nn, 0.0);
    fs.g.resize(channels * nn, 0.0);
    fs.u.resize(nn, 0.0);
    let mut b = [0.0f32; 3];
    for term in &field.terms {
        let (ox, oy) = (&field.ox[term.j[0]], &field.oy[term.j[1]]);
        let blocks = (0..channels).all(|c| {
            let t = &v.transport[c * nn..(c + 1) * nn];
            apply_blocks(n, [ox, oy], t, &mut fs.u, &mut fs.g[c * nn..(c + 1) * nn])
        });
        if !blocks {
            if fs.pixels.is_empty() {
                fs.pixels.extend(v.transport.iter().map(|&x| f64::from(x)));
                for c in 0..channels {
                    inverse_2d(&mut fs.pixels[c * nn..(c + 1) * nn], n);
                }
            }
            pixel_slice(field, term.j, channels, fs);
        }
        let kernel = Kernel {
            primitives,
            source: &term.source,
            targets,
        };
        let vertex = VertexMap {
            s: v.s,
            o: v.o,
            transport: &fs.g,
        };
        let r = shade_vertex(&kernel, &vertex, sc);
        for (b, r) in b.iter_mut().zip(r) {
            *b += r;
        }
    }
    b
}

/// `G = M_y T M_xᵀ` for block operators ([`AxisOp::Blocks`]) on one
/// channel's coefficients `t` (`[k₂ · n + k₁]`): along t₁ within each row
/// into `u`, then along t₂ across rows into `g`. False, with nothing
/// written, unless both operators are blocks.
fn apply_blocks(n: usize, [ox, oy]: [&AxisOp; 2], t: &[f32], u: &mut [f32], g: &mut [f32]) -> bool {
    let (
        AxisOp::Blocks {
            c: cx,
            coarse: kx,
            fine: fx,
        },
        AxisOp::Blocks {
            c: cy,
            coarse: ky,
            fine: fy,
        },
    ) = (ox, oy)
    else {
        return false;
    };
    let (cx, cy) = (*cx, *cy);
    for (urow, trow) in u.chunks_exact_mut(n).zip(t.chunks_exact(n)) {
        for k in 0..cx {
            urow[k] = kx[k * cx..(k + 1) * cx]
                .iter()
                .zip(&trow[..cx])
                .map(|(a, b)| a * b)
                .sum();
        }
        for ((o, &x), &f) in urow[cx..].iter_mut().zip(&trow[cx..]).zip(&fx[cx..]) {
            *o = x * f;
        }
    }
    for k in 0..cy {
        let grow = &mut g[k * n..(k + 1) * n];
        grow.fill(0.0);
        for (k2, &a) in ky[k * cy..(k + 1) * cy].iter().enumerate() {
            for (o, &x) in grow.iter_mut().zip(&u[k2 * n..(k2 + 1) * n]) {
                *o += a * x;
            }
        }
    }
    for k in cy..n {
        let f = fy[k];
        for (o, &x) in g[k * n..(k + 1) * n].iter_mut().zip(&u[k * n..(k + 1) * n]) {
            *o = x * f;
        }
    }
    true
}

/// `G_j = Haar(w_j ⊙ pixels(T))` per channel into `fs.g`, from the
/// transport's pixels in `fs.pixels` (the general path, any view grid).
fn pixel_slice(field: &FieldSource, j: [usize; 2], channels: usize, fs: &mut FieldScratch) {
    let n = field.n;
    let nn = n * n;
    let (wx, wy) = (
        &field.wx[j[0] * n..(j[0] + 1) * n],
        &field.wy[j[1] * n..(j[1] + 1) * n],
    );
    for c in 0..channels {
        let pix = &fs.pixels[c * nn..(c + 1) * nn];
        for (c2, (row, src)) in fs
            .grid
            .chunks_exact_mut(n)
            .zip(pix.chunks_exact(n))
            .enumerate()
        {
            let y = f64::from(wy[c2]);
            for ((g, &p), &x) in row.iter_mut().zip(src).zip(wx) {
                *g = p * f64::from(x) * y;
            }
        }
        forward_2d(&mut fs.grid, n);
        for (g, &x) in fs.g[c * nn..(c + 1) * nn].iter_mut().zip(&fs.grid) {
            *g = x as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{AxisOp, apply_blocks, atom};
    use relight_affine::standard::{forward_2d, inverse_2d};

    /// The block operators give what the pixel domain gives (`Haar(w_y w_x ⊙
    /// pixels(T))`), for block-constant weights at several coarse levels,
    /// and weights that are not block-constant take the pixel path.
    #[test]
    fn block_operators_equal_the_pixel_domain() {
        let n = 32;
        let mut seed = 7u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let t: Vec<f32> = (0..n * n).map(|_| rnd()).collect();
        let blocks =
            |c: usize, vals: &[f32]| -> Vec<f32> { (0..n).map(|i| vals[i * c / n]).collect() };
        let cases = [
            (blocks(1, &[1.0]), blocks(2, &[2.0, -2.0])),
            (
                blocks(4, &[0.0, 2.0, -2.0, 0.0]),
                blocks(8, &[1.0, 1.0, 0.0, 3.0, -3.0, 0.0, 1.0, 1.0]),
            ),
            (blocks(2, &[0.5, 0.0]), blocks(4, &[-1.0, 1.0, 0.25, 0.0])),
        ];
        for (wx, wy) in cases {
            let (ox, oy) = (AxisOp::of(&wx), AxisOp::of(&wy));
            let (mut u, mut g) = (vec![0.0; n * n], vec![0.0; n * n]);
            assert!(
                apply_blocks(n, [&ox, &oy], &t, &mut u, &mut g),
                "block-constant weights are blocks"
            );
            let mut pix: Vec<f64> = t.iter().map(|&x| f64::from(x)).collect();
            inverse_2d(&mut pix, n);
            for (i, p) in pix.iter_mut().enumerate() {
                *p *= f64::from(wx[i % n] * wy[i / n]);
            }
            forward_2d(&mut pix, n);
            let worst = g
                .iter()
                .zip(&pix)
                .map(|(a, b)| (f64::from(*a) - b).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-5, "{ox:?} × {oy:?}: off by {worst}");
        }
        let ramp: Vec<f32> = (0..n).map(|i| i as f32).collect();
        assert_eq!(AxisOp::of(&ramp), AxisOp::Pixels);
    }

    #[test]
    fn atoms_are_orthonormal_and_positive_first() {
        let q = 1024;
        for i in 0..8 {
            for j in 0..8 {
                let dot: f64 = (0..q)
                    .map(|k| {
                        let x = (k as f64 + 0.5) / q as f64;
                        atom(i, x) * atom(j, x)
                    })
                    .sum::<f64>()
                    / q as f64;
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-12, "⟨{i}, {j}⟩ = {dot}");
            }
        }
        assert!(atom(1, 0.25) > 0.0 && atom(1, 0.75) < 0.0);
        assert_eq!(atom(0, 1.0), 0.0);
        assert_eq!(atom(0, -0.1), 0.0);
    }
}
