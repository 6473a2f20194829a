//! Where images leave the CLI: a tone-mapped PNG and a linear EXR side by
//! side, the EXR with `coverage` and `object_id` channels when the image is a
//! render (`relight_assets::render_exr`).

use anyhow::{Result, bail, ensure};
use relight_assets::{MaskChannels, ToneMap, io_reason, write_exr, write_png, write_render_exr};
use relight_render::{Coverage, Image};
use std::path::{Path, PathBuf};

/// Prints each warning on stderr, `relight: warning: …`, once per process:
/// a file loaded twice (`compare a.exr a.exr`, a scene per verify row) does
/// not repeat its warning.
pub fn warn_all(warnings: &[String]) {
    static SHOWN: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let mut shown = SHOWN
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    for w in warnings {
        if !shown.contains(w) {
            eprintln!("relight: warning: {w}");
            shown.push(w.clone());
        }
    }
}

/// The PNG and EXR paths for `--out PATH` (which ends in `.png` or `.exr`).
///
/// # Errors
/// Another extension, or a folder that does not exist (checked before any
/// work starts).
pub fn output_paths(out: &Path) -> Result<(PathBuf, PathBuf)> {
    output_paths_for(out, "--out")
}

/// [`output_paths`] for an output given by `flag` (named in the errors).
///
/// # Errors
/// As [`output_paths`].
pub fn output_paths_for(out: &Path, flag: &str) -> Result<(PathBuf, PathBuf)> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let paths = match ext.as_str() {
        "png" => (out.to_path_buf(), out.with_extension("exr")),
        "exr" => (out.with_extension("png"), out.to_path_buf()),
        _ => bail!(
            "{flag} {}: the output must end in .png or .exr",
            out.display()
        ),
    };
    check_output(out, flag, &[])?;
    Ok(paths)
}

/// Checks, before any work starts, that `path` can be written later: its
/// extension is one of `extensions` (lowercase, without the dot; empty:
/// any), it is not a folder, and its folder exists.
///
/// # Errors
/// A one-line error naming `flag` and `path`.
pub fn check_output(path: &Path, flag: &str, extensions: &[&str]) -> Result<()> {
    if !extensions.is_empty() {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        ensure!(
            extensions.contains(&ext.as_str()),
            "{flag} {}: the output must end in .{}",
            path.display(),
            extensions.join(", .")
        );
    }
    ensure!(
        !path.is_dir(),
        "{flag} {}: is a folder, not a file",
        path.display()
    );
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        ensure!(
            dir.is_dir(),
            "{flag} {}: folder {} does not exist",
            path.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Checks a `--plot DIR` before any work starts: it is a folder, or can be
/// created (it is created now).
///
/// # Errors
/// A file of that name, or a folder that cannot be created.
pub fn check_plot_dir(dir: Option<&Path>) -> Result<()> {
    dir.map_or(Ok(()), |d| check_out_dir(d, "--plot"))
}

/// Makes sure the output folder `dir` given by `flag` exists (creating it),
/// before any work: a file in its place or an unwritable parent is a
/// one-line error naming the flag.
pub fn check_out_dir(dir: &Path, flag: &str) -> Result<()> {
    ensure!(
        !dir.exists() || dir.is_dir(),
        "{flag} {}: is a file, not a folder",
        dir.display()
    );
    std::fs::create_dir_all(dir).map_err(|e| {
        anyhow::anyhow!(
            "{flag} {}: cannot create the folder: {}",
            dir.display(),
            io_reason(&e)
        )
    })
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
