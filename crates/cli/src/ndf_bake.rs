//! `relight ndf bake NORMALMAP --brdf ggx:α|beckmann:α|blinn:s --out DIR
//! [--lobes J]`: a filtered normal-map MIP chain for engines
//! (`relight_ndf::export`), written as files, with a JSON report of each
//! level's error against the texel-level ground truth.
//!
//! # Files (level `k` = 0 is the map's size, down to 1 × 1)
//! * `normal_k.png`: 16-bit RGB tangent-space normals, `rgb = n/2 + ½`,
//!   **green up** (+Y = bitangent, the OpenGL convention that glTF 2.0,
//!   Bevy and three.js use; DirectX-style engines flip green).
//! * GGX / Beckmann: `roughness_k.png`, 16-bit RGB in glTF's
//!   `metallicRoughness` layout: G = perceptual roughness `√α′` (glTF, Bevy
//!   and three.js all square it: `α = roughness²`), B = metalness 0, R = 1.
//!   Beckmann's `α′` is written the same way (no engine above ships Beckmann).
//! * Blinn–Phong: `exponent_k.exr`, f32: R = B = the exponent `s′`, G = the
//!   gain a normalized Blinn–Phong of exponent `s′` needs
//!   (`relight_ndf::export::blinn_gain`, `(s′/s) c(s)/c(s′)`).
//! * With `--lobes J`: `lobes_k_j.exr`, RGBA f32 `(α, α A(κ) μ)` of slot `j`
//!   (linear filtering of these is the moment-matching merge; `μ = m/|m|`,
//!   `A(κ) = |m|/α`).
//! * `report.json`: the conventions, the file list and each level's error.
//!
//! The vMF fit (seconds at 512²) is cached on disk by the map's texels and
//! the bake options: `$RELIGHT_CACHE/ndf`, else `$XDG_CACHE_HOME/relight/ndf`,
//! else `~/.cache/relight/ndf`.

use anyhow::{Context, Result, anyhow, bail};
use glam::{Vec3, Vec4};
use relight_ndf::export::{EngineChain, EngineLevel, LevelError, level_errors};
use relight_ndf::{NdfBrdf, VmfBakeOptions, VmfPyramid};
use relight_render::NormalMap;
use relight_wavelet::CacheUse;
use std::path::{Path, PathBuf};

/// `relight ndf …`.
#[derive(clap::Subcommand, Debug)]
pub enum NdfCommand {
    /// Bake a normal map's filtered MIP chain for engines: normal + roughness
    /// (or exponent) maps per level, optional vMF lobe textures, and a JSON
    /// report of each level's error against exact shading.
    Bake(NdfBakeArgs),
}

/// `relight ndf bake`.
#[derive(clap::Args, Debug)]
pub struct NdfBakeArgs {
    /// Tangent-space normal map (PNG or JPEG, green up).
    pub normal_map: PathBuf,
    /// The BRDF whose lobe absorbs the normal spread: ggx:α, beckmann:α, blinn:s.
    #[arg(long)]
    pub brdf: String,
    /// Output folder (created).
    #[arg(long)]
    pub out: PathBuf,
    /// Also fit and write J vMF lobes per texel (1…8).
    #[arg(long)]
    pub lobes: Option<usize>,
    /// Texels per level in the error report.
    #[arg(long, default_value_t = 64)]
    pub report_texels: usize,
    /// Folder of the vMF fit cache [default: see the module docs].
    #[arg(long)]
    pub cache: Option<PathBuf>,
}

/// The default cache folder of the vMF fits.
fn default_cache_dir() -> PathBuf {
    let wavelet = relight_wavelet::default_cache_dir();
    wavelet
        .parent()
        .map_or_else(|| PathBuf::from("relight-cache/ndf"), |p| p.join("ndf"))
}

/// FNV-1a over the map's texels and the bake options.
fn cache_key(map: &NormalMap, opts: &VmfBakeOptions) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |v: u64| h = (h ^ v).wrapping_mul(0x0100_0000_01b3);
    eat(map.width as u64);
    eat(map.height as u64);
    for t in &map.texels {
        for v in t.to_array() {
            eat(u64::from(v.to_bits()));
        }
    }
    let o = format!("{opts:?}");
    for b in o.bytes() {
        eat(u64::from(b));
    }
    h
}

