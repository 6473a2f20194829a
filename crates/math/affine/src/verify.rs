//! `relight verify affine`: every closed form of §4.3–4.4 against exact
//! overlap, quadrature, brute force or finite differences, as rows.
//!
//! Each gated row has `max_error` ≤ `target` to pass and names the target's
//! `source`; report rows (`pass = None`) show what the uncorrected OCR'd
//! formulas give.

use crate::atom::{Atom, Kind};
use crate::canonical::{
    canonical, canonical_fig44, canonical_gradient, canonical_overlap, canonical_quadrature,
    primitive_form,
};
use crate::coupling::{
    affine_coupling, affine_coupling_gradient, affine_coupling_overlap, affine_coupling_quadrature,
    affine_tripling, affine_tripling_quadrature, property2, standard_coupling, standard_tripling,
    tripling_by_lemma1,
};
use crate::other_bases::{pixel_acc, pixel_acc_bound, pixel_acc_bound_integer, pixel_acc_nonzeros};
use crate::separable::{affine_coupling_2d, affine_coupling_2d_quadrature, propagate_2d};
use crate::sparsity::{acc_nonzeros, random_sets, thesis_acc_bound};
use relight_haar::{Basis, try_forward_2d, try_inverse_2d};

const ISSUE: &str = "issue 13";

/// One row of `relight verify affine`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VerifyRow {
    /// What is checked (equation or figure).
    pub check: String,
    /// Against what.
    pub against: &'static str,
    /// Cases evaluated.
    pub cases: usize,
    /// The measure: max absolute error (or, for counts, the excess ratio).
    pub max_error: f64,
    /// `gate` or `report`.
    pub kind: &'static str,
    /// Whether `max_error ≤ target` (gates only).
    pub pass: Option<bool>,
    /// The bound (gates only).
    pub target: Option<f64>,
    /// Where the target comes from.
    pub source: Option<String>,
}

fn gate(
    check: impl Into<String>,
    against: &'static str,
    cases: usize,
    err: f64,
    target: f64,
    source: &str,
) -> VerifyRow {
    VerifyRow {
        check: check.into(),
        against,
        cases,
        max_error: err,
        kind: "gate",
        pass: Some(err <= target),
        target: Some(target),
        source: Some(source.to_string()),
    }
}

fn report(check: impl Into<String>, against: &'static str, cases: usize, err: f64) -> VerifyRow {
    VerifyRow {
        check: check.into(),
        against,
        cases,
        max_error: err,
        kind: "report",
        pass: None,
        target: None,
        source: None,
    }
}

const KINDS: [(Kind, Kind); 4] = [
    (Kind::Box, Kind::Box),
    (Kind::Box, Kind::Wave),
    (Kind::Wave, Kind::Box),
    (Kind::Wave, Kind::Wave),
];

fn rc_grid(quick: bool) -> Vec<(f64, f64)> {
    let nr = if quick { 30 } else { 120 };
    let nc = if quick { 100 } else { 400 };
    let mut pts = Vec::new();
    for a in 0..nr {
        let r = 0.02 * (200f64).powf(a as f64 / (nr - 1) as f64); // 0.02 … 4
        for b in 0..=nc {
            pts.push((r, -r - 0.7 + (2.0 * r + 2.4) * b as f64 / nc as f64));
        }
        pts.extend([(r, 0.5), (r, 0.0), (r, 1.0), (r, r + 0.5), (r, 0.5 - r)]);
    }
    pts
}

fn atoms() -> Vec<Atom> {
    let mut v: Vec<Atom> = (0..16).map(Atom::from_index).collect();
    for l in 1..4 {
        v.extend((0..1u32 << l).map(|t| Atom::new_box(l, t)));
    }
    v
}

fn lf(i: Atom, j: Atom) -> f64 {
    (0.5 * (f64::from(i.level) - f64::from(j.level))).exp2()
}

