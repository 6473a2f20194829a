//! Source lighting: sampling a spherical function onto the `n × n`
//! octahedral map and its non-linear Haar approximation (wavelet-rotation-2006
//! §3 "Environment Map Rendering": "sample the lighting at run-time onto an
//! n × n octahedral map … projected onto wavelets and non-linearly
//! approximated").

use crate::octa::{oct_density, oct_dir_from_uv};
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use relight_haar::{Ranking, SparseRgb, forward_2d_with_scratch, top_k_rgb};
use relight_sphere::EnvMap;

/// Texel values of `f` on the `n × n` octahedral map: each texel is the
/// solid-angle-weighted mean of `ss × ss` stratified samples (area integral
/// over the texel with the exact area element of the map).
#[must_use]
pub fn sample_octahedral(n: usize, ss: usize, f: impl Fn(Vec3) -> Vec3 + Sync) -> Vec<[f32; 3]> {
    OctSamples::new(n, ss).sample(f)
}

/// The sample points of [`sample_octahedral`] for one `(n, ss)`: directions
/// and solid-angle weights, which do not depend on the lighting, computed
/// once (a lighting change then only evaluates the lighting at them).
#[derive(Clone, Debug)]
pub struct OctSamples {
    n: usize,
    ss: usize,
    /// `ss²` directions per texel, texel-major.
    dirs: Vec<Vec3>,
    /// The area element at each direction (as f32, the factor it multiplies).
    weights: Vec<f32>,
    /// Σ of a texel's weights (summed in f64, then as f32).
    sums: Vec<f32>,
}

impl OctSamples {
    /// The samples of the `n × n` map at `ss × ss` per texel (`ss ≥ 1`).
    #[must_use]
    pub fn new(n: usize, ss: usize) -> Self {
        let ss = ss.max(1);
        let per: Vec<(Vec<(Vec3, f32)>, f32)> = (0..n * n)
            .into_par_iter()
            .map(|t| {
                let (c, r) = (t % n, t / n);
                let mut wsum = 0.0f64;
                let mut pts = Vec::with_capacity(ss * ss);
                for sy in 0..ss {
                    for sx in 0..ss {
                        let u = (c as f64 + (sx as f64 + 0.5) / ss as f64) / n as f64;
                        let v = (r as f64 + (sy as f64 + 0.5) / ss as f64) / n as f64;
                        let w = oct_density(u, v);
                        pts.push((oct_dir_from_uv(u, v).as_vec3(), w as f32));
                        wsum += w;
                    }
                }
                (pts, wsum as f32)
            })
            .collect();
        let mut out = Self {
            n,
            ss,
            dirs: Vec::with_capacity(n * n * ss * ss),
            weights: Vec::with_capacity(n * n * ss * ss),
            sums: Vec::with_capacity(n * n),
        };
        for (pts, sum) in per {
            for (d, w) in pts {
                out.dirs.push(d);
                out.weights.push(w);
            }
            out.sums.push(sum);
        }
        out
    }

    /// Map side n and samples per texel side ss.
    #[must_use]
    pub fn size(&self) -> (usize, usize) {
        (self.n, self.ss)
    }

    /// Texel values of `f` ([`sample_octahedral`]).
    #[must_use]
    pub fn sample(&self, f: impl Fn(Vec3) -> Vec3 + Sync) -> Vec<[f32; 3]> {
        let k = self.ss * self.ss;
        self.dirs
            .par_chunks(k)
            .zip(self.weights.par_chunks(k))
            .zip(self.sums.par_iter())
            .map(|((dirs, weights), &sum)| {
                let mut acc = Vec3::ZERO;
                for (&d, &w) in dirs.iter().zip(weights) {
                    acc += f(d) * w;
                }
                (acc / sum).to_array()
            })
            .collect()
    }

    /// Texel values of `env` seen through `env_from_world`: [`OctSamples::sample`]
    /// of `|d| env.eval(env_from_world * d)`, bit for bit, with the lookups
    /// of a texel made together ([`EnvMap::eval_many`]).
    #[must_use]
    pub fn sample_env(&self, env: &EnvMap, env_from_world: Mat3) -> Vec<[f32; 3]> {
        /// Samples per texel at most (`ss` ≤ 8).
        const MAX: usize = 64;
        let k = self.ss * self.ss;
        if k > MAX {
            return self.sample(|d| env.eval(env_from_world * d));
        }
        self.dirs
            .par_chunks(k)
            .zip(self.weights.par_chunks(k))
            .zip(self.sums.par_iter())
            .map(|((dirs, weights), &sum)| {
                let mut radiance = [Vec3::ZERO; MAX];
                env.eval_many(env_from_world, dirs, &mut radiance[..k]);
                let mut acc = Vec3::ZERO;
                for (&l, &w) in radiance[..k].iter().zip(weights) {
                    acc += l * w;
                }
                (acc / sum).to_array()
            })
            .collect()
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// [`OctSamples::sample_env`] is [`OctSamples::sample`] of the rotated
    /// map's lookups, bit for bit (lat-long: the block path; octahedral: one
    /// lookup each), at every supersampling the renderer picks.
    #[test]
    fn sample_env_equals_sampling_the_lookups() {
        let param = relight_sphere::Param::LatLong {
            width: 48,
            height: 24,
        };
        let texels = (0..param.len())
            .map(|i| Vec3::new(1.0 + (i as f32).sin(), 0.1 * (i % 7) as f32, 0.5))
            .collect();
        let latlong = EnvMap { param, texels };
        let oct = latlong.resample(relight_sphere::Param::Octahedral { n: 8 }, 1);
        let m = Mat3::from_euler(glam::EulerRot::YXZ, 1.1, 0.4, -0.2);
        for env in [&latlong, &oct] {
            for ss in [1, 4, 6, 8, 9] {
                let s = OctSamples::new(8, ss);
                let bits = |v: Vec<[f32; 3]>| -> Vec<[u32; 3]> {
                    v.iter().map(|t| t.map(f32::to_bits)).collect()
                };
                assert_eq!(
                    bits(s.sample_env(env, m)),
                    bits(s.sample(|d| env.eval(m * d))),
                    "ss {ss}"
                );
            }
        }
    }

    /// The samples kept by [`OctSamples`] give the bits of evaluating the
    /// map's points and weights at every call (the computation they replace).
    #[test]
    fn kept_samples_equal_the_direct_area_integral() {
        let f = |d: Vec3| Vec3::new(1.0 + d.x, (3.0 * d.y).sin().abs(), d.z * d.z);
        for (n, ss) in [(8, 1), (16, 3), (8, 6)] {
            let direct: Vec<[f32; 3]> = (0..n * n)
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
                .collect();
            let kept = OctSamples::new(n, ss);
            for _ in 0..2 {
                let got = kept.sample(f);
                assert_eq!(got.len(), direct.len());
                for (g, d) in got.iter().zip(&direct) {
                    assert_eq!(g.map(f32::to_bits), d.map(f32::to_bits), "n {n} ss {ss}");
                }
            }
        }
    }
}
