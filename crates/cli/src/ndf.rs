//! `relight verify ndf`, `relight bench ndf` and the ndf method's flags
//! (`relight_ndf`).

use crate::args::{BenchArgs, MethodFlags, VerifyArgs};
use crate::commands::data_dir;
use crate::plot::{Plot, PlotSpec};
use crate::progress::Bar;
use crate::scene_args::load_normal_map;
use crate::table::Report;
use anyhow::{Result, anyhow, bail};
use relight_ndf::{NdfBrdf, NdfFilter, NdfOptions};

/// Applies the ndf flags (`--normal-filter`, `--ndf-brdf`, `--lobes`,
/// `--vmf-taps`, `--ndf-mask`, `--ndf-supersample`, `--order`).
///
/// # Errors
/// A bad flag value, naming the flag.
pub fn apply_flags(o: &mut NdfOptions, f: &MethodFlags) -> Result<()> {
    if let Some(v) = &f.normal_filter {
        o.filter = NdfFilter::parse(v).map_err(|e| anyhow!("--normal-filter: {e}"))?;
    }
    if let Some(v) = &f.ndf_brdf {
        o.brdf = NdfBrdf::parse(v).map_err(|e| anyhow!("--ndf-brdf: {e}"))?;
        if o.brdf != NdfBrdf::Lambert && f.normal_filter.is_none() {
            o.filter = NdfFilter::Vmf;
        }
    }
    if let Some(j) = f.lobes {
        o.vmf.lobes = j;
    }
    if let Some(t) = &f.vmf_taps {
        o.vmf_taps = t.parse().map_err(|e| anyhow!("--vmf-taps: {e}"))?;
    }
    if let Some(m) = &f.ndf_mask {
        o.probe_masks = match m.as_str() {
            "footprint" => false,
            "probes" => true,
            _ => bail!("--ndf-mask: `{m}`: expected footprint or probes"),
        };
    }
    if let Some(s) = f.ndf_supersample {
        o.supersample = s;
    }
    if let Some(n) = f.order {
        o.order = n;
    }
    if f.ndf_mask.is_some() && o.filter != NdfFilter::Sh {
        bail!(
            "--ndf-mask: applies to the sh filter (--normal-filter sh), not {}",
            o.filter.name()
        );
    }
    if f.vmf_taps.is_some() && o.filter != NdfFilter::Vmf {
        bail!(
            "--vmf-taps: applies to the vmf filter (--normal-filter vmf, or a glossy --ndf-brdf), not {}",
            o.filter.name()
        );
    }
    Ok(())
}

/// The shared normal maps verify and bench read (the two hard ones first).
const MAPS: [&str; 2] = ["0001.png", "0003.png"];

fn maps() -> Result<Vec<(String, relight_render::NormalMap)>> {
    let dir = data_dir().join("normalmaps");
    let mut out = Vec::new();
    for name in MAPS {
        let p = dir.join(name);
        if p.exists() {
            out.push((name.to_string(), load_normal_map(&p)?));
        } else if std::env::var_os("CI").is_some() {
            bail!("{}: not found (CI needs ../shared/data)", p.display());
        } else {
            eprintln!("relight: {} not found; skipping it", p.display());
        }
    }
    Ok(out)
}

/// The environment's 16-band SH (luminance) rotated 8 ways, for the
/// texel-level Lambert rows.
fn env16(quick: bool) -> Result<Vec<Vec<f32>>> {
    let p = data_dir().join("hdri/studio.exr");
    let env = if p.exists() {
        relight_assets::load_env_map(&p)?.0
    } else {
        eprintln!("relight: {} not found; using a procedural sky", p.display());
        relight_sphere::EnvMap::from_fn(
            relight_sphere::Param::LatLong {
                width: 128,
                height: 64,
            },
            |d| glam::Vec3::splat(0.3 + (4.0 * d.y).max(0.0) + (8.0 * d.x - 7.0).max(0.0)),
        )
    };
    let order = 16;
    let sh = relight_sh::project::project_env(&env, order, relight_sh::project::Window::None)?;
    let lum: Vec<f32> = (0..order * order)
        .map(|i| {
            0.2126 * sh.channels[0][i] + 0.7152 * sh.channels[1][i] + 0.0722 * sh.channels[2][i]
        })
        .collect();
    let count = if quick { 2 } else { 8 };
    (0..count)
        .map(|i| {
            let r = glam::Mat3::from_euler(
                glam::EulerRot::YXZ,
                i as f32 * 0.9,
                -1.2 + i as f32 * 0.35,
                0.3 * i as f32,
            );
            let rot = relight_sh::rotation::ShRotation::<f32>::from_rotation(
                order,
                &relight_sh::rotation::Rot3::from_mat3_unchecked(r),
            )?;
            let mut out = vec![0.0f32; order * order];
            rot.apply(&lum, &mut out);
            Ok(out)
        })
        .collect()
}

