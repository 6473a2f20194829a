//! The per-vertex transport bake (`T` of eq. 4.36, thesis §4.5.1 and
//! §4.5.5: "precomputed" per vertex) on disk: versioned, checksummed,
//! written atomically, keyed by everything the bake depends on.
//!
//! The container is the wavelet method's (`relight_wavelet::format`: a
//! 64-byte header with magic, format version, eight u32 parameters and a
//! CRC-32 over parameters and payload, written to a temporary sibling and
//! renamed into place), magic [`MAGIC`], f32 values: every object's
//! transport in scene order, `V_i · n²` values each (the standard-basis
//! layout of [`Transport::values`]).
//!
//! | parameter | meaning |
//! |---|---|
//! | 0 | order `n` |
//! | 1 | face side × 1000 (display only; the key hashes its exact bits) |
//! | 2 | objects |
//! | 3 | shadows (scene visibility) 0/1 |
//! | 4, 5 | key hash, low and high 32 bits |
//! | 6 | vertices over all objects |
//! | 7 | [`BAKE_VERSION`] |
//!
//! The key hash (FNV-1a 64) covers [`BAKE_VERSION`], `n`, the face's bits,
//! visibility, the light's axes and centre (the bake's plane and face
//! directions; [`LightFrame`]) and every object's positions and normals —
//! and, with shadows, every object's triangles (the occluders). The file
//! name carries the parameters and a hash of all eight
//! ([`BakeKey::file_name`]), so another configuration is another file. A
//! file that is truncated, foreign, of another version, fails its
//! checksum or does not match the key is a [`CacheError`], never a panic;
//! the method re-bakes it with a warning.

use crate::face::LightFrame;
use crate::transport::Transport;
use relight_render::Scene;
use relight_wavelet::WaveletError;
use relight_wavelet::format::{fnv1a64, read_file, write_file};
use std::path::{Path, PathBuf};

/// Version of the bake rules (parameter 7); bump when the transport bake
/// changes meaning.
pub const BAKE_VERSION: u32 = 1;

/// Magic of a nearfield transport bake.
pub const MAGIC: [u8; 8] = *b"RLNFTRN1";

/// Kind name in messages (`relight bake nearfield`).
pub const KIND: &str = "nearfield";

/// Why a bake file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// Unreadable, foreign, another format version, truncated or a bad checksum.
    #[error(transparent)]
    File(#[from] WaveletError),
    /// A valid file of another bake (parameters or sizes differ).
    #[error("{}: {why}", path.display())]
    Mismatch { path: PathBuf, why: String },
}

/// Default folder: the wavelet method's cache root with `nearfield` in
/// place of `wavelet` (`$RELIGHT_CACHE/nearfield`,
/// `$XDG_CACHE_HOME/relight/nearfield`, `~/.cache/relight/nearfield`).
#[must_use]
pub fn default_cache_dir() -> PathBuf {
    relight_wavelet::default_cache_dir().with_file_name("nearfield")
}

