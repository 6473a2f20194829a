//! [`ReferenceRenderer`]: the reference behind the method interface
//! ([`Relighter`], name `reference`), with progressive refinement.
//!
//! It renders every [`SceneFeature`] ([`Support::Full`]). It has nothing to
//! bake: `prepare` checks the options and scene, and each frame builds the
//! BVH and the environment sampler of the scene it is given (their cost is
//! part of the frame's `view_ms`; `relight bench` reports the BVH build).
//!
//! # Progressive frames
//! A request with [`FrameRequest::progressive`] whose camera, objects and
//! lighting equal the last frame's adds [`ReferenceOptions::pass_spp`]
//! samples to the running per-pixel sums, up to [`ReferenceOptions::spp`]
//! (then it returns the finished estimate without more work); any change, a
//! `prepare` or `set_lighting`, or a request that is not progressive starts
//! again. A non-progressive request renders all `spp` samples. Since sample
//! `s` of a pixel depends only on `(seed, pixel, s)`, the k-th progressive
//! frame equals a full render with `k · pass_spp` samples.

use super::integrator::Tracer;
use super::lights::{EnvLight, Lights};
use super::render::{Accumulator, validate};
use super::{ReferenceError, ReferenceOptions, validate_scene};
use crate::bvh::{BvhParts, SceneBvh};
use crate::method::{
    COVERAGE_SUBSAMPLES, Coverage, FrameRequest, FrameTimings, MethodError, Noise, Relighter,
    Rendered, SceneFeature, Support, rasterize_coverage,
};
use crate::{AreaLight, Camera, Progress, Scene};
use glam::{Mat3, Vec2, Vec3};
use relight_geom::Mesh;
use relight_sphere::Param;
use std::sync::Arc;
use std::time::Instant;

/// The reference renderer as a [`Relighter`] (module docs).
#[derive(Clone, Debug, Default)]
pub struct ReferenceRenderer {
    /// Its settings (every default in [`ReferenceOptions::default`]).
    pub options: ReferenceOptions,
    running: Option<(FrameKey, Accumulator, Arc<Coverage>)>,
    /// The last BVH and the meshes it was built over, held so that no other
    /// mesh can take their addresses: reused while a scene's objects are
    /// the same `Arc`s (every pass of a still view, every lighting change).
    bvh: Option<(Vec<Arc<Mesh>>, BvhParts)>,
    bvh_builds: usize,
}

impl ReferenceRenderer {
    /// A renderer with `options`.
    #[must_use]
    pub fn new(options: ReferenceOptions) -> Self {
        Self {
            options,
            running: None,
            bvh: None,
            bvh_builds: 0,
        }
    }

    /// BVH builds so far (a scene whose meshes are the same `Arc`s as the
    /// last frame's reuses its BVH).
    #[must_use]
    pub fn bvh_builds(&self) -> usize {
        self.bvh_builds
    }

    /// Samples per pixel of the running estimate (0 before the first frame).
    #[must_use]
    pub fn spp(&self) -> u32 {
        self.running.as_ref().map_or(0, |(_, a, _)| a.spp)
    }
}

/// What a progressive frame must share with the last one.
#[derive(Clone, Debug, PartialEq)]
struct FrameKey {
    camera: Camera,
    meshes: Vec<usize>,
    materials: Vec<(usize, usize, usize, usize)>,
    env_param: Param,
    env: Vec<Vec3>,
    world_from_env: Mat3,
    points: Vec<crate::PointLight>,
    areas: Vec<(Vec3, Vec2, Mat3, Vec3, usize)>,
    medium: Option<crate::Medium>,
    visibility: bool,
}

fn ptr<T: ?Sized>(a: &Arc<T>) -> usize {
    Arc::as_ptr(a).cast::<()>() as usize
}

impl FrameKey {
    fn of(scene: &Scene, camera: &Camera) -> Self {
        Self {
            camera: *camera,
            meshes: scene.objects.iter().map(|o| ptr(&o.mesh)).collect(),
            materials: scene
                .objects
                .iter()
                .map(|o| {
                    (
                        ptr(&o.brdf),
                        o.normal_map.as_ref().map_or(0, ptr),
                        o.blend.as_ref().map_or(0, |b| ptr(&b.second)),
                        o.blend.as_ref().map_or(0, |b| ptr(&b.weight)),
                    )
                })
                .collect(),
            env_param: scene.env.param,
            env: scene.env.texels.clone(),
            world_from_env: scene.world_from_env,
            points: scene.point_lights.clone(),
            areas: scene
                .area_lights
                .iter()
                .map(|a: &AreaLight| {
                    (
                        a.center,
                        a.size,
                        a.world_from_light,
                        a.intensity,
                        a.texture.as_ref().map_or(0, ptr),
                    )
                })
                .collect(),
            medium: scene.medium,
            visibility: scene.visibility,
        }
    }
}

