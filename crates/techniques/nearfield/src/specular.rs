//! Fixed-view specular transport (thesis §4.5.1 and Fig. 4.9: "specular
//! materials with precomputation done per vertex \[75\]"; "Specular rendering
//! from a different view point requires a separate precomputation").
//!
//! # The transport
//! With the view `ω_o` of each vertex fixed (from the scene camera's eye
//! to the vertex), the exitant radiance towards the eye is a linear
//! functional of the light on the face, like the Lambertian one:
//! `B = ∫ L(t) T(t) dt` with
//! `T(t) = S² f(ω_o, ω(t)) max(0, n·ω(t)) V(ω(t)) (1 + |v|²)^{−3/2}`
//! (eq. 4.36 with the BRDF folded into the transport; `v = S (t − ½)`, the
//! face of [`crate::face`]). Its Haar projection at order `n` is again the
//! `n × n` cell means `T̄_c = n² ∫_c T dt`, so the same propagation and
//! sparse dot product shade it ([`crate::propagate`]). `T` is RGB where the
//! BRDF's colour changes with direction (three transports per vertex,
//! `B_c = Σ_k L_{k,c} T_{k,c}`); a BRDF whose colour is one fixed tint
//! times a grey lobe (`f = tint ⊙ g`, [`classify`]) keeps one transport of
//! `g` and multiplies the tint in afterwards.
//!
//! # The cell rule (cell means of a glossy lobe)
//! Lambert's polygon formula makes the cosine's cell means exact; a BRDF
//! lobe has no such closed form, so each cell is integrated by a nested
//! midpoint rule: [`SPEC_SUBSAMPLES`]² = 3 × 3 midpoints per cell; a
//! square whose nine-point mean differs from its centre sample (channel
//! sums of `f cos / len³`) by more than [`SPEC_TOLERANCE`] × the vertex's
//! largest cell mean is split into 3 × 3 sub-squares, each integrated the
//! same way, down to [`SPEC_DEPTH`] splits (27 × 27 points per cell). The
//! 3 × 3 cells about the mirror direction `2 (n·ω_o) n − ω_o` are always
//! split once: a lobe narrower than the 3 × 3 sample spacing (≈ 2.4° at
//! the face's centre at order 32, face 4) can fall between the samples.
//!
//! *Why this rule.* The midpoint rule integrates linear functions exactly;
//! its error on a square of side `h` is `h²/24 · ∇²g` per unit area. The
//! centre sample is the one-point rule on the square and the nine points
//! the same rule on squares of side `h/3`, so `|mean₉ − centre|` is
//! `(1 − 1/9)` of the one-point rule's error and 8× the nine-point
//! rule's (Richardson): a square is split where the nine-point rule's own
//! error would exceed `SPEC_TOLERANCE / 8` of the largest cell — where the
//! lobe bends (its peak, the horizon's kink), not where it merely slopes
//! (a criterion on the samples' spread refined every sloping cell: ~25 ms
//! per vertex on `verify nearfield`'s glossy scene, against 1.3 ms). Three
//! (odd) points per side nest: a sub-square's centre is its parent's
//! sample. Checked against 48 × 48-point brute-force quadrature of every
//! cell (`tests/it/specular.rs::cell_rule_matches_quadrature`).
//!
//! # Visibility
//! As the Lambertian bake ([`crate::transport`]): one shadow ray per cell
//! centre, 4 × 4 rays in a cell the shadow edge or the horizon crosses,
//! each cell scaled by its visible fraction — here weighted by the lobe
//! `Σ_c f_c cos / len³` instead of the cosine, so a highlight half-shadowed
//! in a cell loses its own share.
//!
//! # The view
//! `ω_o` is the direction from the vertex to the camera's eye, in the
//! vertex's shading frame (the normal, and the mesh's tangent where it has
//! one, as the reference's frame); a view below the shading horizon (a
//! silhouette vertex) is raised to the reference's
//! [`relight_render::reference::surface::MIN_COS_VIEW`] keeping its azimuth
//! ([`above_horizon`]), as the reference shades such a point. Only the
//! eye's position matters (not the camera's direction, field of view or
//! image size); another eye needs another bake ([`crate::method`]).

