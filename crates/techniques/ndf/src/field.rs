//! The interpolated normal field: what plain normal mapping shades.
//!
//! The renderer, and the reference judging the method, read a normal map
//! bilinearly and renormalise ([`relight_render::NormalMap::sample`]). So a
//! pixel's NDF is the distribution of those *interpolated* normals over its
//! footprint, not of the texel normals. Between two texels the interpolated
//! normal sweeps through the directions in between. Its mean is longer than
//! the texels' mean, and on a glossy lobe it makes highlights that the texel
//! normals alone miss.
//!
//! The method's SH and vMF pyramids are therefore built from this field,
//! sampled `s × s` per texel ([`crate::NdfOptions::supersample`]): level 0
//! holds the field's samples at `s×` the map's resolution, the uv footprint
//! is measured in them, and a footprint within one of them shades the
//! interpolated normal itself ([`crate::Footprint::plain`]). The screen-level
//! figures, before and after, are in `docs/ndf.md`.
//!
//! The texel-level rows of `relight verify ndf` keep the texel normals (the
//! issue's definition: level 0 a delta per texel, exact shading over the
//! fine texels), so they measure the representation alone.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use relight_render::NormalMap;

/// `s·W × s·H` normals of `map`'s interpolated field, row-major: sample
/// `(i, j)` at uv `((i + ½)/(s·W), (j + ½)/(s·H))`, the centres of an
/// `s × s` grid over each texel's cell, so that the grid's `s × s` blocks
/// are the texels' cells ([`NormalMap::sample`]'s `x = u·W − ½` puts texel
/// `i`'s centre at `u = (i + ½)/W`). `s = 1` gives the texels themselves.
#[must_use]
pub fn interpolated_field(map: &NormalMap, s: usize) -> Vec<Vec3> {
    if s <= 1 {
        return map.texels.clone();
    }
    let (fw, fh) = (map.width * s, map.height * s);
    let mut out = vec![Vec3::Z; fw * fh];
    out.par_chunks_mut(fw).enumerate().for_each(|(j, row)| {
        let v = (j as f32 + 0.5) / fh as f32;
        for (i, n) in row.iter_mut().enumerate() {
            *n = map.sample(Vec2::new((i as f32 + 0.5) / fw as f32, v));
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_field_is_the_maps_bilinear_renormalised_sampling() {
        let map = NormalMap::bumps(8, 2, 0.7);
        assert_eq!(interpolated_field(&map, 1), map.texels);
        let f = interpolated_field(&map, 2);
        assert_eq!(f.len(), 16 * 16);
        // Sample (3, 5) of the 2× field sits a quarter texel past texel
        // (1, 2)'s centre on both axes...
        let want = map.sample(Vec2::new(3.5 / 16.0, 5.5 / 16.0));
        assert_eq!(f[5 * 16 + 3], want);
        // ...where bilinear weights are ¾ and ¼ per axis.
        let t = |x: usize, y: usize| map.texels[y * 8 + x];
        let mix =
            (t(1, 2) * 0.75 + t(2, 2) * 0.25) * 0.75 + (t(1, 3) * 0.75 + t(2, 3) * 0.25) * 0.25;
        assert!((f[5 * 16 + 3] - mix.normalize()).length() < 1e-6);
        assert!(f.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
    }
}
