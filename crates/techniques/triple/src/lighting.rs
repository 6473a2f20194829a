//! The pre-rotated lighting table (spherical-wavelets-triple-product-2006
//! §3.2, Eq. 7): the environment expressed in a set of local frames, each as
//! the level-`m` cell averages of the top-only basis.
//!
//! # The frames: normals without a pole on +Y
//! The paper samples Euler angles (32×16 normals × 32 tangent angles), whose
//! pole would sit on +Y, the normal of every floor. relight instead takes the
//! table normals at the **642 vertices of icosahedral level 3** (near-uniform,
//! no pole anywhere; the isotropic table the issue sizes at ~512 normals) and
//! the frame of a normal `n` by the **shortest-arc rule from +Y**: the
//! rotation taking +Y to `n` along the great circle, applied to the frame
//! `(x, y, z) = (+X, −Z, +Y)` at `n = +Y` ([`frame_of`]). It is continuous
//! everywhere except `n = −Y` (downward-facing surfaces).
//!
//! A frame is then `(normal k, twist τ)`: the rule's frame turned by `τ`
//! about the normal; `twists` bins of `2π / twists` cover the tangent angle.
//!
//! # Lookup (interpolating neighbouring frames)
//! A shading frame `G` (in the table's space) finds the level-3 triangle
//! holding `G.z`, its three vertices `k` with barycentric weights, and per
//! vertex the twist `τ_k` of `G.x` projected onto `k`'s tangent plane,
//! linearly between two twist bins: six weighted table entries
//! ([`LightTable::lookup`]). Measuring the twist per neighbour keeps the
//! lookup continuous even across the rule's singularity.
//!
//! # Rotations are lookups
//! With `twists > 1` the table is built once per environment *in the
//! environment's own space*; a change of `world_from_env` `R` only changes
//! the frame looked up (`G = Rᵀ F_x`), no rebuild. With `twists = 1` (the
//! isotropic 642-normal table) the table is built for the current `R` in
//! world space (`G = F_x`, twist 0 exactly) and a rotation rebuilds it.
//!
//! # Cell averages
//! Entry `(k, τ)` holds, per level-`m` cell `c`, the mean of the environment
//! over the cell seen through the frame, from `16` samples per cell (the
//! level `m + 2` centroids: at `m = 2` the paper's 5120 directions; at
//! `m ≥ 3` denser than the paper, which samples 5120 directions always and
//! so aliases small bright windows into a bias that more terms do not
//! remove — 3.5 % on the `hall` probe, measured) read from the environment
//! prefiltered to a lat-long map whose texels match the sample spacing
//! ([`prefilter`]: area-correct, 2×2 supersampled), so that a window or sun
//! narrower than a sample spacing is averaged rather than aliased. Planar RGB per entry; only the
//! cells that reach above the horizon are stored ([`upper_cells`]), unpadded: the kernel walks
//! the cells eight at a time up to [`padded_cells`], so its last load of a lighting plane reads
//! the first cells of the next plane, which meet the BRDF table's zero padding (finite × 0 = 0:
//! f16 lighting saturates, f32 lighting is finite), and the table ends with that many zeros so
//! the last plane's load stays in bounds. At n = 80 this keeps 58 of 64 slots (the 3.75
//! MiB budget for the compact 642 × 16 table: 3.41 MiB, against 3.76 padded).

use crate::basis::triangles;
use crate::storage::{Planes, Storage};
use glam::{Mat3, Quat, Vec3};
use rayon::prelude::*;
use relight_sphere::atan::atan2_f32;
use relight_sphere::ico_weights::IcoWeights;
use relight_sphere::icosahedral::Icosahedral;
use relight_sphere::{EnvMap, Frame, Param};
use std::cell::Cell;
use std::f32::consts::TAU;

/// Icosahedral level of the table normals (642 vertices).
pub const NORMAL_LEVEL: usize = 3;

