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
//! A row's covered samples are shaded in chunks of [`CHUNK`]: each sample's
//! vertex data is gathered into [`Lanes`] (the scattered reads, one sample
//! at a time; a triangle's vertices once per run of samples on it,
//! [`Triangle`]); the normal-map taps of the whole chunk are computed across
//! lanes and their texels read ([`Pass::blend_maps`]); [`setup_lanes`] then computes the
//! normals, frames, view angles and `T` of the whole chunk across lanes (one
//! branch-free loop over structure-of-arrays: 8-lane registers in the AVX2
//! copy, instead of one sample's chain of square roots and divisions at a
//! time); each sample's transfer vector is looked up; the chunk's rotations
//! run; then the dot products ([`dot3_rgb_avx2`] in the AVX2 copy). On a CPU with AVX2 and FMA the
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
use glam::{Mat3, Vec2, Vec3};
use rayon::prelude::*;
use relight_render::camera::CameraRays;
use relight_render::raster::{GBuffer, NO_TRIANGLE, Rasterizer};
use relight_render::texture::BilinearLanes;
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
    /// Where it is and what it interpolates.
    sample: Sample,
    /// Seen from behind: the coefficients take the back-face flip.
    back: bool,
    /// Transfer vectors (1 for a rank-1 table, else 3) from vector `first`
    /// of the chunk's `dst` buffer, or of its batch buffers where `in_batch`.
    channels: usize,
    first: usize,
    in_batch: bool,
}

/// A gathered sample's place in the frame ([`Pass::gather`]).
#[derive(Clone, Copy, Default)]
struct Sample {
    /// Column in the row.
    x: usize,
    /// Draw and the triangle's three vertices.
    d: usize,
    verts: [usize; 3],
    /// Perspective-correct barycentrics.
    lam: Vec3,
}

/// The triangle [`Pass::gather`] last read: neighbouring samples of a row
/// mostly share one, so its vertex data is read and differenced once per
/// run. Attributes interpolate as `v₀ + b₁ (v₁ − v₀) + b₂ (v₂ − v₀)` with
/// the rasterizer's barycentrics `(b₁, b₂)`.
#[derive(Clone, Copy)]
struct Triangle {
    /// Draw and triangle index within it (`usize::MAX`: none yet).
    d: usize,
    t: usize,
    verts: [usize; 3],
    /// Vertex 0's attributes (normal, tangent, uv) and the edges to
    /// vertices 1 and 2.
    v0: [f32; 9],
    e1: [f32; 9],
    e2: [f32; 9],
    /// Vertex 0's position, the edges, and their cross product (the
    /// geometric normal, not unit).
    p0: Vec3,
    p_e1: Vec3,
    p_e2: Vec3,
    geo: Vec3,
}

impl Default for Triangle {
    fn default() -> Self {
        Self {
            d: usize::MAX,
            t: usize::MAX,
            verts: [0; 3],
            v0: [0.0; 9],
            e1: [0.0; 9],
            e2: [0.0; 9],
            p0: Vec3::ZERO,
            p_e1: Vec3::ZERO,
            p_e2: Vec3::ZERO,
            geo: Vec3::ZERO,
        }
    }
}

impl Triangle {
    /// Triangle `t` of draw `d` (`draw`).
    #[inline(always)]
    fn of(draw: &DrawData, d: usize, t: usize) -> Self {
        let verts = draw.triangles[t].map(|i| i as usize);
        let [i0, i1, i2] = verts;
        let (v0, v1, v2) = (draw.verts[i0], draw.verts[i1], draw.verts[i2]);
        let (p0, p1, p2) = (draw.positions[i0], draw.positions[i1], draw.positions[i2]);
        let (p_e1, p_e2) = (p1 - p0, p2 - p0);
        Self {
            d,
            t,
            verts,
            v0,
            e1: std::array::from_fn(|k| v1[k] - v0[k]),
            e2: std::array::from_fn(|k| v2[k] - v0[k]),
            p0,
            p_e1,
            p_e2,
            geo: p_e1.cross(p_e2),
        }
    }
}

