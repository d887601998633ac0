//! Hand-worked AP cases for `evaluate` (expected values derived in the comments).

use anybox_eval::{evaluate, EstEntry, EvalOptions, GtEntry, IouMethod, Report};
use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::OrientedBox;

/// A 200 x 100 x 300 mm box at `x_mm` along the camera x axis, 1 m in front of the camera.
fn bx(x_mm: f64) -> OrientedBox {
    OrientedBox::new(
        Rotation3::identity(),
        Vector3::new(x_mm, 0.0, 1000.0),
        Vector3::new(200.0, 100.0, 300.0),
    )
    .unwrap()
}

fn gt(i: usize, pose: OrientedBox, visib: f64) -> GtEntry {
    GtEntry {
        scene_id: 1,
        im_id: 0,
        gt_index: i,
        pose,
        visib_fract: visib,
        observed_dims: None,
    }
}

fn est(score: f64, pose: OrientedBox) -> EstEntry {
    EstEntry {
        scene_id: 1,
        im_id: 0,
        score,
        pose,
        gt_index: None,
    }
}

fn shifted(b: OrientedBox, dx_mm: f64) -> OrientedBox {
    let mut c = b;
    c.center_mm += b.axis(0) * dx_mm;
    c
}

fn iou_ap(r: &Report, key: &str) -> f64 {
    r.overall.iou_ap[key].unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

/// Three GTs 1 m apart.
fn three_gts() -> Vec<GtEntry> {
    (0..3).map(|i| gt(i, bx(1000.0 * i as f64), 0.9)).collect()
}

#[test]
fn perfect_estimates_score_one_everywhere() {
    let gts = three_gts();
    let ests: Vec<EstEntry> = gts
        .iter()
        .enumerate()
        .map(|(i, g)| est(0.5 + 0.1 * i as f64, g.pose))
        .collect();
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    for m in [
        &r.overall.iou_ap,
        &r.overall.pose_ap,
        &r.overall.pace,
        &r.overall.adds_ap,
    ] {
        for (k, v) in m {
            assert!(close(v.unwrap(), 1.0), "{k}: {v:?}");
        }
    }
    assert_eq!(r.overall.n_gt, 3);
    assert_eq!(r.overall.n_est, 3);
    assert_eq!(r.overall.size_err_mm.n_pairs, 3);
    assert!(r.overall.size_err_mm.p90.unwrap() < 1e-9);
    // JSON: the exact top-level keys and string threshold keys.
    let j = serde_json::to_value(&r).unwrap();
    for k in [
        "iou_ap",
        "pose_ap",
        "pace",
        "adds_ap",
        "size_err_mm",
        "n_gt",
        "n_est",
    ] {
        assert!(j.get(k).is_some(), "missing top-level key {k}");
    }
    assert_eq!(j["iou_ap"]["0.5"], 1.0);
    assert_eq!(j["iou_ap"]["0.25"], 1.0);
    assert_eq!(j["pose_ap"]["5deg_1cm"], 1.0);
    assert_eq!(j["by_scene"]["1"]["n_gt"], 3);
    // Round trip.
    let back: Report = serde_json::from_value(j).unwrap();
    assert_eq!(back, r);
    let table = r.to_table();
    assert!(table.contains("3D IoU: exact"));
    assert!(table.contains("pose gating: off"));
}

#[test]
fn one_miss() {
    // Two of three GTs found, both TPs at precision 1: recall reaches 2/3 → AP = 2/3.
    let gts = three_gts();
    let ests = vec![est(0.9, gts[0].pose), est(0.8, gts[1].pose)];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    for t in ["0.25", "0.5", "0.9"] {
        assert!(close(iou_ap(&r, t), 2.0 / 3.0));
    }
    assert!(close(r.overall.pose_ap["5deg_1cm"].unwrap(), 2.0 / 3.0));
}

#[test]
fn duplicate_detection_is_a_false_positive() {
    // GT0 detected twice (0.9, 0.8), GT1 once (0.7): TP, FP, TP.
    // precision 1, 1/2, 2/3 at recall 1/2, 1/2, 1; interpolated: 1 for the first half of
    // recall, 2/3 for the second → AP = 1/2 + 1/3 = 5/6.
    let gts = vec![gt(0, bx(0.0), 0.9), gt(1, bx(1000.0), 0.9)];
    let ests = vec![
        est(0.9, gts[0].pose),
        est(0.8, shifted(gts[0].pose, 5.0)),
        est(0.7, gts[1].pose),
    ];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    assert!(close(iou_ap(&r, "0.5"), 5.0 / 6.0));
    // Pose matching is one-to-one as well.
    assert!(close(r.overall.pose_ap["10deg_2cm"].unwrap(), 5.0 / 6.0));
    assert!(close(r.overall.adds_ap["0.1d"].unwrap(), 5.0 / 6.0));
}

#[test]
fn false_positive_ranked_above_true_positives() {
    // FP (0.95, far from every GT), then two TPs, 2 GTs.
    // precision 0, 1/2, 2/3 at recall 0, 1/2, 1 → interpolated 2/3 on both halves → AP 2/3.
    let gts = vec![gt(0, bx(0.0), 0.9), gt(1, bx(1000.0), 0.9)];
    let ests = vec![
        est(0.95, bx(-3000.0)),
        est(0.8, gts[0].pose),
        est(0.7, gts[1].pose),
    ];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    assert!(close(iou_ap(&r, "0.25"), 2.0 / 3.0));
    assert_eq!(r.overall.n_est, 3);
}

#[test]
fn ties_keep_input_order() {
    // Equal scores. FP listed first: FP, TP → precision 1/2 at recall 1 → AP 1/2.
    // TP listed first: AP 1.
    let gts = vec![gt(0, bx(0.0), 0.9)];
    let fp = est(0.5, bx(-3000.0));
    let tp = est(0.5, gts[0].pose);
    let r = evaluate(&gts, &[fp, tp], &EvalOptions::default());
    assert!(close(iou_ap(&r, "0.5"), 0.5));
    let r = evaluate(&gts, &[tp, fp], &EvalOptions::default());
    assert!(close(iou_ap(&r, "0.5"), 1.0));
}

#[test]
fn iou_threshold_is_strict_and_matching_follows_iou_order() {
    // Shift δ along x on a 200 mm side: IoU = (200 − δ)/(200 + δ). δ = 40 → 160/240 = 2/3:
    // a TP at 0.5, an FP at 0.7 (and at 0.75 …).
    let gts = vec![gt(0, bx(0.0), 0.9)];
    let ests = vec![est(0.9, shifted(gts[0].pose, 40.0))];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    assert!(close(iou_ap(&r, "0.5"), 1.0));
    assert!(close(iou_ap(&r, "0.7"), 0.0));
    // Strictness: a 300 mm side shifted by 100 mm gives IoU 200/400 = 0.5 exactly (all
    // quantities are small integers with the axis-aligned IoU): no match at 0.5.
    let g = OrientedBox::new(
        Rotation3::identity(),
        Vector3::new(0.0, 0.0, 1000.0),
        Vector3::new(300.0, 100.0, 300.0),
    )
    .unwrap();
    let e = shifted(g, 100.0);
    assert_eq!(anybox_geom::iou::iou(&e, &g, IouMethod::Aabb), 0.5);
    let opts = EvalOptions {
        iou: IouMethod::Aabb,
        ..EvalOptions::default()
    };
    let r = evaluate(&[gt(0, g, 0.9)], &[est(0.9, e)], &opts);
    assert!(close(iou_ap(&r, "0.25"), 1.0));
    assert!(close(iou_ap(&r, "0.5"), 0.0));
    assert!(r.to_table().contains("3D IoU: aabb"));
}

#[test]
fn ignored_ground_truths() {
    // GT0 barely visible (0.05 < 0.1, ignored), GT1 visible.
    // e1 (0.9) = GT0 exactly; e2 (0.85) a poor estimate of GT0 (shift 110 mm: IoU 90/310 = 0.29);
    // e3 (0.8) = GT1.
    let gts = vec![gt(0, bx(0.0), 0.05), gt(1, bx(1000.0), 0.9)];
    let ests = vec![
        est(0.9, gts[0].pose),
        est(0.85, shifted(gts[0].pose, 110.0)),
        est(0.8, gts[1].pose),
    ];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    // e1 matches ignored GT0 → removed; e2 matches nothing (GT0 taken; IoU 0.29 < 0.5 anyway)
    // and belongs to GT0 → removed; e3 TP. #GT = 1 → AP 1 at every threshold.
    assert_eq!(r.overall.n_gt, 1);
    assert_eq!(r.overall.n_ignored, 1);
    assert!(close(iou_ap(&r, "0.25"), 1.0));
    assert!(close(iou_ap(&r, "0.5"), 1.0));
    assert!(close(r.overall.pose_ap["5deg_1cm"].unwrap(), 1.0));
    // Nothing ignored: TP, FP, TP on 2 GTs → 5/6 (see duplicate_detection_is_a_false_positive).
    let opts = EvalOptions {
        min_visib: 0.0,
        ..EvalOptions::default()
    };
    let r = evaluate(&gts, &ests, &opts);
    assert_eq!(r.overall.n_gt, 2);
    assert!(close(iou_ap(&r, "0.5"), 5.0 / 6.0));
    assert!(close(iou_ap(&r, "0.25"), 5.0 / 6.0));

    // Observed dims: GT1 shows only 2 dims; with min_observed_dims 3 it is ignored too, so
    // nothing is counted and AP is undefined (null).
    let mut gts2 = gts.clone();
    gts2[1].observed_dims = Some(2);
    gts2[0].visib_fract = 0.9;
    gts2[0].observed_dims = Some(3);
    let opts = EvalOptions {
        min_observed_dims: 3,
        ..EvalOptions::default()
    };
    let r = evaluate(&gts2, &ests, &opts);
    // GT0 counted (e1 TP), GT1 ignored (e3 removed), e2 FP (GT0 already matched, its own
    // highest-IoU GT is counted): TP, FP → AP 1 (recall 1 reached at precision 1).
    assert_eq!(r.overall.n_gt, 1);
    assert!(close(iou_ap(&r, "0.5"), 1.0));
    // Reverse the scores of e1 and e2: e2 (FP at 0.5) first, then e1: precision 1/2 → AP 1/2.
    let mut ests2 = ests.clone();
    ests2[1].score = 0.95;
    let r = evaluate(&gts2, &ests2, &opts);
    assert!(close(iou_ap(&r, "0.5"), 0.5));
}

#[test]
fn pose_ap_with_known_offsets_and_pace_averages() {
    // Box A: estimate rotated 3° about its x axis and shifted 6 mm (0.6 cm); score 0.9.
    // Box B: rotated 12° and shifted 31 mm (3.1 cm); score 0.8. GTs 2 m apart.
    let ga = bx(0.0);
    let gb = bx(2000.0);
    let perturb = |g: OrientedBox, deg: f64, mm: f64| {
        let mut e = g;
        e.rotation = g.rotation * Rotation3::from_axis_angle(&Vector3::x_axis(), deg.to_radians());
        e.center_mm += Vector3::new(0.0, mm, 0.0);
        e
    };
    let gts = vec![gt(0, ga, 0.9), gt(1, gb, 0.9)];
    let ests = vec![
        est(0.9, perturb(ga, 3.0, 6.0)),
        est(0.8, perturb(gb, 12.0, 31.0)),
    ];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    let p = &r.overall.pose_ap;
    // Both pass: AP 1. Only A (the higher score) passes: TP then FP → AP 1/2. None: 0.
    let expect = [
        ("5deg_1cm", 0.5),
        ("5deg_2cm", 0.5),
        ("5deg_5cm", 0.5),
        ("10deg_2cm", 0.5),
        ("10deg_5cm", 0.5),
        ("20deg_5cm", 1.0),
        ("rot_5deg", 0.5),
        ("rot_10deg", 0.5),
        ("rot_20deg", 1.0),
        ("trans_1cm", 0.5),
        ("trans_2cm", 0.5),
        ("trans_5cm", 1.0),
    ];
    for (k, v) in expect {
        assert!(close(p[k].unwrap(), v), "{k}: {:?} != {v}", p[k]);
    }
    // PACE rotation-only over k = 0..=20°: k < 3 → 0 (3 values), 3 ≤ k < 12 → 1/2 (9 values),
    // k ≥ 12 → 1 (9 values): (4.5 + 9)/21.
    assert!(close(r.overall.pace["20deg"].unwrap(), 13.5 / 21.0));
    // Translation-only over k/4 cm: A passes from k = 3 (0.75 ≥ 0.6), B from k = 13
    // (3.25 ≥ 3.1): 3 zeros, 10 halves, 8 ones → 13/21.
    assert!(close(r.overall.pace["5cm"].unwrap(), 13.0 / 21.0));
    // Diagonal (k°, k/4 cm): A from k = 3, B from k = 13 (needs both 12° and 3.1 cm) → 13/21.
    assert!(close(r.overall.pace["20deg_5cm"].unwrap(), 13.0 / 21.0));
}

#[test]
fn pose_error_respects_box_symmetry() {
    // A 180° turn about the box's z axis is the same box: pose AP 1 at the tightest threshold.
    let g = bx(0.0);
    let mut e = g;
    e.rotation = g.rotation * Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI);
    let r = evaluate(&[gt(0, g, 0.9)], &[est(0.9, e)], &EvalOptions::default());
    assert!(close(r.overall.pose_ap["5deg_1cm"].unwrap(), 1.0));
    assert!(close(r.overall.pace["20deg_5cm"].unwrap(), 1.0));
}

