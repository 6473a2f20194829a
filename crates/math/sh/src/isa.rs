//! Which vector instruction set the SH kernels may use.
//!
//! The kernels pick their path at run time from what the CPU offers
//! (AVX-512F, AVX2 + FMA, or the portable baseline code). [`set_isa_limit`]
//! caps that choice for the whole process, so that a bench can time — and a
//! test can exercise — the paths a CPU without AVX-512 would take, on a
//! machine that has it. Every path computes the same products (tested
//! against each other); only speed changes.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// An instruction-set level of the SH kernels, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// The baseline target (SSE2 on x86-64), no run-time-selected kernels.
    Portable,
    /// AVX2 with FMA.
    Avx2,
    /// AVX-512F with AVX-512VL, AVX2 and FMA (the register-resident rotation
    /// kernels of [`crate::rotation`] and [`crate::taylor`], and the vector
    /// bands of [`crate::fast`]'s rotation from order 4).
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
            && std::arch::is_x86_feature_detected!("fma");
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
