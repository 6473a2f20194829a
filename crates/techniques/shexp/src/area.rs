//! The SH area light (issue 15: "environment lighting, and an SH area
//! light"): the scene's one-sided textured rectangles
//! ([`AreaLight`]) projected into SH as seen from a receiver point `p`,
//!
//! `A_lm(p) = ∫ L_a(p, ω) y_lm(ω) dω`  (world frame, radiance units).
//!
//! # Shading
//! The thesis shades distant lighting by `L_H(N) · g`, `L_H = L ∗ H(N)`
//! (eq. 5.14): `L` and the clamped cosine `H` are each cut to order n before
//! their product is. A near light of modest extent is far from band-limited,
//! and that double truncation cost 27 % relative RMS on the floor of
//! `relight verify shexp`'s area-light scene. A near light varies over the
//! receivers anyway, so it is projected per receiver point, and the cosine
//! (and, for static receivers, their static visibility) is folded in before
//! projecting:
//!
//! `F_lm(p, N) = (1/π) ∫ L_a(p, ω) max(N·ω, 0) V_static(p, ω) y_lm(ω) dω`,
//!
//! and the receiver adds `F · g`. Since `g` (the exponentiated visibility of
//! the dynamic blockers) is an order-n vector, `F · g = (1/π) ∫ L_a cos⁺
//! V_static g` exactly: the only band limit left is the one the method puts
//! on visibility. A dynamic receiver projects `F` per frame (`V_static ≡ 1`:
//! like the environment's `H(N)`, its occlusion is all in `g`); a static
//! one at each lighting change that moves a light, with a shadow ray per
//! quadrature cell against the static meshes ([`AreaLightSh::project_weighted`]).
//!
//! # Quadrature
//! A rectangle with centre `c`, unit normal `ẑ` and area element `dA`, seen
//! from `p` at height `h = (p − c)·ẑ > 0`, subtends `dω = h dA / r³`
//! (`r = |q − p|`, `q` on the light). The light is cut into `M × M` cells, `M`
//! chosen per receiver and light so that a cell spans at
//! most [`MAX_CELL_ANGLE`] radians from the rectangle's nearest point:
//! `M = ⌈D / (τ d_min)⌉` (D the diagonal), clamped to `1…`[`MAX_CELLS`].
//! Each cell is integrated by the 2 × 2 Gauss–Legendre rule, every point
//! carrying the cell's mean radiance, read from a summed-area table of the
//! texture's means over [`MAX_CELLS`]² cells (built once per lighting
//! change; exact for that piecewise-constant image at any cell boundary), so
//! the texture is integrated exactly at that resolution and the smooth
//! factor (`h/r³`, the basis, the cosine) with an error of `O(τ⁴)` per cell
//! (within 0.3 % of a 512² midpoint rule in the tests; one midpoint per
//! cell needed about 3× the points for 0.25 %).
//!
//! Receivers closer than `D / (τ · MAX_CELLS)`, where `M` would pass
//! [`MAX_CELLS`], get a graded grid instead: per axis, cells grow
//! geometrically away from the receiver's foot point `f` on the rectangle
//! (clamped into it), each no wider than `τ/√2 · max(d_min, |t − f|)` at its
//! inner edge `t`, so that every cell's diagonal still spans at most `τ`
//! seen from `p` (the distance to a cell is at least both `d_min` and its
//! offset from `f` along either axis). That costs `≈ 2 (3.5 + 4 ln(L/d_min))`
//! cells per axis (`L` the light's extent): 44 at `L/d_min = 100`. Until
//! session 34 such receivers took the uniform [`MAX_CELLS`]² grid, whose
//! 2 × 2 points per cell missed the bright patch under a close receiver:
//! a floor 0.01 under a 2 × 2 light received 0.44× the reference's light.
//!
//! Points on the back side or in the light's plane receive nothing: the
//! lights emit from their `+ẑ` side only and do not occlude, as in the
//! reference renderer (`relight_render::reference`).

use glam::{Vec2, Vec3};
use relight_render::AreaLight;

/// Largest angle (radians) one quadrature cell spans, seen from the
/// rectangle's nearest point (τ in the module docs).
pub const MAX_CELL_ANGLE: f32 = 0.4;

/// The 2-point Gauss–Legendre abscissae on [0, 1] (equal weights ½).
const GAUSS_2: [f32; 2] = [0.211_324_87, 0.788_675_1];

/// Most cells per side of one light (a power of two).
pub const MAX_CELLS: usize = 32;

