//! Per-vertex light propagation fused with the transport dot product
//! (thesis §4.5.5): two-step separable propagation (eq. 4.35 in 2D) of the
//! compressed source terms, evaluated only at the target terms the
//! constant-light heuristic (eq. 4.38) keeps. Everything a light position
//! decides — the 1D ACC rows, the target mask — is computed per vertex in
//! the kernel itself ([`shade_vertex`]), so a light move, a scale and a
//! texture edit cost the same one pass and nothing per vertex is stored but
//! the transport (the thesis' frame rates are for a light being edited).
//!
//! # ACC rows from primitives (the computational approach, eq. 4.21)
//! On one axis the face point `v ∈ [0, 1]` sees the light at `x = s v + o`
//! ([`crate::face`]). Every source atom of the order-`n` basis ([`relight_affine::atom`])
//! is constant between the dyadic points `x_j = j/n`, `j = 0 … n`. With
//! `v_j = (x_j − o)/s` and `Q_j[k] = P_k(v_j)`, `P_k` the primitive of the
//! target `Φ_k` (`clamp(v, 0, 1)` for φ, `2^{−l/2} tent(2^l v − t)` for
//! ψ_{l,t}, `tent(x) = max(0, ½ − |x − ½|)`), row `i` of `D(s, o)` is
//!
//! ```text
//!   D_0k = Q_n[k] − Q_0[k]
//!   D_ik = 2^{l/2} (2 Q_{j_m}[k] − Q_{j_a}[k] − Q_{j_b}[k])   i = 2^l + t (ψ_{l,t}),
//!          j_a = t n/2^l,  j_b = j_a + n/2^l,  j_m = (j_a + j_b)/2
//! ```
//!
//! ([`relight_affine::standard::acc_matrix_fast`]'s primitive form, with the
//! breakpoints shared between rows). A target whose support misses the
//! source's pieces, or lies inside one piece, gets exact zeros. The `Q_j`
//! are evaluated lazily in f32 (`n` lanes each), so a vertex pays for the
//! source rows the compression kept and the heuristic's row 0 only.
//!
//! # Target mask (eq. 4.38)
//! The heuristic light `F̃ = [1, 0, 0, …]` propagates to `L̃_{k1k2} = a_{k1}
//! b_{k2}`, `a`, `b` row 0 of `D^x`, `D^y`; the mask keeps the `m` largest
//! `|L̃|`, ties **coarse first** ([`crate::light::coarse_key`]). With `|a|`
//! and `|b|` sorted (magnitude down, index up) the products fall along
//! each row, so the kept set is a prefix of `b`'s order in every row of
//! `a`'s: the mask is one count per row ([`MaskCounts`]). Only the few
//! non-zero factors are sorted (a row of `D` is mostly exact zeros), and
//! their `za × zb` block of positive products comes first:
//! - `m ≥ za·zb`: the whole block, then `m − za·zb` zero products in
//!   coarse order — whole squares `[0, h)²` in closed form (`h² −
//!   nzA(h)·nzB(h)` of them), then a walk of the first level not taken whole;
//! - `m ≤ 16`: the candidates `(i+1)(j+1) ≤ m` ranked directly (an entry
//!   outside has `m` entries at least as large and coarser on ties);
//! - else the `m`-th largest product `τ` by bisection on its f32 bit
//!   pattern (products are ≥ 0, so bit order is value order; each count a
//!   binary search along every sorted row), until at most 24 candidates
//!   remain to rank directly, or only exact ties at `τ`, walked in coarse
//!   order.
//!
//! Within a row coarse order is `k2` order, the order its equal products
//! already sit in, so the counts stay prefixes; a row whose factor is zero
//! is all ties and runs in index order. (Products are compared as computed
//! in f32; ACC values are far from underflow.)
//!
//! # Lighting (per vertex)
//! With `R` distinct source rows `i₂`, `n_s` source terms and `m` targets:
//!
//! ```text
//!   step 1:  Z_{r,k1}[c] = Σ_{i1 in row r} F_{i1 i2}[c] D^x_{i1 k1}     n_s · n · 3 FMA
//!   fuse:    W_{r,k1}    = Σ_{(k1,k2) in mask} D^y_{i2 k2} T_{k1 k2}      R · m FMA
//!   dot:     B[c]        = Σ_r Σ_{k1} Z_{r,k1}[c] W_{r,k1}               R · n · 3 FMA
//! ```
//!
//! `B[c] = Σ_{k ∈ mask} L_k[c] T_k`; step 2 of the thesis is folded into the
//! colour-independent `W` (a one-channel transport does not depend on the
//! colour; an RGB one runs the fuse per channel).
//!
//! The fuse sums one mask row (one `k1`) in registers, lanes over the `R`
//! source rows (padded to 8, 16, 24, 32 or 64; all of them at once), reading
//! each entry's transport value once, scattered; `W` is kept
//! `[c][r][k1]` so the dot runs along `k1` in independent lanes. Measured
//! figures: `docs/nearfield.md` (`relight bench nearfield`).

use crate::light::SourceTerms;

/// The order-`n` basis' primitive constants (module docs): per target
/// `k ≥ 1` (ψ_{l,t}) the scale `2^l`, the shift `t + ½` and the amplitude
/// `2^{−l/2}`; index 0 (φ) is unused.
#[derive(Clone, Debug)]
pub struct Primitives {
    n: usize,
    /// Run [`shade_vertex`] compiled for AVX2 (detected at run time).
    avx2: bool,
    scale: Vec<f32>,
    shift: Vec<f32>,
    amp: Vec<f32>,
}

