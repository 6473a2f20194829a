//! Fixed-view specular transport (topic `specular`, `relight_nearfield::specular`):
//! the cell rule against brute-force quadrature, the method per vertex
//! against face-clipped quadrature (one channel and RGB), the RGB kernel
//! against the dense propagation, blends, the camera's place in the bake,
//! and Lambertian scenes' bakes unchanged bit for bit.

use glam::{DVec3, Vec2, Vec3};
use relight_affine::standard::propagate_two_step;
use relight_brdf::{Brdf, Ggx, Lambert, Mix, Phong};
use relight_nearfield::cache::{BakeKey, DIFFUSE_BAKE_VERSION, save};
use relight_nearfield::face::LightFrame;
use relight_nearfield::light::{LightCoeffs, light_cells};
use relight_nearfield::scenes::{floor_and_sphere, glossy_floor_and_sphere};
use relight_nearfield::specular::{
    BrdfClass, ObjectKind, SpecularScratch, SpecularVertex, VertexBrdf, classify, local_view,
    specular_cells, vertex_frame,
};
use relight_nearfield::transport::bake_transport;
use relight_nearfield::verify_specular::{face_quadrature_brdf, vertex_brdf, vertex_errors};
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::{FrameRequest, Relighter};
use relight_render::texture::Texture;
use relight_render::{BrdfBlend, NoProgress, Scene};
use std::sync::Arc;

fn full() -> NearfieldOptions {
    NearfieldOptions {
        source_terms: 1.0,
        target_terms: 1.0,
        ..NearfieldOptions::default()
    }
}

fn ggx(alpha: f32, f0: Vec3) -> Arc<dyn Brdf> {
    Arc::new(Ggx::isotropic(alpha, f0).unwrap())
}

/// Classification: Lambert, a tinted lobe, a coloured mixture.
#[test]
fn brdfs_are_classified() {
    let l = Lambert::new(Vec3::new(0.5, 0.4, 0.3)).unwrap();
    match classify(&l) {
        BrdfClass::Lambertian(a) => assert!((a - Vec3::new(0.5, 0.4, 0.3)).length() < 1e-5),
        c => panic!("{c:?}"),
    }
    let p = Phong::new(30.0, Vec3::new(0.6, 0.3, 0.3)).unwrap();
    match classify(&p) {
        BrdfClass::Tinted(t) => {
            assert!((t.element_sum() - 3.0).abs() < 1e-4, "{t}");
            assert!((t.x / t.y - 2.0).abs() < 1e-4, "{t}");
        }
        c => panic!("{c:?}"),
    }
    let base: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::new(0.8, 0.2, 0.1)).unwrap());
    let mix = Mix::new(vec![(0.5, base), (0.5, ggx(0.2, Vec3::splat(0.9)))]).unwrap();
    assert_eq!(classify(&mix), BrdfClass::Coloured);
}

