//! Shadowed all-frequency rendering in a homogeneous medium
//! (sun-thesis-2008 §3.6.5): the triple product fed with the environment
//! convolved by the fog chapter's airlight point-spread function.
//!
//! # The model
//! The thesis' environment model (§3.6.4, eqs. 3.35–3.37; the fog method's
//! `ENVIRONMENT_APPROXIMATION`, restated): every surface point is lit as the
//! fog ball's centre is, through optical thickness T = β·R. The light
//! arriving there from direction ω is
//!
//!   L′(ω) = e^{−T} L(ω) + a·(K_T ⊛ L)(ω),
//!
//! the attenuated environment plus the single-scattered glow (albedo `a`,
//! K_T the ball's kernel below, where the thesis has its PSF_T).
//! §3.6.5's point is that L′ is still an environment map, so the triple
//! product shades it with visibility and any BRDF, all-frequency: the
//! attenuated part keeps every detail of L, and only the scattered part is
//! smooth. The surface radiance `L_s` at `t_s` along a view ray then
//! crosses the ray's segment in the ball (the fog method's eq. 3.29 form
//! for the environment):
//!
//!   L = e^{−βD} L_s + s·a·L̄·G_c,   L̄ = (1/4π)∫L dω,
//!
//! D the segment's length, s its share of a uniform sky's scattering
//! against G_c, the centre's view to the edge (s·G_c = (1 − e^{−βD}) e^{−T}
//! if every point were lit as the centre), and L_s scaled by the surface's
//! factor for its place in the ball (the fog crate's `BallIrradiance`:
//! exact for a Lambertian surface under a uniform sky). A pixel that sees no object
//! shows the environment through its ray's chord, of optical thickness
//! T_d = β·(t_out − t_in) (not T: the eye is not at the centre, and may be
//! outside the ball),
//!
//!   L(d) = e^{−T_d} L(d) + g·a·(K_T ⊛ L)(d).
//!
//! The glow weight g and the share s come from the fog crate's chord table
//! (`relight_fog::view_segment::ChordGlow`, exact for a uniform sky from
//! any eye). Against the single-scattering reference on a sphere in a ball
//! of T = 1 seen from 0.58 R off centre, the centre's form put the sky 16 %
//! too bright on average.
//!
//! # How L′ is built
//! * The scattered part in SH ([`PSF_ORDER`] bands): the zonal multipliers
//!   of the ball's single-scattering kernel K_T
//!   (`relight_fog::psf::ball_convolution_weights`: the directional
//!   environment entering the ball at its edge, exact at the centre), not
//!   the thesis' PSF_T of eq. 3.30, whose point sources in an unbounded
//!   medium put 60 % more light into a uniform sky's glow at T = 1 and a
//!   1/γ peak around each source that this medium does not have. The
//!   kernel is smooth, so its series needs no window. The reconstruction is
//!   tabulated on a [`SCATTER_WIDTH`]-wide lat-long map in the
//!   environment's frame; anything below zero is clamped (its size is kept
//!   in [`FoggyLighting::clamped`]).
//! * The attenuated part is the environment itself: the lighting table is
//!   built from `e^{−T}·pre + scattered` on the prefiltered map's texels
//!   ([`FoggyLighting::fog_map`]), so a lighting rotation stays a lookup.
//!
//! Not modelled (the fog method's limits, measured by `verify triple`
//! against the reference): light shafts (the medium's own shadowing of the
//! in-scattered light), multiple scattering, and the directions of a
//! surface's light away from the ball's centre (each has the centre's,
//! scaled in amount to its place).

use glam::Vec3;
use relight_fog::ball_light::BallIrradiance;
use relight_fog::view_segment::ChordGlow;
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
    /// a·(K_T ⊛ L), in the environment's frame, clamped at 0.
    pub scattered: EnvMap,
    /// a·L̄·G_c: what the view segment from the centre to the ball's edge
    /// scatters into the eye (a segment's share s of it,
    /// [`ChordGlow::segment`]).
    pub airlight: Vec3,
    /// The medium.
    pub medium: Medium,
    /// The empty pixels' and view segments' weights along their chords.
    pub chords: ChordGlow,
    /// The surfaces' factors for their place in the ball (the fog crate's
    /// `BallIrradiance`: a uniform sky's irradiance there against the
    /// centre's).
    pub factors: BallIrradiance,
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
        let chords = ChordGlow::new(medium);
        let factors = BallIrradiance::new(medium, &chords);
        let mean = env.integral() / (4.0 * std::f32::consts::PI);
        let airlight = mean * (medium.albedo * chords.centre());
        let mut sh = project_env(env, PSF_ORDER, Window::None)?;
        let weights = relight_fog::psf::ball_convolution_weights(f64::from(t), PSF_ORDER);
        for ch in &mut sh.channels {
            for (i, c) in ch.iter_mut().enumerate() {
                let l = (i as f64).sqrt() as usize;
                *c *= (f64::from(medium.albedo) * weights[l]) as f32;
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
            chords,
            factors,
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
    /// environment's frame) crosses the ball's chord, and the environment's
    /// full detail is attenuated by e^{−T_d}, its glow weighted by the
    /// chord's share ([`ChordGlow::weights`]; module docs).
    #[must_use]
    pub fn background(&self, env: &EnvMap, eye: Vec3, d: Vec3, d_env: Vec3) -> Vec3 {
        let [direct, glow] = self.chords.weights(eye, d);
        env.eval(d_env) * direct + self.scattered.eval(d_env) * glow
    }

    /// Surface radiance `surface` (shaded as lit from the ball's centre) at
    /// `t_s` along the view ray from `eye` in direction `d` (unit), with
    /// unit normal `n` (either side): scaled for its place in the ball
    /// ([`BallIrradiance::factor`]), then across its segment in the ball.
    #[must_use]
    pub fn segment(&self, surface: Vec3, n: Vec3, eye: Vec3, d: Vec3, t_s: f32) -> Vec3 {
        let p = eye + d * t_s;
        let n = if n.dot(d) > 0.0 { -n } else { n };
        let [f, share] = self.chords.segment(eye, d, t_s);
        surface * (self.factors.factor(p, n) * f) + self.airlight * share
    }
}
