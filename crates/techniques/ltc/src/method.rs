//! [`LtcMethod`]: rectangular area lights by linearly transformed cosines
//! (Heitz et al. 2016) behind the method interface ([`Relighter`], name
//! `ltc`).
//!
//! # What it renders
//! Every `[[area_light]]` of the scene, per pixel: at the visible point of
//! each pixel (interpolated vertex normal, turned towards the viewer as the
//! reference turns it) the diffuse term is the exact clamped-cosine
//! integral of the rectangle ([`crate::polygon`]) and the GGX term the
//! integral of the table's LTC ([`crate::table`]) times the lobe's
//! magnitude with Schlick Fresnel. Each object's BRDF must read as Lambert +
//! isotropic GGX ([`crate::lobes`]); any other is refused naming the object.
//!
//! | scene feature | how |
//! |---|---|
//! | area lights | untextured: exact up to the LTC fit; **textured: by the texture's mean** (LTC integrates a constant polygon), with a warning |
//! | visibility (shadows) | approximate: ignored (the unoccluded rectangle), only with `--approximate` |
//! | environment, point lights, medium, normal maps, spatially varying BRDFs, animation | refused |
//!
//! | call | work |
//! |---|---|
//! | [`Relighter::prepare`] | probe each object's BRDF into Lambert + GGX terms; then `set_lighting` |
//! | [`Relighter::set_lighting`] | each light's corners and mean radiance |
//! | [`Relighter::render`] | rasterize; per sample two polygon integrals per light (diffuse, LTC) and one table lookup |

use crate::lobes::{Lobes, identify};
use crate::polygon::clamped_cosine_integral;
use crate::table::lookup;
use glam::{DVec3, Vec2, Vec3};
use relight_geom::Mesh;
use relight_render::method::{
    FrameRequest, MethodError, ObjectRaster, Relighter, Rendered, SceneFeature, Support,
    check_scene,
};
use relight_render::raster::{Background, Fragment};
use relight_render::{Image, Numbered, Progress, Scene};
use std::borrow::Cow;
use std::sync::Arc;
use std::time::Instant;

/// The method's name on the command line.
pub const LTC_METHOD_NAME: &str = "ltc";

/// What `ltc` says when it ignores shadows (with `--approximate`).
pub const SHADOWS_IGNORED: &str =
    "shadows are ignored: LTC integrates the whole, unoccluded rectangle";

/// Settings of [`LtcMethod`]; `Default` holds the defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LtcOptions {
    /// Shade the GGX term (`false`: the diffuse term alone, for comparing
    /// with a Lambert-only method). Default `true`.
    pub specular: bool,
}

impl Default for LtcOptions {
    fn default() -> Self {
        Self { specular: true }
    }
}

/// One light as integrated: world corners (uv (0,0), (1,0), (1,1), (0,1)),
/// centre, emitting normal and mean radiance.
#[derive(Clone, Copy, Debug)]
struct Rect {
    corners: [Vec3; 4],
    center: Vec3,
    normal: Vec3,
    radiance: Vec3,
}

/// An object as shaded.
struct Prepared {
    mesh: Arc<Mesh>,
    lobes: Lobes,
}

/// Area lights by LTC as a [`Relighter`] (module docs).
pub struct LtcMethod {
    options: LtcOptions,
    objects: Vec<Prepared>,
    lights: Vec<Rect>,
    warnings: Vec<String>,
    /// The visibility buffer, kept while the camera and meshes are (a
    /// lighting change shades it again).
    view: ObjectRaster,
    pending_lighting_ms: f64,
}

impl std::fmt::Debug for LtcMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LtcMethod")
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

fn invalid(option: &'static str, message: impl ToString) -> MethodError {
    MethodError::InvalidOption {
        method: LTC_METHOD_NAME,
        option,
        message: message.to_string(),
    }
}

