//! Dyadic 1D Haar atoms on \[0, 1\]: scaled boxes φ_{l,t} and wavelets ψ_{l,t}.
//!
//! The normalized Haar basis of the thesis (§4.4.2, after eq. 4.19):
//! `φ(v) = 1` on `[0, 1)`; `ψ(v) = 1` on `[0, ½)`, `−1` on `[½, 1)`;
//! `ψ_{l,t}(v) = 2^{l/2} ψ(2^l v − t)` and likewise `φ_{l,t}`. A 1D basis of
//! order `N = 2^L` is `{φ_{0,0}} ∪ {ψ_{l,t} : 0 ≤ l < L, 0 ≤ t < 2^l}`,
//! indexed `0` for φ and `2^l + t` for ψ_{l,t} (so index order is level
//! order, as Property 2's `min(j, k)` assumes). Boxes at finer levels are
//! not members of the 1D basis but are needed for two things: the
//! nonstandard 2D basis of `relight-haar` is built from products
//! `ψ_{l,·} × φ_{l,·}` (see [`crate::separable`]), and the product of a
//! wavelet with itself is a box, `ψ_{l,t}² = 2^{l/2} φ_{l,t}` (the case
//! `j = k` of Property 2).

/// The mother function of an atom.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum Kind {
    /// The scaling function φ (box).
    Box,
    /// The Haar wavelet ψ (+1 on the first half, −1 on the second).
    Wave,
}

impl Kind {
    /// The mother function at `x` (right-continuous: half-open pieces).
    #[must_use]
    pub fn mother(self, x: f64) -> f64 {
        if !(0.0..1.0).contains(&x) {
            return 0.0;
        }
        match self {
            Self::Box => 1.0,
            Self::Wave if x < 0.5 => 1.0,
            Self::Wave => -1.0,
        }
    }

    /// The mother function with the mean of its one-sided limits at the
    /// jumps (0, ½, 1): the value the derivatives of `M` need there.
    #[must_use]
    pub fn mother_mean(self, x: f64) -> f64 {
        match (self, x) {
            (_, 0.0) => 0.5,
            (Self::Box, 1.0) => 0.5,
            (Self::Wave, 0.5) => 0.0,
            (Self::Wave, 1.0) => -0.5,
            _ => self.mother(x),
        }
    }

    /// The primitive `B(x) = ∫_{−∞}^x mother`: `clamp(x, 0, 1)` for φ and
    /// the tent `max(0, ½ − |x − ½|)` for ψ. Every coupling coefficient is a
    /// signed sum of these at the transformed atom's break points
    /// ([`crate::canonical::canonical`]).
    #[must_use]
    pub fn primitive(self, x: f64) -> f64 {
        match self {
            Self::Box => x.clamp(0.0, 1.0),
            Self::Wave => (0.5 - (x - 0.5).abs()).max(0.0),
        }
    }

    /// The constant pieces `(start, end, sign)` of the mother function.
    #[must_use]
    pub fn pieces(self) -> &'static [(f64, f64, f64)] {
        match self {
            Self::Box => &[(0.0, 1.0, 1.0)],
            Self::Wave => &[(0.0, 0.5, 1.0), (0.5, 1.0, -1.0)],
        }
    }
}

/// One dyadic atom `2^{l/2} mother(2^l v − t)`, support `[t 2^{−l}, (t+1) 2^{−l})`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct Atom {
    /// φ or ψ.
    pub kind: Kind,
    /// Level `l ≥ 0` (0 = support the whole unit interval).
    pub level: u32,
    /// Offset `t` in supports, `< 2^l`.
    pub offset: u32,
}

impl Atom {
    /// The box φ_{l,t}.
    #[must_use]
    pub fn new_box(level: u32, offset: u32) -> Self {
        Self {
            kind: Kind::Box,
            level,
            offset,
        }
    }

    /// The wavelet ψ_{l,t}.
    #[must_use]
    pub fn wave(level: u32, offset: u32) -> Self {
        Self {
            kind: Kind::Wave,
            level,
            offset,
        }
    }

    /// The 1D basis function of `index` (0 → φ_{0,0}; `2^l + t` → ψ_{l,t}).
    #[must_use]
    pub fn from_index(index: usize) -> Self {
        if index == 0 {
            return Self::new_box(0, 0);
        }
        let level = usize::BITS - 1 - index.leading_zeros();
        Self::wave(level, (index - (1usize << level)) as u32)
    }

    /// Index in the 1D basis, `None` for a box finer than level 0 (not a
    /// basis member).
    #[must_use]
    pub fn index(&self) -> Option<usize> {
        match self.kind {
            Kind::Box if self.level == 0 => Some(0),
            Kind::Box => None,
            Kind::Wave => Some((1usize << self.level) + self.offset as usize),
        }
    }

    /// `2^l` as a float.
    #[must_use]
    pub fn scale(&self) -> f64 {
        f64::from(self.level).exp2()
    }

    /// Support `[start, end)` in v.
    #[must_use]
    pub fn support(&self) -> (f64, f64) {
        let w = 1.0 / self.scale();
        (f64::from(self.offset) * w, f64::from(self.offset + 1) * w)
    }

    /// Value at `v` (L²-normalized: ∫ atom² = 1).
    #[must_use]
    pub fn eval(&self, v: f64) -> f64 {
        let k = self.scale();
        k.sqrt() * self.kind.mother(k * v - f64::from(self.offset))
    }

    /// The product of two atoms as `coefficient × atom` (the "product of two
    /// Haar wavelets is the finer one up to a scale" of §4.4.2), `None` when
    /// their supports do not overlap. For a coarser `p` and a finer `q`:
    /// `p q = σ 2^{l_p/2} q` with σ the sign of `p` on `q`'s support
    /// (+1 for a box; for a wavelet +1 when `q` lies in its first half).
    /// At equal level and offset: `φφ = 2^{l/2} φ`, `φψ = ψφ = 2^{l/2} ψ`,
    /// `ψψ = 2^{l/2} φ_{l,t}` (a box, not a wavelet).
    #[must_use]
    pub fn product(self, other: Atom) -> Option<(f64, Atom)> {
        let (p, q) = if self.level <= other.level {
            (self, other)
        } else {
            (other, self)
        };
        let shift = q.level - p.level;
        if q.offset >> shift != p.offset {
            return None;
        }
        let amp = p.scale().sqrt();
        if shift == 0 {
            let kind = if p.kind == q.kind {
                Kind::Box
            } else {
                Kind::Wave
            };
            return Some((
                amp,
                Atom {
                    kind,
                    level: p.level,
                    offset: p.offset,
                },
            ));
        }
        let sigma = match p.kind {
            Kind::Box => 1.0,
            Kind::Wave if (q.offset >> (shift - 1)) & 1 == 0 => 1.0,
            Kind::Wave => -1.0,
        };
        Some((sigma * amp, q))
    }
}

/// `log2 n` for a power of two `n ≥ 1`, `None` otherwise.
#[must_use]
pub fn log2_order(n: usize) -> Option<u32> {
    (n >= 1 && n.is_power_of_two()).then(|| n.trailing_zeros())
}
