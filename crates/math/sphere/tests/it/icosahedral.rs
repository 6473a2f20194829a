//! Tests of the icosahedral geodesic hierarchy: exact areas (checked by
//! Monte Carlo hit counting), point location, parent/child structure.

use crate::common;

use common::Rng;
use glam::DVec3;
use relight_sphere::icosahedral::spherical_triangle_area;
use relight_sphere::{Icosahedral, IcosahedralError};
use std::f64::consts::PI;
use std::sync::OnceLock;

fn hierarchy() -> &'static Icosahedral {
    static H: OnceLock<Icosahedral> = OnceLock::new();
    H.get_or_init(|| Icosahedral::new(7).unwrap())
}

#[test]
fn counts_and_structure() {
    let h = hierarchy();
    assert_eq!(h.max_level(), 7);
    assert_eq!(Icosahedral::triangle_count(7), 327_680);
    assert_eq!(h.vertices().len(), Icosahedral::vertex_count(7));
    for l in 0..=7 {
        let tris = h.triangles(l);
        assert_eq!(tris.len(), Icosahedral::triangle_count(l), "level {l}");
        let vmax = tris.iter().flatten().copied().max().unwrap() as usize;
        assert_eq!(
            vmax + 1,
            Icosahedral::vertex_count(l),
            "level {l} uses a vertex prefix"
        );
        for (i, t) in tris.iter().enumerate() {
            let [a, b, c] = t.map(|v| h.vertices()[v as usize]);
            assert!(a.dot(b.cross(c)) > 0.0, "level {l} triangle {i} not CCW");
        }
    }
    // Children share the parent's corners and the edge midpoints.
    for l in 0..7 {
        for i in (0..h.triangles(l).len()).step_by(37) {
            let [a, b, c] = h.triangle(l, i);
            let k = Icosahedral::children(i);
            assert!(k.iter().all(|&c| Icosahedral::parent(c) == i));
            assert_eq!(h.triangle(l + 1, k[0])[0], a);
            assert_eq!(h.triangle(l + 1, k[1])[1], b);
            assert_eq!(h.triangle(l + 1, k[2])[2], c);
            let mab = (a + b).normalize();
            assert!((h.triangle(l + 1, k[3])[2] - mab).length() < 1e-15);
        }
    }
    for v in h.vertices() {
        assert!((v.length() - 1.0).abs() < 1e-15);
    }
}

#[test]
fn areas_sum_to_four_pi_at_every_level() {
    let h = hierarchy();
    for l in 0..=7 {
        let areas = h.areas(l);
        let sum: f64 = areas.iter().sum();
        let rel = (sum - 4.0 * PI).abs() / (4.0 * PI);
        assert!(
            rel < 1e-6,
            "level {l}: Σ area = {sum}, want 4π (rel {rel:e})"
        );
        assert!(
            rel < 1e-12,
            "level {l}: Σ area = {sum}, want 4π (rel {rel:e})"
        );
        // Children sum to their parent.
        if l > 0 {
            let parents = h.areas(l - 1);
            for (i, p) in parents.iter().enumerate().step_by(11) {
                let s: f64 = Icosahedral::children(i).iter().map(|&c| areas[c]).sum();
                assert!(
                    (s - p).abs() < 1e-14,
                    "level {l}: children of {i} sum {s} vs {p}"
                );
            }
        }
    }
    // Level 0: twenty equal triangles of area 4π/20.
    for a in h.areas(0) {
        assert!((a - PI / 5.0).abs() < 1e-14, "icosahedron face area {a}");
    }
}

#[test]
fn octant_triangle_area() {
    let a = spherical_triangle_area(DVec3::X, DVec3::Y, DVec3::Z);
    assert!((a - PI / 2.0).abs() < 1e-15, "octant area {a}");
}

/// Second way: areas against Monte Carlo hit counts, with containment by
/// brute-force edge tests (independent of `locate`).
#[test]
fn areas_match_monte_carlo_hit_counts() {
    let h = hierarchy();
    let mut rng = Rng(0x1c05);
    let n = 1_000_000usize;
    let level = 2;
    let probe = [0usize, 3, 77, 163, 250, 319];
    let mut hits = [0u64; 6];
    for _ in 0..n {
        let d = rng.sphere();
        for (k, &i) in probe.iter().enumerate() {
            if h.contains(level, i, d, 0.0) {
                hits[k] += 1;
            }
        }
    }
    for (k, &i) in probe.iter().enumerate() {
        let frac = h.area(level, i) / (4.0 * PI);
        let est = hits[k] as f64 / n as f64;
        let sigma = (frac * (1.0 - frac) / n as f64).sqrt();
        assert!(
            (est - frac).abs() < 5.0 * sigma,
            "level {level} triangle {i}: Monte Carlo {est} vs exact {frac} (5σ {})",
            5.0 * sigma
        );
    }
    // The centre child is larger than a corner child (areas are not equal).
    assert!(h.area(1, 3) > h.area(1, 0));
}

#[test]
fn locate_finds_containing_triangle() {
    let h = hierarchy();
    let mut rng = Rng(5);
    let mut path = [0usize; 8];
    let locators: Vec<_> = (0..=7).map(|l| h.locator(l).unwrap()).collect();
    assert_eq!(locators[3].level(), 3);
    for _ in 0..20_000 {
        let d = rng.sphere();
        h.locate_path(d, 7, &mut path);
        for l in 0..=7 {
            let i = path[l];
            let w = h.barycentric(l, i, d);
            assert!(
                w.min_element() >= -1e-12,
                "level {l}: {d} not in triangle {i} (bary {w})"
            );
            if l > 0 {
                assert_eq!(Icosahedral::parent(i), path[l - 1]);
            }
        }
        assert_eq!(h.locate(d * 2.5, 7), path[7], "non-normalised direction");
        for (l, loc) in locators.iter().enumerate() {
            assert_eq!(loc.locate(d * 2.5), path[l], "locator, level {l}");
        }
    }
}

