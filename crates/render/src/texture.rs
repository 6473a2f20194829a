//! Textures over a mesh's uvs: [`Texture`] (linear RGB, e.g. an area light's
//! radiance or a BRDF blend weight) and [`NormalMap`] (tangent-space normals),
//! both sampled bilinearly with wrap-around — the one texture lookup every
//! method and the reference share, so they shade the same values.
//!
//! # Convention
//! * uv → texel (both types): `x = u·W − ½`, `y = v·H − ½` (v runs down the
//!   image, the glTF convention), bilinear, wrapping in both directions.
//! * Normal-map texel `(x, y)` (row 0 at the top of the image) holds a unit vector in
//!   tangent space `(t, b, n)`: +X along the tangent, +Y along the bitangent
//!   (OpenGL "green up"), +Z out of the surface — the `shared/data/normalmaps`
//!   convention. PNG colours `c ∈ [0, 1]³` decode as `2c − 1`
//!   ([`NormalMap::from_rgb`]).
//! * World normal: `n' = normalize(x·T + y·B + z·N)` with `N` the unit
//!   interpolated vertex normal, `T` the interpolated tangent made orthogonal
//!   to `N` (Gram–Schmidt) and `B = w (N × T)`, `w` = the tangent's handedness.
//!   Every method and the reference call [`NormalMap::perturb`], so they
//!   shade the same normals.

use glam::{Vec2, Vec3, Vec4};

/// Why texels do not make a texture.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TextureError {
    #[error("size {width}×{height} is empty")]
    Empty { width: usize, height: usize },
    #[error("{given} texels given for a {width}×{height} texture ({} expected)", width * height)]
    SizeMismatch {
        width: usize,
        height: usize,
        given: usize,
    },
    #[error("every texel has equal red, green and blue: a grayscale image (a height or bump map?)")]
    Grayscale,
    #[error("texel ({x}, {y}) = {value} {why}")]
    BadTexel {
        x: usize,
        y: usize,
        value: Vec3,
        why: &'static str,
    },
}

fn check_size(width: usize, height: usize, given: usize) -> Result<(), TextureError> {
    if width == 0 || height == 0 {
        return Err(TextureError::Empty { width, height });
    }
    if given != width * height {
        return Err(TextureError::SizeMismatch {
            width,
            height,
            given,
        });
    }
    Ok(())
}

/// The four texels and weights of a bilinear wrap-around lookup at `uv` in a
/// `width × height` grid: `[(index, weight); 4]` (texel centres at
/// `(i + ½)/width`; non-finite uvs read texel 0 with weight 1). Every texture
/// lookup of the workspace uses it, so that all agree on the convention.
#[inline(always)]
#[must_use]
pub fn bilinear_taps(width: usize, height: usize, uv: Vec2) -> [(usize, f32); 4] {
    let fx = uv.x * width as f32 - 0.5;
    let fy = uv.y * height as f32 - 0.5;
    // Fast path (the same taps, without `floorf` calls or eight 64-bit
    // divisions): below 2^23 truncation is exact and `x0 + 1` representable,
    // so `wrap(x0 + 1) = (wrap(x0) + 1) mod n`. NaN fails the test.
    const EXACT: f32 = 8_388_608.0;
    if fx.abs() < EXACT && fy.abs() < EXACT {
        let floor = |v: f32| {
            let i = v as i64;
            if (i as f32) > v { i - 1 } else { i }
        };
        let wrap_pair = |i: i64, n: usize| -> (usize, usize) {
            let n_i = n as i64;
            let a = if (0..n_i).contains(&i) {
                i as usize
            } else if n.is_power_of_two() {
                (i & (n_i - 1)) as usize
            } else {
                i.rem_euclid(n_i) as usize
            };
            (a, if a + 1 == n { 0 } else { a + 1 })
        };
        let (ix, iy) = (floor(fx), floor(fy));
        let (tx, ty) = (fx - ix as f32, fy - iy as f32);
        let (xa, xb) = wrap_pair(ix, width);
        let (ya, yb) = wrap_pair(iy, height);
        return [
            (ya * width + xa, (1.0 - tx) * (1.0 - ty)),
            (ya * width + xb, tx * (1.0 - ty)),
            (yb * width + xa, (1.0 - tx) * ty),
            (yb * width + xb, tx * ty),
        ];
    }
    bilinear_taps_general(width, height, fx, fy)
}

