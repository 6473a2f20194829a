//! Float RGB images: decode EXR / Radiance HDR / PNG / JPEG into linear RGB,
//! encode EXR / HDR / PNG, and write files atomically.
//!
//! # Pixel layout
//! [`RgbImage`] is row-major, row 0 at the top, one linear `Vec3` per pixel
//! (the layout of `relight_render::Image`, so a rendered image converts with
//! a move of its fields).
//!
//! # Decoding rules
//! * EXR: the first valid layer at its largest resolution level. Channels
//!   `R`,`G`,`B` (any layer prefix, e.g. `diffuse.R`), else a luminance `Y`
//!   channel copied to all three; alpha is ignored; half/float/uint samples.
//! * Radiance `.hdr`: flat, new-style RLE and old-style RLE scanlines
//!   (`image`'s decoder), `-Y h +X w` orientation.
//! * PNG/JPEG: 8- or 16-bit; with [`ColorEncoding::Srgb`] (the default) the
//!   sRGB transfer curve is inverted (IEC 61966-2-1), with
//!   [`ColorEncoding::Linear`] values are taken as-is in \[0, 1\] (normal maps).
//! * Any NaN/±Inf sample → [`AssetError::NonFinite`] with the count.
//!   Negative samples are clamped to 0 and reported once, with the pixel
//!   count, in [`LoadReport::warnings`]. Samples above [`MAX_RADIANCE`] are
//!   clamped to it and reported the same way: finite in the file, their sums
//!   and squares (projections, Monte Carlo variance) overflow f32 to ∞.
//!
//! # PNG tone mapping ([`ToneMap`])
//! `v = operator(2^exposure_ev · linear)` per channel, then the sRGB OETF and
//! 8-bit rounding. Operators: `Aces` = Narkowicz's 2015 fit of the ACES
//! filmic curve `x(2.51x+0.03)/(x(2.43x+0.59)+0.14)`; `Reinhard` = `x/(1+x)`;
//! `Clamp` = `min(x, 1)` (no tone mapping, for data and tests).

use crate::error::{AssetError, LoadReport, guard};
use glam::Vec3;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

pub use relight_sphere::MAX_RADIANCE;

/// Largest image accepted by the decoders (pixels), against memory bombs in
/// corrupt headers: 2²⁶ = 8192 × 8192.
pub const MAX_PIXELS: usize = 1 << 26;

/// Most pixels a file of `len` bytes can plausibly hold: deflate, the
/// strongest compressor of these formats, shrinks at most ~1032:1, so a
/// header claiming more than `2048 · len` pixels is corrupt. Checked before
/// the decoders allocate.
fn plausible_pixels(len: usize) -> usize {
    len.saturating_mul(2048).min(MAX_PIXELS)
}

/// A linear float RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<Vec3>,
}

impl RgbImage {
    /// An image; `None` unless `pixels.len() == width * height`.
    #[must_use]
    pub fn try_new(width: usize, height: usize, pixels: Vec<Vec3>) -> Option<Self> {
        (width.checked_mul(height) == Some(pixels.len())).then_some(Self {
            width,
            height,
            pixels,
        })
    }
    /// Pixel at column `x`, row `y`.
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> Vec3 {
        self.pixels[y * self.width + x]
    }
}

/// How 8/16-bit PNG/JPEG values are interpreted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColorEncoding {
    /// sRGB-encoded colour (photos, colour textures): decoded to linear.
    #[default]
    Srgb,
    /// Linear data (normal maps, masks): value / max, no curve.
    Linear,
}

/// Tone-mapping curve for [`write_png`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneOperator {
    /// Narkowicz 2015 ACES filmic fit.
    #[default]
    Aces,
    /// Reinhard `x / (1 + x)`.
    Reinhard,
    /// Clip at 1 (no tone mapping).
    Clamp,
}

/// Exposure and tone mapping for 8-bit output.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToneMap {
    /// Exposure in stops: values are scaled by `2^exposure_ev`.
    pub exposure_ev: f32,
    pub operator: ToneOperator,
}

impl ToneMap {
    /// Maps one linear value to display-referred [0, 1] (before sRGB).
    #[must_use]
    pub fn apply(&self, x: f32) -> f32 {
        self.apply_scaled(x, self.scale())
    }

    /// The exposure factor `2^exposure_ev`, for callers that map many values
    /// with [`ToneMap::apply_scaled`] (one `exp2` per image, not per channel).
    #[must_use]
    pub fn scale(&self) -> f32 {
        self.exposure_ev.exp2()
    }