fn fig44_signed(r: f64, c: f64) -> f64 {
    let d = (c - 0.5f64).abs();
    let (sr, dr, maxr, minr) = (r + 0.5, r - 0.5, r.max(0.5), r.min(0.5));
    if d >= sr {
        0.0
    } else if d >= maxr {
        d - sr
    } else if d >= dr.max(minr) {
        dr - d
    } else if d >= dr.min(minr) {
        if dr >= minr { 0.0 } else { sr - 3.0 * d }
    } else {
        2.0 * (minr - d)
    }
}

/// All rows of `relight verify affine`; `quick` uses coarser grids, 10⁵
/// instead of 10⁶ quadrature samples and N ≤ 512 instead of 4096.
#[must_use]
pub fn verify_affine(quick: bool) -> Vec<VerifyRow> {
    let mut rows = Vec::new();
    rows.extend(canonical_rows(quick));
    rows.extend(coupling_rows(quick));
    rows.extend(separable_rows());
    rows.extend(count_rows(quick));
    rows
}

fn canonical_rows(quick: bool) -> Vec<VerifyRow> {
    let grid = rc_grid(quick);
    let mut rows = Vec::new();
    let (mut e_ov, mut e_fig, mut e_ocr) = (0.0f64, 0.0f64, 0.0f64);
    let (mut e24, mut e27, mut e28, mut e_bound) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for &(r, c) in &grid {
        for (a, b) in KINDS {
            let m = canonical(a, b, r, c);
            e_ov = e_ov.max((m - canonical_overlap(a, b, r, c)).abs());
            if (c - 0.5).abs() > r + 0.5 {
                e24 = e24.max(m.abs());
            }
            let sign = if a == b { 1.0 } else { -1.0 };
            e27 = e27.max((m - sign * canonical(a, b, r, 1.0 - c)).abs());
            let inv = 2.0 * r * canonical(b, a, 0.25 / r, 0.5 + 0.25 / r - c / (2.0 * r));
            e28 = e28.max((m - inv).abs());
        }
        let ov = canonical_overlap(Kind::Wave, Kind::Wave, r, c);
        e_fig = e_fig.max((canonical_fig44(r, c) - ov).abs());
        e_ocr = e_ocr.max((fig44_signed(r, c) - ov).abs());
        let m = canonical(Kind::Wave, Kind::Wave, r, c);
        e_bound = e_bound.max(m - 2.0 * r.min(0.5)).max(-r.min(0.5) - m);
    }
    let n = grid.len();
    rows.push(gate(
        "M(r,c) eq. 4.22, all four φ/ψ kinds",
        "exact overlap",
        4 * n,
        e_ov,
        1e-12,
        ISSUE,
    ));
    rows.push(gate(
        "M_ψψ Fig. 4.4, dr = |r − ½|",
        "exact overlap",
        n,
        e_fig,
        1e-12,
        ISSUE,
    ));
    rows.push(report(
        "M_ψψ Fig. 4.4 as OCR'd (signed dr)",
        "exact overlap",
        n,
        e_ocr,
    ));
    let samples = if quick { 100_000 } else { 1_000_000 };
    let pts = [
        (0.13, 0.41),
        (0.3, 0.9),
        (0.5, 0.5),
        (0.7, -0.1),
        (1.6, 0.2),
        (0.37, 1.2),
        (2.5, 1.9),
        (0.05, 0.02),
    ];
    let mut eq = 0.0f64;
    for (r, c) in pts {
        for (a, b) in KINDS {
            eq = eq.max((canonical(a, b, r, c) - canonical_quadrature(a, b, r, c, samples)).abs());
        }
    }
    rows.push(gate(
        if quick {
            "M(r,c), 10⁵ midpoint samples"
        } else {
            "M(r,c), 10⁶ midpoint samples"
        },
        "quadrature",
        4 * pts.len(),
        eq,
        2e-5,
        ISSUE,
    ));
    rows.push(gate(
        "eq. 4.24 M = 0 for |c−½| > r+½",
        "exact zero",
        4 * n,
        e24,
        0.0,
        "thesis eq. 4.24",
    ));
    rows.push(gate(
        "eq. 4.27 reflection symmetry (odd for mixed kinds)",
        "M itself",
        4 * n,
        e27,
        1e-12,
        "thesis eq. 4.27",
    ));
    rows.push(gate(
        "eq. 4.28 M(r,c) = 2r M(1/(4r), ½+1/(4r)−c/(2r))",
        "M itself",
        4 * n,
        e28,
        1e-12,
        "thesis eq. 4.28",
    ));
    rows.push(gate(
        "bounds −min(r,½) ≤ M_ψψ ≤ 2 min(r,½)",
        "M itself",
        n,
        e_bound.max(0.0),
        1e-12,
        "thesis §4.4.2 Boundedness",
    ));
    // Derivatives (eqs. 4.25–4.26).
    let h = 1e-7;
    let (mut e_d, mut cnt) = (0.0f64, 0);
    for &(r, c) in &grid {
        for (a, b) in KINDS {
            let f = |r: f64, c: f64| primitive_form(a, b, r, c);
            let (fc, bc) = ((f(r, c + h) - f(r, c)) / h, (f(r, c) - f(r, c - h)) / h);
            let (fr, br) = ((f(r + h, c) - f(r, c)) / h, (f(r, c) - f(r - h, c)) / h);
            if (fc - bc).abs() > 1e-5 || (fr - br).abs() > 1e-5 {
                continue;
            }
            let (dr, dc) = canonical_gradient(a, b, r, c);
            e_d = e_d.max((dc - fc).abs()).max((dr - fr).abs());
            cnt += 1;
        }
    }
    rows.push(gate(
        "eqs. 4.25–4.26 ∂M/∂c, ∂M/∂r",
        "finite differences (h = 1e-7)",
        cnt,
        e_d,
        1e-5,
        ISSUE,
    ));
    rows
}

