//! [`LightField`]: an area light whose radiance varies with the direction it
//! is emitted in as well as with the point on the light (sun-thesis-2008
//! §4.5.3, eq. 4.37: `F(v₁, v₂)`, position × direction).
//!
//! # Parameterisation
//! A direction `ω` leaving the light's emitting side (`ω·ẑ > 0`, columns
//! `x̂, ŷ, ẑ` of [`AreaLight::world_from_light`](crate::AreaLight)) is given
//! by its *slope* `σ = (ω·x̂, ω·ŷ) / (ω·ẑ)`: the offset per unit distance
//! from the light, the plane-plane (two-plane) parameterisation of light
//! fields the thesis' face uses too. The field holds `A × A` *views*, each a
//! texture over the light's uv (as [`AreaLight::texture`](crate::AreaLight)):
//! view `(a_x, a_y)` is the radiance towards every slope of the cell
//!
//! ```text
//!   σ_x ∈ [−e + a_x·2e/A, −e + (a_x+1)·2e/A),  σ_y likewise with a_y,
//! ```
//!
//! `e` the *extent*; towards slopes outside `[−e, e]²` (grazing directions)
//! the light emits nothing. Between views the radiance is piecewise
//! constant (no blend), so a field whose cells fall on the near-field
//! method's face cells is represented exactly in its Haar basis.
//!
//! # Images
//! A field is read from one image of `A × A` equal tiles, the sub-aperture
//! layout of light-field archives: the tile in column `c` and row `r` (from
//! the top) is view `(c, A − 1 − r)`: `σ_x` grows to the right and `σ_y`
//! upwards, as `ŷ` points up the light's texture.

use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// An area light's radiance by point and emitted direction (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct LightField {
    views: usize,
    extent: f32,
    /// `views²` textures, index `a_y · views + a_x`.
    textures: Vec<Texture>,
}

impl LightField {
    /// From `views²` textures (index `a_y · views + a_x`) over slopes
    /// `[−extent, extent]²`.
    ///
    /// # Errors
    /// `views` zero, `extent` not finite and > 0, or a texture count other
    /// than `views²`.
    pub fn try_new(views: usize, extent: f32, textures: Vec<Texture>) -> Result<Self, String> {
        if views == 0 || views > 64 {
            return Err(format!("views {views}: must be 1…64 per axis"));
        }
        if !(extent.is_finite() && extent > 0.0) {
            return Err(format!("extent {extent}: must be a finite slope > 0"));
        }
        if textures.len() != views * views {
            return Err(format!(
                "{} views given, {views} × {views} = {} needed",
                textures.len(),
                views * views
            ));
        }
        Ok(Self {
            views,
            extent,
            textures,
        })
    }

    /// The field held by `image`, `views × views` equal tiles in the
    /// sub-aperture layout (module docs).
    ///
    /// # Errors
    /// A side not divisible by `views`, or as [`Self::try_new`].
    pub fn from_tiles(image: &Texture, views: usize, extent: f32) -> Result<Self, String> {
        if views == 0 || !image.width.is_multiple_of(views) || !image.height.is_multiple_of(views) {
            return Err(format!(
                "a {}×{} image does not split into {views} × {views} equal tiles",
                image.width, image.height
            ));
        }
        let (tw, th) = (image.width / views, image.height / views);
        let mut textures = Vec::with_capacity(views * views);
        for ay in 0..views {
            let row = views - 1 - ay;
            for col in 0..views {
                let texels = (0..th)
                    .flat_map(|y| {
                        let start = (row * th + y) * image.width + col * tw;
                        image.texels[start..start + tw].iter().copied()
                    })
                    .collect();
                textures.push(Texture::try_new(tw, th, texels).map_err(|e| e.to_string())?);
            }
        }
        Self::try_new(views, extent, textures)
    }

    /// A built-in field for examples and tests: `base` seen through a
    /// prism-like film, its colour turning from warm (towards `−x̂`) through
    /// white (straight down) to cool (towards `+x̂`), and dimmer towards
    /// large `|σ_y|`: `views × views` views over `[−extent, extent]²`.
    ///
    /// # Panics
    /// `views == 0` or `extent` not > 0.
    #[must_use]
    pub fn prism(base: &Texture, views: usize, extent: f32) -> Self {
        let textures = (0..views * views)
            .map(|i| {
                let (ax, ay) = (i % views, i / views);
                let centre = |a: usize| ((a as f32 + 0.5) / views as f32) * 2.0 - 1.0;
                let (cx, cy) = (centre(ax), centre(ay));
                let warm = Vec3::new(1.6, 0.9, 0.35);
                let cool = Vec3::new(0.35, 0.9, 1.6);
                let tint = if cx < 0.0 {
                    Vec3::ONE.lerp(warm, -cx)
                } else {
                    Vec3::ONE.lerp(cool, cx)
                } * (1.0 - 0.5 * cy.abs());
                let texels = base.texels.iter().map(|&t| t * tint).collect();
                Texture::try_new(base.width, base.height, texels).expect("scaled valid texels")
            })
            .collect();
        Self::try_new(views, extent, textures).expect("views > 0 and extent > 0")
    }

    /// Views per axis `A`.
    #[must_use]
    pub fn views(&self) -> usize {
        self.views
    }

    /// The largest slope `e` emitted along either axis.
    #[must_use]
    pub fn extent(&self) -> f32 {
        self.extent
    }

