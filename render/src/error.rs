//! Typed errors of the renderer. Shot problems reuse rift-fx's error (file, key path, message).

use std::path::PathBuf;

/// Anything that can go wrong building a scene or writing an image.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A problem with the shot file.
    #[error(transparent)]
    Shot(#[from] rift_fx::FxError),
    /// A mesh file is missing or malformed.
    #[error("{}: {message}", file.display())]
    Mesh { file: PathBuf, message: String },
    /// An image could not be written.
    #[error("{}: cannot write: {message}", path.display())]
    Write { path: PathBuf, message: String },
    /// A reference or input image could not be read.
    #[error("{}: cannot read image: {message}", path.display())]
    Image { path: PathBuf, message: String },
    /// Settings that do not fit together (e.g. a crop window outside the image).
    #[error("{0}")]
    Settings(String),
}

/// A shot-key error as a [`RenderError`].
pub fn key_error(
    file: &std::path::Path,
    key: impl Into<String>,
    message: impl Into<String>,
) -> RenderError {
    RenderError::Shot(rift_fx::Invalid::new(key, message).in_file(file))
}
