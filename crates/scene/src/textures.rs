//! Image files as textures over uv: [`load_texture`] (colour, e.g. an area
//! light's radiance), [`load_weight_texture`] (data: a BRDF blend weight)
//! and [`load_normal_map`] (tangent-space normals).
//!
//! Decoding follows `relight_assets::image_io`: EXR and HDR are linear;
//! 8/16-bit PNG/JPEG are sRGB-decoded for colour textures and taken
//! linearly (`value / max`) for data — weights and normal maps, whose
//! colours `c ∈ [0, 1]³` become tangent-space vectors `2c − 1`
//! ([`NormalMap::from_rgb`], the convention of `relight_render::texture`).

use relight_assets::{AssetError, ColorEncoding, RgbImage, read_image_with};
use relight_render::{NormalMap, Texture, TextureError};
use std::path::{Path, PathBuf};

/// Why an image file does not make a texture.
#[derive(Debug, thiserror::Error)]
pub enum TextureFileError {
    /// The file cannot be read or decoded.
    #[error(transparent)]
    Asset(#[from] AssetError),
    /// The decoded texels are not a valid texture.
    #[error("{}: {source}", path.display())]
    Texels { path: PathBuf, source: TextureError },
}

fn read(path: &Path, enc: ColorEncoding) -> Result<(RgbImage, Vec<String>), TextureFileError> {
    // The asset layer's warnings name the file already.
    let (img, report) = read_image_with(path, enc)?;
    Ok((img, report.warnings))
}

fn texels_err(path: &Path) -> impl FnOnce(TextureError) -> TextureFileError + '_ {
    move |source| TextureFileError::Texels {
        path: path.into(),
        source,
    }
}

/// A colour texture (linear RGB; PNG/JPEG sRGB-decoded), with the decoder's
/// warnings.
///
/// # Errors
/// The file is missing or undecodable.
pub fn load_texture(path: &Path) -> Result<(Texture, Vec<String>), TextureFileError> {
    let (img, w) = read(path, ColorEncoding::Srgb)?;
    let t = Texture::try_new(img.width, img.height, img.pixels).map_err(texels_err(path))?;
    Ok((t, w))
}

/// A data texture (PNG/JPEG taken linearly, no sRGB curve): the BRDF blend
/// weight reads its red channel.
///
/// # Errors
/// The file is missing or undecodable.
pub fn load_weight_texture(path: &Path) -> Result<(Texture, Vec<String>), TextureFileError> {
    let (img, w) = read(path, ColorEncoding::Linear)?;
    let t = Texture::try_new(img.width, img.height, img.pixels).map_err(texels_err(path))?;
    Ok((t, w))
}

/// A tangent-space normal map: colours decoded linearly, `2c − 1`.
///
/// # Errors
/// The file is missing or undecodable, or a texel decodes to a zero vector.
pub fn load_normal_map(path: &Path) -> Result<(NormalMap, Vec<String>), TextureFileError> {
    let (img, w) = read(path, ColorEncoding::Linear)?;
    let m = NormalMap::from_rgb(img.width, img.height, &img.pixels).map_err(texels_err(path))?;
    Ok((m, w))
}
