//! Wavelet BRDF slices (wavelet-rotation-2006 §3 "Precomputing BRDFs").
//!
//! # What
//! For each view direction ω_o at a texel centre of a `views × views`
//! hemi-octahedral grid (local frame, normal +Z), the slice
//! `F_t = ∫_{texel t} f(ω_o, ω) cos θ dω` over the texels `t` of the `m × m`
//! hemi-octahedral target map — the BRDF times cosine **integrated over each
//! target texel**, i.e. with the texel's solid angle folded in — is
//! Haar-transformed and its `terms` largest coefficients kept (one index set
//! for R, G, B ranked by `r² + g² + b²`). With the local lighting `L̃_t`
//! (mean radiance over texel `t`, see [`crate::rotation`]) the reflected
//! radiance is the quadrature `B = Σ_t L̃_t F_t = 𝐅 · 𝐋̃` (paper Eq. 7, Parseval).
//!
//! The per-texel integral uses `ss × ss` stratified samples weighted by the
//! exact hemi-octahedral area element (`ss` = `supersample`).
//!
//! # File (`RLWVBRD1`, see [`crate::format`])
//! params = `[m, views, terms, supersample, key_hash_lo, key_hash_hi,
//! energy_fraction_bits (f32), 0]`; sections `indices: [u16; V·terms]`,
//! `values: [[f32; 3]; V·terms]` (slices padded with zero values at index 0),
//! `V = views²`.

use crate::error::{WaveletError, bad};
use crate::format::{self, read_file, split_sections, write_file};
use crate::octa::{hemi_density, hemi_dir_from_uv, hemi_uv_from_dir_f32};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use relight_brdf::Brdf;
use relight_haar::{Ranking, energy_fraction, forward_2d_with_scratch, top_k_rgb};
use relight_render::Progress;
use std::path::Path;

const MAGIC: [u8; 8] = *b"RLWVBRD1";

/// Parameters of a BRDF bake.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct BrdfBakeParams {
    /// Target hemi-octahedral side (M = m²); must equal the rotation matrices' m.
    pub m: usize,
    /// View grid side (views² slices), e.g. 64 or 128.
    pub views: usize,
    /// Wavelet terms kept per slice (≤ M).
    pub terms: usize,
    /// Supersampling per target texel side (1..=16).
    pub supersample: usize,
    /// Identifies the BRDF: its [`relight_brdf::Brdf::label`] (e.g. `ggx:0.1`); hashed into the
    /// file and the cache name.
    pub key: String,
}

impl BrdfBakeParams {
    /// Defaults: supersampling 2 × 2 per target texel.
    #[must_use]
    pub fn new(key: &str, m: usize, views: usize, terms: usize) -> Self {
        Self {
            m,
            views,
            terms,
            supersample: 2,
            key: key.to_string(),
        }
    }

    /// Checks every parameter.
    ///
    /// # Errors
    /// [`WaveletError::BadParam`].
    pub fn validate(&self) -> Result<(), WaveletError> {
        if !self.m.is_power_of_two() || !(2..=256).contains(&self.m) {
            return Err(bad("m", self.m, "must be a power of two in 2..=256"));
        }
        if !(1..=1024).contains(&self.views) {
            return Err(bad("views", self.views, "must be in 1..=1024"));
        }
        if self.terms == 0 || self.terms > self.m * self.m {
            return Err(bad(
                "terms",
                self.terms,
                format!("must be in 1..=M = {}", self.m * self.m),
            ));
        }
        if !(1..=16).contains(&self.supersample) {
            return Err(bad("supersample", self.supersample, "must be in 1..=16"));
        }
        Ok(())
    }

    fn key_hash(&self) -> u64 {
        format::fnv1a64(self.key.as_bytes())
    }

    fn header_params(&self, energy: f32) -> [u32; 8] {
        let h = self.key_hash();
        [
            self.m as u32,
            self.views as u32,
            self.terms as u32,
            self.supersample as u32,
            h as u32,
            (h >> 32) as u32,
            energy.to_bits(),
            0,
        ]
    }

    /// Cache file name (hash of every parameter, the key and the format version).
    #[must_use]
    pub fn cache_file_name(&self) -> String {
        let mut bytes = Vec::new();
        for p in self.header_params(0.0) {
            bytes.extend_from_slice(&p.to_le_bytes());
        }
        bytes.extend_from_slice(&format::FORMAT_VERSION.to_le_bytes());
        // The key (a `Brdf::label`, e.g. `lambert@0.25,0.2,0.3`) made safe for
        // any file system; the hash below tells truncated keys apart.
        let safe: String = self
            .key
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '.' | ',' | '@') {
                    c
                } else {
                    '_'
                }
            })
            .take(40)
            .collect();
        format!(
            "brdf-{safe}-m{}-v{}-k{}-v{}-{:016x}.bin",
            self.m,
            self.views,
            self.terms,
            format::FORMAT_VERSION,
            format::fnv1a64(&bytes)
        )
    }
}

