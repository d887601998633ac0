//! Instance masks from files (SPEC §1 "masks given by the caller").

/// What is wrong with a COCO run-length encoding.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RleError {
    /// No runs at all.
    #[error("empty RLE (no runs)")]
    Empty,
}