#[test]
fn locate_is_robust_on_vertices_and_edges() {
    let h = hierarchy();
    let mut rng = Rng(11);
    // Every vertex, and points exactly on (and a hair off) edges of level 7.
    let mut probes: Vec<DVec3> = h.vertices().to_vec();
    probes.extend([DVec3::X, DVec3::NEG_Y, DVec3::Z, DVec3::new(1.0, 1.0, 1.0)]);
    for _ in 0..5_000 {
        let i = (rng.next_u64() % 327_680) as usize;
        let [a, b, _] = h.triangle(7, i);
        let t = rng.f64();
        let e = (a * (1.0 - t) + b * t).normalize();
        probes.push(e);
        probes.push((e + a.cross(b) * 1e-17).normalize());
    }
    // The tabulated locator answers as `locate` on the same hard probes.
    let locators = [0, 3, 7].map(|l| h.locator(l).unwrap());
    for d in probes {
        for (l, loc) in [0, 3, 7].into_iter().zip(&locators) {
            let i = h.locate(d, l);
            assert_eq!(loc.locate(d), i, "locator, level {l}, {d}");
            let w = h.barycentric(l, i, d);
            assert!(
                w.min_element() >= -1e-12,
                "level {l}: {d} not in triangle {i} (bary {w})"
            );
            assert!(h.contains(l, i, d, 1e-12));
        }
    }
}

/// The weighted locator answers `locate`'s triangle and `barycentric`'s
/// weights whatever its hint (the last answer, as per pixel; a random
/// triangle; one out of range), on random directions and the hard probes
/// (vertices, points on and a hair off edges) — except on an edge, where a
/// hint that also holds the direction may stand, with the same weights on
/// the shared corners and 0 on the others.
#[test]
fn hinted_lookups_are_locates() {
    let h = hierarchy();
    let mut rng = Rng(23);
    let mut probes: Vec<DVec3> = h.vertices().to_vec();
    probes.extend([DVec3::X, DVec3::Y, DVec3::Z, DVec3::NEG_Y]);
    for _ in 0..5_000 {
        probes.push(rng.sphere());
        let i = (rng.next_u64() % 1280) as usize;
        let [a, b, _] = h.triangle(3, i);
        let e = (a * 0.3 + b * 0.7).normalize();
        probes.push(e);
        probes.push((e + a.cross(b) * 1e-17).normalize());
        // A walk of small steps, as along a row of pixels.
        let s = rng.sphere();
        probes.extend((0..8).map(|k| (s + a * (0.01 * f64::from(k))).normalize()));
    }
    let weight_of = |level: usize, i: usize, v: u32, w: DVec3| {
        let t = h.triangles(level)[i];
        t.into_iter()
            .zip([w.x, w.y, w.z])
            .find(|&(k, _)| k == v)
            .map_or(0.0, |(_, x)| x)
    };
    for level in [0, 3, 5] {
        let weights = h.weights(level).unwrap();
        assert_eq!(weights.level(), level);
        let count = Icosahedral::triangle_count(level) as u64;
        let (mut last, mut hits, mut on_edges) = (0, 0, 0);
        for &d in &probes {
            let i = h.locate(d, level);
            let want = h.barycentric(level, i, d);
            let before = last;
            let mut random = (rng.next_u64() % count) as usize;
            let mut out = usize::MAX;
            for hint in [&mut last, &mut random, &mut out] {
                let (j, w) = weights.locate(d * 1.7, hint);
                assert_eq!(*hint, j);
                assert!((w.x + w.y + w.z - 1.0).abs() < 1e-12);
                assert!(w.min_element() >= -1e-9, "{w}");
                if j == i {
                    assert!((w - want).abs().max_element() < 1e-12, "{w} vs {want}");
                    continue;
                }
                // Another triangle: only where `d` is on their shared edge.
                on_edges += 1;
                assert!(want.min_element() < 1e-9, "level {level}, {d}: {j} for {i}");
                for v in h.triangles(level)[i]
                    .into_iter()
                    .chain(h.triangles(level)[j])
                {
                    let (a, b) = (weight_of(level, i, v, want), weight_of(level, j, v, w));
                    assert!((a - b).abs() < 1e-9, "corner {v}: {a} vs {b}");
                }
            }
            hits += usize::from(before == i);
        }
        // The walks keep their triangle most steps (the hint pays), and
        // some probes sat on edges.
        assert!(hits * 4 > probes.len(), "level {level}: {hits} hits");
        assert!(on_edges > 0, "level {level}");
    }
    assert!(h.weights(8).is_err());
}

#[test]
fn errors_for_levels_too_deep() {
    assert_eq!(
        Icosahedral::new(8).unwrap_err(),
        IcosahedralError::LevelTooDeep { level: 8, max: 7 }
    );
    let h = Icosahedral::new(2).unwrap();
    assert!(h.try_locate(DVec3::Z, 3).is_err());
    assert!(h.locator(3).is_err());
    assert!(h.try_triangles(3).is_err());
    assert_eq!(h.try_locate(DVec3::Z, 2).unwrap(), h.locate(DVec3::Z, 2));
    let msg = h.try_locate(DVec3::Z, 5).unwrap_err().to_string();
    assert!(msg.contains("level 5") && msg.contains("0..=2"), "{msg}");
}
