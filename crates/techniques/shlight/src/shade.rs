//! The per-pixel pass (step 3 of [`crate::relight`]) over the rasterizer's
//! visibility buffer.
//!
//! # Work per covered sample (order n, N = n² coefficients)
//! * vertex data: normal, tangent, uv and position of three vertices,
//!   interpolated with the perspective-correct barycentrics (≈ 40 FMA);
//! * the frames `F_v`, `F_p` and the normal-map lookup (≈ 100 flops);
//! * the transfer `B(θ_o)`: one `acos` and a lerp of N values — one vector
//!   when the table is rank-1 (`B_c = ρ_c B̂`, every single-lobe BRDF), three
//!   otherwise; then the band window (N multiplies);
//! * the rotation `T B` (one vector, or three): Taylor ≈ 2 Z rotations of
//!   ~2N FMA + a Y step of ~3N FMA (1st order), ZYZ ≈ 3 Z rotations + two
//!   fixed sparse X matrices (~Σ(2l+1)²/2 non-zeros each), the exact
//!   Ivanic–Ruedenberg matrix ≈ 15 Σ(2l+1)² flops to build plus Σ(2l+1)² to apply;
//! * the dot product with the three vertices' lighting, 3 vertices × 3
//!   channels × N FMA, read straight from the vertex array (the lighting is
//!   never interpolated into a buffer: `⟨Σ_j λ_j L_j, b⟩ = Σ_j λ_j ⟨L_j, b⟩`).
//!
//! At order 6 (N = 36) with the 1st-order Taylor rotation that is ≈ 900 flops
//! per sample, of which the 324-FMA dot product is the largest part; the
//! counts per rotation are in `relight bench sh`.
//!
//! # Background
//! Empty samples get the background only where asked: every empty sample
//! ([`Bg::All`]), only those of pixels that an object partly covers
//! ([`Bg::Partial`]: `relight_render::method::render_frame` fills every pixel
//! no object touches with the shared background anyway), or black.

use crate::bake::BrdfShTable;
use crate::relight::{DrawData, Rotator};
use crate::{MAX_SHADING_ORDER, NormalMap, ShRotationMethod};
use glam::{Mat3, Vec2, Vec3, Vec4};
use rayon::prelude::*;
use relight_render::raster::{NO_TRIANGLE, Rasterizer};
use relight_render::{Camera, Image};
use relight_sh::rotation::{ShRotation, rotate_z};
use relight_sphere::Frame;
use std::sync::Arc;

const MAXN: usize = MAX_SHADING_ORDER * MAX_SHADING_ORDER;

/// Background of the empty samples (module docs).
#[derive(Clone, Copy)]
pub(crate) enum Bg<'a> {
    /// Black.
    Black,
    /// `f(d)` for every empty sample, `d` the unit world view direction.
    All(&'a (dyn Fn(Vec3) -> Vec3 + Sync)),
    /// `f(d)` only for empty samples of `k × k` blocks with a covered sample.
    Partial(usize, &'a (dyn Fn(Vec3) -> Vec3 + Sync)),
}

/// Everything the pass reads, per frame.
pub(crate) struct Pass<'a> {
    pub draws: &'a [DrawData],
    pub tables: &'a [Arc<BrdfShTable>],
    /// Per object: the window factor of every coefficient index (`order²`).
    pub windows: &'a [Vec<f32>],
    pub normal_maps: &'a [Option<&'a NormalMap>],
    pub order: usize,
    /// Coefficients per channel of the vertex lighting (the prepared order²).
    pub nn_max: usize,
    pub method: ShRotationMethod,
    pub rotator: &'a Rotator,
    /// Sign of each coefficient under the back-face flip (`order²`).
    pub flip: &'a [f32],
}

/// Per-thread buffers of the pass.
struct Scratch {
    b: [f32; 3 * MAXN],
    bz: [f32; 3 * MAXN],
    tmp: [f32; MAXN],
    exact: Option<ShRotation<f32>>,
}

impl Scratch {
    fn new() -> Box<Self> {
        Box::new(Self {
            b: [0.0; 3 * MAXN],
            bz: [0.0; 3 * MAXN],
            tmp: [0.0; MAXN],
            exact: None,
        })
    }
}

