//! Data-oriented evaluation of the complete model L = e^{−T_vp} L_p + L_a
//! (Sun 2008, eq. 3.29) over many pixels: the CPU counterpart of the
//! fragment shader of the paper's Figure 3.13.
//!
//! # Layout
//! Pixels are gathered into a [`PixelBatch`] — structure-of-arrays of
//! position, viewer-facing normal, view and mirrored view directions, D_vp
//! and e^{−T_vp}, plus RGB accumulators. For each run of pixels that share a
//! material and for each light, one branch-free loop evaluates
//! [`FogModel::surface_terms`] (airlight as the difference of two tabulated
//! tails, eq. 3.16; Lambert and Phong surface radiance with the scattered
//! term, eq. 3.20–3.28) for every pixel of the run; the light's constants
//! (position, l − e, D_sv, e^{−T_sv}, the clamp of h) are loop invariants
//! ([`PreparedLight`]). Pixels where the two airlight tails nearly cancel
//! are flagged in that loop and fixed afterwards by the 6-point
//! Gauss–Legendre segment integral ([`FogModel::segment_gauss`]), so the
//! main loop has no data-dependent branch and vectorises.
//!
//! On x86-64 with AVX2 and FMA (detected at run time) the loops are compiled
//! for those instructions; otherwise for the baseline target. Nothing here
//! allocates once a batch has grown to its working size.

use crate::fast;
use crate::model::{Bilinear, FogMaterial, FogModel, Lookup, MIN_DISTANCE, Nearest, PreparedLight};
use crate::table::{Interp, Table2};
use glam::Vec3;
use std::f32::consts::PI;

/// Per-material constants of one frame.
#[derive(Clone, Copy, Debug)]
pub struct MaterialConst<'a> {
    /// k_d = ρ_d / π.
    pub kd: Vec3,
    /// k_s (zero without a Phong lobe).
    pub ks: Vec3,
    /// Phong exponent n as f32.
    pub n: f32,
    /// The G_n table (a stand-in when `ks` is zero: its term is multiplied by 0).
    pub g: &'a Table2,
}

impl<'a> MaterialConst<'a> {
    /// Constants of `m` with its Phong table `g_phong` (`None` when `m.ks`
    /// is zero); `None` when the model has no table at all to stand in.
    #[must_use]
    pub fn new(model: &FogModel<'a>, m: &FogMaterial, g_phong: Option<&'a Table2>) -> Self {
        let (ks, g) = match g_phong {
            Some(g) => (m.ks, g),
            None => (Vec3::ZERO, model.stand_in_table()),
        };
        Self {
            kd: m.albedo * (1.0 / PI),
            ks,
            n: m.n as f32,
            g,
        }
    }
}

/// Structure-of-arrays scratch for surface pixels (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct PixelBatch {
    pub px: Vec<f32>,
    pub py: Vec<f32>,
    pub pz: Vec<f32>,
    pub nx: Vec<f32>,
    pub ny: Vec<f32>,
    pub nz: Vec<f32>,
    pub dx: Vec<f32>,
    pub dy: Vec<f32>,
    pub dz: Vec<f32>,
    pub rx: Vec<f32>,
    pub ry: Vec<f32>,
    pub rz: Vec<f32>,
    pub d_vp: Vec<f32>,
    pub e_vp: Vec<f32>,
    /// RGB accumulators.
    pub r: Vec<f32>,
    pub g: Vec<f32>,
    pub b: Vec<f32>,
    /// Per pixel of the current light: tails cancel (1) or not (0), and the
    /// light's offset along / distance from the view ray for the fix-up.
    cancel: Vec<u8>,
    along: Vec<f32>,
    h: Vec<f32>,
}

impl PixelBatch {
    /// Number of pixels.
    #[must_use]
    pub fn len(&self) -> usize {
        self.px.len()
    }

