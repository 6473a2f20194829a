//! Wavelet importance sampling of a textured area light (sun-thesis-2008
//! §4.6.1, after Clarberg, Jarosz, Akenine-Möller & Jensen, *Wavelet
//! importance sampling*, SIGGRAPH 2005): directions drawn in proportion to
//! the light propagated to the shading point times the BRDF·cosine, both on
//! the expanded top face of §4.5.4, by hierarchical warping down the
//! product's quadtree.
//!
//! # The face (sun-thesis-2008 §4.5.4, eq. 4.34)
//! A light ([`AreaLight`]: centre `c`, axes `x̂ ŷ ẑ`, sides `w × h`, emitting
//! towards `+ẑ`) is seen from a point `x` at depth `z = (x − c)·ẑ > 0`
//! through a square face of side `S` ([`WaveletSamplingOptions::face`]) at
//! unit distance, parallel to the light, parameterised by `t ∈ [0, 1]²`:
//! the face point `v = S (t − ½)` is the direction `x̂ v₁ − ŷ v₂ − ẑ`
//! (length `√(1 + |v|²)`). That ray meets the light's plane at uv
//!
//! ```text
//!   u₁ = s₁ t₁ + o₁,  s₁ = zS/w,  o₁ = ½ + p_x/w − ½ s₁
//!   u₂ = s₂ t₂ + o₂,  s₂ = zS/h,  o₂ = ½ − p_y/h − ½ s₂
//! ```
//!
//! (`p_x = (x − c)·x̂`, `p_y = (x − c)·ŷ`): the radiance on the face is the
//! affine transform `F(s t + o)` of the light's texture, exactly (the map of
//! `relight-nearfield`'s `face.rs`, repeated here because the technique
//! crates depend on this one, not the reverse). Solid angle on the face is
//! `dω = (1 + |v|²)^{−3/2} dv`.
//!
//! # The two factors on an order-n grid
//! * **Light.** The light's radiance is box-averaged once per render onto an
//!   `m × m` grid of its uv square ([`LightGrid`], `m` =
//!   [`WaveletSamplingOptions::light_order`], 4 × 4 texture reads per cell):
//!   a piecewise-constant `F̃`. Per shading point its affine image is
//!   box-averaged exactly onto the `n × n` face cells
//!   (`n` = [`WaveletSamplingOptions::order`]): the average of `F̃(s t + o)`
//!   over a face cell is the sum of the light cells it overlaps weighted by
//!   the overlap's share of the cell, separable per axis and done in two
//!   steps like the thesis's two-step propagation (eq. 4.35 in the pixel
//!   basis, eq. 4.18). These averages are the scaling-function part of the
//!   order-n Haar projection of `F̃(s t + o)`, so they are exactly what
//!   eq. 4.35's affine coupling coefficients give after an inverse
//!   transform (a test checks it against `relight_affine::standard`).
//! * **BRDF.** `T(v) = f(ω_o, ω(v)) cos θ(v) (1 + |v|²)^{−3/2}` (BRDF ×
//!   cosine of the shading normal × the face's measure) by `q × q` midpoint
//!   reads per cell ([`WaveletSamplingOptions::brdf_subsamples`]), evaluated
//!   per cell at each shading point instead of Clarberg's pre-tabulated 4D
//!   BRDF (no table to build or store; `q = 1` is the cell-centre value).
//!   Cells where the light is zero are skipped.
//!
//! The product of the two piecewise-constant functions is their cell-wise
//! product (per RGB channel, then luminance): the leaves of a quadtree
//! whose inner nodes sum their four children. These sums are the 2D Haar
//! scaling coefficients of the product at every level (up to the constant
//! `2^{-l}`), so the quadtree *is* the product's Haar pyramid; forming it
//! cell-wise equals the standard triple product of the two factors'
//! coefficients, without the `O(n²)`-term coupling sums.
//!
//! # Hierarchical warping (Clarberg et al. 2005, §4)
//! A uniform `u ∈ [0, 1)²` descends from the root: at each node, `u₁`
//! picks the left or right pair of children in proportion to their sums
//! and is rescaled to `[0, 1)` within the chosen part, then `u₂` picks the
//! lower or upper child of that pair the same way. At a leaf `u` is uniform
//! in the cell; `t = (cell + u)/n`. The density of the face point is
//! `p(v) = leaf / (total · (S/n)²)` and in solid angle
//! `p(ω) = p(v) (1 + |v|²)^{3/2}` ([`FaceProduct::pdf`] gives it for any
//! direction, 0 outside the face). The warp is continuous within the
//! quadtree's nodes, so stratified `u` stay stratified.
//!
//! # What the face misses
//! Directions outside the face (grazing the light's plane, `|v_i| > S/2`)
//! and a light whose product is zero have density 0 here; the reference
//! combines this strategy with light-area and BSDF sampling by the power
//! heuristic (`surface.rs`), whose densities cover every direction that
//! carries light, so the sum stays unbiased.
//!
//! Units: directions are world unit vectors, densities per steradian;
//! `S`, `s`, `o`, `v`, `t` are dimensionless.

