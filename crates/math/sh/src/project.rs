//! Projection onto SH, reconstruction, and ringing windows.
//!
//! # Projection
//! `f_i = ∫ f(ω) y_i(ω) dω ≈ Σ_texels f(d_t) y_i(d_t) Ω_t` with the **exact**
//! solid angle `Ω_t` of every texel ([`relight_sphere::Param::texel_solid_angle`]),
//! per colour channel, accumulated in f64 ([`project_samples`], [`project_env`]).
//!
//! # Lat-long fast path ([`LatLongProjector`])
//! A lat-long map is a product grid: every row is a circle of constant polar
//! angle about world +Y, every column a constant azimuth. In a local frame whose
//! pole is world +Y, `y_{l,±m}(θ,φ) = Q̃_l^m(θ)·(cos mφ | sin mφ)`, so
//! `f_{l,±m} = Σ_rows Ω_row Q̃_l^m(θ_row) · Σ_cols f(row,col)(cos mφ_col | sin mφ_col)`:
//! one Fourier sum per row and `m` (the `cos mφ / sin mφ` table is built once per
//! grid; the row sum is a contiguous dot product over the interleaved RGB texels),
//! then associated Legendre values down the columns. Cost `O(W H n + H n²)`
//! instead of `O(W H n²)`. The local coefficients are finally rotated to the
//! world frame with the exact Ivanic–Ruedenberg matrix of the fixed frame change.
//! The grid geometry (row directions, column azimuths, row solid angles) is read
//! from the `Param` itself, so the fast path needs no assumption about its
//! azimuth convention.
//!
//! # Windows ([`Window`])
//! Ringing (Gibbs) suppression multiplies band `l` by `h_l`: Hanning
//! `h_l = (1 + cos(π l / w))/2` for `l ≤ w` (0 beyond), Lanczos
//! `h_l = sinc(π l / w)`, and Sloan's Gaussian-like window
//! `h_l = 1 / (1 + λ (l(l+1))²)` (Sloan 2008/2017, minimising the Laplacian
//! energy of the reconstruction). Off by default ([`Window::None`]); every
//! projection result records the window it used ([`ShRgb::window`]).

use crate::basis::eval_sh_into;
use crate::rotation::{IvanicRuedenberg, Rot3, ShRotation};
use crate::{MAX_ORDER, ShError, check_order};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use relight_sphere::{EnvMap, Param};

/// A ringing-suppression window applied per band (off by default).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Window {
    /// No windowing (`h_l = 1`).
    #[default]
    None,
    /// Hanning: `h_l = (1 + cos(π l / width))/2` for `l ≤ width`, else 0.
    Hanning { width: f64 },
    /// Lanczos σ-factors: `h_l = sin(π l / width)/(π l / width)` for `l < width`, else 0.
    Lanczos { width: f64 },
    /// Sloan's Gaussian-like window `h_l = 1/(1 + λ (l(l+1))²)`.
    Sloan { lambda: f64 },
}

impl Window {
    /// The factor `h_l` for band `l`.
    #[must_use]
    pub fn factor(&self, l: usize) -> f64 {
        let lf = l as f64;
        match *self {
            Window::None => 1.0,
            Window::Hanning { width } => {
                if lf <= width {
                    0.5 * (1.0 + (std::f64::consts::PI * lf / width).cos())
                } else {
                    0.0
                }
            }
            Window::Lanczos { width } => {
                if l == 0 {
                    1.0
                } else if lf < width {
                    let x = std::f64::consts::PI * lf / width;
                    x.sin() / x
                } else {
                    0.0
                }
            }
            Window::Sloan { lambda } => 1.0 / (1.0 + lambda * (lf * (lf + 1.0)).powi(2)),
        }
    }

    /// Validates the parameter (width > 0, λ ≥ 0, finite).
    pub fn validate(&self) -> Result<(), ShError> {
        let bad = |why: &str| {
            Err(ShError::InvalidParameter {
                what: "window",
                why: why.to_string(),
            })
        };
        match *self {
            Window::None => Ok(()),
            Window::Hanning { width } | Window::Lanczos { width } => {
                if width.is_finite() && width > 0.0 {
                    Ok(())
                } else {
                    bad("width must be a positive number of bands")
                }
            }
            Window::Sloan { lambda } => {
                if lambda.is_finite() && lambda >= 0.0 {
                    Ok(())
                } else {
                    bad("lambda must be finite and ≥ 0")
                }
            }
        }
    }

    /// A short description for output headers, e.g. `hanning(width=6)`.
    #[must_use]
    pub fn describe(&self) -> String {
        match *self {
            Window::None => "none".to_string(),
            Window::Hanning { width } => format!("hanning(width={width})"),
            Window::Lanczos { width } => format!("lanczos(width={width})"),
            Window::Sloan { lambda } => format!("sloan(lambda={lambda})"),
        }
    }

    /// Multiplies every band of `c` (`order²` coefficients) by `h_l`.
    pub fn apply<T: crate::Real>(&self, order: usize, c: &mut [T]) {
        if *self == Window::None {
            return;
        }
        for l in 0..order {
            let h = T::from_f64(self.factor(l));
            for v in &mut c[l * l..(l + 1) * (l + 1)] {
                *v *= h;
            }
        }
    }
}

/// RGB SH coefficients, one `order²` vector per channel (SoA, f32), in the
/// convention of the crate docs. `window` records the window applied.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShRgb {
    pub order: usize,
    /// `[r, g, b]`, each `order²` coefficients at index `l(l+1)+m`.
    pub channels: [Vec<f32>; 3],
    pub window: Window,
}

impl ShRgb {
    /// All-zero coefficients.
    pub fn zeros(order: usize) -> Result<Self, ShError> {
        check_order("order", order, MAX_ORDER)?;
        let z = vec![0.0; order * order];
        Ok(Self {
            order,
            channels: [z.clone(), z.clone(), z],
            window: Window::None,
        })
    }

    /// From three channels; checks lengths and finiteness.
    pub fn try_from_channels(order: usize, channels: [Vec<f32>; 3]) -> Result<Self, ShError> {
        for (c, what) in channels.iter().zip(["red", "green", "blue"]) {
            crate::check_coeffs(what, order, c)?;
        }
        Ok(Self {
            order,
            channels,
            window: Window::None,
        })
    }

    /// Checks a deserialised value: order in range, three channels of `order²`
    /// finite coefficients, valid window (use after reading a coefficient file).
    pub fn validate(&self) -> Result<(), ShError> {
        for (c, what) in self.channels.iter().zip(["red", "green", "blue"]) {
            crate::check_coeffs(what, self.order, c)?;
        }
        self.window.validate()
    }

    /// The coefficients rotated by an exact SH rotation (all channels).
    ///
    /// # Panics
    /// If `rot.order() > self.order`.
    #[must_use]
    pub fn rotated(&self, rot: &ShRotation<f32>) -> Self {
        let mut out = self.clone();
        for (o, s) in out.channels.iter_mut().zip(&self.channels) {
            rot.apply(s, o);
        }
        out
    }

    /// `Σ_i c_i y_i(d)` per channel at a unit direction.
    #[must_use]
    pub fn eval(&self, d: Vec3) -> Vec3 {
        let n = self.order;
        let mut y = [0.0f32; MAX_ORDER * MAX_ORDER];
        eval_sh_into(n, d.to_array(), &mut y);
        let dot = |c: &[f32]| c.iter().zip(&y[..n * n]).map(|(a, b)| a * b).sum::<f32>();
        Vec3::new(
            dot(&self.channels[0]),
            dot(&self.channels[1]),
            dot(&self.channels[2]),
        )
    }

