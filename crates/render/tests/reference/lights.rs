//! Point and area lights against closed forms.

use super::common::*;
use glam::{Mat3, Vec2, Vec3};
use relight_render::sampling::luminance;
use relight_render::{
    AreaLight, LightSampling, NoProgress, Object, PointLight, ReferenceOptions, Scene, Texture,
    render_reference,
};
use std::f64::consts::PI;
use std::sync::Arc;

/// Irradiance at `x` (unit normal `n`) from a uniform Lambertian polygon of
/// unit radiance with vertices `v` (Lambert's edge sum, as in Baum, Rushmeier
/// & Winget 1989): `E = ½ |Σ_i Θ_i n·û_i|`, `Θ_i` the angle subtended by edge
/// i and `û_i` the unit normal of the plane through x and the edge.
pub(super) fn polygon_irradiance(x: Vec3, n: Vec3, v: &[Vec3]) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..v.len() {
        let a = (v[i] - x).as_dvec3().normalize();
        let b = (v[(i + 1) % v.len()] - x).as_dvec3().normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        let u = a.cross(b).normalize();
        sum += theta * n.as_dvec3().dot(u);
    }
    0.5 * sum.abs()
}

/// A Lambert (`rho`) plane under a uniform downward 1 × 0.6 rectangle of
/// `radiance`, shadows on, seen at `size²`; and per pixel the closed form
/// (Lambert's edge sum) averaged over a 4 × 4 sub-pixel grid.
pub fn plane_under_rectangle(rho: f32, radiance: f32, size: usize) -> (Scene, Vec<f64>) {
    let light = AreaLight {
        center: Vec3::new(0.2, 1.0, -0.1),
        size: Vec2::new(1.0, 0.6),
        // x̂ = +X, ŷ = +Z, emitting ẑ = −Y (down).
        world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
        intensity: Vec3::splat(radiance),
        texture: None,
        light_field: None,
    };
    let corners: Vec<Vec3> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        .iter()
        .map(|&(u, v)| light.point_at(Vec2::new(u, v)))
        .collect();
    let mut scene = Scene::new(
        vec![Object::new(
            Arc::new(relight_geom::shapes::plane(6.0, 1)),
            lambert(rho),
        )],
        black_env(),
        camera(
            Vec3::new(0.0, 2.5, 2.5),
            Vec3::new(0.0, 0.0, -0.3),
            50.0,
            size,
            size,
        ),
    );
    scene.visibility = true;
    scene.area_lights.push(light);
    let (w, h) = (size, size);
    let closed = (0..w * h)
        .map(|i| {
            let k = 4;
            let mut s = 0.0;
            for j in 0..k * k {
                let (o, d) = scene.camera.ray(
                    (i % w) as f32 + ((j % k) as f32 + 0.5) / k as f32,
                    (i / w) as f32 + ((j / k) as f32 + 0.5) / k as f32,
                );
                let x = o + d * (-o.y / d.y);
                s += f64::from(rho) / PI
                    * f64::from(radiance)
                    * polygon_irradiance(x, Vec3::Y, &corners);
            }
            s / (k * k) as f64
        })
        .collect();
    (scene, closed)
}

/// A Lambert plane (ρ = 0.8) under one uniform rectangle (radiance 2) and
/// nothing else, against the closed form averaged over each pixel (4 × 4
/// sub-pixel grid) — with MIS, and with each strategy alone.
#[test]
fn lambert_plane_under_a_rectangle_matches_the_closed_form() {
    let rho = 0.8f32;
    let radiance = 2.0f32;
    let (scene, closed) = plane_under_rectangle(rho, radiance, 32);
    let mask = object_mask(&scene, 0);
    let (w, h) = (scene.camera.width, scene.camera.height);
    for (strategy, spp) in [
        (LightSampling::Mis, 64),
        (LightSampling::LightOnly, 64),
        (LightSampling::BsdfOnly, 256),
    ] {
        let o = ReferenceOptions {
            spp,
            pass_spp: 64,
            seed: 21,
            light_sampling: strategy,
            ..ReferenceOptions::default()
        };
        let r = render_reference(&scene, &o, &NoProgress).unwrap();
        let (mut diff, mut sum_cf, mut var, mut sq, mut sq_cf, mut n) =
            (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64, 0);
        for i in 0..w * h {
            if mask[i] {
                let l = f64::from(luminance(r.image.pixels[i]));
                diff += l - closed[i];
                sum_cf += closed[i];
                var += f64::from(r.std_error[i]).powi(2);
                sq += (l - closed[i]).powi(2);
                sq_cf += closed[i].powi(2);
                n += 1;
            }
        }
        let rel_bias = diff / sum_cf;
        let rel_sigma = var.sqrt() / sum_cf;
        let rms = (sq / sq_cf).sqrt();
        let noise = (var / sq_cf).sqrt();
        eprintln!(
            "rectangle over Lambert plane, {strategy:?}, {spp} spp, {n} px: mean closed form {:.5}, MC − closed form {rel_bias:+.2e} ± {rel_sigma:.1e} (relative), per-pixel relative RMS {rms:.4} vs reported noise {noise:.4}",
            sum_cf / n as f64
        );
        assert!(n > 400);
        assert!(
            rel_bias.abs() < 4.0 * rel_sigma + 2e-3,
            "{strategy:?}: bias {rel_bias}"
        );
        assert!(
            rms < 1.5 * noise + 0.005,
            "{strategy:?}: rms {rms} vs noise {noise}"
        );
    }
}

