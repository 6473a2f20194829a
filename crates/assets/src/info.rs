//! [`describe`]: what a file is and its statistics, for `relight info`.
//!
//! Images are decoded *without* the loaders' NaN rejection and negative
//! clamping, so the statistics show the file as it is. Meshes are described
//! after [`relight_geom::Mesh::validate_and_repair`], with what it repaired.

use crate::envmap::{EnvLayout, env_map_from_image};
use crate::error::AssetError;
use crate::image_io::{ColorEncoding, ImageFormat, RgbImage, decode_raw};
use crate::mesh_io::{MeshFormat, load_mesh};
use glam::Vec3;
use relight_geom::{RepairReport, mesh::Aabb};
use relight_sphere::Param;
use std::fmt;
use std::path::{Path, PathBuf};

/// Statistics of an image / environment map file.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageInfo {
    pub path: PathBuf,
    pub format: ImageFormat,
    pub width: usize,
    pub height: usize,
    /// The environment-map parameterization the aspect ratio suggests
    /// (HDR formats, or non-square 8-bit images).
    pub param_guess: Option<Param>,
    /// Per-channel minimum, maximum and mean over finite samples (linear).
    pub min: Vec3,
    pub max: Vec3,
    pub mean: Vec3,
    /// Pixels with a negative channel.
    pub negative_pixels: usize,
    pub nan_samples: usize,
    pub inf_samples: usize,
    /// Brightest pixel (by Rec. 709 luminance): column, row and value.
    pub peak_pixel: (usize, usize),
    pub peak_value: Vec3,
    /// World direction of the brightest texel when `param_guess` is set.
    pub peak_direction: Option<Vec3>,
}

/// Statistics of a mesh file.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshInfo {
    pub path: PathBuf,
    pub vertices: usize,
    pub triangles: usize,
    pub bounds: Aabb,
    pub surface_area: f64,
    /// Whether the file itself carried normals / uvs.
    pub had_normals: bool,
    pub has_uvs: bool,
    pub repair: RepairReport,
}

/// What [`describe`] found.
#[derive(Clone, Debug, PartialEq)]
pub enum FileInfo {
    Image(ImageInfo),
    Mesh(MeshInfo),
    /// A MERL measured BRDF (`.binary`): its dimension header and size check.
    Merl {
        path: PathBuf,
        dims: [i32; 3],
        bytes: usize,
        expected_bytes: Option<usize>,
    },
}

const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// Describes an image, environment map, mesh or MERL file (by extension).
pub fn describe(path: &Path) -> Result<FileInfo, AssetError> {
    if path.is_dir() {
        return Err(AssetError::Folder {
            path: path.to_path_buf(),
        });
    }
    let ext = crate::error::lowercase_extension(path);
    if ext == "binary" {
        let bytes = crate::read_merl_bytes(path)?;
        let d = |k: usize| {
            i32::from_le_bytes([
                bytes[4 * k],
                bytes[4 * k + 1],
                bytes[4 * k + 2],
                bytes[4 * k + 3],
            ])
        };
        let dims = [d(0), d(1), d(2)];
        let expected_bytes = dims
            .iter()
            .try_fold(1usize, |acc, &x| {
                usize::try_from(x).ok().and_then(|x| acc.checked_mul(x))
            })
            .and_then(|n| n.checked_mul(3 * 8))
            .and_then(|n| n.checked_add(12));
        return Ok(FileInfo::Merl {
            path: path.to_path_buf(),
            dims,
            bytes: bytes.len(),
            expected_bytes,
        });
    }
    if let Ok(format) = ImageFormat::from_path(path) {
        let bytes = crate::read_bytes(path)?;
        let img = decode_raw(&bytes, format, ColorEncoding::Srgb, path)?;
        return Ok(FileInfo::Image(image_info(img, format, path)));
    }
    if MeshFormat::from_path(path).is_ok() {
        let (mesh, report) = load_mesh(path)?;
        let repair = report.repair.unwrap_or_default();
        let had_normals = !repair.computed_normals;
        return Ok(FileInfo::Mesh(MeshInfo {
            path: path.to_path_buf(),
            vertices: mesh.vertex_count(),
            triangles: mesh.triangle_count(),
            bounds: mesh.bounds().unwrap_or(Aabb {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
            }),
            surface_area: mesh.area(),
            had_normals,
            has_uvs: !mesh.uvs.is_empty(),
            repair,
        }));
    }
    Err(AssetError::UnknownFormat {
        path: path.to_path_buf(),
        ext,
        expected: ".exr, .hdr, .png, .jpg, .obj, .ply, .gltf, .glb or .binary (MERL)",
    })
}

