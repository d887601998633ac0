//! Property tests of the exact 3D IoU against independent computations.

use anybox_geom::iou::{intersection_volume_mm3, iou, IouMethod};
use anybox_geom::nalgebra::{Matrix3, Rotation3, Vector3};
use anybox_geom::OrientedBox;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
    // Scaled axis with norm up to π√3 (folded by nalgebra): covers all orientations.
    (-3.2f64..3.2, -3.2f64..3.2, -3.2f64..3.2)
        .prop_map(|(a, b, c)| Rotation3::new(Vector3::new(a, b, c)))
}

fn size() -> impl Strategy<Value = Vector3<f64>> {
    (20.0f64..400.0, 20.0f64..400.0, 20.0f64..400.0).prop_map(|(a, b, c)| Vector3::new(a, b, c))
}

fn a_box() -> impl Strategy<Value = OrientedBox> {
    (
        rotation(),
        size(),
        -300.0f64..300.0,
        -300.0f64..300.0,
        300.0f64..2000.0,
    )
        .prop_map(|(r, s, x, y, z)| OrientedBox::new(r, Vector3::new(x, y, z), s).unwrap())
}

/// Two boxes whose centres are within ~0.6 of A's largest extent, so that most pairs overlap.
fn overlapping_pair() -> impl Strategy<Value = (OrientedBox, OrientedBox)> {
    (
        a_box(),
        rotation(),
        size(),
        -0.6f64..0.6,
        -0.6f64..0.6,
        -0.6f64..0.6,
    )
        .prop_map(|(a, r, s, u, v, w)| {
            let m = a.size_mm.amax();
            let c = a.center_mm + Vector3::new(u, v, w) * m;
            (a, OrientedBox::new(r, c, s).unwrap())
        })
}

/// Intersection volume by jittered-grid Monte-Carlo inside `a` (one uniform point per cell of a
/// `g³` grid over `a`'s local box): independent of the clipping code, error ≪ 1 % for g = 40.
fn mc_intersection_mm3(a: &OrientedBox, b: &OrientedBox, g: usize, seed: u64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let s = a.size_mm;
    let mut hits = 0usize;
    for i in 0..g {
        for j in 0..g {
            for k in 0..g {
                let u = (i as f64 + rng.random::<f64>()) / g as f64 - 0.5;
                let v = (j as f64 + rng.random::<f64>()) / g as f64 - 0.5;
                let w = (k as f64 + rng.random::<f64>()) / g as f64 - 0.5;
                let p = a.to_camera(&Vector3::new(u * s.x, v * s.y, w * s.z));
                if b.contains(&p) {
                    hits += 1;
                }
            }
        }
    }
    a.volume_mm3() * hits as f64 / (g * g * g) as f64
}

/// The 24 proper signed permutation matrices, found by brute force over {-1, 0, 1}³ˣ³.
fn proper_signed_permutations() -> Vec<Matrix3<f64>> {
    let mut out = Vec::new();
    for code in 0..3usize.pow(9) {
        let mut m = Matrix3::zeros();
        let mut c = code;
        for e in 0..9 {
            m[(e / 3, e % 3)] = (c % 3) as f64 - 1.0;
            c /= 3;
        }
        if (m.transpose() * m - Matrix3::identity()).abs().max() < 1e-12 && m.determinant() > 0.0 {
            out.push(m);
        }
    }
    out
}

#[test]
fn there_are_24_proper_signed_permutations() {
    assert_eq!(proper_signed_permutations().len(), 24);
}

