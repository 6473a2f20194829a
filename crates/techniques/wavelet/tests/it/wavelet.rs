//! Tests of the wavelet technique: rotation matrices against direct
//! resampling, supersampling convergence, bake files, BRDF slices and the
//! whole pipeline against quadrature of the reflection integral.

use glam::{DVec3, Vec3, Vec3A};
use relight_brdf::{Brdf, BrdfSpec};
use relight_haar::{Ranking, SparseRgb};
use relight_render::NoProgress;
use relight_wavelet::figure7::{direct_local_texels, inverse_rgb, rel_rms};
use relight_wavelet::lighting::{haar_rgb, sample_octahedral};
use relight_wavelet::octa::{grid_normal, oct_uv_from_dir, shading_frame_f64, texel_of};
use relight_wavelet::render::{NormalInterp, WaveletRenderer};
use relight_wavelet::rotation::rotation_matrix_f32;
use relight_wavelet::study::{direct_radiance, smooth_sky, sun_sky};
use relight_wavelet::{
    BrdfBake, BrdfBakeParams, RotationMatrices, RotationParams, WaveletError, bake_brdf,
    bake_rotation,
};
use std::sync::Arc;

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("relight-wavelet-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Applies an unquantized CSC matrix to a dense coefficient vector.
fn apply_csc(cols: &(Vec<u32>, Vec<u16>, Vec<f32>), x: &[[f32; 3]], mm: usize) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0f32; 3]; mm];
    for (i, xi) in x.iter().enumerate() {
        for q in cols.0[i] as usize..cols.0[i + 1] as usize {
            for c in 0..3 {
                out[cols.1[q] as usize][c] += cols.2[q] * xi[c];
            }
        }
    }
    out
}

#[test]
fn identity_frame_matrix_is_restriction_to_the_hemisphere() {
    let p = RotationParams {
        n: 32,
        m: 16,
        ntess: 2,
        ntrunc: 1,
        supersample: 16,
    };
    let frame = [DVec3::X, DVec3::Y, DVec3::Z];
    let cols = rotation_matrix_f32(&p, frame).unwrap();
    // The source map as a piecewise-constant spherical function: with the
    // identity frame, R·L must be its restriction to the upper hemisphere,
    // area-averaged over each target texel (computed here with 32² samples).
    let texels = sample_octahedral(p.n, 4, smooth_sky());
    let pc = |d: Vec3| {
        let (u, v) = oct_uv_from_dir(d.as_dvec3());
        Vec3::from_array(texels[texel_of(u, v, p.n)])
    };
    let src = haar_rgb(&texels, p.n);
    let got = inverse_rgb(&apply_csc(&cols, &src, p.target_len()), p.m);
    let want = direct_local_texels(&pc, &frame, p.m, 64);
    let e = rel_rms(&got, &want);
    eprintln!(
        "identity frame: relative RMS of R·L vs direct restriction = {e:.5} (16² samples per target texel)"
    );
    assert!(e < 0.012, "identity rotation error {e}");
}

#[test]
fn rotation_in_wavelet_domain_matches_direct_resampling_figure7() {
    // Figure 7 measure: rotate the lighting with the (quantized) matrices and
    // compare with direct resampling of the rotated map, for several normals.
    let p = RotationParams {
        n: 32,
        m: 16,
        ntess: 4,
        ntrunc: 1,
        supersample: 4,
    };
    let rot = bake_rotation(&p, &NoProgress).unwrap();
    let f = smooth_sky();
    let src = haar_rgb(&sample_octahedral(p.n, 4, f), p.n);
    let light = SparseRgb {
        indices: (0..src.len() as u32).collect(),
        values: src.clone(),
    };
    let mut local = vec![Vec3A::ZERO; p.normals() * p.target_len()];
    rot.local_lighting(&light, &mut local).unwrap();
    for k in [0, 5, 10, 15] {
        let frame = shading_frame_f64(grid_normal(k, p.ntess));
        let coeffs: Vec<[f32; 3]> = local[k * p.target_len()..(k + 1) * p.target_len()]
            .iter()
            .map(|v| v.to_array())
            .collect();
        let got = inverse_rgb(&coeffs, p.m);
        let want = direct_local_texels(&f, &frame, p.m, 16);
        let e = rel_rms(&got, &want);
        eprintln!("normal {k}: wavelet rotation vs direct resampling rel RMS = {e:.4}");
        assert!(e < 0.03, "normal {k}: {e}");
    }
}

