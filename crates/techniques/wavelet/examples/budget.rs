//! Error budget of the wavelet renderer on the default scene (development
//! study; `cargo run --release -p relight-wavelet --example budget`): the
//! pipeline with both normal-blend rules, per pixel with k × k samples,
//! exact per-vertex local lighting (fine environment resampled in each
//! vertex frame), exact slices, and brute-force per-vertex quadrature
//! (`BRUTE=q`), each drawn with Gouraud, against the reference (cached in
//! /tmp). Env: W, H, SPP, SPP2 (second reference: its own noise), BRDF,
//! ENV, N, M, NTESS, NTRUNC, TERMS, VIEWS, BTERMS, EXACT, FINE, SS.
use glam::{DVec3, Mat3, Vec3, Vec3A};
use rayon::prelude::*;
use relight_render::raster::{Background, DrawCall, RasterOptions, Rasterizer};
use relight_render::reference::{ReferenceOptions, render_reference};
use relight_render::{Image, NoProgress, Scene};
use relight_wavelet::brdf_bake::{BrdfBake, BrdfBakeParams, bake_brdf, brdf_slice};
use relight_wavelet::figure7::direct_local_texels;
use relight_wavelet::lighting::haar_rgb;
use relight_wavelet::octa::{
    hemi_density, hemi_dir_from_uv, normal_bilinear, oct_uv_from_dir, shading_frame_f64,
    shading_frame_fast, texel_of,
};
use relight_wavelet::verify::object_ids;
use relight_wavelet::{RotationParams, WaveletRenderer, bake_or_load_rotation};
use std::sync::Arc;

fn arg(name: &str, def: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| def.to_string())
}

fn reference(scene: &Scene, spp: u32, tag: &str) -> Image {
    let path = format!(
        "/tmp/wavref-{tag}-{}x{}-{spp}.bin",
        scene.camera.width, scene.camera.height
    );
    if let Ok(b) = std::fs::read(&path) {
        let f: Vec<f32> = bytemuck::pod_collect_to_vec(&b);
        let mut img = Image::new(scene.camera.width, scene.camera.height);
        for (p, c) in img.pixels.iter_mut().zip(f.chunks(3)) {
            *p = Vec3::new(c[0], c[1], c[2]);
        }
        return img;
    }
    let t = std::time::Instant::now();
    let mut unshadowed = scene.clone();
    unshadowed.visibility = false;
    let r = render_reference(
        &unshadowed,
        &ReferenceOptions {
            spp,
            ..ReferenceOptions::default()
        },
        &NoProgress,
    )
    .unwrap();
    eprintln!(
        "reference {tag} spp {spp}: {:.1} s, rel std err {:.4}",
        t.elapsed().as_secs_f64(),
        r.relative_std_error
    );
    let f: Vec<f32> = r.image.pixels.iter().flat_map(|p| p.to_array()).collect();
    std::fs::write(&path, bytemuck::cast_slice(&f)).unwrap();
    r.image
}

fn draws(scene: &Scene) -> Vec<DrawCall<'_>> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| DrawCall::new(&o.mesh.positions, &o.mesh.indices).with_object_id(i as u32))
        .collect()
}

fn gouraud(scene: &Scene, colors: &[Vec<Vec3>]) -> Image {
    let d = draws(scene);
    let refs: Vec<&[Vec3]> = colors.iter().map(|c| &c[..]).collect();
    let mut img = Image::new(scene.camera.width, scene.camera.height);
    let opts = RasterOptions::default().fit_depth(&scene.camera, &d);
    let mut r = Rasterizer::new();
    r.render_gouraud(
        &scene.camera,
        &d,
        &refs,
        Background::Color(Vec3::ZERO),
        &opts,
        &mut img,
    )
    .unwrap();
    img
}

/// Gouraud at `k`× resolution, box-downsampled (antialiased like the reference).
fn gouraud_ss(scene: &Scene, colors: &[Vec<Vec3>], k: usize) -> Image {
    let mut s = scene.clone();
    s.camera.width *= k;
    s.camera.height *= k;
    gouraud(&s, colors).box_downsample(k)
}

