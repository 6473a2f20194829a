//! The per-vertex environment part (`relight_fog::env_vertex`) against the
//! per-pixel computation it replaces: one vertex's shade equals the
//! per-pixel formula (lighting rotated into an arbitrary tangent frame,
//! transfer turned by the view's azimuth, dot product), and a whole fog
//! frame shaded per vertex stays close to the per-pixel frame.

use glam::{Mat3, Vec3};
use relight_brdf::BrdfSpec;
use relight_fog::env_vertex::{
    BackgroundScratch, EnvLighting, MIN_COS_VIEW, Scratch, TRANSFER_RUN, TransferRun, VertexShader,
};
use relight_fog::render::floor_grid;
use relight_fog::{EnvShading, FogOptions, FogRelighter};
use relight_render::method::{FrameRequest, Relighter};
use relight_render::{Camera, Medium, NoProgress, Object, Scene};
use relight_sh::project::{ShRgb, Window};
use relight_sh::rotation::{IvanicRuedenberg, Rot3, ShRotation, rotate_z};
use relight_shlight::{ShRenderer, ShRotationMethod};
use relight_sphere::{EnvMap, Frame, Param};
use std::sync::Arc;

/// The per-pixel formula of `relight_shlight::shade` without a normal map:
/// `L_v = R(F_vᵀ) L` in the frame of `n` with tangent `t`, then
/// `⟨L_v, R_z(φ_o) H B(θ_o)⟩` per channel.
fn per_pixel(
    table: &relight_shlight::BrdfShTable,
    window: &[f64],
    order: usize,
    light: &ShRgb,
    n: Vec3,
    t: Vec3,
    wo: Vec3,
) -> Vec3 {
    let k = order * order;
    let f = Frame::from_normal_tangent(n, t);
    let r = Rot3::new_unchecked([f.x.to_array(), f.y.to_array(), f.z.to_array()]);
    let mut rot = ShRotation::<f32>::identity(order).unwrap();
    IvanicRuedenberg::<f32>::new(order)
        .unwrap()
        .build(&r, &mut rot);
    let local = light.rotated(&rot);
    let w = f.to_local(wo);
    let mut b = vec![0.0f32; 3 * k];
    table.lookup(w.z, order, &mut b);
    let rxy = (w.x * w.x + w.y * w.y).sqrt();
    let (c, s) = (w.x / rxy, w.y / rxy);
    let mut out = [0.0f32; 3];
    for (ch, o) in out.iter_mut().enumerate() {
        let mut bc: Vec<f32> = (0..k)
            .map(|i| b[ch * k + i] * window[relight_sh::sh_lm(i).0] as f32)
            .collect();
        let src = bc.clone();
        rotate_z(order, c, s, &src, &mut bc);
        *o = local.channels[ch][..k]
            .iter()
            .zip(&bc)
            .map(|(a, b)| a * b)
            .sum();
    }
    Vec3::from_array(out)
}

#[test]
fn vertex_shade_equals_the_per_pixel_formula() {
    let order = 5;
    let k = order * order;
    let renderer = ShRenderer::new(order, ShRotationMethod::Exact).unwrap();
    let light = ShRgb {
        order,
        channels: std::array::from_fn(|c| {
            (0..k)
                .map(|i| (((i * 7 + 3 * c + 1) % 11) as f32 - 4.0) * 0.1)
                .collect()
        }),
        window: Window::None,
    };
    let lighting = EnvLighting::new(&light, Mat3::IDENTITY, None).unwrap();
    for spec in [
        "phong:40@0.9,0.25,0.2",
        "ggx:0.2@1,0.78,0.34",
        "lambert:0.8",
    ] {
        let brdf = spec.parse::<BrdfSpec>().unwrap().build();
        let table = renderer.table(&brdf, order, 0, &NoProgress).unwrap();
        let window = renderer.window_of(&table, order).unwrap();
        let shader = VertexShader::new(
            order,
            std::slice::from_ref(&table),
            std::slice::from_ref(&window),
        )
        .unwrap();
        let mut s = Scratch::new();
        let mut worst = 0.0f32;
        for j in 0..60 {
            let a = j as f32 * 0.61;
            let n = Vec3::new(
                a.sin() * (1.7 * a).cos(),
                a.cos(),
                a.sin() * (1.7 * a).sin(),
            )
            .normalize();
            // A view above the horizon (cos ≥ 0.1), an arbitrary tangent.
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let th = 0.05 + 1.4 * ((j * 13 % 17) as f32 / 17.0);
            let ph = j as f32 * 2.3;
            let wo = (n * th.cos() + (u * ph.cos() + v * ph.sin()) * th.sin()).normalize();
            let t = (u * (0.7 * a).cos() + v * (0.7 * a).sin()).normalize();
            let want = per_pixel(&table, &window.factors, order, &light, n, t, wo);
            let got = shader.shade(0, &lighting, n, wo, &mut s);
            let scale = want.abs().max_element().max(1e-2);
            worst = worst.max((got - want).abs().max_element() / scale);
        }
        assert!(
            worst < 2e-4,
            "{spec}: per-vertex vs per-pixel formula {worst}"
        );
    }
}

