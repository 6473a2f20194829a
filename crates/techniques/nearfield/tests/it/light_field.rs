//! Light fields (topic `light_field`, thesis eq. 4.37): a field whose views
//! are all one texture relights as that texture; an uncompressed field
//! matches face-clipped quadrature of its own radiance by direction; what
//! cannot be relit is refused.

use glam::Vec3;
use relight_nearfield::face::LightFrame;
use relight_nearfield::scenes::{
    floor_and_sphere, floor_and_sphere_light_field, glossy_floor_and_sphere,
};
use relight_nearfield::verify::face_quadrature_directional;
use relight_nearfield::verify_light_field::boxed_field_radiance;
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::Relighter;
use relight_render::{LightField, NoProgress, Scene};
use std::sync::Arc;

fn full() -> NearfieldOptions {
    NearfieldOptions {
        source_terms: 1.0,
        target_terms: 1.0,
        ..NearfieldOptions::default()
    }
}

/// The small floor-and-sphere scene with its light's texture as the prism
/// field of `views²` views over slopes `[−extent, extent]²`.
fn field_scene(views: usize, extent: f32) -> Scene {
    floor_and_sphere_light_field(8, 8, [32, 24], false, views, extent)
}

fn colors(scene: &Scene, options: NearfieldOptions) -> Vec<Vec<Vec3>> {
    let mut m = NearfieldMethod::new(options).unwrap();
    m.prepare(scene, &NoProgress).unwrap();
    m.vertex_colors().to_vec()
}

/// The largest channel of `a`'s vertex colours and the largest channel
/// difference between `a` and `b`.
fn largest_and_worst(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> (f32, f32) {
    let top = a
        .iter()
        .flatten()
        .map(|c| c.max_element())
        .fold(0.0, f32::max);
    let worst = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max);
    (top, worst)
}

/// Views that are all the light's texture, over slopes wider than the face:
/// only the angular mean is non-zero, and the vertices get what the
/// textured light gives them (to f32 rounding of the extra transforms).
#[test]
fn a_field_of_equal_views_relights_as_its_texture() {
    let plain = floor_and_sphere(8, 8, 32, 24, false);
    let mut s = plain.clone();
    let tex = plain.area_lights[0].texture.clone().unwrap();
    s.area_lights[0].texture = None;
    s.area_lights[0].light_field = Some(Arc::new(
        LightField::try_new(2, 100.0, vec![(*tex).clone(); 4]).unwrap(),
    ));
    for options in [full(), NearfieldOptions::default()] {
        let (a, b) = (colors(&plain, options.clone()), colors(&s, options));
        let (top, worst) = largest_and_worst(&a, &b);
        assert!(top > 0.1 && worst < 1e-4 * top, "off by {worst} of {top}");
    }
}

/// The glossy scene (an RGB fixed-view transport on the sphere, one
/// channel on the floor): a field of equal views relights as its texture
/// there too, and a field whose views differ sums its slices per channel
/// (the prism's warm and cool sides reach the sphere's RGB transport).
#[test]
fn a_field_relights_rgb_transports() {
    let plain = glossy_floor_and_sphere(8, 8, 32, 24, false);
    let tex = plain.area_lights[0].texture.clone().unwrap();
    let mut equal = plain.clone();
    equal.area_lights[0].texture = None;
    equal.area_lights[0].light_field = Some(Arc::new(
        LightField::try_new(4, 2.0, vec![(*tex).clone(); 16]).unwrap(),
    ));
    // Two views over slopes far past the face: nothing is cut.
    let mut wide = equal.clone();
    wide.area_lights[0].light_field = Some(Arc::new(
        LightField::try_new(2, 100.0, vec![(*tex).clone(); 4]).unwrap(),
    ));
    let a = colors(&plain, full());
    let (top, worst) = largest_and_worst(&a, &colors(&wide, full()));
    assert!(top > 0.05 && worst < 1e-4 * top, "off by {worst} of {top}");
    // The aligned 4 × 4 field of equal views takes the block operators on
    // the RGB transport too, and matches the plain light on the sphere's
    // top, whose face holds the whole light inside the field's extent.
    let c = colors(&equal, full());
    let top_vertex = (0..c[0].len())
        .max_by(|&i, &j| {
            let y = |k: usize| equal.objects[0].mesh.positions[k].y;
            y(i).total_cmp(&y(j))
        })
        .unwrap();
    let (x, y) = (a[0][top_vertex], c[0][top_vertex]);
    assert!(
        (x - y).abs().max_element() < 1e-4 * x.max_element(),
        "{x} vs {y}"
    );
    let sphere_top = c[0].iter().map(|c| c.max_element()).fold(0.0, f32::max);
    assert!(sphere_top > 0.01, "the RGB sphere is lit");
    // A prism field tints the RGB sphere's two sides differently.
    let mut prism = plain.clone();
    let base = prism.area_lights[0].texture.take().unwrap();
    prism.area_lights[0].light_field = Some(Arc::new(LightField::prism(&base, 4, 2.0)));
    let p = colors(&prism, full());
    let sphere = &prism.objects[0].mesh;
    let centre = sphere.positions.iter().copied().sum::<Vec3>() / sphere.positions.len() as f32;
    let (mut left, mut right) = (Vec3::ZERO, Vec3::ZERO);
    for (q, c) in sphere.positions.iter().zip(&p[0]) {
        if q.x < centre.x - 0.2 {
            left += *c;
        } else if q.x > centre.x + 0.2 {
            right += *c;
        }
    }
    assert!(
        left.x / left.z > right.x / right.z,
        "warm on the left, cool on the right: {left} {right}"
    );
}