/// Deepest level of the lighting samples (16 per cell up to `m = 4`).
pub const SAMPLE_LEVEL: usize = 6;

/// The frame of normal `n` by the shortest-arc rule from +Y (module docs).
#[must_use]
pub fn frame_of(n: Vec3) -> Frame {
    let q = Quat::from_rotation_arc(Vec3::Y, n);
    let x = q * Vec3::X;
    Frame {
        x,
        y: n.cross(x),
        z: n,
    }
}

/// A cell direction of level `level`, index `j`, in the local frame
/// (normal +Z): the hierarchy's centroid. Every table (lighting,
/// visibility, BRDF quadrature) reads its cells here.
///
/// The hierarchy's own +Z puts vertices and edge midpoints on the horizon,
/// so 58 / 198 of 80 / 320 cells reach above it ([`upper_cells`]). A generic
/// axis keeps fewer (51 / 181, the least over 30 000 random axes) and was
/// tried: it moved the top-only errors of `verify triple` by up to ±50 %
/// per probe (cell boundaries meeting the probes' windows elsewhere), made
/// two probes' error rise from n = 80 to 320, and so was not kept.
#[must_use]
pub fn cell_dir(ico: &Icosahedral, level: usize, j: usize) -> glam::DVec3 {
    ico.centroid(level, j)
}

/// The level-`m` cells a point's product can use: those with a vertex above
/// the local horizon (z > 0 in the canonical frame, with 1e-6 slack), in
/// increasing triangle order.
///
/// The BRDF term of every table carries `cos⁺θ_i`, and a geodesic triangle
/// whose three vertices lie in `z ≤ 0` lies wholly in that closed hemisphere
/// (a hemisphere is geodesically convex; the quadrature's sample points are
/// normalised convex combinations of the vertices), so its `ρ̂_c` is exactly
/// 0 and so is its term of Eq. 7, whatever the lighting and visibility. Every
/// table therefore stores only these cells, in this order (slot `i` holds
/// cell `upper_cells(m)[i]`): about half the memory and the kernel's work,
/// with no change to any product.
#[must_use]
pub fn upper_cells(m: usize) -> &'static [u32] {
    static CELLS: [std::sync::OnceLock<Vec<u32>>; 5] = [const { std::sync::OnceLock::new() }; 5];
    CELLS[m].get_or_init(|| {
        let ico = Icosahedral::new(m).expect("level ≤ 4 is built");
        let v = ico.vertices();
        ico.triangles(m)
            .iter()
            .enumerate()
            .filter(|(_, t)| t.iter().any(|&i| v[i as usize].z > -1e-6))
            .map(|(c, _)| c as u32)
            .collect()
    })
}

/// Cells stored per function at level `m` ([`upper_cells`]), padded to a
/// multiple of 8 (the padding holds zeros).
#[must_use]
pub fn padded_cells(m: usize) -> usize {
    upper_cells(m).len().div_ceil(8) * 8
}

/// Sample directions of the level-`m` cells in the canonical frame: the
/// centroids of level `m + 2` (as deep as `ico` is built), cell-major (the children of
/// cell `c` are consecutive), and how many fall in each cell.
#[must_use]
pub fn cell_samples(ico: &Icosahedral, m: usize) -> (Vec<Vec3>, usize) {
    let s = (m + 2).min(ico.max_level()).max(m);
    let dirs = (0..triangles(s))
        .map(|j| cell_dir(ico, s, j).as_vec3())
        .collect();
    (dirs, 1 << (2 * (s - m)))
}