/// [`bilinear_taps`] past its fast path (huge or non-finite coordinates):
/// kept out of line so that the fast path inlines into per-texel loops.
#[inline(never)]
fn bilinear_taps_general(width: usize, height: usize, fx: f32, fy: f32) -> [(usize, f32); 4] {
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = if fx.is_finite() && fy.is_finite() {
        (fx - x0, fy - y0)
    } else {
        (0.0, 0.0)
    };
    let wrap = |v: f32, n: usize| -> usize {
        let n_i = n as i64;
        let i = if v.is_finite() { v as i64 } else { 0 };
        (((i % n_i) + n_i) % n_i) as usize
    };
    let (xa, xb) = (wrap(x0, width), wrap(x0 + 1.0, width));
    let (ya, yb) = (wrap(y0, height), wrap(y0 + 1.0, height));
    [
        (ya * width + xa, (1.0 - tx) * (1.0 - ty)),
        (ya * width + xb, tx * (1.0 - ty)),
        (yb * width + xa, (1.0 - tx) * ty),
        (yb * width + xb, tx * ty),
    ]
}

/// [`bilinear_taps`] for `N` lookups at once, as structure of arrays, so
/// that a caller's lane loop runs in vector registers (the scalar form's
/// conversions and wrap branches cost more than its four texel reads).
/// Lane `i` looks up a `size[0][i] × size[1][i]` texture at `(u, v)[i]`.
/// Where [`BilinearLanes::exact`] is set, a lane's taps are exactly those
/// of [`bilinear_taps`] (`index` row-major, `weight` in the same order;
/// tested bit for bit); elsewhere — a coordinate beyond 2²³ texels, NaN, a
/// size below 1, beyond 2²³ or with more than 2³² texels — the lane holds
/// nothing meaningful and the caller asks [`bilinear_taps`].
#[derive(Clone, Copy, Debug)]
pub struct BilinearLanes<const N: usize> {
    pub index: [[u32; N]; 4],
    pub weight: [[f32; N]; 4],
    pub exact: [bool; N],
}

impl<const N: usize> Default for BilinearLanes<N> {
    fn default() -> Self {
        Self {
            index: [[0; N]; 4],
            weight: [[0.0; N]; 4],
            exact: [false; N],
        }
    }
}

