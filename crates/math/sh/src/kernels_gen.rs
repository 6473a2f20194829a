//! Generator of [`crate::kernels`]: per-order straight-line f32 kernels for
//! evaluation, exact rotation and the truncated product, written once over the
//! lane type [`crate::lanes::V`] (one item, or eight items side by side).
//!
//! Each kernel is an existing portable algorithm of this crate unrolled for a
//! fixed order, constants as literals, no loops, no bounds checks, no
//! dispatch:
//!
//! * **evaluation**: the associated-Legendre recurrence of [`crate::basis`]
//!   (via [`crate::basis::legendre_polynomials`]), `Q_l^m` in Horner form in
//!   `z²`, `(x + iy)^m` by repeated squaring;
//! * **rotation**: the ZYZ ("ZXZXZ") factorisation of
//!   [`crate::rotation::ZyzRotation`], `R = R_z(α) X₋ R_z(β) X₊ R_z(γ)` with the
//!   fixed `X± = R_x(±90°)` band matrices (computed exactly in f64 by
//!   Ivanic–Ruedenberg) written as sparse literal dot products;
//! * **product**: the output-major Gaunt form of
//!   [`crate::product::TripleProduct::product_with`],
//!   `(f ∗ g)_k = Σ_{a ≤ b} w_{kab} (f_a g_b + f_b g_a)`, only the pair sums
//!   that some output uses.
//!
//! A test regenerates the file and fails on any difference (the CI drift
//! check); `RELIGHT_SH_REGENERATE=1 cargo test -p relight-sh kernels_source`
//! rewrites it.

use crate::basis::legendre_polynomials;
use crate::product::TripleProduct;
use crate::rotation::{Rot3, ShRotation};
use std::fmt::Write;

/// Largest order of the generated evaluation kernels.
pub const KERNEL_EVAL_MAX_ORDER: usize = 8;
/// Largest order of the generated rotation kernels.
pub const KERNEL_ROTATE_MAX_ORDER: usize = 6;
/// Largest order of the generated product kernels.
pub const KERNEL_PRODUCT_MAX_ORDER: usize = 6;

/// Weights per non-inlined chunk of a generated product kernel (compile time:
/// see `product_kernel`).
const PRODUCT_CHUNK_TERMS: usize = 256;

fn lit(v: f64) -> String {
    format!("s({:?})", v as f32)
}

const SIG: &str = "<const W: usize, const F: bool>";

fn eval_kernel(s: &mut String, n: usize) {
    let nn = n * n;
    let polys = legendre_polynomials(n);
    let us = if n == 1 { "_" } else { "" };
    writeln!(
        s,
        "/// All {nn} basis values at a unit direction, order {n}."
    )
    .unwrap();
    writeln!(s, "#[inline(always)]").unwrap();
    writeln!(
        s,
        "pub(crate) fn eval_n{n}{SIG}({us}x: V<W, F>, {us}y: V<W, F>, {us}z: V<W, F>, o: &mut [V<W, F>; {nn}]) {{"
    )
    .unwrap();
    writeln!(s, "    let s = V::<W, F>::splat;").unwrap();
    if n > 2 {
        writeln!(s, "    let z2 = z * z;").unwrap();
    }
    for m in 0..n {
        if m == 1 {
            writeln!(s, "    let c1 = x;\n    let s1 = y;").unwrap();
        } else if m > 1 && m % 2 == 0 {
            let h = m / 2;
            writeln!(
                s,
                "    let c{m} = c{h} * c{h} - s{h} * s{h};\n    let s{m} = (c{h} + c{h}) * s{h};"
            )
            .unwrap();
        } else if m > 1 {
            let p = m - 1;
            writeln!(
                s,
                "    let c{m} = c{p}.mul_add(x, -(s{p} * y));\n    let s{m} = s{p}.mul_add(x, c{p} * y);"
            )
            .unwrap();
        }
        for (lm, p) in polys[m].iter().enumerate() {
            let l = m + lm;
            // Horner in z² over the coefficients of z^d, d ≡ l − m (mod 2).
            let par = lm % 2;
            let cs: Vec<f64> = p.iter().skip(par).step_by(2).copied().collect();
            let mut e = lit(*cs.last().expect("non-empty"));
            for c in cs.iter().rev().skip(1) {
                e = format!("({e}).mul_add(z2, {})", lit(*c));
            }
            if par == 1 {
                e = format!("({e}) * z");
            }
            let base = l * (l + 1);
            if m == 0 {
                writeln!(s, "    o[{base}] = {e};").unwrap();
            } else {
                writeln!(s, "    let q{l}_{m} = {e};").unwrap();
                writeln!(s, "    o[{}] = q{l}_{m} * c{m};", base + m).unwrap();
                writeln!(s, "    o[{}] = q{l}_{m} * s{m};", base - m).unwrap();
            }
        }
    }
    writeln!(s, "}}\n").unwrap();
}

