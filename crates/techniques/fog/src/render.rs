//! The per-pixel fog renderer on relight-render's rasterizer: every covered
//! pixel evaluates the complete model of [`crate::model`] (eq. 3.29) for
//! every light from the interpolated world position and normal; empty
//! pixels get the airlight to infinity (eq. 3.17). [`FogMode::OpenGl`]
//! renders the classic exponential fog of the same scene for comparison.
//!
//! Bad input is rejected before drawing: β < 0, negative intensities,
//! missing G tables for a Phong exponent, and lights inside closed geometry
//! (a light is *inside* an object when rays from it in six directions all
//! cross that object's surface an odd number of times — open surfaces such
//! as a floor do not trip it).

use crate::FogError;
use crate::model::{FogMaterial, FogModel, Phase, PointLight, PreparedLight, opengl_fog_pixel};
use crate::shade::{MaterialConst, PixelBatch, shade_background, shade_surface_run};
use crate::table::{FogTables, Interp};
use crate::view_segment;
use glam::Vec3;
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::raster::{Background, DrawCall, NO_TRIANGLE, RasterOptions, Rasterizer};
use relight_render::{Camera, Image, Medium};

/// Which fog to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FogMode {
    /// The analytic single-scattering model (Sun 2008, ch. 3).
    Analytic,
    /// OpenGL GL_EXP fog with this fog colour (see [`opengl_fog_pixel`]).
    OpenGl { fog_color: Vec3 },
}

/// One mesh (world space) and its material.
#[derive(Clone, Copy, Debug)]
pub struct FogObject<'a> {
    pub mesh: &'a Mesh,
    pub material: FogMaterial,
}

/// The objects of `scene` as fog-shaded surfaces: each BRDF becomes the
/// paper's Lambert + Phong surface fitted to it ([`FogMaterial::fit`]).
#[must_use]
pub fn scene_objects(scene: &relight_render::Scene) -> Vec<FogObject<'_>> {
    scene
        .objects
        .iter()
        .map(|o| FogObject {
            mesh: &o.mesh,
            material: FogMaterial::fit(o.brdf.as_ref()),
        })
        .collect()
}

/// The first `count` (≤ 4) point lights placed around the default scene's
/// objects (`relight_scene::default_scene`): what `render --method fog`
/// uses without `--light`, `bench fog` and the viewer.
#[must_use]
pub fn default_scene_lights(count: usize) -> Vec<PointLight> {
    [
        (Vec3::new(-1.5, 2.2, 1.5), Vec3::splat(8.0)),
        (Vec3::new(1.8, 1.6, 1.2), Vec3::new(6.0, 4.5, 3.0)),
        (Vec3::new(0.2, 2.0, -1.8), Vec3::new(3.0, 4.5, 6.0)),
        (Vec3::new(-0.4, 0.5, 1.6), Vec3::new(5.0, 3.0, 5.0)),
    ]
    .into_iter()
    .take(count)
    .map(|(p, i)| PointLight::new(p, i))
    .collect()
}

/// Medium and evaluation settings.
#[derive(Clone, Debug)]
pub struct FogSettings<'a> {
    /// Scattering coefficient β (1/world unit, ≥ 0).
    pub beta: f32,
    pub phase: Phase,
    pub interp: Interp,
    pub mode: FogMode,
    pub tables: &'a FogTables,
    /// Check lights against closed geometry (brute force, O(lights × triangles)).
    pub check_lights_inside: bool,
    /// Single-scattering albedo σ_s/β in [0, 1] ([`FogModel::with_albedo`]; 1
    /// in the thesis).
    pub albedo: f32,
    /// `Some(R)`: the medium fills only the ball of radius R about the world
    /// origin (`relight_render::Medium`), so an empty pixel's airlight is
    /// integrated along its ray to the ball's edge (eq. 3.16 over the
    /// finite segment) instead of to infinity (eq. 3.17). The eye must be
    /// inside the ball; surfaces are assumed inside it. `None`: unbounded.
    pub ball_radius: Option<f32>,
}

