//! Adaptive selection in the renderer (spherical-wavelets-triple-product-2006
//! §4.1, Fig. 7): per vertex, each of the three functions keeps its `n`
//! largest area-weighted wavelet terms ([`crate::select()`]) and the product
//! is the sparse tree sum ([`crate::product::sparse`], Ng et al. 2004).
//!
//! # Where the functions come from
//! The same tables as the full 5120-cell top-only product, at the leaf
//! level (`m = 4`): the lighting from the table's six taps in the vertex's
//! frame, the BRDF term from its four view taps, the visibility from the
//! vertex's baked row. Each is turned into its 5120 wavelet coefficients
//! ([`Basis::forward`]) and cut to `n` terms: lighting and BRDF per colour
//! channel and per frame, visibility once at `prepare`
//! ([`select_visibility`]). With `n = 5120` nothing is cut and the result
//! is the top-only 5120 product (tested).
//!
//! # Cost and scope
//! Per vertex and frame: ten 5120-long dense accumulations, six forward
//! transforms, six selections and three sparse products, about 0.3 M
//! operations, so the method shades adaptively **per vertex** (Gouraud,
//! [`crate::method::Shading::Vertex`]) — the paper's Fig. 7 comparison is
//! per point too. The tables are the 5120-cell ones: the lighting table
//! must be the isotropic one (`twists = 1`, rebuilt per rotation), as the
//! twisted one would hold 631 MB.

use crate::basis::Basis;
use crate::brdf_table::BrdfTable;
use crate::lighting::{LightTable, Tap, upper_cells};
use crate::product::sparse;
use crate::select::{Selection, SparseVec, select};
use crate::storage::Planes;
use glam::Vec3;

/// Top-only level of the tables adaptive selection reads (the leaves).
pub const ADAPTIVE_LEVEL: usize = 4;

/// The visibility rows (one per vertex, `stride` slots of the leaf level's
/// [`upper_cells`]) cut to `n` adaptive terms each. Leaves below the
/// horizon hold 0: their BRDF term is 0, so the product does not see them,
/// and zeros cost no terms.
#[must_use]
pub fn select_visibility(vis: &Planes, rows: usize, stride: usize, n: usize) -> Vec<SparseVec> {
    let b = Basis::paper();
    let upper = upper_cells(ADAPTIVE_LEVEL);
    let mut leaves = vec![0.0f32; b.len()];
    let mut coeffs = vec![0.0f32; b.len()];
    (0..rows)
        .map(|v| {
            for (slot, &c) in upper.iter().enumerate() {
                leaves[c as usize] = vis.get(v * stride + slot, stride);
            }
            b.forward(&leaves, &mut coeffs);
            select(b, &coeffs, n, Selection::Adaptive)
        })
        .collect()
}

/// Sums `Σ w · table[offset + plane · stride + slot]` over `taps` into the
/// leaves `out` (one colour plane; slot `i` is leaf `upper_cells[i]`, the
/// other leaves 0).
fn accumulate(data: &Planes, taps: &[Tap], plane: usize, stride: usize, out: &mut [f32]) {
    let upper = upper_cells(ADAPTIVE_LEVEL);
    out.iter_mut().for_each(|x| *x = 0.0);
    for t in taps.iter().filter(|t| t.weight != 0.0) {
        let base = t.offset as usize + plane * stride;
        for (slot, &c) in upper.iter().enumerate() {
            out[c as usize] += t.weight * data.get(base + slot, stride);
        }
    }
}

/// `B = Σ L V ρ` of one vertex with `n` adaptive terms per function
/// (module docs); `vis` is the vertex's selected visibility (`None`: V ≡ 1).
#[must_use]
pub fn shade_adaptive(
    table: &LightTable,
    ltaps: &[Tap; 6],
    brdf: &BrdfTable,
    btaps: &[Tap; 4],
    vis: Option<&SparseVec>,
    n: usize,
) -> Vec3 {
    let b = Basis::paper();
    let len = b.len();
    let unshadowed;
    let v = match vis {
        Some(v) => v,
        None => {
            let mut c = vec![0.0f32; len];
            b.forward(&vec![1.0; len], &mut c);
            unshadowed = select(b, &c, n, Selection::Adaptive);
            &unshadowed
        }
    };
    let mut leaves = vec![0.0f32; len];
    let mut coeffs = vec![0.0f32; len];
    let mut out = [0.0f32; 3];
    for (ch, o) in out.iter_mut().enumerate() {
        accumulate(&table.data, ltaps, ch, table.stride, &mut leaves);
        b.forward(&leaves, &mut coeffs);
        let l = select(b, &coeffs, n, Selection::Adaptive);
        accumulate(&brdf.data, btaps, ch, brdf.stride, &mut leaves);
        b.forward(&leaves, &mut coeffs);
        let r = select(b, &coeffs, n, Selection::Adaptive);
        // The tree sum carries the leaf area A_L (`product::top_only`); the
        // tables' cells already fold in the exact solid angles.
        *o = (sparse(b, &l, v, &r) / b.leaf_area()) as f32;
    }
    Vec3::from_array(out)
}
