//! Which vector instruction set the run-time-selected kernels may use.
//!
//! Every crate with a kernel compiled for more than the baseline target (the
//! SH rotations and products, the rasterizer's strips, the fog, triple,
//! near-field, NDF and SH-exponentiation kernels, the lat-long lookups)
//! picks its path here, from what the CPU offers: AVX-512F, AVX2 + FMA, or
//! the portable baseline code. [`set_isa_limit`] caps that choice for the
//! whole process, so that a bench can time (`relight bench … --isa`), and
//! a test can exercise, the paths a CPU without AVX-512 or AVX2 would take,
//! on a machine that has them. Every path computes the same results within
//! its kernel's tested tolerance; only speed changes.
//!
//! [`pages`] holds the other machine-level choice those kernels share: the
//! page size of the large tables they stream through.
//!
//! Invariant: a level is reported only where the CPU has every feature the
//! kernels of that level are compiled with, so `avx2()` (or `avx512()`)
//! being true is what makes calling such a kernel sound.

pub mod pages;

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// An instruction-set level of the run-time-selected kernels, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// The baseline target (SSE2 on x86-64), no run-time-selected kernels.
    Portable,
    /// AVX2 with FMA and F16C (every CPU with AVX2 so far has F16C; the
    /// triple-product kernels convert half floats with it).
    Avx2,
    /// AVX-512F with AVX-512VL, AVX2 and FMA (`relight_sh`'s
    /// register-resident rotation kernels of `rotation` and `taylor`, the
    /// vector bands of `fast`'s rotation from order 4, and `relight_shexp`'s
    /// lane kernels).
    Avx512,
}

impl Isa {
    /// Every level, lowest first.
    pub const ALL: [Self; 3] = [Self::Portable, Self::Avx2, Self::Avx512];

    /// The name used on the command line and in reports.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Portable => "portable",
            Self::Avx2 => "avx2",
            Self::Avx512 => "avx512",
        }
    }

    /// The level named `s` ([`name`](Self::name)).
    #[must_use]
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == s)
    }
}

/// The highest level this CPU supports (std caches the feature checks).
#[must_use]
pub fn detected_isa() -> Isa {
    static DETECTED: OnceLock<Isa> = OnceLock::new();
    *DETECTED.get_or_init(detect)
}

fn detect() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 = std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
            && std::arch::is_x86_feature_detected!("f16c");
        // The AVX-512 copies are compiled with VL, AVX2 and FMA as well
        // (256-bit masked operations, FMA scalars): a CPU with AVX-512F alone
        // (Knights Landing lacks VL) runs the AVX2 copies.
        if avx2
            && std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
        {
            return Isa::Avx512;
        }
        if avx2 {
            return Isa::Avx2;
        }
    }
    Isa::Portable
}

/// The cap set by [`set_isa_limit`] (an `Isa` as `u8`).
static LIMIT: AtomicU8 = AtomicU8::new(Isa::Avx512 as u8);
/// The level in use, `min(detected, cap)`, or [`UNSET`] before the first
/// call: one relaxed load per kernel call (the single-call kernels test it
/// every time).
static EFFECTIVE: AtomicU8 = AtomicU8::new(UNSET);
const UNSET: u8 = u8::MAX;

fn from_u8(v: u8) -> Isa {
    match v {
        0 => Isa::Portable,
        1 => Isa::Avx2,
        _ => Isa::Avx512,
    }
}

/// Caps the level the kernels use from now on, process-wide (default: no
/// cap). A cap above what the CPU has changes nothing.
pub fn set_isa_limit(limit: Isa) {
    LIMIT.store(limit as u8, Ordering::Relaxed);
    EFFECTIVE.store(limit.min(detected_isa()) as u8, Ordering::Relaxed);
}

/// The level the kernels use now: the lower of [`detected_isa`] and the cap.
#[inline]
#[must_use]
pub fn isa() -> Isa {
    match EFFECTIVE.load(Ordering::Relaxed) {
        UNSET => first_isa(),
        v => from_u8(v),
    }
}

#[cold]
#[inline(never)]
fn first_isa() -> Isa {
    let v = from_u8(LIMIT.load(Ordering::Relaxed)).min(detected_isa());
    EFFECTIVE.store(v as u8, Ordering::Relaxed);
    v
}

/// Whether the AVX2 + FMA (+ F16C) kernels may run: the CPU has them and
/// the cap allows them. One relaxed load.
#[inline]
#[must_use]
pub fn avx2() -> bool {
    isa() >= Isa::Avx2
}

/// Whether the AVX-512 (F + VL, with AVX2 and FMA) kernels may run.
#[inline]
#[must_use]
pub fn avx512() -> bool {
    isa() >= Isa::Avx512
}

#[cfg(test)]
mod tests {
    use super::{Isa, avx2, avx512, detected_isa, isa, set_isa_limit};

    /// The cap lowers the level and lifting it restores the detected one;
    /// the flags follow (this test binary is the only user of the cap).
    #[test]
    fn the_cap_lowers_the_level_and_lifts_again() {
        let detected = detected_isa();
        assert_eq!(isa(), detected);
        set_isa_limit(Isa::Portable);
        assert_eq!(isa(), Isa::Portable);
        assert!(!avx2() && !avx512());
        set_isa_limit(Isa::Avx2);
        assert_eq!(isa(), detected.min(Isa::Avx2));
        assert_eq!(avx2(), detected >= Isa::Avx2);
        assert!(!avx512());
        set_isa_limit(Isa::Avx512);
        assert_eq!(isa(), detected);
        assert_eq!(avx512(), detected == Isa::Avx512);
        for level in Isa::ALL {
            assert_eq!(Isa::from_name(level.name()), Some(level));
        }
    }

    /// CI runs on x86-64 machines with AVX2: there the vector paths are
    /// the ones the suite exercises.
    #[test]
    fn ci_machines_have_avx2() {
        if std::env::var_os("CI").is_some() && cfg!(target_arch = "x86_64") {
            assert!(detected_isa() >= Isa::Avx2, "detected {:?}", detected_isa());
        }
    }
}
