//! `synth → read → eval` end to end, and the real ycbv-boxes frames.

use std::path::{Path, PathBuf};

use anybox_eval::{evaluate_dataset, EvalError, EvalOptions, Report};
use anybox_io::bop::BopDataset;
use anybox_io::results::{write_results, EstimateRecord, ResultsFile};
use anybox_synth::{write_dataset, Layout, NoiseModel, SynthConfig};

fn synth(dir: &Path, layout: Layout, seed: u64) -> BopDataset {
    let cfg = SynthConfig {
        layout,
        scenes: 2,
        views: 1,
        distractors: Some(2),
        seed,
        noise: NoiseModel::None,
        width: 320,
        height: 240,
    };
    write_dataset(&cfg, dir).unwrap();
    BopDataset::open(dir, anybox_synth::SPLIT).unwrap()
}

/// The ground truth as estimates, each optionally moved along its own x axis by
/// `shift_frac(i) × size_x`, with score `score(i)`.
fn gt_as_results(
    ds: &BopDataset,
    path: &Path,
    shift_frac: impl Fn(usize) -> f64,
    score: impl Fn(usize) -> f64,
) {
    let mut estimates = Vec::new();
    let mut i = 0;
    for v in &ds.views {
        for g in &v.gts {
            let mut pose = g.pose;
            pose.center_mm += pose.axis(0) * (shift_frac(i) * pose.size_mm.x);
            estimates.push(EstimateRecord::from_pose(
                v.scene_id,
                v.im_id,
                &pose,
                score(i),
                0.0,
                Some(g.gt_index),
            ));
            i += 1;
        }
    }
    write_results(path, &ResultsFile { estimates }).unwrap();
}

fn assert_all_one(r: &Report) {
    let f = &r.overall;
    for (name, m) in [
        ("iou_ap", &f.iou_ap),
        ("pose_ap", &f.pose_ap),
        ("pace", &f.pace),
        ("adds_ap", &f.adds_ap),
    ] {
        for (k, v) in m {
            let v = v.unwrap();
            assert!((v - 1.0).abs() < 1e-12, "{name}[{k}] = {v}");
        }
    }
    assert!(f.size_err_mm.p90.unwrap() < 1e-6);
}

#[test]
fn synthetic_ground_truth_as_estimates_scores_one() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("ds");
    let ds = synth(&root, Layout::Pallet, 7);
    let res = tmp.path().join("res.json");
    gt_as_results(&ds, &res, |_| 0.0, |i| 1.0 - 1e-3 * i as f64);
    let opts = EvalOptions::default();
    let r = evaluate_dataset(&root, anybox_synth::SPLIT, &res, &opts).unwrap();
    let counted = ds
        .views
        .iter()
        .flat_map(|v| &v.gts)
        .filter(|g| g.visib_fract >= 0.1)
        .count();
    assert!(counted > 3, "too few boxes to test ({counted})");
    assert_eq!(r.overall.n_gt, counted);
    assert_eq!(r.overall.n_est, ds.n_gt());
    assert_eq!(r.overall.n_ignored, ds.n_gt() - counted);
    assert_all_one(&r);
    for (s, f) in &r.by_scene {
        assert_eq!(f.iou_ap["0.9"], Some(1.0), "scene {s}");
    }
    // With observed dims computed from the masks (every counted box keeps AP 1).
    let opts3 = EvalOptions {
        min_observed_dims: 2,
        ..EvalOptions::default()
    };
    let r = evaluate_dataset(&root, anybox_synth::SPLIT, &res, &opts3).unwrap();
    assert!(r.overall.n_gt > 0 && r.overall.n_gt <= counted);
    let hist = r.observed_dims_counts.unwrap();
    assert_eq!(hist.iter().sum::<usize>(), ds.n_gt());
    // Counted = visible enough and at least 2 observed dims.
    let mut expected = 0;
    for v in &ds.views {
        for g in &v.gts {
            let mask = v.load_mask_visib(g.gt_index).unwrap();
            let dims = anybox_eval::observed_dims(&g.pose, &mask, &v.intrinsics).count;
            if g.visib_fract >= 0.1 && dims >= 2 {
                expected += 1;
            }
        }
    }
    assert_eq!(r.overall.n_gt, expected);
    assert_all_one(&r);
}

