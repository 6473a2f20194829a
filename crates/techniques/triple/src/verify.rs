//! `relight verify triple`: the exact identities of the basis and the
//! product, and the method's error against the reference renderer with
//! visibility (issue 12, "Verify"). Every row names its target and where the
//! target comes from; rows without a target report (`pass` = null).
//!
//! # Error scenes
//! A sphere (48×24 UV, 1.2 K vertices) on a 6×6 floor (49×49 vertices), floor
//! shadows on, under each given probe, Lambert and Phong 16, at
//! 20/80/320/5120 terms (top-only), per pixel, against
//! [`render_reference`] with visibility, relative RMS over object pixels
//! (`Coverage::object_mask`), corrected for the reference's own noise:
//! `√max(0, e² − σ_MC²)` with σ_MC the reference's noise over the same
//! pixels (`ReferenceImage::rms_relative_std_error_over`; both raw and σ_MC
//! are in the row; until session 30 the whole image's σ, which the sky's
//! noise-free pixels made ≈ 20 % too small). Terms up to 320 use the default twisted
//! (rotation) table; 5120 uses the isotropic table (`twists = 1`; the twisted
//! one would hold 631 MB).

use crate::basis::{Basis, Function, level_area, tripling};
use crate::lighting::{LightTable, frame_of, prefilter};
use crate::method::{Shading, TripleMethod, TripleOptions};
use crate::product::{brute_force, dense, sparse};
use crate::quadrature::{LeafGrid, Weighting};
use crate::select::{Selection, select};
use glam::{Mat3, Vec3};
use relight_brdf::BrdfSpec;
use relight_render::method::{FrameRequest, MethodError, Relighter, render_frame};
use relight_render::reference::{ReferenceImage, ReferenceOptions, render_reference};
use relight_render::{Camera, Image, Object, Progress, Scene, SceneBvh};
use relight_sphere::{EnvMap, Frame};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::Arc;

/// One verify row.
#[derive(Clone, Debug, Serialize)]
pub struct VerifyRow {
    /// What is checked.
    pub check: String,
    /// Scene / probe and BRDF, or `-` for the math rows.
    pub case: String,
    /// Coefficients kept (0 when not applicable).
    pub terms: usize,
    /// The measured value (error rows: corrected for the reference's own
    /// noise, `√max(0, e² − σ_MC²)`).
    pub value: f64,
    /// Error rows: the raw relative RMS against the noisy reference.
    pub raw: Option<f64>,
    /// Error rows: the reference's own relative RMS noise σ_MC.
    pub sigma_mc: Option<f64>,
    /// The target, in words (`≤ 0.10`, `< 1e-12`, …).
    pub target: String,
    /// Where the target comes from.
    pub source: &'static str,
    /// Pass/fail, or null for a reported row.
    pub pass: Option<bool>,
}

fn row(
    check: &str,
    case: &str,
    terms: usize,
    value: f64,
    target: String,
    source: &'static str,
    pass: Option<bool>,
) -> VerifyRow {
    VerifyRow {
        check: check.into(),
        case: case.into(),
        terms,
        value,
        target,
        source,
        pass,
        raw: None,
        sigma_mc: None,
    }
}

/// A relative RMS `raw` against a reference of noise `sigma`, the noise
/// removed: `√max(0, raw² − σ²)` (module docs).
fn without_noise(raw: f64, sigma: f64) -> f64 {
    (raw * raw - sigma * sigma).max(0.0).sqrt()
}

impl VerifyRow {
    /// The row with its raw error and the reference's noise shown beside.
    fn with_noise(mut self, raw: f64, sigma: f64) -> Self {
        self.raw = Some(raw);
        self.sigma_mc = Some(sigma);
        self
    }
}

/// The error target at `terms` (judged only on indoor probes in
/// the full run), and whether `e` meets it.
fn error_target(terms: usize, judged: bool, e: f64) -> (String, Option<bool>) {
    match (terms, judged) {
        (80, true) => ("≤ 0.10".to_string(), Some(e <= 0.10)),
        (320, true) => ("≤ 0.06".to_string(), Some(e <= 0.06)),
        (5120, true) => ("≤ 0.04".to_string(), Some(e <= 0.04)),
        _ => ("report".to_string(), None),
    }
}

struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn signed(&mut self) -> f32 {
        2.0 * self.unit() - 1.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f32) as usize % n
    }
}

/// Support (leaf range) and sign pattern of a function at leaf level `leaf`.
fn support(k: usize, leaf: usize) -> (usize, usize) {
    match Function::decode(k) {
        Function::Scaling(i) => (i << (2 * leaf), (i + 1) << (2 * leaf)),
        Function::Wavelet { level, index, .. } => (
            index << (2 * (leaf - level)),
            (index + 1) << (2 * (leaf - level)),
        ),
    }
}

