//! `bench_sh`: single-threaded timings of every SH operation (f32), for
//! `relight bench sh`.
//!
//! Each figure is the minimum over several batches of the mean time per call
//! within a batch (`std::time::Instant`, inputs and outputs through
//! `std::hint::black_box` or the peer kit's `opaque`/`escape` asm barriers, inputs cycled over a set of random rotations /
//! vectors so nothing is hoisted). `ns_build` is the per-rotation setup
//! (matrix construction for Ivanic–Ruedenberg, the ZYZ decomposition for the
//! others; 0 where none), `ns_apply` the application to one coefficient vector,
//! `ns_total` both together in one loop (what a per-pixel rotation costs).

use crate::basis::eval_sh_into;
use crate::product::{ExpMethod, ShExp, TripleProduct, log_sh};
use crate::project::LatLongProjector;
use crate::rotation::{
    EulerZyz, IvanicRuedenberg, Rot3, ShRotation, ZyzRotation, rotate_z, rotate_zonal,
};
use crate::taylor::{TaylorOrder, TaylorRotation};
use std::hint::black_box;
use std::time::Instant;

/// One benchmark row (flat, serialisable).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ShBenchRow {
    /// `ivanic_ruedenberg`, `zyz`, `taylor1`, `taylor15`, `taylor2`, `z`, `zonal`,
    /// `eval`, `eval_array`, `eval_recurrence`, `product`, `square`, `exp_ps*4`, `exp_hyb`, `log`, `project_latlong`.
    pub method: String,
    /// Number of bands n (n² coefficients).
    pub order: usize,
    /// Construction per rotation (ns), 0 where none.
    pub ns_build: f64,
    /// One application / evaluation (ns).
    pub ns_apply: f64,
    /// Build + apply measured together (ns).
    pub ns_total: f64,
    /// Free-form remark (sizes, µs for projection).
    pub note: String,
}

/// Which f32 rotation kernel runs at order `n` on this CPU (`min`: the
/// smallest order of the method's vectorised kernel).
fn kernel_note(n: usize, min: usize) -> &'static str {
    if (min..=crate::simd::SIMD_MAX_ORDER).contains(&n) && crate::simd::available() {
        "AVX-512 kernel"
    } else {
        "portable code"
    }
}

