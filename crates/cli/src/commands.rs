//! One function per subcommand: validate flags, call the library, report.

use crate::args::{
    BakeCommand, BenchArgs, Cli, Command, ConvertArgs, DemoArgs, FogCommand, Method, ParamKind,
    RenderArgs, ShCommand, Suite, VerifyArgs, ViewArgs, ViewMethodArg,
};
use crate::plot::PlotSpec;
use crate::progress::Bar;
use crate::table::Report;
use anyhow::{Context, Result, anyhow, bail, ensure};
use glam::Vec3;
use relight_assets::{ToneMap, write_exr, write_png};
use relight_brdf::BrdfSpec;
use relight_render::reference::{ReferenceOptions, render_reference};
use relight_render::{Image, Scene};
use relight_sphere::Param;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub fn run(cli: Cli) -> Result<()> {
    let bar = Bar::new(cli.quiet);
    match cli.command {
        Command::Demo(a) => demo(a, &bar),
        Command::Render(a) => render(*a, &bar),
        Command::View(a) => view(a, &bar),
        Command::Info { files } => info(&files),
        Command::Compare {
            image,
            reference,
            diff,
        } => compare(&image, &reference, diff.as_deref()),
        Command::Convert(a) => convert(a),
        Command::Sh(c) => sh(c),
        Command::Bake(c) => bake(c, &bar),
        Command::Fog(c) => fog(c),
        Command::Bench(a) => bench(a),
        Command::Verify(a) => verify(a, &bar),
    }
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(s: &str, flag: &str) -> Result<(usize, usize)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow!("{flag} {s}: expected WIDTHxHEIGHT, e.g. 960x540"))?;
    let w: usize = w
        .trim()
        .parse()
        .map_err(|_| anyhow!("{flag} {s}: width `{w}` is not a positive integer"))?;
    let h: usize = h
        .trim()
        .parse()
        .map_err(|_| anyhow!("{flag} {s}: height `{h}` is not a positive integer"))?;
    ensure!(
        (1..=16384).contains(&w) && (1..=16384).contains(&h),
        "{flag} {s}: each side must be 1…16384 pixels"
    );
    Ok((w, h))
}

/// Parses a comma-separated list of exactly `n` finite floats.
pub fn parse_floats(s: &str, n: usize, flag: &str) -> Result<Vec<f32>> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f32>()
                .map_err(|_| anyhow!("{flag} {s}: `{x}` is not a number"))
        })
        .collect::<Result<_>>()?;
    ensure!(
        v.len() == n,
        "{flag} {s}: expected {n} comma-separated numbers, got {}",
        v.len()
    );
    ensure!(
        v.iter().all(|x| x.is_finite()),
        "{flag} {s}: values must be finite"
    );
    Ok(v)
}

/// Writes `image` as a tone-mapped PNG at `out` and a linear EXR beside it
/// (or the other way round when `out` ends in `.exr`); returns both paths.
pub fn write_outputs(image: &Image, out: &Path) -> Result<(PathBuf, PathBuf)> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let (png, exr) = match ext.as_str() {
        "png" => (out.to_path_buf(), out.with_extension("exr")),
        "exr" => (out.with_extension("png"), out.to_path_buf()),
        _ => bail!(
            "--out {}: the output must end in .png or .exr",
            out.display()
        ),
    };
    ensure!(
        image.pixels.iter().all(|p| p.is_finite()),
        "internal error: the rendered image has non-finite pixels; nothing written"
    );
    write_png(
        &png,
        image.width,
        image.height,
        &image.pixels,
        ToneMap::default(),
    )
    .with_context(|| format!("writing {}", png.display()))?;
    write_exr(&exr, image.width, image.height, &image.pixels)
        .with_context(|| format!("writing {}", exr.display()))?;
    Ok((png, exr))
}

fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("relight: warning: {w}");
    }
}