    /// Whether the batch is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.px.is_empty()
    }

    /// The view-dependent columns, filled by [`prepare`](Self::prepare).
    fn view_columns(&mut self) -> [&mut Vec<f32>; 13] {
        [
            &mut self.dx,
            &mut self.dy,
            &mut self.dz,
            &mut self.rx,
            &mut self.ry,
            &mut self.rz,
            &mut self.d_vp,
            &mut self.e_vp,
            &mut self.r,
            &mut self.g,
            &mut self.b,
            &mut self.along,
            &mut self.h,
        ]
    }

    /// Empties the batch (keeps the capacity).
    pub fn clear(&mut self) {
        for v in [
            &mut self.px,
            &mut self.py,
            &mut self.pz,
            &mut self.nx,
            &mut self.ny,
            &mut self.nz,
        ] {
            v.clear();
        }
        for v in self.view_columns() {
            v.clear();
        }
        self.cancel.clear();
    }

    /// Appends the surface point `p` with unit normal `n` (either side) seen
    /// from `eye`; β for e^{−T_vp}.
    #[inline]
    pub fn push(&mut self, eye: Vec3, p: Vec3, n: Vec3, beta: f32) {
        self.push_point(p, n);
        self.size_columns();
        self.prepare_one(self.len() - 1, eye, beta);
    }

    /// Appends `p` and its unit normal `n` without the view-dependent
    /// fields; [`prepare`](Self::prepare) sizes and fills those, and must
    /// run before shading them.
    #[inline]
    pub fn push_point(&mut self, p: Vec3, n: Vec3) {
        self.px.push(p.x);
        self.py.push(p.y);
        self.pz.push(p.z);
        self.nx.push(n.x);
        self.ny.push(n.y);
        self.nz.push(n.z);
    }

    /// Extends the view-dependent columns and the cancellation flags with
    /// zeros to the pixel count (one resize per column for a run of
    /// [`push_point`](Self::push_point)s, not a push per pixel each).
    fn size_columns(&mut self) {
        let n = self.len();
        for v in self.view_columns() {
            v.resize(n, 0.0);
        }
        self.cancel.resize(n, 0);
    }

    /// The view-dependent fields of pixels `start..` (added by
    /// [`push_point`](Self::push_point)): view direction and D_vp from
    /// `eye`, the normal flipped toward the viewer, the mirrored view
    /// direction, e^{−β D_vp}; the accumulators are zeroed.
    pub fn prepare(&mut self, eye: Vec3, beta: f32, start: usize) {
        self.size_columns();
        let mut i = start.min(self.len());
        #[cfg(target_arch = "x86_64")]
        if relight_isa::avx2() {
            // SAFETY: the CPU supports AVX2 and FMA; i ≤ len.
            i += unsafe { crate::simd::prepare(self, i, eye, beta) };
        }
        for k in i..self.len() {
            self.prepare_one(k, eye, beta);
        }
    }

    #[inline]
    fn prepare_one(&mut self, i: usize, eye: Vec3, beta: f32) {
        let p = Vec3::new(self.px[i], self.py[i], self.pz[i]);
        let n = Vec3::new(self.nx[i], self.ny[i], self.nz[i]);
        let v = p - eye;
        let d_vp = v.length().max(MIN_DISTANCE);
        let dir = v / d_vp;
        let n = if n.dot(dir) > 0.0 { -n } else { n };
        let r = dir - 2.0 * dir.dot(n) * n;
        (self.nx[i], self.ny[i], self.nz[i]) = (n.x, n.y, n.z);
        (self.dx[i], self.dy[i], self.dz[i]) = (dir.x, dir.y, dir.z);
        (self.rx[i], self.ry[i], self.rz[i]) = (r.x, r.y, r.z);
        self.d_vp[i] = d_vp;
        self.e_vp[i] = fast::exp(-beta * d_vp);
        (self.r[i], self.g[i], self.b[i]) = (0.0, 0.0, 0.0);
    }

    /// Every column, mutably (for the AVX2 preparation pass).
    pub(crate) fn fields_mut(&mut self) -> BatchFields<'_> {
        BatchFields {
            px: &mut self.px,
            py: &mut self.py,
            pz: &mut self.pz,
            nx: &mut self.nx,
            ny: &mut self.ny,
            nz: &mut self.nz,
            dx: &mut self.dx,
            dy: &mut self.dy,
            dz: &mut self.dz,
            rx: &mut self.rx,
            ry: &mut self.ry,
            rz: &mut self.rz,
            d_vp: &mut self.d_vp,
            e_vp: &mut self.e_vp,
            r: &mut self.r,
            g: &mut self.g,
            b: &mut self.b,
        }
    }

    /// Accumulator of channel `c` (0 = r, 1 = g, 2 = b).
    pub(crate) fn acc_mut(&mut self, c: usize) -> &mut [f32] {
        match c {
            0 => &mut self.r,
            1 => &mut self.g,
            _ => &mut self.b,
        }
    }

    /// Accumulated radiance of pixel `i`.
    #[inline]
    #[must_use]
    pub fn radiance(&self, i: usize) -> Vec3 {
        Vec3::new(self.r[i], self.g[i], self.b[i])
    }
}

