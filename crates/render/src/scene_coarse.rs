//! Objects too coarse for per-vertex methods, and their repair.
//!
//! Methods that sample visibility or shading at vertices and interpolate
//! between them (triple per-vertex visibility, nearfield's Gouraud shading,
//! wavelet ambient occlusion) see nothing that falls between vertices. A
//! ground quad has four: a shadow or a light's pool on it is lost, and the
//! image is plausible and wrong. [`Scene::coarse_objects`] finds such
//! objects by two measures of vertex spacing:
//! - overall, `√(area / vertices)` against [`COARSE_SHARE_OF_SCENE`] of the
//!   scene's diagonal (the light's pool falls between the vertices);
//! - where another object stands, `√(2 ā)`, `ā` the mean area of the
//!   triangles whose centroids lie within that object's size `d` (its box
//!   diagonal) of its box centre (else the nearest triangle's), against
//!   [`COARSE_SHARE_OF_BLOCKER`] × `d`, so that its shadow spans at least
//!   two vertex spacings. A floor graded towards the objects is judged
//!   where they stand.
//!
//! **The repair** ([`Scene::with_coarse_objects_refined`]) gives a method
//! a copy of the scene in which each coarse object's mesh is
//! midpoint-subdivided ([`relight_geom::Mesh::subdivide_midpoint`]: the same
//! surface, shading normals, uvs and tangents) until its spacing is at most
//! [`REFINED_SHARE_OF_LIMIT`] of the limit it failed, or the next level
//! would pass [`REFINED_MAX_VERTICES`]. Each level halves the spacing and
//! multiplies the vertices by about four. The method shades the copy and
//! warns, naming the object and both vertex counts; an object the cap
//! leaves coarse is still warned about as coarse.

use crate::Numbered;
use crate::scene::Scene;
use glam::Vec3;
use std::borrow::Cow;
use std::sync::Arc;

/// [`Scene::coarse_objects`]' limits: an object's vertex spacing may be at
/// most this share of the scene's diagonal …
pub const COARSE_SHARE_OF_SCENE: f32 = 1.0 / 8.0;
/// … and, where another object stands, at most this share of that object's
/// size (its box diagonal), about the size of its shadow.
pub const COARSE_SHARE_OF_BLOCKER: f32 = 0.5;
/// [`Scene::with_coarse_objects_refined`] subdivides until the spacing is at
/// most this share of the limit it failed: under a unit-size blocker,
/// vertices 1/16 apart, eight across its shadow.
pub const REFINED_SHARE_OF_LIMIT: f32 = 1.0 / 8.0;
/// … and stops before an object passes this many vertices (a 64 × 64-quad
/// floor has 4,225): the per-vertex bakes grow with them (triple's
/// visibility is 5,120 rays a vertex), and beyond it a finer mesh, or
/// triple's visibility texture, is the scene's choice to make.
pub const REFINED_MAX_VERTICES: usize = 5_000;

/// An object whose vertices are far apart for the scene's size
/// ([`Scene::coarse_objects`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoarseObject {
    /// Its index in [`Scene::objects`].
    pub object: usize,
    /// Its vertex count.
    pub vertices: usize,
    /// World units: about how far apart its vertices are, overall or
    /// under `near`.
    pub spacing: f32,
    /// The object whose shadow its vertices are too far apart to hold
    /// (`None`: too far apart overall).
    pub near: Option<usize>,
    /// World units: the spacing it fails (module docs), `< spacing`.
    pub limit: f32,
}

impl CoarseObject {
    /// "object I's V vertices are about S apart[ under object J]", numbered
    /// from 1 ([`Numbered`]).
    #[must_use]
    pub fn describe(&self) -> String {
        let under = self
            .near
            .map_or(String::new(), |j| format!(" under {}", Numbered::object(j)));
        format!(
            "{}'s {} vertices are about {:.2} apart{under}",
            Numbered::object(self.object),
            self.vertices,
            self.spacing
        )
    }
}

