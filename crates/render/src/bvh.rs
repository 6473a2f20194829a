//! Ray casting against every triangle of a scene: [`SceneBvh`], shading
//! points, robust ray offsets and ambient occlusion.
//!
//! # Why obvhs
//! The acceleration structure is the compressed wide BVH8 (CWBVH) of the
//! `obvhs` crate (Ylitie, Karras & Laine 2017, "Efficient Incoherent Ray
//! Traversal on GPUs Through Compressed Wide BVHs"), built by PLOC (Meister &
//! Bittner 2018) with parallel reinsertion, traversed on the CPU four nodes at a
//! time with SSE. It is pure Rust, uses our glam, builds ~80 K triangles in
//! ~80 ms and traces a few million incoherent rays/s on two cores — there is
//! no reason to write our own.
//!
//! # Layout
//! The BVH references primitives through `primitive_indices`; the triangles
//! are stored *in BVH order* (three `Vec3A` vertices per triangle, contiguous) so the leaf test needs
//! no indirection, and a parallel array maps each back to
//! (object, triangle of that object's mesh).
//!
//! # Intersection
//! The watertight test of Woop, Benthin & Wald ("Watertight Ray/Triangle
//! Intersection", JCGT 2013), two-sided: a ray through an edge or vertex
//! shared by several triangles hits at least one of them, so reference images
//! have no pinholes along edges. It returns t and the barycentric weights
//! (w0, w1, w2) of the three vertices.
//!
//! # Self-intersection
//! Secondary rays start at [`offset_ray_origin`]: the hit point recomputed
//! from the barycentrics, pushed along the geometric normal by a few ulps of its
//! own magnitude (Wächter & Binder, "A Fast and Robust Method for Avoiding
//! Self-Intersection", Ray Tracing Gems ch. 6, 2019). This is scale invariant:
//! no scene-dependent epsilon.

use crate::sampling::{Rng, sample_cosine_hemisphere};
use crate::{Cancelled, Progress, Scene};
use glam::{IVec3, Vec2, Vec3, Vec3A, Vec4};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_sphere::Frame;

/// A ray–triangle intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (distance for a unit direction).
    pub t: f32,
    /// Index of the object (mesh) hit, in build order.
    pub object: u32,
    /// Index of the triangle within that object's mesh.
    pub triangle: u32,
    /// Barycentric weights of the triangle's three vertices (sum to 1).
    pub barycentrics: [f32; 3],
}

/// Everything a shader needs at a hit, world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingPoint {
    /// Hit position (from the barycentrics, not `o + t d`).
    pub position: Vec3,
    /// Unit geometric normal of the triangle, by its winding (v1 − v0) × (v2 − v0),
    /// *not* flipped towards the viewer.
    pub geometric_normal: Vec3,
    /// Unit interpolated vertex normal (the geometric normal when the mesh has none).
    pub shading_normal: Vec3,
    /// Interpolated texture coordinates (zero when the mesh has none).
    pub uv: Vec2,
    /// Interpolated tangent (xyz, w = handedness); zero when the mesh has none.
    pub tangent: Vec4,
    pub object: u32,
    pub triangle: u32,
    pub barycentrics: [f32; 3],
}

impl ShadingPoint {
    /// Shading frame around `normal` (usually [`ShadingPoint::shading_normal`]
    /// or an override), with x along the tangent when the mesh has one.
    #[must_use]
    pub fn frame(&self, normal: Vec3) -> Frame {
        if self.tangent.w != 0.0 {
            Frame::from_normal_tangent(normal, self.tangent.truncate())
        } else {
            Frame::from_z(normal)
        }
    }
}

/// One triangle in BVH order: its three vertices.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v: [Vec3A; 3],
}

/// Per-ray constants of the watertight test (Woop, Benthin & Wald 2013):
/// the dominant axis `kz` of the direction, the two others, and the shear
/// that maps the ray onto +Z.
#[derive(Clone, Copy, Debug)]
struct RayShear {
    org: Vec3A,
    k: [usize; 3],
    s: [f32; 3],
}

impl RayShear {
    #[inline(always)]
    fn new(org: Vec3A, dir: Vec3A) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / dir[kz];
        Self {
            org,
            k: [kx, ky, kz],
            s: [dir[kx] * sz, dir[ky] * sz, sz],
        }
    }
}

