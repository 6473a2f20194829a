//! The standard (tensor-product) 2D Haar basis and its two-step separable
//! light propagation (thesis §4.5.5, "Log-Linear-Time Light Propagation").
//!
//! The basis of an `n × n` map is every product `Φ_{i1}(x) Φ_{i2}(y)` of
//! two members of the order-`n` 1D basis ([`crate::atom`]: index 0 = φ,
//! `2^l + t` = ψ_{l,t}); coefficient `(i1, i2)` is stored at `i2 · n + i1`.
//! Unlike the nonstandard basis of `relight-haar` the two factors may sit at
//! different levels, so every 2D ACC is exactly a product of two 1D ACCs,
//! `D_{(i1,i2)(k1,k2)} = D_{i1k1}(s1, o1) · D_{i2k2}(s2, o2)`, and
//! propagation `L_k = Σ_i F_i D_ik` (eq. 4.35) splits into
//!
//! ```text
//!   step 1:  Z_{i2 k1} = Σ_{i1} F_{i1 i2} D_{i1 k1}(s1, o1)
//!   step 2:  L_{k1 k2} = Σ_{i2} Z_{i2 k1} D_{i2 k2}(s2, o2)
//! ```
//!
//! each `O(n log N)` for `n` retained terms of `N = n²` ([`propagate_two_step`]).
//! The 1D transform here is the orthonormal one of the atoms: a function
//! given by its `n` cell means transforms exactly (no quadrature).

use crate::rows::acc_row;

/// In-place orthonormal 1D Haar transform of `n` cell means (`n` a power of
/// two) into the atom layout; `tmp` is scratch of length `n`.
pub fn forward_1d(data: &mut [f64], tmp: &mut [f64]) {
    let n = data.len();
    let mut len = n;
    while len > 1 {
        let half = len / 2;
        // Level of the wavelets produced: 2^l = half.
        let amp = 0.5 / (half as f64).sqrt();
        for t in 0..half {
            let (m1, m2) = (data[2 * t], data[2 * t + 1]);
            tmp[t] = 0.5 * (m1 + m2);
            tmp[half + t] = (m1 - m2) * amp;
        }
        data[..len].copy_from_slice(&tmp[..len]);
        len = half;
    }
}

/// Inverse of [`forward_1d`]: coefficients → `n` cell means.
pub fn inverse_1d(data: &mut [f64], tmp: &mut [f64]) {
    let n = data.len();
    let mut len = 1;
    while len < n {
        let amp = (len as f64).sqrt();
        for t in 0..len {
            let (a, c) = (data[t], data[len + t] * amp);
            tmp[2 * t] = a + c;
            tmp[2 * t + 1] = a - c;
        }
        data[..2 * len].copy_from_slice(&tmp[..2 * len]);
        len *= 2;
    }
}

/// Standard 2D transform of an `n × n` grid of cell means (row-major, row
/// `y`, column `x`) in place: rows, then columns. Output layout `i2 · n + i1`.
pub fn forward_2d(grid: &mut [f64], n: usize) {
    apply_2d(grid, n, forward_1d);
}

/// Inverse of [`forward_2d`].
pub fn inverse_2d(grid: &mut [f64], n: usize) {
    apply_2d(grid, n, inverse_1d);
}

fn apply_2d(grid: &mut [f64], n: usize, f: fn(&mut [f64], &mut [f64])) {
    let mut tmp = vec![0.0; n];
    let mut col = vec![0.0; n];
    for row in grid.chunks_mut(n) {
        f(row, &mut tmp);
    }
    for x in 0..n {
        for y in 0..n {
            col[y] = grid[y * n + x];
        }
        f(&mut col, &mut tmp);
        for y in 0..n {
            grid[y * n + x] = col[y];
        }
    }
}

/// The dense 1D ACC matrix `D[i][k] = D_ik(s, o)` of the order-`n` basis
/// (row-major `i · n + k`, f32) from the exact sparse rows ([`acc_row`]);
/// `row` is scratch.
pub fn acc_matrix_f32(n: usize, s: f64, o: f64, out: &mut [f32], row: &mut Vec<(u32, f64)>) {
    out.iter_mut().for_each(|x| *x = 0.0);
    for i in 0..n {
        acc_row(i, n, s, o, row);
        for &(k, d) in row.iter() {
            out[i * n + k as usize] = d as f32;
        }
    }
}

