//! The nearfield method: the affine map, the target mask, exactness of the
//! uncompressed fused kernel, per-vertex accuracy and run-time edits without
//! a re-bake. Small scenes only (CI budget).

use glam::{Vec2, Vec3};
use relight_affine::standard::propagate_two_step;
use relight_nearfield::face::LightFrame;
use relight_nearfield::light::{LightCoeffs, coarse_key};
use relight_nearfield::propagate::{SelectScratch, select_targets};
use relight_nearfield::scenes::floor_and_sphere;
use relight_nearfield::verify::one_vertex_error;
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::{MethodError, Relighter};
use relight_render::{NoProgress, Scene};

fn small(vis: bool) -> Scene {
    floor_and_sphere(8, 8, 32, 24, vis)
}

fn full() -> NearfieldOptions {
    NearfieldOptions {
        source_terms: 1.0,
        target_terms: 1.0,
        ..NearfieldOptions::default()
    }
}

/// The face point's ray meets the light's plane at the uv the affine map gives.
#[test]
fn affine_map_matches_ray_plane_intersection() {
    let s = small(false);
    let light = &s.area_lights[0];
    let frame = LightFrame::of(light);
    let face = 4.0;
    for p in [Vec3::new(0.3, 0.0, -0.7), Vec3::new(-1.2, 0.4, 0.9)] {
        let (sc, o) = frame.affine(frame.local(p), face).expect("below the light");
        for t in [[0.2, 0.7], [0.55, 0.4]] {
            let d = frame.face_dir((face * (t[0] - 0.5)) as f32, (face * (t[1] - 0.5)) as f32);
            // The ray's crossing of the light's plane (inside the rectangle or not).
            let nz = light.normal();
            let dist = (light.center - p).dot(nz) / d.normalize().dot(nz);
            assert!(dist > 0.0);
            let want = light.uv_of(p + d.normalize() * dist);
            let got = Vec2::new((sc[0] * t[0] + o[0]) as f32, (sc[1] * t[1] + o[1]) as f32);
            assert!((got - want).length() < 1e-4, "{got} vs {want}");
        }
    }
}

/// The k-way merge keeps exactly the m largest |a b|, ties coarse first.
#[test]
fn target_mask_is_the_top_m_with_coarse_ties() {
    let n = 16;
    let a: Vec<f32> = (0..n)
        .map(|i| [0.0, 0.5, -0.5, 0.25][i % 4] * (1.0 + (i / 4) as f32))
        .collect();
    let b: Vec<f32> = (0..n).map(|i| [1.0, 0.0, -0.3, 0.3][(i * 3) % 4]).collect();
    type Keyed = (f32, (u32, usize, usize), (u16, u16));
    let mut all: Vec<Keyed> = Vec::new();
    for (k2, bv) in b.iter().enumerate() {
        for (k1, av) in a.iter().enumerate() {
            all.push(((av * bv).abs(), coarse_key(k1, k2), (k1 as u16, k2 as u16)));
        }
    }
    all.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    let mut sc = SelectScratch::default();
    let mut out = Vec::new();
    for m in [1, 7, 40, 120, 255] {
        select_targets(&a, &b, m, &mut sc, &mut out);
        let want: Vec<(u16, u16)> = all[..m].iter().map(|x| x.2).collect();
        assert_eq!(out, want, "m = {m}");
    }
}

/// At 100 %/100 % the fused kernel equals the dense two-step propagation
/// dotted with the transport.
#[test]
fn uncompressed_kernel_equals_dense_propagation() {
    let s = small(false);
    let mut m = NearfieldMethod::new(NearfieldOptions { order: 8, ..full() }).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    let light = &s.area_lights[0];
    let frame = LightFrame::of(light);
    let n = 8;
    let coeffs = LightCoeffs::of(light, n);
    let obj = 1;
    let mesh = &s.objects[obj].mesh;
    let t = m.transports()[obj];
    let k = m.albedos()[obj] / std::f32::consts::PI;
    for v in [0, 17, 40, 80] {
        let (sc, o) = frame.affine(frame.local(mesh.positions[v]), 4.0).unwrap();
        let mut want = Vec3::ZERO;
        for c in 0..3 {
            let mut l = vec![0.0; n * n];
            propagate_two_step(&coeffs.c[c], n, sc, o, &mut l);
            want[c] = l
                .iter()
                .zip(&t.values[v * n * n..(v + 1) * n * n])
                .map(|(a, b)| a * f64::from(*b))
                .sum::<f64>() as f32;
        }
        let want = want * k;
        let got = m.vertex_colors()[obj][v];
        assert!(
            (got - want).length() <= 1e-4 * want.length() + 1e-7,
            "v {v}: {got} vs {want}"
        );
    }
}

/// Uncompressed, Lambert, unshadowed, order 32, face 4: floor vertices
/// within 1 % of face-clipped quadrature (the verify suite reports the
/// distribution; this is a cheap guard).
#[test]
fn per_vertex_matches_face_quadrature() {
    let s = small(false);
    for v in [40, 30, 10] {
        let e = one_vertex_error(&s, 1, v, 128);
        assert!(e < 0.01, "floor vertex {v}: relative error {e}");
    }
}

/// Moving, scaling and retexturing the light re-bakes nothing; turning it does.
#[test]
fn edits_without_rebake() {
    let mut s = small(true);
    let mut m = NearfieldMethod::new(NearfieldOptions::default()).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    assert_eq!(m.bakes(), 1);
    let before = m.vertex_colors()[1].clone();
    s.area_lights[0].center += Vec3::new(0.3, 0.0, -0.2);
    m.set_lighting(&s, &NoProgress).unwrap();
    s.area_lights[0].size *= 1.3;
    m.set_lighting(&s, &NoProgress).unwrap();
    s.area_lights[0].texture = None;
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!(
        m.bakes(),
        1,
        "moves, scales and texture edits keep the bake"
    );
    assert_ne!(before, m.vertex_colors()[1]);
    s.area_lights[0].world_from_light = glam::Mat3::from_cols(Vec3::Z, -Vec3::X, -Vec3::Y);
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!(m.bakes(), 2, "a turned light re-bakes");
}

#[test]
fn refusals_name_the_problem() {
    assert!(matches!(
        NearfieldMethod::new(NearfieldOptions {
            order: 24,
            ..NearfieldOptions::default()
        }),
        Err(MethodError::InvalidOption {
            option: "order",
            ..
        })
    ));
    assert!(matches!(
        NearfieldMethod::new(NearfieldOptions {
            target_terms: 0.0,
            ..NearfieldOptions::default()
        }),
        Err(MethodError::InvalidOption {
            option: "target-terms",
            ..
        })
    ));
    let mut s = small(false);
    s.area_lights.push(s.area_lights[0].clone());
    let mut m = NearfieldMethod::new(NearfieldOptions::default()).unwrap();
    let e = m.prepare(&s, &NoProgress).unwrap_err().to_string();
    assert!(e.contains("one area light"), "{e}");
    let mut s = small(false);
    s.env = relight_sphere::EnvMap::from_fn(
        relight_sphere::Param::LatLong {
            width: 8,
            height: 4,
        },
        |_| Vec3::ONE,
    );
    let e = m.prepare(&s, &NoProgress).unwrap_err();
    assert!(matches!(e, MethodError::Unsupported { .. }), "{e}");
}
