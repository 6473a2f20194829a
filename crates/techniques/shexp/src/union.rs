//! Ground truths of the accumulation: the exact SH projection of the
//! visibility of a union of caps, `∫ Π_i g_i(s) y(s) ds`, by a dense product
//! quadrature of the indicator (the step converges slowly, so the rule is
//! large: degree [`UNION_QUADRATURE_DEGREE`]).

use relight_sh::eval_sh_into;
use relight_sh::quadrature::SphereQuadrature;

/// Degree of the quadrature of [`UnionProjector`].
pub const UNION_QUADRATURE_DEGREE: usize = 400;

/// A cap: unit axis and half-angle (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cap {
    pub axis: [f64; 3],
    pub theta: f64,
}

/// A reusable quadrature rule with its basis values.
#[derive(Clone, Debug)]
pub struct UnionProjector {
    order: usize,
    dirs: Vec<[f64; 3]>,
    weights: Vec<f64>,
    /// `dirs.len() × order²` basis values.
    y: Vec<f64>,
}

impl UnionProjector {
    /// For `order` bands with a rule of `degree`.
    #[must_use]
    pub fn new(order: usize, degree: usize) -> Self {
        let q = SphereQuadrature::for_degree(degree);
        let nn = order * order;
        let dirs: Vec<[f64; 3]> = q.dirs.iter().map(|d| d.to_array()).collect();
        let mut y = vec![0.0; dirs.len() * nn];
        for (d, yy) in dirs.iter().zip(y.chunks_mut(nn)) {
            eval_sh_into(order, *d, yy);
        }
        Self {
            order,
            dirs,
            weights: q.weights.clone(),
            y,
        }
    }

    /// `∫ vis(s) y(s) ds` where `vis` is 0 inside any cap, 1 elsewhere.
    #[must_use]
    pub fn project(&self, caps: &[Cap]) -> Vec<f64> {
        let nn = self.order * self.order;
        let cos: Vec<f64> = caps.iter().map(|c| c.theta.cos()).collect();
        let mut out = vec![0.0; nn];
        for (k, d) in self.dirs.iter().enumerate() {
            let blocked = caps
                .iter()
                .zip(&cos)
                .any(|(c, &ct)| c.axis[0] * d[0] + c.axis[1] * d[1] + c.axis[2] * d[2] >= ct);
            if blocked {
                continue;
            }
            let w = self.weights[k];
            for (o, y) in out.iter_mut().zip(&self.y[k * nn..(k + 1) * nn]) {
                *o += w * y;
            }
        }
        out
    }
}
