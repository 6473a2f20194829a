//! `relight demo`: the embedded scene rendered by every method, side by
//! side, each labelled with its time per frame and its error against the
//! reference — the product in one image, with no files.
//!
//! # What each tile is
//! The scene is [`relight_scene::default_scene`] with visibility on, so the
//! floor shows the objects' shadows. Each method is checked against it
//! ([`check_scene`]) and renders
//! * the scene as it is when it renders every feature, approximations
//!   accepted and named in its tile (the wavelet method's shadows are
//!   per-vertex ambient occlusion, [`DEMO_AO_RAYS`] rays, wavelet-rotation-2006
//!   §3 step 2: contact shadows, not the sun's);
//! * the scene **unshadowed** when visibility is the feature it cannot render
//!   (SH environment shading computes the unshadowed integral): the tile says
//!   so, and its error against the shadowed reference includes the missing
//!   shadows;
//! * nothing when it cannot render the scene even so: a tile saying why.
//!
//! The shexp tile shows the sun's shadows soft, as an order-n visibility
//! holds them (sphere sets of the blockers, SH exponentiation), and shades
//! the metals as diffuse with their albedo; its notes say so (the method's
//! own [`Relighter::warnings`](relight_render::method::Relighter::warnings),
//! which every tile adds after rendering).
//!
//! # What the labels measure
//! * **ms per frame**: a second frame at the tile's size and AA, after the
//!   first (warm caches): [`FrameTimings::view_ms`](relight_render::method::FrameTimings::view_ms), the view change a
//!   viewer pays when the camera moves; **relight** is one
//!   [`Relighter::set_lighting`](relight_render::Relighter::set_lighting) with the environment turned by
//!   [`DEMO_LIGHT_TURN_DEG`] (and back), the lighting change. The reference
//!   shows the seconds of its one frame.
//! * **bake**: [`Relighter::prepare`](relight_render::Relighter::prepare), bake or cache load.
//! * **error**: relative RMS over object pixels (fully covered in both
//!   images: the `relight compare` measure), against the reference of
//!   [`DEMO_SPP`] samples per pixel; its own Monte Carlo noise over the
//!   same pixels (`σ_MC`, [`relight_render::method::Noise::object_rms_relative_std_error`],
//!   shown in its tile) is part of every figure.
//!
//! Timings are of whatever machine runs it; `relight bench` measures them
//! properly.

use crate::sheet::{Cell, Sheet, compose};
use crate::state::ViewerError;
use crate::text::{GREEN, GREY, Line, YELLOW};
use relight_methods::{MethodKind, MethodOptions};
use relight_render::method::{
    FrameRequest, MethodError, Rendered, SceneFeature, check_scene, render_frame,
};
use relight_render::{Progress, Scene};
use std::time::Instant;

/// Tile size of the demo unless `--size` says otherwise.
pub const DEMO_TILE: (usize, usize) = (480, 270);
/// Samples per pixel side of the raster methods' tiles.
pub const DEMO_AA: usize = 2;
/// Samples per pixel of the reference tile.
pub const DEMO_SPP: u32 = 64;
/// Per-vertex AO rays of the wavelet tile (its shadows).
pub const DEMO_AO_RAYS: u32 = 32;
/// Octahedral resolution n of the wavelet tile: n = 32 (N = 1024, 5.6°
/// texels) bakes in seconds from a cold cache where the default n = 64
/// takes most of the demo's budget.
pub const DEMO_WAVELET_N: usize = 32;
/// Cosine-weighted ray strata per side of the shexp tile's static
/// visibility bake: 6 (36 rays per vertex, about the wavelet tile's
/// [`DEMO_AO_RAYS`]); the method's default 12 (144 rays) spends about 10 s
/// on the embedded scene's 209 K vertices.
pub const DEMO_SHEXP_STRATA: usize = 6;
/// The environment turn of the timed lighting change, degrees about +Y.
pub const DEMO_LIGHT_TURN_DEG: f32 = 30.0;

/// The methods of the demo, in tile order: the reference first (the judge).
pub const DEMO_METHODS: [MethodKind; 5] = [
    MethodKind::Reference,
    MethodKind::Wavelet,
    MethodKind::Sh,
    MethodKind::Fog,
    MethodKind::ShExp,
];

