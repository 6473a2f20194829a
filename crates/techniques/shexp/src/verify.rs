//! `relight verify shexp`, the math rows: log table values, round trips and
//! log space against product space (the image rows are in
//! [`crate::verify_scene`]). Every row names its target and where it comes from.

use crate::ShExpError;
use crate::cap::cap_visibility_zonal;
use crate::exp::{ExpKind, Exponentiator, OlFit};
use crate::log_table::{DEFAULT_EIGEN_CLIP, LogTable, cap_log_zonal};
use crate::shade::irradiance_zonal;
use crate::union::{Cap, UNION_QUADRATURE_DEGREE, UnionProjector};
use relight_sh::product::TripleProduct;
use serde::Serialize;
use std::f64::consts::PI;

/// One verify row.
#[derive(Clone, Debug, Serialize)]
pub struct VerifyRow {
    pub check: String,
    pub measured: String,
    pub target: String,
    /// Where the target comes from.
    pub source: String,
    /// `None` for a report row (no target).
    pub pass: Option<bool>,
}

/// The cross-check of the order-4 log table (issue 15), l = 0…3.
pub const LOG_CROSS_CHECK: [(f64, [f64; 4]); 3] = [
    (10.0, [-0.0286, -0.0484, -0.0612, -0.0700]),
    (30.0, [-0.3642, -0.5647, -0.6190, -0.5615]),
    (60.0, [-2.7007, -3.8489, -3.2336, -1.8459]),
];

/// Bounds of the round trip `‖exp(log g) − g‖/‖g‖` for a cap of `deg`
/// degrees: `(PS*/HYB, fitted OL)`. The clipped log (ε = 0.02) itself loses
/// more as the cap grows (≈ 1 % at 50°, ≈ 5 % at 60° at order 4), so the
/// bound is by angle; the thesis gives none.
#[must_use]
pub fn round_trip_bound(deg: f64) -> (f64, f64) {
    if deg <= 50.0 {
        (0.03, 0.10)
    } else {
        (0.06, 0.15)
    }
}

/// Round trip of one cap of half-angle `deg`: every exponential of the
/// tabulated log against the cap's visibility `g`.
#[derive(Clone, Debug, Serialize)]
pub struct RoundTrip {
    pub deg: f64,
    /// ‖PS*-4(log g) − g‖/‖g‖.
    pub ps4_rel: f64,
    /// ‖PS*-2(log g) − g‖/‖g‖.
    pub ps2_rel: f64,
    /// ‖PS*-2 − PS*-4‖/‖PS*-4‖ of the same log.
    pub ps2_vs_ps4: f64,
    /// ‖OL(log g) − g‖/‖g‖, OL with the fitted coefficients.
    pub ol_rel: f64,
    /// ‖HYB(log g) − g‖/‖g‖.
    pub hyb_rel: f64,
    /// The Gaussian-moment OL of `relight_sh` (for comparison).
    pub gaussian_ol_rel: f64,
    /// Squarings PS* used.
    pub squarings: u32,
}

fn rel(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    (d / b.iter().map(|y| y * y).sum::<f64>().max(1e-300)).sqrt()
}

fn zonal_to_full(n: usize, z: &[f64]) -> Vec<f64> {
    let mut f = vec![0.0; n * n];
    for l in 0..n {
        f[l * (l + 1)] = z[l];
    }
    f
}

