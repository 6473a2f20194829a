//! Editing the scene's area light in the viewer (issue 13): move it in its
//! own plane, scale it, and give it another texture — the edits the
//! `nearfield` method makes without a re-bake (`docs/nearfield.md`,
//! *Run-time edits without a re-bake*), shown to every method alike.
//!
//! A [`LightEdit`] is kept per area light and applied to it as loaded
//! (`Tab` picks the light the edits go to, the first at the start),
//! before the lighting rotation ([`crate::Viewer`]'s right drag), so the
//! edited light is what every method (and the reference) is given through
//! `set_lighting`:
//!
//! * `offset`: the centre moved along the light's own `x̂` and `ŷ` (its
//!   plane; the normal and the height above the scene do not change);
//! * `scale`: both side lengths times this factor (about the centre);
//! * `texture`: the scene's own texture (or none), or one of three built-in
//!   procedural ones ([`LightTexture`]), scaled so that their mean equals the
//!   scene texture's (1 for an untextured light): a texture change moves the
//!   light's detail, not its power.

use glam::{Vec2, Vec3};
use relight_render::AreaLight;
use relight_render::texture::Texture;
use std::sync::Arc;

/// Texels per side of the built-in textures.
pub const TEXTURE_SIZE: usize = 64;

/// The light's side lengths are kept within this factor of the scene's.
pub const MAX_SCALE: f32 = 16.0;

/// Scale factor per wheel step.
pub const SCALE_PER_STEP: f32 = 1.1;

/// The textures the `t` key cycles the area light through.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightTexture {
    /// The scene's own (none: a uniform light).
    #[default]
    Scene,
    /// 8 × 8 cells, bright and near black.
    Checker,
    /// Nine red, green and blue bands across `u`.
    Stripes,
    /// Dark blue to bright warm white across `u`.
    Gradient,
}

impl LightTexture {
    /// In the order `t` cycles them.
    pub const ALL: [Self; 4] = [Self::Scene, Self::Checker, Self::Stripes, Self::Gradient];

    /// Its name on screen.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Scene => "scene's own",
            Self::Checker => "checker",
            Self::Stripes => "stripes",
            Self::Gradient => "gradient",
        }
    }

    /// The next in [`Self::ALL`], wrapping.
    #[must_use]
    pub fn next(self) -> Self {
        let i = Self::ALL.iter().position(|&t| t == self).unwrap_or(0);
        Self::ALL[(i + 1) % Self::ALL.len()]
    }

    /// Linear RGB at `(u, v) ∈ [0, 1)²` before the mean is matched (`None`
    /// for the scene's own).
    fn texel(self, u: f32, v: f32) -> Option<Vec3> {
        Some(match self {
            Self::Scene => return None,
            Self::Checker => {
                let cell = (u * 8.0) as usize + (v * 8.0) as usize;
                if cell.is_multiple_of(2) {
                    Vec3::ONE
                } else {
                    Vec3::splat(0.05)
                }
            }
            Self::Stripes => [Vec3::X, Vec3::Y, Vec3::Z][(u * 9.0) as usize % 3],
            Self::Gradient => Vec3::new(0.05, 0.1, 0.3).lerp(Vec3::new(1.0, 0.85, 0.6), u),
        })
    }

    /// The texture at [`TEXTURE_SIZE`]² texels with mean `mean` (channels
    /// averaged); `None` for the scene's own.
    #[must_use]
    pub fn build(self, mean: f32) -> Option<Texture> {
        let n = TEXTURE_SIZE;
        let mut texels = Vec::with_capacity(n * n);
        for y in 0..n {
            for x in 0..n {
                let (u, v) = ((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
                texels.push(self.texel(u, v)?);
            }
        }
        let own = texels.iter().map(|t| t.element_sum()).sum::<f32>() / (3 * n * n) as f32;
        let k = if own > 0.0 && mean > 0.0 {
            mean / own
        } else {
            1.0
        };
        for t in &mut texels {
            *t *= k;
        }
        Some(Texture::try_new(n, n, texels).expect("finite, non-negative, n² texels"))
    }
}

/// The built-in textures for one light, built once (their mean matched to
/// the light's own texture).
#[derive(Clone, Debug, Default)]
pub struct LightTextures {
    built: Vec<(LightTexture, Arc<Texture>)>,
}

impl LightTextures {
    /// The built-in textures with the mean of `light`'s texture (1 if it has
    /// none).
    #[must_use]
    pub fn for_light(light: &AreaLight) -> Self {
        let mean = light
            .texture
            .as_ref()
            .map_or(1.0, |t| t.mean().element_sum() / 3.0);
        Self {
            built: LightTexture::ALL
                .into_iter()
                .filter_map(|k| Some((k, Arc::new(k.build(mean)?))))
                .collect(),
        }
    }

    /// The texture of `kind` (`None` for the scene's own).
    #[must_use]
    pub fn get(&self, kind: LightTexture) -> Option<&Arc<Texture>> {
        self.built.iter().find(|(k, _)| *k == kind).map(|(_, t)| t)
    }
}

/// An edit of one of the scene's area lights (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightEdit {
    /// The centre's move along the light's own `x̂` and `ŷ` (world units).
    pub offset: Vec2,
    /// Factor on both side lengths (`1/MAX_SCALE … MAX_SCALE`).
    pub scale: f32,
    pub texture: LightTexture,
}

