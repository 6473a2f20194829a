//! Scene file → [`Scene`]: [`load_scene_file`] parses the TOML
//! ([`crate::file`]), checks every value, resolves relative paths against
//! the file's folder, and builds the environment (with its
//! `world_from_env` rotation, the map itself never resampled), the placed
//! objects with their materials, textures and motion, the lights, the
//! medium, visibility and the camera.
//!
//! # Object placement
//! `world_from_object = T(translate) · R(rotate) · S(scale)` with
//! `R = rotation_from_yaw_pitch_roll` (yaw about +Y, then pitch about +X,
//! then roll about +Z, degrees). The mesh is stored placed; keyframes
//! (`relight_render::Animation`) move the placed mesh on top of that.

use crate::check::Ctx;
use crate::embedded::{STUDIO_HEIGHT, builtin_mesh, framing_camera};
use crate::file::{
    BUILTIN_ENVIRONMENTS, CameraDesc, DEFAULT_BRDF, DEFAULT_CAMERA_UP, DEFAULT_CAMERA_UP_VERTICAL,
    DEFAULT_ENV_SCALE, DEFAULT_ENVIRONMENT, DEFAULT_FOV_DEG, DEFAULT_IMAGE_SIZE,
    DEFAULT_OBJECT_SCALE, DEFAULT_ROTATE_DEG, DEFAULT_TRANSLATE, DEFAULT_VISIBILITY, KeyframeDesc,
    MAX_IMAGE_SIDE, ObjectDesc, SceneFile, VERTICAL_NORMAL_COS, parse_scene_file,
};
use crate::lights::{area_light, medium, point_light};
use crate::studio::studio_environment;
use crate::textures::{load_normal_map, load_weight_texture};
use crate::{SceneError, rotation_from_yaw_pitch_roll};
use glam::{Affine3A, Quat, Vec3};
use relight_brdf::{Brdf, BrdfSpec};
use relight_geom::Mesh;
use relight_render::{Animation, BrdfBlend, Camera, Keyframe, Object, Scene};
use relight_sphere::EnvMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Loads an environment by file name, or a built-in one by name
/// ([`BUILTIN_ENVIRONMENTS`]: `studio`, `black`). Soft problems (negative
/// radiance clamped) are returned as warnings.
///
/// # Errors
/// The file is missing or undecodable.
pub fn load_environment(spec: &str) -> Result<(EnvMap, Vec<String>), SceneError> {
    if let Some(env) = builtin_environment(spec) {
        return Ok((env, Vec::new()));
    }
    let (env, report) = relight_assets::load_env_map(Path::new(spec))?;
    Ok((env, report.warnings))
}

fn builtin_environment(name: &str) -> Option<EnvMap> {
    match name {
        "studio" => Some(studio_environment(STUDIO_HEIGHT)),
        "black" => Some(EnvMap::black()),
        _ => None,
    }
}

/// Loads a mesh file, or a built-in shape by name ([`crate::BUILTIN_MESHES`]).
///
/// # Errors
/// The file is missing, undecodable or holds no valid triangle.
pub fn load_mesh(spec: &str) -> Result<(Mesh, Vec<String>), SceneError> {
    if let Some(m) = builtin_mesh(spec) {
        return Ok((m, Vec::new()));
    }
    let (mesh, report) = relight_assets::load_mesh(Path::new(spec))?;
    Ok((mesh, report.warnings))
}

/// A scene file resolved into a [`Scene`], with the parsed file (for its
/// `[render]` settings) and the loaders' soft warnings.
pub struct LoadedScene {
    pub scene: Scene,
    pub file: SceneFile,
    pub warnings: Vec<String>,
}

/// Parses and loads a TOML scene file (format: `docs/scene-format.md`).
/// Relative paths are resolved against the file's folder; `size`
/// (width, height in pixels) overrides the camera's size.
///
/// # Errors
/// One-line [`SceneError`]s naming the file and the key: unreadable file,
/// TOML syntax, unknown/removed/mistyped keys, values out of range, and
/// files named by keys that are missing or invalid.
pub fn load_scene_file(
    path: &Path,
    size: Option<(usize, usize)>,
) -> Result<LoadedScene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound {
            SceneError::Asset(relight_assets::AssetError::Missing { path: path.into() })
        } else {
            SceneError::Read {
                path: path.into(),
                source,
            }
        }
    })?;
    load_scene_text(&text, path, size)
}