impl<'a> FogSettings<'a> {
    /// Isotropic analytic fog with bilinear lookups.
    #[must_use]
    pub fn new(tables: &'a FogTables, beta: f32) -> Self {
        Self {
            beta,
            phase: Phase::isotropic(),
            interp: Interp::Bilinear,
            mode: FogMode::Analytic,
            tables,
            check_lights_inside: true,
            albedo: 1.0,
            ball_radius: None,
        }
    }
}

/// Möller–Trumbore ray/triangle test, t > 1e-6.
fn ray_hits(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> bool {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return false;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    e2.dot(q) * inv > 1e-6
}

/// The first object that encloses `p` (odd crossings in six directions), if any.
///
/// An object whose bounding box does not contain `p` is skipped: each of
/// the six directions has its dominant component of one sign on one axis,
/// so from a point beyond the box on that side the ray only moves away from
/// every triangle, crosses none (an even count) and the object cannot
/// enclose `p` — the same answer as the crossing count, without it.
#[must_use]
pub fn enclosing_object(objects: &[FogObject], p: Vec3) -> Option<usize> {
    enclosing_object_within(objects, &object_bounds(objects), p)
}

/// Each object's bounding box (lowest, highest corner).
fn object_bounds(objects: &[FogObject]) -> Vec<(Vec3, Vec3)> {
    objects
        .iter()
        .map(|o| {
            o.mesh
                .positions
                .iter()
                .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), q| {
                    (lo.min(*q), hi.max(*q))
                })
        })
        .collect()
}

/// [`enclosing_object`] with the objects' [`object_bounds`] given (several
/// points against the same objects scan their vertices once).
fn enclosing_object_within(
    objects: &[FogObject],
    bounds: &[(Vec3, Vec3)],
    p: Vec3,
) -> Option<usize> {
    objects.iter().zip(bounds).position(|(o, &(lo, hi))| {
        let outside = p.cmplt(lo).any() || p.cmpgt(hi).any();
        !outside && encloses(o, p)
    })
}

/// Whether `o` encloses `p`: rays from it in six directions all cross its
/// surface an odd number of times.
fn encloses(o: &FogObject, p: Vec3) -> bool {
    let dirs = [
        Vec3::new(1.0, 0.013, 0.021),
        Vec3::new(-1.0, 0.017, -0.011),
        Vec3::new(0.019, 1.0, 0.007),
        Vec3::new(-0.009, -1.0, 0.023),
        Vec3::new(0.015, -0.012, 1.0),
        Vec3::new(-0.021, 0.008, -1.0),
    ];
    {
        let m = o.mesh;
        dirs.iter().all(|d| {
            let d = d.normalize();
            let n = m
                .indices
                .iter()
                .filter(|t| t.iter().all(|&i| (i as usize) < m.positions.len()))
                .filter(|t| {
                    ray_hits(
                        p,
                        d,
                        m.positions[t[0] as usize],
                        m.positions[t[1] as usize],
                        m.positions[t[2] as usize],
                    )
                })
                .count();
            n % 2 == 1
        })
    }
}

/// Checks β, intensities, light positions and that no light is inside an object.
pub fn validate_lights(
    objects: &[FogObject],
    lights: &[PointLight],
    beta: f32,
    check_inside: bool,
) -> Result<(), FogError> {
    if !(beta.is_finite() && beta >= 0.0) {
        return Err(FogError::Beta { beta });
    }
    let bounds = if check_inside && !lights.is_empty() {
        object_bounds(objects)
    } else {
        Vec::new()
    };
    for (index, l) in lights.iter().enumerate() {
        if !(l.intensity.is_finite() && l.intensity.min_element() >= 0.0) {
            return Err(FogError::Intensity {
                index,
                intensity: l.intensity.to_array(),
            });
        }
        if !l.position.is_finite() {
            return Err(FogError::LightPosition {
                index,
                position: l.position.to_array(),
            });
        }
        if check_inside && let Some(object) = enclosing_object_within(objects, &bounds, l.position)
        {
            return Err(FogError::LightInsideGeometry {
                index,
                position: l.position.to_array(),
                object,
            });
        }
    }
    Ok(())
}

