//! Source lighting: sampling a spherical function onto the `n × n`
//! octahedral map and its non-linear Haar approximation (wavelet-rotation-2006
//! §3 "Environment Map Rendering": "sample the lighting at run-time onto an
//! n × n octahedral map … projected onto wavelets and non-linearly
//! approximated").

use crate::octa::{oct_density, oct_dir_from_uv};
use glam::Vec3;
use rayon::prelude::*;
use relight_haar::{Ranking, SparseRgb, forward_2d_with_scratch, top_k_rgb};

/// Texel values of `f` on the `n × n` octahedral map: each texel is the
/// solid-angle-weighted mean of `ss × ss` stratified samples (area integral
/// over the texel with the exact area element of the map).
#[must_use]
pub fn sample_octahedral(n: usize, ss: usize, f: impl Fn(Vec3) -> Vec3 + Sync) -> Vec<[f32; 3]> {
    let ss = ss.max(1);
    (0..n * n)
        .into_par_iter()
        .map(|t| {
            let (c, r) = (t % n, t / n);
            let (mut acc, mut wsum) = (Vec3::ZERO, 0.0f64);
            for sy in 0..ss {
                for sx in 0..ss {
                    let u = (c as f64 + (sx as f64 + 0.5) / ss as f64) / n as f64;
                    let v = (r as f64 + (sy as f64 + 0.5) / ss as f64) / n as f64;
                    let w = oct_density(u, v);
                    acc += f(oct_dir_from_uv(u, v).as_vec3()) * w as f32;
                    wsum += w;
                }
            }
            (acc / wsum as f32).to_array()
        })
        .collect()
}

/// Haar transform (orthonormal, nonstandard) of an RGB `n × n` map.
#[must_use]
pub fn haar_rgb(texels: &[[f32; 3]], n: usize) -> Vec<[f32; 3]> {
    let mut out = texels.to_vec();
    let mut chan = vec![0.0f32; n * n];
    let mut scratch = vec![0.0f32; n * n];
    for c in 0..3 {
        for (d, s) in chan.iter_mut().zip(texels) {
            *d = s[c];
        }
        forward_2d_with_scratch(&mut chan, n, &mut scratch);
        for (o, d) in out.iter_mut().zip(&chan) {
            o[c] = *d;
        }
    }
    out
}

/// Samples `f`, transforms and keeps the top `terms` coefficients (shared
/// RGB index set ranked by `r² + g² + b²`, see `relight_haar::top_k_rgb`).
/// Returns the sparse lighting and the full coefficient vector.
#[must_use]
pub fn project_lighting(
    n: usize,
    terms: usize,
    ranking: Ranking,
    f: impl Fn(Vec3) -> Vec3 + Sync,
) -> (SparseRgb, Vec<[f32; 3]>) {
    let texels = sample_octahedral(n, 2, f);
    let coeffs = haar_rgb(&texels, n);
    (top_k_rgb(&coeffs, n, terms, ranking), coeffs)
}
