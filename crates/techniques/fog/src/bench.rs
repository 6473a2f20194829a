//! `relight bench fog`: throughput of the complete model and frame time of
//! the rasterized fog renderer.
//!
//! * `evals_per_s`: pixel × light evaluations of the complete model
//!   (eq. 3.29, surface pixels: airlight + Lambert + Phong) per second over
//!   all cores (rayon), on synthetic G-buffer data (SoA arrays of positions
//!   and normals in a 20-unit box, 4 lights).
//! * `frame_ms`: [`crate::render_fog`] at 1280×720 with 4 lights (median of
//!   repeats), on the built-in bench scene (floor + 9 spheres, ≈ 80 K
//!   triangles) unless the caller passes its own objects to
//!   [`bench_fog_scene`].
//! * `table_build_ms`: [`FogTables::build_for`] the scene's materials at the
//!   default size 64.

use crate::model::{FogMaterial, FogModel, Phase, PointLight};
use crate::render::{FogObject, FogSettings, floor_grid, render_fog_into};
use crate::shade::{MaterialConst, PixelBatch, shade_surface_run};
use crate::table::{FogTables, Interp};
use glam::Vec3;
use rayon::prelude::*;
use relight_geom::Mesh;
use relight_render::raster::Rasterizer;
use relight_render::sampling::Rng;
use relight_render::{Camera, Image};
use std::time::Instant;

/// One benchmark result.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BenchRow {
    /// `bilinear` or `nearest`.
    pub interp: String,
    pub evals_per_s: f64,
    pub frame_ms: f64,
    pub fps: f64,
    pub width: usize,
    pub height: usize,
    pub lights: usize,
    pub triangles: usize,
    pub table_size: usize,
    pub table_build_ms: f64,
    pub threads: usize,
}

/// The four bench lights (street-lamp like, intensity 30).
#[must_use]
pub fn bench_lights() -> Vec<PointLight> {
    vec![
        PointLight::new(Vec3::new(-4.0, 3.0, -2.0), Vec3::new(30.0, 27.0, 22.0)),
        PointLight::new(Vec3::new(4.0, 3.5, -6.0), Vec3::new(22.0, 27.0, 30.0)),
        PointLight::new(Vec3::new(0.0, 2.5, -12.0), Vec3::splat(30.0)),
        PointLight::new(Vec3::new(-7.0, 4.0, -16.0), Vec3::new(30.0, 20.0, 12.0)),
    ]
}

/// The bench scene: a floor and nine spheres (≈ 80 K triangles).
#[must_use]
pub fn bench_meshes() -> Vec<Mesh> {
    let mut v = vec![floor_grid(0.0, 30.0, 40)];
    for i in 0..9 {
        let x = -6.0 + 6.0 * (i % 3) as f32;
        let z = -2.0 - 6.0 * (i / 3) as f32;
        v.push(relight_geom::shapes::uv_sphere_at(
            Vec3::new(x, 1.0, z),
            1.0,
            128,
            64,
        ));
    }
    v
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Pixels per task of [`bench_evals`].
const CHUNK: usize = 1024;

/// Model throughput (evaluations per second) for `n` synthetic pixels:
/// n × lights complete-model evaluations (eq. 3.29, surface pixels with
/// airlight, Lambert and Phong terms) per second of wall time.
#[must_use]
pub fn bench_evals(tables: &FogTables, interp: Interp, n: usize, repeats: usize) -> f64 {
    let mut rng = Rng::new(42, 0);
    let eye = Vec3::new(0.0, 1.7, 8.0);
    let pos: Vec<Vec3> = (0..n)
        .map(|_| {
            Vec3::new(
                rng.next_f32() * 20.0 - 10.0,
                rng.next_f32() * 2.0,
                -rng.next_f32() * 20.0,
            )
        })
        .collect();
    let nrm: Vec<Vec3> = (0..n)
        .map(|_| Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5).normalize())
        .collect();
    let lights = bench_lights();
    let phase = Phase::isotropic();
    let Ok(model) = FogModel::new(tables, 0.04, &phase, interp) else {
        return 0.0;
    };
    let Ok(pl) = model.prepare_lights(eye, &lights) else {
        return 0.0;
    };
    let mat = FogMaterial::phong(Vec3::splat(0.6), Vec3::splat(0.3), 20);
    let mc = MaterialConst::new(&model, &mat, tables.g_table(20));
    let mut out = vec![Vec3::ZERO; n];
    let mut times = Vec::new();
    for _ in 0..repeats.max(1) {
        let t0 = Instant::now();
        // Per chunk: the per-pixel setup (view direction, reflection,
        // e^{−T_vp}) into the SoA batch, then every light (complete model).
        out.par_chunks_mut(CHUNK)
            .zip(pos.par_chunks(CHUNK))
            .zip(nrm.par_chunks(CHUNK))
            .for_each_init(PixelBatch::default, |batch, ((o, p), nn)| {
                batch.clear();
                for (&p, &nv) in p.iter().zip(nn) {
                    batch.push_point(p, nv);
                }
                batch.prepare(eye, model.beta, 0);
                let len = batch.len();
                shade_surface_run(&model, &pl, &mc, batch, 0..len);
                for (i, o) in o.iter_mut().enumerate() {
                    *o = batch.radiance(i);
                }
            });
        times.push(t0.elapsed().as_secs_f64());
    }
    std::hint::black_box(&out);
    (n * lights.len()) as f64 / median(times)
}

