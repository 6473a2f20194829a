//! Tests of the sphere parameterizations: exact solid angles (checked a
//! second way by Monte Carlo hit counting), round trips, seam continuity.

use crate::common;

use common::Rng;
use glam::{DVec2, DVec3, Vec3};
use relight_sphere::EnvMap;
use relight_sphere::param::{Param, ParamError};
use std::f64::consts::PI;

fn all_params() -> Vec<Param> {
    let mut v = Vec::new();
    for (w, h) in [
        (1, 1),
        (2, 1),
        (3, 5),
        (7, 3),
        (16, 8),
        (64, 32),
        (255, 128),
    ] {
        v.push(Param::LatLong {
            width: w,
            height: h,
        });
    }
    for n in [1, 2, 3, 5, 16, 33, 64] {
        v.push(Param::Cube { n });
    }
    for n in [1, 2, 3, 4, 7, 16, 31, 64, 128] {
        v.push(Param::Octahedral { n });
        v.push(Param::HemiOctahedral { n });
    }
    v
}

#[test]
fn solid_angles_sum_to_sphere_or_hemisphere() {
    for p in all_params() {
        let total: f64 = p.solid_angles_f64().iter().sum();
        let want = p.total_solid_angle();
        let rel = (total - want).abs() / want;
        assert!(rel < 1e-6, "{p:?}: Σ Ω = {total} want {want} (rel {rel:e})");
        // In practice they are exact to rounding.
        assert!(
            rel < 1e-12,
            "{p:?}: Σ Ω = {total} want {want} (rel {rel:e})"
        );
        assert!(
            (0..p.len()).all(|i| p.texel_solid_angle(i) > 0.0),
            "{p:?}: a texel has non-positive solid angle"
        );
    }
}

#[test]
fn sub_rectangle_solid_angles_add_up() {
    // Splitting a texel into 3×3 uv cells must conserve its solid angle
    // (exercises the polygon clipping of the octahedral maps on odd sizes).
    for p in [
        Param::Octahedral { n: 3 },
        Param::HemiOctahedral { n: 5 },
        Param::Cube { n: 3 },
        Param::LatLong {
            width: 6,
            height: 3,
        },
    ] {
        for i in 0..p.len() {
            let (lo, hi) = p.texel_uv_rect(i);
            let step = (hi - lo) / 3.0;
            let mut sum = 0.0;
            for y in 0..3 {
                for x in 0..3 {
                    let a = lo + step * DVec2::new(x as f64, y as f64);
                    sum += p.uv_rect_solid_angle(a, a + step);
                }
            }
            let want = p.texel_solid_angle(i);
            assert!(
                (sum - want).abs() < 1e-12,
                "{p:?} texel {i}: Σ cells {sum} vs {want}"
            );
        }
    }
}

/// Second way: per-texel solid angle against Monte Carlo hit counting
/// (uniform sphere samples binned with `texel_from_dir`).
#[test]
fn solid_angles_match_monte_carlo_hit_counts() {
    let mut rng = Rng(0x5eed_0001);
    let n_samples = 2_000_000usize;
    for p in [
        Param::LatLong {
            width: 8,
            height: 4,
        },
        Param::Cube { n: 2 },
        Param::Octahedral { n: 4 },
        Param::Octahedral { n: 3 },
        Param::HemiOctahedral { n: 4 },
        Param::HemiOctahedral { n: 3 },
    ] {
        let mut hits = vec![0u64; p.len()];
        for _ in 0..n_samples {
            let mut d = rng.sphere();
            if p.is_hemisphere() {
                d.z = d.z.abs();
            }
            hits[p.texel_from_dir_f64(d)] += 1;
        }
        let total = p.total_solid_angle();
        for (i, &h) in hits.iter().enumerate() {
            let frac = p.texel_solid_angle(i) / total;
            let est = h as f64 / n_samples as f64;
            let sigma = (frac * (1.0 - frac) / n_samples as f64).sqrt();
            assert!(
                (est - frac).abs() < 5.0 * sigma,
                "{p:?} texel {i}: Monte Carlo fraction {est} vs analytic {frac} (5σ = {})",
                5.0 * sigma
            );
        }
    }
}