use crate::face::LightFrame;
use crate::transport::{Transport, TransportScratch, cell_cosines, visible_fractions};
use glam::{DVec3, Vec2, Vec3, Vec4};
use rayon::prelude::*;
use relight_affine::standard::forward_2d;
use relight_brdf::Brdf;
use relight_isa::pages::vec_on_huge_pages;
use relight_render::reference::surface::above_horizon;
use relight_render::{Cancelled, Progress, SceneBvh};
use relight_sphere::Frame;

/// Midpoints per side of a square of the cell rule (module docs).
pub const SPEC_SUBSAMPLES: usize = 3;

/// Splits of a cell into 3 × 3 sub-squares, at most (module docs).
pub const SPEC_DEPTH: usize = 2;

/// A square whose nine-point mean differs from its centre sample by more
/// than this fraction of the vertex's largest cell mean is split (module
/// docs).
pub const SPEC_TOLERANCE: f64 = 0.002;

/// How a BRDF's colour behaves ([`classify`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BrdfClass {
    /// `f` is one constant: Lambertian with this albedo `π f`.
    Lambertian(Vec3),
    /// `f = tint ⊙ g` for a grey `g = mean_c f_c` (tint's mean is 1): one
    /// transport of `g`.
    Tinted(Vec3),
    /// The colour changes with direction: RGB transport.
    Coloured,
}

/// The probe pairs `(ω_o, ω_i)` (local frame, unit) [`classify`] and the
/// cache key read a BRDF at: views at 0°–85° over three azimuths, lights
/// on a 10° × 45° grid, each view's mirror direction and four directions
/// 3° off it.
#[must_use]
pub fn probe_pairs() -> Vec<(Vec3, Vec3)> {
    let dir = |theta: f32, phi: f32| {
        let (st, ct) = theta.to_radians().sin_cos();
        let (sp, cp) = phi.to_radians().sin_cos();
        Vec3::new(st * cp, st * sp, ct)
    };
    let mut out = Vec::new();
    for to in [0.0, 20.0, 45.0, 70.0, 85.0] {
        for po in [0.0, 30.0, 100.0] {
            let wo = dir(to, po);
            for ti in (0..9).map(|i| 5.0 + 10.0 * i as f32) {
                for pi in (0..8).map(|i| 45.0 * i as f32) {
                    out.push((wo, dir(ti, pi)));
                }
            }
            for (dt, dp) in [(0.0, 0.0), (3.0, 0.0), (-3.0, 0.0), (0.0, 3.0), (0.0, -3.0)] {
                let t = (to + dt).clamp(0.0, 89.0);
                out.push((wo, dir(t, po + 180.0 + dp)));
            }
        }
    }
    out
}

/// The BRDF's values at [`probe_pairs`].
#[must_use]
pub fn probe(brdf: &dyn Brdf) -> Vec<Vec3> {
    probe_pairs()
        .iter()
        .map(|&(wo, wi)| brdf.eval(wo, wi))
        .collect()
}

/// Whether `brdf` is Lambertian, one tint times a grey lobe, or coloured,
/// from its values at [`probe_pairs`] (relative tolerance 1e-5): the tint
/// is the mean over the probes of `f / mean_c f` where `f` is not
/// negligible.
#[must_use]
pub fn classify(brdf: &dyn Brdf) -> BrdfClass {
    let values = probe(brdf);
    let first = values[0];
    let top = values
        .iter()
        .map(|v| v.max_element())
        .fold(0.0f32, f32::max);
    let close = |a: Vec3, b: Vec3, scale: f32| (a - b).abs().max_element() <= 1e-5 * scale;
    if values
        .iter()
        .all(|&v| close(v, first, first.max_element().max(1e-12)))
    {
        return BrdfClass::Lambertian(first * std::f32::consts::PI);
    }
    let mean = |v: Vec3| v.element_sum() / 3.0;
    let mut tint = None;
    for &v in &values {
        let g = mean(v);
        if g <= 1e-6 * top {
            continue;
        }
        let t = v / g;
        match tint {
            None => tint = Some(t),
            Some(t0) if close(t, t0, 1.0) => {}
            Some(_) => return BrdfClass::Coloured,
        }
    }
    BrdfClass::Tinted(tint.unwrap_or(Vec3::ONE))
}