/// The vMF pyramid of `map`, from `cache` when present; a file that does not
/// parse (bad checksum, version or sizes) is re-baked and replaced, and the
/// [`CacheUse`] says so.
fn vmf_cached(
    map: &NormalMap,
    opts: &VmfBakeOptions,
    cache: &Path,
) -> Result<(VmfPyramid, CacheUse)> {
    let path = cache.join(format!(
        "vmf-j{}-{:016x}.bin",
        opts.lobes,
        cache_key(map, opts)
    ));
    let mut used = CacheUse::Baked;
    if let Ok(bytes) = std::fs::read(&path) {
        match VmfPyramid::from_bytes(&bytes) {
            Some(p)
                if p.lobes == opts.lobes
                    && p.levels[0].width == map.width
                    && p.levels[0].height == map.height =>
            {
                return Ok((p, CacheUse::Loaded));
            }
            _ => {
                used = CacheUse::Replaced {
                    path: path.clone(),
                    why: "a bad checksum, format or size".into(),
                }
            }
        }
    }
    let p = VmfPyramid::build(map.width, map.height, &map.texels, opts);
    crate::output::check_out_dir(cache, "--cache")?;
    relight_assets::write_atomic(&path, &p.to_bytes())?;
    Ok((p, used))
}

fn u16_of(v: f32) -> u16 {
    (v.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16
}

/// Writes a 16-bit RGB PNG.
fn write_png16(path: &Path, w: usize, h: usize, px: impl Fn(usize) -> [f32; 3]) -> Result<()> {
    let data: Vec<u16> = (0..w * h).flat_map(|i| px(i).map(u16_of)).collect();
    let img = image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(w as u32, h as u32, data)
        .ok_or_else(|| anyhow!("{}: bad image size", path.display()))?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .with_context(|| format!("{}: PNG encoding", path.display()))?;
    relight_assets::write_atomic(path, bytes.get_ref())?;
    Ok(())
}

/// Writes RGBA f32 as OpenEXR (ZIP).
fn write_exr_rgba(path: &Path, w: usize, h: usize, px: &[Vec4]) -> Result<()> {
    use exr::prelude::*;
    let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let p = px[y * w + x];
        (p.x, p.y, p.z, p.w)
    });
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .map_err(|e| anyhow!("{}: OpenEXR encoding: {e}", path.display()))?;
    relight_assets::write_atomic(path, out.get_ref())?;
    Ok(())
}

/// Reads an RGBA OpenEXR written by [`write_exr_rgba`].
fn read_exr_rgba(path: &Path) -> Result<(usize, usize, Vec<Vec4>)> {
    use exr::prelude::*;
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec4::ZERO; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<Vec4>), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec4::new(r, g, b, a);
        },
    )
    .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let size = img.layer_data.size;
    Ok((
        size.width(),
        size.height(),
        img.layer_data.channel_data.pixels.1,
    ))
}

/// The files of level `k`.
fn names(brdf: NdfBrdf, k: usize, lobes: usize) -> (String, String, Vec<String>) {
    let rough = match brdf {
        NdfBrdf::Blinn { .. } => format!("exponent_{k}.exr"),
        _ => format!("roughness_{k}.png"),
    };
    (
        format!("normal_{k}.png"),
        rough,
        (0..lobes).map(|j| format!("lobes_{k}_{j}.exr")).collect(),
    )
}

#[derive(serde::Serialize)]
struct ReportLevel {
    level: usize,
    width: usize,
    height: usize,
    normal: String,
    roughness: String,
    lobes: Vec<String>,
    error: LevelError,
}

