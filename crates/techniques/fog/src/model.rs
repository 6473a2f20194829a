//! The complete analytic single-scattering model evaluated per pixel and
//! per point light: airlight L_a (Sun 2008, eq. 3.16/3.17), surface radiance
//! L_p for Lambertian and Phong surfaces including the scattered light
//! arriving at the surface (eq. 3.20–3.28), and L = e^{−T_vp} L_p + L_a
//! (eq. 3.29), mirroring the fragment shader of the paper's Figure 3.13.
//!
//! # Units and frames
//! World units for distances, β in 1/world-unit (extinction = scattering,
//! single-scattering albedo 1, as in the thesis; [`FogModel::with_albedo`]
//! scales the scattered terms by an albedo < 1), point-light radiant intensity I₀ per RGB
//! channel (radiance = I₀ / distance² · …). Directions are world-space unit
//! vectors; `dir` points from the eye into the scene.
//!
//! # Evaluation (per pixel × light: one `exp`, two fast `atan2`, square
//! roots and 3–4 table lookups; where the two airlight tails below would
//! cancel — L∞(p) e^{−T_vp} > [`CANCELLATION_RATIO`] L∞(eye), a short view
//! segment far from the light — the segment integral of eq. 3.5 is instead
//! taken by 6-point Gauss–Legendre in the equiangular variable)
//! * u = β h with h = |(l − e) × d|, the distance of the light from the view
//!   ray — the same for the eye and for the surface point, so
//!   L_a = L∞(eye) − e^{−T_vp} L∞(p) (see [`crate::special`]), where
//!   L∞(x) = β I₀ e^{−T_xs} N(u, v) R(w(u), v) / (2π h), v = γ_x/2 from
//!   tan v = sin γ / (1 + cos γ) (accurate 1 + cos γ near γ = π).
//!   Seen from the eye, L∞(eye) depends on the ray only through γ, so it
//!   is tabulated per light and frame ([`PreparedLight::eye_tail`]);
//!   L∞(p) is evaluated per pixel.
//! * Surface: I₀ k_d [e^{−T_sp} cos θ_s / D_sp² + β e^{−T_sp} G̃₀(T_sp, cos θ_s) / (2π D_sp)]
//!   and the same with k_s, cosⁿθ′_s (θ′_s from the reflected view direction)
//!   and G̃_n (β²/T_sp = β/D_sp avoids the 0/0 at β → 0).
//!
//! # Documented limits (instead of NaN/Inf)
//! * Looking straight at a light (γ → 0 with the light in front) the
//!   single-scattering airlight diverges like 1/γ; h is clamped to
//!   ≥ [`MIN_ANGLE`] · D so the glow peaks at a finite value.
//! * Distances are clamped to ≥ [`MIN_DISTANCE`] (a light on a surface or at
//!   the eye); T > G_T_MAX is clamped in the G tables.
//! * Tiny negative airlight from interpolation is clamped to 0.

use crate::FogError;
use crate::fast;
use crate::table::{FogTables, Interp, Table2};
use glam::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// Smallest angle (radians) between the view ray and a light used by the
/// airlight (see the module docs).
pub const MIN_ANGLE: f32 = 1e-4;
/// Where L∞(p) e^{−T_vp} exceeds this fraction of L∞(eye), the airlight is
/// integrated over the view segment directly (6-point Gauss–Legendre on
/// eq. 3.5) instead of as a difference of nearly equal tails.
pub const CANCELLATION_RATIO: f32 = 0.5;
/// 6-point Gauss–Legendre nodes on [−1, 1] ([`FogModel::segment_gauss`]).
pub const GAUSS6_X: [f32; 6] = [
    -0.932_469_5,
    -0.661_209_4,
    -0.238_619_2,
    0.238_619_2,
    0.661_209_4,
    0.932_469_5,
];
/// The weights of [`GAUSS6_X`].
pub const GAUSS6_W: [f32; 6] = [
    0.171_324_5,
    0.360_761_6,
    0.467_913_9,
    0.467_913_9,
    0.360_761_6,
    0.171_324_5,
];
/// Smallest distance (world units) used anywhere in the model.
pub const MIN_DISTANCE: f32 = 1e-6;

/// An isotropic point light (the scene model's: position, radiant intensity
/// I₀ per RGB channel).
pub use relight_render::PointLight;

/// Particle phase function k(α) as a polynomial in cos α (eq. 3.18).
///
/// Stored as `w[k]` = 4π W_k, so the isotropic phase 1/(4π) is `[1]` and the
/// weights multiply the tables Rᵏ directly.
#[derive(Clone, Debug, PartialEq)]
pub struct Phase {
    pub w: Vec<f32>,
}

impl Default for Phase {
    fn default() -> Self {
        Self::isotropic()
    }
}

impl Phase {
    /// k(α) = 1/(4π).
    #[must_use]
    pub fn isotropic() -> Self {
        Self { w: vec![1.0] }
    }

    /// Rayleigh-like k(α) = 3/(16π) (1 + cos²α) (exact, degree 2).
    #[must_use]
    pub fn rayleigh() -> Self {
        Self {
            w: vec![0.75, 0.0, 0.75],
        }
    }

