//! `relight verify ltc`: the fit against the GGX it was fitted to, the
//! polygon integrals against quadrature, and images of LTC and of the
//! `nearfield` method against the Monte Carlo reference on the scenes that
//! show where each wins (issue 13: "its rows show where the affine method
//! wins (textures, shadows) and where it loses").
//!
//! Every row with a target says pass/fail and names its source.

use crate::fit::{self, Lobe, l1_error};
use crate::method::{LtcMethod, LtcOptions};
use crate::polygon::clamped_cosine_integral;
use crate::table;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use relight_nearfield::scenes::floor_and_sphere;
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::{FrameRequest, Relighter};
use relight_render::reference::{ReferenceOptions, render_reference};
use relight_render::verify_row::{VerifyRow, row};
use relight_render::{Image, Progress, Scene};
use std::sync::Arc;

const ISSUE: &str = "issue 13 (LTC baseline)";

/// Settings of [`verify_rows`].
#[derive(Clone, Copy, Debug)]
pub struct VerifyOptions {
    /// Rectangles per (roughness, view) in the polygon rows.
    pub rectangles: usize,
    /// Midpoints per side of the area quadrature of a rectangle.
    pub quadrature: usize,
    /// Samples per side per distribution of the fit's L1 rows.
    pub l1_samples: usize,
    /// Quadrature points in cos θ (2× in φ) over the hemisphere for the
    /// magnitude rows.
    pub hemisphere: usize,
    /// The image scenes (`relight_nearfield::scenes::floor_and_sphere`).
    pub floor: usize,
    pub segments: usize,
    pub width: usize,
    pub height: usize,
    pub reference_spp: u32,
    pub aa: usize,
    /// Also the image rows (off: the fit and polygon rows alone).
    pub images: bool,
}

impl VerifyOptions {
    /// Full or `quick` (smoke) sizes.
    #[must_use]
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                rectangles: 4,
                quadrature: 192,
                l1_samples: 24,
                hemisphere: 500,
                floor: 24,
                segments: 16,
                width: 64,
                height: 40,
                reference_spp: 512,
                aa: 4,
                images: true,
            }
        } else {
            Self {
                rectangles: 12,
                quadrature: 400,
                l1_samples: 64,
                hemisphere: 1200,
                floor: 48,
                segments: 32,
                width: 160,
                height: 100,
                reference_spp: 1024,
                aa: 4,
                images: true,
            }
        }
    }
}

/// The roughnesses of the fit and polygon rows (between table rows, so the
/// interpolation is included; ≥ 0.05 so that the area quadrature resolves the
/// lobe).
pub const ROUGHNESSES: [f64; 6] = [0.05, 0.1, 0.2, 0.35, 0.6, 0.9];

/// The view angles (degrees) of the polygon rows.
pub const VIEWS: [f64; 4] = [0.0, 30.0, 60.0, 80.0];

/// A small seeded generator (SplitMix64) for the rectangles.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A rectangle `(corner, u, v)` in front of the origin, above the horizon
/// at its centre: centre at distance 0.8…3 in a direction with z ≥ 0.15
/// (azimuth anywhere), sides 0.3…2, turned randomly about its own normal,
/// which faces the origin.
fn rectangle(rng: &mut Rng) -> (DVec3, DVec3, DVec3) {
    let z = 0.15 + 0.85 * rng.next();
    let phi = 2.0 * std::f64::consts::PI * rng.next();
    let s = (1.0 - z * z).sqrt();
    let dir = DVec3::new(s * phi.cos(), s * phi.sin(), z);
    let c = dir * (0.8 + 2.2 * rng.next());
    let n = -dir;
    let a = n.any_orthonormal_vector();
    let b = n.cross(a);
    let t = 2.0 * std::f64::consts::PI * rng.next();
    let (u, v) = (a * t.cos() + b * t.sin(), b * t.cos() - a * t.sin());
    let (w, h) = (0.3 + 1.7 * rng.next(), 0.3 + 1.7 * rng.next());
    (c - u * (0.5 * w) - v * (0.5 * h), u * w, v * h)
}

/// `∫_rect g(ω) dω` by `q²` midpoints over the rectangle's area.
fn area_quadrature(
    (c, u, v): (DVec3, DVec3, DVec3),
    q: usize,
    g: &(dyn Fn(DVec3) -> f64 + Sync),
) -> f64 {
    let nl = u.cross(v);
    let da = nl.length() / (q * q) as f64;
    let nl = nl.normalize();
    let mut sum = 0.0;
    for j in 0..q {
        for i in 0..q {
            let p = c + u * ((i as f64 + 0.5) / q as f64) + v * ((j as f64 + 0.5) / q as f64);
            let r2 = p.length_squared();
            let w = p / r2.sqrt();
            sum += g(w) * w.dot(nl).abs() / r2;
        }
    }
    sum * da
}

