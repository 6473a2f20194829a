//! Monte Carlo sampling: a tiny seedable random number generator, warps of
//! the unit square onto the sphere and hemisphere, piecewise-constant 1D/2D
//! distributions, and importance sampling of an environment map by luminance.
//!
//! # Random numbers
//! [`Rng`] is O'Neill's PCG32 (XSH-RR output of a 64-bit LCG, "PCG: A Family of
//! Simple Fast Space-Efficient Statistically Good Algorithms for Random Number
//! Generation", 2014). [`Rng::for_sample`] derives an independent stream from
//! (seed, pixel, sample) by SplitMix64 hashing, so every Monte Carlo sample of
//! the reference renderer is a pure function of its indices: images do not
//! depend on the thread count or the tile schedule.
//!
//! # Warps (pbrt families: `sample_x` / `x_pdf` / `invert_x_sample`)
//! All take `u ∈ [0,1)²` and return unit vectors in a local frame with +Z the
//! pole (the surface normal); pdfs are per steradian.
//!
//! # Piecewise-constant distributions
//! [`Distribution1D`] holds a non-negative function on n equal bins, its CDF in
//! f64 (so a million-bin map keeps the tiny probabilities of dark texels) and
//! samples by binary search in O(log n). [`Distribution2D`] is the
//! marginal/conditional construction of pbrt (§A.5 of the 4th edition).
//!
//! # Environment sampling ([`EnvSampler`])
//! Texel `i` of an [`EnvMap`] on any [`Param`] is chosen with probability
//! p_i ∝ Y(L_i) · Ω_i (luminance × exact texel solid angle; texels of zero
//! luminance get zero probability). A point is then drawn *uniformly in the
//! texel's rectangle of map coordinates* `uv ∈ [0,1]²` (the coordinates of
//! [`Param::dir_from_uv`]), and mapped to the sphere. Its density per steradian is
//! exact:
//!
//! pdf(ω) = p_i / (A_i · J(uv)),  A_i = 1/(width·height),  J = |∂ω/∂u × ∂ω/∂v|,
//!
//! where J (steradians per unit map area) is analytic for lat-long and cube
//! maps and evaluated by f64 central differences of `dir_from_uv` for the
//! octahedral maps (relative error ~1e-9, except within 1e-6 of a fold line —
//! a set of measure ~1e-6).
//! The texel of a direction is located from `uv_from_dir` with the same
//! rectangles, so `sample` and `pdf` agree exactly (the MIS weights of the
//! reference renderer rely on that).
//!
//! **Radiance must be evaluated consistently with what is sampled:** the
//! sampler's density is proportional to luminance for the *piecewise-constant*
//! reading of the map (each texel's value over its whole rectangle), which is
//! [`EnvFilter::Nearest`] and is also what a sum over texels × solid angle
//! (SH projection, quadrature) integrates. [`EnvFilter::Bilinear`] gives a
//! smoother background; it stays unbiased because the pdf is the exact density
//! of the samples and BRDF sampling (combined by MIS) covers the texels the
//! bilinear footprint spreads into, but it is no longer a near-zero-variance
//! estimator of the light.

use glam::{DVec2, DVec3, Vec2, Vec3};
use relight_sphere::{EnvMap, Param};
use std::f32::consts::{FRAC_1_PI, PI};

// ---------------------------------------------------------------------------
// Random numbers
// ---------------------------------------------------------------------------

