//! The BRDF library: analytic reflectance models and measured (MERL) data,
//! each with evaluation, importance sampling and its pdf.
//!
//! # Frame and conventions
//! Every function works in the **local shading frame**: the normal is +Z,
//! `wo` (towards the viewer) and `wi` (towards the light) are unit vectors
//! pointing away from the surface. [`Brdf::eval`] returns f(wo, wi) in sr⁻¹
//! **without** the cosine factor; the reflection integral is
//! L_o = ∫ f(wo, wi) L_i(wi) cos θ_i dω_i, with cos θ_i = wi.z supplied by
//! the caller. Directions below the horizon (z ≤ 0) evaluate to zero.
//!
//! **Architecture invariant:** no IO; [`merl::Merl::from_bytes`] parses a
//! buffer that `relight-assets` reads.
//!
//! # Models
//! | model | module | reciprocal | sampling |
//! |---|---|---|---|
//! | [`Lambert`] | [`diffuse`] | yes | cosine hemisphere |
//! | [`OrenNayar`] (qualitative) | [`diffuse`] | yes | cosine hemisphere |
//! | [`Phong`] (normalized, about the mirror direction) | [`phong`] | yes | cosⁿ lobe about the mirror direction |
//! | [`BlinnPhong`] (exactly normalized) | [`phong`] | yes | cosⁿ θ_h half vectors |
//! | [`Ward`] (bounded-albedo, anisotropic) | [`ward`] | yes | Walter's half vectors |
//! | [`Ggx`] (Cook–Torrance, height-correlated Smith, Schlick) | [`microfacet`] | yes | visible normals (Heitz 2018) |
//! | [`AshikhminShirley`] (with its diffuse term) | [`ashikhmin`] | yes | its half vectors + cosine |
//! | [`merl::Merl`] (measured) | [`merl`] | yes | cosine hemisphere |
//! | [`Mix`] (weighted sum) | [`mix`] | if its lobes are | lobe selection, mixture pdf |
//!
//! Every `sample` returns `f = eval(wo, wi)` and `pdf = pdf(wo, wi)` of the
//! returned direction; a sampler that proposes a direction below the
//! horizon returns `None`, so for lobe models ∫ pdf dω over the upper
//! hemisphere equals the acceptance probability (≤ 1) and the estimator
//! f cos θ_i / pdf (0 on `None`) is unbiased. [`spec::BrdfSpec`] parses the
//! one-line syntax (`ggx:0.2@1,0.8,0.6`) and [`verify`] holds the quadrature
//! and Monte Carlo checks used by the tests and `relight verify`.

#![deny(missing_docs)]

pub mod ashikhmin;
pub mod diffuse;
mod error;
pub mod merl;
pub mod microfacet;
pub mod mix;
pub mod model;
pub mod phong;
pub mod sampling;
pub mod spec;
pub mod verify;
pub mod ward;

pub use ashikhmin::AshikhminShirley;
pub use diffuse::{Lambert, OrenNayar};
pub use error::BrdfError;
pub use merl::Merl;
pub use microfacet::Ggx;
pub use mix::Mix;
pub use model::{Brdf, BrdfSample};
pub use phong::{BlinnPhong, Phong};
pub use spec::{BrdfSpec, MixSpec};
pub use ward::Ward;

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn constructors_reject_out_of_range() {
        let w = Vec3::ONE;
        assert!(Lambert::new(Vec3::new(1.1, 0.0, 0.0)).is_err());
        assert!(Lambert::new(Vec3::new(f32::NAN, 0.0, 0.0)).is_err());
        assert!(Phong::new(-0.5, w).is_err());
        assert!(Phong::new(f32::INFINITY, w).is_err());
        assert!(BlinnPhong::new(2e6, w).is_err());
        assert!(Ward::new(0.0, 0.1, w).is_err());
        assert!(Ward::new(0.1, 1.5, w).is_err());
        assert!(Ggx::new(0.1, 0.0, w).is_err());
        assert!(Ggx::isotropic(0.1, Vec3::splat(-0.1)).is_err());
        assert!(AshikhminShirley::new(-1.0, 1.0, w, w).is_err());
        assert!(OrenNayar::new(2.0, w).is_err());
        let e = Ggx::isotropic(2.0, w).unwrap_err().to_string();
        assert_eq!(
            e,
            "ggx BRDF: parameter `alpha_x` = 2 is out of range; expected roughness α in [1e-4, 1]"
        );
        let l: std::sync::Arc<dyn Brdf> = std::sync::Arc::new(Lambert::new(w).unwrap());
        assert!(Mix::new(vec![(0.6, l.clone()), (0.6, l.clone())]).is_err());
        assert!(Mix::new(vec![]).is_err());
        assert!(Mix::new(vec![(0.5, l)]).is_ok());
    }
}
