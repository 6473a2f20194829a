//! relight-methods: the registry of rendering methods.
//!
//! Every method implements [`relight_render::method::Relighter`] in its own
//! crate — the Monte Carlo reference in `relight-render`, SH shading in
//! `relight-shlight`, wavelet shading in `relight-wavelet`, analytic fog in
//! `relight-fog` — with an options type whose `Default` holds its defaults.
//! This crate is the one place that knows them all: [`MethodKind`] names
//! them, [`MethodOptions`] carries one method's options, and [`create`] builds
//! the method behind the interface. The CLI, the viewer and `verify methods`
//! ([`verify`]) reach the methods only through here.
//!
//! The registry holds no defaults of its own: `MethodOptions::default_for`
//! takes each method's `Default`.

pub mod verify;

use relight_fog::{FogOptions, FogRelighter};
use relight_ltc::{LtcMethod, LtcOptions};
use relight_ndf::{NdfMethod, NdfOptions};
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_radcache::{RadianceCacheOptions, RadianceCacheRelighter};
use relight_render::method::{MethodError, Relighter, SceneFeature, Support};
use relight_render::reference::{ReferenceOptions, ReferenceRenderer};
use relight_shexp::{ShExpMethod, ShExpOptions};
use relight_shlight::{ShMethod, ShOptions};
use relight_triple::{TripleMethod, TripleOptions};
use relight_wavelet::{WaveletMethod, WaveletOptions};
use serde::Serialize;

/// The rendering methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodKind {
    /// Monte Carlo ground truth: renders every scene feature.
    Reference,
    /// Spherical-harmonics environment shading with per-pixel rotation.
    Sh,
    /// Haar wavelets on octahedral maps with precomputed rotation matrices.
    Wavelet,
    /// Analytic single-scattering fog with point lights and a foggy environment.
    Fog,
    /// Soft shadows of dynamic sphere-set blockers by SH exponentiation.
    ShExp,
    /// Radiance caching: GI reference direct light plus indirect light
    /// interpolated from rotation-aligned SH records.
    RadianceCache,
    /// Normal-map filtering: SH / vMF normal distributions per MIP texel.
    Ndf,
    /// Triple product of lighting, visibility and BRDF in spherical wavelets, local frames.
    Triple,
    /// Near-field textured area light by affine wavelet products (per vertex).
    Nearfield,
    /// Rectangular area lights by linearly transformed cosines (per pixel; no shadows, textures by their mean).
    Ltc,
}

impl MethodKind {
    /// Every method, the reference first.
    pub const ALL: [MethodKind; 10] = [
        Self::Reference,
        Self::Sh,
        Self::Wavelet,
        Self::Fog,
        Self::ShExp,
        Self::RadianceCache,
        Self::Ndf,
        Self::Triple,
        Self::Nearfield,
        Self::Ltc,
    ];

    /// The name on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Reference => "reference",
            Self::Sh => "sh",
            Self::Wavelet => "wavelet",
            Self::Fog => "fog",
            Self::ShExp => "shexp",
            Self::RadianceCache => "radiance-cache",
            Self::Ndf => "ndf",
            Self::Triple => "triple",
            Self::Nearfield => "nearfield",
            Self::Ltc => "ltc",
        }
    }
}

impl std::fmt::Display for MethodKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for MethodKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
                format!("unknown method `{s}` (known: {})", names.join(", "))
            })
    }
}

/// One method's options.
#[derive(Clone, Debug)]
pub enum MethodOptions {
    Reference(ReferenceOptions),
    Sh(ShOptions),
    Wavelet(WaveletOptions),
    Fog(FogOptions),
    ShExp(ShExpOptions),
    RadianceCache(RadianceCacheOptions),
    Ndf(NdfOptions),
    Triple(TripleOptions),
    Nearfield(NearfieldOptions),
    Ltc(LtcOptions),
}

impl MethodOptions {
    /// The defaults of `kind` (its options type's `Default`).
    #[must_use]
    pub fn default_for(kind: MethodKind) -> Self {
        match kind {
            MethodKind::Reference => Self::Reference(ReferenceOptions::default()),
            MethodKind::Sh => Self::Sh(ShOptions::default()),
            MethodKind::Wavelet => Self::Wavelet(WaveletOptions::default()),
            MethodKind::Fog => Self::Fog(FogOptions::default()),
            MethodKind::ShExp => Self::ShExp(ShExpOptions::default()),
            MethodKind::RadianceCache => Self::RadianceCache(RadianceCacheOptions::default()),
            MethodKind::Ndf => Self::Ndf(NdfOptions::default()),
            MethodKind::Triple => Self::Triple(TripleOptions::default()),
            MethodKind::Nearfield => Self::Nearfield(NearfieldOptions::default()),
            MethodKind::Ltc => Self::Ltc(LtcOptions::default()),
        }
    }

