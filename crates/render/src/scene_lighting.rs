//! What lights a scene: the warnings for a scene whose image would be black
//! (or whose lights miss the objects) through no fault of a method.
//!
//! A scene with a black environment and no light, or an area light whose
//! every object vertex lies behind its emitting side, renders black or
//! loses that light in every method and in the reference alike: it is the
//! scene, not a method, that is wrong, and nothing else would say so.
//! [`crate::method::check_scene`] returns these warnings with the method's
//! own, so the CLI prints them and the viewer shows them on screen.

use crate::Numbered;
use crate::scene::{AreaLight, Scene};

/// Whether `light` emits anything: a positive intensity in some channel,
/// times a texture that is not all black.
fn emits(light: &AreaLight) -> bool {
    let texture = light
        .texture
        .as_ref()
        .is_none_or(|t| t.texels.iter().any(|x| x.max_element() > 0.0));
    light.intensity.max_element() > 0.0 && texture
}

impl Scene {
    /// One line per way the scene's lighting misses its objects, each
    /// beginning `scene:` (empty for a lit scene):
    /// - nothing emits: the environment is black, and no point light or
    ///   area light has a positive intensity (a textured area light also
    ///   needs a texel that is not black);
    /// - an emitting area light with every vertex of every object on or
    ///   behind its plane (one-sided lights emit along `+ẑ` only), objects
    ///   that move excepted (they may come in front of it).
    #[must_use]
    pub fn lighting_warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let point = self
            .point_lights
            .iter()
            .any(|l| l.intensity.max_element() > 0.0);
        if !self.has_environment() && !point && !self.area_lights.iter().any(emits) {
            out.push(
                "scene: nothing lights it (the environment is black, and no point or area light emits): every method renders it black"
                    .to_string(),
            );
            return out;
        }
        let still: Vec<_> = self
            .objects
            .iter()
            .filter(|o| o.animation.is_none())
            .collect();
        if still.is_empty() || still.len() < self.objects.len() {
            return out;
        }
        for (i, light) in self.area_lights.iter().enumerate() {
            if !emits(light) {
                continue;
            }
            let n = light.normal();
            let in_front = still.iter().any(|o| {
                o.mesh
                    .positions
                    .iter()
                    .any(|p| (*p - light.center).dot(n) > 0.0)
            });
            if !in_front {
                out.push(format!(
                    "scene: {} lights none of the objects: every vertex is on or behind its plane (it emits on one side only, towards {:.2})",
                    Numbered::area_light(i),
                    n
                ));
            }
        }
        out
    }
}