/// `let {dst}{i} = R_z({ang}) {src}` for all coefficients; `{ang}c{m}, {ang}s{m}` in scope.
fn z_stage(s: &mut String, n: usize, src: &str, dst: &str, ang: &str) {
    for l in 0..n {
        let b = l * (l + 1);
        writeln!(s, "    let {dst}{b} = {src}{b};").unwrap();
        for m in 1..=l {
            let (p, q) = (b + m, b - m);
            writeln!(
                s,
                "    let {dst}{p} = {src}{p}.mul_add({ang}c{m}, -({src}{q} * {ang}s{m}));\n    let {dst}{q} = {src}{q}.mul_add({ang}c{m}, {src}{p} * {ang}s{m});"
            )
            .unwrap();
        }
    }
}

/// `let {dst}{i} = X {src}` with the sparse literal matrix `x`.
fn x_stage(s: &mut String, n: usize, x: &ShRotation<f64>, src: &str, dst: &str) {
    for l in 0..n {
        let b = l * (l + 1);
        let li = l as isize;
        for m1 in -li..=li {
            let mut e = String::new();
            for m2 in -li..=li {
                let v = x.get(l, m1, m2);
                if v.abs() < 1e-9 {
                    continue;
                }
                let c = (b as isize + m2) as usize;
                let t = if (v - 1.0).abs() < 1e-12 {
                    format!("{src}{c}")
                } else if (v + 1.0).abs() < 1e-12 {
                    format!("-{src}{c}")
                } else {
                    format!("{src}{c} * {}", lit(v))
                };
                e = if e.is_empty() {
                    t
                } else if (v.abs() - 1.0).abs() < 1e-12 {
                    if v > 0.0 {
                        format!("{e} + {src}{c}")
                    } else {
                        format!("{e} - {src}{c}")
                    }
                } else {
                    format!("{src}{c}.mul_add({}, {e})", lit(v))
                };
            }
            let r = (b as isize + m1) as usize;
            writeln!(s, "    let {dst}{r} = {e};").unwrap();
        }
    }
}

fn rotate_kernel(s: &mut String, n: usize) {
    let nn = n * n;
    let xp = ShRotation::<f64>::from_rotation(
        n,
        &Rot3::from_axis_angle([1.0, 0.0, 0.0], std::f64::consts::FRAC_PI_2).expect("axis"),
    )
    .expect("order");
    let xm = xp.inverse();
    writeln!(
        s,
        "/// `d = R_z(α) X₋ R_z(β) X₊ R_z(γ) v`, order {n}; `e = [cos α, sin α, cos β, sin β, cos γ, sin γ]`."
    )
    .unwrap();
    writeln!(s, "#[inline(always)]").unwrap();
    let us = if n == 1 { "_" } else { "" };
    writeln!(
        s,
        "pub(crate) fn rotate_n{n}{SIG}({us}e: &[V<W, F>; 6], v: &[V<W, F>; {nn}], d: &mut [V<W, F>; {nn}]) {{"
    )
    .unwrap();
    if n > 2 {
        writeln!(s, "    let s = V::<W, F>::splat;").unwrap();
    }
    for (ang, k) in [("a", 0), ("b", 2), ("g", 4)] {
        if n > 1 {
            writeln!(
                s,
                "    let {ang}c1 = e[{k}];\n    let {ang}s1 = e[{}];",
                k + 1
            )
            .unwrap();
        }
        for m in 2..n {
            let p = m - 1;
            writeln!(
                s,
                "    let {ang}c{m} = {ang}c{p}.mul_add({ang}c1, -({ang}s{p} * {ang}s1));\n    let {ang}s{m} = {ang}s{p}.mul_add({ang}c1, {ang}c{p} * {ang}s1);"
            )
            .unwrap();
        }
    }
    for i in 0..nn {
        writeln!(s, "    let v{i} = v[{i}];").unwrap();
    }
    z_stage(s, n, "v", "p", "g");
    x_stage(s, n, &xp, "p", "q");
    z_stage(s, n, "q", "r", "b");
    x_stage(s, n, &xm, "r", "t");
    z_stage(s, n, "t", "u", "a");
    for i in 0..nn {
        writeln!(s, "    d[{i}] = u{i};").unwrap();
    }
    writeln!(s, "}}\n").unwrap();
}

