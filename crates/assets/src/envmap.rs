//! Environment maps from image files: lat-long, cube crosses, six faces,
//! the native cube strip and octahedral squares, into a [`relight_sphere::EnvMap`].
//!
//! # Layouts ([`EnvLayout`])
//! | layout | image size | becomes |
//! |---|---|---|
//! | `LatLong` | `2h × h` | `Param::LatLong` — pixels copied as-is (row 0 = +Y, see `relight_sphere::param`) |
//! | `CrossHorizontal` | `4n × 3n` | `Param::Cube { n }` |
//! | `CrossVertical` | `3n × 4n` | `Param::Cube { n }` |
//! | `CubeStrip` | `n × 6n` | `Param::Cube { n }` — the native texel order (what [`write_env_map`] writes for a cube) |
//! | `Octahedral` | `n × n` | `Param::Octahedral { n }` |
//! | `HemiOctahedral` | `n × n` | `Param::HemiOctahedral { n }` (explicit only) |
//!
//! `Auto` picks by aspect ratio (2:1, 4:3, 3:4, 1:6, 1:1 in that order; a
//! square is taken as octahedral and says so in a warning).
//!
//! Cube faces use the OpenGL/Direct3D orientation of `relight_sphere`'s cube
//! map (`d ∝ N + a U + b V`, table in `relight_sphere::param`), which is how
//! cube faces and crosses are conventionally stored. Crosses place the faces
//! on a grid of `n × n` cells (column, row):
//!
//! ```text
//! horizontal 4×3:          vertical 3×4:
//!   .   +Y   .   .           .   +Y   .
//!  −X   +Z  +X  −Z          −X   +Z  +X
//!   .   −Y   .   .           .   −Y   .
//!                            .   −Z*  .     (* rotated 180°)
//! ```
//!
//! Six separate face files are given in the order +X, −X, +Y, −Y, +Z, −Z,
//! each `n × n` in the same face orientation.

use crate::error::{AssetError, LoadReport};
use crate::image_io::{RgbImage, ToneMap, read_image};
use glam::Vec3;
use relight_sphere::{EnvMap, Param};
use std::path::Path;

/// How the pixels of an environment-map image are laid out.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EnvLayout {
    /// Guess from the aspect ratio (module docs).
    #[default]
    Auto,
    LatLong,
    CrossHorizontal,
    CrossVertical,
    CubeStrip,
    Octahedral,
    HemiOctahedral,
}

impl EnvLayout {
    /// The layout an image of `width × height` has under `Auto`, if any.
    #[must_use]
    pub fn guess(width: usize, height: usize) -> Option<Self> {
        if width == 0 || height == 0 {
            None
        } else if width == 2 * height {
            Some(Self::LatLong)
        } else if 3 * width == 4 * height && width.is_multiple_of(4) {
            Some(Self::CrossHorizontal)
        } else if 4 * width == 3 * height && width.is_multiple_of(3) {
            Some(Self::CrossVertical)
        } else if height == 6 * width {
            Some(Self::CubeStrip)
        } else if width == height {
            Some(Self::Octahedral)
        } else {
            None
        }
    }
}

/// Cell (column, row) of each cube face in a cross, and whether it is
/// rotated by 180°; faces in the order +X, −X, +Y, −Y, +Z, −Z.
const CROSS_H: [(usize, usize, bool); 6] = [
    (2, 1, false),
    (0, 1, false),
    (1, 0, false),
    (1, 2, false),
    (1, 1, false),
    (3, 1, false),
];
const CROSS_V: [(usize, usize, bool); 6] = [
    (2, 1, false),
    (0, 1, false),
    (1, 0, false),
    (1, 2, false),
    (1, 1, false),
    (1, 3, true),
];

/// Loads an environment map, guessing the layout from the aspect ratio.
pub fn load_env_map(path: &Path) -> Result<(EnvMap, LoadReport), AssetError> {
    load_env_map_as(path, EnvLayout::Auto)
}