#[test]
fn texel_round_trip_and_unit_directions() {
    for p in all_params() {
        for i in 0..p.len() {
            let d = p.dir_from_texel_f64(i);
            assert!(
                (d.length() - 1.0).abs() < 1e-12,
                "{p:?} texel {i}: |d| = {}",
                d.length()
            );
            assert_eq!(
                p.texel_from_dir_f64(d),
                i,
                "{p:?}: texel {i} → {d} → other texel"
            );
            assert_eq!(
                p.texel_from_dir(p.dir_from_texel(i)),
                i,
                "{p:?}: f32 round trip of {i}"
            );
            // A non-normalised direction maps to the same texel.
            assert_eq!(
                p.texel_from_dir_f64(d * 3.5),
                i,
                "{p:?}: scaled direction of {i}"
            );
        }
    }
}

#[test]
fn uv_round_trips() {
    let mut rng = Rng(42);
    for p in [
        Param::LatLong {
            width: 64,
            height: 32,
        },
        Param::Cube { n: 16 },
        Param::Octahedral { n: 16 },
        Param::HemiOctahedral { n: 16 },
    ] {
        for _ in 0..20_000 {
            // uv → dir → uv (identity away from the poles of the lat-long map,
            // where azimuth is undefined).
            let uv = rng.uv();
            let d = p.dir_from_uv(uv);
            let back = p.uv_from_dir(d);
            assert!((back - uv).length() < 1e-9, "{p:?}: uv {uv} → {d} → {back}");
            // dir → uv → dir.
            let mut d = rng.sphere();
            if p.is_hemisphere() {
                d.z = d.z.abs();
            }
            let back = p.dir_from_uv(p.uv_from_dir(d));
            assert!((back - d).length() < 1e-12, "{p:?}: dir {d} → {back}");
        }
    }
}

#[test]
fn documented_orientation() {
    let ll = Param::LatLong {
        width: 8,
        height: 4,
    };
    let at = |u: f64, v: f64| ll.dir_from_uv(DVec2::new(u, v));
    assert!((at(0.5, 0.0) - DVec3::Y).length() < 1e-12);
    assert!((at(0.0, 0.5) - DVec3::Z).length() < 1e-12);
    assert!((at(0.25, 0.5) - DVec3::NEG_X).length() < 1e-12);
    assert!((at(0.5, 0.5) - DVec3::NEG_Z).length() < 1e-12);
    assert!((at(0.75, 0.5) - DVec3::X).length() < 1e-12);
    assert!((at(0.3, 1.0) - DVec3::NEG_Y).length() < 1e-12);

    let oct = Param::Octahedral { n: 4 };
    let o = |x: f64, y: f64| oct.dir_from_uv(DVec2::new(x, y));
    assert!((o(0.5, 0.5) - DVec3::Z).length() < 1e-12);
    assert!((o(1.0, 0.5) - DVec3::X).length() < 1e-12);
    assert!((o(0.5, 0.0) - DVec3::NEG_Y).length() < 1e-12);
    for (x, y) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        assert!((o(x, y) - DVec3::NEG_Z).length() < 1e-12);
    }

    let hemi = Param::HemiOctahedral { n: 4 };
    let h = |x: f64, y: f64| hemi.dir_from_uv(DVec2::new(x, y));
    assert!((h(0.5, 0.5) - DVec3::Z).length() < 1e-12);
    assert!((h(1.0, 1.0) - DVec3::X).length() < 1e-12);
    assert!((h(0.0, 1.0) - DVec3::Y).length() < 1e-12);
    assert!((h(0.0, 0.0) - DVec3::NEG_X).length() < 1e-12);
    assert!((h(1.0, 0.0) - DVec3::NEG_Y).length() < 1e-12);
    assert!(h(0.5, 1.0).z.abs() < 1e-12, "square edge is the horizon");

    let cube = Param::Cube { n: 4 };
    for (face, axis) in [
        DVec3::X,
        DVec3::NEG_X,
        DVec3::Y,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ]
    .into_iter()
    .enumerate()
    {
        let centre = cube.dir_from_uv(DVec2::new(0.5, (face as f64 + 0.5) / 6.0));
        assert!(
            (centre - axis).length() < 1e-12,
            "cube face {face} centre {centre}"
        );
    }
}