/// Baked BRDF slices, ready for the view-change step.
#[derive(Clone, Debug)]
pub struct BrdfBake {
    /// Parameters (the key is only known as a hash after loading: `key` is then `#<hash>`).
    pub params: BrdfBakeParams,
    key_hash: u64,
    /// Mean fraction of the slices' L2 energy kept by the top-`terms` approximation.
    pub energy_fraction: f32,
    /// `views² × terms` target coefficient indices.
    pub indices: Vec<u16>,
    /// `views² × terms` RGB values.
    pub values: Vec<Vec3A>,
    /// True when every slice equals the first (a view-independent BRDF such
    /// as Lambert): the renderer then needs one slice per vertex whatever
    /// the normal-blend rule.
    pub view_independent: bool,
}

/// Whether all `terms`-long slices equal the first one (relative 1e-6).
fn slices_identical(indices: &[u16], values: &[Vec3A], terms: usize) -> bool {
    let (i0, v0) = (&indices[..terms], &values[..terms]);
    let scale = v0.iter().fold(0.0f32, |a, v| a.max(v.abs().max_element()));
    indices
        .chunks(terms)
        .zip(values.chunks(terms))
        .all(|(i, v)| {
            i == i0
                && v.iter()
                    .zip(v0)
                    .all(|(a, b)| (*a - *b).abs().max_element() <= 1e-6 * scale)
        })
}

/// Unapproximated slice (Haar coefficients, `M` values) for the local view `wo`.
#[must_use]
pub fn brdf_slice(brdf: &dyn Brdf, wo: Vec3, m: usize, ss: usize) -> Vec<[f32; 3]> {
    let mut tex = vec![[0.0f32; 3]; m * m];
    let cell = 1.0 / (m * m * ss * ss) as f64;
    for (t, out) in tex.iter_mut().enumerate() {
        let (c, r) = (t % m, t / m);
        let mut acc = Vec3::ZERO;
        for sy in 0..ss {
            for sx in 0..ss {
                let u = (c as f64 + (sx as f64 + 0.5) / ss as f64) / m as f64;
                let v = (r as f64 + (sy as f64 + 0.5) / ss as f64) / m as f64;
                let wi = hemi_dir_from_uv(u, v).as_vec3();
                let dw = (hemi_density(u, v) * cell) as f32;
                acc += brdf.eval(wo, wi) * (wi.z.max(0.0) * dw);
            }
        }
        *out = acc.to_array();
    }
    let mut chan = vec![0.0f32; m * m];
    let mut scratch = vec![0.0f32; m * m];
    for c in 0..3 {
        for (d, s) in chan.iter_mut().zip(&tex) {
            *d = s[c];
        }
        forward_2d_with_scratch(&mut chan, m, &mut scratch);
        for (s, d) in tex.iter_mut().zip(&chan) {
            s[c] = *d;
        }
    }
    tex
}

/// The view direction (local, unit) of view texel `k`.
#[must_use]
pub fn view_dir(k: usize, views: usize) -> Vec3 {
    let (c, r) = (k % views, k / views);
    hemi_dir_from_uv(
        (c as f64 + 0.5) / views as f64,
        (r as f64 + 0.5) / views as f64,
    )
    .as_vec3()
}

/// Bakes the BRDF slices of `brdf` (parallel over view directions).
///
/// # Errors
/// Invalid parameters or cancellation.
pub fn bake_brdf(
    params: &BrdfBakeParams,
    brdf: &dyn Brdf,
    progress: &dyn Progress,
) -> Result<BrdfBake, WaveletError> {
    params.validate()?;
    let (m, v, k) = (params.m, params.views, params.terms);
    let count = v * v;
    progress.start("bake BRDF slices", count as u64);
    let mut indices = vec![0u16; count * k];
    let mut values = vec![Vec3A::ZERO; count * k];
    let mut energy = 0.0f64;
    let rows = v.max(1);
    for r0 in (0..count).step_by(rows * 8) {
        progress.check()?;
        let r1 = (r0 + rows * 8).min(count);
        let res: Vec<(Vec<u16>, Vec<Vec3A>, f64)> = (r0..r1)
            .into_par_iter()
            .map(|s| {
                let coeffs = brdf_slice(brdf, view_dir(s, v), m, params.supersample);
                let top = top_k_rgb(&coeffs, m, k, Ranking::Magnitude);
                let e = energy_fraction(&top, &coeffs);
                progress.inc(1);
                (
                    top.indices.iter().map(|&i| i as u16).collect(),
                    top.values.iter().map(|v| Vec3A::from_array(*v)).collect(),
                    e,
                )
            })
            .collect();
        for (off, (idx, val, e)) in res.into_iter().enumerate() {
            let s = r0 + off;
            indices[s * k..s * k + idx.len()].copy_from_slice(&idx);
            values[s * k..s * k + val.len()].copy_from_slice(&val);
            energy += e;
        }
    }
    progress.finish();
    Ok(BrdfBake {
        params: params.clone(),
        key_hash: params.key_hash(),
        energy_fraction: (energy / count as f64) as f32,
        view_independent: slices_identical(&indices, &values, k),
        indices,
        values,
    })
}