/// Texture samples per side of a finest cell when its mean is taken.
const TEXTURE_SUPERSAMPLES: usize = 4;

/// Most cells per axis of a graded grid (module docs): enough for
/// `L/d_min` ≈ 10⁵; closer receivers get wider outer cells.
const MAX_GRADED_CELLS: usize = 128;

/// Cell edges along one axis of a light, in its texture coordinate
/// (`u` or `v`, increasing from 0 to 1): `count + 1` of them.
struct Edges {
    at: [f32; MAX_GRADED_CELLS + 1],
    count: usize,
}

impl Edges {
    /// `m` equal cells.
    fn uniform(m: usize) -> Self {
        let mut at = [0.0; MAX_GRADED_CELLS + 1];
        for (i, e) in at.iter_mut().enumerate().take(m + 1) {
            *e = i as f32 / m as f32;
        }
        Self { at, count: m }
    }

    /// Cells graded away from the foot point at offset `f` (light units,
    /// in `[−½ side, ½ side]`) along an axis of length `side`, each at most
    /// `c · max(d_min, |t − f|)` wide at its inner edge `t`; `flip` for `v`,
    /// which runs against the light's `ŷ`.
    fn graded(side: f32, f: f32, d_min: f32, c: f32, flip: bool) -> Self {
        let half = 0.5 * side;
        // Offsets from f outwards, to each end.
        let mut neg = [0.0f32; MAX_GRADED_CELLS + 1];
        let mut pos = [0.0f32; MAX_GRADED_CELLS + 1];
        let walk = |to: f32, out: &mut [f32], budget: usize| -> usize {
            // Edges at offsets 0 = t_0 < t_1 < … < t_k = to.
            let mut k = 0;
            let mut t = 0.0f32;
            while t < to {
                let w = c * d_min.max(t);
                // The last cell takes the rest (past the budget, wider).
                t = if k + 1 >= budget || t + w >= to {
                    to
                } else {
                    t + w
                };
                k += 1;
                out[k] = t;
            }
            k
        };
        let budget = MAX_GRADED_CELLS / 2;
        let kn = walk(f + half, &mut neg, budget);
        let kp = walk(half - f, &mut pos, budget);
        let mut at = [0.0; MAX_GRADED_CELLS + 1];
        let mut n = 0;
        let to_coord = |x: f32| {
            let u = (x / side + 0.5).clamp(0.0, 1.0);
            if flip { 1.0 - u } else { u }
        };
        // From the −end to f, then f to the +end, in axis order.
        for t in neg[1..=kn].iter().rev() {
            at[n] = to_coord(f - t);
            n += 1;
        }
        at[n] = to_coord(f);
        n += 1;
        for t in &pos[1..=kp] {
            at[n] = to_coord(f + t);
            n += 1;
        }
        if flip {
            at[..n].reverse();
        }
        at[0] = 0.0;
        at[n - 1] = 1.0;
        Self { at, count: n - 1 }
    }

    fn cells(&self) -> impl Iterator<Item = (f32, f32)> + '_ {
        self.at[..=self.count].windows(2).map(|w| (w[0], w[1]))
    }
}

/// One light, ready for [`AreaLightSh::project`].
#[derive(Clone, Debug)]
struct LightCells {
    center: Vec3,
    x_axis: Vec3,
    y_axis: Vec3,
    normal: Vec3,
    size: Vec2,
    diagonal: f32,
    /// Summed-area table of the radiance over `uv` ∈ [0, 1]²: entry
    /// `(i, j)` of `(S+1)²`, `S` = [`MAX_CELLS`], is `∫₀^{i/S} ∫₀^{j/S} L du dv`
    /// of the texture's means over `S × S` cells (`v` down, as
    /// [`AreaLight::point_at`]); `None` for an untextured light.
    sat: Option<Vec<Vec3>>,
    intensity: Vec3,
}

/// The scene's area lights as SH lighting per receiver point (module docs).
#[derive(Clone, Debug)]
pub struct AreaLightSh {
    order: usize,
    lights: Vec<LightCells>,
}

impl AreaLightSh {
    /// The lights of a scene, for SH order `order`. Lights with zero
    /// intensity are left out.
    #[must_use]
    pub fn new(order: usize, lights: &[AreaLight]) -> Self {
        let lights = lights
            .iter()
            .filter(|l| l.intensity.max_element() > 0.0)
            .map(LightCells::new)
            .collect();
        Self { order, lights }
    }

