//! The 9-DoF box: rotation, centre and size.

use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::GeomError;

/// A posed box in the camera frame (SPEC §2).
///
/// - `rotation`: box frame → camera; its columns are the box's x, y, z axes in camera coordinates.
/// - `center_mm`: box centre in camera coordinates, mm.
/// - `size_mm`: full extents along the box's own x, y, z axes, mm.
///
/// The same physical box has 24 equivalent descriptions (axis permutations and sign flips that
/// keep a right-handed frame); see the `symmetry` module for the canonical choice.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrientedBox {
    /// Box frame → camera frame.
    pub rotation: Rotation3<f64>,
    /// Box centre in the camera frame, mm.
    pub center_mm: Vector3<f64>,
    /// Full extents along the box axes, mm.
    pub size_mm: Vector3<f64>,
}

/// Unit-cube corner signs in a fixed order: index bit 0 → x, bit 1 → y, bit 2 → z
/// (bit set = positive half-extent).
pub const CORNER_SIGNS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
];

/// The 12 edges of a box as pairs of [`CORNER_SIGNS`] indices.
pub const EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [2, 3],
    [4, 5],
    [6, 7],
    [0, 2],
    [1, 3],
    [4, 6],
    [5, 7],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

impl OrientedBox {
    /// Builds a box, checking that every extent is finite and positive.
    pub fn new(
        rotation: Rotation3<f64>,
        center_mm: Vector3<f64>,
        size_mm: Vector3<f64>,
    ) -> Result<Self, GeomError> {
        if size_mm.iter().any(|s| !s.is_finite() || *s <= 0.0) {
            return Err(GeomError::BadSize([size_mm.x, size_mm.y, size_mm.z]));
        }
        Ok(Self {
            rotation,
            center_mm,
            size_mm,
        })
    }

    /// From BOP-style arrays: `r` row-major 3x3 (box → camera), `t_mm`, `size_mm`.
    ///
    /// The rotation must be orthonormal with det +1 within 1e-3; it is then re-orthonormalised.
    pub fn from_arrays(r: [f64; 9], t_mm: [f64; 3], size_mm: [f64; 3]) -> Result<Self, GeomError> {
        let m = Matrix3::from_row_slice(&r);
        let orth_err = (m.transpose() * m - Matrix3::identity()).abs().max();
        if !orth_err.is_finite() || orth_err > 1e-3 || m.determinant() <= 0.0 {
            return Err(GeomError::BadRotation(r));
        }
        let rotation = Rotation3::from_matrix(&m);
        Self::new(rotation, Vector3::from(t_mm), Vector3::from(size_mm))
    }

    /// Rotation as a row-major array (BOP's `cam_R_m2c` layout).
    pub fn rotation_row_major(&self) -> [f64; 9] {
        let m = self.rotation.matrix();
        [
            m[(0, 0)],
            m[(0, 1)],
            m[(0, 2)],
            m[(1, 0)],
            m[(1, 1)],
            m[(1, 2)],
            m[(2, 0)],
            m[(2, 1)],
            m[(2, 2)],
        ]
    }

    /// Half extents, mm.
    #[inline]
    pub fn half_size_mm(&self) -> Vector3<f64> {
        self.size_mm * 0.5
    }

    /// Volume, mm³.
    #[inline]
    pub fn volume_mm3(&self) -> f64 {
        self.size_mm.x * self.size_mm.y * self.size_mm.z
    }

    /// Length of the space diagonal, mm (the box's diameter as BOP defines it).
    #[inline]
    pub fn diagonal_mm(&self) -> f64 {
        self.size_mm.norm()
    }

    /// Box axis `i` (0 = x, 1 = y, 2 = z) as a unit vector in the camera frame.
    #[inline]
    pub fn axis(&self, i: usize) -> Vector3<f64> {
        self.rotation.matrix().column(i).into_owned()
    }

    /// The 8 corners in the camera frame, mm, in [`CORNER_SIGNS`] order.
    pub fn corners_mm(&self) -> [Point3<f64>; 8] {
        let h = self.half_size_mm();
        CORNER_SIGNS.map(|s| {
            let local = Vector3::new(s[0] * h.x, s[1] * h.y, s[2] * h.z);
            Point3::from(self.rotation * local + self.center_mm)
        })
    }

