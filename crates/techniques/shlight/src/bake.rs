//! Precomputation: SH coefficients of BRDF × cosine for every outgoing polar
//! angle (Kautz, Sloan & Snyder 2002, §3; Křivánek et al. 2006 §4.1).
//!
//! # What is tabulated
//! In the canonical local frame (normal +Z, `ω_o = (sin θ_o, 0, cos θ_o)` in
//! the xz-plane), for `θ_o` on a grid,
//!
//! `B_{l,m}(θ_o) = ∫_{H²} f(ω_o, ω_i) cos θ_i y_{l,m}(ω_i) dω_i`  (per RGB channel).
//!
//! For an **isotropic** BRDF `f(R_z ω_o, R_z ω_i) = f(ω_o, ω_i)`, so the
//! transfer vector for any other outgoing direction with the same θ_o and
//! azimuth φ_o is the exact Z rotation `R_z(φ_o) B(θ_o)` (O(n²),
//! `relight_sh::rotation::rotate_z`): one polar-angle grid is the whole table.
//! In the canonical frame the integrand is even in `ω_i.y`, so every `m < 0`
//! coefficient vanishes exactly; they are stored as zeros.
//!
//! # Quadrature
//! Gauss–Legendre in `μ = cos θ_i ∈ [0, 1]` ([`BakeOptions::mu_nodes`]) ×
//! uniform midpoint rule in φ ∈ [0, π] (doubled by the y-symmetry;
//! [`BakeOptions::phi_nodes`]). The horizon clamp is the end of the μ
//! interval, so the cosine kink costs nothing. Defaults resolve GGX/Phong
//! lobes down to α ≈ 0.1 (exponent ≈ 200) to well under the SH truncation error.
//!
//! # Layout
//! `coeffs[(j · 3 + c) · n² + i]` for polar sample `j`, channel `c ∈ {r,g,b}`,
//! SH index `i = l(l+1)+m`. Polar samples sit at cell centres
//! `θ_j = (j + ½)/N · π/2`; lookups interpolate linearly in θ_o and clamp at
//! both ends. Truncating a table of order `n` to its first `k²` coefficients is
//! exactly the order-`k` table (orthonormal projection).

use crate::{MAX_SHADING_ORDER, ShLightError, check_shading_order};
use glam::Vec3;
use rayon::prelude::*;
use relight_brdf::Brdf;
use relight_render::Progress;
use relight_sh::quadrature::gauss_legendre;
use std::f64::consts::PI;

/// Resolution of the bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BakeOptions {
    /// Polar-angle samples of `θ_o` over `[0, π/2]` (≥ 2).
    pub theta_samples: usize,
    /// Gauss–Legendre nodes in `cos θ_i` (≥ 4).
    pub mu_nodes: usize,
    /// Azimuth nodes over `[0, π]` (≥ 4).
    pub phi_nodes: usize,
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self {
            theta_samples: 64,
            mu_nodes: 96,
            phi_nodes: 96,
        }
    }
}

impl BakeOptions {
    fn validate(&self) -> Result<(), ShLightError> {
        let bad = |what, why: &str| {
            Err(ShLightError::InvalidParameter {
                what,
                why: why.into(),
            })
        };
        if self.theta_samples < 2 {
            return bad("theta_samples", "need at least 2 polar samples");
        }
        if self.mu_nodes < 4 || self.phi_nodes < 4 {
            return bad(
                "mu_nodes/phi_nodes",
                "need at least 4 quadrature nodes each",
            );
        }
        Ok(())
    }
}

/// The baked transfer table of one BRDF (see the module docs for the layout).
#[derive(Clone, Debug, PartialEq)]
pub struct BrdfShTable {
    order: usize,
    theta_samples: usize,
    coeffs: Vec<f32>,
    /// Rank-1 factorisation `B_c(θ) = ρ_c B̂(θ)` where it holds (every
    /// single-lobe BRDF with a colour: Lambert, Phong, GGX, Ward…): the colour
    /// ρ and `B̂` as `mono[j · n² + i]`. The shader then rotates one vector
    /// per pixel instead of three.
    mono: Option<([f32; 3], Vec<f32>)>,
}

/// Relative tolerance of the rank-1 test: `max |B_c − ρ_c B̂| ≤ MONO_TOL ·
/// max |B̂|` over the whole table (f32 rounding of the bake is ~1e-7).
const MONO_TOL: f32 = 1e-5;

