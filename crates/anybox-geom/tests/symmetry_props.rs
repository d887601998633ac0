//! Property tests of the canonical axes and the symmetry-aware rotation error.

use anybox_geom::iou::{iou, IouMethod};
use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::symmetry::{
    canonicalize, geodesic_deg, match_axes, relabel, rotation_error_deg, signed_permutations,
    symmetry_group,
};
use anybox_geom::OrientedBox;
use proptest::prelude::*;

fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
    (-3.2f64..3.2, -3.2f64..3.2, -3.2f64..3.2)
        .prop_map(|(a, b, c)| Rotation3::new(Vector3::new(a, b, c)))
}

fn a_box() -> impl Strategy<Value = OrientedBox> {
    (
        rotation(),
        (20.0f64..400.0, 20.0f64..400.0, 20.0f64..400.0),
        (-300.0f64..300.0, -300.0f64..300.0, 300.0f64..2000.0),
    )
        .prop_map(|(r, s, c)| {
            OrientedBox::new(r, Vector3::new(c.0, c.1, c.2), Vector3::new(s.0, s.1, s.2)).unwrap()
        })
}

/// Sizes whose sorted ratios are at least 1.3, in a random order.
fn distinct_sizes() -> impl Strategy<Value = Vector3<f64>> {
    (20.0f64..100.0, 1.3f64..2.0, 1.3f64..2.0, 0usize..6).prop_map(|(a, f, g, order)| {
        let v = [a, a * f, a * f * g];
        const P: [[usize; 3]; 6] = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        let p = P[order];
        Vector3::new(v[p[0]], v[p[1]], v[p[2]])
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn canonicalize_is_same_box_idempotent_and_description_free(b in a_box()) {
        let c = canonicalize(&b);
        prop_assert!((iou(&b, &c, IouMethod::Exact) - 1.0).abs() < 1e-9);
        // Same corner set.
        for p in c.corners_mm() {
            prop_assert!(b.corners_mm().iter().any(|q| (p - q).norm() < 1e-9));
        }
        prop_assert_eq!(canonicalize(&c), c);
        prop_assert!(c.axis(2).z > 0.0 && c.axis(0).x > 0.0);
        prop_assert!((c.axis(2).cross(&c.axis(0)) - c.axis(1)).norm() < 1e-12);
        for p in signed_permutations() {
            prop_assert_eq!(canonicalize(&relabel(&b, &p)), c);
        }
    }

    #[test]
    fn rotation_error_ignores_descriptions(gt in a_box(), est in a_box()) {
        let e = rotation_error_deg(&est, &gt);
        prop_assert!((0.0..=180.0).contains(&e));
        for p in signed_permutations() {
            let e2 = rotation_error_deg(&relabel(&est, &p), &gt);
            prop_assert!((e - e2).abs() < 1e-6, "{} vs {}", e, e2);
            let e3 = rotation_error_deg(&est, &relabel(&gt, &p));
            prop_assert!((e - e3).abs() < 1e-6, "{} vs {}", e, e3);
        }
        // When the identity assignment is the best size match, it is admissible, so the error
        // cannot exceed the plain geodesic angle.
        let id_cost = (est.size_mm - gt.size_mm).abs().sum();
        let best = signed_permutations()
            .iter()
            .map(|p| (relabel(&est, p).size_mm - gt.size_mm).abs().sum())
            .fold(f64::INFINITY, f64::min);
        if id_cost <= best {
            prop_assert!(e <= geodesic_deg(&est.rotation, &gt.rotation) + 1e-9);
        }
    }

    #[test]
    fn small_perturbation_is_measured_exactly(r in rotation(), s in distinct_sizes(), axis in rotation(), deg in 0.0f64..80.0, p in 0usize..24) {
        let gt = OrientedBox::new(r, Vector3::new(0.0, 0.0, 1000.0), s).unwrap();
        let tilt = Rotation3::from_axis_angle(&(axis * Vector3::x_axis()), deg.to_radians());
        let est = relabel(&OrientedBox { rotation: tilt * gt.rotation, ..gt }, &signed_permutations()[p]);
        let e = rotation_error_deg(&est, &gt);
        prop_assert!((e - deg).abs() < 1e-6, "{} vs {}", e, deg);
        prop_assert!(match_axes(&est, &gt).size_error_mm.norm() < 1e-9);
    }

    #[test]
    fn rotation_error_is_min_over_symmetry_group_for_matching_sizes(gt in a_box(), r in rotation()) {
        // Same size vector: the error is the minimum geodesic over the ground truth's group, when
        // the sizes are clearly distinct or clearly equal (no tolerance ambiguity).
        let s = gt.size_mm;
        let rd = |a: f64, b: f64| (a - b).abs() / a.max(b);
        let pairs = [rd(s.x, s.y), rd(s.y, s.z), rd(s.x, s.z)];
        prop_assume!(pairs.iter().all(|d| *d > 0.2));
        let est = OrientedBox { rotation: r, ..gt };
        let want = symmetry_group(&s, 0.05)
            .iter()
            .map(|g| geodesic_deg(&(r * g), &gt.rotation))
            .fold(f64::INFINITY, f64::min);
        prop_assert!((rotation_error_deg(&est, &gt) - want).abs() < 1e-6);
        // D2's covering radius in SO(3) is 120° (quaternion (1,1,1,1)/2).
        prop_assert!(want <= 120.0 + 1e-6);
    }
}
