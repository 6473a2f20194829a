//! Numerical checks of the models, shared by the tests and `relight verify`:
//! quadrature of directional albedo and of the sampling pdf, the
//! importance-sampled albedo estimator, a seeded RNG, and the
//! [`verify_brdfs`] / [`bench_brdfs`] tables.
//!
//! # Quadrature rule
//! Lobes concentrate about the mirror direction r = mirror(wo), so the
//! sphere is parameterized in polar coordinates (ψ, φ) about r with
//! ψ = π t², t ∈ [0, 1] (sample density ∝ 1/ψ near the peak) and the
//! midpoint rule in (t, φ): dω = sin ψ · 2π t dt dφ. The weights sum to 4π
//! up to O(n_t⁻²).
//!
//! # Verdict of a [`VerifyRow`]
//! Issue 2 asks of every model: "white-furnace albedo ≤ 1" and "sampled
//! estimator matches quadrature". A row passes ([`verdict`]) when both hold:
//! * `albedo_quadrature ≤ target`, target = 1 + [`QUADRATURE_SLACK`]: the
//!   rule's own error on an exactly-unit albedo (measured 2.6·10⁻⁶ for
//!   Lambert at θ_o = 0) must not fail a lossless model; the slack is the
//!   crate's furnace test's;
//! * |`albedo_sampled` − `albedo_quadrature`| ≤ 5 `albedo_std_error` +
//!   [`QUADRATURE_SLACK`] (the crate's sampling test's bound: five standard
//!   errors, plus the quadrature's error).
//!
//! `pdf_integral` against `acceptance` and the reciprocity column are
//! reported beside it without a verdict: the issue gives them no tolerance,
//! and not every model is reciprocal.

use crate::sampling::{from_axis_frame, mirror};
use crate::{Brdf, BrdfSpec};
use glam::{DVec3, Vec2, Vec3};
use std::f64::consts::PI;