fn product_kernel(s: &mut String, n: usize) {
    let nn = n * n;
    let tp = TripleProduct::<f64>::new(n).expect("order");
    // Output-major (output, a ≤ b, weight) exactly as TripleProduct::new builds it.
    let mut per_out: Vec<Vec<(usize, usize, f64)>> = vec![Vec::new(); nn];
    for (i, j, k, v) in tp.entries() {
        let mut combos = vec![(i, j, k), (j, i, k), (k, i, j)];
        combos.sort_unstable();
        combos.dedup();
        for (o, a, b) in combos {
            per_out[o].push((a.min(b), a.max(b), v));
        }
    }
    // Outputs in chunks of about PRODUCT_CHUNK_TERMS weights, each chunk its own
    // non-inlined function: LLVM's cost on one basic block grows faster than
    // its length (one n = 6 body of ~2800 operations took a minute to
    // compile), and a chunk recomputes only the pair sums it uses.
    let mut chunks: Vec<Vec<usize>> = vec![Vec::new()];
    let mut terms = 0;
    for (o, list) in per_out.iter_mut().enumerate() {
        list.sort_by_key(|e| (e.0, e.1));
        if terms > 0 && terms + list.len() > PRODUCT_CHUNK_TERMS {
            chunks.push(Vec::new());
            terms = 0;
        }
        terms += list.len();
        chunks.last_mut().expect("non-empty").push(o);
    }
    let multi = chunks.len() > 1;
    for (c, outs) in chunks.iter().enumerate() {
        let name = if multi {
            writeln!(s, "/// Outputs {outs:?} of [`product_n{n}`].").unwrap();
            writeln!(s, "#[inline(never)]").unwrap();
            format!("product_n{n}_{c}")
        } else {
            writeln!(
                s,
                "/// `o = f ∗ g` truncated to order {n} (Gaunt coefficients as literals)."
            )
            .unwrap();
            writeln!(s, "#[inline(always)]").unwrap();
            format!("product_n{n}")
        };
        writeln!(
            s,
            "pub(crate) fn {name}{SIG}(f: &[V<W, F>; {nn}], g: &[V<W, F>; {nn}], o: &mut [V<W, F>; {nn}]) {{"
        )
        .unwrap();
        writeln!(s, "    let s = V::<W, F>::splat;").unwrap();
        let mut used = vec![false; nn];
        for &o in outs {
            for &(a, b, _) in &per_out[o] {
                used[a] = true;
                used[b] = true;
            }
        }
        for i in (0..nn).filter(|&i| used[i]) {
            writeln!(s, "    let f{i} = f[{i}];\n    let g{i} = g[{i}];").unwrap();
        }
        let mut have = vec![false; nn * nn];
        for &o in outs {
            let mut e = String::new();
            for &(a, b, w) in &per_out[o] {
                if !have[a * nn + b] {
                    have[a * nn + b] = true;
                    if a == b {
                        writeln!(s, "    let p{a}_{b} = f{a} * g{a};").unwrap();
                    } else {
                        writeln!(s, "    let p{a}_{b} = f{a}.mul_add(g{b}, f{b} * g{a});").unwrap();
                    }
                }
                e = if e.is_empty() {
                    format!("p{a}_{b} * {}", lit(w))
                } else {
                    format!("p{a}_{b}.mul_add({}, {e})", lit(w))
                };
            }
            if e.is_empty() {
                e = "s(0.0)".into();
            }
            writeln!(s, "    o[{o}] = {e};").unwrap();
        }
        writeln!(s, "}}\n").unwrap();
    }
    if multi {
        writeln!(
            s,
            "/// `o = f ∗ g` truncated to order {n} (Gaunt coefficients as literals), in {} chunks.",
            chunks.len()
        )
        .unwrap();
        writeln!(s, "#[inline(always)]").unwrap();
        writeln!(
            s,
            "pub(crate) fn product_n{n}{SIG}(f: &[V<W, F>; {nn}], g: &[V<W, F>; {nn}], o: &mut [V<W, F>; {nn}]) {{"
        )
        .unwrap();
        for c in 0..chunks.len() {
            writeln!(s, "    product_n{n}_{c}(f, g, o);").unwrap();
        }
        writeln!(s, "}}\n").unwrap();
    }
}

