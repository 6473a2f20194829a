//! The 2D extension (eqs. 4.30–4.32) on `relight-haar`'s nonstandard basis:
//! against 2D quadrature with that crate's own basis evaluation, and 2D
//! propagation against inverse Haar → box resampling → forward Haar.

use relight_affine::other_bases::pixel_acc;
use relight_affine::separable::{
    affine_coupling_2d, affine_coupling_2d_quadrature, atoms_2d, basis_of_atoms, propagate_2d,
};
use relight_haar::{Basis, try_forward_2d, try_inverse_2d};

#[test]
fn atoms_round_trip() {
    let n = 16;
    for idx in 0..n * n {
        let b = Basis::from_index(idx, n);
        let (u, v) = atoms_2d(b);
        assert_eq!(basis_of_atoms(u, v), Some(b));
        // the product of the atoms is the basis function (texel centres)
        for (x, y) in [(0usize, 0usize), (3, 9), (15, 15), (7, 8)] {
            let (pu, pv) = ((x as f64 + 0.5) / n as f64, (y as f64 + 0.5) / n as f64);
            let prod = u.eval(pu) * v.eval(pv);
            assert!((prod - b.eval(n, pu, pv)).abs() < 1e-5, "{b:?} ({x},{y})");
        }
    }
}

#[test]
fn coupling_2d_matches_quadrature_with_haar_basis_eval() {
    let n = 8;
    // Dyadic (s, o) put every break point on the quadrature grid: exact midpoint.
    let cases = [
        ([0.5, 0.5], [0.25, 0.125]),
        ([2.0, 1.0], [-0.5, 0.25]),
        ([1.0, 0.5], [0.125, 0.5]),
    ];
    for (s, o) in cases {
        for i in (0..n * n).step_by(5) {
            for j in (0..n * n).step_by(7) {
                let (bi, bj) = (Basis::from_index(i, n), Basis::from_index(j, n));
                let d = affine_coupling_2d(bi, bj, s, o);
                let q = affine_coupling_2d_quadrature(bi, bj, n, s, o, 256);
                assert!(
                    (d - q).abs() <= 1e-9,
                    "{bi:?} {bj:?} s={s:?} o={o:?}: {d} vs {q}"
                );
            }
        }
    }
    // A generic (s, o): midpoint error O(h), bounded loosely.
    let (s, o) = ([0.73, 0.73], [0.11, -0.07]);
    for (i, j) in [(0, 0), (1, 5), (9, 20), (37, 63), (2, 2)] {
        let (bi, bj) = (Basis::from_index(i, n), Basis::from_index(j, n));
        let d = affine_coupling_2d(bi, bj, s, o);
        let q = affine_coupling_2d_quadrature(bi, bj, n, s, o, 1024);
        assert!((d - q).abs() <= 0.05, "{bi:?} {bj:?}: {d} vs {q}");
    }
}

#[test]
fn propagation_2d_equals_pixel_box_resampling() {
    let n = 16;
    let img: Vec<f32> = (0..n * n)
        .map(|k| (((k * 37 + 11) % 23) as f32) / 23.0)
        .collect();
    for (s, o) in [
        ([1.0, 1.0], [0.0, 0.0]),
        ([0.5, 0.5], [0.25, 0.3]),
        ([0.8, 0.8], [0.07, -0.1]),
        ([1.7, 1.7], [-0.3, -0.2]),
    ] {
        let mut coeffs = img.clone();
        try_forward_2d(&mut coeffs, n).unwrap();
        let mut out = vec![0.0; n * n];
        propagate_2d(&coeffs, n, s, o, &mut out);
        let mut back: Vec<f32> = out.iter().map(|&x| x as f32).collect();
        try_inverse_2d(&mut back, n).unwrap();
        // Pixel path: L(x) = F(s x + o) projected on texels = Σ F_t D^pix.
        for ty in 0..n {
            for tx in 0..n {
                let mut want = 0.0;
                for y in 0..n {
                    let dy = pixel_acc(y, ty, n, s[1], o[1]);
                    if dy == 0.0 {
                        continue;
                    }
                    for x in 0..n {
                        want += f64::from(img[y * n + x]) * pixel_acc(x, tx, n, s[0], o[0]) * dy;
                    }
                }
                let got = f64::from(back[ty * n + tx]);
                assert!(
                    (got - want).abs() <= 1e-5,
                    "s={s:?} o={o:?} ({tx},{ty}): {got} vs {want}"
                );
            }
        }
    }
}

/// The zoom bench's rows (quick size): exact at 100 % against the pixel
/// path (inverse Haar → box resampling → forward Haar), compressed rows
/// lossy but close.
#[test]
fn zoom_rows_are_exact_at_full_terms() {
    let rows = relight_affine::bench::zoom_rows(true);
    assert_eq!(rows.len(), 5);
    assert!(rows[0].max_diff <= 1e-5, "{:?}", rows[0]);
    assert!(
        rows[1].psnr_db > 20.0 && rows[1].psnr_db.is_finite(),
        "{:?}",
        rows[1]
    );
}

/// The full-size zoom rows, printed (a timing, not a check): `cargo test
/// --release -p relight-affine --test separable -- --ignored --nocapture zoom_full`.
#[test]
#[ignore = "a timing at bench size"]
fn zoom_full_size_rows() {
    for r in relight_affine::bench::zoom_rows(false) {
        println!("{r:?}");
    }
}
