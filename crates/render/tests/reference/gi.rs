//! The GI reference checked a second way: a closed white Lambert box lit by
//! its own walls converges to the geometric series `L_e / (1 − ρ)`, and an
//! open white scene under a uniform sky stays at the sky's radiance (albedo 1
//! conserves energy exactly; every other BRDF reflects at most that).

use super::common::{camera, constant_env, lambert};
use glam::{Mat3, Vec2, Vec3};
use relight_brdf::BrdfSpec;
use relight_geom::Mesh;
use relight_render::sampling::luminance;
use relight_render::{
    AreaLight, GiImage, GiOptions, NoProgress, Object, ReferenceOptions, Scene, render_gi_reference,
};
use std::sync::Arc;

fn gi_opts(spp: u32, seed: u64) -> GiOptions {
    GiOptions {
        reference: ReferenceOptions {
            spp,
            seed,
            ..ReferenceOptions::default()
        },
        ..GiOptions::default()
    }
}

/// The axis-aligned cube `[−1, 1]³` as six inward-facing quads.
fn inward_cube() -> Mesh {
    let mut m = Mesh::default();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::from_array(std::array::from_fn(|k| if k == axis { -sign } else { 0.0 }));
            let (u, v) = (
                Vec3::from_array(std::array::from_fn(|k| {
                    f32::from(u8::from(k == (axis + 1) % 3))
                })),
                Vec3::from_array(std::array::from_fn(|k| {
                    f32::from(u8::from(k == (axis + 2) % 3))
                })),
            );
            // Counter-clockwise seen from inside: the winding agrees with `n`.
            let (u, v) = if u.cross(v).dot(n) > 0.0 {
                (u, v)
            } else {
                (v, u)
            };
            let c = -n;
            let b = m.positions.len() as u32;
            for (a, bb) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                m.positions.push(c + u * a + v * bb);
                m.normals.push(n);
            }
            m.indices.push([b, b + 1, b + 2]);
            m.indices.push([b, b + 2, b + 3]);
        }
    }
    m
}

/// One emitting rectangle just inside each wall, facing the box's centre.
fn wall_lights(radiance: f32, inset: f32) -> Vec<AreaLight> {
    let mut out = vec![];
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let z = Vec3::from_array(std::array::from_fn(|k| if k == axis { -sign } else { 0.0 }));
            let x = Vec3::from_array(std::array::from_fn(|k| {
                f32::from(u8::from(k == (axis + 1) % 3))
            }));
            let y = z.cross(x);
            out.push(AreaLight {
                center: -z * (1.0 - inset),
                size: Vec2::splat(2.0),
                world_from_light: Mat3::from_cols(x, y, z),
                intensity: Vec3::splat(radiance),
                texture: None,
                light_field: None,
            });
        }
    }
    out
}

fn mean_lum(img: &relight_render::Image) -> f64 {
    img.pixels
        .iter()
        .map(|&p| f64::from(luminance(p)))
        .sum::<f64>()
        / img.pixels.len() as f64
}

#[test]
fn closed_white_box_converges_to_the_geometric_series() {
    let (rho, le) = (0.5f32, 1.0f32);
    let mut scene = Scene::new(
        vec![Object::new(Arc::new(inward_cube()), lambert(rho))],
        constant_env(0.0),
        camera(Vec3::ZERO, Vec3::new(0.3, -0.2, -1.0), 70.0, 8, 8),
    );
    scene.visibility = true;
    scene.area_lights = wall_lights(le, 1e-3);
    let r: GiImage = render_gi_reference(&scene, &gi_opts(32, 1), &NoProgress).unwrap();
    let (d, i) = (mean_lum(&r.direct), mean_lum(&r.indirect));
    let (want_d, want_i) = (
        f64::from(le * (1.0 + rho)),
        f64::from(le * rho * rho / (1.0 - rho)),
    );
    eprintln!(
        "closed box ρ = {rho}: direct {d:.4} (analytic {want_d}), indirect {i:.4} (analytic {want_i}), \
         indirect σ_rel {:.1e}",
        r.indirect_rms_relative_std_error
    );
    assert!(
        (d / want_d - 1.0).abs() < 0.02,
        "direct {d} vs {want_d} ± 2 %"
    );
    assert!(
        (i / want_i - 1.0).abs() < 0.03,
        "indirect {i} vs {want_i} ± 3 %"
    );
    let total = mean_lum(&r.total());
    assert!(
        (total * f64::from(1.0 - rho) / f64::from(le) - 1.0).abs() < 0.02,
        "total {total}"
    );
}