/// The nested cell rule (3 × 3 midpoints, split where the nine-point mean
/// and the centre differ by > 0.2 % of the largest cell, up to 27 × 27, the
/// mirror's cells split) against 48 × 48 midpoints in every cell, order
/// 32, face 4: worst cell within 0.1 % of the largest cell and the sum
/// within 0.1 % (measured ≤ 2.5e-4 and ≤ 7.1e-4), for sharp and broad lobes
/// at normal and grazing views; the plain 3 × 3 rule is printed.
#[test]
fn cell_rule_matches_quadrature() {
    let s = floor_and_sphere(8, 8, 32, 24, false);
    let frame = LightFrame::of(&s.area_lights[0]);
    let (n, face, q) = (32usize, 4.0f64, 48usize);
    let a = frame.axes;
    // The vertex below the light's centre; `up` (−ẑ) points at the light.
    let up = -a.z_axis;
    let p = frame.center + a.z_axis * 1.2;
    let cases: [(Arc<dyn Brdf>, Vec3, Vec3); 4] = [
        (
            ggx(0.08, Vec3::splat(0.9)),
            up,
            (up + 0.4 * a.x_axis).normalize(),
        ),
        (
            ggx(0.3, Vec3::new(0.9, 0.6, 0.3)),
            up,
            (up - 0.8 * a.y_axis).normalize(),
        ),
        (
            Arc::new(Phong::new(400.0, Vec3::ONE).unwrap()),
            (up + 0.3 * a.x_axis).normalize(),
            (up + 0.2 * a.y_axis).normalize(),
        ),
        (
            Arc::new(Phong::new(8.0, Vec3::ONE).unwrap()),
            (up + 0.9 * a.x_axis).normalize(),
            (0.2 * up - a.x_axis).normalize(),
        ),
    ];
    for (ci, (brdf, nrm, to_eye)) in cases.iter().enumerate() {
        let shading = vertex_frame(*nrm, None);
        let eye = p + *to_eye * 3.0;
        let v = SpecularVertex {
            p,
            shading,
            wo: local_view(&shading, p, eye),
            brdf: VertexBrdf {
                first: brdf.as_ref(),
                second: None,
            },
        };
        let mut got = vec![DVec3::ZERO; n * n];
        specular_cells(
            &frame,
            &v,
            n,
            face,
            None,
            &mut SpecularScratch::default(),
            &mut got,
        );
        let h = 1.0 / (n * q) as f64;
        let (mut worst, mut sum_g, mut sum_w, mut top) = (0.0f64, 0.0, 0.0, 0.0f64);
        let mut want = vec![0.0f64; n * n];
        let mut naive_worst = 0.0f64;
        for y in 0..n {
            for x in 0..n {
                let mut acc = 0.0;
                for j in 0..q {
                    for i in 0..q {
                        let tx = (x * q + i) as f64 * h + 0.5 * h;
                        let ty = (y * q + j) as f64 * h + 0.5 * h;
                        acc += lobe(&frame, face, &v, tx, ty);
                    }
                }
                let w = acc / (q * q) as f64 * face * face;
                want[y * n + x] = w;
                top = top.max(w);
                let mut naive = 0.0;
                for j in 0..3 {
                    for i in 0..3 {
                        naive += lobe(
                            &frame,
                            face,
                            &v,
                            (x as f64 + (i as f64 + 0.5) / 3.0) / n as f64,
                            (y as f64 + (j as f64 + 0.5) / 3.0) / n as f64,
                        );
                    }
                }
                let naive = naive / 9.0 * face * face;
                naive_worst = naive_worst.max((naive - w).abs());
            }
        }
        for (g, w) in got.iter().zip(&want) {
            let g = g.element_sum();
            worst = worst.max((g - w).abs() / top);
            sum_g += g;
            sum_w += w;
        }
        println!(
            "case {ci}: worst cell {worst:.2e} of the largest (plain 3 × 3: {:.2e}), sum {:.2e}",
            naive_worst / top,
            (sum_g - sum_w).abs() / sum_w
        );
        assert!(top > 0.0, "case {ci}: the lobe reaches the face");
        assert!(worst < 1e-3, "case {ci}: worst cell {worst} of the largest");
        assert!(
            (sum_g - sum_w).abs() < 1e-3 * sum_w,
            "case {ci}: {sum_g} vs {sum_w}"
        );
    }
}

/// The integrand summed over channels, as the rule sees it.
fn lobe(frame: &LightFrame, face: f64, v: &SpecularVertex, tx: f64, ty: f64) -> f64 {
    let d = frame.face_dir((face * (tx - 0.5)) as f32, (face * (ty - 0.5)) as f32);
    let len = d.length();
    let wi = v.shading.to_local(d / len);
    if wi.z <= 0.0 {
        return 0.0;
    }
    f64::from(v.brdf.eval(v.wo, wi).element_sum() * wi.z / (len * len * len))
}

fn boxed(scene: &Scene, n: usize) -> impl Fn(Vec2) -> Vec3 + Sync {
    let cells = light_cells(&scene.area_lights[0], n);
    move |uv: Vec2| {
        let x = ((uv.x * n as f32) as usize).min(n - 1);
        let y = ((uv.y * n as f32) as usize).min(n - 1);
        let k = y * n + x;
        Vec3::new(cells[0][k] as f32, cells[1][k] as f32, cells[2][k] as f32)
    }
}