    /// Henyey–Greenstein with asymmetry `g` ∈ (−1, 1), least-squares fitted
    /// on cos α ∈ [−1, 1] by a polynomial of `degree` (the fit keeps the
    /// normalisation ∫k dω = 1 exactly, since the constant is orthogonal to
    /// the rest of the Legendre basis).
    pub fn henyey_greenstein(g: f32, degree: u32) -> Result<Self, FogError> {
        if !(g.is_finite() && g.abs() < 1.0) {
            return Err(FogError::Asymmetry { g });
        }
        let g = f64::from(g);
        let (x, wq) = relight_sh::quadrature::gauss_legendre(256);
        // Legendre projection c_l = (2l+1)/2 ∫ f P_l.
        let deg = degree as usize;
        let hg = |c: f64| (1.0 - g * g) / (1.0 + g * g - 2.0 * g * c).powf(1.5); // 4π·p_HG
        let mut leg = vec![0.0f64; deg + 1];
        for (xi, wi) in x.iter().zip(&wq) {
            let f = hg(*xi);
            let (mut p0, mut p1) = (1.0, *xi);
            for (l, c) in leg.iter_mut().enumerate() {
                let pl = if l == 0 { p0 } else { p1 };
                *c += (2 * l + 1) as f64 / 2.0 * wi * f * pl;
                if l >= 1 {
                    let p2 = ((2 * l + 1) as f64 * xi * p1 - l as f64 * p0) / (l + 1) as f64;
                    p0 = p1;
                    p1 = p2;
                }
            }
        }
        // Legendre → monomial coefficients via the recurrence on coefficient vectors.
        let mut mono = vec![0.0f64; deg + 1];
        let mut pm1 = vec![0.0f64; deg + 2];
        let mut p = vec![0.0f64; deg + 2];
        pm1[0] = 1.0;
        if deg >= 1 {
            p[1] = 1.0;
        }
        for (l, c) in leg.iter().enumerate() {
            let cur = if l == 0 { &pm1 } else { &p };
            for k in 0..=deg {
                mono[k] += c * cur[k];
            }
            if l >= 1 && l < deg {
                let mut next = vec![0.0f64; deg + 2];
                for k in 0..=deg {
                    if k < deg + 1 {
                        next[k + 1] += (2 * l + 1) as f64 * p[k] / (l + 1) as f64;
                    }
                    next[k] -= l as f64 * pm1[k] / (l + 1) as f64;
                }
                pm1 = std::mem::replace(&mut p, next);
            }
        }
        Ok(Self {
            w: mono.iter().map(|&c| c as f32).collect(),
        })
    }

    /// k(α) for `cos_alpha` (1/sr).
    #[inline]
    #[must_use]
    pub fn eval(&self, cos_alpha: f32) -> f32 {
        let mut s = 0.0;
        for &c in self.w.iter().rev() {
            s = s * cos_alpha + c;
        }
        s / (4.0 * PI)
    }

    /// Polynomial degree.
    #[must_use]
    pub fn degree(&self) -> u32 {
        self.w.len().saturating_sub(1) as u32
    }
}

/// Surface reflectance of the analytic model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FogMaterial {
    /// Diffuse albedo ρ_d; the Lambertian BRDF is k_d = ρ_d / π.
    pub albedo: Vec3,
    /// Phong coefficient k_s of the reparameterised lobe k_s cosⁿθ′ (§3.4.2):
    /// reflected radiance = ∫ L_i k_s max(0, ω_i·r)ⁿ dω_i, r the mirrored
    /// view direction. Zero for a purely Lambertian surface.
    pub ks: Vec3,
    /// Phong exponent n (≥ 1; ignored when `ks` is zero).
    pub n: u32,
}

impl FogMaterial {
    /// A Lambertian surface of albedo `albedo`.
    #[must_use]
    pub fn lambert(albedo: Vec3) -> Self {
        Self {
            albedo,
            ks: Vec3::ZERO,
            n: 1,
        }
    }

    /// Lambertian plus a Phong lobe.
    #[must_use]
    pub fn phong(albedo: Vec3, ks: Vec3, n: u32) -> Self {
        Self { albedo, ks, n }
    }