/// One vertex's BRDF: the object's, or with a blend `(1 − w) f₁ + w f₂`
/// (`relight_render::BrdfBlend`, `w` at the vertex's uv).
#[derive(Clone, Copy, Debug)]
pub struct VertexBrdf<'a> {
    pub first: &'a dyn Brdf,
    pub second: Option<(&'a dyn Brdf, f32)>,
}

impl VertexBrdf<'_> {
    /// `f(ω_o, ω_i)` (local frame).
    #[inline]
    #[must_use]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self.second {
            Some((b, w)) if w >= 1.0 => b.eval(wo, wi),
            Some((b, w)) if w > 0.0 => self.first.eval(wo, wi) * (1.0 - w) + b.eval(wo, wi) * w,
            _ => self.first.eval(wo, wi),
        }
    }
}

/// The shading frame of a vertex: its normal, with the mesh's tangent
/// (`w ≠ 0`) as the reference's frame, else [`Frame::from_z`].
#[must_use]
pub fn vertex_frame(normal: Vec3, tangent: Option<Vec4>) -> Frame {
    match tangent {
        Some(t) if t.w != 0.0 => Frame::from_normal_tangent(normal, t.truncate()),
        _ => Frame::from_z(normal),
    }
}

/// The fixed view of a vertex at `p` seen from `eye`, in `shading`'s
/// local frame, raised above the horizon (module docs).
#[must_use]
pub fn local_view(shading: &Frame, p: Vec3, eye: Vec3) -> Vec3 {
    let wo = (eye - p).try_normalize().unwrap_or(shading.z);
    above_horizon(shading.to_local(wo))
}

/// Reusable buffers of [`specular_cells`].
#[derive(Clone, Debug, Default)]
pub struct SpecularScratch {
    transport: TransportScratch,
    cosines: Vec<f64>,
    change: Vec<f64>,
    forced: Vec<bool>,
}

/// What [`specular_cells`] integrates at one vertex.
#[derive(Clone, Copy, Debug)]
pub struct SpecularVertex<'a> {
    pub p: Vec3,
    pub shading: Frame,
    /// The fixed view (local frame, unit, above the horizon).
    pub wo: Vec3,
    pub brdf: VertexBrdf<'a>,
}

/// The integrand `f(ω_o, ω) cos θ / len³` at face point `t ∈ [0, 1]²`
/// (module docs; `S²` applied by the caller).
#[inline]
fn lobe_at(frame: &LightFrame, face: f64, v: &SpecularVertex, tx: f64, ty: f64) -> Vec3 {
    let d = frame.face_dir((face * (tx - 0.5)) as f32, (face * (ty - 0.5)) as f32);
    let len = d.length();
    let wi = v.shading.to_local(d / len);
    if wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    v.brdf.eval(v.wo, wi) * (wi.z / (len * len * len))
}