/// SplitMix64 finaliser: a bijective 64-bit mix (Steele et al. 2014).
#[inline]
#[must_use]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// PCG32 (XSH-RR): 64-bit state, 32-bit output, selectable stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    const MULT: u64 = 6_364_136_223_846_793_005;

    /// A generator seeded with `seed` on stream `stream` (any values).
    #[must_use]
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// The generator of sample `sample` of pixel (or item) `pixel` under the
    /// global `seed`: a pure function of the three, so results do not depend
    /// on scheduling.
    #[must_use]
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        let s = splitmix64(
            seed ^ splitmix64(pixel.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ splitmix64(sample)),
        );
        Self::new(s, splitmix64(s ^ 0x5851_F42D_4C95_7F2D))
    }

    /// Next uniform 32-bit integer.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1) (24 random bits; never returns 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = u64::from(self.next_u32());
        let lo = u64::from(self.next_u32());
        (((hi << 32) | lo) >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// Uniform point in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

// ---------------------------------------------------------------------------
// Warps
// ---------------------------------------------------------------------------

// The disk and cosine-hemisphere warps are the BRDF crate's (one copy of each
// warp in the workspace); re-exported so renderer code has one `sampling` module.
pub use relight_brdf::sampling::{
    cosine_hemisphere_pdf, invert_cosine_hemisphere_sample, sample_cosine_hemisphere,
    sample_uniform_disk_concentric,
};

/// Uniform direction on the unit sphere; density [`uniform_sphere_pdf`].
#[inline]
#[must_use]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// Density of [`sample_uniform_sphere`]: 1 / (4π) per steradian.
#[inline]
#[must_use]
pub fn uniform_sphere_pdf() -> f32 {
    0.25 * FRAC_1_PI
}

/// Inverse of [`sample_uniform_sphere`].
#[must_use]
pub fn invert_uniform_sphere_sample(w: Vec3) -> Vec2 {
    let mut phi = w.y.atan2(w.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    Vec2::new((1.0 - w.z) * 0.5, phi / (2.0 * PI))
}

/// Uniform direction on the hemisphere z ≥ 0; density [`uniform_hemisphere_pdf`].
#[inline]
#[must_use]
pub fn sample_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// Density of [`sample_uniform_hemisphere`]: 1 / (2π) per steradian.
#[inline]
#[must_use]
pub fn uniform_hemisphere_pdf() -> f32 {
    0.5 * FRAC_1_PI
}

/// Power heuristic with β = 2 (Veach 1997, §9.2.4) for one sample from each
/// of two techniques: the weight of the technique with density `pdf_a`.
#[inline]
#[must_use]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a.is_infinite() {
        return 1.0;
    }
    if a + b == 0.0 { 0.0 } else { a / (a + b) }
}

/// Rec. 709 / sRGB luminance of a linear RGB value.
#[inline]
#[must_use]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

// ---------------------------------------------------------------------------
// Piecewise-constant distributions
// ---------------------------------------------------------------------------

/// A piecewise-constant density on [0, 1) with `n` equal bins, proportional to
/// non-negative weights. When every weight is zero (or the input is empty of
/// mass) the distribution is uniform, and [`Distribution1D::integral`] is 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    func: Vec<f64>,
    /// `n + 1` entries, cdf[0] = 0, cdf[n] = 1.
    cdf: Vec<f64>,
    /// Mean of `func` over [0, 1) (Σ func / n).
    integral: f64,
}

impl Distribution1D {
    /// From non-negative finite weights (negative or non-finite ones count as
    /// zero). `None` when `func` is empty.
    #[must_use]
    pub fn try_new(func: &[f64]) -> Option<Self> {
        let n = func.len();
        if n == 0 {
            return None;
        }
        let func: Vec<f64> = func
            .iter()
            .map(|&f| if f.is_finite() && f > 0.0 { f } else { 0.0 })
            .collect();
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0);
        let mut acc = 0.0;
        for &f in &func {
            acc += f;
            cdf.push(acc);
        }
        let total = acc;
        if total > 0.0 {
            for c in &mut cdf[1..] {
                *c /= total;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f64 / n as f64;
            }
        }
        cdf[n] = 1.0;
        Some(Self {
            func,
            cdf,
            integral: total / n as f64,
        })
    }

    /// Number of bins.
    #[must_use]
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Always false (a distribution has at least one bin).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Mean of the weights (Σ w / n); 0 for an all-zero input.
    #[must_use]
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Probability of bin `i` when sampling discretely.
    #[inline]
    #[must_use]
    pub fn discrete_pmf(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// Bin containing `u ∈ [0,1)` of the CDF (O(log n)).
    #[inline]
    fn find(&self, u: f64) -> usize {
        // Largest i with cdf[i] <= u, skipping zero-probability bins.
        let i = self.cdf.partition_point(|&c| c <= u);
        i.saturating_sub(1).min(self.func.len() - 1)
    }

    /// Draws a bin: (index, probability, `u` remapped to [0,1) within the bin).
    #[inline]
    #[must_use]
    pub fn sample_discrete(&self, u: f64) -> (usize, f64, f64) {
        let i = self.find(u);
        let p = self.discrete_pmf(i);
        let remapped = if p > 0.0 {
            ((u - self.cdf[i]) / p).clamp(0.0, 1.0 - f64::EPSILON)
        } else {
            0.5
        };
        (i, p, remapped)
    }

    /// Draws x ∈ [0,1) with the piecewise-constant density: (x, pdf(x), bin).
    #[inline]
    #[must_use]
    pub fn sample_continuous(&self, u: f64) -> (f64, f64, usize) {
        let (i, p, du) = self.sample_discrete(u);
        let n = self.func.len() as f64;
        ((i as f64 + du) / n, p * n, i)
    }

    /// Density at x ∈ [0,1) of [`Distribution1D::sample_continuous`].
    #[inline]
    #[must_use]
    pub fn pdf(&self, x: f64) -> f64 {
        let n = self.func.len();
        let i = ((x * n as f64) as usize).min(n - 1);
        self.discrete_pmf(i) * n as f64
    }
}