/// The draw of a global triangle id (the rasterizer numbers the triangles
/// of draw `d` after those of draws `0..d`), remembering the last draw.
struct Locator<'a> {
    /// First global id of every draw, and the total.
    offsets: &'a [u32],
    draw: usize,
}

impl Locator<'_> {
    #[inline]
    fn locate(&mut self, id: u32) -> Option<(usize, usize)> {
        let o = self.offsets;
        if !(id >= o[self.draw] && id < o[self.draw + 1]) {
            if id >= *o.last()? {
                return None;
            }
            self.draw = o.partition_point(|&x| x <= id) - 1;
        }
        Some((self.draw, (id - o[self.draw]) as usize))
    }
}

/// `Σ_j λ_j ⟨l_j, b⟩` over the first `b.len()` coefficients (8-lane sums
/// that the compiler vectorises).
#[inline]
fn dot3(l0: &[f32], l1: &[f32], l2: &[f32], lam: Vec3, b: &[f32]) -> f32 {
    let k = b.len();
    let (l0, l1, l2) = (&l0[..k], &l1[..k], &l2[..k]);
    let mut acc = [0.0f32; 8];
    let chunks = l0
        .chunks_exact(8)
        .zip(l1.chunks_exact(8))
        .zip(l2.chunks_exact(8))
        .zip(b.chunks_exact(8));
    for (((a0, a1), a2), bb) in chunks {
        for j in 0..8 {
            acc[j] += (lam.x * a0[j] + lam.y * a1[j] + lam.z * a2[j]) * bb[j];
        }
    }
    let mut s: f32 = acc.iter().sum();
    for i in k / 8 * 8..k {
        s += (lam.x * l0[i] + lam.y * l1[i] + lam.z * l2[i]) * b[i];
    }
    s
}