fn demo(a: DemoArgs, bar: &Bar) -> Result<()> {
    let (w, h) = parse_size(&a.size, "--size")?;
    ensure!(a.spp >= 1, "--spp must be at least 1 (got {})", a.spp);
    let start = Instant::now();
    let scene = relight_scene::default_scene(w, h);
    let image = render_scene(
        &scene,
        a.method,
        &RenderSettings {
            spp: a.spp,
            aa: a.aa,
            ..RenderSettings::default()
        },
        bar,
    )?;
    let (png, exr) = write_outputs(&image, &a.out)?;
    println!(
        "relight demo: {w}×{h}, method {:?}, wrote {} and {} in {:.2} s",
        a.method,
        png.display(),
        exr.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Method-independent settings of one render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub spp: u32,
    pub seed: u64,
    pub visibility: bool,
    /// SH bands and per-pixel rotation (`--method sh`).
    pub order: usize,
    pub rotation: String,
    pub normal_map: Option<PathBuf>,
    /// Wavelet parameters (`--method wavelet`).
    pub n: usize,
    pub ntess: usize,
    pub terms: usize,
    /// Ambient-occlusion rays per vertex (`--method wavelet`; 0 = off).
    pub ao: u32,
    pub cache: Option<PathBuf>,
    /// Fog parameters (`--method fog`).
    pub beta: Option<f32>,
    pub lights: Vec<String>,
    pub fog: String,
    /// Distance of the environment's sources in fog (`--method sh --beta`).
    pub env_distance: f32,
    /// K × K samples per pixel for the raster methods (1 = none).
    pub aa: usize,
    /// `world_from_env` lighting rotation (`--light-rotate`). The wavelet
    /// method rotates in its own step 1 (§3), the SH method rotates its
    /// coefficients; the others resample the map.
    pub light_rotation: glam::Mat3,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            spp: 64,
            seed: 1,
            visibility: false,
            order: 6,
            rotation: "exact".into(),
            normal_map: None,
            n: 64,
            ntess: 32,
            terms: 256,
            ao: 0,
            cache: None,
            beta: None,
            lights: Vec::new(),
            fog: "analytic".into(),
            env_distance: 10.0,
            aa: 1,
            light_rotation: glam::Mat3::IDENTITY,
        }
    }
}