impl Primitives {
    /// The constants of the order-`n` basis (`n` a power of two, ≤ 64).
    #[must_use]
    pub fn new(n: usize) -> Self {
        assert!(n.is_power_of_two() && n <= 64, "order {n}");
        let (mut scale, mut shift, mut amp) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for k in 1..n {
            let l = k.ilog2();
            let level = (1usize << l) as f32;
            scale[k] = level;
            shift[k] = (k - (1 << l)) as f32 + 0.5;
            amp[k] = 1.0 / level.sqrt();
        }
        Self {
            n,
            avx2: relight_isa::avx2(),
            scale,
            shift,
            amp,
        }
    }

    /// [`Self::new`] on the portable path only (tests compare the two).
    #[must_use]
    pub fn portable(n: usize) -> Self {
        Self {
            avx2: false,
            ..Self::new(n)
        }
    }

    /// The basis order `n`.
    #[must_use]
    pub fn order(&self) -> usize {
        self.n
    }

    /// `out[k] = P_k(v)` for every target `k`.
    #[inline(always)]
    fn eval(&self, v: f32, out: &mut [f32]) {
        out[0] = v.clamp(0.0, 1.0);
        for (((o, &sc), &sh), &a) in out[1..]
            .iter_mut()
            .zip(&self.scale[1..])
            .zip(&self.shift[1..])
            .zip(&self.amp[1..])
        {
            *o = a * (0.5 - (sc * v - sh).abs()).max(0.0);
        }
    }
}

/// One axis of a vertex's affine map and its lazily evaluated primitives
/// `Q_j` (module docs).
#[derive(Clone, Debug, Default)]
struct Axis {
    o: f64,
    inv_s: f64,
    /// `1/n`, exact (`n` is a power of two): `j · inv_n` is `j / n`.
    inv_n: f64,
    /// `(n + 1) · n`: `Q_j` at `j · n`.
    q: Vec<f32>,
    /// Bit `j`: `Q_j` evaluated.
    done: u128,
}

impl Axis {
    fn reset(&mut self, n: usize, s: f64, o: f64) {
        self.q.resize((n + 1) * n, 0.0);
        self.done = 0;
        self.o = o;
        self.inv_s = 1.0 / s;
        self.inv_n = 1.0 / n as f64;
    }

    /// The offset of `Q_j` in `q`, evaluating it first if needed.
    #[inline(always)]
    fn q(&mut self, p: &Primitives, j: usize) -> usize {
        let n = p.n;
        if self.done >> j & 1 == 0 {
            let v = ((j as f64 * self.inv_n - self.o) * self.inv_s) as f32;
            p.eval(v, &mut self.q[j * n..(j + 1) * n]);
            self.done |= 1 << j;
        }
        j * n
    }

    /// Row `i` of `D(s, o)` into `out` (`n` values).
    #[inline(always)]
    fn acc_row(&mut self, p: &Primitives, i: usize, out: &mut [f32]) {
        let n = p.n;
        if i == 0 {
            let (a, b) = (self.q(p, 0), self.q(p, n));
            for ((o, &qa), &qb) in out.iter_mut().zip(&self.q[a..a + n]).zip(&self.q[b..b + n]) {
                *o = qb - qa;
            }
            return;
        }
        let l = i.ilog2();
        let step = n >> l;
        let ja = (i - (1 << l)) * step;
        let (a, m, b) = (
            self.q(p, ja),
            self.q(p, ja + step / 2),
            self.q(p, ja + step),
        );
        let amp = ((1usize << l) as f32).sqrt();
        let q = &self.q;
        for (((o, &qa), &qm), &qb) in out
            .iter_mut()
            .zip(&q[a..a + n])
            .zip(&q[m..m + n])
            .zip(&q[b..b + n])
        {
            *o = amp * (2.0 * qm - qa - qb);
        }
    }
}

/// Row `i` of the 1D ACC matrix `D(s, o)` of the order-`p.order()` basis
/// (module docs), for tests and tools; [`shade_vertex`] builds its rows
/// the same way.
pub fn acc_row(p: &Primitives, s: f64, o: f64, i: usize, out: &mut [f32]) {
    let mut axis = Axis::default();
    axis.reset(p.n, s, o);
    axis.acc_row(p, i, out);
}

/// The target mask of one vertex (module docs): row `i` of `a`'s order
/// keeps the first `counts[i]` entries of `b`'s order (of index order when
/// `a`'s factor there is zero).
#[derive(Clone, Debug, Default)]
pub struct MaskCounts {
    /// `a`'s indices `k1`, magnitude down, index up; `va` their `|a|`. Past
    /// the non-zeros (`nonzero`) only where a row there keeps entries (all
    /// of the mask, or ties: [`order_zeros`]); rows past them keep none
    /// otherwise, and their slots hold an earlier vertex's order.
    sa: Vec<u8>,
    va: Vec<f32>,
    /// The same for `b` (`k2`).
    sb: Vec<u8>,
    vb: Vec<f32>,
    /// Per row of `sa`: the kept prefix length.
    counts: Vec<u8>,
    /// Row counts at a bisection step.
    walk: Vec<u8>,
    /// Inverse of `sa`: `k1` → row.
    ra: Vec<u8>,
    /// Bit `k` set where `a_k` (`[0]`) and `b_k` (`[1]`) are non-zero.
    nonzero: [u64; 2],
}

impl MaskCounts {
    /// The kept `(k1, k2)`, grouped by `k1` in `a`'s order.
    pub fn pairs(&self) -> impl Iterator<Item = (u16, u16)> + '_ {
        self.sa.iter().enumerate().flat_map(move |(i, &k1)| {
            let zero = self.va[i] == 0.0;
            (0..usize::from(self.counts[i])).map(move |j| {
                let k2 = if zero { j } else { usize::from(self.sb[j]) };
                (u16::from(k1), k2 as u16)
            })
        })
    }

    /// The number of kept entries.
    #[must_use]
    pub fn len(&self) -> usize {
        self.counts.iter().map(|&c| usize::from(c)).sum()
    }

    /// True when nothing is kept.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Indices of `x` by `|x|` down, index up, into `order`, the magnitudes