fn method_error(e: ReferenceError) -> MethodError {
    match e {
        ReferenceError::Cancelled => MethodError::Cancelled,
        ReferenceError::ZeroSamples(_) => MethodError::InvalidOption {
            method: "reference",
            option: "spp",
            message: e.to_string(),
        },
        ReferenceError::EmptyImage { .. } => MethodError::InvalidOption {
            method: "reference",
            option: "size",
            message: e.to_string(),
        },
        ReferenceError::InvalidOption { parameter, .. } => MethodError::InvalidOption {
            method: "reference",
            option: parameter,
            message: e.to_string(),
        },
        ReferenceError::InvalidScene { .. } => MethodError::failed("reference", e),
    }
}

impl Relighter for ReferenceRenderer {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn supports(&self, _feature: SceneFeature) -> Support {
        Support::Full
    }

    fn prepare(&mut self, scene: &Scene, _progress: &dyn Progress) -> Result<(), MethodError> {
        self.running = None;
        if self.options.spp == 0 {
            return Err(method_error(ReferenceError::ZeroSamples(0)));
        }
        validate_scene(scene).map_err(method_error)
    }

    fn set_lighting(
        &mut self,
        scene: &Scene,
        _progress: &dyn Progress,
    ) -> Result<f64, MethodError> {
        let t = Instant::now();
        self.running = None;
        validate_scene(scene).map_err(method_error)?;
        Ok(t.elapsed().as_secs_f64() * 1e3)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(self.name())?;
        let t = Instant::now();
        let camera = request.camera;
        let opts = self.options;
        validate(scene, &camera, &opts).map_err(method_error)?;
        let key = FrameKey::of(scene, &camera);
        let (mut acc, coverage) = match self.running.take() {
            Some((k, a, c)) if request.progressive && k == key => (a, c),
            _ => (
                Accumulator::new(camera.width, camera.height),
                Arc::new(
                    rasterize_coverage(scene, &camera, COVERAGE_SUBSAMPLES)
                        .map_err(|e| MethodError::failed(self.name(), e))?,
                ),
            ),
        };
        let until = if request.progressive {
            (acc.spp + opts.pass_spp.max(1)).min(opts.spp)
        } else {
            opts.spp
        };
        if until > acc.spp {
            let meshes: Vec<&Mesh> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
            let cached = self.bvh.take().and_then(|(held, parts)| {
                let same = held.len() == scene.objects.len()
                    && held
                        .iter()
                        .zip(&scene.objects)
                        .all(|(h, o)| Arc::ptr_eq(h, &o.mesh));
                same.then(|| SceneBvh::from_parts(meshes.clone(), parts))
                    .flatten()
            });
            let bvh = cached.unwrap_or_else(|| {
                self.bvh_builds += 1;
                SceneBvh::build(&meshes)
            });
            let light = EnvLight::new(&scene.env, opts.env_filter);
            let wavelet = super::render::wavelet_lights(scene, &opts);
            let tracer = Tracer::new(scene, &bvh, Lights::new(scene, &light), &opts)
                .with_wavelet(wavelet.as_ref());
            acc.add_samples(&tracer, scene, &camera, &opts, until, progress)
                .map_err(method_error)?;
            let held = scene.objects.iter().map(|o| o.mesh.clone()).collect();
            self.bvh = Some((held, bvh.into_parts()));
        }
        let r = acc.image();
        self.running = Some((key, acc, coverage.clone()));
        let object_rms_relative_std_error = r.rms_relative_std_error_over(&coverage.object_mask());
        Ok(Rendered {
            image: r.image,
            coverage: Some(coverage),
            timings: FrameTimings {
                lighting_ms: 0.0,
                view_ms: t.elapsed().as_secs_f64() * 1e3,
            },
            noise: Some(Noise {
                spp: r.spp,
                relative_std_error: r.relative_std_error,
                rms_relative_std_error: r.rms_relative_std_error,
                object_rms_relative_std_error,
            }),
        })
    }
}