/// A piecewise-constant density on [0,1)² over an `nu × nv` grid (row-major,
/// `func[v * nu + u]`), sampled as a marginal in v and a conditional in u.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// `None` when `func.len() != nu * nv` or either size is zero.
    #[must_use]
    pub fn try_new(func: &[f64], nu: usize, nv: usize) -> Option<Self> {
        if nu == 0 || nv == 0 || func.len() != nu * nv {
            return None;
        }
        let conditional: Vec<Distribution1D> = func
            .chunks_exact(nu)
            .map(Distribution1D::try_new)
            .collect::<Option<Vec<_>>>()?;
        let marg: Vec<f64> = conditional.iter().map(Distribution1D::integral).collect();
        Some(Self {
            marginal: Distribution1D::try_new(&marg)?,
            conditional,
        })
    }

    /// Draws a point with the piecewise-constant density: (uv, pdf).
    #[must_use]
    pub fn sample_continuous(&self, u: DVec2) -> (DVec2, f64) {
        let (v, pdf_v, iv) = self.marginal.sample_continuous(u.y);
        let (x, pdf_u, _) = self.conditional[iv].sample_continuous(u.x);
        (DVec2::new(x, v), pdf_u * pdf_v)
    }

    /// Density at `uv` of [`Distribution2D::sample_continuous`].
    #[must_use]
    pub fn pdf(&self, uv: DVec2) -> f64 {
        let nv = self.marginal.len();
        let iv = ((uv.y * nv as f64) as usize).min(nv - 1);
        self.marginal.pdf(uv.y) * self.conditional[iv].pdf(uv.x)
    }
}

// ---------------------------------------------------------------------------
// Environment-map sampling
// ---------------------------------------------------------------------------

/// How the radiance of an [`EnvMap`] is read between texel centres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum EnvFilter {
    /// Piecewise constant: the value of the texel containing the direction
    /// (consistent with [`EnvSampler`] and with sums over texels).
    #[default]
    Nearest,
    /// [`EnvMap::eval`]: bilinear, continuous across seams.
    Bilinear,
}

/// One direction drawn by [`EnvSampler::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    /// World direction towards the environment (unit).
    pub wi: Vec3,
    /// Solid-angle density of `wi`.
    pub pdf: f32,
    /// The texel drawn.
    pub texel: usize,
}

/// Luminance importance sampling of an environment map on any [`Param`]
/// (see the module docs for the exact density).
#[derive(Clone, Debug)]
pub struct EnvSampler {
    param: Param,
    texels: Distribution1D,
    width: usize,
    height: usize,
}

/// Half-step of the central differences of `dir_from_uv`.
const JACOBIAN_STEP: f64 = 1e-6;

