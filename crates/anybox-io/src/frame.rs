//! One RGB-D frame: optional RGB, depth in millimetres, and the camera intrinsics
//! (pipeline stage 1 of SPEC §1). In: SAM-6D-style paths (`rgb.png`, `depth.png`,
//! `camera.json`); out: a [`Frame`] whose images are checked to have the same size.

use std::path::Path;

use anybox_geom::Intrinsics;

use crate::camera::read_camera_info;
use crate::image::{check_size, read_depth_png, read_rgb, DepthMap, RgbImage};
use crate::IoError;

/// An RGB-D frame.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Colour image, same size as `depth` (absent for depth-only input).
    pub rgb: Option<RgbImage>,
    /// Depth along the optical axis, mm (0 = invalid).
    pub depth: DepthMap,
    /// Pinhole intrinsics, px.
    pub intrinsics: Intrinsics,
}

impl Frame {
    /// `(width, height)` of the frame, px.
    pub fn size(&self) -> (u32, u32) {
        (self.depth.width, self.depth.height)
    }
}

/// Reads a frame: the camera file gives `K` and `depth_scale`; the depth PNG is uint16
/// (value × depth_scale = mm); RGB (PNG/JPEG) is optional. The RGB and depth sizes must agree,
/// and must match `width`/`height` when the camera file gives them.
pub fn read_frame(rgb: Option<&Path>, depth: &Path, camera: &Path) -> Result<Frame, IoError> {
    let crate::camera::CameraInfo {
        intrinsics,
        depth_scale,
        size: cam_size,
    } = read_camera_info(camera)?;
    let depth_map = read_depth_png(depth, depth_scale)?;
    let dsize = (depth_map.width, depth_map.height);
    let rgb_img = match rgb {
        Some(p) => {
            let img = read_rgb(p)?;
            let what = format!("depth image (vs the RGB image {})", p.display());
            check_size(depth, &what, img.dimensions(), dsize)?;
            Some(img)
        }
        None => None,
    };
    if let Some(size) = cam_size {
        let what = format!("depth image (vs width/height in {})", camera.display());
        check_size(depth, &what, size, dsize)?;
    }
    Ok(Frame {
        rgb: rgb_img,
        depth: depth_map,
        intrinsics,
    })
}
