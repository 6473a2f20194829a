//! [`WaveletError`]: everything that can go wrong in the wavelet technique.

use std::path::PathBuf;

/// Errors of relight-wavelet. Messages name the parameter or file and say how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum WaveletError {
    /// A parameter is out of range.
    #[error("invalid parameter {name} = {value}: {why}")]
    BadParam {
        /// Parameter name as the CLI spells it (`n`, `m`, `ntess`, `terms`, …).
        name: &'static str,
        /// The offending value.
        value: String,
        /// What is required.
        why: String,
    },
    /// Reading or writing a file failed.
    #[error("{}: {}", path.display(), relight_assets::io_reason(error))]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error, told in words in the message and kept out of the
        /// source chain (a chained report names it once).
        error: std::io::Error,
    },
    /// The file is not a relight wavelet bake of the expected kind.
    #[error(
        "{path}: not a relight {kind} bake file (bad magic); re-bake it with `relight bake {kind}`"
    )]
    Foreign {
        /// The file.
        path: PathBuf,
        /// `rotation` or `brdf`.
        kind: &'static str,
    },
    /// The file was written by another format version.
    #[error(
        "{path}: bake format version {found}, this relight reads version {expected}; delete it and re-bake"
    )]
    Version {
        /// The file.
        path: PathBuf,
        /// Version in the file.
        found: u32,
        /// Version this build reads.
        expected: u32,
    },
    /// The file is shorter/longer than its header says, or its checksum is wrong.
    #[error("{path}: corrupted or truncated bake file ({why}); delete it and re-bake")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What was found.
        why: String,
    },
    /// The file holds a bake with other parameters than requested.
    #[error(
        "{path}: baked with {found}, but {requested} was requested; re-bake or pass matching parameters"
    )]
    ParamMismatch {
        /// The file.
        path: PathBuf,
        /// Parameters in the file.
        found: String,
        /// Parameters asked for.
        requested: String,
    },
    /// The user cancelled (Ctrl-C); nothing was written.
    #[error("cancelled")]
    Cancelled,
}

impl WaveletError {
    /// What is wrong, without the file's name or the advice on fixing it:
    /// the reason in the warning that an unusable cache file was re-baked
    /// and replaced ([`crate::study::CacheUse`]).
    #[must_use]
    pub fn problem(&self) -> String {
        match self {
            Self::Io { error, .. } => relight_assets::io_reason(error),
            Self::Foreign { kind, .. } => format!("not a relight {kind} bake file (bad magic)"),
            Self::Version {
                found, expected, ..
            } => format!("bake format version {found}, this relight reads version {expected}"),
            Self::Corrupt { why, .. } => format!("corrupted or truncated: {why}"),
            Self::ParamMismatch {
                found, requested, ..
            } => format!("baked with {found}, not {requested}"),
            Self::BadParam { .. } | Self::Cancelled => self.to_string(),
        }
    }
}

impl From<relight_render::Cancelled> for WaveletError {
    fn from(_: relight_render::Cancelled) -> Self {
        Self::Cancelled
    }
}

pub(crate) fn bad(
    name: &'static str,
    value: impl ToString,
    why: impl Into<String>,
) -> WaveletError {
    WaveletError::BadParam {
        name,
        value: value.to_string(),
        why: why.into(),
    }
}

pub(crate) fn io(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> WaveletError + '_ {
    move |error| WaveletError::Io {
        path: path.to_path_buf(),
        error,
    }
}