    /// Applies a window (recorded in `self.window`; windows compose multiplicatively,
    /// so only apply one).
    pub fn apply_window(&mut self, w: Window) -> Result<(), ShError> {
        w.validate()?;
        for c in &mut self.channels {
            w.apply(self.order, c);
        }
        self.window = w;
        Ok(())
    }

    /// The leading `order` bands (truncation), or an error if `order` exceeds ours.
    pub fn truncated(&self, order: usize) -> Result<Self, ShError> {
        check_order("order", order, self.order)?;
        Ok(Self {
            order,
            channels: self.channels.clone().map(|mut c| {
                c.truncate(order * order);
                c
            }),
            window: self.window,
        })
    }
}

/// Projects samples `values[k]` at unit directions `dirs[k]` with quadrature
/// weights `weights[k]` (steradians) onto `order` bands. f64 accumulation,
/// parallel over chunks (rayon).
pub fn project_samples(
    order: usize,
    dirs: &[Vec3],
    weights: &[f32],
    values: &[Vec3],
) -> Result<ShRgb, ShError> {
    check_order("order", order, MAX_ORDER)?;
    if dirs.len() != weights.len() || dirs.len() != values.len() {
        return Err(ShError::InvalidParameter {
            what: "samples",
            why: format!(
                "dirs ({}), weights ({}) and values ({}) must have equal length",
                dirs.len(),
                weights.len(),
                values.len()
            ),
        });
    }
    let nn = order * order;
    let acc = (0..dirs.len())
        .into_par_iter()
        .with_min_len(4096)
        .fold(
            || (vec![0.0f64; 3 * nn], vec![0.0f32; nn]),
            |(mut acc, mut y), k| {
                eval_sh_into(order, dirs[k].to_array(), &mut y);
                let v = values[k] * weights[k];
                let (r, g, b) = (v.x as f64, v.y as f64, v.z as f64);
                for i in 0..nn {
                    let yi = y[i] as f64;
                    acc[i] += r * yi;
                    acc[nn + i] += g * yi;
                    acc[2 * nn + i] += b * yi;
                }
                (acc, y)
            },
        )
        .map(|(a, _)| a)
        .reduce(
            || vec![0.0f64; 3 * nn],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
                a
            },
        );
    let ch = |c: usize| {
        acc[c * nn..(c + 1) * nn]
            .iter()
            .map(|&v| v as f32)
            .collect::<Vec<_>>()
    };
    let out = ShRgb {
        order,
        channels: [ch(0), ch(1), ch(2)],
        window: Window::None,
    };
    crate::check_finite(
        "projected coefficients (input map has NaN/inf texels?)",
        &out.channels[0],
    )?;
    crate::check_finite(
        "projected coefficients (input map has NaN/inf texels?)",
        &out.channels[1],
    )?;
    crate::check_finite(
        "projected coefficients (input map has NaN/inf texels?)",
        &out.channels[2],
    )?;
    Ok(out)
}

/// The unwindowed projection ([`project_env`]) of the last environment map
/// asked for, kept by the map's fingerprint ([`EnvMap::fingerprint`]) and
/// the order: a method that keeps one projects a map once, and a lighting
/// change that only turns the map (`world_from_env`, applied in the SH
/// domain) or moves its lights reads the kept coefficients.
#[derive(Clone, Debug, Default)]
pub struct EnvProjection {
    kept: Option<(u64, ShRgb)>,
}

impl EnvProjection {
    /// The projection of `map` at `order` bands (in the map's own frame),
    /// and whether it was computed by this call (`false`: kept from the
    /// last, for the same texels and order).
    ///
    /// # Errors
    /// As [`project_env`] (the cache then holds nothing).
    pub fn project(&mut self, map: &EnvMap, order: usize) -> Result<(&ShRgb, bool), ShError> {
        let fingerprint = map.fingerprint();
        let fresh = !matches!(&self.kept, Some((f, sh)) if *f == fingerprint && sh.order == order);
        if fresh {
            self.kept = None;
            self.kept = Some((fingerprint, project_env(map, order, Window::None)?));
        }
        let (_, sh) = self.kept.as_ref().expect("kept above");
        Ok((sh, fresh))
    }

    /// The fingerprint of the map last projected (`None` before any).
    #[must_use]
    pub fn fingerprint(&self) -> Option<u64> {
        self.kept.as_ref().map(|(f, _)| *f)
    }

    /// The last projection (`None` before any).
    #[must_use]
    pub fn last(&self) -> Option<&ShRgb> {
        self.kept.as_ref().map(|(_, sh)| sh)
    }
}

/// Projects an environment map in any parameterization (exact texel solid
/// angles), with the lat-long fast path where it applies, then applies `window`.
///
/// The map is read as piecewise constant (each texel its value over its
/// whole solid angle). Where its texels are coarse for `order` bands
/// ([`texel_subsamples`] > 1), each texel is split into `k × k` uv
/// sub-rectangles, each with its exact solid angle, so that the harmonics
/// are integrated over the texel rather than read at its centre: a constant
/// 8 × 4 map projected by texel centres alone has band-2 coefficients of a
/// few per cent of band 0, which the split removes.
pub fn project_env(map: &EnvMap, order: usize, window: Window) -> Result<ShRgb, ShError> {
    check_order("order", order, MAX_ORDER)?;
    window.validate()?;
    let k = texel_subsamples(&map.param, order);
    let mut out = match map.param {
        _ if k > 1 => project_subsampled(map, order, k)?,
        Param::LatLong { .. } => LatLongProjector::new(map.param, order)?.project(&map.texels)?,
        p => project_samples(order, &p.directions(), &p.solid_angles(), &map.texels)?,
    };
    out.apply_window(window)?;
    Ok(out)
}

/// Sub-samples per texel side for [`project_env`] at `order` bands: 1 when
/// the texel-centre rule is accurate, more for coarse maps. A texel spans
/// `h ≈ π / √(texels / 2)` radians (a lat-long map's row height); the
/// centre rule integrates a band-`l` harmonic over it with relative error
/// about `(l h)² / 24`, so `k = ⌈(order · h) / 0.155⌉` keeps that below
/// 10⁻³ for every band (capped at 32). Maps of 256 rows and more at order 8
/// (every shipped probe) take 1, the centre rule unchanged.
#[must_use]
pub fn texel_subsamples(param: &Param, order: usize) -> usize {
    let per_pi = (param.len() as f64 / 2.0).sqrt().max(1.0);
    let h = std::f64::consts::PI / per_pi;
    ((order as f64 * h / 0.155).ceil() as usize).clamp(1, 32)
}

/// [`project_env`]'s rule for coarse maps: every texel as `k × k` uv
/// sub-rectangles, read at their centres with their exact solid angles.
fn project_subsampled(map: &EnvMap, order: usize, k: usize) -> Result<ShRgb, ShError> {
    let p = map.param;
    let n = p.len() * k * k;
    let (mut dirs, mut weights, mut values) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for (i, &value) in map.texels.iter().enumerate().take(p.len()) {
        let (lo, hi) = p.texel_uv_rect(i);
        let step = (hi - lo) / k as f64;
        for a in 0..k {
            for b in 0..k {
                let min = lo + step * glam::DVec2::new(a as f64, b as f64);
                let max = min + step;
                dirs.push(p.dir_from_uv((min + max) * 0.5).as_vec3());
                weights.push(p.uv_rect_solid_angle(min, max) as f32);
                values.push(value);
            }
        }
    }
    project_samples(order, &dirs, &weights, &values)
}