/// Mean of the integrand over the square `[x0, x0 + h] × [y0, y0 + h]`
/// (face units `t`) by the nested rule (module docs); `tol`: the split
/// threshold on the change `|mean₉ − centre|` (channel sums), `split`:
/// split at least once. Returns the mean and that change.
#[allow(clippy::too_many_arguments)]
fn square_mean(
    frame: &LightFrame,
    face: f64,
    v: &SpecularVertex,
    x0: f64,
    y0: f64,
    h: f64,
    depth: usize,
    tol: f64,
    split: bool,
) -> (DVec3, f64) {
    let q = SPEC_SUBSAMPLES;
    let step = h / q as f64;
    let mut sum = DVec3::ZERO;
    let mut centre = 0.0;
    for j in 0..q {
        for i in 0..q {
            let g = lobe_at(
                frame,
                face,
                v,
                x0 + (i as f64 + 0.5) * step,
                y0 + (j as f64 + 0.5) * step,
            )
            .as_dvec3();
            if 2 * i + 1 == q && 2 * j + 1 == q {
                centre = g.element_sum();
            }
            sum += g;
        }
    }
    let mean = sum / (q * q) as f64;
    // The one-point rule's error, estimated against the nine-point one.
    let change = (mean.element_sum() - centre).abs();
    if depth < SPEC_DEPTH && (split || change > tol) {
        let mut sub = DVec3::ZERO;
        for j in 0..q {
            for i in 0..q {
                sub += square_mean(
                    frame,
                    face,
                    v,
                    x0 + i as f64 * step,
                    y0 + j as f64 * step,
                    step,
                    depth + 1,
                    tol,
                    false,
                )
                .0;
            }
        }
        return (sub / (q * q) as f64, change);
    }
    (mean, change)
}

/// The cell means `T̄_c` (RGB, module docs) of one vertex, row-major
/// `y · n + x`, into `out` (`n²`). `bvh`: shadows.
#[allow(clippy::too_many_arguments)]
pub fn specular_cells(
    frame: &LightFrame,
    v: &SpecularVertex,
    n: usize,
    face: f64,
    bvh: Option<&SceneBvh>,
    scratch: &mut SpecularScratch,
    out: &mut [DVec3],
) {
    let local = frame.local(v.p);
    out.iter_mut().for_each(|x| *x = DVec3::ZERO);
    if local.z <= 1e-6 {
        return;
    }
    let nn = n * n;
    let h = 1.0 / n as f64;
    scratch.change.resize(nn, 0.0);
    scratch.forced.clear();
    scratch.forced.resize(nn, false);
    // Pass 1: 3 × 3 midpoints per cell; the vertex's largest cell mean.
    let mut peak = 0.0f64;
    for y in 0..n {
        for x in 0..n {
            let k = y * n + x;
            let (m, s) = square_mean(
                frame,
                face,
                v,
                x as f64 * h,
                y as f64 * h,
                h,
                SPEC_DEPTH,
                f64::MAX,
                false,
            );
            out[k] = m;
            scratch.change[k] = s;
            peak = peak.max(m.element_sum());
        }
    }
    if peak <= 0.0 {
        return;
    }
    // The mirror direction's cell and its neighbours (module docs).
    let r = v.shading.from_local(Vec3::new(-v.wo.x, -v.wo.y, v.wo.z));
    let a = -r.dot(frame.axes.z_axis);
    if a > 1e-6 {
        let t1 = f64::from(r.dot(frame.axes.x_axis) / a) / face + 0.5;
        let t2 = f64::from(-r.dot(frame.axes.y_axis) / a) / face + 0.5;
        let (cx, cy) = ((t1 * n as f64).floor(), (t2 * n as f64).floor());
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (x, y) = (cx + f64::from(dx), cy + f64::from(dy));
                if (0.0..n as f64).contains(&x) && (0.0..n as f64).contains(&y) {
                    scratch.forced[y as usize * n + x as usize] = true;
                }
            }
        }
    }
    // Pass 2: refine where the rule's error estimate is large (or about
    // the mirror).
    let tol = SPEC_TOLERANCE * peak;
    for y in 0..n {
        for x in 0..n {
            let k = y * n + x;
            if scratch.forced[k] || scratch.change[k] > tol {
                out[k] = square_mean(
                    frame,
                    face,
                    v,
                    x as f64 * h,
                    y as f64 * h,
                    h,
                    0,
                    tol,
                    scratch.forced[k],
                )
                .0;
            }
        }
    }
    let s2 = face * face;
    if let Some(b) = bvh {
        // The cell states of the Lambertian bake (lit / cut by the horizon).
        scratch.cosines.resize(nn, 0.0);
        let nrm = v.shading.z;
        cell_cosines(
            frame,
            nrm,
            n,
            face,
            &mut scratch.transport,
            &mut scratch.cosines,
        );
        let ts = &mut scratch.transport;
        let mut vis = std::mem::take(&mut ts.vis);
        visible_fractions(
            frame,
            v.p,
            nrm,
            n,
            face,
            b,
            &mut ts.state,
            |w, c, len| {
                v.brdf.eval(v.wo, v.shading.to_local(w)).element_sum() * c / (len * len * len)
            },
            &mut vis,
        );
        for (o, f) in out.iter_mut().zip(&vis) {
            *o *= *f * s2;
        }
        ts.vis = vis;
    } else {
        out.iter_mut().for_each(|o| *o *= s2);
    }
}

