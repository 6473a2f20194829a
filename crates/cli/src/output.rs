//! Where images leave the CLI: a tone-mapped PNG and a linear EXR side by
//! side, the EXR with `coverage` and `object_id` channels when the image is a
//! render (`relight_assets::render_exr`).

use anyhow::{Result, bail, ensure};
use relight_assets::{MaskChannels, ToneMap, write_exr, write_png, write_render_exr};
use relight_render::{Coverage, Image};
use std::path::{Path, PathBuf};

/// Prints each warning on stderr, `relight: warning: …`.
pub fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("relight: warning: {w}");
    }
}

/// The PNG and EXR paths for `--out PATH` (which ends in `.png` or `.exr`).
///
/// # Errors
/// Another extension, or a folder that does not exist (checked before any
/// work starts).
pub fn output_paths(out: &Path) -> Result<(PathBuf, PathBuf)> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let paths = match ext.as_str() {
        "png" => (out.to_path_buf(), out.with_extension("exr")),
        "exr" => (out.with_extension("png"), out.to_path_buf()),
        _ => bail!(
            "--out {}: the output must end in .png or .exr",
            out.display()
        ),
    };
    if let Some(dir) = out.parent()
        && !dir.as_os_str().is_empty()
    {
        ensure!(
            dir.is_dir(),
            "--out {}: folder {} does not exist",
            out.display(),
            dir.display()
        );
    }
    Ok(paths)
}

/// Writes `image` as a tone-mapped PNG and a linear EXR (see
/// [`output_paths`]), the EXR with the masks of `coverage` when given;
/// returns both paths.
///
/// # Errors
/// A bad path, non-finite pixels (nothing written), or the writes.
pub fn write_outputs(
    image: &Image,
    coverage: Option<&Coverage>,
    out: &Path,
) -> Result<(PathBuf, PathBuf)> {
    let (png, exr) = output_paths(out)?;
    ensure!(
        image.pixels.iter().all(|p| p.is_finite()),
        "internal error: the rendered image has non-finite pixels; nothing written"
    );
    write_png(
        &png,
        image.width,
        image.height,
        &image.pixels,
        ToneMap::default(),
    )?;
    match coverage {
        Some(c) => write_render_exr(
            &exr,
            image.width,
            image.height,
            &image.pixels,
            MaskChannels {
                coverage: &c.coverage,
                object_id: &c.object_id,
            },
        ),
        None => write_exr(&exr, image.width, image.height, &image.pixels),
    }?;
    Ok((png, exr))
}
