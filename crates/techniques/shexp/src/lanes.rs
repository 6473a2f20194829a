//! The per-frame kernel over [`W`] receivers at once (structure of arrays):
//! the same computation as the per-vertex path of [`crate::accumulate`] and
//! [`crate::exp`], vectorised across receivers instead of across SH
//! coefficients.
//!
//! For one chunk of `W` receiver vertices of a cluster and every blocker
//! sphere the cluster keeps (§5.2.4 culling):
//! 1. **Accumulation** (eq. 5.13): per lane, the blocker's direction `ω` and
//!    the table coordinate `tan(θ/2)` of its half-angle straight from
//!    `sin θ = r/d` ([`crate::log_table::tan_half_of_sin`]: no `asin`), the
//!    zonal log `f_l(θ)` by linear interpolation of the [`LogTable`] (the same
//!    entries and interpolation as [`LogTable::lookup`]), and `f_{l,m} += √(4π/(2l+1)) f_l(θ) y_{l,m}(ω)`
//!    with `y_{l,m}` written as `Q_{l,m}(z)·{Re, Im}((x + iy)^m)`: the
//!    polynomials `Q_{l,m}` (real SH with the Condon–Shortley phase, the
//!    convention of `relight_sh`, the factor `√(4π/(2l+1))` folded in) are
//!    derived from the Legendre polynomials in [`LaneKernel::new`]. A sphere
//!    entirely below the tangent plane contributes nothing (the per-vertex
//!    test of [`crate::method`]).
//! 2. **Exponential** (eqs. 5.24–5.27): per lane the DC factor, `‖f̂‖` (f64)
//!    and the squaring rule (5.26, capped at [`MAX_SQUARINGS`]) exactly as
//!    [`crate::exp::Exponentiator::exp`]; the factored PS*-p series (or the
//!    fitted OL of HYB/OL) and the squarings run on all lanes with the SH
//!    product's Gaunt terms grouped by output; a lane needing fewer squarings
//!    than the chunk's most keeps its value (a per-lane select).
//!
//! Results equal the per-vertex path's up to f32 rounding (fused
//! multiply–adds, another summation order, `tan(θ/2)` from `sin θ` rather
//! than from `asin`); a test compares
//! them. The body is compiled three times — AVX-512F, AVX2 + FMA, portable —
//! and picked at run time by [`relight_sh::isa()`].

use crate::ShExpError;
use crate::exp::{ExpKind, MAX_SQUARINGS, OlFit, SquaringHistogram, squarings_rule};
use crate::log_table::LogTable;
use relight_sh::product::TripleProduct;
use std::f64::consts::PI;

/// Receivers per chunk (one AVX-512 register of f32).
pub const W: usize = 16;

/// One value per receiver of a chunk.
pub type Lane = [f32; W];

const SQRT_4PI: f32 = 3.544_907_7;

/// A blocker sphere in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneBlocker {
    pub c: [f32; 3],
    pub r: f32,
}

/// `W` receivers: positions and unit normals, structure of arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LaneReceivers {
    pub p: [Lane; 3],
    pub n: [Lane; 3],
}

impl LaneReceivers {
    /// Lane `j` ← position `p`, normal `n`.
    #[inline]
    pub fn set(&mut self, j: usize, p: glam::Vec3, n: glam::Vec3) {
        for a in 0..3 {
            self.p[a][j] = p[a];
            self.n[a][j] = n[a];
        }
    }
}

/// One term `w·f_a·f_b` of output `o` of the SH square (`w = Γ_{oaa}` for
/// `a = b`, `2Γ_{oab}` otherwise); the product `f ∗ g` uses
/// `(w/2)(f_a g_b + f_b g_a)`.
#[derive(Clone, Copy, Debug)]
struct Term {
    a: u16,
    b: u16,
    w: f32,
}

/// One basis polynomial `k_l Q_{l,m}(z) = z^odd · Σ_i c_i (z²)^i`.
#[derive(Clone, Copy, Debug)]
struct BasisPoly {
    l: u16,
    m: u16,
    odd: bool,
    /// Coefficients in `coef[start..start + len]` while building (then
    /// [`LaneKernel::coef4`]), highest power first.
    start: u32,
    len: u32,
}

/// What the kernel needs, built once per order (immutable, shared by threads).
#[derive(Clone, Debug)]
pub struct LaneKernel {
    order: usize,
    entries: usize,
    /// Per entry `e`: `f_l(θ_e)`, `l < n`, then `f_l(θ_{e+1}) − f_l(θ_e)`.
    table: Vec<f32>,
    /// The same, one row per coefficient: row `l` holds `f_l(θ_e)` and row
    /// `n + l` the difference, each [`SOA_ROW`] long (the tail zero), for
    /// [`accumulate_zmm`]'s two-register lookups.
    table_soa: Vec<f32>,
    basis: Vec<BasisPoly>,
    /// Per basis polynomial (index `l(l+1)/2 + m`), its coefficients in `z²`,
    /// highest first, zero-padded in front to [`HORNER`] (so every Horner
    /// runs the same, constant, number of steps; leading zeros are exact).
    coef4: Vec<[f32; HORNER]>,
    out_start: Vec<u32>,
    terms: Vec<Term>,
    ol: OlFit,
}

