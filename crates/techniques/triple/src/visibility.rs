//! Per-vertex binary visibility (spherical-wavelets-triple-product-2006 §4.1)
//! (the texels of a visibility texture are baked the same way,
//! [`bake_point_visibility`]; [`crate::vis_texture`]):
//! for every vertex, the level-`m` cell means of `V(ω)` in the vertex's local
//! frame ([`crate::lighting::frame_of`], the same rule the lighting lookup
//! uses), ray-cast with the scene BVH from [`offset_ray_origin`] at the
//! centroids of level `vis_level ≥ m` (4 = the paper's 5120 directions).
//! Directions below the vertex's horizon are not traced and count as visible:
//! the BRDF term is zero there, and a plane with nothing above it gets
//! `V ≡ 1` exactly.

use crate::basis::triangles;
use crate::lighting::{cell_dir, frame_of, padded_cells, upper_cells};
use glam::Vec3;
use rayon::prelude::*;
use relight_render::bvh::offset_ray_origin;
use relight_render::{Cancelled, Progress, SceneBvh};
use relight_sphere::icosahedral::Icosahedral;

/// Per-vertex visibility of one object: `stride` cells per vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexVisibility {
    pub stride: usize,
    pub values: Vec<f32>,
}

/// Ray-casts the visibility of every vertex of object `object` of `bvh`
/// at level `m` from samples at `vis_level` (≥ m, ≤ 5).
///
/// # Errors
/// [`Cancelled`].
pub fn bake_vertex_visibility(
    bvh: &SceneBvh,
    object: usize,
    m: usize,
    vis_level: usize,
    progress: &dyn Progress,
) -> Result<VertexVisibility, Cancelled> {
    let mesh = bvh.meshes()[object];
    let points: Vec<(Vec3, Vec3)> = mesh
        .positions
        .iter()
        .zip(&mesh.normals)
        .map(|(p, n)| (*p, *n))
        .collect();
    bake_point_visibility(bvh, &points, m, vis_level, progress)
}

/// Ray-casts the visibility of surface points `(position, unit normal)`, as
/// [`bake_vertex_visibility`] does for vertices.
///
/// # Errors
/// [`Cancelled`].
pub fn bake_point_visibility(
    bvh: &SceneBvh,
    points: &[(Vec3, Vec3)],
    m: usize,
    vis_level: usize,
    progress: &dyn Progress,
) -> Result<VertexVisibility, Cancelled> {
    let s = vis_level.max(m);
    let ico = Icosahedral::new(s).expect("visibility level ≤ 7");
    let dirs: Vec<Vec3> = (0..triangles(s))
        .map(|j| cell_dir(&ico, s, j).as_vec3())
        .collect();
    let per = 1usize << (2 * (s - m));
    let stride = padded_cells(m);
    let mut values = vec![0.0f32; points.len() * stride];
    const CHUNK: usize = 256;
    for (ci, chunk) in values.chunks_mut(CHUNK * stride).enumerate() {
        progress.check()?;
        chunk
            .par_chunks_mut(stride)
            .enumerate()
            .for_each(|(i, out)| {
                let (p, n) = points[ci * CHUNK + i];
                let f = frame_of(n);
                let o = offset_ray_origin(p, n);
                for (slot, &c) in upper_cells(m).iter().enumerate() {
                    let c = c as usize;
                    let mut seen = 0u32;
                    for d in &dirs[c * per..(c + 1) * per] {
                        if d.z <= 0.0 || !bvh.occluded(o, f.from_local(*d), f32::MAX) {
                            seen += 1;
                        }
                    }
                    out[slot] = seen as f32 / per as f32;
                }
            });
        progress.inc((chunk.len() / stride) as u64);
    }
    Ok(VertexVisibility { stride, values })
}