    /// [`ToneMap::apply`] with the exposure factor `scale` = [`ToneMap::scale`]
    /// computed by the caller: the same result, bit for bit.
    #[must_use]
    #[inline]
    pub fn apply_scaled(&self, x: f32, scale: f32) -> f32 {
        let x = (x * scale).max(0.0);
        let y = match self.operator {
            ToneOperator::Aces => (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14),
            ToneOperator::Reinhard => x / (1.0 + x),
            ToneOperator::Clamp => x,
        };
        if y.is_finite() {
            y.clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// sRGB decoding curve (IEC 61966-2-1), \[0,1\] → \[0,1\].
#[must_use]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB encoding curve (IEC 61966-2-1), \[0,1\] → \[0,1\].
#[must_use]
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Image file formats relight reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Exr,
    Hdr,
    Png,
    Jpeg,
}

const IMAGE_EXTS: &str = ".exr, .hdr, .pic, .png, .jpg or .jpeg";

impl ImageFormat {
    /// The format named by the file extension.
    pub fn from_path(path: &Path) -> Result<Self, AssetError> {
        crate::error::format_by_extension(path, |ext| match ext {
            "exr" => Some(Self::Exr),
            "hdr" | "pic" | "rgbe" => Some(Self::Hdr),
            "png" => Some(Self::Png),
            "jpg" | "jpeg" => Some(Self::Jpeg),
            _ => None,
        })?
        .ok_or_else(|| AssetError::UnknownFormat {
            path: path.to_path_buf(),
            ext: crate::error::lowercase_extension(path),
            expected: IMAGE_EXTS,
        })
    }
    fn magic_ok(self, b: &[u8]) -> bool {
        match self {
            Self::Exr => b.starts_with(&[0x76, 0x2f, 0x31, 0x01]),
            Self::Hdr => b.starts_with(b"#?"),
            Self::Png => b.starts_with(b"\x89PNG\r\n\x1a\n"),
            Self::Jpeg => b.starts_with(&[0xff, 0xd8]),
        }
    }
    /// The format's name in messages (`OpenEXR`, `Radiance HDR`, …).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Exr => "OpenEXR",
            Self::Hdr => "Radiance HDR",
            Self::Png => "PNG",
            Self::Jpeg => "JPEG",
        }
    }
}

/// Reads an image as linear RGB (sRGB decoding for PNG/JPEG); see the module
/// docs for the rules. Negative values are clamped and reported.
pub fn read_image(path: &Path) -> Result<(RgbImage, LoadReport), AssetError> {
    read_image_with(path, ColorEncoding::Srgb)
}

/// [`read_image`] with an explicit interpretation of 8/16-bit formats.
pub fn read_image_with(
    path: &Path,
    enc: ColorEncoding,
) -> Result<(RgbImage, LoadReport), AssetError> {
    let format = ImageFormat::from_path(path)?;
    let bytes = crate::read_bytes(path)?;
    decode_image(&bytes, format, enc, path)
}

/// Decodes an in-memory image; `path` is only used in messages.
pub fn decode_image(
    bytes: &[u8],
    format: ImageFormat,
    enc: ColorEncoding,
    path: &Path,
) -> Result<(RgbImage, LoadReport), AssetError> {
    let mut img = decode_raw(bytes, format, enc, path)?;
    let report = sanitize(&mut img, path)?;
    Ok((img, report))
}

/// Rejects non-finite samples and clamps negative ones (module docs).
pub(crate) fn sanitize(img: &mut RgbImage, path: &Path) -> Result<LoadReport, AssetError> {
    let non_finite: usize = img
        .pixels
        .iter()
        .map(|p| p.to_array().iter().filter(|v| !v.is_finite()).count())
        .sum();
    if non_finite > 0 {
        return Err(AssetError::NonFinite {
            path: path.to_path_buf(),
            count: non_finite,
        });
    }
    let (mut negative, mut huge) = (0, 0);
    for p in &mut img.pixels {
        if p.min_element() < 0.0 {
            negative += 1;
            *p = p.max(Vec3::ZERO);
        }
        if p.max_element() > MAX_RADIANCE {
            huge += 1;
            *p = p.min(Vec3::splat(MAX_RADIANCE));
        }
    }
    let mut report = LoadReport {
        negative_pixels_clamped: negative,
        ..Default::default()
    };
    if negative > 0 {
        report.warnings.push(format!(
            "{}: clamped {negative} pixel(s) with negative values to 0",
            path.display()
        ));
    }
    if huge > 0 {
        report.warnings.push(format!(
            "{}: clamped {huge} pixel(s) above {MAX_RADIANCE:e} to it (larger values overflow f32 in sums)",
            path.display()
        ));
    }
    Ok(report)
}

