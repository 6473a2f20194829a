//! `relight compare`: the verify measure between two images.
//!
//! The relative RMS error √(Σ|a − r|² / Σ|r|²) over a region's pixels (RGB
//! pooled, [`Image::relative_rms_error`]). The region comes from the
//! `coverage` channel every relight EXR carries (`relight_assets::render_exr`):
//! `object` (default) = pixels fully covered by objects in both images,
//! `background` = pixels no object touches in either, `all` = every pixel.
//! Object pixels measure shading, not how the background was filtered.

use crate::args::Region;
use crate::output::{warn_all, write_outputs};
use anyhow::{Result, bail, ensure};
use relight_assets::ImageFormat;
use relight_render::Image;
use std::path::Path;

struct Loaded {
    image: Image,
    coverage: Option<Vec<f32>>,
}

fn load(path: &Path) -> Result<Loaded> {
    let (img, report) = relight_assets::read_image(path)?;
    warn_all(&report.warnings);
    let coverage = if ImageFormat::from_path(path)? == ImageFormat::Exr {
        relight_assets::read_mask_channels(path)?.coverage
    } else {
        None
    };
    Ok(Loaded {
        image: Image {
            width: img.width,
            height: img.height,
            pixels: img.pixels,
        },
        coverage,
    })
}

/// Runs `relight compare`.
pub fn compare(image: &Path, reference: &Path, region: Region, diff: Option<&Path>) -> Result<()> {
    let (fa, fr) = (
        ImageFormat::from_path(image)?,
        ImageFormat::from_path(reference)?,
    );
    let linear = |f: ImageFormat| matches!(f, ImageFormat::Exr | ImageFormat::Hdr);
    ensure!(
        linear(fa) == linear(fr),
        "{} and {}: cannot compare a tone-mapped 8-bit image with a linear one (compare the EXRs relight writes beside every PNG)",
        image.display(),
        reference.display()
    );
    let (a, r) = (load(image)?, load(reference)?);
    ensure!(
        (a.image.width, a.image.height) == (r.image.width, r.image.height),
        "{} is {}×{} but {} is {}×{}",
        image.display(),
        a.image.width,
        a.image.height,
        reference.display(),
        r.image.width,
        r.image.height
    );
    ensure!(
        a.image
            .pixels
            .iter()
            .chain(&r.image.pixels)
            .all(|p| p.is_finite()),
        "{} or {} holds NaN or Inf pixels",
        image.display(),
        reference.display()
    );
    let mask: Option<Vec<bool>> = match region {
        Region::All => None,
        Region::Object | Region::Background => {
            let (Some(ca), Some(cr)) = (&a.coverage, &r.coverage) else {
                let missing = if a.coverage.is_none() {
                    image
                } else {
                    reference
                };
                bail!(
                    "{}: no coverage channel, so --region {} cannot be found (relight's EXRs carry one; use --region all for other images)",
                    missing.display(),
                    region.name()
                );
            };
            Some(
                ca.iter()
                    .zip(cr)
                    .map(|(&x, &y)| match region {
                        Region::Object => x >= 1.0 && y >= 1.0,
                        _ => x <= 0.0 && y <= 0.0,
                    })
                    .collect(),
            )
        }
    };
    let pixels = mask
        .as_ref()
        .map_or(a.image.pixels.len(), |m| m.iter().filter(|&&b| b).count());
    ensure!(
        pixels > 0,
        "--region {}: no pixel of {} and {} is in that region",
        region.name(),
        image.display(),
        reference.display()
    );
    let rel = a.image.relative_rms_error(&r.image, mask.as_deref());
    ensure!(
        rel.is_finite(),
        "{}: the reference is black over the {} region",
        reference.display(),
        region.name()
    );
    let max = a
        .image
        .pixels
        .iter()
        .zip(&r.image.pixels)
        .enumerate()
        .filter(|(i, _)| mask.as_ref().is_none_or(|m| m[*i]))
        .map(|(_, (p, q))| (*p - *q).abs().max_element())
        .fold(0.0f32, f32::max);
    println!(
        "relight compare: region {} ({pixels} of {} pixels): relative RMS {rel:.5}, largest pixel difference {max:.5}",
        region.name(),
        a.image.pixels.len()
    );
    if let Some(out) = diff {
        let mut img = Image::new(a.image.width, a.image.height);
        for ((o, p), q) in img
            .pixels
            .iter_mut()
            .zip(&a.image.pixels)
            .zip(&r.image.pixels)
        {
            *o = (*p - *q).abs();
        }
        let (png, exr) = write_outputs(&img, None, out)?;
        println!(
            "relight compare: wrote {} and {}",
            png.display(),
            exr.display()
        );
    }
    Ok(())
}
