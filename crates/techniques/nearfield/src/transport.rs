//! Per-vertex transport on the face (thesis eq. 4.33, 4.36): the
//! Lambertian cosine × visibility × the face's measure, baked in the
//! standard 2D Haar basis.
//!
//! With `v = S (t − ½)` ([`crate::face`]) the solid angle of a face element
//! is `dω = dv / (1 + |v|²)^{3/2}` and `dv = S² dt`, so the exitant radiance
//! of a Lambertian vertex of albedo ρ is
//! `B = (ρ/π) ∫ L(t) T(t) dt` with
//! `T(t) = S² max(0, n·ω(t)) V(ω(t)) / (1 + |v|²)^{3/2}`.
//!
//! # The Haar projection of `T`
//! `T` is stored as its **Haar projection** at order `n`: the `n × n` cell
//! means `T̄_c = n² ∫_c T dt = n² ∫_{Ω_c} max(0, n·ω) V dω`, transformed to
//! the standard basis, so that `B = (ρ/π) Σ_k L_k T_k` is `∫ L P(T)` for the
//! exact projection `P` (Parseval). Per cell:
//!
//! * **cosine, exactly** — the unshadowed term `∫_{Ω_c} max(0, n·ω) dω` is
//!   Lambert's polygon formula (the irradiance of a uniform polygon,
//!   Arvo 1995 eq. 9; Baum et al. 1989):
//!   `½ Σ_i Θ_i (n·Γ_i)`, over the edges `(d_i, d_{i+1})` of the cell seen
//!   from the vertex, `Θ_i` the angle between the corner directions and
//!   `Γ_i = (d_i × d_{i+1}) / |d_i × d_{i+1}|` (corners ordered so `Γ`
//!   points into the cell). The grid's edges are shared: `2 n (n+1)` edge
//!   terms per vertex. A cell cut by the vertex's horizon `n·ω = 0` is
//!   clipped to `n·d ≥ 0` first ([`clipped_cell_cosine`]); the formula is
//!   then exact for the clipped polygon.
//! * **visibility, supersampled where it changes** — one shadow ray at each
//!   cell centre; a cell whose centre visibility differs from one of its 8
//!   neighbours', or that the horizon cuts, casts
//!   [`SHADOW_SUBSAMPLES`]² stratified rays instead, and its cosine
//!   integral is scaled by their cosine-weighted visible fraction
//!   `Σ V_j w_j / Σ w_j` (`w_j = max(0, n·ω_j)/(1+|v_j|²)^{3/2}`, the
//!   midpoint weights of `T`). Rays are cast towards the light's plane as
//!   baked: blockers beyond the plane do not shadow. A blocker smaller
//!   than a cell that no centre ray hits is missed.
//!
//! What the projection cannot hold is `∫ (L − P L)(T − P T)`: a light edge
//! or texture detail inside a cell meets the cell's cosine gradient (the
//! order-`n` discretisation error, `docs/nearfield.md`).

use crate::face::LightFrame;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use relight_affine::standard::forward_2d;
use relight_isa::pages::vec_on_huge_pages;
use relight_render::bvh::offset_ray_origin;
use relight_render::{Cancelled, Progress, SceneBvh};

/// Shadow rays per cell side in a cell where the visibility changes
/// (module docs).
pub const SHADOW_SUBSAMPLES: usize = 4;

/// The transport of every vertex: `n²` standard-basis coefficients each.
#[derive(Clone, Debug, PartialEq)]
pub struct Transport {
    pub n: usize,
    pub face: f64,
    /// Transports per vertex: 1 (Lambert, or a specular BRDF whose colour
    /// is one tint, [`crate::specular`]) or 3 (RGB: a BRDF whose colour
    /// changes with direction).
    pub channels: usize,
    /// `values[(v · channels + c) · n² + i2 · n + i1]`.
    pub values: Vec<f32>,
}