#[test]
fn bilinear_weights_sum_to_one_and_interpolate_centres() {
    let mut rng = Rng(7);
    for p in all_params() {
        for _ in 0..500 {
            let b = p.bilinear_f64(rng.sphere());
            let s: f64 = b.weights.iter().sum();
            assert!((s - 1.0).abs() < 1e-12, "{p:?}: weights sum {s}");
            assert!(
                b.weights.iter().all(|&w| w >= -1e-15),
                "{p:?}: negative weight {b:?}"
            );
            assert!(
                b.texels.iter().all(|&t| t < p.len()),
                "{p:?}: texel out of range {b:?}"
            );
        }
        // At a texel centre the footprint is that texel alone.
        for i in (0..p.len()).step_by(p.len() / 50 + 1) {
            let b = p.bilinear_f64(p.dir_from_texel_f64(i));
            let w: f64 = (0..4)
                .filter(|&k| b.texels[k] == i)
                .map(|k| b.weights[k])
                .sum();
            assert!(
                (w - 1.0).abs() < 1e-9,
                "{p:?}: centre of {i} has own weight {w} ({b:?})"
            );
        }
    }
}

/// A smooth test function with gradient of order 1.
fn smooth(d: Vec3) -> Vec3 {
    let a = (1.3 * d.x + 0.4 * d.y - 0.9 * d.z).sin();
    let b = (d.x * d.y + 0.7 * d.z).exp();
    Vec3::new(1.0 + a, b, 0.5 + d.y * d.z + d.x)
}

/// `d ± ε t` straddle a seam through `s` (t ⟂ s): the two lookups must agree
/// to a tolerance far below what a discontinuity (≈ texel size × gradient)
/// would give; the tolerance shrinks with the resolution.
fn assert_straddle(map: &EnvMap, s: DVec3, t: DVec3, what: &str) {
    let eps = 1e-7;
    let t = (t - s * s.dot(t)).normalize();
    let a = map.eval((s + t * eps).normalize().as_vec3());
    let b = map.eval((s - t * eps).normalize().as_vec3());
    let h = (map.param.total_solid_angle() / map.param.len() as f64).sqrt() as f32;
    let tol = 0.01 * h;
    assert!(
        (a - b).abs().max_element() < tol,
        "{:?} {what}: across the seam at {s}: {a} vs {b} (tol {tol})",
        map.param
    );
}