/// Deterministic PCG32 (O'Neill 2014, XSH-RR) for seeded checks.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator for `seed` (stream fixed).
    #[must_use]
    pub fn new(seed: u64) -> Self {
        let mut r = Self {
            state: 0,
            inc: 0xda3e_39cb_94b9_5bdb | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }
    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
    /// Uniform point of [0, 1)².
    pub fn next_vec2(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// Calls `f(direction, weight)` for every node of the concentrated polar
/// rule about the unit `axis` (module docs); `n_t × n_phi` nodes.
pub fn sphere_quadrature(axis: Vec3, n_t: usize, n_phi: usize, mut f: impl FnMut(Vec3, f64)) {
    let dt = 1.0 / n_t as f64;
    let dphi = 2.0 * PI / n_phi as f64;
    for i in 0..n_t {
        let t = (i as f64 + 0.5) * dt;
        let psi = PI * t * t;
        let w = psi.sin() * 2.0 * PI * t * dt * dphi;
        let (sp, cp) = psi.sin_cos();
        for j in 0..n_phi {
            let phi = (j as f64 + 0.5) * dphi;
            let local = Vec3::new((sp * phi.cos()) as f32, (sp * phi.sin()) as f32, cp as f32);
            f(from_axis_frame(axis, local), w);
        }
    }
}

/// Default quadrature resolution (n_t, n_φ).
pub const QUADRATURE: (usize, usize) = (768, 192);

/// Directional albedo ∫ f(wo, wi) cos θ_i dω_i by quadrature (RGB).
#[must_use]
pub fn directional_albedo_quadrature(brdf: &dyn Brdf, wo: Vec3, n: (usize, usize)) -> DVec3 {
    let mut sum = DVec3::ZERO;
    sphere_quadrature(mirror(wo), n.0, n.1, |wi, w| {
        if wi.z > 0.0 {
            sum += brdf.eval(wo, wi).as_dvec3() * (f64::from(wi.z) * w);
        }
    });
    sum
}

/// ∫ pdf(wo, wi) dω_i over the sphere by quadrature.
#[must_use]
pub fn pdf_integral_quadrature(brdf: &dyn Brdf, wo: Vec3, n: (usize, usize)) -> f64 {
    let mut sum = 0.0;
    sphere_quadrature(mirror(wo), n.0, n.1, |wi, w| {
        sum += f64::from(brdf.pdf(wo, wi)) * w
    });
    sum
}

/// Importance-sampled directional albedo: mean and standard error of
/// f cos θ_i / pdf over `n` samples (0 for a failed sample), and the
/// fraction of samples that succeeded.
#[derive(Clone, Copy, Debug)]
pub struct SampledAlbedo {
    /// Estimated albedo (RGB).
    pub mean: DVec3,
    /// Standard error of the mean (RGB).
    pub std_error: DVec3,
    /// Fraction of `sample` calls that returned `Some`.
    pub acceptance: f64,
}

/// Runs the importance-sampled albedo estimator with `n` seeded samples.
#[must_use]
pub fn directional_albedo_sampled(brdf: &dyn Brdf, wo: Vec3, n: usize, seed: u64) -> SampledAlbedo {
    let mut rng = Pcg32::new(seed);
    let (mut s1, mut s2, mut ok) = (DVec3::ZERO, DVec3::ZERO, 0usize);
    for _ in 0..n {
        if let Some(s) = brdf.sample(wo, rng.next_vec2()) {
            ok += 1;
            let x = s.f.as_dvec3() * (f64::from(s.wi.z) / f64::from(s.pdf));
            s1 += x;
            s2 += x * x;
        }
    }
    let nf = n as f64;
    let mean = s1 / nf;
    let var = (s2 / nf - mean * mean).max(DVec3::ZERO) * (nf / (nf - 1.0));
    SampledAlbedo {
        mean,
        std_error: (var / nf).powf(0.5),
        acceptance: ok as f64 / nf,
    }
}

/// Outgoing direction at polar angle `theta_deg` and azimuth `phi_deg`.
#[must_use]
pub fn direction_deg(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// One row of [`verify_brdfs`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct VerifyRow {
    /// Canonical spec of the model.
    pub spec: String,
    /// Polar angle of wo, degrees.
    pub theta_o_deg: f32,
    /// Mean-RGB directional albedo by quadrature.
    pub albedo_quadrature: f64,
    /// Mean-RGB importance-sampled albedo.
    pub albedo_sampled: f64,
    /// Its standard error.
    pub albedo_std_error: f64,
    /// |sampled − quadrature| / max(standard error, 10⁻⁵) (the floor keeps
    /// zero-variance estimators, e.g. Lambert, finite).
    pub albedo_z_score: f64,
    /// ∫ pdf over the sphere by quadrature.
    pub pdf_integral: f64,
    /// Fraction of successful samples (should equal `pdf_integral`).
    pub acceptance: f64,
    /// Largest |f(wo,wi) − f(wi,wo)| / max(|f|) over random pairs.
    pub reciprocity_max_rel_error: f64,
    /// [`verdict`] (module docs): furnace and sampled-vs-quadrature agreement.
    pub pass: Option<bool>,
    /// The furnace bound on `albedo_quadrature`: 1 + [`QUADRATURE_SLACK`].
    pub target: Option<f64>,
    /// Where the target comes from ([`SOURCE`]).
    pub source: Option<String>,
}

/// Allowance for the quadrature's own error in the furnace and agreement
/// checks (the crate's tests use the same).
pub const QUADRATURE_SLACK: f64 = 2e-3;

/// The furnace target on `albedo_quadrature`.
pub const FURNACE_TARGET: f64 = 1.0 + QUADRATURE_SLACK;

/// The source of the targets of [`verify_brdfs`].
pub const SOURCE: &str = "issue 2: white-furnace albedo ≤ 1 (+2e-3 quadrature slack); sampled \
     albedo = quadrature (≤ 5σ + 2e-3)";

/// The verdict of a row (module docs): `Some(true)` when `quadrature ≤`
/// [`FURNACE_TARGET`] and `|sampled − quadrature| ≤ 5 σ +`
/// [`QUADRATURE_SLACK`]; NaN anywhere fails.
#[must_use]
pub fn verdict(quadrature: f64, sampled: f64, std_error: f64) -> Option<bool> {
    let furnace = quadrature <= FURNACE_TARGET;
    let agree = (sampled - quadrature).abs() <= 5.0 * std_error + QUADRATURE_SLACK;
    Some(furnace && agree)
}

/// The specs checked by [`verify_brdfs`] (white, so albedo ≤ 1 is the furnace test).
pub const VERIFY_SPECS: &[&str] = &[
    "lambert",
    "oren-nayar:0.5",
    "phong:20",
    "blinn:50",
    "ward:0.2",
    "ward:0.1,0.4",
    "ggx:0.2",
    "ggx:0.05,0.3",
    "ashikhmin:100,10,1@0,0,0",
    "ashikhmin:20,200",
    "0.6*lambert+0.4*ggx:0.1",
];

/// Quadrature vs importance sampling vs reciprocity for [`VERIFY_SPECS`] at
/// θ_o ∈ {0°, 45°, 75°, 88°}; `samples` estimator samples per row.
#[must_use]
pub fn verify_brdfs(samples: usize) -> Vec<VerifyRow> {
    let mut rows = Vec::new();
    for (k, s) in VERIFY_SPECS.iter().enumerate() {
        let spec: BrdfSpec = s.parse().expect("VERIFY_SPECS parse");
        let brdf = spec.build();
        for (m, theta) in [0.0f32, 45.0, 75.0, 88.0].into_iter().enumerate() {
            let wo = direction_deg(theta, 30.0);
            let q = directional_albedo_quadrature(&*brdf, wo, QUADRATURE);
            let mc = directional_albedo_sampled(&*brdf, wo, samples, (k * 16 + m) as u64);
            let avg = |v: DVec3| (v.x + v.y + v.z) / 3.0;
            let se = avg(mc.std_error);
            rows.push(VerifyRow {
                spec: spec.to_string(),
                theta_o_deg: theta,
                albedo_quadrature: avg(q),
                albedo_sampled: avg(mc.mean),
                albedo_std_error: se,
                albedo_z_score: (avg(mc.mean) - avg(q)).abs() / se.max(1e-5),
                pdf_integral: pdf_integral_quadrature(&*brdf, wo, QUADRATURE),
                acceptance: mc.acceptance,
                reciprocity_max_rel_error: reciprocity_error(&*brdf, 2000, k as u64),
                pass: verdict(avg(q), avg(mc.mean), se),
                target: Some(FURNACE_TARGET),
                source: Some(SOURCE.into()),
            });
        }
    }
    rows
}

/// Largest |f(wo,wi) − f(wi,wo)| / max|f| over `n` random upper-hemisphere pairs.
#[must_use]
pub fn reciprocity_error(brdf: &dyn Brdf, n: usize, seed: u64) -> f64 {
    let mut rng = Pcg32::new(seed ^ 0x5eed);
    let mut worst = 0.0f64;
    for _ in 0..n {
        let a = crate::sampling::sample_cosine_hemisphere(rng.next_vec2());
        let b = crate::sampling::sample_cosine_hemisphere(rng.next_vec2());
        if a.z < 1e-3 || b.z < 1e-3 {
            continue;
        }
        let (x, y) = (brdf.eval(a, b), brdf.eval(b, a));
        let scale = f64::from(x.max_element().max(y.max_element()));
        if scale > 0.0 {
            worst = worst.max(f64::from((x - y).abs().max_element()) / scale);
        }
    }
    worst
}

/// One row of [`bench_brdfs`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchRow {
    /// Canonical spec.
    pub spec: String,
    /// Nanoseconds per `eval`.
    pub eval_ns: f64,
    /// Nanoseconds per `sample` (includes its eval and pdf).
    pub sample_ns: f64,
    /// Nanoseconds per `pdf`.
    pub pdf_ns: f64,
}

/// Times eval / sample / pdf of each [`VERIFY_SPECS`] model over `n` calls
/// (single thread, random directions).
#[must_use]
pub fn bench_brdfs(n: usize) -> Vec<BenchRow> {
    use std::hint::black_box;
    use std::time::Instant;
    let mut rng = Pcg32::new(7);
    let dirs: Vec<(Vec3, Vec3, Vec2)> = (0..n)
        .map(|_| {
            let a = crate::sampling::sample_cosine_hemisphere(rng.next_vec2());
            let b = crate::sampling::sample_cosine_hemisphere(rng.next_vec2());
            (a, b, rng.next_vec2())
        })
        .collect();
    let per = |t: Instant| t.elapsed().as_secs_f64() * 1e9 / n as f64;
    VERIFY_SPECS
        .iter()
        .map(|s| {
            let spec: BrdfSpec = s.parse().expect("VERIFY_SPECS parse");
            let b = spec.build();
            let t = Instant::now();
            let mut acc = Vec3::ZERO;
            for (wo, wi, _) in &dirs {
                acc += b.eval(*wo, *wi);
            }
            black_box(acc);
            let eval_ns = per(t);
            let t = Instant::now();
            for (wo, _, u) in &dirs {
                black_box(b.sample(*wo, *u));
            }
            let sample_ns = per(t);
            let t = Instant::now();
            let mut p = 0.0;
            for (wo, wi, _) in &dirs {
                p += b.pdf(*wo, *wi);
            }
            black_box(p);
            BenchRow {
                spec: spec.to_string(),
                eval_ns,
                sample_ns,
                pdf_ns: per(t),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Just over the furnace target fails; so does a sampled albedo just
    /// outside 5σ + slack, or a NaN.
    #[test]
    fn verdict_at_and_over_the_targets() {
        assert_eq!(verdict(1.0, 1.0, 0.0), Some(true));
        assert_eq!(verdict(FURNACE_TARGET, FURNACE_TARGET, 0.0), Some(true));
        let over = FURNACE_TARGET + 1e-12;
        assert_eq!(verdict(over, over, 0.0), Some(false));
        let se = 0.01;
        let edge = 5.0 * se + QUADRATURE_SLACK;
        assert_eq!(verdict(0.5, 0.5 + 0.999 * edge, se), Some(true));
        assert_eq!(verdict(0.5, 0.5 - 1.001 * edge, se), Some(false));
        assert_eq!(verdict(f64::NAN, 0.5, se), Some(false));
        assert_eq!(verdict(0.5, f64::NAN, se), Some(false));
    }

    /// Every row of the quick table is judged, and the models of
    /// [`VERIFY_SPECS`] pass.
    #[test]
    fn quick_table_passes() {
        for r in verify_brdfs(4000) {
            assert_eq!(r.target, Some(FURNACE_TARGET));
            assert_eq!(r.pass, Some(true), "{r:?}");
        }
    }
}
