//! How many of a box's three dimensions a view shows, from the true pose and the visible mask.
//!
//! Every mask pixel's viewing ray is intersected with the true box (slab test,
//! `anybox_geom::projection::ray_box_intersection`);
//! the face the ray enters through gets the pixel. A face is *observed* when it holds at least
//! [`MIN_FACE_FRACTION`] of the mask pixels and at least [`MIN_FACE_PX`] pixels; a face whose
//! normal is box axis k spans the two other axes, and a dimension is observed when an observed
//! face spans it. A box seen flat from one side shows two dimensions: nothing in the image
//! measures the third, so no method can be scored on it.

use anybox_geom::nalgebra::Point3;
use anybox_geom::projection::ray_box_intersection;
use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::Mask;
use serde::{Deserialize, Serialize};

/// A face must hold at least this fraction of the mask pixels to count as observed.
pub const MIN_FACE_FRACTION: f64 = 0.05;

/// A face must hold at least this many mask pixels to count as observed, px.
pub const MIN_FACE_PX: usize = 30;

/// What a view shows of a box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ObservedDims {
    /// Number of observed dimensions (0..=3).
    pub count: u8,
    /// Whether box axis x, y, z is observed.
    pub axes: [bool; 3],
    /// Fraction of the mask pixels whose ray enters through each face, in the order
    /// −x, +x, −y, +y, −z, +z (box frame).
    pub face_fractions: [f64; 6],
}

/// The face a camera ray through pixel centre `(u, v)` enters the box by: `(axis, positive)`.
fn entry_face(b: &OrientedBox, k: &Intrinsics, u: f64, v: f64) -> Option<(usize, bool)> {
    let dir = k.ray(u, v);
    let (t_enter, _, axis) = ray_box_intersection(&Point3::origin(), &dir, b)?;
    if t_enter <= 0.0 {
        // The camera is inside the box: no face is seen from outside.
        return None;
    }
    let local = b.to_local(&Point3::from(dir * t_enter));
    Some((axis, local[axis] > 0.0))
}

/// Ray-casts the true box `pose` at every pixel of `mask_visib` and says which faces, hence which
/// dimensions, the view shows (see the module docs for the rule).
pub fn observed_dims(
    pose: &OrientedBox,
    mask_visib: &Mask,
    intrinsics: &Intrinsics,
) -> ObservedDims {
    let mut counts = [0usize; 6];
    let mut total = 0usize;
    let w = mask_visib.width as usize;
    for (i, &on) in mask_visib.data.iter().enumerate() {
        if !on || w == 0 {
            continue;
        }
        total += 1;
        let (u, v) = ((i % w) as f64, (i / w) as f64);
        if let Some((a, pos)) = entry_face(pose, intrinsics, u, v) {
            counts[2 * a + usize::from(pos)] += 1;
        }
    }
    let mut face_fractions = [0.0; 6];
    let mut axes = [false; 3];
    for f in 0..6 {
        if total > 0 {
            face_fractions[f] = counts[f] as f64 / total as f64;
        }
        if counts[f] >= MIN_FACE_PX && face_fractions[f] >= MIN_FACE_FRACTION {
            let normal = f / 2;
            for (a, seen) in axes.iter_mut().enumerate() {
                if a != normal {
                    *seen = true;
                }
            }
        }
    }
    ObservedDims {
        count: axes.iter().filter(|a| **a).count() as u8,
        axes,
        face_fractions,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anybox_geom::nalgebra::{Rotation3, Vector3};

    /// The box's own silhouette: every pixel whose ray hits it (an unoccluded visible mask).
    fn silhouette(b: &OrientedBox, k: &Intrinsics, w: u32, h: u32) -> Mask {
        let mut m = Mask::empty(w, h);
        for v in 0..h {
            for u in 0..w {
                let hit = ray_box_intersection(&Point3::origin(), &k.ray(u as f64, v as f64), b);
                m.set(u, v, hit.is_some_and(|(t, _, _)| t > 0.0));
            }
        }
        m
    }

    fn cam() -> Intrinsics {
        Intrinsics::new(500.0, 500.0, 160.0, 120.0).unwrap()
    }

    #[test]
    fn straight_down_the_z_axis_shows_two_dims() {
        // Centred on the optical axis, looking down the box's z axis: only the −z face (normal
        // z, spanning x and y) faces the camera; the side faces point away from it.
        let b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(200.0, 120.0, 80.0),
        )
        .unwrap();
        let mask = silhouette(&b, &cam(), 320, 240);
        assert!(mask.count() > 1000);
        let o = observed_dims(&b, &mask, &cam());
        assert_eq!(o.count, 2);
        assert_eq!(o.axes, [true, true, false]);
        assert!((o.face_fractions[4] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn oblique_view_shows_three_dims() {
        let r = Rotation3::from_euler_angles(0.5, -0.6, 0.3);
        let b = OrientedBox::new(
            r,
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(200.0, 120.0, 80.0),
        )
        .unwrap();
        let mask = silhouette(&b, &cam(), 320, 240);
        let o = observed_dims(&b, &mask, &cam());
        assert_eq!(o.count, 3, "{:?}", o.face_fractions);
        // Exactly three faces (one per axis) are seen, and they share the whole mask.
        let seen = o.face_fractions.iter().filter(|f| **f > 0.0).count();
        assert_eq!(seen, 3);
        assert!((o.face_fractions.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        for a in 0..3 {
            assert!(o.face_fractions[2 * a] == 0.0 || o.face_fractions[2 * a + 1] == 0.0);
        }
    }

    #[test]
    fn a_sliver_below_five_percent_does_not_count() {
        // Tilt the box by 5° about x: its −z face fills the mask and one y face just turns
        // towards the camera, a sliver of ~1.5 % of the mask: still two dims. At 25° the y face
        // is well seen.
        let size = Vector3::new(200.0, 120.0, 80.0);
        let at = |deg: f64| {
            let r = Rotation3::from_axis_angle(&Vector3::x_axis(), deg.to_radians());
            OrientedBox::new(r, Vector3::new(0.0, 0.0, 1000.0), size).unwrap()
        };
        let b = at(5.0);
        let o = observed_dims(&b, &silhouette(&b, &cam(), 320, 240), &cam());
        let y_faces = o.face_fractions[2] + o.face_fractions[3];
        assert!(y_faces > 0.0 && y_faces < MIN_FACE_FRACTION, "{y_faces}");
        assert_eq!(o.count, 2);
        let b = at(25.0);
        let o = observed_dims(&b, &silhouette(&b, &cam(), 320, 240), &cam());
        assert_eq!(o.count, 3);
        assert!(o.axes.iter().all(|a| *a));
    }

    #[test]
    fn empty_mask_observes_nothing() {
        let b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(200.0, 120.0, 80.0),
        )
        .unwrap();
        let o = observed_dims(&b, &Mask::empty(320, 240), &cam());
        assert_eq!(o.count, 0);
        assert_eq!(o.face_fractions, [0.0; 6]);
    }
}