/// Loads a tangent-space normal map (PNG, decoded linearly).
fn load_normal_map(path: &Path) -> Result<relight_shlight::NormalMap> {
    let (img, report) =
        relight_assets::read_image_with(path, relight_assets::ColorEncoding::Linear)?;
    warn_all(&report.warnings);
    relight_shlight::NormalMap::from_rgb(img.width, img.height, &img.pixels)
        .map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Renders `scene` with `method`.
pub fn render_scene(scene: &Scene, method: Method, s: &RenderSettings, bar: &Bar) -> Result<Image> {
    ensure!(
        (1..=8).contains(&s.aa),
        "--aa must be 1…8 samples per pixel side (got {})",
        s.aa
    );
    // The wavelet and SH methods rotate the lighting in their own domain;
    // the others see the rotated map.
    let rotated;
    let in_domain = matches!(method, Method::Wavelet | Method::Sh);
    let scene = if !in_domain && s.light_rotation != glam::Mat3::IDENTITY {
        let mut r = scene.clone();
        r.env = scene.env.rotated(s.light_rotation, 2);
        rotated = r;
        &rotated
    } else {
        scene
    };
    // The raster methods draw K × K times the pixels and box-filter them.
    let supersampled = |scene: &Scene| {
        let mut big = scene.clone();
        big.camera.width *= s.aa;
        big.camera.height *= s.aa;
        big
    };
    match method {
        Method::Reference => {
            let opts = ReferenceOptions {
                spp: s.spp,
                pass_spp: s.spp.min(8),
                seed: s.seed,
                ..ReferenceOptions::default()
            };
            let mut shadowed = scene.clone();
            shadowed.visibility = s.visibility;
            let r = render_reference(&shadowed, &opts, bar)?;
            eprintln!(
                "relight: reference: {} spp, {:.2e} rays/s, relative standard error {:.4}",
                r.spp,
                r.rays as f64 / r.seconds.max(1e-9),
                r.relative_std_error
            );
            Ok(r.image)
        }
        Method::Sh => {
            let rotation: relight_shlight::ShRotationMethod = s
                .rotation
                .parse()
                .map_err(|e| anyhow!("--rotation {}: {e}", s.rotation))?;
            let mut renderer = relight_shlight::ShRenderer::new(s.order, rotation)
                .map_err(|e| anyhow!("--order: {e}"))?
                .with_supersampling(s.aa)
                .with_lighting_rotation(s.light_rotation)?;
            if let Some(beta) = s.beta {
                // The foggy environment of eq. 3.35–3.37 at T_sv = β D.
                let t = f64::from(beta) * f64::from(s.env_distance);
                ensure!(
                    beta >= 0.0 && s.env_distance > 0.0 && t.is_finite(),
                    "--beta {beta} and --env-distance {} must be ≥ 0 and > 0",
                    s.env_distance
                );
                let bands = relight_fog::psf::convolution_weights(t, s.order, true);
                renderer = renderer.with_lighting_filter(relight_shlight::LightingFilter {
                    direct: (-t).exp() as f32,
                    bands: bands.iter().map(|&w| w as f32).collect(),
                })?;
            }
            let nm = s.normal_map.as_deref().map(load_normal_map).transpose()?;
            Ok(renderer.render(scene, nm.as_ref(), bar)?.image)
        }
        Method::Wavelet => Ok(render_wavelet(&supersampled(scene), s, bar)?.box_downsample(s.aa)),
        Method::Fog => Ok(render_fog(&supersampled(scene), s)?.box_downsample(s.aa)),
    }
}

fn render_wavelet(scene: &Scene, s: &RenderSettings, bar: &Bar) -> Result<Image> {
    let cache = s
        .cache
        .clone()
        .unwrap_or_else(relight_wavelet::default_cache_dir);
    let params = relight_wavelet::RotationParams::new(s.n, s.ntess, 1);
    params.validate().map_err(|e| anyhow!("--n/--ntess: {e}"))?;
    let t = Instant::now();
    let rot = relight_wavelet::bake_or_load_rotation(&params, &cache, bar)?;
    let bakes = relight_wavelet::bake_or_load_scene_brdfs(scene, params.m, 64, 128, &cache, bar)?;
    eprintln!(
        "relight: wavelet data ready in {:.2} s (cache {})",
        t.elapsed().as_secs_f64(),
        cache.display()
    );
    let mut renderer = relight_wavelet::WaveletRenderer::new(rot, s.terms)?;
    let t = Instant::now();
    renderer.set_lighting(&scene.env, s.light_rotation)?;
    let light_ms = t.elapsed().as_secs_f64() * 1e3;
    let refs: Vec<&relight_wavelet::BrdfBake> = bakes.iter().map(|b| b.as_ref()).collect();
    let ao = if s.ao > 0 {
        let t = Instant::now();
        let meshes: Vec<&relight_geom::Mesh> = scene.objects.iter().map(|o| &*o.mesh).collect();
        let bvh = relight_render::SceneBvh::build(&meshes);
        let ao = (0..meshes.len())
            .map(|i| bvh.vertex_ambient_occlusion(i, s.ao, s.seed, bar))
            .collect::<Result<Vec<_>, _>>()?;
        eprintln!(
            "relight: ambient occlusion, {} rays per vertex: {:.2} s",
            s.ao,
            t.elapsed().as_secs_f64()
        );
        Some(ao)
    } else {
        None
    };
    let t = Instant::now();
    let image = renderer.render(scene, &refs, &scene.camera, ao.as_deref())?;
    eprintln!(
        "relight: wavelet: lighting change {light_ms:.1} ms, view change + raster {:.1} ms",
        t.elapsed().as_secs_f64() * 1e3
    );
    Ok(image)
}

fn render_fog(scene: &Scene, s: &RenderSettings) -> Result<Image> {
    let beta = s.beta.unwrap_or(0.04);
    ensure!(
        beta.is_finite() && beta >= 0.0,
        "--beta must be a finite number ≥ 0 (got {beta})"
    );
    let mut lights = Vec::new();
    for l in &s.lights {
        let v = parse_floats(l, 4, "--light")?;
        ensure!(v[3] >= 0.0, "--light {l}: intensity must be ≥ 0");
        lights.push(relight_fog::PointLight::new(
            Vec3::new(v[0], v[1], v[2]),
            Vec3::splat(v[3]),
        ));
    }
    if lights.is_empty() {
        lights = relight_fog::default_scene_lights(2);
    }
    let objects = relight_fog::scene_objects(scene);
    let tables = relight_fog::FogTables::build_for(64, objects.iter().map(|o| &o.material))?;
    let mut settings = relight_fog::FogSettings::new(&tables, beta);
    settings.mode = match s.fog.as_str() {
        "analytic" => relight_fog::FogMode::Analytic,
        "opengl" => relight_fog::FogMode::OpenGl {
            fog_color: Vec3::splat(0.5),
        },
        other => bail!("--fog {other}: expected `analytic` or `opengl`"),
    };
    Ok(relight_fog::render_fog(
        &objects,
        &scene.camera,
        &lights,
        &settings,
    )?)
}

fn render(a: RenderArgs, bar: &Bar) -> Result<()> {
    let start = Instant::now();
    let size = a
        .size
        .as_deref()
        .map(|s| parse_size(s, "--size"))
        .transpose()?;
    let mut method = a.method;
    let mut spp = a.spp;
    let mut beta = a.beta;
    let mut lights = a.light.clone();
    let mut scene = if let Some(path) = &a.scene {
        let loaded = relight_scene::load_scene_file(path, size)?;
        warn_all(&loaded.warnings);
        if let Some(r) = &loaded.file.render {
            if let (None, Some(m)) = (method, &r.method) {
                method = Some(
                    <Method as clap::ValueEnum>::from_str(m, true)
                        .map_err(|_| anyhow!("{}: unknown render method `{m}`", path.display()))?,
                );
            }
            spp = spp.or(r.spp);
        }
        if let (None, Some(f)) = (beta, &loaded.file.fog) {
            beta = Some(f.beta);
        }
        if lights.is_empty() {
            lights = loaded
                .file
                .lights
                .iter()
                .map(|l| {
                    let p = l.position;
                    format!("{},{},{},{}", p[0], p[1], p[2], l.intensity)
                })
                .collect();
        }
        loaded.scene
    } else {
        ensure!(
            !a.mesh.is_empty(),
            "give a scene file or at least one --mesh (a file, or sphere/torus/knot)"
        );
        let (w, h) = size.unwrap_or((960, 540));
        let env_spec = a.env.clone().unwrap_or_else(|| "studio".into());
        let (env, warnings) = relight_scene::load_environment(&env_spec)?;
        warn_all(&warnings);
        let brdf_spec = a.brdf.as_deref().unwrap_or("lambert");
        let brdf = brdf_spec
            .parse::<BrdfSpec>()
            .map_err(|e| anyhow!("--brdf {brdf_spec}: {e}"))?
            .build();
        let mut objects = Vec::new();
        for m in &a.mesh {
            let (mesh, warnings) = relight_scene::load_mesh(m)?;
            warn_all(
                &warnings
                    .iter()
                    .map(|w| format!("{m}: {w}"))
                    .collect::<Vec<_>>(),
            );
            objects.push(relight_render::Object::new(
                std::sync::Arc::new(mesh),
                brdf.clone(),
            ));
        }
        let camera = relight_scene::framing_camera(&objects, w, h, 40.0);
        Scene::new(objects, env, camera)
    };
    if let (Some(spec), Some(_)) = (&a.brdf, &a.scene) {
        {
            let brdf = spec
                .parse::<BrdfSpec>()
                .map_err(|e| anyhow!("--brdf {spec}: {e}"))?
                .build();
            scene = relight_scene::with_brdf(&scene, &brdf);
        }
    }
    if let (Some(env), Some(_)) = (&a.env, &a.scene) {
        {
            let (e, warnings) = relight_scene::load_environment(env)?;
            warn_all(&warnings);
            scene.env = e;
        }
    }
    if let Some(c) = &a.camera {
        let v = parse_floats(c, c.split(',').count().clamp(6, 7), "--camera")?;
        scene.camera.eye = Vec3::new(v[0], v[1], v[2]);
        scene.camera.target = Vec3::new(v[3], v[4], v[5]);
        if let Some(fov) = v.get(6) {
            ensure!(
                *fov > 0.0 && *fov < 180.0,
                "--camera: field of view must be in (0, 180) degrees, got {fov}"
            );
            scene.camera.vfov_deg = *fov;
        }
    }
    let light_rotation = match &a.light_rotate {
        Some(r) => {
            let v = parse_floats(r, 3, "--light-rotate")?;
            relight_scene::rotation_from_yaw_pitch_roll([v[0], v[1], v[2]])
        }
        None => glam::Mat3::IDENTITY,
    };
    let spp = spp.unwrap_or(64);
    ensure!(spp >= 1, "--spp must be at least 1 (got {spp})");
    let method = method.unwrap_or(Method::Reference);
    let settings = RenderSettings {
        spp,
        seed: a.seed,
        visibility: a.visibility,
        order: a.order,
        rotation: a.rotation.clone(),
        normal_map: a.normal_map.clone(),
        n: a.n,
        ntess: a.ntess,
        terms: a.terms,
        ao: a.ao,
        cache: a.cache.clone(),
        beta,
        lights,
        fog: a.fog.clone(),
        env_distance: a.env_distance,
        aa: a.aa,
        light_rotation,
    };
    let image = render_scene(&scene, method, &settings, bar)?;
    let (png, exr) = write_outputs(&image, &a.out)?;
    println!(
        "relight render: {}×{}, method {method:?}, wrote {} and {} in {:.2} s",
        image.width,
        image.height,
        png.display(),
        exr.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn info(files: &[PathBuf]) -> Result<()> {
    let mut failed = 0;
    for f in files {
        match relight_assets::describe(f) {
            Ok(info) => println!("{info}"),
            Err(e) => {
                eprintln!("relight: {e}");
                failed += 1;
            }
        }
    }
    ensure!(
        failed == 0,
        "{failed} of {} files could not be read",
        files.len()
    );
    Ok(())
}

/// `relight view`: prepares the first method (bake or load, with progress)
/// and opens the window.
fn view(a: ViewArgs, bar: &Bar) -> Result<()> {
    let (w, h) = parse_size(&a.size, "--size")?;
    let mut scene = match &a.scene {
        Some(path) => {
            let loaded = relight_scene::load_scene_file(path, Some((w, h)))?;
            warn_all(&loaded.warnings);
            loaded.scene
        }
        None => relight_scene::default_scene(w, h),
    };
    if let Some(env) = &a.env {
        let (e, warnings) = relight_scene::load_environment(env)?;
        warn_all(&warnings);
        scene.env = e;
    }
    let method = match a.method {
        ViewMethodArg::Wavelet => relight_viewer::ViewMethod::Wavelet,
        ViewMethodArg::Sh => relight_viewer::ViewMethod::Sh,
        ViewMethodArg::Fog => relight_viewer::ViewMethod::Fog,
        ViewMethodArg::Reference => relight_viewer::ViewMethod::Reference,
    };
    let opts = relight_viewer::ViewerOptions {
        n: a.n,
        ntess: a.ntess,
        terms: a.terms,
        sh_order: a.order,
        beta: a.beta,
        aa: a.aa,
        cache: a.cache.unwrap_or_else(relight_wavelet::default_cache_dir),
    };
    let mut viewer = relight_viewer::Viewer::new(scene, method, opts)?;
    viewer.prepare(bar)?;
    relight_viewer::run(viewer, w as u32, h as u32)?;
    Ok(())
}

/// `relight compare`: the relative RMS difference √(Σ|a − r|² / Σ|r|²)
/// over all pixels and channels, plus the largest per-pixel difference.
fn compare(image: &Path, reference: &Path, diff: Option<&Path>) -> Result<()> {
    let load = |p: &Path| -> Result<relight_assets::RgbImage> {
        let (img, report) = relight_assets::read_image(p)?;
        warn_all(&report.warnings);
        Ok(img)
    };
    let (a, r) = (load(image)?, load(reference)?);
    ensure!(
        (a.width, a.height) == (r.width, r.height),
        "{} is {}×{} but {} is {}×{}",
        image.display(),
        a.width,
        a.height,
        reference.display(),
        r.width,
        r.height
    );
    let (mut num, mut den, mut max) = (0.0f64, 0.0f64, 0.0f32);
    for (p, q) in a.pixels.iter().zip(&r.pixels) {
        let d = *p - *q;
        num += f64::from(d.length_squared());
        den += f64::from(q.length_squared());
        max = max.max(d.abs().max_element());
    }
    ensure!(
        num.is_finite() && den.is_finite(),
        "{} or {} holds NaN or Inf pixels",
        image.display(),
        reference.display()
    );
    ensure!(den > 0.0, "{}: the reference is black", reference.display());
    println!(
        "relight compare: relative RMS {:.5}, largest pixel difference {max:.5} ({}×{})",
        (num / den).sqrt(),
        a.width,
        a.height
    );
    if let Some(out) = diff {
        let mut img = Image::new(a.width, a.height);
        for ((o, p), q) in img.pixels.iter_mut().zip(&a.pixels).zip(&r.pixels) {
            *o = (*p - *q).abs();
        }
        let (png, exr) = write_outputs(&img, out)?;
        println!(
            "relight compare: wrote {} and {}",
            png.display(),
            exr.display()
        );
    }
    Ok(())
}

fn convert(a: ConvertArgs) -> Result<()> {
    let (env, report) = relight_assets::load_env_map(&a.input)?;
    warn_all(&report.warnings);
    ensure!(
        (1..=16).contains(&a.supersample),
        "--supersample must be 1…16 (got {})",
        a.supersample
    );
    let size = a.size.unwrap_or(match env.param {
        Param::LatLong { height, .. } => height,
        Param::Cube { n } | Param::Octahedral { n } | Param::HemiOctahedral { n } => n,
    });
    ensure!(
        (1..=8192).contains(&size),
        "--size must be 1…8192 (got {size})"
    );
    let target = match a.to {
        ParamKind::Latlong => Param::LatLong {
            width: 2 * size,
            height: size,
        },
        ParamKind::Cube => Param::Cube { n: size },
        ParamKind::Octahedral => Param::Octahedral { n: size },
        ParamKind::HemiOctahedral => Param::HemiOctahedral { n: size },
    };
    let out = env.resample(target, a.supersample);
    relight_assets::write_env_map(&a.output, &out, ToneMap::default())
        .with_context(|| format!("writing {}", a.output.display()))?;
    println!(
        "relight convert: {} ({}×{}) → {} ({}×{}, {:?})",
        a.input.display(),
        env.param.width(),
        env.param.height(),
        a.output.display(),
        target.width(),
        target.height(),
        a.to
    );
    Ok(())
}

fn parse_window(w: &str) -> Result<relight_sh::project::Window> {
    use relight_sh::project::Window;
    let (name, arg) = w.split_once(':').map_or((w, None), |(n, a)| (n, Some(a)));
    let value = |default: f64| -> Result<f64> {
        arg.map_or(Ok(default), |a| {
            a.parse::<f64>()
                .map_err(|_| anyhow!("--window {w}: `{a}` is not a number"))
        })
    };
    Ok(match name {
        "none" => Window::None,
        "hanning" => Window::Hanning { width: value(8.0)? },
        "lanczos" => Window::Lanczos { width: value(8.0)? },
        "sloan" => Window::Sloan {
            lambda: value(0.001)?,
        },
        _ => {
            bail!("--window {w}: expected none, hanning[:WIDTH], lanczos[:WIDTH] or sloan[:LAMBDA]")
        }
    })
}

fn sh(c: ShCommand) -> Result<()> {
    match c {
        ShCommand::Project {
            file,
            order,
            window,
            json,
            out,
        } => {
            ensure!(
                (1..=30).contains(&order),
                "--order must be 1…30 bands (got {order})"
            );
            let (env, report) = relight_assets::load_env_map(&file)?;
            warn_all(&report.warnings);
            let w = parse_window(&window)?;
            let coeffs = relight_shlight::project_env(&env, order, w)?;
            let doc = serde_json::json!({
                "file": file.display().to_string(),
                "convention": relight_sh::CONVENTION,
                "order": order,
                "window": w.describe(),
                "coefficients": coeffs,
            });
            if let Some(out) = &out {
                relight_assets::write_atomic(out, serde_json::to_string_pretty(&doc)?.as_bytes())?;
                eprintln!("relight: wrote {}", out.display());
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&doc)?);
            } else {
                println!(
                    "{}: {order} bands ({} coefficients per channel), window {}",
                    file.display(),
                    order * order,
                    w.describe()
                );
                println!("convention: {}", relight_sh::CONVENTION);
                println!("{:>4} {:>4} {:>14} {:>14} {:>14}", "l", "m", "R", "G", "B");
                for l in 0..order as i64 {
                    for m in -l..=l {
                        let i = (l * (l + 1) + m) as usize;
                        println!(
                            "{l:>4} {m:>4} {:>14.6e} {:>14.6e} {:>14.6e}",
                            coeffs.channels[0][i], coeffs.channels[1][i], coeffs.channels[2][i]
                        );
                    }
                }
            }
            Ok(())
        }
        ShCommand::Irradiance { file, out, json } => {
            let (env, report) = relight_assets::load_env_map(&file)?;
            warn_all(&report.warnings);
            let (coeffs, map) = relight_shlight::irradiance_map(
                &env,
                Param::LatLong {
                    width: 256,
                    height: 128,
                },
            )?;
            let img = Image {
                width: map.param.width(),
                height: map.param.height(),
                pixels: map.texels,
            };
            let (png, exr) = write_outputs(&img, &out)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&coeffs)?);
            } else {
                println!(
                    "{}: irradiance E(n), 9 coefficients per channel ({})",
                    file.display(),
                    relight_sh::CONVENTION
                );
                for i in 0..9 {
                    println!(
                        "{i:>2} {:>14.6e} {:>14.6e} {:>14.6e}",
                        coeffs.channels[0][i], coeffs.channels[1][i], coeffs.channels[2][i]
                    );
                }
            }
            eprintln!("relight: wrote {} and {}", png.display(), exr.display());
            Ok(())
        }
    }
}

