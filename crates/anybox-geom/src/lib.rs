//! Box geometry for anybox.
//!
//! Conventions (SPEC §2), used by every anybox crate:
//! - Camera frame: OpenCV, x right, y down, z forward. Pixel `(u, v)` of a camera point
//!   `(x, y, z)` is `(fx·x/z + cx, fy·y/z + cy)`; pixel centres sit at integer coordinates.
//! - Units: **millimetres** for every length (`*_mm` in names), radians for angles unless a
//!   name says `_deg`.
//! - A box ([`OrientedBox`]) is `R` (box frame → camera; the columns of `R` are the box axes in
//!   camera coordinates), `t` (box centre in camera coordinates, mm) and `size` (full extents
//!   along the box's own x, y, z, mm).
//!
//! Modules:
//! - [`camera`], [`cuboid`]: pinhole intrinsics and the 9-DoF box.
//! - [`projection`]: projected corners, the cuboid silhouette (convex hull), convex-polygon
//!   rasterisation, ray/box intersection (SPEC §1 scale estimation, evaluator ray casting).
//! - [`iou`]: 3D IoU — exact oriented (default), `aabb` (NOCS `axis=1` / "CATRE") and
//!   `nocs-legacy` (NOCS's published `axis=0` code) (SPEC §4).
//! - [`symmetry`]: the 24 axis relabellings, box symmetry groups, the canonical choice of axes,
//!   symmetry-aware rotation error and matched size error (SPEC §2, §4).
//! - [`adds`]: area-uniform surface sampling and ADD-S (SPEC §4).

pub mod adds;
pub mod camera;
pub mod cuboid;
pub mod error;
pub mod iou;
pub mod projection;
pub mod symmetry;

pub use camera::Intrinsics;
pub use cuboid::OrientedBox;
pub use error::GeomError;

/// Re-exported so that users need no direct `nalgebra` dependency for the basic types.
pub use nalgebra;