fn image_info(img: RgbImage, format: ImageFormat, path: &Path) -> ImageInfo {
    let (mut min, mut max, mut sum) = (
        Vec3::splat(f32::INFINITY),
        Vec3::splat(f32::NEG_INFINITY),
        glam::DVec3::ZERO,
    );
    let (mut counts, mut nan, mut inf, mut neg) = (glam::DVec3::ZERO, 0, 0, 0);
    let (mut peak_i, mut peak_l) = (0usize, f32::NEG_INFINITY);
    for (i, p) in img.pixels.iter().enumerate() {
        for (k, v) in p.to_array().into_iter().enumerate() {
            if v.is_nan() {
                nan += 1;
            } else if v.is_infinite() {
                inf += 1;
            } else {
                min[k] = min[k].min(v);
                max[k] = max[k].max(v);
                sum[k] += f64::from(v);
                counts[k] += 1.0;
            }
        }
        neg += usize::from(p.min_element() < 0.0);
        let l = p.dot(LUMA);
        if l.is_finite() && l > peak_l {
            (peak_i, peak_l) = (i, l);
        }
    }
    let mean = (sum / counts.max(glam::DVec3::ONE)).as_vec3();
    let hdr = matches!(format, ImageFormat::Exr | ImageFormat::Hdr);
    let layout =
        EnvLayout::guess(img.width, img.height).filter(|&l| hdr || l != EnvLayout::Octahedral);
    let (width, height) = (img.width, img.height);
    let peak_value = img.pixels.get(peak_i).copied().unwrap_or(Vec3::ZERO);
    let (mut param_guess, mut peak_direction) = (None, None);
    if let Some(layout) = layout
        && let Ok((env, _)) = env_map_from_image(img, layout, path)
    {
        param_guess = Some(env.param);
        // The direction of the peak pixel itself: texel i is pixel i in the
        // single-image layouts; a cube cross is reordered, so there the first
        // texel of the peak's value (ties resolve to the same pixel value).
        let same_order = matches!(
            env.param,
            Param::LatLong { .. } | Param::Octahedral { .. } | Param::HemiOctahedral { .. }
        ) && env.texels.len() == width * height;
        let best = if same_order {
            (peak_l > f32::NEG_INFINITY).then_some(peak_i)
        } else {
            env.texels.iter().position(|t| *t == peak_value)
        };
        peak_direction = best.map(|i| env.param.dir_from_texel(i));
    }
    ImageInfo {
        path: path.to_path_buf(),
        format,
        width,
        height,
        param_guess,
        min,
        max,
        mean,
        negative_pixels: neg,
        nan_samples: nan,
        inf_samples: inf,
        peak_pixel: (peak_i % width.max(1), peak_i / width.max(1)),
        peak_value,
        peak_direction,
    }
}