/// A sphere resting on a floor: concave contact, so light is reflected
/// between them.
fn sphere_on_floor(brdf: &str, size: usize) -> Scene {
    let b = brdf.parse::<BrdfSpec>().unwrap().build();
    let sphere = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, 1.0, 0.0), 1.0, 48, 24);
    let mut floor = relight_geom::shapes::plane(6.0, 1);
    if floor.normals.is_empty() {
        floor.normals = vec![Vec3::Y; floor.positions.len()];
    }
    let mut scene = Scene::new(
        vec![
            Object::new(Arc::new(sphere), b.clone()),
            Object::new(Arc::new(floor), b),
        ],
        constant_env(1.0),
        camera(
            Vec3::new(0.0, 2.5, 4.5),
            Vec3::new(0.0, 0.6, 0.0),
            45.0,
            size,
            size,
        ),
    );
    scene.visibility = true;
    scene
}

#[test]
fn white_furnace_with_interreflection_conserves_energy() {
    let scene = sphere_on_floor("lambert", 10);
    let r = render_gi_reference(&scene, &gi_opts(24, 2), &NoProgress).unwrap();
    let total = r.total();
    let (mean, ind) = (mean_lum(&total), mean_lum(&r.indirect));
    // Where interreflection carries much of the light (the contact region),
    // direct + indirect still sums to the sky's radiance.
    let contact: Vec<f64> = (0..total.pixels.len())
        .filter(|&k| luminance(r.indirect.pixels[k]) > 0.1)
        .map(|k| f64::from(luminance(total.pixels[k])))
        .collect();
    let contact_mean = contact.iter().sum::<f64>() / contact.len().max(1) as f64;
    eprintln!(
        "white furnace: mean {mean:.4}, contact region ({} px) {contact_mean:.4}, mean indirect {ind:.4}",
        contact.len()
    );
    assert!((mean - 1.0).abs() < 0.01, "mean {mean} vs 1 ± 1 %");
    assert!(contact.len() >= 10, "{} contact pixels", contact.len());
    assert!(
        (contact_mean - 1.0).abs() < 0.04,
        "contact mean {contact_mean} vs 1 ± 4 %"
    );
    // The contact region really is lit by the other surface.
    assert!(ind > 0.02, "indirect {ind}");
}

#[test]
fn no_brdf_creates_energy_under_a_uniform_sky() {
    for spec in [
        "phong:20",
        "blinn:40",
        "ward:0.2",
        "ggx:0.3",
        "ashikhmin:50,50",
        "oren-nayar:0.4",
        "0.5*lambert+0.5*ggx:0.2",
    ] {
        let scene = sphere_on_floor(spec, 8);
        let r = render_gi_reference(&scene, &gi_opts(16, 3), &NoProgress).unwrap();
        let mean = mean_lum(&r.total());
        eprintln!(
            "{spec}: mean total {mean:.4} (≤ 1), indirect {:.4}",
            mean_lum(&r.indirect)
        );
        assert!(
            mean < 1.02,
            "{spec}: mean {mean} exceeds the sky's radiance 1"
        );
        assert!(mean > 0.1, "{spec}: mean {mean}: reflected nothing");
    }
}

#[test]
fn indirect_is_zero_without_visibility_and_media_are_refused() {
    let mut scene = sphere_on_floor("lambert:0.8", 6);
    scene.visibility = false;
    let r = render_gi_reference(&scene, &gi_opts(4, 4), &NoProgress).unwrap();
    assert!(r.indirect.pixels.iter().all(|p| *p == Vec3::ZERO));
    scene.medium = Some(relight_render::Medium {
        beta: 0.1,
        albedo: 0.5,
        radius: 5.0,
    });
    let e = render_gi_reference(&scene, &gi_opts(4, 4), &NoProgress).unwrap_err();
    assert!(e.to_string().contains("medium"), "{e}");
}
