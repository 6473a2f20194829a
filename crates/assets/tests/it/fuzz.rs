//! Fuzz-style robustness: truncated and byte-flipped copies of every real
//! file in `../shared/data` go through every loader; each call must return
//! `Ok` or `Err`, never panic. Cut points and flips are sampled (seeded) to
//! keep the suite fast.

use crate::common;

use relight_assets::*;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

/// Small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Every loader that accepts this kind of file, applied to `bytes`.
fn run_loaders(bytes: &[u8], path: &Path) -> Vec<bool> {
    let mut ok = Vec::new();
    if let Ok(f) = ImageFormat::from_path(path) {
        ok.push(decode_image(bytes, f, ColorEncoding::Srgb, path).is_ok());
        if matches!(f, ImageFormat::Png | ImageFormat::Jpeg) {
            ok.push(decode_image(bytes, f, ColorEncoding::Linear, path).is_ok());
        }
    }
    if let Ok(f) = MeshFormat::from_path(path) {
        ok.push(decode_mesh(bytes, f, path).is_ok());
    }
    ok
}

fn check(bytes: &[u8], path: &Path, what: &str) {
    let r = catch_unwind(AssertUnwindSafe(|| run_loaders(bytes, path)));
    assert!(r.is_ok(), "{}: a loader panicked on {what}", path.display());
}

#[test]
fn truncated_and_flipped_files_never_panic() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let mut files = Vec::new();
    for (sub, ext) in [
        ("hdri", "exr"),
        ("hdri", "hdr"),
        ("hdri-unsupported", "exr"),
        ("mesh", "obj"),
        ("mesh", "glb"),
        ("mesh-unsupported", "glb"),
        ("normalmaps", "png"),
    ] {
        files.extend(common::files(&dir, sub, ext));
    }
    // Generated variants the shared data lacks: a tiled PIZ EXR and an RLE
    // .hdr of a probe, and binary and ASCII PLY copies of the bunny.
    let mut generated: Vec<(std::path::PathBuf, Vec<u8>)> = Vec::new();
    {
        let city = dir.join("hdri/city.exr");
        let (img, _) = read_image(&city).unwrap();
        let enc = exr::prelude::Encoding {
            compression: exr::prelude::Compression::PIZ,
            blocks: exr::prelude::Blocks::Tiles(exr::prelude::Vec2(64, 64)),
            line_order: exr::prelude::LineOrder::Unspecified,
        };
        let p = std::path::PathBuf::from("city-tiled-piz.exr");
        generated.push((
            p.clone(),
            image_io::encode_exr_with(img.width, img.height, &img.pixels, enc, &p).unwrap(),
        ));
        let p = std::path::PathBuf::from("city-rle.hdr");
        generated.push((
            p.clone(),
            encode_hdr(img.width, img.height, &img.pixels, &p).unwrap(),
        ));
        let (bunny, _) = load_mesh(&dir.join("mesh/bunny.obj")).unwrap();
        for enc in ["ascii", "binary_big_endian"] {
            let p = std::path::PathBuf::from(format!("bunny-{enc}.ply"));
            generated.push((p, ply_bytes(&bunny, enc)));
        }
    }
    for (p, bytes) in &generated {
        let ok = run_loaders(bytes, p);
        assert!(
            ok.iter().all(|&b| b) || p.extension().unwrap() == "png",
            "{} must load intact",
            p.display()
        );
    }
    // Fewer variants for the 12 look-alike probes, more for the others.
    let mut rng = Rng(0x5EED_2026);
    let mut total = 0;
    let inputs: Vec<(std::path::PathBuf, Vec<u8>)> = files
        .iter()
        .map(|p| (p.clone(), std::fs::read(p).unwrap()))
        .chain(generated)
        .collect();
    for (k, (path, bytes)) in inputs.iter().enumerate() {
        let path = &path;
        let n = bytes.len();
        let probes = path.parent().is_some_and(|p| p.ends_with("hdri"));
        let (cuts, flips) = if probes && k % 4 != 0 {
            (6, 6)
        } else {
            (24, 24)
        };
        // Truncations: the header region densely, the body sampled.
        let mut points: Vec<usize> = vec![0, 1, 3, 8, 16, 64, n / 2, n - 1];
        points.extend((0..cuts).map(|_| rng.below(n.min(2048))));
        points.extend((0..cuts).map(|_| rng.below(n)));
        for &cut in &points {
            let cut = cut.min(n);
            check(&bytes[..cut], path, &format!("truncation at {cut}/{n}"));
            total += 1;
        }
        // Byte flips: mostly in the header (where sizes live), some anywhere.
        for f in 0..flips {
            let mut copy = bytes.clone();
            let nflip = 1 + rng.below(4);
            for _ in 0..nflip {
                let at = if f % 2 == 0 {
                    rng.below(n.min(512))
                } else {
                    rng.below(n)
                };
                copy[at] ^= 1 << rng.below(8) as u8 | if f % 3 == 0 { 0xff } else { 0 };
            }
            check(&copy, path, &format!("byte flips (variant {f})"));
            total += 1;
        }
    }
    eprintln!("fuzzed {total} corrupted copies of {} files", inputs.len());
    assert!(total > 500);
}

#[test]
fn every_truncated_prefix_of_the_whole_bunny_obj_is_handled() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let path = dir.join("mesh/bunny.obj");
    let bytes = std::fs::read(&path).unwrap();
    for cut in (0..bytes.len()).step_by(bytes.len() / 64) {
        check(&bytes[..cut], &path, &format!("truncation at {cut}"));
    }
}

/// A PLY copy of `m` (positions and triangles) in `enc`.
fn ply_bytes(m: &Mesh, enc: &str) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {enc} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.positions.len(),
        m.indices.len()
    )
    .into_bytes();
    for p in &m.positions {
        if enc == "ascii" {
            out.extend_from_slice(format!("{} {} {}\n", p.x, p.y, p.z).as_bytes());
        } else {
            for v in p.to_array() {
                out.extend_from_slice(&v.to_be_bytes());
            }
        }
    }
    for t in &m.indices {
        if enc == "ascii" {
            out.extend_from_slice(format!("3 {} {} {}\n", t[0], t[1], t[2]).as_bytes());
        } else {
            out.push(3);
            for &i in t {
                out.extend_from_slice(&(i as i32).to_be_bytes());
            }
        }
    }
    out
}
