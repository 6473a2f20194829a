//! `relight bench raster`: the rasterizer alone on a generated torus.

use super::{
    Background, DrawCall, Fragment, MAX_IMAGE_SIDE, RasterError, RasterOptions, Rasterizer,
};
use crate::{Camera, Image};
use glam::Vec3;

/// One row of [`bench_raster`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct RasterBenchRow {
    /// `gbuffer` (pass 1 only), `gouraud` (pass 1 + per-vertex colour) or
    /// `per_pixel` (pass 1 + a per-pixel shader reading normal, position
    /// and two attributes).
    pub mode: String,
    pub triangles: usize,
    pub width: usize,
    pub height: usize,
    /// Pixels covered by the mesh.
    pub covered_pixels: usize,
    /// Rayon worker threads.
    pub threads: usize,
    /// Median over the repeats (after one warm-up frame).
    pub ms_per_frame: f64,
    /// Fastest repeat.
    pub ms_min: f64,
    /// Million submitted triangles per second at the median.
    pub mtri_per_s: f64,
}

/// A torus (major radius 1, minor 0.4, axis +Y) tessellated into `nu × nv`
/// quads (2·nu·nv triangles, counter-clockwise seen from outside), with
/// per-vertex (u, v) texture coordinates in \[0, 1\].
#[must_use]
pub fn torus_grid(nu: usize, nv: usize) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<f32>) {
    let (nu, nv) = (nu.max(3), nv.max(3));
    let mut positions = Vec::with_capacity(nu * nv);
    let mut uv = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        let a = std::f32::consts::TAU * i as f32 / nu as f32;
        for j in 0..nv {
            let b = std::f32::consts::TAU * j as f32 / nv as f32;
            let r = 1.0 + 0.4 * b.cos();
            positions.push(Vec3::new(r * a.cos(), 0.4 * b.sin(), -r * a.sin()));
            uv.extend_from_slice(&[i as f32 / nu as f32, j as f32 / nv as f32]);
        }
    }
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    let idx = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    (positions, triangles, uv)
}

/// Benchmark of the rasterizer: a torus of about `triangles_target`
/// triangles (generated here) filling a `width × height` view, back faces
/// culled, drawn `repeats` times per mode (see [`RasterBenchRow::mode`]).
#[must_use]
pub fn bench_raster(
    triangles_target: usize,
    width: usize,
    height: usize,
    repeats: usize,
) -> Vec<RasterBenchRow> {
    let quads = (triangles_target / 2).max(9);
    let nv = ((quads as f64 / 2.5).sqrt().round() as usize).max(3);
    let nu = quads.div_ceil(nv).max(3);
    let (positions, triangles, uv) = torus_grid(nu, nv);
    let colors: Vec<Vec3> = positions
        .iter()
        .map(|p| *p * 0.5 + Vec3::splat(0.5))
        .collect();
    let draws = [DrawCall::new(&positions, &triangles).with_attributes(2, &uv)];
    let camera = Camera {
        eye: Vec3::new(0.0, 1.6, 2.2),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
        width: width.clamp(1, MAX_IMAGE_SIDE),
        height: height.clamp(1, MAX_IMAGE_SIDE),
        image_offset: glam::Vec2::ZERO,
    };
    let options = RasterOptions::default()
        .cull_back()
        .fit_depth(&camera, &draws);
    let mut raster = Rasterizer::new();
    let mut image = Image::new(camera.width, camera.height);
    let bg = Background::Color(Vec3::splat(0.1));
    let color_slices: [&[Vec3]; 1] = [&colors];
    let shader = |f: &Fragment| {
        f.normal.abs() * (0.5 + 0.5 * f.attributes[0]) + Vec3::splat(f.attributes[1] * 0.1)
    };
    let mut rows = Vec::new();
    for mode in ["gbuffer", "gouraud", "per_pixel"] {
        let frame = |raster: &mut Rasterizer, image: &mut Image| -> Result<(), RasterError> {
            match mode {
                "gbuffer" => raster.rasterize(&camera, &draws, &options).map(|_| ()),
                "gouraud" => raster
                    .render_gouraud(&camera, &draws, &color_slices, bg, &options, image)
                    .map(|_| ()),
                _ => raster
                    .render(&camera, &draws, shader, bg, &options, image)
                    .map(|_| ()),
            }
        };
        if frame(&mut raster, &mut image).is_err() {
            continue;
        }
        let mut times = Vec::with_capacity(repeats.max(1));
        for _ in 0..repeats.max(1) {
            let t = std::time::Instant::now();
            let _ = frame(&mut raster, &mut image);
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        let ms = times[times.len() / 2];
        rows.push(RasterBenchRow {
            mode: mode.to_string(),
            triangles: triangles.len(),
            width: camera.width,
            height: camera.height,
            covered_pixels: raster.gbuffer().covered_pixels(),
            threads: rayon::current_num_threads(),
            ms_per_frame: ms,
            ms_min: times[0],
            mtri_per_s: triangles.len() as f64 / (ms * 1e3),
        });
    }
    rows
}