/// into `vals`; returns the number of non-zero entries (the zeros come
/// last, in index order). A row of `D(s, o)` is mostly exact zeros (about
/// two targets per level meet the footprint's edges), so only the few
/// non-zeros are sorted (insertion sort).
#[inline(always)]
fn sort_magnitudes(x: &[f32], order: &mut Vec<u8>, vals: &mut Vec<f32>) -> (usize, u64) {
    debug_assert!(x.len() <= 64);
    // Which entries are non-zero, as bits (branch-free: about a third of
    // a row is non-zero, in no pattern a predictor learns).
    let mut nonzero = 0u64;
    for (i, v) in x.iter().enumerate() {
        nonzero |= u64::from(*v != 0.0) << i;
    }
    let mut keys = [0u64; 64];
    let mut nz = 0;
    let mut bits = nonzero;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        // Non-negative floats order as their bits; `!bits` puts large first.
        let key = (u64::from(!x[i].abs().to_bits()) << 32) | i as u64;
        let mut at = nz;
        while at > 0 && keys[at - 1] > key {
            keys[at] = keys[at - 1];
            at -= 1;
        }
        keys[at] = key;
        nz += 1;
    }
    order.resize(x.len(), 0);
    vals.resize(x.len(), 0.0);
    for (slot, &k) in keys[..nz].iter().enumerate() {
        let i = (k & 0xff) as usize;
        order[slot] = i as u8;
        vals[slot] = x[i].abs();
    }
    (nz, nonzero)
}

/// The zero entries of a [`sort_magnitudes`] order after its `nz` non-zero
/// ones, in index order (`nonzero`: its bits; `n` entries in all). Only the
/// ties' walk reads past the non-zeros ([`ties_in_coarse_order`]: its rows
/// of zero `a` and its zero `b`s), so the other masks skip this.
fn order_zeros(n: usize, nz: usize, nonzero: u64, order: &mut [u8], vals: &mut [f32]) {
    let all = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
    let mut zeros = !nonzero & all;
    let mut slot = nz;
    while zeros != 0 {
        order[slot] = zeros.trailing_zeros() as u8;
        vals[slot] = 0.0;
        zeros &= zeros - 1;
        slot += 1;
    }
}

/// Entries with `va[i] · vb[j] ≥ v` per row into `rows` (`vb` sorted
/// down); their total.
#[inline(always)]
fn count_at_least(va: &[f32], vb: &[f32], v: f32, rows: &mut [u8]) -> usize {
    let mut total = 0;
    for (&x, r) in va.iter().zip(rows.iter_mut()) {
        // Products fall along the row: a binary search finds the count.
        let c = vb.partition_point(|&y| x * y >= v);
        *r = c as u8;
        total += c;
    }
    total
}

/// Coarse-first rank of a 1D index, as [`relight_affine::standard::level_rank`].
fn rank(i: usize) -> u32 {
    if i == 0 { 0 } else { i.ilog2() + 1 }
}

/// [`crate::light::coarse_key`] packed into 32 bits (indices < 64).
fn packed_coarse_key(k1: usize, k2: usize) -> u32 {
    (rank(k1).max(rank(k2)) << 12) | ((k2 as u32) << 6) | k1 as u32
}

/// Entries between two bisection bounds at most that many are ranked
/// directly (sorted) rather than bisected further.
const BRACKET: usize = 24;

/// A target count `m` at most this ranks the candidates `(i + 1)(j + 1) ≤
/// m` directly (an entry outside has at least `m` entries at least as
/// large and coarser on ties): `Σ_i ⌊m/(i+1)⌋ ≤ 50` of them for `m ≤ 16`.
const SMALL_M: usize = 16;

/// Room for the candidates of [`SMALL_M`] (and of a [`BRACKET`]).
const CANDIDATES: usize = 64;

/// The mask of the `m` largest `|a_{k1} b_{k2}|`, ties coarse first
/// (module docs), into `mask`.
#[inline(always)]
pub fn select_mask(a: &[f32], b: &[f32], m: usize, mask: &mut MaskCounts) {
    let n = a.len();
    debug_assert!(n <= 64 && b.len() == n);
    let (za, nonzero_a) = sort_magnitudes(a, &mut mask.sa, &mut mask.va);
    let (zb, nonzero_b) = sort_magnitudes(b, &mut mask.sb, &mut mask.vb);
    mask.nonzero = [nonzero_a, nonzero_b];
    mask.counts.clear();
    mask.counts.resize(n, 0);
    if m >= n * n {
        order_zeros(n, za, nonzero_a, &mut mask.sa, &mut mask.va);
        order_zeros(n, zb, nonzero_b, &mut mask.sb, &mut mask.vb);
        mask.counts.fill(n as u8);
        return;
    }
    if m == 0 {
        return;
    }
    // The `za × zb` block of positive products comes first.
    let block = za * zb;
    if m >= block {
        mask.counts[..za].fill(zb as u8);
        ties_in_coarse_order(a, b, 0.0, m - block, mask);
        return;
    }
    let (va, vb) = (&mask.va[..za], &mask.vb[..zb]);
    let mut cand = [0u64; CANDIDATES];
    let mut len = 0;
    if m <= SMALL_M {
        for (i, &x) in va.iter().enumerate() {
            let k1 = usize::from(mask.sa[i]);
            for (j, &y) in vb.iter().enumerate().take(m / (i + 1)) {
                let k2 = usize::from(mask.sb[j]);
                cand[len] = candidate(x * y, k1, k2, i);
                len += 1;
            }
        }
        rank_candidates(&mut cand[..len], m, &mut mask.counts);
        return;
    }
    // Bisection on the bit pattern of the threshold, with the row counts
    // at both bounds: `counts` at `hi` (< m entries), `walk` at `lo` (≥ m).
    mask.walk.clear();
    mask.walk.resize(n, 0);
    mask.walk[..za].fill(zb as u8);
    let (mut lo, mut hi) = (0u32, (va[0] * vb[0]).to_bits() + 1);
    let (mut at_lo, mut at_hi) = (block, 0usize);
    let mut mid_rows = [0u8; 64];
    let mid_rows = &mut mid_rows[..za];
    while hi - lo > 1 && at_lo - at_hi > BRACKET {
        let mid = lo + (hi - lo) / 2;
        let c = count_at_least(va, vb, f32::from_bits(mid), mid_rows);
        if c == m {
            mask.counts[..za].copy_from_slice(mid_rows);
            return;
        }
        if c > m {
            (lo, at_lo) = (mid, c);
            mask.walk[..za].copy_from_slice(mid_rows);
        } else {
            (hi, at_hi) = (mid, c);
            mask.counts[..za].copy_from_slice(mid_rows);
        }
    }
    // Everything at or above `hi` is kept; `need` more of the entries in
    // [lo, hi), by value, then coarse first.
    let need = m - at_hi;
    if at_lo - at_hi <= BRACKET {
        for (i, &x) in va.iter().enumerate() {
            let k1 = usize::from(mask.sa[i]);
            let (from, to) = (usize::from(mask.counts[i]), usize::from(mask.walk[i]));
            for (&y, &k2) in vb[from..to].iter().zip(&mask.sb[from..to]) {
                cand[len] = candidate(x * y, k1, usize::from(k2), i);
                len += 1;
            }
        }
        rank_candidates(&mut cand[..len], need, &mut mask.counts);
        return;
    }
    // Many exact ties at τ = lo (equal magnitudes): the coarse-order walk.
    ties_in_coarse_order(a, b, f32::from_bits(lo), need, mask);
}

