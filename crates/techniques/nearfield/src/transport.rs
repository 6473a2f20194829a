//! Per-vertex transport on the face (thesis eq. 4.33, 4.36): the
//! Lambertian cosine × visibility × the face's measure, baked in the
//! standard 2D Haar basis.
//!
//! With `v = S (t − ½)` ([`crate::face`]) the solid angle of a face element
//! is `dω = dv / (1 + |v|²)^{3/2}` and `dv = S² dt`, so the exitant radiance
//! of a Lambertian vertex of albedo ρ is
//! `B = (ρ/π) ∫ L(t) T(t) dt` with
//! `T(t) = S² max(0, n·ω(t)) V(ω(t)) / (1 + |v|²)^{3/2}`.
//! `T` is stored as its `n × n` cell means (`q × q` midpoint samples of the
//! smooth cosine factor; one shadow ray per cell at its centre, cast towards
//! the light's plane as baked: blockers beyond the plane do not shadow),
//! transformed to the standard basis: `B = (ρ/π) Σ_k L_k T_k` exactly for
//! piecewise-constant `T` (Parseval).

use crate::face::LightFrame;
use glam::Vec3;
use rayon::prelude::*;
use relight_affine::standard::forward_2d;
use relight_render::bvh::offset_ray_origin;
use relight_render::{Cancelled, Progress, SceneBvh};

/// Cosine samples per cell side.
pub const COS_SUBSAMPLES: usize = 2;

/// The transport of every vertex: `n²` standard-basis coefficients each.
#[derive(Clone, Debug, PartialEq)]
pub struct Transport {
    pub n: usize,
    pub face: f64,
    /// `values[v · n² + i2 · n + i1]`.
    pub values: Vec<f32>,
}

/// The cell means of `T` (module docs) for one vertex at `p` with normal
/// `nrm`, row-major `y · n + x`, into `out` (`n²`). `bvh`: shadows.
pub fn transport_cells(
    frame: &LightFrame,
    p: Vec3,
    nrm: Vec3,
    n: usize,
    face: f64,
    bvh: Option<&SceneBvh>,
    out: &mut [f64],
) {
    let local = frame.local(p);
    out.iter_mut().for_each(|x| *x = 0.0);
    if local.z <= 1e-6 {
        return;
    }
    let q = COS_SUBSAMPLES;
    let origin = offset_ray_origin(p, nrm);
    let s = face as f32;
    let nq = (n * q) as f32;
    for y in 0..n {
        for x in 0..n {
            let mut sum = 0.0f32;
            for j in 0..q {
                for i in 0..q {
                    let v1 = s * (((x * q + i) as f32 + 0.5) / nq - 0.5);
                    let v2 = s * (((y * q + j) as f32 + 0.5) / nq - 0.5);
                    let d = frame.face_dir(v1, v2);
                    let len = d.length();
                    let c = nrm.dot(d) / len;
                    if c > 0.0 {
                        sum += c / (len * len * len);
                    }
                }
            }
            if sum <= 0.0 {
                continue;
            }
            if let Some(b) = bvh {
                let v1 = s * ((x as f32 + 0.5) / n as f32 - 0.5);
                let v2 = s * ((y as f32 + 0.5) / n as f32 - 0.5);
                let d = frame.face_dir(v1, v2);
                let len = d.length();
                let tmax = local.z * len;
                if b.occluded(origin, d / len, tmax * 0.9999) {
                    continue;
                }
            }
            out[y * n + x] = f64::from(s * s * sum) / (q * q) as f64;
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
    let mut values = vec![0.0f32; positions.len() * nn];
    const CHUNK: usize = 1024;
    for (ci, chunk) in values.chunks_mut(CHUNK * nn).enumerate() {
        progress.check()?;
        chunk.par_chunks_mut(nn).enumerate().for_each_init(
            || vec![0.0f64; nn],
            |cells, (i, out)| {
                let v = ci * CHUNK + i;
                transport_cells(frame, positions[v], normals[v], n, face, bvh, cells);
                forward_2d(cells, n);
                for (o, c) in out.iter_mut().zip(cells.iter()) {
                    *o = *c as f32;
                }
            },
        );
        progress.inc((chunk.len() / nn) as u64);
    }
    Ok(Transport { n, face, values })
}