/// `B_c = ρ_c B̂` for the table `coeffs` (layout of the module docs), if it
/// holds: `B̂` is the channel of largest norm, `ρ_c = ⟨B_c, B̂⟩ / ⟨B̂, B̂⟩`.
fn factor_mono(nt: usize, nn: usize, coeffs: &[f32]) -> Option<([f32; 3], Vec<f32>)> {
    let chan = |c: usize| (0..nt).flat_map(move |j| (0..nn).map(move |i| (j * 3 + c) * nn + i));
    let norm2 = |c: usize| chan(c).map(|k| f64::from(coeffs[k]).powi(2)).sum::<f64>();
    let g = (0..3).max_by(|&a, &b| norm2(a).total_cmp(&norm2(b)))?;
    let gg = norm2(g);
    if gg == 0.0 {
        return Some(([0.0; 3], vec![0.0; nt * nn]));
    }
    let mut rho = [0.0f32; 3];
    for (c, r) in rho.iter_mut().enumerate() {
        let dot: f64 = chan(c)
            .zip(chan(g))
            .map(|(a, b)| f64::from(coeffs[a]) * f64::from(coeffs[b]))
            .sum();
        *r = (dot / gg) as f32;
    }
    let scale = chan(g).map(|k| coeffs[k].abs()).fold(0.0f32, f32::max);
    for (c, r) in rho.iter().enumerate() {
        for (a, b) in chan(c).zip(chan(g)) {
            if (coeffs[a] - r * coeffs[b]).abs() > MONO_TOL * scale {
                return None;
            }
        }
    }
    Some((rho, chan(g).map(|k| coeffs[k]).collect()))
}

/// Relative change of `f` under rotations about the normal, over fixed probe
/// pairs (0 for an isotropic BRDF).
#[must_use]
pub fn anisotropy(brdf: &dyn Brdf) -> f32 {
    let dir = |t: f32, p: f32| Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    let mut worst = 0.0f32;
    for (k, &(to, po, ti, pi)) in [
        (0.4f32, 0.3f32, 0.5f32, 2.9f32),
        (1.0, 1.1, 0.9, 4.0),
        (0.7, 2.0, 0.3, 5.5),
        (1.2, 0.0, 1.1, 3.3),
        (0.2, 4.0, 1.3, 0.7),
    ]
    .iter()
    .enumerate()
    {
        let psi = 0.7 + k as f32;
        let a = brdf.eval(dir(to, po), dir(ti, pi));
        let b = brdf.eval(dir(to, po + psi), dir(ti, pi + psi));
        let scale = a.max_element().max(b.max_element());
        if scale > 1e-6 {
            worst = worst.max((a - b).abs().max_element() / scale);
        }
    }
    worst
}

/// The largest [`anisotropy`] an SH table accepts: a model that changes by
/// more under rotation about the normal is not isotropic.
pub const MAX_ANISOTROPY: f32 = 2e-2;

/// `Ok` when `brdf` (object `object`'s) is isotropic within
/// [`MAX_ANISOTROPY`], the condition of [`BrdfShTable::bake`].
///
/// # Errors
/// [`ShLightError::Anisotropic`].
pub fn check_isotropic(brdf: &dyn Brdf, object: usize) -> Result<(), ShLightError> {
    let deviation = anisotropy(brdf);
    if deviation > MAX_ANISOTROPY {
        return Err(ShLightError::Anisotropic {
            object,
            brdf: brdf.label(),
            deviation,
        });
    }
    Ok(())
}