/// The chunk's samples between [`Pass::gather`] and [`Pass::place`], as
/// structure of arrays so that [`setup_lanes`] runs across them.
struct Lanes {
    sample: [Sample; CHUNK],
    /// In (world, not unit): the interpolated normal; the interpolated
    /// tangent (xyz, w = handedness); the normal map's texel blend (tangent
    /// space, +z without a map; [`Pass::blend_maps`]); `eye − p`; the
    /// geometric normal.
    n: [[f32; CHUNK]; 3],
    t: [[f32; CHUNK]; 4],
    m: [[f32; CHUNK]; 3],
    /// The interpolated uv, and the normal map's width and height in
    /// texels (1 × 1 without a map), for [`Pass::blend_maps`].
    uv: [[f32; CHUNK]; 2],
    map_size: [[f32; CHUNK]; 2],
    taps: BilinearLanes<CHUNK>,
    view: [[f32; CHUNK]; 3],
    geo: [[f32; CHUNK]; 3],
    /// Out: `cos θ_o`, `θ_o`, `cos φ_o`, `sin φ_o` of the view in `F_p`; the
    /// back-face sign (−1 seen from behind); `T = F_vᵀ F_p R_z(φ_o)`,
    /// column-major.
    cos_o: [f32; CHUNK],
    theta_o: [f32; CHUNK],
    cphi: [f32; CHUNK],
    sphi: [f32; CHUNK],
    sign: [f32; CHUNK],
    rot: [[f32; CHUNK]; 9],
}

impl Lanes {
    /// Sample `i`'s inputs ([`Lanes`]' fields of the same names).
    #[inline(always)]
    fn put(&mut self, i: usize, n: Vec3, t: glam::Vec4, view: Vec3, geo: Vec3) {
        for c in 0..3 {
            self.n[c][i] = n[c];
            self.view[c][i] = view[c];
            self.geo[c][i] = geo[c];
        }
        for c in 0..4 {
            self.t[c][i] = t[c];
        }
    }

    /// Sample `i`'s normal-map blend, tangent space (+z without a map).
    #[inline(always)]
    fn put_m(&mut self, i: usize, m: Vec3) {
        for c in 0..3 {
            self.m[c][i] = m[c];
        }
    }
}

impl Default for Lanes {
    fn default() -> Self {
        let z = [0.0; CHUNK];
        Self {
            sample: [Sample::default(); CHUNK],
            n: [z; 3],
            t: [z; 4],
            m: [z; 3],
            uv: [z; 2],
            map_size: [z; 2],
            taps: BilinearLanes::default(),
            view: [z; 3],
            geo: [z; 3],
            cos_o: z,
            theta_o: z,
            cphi: z,
            sphi: z,
            sign: z,
            rot: [z; 9],
        }
    }
}

