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
//! # Chunks
//! A row's covered samples are shaded in chunks of [`CHUNK`]: each is
//! prepared (interpolation, frames, transfer lookup), then the chunk's
//! rotations run, then the dot products. On a CPU with AVX2 and FMA the
//! rotations of a normal-mapped chunk at order ≤ 6 run eight vectors at a
//! time, lanes across samples: the exact ones (ZYZ, Ivanic–Ruedenberg) by
//! [`relight_sh::fast::rotate_batch`] (≈ 18 ns per order-6 vector against
//! ≈ 50 one at a time), the Taylor ones by [`relight_sh::fast::taylor_batch`];
//! the Z-only turns of samples without a normal map stay one by one (a cheap
//! O(N) step).
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
use relight_render::camera::CameraRays;
use relight_render::raster::{GBuffer, NO_TRIANGLE, Rasterizer};
use relight_render::{Camera, Image};
use relight_sh::fast::ROTATE_BATCH_MAX_ORDER;
use relight_sh::rotation::{Rot3, ShRotation, rotate_z};
use relight_sphere::Frame;
use std::sync::Arc;

const MAXN: usize = MAX_SHADING_ORDER * MAX_SHADING_ORDER;

/// Draws whose triangle offsets [`Pass::run`] keeps on the stack.
const MAX_DRAWS: usize = 64;

/// First global triangle id of every draw, and the total.
pub(crate) fn triangle_offsets(draws: &[DrawData]) -> Vec<u32> {
    let mut offsets = Vec::with_capacity(draws.len() + 1);
    let mut total = 0u32;
    offsets.push(0);
    for d in draws {
        total += d.triangles.len() as u32;
        offsets.push(total);
    }
    offsets
}

/// Fused multiply-adds of one covered sample at `order` bands (module docs,
/// "Work per covered sample"): `channels` transfer vectors (1 for a rank-1
/// table, else 3) rotated by `method` where `normal_mapped`, else only
/// turned about z; `x_nonzeros` is one fixed X matrix's non-zeros of the
/// ZYZ plan. A multiply or add alone counts as one.
#[must_use]
pub(crate) fn sample_fma(
    order: usize,
    method: ShRotationMethod,
    normal_mapped: bool,
    channels: usize,
    x_nonzeros: usize,
) -> f64 {
    let n = order as f64;
    let nn = n * n;
    let ch = channels as f64;
    // Interpolation (9 attributes, position), geometric normal, view and
    // normal normalisation: ≈ 60; two Gram–Schmidt frames, the normal-map
    // lookup and the local view: ≈ 90; acos and the table position: ≈ 10.
    let setup = 160.0;
    // Lerp and window: 2 per coefficient and channel.
    let lookup = 2.0 * nn * ch;
    // A Z rotation: 2 per coefficient plus the cos/sin recurrence of m φ.
    let z = 2.0 * nn + 4.0 * n;
    let band_sq: f64 = (0..order).map(|l| ((2 * l + 1) * (2 * l + 1)) as f64).sum();
    let rotation = if !normal_mapped || method == ShRotationMethod::None {
        z * ch
    } else {
        // T = F_vᵀ F_p R_z: two 3×3 products, then the SH rotation.
        54.0 + ch
            * match method {
                ShRotationMethod::Exact => 16.0 * band_sq,
                ShRotationMethod::Zyz => 3.0 * z + 2.0 * x_nonzeros as f64,
                ShRotationMethod::Taylor1 => 2.0 * z + 3.0 * nn,
                ShRotationMethod::Taylor15 => 2.0 * z + 4.0 * nn,
                ShRotationMethod::Taylor2 => 2.0 * z + 5.0 * nn,
                ShRotationMethod::None => 0.0,
            }
    };
    // Three vertices' lighting, three output channels.
    let dot = 9.0 * nn + 9.0;
    setup + lookup + rotation + dot
}

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

/// Samples [`Pass::row`] prepares before rotating them together: 32 samples
/// of three channels at order 6 are 14 KB per buffer, inside L1 and L2.
const CHUNK: usize = 32;