/// The lighting table (module docs).
#[derive(Clone, Debug)]
pub struct LightTable {
    /// Top-only level `m` (cells `20·4^m`).
    pub m: usize,
    /// Twist bins per normal (1 = isotropic, rebuilt per rotation).
    pub twists: usize,
    /// Cells per plane ([`upper_cells`], unpadded: module docs).
    pub stride: usize,
    /// Cells the kernel walks ([`padded_cells`]): the BRDF and visibility
    /// stride.
    pub padded: usize,
    /// `space_from_env` the table was built for: identity when `twists > 1`,
    /// else the scene's `world_from_env` at build time.
    pub built_for: Mat3,
    /// Entries `(k, τ)` at `(k · twists + τ) · 3 · stride`: R, G, B planes
    /// ([`crate::storage`]: f32, or f16 when compact).
    pub data: Planes,
    /// [`frame_of`] each table normal (the twist angles are read in it).
    frames: Vec<Frame>,
    /// The weighted locator at [`NORMAL_LEVEL`] (every lookup locates a
    /// normal and weighs its triangle's corners).
    weights: IcoWeights,
    /// The triangles of [`NORMAL_LEVEL`]: corner = table normal index.
    triangles: Vec<[u32; 3]>,
}

thread_local! {
    /// The triangle of this thread's last [`LightTable::lookup`]: neighbouring
    /// pixels' normals mostly share it ([`IcoWeights::locate`] tries it
    /// first). Only a starting guess: the answer never depends on it.
    static LAST_TRIANGLE: Cell<usize> = const { Cell::new(0) };
}

/// One weighted table entry (its offset into [`LightTable::data`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tap {
    pub offset: u32,
    pub weight: f32,
}

/// The environment prefiltered for the samples of level `m` (module docs):
/// a lat-long map whose texels match the sample spacing of level `m + 2`
/// (128 columns at level 4, doubling per level, at least 64), so that a
/// bilinear point sample is close to the area average it stands for.
#[must_use]
pub fn prefilter(env: &EnvMap, m: usize) -> EnvMap {
    let s = (m + 2).min(SAMPLE_LEVEL);
    let width = if s >= 4 { 128 << (s - 4) } else { 64 };
    env.resample(
        Param::LatLong {
            width,
            height: width / 2,
        },
        2,
    )
}

impl LightTable {
    /// Builds the table of `env` (already [`prefilter`]ed) seen through
    /// `space_from_env` (see the module docs for which one), for level `m`
    /// and `twists` bins.
    #[must_use]
    pub fn build(env: &EnvMap, space_from_env: Mat3, m: usize, twists: usize) -> Self {
        let ico = Icosahedral::new(SAMPLE_LEVEL.min(m + 2).max(NORMAL_LEVEL))
            .expect("level ≤ 6 is built");
        let normals: Vec<Vec3> = ico.vertices()[..Icosahedral::vertex_count(NORMAL_LEVEL)]
            .iter()
            .map(|d| d.as_vec3())
            .collect();
        let (dirs, per) = cell_samples(&ico, m);
        let stride = upper_cells(m).len();
        let padded = padded_cells(m);
        let twists = twists.max(1);
        let env_from_space = space_from_env.transpose();
        let inv = 1.0 / per as f32;
        let planes = normals.len() * twists * 3 * stride;
        let mut data = vec![0.0f32; planes + padded - stride];
        data[..planes]
            .par_chunks_mut(3 * stride)
            .enumerate()
            .for_each(|(e, out)| {
                let (k, t) = (e / twists, e % twists);
                let f = frame_of(normals[k]);
                let tau = TAU * t as f32 / twists as f32;
                let (s, c) = tau.sin_cos();
                let x = f.x * c + f.y * s;
                let fr = Frame {
                    x,
                    y: f.z.cross(x),
                    z: f.z,
                };
                for (slot, &cell) in upper_cells(m).iter().enumerate() {
                    let cell = cell as usize;
                    let mut sum = Vec3::ZERO;
                    for d in &dirs[cell * per..(cell + 1) * per] {
                        sum += env.eval(env_from_space * fr.from_local(*d));
                    }
                    let v = sum * inv;
                    out[slot] = v.x;
                    out[stride + slot] = v.y;
                    out[2 * stride + slot] = v.z;
                }
            });
        Self {
            m,
            twists,
            stride,
            padded,
            built_for: space_from_env,
            data: Planes::F32(data),
            frames: normals.iter().map(|&n| frame_of(n)).collect(),
            weights: ico.weights(NORMAL_LEVEL).expect("NORMAL_LEVEL is built"),
            triangles: ico.triangles(NORMAL_LEVEL).to_vec(),
        }
    }

