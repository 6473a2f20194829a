//! [`LitScene`]: the SH renderer's state kept between frames, for every
//! method that shades with SH lighting.
//!
//! A frame of SH shading splits by what invalidates it (Kautz et al. 2002;
//! [`crate::relight`] has the algorithm):
//!
//! | step | depends on | cost | here |
//! |---|---|---|---|
//! | BRDF tables, vertex frames | the meshes and BRDFs | a bake, then O(vertices) | [`LitScene::build`] |
//! | the environment's projection | the map's texels | O(texels · n²) | [`LitScene::light`], only when the map's fingerprint changes |
//! | lighting in every vertex frame | the lighting rotation and filter | O(vertices · n³) | [`LitScene::light`] |
//! | rasterization, per-pixel rotation and dot product | the camera | O(samples · n³) | [`LitScene::render_into`] |
//!
//! The `sh` method ([`crate::method::ShMethod`]) and the fog method (SH
//! lighting filtered by the fog's point-spread function, sun-thesis-2008
//! eqs. 3.35–3.37) both keep one, so that a view change does only the last
//! row's work.

use crate::bake::BrdfShTable;
use crate::relight::{Background, Lit};
use crate::{LightingFilter, NormalMap, ShLightError, ShRenderer, ShRotationMethod};
use glam::Mat3;
use relight_geom::Mesh;
use relight_render::raster::Rasterizer;
use relight_render::{Camera, Image, Progress, Scene};
use relight_sh::project::{EnvProjection, ShRgb};
use relight_sh::window::ChosenWindow;
use std::sync::Arc;

/// The camera-independent SH state of one scene (module docs), with the
/// rasterizer of its last frame.
pub struct LitScene {
    lit: Lit,
    /// The meshes built for (identity compared with a rendered scene's).
    meshes: Vec<Arc<Mesh>>,
    /// The projected environment (env frame), kept by its fingerprint.
    env: EnvProjection,
    /// What the vertex lighting was last lit with: the environment's
    /// fingerprint, the lighting filter and rotation (`None`: unlit).
    lit_with: Option<LitWith>,
    raster: Rasterizer,
    /// The camera `raster` was last rasterized for and the generation that
    /// produced ([`Rasterizer::generation`]); the geometry is fixed per
    /// build, so a lighting change under this camera keeps the buffer.
    rastered: Option<(u64, Camera)>,
}

/// The inputs of one [`LitScene::light`].
#[derive(Clone, Debug, PartialEq)]
struct LitWith {
    env: u64,
    filter: Option<LightingFilter>,
    world_from_env: Option<Mat3>,
}

impl std::fmt::Debug for LitScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LitScene")
            .field("order", &self.lit.order_max)
            .field("objects", &self.meshes.len())
            .finish_non_exhaustive()
    }
}

impl LitScene {
    /// The tables, vertex data and environment projection of `scene` at
    /// `renderer`'s order, unlit until [`LitScene::light`]; `needs_uvs(i)`
    /// where object `i` will be shaded with a normal map. `previous` (the
    /// state of an earlier `build`) lends its projection when the
    /// environment is unchanged.
    ///
    /// # Errors
    /// As [`ShRenderer::build`](crate::ShRenderer) (meshes without normals, a
    /// normal-mapped mesh without uvs or tangents, an anisotropic BRDF,
    /// cancellation) and the projection's.
    pub fn build(
        renderer: &ShRenderer,
        scene: &Scene,
        needs_uvs: &dyn Fn(usize) -> bool,
        previous: Option<Self>,
        progress: &dyn Progress,
    ) -> Result<Self, ShLightError> {
        let order = renderer.order();
        let lit = renderer.build(scene, order, needs_uvs, progress)?;
        let (mut env, raster) = previous.map_or_else(
            || (EnvProjection::default(), Rasterizer::new()),
            |p| (p.env, p.raster),
        );
        env.project(&scene.env, order)?;
        Ok(Self {
            lit,
            meshes: scene.objects.iter().map(|o| o.mesh.clone()).collect(),
            env,
            lit_with: None,
            raster,
            rastered: None,
        })
    }

    /// Whether `scene` has exactly the meshes this was built for (the same
    /// allocations, in order; an animation that moves an object makes new
    /// ones).
    #[must_use]
    pub fn is_built_for(&self, scene: &Scene) -> bool {
        self.meshes.len() == scene.objects.len()
            && self
                .meshes
                .iter()
                .zip(&scene.objects)
                .all(|(m, o)| Arc::ptr_eq(m, &o.mesh))
    }

