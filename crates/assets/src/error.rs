//! [`AssetError`] and [`LoadReport`].

use relight_geom::RepairReport;
use std::path::{Path, PathBuf};

/// Why a file could not be read or written. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum AssetError {
    #[error("{}: file not found", path.display())]
    Missing { path: PathBuf },
    /// `error` is told in words in the message ([`io_reason`]) and kept
    /// out of the source chain, so that a chained report names it once.
    #[error("{}: cannot read: {}", path.display(), io_reason(error))]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// As `Io`, for writes.
    #[error("{}: cannot write: {}", path.display(), io_reason(error))]
    Write {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}: truncated file: {detail}", path.display())]
    Truncated { path: PathBuf, detail: String },
    #[error("{}: corrupt file: {detail}", path.display())]
    Corrupt { path: PathBuf, detail: String },
    #[error("{}: unsupported: {what}", path.display())]
    Unsupported { path: PathBuf, what: String },
    #[error("{}: is a folder, not a file", path.display())]
    Folder { path: PathBuf },
    #[error("{}: unknown file type (extension `{ext}`); expected {expected}", path.display())]
    UnknownFormat {
        path: PathBuf,
        ext: String,
        expected: &'static str,
    },
    #[error("{}: bad dimensions: {detail}", path.display())]
    BadDimensions { path: PathBuf, detail: String },
    #[error("{}: {count} non-finite (NaN or infinite) value(s); fix or re-export the file", path.display())]
    NonFinite { path: PathBuf, count: usize },
    #[error("{}: mesh has no valid triangles ({detail})", path.display())]
    EmptyMesh { path: PathBuf, detail: String },
}

/// Why a file-system call failed, in words rather than the OS's
/// "(os error N)" text: the one wording of IO failures in relight's
/// messages (asset reads and writes, bake caches, output folders).
#[must_use]
pub fn io_reason(e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    match e.kind() {
        K::NotADirectory => "a part of the path is a file, not a folder".into(),
        K::NotFound => "a folder on the path does not exist".into(),
        K::PermissionDenied => "permission denied".into(),
        K::ReadOnlyFilesystem => "the file system is read-only".into(),
        K::StorageFull => "no space left on the device".into(),
        K::AlreadyExists => "a file of that name is in the way".into(),
        K::IsADirectory => "it is a folder, not a file".into(),
        _ => {
            let text = e.to_string();
            match text.find(" (os error") {
                Some(i) => text[..i].to_string(),
                None => text,
            }
        }
    }
}

impl AssetError {
    pub(crate) fn from_io(path: &Path, e: std::io::Error) -> Self {
        match e.kind() {
            std::io::ErrorKind::NotFound => Self::Missing {
                path: path.to_path_buf(),
            },
            std::io::ErrorKind::UnexpectedEof => Self::Truncated {
                path: path.to_path_buf(),
                detail: e.to_string(),
            },
            _ => Self::Io {
                path: path.to_path_buf(),
                error: e,
            },
        }
    }
    pub(crate) fn corrupt(path: &Path, detail: impl Into<String>) -> Self {
        Self::Corrupt {
            path: path.to_path_buf(),
            detail: detail.into(),
        }
    }
    pub(crate) fn truncated(path: &Path, detail: impl Into<String>) -> Self {
        Self::Truncated {
            path: path.to_path_buf(),
            detail: detail.into(),
        }
    }
    pub(crate) fn unsupported(path: &Path, what: impl Into<String>) -> Self {
        Self::Unsupported {
            path: path.to_path_buf(),
            what: what.into(),
        }
    }
    pub(crate) fn bad_dims(path: &Path, detail: impl Into<String>) -> Self {
        Self::BadDimensions {
            path: path.to_path_buf(),
            detail: detail.into(),
        }
    }
    /// The file the error is about.
    #[must_use]
    pub fn path(&self) -> &Path {
        match self {
            Self::Missing { path }
            | Self::Folder { path }
            | Self::Io { path, .. }
            | Self::Write { path, .. }
            | Self::Truncated { path, .. }
            | Self::Corrupt { path, .. }
            | Self::Unsupported { path, .. }
            | Self::UnknownFormat { path, .. }
            | Self::BadDimensions { path, .. }
            | Self::NonFinite { path, .. }
            | Self::EmptyMesh { path, .. } => path,
        }
    }
}

/// Soft problems met while loading, returned next to the data (the library
/// never prints). `warnings` holds one line per problem, ready to show.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadReport {
    /// Human-readable warnings, each naming the file.
    pub warnings: Vec<String>,
    /// Pixels with at least one negative channel that were clamped to 0.
    pub negative_pixels_clamped: usize,
    /// What mesh validation repaired (meshes only).
    pub repair: Option<RepairReport>,
}

impl LoadReport {
    pub(crate) fn merge(&mut self, other: LoadReport) {
        self.warnings.extend(other.warnings);
        self.negative_pixels_clamped += other.negative_pixels_clamped;
        if other.repair.is_some() {
            self.repair = other.repair;
        }
    }
}

/// The file extension of `path`, lower-cased ("" when there is none), which
/// names the format of every file relight reads.
/// The format named by `path`'s extension, `Ok(None)` for an unknown one;
/// a folder is [`AssetError::Folder`], whatever its name.
pub(crate) fn format_by_extension<F>(
    path: &Path,
    of: impl Fn(&str) -> Option<F>,
) -> Result<Option<F>, AssetError> {
    if path.is_dir() {
        return Err(AssetError::Folder {
            path: path.to_path_buf(),
        });
    }
    Ok(of(&lowercase_extension(path)))
}

pub(crate) fn lowercase_extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Runs a third-party decoder, turning a panic into [`AssetError::Corrupt`].
pub(crate) fn guard<T>(
    path: &Path,
    what: &str,
    f: impl FnOnce() -> Result<T, AssetError>,
) -> Result<T, AssetError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<&str>()
                .map(|s| (*s).to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(AssetError::corrupt(
                path,
                format!("{what} decoder failed: {msg}"),
            ))
        }
    }
}
