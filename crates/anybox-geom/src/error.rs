//! Errors of the geometry crate.

/// What can go wrong when building geometric objects from user input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeomError {
    /// A focal length is zero, negative or not finite.
    #[error("invalid intrinsics: focal lengths must be finite and > 0 px (fx = {fx}, fy = {fy})")]
    BadFocalLength {
        /// Focal length along x, px.
        fx: f64,
        /// Focal length along y, px.
        fy: f64,
    },
    /// The principal point is not finite.
    #[error("invalid intrinsics: principal point must be finite (cx = {cx}, cy = {cy})")]
    BadPrincipalPoint {
        /// Principal point x, px.
        cx: f64,
        /// Principal point y, px.
        cy: f64,
    },
    /// A camera matrix that is not of the form [fx s cx; 0 fy cy; 0 0 1].
    #[error("invalid camera matrix: expected [fx 0 cx, 0 fy cy, 0 0 1], got {0:?}")]
    BadCameraMatrix([f64; 9]),
    /// A box size with a non-positive or non-finite extent.
    #[error("invalid box size: every extent must be finite and > 0 mm, got {0:?}")]
    BadSize([f64; 3]),
    /// A rotation matrix that is not orthonormal with determinant +1.
    #[error("invalid rotation matrix (not orthonormal with det +1): {0:?}")]
    BadRotation([f64; 9]),
    /// A 3D IoU method name that is not one of `exact`, `aabb`, `nocs-legacy`.
    #[error("unknown IoU method {0:?}: expected one of exact, aabb, nocs-legacy")]
    UnknownIouMethod(String),
}
