//! relight-wavelet: all-frequency environment-map rendering with Haar
//! wavelets on octahedral maps and precomputed wavelet rotation matrices
//! (Wang, Ng, Luebke, Humphreys, "Efficient Wavelet Rotation for Environment
//! Map Rendering", EGSR 2006 — "wavelet-rotation-2006").
//!
//! # Pipeline
//! ```text
//!  bake (once)                     lighting change                 view change
//!  ───────────                     ───────────────                 ───────────
//!  rotation matrices 𝐑_k  ──┐      L → octahedral n×n → Haar →     per vertex: BRDF slice 𝐅(ω_o)
//!  (rotation.rs)            ├──►   top-k 𝐋 → L̃_k = 𝐑_k 𝐋 for  ──►  · bilinear(L̃ of 4 normals)
//!  BRDF slices 𝐅(ω_o)  ─────┘      every sampled normal k           × AO → Gouraud raster
//!  (brdf_bake.rs)                  (lighting.rs, rotation.rs)       (render.rs)
//! ```
//! B(n, ω_o) = 𝐅_r(ω_o) · (𝐑_(n) 𝐋) (paper Eq. 7). The solid angle of every
//! target texel is folded into the BRDF slices, so the wavelet dot product is
//! a quadrature of the reflection integral (Eq. 1). Between sampled normals
//! the default blend is mirror-aligned ([`NormalInterp`]): each of the four
//! neighbours gets the slice whose mirror direction matches the vertex's, and
//! their colours are blended — the paper's single-slice blend of local
//! lighting ghosts sharp highlights ([`NormalInterp::Paper`] keeps it).
//!
//! # Entry points (what the CLI calls)
//! * The method interface: [`WaveletMethod`] (`wavelet`, defaults in
//!   [`WaveletOptions`]) — `prepare` bakes or loads the matrices and BRDF
//!   slices (and per-vertex AO), `set_lighting` is step 1 with the scene's
//!   `world_from_env`, `render` step 2 and the raster at the frame's `aa`.
//! * `relight bake rotation`: [`RotationParams::new`] → [`bake_rotation`] →
//!   [`RotationMatrices::save`]; [`RotationMatrices::load_expect`] memory-maps it back.
//! * `relight bake brdf`: [`BrdfBakeParams::new`] → [`bake_brdf`] → [`BrdfBake::save`].
//! * `relight render --method wavelet`: [`bake_or_load_rotation`] and
//!   [`bake_or_load_brdf`] (cache keyed by every parameter, [`default_cache_dir`]),
//!   [`WaveletRenderer::new`], [`WaveletRenderer::set_lighting`] with
//!   `relight_sphere::rotation_from_yaw_pitch_roll([yaw, pitch, roll])`, [`WaveletRenderer::render`].
//! * `relight verify wavelet`: [`verify_wavelet`] (image error vs the reference
//!   renderer) and [`verify_rotation`] (Figure 7); `relight bench wavelet`:
//!   [`bench_wavelet`].
//!
//! Modules: [`octa`] (maps, normal grid, frame rule), [`rotation`] (matrices,
//! bake, file), [`brdf_bake`] (BRDF slices, file), [`lighting`] (source
//! lighting), [`render`] (runtime), [`study`] (bake cache, bench rows), [`verify`] (image error
//! rows), [`figure7`] (rotated-lighting rows),
//! [`mod@format`] (bake container).

pub mod brdf_bake;
pub mod error;
pub mod figure7;
pub mod format;
pub mod lighting;
pub mod memo;
pub mod method;
pub mod octa;
pub mod render;
pub mod rotation;
pub mod study;
pub mod verify;

pub use brdf_bake::{BrdfBake, BrdfBakeParams, bake_brdf};
pub use error::WaveletError;
pub use figure7::{RotationRow, verify_rotation};
pub use method::{AO_APPROXIMATION, WAVELET_METHOD_NAME, WaveletMethod, WaveletOptions};
pub use render::{LightingStats, NormalInterp, VertexColors, WaveletRenderer};
pub use rotation::{RotationMatrices, RotationParams, bake_rotation};
pub use study::{
    BenchOptions, BenchRow, CacheUse, bake_or_load_brdf, bake_or_load_rotation,
    bake_or_load_scene_brdfs, bench_wavelet, default_cache_dir,
};
pub use verify::{
    CompareRow, Densify, VerifyOptions, VerifyRow, verify_wavelet, verify_wavelet_with_sh,
};
