//! The transport bake on disk (`relight_nearfield::cache`): a second
//! prepare loads it and shades bit for bit as the first; a corrupted,
//! truncated or foreign file is an error from `load` and a re-bake with a
//! warning from `prepare`, never a panic; the key follows what the bake
//! depends on.

use glam::Vec3;
use relight_nearfield::cache::{BakeKey, CacheError, load};
use relight_nearfield::face::LightFrame;
use relight_nearfield::scenes::floor_and_sphere;
use relight_nearfield::{NearfieldMethod, NearfieldOptions};
use relight_render::method::Relighter;
use relight_render::{NoProgress, Scene};
use std::path::{Path, PathBuf};

fn scene() -> Scene {
    floor_and_sphere(8, 8, 32, 24, true)
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "relight-nearfield-cache-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn cached(dir: &Path) -> NearfieldMethod {
    NearfieldMethod::new(NearfieldOptions {
        order: 16,
        cache_dir: Some(dir.to_path_buf()),
        ..NearfieldOptions::default()
    })
    .unwrap()
}

#[test]
fn second_prepare_loads_the_bake_bit_for_bit() {
    let d = dir("hit");
    let s = scene();
    let mut a = cached(&d);
    a.prepare(&s, &NoProgress).unwrap();
    assert_eq!((a.bakes(), a.loads()), (1, 0));
    let path = a.cache_path().unwrap();
    assert!(path.exists(), "{}", path.display());
    let mut b = cached(&d);
    b.prepare(&s, &NoProgress).unwrap();
    assert_eq!(
        (b.bakes(), b.loads()),
        (0, 1),
        "the second prepare hits the cache"
    );
    assert!(b.warnings().is_empty(), "{:?}", b.warnings());
    for (x, y) in a.transports().iter().zip(b.transports()) {
        assert_eq!(x.values, y.values);
    }
    assert_eq!(a.vertex_colors(), b.vertex_colors(), "bit for bit");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn corrupt_truncated_and_foreign_files_are_detected() {
    let d = dir("bad");
    let s = scene();
    let mut a = cached(&d);
    a.prepare(&s, &NoProgress).unwrap();
    let path = a.cache_path().unwrap();
    let key = a.bake_key().unwrap().clone();
    let good = std::fs::read(&path).unwrap();
    let mut flipped = good.clone();
    let at = flipped.len() - 100;
    flipped[at] ^= 0x40;
    let mut foreign = good.clone();
    foreign[..8].copy_from_slice(b"NOTMINE!");
    for (what, bytes, needle) in [
        ("corrupted", flipped, "checksum"),
        (
            "truncated",
            good[..good.len() / 2].to_vec(),
            "bytes, header says",
        ),
        ("foreign", foreign, "not a relight nearfield bake"),
        ("empty", Vec::new(), "not a relight nearfield bake"),
    ] {
        std::fs::write(&path, &bytes).unwrap();
        let e = load(&path, &key, 4.0).unwrap_err();
        assert!(matches!(e, CacheError::File(_)), "{what}: {e:?}");
        let msg = e.to_string();
        assert!(msg.contains(needle) && !msg.contains('\n'), "{what}: {msg}");
        let mut b = cached(&d);
        b.prepare(&s, &NoProgress).unwrap();
        assert_eq!((b.bakes(), b.loads()), (1, 0), "{what}: re-baked");
        let w = b.warnings().join(" | ");
        assert!(w.contains("re-baked") && w.contains(needle), "{what}: {w}");
        assert_eq!(a.vertex_colors(), b.vertex_colors(), "{what}");
        // The re-bake replaced the file.
        assert_eq!(std::fs::read(&path).unwrap(), good, "{what}");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn the_key_follows_what_the_bake_depends_on() {
    let s = scene();
    let frame = LightFrame::of(&s.area_lights[0]);
    let base = BakeKey::of(&s, &frame, 32, 4.0).file_name();
    assert_eq!(base, BakeKey::of(&s.clone(), &frame, 32, 4.0).file_name());
    assert!(base.starts_with("nearfield-n32-f4000-o2-s1-v1-"), "{base}");
    let mut moved = s.clone();
    let mut mesh = (*moved.objects[0].mesh).clone();
    mesh.positions[3] += Vec3::new(0.0, 1e-3, 0.0);
    moved.objects[0].mesh = std::sync::Arc::new(mesh);
    let mut unshadowed = s.clone();
    unshadowed.visibility = false;
    let mut lifted = frame;
    lifted.center.y += 0.1;
    for (what, other) in [
        ("order", BakeKey::of(&s, &frame, 16, 4.0)),
        ("face", BakeKey::of(&s, &frame, 32, 3.0)),
        ("a vertex", BakeKey::of(&moved, &frame, 32, 4.0)),
        ("visibility", BakeKey::of(&unshadowed, &frame, 32, 4.0)),
        ("the light's plane", BakeKey::of(&s, &lifted, 32, 4.0)),
    ] {
        assert_ne!(other.file_name(), base, "{what}");
    }
}
