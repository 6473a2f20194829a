//! The pixel and Fourier bases of §4.4.1, for the complexity table (§4.4.3).
//!
//! **Pixel basis** of order `N` on \[0, 1\]: `P_i = √N` on `[i/N, (i+1)/N)`.
//! `D_ij(s, o) = N |[(i/N − o)/s, ((i+1)/N − o)/s) ∩ [j/N, (j+1)/N)|`; its
//! non-zeros are the cells of the common refinement of the two partitions,
//! at most `min((s+1)N, (1/s+1)N)` (the thesis' tight bound). The pixel STC
//! is `√N δ_ij δ_jk`, so by Lemma 1 the ATC has the ACC's non-zeros.
//!
//! **Fourier basis** on \[0, 2π\]: `Φ_p(v) = (2π)^{−½} e^{I p v}`,
//! conjugating the last factor. For an integer scale `s`, eq. 4.18:
//! `D_pq(s, o) = e^{I p o} δ_{sp, q}`; eq. 4.19:
//! `D_npq(s, o) = (2π)^{−½} e^{I n o} δ_{sn+p, q}`. (For non-integer `s`,
//! `e^{I(sp − q)v}` no longer integrates to zero over a period and the ACC
//! is dense; the table uses integer `s`.)

/// `D_ij(s, o)` in the pixel basis of order `n` (exact overlap).
#[must_use]
pub fn pixel_acc(i: usize, j: usize, n: usize, s: f64, o: f64) -> f64 {
    let nf = n as f64;
    let (v0, v1) = ((i as f64 / nf - o) / s, ((i + 1) as f64 / nf - o) / s);
    let (w0, w1) = (j as f64 / nf, (j + 1) as f64 / nf);
    nf * (v1.min(w1) - v0.max(w0)).max(0.0)
}

/// Number of non-zero pixel ACCs `D_ij(s, o)` over all `i, j < n`, by
/// counting overlapping cells per source pixel.
#[must_use]
pub fn pixel_acc_nonzeros(n: usize, s: f64, o: f64) -> usize {
    let nf = n as f64;
    let mut count = 0;
    for i in 0..n {
        let (v0, v1) = ((i as f64 / nf - o) / s, ((i + 1) as f64 / nf - o) / s);
        let (lo, hi) = (v0.max(0.0), v1.min(1.0));
        if hi <= lo {
            continue;
        }
        let j0 = (lo * nf).floor() as usize;
        let j1 = ((hi * nf).ceil() as usize).min(n);
        count += (j0..j1)
            .filter(|&j| pixel_acc(i, j, n, s, o) != 0.0)
            .count();
    }
    count
}

/// The thesis' bound `min((s+1)N, (1/s+1)N)` on [`pixel_acc_nonzeros`].
/// It is exceeded by one when `min(s, 1/s) N` is not an integer (e.g.
/// N = 64, s = 0.5245, o = 0.1692: 98 > 97.6); [`pixel_acc_bound_integer`]
/// is the bound that holds.
#[must_use]
pub fn pixel_acc_bound(n: usize, s: f64) -> f64 {
    let nf = n as f64;
    ((s + 1.0) * nf).min((1.0 / s + 1.0) * nf)
}

/// The pixel ACC bound with the rounding made explicit:
/// `N + ⌈min(s, 1/s) N⌉` — the cells of the common refinement of two
/// partitions are their break points inside the overlap minus one: all
/// `N + 1` of the finer-in-extent partition and at most `⌈min(s,1/s) N⌉ − 1`
/// interior ones of the other.
#[must_use]
pub fn pixel_acc_bound_integer(n: usize, s: f64) -> usize {
    n + (s.min(1.0 / s) * n as f64).ceil() as usize
}

/// A complex number `(re, im)`.
pub type Complex = (f64, f64);

/// `Φ_p(v) = (2π)^{−½} e^{I p v}` (`p` may be fractional for `Φ_p(s v)`).
fn fourier(p: f64, v: f64) -> Complex {
    let a = (2.0 * std::f64::consts::PI).powf(-0.5);
    (a * (p * v).cos(), a * (p * v).sin())
}

fn mul(a: Complex, b: Complex) -> Complex {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}

/// Eq. 4.18: `D_pq(s, o) = e^{I p o} δ_{sp, q}` for integer `s`.
#[must_use]
pub fn fourier_acc(p: i64, q: i64, s: i64, o: f64) -> Complex {
    if s * p == q {
        ((p as f64 * o).cos(), (p as f64 * o).sin())
    } else {
        (0.0, 0.0)
    }
}

/// Eq. 4.19: `D_npq(s, o) = (2π)^{−½} e^{I n o} δ_{sn+p, q}` for integer `s`.
#[must_use]
pub fn fourier_atc(n: i64, p: i64, q: i64, s: i64, o: f64) -> Complex {
    if s * n + p == q {
        let a = (2.0 * std::f64::consts::PI).powf(-0.5);
        (a * (n as f64 * o).cos(), a * (n as f64 * o).sin())
    } else {
        (0.0, 0.0)
    }
}

/// `∫_0^{2π} Φ_p(s v + o) Φ_q*(v) dv` by the midpoint rule (check of 4.18).
#[must_use]
pub fn fourier_acc_quadrature(p: i64, q: i64, s: f64, o: f64, samples: usize) -> Complex {
    let h = 2.0 * std::f64::consts::PI / samples as f64;
    let mut acc = (0.0, 0.0);
    for k in 0..samples {
        let v = (k as f64 + 0.5) * h;
        let a = fourier(p as f64, s * v + o);
        let b = fourier(-(q as f64), v);
        let m = mul(a, b);
        acc = (acc.0 + m.0 * h, acc.1 + m.1 * h);
    }
    acc
}

/// `∫_0^{2π} Φ_n(s v + o) Φ_p(v) Φ_q*(v) dv` by the midpoint rule (check of 4.19).
#[must_use]
pub fn fourier_atc_quadrature(n: i64, p: i64, q: i64, s: f64, o: f64, samples: usize) -> Complex {
    let h = 2.0 * std::f64::consts::PI / samples as f64;
    let mut acc = (0.0, 0.0);
    for k in 0..samples {
        let v = (k as f64 + 0.5) * h;
        let m = mul(
            mul(fourier(n as f64, s * v + o), fourier(p as f64, v)),
            fourier(-(q as f64), v),
        );
        acc = (acc.0 + m.0 * h, acc.1 + m.1 * h);
    }
    acc
}

/// Non-zero Fourier ACCs for frequencies `p, q ∈ [−N/2, N/2)` and integer `s`.
#[must_use]
pub fn fourier_acc_nonzeros(n: usize, s: i64) -> usize {
    let h = (n / 2) as i64;
    (-h..h).filter(|p| (-h..h).contains(&(s * p))).count()
}

/// Non-zero Fourier ATCs (`q = s n + p` in range) for integer `s`.
#[must_use]
pub fn fourier_atc_nonzeros(n: usize, s: i64) -> usize {
    let h = (n / 2) as i64;
    let mut count = 0;
    for a in -h..h {
        for p in -h..h {
            if (-h..h).contains(&(s * a + p)) {
                count += 1;
            }
        }
    }
    count
}