    /// The model's Lambert + Phong surface (§3.4) closest to any `brdf`,
    /// fitted at normal view (ω_o = n, where the mirror direction is n):
    /// k_d/π is the BRDF's floor (its least value 60°–80° from the mirror
    /// direction), k_s the peak above that floor, and n the exponent whose
    /// cosⁿ lobe has the same half-maximum angle (luminance). A normalized
    /// Phong BRDF ρ_s (n+2)/(2π) cosⁿα comes back exactly (k_s = ρ_s
    /// (n+2)/(2π)), Lambert as k_s = 0; other lobes (GGX, Ward, measured)
    /// get the Phong lobe of the same peak and width. As in §3.4.2 the lobe
    /// stands for BRDF × cos θᵢ, so the cos θᵢ foreshortening is dropped.
    /// The exponent is clamped to 1…[`MAX_FITTED_EXPONENT`].
    #[must_use]
    pub fn fit(brdf: &dyn relight_brdf::Brdf) -> Self {
        let at = |deg: f32| {
            let a = deg.to_radians();
            brdf.eval(Vec3::Z, Vec3::new(a.sin(), 0.0, a.cos()))
                .max(Vec3::ZERO)
        };
        let lum = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let floor = [60.0f32, 70.0, 80.0]
            .into_iter()
            .map(at)
            .fold(Vec3::splat(f32::INFINITY), Vec3::min);
        let peak = (at(0.0) - floor).max(Vec3::ZERO);
        let albedo = (floor * PI).min(Vec3::ONE);
        if lum(peak) <= 1e-3 * lum(floor).max(1e-6) {
            return Self::lambert(albedo);
        }
        // Half-maximum angle of the lobe above the floor, by bisection.
        let half = 0.5 * lum(peak);
        let (mut lo, mut hi) = (0.0f32, 80.0f32);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if lum(at(mid) - floor) > half {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let c = (0.5 * (lo + hi)).to_radians().cos();
        let n = (0.5f32.ln() / c.ln()).round();
        Self::phong(
            albedo,
            peak,
            if n.is_finite() {
                n.clamp(1.0, MAX_FITTED_EXPONENT as f32) as u32
            } else {
                MAX_FITTED_EXPONENT
            },
        )
    }
}

/// Largest exponent [`FogMaterial::fit`] returns (a G table per exponent
/// is built; beyond this the lobe is narrower than a 64² table resolves).
pub const MAX_FITTED_EXPONENT: u32 = 1000;

pub use crate::fast::atan2_pos;

/// How the per-pixel code reads a table: a zero-sized type per
/// [`Interp`], so the batch loops are compiled once per interpolation
/// with no per-lookup branch.
pub trait Lookup: Copy + Send + Sync {
    fn get(t: &Table2, x: f32, y: f32) -> f32;
}

/// [`Interp::Bilinear`] as a type.
#[derive(Clone, Copy, Debug)]
pub struct Bilinear;
/// [`Interp::Nearest`] as a type.
#[derive(Clone, Copy, Debug)]
pub struct Nearest;

impl Lookup for Bilinear {
    #[inline(always)]
    fn get(t: &Table2, x: f32, y: f32) -> f32 {
        t.bilinear(x, y)
    }
}

impl Lookup for Nearest {
    #[inline(always)]
    fn get(t: &Table2, x: f32, y: f32) -> f32 {
        t.nearest(x, y)
    }
}

/// Intervals of [`PreparedLight::eye_tail`] (see there).
pub const EYE_TAIL_INTERVALS: usize = 1024;

/// How much finer [`PreparedLight::eye_tail`] samples v near the light
/// than far from it (the constant K of its coordinate).
pub const EYE_TAIL_REFINE: f32 = 32.0;

/// A light with the per-frame constants of one eye position.
#[derive(Clone, Debug)]
pub struct PreparedLight {
    pub position: Vec3,
    pub intensity: Vec3,
    /// l − e.
    pub to_light: Vec3,
    /// D_sv (clamped to ≥ MIN_DISTANCE).
    pub d_sv: f32,
    /// e^{−β D_sv}.
    pub exp_t_sv: f32,
    /// MIN_ANGLE · D_sv: the smallest light-to-ray distance h used.
    pub h_min_sv: f32,
    /// The eye's airlight tail e^{−T_sv} N(u, v) q R(w, v) (the first term
    /// of eq. 3.16 without β / (2π h), see the module docs) at
    /// [`EYE_TAIL_INTERVALS`] + 1 points of v = γ/2 ∈ [0, π/2].
    ///
    /// From the eye the light sits at the fixed distance D_sv, so the
    /// offset along a view ray is D_sv cos γ and its distance from it
    /// D_sv sin γ: the tail depends on the ray only through γ. Every pixel
    /// and every background direction reads it from this table
    /// ([`PreparedLight::eye_tail`]) instead of evaluating the kernel's
    /// square root, three divisions and six 2D table taps.
    ///
    /// Near the light the tail changes over Δv ≈ 1/(2 β D_sv) (its
    /// u = β D_sv sin γ runs through the tables' w), so the samples are
    /// uniform in x = v + K c v / (v + c), c = 1/(2 β D_sv) clamped to
    /// [10⁻⁴, 1], K = [`EYE_TAIL_REFINE`]: K + 1 times denser within ~c of
    /// the light, about uniform beyond. Test `eye_tail_matches_the_kernel`
    /// measures the interpolation error against the kernel. The table
    /// samples the bilinear kernel in either [`Interp`] mode. Rays within
    /// h_min of the light (< 10⁻⁴ rad, h clamped up) read it at their
    /// clamped v.
    pub eye_tail: Box<[f32]>,
    /// c of [`PreparedLight::eye_tail`]'s coordinate.
    pub eye_tail_c: f32,
    /// K c of [`PreparedLight::eye_tail`]'s coordinate.
    pub eye_tail_kc: f32,
    /// [`EYE_TAIL_INTERVALS`] / x(π/2): table intervals per unit of x.
    pub eye_tail_scale: f32,
}

/// The half angle of a light seen from a point at distance `1 / inv_d`
/// from it, offset `along` along a ray and at distance `h` from it:
/// (s = min(h / D, 1), 1 + cos γ (≥ 10⁻³⁰), v = γ/2 = atan(s / (1 + cos γ))),
/// with cos γ = along / D clamped to [−1, 1] and 1 + cos γ = s² / (1 − cos γ)
/// for cos γ < 0 (accurate near γ = π).
#[inline(always)]
#[allow(clippy::manual_clamp)] // maps NaN to a bound
pub(crate) fn half_angle(inv_d: f32, along: f32, h: f32) -> (f32, f32, f32) {
    let s = (h * inv_d).min(1.0);
    let c = (along * inv_d).max(-1.0).min(1.0);
    let opc = if c >= 0.0 { 1.0 + c } else { s * s / (1.0 - c) };
    let opc = opc.max(1e-30);
    (s, opc, atan2_pos(s, opc))
}

impl PreparedLight {
    /// [`PreparedLight::eye_tail`] interpolated at v = atan(s / (1 + c)),
    /// s = min(h / D_sv, 1) and c = along / D_sv clamped to [−1, 1], with
    /// 1 + c = s² / (1 − c) for c < 0 (the kernel's own v, accurate near
    /// γ = π), linearly between the samples around its coordinate x(v)
    /// (see the field). The AVX2 kernels repeat this arithmetic lane by
    /// lane.
    #[inline(always)]
    #[must_use]
    #[allow(clippy::manual_clamp)] // maps NaN to a bound
    pub fn eye_tail(&self, along: f32, h: f32) -> f32 {
        let (_, _, v) = half_angle(1.0 / self.d_sv, along, h);
        let x = (v + self.eye_tail_kc * v / (v + self.eye_tail_c)) * self.eye_tail_scale;
        let x = x.max(0.0).min(EYE_TAIL_INTERVALS as f32);
        let i = (x as usize).min(EYE_TAIL_INTERVALS - 1);
        let f = x - i as f32;
        let (t0, t1) = (self.eye_tail[i], self.eye_tail[i + 1]);
        (t1 - t0) * f + t0
    }
}

/// The per-(pixel, light) quantities of a surface pixel before the
/// material is applied (eq. 3.20–3.29, per unit intensity).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceTerms {
    /// Airlight difference L∞(eye) − e^{−T_vp} L∞(p) (clamped to ≥ 0).
    pub air: f32,
    /// Whether the two tails nearly cancel (then `air` must be replaced by
    /// [`FogModel::segment_gauss`] of `along`, `h`).
    pub cancels: bool,
    /// e^{−T_sp} cos θ_s / D_sp² + β e^{−T_sp} G̃₀ / (2π D_sp) (× k_d).
    pub diffuse: f32,
    /// e^{−T_sp} cosⁿθ′_s / D_sp² + β e^{−T_sp} G̃_n / (2π D_sp) (× k_s).
    pub spec: f32,
    /// Offset of the light along the view ray and its distance from it.
    pub along: f32,
    pub h: f32,
}