use crate::AreaLight;
use crate::sampling::luminance;
use glam::{Mat3, Vec2, Vec3};

/// Texture reads per light-grid cell side when box-averaging the light.
pub const LIGHT_SUBSAMPLES: usize = 4;

/// Settings of [`LightSampling::Wavelet`](super::LightSampling::Wavelet);
/// `Default` holds every default.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct WaveletSamplingOptions {
    /// Face grid order `n` per axis: a power of two, 2 … 256.
    pub order: usize,
    /// Side `S` of the expanded top face at unit distance (> 0; the cube
    /// map's top face is 2, §4.5.4 uses 3–4).
    pub face: f32,
    /// Order `m` of the light's box-averaged grid per axis (1 … 1024).
    pub light_order: usize,
    /// BRDF midpoint reads per face-cell side (1 … 8).
    pub brdf_subsamples: usize,
}

impl Default for WaveletSamplingOptions {
    fn default() -> Self {
        Self {
            order: 32,
            face: 4.0,
            light_order: 64,
            brdf_subsamples: 1,
        }
    }
}

impl WaveletSamplingOptions {
    /// `Err((parameter, problem))` for a value out of range.
    ///
    /// # Errors
    /// The first bad value, named.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        if !(self.order.is_power_of_two() && (2..=256).contains(&self.order)) {
            return Err((
                "wavelet.order",
                format!("must be a power of two in 2…256 (got {})", self.order),
            ));
        }
        if !(self.face.is_finite() && self.face > 0.0) {
            return Err((
                "wavelet.face",
                format!("must be finite and > 0 (got {})", self.face),
            ));
        }
        if !(1..=1024).contains(&self.light_order) {
            return Err((
                "wavelet.light_order",
                format!("must be in 1…1024 (got {})", self.light_order),
            ));
        }
        if !(1..=8).contains(&self.brdf_subsamples) {
            return Err((
                "wavelet.brdf_subsamples",
                format!("must be in 1…8 (got {})", self.brdf_subsamples),
            ));
        }
        Ok(())
    }
}

/// A light's radiance box-averaged on an `m × m` grid of its uv square
/// (cell `(k₁, k₂)` covers `[k₁/m, (k₁+1)/m] × [k₂/m, (k₂+1)/m]`, row `k₂`
/// = uv.y), by [`LIGHT_SUBSAMPLES`]² midpoint reads per cell.
#[derive(Clone, Debug, PartialEq)]
pub struct LightGrid {
    pub m: usize,
    /// `[k₂ · m + k₁]`, linear RGB radiance.
    pub cells: Vec<Vec3>,
}

impl LightGrid {
    /// Box-averages `light` at order `m` (≥ 1). A light field gives its
    /// views' mean ([`AreaLight::radiance_at`]): a proposal only, as the
    /// estimator weighs each sample by the radiance in its direction.
    #[must_use]
    pub fn of(light: &AreaLight, m: usize) -> Self {
        let m = m.max(1);
        let q = LIGHT_SUBSAMPLES;
        let h = 1.0 / (m * q) as f32;
        let mut cells = Vec::with_capacity(m * m);
        for k2 in 0..m {
            for k1 in 0..m {
                let mut sum = Vec3::ZERO;
                for j in 0..q {
                    for i in 0..q {
                        sum += light.radiance_at(Vec2::new(
                            ((k1 * q + i) as f32 + 0.5) * h,
                            ((k2 * q + j) as f32 + 0.5) * h,
                        ));
                    }
                }
                cells.push(sum / (q * q) as f32);
            }
        }
        Self { m, cells }
    }
}

