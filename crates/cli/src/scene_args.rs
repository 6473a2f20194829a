//! Scene flags → one [`Scene`]: a scene file (or a mesh under an environment)
//! with every flag that overrides it applied. The scene is the method
//! interface's input, so each flag here is a scene feature, not a method
//! option: a method that cannot render what a flag adds refuses the scene
//! (`relight_render::method::check_scene`).

use crate::args::SceneArgs;
use crate::output::warn_all;
use crate::parse::{parse_floats, parse_size};
use anyhow::{Result, anyhow, bail, ensure};
use glam::{Vec2, Vec3};
use relight_brdf::BrdfSpec;
use relight_render::{AreaLight, Medium, Numbered, Object, PointLight, Scene};
use relight_scene::file::RenderDesc;
use std::path::Path;
use std::sync::Arc;

/// Default image size when neither the scene file nor `--size` gives one.
pub const DEFAULT_SIZE: (usize, usize) = (960, 540);

/// The scene (animated as the file says), the time to show it at
/// (`--time`, else 0 s) and the scene file's `[render]` section, if any.
pub struct BuiltScene {
    pub scene: Scene,
    pub time: f32,
    pub render: Option<RenderDesc>,
}

/// What a user may not know about a scene built from a file or `--mesh`:
/// it has an environment unless told otherwise (the refusals of methods
/// without environment lighting add it).
pub const STUDIO_ENV_HINT: &str = "scenes are lit by the built-in studio map unless told otherwise: `--env black`, or `builtin = \"black\"` under `[environment]`";

/// Loads a tangent-space normal map (PNG or JPEG, decoded linearly: each
/// 8-bit channel c maps to 2c − 1).
///
/// # Errors
/// A linear HDR image (EXR, Radiance HDR) is refused: its values are
/// radiance, not encoded unit vectors, and an environment map given by
/// mistake would otherwise shade as a noisy bump pattern.
pub fn load_normal_map(path: &Path) -> Result<relight_render::NormalMap> {
    let format = relight_assets::ImageFormat::from_path(path)?;
    ensure!(
        !matches!(
            format,
            relight_assets::ImageFormat::Exr | relight_assets::ImageFormat::Hdr
        ),
        "{}: {} is linear radiance, not a normal map (give a tangent-space PNG or JPEG)",
        path.display(),
        match format {
            relight_assets::ImageFormat::Exr => "an OpenEXR image",
            _ => "a Radiance HDR image",
        }
    );
    let (img, report) =
        relight_assets::read_image_with(path, relight_assets::ColorEncoding::Linear)?;
    warn_all(&report.warnings);
    relight_render::NormalMap::from_rgb(img.width, img.height, &img.pixels)
        .map_err(|e| anyhow!("{}: not a normal map: {e}", path.display()))
}

