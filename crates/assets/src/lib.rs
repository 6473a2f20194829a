//! relight-assets: every file relight reads or writes.
//!
//! | what | read | write |
//! |---|---|---|
//! | float RGB images ([`RgbImage`]) | OpenEXR (`exr`: scanline/tiled, every compression `exr` decodes incl. DWAA/DWAB; RGB, RGBA or Y; half/float/uint), Radiance `.hdr` (flat and RLE), PNG/JPEG (sRGB → linear) | EXR (linear f32, ZIP), `.hdr` (RLE RGBE), PNG (exposure + tone map + sRGB, 8-bit) |
//! | environment maps ([`EnvMap`]) | lat-long, horizontal 4×3 and vertical 3×4 cube crosses, six face files, the native cube strip (1×6) and octahedral squares | the texel grid of any [`Param`] as an image |
//! | meshes ([`Mesh`]) | OBJ (`tobj`, triangulated), PLY (ASCII, binary LE/BE; own reader), glTF/GLB (`gltf` JSON + our own buffer reading; node transforms applied) | — |
//! | MERL BRDF | [`load_merl`] (parsed by `relight_brdf::Merl`), raw bytes ([`read_merl_bytes`]) | — |
//!
//! **Architecture invariant:** this is the only crate of relight that touches
//! the file system for assets; the math crates (`relight-sphere`,
//! `relight-geom`, `relight-brdf`) parse or build in-memory data only.
//!
//! # Errors and warnings
//! Every fallible function returns [`AssetError`], which names the file and
//! the problem (missing, truncated, corrupt, unsupported format/compression,
//! bad dimensions, non-finite values). Third-party decoders are additionally
//! run under `catch_unwind`, so a decoder bug on hostile input becomes
//! [`AssetError::Corrupt`] instead of a panic. The library never prints: soft
//! problems (negative radiance clamped, triangles dropped) come back in a
//! [`LoadReport`] next to the data, for the caller to show.
//!
//! # Writes are atomic
//! Writers encode to memory, write `<dir>/.<name>.tmp-<pid>-<n>`, flush it to
//! disk and rename it over the target, so a reader never sees a half-written
//! file and a failed write leaves any previous file intact.

pub mod envmap;
mod error;
pub mod image_io;
pub mod info;
pub mod mesh_io;
pub mod render_exr;

pub use envmap::{
    EnvLayout, encode_env_map, env_map_from_image, grid_size, load_env_map, load_env_map_as,
    load_env_map_faces, write_env_map,
};
pub use error::{AssetError, LoadReport, io_reason};
pub use image_io::{
    ColorEncoding, ImageFormat, RgbImage, ToneMap, ToneOperator, decode_image, encode_exr,
    encode_hdr, encode_png, linear_to_srgb, read_image, read_image_with, write_atomic,
    write_atomic_with, write_exr, write_hdr, write_image, write_png,
};
pub use info::{FileInfo, ImageInfo, MeshInfo, describe};
pub use mesh_io::{MeshFormat, decode_mesh, load_mesh};
pub use relight_geom::{Mesh, RepairReport};
pub use relight_sphere::{EnvMap, Param};
pub use render_exr::{MaskChannels, Masks, read_mask_channels, write_render_exr};

use std::path::Path;

/// Reads a whole file, mapping a missing file to [`AssetError::Missing`].
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, AssetError> {
    std::fs::read(path).map_err(|e| AssetError::from_io(path, e))
}

/// Loads a MERL measured-BRDF binary file (Matusik et al. 2003) with
/// [`relight_brdf::Merl::from_bytes`]; parse errors are mapped to
/// [`AssetError`]s naming the file.
pub fn load_merl(path: &Path) -> Result<relight_brdf::Merl, AssetError> {
    use relight_brdf::BrdfError as B;
    let bytes = read_merl_bytes(path)?;
    relight_brdf::Merl::from_bytes(&bytes).map_err(|e| match e {
        B::MerlTruncated { .. } => AssetError::truncated(path, format!("MERL: {e}")),
        B::MerlDims { .. } => AssetError::bad_dims(path, format!("MERL: {e}")),
        B::MerlNonFinite { count, .. } => AssetError::NonFinite {
            path: path.to_path_buf(),
            count,
        },
        other => AssetError::corrupt(path, format!("MERL: {other}")),
    })
}

/// Reads a MERL measured-BRDF binary file (Matusik et al. 2003) as raw
/// bytes, for `relight_brdf::merl::Merl::from_bytes`. Checks only that the
/// file exists and holds at least the 12-byte dimension header; the parser
/// validates the rest.
pub fn read_merl_bytes(path: &Path) -> Result<Vec<u8>, AssetError> {
    let bytes = read_bytes(path)?;
    if bytes.len() < 12 {
        return Err(AssetError::Truncated {
            path: path.to_path_buf(),
            detail: format!(
                "MERL file has {} bytes, the header alone needs 12",
                bytes.len()
            ),
        });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merl_files_load_and_bad_ones_name_the_file() {
        let dir = std::env::temp_dir().join(format!("relight-merl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let m =
            relight_brdf::Merl::from_fn([4, 3, 8], |_, _| glam::Vec3::new(0.1, 0.2, 0.3)).unwrap();
        let bytes = m.to_bytes();
        let p = dir.join("m.binary");
        write_atomic(&p, &bytes).unwrap();
        assert_eq!(load_merl(&p).unwrap().dims(), [4, 3, 8]);
        write_atomic(&p, &bytes[..bytes.len() - 5]).unwrap();
        let e = load_merl(&p).unwrap_err();
        assert!(
            matches!(e, AssetError::Truncated { .. }) && e.to_string().contains("m.binary"),
            "{e}"
        );
        let mut bad = bytes.clone();
        bad[..4].copy_from_slice(&(-3i32).to_le_bytes());
        write_atomic(&p, &bad).unwrap();
        assert!(matches!(
            load_merl(&p),
            Err(AssetError::BadDimensions { .. })
        ));
        write_atomic(&p, &bytes[..7]).unwrap();
        assert!(matches!(load_merl(&p), Err(AssetError::Truncated { .. })));
        assert!(matches!(
            load_merl(&dir.join("none.binary")),
            Err(AssetError::Missing { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