/// A covered sample between its preparation and its dot product.
#[derive(Clone, Copy, Default)]
struct Pending {
    /// Column in the row.
    x: usize,
    /// Draw and the triangle's three vertices.
    d: usize,
    verts: [usize; 3],
    lam: Vec3,
    /// Seen from behind: the coefficients take the back-face flip.
    back: bool,
    /// Transfer vectors (1 for a rank-1 table, else 3) from vector `first`
    /// of the chunk's `dst` buffer, or of its batch buffers where `in_batch`.
    channels: usize,
    first: usize,
    in_batch: bool,
}

/// Per-thread buffers of the pass.
struct Scratch {
    tmp: [f32; MAXN],
    exact: Option<ShRotation<f32>>,
    /// The chunk's samples and, per sample, `channels` transfer vectors of
    /// `order²`: rotated one by one (`src` before, `dst` after) or, for the
    /// batch rotation, noted with one rotation per vector (`batch_src`,
    /// `batch_dst`, `rots`).
    pending: [Pending; CHUNK],
    src: Vec<f32>,
    dst: Vec<f32>,
    batch_src: Vec<f32>,
    batch_dst: Vec<f32>,
    rots: Vec<Rot3<f32>>,
}

impl Scratch {
    fn new() -> Box<Self> {
        Box::new(Self {
            tmp: [0.0; MAXN],
            exact: None,
            pending: [Pending::default(); CHUNK],
            src: Vec::new(),
            dst: Vec::new(),
            batch_src: Vec::new(),
            batch_dst: Vec::new(),
            rots: Vec::new(),
        })
    }