fn dispatch(s: &mut String, name: &str, args: &str, call: &str, lo: usize, hi: usize) {
    writeln!(
        s,
        "/// Runs the order-`n` `{name}` kernel on `n²`-long slices; `false` (nothing done) outside {lo}..={hi}.\n\
         ///\n/// # Panics\n/// If a slice is shorter than `n²`."
    )
    .unwrap();
    writeln!(s, "#[inline(always)]").unwrap();
    writeln!(s, "pub(crate) fn {name}{SIG}(n: usize, {args}) -> bool {{").unwrap();
    writeln!(s, "    match n {{").unwrap();
    for n in lo..=hi {
        let nn = n * n;
        let c = call
            .replace("{n}", &n.to_string())
            .replace("{nn}", &nn.to_string());
        writeln!(s, "        {n} => {c},").unwrap();
    }
    writeln!(s, "        _ => return false,\n    }}\n    true\n}}\n").unwrap();
}

/// Source text of `src/kernels.rs`.
#[must_use]
pub fn generate_kernels_source() -> String {
    let mut s = String::new();
    s.push_str(
        "// @generated by relight_sh::kernels_gen::generate_kernels_source — do not edit by hand.\n\
         // Regenerate: RELIGHT_SH_REGENERATE=1 cargo test -p relight-sh kernels_source\n\
         //! Generated straight-line f32 kernels (evaluation, ZYZ rotation, truncated product)\n\
         //! over the lane type `V<W, F>`; see [`crate::kernels_gen`] for what each one unrolls.\n\
         #![allow(clippy::excessive_precision, clippy::unreadable_literal, clippy::too_many_lines, clippy::many_single_char_names, clippy::similar_names, clippy::neg_multiply, unused_variables)]\n\n\
         use crate::lanes::V;\n\n",
    );
    for n in 1..=KERNEL_EVAL_MAX_ORDER {
        eval_kernel(&mut s, n);
    }
    for n in 1..=KERNEL_ROTATE_MAX_ORDER {
        rotate_kernel(&mut s, n);
    }
    for n in 1..=KERNEL_PRODUCT_MAX_ORDER {
        product_kernel(&mut s, n);
    }
    dispatch(
        &mut s,
        "eval",
        "x: V<W, F>, y: V<W, F>, z: V<W, F>, o: &mut [V<W, F>]",
        "eval_n{n}(x, y, z, (&mut o[..{nn}]).try_into().expect(\"length\"))",
        1,
        KERNEL_EVAL_MAX_ORDER,
    );
    dispatch(
        &mut s,
        "rotate",
        "e: &[V<W, F>; 6], v: &[V<W, F>], d: &mut [V<W, F>]",
        "rotate_n{n}(e, (&v[..{nn}]).try_into().expect(\"length\"), (&mut d[..{nn}]).try_into().expect(\"length\"))",
        1,
        KERNEL_ROTATE_MAX_ORDER,
    );
    dispatch(
        &mut s,
        "product",
        "f: &[V<W, F>], g: &[V<W, F>], o: &mut [V<W, F>]",
        "product_n{n}((&f[..{nn}]).try_into().expect(\"length\"), (&g[..{nn}]).try_into().expect(\"length\"), (&mut o[..{nn}]).try_into().expect(\"length\"))",
        1,
        KERNEL_PRODUCT_MAX_ORDER,
    );
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn kernels_source_matches_generator() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/kernels.rs");
        let want = super::generate_kernels_source();
        if std::env::var_os("RELIGHT_SH_REGENERATE").is_some() {
            std::fs::write(path, &want).unwrap();
        }
        let have = std::fs::read_to_string(path).unwrap_or_default();
        assert!(
            have == want,
            "src/kernels.rs drifted from generate_kernels_source(); regenerate with RELIGHT_SH_REGENERATE=1 cargo test -p relight-sh kernels_source"
        );
    }
}
