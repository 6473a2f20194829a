//! [`ObjectRaster`]: a rasterizing method's visibility buffer of the scene's
//! objects, kept from frame to frame.
//!
//! The visibility buffer depends on the camera and the meshes only. A
//! lighting change (a light dragged, an environment turned) draws the next
//! frame from the same camera, so the buffer, and the coverage reduced from
//! it, are the last frame's: the frame shades them again instead of
//! rasterizing. Every method that rasterizes the scene's objects and
//! shades per pixel or per vertex holds one (the wavelet and SH methods
//! keep their buffers the same way inside their own renderers).

use crate::cull::ClosedMeshes;
use crate::method::{CoverageCache, FrameRequest, Rendered, same_mesh_list};
use crate::raster::{DrawCall, RasterOptions, Rasterizer};
use crate::{Camera, Image, RasterError, Scene};
use relight_geom::Mesh;
use std::borrow::Cow;
use std::sync::Arc;
use std::time::Instant;

/// The rasterizer, the closed-mesh cache its culling reads, what the buffer
/// holds and the coverage reduced from it.
#[derive(Debug, Default)]
pub struct ObjectRaster {
    raster: Rasterizer,
    closed: ClosedMeshes,
    /// The rasterizer's generation, the supersampled camera and the meshes
    /// of the buffer it holds.
    held: Option<(u64, Camera, Vec<Arc<Mesh>>)>,
    coverage: CoverageCache,
    rasterizations: u64,
}

impl ObjectRaster {
    /// An empty one; the first [`Self::draw`] rasterizes.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The draws of `scene`'s objects (object id = index) for `request`'s
    /// camera at `request.aa`² samples per pixel, and that supersampled
    /// camera, with the visibility buffer rasterized for them (depth range
    /// fitted to the draws, back faces of closed meshes culled from outside
    /// them, [`crate::cull`]) unless it already is: same camera, same
    /// meshes (by identity) as the buffer held.
    ///
    /// # Errors
    /// The rasterizer's (image size, depth range).
    pub fn draw<'a>(
        &mut self,
        scene: &'a Scene,
        request: &FrameRequest,
    ) -> Result<(Camera, Vec<DrawCall<'a>>), RasterError> {
        let meshes: Vec<&'a Arc<Mesh>> = scene.objects.iter().map(|o| &o.mesh).collect();
        self.draw_meshes(&meshes, request)
    }

    /// [`Self::draw`] for meshes a method shades in place of the scene's,
    /// one per object (a coarse object's refined copy,
    /// [`Scene::with_coarse_objects_refined`]).
    ///
    /// # Errors
    /// As [`Self::draw`].
    pub fn draw_meshes<'a>(
        &mut self,
        meshes: &[&'a Arc<Mesh>],
        request: &FrameRequest,
    ) -> Result<(Camera, Vec<DrawCall<'a>>), RasterError> {
        let mut camera = request.camera;
        camera.width *= request.aa;
        camera.height *= request.aa;
        let draws = draws_of(meshes, &mut self.closed, &camera);
        let holds = self.held.as_ref().is_some_and(|(g, c, held)| {
            *g != 0
                && *g == self.raster.generation()
                && *c == camera
                && same_mesh_list(held.iter(), meshes.iter().copied())
        });
        if !holds {
            self.held = None;
            let opts = RasterOptions::default().fit_depth(&camera, &draws);
            self.raster.rasterize(&camera, &draws, &opts)?;
            self.rasterizations += 1;
            self.held = Some((
                self.raster.generation(),
                camera,
                meshes.iter().map(|&m| m.clone()).collect(),
            ));
        }
        Ok((camera, draws))
    }

    /// The rasterizer, holding the buffer of the last [`Self::draw`].
    #[must_use]
    pub fn raster(&self) -> &Rasterizer {
        &self.raster
    }

    /// How many times [`Self::draw`] rasterized (a test's count).
    #[must_use]
    pub fn rasterizations(&self) -> u64 {
        self.rasterizations
    }

    /// The frame of `samples` (drawn at `k × k` per pixel over the buffer
    /// held), its coverage from the cache when the buffer is the one the
    /// cache last reduced ([`Rendered::from_samples_cached`]).
    pub fn rendered(
        &mut self,
        samples: Cow<'_, Image>,
        k: usize,
        lighting_ms: f64,
        view_start: Instant,
    ) -> Rendered {
        Rendered::from_samples_cached(
            samples,
            &self.raster,
            k,
            &mut self.coverage,
            lighting_ms,
            view_start,
        )
    }
}

/// One draw call per object (object id = index), back faces of closed
/// meshes culled from outside them.
fn draws_of<'a>(
    meshes: &[&'a Arc<Mesh>],
    closed: &mut ClosedMeshes,
    camera: &Camera,
) -> Vec<DrawCall<'a>> {
    meshes
        .iter()
        .zip(closed.of_meshes(meshes))
        .enumerate()
        .map(|(i, (&m, closed))| {
            DrawCall::new(&m.positions, &m.indices)
                .with_object_id(i as u32)
                .with_cull(crate::cull::cull_for_closed(closed.as_ref(), camera.eye))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Object, Scene};
    use glam::{Vec2, Vec3};

    fn scene() -> Scene {
        let mesh = Arc::new(relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 24, 12));
        let brdf = Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.5)).unwrap());
        let param = relight_sphere::Param::LatLong {
            width: 8,
            height: 4,
        };
        let env = relight_sphere::EnvMap::try_new(param, vec![Vec3::ONE; param.len()]).unwrap();
        let camera = Camera {
            eye: Vec3::new(0.0, 0.0, 4.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 40.0,
            width: 32,
            height: 24,
            image_offset: Vec2::ZERO,
        };
        Scene::new(vec![Object::new(mesh, brdf)], env, camera)
    }

    /// The buffer is rasterized once per camera and set of meshes: the
    /// same frame again (a lighting change) keeps it, with the same
    /// coverage; a moved camera, another `aa` or a new mesh rasterize.
    #[test]
    fn keeps_the_buffer_while_camera_and_meshes_are_unchanged() {
        let mut s = scene();
        let mut v = ObjectRaster::new();
        let request = FrameRequest::new(s.camera);
        let img = Image::new(32, 24);
        v.draw(&s, &request).unwrap();
        let first = v.rendered(Cow::Borrowed(&img), 1, 0.0, Instant::now());
        v.draw(&s, &request).unwrap();
        let again = v.rendered(Cow::Borrowed(&img), 1, 0.0, Instant::now());
        assert_eq!(v.rasterizations(), 1);
        assert_eq!(first.coverage, again.coverage);
        let mut moved = request.clone();
        moved.camera.eye.x += 0.1;
        v.draw(&s, &moved).unwrap();
        assert_eq!(v.rasterizations(), 2);
        v.draw(&s, &moved.clone().with_aa(2)).unwrap();
        assert_eq!(v.rasterizations(), 3);
        s.objects[0].mesh = Arc::new((*s.objects[0].mesh).clone());
        v.draw(&s, &moved.clone().with_aa(2)).unwrap();
        assert_eq!(v.rasterizations(), 4);
        v.draw(&s, &moved.with_aa(2)).unwrap();
        assert_eq!(v.rasterizations(), 4);
    }
}