/// `VertexShader::transfer_run` (a batch of sides turned together, lanes
/// across vectors where the CPU has AVX2) gives each side the transfer of
/// `VertexShader::transfer` (one at a time): rank-1 and three-channel
/// tables mixed in one batch, orders 3 and 6 (batched) and 8 (one by one),
/// a full and a partial batch, a stride wider than a side needs.
#[test]
fn batched_transfers_match_one_at_a_time() {
    for order in [3, 6, 8] {
        let renderer = ShRenderer::new(order, ShRotationMethod::Exact).unwrap();
        let (tables, windows): (Vec<_>, Vec<_>) = [
            "phong:30@0.9,0.25,0.2",
            "lambert:0.7",
            "0.5*lambert:0.6+0.5*phong:12@0.9,0.2,0.1",
        ]
        .iter()
        .map(|spec| {
            let brdf = spec.parse::<BrdfSpec>().unwrap().build();
            let table = renderer.table(&brdf, order, 0, &NoProgress).unwrap();
            let window = renderer.window_of(&table, order).unwrap();
            (table, window)
        })
        .unzip();
        assert!(tables[0].mono_colour().is_some() && tables[2].mono_colour().is_none());
        let shader = VertexShader::new(order, &tables, &windows).unwrap();
        let stride = shader.transfer_len() + 5;
        for count in [TRANSFER_RUN, 13] {
            let sides: Vec<(usize, Vec3, Vec3)> = (0..count)
                .map(|j| {
                    let a = j as f32 * 0.83 + order as f32;
                    let n = Vec3::new(
                        a.sin() * (1.3 * a).cos(),
                        a.cos(),
                        a.sin() * (1.3 * a).sin(),
                    )
                    .normalize();
                    let wo = (n + Vec3::new((2.1 * a).cos(), 0.4, (2.1 * a).sin())).normalize();
                    (j % 3, n, wo)
                })
                .collect();
            let mut run = TransferRun::new();
            let mut out = vec![f32::NAN; count * stride];
            shader.transfer_run(&sides, &mut run, &mut out, stride);
            let mut s = Scratch::new();
            let mut one = vec![0.0f32; shader.transfer_len()];
            for (j, &(obj, n, wo)) in sides.iter().enumerate() {
                let ch = shader.transfer(obj, n, wo, &mut s, &mut one);
                let len = ch * order * order;
                let got = &out[j * stride..j * stride + len];
                let scale = one[..len].iter().fold(0.0f32, |m, v| m.max(v.abs()));
                for (g, w) in got.iter().zip(&one[..len]) {
                    assert!(
                        (g - w).abs() <= 2e-5 * scale,
                        "order {order}, side {j} of {count}: {g} vs {w} (scale {scale})"
                    );
                }
            }
        }
    }
}

/// `EnvLighting::add_background` (the environment by `EnvMap::eval_many`,
/// the filtered part of eight directions at
/// a time) adds what `EnvLighting::background` gives each direction alone:
/// orders 3 and 6 (batched) and 8 (one by one), a count that is not a
/// multiple of eight, with and without a filter, a turned environment,
/// with the centre's weights and with a chord's per direction.
#[test]
fn batched_background_matches_one_at_a_time() {
    let sky = EnvMap::from_fn(
        Param::LatLong {
            width: 32,
            height: 16,
        },
        |d| Vec3::new(1.0 + d.y, 0.5 + 0.3 * d.x, 0.2 + d.z * d.z),
    );
    for order in [3, 6, 8] {
        let k = order * order;
        let light = ShRgb {
            order,
            channels: std::array::from_fn(|c| {
                (0..k)
                    .map(|i| (((i * 5 + 2 * c + 1) % 9) as f32 - 3.0) * 0.2)
                    .collect()
            }),
            window: Window::None,
        };
        let filter = relight_shlight::LightingFilter {
            direct: 0.6,
            bands: (0..order).map(|l| 0.5 / (1.0 + l as f32)).collect(),
        };
        let turn = Mat3::from_rotation_y(0.7);
        for f in [Some(&filter), None] {
            let lighting = EnvLighting::new(&light, turn, f).unwrap();
            let dirs: Vec<Vec3> = (0..29)
                .map(|j| {
                    let a = j as f32 * 0.71;
                    Vec3::new(
                        a.sin() * (1.9 * a).cos(),
                        a.cos(),
                        a.sin() * (1.9 * a).sin(),
                    )
                    .normalize()
                })
                .collect();
            let chords: Vec<[f32; 2]> = (0..dirs.len())
                .map(|j| [0.2 + 0.03 * j as f32, 1.5 - 0.04 * j as f32])
                .collect();
            for weights in [None, Some(&chords[..])] {
                let mut out = vec![Vec3::splat(0.25); dirs.len()];
                let mut scratch = BackgroundScratch::default();
                lighting.add_background(&sky, &dirs, weights, &mut scratch, &mut out);
                for (j, (d, got)) in dirs.iter().zip(&out).enumerate() {
                    let w = weights.map(|w| w[j]);
                    let want = lighting.background(&sky, *d, w) + Vec3::splat(0.25);
                    assert!(
                        (*got - want).abs().max_element()
                            <= 1e-5 * want.abs().max_element().max(1.0),
                        "order {order}, filter {}, weights {w:?}: {got} vs {want}",
                        f.is_some()
                    );
                }
            }
        }
    }
}

