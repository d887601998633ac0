//! Property tests of ADD-S: invariances and bounds that follow from its definition.

use anybox_geom::adds::{adds_mm, sample_surface_mm};
use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::symmetry::{relabel, signed_permutations};
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

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn translation_costs_at_most_its_length(gt in a_box(), d in (-50.0f64..50.0, -50.0f64..50.0, -50.0f64..50.0)) {
        // Each ground-truth surface point p has p + δ on the estimate's surface.
        let delta = Vector3::new(d.0, d.1, d.2);
        let est = OrientedBox { center_mm: gt.center_mm + delta, ..gt };
        let e = adds_mm(&est, &gt, 300);
        prop_assert!(e >= 0.0 && e <= delta.norm() + 1e-9, "{} > {}", e, delta.norm());
    }

    #[test]
    fn rotation_about_centre_costs_at_most_the_largest_displacement(gt in a_box(), r in rotation()) {
        // p ↦ R_est R_gtᵀ (p - c) + c maps the ground truth's surface onto the estimate's.
        let est = OrientedBox { rotation: r, ..gt };
        let m = est.rotation * gt.rotation.inverse();
        let pts = sample_surface_mm(&gt, 300, anybox_geom::adds::ADDS_SEED);
        let bound = pts
            .iter()
            .map(|p| {
                let q = m * (p.coords - gt.center_mm) + gt.center_mm;
                (q - p.coords).norm()
            })
            .sum::<f64>()
            / pts.len() as f64;
        prop_assert!(adds_mm(&est, &gt, 300) <= bound + 1e-9);
    }

    #[test]
    fn descriptions_do_not_matter(gt in a_box(), est in a_box(), p in 0usize..24) {
        let e = adds_mm(&est, &gt, 200);
        let perm = signed_permutations()[p];
        prop_assert!((adds_mm(&relabel(&est, &perm), &gt, 200) - e).abs() < 1e-9);
        prop_assert!(adds_mm(&relabel(&gt, &perm), &gt, 200) < 1e-9);
    }
}
