//! Evaluation of the real SH basis at a direction.
//!
//! # Recurrence
//! With `z = cos θ` and `C_m + i S_m = (x + i y)^m = sin^m θ e^{imφ}`, every basis
//! function is `y_{l,±m} = Q_l^m(z) · (C_m | S_m)`, where `Q_l^m` is the normalised
//! associated Legendre function divided by `sin^m θ` (a polynomial in `z`):
//!
//! * `Q_0^0 = 1/√(4π)`, `Q_m^m = −Q_{m−1}^{m−1} √((2m+1)/(2m))` (× √2 once, at m = 1:
//!   the real-SH factor), which carries the Condon–Shortley phase `(−1)^m`;
//! * `Q_{m+1}^m = √(2m+3) z Q_m^m`;
//! * `Q_l^m = a_l^m z Q_{l−1}^m + b_l^m Q_{l−2}^m`, `a = √((4l²−1)/(l²−m²))`,
//!   `b = −√(((l−1)²−m²)(2l+1)/((2l−3)(l²−m²)))`;
//! * `C_m = x C_{m−1} − y S_{m−1}`, `S_m = x S_{m−1} + y C_{m−1}`.
//!
//! No trigonometric function is called; the constants are tabulated once (f64
//! and f32) for every order up to [`MAX_ORDER`]. For `n ≤ 8` (L ≤ 7) the same
//! recurrence is unrolled into straight-line code with literal constants
//! ([`crate::generated`], written by [`generate_fast_eval_source`]) with two
//! changes that shorten the dependency chains: `Q_l^m` is expanded into an
//! explicit polynomial in `z` (powers `z^k` precomputed), and `(x + iy)^m` is
//! formed by repeated squaring.

use crate::{MAX_ORDER, Real, ShError, check_order};
use std::sync::OnceLock;

/// Largest order served by the generated straight-line code.
pub const FAST_MAX_ORDER: usize = 8;

/// Recurrence constants for `0 ≤ m ≤ l < MAX_ORDER`, packed at `l(l+1)/2 + m`.
struct Tables<T> {
    /// `Q_m^m` (diagonal seeds), index m.
    diag: Vec<T>,
    /// `a_l^m`, packed.
    a: Vec<T>,
    /// `b_l^m`, packed.
    b: Vec<T>,
}

fn tables_f64() -> Tables<f64> {
    let n = MAX_ORDER;
    let mut diag = vec![0.0; n];
    diag[0] = 1.0 / (4.0 * std::f64::consts::PI).sqrt();
    for m in 1..n {
        let mf = m as f64;
        let mut v = -diag[m - 1] * ((2.0 * mf + 1.0) / (2.0 * mf)).sqrt();
        if m == 1 {
            v *= std::f64::consts::SQRT_2;
        }
        diag[m] = v;
    }
    let len = n * (n + 1) / 2;
    let mut a = vec![0.0; len];
    let mut b = vec![0.0; len];
    for l in 0..n {
        for m in 0..l {
            let (lf, mf) = (l as f64, m as f64);
            let k = l * (l + 1) / 2 + m;
            a[k] = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
            b[k] = if l >= m + 2 {
                -(((lf - 1.0) * (lf - 1.0) - mf * mf) * (2.0 * lf + 1.0)
                    / ((2.0 * lf - 3.0) * (lf * lf - mf * mf)))
                    .sqrt()
            } else {
                0.0
            };
        }
    }
    Tables { diag, a, b }
}

fn convert<T: Real>(t: &Tables<f64>) -> Tables<T> {
    let c = |v: &Vec<f64>| v.iter().map(|&x| T::from_f64(x)).collect();
    Tables {
        diag: c(&t.diag),
        a: c(&t.a),
        b: c(&t.b),
    }
}

static TABLES_F64: OnceLock<Tables<f64>> = OnceLock::new();
static TABLES_F32: OnceLock<Tables<f32>> = OnceLock::new();

/// Access to the per-type tables (implemented for f32 and f64 only).
trait HasTables: Real {
    fn tables() -> &'static Tables<Self>;
}
impl HasTables for f64 {
    fn tables() -> &'static Tables<f64> {
        TABLES_F64.get_or_init(tables_f64)
    }
}
impl HasTables for f32 {
    fn tables() -> &'static Tables<f32> {
        TABLES_F32.get_or_init(|| convert(&tables_f64()))
    }
}