impl<const N: usize> BilinearLanes<N> {
    /// The taps of lanes `0..count` (see the type's docs): `size` the
    /// textures' widths and heights in texels (as `f32`), `uv` the lookup
    /// coordinates. Branch-free over lanes. The wrap `i mod n` is computed
    /// in `f32`, `i − n ⌊i / n⌋` corrected by ± n, which is exact for the
    /// integers below 2²⁴ it meets.
    #[inline(always)]
    pub fn compute(&mut self, size: [&[f32; N]; 2], uv: [&[f32; N]; 2], count: usize) {
        const EXACT: f32 = 8_388_608.0;
        /// `v` truncated, for `|v| ≤ 2²³` (every operand is sanitised to
        /// that range first, so that the conversion is a plain vector
        /// instruction instead of Rust's saturating `as`).
        #[inline(always)]
        fn trunc(v: f32) -> i32 {
            debug_assert!(v.abs() <= EXACT);
            // SAFETY: finite and within i32's range (above).
            unsafe { v.to_int_unchecked::<i32>() }
        }
        #[inline(always)]
        fn floor(v: f32) -> f32 {
            let t = trunc(v) as f32;
            if t > v { t - 1.0 } else { t }
        }
        #[inline(always)]
        fn wrap(i: f32, n: f32) -> f32 {
            let a = i - n * floor(i / n);
            let a = if a < 0.0 { a + n } else { a };
            if a >= n { a - n } else { a }
        }
        for i in 0..count.min(N) {
            let (w, h) = (size[0][i], size[1][i]);
            let fx = uv[0][i] * w - 0.5;
            let fy = uv[1][i] * h - 0.5;
            // `&`, not `&&`: no branch, so that the loop vectorises.
            let exact = (fx.abs() < EXACT)
                & (fy.abs() < EXACT)
                & (w >= 1.0)
                & (h >= 1.0)
                & (w < EXACT)
                & (h < EXACT)
                & (w * h <= 4_294_967_296.0);
            self.exact[i] = exact;
            // Off the fast path every operand is replaced by one in range
            // (the lane's taps are then meaningless, as documented).
            let (w, h, fx, fy) = if exact {
                (w, h, fx, fy)
            } else {
                (1.0, 1.0, 0.0, 0.0)
            };
            let (ix, iy) = (floor(fx), floor(fy));
            let (tx, ty) = (fx - ix, fy - iy);
            let (xa, ya) = (wrap(ix, w), wrap(iy, h));
            let xb = if xa + 1.0 == w { 0.0 } else { xa + 1.0 };
            let yb = if ya + 1.0 == h { 0.0 } else { ya + 1.0 };
            let wu = trunc(w) as u32;
            let row = |y: f32| (trunc(y) as u32).wrapping_mul(wu);
            let (ra, rb) = (row(ya), row(yb));
            let (xa, xb) = (trunc(xa) as u32, trunc(xb) as u32);
            self.index[0][i] = ra.wrapping_add(xa);
            self.index[1][i] = ra.wrapping_add(xb);
            self.index[2][i] = rb.wrapping_add(xa);
            self.index[3][i] = rb.wrapping_add(xb);
            self.weight[0][i] = (1.0 - tx) * (1.0 - ty);
            self.weight[1][i] = tx * (1.0 - ty);
            self.weight[2][i] = (1.0 - tx) * ty;
            self.weight[3][i] = tx * ty;
        }
    }
}

/// A linear-RGB texture over uv (row 0 at the top, v down).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: usize,
    pub height: usize,
    /// Finite, non-negative linear RGB, row-major.
    pub texels: Vec<Vec3>,
}

impl Texture {
    /// The light texture of the area-light verify scenes, `size²` texels:
    /// warm (left) and cool (right) halves, six horizontal stripe bands
    /// alternating 1 and `stripe_low`, and a bright disc of radius 0.1 at
    /// uv (0.7, 0.3) adding `spot` (all the frequencies a light's wavelet
    /// compression must track).
    ///
    /// # Panics
    /// `size == 0`.
    #[must_use]
    pub fn stripes_and_spot(size: usize, stripe_low: f32, spot: f32) -> Self {
        let texels = (0..size * size)
            .map(|i| {
                let (x, y) = (
                    (i % size) as f32 / size as f32,
                    (i / size) as f32 / size as f32,
                );
                let warm = if x < 0.5 {
                    Vec3::new(1.4, 0.9, 0.4)
                } else {
                    Vec3::new(0.4, 0.8, 1.4)
                };
                let stripe = if ((y * 6.0) as i32) % 2 == 0 {
                    1.0
                } else {
                    stripe_low
                };
                let disc = if (x - 0.7).powi(2) + (y - 0.3).powi(2) < 0.01 {
                    spot
                } else {
                    0.0
                };
                warm * stripe + Vec3::splat(disc)
            })
            .collect();
        Self::try_new(size, size, texels).expect("a non-zero size")
    }