/// The demo's own settings of a method (on top of `options`, which carry the
/// user's flags): applied where the user gave none (`user_set` false).
pub fn apply_demo_defaults(options: &mut MethodOptions, user_set: &DemoUserSet) {
    match options {
        MethodOptions::Reference(r) if !user_set.spp => r.spp = DEMO_SPP,
        MethodOptions::Wavelet(w) => {
            if !user_set.ao {
                w.ao = DEMO_AO_RAYS;
            }
            if !user_set.n {
                w.n = DEMO_WAVELET_N;
            }
        }
        MethodOptions::ShExp(x) => x.bake_strata = DEMO_SHEXP_STRATA,
        _ => {}
    }
}

/// Which demo defaults the user overrode on the command line.
#[derive(Clone, Copy, Debug, Default)]
pub struct DemoUserSet {
    pub spp: bool,
    pub ao: bool,
    pub n: bool,
}

/// One method's tile.
#[derive(Clone, Debug)]
pub struct DemoTile {
    pub method: MethodKind,
    /// The frame, or why the method cannot render the scene.
    pub rendered: Result<Rendered, String>,
    /// What the tile shows differently from the scene (unshadowed,
    /// approximated).
    pub notes: Vec<String>,
    /// Seconds of `prepare`.
    pub prepare_s: f64,
    /// Milliseconds of a warm frame (raster methods) or of the one frame
    /// (the reference).
    pub frame_ms: f64,
    /// Milliseconds of one lighting change (0 for the reference).
    pub lighting_ms: f64,
    /// Relative RMS error against the reference over object pixels.
    pub error: Option<f64>,
}

/// The demo's scene at `width × height`: the default scene with shadows.
#[must_use]
pub fn demo_scene(width: usize, height: usize) -> Scene {
    let mut s = relight_scene::default_scene(width, height);
    s.visibility = true;
    s
}

/// Renders `scene` with each of `methods` (see the module docs), errors
/// measured against the first reference among them.
///
/// # Errors
/// Bad options, a method's own failure, or cancellation (a refusal is a
/// tile, not an error).
pub fn render_demo(
    scene: &Scene,
    methods: &[MethodOptions],
    aa: usize,
    progress: &dyn Progress,
    log: &mut dyn FnMut(&DemoTile),
) -> Result<Vec<DemoTile>, ViewerError> {
    let mut tiles = Vec::new();
    for options in methods {
        progress.check().map_err(MethodError::from)?;
        let tile = render_tile(scene, options, aa, progress)?;
        log(&tile);
        tiles.push(tile);
    }
    let reference = tiles
        .iter()
        .position(|t| t.method == MethodKind::Reference && t.rendered.is_ok());
    if let Some(ri) = reference {
        let (r_img, r_cov) = match &tiles[ri].rendered {
            Ok(r) => (r.image.clone(), r.coverage.clone()),
            Err(_) => unreachable!("checked above"),
        };
        for (i, t) in tiles.iter_mut().enumerate() {
            if i == ri {
                continue;
            }
            if let Ok(r) = &t.rendered {
                let mask: Option<Vec<bool>> = match (&r.coverage, &r_cov) {
                    (Some(a), Some(b)) => Some(
                        a.object_mask()
                            .iter()
                            .zip(b.object_mask())
                            .map(|(x, y)| *x && y)
                            .collect(),
                    ),
                    _ => None,
                };
                t.error = Some(r.image.relative_rms_error(&r_img, mask.as_deref()));
            }
        }
    }
    Ok(tiles)
}

