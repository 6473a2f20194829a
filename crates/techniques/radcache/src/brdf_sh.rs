//! The BRDF's SH coefficients in the shading frame (Křivánek et al. 2005,
//! §3): for a view at polar angle `θ_o` in the `xz` plane of the point's
//! frame, `ρ_k(θ_o) = ∫_{H⁺} f(ω_o, ω) cos θ y_k(ω) dω`, so that the
//! reflected indirect light is `Σ_k λ_k ρ_k` for incoming radiance
//! `Σ_k λ_k y_k`. Tabulated per BRDF over `θ_o` (linear interpolation), by
//! midpoint quadrature in `(cos θ, φ)`. An isotropic BRDF depends on the view
//! only through `θ_o` once the frame's `x` axis follows the view's azimuth;
//! an anisotropic one is read as if the view lay along the frame's `x`.

use glam::Vec3;
use relight_brdf::Brdf;

/// `θ_o` samples of the table, uniform in `θ_o ∈ [0, π/2]`.
const THETA_BINS: usize = 24;
/// Quadrature cells in `cos θ` and `φ`.
const QUAD_COS: usize = 48;
const QUAD_PHI: usize = 96;

/// One BRDF's coefficient table.
#[derive(Clone, Debug)]
pub struct BrdfSh {
    order: usize,
    /// `THETA_BINS` rows of `order²` RGB coefficients.
    rows: Vec<Vec3>,
}

impl BrdfSh {
    /// Tabulates `brdf` at `order` bands.
    #[must_use]
    pub fn new(brdf: &dyn Brdf, order: usize) -> Self {
        let nn = order * order;
        let mut rows = vec![Vec3::ZERO; THETA_BINS * nn];
        let mut y = vec![0.0f32; nn];
        let cell = (1.0 / QUAD_COS as f32) * (std::f32::consts::TAU / QUAD_PHI as f32);
        for t in 0..THETA_BINS {
            let th = (t as f32 / (THETA_BINS - 1) as f32) * std::f32::consts::FRAC_PI_2;
            let wo = Vec3::new(th.sin(), 0.0, th.cos().max(1e-3)).normalize();
            let row = &mut rows[t * nn..(t + 1) * nn];
            for i in 0..QUAD_COS {
                let c = (i as f32 + 0.5) / QUAD_COS as f32;
                let s = (1.0 - c * c).sqrt();
                for j in 0..QUAD_PHI {
                    let phi = (j as f32 + 0.5) / QUAD_PHI as f32 * std::f32::consts::TAU;
                    let wi = Vec3::new(s * phi.cos(), s * phi.sin(), c);
                    let f = brdf.eval(wo, wi) * (c * cell);
                    if f == Vec3::ZERO {
                        continue;
                    }
                    relight_sh::basis::eval_sh_into(order, wi.to_array(), &mut y);
                    for (r, &yk) in row.iter_mut().zip(&y) {
                        *r += f * yk;
                    }
                }
            }
        }
        Self { order, rows }
    }

    /// Bands.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// `Σ_k ρ_k(θ_o) λ_k` for RGB coefficients `lambda` (channel-major,
    /// `3·order²`) and `cos θ_o` of the view.
    #[must_use]
    pub fn shade(&self, cos_theta_o: f32, lambda: &[f32]) -> Vec3 {
        let nn = self.order * self.order;
        let th = cos_theta_o.clamp(0.0, 1.0).acos();
        let x = th / std::f32::consts::FRAC_PI_2 * (THETA_BINS - 1) as f32;
        let i0 = (x.floor() as usize).min(THETA_BINS - 2);
        let w = (x - i0 as f32).clamp(0.0, 1.0);
        let (a, b) = (
            &self.rows[i0 * nn..(i0 + 1) * nn],
            &self.rows[(i0 + 1) * nn..(i0 + 2) * nn],
        );
        let (lr, lg, lb) = (&lambda[..nn], &lambda[nn..2 * nn], &lambda[2 * nn..3 * nn]);
        let mut out = Vec3::ZERO;
        for k in 0..nn {
            let rho = a[k] * (1.0 - w) + b[k] * w;
            out += rho * Vec3::new(lr[k], lg[k], lb[k]);
        }
        out
    }
}