/// Uncompressed, the glossy scene (RGB sphere, one-channel floor) per
/// vertex against face-clipped quadrature of the box light with the BRDF
/// at each vertex's fixed view, unshadowed. With the transport at twice
/// the light's order (the light exact in its basis, as the Lambertian
/// verify row) only the cell rule's error is left: worst lit vertex
/// ≤ 0.5 %, pooled ≤ 0.2 % (measured 0.18 % / 0.08 %). At the default
/// order the discretisation `∫ (L − P L)(T − P T)` adds the floor's
/// reflected texture detail inside cells: ≤ 5 % / 2 % (measured 3.2 % /
/// 1.3 %).
#[test]
fn glossy_vertices_match_face_quadrature() {
    let s = glossy_floor_and_sphere(10, 12, 32, 24, false);
    let frame = LightFrame::of(&s.area_lights[0]);
    let light = boxed(&s, 32);
    for (order, worst, pooled) in [(64, 0.005, 0.002), (32, 0.05, 0.02)] {
        let mut m = NearfieldMethod::new(NearfieldOptions {
            order,
            light_order: Some(32),
            ..full()
        })
        .unwrap();
        m.prepare(&s, &NoProgress).unwrap();
        let kinds = m.kinds();
        assert_eq!(kinds[0], ObjectKind::Specular { tint: None }, "RGB sphere");
        assert!(
            matches!(kinds[1], ObjectKind::Specular { tint: Some(_) }),
            "{:?}",
            kinds[1]
        );
        assert_eq!(m.transports()[0].channels, 3);
        assert_eq!(m.transports()[1].channels, 1);
        for (oi, o) in s.objects.iter().enumerate() {
            let (mut got, mut want) = (Vec::new(), Vec::new());
            for v in (0..o.mesh.positions.len()).step_by(3) {
                let p = o.mesh.positions[v];
                if frame.local(p).z <= 0.0 {
                    continue;
                }
                let shading = vertex_frame(o.mesh.normals[v], None);
                let wo = local_view(&shading, p, s.camera.eye);
                want.push(face_quadrature_brdf(
                    &frame,
                    4.0,
                    p,
                    &shading,
                    wo,
                    vertex_brdf(o, v),
                    160,
                    &light,
                    None,
                ));
                got.push(m.vertex_colors()[oi][v]);
            }
            let (max, rms) = vertex_errors(&got, &want);
            println!(
                "order {order}, object {oi}: worst {max:.4}, pooled {rms:.4} over {} vertices",
                got.len()
            );
            assert!(
                max < worst && rms < pooled,
                "order {order}, object {oi}: worst {max}, pooled {rms}"
            );
        }
    }
}

/// The RGB kernel at 100 %/100 % equals the dense two-step propagation of
/// each channel dotted with that channel's transport.
#[test]
fn rgb_kernel_equals_dense_propagation() {
    let s = glossy_floor_and_sphere(6, 8, 32, 24, false);
    let n = 8;
    let mut m = NearfieldMethod::new(NearfieldOptions { order: n, ..full() }).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    let light = &s.area_lights[0];
    let frame = LightFrame::of(light);
    let coeffs = LightCoeffs::of(light, n);
    let t = m.transports()[0];
    assert_eq!(t.channels, 3);
    let mesh = &s.objects[0].mesh;
    let nn = n * n;
    let mut checked = 0;
    for v in (0..mesh.positions.len()).step_by(5) {
        let Some((sc, o)) = frame.affine(frame.local(mesh.positions[v]), 4.0) else {
            continue;
        };
        let mut want = Vec3::ZERO;
        for c in 0..3 {
            let mut l = vec![0.0; nn];
            propagate_two_step(&coeffs.c[c], n, sc, o, &mut l);
            let tc = &t.values[(v * 3 + c) * nn..(v * 3 + c + 1) * nn];
            want[c] = l
                .iter()
                .zip(tc)
                .map(|(a, b)| a * f64::from(*b))
                .sum::<f64>() as f32;
        }
        let want = want.max(Vec3::ZERO);
        let got = m.vertex_colors()[0][v];
        assert!(
            (got - want).length() <= 1e-4 * want.length() + 1e-7,
            "v {v}: {got} vs {want}"
        );
        checked += 1;
    }
    assert!(checked > 5);
}