/// A point light over a Lambert floor, a square blocker between them: the
/// shadow's pixels are exactly 0, the lit pixels `ρ/π · I cos θ / r²`; with
/// visibility off every floor pixel is lit.
#[test]
fn point_light_shadow_has_the_analytic_values() {
    let (rho, intensity, h_light, h_block, half) = (0.5f32, 5.0f32, 2.0f32, 1.5f32, 0.25f32);
    let blocker = relight_geom::shapes::plane(2.0 * half, 1).transformed(
        glam::Affine3A::from_translation(Vec3::new(0.0, h_block, 0.0)),
    );
    let light_pos = Vec3::new(0.0, h_light, 0.0);
    let mut scene = Scene::new(
        vec![
            Object::new(Arc::new(relight_geom::shapes::plane(8.0, 1)), lambert(rho)),
            Object::new(Arc::new(blocker), lambert(rho)),
        ],
        black_env(),
        camera(Vec3::new(0.0, 4.0, 0.0), Vec3::ZERO, 60.0, 48, 48),
    );
    scene
        .point_lights
        .push(PointLight::new(light_pos, Vec3::splat(intensity)));
    // The shadow of the square [−half, half]² at h_block from the light at h_light.
    let s = half * h_light / (h_light - h_block);
    let mask = object_mask(&scene, 0);
    let (w, hgt) = (scene.camera.width, scene.camera.height);
    let lit_value = |x: Vec3| -> f64 {
        let v = light_pos - x;
        let r2 = f64::from(v.length_squared());
        f64::from(rho) / PI * f64::from(intensity) * f64::from(v.normalize().y) / r2
    };
    for visibility in [true, false] {
        scene.visibility = visibility;
        let o = ReferenceOptions {
            spp: 64,
            ..ReferenceOptions::default()
        };
        let r = render_reference(&scene, &o, &NoProgress).unwrap();
        let (mut n_shadow, mut n_lit, mut worst_lit) = (0, 0, 0.0f64);
        for i in 0..w * hgt {
            if !mask[i] {
                continue;
            }
            let k = 4;
            let mut pts = Vec::new();
            let mut expect = 0.0;
            for j in 0..k * k {
                let (o, d) = scene.camera.ray(
                    (i % w) as f32 + ((j % k) as f32 + 0.5) / k as f32,
                    (i / w) as f32 + ((j / k) as f32 + 0.5) / k as f32,
                );
                let x = o + d * (-o.y / d.y);
                expect += lit_value(x) / (k * k) as f64;
                pts.push(x);
            }
            let margin = 0.02;
            let inside = pts
                .iter()
                .all(|p| p.x.abs() < s - margin && p.z.abs() < s - margin);
            let outside = pts
                .iter()
                .all(|p| p.x.abs() > s + margin || p.z.abs() > s + margin);
            let got = f64::from(luminance(r.image.pixels[i]));
            if inside && visibility {
                n_shadow += 1;
                assert_eq!(got, 0.0, "pixel {i} in the shadow");
            } else if outside || !visibility {
                n_lit += 1;
                let rel = (got - expect).abs() / expect;
                worst_lit = worst_lit.max(rel);
                assert!(rel < 0.01, "lit pixel {i}: {got} vs {expect} ({rel})");
            }
        }
        eprintln!(
            "point-light shadow (visibility {visibility}): {n_shadow} shadow pixels exactly 0, {n_lit} lit pixels within {worst_lit:.2e} of ρ/π·I·cosθ/r²"
        );
        if visibility {
            assert!(n_shadow > 30, "{n_shadow} shadow pixels");
        }
        assert!(n_lit > 300);
    }
}

