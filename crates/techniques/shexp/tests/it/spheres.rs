//! Sphere-set fitting and the hierarchy.

use relight_geom::shapes::{torus, uv_sphere_at};
use relight_shexp::spheres::{FitOptions, Sphere, SphereSet, fit_spheres};

fn covers(set: &SphereSet, p: glam::Vec3) -> bool {
    set.spheres
        .iter()
        .any(|s| s.c().distance(p) <= s.radius * (1.0 + 1e-4) + 1e-5)
}

#[test]
fn a_sphere_mesh_is_fitted_by_itself() {
    let m = uv_sphere_at(glam::Vec3::new(1.0, 2.0, 3.0), 0.5, 48, 24);
    let s = fit_spheres(&m, &FitOptions::default()).unwrap();
    assert_eq!(s.spheres.len(), 1, "{:?}", s.spheres);
    let c = s.spheres[0];
    assert!(
        (c.c() - glam::Vec3::new(1.0, 2.0, 3.0)).length() < 0.01,
        "{c:?}"
    );
    assert!((c.radius - 0.5).abs() < 0.01, "{c:?}");
}

#[test]
fn torus_sets_cover_every_vertex_and_the_hierarchy_nests() {
    let m = torus(1.0, 0.3, 64, 24);
    for k in [4, 16, 32] {
        let s = fit_spheres(
            &m,
            &FitOptions {
                spheres: k,
                ..FitOptions::default()
            },
        )
        .unwrap();
        assert!(
            s.spheres.len() <= k && s.spheres.len() >= k / 2,
            "{k}: {}",
            s.spheres.len()
        );
        for p in &m.positions {
            assert!(covers(&s, *p), "{k} spheres: vertex {p} uncovered");
        }
        // Tighter with more spheres: the largest radius shrinks.
        let rmax = s.spheres.iter().map(|s| s.radius).fold(0.0, f32::max);
        assert!(
            rmax < 1.5 * (1.3 / (k as f32).sqrt()).max(0.35),
            "{k}: {rmax}"
        );
        // Every node encloses every leaf sphere below it, and is no larger than
        // the sphere enclosing its two children; leaves are all reached once.
        fn leaves_under(s: &SphereSet, i: usize, out: &mut Vec<usize>) {
            match s.nodes[i].children {
                Some([a, b]) => {
                    leaves_under(s, a as usize, out);
                    leaves_under(s, b as usize, out);
                }
                None => out.push(s.nodes[i].leaf.unwrap() as usize),
            }
        }
        let mut seen = vec![0; s.spheres.len()];
        for (i, n) in s.nodes.iter().enumerate() {
            let mut under = Vec::new();
            leaves_under(&s, i, &mut under);
            // The proxy, from the leaves directly: r²-weighted centre, √Σr².
            let w: f64 = under
                .iter()
                .map(|&l| f64::from(s.spheres[l].radius).powi(2))
                .sum();
            let c = under
                .iter()
                .map(|&l| s.spheres[l].c().as_dvec3() * f64::from(s.spheres[l].radius).powi(2))
                .sum::<glam::DVec3>()
                / w;
            assert!((f64::from(n.proxy.radius) - w.sqrt()).abs() <= 1e-5 * w.sqrt());
            assert!(n.proxy.c().as_dvec3().distance(c) <= 1e-5 * (1.0 + c.length()));
            if n.leaf.is_some() {
                assert_eq!(n.proxy, n.sphere);
            }
            for l in under {
                let ch = s.spheres[l];
                let d = n.sphere.c().distance(ch.c());
                assert!(d + ch.radius <= n.sphere.radius * (1.0 + 1e-4) + 1e-5);
            }
            if let Some([a, b]) = n.children {
                let nested = relight_shexp::Sphere::enclosing(
                    &s.nodes[a as usize].sphere,
                    &s.nodes[b as usize].sphere,
                );
                assert!(n.sphere.radius <= nested.radius * (1.0 + 1e-5));
            }
            if let Some(l) = n.leaf {
                seen[l as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
        // The root is within 5 % of the ball about the torus' centre (the
        // origin) that encloses the leaves, not the compounded enclosure of
        // halves.
        let about_origin = s
            .spheres
            .iter()
            .map(|l| l.c().length() + l.radius)
            .fold(0.0, f32::max);
        assert!(
            s.nodes[0].sphere.radius <= 1.05 * about_origin,
            "{k}: root {} vs {about_origin}",
            s.nodes[0].sphere.radius
        );
        assert!(s.depth() <= 2 + (s.spheres.len() as f32).log2().ceil() as usize * 2);
        let json = serde_json::to_string(&s).unwrap();
        let back: SphereSet = serde_json::from_str(&json).unwrap();
        assert_eq!(back, s);
    }
}

#[test]
fn enclosing_two_spheres_is_exact() {
    let a = Sphere {
        center: [0.0, 0.0, 0.0],
        radius: 1.0,
    };
    let b = Sphere {
        center: [3.0, 0.0, 0.0],
        radius: 0.5,
    };
    let e = Sphere::enclosing(&a, &b);
    assert!(
        (e.radius - 2.25).abs() < 1e-6 && (e.center[0] - 1.25).abs() < 1e-6,
        "{e:?}"
    );
    assert_eq!(
        Sphere::enclosing(
            &a,
            &Sphere {
                center: [0.2, 0.0, 0.0],
                radius: 0.3
            }
        ),
        a
    );
}

#[test]
fn bad_input_is_an_error() {
    let m = torus(1.0, 0.3, 8, 6);
    assert!(
        fit_spheres(
            &m,
            &FitOptions {
                spheres: 0,
                ..FitOptions::default()
            }
        )
        .is_err()
    );
    let mut e = m.clone();
    e.indices.clear();
    assert!(fit_spheres(&e, &FitOptions::default()).is_err());
}