/// The exact identities (module docs of [`crate::basis`] and [`crate::product`]).
#[must_use]
pub fn identity_rows(quick: bool) -> Vec<VerifyRow> {
    let mut rows = Vec::new();
    // Orthogonality: every pair at leaf level 2 (320 functions).
    let b2 = Basis::new(2).expect("level 2");
    let f: Vec<Vec<f32>> = (0..b2.len()).map(|k| b2.function_on_leaves(k)).collect();
    let mut worst = 0.0f64;
    for i in 0..b2.len() {
        for j in i..b2.len() {
            let g: f64 = b2.leaf_area()
                * f[i]
                    .iter()
                    .zip(&f[j])
                    .map(|(x, y)| f64::from(x * y))
                    .sum::<f64>();
            let want = if i == j { b2.norm2(i) } else { 0.0 };
            worst = worst.max((g - want).abs());
        }
    }
    rows.push(row(
        "orthogonality <b_i,b_j> = δ_ij A_l (all pairs of 320)",
        "-",
        320,
        worst,
        "< 1e-12".into(),
        "paper §3.1 (orthogonal basis)",
        Some(worst < 1e-12),
    ));
    // Perfect reconstruction.
    let b = Basis::paper();
    let mut rng = Rng(0x9e37_79b9);
    let leaves: Vec<f32> = (0..b.len()).map(|_| rng.signed() * 100.0).collect();
    let mut c = vec![0.0; b.len()];
    b.forward(&leaves, &mut c);
    let mut back = vec![0.0; b.len()];
    b.inverse(&c, &mut back);
    let err = leaves
        .iter()
        .zip(&back)
        .map(|(x, y)| f64::from((x - y).abs()) / 100.0)
        .fold(0.0, f64::max);
    rows.push(row(
        "perfect reconstruction max |f − W⁻¹Wf| / max|f| (5120)",
        "-",
        5120,
        err,
        "< 1e-6".into(),
        "issue 12 (exact identity; f32 rounding)",
        Some(err < 1e-6),
    ));
    // Tripling coefficients: every triple of the first 80 (quick) or 320.
    let first = if quick { 80 } else { 320 };
    let leaf = 3;
    let b3 = Basis::new(leaf).expect("level 3");
    let vals: Vec<Vec<f32>> = (0..first).map(|k| b3.function_on_leaves(k)).collect();
    let sup: Vec<(usize, usize)> = (0..first).map(|k| support(k, leaf)).collect();
    let mut worst = 0.0f64;
    let mut nonzero = 0usize;
    for i in 0..first {
        for j in 0..first {
            for k in 0..first {
                let lo = sup[i].0.max(sup[j].0).max(sup[k].0);
                let hi = sup[i].1.min(sup[j].1).min(sup[k].1);
                let mut s = 0.0f64;
                let r = lo..hi.max(lo);
                for ((x, y), z) in vals[i][r.clone()]
                    .iter()
                    .zip(&vals[j][r.clone()])
                    .zip(&vals[k][r])
                {
                    s += f64::from(x * y * z);
                }
                let want = s * b3.leaf_area();
                worst = worst.max((tripling(i, j, k) - want).abs());
                nonzero += usize::from(want != 0.0);
            }
        }
    }
    rows.push(row(
        &format!("tripling coefficients, all {first}³ triples vs brute force ({nonzero} non-zero)"),
        "-",
        first,
        worst,
        "< 1e-12".into(),
        "paper §3.1 theorem (3 non-zero cases)",
        Some(worst < 1e-12),
    ));
    // Random deeper triples at level 4 (biased to the non-zero cases).
    let mut worst = 0.0f64;
    for _ in 0..if quick { 200 } else { 2000 } {
        let k = 20 + rng.below(b.len() - 20);
        let Function::Wavelet { level, index, kind } = Function::decode(k) else {
            continue;
        };
        let lp = rng.below(level + 1);
        let third = if lp == level {
            Function::Scaling(index >> (2 * level)).encode()
        } else {
            Function::Wavelet {
                level: lp,
                index: index >> (2 * (level - lp)),
                kind: rng.below(3),
            }
            .encode()
        };
        let sib = k - kind + (kind + 1) % 3;
        let other = rng.below(b.len());
        for (x, y, z) in [
            (k, k, third),
            (k, sib, k - kind + (kind + 2) % 3),
            (k, sib, other),
        ] {
            let fx = b.function_on_leaves(x);
            let fy = b.function_on_leaves(y);
            let fz = b.function_on_leaves(z);
            let want = b.leaf_area()
                * fx.iter()
                    .zip(&fy)
                    .zip(&fz)
                    .map(|((p, q), r)| f64::from(p * q * r))
                    .sum::<f64>();
            worst = worst.max((tripling(x, y, z) - want).abs());
        }
    }
    rows.push(row(
        "tripling coefficients, random level-0…3 triples vs brute force",
        "-",
        5120,
        worst,
        "< 1e-12".into(),
        "paper §3.1 theorem",
        Some(worst < 1e-12),
    ));
    // Fast product, dense and sparse.
    let rand = |rng: &mut Rng| -> Vec<f32> {
        let leaves: Vec<f32> = (0..b.len()).map(|_| rng.signed().powi(3)).collect();
        let mut c = vec![0.0; b.len()];
        b.forward(&leaves, &mut c);
        c
    };
    let (l, v, r) = (rand(&mut rng), rand(&mut rng), rand(&mut rng));
    let want = brute_force(b, &l, &v, &r);
    let got = dense(b, &l, &v, &r);
    let rel = (got - want).abs() / want.abs().max(1e-12);
    rows.push(row(
        "fast triple product, dense O(N) vs brute force (relative)",
        "-",
        5120,
        rel,
        "< 1e-5".into(),
        "Ng et al. 2004 §5 tree sum",
        Some(rel < 1e-5),
    ));
    for n in [80, 320] {
        let s = [&l, &v, &r].map(|x| select(b, x, n, Selection::Adaptive));
        let d = s.clone().map(|x| x.to_dense(b.len()));
        let want = brute_force(b, &d[0], &d[1], &d[2]);
        let got = sparse(b, &s[0], &s[1], &s[2]);
        let rel = (got - want).abs() / want.abs().max(1e-9);
        rows.push(row(
            "fast triple product, sparse O(n log n) vs brute force (relative)",
            "adaptive",
            n,
            rel,
            "< 1e-4".into(),
            "Ng et al. 2004 §5 tree sum",
            Some(rel < 1e-4),
        ));
    }
    // Furnace: L ≡ 1, V ≡ 1, Lambert, random frames.
    let grid = LeafGrid::new(b, 2).expect("level 6");
    let mut ones = vec![0.0; b.len()];
    b.forward(&vec![1.0; b.len()], &mut ones);
    let mut worst = 0.0f64;
    for _ in 0..if quick { 6 } else { 24 } {
        let n = Vec3::new(rng.signed(), rng.signed(), rng.signed()).normalize();
        let mut rho = vec![0.0; b.len()];
        grid.brdf_term(
            |w| n.dot(w).max(0.0) / std::f32::consts::PI,
            Weighting::Exact,
            &mut rho,
        );
        let mut rc = vec![0.0; b.len()];
        b.forward(&rho, &mut rc);
        worst = worst.max((dense(b, &ones, &ones, &rc) - 1.0).abs());
    }
    rows.push(row(
        "furnace |B − 1|, L ≡ 1, V ≡ 1, Lambert, random frames (exact areas)",
        "-",
        5120,
        worst,
        "≤ 1e-4".into(),
        "issue 12",
        Some(worst <= 1e-4),
    ));
    // The paper's unweighted form under the same furnace: reported.
    let mut worst_p = 0.0f64;
    for _ in 0..6 {
        let n = Vec3::new(rng.signed(), rng.signed(), rng.signed()).normalize();
        let mut rho = vec![0.0; b.len()];
        grid.brdf_term(
            |w| n.dot(w).max(0.0) / std::f32::consts::PI,
            Weighting::Paper,
            &mut rho,
        );
        let mut rc = vec![0.0; b.len()];
        b.forward(&rho, &mut rc);
        worst_p = worst_p.max((dense(b, &ones, &ones, &rc) - 1.0).abs());
    }
    rows.push(row(
        "furnace |B − 1| with the paper's equal areas (unweighted)",
        "-",
        5120,
        worst_p,
        "report".into(),
        "paper §3.1 (A_l = 4^-l)",
        None,
    ));
    // A grid-aligned light rotation is an exact index shift.
    let env = EnvMap::from_fn(
        relight_sphere::Param::LatLong {
            width: 32,
            height: 16,
        },
        |d| Vec3::splat(d.x.max(0.0)),
    );
    let twists = 8;
    let table = LightTable::build(&env, Mat3::IDENTITY, 1, twists);
    let mut worst = 0.0f32;
    let verts = relight_sphere::Icosahedral::new(3).expect("level 3");
    for k in [0usize, 5, 17, 100, 400] {
        let n = verts.vertices()[k].as_vec3();
        let f = frame_of(n);
        for shift in 0..twists {
            let tau = std::f32::consts::TAU * shift as f32 / twists as f32;
            let rot = Mat3::from_axis_angle(n, tau);
            let g = Frame {
                x: rot * f.x,
                y: rot * f.y,
                z: n,
            };
            let taps = table.lookup(&g);
            let want = ((k * twists + shift) * 3 * table.stride) as u32;
            let w: f32 = taps
                .iter()
                .filter(|t| t.offset == want)
                .map(|t| t.weight)
                .sum();
            worst = worst.max((1.0 - w).abs());
        }
    }
    rows.push(row(
        "grid-aligned light rotation = one table entry (1 − its weight)",
        "-",
        80,
        f64::from(worst),
        "< 1e-4".into(),
        "issue 12 (rotation is a lookup)",
        Some(worst < 1e-4),
    ));
    let _ = level_area;
    rows
}

