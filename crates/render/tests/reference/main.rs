//! The reference renderer checked a second way: furnaces, closed forms,
//! quadrature of the airlight integral, energy conservation, determinism and
//! the method interface. Small images and low sample counts; tolerances come
//! from the renderer's own reported noise.

// Pixel loops index several parallel images by the same pixel number.
#![allow(clippy::needless_range_loop)]

mod basic;
mod common;
mod gi;
mod lights;
mod medium;
mod wavelet;