/// Loads an environment map with an explicit (or `Auto`) layout.
pub fn load_env_map_as(path: &Path, layout: EnvLayout) -> Result<(EnvMap, LoadReport), AssetError> {
    let (img, mut report) = read_image(path)?;
    let (env, warn) = env_map_from_image(img, layout, path)?;
    report.warnings.extend(warn);
    Ok((env, report))
}

/// Turns a decoded image into an [`EnvMap`] (`path` only for messages);
/// returns a warning when the layout was a guess worth mentioning.
pub fn env_map_from_image(
    img: RgbImage,
    layout: EnvLayout,
    path: &Path,
) -> Result<(EnvMap, Option<String>), AssetError> {
    let (w, h) = (img.width, img.height);
    let mut warning = None;
    let layout = match layout {
        EnvLayout::Auto => {
            let guess = EnvLayout::guess(w, h).ok_or_else(|| {
                AssetError::bad_dims(
                    path,
                    format!(
                        "{w}×{h} is no environment-map layout: expected 2:1 lat-long, 4:3 or 3:4 cube cross, 1:6 cube strip or a square octahedral map"
                    ),
                )
            })?;
            if guess == EnvLayout::Octahedral {
                warning = Some(format!(
                    "{}: square {w}×{h} image taken as an octahedral map",
                    path.display()
                ));
            }
            guess
        }
        l => l,
    };
    let bad =
        |want: &str| AssetError::bad_dims(path, format!("{w}×{h} does not fit the {want} layout"));
    let env = match layout {
        EnvLayout::Auto => unreachable!("resolved above"),
        EnvLayout::LatLong => {
            if w < 2 || h < 1 {
                return Err(bad("lat-long (width ≥ 2)"));
            }
            EnvMap {
                param: Param::LatLong {
                    width: w,
                    height: h,
                },
                texels: img.pixels,
            }
        }
        EnvLayout::Octahedral | EnvLayout::HemiOctahedral => {
            if w != h {
                return Err(bad("square octahedral"));
            }
            let param = if layout == EnvLayout::Octahedral {
                Param::Octahedral { n: w }
            } else {
                Param::HemiOctahedral { n: w }
            };
            EnvMap {
                param,
                texels: img.pixels,
            }
        }
        EnvLayout::CubeStrip => {
            if h != 6 * w {
                return Err(bad("n × 6n cube strip"));
            }
            EnvMap {
                param: Param::Cube { n: w },
                texels: img.pixels,
            }
        }
        EnvLayout::CrossHorizontal | EnvLayout::CrossVertical => {
            let (cells, cw, ch) = if layout == EnvLayout::CrossHorizontal {
                (&CROSS_H, 4, 3)
            } else {
                (&CROSS_V, 3, 4)
            };
            if !w.is_multiple_of(cw) || !h.is_multiple_of(ch) || w / cw != h / ch || w == 0 {
                return Err(bad(if cw == 4 {
                    "4×3 horizontal cross"
                } else {
                    "3×4 vertical cross"
                }));
            }
            let n = w / cw;
            let mut texels = Vec::with_capacity(6 * n * n);
            for &(cx, cy, rot) in cells {
                for r in 0..n {
                    for c in 0..n {
                        let (sc, sr) = if rot { (n - 1 - c, n - 1 - r) } else { (c, r) };
                        texels.push(img.get(cx * n + sc, cy * n + sr));
                    }
                }
            }
            EnvMap {
                param: Param::Cube { n },
                texels,
            }
        }
    };
    Ok((env, warning))
}

/// Loads a cube map from six square face images (+X, −X, +Y, −Y, +Z, −Z).
pub fn load_env_map_faces<P: AsRef<Path>>(
    faces: &[P; 6],
) -> Result<(EnvMap, LoadReport), AssetError> {
    let mut report = LoadReport::default();
    let mut texels = Vec::new();
    let mut n = 0;
    for (k, p) in faces.iter().enumerate() {
        let path = p.as_ref();
        let (img, r) = read_image(path)?;
        report.merge(r);
        if img.width != img.height {
            return Err(AssetError::bad_dims(
                path,
                format!("cube face {}×{} is not square", img.width, img.height),
            ));
        }
        if k == 0 {
            n = img.width;
        } else if img.width != n {
            return Err(AssetError::bad_dims(
                path,
                format!(
                    "cube face is {0}×{0} but the first face is {n}×{n}",
                    img.width
                ),
            ));
        }
        texels.extend(img.pixels);
    }
    Ok((
        EnvMap {
            param: Param::Cube { n },
            texels,
        },
        report,
    ))
}