/// 64-bit FNV-1a fed in pieces.
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        for x in b {
            self.0 ^= u64::from(*x);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn floats(&mut self, f: impl IntoIterator<Item = f32>) {
        for x in f {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
}

/// What identifies a transport bake (module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BakeKey {
    /// The header's eight parameters.
    pub params: [u32; 8],
    /// Vertices per object.
    pub vertices: Vec<usize>,
}

impl BakeKey {
    /// The key of `scene`'s bake for a light with `frame`, at order `n`
    /// and face side `face`.
    #[must_use]
    pub fn of(scene: &Scene, frame: &LightFrame, n: usize, face: f64) -> Self {
        let mut h = Fnv(0xcbf2_9ce4_8422_2325);
        h.bytes(&BAKE_VERSION.to_le_bytes());
        h.bytes(&(n as u64).to_le_bytes());
        h.bytes(&face.to_bits().to_le_bytes());
        h.bytes(&[u8::from(scene.visibility)]);
        h.floats(frame.axes.to_cols_array());
        h.floats(frame.center.to_array());
        let mut vertices = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            let m = &o.mesh;
            vertices.push(m.positions.len());
            h.bytes(&(m.positions.len() as u64).to_le_bytes());
            h.floats(m.positions.iter().flat_map(|p| p.to_array()));
            h.floats(m.normals.iter().flat_map(|p| p.to_array()));
            if scene.visibility {
                h.bytes(&(m.indices.len() as u64).to_le_bytes());
                for t in &m.indices {
                    for i in t {
                        h.bytes(&i.to_le_bytes());
                    }
                }
            }
        }
        let key = h.0;
        let total: usize = vertices.iter().sum();
        Self {
            params: [
                n as u32,
                (face * 1000.0).round() as u32,
                scene.objects.len() as u32,
                u32::from(scene.visibility),
                key as u32,
                (key >> 32) as u32,
                total.min(u32::MAX as usize) as u32,
                BAKE_VERSION,
            ],
            vertices,
        }
    }

    /// Values in the file: `Σ V_i · n²`.
    #[must_use]
    pub fn values(&self) -> usize {
        let n = self.params[0] as usize;
        self.vertices.iter().sum::<usize>() * n * n
    }

    /// The cache file name: `nearfield-n{n}-f{face·1000}-o{objects}-s{0|1}-v{version}-{hash}.bin`.
    #[must_use]
    pub fn file_name(&self) -> String {
        let p = &self.params;
        let mut bytes = Vec::with_capacity(32);
        for x in p {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
        format!(
            "{KIND}-n{}-f{}-o{}-s{}-v{}-{:016x}.bin",
            p[0],
            p[1],
            p[2],
            p[3],
            p[7],
            fnv1a64(&bytes)
        )
    }
}

/// Writes `transports` (one per object, in scene order) for `key` to
/// `path`, atomically.
///
/// # Errors
/// [`CacheError::Mismatch`] when the transports do not have the key's
/// sizes; [`CacheError::File`] when the file cannot be written.
pub fn save(path: &Path, key: &BakeKey, transports: &[&Transport]) -> Result<(), CacheError> {
    let n = key.params[0] as usize;
    let sizes_ok = transports.len() == key.vertices.len()
        && transports
            .iter()
            .zip(&key.vertices)
            .all(|(t, &v)| t.n == n && t.values.len() == v * n * n);
    if !sizes_ok {
        return Err(CacheError::Mismatch {
            path: path.to_path_buf(),
            why: "the transports do not have the sizes of the key".into(),
        });
    }
    let sections: Vec<&[u8]> = transports
        .iter()
        .map(|t| bytemuck::cast_slice::<f32, u8>(&t.values))
        .collect();
    // One section per object: `V n² · 4` bytes with n ≥ 4 is a multiple of
    // 8, so the container adds no padding and the payload is every
    // object's values back to back.
    write_file(path, MAGIC, key.params, &sections)?;
    Ok(())
}

/// Reads the transports of `key` from `path` (`face`: the face side the
/// key was made with).
///
/// # Errors
/// [`CacheError::File`] for an unreadable, foreign, other-version,
/// truncated or corrupted file; [`CacheError::Mismatch`] for a valid file
/// of another bake.
pub fn load(path: &Path, key: &BakeKey, face: f64) -> Result<Vec<Transport>, CacheError> {
    let f = read_file(path, MAGIC, KIND)?;
    let mismatch = |why: String| CacheError::Mismatch {
        path: path.to_path_buf(),
        why,
    };
    if f.header.params != key.params {
        return Err(mismatch(format!(
            "bake parameters {:?}, expected {:?}",
            f.header.params, key.params
        )));
    }
    let bytes = key.values() * 4;
    let payload = f.payload();
    if payload.len() != bytes.div_ceil(8) * 8 {
        return Err(mismatch(format!(
            "{} payload bytes, the key needs {bytes}",
            payload.len()
        )));
    }
    let n = key.params[0] as usize;
    let mut out = Vec::with_capacity(key.vertices.len());
    let mut at = 0;
    for &v in &key.vertices {
        let len = v * n * n * 4;
        let values: Vec<f32> = bytemuck::pod_collect_to_vec(&payload[at..at + len]);
        at += len;
        out.push(Transport { n, face, values });
    }
    Ok(out)
}
