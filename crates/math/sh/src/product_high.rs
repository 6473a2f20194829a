//! The truncated SH product at orders 5…10 in f32, pseudo-spectrally:
//! synthesis on a Gauss–Legendre grid in `z`, the product of the two φ-Fourier
//! series by convolution, and analysis back to SH by the same rule.
//!
//! # Why (operation counts, order `n = L + 1`)
//! The direct sum `(f ∗ g)_i = Σ Γ_{ijk} f_j g_k` has 12 868 non-zero terms at
//! n = 8 (2 300 index-sorted triples): scalar multiply–adds, each with a sparse
//! load, whose Gaunt pattern does not fill eight lanes. Here, per latitude
//! (eight north nodes in one AVX2 register, the south ones by symmetry):
//! * synthesis of `f` and `g`: one 8-lane FMA per coefficient each (`2n²`);
//! * the φ-product: `h(φ) = f(φ) g(φ)` as trigonometric polynomials, only
//!   modes `0…L` kept, `H_p = Σ_m F_m G_{p−m}`: `Σ_p (p+1) + 2(L−p)` complex
//!   products, i.e. `4(L+1)² + …` 8-lane FMAs per hemisphere (368 at n = 8);
//! * analysis: one 8-lane multiply per coefficient and a horizontal sum per
//!   eight coefficients.
//!
//! At n = 8 that is about 960 8-lane operations, dense, against ≥ 1 600 even
//! with perfect lane packing of the direct sum.
//!
//! # Exactness
//! `Y_lm = Λ_lm(z) · trig(mφ)`, with `Λ_lm(z) = (1−z²)^{|m|/2} ×` a polynomial
//! of degree `l−|m|`. In `∫ y_i f g dω` the z-integrand `Λ_i F_{m₁} G_{m₂}`
//! (`m₁ + m₂ = ±m_i`) is a polynomial of degree `≤ 3L`, integrated exactly by
//! the 16-point Gauss–Legendre rule (exact to degree 31 ≥ 27 = 3·9); the φ part
//! is an exact convolution of Fourier coefficients. So the result is the
//! truncated product of [`crate::product::TripleProduct::product_triples`]
//! up to f32 rounding only: the tests bound `|Δ_i| ≤ 2·10⁻⁷ · ‖f‖₂‖g‖₂`
//! against the f64 Gaunt product on the same (f32) inputs (measured
//! ≤ 1.8·10⁻⁸ at n = 7…10; n = 5, 6 are tested the same way).
//!
//! # Paths
//! One generic kernel, instantiated for the portable 8-lane array type
//! ([`V<8, false>`], plain multiply and add) and, when
//! [`crate::lanes::avx2_fma_available`], for one AVX2 register ([`F8`], fused).
//! The tables are built once per [`HighProduct`]; a call allocates nothing.

use crate::basis::eval_sh_into;
#[cfg(target_arch = "x86_64")]
use crate::lanes::F8;
use crate::lanes::{Lane, V};
use std::f64::consts::PI;

/// Lowest order taken by this path.
pub(crate) const HIGH_MIN_ORDER: usize = 5;
/// Highest order taken by this path (the 16-node rule is exact up to here).
pub(crate) const HIGH_MAX_ORDER: usize = 10;
/// Gauss–Legendre nodes in `z` (8 north + 8 mirrored south).
const GL_NODES: usize = 16;
/// Largest `n²` padded to a multiple of 8.
const MAX_PAD: usize = (HIGH_MAX_ORDER * HIGH_MAX_ORDER).next_multiple_of(8);

/// Eight f32 lanes: what the kernel needs beyond [`Lane`].
trait Vec8: Lane {
    /// The lanes `p[0..8]`.
    fn ld(p: &[f32; 8]) -> Self;
    /// `[Σ lanes of p[0], …, Σ lanes of p[7]]`.
    fn hsum8(p: [Self; 8]) -> [f32; 8];
}