/// A candidate's sort key: value down (inverted bits), then the coarse key
/// up ([`packed_coarse_key`], 15 bits), then its row (8 bits).
fn candidate(value: f32, k1: usize, k2: usize, row: usize) -> u64 {
    (u64::from(!value.to_bits()) << 32) | (u64::from(packed_coarse_key(k1, k2)) << 8) | row as u64
}

/// Adds the `need` first candidates in key order ([`candidate`]: at most
/// [`CANDIDATES`]) to their rows' counts. Keys are distinct (each holds
/// its `(k1, k2)`), so only the first `need` are kept in order, by
/// insertion: a candidate after them enters only when it is smaller than
/// the last kept (sorting all of them was the top line of the 1 %/1 %
/// propagation profile; `select_nth_unstable`, not inlined, cost more).
#[inline(always)]
fn rank_candidates(cand: &mut [u64], need: usize, counts: &mut [u8]) {
    let need = need.min(cand.len());
    if need == 0 {
        return;
    }
    for i in 1..cand.len() {
        let key = cand[i];
        let mut at = if i < need {
            i
        } else if key < cand[need - 1] {
            need - 1
        } else {
            continue;
        };
        while at > 0 && cand[at - 1] > key {
            cand[at] = cand[at - 1];
            at -= 1;
        }
        cand[at] = key;
    }
    for &c in &cand[..need] {
        counts[(c & 0xff) as usize] += 1;
    }
}

/// Adds `need` entries with `|a_{k1} b_{k2}| = tau` to `mask.counts`, the
/// 2D indices walked in coarse order (within a row, `k2` order: the order
/// the row's equal products sit in, so counts stay prefixes).
fn ties_in_coarse_order(a: &[f32], b: &[f32], tau: f32, mut need: usize, mask: &mut MaskCounts) {
    if need == 0 {
        return;
    }
    let n = a.len();
    let [nonzero_a, nonzero_b] = mask.nonzero;
    let (za, zb) = (nonzero_a.count_ones(), nonzero_b.count_ones());
    order_zeros(n, za as usize, nonzero_a, &mut mask.sa, &mut mask.va);
    order_zeros(n, zb as usize, nonzero_b, &mut mask.sb, &mut mask.vb);
    mask.ra.clear();
    mask.ra.resize(n, 0);
    for (row, &k1) in mask.sa.iter().enumerate() {
        mask.ra[usize::from(k1)] = row as u8;
    }
    // Bit k set: |a_k| · x = tau can hold for k with a_k = 0 only, when
    // tau = 0 (the common case: the targets no heuristic product reaches).
    // (`sort_magnitudes` found the non-zeros.)
    let all = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
    let zero_a = !mask.nonzero[0] & all;
    let mut first_level = 0;
    if tau == 0.0 {
        // Whole squares [0, h)² first: their zero products are
        // h² − nzA(h)·nzB(h), and a row's share is h (a zero row, in index
        // order) or its zero b's below h (after its non-zero b's in its
        // order), so the counts stay prefixes. The walk resumes at the
        // first square not taken whole.
        let zero_b = !mask.nonzero[1] & all;
        let below = |h: usize| if h >= 64 { u64::MAX } else { (1u64 << h) - 1 };
        let zeros_in = |h: usize| {
            let (nza, nzb) = (
                h - (zero_a & below(h)).count_ones() as usize,
                h - (zero_b & below(h)).count_ones() as usize,
            );
            h * h - nza * nzb
        };
        let mut whole = 0;
        while whole < n && zeros_in((whole * 2).max(1)) <= need {
            whole = (whole * 2).max(1);
        }
        if whole > 0 {
            let zb_below = (zero_b & below(whole)).count_ones() as u8;
            for k1 in 0..whole {
                let row = usize::from(mask.ra[k1]);
                mask.counts[row] += if zero_a >> k1 & 1 == 1 {
                    whole as u8
                } else {
                    zb_below
                };
            }
            need -= zeros_in(whole);
            if need == 0 {
                return;
            }
            first_level = whole.ilog2() + 1;
        }
    }
    for level in first_level..=n.ilog2() {
        let hi_k = 1usize << level;
        let lo_k = hi_k / 2;
        for (k2, bk) in b.iter().enumerate().take(hi_k) {
            let from = if rank(k2) == level { 0 } else { lo_k };
            let bk = bk.abs();
            if tau == 0.0 && bk != 0.0 {
                // Only the zeros of `a` in [from, hi_k).
                let range = (u64::MAX >> (64 - hi_k)) & !((1u64 << from) - 1);
                let mut bits = zero_a & range;
                while bits != 0 {
                    let k1 = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    mask.counts[usize::from(mask.ra[k1])] += 1;
                    need -= 1;
                    if need == 0 {
                        return;
                    }
                }
                continue;
            }
            if tau == 0.0 {
                // b_k2 = 0: every k1 of the range is a tie, in k1 order.
                let take = (hi_k - from).min(need);
                for &row in &mask.ra[from..from + take] {
                    mask.counts[usize::from(row)] += 1;
                }
                need -= take;
                if need == 0 {
                    return;
                }
                continue;
            }
            for (k1, ak) in a.iter().enumerate().take(hi_k).skip(from) {
                if ak.abs() * bk == tau {
                    mask.counts[usize::from(mask.ra[k1])] += 1;
                    need -= 1;
                    if need == 0 {
                        return;
                    }
                }
            }
        }
    }
}