impl BrdfBake {
    /// Slice index of the nearest baked view direction to the local `wo`
    /// (paper: nearest view, no interpolation, with a dense view grid).
    #[inline]
    #[must_use]
    pub fn nearest_slice(&self, wo: Vec3) -> usize {
        let (u, v) = hemi_uv_from_dir_f32(wo);
        let n = self.params.views;
        let c = ((u * n as f32) as usize).min(n - 1);
        let r = ((v * n as f32) as usize).min(n - 1);
        r * n + c
    }

    /// Terms of slice `s`: (target indices, RGB values).
    #[inline]
    #[must_use]
    pub fn slice(&self, s: usize) -> (&[u16], &[Vec3A]) {
        let k = self.params.terms;
        (
            &self.indices[s * k..(s + 1) * k],
            &self.values[s * k..(s + 1) * k],
        )
    }

    /// Writes the bake file atomically.
    ///
    /// # Errors
    /// IO errors naming `path`.
    pub fn save(&self, path: &Path) -> Result<(), WaveletError> {
        let vals: Vec<[f32; 3]> = self.values.iter().map(|v| v.to_array()).collect();
        let mut hp = self.params.header_params(self.energy_fraction);
        hp[4] = self.key_hash as u32;
        hp[5] = (self.key_hash >> 32) as u32;
        write_file(
            path,
            MAGIC,
            hp,
            &[
                bytemuck::cast_slice(&self.indices),
                bytemuck::cast_slice(&vals),
            ],
        )
    }

    /// Reads and validates a bake file.
    ///
    /// # Errors
    /// IO, foreign, stale-version, truncated or corrupted files.
    pub fn load(path: &Path) -> Result<Self, WaveletError> {
        let file = read_file(path, MAGIC, "brdf")?;
        let h = file.header.params;
        let key_hash = u64::from(h[4]) | (u64::from(h[5]) << 32);
        let params = BrdfBakeParams {
            m: h[0] as usize,
            views: h[1] as usize,
            terms: h[2] as usize,
            supersample: h[3] as usize,
            key: format!("#{key_hash:016x}"),
        };
        let corrupt = |why: String| WaveletError::Corrupt {
            path: path.to_path_buf(),
            why,
        };
        params
            .validate()
            .map_err(|e| corrupt(format!("bad parameters in header: {e}")))?;
        let total = params.views * params.views * params.terms;
        let secs = split_sections(file.payload(), &[total * 2, total * 12])
            .ok_or_else(|| corrupt("section sizes do not match the header".into()))?;
        let indices: Vec<u16> = bytemuck::pod_collect_to_vec(secs[0]);
        let vals: Vec<[f32; 3]> = bytemuck::pod_collect_to_vec(secs[1]);
        let mm = params.m * params.m;
        if indices.iter().any(|&i| i as usize >= mm) {
            return Err(corrupt("coefficient index out of range".into()));
        }
        let values: Vec<Vec3A> = vals.into_iter().map(Vec3A::from_array).collect();
        Ok(Self {
            view_independent: slices_identical(&indices, &values, params.terms),
            params,
            key_hash,
            energy_fraction: f32::from_bits(h[6]),
            indices,
            values,
        })
    }

    /// [`BrdfBake::load`], then checks that the file matches `want` (key included).
    ///
    /// # Errors
    /// As `load`, plus [`WaveletError::ParamMismatch`].
    pub fn load_expect(path: &Path, want: &BrdfBakeParams) -> Result<Self, WaveletError> {
        let mut b = Self::load(path)?;
        let same = b.params.m == want.m
            && b.params.views == want.views
            && b.params.terms == want.terms
            && b.params.supersample == want.supersample
            && b.key_hash == want.key_hash();
        if !same {
            return Err(WaveletError::ParamMismatch {
                path: path.to_path_buf(),
                found: format!("{:?}", b.params),
                requested: format!("{want:?}"),
            });
        }
        b.params.key.clone_from(&want.key);
        Ok(b)
    }
}