impl Tri {
    /// Watertight ray–triangle test (Woop, Benthin & Wald, "Watertight
    /// Ray/Triangle Intersection", JCGT 2013), two-sided: `(t, [w0, w1, w2])`
    /// when `tmin < t < tmax`. Rays through a shared edge or vertex hit at
    /// least one of the triangles sharing it.
    #[inline(always)]
    fn intersect(&self, r: &RayShear, tmin: f32, tmax: f32) -> Option<(f32, [f32; 3])> {
        let [kx, ky, kz] = r.k;
        let [sx, sy, sz] = r.s;
        let a = self.v[0] - r.org;
        let b = self.v[1] - r.org;
        let c = self.v[2] - r.org;
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exactly on an edge in f32: decide in f64.
            let f = |p: f32, q: f32, r: f32, s: f32| {
                (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32
            };
            u = f(cx, by, cy, bx);
            v = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let t_scaled = u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz]);
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        (t > tmin && t < tmax).then_some((t, [u * inv, v * inv, w * inv]))
    }
}

/// A [`SceneBvh`]'s tree without its meshes ([`SceneBvh::into_parts`]).
#[derive(Clone, Debug)]
pub struct BvhParts {
    /// Triangles per mesh, the guard of [`SceneBvh::from_parts`].
    triangles: Vec<usize>,
    bvh: CwBvh,
    tris: Vec<Tri>,
    ids: Vec<(u32, u32)>,
}

/// A BVH over every triangle of a set of meshes (the objects of a [`Scene`]).
#[derive(Debug)]
pub struct SceneBvh<'a> {
    meshes: Vec<&'a Mesh>,
    bvh: CwBvh,
    tris: Vec<Tri>,
    /// (object, triangle) of each entry of `tris`.
    ids: Vec<(u32, u32)>,
}

impl<'a> SceneBvh<'a> {
    /// Builds the BVH over all triangles of the scene's objects (object index
    /// = position in `scene.objects`).
    #[must_use]
    pub fn from_scene(scene: &'a Scene) -> Self {
        let meshes: Vec<&Mesh> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
        Self::build(&meshes)
    }

    /// Builds the BVH over all triangles of `meshes` (already in world space).
    /// Triangles whose indices are out of range are skipped.
    #[must_use]
    pub fn build(meshes: &[&'a Mesh]) -> Self {
        let mut tris_in: Vec<Triangle> = Vec::new();
        let mut ids_in: Vec<(u32, u32)> = Vec::new();
        for (oi, m) in meshes.iter().enumerate() {
            let n = m.positions.len();
            for (ti, t) in m.indices.iter().enumerate() {
                if t.iter().any(|&i| i as usize >= n) {
                    continue;
                }
                let [a, b, c] = t.map(|i| Vec3A::from(m.positions[i as usize]));
                if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                    continue;
                }
                tris_in.push(Triangle {
                    v0: a,
                    v1: b,
                    v2: c,
                });
                ids_in.push((oi as u32, ti as u32));
            }
        }
        let (bvh, tris, ids) = if tris_in.is_empty() {
            (CwBvh::default(), Vec::new(), Vec::new())
        } else {
            let bvh = build_cwbvh_from_tris(
                &tris_in,
                BvhBuildParams::medium_build(),
                &mut Default::default(),
            );
            let mut tris = Vec::with_capacity(bvh.primitive_indices.len());
            let mut ids = Vec::with_capacity(bvh.primitive_indices.len());
            for &pi in &bvh.primitive_indices {
                let t = &tris_in[pi as usize];
                tris.push(Tri {
                    v: [t.v0, t.v1, t.v2],
                });
                ids.push(ids_in[pi as usize]);
            }
            (bvh, tris, ids)
        };
        Self {
            meshes: meshes.to_vec(),
            bvh,
            tris,
            ids,
        }
    }

    /// The built tree without the borrow of its meshes, for a caller that
    /// keeps the meshes alive across frames (by `Arc`) and lends them again
    /// with [`Self::from_parts`] instead of building again.
    #[must_use]
    pub fn into_parts(self) -> BvhParts {
        BvhParts {
            triangles: self.meshes.iter().map(|m| m.indices.len()).collect(),
            bvh: self.bvh,
            tris: self.tris,
            ids: self.ids,
        }
    }

