//! Visibility textures (spherical-wavelets-triple-product-2006 §4.1, Fig. 6
//! and Table 3): an object's visibility stored per texel of a `res × res`
//! texture over its uvs instead of per vertex, so that a coarse mesh (the
//! paper's two-triangle floor) carries shadows as fine as the texture.
//!
//! Each texel centre is mapped to the surface through the triangle whose uv
//! triangle holds it (the first such triangle: charts must not overlap), its
//! position and normal interpolated barycentrically, and baked exactly as a
//! vertex ([`crate::visibility::bake_point_visibility`]: the same cells in
//! the same frame rule). Texels no triangle covers take the point of a
//! covered neighbour within [`DILATE`] texels, so that bilinear lookups at
//! chart borders read real visibility; farther ones are never read and hold
//! `V ≡ 1`. A pixel reads its four nearest texel centres bilinearly at its
//! interpolated uv (clamped to the texture, no wrap).
//!
//! Meshes without uvs keep per-vertex visibility (the method warns): a
//! parameterisation (chart packing) is not built.

use glam::{Vec2, Vec3};
use relight_geom::Mesh;

/// Texels a covered texel's point is spread over, beyond the charts' edges.
pub const DILATE: usize = 2;

/// Largest texture side.
pub const MAX_RES: usize = 2048;

/// The surface point `(position, unit normal)` of every texel centre of a
/// `res × res` texture over `mesh`'s uvs (module docs), row-major from
/// `uv = (0, 0)`; `None` for texels far from every chart. `None` overall
/// when the mesh has no uvs (or no normals) per vertex.
#[must_use]
pub fn texel_points(mesh: &Mesh, res: usize) -> Option<Vec<Option<(Vec3, Vec3)>>> {
    let n = mesh.positions.len();
    if res == 0 || mesh.uvs.len() != n || mesh.normals.len() != n {
        return None;
    }
    let mut out: Vec<Option<(Vec3, Vec3)>> = vec![None; res * res];
    let r = res as f32;
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| i as usize);
        let (ua, ub, uc) = (mesh.uvs[a] * r, mesh.uvs[b] * r, mesh.uvs[c] * r);
        let det = (ub - ua).perp_dot(uc - ua);
        if det.abs() < 1e-12 {
            continue;
        }
        let lo = ua.min(ub).min(uc);
        let hi = ua.max(ub).max(uc);
        let (x0, y0) = (
            (lo.x - 0.5).ceil().max(0.0) as usize,
            (lo.y - 0.5).ceil().max(0.0) as usize,
        );
        let (x1, y1) = (
            ((hi.x - 0.5).floor().min(r - 1.0)).max(-1.0),
            ((hi.y - 0.5).floor().min(r - 1.0)).max(-1.0),
        );
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        for y in y0..=y1 as usize {
            for x in x0..=x1 as usize {
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let l1 = (q - ua).perp_dot(uc - ua) / det;
                let l2 = (ub - ua).perp_dot(q - ua) / det;
                let l0 = 1.0 - l1 - l2;
                let eps = -1e-5;
                if l0 < eps || l1 < eps || l2 < eps || out[y * res + x].is_some() {
                    continue;
                }
                let p = mesh.positions[a] * l0 + mesh.positions[b] * l1 + mesh.positions[c] * l2;
                let nrm = (mesh.normals[a] * l0 + mesh.normals[b] * l1 + mesh.normals[c] * l2)
                    .normalize_or(mesh.normals[a]);
                out[y * res + x] = Some((p, nrm));
            }
        }
    }
    for _ in 0..DILATE {
        let prev = out.clone();
        for y in 0..res {
            for x in 0..res {
                if prev[y * res + x].is_some() {
                    continue;
                }
                let near = [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
                    .iter()
                    .filter_map(|(dx, dy)| {
                        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                        ((0..res as i64).contains(&nx) && (0..res as i64).contains(&ny))
                            .then(|| prev[ny as usize * res + nx as usize])
                            .flatten()
                    })
                    .next();
                out[y * res + x] = near;
            }
        }
    }
    Some(out)
}

/// The four texels around `uv` on a `res × res` texture and their bilinear
/// weights (clamped to the texture: no wrap).
#[inline]
#[must_use]
pub fn taps(uv: Vec2, res: usize) -> ([usize; 4], [f32; 4]) {
    let r = res as f32;
    let fx = (uv.x * r - 0.5).clamp(0.0, r - 1.0);
    let fy = (uv.y * r - 0.5).clamp(0.0, r - 1.0);
    let (x0, y0) = (fx as usize, fy as usize);
    let (x1, y1) = ((x0 + 1).min(res - 1), (y0 + 1).min(res - 1));
    let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
    (
        [y0 * res + x0, y0 * res + x1, y1 * res + x0, y1 * res + x1],
        [
            (1.0 - tx) * (1.0 - ty),
            tx * (1.0 - ty),
            (1.0 - tx) * ty,
            tx * ty,
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_maps_every_texel_and_taps_reproduce_linear_functions() {
        let plane = relight_geom::shapes::plane(4.0, 1);
        assert_eq!(plane.uvs.len(), plane.positions.len());
        let pts = texel_points(&plane, 16).expect("uvs");
        assert!(pts.iter().all(Option::is_some));
        // Texel centres are the uv map's points: a linear map of uv.
        let (p00, _) = pts[0].unwrap();
        let (p10, _) = pts[1].unwrap();
        let (p01, _) = pts[16].unwrap();
        for y in 0..16 {
            for x in 0..16 {
                let (p, n) = pts[y * 16 + x].unwrap();
                let want = p00 + (p10 - p00) * x as f32 + (p01 - p00) * y as f32;
                assert!((p - want).length() < 1e-4, "{x} {y}: {p} vs {want}");
                assert!((n - Vec3::Y).length() < 1e-5);
            }
        }
        // Bilinear taps: weights sum to 1 and reproduce x + 2y.
        let f = |i: usize| (i % 16) as f32 + 2.0 * (i / 16) as f32;
        for uv in [
            Vec2::new(0.3, 0.7),
            Vec2::new(0.51, 0.02),
            Vec2::new(1.0, 1.0),
        ] {
            let (t, w) = taps(uv, 16);
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            let got: f32 = t.iter().zip(&w).map(|(&i, &w)| w * f(i)).sum();
            let fx = (uv.x * 16.0 - 0.5).clamp(0.0, 15.0);
            let fy = (uv.y * 16.0 - 0.5).clamp(0.0, 15.0);
            assert!((got - (fx + 2.0 * fy)).abs() < 1e-4, "{uv}");
        }
        let mut no_uv = plane.clone();
        no_uv.uvs.clear();
        assert!(texel_points(&no_uv, 16).is_none());
    }
}