/// A blend by a constant-weight texture shades as the equivalent mixture,
/// and a blend of two Lambertian BRDFs stays on the Lambertian path with the
/// albedo blended per vertex.
#[test]
fn blends_shade_as_their_mixture() {
    let mut a = floor_and_sphere(6, 8, 32, 24, false);
    let w = 0.25;
    let lam: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::new(0.7, 0.5, 0.3)).unwrap());
    let gl = ggx(0.3, Vec3::splat(0.8));
    a.objects[0].brdf = lam.clone();
    a.objects[0].blend = Some(BrdfBlend {
        second: gl.clone(),
        weight: Arc::new(Texture::constant(Vec3::splat(w)).unwrap()),
    });
    let mut b = a.clone();
    b.objects[0].blend = None;
    b.objects[0].brdf = Arc::new(Mix::new(vec![(1.0 - w, lam.clone()), (w, gl)]).unwrap());
    let (mut ma, mut mb) = (
        NearfieldMethod::new(full()).unwrap(),
        NearfieldMethod::new(full()).unwrap(),
    );
    ma.prepare(&a, &NoProgress).unwrap();
    mb.prepare(&b, &NoProgress).unwrap();
    let top = mb.vertex_colors()[0]
        .iter()
        .map(|c| c.max_element())
        .fold(0.0f32, f32::max);
    for (x, y) in ma.vertex_colors()[0].iter().zip(&mb.vertex_colors()[0]) {
        assert!((*x - *y).abs().max_element() <= 1e-4 * top, "{x} vs {y}");
    }
    // Two Lambertian BRDFs: the Lambertian transport, albedo per vertex.
    let mut c = floor_and_sphere(6, 8, 32, 24, false);
    let second: Arc<dyn Brdf> = Arc::new(Lambert::new(Vec3::new(0.1, 0.2, 0.9)).unwrap());
    c.objects[1].blend = Some(BrdfBlend {
        second,
        weight: Arc::new(Texture::constant(Vec3::splat(0.5)).unwrap()),
    });
    let mut mc = NearfieldMethod::new(full()).unwrap();
    mc.prepare(&c, &NoProgress).unwrap();
    assert!(matches!(mc.kinds()[1], ObjectKind::DiffuseBlend { .. }));
    let plain = floor_and_sphere(6, 8, 32, 24, false);
    let mut mp = NearfieldMethod::new(full()).unwrap();
    mp.prepare(&plain, &NoProgress).unwrap();
    assert_eq!(mc.transports()[1].values, mp.transports()[1].values);
    let blended = (Vec3::splat(0.7) + Vec3::new(0.1, 0.2, 0.9)) * 0.5;
    for (x, y) in mc.vertex_colors()[1].iter().zip(&mp.vertex_colors()[1]) {
        let want = *y / 0.7 * blended;
        assert!((*x - want).abs().max_element() <= 1e-5 * (1.0 + want.max_element()));
    }
}

