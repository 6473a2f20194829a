//! [`SceneError`]: what can go wrong building a scene. Every message is one
//! line naming the scene file and, for a bad value, the key
//! (`FILE: object[2].scale: must be > 0 (got -1)`).

use relight_assets::AssetError;
use std::path::PathBuf;

/// What can go wrong building a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A named asset (environment or mesh given outside a scene file).
    #[error(transparent)]
    Asset(#[from] AssetError),
    /// The scene file itself cannot be read.
    #[error("{}: cannot read scene file: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// TOML syntax, an unknown or removed key, a wrong type, a missing key.
    #[error("{}: {message}", path.display())]
    Parse { path: PathBuf, message: String },
    /// A value out of range; `context` is `FILE: KEY`.
    #[error("{context}: {message}")]
    Invalid { context: String, message: String },
    /// An image named by a key does not make a texture; `context` is `FILE: KEY`.
    #[error("{context}: {source}")]
    Texture {
        context: String,
        #[source]
        source: crate::textures::TextureFileError,
    },
    /// A file named by a key cannot be loaded; `context` is `FILE: KEY`.
    #[error("{context}: {source}")]
    File {
        context: String,
        #[source]
        source: AssetError,
    },
}
