//! Generator of `crate::kernels`: per-order straight-line f32 kernels for
//! evaluation, exact rotation and the truncated product, written once over the
//! lane type `crate::lanes::V` (one item, or eight items side by side).
//!
//! Each kernel is an existing portable algorithm of this crate unrolled for a
//! fixed order, constants as literals, no loops, no bounds checks, no
//! dispatch:
//!
//! * **evaluation**: the associated-Legendre recurrence of [`crate::basis`]
//!   (via `crate::basis::legendre_polynomials`), `Q_l^m` in Horner form in
//!   `z²`, `(x + iy)^m` by repeated squaring;
//! * **rotation**: bands 1 and 2 straight from the 3×3 matrix (a linear and
//!   a quadratic form, `matrix_bands_1_2`), bands ≥ 3 by the ZYZ ("ZXZXZ")
//!   factorisation of [`crate::rotation::ZyzRotation`],
//!   `R = R_z(α) X₋ R_z(β) X₊ R_z(γ)` with the fixed `X± = R_x(±90°)` band
//!   matrices (computed exactly in f64 by Ivanic–Ruedenberg) written as
//!   sparse literal dot products;
//! * **product**: the Gaunt triples of [`crate::product::TripleProduct`]
//!   grouped by index pair, DirectXMath's factorisation: for the pair `(a, b)`
//!   `t = f_a g_b + f_b g_a` feeds every `y_k` of its triples `{a, b, k}`, and
//!   `Σ_k Γ f_k`, `Σ_k Γ g_k` feed `y_a` and `y_b` (≈ 3 multiply–adds per
//!   triple); in chunks above n = 4, each chunk with a portable, an
//!   AVX2+FMA and an AVX-512F copy (the same code with 32 registers). The
//!   one-chunk kernels (n ≤ 4) read their inputs through fresh pointers per
//!   pair block (`crate::lanes::fresh`), so the inputs are memory operands
//!   and only the accumulators stay in registers.
//! * **rotation** runs band by band (all five stages of one band, then the
//!   next), so only one band's intermediates are live at a time.
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

/// Operations per non-inlined chunk of a generated product kernel (compile
/// time: see `product_kernel`).
const PRODUCT_CHUNK_OPS: usize = 600;

fn lit(v: f64) -> String {
    format!("s({:?})", v as f32)
}

const SIG: &str = "<const W: usize, const F: bool>";
/// Evaluation and rotation are generic over any [`crate::lanes::Lane`]
/// (`V<W, F>` or the AVX2 register type `F8`).
const LSIG: &str = "<L: Lane>";

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
        "pub(crate) fn eval_n{n}{LSIG}({us}x: L, {us}y: L, {us}z: L, o: &mut [L; {nn}]) {{"
    )
    .unwrap();
    writeln!(s, "    let s = L::splat;").unwrap();
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