impl Pass<'_> {
    /// Shades the visibility buffer of `raster` (rasterized for `camera`,
    /// supersampling included) into `out`.
    pub(crate) fn run(&self, raster: &Rasterizer, camera: &Camera, bg: Bg, out: &mut Image) {
        let g = raster.gbuffer();
        let (w, h) = (g.width, g.height);
        out.width = w;
        out.height = h;
        out.pixels.resize(w * h, Vec3::ZERO);
        let rays = camera.ray_frame();
        let eye = camera.eye;
        let mut offsets = Vec::with_capacity(self.draws.len() + 1);
        let mut total = 0u32;
        offsets.push(0);
        for d in self.draws {
            total += d.triangles.len() as u32;
            offsets.push(total);
        }
        out.pixels
            .par_chunks_mut(w)
            .enumerate()
            .for_each_init(Scratch::new, |s, (y, row)| {
                let mut loc = Locator {
                    offsets: &offsets,
                    draw: 0,
                };
                let ids = &g.triangle[y * w..(y + 1) * w];
                let bary = &g.barycentrics[y * w..(y + 1) * w];
                for (x, px) in row.iter_mut().enumerate() {
                    let id = ids[x];
                    if id == NO_TRIANGLE {
                        *px = match bg {
                            Bg::Black => Vec3::ZERO,
                            Bg::All(f) => f(rays.dir(x as f32 + 0.5, y as f32 + 0.5)),
                            Bg::Partial(k, f) => {
                                let (bx, by) = (x / k * k, y / k * k);
                                let touched = (by..(by + k).min(h)).any(|yy| {
                                    g.triangle[yy * w + bx..yy * w + (bx + k).min(w)]
                                        .iter()
                                        .any(|&t| t != NO_TRIANGLE)
                                });
                                if touched {
                                    f(rays.dir(x as f32 + 0.5, y as f32 + 0.5))
                                } else {
                                    Vec3::ZERO
                                }
                            }
                        };
                        continue;
                    }
                    *px = match loc.locate(id) {
                        Some((d, t)) => self.sample(s, eye, d, t, bary[x]),
                        None => Vec3::ZERO,
                    };
                }
            });
    }

    /// One covered sample of draw `d`, triangle `t` (module docs).
    #[inline]
    fn sample(&self, s: &mut Scratch, eye: Vec3, d: usize, t: usize, bary: [f32; 2]) -> Vec3 {
        let draw = &self.draws[d];
        let [i0, i1, i2] = draw.triangles[t].map(|i| i as usize);
        let lam = Vec3::new(1.0 - bary[0] - bary[1], bary[0], bary[1]);
        let (v0, v1, v2) = (&draw.verts[i0], &draw.verts[i1], &draw.verts[i2]);
        let mix = |k: usize| lam.x * v0[k] + lam.y * v1[k] + lam.z * v2[k];
        let (p0, p1, p2) = (draw.positions[i0], draw.positions[i1], draw.positions[i2]);
        let position = p0 * lam.x + p1 * lam.y + p2 * lam.z;
        let geo = (p1 - p0).cross(p2 - p0);
        let wo_world = (eye - position).normalize_or_zero();
        let n_i = Vec3::new(mix(0), mix(1), mix(2)).normalize_or(geo.normalize_or(Vec3::Z));
        let t_i = Vec4::new(mix(3), mix(4), mix(5), mix(6));
        let uv = Vec2::new(mix(7), mix(8));
        let back = wo_world.dot(geo) < 0.0;
        let sgn = if back { -1.0 } else { 1.0 };
        let normal_map = self.normal_maps[d];
        let fv = Frame::from_normal_tangent(sgn * n_i, t_i.truncate());
        let fp = match normal_map {
            Some(m) => Frame::from_normal_tangent(sgn * m.perturb(n_i, t_i, uv), t_i.truncate()),
            None => fv,
        };
        let wo = fp.to_local(wo_world);
        if wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let order = self.order;
        let k = order * order;
        let table = &self.tables[d];
        let h = &self.windows[d][..k];
        let mono = table.mono_colour();
        let channels = if mono.is_some() { 1 } else { 3 };
        let b = &mut s.b[..channels * k];
        if mono.is_some() {
            table.lookup_mono(wo.z, order, b);
        } else {
            table.lookup(wo.z, order, b);
        }
        for c in 0..channels {
            for (v, hw) in b[c * k..(c + 1) * k].iter_mut().zip(h) {
                *v *= hw;
            }
        }
        let rxy = (wo.x * wo.x + wo.y * wo.y).sqrt();
        let (cphi, sphi) = if rxy > 1e-12 {
            (wo.x / rxy, wo.y / rxy)
        } else {
            (1.0, 0.0)
        };
        let bz = &mut s.bz[..channels * k];
        if self.method == ShRotationMethod::None || normal_map.is_none() {
            for c in 0..channels {
                rotate_z(
                    order,
                    cphi,
                    sphi,
                    &b[c * k..(c + 1) * k],
                    &mut bz[c * k..(c + 1) * k],
                );
            }
        } else {
            // T = F_vᵀ F_p R_z(φ_o): canonical → perturbed frame → vertex frame.
            let fv_m = Mat3::from_cols(fv.x, fv.y, fv.z);
            let fp_m = Mat3::from_cols(fp.x, fp.y, fp.z);
            let rz = Mat3::from_cols(
                Vec3::new(cphi, sphi, 0.0),
                Vec3::new(-sphi, cphi, 0.0),
                Vec3::Z,
            );
            self.rotator.rotate(
                fv_m.transpose() * fp_m * rz,
                channels,
                b,
                bz,
                &mut s.tmp,
                &mut s.exact,
            );
        }
        if back {
            for c in 0..channels {
                for (v, f) in bz[c * k..(c + 1) * k].iter_mut().zip(self.flip) {
                    *v *= f;
                }
            }
        }
        let nn = self.nn_max;
        let stride = 3 * nn;
        let (l0, l1, l2) = (
            &draw.light[i0 * stride..(i0 + 1) * stride],
            &draw.light[i1 * stride..(i1 + 1) * stride],
            &draw.light[i2 * stride..(i2 + 1) * stride],
        );
        let mut out = [0.0f32; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let bc = if channels == 1 {
                &bz[..k]
            } else {
                &bz[c * k..(c + 1) * k]
            };
            let r = c * nn..c * nn + k;
            *o = dot3(&l0[r.clone()], &l1[r.clone()], &l2[r], lam, bc);
        }
        let v = Vec3::from_array(out);
        match mono {
            Some(rho) => v * Vec3::from_array(rho),
            None => v,
        }
    }
}