    /// Sizes the chunk buffers for `channels × k` coefficients per sample.
    fn size_for(&mut self, per_sample: usize) {
        if self.src.len() != CHUNK * per_sample {
            for b in [
                &mut self.src,
                &mut self.dst,
                &mut self.batch_src,
                &mut self.batch_dst,
            ] {
                b.resize(CHUNK * per_sample, 0.0);
            }
        }
        if self.rots.len() != CHUNK * 3 {
            self.rots
                .resize(CHUNK * 3, Rot3::from_mat3_unchecked(Mat3::IDENTITY));
        }
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

/// `a · b + c`, fused where `F` (the caller runs with the FMA target
/// feature, [`Pass::run`]).
#[inline(always)]
fn madd<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

/// `Σ_j λ_j ⟨l_j, b⟩ = ⟨Σ_j λ_j l_j, b⟩` over the first `b.len()`
/// coefficients: the lighting blended by `λ` and multiplied into 8-lane
/// sums (3 FMA per coefficient, as three dot products would take), then one
/// horizontal sum instead of three. Tails of 4 (orders 2, 6, 10, …) in a
/// 4-lane sum, the rest in scalars.
#[inline(always)]
fn dot3<const F: bool>(l0: &[f32], l1: &[f32], l2: &[f32], lam: Vec3, b: &[f32]) -> f32 {
    let k = b.len();
    let (l0, l1, l2) = (&l0[..k], &l1[..k], &l2[..k]);
    let mut s = [0.0f32; 8];
    let full = k / 8 * 8;
    let chunks = l0[..full]
        .chunks_exact(8)
        .zip(l1[..full].chunks_exact(8))
        .zip(l2[..full].chunks_exact(8))
        .zip(b[..full].chunks_exact(8));
    for (((a0, a1), a2), bb) in chunks {
        for j in 0..8 {
            let l = madd::<F>(lam.x, a0[j], madd::<F>(lam.y, a1[j], lam.z * a2[j]));
            s[j] = madd::<F>(l, bb[j], s[j]);
        }
    }
    let mut q = [0.0f32; 4];
    let mut i = full;
    if k - i >= 4 {
        for j in 0..4 {
            let l = madd::<F>(
                lam.x,
                l0[i + j],
                madd::<F>(lam.y, l1[i + j], lam.z * l2[i + j]),
            );
            q[j] = madd::<F>(l, b[i + j], q[j]);
        }
        i += 4;
    }
    let mut t = 0.0f32;
    for i in i..k {
        let l = madd::<F>(lam.x, l0[i], madd::<F>(lam.y, l1[i], lam.z * l2[i]));
        t = madd::<F>(l, b[i], t);
    }
    let q = [
        s[0] + s[4] + q[0],
        s[1] + s[5] + q[1],
        s[2] + s[6] + q[2],
        s[3] + s[7] + q[3],
    ];
    ((q[0] + q[2]) + (q[1] + q[3])) + t
}

/// The frame of `n` and `t` by Gram–Schmidt: the arithmetic of
/// [`Frame::from_normal_tangent`] inlined into the pass (a call per frame,
/// two per pixel, was 6 % of a frame), with its fallback.
#[inline(always)]
fn frame_of(n: Vec3, t: Vec3) -> Frame {
    match (t - n * n.dot(t)).try_normalize() {
        Some(x) => Frame {
            x,
            y: n.cross(x),
            z: n,
        },
        None => Frame::from_z(n),
    }
}

/// Whether this CPU runs the pass's AVX2 + FMA copy ([`Pass::run`]).
#[inline]
pub(crate) fn fma_path() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// What every row of one pass reads.
struct Rows<'a> {
    g: &'a GBuffer,
    rays: CameraRays,
    eye: Vec3,
    offsets: &'a [u32],
    bg: Bg<'a>,
    /// Rotate each chunk's normal-mapped transfer vectors eight at a time
    /// ([`relight_sh::fast::rotate_batch`], [`relight_sh::fast::taylor_batch`])
    /// instead of one by one.
    batched: bool,
}

impl Pass<'_> {
    /// Shades the visibility buffer of `raster` (rasterized for `camera`,
    /// supersampling included) into `out`. Rows run in parallel; on a CPU
    /// with AVX2 and FMA ([`fma_path`]) through a copy of the row loop
    /// compiled for them (8-lane fused dot products and lerps), elsewhere
    /// through the portable copy, unless `portable` forces it (tests).
    pub(crate) fn run(
        &self,
        raster: &Rasterizer,
        camera: &Camera,
        bg: Bg,
        out: &mut Image,
        portable: bool,
    ) {
        let g = raster.gbuffer();
        let w = g.width;
        out.width = w;
        out.height = g.height;
        out.pixels.resize(w * g.height, Vec3::ZERO);
        let mut offsets = [0u32; MAX_DRAWS + 1];
        let offsets: &[u32] = if self.draws.len() <= MAX_DRAWS {
            let mut total = 0u32;
            for (i, d) in self.draws.iter().enumerate() {
                total += d.triangles.len() as u32;
                offsets[i + 1] = total;
            }
            &offsets[..=self.draws.len()]
        } else {
            &triangle_offsets(self.draws)
        };
        let fma = !portable && fma_path();
        let batched =
            fma && self.order <= ROTATE_BATCH_MAX_ORDER && self.method != ShRotationMethod::None;
        let rows = Rows {
            g,
            rays: camera.ray_frame(),
            eye: camera.eye,
            offsets,
            bg,
            batched,
        };
        out.pixels
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each_init(Scratch::new, |s, (y, row)| {
                #[cfg(target_arch = "x86_64")]
                if fma {
                    // SAFETY: AVX2 and FMA were detected at run time (`fma_path`).
                    unsafe { self.row_fma(s, &rows, y, row) };
                    return;
                }
                let _ = fma;
                self.row::<false>(s, &rows, y, row);
            });
    }

