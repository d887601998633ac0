//! Pinhole camera intrinsics: projection and back-projection (OpenCV convention).

use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

use crate::GeomError;

/// Pinhole intrinsics `K = [fx 0 cx; 0 fy cy; 0 0 1]`, all in pixels.
///
/// Skew is not modelled (BOP and SAM-6D files have none); [`Intrinsics::from_row_major`]
/// rejects a matrix with skew rather than silently dropping it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along x, px.
    pub fx: f64,
    /// Focal length along y, px.
    pub fy: f64,
    /// Principal point x, px.
    pub cx: f64,
    /// Principal point y, px.
    pub cy: f64,
}

impl Intrinsics {
    /// Checked constructor: focal lengths must be finite and positive, the principal point finite.
    pub fn new(fx: f64, fy: f64, cx: f64, cy: f64) -> Result<Self, GeomError> {
        if !(fx.is_finite() && fy.is_finite() && fx > 0.0 && fy > 0.0) {
            return Err(GeomError::BadFocalLength { fx, fy });
        }
        if !(cx.is_finite() && cy.is_finite()) {
            return Err(GeomError::BadPrincipalPoint { cx, cy });
        }
        Ok(Self { fx, fy, cx, cy })
    }

    /// From a row-major 3x3 `K` as BOP's `cam_K` stores it.
    pub fn from_row_major(k: [f64; 9]) -> Result<Self, GeomError> {
        let tol = 1e-9;
        let structure_ok = k[1].abs() <= tol
            && k[3].abs() <= tol
            && k[6].abs() <= tol
            && k[7].abs() <= tol
            && (k[8] - 1.0).abs() <= tol;
        if !structure_ok {
            return Err(GeomError::BadCameraMatrix(k));
        }
        Self::new(k[0], k[4], k[2], k[5])
    }

    /// Row-major 3x3 `K`, as BOP's `cam_K`.
    pub fn to_row_major(&self) -> [f64; 9] {
        [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0]
    }

    /// Projects a camera-frame point (mm) to pixel coordinates; `None` when `z <= 0`.
    #[inline]
    pub fn project(&self, p_mm: &Point3<f64>) -> Option<Point2<f64>> {
        if p_mm.z <= 0.0 {
            return None;
        }
        Some(Point2::new(
            self.fx * p_mm.x / p_mm.z + self.cx,
            self.fy * p_mm.y / p_mm.z + self.cy,
        ))
    }

    /// Back-projects pixel `(u, v)` at depth `z_mm` (along the optical axis) to a camera point, mm.
    #[inline]
    pub fn back_project(&self, u: f64, v: f64, z_mm: f64) -> Point3<f64> {
        Point3::new(
            (u - self.cx) * z_mm / self.fx,
            (v - self.cy) * z_mm / self.fy,
            z_mm,
        )
    }

    /// Unit-free viewing ray through pixel `(u, v)`, scaled so that its z component is 1.
    #[inline]
    pub fn ray(&self, u: f64, v: f64) -> nalgebra::Vector3<f64> {
        nalgebra::Vector3::new((u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_back_project_round_trip() {
        let k = Intrinsics::new(600.0, 610.0, 320.0, 240.0).unwrap();
        let p = Point3::new(-120.0, 45.5, 870.0);
        let uv = k.project(&p).unwrap();
        let q = k.back_project(uv.x, uv.y, p.z);
        assert!((p - q).norm() < 1e-9);
    }

    #[test]
    fn rejects_bad_focal_and_skew() {
        assert!(Intrinsics::new(0.0, 1.0, 0.0, 0.0).is_err());
        assert!(Intrinsics::new(f64::NAN, 1.0, 0.0, 0.0).is_err());
        assert!(Intrinsics::new(500.0, 500.0, f64::INFINITY, 0.0).is_err());
        let skewed = [500.0, 3.0, 320.0, 0.0, 500.0, 240.0, 0.0, 0.0, 1.0];
        assert!(Intrinsics::from_row_major(skewed).is_err());
    }

    #[test]
    fn behind_camera_does_not_project() {
        let k = Intrinsics::new(500.0, 500.0, 320.0, 240.0).unwrap();
        assert!(k.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
    }
}