/// The `m` target indices `(k1, k2)` of [`select_mask`], into `out`
/// (cleared), grouped by `k1` in `a`'s order.
pub fn select_targets(
    a: &[f32],
    b: &[f32],
    m: usize,
    mask: &mut MaskCounts,
    out: &mut Vec<(u16, u16)>,
) {
    select_mask(a, b, m, mask);
    out.clear();
    out.extend(mask.pairs());
}

/// Per-thread scratch of [`shade_vertex`].
#[derive(Clone, Debug, Default)]
pub struct VertexScratch {
    /// `(n, s, o, m)` the axes, row 0, the mask and the cached `D^x` rows
    /// below were made for: a call with the same key (the angular slices of
    /// one light field at one vertex, [`crate::light_field`]) reuses them.
    key: Option<(usize, [f64; 2], [f64; 2], usize)>,
    x: Axis,
    y: Axis,
    a: Vec<f32>,
    b: Vec<f32>,
    mask: MaskCounts,
    /// Rows of `D^x` by `i1`, built on first use (bit `i1` of `dx_done`).
    dx: Vec<f32>,
    dx_done: u64,
    row: Vec<f32>,
    z: Vec<f32>,
    dyt: Vec<f32>,
    /// `(n, stride, rows)` of `dyt`'s layout (its padding lanes are zero).
    dyt_layout: (usize, usize, usize),
    w: Vec<f32>,
}

/// What every vertex of one propagation shares: the basis' primitives,
/// the compressed source terms and the target count `m`.
#[derive(Clone, Copy, Debug)]
pub struct Kernel<'a> {
    pub primitives: &'a Primitives,
    pub source: &'a SourceTerms,
    pub targets: usize,
}

/// One vertex: its affine map `(s, o)` per axis
/// ([`crate::face::LightFrame::affine`]) and its transport, `n²`
/// coefficients (one channel, the same for every colour) or `3 n²` (one
/// block per channel), layout `k2 · n + k1`.
#[derive(Clone, Copy, Debug)]
pub struct VertexMap<'a> {
    pub s: [f64; 2],
    pub o: [f64; 2],
    pub transport: &'a [f32],
}

/// The fused kernel (module docs) for one vertex:
/// `B[c] = Σ_{k ∈ mask} L_k[c] T_k[c]`.
#[must_use]
pub fn shade_vertex(k: &Kernel, v: &VertexMap, sc: &mut VertexScratch) -> [f32; 3] {
    #[cfg(target_arch = "x86_64")]
    if k.primitives.avx2 {
        // SAFETY: AVX2 was detected at run time (`Primitives::new`).
        return unsafe { shade_vertex_avx2(k, v, sc) };
    }
    shade_vertex_body(k, v, sc)
}

/// [`shade_vertex`] compiled for AVX2 (its loops run over `n` targets or
/// `R` source rows: 8 lanes instead of 4).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn shade_vertex_avx2(k: &Kernel, v: &VertexMap, sc: &mut VertexScratch) -> [f32; 3] {
    shade_vertex_body(k, v, sc)
}