    /// The BVH of `parts` over `meshes`, which must be the meshes it was
    /// built from, in the same order and unchanged; `None` when their count
    /// or triangle counts differ (a cheap guard, not a proof: the caller
    /// vouches for identity).
    #[must_use]
    pub fn from_parts(meshes: Vec<&'a Mesh>, parts: BvhParts) -> Option<Self> {
        let same = meshes.len() == parts.triangles.len()
            && meshes
                .iter()
                .zip(&parts.triangles)
                .all(|(m, &n)| m.indices.len() == n);
        if !same {
            return None;
        }
        Some(Self {
            meshes,
            bvh: parts.bvh,
            tris: parts.tris,
            ids: parts.ids,
        })
    }

    /// The meshes, in object order.
    #[must_use]
    pub fn meshes(&self) -> &[&'a Mesh] {
        &self.meshes
    }

    /// Number of triangles in the BVH.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Closest hit of the ray `origin + t·dir` with `tmin < t < tmax`
    /// (`dir` need not be unit; `t` is in its units).
    #[must_use]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let o = Vec3A::from(origin);
        let d = canonical_dir(dir);
        let ray = Ray::new(o, d, tmin, tmax);
        let mut hit = RayHit::none();
        let shear = RayShear::new(o, d);
        let mut best = (0usize, [0.0f32; 3]);
        let found = self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            match self.tris[id].intersect(&shear, tmin, r.tmax) {
                Some((t, b)) => {
                    best = (id, b);
                    t
                }
                None => f32::INFINITY,
            }
        });
        if !found {
            return None;
        }
        let (id, barycentrics) = best;
        debug_assert_eq!(id, hit.primitive_id as usize);
        let (object, triangle) = self.ids[id];
        Some(Hit {
            t: hit.t,
            object,
            triangle,
            barycentrics,
        })
    }

    /// True when anything lies on the ray `origin + t·dir`, 0 < t < `tmax`
    /// (any-hit traversal; start shadow rays at [`offset_ray_origin`]).
    #[must_use]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let o = Vec3A::from(origin);
        let d = canonical_dir(dir);
        let ray = Ray::new(o, d, 0.0, tmax);
        let shear = RayShear::new(o, d);
        !self.bvh.ray_traverse_miss(ray, |_, id| {
            match self.tris[id].intersect(&shear, 0.0, tmax) {
                Some((t, _)) => t,
                None => f32::INFINITY,
            }
        })
    }

    /// Position, normals, uv and tangent at a hit.
    #[must_use]
    pub fn shading_point(&self, hit: &Hit) -> ShadingPoint {
        let m = self.meshes[hit.object as usize];
        let [i0, i1, i2] = m.indices[hit.triangle as usize].map(|i| i as usize);
        let [w0, w1, w2] = hit.barycentrics;
        let (p0, p1, p2) = (m.positions[i0], m.positions[i1], m.positions[i2]);
        let position = p0 * w0 + p1 * w1 + p2 * w2;
        let geometric_normal = (p1 - p0).cross(p2 - p0).normalize_or(Vec3::Z);
        let shading_normal = if m.normals.len() == m.positions.len() {
            (m.normals[i0] * w0 + m.normals[i1] * w1 + m.normals[i2] * w2)
                .normalize_or(geometric_normal)
        } else {
            geometric_normal
        };
        let uv = if m.uvs.len() == m.positions.len() {
            m.uvs[i0] * w0 + m.uvs[i1] * w1 + m.uvs[i2] * w2
        } else {
            Vec2::ZERO
        };
        let tangent = if m.tangents.len() == m.positions.len() {
            let t = m.tangents[i0] * w0 + m.tangents[i1] * w1 + m.tangents[i2] * w2;
            t.truncate()
                .normalize_or_zero()
                .extend(m.tangents[i0].w.signum())
        } else {
            Vec4::ZERO
        };
        ShadingPoint {
            position,
            geometric_normal,
            shading_normal,
            uv,
            tangent,
            object: hit.object,
            triangle: hit.triangle,
            barycentrics: hit.barycentrics,
        }
    }

    /// Cosine-weighted ambient occlusion at `p` with normal `n` (see
    /// [`ambient_occlusion`]).
    #[must_use]
    pub fn ambient_occlusion(&self, p: Vec3, n: Vec3, samples: u32, rng: &mut Rng) -> f32 {
        ambient_occlusion(self, p, n, samples, rng)
    }

    /// Per-vertex ambient occlusion of object `object` against the whole BVH
    /// (every object occludes): `samples` cosine-weighted rays per vertex from
    /// the vertex pushed along its normal. Parallel over vertices; vertex `v`
    /// uses the random stream (`seed`, v), so results are independent of the
    /// thread count. Progress: one unit per 1024 vertices.
    ///
    /// # Errors
    /// [`Cancelled`] when `progress` asks to stop.
    pub fn vertex_ambient_occlusion(
        &self,
        object: usize,
        samples: u32,
        seed: u64,
        progress: &dyn Progress,
    ) -> Result<Vec<f32>, Cancelled> {
        let Some(m) = self.meshes.get(object) else {
            return Ok(Vec::new());
        };
        let normals: Vec<Vec3> = if m.normals.len() == m.positions.len() {
            m.normals.clone()
        } else {
            area_weighted_normals(m)
        };
        let scale = scene_scale(&self.meshes);
        const CHUNK: usize = 1024;
        progress.start(
            "ambient occlusion",
            m.positions.len().div_ceil(CHUNK) as u64,
        );
        let out: Result<Vec<Vec<f32>>, Cancelled> = m
            .positions
            .par_chunks(CHUNK)
            .zip(normals.par_chunks(CHUNK))
            .enumerate()
            .map(|(c, (ps, ns))| {
                progress.check()?;
                let v = ps
                    .iter()
                    .zip(ns)
                    .enumerate()
                    .map(|(k, (&p, &n))| {
                        let mut rng = Rng::for_sample(seed, (c * CHUNK + k) as u64, 0);
                        // Vertices are shared by triangles with other planes:
                        // lift by a small fraction of the scene size as well.
                        let n = n.normalize_or(Vec3::Y);
                        ambient_occlusion(self, p + n * (1e-4 * scale), n, samples, &mut rng)
                    })
                    .collect();
                progress.inc(1);
                Ok(v)
            })
            .collect();
        progress.finish();
        Ok(out?.concat())
    }
}

