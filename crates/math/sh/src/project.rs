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

/// Projects an environment map in any parameterization (exact texel solid
/// angles), with the lat-long fast path where it applies, then applies `window`.
pub fn project_env(map: &EnvMap, order: usize, window: Window) -> Result<ShRgb, ShError> {
    check_order("order", order, MAX_ORDER)?;
    window.validate()?;
    let mut out = match map.param {
        Param::LatLong { .. } => LatLongProjector::new(map.param, order)?.project(&map.texels)?,
        p => project_samples(order, &p.directions(), &p.solid_angles(), &map.texels)?,
    };
    out.apply_window(window)?;
    Ok(out)
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
#[derive(Clone, Debug)]
pub struct LatLongProjector {
    order: usize,
    width: usize,
    height: usize,
    /// `cos(m φ_j)` for m < order, each repeated ×3 (interleaved RGB): `[m][3j + c]`.
    cos3: Vec<f32>,
    /// `sin(m φ_j)`, same layout (row m = 0 unused).
    sin3: Vec<f32>,
    /// Per row: `Ω_row · y_{l,m}(θ_row, φ=0)` for m ≥ 0 at index `l(l+1)+m`.
    row_y: Vec<f32>,
    /// Coefficients of the local (pole = world +Y) frame → world frame.
    world_from_local: ShRotation<f64>,
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
    /// solid angle of each texel in a row.
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
        // Local frame: x' = world Z, y' = world X, z' = world Y (a cyclic, proper rotation).
        let local = |d: Vec3| DVec3::new(d.z as f64, d.x as f64, d.y as f64);
        let mid = height / 2;
        let mut cos3 = vec![0.0f32; order * 3 * width];
        let mut sin3 = vec![0.0f32; order * 3 * width];
        for j in 0..width {
            let d = local(dir(mid, j));
            let h = d.x.hypot(d.y);
            let (c1, s1) = if h > 0.0 {
                (d.x / h, d.y / h)
            } else {
                (1.0, 0.0)
            };
            let (mut cm, mut sm) = (1.0f64, 0.0f64);
            for m in 0..order {
                for c in 0..3 {
                    cos3[m * 3 * width + 3 * j + c] = cm as f32;
                    sin3[m * 3 * width + 3 * j + c] = sm as f32;
                }
                let cn = cm * c1 - sm * s1;
                sm = sm * c1 + cm * s1;
                cm = cn;
            }
        }
        let nn = order * order;
        let mut row_y = vec![0.0f32; height * nn];
        let mut y = vec![0.0f64; nn];
        for r in 0..height {
            let z = (local(dir(r, 0)).z).clamp(-1.0, 1.0);
            let s = (1.0 - z * z).max(0.0).sqrt();
            eval_sh_into(order, [s, 0.0, z], &mut y);
            let w = solid_angle(r);
            for (o, v) in row_y[r * nn..(r + 1) * nn].iter_mut().zip(&y) {
                *o = (w * v) as f32;
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
            cos3,
            sin3,
            row_y,
            world_from_local,
        })
    }

    /// Projects `width × height` texels (row-major) onto the projector's order.
    pub fn project(&self, texels: &[Vec3]) -> Result<ShRgb, ShError> {
        let (w, n) = (self.width, self.order);
        if texels.len() != w * self.height {
            return Err(ShError::InvalidParameter {
                what: "texels",
                why: format!("expected {} texels, got {}", w * self.height, texels.len()),
            });
        }
        let nn = n * n;
        let mut local = [vec![0.0f64; nn], vec![0.0f64; nn], vec![0.0f64; nn]];
        let mut fc = vec![[0.0f32; 3]; n];
        let mut fs = vec![[0.0f32; 3]; n];
        for r in 0..self.height {
            let row = vec3_as_f32(&texels[r * w..(r + 1) * w]);
            for m in 0..n {
                let c = &self.cos3[m * 3 * w..(m + 1) * 3 * w];
                if m == 0 {
                    fc[0] = dot3(row, c);
                } else {
                    let s = &self.sin3[m * 3 * w..(m + 1) * 3 * w];
                    (fc[m], fs[m]) = dot3x2(row, c, s);
                }
            }
            let ry = &self.row_y[r * nn..(r + 1) * nn];
            for m in 0..n {
                for l in m..n {
                    let b = l * (l + 1);
                    let yv = ry[b + m] as f64;
                    for ch in 0..3 {
                        local[ch][b + m] += yv * fc[m][ch] as f64;
                        if m > 0 {
                            local[ch][b - m] += yv * fs[m][ch] as f64;
                        }
                    }
                }
            }
        }
        let mut channels = [vec![0.0f32; nn], vec![0.0f32; nn], vec![0.0f32; nn]];
        let mut tmp = vec![0.0f64; nn];
        for ch in 0..3 {
            self.world_from_local.apply(&local[ch], &mut tmp);
            for (o, v) in channels[ch].iter_mut().zip(&tmp) {
                *o = *v as f32;
            }
            crate::check_finite(
                "projected coefficients (input map has NaN/inf texels?)",
                &channels[ch],
            )?;
        }
        Ok(ShRgb {
            order: n,
            channels,
            window: Window::None,
        })
    }
}

#[inline]
fn vec3_as_f32(v: &[Vec3]) -> &[f32] {
    // SAFETY: glam::Vec3 is `#[repr(C)] struct { x: f32, y: f32, z: f32 }`
    // (size 12, align 4), so a slice of n Vec3 is 3n contiguous f32.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<f32>(), v.len() * 3) }
}

const LANES: usize = 24; // lcm(3, 8): lane k accumulates channel k % 3.

#[inline]
fn fold3(acc: &[f32; LANES]) -> [f32; 3] {
    let mut o = [0.0f32; 3];
    for (k, v) in acc.iter().enumerate() {
        o[k % 3] += v;
    }
    o
}

#[inline]
fn dot3(a: &[f32], b: &[f32]) -> [f32; 3] {
    let mut acc = [0.0f32; LANES];
    let (ac, ar) = (a.chunks_exact(LANES), a.len() % LANES);
    for (x, y) in ac.zip(b.chunks_exact(LANES)) {
        for k in 0..LANES {
            acc[k] += x[k] * y[k];
        }
    }
    let mut o = fold3(&acc);
    let s = a.len() - ar;
    for k in s..a.len() {
        o[k % 3] += a[k] * b[k];
    }
    o
}

#[inline]
fn dot3x2(a: &[f32], b: &[f32], c: &[f32]) -> ([f32; 3], [f32; 3]) {
    let mut acc = [0.0f32; LANES];
    let mut acc2 = [0.0f32; LANES];
    for ((x, y), z) in a
        .chunks_exact(LANES)
        .zip(b.chunks_exact(LANES))
        .zip(c.chunks_exact(LANES))
    {
        for k in 0..LANES {
            acc[k] += x[k] * y[k];
            acc2[k] += x[k] * z[k];
        }
    }
    let (mut o, mut o2) = (fold3(&acc), fold3(&acc2));
    let s = a.len() - a.len() % LANES;
    for k in s..a.len() {
        o[k % 3] += a[k] * b[k];
        o2[k % 3] += a[k] * c[k];
    }
    (o, o2)
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
}