/// Applies the `--light-*` area-light flags: edits the scene's area light
/// number `--light-index` (from 1; the one light without it), or adds one
/// to a scene without (then `--light-center` is needed). Each bad value is
/// a one-line error naming its flag.
fn apply_area_light_flags(a: &SceneArgs, scene: &mut Scene) -> Result<()> {
    let count = scene.area_lights.len();
    let index = match (a.light_index, count) {
        (Some(i), n) if (1..=n).contains(&i) => Some(i - 1),
        (Some(i), 0) => bail!("--light-index {i}: the scene has no [[area_light]]"),
        (Some(i), n) => bail!("--light-index {i}: must be 1…{n} (the scene's area lights)"),
        (None, 0) => None,
        (None, 1) => Some(0),
        (None, n) => bail!(
            "--light-center/--light-size/--light-orientation/--light-intensity/--light-texture edit one area light; the scene has {n}: give --light-index 1…{n}"
        ),
    };
    let center = a
        .light_center
        .as_deref()
        .map(|c| parse_floats(c, 3, "--light-center").map(|v| Vec3::new(v[0], v[1], v[2])))
        .transpose()?;
    let mut light = match index {
        Some(i) => scene.area_lights.remove(i),
        None => AreaLight {
            center: center.ok_or_else(|| {
                anyhow!(
                    "--light-*: the scene has no [[area_light]]; give --light-center to add one"
                )
            })?,
            size: Vec2::ONE,
            world_from_light: relight_scene::rotation_from_yaw_pitch_roll([0.0, 90.0, 0.0]),
            intensity: Vec3::ONE,
            texture: None,
            light_field: None,
        },
    };
    if let Some(c) = center {
        light.center = c;
    }
    if let Some(s) = &a.light_size {
        let v = parse_floats(s, 2, "--light-size")?;
        ensure!(
            v[0] > 0.0 && v[1] > 0.0,
            "--light-size {s}: both sides must be > 0"
        );
        light.size = Vec2::new(v[0], v[1]);
    }
    if let Some(r) = &a.light_orientation {
        let v = parse_floats(r, 3, "--light-orientation")?;
        light.world_from_light = relight_scene::rotation_from_yaw_pitch_roll([v[0], v[1], v[2]]);
    }
    if let Some(i) = &a.light_intensity {
        let n = if i.contains(',') { 3 } else { 1 };
        let v = parse_floats(i, n, "--light-intensity")?;
        ensure!(
            v.iter()
                .all(|x| (0.0..=relight_sphere::MAX_RADIANCE).contains(x)),
            "--light-intensity {i}: must be 0…{:e}",
            relight_sphere::MAX_RADIANCE
        );
        light.intensity = if n == 3 {
            Vec3::new(v[0], v[1], v[2])
        } else {
            Vec3::splat(v[0])
        };
    }
    if let Some(p) = &a.light_texture {
        ensure!(
            light.light_field.is_none(),
            "--light-texture {}: this area light has a light field, whose views give its radiance (edit [area_light.light_field] instead)",
            p.display()
        );
        let (tex, warnings) =
            relight_scene::load_texture(p).map_err(|e| anyhow!("--light-texture: {e}"))?;
        warn_all(&warnings);
        light.texture = Some(Arc::new(tex));
    }
    scene
        .area_lights
        .insert(index.unwrap_or(scene.area_lights.len()), light);
    Ok(())
}