fn report(name: &str, img: &Image, reference: &Image, ids: &[i32], nobj: usize, w: usize) {
    let mut s = format!("{name:<40}");
    let all: Vec<bool> = ids.iter().map(|&i| i >= 0).collect();
    s += &format!(" all {:.4}", img.relative_rms_error(reference, Some(&all)));
    // Interior: the pixel and its 4 neighbours belong to the same object.
    let interior: Vec<bool> = (0..ids.len())
        .map(|p| {
            let i = ids[p];
            if i < 0 {
                return false;
            }
            let (x, y) = (p % w, p / w);
            let h = ids.len() / w;
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && ids[p - 1] == i
                && ids[p + 1] == i
                && ids[p - w] == i
                && ids[p + w] == i
        })
        .collect();
    s += &format!(
        " interior {:.4} |",
        img.relative_rms_error(reference, Some(&interior))
    );
    for k in 0..nobj {
        let m: Vec<bool> = ids.iter().map(|&i| i == k as i32).collect();
        s += &format!(" obj{k} {:.4}", img.relative_rms_error(reference, Some(&m)));
    }
    s += " | ratio";
    for k in 0..nobj {
        let (mut a, mut b) = (0.0f64, 0.0f64);
        for (p, &i) in ids.iter().enumerate() {
            if i == k as i32 {
                a += f64::from(img.pixels[p].element_sum());
                b += f64::from(reference.pixels[p].element_sum());
            }
        }
        s += &format!(" {:.3}", a / b);
    }
    println!("{s}");
}

/// Fine octahedral sampling of the environment for "exact" local lighting.
struct Fine {
    n: usize,
    tex: Vec<Vec3>,
}

impl Fine {
    fn new(scene: &Scene, n: usize) -> Self {
        let tex = relight_wavelet::lighting::sample_octahedral(n, 4, |d| scene.env.eval(d))
            .into_iter()
            .map(Vec3::from_array)
            .collect();
        Self { n, tex }
    }
    /// Haar coefficients of the local lighting (m × m) in `frame`, ss² samples per texel.
    fn local(&self, frame: &[DVec3; 3], m: usize, ss: usize) -> Vec<Vec3A> {
        let look = |d: Vec3| {
            let (a, b) = oct_uv_from_dir(d.as_dvec3());
            self.tex[texel_of(a, b, self.n)]
        };
        haar_rgb(&direct_local_texels(&look, frame, m, ss), m)
            .into_iter()
            .map(Vec3A::from_array)
            .collect()
    }
}