#[test]
fn supersampling_of_the_area_integral_converges() {
    let frame = shading_frame_f64(grid_normal(3, 8));
    let dense = |ss: usize| {
        let p = RotationParams {
            n: 16,
            m: 8,
            ntess: 2,
            ntrunc: 1,
            supersample: ss,
        };
        let c = rotation_matrix_f32(&p, frame).unwrap();
        let mut d = vec![0.0f64; p.target_len() * p.source_len()];
        for i in 0..p.source_len() {
            for q in c.0[i] as usize..c.0[i + 1] as usize {
                d[c.1[q] as usize * p.source_len() + i] = f64::from(c.2[q]);
            }
        }
        d
    };
    let r16 = dense(16);
    let norm = r16.iter().map(|v| v * v).sum::<f64>().sqrt();
    let diff = |a: &[f64]| {
        a.iter()
            .zip(&r16)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
            / norm
    };
    let r32 = dense(32);
    let d32 = diff(&r32);
    let (e2, e4, e8) = (diff(&dense(2)), diff(&dense(4)), diff(&dense(8)));
    eprintln!(
        "supersampling: ‖R_ss − R_16‖/‖R_16‖ = {e2:.4} (2), {e4:.4} (4), {e8:.4} (8), {d32:.4} (32)"
    );
    // Midpoint sampling of texel-boundary crossings converges as O(1/ss).
    assert!(
        e4 < 0.7 * e2 && e8 < 0.7 * e4,
        "not converging: {e2} {e4} {e8}"
    );
    assert!(
        e8 < 0.12 && d32 < 0.07,
        "8×8 supersampling too far from converged: {e8} {d32}"
    );
}

#[test]
fn bake_statistics_and_layouts_agree() {
    let p = RotationParams {
        n: 16,
        m: 8,
        ntess: 4,
        ntrunc: 1,
        supersample: 4,
    };
    let rot = bake_rotation(&p, &NoProgress).unwrap();
    assert!(
        rot.nnz_per_row() > 5.0 && rot.sparsity() < 0.5,
        "nnz/row {} sparsity {}",
        rot.nnz_per_row(),
        rot.sparsity()
    );
    let src = haar_rgb(&sample_octahedral(p.n, 2, sun_sky()), p.n);
    let light = relight_haar::top_k_rgb(&src, p.n, 40, Ranking::Magnitude);
    let mut a = vec![Vec3A::ZERO; p.normals() * p.target_len()];
    let mut b = a.clone();
    rot.local_lighting(&light, &mut a).unwrap();
    rot.to_csr().local_lighting(&light, &mut b);
    // Dense multiplication as the third way.
    let k = 7;
    let d = rot.dense(k);
    let ld = light.to_dense(p.source_len());
    for j in 0..p.target_len() {
        let mut s = [0.0f32; 3];
        for i in 0..p.source_len() {
            for c in 0..3 {
                s[c] += d[j * p.source_len() + i] * ld[i][c];
            }
        }
        let x = a[k * p.target_len() + j];
        assert!(
            (Vec3A::from_array(s) - x).abs().max_element() < 1e-3 * (1.0 + x.abs().max_element()),
            "row {j}"
        );
    }
    let maxdiff = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(maxdiff < 1e-3, "CSC vs CSR differ by {maxdiff}");
}

