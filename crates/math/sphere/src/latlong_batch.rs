//! Many bilinear lookups of a lat-long environment at once
//! ([`EnvMap::eval_many`]): the lookups of a wavelet lighting change
//! (≈ 150 K per change on the default scene) and of a frame's background.
//!
//! # What is computed
//! `out[i] = env.eval(env_from_world · dirs[i])`, bit for bit: the same
//! operations in the same order as [`EnvMap::eval`] and the f32 lat-long
//! footprint of [`Param::bilinear`] (two `atan2`s by the polynomial of
//! [`crate::atan`], the seam and pole rules), written lane-wise over blocks
//! of `LANES` directions without branches, so that the compiler turns the
//! footprint into vector code. The texel reads stay scalar (four RGB texels
//! per lookup).
//!
//! # Paths
//! With AVX2 and FMA (detected at run time) the block is compiled for them;
//! otherwise for baseline x86-64 (SSE2, four lanes) or the target's own
//! ISA. FMA changes nothing here: the arithmetic has no `mul_add`, and Rust
//! never contracts a multiply and an add. Both paths are tested against
//! [`EnvMap::eval`].

use crate::atan::atan2_f32;
use crate::param::latlong_texel;
use crate::{EnvMap, Param};
use glam::{Mat3, Vec3};
use std::f32::consts::{PI, TAU};

/// Directions per block.
pub(crate) const LANES: usize = 16;

type Lanes = [f32; LANES];

/// `atan2(y, x)` per lane ([`atan2_f32`], whose branches are selects: a
/// loop of it alone vectorises).
#[inline(always)]
fn atan2_lanes(y: &Lanes, x: &Lanes) -> Lanes {
    std::array::from_fn(|l| atan2_f32(y[l], x[l]))
}

/// One block: `out[l] = env.eval(m · d_l)` for the lat-long map `texels`
/// (`width × height`), `d` in structure-of-arrays form.
#[inline(always)]
fn block(texels: &[Vec3], width: usize, height: usize, m: &Mat3, d: [&Lanes; 3], out: &mut [Vec3]) {
    let (w, h) = (width as i32, height as i32);
    // The rotation, as `Mat3 * Vec3` computes it (columns times components).
    let row = |k: usize| -> Lanes {
        let (cx, cy, cz) = (m.x_axis[k], m.y_axis[k], m.z_axis[k]);
        std::array::from_fn(|l| cx * d[0][l] + cy * d[1][l] + cz * d[2][l])
    };
    let (x, y, z) = (row(0), row(1), row(2));
    let rxz: Lanes = std::array::from_fn(|l| (x[l] * x[l] + z[l] * z[l]).sqrt());
    let theta = atan2_lanes(&rxz, &y);
    let neg_x: Lanes = std::array::from_fn(|l| -x[l]);
    let phi = atan2_lanes(&neg_x, &z);
    let mut c0 = [0i32; LANES];
    let mut r0 = [0i32; LANES];
    let mut fx: Lanes = [0.0; LANES];
    let mut fy: Lanes = [0.0; LANES];
    for l in 0..LANES {
        let phi = if phi[l] < 0.0 { phi[l] + TAU } else { phi[l] };
        let u = phi / TAU;
        let u = if u >= 1.0 { 0.0 } else { u };
        let v = theta[l] / PI;
        let xx = u * w as f32 - 0.5;
        let yy = v * h as f32 - 0.5;
        // Floor by truncation, as `Param::bilinear` (x, y ≥ −0.5).
        let floor = |t: f32| {
            let i = t as i32;
            if i as f32 > t { i - 1 } else { i }
        };
        c0[l] = floor(xx);
        r0[l] = floor(yy);
        fx[l] = xx - c0[l] as f32;
        fy[l] = yy - r0[l] as f32;
    }
    let texel = |c: i32, r: i32| latlong_texel(w, h, c, r) as usize;
    for (l, o) in out.iter_mut().enumerate() {
        let (c, r) = (c0[l], r0[l]);
        let (a, b) = (fx[l], fy[l]);
        let ts = [
            texel(c, r),
            texel(c + 1, r),
            texel(c, r + 1),
            texel(c + 1, r + 1),
        ];
        let ws = [(1.0 - a) * (1.0 - b), a * (1.0 - b), (1.0 - a) * b, a * b];
        // `EnvMap::eval`'s sum: from zero, in texel order.
        let mut acc = Vec3::ZERO;
        for k in 0..4 {
            acc += texels[ts[k]] * ws[k];
        }
        *o = acc;
    }
}

/// All blocks of `dirs` (a short last block padded with +z).
#[inline(always)]
fn lookups(
    texels: &[Vec3],
    width: usize,
    height: usize,
    m: &Mat3,
    dirs: &[Vec3],
    out: &mut [Vec3],
) {
    for (ds, os) in dirs.chunks(LANES).zip(out.chunks_mut(LANES)) {
        let mut soa = [[0.0f32; LANES]; 3];
        soa[2] = [1.0; LANES];
        for (l, d) in ds.iter().enumerate() {
            soa[0][l] = d.x;
            soa[1][l] = d.y;
            soa[2][l] = d.z;
        }
        let mut full = [Vec3::ZERO; LANES];
        block(
            texels,
            width,
            height,
            m,
            [&soa[0], &soa[1], &soa[2]],
            &mut full,
        );
        os.copy_from_slice(&full[..os.len()]);
    }
}