fn render_tile(
    scene: &Scene,
    options: &MethodOptions,
    aa: usize,
    progress: &dyn Progress,
) -> Result<DemoTile, ViewerError> {
    let kind = options.kind();
    let mut tile = DemoTile {
        method: kind,
        rendered: Err(String::new()),
        notes: Vec::new(),
        prepare_s: 0.0,
        frame_ms: 0.0,
        lighting_ms: 0.0,
        error: None,
    };
    let mut method = relight_methods::create(options)?;
    let mut unshadowed;
    let mut scene = scene;
    match check_scene(method.as_ref(), scene, true) {
        Ok(w) => tile.notes.extend(w),
        Err(MethodError::Unsupported {
            feature: SceneFeature::Visibility,
            ..
        }) => {
            unshadowed = scene.clone();
            unshadowed.visibility = false;
            scene = &unshadowed;
            match check_scene(method.as_ref(), scene, true) {
                Ok(w) => {
                    tile.notes.push(format!(
                        "unshadowed: {kind} cannot render visibility (shadows)"
                    ));
                    tile.notes.extend(w);
                }
                Err(e) => {
                    tile.rendered = Err(e.to_string());
                    return Ok(tile);
                }
            }
        }
        Err(e @ MethodError::Unsupported { .. }) => {
            tile.rendered = Err(e.to_string());
            return Ok(tile);
        }
        Err(e) => return Err(e.into()),
    }
    let t = Instant::now();
    match method.prepare(scene, progress) {
        Ok(()) => {}
        // What the method finds wrong with this scene only when it looks
        // closer (ndf: the objects' BRDF is not the one its options name) is
        // that tile's message; the other tiles still render.
        Err(e @ (MethodError::Unsupported { .. } | MethodError::InvalidOption { .. })) => {
            tile.rendered = Err(e.to_string());
            return Ok(tile);
        }
        Err(e) => return Err(e.into()),
    }
    tile.prepare_s = t.elapsed().as_secs_f64();
    let aa = if kind == MethodKind::Reference { 1 } else { aa };
    let request = FrameRequest::new(scene.camera).with_aa(aa);
    let t = Instant::now();
    let mut out = render_frame(method.as_mut(), scene, &request, progress)?;
    tile.frame_ms = t.elapsed().as_secs_f64() * 1e3;
    if out.noise.is_none() {
        // Deterministic: a lighting change there and back, then a warm frame.
        let mut turned = scene.clone();
        turned.world_from_env =
            glam::Mat3::from_rotation_y(DEMO_LIGHT_TURN_DEG.to_radians()) * scene.world_from_env;
        tile.lighting_ms = method.set_lighting(&turned, progress)?;
        method.set_lighting(scene, progress)?;
        out = render_frame(method.as_mut(), scene, &request, progress)?;
        tile.frame_ms = out.timings.view_ms + out.timings.lighting_ms;
    }
    // What the method itself says it approximated (e.g. a BRDF it shades as
    // diffuse), after it saw the scene.
    let own = format!("{kind}: ");
    for w in method.warnings() {
        // The tile and the log name the method already.
        let w = w.strip_prefix(&own).map_or(w.clone(), str::to_string);
        if !tile.notes.contains(&w) {
            tile.notes.push(w);
        }
    }
    tile.rendered = Ok(out);
    Ok(tile)
}

/// The label of a tile: title and detail lines.
#[must_use]
pub fn tile_cell(tile: &DemoTile) -> Cell {
    let r = tile.rendered.as_ref();
    let title = match (r, tile.method) {
        (Err(_), m) => format!("{m}: cannot render this scene"),
        (Ok(_), MethodKind::Reference) => {
            format!("{}  {:.1} s", tile.method, tile.frame_ms / 1e3)
        }
        (Ok(_), m) => format!("{m}  {:.1} ms/frame", tile.frame_ms),
    };
    let mut details = Vec::new();
    if let Ok(out) = r {
        if let Some(n) = out.noise {
            details.push(Line::new(
                format!(
                    "Monte Carlo, {} spp: σ_MC {:.1} % over objects (judge)",
                    n.spp,
                    100.0 * n.object_rms_relative_std_error
                ),
                GREEN,
            ));
        } else {
            details.push(Line::new(
                match tile.error {
                    Some(e) => format!("error {:.1} % rel. RMS vs reference", 100.0 * e),
                    None => "error: no reference rendered".into(),
                },
                GREEN,
            ));
            details.push(Line::new(
                format!(
                    "relight {:.1} ms · bake/load {:.1} s",
                    tile.lighting_ms, tile.prepare_s
                ),
                GREY,
            ));
        }
    }
    for n in &tile.notes {
        details.push(Line::new(shorten(n), YELLOW));
    }
    Cell {
        title,
        details,
        image: r.map(|o| o.image.clone()).map_err(Clone::clone),
    }
}