/// The camera sees an area light's front side (texture × intensity, plus the
/// environment behind it: a luminaire does not occlude) and only the
/// environment through its back.
#[test]
fn area_light_is_seen_from_the_front_only() {
    let tex = Arc::new(
        Texture::try_new(
            2,
            2,
            vec![
                Vec3::new(1.0, 0.2, 0.1),
                Vec3::new(0.1, 1.0, 0.2),
                Vec3::new(0.2, 0.1, 1.0),
                Vec3::new(1.0, 1.0, 1.0),
            ],
        )
        .unwrap(),
    );
    let light = AreaLight {
        center: Vec3::new(0.0, 2.0, 0.0),
        size: Vec2::new(2.0, 2.0),
        world_from_light: Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
        intensity: Vec3::splat(3.0),
        texture: Some(tex),
        light_field: None,
    };
    let env = 0.5;
    for (eye, front) in [
        (Vec3::new(0.0, 0.5, 0.0), true),
        (Vec3::new(0.0, 3.5, 0.0), false),
    ] {
        let mut scene = Scene::new(
            Vec::new(),
            constant_env(env),
            camera(eye, Vec3::new(0.0, 2.0, 0.0), 40.0, 16, 16),
        );
        scene.area_lights.push(light.clone());
        let r = render_reference(
            &scene,
            &ReferenceOptions {
                spp: 256,
                ..ReferenceOptions::default()
            },
            &NoProgress,
        )
        .unwrap();
        let (w, h) = (16, 16);
        let mut worst = 0.0f32;
        for i in 0..w * h {
            let k = 4;
            let mut expect = Vec3::ZERO;
            for j in 0..k * k {
                let (o, d) = scene.camera.ray(
                    (i % w) as f32 + ((j % k) as f32 + 0.5) / k as f32,
                    (i / w) as f32 + ((j / k) as f32 + 0.5) / k as f32,
                );
                let e = match light.intersect(o, d, 0.0) {
                    Some((_, uv)) if front => light.radiance_at(uv),
                    _ => Vec3::ZERO,
                };
                expect += (e + Vec3::splat(env)) / (k * k) as f32;
            }
            let got = r.image.pixels[i];
            let rel = ((got - expect).abs() / expect).max_element();
            worst = worst.max(rel);
            assert!(rel < 0.03, "front {front}, pixel {i}: {got} vs {expect}");
        }
        eprintln!(
            "area light seen from the {}: worst relative pixel error {worst:.2e}",
            if front { "front" } else { "back" }
        );
    }
}

/// A scene whose lighting misses its objects says so, through
/// `check_scene` (what the CLI and the viewer call): nothing emitting at
/// all, or an area light with every vertex behind its emitting side.
#[test]
fn lighting_that_misses_the_objects_is_warned() {
    use relight_render::method::check_scene;
    let (lit, _) = plane_under_rectangle(0.5, 1.0, 8);
    let method = relight_render::ReferenceRenderer::new(ReferenceOptions::default());
    assert!(lit.lighting_warnings().is_empty());
    assert!(check_scene(&method, &lit, false).unwrap().is_empty());

    // Turned over (emitting up, away from the plane below it).
    let mut up = lit.clone();
    up.area_lights[0].world_from_light = Mat3::from_cols(Vec3::X, -Vec3::Z, Vec3::Y);
    let w = check_scene(&method, &up, false).unwrap().join("\n");
    assert!(w.contains("area light 1 lights none of the objects"), "{w}");
    assert!(!w.contains("nothing lights it"), "{w}");

    // Nothing emits: zero intensity, or a black texture, under a black sky.
    let mut dark = lit.clone();
    dark.area_lights[0].intensity = Vec3::ZERO;
    let w = dark.lighting_warnings().join("\n");
    assert!(w.contains("nothing lights it"), "{w}");
    let mut black_texture = lit.clone();
    black_texture.area_lights[0].texture = Some(Arc::new(Texture::constant(Vec3::ZERO).unwrap()));
    assert!(black_texture.lighting_warnings()[0].contains("nothing lights it"));
    // A point light, or a sky, lights it again.
    dark.point_lights
        .push(PointLight::new(Vec3::new(0.0, 1.0, 0.0), Vec3::ONE));
    assert!(dark.lighting_warnings().is_empty());
    black_texture.env = constant_env(0.5);
    assert!(black_texture.lighting_warnings().is_empty());
}