    /// No light to project.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Cells along the longer axis that [`Self::project`] uses for light
    /// `i` from `p` (0 on the back side): `M` of the uniform grid, or the
    /// graded grid's count (module docs).
    #[must_use]
    pub fn cells_per_side(&self, i: usize, p: Vec3) -> usize {
        self.lights
            .get(i)
            .and_then(|l| l.grid_from(p))
            .map_or(0, |(u, v, _)| u.count.max(v.count))
    }

    /// `A(p)` into `out` (RGB, channel-major: `out[c·n² + k]`, overwritten);
    /// `y` is scratch of `n²`. Returns false when no light faces `p` (`out`
    /// is then zero).
    ///
    /// # Panics
    /// If `out` is shorter than `3 n²` or `y` than `n²`.
    pub fn project(&self, p: Vec3, y: &mut [f32], out: &mut [f32]) -> bool {
        self.project_weighted(p, |_, _| 1.0, y, out)
    }

    /// `∫ L_a(p, ω) w(ω) y(ω) dω` into `out` (as [`Self::project`]), the
    /// weight `w(ω, r)` taken at each cell's direction `ω` and distance `r`
    /// from `p` (a cell of weight 0 costs no basis evaluation): with
    /// `w = max(N·ω, 0)/π`, and a shadow test, this is the SH vector whose dot
    /// product with an order-n visibility `g` is exactly `(1/π) ∫ L_a cos⁺ V g`.
    ///
    /// # Panics
    /// As [`Self::project`].
    pub fn project_weighted<W: Fn(Vec3, f32) -> f32>(
        &self,
        p: Vec3,
        weight: W,
        y: &mut [f32],
        out: &mut [f32],
    ) -> bool {
        let nn = self.order * self.order;
        let out = &mut out[..3 * nn];
        out.fill(0.0);
        let mut any = false;
        for l in &self.lights {
            let Some((us, vs, h)) = l.grid_from(p) else {
                continue;
            };
            any = true;
            // Cells of 2 × 2 Gauss–Legendre points, each point carrying its
            // cell's mean radiance.
            let area = l.size.x * l.size.y;
            for (v0, v1) in vs.cells() {
                for (u0, u1) in us.cells() {
                    let mean = l.mean_over(u0, u1, v0, v1);
                    let da = area * (u1 - u0) * (v1 - v0) * 0.25;
                    for (gi, gj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let uv =
                            Vec2::new(u0 + GAUSS_2[gi] * (u1 - u0), v0 + GAUSS_2[gj] * (v1 - v0));
                        let q = l.center
                            + l.x_axis * ((uv.x - 0.5) * l.size.x)
                            + l.y_axis * ((0.5 - uv.y) * l.size.y);
                        let d = q - p;
                        let r = d.length();
                        let inv_r = r.recip();
                        let dir = d * inv_r;
                        let k = weight(dir, r);
                        if k == 0.0 {
                            continue;
                        }
                        // dω = h dA / r³.
                        let w = mean * (k * h * da * inv_r * inv_r * inv_r);
                        relight_sh::eval_sh_into(self.order, dir.to_array(), y);
                        let (r0, rest) = out.split_at_mut(nn);
                        let (r1, r2) = rest.split_at_mut(nn);
                        for (((o0, o1), o2), y) in r0.iter_mut().zip(r1).zip(r2).zip(&y[..nn]) {
                            *o0 += w.x * y;
                            *o1 += w.y * y;
                            *o2 += w.z * y;
                        }
                    }
                }
            }
        }
        any
    }
}

impl LightCells {
    fn new(l: &AreaLight) -> Self {
        let m = MAX_CELLS;
        let s = TEXTURE_SUPERSAMPLES;
        let sat = l.texture.as_ref().map(|_| {
            let mut sat = vec![Vec3::ZERO; (m + 1) * (m + 1)];
            for j in 0..m {
                for i in 0..m {
                    let mut sum = Vec3::ZERO;
                    for b in 0..s {
                        for a in 0..s {
                            let uv = Vec2::new((i * s + a) as f32 + 0.5, (j * s + b) as f32 + 0.5)
                                / (m * s) as f32;
                            sum += l.radiance_at(uv);
                        }
                    }
                    let cell = sum / (s * s * m * m) as f32;
                    sat[(j + 1) * (m + 1) + i + 1] =
                        cell + sat[j * (m + 1) + i + 1] + sat[(j + 1) * (m + 1) + i]
                            - sat[j * (m + 1) + i];
                }
            }
            sat
        });
        Self {
            center: l.center,
            x_axis: l.world_from_light.x_axis,
            y_axis: l.world_from_light.y_axis,
            normal: l.normal(),
            size: l.size,
            diagonal: l.size.length(),
            sat,
            intensity: l.intensity,
        }
    }