#[test]
fn bilinear_is_continuous_across_every_seam() {
    let mut rng = Rng(99);
    for scale in [1usize, 4, 16] {
        // Lat-long: azimuth seam (u = 0) and both poles.
        let p = Param::LatLong {
            width: 16 * scale,
            height: 8 * scale,
        };
        let map = EnvMap::from_fn(p, smooth);
        for _ in 0..200 {
            let theta = 0.02 + (PI - 0.04) * rng.f64();
            let s = DVec3::new(0.0, theta.cos(), theta.sin());
            assert_straddle(&map, s, DVec3::X, "azimuth seam");
            let phi = std::f64::consts::TAU * rng.f64();
            let t = DVec3::new(phi.cos(), 0.0, phi.sin());
            assert_straddle(&map, DVec3::Y, t, "north pole");
            assert_straddle(&map, DVec3::NEG_Y, t, "south pole");
        }

        // Octahedral: the four outer edges fold onto themselves; corners are −Z.
        let p = Param::Octahedral { n: 8 * scale };
        let map = EnvMap::from_fn(p, smooth);
        let e = 1e-9;
        for _ in 0..200 {
            let v = rng.f64();
            for (a, b) in [
                (DVec2::new(1.0 - e, v), DVec2::new(1.0 - e, 1.0 - v)),
                (DVec2::new(e, v), DVec2::new(e, 1.0 - v)),
                (DVec2::new(v, 1.0 - e), DVec2::new(1.0 - v, 1.0 - e)),
                (DVec2::new(v, e), DVec2::new(1.0 - v, e)),
            ] {
                let (da, db) = (p.dir_from_uv(a), p.dir_from_uv(b));
                assert!(
                    (da - db).length() < 1e-6,
                    "seam pair not adjacent: {da} {db}"
                );
                let (la, lb) = (map.eval(da.as_vec3()), map.eval(db.as_vec3()));
                let tol = 0.01 * (2.0 / p.width() as f32);
                assert!(
                    (la - lb).abs().max_element() < tol,
                    "{p:?}: outer edge {a} vs {b}: {la} vs {lb}"
                );
            }
            // Random crossings of the equator and of the seam half-planes.
            let phi = std::f64::consts::TAU * rng.f64();
            let s = DVec3::new(phi.cos(), phi.sin(), 0.0);
            assert_straddle(&map, s, DVec3::Z, "equator (fold)");
            let th = PI / 2.0 + (PI / 2.0) * rng.f64();
            for axis in [0.0, 0.5 * PI, PI, 1.5 * PI] {
                let s = DVec3::new(th.sin() * axis.cos(), th.sin() * axis.sin(), th.cos());
                let t = DVec3::new(-axis.sin(), axis.cos(), 0.0);
                assert_straddle(&map, s, t, "outer edge");
            }
            let t = DVec3::new(phi.cos(), phi.sin(), 0.0);
            assert_straddle(&map, DVec3::NEG_Z, t, "−Z corner");
        }

        // Cube: all 12 edges and 8 corners.
        let p = Param::Cube { n: 8 * scale };
        let map = EnvMap::from_fn(p, smooth);
        let axes = [
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ];
        for a in axes {
            for b in axes {
                if a.dot(b) != 0.0 {
                    continue;
                }
                for _ in 0..30 {
                    let t = 2.0 * rng.f64() - 1.0;
                    let s = (a + b + a.cross(b) * t).normalize();
                    assert_straddle(&map, s, a - b, "cube edge");
                }
            }
        }
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    let s = DVec3::new(sx, sy, sz).normalize();
                    for _ in 0..30 {
                        let t = rng.sphere().cross(s);
                        assert_straddle(&map, s, t, "cube corner");
                    }
                }
            }
        }

        // Hemi-octahedral: no seam inside; the horizon is mirrored.
        let p = Param::HemiOctahedral { n: 8 * scale };
        let map = EnvMap::from_fn(p, smooth);
        for _ in 0..200 {
            let phi = std::f64::consts::TAU * rng.f64();
            let s = DVec3::new(phi.cos(), phi.sin(), 0.0);
            assert_straddle(&map, s, DVec3::Z, "horizon");
            let d = DVec3::new(rng.f64() - 0.5, rng.f64() - 0.5, 0.3).normalize();
            assert_straddle(&map, d, rng.sphere(), "interior (diagonal folds)");
        }
    }
}