/// Mutable views of the columns of a [`PixelBatch`].
pub(crate) struct BatchFields<'a> {
    pub px: &'a mut [f32],
    pub py: &'a mut [f32],
    pub pz: &'a mut [f32],
    pub nx: &'a mut [f32],
    pub ny: &'a mut [f32],
    pub nz: &'a mut [f32],
    pub dx: &'a mut [f32],
    pub dy: &'a mut [f32],
    pub dz: &'a mut [f32],
    pub rx: &'a mut [f32],
    pub ry: &'a mut [f32],
    pub rz: &'a mut [f32],
    pub d_vp: &'a mut [f32],
    pub e_vp: &'a mut [f32],
    pub r: &'a mut [f32],
    pub g: &'a mut [f32],
    pub b: &'a mut [f32],
}

/// Adds the complete model of every light to pixels `range` of `batch`,
/// all of material `mat`.
pub fn shade_surface_run(
    model: &FogModel,
    lights: &[PreparedLight],
    mat: &MaterialConst,
    batch: &mut PixelBatch,
    range: std::ops::Range<usize>,
) {
    let mut range = range.start.min(batch.len())..range.end.min(batch.len());
    #[cfg(target_arch = "x86_64")]
    if simd_ok(model) {
        let ctx = model.simd_ctx();
        // SAFETY: AVX2 and FMA are present, table sides are checked by
        // `simd_ok`, and the range lies inside the batch.
        let done = unsafe {
            match model.interp {
                Interp::Bilinear => crate::simd::surface_run::<false>(
                    &ctx,
                    lights,
                    mat,
                    batch,
                    range.start,
                    range.end,
                ),
                Interp::Nearest => crate::simd::surface_run::<true>(
                    &ctx,
                    lights,
                    mat,
                    batch,
                    range.start,
                    range.end,
                ),
            }
        };
        range.start += done;
    }
    surface_run_dispatch(model, lights, mat, batch, range);
}

/// Whether the AVX2 kernels may run: CPU support and i32-indexable tables.
#[cfg(target_arch = "x86_64")]
fn simd_ok(model: &FogModel) -> bool {
    relight_isa::avx2() && model.max_table_size() <= crate::simd::MAX_GATHER_SIZE
}

#[inline(always)]
fn surface_run_dispatch(
    model: &FogModel,
    lights: &[PreparedLight],
    mat: &MaterialConst,
    batch: &mut PixelBatch,
    range: std::ops::Range<usize>,
) {
    match model.interp {
        Interp::Bilinear => surface_run::<Bilinear>(model, lights, mat, batch, range),
        Interp::Nearest => surface_run::<Nearest>(model, lights, mat, batch, range),
    }
}