/// The tables, medium and interpolation of one frame, ready to evaluate.
#[derive(Clone, Copy, Debug)]
pub struct FogModel<'a> {
    pub beta: f32,
    pub interp: Interp,
    tails: &'a [Table2],
    phase: &'a [f32],
    g_lambert: Option<&'a Table2>,
    tables: &'a FogTables,
    /// Single-scattering albedo a = σ_s/β ∈ [0, 1] (1 = Sun's model).
    albedo: f32,
    /// σ_s / (2π) = a β / (2π): the in-scattering factor of every
    /// scattered term (airlight and the surface's scattered light).
    beta_2pi: f32,
}

impl<'a> FogModel<'a> {
    /// Checks β (finite, ≥ 0) and that the tables cover `phase`. Without a
    /// Lambert G table (`build_parts` with no lobes) the scattered surface
    /// term is omitted.
    pub fn new(
        tables: &'a FogTables,
        beta: f32,
        phase: &'a Phase,
        interp: Interp,
    ) -> Result<Self, FogError> {
        if !(beta.is_finite() && beta >= 0.0) {
            return Err(FogError::Beta { beta });
        }
        let max = tables.tail.len().saturating_sub(1) as u32;
        if phase.degree() > max || phase.w.is_empty() {
            return Err(FogError::PhaseDegree {
                degree: phase.degree(),
                max,
            });
        }
        let g_lambert = tables.g_table(1);
        Ok(Self {
            beta,
            interp,
            tails: &tables.tail[..phase.w.len()],
            phase: &phase.w,
            g_lambert,
            tables,
            albedo: 1.0,
            beta_2pi: beta / (2.0 * PI),
        })
    }

    /// The same model in a medium of single-scattering albedo `albedo`
    /// (σ_s = albedo · β, extinction σ_t = β). Sun's model has albedo 1 (β
    /// is both); in single scattering every scattered term — the airlight
    /// (eq. 3.16/3.17) and the scattered surface light (eq. 3.22) — is
    /// linear in σ_s while every attenuation stays e^{−β·distance}, so the
    /// albedo only scales those terms.
    ///
    /// # Errors
    /// [`FogError::Albedo`] unless 0 ≤ `albedo` ≤ 1.
    pub fn with_albedo(mut self, albedo: f32) -> Result<Self, FogError> {
        if !(0.0..=1.0).contains(&albedo) {
            return Err(FogError::Albedo { albedo });
        }
        self.albedo = albedo;
        self.beta_2pi = albedo * self.beta / (2.0 * PI);
        Ok(self)
    }

    /// The single-scattering albedo (1 unless [`FogModel::with_albedo`]).
    #[must_use]
    pub fn albedo(&self) -> f32 {
        self.albedo
    }