/// Options of the error rows.
#[derive(Clone, Debug)]
pub struct ErrorOptions {
    /// Image size.
    pub width: usize,
    pub height: usize,
    /// Reference samples per pixel.
    pub spp: u32,
    /// Terms of the rows.
    pub terms: Vec<usize>,
    /// BRDF specs.
    pub brdfs: Vec<String>,
    /// Visibility ray level.
    pub vis_level: usize,
    /// Bake cache.
    pub cache_dir: PathBuf,
    /// Judge the rows against the targets (false for the smoke
    /// run, whose sizes the targets were not set for: its rows report).
    pub judge: bool,
}

impl ErrorOptions {
    /// The full run (or the CI smoke run with `quick`).
    #[must_use]
    pub fn new(quick: bool, cache_dir: PathBuf) -> Self {
        if quick {
            Self {
                width: 64,
                height: 48,
                spp: 256,
                terms: vec![20, 80],
                brdfs: vec!["lambert:0.8".into()],
                vis_level: 2,
                cache_dir,
                judge: false,
            }
        } else {
            Self {
                width: 128,
                height: 96,
                // 4096: at 1024 the reference's own noise over the Phong 16
                // objects (σ_MC 0.069 under lobby) was above the 0.04 and
                // 0.06 targets it judges, so the noise-removed figures were
                // small differences of large numbers.
                spp: 4096,
                terms: vec![20, 80, 320, 5120],
                brdfs: vec!["lambert:0.8".into(), "phong:16".into()],
                vis_level: 4,
                cache_dir,
                judge: true,
            }
        }
    }
}