#[test]
fn bake_files_round_trip_and_bad_files_are_rejected() {
    let p = RotationParams {
        n: 8,
        m: 4,
        ntess: 3,
        ntrunc: 1,
        supersample: 2,
    };
    let rot = bake_rotation(&p, &NoProgress).unwrap();
    let path = tmp("rot.bin");
    rot.save(&path).unwrap();
    let back = RotationMatrices::load_expect(&path, &p).unwrap();
    assert_eq!(back.nnz(), rot.nnz());
    assert_eq!(back.dense(4), rot.dense(4));
    // Other parameters than requested.
    let other = RotationParams { ntrunc: 2, ..p };
    assert!(matches!(
        RotationMatrices::load_expect(&path, &other),
        Err(WaveletError::ParamMismatch { .. })
    ));
    let bytes = std::fs::read(&path).unwrap();
    // Truncated.
    let t = tmp("rot-trunc.bin");
    std::fs::write(&t, &bytes[..bytes.len() - 7]).unwrap();
    assert!(matches!(
        RotationMatrices::load(&t),
        Err(WaveletError::Corrupt { .. })
    ));
    // Corrupted payload byte.
    let mut c = bytes.clone();
    let last = c.len() - 3;
    c[last] ^= 0x5a;
    std::fs::write(&t, &c).unwrap();
    let e = RotationMatrices::load(&t).unwrap_err();
    assert!(matches!(e, WaveletError::Corrupt { .. }), "{e}");
    assert!(e.to_string().contains("checksum"), "{e}");
    // Other version.
    let mut v = bytes.clone();
    v[8] = v[8].wrapping_add(1);
    std::fs::write(&t, &v).unwrap();
    assert!(matches!(
        RotationMatrices::load(&t),
        Err(WaveletError::Version { .. })
    ));
    // Foreign file (a BRDF bake or random bytes).
    std::fs::write(&t, b"P6\n2 2\n255\n............").unwrap();
    assert!(matches!(
        RotationMatrices::load(&t),
        Err(WaveletError::Foreign { .. })
    ));
    // BRDF files.
    let bp = BrdfBakeParams::new("lambert", 4, 4, 8);
    let brdf: Arc<dyn Brdf> = "lambert".parse::<BrdfSpec>().unwrap().build();
    let bb = bake_brdf(&bp, brdf.as_ref(), &NoProgress).unwrap();
    let bpath = tmp("brdf.bin");
    bb.save(&bpath).unwrap();
    let bback = BrdfBake::load_expect(&bpath, &bp).unwrap();
    assert_eq!(bback.indices, bb.indices);
    assert_eq!(bback.values, bb.values);
    assert!(bback.view_independent && bb.view_independent);
    assert!(matches!(
        BrdfBake::load(&path),
        Err(WaveletError::Foreign { .. })
    ));
    assert!(matches!(
        BrdfBake::load_expect(&bpath, &BrdfBakeParams::new("ggx:0.1", 4, 4, 8)),
        Err(WaveletError::ParamMismatch { .. })
    ));
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

#[test]
fn bad_parameters_are_errors() {
    let bad = |p: RotationParams, name: &str| match bake_rotation(&p, &NoProgress) {
        Err(WaveletError::BadParam { name: got, .. }) => assert_eq!(got, name),
        other => panic!("expected BadParam {name}, got {other:?}"),
    };
    bad(RotationParams::new(48, 8, 1), "n");
    bad(
        RotationParams {
            m: 32,
            ..RotationParams::new(16, 8, 1)
        },
        "m",
    );
    bad(RotationParams::new(16, 1, 1), "ntess");
    bad(RotationParams::new(16, 8, 0), "ntrunc");
    let rot = Arc::new(bake_rotation(&RotationParams::new(8, 2, 1), &NoProgress).unwrap());
    assert!(matches!(
        WaveletRenderer::new(rot.clone(), 65),
        Err(WaveletError::BadParam { name: "terms", .. })
    ));
    assert!(WaveletRenderer::new(rot, 64).is_ok());
    assert!(matches!(
        BrdfBakeParams::new("x", 4, 8, 17).validate(),
        Err(WaveletError::BadParam { name: "terms", .. })
    ));
}

#[test]
fn lambert_slice_integrates_cosine_exactly() {
    // ∫ ρ/π cos dω = ρ: under unit lighting the reflected radiance is the
    // albedo (the scaling coefficient of unit lighting on an m × m map is m).
    let bp = BrdfBakeParams {
        supersample: 4,
        ..BrdfBakeParams::new("lambert:0.5", 16, 4, 256)
    };
    let brdf = "lambert:0.5".parse::<BrdfSpec>().unwrap().build();
    let bb = bake_brdf(&bp, brdf.as_ref(), &NoProgress).unwrap();
    for s in 0..16 {
        let (idx, val) = bb.slice(s);
        let b: Vec3A = idx
            .iter()
            .zip(val)
            .filter(|(i, _)| **i == 0)
            .map(|(_, v)| *v * 16.0)
            .sum();
        assert!(
            (b.x - 0.5).abs() < 2e-3,
            "slice {s}: unit-light radiance {} vs albedo 0.5",
            b.x
        );
    }
    assert!(bb.energy_fraction > 0.99);
    assert!(
        bb.view_independent,
        "Lambert slices do not depend on the view"
    );
}

#[test]
fn pipeline_matches_quadrature_of_the_reflection_integral() {
    // Per-vertex wavelet shading vs direct quadrature (second way), sphere normals.
    let p = RotationParams::new(32, 16, 1);
    let rot = Arc::new(bake_rotation(&p, &NoProgress).unwrap());
    let mut r = WaveletRenderer::new(rot, 256).unwrap();
    let f = smooth_sky();
    r.set_lighting_fn(f).unwrap();
    let eye = Vec3::new(0.3, 1.0, 4.0);
    for spec in ["lambert:0.8", "ggx:0.3"] {
        let brdf = spec.parse::<BrdfSpec>().unwrap().build();
        let bb = bake_brdf(
            &BrdfBakeParams::new(spec, p.m, 32, 64),
            brdf.as_ref(),
            &NoProgress,
        )
        .unwrap();
        let normals: Vec<Vec3> = (0..200)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / 200.0;
                let a = i as f32 * 2.399_963;
                let s = (1.0 - z * z).sqrt();
                Vec3::new(s * a.cos(), z, s * a.sin())
            })
            .filter(|n| n.dot((eye - *n).normalize()) > 0.2)
            .collect();
        let pos = normals.clone();
        let mut got = vec![Vec3::ZERO; pos.len()];
        r.shade_vertices(&pos, &normals, &bb, eye, None, &mut got)
            .unwrap();
        let want: Vec<Vec3> = pos
            .iter()
            .zip(&normals)
            .map(|(x, n)| direct_radiance(&f, brdf.as_ref(), *n, (eye - *x).normalize(), 64))
            .collect();
        let g: Vec<[f32; 3]> = got.iter().map(|v| v.to_array()).collect();
        let w: Vec<[f32; 3]> = want.iter().map(|v| v.to_array()).collect();
        let e = rel_rms(&g, &w);
        eprintln!(
            "{spec}: per-vertex wavelet vs quadrature rel RMS = {e:.4} over {} vertices",
            pos.len()
        );
        assert!(e < 0.05, "{spec}: {e}");
    }
}