    /// From finite, non-negative texels.
    ///
    /// # Errors
    /// Size mismatch, zero size, negative or non-finite texels.
    pub fn try_new(width: usize, height: usize, texels: Vec<Vec3>) -> Result<Self, TextureError> {
        check_size(width, height, texels.len())?;
        if let Some(i) = texels
            .iter()
            .position(|t| !t.is_finite() || t.min_element() < 0.0)
        {
            return Err(TextureError::BadTexel {
                x: i % width,
                y: i / width,
                value: texels[i],
                why: "is negative or not finite",
            });
        }
        Ok(Self {
            width,
            height,
            texels,
        })
    }

    /// A 1 × 1 texture of one value (must be finite and ≥ 0).
    ///
    /// # Errors
    /// A negative or non-finite value.
    pub fn constant(value: Vec3) -> Result<Self, TextureError> {
        Self::try_new(1, 1, vec![value])
    }

    /// Bilinear sample at `uv` with wrap-around.
    #[inline]
    #[must_use]
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        bilinear_taps(self.width, self.height, uv)
            .iter()
            .map(|&(i, w)| self.texels[i] * w)
            .sum()
    }

    /// Mean texel value (the texture's average over uv).
    #[must_use]
    pub fn mean(&self) -> Vec3 {
        self.texels.iter().copied().sum::<Vec3>() / self.texels.len() as f32
    }
}

/// A decoded tangent-space normal map: `width × height` unit vectors, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap {
    pub width: usize,
    pub height: usize,
    /// Unit tangent-space normals (z > 0 after decoding; see the module docs).
    pub texels: Vec<Vec3>,
}

impl NormalMap {
    /// From tangent-space vectors in `[−1, 1]³` (normalised here).
    ///
    /// # Errors
    /// Size mismatch, zero size, non-finite or zero-length texels.
    pub fn from_vectors(width: usize, height: usize, v: &[Vec3]) -> Result<Self, TextureError> {
        check_size(width, height, v.len())?;
        let mut texels = Vec::with_capacity(v.len());
        for (i, t) in v.iter().enumerate() {
            let Some(n) = t.try_normalize() else {
                return Err(TextureError::BadTexel {
                    x: i % width,
                    y: i / width,
                    value: *t,
                    why: "is not a direction (zero or not finite)",
                });
            };
            texels.push(n);
        }
        Ok(Self {
            width,
            height,
            texels,
        })
    }

    /// From decoded PNG colours in `[0, 1]³` (linear, no sRGB curve): `2c − 1`.
    ///
    /// # Errors
    /// As [`NormalMap::from_vectors`], and [`TextureError::Grayscale`] when
    /// every texel has `r = g = b` (no normal map is: its flat texel is
    /// (0.5, 0.5, 1)), the sign of a height map given by mistake.
    pub fn from_rgb(width: usize, height: usize, rgb: &[Vec3]) -> Result<Self, TextureError> {
        check_size(width, height, rgb.len())?;
        if rgb.iter().all(|c| c.x == c.y && c.y == c.z) {
            return Err(TextureError::Grayscale);
        }
        let v: Vec<Vec3> = rgb.iter().map(|c| *c * 2.0 - Vec3::ONE).collect();
        Self::from_vectors(width, height, &v)
    }