/// `relight verify ndf`.
pub fn verify(a: &VerifyArgs, report: &Report, bar: &Bar) -> Result<()> {
    let opts = relight_ndf::verify::NdfVerifyOptions::new(a.quick);
    let mut rows = relight_ndf::verify::identities();
    let env = env16(a.quick)?;
    let maps = maps()?;
    for (name, map) in &maps {
        rows.extend(relight_ndf::verify::texel_levels(
            name, map, &env, &opts, bar,
        )?);
    }
    let screen_map = maps
        .first()
        .map(|(n, m)| (n.clone(), m.clone()))
        .unwrap_or_else(|| {
            (
                "bumps".into(),
                relight_render::NormalMap::bumps(256, 8, 0.8),
            )
        });
    let (screen_rows, panels) =
        relight_ndf::verify::screen(&screen_map.0, &screen_map.1, &opts, bar)?;
    rows.extend(screen_rows);
    if let Some(dir) = &report.plot_dir {
        for p in &panels {
            write_screen_sheet(dir, &screen_map.0, p)?;
        }
    }
    report.table_plots(
        "relight verify ndf: normal-map filtering against exact shading",
        &rows,
        &[Plot::new(PlotSpec {
            name: "verify-ndf-levels",
            x: "level",
            y: "error",
            series: &["map", "representation", "brdf"],
            log_y: true,
        })
        .only("check", "texel")
        .labels(
            "MIP level",
            "relative RMS error vs exact over the fine normals",
        )],
    )?;
    Ok(())
}

/// Writes one screen-level panel side by side as
/// `verify-ndf-screen-<scene>-<brdf>[-sky].png` in `dir`: the reference first, then
/// plain normal mapping 8 × 8 and every filter at 1 spp, each labelled with
/// its error against the reference.
fn write_screen_sheet(
    dir: &std::path::Path,
    map: &str,
    p: &relight_ndf::verify::ScreenPanel,
) -> Result<()> {
    use relight_viewer::sheet::{Cell, compose, words_to_display_linear};
    use relight_viewer::text::{GREEN, GREY, Line, RED};
    let (w, h) = p
        .tiles
        .first()
        .map_or((1, 1), |t| (t.image.width, t.image.height));
    // Small tiles (`--quick`) are enlarged by whole pixels, so that the
    // labels fit over them.
    let k = 384usize.div_ceil(w.max(1)).max(1);
    let enlarge = |img: &relight_render::Image| {
        let mut out = relight_render::Image::new(w * k, h * k);
        for (i, p) in out.pixels.iter_mut().enumerate() {
            *p = img.pixels[(i / (w * k) / k) * w + (i % (w * k)) / k];
        }
        out
    };
    let cells: Vec<Cell> = p
        .tiles
        .iter()
        .map(|t| {
            let details = match t.error {
                None => vec![Line::new(
                    format!("the judge: noise σ_MC {:.1} %", 100.0 * p.sigma),
                    GREEN,
                )],
                Some(e) => {
                    let verdict = match t.target {
                        Some(tgt) if e <= tgt => (format!(" ≤ {:.0} %: pass", 100.0 * tgt), GREEN),
                        Some(tgt) => (format!(" > {:.0} %: FAIL", 100.0 * tgt), RED),
                        None => (String::new(), GREY),
                    };
                    vec![Line::new(
                        format!("error {:.1} % vs reference{}", 100.0 * e, verdict.0),
                        verdict.1,
                    )]
                }
            };
            Cell {
                title: t.label.clone(),
                details: [
                    vec![Line::new(
                        format!(
                            "{}{} · {} · {map}",
                            p.scene.name(),
                            p.light.suffix(),
                            p.brdf.label()
                        ),
                        GREY,
                    )],
                    details,
                ]
                .concat(),
                image: Ok(enlarge(&t.image)),
            }
        })
        .collect();
    let sheet = compose(&cells, w * k, h * k);
    crate::output::check_out_dir(dir, "--plot")?;
    let name = format!(
        "verify-ndf-screen-{}-{}{}.png",
        p.scene.name().replace(' ', "-"),
        p.brdf.label().replace(':', ""),
        if p.light == relight_ndf::verify::ScreenLight::Sky {
            "-sky"
        } else {
            ""
        }
    );
    relight_assets::write_png(
        &dir.join(name),
        sheet.width,
        sheet.height,
        &words_to_display_linear(&sheet.words),
        relight_assets::ToneMap {
            exposure_ev: 0.0,
            operator: relight_assets::ToneOperator::Clamp,
        },
    )?;
    Ok(())
}

