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
use relight_sh::project::{ShRgb, Window, project_env};
use relight_sh::window::ChosenWindow;
use relight_sphere::EnvMap;
use std::sync::Arc;

/// The camera-independent SH state of one scene (module docs), with the
/// rasterizer of its last frame.
pub struct LitScene {
    lit: Lit,
    /// The meshes built for (identity compared with a rendered scene's).
    meshes: Vec<Arc<Mesh>>,
    /// Fingerprint of the projected environment and its projection (env frame).
    env: (u64, ShRgb),
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

/// A 64-bit fingerprint of the map's parameterization and every texel's bits
/// (FNV-1a over 32-bit words, in six interleaved streams folded at the
/// end, with the texel count: one stream was a chain of dependent
/// multiplies, ≈ 0.6 ms per lighting change of the default scene): equal
/// maps give equal fingerprints.
fn env_fingerprint(env: &EnvMap) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    const BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    let fnv = |h: u64, w: u64| (h ^ w).wrapping_mul(PRIME);
    let mut h = BASIS;
    for b in format!("{:?}", env.param).bytes() {
        h = fnv(h, u64::from(b));
    }
    // Two texels (six words) per step, one stream per word.
    let mut lanes = [BASIS; 6];
    let pairs = env.texels.chunks_exact(2);
    let rest = pairs.remainder();
    let word = |t: &glam::Vec3, k: usize| u64::from(t[k].to_bits());
    for p in pairs {
        for (k, l) in lanes.iter_mut().enumerate() {
            *l = fnv(*l, word(&p[k / 3], k % 3));
        }
    }
    for t in rest {
        for (k, l) in lanes.iter_mut().take(3).enumerate() {
            *l = fnv(*l, word(t, k));
        }
    }
    lanes
        .iter()
        .fold(fnv(h, env.texels.len() as u64), |h, &l| fnv(h, l))
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
        let fp = env_fingerprint(&scene.env);
        let (env, raster) = match previous {
            Some(p) if p.env.0 == fp && p.env.1.order == order => (p.env, p.raster),
            p => (
                (fp, project_env(&scene.env, order, Window::None)?),
                p.map_or_else(Rasterizer::new, |p| p.raster),
            ),
        };
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
        let fp = env_fingerprint(&scene.env);
        let with = LitWith {
            env: fp,
            filter: renderer.filter.clone(),
            world_from_env: renderer.lighting_rotation.as_ref().map(|r| r.0),
        };
        if self.lit_with.as_ref() == Some(&with) {
            return Ok(());
        }
        self.lit_with = None;
        if fp != self.env.0 {
            self.env = (
                fp,
                project_env(&scene.env, self.lit.order_max, Window::None)?,
            );
        }
        renderer.light(&mut self.lit, &self.env.1, progress)?;
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
        let fp = env_fingerprint(&scene.env);
        if fp != self.env.0 {
            self.env = (
                fp,
                project_env(&scene.env, self.lit.order_max, Window::None)?,
            );
            self.lit_with = None;
        }
        Ok(&self.env.1)
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use relight_sphere::Param;

    /// Equal maps give equal fingerprints; one texel's channel changed (in
    /// each of the six streams and in an odd map's last texel), the size or
    /// the parameterization changed, give another.
    #[test]
    fn env_fingerprint_follows_every_texel() {
        let map = |w: usize| {
            EnvMap::from_fn(
                Param::LatLong {
                    width: w,
                    height: 3,
                },
                |d| Vec3::new(1.0 + d.x, 0.5 + d.y * d.y, 0.25 + d.z),
            )
        };
        let base = map(7);
        assert_eq!(env_fingerprint(&base), env_fingerprint(&map(7)));
        let mut seen = vec![env_fingerprint(&base)];
        for (t, c) in [(0, 0), (0, 2), (1, 1), (10, 0), (11, 2), (20, 1)] {
            let mut m = base.clone();
            m.texels[t][c] += 1e-3;
            let f = env_fingerprint(&m);
            assert!(!seen.contains(&f), "texel {t} channel {c}");
            seen.push(f);
        }
        assert!(!seen.contains(&env_fingerprint(&map(8))));
        let mut swapped = base.clone();
        swapped.texels.swap(0, 1);
        assert!(!seen.contains(&env_fingerprint(&swapped)));
    }
}