/// `let {dst}{i} = R_z({ang}) {src}` for the coefficients of bands `lo..n`; `{ang}c{m}, {ang}s{m}` in scope.
fn z_stage(s: &mut String, lo: usize, n: usize, src: &str, dst: &str, ang: &str) {
    for l in lo..n {
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

/// `let {dst}{i} = X {src}` with the sparse literal matrix `x`, bands `lo..n`.
fn x_stage(s: &mut String, lo: usize, n: usize, x: &ShRotation<f64>, src: &str, dst: &str) {
    for l in lo..n {
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

/// Bands 1 and 2 of an exact rotation straight from the matrix `m`
/// (`m[i][j]` = `R_ij`, acting on column vectors), no Euler angles.
///
/// * Band 1 is a linear form: with `y_{1,−1} ∝ −y`, `y_{1,0} ∝ z`,
///   `y_{1,1} ∝ −x` (Condon–Shortley, crate docs) the band is `c uᵀω` with
///   `u = (−v₃, −v₁, v₂)`, and `f(R⁻¹ω)` has `u' = R u`.
/// * Band 2 is a quadratic form `ωᵀQω`, `Q` symmetric and traceless (the
///   five `y_{2,m}` are `a·xy`, `−a·yz`, `b(2z² − x² − y²)`, `−a·xz`,
///   `(a/2)(x² − y²)` on the sphere, `a = ½√(15/π)`, `b = ¼√(5/π)`); the
///   rotated function has `Q' = R Q Rᵀ`. In units of `a/2`:
///   `Q = [[v₈ − κv₆, v₄, −v₇], [v₄, −v₈ − κv₆, −v₅], [−v₇, −v₅, 2κv₆]]`,
///   `κ = 2b/a = 1/√3`, and back `v₄' = Q'_xy`, `v₅' = −Q'_yz`,
///   `v₆' = (√3/2) Q'_zz`, `v₇' = −Q'_xz`, `v₈' = (Q'_xx − Q'_yy)/2`.
///   45 multiply–adds, against 25 + 25 for building and applying the 5×5
///   band matrix (DirectXMath's order-3 code).
fn matrix_bands_1_2(s: &mut String, n: usize) {
    if n < 2 {
        return;
    }
    for i in 0..3 {
        for j in 0..3 {
            writeln!(s, "    let m{i}{j} = m[{i}][{j}];").unwrap();
        }
    }
    writeln!(
        s,
        "    let (v1, v2, v3) = (v[1], v[2], v[3]);\n\
         \x20   d[1] = m12.mul_add(-v2, m11.mul_add(v1, m10 * v3));\n\
         \x20   d[2] = m22.mul_add(v2, -(m21.mul_add(v1, m20 * v3)));\n\
         \x20   d[3] = m02.mul_add(-v2, m01.mul_add(v1, m00 * v3));"
    )
    .unwrap();
    if n < 3 {
        return;
    }
    let kappa = lit(1.0 / 3f64.sqrt());
    let half_sqrt3 = lit(3f64.sqrt() / 2.0);
    writeln!(
        s,
        "    let k6 = v[6] * {kappa};\n\
         \x20   let (qxy, qyz, qxz) = (v[4], -v[5], -v[7]);\n\
         \x20   let (qxx, qyy, qzz) = (v[8] - k6, -(v[8] + k6), k6 + k6);"
    )
    .unwrap();
    // P = R Q (row i of R times column j of the symmetric Q).
    let q = [
        ["qxx", "qxy", "qxz"],
        ["qxy", "qyy", "qyz"],
        ["qxz", "qyz", "qzz"],
    ];
    for i in 0..3 {
        for j in 0..3 {
            writeln!(
                s,
                "    let p{i}{j} = m{i}2.mul_add({}, m{i}1.mul_add({}, m{i}0 * {}));",
                q[2][j], q[1][j], q[0][j]
            )
            .unwrap();
        }
    }
    // Q' = P Rᵀ: Q'_ij = Σ_k P_ik R_jk, the five entries needed.
    for (name, i, j) in [
        ("wxy", 0, 1),
        ("wyz", 1, 2),
        ("wxz", 0, 2),
        ("wzz", 2, 2),
        ("wxx", 0, 0),
        ("wyy", 1, 1),
    ] {
        writeln!(
            s,
            "    let {name} = p{i}2.mul_add(m{j}2, p{i}1.mul_add(m{j}1, p{i}0 * m{j}0));"
        )
        .unwrap();
    }
    writeln!(
        s,
        "    d[4] = wxy;\n    d[5] = -wyz;\n    d[6] = wzz * {half_sqrt3};\n    d[7] = -wxz;\n    d[8] = (wxx - wyy) * s(0.5);"
    )
    .unwrap();
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
        "/// `d = R v`, order {n}: bands 0–2 straight from the matrix `m` (`R_ij = m[i][j]`),\n\
         /// bands ≥ 3 as `R_z(α) X₋ R_z(β) X₊ R_z(γ)` with `e = [cos α, sin α, cos β, sin β, cos γ, sin γ]`\n\
         /// the ZYZ angles of the same `R` (unused below order 4)."
    )
    .unwrap();
    writeln!(s, "#[inline(always)]").unwrap();
    let um = if n == 1 { "_" } else { "" };
    let ue = if n < 4 { "_" } else { "" };
    writeln!(
        s,
        "pub(crate) fn rotate_n{n}{LSIG}({um}m: &[[L; 3]; 3], {ue}e: &[L; 6], v: &[L; {nn}], d: &mut [L; {nn}]) {{"
    )
    .unwrap();
    if n > 2 {
        writeln!(s, "    let s = L::splat;").unwrap();
    }
    writeln!(s, "    d[0] = v[0];").unwrap();
    matrix_bands_1_2(s, n);
    if n > 3 {
        for (ang, k) in [("a", 0), ("b", 2), ("g", 4)] {
            writeln!(
                s,
                "    let {ang}c1 = e[{k}];\n    let {ang}s1 = e[{}];",
                k + 1
            )
            .unwrap();
            // cos mθ, sin mθ by the Chebyshev recurrence
            // x_m = 2 cos θ · x_{m−1} − x_{m−2}: one multiply–add per value
            // and one per step on the dependency chain (the angle-addition
            // formula took two of each).
            writeln!(s, "    let {ang}t = {ang}c1 + {ang}c1;").unwrap();
            writeln!(
                s,
                "    let {ang}c2 = {ang}t.mul_add({ang}c1, s(-1.0));\n    let {ang}s2 = {ang}t * {ang}s1;"
            )
            .unwrap();
            for m in 3..n {
                let (p, q) = (m - 1, m - 2);
                writeln!(
                    s,
                    "    let {ang}c{m} = {ang}t.mul_add({ang}c{p}, -{ang}c{q});\n    let {ang}s{m} = {ang}t.mul_add({ang}s{p}, -{ang}s{q});"
                )
                .unwrap();
            }
        }
        // Band by band, all five stages each: only one band's values are
        // live at a time (stage by stage over all bands kept every band's
        // intermediates live and spilled at n = 5, 6).
        for l in 3..n {
            let span = l * l..(l + 1) * (l + 1);
            for i in span.clone() {
                writeln!(s, "    let v{i} = v[{i}];").unwrap();
            }
            z_stage(s, l, l + 1, "v", "p", "g");
            x_stage(s, l, l + 1, &xp, "p", "q");
            z_stage(s, l, l + 1, "q", "r", "b");
            x_stage(s, l, l + 1, &xm, "r", "t");
            z_stage(s, l, l + 1, "t", "u", "a");
            for i in span {
                writeln!(s, "    d[{i}] = u{i};").unwrap();
            }
        }
    }
    writeln!(s, "}}\n").unwrap();
}

/// One block of the product kernel: the Gaunt triples `{a, b, k}` that share
/// the pair `(a, b)` (DirectXMath's factorisation of `XMSHMultiplyN`).
struct PairBlock {
    a: usize,
    b: usize,
    /// `(k, Γ_{abk})`, `k ∉ {a, b}`.
    ks: Vec<(usize, f64)>,
    /// `Γ_{aaa}` (only for `a = b`).
    aaa: Option<f64>,
}

impl PairBlock {
    /// Operations the block emits (for chunking).
    fn ops(&self) -> usize {
        3 * self.ks.len() + 6
    }
}

/// The Gaunt triples of order `n` grouped into pair blocks. Every triple with
/// a repeated index `{a, a, k}` goes to the pair `(a, a)`; the triples of three
/// distinct indices are covered greedily, always by the pair that still has
/// the most uncovered triples (fewer blocks, fewer per-block operations).
fn pair_blocks(n: usize) -> Vec<PairBlock> {
    let nn = n * n;
    let tp = TripleProduct::<f64>::new(n).expect("order");
    let mut diag: Vec<PairBlock> = (0..nn)
        .map(|a| PairBlock {
            a,
            b: a,
            ks: Vec::new(),
            aaa: None,
        })
        .collect();
    let mut distinct: Vec<([usize; 3], f64)> = Vec::new();
    for (i, j, k, v) in tp.entries() {
        if i == j && j == k {
            diag[i].aaa = Some(v);
        } else if i == j {
            diag[i].ks.push((k, v));
        } else if j == k {
            diag[j].ks.push((i, v));
        } else {
            distinct.push(([i, j, k], v));
        }
    }
    // pair -> the distinct triples containing it.
    let mut by_pair: std::collections::BTreeMap<(usize, usize), Vec<usize>> =
        std::collections::BTreeMap::new();
    for (t, ([i, j, k], _)) in distinct.iter().enumerate() {
        for pair in [(*i, *j), (*i, *k), (*j, *k)] {
            by_pair.entry(pair).or_default().push(t);
        }
    }
    let mut covered = vec![false; distinct.len()];
    let mut count: std::collections::BTreeMap<(usize, usize), usize> =
        by_pair.iter().map(|(p, v)| (*p, v.len())).collect();
    let mut blocks: Vec<PairBlock> = Vec::new();
    let mut left = distinct.len();
    while left > 0 {
        // The first pair (in index order) with the most uncovered triples.
        let (&(a, b), _) = count
            .iter()
            .max_by(|x, y| x.1.cmp(y.1).then(y.0.cmp(x.0)))
            .expect("uncovered triples have pairs");
        let mut ks = Vec::new();
        for &t in &by_pair[&(a, b)] {
            if covered[t] {
                continue;
            }
            covered[t] = true;
            left -= 1;
            let ([i, j, k], v) = distinct[t];
            let other = i + j + k - a - b;
            ks.push((other, v));
            for pair in [(i, j), (i, k), (j, k)] {
                *count.get_mut(&pair).expect("pair") -= 1;
            }
        }
        ks.sort_by_key(|e| e.0);
        blocks.push(PairBlock {
            a,
            b,
            ks,
            aaa: None,
        });
    }
    blocks.extend(
        diag.into_iter()
            .filter(|d| !d.ks.is_empty() || d.aaa.is_some()),
    );
    blocks.sort_by_key(|d| (d.a, d.b));
    blocks
}

/// Which outputs a product kernel has written so far.
struct Acc {
    touched: Vec<bool>,
}

impl Acc {
    /// `o[k] += x · w` (`x` an expression, `w` a literal).
    fn add(&mut self, s: &mut String, k: usize, x: &str, w: f64) {
        let w = lit(w);
        let e = if self.touched[k] {
            format!("{x}.mul_add({w}, *o.add({k}))")
        } else {
            format!("{x} * {w}")
        };
        writeln!(s, "    *o.add({k}) = {e};").unwrap();
        self.touched[k] = true;
    }

    /// `o[k] += u · v + p · q`.
    fn add2(&mut self, s: &mut String, k: usize, [u, v, p, q]: [&str; 4]) {
        let e = if self.touched[k] {
            format!("{u}.mul_add({v}, {p}.mul_add({q}, *o.add({k})))")
        } else {
            format!("{u}.mul_add({v}, {p} * {q})")
        };
        writeln!(s, "    *o.add({k}) = {e};").unwrap();
        self.touched[k] = true;
    }
}

/// Emits one pair block: `t = f_a g_b + f_b g_a` (or `f_a g_a`) feeds every
/// `y_k`, and `tf = Σ_k Γ f_k`, `tg = Σ_k Γ g_k` feed `y_a` and `y_b`.
/// The load of `f[i]` (`src = 'f'`) or `g[i]` in a product kernel: read where
/// used, not hoisted into a variable (see `product_kernel`).
fn ld(src: char, i: usize) -> String {
    format!("(*{src}.add({i}))")
}
fn fv(i: usize) -> String {
    ld('f', i)
}
fn gv(i: usize) -> String {
    ld('g', i)
}

fn emit_block(s: &mut String, acc: &mut Acc, blk: &PairBlock, fresh: bool) {
    let (a, b) = (blk.a, blk.b);
    if fresh {
        writeln!(s, "    let (f, g) = (fresh(f), fresh(g));").unwrap();
    }
    if a == b {
        writeln!(s, "    let t = {} * {};", fv(a), gv(a)).unwrap();
    } else {
        writeln!(
            s,
            "    let t = {}.mul_add({}, {} * {});",
            fv(a),
            gv(b),
            fv(b),
            gv(a)
        )
        .unwrap();
    }
    if let Some(w) = blk.aaa {
        acc.add(s, a, "t", w);
    }
    for &(k, w) in &blk.ks {
        acc.add(s, k, "t", w);
    }
    if blk.ks.is_empty() {
        return;
    }
    for (name, src) in [("tf", 'f'), ("tg", 'g')] {
        let mut e = String::new();
        for &(k, w) in &blk.ks {
            e = if e.is_empty() {
                format!("{} * {}", ld(src, k), lit(w))
            } else {
                format!("{}.mul_add({}, {e})", ld(src, k), lit(w))
            };
        }
        writeln!(s, "    let {name} = {e};").unwrap();
    }
    let (fb, gb, fa, ga) = (fv(b), gv(b), fv(a), gv(a));
    acc.add2(s, a, ["tf", &gb, "tg", &fb]);
    if a != b {
        acc.add2(s, b, ["tf", &ga, "tg", &fa]);
    }
}

fn product_kernel(s: &mut String, n: usize) {
    let nn = n * n;
    let blocks = pair_blocks(n);
    // Blocks in chunks of about PRODUCT_CHUNK_OPS operations, each chunk its
    // own non-inlined function (one portable copy, one AVX2+FMA copy): LLVM's
    // cost on one basic block grows faster than its length (one n = 6 body of
    // ~2800 operations took a minute to compile). A chunk keeps its
    // accumulators in registers and hands them on through `o`.
    let mut chunks: Vec<Vec<&PairBlock>> = vec![Vec::new()];
    let mut ops = 0;
    for blk in &blocks {
        if ops > 0 && ops + blk.ops() > PRODUCT_CHUNK_OPS {
            chunks.push(Vec::new());
            ops = 0;
        }
        ops += blk.ops();
        chunks.last_mut().expect("non-empty").push(blk);
    }
    let mut acc = Acc {
        touched: vec![false; nn],
    };
    for (c, blks) in chunks.iter().enumerate() {
        let last = c + 1 == chunks.len();
        writeln!(
            s,
            "/// Pair blocks {:?}…{:?} of the order-{n} product `o = f ∗ g` (chunk {c} of {}).",
            (blks[0].a, blks[0].b),
            (blks[blks.len() - 1].a, blks[blks.len() - 1].b),
            chunks.len()
        )
        .unwrap();
        let name = format!("product_n{n}_{c}");
        writeln!(
            s,
            "///\n/// # Safety\n/// `f`, `g` and `o` each point to {nn} values (`o` may overlap neither)."
        )
        .unwrap();
        writeln!(s, "#[inline(always)]").unwrap();
        writeln!(
            s,
            "pub(crate) unsafe fn {name}{SIG}(f: *const V<W, F>, g: *const V<W, F>, o: *mut V<W, F>) {{"
        )
        .unwrap();
        writeln!(s, "    let s = V::<W, F>::splat;").unwrap();
        writeln!(s, "    // SAFETY: the caller's contract.\n    unsafe {{").unwrap();
        for blk in blks {
            emit_block(s, &mut acc, blk, chunks.len() == 1);
        }
        if last {
            for k in (0..nn).filter(|&k| !acc.touched[k]) {
                writeln!(s, "    *o.add({k}) = s(0.0);").unwrap();
            }
        }
        writeln!(s, "    }}\n}}\n").unwrap();
    }
    // The non-inlined entry points: one portable, one
    // AVX2+FMA copy per chunk. They take raw pointers, so LLVM may not assume
    // that `o` overlaps neither input: every accumulation goes through memory
    // and every input is loaded where used, as in DirectXMath's C code. With
    // `&mut` outputs it kept all accumulators and inputs of a chunk live and
    // spilled most of them (n = 6 was 1.8× slower).
    for (fma, suffix) in ISAS {
        let t = if fma { "V<1, true>" } else { "V<1, false>" };
        let sig = format!("(f: *const {t}, g: *const {t}, o: *mut {t})");
        let attrs = isa_attrs(suffix);
        let single = chunks.len() == 1;
        for c in 0..chunks.len() {
            if single {
                // One chunk (n ≤ 4): references, so that LLVM keeps the few
                // accumulators in registers (measured 5–8 % faster there).
                writeln!(
                    s,
                    "{attrs}#[inline(never)]\nfn product_n{n}_{c}_{suffix}(f: &[{t}; {nn}], g: &[{t}; {nn}], o: &mut [{t}; {nn}]) {{\n    // SAFETY: {nn} values each; `o` is exclusive.\n    unsafe {{ product_n{n}_{c}(f.as_ptr(), g.as_ptr(), o.as_mut_ptr()) }};\n}}\n"
                )
                .unwrap();
            } else {
                writeln!(
                    s,
                    "/// # Safety\n/// As [`product_n{n}_{c}`].\n{attrs}#[inline(never)]\nunsafe fn product_n{n}_{c}_{suffix}{sig} {{\n    // SAFETY: the caller's contract.\n    unsafe {{ product_n{n}_{c}(f, g, o) }};\n}}\n"
                )
                .unwrap();
            }
        }
        writeln!(
            s,
            "/// `o = f ∗ g` truncated to order {n}, {} chunks ({suffix}): inlined into the\n/// caller, which calls the chunks directly.\n///\n/// # Safety\n/// As [`product_n{n}_0`]; the CPU must have the features of the `{suffix}` copy.\n{}#[inline(always)]\nunsafe fn product_n{n}_{suffix}{sig} {{\n    // SAFETY: the caller's contract.\n    unsafe {{",
            chunks.len(),
            isa_cfg(suffix)
        )
        .unwrap();
        for c in 0..chunks.len() {
            if single {
                writeln!(
                    s,
                    "        product_n{n}_{c}_{suffix}(&*f.cast::<[{t}; {nn}]>(), &*g.cast::<[{t}; {nn}]>(), &mut *o.cast::<[{t}; {nn}]>());"
                )
                .unwrap();
            } else {
                writeln!(s, "        product_n{n}_{c}_{suffix}(f, g, o);").unwrap();
            }
        }
        writeln!(s, "    }}\n}}\n").unwrap();
    }
}

/// The product kernels' copies: plain multiply and add, AVX2 + FMA, and
/// AVX-512 (the FMA code with 32 vector registers instead of 16, so the
/// accumulators of a one-chunk kernel stay in registers).
const ISAS: [(bool, &str); 3] = [(false, "plain"), (true, "fma"), (true, "avx512")];

/// The `#[cfg]` line of one copy of [`ISAS`].
fn isa_cfg(suffix: &str) -> &'static str {
    if suffix == "plain" {
        ""
    } else {
        "#[cfg(target_arch = \"x86_64\")]\n"
    }
}

/// `#[cfg]`/`#[target_feature]` lines of one copy of [`ISAS`].
fn isa_attrs(suffix: &str) -> &'static str {
    match suffix {
        "fma" => "#[cfg(target_arch = \"x86_64\")]\n#[target_feature(enable = \"avx2,fma\")]\n",
        "avx512" => {
            "#[cfg(target_arch = \"x86_64\")]\n#[target_feature(enable = \"avx512f,avx512vl,avx2,fma\")]\n"
        }
        _ => "",
    }
}

/// `product_plain`, `product_fma` and `product_avx512`: the order-`n` product on `n²`-long slices.
fn product_dispatch(s: &mut String) {
    for (fma, suffix) in ISAS {
        let t = if fma { "V<1, true>" } else { "V<1, false>" };
        let doc = match suffix {
            "fma" => "with fused multiply–add (AVX2 + FMA)",
            "avx512" => "with fused multiply–add, compiled for AVX-512F",
            _ => "with plain multiply and add",
        };
        // Inlined into the caller (no target feature of its own): the
        // caller tests the CPU once, and one call reaches the order's code.
        let (safety, unsafety) = if fma {
            (
                "\n///\n/// # Safety\n/// The CPU must have the features of the copy.",
                "unsafe ",
            )
        } else {
            ("", "")
        };
        writeln!(
            s,
            "/// Runs the order-`n` product kernel {doc} on `n²`-long slices; `false` (nothing done) outside 1..={KERNEL_PRODUCT_MAX_ORDER}.\n\
             ///\n/// # Panics\n/// If a slice is shorter than `n²`.{safety}"
        )
        .unwrap();
        writeln!(
            s,
            "{}#[inline(always)]\npub(crate) {unsafety}fn product_{suffix}(n: usize, f: &[{t}], g: &[{t}], o: &mut [{t}]) -> bool {{",
            isa_cfg(suffix)
        )
        .unwrap();
        writeln!(s, "    match n {{").unwrap();
        for n in 1..=KERNEL_PRODUCT_MAX_ORDER {
            let nn = n * n;
            let callee = format!("product_n{n}_{suffix}");
            writeln!(
                s,
                "        // SAFETY: the slices hold {nn} values each (checked), `o` is exclusive.\n        {n} => unsafe {{ {callee}(f[..{nn}].as_ptr(), g[..{nn}].as_ptr(), o[..{nn}].as_mut_ptr()) }},"
            )
            .unwrap();
        }
        writeln!(s, "        _ => return false,\n    }}\n    true\n}}\n").unwrap();
    }
}

fn dispatch(s: &mut String, name: &str, args: &str, call: &str, lo: usize, hi: usize) {
    let sig = if args.contains("V<W, F>") { SIG } else { LSIG };
    writeln!(
        s,
        "/// Runs the order-`n` `{name}` kernel on `n²`-long slices; `false` (nothing done) outside {lo}..={hi}.\n\
         ///\n/// # Panics\n/// If a slice is shorter than `n²`."
    )
    .unwrap();
    writeln!(s, "#[inline(always)]").unwrap();
    writeln!(s, "pub(crate) fn {name}{sig}(n: usize, {args}) -> bool {{").unwrap();
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
         //! over the lane types `V<W, F>` / [`Lane`]; see [`crate::kernels_gen`] for what each one unrolls.\n\
         #![allow(clippy::excessive_precision, clippy::unreadable_literal, clippy::too_many_lines, clippy::many_single_char_names, clippy::similar_names, clippy::neg_multiply, unused_variables, unused_parens)]\n\n\
         use crate::lanes::{Lane, V, fresh};\n\n",
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
        "x: L, y: L, z: L, o: &mut [L]",
        "eval_n{n}(x, y, z, (&mut o[..{nn}]).try_into().expect(\"length\"))",
        1,
        KERNEL_EVAL_MAX_ORDER,
    );
    dispatch(
        &mut s,
        "rotate",
        "m: &[[L; 3]; 3], e: &[L; 6], v: &[L], d: &mut [L]",
        "rotate_n{n}(m, e, (&v[..{nn}]).try_into().expect(\"length\"), (&mut d[..{nn}]).try_into().expect(\"length\"))",
        1,
        KERNEL_ROTATE_MAX_ORDER,
    );
    product_dispatch(&mut s);
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