/// Renders `objects` seen by `camera` under point `lights` in fog.
pub fn render_fog(
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
    settings: &FogSettings,
) -> Result<Image, FogError> {
    let mut r = Rasterizer::new();
    let mut out = Image::new(camera.width, camera.height);
    render_fog_into(&mut r, objects, camera, lights, settings, &mut out)?;
    Ok(out)
}

/// [`render_fog`] reusing a rasterizer and an output image. Per frame it
/// allocates only a few small per-object/per-light arrays and one scratch
/// [`PixelBatch`] per rayon task; the per-pixel loops do not allocate once
/// the scratch has grown to a row.
pub fn render_fog_into(
    rasterizer: &mut Rasterizer,
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
    settings: &FogSettings,
    out: &mut Image,
) -> Result<(), FogError> {
    match settings.mode {
        FogMode::Analytic => {
            check_frame(objects, camera, lights, settings)?;
            rasterize_objects(rasterizer, objects, &[], camera)?;
            shade_fog_raster(rasterizer, objects, camera, lights, settings, out)
        }
        FogMode::OpenGl { fog_color } => {
            check_frame(objects, camera, lights, settings)?;
            frame_model(objects, camera, lights, settings)?;
            render_opengl(
                rasterizer, objects, camera, lights, settings, fog_color, out,
            )
        }
    }
}

/// Rasterizes `objects` (draw i = object i, positions and indices) for
/// `camera` into `rasterizer`: the visibility buffer [`shade_fog_raster`]
/// shades. `closed[i]` are object i's bounds where its mesh is closed and
/// outward ([`relight_render::cull::ClosedMeshes`]): its back faces are
/// culled from outside them, the same buffer with fewer triangles; objects
/// past the end of `closed` (all, for `&[]`) draw both sides.
///
/// # Errors
/// Rasterizer errors (image size, camera, indices).
pub fn rasterize_objects(
    rasterizer: &mut Rasterizer,
    objects: &[FogObject],
    closed: &[Option<relight_geom::Aabb>],
    camera: &Camera,
) -> Result<(), FogError> {
    let draws: Vec<DrawCall> = objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let closed = closed.get(i).and_then(Option::as_ref);
            DrawCall::new(&o.mesh.positions, &o.mesh.indices)
                .with_object_id(i as u32)
                .with_cull(relight_render::cull::cull_for_closed(closed, camera.eye))
        })
        .collect();
    let options = RasterOptions::default().fit_depth(camera, &draws);
    rasterizer.rasterize(camera, &draws, &options)?;
    Ok(())
}

/// The checks of [`render_fog_into`] (lights, β, the fog ball and the eye's
/// distance from it).
fn check_frame(
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
    settings: &FogSettings,
) -> Result<(), FogError> {
    validate_lights(objects, lights, settings.beta, settings.check_lights_inside)?;
    if let Some(r) = settings.ball_radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(FogError::Distance {
                what: "fog ball radius",
                value: f64::from(r),
            });
        }
        if !lights.is_empty() {
            view_segment::check_eye(camera.eye, settings.beta, r)?;
        }
    }
    Ok(())
}

/// The analytic model's pass over a visibility buffer that
/// [`rasterize_objects`] drew for `camera` (or any rasterization of the
/// same meshes, draw i = object i): what [`render_fog_into`] does after
/// rasterizing, so a caller that needs the buffer for other passes (the
/// fog method's environment part) rasterizes once. Ignores `settings.mode`.
///
/// # Errors
/// As [`render_fog_into`].
pub fn shade_fog_raster(
    rasterizer: &Rasterizer,
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
    settings: &FogSettings,
    out: &mut Image,
) -> Result<(), FogError> {
    check_frame(objects, camera, lights, settings)?;
    let (model, mats, prepared) = frame_model(objects, camera, lights, settings)?;
    shade_gbuffer(
        rasterizer,
        objects,
        &mats,
        camera,
        &model,
        &prepared,
        settings.ball_radius,
        out,
    );
    Ok(())
}