/// Every area light's grid, built once per render for
/// [`LightSampling::Wavelet`](super::LightSampling::Wavelet).
#[derive(Clone, Debug, PartialEq)]
pub struct WaveletLights {
    pub options: WaveletSamplingOptions,
    /// One per area light, in scene order.
    pub grids: Vec<LightGrid>,
}

impl WaveletLights {
    /// The grids of `lights` at `options.light_order`.
    #[must_use]
    pub fn new(lights: &[AreaLight], options: WaveletSamplingOptions) -> Self {
        Self {
            options,
            grids: lights
                .iter()
                .map(|l| LightGrid::of(l, options.light_order))
                .collect(),
        }
    }
}

/// The overlap of the face's cells with the light's cells along one axis:
/// face cell `i` covers uv `[s i/n + o, s (i+1)/n + o]`; its entries are
/// `(k, share of the face cell that light cell k covers)`.
#[derive(Clone, Debug, Default)]
struct AxisOverlap {
    /// `[i] → (first entry, end)` into `k`/`w`.
    range: Vec<(u32, u32)>,
    k: Vec<u32>,
    w: Vec<f32>,
    /// Face cells `lo..hi` overlap the light (empty when `lo ≥ hi`).
    lo: usize,
    hi: usize,
}

impl AxisOverlap {
    fn build(&mut self, n: usize, m: usize, s: f64, o: f64) {
        self.range.clear();
        self.k.clear();
        self.w.clear();
        self.lo = n;
        self.hi = 0;
        let cell = s / n as f64;
        let mf = m as f64;
        for i in 0..n {
            let start = self.k.len() as u32;
            let a = (s * i as f64 / n as f64 + o).max(0.0);
            let b = (s * (i + 1) as f64 / n as f64 + o).min(1.0);
            if b > a {
                let k0 = ((a * mf).floor() as usize).min(m - 1);
                let k1 = ((b * mf).ceil() as usize).clamp(k0 + 1, m);
                for k in k0..k1 {
                    let lo = a.max(k as f64 / mf);
                    let hi = b.min((k + 1) as f64 / mf);
                    if hi > lo {
                        self.k.push(k as u32);
                        self.w.push(((hi - lo) / cell) as f32);
                    }
                }
            }
            let end = self.k.len() as u32;
            if end > start {
                self.lo = self.lo.min(i);
                self.hi = i + 1;
            }
            self.range.push((start, end));
        }
    }

    #[inline]
    fn entries(&self, i: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        let (a, b) = self.range[i];
        let (a, b) = (a as usize, b as usize);
        self.k[a..b]
            .iter()
            .zip(&self.w[a..b])
            .map(|(&k, &w)| (k as usize, w))
    }
}

/// The light × BRDF product on the face of one shading point and its
/// quadtree (module docs); reused across shading points (no allocation
/// after the first build at a given order).
#[derive(Clone, Debug)]
pub struct FaceProduct {
    n: usize,
    /// `log₂ n`.
    depth: u32,
    face: f32,
    brdf_subsamples: usize,
    /// The light's axes (columns x̂, ŷ, ẑ) of the last build.
    axes: Mat3,
    /// Quadtree sums: level `l` (`2^l × 2^l`, row-major, row = `t₂`) at
    /// offset `(4^l − 1)/3`; the leaves are level `depth`.
    tree: Vec<f32>,
    /// The light averaged on the face cells (`[i₂ · n + i₁]`).
    light: Vec<Vec3>,
    /// Step-one scratch, `[i₂ · m + k₁]`.
    step: Vec<Vec3>,
    ax: [AxisOverlap; 2],
}