fn coupling_rows(quick: bool) -> Vec<VerifyRow> {
    let mut rows = Vec::new();
    let at = atoms();
    let sets = random_sets(if quick { 6 } else { 24 }, 5);
    let (mut e_ov, mut e_ocr, mut e13, mut cnt) = (0.0f64, 0.0f64, 0.0f64, 0);
    for &(s, o) in &sets {
        for &i in &at {
            for &j in &at {
                let d = affine_coupling(i, j, s, o);
                let ov = affine_coupling_overlap(i, j, s, o);
                e_ov = e_ov.max((d - ov).abs() / lf(i, j).max(1.0));
                let dl = (f64::from(j.level) - f64::from(i.level)).exp2();
                let c_ocr =
                    (dl * f64::from(i.offset) - i.scale() * o + 0.5 * dl) / s - f64::from(j.offset);
                let wrong = lf(i, j) * canonical(i.kind, j.kind, 0.5 * dl / s, c_ocr);
                e_ocr = e_ocr.max((wrong - ov).abs() / lf(i, j).max(1.0));
                let b = affine_coupling(j, i, 1.0 / s, -o / s) / s;
                e13 = e13.max((d - b).abs() / lf(i, j).max(lf(j, i)));
                cnt += 1;
            }
        }
    }
    rows.push(gate(
        "ACC eqs. 4.21–4.23, c with 2^{l_j}·o",
        "exact overlap in v",
        cnt,
        e_ov,
        1e-12,
        ISSUE,
    ));
    rows.push(report(
        "ACC eq. 4.23 as OCR'd (2^{l_i}·o)",
        "exact overlap in v",
        cnt,
        e_ocr,
    ));
    rows.push(gate(
        "eq. 4.13 D_ij(s,o) = D_ji(1/s,−o/s)/s",
        "ACC itself",
        cnt,
        e13,
        1e-12,
        "thesis eq. 4.13",
    ));
    let samples = 100_000;
    let (mut eq, mut qn) = (0.0f64, 0);
    for &(s, o) in sets.iter().take(3) {
        for &i in at.iter().step_by(3) {
            for &j in at.iter().step_by(4) {
                let q = affine_coupling_quadrature(i, j, s, o, samples);
                let w = lf(i, j).max(1.0) * (1.0 + s * i.scale() / j.scale());
                eq = eq.max((q - affine_coupling(i, j, s, o)).abs() / w);
                qn += 1;
            }
        }
    }
    rows.push(gate(
        "ACC D_ij(s,o) / (2^{(l_i−l_j)/2}(1+s2^{l_i−l_j}))",
        "quadrature, 10⁵ samples",
        qn,
        eq,
        2e-5,
        ISSUE,
    ));
    // Standard coefficients.
    let b32: Vec<Atom> = (0..32).map(Atom::from_index).collect();
    let mut e12 = 0.0f64;
    for &i in &b32 {
        for &j in &b32 {
            e12 = e12.max((standard_coupling(i, j) - if i == j { 1.0 } else { 0.0 }).abs());
        }
    }
    rows.push(gate(
        "eq. 4.12 C_ij = D_ij(1,0) = δ_ij (N = 32)",
        "Kronecker delta",
        1024,
        e12,
        0.0,
        "thesis §4.3.3",
    ));
    let b16: Vec<Atom> = (0..16).map(Atom::from_index).collect();
    let mut e11 = 0.0f64;
    for &i in &b16 {
        for &j in &b16 {
            for &k in &b16 {
                let c = standard_tripling(i, j, k);
                for p in [
                    standard_tripling(j, i, k),
                    standard_tripling(k, j, i),
                    standard_tripling(i, k, j),
                ] {
                    e11 = e11.max((c - p).abs());
                }
            }
        }
    }
    rows.push(gate(
        "eq. 4.11 C_ijk symmetric (N = 16)",
        "permutations",
        4096,
        e11,
        1e-12,
        "thesis eq. 4.11",
    ));
    // ACC derivatives.
    let h = 1e-7;
    let (mut e_d, mut dn) = (0.0f64, 0);
    for &(s, o) in &sets {
        for &i in &at {
            for &j in &at {
                let f = |s: f64, o: f64| affine_coupling_overlap(i, j, s, o);
                let (fs, bs) = ((f(s + h, o) - f(s, o)) / h, (f(s, o) - f(s - h, o)) / h);
                let (fo, bo) = ((f(s, o + h) - f(s, o)) / h, (f(s, o) - f(s, o - h)) / h);
                let w = 16.0 * lf(i, j).max(1.0) * j.scale();
                if (fs - bs).abs() > 1e-4 * w || (fo - bo).abs() > 1e-4 * w {
                    continue;
                }
                let (ds, d_o) = affine_coupling_gradient(i, j, s, o);
                e_d = e_d.max((ds - fs).abs() / w).max((d_o - fo).abs() / w);
                dn += 1;
            }
        }
    }
    rows.push(gate(
        "∂D_ij/∂s, ∂D_ij/∂o by the chain rule / (16·2^{(l_i−l_j)/2}·2^{l_j})",
        "finite differences (h = 1e-7)",
        dn,
        e_d,
        1e-4,
        ISSUE,
    ));
    // ATC.
    let (mut e_l1, mut e_p2, mut tn, mut pn) = (0.0f64, 0.0f64, 0, 0);
    for &(s, o) in sets.iter().take(3) {
        for &i in &at {
            for &j in &b16 {
                for &k in &b16 {
                    let d = affine_tripling(i, j, k, s, o);
                    let w = lf(i, j).max(1.0) * j.scale().max(k.scale()).sqrt() * 4.0;
                    e_l1 = e_l1.max((d - tripling_by_lemma1(i, j, k, s, o, 16)).abs() / w);
                    tn += 1;
                    if let Some(p2) = property2(i, j, k, s, o) {
                        e_p2 = e_p2.max((d - p2).abs() / w);
                        pn += 1;
                    }
                }
            }
        }
    }
    rows.push(gate(
        "Lemma 1 eq. 4.14 Σ_l D_il C_ljk (N = 16)",
        "direct ATC",
        tn,
        e_l1,
        1e-12,
        "thesis Lemma 1",
    ));
    rows.push(gate(
        "Property 2 eq. 4.29 with sign σ",
        "direct ATC",
        pn,
        e_p2,
        1e-12,
        ISSUE,
    ));
    rows.push(report(
        "Property 2 eq. 4.29 as printed (no σ)",
        "direct ATC",
        pn,
        unsigned_p2_error(&sets, &at, &b16),
    ));
    let mut e_tq = 0.0f64;
    let mut qn = 0;
    for &(s, o) in sets.iter().take(2) {
        for &i in at.iter().step_by(5) {
            for j in [0usize, 1, 5, 9].map(Atom::from_index) {
                for k in [0usize, 3, 9, 13].map(Atom::from_index) {
                    let q = affine_tripling_quadrature(i, j, k, s, o, samples);
                    let w =
                        lf(i, j).max(1.0) * j.scale().max(k.scale()).sqrt() * (1.0 + s * i.scale());
                    e_tq = e_tq.max((q - affine_tripling(i, j, k, s, o)).abs() / w);
                    qn += 1;
                }
            }
        }
    }
    rows.push(gate(
        "ATC D_ijk(s,o), scaled as the ACC row",
        "quadrature, 10⁵ samples",
        qn,
        e_tq,
        2e-5,
        ISSUE,
    ));
    rows
}

