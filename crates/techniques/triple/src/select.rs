//! Coefficient selection (spherical-wavelets-triple-product-2006 §4.1,
//! Fig. 7): **top-only** keeps the first `n` coefficients of the
//! coarse-levels-first layout (complete levels when `n = 20·4^m`, the regular
//! form the runtime kernel uses); **adaptive** keeps the `n` largest
//! *area-weighted* terms `|c_k| · A_{l(k)}` (`A_l = 4^{−l}`, 1 for the
//! scaling functions), the paper's "n largest area-weighted coefficients".

use crate::basis::Basis;
use serde::Serialize;

/// How the `n` kept coefficients are chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Selection {
    /// The first `n` (complete coarse levels).
    #[default]
    Top,
    /// The `n` largest area-weighted terms.
    Adaptive,
}

impl Selection {
    /// The CLI spelling.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Top => "top",
            Self::Adaptive => "adaptive",
        }
    }
}

impl std::str::FromStr for Selection {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "top" | "top-only" => Ok(Self::Top),
            "adaptive" => Ok(Self::Adaptive),
            other => Err(format!("unknown selection {other:?}: use top or adaptive")),
        }
    }
}

/// A sparse coefficient vector with sorted, distinct indices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseVec {
    pub indices: Vec<u32>,
    pub values: Vec<f32>,
}

impl SparseVec {
    /// Number of stored terms.
    #[must_use]
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// True when no term is stored.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Coefficient `k` (0 when not stored), by binary search.
    #[must_use]
    pub fn get(&self, k: usize) -> f64 {
        match self.indices.binary_search(&(k as u32)) {
            Ok(p) => f64::from(self.values[p]),
            Err(_) => 0.0,
        }
    }

    /// The dense vector of length `n`.
    #[must_use]
    pub fn to_dense(&self, n: usize) -> Vec<f32> {
        let mut out = vec![0.0; n];
        for (&k, &x) in self.indices.iter().zip(&self.values) {
            out[k as usize] = x;
        }
        out
    }
}

/// Keeps `n` coefficients of `coeffs` by `selection` (`n` capped at the length).
#[must_use]
pub fn select(basis: Basis, coeffs: &[f32], n: usize, selection: Selection) -> SparseVec {
    let n = n.min(coeffs.len());
    let mut keep: Vec<u32> = match selection {
        Selection::Top => (0..n as u32).collect(),
        Selection::Adaptive => {
            let mut order: Vec<u32> = (0..coeffs.len() as u32).collect();
            let key = |k: u32| f64::from(coeffs[k as usize].abs()) * basis.norm2(k as usize);
            if n < order.len() {
                order.select_nth_unstable_by(n, |&a, &b| key(b).total_cmp(&key(a)));
            }
            order.truncate(n);
            order
        }
    };
    keep.sort_unstable();
    SparseVec {
        values: keep.iter().map(|&k| coeffs[k as usize]).collect(),
        indices: keep,
    }
}