#[test]
fn adds_ap() {
    // 100 mm cubes, d = 173.2 mm (0.1d = 17.3, 0.15d = 26.0). A shift δ gives δ/6 ≤ ADD-S ≤ δ
    // (points on the trailing face are exactly δ from the moved box; no point is farther than
    // δ, since its shifted copy lies on the moved surface).
    // δ = 5 → TP at both; δ = 170 → ADD-S ≥ 28.3 → FP at both; third GT missed.
    let cube = |x: f64| {
        OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(x, 0.0, 1000.0),
            Vector3::new(100.0, 100.0, 100.0),
        )
        .unwrap()
    };
    let gts = vec![
        gt(0, cube(0.0), 0.9),
        gt(1, cube(1000.0), 0.9),
        gt(2, cube(2000.0), 0.9),
    ];
    let ests = vec![
        est(0.9, shifted(cube(0.0), 5.0)),
        est(0.8, shifted(cube(1000.0), 170.0)),
        est(0.7, shifted(cube(2000.0), 8.0)),
    ];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    // TP, FP, TP over 3 GTs: precision 1, 1/2, 2/3 at recall 1/3, 1/3, 2/3 →
    // 1/3·1 + 1/3·2/3 = 5/9.
    for k in ["0.1d", "0.15d"] {
        assert!(close(r.overall.adds_ap[k].unwrap(), 5.0 / 9.0), "{k}");
    }
}