/// Lambert's edge term `Θ (n·Γ)` of the directed edge `(a, b)` (module
/// docs): `atan2(|a×b|, a·b) · n·(a×b)/|a×b|`, 0 for a degenerate edge.
#[inline]
#[must_use]
pub fn edge_term(nrm: DVec3, a: DVec3, b: DVec3) -> f64 {
    let c = a.cross(b);
    let l = c.length();
    if l <= 0.0 {
        return 0.0;
    }
    l.atan2(a.dot(b)) * nrm.dot(c) / l
}

/// `∫ max(0, n·ω) dω` over the convex polygon `corners` (directions from
/// the vertex, ordered so Lambert's `Γ` points inside), clipped to the
/// hemisphere `n·d ≥ 0` (Sutherland–Hodgman on the polygon's plane).
#[must_use]
pub fn clipped_cell_cosine(nrm: DVec3, corners: &[DVec3]) -> f64 {
    let mut poly = [DVec3::ZERO; 8];
    let mut m = 0;
    let k = corners.len();
    for i in 0..k {
        let (a, b) = (corners[i], corners[(i + 1) % k]);
        let (na, nb) = (nrm.dot(a), nrm.dot(b));
        if na >= 0.0 {
            poly[m] = a;
            m += 1;
        }
        if (na >= 0.0) != (nb >= 0.0) {
            poly[m] = a + (b - a) * (na / (na - nb));
            m += 1;
        }
    }
    if m < 3 {
        return 0.0;
    }
    let sum: f64 = (0..m)
        .map(|i| edge_term(nrm, poly[i], poly[(i + 1) % m]))
        .sum();
    (0.5 * sum).max(0.0)
}

/// Reusable buffers of [`transport_cells`].
#[derive(Clone, Debug, Default)]
pub struct TransportScratch {
    corners: Vec<DVec3>,
    cos_at: Vec<f64>,
    h: Vec<f64>,
    v: Vec<f64>,
    /// Per cell: 0 unlit (no cosine), 1 centre visible, 2 centre blocked,
    /// 3 cut by the horizon.
    pub(crate) state: Vec<u8>,
    /// Per cell: the visible fraction ([`visible_fractions`]).
    pub(crate) vis: Vec<f64>,
}

/// The unshadowed cell integrals `∫_{Ω_c} max(0, n·ω) dω` of the `n × n`
/// face cells (row-major `y · n + x`) into `out`, exactly (module docs);
/// `scratch.state` is set to 1 for a lit cell, 3 for one the horizon cuts,
/// 0 otherwise.
pub fn cell_cosines(
    frame: &LightFrame,
    nrm: Vec3,
    n: usize,
    face: f64,
    scratch: &mut TransportScratch,
    out: &mut [f64],
) {
    let nrm = nrm.as_dvec3();
    let (xa, ya, za) = (
        frame.axes.x_axis.as_dvec3(),
        frame.axes.y_axis.as_dvec3(),
        frame.axes.z_axis.as_dvec3(),
    );
    let w = n + 1;
    let sc = scratch;
    sc.corners.resize(w * w, DVec3::ZERO);
    sc.cos_at.resize(w * w, 0.0);
    sc.h.resize(w * n, 0.0);
    sc.v.resize(n * w, 0.0);
    sc.state.resize(n * n, 0);
    for j in 0..w {
        let v2 = face * (j as f64 / n as f64 - 0.5);
        for i in 0..w {
            let v1 = face * (i as f64 / n as f64 - 0.5);
            let d = xa * v1 - ya * v2 - za;
            sc.corners[j * w + i] = d;
            sc.cos_at[j * w + i] = nrm.dot(d);
        }
    }
    // Shared edges: h[j][i] = (i, j) → (i+1, j), v[j][i] = (i, j) → (i, j+1).
    for j in 0..w {
        for i in 0..n {
            let (a, b) = (j * w + i, j * w + i + 1);
            sc.h[j * n + i] = if sc.cos_at[a] > 0.0 && sc.cos_at[b] > 0.0 {
                edge_term(nrm, sc.corners[a], sc.corners[b])
            } else {
                0.0
            };
        }
    }
    for j in 0..n {
        for i in 0..w {
            let (a, b) = (j * w + i, (j + 1) * w + i);
            sc.v[j * w + i] = if sc.cos_at[a] > 0.0 && sc.cos_at[b] > 0.0 {
                edge_term(nrm, sc.corners[a], sc.corners[b])
            } else {
                0.0
            };
        }
    }
    for y in 0..n {
        for x in 0..n {
            let c = [
                y * w + x,
                y * w + x + 1,
                (y + 1) * w + x + 1,
                (y + 1) * w + x,
            ];
            let lit = c.iter().filter(|&&k| sc.cos_at[k] > 0.0).count();
            let k = y * n + x;
            if lit == 4 {
                // A → B → C → D: Γ points into the cell (module docs).
                let s =
                    sc.h[y * n + x] + sc.v[y * w + x + 1] - sc.h[(y + 1) * n + x] - sc.v[y * w + x];
                out[k] = (0.5 * s).max(0.0);
                sc.state[k] = 1;
            } else if lit == 0 {
                out[k] = 0.0;
                sc.state[k] = 0;
            } else {
                out[k] = clipped_cell_cosine(nrm, &c.map(|i| sc.corners[i]));
                sc.state[k] = if out[k] > 0.0 { 3 } else { 0 };
            }
        }
    }
}