/// Per-thread scratch of [`LaneKernel`] (order² lanes each).
#[derive(Clone, Debug)]
pub struct LaneScratch {
    fh: Vec<Lane>,
    f2: Vec<Lane>,
    pw: Vec<Lane>,
    odd: Vec<Lane>,
    tmp: Vec<Lane>,
}

impl LaneScratch {
    /// For `order` bands.
    #[must_use]
    pub fn new(order: usize) -> Self {
        let z = vec![[0.0; W]; order * order];
        Self {
            fh: z.clone(),
            f2: z.clone(),
            pw: z.clone(),
            odd: z.clone(),
            tmp: z,
        }
    }
}

/// Coefficients (ascending powers) of the Legendre polynomial `P_l`.
fn legendre_coefficients(l: usize) -> Vec<f64> {
    let mut prev = vec![1.0];
    if l == 0 {
        return prev;
    }
    let mut cur = vec![0.0, 1.0];
    for k in 1..l {
        // (k+1) P_{k+1} = (2k+1) z P_k − k P_{k−1}
        let kf = k as f64;
        let mut next = vec![0.0; k + 2];
        for (i, c) in cur.iter().enumerate() {
            next[i + 1] += (2.0 * kf + 1.0) * c / (kf + 1.0);
        }
        for (i, c) in prev.iter().enumerate() {
            next[i] -= kf * c / (kf + 1.0);
        }
        prev = cur;
        cur = next;
    }
    cur
}

#[inline(always)]
fn fma<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F { a.mul_add(b, c) } else { a * b + c }
}

impl LaneKernel {
    /// The kernel for `table`'s order, with the OL fit of HYB/OL.
    ///
    /// # Errors
    /// An order the product tensor does not support.
    pub fn new(table: &LogTable, ol: OlFit) -> Result<Self, ShExpError> {
        let n = table.order();
        let entries = table.entries();
        let mut t = Vec::with_capacity(entries * 2 * n);
        let mut a = vec![0.0f32; n];
        let mut b = vec![0.0f32; n];
        for e in 0..entries {
            let at = |e: usize, out: &mut [f32]| {
                for (o, v) in out.iter_mut().zip(table.entry(e.min(entries - 1))) {
                    *o = *v as f32;
                }
            };
            at(e, &mut a);
            at(e + 1, &mut b);
            t.extend_from_slice(&a);
            t.extend(a.iter().zip(&b).map(|(a, b)| b - a));
        }
        // Basis polynomials: k_l · K_{l,m} · (−1)^m · d^m P_l/dz^m.
        let mut basis = Vec::new();
        let mut coef = Vec::new();
        for l in 0..n {
            let mut p = legendre_coefficients(l);
            let kl = (4.0 * PI / (2 * l + 1) as f64).sqrt();
            for m in 0..=l {
                if m > 0 {
                    p = p
                        .iter()
                        .enumerate()
                        .skip(1)
                        .map(|(i, c)| i as f64 * c)
                        .collect();
                }
                let fact_ratio: f64 = ((l - m + 1)..=(l + m)).map(|v| v as f64).product();
                let mut k = ((2 * l + 1) as f64 / (4.0 * PI) / fact_ratio).sqrt();
                if m > 0 {
                    k *= std::f64::consts::SQRT_2;
                }
                if m % 2 == 1 {
                    k = -k;
                }
                let odd = (l - m) % 2 == 1;
                let start = coef.len() as u32;
                // Powers odd, odd+2, …, l−m of z: highest first, in z².
                let mut pw = (l - m) as isize;
                while pw >= 0 {
                    coef.push((kl * k * p[pw as usize]) as f32);
                    pw -= 2;
                }
                basis.push(BasisPoly {
                    l: l as u16,
                    m: m as u16,
                    odd,
                    start,
                    len: coef.len() as u32 - start,
                });
            }
        }
        let coef4 = basis
            .iter()
            .map(|bp| {
                let mut c = [0.0f32; HORNER];
                let src = &coef[bp.start as usize..(bp.start + bp.len) as usize];
                c[HORNER - src.len()..].copy_from_slice(src);
                c
            })
            .collect();
        // Gaunt terms by output.
        let tp = TripleProduct::<f64>::new(n)?;
        let nn = n * n;
        let mut per_out: Vec<Vec<(u16, u16, f64)>> = vec![Vec::new(); nn];
        for (i, j, k, v) in tp.entries() {
            let mut combos = vec![(i, j, k), (j, i, k), (k, i, j)];
            combos.sort_unstable();
            combos.dedup();
            for (o, a, b) in combos {
                let (a, b) = (a.min(b), a.max(b));
                per_out[o].push((a as u16, b as u16, if a == b { v } else { 2.0 * v }));
            }
        }
        let mut out_start = vec![0u32];
        let mut terms = Vec::new();
        for mut list in per_out {
            list.sort_unstable_by_key(|e| (e.0, e.1));
            terms.extend(list.into_iter().map(|(a, b, w)| Term { a, b, w: w as f32 }));
            out_start.push(terms.len() as u32);
        }
        Ok(Self {
            order: n,
            entries,
            table_soa: {
                let mut soa = vec![0.0f32; 2 * n * soa_row(entries)];
                for (e, row) in t.chunks(2 * n).enumerate() {
                    for (c, v) in row.iter().enumerate() {
                        soa[c * soa_row(entries) + e] = *v;
                    }
                }
                soa
            },
            table: t,
            basis,
            coef4,
            out_start,
            terms,
            ol,
        })
    }

