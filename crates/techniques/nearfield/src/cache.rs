//! The per-vertex transport bake (`T` of eq. 4.36, thesis §4.5.1 and
//! §4.5.5: "precomputed" per vertex) on disk: versioned, checksummed,
//! written atomically, keyed by everything the bake depends on.
//!
//! The container is the wavelet method's (`relight_wavelet::format`: a
//! 64-byte header with magic, format version, eight u32 parameters and a
//! CRC-32 over parameters and payload, written to a temporary sibling and
//! renamed into place), magic [`MAGIC`], f32 values: every object's
//! transport in scene order, `V_i · c_i · n²` values each (the
//! standard-basis layout of [`Transport::values`]; `c_i` = 1, or 3 for an
//! RGB fixed-view transport, [`crate::specular`]).
//!
//! | parameter | meaning |
//! |---|---|
//! | 0 | order `n` |
//! | 1 | face side × 1000 (display only; the key hashes its exact bits) |
//! | 2 | objects |
//! | 3 | shadows (scene visibility) 0/1 |
//! | 4, 5 | key hash, low and high 32 bits |
//! | 6 | vertices over all objects |
//! | 7 | [`BAKE_VERSION`], or [`DIFFUSE_BAKE_VERSION`] for a scene of Lambertian objects only |
//!
//! The key hash (FNV-1a 64) covers the version, `n`, the face's bits,
//! visibility, the light's axes and centre (the bake's plane and face
//! directions; [`LightFrame`]) and every object's positions and normals —
//! and, with shadows, every object's triangles (the occluders). A scene
//! with a fixed-view (specular) object ([`crate::specular::ObjectKind`])
//! is version [`BAKE_VERSION`] and its hash goes on to cover, per object,
//! how it is shaded (Lambertian, or fixed-view with its channel count and
//! tint), and per fixed-view object its BRDFs (their [`relight_brdf::Brdf::label`] and their
//! values at [`crate::specular::probe_pairs`]), its blend weight per
//! vertex and its tangents; and the camera's eye (the fixed view). A
//! scene of Lambertian objects only keeps [`DIFFUSE_BAKE_VERSION`] and
//! exactly the key, name and bytes it had before fixed-view transport
//! existed: its bake did not change meaning, and older cache files stay
//! valid (`tests/it/specular.rs::diffuse_bake_files_are_unchanged`). The file
//! name carries the parameters and a hash of all eight
//! ([`BakeKey::file_name`]), so another configuration is another file. A
//! file that is truncated, foreign, of another version, fails its
//! checksum or does not match the key is a [`CacheError`], never a panic;
//! the method re-bakes it with a warning.

use crate::face::LightFrame;
use crate::specular::{ObjectKind, probe};
use crate::transport::Transport;
use glam::Vec3;
use relight_isa::pages::vec_on_huge_pages;
use relight_render::Scene;
use relight_wavelet::WaveletError;
use relight_wavelet::format::{fnv1a64, read_file, write_file};
use std::path::{Path, PathBuf};

/// Version of the bake rules (parameter 7); bump when the transport bake
/// changes meaning. 2: fixed-view specular transport (the camera's eye and
/// the BRDFs in the key, RGB transports).
pub const BAKE_VERSION: u32 = 2;

/// Version of a bake of Lambertian objects only: the rules of version 1,
/// unchanged (module docs).
pub const DIFFUSE_BAKE_VERSION: u32 = 1;

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
    /// Transports per vertex, per object (1 or 3).
    pub channels: Vec<usize>,
}

impl BakeKey {
    /// The key of `scene`'s bake for a light with `frame`, at order `n`
    /// and face side `face`.
    #[must_use]
    pub fn of(scene: &Scene, frame: &LightFrame, n: usize, face: f64) -> Self {
        let kinds: Vec<ObjectKind> = scene
            .objects
            .iter()
            .map(crate::specular::object_kind)
            .collect();
        Self::of_kinds(scene, frame, n, face, &kinds)
    }

    /// [`Self::of`] with each object's [`ObjectKind`] already known.
    #[must_use]
    pub fn of_kinds(
        scene: &Scene,
        frame: &LightFrame,
        n: usize,
        face: f64,
        kinds: &[ObjectKind],
    ) -> Self {
        let specular = kinds.iter().any(ObjectKind::is_specular);
        let version = if specular {
            BAKE_VERSION
        } else {
            DIFFUSE_BAKE_VERSION
        };
        let mut h = Fnv(0xcbf2_9ce4_8422_2325);
        h.bytes(&version.to_le_bytes());
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
        if specular {
            h.floats(scene.camera.eye.to_array());
            for (o, k) in scene.objects.iter().zip(kinds) {
                match *k {
                    ObjectKind::Specular { tint } => {
                        h.bytes(&[2, k.channels() as u8]);
                        h.floats(tint.unwrap_or(Vec3::ZERO).to_array());
                        let mut brdf = |b: &dyn relight_brdf::Brdf| {
                            h.bytes(b.label().as_bytes());
                            h.floats(probe(b).iter().flat_map(|v| v.to_array()));
                        };
                        brdf(o.brdf.as_ref());
                        if let Some(bl) = &o.blend {
                            brdf(bl.second.as_ref());
                            h.floats(o.mesh.uvs.iter().map(|&uv| bl.weight_at(uv)));
                        }
                        h.floats(o.mesh.tangents.iter().flat_map(|t| t.to_array()));
                    }
                    _ => h.bytes(&[1]),
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
                version,
            ],
            vertices,
            channels: kinds.iter().map(ObjectKind::channels).collect(),
        }
    }

    /// Values in the file: `Σ V_i · c_i · n²`.
    #[must_use]
    pub fn values(&self) -> usize {
        let n = self.params[0] as usize;
        self.vertices
            .iter()
            .zip(&self.channels)
            .map(|(v, c)| v * c)
            .sum::<usize>()
            * n
            * n
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
            .zip(key.vertices.iter().zip(&key.channels))
            .all(|(t, (&v, &c))| t.n == n && t.channels == c && t.values.len() == v * c * n * n);
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
    // One section per object: `V c n² · 4` bytes with n ≥ 4 is a multiple of
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
    for (&v, &channels) in key.vertices.iter().zip(&key.channels) {
        let len = v * channels * n * n * 4;
        // On huge pages, as a bake's (`bake_transport`); the payload may
        // sit at any byte offset, so it is copied as bytes.
        let mut values = vec_on_huge_pages(len / 4, 0.0f32);
        bytemuck::cast_slice_mut::<f32, u8>(&mut values).copy_from_slice(&payload[at..at + len]);
        at += len;
        out.push(Transport {
            n,
            face,
            channels,
            values,
        });
    }
    Ok(out)
}