fn fit_rows(opts: &VerifyOptions, rows: &mut Vec<VerifyRow>) {
    // Diffuse: the edge-form integral against quadrature.
    let mut rng = Rng(11);
    let rects: Vec<_> = (0..4 * opts.rectangles)
        .map(|_| rectangle(&mut rng))
        .collect();
    let worst = rects
        .par_iter()
        .map(|&r| {
            let (c, u, v) = r;
            let e = clamped_cosine_integral(&[c, c + u, c + u + v, c + v]).abs();
            let q = area_quadrature(r, opts.quadrature, &|w| w.z.max(0.0) / std::f64::consts::PI);
            (e - q).abs() / q.max(1e-3)
        })
        .reduce(|| 0.0, f64::max);
    rows.push(row(
        format!(
            "diffuse: clamped-cosine polygon integral vs {0}×{0} area quadrature, {1} rectangles: max relative difference",
            opts.quadrature,
            rects.len()
        ),
        worst,
        "relative",
        // Exact closed form: only the quadrature's error (O(h²)) remains.
        Some((1e-3, true)),
        "Heitz et al. 2016 eq. 11 (exact)",
    ));
    // The magnitude and Fresnel moment at the table's own cells against
    // hemisphere quadrature of the GGX·cos they were sampled from.
    let size = table::size();
    let cells: Vec<(usize, usize)> = [size / 4, size / 2, 3 * size / 4, size - 1]
        .into_iter()
        .flat_map(|i| [0, size / 3, 2 * size / 3, size - 4].map(|j| (i, j)))
        .collect();
    let worst = cells
        .par_iter()
        .map(|&(i, j)| {
            let (alpha, theta) = (fit::row_alpha(i, size), fit::column_theta(j, size));
            let lobe = Lobe::new(alpha, theta);
            let wo = lobe.wo();
            let q = opts.hemisphere;
            let (mut n, mut f) = (0.0, 0.0);
            for b in 0..q {
                let z = (b as f64 + 0.5) / q as f64;
                let s = (1.0 - z * z).sqrt();
                for a in 0..2 * q {
                    let phi = std::f64::consts::PI * (a as f64 + 0.5) / q as f64;
                    let w = DVec3::new(s * phi.cos(), s * phi.sin(), z);
                    let rho = lobe.eval(w).0;
                    n += rho;
                    f += rho * (1.0 - wo.dot((wo + w).normalize())).clamp(0.0, 1.0).powi(5);
                }
            }
            let dw = std::f64::consts::PI / (q * q) as f64;
            let c = table::cell(i, j);
            let en = (f64::from(c[4]) - n * dw).abs() / (n * dw);
            let ef = (f64::from(c[5]) - f * dw).abs() / (n * dw);
            en.max(ef)
        })
        .reduce(|| 0.0, f64::max);
    rows.push(row(
        format!(
            "table magnitude n and Fresnel moment f at {} cells (α ≥ {:.3}) vs {}×{} hemisphere quadrature: max |error| / n",
            cells.len(),
            fit::row_alpha(size / 4, size),
            opts.hemisphere,
            2 * opts.hemisphere
        ),
        worst,
        "relative",
        // The moments are 128² stratified visible-normal samples (weights
        // G₂/G₁ ≤ 1); at grazing views many fall below the horizon, a
        // discontinuous integrand whose stratified error is ~N^(−3/4) ≈ 7·10⁻⁴
        // times the weights' spread. 5·10⁻³ keeps the magnitude's error below
        // the fit's own shape error (mean |error| / n ≥ 2·10⁻³ per roughness,
        // the rows below), so it never dominates an image.
        Some((5e-3, true)),
        ISSUE,
    ));
    // The fit per roughness.
    for &alpha in &ROUGHNESSES {
        // L1 distance of the table's lobes (interpolated at α) over the θ_o
        // columns.
        let l1: Vec<f64> = (0..size)
            .into_par_iter()
            .map(|j| {
                let theta = fit::column_theta(j, size);
                let lobe = Lobe::new(alpha, theta);
                let l = table::lookup(alpha as f32, theta.cos() as f32);
                l1_error(&l.ltc, f64::from(l.norm), &lobe, opts.l1_samples)
            })
            .collect();
        let l1_max = l1.iter().copied().fold(0.0, f64::max);
        let l1_mean = l1.iter().sum::<f64>() / l1.len() as f64;
        // Polygon integrals against quadrature of the true GGX·cos.
        let mut rng = Rng(1000 + (alpha * 1e4) as u64);
        let cases: Vec<(f64, (DVec3, DVec3, DVec3))> = VIEWS
            .iter()
            .flat_map(|&t| (0..opts.rectangles).map(move |_| t))
            .map(|t| (t, rectangle(&mut rng)))
            .collect();
        let errs: Vec<(f64, f64, f64)> = cases
            .par_iter()
            .map(|&(t, r)| {
                let theta = t.to_radians();
                let lobe = Lobe::new(alpha, theta);
                let l = table::lookup(alpha as f32, theta.cos() as f32);
                let (c, u, v) = r;
                let got =
                    l.ltc.polygon_integral(&[c, c + u, c + u + v, c + v]).abs() * f64::from(l.norm);
                let want = area_quadrature(r, opts.quadrature, &|w| lobe.eval(w).0);
                let n = f64::from(l.norm);
                (
                    (got - want).abs() / n,
                    (got - want).abs() / want.max(1e-30),
                    want / n,
                )
            })
            .collect();
        // The L1 distance at each view: |∫_P (ρ − nD)| ≤ ∫ |ρ − nD| = n·L1,
        // so a polygon's error over n cannot exceed it (plus the
        // quadrature's and the L1 estimate's own error).
        let view_l1: Vec<f64> = VIEWS
            .iter()
            .map(|t| {
                let theta = t.to_radians();
                let l = table::lookup(alpha as f32, theta.cos() as f32);
                l1_error(
                    &l.ltc,
                    f64::from(l.norm),
                    &Lobe::new(alpha, theta),
                    opts.l1_samples,
                )
            })
            .collect();
        let excess = cases
            .iter()
            .zip(&errs)
            .map(|((t, _), e)| {
                let k = VIEWS.iter().position(|v| v == t).unwrap_or(0);
                e.0 - view_l1[k]
            })
            .fold(f64::NEG_INFINITY, f64::max);
        let e_mean = errs.iter().map(|e| e.0).sum::<f64>() / errs.len() as f64;
        let e_max = errs.iter().map(|e| e.0).fold(0.0, f64::max);
        // Relative error of rectangles that hold ≥ 10 % of the lobe.
        let big: Vec<f64> = errs.iter().filter(|e| e.2 >= 0.1).map(|e| e.1).collect();
        let rel_max = big.iter().copied().fold(0.0, f64::max);
        rows.push(row(
            format!("fit α = {alpha}: L1 distance ∫|ρ − n D| dω / n over the θ_o columns, mean (max {l1_max:.4})"),
            l1_mean,
            "fraction of the lobe",
            None,
            "Heitz et al. 2016 §5 (fit)",
        ));
        rows.push(row(
            format!(
                "fit α = {alpha}: rectangle integral vs {0}×{0} quadrature of GGX·cos, {1} rectangles × views {VIEWS:?}°: mean |error| / n (max {e_max:.4})",
                opts.quadrature,
                errs.len() / VIEWS.len()
            ),
            e_mean,
            "fraction of the lobe",
            None,
            ISSUE,
        ));
        rows.push(row(
            format!("fit α = {alpha}: … max over rectangles of |error| / n − L1 at its view (bound: ≤ 0 up to quadrature)"),
            excess,
            "fraction of the lobe",
            Some((2e-3, true)),
            "|∫_P (ρ − nD)| ≤ n·L1",
        ));
        rows.push(row(
            format!("fit α = {alpha}: … max relative error of the {} rectangles holding ≥ 10 % of the lobe", big.len()),
            rel_max,
            "relative",
            None,
            ISSUE,
        ));
    }
}

