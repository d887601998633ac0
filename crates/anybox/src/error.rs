//! Errors of the estimator (every stage of SPEC §1 returns these; no stage panics on user input).

use anybox_geom::GeomError;

/// What can go wrong while estimating a box from one mask and one depth map.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EstimateError {
    /// The instance mask has no pixel set.
    #[error("the instance mask is empty (no pixel set)")]
    EmptyMask,
    /// Too few usable 3D points (mask ∩ valid depth, after outlier rejection).
    #[error("too few valid 3D points under the mask: {valid} usable, at least {needed} needed")]
    TooFewPoints {
        /// Points left after masking, invalid-depth removal and outlier rejection.
        valid: usize,
        /// The configured minimum (`ObservationConfig::min_points`).
        needed: usize,
    },
    /// The mask and the depth map have different dimensions.
    #[error(
        "mask is {mask_width}x{mask_height} px but the depth map is {depth_width}x{depth_height} px"
    )]
    SizeMismatch {
        /// Mask width, px.
        mask_width: u32,
        /// Mask height, px.
        mask_height: u32,
        /// Depth width, px.
        depth_width: u32,
        /// Depth height, px.
        depth_height: u32,
    },
    /// A buffer whose length does not match its declared width × height.
    #[error("{what}: buffer holds {len} values but width x height = {expected}")]
    BadBuffer {
        /// Which buffer ("mask" or "depth map").
        what: &'static str,
        /// Actual length.
        len: usize,
        /// width × height.
        expected: usize,
    },
    /// A requested template size with a non-finite or non-positive extent.
    #[error("invalid template size: every extent must be finite and > 0 mm, got {0:?}")]
    BadTemplateSize([f64; 3]),
    /// No pose hypothesis could be formed or scored (e.g. every hypothesis is behind the camera).
    #[error("no usable pose hypothesis: {0}")]
    NoHypothesis(&'static str),
    /// A geometric object could not be built.
    #[error(transparent)]
    Geom(#[from] GeomError),
}