#[inline(always)]
fn surface_run<L: Lookup>(
    model: &FogModel,
    lights: &[PreparedLight],
    mat: &MaterialConst,
    batch: &mut PixelBatch,
    range: std::ops::Range<usize>,
) {
    let m = range.len();
    let r0 = range.start;
    fn sl(v: &[f32], r0: usize, m: usize) -> &[f32] {
        &v[r0..r0 + m]
    }
    let (px, py, pz) = (
        sl(&batch.px, r0, m),
        sl(&batch.py, r0, m),
        sl(&batch.pz, r0, m),
    );
    let (nx, ny, nz) = (
        sl(&batch.nx, r0, m),
        sl(&batch.ny, r0, m),
        sl(&batch.nz, r0, m),
    );
    let (dx, dy, dz) = (
        sl(&batch.dx, r0, m),
        sl(&batch.dy, r0, m),
        sl(&batch.dz, r0, m),
    );
    let (rx, ry, rz) = (
        sl(&batch.rx, r0, m),
        sl(&batch.ry, r0, m),
        sl(&batch.rz, r0, m),
    );
    let (d_vp, e_vp) = (sl(&batch.d_vp, r0, m), sl(&batch.e_vp, r0, m));
    let acc_r = &mut batch.r[r0..r0 + m];
    let acc_g = &mut batch.g[r0..r0 + m];
    let acc_b = &mut batch.b[r0..r0 + m];
    let cancel = &mut batch.cancel[r0..r0 + m];
    let along = &mut batch.along[r0..r0 + m];
    let hh = &mut batch.h[r0..r0 + m];
    for light in lights {
        let li = light.intensity;
        // Material × intensity constants of this light.
        let (kdr, kdg, kdb) = (mat.kd.x * li.x, mat.kd.y * li.y, mat.kd.z * li.z);
        let (ksr, ksg, ksb) = (mat.ks.x * li.x, mat.ks.y * li.y, mat.ks.z * li.z);
        let mut any = 0u8;
        for i in 0..m {
            let s = model.surface_terms::<L>(
                light,
                Vec3::new(px[i], py[i], pz[i]),
                Vec3::new(nx[i], ny[i], nz[i]),
                Vec3::new(dx[i], dy[i], dz[i]),
                Vec3::new(rx[i], ry[i], rz[i]),
                e_vp[i],
                mat.n,
                mat.g,
            );
            let air = if s.cancels { 0.0 } else { s.air };
            let (sd, ss) = (e_vp[i] * s.diffuse, e_vp[i] * s.spec);
            acc_r[i] += kdr * sd + ksr * ss + li.x * air;
            acc_g[i] += kdg * sd + ksg * ss + li.y * air;
            acc_b[i] += kdb * sd + ksb * ss + li.z * air;
            let c = u8::from(s.cancels);
            cancel[i] = c;
            any |= c;
            along[i] = s.along;
            hh[i] = s.h;
        }
        if any != 0 {
            for i in 0..m {
                if cancel[i] != 0 {
                    let air = model.segment_gauss(along[i], hh[i], d_vp[i]);
                    acc_r[i] += li.x * air;
                    acc_g[i] += li.y * air;
                    acc_b[i] += li.z * air;
                }
            }
        }
    }
}