#[test]
fn mirror_aligned_normal_blend_removes_highlight_ghosting() {
    // Between sampled normals the paper's blend of the neighbours' local
    // lighting shows a sharp highlight once per neighbour; the mirror-aligned
    // blend centres all four on the vertex's mirror direction. Coarse normal
    // grid (8²), glossy GGX, a small bright light: the mirror-aligned rule
    // must be clearly closer to quadrature; for Lambert both rules agree.
    let p = RotationParams::new(32, 8, 1);
    let rot = Arc::new(bake_rotation(&p, &NoProgress).unwrap());
    let mut r = WaveletRenderer::new(rot, 512).unwrap();
    let light = |d: Vec3| {
        let s = Vec3::new(0.3, 0.8, 0.52).normalize();
        Vec3::splat(0.2) + Vec3::new(8.0, 7.0, 6.0) * d.dot(s).max(0.0).powi(60)
    };
    r.set_lighting_fn(light).unwrap();
    let eye = Vec3::new(0.0, 0.5, 4.0);
    // Normals around the highlight of a unit sphere seen from `eye`.
    let s = Vec3::new(0.3, 0.8, 0.52).normalize();
    let h = (s + eye.normalize()).normalize();
    let normals: Vec<Vec3> = (0..150)
        .map(|i| {
            let a = i as f32 * 2.399_963;
            let rad = 0.35 * ((i as f32 + 0.5) / 150.0).sqrt();
            (h + Vec3::new(rad * a.cos(), rad * a.sin(), 0.3 * rad * a.cos())).normalize()
        })
        .collect();
    let mut errs = Vec::new();
    for spec in ["ggx:0.15", "lambert:0.8"] {
        let brdf = spec.parse::<BrdfSpec>().unwrap().build();
        let bb = bake_brdf(
            &BrdfBakeParams::new(spec, p.m, 32, 128),
            brdf.as_ref(),
            &NoProgress,
        )
        .unwrap();
        assert_eq!(bb.view_independent, spec.starts_with("lambert"), "{spec}");
        let want: Vec<[f32; 3]> = normals
            .iter()
            .map(|n| {
                direct_radiance(&light, brdf.as_ref(), *n, (eye - *n).normalize(), 96).to_array()
            })
            .collect();
        for rule in [NormalInterp::Paper, NormalInterp::MirrorAligned] {
            r.normal_interp = rule;
            let mut got = vec![Vec3::ZERO; normals.len()];
            r.shade_vertices(&normals, &normals, &bb, eye, None, &mut got)
                .unwrap();
            let g: Vec<[f32; 3]> = got.iter().map(|v| v.to_array()).collect();
            let e = rel_rms(&g, &want);
            eprintln!("{spec} {rule:?}: rel RMS vs quadrature {e:.4}");
            errs.push(e);
        }
    }
    assert!(
        errs[1] < 0.6 * errs[0],
        "GGX: mirror {} vs paper {}",
        errs[1],
        errs[0]
    );
    assert!(
        (errs[2] - errs[3]).abs() < 1e-4,
        "Lambert: {} vs {}",
        errs[2],
        errs[3]
    );
}

#[test]
fn brdf_cache_files_are_named_by_the_brdf_label() {
    let name = |spec: &str| {
        let brdf = spec.parse::<BrdfSpec>().unwrap().build();
        BrdfBakeParams::new(&brdf.label(), 16, 64, 128).cache_file_name()
    };
    let a = name("lambert@0.25,0.2,0.3");
    assert!(
        a.starts_with("brdf-lambert@0.25,0.2,0.3-m16-v64-k128-v"),
        "{a}"
    );
    // A label past the name's 40 characters is told apart by the hash.
    let long = |b: f32| {
        name(&format!(
            "0.5*lambert@0.25,0.2,0.3+0.5*ggx:0.2,0.3@1,0.8,{b}"
        ))
    };
    assert_eq!(long(0.6)[..45], long(0.7)[..45]);
    assert_ne!(long(0.6), long(0.7));
    assert_ne!(a, name("lambert@0.25,0.21,0.3"));
    assert!(name("oren-nayar:0.3").starts_with("brdf-oren_nayar_0.3-m16"));
}