/// [`bench_fog_scene`] on the built-in bench scene.
#[must_use]
pub fn bench_fog(quick: bool) -> Vec<BenchRow> {
    let meshes = bench_meshes();
    let objects: Vec<FogObject> = meshes
        .iter()
        .enumerate()
        .map(|(i, m)| FogObject {
            mesh: m,
            material: if i == 0 {
                FogMaterial::lambert(Vec3::splat(0.5))
            } else {
                FogMaterial::phong(Vec3::splat(0.5), Vec3::splat(0.4), 20)
            },
        })
        .collect();
    let camera = Camera {
        eye: Vec3::new(0.0, 2.0, 8.0),
        target: Vec3::new(0.0, 1.0, -8.0),
        up: Vec3::Y,
        vfov_deg: 50.0,
        width: 1280,
        height: 720,
        image_offset: glam::Vec2::ZERO,
    };
    bench_fog_scene(quick, &objects, &camera, &bench_lights())
}

/// Benchmarks on the caller's objects, camera and lights (the CLI passes the
/// default scene as well as the bench scene).
#[must_use]
pub fn bench_fog_scene(
    quick: bool,
    objects: &[FogObject],
    camera: &Camera,
    lights: &[PointLight],
) -> Vec<BenchRow> {
    let t0 = Instant::now();
    let Ok(tables) = FogTables::build_for(64, objects.iter().map(|o| &o.material)) else {
        return Vec::new();
    };
    let table_build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let (n, reps, frames) = if quick {
        (200_000, 3, 3)
    } else {
        (2_000_000, 5, 9)
    };
    let triangles = objects.iter().map(|o| o.mesh.indices.len()).sum();
    let mut rows = Vec::new();
    for interp in [Interp::Bilinear, Interp::Nearest] {
        let evals = bench_evals(&tables, interp, n, reps);
        let mut settings = FogSettings::new(&tables, 0.04);
        settings.interp = interp;
        let mut r = Rasterizer::new();
        let mut img = Image::new(camera.width, camera.height);
        let mut times = Vec::new();
        for f in 0..frames + 1 {
            // Lights are validated once (the first, untimed frame).
            settings.check_lights_inside = f == 0;
            let t = Instant::now();
            if render_fog_into(&mut r, objects, camera, lights, &settings, &mut img).is_err() {
                break;
            }
            if f > 0 {
                times.push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
        let frame_ms = if times.is_empty() {
            f64::NAN
        } else {
            median(times)
        };
        rows.push(BenchRow {
            interp: match interp {
                Interp::Bilinear => "bilinear".into(),
                Interp::Nearest => "nearest".into(),
            },
            evals_per_s: evals,
            frame_ms,
            fps: 1e3 / frame_ms,
            width: camera.width,
            height: camera.height,
            lights: lights.len(),
            triangles,
            table_size: 64,
            table_build_ms,
            threads: rayon::current_num_threads(),
        });
    }
    rows
}