/// The recurrence for any order (no fast path), written once for f32/f64.
/// Out of line, so that the always-inlined [`eval_sh_into`] stays small.
#[inline(never)]
fn eval_recurrence<T: Real>(tab: &Tables<T>, order: usize, x: T, y: T, z: T, out: &mut [T]) {
    let out = &mut out[..order * order];
    let (mut c, mut s) = (T::ONE, T::ZERO);
    for m in 0..order {
        if m > 0 {
            let c1 = x * c - y * s;
            s = x * s + y * c;
            c = c1;
        }
        let mut q2 = tab.diag[m];
        let emit = |out: &mut [T], l: usize, q: T| {
            let base = l * (l + 1);
            if m == 0 {
                out[base] = q;
            } else {
                out[base + m] = q * c;
                out[base - m] = q * s;
            }
        };
        emit(out, m, q2);
        if m + 1 >= order {
            continue;
        }
        let l = m + 1;
        let mut q1 = tab.a[l * (l + 1) / 2 + m] * z * q2;
        emit(out, l, q1);
        for l in m + 2..order {
            let k = l * (l + 1) / 2 + m;
            let q = tab.a[k] * z * q1 + tab.b[k] * q2;
            emit(out, l, q);
            q2 = q1;
            q1 = q;
        }
    }
}

/// Dispatch to the generated code where it exists.
trait FastEval: Real {
    /// The inlined small orders (checks its own output length); `false`
    /// (nothing done) where the type has none or the order is larger.
    fn eval_small(order: usize, dir: [Self; 3], out: &mut [Self]) -> bool;
    fn eval_fast(order: usize, x: Self, y: Self, z: Self, out: &mut [Self]) -> bool;
}
impl FastEval for f32 {
    #[inline(always)]
    fn eval_small(order: usize, dir: [f32; 3], out: &mut [f32]) -> bool {
        crate::fast::eval_inline_dir(order, dir, out)
    }
    #[inline(always)]
    fn eval_fast(order: usize, x: f32, y: f32, z: f32, out: &mut [f32]) -> bool {
        crate::fast::eval_one(order, x, y, z, out)
    }
}
impl FastEval for f64 {
    #[inline(always)]
    fn eval_small(_order: usize, _dir: [f64; 3], _out: &mut [f64]) -> bool {
        false
    }
    #[inline(always)]
    fn eval_fast(order: usize, x: f64, y: f64, z: f64, out: &mut [f64]) -> bool {
        crate::generated::eval_sh_fast_f64(order, x, y, z, out)
    }
}

/// Sealed helper trait: the float types [`eval_sh_into`] is implemented for.
#[allow(private_bounds)]
pub trait ShFloat: Real + HasTables + FastEval {}
impl ShFloat for f32 {}
impl ShFloat for f64 {}

/// Evaluates all `order²` basis functions at the unit direction `dir` into
/// `out[..order²]` (index `l(l+1)+m`), allocation-free.
///
/// `dir` must be unit length (it is not normalised; a non-unit direction
/// evaluates the harmonic polynomials off the sphere). Orders `≤ 8` use the
/// generated straight-line code, larger ones the tabulated recurrence.
///
/// # Panics
/// If `order` is 0 or > [`MAX_ORDER`] or `out.len() < order²`; see
/// [`try_eval_sh_into`] for the checked variant.
///
/// Always inlined: for f32 at `order ≤` [`crate::fast::INLINE_EVAL_MAX_ORDER`]
/// the generated straight-line code lands in the caller (no call, no CPU test);
/// larger orders call one out-of-line kernel.
#[inline(always)]
pub fn eval_sh_into<T: ShFloat>(order: usize, dir: [T; 3], out: &mut [T]) {
    if T::eval_small(order, dir, out) {
        return;
    }
    let [x, y, z] = dir;
    assert!(
        (1..=MAX_ORDER).contains(&order) && out.len() >= order * order,
        "eval_sh_into: order {order} out of range or output too short ({})",
        out.len()
    );
    if !T::eval_fast(order, x, y, z, out) {
        eval_recurrence(T::tables(), order, x, y, z, out);
    }
}