    /// A lighting change: the environment projected again if its texels
    /// changed, then rotated by `renderer`'s lighting rotation, filtered by
    /// its lighting filter and rotated into every vertex frame. Nothing is
    /// done when the environment, filter and rotation are those of the last
    /// call (a point-light change of the fog method, say).
    ///
    /// # Errors
    /// The projection's, cancellation (the scene is then unlit).
    pub fn light(
        &mut self,
        renderer: &ShRenderer,
        scene: &Scene,
        progress: &dyn Progress,
    ) -> Result<(), ShLightError> {
        self.env.project(&scene.env, self.lit.order_max)?;
        let with = LitWith {
            env: self.env.fingerprint().expect("projected above"),
            filter: renderer.filter.clone(),
            world_from_env: renderer.lighting_rotation.as_ref().map(|r| r.0),
        };
        if self.lit_with.as_ref() == Some(&with) {
            return Ok(());
        }
        self.lit_with = None;
        let light = self.env.last().expect("projected above");
        renderer.light(&mut self.lit, light, progress)?;
        self.lit_with = Some(with);
        Ok(())
    }

    /// A view change: rasterizes for `camera` (whose size is the output's,
    /// supersampling included; kept from the last call when that was for the
    /// same camera, as after a lighting change) and shades every sample into `out` at
    /// `order` bands with per-pixel `rotation` (`beta_lim`: the Taylor
    /// rotations' switch to exact), object `i` with `normal_maps[i]`; empty
    /// samples as `background` says. `scene` gives the environment for the
    /// background (its camera is not used).
    ///
    /// # Errors
    /// Rasterizer errors (image size, camera), an order above the built one,
    /// `normal_maps` not one per object.
    #[allow(clippy::too_many_arguments)]
    pub fn render_into(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        order: usize,
        rotation: ShRotationMethod,
        normal_maps: &[Option<&NormalMap>],
        beta_lim: f32,
        background: Background,
        out: &mut Image,
    ) -> Result<(), ShLightError> {
        let kept = self
            .rastered
            .is_some_and(|(g, c)| g != 0 && g == self.raster.generation() && c == *camera);
        if !kept {
            self.rastered = None;
            self.lit.rasterize(camera, &mut self.raster)?;
            self.rastered = Some((self.raster.generation(), *camera));
        }
        self.lit.shade_into(
            &self.raster,
            camera,
            scene,
            order,
            rotation,
            normal_maps,
            beta_lim,
            background,
            out,
        )
    }

    /// [`LitScene::render_into`] shading from a visibility buffer the caller
    /// rasterized: `raster` must hold `scene`'s meshes (positions and
    /// indices, draw `i` = object `i`, in order) drawn for `camera`. That
    /// buffer equals the one [`LitScene::render_into`] draws (meshes without
    /// tangents are shaded on one vertex per corner, in the same triangle
    /// order and at the same positions), so a caller that needs the
    /// visibility buffer anyway (the fog method's point-light pass)
    /// rasterizes once per frame.
    ///
    /// # Errors
    /// As [`LitScene::render_into`]; a raster with another triangle count.
    #[allow(clippy::too_many_arguments)]
    pub fn shade_raster_into(
        &mut self,
        raster: &Rasterizer,
        scene: &Scene,
        camera: &Camera,
        order: usize,
        rotation: ShRotationMethod,
        normal_maps: &[Option<&NormalMap>],
        beta_lim: f32,
        background: Background,
        out: &mut Image,
    ) -> Result<(), ShLightError> {
        self.lit.shade_into(
            raster,
            camera,
            scene,
            order,
            rotation,
            normal_maps,
            beta_lim,
            background,
            out,
        )
    }

    /// The environment's projection in its own frame at the built order
    /// (projected again first if `scene`'s texels changed since), for a
    /// caller that shades in the world frame itself (the fog method's
    /// per-vertex environment part) and so needs no per-vertex lighting.
    ///
    /// # Errors
    /// The projection's.
    pub fn projection(&mut self, scene: &Scene) -> Result<&ShRgb, ShLightError> {
        let (sh, fresh) = self.env.project(&scene.env, self.lit.order_max)?;
        if fresh {
            self.lit_with = None;
        }
        Ok(sh)
    }

    /// The rasterizer of the last [`LitScene::render_into`] (its visibility
    /// buffer gives the frame's coverage).
    #[must_use]
    pub fn raster(&self) -> &Rasterizer {
        &self.raster
    }

    /// The vertices the last frame lit into their frames (step 2 of
    /// [`crate::relight`], lazy: the stale ones it showed).
    #[must_use]
    pub fn last_relit(&self) -> usize {
        self.lit.last_relit
    }

    /// The BRDF tables, one per object (shared where objects share a BRDF).
    #[must_use]
    pub fn tables(&self) -> &[Arc<BrdfShTable>] {
        &self.lit.tables
    }

    /// The window chosen for each object at the built order.
    #[must_use]
    pub fn windows(&self) -> &[ChosenWindow] {
        &self.lit.windows
    }
}