    /// A camera-frame point expressed in the box frame (origin at the box centre), mm.
    #[inline]
    pub fn to_local(&self, p_mm: &Point3<f64>) -> Vector3<f64> {
        self.rotation.inverse() * (p_mm.coords - self.center_mm)
    }

    /// A box-frame point expressed in the camera frame, mm.
    #[inline]
    pub fn to_camera(&self, local_mm: &Vector3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * local_mm + self.center_mm)
    }

    /// True when the camera-frame point lies inside or on the box.
    pub fn contains(&self, p_mm: &Point3<f64>) -> bool {
        let l = self.to_local(p_mm);
        let h = self.half_size_mm();
        l.x.abs() <= h.x && l.y.abs() <= h.y && l.z.abs() <= h.z
    }

    /// Closest point on the box *surface* to a camera-frame point, in the camera frame, mm.
    ///
    /// Analytic: clamp to the box, and for points inside push to the nearest face.
    pub fn closest_surface_point(&self, p_mm: &Point3<f64>) -> Point3<f64> {
        let l = self.to_local(p_mm);
        let h = self.half_size_mm();
        let mut c = Vector3::new(
            l.x.clamp(-h.x, h.x),
            l.y.clamp(-h.y, h.y),
            l.z.clamp(-h.z, h.z),
        );
        let inside = l.x.abs() < h.x && l.y.abs() < h.y && l.z.abs() < h.z;
        if inside {
            // Push to the face with the smallest gap.
            let gaps = [h.x - l.x.abs(), h.y - l.y.abs(), h.z - l.z.abs()];
            let mut k = 0;
            for i in 1..3 {
                if gaps[i] < gaps[k] {
                    k = i;
                }
            }
            c[k] = if l[k] >= 0.0 { h[k] } else { -h[k] };
        }
        self.to_camera(&c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_box() -> OrientedBox {
        let r = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        OrientedBox::new(
            r,
            Vector3::new(10.0, -20.0, 800.0),
            Vector3::new(200.0, 100.0, 300.0),
        )
        .unwrap()
    }

    #[test]
    fn corners_are_at_half_extents() {
        let b = sample_box();
        for (c, s) in b.corners_mm().iter().zip(CORNER_SIGNS) {
            let l = b.to_local(c);
            for i in 0..3 {
                assert!((l[i] - s[i] * b.size_mm[i] / 2.0).abs() < 1e-9);
            }
        }
        for e in EDGES {
            let [a, c] = e;
            let d = (b.corners_mm()[a] - b.corners_mm()[c]).norm();
            // Each edge is one of the three extents.
            assert!(b.size_mm.iter().any(|s| (s - d).abs() < 1e-9));
        }
    }

    #[test]
    fn array_round_trip_and_validation() {
        let b = sample_box();
        let c = OrientedBox::from_arrays(
            b.rotation_row_major(),
            [b.center_mm.x, b.center_mm.y, b.center_mm.z],
            [200.0, 100.0, 300.0],
        )
        .unwrap();
        assert!((b.rotation.matrix() - c.rotation.matrix()).abs().max() < 1e-12);
        assert!(OrientedBox::from_arrays([1.0; 9], [0.0; 3], [1.0; 3]).is_err());
        let mirror = [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert!(OrientedBox::from_arrays(mirror, [0.0; 3], [1.0; 3]).is_err());
        assert!(OrientedBox::new(
            Rotation3::identity(),
            Vector3::zeros(),
            Vector3::new(1.0, 0.0, 1.0)
        )
        .is_err());
    }

    #[test]
    fn closest_surface_point_is_on_surface_and_nearest() {
        let b = sample_box();
        let inside = b.to_camera(&Vector3::new(90.0, 0.0, 0.0));
        let q = b.closest_surface_point(&inside);
        assert!((b.to_local(&q) - Vector3::new(100.0, 0.0, 0.0)).norm() < 1e-9);
        let outside = b.to_camera(&Vector3::new(130.0, 70.0, 0.0));
        let q = b.closest_surface_point(&outside);
        assert!((b.to_local(&q) - Vector3::new(100.0, 50.0, 0.0)).norm() < 1e-9);
    }
}