#[inline(always)]
fn shade_vertex_body(k: &Kernel, v: &VertexMap, sc: &mut VertexScratch) -> [f32; 3] {
    let (p, src, m) = (k.primitives, k.source, k.targets);
    let (s, o, transport) = (v.s, v.o, v.transport);
    let n = p.n;
    let rows = src.rows.len();
    if rows == 0 {
        return [0.0; 3];
    }
    debug_assert_eq!(src.n, n);
    // Everything here depends on the vertex's map and the target count
    // only, not on the source terms.
    let key = Some((n, s, o, m));
    if sc.key != key {
        sc.x.reset(n, s[0], o[0]);
        sc.y.reset(n, s[1], o[1]);
        sc.a.resize(n, 0.0);
        sc.b.resize(n, 0.0);
        sc.x.acc_row(p, 0, &mut sc.a);
        sc.y.acc_row(p, 0, &mut sc.b);
        select_mask(&sc.a, &sc.b, m, &mut sc.mask);
        if prefetches_mask(n, m) {
            // Step 1 below runs while these lines arrive.
            prefetch_mask(&sc.mask, transport, n);
        }
        sc.dx.resize(n * n, 0.0);
        sc.dx_done = 0;
        sc.key = key;
    }
    sc.row.resize(n, 0.0);
    sc.z.resize(rows * 3 * n, 0.0);
    // D^y's rows transposed, each k2's `R` values padded with zeros to
    // whole vectors of LANES (the fuse's lanes): 1–4 vectors, or 8 (only an
    // order-64 basis has more than 32 rows; fewer fuse copies, less code).
    let blocks = rows.div_ceil(LANES);
    let stride = if blocks <= 4 { blocks } else { MAX_BLOCKS } * LANES;
    // Every vertex writes lanes `r < rows` of every `k2`; the padding lanes
    // stay zero while the layout does (zeroing all of it per vertex was
    // 2–3 % of a 1 %/1 % propagation).
    if sc.dyt_layout != (n, stride, rows) {
        sc.dyt.clear();
        sc.dyt.resize(n * stride, 0.0);
        sc.dyt_layout = (n, stride, rows);
    }
    // Step 1, and D^y's source rows transposed to [k2][r].
    for (r, &(i2, start, end)) in src.rows.iter().enumerate() {
        let z = &mut sc.z[r * 3 * n..(r + 1) * 3 * n];
        z.fill(0.0);
        let (z0, rest) = z.split_at_mut(n);
        let (z1, z2) = rest.split_at_mut(n);
        for t in &src.terms[start as usize..end as usize] {
            let i1 = usize::from(t.i1);
            let d = &mut sc.dx[i1 * n..(i1 + 1) * n];
            if sc.dx_done >> i1 & 1 == 0 {
                sc.x.acc_row(p, i1, d);
                sc.dx_done |= 1 << i1;
            }
            let [c0, c1, c2] = t.rgb;
            for (((a, b), c), &dk) in z0.iter_mut().zip(z1.iter_mut()).zip(z2.iter_mut()).zip(&*d) {
                *a += c0 * dk;
                *b += c1 * dk;
                *c += c2 * dk;
            }
        }
        sc.y.acc_row(p, usize::from(i2), &mut sc.row);
        // Split borrows: with `sc.dyt[..]` indexed through `sc` the loop
        // reloaded its pointer and length after every store.
        let dyt = &mut sc.dyt[r..];
        for (k2, &d) in sc.row.iter().enumerate() {
            dyt[k2 * stride] = d;
        }
    }
    if transport.len() == 3 * n * n {
        fuse_dot::<3>(n, rows, stride, transport, sc)
    } else {
        fuse_dot::<1>(n, rows, stride, transport, sc)
    }
}

/// Lanes of the fuse's vectors (`R` source rows padded to a multiple).
const LANES: usize = 8;

/// Blocks of [`LANES`] source rows at most: `R ≤ n ≤ 64`.
const MAX_BLOCKS: usize = 8;

/// The fuse's inputs: the mask, the transport (`C` blocks of `n²`,
/// `k2 · n + k1`), `D^y` transposed (`NB · LANES` values per `k2`) and the
/// `rows` source rows.
struct Fuse<'a> {
    mask: &'a MaskCounts,
    transport: &'a [f32],
    dyt: &'a [f32],
    n: usize,
    rows: usize,
}

impl Fuse<'_> {
    /// `W_c[k1][r] = Σ_{(k1,k2) ∈ mask} D^y[i2_r][k2] T_c[k2][k1]` into `w`
    /// (`[c][r][k1]`): per mask row (one `k1`) the sums over its entries in
    /// registers, lanes over `r`, all `NB` blocks of rows at once, so each
    /// entry's scattered transport value is read once (it was read once per
    /// block: 5 %/40 % propagation −10 %, 20 %/70 % −17 %); stored once per
    /// row. One or two blocks pair the entries into two register sets, so
    /// that more chains hide the add latency (with one set, two blocks cost
    /// the 1 %/1 % propagation 4 %); more blocks are chains enough.
    #[inline(always)]
    fn run<const C: usize, const NB: usize>(&self, w: &mut [f32]) {
        let (n, rows, stride) = (self.n, self.rows, NB * LANES);
        let nn = n * n;
        let mask = self.mask;
        for (i, &count) in mask.counts.iter().enumerate() {
            if count == 0 {
                continue;
            }
            let k1 = usize::from(mask.sa[i]);
            let zero = mask.va[i] == 0.0;
            let k2_of = |j: usize| if zero { j } else { usize::from(mask.sb[j]) };
            let count = usize::from(count);
            for ch in 0..C {
                let col = &self.transport[ch * nn..(ch + 1) * nn];
                let entry = |j: usize| -> (f32, &[f32]) {
                    let k2 = k2_of(j);
                    (col[k2 * n + k1], &self.dyt[k2 * stride..][..stride])
                };
                let mut acc = [[0.0f32; LANES]; NB];
                let mut j = 0;
                if NB <= 2 {
                    // One or two blocks: entries in pairs into a second set,
                    // so that more chains hide the add latency.
                    let mut odd = [[0.0f32; LANES]; NB];
                    while j + 1 < count {
                        let ((ta, da), (tb, db)) = (entry(j), entry(j + 1));
                        for b in 0..NB {
                            for l in 0..LANES {
                                acc[b][l] += da[b * LANES + l] * ta;
                                odd[b][l] += db[b * LANES + l] * tb;
                            }
                        }
                        j += 2;
                    }
                    for (a, o) in acc.iter_mut().zip(&odd) {
                        for l in 0..LANES {
                            a[l] += o[l];
                        }
                    }
                }
                while j < count {
                    let (t, d) = entry(j);
                    for (b, a) in acc.iter_mut().enumerate() {
                        for l in 0..LANES {
                            a[l] += d[b * LANES + l] * t;
                        }
                    }
                    j += 1;
                }
                for r in 0..rows {
                    w[(ch * rows + r) * n + k1] = acc[r / LANES][r % LANES];
                }
            }
        }
    }
}