#[test]
fn pose_gating_drops_undetected_ground_truths() {
    // GT0 found exactly; GT1's estimate has the right orientation but is 150 mm off along
    // the 100 mm axis (y): IoU 0 (no overlap) yet translation 15 cm; GT2 missed entirely.
    let gts = vec![
        gt(0, bx(0.0), 0.9),
        gt(1, bx(1000.0), 0.9),
        gt(2, bx(2000.0), 0.9),
    ];
    let mut far = gts[1].pose;
    far.center_mm.y += 150.0;
    let ests = vec![est(0.9, gts[0].pose), est(0.8, far)];
    let r = evaluate(&gts, &ests, &EvalOptions::default());
    // Without gating: rot_5deg (translation ≤ 100 cm): both TP over 3 GTs → 2/3.
    assert!(close(r.overall.pose_ap["rot_5deg"].unwrap(), 2.0 / 3.0));
    assert_eq!(r.overall.n_pose_gt, 3);
    let opts = EvalOptions {
        pose_gating: true,
        iou: IouMethod::Exact,
        ..EvalOptions::default()
    };
    let r = evaluate(&gts, &ests, &opts);
    // With gating only GT0 and e0 remain (IoU > 0.1) → AP 1 over 1 GT.
    assert_eq!(r.overall.n_pose_gt, 1);
    assert!(close(r.overall.pose_ap["rot_5deg"].unwrap(), 1.0));
    assert!(r.to_table().contains("pose gating: on"));
    // Detection AP does not depend on gating: 1 of 3 → 1/3.
    assert!(close(iou_ap(&r, "0.5"), 1.0 / 3.0));
}