/// One object's BRDF for the bake: the object's, and a blend's second BRDF
/// with the blend weight per vertex.
#[derive(Clone, Copy, Debug)]
pub struct ObjectBrdf<'a> {
    pub first: &'a dyn Brdf,
    pub second: Option<(&'a dyn Brdf, &'a [f32])>,
    /// `Some(tint)`: one transport of `g = mean_c f` (tint's mean is 1);
    /// `None`: RGB.
    pub tint: Option<Vec3>,
}

/// The mesh data one specular bake reads.
#[derive(Clone, Copy, Debug)]
pub struct SpecularMesh<'a> {
    pub positions: &'a [Vec3],
    pub normals: &'a [Vec3],
    /// Empty or one per vertex.
    pub tangents: &'a [Vec4],
}

/// Bakes the fixed-view transport (module docs) of every vertex of one
/// mesh for the eye at `eye`, in parallel, with progress per chunk.
///
/// # Errors
/// [`Cancelled`].
#[allow(clippy::too_many_arguments)]
pub fn bake_specular(
    frame: &LightFrame,
    mesh: SpecularMesh,
    brdf: ObjectBrdf,
    eye: Vec3,
    n: usize,
    face: f64,
    bvh: Option<&SceneBvh>,
    progress: &dyn Progress,
) -> Result<Transport, Cancelled> {
    let nn = n * n;
    let channels = if brdf.tint.is_some() { 1 } else { 3 };
    let per = channels * nn;
    // On huge pages, as `bake_transport`'s.
    let mut values = vec_on_huge_pages(mesh.positions.len() * per, 0.0f32);
    const CHUNK: usize = 256;
    for (ci, chunk) in values.chunks_mut(CHUNK * per).enumerate() {
        progress.check()?;
        chunk.par_chunks_mut(per).enumerate().for_each_init(
            || {
                (
                    vec![DVec3::ZERO; nn],
                    vec![0.0f64; nn],
                    SpecularScratch::default(),
                )
            },
            |(cells, plane, scratch), (i, out)| {
                let vi = ci * CHUNK + i;
                let shading = vertex_frame(mesh.normals[vi], mesh.tangents.get(vi).copied());
                let p = mesh.positions[vi];
                let vertex = SpecularVertex {
                    p,
                    shading,
                    wo: local_view(&shading, p, eye),
                    brdf: VertexBrdf {
                        first: brdf.first,
                        second: brdf.second.map(|(b, w)| (b, w[vi])),
                    },
                };
                specular_cells(frame, &vertex, n, face, bvh, scratch, cells);
                for (c, o) in out.chunks_mut(nn).enumerate() {
                    for (dst, cell) in plane.iter_mut().zip(cells.iter()) {
                        *dst = if channels == 1 {
                            cell.element_sum() / 3.0
                        } else {
                            cell[c]
                        };
                    }
                    forward_2d(plane, n);
                    for (x, y) in o.iter_mut().zip(plane.iter()) {
                        *x = *y as f32;
                    }
                }
            },
        );
        progress.inc((chunk.len() / per) as u64);
    }
    Ok(Transport {
        n,
        face,
        channels,
        values,
    })
}