/// Image size of the texel grid of `param`: cube maps are the `n × 6n` strip.
#[must_use]
pub fn grid_size(param: Param) -> (usize, usize) {
    match param {
        Param::LatLong { width, height } => (width, height),
        Param::Cube { n } => (n, 6 * n),
        Param::Octahedral { n } | Param::HemiOctahedral { n } => (n, n),
    }
}

/// Encodes an environment map's texel grid in the format of `path`'s extension.
pub fn encode_env_map(env: &EnvMap, tone: ToneMap, path: &Path) -> Result<Vec<u8>, AssetError> {
    let (w, h) = grid_size(env.param);
    match crate::image_io::ImageFormat::from_path(path)? {
        crate::image_io::ImageFormat::Exr => crate::image_io::encode_exr(w, h, &env.texels, path),
        crate::image_io::ImageFormat::Hdr => crate::image_io::encode_hdr(w, h, &env.texels, path),
        crate::image_io::ImageFormat::Png => {
            crate::image_io::encode_png(w, h, &env.texels, tone, path)
        }
        crate::image_io::ImageFormat::Jpeg => Err(AssetError::unsupported(path, "writing JPEG")),
    }
}

/// Writes an environment map's texel grid (lat-long as-is, cube maps as the
/// `n × 6n` strip, octahedral maps as the square) atomically; the format
/// follows the extension (`.exr`, `.hdr`, `.png` with `tone`).
/// [`load_env_map_as`] with the matching layout reads it back.
pub fn write_env_map(path: &Path, env: &EnvMap, tone: ToneMap) -> Result<(), AssetError> {
    crate::image_io::write_atomic(path, &encode_env_map(env, tone, path)?)
}