    /// The same table kept in `storage` ([`crate::storage`]).
    #[must_use]
    pub fn with_storage(mut self, storage: Storage) -> Self {
        if let (true, Planes::F32(v)) = (storage.lighting_f16(), &self.data) {
            self.data = Planes::lighting(v.clone(), true);
        }
        self
    }

    /// Bytes held.
    #[must_use]
    pub fn bytes(&self) -> u64 {
        self.data.bytes()
    }

    /// The six weighted entries of frame `g` (in the table's space).
    #[must_use]
    pub fn lookup(&self, g: &Frame) -> [Tap; 6] {
        let mut hint = LAST_TRIANGLE.get();
        let (tri, w) = self.weights.locate(g.z.as_dvec3(), &mut hint);
        LAST_TRIANGLE.set(hint);
        let verts = self.triangles[tri];
        let mut taps = [Tap::default(); 6];
        let entry = 3 * self.stride;
        let bins_per_radian = self.twists as f32 / TAU;
        for (v, (&k, wk)) in verts.iter().zip([w.x, w.y, w.z]).enumerate() {
            let k = k as usize;
            let wk = wk.max(0.0) as f32;
            let base = k * self.twists;
            if self.twists == 1 {
                taps[2 * v] = Tap {
                    offset: (base * entry) as u32,
                    weight: wk,
                };
                continue;
            }
            let f = &self.frames[k];
            // The polynomial atan2 (≤ 4 × 10⁻⁷ rad): libm's was a fifth
            // of a lookup.
            let tau = atan2_f32(g.x.dot(f.y), g.x.dot(f.x));
            // τ ∈ [−π, π] into [0, 2π) as `rem_euclid` would (one add, no
            // `fmodf`), then the bins without divisions: `u` ∈ [0, twists],
            // `twists` only by rounding.
            let tau = if tau < 0.0 { tau + TAU } else { tau };
            let u = tau * bins_per_radian;
            // (`u` ≥ 0: truncation is the floor, without a `floorf` call on
            // the baseline target.)
            let wrap = |b: usize| if b >= self.twists { b - self.twists } else { b };
            let bin = u as usize;
            let fr = u - bin as f32;
            let (b0, b1) = (wrap(bin), wrap(wrap(bin) + 1));
            taps[2 * v] = Tap {
                offset: ((base + b0) * entry) as u32,
                weight: wk * (1.0 - fr),
            };
            taps[2 * v + 1] = Tap {
                offset: ((base + b1) * entry) as u32,
                weight: wk * fr,
            };
        }
        taps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dropping the cells below the horizon is exact: every quadrature
    /// sample of a dropped cell (two levels finer) lies in z ≤ 0, where the
    /// BRDF term's cos⁺ is 0; and the counts are the hierarchy's.
    #[test]
    fn dropped_cells_lie_below_the_horizon() {
        let ico = Icosahedral::new(6).unwrap();
        for (m, want) in [
            (0, None),
            (1, Some(58)),
            (2, Some(198)),
            (3, Some(718)),
            (4, Some(2718)),
        ] {
            let kept = upper_cells(m);
            if let Some(w) = want {
                assert_eq!(kept.len(), w, "level {m}");
            }
            let per = 1usize << (2 * 2);
            for c in 0..triangles(m) {
                if kept.binary_search(&(c as u32)).is_ok() {
                    continue;
                }
                for j in c * per..(c + 1) * per {
                    let z = cell_dir(&ico, m + 2, j).z;
                    assert!(z <= 1e-9, "level {m} cell {c}: sample z {z}");
                }
            }
        }
    }
}