/// exp(log g) against g, per cap angle (degrees), at `order`.
///
/// # Errors
/// A bad order.
pub fn cap_round_trip(order: usize, degrees: &[f64]) -> Result<Vec<RoundTrip>, ShExpError> {
    let table = LogTable::with_defaults(order)?;
    let tp = TripleProduct::<f64>::new(order)?;
    let mut e = Exponentiator::<f64>::new(order, OlFit::fit(&table))?;
    let mut gauss = relight_sh::product::ShExp::<f64>::new(order)?;
    let nn = order * order;
    let mut rows = Vec::new();
    for &deg in degrees {
        let z = cap_log_zonal(&tp, deg.to_radians(), DEFAULT_EIGEN_CLIP)?;
        let f = zonal_to_full(order, &z);
        let g = zonal_to_full(order, &cap_visibility_zonal(order, deg.to_radians()));
        let mut v = vec![vec![0.0; nn]; 5];
        let (s, _) = e.exp(ExpKind::PsStar(4), &f, &mut v[0]);
        e.exp(ExpKind::PsStar(2), &f, &mut v[1]);
        e.exp(ExpKind::Ol, &f, &mut v[2]);
        e.exp(ExpKind::Hyb, &f, &mut v[3]);
        gauss.exp(relight_sh::product::ExpMethod::Ol, &f, &mut v[4]);
        rows.push(RoundTrip {
            deg,
            ps4_rel: rel(&v[0], &g),
            ps2_rel: rel(&v[1], &g),
            ps2_vs_ps4: rel(&v[1], &v[0]),
            ol_rel: rel(&v[2], &g),
            hyb_rel: rel(&v[3], &g),
            gaussian_ol_rel: rel(&v[4], &g),
            squarings: s,
        });
    }
    Ok(rows)
}

/// Log space against product space on random cap sets.
#[derive(Clone, Debug, Serialize)]
pub struct LogVsProduct {
    pub order: usize,
    pub sets: usize,
    /// RMS over sets of `L_H(N)·g − L_H(N)·g_exact`, log space + PS*-2.
    pub log_rms: f64,
    /// The same for product space.
    pub product_rms: f64,
    /// RMS of the unshadowed `L_H(N)·1`.
    pub unshadowed_rms: f64,
}

/// A small xorshift for seeded cap sets.
pub(crate) struct XorShift(u64);