/// A coarse object that [`Scene::with_coarse_objects_refined`] subdivided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefinedObject {
    /// What was found.
    pub coarse: CoarseObject,
    /// Midpoint subdivision levels applied (≥ 1).
    pub levels: u32,
    /// The refined copy's vertex count.
    pub vertices: usize,
}

impl RefinedObject {
    /// "object I's V vertices are about S apart[ under object J]: shaded on
    /// a copy refined to V' vertices about S' apart".
    #[must_use]
    pub fn describe(&self) -> String {
        format!(
            "{}: shaded on a copy refined to {} vertices about {:.3} apart",
            self.coarse.describe(),
            self.vertices,
            self.coarse.spacing / (1u32 << self.levels) as f32
        )
    }
}

impl Scene {
    /// Objects whose vertices are too far apart to hold what falls on them
    /// (module docs), each with the criterion it fails worst (the largest
    /// `spacing / limit`).
    ///
    /// A method that samples visibility or shading per vertex refines them
    /// ([`Scene::with_coarse_objects_refined`]) or says so.
    #[must_use]
    pub fn coarse_objects(&self) -> Vec<CoarseObject> {
        let bounds: Vec<Option<relight_geom::Aabb>> =
            self.objects.iter().map(|o| o.mesh.bounds()).collect();
        let diagonal = bounds
            .iter()
            .flatten()
            .copied()
            .reduce(|a, b| relight_geom::Aabb {
                min: a.min.min(b.min),
                max: a.max.max(b.max),
            })
            .map_or(0.0, |b| b.extent().length());
        let mut out = Vec::new();
        for (object, o) in self.objects.iter().enumerate() {
            let m = &o.mesh;
            let vertices = m.positions.len().max(1);
            let mut worst: Option<CoarseObject> = None;
            let mut judge = |spacing: f32, limit: f32, near: Option<usize>| {
                let fails = limit > 0.0 && spacing > limit;
                let worse = worst.is_none_or(|w| spacing / limit > w.spacing / w.limit);
                if fails && worse {
                    worst = Some(CoarseObject {
                        object,
                        vertices,
                        spacing,
                        near,
                        limit,
                    });
                }
            };
            let spacing = (m.area() / vertices as f64).sqrt() as f32;
            judge(spacing, COARSE_SHARE_OF_SCENE * diagonal, None);
            // Each triangle's centroid and area, once for every other object.
            let triangles: Vec<(Vec3, f64)> = m
                .indices
                .iter()
                .map(|t| {
                    let [p, q, r] = t.map(|i| m.positions[i as usize]);
                    (
                        (p + q + r) / 3.0,
                        0.5 * f64::from((q - p).cross(r - p).length()),
                    )
                })
                .collect();
            for (j, b) in bounds.iter().enumerate() {
                let Some(b) = b.filter(|_| j != object) else {
                    continue;
                };
                let (c, d) = (b.center(), b.extent().length());
                // Mean triangle area within `d` of `c`, else the nearest's.
                let (mut sum, mut count, mut nearest) = (0.0f64, 0usize, (f32::INFINITY, 0.0f64));
                for &(centroid, area) in &triangles {
                    let dist = centroid.distance(c);
                    if dist <= d {
                        sum += area;
                        count += 1;
                    } else if dist < nearest.0 {
                        nearest = (dist, area);
                    }
                }
                let mean = if count > 0 {
                    sum / count as f64
                } else {
                    nearest.1
                };
                judge(
                    (2.0 * mean).sqrt() as f32,
                    COARSE_SHARE_OF_BLOCKER * d,
                    Some(j),
                );
            }
            out.extend(worst);
        }
        out
    }

