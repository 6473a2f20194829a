#![allow(clippy::needless_range_loop)]

//! The lane kernel (`relight_shexp::lanes`) against the per-vertex path it
//! replaces: accumulation, squaring, every exponential, every compiled path,
//! and whole frames of the method.

use glam::Vec3;
use relight_render::method::Relighter;
use relight_render::{NoProgress, Rng};
use relight_sh::product::TripleProduct;
use relight_shexp::accumulate::{Scratch, add_blocker_log, zonal_rotation_factors};
use relight_shexp::lanes::{LaneBlocker, LaneKernel, LanePath, LaneReceivers, LaneScratch, W};
use relight_shexp::verify_scene::{floor_scene, floor_spheres, sky};
use relight_shexp::{
    ExpKind, Exponentiator, Kernel, LogTable, OlFit, ShExpMethod, ShExpOptions, SquaringHistogram,
};

fn paths() -> Vec<LanePath> {
    LanePath::ALL
        .into_iter()
        .filter(|p| p.supported())
        .collect()
}

/// Receivers on a patch with tilted normals, blockers around them (some
/// below the tangent planes, one receiver inside a sphere).
fn setup(rng: &mut Rng) -> (LaneReceivers, Vec<LaneBlocker>, Vec<(Vec3, Vec3)>) {
    let mut rec = LaneReceivers::default();
    let mut pn = Vec::new();
    for j in 0..W {
        let p = Vec3::new(
            rng.next_f32() * 2.0 - 1.0,
            0.1 * rng.next_f32(),
            rng.next_f32() * 2.0 - 1.0,
        );
        let n = Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5).normalize();
        rec.set(j, p, n);
        pn.push((p, n));
    }
    let mut blockers: Vec<LaneBlocker> = (0..40)
        .map(|_| LaneBlocker {
            c: [
                (rng.next_f32() - 0.5) * 6.0,
                -0.5 + 3.0 * rng.next_f32(),
                (rng.next_f32() - 0.5) * 6.0,
            ],
            r: 0.05 + 0.4 * rng.next_f32(),
        })
        .collect();
    let (p3, _) = pn[3];
    blockers.push(LaneBlocker {
        c: (p3 + Vec3::new(0.05, 0.02, 0.0)).to_array(),
        r: 0.2,
    });
    (rec, blockers, pn)
}

/// The table coordinate from `sin θ` equals `tan(θ/2)` of `θ = asin(sin θ)`
/// (f64), over [0, 1].
#[test]
fn tan_half_of_sin_matches_tan_of_half_asin() {
    let mut worst = 0.0f64;
    for i in 0..=100_000 {
        let x = i as f32 / 100_000.0;
        let want = (0.5 * f64::from(x).asin()).tan();
        worst = worst.max((f64::from(relight_shexp::log_table::tan_half_of_sin(x)) - want).abs());
    }
    assert!(worst < 2e-7, "tan(θ/2) error {worst}");
}

#[test]
fn lane_accumulation_matches_the_per_vertex_logs() {
    for n in [2, 3, 4, 5, 6, 8] {
        let table = LogTable::with_defaults(n).unwrap();
        let k = LaneKernel::new(&table, OlFit::fit(&table)).unwrap();
        let factors = zonal_rotation_factors(n);
        let mut scr = Scratch::new(n);
        let mut rng = Rng::new(7 + n as u64, 0);
        let (rec, blockers, pn) = setup(&mut rng);
        for path in paths() {
            let mut fl = vec![[0.0f32; W]; n * n];
            let any = k.accumulate_on(path, &rec, &blockers, &mut fl);
            for (j, &(p, nrm)) in pn.iter().enumerate() {
                let mut f = vec![0.0f32; n * n];
                let mut seen = false;
                for b in &blockers {
                    let d = Vec3::from(b.c) - p;
                    if d.dot(nrm) <= -b.r {
                        continue;
                    }
                    seen = true;
                    let dist = d.length();
                    let theta = if dist <= b.r {
                        std::f32::consts::FRAC_PI_2
                    } else {
                        (b.r / dist).asin()
                    };
                    add_blocker_log(
                        &table,
                        &factors,
                        theta,
                        (d / dist).to_array(),
                        &mut scr,
                        &mut f,
                    );
                }
                assert_eq!(any & (1 << j) != 0, seen, "n = {n}, lane {j}");
                let scale = f.iter().map(|v| v.abs()).fold(1.0f32, f32::max);
                for i in 0..n * n {
                    assert!(
                        (fl[i][j] - f[i]).abs() <= 2e-5 * scale,
                        "{path:?} n = {n} lane {j} coefficient {i}: {} vs {}",
                        fl[i][j],
                        f[i]
                    );
                }
            }
        }
    }
}