/// Uncompressed, the floor's vertices against face-clipped quadrature of
/// the field's radiance by direction (views box-averaged at the method's
/// order, as the plain light's test), views aligned with face cells
/// (face 4, order 32, extent 2, 4 × 4 views: a view is 8 × 8 face cells),
/// and the same for views that are not (extent 1.7, reported and held to
/// a looser bound).
#[test]
fn a_field_matches_face_quadrature_by_direction() {
    for (extent, bound) in [(2.0f32, 0.01), (1.7, 0.05)] {
        let s = field_scene(4, extent);
        let mut m = NearfieldMethod::new(full()).unwrap();
        m.prepare(&s, &NoProgress).unwrap();
        let light = &s.area_lights[0];
        let frame = LightFrame::of(light);
        let radiance = boxed_field_radiance(light, m.options().order);
        let floor = &s.objects[1].mesh;
        let albedo = m.albedos()[1] / std::f32::consts::PI;
        let got = &m.vertex_colors()[1];
        let mut worst = 0.0f32;
        let mut peak = 0.0f32;
        let mut wants = Vec::new();
        for v in (0..floor.positions.len()).step_by(3) {
            let want = albedo
                * face_quadrature_directional(
                    &frame,
                    m.options().face,
                    floor.positions[v],
                    floor.normals[v],
                    96,
                    &radiance,
                    None,
                );
            peak = peak.max(want.max_element());
            wants.push((v, want));
        }
        for (v, want) in wants {
            // Lit vertices (≥ 5 % of the brightest), as the verify rows.
            if want.max_element() >= 0.05 * peak {
                worst = worst.max((got[v] - want).length() / want.length());
            }
        }
        eprintln!("light field, extent {extent}: worst lit floor vertex {worst:.4}");
        assert!(peak > 0.0 && worst < bound, "extent {extent}: {worst}");
    }
}

/// The prism field varies with direction: a compressed field keeps several
/// angular slices, and the floor's colour turns from warm to cool across
/// it (views towards −x̂ are warm).
#[test]
fn a_prism_field_colours_the_floor_by_direction() {
    let s = field_scene(4, 2.0);
    let c = colors(&s, NearfieldOptions::default());
    let floor = &s.objects[1].mesh;
    let centre = s.area_lights[0].center.x;
    let (mut left, mut right) = (Vec3::ZERO, Vec3::ZERO);
    for (p, c) in floor.positions.iter().zip(&c[1]) {
        if p.x < centre - 0.5 {
            left += *c;
        } else if p.x > centre + 0.5 {
            right += *c;
        }
    }
    // Light emitted towards −x̂ reaches the floor left of the light: warm
    // (red over blue) there, cool on the right.
    assert!(
        left.x > left.z && right.z > right.x,
        "left {left}, right {right}"
    );
}

/// A view count that is not a power of two, and a field turned in its
/// baked plane, are errors naming the light field; a move is not.
#[test]
fn what_cannot_be_relit_is_refused() {
    let s = field_scene(3, 2.0);
    let mut m = NearfieldMethod::new(NearfieldOptions::default()).unwrap();
    let e = m.prepare(&s, &NoProgress).unwrap_err().to_string();
    assert!(
        e.contains("power of two") && e.contains("light field"),
        "{e}"
    );
    // Turned in its baked plane: its directions would turn too.
    let s = field_scene(4, 2.0);
    let mut m = NearfieldMethod::new(NearfieldOptions::default()).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    let mut turned = s.clone();
    turned.area_lights[0].world_from_light *= glam::Mat3::from_rotation_z(0.5);
    let e = m
        .set_lighting(&turned, &NoProgress)
        .unwrap_err()
        .to_string();
    assert!(e.contains("light field turned"), "{e}");
    // Moved within its plane: relit, no error.
    let mut moved = s.clone();
    moved.area_lights[0].center.x += 0.3;
    m.set_lighting(&moved, &NoProgress).unwrap();
}