/// Max error of eq. 4.29 without σ (`|…| M`), to show the correction.
fn unsigned_p2_error(sets: &[(f64, f64)], at: &[Atom], b16: &[Atom]) -> f64 {
    let mut e = 0.0f64;
    for &(s, o) in sets.iter().take(3) {
        for &i in at {
            for &j in b16 {
                for &k in b16 {
                    if let Some(p2) = property2(i, j, k, s, o) {
                        let (n, m) = if j.level <= k.level { (j, k) } else { (k, j) };
                        let unsigned = if n.product(m).is_some_and(|(kap, _)| kap < 0.0) {
                            -p2
                        } else {
                            p2
                        };
                        e = e.max((affine_tripling(i, j, k, s, o) - unsigned).abs());
                    }
                }
            }
        }
    }
    e
}

fn separable_rows() -> Vec<VerifyRow> {
    let mut rows = Vec::new();
    let n = 8;
    let cases = [
        ([0.5, 0.5], [0.25, 0.125]),
        ([2.0, 1.0], [-0.5, 0.25]),
        ([1.0, 0.5], [0.125, 0.5]),
    ];
    let (mut e, mut cnt) = (0.0f64, 0);
    for (s, o) in cases {
        for i in (0..n * n).step_by(5) {
            for j in (0..n * n).step_by(7) {
                let (bi, bj) = (Basis::from_index(i, n), Basis::from_index(j, n));
                let d = affine_coupling_2d(bi, bj, s, o);
                e = e.max((d - affine_coupling_2d_quadrature(bi, bj, n, s, o, 256)).abs());
                cnt += 1;
            }
        }
    }
    rows.push(gate(
        "eq. 4.31 2D ACC = product of 1D (dyadic s, o)",
        "2D quadrature with relight-haar Basis::eval",
        cnt,
        e,
        1e-9,
        ISSUE,
    ));
    let n = 16;
    let img: Vec<f32> = (0..n * n)
        .map(|k| (((k * 37 + 11) % 23) as f32) / 23.0)
        .collect();
    let mut e = 0.0f64;
    let mut cnt = 0;
    for (s, o) in [
        ([1.0, 1.0], [0.0, 0.0]),
        ([0.5, 0.5], [0.25, 0.3]),
        ([0.8, 0.8], [0.07, -0.1]),
        ([1.7, 1.7], [-0.3, -0.2]),
    ] {
        let mut coeffs = img.clone();
        if try_forward_2d(&mut coeffs, n).is_err() {
            continue;
        }
        let mut out = vec![0.0; n * n];
        propagate_2d(&coeffs, n, s, o, &mut out);
        let mut back: Vec<f32> = out.iter().map(|&x| x as f32).collect();
        if try_inverse_2d(&mut back, n).is_err() {
            continue;
        }
        for ty in 0..n {
            for tx in 0..n {
                let mut want = 0.0;
                for y in 0..n {
                    let dy = pixel_acc(y, ty, n, s[1], o[1]);
                    if dy != 0.0 {
                        for x in 0..n {
                            want +=
                                f64::from(img[y * n + x]) * pixel_acc(x, tx, n, s[0], o[0]) * dy;
                        }
                    }
                }
                e = e.max((f64::from(back[ty * n + tx]) - want).abs());
                cnt += 1;
            }
        }
    }
    rows.push(gate(
        "2D propagation in wavelets (16², 4 transforms)",
        "inverse Haar → box resampling → forward Haar",
        cnt,
        e,
        1e-5,
        ISSUE,
    ));
    // Zoom at 100 % (§4.6.2): the identity, exactly.
    let n2 = 32;
    let img2: Vec<f32> = (0..n2 * n2)
        .map(|k| (((k * 53 + 7) % 31) as f32) / 31.0)
        .collect();
    let mut c2 = img2.clone();
    let mut e_id = f64::INFINITY;
    if try_forward_2d(&mut c2, n2).is_ok() {
        let (s, o) = crate::separable::zoom_transform(1.0, [0.5, 0.5]);
        let mut out = vec![0.0; n2 * n2];
        let src: Vec<(u32, f32)> = c2.iter().enumerate().map(|(k, &v)| (k as u32, v)).collect();
        let mut scratch = crate::zoom::ZoomScratch::default();
        crate::zoom::zoom_sparse(&src, n2, s, o, n2, &mut out, &mut scratch);
        let mut back: Vec<f32> = out.iter().map(|&x| x as f32).collect();
        if try_inverse_2d(&mut back, n2).is_ok() {
            e_id = img2
                .iter()
                .zip(&back)
                .map(|(a, b)| f64::from((a - b).abs()))
                .fold(0.0, f64::max);
        }
    }
    rows.push(gate(
        "wavelet zoom at 100 % (32², scale 1, centre ½,½)",
        "the input image",
        n2 * n2,
        e_id,
        1e-5,
        ISSUE,
    ));
    rows
}