    /// The mean radiance over the texture rectangle `[u0, u1] × [v0, v1]`:
    /// the summed-area table read bilinearly, exact for the
    /// piecewise-constant `S × S` image (its integral is bilinear inside
    /// each texel).
    fn mean_over(&self, u0: f32, u1: f32, v0: f32, v1: f32) -> Vec3 {
        let Some(sat) = &self.sat else {
            return self.intensity;
        };
        let side = MAX_CELLS;
        let at = |u: f32, v: f32| {
            let (x, y) = (u * side as f32, v * side as f32);
            let (x0, y0) = ((x as usize).min(side - 1), (y as usize).min(side - 1));
            let (fx, fy) = (x - x0 as f32, y - y0 as f32);
            let e = |a: usize, b: usize| sat[b * (side + 1) + a];
            (e(x0, y0) * (1.0 - fx) + e(x0 + 1, y0) * fx) * (1.0 - fy)
                + (e(x0, y0 + 1) * (1.0 - fx) + e(x0 + 1, y0 + 1) * fx) * fy
        };
        (at(u1, v1) - at(u0, v1) - at(u1, v0) + at(u0, v0)) / ((u1 - u0) * (v1 - v0))
    }

    /// The cell edges for `p` along `u` and `v`, and `p`'s height over the
    /// plane: `M × M` equal cells, or a graded grid where `M` would pass
    /// [`MAX_CELLS`] (module docs); `None` on the back side or in the plane.
    fn grid_from(&self, p: Vec3) -> Option<(Edges, Edges, f32)> {
        let (m, h) = self.cells_from(p);
        if m == 0 {
            return None;
        }
        if m < MAX_CELLS {
            return Some((Edges::uniform(m), Edges::uniform(m), h));
        }
        let d = p - self.center;
        let (u, v) = (d.dot(self.x_axis), d.dot(self.y_axis));
        let (hx, hy) = (0.5 * self.size.x, 0.5 * self.size.y);
        let du = (u.abs() - hx).max(0.0);
        let dv = (v.abs() - hy).max(0.0);
        let d_min = (h * h + du * du + dv * dv).sqrt();
        let c = MAX_CELL_ANGLE * std::f32::consts::FRAC_1_SQRT_2;
        Some((
            Edges::graded(self.size.x, u.clamp(-hx, hx), d_min, c, false),
            Edges::graded(self.size.y, v.clamp(-hy, hy), d_min, c, true),
            h,
        ))
    }

