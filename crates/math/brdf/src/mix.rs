//! [`Mix`]: a weighted sum of BRDFs, e.g. a diffuse base plus a glossy lobe.
//!
//! f = Σ w_k f_k with w_k ≥ 0 and Σ w_k ≤ 1, so a mix of energy-conserving
//! lobes conserves energy. Sampling picks lobe k with probability w_k / Σ w
//! (reusing u_x), then returns the **whole** mixture's f and the mixture
//! density p = Σ (w_k/Σw) p_k (one-sample MIS with the balance heuristic).

use crate::{Brdf, BrdfError, BrdfSample};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// A weighted sum of BRDFs (module docs).
#[derive(Clone, Debug)]
pub struct Mix {
    weights: Vec<f32>,
    lobes: Vec<Arc<dyn Brdf>>,
    total: f32,
}

impl Mix {
    /// Mixes `lobes` with weights each in [0, 1], summing to (0, 1]
    /// (tolerance 10⁻⁶).
    pub fn new(lobes: Vec<(f32, Arc<dyn Brdf>)>) -> Result<Self, BrdfError> {
        check_weights(lobes.iter().map(|l| l.0))?;
        Ok(Self::from_checked(lobes))
    }

    pub(crate) fn from_checked(lobes: Vec<(f32, Arc<dyn Brdf>)>) -> Self {
        let (weights, lobes): (Vec<f32>, Vec<_>) = lobes.into_iter().unzip();
        let total = weights.iter().sum();
        Self {
            weights,
            lobes,
            total,
        }
    }

    /// The weights w_k.
    #[must_use]
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }
}

/// Validates mixture weights (shared with the spec parser).
pub(crate) fn check_weights(weights: impl Iterator<Item = f32>) -> Result<(), BrdfError> {
    let mut sum = 0.0;
    let mut n = 0;
    for w in weights {
        crate::error::check_range("mix", "weight", w, 0.0, 1.0, "each weight finite in [0, 1]")?;
        sum += w;
        n += 1;
    }
    if n == 0 || sum <= 0.0 || sum > 1.0 + 1e-6 {
        return Err(BrdfError::OutOfRange {
            model: "mix",
            param: "sum of weights",
            value: sum,
            expected: "at least one lobe and a total in (0, 1]",
        });
    }
    Ok(())
}

impl Brdf for Mix {
    /// `W*LABEL+W*LABEL…`, the spec syntax of a mixture.
    fn label(&self) -> String {
        let terms: Vec<String> = self
            .weights
            .iter()
            .zip(&self.lobes)
            .map(|(w, l)| format!("{w}*{}", l.label()))
            .collect();
        terms.join("+")
    }
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.weights
            .iter()
            .zip(&self.lobes)
            .map(|(w, l)| *w * l.eval(wo, wi))
            .sum()
    }
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BrdfSample> {
        let mut x = u.x * self.total;
        let last = self.weights.iter().rposition(|w| *w > 0.0)?;
        for (k, (w, l)) in self.weights.iter().zip(&self.lobes).enumerate() {
            if *w <= 0.0 {
                continue;
            }
            if x < *w || k == last {
                let ux = (x / w).clamp(0.0, 1.0 - f32::EPSILON);
                let s = l.sample(wo, Vec2::new(ux, u.y))?;
                return BrdfSample::at(self, wo, s.wi);
            }
            x -= w;
        }
        None
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.weights
            .iter()
            .zip(&self.lobes)
            .map(|(w, l)| *w * l.pdf(wo, wi))
            .sum::<f32>()
            / self.total
    }
}