impl EnvSampler {
    /// Builds the texel distribution p_i ∝ luminance(L_i) · Ω_i. An all-black
    /// map gives a sampler whose [`EnvSampler::sample`] returns `None`.
    #[must_use]
    pub fn new(env: &EnvMap) -> Self {
        let param = env.param;
        let weights: Vec<f64> = env
            .texels
            .iter()
            .enumerate()
            .map(|(i, &l)| f64::from(luminance(l).max(0.0)) * param.texel_solid_angle(i))
            .collect();
        let texels = Distribution1D::try_new(&weights).unwrap_or_else(|| {
            Distribution1D::try_new(&[0.0]).expect("one bin") // empty map: never sampled
        });
        Self {
            param,
            texels,
            width: param.width(),
            height: param.height(),
        }
    }

    /// The parameterization sampled.
    #[must_use]
    pub fn param(&self) -> Param {
        self.param
    }

    /// True when the map has no luminance (nothing to sample).
    #[must_use]
    pub fn is_black(&self) -> bool {
        self.texels.integral() == 0.0
    }

    /// Probability of drawing texel `i`.
    #[must_use]
    pub fn texel_pmf(&self, i: usize) -> f64 {
        if self.is_black() {
            0.0
        } else {
            self.texels.discrete_pmf(i)
        }
    }

    /// Texel whose map rectangle contains `uv`.
    #[inline]
    #[must_use]
    pub fn texel_from_uv(&self, uv: DVec2) -> usize {
        let col = ((uv.x * self.width as f64) as usize).min(self.width - 1);
        let row = ((uv.y * self.height as f64) as usize).min(self.height - 1);
        row * self.width + col
    }

    /// Texel containing direction `d` (through `uv_from_dir`, consistent with
    /// the sampling rectangles).
    #[inline]
    #[must_use]
    pub fn texel_from_dir(&self, d: Vec3) -> usize {
        self.texel_from_uv(self.param.uv_from_dir(d.as_dvec3()))
    }

    /// Steradians per unit of map area at `uv`: |∂ω/∂u × ∂ω/∂v|. Analytic for
    /// lat-long (2π² sin θ) and cube maps (24 / (1 + a² + b²)^{3/2}); f64
    /// central differences of `dir_from_uv` for the octahedral maps, kept
    /// inside the texel's rectangle (the map is smooth there except on the
    /// octahedral fold lines).
    #[must_use]
    pub fn jacobian(&self, uv: DVec2) -> f64 {
        match self.param {
            Param::LatLong { .. } => {
                let s = (std::f64::consts::PI * uv.y).sin();
                2.0 * std::f64::consts::PI * std::f64::consts::PI * s
            }
            Param::Cube { .. } => {
                let fy = uv.y * 6.0;
                let face = fy.floor().clamp(0.0, 5.0);
                let a = 2.0 * uv.x - 1.0;
                let b = 2.0 * (fy - face) - 1.0;
                let r2 = 1.0 + a * a + b * b;
                24.0 / (r2 * r2.sqrt())
            }
            _ => self.jacobian_numerical(uv),
        }
    }

    /// [`EnvSampler::jacobian`] by central differences within the texel of `uv`.
    #[must_use]
    pub fn jacobian_numerical(&self, uv: DVec2) -> f64 {
        let h = JACOBIAN_STEP;
        let i = self.texel_from_uv(uv);
        let (lo, hi) = self.param.texel_uv_rect(i);
        let diff = |a: DVec2, b: DVec2| -> DVec3 {
            let span = (b - a).length();
            (self.param.dir_from_uv(b) - self.param.dir_from_uv(a)) / span
        };
        let cu = |x: f64| x.clamp(lo.x, hi.x);
        let cv = |x: f64| x.clamp(lo.y, hi.y);
        let du = diff(
            DVec2::new(cu(uv.x - h), uv.y),
            DVec2::new(cu(uv.x + h), uv.y),
        );
        let dv = diff(
            DVec2::new(uv.x, cv(uv.y - h)),
            DVec2::new(uv.x, cv(uv.y + h)),
        );
        du.cross(dv).length()
    }

