//! [`Image`]: a linear RGB float framebuffer.

use glam::Vec3;

/// Linear RGB pixels, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    #[must_use]
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width * height],
        }
    }

    /// Pixel at column `x`, row `y`.
    #[inline]
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> Vec3 {
        self.pixels[y * self.width + x]
    }

    /// Relative RMS error of `self` against `reference` over the pixels where
    /// `mask` is true (all pixels when `None`):
    /// sqrt(Σ|a−b|²) / sqrt(Σ|b|²), RGB channels pooled.
    #[must_use]
    pub fn relative_rms_error(&self, reference: &Image, mask: Option<&[bool]>) -> f64 {
        let mut num = 0.0f64;
        let mut den = 0.0f64;
        for (i, (a, b)) in self.pixels.iter().zip(&reference.pixels).enumerate() {
            if mask.is_some_and(|m| !m[i]) {
                continue;
            }
            num += f64::from((*a - *b).length_squared());
            den += f64::from(b.length_squared());
        }
        if den == 0.0 {
            if num == 0.0 { 0.0 } else { f64::INFINITY }
        } else {
            (num / den).sqrt()
        }
    }
}