impl FaceProduct {
    /// An empty product (total 0) at `options`' order, face and BRDF reads.
    #[must_use]
    pub fn new(options: &WaveletSamplingOptions) -> Self {
        let n = options.order.next_power_of_two().max(2);
        let nodes = (4 * n * n - 1) / 3;
        Self {
            n,
            depth: n.trailing_zeros(),
            face: options.face,
            brdf_subsamples: options.brdf_subsamples.max(1),
            axes: Mat3::IDENTITY,
            tree: vec![0.0; nodes],
            light: vec![Vec3::ZERO; n * n],
            step: Vec::new(),
            ax: [AxisOverlap::default(), AxisOverlap::default()],
        }
    }

    /// Face order `n`.
    #[must_use]
    pub fn order(&self) -> usize {
        self.n
    }

    /// Face side `S`.
    #[must_use]
    pub fn face(&self) -> f32 {
        self.face
    }

    /// True when built for `options` (same order, face and BRDF reads).
    #[must_use]
    pub fn matches(&self, options: &WaveletSamplingOptions) -> bool {
        self.n == options.order
            && self.face == options.face
            && self.brdf_subsamples == options.brdf_subsamples
    }

    #[inline]
    fn level_offset(l: u32) -> usize {
        ((1usize << (2 * l)) - 1) / 3
    }

    /// Builds the product at point `x` for `light` (box-averaged in `grid`)
    /// and `rho(ω)` = BRDF × cosine of the shading normal for world unit
    /// direction `ω` (zero below the shading horizon), RGB.
    pub fn build(
        &mut self,
        grid: &LightGrid,
        light: &AreaLight,
        x: Vec3,
        rho: impl Fn(Vec3) -> Vec3,
    ) {
        let n = self.n;
        self.tree.iter_mut().for_each(|v| *v = 0.0);
        self.axes = light.world_from_light;
        self.light.iter_mut().for_each(|v| *v = Vec3::ZERO);
        if !self.propagate(grid, light, x) {
            return;
        }
        // Leaves: light × T, luminance of the RGB product.
        let leaves = Self::level_offset(self.depth);
        let (s_face, q) = (f64::from(self.face), self.brdf_subsamples);
        let cell = s_face / n as f64;
        let sub = cell / q as f64;
        let (x_axis, y_axis, z_axis) = (self.axes.x_axis, self.axes.y_axis, self.axes.z_axis);
        for i2 in self.ax[1].lo..self.ax[1].hi {
            for i1 in self.ax[0].lo..self.ax[0].hi {
                let l = self.light[i2 * n + i1];
                if l == Vec3::ZERO {
                    continue;
                }
                let mut t = Vec3::ZERO;
                for j in 0..q {
                    let v2 = (-0.5 * s_face + i2 as f64 * cell + (j as f64 + 0.5) * sub) as f32;
                    for i in 0..q {
                        let v1 = (-0.5 * s_face + i1 as f64 * cell + (i as f64 + 0.5) * sub) as f32;
                        let r2 = 1.0 + v1 * v1 + v2 * v2;
                        let inv = r2.sqrt().recip();
                        let d = (x_axis * v1 - y_axis * v2 - z_axis) * inv;
                        // ρ × (1 + |v|²)^{−3/2}.
                        t += rho(d) * (inv * inv * inv);
                    }
                }
                let value = luminance(l * t) / (q * q) as f32;
                if value > 0.0 && value.is_finite() {
                    self.tree[leaves + i2 * n + i1] = value;
                }
            }
        }
        // Inner nodes: sums of their four children.
        for l in (0..self.depth).rev() {
            let (side, child) = (1usize << l, 1usize << (l + 1));
            let (off, coff) = (Self::level_offset(l), Self::level_offset(l + 1));
            for j in 0..side {
                for i in 0..side {
                    let c = coff + 2 * j * child + 2 * i;
                    self.tree[off + j * side + i] = self.tree[c]
                        + self.tree[c + 1]
                        + self.tree[c + child]
                        + self.tree[c + child + 1];
                }
            }
        }
    }