/// The model of one frame: the medium's [`FogModel`], every object's
/// constants (its G table checked) and the lights prepared for the eye.
fn frame_model<'a>(
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
    settings: &'a FogSettings<'a>,
) -> Result<(FogModel<'a>, Vec<MaterialConst<'a>>, Vec<PreparedLight>), FogError> {
    let model = FogModel::new(
        settings.tables,
        settings.beta,
        &settings.phase,
        settings.interp,
    )?
    .with_albedo(settings.albedo)?;
    let mats = objects
        .iter()
        .map(|o| {
            let g = if o.material.ks == Vec3::ZERO {
                None
            } else {
                Some(model.g_table(o.material.n)?)
            };
            Ok(MaterialConst::new(&model, &o.material, g))
        })
        .collect::<Result<Vec<_>, FogError>>()?;
    let prepared = model.prepare_lights(camera.eye, lights)?;
    Ok((model, mats, prepared))
}

/// [`FogMode::OpenGl`]: classic exponential fog, rasterized and shaded in
/// one pass.
fn render_opengl(
    rasterizer: &mut Rasterizer,
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
    settings: &FogSettings,
    fog_color: Vec3,
    out: &mut Image,
) -> Result<(), FogError> {
    let eye = camera.eye;
    // Smooth normals as a 3-float vertex attribute where the mesh has them.
    let normals: Vec<Vec<f32>> = objects
        .iter()
        .map(|o| {
            if o.mesh.normals.len() == o.mesh.positions.len() {
                o.mesh.normals.iter().flat_map(|n| n.to_array()).collect()
            } else {
                Vec::new()
            }
        })
        .collect();
    let draws: Vec<DrawCall> = objects
        .iter()
        .zip(&normals)
        .enumerate()
        .map(|(i, (o, n))| {
            let d = DrawCall::new(&o.mesh.positions, &o.mesh.indices).with_object_id(i as u32);
            if n.is_empty() {
                d
            } else {
                d.with_attributes(3, n)
            }
        })
        .collect();
    let options = RasterOptions::default().fit_depth(camera, &draws);
    let beta = settings.beta;
    rasterizer.render(
        camera,
        &draws,
        |f| {
            let n = if f.attributes.len() == 3 {
                Vec3::from_slice(f.attributes).normalize_or(f.normal)
            } else {
                f.normal
            };
            opengl_fog_pixel(
                eye,
                -f.to_eye,
                lights,
                beta,
                fog_color,
                Some((f.position, n, &objects[f.object as usize].material)),
            )
        },
        Background::Color(fog_color),
        &options,
        out,
    )?;
    Ok(())
}

/// Per-row scratch of [`shade_gbuffer`].
#[derive(Default)]
struct RowScratch {
    batch: PixelBatch,
    /// Column and object of each surface pixel of the batch.
    xs: Vec<u32>,
    objs: Vec<u32>,
    /// Background pixels: columns, directions and accumulators.
    bg_x: Vec<u32>,
    bg_d: [Vec<f32>; 3],
    bg_c: [Vec<f32>; 3],
    /// With the eye outside the fog ball: the batch index of each sample
    /// whose medium starts at t_in > 0 and that t_in, for the model from
    /// the ball's edge ([`crate::view_segment`]).
    entry: Vec<(u32, f32)>,
    /// Batch indices of empty samples whose ray misses the ball.
    missed: Vec<u32>,
}

