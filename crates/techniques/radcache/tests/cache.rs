//! The radiance cache against the GI reference on a tiny glossy scene, the
//! rotation methods against each other, and the octree against brute force.

use glam::Vec3;
use relight_radcache::index::Octree;
use relight_radcache::verify::{glossy_scene, relative_rms};
use relight_radcache::{
    RadianceCacheOptions, RotationMethod, brdf_tables, render_radiance_cache,
    render_radiance_cache_with, validate,
};
use relight_render::reference::{GiOptions, render_gi_reference};
use relight_render::{NoProgress, ReferenceOptions};

fn opts(error: f32, rotation: RotationMethod) -> RadianceCacheOptions {
    RadianceCacheOptions {
        error,
        rotation,
        record_rays_side: 10,
        spp: 2,
        ..RadianceCacheOptions::default()
    }
}

#[test]
fn cache_follows_the_gi_reference_and_improves_as_a_falls() {
    let scene = glossy_scene(24, 18);
    let gi = GiOptions {
        reference: ReferenceOptions {
            spp: 48,
            ..ReferenceOptions::default()
        },
        ..GiOptions::default()
    };
    let reference = render_gi_reference(&scene, &gi, &NoProgress).unwrap();
    let tables = brdf_tables(&scene, 6);
    let mut errs = vec![];
    for a in [0.5, 0.15] {
        let o = RadianceCacheOptions {
            spp: 48,
            ..opts(a, RotationMethod::Taylor15)
        };
        let r = render_radiance_cache(&scene, &scene.camera, &o, &tables, 0, &NoProgress).unwrap();
        // Same seed and samples: the direct image is the reference's own.
        assert_eq!(r.direct.pixels, reference.direct.pixels);
        errs.push((
            a,
            r.stats.records,
            relative_rms(&r.indirect, &reference.indirect),
        ));
    }
    eprintln!(
        "a, records, rel RMS vs GI reference (48 spp, σ {:.3}): {errs:?}",
        reference.indirect_rms_relative_std_error
    );
    assert!(errs[1].1 > errs[0].1, "more records at smaller a");
    assert!(
        errs[1].2 < 0.6,
        "indirect within 60 % RMS of a 2-spp reference: {}",
        errs[1].2
    );
}

#[test]
fn exact_rotations_agree_and_taylor_beats_ignoring() {
    let scene = glossy_scene(20, 15);
    let tables = brdf_tables(&scene, 6);
    let run = |m| {
        render_radiance_cache(
            &scene,
            &scene.camera,
            &opts(0.3, m),
            &tables,
            0,
            &NoProgress,
        )
        .unwrap()
    };
    let exact = run(RotationMethod::Ivanic);
    let zyz = relative_rms(&run(RotationMethod::Zyz).indirect, &exact.indirect);
    let t15 = run(RotationMethod::Taylor15);
    let taylor = relative_rms(&t15.indirect, &exact.indirect);
    let ignore = relative_rms(&run(RotationMethod::Ignore).indirect, &exact.indirect);
    eprintln!(
        "vs Ivanic: zyz {zyz:.2e}, taylor1.5 {taylor:.2e}, ignore {ignore:.2e}; exact share {}/{}",
        t15.stats.exact_rotations, t15.stats.rotations
    );
    assert!(zyz < 1e-4, "{zyz}");
    assert!(taylor < ignore, "taylor {taylor} vs ignore {ignore}");
    assert!(t15.stats.rotations > 0);
}