/// The camera's eye is part of a fixed-view bake: a frame from another
/// camera keeps the bake (and says so), a scene whose camera moved re-bakes
/// the fixed-view objects only — to exactly what a fresh prepare gives.
/// Lambertian scenes ignore the eye.
#[test]
fn the_camera_moves_the_fixed_view() {
    let mut s = glossy_floor_and_sphere(6, 8, 32, 24, true);
    s.objects[1].brdf = Arc::new(Lambert::new(Vec3::splat(0.6)).unwrap());
    let mut m = NearfieldMethod::new(NearfieldOptions {
        order: 16,
        ..full()
    })
    .unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    assert_eq!(m.bakes(), 1);
    let w = m.warnings().join("\n");
    assert!(w.contains("fixed-view") && w.contains("eye"), "{w}");
    assert!(!w.contains("Lambertian with albedo"), "{w}");
    // The viewer's orbit: another camera per frame, no re-bake.
    let mut cam = s.camera;
    cam.eye = Vec3::new(-2.5, 1.5, 2.0);
    m.render(&s, &FrameRequest::new(cam), &NoProgress).unwrap();
    assert_eq!(m.bakes(), 1);
    assert!(!m.view_is_baked());
    m.render(&s, &FrameRequest::new(s.camera), &NoProgress)
        .unwrap();
    assert!(m.view_is_baked());
    // The scene's camera moved: the sphere re-bakes, the floor keeps its own.
    let floor_before = m.transports()[1].values.clone();
    let key_before = m.bake_key().unwrap().clone();
    s.camera = cam;
    m.set_lighting(&s, &NoProgress).unwrap();
    assert_eq!(m.bakes(), 2);
    assert_eq!(m.baked_eye(), Some(cam.eye));
    assert_ne!(m.bake_key().unwrap(), &key_before, "the eye is in the key");
    assert_eq!(m.transports()[1].values, floor_before);
    let mut fresh = NearfieldMethod::new(NearfieldOptions {
        order: 16,
        ..full()
    })
    .unwrap();
    fresh.prepare(&s, &NoProgress).unwrap();
    assert_eq!(fresh.transports()[0].values, m.transports()[0].values);
    assert_eq!(fresh.vertex_colors(), m.vertex_colors());
    // Lambertian only: the eye is not in the key and moves re-bake nothing.
    let mut d = floor_and_sphere(6, 8, 32, 24, false);
    let frame = LightFrame::of(&d.area_lights[0]);
    let k = BakeKey::of(&d, &frame, 16, 4.0);
    let mut md = NearfieldMethod::new(NearfieldOptions {
        order: 16,
        ..full()
    })
    .unwrap();
    md.prepare(&d, &NoProgress).unwrap();
    d.camera.eye = cam.eye;
    assert_eq!(BakeKey::of(&d, &frame, 16, 4.0), k);
    md.set_lighting(&d, &NoProgress).unwrap();
    assert_eq!(md.bakes(), 1);
    assert!(md.view_is_baked() && md.baked_eye().is_none());
    // A BRDF change is another key.
    let mut g = glossy_floor_and_sphere(6, 8, 32, 24, true);
    let k1 = BakeKey::of(&g, &frame, 16, 4.0);
    g.objects[0].brdf = ggx(0.3, Vec3::splat(0.9));
    assert_ne!(BakeKey::of(&g, &frame, 16, 4.0), k1);
}

