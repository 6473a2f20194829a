//! relight-shlight: spherical-harmonic environment-map shading of arbitrary
//! (isotropic) BRDFs, with per-pixel SH rotation for normal mapping.
//!
//! # What
//! The technique of Kautz, Sloan & Snyder 2002 ("Fast, arbitrary BRDF shading
//! for low-frequency lighting using spherical harmonics") as extended by
//! Křivánek, Konttinen, Pattanaik & Bouatouch 2006 ("Fast approximation to
//! spherical harmonic rotation", §4.1, `sh-rotation-taylor-2006.txt`): the
//! unshadowed reflection integral
//!
//! `L_o(x, ω_o) = ∫_{H²(n)} f(ω_o, ω_i) L_env(ω_i) (n·ω_i) dω_i`
//!
//! becomes a dot product of two SH coefficient vectors expressed in the same
//! frame: the lighting `L` and the *transfer* `B(ω_o)` = SH projection of
//! `ω_i ↦ f(ω_o, ω_i) max(cos θ_i, 0)`.
//!
//! # How (data flow)
//! 1. **Bake** ([`bake`], once per BRDF and order): `B(θ_o)` on a grid of
//!    outgoing polar angles, in the canonical local frame (normal = +Z, `ω_o`
//!    in the xz-plane at azimuth 0), by Gauss–Legendre × uniform-φ quadrature
//!    over the hemisphere. For an isotropic BRDF that is all there is: any
//!    other `ω_o` with the same θ_o is reached by an exact O(n²) Z rotation.
//! 2. **Lighting** (once per frame): the environment map projected onto `n`
//!    bands (`relight_sh::project::project_env`, exact texel solid angles).
//! 3. **Per vertex**: the lighting rotated into the vertex's local frame
//!    (exact Ivanic–Ruedenberg matrix) and handed to the rasterizer as vertex
//!    attributes — step 1 of the paper's algorithm.
//! 4. **Per pixel** ([`relight`]): the interpolated vertex frame `F_v`, the
//!    normal-mapped frame `F_p`; `B(θ_o)` looked up for the view direction in
//!    `F_p`, turned about z to the view azimuth, rotated from `F_p` to `F_v` with
//!    the chosen [`ShRotationMethod`] and dotted with the interpolated lighting
//!    (paper §4.1, steps 2–5). `none` skips the rotation: the paper's
//!    "simplified normal mapping" baseline.
//!
//! # Ringing
//! A glossy lobe truncated to `n` bands rings below zero (Gibbs), and under a
//! bright light a negative lobe gives negative radiance (black blotches, 11 K
//! negative pixels in the default scene at order 6 without a window). Each
//! BRDF's transfer is therefore windowed band by band ([`WindowChoice`],
//! `--window`, default `auto`): where any of its lobes `B(θ_o)` would go
//! negative, Sloan's deringing picks the band factors that keep every lobe
//! non-negative with the least L2 change (`relight_sh::window`). Since the
//! lighting is non-negative and exact rotations and barycentric blends keep
//! a non-negative lobe non-negative, no pixel is then negative (up to the
//! Taylor rotations' own error). The cost is blur: a lobe narrower than `n`
//! bands can hold (GGX α = 0.2 at order 6 changes by ~50 %) loses its peak;
//! [`ShMethod::windows`] reports the change per object, and
//! `relight verify sh` has rows with and without the window.
//!
//! # Entry points
//! * [`ShMethod`] (`sh`): the method interface
//!   (`relight_render::method::Relighter`) — bake once in `prepare`, rotate the
//!   lighting in the SH domain in `set_lighting`, shade per pixel with each
//!   object's own normal map in `render`; defaults in [`ShOptions`].
//! * [`ShRenderer::render`]: one whole frame at once (bake lookups, lighting,
//!   raster, shading), with one normal map for every object and the optional
//!   [`LightingFilter`] (the foggy environment).
//!
//! # Conventions
//! SH as in `relight-sh` (real, orthonormal, Condon–Shortley phase, index
//! `l(l+1)+m`, polar axis +Z of whatever frame the coefficients live in;
//! order `n` = number of bands). World frame +Y up (the env map's frame).
//! Radiance in the env map's units; the output image is linear RGB radiance.
//!
//! # Limitations (checked, typed errors)
//! * Isotropic BRDFs only: [`bake::BrdfShTable::bake`] tests `f` for
//!   invariance under rotations about the normal and refuses anisotropic
//!   models (e.g. anisotropic Ward) with [`ShLightError::Anisotropic`].
//! * No visibility (unshadowed), no interreflection — the same integral the
//!   reference renderer computes with visibility off.
//! * Normal maps need per-vertex uvs and tangents ([`ShLightError::MissingUvs`]).

pub mod bake;
pub mod bench;
mod filter;
pub mod lit_scene;
pub mod method;
pub mod relight;
mod shade;
pub mod verify;

pub use bake::{BakeOptions, BrdfShTable};
pub use bench::{
    FRAME_TARGETS, ShFrameBenchRow, ShRenderBenchRow, bench_sh_frames, bench_sh_render,
};
pub use lit_scene::LitScene;
pub use method::{SH_METHOD_NAME, ShMethod, ShOptions};
pub use relight::{
    Background, LightingFilter, ShImage, ShRenderer, ShRotationMethod, check_objects,
};
pub use relight_render::NormalMap;
pub use relight_sh::window::{ChosenWindow, WindowChoice};
pub use verify::{ShVerifyRow, VerifyOptions, VerifyScene, verify_sh};