/// [`acc_matrix_f32`] by the primitive form directly, without the
/// canonical reduction: the run-time path of near-field relighting, where
/// `exp2` and the structural-zero tests of [`crate::canonical()`] dominate.
///
/// For a source atom with constant pieces `±A_i` on `[x_a, x_b)` (in
/// `x = s v + o`), `D_ik = Σ_pieces ±A_i (P_k(v_b) − P_k(v_a))` with
/// `v = (x − o)/s` and `P_k` the primitive of target `Φ_k`: `clamp(v, 0, 1)`
/// for φ, `2^{−l/2} tent(2^l v − t)` for ψ_{l,t} (`tent(x) = max(0, ½ −
/// |x − ½|)`). Only targets whose support meets `[v_a, v_b)` are evaluated;
/// the others are exact zeros. Agrees with [`acc_matrix_f32`] to f32
/// rounding (`tests/it/standard.rs`), except that a coefficient the canonical
/// form returns as an exact zero may come out as a rounding residue here.
pub fn acc_matrix_fast(n: usize, s: f64, o: f64, out: &mut [f32]) {
    out.iter_mut().for_each(|x| *x = 0.0);
    let levels = n.trailing_zeros();
    let inv_s = 1.0 / s;
    let tent = |x: f64| (0.5 - (x - 0.5).abs()).max(0.0);
    for i in 0..n {
        // Source pieces in v: breakpoints and signs.
        let (li, ti) = if i == 0 {
            (0u32, 0usize)
        } else {
            let l = usize::BITS - 1 - i.leading_zeros();
            (l, i - (1usize << l))
        };
        let w = 1.0 / f64::from(1u32 << li);
        let amp = if i == 0 {
            1.0
        } else {
            f64::from(1u32 << li).sqrt()
        };
        let va = (ti as f64 * w - o) * inv_s;
        let vb = ((ti as f64 + 1.0) * w - o) * inv_s;
        let vm = 0.5 * (va + vb);
        if vb <= 0.0 || va >= 1.0 {
            continue;
        }
        let row = &mut out[i * n..(i + 1) * n];
        // Target φ_0: primitive clamp(v, 0, 1).
        let p0 = |v: f64| v.clamp(0.0, 1.0);
        row[0] = (amp
            * if i == 0 {
                p0(vb) - p0(va)
            } else {
                2.0 * p0(vm) - p0(va) - p0(vb)
            }) as f32;
        for l in 0..levels {
            let k = f64::from(1u32 << l);
            let scale = 1.0 / k.sqrt();
            let t0 = (va * k).floor().max(0.0) as usize;
            let t1 = ((vb * k).ceil().min(k)) as usize;
            for t in t0..t1 {
                let tf = t as f64;
                let pk = |v: f64| tent(k * v - tf);
                let d = if i == 0 {
                    pk(vb) - pk(va)
                } else {
                    2.0 * pk(vm) - pk(va) - pk(vb)
                };
                row[(1usize << l) + t] = (amp * scale * d) as f32;
            }
        }
    }
}

/// Two-step propagation (module docs) of the dense standard-basis
/// coefficients `f` (`n²`, layout `i2 · n + i1`) by `(s, o)` per axis, into
/// `out` (`n²`, same layout). Zero sources are skipped; the reference for
/// compressed, fused kernels.
pub fn propagate_two_step(f: &[f64], n: usize, s: [f64; 2], o: [f64; 2], out: &mut [f64]) {
    let mut row = Vec::new();
    let mut dx = vec![0.0f32; n * n];
    let mut dy = vec![0.0f32; n * n];
    acc_matrix_f32(n, s[0], o[0], &mut dx, &mut row);
    acc_matrix_f32(n, s[1], o[1], &mut dy, &mut row);
    let mut z = vec![0.0f64; n * n]; // z[i2 * n + k1]
    for i2 in 0..n {
        for i1 in 0..n {
            let fi = f[i2 * n + i1];
            if fi == 0.0 {
                continue;
            }
            for k1 in 0..n {
                z[i2 * n + k1] += fi * f64::from(dx[i1 * n + k1]);
            }
        }
    }
    out.iter_mut().for_each(|x| *x = 0.0);
    for i2 in 0..n {
        for k1 in 0..n {
            let zv = z[i2 * n + k1];
            if zv == 0.0 {
                continue;
            }
            for k2 in 0..n {
                out[k2 * n + k1] += zv * f64::from(dy[i2 * n + k2]);
            }
        }
    }
}

/// Coarse-first rank of 1D index `i`: 0 for φ, `l + 1` for ψ_{l,t}.
#[must_use]
pub fn level_rank(i: usize) -> u32 {
    if i == 0 {
        0
    } else {
        usize::BITS - i.leading_zeros()
    }
}

/// The cell means of `f(x, y)` on an `n × n` grid by `q × q` midpoint
/// samples per cell (for tests and bakes of smooth functions).
pub fn cell_means(n: usize, q: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
    let mut out = vec![0.0; n * n];
    let h = 1.0 / (n * q) as f64;
    for y in 0..n {
        for x in 0..n {
            let mut sum = 0.0;
            for j in 0..q {
                for i in 0..q {
                    sum += f(
                        ((x * q + i) as f64 + 0.5) * h,
                        ((y * q + j) as f64 + 0.5) * h,
                    );
                }
            }
            out[y * n + x] = sum / (q * q) as f64;
        }
    }
    out
}