/// Background pixels: the airlight to infinity (eq. 3.17) of every light
/// along unit directions (`dx`, `dy`, `dz`), added to (`r`, `g`, `b`).
#[allow(clippy::too_many_arguments)]
pub fn shade_background(
    model: &FogModel,
    lights: &[PreparedLight],
    dx: &[f32],
    dy: &[f32],
    dz: &[f32],
    r: &mut [f32],
    g: &mut [f32],
    b: &mut [f32],
) {
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if simd_ok(model) {
        let ctx = model.simd_ctx();
        // SAFETY: AVX2 and FMA are present and table sides are checked.
        done = unsafe { crate::simd::background(&ctx, lights, dx, dy, dz, r, g, b) };
    }
    let end = dx
        .len()
        .min(dy.len())
        .min(dz.len())
        .min(r.len())
        .min(g.len())
        .min(b.len());
    let done = done.min(end);
    background(
        model,
        lights,
        &dx[done..end],
        &dy[done..end],
        &dz[done..end],
        &mut r[done..end],
        &mut g[done..end],
        &mut b[done..end],
    );
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn background(
    model: &FogModel,
    lights: &[PreparedLight],
    dx: &[f32],
    dy: &[f32],
    dz: &[f32],
    r: &mut [f32],
    g: &mut [f32],
    b: &mut [f32],
) {
    let m = dx
        .len()
        .min(dy.len())
        .min(dz.len())
        .min(r.len())
        .min(g.len())
        .min(b.len());
    let (dx, dy, dz) = (&dx[..m], &dy[..m], &dz[..m]);
    let (r, g, b) = (&mut r[..m], &mut g[..m], &mut b[..m]);
    for light in lights {
        let li = light.intensity;
        for i in 0..m {
            let a = model.air_inf(light, Vec3::new(dx[i], dy[i], dz[i]));
            r[i] += li.x * a;
            g[i] += li.y * a;
            b[i] += li.z * a;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Phase, PointLight};
    use crate::table::FogTables;
    use relight_render::sampling::Rng;

    /// The batch kernels (AVX2 where the CPU has it) agree with the scalar
    /// per-pixel model, including pixels whose airlight tails cancel.
    #[test]
    fn batch_kernels_match_scalar_model() {
        let tables = FogTables::build_with(16, 2, &[20]).unwrap();
        let eye = Vec3::new(0.0, 1.5, 6.0);
        let lights = [
            PointLight::new(Vec3::new(-3.0, 2.0, -2.0), Vec3::new(20.0, 15.0, 10.0)),
            PointLight::new(Vec3::new(2.0, 3.0, -9.0), Vec3::splat(25.0)),
        ];
        for (phase, interp) in [
            (Phase::isotropic(), Interp::Bilinear),
            (Phase::rayleigh(), Interp::Nearest),
        ] {
            let model = FogModel::new(&tables, 0.08, &phase, interp).unwrap();
            let pl = model.prepare_lights(eye, &lights).unwrap();
            let mut rng = Rng::new(5, 1);
            let mut batch = PixelBatch::default();
            let mut pts = Vec::new();
            for i in 0..203 {
                // Some points close to the eye (short segments: cancellation).
                let r = if i % 3 == 0 { 0.3 } else { 12.0 };
                let p = eye
                    + Vec3::new(
                        r * (rng.next_f32() - 0.5),
                        r * (rng.next_f32() - 0.5),
                        -r * rng.next_f32() - 0.05,
                    );
                let n = Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5).normalize();
                batch.push(eye, p, n, model.beta);
                pts.push((p, n));
            }
            // The deferred path (push_point + prepare, AVX2 where present)
            // gives the same columns as the immediate one.
            let mut deferred = PixelBatch::default();
            for &(p, n) in &pts {
                deferred.push_point(p, n);
            }
            deferred.prepare(eye, model.beta, 0);
            for (a, b) in [
                (&batch.nx, &deferred.nx),
                (&batch.dz, &deferred.dz),
                (&batch.ry, &deferred.ry),
                (&batch.d_vp, &deferred.d_vp),
                (&batch.e_vp, &deferred.e_vp),
            ] {
                for (x, y) in a.iter().zip(b) {
                    assert!((x - y).abs() <= 1e-5 * x.abs().max(1.0), "{x} vs {y}");
                }
            }
            let mat = FogMaterial::phong(Vec3::new(0.6, 0.5, 0.4), Vec3::splat(0.3), 20);
            let g = tables.g_table(20);
            let mc = MaterialConst::new(&model, &mat, g);
            let len = batch.len();
            shade_surface_run(&model, &pl, &mc, &mut batch, 0..len);
            for (i, &(p, n)) in pts.iter().enumerate() {
                let dir = (p - eye).normalize();
                let want = model.shade_pixel(eye, dir, &pl, Some((p, n, &mat, g)));
                let got = batch.radiance(i);
                assert!(
                    (got - want).abs().max_element() <= 1e-4 * want.max_element() + 1e-7,
                    "pixel {i}: batch {got} vs scalar {want}"
                );
            }
            // Background.
            let dirs: Vec<Vec3> = (0..37)
                .map(|_| Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, -1.0).normalize())
                .collect();
            let dx: Vec<f32> = dirs.iter().map(|d| d.x).collect();
            let dy: Vec<f32> = dirs.iter().map(|d| d.y).collect();
            let dz: Vec<f32> = dirs.iter().map(|d| d.z).collect();
            let (mut r, mut gg, mut b) = (vec![0.0; 37], vec![0.0; 37], vec![0.0; 37]);
            shade_background(&model, &pl, &dx, &dy, &dz, &mut r, &mut gg, &mut b);
            for (i, &d) in dirs.iter().enumerate() {
                let want = model.shade_pixel(eye, d, &pl, None);
                let got = Vec3::new(r[i], gg[i], b[i]);
                assert!(
                    (got - want).abs().max_element() <= 1e-4 * want.max_element() + 1e-9,
                    "background {i}: batch {got} vs scalar {want}"
                );
            }
        }
    }

    /// A surface that reflects nothing (the fog ball's edge behind empty
    /// pixels) takes the airlight-only AVX2 kernel: the same sums as the
    /// full kernel bit for bit (its surface terms are finite products with
    /// zero), and the scalar model's airlight within the kernels' tolerance.
    #[test]
    fn black_surface_kernel_equals_the_full_kernel() {
        let tables = FogTables::build_with(16, 2, &[20]).unwrap();
        let eye = Vec3::new(0.0, 1.5, 6.0);
        let lights = [
            PointLight::new(Vec3::new(-3.0, 2.0, -2.0), Vec3::new(20.0, 15.0, 10.0)),
            PointLight::new(Vec3::new(2.0, 3.0, -9.0), Vec3::splat(25.0)),
        ];
        let mut rng = Rng::new(9, 2);
        for (phase, interp) in [
            (Phase::isotropic(), Interp::Bilinear),
            (Phase::rayleigh(), Interp::Nearest),
        ] {
            let model = FogModel::new(&tables, 0.08, &phase, interp).unwrap();
            let pl = model.prepare_lights(eye, &lights).unwrap();
            let black = MaterialConst {
                kd: Vec3::ZERO,
                ks: Vec3::ZERO,
                n: 1.0,
                g: model.stand_in_table(),
            };
            let mut batch = PixelBatch::default();
            let mut pts = Vec::new();
            for i in 0..101 {
                let r = if i % 4 == 0 { 0.4 } else { 15.0 };
                let p = eye
                    + Vec3::new(
                        r * (rng.next_f32() - 0.5),
                        r * (rng.next_f32() - 0.5),
                        -r * rng.next_f32() - 0.05,
                    );
                let n = -(p - eye).normalize();
                batch.push(eye, p, n, model.beta);
                pts.push((p, n));
            }
            let len = batch.len();
            #[cfg(target_arch = "x86_64")]
            if simd_ok(&model) {
                let ctx = model.simd_ctx();
                let mut full = batch.clone();
                // SAFETY: AVX2 and FMA are present (simd_ok), tables are small.
                let (a, b) = unsafe {
                    if interp == Interp::Nearest {
                        (
                            crate::simd::surface_run_impl::<true, false>(
                                &ctx, &pl, &black, &mut batch, 0, len,
                            ),
                            crate::simd::surface_run_impl::<true, true>(
                                &ctx, &pl, &black, &mut full, 0, len,
                            ),
                        )
                    } else {
                        (
                            crate::simd::surface_run_impl::<false, false>(
                                &ctx, &pl, &black, &mut batch, 0, len,
                            ),
                            crate::simd::surface_run_impl::<false, true>(
                                &ctx, &pl, &black, &mut full, 0, len,
                            ),
                        )
                    }
                };
                assert_eq!(a, b);
                for i in 0..a {
                    assert_eq!(batch.radiance(i), full.radiance(i), "pixel {i}");
                }
                // Reset the accumulators for the public path below.
                batch.prepare(eye, model.beta, 0);
            }
            shade_surface_run(&model, &pl, &black, &mut batch, 0..len);
            let mat = FogMaterial::lambert(Vec3::ZERO);
            for (i, &(p, n)) in pts.iter().enumerate() {
                let dir = (p - eye).normalize();
                let want = model.shade_pixel(eye, dir, &pl, Some((p, n, &mat, None)));
                let got = batch.radiance(i);
                assert!(
                    (got - want).abs().max_element() <= 1e-4 * want.max_element() + 1e-7,
                    "pixel {i}: batch {got} vs scalar {want}"
                );
            }
        }
    }

    /// Edge cases through the batch kernels: β = 0, a surface point on the
    /// light, points on the line through eye and light, a light at the eye
    /// — finite, non-negative radiance everywhere.
    #[test]
    fn batch_kernels_are_finite_at_edges() {
        let tables = FogTables::build_with(8, 0, &[20]).unwrap();
        let phase = Phase::isotropic();
        let eye = Vec3::new(0.0, 1.0, 5.0);
        let lpos = Vec3::new(0.0, 1.0, -5.0);
        let lights = [
            PointLight::new(lpos, Vec3::splat(10.0)),
            PointLight::new(eye, Vec3::splat(3.0)),
        ];
        for beta in [0.0f32, 1e-6, 0.3, 50.0] {
            for interp in [Interp::Bilinear, Interp::Nearest] {
                let model = FogModel::new(&tables, beta, &phase, interp).unwrap();
                let pl = model.prepare_lights(eye, &lights).unwrap();
                let mut batch = PixelBatch::default();
                let pts = [
                    lpos,
                    lpos + Vec3::new(0.0, 0.0, 1e-7),
                    eye + (lpos - eye) * 0.5,
                    eye + (lpos - eye) * 2.0,
                    eye + Vec3::new(0.0, 0.0, -1e-6),
                    Vec3::new(1e4, -3.0, -1e4),
                ];
                for _ in 0..3 {
                    for &p in &pts {
                        batch.push(eye, p, Vec3::Y, beta);
                        batch.push(eye, p, Vec3::ZERO, beta);
                    }
                }
                let mat = FogMaterial::phong(Vec3::splat(0.5), Vec3::splat(0.5), 20);
                let mc = MaterialConst::new(&model, &mat, tables.g_table(20));
                let len = batch.len();
                shade_surface_run(&model, &pl, &mc, &mut batch, 0..len);
                for i in 0..len {
                    let c = batch.radiance(i);
                    assert!(
                        c.is_finite() && c.min_element() >= 0.0,
                        "β={beta} pixel {i}: {c}"
                    );
                }
                let d: Vec<f32> = vec![0.0; 9];
                let dz: Vec<f32> = vec![-1.0; 9];
                let (mut r, mut g, mut b) = (vec![0.0; 9], vec![0.0; 9], vec![0.0; 9]);
                shade_background(&model, &pl, &d, &d, &dz, &mut r, &mut g, &mut b);
                assert!(
                    r.iter()
                        .chain(&g)
                        .chain(&b)
                        .all(|v| v.is_finite() && *v >= 0.0)
                );
            }
        }
    }
}