    /// SH order n.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// `f = Σ_b log g_b` (order² lanes) over `blockers` for the receivers of
    /// `rec`, skipping per lane a sphere entirely below the tangent plane;
    /// bit `j` of the result says lane `j` saw at least one blocker.
    ///
    /// # Panics
    /// If `f` is shorter than order².
    pub fn accumulate(&self, rec: &LaneReceivers, blockers: &[LaneBlocker], f: &mut [Lane]) -> u32 {
        self.accumulate_on(LanePath::current(), rec, blockers, f)
    }

    /// [`Self::accumulate`] on `path` (tests compare the paths).
    ///
    /// # Panics
    /// If this CPU lacks `path`, or `f` is shorter than order².
    pub fn accumulate_on(
        &self,
        path: LanePath,
        rec: &LaneReceivers,
        blockers: &[LaneBlocker],
        f: &mut [Lane],
    ) -> u32 {
        assert!(path.supported(), "{path:?} is not available on this CPU");
        #[cfg(target_arch = "x86_64")]
        match path {
            LanePath::Avx512 => {
                // SAFETY: AVX-512F, AVX2 and FMA were detected (asserted above).
                return unsafe { accumulate_avx512(self, rec, blockers, f) };
            }
            LanePath::Avx2 => {
                // SAFETY: AVX2 and FMA were detected (asserted above).
                return unsafe { accumulate_avx2(self, rec, blockers, f) };
            }
            LanePath::Portable => {}
        }
        accumulate_by_order::<false, false>(self, rec, blockers, f)
    }

    /// `out = exp_*(f)` by `kind` (not [`ExpKind::Product`]) on every lane;
    /// lanes whose bit in `any` is clear get the unshadowed `(√(4π), 0, …)`.
    /// The squarings of the lanes `< lanes` that saw a blocker go to `hist`.
    ///
    /// # Panics
    /// On [`ExpKind::Product`], or short slices.
    #[allow(clippy::too_many_arguments)]
    pub fn exp(
        &self,
        kind: ExpKind,
        f: &[Lane],
        any: u32,
        lanes: usize,
        s: &mut LaneScratch,
        out: &mut [Lane],
        hist: &mut SquaringHistogram,
    ) {
        self.exp_on(LanePath::current(), kind, f, any, lanes, s, out, hist);
    }

    /// [`Self::exp`] on `path` (tests compare the paths).
    ///
    /// # Panics
    /// As [`Self::exp`], or if this CPU lacks `path`.
    #[allow(clippy::too_many_arguments)]
    pub fn exp_on(
        &self,
        path: LanePath,
        kind: ExpKind,
        f: &[Lane],
        any: u32,
        lanes: usize,
        s: &mut LaneScratch,
        out: &mut [Lane],
        hist: &mut SquaringHistogram,
    ) {
        assert!(
            kind != ExpKind::Product,
            "the lane kernel has no product path"
        );
        assert!(path.supported(), "{path:?} is not available on this CPU");
        #[cfg(target_arch = "x86_64")]
        match path {
            LanePath::Avx512 => {
                // SAFETY: AVX-512F, AVX2 and FMA were detected (asserted above).
                return unsafe { exp_avx512(self, kind, f, any, lanes, s, out, hist) };
            }
            LanePath::Avx2 => {
                // SAFETY: AVX2 and FMA were detected (asserted above).
                return unsafe { exp_avx2(self, kind, f, any, lanes, s, out, hist) };
            }
            LanePath::Portable => {}
        }
        exp_body::<false>(self, kind, f, any, lanes, s, out, hist);
    }

    /// `out = f ∗ f` on every lane (the kernel's squaring, for tests).
    pub fn square(&self, f: &[Lane], out: &mut [Lane]) {
        square_body::<false>(self, f, out);
    }
}

/// A compiled form of the kernel body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LanePath {
    /// AVX-512F (with AVX2 and FMA): a lane is one register.
    Avx512,
    /// AVX2 with FMA: a lane is two registers.
    Avx2,
    /// The baseline target, plain multiply and add.
    Portable,
}

impl LanePath {
    /// Every path, fastest first.
    pub const ALL: [Self; 3] = [Self::Avx512, Self::Avx2, Self::Portable];