    /// A table that stands in for a missing Phong G table (its term is then
    /// multiplied by k_s = 0): Lambert's G, else the first tail table.
    #[must_use]
    pub fn stand_in_table(&self) -> &'a Table2 {
        self.g_lambert.unwrap_or(&self.tails[0])
    }

    /// The parts the AVX2 kernels read.
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn simd_ctx(&self) -> crate::simd::Ctx<'a> {
        crate::simd::Ctx {
            beta: self.beta,
            sigma_s: self.albedo * self.beta,
            tables: self.tables,
            tails: self.tails,
            phase: self.phase,
            g_lambert: self.g_lambert,
        }
    }

    /// The largest side of any table this model may read.
    #[must_use]
    pub fn max_table_size(&self) -> usize {
        self.tables
            .tail
            .iter()
            .chain(self.tables.g.iter().map(|(_, t)| t))
            .map(Table2::size)
            .max()
            .unwrap_or(0)
    }

    /// The G table for a material's Phong exponent (error if not built).
    pub fn g_table(&self, n: u32) -> Result<&'a Table2, FogError> {
        self.tables
            .g_table(n)
            .ok_or(FogError::MissingPhongTable { n })
    }

    /// Per-frame light constants for the eye at `eye`. Errors on negative or
    /// non-finite intensity or position.
    pub fn prepare_lights(
        &self,
        eye: Vec3,
        lights: &[PointLight],
    ) -> Result<Vec<PreparedLight>, FogError> {
        lights
            .iter()
            .enumerate()
            .map(|(index, l)| {
                if !(l.intensity.is_finite() && l.intensity.min_element() >= 0.0) {
                    return Err(FogError::Intensity {
                        index,
                        intensity: l.intensity.to_array(),
                    });
                }
                if !l.position.is_finite() {
                    return Err(FogError::LightPosition {
                        index,
                        position: l.position.to_array(),
                    });
                }
                let to_light = l.position - eye;
                let d_sv = to_light.length().max(MIN_DISTANCE);
                let exp_t_sv = (-self.beta * d_sv).exp();
                let c = (0.5 / (self.beta * d_sv)).clamp(1e-4, 1.0);
                let kc = EYE_TAIL_REFINE * c;
                let x_max = FRAC_PI_2 + kc * FRAC_PI_2 / (FRAC_PI_2 + c);
                Ok(PreparedLight {
                    position: l.position,
                    intensity: l.intensity,
                    to_light,
                    d_sv,
                    exp_t_sv,
                    h_min_sv: (MIN_ANGLE * d_sv).max(MIN_DISTANCE),
                    eye_tail: self.eye_tail_table(d_sv, exp_t_sv, c, kc, x_max),
                    eye_tail_c: c,
                    eye_tail_kc: kc,
                    eye_tail_scale: EYE_TAIL_INTERVALS as f32 / x_max,
                })
            })
            .collect()
    }

    /// [`PreparedLight::eye_tail`] of a light at distance `d_sv` from the
    /// eye: the bilinear kernel at the v_k of x_k = k x_max / N (the
    /// positive root of v² + (c + K c − x) v − x c = 0), γ = 2 v_k, offset
    /// D_sv cos γ, distance D_sv sin γ.
    fn eye_tail_table(&self, d_sv: f32, exp_t_sv: f32, c: f32, kc: f32, x_max: f32) -> Box<[f32]> {
        let (c, kc) = (f64::from(c), f64::from(kc));
        (0..=EYE_TAIL_INTERVALS)
            .map(|k| {
                let x = f64::from(x_max) * k as f64 / EYE_TAIL_INTERVALS as f64;
                let b = c + kc - x;
                let v = 0.5 * ((b * b + 4.0 * x * c).sqrt() - b);
                let gamma = (2.0 * v).min(std::f64::consts::PI);
                let (along, h) = (
                    (f64::from(d_sv) * gamma.cos()) as f32,
                    (f64::from(d_sv) * gamma.sin()).max(0.0) as f32,
                );
                let u = self.beta * h;
                let w = u / (1.0 + u);
                exp_t_sv * self.l_inf_kernel::<Bilinear>(d_sv, along, h, u, w)
            })
            .collect()
    }

    /// What [`PreparedLight::eye_tail`] interpolates, evaluated directly by
    /// the bilinear kernel (the table's reference in tests): the eye's tail of
    /// `light` for a ray whose offset along it is `along` and distance `h`.
    #[must_use]
    pub fn eye_tail_direct(&self, light: &PreparedLight, along: f32, h: f32) -> f32 {
        let u = self.beta * h;
        let w = u / (1.0 + u);
        light.exp_t_sv * self.l_inf_kernel::<Bilinear>(light.d_sv, along, h, u, w)
    }

    /// Phase-weighted Σ_k w_k Rᵏ(w, v).
    #[inline(always)]
    fn tail_sum<L: Lookup>(&self, w: f32, v: f32) -> f32 {
        if self.phase.len() == 1 {
            return self.phase[0] * L::get(&self.tails[0], w, v);
        }
        let mut s = 0.0;
        for (c, t) in self.phase.iter().zip(self.tails) {
            s += c * L::get(t, w, v);
        }
        s
    }

    /// Airlight to infinity per unit intensity without e^{−T} and without
    /// the common factor β / (2π h): N(u, v) q R(w, v) for a light at
    /// distance `d` whose offset along the ray is `along`, with u = β h and
    /// w = u / (1 + u) of the (clamped) distance h from the ray.
    #[inline(always)]
    fn l_inf_kernel<L: Lookup>(&self, d: f32, along: f32, h: f32, u: f32, w: f32) -> f32 {
        let (s, opc, v) = half_angle(1.0 / d, along, h);
        let cos2v = 0.5 * opc;
        let cosv = cos2v.sqrt();
        let q = self.tables.corner(u * s / opc);
        cos2v / (cosv + u) * q * self.tail_sum::<L>(w, v)
    }

    /// Airlight to infinity (eq. 3.17) per unit intensity along unit `dir`
    /// from the eye (no surface).
    #[inline(always)]
    pub fn air_inf(&self, light: &PreparedLight, dir: Vec3) -> f32 {
        let along = light.to_light.dot(dir);
        let h = light.to_light.cross(dir).length().max(light.h_min_sv);
        light.eye_tail(along, h) * self.beta_2pi / h
    }

    /// The airlight difference of eq. 3.16 as two tails (see
    /// [`crate::special`]): (L∞(eye) − e^{−T_vp} L∞(p), tails cancel?).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn air_split<L: Lookup>(
        &self,
        light: &PreparedLight,
        along: f32,
        h_raw: f32,
        along_p: f32,
        d_sp: f32,
        exp_vp_sp: f32,
    ) -> (f32, bool, f32) {
        let h = h_raw.max(light.h_min_sv.min(MIN_ANGLE * d_sp).max(MIN_DISTANCE));
        let u = self.beta * h;
        let w = u / (1.0 + u);
        let a = light.eye_tail(along, h);
        let b = exp_vp_sp * self.l_inf_kernel::<L>(d_sp, along_p, h, u, w);
        let k = self.beta_2pi / h;
        ((a - b).max(0.0) * k, b > CANCELLATION_RATIO * a, h)
    }

    /// Airlight L_a (eq. 3.16, per unit intensity) along the ray from the
    /// eye in unit direction `dir`, ending at `hit` = (surface point,
    /// D_vp, e^{−T_vp}) or at infinity (eq. 3.17).
    #[inline]
    #[must_use]
    pub fn airlight(&self, light: &PreparedLight, dir: Vec3, hit: Option<(Vec3, f32, f32)>) -> f32 {
        match self.interp {
            Interp::Bilinear => self.airlight_g::<Bilinear>(light, dir, hit),
            Interp::Nearest => self.airlight_g::<Nearest>(light, dir, hit),
        }
    }

    #[inline(always)]
    fn airlight_g<L: Lookup>(
        &self,
        light: &PreparedLight,
        dir: Vec3,
        hit: Option<(Vec3, f32, f32)>,
    ) -> f32 {
        match hit {
            None => self.air_inf(light, dir),
            Some((p, d_vp, exp_t_vp)) => {
                let along = light.to_light.dot(dir);
                let h_raw = light.to_light.cross(dir).length();
                let lp = light.position - p;
                let d_sp = lp.length().max(MIN_DISTANCE);
                let exp_t_sp = fast::exp(-self.beta * d_sp);
                let (air, cancels, h) = self.air_split::<L>(
                    light,
                    along,
                    h_raw,
                    lp.dot(dir),
                    d_sp,
                    exp_t_vp * exp_t_sp,
                );
                if cancels {
                    self.segment_gauss(along, h, d_vp)
                } else {
                    air
                }
            }
        }
    }

    /// Eq. 3.5 (with the polynomial phase) over [0, d_vp] per unit
    /// intensity, in the equiangular variable θ = atan((t − Δ)/h) (Δ the
    /// light's offset along the ray): dt/d² = dθ/h, so the integrand
    /// e^{−β(t + d)} k(−sin θ) is smooth and 6-point Gauss–Legendre suffices.
    /// The nodes and weights are also used by the AVX2 kernel.
    #[inline]
    #[must_use]
    pub fn segment_gauss(&self, along: f32, h: f32, d_vp: f32) -> f32 {
        // θ0 = atan(−Δ/h); θ1 − θ0 from the atan difference formula, so a
        // short segment keeps its relative accuracy:
        // θ1 − θ0 = atan2(D_vp h, h² − Δ (D_vp − Δ)) ∈ (0, π).
        let th0 = fast::atan_ratio(-along, h);
        let (y, x) = (d_vp * h, h * h - along * (d_vp - along));
        let a = fast::atan2_precise(y, x.abs());
        let dth = if x >= 0.0 { a } else { PI - a };
        let (mid, half) = (th0 + 0.5 * dth, 0.5 * dth);
        let mut s = 0.0;
        for (x, w) in GAUSS6_X.iter().zip(GAUSS6_W) {
            // θ ∈ (−π/2, π/2): t + d = Δ + h (1 + sin θ)/cos θ.
            let (sn, cs) = fast::sin_cos(mid + half * x);
            let inv_c = 1.0 / cs.max(1e-30);
            let t_plus_d = along + h * (1.0 + sn) * inv_c;
            let c = -sn;
            let mut k = 0.0;
            for &pw in self.phase.iter().rev() {
                k = k * c + pw;
            }
            s += w * k * fast::exp(-self.beta * t_plus_d);
        }
        (self.albedo * self.beta / (4.0 * PI) * half * s / h).max(0.0)
    }

    /// The per-(pixel, light) terms of a surface pixel (see
    /// [`SurfaceTerms`]): `p` the visible point, `n` its unit normal facing
    /// the viewer (n · dir ≤ 0), `dir` the unit view direction, `refl` the
    /// mirrored view direction dir − 2 (dir·n) n,
    /// `exp_t_vp` = e^{−β D_vp}, `phong_n` the Phong exponent and `g_phong`
    /// its G table (any table, e.g. Lambert's, when k_s = 0: `spec` is then
    /// unused). Branch-free apart from the phase loop, so loops over pixels
    /// vectorise.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn surface_terms<L: Lookup>(
        &self,
        light: &PreparedLight,
        p: Vec3,
        n: Vec3,
        dir: Vec3,
        refl: Vec3,
        exp_t_vp: f32,
        phong_n: f32,
        g_phong: &Table2,
    ) -> SurfaceTerms {
        let lp = light.position - p;
        let d2 = lp.length_squared().max(MIN_DISTANCE * MIN_DISTANCE);
        let inv_d = 1.0 / d2.sqrt();
        let d_sp = d2 * inv_d;
        let t_sp = self.beta * d_sp;
        let exp_t_sp = fast::exp(-t_sp);
        let along = light.to_light.dot(dir);
        let h_raw = light.to_light.cross(dir).length();
        let (air, cancels, h) =
            self.air_split::<L>(light, along, h_raw, lp.dot(dir), d_sp, exp_t_vp * exp_t_sp);
        let w_t = t_sp / (1.0 + t_sp);
        let direct = exp_t_sp * inv_d * inv_d;
        let scat = self.beta_2pi * exp_t_sp * inv_d;
        let mu = n.dot(lp) * inv_d;
        let mu_r = refl.dot(lp) * inv_d;
        let g0 = self.g_lambert.map_or(0.0, |g| L::get(g, w_t, mu));
        let gn = L::get(g_phong, w_t, mu_r);
        let lobe = if mu > 0.0 {
            fast::powi_pos(mu_r, phong_n)
        } else {
            0.0
        };
        SurfaceTerms {
            air,
            cancels,
            diffuse: direct * mu.max(0.0) + scat * g0,
            spec: direct * lobe + scat * gn,
            along,
            h,
        }
    }

    /// Complete model (eq. 3.29) for one pixel and one light: radiance
    /// reaching the eye along `dir` (unit), with the visible surface point
    /// `p`, its unit normal `n` (either side; flipped toward the viewer),
    /// distance `d_vp` = |p − eye| and e^{−T_vp} = `exp_t_vp`, material `m` and its G
    /// table `g_phong` (`None` when `m.ks` is zero).
    #[inline]
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn shade_surface(
        &self,
        light: &PreparedLight,
        dir: Vec3,
        p: Vec3,
        n: Vec3,
        d_vp: f32,
        exp_t_vp: f32,
        m: &FogMaterial,
        g_phong: Option<&Table2>,
    ) -> Vec3 {
        match self.interp {
            Interp::Bilinear => {
                self.shade_surface_g::<Bilinear>(light, dir, p, n, d_vp, exp_t_vp, m, g_phong)
            }
            Interp::Nearest => {
                self.shade_surface_g::<Nearest>(light, dir, p, n, d_vp, exp_t_vp, m, g_phong)
            }
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn shade_surface_g<L: Lookup>(
        &self,
        light: &PreparedLight,
        dir: Vec3,
        p: Vec3,
        n: Vec3,
        d_vp: f32,
        exp_t_vp: f32,
        m: &FogMaterial,
        g_phong: Option<&Table2>,
    ) -> Vec3 {
        let n = if n.dot(dir) > 0.0 { -n } else { n };
        let refl = dir - 2.0 * dir.dot(n) * n;
        // Without a Phong lobe any table stands in (its `spec` is unused).
        let (ks, gt) = match g_phong {
            Some(g) => (m.ks, g),
            None => (Vec3::ZERO, self.stand_in_table()),
        };
        let s = self.surface_terms::<L>(light, p, n, dir, refl, exp_t_vp, m.n as f32, gt);
        let air = if s.cancels {
            self.segment_gauss(s.along, s.h, d_vp)
        } else {
            s.air
        };
        light.intensity
            * (exp_t_vp * (m.albedo * (s.diffuse * (1.0 / PI)) + ks * s.spec) + Vec3::splat(air))
    }

    /// Complete model summed over `lights` for one pixel: surface hit
    /// `Some((p, n, material, g_phong))` or background (`None`).
    #[inline]
    #[must_use]
    pub fn shade_pixel(
        &self,
        eye: Vec3,
        dir: Vec3,
        lights: &[PreparedLight],
        hit: Option<(Vec3, Vec3, &FogMaterial, Option<&Table2>)>,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        match hit {
            None => {
                for l in lights {
                    sum += l.intensity * self.airlight(l, dir, None);
                }
            }
            Some((p, n, m, g)) => {
                let d_vp = (p - eye).length();
                let exp_t_vp = fast::exp(-self.beta * d_vp);
                for l in lights {
                    sum += self.shade_surface(l, dir, p, n, d_vp, exp_t_vp, m, g);
                }
            }
        }
        sum
    }
}

/// The classic OpenGL exponential fog (GL_EXP) for comparison: the surface
/// shaded without a medium (Lambert + Phong under inverse-square point
/// lights, same [`FogMaterial`]), blended with a constant fog colour:
/// f = e^{−β D_vp}, C = f C_surface + (1 − f) C_fog; background = C_fog.
#[must_use]
pub fn opengl_fog_pixel(
    eye: Vec3,
    dir: Vec3,
    lights: &[PointLight],
    beta: f32,
    fog_color: Vec3,
    hit: Option<(Vec3, Vec3, &FogMaterial)>,
) -> Vec3 {
    let Some((p, n, m)) = hit else {
        return fog_color;
    };
    let n = if n.dot(dir) > 0.0 { -n } else { n };
    let mut c = Vec3::ZERO;
    for l in lights {
        let lp = l.position - p;
        let d = lp.length().max(MIN_DISTANCE);
        let lh = lp / d;
        let mu = n.dot(lh);
        if mu <= 0.0 {
            continue;
        }
        let r = dir - 2.0 * dir.dot(n) * n;
        let spec = if m.ks == Vec3::ZERO {
            Vec3::ZERO
        } else {
            m.ks * r.dot(lh).max(0.0).powi(m.n as i32)
        };
        c += l.intensity / (d * d) * (m.albedo / PI * mu + spec);
    }
    let f = (-beta.max(0.0) * (p - eye).length()).exp();
    f * c + (1.0 - f) * fog_color
}

/// Scalar airlight through the model for the canonical geometry of eq. 3.5
/// (eye at the origin looking down +z, light at D_sv (sin γ, 0, cos γ),
/// surface at D_vp or none when infinite) — used by `verify_fog`.
#[must_use]
pub fn airlight_model(model: &FogModel, i0: f32, d_sv: f32, d_vp: f32, gamma: f32) -> f32 {
    let light = PointLight::new(
        Vec3::new(gamma.sin(), 0.0, gamma.cos()) * d_sv,
        Vec3::splat(i0),
    );
    let Ok(pl) = model.prepare_lights(Vec3::ZERO, &[light]) else {
        return 0.0;
    };
    let hit = d_vp
        .is_finite()
        .then(|| (Vec3::Z * d_vp, d_vp, (-model.beta * d_vp).exp()));
    i0 * model.airlight(&pl[0], Vec3::Z, hit)
}

/// Airlight with the paper's own table of F (eq. 3.16, u clamped to the F
/// table's range): A₀ [F(A₁, v₂) − F(A₁, γ/2)] — for the comparison rows of
/// `verify_fog`.
#[must_use]
pub fn airlight_paper_f(
    tables: &FogTables,
    interp: Interp,
    beta: f64,
    i0: f64,
    d_sv: f64,
    d_vp: f64,
    gamma: f64,
) -> f64 {
    let t_sv = beta * d_sv;
    let (s, c) = gamma.sin_cos();
    let a1 = (t_sv * s).max(1e-12);
    let a0 = beta * beta * i0 * (-t_sv * c).exp() / (2.0 * std::f64::consts::PI * a1);
    let v2 = if d_vp.is_finite() {
        std::f64::consts::FRAC_PI_4 + 0.5 * ((beta * d_vp - t_sv * c) / a1).atan()
    } else {
        std::f64::consts::FRAC_PI_2
    };
    let f = |v: f64| f64::from(tables.f.lookup(interp, a1 as f32, v as f32));
    a0 * (f(v2) - f(0.5 * gamma))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_lambert_and_phong_and_fits_other_lobes() {
        use relight_brdf::BrdfSpec;
        let fit = |spec: &str| FogMaterial::fit(spec.parse::<BrdfSpec>().unwrap().build().as_ref());
        let l = fit("lambert:0.8");
        assert!((l.albedo - Vec3::splat(0.8)).abs().max_element() < 1e-5 && l.ks == Vec3::ZERO);
        let p = fit("phong:40@0.9,0.25,0.2");
        assert_eq!(p.n, 40);
        let ks = Vec3::new(0.9, 0.25, 0.2) * 42.0 / (2.0 * PI);
        assert!(
            (p.ks - ks).abs().max_element() < 1e-4 * ks.max_element(),
            "{p:?}"
        );
        assert!(p.albedo.max_element() < 1e-6, "{p:?}");
        let m = fit("0.5*lambert:0.6+0.5*phong:20");
        assert_eq!(m.n, 20, "{m:?}");
        assert!(
            (m.albedo - Vec3::splat(0.3)).abs().max_element() < 1e-4,
            "{m:?}"
        );
        // GGX α = 0.2: a narrow lobe (Blinn ≈ 2/α² − 2 = 48 in the half
        // vector, ≈ 12 about the mirror direction at normal view).
        let g = fit("ggx:0.2");
        assert!(g.ks.min_element() > 0.0 && (6..=40).contains(&g.n), "{g:?}");
        let rough = fit("ggx:0.8");
        assert!(rough.n < g.n, "{rough:?} vs {g:?}");
    }

    #[test]
    fn phase_fits() {
        let r = Phase::rayleigh();
        assert!((r.eval(1.0) - 3.0 / (8.0 * PI)).abs() < 1e-6);
        let hg = Phase::henyey_greenstein(0.3, 6).unwrap();
        // Normalisation preserved: ∫ k dω = 2π ∫ k(x) dx = 1.
        let m = 2000;
        let integral: f32 = (0..m)
            .map(|i| hg.eval(-1.0 + 2.0 * (i as f32 + 0.5) / m as f32))
            .sum::<f32>()
            * 2.0
            / m as f32
            * 2.0
            * PI;
        assert!((integral - 1.0).abs() < 1e-3, "∫HG fit = {integral}");
        let exact = |c: f32| (1.0 - 0.09) / (4.0 * PI * (1.09 - 0.6 * c).powf(1.5));
        for &c in &[-1.0f32, 0.0, 0.5, 1.0] {
            assert!(
                (hg.eval(c) - exact(c)).abs() < 0.05 * exact(c) + 2e-3,
                "HG fit at {c}: {} vs {}",
                hg.eval(c),
                exact(c)
            );
        }
        assert!(Phase::henyey_greenstein(1.0, 3).is_err());
    }
}