#[test]
fn breakdowns_by_scene_and_visibility() {
    // Scene 1: GT visib 0.2 found; scene 2: GT visib 0.9 missed, plus an FP far away.
    let mut g1 = gt(0, bx(0.0), 0.2);
    g1.scene_id = 1;
    let mut g2 = gt(0, bx(0.0), 0.9);
    g2.scene_id = 2;
    let mut e1 = est(0.9, g1.pose);
    e1.scene_id = 1;
    let mut e2 = est(0.8, bx(-3000.0));
    e2.scene_id = 2;
    let r = evaluate(&[g1, g2], &[e1, e2], &EvalOptions::default());
    // Overall: TP then FP over 2 GTs → recall 1/2 at precision 1 → AP 1/2.
    assert!(close(iou_ap(&r, "0.5"), 0.5));
    assert!(close(r.by_scene[&1].iou_ap["0.5"].unwrap(), 1.0));
    assert!(close(r.by_scene[&2].iou_ap["0.5"].unwrap(), 0.0));
    // Band [0.1,0.3): only g1 counts; e2 overlaps nothing so stays an FP: TP, FP → AP 1.
    let low = &r.by_visibility["[0.1,0.3)"];
    assert_eq!(low.n_gt, 1);
    assert!(close(low.iou_ap["0.5"].unwrap(), 1.0));
    // Band [0.8,1.0]: only g2 counts; e1 belongs to g1 (ignored here) → removed; e2 FP → 0.
    let high = &r.by_visibility["[0.8,1.0]"];
    assert_eq!(high.n_gt, 1);
    assert!(close(high.iou_ap["0.5"].unwrap(), 0.0));
    // Empty band: undefined.
    assert!(r.by_visibility["[0.3,0.5)"].iou_ap["0.5"].is_none());
}