impl XorShift {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub(crate) fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A sky-like test lighting: `0.5 + 3 max(0, s·sun)⁸`, projected at `order`.
#[must_use]
pub fn test_lighting(order: usize) -> Vec<f64> {
    let sun = glam::DVec3::new(0.3, 0.4, 0.85).normalize();
    let q = relight_sh::quadrature::SphereQuadrature::for_degree(64);
    relight_sh::project::project_fn(order, &q, |d| 0.5 + 3.0 * d.dot(sun).max(0.0).powi(8))
}

/// `sets` seeded random sets of 1–20 caps above a receiver with normal +Z
/// (axes in the upper hemisphere, half-angles 5°–35°), shaded under
/// [`test_lighting`]: log space (PS*-2) and product space against the exact
/// projected union of the caps.
///
/// # Errors
/// A bad order.
pub fn log_vs_product(order: usize, sets: usize, seed: u64) -> Result<LogVsProduct, ShExpError> {
    let nn = order * order;
    let table = LogTable::with_defaults(order)?;
    let tp = TripleProduct::<f64>::new(order)?;
    let mut e = Exponentiator::<f64>::new(order, OlFit::fit(&table))?;
    let proj = UnionProjector::new(order, UNION_QUADRATURE_DEGREE);
    let l = test_lighting(order);
    let h = zonal_to_full(order, &irradiance_zonal(order));
    let mut lh = vec![0.0; nn];
    tp.product(&l, &h, &mut lh);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let unshadowed = lh[0] * (4.0 * PI).sqrt();
    let mut rng = XorShift::new(seed);
    let (mut el, mut ep) = (0.0, 0.0);
    let mut z = vec![0.0; order];
    let mut y = vec![0.0; nn];
    for _ in 0..sets {
        let count = 1 + (rng.next() * 20.0) as usize;
        let caps: Vec<Cap> = (0..count.min(20))
            .map(|_| {
                let zc = 0.15 + 0.85 * rng.next();
                let phi = 2.0 * PI * rng.next();
                let s = (1.0 - zc * zc).sqrt();
                Cap {
                    axis: [s * phi.cos(), s * phi.sin(), zc],
                    theta: (5.0 + 30.0 * rng.next()).to_radians(),
                }
            })
            .collect();
        let exact = proj.project(&caps);
        let mut f = vec![0.0; nn];
        let mut g = vec![0.0; nn];
        g[0] = (4.0 * PI).sqrt();
        let mut tmp = vec![0.0; nn];
        for c in &caps {
            relight_sh::eval_sh_into(order, c.axis, &mut y);
            table.lookup_f64(c.theta, &mut z);
            let gz = cap_visibility_zonal(order, c.theta);
            let mut gc = vec![0.0; nn];
            for li in 0..order {
                let k = (4.0 * PI / (2 * li + 1) as f64).sqrt();
                for i in li * li..(li + 1) * (li + 1) {
                    f[i] += k * z[li] * y[i];
                    gc[i] = k * gz[li] * y[i];
                }
            }
            tp.product(&g, &gc, &mut tmp);
            g.copy_from_slice(&tmp);
        }
        let mut gl = vec![0.0; nn];
        e.exp(ExpKind::PsStar(2), &f, &mut gl);
        let want = dot(&lh, &exact);
        el += (dot(&lh, &gl) - want).powi(2);
        ep += (dot(&lh, &g) - want).powi(2);
    }
    let k = sets.max(1) as f64;
    Ok(LogVsProduct {
        order,
        sets,
        log_rms: (el / k).sqrt(),
        product_rms: (ep / k).sqrt(),
        unshadowed_rms: unshadowed,
    })
}

/// The math rows of `relight verify shexp` at `order` (the log-table row is
/// always at order 4, where the cross-check lives).
///
/// # Errors
/// A bad order.
pub fn verify_math(order: usize, sets: usize) -> Result<Vec<VerifyRow>, ShExpError> {
    let mut rows = Vec::new();
    let tp4 = TripleProduct::<f64>::new(4)?;
    for (deg, want) in LOG_CROSS_CHECK {
        let got = cap_log_zonal(&tp4, deg.to_radians(), DEFAULT_EIGEN_CLIP)?;
        let err = got
            .iter()
            .zip(want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        rows.push(VerifyRow {
            check: format!("log table, order 4, {deg}° cap"),
            measured: format!(
                "[{}] (max |Δ| {err:.1e})",
                got.iter()
                    .map(|v| format!("{v:.4}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            target: "max |Δ| ≤ 1e-3".into(),
            source: "issue 15 cross-check values".into(),
            pass: Some(err <= 1e-3),
        });
    }
    for r in cap_round_trip(order, &[10.0, 20.0, 30.0, 40.0, 50.0, 60.0])? {
        rows.push(VerifyRow {
            check: format!("round trip, {}° cap, order {order}", r.deg),
            measured: format!(
                "PS*-4 {:.2} %, PS*-2 {:.2} % (vs PS*-4 {:.2} %), HYB {:.2} %, fitted OL {:.2} % (Gaussian OL {:.1} %), {} squarings",
                100.0 * r.ps4_rel,
                100.0 * r.ps2_rel,
                100.0 * r.ps2_vs_ps4,
                100.0 * r.hyb_rel,
                100.0 * r.ol_rel,
                100.0 * r.gaussian_ol_rel,
                r.squarings
            ),
            target: {
                let (b, o) = round_trip_bound(r.deg);
                format!("‖exp(log g) − g‖/‖g‖: PS*-4, PS*-2, HYB ≤ {:.0} %; fitted OL ≤ {:.0} %", 100.0 * b, 100.0 * o)
            },
            source: "this crate's bounds (thesis §5.2.2 gives no numbers); the issue's Gaussian-OL errors 7/28/190 % at 30/40/50°".into(),
            pass: {
                let (b, o) = round_trip_bound(r.deg);
                Some(r.ps4_rel <= b && r.ps2_rel <= b && r.hyb_rel <= b && r.ol_rel <= o)
            },
        });
    }
    let r = log_vs_product(order, sets, 7)?;
    rows.push(VerifyRow {
        check: format!(
            "log vs product space, {} random sets of 1–20 caps, order {order}",
            r.sets
        ),
        measured: format!(
            "log RMS {:.4}, product RMS {:.4}, unshadowed {:.4}",
            r.log_rms, r.product_rms, r.unshadowed_rms
        ),
        target: "log ≤ 1.25 × product + 0.5 % of unshadowed".into(),
        source: "issue 15".into(),
        pass: Some(r.log_rms <= 1.25 * r.product_rms + 0.005 * r.unshadowed_rms),
    });
    Ok(rows)
}