#[test]
fn octree_finds_every_ball_brute_force_finds() {
    let mut t = Octree::new(Vec3::ZERO, 1.0);
    let mut balls = vec![];
    let mut s = 1u64;
    let mut rnd = || {
        s = relight_render::sampling::splitmix64(s);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    for i in 0..300 {
        let p = Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0;
        let r = 0.01 + 0.3 * rnd() * rnd();
        t.insert(i, p, r);
        balls.push((p, r));
    }
    for _ in 0..300 {
        let q = Vec3::new(rnd(), rnd(), rnd()) * 2.2 - 1.1;
        let mut found = vec![];
        t.for_each_near(q, |i| found.push(i));
        for (i, (p, r)) in balls.iter().enumerate() {
            if (q - *p).length() < *r {
                assert!(found.contains(&(i as u32)), "ball {i} missed at {q}");
            }
        }
    }
}

#[test]
fn bad_options_name_their_flag() {
    let e = validate(&RadianceCacheOptions {
        error: 0.0,
        ..Default::default()
    })
    .unwrap_err();
    assert!(e.to_string().starts_with("--error"), "{e}");
    let e = validate(&RadianceCacheOptions {
        order: 40,
        ..Default::default()
    })
    .unwrap_err();
    assert!(e.to_string().starts_with("--order"), "{e}");
    assert!("taylor3".parse::<RotationMethod>().is_err());
    assert_eq!(
        "taylor15".parse::<RotationMethod>(),
        Ok(RotationMethod::Taylor15)
    );
}

#[test]
fn lambert_table_reflects_uniform_light_by_its_albedo() {
    let b = relight_brdf::Lambert::new(Vec3::new(0.2, 0.5, 0.8)).unwrap();
    for order in [6, 10] {
        let t = relight_radcache::brdf_sh::BrdfSh::new(&b, order);
        let nn = order * order;
        // Uniform radiance 1 over the sphere: λ₀₀ = 2√π, all else 0.
        let mut lambda = vec![0.0f32; 3 * nn];
        for c in 0..3 {
            lambda[c * nn] = 2.0 * std::f32::consts::PI.sqrt();
        }
        for cos in [1.0, 0.7, 0.2] {
            let l = t.shade(cos, &lambda);
            assert!(
                (l - Vec3::new(0.2, 0.5, 0.8)).abs().max_element() < 2e-3,
                "order {order} cos {cos}: {l}"
            );
        }
    }
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    let scene = glossy_scene(16, 12);
    let tables = brdf_tables(&scene, 6);
    let o = opts(0.3, RotationMethod::Taylor15);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                render_radiance_cache(&scene, &scene.camera, &o, &tables, 0, &NoProgress).unwrap()
            })
    };
    let (a, b) = (run(1), run(3));
    assert_eq!(a.stats.records, b.stats.records);
    assert_eq!(a.indirect.pixels, b.indirect.pixels);
}

#[test]
fn reused_records_reproduce_the_render() {
    let scene = glossy_scene(16, 12);
    let tables = brdf_tables(&scene, 6);
    let o = opts(0.3, RotationMethod::Zyz);
    let first = render_radiance_cache(&scene, &scene.camera, &o, &tables, 0, &NoProgress).unwrap();
    let again = render_radiance_cache_with(
        &scene,
        &scene.camera,
        &o,
        &tables,
        0,
        Some(&first.records),
        &NoProgress,
    )
    .unwrap();
    assert_eq!(again.stats.records, first.stats.records);
    assert_eq!(again.stats.wasted_records, 0);
    assert_eq!(again.indirect.pixels, first.indirect.pixels);
}

#[test]
fn exact_rotation_share_is_constant_across_a_on_a_curved_surface() {
    use relight_radcache::verify::exact_share_on_sphere;
    let curved: Vec<f64> = [0.4, 0.1]
        .iter()
        .map(|&a| exact_share_on_sphere(0.02, a, 6).unwrap())
        .collect();
    eprintln!("share at r/R = 0.02, a = 0.4, 0.1: {curved:?}");
    assert!(curved.iter().all(|&s| s > 0.05), "{curved:?}");
    assert!(curved[0] / curved[1] < 1.25 && curved[1] / curved[0] < 1.25);
    assert_eq!(exact_share_on_sphere(0.15, 0.2, 6).unwrap(), 0.0);
}