/// [`load_scene_file`] on text already read: `path` names the file in
/// errors and its folder is the base of relative paths (it need not exist).
///
/// # Errors
/// As [`load_scene_file`], less the read error.
pub fn load_scene_text(
    text: &str,
    path: &Path,
    size: Option<(usize, usize)>,
) -> Result<LoadedScene, SceneError> {
    let file = parse_scene_file(text, path)?;
    let cx = Ctx { file: path };
    let base = path.parent().unwrap_or(Path::new("."));
    let resolve = |p: &str| -> PathBuf {
        let pb = Path::new(p);
        if pb.is_absolute() {
            pb.to_path_buf()
        } else {
            base.join(pb)
        }
    };
    let mut warnings = Vec::new();

    if file.objects.is_empty() {
        return Err(cx.err("object", "the scene has no `[[object]]`"));
    }
    let objects = file
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            object(
                cx,
                &format!("object[{}]", i + 1),
                o,
                &resolve,
                &mut warnings,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let point_lights = file
        .point_lights
        .iter()
        .enumerate()
        .map(|(i, l)| point_light(cx, &format!("point_light[{}]", i + 1), l))
        .collect::<Result<Vec<_>, _>>()?;
    let area_lights = file
        .area_lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            area_light(
                cx,
                &format!("area_light[{}]", i + 1),
                l,
                resolve,
                &mut warnings,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let medium = file.medium.as_ref().map(|m| medium(cx, m)).transpose()?;
    if let Some(r) = &file.render
        && r.spp == Some(0)
    {
        return Err(cx.err("render.spp", "must be at least 1 (got 0)"));
    }
    let camera = camera(cx, file.camera.as_ref(), size, &objects)?;
    // Last: the (possibly large) environment is loaded once all else checks out.
    let (env, world_from_env) = environment(cx, &file, &resolve, &mut warnings)?;

    let mut scene = Scene::new(objects, env, camera);
    scene.world_from_env = world_from_env;
    scene.point_lights = point_lights;
    scene.area_lights = area_lights;
    scene.medium = medium;
    scene.visibility = file.visibility.unwrap_or(DEFAULT_VISIBILITY);
    Ok(LoadedScene {
        scene,
        file,
        warnings,
    })
}

/// `[environment]`: the map (scaled) and `world_from_env`.
fn environment(
    cx: Ctx,
    file: &SceneFile,
    resolve: &impl Fn(&str) -> PathBuf,
    warnings: &mut Vec<String>,
) -> Result<(EnvMap, glam::Mat3), SceneError> {
    let e = &file.environment;
    let scale = cx.non_negative("environment.scale", e.scale.unwrap_or(DEFAULT_ENV_SCALE))?;
    let rot = cx.angles("environment.rotate", e.rotate.unwrap_or(DEFAULT_ROTATE_DEG))?;
    let mut env = match (&e.file, &e.builtin) {
        (Some(_), Some(_)) => {
            return Err(cx.err("environment", "give either `file` or `builtin`, not both"));
        }
        (Some(f), None) => {
            let p = resolve(f);
            let (env, report) = relight_assets::load_env_map(&p)
                .map_err(|source| cx.file_err("environment.file", source))?;
            warnings.extend(report.warnings);
            env
        }
        (None, b) => {
            let name = b.as_deref().unwrap_or(DEFAULT_ENVIRONMENT);
            builtin_environment(name).ok_or_else(|| {
                cx.err(
                    "environment.builtin",
                    format!(
                        "unknown built-in environment `{name}` (known: {})",
                        BUILTIN_ENVIRONMENTS.join(", ")
                    ),
                )
            })?
        }
    };
    if scale != 1.0 {
        env.texels.iter_mut().for_each(|t| *t *= scale);
    }
    Ok((env, rotation_from_yaw_pitch_roll(rot)))
}

fn parse_brdf(cx: Ctx, key: &str, spec: &str) -> Result<Arc<dyn Brdf>, SceneError> {
    Ok(spec
        .parse::<BrdfSpec>()
        .map_err(|e| cx.err(key, e.to_string()))?
        .build())
}

/// `T(translate) · R(rotate) · S(scale)`.
fn placement(
    cx: Ctx,
    key: &str,
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<f32>,
) -> Result<(Vec3, Quat, f32), SceneError> {
    let t = cx.vec3(
        &format!("{key}.translate"),
        translate.unwrap_or(DEFAULT_TRANSLATE),
    )?;
    let r = cx.angles(
        &format!("{key}.rotate"),
        rotate.unwrap_or(DEFAULT_ROTATE_DEG),
    )?;
    let s = cx.positive(
        &format!("{key}.scale"),
        scale.unwrap_or(DEFAULT_OBJECT_SCALE),
    )?;
    Ok((t, Quat::from_mat3(&rotation_from_yaw_pitch_roll(r)), s))
}

fn object(
    cx: Ctx,
    key: &str,
    o: &ObjectDesc,
    resolve: &impl Fn(&str) -> PathBuf,
    warnings: &mut Vec<String>,
) -> Result<Object, SceneError> {
    let (mut mesh, mesh_name) = match (&o.mesh, &o.builtin) {
        (Some(m), None) => {
            if crate::BUILTIN_MESHES.contains(&m.as_str()) && !resolve(m).exists() {
                return Err(cx.err(
                    &format!("{key}.mesh"),
                    format!("`{m}` is a built-in shape, not a file: write `builtin = \"{m}\"`"),
                ));
            }
            let p = resolve(m);
            let (mesh, report) = relight_assets::load_mesh(&p)
                .map_err(|source| cx.file_err(&format!("{key}.mesh"), source))?;
            // The asset layer's warnings name the file already.
            warnings.extend(report.warnings);
            (mesh, m.clone())
        }
        (None, Some(b)) => {
            let mesh = builtin_mesh(b).ok_or_else(|| {
                cx.err(
                    &format!("{key}.builtin"),
                    format!(
                        "unknown built-in mesh `{b}` (known: {})",
                        crate::BUILTIN_MESHES.join(", ")
                    ),
                )
            })?;
            (mesh, b.clone())
        }
        _ => {
            return Err(cx.err(
                key,
                format!(
                    "give exactly one of `mesh` (a file) or `builtin` ({})",
                    crate::BUILTIN_MESHES.join(", ")
                ),
            ));
        }
    };
    let brdf = parse_brdf(
        cx,
        &format!("{key}.brdf"),
        o.brdf.as_deref().unwrap_or(DEFAULT_BRDF),
    )?;
    let needs_uvs = |what: &str| -> Result<(), SceneError> {
        if mesh.uvs.is_empty() {
            Err(cx.err(
                &format!("{key}.{what}"),
                format!(
                    "mesh `{mesh_name}` has no texture coordinates (uvs) to map it with; \
                     use a mesh with uvs or a builtin shape"
                ),
            ))
        } else {
            Ok(())
        }
    };
    let normal_map = match &o.normal_map {
        Some(f) => {
            needs_uvs("normal_map")?;
            let k = format!("{key}.normal_map");
            let (m, w) = load_normal_map(&resolve(f)).map_err(|source| SceneError::Texture {
                context: cx.context(&k),
                source,
            })?;
            warnings.extend(w);
            Some(Arc::new(m))
        }
        None => None,
    };
    let blend = match &o.blend {
        Some(b) => {
            needs_uvs("blend")?;
            let second = parse_brdf(cx, &format!("{key}.blend.brdf"), &b.brdf)?;
            let k = format!("{key}.blend.weight");
            let (weight, w) =
                load_weight_texture(&resolve(&b.weight)).map_err(|source| SceneError::Texture {
                    context: cx.context(&k),
                    source,
                })?;
            warnings.extend(w);
            Some(BrdfBlend {
                second,
                weight: Arc::new(weight),
            })
        }
        None => None,
    };
    // A normal map needs the tangent frame: repair it from the uvs.
    if normal_map.is_some() && mesh.tangents.len() != mesh.positions.len() {
        mesh.tangents = mesh.compute_tangents();
        if mesh.tangents.is_empty() {
            return Err(cx.err(
                &format!("{key}.normal_map"),
                format!("mesh `{mesh_name}`: cannot build tangents from its uvs"),
            ));
        }
    }
    let (t, r, s) = placement(cx, key, o.translate, o.rotate, o.scale)?;
    let xf = Affine3A::from_scale_rotation_translation(Vec3::splat(s), r, t);
    let animation = if o.keyframes.is_empty() {
        None
    } else {
        Some(Arc::new(animation(cx, key, &o.keyframes)?))
    };
    let mut obj = Object::new(Arc::new(mesh.transformed(xf)), brdf);
    obj.normal_map = normal_map;
    obj.blend = blend;
    obj.animation = animation;
    Ok(obj)
}

fn animation(cx: Ctx, key: &str, keys: &[KeyframeDesc]) -> Result<Animation, SceneError> {
    let mut out = Vec::with_capacity(keys.len());
    for (i, k) in keys.iter().enumerate() {
        let kk = format!("{key}.keyframe[{}]", i + 1);
        let time = cx.finite(&format!("{kk}.time"), k.time)?;
        if let Some(prev) = keys[..i].iter().position(|p| p.time == time) {
            return Err(cx.err(
                &format!("{kk}.time"),
                format!("time {time} repeats keyframe[{}]", prev + 1),
            ));
        }
        let (translate, rotation, scale) = placement(cx, &kk, k.translate, k.rotate, k.scale)?;
        out.push(Keyframe {
            time,
            translate,
            rotation,
            scale,
        });
    }
    Animation::try_new(out).map_err(|m| cx.err(&format!("{key}.keyframe"), m))
}

/// A camera's up when none is given: [`DEFAULT_CAMERA_UP`], or
/// [`DEFAULT_CAMERA_UP_VERTICAL`] when the unit `view` direction is within
/// [`VERTICAL_NORMAL_COS`] of ±Y (a top-down camera), so that no default
/// is parallel to the view.
#[must_use]
pub fn default_camera_up(view: Vec3) -> Vec3 {
    if view.y.abs() > VERTICAL_NORMAL_COS {
        Vec3::from(DEFAULT_CAMERA_UP_VERTICAL)
    } else {
        Vec3::from(DEFAULT_CAMERA_UP)
    }
}

fn camera(
    cx: Ctx,
    c: Option<&CameraDesc>,
    size: Option<(usize, usize)>,
    objects: &[Object],
) -> Result<Camera, SceneError> {
    let file_size = c.and_then(|c| c.size);
    if let Some([w, h]) = file_size
        && !((1..=MAX_IMAGE_SIDE).contains(&w) && (1..=MAX_IMAGE_SIDE).contains(&h))
    {
        return Err(cx.err(
            "camera.size",
            format!("both sides must be in 1..={MAX_IMAGE_SIDE} pixels (got [{w}, {h}])"),
        ));
    }
    let [dw, dh] = DEFAULT_IMAGE_SIZE;
    let (w, h) = size.or(file_size.map(|[w, h]| (w, h))).unwrap_or((dw, dh));
    let Some(c) = c else {
        return Ok(framing_camera(objects, w, h, DEFAULT_FOV_DEG));
    };
    let eye = cx.vec3("camera.eye", c.eye)?;
    let target = cx.vec3("camera.target", c.target)?;
    let view = cx
        .direction("camera.target", (target - eye).to_array())
        .map_err(|_| {
            cx.err(
                "camera.target",
                format!("must differ from camera.eye (both {eye})"),
            )
        })?;
    let up = match c.up {
        Some(u) => cx.direction("camera.up", u)?,
        None => default_camera_up(view),
    };
    if up.cross(view).length() < 1e-3 {
        return Err(cx.err(
            "camera.up",
            format!(
                "degenerate orientation: up {up} is parallel to the view direction {view}; give \
                 another up (or none: a vertical view then takes {})",
                Vec3::from(DEFAULT_CAMERA_UP_VERTICAL)
            ),
        ));
    }
    let fov = cx.finite("camera.fov", c.fov.unwrap_or(DEFAULT_FOV_DEG))?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(cx.err(
            "camera.fov",
            format!("must lie in (0, 180) degrees (got {fov})"),
        ));
    }
    Ok(Camera {
        eye,
        target,
        up,
        vfov_deg: fov,
        width: w,
        height: h,
        image_offset: glam::Vec2::ZERO,
    })
}
