//! Each bad value gives its own one-line error naming the file and the key.

use crate::common;

use glam::Vec3;
use relight_scene::{load_scene_file, load_scene_text};
use std::path::{Path, PathBuf};

const SPHERE: &str = "[[object]]\nbuiltin = \"sphere\"\n";

/// The error of loading `text` as `bad.toml` in `dir` (or the current folder).
fn error_in(dir: Option<&Path>, text: &str) -> String {
    let path = dir.map_or_else(|| PathBuf::from("bad.toml"), |d| d.join("bad.toml"));
    match load_scene_text(text, &path, Some((8, 8))) {
        Ok(_) => panic!("loaded:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts the error is one line, names the file and `key`, and says `what`.
fn check(text: &str, key: &str, what: &str) {
    check_in(None, text, key, what);
}

fn check_in(dir: Option<&Path>, text: &str, key: &str, what: &str) {
    let e = error_in(dir, text);
    assert!(!e.contains('\n'), "not one line: {e}");
    assert!(e.contains("bad.toml: "), "no file in: {e}");
    assert!(e.contains(&format!("{key}: ")), "no key `{key}` in: {e}");
    assert!(e.contains(what), "no `{what}` in: {e}");
}

#[test]
fn bad_numbers_name_their_key() {
    check(
        &format!("{SPHERE}scale = nan"),
        "object[1].scale",
        "finite number > 0",
    );
    check(
        &format!("{SPHERE}scale = -1"),
        "object[1].scale",
        "> 0 (got -1)",
    );
    check(
        &format!("{SPHERE}translate = [inf, 0, 0]"),
        "object[1].translate",
        "finite",
    );
    check(
        &format!("{SPHERE}rotate = [0, nan, 0]"),
        "object[1].rotate",
        "finite",
    );
    check(
        &format!("[environment]\nscale = -2\n{SPHERE}"),
        "environment.scale",
        "≥ 0",
    );
    check(
        &format!("[environment]\nrotate = [nan, 0, 0]\n{SPHERE}"),
        "environment.rotate",
        "finite",
    );
    check(
        &format!("[render]\nspp = 0\n{SPHERE}"),
        "render.spp",
        "at least 1",
    );
}

#[test]
fn bad_point_lights() {
    let l = |body: &str| format!("{SPHERE}[[point_light]]\nposition = [0, 1, 0]\n{body}");
    check(&l("intensity = -1"), "point_light[1].intensity", "≥ 0");
    check(
        &l("intensity = [1, -0.5, 1]"),
        "point_light[1].intensity",
        "≥ 0",
    );
    check(&l("intensity = nan"), "point_light[1].intensity", "finite");
    check(&l("intensity = 1e38"), "point_light[1].intensity", "≤ 1e12");
    check(
        &l("intensity = 1\ncolor = [1, inf, 1]"),
        "point_light[1].color",
        "finite",
    );
    check(
        &l("intensity = [1, 2]"),
        "point_light[1].intensity",
        "[r, g, b]",
    );
    check(
        &format!("{SPHERE}[[point_light]]\nposition = [0, nan, 0]\nintensity = 1"),
        "point_light[1].position",
        "finite",
    );
    check(
        &format!("{SPHERE}[[point_light]]\nintensity = 1"),
        "point_light[1]",
        "missing field `position`",
    );
}

#[test]
fn bad_area_lights() {
    let a =
        |body: &str| format!("{SPHERE}[[area_light]]\ncenter = [0, 2, 0]\nintensity = 1\n{body}");
    check(
        &a("size = [0, 1]\nnormal = [0, -1, 0]"),
        "area_light[1].size",
        "> 0",
    );
    check(
        &a("size = [1, -1]\nnormal = [0, -1, 0]"),
        "area_light[1].size",
        "> 0",
    );
    check(
        &a("size = [1, 1]\nnormal = [0, 0, 0]"),
        "area_light[1].normal",
        "non-zero direction",
    );
    check(
        &a("size = [1, 1]\nnormal = [0, 1, 0]\nup = [0, -3, 0]"),
        "area_light[1].up",
        "degenerate orientation",
    );
    check(&a("size = [1, 1]"), "area_light[1]", "needs an orientation");
    check(
        &format!(
            "{SPHERE}[[area_light]]\ncenter = [0, 2, 0]\nsize = [1, 1]\nnormal = [0, -1, 0]\nintensity = [1, 2e12, 1]"
        ),
        "area_light[1].intensity",
        "≤ 1e12",
    );
    check(
        &a("size = [1, 1]\nnormal = [0, -1, 0]\nrotate = [0, 90, 0]"),
        "area_light[1]",
        "not both",
    );
    check(
        &a("size = [1, 1]\nrotate = [0, 90, 0]\nup = [0, 0, 1]"),
        "area_light[1].up",
        "with `normal`",
    );
    check(
        &format!(
            "{SPHERE}[[area_light]]\ncenter = [0, 2, 0]\nsize = [1, 1]\nnormal = [0, -1, 0]\nintensity = -1"
        ),
        "area_light[1].intensity",
        "≥ 0",
    );
    check(
        &a("size = [1, 1]\nnormal = [0, -1, 0]\ntexture = \"no-such.png\""),
        "area_light[1].texture",
        "no-such.png: file not found",
    );
}

#[test]
fn bad_media() {
    let m = |body: &str| format!("{SPHERE}[medium]\n{body}");
    check(&m("beta = -0.1"), "medium.beta", "≥ 0");
    check(&m("beta = nan"), "medium.beta", "≥ 0");
    check(&m("beta = 0.1\nalbedo = 1.5"), "medium.albedo", "[0, 1]");
    check(&m("beta = 0.1\nalbedo = -0.01"), "medium.albedo", "[0, 1]");
    check(&m("beta = 0.1\nradius = 0"), "medium.radius", "> 0");
    check(&m("beta = 0.1\nradius = -3"), "medium.radius", "> 0");
    check(&m("albedo = 0.5"), "medium", "missing field `beta`");
}

/// A camera looking straight down (or up) without an `up` takes
/// `DEFAULT_CAMERA_UP_VERTICAL` (−Z: the image's top towards the default
/// camera's forward), as a vertical area light takes its own; an `up`
/// given parallel to the view stays an error that names the fix.
#[test]
fn a_vertical_camera_without_up_takes_the_vertical_default() {
    for (eye, y) in [([0.0, 5.0, 0.0], -1.0), ([0.0, -5.0, 0.0], 1.0)] {
        let text = format!("[camera]\neye = {eye:?}\ntarget = [0.0, 0.0, 0.0]\n{SPHERE}");
        let scene = load_scene_text(&text, Path::new("top.toml"), Some((8, 8)))
            .unwrap()
            .scene;
        assert_eq!(scene.camera.up, Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(
            relight_scene::default_camera_up(Vec3::new(0.0, y, 0.0)),
            Vec3::new(0.0, 0.0, -1.0)
        );
    }
    // Off vertical by more than 2.6°, the default +Y.
    let tilted = Vec3::new(0.05, -1.0, 0.0).normalize();
    assert_eq!(relight_scene::default_camera_up(tilted), Vec3::Y);
    check(
        &format!("[camera]\neye = [0, 5, 0]\ntarget = [0, 0, 0]\nup = [0, 1, 0]\n{SPHERE}"),
        "camera.up",
        "give another up (or none: a vertical view then takes [0, 0, -1])",
    );
}

#[test]
fn bad_cameras() {
    let c = |body: &str| format!("[camera]\n{body}\n{SPHERE}");
    check(
        &c("eye = [0, 0, 1]\ntarget = [0, 0, 1]"),
        "camera.target",
        "must differ",
    );
    check(
        &c("eye = [0, 0, 1]\ntarget = [0, 0, 0]\nup = [0, 0, 2]"),
        "camera.up",
        "degenerate orientation",
    );
    check(
        &c("eye = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 0"),
        "camera.fov",
        "(0, 180)",
    );
    check(
        &c("eye = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 180"),
        "camera.fov",
        "(0, 180)",
    );
    check(
        &c("eye = [0, 0, 1]\ntarget = [0, 0, 0]\nsize = [0, 10]"),
        "camera.size",
        "1..=16384",
    );
    check(
        &c("eye = [0, nan, 1]\ntarget = [0, 0, 0]"),
        "camera.eye",
        "finite",
    );
}

#[test]
fn bad_objects_and_materials() {
    check("visibility = true\n", "object", "no `[[object]]`");
    check(
        "[[object]]\nbrdf = \"lambert\"",
        "object[1]",
        "exactly one of `mesh`",
    );
    check(
        "[[object]]\nbuiltin = \"sphere\"\nmesh = \"a.obj\"",
        "object[1]",
        "exactly one of `mesh`",
    );
    check(
        "[[object]]\nbuiltin = \"cube\"",
        "object[1].builtin",
        "unknown built-in mesh `cube`",
    );
    check(
        "[[object]]\nmesh = \"sphere\"",
        "object[1].mesh",
        "`sphere` is a built-in shape, not a file: write `builtin = \"sphere\"`",
    );
    check(
        &format!("{SPHERE}brdf = \"ggx:-1\""),
        "object[1].brdf",
        "ggx",
    );
    check(
        &format!("{SPHERE}[object.blend]\nbrdf = \"nope\"\nweight = \"w.png\""),
        "object[1].blend.brdf",
        "nope",
    );
    check(
        &format!("{SPHERE}[object.blend]\nbrdf = \"ggx:0.2\"\nweight = \"w.png\""),
        "object[1].blend.weight",
        "w.png: file not found",
    );
    check(
        &format!("{SPHERE}normal_map = \"n.png\""),
        "object[1].normal_map",
        "n.png: file not found",
    );
    check(
        "[[object]]\nmesh = \"no-such.obj\"",
        "object[1].mesh",
        "no-such.obj: file not found",
    );
    check(
        &format!("[environment]\nfile = \"no-such.exr\"\n{SPHERE}"),
        "environment.file",
        "file not found",
    );
    check(
        &format!("[environment]\nbuiltin = \"moon\"\n{SPHERE}"),
        "environment.builtin",
        "studio, black",
    );
    check(
        &format!("[environment]\nbuiltin = \"studio\"\nfile = \"a.exr\"\n{SPHERE}"),
        "environment",
        "not both",
    );
}

#[test]
fn bad_keyframes() {
    let k =
        |body: &str| format!("{SPHERE}[[object.keyframe]]\ntime = 0\n[[object.keyframe]]\n{body}");
    check(
        &k("time = 1\nscale = 0"),
        "object[1].keyframe[2].scale",
        "> 0",
    );
    check(
        &k("time = 0"),
        "object[1].keyframe[2].time",
        "repeats keyframe[1]",
    );
    check(&k("time = nan"), "object[1].keyframe[2].time", "finite");
    check(
        &k("time = 1\ntranslate = [0, inf, 0]"),
        "object[1].keyframe[2].translate",
        "finite",
    );
    check(
        &k("scale = 2"),
        "object[1].keyframe[2]",
        "missing field `time`",
    );
}

#[test]
fn syntax_unknown_and_removed_keys() {
    check(
        &format!("{SPHERE}colour = 1"),
        "object[1].colour",
        "unknown field `colour`",
    );
    check(
        &format!("{SPHERE}scale = \"big\""),
        "object[1].scale",
        "invalid type",
    );
    check(
        &format!("{SPHERE}[fog]\nbeta = 0.1"),
        "fog",
        "replaced by `[medium]`",
    );
    check(
        &format!("{SPHERE}[[light]]\nposition = [0, 1, 0]\nintensity = 1"),
        "light",
        "replaced by `[[point_light]]`",
    );
    let e = error_in(None, &format!("{SPHERE}[fog]\nbeta = 0.1"));
    assert!(e.contains("line 3"), "{e}");
    let e = error_in(None, &format!("{SPHERE}scale = \"big\""));
    assert!(e.contains("line 3, column 9"), "{e}");
    let e = error_in(None, "[[object]\nbuiltin = 1");
    assert!(
        !e.contains('\n') && e.starts_with("bad.toml: line 1"),
        "{e}"
    );
    let e = load_scene_file(Path::new("/no/such/scene.toml"), None)
        .err()
        .unwrap()
        .to_string();
    assert_eq!(e, "/no/such/scene.toml: file not found");
    // A folder is not read as a scene file either.
    let e = load_scene_file(Path::new("/"), None)
        .err()
        .unwrap()
        .to_string();
    assert!(e.starts_with("/: cannot read scene file"), "{e}");
}

/// Texture files: a normal map or blend on a mesh without uvs is an error;
/// a texel that decodes to no direction is an error; colour textures are
/// sRGB-decoded and weights read linearly (checked against the encoder).
#[test]
fn texture_files() {
    let dir = common::temp_dir("textures");
    // A mesh without uvs: one triangle.
    std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let grey = vec![Vec3::splat(0.5); 4];
    relight_assets::write_png(
        &dir.join("half.png"),
        2,
        2,
        &grey,
        relight_assets::ToneMap {
            exposure_ev: 0.0,
            operator: relight_assets::ToneOperator::Clamp,
        },
    )
    .unwrap();
    // A normal map: 0.5, 0.5, 1 through the sRGB curve (188, 188, 255).
    relight_assets::write_png(
        &dir.join("nrm.png"),
        2,
        2,
        &[Vec3::new(0.5, 0.5, 1.0); 4],
        relight_assets::ToneMap {
            exposure_ev: 0.0,
            operator: relight_assets::ToneOperator::Clamp,
        },
    )
    .unwrap();
    // Linear 0.5 in an EXR: 2c − 1 = 0, no direction (one texel; the others
    // make it no grayscale image).
    let mut flat0 = vec![Vec3::new(0.5, 0.5, 1.0); 4];
    flat0[3] = Vec3::splat(0.5);
    relight_assets::write_exr(&dir.join("flat0.exr"), 2, 2, &flat0).unwrap();
    let tri = "[[object]]\nmesh = \"tri.obj\"\n";
    check_in(
        Some(&dir),
        &format!("{tri}normal_map = \"half.png\""),
        "object[1].normal_map",
        "no texture coordinates",
    );
    check_in(
        Some(&dir),
        &format!("{tri}[object.blend]\nbrdf = \"ggx:0.2\"\nweight = \"half.png\""),
        "object[1].blend",
        "no texture coordinates",
    );
    check_in(
        Some(&dir),
        &format!("{SPHERE}normal_map = \"flat0.exr\""),
        "object[1].normal_map",
        "not a direction",
    );
    // A grayscale image is no normal map (a height map given by mistake).
    check_in(
        Some(&dir),
        &format!("{SPHERE}normal_map = \"half.png\""),
        "object[1].normal_map",
        "grayscale image",
    );

    let text = format!(
        "{SPHERE}normal_map = \"nrm.png\"\n[object.blend]\nbrdf = \"ggx:0.2\"\nweight = \"half.png\"\n\
         [[area_light]]\ncenter = [0, 2, 0]\nsize = [1, 1]\nnormal = [0, -1, 0]\nintensity = 2\ntexture = \"half.png\"\n"
    );
    let l = load_scene_text(&text, &dir.join("ok.toml"), Some((8, 8)))
        .unwrap_or_else(|e| panic!("{e}"));
    let s = l.scene;
    // 0.5 linear was written through the sRGB curve as round(255·0.7354) = 188.
    let encoded = 188.0 / 255.0;
    let area = s.area_lights[0].texture.as_ref().unwrap().texels[0];
    assert!(
        (area - Vec3::splat(0.5)).abs().max_element() < 0.003,
        "sRGB-decoded: {area}"
    );
    let w = s.objects[0].blend.as_ref().unwrap().weight.texels[0];
    assert!(
        (w - Vec3::splat(encoded)).abs().max_element() < 1e-6,
        "linear: {w}"
    );
    let n = s.objects[0].normal_map.as_ref().unwrap().texels[0];
    let expect = Vec3::new(2.0 * encoded - 1.0, 2.0 * encoded - 1.0, 1.0).normalize();
    assert!((n - expect).length() < 1e-5, "2c − 1: {n} vs {expect}");
    assert_eq!(
        s.objects[0].mesh.tangents.len(),
        s.objects[0].mesh.positions.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A soft problem in a texture or a mesh is a warning that names its file
/// once (the asset layer names it; the scene loader passes it on).
#[test]
fn file_warnings_name_the_file_once() {
    let dir = common::temp_dir("file-warnings");
    let mut px = vec![Vec3::splat(0.5); 4];
    px[0] = Vec3::new(-1.0, 0.5, 0.5);
    relight_assets::write_exr(&dir.join("neg.exr"), 2, 2, &px).unwrap();
    // A degenerate (zero-area) triangle beside a good one: repaired, warned.
    std::fs::write(
        dir.join("two.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    )
    .unwrap();
    let text = "[[object]]\nmesh = \"two.obj\"\n\
                [[area_light]]\ncenter = [0, 2, 0]\nsize = [1, 1]\nnormal = [0, -1, 0]\nintensity = 2\ntexture = \"neg.exr\"\n";
    let l =
        load_scene_text(text, &dir.join("ok.toml"), Some((8, 8))).unwrap_or_else(|e| panic!("{e}"));
    for file in ["neg.exr", "two.obj"] {
        let hits: Vec<&String> = l.warnings.iter().filter(|w| w.contains(file)).collect();
        assert!(
            !hits.is_empty(),
            "no warning names {file}: {:?}",
            l.warnings
        );
        for w in hits {
            assert_eq!(w.matches(file).count(), 1, "{file} named twice: {w}");
        }
    }
}

/// `[area_light.light_field]`: tiles from an image (views mapped with σ_y
/// upwards) or the built-in prism; each bad combination names its key.
#[test]
fn light_fields_load_and_bad_ones_name_their_key() {
    let dir = common::temp_dir("light-field");
    // 2 × 2 tiles of 2 × 2 texels; tile (column c, row r) = (c, r, 1) / 4.
    let px: Vec<Vec3> = (0..16)
        .map(|i| Vec3::new(((i % 4) / 2) as f32, ((i / 4) / 2) as f32, 1.0) / 4.0)
        .collect();
    relight_assets::write_exr(&dir.join("tiles.exr"), 4, 4, &px).unwrap();
    relight_assets::write_exr(&dir.join("odd.exr"), 3, 3, &px[..9]).unwrap();
    let light = |body: &str| {
        format!(
            "{SPHERE}[[area_light]]\ncenter = [0, 2, 0]\nsize = [1, 1]\nnormal = [0, -1, 0]\nintensity = 2\n{body}"
        )
    };
    let text = light("[area_light.light_field]\ntiles = \"tiles.exr\"\nviews = 2\nextent = 1.5\n");
    let l = load_scene_text(&text, &dir.join("ok.toml"), Some((8, 8)))
        .unwrap_or_else(|e| panic!("{e}"));
    let a = &l.scene.area_lights[0];
    let lf = a.light_field.as_ref().expect("a light field");
    assert!(a.texture.is_none());
    assert_eq!((lf.views(), lf.extent()), (2, 1.5));
    // View (a_x, a_y) is tile (column a_x, row 1 − a_y).
    for (ax, ay) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let want = Vec3::new(ax as f32, (1 - ay) as f32, 1.0) / 4.0;
        assert!(
            lf.view(ax, ay)
                .texels
                .iter()
                .all(|t| (*t - want).abs().max_element() < 1e-3)
        );
    }
    let text = light(
        "texture = \"tiles.exr\"\n[area_light.light_field]\nbuiltin = \"prism\"\nviews = 4\nextent = 2\n",
    );
    let l = load_scene_text(&text, &dir.join("ok.toml"), Some((8, 8)))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        l.scene.area_lights[0].light_field.as_ref().unwrap().views(),
        4
    );

    let key = "area_light[1].light_field";
    let lf = |body: &str| light(&format!("[area_light.light_field]\n{body}"));
    check_in(
        Some(&dir),
        &lf("tiles = \"odd.exr\"\nviews = 2\nextent = 1"),
        &format!("{key}.tiles"),
        "2 × 2 equal tiles",
    );
    check_in(
        Some(&dir),
        &lf("tiles = \"none.exr\"\nviews = 2\nextent = 1"),
        &format!("{key}.tiles"),
        "none.exr",
    );
    check(
        &lf("builtin = \"prism\"\nviews = 0\nextent = 1"),
        &format!("{key}.views"),
        "1…64",
    );
    check(
        &lf("builtin = \"prism\"\nviews = 2\nextent = 0"),
        &format!("{key}.extent"),
        "> 0",
    );
    check(
        &lf("builtin = \"rainbow\"\nviews = 2\nextent = 1"),
        &format!("{key}.builtin"),
        "prism",
    );
    check(&lf("views = 2\nextent = 1"), key, "exactly one of");
    check_in(
        Some(&dir),
        &light(
            "texture = \"tiles.exr\"\n[area_light.light_field]\ntiles = \"tiles.exr\"\nviews = 2\nextent = 1\n",
        ),
        "area_light[1].texture",
        "drop `texture`",
    );
    let _ = std::fs::remove_dir_all(&dir);
}