/// The verify scene: a sphere on a floor under `env`, shadows on.
#[must_use]
pub fn floor_scene(
    env: EnvMap,
    brdf: Arc<dyn relight_brdf::Brdf>,
    width: usize,
    height: usize,
) -> Scene {
    let sphere = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, 1.0, 0.0), 1.0, 48, 24);
    let floor = relight_geom::shapes::plane(6.0, 48);
    let mut s = Scene::new(
        vec![
            Object::new(Arc::new(sphere), brdf.clone()),
            Object::new(Arc::new(floor), brdf),
        ],
        env,
        Camera {
            eye: Vec3::new(0.0, 2.6, 5.2),
            target: Vec3::new(0.0, 0.6, 0.0),
            up: Vec3::Y,
            vfov_deg: 45.0,
            width,
            height,
            image_offset: glam::Vec2::ZERO,
        },
    );
    s.visibility = true;
    s
}

/// The reference of `scene` at `spp` samples per pixel (default options).
fn reference_at(
    scene: &Scene,
    spp: u32,
    progress: &dyn Progress,
) -> Result<ReferenceImage, MethodError> {
    render_reference(
        scene,
        &ReferenceOptions {
            spp,
            ..ReferenceOptions::default()
        },
        progress,
    )
    .map_err(|e| MethodError::failed("triple", e))
}

fn rel_rms(img: &Image, reference: &Image, mask: &[bool]) -> f64 {
    img.relative_rms_error(reference, Some(mask))
}

/// The relative RMS of `img` against `reference` over `mask`, and the
/// reference's own noise σ_MC over the same pixels (the whole image's σ
/// counts the nearly noise-free sky and understates the objects' noise).
fn rel_rms_noise(img: &Image, reference: &ReferenceImage, mask: &[bool]) -> (f64, f64) {
    (
        rel_rms(img, &reference.image, mask),
        reference.rms_relative_std_error_over(mask),
    )
}

/// Renders `scene` with `options` through the interface; image and object mask.
///
/// # Errors
/// The method's.
pub fn render_with(
    scene: &Scene,
    options: TripleOptions,
    progress: &dyn Progress,
) -> Result<(Image, Vec<bool>), MethodError> {
    render_method(&mut TripleMethod::new(options)?, scene, progress)
}

/// Prepares `method` on `scene` and renders one frame through the
/// interface; image and object mask.
///
/// # Errors
/// The method's.
pub fn render_method(
    method: &mut dyn Relighter,
    scene: &Scene,
    progress: &dyn Progress,
) -> Result<(Image, Vec<bool>), MethodError> {
    method.prepare(scene, progress)?;
    let r = render_frame(method, scene, &FrameRequest::new(scene.camera), progress)?;
    let mask = r
        .coverage
        .as_ref()
        .map(|c| c.object_mask())
        .unwrap_or_default();
    Ok((r.image, mask))
}