#[test]
fn shifted_estimates_lower_iou_ap_as_geometry_predicts() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("ds");
    let ds = synth(&root, Layout::Table, 11);
    let res = tmp.path().join("res.json");
    // Shift δ = f·sx along the box's own x axis: exact IoU = (sx − δ)/(sx + δ) = (1−f)/(1+f):
    // 0.961, 0.818, 0.667, 0.538 for the four fractions. Scores fall with f, so every TP ranks
    // above every FP and AP@τ = recall = the fraction of counted boxes with IoU > τ.
    let fracs = [0.02, 0.1, 0.2, 0.3];
    let frac = |i: usize| fracs[i % 4];
    gt_as_results(&ds, &res, frac, |i| 1.0 - frac(i));
    let r = evaluate_dataset(&root, anybox_synth::SPLIT, &res, &EvalOptions::default()).unwrap();
    let mut ious = Vec::new();
    let mut i = 0;
    for v in &ds.views {
        for g in &v.gts {
            if g.visib_fract >= 0.1 {
                let f = frac(i);
                ious.push((1.0 - f) / (1.0 + f));
            }
            i += 1;
        }
    }
    assert!(ious.len() >= 8, "too few boxes ({})", ious.len());
    for tau in anybox_eval::IOU_THRESHOLDS {
        let expected = ious.iter().filter(|&&v| v > tau).count() as f64 / ious.len() as f64;
        let got = r.overall.iou_ap[&format!("{tau}")].unwrap();
        assert!(
            (got - expected).abs() < 1e-9,
            "AP@{tau}: {got} vs {expected}"
        );
    }
    // Rotation is untouched: rotation-only AP stays 1.
    assert!((r.overall.pose_ap["rot_5deg"].unwrap() - 1.0).abs() < 1e-12);
}

fn ycbv() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/ycbv-boxes");
    p.join("test").is_dir().then_some(p)
}

#[test]
fn real_ycbv_ground_truth_as_estimates_scores_one() {
    let Some(root) = ycbv() else {
        eprintln!("ycbv-boxes not found; skipped");
        return;
    };
    let ds = BopDataset::open(&root, "test").unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let res = tmp.path().join("res.json");
    gt_as_results(&ds, &res, |_| 0.0, |_| 1.0);
    let opts = EvalOptions {
        min_observed_dims: 1,
        ..EvalOptions::default()
    };
    let r = evaluate_dataset(&root, "test", &res, &opts).unwrap();
    assert_eq!(r.overall.n_est, 20);
    assert!(r.overall.n_gt > 0);
    assert_all_one(&r);
}

#[test]
fn unknown_image_and_bad_options_are_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("ds");
    let ds = synth(&root, Layout::Shelf, 3);
    let res = tmp.path().join("res.json");
    let pose = ds.views[0].gts[0].pose;
    let e = EstimateRecord::from_pose(99, 0, &pose, 1.0, 0.0, None);
    write_results(&res, &ResultsFile { estimates: vec![e] }).unwrap();
    let err =
        evaluate_dataset(&root, anybox_synth::SPLIT, &res, &EvalOptions::default()).unwrap_err();
    assert!(matches!(err, EvalError::UnknownImage { scene_id: 99, .. }));
    assert!(err.to_string().contains("res.json"));
    let bad = EvalOptions {
        min_visib: 2.0,
        ..EvalOptions::default()
    };
    assert!(matches!(
        evaluate_dataset(&root, anybox_synth::SPLIT, &res, &bad),
        Err(EvalError::BadOption(_))
    ));
    // A missing results file names the file.
    let missing = tmp.path().join("nope.json");
    let err = evaluate_dataset(
        &root,
        anybox_synth::SPLIT,
        &missing,
        &EvalOptions::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("nope.json"));
}