fn count_rows(quick: bool) -> Vec<VerifyRow> {
    let mut rows = Vec::new();
    let sets = random_sets(50, 1);
    let n = 256;
    let (mut excess, mut thesis_excess) = (i64::MIN, f64::MIN);
    for (s, o) in random_sets(60, 11) {
        let c = pixel_acc_nonzeros(n, s, o);
        excess = excess.max(c as i64 - pixel_acc_bound_integer(n, s) as i64);
        thesis_excess = thesis_excess.max(c as f64 - pixel_acc_bound(n, s));
    }
    rows.push(gate(
        "pixel ACC count − (N + ⌈min(s,1/s)N⌉), N = 256",
        "exact count",
        60,
        excess as f64,
        0.0,
        ISSUE,
    ));
    rows.push(report(
        "pixel ACC count − min((s+1)N,(1/s+1)N) (thesis bound)",
        "exact count",
        60,
        thesis_excess,
    ));
    let max_n = if quick { 512 } else { 4096 };
    // (ratio, N) of the worst case against each bound.
    let (mut worst, mut worst_thesis, mut worst_thesis4, mut cnt) =
        ((0.0f64, 0), (0.0f64, 0), (0.0f64, 0), 0);
    for &(s, o) in &sets {
        let mut n = 2;
        while n <= max_n {
            let nz = acc_nonzeros(n, s, o) as f64;
            let a = nz / (2.0 * n as f64 * (n as f64).log2());
            let b = nz / thesis_acc_bound(n);
            if a > worst.0 {
                worst = (a, n);
            }
            if b > worst_thesis.0 {
                worst_thesis = (b, n);
            }
            if n >= 4 && b > worst_thesis4.0 {
                worst_thesis4 = (b, n);
            }
            cnt += 1;
            n *= 2;
        }
    }
    rows.push(gate(
        format!(
            "Haar ACC non-zeros / (2N log₂N), N = 2…{max_n}, 50 (s,o); worst at N = {}",
            worst.1
        ),
        "exact count",
        cnt,
        worst.0,
        1.0,
        ISSUE,
    ));
    rows.push(report(
        format!(
            "Haar ACC non-zeros / (N log₂N + log₂²N) (thesis bound); worst at N = {}",
            worst_thesis.1
        ),
        "exact count",
        cnt,
        worst_thesis.0,
    ));
    rows.push(report(
        format!("the same for N ≥ 4; worst at N = {}", worst_thesis4.1),
        "exact count",
        cnt,
        worst_thesis4.0,
    ));
    rows
}