/// Decodes without the NaN/negative policy (for statistics in `describe`).
pub(crate) fn decode_raw(
    bytes: &[u8],
    format: ImageFormat,
    enc: ColorEncoding,
    path: &Path,
) -> Result<RgbImage, AssetError> {
    if !format.magic_ok(bytes) {
        return Err(if bytes.len() < 4 {
            AssetError::truncated(
                path,
                format!("{} bytes is too short for {}", bytes.len(), format.name()),
            )
        } else {
            AssetError::corrupt(
                path,
                format!("not a {} file (wrong magic bytes)", format.name()),
            )
        });
    }
    guard(path, format.name(), || match format {
        ImageFormat::Exr => decode_exr(bytes, path),
        ImageFormat::Hdr => decode_hdr(bytes, path),
        ImageFormat::Png | ImageFormat::Jpeg => decode_ldr(bytes, format, enc, path),
    })
}

pub(crate) fn exr_error(path: &Path, e: exr::error::Error) -> AssetError {
    use exr::error::Error as E;
    match e {
        E::NotSupported(m) => AssetError::unsupported(path, format!("OpenEXR feature: {m}")),
        E::Invalid(m) => {
            let m = m.to_string();
            if m.contains("end of file") || m.contains("EOF") || m.contains("eof") {
                AssetError::truncated(path, m)
            } else {
                AssetError::corrupt(path, format!("invalid OpenEXR data: {m}"))
            }
        }
        E::Io(io) => match io.kind() {
            std::io::ErrorKind::UnexpectedEof => AssetError::truncated(path, io.to_string()),
            _ => AssetError::corrupt(path, format!("OpenEXR: {io}")),
        },
        E::Aborted => AssetError::corrupt(path, "OpenEXR decoding aborted"),
    }
}

fn decode_exr(bytes: &[u8], path: &Path) -> Result<RgbImage, AssetError> {
    use exr::prelude::*;
    // Check the header first so a corrupt size cannot trigger a huge allocation.
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| exr_error(path, e))?;
    for h in meta.headers.iter() {
        let (w, hgt) = (h.layer_size.0, h.layer_size.1);
        if w == 0 || hgt == 0 || w.saturating_mul(hgt) > plausible_pixels(bytes.len()) {
            return Err(AssetError::bad_dims(
                path,
                format!("EXR layer of {w}×{hgt} pixels"),
            ));
        }
        if h.deep {
            return Err(AssetError::unsupported(path, "deep OpenEXR data"));
        }
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| exr_error(path, e))?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let n = width * height;
    let find = |name: &str| {
        layer.channel_data.list.iter().find(|c| {
            let full = c.name.to_string();
            full.rsplit('.').next() == Some(name) || full.eq_ignore_ascii_case(name)
        })
    };
    let channel_values =
        |c: &AnyChannel<FlatSamples>| -> std::result::Result<Vec<f32>, AssetError> {
            if c.sample_data.len() != n {
                return Err(AssetError::unsupported(
                    path,
                    format!("subsampled OpenEXR channel `{}`", c.name),
                ));
            }
            Ok(c.sample_data.values_as_f32().collect())
        };
    let pixels: Vec<Vec3> = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => {
            let (r, g, b) = (channel_values(r)?, channel_values(g)?, channel_values(b)?);
            (0..n).map(|i| Vec3::new(r[i], g[i], b[i])).collect()
        }
        (_, _, _, Some(y)) => channel_values(y)?.into_iter().map(Vec3::splat).collect(),
        _ => {
            let names: Vec<String> = layer
                .channel_data
                .list
                .iter()
                .map(|c| c.name.to_string())
                .collect();
            return Err(AssetError::unsupported(
                path,
                format!(
                    "OpenEXR without R,G,B or Y channels (has: {})",
                    names.join(", ")
                ),
            ));
        }
    };
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

fn image_error(path: &Path, what: &str, e: image::ImageError) -> AssetError {
    use image::ImageError as E;
    match e {
        E::Unsupported(u) => AssetError::unsupported(path, format!("{what}: {u}")),
        E::Limits(l) => AssetError::bad_dims(path, format!("{what}: {l}")),
        E::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            AssetError::truncated(path, format!("{what}: {io}"))
        }
        other => {
            let m = other.to_string();
            if m.to_ascii_lowercase().contains("eof")
                || m.contains("end of file")
                || m.contains("truncat")
            {
                AssetError::truncated(path, format!("{what}: {m}"))
            } else {
                AssetError::corrupt(path, format!("{what}: {m}"))
            }
        }
    }
}