/// Evaluates all `NN = n²` f32 basis functions at the unit direction `dir`
/// into a fixed-size array, for an order `n` (1 ≤ n ≤ 8) known at compile
/// time: the generated straight-line code with no order dispatch and no
/// length check (n ≤ 4 inlined into the caller, plain multiply and add;
/// n ≥ 5 one call into the FMA kernel). Same values and layout as
/// [`eval_sh_into`]; `NN` other than 1, 4, 9, …, 64 does not compile.
///
/// ```
/// let y: [f32; 9] = relight_sh::eval_sh_array([0.0, 0.0, 1.0]);
/// assert!((y[2] - 0.488_602_5).abs() < 1e-6); // y_{1,0}(+Z) = √(3/4π)
/// ```
#[inline(always)]
#[must_use]
pub fn eval_sh_array<const NN: usize>(dir: [f32; 3]) -> [f32; NN] {
    let mut out = [0.0f32; NN];
    crate::fast::eval_array(dir[0], dir[1], dir[2], &mut out);
    out
}

/// [`eval_sh_array`] into a caller's array (no return copy).
#[inline(always)]
pub fn eval_sh_array_into<const NN: usize>(dir: [f32; 3], out: &mut [f32; NN]) {
    crate::fast::eval_array(dir[0], dir[1], dir[2], out);
}

/// Evaluates with the tabulated recurrence only (no generated fast path); used
/// to cross-check the generated code and for benchmarking.
///
/// # Panics
/// As [`eval_sh_into`].
pub fn eval_sh_recurrence_into<T: ShFloat>(order: usize, dir: [T; 3], out: &mut [T]) {
    assert!((1..=MAX_ORDER).contains(&order) && out.len() >= order * order);
    let [x, y, z] = dir;
    eval_recurrence(T::tables(), order, x, y, z, out);
}

/// Checked [`eval_sh_into`]: errors for an order outside `1..=MAX_ORDER`, a
/// short output, or a zero / non-finite direction; normalises `dir`.
pub fn try_eval_sh_into<T: ShFloat>(
    order: usize,
    dir: [T; 3],
    out: &mut [T],
) -> Result<(), ShError> {
    check_order("order", order, MAX_ORDER)?;
    if out.len() < order * order {
        return Err(ShError::LengthMismatch {
            what: "out",
            order,
            expected: order * order,
            got: out.len(),
        });
    }
    let len = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let lf = len.to_f64();
    if !lf.is_finite() || lf == 0.0 {
        return Err(ShError::BadDirection {
            what: "dir",
            length: lf,
        });
    }
    let inv = T::ONE / len;
    eval_sh_into(order, [dir[0] * inv, dir[1] * inv, dir[2] * inv], out);
    Ok(())
}

/// All `order²` basis values at a unit direction (allocates; see [`eval_sh_into`]).
///
/// # Panics
/// If `order` is 0 or > [`MAX_ORDER`].
#[must_use]
pub fn eval_sh(order: usize, dir: glam::Vec3) -> Vec<f32> {
    let mut out = vec![0.0; order * order];
    eval_sh_into(order, dir.to_array(), &mut out);
    out
}

/// Checked, normalising, f64 variant of [`eval_sh`].
pub fn try_eval_sh(order: usize, dir: glam::DVec3) -> Result<Vec<f64>, ShError> {
    let mut out = vec![0.0; order.min(MAX_ORDER + 1).pow(2)];
    try_eval_sh_into(order, dir.to_array(), &mut out)?;
    Ok(out)
}

/// f64 evaluation at a unit direction (allocates).
///
/// # Panics
/// If `order` is 0 or > [`MAX_ORDER`].
#[must_use]
pub fn eval_sh_f64(order: usize, dir: glam::DVec3) -> Vec<f64> {
    let mut out = vec![0.0; order * order];
    eval_sh_into(order, dir.to_array(), &mut out);
    out
}