impl Vec8 for V<8, false> {
    #[inline(always)]
    fn ld(p: &[f32; 8]) -> Self {
        V(*p)
    }
    #[inline(always)]
    fn hsum8(p: [Self; 8]) -> [f32; 8] {
        p.map(|v| {
            let v = v.0;
            ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]))
        })
    }
}

#[cfg(target_arch = "x86_64")]
impl Vec8 for F8 {
    #[inline(always)]
    fn ld(p: &[f32; 8]) -> Self {
        // SAFETY: `p` holds eight f32.
        unsafe { F8::load(p.as_ptr()) }
    }
    #[inline(always)]
    fn hsum8(p: [Self; 8]) -> [f32; 8] {
        use std::arch::x86_64::*;
        // SAFETY: F8 is only used in functions compiled for AVX2 + FMA on CPUs
        // that have them (see `HighProduct::product_fma`).
        unsafe {
            let h01 = _mm256_hadd_ps(p[0].0, p[1].0);
            let h23 = _mm256_hadd_ps(p[2].0, p[3].0);
            let h45 = _mm256_hadd_ps(p[4].0, p[5].0);
            let h67 = _mm256_hadd_ps(p[6].0, p[7].0);
            // Lanes: [s0 s1 s2 s3 | s0' s1' s2' s3'] (low and high halves' sums).
            let a = _mm256_hadd_ps(h01, h23);
            let b = _mm256_hadd_ps(h45, h67);
            let lo = _mm256_permute2f128_ps::<0x20>(a, b);
            let hi = _mm256_permute2f128_ps::<0x31>(a, b);
            F8(_mm256_add_ps(lo, hi)).to_array()
        }
    }
}

/// Tables of the pseudo-spectral product for one order (f32).
#[derive(Clone, Debug)]
pub(crate) struct HighProduct {
    order: usize,
    /// Synthesis, by coefficient index `i = l(l+1)+m`: over the north nodes,
    /// `Λ_l0(z_t)` (m = 0), `Λ_lm(z_t)/2` (m > 0, real part of `F_m`),
    /// `−Λ_l,−m(z_t)/2` (m < 0, imaginary part of `F_|m|`).
    syn: Vec<[f32; 8]>,
    /// Analysis, by coefficient index, padded with zeros to a multiple of 8:
    /// `2π w_t Λ_i(z_t)`, negated for m < 0.
    ana: Vec<[f32; 8]>,
    /// Per (padded) coefficient, which combination of the φ-product it reads:
    /// `4|m| + 2·[m < 0] + (l + |m|) mod 2` (north + south, or north − south).
    sel: Vec<u8>,
}

impl HighProduct {
    /// Tables for `order` (`HIGH_MIN_ORDER ..= HIGH_MAX_ORDER`), in f64 from
    /// [`crate::basis::eval_sh_into`], rounded to f32.
    pub(crate) fn new(order: usize) -> Option<Self> {
        if !(HIGH_MIN_ORDER..=HIGH_MAX_ORDER).contains(&order) {
            return None;
        }
        let nn = order * order;
        let (z, w) = crate::quadrature::gauss_legendre(GL_NODES);
        // North nodes (z > 0): the upper half of the ascending list.
        let north: Vec<(f64, f64)> = (GL_NODES / 2..GL_NODES).map(|k| (z[k], w[k])).collect();
        let mut syn = vec![[0.0f32; 8]; nn];
        let padded = nn.next_multiple_of(8);
        let mut ana = vec![[0.0f32; 8]; padded];
        let mut sel = vec![0u8; padded];
        let mut y = vec![0.0f64; nn];
        for (t, &(zt, wt)) in north.iter().enumerate() {
            let st = (1.0 - zt * zt).sqrt();
            // Λ_lm(z) for m ≥ 0 at φ = 0 (cos mφ = 1); for m < 0 at φ = π/(2|m|).
            eval_sh_into(order, [st, 0.0, zt], &mut y);
            let mut lam = y.clone();
            for m in 1..order {
                let phi = PI / (2 * m) as f64;
                eval_sh_into(order, [st * phi.cos(), st * phi.sin(), zt], &mut y);
                for l in m..order {
                    lam[l * (l + 1) - m] = y[l * (l + 1) - m];
                }
            }
            for l in 0..order {
                for m in -(l as isize)..=(l as isize) {
                    let i = (l * (l + 1)) as isize + m;
                    let i = i as usize;
                    let s = match m.signum() {
                        0 => 1.0,
                        1 => 0.5,
                        _ => -0.5,
                    };
                    syn[i][t] = (s * lam[i]) as f32;
                    let sa = if m < 0 { -1.0 } else { 1.0 };
                    ana[i][t] = (sa * 2.0 * PI * wt * lam[i]) as f32;
                    let am = m.unsigned_abs();
                    sel[i] = (4 * am + 2 * usize::from(m < 0) + (l + am) % 2) as u8;
                }
            }
        }
        Some(Self {
            order,
            syn,
            ana,
            sel,
        })
    }