    /// A procedural bump map (for tests and `verify` without a file): a
    /// `cells × cells` grid of spherical-cap bumps, each tilting the normal by
    /// up to `max_tilt` radians at its rim. `size` texels square.
    #[must_use]
    pub fn bumps(size: usize, cells: usize, max_tilt: f32) -> Self {
        let size = size.max(1);
        let cells = cells.max(1) as f32;
        let texels = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
                let u = (x / size as f32 * cells).fract() * 2.0 - 1.0;
                let v = (y / size as f32 * cells).fract() * 2.0 - 1.0;
                let r = (u * u + v * v).sqrt();
                if r >= 1.0 {
                    return Vec3::Z;
                }
                // Tilt grows linearly with the radius; direction = outward.
                let tilt = max_tilt * r;
                let (s, c) = tilt.sin_cos();
                let dir = if r > 0.0 {
                    Vec2::new(u, -v) / r
                } else {
                    Vec2::ZERO
                };
                Vec3::new(dir.x * s, dir.y * s, c)
            })
            .collect();
        Self {
            width: size,
            height: size,
            texels,
        }
    }

    /// Bilinear sample at `uv` with wrap-around, renormalised (tangent space).
    #[inline]
    #[must_use]
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        self.blend(uv).normalize_or(Vec3::Z)
    }

    /// The bilinear blend of the four texels at `uv`, not renormalised: the
    /// direction of [`NormalMap::sample`] (or zero where that falls back to
    /// +z), for callers that normalise later anyway.
    #[inline]
    #[must_use]
    pub fn blend(&self, uv: Vec2) -> Vec3 {
        let [a, b, c, d] = bilinear_taps(self.width, self.height, uv);
        self.texels[a.0] * a.1
            + self.texels[b.0] * b.1
            + self.texels[c.0] * c.1
            + self.texels[d.0] * d.1
    }

    /// The perturbed world normal at a surface point with unit normal `n`,
    /// interpolated tangent `tangent` (xyz, w = handedness) and `uv`.
    #[inline]
    #[must_use]
    pub fn perturb(&self, n: Vec3, tangent: Vec4, uv: Vec2) -> Vec3 {
        let t = (tangent.truncate() - n * n.dot(tangent.truncate()))
            .normalize_or(n.any_orthonormal_vector());
        let w = if tangent.w < 0.0 { -1.0 } else { 1.0 };
        let b = n.cross(t) * w;
        let m = self.sample(uv);
        (t * m.x + b * m.y + n * m.z).normalize_or(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_bilinear_taps_match_the_floor_and_modulo_definition() {
        let reference = |width: usize, height: usize, uv: Vec2| {
            let fx = uv.x * width as f32 - 0.5;
            let fy = uv.y * height as f32 - 0.5;
            let (x0, y0) = (fx.floor(), fy.floor());
            let (tx, ty) = (fx - x0, fy - y0);
            let wrap = |v: f32, n: usize| (((v as i64 % n as i64) + n as i64) % n as i64) as usize;
            let (xa, xb) = (wrap(x0, width), wrap(x0 + 1.0, width));
            let (ya, yb) = (wrap(y0, height), wrap(y0 + 1.0, height));
            [
                (ya * width + xa, (1.0 - tx) * (1.0 - ty)),
                (ya * width + xb, tx * (1.0 - ty)),
                (yb * width + xa, (1.0 - tx) * ty),
                (yb * width + xb, tx * ty),
            ]
        };
        for (w, h) in [(1, 1), (4, 8), (5, 3), (512, 512)] {
            for i in 0..400 {
                let t = i as f32 * 0.618_034;
                let uv = Vec2::new((t.fract() - 0.5) * 37.0, (t * 1.7).sin() * 23.0 + 0.25);
                assert_eq!(
                    bilinear_taps(w, h, uv),
                    reference(w, h, uv),
                    "{w}×{h} at {uv}"
                );
            }
            assert_eq!(
                bilinear_taps(w, h, Vec2::new(0.0, -0.0)),
                reference(w, h, Vec2::ZERO)
            );
        }
        assert_eq!(bilinear_taps(4, 4, Vec2::NAN)[0], (0, 1.0));
    }

    /// The lane form gives [`bilinear_taps`]' taps bit for bit wherever it
    /// says `exact`, and says it for every coordinate of the fast path.
    #[test]
    fn bilinear_lanes_match_the_scalar_taps() {
        const N: usize = 16;
        let sizes = [(1, 1), (4, 8), (5, 3), (7, 1), (512, 512), (1000, 3)];
        let mut lanes = BilinearLanes::<N>::default();
        let mut k = 0u32;
        let mut checked = 0;
        for _ in 0..200 {
            let mut size = [[0.0f32; N]; 2];
            let mut uv = [[0.0f32; N]; 2];
            let mut dims = [(0usize, 0usize); N];
            for i in 0..N {
                k += 1;
                let t = k as f32 * 0.618_034;
                let (w, h) = sizes[k as usize % sizes.len()];
                dims[i] = (w, h);
                size[0][i] = w as f32;
                size[1][i] = h as f32;
                let scale = [1.0, 9.0, 300.0, 3.0e5][k as usize % 4];
                uv[0][i] = (t.fract() - 0.5) * scale;
                uv[1][i] = (t * 1.7).sin() * scale + 0.25;
                match k % 29 {
                    0 => uv[0][i] = f32::NAN,
                    1 => uv[1][i] = 1.0e9,
                    2 => uv[0][i] = -0.0,
                    3 => uv[1][i] = 1.0 - f32::EPSILON,
                    // ⌊x⌋ = −2²³ (on a texture one texel wide).
                    4 => uv[0][i] = -8_388_607.0,
                    _ => {}
                }
            }
            lanes.compute([&size[0], &size[1]], [&uv[0], &uv[1]], N);
            for i in 0..N {
                let (w, h) = dims[i];
                let (fx, fy) = (uv[0][i] * w as f32 - 0.5, uv[1][i] * h as f32 - 0.5);
                let fast = fx.abs() < 8_388_608.0 && fy.abs() < 8_388_608.0;
                assert_eq!(
                    lanes.exact[i], fast,
                    "lane {i}: {w}×{h} at {}, {}",
                    uv[0][i], uv[1][i]
                );
                if !fast {
                    continue;
                }
                let want = bilinear_taps(w, h, Vec2::new(uv[0][i], uv[1][i]));
                for (j, (index, weight)) in want.into_iter().enumerate() {
                    assert_eq!(
                        lanes.index[j][i] as usize, index,
                        "lane {i} tap {j}: {w}×{h} at {}, {}",
                        uv[0][i], uv[1][i]
                    );
                    assert_eq!(
                        lanes.weight[j][i].to_bits(),
                        weight.to_bits(),
                        "lane {i} tap {j}"
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 2500, "only {checked} lanes on the fast path");
    }

    #[test]
    fn flat_map_leaves_normal_unchanged_and_bad_input_errors() {
        let m = NormalMap::from_rgb(2, 2, &[Vec3::new(0.5, 0.5, 1.0); 4]).unwrap();
        let n = Vec3::new(0.3, 0.4, -0.5).normalize();
        let p = m.perturb(n, Vec3::X.extend(1.0), Vec2::new(0.37, 0.91));
        assert!((p - n).length() < 1e-6, "{p} vs {n}");
        assert!(NormalMap::from_vectors(2, 2, &[Vec3::Z; 3]).is_err());
        assert!(NormalMap::from_vectors(1, 1, &[Vec3::ZERO]).is_err());
        assert!(NormalMap::from_vectors(0, 1, &[]).is_err());
        // A grayscale image (a height map given by mistake) is refused.
        let gray = [Vec3::splat(0.2), Vec3::splat(0.8)];
        assert!(matches!(
            NormalMap::from_rgb(2, 1, &gray),
            Err(TextureError::Grayscale)
        ));
    }

    #[test]
    fn bilinear_wraps() {
        let v = vec![Vec3::X, Vec3::Y];
        let m = NormalMap::from_vectors(2, 1, &v).unwrap();
        // u = 0 lies half-way between texel 1 (wrapped) and texel 0.
        let s = m.sample(Vec2::new(0.0, 0.5));
        assert!(
            (s - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6,
            "{s}"
        );
        assert!((m.sample(Vec2::new(1.25, 0.5)) - Vec3::X).length() < 1e-6);
    }

    #[test]
    fn bumps_tilt_is_bounded() {
        let m = NormalMap::bumps(64, 4, 0.6);
        let max = m
            .texels
            .iter()
            .map(|t| t.z.clamp(-1.0, 1.0).acos())
            .fold(0.0f32, f32::max);
        assert!(max <= 0.6 + 1e-5 && max > 0.5, "max tilt {max}");
    }
}