fn main() {
    let (w, h) = (
        arg("W", "320").parse().unwrap(),
        arg("H", "180").parse().unwrap(),
    );
    let spp: u32 = arg("SPP", "1024").parse().unwrap();
    let brdf = arg("BRDF", "scene");
    let envname = arg("ENV", "default");
    let mut scene = relight_scene::default_scene(w, h);
    if brdf != "scene" {
        let b = brdf.parse::<relight_brdf::BrdfSpec>().unwrap().build();
        scene = relight_scene::with_brdf(&scene, &b);
    }
    if envname != "default" {
        let (env, _) = relight_assets::load_env_map(std::path::Path::new(&format!(
            "../shared/data/hdri/{envname}.exr"
        )))
        .unwrap();
        scene.env = env;
    }
    let tag = format!("{envname}-{}", brdf.replace(':', ""));
    let reference_img = reference(&scene, spp, &tag);
    let ids = object_ids(&scene);
    let nobj = scene.objects.len();
    if let Ok(s2) = std::env::var("SPP2") {
        let r2 = reference(&scene, s2.parse().unwrap(), &tag);
        report(
            &format!("ref spp {s2} vs ref spp {spp}"),
            &r2,
            &reference_img,
            &ids,
            nobj,
            w,
        );
    }
    let (n, ntess, ntrunc, terms) = (
        arg("N", "64").parse().unwrap(),
        arg("NTESS", "32").parse().unwrap(),
        arg("NTRUNC", "1").parse::<u16>().unwrap(),
        arg("TERMS", "256").parse().unwrap(),
    );
    let views: usize = arg("VIEWS", "64").parse().unwrap();
    let bterms: usize = arg("BTERMS", "128").parse().unwrap();
    let mut rp = RotationParams::new(n, ntess, ntrunc);
    rp.m = arg("M", &rp.m.to_string()).parse().unwrap();
    let cache = std::path::PathBuf::from("/tmp/wavcache/wavelet");
    let (rot, _) = bake_or_load_rotation(&rp, &cache, &NoProgress).unwrap();
    let bakes: Vec<Arc<BrdfBake>> = scene
        .objects
        .iter()
        .map(|o| {
            let key = o.brdf.label();
            relight_wavelet::bake_or_load_brdf(
                &BrdfBakeParams::new(&key, rp.m, views, bterms.min(rp.target_len())),
                o.brdf.as_ref(),
                &cache,
                &NoProgress,
            )
            .unwrap()
            .0
        })
        .collect();
    let mut r = WaveletRenderer::new(rot.clone(), terms).unwrap();
    r.set_lighting(&scene.env, Mat3::IDENTITY).unwrap();
    let refs: Vec<&BrdfBake> = bakes.iter().map(AsRef::as_ref).collect();
    r.normal_interp = relight_wavelet::NormalInterp::Paper;
    let (img, _) = r
        .render_with_mask(&scene, &refs, &scene.camera, None)
        .unwrap();
    report(
        &format!("pipeline n{n} m{} t{ntess} q{ntrunc} k{terms} paper", rp.m),
        &img,
        &reference_img,
        &ids,
        nobj,
        w,
    );
    r.normal_interp = relight_wavelet::NormalInterp::MirrorAligned;
    let (img, _) = r
        .render_with_mask(&scene, &refs, &scene.camera, None)
        .unwrap();
    report(
        "pipeline mirror-aligned",
        &img,
        &reference_img,
        &ids,
        nobj,
        w,
    );
    r.normal_interp = relight_wavelet::NormalInterp::Paper;
    {
        let mut s2 = scene.clone();
        s2.camera.width *= 4;
        s2.camera.height *= 4;
        let (big, _) = r.render_per_pixel(&s2, &refs, &s2.camera).unwrap();
        report(
            "paper per-pixel 4x4 SSAA",
            &big.box_downsample(4),
            &reference_img,
            &ids,
            nobj,
            w,
        );
    }
    r.normal_interp = relight_wavelet::NormalInterp::MirrorAligned;
    for k in [2usize, 4] {
        let mut s2 = scene.clone();
        s2.camera.width *= k;
        s2.camera.height *= k;
        let (big, _) = r.render_per_pixel(&s2, &refs, &s2.camera).unwrap();
        let img = big.box_downsample(k);
        report(
            &format!("mirror per-pixel {k}x{k} SSAA"),
            &img,
            &reference_img,
            &ids,
            nobj,
            w,
        );
    }
    if arg("ONLYWARP", "0") == "1" {
        // skip
    }
    let (pimg, _) = r.render_per_pixel(&scene, &refs, &scene.camera).unwrap();
    report("pipeline per-pixel", &pimg, &reference_img, &ids, nobj, w);

    let eye = scene.camera.eye;
    let m = rp.m;
    let mm = m * m;
    // Variant shading per vertex.
    let shade_all = |f: &(dyn Fn(usize, Vec3, Vec3) -> Vec3 + Sync)| -> Vec<Vec<Vec3>> {
        scene
            .objects
            .iter()
            .enumerate()
            .map(|(oi, o)| {
                (0..o.mesh.positions.len())
                    .into_par_iter()
                    .map(|v| {
                        let nrm = o.mesh.normals[v];
                        let wo = (eye - o.mesh.positions[v]).normalize();
                        if nrm.dot(wo) < -0.2 {
                            return Vec3::ZERO;
                        }
                        f(oi, nrm, wo)
                    })
                    .collect()
            })
            .collect()
    };
    let local_wo = |nrm: Vec3, wo: Vec3| {
        let fr = shading_frame_fast(nrm);
        let mut wl = fr.to_local(wo);
        if wl.z < 1e-3 {
            wl.z = 1e-3;
            wl = wl.normalize();
        }
        wl
    };
    // Every sampled normal's local lighting, formed once.
    let local: Vec<Vec<Vec3A>> = (0..ntess * ntess)
        .map(|k| r.local_lighting(k).expect("local lighting"))
        .collect();
    let dot = |b: &BrdfBake, s: usize, l: &[Vec3A]| {
        let (idx, val) = b.slice(s);
        let mut acc = Vec3A::ZERO;
        for (&j, &f) in idx.iter().zip(val) {
            acc += f * l[j as usize];
        }
        Vec3::from(acc.max(Vec3A::ZERO))
    };
    // Reflection-warped neighbour interpolation.
    let warped = shade_all(&|oi, nrm, wo| {
        let b = &bakes[oi];
        let (nk, nw) = normal_bilinear(nrm, ntess);
        let rw = (2.0 * nrm.dot(wo) * nrm - wo).normalize();
        let mut acc = Vec3::ZERO;
        for c in 0..4 {
            let nc = relight_wavelet::octa::grid_normal(nk[c] as usize, ntess).as_vec3();
            let fr = shading_frame_fast(nc);
            let rc = fr.to_local(rw);
            let mut wl = Vec3::new(-rc.x, -rc.y, rc.z);
            if wl.z < 1e-3 {
                wl.z = 1e-3;
                wl = wl.normalize();
            }
            acc += dot(b, b.nearest_slice(wl), &local[nk[c] as usize]) * nw[c];
        }
        acc
    });
    report(
        "warped neighbours",
        &gouraud(&scene, &warped),
        &reference_img,
        &ids,
        nobj,
        w,
    );
    report(
        "warped neighbours 4x4 SSAA",
        &gouraud_ss(&scene, &warped, 4),
        &reference_img,
        &ids,
        nobj,
        w,
    );
    // Nearest sampled normal only.
    let nearest = shade_all(&|oi, nrm, wo| {
        let b = &bakes[oi];
        let (nk, nw) = normal_bilinear(nrm, ntess);
        let c = (0..4).max_by(|&a, &b2| nw[a].total_cmp(&nw[b2])).unwrap();
        dot(
            b,
            b.nearest_slice(local_wo(nrm, wo)),
            &local[nk[c] as usize],
        )
    });
    report(
        "nearest normal",
        &gouraud(&scene, &nearest),
        &reference_img,
        &ids,
        nobj,
        w,
    );
    if arg("EXACT", "1") == "1" {
        let fine = Fine::new(&scene, arg("FINE", "256").parse().unwrap());
        let ss: usize = arg("SS", "4").parse().unwrap();
        let t = std::time::Instant::now();
        let exact = shade_all(&|oi, nrm, wo| {
            let fr = shading_frame_f64(nrm.as_dvec3());
            let l = fine.local(&fr, m, ss);
            dot(&bakes[oi], bakes[oi].nearest_slice(local_wo(nrm, wo)), &l)
        });
        eprintln!("exact local lighting: {:.1} s", t.elapsed().as_secs_f64());
        report(
            "exact local lighting (fine env)",
            &gouraud(&scene, &exact),
            &reference_img,
            &ids,
            nobj,
            w,
        );
        // Exact local lighting and exact (unapproximated) BRDF slice.
        let full = shade_all(&|oi, nrm, wo| {
            let fr = shading_frame_f64(nrm.as_dvec3());
            let l = fine.local(&fr, m, ss);
            let s = brdf_slice(scene.objects[oi].brdf.as_ref(), local_wo(nrm, wo), m, 2);
            let mut acc = Vec3A::ZERO;
            for (a, b) in s.iter().zip(&l) {
                acc += Vec3A::from_array(*a) * *b;
            }
            Vec3::from(acc.max(Vec3A::ZERO))
        });
        report(
            "exact lighting + exact slice",
            &gouraud(&scene, &full),
            &reference_img,
            &ids,
            nobj,
            w,
        );
        let _ = (mm, bake_brdf as fn(_, _, _) -> _);
        let q: usize = arg("BRUTE", "0").parse().unwrap();
        if q > 0 {
            let brute = shade_all(&|oi, nrm, wo| {
                let fr = shading_frame_f64(nrm.as_dvec3());
                let wl = local_wo(nrm, wo);
                let mut acc = Vec3::ZERO;
                for i in 0..q * q {
                    let (c, r) = (i % q, i / q);
                    let (u, v) = ((c as f64 + 0.5) / q as f64, (r as f64 + 0.5) / q as f64);
                    let l = hemi_dir_from_uv(u, v);
                    let wd = fr[0] * l.x + fr[1] * l.y + fr[2] * l.z;
                    let (a, b) = oct_uv_from_dir(wd);
                    let dw = (hemi_density(u, v) / (q * q) as f64) as f32;
                    let li = fine.tex[texel_of(a, b, fine.n)];
                    let wi = l.as_vec3();
                    acc += scene.objects[oi].brdf.eval(wl, wi) * li * (wi.z * dw);
                }
                acc
            });
            report(
                &format!("brute force q{q} per vertex"),
                &gouraud(&scene, &brute),
                &reference_img,
                &ids,
                nobj,
                w,
            );
            report(
                &format!("brute force q{q} per vertex, 4x4 SSAA"),
                &gouraud_ss(&scene, &brute, 4),
                &reference_img,
                &ids,
                nobj,
                w,
            );
        }
    }
}