    /// Whether `self` may run here: the CPU has it and the process-wide
    /// cap ([`relight_isa::set_isa_limit`]) allows it.
    #[must_use]
    pub fn supported(self) -> bool {
        match self {
            Self::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Self::Avx2 => relight_isa::avx2(),
            #[cfg(target_arch = "x86_64")]
            Self::Avx512 => relight_isa::avx512(),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The path in use: the fastest that is [`supported`](Self::supported).
    #[must_use]
    pub fn current() -> Self {
        Self::ALL
            .into_iter()
            .find(|p| p.supported())
            .unwrap_or(Self::Portable)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
fn accumulate_avx512(
    k: &LaneKernel,
    rec: &LaneReceivers,
    blockers: &[LaneBlocker],
    f: &mut [Lane],
) -> u32 {
    // SAFETY: AVX-512F and FMA are enabled here; the order matches.
    unsafe {
        match k.order {
            3 => accumulate_zmm::<3>(k, rec, blockers, f),
            4 => accumulate_zmm::<4>(k, rec, blockers, f),
            5 => accumulate_zmm::<5>(k, rec, blockers, f),
            6 => accumulate_zmm::<6>(k, rec, blockers, f),
            _ => accumulate_by_order::<true, true>(k, rec, blockers, f),
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn accumulate_avx2(
    k: &LaneKernel,
    rec: &LaneReceivers,
    blockers: &[LaneBlocker],
    f: &mut [Lane],
) -> u32 {
    accumulate_by_order::<true, false>(k, rec, blockers, f)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[allow(clippy::too_many_arguments)]
fn exp_avx512(
    k: &LaneKernel,
    kind: ExpKind,
    f: &[Lane],
    any: u32,
    lanes: usize,
    s: &mut LaneScratch,
    out: &mut [Lane],
    hist: &mut SquaringHistogram,
) {
    exp_body::<true>(k, kind, f, any, lanes, s, out, hist);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
fn exp_avx2(
    k: &LaneKernel,
    kind: ExpKind,
    f: &[Lane],
    any: u32,
    lanes: usize,
    s: &mut LaneScratch,
    out: &mut [Lane],
    hist: &mut SquaringHistogram,
) {
    exp_body::<true>(k, kind, f, any, lanes, s, out, hist);
}

/// `base[idx[j]]` for the 16 lanes, one AVX-512 gather.
///
/// # Safety
/// AVX-512F must be available and every `base + idx[j]` readable.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn gather16(base: *const f32, idx: &[i32; W]) -> Lane {
    use std::arch::x86_64::{_mm512_i32gather_ps, _mm512_loadu_si512, _mm512_storeu_ps};
    let mut out = [0.0f32; W];
    // SAFETY: as the caller promises.
    unsafe {
        let vi = _mm512_loadu_si512(idx.as_ptr().cast());
        let v = _mm512_i32gather_ps::<4>(vi, base.cast());
        _mm512_storeu_ps(out.as_mut_ptr().cast(), v);
    }
    out
}

/// Row length of [`LaneKernel::table_soa`]: the entries and a 32-float tail,
/// so that the 32 floats from any entry below `entries − 1` are readable.
const fn soa_row(entries: usize) -> usize {
    entries + 32
}

/// Most bands the kernel handles (the method's limit).
const MAX_N: usize = 8;

/// Most coefficients of a basis polynomial in `z²`: `(l − m)/2 + 1` for `l < MAX_N`.
const HORNER: usize = MAX_N.div_ceil(2);

/// Per order: a body with the order a constant (loops unrolled) for the
/// usual orders, the run-time order otherwise.
#[inline(always)]
fn accumulate_by_order<const F: bool, const G: bool>(
    k: &LaneKernel,
    rec: &LaneReceivers,
    blockers: &[LaneBlocker],
    f: &mut [Lane],
) -> u32 {
    match k.order {
        3 => accumulate_body::<F, G, 3>(k, rec, blockers, f),
        4 => accumulate_body::<F, G, 4>(k, rec, blockers, f),
        5 => accumulate_body::<F, G, 5>(k, rec, blockers, f),
        6 => accumulate_body::<F, G, 6>(k, rec, blockers, f),
        _ => accumulate_body::<F, G, 0>(k, rec, blockers, f),
    }
}

/// `N`: the order when non-zero (it must then equal `k.order`), else
/// `k.order` at run time; `G`: AVX-512 gathers for the table (only inside
/// [`accumulate_avx512`]).
#[inline(always)]
fn accumulate_body<const F: bool, const G: bool, const N: usize>(
    k: &LaneKernel,
    rec: &LaneReceivers,
    blockers: &[LaneBlocker],
    f: &mut [Lane],
) -> u32 {
    let n = if N == 0 { k.order } else { N };
    debug_assert_eq!(n, k.order);
    let nn = n * n;
    let f = &mut f[..nn];
    for v in f.iter_mut() {
        *v = [0.0; W];
    }
    let scale = (k.entries - 1) as f32;
    let last = (k.entries - 1) as f32;
    let imax = (k.entries - 2) as i32;
    let mut any = [0.0f32; W];
    let (mut x, mut y, mut z) = ([0.0f32; W], [0.0f32; W], [0.0f32; W]);
    let mut wv = [0.0f32; W];
    let mut idx = [0i32; W];
    let mut tt = [0.0f32; W];
    let mut zl = [[0.0f32; W]; MAX_N];
    let mut z2 = [0.0f32; W];
    let tab = &k.table[..];
    for b in blockers {
        for j in 0..W {
            let dx = b.c[0] - rec.p[0][j];
            let dy = b.c[1] - rec.p[1][j];
            let dz = b.c[2] - rec.p[2][j];
            let dn = fma::<F>(dx, rec.n[0][j], fma::<F>(dy, rec.n[1][j], dz * rec.n[2][j]));
            let vis = dn > -b.r;
            let dist = fma::<F>(dx, dx, fma::<F>(dy, dy, dz * dz)).sqrt();
            let inv = 1.0 / dist;
            let pos = dist > 0.0;
            x[j] = if pos { dx * inv } else { rec.n[0][j] };
            y[j] = if pos { dy * inv } else { rec.n[1][j] };
            z[j] = if pos { dz * inv } else { rec.n[2][j] };
            let s = if dist <= b.r { 1.0 } else { b.r * inv };
            let tan_half = crate::log_table::tan_half_of_sin(s);
            // max/min, unlike clamp, turn a NaN (from a NaN position) into a bound.
            let u = (tan_half * scale).max(0.0).min(last);
            // SAFETY: 0 ≤ u ≤ entries − 1 < 2³¹ and u is not NaN.
            let i = unsafe { u.to_int_unchecked::<i32>() }.min(imax);
            idx[j] = i * (2 * n) as i32;
            tt[j] = u - i as f32;
            wv[j] = if vis { 1.0 } else { 0.0 };
            any[j] = any[j].max(wv[j]);
        }
        // Below every lane's tangent plane: nothing to add (an integer
        // count, which vectorises; a float max-fold is serial).
        if wv.iter().map(|&w| u32::from(w > 0.0)).sum::<u32>() == 0 {
            continue;
        }
        for l in 0..n {
            let zl = &mut zl[l];
            #[cfg(target_arch = "x86_64")]
            if G {
                // SAFETY: only reached inside `accumulate_avx512` (AVX-512F);
                // idx ≤ (entries − 2)·2n and l < n, so every offset + n is
                // inside the table.
                let (a, d) = unsafe {
                    (
                        gather16(tab.as_ptr().add(l), &idx),
                        gather16(tab.as_ptr().add(l + n), &idx),
                    )
                };
                for j in 0..W {
                    zl[j] = fma::<F>(d[j], tt[j], a[j]) * wv[j];
                }
                continue;
            }
            for j in 0..W {
                let e = idx[j] as usize + l;
                // SAFETY: idx ≤ (entries − 2)·2n and l < n, so e + n < table.len().
                let (a, d) = unsafe { (*tab.get_unchecked(e), *tab.get_unchecked(e + n)) };
                zl[j] = fma::<F>(d, tt[j], a) * wv[j];
            }
        }
        for j in 0..W {
            z2[j] = z[j] * z[j];
        }
        // m-major, so that Re/Im (x + iy)^m stay in registers.
        let steps = n.div_ceil(2);
        let (mut cm, mut sm) = ([1.0f32; W], [0.0f32; W]);
        for m in 0..n {
            if m > 0 {
                let (mut c2, mut s2) = ([0.0f32; W], [0.0f32; W]);
                for j in 0..W {
                    c2[j] = fma::<F>(cm[j], x[j], -(sm[j] * y[j]));
                    s2[j] = fma::<F>(sm[j], x[j], cm[j] * y[j]);
                }
                (cm, sm) = (c2, s2);
            }
            for l in m..n {
                let bi = l * (l + 1) / 2 + m;
                let bp = &k.basis[bi];
                let odd = (l - m) % 2 == 1;
                debug_assert_eq!(
                    (bp.l as usize, bp.m as usize, bp.odd, bp.len as usize),
                    (l, m, odd, (l - m) / 2 + 1)
                );
                // Horner over the padded coefficients: `steps` = the most any
                // polynomial of this order needs.
                let c = &k.coef4[bi];
                let mut q = [c[HORNER - steps]; W];
                for &ci in &c[HORNER - steps + 1..] {
                    for j in 0..W {
                        q[j] = fma::<F>(q[j], z2[j], ci);
                    }
                }
                if odd {
                    for j in 0..W {
                        q[j] = q[j] * z[j] * zl[l][j];
                    }
                } else {
                    for j in 0..W {
                        q[j] *= zl[l][j];
                    }
                }
                let centre = l * (l + 1);
                if m == 0 {
                    let o = &mut f[centre];
                    for j in 0..W {
                        o[j] += q[j];
                    }
                } else {
                    let o = &mut f[centre + m];
                    for j in 0..W {
                        o[j] = fma::<F>(q[j], cm[j], o[j]);
                    }
                    let o = &mut f[centre - m];
                    for j in 0..W {
                        o[j] = fma::<F>(q[j], sm[j], o[j]);
                    }
                }
            }
        }
    }
    let mut bits = 0u32;
    for (j, a) in any.iter().enumerate() {
        if *a > 0.0 {
            bits |= 1 << j;
        }
    }
    bits
}

#[inline(always)]
fn square_body<const F: bool>(k: &LaneKernel, f: &[Lane], out: &mut [Lane]) {
    let nn = k.order * k.order;
    for o in 0..nn {
        let mut acc = [0.0f32; W];
        for t in &k.terms[k.out_start[o] as usize..k.out_start[o + 1] as usize] {
            let (fa, fb) = (&f[t.a as usize], &f[t.b as usize]);
            for j in 0..W {
                acc[j] = fma::<F>(t.w, fa[j] * fb[j], acc[j]);
            }
        }
        out[o] = acc;
    }
}

#[inline(always)]
fn product_body<const F: bool>(k: &LaneKernel, f: &[Lane], g: &[Lane], out: &mut [Lane]) {
    let nn = k.order * k.order;
    for o in 0..nn {
        let mut acc = [0.0f32; W];
        for t in &k.terms[k.out_start[o] as usize..k.out_start[o + 1] as usize] {
            let (a, b) = (t.a as usize, t.b as usize);
            let w = 0.5 * t.w;
            for j in 0..W {
                let s = fma::<F>(f[a][j], g[b][j], f[b][j] * g[a][j]);
                acc[j] = fma::<F>(w, s, acc[j]);
            }
        }
        out[o] = acc;
    }
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn exp_body<const F: bool>(
    k: &LaneKernel,
    kind: ExpKind,
    f: &[Lane],
    any: u32,
    lanes: usize,
    s: &mut LaneScratch,
    out: &mut [Lane],
    hist: &mut SquaringHistogram,
) {
    let n = k.order;
    let nn = n * n;
    let sqrt4pi = (4.0 * PI).sqrt();
    let mut norm2 = [0.0f64; W];
    for v in &f[1..nn] {
        for j in 0..W {
            let x = f64::from(v[j]);
            norm2[j] += x * x;
        }
    }
    let mut sq = [0u32; W];
    let mut scale = [0.0f32; W];
    let mut dc = [0.0f32; W];
    let mut norm = [0.0f64; W];
    let mut smax = 0;
    for j in 0..W {
        norm[j] = norm2[j].sqrt();
        dc[j] = (f64::from(f[0][j]) / sqrt4pi).exp() as f32;
        let (sj, capped) = match kind {
            ExpKind::Ol => (0, false),
            _ => {
                let r = squarings_rule(norm[j]);
                (r.min(MAX_SQUARINGS), r > MAX_SQUARINGS)
            }
        };
        sq[j] = sj;
        scale[j] = 0.5f64.powi(sj as i32) as f32;
        if any & (1 << j) != 0 {
            smax = smax.max(sj);
            if j < lanes {
                hist.counts[sj as usize] += 1;
                hist.capped += u64::from(capped);
            }
        }
    }
    let fh = &mut s.fh[..nn];
    fh[0] = [0.0; W];
    for i in 1..nn {
        for j in 0..W {
            fh[i][j] = f[i][j] * scale[j];
        }
    }
    let out = &mut out[..nn];
    match kind {
        ExpKind::PsStar(p) => series_body::<F>(k, p, s, out),
        _ => {
            for j in 0..W {
                let (a, b) = k.ol.at(norm[j] * f64::from(scale[j]));
                let (a, b) = (a as f32, b as f32);
                for i in 0..nn {
                    out[i][j] = b * s.fh[i][j];
                }
                out[0][j] = a * SQRT_4PI;
            }
        }
    }
    for t in 1..=smax {
        let tmp = &mut s.tmp[..nn];
        square_body::<F>(k, out, tmp);
        // Lanes that need this squaring take it; the others keep their value.
        // Written as a select of whole lanes (a branch per element had
        // compiled to scalar code: a seventh of `exp_avx512` in `perf`).
        let take: [bool; W] = std::array::from_fn(|j| sq[j] >= t);
        if take.iter().all(|&b| b) {
            out.copy_from_slice(tmp);
        } else {
            for (o, x) in out.iter_mut().zip(tmp.iter()) {
                for j in 0..W {
                    o[j] = if take[j] { x[j] } else { o[j] };
                }
            }
        }
    }
    for i in 0..nn {
        for j in 0..W {
            out[i][j] *= dc[j];
        }
    }
    for j in 0..W {
        if any & (1 << j) == 0 {
            for i in 0..nn {
                out[i][j] = if i == 0 { SQRT_4PI } else { 0.0 };
            }
        }
    }
}

/// The factored series (5.27) of degree `p` of `s.fh` into `out`, as
/// `Exponentiator`'s.
#[inline(always)]
fn series_body<const F: bool>(k: &LaneKernel, p: u32, s: &mut LaneScratch, out: &mut [Lane]) {
    let nn = k.order * k.order;
    let h = |q: u32| (1.0 / (1..=q).map(f64::from).product::<f64>()) as f32;
    let LaneScratch {
        fh,
        f2,
        pw,
        odd,
        tmp,
    } = s;
    for (i, o) in out.iter_mut().enumerate() {
        *o = [if i == 0 { SQRT_4PI } else { 0.0 }; W];
    }
    for (i, o) in odd[..nn].iter_mut().enumerate() {
        *o = [if i == 0 { SQRT_4PI } else { 0.0 }; W];
    }
    let mut odd_is_one = true;
    if p >= 2 {
        square_body::<F>(k, fh, f2);
        pw[..nn].copy_from_slice(&f2[..nn]);
        let mut kk = 2;
        loop {
            let he = h(kk);
            for i in 0..nn {
                for j in 0..W {
                    out[i][j] = fma::<F>(he, pw[i][j], out[i][j]);
                }
            }
            if kk < p {
                let ho = h(kk + 1);
                for i in 0..nn {
                    for j in 0..W {
                        odd[i][j] = fma::<F>(ho, pw[i][j], odd[i][j]);
                    }
                }
                odd_is_one = false;
            }
            kk += 2;
            if kk > p {
                break;
            }
            product_body::<F>(k, pw, f2, tmp);
            std::mem::swap(pw, tmp);
        }
    }
    if p >= 1 {
        if odd_is_one {
            for i in 0..nn {
                for j in 0..W {
                    out[i][j] += fh[i][j];
                }
            }
        } else {
            product_body::<F>(k, fh, odd, f2);
            for i in 0..nn {
                for j in 0..W {
                    out[i][j] += f2[i][j];
                }
            }
        }
    }
}

/// [`accumulate_body`] written for AVX-512F registers, the order `N` a
/// constant (3…6): the `N²` accumulators stay in `zmm` registers across the
/// blocker loop (eq. 5.13's sum), a blocker is broadcast from its
/// [`LaneBlocker`] (no gathers but the log table's `2N`), and the division
/// and square roots (`1/d`, `cos θ = √(1 − sin²θ)`, `1/(1 + cos θ)`) are
/// `rsqrt14` / `rcp14` with one Newton step (relative error ≈ 2⁻²³, f32
/// rounding; a test compares this path with the portable one). The table is
/// read from [`LaneKernel::table_soa`] by a two-register permute when the
/// chunk's entries lie within 32 (gathers otherwise).
///
/// # Safety
/// AVX-512F and FMA must be available; `k.order == N`, `f.len() ≥ N²`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[allow(clippy::too_many_lines)]
unsafe fn accumulate_zmm<const N: usize>(
    k: &LaneKernel,
    rec: &LaneReceivers,
    blockers: &[LaneBlocker],
    f: &mut [Lane],
) -> u32 {
    use std::arch::x86_64::*;
    debug_assert_eq!(N, k.order);
    const MAXNN: usize = 36;
    let nn = N * N;
    assert!(N <= 6 && f.len() >= nn);
    // SAFETY (whole body): AVX-512F and FMA as the caller promises; every
    // load and store is of a `Lane` (16 f32) or inside the table as
    // `accumulate_body` argues.
    unsafe {
        let ld = |l: &Lane| _mm512_loadu_ps(l.as_ptr());
        let (px, py, pz) = (ld(&rec.p[0]), ld(&rec.p[1]), ld(&rec.p[2]));
        let (nx, ny, nz) = (ld(&rec.n[0]), ld(&rec.n[1]), ld(&rec.n[2]));
        let one = _mm512_set1_ps(1.0);
        let half = _mm512_set1_ps(0.5);
        let three_halves = _mm512_set1_ps(1.5);
        let zero = _mm512_setzero_ps();
        let scale = _mm512_set1_ps((k.entries - 1) as f32);
        let two = _mm512_set1_ps(2.0);
        let last = _mm512_set1_ps((k.entries - 1) as f32);
        let imax = _mm512_set1_epi32((k.entries - 2) as i32);
        let stride = _mm512_set1_epi32((2 * N) as i32);
        // 1/√v for v > 0: rsqrt14 and one Newton step y(3 − v y²)/2.
        let rsqrt = |v: __m512| {
            let y = _mm512_rsqrt14_ps(v);
            let hv = _mm512_mul_ps(half, v);
            _mm512_mul_ps(y, _mm512_fnmadd_ps(_mm512_mul_ps(hv, y), y, three_halves))
        };
        let tab = k.table.as_ptr();
        let mut acc = [zero; MAXNN];
        let mut any: __mmask16 = 0;
        for b in blockers {
            let dx = _mm512_sub_ps(_mm512_set1_ps(b.c[0]), px);
            let dy = _mm512_sub_ps(_mm512_set1_ps(b.c[1]), py);
            let dz = _mm512_sub_ps(_mm512_set1_ps(b.c[2]), pz);
            let dn = _mm512_fmadd_ps(dx, nx, _mm512_fmadd_ps(dy, ny, _mm512_mul_ps(dz, nz)));
            let r = _mm512_set1_ps(b.r);
            let vis = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(dn, _mm512_set1_ps(-b.r));
            // Below every lane's tangent plane: nothing to add.
            if vis == 0 {
                continue;
            }
            any |= vis;
            let d2 = _mm512_fmadd_ps(dx, dx, _mm512_fmadd_ps(dy, dy, _mm512_mul_ps(dz, dz)));
            let pos = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(d2, zero);
            let inv = rsqrt(d2);
            let x = _mm512_mask_mul_ps(nx, pos, dx, inv);
            let y = _mm512_mask_mul_ps(ny, pos, dy, inv);
            let z = _mm512_mask_mul_ps(nz, pos, dz, inv);
            // sin θ = r/d, 1 inside the sphere (d ≤ r, d = 0 included).
            let inside = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(d2, _mm512_mul_ps(r, r));
            let s = _mm512_mask_blend_ps(inside, _mm512_mul_ps(r, inv), one);
            let s = _mm512_min_ps(_mm512_max_ps(s, zero), one);
            // tan(θ/2) = s/(1 + cos θ), cos θ = √(1 − s²) by rsqrt14 + Newton
            // (0 at s = 1), 1/(1 + cos θ) by rcp14 + Newton (the table's
            // coordinate, `log_table::tan_half_of_sin`).
            let v = _mm512_fnmadd_ps(s, s, one);
            let vpos = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(v, zero);
            let cos = _mm512_maskz_mul_ps(vpos, v, rsqrt(v));
            let den = _mm512_add_ps(one, cos);
            let y0 = _mm512_rcp14_ps(den);
            let rcp = _mm512_mul_ps(y0, _mm512_fnmadd_ps(den, y0, two));
            let tan_half = _mm512_mul_ps(s, rcp);
            // Table position; max/min turn a NaN into a bound.
            let t = _mm512_min_ps(_mm512_max_ps(_mm512_mul_ps(tan_half, scale), zero), last);
            let i = _mm512_min_epi32(_mm512_cvttps_epi32(t), imax);
            let tt = _mm512_sub_ps(t, _mm512_cvtepi32_ps(i));
            let idx = _mm512_mullo_epi32(i, stride);
            let mut zl = [zero; 6];
            // Every index below is a literal and `N` a constant, so that the
            // accumulators, `zl` and the powers stay in registers.
            // The chunk's receivers are neighbours, so their table entries
            // usually lie within 32 of each other: two loads of each row and
            // a two-register permute; gathers otherwise.
            let i0 = _mm512_reduce_min_epi32(i);
            let rel = _mm512_sub_epi32(i, _mm512_set1_epi32(i0));
            let near = _mm512_cmplt_epu32_mask(rel, _mm512_set1_epi32(32)) == 0xffff;
            let row = soa_row(k.entries);
            let soa = k.table_soa.as_ptr().add(i0 as usize);
            macro_rules! table {
                ($($l:literal)*) => {$(
                    if $l < N {
                        let (a, d) = if near {
                            let ra = soa.add($l * row);
                            let rd = soa.add(($l + N) * row);
                            (
                                _mm512_permutex2var_ps(
                                    _mm512_loadu_ps(ra),
                                    rel,
                                    _mm512_loadu_ps(ra.add(16)),
                                ),
                                _mm512_permutex2var_ps(
                                    _mm512_loadu_ps(rd),
                                    rel,
                                    _mm512_loadu_ps(rd.add(16)),
                                ),
                            )
                        } else {
                            (
                                _mm512_i32gather_ps::<4>(idx, tab.add($l).cast()),
                                _mm512_i32gather_ps::<4>(idx, tab.add($l + N).cast()),
                            )
                        };
                        zl[$l] = _mm512_maskz_fmadd_ps(vis, d, tt, a);
                    }
                )*};
            }
            table!(0 1 2 3 4 5);
            let z2 = _mm512_mul_ps(z, z);
            // Re/Im (x + iy)^m.
            let mut cm = [one; 6];
            let mut sm = [zero; 6];
            macro_rules! powers {
                ($($m:literal)*) => {$(
                    if $m < N {
                        cm[$m] = _mm512_fmsub_ps(cm[$m - 1], x, _mm512_mul_ps(sm[$m - 1], y));
                        sm[$m] = _mm512_fmadd_ps(sm[$m - 1], x, _mm512_mul_ps(cm[$m - 1], y));
                    }
                )*};
            }
            cm[1] = x;
            sm[1] = y;
            powers!(2 3 4 5);
            macro_rules! terms {
                ($(($l:literal, $m:literal))*) => {$(
                    if $l < N {
                        let bi = $l * ($l + 1) / 2 + $m;
                        let len = ($l - $m) / 2 + 1;
                        let c = &k.coef4[bi][HORNER - len..];
                        let mut q = _mm512_set1_ps(c[0]);
                        for &ci in &c[1..] {
                            q = _mm512_fmadd_ps(q, z2, _mm512_set1_ps(ci));
                        }
                        if ($l - $m) % 2 == 1 {
                            q = _mm512_mul_ps(q, z);
                        }
                        q = _mm512_mul_ps(q, zl[$l]);
                        let centre = $l * ($l + 1);
                        if $m == 0 {
                            acc[centre] = _mm512_add_ps(acc[centre], q);
                        } else {
                            acc[centre + $m] = _mm512_fmadd_ps(q, cm[$m], acc[centre + $m]);
                            acc[centre - $m] = _mm512_fmadd_ps(q, sm[$m], acc[centre - $m]);
                        }
                    }
                )*};
            }
            terms!(
                (0, 0)(1, 0)(1, 1)(2, 0)(2, 1)(2, 2)(3, 0)(3, 1)(3, 2)(3, 3)(4, 0)(4, 1)(4, 2)(
                    4, 3
                )(4, 4)(5, 0)(5, 1)(5, 2)(5, 3)(5, 4)(5, 5)
            );
        }
        for (o, a) in f[..nn].iter_mut().zip(&acc) {
            _mm512_storeu_ps(o.as_mut_ptr(), *a);
        }
        u32::from(any)
    }
}