/// Notes the tiles print, shortened to the gist (the log keeps them whole).
fn shorten(note: &str) -> String {
    let note = note
        .strip_prefix("method ")
        .map_or(note.to_string(), str::to_string)
        .replace(
            "renders visibility (shadows) approximately: per-vertex ambient occlusion × unshadowed radiance, wavelet-rotation-2006 §3 step 2",
            "shadows: per-vertex AO × unshadowed radiance (§3)",
        );
    // shexp's "object i: its BRDF is not Lambertian; shaded as diffuse with
    // albedo (r, g, b)": the albedo does not fit a tile's line.
    if let Some((object, _)) = note.split_once(": its BRDF is not Lambertian; shaded as diffuse") {
        return format!("{object}: not Lambertian, shaded as diffuse");
    }
    // sh's "object i: order n cannot represent this BRDF's lobe (…); the W
    // window changes it by x % — raise --order …": three lines of a tile.
    lobe_gist(&note).unwrap_or(note)
}

/// The gist of sh's lobe warning (`relight_shlight::ShMethod::lobe_warnings`):
/// `object i: lobe too sharp for order n; W window: x %` (the lobe's
/// relative change), which fits a 480-pixel tile's line; `None` for any
/// other note.
fn lobe_gist(note: &str) -> Option<String> {
    let (object, rest) = note.split_once(": order ")?;
    let (order, rest) = rest.split_once(" cannot represent this BRDF's lobe")?;
    let (_, rest) = rest.split_once("; the ")?;
    let (window, rest) = rest.split_once(" window changes it by ")?;
    let (change, _) = rest.split_once(" %")?;
    Some(format!(
        "{object}: lobe too sharp for order {order}; {window} window: {change} %"
    ))
}