/// The fuse and the dot of [`shade_vertex`] for a `C`-channel transport;
/// `D^y` transposed in `sc.dyt` with `stride` (≥ `rows`, a multiple of
/// [`LANES`]) values per `k2`.
#[inline(always)]
fn fuse_dot<const C: usize>(
    n: usize,
    rows: usize,
    stride: usize,
    transport: &[f32],
    sc: &mut VertexScratch,
) -> [f32; 3] {
    // W stored transposed, `[c][r][k1]`, so the dot runs along k1 in lanes.
    sc.w.clear();
    sc.w.resize(C * rows * n, 0.0);
    let f = Fuse {
        mask: &sc.mask,
        transport,
        dyt: &sc.dyt,
        n,
        rows,
    };
    let w = &mut sc.w;
    match stride / LANES {
        1 => f.run::<C, 1>(w),
        2 => f.run::<C, 2>(w),
        3 => f.run::<C, 3>(w),
        4 => f.run::<C, 4>(w),
        _ => f.run::<C, MAX_BLOCKS>(w),
    }
    // Dot: B[c] = Σ_r Σ_k1 Z[r][c][k1] W_c[r][k1], along k1 in LANES
    // independent sums (one dependent chain per lane, not per product).
    let mut out = [0.0f32; 3];
    for r in 0..rows {
        let z = &sc.z[r * 3 * n..(r + 1) * 3 * n];
        for (c, o) in out.iter_mut().enumerate() {
            let at = ((c % C) * rows + r) * n;
            let (w, zc) = (&sc.w[at..at + n], &z[c * n..(c + 1) * n]);
            let (zv, ztail) = zc.as_chunks::<LANES>();
            let (wv, wtail) = w.as_chunks::<LANES>();
            let mut lanes = [0.0f32; LANES];
            for (zz, ww) in zv.iter().zip(wv) {
                for ((l, &a), &b) in lanes.iter_mut().zip(zz).zip(ww) {
                    *l += a * b;
                }
            }
            let tail: f32 = ztail.iter().zip(wtail).map(|(a, b)| a * b).sum();
            *o += lanes.iter().sum::<f32>() + tail;
        }
    }
    out
}

/// Whether a kernel of `m` target terms on an order-`n` basis asks for
/// the transport lines its own mask reads ([`prefetch_mask`], in
/// [`shade_vertex`]) rather than for the next vertex's whole transport
/// ([`prefetch`], the caller's): below one entry per 32 coefficients (two
/// per 64-byte line of 16) the mask touches few of the lines, and reading
/// them all cost more than it hid. Measured on `bench nearfield`'s 39 K
/// scene, one thread (`docs/nearfield.md`, session 50): at 1 %/1 % (`m` =
/// 10) the whole next transport 43.5 ms, nothing 42.2, the mask's lines
/// 37.2 (31 without the measuring switches); at 1 %/20 % (`m` = 205) the
/// whole next transport 54.1, nothing 59.8, the mask's lines 62.3.
#[must_use]
pub fn prefetches_mask(n: usize, m: usize) -> bool {
    m * 32 < n * n
}