/// Maps a direction to its (face, column, row) in an `n × n` cube face in
/// relight's cube convention; used by tests and `describe`.
#[must_use]
pub fn cube_texel_from_dir(d: Vec3, n: usize) -> (usize, usize, usize) {
    let (face, ab) = relight_sphere::param::cube_face_from_dir(d.as_dvec3());
    let to = |x: f64| (((x + 1.0) * 0.5 * n as f64) as usize).min(n - 1);
    (face, to(ab.x), to(ab.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth colourful function of direction.
    fn f(d: Vec3) -> Vec3 {
        Vec3::new(1.0 + d.x, 2.0 + d.y * d.z, 1.5 + 0.5 * d.z)
    }

    #[test]
    fn crosses_agree_with_the_sphere_cube_convention() {
        let n = 8;
        let cube = Param::Cube { n };
        // Build cross images by placing each cube texel's value where the
        // layout says; then check every loaded texel against f(dir).
        for (layout, cells, cw, ch) in [
            (EnvLayout::CrossHorizontal, &CROSS_H, 4, 3),
            (EnvLayout::CrossVertical, &CROSS_V, 3, 4),
        ] {
            let (w, h) = (cw * n, ch * n);
            let mut px = vec![Vec3::ZERO; w * h];
            for (face, &(cx, cy, rot)) in cells.iter().enumerate() {
                for r in 0..n {
                    for c in 0..n {
                        let d = cube.dir_from_texel((face * n + r) * n + c);
                        let (sc, sr) = if rot { (n - 1 - c, n - 1 - r) } else { (c, r) };
                        px[(cy * n + sr) * w + cx * n + sc] = f(d);
                    }
                }
            }
            let img = RgbImage {
                width: w,
                height: h,
                pixels: px,
            };
            let (env, warn) = env_map_from_image(img, EnvLayout::Auto, Path::new("x.exr")).unwrap();
            assert!(warn.is_none());
            assert_eq!(env.param, cube, "{layout:?}");
            for (i, t) in env.texels.iter().enumerate() {
                assert_eq!(*t, f(cube.dir_from_texel(i)), "{layout:?} texel {i}");
            }
        }
    }

    #[test]
    fn cross_faces_are_continuous_across_their_shared_edges() {
        // Independent check of the layout table: in a vertical cross the
        // −Y face's bottom row and the (rotated) −Z face's top row are
        // neighbours on the sphere, as are +Z's right column and +X's left.
        let n = 16;
        let cube = Param::Cube { n };
        let dir = |face: usize, c: usize, r: usize| cube.dir_from_texel((face * n + r) * n + c);
        for i in 0..n {
            // −Y (3) bottom row, column i  vs  −Z (5) stored rotated: the cell
            // below holds face row n−1−0 = n−1 at column n−1−i.
            let a = dir(3, i, n - 1);
            let b = dir(5, n - 1 - i, n - 1);
            assert!(
                a.angle_between(b) < 2.0 / n as f32,
                "−Y/−Z edge at {i}: {a} {b}"
            );
            let a = dir(4, n - 1, i);
            let b = dir(0, 0, i);
            assert!(
                a.angle_between(b) < 2.0 / n as f32,
                "+Z/+X edge at {i}: {a} {b}"
            );
        }
    }

    #[test]
    fn layouts_guess_and_reject() {
        assert_eq!(EnvLayout::guess(512, 256), Some(EnvLayout::LatLong));
        assert_eq!(EnvLayout::guess(64, 48), Some(EnvLayout::CrossHorizontal));
        assert_eq!(EnvLayout::guess(48, 64), Some(EnvLayout::CrossVertical));
        assert_eq!(EnvLayout::guess(16, 96), Some(EnvLayout::CubeStrip));
        assert_eq!(EnvLayout::guess(32, 32), Some(EnvLayout::Octahedral));
        assert_eq!(EnvLayout::guess(30, 17), None);
        let img = RgbImage {
            width: 30,
            height: 17,
            pixels: vec![Vec3::ONE; 30 * 17],
        };
        let e = env_map_from_image(img.clone(), EnvLayout::Auto, Path::new("odd.exr")).unwrap_err();
        assert!(
            matches!(e, AssetError::BadDimensions { .. }) && e.to_string().contains("odd.exr"),
            "{e}"
        );
        let e =
            env_map_from_image(img, EnvLayout::CrossHorizontal, Path::new("odd.exr")).unwrap_err();
        assert!(e.to_string().contains("cross"), "{e}");
    }

    #[test]
    fn write_read_round_trip_for_every_param() {
        let dir = std::env::temp_dir().join(format!("relight-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (param, layout) in [
            (
                Param::LatLong {
                    width: 16,
                    height: 8,
                },
                EnvLayout::Auto,
            ),
            (Param::Cube { n: 4 }, EnvLayout::Auto),
            (Param::Octahedral { n: 8 }, EnvLayout::Octahedral),
            (Param::HemiOctahedral { n: 8 }, EnvLayout::HemiOctahedral),
        ] {
            let env = EnvMap::from_fn(param, f);
            let path = dir.join("env.exr");
            write_env_map(&path, &env, ToneMap::default()).unwrap();
            let (back, _) = load_env_map_as(&path, layout).unwrap();
            assert_eq!(back, env, "{param:?}");
        }
        // Six face files.
        let cube = EnvMap::from_fn(Param::Cube { n: 4 }, f);
        let paths: Vec<_> = (0..6).map(|k| dir.join(format!("face{k}.exr"))).collect();
        for (k, p) in paths.iter().enumerate() {
            crate::image_io::write_exr(p, 4, 4, &cube.texels[k * 16..(k + 1) * 16]).unwrap();
        }
        let faces: [std::path::PathBuf; 6] = paths.clone().try_into().unwrap();
        let (back, _) = load_env_map_faces(&faces).unwrap();
        assert_eq!(back, cube);
        crate::image_io::write_exr(&paths[3], 4, 2, &cube.texels[..8]).unwrap();
        let e = load_env_map_faces(&faces).unwrap_err();
        assert!(e.to_string().contains("face3.exr"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