fn check_dims(path: &Path, w: u32, h: u32, len: usize) -> Result<(), AssetError> {
    if w == 0 || h == 0 || (w as usize).saturating_mul(h as usize) > plausible_pixels(len) {
        return Err(AssetError::bad_dims(
            path,
            format!(
                "{w}×{h} pixels is empty, above the {MAX_PIXELS}-pixel limit or more than a {len}-byte file can hold"
            ),
        ));
    }
    Ok(())
}

/// Checks that a Radiance header is complete before the image crate reads
/// it: header lines, one empty line, then the resolution line
/// (`-Y H +X W`). A file cut inside the header is truncated; the decoder
/// would otherwise report a half-read `FORMAT=` line as an unsupported
/// format.
fn check_hdr_header(bytes: &[u8], path: &Path) -> Result<(), AssetError> {
    let n = bytes.len();
    let Some(end) = bytes.windows(2).position(|w| w == b"\n\n") else {
        return Err(AssetError::truncated(
            path,
            format!("Radiance HDR: the file ends inside its header ({n} bytes)"),
        ));
    };
    let rest = &bytes[end + 2..];
    let Some(eol) = rest.iter().position(|&b| b == b'\n') else {
        return Err(AssetError::truncated(
            path,
            format!("Radiance HDR: the file ends inside its resolution line ({n} bytes)"),
        ));
    };
    let line = String::from_utf8_lossy(&rest[..eol]);
    let words: Vec<&str> = line.split_whitespace().collect();
    let axis = |w: &str| matches!(w, "-Y" | "+Y" | "-X" | "+X");
    let ok = words.len() == 4
        && axis(words[0])
        && axis(words[2])
        && words[1].parse::<u32>().is_ok()
        && words[3].parse::<u32>().is_ok();
    if !ok {
        return Err(AssetError::corrupt(
            path,
            format!("Radiance HDR: bad resolution line `{line}` (expected e.g. `-Y 256 +X 512`)"),
        ));
    }
    Ok(())
}

fn decode_hdr(bytes: &[u8], path: &Path) -> Result<RgbImage, AssetError> {
    use image::ImageDecoder;
    check_hdr_header(bytes, path)?;
    let dec = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes))
        .map_err(|e| image_error(path, "Radiance HDR", e))?;
    let (w, h) = dec.dimensions();
    check_dims(path, w, h, bytes.len())?;
    let mut buf = vec![0u8; dec.total_bytes() as usize];
    dec.read_image(&mut buf)
        .map_err(|e| image_error(path, "Radiance HDR", e))?;
    let pixels = buf
        .chunks_exact(12)
        .map(|c| {
            let f = |k: usize| f32::from_ne_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
            Vec3::new(f(0), f(4), f(8))
        })
        .collect();
    Ok(RgbImage {
        width: w as usize,
        height: h as usize,
        pixels,
    })
}

fn decode_ldr(
    bytes: &[u8],
    format: ImageFormat,
    enc: ColorEncoding,
    path: &Path,
) -> Result<RgbImage, AssetError> {
    let fmt = match format {
        ImageFormat::Png => image::ImageFormat::Png,
        _ => image::ImageFormat::Jpeg,
    };
    let (w, h) = image::ImageReader::with_format(Cursor::new(bytes), fmt)
        .into_dimensions()
        .map_err(|e| image_error(path, format.name(), e))?;
    check_dims(path, w, h, bytes.len())?;
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), fmt);
    let mut limits = image::Limits::default();
    limits.max_alloc = Some((MAX_PIXELS as u64) * 8);
    reader.limits(limits);
    let dynimg = reader
        .decode()
        .map_err(|e| image_error(path, format.name(), e))?;
    let rgb = dynimg.into_rgb32f();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    let curve = |v: f32| match enc {
        ColorEncoding::Srgb => srgb_to_linear(v),
        ColorEncoding::Linear => v,
    };
    let pixels = rgb
        .pixels()
        .map(|p| Vec3::new(curve(p.0[0]), curve(p.0[1]), curve(p.0[2])))
        .collect();
    Ok(RgbImage {
        width: w,
        height: h,
        pixels,
    })
}

pub(crate) fn check_pixels(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
) -> Result<(), AssetError> {
    if width == 0 || height == 0 || width.checked_mul(height) != Some(pixels.len()) {
        return Err(AssetError::bad_dims(
            path,
            format!("{width}×{height} image given {} pixels", pixels.len()),
        ));
    }
    Ok(())
}