/// A light field (`relight_render::LightField`, two views along x̂: red
/// towards −x̂, blue towards +x̂) over a Lambert plane: each receiving point
/// gets red from the part of the rectangle on its +x̂ side and blue from the
/// rest (the emitted slope along x̂ is the receiver's offset from the light
/// point, at unit depth), Lambert's edge sum on each part per channel. And
/// a field whose views all equal one texture renders exactly as that
/// texture (same seed, same image).
#[test]
fn light_field_views_light_the_sides_they_face() {
    let (mut scene, _) = plane_under_rectangle(0.8, 1.0, 24);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let red = Texture::constant(Vec3::X).unwrap();
    let blue = Texture::constant(Vec3::Z).unwrap();
    let field =
        relight_render::LightField::try_new(2, 50.0, vec![red.clone(), blue.clone(), red, blue])
            .unwrap();
    scene.area_lights[0].light_field = Some(Arc::new(field));
    let light = scene.area_lights[0].clone();
    // Receiver on the plane right below the light's centre: red from the
    // +x̂ half, which it sees along −x̂ emission.
    let below = Vec3::new(light.center.x, 0.0, light.center.z);
    let towards_right_half = (light.point_at(Vec2::new(0.9, 0.5)) - below).normalize();
    assert_eq!(
        light.radiance(Vec2::new(0.9, 0.5), towards_right_half),
        Vec3::X
    );
    let towards_left_half = (light.point_at(Vec2::new(0.1, 0.5)) - below).normalize();
    assert_eq!(
        light.radiance(Vec2::new(0.1, 0.5), towards_left_half),
        Vec3::Z
    );
    assert_eq!(
        light.radiance(Vec2::new(0.1, 0.5), -towards_left_half),
        Vec3::ZERO,
        "behind"
    );

    let o = ReferenceOptions {
        spp: 64,
        pass_spp: 64,
        seed: 5,
        ..ReferenceOptions::default()
    };
    let r = render_reference(&scene, &o, &NoProgress).unwrap();
    let mask = object_mask(&scene, 0);
    let (mut sum, mut closed, mut var) = ([0.0f64; 2], [0.0f64; 2], [0.0f64; 2]);
    for i in 0..w * h {
        if !mask[i] {
            continue;
        }
        // Per 4 × 4 sub-pixel receiver: the split of the rectangle at its
        // x̂ offset (in uv), red from the +x̂ part, blue from the rest.
        let mut exact = [0.0f64; 2];
        for j in 0..16 {
            let (o, d) = scene.camera.ray(
                (i % w) as f32 + ((j % 4) as f32 + 0.5) / 4.0,
                (i / w) as f32 + ((j / 4) as f32 + 0.5) / 4.0,
            );
            let x = o + d * (-o.y / d.y);
            let cut = light
                .uv_of(Vec3::new(x.x, light.center.y, light.center.z))
                .x;
            let part = |u0: f32, u1: f32| {
                let (u0, u1) = (u0.clamp(0.0, 1.0), u1.clamp(0.0, 1.0));
                if u1 <= u0 {
                    return 0.0;
                }
                let c: Vec<Vec3> = [(u0, 0.0), (u1, 0.0), (u1, 1.0), (u0, 1.0)]
                    .iter()
                    .map(|&(u, v)| light.point_at(Vec2::new(u, v)))
                    .collect();
                0.8 / PI * polygon_irradiance(x, Vec3::Y, &c) / 16.0
            };
            exact[0] += part(cut, 1.0);
            exact[1] += part(0.0, cut);
        }
        let p = r.image.pixels[i];
        for (c, (value, exact)) in [(p.x, exact[0]), (p.z, exact[1])].into_iter().enumerate() {
            sum[c] += f64::from(value);
            closed[c] += exact;
            // The reported error is luminance's; a channel's is about it
            // over the channel's luminance weight (Rec. 709: 0.2126 red,
            // 0.0722 blue) where that channel dominates.
            let weight = [0.2126, 0.0722][c];
            var[c] += (f64::from(r.std_error[i]) / weight).powi(2);
        }
        assert!(p.y.abs() < 1e-6, "no green emitted");
    }
    for c in 0..2 {
        let bias = (sum[c] - closed[c]) / closed[c];
        let sigma = var[c].sqrt() / closed[c];
        eprintln!("light field channel {c}: MC − closed form {bias:+.2e} ± {sigma:.1e}");
        assert!(closed[c] > 1.0, "both sides lit");
        assert!(bias.abs() < 4.0 * sigma + 1e-3, "channel {c}: bias {bias}");
    }

    // Identical views: the textured light, bit for bit.
    let tex = Arc::new(Texture::stripes_and_spot(16, 0.3, 2.0));
    scene.area_lights[0].light_field = None;
    scene.area_lights[0].texture = Some(tex.clone());
    let plain = render_reference(&scene, &o, &NoProgress).unwrap();
    scene.area_lights[0].texture = None;
    scene.area_lights[0].light_field = Some(Arc::new(
        relight_render::LightField::try_new(2, 1e4, vec![(*tex).clone(); 4]).unwrap(),
    ));
    let field = render_reference(&scene, &o, &NoProgress).unwrap();
    assert_eq!(plain.image.pixels, field.image.pixels);
}