/// The model from the ball's edge ([`crate::view_segment`]): each sample
/// `(i, t_in)` of `s.entry`, shaded from the real eye as M(t), becomes
/// e^{β t_in} (M(t) − A(t_in)), A(t_in) the airlight to a black surface at
/// the ray's entry into the ball (one more batch run, appended after the
/// samples and left in the batch).
fn from_ball_edge(
    model: &FogModel,
    lights: &[PreparedLight],
    black: &MaterialConst,
    eye: Vec3,
    s: &mut RowScratch,
) {
    if s.entry.is_empty() {
        return;
    }
    let b = &mut s.batch;
    let start = b.len();
    for &(i, t_in) in &s.entry {
        let i = i as usize;
        let d = Vec3::new(b.dx[i], b.dy[i], b.dz[i]);
        b.push_point(eye + t_in * d, -d);
    }
    b.prepare(eye, model.beta, start);
    let end = b.len();
    shade_surface_run(model, lights, black, b, start..end);
    for (k, &(i, t_in)) in s.entry.iter().enumerate() {
        let i = i as usize;
        let scale = (model.beta * t_in).exp();
        let l = ((b.radiance(i) - b.radiance(start + k)) * scale).max(Vec3::ZERO);
        (b.r[i], b.g[i], b.b[i]) = (l.x, l.y, l.z);
    }
}

