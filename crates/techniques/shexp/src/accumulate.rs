//! Accumulating blockers at one receiver: in log space (eq. 5.13) or in
//! product space (eq. 5.11, the shadow-fields baseline).
//!
//! A blocker sphere seen from the receiver along the unit direction `ω` under
//! half-angle θ has the zonal log `f_l(θ)` of the [`LogTable`]; turned to `ω`
//! it is `f_{l,m} = √(4π/(2l+1)) f_l(θ) y_{l,m}(ω)` (the zonal rotation
//! formula, as in `relight_sh::rotation::rotate_zonal`), so accumulating one
//! blocker costs one basis evaluation and `n²` multiply-adds. The product
//! baseline turns the cap's visibility itself ([`crate::cap`]) the same way and
//! multiplies it in with one SH product per blocker.

use crate::log_table::LogTable;
use relight_sh::eval_sh_into;
use relight_sh::product::TripleProduct;
use std::f64::consts::PI;

/// `√(4π/(2l+1))` for `l < 16`.
#[must_use]
pub fn zonal_rotation_factors(order: usize) -> Vec<f32> {
    (0..order)
        .map(|l| (4.0 * PI / (2 * l + 1) as f64).sqrt() as f32)
        .collect()
}

/// Per-thread scratch of the accumulation kernels.
#[derive(Clone, Debug)]
pub struct Scratch {
    pub y: Vec<f32>,
    pub zonal: Vec<f32>,
    pub g: Vec<f32>,
    pub tmp: Vec<f32>,
    pub product: Vec<f32>,
}

impl Scratch {
    /// For `order` bands.
    #[must_use]
    pub fn new(order: usize) -> Self {
        let nn = order * order;
        Self {
            y: vec![0.0; nn],
            zonal: vec![0.0; order],
            g: vec![0.0; nn],
            tmp: vec![0.0; nn],
            product: vec![0.0; nn * nn],
        }
    }
}

/// `out += √(4π/(2l+1)) zonal_l y_{l,m}(dir)` (factors from
/// [`zonal_rotation_factors`]); `y` is scratch of `order²`.
#[inline]
pub fn add_rotated_zonal(
    order: usize,
    factors: &[f32],
    zonal: &[f32],
    dir: [f32; 3],
    y: &mut [f32],
    out: &mut [f32],
) {
    eval_sh_into(order, dir, y);
    for l in 0..order {
        let s = factors[l] * zonal[l];
        let r = l * l..(l + 1) * (l + 1);
        for (o, y) in out[r.clone()].iter_mut().zip(&y[r]) {
            *o += s * y;
        }
    }
}

/// Adds the log of a blocker of half-angle `theta` (radians) in direction
/// `dir` (unit) to `f` (eq. 5.13).
#[inline]
pub fn add_blocker_log(
    table: &LogTable,
    factors: &[f32],
    theta: f32,
    dir: [f32; 3],
    s: &mut Scratch,
    f: &mut [f32],
) {
    let n = table.order();
    table.lookup(theta, &mut s.zonal);
    add_rotated_zonal(n, factors, &s.zonal, dir, &mut s.y, f);
}

/// `out[..order]` = the zonal visibility of a cap of half-angle `theta`, in f32
/// (the analytic formula of [`crate::cap`]).
#[inline]
pub fn cap_visibility_zonal_f32(theta: f32, out: &mut [f32]) {
    let x = theta.cos();
    let (mut pm, mut p) = (1.0f32, x);
    let two_pi = 2.0 * std::f32::consts::PI;
    let inv4pi = 1.0 / (4.0 * std::f32::consts::PI);
    for (l, o) in out.iter_mut().enumerate() {
        let int_cap = if l == 0 {
            1.0 - x
        } else {
            let lf = l as f32;
            let next = ((2.0 * lf + 1.0) * x * p - lf * pm) / (lf + 1.0);
            let v = (pm - next) / (2.0 * lf + 1.0);
            pm = p;
            p = next;
            v
        };
        let c = two_pi * ((2 * l + 1) as f32 * inv4pi).sqrt() * int_cap;
        *o = if l == 0 {
            (4.0 * std::f32::consts::PI).sqrt() - c
        } else {
            -c
        };
    }
}

/// Multiplies a blocker's visibility into `g` (eq. 5.11): `g ← g ∗ g_blocker`.
#[inline]
pub fn mul_blocker_visibility(
    tp: &TripleProduct<f32>,
    factors: &[f32],
    theta: f32,
    dir: [f32; 3],
    s: &mut Scratch,
    g: &mut [f32],
) {
    let n = tp.order();
    let nn = n * n;
    cap_visibility_zonal_f32(theta, &mut s.zonal);
    s.g[..nn].fill(0.0);
    add_rotated_zonal(n, factors, &s.zonal, dir, &mut s.y, &mut s.g);
    tp.product_with(g, &s.g, &mut s.tmp, &mut s.product);
    g[..nn].copy_from_slice(&s.tmp[..nn]);
}
