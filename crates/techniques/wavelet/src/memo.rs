//! Memo of the view-change step's dot products (wavelet-rotation-2006 §3
//! "Environment Map Rendering", Eq. 7).
//!
//! A vertex colour is a blend of at most four dot products `𝐅_s · L̃_c` of a
//! baked BRDF slice `s` with the local lighting of a sampled normal `c`
//! ([`crate::render`]). Each product depends on the lighting and on the pair
//! `(s, c)` only — not on the vertex, nor on the eye — and neighbouring
//! vertices pick the same pairs. [`DotMemo`] keeps the products computed
//! since the last lighting change, so a frame computes each distinct pair
//! once and a view change only pairs not seen before: on the default scene
//! at 960×540 an orbit step computes ≈ 35 K products for ≈ 40 K shaded
//! (glossy) vertices, against 4 per vertex without the memo.
//!
//! The table is direct-mapped and lossy: a slot holds the last pair hashed
//! to it, and a pair that is not found is simply computed again. A hit
//! returns the bits the computation produced, so shading with the memo gives
//! the same colours as without it.
//!
//! Slots are shared by the threads of a frame without locks: each colour
//! channel is one 64-bit atomic word holding the pair's tag (high 32 bits)
//! next to the channel's f32 bits (low 32), and a slot is a hit only when all
//! three words carry the pair's tag. Two threads writing one slot at once can
//! leave words of different pairs in it, which then reads as a miss; a word
//! with the right tag always holds that pair's value (every writer of a pair
//! writes the same bits).

use glam::Vec3A;
use std::sync::atomic::{AtomicU64, Ordering};

/// One slot: an RGB value with its pair's tag in every word.
#[derive(Debug, Default)]
#[repr(align(32))]
struct Slot([AtomicU64; 3]);

/// Slots of a table: 2^17 (4 MiB), several times the distinct pairs of a
/// default-scene frame (≈ 20–40 K) so that collisions stay rare.
pub const MEMO_SLOTS_LOG2: u32 = 17;

/// Dot products `𝐅_s · L̃_c` by pair key (see the module docs). The owner
/// decides what a key means and calls [`DotMemo::reset`] whenever the
/// lighting or the meaning of the keys changes.
#[derive(Debug)]
pub struct DotMemo {
    slots: Vec<Slot>,
    shift: u32,
}

impl Default for DotMemo {
    fn default() -> Self {
        Self::with_slots_log2(MEMO_SLOTS_LOG2)
    }
}

impl DotMemo {
    /// An empty table of `2^log2` slots (`1 ≤ log2 ≤ 28`).
    #[must_use]
    pub fn with_slots_log2(log2: u32) -> Self {
        let log2 = log2.clamp(1, 28);
        Self {
            slots: (0..1usize << log2).map(|_| Slot::default()).collect(),
            shift: 32 - log2,
        }
    }

    /// Forgets every value.
    pub fn reset(&mut self) {
        for s in &mut self.slots {
            for w in &mut s.0 {
                *w.get_mut() = 0;
            }
        }
    }

    /// Largest key the table accepts (the tag `key + 1` fits in 32 bits and
    /// is never 0, the empty slot).
    pub const MAX_KEY: u32 = u32::MAX - 1;

    #[inline]
    fn slot(&self, key: u32) -> &Slot {
        // Fibonacci hashing: the structured keys (s · normals + c) spread.
        let h = key.wrapping_mul(0x9E37_79B9) >> self.shift;
        &self.slots[h as usize]
    }

    /// The value of `key`, from the table or from `compute` (then stored).
    /// Returns whether `compute` ran. `key ≤` [`DotMemo::MAX_KEY`].
    #[inline]
    pub fn get_or(&self, key: u32, compute: impl FnOnce() -> Vec3A) -> (Vec3A, bool) {
        debug_assert!(key <= Self::MAX_KEY);
        let tag = u64::from(key + 1) << 32;
        let s = self.slot(key);
        let w = [
            s.0[0].load(Ordering::Relaxed),
            s.0[1].load(Ordering::Relaxed),
            s.0[2].load(Ordering::Relaxed),
        ];
        const HI: u64 = 0xFFFF_FFFF_0000_0000;
        if w.iter().all(|&x| x & HI == tag) {
            let c = |x: u64| f32::from_bits(x as u32);
            return (Vec3A::new(c(w[0]), c(w[1]), c(w[2])), false);
        }
        let v = compute();
        for (word, x) in s.0.iter().zip([v.x, v.y, v.z]) {
            word.store(tag | u64::from(x.to_bits()), Ordering::Relaxed);
        }
        (v, true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn returns_stored_bits_and_recomputes_after_reset_or_collision() {
        let mut m = DotMemo::with_slots_log2(4);
        let v = Vec3A::new(1.0, -0.0, f32::MIN_POSITIVE);
        assert_eq!(m.get_or(7, || v), (v, true));
        let (got, computed) = m.get_or(7, || Vec3A::ZERO);
        assert!(!computed);
        assert_eq!(
            got.to_array().map(f32::to_bits),
            v.to_array().map(f32::to_bits)
        );
        // 16 slots: among 17 other keys at least one shares key 7's slot and
        // evicts it; key 7 is then computed again, never confused.
        for k in 100..117 {
            m.get_or(k, || Vec3A::splat(k as f32));
        }
        for k in 100..117 {
            let (got, computed) = m.get_or(k, || Vec3A::splat(k as f32));
            assert_eq!(got, Vec3A::splat(k as f32), "computed: {computed}");
        }
        m.reset();
        assert!(m.get_or(7, || v).1);
        assert!(m.get_or(DotMemo::MAX_KEY, || v).1);
        assert!(!m.get_or(DotMemo::MAX_KEY, || Vec3A::ZERO).1);
    }

    #[test]
    fn torn_slots_read_as_misses() {
        let m = DotMemo::with_slots_log2(1);
        m.get_or(3, || Vec3A::splat(3.0));
        // Half-overwrite key 3's slot as a racing writer of another key would.
        let s = m.slot(3);
        s.0[1].store(
            (u64::from(9u32 + 1) << 32) | u64::from(9.0f32.to_bits()),
            Ordering::Relaxed,
        );
        let (v, computed) = m.get_or(3, || Vec3A::splat(3.5));
        assert!(computed);
        assert_eq!(v, Vec3A::splat(3.5));
    }
}
