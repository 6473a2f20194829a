//! Rendered images as OpenEXR with mask channels beside the colour.
//!
//! Every render relight writes is an EXR with five channels:
//!
//! | channel | type | meaning |
//! |---|---|---|
//! | `R`, `G`, `B` | f32 | linear radiance |
//! | `coverage` | f32 | fraction of the pixel covered by objects, in [0, 1] |
//! | `object_id` | u32 | 1 + index of the object covering most of the pixel; 0 = background |
//!
//! so that `relight compare` — and any outside tool — can restrict a
//! comparison to object or background pixels. Readers that only know RGB
//! (every EXR viewer) ignore the extra channels.

use crate::AssetError;
use crate::image_io::{check_pixels, exr_error, exr_write_error, write_atomic};
use glam::Vec3;
use std::io::Cursor;
use std::path::Path;

/// Name of the coverage channel.
pub const COVERAGE_CHANNEL: &str = "coverage";
/// Name of the object-id channel.
pub const OBJECT_ID_CHANNEL: &str = "object_id";

/// Per-pixel masks written beside the colour (row-major, one value a pixel).
#[derive(Clone, Copy, Debug)]
pub struct MaskChannels<'a> {
    pub coverage: &'a [f32],
    pub object_id: &'a [u32],
}

/// The mask channels read back from an EXR ([`read_mask_channels`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Masks {
    pub width: usize,
    pub height: usize,
    pub coverage: Option<Vec<f32>>,
    pub object_id: Option<Vec<u32>>,
}

/// Encodes linear RGB plus [`MaskChannels`] as OpenEXR (f32/u32, ZIP) in memory.
///
/// # Errors
/// Mismatched sizes, non-finite pixels, or an encoder failure.
pub fn encode_render_exr(
    width: usize,
    height: usize,
    pixels: &[Vec3],
    masks: MaskChannels,
    path: &Path,
) -> Result<Vec<u8>, AssetError> {
    use exr::prelude::*;
    check_pixels(path, width, height, pixels)?;
    let n = width * height;
    if masks.coverage.len() != n || masks.object_id.len() != n {
        return Err(AssetError::bad_dims(
            path,
            format!(
                "{} coverage and {} object-id values for a {width}×{height} image",
                masks.coverage.len(),
                masks.object_id.len()
            ),
        ));
    }
    let f = |c: fn(&Vec3) -> f32| FlatSamples::F32(pixels.iter().map(c).collect());
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        AnyChannel::new("R", f(|p| p.x)),
        AnyChannel::new("G", f(|p| p.y)),
        AnyChannel::new("B", f(|p| p.z)),
        AnyChannel::new(
            COVERAGE_CHANNEL,
            FlatSamples::F32(masks.coverage.iter().map(|c| c.clamp(0.0, 1.0)).collect()),
        ),
        AnyChannel::new(
            OBJECT_ID_CHANNEL,
            FlatSamples::U32(masks.object_id.to_vec()),
        ),
    ]));
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let mut out = Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .map_err(|e| exr_write_error(path, e))?;
    Ok(out.into_inner())
}

/// Writes linear RGB plus [`MaskChannels`] as OpenEXR, atomically.
///
/// # Errors
/// As [`encode_render_exr`], or the write.
pub fn write_render_exr(
    path: &Path,
    width: usize,
    height: usize,
    pixels: &[Vec3],
    masks: MaskChannels,
) -> Result<(), AssetError> {
    write_atomic(
        path,
        &encode_render_exr(width, height, pixels, masks, path)?,
    )
}

/// Reads the `coverage` and `object_id` channels of an EXR, where present
/// (an EXR from another tool has neither: both `None`).
///
/// # Errors
/// The file cannot be read or is not a valid EXR.
pub fn read_mask_channels(path: &Path) -> Result<Masks, AssetError> {
    use exr::prelude::*;
    let bytes = crate::read_bytes(path)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(&bytes))
        .map_err(|e| exr_error(path, e))?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let find = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name && c.sample_data.len() == width * height)
    };
    let coverage = find(COVERAGE_CHANNEL).map(|c| c.sample_data.values_as_f32().collect());
    let object_id = find(OBJECT_ID_CHANNEL).map(|c| match &c.sample_data {
        FlatSamples::U32(v) => v.clone(),
        other => other.values_as_f32().map(|v| v.max(0.0) as u32).collect(),
    });
    Ok(Masks {
        width,
        height,
        coverage,
        object_id,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_round_trip_and_rgb_readers_still_work() {
        let dir = std::env::temp_dir().join(format!("relight-render-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("masks.exr");
        let (w, h) = (3, 2);
        let pixels: Vec<Vec3> = (0..6).map(|i| Vec3::splat(i as f32 * 0.5)).collect();
        let coverage = [0.0, 0.25, 1.0, 1.0, 0.5, 0.0];
        let ids = [0, 2, 2, 1, 1, 0];
        write_render_exr(
            &path,
            w,
            h,
            &pixels,
            MaskChannels {
                coverage: &coverage,
                object_id: &ids,
            },
        )
        .unwrap();
        let m = read_mask_channels(&path).unwrap();
        assert_eq!((m.width, m.height), (w, h));
        assert_eq!(m.coverage.as_deref(), Some(&coverage[..]));
        assert_eq!(m.object_id.as_deref(), Some(&ids[..]));
        let (rgb, _) = crate::read_image(&path).unwrap();
        assert_eq!(rgb.pixels, pixels);
        // A plain EXR has no masks.
        let plain = dir.join("plain.exr");
        crate::write_exr(&plain, w, h, &pixels).unwrap();
        let m = read_mask_channels(&plain).unwrap();
        assert_eq!((m.coverage, m.object_id), (None, None));
        let bad = encode_render_exr(
            w,
            h,
            &pixels,
            MaskChannels {
                coverage: &coverage[..5],
                object_id: &ids,
            },
            &path,
        );
        assert!(bad.is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