#[test]
fn lane_square_matches_the_product_tensor() {
    for n in [2, 4, 6, 8] {
        let table = LogTable::new(n, 4, 0.02).unwrap();
        let k = LaneKernel::new(&table, OlFit::fit(&table)).unwrap();
        let tp = TripleProduct::<f64>::new(n).unwrap();
        let mut rng = Rng::new(n as u64, 0);
        let fl: Vec<[f32; W]> = (0..n * n)
            .map(|_| std::array::from_fn(|_| rng.next_f32() - 0.5))
            .collect();
        let mut out = vec![[0.0f32; W]; n * n];
        k.square(&fl, &mut out);
        for j in 0..W {
            let f: Vec<f64> = fl.iter().map(|l| f64::from(l[j])).collect();
            let mut want = vec![0.0; n * n];
            tp.square(&f, &mut want);
            for i in 0..n * n {
                assert!(
                    (f64::from(out[i][j]) - want[i]).abs() < 1e-5,
                    "n = {n}, {i}: {} vs {}",
                    out[i][j],
                    want[i]
                );
            }
        }
    }
}

#[test]
fn lane_exponentials_match_the_exponentiator() {
    for n in [3, 4, 6] {
        let table = LogTable::with_defaults(n).unwrap();
        let ol = OlFit::fit(&table);
        let k = LaneKernel::new(&table, ol.clone()).unwrap();
        let mut e = Exponentiator::<f32>::new(n, ol).unwrap();
        let factors = zonal_rotation_factors(n);
        let mut scr = Scratch::new(n);
        let mut rng = Rng::new(40 + n as u64, 0);
        // Per lane a sum of 0…30 random caps: norms from 0 to past the cap.
        let mut fl = vec![[0.0f32; W]; n * n];
        for j in 0..W {
            let mut f = vec![0.0f32; n * n];
            let caps = if j == 5 { 0 } else { 2 * j };
            for _ in 0..caps {
                let th = 0.05 + 0.9 * rng.next_f32();
                let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32(), rng.next_f32() - 0.5)
                    .normalize();
                add_blocker_log(&table, &factors, th, d.to_array(), &mut scr, &mut f);
            }
            for i in 0..n * n {
                fl[i][j] = f[i];
            }
        }
        let any = !(1u32 << 5) & ((1 << W) - 1);
        for kind in [
            ExpKind::PsStar(2),
            ExpKind::PsStar(3),
            ExpKind::PsStar(4),
            ExpKind::Hyb,
            ExpKind::Ol,
        ] {
            for path in paths() {
                let mut s = LaneScratch::new(n);
                let mut gl = vec![[0.0f32; W]; n * n];
                let mut hist = SquaringHistogram::new();
                k.exp_on(path, kind, &fl, any, W - 2, &mut s, &mut gl, &mut hist);
                let mut want_hist = SquaringHistogram::new();
                for j in 0..W {
                    let f: Vec<f32> = fl.iter().map(|l| l[j]).collect();
                    let mut g = vec![0.0f32; n * n];
                    if any & (1 << j) != 0 {
                        let (sq, capped) = e.exp(kind, &f, &mut g);
                        if j < W - 2 {
                            want_hist.counts[sq as usize] += 1;
                            want_hist.capped += u64::from(capped);
                        }
                    } else {
                        g[0] = (4.0 * std::f32::consts::PI).sqrt();
                    }
                    let scale = g.iter().map(|v| v.abs()).fold(1e-3f32, f32::max);
                    for i in 0..n * n {
                        assert!(
                            (gl[i][j] - g[i]).abs() <= 1e-4 * scale,
                            "{path:?} {kind:?} n = {n} lane {j} coefficient {i}: {} vs {}",
                            gl[i][j],
                            g[i]
                        );
                    }
                }
                assert_eq!(hist, want_hist, "{path:?} {kind:?} n = {n}");
            }
        }
    }
}

