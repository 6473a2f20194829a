//! The bake file container shared by rotation matrices and BRDF slices.
//!
//! # Layout (little-endian, memory-mappable)
//! | bytes     | field                                                        |
//! |-----------|--------------------------------------------------------------|
//! | 0..8      | magic: `RLWVROT1` (rotation) or `RLWVBRD1` (BRDF)            |
//! | 8..12     | format version ([`FORMAT_VERSION`])                          |
//! | 12..16    | header size (64)                                             |
//! | 16..48    | eight u32 parameters (kind-specific, see each module)        |
//! | 48..56    | payload size in bytes                                        |
//! | 56..60    | CRC-32 (crc32fast) of bytes 16..56 and of the payload       |
//! | 60..64    | zero                                                         |
//! | 64..      | payload: sections, each padded to a multiple of 8 bytes      |
//!
//! Files are written to a temporary sibling and renamed into place, so a
//! reader never sees a half-written file; a truncated, foreign, stale
//! (other version) or corrupted file is rejected with [`WaveletError`].

use crate::error::{WaveletError, io};
use bytemuck::{Pod, Zeroable};
use std::path::Path;

/// Version of the bake formats; bump when any layout or bake rule changes.
pub const FORMAT_VERSION: u32 = 1;

/// The fixed 64-byte header.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct Header {
    /// File kind.
    pub magic: [u8; 8],
    /// [`FORMAT_VERSION`] of the writer.
    pub version: u32,
    /// `size_of::<Header>()`.
    pub header_bytes: u32,
    /// Kind-specific parameters.
    pub params: [u32; 8],
    /// Bytes after the header.
    pub payload_bytes: u64,
    /// CRC-32 of `params`, `payload_bytes` and the payload.
    pub crc32: u32,
    /// Zero.
    pub reserved: u32,
}

const HEADER_BYTES: usize = std::mem::size_of::<Header>();

fn pad8(len: usize) -> usize {
    len.div_ceil(8) * 8
}

/// Writes a bake file atomically (temporary file + rename).
pub fn write_file(
    path: &Path,
    magic: [u8; 8],
    params: [u32; 8],
    sections: &[&[u8]],
) -> Result<(), WaveletError> {
    let payload_bytes: usize = sections.iter().map(|s| pad8(s.len())).sum();
    let mut h = Header {
        magic,
        version: FORMAT_VERSION,
        header_bytes: HEADER_BYTES as u32,
        params,
        payload_bytes: payload_bytes as u64,
        crc32: 0,
        reserved: 0,
    };
    let zeros = [0u8; 8];
    let mut crc = crc32fast::Hasher::new();
    crc.update(bytemuck::bytes_of(&h.params));
    crc.update(&h.payload_bytes.to_le_bytes());
    for s in sections {
        crc.update(s);
        crc.update(&zeros[..pad8(s.len()) - s.len()]);
    }
    h.crc32 = crc.finalize();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
    }
    relight_assets::write_atomic_with(path, |w| {
        w.write_all(bytemuck::bytes_of(&h))?;
        for s in sections {
            w.write_all(s)?;
            w.write_all(&zeros[..pad8(s.len()) - s.len()])?;
        }
        Ok(())
    })
    .map_err(|e| match e {
        relight_assets::AssetError::Write { path, error } => WaveletError::Io { path, error },
        other => WaveletError::Io {
            path: path.to_path_buf(),
            error: std::io::Error::other(other.to_string()),
        },
    })?;
    Ok(())
}

/// A validated, memory-mapped bake file.
pub struct MappedFile {
    pub map: memmap2::Mmap,
    pub header: Header,
}

impl MappedFile {
    /// The payload bytes.
    pub fn payload(&self) -> &[u8] {
        &self.map[HEADER_BYTES..]
    }
}

/// Opens, maps and validates a bake file of kind `magic`.
pub fn read_file(
    path: &Path,
    magic: [u8; 8],
    kind: &'static str,
) -> Result<MappedFile, WaveletError> {
    let f = std::fs::File::open(path).map_err(io(path))?;
    // SAFETY: the file is opened read-only; relight replaces bake files only
    // by atomic rename, never by writing in place, so the mapping is stable.
    let map = unsafe { memmap2::Mmap::map(&f) }.map_err(io(path))?;
    let corrupt = |why: String| WaveletError::Corrupt {
        path: path.to_path_buf(),
        why,
    };
    if map.len() < 8 || map[..8] != magic {
        return Err(WaveletError::Foreign {
            path: path.to_path_buf(),
            kind,
        });
    }
    if map.len() < HEADER_BYTES {
        return Err(corrupt(format!(
            "{} bytes, shorter than the {HEADER_BYTES}-byte header",
            map.len()
        )));
    }
    let header: Header = bytemuck::pod_read_unaligned(&map[..HEADER_BYTES]);
    if header.version != FORMAT_VERSION {
        return Err(WaveletError::Version {
            path: path.to_path_buf(),
            found: header.version,
            expected: FORMAT_VERSION,
        });
    }
    let want = HEADER_BYTES as u64 + header.payload_bytes;
    if header.header_bytes as usize != HEADER_BYTES || map.len() as u64 != want {
        return Err(corrupt(format!("{} bytes, header says {want}", map.len())));
    }
    let mut crc = crc32fast::Hasher::new();
    crc.update(bytemuck::bytes_of(&header.params));
    crc.update(&header.payload_bytes.to_le_bytes());
    crc.update(&map[HEADER_BYTES..]);
    let got = crc.finalize();
    if got != header.crc32 {
        return Err(corrupt(format!(
            "checksum {got:08x}, header says {:08x}",
            header.crc32
        )));
    }
    Ok(MappedFile { map, header })
}

/// Splits a payload into sections of the given byte lengths (each padded to 8).
pub fn split_sections<'a>(payload: &'a [u8], lens: &[usize]) -> Option<Vec<&'a [u8]>> {
    let mut out = Vec::with_capacity(lens.len());
    let mut off = 0usize;
    for &l in lens {
        let end = off.checked_add(l)?;
        out.push(payload.get(off..end)?);
        off = off.checked_add(pad8(l))?;
    }
    (off == payload.len()).then_some(out)
}

/// Stable 64-bit FNV-1a hash (cache keys; not cryptographic).
#[must_use]
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}