/// Pass 2 of the analytic renderer over the rasterizer's visibility
/// buffer: per row (parallel), every covered pixel's world position,
/// interpolated normal and view direction go into a [`PixelBatch`]; each run
/// of pixels of one object is shaded by [`shade_surface_run`] and the empty
/// pixels by [`shade_background`] (the airlight to infinity), or, inside a
/// fog ball of radius `ball`, by the finite-segment airlight to its edge.
#[allow(clippy::too_many_arguments)]
fn shade_gbuffer(
    rasterizer: &Rasterizer,
    objects: &[FogObject],
    mats: &[MaterialConst],
    camera: &Camera,
    model: &FogModel,
    lights: &[PreparedLight],
    ball: Option<f32>,
    out: &mut Image,
) {
    let g = rasterizer.gbuffer();
    let (w, h) = (g.width, g.height);
    out.width = w;
    out.height = h;
    out.pixels.resize(w * h, Vec3::ZERO);
    if w == 0 || h == 0 {
        return;
    }
    if lights.is_empty() {
        // Every term of the model is a sum over the lights (surface
        // radiance and airlight alike): without lights the image is black.
        out.pixels.fill(Vec3::ZERO);
        return;
    }
    // First global triangle id of each object (ids of draw d follow those
    // of draws 0..d).
    let mut first = Vec::with_capacity(objects.len() + 1);
    let mut total = 0u32;
    for o in objects {
        first.push(total);
        total += o.mesh.indices.len() as u32;
    }
    first.push(total);
    // Background directions are the camera rays through the pixel centres.
    let rays = camera.ray_frame();
    // A surface that reflects nothing: only the airlight term remains.
    let black = MaterialConst {
        kd: Vec3::ZERO,
        ks: Vec3::ZERO,
        n: 1.0,
        g: model.stand_in_table(),
    };
    let eye = camera.eye;
    let beta = model.beta;
    let medium = ball.map(|radius| Medium {
        beta,
        albedo: 1.0,
        radius,
    });
    // The medium starts at the eye unless the eye is outside the ball.
    let outside = medium.filter(|m| eye.length() >= m.radius);
    out.pixels
        .par_chunks_mut(w)
        .zip(g.triangle.par_chunks(w))
        .zip(g.barycentrics.par_chunks(w))
        .enumerate()
        .for_each_init(RowScratch::default, |s, (y, ((row, ids), bary))| {
            s.batch.clear();
            s.xs.clear();
            s.objs.clear();
            s.bg_x.clear();
            for v in s.bg_d.iter_mut().chain(s.bg_c.iter_mut()) {
                v.clear();
            }
            let (mut lo, mut hi, mut obj) = (1u32, 0u32, 0usize);
            // The last triangle's corners and vertex normals (`None`: the
            // mesh has none): neighbouring pixels of one triangle share them.
            let mut last = NO_TRIANGLE;
            let mut corners = [Vec3::ZERO; 3];
            let mut normals: Option<[Vec3; 3]> = None;
            for (x, (&id, b)) in ids.iter().zip(bary).enumerate() {
                if id == NO_TRIANGLE || id >= total {
                    let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
                    s.bg_x.push(x as u32);
                    for (k, v) in s.bg_d.iter_mut().enumerate() {
                        v.push(d[k]);
                    }
                    for v in &mut s.bg_c {
                        v.push(0.0);
                    }
                    continue;
                }
                if id != last {
                    last = id;
                    if !(id >= lo && id < hi) {
                        obj = first.partition_point(|&f| f <= id) - 1;
                        lo = first[obj];
                        hi = first[obj + 1];
                    }
                    let mesh = objects[obj].mesh;
                    let tri = mesh.indices[(id - lo) as usize];
                    corners = tri.map(|v| mesh.positions[v as usize]);
                    normals = (mesh.normals.len() == mesh.positions.len())
                        .then(|| tri.map(|v| mesh.normals[v as usize]));
                }
                let l = Vec3::new(1.0 - b[0] - b[1], b[0], b[1]);
                let [p0, p1, p2] = corners;
                let p = p0 * l.x + p1 * l.y + p2 * l.z;
                // Interpolated smooth normal; the geometric one only where the
                // mesh has none or they cancel.
                let ns = match normals {
                    Some([n0, n1, n2]) => n0 * l.x + n1 * l.y + n2 * l.z,
                    None => Vec3::ZERO,
                };
                let len2 = ns.length_squared();
                let n = if len2 > 1e-30 && len2.is_finite() {
                    ns * (1.0 / len2.sqrt())
                } else {
                    (p1 - p0).cross(p2 - p0).normalize_or_zero()
                };
                s.batch.push_point(p, n);
                s.xs.push(x as u32);
                s.objs.push(obj as u32);
            }
            s.batch.prepare(eye, beta, 0);
            // Runs of one object.
            let n = s.batch.len();
            let mut start = 0;
            while start < n {
                let o = s.objs[start];
                let mut end = start + 1;
                while end < n && s.objs[end] == o {
                    end += 1;
                }
                shade_surface_run(model, lights, &mats[o as usize], &mut s.batch, start..end);
                start = end;
            }
            if let Some(medium) = outside {
                // The eye outside the ball: where each covered sample's
                // medium starts.
                s.entry.clear();
                for i in 0..n {
                    let d = Vec3::new(s.batch.dx[i], s.batch.dy[i], s.batch.dz[i]);
                    let t_in = view_segment::medium_start(&medium, eye, d, s.batch.d_vp[i]);
                    if t_in > 0.0 {
                        s.entry.push((i as u32, t_in));
                    }
                }
                from_ball_edge(model, lights, &black, eye, s);
            }
            for (i, &x) in s.xs.iter().enumerate() {
                row[x as usize] = s.batch.radiance(i);
            }
            let [dx, dy, dz] = &s.bg_d;
            if let Some(medium) = medium {
                // The airlight over the ray's span [t_in, t_out] in the
                // ball: the surface model's airlight term to a black surface
                // at t_out, so the batch's (AVX2) loop computes it; with the
                // eye outside, from the ball's edge ([`from_ball_edge`]).
                s.entry.clear();
                s.missed.clear();
                let start = s.batch.len();
                for i in 0..s.bg_x.len() {
                    let d = Vec3::new(dx[i], dy[i], dz[i]);
                    let j = (start + i) as u32;
                    let (t_in, t_out) = medium.ball_span(eye, d).unwrap_or_else(|| {
                        s.missed.push(j);
                        (0.0, 0.0)
                    });
                    s.batch.push_point(eye + t_out * d, -d);
                    if t_in > 0.0 {
                        s.entry.push((j, t_in));
                    }
                }
                s.batch.prepare(eye, beta, start);
                let end = s.batch.len();
                shade_surface_run(model, lights, &black, &mut s.batch, start..end);
                from_ball_edge(model, lights, &black, eye, s);
                for &j in &s.missed {
                    // No medium on the ray: no airlight.
                    let j = j as usize;
                    (s.batch.r[j], s.batch.g[j], s.batch.b[j]) = (0.0, 0.0, 0.0);
                }
                for (i, &x) in s.bg_x.iter().enumerate() {
                    row[x as usize] = s.batch.radiance(start + i);
                }
            } else {
                let [cr, cg, cb] = &mut s.bg_c;
                shade_background(model, lights, dx, dy, dz, cr, cg, cb);
                for (i, &x) in s.bg_x.iter().enumerate() {
                    row[x as usize] = Vec3::new(cr[i], cg[i], cb[i]);
                }
            }
        });
}