#[derive(serde::Serialize)]
struct Report {
    normal_map: String,
    brdf: String,
    lobes: usize,
    conventions: [&'static str; 5],
    ground_truth: &'static str,
    levels: Vec<ReportLevel>,
}

/// Writes `chain` (and its report) into `dir`.
fn write_chain(
    dir: &Path,
    source: &str,
    chain: &EngineChain,
    errors: Vec<LevelError>,
) -> Result<()> {
    crate::output::check_out_dir(dir, "--out")?;
    let j = chain.vmf.as_ref().map_or(0, |v| v.lobes);
    let mut levels = Vec::new();
    for ((k, l), error) in chain.levels.iter().enumerate().zip(errors) {
        let (nn, rn, ln) = names(chain.brdf, k, j);
        write_png16(&dir.join(&nn), l.width, l.height, |i| {
            (l.normals[i] * 0.5 + Vec3::splat(0.5)).to_array()
        })?;
        match chain.brdf {
            NdfBrdf::Blinn { .. } => {
                let NdfBrdf::Blinn { s } = chain.brdf else {
                    unreachable!("matched Blinn")
                };
                let px: Vec<Vec3> = l
                    .roughness
                    .iter()
                    .map(|sp| Vec3::new(*sp, relight_ndf::export::blinn_gain(s, *sp), *sp))
                    .collect();
                relight_assets::write_exr(&dir.join(&rn), l.width, l.height, &px)?;
            }
            _ => write_png16(&dir.join(&rn), l.width, l.height, |i| {
                [1.0, l.roughness[i].sqrt(), 0.0]
            })?,
        }
        if let Some(v) = &chain.vmf {
            let vl = &v.levels[k];
            for (jj, name) in ln.iter().enumerate() {
                let px: Vec<Vec4> = vl.lobes.iter().skip(jj).step_by(j).copied().collect();
                write_exr_rgba(&dir.join(name), vl.width, vl.height, &px)?;
            }
        }
        levels.push(ReportLevel {
            level: k,
            width: l.width,
            height: l.height,
            normal: nn,
            roughness: rn,
            lobes: ln,
            error,
        });
    }
    let report = Report {
        normal_map: source.into(),
        brdf: chain.brdf.label(),
        lobes: j,
        conventions: [
            "normal_k.png: 16-bit RGB, rgb = n/2 + 1/2, tangent space, green up (+Y bitangent; glTF 2.0, Bevy, three.js); flip green for DirectX-style engines",
            "roughness_k.png (ggx, beckmann): glTF metallicRoughness layout, G = perceptual roughness sqrt(alpha'), B = metalness 0, R = 1; glTF, Bevy and three.js use alpha = roughness^2",
            "exponent_k.exr (blinn): f32, R = B = the Blinn-Phong exponent s', G = the gain (s'/s) c(s)/c(s') a normalized Blinn-Phong of exponent s' needs",
            "lobes_k_j.exr: RGBA f32 (alpha, alpha A(kappa) mu) of vMF slot j; linear filtering is the moment-matching merge",
            "level 0 is the input size; level k is ceil(size / 2^k), down to 1x1",
        ],
        ground_truth: "exact shading averaged over the fine texels under each texel, 8 light x 8 view directions (elevations 15-75 deg); relative RMS",
        levels,
    };
    let json = serde_json::to_string_pretty(&report)?;
    relight_assets::write_atomic(&dir.join("report.json"), json.as_bytes())?;
    Ok(())
}

/// Reads a chain written by [`write_chain`] back (the test's check, and
/// what an engine loader does): normals renormalized, roughness `G²`.
fn read_chain(dir: &Path, brdf: NdfBrdf, lobes: usize, levels: usize) -> Result<EngineChain> {
    let read16 = |p: &Path| {
        relight_assets::read_image_with(p, relight_assets::ColorEncoding::Linear)
            .map(|(i, _)| i)
            .with_context(|| p.display().to_string())
    };
    let mut out = Vec::new();
    let mut vmf_levels = Vec::new();
    for k in 0..levels {
        let (nn, rn, ln) = names(brdf, k, lobes);
        let n = read16(&dir.join(nn))?;
        let r = read16(&dir.join(rn))?;
        let roughness = match brdf {
            NdfBrdf::Blinn { .. } => r.pixels.iter().map(|p| p.x).collect(),
            _ => r.pixels.iter().map(|p| p.y * p.y).collect(),
        };
        out.push(EngineLevel {
            width: n.width,
            height: n.height,
            normals: n
                .pixels
                .iter()
                .map(|p| (*p * 2.0 - Vec3::ONE).normalize_or(Vec3::Z))
                .collect(),
            roughness,
        });
        if lobes > 0 {
            let mut packed = vec![Vec4::ZERO; n.width * n.height * lobes];
            for (jj, name) in ln.iter().enumerate() {
                let (w, h, px) = read_exr_rgba(&dir.join(name))?;
                if (w, h) != (n.width, n.height) {
                    bail!("{name}: {w}×{h}, expected {}×{}", n.width, n.height);
                }
                for (i, v) in px.into_iter().enumerate() {
                    packed[i * lobes + jj] = v;
                }
            }
            vmf_levels.push(relight_ndf::pyramid::VmfLevel {
                width: n.width,
                height: n.height,
                lobes: packed,
            });
        }
    }
    Ok(EngineChain {
        brdf,
        levels: out,
        vmf: (lobes > 0).then_some(VmfPyramid {
            lobes,
            levels: vmf_levels,
        }),
    })
}

/// `relight ndf …`.
pub fn run(c: NdfCommand) -> Result<()> {
    match c {
        NdfCommand::Bake(a) => bake(&a),
    }
}

fn bake(a: &NdfBakeArgs) -> Result<()> {
    let brdf = NdfBrdf::parse(&a.brdf).map_err(|e| anyhow!("--brdf: {e}"))?;
    if brdf == NdfBrdf::Lambert {
        bail!(
            "--brdf lambert: the engine bake widens a glossy lobe (give ggx:α, beckmann:α or blinn:s)"
        );
    }
    if let Some(j) = a.lobes
        && !(1..=relight_ndf::pyramid::MAX_LOBES).contains(&j)
    {
        bail!("--lobes {j}: must be 1…{}", relight_ndf::pyramid::MAX_LOBES);
    }
    crate::output::check_out_dir(&a.out, "--out")?;
    if let Some(c) = &a.cache {
        crate::output::check_out_dir(c, "--cache")?;
    }
    let map = crate::scene_args::load_normal_map(&a.normal_map)?;
    let t = std::time::Instant::now();
    let vmf = match a.lobes {
        Some(j) => {
            let opts = VmfBakeOptions {
                lobes: j,
                ..VmfBakeOptions::default()
            };
            let dir = a.cache.clone().unwrap_or_else(default_cache_dir);
            let (p, used) = vmf_cached(&map, &opts, &dir)?;
            crate::output::warn_all(&Vec::from_iter(used.warning("ndf bake")));
            let hit = used.loaded();
            eprintln!(
                "relight: vMF fit, J = {j}: {} ({:.2} s)",
                if hit {
                    "from the cache"
                } else {
                    "baked and cached"
                },
                t.elapsed().as_secs_f64()
            );
            Some(p)
        }
        None => None,
    };
    let chain = EngineChain::bake(&map, brdf, vmf)?;
    let errors = level_errors(&map, &chain, a.report_texels);
    write_chain(
        &a.out,
        &a.normal_map.display().to_string(),
        &chain,
        errors.clone(),
    )?;
    // Read the files back as an engine would and compare with the bake.
    let back = read_chain(
        &a.out,
        brdf,
        chain.vmf.as_ref().map_or(0, |v| v.lobes),
        chain.levels.len(),
    )?;
    let (mut dn, mut dr) = (0.0f32, 0.0f32);
    for (x, y) in chain.levels.iter().zip(&back.levels) {
        for (p, q) in x.normals.iter().zip(&y.normals) {
            dn = dn.max((*p - *q).length());
        }
        for (p, q) in x.roughness.iter().zip(&y.roughness) {
            dr = dr.max((p - q).abs() / p.max(1e-6));
        }
    }
    if back.vmf != chain.vmf {
        bail!(
            "{}: the lobe textures read back differ from the bake",
            a.out.display()
        );
    }
    for e in &errors {
        println!(
            "level {:>2} {:>4}×{:<4} single lobe {:.4}{} normalized MIP {:.4} Toksvig {:.4} LEAN {:.4}",
            e.level,
            e.width,
            e.height,
            e.single_lobe,
            e.vmf.map_or_else(String::new, |v| format!("  vMF {v:.4}")),
            e.normalized_mip,
            e.toksvig,
            e.lean
        );
    }
    println!(
        "relight: wrote {} (report.json beside the maps); read back: max |Δn| {dn:.1e}, max relative Δ{} {dr:.1e}, lobes exact",
        a.out.display(),
        if matches!(brdf, NdfBrdf::Blinn { .. }) {
            "s′"
        } else {
            "α′"
        }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exported_chain_reloads_as_the_in_memory_one() {
        let map = NormalMap::bumps(16, 2, 0.8);
        let dir = std::env::temp_dir().join(format!("relight-ndf-bake-{}", std::process::id()));
        for brdf in [NdfBrdf::Ggx { alpha: 0.2 }, NdfBrdf::Blinn { s: 64.0 }] {
            let opts = VmfBakeOptions {
                lobes: 2,
                ..VmfBakeOptions::default()
            };
            let vmf = VmfPyramid::build(16, 16, &map.texels, &opts);
            let chain = EngineChain::bake(&map, brdf, Some(vmf)).unwrap();
            let errors = level_errors(&map, &chain, 4);
            write_chain(&dir, "bumps", &chain, errors).unwrap();
            let back = read_chain(&dir, brdf, 2, chain.levels.len()).unwrap();
            assert_eq!(back.levels.len(), 5);
            for (a, b) in chain.levels.iter().zip(&back.levels) {
                assert_eq!((a.width, a.height), (b.width, b.height));
                for (x, y) in a.normals.iter().zip(&b.normals) {
                    assert!((*x - *y).length() < 1e-4, "normal {x} vs {y}");
                }
                for (x, y) in a.roughness.iter().zip(&b.roughness) {
                    // 16-bit √α′: |Δα′| ≤ 2√α′/65535.
                    assert!((x - y).abs() <= 3e-5 * x.max(1.0), "roughness {x} vs {y}");
                }
            }
            // The lobe textures are f32: exact.
            assert_eq!(back.vmf, chain.vmf);
            let json: serde_json::Value =
                serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap();
            assert_eq!(json["levels"].as_array().unwrap().len(), 5);
            // Level 0 is plain normal mapping: no error at all.
            assert!(json["levels"][0]["error"]["single_lobe"].as_f64().unwrap() < 1e-6);
        }
        // The cache returns the pyramid it stored.
        let opts = VmfBakeOptions {
            lobes: 2,
            ..VmfBakeOptions::default()
        };
        let (a, used_a) = vmf_cached(&map, &opts, &dir.join("cache")).unwrap();
        let (b, used_b) = vmf_cached(&map, &opts, &dir.join("cache")).unwrap();
        assert_eq!((used_a, used_b), (CacheUse::Baked, CacheUse::Loaded));
        assert_eq!(a, b);
        // A flipped bit in a lobe, or a truncated file, fails the CRC: the
        // cache re-bakes and replaces it.
        let file = std::fs::read_dir(dir.join("cache"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|e| e == "bin"))
            .unwrap();
        let good = std::fs::read(&file).unwrap();
        let mut flipped = good.clone();
        flipped[good.len() / 2] ^= 0x10;
        for bad in [flipped, good[..good.len() - 1].to_vec()] {
            assert!(VmfPyramid::from_bytes(&bad).is_none());
            std::fs::write(&file, &bad).unwrap();
            let (c, used) = vmf_cached(&map, &opts, &dir.join("cache")).unwrap();
            let warning = used
                .warning("ndf bake")
                .expect("a replaced file is warned about");
            assert!(
                warning.contains(file.to_str().unwrap()) && warning.contains("re-baked"),
                "{warning}"
            );
            assert_eq!(c, a);
            assert_eq!(std::fs::read(&file).unwrap(), good);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
