//! Shared test helpers: a seeded RNG and uniform sphere sampling.
#![allow(dead_code)]

use glam::{DVec2, DVec3};

/// SplitMix64: tiny, seeded, good enough for tests.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    pub fn uv(&mut self) -> DVec2 {
        DVec2::new(self.f64(), self.f64())
    }
    /// Uniform direction on the unit sphere.
    pub fn sphere(&mut self) -> DVec3 {
        let z = 1.0 - 2.0 * self.f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * self.f64();
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}
