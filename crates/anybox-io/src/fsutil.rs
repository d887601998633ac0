//! File helpers shared by the readers and writers: atomic writes and JSON parsing with
//! path-carrying errors.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

use crate::IoError;

/// `<path>.tmp`, in the same directory as `path` so that the final rename is atomic.
fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `bytes` to `path` atomically: the data goes to `<path>.tmp` in the same directory,
/// which is then renamed over `path`. On any error the temporary file is removed and `path` is
/// left as it was. The parent directory is created when missing.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let werr = |source: std::io::Error| IoError::Write {
        path: path.to_path_buf(),
        source,
    };
    if let Some(parent) = path.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent).map_err(werr)?;
        }
    }
    let tmp = tmp_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.flush()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(werr(e));
    }
    Ok(())
}

/// Reads a whole file, mapping "not found" to [`IoError::NotFound`].
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|e| IoError::from_read(path, e))
}

/// Reads and parses a JSON file into `T`.
pub(crate) fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T, IoError> {
    let bytes = read_bytes(path)?;
    serde_json::from_slice(&bytes).map_err(|e| IoError::from_json(path, &e))
}

/// Serialises `value` as pretty JSON and writes it atomically.
pub(crate) fn write_json_pretty<T: serde::Serialize>(
    path: &Path,
    value: &T,
) -> Result<(), IoError> {
    let mut text = serde_json::to_string_pretty(value).map_err(|e| IoError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    text.push('\n');
    write_atomic(path, text.as_bytes())
}

/// Serialises a value compactly (one line) for the hand-assembled BOP JSON files.
pub(crate) fn to_compact<T: serde::Serialize>(path: &Path, value: &T) -> Result<String, IoError> {
    serde_json::to_string(value).map_err(|e| IoError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })
}