    /// The light's box averages on the face cells (module docs): false when
    /// `x` is on or behind the light's plane or sees none of it.
    fn propagate(&mut self, grid: &LightGrid, light: &AreaLight, x: Vec3) -> bool {
        let (n, m) = (self.n, grid.m);
        let d = x - light.center;
        let (px, py, z) = (
            f64::from(d.dot(light.world_from_light.x_axis)),
            f64::from(d.dot(light.world_from_light.y_axis)),
            f64::from(d.dot(light.world_from_light.z_axis)),
        );
        if z.is_nan() || z <= 1e-6 {
            return false;
        }
        let (w, h) = (f64::from(light.size.x), f64::from(light.size.y));
        let face = f64::from(self.face);
        let (s1, s2) = (z * face / w, z * face / h);
        let o1 = 0.5 + px / w - 0.5 * s1;
        let o2 = 0.5 - py / h - 0.5 * s2;
        self.ax[0].build(n, m, s1, o1);
        self.ax[1].build(n, m, s2, o2);
        let (ax, ay) = (&self.ax[0], &self.ax[1]);
        if ax.lo >= ax.hi || ay.lo >= ay.hi {
            return false;
        }
        // Step 1 (rows): step[i₂][k₁] = Σ_{k₂} w₂(i₂, k₂) F[k₂][k₁].
        self.step.resize(n * m, Vec3::ZERO);
        for i2 in ay.lo..ay.hi {
            let row = &mut self.step[i2 * m..(i2 + 1) * m];
            row.iter_mut().for_each(|v| *v = Vec3::ZERO);
            for (k2, w2) in ay.entries(i2) {
                let src = &grid.cells[k2 * m..(k2 + 1) * m];
                for (r, &f) in row.iter_mut().zip(src) {
                    *r += f * w2;
                }
            }
        }
        // Step 2 (columns): light[i₂][i₁] = Σ_{k₁} w₁(i₁, k₁) step[i₂][k₁].
        for i2 in ay.lo..ay.hi {
            let row = &self.step[i2 * m..(i2 + 1) * m];
            for i1 in ax.lo..ax.hi {
                let mut sum = Vec3::ZERO;
                for (k1, w1) in ax.entries(i1) {
                    sum += row[k1] * w1;
                }
                self.light[i2 * n + i1] = sum;
            }
        }
        true
    }

    /// The light averaged on face cell `(i₁, i₂)` (after [`Self::build`]).
    #[must_use]
    pub fn light_on_face(&self, i1: usize, i2: usize) -> Vec3 {
        self.light[i2 * self.n + i1]
    }

    /// The product's integral over the face up to the constant cell area:
    /// the quadtree's root. Zero: nothing to sample.
    #[must_use]
    pub fn total(&self) -> f32 {
        self.tree[0]
    }

    /// Probability of face cell `(i₁, i₂)` (leaf / total; 0 when empty).
    #[must_use]
    pub fn cell_probability(&self, i1: usize, i2: usize) -> f32 {
        let total = self.total();
        if total > 0.0 {
            self.tree[Self::level_offset(self.depth) + i2 * self.n + i1] / total
        } else {
            0.0
        }
    }

