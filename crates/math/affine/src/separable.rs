//! The separable extension to 2D (thesis §4.4.4, eqs. 4.30–4.32) on the
//! nonstandard 2D Haar basis of `relight-haar`.
//!
//! Every nonstandard basis function is a product of two 1D atoms
//! ([`atoms_2d`]): the scaling function `φ_{0,0}(u) φ_{0,0}(v)` and, at
//! level `l` with offsets `(px, py)`, type H `ψ_{l,px}(u) φ_{l,py}(v)`,
//! V `φ_{l,px}(u) ψ_{l,py}(v)`, D `ψ_{l,px}(u) ψ_{l,py}(v)` — boxes at level
//! `l`, which is why [`mod@crate::canonical`] needs the φ forms. (`u` runs along
//! columns, `v` along rows, as in [`relight_haar::Basis::eval`].) The 2D ACC
//! and ATC are then products of 1D ones (eqs. 4.31–4.32), for a scale and
//! offset per axis: `D(s, o) = D¹(s_u, o_u) · D¹(s_v, o_v)`.

use crate::atom::Atom;
use crate::coupling::{affine_coupling, affine_tripling};
use crate::rows::overlapping_offsets;
use relight_haar::{Basis, WaveletType};

/// The (u, v) atoms of a nonstandard 2D basis function.
#[must_use]
pub fn atoms_2d(b: Basis) -> (Atom, Atom) {
    match b {
        Basis::Scaling => (Atom::new_box(0, 0), Atom::new_box(0, 0)),
        Basis::Wavelet { ty, level, px, py } => match ty {
            WaveletType::H => (Atom::wave(level, px), Atom::new_box(level, py)),
            WaveletType::V => (Atom::new_box(level, px), Atom::wave(level, py)),
            WaveletType::D => (Atom::wave(level, px), Atom::wave(level, py)),
        },
    }
}

/// The 2D basis function of two atoms of the same level, if it is one.
#[must_use]
pub fn basis_of_atoms(u: Atom, v: Atom) -> Option<Basis> {
    use crate::atom::Kind::{Box, Wave};
    if u.level != v.level {
        return None;
    }
    let ty = match (u.kind, v.kind) {
        (Box, Box) if u.level == 0 => return Some(Basis::Scaling),
        (Box, Box) => return None,
        (Wave, Box) => WaveletType::H,
        (Box, Wave) => WaveletType::V,
        (Wave, Wave) => WaveletType::D,
    };
    Some(Basis::Wavelet {
        ty,
        level: u.level,
        px: u.offset,
        py: v.offset,
    })
}

/// The 2D ACC `∫∫ Ψ_i(s ⊙ x + o) Ψ_j(x) dx` (eq. 4.31).
#[must_use]
pub fn affine_coupling_2d(i: Basis, j: Basis, s: [f64; 2], o: [f64; 2]) -> f64 {
    let (iu, iv) = atoms_2d(i);
    let (ju, jv) = atoms_2d(j);
    let a = affine_coupling(iu, ju, s[0], o[0]);
    if a == 0.0 {
        return 0.0;
    }
    a * affine_coupling(iv, jv, s[1], o[1])
}

/// The 2D ATC (eq. 4.32).
#[must_use]
pub fn affine_tripling_2d(i: Basis, j: Basis, k: Basis, s: [f64; 2], o: [f64; 2]) -> f64 {
    let (iu, iv) = atoms_2d(i);
    let (ju, jv) = atoms_2d(j);
    let (ku, kv) = atoms_2d(k);
    let a = affine_tripling(iu, ju, ku, s[0], o[0]);
    if a == 0.0 {
        return 0.0;
    }
    a * affine_tripling(iv, jv, kv, s[1], o[1])
}

/// The 2D ACC by midpoint quadrature on a `q × q` grid over \[0,1\]² using
/// `relight-haar`'s own basis evaluation (`n × n` map): ties this module to
/// the existing transform.
#[must_use]
pub fn affine_coupling_2d_quadrature(
    i: Basis,
    j: Basis,
    n: usize,
    s: [f64; 2],
    o: [f64; 2],
    q: usize,
) -> f64 {
    let h = 1.0 / q as f64;
    let mut sum = 0.0;
    for y in 0..q {
        let v = (y as f64 + 0.5) * h;
        for x in 0..q {
            let u = (x as f64 + 0.5) * h;
            let bj = j.eval(n, u, v);
            if bj != 0.0 {
                let (xu, xv) = (s[0] * u + o[0], s[1] * v + o[1]);
                if (0.0..1.0).contains(&xu) && (0.0..1.0).contains(&xv) {
                    sum += i.eval(n, xu, xv) * bj;
                }
            }
        }
    }
    sum * h * h
}