#[test]
fn frames_by_the_lane_kernel_match_the_per_vertex_kernel() {
    let scene = floor_scene(floor_spheres(), sky(), 24);
    for exp in [ExpKind::PsStar(2), ExpKind::Hyb] {
        let mut m = ShExpMethod::new(ShExpOptions {
            exp,
            bake_strata: 3,
            flat_receiver_vertices: 3000,
            ..ShExpOptions::default()
        })
        .unwrap();
        m.prepare(&scene, &NoProgress).unwrap();
        m.shade_vertices_with(&scene, Kernel::PerVertex).unwrap();
        let want = m.vertex_colors().to_vec();
        let hist_want = m.take_histogram();
        m.shade_vertices_with(&scene, Kernel::Lanes).unwrap();
        assert_eq!(m.take_histogram(), hist_want, "{exp:?}");
        let got = m.vertex_colors();
        let mut worst = 0.0f32;
        for (a, b) in got.iter().flatten().zip(want.iter().flatten()) {
            worst = worst.max((*a - *b).abs().max_element() / b.max_element().max(1e-3));
        }
        assert!(worst < 1e-4, "{exp:?}: worst relative difference {worst}");
    }
}

/// Every compiled accumulation against the portable one, on receivers close
/// together (table entries within 32: the AVX-512 path's permute lookup) and
/// spread out (its gathers), with a receiver at a blocker's centre (d = 0)
/// and on a sphere's surface: the fast paths' `rsqrt14` + Newton step and
/// lookups must agree with plain division and square roots within the
/// per-vertex test's tolerance (the tangent sphere puts θ near 90°, where
/// `asin` magnifies an ulp of `r/d`).
#[test]
fn compiled_accumulations_match_the_portable_path() {
    for n in [2, 3, 4, 5, 6, 7] {
        let table = LogTable::with_defaults(n).unwrap();
        let k = LaneKernel::new(&table, OlFit::fit(&table)).unwrap();
        for (case, spread) in [0.02f32, 0.3, 3.0].into_iter().enumerate() {
            let mut rng = Rng::new(100 + n as u64, case as u64);
            let (_, mut blockers, _) = setup(&mut rng);
            let mut rec = LaneReceivers::default();
            for j in 0..W {
                let p = Vec3::new(
                    spread * (rng.next_f32() - 0.5),
                    0.0,
                    spread * (rng.next_f32() - 0.5),
                );
                let nrm = Vec3::new(0.3 * (rng.next_f32() - 0.5), 1.0, 0.0).normalize();
                rec.set(j, p, nrm);
            }
            let p0 = Vec3::new(rec.p[0][0], rec.p[1][0], rec.p[2][0]);
            let p1 = Vec3::new(rec.p[0][1], rec.p[1][1], rec.p[2][1]);
            blockers.push(LaneBlocker {
                c: p0.to_array(),
                r: 0.1,
            });
            blockers.push(LaneBlocker {
                c: (p1 + Vec3::Y * 0.25).to_array(),
                r: 0.25,
            });
            let mut want = vec![[0.0f32; W]; n * n];
            let any_want = k.accumulate_on(LanePath::Portable, &rec, &blockers, &mut want);
            for path in paths() {
                let mut got = vec![[0.0f32; W]; n * n];
                let any = k.accumulate_on(path, &rec, &blockers, &mut got);
                assert_eq!(any, any_want, "{path:?} n = {n} case {case}");
                for j in 0..W {
                    let scale = want.iter().map(|v| v[j].abs()).fold(1.0f32, f32::max);
                    for i in 0..n * n {
                        assert!(
                            got[i][j].is_finite() && (got[i][j] - want[i][j]).abs() <= 2e-5 * scale,
                            "{path:?} n = {n} case {case} lane {j} coefficient {i}: {} vs {}",
                            got[i][j],
                            want[i][j]
                        );
                    }
                }
            }
        }
    }
}