/// Asks for the transport values `mask` selects (every channel's; `transport`
/// as [`fuse_dot`] reads it, `k2 · n + k1` per channel block of `n²`), so
/// that the fuse's scattered reads find them in cache (x86-64: one
/// prefetch per entry; elsewhere nothing). Step 1 runs between the two.
/// Asking a whole vertex ahead instead (the next vertex's mask made before
/// this one is shaded) measured the same: step 1 hides the latency.
#[inline(always)]
fn prefetch_mask(mask: &MaskCounts, transport: &[f32], n: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        let nn = n * n;
        for col in transport.chunks_exact(nn) {
            for (i, &count) in mask.counts.iter().enumerate() {
                let k1 = usize::from(mask.sa[i]);
                let zero = mask.va[i] == 0.0;
                for j in 0..usize::from(count) {
                    let k2 = if zero { j } else { usize::from(mask.sb[j]) };
                    if let Some(t) = col.get(k2 * n + k1) {
                        // SAFETY: `t` is inside `transport`; a prefetch has
                        // no architectural effect.
                        unsafe {
                            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                                std::ptr::from_ref(t).cast(),
                            );
                        }
                    }
                }
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (mask, transport, n);
}

/// Asks for `data`'s cache lines ahead of use: the next vertex's
/// transport, whose coefficients the mask reads scattered, where the mask
/// reads most of its lines (not [`prefetches_mask`]; x86-64: one prefetch
/// per line, into L2 (`T1`); elsewhere nothing). Into L2 rather than L1:
/// 1 %/20 % propagation −4 % on one thread, −6 % on two, 5 %/40 % −0–3 %
/// (alternating runs of `nearfield_frames`, session 50).
pub fn prefetch(data: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    for p in (0..data.len()).step_by(16) {
        // SAFETY: `p < data.len()`: the address is inside `data`; a
        // prefetch has no architectural effect.
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T1 }>(
                data.as_ptr().add(p).cast(),
            );
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = data;
}

/// FMAs of one one-channel [`shade_vertex`] call (module docs' counts).
#[must_use]
pub fn shade_fma(src: &SourceTerms, m: usize) -> usize {
    let n = src.n;
    let r = src.rows.len();
    src.len() * n * 3 + r * m + r * n * 3
}

/// FMAs of one RGB [`shade_vertex`] call: the fuse three times.
#[must_use]
pub fn shade_rgb_fma(src: &SourceTerms, m: usize) -> usize {
    shade_fma(src, m) + 2 * src.rows.len() * m
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_affine::standard::acc_matrix_fast;

    #[test]
    fn rows_from_shared_primitives_match_the_primitive_form() {
        for n in [4, 8, 32, 64] {
            let p = Primitives::new(n);
            let mut want = vec![0.0f32; n * n];
            let mut got = vec![0.0f32; n];
            for (s, o) in [
                (1.0, 0.0),
                (0.37, 0.21),
                (2.5, -0.8),
                (7.3, -3.1),
                (0.9, 0.6),
            ] {
                acc_matrix_fast(n, s, o, &mut want);
                for i in 0..n {
                    acc_row(&p, s, o, i, &mut got);
                    // The source's support in v.
                    let (l, t) = if i == 0 {
                        (0, 0)
                    } else {
                        (i.ilog2(), i - (1 << i.ilog2()))
                    };
                    let w = 1.0 / f64::from(1u32 << l);
                    let (va, vb) = ((t as f64 * w - o) / s, ((t + 1) as f64 * w - o) / s);
                    for k in 0..n {
                        let (g, w) = (got[k], want[i * n + k]);
                        assert!(
                            (g - w).abs() <= 1e-5,
                            "n {n} s {s} o {o} D[{i}][{k}] {g} vs {w}"
                        );
                        // A target whose support misses the source's is an exact zero.
                        let (kl, kt) = if k == 0 {
                            (0, 0)
                        } else {
                            (k.ilog2(), k - (1 << k.ilog2()))
                        };
                        let kw = 1.0 / f64::from(1u32 << kl);
                        if vb <= kt as f64 * kw || va >= (kt + 1) as f64 * kw {
                            assert_eq!(g, 0.0, "n {n} s {s} o {o} D[{i}][{k}] not an exact zero");
                        }
                    }
                }
            }
        }
    }

    /// A tiny deterministic generator for the kernel test's data.
    fn noise(seed: &mut u64) -> f32 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }

    /// The fused kernel, on both compiled paths, equals the masked sum
    /// `Σ_{k ∈ mask} L_k[c] T_k[c]` computed the long way: dense ACC
    /// matrices (`acc_matrix_fast`), the propagated light of every target,
    /// the mask from `select_targets`.
    #[test]
    fn fused_kernel_equals_the_masked_dense_sum() {
        use crate::light::SourceTerm;
        let n = 16;
        let nn = n * n;
        let mut seed = 7u64;
        // Source terms on a few rows (one block of the fuse's lanes), some
        // rows with several terms; then on twelve rows (two blocks).
        let few: Vec<(u16, Vec<u16>)> =
            vec![(0, vec![0, 1, 5]), (3, vec![2]), (9, vec![0, 7, 8, 15])];
        let many: Vec<(u16, Vec<u16>)> = (0..12u16)
            .map(|i2| (i2, (0..1 + i2 % 3).map(|k| (i2 * 5 + k * 3) % 16).collect()))
            .collect();
        let mut sources = Vec::new();
        for rows in [few, many] {
            let mut src = SourceTerms {
                n,
                ..SourceTerms::default()
            };
            for (i2, i1s) in rows {
                let at = src.terms.len() as u32;
                for i1 in i1s {
                    src.terms.push(SourceTerm {
                        i1,
                        rgb: [noise(&mut seed), noise(&mut seed), noise(&mut seed)],
                    });
                }
                src.rows.push((i2, at, src.terms.len() as u32));
            }
            sources.push(src);
        }
        let transport: Vec<f32> = (0..3 * nn).map(|_| noise(&mut seed)).collect();
        let mut dx = vec![0.0f32; nn];
        let mut dy = vec![0.0f32; nn];
        let mut mask = MaskCounts::default();
        let mut pairs = Vec::new();
        // One scratch per path kept across every call: a call with the key
        // of the one before (same map and target count, another source or
        // transport) reuses its rows and mask, bit for bit as a fresh one.
        let mut shared = [VertexScratch::default(), VertexScratch::default()];
        for (src, (s, o)) in sources.iter().flat_map(|src| {
            [([0.6, 1.7], [0.1, -0.4]), ([3.2, 2.4], [-1.1, -0.9])].map(|so| (src, so))
        }) {
            acc_matrix_fast(n, s[0], o[0], &mut dx);
            acc_matrix_fast(n, s[1], o[1], &mut dy);
            for m in [3, 40, 130, nn] {
                select_targets(&dx[..n], &dy[..n], m, &mut mask, &mut pairs);
                for channels in [1, 3] {
                    let t = &transport[..channels * nn];
                    let mut want = [0.0f64; 3];
                    for &(k1, k2) in &pairs {
                        let (k1, k2) = (usize::from(k1), usize::from(k2));
                        for (c, w) in want.iter_mut().enumerate() {
                            // L_k[c] = Σ_terms F[c] D^x[i1][k1] D^y[i2][k2].
                            let mut l = 0.0f64;
                            for &(i2, a, b) in &src.rows {
                                for term in &src.terms[a as usize..b as usize] {
                                    l += f64::from(term.rgb[c])
                                        * f64::from(dx[usize::from(term.i1) * n + k1])
                                        * f64::from(dy[usize::from(i2) * n + k2]);
                                }
                            }
                            let tc = if channels == 3 { c } else { 0 };
                            *w += l * f64::from(t[tc * nn + k2 * n + k1]);
                        }
                    }
                    for (path, p) in [Primitives::new(n), Primitives::portable(n)]
                        .into_iter()
                        .enumerate()
                    {
                        let mut sc = VertexScratch::default();
                        let kernel = Kernel {
                            primitives: &p,
                            source: src,
                            targets: m,
                        };
                        let vertex = VertexMap { s, o, transport: t };
                        let got = shade_vertex(&kernel, &vertex, &mut sc);
                        for other in [src, &sources[0]] {
                            let kernel = Kernel {
                                source: other,
                                ..kernel
                            };
                            let reused = shade_vertex(&kernel, &vertex, &mut shared[path]);
                            let fresh =
                                shade_vertex(&kernel, &vertex, &mut VertexScratch::default());
                            assert_eq!(reused, fresh, "s {s:?} m {m} channels {channels}");
                        }
                        for c in 0..3 {
                            assert!(
                                (f64::from(got[c]) - want[c]).abs() <= 1e-4 * (1.0 + want[c].abs()),
                                "s {s:?} m {m} channels {channels} avx2 {}: {got:?} vs {want:?}",
                                p.avx2
                            );
                        }
                    }
                }
            }
        }
    }
}