/// The four image scenes: untextured + unshadowed, textured, shadowed, and
/// untextured + unshadowed with a glossy sphere.
fn scenes(opts: &VerifyOptions) -> Vec<(&'static str, Scene, Option<bool>)> {
    let base = floor_and_sphere(opts.floor, opts.segments, opts.width, opts.height, false);
    let mut plain = base.clone();
    plain.area_lights[0].texture = None;
    let textured = base.clone();
    let mut shadowed = plain.clone();
    shadowed.visibility = true;
    let mut glossy = plain.clone();
    glossy.objects[0].brdf = Arc::new(
        relight_brdf::Mix::new(vec![
            (
                0.5,
                Arc::new(relight_brdf::Lambert::new(Vec3::splat(0.8)).expect("valid albedo")),
            ),
            (
                0.5,
                Arc::new(
                    relight_brdf::Ggx::isotropic(0.15, Vec3::new(0.95, 0.64, 0.54))
                        .expect("valid GGX"),
                ),
            ),
        ])
        .expect("valid weights"),
    );
    // `Some(true)`: LTC should win; `Some(false)`: nearfield should. The
    // glossy sphere is untextured and unshadowed, LTC's own case: nearfield
    // shades its GGX by the fixed-view transport, per vertex.
    vec![
        ("untextured, unshadowed, Lambert", plain, Some(true)),
        (
            "textured (64² test texture), unshadowed, Lambert",
            textured,
            Some(false),
        ),
        ("untextured, shadowed, Lambert", shadowed, Some(false)),
        (
            "untextured, unshadowed, glossy sphere (0.5 Lambert + 0.5 GGX α 0.15)",
            glossy,
            Some(true),
        ),
    ]
}