/// The cell means `T̄_c` (module docs) for one vertex at `p` with normal
/// `nrm`, row-major `y · n + x`, into `out` (`n²`). `bvh`: shadows.
#[allow(clippy::too_many_arguments)]
pub fn transport_cells(
    frame: &LightFrame,
    p: Vec3,
    nrm: Vec3,
    n: usize,
    face: f64,
    bvh: Option<&SceneBvh>,
    scratch: &mut TransportScratch,
    out: &mut [f64],
) {
    let local = frame.local(p);
    if local.z <= 1e-6 {
        out.iter_mut().for_each(|x| *x = 0.0);
        return;
    }
    cell_cosines(frame, nrm, n, face, scratch, out);
    if let Some(b) = bvh {
        shadow_cells(frame, p, nrm, n, face, b, scratch, out);
    }
    let area = (n * n) as f64;
    out.iter_mut().for_each(|x| *x *= area);
}

/// Scales each cell of `out` by its visible fraction (module docs).
#[allow(clippy::too_many_arguments)]
fn shadow_cells(
    frame: &LightFrame,
    p: Vec3,
    nrm: Vec3,
    n: usize,
    face: f64,
    bvh: &SceneBvh,
    scratch: &mut TransportScratch,
    out: &mut [f64],
) {
    // The midpoint weight of `T` (module docs): `cos / len³`.
    let mut vis = std::mem::take(&mut scratch.vis);
    visible_fractions(
        frame,
        p,
        nrm,
        n,
        face,
        bvh,
        &mut scratch.state,
        |_, c, len| c / (len * len * len),
        &mut vis,
    );
    // `× 1` (a visible cell) and `× 0` (a blocked one, `out ≥ 0`) are exact:
    // the same values as scaling only the cells that change.
    for (o, v) in out.iter_mut().zip(&vis) {
        *o *= *v;
    }
    scratch.vis = vis;
}