#[test]
fn lat_long_pole_value_varies_only_at_second_order() {
    // Documented behaviour: at a pole the bilinear value depends on the
    // approach azimuth by O(Δθ²).
    let mut prev = f32::INFINITY;
    for scale in [1usize, 4, 16] {
        let p = Param::LatLong {
            width: 16 * scale,
            height: 8 * scale,
        };
        let map = EnvMap::from_fn(p, smooth);
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for k in 0..64 {
            let phi = k as f64 * std::f64::consts::TAU / 64.0;
            let d = DVec3::new(1e-9 * phi.cos(), 1.0, 1e-9 * phi.sin()).normalize();
            let v = map.eval(d.as_vec3());
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let spread = (hi - lo).max_element();
        let dtheta = (PI / p.height() as f64) as f32;
        assert!(
            spread < 2.0 * dtheta * dtheta,
            "{p:?}: pole spread {spread} (Δθ {dtheta})"
        );
        assert!(
            spread <= prev,
            "pole spread must shrink with resolution: {spread} after {prev}"
        );
        prev = spread;
    }
}

#[test]
fn validate_rejects_zero_sizes() {
    assert_eq!(
        Param::Octahedral { n: 0 }.validate(),
        Err(ParamError::ZeroSize {
            param: Param::Octahedral { n: 0 }
        })
    );
    assert!(
        Param::LatLong {
            width: 4,
            height: 0
        }
        .validate()
        .is_err()
    );
    let msg = Param::Cube { n: 0 }.validate().unwrap_err().to_string();
    assert!(msg.contains("Cube") && msg.contains("at least 1"), "{msg}");
    assert!(Param::Cube { n: 1 << 20 }.validate().is_err());
    assert!(Param::HemiOctahedral { n: 3 }.validate().is_ok());
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    fn any_param() -> impl Strategy<Value = Param> {
        prop_oneof![
            (1usize..40, 1usize..20).prop_map(|(w, h)| Param::LatLong {
                width: w,
                height: h
            }),
            (1usize..20).prop_map(|n| Param::Cube { n }),
            (1usize..40).prop_map(|n| Param::Octahedral { n }),
            (1usize..40).prop_map(|n| Param::HemiOctahedral { n }),
        ]
    }

    proptest! {
        /// The texel of a uv point and the texel of its direction agree, and
        /// the direction lies within the texel's corner bounds.
        #[test]
        fn texel_of_uv_matches_texel_of_direction(p in any_param(), u in 0.001f64..0.999, v in 0.001f64..0.999) {
            let uv = DVec2::new(u, v);
            let (w, h) = (p.width() as f64, p.height() as f64);
            // Stay off texel boundaries, where either neighbour is correct.
            let fx = (u * w).fract();
            let fy = (v * h).fract();
            prop_assume!(fx > 1e-6 && fx < 1.0 - 1e-6 && fy > 1e-6 && fy < 1.0 - 1e-6);
            let d = p.dir_from_uv(uv);
            prop_assert_eq!(p.texel_from_dir_f64(d), p.texel_from_uv(uv));
        }

        #[test]
        fn bilinear_weights_form_a_partition_of_unity(p in any_param(), x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
            let d = DVec3::new(x, y, z);
            prop_assume!(d.length() > 1e-3);
            let b = p.bilinear_f64(d);
            prop_assert!((b.weights.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            prop_assert!(b.texels.iter().all(|&t| t < p.len()));
        }
    }
}

/// The f32 lat-long path of `Param::bilinear` puts the same weight on every
/// texel as the f64 footprint, to f32 rounding of the position, including
/// directions on the seam (φ = 0), at the poles and on texel edges.
#[test]
fn latlong_bilinear_f32_matches_f64() {
    use std::collections::HashMap;
    let mut rng = Rng(11);
    for (w, h) in [
        (1, 1),
        (2, 1),
        (3, 5),
        (16, 8),
        (64, 32),
        (1024, 512),
        (4096, 2048),
    ] {
        let p = Param::LatLong {
            width: w,
            height: h,
        };
        let mut dirs: Vec<DVec3> = (0..2000).map(|_| rng.sphere()).collect();
        dirs.extend([
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::X,
            DVec3::new(0.0, 0.3, 1.0),
        ]);
        // Texel edges and centres.
        dirs.extend((0..200).map(|i| {
            let uv = DVec2::new((i % 20) as f64 / 20.0, (i / 20) as f64 / 10.0 + 0.01);
            p.dir_from_uv(uv)
        }));
        let mut worst = 0.0f64;
        for d in dirs {
            let d = d.normalize();
            let b32 = p.bilinear(d.as_vec3());
            let b64 = p.bilinear_f64(d);
            let mut diff: HashMap<usize, f64> = HashMap::new();
            for k in 0..4 {
                assert!((b32.texels[k] as usize) < p.len(), "{p:?} {d:?}: {b32:?}");
                *diff.entry(b32.texels[k] as usize).or_default() += f64::from(b32.weights[k]);
                *diff.entry(b64.texels[k]).or_default() -= b64.weights[k];
            }
            let moved: f64 = diff.values().map(|x| x.abs()).sum();
            assert!(moved < 2e-3, "{w}×{h}: {d:?}: {b32:?} vs {b64:?}");
            worst = worst.max(moved);
        }
        // A position error of ε texels moves at most 4ε of weight.
        assert!(worst < 2e-3, "{w}×{h}: weight moved {worst:e}");
    }
}