/// Per-thread buffers of the pass.
struct Scratch {
    lanes: Lanes,
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
            lanes: Lanes::default(),
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
    // Whole arrays (not `chunks_exact` slices): the 8-lane body then
    // compiles to one register per operand instead of lane pairs.
    let (b8, _) = b.as_chunks::<8>();
    let full = b8.len() * 8;
    let chunks = l0
        .as_chunks::<8>()
        .0
        .iter()
        .zip(l1.as_chunks::<8>().0)
        .zip(l2.as_chunks::<8>().0)
        .zip(b8);
    for (((a0, a1), a2), bb) in chunks {
        let (a0, a1, a2, bb) = (*a0, *a1, *a2, *bb);
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

/// [`dot3`] for the three output channels at once, in AVX2 registers:
/// `out_c = ⟨Σ_j λ_j L_j^c, b_c⟩` over `k` coefficients, `L_j^c` at
/// `light[j][c · nn..]` (vertex `j`'s lighting, `nn` coefficients per
/// channel) and `b_c = b[c]`; `MONO`: one transfer vector `b[0]` for all
/// three channels (a rank-1 table), loaded once per 8 coefficients. The
/// compiler pairs [`dot3`]'s eight lanes into 2-lane registers; written
/// with intrinsics the pass's dot product takes a quarter of the
/// instructions. The three channels share one loop and one horizontal sum
/// (three `hadd`s and one 128-bit add instead of three reductions). The
/// last `k mod 8` coefficients are masked loads.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn dot3_rgb_avx2<const MONO: bool>(
    light: [&[f32]; 3],
    nn: usize,
    k: usize,
    lam: Vec3,
    b: [&[f32]; 3],
) -> [f32; 3] {
    use std::arch::x86_64::*;
    assert!(k <= nn && light.iter().all(|l| l.len() >= 3 * nn) && b.iter().all(|b| b.len() >= k));
    let (lx, ly, lz) = (
        _mm256_set1_ps(lam.x),
        _mm256_set1_ps(lam.y),
        _mm256_set1_ps(lam.z),
    );
    let rem = (k % 8) as i32;
    let mask = _mm256_cmpgt_epi32(
        _mm256_set1_epi32(rem),
        _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
    );
    // SAFETY: every full load reads `i..i + 8 ≤ k` of a slice of at least
    // `c · nn + k` (lighting) or `k` (transfer) values, checked above; the
    // masked loads read only their first `k mod 8` lanes.
    unsafe {
        let p = |c: usize| {
            [
                light[0].as_ptr().add(c * nn),
                light[1].as_ptr().add(c * nn),
                light[2].as_ptr().add(c * nn),
            ]
        };
        let p = [p(0), p(1), p(2)];
        let pb = if MONO {
            [b[0].as_ptr(); 3]
        } else {
            [b[0].as_ptr(), b[1].as_ptr(), b[2].as_ptr()]
        };
        let mut acc = [_mm256_setzero_ps(); 3];
        let mut i = 0;
        while i + 8 <= k {
            let b0 = _mm256_loadu_ps(pb[0].add(i));
            for c in 0..3 {
                let bc = if MONO || c == 0 {
                    b0
                } else {
                    _mm256_loadu_ps(pb[c].add(i))
                };
                let l = _mm256_fmadd_ps(
                    lx,
                    _mm256_loadu_ps(p[c][0].add(i)),
                    _mm256_fmadd_ps(
                        ly,
                        _mm256_loadu_ps(p[c][1].add(i)),
                        _mm256_mul_ps(lz, _mm256_loadu_ps(p[c][2].add(i))),
                    ),
                );
                acc[c] = _mm256_fmadd_ps(l, bc, acc[c]);
            }
            i += 8;
        }
        if rem > 0 {
            // No closure: it could be compiled outside these features.
            let b0 = _mm256_maskload_ps(pb[0].add(i), mask);
            for c in 0..3 {
                let bc = if MONO || c == 0 {
                    b0
                } else {
                    _mm256_maskload_ps(pb[c].add(i), mask)
                };
                let l = _mm256_fmadd_ps(
                    lx,
                    _mm256_maskload_ps(p[c][0].add(i), mask),
                    _mm256_fmadd_ps(
                        ly,
                        _mm256_maskload_ps(p[c][1].add(i), mask),
                        _mm256_mul_ps(lz, _mm256_maskload_ps(p[c][2].add(i), mask)),
                    ),
                );
                acc[c] = _mm256_fmadd_ps(l, bc, acc[c]);
            }
        }
        // [r01 r23 g01 g23 | r45 r67 g45 g67], [b01 b23 b01 b23 | …], then
        // [r0123 g0123 b0123 b0123 | r4567 …]: the halves' sum is (r, g, b, b).
        let rg = _mm256_hadd_ps(acc[0], acc[1]);
        let bb = _mm256_hadd_ps(acc[2], acc[2]);
        let h = _mm256_hadd_ps(rg, bb);
        let q = _mm_add_ps(_mm256_castps256_ps128(h), _mm256_extractf128_ps::<1>(h));
        let mut out = [0.0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), q);
        [out[0], out[1], out[2]]
    }
}

/// The frame of `n` and `t` by Gram–Schmidt: the arithmetic of
/// [`Frame::from_normal_tangent`] inlined into [`setup_lanes`], its fallback
/// ([`Frame::from_z`]) computed always and selected, so that the lane loop
/// has no branch.
#[inline(always)]
fn frame_of(n: Vec3, t: Vec3) -> Frame {
    let u = t - n * n.dot(t);
    let r = u.length_recip();
    let fallback = Frame::from_z(n);
    let ok = r.is_finite() && r > 0.0;
    let x = u * r;
    Frame {
        x: if ok { x } else { fallback.x },
        y: if ok { n.cross(x) } else { fallback.y },
        z: n,
    }
}