use relight_render::raster::RasterError;
use relight_render::reference::ReferenceError;
use relight_render::{Cancelled, Numbered};
use relight_sh::ShError;

/// Largest SH order (bands) the renderer accepts: per-pixel buffers live on
/// the stack (`n² ≤ 256`), and a glossy BRDF bake beyond 16 bands is not
/// what SH shading is for (use the wavelet technique).
pub const MAX_SHADING_ORDER: usize = 16;

/// Errors of SH shading. Every message names the input and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum ShLightError {
    /// From the SH toolkit (order out of range, NaN coefficients, …).
    #[error(transparent)]
    Sh(#[from] ShError),
    /// From the rasterizer (image size, camera, indices).
    #[error(transparent)]
    Raster(#[from] RasterError),
    /// From the reference renderer (verify only).
    #[error(transparent)]
    Reference(#[from] ReferenceError),
    /// Ctrl-C: nothing was produced.
    #[error("SH rendering cancelled")]
    Cancelled,
    /// A normal map was given but an object has no uvs or tangents.
    #[error(
        "{}: a normal map needs per-vertex uvs and tangents, but the mesh has {uvs} uvs and {tangents} tangents for {vertices} vertices; load a mesh with texture coordinates (tangents are computed from them) or render without --normal-map",
        Numbered::object(*.object)
    )]
    MissingUvs {
        object: usize,
        uvs: usize,
        tangents: usize,
        vertices: usize,
    },
    /// A mesh without one unit normal per vertex.
    #[error(
        "{}: the mesh has {normals} normals for {vertices} vertices; repair it (relight-geom `validate_and_repair`) first",
        Numbered::object(*.object)
    )]
    MissingNormals {
        object: usize,
        normals: usize,
        vertices: usize,
    },
    /// The BRDF is not invariant under rotation about the normal.
    #[error(
        "{}: its BRDF {brdf} is anisotropic (f changes by {deviation:.3} relative under rotation about the normal); SH shading bakes isotropic BRDFs only — use the reference or wavelet method",
        Numbered::object(*.object)
    )]
    Anisotropic {
        object: usize,
        /// The BRDF's `Brdf::label`.
        brdf: String,
        deviation: f32,
    },
    /// A malformed normal map.
    #[error("normal map: {0}")]
    NormalMap(#[from] relight_render::TextureError),
    /// Any other invalid parameter.
    #[error("invalid parameter `{what}`: {why}")]
    InvalidParameter { what: &'static str, why: String },
}

impl From<Cancelled> for ShLightError {
    fn from(_: Cancelled) -> Self {
        Self::Cancelled
    }
}

/// Checks `1 ≤ order ≤` [`MAX_SHADING_ORDER`].
pub fn check_shading_order(order: usize) -> Result<(), ShLightError> {
    relight_sh::check_order("--order (SH shading)", order, MAX_SHADING_ORDER)
        .map_err(ShLightError::from)
}

// Re-exports for `relight sh project` / `relight sh irradiance`: the CLI can
// call these without depending on relight-sh directly.
pub use relight_sh::convolve::{IrradianceQuadratic, irradiance};
pub use relight_sh::project::{ShRgb, Window, project_env, reconstruct};

/// The irradiance environment map of Ramamoorthi & Hanrahan 2001 for
/// `relight sh irradiance`: the 9 irradiance coefficients `E_{l,m} = Â_l L_{l,m}`
/// (order 3, same convention as [`project_env`]) and the irradiance `E(n)`
/// evaluated at every texel direction of `param` (e.g. a lat-long map),
/// in W·m⁻² when the map holds radiance. Divide by π for the radiance of a
/// white Lambertian surface.
///
/// # Errors
/// NaN/inf texels ([`ShError::NonFinite`]).
pub fn irradiance_map(
    env: &relight_sphere::EnvMap,
    param: relight_sphere::Param,
) -> Result<(ShRgb, relight_sphere::EnvMap), ShLightError> {
    let light = project_env(env, 3, Window::None)?;
    let e = irradiance(&light)?;
    let map = reconstruct(&e, param);
    Ok((e, map))
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_sphere::{EnvMap, Param};

    /// Constant radiance 1: irradiance π for every normal (∫ cos = π), and the
    /// 9 coefficients are E₀₀ = Â₀ L₀₀ = π √(4π). (Texel-centre projection of the
    /// 32-row map leaks ~5e-4 relative into band 2, hence the tolerance.)
    #[test]
    fn irradiance_of_constant_sky_is_pi() {
        let env = EnvMap::from_fn(
            Param::LatLong {
                width: 64,
                height: 32,
            },
            |_| glam::Vec3::ONE,
        );
        let (e, map) = irradiance_map(
            &env,
            Param::LatLong {
                width: 16,
                height: 8,
            },
        )
        .unwrap();
        assert_eq!(e.order, 3);
        let want0 = std::f64::consts::PI * (4.0 * std::f64::consts::PI).sqrt();
        assert!(
            (f64::from(e.channels[0][0]) - want0).abs() < 1e-3 * want0,
            "E00 {} vs {want0}",
            e.channels[0][0]
        );
        for t in &map.texels {
            assert!(
                (t.x - std::f32::consts::PI).abs() < 2e-3 * std::f32::consts::PI,
                "E = {} vs π",
                t.x
            );
        }
    }
}