/// Pixels fully covered by one object whose eight neighbours are too: the
/// image rows compare lighting, not how a silhouette between two objects
/// is antialiased (both methods share the rasterizer there; the reference
/// integrates the pixel).
fn interior_mask(c: &relight_render::method::Coverage) -> Vec<bool> {
    let (w, h) = (c.width, c.height);
    let full = |x: usize, y: usize| c.coverage[y * w + x] >= 1.0;
    let mut m = vec![false; w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let id = c.object_id[y * w + x];
            m[y * w + x] = (y - 1..=y + 1)
                .all(|yy| (x - 1..=x + 1).all(|xx| full(xx, yy) && c.object_id[yy * w + xx] == id));
        }
    }
    m
}

fn image_rows(
    opts: &VerifyOptions,
    progress: &dyn Progress,
    rows: &mut Vec<VerifyRow>,
) -> Result<(), String> {
    for (what, scene, ltc_wins) in scenes(opts) {
        let reference = render_reference(
            &scene,
            &ReferenceOptions {
                spp: opts.reference_spp,
                pass_spp: opts.reference_spp.min(16),
                seed: 7,
                ..ReferenceOptions::default()
            },
            progress,
        )
        .map_err(|e| e.to_string())?;
        let request = FrameRequest::new(scene.camera).with_aa(opts.aa);
        let mut ltc = LtcMethod::new(LtcOptions::default()).map_err(|e| e.to_string())?;
        ltc.prepare(&scene, progress).map_err(|e| e.to_string())?;
        let a = ltc
            .render(&scene, &request, progress)
            .map_err(|e| e.to_string())?;
        let mask = interior_mask(a.coverage.as_deref().ok_or("no coverage")?);
        let err = |img: &Image| img.relative_rms_error(&reference.image, Some(&mask));
        let mut nf =
            NearfieldMethod::new(NearfieldOptions::default()).map_err(|e| e.to_string())?;
        nf.prepare(&scene, progress).map_err(|e| e.to_string())?;
        let b = nf
            .render(&scene, &request, progress)
            .map_err(|e| e.to_string())?;
        let (e_ltc, e_nf) = (err(&a.image), err(&b.image));
        rows.push(row(
            format!("{what}: reference noise σ_MC ({} spp)", reference.spp),
            reference.rms_relative_std_error_over(&mask),
            "relative RMS",
            None,
            "relight_render::reference",
        ));
        rows.push(row(
            format!("{what}: ltc (interior pixels)"),
            e_ltc,
            "relative RMS vs reference",
            None,
            ISSUE,
        ));
        rows.push(row(
            format!("{what}: nearfield (order 32, 1 %/20 %, per vertex)"),
            e_nf,
            "relative RMS vs reference",
            None,
            ISSUE,
        ));
        let ratio = e_ltc / e_nf;
        let (label, target) = match ltc_wins {
            Some(true) => ("ltc wins: ltc error ÷ nearfield error", Some((1.0, true))),
            Some(false) => (
                "nearfield wins: ltc error ÷ nearfield error",
                Some((1.0, false)),
            ),
            None => ("ltc error ÷ nearfield error", None),
        };
        rows.push(row(
            format!("{what}: {label}"),
            ratio,
            "ratio",
            target,
            ISSUE,
        ));
    }
    Ok(())
}

/// Every verify row (module docs).
///
/// # Errors
/// A method or reference failure, as text.
pub fn verify_rows(
    opts: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, String> {
    let mut rows = Vec::new();
    rows.push(row(
        format!(
            "table: {0}×{0} cells over (√α, θ_o), α ≥ {1}",
            table::size(),
            fit::ALPHA_MIN
        ),
        (table::size() * table::size()) as f64,
        "cells",
        None,
        "crate::fit (FitOptions::default)",
    ));
    fit_rows(opts, &mut rows);
    progress.check().map_err(|e| e.to_string())?;
    if opts.images {
        image_rows(opts, progress, &mut rows)?;
    }
    Ok(rows)
}
