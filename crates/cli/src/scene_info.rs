//! `relight info SCENE.toml`: what a scene file holds (objects too coarse
//! for per-vertex shadows marked, `Scene::coarse_objects`), its features,
//! and which methods render it, feature by feature through the method
//! interface (`Relighter::supports`, then `Relighter::check_objects`),
//! before anything is baked.

use anyhow::Result;
use relight_methods::{MethodKind, MethodOptions};
use relight_render::method::{MethodError, SceneFeature, Support};
use relight_render::{Numbered, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// True when `path` names a scene file (by its extension).
pub fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// Loads the scene file at `path` and describes it (the loader's warnings
/// first, one line each).
///
/// # Errors
/// The scene file's one-line error.
pub fn describe_scene_file(path: &Path) -> Result<String> {
    let loaded = relight_scene::load_scene_file(path, None)?;
    crate::output::warn_all(&loaded.warnings);
    Ok(describe(path, &loaded.scene))
}

/// The description of `scene` (loaded from `path`): one header line, then
/// indented lines as `relight info` prints them for other files.
pub fn describe(path: &Path, scene: &Scene) -> String {
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let mut s = format!(
        "{}: scene, {}, {}, {}, camera {}×{}",
        path.display(),
        plural(scene.objects.len(), "object"),
        plural(scene.point_lights.len(), "point light"),
        plural(scene.area_lights.len(), "area light"),
        scene.camera.width,
        scene.camera.height
    );
    // What triple, nearfield and wavelet --ao would shade instead.
    let (_, refined, still) = scene.with_coarse_objects_refined();
    for (i, o) in scene.objects.iter().enumerate() {
        let m = &o.mesh;
        let mut extras = Vec::new();
        let describe = |c: &relight_render::CoarseObject| {
            let under = c
                .near
                .map_or(String::new(), |j| format!(" under {}", Numbered::object(j)));
            format!(
                "vertices about {:.2} apart{under}: too coarse for per-vertex shadows",
                c.spacing
            )
        };
        let left = still.iter().find(|c| c.object == i);
        if let Some(r) = refined.iter().find(|r| r.coarse.object == i) {
            extras.push(format!(
                "{} (triple, nearfield and wavelet --ao shade a copy refined to {} vertices{})",
                describe(&r.coarse),
                r.vertices,
                if left.is_some() {
                    ", still too coarse: give it a finer mesh"
                } else {
                    ""
                }
            ));
        } else if let Some(c) = left {
            extras.push(format!(
                "{} (a refined copy would pass {} vertices: give it a finer mesh)",
                describe(c),
                relight_render::REFINED_MAX_VERTICES
            ));
        }
        if o.normal_map.is_some() {
            extras.push("normal map".to_string());
        }
        if o.blend.is_some() {
            extras.push("BRDF blend".to_string());
        }
        if let Some(a) = &o.animation {
            extras.push(format!("{} keyframes", a.keys().len()));
        }
        let _ = write!(
            s,
            "\n  {}:   {} vertices, {}{}",
            Numbered::object(i),
            m.vertex_count(),
            plural(m.triangle_count(), "triangle"),
            if extras.is_empty() {
                String::new()
            } else {
                format!(", {}", extras.join(", "))
            }
        );
    }
    let features = SceneFeature::of_scene(scene);
    let names: Vec<&str> = features.iter().map(|f| f.describe()).collect();
    let _ = write!(
        s,
        "\n  features:   {}",
        if names.is_empty() {
            "none (nothing lights it)".to_string()
        } else {
            names.join(", ")
        }
    );
    for w in scene.lighting_warnings() {
        let _ = write!(s, "\n  warning:    {w}");
    }
    let _ = write!(
        s,
        "\n  methods (by feature; `relight render SCENE --method NAME`):"
    );
    // A method that does not follow motion renders a moving scene posed
    // (`posed_for`): animation decides how, not whether.
    let still: Vec<SceneFeature> = features
        .iter()
        .copied()
        .filter(|&f| f != SceneFeature::Animation)
        .collect();
    for kind in MethodKind::ALL {
        let verdict = match relight_methods::create(&MethodOptions::default_for(kind)) {
            Ok(method) => {
                let mut v = verdict(&still, |f| method.supports(f));
                if !v.starts_with("cannot")
                    && let Err(e) = method.check_objects(scene)
                {
                    // The message without its "method NAME: " prefix.
                    let text = match e {
                        MethodError::InvalidOption { message, .. } => message,
                        e => {
                            let text = e.to_string();
                            let prefix = format!("method {}: ", kind.name());
                            text.strip_prefix(&prefix)
                                .map_or(text.clone(), str::to_string)
                        }
                    };
                    v = format!("cannot render {text}");
                }
                if scene.is_animated() {
                    v.push_str(
                        if relight_render::method::follows_animation(method.as_ref()) {
                            "; follows the motion"
                        } else {
                            "; prepared again at each pose"
                        },
                    );
                }
                v
            }
            Err(e) => format!("cannot be created: {e}"),
        };
        let _ = write!(s, "\n    {:<15} {verdict}", kind.name());
    }
    if features.contains(&SceneFeature::Environment) && s.contains("cannot render environment") {
        let _ = write!(s, "\n  note:       {}", crate::scene_args::STUDIO_ENV_HINT);
    }
    s
}

/// One method's line: every feature it cannot render, else those it renders
/// only approximately (with `--approximate`), else that it renders them all.
fn verdict(features: &[SceneFeature], supports: impl Fn(SceneFeature) -> Support) -> String {
    let (mut missing, mut approximate) = (Vec::new(), Vec::new());
    for &f in features {
        match supports(f) {
            Support::Full => {}
            Support::Approximate(how) => approximate.push(format!("{f} ({how})")),
            Support::No => missing.push(f.describe()),
        }
    }
    if !missing.is_empty() {
        format!("cannot render {}", missing.join(", "))
    } else if !approximate.is_empty() {
        format!("with --approximate: {}", approximate.join("; "))
    } else {
        "renders every feature".to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The embedded scene: the reference renders everything; a method that
    /// lacks a feature is named with it; approximations say how.
    #[test]
    fn verdicts_name_the_features() {
        let scene = relight_scene::default_scene(16, 9);
        let text = describe(Path::new("default.toml"), &scene);
        let line = |name: &str| {
            text.lines()
                .find(|l| l.trim_start().starts_with(&format!("{name} ")))
                .unwrap_or_else(|| panic!("no line for {name} in:\n{text}"))
                .to_string()
        };
        assert!(
            line("reference").ends_with("renders every feature"),
            "{text}"
        );
        assert!(
            line("nearfield").contains("cannot render environment lighting"),
            "{text}"
        );
        assert!(text.contains("camera 16×9"), "{text}");
        // A moving scene: every method renders it, posed or following.
        let mut moving = scene.clone();
        moving.objects[0].animation = Some(std::sync::Arc::new(
            relight_render::Animation::try_new(vec![relight_render::Keyframe {
                time: 0.0,
                translate: glam::Vec3::ZERO,
                rotation: glam::Quat::IDENTITY,
                scale: 1.0,
            }])
            .unwrap(),
        ));
        let text = describe(Path::new("moving.toml"), &moving);
        assert!(text.contains("animation (moving objects)"), "{text}");
        assert!(!text.contains("cannot render animation"), "{text}");
        assert!(text.contains("; prepared again at each pose"), "{text}");
        let v = verdict(&[SceneFeature::Visibility], |_| Support::Approximate("AO"));
        assert_eq!(v, "with --approximate: visibility (shadows) (AO)");
    }
}