/// `acos x` for `x ∈ [0, 1]` (radians) without a libm call, so that it
/// runs across lanes: Abramowitz & Stegun 4.4.46, `√(1 − x) Σ_{k<8} a_k x^k`,
/// absolute error ≤ 2·10⁻⁸ in exact arithmetic (a few f32 ulps here; the
/// test `lane_acos_matches_libm` checks it against `f32::acos`).
#[inline(always)]
fn acos_unit(x: f32) -> f32 {
    const A: [f32; 8] = [
        // a₀ = 1.5707963050, π/2 to f32 precision.
        std::f32::consts::FRAC_PI_2,
        -0.214_598_8,
        0.088_978_99,
        -0.050_174_3,
        0.030_891_88,
        -0.017_088_126,
        0.006_670_09,
        -0.001_262_491_1,
    ];
    let x = x.clamp(0.0, 1.0);
    let mut p = A[7];
    for a in A[..7].iter().rev() {
        p = p * x + a;
    }
    (1.0 - x).sqrt() * p
}

/// The arithmetic of the chunk's first `count` samples, across lanes (no
/// branch, no call, structure of arrays: the loop compiles to 8-lane
/// registers in the AVX2 copy of the pass). Per sample, from the gathered
/// interpolants ([`Lanes`]):
/// * the unit normal `n_i` (falling back to the geometric normal, then +z)
///   and the view `ω_o` (unit, world);
/// * the back-face sign `s` (`ω_o · n_g < 0`: both frames flip);
/// * the perturbed normal: [`NormalMap::perturb`]'s arithmetic with the
///   gathered texel blend (`+z` without a map gives `n_i`);
/// * `F_v = frame(s n_i, t)`, `F_p = frame(s n_p, t)`, `ω_o` in `F_p` as
///   `cos θ_o`, `θ_o` ([`acos_unit`]), `cos φ_o`, `sin φ_o`, and
///   `T = F_vᵀ F_p R_z(φ_o)`.
#[inline(always)]
fn setup_lanes(l: &mut Lanes, count: usize) {
    let Lanes {
        n,
        t,
        m,
        view,
        geo,
        cos_o,
        theta_o,
        cphi,
        sphi,
        sign,
        rot,
        ..
    } = l;
    for i in 0..count.min(CHUNK) {
        let g = Vec3::new(geo[0][i], geo[1][i], geo[2][i]);
        let n_i = Vec3::new(n[0][i], n[1][i], n[2][i]).normalize_or(g.normalize_or(Vec3::Z));
        let wo = Vec3::new(view[0][i], view[1][i], view[2][i]).normalize_or_zero();
        let s = if wo.dot(g) < 0.0 { -1.0 } else { 1.0 };
        let tangent = Vec3::new(t[0][i], t[1][i], t[2][i]);
        let tp = (tangent - n_i * n_i.dot(tangent)).normalize_or(n_i.any_orthonormal_vector());
        let bp = n_i.cross(tp) * if t[3][i] < 0.0 { -1.0 } else { 1.0 };
        let n_p = (tp * m[0][i] + bp * m[1][i] + n_i * m[2][i]).normalize_or(n_i);
        let fv = frame_of(s * n_i, tangent);
        let fp = frame_of(s * n_p, tangent);
        let w = fp.to_local(wo);
        let rxy = (w.x * w.x + w.y * w.y).sqrt();
        let turn = rxy > 1e-12;
        let (c, sn) = if turn {
            (w.x / rxy, w.y / rxy)
        } else {
            (1.0, 0.0)
        };
        cos_o[i] = w.z;
        theta_o[i] = acos_unit(w.z);
        cphi[i] = c;
        sphi[i] = sn;
        sign[i] = s;
        // T = F_vᵀ F_p R_z(φ_o), column-major: (F_vᵀ F_p)_rc = F_v,r · F_p,c.
        for (r, fr) in [fv.x, fv.y, fv.z].into_iter().enumerate() {
            let (m0, m1) = (fr.dot(fp.x), fr.dot(fp.y));
            rot[r][i] = m0 * c + m1 * sn;
            rot[3 + r][i] = m1 * c - m0 * sn;
            rot[6 + r][i] = fr.dot(fp.z);
        }
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
    /// with AVX2 and FMA ([`relight_isa::avx2`]) through a copy of the row loop
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
        let fma = !portable && relight_isa::avx2();
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
                    // SAFETY: AVX2 and FMA were detected at run time (`relight_isa::avx2`).
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

    /// Row `y` of the pass (`F`: fused multiply-adds): the covered samples
    /// are gathered into [`Lanes`], [`CHUNK`] at a time, and shaded by
    /// [`Pass::shade_chunk`].
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
        let mut tri = Triangle::default();
        let mut count = 0usize;
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
            self.gather::<F>(&mut s.lanes, &mut tri, count, rows.eye, (d, t), bary[x], x);
            count += 1;
            if count == CHUNK {
                self.shade_chunk::<F>(s, rows, count, row);
                count = 0;
            }
        }
        if count > 0 {
            self.shade_chunk::<F>(s, rows, count, row);
        }
    }

    /// Lane `i` of `lanes`: covered sample `x` of draw `d`, triangle `t`,
    /// its vertex data interpolated with the barycentrics `bary` (the
    /// scattered reads, one sample at a time; the arithmetic after them runs
    /// across lanes in [`Pass::blend_maps`] and [`setup_lanes`]).
    /// The triangle's data is read once per run of samples on it
    /// ([`Triangle`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn gather<const F: bool>(
        &self,
        lanes: &mut Lanes,
        tri: &mut Triangle,
        i: usize,
        eye: Vec3,
        (d, t): (usize, usize),
        bary: [f32; 2],
        x: usize,
    ) {
        if (tri.d, tri.t) != (d, t) {
            *tri = Triangle::of(&self.draws[d], d, t);
        }
        let [b1, b2] = bary;
        // No closures here: one was left out of line, outside the caller's
        // `avx2,fma` features (its `mul_add` a libm call).
        let mut mix = [0.0f32; 9];
        for (k, m) in mix.iter_mut().enumerate() {
            *m = madd::<F>(b1, tri.e1[k], madd::<F>(b2, tri.e2[k], tri.v0[k]));
        }
        let position = tri.p0 + tri.p_e1 * b1 + tri.p_e2 * b2;
        let view = eye - position;
        let size =
            self.normal_maps[d].map_or([1.0; 2], |map| [map.width as f32, map.height as f32]);
        for c in 0..2 {
            lanes.uv[c][i] = mix[7 + c];
            lanes.map_size[c][i] = size[c];
        }
        let lam = Vec3::new(1.0 - b1 - b2, b1, b2);
        lanes.sample[i] = Sample {
            x,
            d,
            verts: tri.verts,
            lam,
        };
        let tangent = glam::Vec4::new(mix[3], mix[4], mix[5], mix[6]);
        lanes.put(i, Vec3::new(mix[0], mix[1], mix[2]), tangent, view, tri.geo);
    }

    /// The chunk's `count` gathered samples: their frames across lanes
    /// ([`setup_lanes`]), then, one by one, the transfer vectors into the
    /// chunk buffers ([`Pass::place`]), then [`Pass::finish`].
    #[inline(always)]
    fn shade_chunk<const F: bool>(
        &self,
        s: &mut Scratch,
        rows: &Rows,
        count: usize,
        row: &mut [Vec3],
    ) {
        self.blend_maps(&mut s.lanes, count);
        setup_lanes(&mut s.lanes, count);
        let (mut pending, mut vectors, mut batched) = (0usize, 0usize, 0usize);
        for i in 0..count {
            match self.place::<F>(s, rows, i, [vectors, batched]) {
                Some(p) => {
                    s.pending[pending] = p;
                    pending += 1;
                    if p.in_batch {
                        batched += p.channels;
                    } else {
                        vectors += p.channels;
                    }
                }
                None => row[s.lanes.sample[i].x] = Vec3::ZERO,
            }
        }
        self.finish::<F>(s, pending, batched, row);
    }

    /// The normal-map blend of the chunk's first `count` samples
    /// ([`NormalMap::blend`](relight_render::texture::NormalMap::blend) at
    /// their uv, bit for bit): the taps across lanes
    /// ([`BilinearLanes::compute`]), then the four texel reads of each
    /// sample; a lane off the taps' fast path asks `blend` itself.
    #[inline(always)]
    fn blend_maps(&self, l: &mut Lanes, count: usize) {
        l.taps.compute(
            [&l.map_size[0], &l.map_size[1]],
            [&l.uv[0], &l.uv[1]],
            count,
        );
        for i in 0..count.min(CHUNK) {
            let m = match self.normal_maps[l.sample[i].d] {
                None => Vec3::Z,
                Some(map) if l.taps.exact[i] => {
                    let t = &map.texels;
                    let tap = |j: usize| t[l.taps.index[j][i] as usize] * l.taps.weight[j][i];
                    tap(0) + tap(1) + tap(2) + tap(3)
                }
                Some(map) => map.blend(Vec2::new(l.uv[0][i], l.uv[1][i])),
            };
            l.put_m(i, m);
        }
    }

    /// The first half of lane `i` after [`setup_lanes`]: its transfer
    /// vectors into the chunk buffers from vector `first[0]` (windowed,
    /// turned to the view's azimuth and rotated to the vertex frame now), or
    /// from vector `first[1]` of the batch buffers with their rotations
    /// noted (a full rotation where [`Rows::batched`]); `None` when the view
    /// is below the shading frame's horizon (black).
    #[inline(always)]
    fn place<const F: bool>(
        &self,
        s: &mut Scratch,
        rows: &Rows,
        i: usize,
        first: [usize; 2],
    ) -> Option<Pending> {
        let l = &s.lanes;
        let cos_o = l.cos_o[i];
        // Below the horizon, or NaN from degenerate vertex data: black.
        if cos_o.is_nan() || cos_o <= 0.0 {
            return None;
        }
        let sample = l.sample[i];
        let d = sample.d;
        let (cphi, sphi) = (l.cphi[i], l.sphi[i]);
        let back = l.sign[i] < 0.0;
        let vertex_from_canonical = Mat3::from_cols_array(&std::array::from_fn(|e| l.rot[e][i]));
        let order = self.order;
        let k = order * order;
        let table = &self.tables[d];
        let h = &self.windows[d][..k];
        let mono = table.mono_colour().is_some();
        let channels = if mono { 1 } else { 3 };
        let turned_only = self.method == ShRotationMethod::None || self.normal_maps[d].is_none();
        let in_batch = rows.batched && !turned_only;
        let first = first[usize::from(in_batch)];
        let pending = Pending {
            sample,
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
            table.lookup_mono_windowed::<F>(l.theta_o[i], order, h, b);
        } else {
            table.lookup(cos_o, order, b);
            for c in 0..channels {
                for (v, hw) in b[c * k..(c + 1) * k].iter_mut().zip(h) {
                    *v *= hw;
                }
            }
        }
        if turned_only {
            for c in 0..channels {
                let r = (first + c) * k..(first + c + 1) * k;
                rotate_z(order, cphi, sphi, &s.src[r.clone()], &mut s.dst[r]);
            }
        } else if in_batch {
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
            let Sample { x, d, verts, lam } = p.sample;
            let draw = &self.draws[d];
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
            let [i0, i1, i2] = verts;
            let (l0, l1, l2) = (
                &draw.light[i0 * stride..(i0 + 1) * stride],
                &draw.light[i1 * stride..(i1 + 1) * stride],
                &draw.light[i2 * stride..(i2 + 1) * stride],
            );
            let bc = |c: usize| {
                if p.channels == 1 {
                    &bz[..k]
                } else {
                    &bz[c * k..(c + 1) * k]
                }
            };
            #[cfg(target_arch = "x86_64")]
            let out = if F {
                debug_assert!(relight_isa::avx2());
                // SAFETY: `F` is the AVX2 + FMA copy of the pass, which
                // `Pass::run` takes only where `relight_isa::avx2` allowed them.
                unsafe {
                    if p.channels == 1 {
                        dot3_rgb_avx2::<true>([l0, l1, l2], nn, k, lam, [bc(0); 3])
                    } else {
                        dot3_rgb_avx2::<false>([l0, l1, l2], nn, k, lam, [bc(0), bc(1), bc(2)])
                    }
                }
            } else {
                std::array::from_fn(|c| {
                    let r = c * nn..c * nn + k;
                    dot3::<F>(&l0[r.clone()], &l1[r.clone()], &l2[r], lam, bc(c))
                })
            };
            #[cfg(not(target_arch = "x86_64"))]
            let out: [f32; 3] = std::array::from_fn(|c| {
                let r = c * nn..c * nn + k;
                dot3::<F>(&l0[r.clone()], &l1[r.clone()], &l2[r], lam, bc(c))
            });
            let v = Vec3::from_array(out);
            row[x] = match self.tables[d].mono_colour() {
                Some(rho) => v * Vec3::from_array(rho),
                None => v,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{CHUNK, Lanes, acos_unit, frame_of, setup_lanes};
    use glam::{Mat3, Vec2, Vec3, Vec4};

    /// The lane setup against the scalar forms it restates: the perturbed
    /// normal of [`crate::NormalMap::perturb`] (fed the unnormalised blend, as
    /// the pass gathers it), the back-face sign, `cos θ_o` in `F_p`, and
    /// `T = F_vᵀ F_p R_z(φ_o)` built from [`frame_of`] matrices; on random
    /// samples, a few seen from behind, one with a tangent along the normal.
    #[test]
    fn lane_setup_matches_the_scalar_perturbation_and_frames() {
        let map = crate::NormalMap::bumps(32, 4, 0.8);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut r = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
        };
        let mut lanes = Lanes::default();
        let mut want = Vec::new();
        for i in 0..CHUNK {
            let n = Vec3::new(r(), r(), r() + 1.5) * 1.7; // not unit
            let geo = (n + Vec3::new(r(), r(), r()) * 0.2).normalize();
            let tangent = if i == 3 {
                Vec4::from((n, 1.0))
            } else {
                Vec4::new(r() + 1.2, r(), r(), if i % 2 == 0 { 1.0 } else { -1.0 })
            };
            let uv = Vec2::new(r(), r()) * 3.0;
            let view = if i % 4 == 1 {
                -geo * 2.0 + Vec3::new(r(), r(), r()) * 0.3 // from behind
            } else {
                geo * 2.0 + Vec3::new(r(), r(), r())
            };
            lanes.put(i, n, tangent, view, geo);
            lanes.put_m(i, map.blend(uv));
            let n_i = n.normalize();
            let wo = view.normalize();
            let s = if wo.dot(geo) < 0.0 { -1.0 } else { 1.0 };
            let n_p = map.perturb(n_i, tangent, uv);
            want.push((s, n_p, n_i, tangent.truncate(), wo));
        }
        setup_lanes(&mut lanes, CHUNK);
        let cols = |f: relight_sphere::Frame| Mat3::from_cols(f.x, f.y, f.z);
        for (i, (s, n_p, n_i, tangent, wo)) in want.into_iter().enumerate() {
            assert_eq!(lanes.sign[i], s, "sample {i}: sign");
            let cos_o = wo.dot(s * n_p);
            assert!(
                (lanes.cos_o[i] - cos_o).abs() < 1e-5,
                "sample {i}: cos θ_o {} vs {cos_o}",
                lanes.cos_o[i]
            );
            assert!((lanes.theta_o[i] - cos_o.clamp(-1.0, 1.0).acos()).abs() < 1e-4 || cos_o < 0.0);
            let (fv, fp) = (
                cols(frame_of(s * n_i, tangent)),
                cols(frame_of(s * n_p, tangent)),
            );
            let w = fp.transpose() * wo;
            let phi = w.y.atan2(w.x);
            let want_t = fv.transpose() * fp * Mat3::from_rotation_z(phi);
            let got = Mat3::from_cols_array(&std::array::from_fn(|k| lanes.rot[k][i]));
            for k in 0..3 {
                let (a, b) = (got.col(k), want_t.col(k));
                assert!(
                    (a - b).abs().max_element() < 1e-5,
                    "sample {i}: T column {k}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn lane_acos_matches_libm() {
        let mut worst = 0.0f32;
        for i in 0..=100_000 {
            let x = i as f32 / 100_000.0;
            worst = worst.max((acos_unit(x) - x.acos()).abs());
        }
        assert!(worst < 5e-7, "worst |acos_unit − acos| = {worst:e}");
        assert_eq!(acos_unit(1.0), 0.0);
        assert!((acos_unit(0.0) - std::f32::consts::FRAC_PI_2).abs() < 2e-7);
    }
}