/// The visible fraction of each of the `n × n` cells into `vis` (module
/// docs): 1 where the centre ray (or no ray: an unlit cell, `state` 0) sees
/// the light and no neighbour's centre differs, 0 where it is blocked, and
/// in a cell the shadow edge or the horizon crosses (`state` 3) the
/// weighted visible fraction `Σ V_j w_j / Σ w_j` of
/// [`SHADOW_SUBSAMPLES`]² stratified rays, `w_j = weight(ω_j, cos θ_j,
/// |d_j|)` (`ω_j` unit, world; `|d_j| = √(1 + |v_j|²)`). `state` comes
/// from [`cell_cosines`] (1 lit, 3 cut by the horizon, 0 unlit) and is
/// overwritten (2: centre blocked).
#[allow(clippy::too_many_arguments)]
pub fn visible_fractions<W: Fn(Vec3, f32, f32) -> f32>(
    frame: &LightFrame,
    p: Vec3,
    nrm: Vec3,
    n: usize,
    face: f64,
    bvh: &SceneBvh,
    state: &mut [u8],
    weight: W,
    vis: &mut Vec<f64>,
) {
    vis.clear();
    vis.resize(n * n, 1.0);
    let local = frame.local(p);
    let origin = offset_ray_origin(p, nrm);
    let s = face as f32;
    // Weight and visibility of the ray through face point t (cell units).
    let ray = |tx: f32, ty: f32| -> (f32, bool) {
        let d = frame.face_dir(s * (tx / n as f32 - 0.5), s * (ty / n as f32 - 0.5));
        let len = d.length();
        let c = nrm.dot(d) / len;
        if c <= 0.0 {
            return (0.0, false);
        }
        let blocked = bvh.occluded(origin, d / len, local.z * len * 0.9999);
        (weight(d / len, c, len), !blocked)
    };
    for y in 0..n {
        for x in 0..n {
            let k = y * n + x;
            if state[k] == 1 {
                let (_, vis) = ray(x as f32 + 0.5, y as f32 + 0.5);
                state[k] = if vis { 1 } else { 2 };
            }
        }
    }
    let q = SHADOW_SUBSAMPLES;
    for y in 0..n {
        for x in 0..n {
            let k = y * n + x;
            let st = state[k];
            if st == 0 {
                continue;
            }
            let mut edge = st == 3;
            if !edge {
                'nb: for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                        if (0..n as i64).contains(&xx) && (0..n as i64).contains(&yy) {
                            let o = state[yy as usize * n + xx as usize];
                            if (o == 1 || o == 2) && o != st {
                                edge = true;
                                break 'nb;
                            }
                        }
                    }
                }
            }
            if !edge {
                if st == 2 {
                    vis[k] = 0.0;
                }
                continue;
            }
            let (mut wv, mut wt, mut nv) = (0.0f32, 0.0f32, 0usize);
            for j in 0..q {
                for i in 0..q {
                    let (w, seen) = ray(
                        x as f32 + (i as f32 + 0.5) / q as f32,
                        y as f32 + (j as f32 + 0.5) / q as f32,
                    );
                    wt += w;
                    if seen {
                        wv += w;
                        nv += 1;
                    }
                }
            }
            vis[k] = if wt > 0.0 {
                f64::from(wv / wt)
            } else {
                nv as f64 / (q * q) as f64
            };
        }
    }
}

/// Bakes the transport of every vertex of one mesh (`positions`,
/// `normals`), in parallel, with progress per chunk of vertices.
///
/// # Errors
/// [`Cancelled`].
pub fn bake_transport(
    frame: &LightFrame,
    positions: &[Vec3],
    normals: &[Vec3],
    n: usize,
    face: f64,
    bvh: Option<&SceneBvh>,
    progress: &dyn Progress,
) -> Result<Transport, Cancelled> {
    let nn = n * n;
    // On huge pages: the propagation reads a few values from each
    // vertex's block (`relight_isa::pages`).
    let mut values = vec_on_huge_pages(positions.len() * nn, 0.0f32);
    const CHUNK: usize = 1024;
    for (ci, chunk) in values.chunks_mut(CHUNK * nn).enumerate() {
        progress.check()?;
        chunk.par_chunks_mut(nn).enumerate().for_each_init(
            || (vec![0.0f64; nn], TransportScratch::default()),
            |(cells, scratch), (i, out)| {
                let v = ci * CHUNK + i;
                transport_cells(
                    frame,
                    positions[v],
                    normals[v],
                    n,
                    face,
                    bvh,
                    scratch,
                    cells,
                );
                forward_2d(cells, n);
                for (o, c) in out.iter_mut().zip(cells.iter()) {
                    *o = *c as f32;
                }
            },
        );
        progress.inc((chunk.len() / nn) as u64);
    }
    Ok(Transport {
        n,
        face,
        channels: 1,
        values,
    })
}