impl LtcMethod {
    /// A method with `options`.
    ///
    /// # Errors
    /// None at present (every option value is valid); kept for the
    /// registry's uniform signature.
    pub fn new(options: LtcOptions) -> Result<Self, MethodError> {
        Ok(Self {
            options,
            objects: Vec::new(),
            lights: Vec::new(),
            warnings: Vec::new(),
            view: ObjectRaster::new(),
            pending_lighting_ms: 0.0,
        })
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &LtcOptions {
        &self.options
    }

    /// Each object's BRDF as shaded (after `prepare`).
    #[must_use]
    pub fn lobes(&self) -> Vec<Lobes> {
        self.objects.iter().map(|p| p.lobes).collect()
    }

    /// Exitant radiance towards `to_eye` (unit) at world point `p` with unit
    /// shading normal `n` and geometric normal `ng`, for an object shaded
    /// as `lobes`: every light's diffuse and GGX integrals (module docs).
    #[must_use]
    pub fn shade_point(&self, lobes: &Lobes, p: Vec3, n: Vec3, ng: Vec3, to_eye: Vec3) -> Vec3 {
        shade(&self.lights, lobes, self.options.specular, p, n, ng, to_eye)
    }
}

/// The frame `(t₁, t₂, n)` with the view in the `t₁ n` half-plane, and
/// `cos θ_o` (at least [`MIN_COS_VIEW`]).
fn view_frame(n: Vec3, v: Vec3) -> (Vec3, Vec3, f32) {
    let c = n.dot(v);
    let t = v - n * c;
    let t1 = if t.length_squared() > 1e-12 {
        t.normalize()
    } else {
        n.any_orthonormal_vector()
    };
    (t1, n.cross(t1), c.max(MIN_COS_VIEW))
}

/// Smallest `cos θ_o` shaded: a view below it (an interpolated normal
/// turned away at a silhouette) is shaded at it, as the reference does.
pub const MIN_COS_VIEW: f32 = 1e-3;

fn shade(
    lights: &[Rect],
    lobes: &Lobes,
    specular: bool,
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    to_eye: Vec3,
) -> Vec3 {
    // Two-sided surfaces: the shading normal turned with the geometric one
    // towards the viewer (as the reference turns them).
    let n = if ng.dot(to_eye) < 0.0 { -n } else { n };
    let (t1, t2, cos_o) = view_frame(n, to_eye);
    let spec = lobes.specular.filter(|_| specular).map(|s| {
        let l = lookup(s.alpha, cos_o);
        let scale = s.a * l.scale(1.0, 0.0) + s.b * l.scale(0.0, 1.0);
        (l.ltc, scale)
    });
    let mut sum = Vec3::ZERO;
    for l in lights {
        if (p - l.center).dot(l.normal) <= 0.0 {
            continue; // behind the one-sided emitter
        }
        let local = |c: Vec3| {
            let d = c - p;
            DVec3::new(
                f64::from(d.dot(t1)),
                f64::from(d.dot(t2)),
                f64::from(d.dot(n)),
            )
        };
        let poly = l.corners.map(local);
        let e_d = clamped_cosine_integral(&poly).abs() as f32;
        let mut out = lobes.diffuse * e_d;
        if let Some((ltc, scale)) = &spec {
            out += *scale * ltc.polygon_integral(&poly).abs() as f32;
        }
        sum += out * l.radiance;
    }
    sum
}

impl Relighter for LtcMethod {
    fn name(&self) -> &'static str {
        LTC_METHOD_NAME
    }

    fn supports(&self, feature: SceneFeature) -> Support {
        match feature {
            SceneFeature::AreaLights => Support::Full,
            SceneFeature::Visibility => Support::Approximate(SHADOWS_IGNORED),
            SceneFeature::Environment
            | SceneFeature::PointLights
            | SceneFeature::Medium
            | SceneFeature::NormalMaps
            | SceneFeature::SpatiallyVaryingBrdf
            | SceneFeature::LightFields
            | SceneFeature::Animation => Support::No,
        }
    }