/// Reconstruct `Σ c_i y_i(dir)` for a scalar coefficient vector (any order ≤ MAX_ORDER).
///
/// # Panics
/// If `c.len()` is not a perfect square in `1..=MAX_ORDER²`.
#[must_use]
pub fn eval_fn_f64(c: &[f64], dir: glam::DVec3) -> f64 {
    let n = crate::order_of_len(c.len()).expect("coefficient count must be a square");
    let mut y = [0.0f64; MAX_ORDER * MAX_ORDER];
    eval_sh_into(n, dir.to_array(), &mut y);
    c.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// `Q_l^m(z)` as explicit polynomials for `0 ≤ m ≤ l < n`: `[m][l − m][d]` is
/// the coefficient of `z^d`, built from the recurrence constants above (f64).
/// The source of truth for every generated evaluation kernel.
pub(crate) fn legendre_polynomials(n: usize) -> Vec<Vec<Vec<f64>>> {
    let t = tables_f64();
    (0..n)
        .map(|m| {
            let mut polys: Vec<Vec<f64>> = Vec::new();
            for l in m..n {
                let p = if l == m {
                    vec![t.diag[m]]
                } else {
                    let k = l * (l + 1) / 2 + m;
                    let prev = &polys[l - m - 1];
                    let mut p = vec![0.0; l - m + 1];
                    for (d, c) in prev.iter().enumerate() {
                        p[d + 1] += t.a[k] * c;
                    }
                    if l >= m + 2 {
                        for (d, c) in polys[l - m - 2].iter().enumerate() {
                            p[d] += t.b[k] * c;
                        }
                    }
                    p
                };
                polys.push(p);
            }
            polys
        })
        .collect()
}

/// Source text of [`crate::generated`]: the recurrence above unrolled for
/// `n = 1 ..= FAST_MAX_ORDER`, f32 and f64, with the tabulated constants
/// written as literals. A test regenerates it and compares with the file, so
/// any drift fails; run `RELIGHT_SH_REGENERATE=1 cargo test -p relight-sh
/// generated_code` to rewrite the file after changing this generator.
#[must_use]
pub fn generate_fast_eval_source() -> String {
    use std::fmt::Write;
    let mut s = String::new();
    s.push_str(
        "// @generated by relight_sh::basis::generate_fast_eval_source — do not edit by hand.\n\
         // Regenerate: RELIGHT_SH_REGENERATE=1 cargo test -p relight-sh generated_code\n\
         //! Generated straight-line SH evaluation for orders 1..=8 (L ≤ 7), f32 and f64.\n\
         //!\n\
         //! The recurrence of [`crate::basis`] unrolled, constants as literals.\n\
         #![allow(clippy::excessive_precision, clippy::unreadable_literal, clippy::too_many_lines)]\n\n",
    );
    for ty in ["f32", "f64"] {
        for n in 1..=FAST_MAX_ORDER {
            let q_polys = legendre_polynomials(n);
            let lit = |v: f64| -> String {
                if ty == "f32" {
                    format!("{:?}_f32", v as f32)
                } else {
                    format!("{v:?}_f64")
                }
            };
            writeln!(
                s,
                "/// All {} SH basis values for order {n} at a unit direction.",
                n * n
            )
            .unwrap();
            writeln!(s, "#[inline]").unwrap();
            let unused = if n == 1 { "_" } else { "" };
            let unused_xy = if n <= 1 { "_" } else { "" };
            writeln!(
                s,
                "pub fn eval_sh_n{n}_{ty}({unused_xy}x: {ty}, {unused_xy}y: {ty}, {unused}z: {ty}, out: &mut [{ty}; {}]) {{",
                n * n
            )
            .unwrap();
            // Powers of z (short dependency chains: z^k from z^{k/2}).
            for k in 2..n {
                if k % 2 == 0 {
                    let h = if k / 2 == 1 {
                        "z".to_string()
                    } else {
                        format!("z{}", k / 2)
                    };
                    writeln!(s, "    let z{k} = {h} * {h};").unwrap();
                } else {
                    let p = if k - 1 == 1 {
                        "z".to_string()
                    } else {
                        format!("z{}", k - 1)
                    };
                    writeln!(s, "    let z{k} = {p} * z;").unwrap();
                }
            }
            for m in 0..n {
                // (x + iy)^m by repeated squaring (depth ~2 log₂ m).
                if m == 1 {
                    writeln!(s, "    let c1 = x;\n    let s1 = y;").unwrap();
                } else if m > 1 && m % 2 == 0 {
                    let h = m / 2;
                    writeln!(s, "    let c{m} = c{h} * c{h} - s{h} * s{h};\n    let s{m} = (c{h} + c{h}) * s{h};").unwrap();
                } else if m > 1 {
                    let p = m - 1;
                    writeln!(
                        s,
                        "    let c{m} = c{p} * x - s{p} * y;\n    let s{m} = s{p} * x + c{p} * y;"
                    )
                    .unwrap();
                }
                // Q_l^m as explicit polynomials in z (coefficients by the recurrence).
                for (lm, p) in q_polys[m].iter().enumerate() {
                    let l = m + lm;
                    let terms: Vec<String> = p
                        .iter()
                        .enumerate()
                        .filter(|(d, _)| (l - m - d) % 2 == 0)
                        .map(|(d, c)| match d {
                            0 => lit(*c),
                            1 => format!("{} * z", lit(*c)),
                            _ => format!("{} * z{d}", lit(*c)),
                        })
                        .collect();
                    let q = terms.join(" + ");
                    let base = l * (l + 1);
                    if m == 0 {
                        writeln!(s, "    out[{base}] = {q};").unwrap();
                    } else {
                        writeln!(s, "    let q{l}_{m} = {q};").unwrap();
                        writeln!(s, "    out[{}] = q{l}_{m} * c{m};", base + m).unwrap();
                        writeln!(s, "    out[{}] = q{l}_{m} * s{m};", base - m).unwrap();
                    }
                }
            }
            writeln!(s, "}}\n").unwrap();
        }
        writeln!(
            s,
            "/// Dispatch: evaluates with the generated code and returns `true` when `order ≤ 8`."
        )
        .unwrap();
        writeln!(s, "#[inline]").unwrap();
        writeln!(
            s,
            "pub fn eval_sh_fast_{ty}(order: usize, x: {ty}, y: {ty}, z: {ty}, out: &mut [{ty}]) -> bool {{"
        )
        .unwrap();
        writeln!(s, "    match order {{").unwrap();
        for n in 1..=FAST_MAX_ORDER {
            writeln!(
                s,
                "        {n} => eval_sh_n{n}_{ty}(x, y, z, (&mut out[..{nn}]).try_into().expect(\"length {nn}\")),",
                nn = n * n
            )
            .unwrap();
        }
        writeln!(s, "        _ => return false,\n    }}\n    true\n}}\n").unwrap();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::SphereQuadrature;
    use std::f64::consts::PI;

    #[test]
    fn generated_code_matches_generator() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/generated.rs");
        let want = generate_fast_eval_source();
        if std::env::var_os("RELIGHT_SH_REGENERATE").is_some() {
            std::fs::write(path, &want).unwrap();
        }
        let have = std::fs::read_to_string(path).unwrap();
        assert!(
            have == want,
            "src/generated.rs drifted from generate_fast_eval_source(); regenerate with RELIGHT_SH_REGENERATE=1"
        );
    }

    #[test]
    fn issue_test_vector() {
        let d = glam::DVec3::new(1.0, 2.0, 3.0).normalize();
        let y = eval_sh_f64(4, d);
        let want = [
            (0, 0, 0.28209479177),
            (1, -1, -0.26116903),
            (1, 0, 0.39175354),
            (1, 1, -0.13058451),
            (2, -2, 0.15607835),
            (2, -1, -0.46823504),
            (2, 0, 0.29286360),
            (2, 1, -0.23411752),
            (2, 2, -0.11705876),
            (3, -3, 0.02252797),
            (3, 0, 0.06411572),
            (3, 3, 0.12390383),
        ];
        for (l, m, v) in want {
            let got = y[crate::sh_index(l, m)];
            assert!((got - v).abs() < 1e-8, "Y_{l},{m}: got {got}, want {v}");
        }
        // f32 path agrees, and the generic recurrence agrees with the generated code.
        let yf = eval_sh(4, d.as_vec3());
        for i in 0..16 {
            assert!(
                (yf[i] as f64 - y[i]).abs() < 1e-6,
                "f32 {i}: {} vs {}",
                yf[i],
                y[i]
            );
        }
    }

    #[test]
    fn generated_matches_recurrence_all_fast_orders() {
        let d = glam::DVec3::new(-0.3, 0.7, -0.2).normalize();
        for n in 1..=FAST_MAX_ORDER + 2 {
            let mut a = vec![0.0f64; n * n];
            let mut b = vec![0.0f64; n * n];
            eval_sh_into(n, d.to_array(), &mut a);
            eval_sh_recurrence_into(n, d.to_array(), &mut b);
            for i in 0..n * n {
                assert!(
                    (a[i] - b[i]).abs() < 1e-14,
                    "n={n} i={i}: {} vs {}",
                    a[i],
                    b[i]
                );
            }
            let mut af = vec![0.0f32; n * n];
            eval_sh_into(n, d.as_vec3().to_array(), &mut af);
            for i in 0..n * n {
                assert!(
                    (af[i] as f64 - b[i]).abs() < 2e-6,
                    "f32 n={n} i={i}: {} vs {}",
                    af[i],
                    b[i]
                );
            }
        }
    }

    #[test]
    fn closed_forms_bands_0_to_2() {
        for d in [
            glam::DVec3::new(0.3, -0.5, 0.81),
            glam::DVec3::new(-0.9, 0.1, -0.2),
            glam::DVec3::Z,
            glam::DVec3::new(0.0, -1.0, 0.0),
        ] {
            let d = d.normalize();
            let (x, y, z) = (d.x, d.y, d.z);
            let c0 = 0.5 * (1.0 / PI).sqrt();
            let c1 = (3.0 / (4.0 * PI)).sqrt();
            let c2 = 0.5 * (15.0 / PI).sqrt();
            let c20 = 0.25 * (5.0 / PI).sqrt();
            let c22 = 0.25 * (15.0 / PI).sqrt();
            let want = [
                c0,
                -c1 * y,
                c1 * z,
                -c1 * x,
                c2 * x * y,
                -c2 * y * z,
                c20 * (3.0 * z * z - 1.0),
                -c2 * x * z,
                c22 * (x * x - y * y),
            ];
            let got = eval_sh_f64(3, d);
            for i in 0..9 {
                assert!(
                    (got[i] - want[i]).abs() < 1e-14,
                    "{d} i={i}: {} vs closed form {}",
                    got[i],
                    want[i]
                );
            }
        }
    }

    #[test]
    fn orthonormal_to_1e10_up_to_l30() {
        let n = 31;
        let q = SphereQuadrature::for_degree(2 * (n - 1));
        let k = n * n;
        let npts = q.len();
        // Y: k × npts, weighted copy.
        let mut y = nalgebra::DMatrix::<f64>::zeros(k, npts);
        let mut yw = nalgebra::DMatrix::<f64>::zeros(k, npts);
        let mut buf = vec![0.0; k];
        for p in 0..npts {
            eval_sh_into(n, q.dirs[p].to_array(), &mut buf);
            for i in 0..k {
                y[(i, p)] = buf[i];
                yw[(i, p)] = buf[i] * q.weights[p];
            }
        }
        let g = &y * yw.transpose();
        let mut worst = (0.0f64, 0, 0);
        for i in 0..k {
            for j in 0..k {
                let e = (g[(i, j)] - if i == j { 1.0 } else { 0.0 }).abs();
                if e > worst.0 {
                    worst = (e, i, j);
                }
            }
        }
        assert!(
            worst.0 < 1e-10,
            "Gram matrix deviates by {:e} at ({}, {})",
            worst.0,
            worst.1,
            worst.2
        );
    }

    #[test]
    fn bad_inputs_are_errors() {
        let mut out = vec![0.0f64; 16];
        assert!(matches!(
            try_eval_sh_into(0, [0.0, 0.0, 1.0], &mut out),
            Err(ShError::OrderOutOfRange { .. })
        ));
        assert!(matches!(
            try_eval_sh_into(MAX_ORDER + 1, [0.0, 0.0, 1.0], &mut out),
            Err(ShError::OrderOutOfRange { .. })
        ));
        assert!(matches!(
            try_eval_sh_into(5, [0.0, 0.0, 1.0], &mut out),
            Err(ShError::LengthMismatch { .. })
        ));
        assert!(matches!(
            try_eval_sh_into(4, [f64::NAN, 0.0, 1.0], &mut out),
            Err(ShError::BadDirection { .. })
        ));
        // Non-unit directions are normalised by the checked variant.
        try_eval_sh_into(4, [0.0, 0.0, 3.0], &mut out).unwrap();
        assert!((out[2] - (3.0 / (4.0 * PI)).sqrt()).abs() < 1e-14);
    }
}
