//! Sampling spherical functions onto the leaves, and the exact solid-angle
//! weighting folded into the BRDF term (spherical-wavelets-triple-product-2006
//! §4.1: "we sample its values at 5120 directions").
//!
//! # Why the BRDF carries the solid angle
//! The counting-measure product is `B = A_L Σ_j L_j V_j ρ̃_j`. The true
//! integral is `Σ_j ∫_{T_j} L V ρ cos⁺ dω ≈ Σ_j L_j V_j ∫_{T_j} ρ cos⁺ dω`
//! with `L_j, V_j` the leaf values. So with [`Weighting::Exact`] the BRDF leaf
//! value is
//!
//! ```text
//! ρ̃_j = (1 / A_L) Σ_{s ∈ T_j} ρ(ω_s) cos⁺θ_s Ω_s       (sr, summed over 4^sub sub-triangles)
//! ```
//!
//! with `Ω_s` the exact spherical areas of the leaf's sub-triangles
//! ([`relight_sphere::icosahedral`]), so `B` is the quadrature of the true
//! integral; the cosine's horizon clip is resolved at the sub-triangles. The
//! paper's unweighted form, [`Weighting::Paper`], treats every leaf as
//! `4π / 20·4^L` sr and samples the leaf centroid:
//! `ρ̃_j = ρ(c_j) cos⁺θ(c_j) · 4π/20`. At level 4 the leaf areas differ by
//! 1.30× (max/min), which the paper form ignores.

use crate::basis::Basis;
use crate::lighting::cell_dir;
use glam::Vec3;
use relight_sphere::icosahedral::Icosahedral;
use serde::Serialize;

/// How the BRDF term takes the leaves' solid angles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// Exact spherical areas (sub-triangle quadrature).
    #[default]
    Exact,
    /// The paper's equal areas, centroid samples.
    Paper,
}

impl Weighting {
    /// The CLI spelling.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Exact => "exact",
            Self::Paper => "paper",
        }
    }
}

/// The leaves of a basis with their centroids, areas and sub-triangle samples.
#[derive(Clone, Debug)]
pub struct LeafGrid {
    basis: Basis,
    sub: usize,
    /// Unit centroid direction of every leaf (leaf order).
    pub centroids: Vec<Vec3>,
    /// Exact solid angle (sr) of every leaf.
    pub areas: Vec<f32>,
    /// `4^sub` sample directions per leaf (leaf-major).
    pub samples: Vec<Vec3>,
    /// Their exact solid angles (sr); each leaf's sum to its area.
    pub sample_areas: Vec<f32>,
}

impl LeafGrid {
    /// The leaves of `basis`, each split `sub` more levels for the BRDF
    /// quadrature (`leaf_level + sub ≤ 7`).
    ///
    /// # Errors
    /// When the hierarchy cannot be that deep (a message naming `sub`).
    pub fn new(basis: Basis, sub: usize) -> Result<Self, String> {
        let l = basis.leaf_level();
        let ico = Icosahedral::new(l + sub).map_err(|e| format!("quadrature sub = {sub}: {e}"))?;
        let to_f32 = |d: glam::DVec3| d.as_vec3();
        let centroids = (0..basis.len())
            .map(|j| to_f32(cell_dir(&ico, l, j)))
            .collect();
        let areas = ico.areas(l).iter().map(|&a| a as f32).collect();
        let fine = l + sub;
        let nfine = Icosahedral::triangle_count(fine);
        let samples = (0..nfine)
            .map(|j| to_f32(cell_dir(&ico, fine, j)))
            .collect();
        let sample_areas = ico.areas(fine).iter().map(|&a| a as f32).collect();
        Ok(Self {
            basis,
            sub,
            centroids,
            areas,
            samples,
            sample_areas,
        })
    }

    /// The basis.
    #[must_use]
    pub fn basis(&self) -> Basis {
        self.basis
    }

    /// Sub-levels of the BRDF quadrature.
    #[must_use]
    pub fn sub(&self) -> usize {
        self.sub
    }

    /// `f` at every leaf centroid (lighting and visibility).
    #[must_use]
    pub fn point_values(&self, f: impl Fn(Vec3) -> f32) -> Vec<f32> {
        self.centroids.iter().map(|&d| f(d)).collect()
    }

    /// The BRDF term `ρ̃_j` of `f(ω) = ρ(ω) cos⁺θ` (local frame, normal +Z;
    /// the caller folds in the cosine) by `weighting` (module docs), into `out`.
    /// `T` is `f32` for one channel or `Vec3` for RGB; `f` is evaluated once
    /// per sample either way.
    ///
    /// # Panics
    /// When `out` is not one value per leaf.
    pub fn brdf_term<T>(&self, f: impl Fn(Vec3) -> T, weighting: Weighting, out: &mut [T])
    where
        T: Copy + std::ops::Mul<f32, Output = T> + std::iter::Sum<T>,
    {
        assert_eq!(out.len(), self.basis.len(), "BRDF term length");
        match weighting {
            Weighting::Exact => {
                let per = 1usize << (2 * self.sub);
                let inv_area = (1.0 / self.basis.leaf_area()) as f32;
                for (j, o) in out.iter_mut().enumerate() {
                    let s = j * per..(j + 1) * per;
                    let sum: T = self.samples[s.clone()]
                        .iter()
                        .zip(&self.sample_areas[s])
                        .map(|(&d, &a)| f(d) * a)
                        .sum();
                    *o = sum * inv_area;
                }
            }
            Weighting::Paper => {
                let scale = 4.0 * std::f32::consts::PI / 20.0;
                for (o, &d) in out.iter_mut().zip(&self.centroids) {
                    *o = f(d) * scale;
                }
            }
        }
    }
}