/// `dir` with negative zeros made positive: obvhs's node test mishandles a
/// `-0.0` direction component (an axis-aligned ray such as `-Vec3::Y` would
/// miss everything), and `x + 0.0` maps `-0.0` to `+0.0` and leaves every other
/// value unchanged.
#[inline(always)]
fn canonical_dir(dir: Vec3) -> Vec3A {
    Vec3A::from(dir) + Vec3A::ZERO
}

/// Length of the diagonal of the bounding box of all positions (1 when empty).
fn scene_scale(meshes: &[&Mesh]) -> f32 {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for m in meshes {
        for &p in &m.positions {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let d = (hi - lo).length();
    if d.is_finite() && d > 0.0 { d } else { 1.0 }
}

/// Area-weighted vertex normals (for meshes that carry none).
fn area_weighted_normals(m: &Mesh) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; m.positions.len()];
    for t in &m.indices {
        if t.iter().any(|&i| i as usize >= n.len()) {
            continue;
        }
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let f = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += f;
        }
    }
    n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}

/// Fraction of the cosine-weighted hemisphere around the unit normal `n` at `p`
/// that sees no geometry (1 = fully open, 0 = fully occluded): the
/// "accessibility" that multiplies unshadowed lighting. Estimated with
/// `samples` cosine-distributed rays of unbounded length from
/// [`offset_ray_origin`]`(p, n)`. 1 when `samples` is 0.
#[must_use]
pub fn ambient_occlusion(bvh: &SceneBvh, p: Vec3, n: Vec3, samples: u32, rng: &mut Rng) -> f32 {
    if samples == 0 {
        return 1.0;
    }
    let frame = Frame::from_z(n);
    let o = offset_ray_origin(p, n);
    let mut open = 0u32;
    for _ in 0..samples {
        let d = frame.from_local(sample_cosine_hemisphere(rng.next_2d()));
        if !bvh.occluded(o, d, f32::INFINITY) {
            open += 1;
        }
    }
    open as f32 / samples as f32
}

/// Per-vertex ambient occlusion of a single mesh against itself (builds a BVH;
/// see [`SceneBvh::vertex_ambient_occlusion`]). Used by the wavelet renderer.
///
/// # Errors
/// [`Cancelled`] when `progress` asks to stop.
pub fn vertex_ambient_occlusion(
    mesh: &Mesh,
    samples: u32,
    seed: u64,
    progress: &dyn Progress,
) -> Result<Vec<f32>, Cancelled> {
    SceneBvh::build(&[mesh]).vertex_ambient_occlusion(0, samples, seed, progress)
}