    /// The tables of `order`, built once per process (`None` outside
    /// `HIGH_MIN_ORDER ..= HIGH_MAX_ORDER`).
    pub(crate) fn cached(order: usize) -> Option<&'static Self> {
        static TABLES: [std::sync::OnceLock<Option<HighProduct>>; HIGH_MAX_ORDER + 1] =
            [const { std::sync::OnceLock::new() }; HIGH_MAX_ORDER + 1];
        TABLES.get(order)?.get_or_init(|| Self::new(order)).as_ref()
    }

    /// `out = f ∗ g`, truncated to the order: AVX2 + FMA where available
    /// ([`crate::lanes::avx2_fma_available`]), else [`product_portable`](Self::product_portable).
    ///
    /// # Panics
    /// If a slice is shorter than `order²`.
    #[inline]
    pub(crate) fn product(&self, f: &[f32], g: &[f32], out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if crate::lanes::avx2_fma_available() {
            // SAFETY: AVX2 and FMA were detected.
            unsafe { self.product_fma(f, g, out) };
            return;
        }
        self.product_portable(f, g, out);
    }

    /// The portable path: eight-lane arrays, plain multiply and add.
    ///
    /// # Panics
    /// As [`product`](Self::product).
    #[inline(never)]
    pub(crate) fn product_portable(&self, f: &[f32], g: &[f32], out: &mut [f32]) {
        self.dispatch::<V<8, false>>(f, g, out);
    }

    /// The AVX2 + FMA path.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    ///
    /// # Panics
    /// As [`product`](Self::product).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline(never)]
    pub(crate) unsafe fn product_fma(&self, f: &[f32], g: &[f32], out: &mut [f32]) {
        self.dispatch::<F8>(f, g, out);
    }

    #[inline(always)]
    fn dispatch<W: Vec8>(&self, f: &[f32], g: &[f32], out: &mut [f32]) {
        match self.order {
            5 => self.kernel::<W, 5>(f, g, out),
            6 => self.kernel::<W, 6>(f, g, out),
            7 => self.kernel::<W, 7>(f, g, out),
            8 => self.kernel::<W, 8>(f, g, out),
            9 => self.kernel::<W, 9>(f, g, out),
            10 => self.kernel::<W, 10>(f, g, out),
            _ => unreachable!("HighProduct is only built for orders 5..=10"),
        }
    }

    /// Fourier coefficients `F_m = re + i·im`, m = 0…N−1, at the north
    /// (`[0]`) and south (`[1]`) nodes: for each m, the even (`l+m` even) and
    /// odd sums over l at the north nodes, north = even + odd, south = even − odd.
    #[inline(always)]
    fn synth<W: Vec8, const N: usize>(&self, a: &[f32]) -> [[[W; N]; 2]; 2] {
        let syn = &self.syn[..N * N];
        let a = &a[..N * N];
        let z = W::splat(0.0);
        let mut r = [[[z; N]; 2]; 2];
        for m in 0..N {
            let (mut er, mut or, mut ei, mut oi) = (z, z, z, z);
            let mut l = m;
            while l < N {
                let i = l * (l + 1) + m;
                er = W::ld(&syn[i]).mul_add(W::splat(a[i]), er);
                if m > 0 {
                    let i = l * (l + 1) - m;
                    ei = W::ld(&syn[i]).mul_add(W::splat(a[i]), ei);
                }
                if l + 1 < N {
                    let i = (l + 1) * (l + 2) + m;
                    or = W::ld(&syn[i]).mul_add(W::splat(a[i]), or);
                    if m > 0 {
                        let i = (l + 1) * (l + 2) - m;
                        oi = W::ld(&syn[i]).mul_add(W::splat(a[i]), oi);
                    }
                }
                l += 2;
            }
            r[0][0][m] = er + or;
            r[0][1][m] = er - or;
            r[1][0][m] = ei + oi;
            r[1][1][m] = ei - oi;
        }
        r
    }

    #[inline(always)]
    fn kernel<W: Vec8, const N: usize>(&self, f: &[f32], g: &[f32], out: &mut [f32]) {
        let nn = N * N;
        let out = &mut out[..nn];
        let [fr, fi] = self.synth::<W, N>(f);
        let [gr, gi] = self.synth::<W, N>(g);
        let z = W::splat(0.0);
        // hv[4p + …]: re(N+S), re(N−S), im(N+S), im(N−S) of H_p.
        let mut hv = [z; 40];
        for p in 0..N {
            let mut acc = [[z; 4]; 2];
            for h in 0..2 {
                let (fr, fi, gr, gi) = (&fr[h], &fi[h], &gr[h], &gi[h]);
                let [mut rp, mut rn, mut ip, mut inn] = acc[h];
                // Σ_{m=0}^{p} F_m G_{p−m}: re = ac − bd, im = ad + bc.
                for m in 0..=p {
                    let (a, b, c, d) = (fr[m], fi[m], gr[p - m], gi[p - m]);
                    rp = a.mul_add(c, rp);
                    rn = b.mul_add(d, rn);
                    ip = a.mul_add(d, ip);
                    ip = b.mul_add(c, ip);
                }
                // Σ_{j=1}^{L−p} F_{p+j} conj(G_j) + conj(F_j) G_{p+j}.
                for j in 1..N - p {
                    let (a, b, c, d) = (fr[p + j], fi[p + j], gr[j], gi[j]);
                    let (e, f, g, hh) = (fr[j], fi[j], gr[p + j], gi[p + j]);
                    rp = a.mul_add(c, rp);
                    rp = b.mul_add(d, rp);
                    rp = e.mul_add(g, rp);
                    rp = f.mul_add(hh, rp);
                    ip = b.mul_add(c, ip);
                    ip = e.mul_add(hh, ip);
                    inn = a.mul_add(d, inn);
                    inn = f.mul_add(g, inn);
                }
                acc[h] = [rp, rn, ip, inn];
            }
            let re_n = acc[0][0] - acc[0][1];
            let re_s = acc[1][0] - acc[1][1];
            let im_n = acc[0][2] - acc[0][3];
            let im_s = acc[1][2] - acc[1][3];
            hv[4 * p] = re_n + re_s;
            hv[4 * p + 1] = re_n - re_s;
            hv[4 * p + 2] = im_n + im_s;
            hv[4 * p + 3] = im_n - im_s;
        }
        let padded = nn.next_multiple_of(8);
        let (ana, sel) = (&self.ana[..padded], &self.sel[..padded]);
        let mut tmp = [0.0f32; MAX_PAD];
        for c in (0..padded).step_by(8) {
            let p: [W; 8] =
                std::array::from_fn(|k| W::ld(&ana[c + k]) * hv[usize::from(sel[c + k])]);
            tmp[c..c + 8].copy_from_slice(&W::hsum8(p));
        }
        out.copy_from_slice(&tmp[..nn]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::product::TripleProduct;

    /// Uniform in [−1, 1): twice `fast_tests`' generator (the same stream).
    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut r = crate::fast::tests::rng(seed);
        move || 2.0 * r()
    }

    /// True when the AVX2+FMA path can run (fails under `CI` without it).
    fn avx2_or_skip() -> bool {
        crate::fast::tests::avx2_or_skip()
    }

    /// Both paths against the f64 Gaunt-triple product, within `2e-7 ‖f‖‖g‖`.
    #[test]
    fn pseudo_spectral_matches_gaunt_product() {
        let avx2 = avx2_or_skip();
        for n in HIGH_MIN_ORDER..=HIGH_MAX_ORDER {
            let nn = n * n;
            let hp = HighProduct::new(n).unwrap();
            let tp = TripleProduct::<f64>::new(n).unwrap();
            let mut r = rng(n as u64);
            let mut worst = 0.0f64;
            for trial in 0..20 {
                let scale = [1.0, 1e-3, 40.0][trial % 3];
                let f: Vec<f64> = (0..nn).map(|_| scale * r()).collect();
                let g: Vec<f64> = (0..nn).map(|_| r()).collect();
                let (f32v, g32v): (Vec<f32>, Vec<f32>) = (
                    f.iter().map(|&v| v as f32).collect(),
                    g.iter().map(|&v| v as f32).collect(),
                );
                // Reference on the f32-rounded inputs.
                let (fr, gr): (Vec<f64>, Vec<f64>) = (
                    f32v.iter().map(|&v| f64::from(v)).collect(),
                    g32v.iter().map(|&v| f64::from(v)).collect(),
                );
                let mut want = vec![0.0; nn];
                tp.product_triples(&fr, &gr, &mut want);
                let norm = fr.iter().map(|v| v * v).sum::<f64>().sqrt()
                    * gr.iter().map(|v| v * v).sum::<f64>().sqrt();
                let mut paths: Vec<(&str, Vec<f32>)> = Vec::new();
                let mut o = vec![f32::NAN; nn + 3];
                hp.product_portable(&f32v, &g32v, &mut o);
                paths.push(("portable", o[..nn].to_vec()));
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    let mut o = vec![f32::NAN; nn];
                    // SAFETY: AVX2 + FMA detected.
                    unsafe { hp.product_fma(&f32v, &g32v, &mut o) };
                    paths.push(("avx2", o));
                }
                let _ = avx2;
                for (name, o) in &paths {
                    for i in 0..nn {
                        let e = (f64::from(o[i]) - want[i]).abs() / norm;
                        worst = worst.max(e);
                        assert!(
                            e <= 2e-7,
                            "n {n} {name} i {i}: {} vs {} (rel err {e:.2e})",
                            o[i],
                            want[i]
                        );
                    }
                }
            }
            eprintln!("n = {n}: worst |Δ|/(‖f‖‖g‖) = {worst:.2e}");
        }
    }

    /// The public entry points take this path at orders 5…10 in f32.
    #[test]
    fn triple_product_uses_it() {
        for n in HIGH_MIN_ORDER..=HIGH_MAX_ORDER {
            let nn = n * n;
            let tp = TripleProduct::<f32>::new(n).unwrap();
            let hp = HighProduct::new(n).unwrap();
            let mut r = rng(100 + n as u64);
            let f: Vec<f32> = (0..nn).map(|_| r() as f32).collect();
            let g: Vec<f32> = (0..nn).map(|_| r() as f32).collect();
            let (mut a, mut b, mut c) = (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
            let mut scratch = vec![0.0; tp.scratch_len()];
            tp.product(&f, &g, &mut a);
            tp.product_with(&f, &g, &mut b, &mut scratch);
            hp.product(&f, &g, &mut c);
            assert_eq!(a, c, "n {n} product");
            assert_eq!(b, c, "n {n} product_with");
            tp.square_with(&f, &mut a, &mut scratch);
            hp.product(&f, &f, &mut c);
            assert_eq!(a, c, "n {n} square_with");
        }
        assert!(HighProduct::new(HIGH_MIN_ORDER - 1).is_none());
        assert!(HighProduct::new(11).is_none());
    }
}