/// The labelled sheet of `tiles` at `width × height` each.
#[must_use]
pub fn demo_sheet(tiles: &[DemoTile], width: usize, height: usize) -> Sheet {
    let cells: Vec<Cell> = tiles.iter().map(tile_cell).collect();
    compose(&cells, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;
    use relight_render::NoProgress;

    #[test]
    fn every_method_gets_a_tile_with_its_shadows_or_a_note_and_an_error() {
        let (w, h) = (48, 27);
        let scene = demo_scene(w, h);
        let cache = std::env::temp_dir().join(format!("relight-demo-test-{}", std::process::id()));
        // The wavelet bake's cache goes when the test ends, pass or fail
        // (it was left behind, one folder per run).
        struct RemoveOnDrop(std::path::PathBuf);
        impl Drop for RemoveOnDrop {
            fn drop(&mut self) {
                let _ = std::fs::remove_dir_all(&self.0);
            }
        }
        let _cleanup = RemoveOnDrop(cache.clone());
        let methods: Vec<MethodOptions> = DEMO_METHODS
            .into_iter()
            .map(|k| {
                let mut o = MethodOptions::default_for(k);
                apply_demo_defaults(&mut o, &DemoUserSet::default());
                match &mut o {
                    MethodOptions::Reference(r) => r.spp = 4,
                    MethodOptions::Wavelet(wv) => {
                        wv.n = 16;
                        wv.ntess = 4;
                        wv.terms = 64;
                        wv.ao = 4;
                        wv.cache_dir = cache.clone();
                    }
                    MethodOptions::Sh(s) => s.order = 3,
                    MethodOptions::Fog(_)
                    | MethodOptions::ShExp(_)
                    | MethodOptions::RadianceCache(_)
                    | MethodOptions::Ndf(_)
                    | MethodOptions::Triple(_)
                    | MethodOptions::Nearfield(_)
                    | MethodOptions::Ltc(_) => {}
                }
                o
            })
            .collect();
        let mut logged = 0;
        let tiles = render_demo(&scene, &methods, 1, &NoProgress, &mut |_| logged += 1).unwrap();
        assert_eq!(logged, DEMO_METHODS.len());
        let by = |k: MethodKind| tiles.iter().find(|t| t.method == k).unwrap();
        let reference = by(MethodKind::Reference);
        assert!(reference.rendered.is_ok() && reference.error.is_none());
        // The judge's noise over the pixels the errors are measured on.
        let judge = &tile_cell(reference).details[0].text;
        assert!(judge.contains("over objects"), "{judge}");
        // Wavelet renders the shadows approximately (AO), and says so.
        let wavelet = by(MethodKind::Wavelet);
        assert!(
            wavelet.notes.iter().any(|n| n.contains("approximately")),
            "{:?}",
            wavelet.notes
        );
        // SH renders unshadowed, and says so.
        let sh = by(MethodKind::Sh);
        assert!(
            sh.notes.iter().any(|n| n.starts_with("unshadowed")),
            "{:?}",
            sh.notes
        );
        // shexp shades the metals as diffuse, and says so.
        let shexp = by(MethodKind::ShExp);
        assert!(
            shexp.notes.iter().any(|n| n.contains("not Lambertian")),
            "{:?}",
            shexp.notes
        );
        for t in [wavelet, sh, by(MethodKind::Fog), shexp] {
            let e = t.error.expect("measured against the reference");
            assert!(e.is_finite() && e > 0.0 && e < 1.5, "{}: {e}", t.method);
            assert!(t.frame_ms > 0.0);
        }
        let sheet = demo_sheet(&tiles, w, h);
        assert_eq!(sheet.tiles.len(), DEMO_METHODS.len());
        let cell = tile_cell(sh);
        assert!(cell.title.starts_with("sh") && cell.title.contains("ms/frame"));
        assert!(cell.details.iter().any(|l| l.text.contains("unshadowed")));
        assert!(cell.details[0].text.contains("% rel. RMS"));
    }

    /// sh's lobe warning is shortened to one tile line; other notes pass.
    #[test]
    fn the_lobe_warning_fits_a_tile_line() {
        let long = "object 1: order 6 cannot represent this BRDF's lobe (it rings to 14 % of its \
                    peak below zero); the dering window changes it by 52 % — raise --order or use \
                    the wavelet method for sharp highlights";
        assert_eq!(
            shorten(long),
            "object 1: lobe too sharp for order 6; dering window: 52 %"
        );
        assert_eq!(
            shorten("object 2: something else"),
            "object 2: something else"
        );
    }

    #[test]
    fn a_method_that_cannot_render_the_scene_is_a_tile_saying_why() {
        let mut scene = demo_scene(32, 18);
        scene.area_lights.push(relight_render::AreaLight {
            center: glam::Vec3::Y * 3.0,
            size: glam::Vec2::ONE,
            world_from_light: glam::Mat3::from_cols(glam::Vec3::X, glam::Vec3::Z, -glam::Vec3::Y),
            intensity: glam::Vec3::ONE,
            texture: None,
            light_field: None,
        });
        let mut sh = MethodOptions::default_for(MethodKind::Sh);
        if let MethodOptions::Sh(s) = &mut sh {
            s.order = 2;
        }
        let tiles = render_demo(&scene, &[sh], 1, &NoProgress, &mut |_| {}).unwrap();
        let why = tiles[0].rendered.as_ref().unwrap_err();
        assert!(why.contains("area lights"), "{why}");
        let cell = tile_cell(&tiles[0]);
        assert!(cell.image.is_err() && cell.title.contains("cannot render"));
    }

    /// A method that refuses the scene only at `prepare` (ndf: its BRDF
    /// option is Lambert, the scene's metals are not) gets a tile saying
    /// why; the demo goes on with the next method instead of stopping.
    #[test]
    fn a_refusal_at_prepare_is_that_tiles_message() {
        let scene = demo_scene(32, 18);
        let mut sh = MethodOptions::default_for(MethodKind::Sh);
        if let MethodOptions::Sh(s) = &mut sh {
            s.order = 2;
        }
        let methods = [MethodOptions::default_for(MethodKind::Ndf), sh];
        let tiles = render_demo(&scene, &methods, 1, &NoProgress, &mut |_| {}).unwrap();
        let why = tiles[0].rendered.as_ref().unwrap_err();
        assert!(why.contains("ndf-brdf"), "{why}");
        assert!(tiles[1].rendered.is_ok());
    }
}
