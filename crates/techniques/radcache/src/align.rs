//! The aligning rotation `R_i` from a record's frame into the point's frame
//! by each [`RotationMethod`], through `relight_sh`'s public rotations.

use crate::RotationMethod;
use relight_sh::rotation::{IvanicRuedenberg, Rot3, ShRotation, ZyzRotation};
use relight_sh::taylor::TaylorRotation;

/// A rotation plan for one method and order, with its scratch.
#[derive(Clone, Debug)]
pub struct Aligner {
    method: RotationMethod,
    order: usize,
    taylor: Option<TaylorRotation<f32>>,
    zyz: ZyzRotation<f32>,
    ivanic: IvanicRuedenberg<f32>,
    matrix: ShRotation<f32>,
    scratch: Vec<f32>,
    /// `relight_sh`'s fused matrix-form Taylor kernels run here (AVX-512F):
    /// hand them the matrix per channel; elsewhere the RGB Taylor rotation
    /// (one decomposition for all three channels).
    fused: bool,
}

impl Aligner {
    /// The plan; `beta_lim` in radians (the Taylor methods' switch).
    ///
    /// # Errors
    /// An order `relight_sh` rejects, or a negative `beta_lim`.
    pub fn new(
        method: RotationMethod,
        order: usize,
        beta_lim: f32,
    ) -> Result<Self, relight_sh::ShError> {
        Ok(Self {
            method,
            order,
            taylor: method
                .taylor()
                .map(|k| TaylorRotation::new(order, k, beta_lim))
                .transpose()?,
            zyz: ZyzRotation::new(order)?,
            ivanic: IvanicRuedenberg::new(order)?,
            matrix: ShRotation::identity(order)?,
            scratch: vec![0.0; 3 * order * order],
            fused: avx512f(),
        })
    }

    /// `dst = R src` for RGB coefficients (channel-major, `3·order²`).
    /// Returns `true` when a Taylor method took the exact rotation (β above
    /// β_lim).
    pub fn apply(&mut self, rot: &Rot3<f32>, src: &[f32], dst: &mut [f32]) -> bool {
        let nn = self.order * self.order;
        match self.method {
            RotationMethod::Ignore => {
                dst[..3 * nn].copy_from_slice(&src[..3 * nn]);
                false
            }
            RotationMethod::Taylor1 | RotationMethod::Taylor15 | RotationMethod::Taylor2 => {
                let t = self.taylor.as_ref().expect("Taylor plan");
                let mut exact = false;
                if self.fused {
                    for c in 0..3 {
                        exact |= !t.apply(
                            rot,
                            &src[c * nn..(c + 1) * nn],
                            &mut dst[c * nn..(c + 1) * nn],
                            &mut self.scratch,
                        );
                    }
                } else {
                    // One ZYZ split and one set of multiple angles for the
                    // three channels.
                    exact = !t.apply_rgb(rot, src, dst, &mut self.scratch);
                }
                exact
            }
            RotationMethod::Zyz => {
                let e = rot.euler_zyz();
                for c in 0..3 {
                    self.zyz.apply_euler(
                        &e,
                        &src[c * nn..(c + 1) * nn],
                        &mut dst[c * nn..(c + 1) * nn],
                        &mut self.scratch,
                    );
                }
                false
            }
            RotationMethod::Ivanic => {
                self.ivanic.build(rot, &mut self.matrix);
                let (d0, rest) = dst[..3 * nn].split_at_mut(nn);
                let (d1, d2) = rest.split_at_mut(nn);
                self.matrix.apply_rgb(
                    [&src[..nn], &src[nn..2 * nn], &src[2 * nn..3 * nn]],
                    [d0, d1, d2],
                );
                false
            }
        }
    }
}

/// True where `relight_sh`'s AVX-512F kernels run (detected at run time).
fn avx512f() -> bool {
    relight_sh::isa() == relight_sh::Isa::Avx512
}