#[test]
fn most_generated_pairs_overlap() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let strat = overlapping_pair();
    let n = 300;
    let overlapping = (0..n)
        .filter(|_| {
            let (a, b) = strat.new_tree(&mut runner).unwrap().current();
            iou(&a, &b, IouMethod::Exact) > 0.0
        })
        .count();
    assert!(overlapping * 10 > n * 6, "{overlapping} of {n} overlap");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn exact_iou_matches_monte_carlo((a, b) in overlapping_pair()) {
        // Sample inside the smaller box: the MC error then scales with the smaller volume.
        let (small, big) = if a.volume_mm3() <= b.volume_mm3() { (&a, &b) } else { (&b, &a) };
        let inter = mc_intersection_mm3(small, big, 40, 7);
        let mc = inter / (a.volume_mm3() + b.volume_mm3() - inter);
        let exact = iou(&a, &b, IouMethod::Exact);
        prop_assert!((exact - mc).abs() < 0.01, "exact {} mc {}", exact, mc);
        // And the volume itself, relative to the smaller box.
        let v = intersection_volume_mm3(&a, &b);
        let vmin = a.volume_mm3().min(b.volume_mm3());
        prop_assert!((v - inter).abs() < 0.01 * vmin, "vol {} mc {}", v, inter);
    }

    #[test]
    fn iou_is_reflexive_and_symmetric((a, b) in overlapping_pair()) {
        for m in IouMethod::ALL {
            prop_assert!((iou(&a, &a, m) - 1.0).abs() < 1e-9, "{}", m);
            let (ab, ba) = (iou(&a, &b, m), iou(&b, &a, m));
            prop_assert!((ab - ba).abs() < 1e-9, "{} {} {}", m, ab, ba);
            prop_assert!((0.0..=1.0).contains(&ab));
        }
    }

    #[test]
    fn iou_ignores_axis_relabelling((a, b) in overlapping_pair()) {
        let base = iou(&a, &b, IouMethod::Exact);
        let base_aabb = iou(&a, &b, IouMethod::Aabb);
        for p in proper_signed_permutations() {
            // Columns of R·P are ± the original axes; the size follows the axes.
            let r = Rotation3::from_matrix_unchecked(a.rotation.matrix() * p);
            let s = p.abs().transpose() * a.size_mm;
            let relabelled = OrientedBox::new(r, a.center_mm, s).unwrap();
            prop_assert!((iou(&a, &relabelled, IouMethod::Exact) - 1.0).abs() < 1e-9);
            prop_assert!((iou(&relabelled, &b, IouMethod::Exact) - base).abs() < 1e-9);
            prop_assert!((iou(&relabelled, &b, IouMethod::Aabb) - base_aabb).abs() < 1e-9);
        }
    }

    #[test]
    fn separated_boxes_have_zero_iou(a in a_box(), r in rotation(), s in size(), dir in rotation()) {
        let gap = (a.diagonal_mm() + s.norm()) / 2.0 + 1.0;
        let c = a.center_mm + dir * Vector3::x() * gap;
        let b = OrientedBox::new(r, c, s).unwrap();
        prop_assert_eq!(intersection_volume_mm3(&a, &b), 0.0);
        prop_assert_eq!(iou(&a, &b, IouMethod::Exact), 0.0);
    }

    #[test]
    fn contained_box_gives_volume_ratio(a in a_box(), r in rotation(), f in (0.05f64..0.95, 0.05f64..0.95, 0.05f64..0.95), off in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)) {
        // B's bounding sphere (radius ρ) fits inside A's inscribed sphere, shifted by at most the slack.
        let rin = a.size_mm.min() / 2.0;
        let s = Vector3::new(f.0, f.1, f.2).normalize() * rin * 1.2;
        let rho = s.norm() / 2.0;
        prop_assume!(rho < rin);
        let shift = Vector3::new(off.0, off.1, off.2) / 3f64.sqrt() * (rin - rho);
        let b = OrientedBox::new(r, a.center_mm + shift, s).unwrap();
        let want = b.volume_mm3() / a.volume_mm3();
        prop_assert!((iou(&a, &b, IouMethod::Exact) - want).abs() < 1e-9);
        prop_assert!((intersection_volume_mm3(&b, &a) - b.volume_mm3()).abs() < 1e-9 * a.volume_mm3());
    }

    #[test]
    fn flush_shift_along_own_axis_has_closed_form(a in a_box(), axis in 0usize..3, f in -1.2f64..1.2) {
        // Same orientation and size, shifted by d along one box axis: four faces stay coplanar.
        let d = f * a.size_mm[axis];
        let b = OrientedBox::new(a.rotation, a.center_mm + a.axis(axis) * d, a.size_mm).unwrap();
        let s = a.size_mm[axis];
        let want = ((s - d.abs()) / (s + d.abs())).max(0.0);
        prop_assert!((iou(&a, &b, IouMethod::Exact) - want).abs() < 1e-9, "{} vs {}", iou(&a, &b, IouMethod::Exact), want);
    }

    #[test]
    fn nearly_coplanar_boxes_are_stable(a in a_box(), axis in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), log_angle in -14.0f64..-5.0, log_shift in -12.0f64..-4.0) {
        // Tiny rotations and shifts (down to rounding level) must not break the coplanar-face
        // handling: IoU stays within first-order of 1.
        let ax = Vector3::new(axis.0, axis.1, axis.2);
        prop_assume!(ax.norm() > 0.1);
        let angle = 10f64.powf(log_angle);
        let shift = 10f64.powf(log_shift) * a.size_mm.amax();
        let r = Rotation3::new(ax.normalize() * angle) * a.rotation;
        let b = OrientedBox::new(r, a.center_mm + ax.normalize() * shift, a.size_mm).unwrap();
        let v = iou(&a, &b, IouMethod::Exact);
        let bound = 4.0 * (angle * 3.0 + shift / a.size_mm.min()) + 1e-9;
        prop_assert!(v <= 1.0 && 1.0 - v < bound, "iou {} angle {} shift {}", v, angle, shift);
    }

    #[test]
    fn exact_iou_is_invariant_to_rigid_motion_and_scale((a, b) in overlapping_pair(), r in rotation(), k in 0.01f64..100.0) {
        let base = iou(&a, &b, IouMethod::Exact);
        let far = Vector3::new(2.0e4, -3.0e4, 5.0e4);
        let moved = |x: &OrientedBox| {
            OrientedBox::new(r * x.rotation, r * x.center_mm + far, x.size_mm).unwrap()
        };
        let scaled = |x: &OrientedBox| {
            OrientedBox::new(x.rotation, x.center_mm * k, x.size_mm * k).unwrap()
        };
        prop_assert!((iou(&moved(&a), &moved(&b), IouMethod::Exact) - base).abs() < 1e-7);
        prop_assert!((iou(&scaled(&a), &scaled(&b), IouMethod::Exact) - base).abs() < 1e-9);
    }

    #[test]
    fn thin_boxes_match_monte_carlo(a in a_box(), r in rotation(), t in 0.05f64..2.0, off in (-0.3f64..0.3, -0.3f64..0.3)) {
        // A thin slab (down to 0.05 mm) cutting through a box: the volume inside is a slab
        // fraction, estimated by MC over the slab.
        let s = Vector3::new(600.0, 600.0, t);
        let c = a.center_mm + Vector3::new(off.0, off.1, 0.0) * a.size_mm.amax();
        let slab = OrientedBox::new(r, c, s).unwrap();
        let inter = mc_intersection_mm3(&slab, &a, 40, 11);
        let v = intersection_volume_mm3(&slab, &a);
        prop_assert!((v - inter).abs() <= 0.01 * slab.volume_mm3(), "{} vs {}", v, inter);
    }
}
