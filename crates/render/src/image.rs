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

    /// The image box-filtered down by `k` in each direction: pixel (x, y) is
    /// the mean of the k × k block at (k·x, k·y) (the reference renderer's
    /// pixel filter, for supersampled rasterization). Trailing rows/columns
    /// that do not fill a block are dropped; `k = 0` is treated as 1.
    #[must_use]
    pub fn box_downsample(&self, k: usize) -> Image {
        let k = k.max(1);
        let (w, h) = (self.width / k, self.height / k);
        let inv = 1.0 / (k * k) as f32;
        let mut out = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let mut acc = Vec3::ZERO;
                for j in 0..k {
                    let row = (y * k + j) * self.width + x * k;
                    for p in &self.pixels[row..row + k] {
                        acc += *p;
                    }
                }
                out.pixels[y * w + x] = acc * inv;
            }
        }
        out
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_downsample_averages_blocks_and_drops_partial_ones() {
        let mut img = Image::new(5, 4);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(i as f32);
        }
        let d = img.box_downsample(2);
        assert_eq!((d.width, d.height), (2, 2));
        // Block (0,0): pixels 0, 1, 5, 6; block (1,1): 12, 13, 17, 18.
        assert_eq!(d.get(0, 0), Vec3::splat(3.0));
        assert_eq!(d.get(1, 1), Vec3::splat(15.0));
        assert_eq!(img.box_downsample(1), img);
        assert_eq!(img.box_downsample(0), img);
    }
}