/// Below the horizon the transfer is read at the grazing cosine
/// `MIN_COS_VIEW`, at the view's azimuth.
#[test]
fn views_below_the_horizon_read_the_grazing_transfer() {
    let order = 4;
    let renderer = ShRenderer::new(order, ShRotationMethod::Exact).unwrap();
    let brdf = "phong:20@0.8,0.8,0.8".parse::<BrdfSpec>().unwrap().build();
    let table = renderer.table(&brdf, order, 0, &NoProgress).unwrap();
    let window = renderer.window_of(&table, order).unwrap();
    let shader = VertexShader::new(order, &[table], &[window]).unwrap();
    let light = ShRgb {
        order,
        channels: std::array::from_fn(|c| (0..16).map(|i| 0.3 + 0.05 * (i + c) as f32).collect()),
        window: Window::None,
    };
    let lighting = EnvLighting::new(&light, Mat3::IDENTITY, None).unwrap();
    let mut s = Scratch::new();
    let n = Vec3::Y;
    let below = shader.shade(
        0,
        &lighting,
        n,
        Vec3::new(1.0, -0.3, 0.0).normalize(),
        &mut s,
    );
    let c = MIN_COS_VIEW;
    let grazing = Vec3::new((1.0 - c * c).sqrt(), c, 0.0);
    let want = shader.shade(0, &lighting, n, grazing, &mut s);
    assert!(
        (below - want).abs().max_element() < 1e-6,
        "{below} vs {want}"
    );
    assert!(want.max_element() > 0.0);
}

/// A glossy sphere and a diffuse floor in fog under a sky, no point lights: the frame with
/// the environment shaded per vertex is within 2 % (mean) of the per-pixel
/// frame on covered pixels and equal on the sky.
#[test]
fn per_vertex_frame_is_close_to_the_per_pixel_frame() {
    let sky = EnvMap::from_fn(
        Param::LatLong {
            width: 64,
            height: 32,
        },
        |d| {
            Vec3::new(0.4, 0.5, 0.7) * (1.0 + d.y).max(0.0)
                + Vec3::new(2.0, 1.8, 1.5) * d.x.max(0.0).powi(8)
        },
    );
    let sphere = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, 0.6, 0.0), 0.6, 128, 64);
    let floor = floor_grid(0.0, 3.0, 24);
    let camera = Camera {
        eye: Vec3::new(0.0, 1.5, 5.0),
        target: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Y,
        vfov_deg: 40.0,
        width: 96,
        height: 64,
        image_offset: glam::Vec2::ZERO,
    };
    let brdf = |s: &str| s.parse::<BrdfSpec>().unwrap().build();
    let mut s = Scene::new(
        vec![
            Object::new(Arc::new(floor), brdf("lambert:0.6")),
            Object::new(Arc::new(sphere), brdf("phong:30@0.9,0.5,0.3")),
        ],
        sky,
        camera,
    );
    // The environment part alone (the point lights are shaded per pixel
    // by both).
    s.point_lights.clear();
    s.medium = Some(Medium {
        beta: 0.1,
        albedo: 0.8,
        radius: 10.0,
    });
    s.world_from_env = Mat3::from_rotation_y(0.7);
    let frame = |shading: EnvShading| {
        let mut m = FogRelighter::new(FogOptions {
            env_order: 5,
            env_shading: shading,
            ..FogOptions::default()
        })
        .unwrap();
        m.prepare(&s, &NoProgress).unwrap();
        let r = m
            .render(&s, &FrameRequest::new(s.camera), &NoProgress)
            .unwrap();
        (r.image, r.coverage.unwrap().coverage.clone())
    };
    let (vertex, cov) = frame(EnvShading::PerVertex);
    let (pixel, _) = frame(EnvShading::PerPixel);
    let (mut diff, mut sum, mut covered) = (0.0f64, 0.0f64, 0);
    for ((a, b), c) in vertex.pixels.iter().zip(&pixel.pixels).zip(&cov) {
        if *c == 0.0 {
            let e = (*a - *b).abs().max_element() / b.max_element().max(1e-6);
            assert!(e < 1e-5, "sky pixel {a} vs {b}");
        } else if *c == 1.0 {
            diff += f64::from((*a - *b).abs().element_sum());
            sum += f64::from(b.element_sum());
            covered += 1;
        }
    }
    assert!(covered > 1000, "{covered} covered pixels");
    let rel = diff / sum;
    eprintln!("per-vertex vs per-pixel: mean relative {rel:.5} over {covered} pixels");
    assert!(
        rel < 0.02,
        "per-vertex vs per-pixel frame: mean relative {rel}"
    );
    assert!(rel > 0.0, "the two paths are not both exercised");
}
