//! Loads every real file in `../shared/data` (skips when absent, fails under CI).

use crate::common;

use glam::Vec3;
use relight_assets::*;

#[test]
fn every_hdri_loads_and_exr_matches_hdr_twin_to_rgbe_precision() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let exrs = common::files(&dir, "hdri", "exr");
    assert_eq!(exrs.len(), 12, "expected 12 probes in {}", dir.display());
    for exr in &exrs {
        let hdr = exr.with_extension("hdr");
        let (a, ra) = load_env_map(exr).unwrap_or_else(|e| panic!("{e}"));
        let (b, rb) = load_env_map(&hdr).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            a.param,
            Param::LatLong {
                width: 512,
                height: 256
            },
            "{}",
            exr.display()
        );
        assert_eq!(b.param, a.param, "{}", hdr.display());
        assert_eq!(
            rb.negative_pixels_clamped,
            0,
            "{}: .hdr cannot hold negatives",
            hdr.display()
        );
        assert!(
            ra.warnings.len() <= 1,
            "one warning at most: {:?}",
            ra.warnings
        );
        if ra.negative_pixels_clamped > 0 {
            assert!(ra.warnings[0].contains(&ra.negative_pixels_clamped.to_string()));
        }
        // RGBE stores a shared exponent and 8-bit mantissas: the error of a
        // channel is below 2^(e−8) ≤ max_channel / 128 (plus f16 rounding of
        // the EXR, 2⁻¹¹ relative).
        let mut worst = 0.0f32;
        for (x, y) in a.texels.iter().zip(&b.texels) {
            assert!(x.is_finite() && x.min_element() >= 0.0);
            let tol = x.max_element().max(y.max_element()) / 128.0 + 1e-6;
            let err = (*x - *y).abs().max_element();
            worst = worst.max(err / tol);
            assert!(
                err <= tol,
                "{}: exr {x} vs hdr {y} (tol {tol})",
                exr.display()
            );
        }
        eprintln!(
            "{}: worst |exr−hdr| / tolerance = {worst:.3}, {} negatives clamped",
            exr.display(),
            ra.negative_pixels_clamped
        );
    }
}

#[test]
fn dwab_city_decodes_and_matches_zip_city() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let dwab = dir.join("hdri-unsupported/city-dwab.exr");
    match load_env_map(&dwab) {
        Err(e) => {
            assert!(
                e.to_string().to_ascii_uppercase().contains("DWAB"),
                "error must name DWAB: {e}"
            );
        }
        Ok((a, _)) => {
            let (b, _) = load_env_map(&dir.join("hdri/city.exr")).unwrap();
            assert_eq!(a.param, b.param);
            let mean_r = |m: &EnvMap| {
                m.texels.iter().map(|t| f64::from(t.x)).sum::<f64>() / m.texels.len() as f64
            };
            let (ma, mb) = (mean_r(&a), mean_r(&b));
            assert!(
                (ma - 0.6823).abs() < 5e-4 && (mb - 0.6823).abs() < 5e-4,
                "mean red {ma} vs {mb} (README: 0.6823)"
            );
            // Within half-float precision (2⁻¹⁰ relative) per texel.
            for (x, y) in a.texels.iter().zip(&b.texels) {
                let tol = x.abs().max(y.abs()) * (1.0 / 1024.0) + 1e-6;
                assert!((*x - *y).abs().cmple(tol).all(), "dwab {x} vs zip {y}");
            }
        }
    }
}

#[test]
fn meshes_load_with_expected_counts() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let (obj, rep) = load_mesh(&dir.join("mesh/bunny.obj")).unwrap();
    let r = rep.repair.unwrap();
    assert!(r.computed_normals, "bunny.obj has no normals: {r:?}");
    assert_eq!(obj.vertex_count(), 1839);
    assert_eq!(
        obj.triangle_count() + r.degenerate_triangles + r.out_of_range_triangles,
        3674
    );
    assert!(obj.try_validate().is_ok());

    let (glb, rep) = load_mesh(&dir.join("mesh/bunny.glb")).unwrap();
    let r = rep.repair.unwrap();
    assert!(!r.computed_normals, "bunny.glb carries normals");
    assert_eq!(glb.vertex_count(), 2826);
    assert!(glb.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
    let b = glb.bounds().unwrap();
    assert!(b.extent().min_element() > 0.0);
    eprintln!(
        "bunny.glb: {} tris, bounds {:?}, {r}",
        glb.triangle_count(),
        b
    );

    let e = load_mesh(&dir.join("mesh-unsupported/bunny-draco.glb")).unwrap_err();
    assert!(matches!(e, AssetError::Unsupported { .. }), "{e}");
    assert!(e.to_string().contains("KHR_draco_mesh_compression"), "{e}");
    assert!(e.to_string().contains("bunny-draco.glb"), "{e}");
}