/// `∫ f y_i dω` of a scalar f64 function by a product quadrature rule.
#[must_use]
pub fn project_fn(
    order: usize,
    q: &crate::quadrature::SphereQuadrature,
    f: impl Fn(DVec3) -> f64,
) -> Vec<f64> {
    let nn = order * order;
    let mut out = vec![0.0; nn];
    let mut y = vec![0.0; nn];
    for (d, w) in q.dirs.iter().zip(&q.weights) {
        let v = f(*d) * w;
        if v == 0.0 {
            continue;
        }
        eval_sh_into(order, d.to_array(), &mut y);
        out.iter_mut().zip(&y).for_each(|(o, y)| *o += v * y);
    }
    out
}

/// Reconstructs `Σ c_i y_i` at every texel centre of `param` (parallel).
#[must_use]
pub fn reconstruct(c: &ShRgb, param: Param) -> EnvMap {
    let texels = (0..param.len())
        .into_par_iter()
        .map(|i| c.eval(param.dir_from_texel(i)))
        .collect();
    EnvMap { param, texels }
}

/// The lat-long fast projector of one grid and order (build once, project many).
///
/// Per row (a circle of constant polar angle about world +Y) it forms the
/// Fourier sums `F_m = Σ_j f_j (cos mφ_j, sin mφ_j)` for `m < order` (φ_j: the
/// column azimuth in the local frame whose pole is world +Y, radians), then
/// accumulates `Ω_row Q̃_l^m(θ_row) F_m` in f64 and finally rotates the local
/// coefficients to world (see the module docs).
///
/// # Symmetry fold (a truncated decimation-in-frequency FFT)
/// When the columns are uniformly spaced (checked at build time, to 1e-6 rad),
/// `φ_{j+W/2} = φ_j + π` gives `e^{im(φ_j+π)} = (−1)^m e^{imφ_j}`, so odd `m`
/// sum `d¹_j = f_j − f_{j+W/2}` and even `m` sum `x¹_j = f_j + f_{j+W/2}` over
/// `W/2` columns. Folding `x^{k−1}` (length `L`, spacing `Δ = π/2^{k−1}` between
/// its halves) again gives `d^k` for `m = 2^{k−1}·odd` (`e^{imΔ} = −1`) and `x^k`
/// for `m ≡ 0 mod 2^k` (`e^{imΔ} = 1`), as long as `L` is even and the check
/// holds. `m` with 2-adic valuation `v` then sums `d^{v+1}` (`W/2^{v+1}`
/// columns), the rest (and `m = 0`) the last `x^K`: about `0.67·W·n` instead of
/// `2·W·n` multiply-adds per row and channel. With `K = 0` (odd width, or
/// non-uniform columns) this is the direct sum over all columns.
///
/// # North/south pairing
/// When row `H−1−r` mirrors row `r` (`z ↦ −z`, equal solid angle; checked to
/// 1e-6), `Q̃_l^m(−z) = (−1)^{l+m} Q̃_l^m(z)` lets both rows share one pass of
/// the Legendre accumulation with `F_r ± F_{H−1−r}`.
///
/// The sums run in f32 (RGB interleaved, 24 lanes) with FMA where the CPU has
/// AVX2+FMA (`crate::lanes::avx2_fma_available`); [`Self::project_direct`] is
/// the unfolded, unpaired reference.
#[derive(Clone, Debug)]
pub struct LatLongProjector {
    order: usize,
    width: usize,
    height: usize,
    /// `(cos φ_j, sin φ_j)` of every column (local frame, taken on the middle row).
    col_cs: Vec<[f64; 2]>,
    /// Number of symmetry folds `K` in use (0: direct sums): the valid ones,
    /// at most `⌊log2(order − 1)⌋ + 1`.
    levels: usize,
    /// Per m: offset (f32s) of its source row in the scratch buffer, and its length `3·cols`.
    src: Vec<(usize, usize)>,
    /// Per m: offset of its tables in `tab`: `cos(mφ_j)` ×3 then `sin(mφ_j)` ×3, `j < cols`.
    tab_off: Vec<usize>,
    tab: Vec<f32>,
    /// Groups of one or two m sharing a source (one pass over the source each).
    groups: Vec<(usize, [usize; 2])>,
    /// Rows processed as units: `(r, Some(mirror))` or `(r, None)`.
    units: Vec<(usize, Option<usize>)>,
    /// Per row: `Ω_row · y_{l,m}(θ_row, φ=0)` for `m ≥ 0`, m-major (`m`, then `l = m..n`).
    row_y: Vec<f32>,
    /// The same values per pair `p` then unit `u` (the unit's first row), as f64: `[p·U + u]`.
    unit_y: Vec<f64>,
    /// Coefficients of the local (pole = world +Y) frame → world frame.
    world_from_local: ShRotation<f64>,
}

/// Number of `(m, l)` pairs with `0 ≤ m ≤ l < n`.
const fn pairs(n: usize) -> usize {
    n * (n + 1) / 2
}

impl LatLongProjector {
    /// The projector for a `Param::LatLong` grid (error for other parameterizations).
    pub fn new(param: Param, order: usize) -> Result<Self, ShError> {
        let Param::LatLong { width, height } = param else {
            return Err(ShError::InvalidParameter {
                what: "param",
                why: format!("LatLongProjector needs a LatLong map, got {param:?}"),
            });
        };
        Self::from_layout(
            order,
            width,
            height,
            |r, c| param.dir_from_texel(r * width + c),
            |r| param.texel_solid_angle(r * width),
        )
    }

