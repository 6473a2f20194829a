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
    /// As [`NormalMap::from_vectors`].
    pub fn from_rgb(width: usize, height: usize, rgb: &[Vec3]) -> Result<Self, TextureError> {
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

    #[test]
    fn flat_map_leaves_normal_unchanged_and_bad_input_errors() {
        let m = NormalMap::from_rgb(2, 2, &[Vec3::new(0.5, 0.5, 1.0); 4]).unwrap();
        let n = Vec3::new(0.3, 0.4, -0.5).normalize();
        let p = m.perturb(n, Vec3::X.extend(1.0), Vec2::new(0.37, 0.91));
        assert!((p - n).length() < 1e-6, "{p} vs {n}");
        assert!(NormalMap::from_vectors(2, 2, &[Vec3::Z; 3]).is_err());
        assert!(NormalMap::from_vectors(1, 1, &[Vec3::ZERO]).is_err());
        assert!(NormalMap::from_vectors(0, 1, &[]).is_err());
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