/// [`lookups`] compiled for AVX2 and FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn lookups_avx2(
    texels: &[Vec3],
    width: usize,
    height: usize,
    m: &Mat3,
    dirs: &[Vec3],
    out: &mut [Vec3],
) {
    lookups(texels, width, height, m, dirs, out);
}

/// The lat-long lookups of [`EnvMap::eval_many`]; `portable` forces the
/// baseline path (for tests).
pub(crate) fn latlong_many(
    env: &EnvMap,
    width: usize,
    height: usize,
    env_from_world: Mat3,
    dirs: &[Vec3],
    out: &mut [Vec3],
    portable: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if !portable && relight_isa::avx2() {
        // SAFETY: AVX2 and FMA were detected just above.
        unsafe { lookups_avx2(&env.texels, width, height, &env_from_world, dirs, out) };
        return;
    }
    let _ = portable;
    lookups(&env.texels, width, height, &env_from_world, dirs, out);
}

impl EnvMap {
    /// `out[i] = self.eval(env_from_world · dirs[i])` for every direction,
    /// bit for bit; a lat-long map takes the block path of this module
    /// (about `LANES` lookups at a time), other parameterizations one
    /// [`EnvMap::eval`] each. `out` must be as long as `dirs` (extra entries
    /// of the longer one are left alone).
    pub fn eval_many(&self, env_from_world: Mat3, dirs: &[Vec3], out: &mut [Vec3]) {
        let n = dirs.len().min(out.len());
        let (dirs, out) = (&dirs[..n], &mut out[..n]);
        match self.param {
            Param::LatLong { width, height } => {
                latlong_many(self, width, height, env_from_world, dirs, out, false);
            }
            _ => {
                for (o, &d) in out.iter_mut().zip(dirs) {
                    *o = self.eval(env_from_world * d);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A 2:1 map with distinct texels, and directions over the sphere with
    /// the poles, the seam and the axes among them.
    fn case(width: usize) -> (EnvMap, Vec<Vec3>) {
        let height = width / 2;
        let param = Param::LatLong { width, height };
        let texels = (0..width * height)
            .map(|i| {
                let f = i as f32;
                Vec3::new(1.0 + f.sin(), 0.5 + 0.25 * (0.3 * f).cos(), f * 1e-3)
            })
            .collect();
        let env = EnvMap { param, texels };
        let mut dirs = vec![
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
            Vec3::new(0.0, 1.0, -0.0),
            Vec3::new(-0.0, -1.0, -0.0),
            Vec3::new(1e-7, 1.0, -1e-7).normalize(),
        ];
        let n = 2001;
        for i in 0..n {
            // A Fibonacci spiral: every latitude and longitude band.
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).sqrt();
            let a = i as f32 * 2.399_963;
            dirs.push(Vec3::new(r * a.cos(), z, r * a.sin()));
        }
        (env, dirs)
    }

    fn check(width: usize, m: Mat3, portable: bool) {
        let (env, dirs) = case(width);
        let mut got = vec![Vec3::splat(f32::NAN); dirs.len()];
        let Param::LatLong { width, height } = env.param else {
            unreachable!()
        };
        latlong_many(&env, width, height, m, &dirs, &mut got, portable);
        for (i, (&d, g)) in dirs.iter().zip(&got).enumerate() {
            let want = env.eval(m * d);
            assert_eq!(
                g.to_array().map(f32::to_bits),
                want.to_array().map(f32::to_bits),
                "direction {i} {d}: {g} vs {want}"
            );
        }
    }

    #[test]
    fn blocks_match_eval_bit_for_bit() {
        let turn = Mat3::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.2);
        for portable in [true, false] {
            for width in [64, 34, 7] {
                check(width, Mat3::IDENTITY, portable);
                check(width, turn, portable);
            }
        }
        if std::env::var_os("CI").is_some() && cfg!(target_arch = "x86_64") {
            assert!(
                relight_isa::avx2(),
                "CI machines have AVX2: the vector path ran"
            );
        }
    }

    #[test]
    fn eval_many_covers_every_parameterization_and_length() {
        let (env, dirs) = case(32);
        let oct = env.resample(Param::Octahedral { n: 16 }, 1);
        let m = Mat3::from_rotation_y(0.4);
        for map in [&env, &oct] {
            for n in [0, 1, 15, 16, 17, dirs.len()] {
                let mut out = vec![Vec3::splat(-1.0); n + 1];
                map.eval_many(m, &dirs[..n], &mut out[..n]);
                for (i, (o, &d)) in out.iter().zip(&dirs[..n]).enumerate() {
                    // `m · d`, not `d`: even the identity turns −0 into +0,
                    // and the seam reads the sign of zero.
                    let want = map.eval(m * d);
                    assert_eq!(*o, want, "{:?} n {n} direction {i} {d}", map.param);
                }
                assert_eq!(out[n], Vec3::splat(-1.0), "wrote past the end");
            }
        }
    }
}