    /// A projector for any product grid whose rows are circles about world +Y:
    /// `dir(row, col)` gives texel centres, `solid_angle(row)` the (exact)
    /// solid angle of each texel in a row (steradians).
    pub fn from_layout(
        order: usize,
        width: usize,
        height: usize,
        dir: impl Fn(usize, usize) -> Vec3,
        solid_angle: impl Fn(usize) -> f64,
    ) -> Result<Self, ShError> {
        check_order("order", order, MAX_ORDER)?;
        if width == 0 || height == 0 {
            return Err(ShError::InvalidParameter {
                what: "param",
                why: "empty lat-long grid".into(),
            });
        }
        let n = order;
        // Local frame: x' = world Z, y' = world X, z' = world Y (a cyclic, proper rotation).
        let local = |d: Vec3| DVec3::new(d.z as f64, d.x as f64, d.y as f64);
        let mid = height / 2;
        let col_cs: Vec<[f64; 2]> = (0..width)
            .map(|j| {
                let d = local(dir(mid, j));
                let h = d.x.hypot(d.y);
                if h > 0.0 {
                    [d.x / h, d.y / h]
                } else {
                    [1.0, 0.0]
                }
            })
            .collect();
        // Folds past the deepest d^k some m < n reads (m ≤ n − 1 has 2-adic
        // valuation ≤ ⌊log2(n − 1)⌋) would only serve m = 0 through short,
        // scalar loops: stop there.
        let needed = if n <= 1 {
            0
        } else {
            (n - 1).ilog2() as usize + 1
        };
        let levels = fold_levels(&col_cs).min(needed);
        // Sources: d^k at Σ_{i<k} 3W/2^i in the first 3W f32s, x^K after 3W.
        let n3 = 3 * width;
        let d_off = |k: usize| (1..k).map(|i| n3 >> i).sum::<usize>();
        let x_src = (n3 + d_off(levels), n3 >> levels);
        let mut src = Vec::with_capacity(n);
        let mut tab_off = Vec::with_capacity(n);
        let mut tab = Vec::new();
        for m in 0..n {
            let v = if m == 0 {
                usize::MAX
            } else {
                m.trailing_zeros() as usize
            };
            let s = if v < levels {
                (d_off(v + 1), n3 >> (v + 1))
            } else {
                x_src
            };
            src.push(s);
            tab_off.push(tab.len());
            let cols = s.1 / 3;
            let (mut cos, mut sin) = (Vec::with_capacity(s.1), Vec::with_capacity(s.1));
            for &[c1, s1] in &col_cs[..cols] {
                let (c, s) = cos_sin_m(m, c1, s1);
                for _ in 0..3 {
                    cos.push(c as f32);
                    sin.push(s as f32);
                }
            }
            tab.extend_from_slice(&cos);
            tab.extend_from_slice(&sin);
        }
        let mut groups: Vec<(usize, [usize; 2])> = Vec::new();
        for m in 0..n {
            match groups.last_mut() {
                Some((1, g)) if src[g[0]] == src[m] => {
                    g[1] = m;
                    groups.last_mut().expect("just matched").0 = 2;
                }
                _ => groups.push((1, [m, m])),
            }
        }
        let np = pairs(n);
        let mut row_y = vec![0.0f32; height * np];
        let mut y = vec![0.0f64; n * n];
        let mut zs = Vec::with_capacity(height);
        let mut omegas = Vec::with_capacity(height);
        for r in 0..height {
            let z = (local(dir(r, 0)).z).clamp(-1.0, 1.0);
            let s = (1.0 - z * z).max(0.0).sqrt();
            eval_sh_into(n, [s, 0.0, z], &mut y);
            let w = solid_angle(r);
            zs.push(z);
            omegas.push(w);
            let mut p = r * np;
            for m in 0..n {
                for l in m..n {
                    row_y[p] = (w * y[l * (l + 1) + m]) as f32;
                    p += 1;
                }
            }
        }
        let mirrored = (0..height / 2).all(|r| {
            let q = height - 1 - r;
            (zs[r] + zs[q]).abs() <= 1e-6
                && (omegas[r] - omegas[q]).abs() <= 1e-6 * omegas[r].abs().max(omegas[q].abs())
        });
        let units = if mirrored {
            let mut u: Vec<_> = (0..height / 2).map(|r| (r, Some(height - 1 - r))).collect();
            if !height.is_multiple_of(2) {
                u.push((height / 2, None));
            }
            u
        } else {
            (0..height).map(|r| (r, None)).collect()
        };
        let nu = units.len();
        let mut unit_y = vec![0.0f64; np * nu];
        for (u, &(r, _)) in units.iter().enumerate() {
            for p in 0..np {
                unit_y[p * nu + u] = row_y[r * np + p] as f64;
            }
        }
        // c_world = M(P⁻¹) c_local with P d = (d.z, d.x, d.y).
        let p = Rot3::new_unchecked([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let mut world_from_local = ShRotation::identity(order)?;
        IvanicRuedenberg::new(order)?.build(&p.transpose(), &mut world_from_local);
        Ok(Self {
            order,
            width,
            height,
            col_cs,
            levels,
            src,
            tab_off,
            tab,
            groups,
            units,
            row_y,
            unit_y,
            world_from_local,
        })
    }

    /// The number of symmetry folds in use (0: direct sums over all columns).
    #[must_use]
    pub fn fold_levels(&self) -> usize {
        self.levels
    }

    /// Whether mirrored north/south rows share the Legendre pass.
    #[must_use]
    pub fn rows_paired(&self) -> bool {
        self.units.iter().any(|u| u.1.is_some())
    }

    fn check_len(&self, texels: &[Vec3]) -> Result<(), ShError> {
        if texels.len() == self.width * self.height {
            Ok(())
        } else {
            Err(ShError::InvalidParameter {
                what: "texels",
                why: format!(
                    "expected {} texels, got {}",
                    self.width * self.height,
                    texels.len()
                ),
            })
        }
    }

    /// Projects `width × height` texels (row-major) onto the projector's order.
    pub fn project(&self, texels: &[Vec3]) -> Result<ShRgb, ShError> {
        self.check_len(texels)?;
        let mut acc = vec![0.0f64; ACC * pairs(self.order)];
        #[cfg(target_arch = "x86_64")]
        if crate::lanes::avx2_fma_available() {
            // SAFETY: the CPU has AVX2 and FMA (checked just above).
            unsafe { self.accumulate_fma(texels, &mut acc) };
            return self.finish(&acc);
        }
        self.accumulate::<false>(texels, &mut acc);
        self.finish(&acc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn accumulate_fma(&self, texels: &[Vec3], acc: &mut [f64]) {
        self.accumulate::<true>(texels, acc);
    }

    /// `acc[8p + k] = Σ_rows Ω Q̃_l^m (F_m)_k` for pair `p = (m, l)` (m-major; overwritten),
    /// `k = 0..3` the cos sums (RGB), `3..6` the sin sums (`6, 7`: padding, so
    /// one update is two 4-wide f64 FMAs).
    #[inline(always)]
    fn accumulate<const FMA: bool>(&self, texels: &[Vec3], acc: &mut [f64]) {
        let (w, n) = (self.width, self.order);
        let nu = self.units.len();
        let mut scratch = vec![0.0f32; 6 * w];
        let mut f1 = vec![[0.0f32; 6]; n];
        let mut f2 = vec![[0.0f32; 6]; n];
        // Per m and parity, per unit: F_r ± F_mirror (f64, padded to ACC).
        let mut gbuf = vec![[0.0f64; ACC]; 2 * n * nu];
        for (u, &(r, mirror)) in self.units.iter().enumerate() {
            self.fourier_row::<FMA>(
                vec3_as_f32(&texels[r * w..(r + 1) * w]),
                &mut scratch,
                &mut f1,
            );
            if let Some(q) = mirror {
                self.fourier_row::<FMA>(
                    vec3_as_f32(&texels[q * w..(q + 1) * w]),
                    &mut scratch,
                    &mut f2,
                );
            }
            for m in 0..n {
                let (a, b) = (f1[m], f2[m]);
                let (mut ge, mut go) = ([0.0f64; ACC], [0.0f64; ACC]);
                for k in 0..6 {
                    let (x, y) = (a[k] as f64, b[k] as f64);
                    (ge[k], go[k]) = if mirror.is_some() {
                        (x + y, x - y)
                    } else {
                        (x, x)
                    };
                }
                gbuf[2 * m * nu + u] = ge;
                gbuf[(2 * m + 1) * nu + u] = go;
            }
        }
        // Legendre pass, m-major: Q̃_l^m(−z) = (−1)^{l+m} Q̃_l^m(z), so l of the
        // parity of m take F_r + F_mirror and the others F_r − F_mirror. Four l
        // at a time keep their accumulators in registers over all units.
        for m in 0..n {
            let p0 = m * n - m * m.saturating_sub(1) / 2;
            for par in 0..2 {
                let g = &gbuf[(2 * m + par) * nu..(2 * m + par + 1) * nu];
                let ls: Vec<usize> = (m + par..n).step_by(2).collect();
                let mut chunks = ls.chunks_exact(4);
                for c in &mut chunks {
                    let ys: [&[f64]; 4] = std::array::from_fn(|i| {
                        let p = p0 + c[i] - m;
                        &self.unit_y[p * nu..(p + 1) * nu]
                    });
                    let out = legendre_group::<FMA, 4>(g, ys);
                    for i in 0..4 {
                        let p = p0 + c[i] - m;
                        acc[ACC * p..ACC * (p + 1)].copy_from_slice(&out[i]);
                    }
                }
                for &l in chunks.remainder() {
                    let p = p0 + l - m;
                    let [out] = legendre_group::<FMA, 1>(g, [&self.unit_y[p * nu..(p + 1) * nu]]);
                    acc[ACC * p..ACC * (p + 1)].copy_from_slice(&out);
                }
            }
        }
    }

    /// The Fourier sums of one row (`3W` interleaved RGB f32): `out[m] = [cos sums; sin sums]`.
    #[inline(always)]
    fn fourier_row<const FMA: bool>(&self, row: &[f32], scratch: &mut [f32], out: &mut [[f32; 6]]) {
        let n3 = row.len();
        {
            let (d, x) = scratch.split_at_mut(n3);
            if self.levels == 0 {
                x[..n3].copy_from_slice(row);
            }
            let (mut doff, mut xoff, mut len) = (0, 0, n3);
            for k in 0..self.levels {
                let h = len / 2;
                let (xprev, xnext) = x.split_at_mut(xoff);
                let cur: &[f32] = if k == 0 { row } else { &xprev[xoff - len..] };
                let (a, b) = cur.split_at(h);
                fold_step_dispatch::<FMA>(a, b, &mut d[doff..doff + h], &mut xnext[..h]);
                doff += h;
                xoff += h;
                len = h;
            }
        }
        for &(cnt, ms) in &self.groups {
            let (off, len) = self.src[ms[0]];
            let s = &scratch[off..off + len];
            let t = |m: usize| {
                let o = self.tab_off[m];
                (&self.tab[o..o + len], &self.tab[o + len..o + 2 * len])
            };
            let (c0, s0) = t(ms[0]);
            if cnt == 2 {
                let (c1, s1) = t(ms[1]);
                let [a, b, c, d] = dot3xk_dispatch::<FMA, 4>(s, [c0, s0, c1, s1]);
                out[ms[0]] = [a[0], a[1], a[2], b[0], b[1], b[2]];
                out[ms[1]] = [c[0], c[1], c[2], d[0], d[1], d[2]];
            } else {
                let [a, b] = dot3xk_dispatch::<FMA, 2>(s, [c0, s0]);
                out[ms[0]] = [a[0], a[1], a[2], b[0], b[1], b[2]];
            }
        }
    }

    /// Local-frame accumulators → world-frame [`ShRgb`] (Ivanic–Ruedenberg rotation).
    fn finish(&self, acc: &[f64]) -> Result<ShRgb, ShError> {
        let n = self.order;
        let nn = n * n;
        let mut local = [vec![0.0f64; nn], vec![0.0f64; nn], vec![0.0f64; nn]];
        let mut p = 0;
        for m in 0..n {
            for l in m..n {
                let b = l * (l + 1);
                for ch in 0..3 {
                    local[ch][b + m] = acc[ACC * p + ch];
                    if m > 0 {
                        local[ch][b - m] = acc[ACC * p + 3 + ch];
                    }
                }
                p += 1;
            }
        }
        // Frame change, all three channels per pass over the band blocks.
        let mut world = [vec![0.0f64; nn], vec![0.0f64; nn], vec![0.0f64; nn]];
        #[cfg(target_arch = "x86_64")]
        if crate::lanes::avx2_fma_available() {
            // SAFETY: the CPU has AVX2 and FMA (checked just above).
            unsafe { rotate_rgb_fma(&self.world_from_local, &local, &mut world) };
            return to_shrgb(n, world);
        }
        rotate_rgb::<false>(&self.world_from_local, &local, &mut world);
        to_shrgb(n, world)
    }

    /// The reference frame change: [`ShRotation::apply`] per channel.
    fn rotate_out(&self, local: &[Vec<f64>; 3]) -> Result<ShRgb, ShError> {
        let nn = self.order * self.order;
        let mut world = [vec![0.0f64; nn], vec![0.0f64; nn], vec![0.0f64; nn]];
        for ch in 0..3 {
            self.world_from_local.apply(&local[ch], &mut world[ch]);
        }
        to_shrgb(self.order, world)
    }

    /// The reference path: per row, direct f32 Fourier sums over all `W`
    /// columns (no fold, no row pairing, no FMA), then the Legendre
    /// accumulation in f64. Same result as [`Self::project`] up to f32 rounding.
    pub fn project_direct(&self, texels: &[Vec3]) -> Result<ShRgb, ShError> {
        self.check_len(texels)?;
        let (w, n) = (self.width, self.order);
        let mut cos3 = vec![0.0f32; n * 3 * w];
        let mut sin3 = vec![0.0f32; n * 3 * w];
        for (j, &[c1, s1]) in self.col_cs.iter().enumerate() {
            for m in 0..n {
                let (c, s) = cos_sin_m(m, c1, s1);
                for ch in 0..3 {
                    cos3[m * 3 * w + 3 * j + ch] = c as f32;
                    sin3[m * 3 * w + 3 * j + ch] = s as f32;
                }
            }
        }
        let nn = n * n;
        let np = pairs(n);
        let mut local = [vec![0.0f64; nn], vec![0.0f64; nn], vec![0.0f64; nn]];
        for r in 0..self.height {
            let row = vec3_as_f32(&texels[r * w..(r + 1) * w]);
            let ry = &self.row_y[r * np..(r + 1) * np];
            let mut p = 0;
            for m in 0..n {
                let c = &cos3[m * 3 * w..(m + 1) * 3 * w];
                let s = &sin3[m * 3 * w..(m + 1) * 3 * w];
                let [fc, fs] = dot3xk::<false, 2>(row, [c, s]);
                for l in m..n {
                    let b = l * (l + 1);
                    let yv = ry[p] as f64;
                    for ch in 0..3 {
                        local[ch][b + m] += yv * fc[ch] as f64;
                        if m > 0 {
                            local[ch][b - m] += yv * fs[ch] as f64;
                        }
                    }
                    p += 1;
                }
            }
        }
        self.rotate_out(&local)
    }
}

/// `(cos mφ, sin mφ)` from `(cos φ, sin φ)` by the angle-addition recurrence (f64).
fn cos_sin_m(m: usize, c1: f64, s1: f64) -> (f64, f64) {
    let (mut c, mut s) = (1.0f64, 0.0f64);
    for _ in 0..m {
        (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
    }
    (c, s)
}

/// How many times the columns `(cos φ_j, sin φ_j)` fold by symmetry (see
/// [`LatLongProjector`]): fold `k` (on a sequence of length `L = W/2^{k−1}`)
/// needs `L` even and `2^{k−1}(φ_{j+L/2} − φ_j) ≡ π (mod 2π)` for every
/// `j < L/2`, to 1e-6 rad in `φ`. Stops at the first fold that fails.
fn fold_levels(cs: &[[f64; 2]]) -> usize {
    let w = cs.len();
    let phi: Vec<f64> = cs.iter().map(|&[c, s]| s.atan2(c)).collect();
    let mut len = w;
    let mut k = 0usize;
    while len >= 2 && len.is_multiple_of(2) {
        let h = len / 2;
        let scale = (1u64 << k) as f64; // 2^{k} for fold k+1
        let ok = (0..h).all(|j| {
            let t = scale * (phi[j + h] - phi[j]) / std::f64::consts::PI;
            let r = t.round();
            (r as i64).rem_euclid(2) == 1 && (t - r).abs() * std::f64::consts::PI / scale <= 1e-6
        });
        if !ok {
            break;
        }
        k += 1;
        len = h;
    }
    k
}

#[inline]
fn vec3_as_f32(v: &[Vec3]) -> &[f32] {
    // SAFETY: glam::Vec3 is `#[repr(C)] struct { x: f32, y: f32, z: f32 }`
    // (size 12, align 4), so a slice of n Vec3 is 3n contiguous f32.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<f32>(), v.len() * 3) }
}

const LANES: usize = 24; // lcm(3, 8): lane k accumulates channel k % 3.

/// Stride of one `(m, l)` accumulator: cos RGB, sin RGB, two pad lanes.
const ACC: usize = 8;

/// `a·b + c`, fused when `FMA` (only instantiate `FMA = true` inside
/// `#[target_feature(enable = "fma")]` code, else `mul_add` is a libm call).
#[inline(always)]
fn madd<const FMA: bool, T: num_like::MulAdd>(a: T, b: T, c: T) -> T {
    if FMA { a.fused(b, c) } else { a.plain(b, c) }
}

mod num_like {
    pub trait MulAdd: Copy {
        fn fused(self, b: Self, c: Self) -> Self;
        fn plain(self, b: Self, c: Self) -> Self;
    }
    impl MulAdd for f32 {
        #[inline(always)]
        fn fused(self, b: Self, c: Self) -> Self {
            self.mul_add(b, c)
        }
        #[inline(always)]
        fn plain(self, b: Self, c: Self) -> Self {
            self * b + c
        }
    }
    impl MulAdd for f64 {
        #[inline(always)]
        fn fused(self, b: Self, c: Self) -> Self {
            self.mul_add(b, c)
        }
        #[inline(always)]
        fn plain(self, b: Self, c: Self) -> Self {
            self * b + c
        }
    }
}

/// World-frame f64 coefficients → f32 [`ShRgb`], rejecting non-finite values.
fn to_shrgb(order: usize, world: [Vec<f64>; 3]) -> Result<ShRgb, ShError> {
    let channels = world.map(|c| c.iter().map(|&v| v as f32).collect::<Vec<f32>>());
    for c in &channels {
        crate::check_finite("projected coefficients (input map has NaN/inf texels?)", c)?;
    }
    Ok(ShRgb {
        order,
        channels,
        window: Window::None,
    })
}

/// `dst_c = M src_c` for the three channels in one pass over each band block
/// of `M` (row-major `(2l+1)²`, [`ShRotation::block`]); four partial sums per
/// channel and row.
#[inline(always)]
fn rotate_rgb<const FMA: bool>(
    rot: &ShRotation<f64>,
    src: &[Vec<f64>; 3],
    dst: &mut [Vec<f64>; 3],
) {
    let n = rot.order();
    for c in 0..3 {
        dst[c][0] = src[c][0];
    }
    for l in 1..n {
        let (w, base) = (2 * l + 1, l * l);
        let s: [&[f64]; 3] = std::array::from_fn(|c| &src[c][base..base + w]);
        for (i, row) in rot.block(l).chunks_exact(w).enumerate() {
            let mut acc = [[0.0f64; 4]; 3];
            let full = w - w % 4;
            for k in (0..full).step_by(4) {
                for c in 0..3 {
                    for j in 0..4 {
                        acc[c][j] = madd::<FMA, f64>(row[k + j], s[c][k + j], acc[c][j]);
                    }
                }
            }
            for c in 0..3 {
                let mut v = (acc[c][0] + acc[c][1]) + (acc[c][2] + acc[c][3]);
                for k in full..w {
                    v = madd::<FMA, f64>(row[k], s[c][k], v);
                }
                dst[c][base + i] = v;
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn rotate_rgb_fma(rot: &ShRotation<f64>, src: &[Vec<f64>; 3], dst: &mut [Vec<f64>; 3]) {
    rotate_rgb::<true>(rot, src, dst);
}

/// `G` Legendre sums over all units: `out[i][k] = Σ_u ys[i][u] · g[u][k]` (f64).
#[inline(always)]
fn legendre_group<const FMA: bool, const G: usize>(
    g: &[[f64; ACC]],
    ys: [&[f64]; G],
) -> [[f64; ACC]; G] {
    let nu = g.len();
    let ys: [&[f64]; G] = ys.map(|y| &y[..nu]);
    let mut acc = [[0.0f64; ACC]; G];
    for u in 0..nu {
        let gv = &g[u];
        for i in 0..G {
            let y = ys[i][u];
            for k in 0..ACC {
                acc[i][k] = madd::<FMA, f64>(y, gv[k], acc[i][k]);
            }
        }
    }
    acc
}

/// One fold: `d = a − b`, `x = a + b` (all of equal length). Out of line so
/// that the four slices are `noalias` arguments: inlined, LLVM guarded the
/// vector loop with overlap checks and ran a scalar copy hot.
#[inline(never)]
fn fold_step(a: &[f32], b: &[f32], d: &mut [f32], x: &mut [f32]) {
    let h = a.len();
    let (b, d, x) = (&b[..h], &mut d[..h], &mut x[..h]);
    for i in 0..h {
        d[i] = a[i] - b[i];
        x[i] = a[i] + b[i];
    }
}

/// [`fold_step`] compiled for AVX2 (eight lanes).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
fn fold_step_avx2(a: &[f32], b: &[f32], d: &mut [f32], x: &mut [f32]) {
    let h = a.len();
    let (b, d, x) = (&b[..h], &mut d[..h], &mut x[..h]);
    for i in 0..h {
        d[i] = a[i] - b[i];
        x[i] = a[i] + b[i];
    }
}

#[inline(always)]
fn fold_step_dispatch<const FMA: bool>(a: &[f32], b: &[f32], d: &mut [f32], x: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if FMA {
        // SAFETY: `FMA = true` is only instantiated under
        // `#[target_feature(enable = "avx2,fma")]`, after the CPU check.
        unsafe { fold_step_avx2(a, b, d, x) };
        return;
    }
    fold_step(a, b, d, x);
}

/// Channel sums of 24 interleaved lanes (lane `k` is channel `k % 3`), as
/// three independent depth-3 trees.
#[inline(always)]
fn reduce24(l: &[f32; LANES]) -> [f32; 3] {
    std::array::from_fn(|c| {
        ((l[c] + l[c + 3]) + (l[c + 6] + l[c + 9]))
            + ((l[c + 12] + l[c + 15]) + (l[c + 18] + l[c + 21]))
    })
}

/// [`dot3xk`], through explicit AVX2+FMA registers when `FMA` (x86-64; the
/// `[f32; 24]` lane arrays of the portable form vectorise only 4-wide).
#[inline(always)]
fn dot3xk_dispatch<const FMA: bool, const K: usize>(a: &[f32], t: [&[f32]; K]) -> [[f32; 3]; K] {
    #[cfg(target_arch = "x86_64")]
    if FMA {
        // SAFETY: `FMA = true` is only instantiated under
        // `#[target_feature(enable = "avx2,fma")]`, after the CPU check.
        return unsafe { dot3xk_avx2::<K>(a, t) };
    }
    dot3xk::<FMA, K>(a, t)
}

/// [`dot3xk`] with `__m256` accumulators: three registers per table cover
/// one 24-float chunk, so register lane `8i + k` holds channel `(8i + k) % 3`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn dot3xk_avx2<const K: usize>(a: &[f32], t: [&[f32]; K]) -> [[f32; 3]; K] {
    use std::arch::x86_64::{
        __m256, _mm256_fmadd_ps, _mm256_loadu_ps, _mm256_setzero_ps, _mm256_storeu_ps,
    };
    let n = a.len();
    for tq in &t {
        assert_eq!(tq.len(), n, "table length");
    }
    let full = n - n % LANES;
    let mut acc: [[__m256; 3]; K] = [[_mm256_setzero_ps(); 3]; K];
    let pa = a.as_ptr();
    let mut s = 0;
    while s < full {
        // SAFETY: s + 24 ≤ full ≤ n = len of `a` and of every table.
        unsafe {
            let x = [
                _mm256_loadu_ps(pa.add(s)),
                _mm256_loadu_ps(pa.add(s + 8)),
                _mm256_loadu_ps(pa.add(s + 16)),
            ];
            for q in 0..K {
                let pt = t[q].as_ptr().add(s);
                for i in 0..3 {
                    acc[q][i] = _mm256_fmadd_ps(x[i], _mm256_loadu_ps(pt.add(8 * i)), acc[q][i]);
                }
            }
        }
        s += LANES;
    }
    let mut o = [[0.0f32; 3]; K];
    for q in 0..K {
        let mut lanes = [0.0f32; LANES];
        for i in 0..3 {
            // SAFETY: 8 floats at 8i < 24.
            unsafe { _mm256_storeu_ps(lanes.as_mut_ptr().add(8 * i), acc[q][i]) };
        }
        o[q] = reduce24(&lanes);
        for k in full..n {
            o[q][k % 3] = a[k].mul_add(t[q][k], o[q][k % 3]);
        }
    }
    o
}

/// `K` per-channel dot products of one interleaved-RGB row `a` with `K`
/// tables of the same length: `out[q][ch] = Σ_{i ≡ ch (3)} a_i t_q,i` (f32).
#[inline(always)]
fn dot3xk<const FMA: bool, const K: usize>(a: &[f32], t: [&[f32]; K]) -> [[f32; 3]; K] {
    let n = a.len();
    for tq in &t {
        assert_eq!(tq.len(), n, "table length");
    }
    let mut acc = [[0.0f32; LANES]; K];
    let full = n - n % LANES;
    let mut s = 0;
    while s < full {
        let x: &[f32; LANES] = a[s..s + LANES].try_into().expect("chunk");
        for q in 0..K {
            let y: &[f32; LANES] = t[q][s..s + LANES].try_into().expect("chunk");
            for k in 0..LANES {
                acc[q][k] = madd::<FMA, f32>(x[k], y[k], acc[q][k]);
            }
        }
        s += LANES;
    }
    let mut o = [[0.0f32; 3]; K];
    for q in 0..K {
        for (k, v) in acc[q].iter().enumerate() {
            o[q][k % 3] += v;
        }
        for k in full..n {
            o[q][k % 3] = madd::<FMA, f32>(a[k], t[q][k], o[q][k % 3]);
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::SphereQuadrature;

    /// A smooth test radiance: a band-limited part plus a bright lobe.
    fn radiance(d: Vec3) -> Vec3 {
        let lobe = (d.dot(Vec3::new(0.3, 0.8, 0.52).normalize()).max(0.0)).powi(8);
        Vec3::new(
            1.0 + 0.5 * d.x + lobe * 3.0,
            0.5 + 0.25 * d.y * d.z,
            0.2 + lobe,
        )
    }

    /// The cache projects a map once per texels and order, and gives what
    /// `project_env` gives.
    #[test]
    fn env_projection_keeps_the_last_map() {
        let param = Param::LatLong {
            width: 32,
            height: 16,
        };
        let map = EnvMap::from_fn(param, radiance);
        let mut cache = EnvProjection::default();
        assert_eq!(cache.fingerprint(), None);
        let (sh, fresh) = cache.project(&map, 4).unwrap();
        assert!(fresh);
        assert_eq!(*sh, project_env(&map, 4, Window::None).unwrap());
        assert!(!cache.project(&map.clone(), 4).unwrap().1, "same texels");
        assert_eq!(cache.fingerprint(), Some(map.fingerprint()));
        assert!(cache.project(&map, 3).unwrap().1, "another order");
        let mut brighter = map.clone();
        brighter.texels[5] *= 2.0;
        let (sh, fresh) = cache.project(&brighter, 3).unwrap();
        assert!(fresh, "another texel");
        assert_eq!(*sh, project_env(&brighter, 3, Window::None).unwrap());
    }

    #[test]
    fn latlong_fast_path_matches_generic_on_real_param() {
        let param = Param::LatLong {
            width: 128,
            height: 64,
        };
        let map = EnvMap::from_fn(param, radiance);
        for order in [1, 3, 6, 9] {
            let fast = LatLongProjector::new(param, order)
                .unwrap()
                .project(&map.texels)
                .unwrap();
            let slow = project_samples(
                order,
                &param.directions(),
                &param.solid_angles(),
                &map.texels,
            )
            .unwrap();
            for ch in 0..3 {
                for i in 0..order * order {
                    let (a, b) = (fast.channels[ch][i], slow.channels[ch][i]);
                    assert!(
                        (a - b).abs() < 2e-4,
                        "order {order} ch {ch} i {i}: fast {a} vs generic {b}"
                    );
                }
            }
        }
    }

    /// Uniform random texels in [0.5, 1.5) (xorshift; no timing, no stored outputs).
    fn random_texels(len: usize, seed: u64) -> Vec<Vec3> {
        let mut s = seed | 1;
        let mut r = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 + 0.5
        };
        (0..len).map(|_| Vec3::new(r(), r(), r())).collect()
    }

    /// `max |a − b| / max |b|` over all channels and coefficients.
    fn rel_diff(a: &ShRgb, b: &ShRgb) -> f32 {
        let (mut d, mut m) = (0.0f32, 0.0f32);
        for ch in 0..3 {
            for (x, y) in a.channels[ch].iter().zip(&b.channels[ch]) {
                d = d.max((x - y).abs());
                m = m.max(y.abs());
            }
        }
        d / m
    }

    #[test]
    fn folded_projection_matches_direct_sums() {
        // (width, height, expected folds): power of two, 2^5·3, 2^2·25, odd.
        for (w, h, folds) in [
            (256, 128, 8),
            (96, 48, 5),
            (100, 50, 2),
            (255, 128, 0),
            (7, 5, 0),
        ] {
            let param = Param::LatLong {
                width: w,
                height: h,
            };
            let texels = random_texels(w * h, 0x9e37_79b9 ^ w as u64);
            for order in [1, 2, 3, 10, 16, 30] {
                let pr = LatLongProjector::new(param, order).unwrap();
                assert_eq!(fold_levels(&pr.col_cs), folds, "{w}x{h}");
                let needed = if order == 1 {
                    0
                } else {
                    (order - 1).ilog2() + 1
                };
                assert_eq!(pr.fold_levels(), folds.min(needed as usize), "{w}x{h}");
                assert!(pr.rows_paired(), "{w}x{h}: lat-long rows are mirrored");
                let fast = pr.project(&texels).unwrap();
                let direct = pr.project_direct(&texels).unwrap();
                let e = rel_diff(&fast, &direct);
                assert!(e <= 1e-5, "{w}x{h} order {order}: fold vs direct {e:e}");
                let mut acc = vec![0.0f64; ACC * pairs(order)];
                pr.accumulate::<false>(&texels, &mut acc);
                let portable = pr.finish(&acc).unwrap();
                let e = rel_diff(&portable, &direct);
                assert!(e <= 1e-5, "{w}x{h} order {order}: portable vs direct {e:e}");
                if order <= 10 && w * h <= 256 * 128 {
                    let generic =
                        project_samples(order, &param.directions(), &param.solid_angles(), &texels)
                            .unwrap();
                    let e = rel_diff(&fast, &generic);
                    assert!(e <= 1e-5, "{w}x{h} order {order}: fold vs per-texel {e:e}");
                }
            }
        }
    }

    #[test]
    fn non_uniform_columns_and_unmirrored_rows_fall_back() {
        // Jittered column azimuths (no fold) and rows only in the upper
        // hemisphere (no pairing): the projector must still equal per-texel
        // projection of the same samples.
        let (w, h) = (64usize, 16usize);
        let phi = |j: usize| {
            std::f64::consts::TAU * (j as f64 + 0.5) / w as f64 + 0.01 * ((j * 7) % 5) as f64
        };
        let theta = |r: usize| 0.1 + 1.2 * (r as f64 + 0.5) / h as f64;
        let dir = |r: usize, j: usize| {
            let (st, ct) = theta(r).sin_cos();
            let (sp, cp) = phi(j).sin_cos();
            // Local frame (x', y', z') = (world Z, world X, world Y).
            Vec3::new((st * sp) as f32, ct as f32, (st * cp) as f32)
        };
        let omega = |r: usize| 0.01 + 0.001 * r as f64;
        let texels = random_texels(w * h, 7);
        for order in [3, 10, 16] {
            let pr = LatLongProjector::from_layout(order, w, h, dir, omega).unwrap();
            assert_eq!(pr.fold_levels(), 0);
            assert!(!pr.rows_paired());
            let fast = pr.project(&texels).unwrap();
            let direct = pr.project_direct(&texels).unwrap();
            assert!(rel_diff(&fast, &direct) <= 1e-5, "order {order}");
            let dirs: Vec<Vec3> = (0..w * h).map(|i| dir(i / w, i % w)).collect();
            let ws: Vec<f32> = (0..w * h).map(|i| omega(i / w) as f32).collect();
            let generic = project_samples(order, &dirs, &ws, &texels).unwrap();
            let e = rel_diff(&fast, &generic);
            assert!(e <= 1e-5, "order {order}: {e:e}");
        }
    }

    #[test]
    fn projection_matches_quadrature_oracle() {
        // Oracle: high-order Gauss–Legendre projection of the same function.
        let order = 5;
        let q = SphereQuadrature::new(64, 128);
        let want = project_fn(order, &q, |d| radiance(d.as_vec3()).x as f64);
        let param = Param::LatLong {
            width: 512,
            height: 256,
        };
        let map = EnvMap::from_fn(param, radiance);
        let got = project_env(&map, order, Window::None).unwrap();
        for i in 0..order * order {
            let (a, b) = (got.channels[0][i] as f64, want[i]);
            assert!(
                (a - b).abs() < 2e-3,
                "i {i}: lat-long {a} vs quadrature {b}"
            );
        }
        // Cube map through the generic path.
        let cube = EnvMap::from_fn(Param::Cube { n: 64 }, radiance);
        let got = project_env(&cube, order, Window::None).unwrap();
        for i in 0..order * order {
            let (a, b) = (got.channels[0][i] as f64, want[i]);
            assert!((a - b).abs() < 5e-3, "cube i {i}: {a} vs quadrature {b}");
        }
    }

    #[test]
    fn reconstruct_round_trip_band_limited() {
        let order = 4;
        let mut c = ShRgb::zeros(order).unwrap();
        for (i, v) in c.channels[1].iter_mut().enumerate() {
            *v = ((i * 7 % 5) as f32 - 2.0) * 0.1;
        }
        let param = Param::LatLong {
            width: 256,
            height: 128,
        };
        let map = reconstruct(&c, param);
        let back = project_env(&map, order, Window::None).unwrap();
        for i in 0..order * order {
            assert!(
                (back.channels[1][i] - c.channels[1][i]).abs() < 2e-3,
                "i {i}"
            );
        }
    }

    #[test]
    fn windows() {
        assert_eq!(Window::None.factor(5), 1.0);
        assert!((Window::Hanning { width: 4.0 }.factor(2) - 0.5).abs() < 1e-15);
        assert_eq!(Window::Hanning { width: 4.0 }.factor(5), 0.0);
        assert!(
            (Window::Lanczos { width: 4.0 }.factor(2) - 2.0 / std::f64::consts::PI).abs() < 1e-15
        );
        assert!((Window::Sloan { lambda: 0.01 }.factor(2) - 1.0 / 1.36).abs() < 1e-15);
        assert!(Window::Hanning { width: -1.0 }.validate().is_err());
        assert!(Window::Sloan { lambda: f64::NAN }.validate().is_err());
        let mut c = ShRgb::zeros(3).unwrap();
        c.channels[0].fill(1.0);
        c.apply_window(Window::Hanning { width: 4.0 }).unwrap();
        assert_eq!(c.window, Window::Hanning { width: 4.0 });
        assert!((c.channels[0][2] - 0.8535534).abs() < 1e-6);
        assert!((c.channels[0][5] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn bad_input() {
        let param = Param::LatLong {
            width: 8,
            height: 4,
        };
        let mut map = EnvMap::from_fn(param, radiance);
        assert!(matches!(
            project_env(&map, 0, Window::None),
            Err(ShError::OrderOutOfRange { .. })
        ));
        map.texels[3].x = f32::NAN;
        assert!(matches!(
            project_env(&map, 3, Window::None),
            Err(ShError::NonFinite { .. })
        ));
        assert!(project_samples(2, &[Vec3::Z], &[1.0, 2.0], &[Vec3::ONE]).is_err());
        assert!(LatLongProjector::new(Param::Cube { n: 4 }, 3).is_err());
        // A malformed coefficient set (as read from a file) is rejected by validate().
        let mut c = ShRgb::zeros(3).unwrap();
        assert!(c.validate().is_ok());
        c.channels[2].pop();
        assert!(matches!(c.validate(), Err(ShError::LengthMismatch { .. })));
        let mut c = ShRgb::zeros(3).unwrap();
        c.channels[0][4] = f32::INFINITY;
        assert!(matches!(c.validate(), Err(ShError::NonFinite { .. })));
        c.order = 0;
        assert!(matches!(c.validate(), Err(ShError::OrderOutOfRange { .. })));
    }

    /// A coarse map is integrated over its texels: a constant 8 × 4
    /// lat-long map (and a 3 × 3-per-face cube map) projects to band 0 alone,
    /// and an 8 × 4 map's texels sum to their piecewise-constant integral.
    /// Texel centres alone leave band 2 at a few per cent of band 0 on the
    /// 8 × 4 map (the case that made shexp's ambient occlusion row fail).
    /// Shipped probes (256 rows and more, order ≤ 8) keep the centre rule.
    #[test]
    fn coarse_maps_are_integrated_over_their_texels() {
        for param in [
            Param::LatLong {
                width: 8,
                height: 4,
            },
            Param::Cube { n: 3 },
        ] {
            let map = EnvMap::from_fn(param, |_| Vec3::splat(2.0));
            assert!(texel_subsamples(&param, 6) > 1, "{param:?}");
            let sh = project_env(&map, 6, Window::None).unwrap();
            let want0 = 2.0 * (4.0 * std::f32::consts::PI).sqrt();
            assert!(
                (sh.channels[0][0] - want0).abs() < 1e-4 * want0,
                "{param:?}"
            );
            for (i, c) in sh.channels[0].iter().enumerate().skip(1) {
                assert!(c.abs() < 2e-4 * want0, "{param:?}: coefficient {i} = {c}");
            }
            // Texel centres alone alias the constant into band 2.
            let centres =
                project_samples(6, &param.directions(), &param.solid_angles(), &map.texels)
                    .unwrap();
            if matches!(param, Param::LatLong { .. }) {
                assert!(centres.channels[0][6].abs() > 0.01 * want0, "{centres:?}");
            }
        }
        for height in [256, 512, 1024] {
            let param = Param::LatLong {
                width: 2 * height,
                height,
            };
            assert_eq!(texel_subsamples(&param, 8), 1, "{height} rows");
        }
    }
}
