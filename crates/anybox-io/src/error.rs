//! The one error type of the I/O crate.
//!
//! Every variant carries the file it is about and says what is wrong with it, so that a user
//! can fix the input without reading the source (SPEC §3, team rule "bad input → clear error").

use std::path::{Path, PathBuf};

use anybox_geom::GeomError;

/// Everything that can go wrong reading or writing anybox / BOP / SAM-6D files.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file (or directory) does not exist.
    #[error("{}: file not found", path.display())]
    NotFound {
        /// The missing path.
        path: PathBuf,
    },
    /// The file exists but could not be read (permissions, I/O error, not a regular file …).
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The unreadable path.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The file could not be written (or renamed into place, or its directory created).
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The path being written.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The bytes are not a decodable PNG/JPEG (random bytes, truncated file, bad checksum …).
    #[error("{}: corrupt or unsupported image: {reason}", path.display())]
    CorruptImage {
        /// The image path.
        path: PathBuf,
        /// What the decoder reported.
        reason: String,
    },
    /// The image decoded but has the wrong bit depth or colour type for its role.
    #[error("{}: expected {expected}, got {got}", path.display())]
    PixelFormat {
        /// The image path.
        path: PathBuf,
        /// What this role needs, e.g. "16-bit grayscale depth PNG".
        expected: String,
        /// What the file holds, e.g. "8-bit RGB PNG".
        got: String,
    },
    /// An image (or an RLE mask) has a different size from the one it must match.
    #[error(
        "{}: {what} has the wrong size: expected {}x{} px, got {}x{} px",
        path.display(), expected.0, expected.1, got.0, got.1
    )]
    WrongSize {
        /// The file whose content has the wrong size.
        path: PathBuf,
        /// What is being compared, e.g. "depth image (vs the RGB image)".
        what: String,
        /// Expected (width, height), px.
        expected: (u32, u32),
        /// Actual (width, height), px.
        got: (u32, u32),
    },
    /// Invalid JSON syntax, truncated JSON or a value of the wrong type.
    #[error("{}: invalid JSON at line {line}, column {column}: {message}", path.display())]
    Json {
        /// The JSON file.
        path: PathBuf,
        /// 1-based line of the problem (0 when unknown).
        line: usize,
        /// 1-based column of the problem (0 when unknown).
        column: usize,
        /// serde_json's description.
        message: String,
    },
    /// A required key is absent.
    #[error("{}: missing key `{key}`{}", path.display(), fmt_ctx(context))]
    MissingKey {
        /// The JSON file.
        path: PathBuf,
        /// The missing key.
        key: String,
        /// Where in the file it was expected (e.g. "image 3"), may be empty.
        context: String,
    },
    /// `depth_scale` is zero, negative or not finite.
    #[error(
        "{}: depth_scale must be finite and > 0 (depth_mm = value * depth_scale), got {value}",
        path.display()
    )]
    BadDepthScale {
        /// The camera file.
        path: PathBuf,
        /// The offending value.
        value: f64,
    },
    /// A camera matrix that is not a valid pinhole `K`.
    #[error("{}: {source}", path.display())]
    BadIntrinsics {
        /// The camera file.
        path: PathBuf,
        /// What the geometry crate rejected.
        source: GeomError,
    },
    /// A value that parsed but makes no sense (non-orthonormal rotation, negative size, bad id …).
    #[error("{}: invalid value{}: {reason}", path.display(), fmt_ctx(context))]
    BadValue {
        /// The file.
        path: PathBuf,
        /// Where in the file (e.g. "scene 1, image 4, gt 0"), may be empty.
        context: String,
        /// What is wrong.
        reason: String,
    },
    /// Two files (or two parts of one file) disagree, e.g. scene_gt and scene_gt_info lengths.
    #[error("{}: inconsistent data: {reason}", path.display())]
    Inconsistent {
        /// The file found to disagree.
        path: PathBuf,
        /// What disagrees with what.
        reason: String,
    },
    /// A COCO run-length encoding that cannot be decoded.
    #[error("{}: bad COCO RLE{}: {source}", path.display(), fmt_ctx(context))]
    Rle {
        /// The JSON file holding the RLE.
        path: PathBuf,
        /// Which entry (e.g. "detection 3"), may be empty.
        context: String,
        /// What is wrong with the encoding.
        source: crate::masks::RleError,
    },
    /// An image could not be encoded (e.g. zero-sized, or a buffer of the wrong length).
    #[error("{}: cannot encode image: {reason}", path.display())]
    Encode {
        /// The path being written.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

fn fmt_ctx(context: &str) -> String {
    if context.is_empty() {
        String::new()
    } else {
        format!(" ({context})")
    }
}

impl IoError {
    /// The file this error is about.
    pub fn path(&self) -> &Path {
        match self {
            IoError::NotFound { path }
            | IoError::Read { path, .. }
            | IoError::Write { path, .. }
            | IoError::CorruptImage { path, .. }
            | IoError::PixelFormat { path, .. }
            | IoError::WrongSize { path, .. }
            | IoError::Json { path, .. }
            | IoError::MissingKey { path, .. }
            | IoError::BadDepthScale { path, .. }
            | IoError::BadIntrinsics { path, .. }
            | IoError::BadValue { path, .. }
            | IoError::Inconsistent { path, .. }
            | IoError::Rle { path, .. }
            | IoError::Encode { path, .. } => path,
        }
    }

    /// Maps an `std::io::Error` from reading `path` to [`IoError::NotFound`] or [`IoError::Read`].
    pub(crate) fn from_read(path: &Path, source: std::io::Error) -> Self {
        if source.kind() == std::io::ErrorKind::NotFound {
            IoError::NotFound {
                path: path.to_path_buf(),
            }
        } else {
            IoError::Read {
                path: path.to_path_buf(),
                source,
            }
        }
    }

    /// Maps a serde_json error: a "missing field" becomes [`IoError::MissingKey`], everything
    /// else [`IoError::Json`] with serde_json's line and column.
    pub(crate) fn from_json(path: &Path, err: &serde_json::Error) -> Self {
        let message = err.to_string();
        if let Some(rest) = message.strip_prefix("missing field `") {
            if let Some(end) = rest.find('`') {
                return IoError::MissingKey {
                    path: path.to_path_buf(),
                    key: rest[..end].to_string(),
                    context: format!("line {}, column {}", err.line(), err.column()),
                };
            }
        }
        // serde_json appends " at line L column C" itself; keep the message short.
        let trimmed = match message.rfind(" at line ") {
            Some(i) => message[..i].to_string(),
            None => message,
        };
        let trimmed = if err.is_eof() {
            format!("{trimmed} (file truncated?)")
        } else {
            trimmed
        };
        IoError::Json {
            path: path.to_path_buf(),
            line: err.line(),
            column: err.column(),
            message: trimmed,
        }
    }
}
