//! `camera.json` as SAM-6D's demo and BOP's per-image `scene_camera.json` entries write it
//! (SPEC §3, notes §3.1): `{"cam_K": [fx, 0, cx, 0, fy, cy, 0, 0, 1], "depth_scale": s}` with
//! optional `width` and `height` (px). In: a path; out: checked [`Intrinsics`] (px) and the
//! depth scale (uint16 value × depth_scale = mm).

use std::path::Path;

use anybox_geom::Intrinsics;
use serde::{Deserialize, Serialize};

use crate::fsutil::{read_json, write_json_pretty};
use crate::image::check_depth_scale;
use crate::IoError;

/// The raw content of a `camera.json` / one `scene_camera.json` entry.
///
/// Unknown keys (`cam_R_w2c`, `cam_t_w2c`, `view_level`, …) are ignored on reading.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraJson {
    /// Row-major 3x3 camera matrix, px.
    #[serde(rename = "cam_K")]
    pub cam_k: [f64; 9],
    /// Multiply a uint16 depth PNG value by this to get millimetres.
    pub depth_scale: f64,
    /// Image width, px (optional; checked against the images when present).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<u32>,
    /// Image height, px (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<u32>,
}

impl CameraJson {
    /// Builds the JSON record from checked intrinsics.
    pub fn new(intrinsics: &Intrinsics, depth_scale: f64, size: Option<(u32, u32)>) -> Self {
        Self {
            cam_k: intrinsics.to_row_major(),
            depth_scale,
            width: size.map(|s| s.0),
            height: size.map(|s| s.1),
        }
    }

    /// Validates the record: `K` must be a skew-free pinhole matrix with positive focal
    /// lengths, `depth_scale` finite and positive. `path` is only used in errors.
    pub fn validate(&self, path: &Path) -> Result<(Intrinsics, f64), IoError> {
        let k =
            Intrinsics::from_row_major(self.cam_k).map_err(|source| IoError::BadIntrinsics {
                path: path.to_path_buf(),
                source,
            })?;
        check_depth_scale(path, self.depth_scale)?;
        if self.width == Some(0) || self.height == Some(0) {
            return Err(IoError::BadValue {
                path: path.to_path_buf(),
                context: String::new(),
                reason: format!(
                    "image size must be positive, got width {:?}, height {:?}",
                    self.width, self.height
                ),
            });
        }
        Ok((k, self.depth_scale))
    }

    /// `(width, height)` when both are given.
    pub fn size(&self) -> Option<(u32, u32)> {
        Some((self.width?, self.height?))
    }
}

/// A validated camera file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraInfo {
    /// Pinhole intrinsics, px.
    pub intrinsics: Intrinsics,
    /// uint16 depth value × depth_scale = mm.
    pub depth_scale: f64,
    /// `(width, height)`, px, when the file gives both.
    pub size: Option<(u32, u32)>,
}

/// Reads and validates a `camera.json`; returns the intrinsics (px) and `depth_scale`.
pub fn read_camera_json(path: &Path) -> Result<(Intrinsics, f64), IoError> {
    read_camera_info(path).map(|c| (c.intrinsics, c.depth_scale))
}

/// Like [`read_camera_json`], also returning the optional image size.
pub fn read_camera_info(path: &Path) -> Result<CameraInfo, IoError> {
    let cam: CameraJson = read_json(path)?;
    let (intrinsics, depth_scale) = cam.validate(path)?;
    Ok(CameraInfo {
        intrinsics,
        depth_scale,
        size: cam.size(),
    })
}

/// Writes a SAM-6D style `camera.json` atomically.
pub fn write_camera_json(
    path: &Path,
    intrinsics: &Intrinsics,
    depth_scale: f64,
    size: Option<(u32, u32)>,
) -> Result<(), IoError> {
    check_depth_scale(path, depth_scale)?;
    write_json_pretty(path, &CameraJson::new(intrinsics, depth_scale, size))
}
