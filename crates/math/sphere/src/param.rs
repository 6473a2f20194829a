//! The texel layouts of the sphere: lat-long, cube map, octahedral and
//! hemi-octahedral maps.
//!
//! (Contract written first; the helper that owns this crate documents each
//! layout here: formula + table, Bevy style.)

use glam::{DVec3, Vec3};

/// A parameterization of the sphere (or, for [`Param::HemiOctahedral`], of the
/// upper hemisphere z ≥ 0 of a local frame) by a grid of texels.
///
/// Texels are numbered row-major: `index = row * width + col`; a cube map
/// stacks its six faces vertically (`width = n`, `height = 6 n`, faces in the
/// order +X, −X, +Y, −Y, +Z, −Z).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Param {
    /// Equirectangular, `width × height` (usually width = 2 height); world
    /// +Y up, row 0 at the top (+Y).
    LatLong { width: usize, height: usize },
    /// Six `n × n` faces.
    Cube { n: usize },
    /// Praun–Hoppe octahedral map of the whole sphere, `n × n`, poles on ±Z
    /// (+Z at the centre of the square).
    Octahedral { n: usize },
    /// Octahedral map of the upper hemisphere z ≥ 0, `n × n` (the inner
    /// diamond of the octahedral map stretched to the square).
    HemiOctahedral { n: usize },
}

/// Four texels and bilinear weights that sum to 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bilinear {
    pub texels: [u32; 4],
    pub weights: [f32; 4],
}

impl Param {
    /// Grid width in texels.
    #[must_use]
    pub fn width(&self) -> usize {
        todo!()
    }
    /// Grid height in texels (6 n for a cube map).
    #[must_use]
    pub fn height(&self) -> usize {
        todo!()
    }
    /// Number of texels.
    #[must_use]
    pub fn len(&self) -> usize {
        self.width() * self.height()
    }
    /// Total solid angle covered: 4π, or 2π for the hemisphere.
    #[must_use]
    pub fn total_solid_angle(&self) -> f64 {
        todo!()
    }
    /// Direction through the continuous map coordinate `uv` ∈ [0,1]² of the
    /// whole grid (texel centres at `(col + 0.5) / width`).
    #[must_use]
    pub fn dir_from_uv(&self, uv: glam::DVec2) -> DVec3 {
        let _ = uv;
        todo!()
    }
    /// Continuous map coordinate of a direction (inverse of `dir_from_uv`).
    #[must_use]
    pub fn uv_from_dir(&self, d: DVec3) -> glam::DVec2 {
        let _ = d;
        todo!()
    }
    /// Direction through the centre of texel `i` (unit length).
    #[must_use]
    pub fn dir_from_texel(&self, i: usize) -> Vec3 {
        let _ = i;
        todo!()
    }
    /// Texel containing direction `d` (need not be normalised; must be non-zero).
    #[must_use]
    pub fn texel_from_dir(&self, d: Vec3) -> usize {
        let _ = d;
        todo!()
    }
    /// Exact solid angle of texel `i` in steradians (analytic, f64).
    #[must_use]
    pub fn texel_solid_angle(&self, i: usize) -> f64 {
        let _ = i;
        todo!()
    }
    /// All texel solid angles, f32, in texel order (handy for quadrature).
    #[must_use]
    pub fn solid_angles(&self) -> Vec<f32> {
        (0..self.len()).map(|i| self.texel_solid_angle(i) as f32).collect()
    }
    /// All texel centre directions in texel order.
    #[must_use]
    pub fn directions(&self) -> Vec<Vec3> {
        (0..self.len()).map(|i| self.dir_from_texel(i)).collect()
    }
    /// Bilinear footprint of `d`, continuous across seams and poles (neighbours
    /// across a seam are the texels adjacent on the sphere).
    #[must_use]
    pub fn bilinear(&self, d: Vec3) -> Bilinear {
        let _ = d;
        todo!()
    }
}