    /// A copy of the scene whose coarse objects' meshes are refined (module
    /// docs; `self` itself when none is), the refined objects, and the
    /// objects still coarse after it (the vertex cap stopped them). The
    /// other objects share their meshes with `self` (`Arc`), and the
    /// objects' order, the original vertices' indices and everything else
    /// are unchanged.
    #[must_use]
    pub fn with_coarse_objects_refined(
        &self,
    ) -> (Cow<'_, Scene>, Vec<RefinedObject>, Vec<CoarseObject>) {
        let mut out = Cow::Borrowed(self);
        let mut refined = Vec::new();
        let coarse = self.coarse_objects();
        for &c in &coarse {
            let mut mesh = (*self.objects[c.object].mesh).clone();
            let mut levels = 0;
            while c.spacing / (1u32 << levels) as f32 > REFINED_SHARE_OF_LIMIT * c.limit
                && !mesh.indices.is_empty()
                && mesh.loop_vertex_count() <= REFINED_MAX_VERTICES
                && levels < 16
            {
                mesh = mesh.subdivide_midpoint();
                levels += 1;
            }
            if levels > 0 {
                refined.push(RefinedObject {
                    coarse: c,
                    levels,
                    vertices: mesh.positions.len(),
                });
                out.to_mut().objects[c.object].mesh = Arc::new(mesh);
            }
        }
        // Judged again only when a mesh changed.
        let still = if refined.is_empty() {
            coarse
        } else {
            out.coarse_objects()
        };
        (out, refined, still)
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{Object, Scene};
    use crate::{Camera, Numbered};
    use glam::Vec3;
    use relight_brdf::Brdf;
    use relight_geom::Mesh;
    use relight_sphere::EnvMap;
    use std::sync::Arc;

    fn scene(ground: Mesh) -> Scene {
        let brdf: Arc<dyn Brdf> = Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.5)).unwrap());
        let object = |m: Mesh| Object::new(Arc::new(m), brdf.clone());
        let sphere = relight_geom::shapes::uv_sphere(0.5, 32, 16);
        Scene::new(
            vec![object(ground), object(sphere)],
            EnvMap::from_fn(
                relight_sphere::Param::LatLong {
                    width: 8,
                    height: 4,
                },
                |_| Vec3::ONE,
            ),
            Camera {
                eye: Vec3::new(0.0, 1.0, 4.0),
                target: Vec3::ZERO,
                up: Vec3::Y,
                vfov_deg: 45.0,
                width: 16,
                height: 9,
                image_offset: glam::Vec2::ZERO,
            },
        )
    }

    #[test]
    fn a_ground_quad_is_coarse_and_a_grid_is_not() {
        // A 4 × 4 quad: four vertices, in a scene about 5.7 across. Both
        // measures fail: overall 2 against 0.71 (2.8×), and under the unit
        // sphere the triangles' √(2 · 8) = 4 against 0.87 (4.6×), the worse.
        let c = scene(relight_geom::shapes::plane(4.0, 1)).coarse_objects();
        assert_eq!(c.len(), 1, "{c:?}");
        assert_eq!((c[0].object, c[0].vertices, c[0].near), (0, 4, Some(1)));
        assert!((c[0].spacing - 4.0).abs() < 1e-5, "{c:?}");
        assert!((c[0].limit - 0.5 * 3f32.sqrt()).abs() < 1e-5, "{c:?}");
        assert_eq!(
            c[0].describe(),
            "object 1's 4 vertices are about 4.00 apart under object 2"
        );
        // The same floor as 64 × 64 quads, and the sphere, pass; 8 × 8 quads
        // (0.44 apart) hold the unit sphere's shadow, 4 × 4 (0.8) do not.
        let coarse = |n: usize| scene(relight_geom::shapes::plane(4.0, n)).coarse_objects();
        assert!(coarse(64).is_empty());
        assert!(coarse(8).is_empty());
        assert_eq!(coarse(4).len(), 1);
        // A floor fine under the sphere and coarse far away (the default
        // scene's is graded so): its mean spacing (over 1) would fail, the
        // spacing where the shadow falls (0.03) passes.
        let mut graded = relight_geom::shapes::plane(2.0, 64);
        let far = Mesh::try_from_triangles(
            vec![
                Vec3::new(50.0, 0.0, 50.0),
                Vec3::new(150.0, 0.0, 50.0),
                Vec3::new(50.0, 0.0, -150.0),
            ],
            vec![[0, 2, 1]],
        )
        .unwrap();
        graded.merge(&far);
        let mean = (graded.area() / graded.positions.len() as f64).sqrt();
        assert!(mean > 1.0, "{mean}");
        assert!(scene(graded).coarse_objects().is_empty());
        // A quad under the sphere and a fine grid far away: fine on average,
        // coarse where the shadow falls.
        let mut quad = relight_geom::shapes::plane(4.0, 1);
        quad.merge(
            &relight_geom::shapes::plane(2.0, 64)
                .transformed(glam::Affine3A::from_translation(Vec3::new(50.0, 0.0, 50.0))),
        );
        let c = scene(quad).coarse_objects();
        assert_eq!(c.len(), 1, "{c:?}");
        assert_eq!(c[0].near, Some(1), "{c:?}");
        assert!(c[0].describe().ends_with("apart under object 2"), "{c:?}");
    }

    #[test]
    fn refining_a_ground_quad_keeps_its_surface_and_passes() {
        let s = scene(relight_geom::shapes::plane(4.0, 1));
        let (fine, refined, still) = s.with_coarse_objects_refined();
        assert!(still.is_empty(), "{still:?}");
        assert_eq!(refined.len(), 1, "{refined:?}");
        let r = refined[0];
        assert_eq!(r.coarse.object, 0);
        // Each level halves the spacing: 2 → at most 1/8 of the limit.
        let spacing = r.coarse.spacing / (1u32 << r.levels) as f32;
        assert!(
            spacing <= super::REFINED_SHARE_OF_LIMIT * r.coarse.limit,
            "{r:?}"
        );
        assert!(
            2.0 * spacing > super::REFINED_SHARE_OF_LIMIT * r.coarse.limit,
            "{r:?}"
        );
        let m = &fine.objects[0].mesh;
        let side = (1usize << r.levels) + 1;
        assert_eq!((r.vertices, m.positions.len()), (side * side, side * side));
        assert!((m.area() - 16.0).abs() < 1e-3, "{}", m.area());
        assert!(m.positions.iter().all(|p| p.y == 0.0));
        assert!(m.normals.iter().all(|n| *n == Vec3::Y));
        assert_eq!((m.uvs.len(), m.tangents.len()), (side * side, side * side));
        // The sphere is shared, not copied.
        assert!(Arc::ptr_eq(&fine.objects[1].mesh, &s.objects[1].mesh));
        assert!(
            r.describe()
                .starts_with(&format!("{}'s 4 vertices", Numbered::object(0)))
        );
        // A fine scene comes back as it was, not copied.
        let fine = scene(relight_geom::shapes::plane(4.0, 64));
        let (same, refined, still) = fine.with_coarse_objects_refined();
        assert!(refined.is_empty() && still.is_empty());
        assert!(matches!(same, std::borrow::Cow::Borrowed(_)));
    }

    #[test]
    fn the_vertex_cap_leaves_an_object_coarse() {
        // A 400-unit floor under a unit sphere: 2^10 levels would be needed.
        let s = scene(relight_geom::shapes::plane(400.0, 1));
        let (fine, refined, still) = s.with_coarse_objects_refined();
        assert_eq!(refined.len(), 1);
        assert!(
            refined[0].vertices <= super::REFINED_MAX_VERTICES,
            "{refined:?}"
        );
        assert!(fine.objects[0].mesh.loop_vertex_count() > super::REFINED_MAX_VERTICES);
        assert_eq!(still.len(), 1, "{still:?}");
        assert_eq!(fine.objects[0].mesh.positions.len(), refined[0].vertices);
    }
}