impl Default for LightEdit {
    fn default() -> Self {
        Self {
            offset: Vec2::ZERO,
            scale: 1.0,
            texture: LightTexture::Scene,
        }
    }
}

impl LightEdit {
    /// `light` (as loaded) with this edit. A light with a light field keeps
    /// it: its views are its texture (the HUD says so).
    #[must_use]
    pub fn apply(&self, light: &AreaLight, textures: &LightTextures) -> AreaLight {
        let mut l = light.clone();
        let axes = light.world_from_light;
        l.center += axes.x_axis * self.offset.x + axes.y_axis * self.offset.y;
        l.size *= self.scale;
        if let Some(t) = textures.get(self.texture)
            && l.light_field.is_none()
        {
            l.texture = Some(t.clone());
        }
        l
    }

    /// Scales by [`SCALE_PER_STEP`] per step (negative: smaller), within
    /// [`MAX_SCALE`].
    pub fn scale_by_steps(&mut self, steps: f32) {
        if steps.is_finite() {
            self.scale =
                (self.scale * SCALE_PER_STEP.powf(steps)).clamp(1.0 / MAX_SCALE, MAX_SCALE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_textures_differ_and_keep_the_mean() {
        let mut seen: Vec<Vec<Vec3>> = Vec::new();
        for k in LightTexture::ALL {
            let Some(t) = k.build(0.4) else {
                assert_eq!(k, LightTexture::Scene);
                continue;
            };
            let m = t.mean().element_sum() / 3.0;
            assert!((m - 0.4).abs() < 1e-4, "{}: mean {m}", k.name());
            assert!(!seen.contains(&t.texels), "{} repeats a texture", k.name());
            seen.push(t.texels);
        }
        assert_eq!(seen.len(), 3);
        // t cycles through all four and back.
        let mut k = LightTexture::Scene;
        for want in [
            LightTexture::Checker,
            LightTexture::Stripes,
            LightTexture::Gradient,
            LightTexture::Scene,
        ] {
            k = k.next();
            assert_eq!(k, want);
        }
    }

    #[test]
    fn scale_steps_compound_and_are_bounded() {
        let mut e = LightEdit::default();
        e.scale_by_steps(2.0);
        assert!((e.scale - 1.21).abs() < 1e-5, "{}", e.scale);
        e.scale_by_steps(-2.0);
        assert!((e.scale - 1.0).abs() < 1e-5, "{}", e.scale);
        e.scale_by_steps(1000.0);
        assert_eq!(e.scale, MAX_SCALE);
        e.scale_by_steps(f32::NAN);
        assert_eq!(e.scale, MAX_SCALE);
    }

    /// Issue 13 in the viewer, at a tiny size: the nearfield method (order
    /// 8, uncompressed, so a texture's detail shows) and the reference on a
    /// floor and sphere under a ceiling light.
    mod in_the_viewer {
        use super::*;
        use crate::{Viewer, ViewerOptions};
        use relight_methods::{MethodKind, MethodOptions};
        use relight_render::{NoProgress, Progress, Scene};
        use std::sync::atomic::{AtomicUsize, Ordering};

        /// Counts the phases that bake nearfield's transport (in `prepare`,
        /// or in `set_lighting` for a light whose normal changed).
        #[derive(Default)]
        struct Bakes(AtomicUsize);

        impl Progress for Bakes {
            fn start(&self, what: &str, _: u64) {
                if what.contains("transport") {
                    self.0.fetch_add(1, Ordering::Relaxed);
                }
            }
            fn inc(&self, _: u64) {}
            fn finish(&self) {}
            fn is_cancelled(&self) -> bool {
                false
            }
        }

        fn scene() -> Scene {
            relight_nearfield::scenes::floor_and_sphere(6, 8, 32, 18, true)
        }

        fn viewer(scene: Scene) -> Viewer {
            let nearfield = relight_nearfield::NearfieldOptions {
                order: 8,
                source_terms: 1.0,
                target_terms: 1.0,
                ..relight_nearfield::NearfieldOptions::default()
            };
            let reference = relight_render::ReferenceOptions {
                spp: 4,
                pass_spp: 4,
                ..relight_render::ReferenceOptions::default()
            };
            let opts = ViewerOptions {
                methods: vec![
                    MethodOptions::Nearfield(nearfield),
                    MethodOptions::Reference(reference),
                ],
                aa: 1,
                approximate: false,
            };
            Viewer::new(scene, MethodKind::Nearfield, opts).unwrap()
        }

        use crate::tests::diff;

        #[test]
        fn moves_scales_and_textures_reach_the_method_without_preparing_again() {
            let s = scene();
            let l0 = s.area_lights[0].clone();
            let (x, y) = (l0.world_from_light.x_axis, l0.world_from_light.y_axis);
            let mut v = viewer(s);
            let bakes = Bakes::default();
            let frame = |v: &mut Viewer| v.frame(32, 18, false, &bakes).unwrap();
            let f0 = frame(&mut v);
            assert!(f0.message.is_none(), "{:?}", f0.message);
            assert!(f0.image.pixels.iter().any(|p| p.element_sum() > 0.01));
            assert_eq!((v.prepares(), bakes.0.load(Ordering::Relaxed)), (1, 1));
            let light = |v: &Viewer| v.lit_scene().area_lights[0].clone();

            // Moved in its plane along its own axes.
            assert!(v.move_light(Vec2::new(0.3, -0.2)));
            let f1 = frame(&mut v);
            assert!(diff(&f0, &f1) > 0.0, "the move changed nothing");
            let l = light(&v);
            assert!((l.center - (l0.center + 0.3 * x - 0.2 * y)).length() < 1e-6);
            assert_eq!((l.size, l.world_from_light), (l0.size, l0.world_from_light));

            // Scaled by two wheel steps.
            assert!(v.scale_light(2.0));
            let f2 = frame(&mut v);
            assert!(diff(&f1, &f2) > 0.0, "the scale changed nothing");
            assert!((light(&v).size - l0.size * 1.21).abs().max_element() < 1e-5);

            // The next texture: the built-in checker, with the mean of the
            // scene's own.
            assert!(v.cycle_light_texture());
            let f3 = frame(&mut v);
            assert!(diff(&f2, &f3) > 0.0, "the texture changed nothing");
            let mean = l0.texture.as_ref().unwrap().mean().element_sum() / 3.0;
            let checker = LightTexture::Checker.build(mean).unwrap();
            assert_eq!(light(&v).texture.unwrap().texels, checker.texels);

            // A drag: the plane point under the first pixel goes under the
            // second; the light stays in its plane.
            let before = light(&v).center;
            let (from, to) = ((10.0, 4.0), (20.0, 6.0));
            assert!(v.drag_light(from, to, 32, 18));
            let f4 = frame(&mut v);
            assert!(diff(&f3, &f4) > 0.0, "the drag changed nothing");
            let rays = v.camera(32, 18).ray_frame();
            let on_plane = |(px, py): (f32, f32)| {
                let d = rays.dir(px, py);
                rays.origin() + d * ((before - rays.origin()).dot(l0.normal()) / d.dot(l0.normal()))
            };
            let moved = light(&v).center - before;
            let want = on_plane(to) - on_plane(from);
            assert!((moved - want).length() < 1e-4, "{moved} vs {want}");
            assert!(moved.length() > 0.1 && moved.dot(l0.normal()).abs() < 1e-5);

            assert_eq!(v.prepares(), 1, "an edit prepared the method again");
            assert_eq!(bakes.0.load(Ordering::Relaxed), 1, "an edit re-baked");

            // The reference is given the same edited light.
            v.select(1);
            let r = frame(&mut v);
            assert!(r.image.pixels.iter().any(|p| p.element_sum() > 0.01));
            assert_eq!(light(&v).center, before + moved);
            assert_eq!(v.prepares(), 2);

            // Reset: the light as loaded, nearfield's first frame again,
            // still without a new preparation.
            v.reset();
            v.select(0);
            let back = frame(&mut v);
            assert_eq!(light(&v).center, l0.center);
            assert!(diff(&f0, &back) <= 1e-4 * diff(&f0, &f3), "reset");
            assert_eq!((v.prepares(), bakes.0.load(Ordering::Relaxed)), (2, 1));
        }

        /// LTC is among the viewer's default methods (`relight view
        /// --method ltc`): it draws the area-lit scene (shadows ignored,
        /// said on screen) and follows a light's move and scale without
        /// preparing again.
        #[test]
        fn ltc_draws_and_follows_the_edited_light() {
            let opts = ViewerOptions {
                approximate: true,
                ..ViewerOptions::default()
            };
            assert!(opts.methods.iter().any(|m| m.kind() == MethodKind::Ltc));
            let mut v = Viewer::new(scene(), MethodKind::Ltc, opts).unwrap();
            let f0 = v.frame(32, 18, false, &NoProgress).unwrap();
            assert!(!f0.refused, "{:?}", f0.message);
            assert!(
                f0.message.as_deref().is_some_and(|m| m.contains("shadow")),
                "{:?}",
                f0.message
            );
            assert!(f0.image.pixels.iter().any(|p| p.element_sum() > 0.01));
            assert!(v.move_light(Vec2::new(0.3, -0.2)) && v.scale_light(2.0));
            let f1 = v.frame(32, 18, false, &NoProgress).unwrap();
            assert!(diff(&f0, &f1) > 0.0, "the edits changed nothing");
            assert_eq!(v.prepares(), 1);
        }

        /// With several lights, `Tab` passes the edits on: each light
        /// keeps its own edit, nearfield re-bakes nothing (the moved light
        /// stays in its plane), the HUD names the edited light, and a reset
        /// restores them all.
        #[test]
        fn tab_passes_the_edits_to_the_next_light() {
            let s = relight_nearfield::scenes::floor_and_sphere_three_lights(6, 8, 32, 18, true);
            let loaded: Vec<Vec3> = s.area_lights.iter().map(|l| l.center).collect();
            let mut v = viewer(s);
            let bakes = Bakes::default();
            let f0 = v.frame(32, 18, false, &bakes).unwrap();
            // The wall light's face-clipping warning may be on screen, no
            // refusal.
            assert!(v.refusal().is_none(), "{:?}", f0.message);
            assert!(
                f0.message
                    .as_deref()
                    .is_none_or(|m| m.contains("falls past the face")),
                "{:?}",
                f0.message
            );
            let centres = |v: &Viewer| -> Vec<Vec3> {
                v.lit_scene().area_lights.iter().map(|l| l.center).collect()
            };
            assert_eq!(v.edited_light(), 0);
            assert!(v.move_light(Vec2::new(0.2, 0.0)));
            assert!(v.edit_next_light() && v.edit_next_light());
            assert_eq!(v.edited_light(), 2);
            assert!(v.move_light(Vec2::new(0.0, -0.1)) && v.scale_light(1.0));
            let f1 = v.frame(32, 18, false, &bakes).unwrap();
            assert!(diff(&f0, &f1) > 0.0, "the edits changed nothing");
            let c = centres(&v);
            let lights = &v.lit_scene().area_lights;
            assert!((c[0] - (loaded[0] + 0.2 * lights[0].world_from_light.x_axis)).length() < 1e-6);
            assert_eq!(c[1], loaded[1], "light 2 was never edited");
            assert!((c[2] - (loaded[2] - 0.1 * lights[2].world_from_light.y_axis)).length() < 1e-6);
            assert!(
                (lights[2].size.x / 0.8 - 1.1).abs() < 1e-5,
                "{}",
                lights[2].size
            );
            assert_eq!(bakes.0.load(Ordering::Relaxed), 1, "an edit re-baked");
            let info =
                crate::hud::HudInfo::new(&v, &f1, crate::hud::ErrorReading::IsReference, 1.0);
            let status: String = info.status_lines().iter().map(|l| l.text.clone()).collect();
            assert!(status.contains("area light 3 of 3"), "{status}");
            let help: String = info.help_lines().iter().map(|l| l.text.clone()).collect();
            assert!(help.contains("Tab: next light"), "{help}");
            // Back to the first: its edit is still there.
            assert!(v.edit_next_light());
            assert_eq!(
                (v.edited_light(), v.light_edit().offset),
                (0, Vec2::new(0.2, 0.0))
            );
            // A reset restores every light, also from the never-edited
            // second light (whose own edit the reset leaves as it was).
            assert!(v.edit_next_light());
            v.frame(32, 18, false, &bakes).unwrap();
            v.reset();
            let f2 = v.frame(32, 18, false, &bakes).unwrap();
            assert_eq!(centres(&v), loaded);
            assert!(diff(&f0, &f2) <= 1e-4 * diff(&f0, &f1), "reset");
        }

        /// The method's warnings follow the lighting: moved far along its
        /// plane, the ceiling light falls past every vertex's face, which
        /// the next still frame says (no bake), and the reset takes the
        /// warning away.
        #[test]
        fn warnings_follow_the_edited_light() {
            let mut v = viewer(scene());
            let bakes = Bakes::default();
            let says = |f: &crate::Frame| {
                f.message
                    .as_deref()
                    .is_some_and(|m| m.contains("area light 1 falls past the face"))
            };
            let f0 = v.frame(32, 18, false, &bakes).unwrap();
            assert!(!says(&f0), "{:?}", f0.message);
            assert!(v.move_light(Vec2::new(12.0, 0.0)));
            // A drag's preview frames keep the warnings they had (reading
            // them costs a pass over the vertices); the still frame reads.
            let preview = v.frame(32, 18, true, &bakes).unwrap();
            assert!(!says(&preview), "{:?}", preview.message);
            let f1 = v.frame(32, 18, false, &bakes).unwrap();
            assert!(says(&f1), "{:?}", f1.message);
            v.reset();
            let f2 = v.frame(32, 18, false, &bakes).unwrap();
            assert!(!says(&f2), "{:?}", f2.message);
            assert_eq!(bakes.0.load(Ordering::Relaxed), 1, "an edit re-baked");
        }

        #[test]
        fn a_tilting_drag_bakes_once_at_the_release() {
            let mut v = viewer(scene());
            let bakes = Bakes::default();
            let f0 = v.frame(32, 18, false, &bakes).unwrap();
            assert_eq!(bakes.0.load(Ordering::Relaxed), 1);
            // A yaw turns the ceiling light in its plane: no bake, mid-drag
            // either.
            v.light_yaw_deg = 30.0;
            let f1 = v.frame(32, 18, true, &bakes).unwrap();
            assert_eq!(bakes.0.load(Ordering::Relaxed), 1);
            assert!(f1.message.is_none(), "{:?}", f1.message);
            assert!(diff(&f0, &f1) > 0.0, "the yaw changed nothing");
            // A right drag that pitches the lighting tilts the light's plane.
            for step in 1..=3 {
                v.light_pitch_deg = 10.0 * step as f32;
                let f = v.frame(32, 18, true, &bakes).unwrap();
                assert_eq!(bakes.0.load(Ordering::Relaxed), 1, "a drag frame re-baked");
                assert!(
                    f.message
                        .as_deref()
                        .is_some_and(|m| m.contains("drag ends")),
                    "{:?}",
                    f.message
                );
                assert_eq!(
                    diff(&f1, &f),
                    0.0,
                    "a deferred frame is the last lighting's"
                );
            }
            // The release. The window asks whether a bake is due and runs
            // it on its worker thread; a cancelled bake leaves it due.
            assert!(v.lighting_bake_due(), "the tilt is not announced");
            struct Cancelled;
            impl Progress for Cancelled {
                fn start(&self, _: &str, _: u64) {}
                fn inc(&self, _: u64) {}
                fn finish(&self) {}
                fn is_cancelled(&self) -> bool {
                    true
                }
            }
            assert!(v.apply_lighting(&Cancelled).is_err());
            assert!(v.lighting_bake_due(), "a cancelled bake counted as done");
            v.apply_lighting(&bakes).unwrap();
            assert_eq!(bakes.0.load(Ordering::Relaxed), 2);
            assert!(!v.lighting_bake_due());
            // The frame after it: no second bake, the tilted light, no note.
            let f = v.frame(32, 18, false, &bakes).unwrap();
            assert_eq!(bakes.0.load(Ordering::Relaxed), 2);
            assert!(f.message.is_none(), "{:?}", f.message);
            assert!(diff(&f1, &f) > 0.0, "the tilt changed nothing");
            assert_eq!(v.prepares(), 1);
            // A caller that draws straight away (no worker) bakes in the
            // still frame itself.
            v.light_pitch_deg = 40.0;
            let g = v.frame(32, 18, false, &bakes).unwrap();
            assert_eq!(bakes.0.load(Ordering::Relaxed), 3);
            assert!(diff(&f, &g) > 0.0 && !v.lighting_bake_due());
        }

        #[test]
        fn nearfield_without_an_area_light_says_why_on_screen() {
            // No environment, no area light: the method's own refusal.
            let mut s = scene();
            s.area_lights.clear();
            let mut v = viewer(s);
            let f = v.frame(32, 18, false, &NoProgress).unwrap();
            let msg = f.message.expect("a message on screen");
            assert!(
                msg.contains("nearfield") && msg.contains("area_light"),
                "{msg}"
            );
            assert!(v.refusal().is_some());
            assert!(!v.move_light(Vec2::X) && !v.scale_light(1.0));
            assert!(!v.cycle_light_texture());
            // The embedded scene (an environment, no area light): refused by
            // feature.
            let mut v = viewer(relight_scene::default_scene(32, 18));
            let f = v.frame(32, 18, false, &NoProgress).unwrap();
            let msg = f.message.expect("a message on screen");
            assert!(msg.contains("nearfield cannot render"), "{msg}");
        }

        #[test]
        fn the_hud_shows_the_light_and_its_keys() {
            let mut v = viewer(scene());
            // The reference at 1 spp is the cheapest frame here.
            v.select(1);
            v.cycle_light_texture();
            v.cycle_light_texture();
            v.light_mode = true;
            let f = v.frame(32, 18, true, &NoProgress).unwrap();
            let info = crate::hud::HudInfo::new(&v, &f, crate::hud::ErrorReading::IsReference, 1.0);
            let status: String = info.status_lines().iter().map(|l| l.text.clone()).collect();
            assert!(
                status.contains("area light: centre (0.00, 1.60, 0.00)"),
                "{status}"
            );
            assert!(
                status.contains("texture stripes") && status.contains("[editing]"),
                "{status}"
            );
            let help: String = info.help_lines().iter().map(|l| l.text.clone()).collect();
            assert!(
                help.contains("drag: move area light") && help.contains("t: light texture"),
                "{help}"
            );
            v.light_mode = false;
            let info = crate::hud::HudInfo::new(&v, &f, crate::hud::ErrorReading::IsReference, 1.0);
            let help: String = info.help_lines().iter().map(|l| l.text.clone()).collect();
            assert!(
                help.contains("drag: orbit") && help.contains("l or hold Shift"),
                "{help}"
            );
        }
    }
}