/// Error rows against the reference for every probe `(name, env, indoor)`.
///
/// # Errors
/// The method's, or cancellation.
pub fn error_rows(
    probes: &[(String, EnvMap, bool)],
    opts: &ErrorOptions,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, MethodError> {
    let mut rows = Vec::new();
    for (name, env, indoor) in probes {
        for brdf in &opts.brdfs {
            let model = parse_brdf(brdf)?;
            let scene = floor_scene(env.clone(), model, opts.width, opts.height);
            let reference = reference_at(&scene, opts.spp, progress)?;
            let case = format!("{name} · {brdf}");
            let mut errs = Vec::new();
            for &terms in &opts.terms {
                let o = TripleOptions {
                    terms,
                    vis_level: opts.vis_level.max(crate::method::level_of(terms)),
                    twists: if terms > 320 {
                        1
                    } else {
                        TripleOptions::default().twists
                    },
                    cache_dir: opts.cache_dir.clone(),
                    ..TripleOptions::default()
                };
                let (img, mask) = render_with(&scene, o.clone(), progress)?;
                let (raw, sigma) = rel_rms_noise(&img, &reference, &mask);
                let e = without_noise(raw, sigma);
                errs.push(e);
                let source = if *indoor {
                    "issue 12 error targets (indoor probes)"
                } else {
                    "issue 12: sun probes are reported"
                };
                let (target, pass) = error_target(terms, *indoor && opts.judge, e);
                rows.push(
                    row(
                        "relative RMS vs reference with visibility (per pixel, top-only)",
                        &case,
                        terms,
                        e,
                        target,
                        source,
                        pass,
                    )
                    .with_noise(raw, sigma),
                );
                if terms == 80 || terms == 320 {
                    // Adaptive selection (per vertex, the isotropic 5120-cell
                    // tables: crate::adaptive), judged by the same targets.
                    let (aimg, amask) = render_with(
                        &scene,
                        TripleOptions {
                            selection: Selection::Adaptive,
                            shading: Shading::Vertex,
                            twists: 1,
                            vis_level: 4,
                            ..o.clone()
                        },
                        progress,
                    )?;
                    let (ear, asigma) = rel_rms_noise(&aimg, &reference, &amask);
                    let ea = without_noise(ear, asigma);
                    let (target, pass) = error_target(terms, *indoor && opts.judge, ea);
                    rows.push(
                        row(
                            "relative RMS vs reference with visibility (per vertex, adaptive)",
                            &case,
                            terms,
                            ea,
                            target,
                            source,
                            pass,
                        )
                        .with_noise(ear, asigma),
                    );
                }
                if terms == 80 {
                    let (vimg, vmask) = render_with(
                        &scene,
                        TripleOptions {
                            shading: Shading::Vertex,
                            ..o.clone()
                        },
                        progress,
                    )?;
                    let (evr, vsigma) = rel_rms_noise(&vimg, &reference, &vmask);
                    let ev = without_noise(evr, vsigma);
                    rows.push(row(
                        "Fig. 5: per-vertex (Gouraud) error − per-pixel error",
                        &case,
                        terms,
                        ev - e,
                        "≥ 0 (per pixel no worse)".into(),
                        "paper Fig. 5",
                        opts.judge.then_some(ev >= e - 1e-3),
                    ));
                    // §3.3's own per-pixel form: the vertices' functions
                    // interpolated (Fig. 5 compares it with Gouraud).
                    let (iimg, imask) = render_with(
                        &scene,
                        TripleOptions {
                            shading: Shading::Interpolated,
                            ..o
                        },
                        progress,
                    )?;
                    let (eir, isigma) = rel_rms_noise(&iimg, &reference, &imask);
                    let ei = without_noise(eir, isigma);
                    rows.push(
                        row(
                            "relative RMS vs reference with visibility (interpolated vertex functions, §3.3)",
                            &case,
                            terms,
                            ei,
                            "report".into(),
                            source,
                            None,
                        )
                        .with_noise(eir, isigma),
                    );
                    rows.push(row(
                        "Fig. 5: per-vertex (Gouraud) error − interpolated per-pixel error",
                        &case,
                        terms,
                        ev - ei,
                        "≥ 0 (per pixel no worse)".into(),
                        "paper Fig. 5",
                        opts.judge.then_some(ev >= ei - 1e-3),
                    ));
                }
            }
            let mono = errs.windows(2).all(|w| w[1] <= w[0] + 1e-3);
            rows.push(row(
                "error falls monotonically with terms",
                &case,
                0,
                errs.windows(2)
                    .map(|w| w[1] - w[0])
                    .fold(f64::NEG_INFINITY, f64::max),
                "largest step ≤ 0 (+1e-3 noise)".into(),
                "issue 12",
                opts.judge.then_some(mono),
            ));
        }
    }
    Ok(rows)
}

/// Fig. 7: adaptive against top-only at equal `n`, point by point: at
/// `points` vertices of the verify scene's floor and sphere, the full
/// 5120-coefficient functions (lighting at the leaf centroids of the
/// prefiltered probe, visibility by rays, the exact-area BRDF term for the
/// camera's view), and the relative RMS over points of `B(n)` against the
/// full product, for both selections.
///
/// # Errors
/// A bad BRDF spec.
pub fn figure7_rows(
    name: &str,
    env: &EnvMap,
    brdf: &str,
    points: usize,
) -> Result<Vec<VerifyRow>, MethodError> {
    let scene = floor_scene(env.clone(), parse_brdf(brdf)?, 8, 8);
    let b = Basis::paper();
    let grid = LeafGrid::new(b, 1).expect("level 5");
    let pre = prefilter(env, 3);
    let meshes: Vec<&relight_geom::Mesh> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
    let bvh = SceneBvh::build(&meshes);
    let brdf_model = scene.objects[0].brdf.clone();
    let mut rng = Rng(77);
    let mut funcs = Vec::new();
    for _ in 0..points {
        let obj = rng.below(2);
        let mesh = meshes[obj];
        let v = rng.below(mesh.positions.len());
        let (p, n) = (mesh.positions[v], mesh.normals[v]);
        let f = frame_of(n);
        let wo = f.to_local((scene.camera.eye - p).normalize()).normalize();
        let o = relight_render::bvh::offset_ray_origin(p, n);
        let lum = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let l = grid.point_values(|d| lum(pre.eval(f.from_local(d))));
        let vis = grid.point_values(|d| {
            if d.z <= 0.0 || !bvh.occluded(o, f.from_local(d), f32::MAX) {
                1.0
            } else {
                0.0
            }
        });
        let mut r = vec![0.0; b.len()];
        grid.brdf_term(
            |wi| {
                if wi.z <= 0.0 || wo.z <= 0.0 {
                    0.0
                } else {
                    lum(brdf_model.eval(wo, wi)) * wi.z
                }
            },
            Weighting::Exact,
            &mut r,
        );
        let c = [l, vis, r].map(|x| {
            let mut c = vec![0.0; b.len()];
            b.forward(&x, &mut c);
            c
        });
        funcs.push(c);
    }
    let full: Vec<f64> = funcs
        .iter()
        .map(|c| dense(b, &c[0], &c[1], &c[2]))
        .collect();
    let norm = full.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-12);
    let mut rows = Vec::new();
    for n in [20, 80, 320] {
        let mut err = [0.0f64; 2];
        for (c, &want) in funcs.iter().zip(&full) {
            for (s, sel) in [Selection::Top, Selection::Adaptive]
                .into_iter()
                .enumerate()
            {
                let sv = c.clone().map(|x| select(b, &x, n, sel));
                let got = sparse(b, &sv[0], &sv[1], &sv[2]);
                err[s] += (got - want).powi(2);
            }
        }
        for (s, sel) in ["top-only", "adaptive"].iter().enumerate() {
            rows.push(row(
                &format!(
                    "Fig. 7: {sel} selection, relative RMS of B over {points} points vs 5120 terms"
                ),
                &format!("{name} · {brdf}"),
                n,
                err[s].sqrt() / norm,
                "report".into(),
                "paper Fig. 7 (adaptive better, not by much)",
                None,
            ));
        }
    }
    Ok(rows)
}