fn bake(c: BakeCommand, bar: &Bar) -> Result<()> {
    let t = Instant::now();
    match c {
        BakeCommand::Rotation {
            n,
            ntess,
            ntrunc,
            m,
            supersample,
            out,
        } => {
            let mut p = relight_wavelet::RotationParams::new(n, ntess, ntrunc);
            if let Some(m) = m {
                p.m = m;
            }
            p.supersample = supersample;
            p.validate()?;
            let rot = relight_wavelet::bake_rotation(&p, bar)?;
            rot.save(&out)?;
            println!(
                "relight bake rotation: n={n} ntess={ntess} ntrunc={ntrunc} m={} supersample={supersample}: {:.1} nnz/row, {:.1} MB, wrote {} in {:.1} s",
                p.m,
                rot.nnz_per_row(),
                rot.size_bytes() as f64 / 1e6,
                out.display(),
                t.elapsed().as_secs_f64()
            );
        }
        BakeCommand::Brdf {
            brdf,
            m,
            views,
            terms,
            out,
        } => {
            let spec = brdf
                .parse::<BrdfSpec>()
                .map_err(|e| anyhow!("--brdf {brdf}: {e}"))?;
            let b = spec.build();
            let p = relight_wavelet::BrdfBakeParams::new(&spec.to_string(), m, views, terms);
            let bake = relight_wavelet::bake_brdf(&p, b.as_ref(), bar)?;
            bake.save(&out)?;
            println!(
                "relight bake brdf: {spec} m={m} views={views}² terms={terms}: L2 energy kept {:.4}, wrote {} in {:.1} s",
                bake.energy_fraction,
                out.display(),
                t.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}

fn fog(c: FogCommand) -> Result<()> {
    match c {
        FogCommand::Tables { size, out } => {
            ensure!(size >= 2, "--size must be at least 2 (got {size})");
            let t = Instant::now();
            let tables = relight_fog::FogTables::build(size)?;
            let stem = out.with_extension("");
            for img in tables.images() {
                let path = PathBuf::from(format!("{}-{}.exr", stem.display(), img.name));
                write_exr(&path, img.width, img.height, &img.pixels)?;
                println!("wrote {} ({}×{})", path.display(), img.width, img.height);
            }
            println!(
                "relight fog tables: size {size}, built in {:.2} s",
                t.elapsed().as_secs_f64()
            );
            Ok(())
        }
    }
}

fn bench(a: BenchArgs) -> Result<()> {
    let report = Report {
        json: a.json,
        plot_dir: a.plot.clone(),
    };
    match a.suite {
        Suite::Raster => {
            let rows = if a.quick {
                relight_render::raster::bench_raster(100_000, 640, 360, 3)
            } else {
                relight_render::raster::bench_raster(1_000_000, 1920, 1080, 10)
            };
            report.table("relight bench raster", &rows, &[])
        }
        Suite::Reference => {
            let rows = if a.quick {
                relight_render::reference::bench_reference(160, 90, 4)
            } else {
                relight_render::reference::bench_reference(640, 360, 16)
            };
            report.table("relight bench reference", &rows, &[])
        }
        Suite::Sh => {
            report.table(
                "relight bench sh (single thread, f32, ns)",
                &relight_sh::bench_sh(a.quick),
                &[PlotSpec {
                    name: "bench-sh",
                    x: "order",
                    y: "ns_total",
                    series: &["method"],
                    log_y: true,
                }],
            )?;
            let (w, h, orders): (usize, usize, &[usize]) = if a.quick {
                (320, 180, &[3, 6])
            } else {
                (1280, 720, &[3, 6, 10])
            };
            let scene = relight_scene::default_scene(w, h);
            // Per-pixel rotation under a procedural bump map, every method.
            let bumps = relight_shlight::NormalMap::bumps(256, 8, 0.6);
            let rows = relight_shlight::bench_sh_render(
                &scene,
                Some(&bumps),
                w,
                h,
                orders,
                &relight_shlight::ShRotationMethod::ALL,
                if a.quick { 1 } else { 3 },
            )?;
            report.table(
                "relight bench sh: SH shading frame time",
                &rows,
                &[PlotSpec {
                    name: "bench-sh-frame",
                    x: "order",
                    y: "ms_frame",
                    series: &["rotation", "normal_map"],
                    log_y: false,
                }],
            )
        }
        Suite::Wavelet => {
            let opts = if a.quick {
                relight_wavelet::BenchOptions::quick()
            } else {
                relight_wavelet::BenchOptions::full()
            };
            let bunny = data_dir().join("mesh/bunny.obj");
            let mut meshes = Vec::new();
            if bunny.exists() {
                let (mesh, _) = relight_assets::load_mesh(&bunny)?;
                for &target in &opts.vertices {
                    let m = mesh.refine_to_vertices(target);
                    meshes.push((target, std::sync::Arc::new(m)));
                }
            } else {
                eprintln!(
                    "relight: {} not found; view-change rows use UV spheres",
                    bunny.display()
                );
            }
            let rows = relight_wavelet::bench_wavelet(&opts, &meshes, &Bar::new(true))?;
            report.table(
                "relight bench wavelet",
                &rows,
                &[
                    PlotSpec {
                        name: "bench-wavelet-view",
                        x: "vertices",
                        y: "view_change_ms",
                        series: &["n", "ntess"],
                        log_y: false,
                    },
                    PlotSpec {
                        name: "bench-wavelet-light",
                        x: "terms",
                        y: "light_change_ms",
                        series: &["n", "ntess", "layout"],
                        log_y: true,
                    },
                ],
            )
        }
        Suite::Fog => {
            report.table(
                "relight bench fog (fog bench scene: floor + 9 spheres, 4 lights)",
                &relight_fog::bench_fog(a.quick),
                &[],
            )?;
            let (w, h) = if a.quick { (320, 180) } else { (1280, 720) };
            let scene = relight_scene::default_scene(w, h);
            let rows = relight_fog::bench_fog_scene(
                a.quick,
                &relight_fog::scene_objects(&scene),
                &scene.camera,
                &relight_fog::default_scene_lights(4),
            );
            report.table("relight bench fog (default scene, 4 lights)", &rows, &[])
        }
    }
}

/// `../shared/data` beside the working directory, or `$RELIGHT_DATA`.
fn data_dir() -> PathBuf {
    std::env::var_os("RELIGHT_DATA").map_or_else(|| PathBuf::from("../shared/data"), PathBuf::from)
}

fn verify(a: VerifyArgs, bar: &Bar) -> Result<()> {
    let report = Report {
        json: a.json,
        plot_dir: a.plot.clone(),
    };
    match a.suite {
        Suite::Sh => {
            let opts = relight_shlight::VerifyOptions::new(a.quick);
            let default = relight_scene::default_scene(opts.width, opts.height);
            let mut scenes = vec![("default".to_string(), default.clone())];
            let park = data_dir().join("hdri/park.exr");
            if park.exists() {
                let (env, _) = relight_assets::load_env_map(&park)?;
                let ggx = "ggx:0.3"
                    .parse::<BrdfSpec>()
                    .map_err(|e| anyhow!("{e}"))?
                    .build();
                let mut s = relight_scene::with_brdf(&default, &ggx);
                s.env = env;
                scenes.push(("park-ggx0.3".to_string(), s));
            } else {
                eprintln!(
                    "relight: {} not found; verifying the default scene only",
                    park.display()
                );
            }
            let nm_path = data_dir().join("normalmaps/0000.png");
            let nm = if nm_path.exists() {
                Some(load_normal_map(&nm_path)?)
            } else {
                None
            };
            let vs: Vec<relight_shlight::VerifyScene> = scenes
                .iter()
                .map(|(n, s)| relight_shlight::VerifyScene { name: n, scene: s })
                .collect();
            let rows =
                relight_shlight::verify_sh(&vs, nm.as_ref().map(|m| ("0000.png", m)), &opts, bar)?;
            report.table(
                "relight verify sh: relative RMS error vs the reference renderer",
                &rows,
                &[
                    PlotSpec {
                        name: "verify-sh",
                        x: "order",
                        y: "rel_rms_error",
                        series: &["scene", "normal_map", "rotation"],
                        log_y: true,
                    },
                    PlotSpec {
                        name: "verify-sh-rotation",
                        x: "order",
                        y: "rel_rms_vs_exact",
                        series: &["scene", "rotation"],
                        log_y: true,
                    },
                ],
            )
        }
        Suite::Wavelet => {
            let opts = if a.quick {
                relight_wavelet::VerifyOptions::quick()
            } else {
                relight_wavelet::VerifyOptions::full()
            };
            let (w, h) = if a.quick { (160, 90) } else { (320, 180) };
            let default = relight_scene::default_scene(w, h);
            let mut scenes = vec![("default".to_string(), default.clone())];
            if !a.quick {
                for name in ["park", "sky", "studio"] {
                    let p = data_dir().join(format!("hdri/{name}.exr"));
                    if p.exists() {
                        let (env, _) = relight_assets::load_env_map(&p)?;
                        let mut s = default.clone();
                        s.env = env;
                        scenes.push((name.to_string(), s));
                    }
                }
            }
            let (rows, compare) = relight_wavelet::verify_wavelet_with_sh(&scenes, &opts, bar)?;
            report.table(
                "relight verify wavelet: relative RMS error vs the reference renderer",
                &rows,
                &[PlotSpec {
                    name: "verify-wavelet",
                    x: "terms",
                    y: "rel_rms_error",
                    series: &["scene", "brdf", "n", "ntess", "ntrunc"],
                    log_y: true,
                }],
            )?;
            report.table(
                "relight verify wavelet: wavelets beside SH (antialiased, same reference)",
                &compare,
                &[],
            )?;
            // Figure 7 used N = 128² matrices; 64² is the renderer's default.
            let light = |d: Vec3| relight_scene::studio_radiance(d);
            let mut rows = Vec::new();
            for &n in if a.quick { &[32][..] } else { &[64, 128][..] } {
                rows.extend(relight_wavelet::verify_rotation("studio", &light, n, bar)?);
            }
            report.table(
                "relight verify wavelet: rotated lighting (Figure 7)",
                &rows,
                &[PlotSpec {
                    name: "verify-wavelet-rotation",
                    x: "terms",
                    y: "rel_rms_error",
                    series: &["lighting", "n", "method"],
                    log_y: true,
                }],
            )
        }
        Suite::Fog => report.table(
            "relight verify fog",
            &relight_fog::verify_fog(a.quick),
            &[PlotSpec {
                name: "verify-fog",
                x: "param",
                y: "max_error",
                series: &["check", "variant"],
                log_y: true,
            }],
        ),
        Suite::Raster | Suite::Reference => {
            let rows = relight_brdf::verify::verify_brdfs(if a.quick { 20_000 } else { 200_000 });
            report.table(
                "relight verify: BRDF sampling used by the reference renderer",
                &rows,
                &[PlotSpec {
                    name: "verify-brdf",
                    x: "theta_o_deg",
                    y: "albedo_quadrature",
                    series: &["spec"],
                    log_y: false,
                }],
            )
        }
    }
}
