//! Baked tables on disk: versioned, checksummed, atomic, keyed by every
//! parameter — the wavelet method's container (`relight_wavelet::format`:
//! 64-byte header with magic, version, eight u32 parameters and a CRC-32,
//! written by temp file + rename) with one f32 section.
//!
//! | kind | magic | parameters |
//! |---|---|---|
//! | BRDF table | `RLTRBRD1` | m, views, weighting, quadrature sub, key hash lo/hi, values, [`BAKE_VERSION`] |
//! | vertex visibility | `RLTRVIS1` | m, vis level, 0, 0, key hash lo/hi, values, [`BAKE_VERSION`] |
//!
//! The key hash (FNV-1a 64) is over the BRDF's `Debug` description, or over
//! every mesh of the scene (positions, normals, indices) and the object
//! index for visibility. A file with other parameters, another version or a
//! bad checksum is re-baked and replaced, with a warning
//! ([`relight_wavelet::CacheUse`]).

use relight_wavelet::format::{fnv1a64, read_file, write_file};
use relight_wavelet::{CacheUse, WaveletError};
use std::path::{Path, PathBuf};

/// Version of this crate's bake rules (the 8th parameter); bump when a bake
/// changes meaning.
pub const BAKE_VERSION: u32 = 3;

/// Magic of a BRDF table.
pub const BRDF_MAGIC: [u8; 8] = *b"RLTRBRD1";
/// Magic of a per-vertex visibility bake.
pub const VIS_MAGIC: [u8; 8] = *b"RLTRVIS1";

/// Default cache: the wavelet method's cache root with `triple` in place of
/// `wavelet` (`$RELIGHT_CACHE/triple`, `$XDG_CACHE_HOME/relight/triple`, …).
#[must_use]
pub fn default_cache_dir() -> PathBuf {
    relight_wavelet::default_cache_dir().with_file_name("triple")
}

/// The 8 header parameters of a bake.
#[must_use]
pub fn params(a: u32, b: u32, c: u32, d: u32, key: u64, len: usize) -> [u32; 8] {
    [
        a,
        b,
        c,
        d,
        key as u32,
        (key >> 32) as u32,
        len as u32,
        BAKE_VERSION,
    ]
}

/// The cache file of a bake.
#[must_use]
pub fn file_name(kind: &str, p: &[u32; 8]) -> String {
    let h = fnv1a64(bytemuck::bytes_of(p));
    format!("{kind}-m{}-{}-{h:016x}.bin", p[0], p[1])
}

/// Loads the f32 values of a bake with exactly `p`, or computes, stores and
/// returns them. A bad or stale file is replaced, and the [`CacheUse`] says
/// why.
///
/// # Errors
/// Cancellation from `compute`, or an unwritable cache.
pub fn bake_or_load<E>(
    dir: &Path,
    kind: &'static str,
    magic: [u8; 8],
    p: [u32; 8],
    compute: impl FnOnce() -> Result<Vec<f32>, E>,
) -> Result<(Vec<f32>, CacheUse), E>
where
    E: From<WaveletError>,
{
    let path = dir.join(file_name(kind, &p));
    let mut used = CacheUse::Baked;
    if path.exists() {
        let payload = (p[6] as usize * 4).div_ceil(8) * 8;
        match read_file(&path, magic, kind) {
            Ok(f) if f.header.params == p && f.header.payload_bytes as usize == payload => {
                let bytes = &f.payload()[..p[6] as usize * 4];
                return Ok((bytemuck::pod_collect_to_vec(bytes), CacheUse::Loaded));
            }
            // The name hashes the parameters: only a collision or a file
            // written by hand gets here.
            Ok(_) => {
                used = CacheUse::Replaced {
                    path: path.clone(),
                    why: "its header's parameters or size are not the ones its name stands for"
                        .into(),
                }
            }
            Err(e) => used = CacheUse::replaced(&path, &e),
        }
    }
    let values = compute()?;
    debug_assert_eq!(values.len(), p[6] as usize);
    write_file(&path, magic, p, &[bytemuck::cast_slice(&values)])?;
    Ok((values, used))
}

/// FNV-1a over several byte slices.
#[must_use]
pub fn hash_parts(parts: &[&[u8]]) -> u64 {
    let mut all = Vec::new();
    for p in parts {
        all.extend_from_slice(&(p.len() as u64).to_le_bytes());
        all.extend_from_slice(&fnv1a64(p).to_le_bytes());
    }
    fnv1a64(&all)
}