#[test]
fn normal_maps_load_as_linear_data() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let pngs = common::files(&dir, "normalmaps", "png");
    assert_eq!(pngs.len(), 6);
    for p in &pngs {
        let (img, _) = read_image_with(p, ColorEncoding::Linear).unwrap();
        assert_eq!((img.width, img.height), (512, 512));
        let mean = img.pixels.iter().copied().sum::<Vec3>() / img.pixels.len() as f32;
        // Tangent-space normals point mostly out of the surface (+Z = blue).
        assert!(
            mean.z > 0.7 && (mean.x - 0.5).abs() < 0.15,
            "{}: mean {mean}",
            p.display()
        );
    }
}

#[test]
fn describe_every_shared_file() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let mut all = Vec::new();
    for (sub, exts) in [
        ("hdri", &["exr", "hdr"][..]),
        ("hdri-unsupported", &["exr"][..]),
        ("mesh", &["obj", "glb"][..]),
        ("normalmaps", &["png"][..]),
    ] {
        for ext in exts {
            all.extend(common::files(&dir, sub, ext));
        }
    }
    for p in &all {
        let info = describe(p).unwrap_or_else(|e| panic!("{e}"));
        let text = info.to_string();
        assert!(text.contains(p.file_name().unwrap().to_str().unwrap()));
        if let FileInfo::Image(i) = &info {
            assert_eq!(i.nan_samples + i.inf_samples, 0, "{text}");
            if p.parent().unwrap().ends_with("hdri") {
                assert!(
                    i.peak_direction.is_some() && i.max.max_element() > i.mean.max_element(),
                    "{text}"
                );
            }
        }
    }
    // The sun probes have peaks far above their mean (README: 1e4–3e4 vs ~1).
    let FileInfo::Image(park) = describe(&dir.join("hdri/park.exr")).unwrap() else {
        panic!()
    };
    assert!(park.max.max_element() > 1e3, "park peak {}", park.max);
    assert!(
        park.peak_direction.unwrap().y > 0.0,
        "the sun is above the horizon"
    );
    println!("{}", describe(&dir.join("hdri/park.exr")).unwrap());
    println!("{}", describe(&dir.join("mesh/bunny.obj")).unwrap());
}

#[test]
fn bunny_subdivides_to_benchmark_size() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let (bunny, _) = load_mesh(&dir.join("mesh/bunny.obj")).unwrap();
    let chi = bunny.euler_characteristic();
    let (_, boundary) = bunny.edge_counts();
    let t = std::time::Instant::now();
    let (big, levels) = bunny.subdivide_to_vertices(100_000, 6);
    eprintln!(
        "bunny: {} → {} vertices, {} triangles in {levels} Loop steps ({:.2} s); χ {chi}, {boundary} boundary edges",
        bunny.vertex_count(),
        big.vertex_count(),
        big.triangle_count(),
        t.elapsed().as_secs_f64()
    );
    assert_eq!(levels, 3);
    assert!(big.vertex_count() >= 100_000 && big.vertex_count() < 140_000);
    assert_eq!(big.triangle_count(), 64 * bunny.triangle_count());
    assert_eq!(big.euler_characteristic(), chi, "subdivision preserves χ");
    assert!(big.try_validate().is_ok());
}

#[test]
fn rle_copy_of_a_flat_hdr_decodes_to_the_same_radiance() {
    let Some(dir) = common::data_dir() else {
        return;
    };
    let flat = dir.join("hdri/park.hdr");
    let bytes = std::fs::read(&flat).unwrap();
    assert!(
        !bytes.windows(4).any(|w| w == [2, 2, 2, 0]),
        "park.hdr is expected to be flat (not RLE)"
    );
    let (a, _) = read_image(&flat).unwrap();
    let p = std::path::Path::new("park-rle.hdr");
    let rle = encode_hdr(a.width, a.height, &a.pixels, p).unwrap();
    assert!(
        rle.len() < bytes.len(),
        "RLE {} bytes vs flat {}",
        rle.len(),
        bytes.len()
    );
    let (b, _) = decode_image(&rle, ImageFormat::Hdr, ColorEncoding::Srgb, p).unwrap();
    for (x, y) in a.pixels.iter().zip(&b.pixels) {
        let tol = x.max_element() / 128.0 + 1e-7;
        assert!((*x - *y).abs().max_element() <= tol, "flat {x} vs RLE {y}");
    }
}