/// `relight bench ndf`.
pub fn bench(a: &BenchArgs, report: &Report, _bar: &Bar) -> Result<()> {
    let map = match maps()?.into_iter().next() {
        Some((_, m)) => m,
        None => relight_ndf::bench::procedural_map(relight_ndf::bench::TARGET_SIZE),
    };
    let map = if a.quick {
        let c = 128.min(map.width).min(map.height);
        let texels = (0..c * c)
            .map(|i| map.texels[(i / c) * map.width + i % c])
            .collect();
        relight_render::NormalMap {
            width: c,
            height: c,
            texels,
        }
    } else {
        map
    };
    let (image, repeats) = if a.quick { (128, 2) } else { (512, 5) };
    let rows = relight_ndf::bench::bench_ndf(&map, image, repeats)?;
    report.table("relight bench ndf", &rows, &[])?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_ndf::verify::{ScreenLight, ScreenPanel, ScreenScene, ScreenTile};

    /// `--vmf-taps` reads the vmf filter's taps: given with another filter
    /// it is an error naming the flag; a glossy BRDF picks vmf by itself.
    #[test]
    fn vmf_taps_needs_the_vmf_filter() {
        let flags = |filter: Option<&str>, brdf: Option<&str>| MethodFlags {
            normal_filter: filter.map(str::to_string),
            ndf_brdf: brdf.map(str::to_string),
            vmf_taps: Some("mixture".into()),
            ..MethodFlags::default()
        };
        let mut o = NdfOptions::default();
        let e = apply_flags(&mut o, &flags(Some("sh"), None)).unwrap_err();
        assert!(e.to_string().starts_with("--vmf-taps:"), "{e}");
        let mut o = NdfOptions::default();
        apply_flags(&mut o, &flags(None, Some("blinn:64"))).unwrap();
        assert_eq!(
            (o.filter, o.vmf_taps),
            (NdfFilter::Vmf, relight_ndf::VmfTaps::Mixture)
        );
        let mut o = NdfOptions::default();
        let bad = MethodFlags {
            vmf_taps: Some("blend".into()),
            ..flags(Some("vmf"), None)
        };
        let e = apply_flags(&mut o, &bad).unwrap_err();
        assert!(e.to_string().contains("expected merge or mixture"), "{e}");
    }

    /// `--ndf-mask` picks the sh filter's mask; a bad value or another
    /// filter is an error naming the flag.
    #[test]
    fn ndf_mask_sets_the_sh_filters_probe_masks() {
        let flags = |filter: &str, mask: &str| MethodFlags {
            normal_filter: Some(filter.into()),
            ndf_mask: Some(mask.into()),
            ..MethodFlags::default()
        };
        let mut o = NdfOptions::default();
        assert!(!o.probe_masks);
        apply_flags(&mut o, &flags("sh", "probes")).unwrap();
        assert!(o.probe_masks);
        apply_flags(&mut o, &flags("sh", "footprint")).unwrap();
        assert!(!o.probe_masks);
        let e = apply_flags(&mut o, &flags("sh", "each")).unwrap_err();
        assert!(e.to_string().starts_with("--ndf-mask: `each`"), "{e}");
        let e = apply_flags(&mut o, &flags("vmf", "probes")).unwrap_err();
        assert!(e.to_string().starts_with("--ndf-mask: applies"), "{e}");
    }

    /// Small tiles are enlarged to a readable width and laid out two per
    /// row: three 20 × 10 tiles make a 2 × 2 sheet of 400 × 200 tiles under
    /// their headers, written where `--plot` points.
    #[test]
    fn screen_sheet_enlarges_small_tiles_and_writes_one_png_per_panel() {
        let mut image = relight_render::Image::new(20, 10);
        image.pixels[3] = glam::Vec3::ONE;
        let tile = |label: &str, error| ScreenTile {
            label: label.into(),
            image: image.clone(),
            error,
            target: error.map(|_| 0.05),
        };
        let panel = ScreenPanel {
            scene: ScreenScene::Sphere,
            brdf: relight_ndf::NdfBrdf::Blinn { s: 64.0 },
            light: ScreenLight::Point,
            sigma: 0.01,
            tiles: vec![
                tile("reference", None),
                tile("sh", Some(0.04)),
                tile("vmf", Some(0.2)),
            ],
        };
        let dir = std::env::temp_dir().join(format!("relight-ndf-sheet-{}", std::process::id()));
        write_screen_sheet(&dir, "test.png", &panel).unwrap();
        let path = dir.join("verify-ndf-screen-sphere-blinn64.png");
        let (img, _) =
            relight_assets::read_image_with(&path, relight_assets::ColorEncoding::Srgb).unwrap();
        let header =
            relight_viewer::sheet::header_height(400, relight_viewer::sheet::MIN_DETAIL_LINES);
        assert_eq!((img.width, img.height), (800, 2 * (header + 200)));
        // The bright texel, enlarged 20× (the first tile's pixels 60..80 ×
        // 0..20), tone mapped like the viewer (1.0 → about 0.8).
        let at = |x: usize, y: usize| img.pixels[(header + y) * img.width + x];
        assert!(at(65, 5).x > 0.5 && at(85, 5).x < 0.1 && at(65, 25).x < 0.1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