/// The input barrier of the peer kit's C++ harness (`opaque` in
/// `shared/peers/harness/common.h`): the compiler must assume the returned
/// reference may point anywhere, so nothing is hoisted out of the timed loop,
/// and the value is not copied through the stack as `black_box(value)` does
/// (that copy is a store and a reload per call, ~1 ns against a 3 ns
/// evaluation, which DirectXMath's harness does not pay).
#[inline(always)]
#[allow(clippy::pointers_in_nomem_asm_block)] // the asm only launders the pointer, as the kit's `"+r"(p)`
fn opaque<T>(p: &T) -> &T {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    {
        let mut q = std::ptr::from_ref(p);
        // SAFETY: an empty asm block that only claims to change `q`.
        unsafe {
            std::arch::asm!("/* {0} */", inout(reg) q, options(nomem, nostack, preserves_flags))
        };
        // SAFETY: `q` is still `p`.
        unsafe { &*q }
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    black_box(p)
}

/// The output barrier of the kit's harness (`escape`): the compiler must
/// assume everything reachable from `p` is read here, so the timed call's
/// stores stay, without storing the reference itself as `black_box(&v)` does.
#[inline(always)]
fn escape<T: ?Sized>(p: &T) {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    // SAFETY: an empty asm block (it may read memory: no `nomem`).
    unsafe {
        std::arch::asm!("/* {0} */", in(reg) std::ptr::from_ref(p).cast::<u8>(), options(nostack, preserves_flags));
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    black_box(p);
}

fn time_ns(reps: usize, batches: usize, mut f: impl FnMut(usize)) -> f64 {
    // Short batches (≈ reps/50 calls), many of them, minimum taken: on a shared
    // machine the minimum of short batches is the uncontended cost.
    let per = (reps / 50).max(1);
    let mut best = f64::INFINITY;
    let mut i = 0usize;
    for _ in 0..batches * 50 {
        let t = Instant::now();
        for _ in 0..per {
            f(i);
            i = i.wrapping_add(1);
        }
        best = best.min(t.elapsed().as_nanos() as f64 / per as f64);
    }
    best
}

fn rng(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed.wrapping_mul(0x9E3779B97F4A7C15) | 1;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    }
}

const SET: usize = 64;

fn rotations(small_beta: bool) -> Vec<Rot3<f32>> {
    let mut r = rng(5);
    (0..SET)
        .map(|_| {
            let (a, b, g) = (r() * 6.0, r() + 0.5, r() * 6.0);
            let b = if small_beta { b * 0.4 } else { b * 2.5 };
            Rot3::from_euler_zyz(&EulerZyz::from_angles(a, b, g))
        })
        .collect()
}

fn vectors(n: usize) -> Vec<Vec<f32>> {
    let mut r = rng(9);
    (0..SET)
        .map(|_| (0..n * n).map(|_| r()).collect())
        .collect()
}

fn row(
    method: &str,
    order: usize,
    ns_build: f64,
    ns_apply: f64,
    ns_total: f64,
    note: String,
) -> ShBenchRow {
    ShBenchRow {
        method: method.to_string(),
        order,
        ns_build,
        ns_apply,
        ns_total,
        note,
    }
}

/// [`crate::eval_sh_array_into`] at order `n ≤ 8` (one instantiation per
/// order, the order a compile-time constant as in a caller that fixes it).
fn time_eval_array(n: usize, reps: usize, batches: usize, dirs: &[[f32; 3]]) -> Option<f64> {
    fn t<const NN: usize>(reps: usize, batches: usize, dirs: &[[f32; 3]]) -> f64 {
        // On the heap, as the other rows' outputs (and the kit's).
        let mut out = Box::new([0.0f32; NN]);
        let o = &mut *out;
        time_ns(reps, batches, |i| {
            crate::eval_sh_array_into(*opaque(&dirs[i % SET]), o);
            escape(&o[..]);
        })
    }
    Some(match n {
        1 => t::<1>(reps, batches, dirs),
        2 => t::<4>(reps, batches, dirs),
        3 => t::<9>(reps, batches, dirs),
        4 => t::<16>(reps, batches, dirs),
        5 => t::<25>(reps, batches, dirs),
        6 => t::<36>(reps, batches, dirs),
        7 => t::<49>(reps, batches, dirs),
        8 => t::<64>(reps, batches, dirs),
        _ => return None,
    })
}

/// Runs all benchmarks. `quick` cuts repetitions ~50× (a smoke test, noisy).
#[must_use]
pub fn bench_sh(quick: bool) -> Vec<ShBenchRow> {
    let (reps, batches) = if quick { (200, 2) } else { (20_000, 5) };
    let mut rows = Vec::new();
    let rots = rotations(false);
    let small = rotations(true);
    for n in 2..=10 {
        let nn = n * n;
        let vs = vectors(n);
        let mut dst = vec![0.0f32; nn];
        let mut scratch = vec![0.0f32; nn];

        // Ivanic–Ruedenberg.
        let plan = IvanicRuedenberg::<f32>::new(n).expect("order");
        let mut m = ShRotation::identity(n).expect("order");
        let b = time_ns(reps, batches, |i| {
            plan.build(opaque(&rots[i % SET]), &mut m)
        });
        black_box(&m);
        let a = time_ns(reps, batches, |i| {
            m.apply(opaque(&vs[i % SET]).as_slice(), &mut dst);
            escape(&dst[..]);
        });
        let t = time_ns(reps, batches, |i| {
            plan.build(opaque(&rots[i % SET]), &mut m);
            m.apply(opaque(&vs[i % SET]).as_slice(), &mut dst);
            escape(&dst[..]);
        });
        rows.push(row("ivanic_ruedenberg", n, b, a, t, String::new()));

        // ZYZ ("ZXZXZ").
        let zyz = ZyzRotation::<f32>::new(n).expect("order");
        let eul: Vec<EulerZyz<f32>> = rots.iter().map(|r| r.euler_zyz()).collect();
        let b = time_ns(reps, batches, |i| {
            black_box(opaque(&rots[i % SET]).euler_zyz());
        });
        let a = time_ns(reps, batches, |i| {
            zyz.apply_euler(
                opaque(&eul[i % SET]),
                opaque(&vs[i % SET]).as_slice(),
                &mut dst,
                &mut scratch,
            );
            escape(&dst[..]);
        });
        let t = time_ns(reps, batches, |i| {
            zyz.apply(
                opaque(&rots[i % SET]),
                opaque(&vs[i % SET]).as_slice(),
                &mut dst,
                &mut scratch,
            );
            escape(&dst[..]);
        });
        rows.push(row(
            "zyz",
            n,
            b,
            a,
            t,
            format!(
                "{} non-zeros per fixed X matrix; {}",
                zyz.x_nonzeros(),
                kernel_note(n, crate::simd::SIMD_MIN_ORDER_ZYZ)
            ),
        ));

        // Taylor (β ≤ 0.4 rad, always the Taylor path).
        let eul_s: Vec<EulerZyz<f32>> = small.iter().map(|r| r.euler_zyz()).collect();
        for (name, kind) in [
            ("taylor1", TaylorOrder::First),
            ("taylor15", TaylorOrder::OneAndHalf),
            ("taylor2", TaylorOrder::Second),
        ] {
            let tr = TaylorRotation::<f32>::new(n, kind, std::f32::consts::PI).expect("order");
            let b = time_ns(reps, batches, |i| {
                black_box(opaque(&small[i % SET]).euler_zyz());
            });
            let a = time_ns(reps, batches, |i| {
                tr.apply_euler(
                    opaque(&eul_s[i % SET]),
                    opaque(&vs[i % SET]).as_slice(),
                    &mut dst,
                    &mut scratch,
                );
                escape(&dst[..]);
            });
            let t = time_ns(reps, batches, |i| {
                tr.apply(
                    opaque(&small[i % SET]),
                    opaque(&vs[i % SET]).as_slice(),
                    &mut dst,
                    &mut scratch,
                );
                escape(&dst[..]);
            });
            rows.push(row(
                name,
                n,
                b,
                a,
                t,
                format!("β ≤ 0.4 rad; {}", kernel_note(n, 2)),
            ));
        }

        // Z rotation and zonal rotation.
        let cs: Vec<(f32, f32)> = (0..SET).map(|i| (i as f32 * 0.1).sin_cos()).collect();
        let a = time_ns(reps, batches, |i| {
            let (s, c) = cs[i % SET];
            rotate_z(
                n,
                black_box(c),
                black_box(s),
                opaque(&vs[i % SET]).as_slice(),
                &mut dst,
            );
            escape(&dst[..]);
        });
        rows.push(row(
            "z",
            n,
            0.0,
            a,
            a,
            format!(
                "cos α, sin α given; {}",
                kernel_note(n, crate::simd::SIMD_MIN_ORDER_Z)
            ),
        ));
        let dirs: Vec<[f32; 3]> = rots.iter().map(|r| r.apply([0.0, 0.0, 1.0])).collect();
        let a = time_ns(reps, batches, |i| {
            rotate_zonal(
                n,
                black_box(&vs[i % SET][..n]),
                *opaque(&dirs[i % SET]),
                &mut dst,
            );
            escape(&dst[..]);
        });
        rows.push(row("zonal", n, 0.0, a, a, String::new()));

        // Evaluation.
        let a = time_ns(reps, batches, |i| {
            eval_sh_into(n, *opaque(&dirs[i % SET]), &mut dst);
            escape(&dst[..]);
        });
        rows.push(row("eval", n, 0.0, a, a, crate::fast::eval_path(n).into()));
        if let Some(a) = time_eval_array(n, reps, batches, &dirs) {
            rows.push(row(
                "eval_array",
                n,
                0.0,
                a,
                a,
                "eval_sh_array_into: order fixed at compile time".into(),
            ));
        }
        let a = time_ns(reps, batches, |i| {
            crate::basis::eval_sh_recurrence_into(n, *opaque(&dirs[i % SET]), &mut dst);
            escape(&dst[..]);
        });
        rows.push(row("eval_recurrence", n, 0.0, a, a, String::new()));

        // RGB rotation (three channels, one decomposition) and batches of SET
        // items per call, reported per item.
        if n <= crate::fast::KERNEL_ROTATE_MAX_ORDER {
            let (mut d1, mut d2) = (vec![0.0f32; nn], vec![0.0f32; nn]);
            let t = time_ns(reps, batches, |i| {
                crate::fast::rotate_rgb(
                    n,
                    opaque(&rots[i % SET]),
                    [&vs[i % SET], &vs[(i + 1) % SET], &vs[(i + 2) % SET]],
                    [&mut dst, &mut d1, &mut d2],
                )
                .ok();
                black_box((&dst, &d1, &d2));
            });
            rows.push(row(
                "zyz_rgb",
                n,
                0.0,
                t,
                t,
                "3 channels, one rotation; generated kernel".into(),
            ));
        }
        if n <= crate::fast::ROTATE_BATCH_MAX_ORDER {
            let src: Vec<f32> = vs.concat();
            let mut out = vec![0.0f32; src.len()];
            let br = (reps / 16).max(1);
            let t = time_ns(br, batches, |_| {
                crate::fast::rotate_batch(n, black_box(&rots), black_box(&src), &mut out).ok();
                black_box(&out);
            }) / SET as f64;
            rows.push(row(
                "rotate_batch",
                n,
                0.0,
                t,
                t,
                format!(
                    "per item, {SET} rotations per call; {:?}",
                    crate::fast::batch_path()
                ),
            ));
        }
        if n <= crate::fast::BATCH_MAX_ORDER {
            let mut out = vec![0.0f32; SET * n * n];
            let br = (reps / 16).max(1);
            let t = time_ns(br, batches, |_| {
                crate::fast::eval_batch(n, black_box(&dirs), &mut out).ok();
                black_box(&out);
            }) / SET as f64;
            rows.push(row(
                "eval_batch",
                n,
                0.0,
                t,
                t,
                format!(
                    "per direction, {SET} per call; {:?}",
                    crate::fast::batch_path()
                ),
            ));
            let mut sh = vec![0.0f32; SET];
            let t = time_ns(br, batches, |_| {
                crate::fast::shade_batch(n, black_box(&vs[0]), black_box(&dirs), &mut sh).ok();
                black_box(&sh);
            }) / SET as f64;
            rows.push(row(
                "shade_batch",
                n,
                0.0,
                t,
                t,
                format!(
                    "Σ c_k y_k(d) per direction, {SET} per call; {:?}",
                    crate::fast::batch_path()
                ),
            ));
            let mut rgb = vec![[0.0f32; 3]; SET];
            let t = time_ns(br, batches, |_| {
                crate::fast::shade_rgb_batch(
                    n,
                    [&vs[0], &vs[1], &vs[2]],
                    black_box(&dirs),
                    &mut rgb,
                )
                .ok();
                black_box(&rgb);
            }) / SET as f64;
            rows.push(row(
                "shade_rgb_batch",
                n,
                0.0,
                t,
                t,
                format!(
                    "RGB, per direction, {SET} per call; {:?}",
                    crate::fast::batch_path()
                ),
            ));
        }
    }
    // Products, exp, log (n ≤ 8); products only at n = 9, 10.
    for n in 2..=10 {
        let nn = n * n;
        let vs = vectors(n);
        let mut dst = vec![0.0f32; nn];
        let tp = TripleProduct::<f32>::new(n).expect("order");
        let r = if n >= 7 { reps / 4 } else { reps };
        let mut scratch = vec![0.0f32; tp.scratch_len()];
        let a = time_ns(r, batches, |i| {
            tp.product_with(
                opaque(&vs[i % SET]).as_slice(),
                opaque(&vs[(i + 1) % SET]).as_slice(),
                &mut dst,
                &mut scratch,
            );
            escape(&dst[..]);
        });
        let how = if n >= crate::product_high::HIGH_MIN_ORDER {
            "f32 pseudo-spectral: 16-node Gauss z × φ-Fourier convolution"
        } else {
            crate::fast::product_path(n)
        };
        rows.push(row("product", n, 0.0, a, a, how.into()));
        let a = time_ns(r, batches, |i| {
            tp.product_triples(
                opaque(&vs[i % SET]).as_slice(),
                opaque(&vs[(i + 1) % SET]).as_slice(),
                &mut dst,
            );
            escape(&dst[..]);
        });
        rows.push(row(
            "product_triples",
            n,
            0.0,
            a,
            a,
            format!("{} stored Γ entries", tp.nonzeros_stored()),
        ));
        if n > 8 {
            continue;
        }
        let a = time_ns(r, batches, |i| {
            tp.square_with(opaque(&vs[i % SET]).as_slice(), &mut dst, &mut scratch);
            escape(&dst[..]);
        });
        rows.push(row("square", n, 0.0, a, a, String::new()));
        if n <= crate::fast::KERNEL_PRODUCT_MAX_ORDER {
            let (mut d1, mut d2) = (vec![0.0f32; nn], vec![0.0f32; nn]);
            let a = time_ns(r, batches, |i| {
                crate::fast::product_rgb(
                    n,
                    [&vs[i % SET], &vs[(i + 1) % SET], &vs[(i + 2) % SET]],
                    [&vs[(i + 3) % SET], &vs[(i + 4) % SET], &vs[(i + 5) % SET]],
                    [&mut dst, &mut d1, &mut d2],
                )
                .ok();
                black_box((&dst, &d1, &d2));
            });
            rows.push(row(
                "product_rgb",
                n,
                0.0,
                a,
                a,
                "3 channel-wise products; generated kernel".into(),
            ));
        }
        let mut ex = ShExp::<f32>::new(n).expect("order");
        for (name, m) in [
            ("exp_ps*4", ExpMethod::PsStar(4)),
            ("exp_hyb", ExpMethod::Hyb),
        ] {
            let a = time_ns(r / 4 + 1, batches, |i| {
                ex.exp(m, opaque(&vs[i % SET]).as_slice(), &mut dst);
                escape(&dst[..]);
            });
            rows.push(row(name, n, 0.0, a, a, String::new()));
        }
        let tp64 = TripleProduct::<f64>::new(n).expect("order");
        let g: Vec<Vec<f64>> = vs
            .iter()
            .map(|v| {
                let mut g: Vec<f64> = v.iter().map(|&x| 0.2 * x as f64).collect();
                g[0] += 3.0;
                g
            })
            .collect();
        let lr = if quick { 5 } else { 200 };
        let a = time_ns(lr, batches.min(3), |i| {
            black_box(log_sh(&tp64, opaque(&g[i % SET]).as_slice(), 0.02).ok());
        });
        rows.push(row("log", n, 0.0, a, a, "f64, eigen-analysis".into()));
    }
    // Projection of a 256×128 RGB lat-long map.
    let (w, h) = (256usize, 128usize);
    let param = relight_sphere::Param::LatLong {
        width: w,
        height: h,
    };
    let mut r = rng(3);
    let texels: Vec<glam::Vec3> = (0..w * h)
        .map(|_| glam::Vec3::new(r(), r(), r()) + 0.5)
        .collect();
    for n in [3, 6, 10, 16, 30] {
        let pr = LatLongProjector::new(param, n).expect("order");
        let pr_reps = if quick {
            3
        } else if n > 10 {
            50
        } else {
            200
        };
        let a = time_ns(pr_reps, batches, |_| {
            black_box(pr.project(black_box(&texels)).ok());
        });
        let t = time_ns(pr_reps.div_ceil(4), batches, |_| {
            let pr = LatLongProjector::new(param, n).expect("order");
            black_box(pr.project(black_box(&texels)).ok());
        });
        rows.push(row(
            "project_latlong",
            n,
            t - a,
            a,
            t,
            format!(
                "256x128 RGB: {:.1} µs (with projector build {:.1} µs)",
                a / 1000.0,
                t / 1000.0
            ),
        ));
    }
    rows
}

#[cfg(test)]
mod tests {
    #[test]
    fn bench_quick_smoke() {
        let rows = super::bench_sh(true);
        assert!(
            rows.iter()
                .all(|r| r.ns_apply.is_finite() && r.ns_apply > 0.0)
        );
        assert!(rows.iter().any(|r| r.method == "taylor15" && r.order == 6));
        assert!(
            rows.iter()
                .any(|r| r.method == "project_latlong" && r.order == 10)
        );
    }
}