/// The key and file of a Lambertian scene as they were before fixed-view
/// transport (the rules of version 1, restated here as the spec): same
/// hash, same name, and the file holds exactly the Lambertian bake's values.
#[test]
fn diffuse_bake_files_are_unchanged() {
    let s = floor_and_sphere(6, 8, 32, 24, true);
    let frame = LightFrame::of(&s.area_lights[0]);
    let (n, face) = (16usize, 4.0f64);
    let key = BakeKey::of(&s, &frame, n, face);
    assert_eq!(key.params[7], DIFFUSE_BAKE_VERSION);
    assert_eq!(key.params[7], 1);
    // Version 1's hash: FNV-1a 64 over version, n, face bits, visibility,
    // axes, centre, then per object the count, positions, normals and,
    // with shadows, the triangle count and indices.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut feed = |b: &[u8]| {
        for x in b {
            h ^= u64::from(*x);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    feed(&1u32.to_le_bytes());
    feed(&(n as u64).to_le_bytes());
    feed(&face.to_bits().to_le_bytes());
    feed(&[1]);
    for x in frame
        .axes
        .to_cols_array()
        .iter()
        .chain(&frame.center.to_array())
    {
        feed(&x.to_bits().to_le_bytes());
    }
    for o in &s.objects {
        let m = &o.mesh;
        feed(&(m.positions.len() as u64).to_le_bytes());
        for p in m.positions.iter().chain(&m.normals) {
            for x in p.to_array() {
                feed(&x.to_bits().to_le_bytes());
            }
        }
        feed(&(m.indices.len() as u64).to_le_bytes());
        for t in &m.indices {
            for i in t {
                feed(&i.to_le_bytes());
            }
        }
    }
    assert_eq!((key.params[4], key.params[5]), (h as u32, (h >> 32) as u32));
    assert!(key.file_name().contains("-v1-"), "{}", key.file_name());
    // The method's bake is the Lambertian bake, and the file its bytes.
    let mut m = NearfieldMethod::new(NearfieldOptions { order: n, ..full() }).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    assert!(m.warnings().is_empty(), "{:?}", m.warnings());
    let meshes: Vec<_> = s.objects.iter().map(|o| o.mesh.as_ref()).collect();
    let bvh = relight_render::SceneBvh::build(&meshes);
    for (o, t) in s.objects.iter().zip(m.transports()) {
        let want = bake_transport(
            &frame,
            &o.mesh.positions,
            &o.mesh.normals,
            n,
            face,
            Some(&bvh),
            &NoProgress,
        )
        .unwrap();
        assert_eq!(t.values, want.values);
        assert_eq!(t.channels, 1);
    }
    let dir = std::env::temp_dir().join(format!("relight-nf-v1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(key.file_name());
    save(&path, &key, &m.transports()).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let payload: Vec<u8> = m
        .transports()
        .iter()
        .flat_map(|t| t.values.iter().flat_map(|x| x.to_le_bytes()))
        .collect();
    assert_eq!(bytes.len(), 64 + payload.len());
    assert_eq!(&bytes[64..], &payload[..]);
    assert_eq!(&bytes[..8], b"RLNFTRN1");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The fixed-view bake of `verify nearfield`'s glossy scene (floor 65² Phong,
/// sphere 48 segments GGX over diffuse, shadows, order 32). A timing, not a
/// check: `cargo test --release -p relight-nearfield --test it -- --ignored
/// --nocapture glossy_bake_time`.
#[test]
#[ignore = "a timing (seconds in release), not a check"]
fn glossy_bake_time() {
    let s = glossy_floor_and_sphere(64, 48, 64, 48, true);
    let verts: usize = s.objects.iter().map(|o| o.mesh.positions.len()).sum();
    let mut m = NearfieldMethod::new(NearfieldOptions::default()).unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    println!(
        "fixed-view bake, {verts} vertices with shadows: {:.1} s ({:.2} ms per vertex, wall)",
        m.specular_bake_s,
        m.specular_bake_s * 1e3 / verts as f64
    );
    assert!(m.specular_bake_s > 0.0);
    // The Lambertian bake of the same scene, for comparison.
    let d = floor_and_sphere(64, 48, 64, 48, true);
    let mut l = NearfieldMethod::new(NearfieldOptions::default()).unwrap();
    let t = std::time::Instant::now();
    l.prepare(&d, &NoProgress).unwrap();
    let bake = t.elapsed().as_secs_f64() - l.last_times.iter().sum::<f64>() * 1e-3;
    println!(
        "Lambertian bake, same vertices: {bake:.1} s ({:.2} ms per vertex, wall)",
        bake * 1e3 / verts as f64
    );
}

/// A lobe narrower than a face cell is named in a warning (the method, the
/// object, the widths); a broad one is not.
#[test]
fn narrow_lobes_are_warned() {
    use relight_nearfield::specular::lobe_half_width_deg;
    let phong = |e: f32| Phong::new(e, Vec3::ONE).unwrap();
    // cos^e α = ½ at α = acos(2^{−1/e}).
    for e in [20.0f32, 400.0] {
        let want = 0.5f32.powf(1.0 / e).acos().to_degrees();
        let got = lobe_half_width_deg(&phong(e)).unwrap();
        assert!((got - want).abs() < 0.15, "Phong {e}: {got}° vs {want}°");
    }
    assert_eq!(lobe_half_width_deg(&Lambert::new(Vec3::ONE).unwrap()), None);
    let mut s = floor_and_sphere(4, 8, 32, 24, false);
    s.objects[0].brdf = Arc::new(phong(3000.0));
    s.objects[1].brdf = Arc::new(phong(20.0));
    let mut m = NearfieldMethod::new(NearfieldOptions {
        order: 16,
        ..full()
    })
    .unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    let w = m.warnings();
    let narrow: Vec<&String> = w
        .iter()
        .filter(|x| x.contains("narrower than a face cell"))
        .collect();
    assert_eq!(narrow.len(), 1, "{w:?}");
    assert!(
        narrow[0].starts_with("method nearfield: object 1's"),
        "{}",
        narrow[0]
    );
}