    /// Cells per side of a uniform grid from `p` (clamped to [`MAX_CELLS`])
    /// and `p`'s height over the plane; `(0, h)` on the back side or in the
    /// plane.
    fn cells_from(&self, p: Vec3) -> (usize, f32) {
        let d = p - self.center;
        let h = d.dot(self.normal);
        if h.is_nan() || h <= 0.0 {
            return (0, h);
        }
        // Distance to the rectangle's nearest point.
        let (u, v) = (d.dot(self.x_axis), d.dot(self.y_axis));
        let du = (u.abs() - 0.5 * self.size.x).max(0.0);
        let dv = (v.abs() - 0.5 * self.size.y).max(0.0);
        let d_min = (h * h + du * du + dv * dv).sqrt();
        let want = self.diagonal / (MAX_CELL_ANGLE * d_min);
        let m = if want <= 1.0 {
            1
        } else if want >= MAX_CELLS as f32 {
            MAX_CELLS
        } else {
            want.ceil() as usize
        };
        (m, h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;

    fn light(texture: bool) -> AreaLight {
        let tex = texture.then(|| {
            let w = 8;
            let texels = (0..w * w)
                .map(|k| {
                    let (i, j) = (k % w, k / w);
                    if (i + j) % 2 == 0 {
                        Vec3::new(2.0, 1.0, 0.5)
                    } else {
                        Vec3::new(0.1, 0.3, 1.0)
                    }
                })
                .collect();
            std::sync::Arc::new(relight_render::Texture::try_new(w, w, texels).unwrap())
        });
        // Facing down (−Y), 1.6 × 0.8, at height 2.
        AreaLight {
            center: Vec3::new(0.2, 2.0, -0.1),
            size: Vec2::new(1.6, 0.8),
            world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
            intensity: Vec3::new(3.0, 2.0, 1.0),
            texture: tex,
            light_field: None,
        }
    }

    /// A plain midpoint rule at `k²` cells with the texture sampled at each
    /// cell centre.
    fn brute(l: &AreaLight, order: usize, p: Vec3, k: usize) -> Vec<f64> {
        let nn = order * order;
        let mut out = vec![0.0f64; 3 * nn];
        let mut y = vec![0.0f64; nn];
        let da = f64::from(l.area()) / (k * k) as f64;
        for j in 0..k {
            for i in 0..k {
                let uv = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                let q = l.point_at(uv).as_dvec3();
                let d = q - p.as_dvec3();
                let r = d.length();
                let h = (p.as_dvec3() - l.center.as_dvec3()).dot(l.normal().as_dvec3());
                let w = l.radiance_at(uv).as_dvec3() * (h * da / (r * r * r));
                relight_sh::eval_sh_into(order, (d / r).to_array(), &mut y);
                for c in 0..3 {
                    for kk in 0..nn {
                        out[c * nn + kk] += w[c] * y[kk];
                    }
                }
            }
        }
        out
    }

    #[test]
    fn weighted_projection_is_exact_against_band_limited_vectors() {
        // F · g for an order-n g equals the integral of L_a cos⁺/π · g.
        let l = light(true);
        let a = AreaLightSh::new(3, std::slice::from_ref(&l));
        let p = Vec3::new(0.7, 0.4, 0.3);
        let nrm = Vec3::new(0.3, 1.0, -0.2).normalize();
        let (mut y, mut f) = (vec![0.0f32; 9], vec![0.0f32; 27]);
        let w = |d: Vec3, _r: f32| d.dot(nrm).max(0.0) / std::f32::consts::PI;
        assert!(a.project_weighted(p, w, &mut y, &mut f));
        let g: Vec<f32> = (0..9).map(|k| 0.5 - 0.1 * k as f32).collect();
        // The same integral cell by cell, g evaluated at each direction.
        let k = 512;
        let mut want = 0.0f64;
        let mut yy = vec![0.0f32; 9];
        for j in 0..k {
            for i in 0..k {
                let uv = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                let d = l.point_at(uv) - p;
                let r = d.length();
                let h = (p - l.center).dot(l.normal());
                relight_sh::eval_sh_into(3, (d / r).to_array(), &mut yy);
                let gv: f32 = g.iter().zip(&yy).map(|(a, b)| a * b).sum();
                let dw = h * l.area() / (k * k) as f32 / (r * r * r);
                want += f64::from(l.radiance_at(uv).x * w(d / r, r) * gv * dw);
            }
        }
        let got: f64 = f[..9].iter().zip(&g).map(|(a, b)| f64::from(a * b)).sum();
        assert!((got - want).abs() <= 5e-3 * want.abs(), "{got} vs {want}");
    }

    #[test]
    fn projection_matches_a_fine_midpoint_rule() {
        for texture in [false, true] {
            let l = light(texture);
            let a = AreaLightSh::new(4, std::slice::from_ref(&l));
            let nn = 16;
            let (mut y, mut out) = (vec![0.0f32; nn], vec![0.0f32; 3 * nn]);
            for p in [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.5, 0.3, 0.7),
                Vec3::new(-2.0, 1.5, 0.0),
                Vec3::new(0.3, 1.7, 0.1),
                Vec3::new(5.0, -3.0, 4.0),
            ] {
                assert!(a.project(p, &mut y, &mut out));
                let want = brute(&l, 4, p, 512);
                let norm: f64 = want.iter().map(|v| v * v).sum::<f64>().sqrt();
                let err: f64 = out
                    .iter()
                    .zip(&want)
                    .map(|(x, w)| (f64::from(*x) - w).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    err <= 3e-3 * norm,
                    "texture {texture}, p {p}: |ΔA| {err:.3e} vs |A| {norm:.3e} ({} cells per side)",
                    a.cells_per_side(0, p)
                );
            }
        }
    }

    /// Solid angle of the triangle `a, b, c` seen from the origin (Van
    /// Oosterom & Strackee 1983).
    fn triangle_solid_angle(a: glam::DVec3, b: glam::DVec3, c: glam::DVec3) -> f64 {
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c)).abs();
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        2.0 * num.atan2(den)
    }

    /// Receivers very close to an untextured light (down to 10⁻⁴ of its
    /// size, over its middle, a corner and just past an edge) get its
    /// order-1 projection in closed form: `A_00 = L Ω / √(4π)` (Ω by two
    /// triangles' solid angles) and `A_1m = √(3/4π) L ∫ ω dω`, the vector
    /// form factor `½ Σ Θ_i û_i` of Lambert's edge sum. The uniform
    /// 32² grid gave 0.44× the light at height 0.01 under a 2 × 2 light.
    #[test]
    fn close_receivers_match_the_closed_form() {
        let l = light(false);
        let a = AreaLightSh::new(2, std::slice::from_ref(&l));
        let (mut y, mut out) = (vec![0.0f32; 4], vec![0.0f32; 12]);
        let corners: Vec<glam::DVec3> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
            .iter()
            .map(|&(u, v)| l.point_at(Vec2::new(u, v)).as_dvec3())
            .collect();
        let below = -l.normal();
        for (uv, h) in [
            ((0.5, 0.5), 1e-2),
            ((0.5, 0.5), 1e-4),
            ((0.3, 0.6), 1e-3),
            ((0.02, 0.97), 2e-3),
            ((1.01, 0.5), 5e-3),
        ] {
            let p = l.point_at(Vec2::new(uv.0, uv.1)) - below * h;
            assert!(a.project(p, &mut y, &mut out));
            let rel: Vec<glam::DVec3> = corners.iter().map(|c| *c - p.as_dvec3()).collect();
            let omega = triangle_solid_angle(rel[0], rel[1], rel[2])
                + triangle_solid_angle(rel[0], rel[2], rel[3]);
            let mut vector = glam::DVec3::ZERO;
            for i in 0..4 {
                let (u, w) = (rel[i].normalize(), rel[(i + 1) % 4].normalize());
                let theta = u.dot(w).clamp(-1.0, 1.0).acos();
                vector += 0.5 * theta * u.cross(w).normalize();
            }
            // The edge sum's sign follows the winding: ∫ ω dω points at the light.
            if vector.dot(below.as_dvec3()) < 0.0 {
                vector = -vector;
            }
            let radiance = f64::from(l.intensity.x);
            // Band 1 is linear in ω: its coefficients from the basis at
            // the three axes (whatever the sign convention).
            let mut basis = [[0.0f64; 4]; 3];
            for (axis, b) in basis.iter_mut().enumerate() {
                let mut d = [0.0f64; 3];
                d[axis] = 1.0;
                relight_sh::eval_sh_into(2, d, b);
            }
            let mut want = [radiance * omega * basis[0][0], 0.0, 0.0, 0.0];
            for (k, w) in want.iter_mut().enumerate().skip(1) {
                *w = radiance * (0..3).map(|a| basis[a][k] * vector[a]).sum::<f64>();
            }
            let scale = want[0];
            for (k, w) in want.iter().enumerate() {
                let got = f64::from(out[k]);
                assert!(
                    (got - w).abs() <= 5e-3 * scale,
                    "uv {uv:?}, h {h}: A[{k}] {got:.5} vs {w:.5} (A_00 {scale:.5}; {} cells per side)",
                    a.cells_per_side(0, p)
                );
            }
        }
    }

    #[test]
    fn back_side_and_plane_receive_nothing() {
        let l = light(false);
        let a = AreaLightSh::new(3, std::slice::from_ref(&l));
        let (mut y, mut out) = (vec![0.0f32; 9], vec![1.0f32; 27]);
        for p in [Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.5, 2.0, 0.2)] {
            assert!(!a.project(p, &mut y, &mut out));
            assert!(out.iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn dc_term_is_the_solid_angle_times_radiance() {
        // Far away on the axis, a constant light subtends ≈ S/d², so
        // A_00 = L S / (d² √(4π)).
        let mut l = light(false);
        l.world_from_light = Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::Z);
        l.center = Vec3::ZERO;
        let a = AreaLightSh::new(2, std::slice::from_ref(&l));
        let (mut y, mut out) = (vec![0.0f32; 4], vec![0.0f32; 12]);
        let d = 40.0;
        assert!(a.project(Vec3::new(0.0, 0.0, d), &mut y, &mut out));
        let want = 3.0 * l.area() / (d * d) / (4.0 * std::f32::consts::PI).sqrt();
        assert!((out[0] - want).abs() <= 1e-3 * want, "{} vs {want}", out[0]);
    }
}