/// Builds the scene of `a`; `fallback` is the scene used when neither a file
/// nor `--mesh` is given (`None`: that is an error).
pub fn build_scene(
    a: &SceneArgs,
    fallback: Option<&dyn Fn(usize, usize) -> Scene>,
) -> Result<BuiltScene> {
    let size = a
        .size
        .as_deref()
        .map(|s| parse_size(s, "--size"))
        .transpose()?;
    let (mut scene, render) = if let Some(path) = &a.scene {
        let loaded = relight_scene::load_scene_file(path, size)?;
        warn_all(&loaded.warnings);
        (loaded.scene, loaded.file.render.clone())
    } else if !a.mesh.is_empty() {
        let (w, h) = size.unwrap_or(DEFAULT_SIZE);
        let env_spec = a.env.as_deref().unwrap_or("studio");
        let (env, warnings) = relight_scene::load_environment(env_spec)?;
        warn_all(&warnings);
        let brdf_spec = a.brdf.as_deref().unwrap_or("lambert");
        let brdf = brdf_spec
            .parse::<BrdfSpec>()
            .map_err(|e| anyhow!("--brdf {brdf_spec}: {e}"))?
            .build();
        let mut objects = Vec::new();
        for m in &a.mesh {
            let builtin = relight_scene::BUILTIN_MESHES.contains(&m.as_str());
            ensure!(
                builtin || Path::new(m).exists(),
                "--mesh {m}: no such file, and not a built-in shape ({})",
                relight_scene::BUILTIN_MESHES.join(", ")
            );
            // The loader's warnings already name the file.
            let (mesh, warnings) = relight_scene::load_mesh(m)?;
            warn_all(&warnings);
            objects.push(Object::new(Arc::new(mesh), brdf.clone()));
        }
        let camera = relight_scene::framing_camera(&objects, w, h, 40.0);
        (Scene::new(objects, env, camera), None)
    } else if let Some(f) = fallback {
        let (w, h) = size.unwrap_or(DEFAULT_SIZE);
        (f(w, h), None)
    } else {
        anyhow::bail!(
            "give a scene file or at least one --mesh (a file, or sphere/torus/knot/ground)"
        );
    };
    let from_file = a.scene.is_some();
    if from_file || a.mesh.is_empty() {
        if let Some(spec) = &a.brdf {
            let brdf = spec
                .parse::<BrdfSpec>()
                .map_err(|e| anyhow!("--brdf {spec}: {e}"))?
                .build();
            scene = relight_scene::with_brdf(&scene, &brdf);
        }
        if let Some(env) = &a.env {
            let (e, warnings) = relight_scene::load_environment(env)?;
            warn_all(&warnings);
            scene.env = e;
        }
    }
    if let Some(c) = &a.camera {
        let v = parse_floats(c, c.split(',').count().clamp(6, 7), "--camera")?;
        let (eye, target) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
        let view = (target - eye).normalize_or_zero();
        ensure!(
            view != Vec3::ZERO,
            "--camera {c}: the target must differ from the eye"
        );
        scene.camera.eye = eye;
        scene.camera.target = target;
        // A view along the scene's up (a top-down camera) takes the up a
        // scene file without one would get.
        if scene.camera.up.normalize_or_zero().cross(view).length() < 1e-3 {
            scene.camera.up = relight_scene::default_camera_up(view);
        }
        if let Some(fov) = v.get(6) {
            ensure!(
                *fov > 0.0 && *fov < 180.0,
                "--camera {c}: field of view must be in (0, 180) degrees, got {fov}"
            );
            scene.camera.vfov_deg = *fov;
        }
    }
    if let Some(r) = &a.light_rotate {
        let v = parse_floats(r, 3, "--light-rotate")?;
        scene.world_from_env =
            relight_scene::rotation_from_yaw_pitch_roll([v[0], v[1], v[2]]) * scene.world_from_env;
    }
    if let Some(p) = &a.normal_map {
        let nm = Arc::new(load_normal_map(p).map_err(|e| anyhow!("--normal-map {e:#}"))?);
        for (i, o) in scene.objects.iter_mut().enumerate() {
            ensure!(
                o.mesh.uvs.len() == o.mesh.positions.len(),
                "--normal-map {}: {} has no texture coordinates (uvs) to map it with",
                p.display(),
                Numbered::object(i)
            );
            o.normal_map = Some(nm.clone());
        }
    }
    for l in &a.light {
        let v = parse_floats(l, 4, "--light")?;
        ensure!(v[3] >= 0.0, "--light {l}: intensity must be ≥ 0");
        scene.point_lights.push(PointLight::new(
            Vec3::new(v[0], v[1], v[2]),
            Vec3::splat(v[3]),
        ));
    }
    if a.beta.is_some() || a.albedo.is_some() || a.medium_radius.is_some() {
        let base = scene.medium;
        let beta = a.beta.or(base.map(|m| m.beta)).ok_or_else(|| {
            anyhow!("--albedo/--medium-radius need a medium: give --beta (or a [medium] in the scene file)")
        })?;
        let m = Medium {
            beta,
            albedo: a
                .albedo
                .or(base.map(|m| m.albedo))
                .unwrap_or(relight_scene::file::DEFAULT_MEDIUM_ALBEDO),
            radius: a
                .medium_radius
                .or(base.map(|m| m.radius))
                .unwrap_or(relight_scene::file::DEFAULT_MEDIUM_RADIUS),
        };
        ensure!(
            m.beta.is_finite() && m.beta >= 0.0,
            "--beta {}: must be a finite number ≥ 0",
            m.beta
        );
        ensure!(
            (0.0..=1.0).contains(&m.albedo),
            "--albedo {}: must be in [0, 1]",
            m.albedo
        );
        ensure!(
            m.radius.is_finite() && m.radius > 0.0,
            "--medium-radius {}: must be a finite number > 0",
            m.radius
        );
        scene.medium = Some(m);
    }
    if a.visibility {
        scene.visibility = true;
    }
    if a.edits_area_light() {
        apply_area_light_flags(a, &mut scene)?;
    } else if let Some(i) = a.light_index {
        bail!(
            "--light-index {i}: says which area light the --light-center/--light-size/--light-orientation/--light-intensity/--light-texture flags edit, and none is given"
        );
    }
    let time = a.time.unwrap_or(0.0);
    ensure!(
        time.is_finite(),
        "--time {time}: must be a finite number of seconds"
    );
    Ok(BuiltScene {
        scene,
        time,
        render,
    })
}
