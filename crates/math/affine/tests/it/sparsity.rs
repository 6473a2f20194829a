//! Exact non-zero counts (§4.4.1–4.4.3, Fig. 4.6), the sparse rows of the
//! computational approach, the 4D table, and the pixel/Fourier forms.

use relight_affine::Atom;
use relight_affine::coupling::affine_tripling;
use relight_affine::other_bases::{
    fourier_acc, fourier_acc_quadrature, fourier_atc, fourier_atc_quadrature, pixel_acc,
    pixel_acc_bound, pixel_acc_bound_integer, pixel_acc_nonzeros,
};
use relight_affine::rows::{acc_dense, acc_row, propagate};
use relight_affine::sparsity::{acc_nonzeros, atc_nonzeros, random_sets};
use relight_affine::table::{AccTable, Grid, quantisation_error};

#[test]
fn sparse_rows_equal_the_dense_matrix() {
    let n = 64;
    for (s, o) in random_sets(8, 3)
        .into_iter()
        .chain([(1.0, 0.0), (0.5, 0.25)])
    {
        let dense = acc_dense(n, s, o);
        let mut row = Vec::new();
        let mut total = 0;
        for i in 0..n {
            acc_row(i, n, s, o, &mut row);
            let mut from_row = vec![0.0; n];
            for &(j, d) in &row {
                assert_ne!(d, 0.0);
                from_row[j as usize] = d;
            }
            assert_eq!(
                &from_row[..],
                &dense[i * n..(i + 1) * n],
                "row {i} s={s} o={o}"
            );
            total += row.len();
        }
        assert_eq!(total, dense.iter().filter(|d| **d != 0.0).count());
        assert_eq!(total, acc_nonzeros(n, s, o));
    }
}

#[test]
fn acc_nonzeros_are_at_most_2_n_log_n() {
    for (s, o) in random_sets(50, 1) {
        let mut n = 2;
        while n <= 512 {
            let nz = acc_nonzeros(n, s, o) as f64;
            let bound = 2.0 * n as f64 * (n as f64).log2();
            assert!(nz <= bound, "N={n} s={s} o={o}: {nz} > {bound}");
            n *= 2;
        }
    }
    assert_eq!(acc_nonzeros(256, 1.0, 0.0), 256, "identity at s = 1, o = 0");
}

#[test]
fn atc_count_equals_brute_force() {
    let n = 16;
    for (s, o) in random_sets(4, 7).into_iter().chain([(1.0, 0.0)]) {
        let mut brute = 0;
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let (i, j, k) = (
                        Atom::from_index(i),
                        Atom::from_index(j),
                        Atom::from_index(k),
                    );
                    brute += usize::from(affine_tripling(i, j, k, s, o) != 0.0);
                }
            }
        }
        assert_eq!(atc_nonzeros(n, s, o), brute, "s={s} o={o}");
    }
}

#[test]
fn pixel_counts_respect_the_tight_bound() {
    let n = 64;
    let (mut tight, mut exceeded) = (false, false);
    for (s, o) in random_sets(40, 11)
        .into_iter()
        .chain([(1.0, 0.0), (2.0, 0.0), (0.5, 0.0)])
    {
        let brute = (0..n * n)
            .filter(|p| pixel_acc(p / n, p % n, n, s, o) != 0.0)
            .count();
        let count = pixel_acc_nonzeros(n, s, o);
        assert_eq!(count, brute);
        assert!(
            count <= pixel_acc_bound_integer(n, s),
            "s={s} o={o}: {count}"
        );
        assert!(
            count as f64 <= pixel_acc_bound(n, s) + 1.0,
            "s={s} o={o}: {count}"
        );
        exceeded |= count as f64 > pixel_acc_bound(n, s);
        tight |= count == pixel_acc_bound_integer(n, s);
    }
    assert!(tight, "bound never attained");
    assert!(
        exceeded,
        "the thesis' real-valued bound is exceeded by one for some s"
    );
}

#[test]
fn fourier_closed_forms_match_quadrature() {
    for s in [1i64, 2, 3] {
        for p in -3..=3 {
            for q in -6..=6 {
                let o = 0.37;
                let (a, b) = (
                    fourier_acc(p, q, s, o),
                    fourier_acc_quadrature(p, q, s as f64, o, 4096),
                );
                assert!(
                    (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9,
                    "4.18 p={p} q={q} s={s}"
                );
                for m in [-2i64, 0, 1] {
                    let (a, b) = (
                        fourier_atc(m, p, q, s, o),
                        fourier_atc_quadrature(m, p, q, s as f64, o, 4096),
                    );
                    assert!(
                        (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9,
                        "4.19 n={m} p={p} q={q}"
                    );
                }
            }
        }
    }
}

#[test]
fn table_reproduces_grid_points_and_bilinear_beats_nearest() {
    let n = 16;
    let grid = Grid::standard(16);
    let table = AccTable::build(n, grid);
    let f: Vec<f64> = (0..n)
        .map(|k| ((k * 7 + 3) % 11) as f64 / 11.0 - 0.4)
        .collect();
    let (mut exact, mut near) = (vec![0.0; n], vec![0.0; n]);
    let mut row = Vec::new();
    let (s, o) = (grid.s_at(5), grid.o_at(9));
    propagate(&f, s, o, &mut exact, &mut row);
    table.propagate_nearest(&f, s, o, &mut near);
    for (a, b) in exact.iter().zip(&near) {
        assert!(
            (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
            "on-grid: {a} vs {b}"
        );
    }
    let queries = random_sets(40, 99);
    let (en, eb) = quantisation_error(&table, &f, &queries);
    assert!(en > 0.0 && eb < en, "nearest {en}, bilinear {eb}");
    assert!(table.bytes() > 8 * table.nonzeros());
}