impl BrdfShTable {
    /// Bakes `brdf` to `order` bands.
    ///
    /// # Errors
    /// Order out of `1..=`[`MAX_SHADING_ORDER`], bad options, an anisotropic
    /// BRDF ([`ShLightError::Anisotropic`], `object` = `object_index`), a BRDF
    /// producing NaN, or cancellation.
    pub fn bake(
        brdf: &dyn Brdf,
        order: usize,
        opts: &BakeOptions,
        object_index: usize,
        progress: &dyn Progress,
    ) -> Result<Self, ShLightError> {
        check_shading_order(order)?;
        opts.validate()?;
        check_isotropic(brdf, object_index)?;
        let nn = order * order;
        // Indices with m ≥ 0 (the only non-zero ones in the canonical frame).
        let idx: Vec<usize> = (0..order)
            .flat_map(|l| (0..=l).map(move |m| l * l + l + m))
            .collect();
        // Quadrature points: directions, weights × cos θ_i, and y_i (m ≥ 0).
        let (gx, gw) = gauss_legendre(opts.mu_nodes);
        let mut dirs = Vec::with_capacity(opts.mu_nodes * opts.phi_nodes);
        let mut wts = Vec::with_capacity(dirs.capacity());
        let dphi = PI / opts.phi_nodes as f64;
        for (x, w) in gx.iter().zip(&gw) {
            let mu = 0.5 * (x + 1.0);
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            for k in 0..opts.phi_nodes {
                let phi = (k as f64 + 0.5) * dphi;
                dirs.push([s * phi.cos(), s * phi.sin(), mu]);
                // ½ w (μ-interval), 2 dφ (φ over [0, π] doubled by symmetry), × cos θ_i.
                wts.push(w * dphi * mu);
            }
        }
        let np = dirs.len();
        let ni = idx.len();
        let mut ytab = vec![0.0f32; np * ni];
        {
            let mut y = vec![0.0f64; nn];
            for (p, d) in dirs.iter().enumerate() {
                relight_sh::eval_sh_into(order, *d, &mut y);
                for (k, &i) in idx.iter().enumerate() {
                    ytab[p * ni + k] = y[i] as f32;
                }
            }
        }
        let nt = opts.theta_samples;
        progress.start("sh bake", nt as u64);
        let rows: Result<Vec<Vec<f32>>, ShLightError> = (0..nt)
            .into_par_iter()
            .map(|j| {
                progress.check()?;
                let theta = (j as f64 + 0.5) / nt as f64 * 0.5 * PI;
                let wo = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
                let mut acc = vec![0.0f64; 3 * ni];
                for p in 0..np {
                    let d = dirs[p];
                    let f = brdf.eval(wo, Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
                    if f == Vec3::ZERO {
                        continue;
                    }
                    let w = wts[p];
                    let (r, g, b) = (f64::from(f.x) * w, f64::from(f.y) * w, f64::from(f.z) * w);
                    let yrow = &ytab[p * ni..(p + 1) * ni];
                    for (k, &y) in yrow.iter().enumerate() {
                        let y = f64::from(y);
                        acc[k] += r * y;
                        acc[ni + k] += g * y;
                        acc[2 * ni + k] += b * y;
                    }
                }
                let mut row = vec![0.0f32; 3 * nn];
                for c in 0..3 {
                    for (k, &i) in idx.iter().enumerate() {
                        row[c * nn + i] = acc[c * ni + k] as f32;
                    }
                }
                progress.inc(1);
                Ok(row)
            })
            .collect();
        progress.finish();
        let coeffs: Vec<f32> = rows?.concat();
        relight_sh::check_finite(
            "baked BRDF coefficients (the BRDF returned NaN/inf)",
            &coeffs,
        )?;
        Ok(Self::from_coeffs(order, nt, coeffs))
    }

    /// A table from its raw coefficients (layout of the module docs); the
    /// rank-1 factorisation is found here.
    fn from_coeffs(order: usize, theta_samples: usize, coeffs: Vec<f32>) -> Self {
        let mono = factor_mono(theta_samples, order * order, &coeffs);
        Self {
            order,
            theta_samples,
            coeffs,
            mono,
        }
    }

    /// The same table with band `l` of every transfer vector multiplied by
    /// `h[l]` (a ringing window, [`relight_sh::window`]); bands past the end
    /// of `h` are kept.
    #[must_use]
    pub fn windowed(&self, h: &[f64]) -> Self {
        let nn = self.order * self.order;
        let mut coeffs = self.coeffs.clone();
        for row in coeffs.chunks_exact_mut(nn) {
            for (l, &w) in h.iter().enumerate().take(self.order) {
                for v in &mut row[l * l..(l + 1) * (l + 1)] {
                    *v *= w as f32;
                }
            }
        }
        Self::from_coeffs(self.order, self.theta_samples, coeffs)
    }

    /// The transfer vector of channel `c` at polar sample `j` (all `n²`
    /// coefficients, canonical frame).
    #[must_use]
    pub fn sample(&self, j: usize, c: usize) -> &[f32] {
        let nn = self.order * self.order;
        &self.coeffs[(j * 3 + c) * nn..(j * 3 + c + 1) * nn]
    }

    /// The outgoing polar angle of sample `j` (radians, cell centres of
    /// `[0, π/2]`).
    #[must_use]
    pub fn sample_theta(&self, j: usize) -> f64 {
        (j as f64 + 0.5) / self.theta_samples as f64 * 0.5 * PI
    }

    /// The transfer lobes at `order ≤ self.order()` bands for choosing a
    /// window: every polar sample's `B̂` where the table is rank-1, else
    /// every sample's three channels (each `order²` coefficients).
    #[must_use]
    pub fn lobes(&self, order: usize) -> Vec<Vec<f32>> {
        let (nn, k) = (self.order * self.order, order.min(self.order).pow(2));
        match &self.mono {
            Some((_, m)) => m.chunks_exact(nn).map(|r| r[..k].to_vec()).collect(),
            None => self
                .coeffs
                .chunks_exact(nn)
                .map(|r| r[..k].to_vec())
                .collect(),
        }
    }

    /// The colour ρ of the rank-1 factorisation `B_c = ρ_c B̂`, where the
    /// table has one.
    #[must_use]
    pub fn mono_colour(&self) -> Option<[f32; 3]> {
        self.mono.as_ref().map(|m| m.0)
    }

    /// Interpolation position of `cos θ_o`: lower sample and weight, or
    /// `None` below the horizon (also for NaN).
    #[inline(always)]
    fn locate(&self, cos_theta_o: f32) -> Option<(usize, f32)> {
        if cos_theta_o.is_nan() || cos_theta_o <= 0.0 {
            return None;
        }
        Some(self.locate_theta(cos_theta_o.min(1.0).acos()))
    }

    /// Interpolation position of `θ_o` (radians, clamped to the samples'
    /// range): lower sample and weight.
    #[inline(always)]
    fn locate_theta(&self, theta_o: f32) -> (usize, f32) {
        let nt = self.theta_samples;
        let t =
            (theta_o / std::f32::consts::FRAC_PI_2 * nt as f32 - 0.5).clamp(0.0, (nt - 1) as f32);
        let j0 = (t as usize).min(nt - 2);
        (j0, t - j0 as f32)
    }

    /// `B̂(θ_o)` of the rank-1 factorisation ([`BrdfShTable::mono_colour`]),
    /// truncated to `order` bands into `out[..order²]`; `false` (and `out`
    /// untouched) where the table has no such factorisation. Zero below the
    /// horizon, as [`BrdfShTable::lookup`].
    ///
    /// # Panics
    /// If `order > self.order()` or `out.len() < order²`.
    #[inline]
    pub fn lookup_mono(&self, cos_theta_o: f32, order: usize, out: &mut [f32]) -> bool {
        assert!(
            order <= self.order,
            "lookup order {order} above the baked {}",
            self.order
        );
        let Some((_, m)) = &self.mono else {
            return false;
        };
        let k = order * order;
        let out = &mut out[..k];
        let Some((j0, a)) = self.locate(cos_theta_o) else {
            out.fill(0.0);
            return true;
        };
        let nn = self.order * self.order;
        let (s0, s1) = (
            &m[j0 * nn..j0 * nn + k],
            &m[(j0 + 1) * nn..(j0 + 1) * nn + k],
        );
        for ((o, x), y) in out.iter_mut().zip(s0).zip(s1) {
            *o = x + a * (y - x);
        }
        true
    }

    /// [`BrdfShTable::lookup_mono`] at the polar angle `theta_o` of a view
    /// above the horizon (radians, `[0, π/2)`; the caller has the angle
    /// already, [`crate::shade`]), times the band window `h` (one factor
    /// per coefficient, `order²`), in one pass, for a table that has the
    /// rank-1 factorisation (else `false`, `out` untouched). `F`: fused
    /// multiply-adds (inside a caller compiled for FMA).
    ///
    /// # Panics
    /// As [`BrdfShTable::lookup_mono`], or if `h` is shorter than `order²`.
    #[inline(always)]
    pub(crate) fn lookup_mono_windowed<const F: bool>(
        &self,
        theta_o: f32,
        order: usize,
        h: &[f32],
        out: &mut [f32],
    ) -> bool {
        assert!(
            order <= self.order,
            "lookup order {order} above the baked {}",
            self.order
        );
        let Some((_, m)) = &self.mono else {
            return false;
        };
        let k = order * order;
        let (out, h) = (&mut out[..k], &h[..k]);
        let (j0, a) = self.locate_theta(theta_o);
        let nn = self.order * self.order;
        let (s0, s1) = (
            &m[j0 * nn..j0 * nn + k],
            &m[(j0 + 1) * nn..(j0 + 1) * nn + k],
        );
        for (((o, x), y), w) in out.iter_mut().zip(s0).zip(s1).zip(h) {
            let v = if F {
                a.mul_add(y - x, *x)
            } else {
                x + a * (y - x)
            };
            *o = v * w;
        }
        true
    }

    /// Number of bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Polar samples.
    #[must_use]
    pub fn theta_samples(&self) -> usize {
        self.theta_samples
    }

    /// The raw table (layout in the module docs).
    #[must_use]
    pub fn coeffs(&self) -> &[f32] {
        &self.coeffs
    }

    /// Transfer coefficients for an outgoing direction with `cos θ_o`
    /// in the canonical frame (azimuth 0), truncated to `order ≤ self.order()`
    /// bands: `out[c · order² + i]`. Zero when `cos θ_o ≤ 0` (the view is
    /// below the shading horizon: the BRDF vanishes). Allocation-free.
    ///
    /// # Panics
    /// If `order > self.order()` or `out.len() < 3 order²`.
    #[inline]
    pub fn lookup(&self, cos_theta_o: f32, order: usize, out: &mut [f32]) {
        assert!(
            order <= self.order && order <= MAX_SHADING_ORDER,
            "lookup order {order} above the baked {}",
            self.order
        );
        let k = order * order;
        let out = &mut out[..3 * k];
        let Some((j0, a)) = self.locate(cos_theta_o) else {
            out.fill(0.0);
            return;
        };
        let nn = self.order * self.order;
        let r0 = &self.coeffs[j0 * 3 * nn..(j0 + 1) * 3 * nn];
        let r1 = &self.coeffs[(j0 + 1) * 3 * nn..(j0 + 2) * 3 * nn];
        for c in 0..3 {
            let (s0, s1) = (&r0[c * nn..c * nn + k], &r1[c * nn..c * nn + k]);
            for ((o, x), y) in out[c * k..(c + 1) * k].iter_mut().zip(s0).zip(s1) {
                *o = x + a * (y - x);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_brdf::{Ggx, Lambert, Ward};
    use relight_render::NoProgress;
    use relight_sh::quadrature::SphereQuadrature;

    /// Lambert: B = ρ/π · clamped-cosine zonal coefficients, independent of θ_o.
    #[test]
    fn lambert_bake_is_the_clamped_cosine() {
        let b = Lambert::new(Vec3::new(0.8, 0.5, 0.2)).unwrap();
        let t = BrdfShTable::bake(
            &b,
            5,
            &BakeOptions {
                theta_samples: 4,
                ..Default::default()
            },
            0,
            &NoProgress,
        )
        .unwrap();
        let mut out = vec![0.0; 75];
        t.lookup(0.3, 5, &mut out);
        for l in 0..5 {
            let want = relight_sh::convolve::clamped_cosine_a_hat(l)
                / (4.0 * PI / (2 * l + 1) as f64).sqrt()
                / PI;
            let got = out[l * l + l] as f64 / 0.8;
            assert!(
                (got - want).abs() < 1e-5,
                "l={l}: bake {got} vs Â_l/… {want}"
            );
            for m in 1..=l {
                assert!(out[l * l + l + m].abs() < 1e-6 && out[l * l + l - m] == 0.0);
            }
        }
    }

    /// GGX: the bake matches brute-force product quadrature over the full sphere.
    #[test]
    fn ggx_bake_matches_independent_quadrature() {
        let b = Ggx::isotropic(0.3, Vec3::ONE).unwrap();
        let order = 6;
        let t = BrdfShTable::bake(
            &b,
            order,
            &BakeOptions {
                theta_samples: 3,
                mu_nodes: 64,
                phi_nodes: 64,
            },
            0,
            &NoProgress,
        )
        .unwrap();
        let theta = (1.0 + 0.5) / 3.0 * 0.5 * PI; // sample j = 1, no interpolation
        let wo = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
        let q = SphereQuadrature::new(300, 600);
        let want = relight_sh::project::project_fn(order, &q, |d| {
            if d.z <= 0.0 {
                0.0
            } else {
                f64::from(b.eval(wo, d.as_vec3()).x) * d.z
            }
        });
        let mut out = vec![0.0; 3 * order * order];
        t.lookup(theta.cos() as f32, order, &mut out);
        for i in 0..order * order {
            assert!(
                (f64::from(out[i]) - want[i]).abs() < 2e-3 * want[0].abs(),
                "i={i}: bake {} vs quadrature {}",
                out[i],
                want[i]
            );
        }
    }

    #[test]
    fn anisotropic_and_bad_orders_are_refused() {
        let w = Ward::new(0.05, 0.4, Vec3::ONE).unwrap();
        assert!(matches!(
            BrdfShTable::bake(&w, 3, &BakeOptions::default(), 2, &NoProgress),
            Err(ShLightError::Anisotropic { object: 2, .. })
        ));
        let l = Lambert::new(Vec3::ONE).unwrap();
        assert!(BrdfShTable::bake(&l, 0, &BakeOptions::default(), 0, &NoProgress).is_err());
        assert!(
            BrdfShTable::bake(
                &l,
                MAX_SHADING_ORDER + 1,
                &BakeOptions::default(),
                0,
                &NoProgress
            )
            .is_err()
        );
    }
}