#[test]
fn deterministic_and_independent_of_ground_truth_order() {
    // 30 images x 5 boxes with irregular perturbations; rayon runs images in parallel.
    let mut state = 7u64;
    let mut rnd = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut gts = Vec::new();
    let mut ests = Vec::new();
    for im in 0..30u32 {
        for i in 0..5 {
            let mut g = gt(i, bx(300.0 * i as f64), rnd());
            g.im_id = im;
            g.scene_id = im % 3;
            let mut e = est(rnd(), shifted(g.pose, 60.0 * rnd()));
            e.pose.rotation *= Rotation3::from_axis_angle(&Vector3::y_axis(), 0.3 * rnd());
            e.im_id = im;
            e.scene_id = im % 3;
            gts.push(g);
            ests.push(e);
        }
    }
    let opts = EvalOptions::default();
    let a = evaluate(&gts, &ests, &opts);
    let b = evaluate(&gts, &ests, &opts);
    assert_eq!(a, b);
    let mut rev = gts.clone();
    rev.reverse();
    let c = evaluate(&rev, &ests, &opts);
    assert_eq!(a, c);
    // Sanity: the set is neither trivially perfect nor empty.
    let ap = a.overall.iou_ap["0.7"].unwrap();
    assert!(ap > 0.05 && ap < 0.95, "{ap}");
}