    /// Draws a direction: texel by `u_texel`, position in the texel's map
    /// rectangle by `u_pos`. `None` for an all-black map.
    #[must_use]
    pub fn sample(&self, u_texel: f64, u_pos: Vec2) -> Option<EnvSample> {
        if self.is_black() {
            return None;
        }
        let (i, p, _) = self.texels.sample_discrete(u_texel);
        if p <= 0.0 {
            return None;
        }
        let (row, col) = (i / self.width, i % self.width);
        let uv = DVec2::new(
            (col as f64 + f64::from(u_pos.x)) / self.width as f64,
            (row as f64 + f64::from(u_pos.y)) / self.height as f64,
        );
        let wi = self.param.dir_from_uv(uv).normalize();
        let j = self.jacobian(uv);
        if j <= 0.0 || !j.is_finite() {
            return None;
        }
        let pdf = p * (self.width * self.height) as f64 / j;
        Some(EnvSample {
            wi: wi.as_vec3(),
            pdf: pdf as f32,
            texel: i,
        })
    }

    /// Solid-angle density of [`EnvSampler::sample`] producing direction `wi`.
    #[must_use]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.is_black() {
            return 0.0;
        }
        let uv = self.param.uv_from_dir(wi.as_dvec3());
        self.density(uv, self.texel_from_uv(uv))
    }

    /// Solid-angle density at map coordinates `uv` inside `texel`:
    /// p_texel / (A_texel · J(uv)) (see the module docs).
    fn density(&self, uv: DVec2, texel: usize) -> f32 {
        let p = self.texels.discrete_pmf(texel);
        if p <= 0.0 {
            return 0.0;
        }
        let j = self.jacobian(uv);
        if j <= 0.0 {
            0.0
        } else {
            (p * (self.width * self.height) as f64 / j) as f32
        }
    }

    /// Radiance of `env` in direction `d` read with `filter` (`Nearest` uses
    /// the same texel rectangles as the sampler).
    #[inline]
    #[must_use]
    pub fn radiance(&self, env: &EnvMap, d: Vec3, filter: EnvFilter) -> Vec3 {
        match filter {
            EnvFilter::Nearest => env.texels[self.texel_from_dir(d)],
            EnvFilter::Bilinear => env.eval(d),
        }
    }

    /// Radiance (as [`EnvSampler::radiance`]) and [`EnvSampler::pdf`] of
    /// direction `d`, locating the texel once.
    #[inline]
    #[must_use]
    pub fn radiance_and_pdf(&self, env: &EnvMap, d: Vec3, filter: EnvFilter) -> (Vec3, f32) {
        let uv = self.param.uv_from_dir(d.as_dvec3());
        let i = self.texel_from_uv(uv);
        let l = match filter {
            EnvFilter::Nearest => env.texels[i],
            EnvFilter::Bilinear => env.eval(d),
        };
        if self.is_black() {
            return (l, 0.0);
        }
        (l, self.density(uv, i))
    }

    /// Radiance of a sample drawn by [`EnvSampler::sample`] (its texel is known).
    #[inline]
    #[must_use]
    pub fn sample_radiance(&self, env: &EnvMap, s: &EnvSample, filter: EnvFilter) -> Vec3 {
        match filter {
            EnvFilter::Nearest => env.texels[s.texel],
            EnvFilter::Bilinear => env.eval(s.wi),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_deterministic_and_uniform() {
        let mut a = Rng::new(42, 7);
        let mut b = Rng::new(42, 7);
        let mut c = Rng::new(42, 8);
        let xs: Vec<u32> = (0..100).map(|_| a.next_u32()).collect();
        let ys: Vec<u32> = (0..100).map(|_| b.next_u32()).collect();
        let zs: Vec<u32> = (0..100).map(|_| c.next_u32()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs, "streams differ");
        assert_ne!(Rng::for_sample(1, 2, 3), Rng::for_sample(1, 3, 2));
        // Mean and variance of U[0,1).
        let mut r = Rng::for_sample(9, 0, 0);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = f64::from(r.next_f32());
            assert!((0.0..1.0).contains(&x));
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!((mean - 0.5).abs() < 0.003, "mean {mean} vs 0.5");
        assert!(
            (var - 1.0 / 12.0).abs() < 0.002,
            "variance {var} vs {}",
            1.0 / 12.0
        );
    }

    #[test]
    fn warps_round_trip_and_stay_on_the_sphere() {
        let mut r = Rng::new(5, 0);
        for _ in 0..2000 {
            let u = r.next_2d();
            let w = sample_cosine_hemisphere(u);
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            let u2 = invert_cosine_hemisphere_sample(w);
            assert!((u - u2).length() < 2e-3, "cosine {u:?} -> {u2:?}");
            let w = sample_uniform_sphere(u);
            assert!((w.length() - 1.0).abs() < 1e-5);
            let u2 = invert_uniform_sphere_sample(w);
            assert!((u - u2).length() < 1e-3, "sphere {u:?} -> {u2:?}");
            assert!((sample_uniform_hemisphere(u).length() - 1.0).abs() < 1e-5);
        }
    }

    /// E[g(ω)/pdf(ω)] = ∫ g: checks each warp's density against a known integral.
    #[test]
    fn warp_pdfs_integrate_known_functions() {
        let mut r = Rng::new(11, 0);
        let n = 200_000;
        let (mut cos_est, mut sph_est, mut hemi_est) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..n {
            // ∫_H cos³θ dω = π/2 ... estimate with cosine sampling: cos³/ (cos/π) = π cos².
            let w = sample_cosine_hemisphere(r.next_2d());
            if w.z > 0.0 {
                cos_est += f64::from(w.z.powi(3) / cosine_hemisphere_pdf(w.z));
            }
            // ∫_S z² dω = 4π/3.
            let w = sample_uniform_sphere(r.next_2d());
            sph_est += f64::from(w.z * w.z / uniform_sphere_pdf());
            // ∫_H z dω = π.
            let w = sample_uniform_hemisphere(r.next_2d());
            hemi_est += f64::from(w.z / uniform_hemisphere_pdf());
        }
        let pi = std::f64::consts::PI;
        let checks = [
            (cos_est / n as f64, pi / 2.0),
            (sph_est / n as f64, 4.0 * pi / 3.0),
            (hemi_est / n as f64, pi),
        ];
        for (est, exact) in checks {
            assert!(
                (est - exact).abs() < 0.01 * exact,
                "Monte Carlo {est} vs exact {exact}"
            );
        }
    }

    #[test]
    fn distribution_1d_samples_its_pdf() {
        let f = [0.0, 1.0, 3.0, 0.0, 4.0, 2.0];
        let d = Distribution1D::try_new(&f).unwrap();
        assert!((d.integral() - 10.0 / 6.0).abs() < 1e-12);
        let total: f64 = (0..f.len()).map(|i| d.discrete_pmf(i)).sum();
        assert!((total - 1.0).abs() < 1e-12);
        let mut counts = [0usize; 6];
        let mut r = Rng::new(3, 3);
        let n = 100_000;
        for _ in 0..n {
            let (x, pdf, i) = d.sample_continuous(r.next_f64());
            assert!((0.0..1.0).contains(&x));
            assert_eq!(i, (x * 6.0) as usize);
            assert!((pdf - d.pdf(x)).abs() < 1e-9, "pdf {pdf} vs {}", d.pdf(x));
            counts[i] += 1;
        }
        for i in 0..6 {
            let expected = f[i] / 10.0;
            let got = counts[i] as f64 / n as f64;
            assert!(
                (got - expected).abs() < 0.01,
                "bin {i}: frequency {got} vs probability {expected}"
            );
        }
        // All-zero input: uniform, zero integral.
        let z = Distribution1D::try_new(&[0.0; 4]).unwrap();
        assert_eq!(z.integral(), 0.0);
        assert!((z.discrete_pmf(2) - 0.25).abs() < 1e-12);
        assert!(Distribution1D::try_new(&[]).is_none());
    }

    #[test]
    fn distribution_2d_pdf_integrates_to_one_and_matches_samples() {
        let (nu, nv) = (8, 4);
        let f: Vec<f64> = (0..nu * nv).map(|i| ((i * 7919) % 13) as f64).collect();
        let d = Distribution2D::try_new(&f, nu, nv).unwrap();
        // ∫ pdf = Σ pdf(centre) · cell area.
        let mut integral = 0.0;
        for v in 0..nv {
            for u in 0..nu {
                integral += d.pdf(DVec2::new(
                    (u as f64 + 0.5) / nu as f64,
                    (v as f64 + 0.5) / nv as f64,
                )) / (nu * nv) as f64;
            }
        }
        assert!((integral - 1.0).abs() < 1e-12, "∫pdf = {integral}");
        let total: f64 = f.iter().sum();
        let mut counts = vec![0usize; nu * nv];
        let mut r = Rng::new(4, 4);
        let n = 200_000;
        for _ in 0..n {
            let (uv, pdf) = d.sample_continuous(DVec2::new(r.next_f64(), r.next_f64()));
            assert!((pdf - d.pdf(uv)).abs() < 1e-9 * pdf.max(1.0));
            counts[(uv.y * nv as f64) as usize * nu + (uv.x * nu as f64) as usize] += 1;
        }
        for i in 0..nu * nv {
            let p = f[i] / total;
            let got = counts[i] as f64 / n as f64;
            assert!(
                (got - p).abs() < 4.0 * (p * (1.0 - p) / n as f64).sqrt() + 1e-4,
                "cell {i}: {got} vs {p}"
            );
        }
        assert!(Distribution2D::try_new(&f, 3, 3).is_none());
    }

    /// A high-dynamic-range test map: sky gradient plus a small, very bright sun.
    fn sun_env(param: Param) -> EnvMap {
        let sun = Vec3::new(0.3, 0.8, 0.5).normalize();
        EnvMap::from_fn(param, |d| {
            let sky = Vec3::new(0.2, 0.3, 0.6) * (1.0 + d.y).max(0.05);
            if d.dot(sun) > 0.995 {
                sky + Vec3::splat(500.0)
            } else {
                sky
            }
        })
    }

    fn params() -> [Param; 4] {
        [
            Param::LatLong {
                width: 64,
                height: 32,
            },
            Param::Cube { n: 16 },
            Param::Octahedral { n: 32 },
            Param::Octahedral { n: 31 },
        ]
    }

    #[test]
    fn env_jacobian_is_exact() {
        for param in params() {
            let s = EnvSampler::new(&sun_env(param));
            // Σ over texels of ∫ J du dv (midpoint quadrature on a fine sub-grid) = 4π,
            // and the analytic Jacobians agree with finite differences.
            let mut r = Rng::new(1, 1);
            for _ in 0..500 {
                let uv = DVec2::new(r.next_f64(), r.next_f64());
                let (a, b) = (s.jacobian(uv), s.jacobian_numerical(uv));
                assert!(
                    (a - b).abs() < 1e-5 * a.max(1e-3),
                    "{param:?} uv {uv:?}: analytic {a} vs numerical {b}"
                );
            }
            for i in [0, param.len() / 3, param.len() / 2 + 1, param.len() - 1] {
                let (lo, hi) = param.texel_uv_rect(i);
                let k = 16;
                let mut acc = 0.0;
                for a in 0..k {
                    for b in 0..k {
                        let uv = lo
                            + (hi - lo)
                                * DVec2::new(
                                    (a as f64 + 0.5) / k as f64,
                                    (b as f64 + 0.5) / k as f64,
                                );
                        acc += s.jacobian(uv);
                    }
                }
                let area = (hi - lo).x * (hi - lo).y;
                let quad = acc / (k * k) as f64 * area;
                let exact = param.texel_solid_angle(i);
                assert!(
                    (quad - exact).abs() < 2e-3 * exact,
                    "{param:?} texel {i}: ∫J = {quad} vs Ω = {exact}"
                );
            }
        }
    }

    /// ∫ pdf dω = 1 and E[1/pdf] = total solid angle of the support.
    #[test]
    fn env_pdf_integrates_to_one() {
        for param in params() {
            let env = sun_env(param);
            let s = EnvSampler::new(&env);
            // Quadrature on a fine lat-long grid of a different parameterization.
            let q = Param::LatLong {
                width: 1024,
                height: 512,
            };
            let integral: f64 = (0..q.len())
                .map(|i| f64::from(s.pdf(q.dir_from_texel(i))) * q.texel_solid_angle(i))
                .sum();
            assert!(
                (integral - 1.0).abs() < 0.01,
                "{param:?}: ∫pdf dω = {integral} (expected 1)"
            );
            // Sampled pdfs agree with pdf(wi).
            let mut r = Rng::new(2, 2);
            for _ in 0..2000 {
                let e = s.sample(r.next_f64(), r.next_2d()).unwrap();
                let p = s.pdf(e.wi);
                let (l, p2) = s.radiance_and_pdf(&env, e.wi, EnvFilter::Nearest);
                assert_eq!(p, p2);
                assert_eq!(
                    l,
                    s.sample_radiance(&env, &e, EnvFilter::Nearest),
                    "{param:?}: sampled texel"
                );
                assert!(
                    (e.pdf - p).abs() <= 1e-3 * e.pdf,
                    "{param:?}: sample pdf {} vs pdf(wi) {p}",
                    e.pdf
                );
            }
        }
    }

    /// Histogram of sampled directions over coarse lat-long bins vs ∫_bin pdf.
    #[test]
    fn env_samples_follow_pdf() {
        let bins = Param::LatLong {
            width: 16,
            height: 8,
        };
        for param in params() {
            let s = EnvSampler::new(&sun_env(param));
            let fine = Param::LatLong {
                width: 512,
                height: 256,
            };
            let mut expected = vec![0.0f64; bins.len()];
            for i in 0..fine.len() {
                let d = fine.dir_from_texel(i);
                expected[bins.texel_from_dir(d)] += f64::from(s.pdf(d)) * fine.texel_solid_angle(i);
            }
            let n = 200_000;
            let mut counts = vec![0usize; bins.len()];
            let mut r = Rng::new(8, 8);
            for _ in 0..n {
                let e = s.sample(r.next_f64(), r.next_2d()).unwrap();
                counts[bins.texel_from_dir(e.wi)] += 1;
            }
            for b in 0..bins.len() {
                let p = expected[b];
                let got = counts[b] as f64 / n as f64;
                let sigma = (p * (1.0 - p) / n as f64).sqrt();
                assert!(
                    (got - p).abs() < 5.0 * sigma + 0.004 * p + 2e-4,
                    "{param:?} bin {b}: frequency {got} vs ∫pdf {p}"
                );
            }
        }
    }

    /// With `Nearest` radiance, E[L/pdf · cos] under env sampling equals the
    /// texel quadrature Σ L_i ∫ cos — here checked against Σ L_i cos(centre) Ω_i.
    #[test]
    fn env_sampling_estimates_irradiance() {
        let param = Param::LatLong {
            width: 128,
            height: 64,
        };
        let env = sun_env(param);
        let s = EnvSampler::new(&env);
        let n = Vec3::new(0.2, 0.9, -0.1).normalize();
        let quad: f64 = (0..param.len())
            .map(|i| {
                f64::from(luminance(env.texels[i]))
                    * f64::from(param.dir_from_texel(i).dot(n).max(0.0))
                    * param.texel_solid_angle(i)
            })
            .sum();
        let mut r = Rng::new(6, 6);
        let m = 200_000;
        let mut est = 0.0f64;
        for _ in 0..m {
            let e = s.sample(r.next_f64(), r.next_2d()).unwrap();
            let l = luminance(s.radiance(&env, e.wi, EnvFilter::Nearest));
            est += f64::from(l * e.wi.dot(n).max(0.0) / e.pdf);
        }
        est /= m as f64;
        assert!(
            (est - quad).abs() < 0.01 * quad,
            "env-sampled irradiance {est} vs quadrature {quad}"
        );
    }

    #[test]
    fn black_env_is_never_sampled() {
        let env = EnvMap::try_new(
            Param::LatLong {
                width: 8,
                height: 4,
            },
            vec![Vec3::ZERO; 32],
        )
        .unwrap();
        let s = EnvSampler::new(&env);
        assert!(s.is_black());
        assert!(s.sample(0.5, Vec2::splat(0.5)).is_none());
        assert_eq!(s.pdf(Vec3::Y), 0.0);
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0f32, 2.0f32), (0.0, 3.0), (5.0, 0.0), (1e-20, 1e20)] {
            let s = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((s - 1.0).abs() < 1e-6, "{a} {b}: {s}");
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}