/// 2D propagation `L_k = Σ_i F_i D_ik(s, o)` (eq. 4.35 in 2D) on the
/// nonstandard basis of an `n × n` map: for every non-zero source, the
/// targets whose support meets its transformed support, by level and type.
/// `f` and `out` have `n²` entries (Mallat layout of `relight-haar`).
pub fn propagate_2d(f: &[f32], n: usize, s: [f64; 2], o: [f64; 2], out: &mut [f64]) {
    out.iter_mut().for_each(|x| *x = 0.0);
    for (idx, &fi) in f.iter().enumerate() {
        if fi == 0.0 {
            continue;
        }
        let bi = Basis::from_index(idx, n);
        let (iu, iv) = atoms_2d(bi);
        let (u0, u1) = iu.support();
        let (v0, v1) = iv.support();
        let (a0, a1) = ((u0 - o[0]) / s[0], (u1 - o[0]) / s[0]);
        let (b0, b1) = ((v0 - o[1]) / s[1], (v1 - o[1]) / s[1]);
        let fi = f64::from(fi);
        let mut add = |bj: Basis| {
            let d = affine_coupling_2d(bi, bj, s, o);
            if d != 0.0 {
                out[bj.index(n)] += fi * d;
            }
        };
        add(Basis::Scaling);
        for level in 0..n.trailing_zeros() {
            overlapping_offsets(level, a0, a1, |px| {
                overlapping_offsets(level, b0, b1, |py| {
                    for ty in [WaveletType::H, WaveletType::V, WaveletType::D] {
                        add(Basis::Wavelet { ty, level, px, py });
                    }
                });
            });
        }
    }
}

/// The affine map of a zoom (§4.6.2): magnification `scale > 0` about the
/// image point `center` ∈ \[0,1\]² (u along columns, v along rows), which
/// lands in the middle of the output. Output point `x` shows input
/// `s x + o` with `s = 1/scale`, `o = center − s/2` per axis.
#[must_use]
pub fn zoom_transform(scale: f64, center: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let s = 1.0 / scale;
    ([s, s], [center[0] - 0.5 * s, center[1] - 0.5 * s])
}

/// The pixel path of a zoom (§4.6.2, Fig. 4.13's baseline): the box
/// resampling `out(x) = mean of the image over the preimage of pixel x`
/// of the affine map `u = s x + o` (zero outside the image), separable,
/// each target pixel reading the `⌈s⌉ + 1` source pixels per axis its
/// preimage overlaps. `img`, `out`: `n × n` row-major; `tmp`: `n²`.
pub fn box_resample_2d(
    img: &[f32],
    n: usize,
    s: [f64; 2],
    o: [f64; 2],
    tmp: &mut [f32],
    out: &mut [f32],
) {
    let nf = n as f64;
    // (first source pixel, weights) of target pixel j on one axis.
    let taps = |s: f64, o: f64, j: usize, w: &mut Vec<(usize, f32)>| {
        w.clear();
        let (u0, u1) = (s * j as f64 / nf + o, s * (j + 1) as f64 / nf + o);
        let i0 = (u0 * nf).floor().max(0.0) as usize;
        let i1 = ((u1 * nf).ceil().min(nf)).max(0.0) as usize;
        for i in i0..i1 {
            let ov = (u1.min((i + 1) as f64 / nf) - u0.max(i as f64 / nf)).max(0.0);
            if ov > 0.0 {
                w.push((i, (ov / (u1 - u0)) as f32));
            }
        }
    };
    let mut w = Vec::new();
    for tx in 0..n {
        taps(s[0], o[0], tx, &mut w);
        for y in 0..n {
            let row = &img[y * n..(y + 1) * n];
            tmp[y * n + tx] = w.iter().map(|&(i, a)| row[i] * a).sum();
        }
    }
    for ty in 0..n {
        taps(s[1], o[1], ty, &mut w);
        let dst = &mut out[ty * n..(ty + 1) * n];
        dst.fill(0.0);
        for &(i, a) in &w {
            for (d, &v) in dst.iter_mut().zip(&tmp[i * n..(i + 1) * n]) {
                *d += v * a;
            }
        }
    }
}