/// Origin for a secondary ray leaving the surface point `p` on the side of the
/// (geometric) normal `n` (Wächter & Binder 2019): each coordinate moves by
/// `256·n` ulps, or by `n/65536` near the origin where ulps are tiny.
#[inline]
#[must_use]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65_536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i: IVec3 = (n * INT_SCALE).as_ivec3();
    let step = |p: f32, o: i32, n: f32| -> f32 {
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            let o = if p < 0.0 { -o } else { o };
            f32::from_bits((p.to_bits() as i32).wrapping_add(o) as u32)
        }
    };
    Vec3::new(
        step(p.x, of_i.x, n.x),
        step(p.y, of_i.y, n.y),
        step(p.z, of_i.z, n.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::NoProgress;

    use crate::reference::floor_quad;

    fn quad(y: f32, half: f32) -> Mesh {
        floor_quad(y, half)
    }

    #[test]
    fn ray_hits_sphere_at_analytic_distance() {
        let s = relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 128, 64);
        let bvh = SceneBvh::build(&[&s]);
        let mut rng = Rng::new(7, 0);
        for _ in 0..200 {
            let o = Vec3::new(0.0, 0.0, 5.0);
            let target = (rng.next_2d() - 0.5) * 1.0;
            let d = (Vec3::new(target.x, target.y, 0.0) - o).normalize();
            let hit = bvh
                .intersect(o, d, 0.0, f32::INFINITY)
                .expect("ray toward the sphere centre region hits");
            // Analytic: |o + t d| = 1.
            let b = o.dot(d);
            let t_exact = -b - (b * b - (o.length_squared() - 1.0)).sqrt();
            assert!(
                (hit.t - t_exact).abs() < 2e-3,
                "t {} vs analytic {}",
                hit.t,
                t_exact
            );
            let sp = bvh.shading_point(&hit);
            let p = o + d * hit.t;
            assert!(
                (sp.position - p).length() < 1e-4,
                "position {:?} vs {:?}",
                sp.position,
                p
            );
            assert!(
                sp.shading_normal.dot(p.normalize()) > 0.999,
                "normal {:?}",
                sp.shading_normal
            );
            assert!(
                sp.geometric_normal.dot(p.normalize()) > 0.99,
                "outward winding {:?}",
                sp.geometric_normal
            );
            let bsum: f32 = sp.barycentrics.iter().sum();
            assert!((bsum - 1.0).abs() < 1e-5);
        }
        // Misses.
        assert!(
            bvh.intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::Z, 0.0, f32::INFINITY)
                .is_none()
        );
        assert!(
            bvh.intersect(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 0.0, 3.0)
                .is_none(),
            "tmax respected"
        );
    }

    #[test]
    fn occlusion_and_multiple_objects() {
        let floor = quad(0.0, 10.0);
        let ball = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, 2.0, 0.0), 1.0, 32, 16);
        let bvh = SceneBvh::build(&[&floor, &ball]);
        assert_eq!(
            bvh.triangle_count(),
            floor.triangle_count() + ball.triangle_count()
        );
        let below = Vec3::new(0.0, 0.0, 0.0);
        let o = offset_ray_origin(below, Vec3::Y);
        assert!(
            bvh.occluded(o, Vec3::Y, f32::INFINITY),
            "the ball shadows the point below it"
        );
        assert!(!bvh.occluded(o, Vec3::Y, 0.5), "tmax before the ball");
        assert!(!bvh.occluded(
            offset_ray_origin(Vec3::new(5.0, 0.0, 0.0), Vec3::Y),
            Vec3::Y,
            f32::INFINITY
        ));
        // Regression: -Vec3::Y has -0.0 components, which obvhs mishandled.
        let hit = bvh
            .intersect(Vec3::new(0.0, 10.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY)
            .unwrap();
        assert_eq!(hit.object, 1, "ball first from above");
        assert!((hit.t - 7.0).abs() < 0.02, "t {}", hit.t);
        let hit = bvh
            .intersect(Vec3::new(5.0, 10.0, 0.0), -Vec3::Y, 0.0, f32::INFINITY)
            .unwrap();
        assert_eq!(hit.object, 0);
        assert!((hit.t - 10.0).abs() < 1e-4);
    }

    #[test]
    fn offset_origin_escapes_its_own_surface_at_any_scale() {
        for scale in [1e-3f32, 1.0, 1e3, 1e5] {
            let s = relight_geom::shapes::uv_sphere_at(Vec3::splat(scale * 3.0), scale, 64, 32);
            let bvh = SceneBvh::build(&[&s]);
            let mut rng = Rng::new(3, 1);
            let mut self_hits = 0;
            for _ in 0..2000 {
                let d0 = crate::sampling::sample_uniform_sphere(rng.next_2d());
                let o = Vec3::splat(scale * 3.0) + d0 * scale * 3.0;
                let Some(hit) = bvh.intersect(
                    o,
                    (Vec3::splat(scale * 3.0) - o).normalize(),
                    0.0,
                    f32::INFINITY,
                ) else {
                    continue;
                };
                let sp = bvh.shading_point(&hit);
                let org = offset_ray_origin(sp.position, sp.geometric_normal);
                // Leave along the outward geometric hemisphere: a convex mesh is never hit again.
                let frame = Frame::from_z(sp.geometric_normal);
                let d = frame.from_local(sample_cosine_hemisphere(rng.next_2d()));
                if bvh.occluded(org, d, f32::INFINITY) {
                    self_hits += 1;
                }
            }
            assert_eq!(self_hits, 0, "self-intersections at scale {scale}");
        }
    }

    #[test]
    fn ambient_occlusion_of_open_plane_and_under_a_ball() {
        let floor = quad(0.0, 100.0);
        let bvh = SceneBvh::build(&[&floor]);
        let mut rng = Rng::new(1, 2);
        assert_eq!(
            ambient_occlusion(&bvh, Vec3::ZERO, Vec3::Y, 256, &mut rng),
            1.0
        );
        // Under an infinite-ish ceiling at height 1: fully occluded.
        let ceiling = quad(1.0, 1000.0);
        let bvh = SceneBvh::build(&[&floor, &ceiling]);
        assert_eq!(
            ambient_occlusion(&bvh, Vec3::ZERO, Vec3::Y, 256, &mut rng),
            0.0
        );
        // A disk-like blocker: a sphere of radius r at height h above the point
        // blocks the cone of half-angle asin(r/h); cosine-weighted blocked
        // fraction = sin²(asin(r/h)) = (r/h)².
        let (r, h) = (1.0f32, 2.0f32);
        let ball = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, h, 0.0), r, 128, 64);
        let bvh = SceneBvh::build(&[&floor, &ball]);
        let n = 20_000;
        let ao = ambient_occlusion(&bvh, Vec3::ZERO, Vec3::Y, n, &mut rng);
        let expected = 1.0 - (r / h) * (r / h);
        let sigma = (expected * (1.0 - expected) / n as f32).sqrt();
        assert!(
            (ao - expected).abs() < 4.0 * sigma + 2e-3,
            "AO {ao} vs analytic {expected} (σ {sigma})"
        );
    }

    #[test]
    fn vertex_ao_is_deterministic_and_bounded() {
        let floor = quad(-1.5, 5.0);
        let ball = relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 24, 12);
        let bvh = SceneBvh::build(&[&ball, &floor]);
        let a = bvh.vertex_ambient_occlusion(0, 64, 9, &NoProgress).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| bvh.vertex_ambient_occlusion(0, 64, 9, &NoProgress).unwrap());
        assert_eq!(a, b, "same seed, different thread count");
        assert_eq!(a.len(), ball.positions.len());
        assert!(a.iter().all(|&v| (0.0..=1.0).contains(&v)));
        // Top of the ball (vertex 0 is the +Y pole) is open, bottom pole sees the floor.
        let top = a[0];
        let bottom = a[a.len() - 1];
        assert!(top > 0.99 && bottom < 0.05, "top {top} bottom {bottom}");
        // A convex mesh barely occludes its own vertices (only rays grazing the
        // adjacent faces, which tilt away from the vertex normal, can hit).
        let single = vertex_ambient_occlusion(&ball, 256, 1, &NoProgress).unwrap();
        let mean = single.iter().sum::<f32>() / single.len() as f32;
        eprintln!(
            "self-AO of a convex 12×24 sphere: mean {mean}, min {:?}",
            single.iter().copied().fold(1.0f32, f32::min)
        );
        assert!(mean > 0.98, "mean self-AO {mean}");
    }
}