    /// Draws a world unit direction from `u ∈ [0, 1)²` by hierarchical
    /// warping (module docs): `(ω, p(ω))`, `None` when the product is zero.
    #[must_use]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let total = self.total();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let below_one = 1.0 - f32::EPSILON;
        let (mut ux, mut uy) = (u.x.clamp(0.0, below_one), u.y.clamp(0.0, below_one));
        let (mut i, mut j) = (0usize, 0usize);
        for l in 1..=self.depth {
            let side = 1usize << l;
            let off = Self::level_offset(l);
            let (ci, cj) = (2 * i, 2 * j);
            let at = |a: usize, b: usize| self.tree[off + b * side + a];
            let (c00, c10, c01, c11) = (
                at(ci, cj),
                at(ci + 1, cj),
                at(ci, cj + 1),
                at(ci + 1, cj + 1),
            );
            // u₁: left (c00 + c01) or right column.
            let left = c00 + c01;
            let sum = left + c10 + c11;
            let p_left = if sum > 0.0 { left / sum } else { 0.5 };
            let right = if ux < p_left {
                ux /= p_left;
                false
            } else {
                ux = (ux - p_left) / (1.0 - p_left);
                true
            };
            ux = ux.clamp(0.0, below_one);
            let (lo, hi) = if right { (c10, c11) } else { (c00, c01) };
            // u₂: lower or upper cell of that column.
            let col = lo + hi;
            let p_lo = if col > 0.0 { lo / col } else { 0.5 };
            let up = if uy < p_lo {
                uy /= p_lo;
                false
            } else {
                uy = (uy - p_lo) / (1.0 - p_lo);
                true
            };
            uy = uy.clamp(0.0, below_one);
            i = ci + usize::from(right);
            j = cj + usize::from(up);
        }
        let p_cell = self.cell_probability(i, j);
        if p_cell.is_nan() || p_cell <= 0.0 {
            return None;
        }
        let n = self.n as f32;
        let v1 = self.face * ((i as f32 + ux) / n - 0.5);
        let v2 = self.face * ((j as f32 + uy) / n - 0.5);
        let r2 = 1.0 + v1 * v1 + v2 * v2;
        let dir = (self.axes.x_axis * v1 - self.axes.y_axis * v2 - self.axes.z_axis) / r2.sqrt();
        let cell_area = (self.face / n) * (self.face / n);
        Some((dir, p_cell / cell_area * r2 * r2.sqrt()))
    }

    /// Face cell of world direction `dir` (unit) and its `1 + |v|²`:
    /// `None` outside the face or away from the light's plane.
    #[must_use]
    pub fn cell_of(&self, dir: Vec3) -> Option<(usize, usize, f32)> {
        let c = -dir.dot(self.axes.z_axis);
        if c.is_nan() || c <= 0.0 {
            return None;
        }
        let v1 = dir.dot(self.axes.x_axis) / c;
        let v2 = -dir.dot(self.axes.y_axis) / c;
        let n = self.n as f32;
        let t1 = (v1 / self.face + 0.5) * n;
        let t2 = (v2 / self.face + 0.5) * n;
        if !(t1 >= 0.0 && t1 < n && t2 >= 0.0 && t2 < n) {
            return None;
        }
        Some((t1 as usize, t2 as usize, 1.0 + v1 * v1 + v2 * v2))
    }

    /// Solid-angle density with which [`Self::sample`] draws world unit
    /// direction `dir`: 0 outside the face or for a zero product.
    #[must_use]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let Some((i, j, r2)) = self.cell_of(dir) else {
            return 0.0;
        };
        let p = self.cell_probability(i, j);
        if p > 0.0 {
            let cell = self.face / self.n as f32;
            p / (cell * cell) * r2 * r2.sqrt()
        } else {
            0.0
        }
    }
}

/// One [`FaceProduct`] per area light, rebuilt at each shading point.
#[derive(Clone, Debug, Default)]
pub(crate) struct FaceSet {
    pub faces: Vec<FaceProduct>,
}

impl FaceSet {
    /// Builds every light's product at `x` with `rho` (see
    /// [`FaceProduct::build`]).
    pub fn build(
        &mut self,
        lights: &WaveletLights,
        areas: &[AreaLight],
        x: Vec3,
        rho: impl Fn(Vec3) -> Vec3 + Copy,
    ) {
        if self.faces.len() != areas.len()
            || self
                .faces
                .first()
                .is_some_and(|f| !f.matches(&lights.options))
        {
            self.faces = areas
                .iter()
                .map(|_| FaceProduct::new(&lights.options))
                .collect();
        }
        for ((f, g), a) in self.faces.iter_mut().zip(&lights.grids).zip(areas) {
            f.build(g, a, x, rho);
        }
    }
}

/// Power heuristic (β = 2) of three strategies: the weight of the one with
/// density `p` against `a` and `b` (Veach 1997, eq. 9.13).
#[inline]
#[must_use]
pub(crate) fn power3(p: f32, a: f32, b: f32) -> f32 {
    if p.is_infinite() {
        return 1.0;
    }
    let (p2, d) = (p * p, p * p + a * a + b * b);
    if d > 0.0 && d.is_finite() {
        p2 / d
    } else {
        0.0
    }
}