/// `1 triangle`, `2 triangles`.
fn counted(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

impl fmt::Display for FileInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Image(i) => {
                writeln!(
                    f,
                    "{}: {:?} image, {}×{} RGB",
                    i.path.display(),
                    i.format,
                    i.width,
                    i.height
                )?;
                match i.param_guess {
                    Some(p) => writeln!(f, "  layout:     {p:?} (guessed from the aspect ratio)")?,
                    None => writeln!(
                        f,
                        "  layout:     plain image (no environment-map aspect ratio)"
                    )?,
                }
                let v = |v: Vec3| format!("{:.5} {:.5} {:.5}", v.x, v.y, v.z);
                writeln!(f, "  min  (RGB): {}", v(i.min))?;
                writeln!(f, "  max  (RGB): {}", v(i.max))?;
                writeln!(f, "  mean (RGB): {}", v(i.mean))?;
                writeln!(
                    f,
                    "  negative pixels: {}, NaN samples: {}, Inf samples: {}",
                    i.negative_pixels, i.nan_samples, i.inf_samples
                )?;
                write!(f, "  peak: {} at pixel {:?}", v(i.peak_value), i.peak_pixel)?;
                if let Some(d) = i.peak_direction {
                    write!(f, ", direction ({:.4}, {:.4}, {:.4})", d.x, d.y, d.z)?;
                }
                Ok(())
            }
            Self::Mesh(m) => {
                writeln!(
                    f,
                    "{}: mesh, {}, {}",
                    m.path.display(),
                    counted(m.vertices, "vertex", "vertices"),
                    counted(m.triangles, "triangle", "triangles")
                )?;
                let (a, b) = (m.bounds.min, m.bounds.max);
                writeln!(
                    f,
                    "  bounds: ({:.4}, {:.4}, {:.4}) .. ({:.4}, {:.4}, {:.4})",
                    a.x, a.y, a.z, b.x, b.y, b.z
                )?;
                writeln!(f, "  surface area: {:.6}", m.surface_area)?;
                writeln!(
                    f,
                    "  normals: {}, uvs: {}",
                    if m.had_normals {
                        "from file"
                    } else {
                        "computed"
                    },
                    m.has_uvs
                )?;
                write!(f, "  repairs: {}", m.repair)
            }
            Self::Merl {
                path,
                dims,
                bytes,
                expected_bytes,
            } => {
                write!(
                    f,
                    "{}: MERL BRDF, dims {}×{}×{}, {bytes} bytes",
                    path.display(),
                    dims[0],
                    dims[1],
                    dims[2]
                )?;
                match expected_bytes {
                    Some(e) if *e == *bytes => write!(f, " (size matches)"),
                    Some(e) => write!(f, " (expected {e} bytes: corrupt or truncated)"),
                    None => write!(f, " (invalid dimensions)"),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two pixels of equal peak value: the pixel and the direction printed
    /// are the same pixel's (the first in row order).
    #[test]
    fn peak_pixel_and_direction_agree_on_ties() {
        let dir = std::env::temp_dir().join(format!("relight-info-tie-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (16, 8);
        let mut px = vec![Vec3::splat(0.5); w * h];
        px[2 * w + 3] = Vec3::splat(7.0);
        px[6 * w + 12] = Vec3::splat(7.0);
        let p = dir.join("tie.exr");
        crate::write_exr(&p, w, h, &px).unwrap();
        let FileInfo::Image(i) = describe(&p).unwrap() else {
            panic!("not an image")
        };
        assert_eq!(i.peak_pixel, (3, 2));
        let param = i.param_guess.unwrap();
        assert_eq!(i.peak_direction, Some(param.dir_from_texel(2 * w + 3)));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn describes_images_meshes_and_merl() {
        let dir = std::env::temp_dir().join(format!("relight-info-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (w, h) = (16, 8);
        let mut px = vec![Vec3::splat(0.5); w * h];
        px[3 * w + 5] = Vec3::new(100.0, 90.0, 80.0);
        px[0] = Vec3::new(-0.25, 0.0, 0.0);
        let p = dir.join("e.exr");
        crate::write_exr(&p, w, h, &px).unwrap();
        let FileInfo::Image(i) = describe(&p).unwrap() else {
            panic!("not an image")
        };
        assert_eq!(
            i.param_guess,
            Some(Param::LatLong {
                width: 16,
                height: 8
            })
        );
        assert_eq!(i.peak_pixel, (5, 3));
        assert_eq!(i.negative_pixels, 1);
        assert_eq!(i.min.x, -0.25);
        assert_eq!(i.max, Vec3::new(100.0, 90.0, 80.0));
        let want = Param::LatLong {
            width: 16,
            height: 8,
        }
        .dir_from_texel(3 * w + 5);
        assert_eq!(i.peak_direction, Some(want));
        let text = describe(&p).unwrap().to_string();
        assert!(
            text.contains("16×8") && text.contains("negative pixels: 1"),
            "{text}"
        );

        let obj = dir.join("t.obj");
        std::fs::write(
            &obj,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nf 1 2 3\nf 1 1 2\n",
        )
        .unwrap();
        let FileInfo::Mesh(m) = describe(&obj).unwrap() else {
            panic!("not a mesh")
        };
        assert_eq!((m.vertices, m.triangles), (3, 1)); // tobj keeps used vertices only
        assert_eq!(m.repair.degenerate_triangles, 1);
        let text = describe(&obj).unwrap().to_string();
        assert!(text.contains("3 vertices, 1 triangle\n"), "{text}");
        assert!(!m.had_normals);
        assert!((m.surface_area - 0.5).abs() < 1e-9);

        let merl = dir.join("m.binary");
        let mut b = Vec::new();
        for d in [2i32, 1, 1] {
            b.extend_from_slice(&d.to_le_bytes());
        }
        b.extend(std::iter::repeat_n(0u8, 2 * 3 * 8));
        std::fs::write(&merl, &b).unwrap();
        let t = describe(&merl).unwrap().to_string();
        assert!(t.contains("size matches"), "{t}");
        assert!(matches!(
            describe(&dir.join("x.xyz")),
            Err(AssetError::UnknownFormat { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