    /// View `(a_x, a_y)`'s texture.
    #[must_use]
    pub fn view(&self, ax: usize, ay: usize) -> &Texture {
        &self.textures[ay * self.views + ax]
    }

    /// The view `(a_x, a_y)` holding slope `σ`, or `None` past the extent.
    #[must_use]
    pub fn view_of(&self, slope: Vec2) -> Option<(usize, usize)> {
        let cell = |s: f32| {
            let f = (s + self.extent) / (2.0 * self.extent) * self.views as f32;
            (f >= 0.0 && f < self.views as f32).then_some(f as usize)
        };
        Some((cell(slope.x)?, cell(slope.y)?))
    }

    /// Radiance at uv towards slope `σ` (0 past the extent).
    #[must_use]
    pub fn radiance(&self, uv: Vec2, slope: Vec2) -> Vec3 {
        self.view_of(slope)
            .map_or(Vec3::ZERO, |(ax, ay)| self.view(ax, ay).sample(uv))
    }

    /// The slopes `[lo, hi)` of view cell `a` along one axis.
    #[must_use]
    pub fn cell(&self, a: usize) -> [f32; 2] {
        let w = 2.0 * self.extent / self.views as f32;
        [
            -self.extent + a as f32 * w,
            -self.extent + (a + 1) as f32 * w,
        ]
    }

    /// The projected solid angle of view cell `(a_x, a_y)` seen from a point
    /// of the light, `∫∫ (1 + |σ|²)⁻² dσ` over the cell (the cosine at the
    /// light times the solid angle per unit slope area; midpoint rule, 16²
    /// points), for [`AreaLight::power`](crate::AreaLight::power).
    #[must_use]
    pub fn projected_solid_angle(&self, ax: usize, ay: usize) -> f32 {
        const Q: usize = 16;
        let ([x0, x1], [y0, y1]) = (self.cell(ax), self.cell(ay));
        let (hx, hy) = ((x1 - x0) / Q as f32, (y1 - y0) / Q as f32);
        let mut sum = 0.0;
        for j in 0..Q {
            let y = y0 + (j as f32 + 0.5) * hy;
            for i in 0..Q {
                let x = x0 + (i as f32 + 0.5) * hx;
                let r = 1.0 + x * x + y * y;
                sum += 1.0 / (r * r);
            }
        }
        sum * hx * hy
    }
}

#[cfg(test)]
mod tests {
    use super::LightField;
    use crate::texture::Texture;
    use glam::{Vec2, Vec3};

    fn tile_image(views: usize) -> Texture {
        // Tile (c, r) filled with (c, r, 1).
        let (tw, th) = (3, 2);
        let (w, h) = (views * tw, views * th);
        let texels = (0..w * h)
            .map(|i| Vec3::new(((i % w) / tw) as f32, ((i / w) / th) as f32, 1.0))
            .collect();
        Texture::try_new(w, h, texels).unwrap()
    }

    #[test]
    fn tiles_map_to_views_with_slope_y_upwards() {
        let lf = LightField::from_tiles(&tile_image(4), 4, 1.0).unwrap();
        for ay in 0..4 {
            for ax in 0..4 {
                let t = lf.view(ax, ay);
                assert_eq!((t.width, t.height), (3, 2));
                assert!(
                    t.texels
                        .iter()
                        .all(|&v| v == Vec3::new(ax as f32, (3 - ay) as f32, 1.0))
                );
            }
        }
        // Slope (−0.9, 0.9): leftmost column, top row of tiles.
        assert_eq!(lf.view_of(Vec2::new(-0.9, 0.9)), Some((0, 3)));
        assert_eq!(lf.view_of(Vec2::new(0.1, -0.1)), Some((2, 1)));
        assert_eq!(lf.view_of(Vec2::new(1.01, 0.0)), None);
        assert_eq!(
            lf.radiance(Vec2::splat(0.5), Vec2::new(0.0, -1.5)),
            Vec3::ZERO
        );
    }

    #[test]
    fn bad_fields_are_refused() {
        let img = tile_image(3);
        assert!(
            LightField::from_tiles(&img, 2, 1.0).is_err(),
            "9×6 in 2×2 tiles"
        );
        assert!(LightField::from_tiles(&img, 3, 0.0).is_err());
        assert!(LightField::from_tiles(&img, 3, f32::NAN).is_err());
        assert!(LightField::try_new(2, 1.0, vec![]).is_err());
    }

    #[test]
    fn projected_solid_angle_sums_to_the_square_form_factor() {
        // Over the whole slope square [−e, e]²: π × (form factor of a
        // parallel square), 4·parallel_rect_corner(e, e) in closed form.
        let e = 1.5f32;
        let lf = LightField::prism(&Texture::constant(Vec3::ONE).unwrap(), 4, e);
        let sum: f32 = (0..16)
            .map(|i| lf.projected_solid_angle(i % 4, i / 4))
            .sum();
        let corner = |x: f64, y: f64| {
            let (rx, ry) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
            0.5 * (x / rx * (y / rx).atan() + y / ry * (x / ry).atan())
        };
        let exact = 4.0 * corner(f64::from(e), f64::from(e));
        assert!(
            (f64::from(sum) - exact).abs() < 1e-3 * exact,
            "{sum} vs {exact}"
        );
    }
}
