//! Rows of per-lane constants for the vector kernels ([`crate::simd_bands`],
//! [`crate::simd_eval`], [`crate::simd_product`]): one register's worth of
//! values, aligned so that a kernel loads a row with one aligned load.

#![cfg(target_arch = "x86_64")]

/// Sixteen lanes (one 512-bit register), 64-byte aligned.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Row16<T>(pub(crate) [T; 16]);

/// Eight lanes (one 256-bit register), 32-byte aligned.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Row8<T>(pub(crate) [T; 8]);

/// Sixteen f32 lanes.
pub(crate) type F16 = Row16<f32>;
/// Sixteen i32 lanes (permute indices).
pub(crate) type I16 = Row16<i32>;