/// Encodes linear f32 RGB as a ZIP-compressed scanline OpenEXR file in memory.
pub fn encode_exr(
    width: usize,
    height: usize,
    pixels: &[Vec3],
    path: &Path,
) -> Result<Vec<u8>, AssetError> {
    encode_exr_with(
        width,
        height,
        pixels,
        exr::prelude::Encoding::SMALL_LOSSLESS,
        path,
    )
}

/// [`encode_exr`] with a chosen `exr` encoding (compression, tiles).
pub fn encode_exr_with(
    width: usize,
    height: usize,
    pixels: &[Vec3],
    encoding: exr::prelude::Encoding,
    path: &Path,
) -> Result<Vec<u8>, AssetError> {
    use exr::prelude::*;
    check_pixels(path, width, height, pixels)?;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = pixels[y * width + x];
        (p.x, p.y, p.z)
    });
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        encoding,
        channels,
    );
    let image = Image::from_layer(layer);
    let mut out = Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut out)
        .map_err(|e| exr_write_error(path, e))?;
    Ok(out.into_inner())
}

/// An `exr` encoder failure as the error naming `path`.
pub(crate) fn exr_write_error(path: &Path, e: exr::error::Error) -> AssetError {
    match e {
        exr::error::Error::Io(error) => AssetError::Write {
            path: path.to_path_buf(),
            error,
        },
        other => AssetError::corrupt(path, format!("OpenEXR encoding failed: {other}")),
    }
}

/// Encodes linear RGB as run-length-encoded Radiance RGBE in memory.
/// Negative and non-finite values are written as 0.
pub fn encode_hdr(
    width: usize,
    height: usize,
    pixels: &[Vec3],
    path: &Path,
) -> Result<Vec<u8>, AssetError> {
    check_pixels(path, width, height, pixels)?;
    let rgb: Vec<image::Rgb<f32>> = pixels
        .iter()
        .map(|p| {
            let c = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
            image::Rgb([c(p.x), c(p.y), c(p.z)])
        })
        .collect();
    let mut out = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut out)
        .encode(&rgb, width, height)
        .map_err(|e| AssetError::corrupt(path, format!("HDR encoding failed: {e}")))?;
    Ok(out)
}

/// Encodes linear RGB as an 8-bit sRGB PNG after exposure and tone mapping.
pub fn encode_png(
    width: usize,
    height: usize,
    pixels: &[Vec3],
    tone: ToneMap,
    path: &Path,
) -> Result<Vec<u8>, AssetError> {
    use image::ImageEncoder;
    check_pixels(path, width, height, pixels)?;
    let (w, h) = (
        u32::try_from(width).map_err(|_| AssetError::bad_dims(path, "width too large for PNG"))?,
        u32::try_from(height)
            .map_err(|_| AssetError::bad_dims(path, "height too large for PNG"))?,
    );
    let scale = tone.scale();
    let q = |v: f32| (linear_to_srgb(tone.apply_scaled(v, scale)) * 255.0 + 0.5) as u8;
    let bytes: Vec<u8> = pixels
        .iter()
        .flat_map(|p| [q(p.x), q(p.y), q(p.z)])
        .collect();
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&bytes, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| AssetError::corrupt(path, format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically: a temporary file in the same
/// directory, flushed to disk, then renamed over `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), AssetError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes to `path` atomically, streaming: `write` fills a buffered writer on
/// a temporary file in the same directory, which is flushed to disk and
/// renamed over `path` only when `write` succeeds (else it is removed). The
/// one atomic-write helper of relight: images, bakes and JSON all go
/// through it.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<(), AssetError> {
    let werr = |error| AssetError::Write {
        path: path.to_path_buf(),
        error,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| AssetError::Write {
        path: path.to_path_buf(),
        error: std::io::Error::new(std::io::ErrorKind::InvalidInput, "path has no file name"),
    })?;
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        TMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let f = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
        write(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(werr(e));
    }
    Ok(())
}

/// Writes linear RGB as OpenEXR (f32, ZIP), atomically.
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
) -> Result<(), AssetError> {
    write_atomic(path, &encode_exr(width, height, pixels, path)?)
}

/// Writes linear RGB as RLE Radiance HDR, atomically.
pub fn write_hdr(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
) -> Result<(), AssetError> {
    write_atomic(path, &encode_hdr(width, height, pixels, path)?)
}

/// Writes a tone-mapped 8-bit sRGB PNG, atomically.
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
    tone: ToneMap,
) -> Result<(), AssetError> {
    write_atomic(path, &encode_png(width, height, pixels, tone, path)?)
}