    /// Which method these options are for.
    #[must_use]
    pub fn kind(&self) -> MethodKind {
        match self {
            Self::Reference(_) => MethodKind::Reference,
            Self::Sh(_) => MethodKind::Sh,
            Self::Wavelet(_) => MethodKind::Wavelet,
            Self::Fog(_) => MethodKind::Fog,
            Self::ShExp(_) => MethodKind::ShExp,
            Self::RadianceCache(_) => MethodKind::RadianceCache,
            Self::Ndf(_) => MethodKind::Ndf,
            Self::Triple(_) => MethodKind::Triple,
            Self::Nearfield(_) => MethodKind::Nearfield,
            Self::Ltc(_) => MethodKind::Ltc,
        }
    }
}

/// Builds the method `options` are for, behind the interface.
///
/// # Errors
/// Out-of-range options ([`MethodError::InvalidOption`], naming the method).
pub fn create(options: &MethodOptions) -> Result<Box<dyn Relighter>, MethodError> {
    Ok(match options {
        MethodOptions::Reference(o) => Box::new(ReferenceRenderer::new(*o)),
        MethodOptions::Sh(o) => Box::new(ShMethod::new(*o)?),
        MethodOptions::Wavelet(o) => Box::new(WaveletMethod::new(o.clone())?),
        MethodOptions::Fog(o) => Box::new(FogRelighter::new(*o)?),
        MethodOptions::ShExp(o) => Box::new(ShExpMethod::new(*o)?),
        MethodOptions::RadianceCache(o) => Box::new(RadianceCacheRelighter::new(*o)?),
        MethodOptions::Ndf(o) => Box::new(NdfMethod::new(*o)?),
        MethodOptions::Triple(o) => Box::new(TripleMethod::new(o.clone())?),
        MethodOptions::Nearfield(o) => Box::new(NearfieldMethod::new(o.clone())?),
        MethodOptions::Ltc(o) => Box::new(LtcMethod::new(*o)?),
    })
}

/// What each method renders, feature by feature: `(method, feature, support)`
/// for every pair (with default options), for help texts and docs.
#[must_use]
pub fn support_table() -> Vec<(MethodKind, SceneFeature, Support)> {
    let mut rows = Vec::new();
    for kind in MethodKind::ALL {
        let m = create(&MethodOptions::default_for(kind)).expect("default options are valid");
        for f in SceneFeature::ALL {
            rows.push((kind, f, m.supports(f)));
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_the_reference_renders_everything() {
        for k in MethodKind::ALL {
            assert_eq!(k.name().parse::<MethodKind>().unwrap(), k);
            assert_eq!(MethodOptions::default_for(k).kind(), k);
            assert_eq!(
                create(&MethodOptions::default_for(k)).unwrap().name(),
                k.name()
            );
        }
        assert!(
            "spere"
                .parse::<MethodKind>()
                .unwrap_err()
                .contains("known: reference")
        );
        for (k, f, s) in support_table() {
            if k == MethodKind::Reference {
                assert_eq!(s, Support::Full, "reference must render {f}");
            }
        }
    }

    /// A moving scene is prepared whole for a method that follows motion and
    /// posed for one that does not; a static scene is passed as it is.
    #[test]
    fn posed_for_poses_a_moving_scene_only_for_methods_that_do_not_follow_it() {
        use relight_render::method::{check_scene, posed_for};
        use std::borrow::Cow;
        let still = relight_scene::default_scene(8, 8);
        let mut moving = still.clone();
        let key = |time: f32, x: f32| relight_render::Keyframe {
            time,
            translate: glam::Vec3::new(x, 0.0, 0.0),
            rotation: glam::Quat::IDENTITY,
            scale: 1.0,
        };
        moving.objects[1].animation = Some(std::sync::Arc::new(
            relight_render::Animation::try_new(vec![key(0.0, 0.0), key(1.0, 1.0)]).unwrap(),
        ));
        let shexp = create(&MethodOptions::default_for(MethodKind::ShExp)).unwrap();
        let sh = create(&MethodOptions::default_for(MethodKind::Sh)).unwrap();
        assert!(matches!(
            posed_for(sh.as_ref(), &still, 0.5),
            Cow::Borrowed(_)
        ));
        assert!(
            matches!(posed_for(shexp.as_ref(), &moving, 0.5), Cow::Borrowed(s) if s.is_animated())
        );
        let posed = posed_for(sh.as_ref(), &moving, 0.5);
        assert!(!posed.is_animated());
        let (a, b) = (&still.objects[1].mesh, &posed.objects[1].mesh);
        assert!((b.positions[0] - a.positions[0] - glam::Vec3::new(0.5, 0.0, 0.0)).length() < 1e-5);
        // Only a method that follows motion accepts the moving scene itself.
        assert!(check_scene(shexp.as_ref(), &moving, false).is_ok());
        let e = check_scene(sh.as_ref(), &moving, false)
            .unwrap_err()
            .to_string();
        assert_eq!(e, "method sh cannot render animation (moving objects)");
    }
}