fn parse_brdf(spec: &str) -> Result<Arc<dyn relight_brdf::Brdf>, MethodError> {
    spec.parse::<BrdfSpec>()
        .map(|b| b.build())
        .map_err(|e| MethodError::InvalidOption {
            method: "triple",
            option: "brdf",
            message: format!("{spec}: {e}"),
        })
}

/// `scene` with `map` on every object (tangents built from the uvs).
fn with_normal_map(scene: &Scene, map: &Arc<relight_render::NormalMap>) -> Scene {
    let mut s = scene.clone();
    for o in &mut s.objects {
        let mut m = (*o.mesh).clone();
        m.tangents = m.compute_tangents();
        o.mesh = Arc::new(m);
        o.normal_map = Some(map.clone());
    }
    s
}

/// Bump mapping (§3.3, issue 12): a flat normal map gives the unbumped
/// image exactly (gated); a bumpy map against the reference with the full
/// normal map, with and without visibility (reported: with visibility on,
/// the paper's unrotated visibility is an approximation; without it the
/// error is the method's own truncation).
///
/// # Errors
/// The method's or the reference's.
pub fn bump_rows(
    env: &EnvMap,
    quick: bool,
    cache_dir: PathBuf,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, MethodError> {
    let (w, h, spp) = if quick { (48, 36, 64) } else { (96, 72, 512) };
    let brdf = parse_brdf("lambert:0.8")?;
    let plain = floor_scene(env.clone(), brdf, w, h);
    let o = TripleOptions {
        terms: 80,
        vis_level: 2,
        cache_dir,
        ..TripleOptions::default()
    };
    let mut rows = Vec::new();
    let flat = Arc::new(
        relight_render::NormalMap::from_vectors(1, 1, &[Vec3::Z])
            .map_err(|e| MethodError::failed("triple", e))?,
    );
    let (a, _) = render_with(&plain, o.clone(), progress)?;
    let (b, _) = render_with(&with_normal_map(&plain, &flat), o.clone(), progress)?;
    let worst = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0f32, f32::max);
    rows.push(row(
        "flat bump map (every texel +Z) vs no map: largest pixel difference",
        "sphere and floor · lambert:0.8",
        80,
        f64::from(worst),
        "= 0 (exact)".into(),
        "issue 12 identity",
        Some(worst == 0.0),
    ));
    let bumps = Arc::new(relight_render::NormalMap::bumps(256, 8, 0.5));
    for visibility in [true, false] {
        let mut s = with_normal_map(&plain, &bumps);
        s.visibility = visibility;
        let reference = reference_at(&s, spp, progress)?;
        let (img, mask) = render_with(&s, o.clone(), progress)?;
        let (raw, sigma) = rel_rms_noise(&img, &reference, &mask);
        let e = without_noise(raw, sigma);
        rows.push(
            row(
                if visibility {
                    "bump-mapped, visibility on (unrotated visibility: the paper's approximation)"
                } else {
                    "bump-mapped, visibility off (the lighting lookup in the bumped frame)"
                },
                "sphere and floor · lambert:0.8 · bumps 8×8",
                80,
                e,
                "report".into(),
                "issue 12 (bump mapping is stated as an approximation)",
                None,
            )
            .with_noise(raw, sigma),
        );
    }
    Ok(rows)
}