/// Writes by extension: `.exr`/`.hdr` linear, `.png` tone mapped with `tone`.
pub fn write_image(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
    tone: ToneMap,
) -> Result<(), AssetError> {
    match ImageFormat::from_path(path)? {
        ImageFormat::Exr => write_exr(path, width, height, pixels),
        ImageFormat::Hdr => write_hdr(path, width, height, pixels),
        ImageFormat::Png => write_png(path, width, height, pixels, tone),
        ImageFormat::Jpeg => Err(AssetError::unsupported(
            path,
            "writing JPEG (use .png, .exr or .hdr)",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Vec<Vec3> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                Vec3::new(x * 0.37 + 0.01, y * 13.0 + 0.5, 1e-3 + (x * y) * 7.0)
            })
            .collect()
    }

    #[test]
    fn apply_scaled_is_apply_bit_for_bit() {
        for operator in [
            ToneOperator::Aces,
            ToneOperator::Reinhard,
            ToneOperator::Clamp,
        ] {
            for ev in [-3.5f32, 0.0, 0.7, 4.0] {
                let tone = ToneMap {
                    exposure_ev: ev,
                    operator,
                };
                let scale = tone.scale();
                assert_eq!(scale, 2f32.powf(ev));
                for x in [
                    -1.0f32,
                    0.0,
                    1e-6,
                    0.18,
                    1.0,
                    7.3,
                    1e30,
                    f32::NAN,
                    f32::INFINITY,
                ] {
                    assert_eq!(
                        tone.apply_scaled(x, scale).to_bits(),
                        tone.apply(x).to_bits(),
                        "{operator:?} ev {ev} x {x}"
                    );
                }
            }
        }
    }

    #[test]
    fn exr_round_trip_every_encoding() {
        use exr::prelude::{Blocks, Compression, Encoding, LineOrder, Vec2};
        let (w, h) = (37, 19);
        let px = ramp(w, h);
        let p = Path::new("mem.exr");
        for compression in [
            Compression::Uncompressed,
            Compression::RLE,
            Compression::ZIP1,
            Compression::ZIP16,
            Compression::PIZ,
        ] {
            for blocks in [Blocks::ScanLines, Blocks::Tiles(Vec2(16, 8))] {
                let enc = Encoding {
                    compression,
                    blocks,
                    line_order: LineOrder::Increasing,
                };
                let bytes = encode_exr_with(w, h, &px, enc, p).unwrap();
                let (img, rep) =
                    decode_image(&bytes, ImageFormat::Exr, ColorEncoding::Srgb, p).unwrap();
                assert_eq!((img.width, img.height), (w, h));
                assert_eq!(img.pixels, px, "{compression:?} {blocks:?}");
                assert!(rep.warnings.is_empty());
            }
        }
    }

    #[test]
    fn exr_lossy_half_and_luminance_channels() {
        use exr::prelude::*;
        let (w, h) = (16usize, 8usize);
        // Half-float Y-only image with PXR24/B44 (lossy) compression.
        for compression in [Compression::PXR24, Compression::B44] {
            let ch = AnyChannel::new(
                "Y",
                FlatSamples::F16(
                    (0..w * h)
                        .map(|i| f16::from_f32(1.0 + i as f32 * 0.01))
                        .collect(),
                ),
            );
            let layer = Layer::new(
                (w, h),
                LayerAttributes::default(),
                Encoding {
                    compression,
                    blocks: Blocks::ScanLines,
                    line_order: LineOrder::Increasing,
                },
                AnyChannels::sort(SmallVec::from_vec(vec![ch])),
            );
            let mut out = Cursor::new(Vec::new());
            Image::from_layer(layer)
                .write()
                .to_buffered(&mut out)
                .unwrap();
            let p = Path::new("y.exr");
            let (img, _) =
                decode_image(out.get_ref(), ImageFormat::Exr, ColorEncoding::Srgb, p).unwrap();
            for (i, px) in img.pixels.iter().enumerate() {
                let want = 1.0 + i as f32 * 0.01;
                // PXR24 keeps 15 mantissa bits; B44 quantises each 4×4 block's
                // differences to 6 bits (lossy; fine on this smooth ramp).
                let tol = if compression == Compression::B44 {
                    0.02 * want
                } else {
                    1e-3 * want
                };
                assert!(
                    (px.x - want).abs() <= tol,
                    "{compression:?} {i}: {px} vs {want}"
                );
                assert_eq!(px.x, px.y);
            }
        }
    }

    #[test]
    fn hdr_rle_round_trip_to_rgbe_precision() {
        let (w, h) = (64, 9); // ≥ 8 wide: the encoder uses new-style RLE
        let mut px = ramp(w, h);
        px[3] = Vec3::splat(2.0); // runs for RLE
        px[4] = Vec3::splat(2.0);
        let p = Path::new("mem.hdr");
        let bytes = encode_hdr(w, h, &px, p).unwrap();
        let (img, _) = decode_image(&bytes, ImageFormat::Hdr, ColorEncoding::Srgb, p).unwrap();
        for (a, b) in img.pixels.iter().zip(&px) {
            // RGBE keeps 8 mantissa bits of the largest channel.
            let tol = b.max_element() / 128.0;
            assert!((*a - *b).abs().max_element() <= tol, "{a} vs {b}");
        }
    }

    /// A Radiance file cut anywhere in its header or pixels is a truncated
    /// (or corrupt) file, never "format '32' not supported"; the 20-byte
    /// cut of issue 11 says the file is truncated.
    #[test]
    fn hdr_cut_anywhere_is_truncated_or_corrupt() {
        let (w, h) = (16, 4);
        let p = Path::new("cut.hdr");
        let bytes = encode_hdr(w, h, &ramp(w, h), p).unwrap();
        for cut in 4..bytes.len() {
            let e = decode_image(&bytes[..cut], ImageFormat::Hdr, ColorEncoding::Srgb, p)
                .expect_err("a cut file is an error");
            assert!(
                matches!(e, AssetError::Truncated { .. } | AssetError::Corrupt { .. }),
                "cut {cut}: {e}"
            );
        }
        let e = decode_image(&bytes[..20], ImageFormat::Hdr, ColorEncoding::Srgb, p).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("truncated") && msg.contains("header") && !msg.contains("'32'"),
            "{msg}"
        );
    }

    #[test]
    fn nan_is_an_error_and_negatives_are_clamped_once() {
        let p = Path::new("bad.exr");
        let mut px = ramp(8, 4);
        px[0].x = -1.0;
        px[5] = Vec3::splat(-0.5);
        let bytes = encode_exr(8, 4, &px, p).unwrap();
        let (img, rep) = decode_image(&bytes, ImageFormat::Exr, ColorEncoding::Srgb, p).unwrap();
        assert_eq!(rep.negative_pixels_clamped, 2);
        assert_eq!(rep.warnings.len(), 1);
        assert!(
            rep.warnings[0].contains("2 pixel") && rep.warnings[0].contains("bad.exr"),
            "{:?}",
            rep.warnings
        );
        assert!(img.pixels.iter().all(|p| p.min_element() >= 0.0));
        // Finite but overflow-prone samples are clamped to MAX_RADIANCE.
        let mut big = px.clone();
        big[7] = Vec3::new(3e38, 1.0, 2e12);
        let bytes = encode_exr(8, 4, &big, p).unwrap();
        let (img, rep) = decode_image(&bytes, ImageFormat::Exr, ColorEncoding::Srgb, p).unwrap();
        assert_eq!(img.pixels[7], Vec3::new(MAX_RADIANCE, 1.0, MAX_RADIANCE));
        assert!(
            rep.warnings
                .iter()
                .any(|w| w.contains("bad.exr") && w.contains("1 pixel(s) above 1e12")),
            "{:?}",
            rep.warnings
        );
        px[1].y = f32::NAN;
        px[2].z = f32::INFINITY;
        let bytes = encode_exr(8, 4, &px, p).unwrap();
        let err = decode_image(&bytes, ImageFormat::Exr, ColorEncoding::Srgb, p).unwrap_err();
        assert!(
            matches!(err, AssetError::NonFinite { count: 2, .. }),
            "{err}"
        );
        assert!(err.to_string().contains("bad.exr"), "{err}");
    }

    #[test]
    fn png_tone_mapping_and_srgb() {
        let p = Path::new("t.png");
        // Clamp operator at 0 EV: sRGB(0.5 linear) = 188/255; round trip back.
        let px = vec![Vec3::new(0.0, 0.5, 1.0), Vec3::splat(0.214_041)];
        let bytes = encode_png(
            2,
            1,
            &px,
            ToneMap {
                exposure_ev: 0.0,
                operator: ToneOperator::Clamp,
            },
            p,
        )
        .unwrap();
        let (img, _) = decode_image(&bytes, ImageFormat::Png, ColorEncoding::Srgb, p).unwrap();
        for (a, b) in img.pixels.iter().zip(&px) {
            assert!((*a - *b).abs().max_element() < 4e-3, "{a} vs {b}");
        }
        let lin = decode_image(&bytes, ImageFormat::Png, ColorEncoding::Linear, p)
            .unwrap()
            .0;
        assert!(
            (lin.pixels[0].y - 188.0 / 255.0).abs() < 1e-6,
            "{}",
            lin.pixels[0].y
        );
        // Tone curves are monotone, map 0 → 0 and saturate below 1.
        for op in [ToneOperator::Aces, ToneOperator::Reinhard] {
            let t = ToneMap {
                exposure_ev: 1.0,
                operator: op,
            };
            assert_eq!(t.apply(0.0), 0.0);
            let mut prev = 0.0;
            for i in 1..200 {
                let v = t.apply(i as f32 * 0.1);
                assert!(v >= prev && v <= 1.0, "{op:?} not monotone at {i}");
                prev = v;
            }
            assert!(t.apply(f32::INFINITY) <= 1.0);
        }
    }

    #[test]
    fn jpeg_and_rgba_exr_decode() {
        use image::ImageEncoder;
        // A flat mid-grey JPEG: sRGB 128 → linear 0.2158.
        let (w, h) = (16u32, 16u32);
        let px = vec![128u8; (w * h * 3) as usize];
        let mut jpg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpg, 95)
            .write_image(&px, w, h, image::ExtendedColorType::Rgb8)
            .unwrap();
        let p = Path::new("g.jpg");
        let (img, _) = decode_image(&jpg, ImageFormat::Jpeg, ColorEncoding::Srgb, p).unwrap();
        let want = srgb_to_linear(128.0 / 255.0);
        assert!(
            img.pixels
                .iter()
                .all(|q| (*q - Vec3::splat(want)).abs().max_element() < 0.01),
            "{}",
            img.pixels[0]
        );
        // RGBA half-float EXR: alpha ignored.
        use exr::prelude::*;
        let ch = SpecificChannels::rgba(|Vec2(x, _y): Vec2<usize>| {
            (
                f16::from_f32(x as f32),
                f16::from_f32(0.5),
                f16::from_f32(2.0),
                f16::from_f32(0.25),
            )
        });
        let mut out = Cursor::new(Vec::new());
        Image::from_channels((4, 2), ch)
            .write()
            .to_buffered(&mut out)
            .unwrap();
        let (img, _) = decode_image(
            out.get_ref(),
            ImageFormat::Exr,
            ColorEncoding::Srgb,
            Path::new("a.exr"),
        )
        .unwrap();
        assert_eq!(img.get(3, 1), Vec3::new(3.0, 0.5, 2.0));
    }

    #[test]
    fn atomic_writes_and_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("relight-assets-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let px = ramp(4, 3);
        for name in ["a.exr", "a.hdr", "a.png"] {
            let path = dir.join(name);
            write_image(&path, 4, 3, &px, ToneMap::default()).unwrap();
            let (img, _) = read_image(&path).unwrap();
            assert_eq!((img.width, img.height), (4, 3));
        }
        // No temporary files left behind.
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
            .collect();
        assert!(left.is_empty());
        // Writing into a missing directory fails with the path, no panic.
        let bad = dir.join("no/such/dir/x.exr");
        let e = write_exr(&bad, 4, 3, &px).unwrap_err();
        assert!(e.to_string().contains("x.exr"), "{e}");
        assert!(matches!(
            write_exr(&dir.join("z.exr"), 5, 3, &px),
            Err(AssetError::BadDimensions { .. })
        ));
        let e = read_image(&dir.join("missing.exr")).unwrap_err();
        assert!(
            matches!(e, AssetError::Missing { .. }) && e.to_string().contains("missing.exr"),
            "{e}"
        );
        assert!(matches!(
            read_image(&dir.join("x.tga")),
            Err(AssetError::UnknownFormat { .. })
        ));
        // A folder, even one named like an image, is said to be a folder.
        std::fs::create_dir_all(dir.join("folder.exr")).unwrap();
        for p in [dir.clone(), dir.join("folder.exr")] {
            let e = read_image(&p).unwrap_err();
            assert!(matches!(e, AssetError::Folder { .. }), "{e}");
            assert!(e.to_string().ends_with("is a folder, not a file"), "{e}");
        }
        assert!(matches!(
            crate::load_mesh(&dir),
            Err(AssetError::Folder { .. })
        ));
        // An .exr that is really a PNG.
        std::fs::copy(dir.join("a.png"), dir.join("fake.exr")).unwrap();
        let e = read_image(&dir.join("fake.exr")).unwrap_err();
        assert!(matches!(e, AssetError::Corrupt { .. }), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
