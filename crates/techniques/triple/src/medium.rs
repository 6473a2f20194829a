//! Shadowed all-frequency rendering in a homogeneous medium
//! (sun-thesis-2008 §3.6.5): the triple product fed with the environment
//! convolved by the fog chapter's airlight point-spread function.
//!
//! # The model
//! The thesis' environment model (§3.6.4, eqs. 3.35–3.37; the fog method's
//! `ENVIRONMENT_APPROXIMATION`, restated): every surface point is lit as the
//! fog ball's centre is, by sources at distance R through optical thickness
//! T = β·R. The light arriving there from direction ω is
//!
//!   L′(ω) = e^{−T} L(ω) + a·(PSF_T ⊛ L)(ω),
//!
//! the attenuated environment plus the single-scattered glow (albedo `a`).
//! §3.6.5's point is that L′ is still an environment map, so the triple
//! product shades it with visibility and any BRDF, all-frequency: the
//! attenuated part keeps every detail of L, and only the scattered part is
//! smooth. The surface radiance `L_s` then crosses the view segment of
//! length D (the fog method's eq. 3.29 form for the environment):
//!
//!   L = e^{−βD} L_s + (1 − e^{−βD})·a·e^{−T}·L̄,   L̄ = (1/4π)∫L dω,
//!
//! and a pixel that sees no object shows the environment through the
//! medium between the eye and the ball's edge: optical thickness
//! T_d = β·t_out along its ray d (not T: the eye is not at the centre),
//!
//!   L(d) = e^{−T_d} L(d) + a·(PSF_{T_d} ⊛ L)(d),
//!
//! with the scattered part rescaled from T to T_d by the PSF's amplitude
//! T e^{−T} (the empirical factorisation of eq. 3.32, PSF_T ≈ T e^{−T} NPSF;
//! [`FoggyLighting::background`]). Against the single-scattering reference
//! on a sphere in a ball of T = 1 seen from 0.58 R off centre, the
//! centre's form put the sky 16 % too bright on average.
//!
//! # How L′ is built
//! * The scattered part in SH ([`PSF_ORDER`] bands): the zonal multipliers
//!   √(4π/(2l+1))·PSF_l of the *exact* PSF_T (eq. 3.30, not the empirical
//!   factorisation of eq. 3.32; `relight_fog::psf::convolution_weights`),
//!   times a Hanning window over the bands, since PSF_T's 1/γ forward peak
//!   makes the truncated series ring. The window keeps band 0, so the
//!   scattered energy is exact; its only cost is a softer glow core.
//!   The reconstruction is tabulated on a [`SCATTER_WIDTH`]-wide lat-long
//!   map in the environment's frame; what ringing the window leaves below
//!   zero is clamped (its size is kept in [`FoggyLighting::clamped`]).
//! * The attenuated part is the environment itself: the lighting table is
//!   built from `e^{−T}·pre + scattered` on the prefiltered map's texels
//!   ([`FoggyLighting::fog_map`]), so a lighting rotation stays a lookup.
//!
//! Not modelled (the fog method's limits, measured by `verify triple`
//! against the reference): light shafts (the medium's own shadowing of the
//! in-scattered light), multiple scattering, and positions away from the
//! ball's centre.

use glam::Vec3;
use relight_render::Medium;
use relight_sh::ShError;
use relight_sh::project::{Window, project_env};
use relight_sphere::{EnvMap, Param};

/// SH bands of the scattered part.
pub const PSF_ORDER: usize = 16;

/// Columns of the tabulated scattered part (rows: half).
pub const SCATTER_WIDTH: usize = 128;

/// The lighting of one environment in one medium (module docs).
#[derive(Clone, Debug)]
pub struct FoggyLighting {
    /// e^{−T}, T = β·R.
    pub direct: f32,
    /// a·(PSF_T ⊛ L), in the environment's frame, clamped at 0.
    pub scattered: EnvMap,
    /// a·e^{−T}·L̄: what a fully foggy view segment shows.
    pub airlight: Vec3,
    /// The medium.
    pub medium: Medium,
    /// The most negative scattered value clamped, relative to the largest
    /// scattered value (0 when nothing was clamped).
    pub clamped: f32,
}

impl FoggyLighting {
    /// The foggy lighting of `env` (in its own frame) in `medium`.
    ///
    /// # Errors
    /// The projection's (non-finite texels).
    pub fn new(env: &EnvMap, medium: &Medium) -> Result<Self, ShError> {
        let t = medium.env_thickness();
        let direct = (-t).exp();
        let mean = env.integral() / (4.0 * std::f32::consts::PI);
        let airlight = mean * (medium.albedo * direct);
        let mut sh = project_env(env, PSF_ORDER, Window::None)?;
        let weights = relight_fog::psf::convolution_weights(f64::from(t), PSF_ORDER, false);
        let window = Window::Hanning {
            width: PSF_ORDER as f64,
        };
        for ch in &mut sh.channels {
            for (i, c) in ch.iter_mut().enumerate() {
                let l = (i as f64).sqrt() as usize;
                *c *= (f64::from(medium.albedo) * weights[l] * window.factor(l)) as f32;
            }
        }
        let param = Param::LatLong {
            width: SCATTER_WIDTH,
            height: SCATTER_WIDTH / 2,
        };
        let raw = EnvMap::from_fn(param, |d| sh.eval(d));
        let peak = raw
            .texels
            .iter()
            .fold(0.0f32, |m, v| m.max(v.max_element()));
        let low = raw
            .texels
            .iter()
            .fold(0.0f32, |m, v| m.min(v.min_element()));
        let scattered = EnvMap {
            param,
            texels: raw.texels.iter().map(|v| v.max(Vec3::ZERO)).collect(),
        };
        Ok(Self {
            direct,
            scattered,
            airlight,
            medium: *medium,
            clamped: if peak > 0.0 { -low / peak } else { 0.0 },
        })
    }

    /// L′ on the texels of `pre` (the prefiltered environment, same frame):
    /// `e^{−T}·pre + scattered`.
    #[must_use]
    pub fn fog_map(&self, pre: &EnvMap) -> EnvMap {
        EnvMap {
            param: pre.param,
            texels: pre
                .texels
                .iter()
                .enumerate()
                .map(|(i, v)| *v * self.direct + self.scattered.eval(pre.param.dir_from_texel(i)))
                .collect(),
        }
    }

    /// What a pixel that sees no object shows: the ray from `eye` along
    /// `d` (unit, world frame; `d_env` the same direction in the
    /// environment's frame) leaves the ball after `t_out`, and the
    /// environment's full detail is attenuated by e^{−β t_out}, its glow
    /// rescaled to that thickness (module docs).
    #[must_use]
    pub fn background(&self, env: &EnvMap, eye: Vec3, d: Vec3, d_env: Vec3) -> Vec3 {
        let t = self.medium.env_thickness();
        let t_d = self
            .medium
            .ball_span(eye, d)
            .map_or(0.0, |(_, t_out)| self.medium.beta * t_out);
        let amplitude = |x: f32| x * (-x).exp();
        let glow = if t > 0.0 {
            amplitude(t_d) / amplitude(t)
        } else {
            0.0
        };
        env.eval(d_env) * (-t_d).exp() + self.scattered.eval(d_env) * glow
    }

    /// Surface radiance `surface` seen across a view segment of `distance`
    /// scene units.
    #[must_use]
    pub fn segment(&self, surface: Vec3, distance: f32) -> Vec3 {
        let f = (-self.medium.beta * distance).exp();
        surface * f + self.airlight * (1.0 - f)
    }
}