/// The blend weight of every vertex of a mesh with `uvs`
/// (`relight_render::BrdfBlend::weight_at`).
#[must_use]
pub fn blend_weights(blend: &relight_render::BrdfBlend, uvs: &[Vec2]) -> Vec<f32> {
    uvs.iter().map(|&uv| blend.weight_at(uv)).collect()
}

/// How the method shades one object ([`object_kind`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ObjectKind {
    /// Lambertian: the transport is `cos V` (the Lambertian bake) and the
    /// colour `B ⊙ albedo/π`.
    Diffuse { albedo: Vec3 },
    /// Two Lambertian BRDFs blended by a texture: the same transport, the
    /// albedo blended per vertex.
    DiffuseBlend { first: Vec3, second: Vec3 },
    /// Anything else: the fixed-view transport of this module, one channel
    /// times `tint` (`Some`) or RGB (`None`).
    Specular { tint: Option<Vec3> },
}

impl ObjectKind {
    /// Fixed-view (depends on the camera's eye).
    #[must_use]
    pub fn is_specular(&self) -> bool {
        matches!(self, Self::Specular { .. })
    }

    /// Transports per vertex.
    #[must_use]
    pub fn channels(&self) -> usize {
        match self {
            Self::Specular { tint: None } => 3,
            _ => 1,
        }
    }
}

/// How `object` is shaded: Lambertian BRDFs (and blends of two) by the
/// Lambertian transport, every other BRDF (and blend) by the fixed-view
/// one; one tint when every BRDF involved is that tint times a grey lobe.
#[must_use]
pub fn object_kind(object: &relight_render::Object) -> ObjectKind {
    let first = classify(object.brdf.as_ref());
    let second = object.blend.as_ref().map(|b| classify(b.second.as_ref()));
    let tint_of = |c: BrdfClass| match c {
        BrdfClass::Lambertian(a) => {
            let m = a.element_sum() / 3.0;
            (m > 0.0).then(|| a / m)
        }
        BrdfClass::Tinted(t) => Some(t),
        BrdfClass::Coloured => None,
    };
    match (first, second) {
        (BrdfClass::Lambertian(albedo), None) => ObjectKind::Diffuse { albedo },
        (BrdfClass::Lambertian(a), Some(BrdfClass::Lambertian(b))) => ObjectKind::DiffuseBlend {
            first: a,
            second: b,
        },
        (a, None) => ObjectKind::Specular { tint: tint_of(a) },
        (a, Some(b)) => {
            let tint = match (tint_of(a), tint_of(b)) {
                (Some(x), Some(y)) if (x - y).abs().max_element() <= 1e-5 => Some(x),
                _ => None,
            };
            ObjectKind::Specular { tint }
        }
    }
}

/// Half width at half maximum of `brdf`'s lobe in degrees, seen at 30°
/// incidence: the smallest offset `δ` from the mirror direction, in the
/// plane of incidence, where `Σ_c f` falls to half its value at the mirror
/// (0.1° steps up to 60°); `None` when it never does (a diffuse-like BRDF).
#[must_use]
pub fn lobe_half_width_deg(brdf: &dyn Brdf) -> Option<f32> {
    let dir = |theta_deg: f32, phi: f32| {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    };
    let wo = dir(30.0, 0.0);
    let peak = brdf.eval(wo, dir(30.0, std::f32::consts::PI)).element_sum();
    if peak <= 0.0 {
        return None;
    }
    (1..=600).map(|i| i as f32 * 0.1).find(|&d| {
        let a = brdf
            .eval(wo, dir(30.0 + d, std::f32::consts::PI))
            .element_sum();
        let b = brdf
            .eval(wo, dir(30.0 - d, std::f32::consts::PI))
            .element_sum();
        a.max(b) <= 0.5 * peak
    })
}

/// Angular size (degrees) of the face's central cell at order `n`, face
/// side `face`: `atan(face / n)`.
#[must_use]
pub fn central_cell_deg(n: usize, face: f64) -> f32 {
    (face / n as f64).atan().to_degrees() as f32
}