    fn prepare(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<(), MethodError> {
        // Features it cannot render at all are refused; the caller's
        // `check_scene` decides whether ignoring shadows is allowed.
        check_scene(self, scene, true)?;
        if scene.area_lights.is_empty() {
            return Err(invalid(
                "scene",
                "needs at least one [[area_light]] (it has none)",
            ));
        }
        let mut objects = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            progress.check()?;
            let lobes = identify(o.brdf.as_ref()).map_err(|why| {
                invalid(
                    "scene",
                    format!("{}'s BRDF cannot be shaded: {why}", Numbered::object(i)),
                )
            })?;
            objects.push(Prepared {
                mesh: o.mesh.clone(),
                lobes,
            });
        }
        self.objects = objects;
        self.set_lighting(scene, progress)?;
        Ok(())
    }

    fn set_lighting(&mut self, scene: &Scene, progress: &dyn Progress) -> Result<f64, MethodError> {
        let t = Instant::now();
        progress.check()?;
        self.warnings.clear();
        self.lights = scene
            .area_lights
            .iter()
            .map(|l| {
                let mean = l.texture.as_ref().map_or(Vec3::ONE, |t| t.mean());
                Rect {
                    corners: [
                        Vec2::new(0.0, 0.0),
                        Vec2::new(1.0, 0.0),
                        Vec2::new(1.0, 1.0),
                        Vec2::new(0.0, 1.0),
                    ]
                    .map(|uv| l.point_at(uv)),
                    center: l.center,
                    normal: l.normal(),
                    radiance: l.intensity * mean,
                }
            })
            .collect();
        for (i, l) in scene.area_lights.iter().enumerate() {
            if l.texture.is_some() {
                self.warnings.push(format!(
                    "method ltc renders {}'s texture by its mean radiance (LTC integrates a constant polygon; the texture's pattern is not shown)",
                    Numbered::area_light(i)
                ));
            }
        }
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.pending_lighting_ms = ms;
        Ok(ms)
    }

    fn render(
        &mut self,
        scene: &Scene,
        request: &FrameRequest,
        progress: &dyn Progress,
    ) -> Result<Rendered, MethodError> {
        request.validate(LTC_METHOD_NAME)?;
        let t0 = Instant::now();
        let same = relight_render::method::same_meshes(self.objects.iter().map(|p| &p.mesh), scene);
        if !same {
            return Err(invalid(
                "scene",
                "the objects changed since `prepare` (or it was not called); call prepare again",
            ));
        }
        progress.check()?;
        let k = request.aa;
        let (_, draws) = self
            .view
            .draw(scene, request)
            .map_err(|e| invalid("raster", e))?;
        let (objects, lights, specular) = (&self.objects, &self.lights, self.options.specular);
        let shader = |f: &Fragment| -> Vec3 {
            let o = &objects[f.draw as usize];
            let m = &o.mesh;
            let n = if m.normals.len() == m.positions.len() {
                let [i0, i1, i2] = m.indices[f.triangle as usize].map(|i| i as usize);
                let l = f.barycentrics;
                (m.normals[i0] * l.x + m.normals[i1] * l.y + m.normals[i2] * l.z)
                    .normalize_or(f.normal)
            } else {
                f.normal
            };
            shade(
                lights, &o.lobes, specular, f.position, n, f.normal, f.to_eye,
            )
        };
        // Shaded straight into the frame handed out (the pass writes every
        // pixel of a new image: no zero-fill, no copy).
        let mut frame = Image::new(0, 0);
        self.view
            .raster()
            .shade(&draws, shader, Background::Color(Vec3::ZERO), &mut frame)
            .map_err(|e| invalid("raster", e))?;
        Ok(self.view.rendered(
            Cow::Owned(frame),
            k,
            std::mem::take(&mut self.pending_lighting_ms),
            t0,
        ))
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }
}