/// A square floor at height `y` of half-size `half`, `n`×`n` quads, normal +Y
/// ([`relight_geom::shapes::plane`] raised to `y`).
#[must_use]
pub fn floor_grid(y: f32, half: f32, n: u32) -> Mesh {
    relight_geom::shapes::plane(2.0 * half, n as usize)
        .transformed(glam::Affine3A::from_translation(Vec3::new(0.0, y, 0.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without lights the frame skips the per-pixel model: black, as the
    /// model itself (every term is a sum over the lights) gives per pixel,
    /// with or without a fog ball.
    #[test]
    fn no_lights_is_the_models_black_frame() {
        let sphere = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, 0.5, 0.0), 0.7, 24, 12);
        let floor = floor_grid(0.0, 3.0, 4);
        let mat = FogMaterial::phong(Vec3::splat(0.5), Vec3::splat(0.3), 20);
        let objects = [
            FogObject {
                mesh: &sphere,
                material: mat,
            },
            FogObject {
                mesh: &floor,
                material: FogMaterial::lambert(Vec3::splat(0.4)),
            },
        ];
        let tables = FogTables::build_for(16, &[mat]).unwrap();
        let camera = Camera {
            eye: Vec3::new(0.0, 1.0, 4.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            vfov_deg: 50.0,
            width: 37,
            height: 23,
            image_offset: glam::Vec2::ZERO,
        };
        for ball in [None, Some(9.0)] {
            let mut settings = FogSettings::new(&tables, 0.2);
            settings.ball_radius = ball;
            let model = FogModel::new(&tables, 0.2, &settings.phase, settings.interp).unwrap();
            let prepared = model.prepare_lights(camera.eye, &[]).unwrap();
            let want = model.shade_pixel(camera.eye, Vec3::NEG_Z, &prepared, None);
            assert_eq!(want, Vec3::ZERO);
            let img = render_fog(&objects, &camera, &[], &settings).unwrap();
            assert_eq!((img.width, img.height), (37, 23));
            assert!(img.pixels.iter().all(|p| *p == want), "ball {ball:?}");
        }
    }

    /// The bounding-box skip of [`enclosing_object`] gives the crossing
    /// count's answer at points inside, near and outside closed meshes.
    #[test]
    fn enclosing_object_equals_the_crossing_count() {
        let sphere = relight_geom::shapes::uv_sphere_at(Vec3::new(0.3, 0.5, -0.2), 0.7, 24, 12);
        let o = [FogObject {
            mesh: &sphere,
            material: FogMaterial::lambert(Vec3::splat(0.5)),
        }];
        let (mut inside, mut outside) = (0, 0);
        for i in 0..400 {
            let a = i as f32 * 0.37;
            let r = 0.05 + 1.6 * ((i * 7 % 23) as f32 / 23.0);
            let p = Vec3::new(0.3, 0.5, -0.2)
                + r * Vec3::new(
                    a.sin() * (1.3 * a).cos(),
                    a.cos(),
                    a.sin() * (1.3 * a).sin(),
                );
            let want = encloses(&o[0], p).then_some(0);
            assert_eq!(enclosing_object(&o, p), want, "point {p}");
            if want.is_some() {
                inside += 1;
            } else {
                outside += 1;
            }
        }
        assert!(
            inside > 50 && outside > 50,
            "{inside} inside, {outside} outside"
        );
    }
}