    /// [`Pass::row`] compiled for AVX2 and FMA.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn row_fma(&self, s: &mut Scratch, rows: &Rows, y: usize, row: &mut [Vec3]) {
        self.row::<true>(s, rows, y, row);
    }

    /// Row `y` of the pass (`F`: fused multiply-adds).
    #[inline(always)]
    fn row<const F: bool>(&self, s: &mut Scratch, rows: &Rows, y: usize, row: &mut [Vec3]) {
        let g = rows.g;
        let (w, h) = (g.width, g.height);
        let mut loc = Locator {
            offsets: rows.offsets,
            draw: 0,
        };
        let ids = &g.triangle[y * w..(y + 1) * w];
        let bary = &g.barycentrics[y * w..(y + 1) * w];
        let k = self.order * self.order;
        s.size_for(3 * k);
        let (mut count, mut vectors, mut batched) = (0usize, 0usize, 0usize);
        for x in 0..row.len() {
            let id = ids[x];
            if id == NO_TRIANGLE {
                row[x] = match rows.bg {
                    Bg::Black => Vec3::ZERO,
                    Bg::All(f) => f(rows.rays.dir(x as f32 + 0.5, y as f32 + 0.5)),
                    Bg::Partial(k, f) => {
                        let (bx, by) = (x / k * k, y / k * k);
                        let touched = (by..(by + k).min(h)).any(|yy| {
                            g.triangle[yy * w + bx..yy * w + (bx + k).min(w)]
                                .iter()
                                .any(|&t| t != NO_TRIANGLE)
                        });
                        if touched {
                            f(rows.rays.dir(x as f32 + 0.5, y as f32 + 0.5))
                        } else {
                            Vec3::ZERO
                        }
                    }
                };
                continue;
            }
            let Some((d, t)) = loc.locate(id) else {
                row[x] = Vec3::ZERO;
                continue;
            };
            match self.prepare::<F>(s, rows, d, t, bary[x], x, [vectors, batched]) {
                Some(p) => {
                    s.pending[count] = p;
                    count += 1;
                    if p.in_batch {
                        batched += p.channels;
                    } else {
                        vectors += p.channels;
                    }
                    if count == CHUNK {
                        self.finish::<F>(s, count, batched, row);
                        (count, vectors, batched) = (0, 0, 0);
                    }
                }
                None => row[x] = Vec3::ZERO,
            }
        }
        if count > 0 {
            self.finish::<F>(s, count, batched, row);
        }
    }

    /// The first half of covered sample `x` of draw `d`, triangle `t`
    /// (module docs): its transfer vectors into the chunk buffers from vector
    /// `first[0]` (windowed, turned to the view's azimuth and rotated to the
    /// vertex frame now), or from vector `first[1]` of the batch buffers with
    /// their rotations noted (a full rotation where [`Rows::batched`]);
    /// `None` when the view is below the shading frame's horizon (black).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn prepare<const F: bool>(
        &self,
        s: &mut Scratch,
        rows: &Rows,
        d: usize,
        t: usize,
        bary: [f32; 2],
        x: usize,
        first: [usize; 2],
    ) -> Option<Pending> {
        let draw = &self.draws[d];
        let verts = draw.triangles[t].map(|i| i as usize);
        let [i0, i1, i2] = verts;
        let lam = Vec3::new(1.0 - bary[0] - bary[1], bary[0], bary[1]);
        let (v0, v1, v2) = (&draw.verts[i0], &draw.verts[i1], &draw.verts[i2]);
        // No closures here: one was left out of line, outside the caller's
        // `avx2,fma` features (its `mul_add` a libm call).
        let mut mix = [0.0f32; 9];
        for (k, m) in mix.iter_mut().enumerate() {
            *m = madd::<F>(lam.x, v0[k], madd::<F>(lam.y, v1[k], lam.z * v2[k]));
        }
        let (p0, p1, p2) = (draw.positions[i0], draw.positions[i1], draw.positions[i2]);
        let position = p0 * lam.x + p1 * lam.y + p2 * lam.z;
        let geo = (p1 - p0).cross(p2 - p0);
        let wo_world = (rows.eye - position).normalize_or_zero();
        let n_i = Vec3::new(mix[0], mix[1], mix[2]).normalize_or(geo.normalize_or(Vec3::Z));
        let t_i = Vec4::new(mix[3], mix[4], mix[5], mix[6]);
        let uv = Vec2::new(mix[7], mix[8]);
        let back = wo_world.dot(geo) < 0.0;
        let sgn = if back { -1.0 } else { 1.0 };
        let normal_map = self.normal_maps[d];
        let fv = frame_of(sgn * n_i, t_i.truncate());
        let fp = match normal_map {
            Some(m) => frame_of(sgn * m.perturb(n_i, t_i, uv), t_i.truncate()),
            None => fv,
        };
        let wo = fp.to_local(wo_world);
        if wo.z <= 0.0 {
            return None;
        }
        let order = self.order;
        let k = order * order;
        let table = &self.tables[d];
        let h = &self.windows[d][..k];
        let mono = table.mono_colour().is_some();
        let channels = if mono { 1 } else { 3 };
        let turned_only = self.method == ShRotationMethod::None || normal_map.is_none();
        let in_batch = rows.batched && !turned_only;
        let first = first[usize::from(in_batch)];
        let pending = Pending {
            x,
            d,
            verts,
            lam,
            back,
            channels,
            first,
            in_batch,
        };
        let span = first * k..(first + channels) * k;
        let b = if in_batch {
            &mut s.batch_src[span.clone()]
        } else {
            &mut s.src[span.clone()]
        };
        if mono {
            table.lookup_mono_windowed::<F>(wo.z, order, h, b);
        } else {
            table.lookup(wo.z, order, b);
            for c in 0..channels {
                for (v, hw) in b[c * k..(c + 1) * k].iter_mut().zip(h) {
                    *v *= hw;
                }
            }
        }
        let rxy = (wo.x * wo.x + wo.y * wo.y).sqrt();
        let (cphi, sphi) = if rxy > 1e-12 {
            (wo.x / rxy, wo.y / rxy)
        } else {
            (1.0, 0.0)
        };
        if turned_only {
            for c in 0..channels {
                let r = (first + c) * k..(first + c + 1) * k;
                rotate_z(order, cphi, sphi, &s.src[r.clone()], &mut s.dst[r]);
            }
            return Some(pending);
        }
        // T = F_vᵀ F_p R_z(φ_o): canonical → perturbed frame → vertex frame.
        let rz = Mat3::from_cols(
            Vec3::new(cphi, sphi, 0.0),
            Vec3::new(-sphi, cphi, 0.0),
            Vec3::Z,
        );
        let fv_m = Mat3::from_cols(fv.x, fv.y, fv.z);
        let fp_m = Mat3::from_cols(fp.x, fp.y, fp.z);
        let vertex_from_canonical = fv_m.transpose() * fp_m * rz;
        if in_batch {
            let rot = Rot3::from_mat3_unchecked(vertex_from_canonical);
            s.rots[first..first + channels].fill(rot);
        } else {
            self.rotator.rotate(
                vertex_from_canonical,
                channels,
                &s.src[span.clone()],
                &mut s.dst[span],
                &mut s.tmp,
                &mut s.exact,
            );
        }
        Some(pending)
    }

    /// The second half of the chunk's `count` samples: the batch rotation of
    /// its `batched` vectors, the back-face flip and the dot product with the
    /// three vertices' lighting, into `row`.
    #[inline(always)]
    fn finish<const F: bool>(
        &self,
        s: &mut Scratch,
        count: usize,
        batched: usize,
        row: &mut [Vec3],
    ) {
        let k = self.order * self.order;
        if batched > 0 {
            let (rots, src, dst) = (
                &s.rots[..batched],
                &s.batch_src[..batched * k],
                &mut s.batch_dst[..batched * k],
            );
            match self.rotator.taylor() {
                Some(taylor) => relight_sh::fast::taylor_batch(taylor, rots, src, dst),
                None => relight_sh::fast::rotate_batch(self.order, rots, src, dst),
            }
            .expect("order and lengths checked by Pass::run and Scratch::size_for");
        }
        let nn = self.nn_max;
        let stride = 3 * nn;
        for p in &s.pending[..count] {
            let draw = &self.draws[p.d];
            let span = p.first * k..(p.first + p.channels) * k;
            let bz = if p.in_batch {
                &mut s.batch_dst[span]
            } else {
                &mut s.dst[span]
            };
            if p.back {
                for c in 0..p.channels {
                    for (v, f) in bz[c * k..(c + 1) * k].iter_mut().zip(self.flip) {
                        *v *= f;
                    }
                }
            }
            let [i0, i1, i2] = p.verts;
            let (l0, l1, l2) = (
                &draw.light[i0 * stride..(i0 + 1) * stride],
                &draw.light[i1 * stride..(i1 + 1) * stride],
                &draw.light[i2 * stride..(i2 + 1) * stride],
            );
            let mut out = [0.0f32; 3];
            for (c, o) in out.iter_mut().enumerate() {
                let bc = if p.channels == 1 {
                    &bz[..k]
                } else {
                    &bz[c * k..(c + 1) * k]
                };
                let r = c * nn..c * nn + k;
                *o = dot3::<F>(&l0[r.clone()], &l1[r.clone()], &l2[r], p.lam, bc);
            }
            let v = Vec3::from_array(out);
            row[p.x] = match self.tables[p.d].mono_colour() {
                Some(rho) => v * Vec3::from_array(rho),
                None => v,
            };
        }
    }
}