/// What each storage choice costs ([`crate::storage`], issue 12): the
/// sphere-and-floor scene under `env` (Phong 16, shadows on) rendered with
/// every table f32 and with each compact choice, the relative RMS of the
/// difference over object pixels (reported), with the bytes each keeps.
///
/// # Errors
/// The method's.
pub fn storage_rows(
    env: &EnvMap,
    quick: bool,
    cache_dir: PathBuf,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, MethodError> {
    use crate::storage::Storage;
    let (w, h, terms) = if quick { (64, 48, 80) } else { (128, 96, 320) };
    let scene = floor_scene(env.clone(), parse_brdf("phong:16")?, w, h);
    let options = |storage| TripleOptions {
        terms,
        vis_level: if quick { 2 } else { 4 },
        cache_dir: cache_dir.clone(),
        storage,
        ..TripleOptions::default()
    };
    let mut f32_bytes = 0;
    let mut base = None;
    let mut rows = Vec::new();
    for storage in Storage::ALL {
        let mut m = TripleMethod::new(options(storage))?;
        m.prepare(&scene, progress)?;
        let r = render_frame(&mut m, &scene, &FrameRequest::new(scene.camera), progress)?;
        let mask = r
            .coverage
            .as_ref()
            .map(|c| c.object_mask())
            .unwrap_or_default();
        let bytes = m.data_bytes();
        let Some((reference, mask0)) = &base else {
            f32_bytes = bytes;
            base = Some((r.image, mask));
            continue;
        };
        let e = rel_rms(&r.image, reference, mask0);
        rows.push(row(
            &format!(
                "storage {}: image vs every table f32 ({:.1} of {:.1} MiB held)",
                storage.name(),
                bytes as f64 / 1_048_576.0,
                f32_bytes as f64 / 1_048_576.0
            ),
            "sphere and floor · phong:16",
            terms,
            e,
            "report".into(),
            "issue 12 (report the error each choice costs)",
            None,
        ));
    }
    Ok(rows)
}

/// Fig. 6 / Table 3 (issue 12): the verify scene's sphere over a
/// two-triangle floor with a visibility texture against the same sphere
/// over a finely tessellated floor with per-vertex visibility (≈ 26 K
/// triangles in the full run), both against one reference. The texture must
/// come within 10 % of the fine floor's error (judged in the full run).
///
/// # Errors
/// The method's or the reference's.
pub fn figure6_rows(
    env: &EnvMap,
    quick: bool,
    cache_dir: PathBuf,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, MethodError> {
    // (image, spp, terms, vis level, texture side, fine floor cells per side)
    let (w, h, spp, terms, vis_level, res, cells) = if quick {
        (64, 48, 256, 80, 2, 32, 40)
    } else {
        (128, 96, 1024, 320, 4, 128, 114)
    };
    let brdf = parse_brdf("lambert:0.8")?;
    let mut coarse = floor_scene(env.clone(), brdf, w, h);
    let floor = |n: usize| Arc::new(relight_geom::shapes::plane(6.0, n));
    coarse.objects[1].mesh = floor(1);
    let mut fine = coarse.clone();
    fine.objects[1].mesh = floor(cells);
    let reference = reference_at(&coarse, spp, progress)?;
    let o = TripleOptions {
        terms,
        vis_level,
        cache_dir,
        ..TripleOptions::default()
    };
    let err = |scene: &Scene, o: TripleOptions| -> Result<f64, MethodError> {
        let (img, mask) = render_with(scene, o, progress)?;
        let (raw, sigma) = rel_rms_noise(&img, &reference, &mask);
        Ok(without_noise(raw, sigma))
    };
    let e_tex = err(
        &coarse,
        TripleOptions {
            visibility_texture: res,
            ..o.clone()
        },
    )?;
    let e_vertex = err(&fine, o.clone())?;
    let e_refined = err(&coarse, o.clone())?;
    let e_coarse = err(
        &coarse,
        TripleOptions {
            refine_coarse: false,
            ..o
        },
    )?;
    let case = format!(
        "sphere · 2-triangle floor, texture {res}² vs {}-triangle floor per vertex",
        2 * cells * cells
    );
    let refined_to = coarse
        .with_coarse_objects_refined()
        .1
        .first()
        .map_or(4, |r| r.vertices);
    Ok(vec![
        row(
            "Fig. 6: visibility texture error ÷ fine per-vertex error",
            &case,
            terms,
            e_tex / e_vertex.max(1e-12),
            "≤ 1.10".into(),
            "issue 12 (Fig. 6 / Table 3: within 10 % of the fine floor's error)",
            (!quick).then_some(e_tex <= 1.10 * e_vertex),
        ),
        row(
            &format!(
                "Fig. 6: errors (texture, fine per vertex, 2-triangle per vertex, 2-triangle refined to {refined_to} vertices)"
            ),
            &format!("{e_tex:.4}, {e_vertex:.4}, {e_coarse:.4}, {e_refined:.4}"),
            terms,
            e_tex,
            "report".into(),
            "issue 12",
            None,
        ),
    ])
}

/// The verify medium: T = β·R = 1, albedo 0.8, the eye inside the ball.
pub const VERIFY_MEDIUM: relight_render::Medium = relight_render::Medium {
    beta: 0.1,
    albedo: 0.8,
    radius: 10.0,
};

/// Media (sun-thesis-2008 §3.6.5, [`crate::medium`]): the sphere-and-floor
/// scene under `env` in [`VERIFY_MEDIUM`] against the single-scattering
/// reference (the model's own physics), over every pixel (the glow is in the
/// medium) and over object pixels, with shadows; and unshadowed beside the
/// fog method (SH order 6 environment part, which cannot shadow) on the
/// same unshadowed scene, both against its reference. Reported: no target
/// is set for the model's error (light shafts and off-centre points are
/// outside it).
///
/// # Errors
/// The method's or the reference's.
pub fn medium_rows(
    env: &EnvMap,
    quick: bool,
    cache_dir: PathBuf,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, MethodError> {
    use relight_render::reference::MediumMode;
    let (w, h, spp) = if quick { (48, 36, 64) } else { (128, 96, 512) };
    let o = TripleOptions {
        terms: 80,
        vis_level: if quick { 2 } else { 4 },
        cache_dir,
        ..TripleOptions::default()
    };
    let mut rows = Vec::new();
    for visibility in [true, false] {
        let mut scene = floor_scene(env.clone(), parse_brdf("lambert:0.8")?, w, h);
        scene.medium = Some(VERIFY_MEDIUM);
        scene.visibility = visibility;
        let reference = render_reference(
            &scene,
            &ReferenceOptions {
                spp,
                medium_mode: MediumMode::SingleScattering,
                ..ReferenceOptions::default()
            },
            progress,
        )
        .map_err(|e| MethodError::failed("triple", e))?;
        let mut methods: Vec<(&str, Box<dyn Relighter>)> =
            vec![("triple", Box::new(TripleMethod::new(o.clone())?))];
        if !visibility {
            methods.push((
                "fog (SH order 6)",
                Box::new(relight_fog::FogRelighter::new(
                    relight_fog::FogOptions::default(),
                )?),
            ));
        }
        for (name, mut m) in methods {
            let (image, objects) = render_method(m.as_mut(), &scene, progress)?;
            let all = vec![true; objects.len()];
            for (region, mask) in [("all pixels", &all), ("object pixels", &objects)] {
                let (raw, sigma) = rel_rms_noise(&image, &reference, mask);
                let e = without_noise(raw, sigma);
                rows.push(
                    row(
                    &format!(
                        "medium (§3.6.5), {}: {name} vs the single-scattering reference, {region}",
                        if visibility { "shadows" } else { "unshadowed" }
                    ),
                    &format!(
                        "sphere and floor · lambert:0.8 · β {} a {} R {}",
                        VERIFY_MEDIUM.beta, VERIFY_MEDIUM.albedo, VERIFY_MEDIUM.radius
                    ),
                    80,
                    e,
                    "report".into(),
                    "issue 12 (media, verified against the reference with the medium)",
                    None,
                    )
                    .with_noise(raw, sigma),
                );
            }
        }
    }
    Ok(rows)
}

/// The comparison with the wavelet-rotation method (issue 12, "a comparison
/// row against the wavelet-rotation method on the same scenes"): the verify
/// scene under each probe **unshadowed** (the wavelet method has no
/// visibility), both methods at the same coefficient count `n` (triple:
/// top-only cells; wavelet: the `n` largest lighting terms), each against
/// the reference without visibility over object pixels, noise removed.
/// Quick: hall, Phong 16, n = 80, the wavelet cube at 16² per face; full:
/// every probe, Lambert and Phong 16, n = 80 and 320, 32² per face.
/// Reported.
///
/// # Errors
/// The methods' or the reference's.
pub fn wavelet_comparison_rows(
    probes: &[(String, EnvMap, bool)],
    quick: bool,
    cache_dir: PathBuf,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, MethodError> {
    let (w, h, spp) = if quick {
        (48, 36, 256)
    } else {
        (128, 96, 1024)
    };
    let terms: &[usize] = if quick { &[80] } else { &[80, 320] };
    let brdfs: &[&str] = if quick {
        &["phong:16"]
    } else {
        &["lambert:0.8", "phong:16"]
    };
    let mut rows = Vec::new();
    for (name, env, _) in probes.iter().take(if quick { 1 } else { probes.len() }) {
        for brdf in brdfs {
            let mut scene = floor_scene(env.clone(), parse_brdf(brdf)?, w, h);
            scene.visibility = false;
            let reference = reference_at(&scene, spp, progress)?;
            for &n in terms {
                let triple = TripleMethod::new(TripleOptions {
                    terms: n,
                    vis_level: crate::method::level_of(n),
                    cache_dir: cache_dir.clone(),
                    ..TripleOptions::default()
                })?;
                let wavelet =
                    relight_wavelet::WaveletMethod::new(relight_wavelet::WaveletOptions {
                        n: if quick { 16 } else { 32 },
                        ntess: if quick { 8 } else { 16 },
                        terms: n,
                        ..relight_wavelet::WaveletOptions::default()
                    })?;
                let methods: [(&str, Box<dyn Relighter>); 2] =
                    [("triple", Box::new(triple)), ("wavelet", Box::new(wavelet))];
                for (method, mut m) in methods {
                    let (image, mask) = render_method(m.as_mut(), &scene, progress)?;
                    let (raw, sigma) = rel_rms_noise(&image, &reference, &mask);
                    let e = without_noise(raw, sigma);
                    rows.push(
                        row(
                        &format!(
                            "wavelet-rotation comparison, unshadowed, n = {n}: {method} vs the reference"
                        ),
                        &format!("{name} · {brdf}"),
                        n,
                        e,
                        "report".into(),
                        "issue 12 (a comparison row against the wavelet-rotation method)",
                        None,
                        )
                        .with_noise(raw, sigma),
                    );
                }
            }
        }
    }
    Ok(rows)
}
