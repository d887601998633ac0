//! End-to-end tests of the `anybox` binary: the commands users run, on real and generated data,
//! and bad input that must give a clear error (exit code 1, a message naming the file), never a
//! panic (exit code 101).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn anybox(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_anybox"))
        .args(args)
        .output()
        .expect("the anybox binary runs")
}

fn ycbv() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/ycbv-boxes");
    if p.join("test").is_dir() {
        Some(p)
    } else {
        eprintln!("note: {} absent; skipping", p.display());
        None
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A failed run must be a handled error: exit code 1 (anyhow), not 101 (panic).
fn assert_clean_failure(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(1),
        "expected a handled error, got {:?}: {err}",
        o.status
    );
    assert!(!err.contains("panicked"), "panic: {err}");
    assert!(
        err.contains(needle),
        "error should mention {needle:?}: {err}"
    );
}

#[test]
fn single_frame_estimate_on_real_ycbv_frame_writes_results_and_overlay() {
    let Some(root) = ycbv() else { return };
    let scene = root.join("test/000000");
    let dir = tempfile::tempdir().unwrap();
    // camera.json in SAM-6D layout from the BOP scene_camera entry.
    let cam = dir.path().join("camera.json");
    std::fs::write(
        &cam,
        r#"{"cam_K": [1066.778, 0.0, 312.9869, 0.0, 1067.487, 241.3109, 0.0, 0.0, 1.0], "depth_scale": 0.1}"#,
    )
    .unwrap();
    let out = dir.path().join("result.json");
    let overlay = dir.path().join("overlay.png");
    let o = anybox(&[
        "estimate",
        "--rgb",
        scene.join("rgb/000000.png").to_str().unwrap(),
        "--depth",
        scene.join("depth/000000.png").to_str().unwrap(),
        "--camera",
        cam.to_str().unwrap(),
        "--masks",
        scene.join("mask_visib/000000_000000.png").to_str().unwrap(),
        scene.join("mask_visib/000000_000001.png").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--overlay",
        overlay.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let ests = v["estimates"].as_array().unwrap();
    assert_eq!(ests.len(), 2);
    // Gelatin box 88.8 x 72.8 x 29.7 mm and foam brick 77.4 x 51.7 x 50.9 mm: sorted sizes
    // within 15 mm per axis (a loose sanity bound; accuracy is measured by bench).
    let truth: [[f64; 3]; 2] = [[88.84, 72.76, 29.73], [77.42, 51.66, 50.93]];
    for (e, t) in ests.iter().zip(truth) {
        let mut s: Vec<f64> = e["size"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        s.sort_by(|a, b| b.total_cmp(a));
        let mut t = t.to_vec();
        t.sort_by(|a, b| b.total_cmp(a));
        for (a, b) in s.iter().zip(&t) {
            assert!((a - b).abs() < 15.0, "size {s:?} vs {t:?}");
        }
        assert_eq!(e["R"].as_array().unwrap().len(), 9);
        assert!(e["gt_index"].is_null());
    }
    let img = image::open(&overlay).unwrap();
    assert_eq!((img.width(), img.height()), (640, 480));
}

#[test]
fn dataset_estimate_then_eval_on_ycbv() {
    let Some(root) = ycbv() else { return };
    let dir = tempfile::tempdir().unwrap();
    let res = dir.path().join("results.json");
    let csv = dir.path().join("results.csv");
    let o = anybox(&[
        "estimate",
        "--dataset",
        root.to_str().unwrap(),
        "--masks",
        "gt",
        "--out",
        res.to_str().unwrap(),
        "--bop-csv",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&res).unwrap()).unwrap();
    assert_eq!(v["estimates"].as_array().unwrap().len(), 20);
    let csv_text = std::fs::read_to_string(&csv).unwrap();
    assert!(csv_text.starts_with("scene_id,im_id,obj_id,score,R,t,time"));
    assert_eq!(csv_text.lines().count(), 21);

    let report = dir.path().join("report.json");
    let o = anybox(&[
        "eval",
        "--dataset",
        root.to_str().unwrap(),
        "--results",
        res.to_str().unwrap(),
        "--json",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    for key in [
        "iou_ap",
        "pose_ap",
        "pace",
        "adds_ap",
        "size_err_mm",
        "n_gt",
        "n_est",
    ] {
        assert!(r.get(key).is_some(), "report lacks {key}");
    }
    assert_eq!(r["n_gt"], 20);
    // Every real box is found at IoU 0.5 (issue #3 target).
    assert!(
        r["iou_ap"]["0.5"].as_f64().unwrap() >= 0.99,
        "{}",
        r["iou_ap"]
    );
}

#[test]
fn bad_inputs_give_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("out.json");
    let out_s = out.to_str().unwrap();
    // Missing files.
    let o = anybox(&[
        "estimate",
        "--depth",
        "/nonexistent/depth.png",
        "--camera",
        "/nonexistent/cam.json",
        "--masks",
        "/nonexistent/m.png",
        "--out",
        out_s,
    ]);
    assert_clean_failure(&o, "nonexistent");
    // Inline JSON where a config file is expected.
    let o = anybox(&[
        "estimate",
        "--depth",
        "/nonexistent/depth.png",
        "--camera",
        "/nonexistent/cam.json",
        "--masks",
        "/nonexistent/m.png",
        "--out",
        out_s,
        "--config",
        r#"{"detect": {"blobs": false}}"#,
    ]);
    assert_clean_failure(&o, "takes the path of a JSON file");
    // Truncated camera JSON.
    let cam = d.join("camera.json");
    std::fs::write(&cam, r#"{"cam_K": [500, 0, 320, 0, 500"#).unwrap();
    let depth = d.join("depth.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_pixel(64, 48, image::Luma([1000u16]))
        .save(&depth)
        .unwrap();
    let mask = d.join("mask.png");
    image::GrayImage::from_fn(64, 48, |u, v| {
        image::Luma([if (10..40).contains(&u) && (10..30).contains(&v) {
            255
        } else {
            0
        }])
    })
    .save(&mask)
    .unwrap();
    let args = |cam: &Path, depth: &Path, mask: &Path| {
        anybox(&[
            "estimate",
            "--depth",
            depth.to_str().unwrap(),
            "--camera",
            cam.to_str().unwrap(),
            "--masks",
            mask.to_str().unwrap(),
            "--out",
            out_s,
        ])
    };
    assert_clean_failure(&args(&cam, &depth, &mask), "camera.json");
    // Non-positive focal length.
    std::fs::write(
        &cam,
        r#"{"cam_K": [0, 0, 32, 0, 500, 24, 0, 0, 1], "depth_scale": 1.0}"#,
    )
    .unwrap();
    assert_clean_failure(&args(&cam, &depth, &mask), "camera.json");
    std::fs::write(
        &cam,
        r#"{"cam_K": [50, 0, 32, 0, 50, 24, 0, 0, 1], "depth_scale": 1.0}"#,
    )
    .unwrap();
    // Corrupt depth PNG.
    let bad = d.join("corrupt.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\nnot really a png").unwrap();
    assert_clean_failure(&args(&cam, &bad, &mask), "corrupt.png");
    // 8-bit depth.
    assert_clean_failure(&args(&cam, &mask, &mask), "mask.png");
    // Mask of the wrong size.
    let small = d.join("small.png");
    image::GrayImage::from_pixel(10, 10, image::Luma([255]))
        .save(&small)
        .unwrap();
    assert_clean_failure(&args(&cam, &depth, &small), "small.png");
    // A flat wall: the estimate may fail or succeed, but never panics; nothing partial is left.
    let o = args(&cam, &depth, &mask);
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{}",
        stderr(&o)
    );
    // An empty mask and a three-pixel mask: a per-instance failure, reported, not a crash.
    let empty = d.join("empty.png");
    image::GrayImage::new(64, 48).save(&empty).unwrap();
    let three = d.join("three.png");
    let mut t = image::GrayImage::new(64, 48);
    for u in 20..23 {
        t.put_pixel(u, 20, image::Luma([255]));
    }
    t.save(&three).unwrap();
    for m in [&empty, &three] {
        let o = args(&cam, &depth, m);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains("no estimate"), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
        assert_eq!(v["estimates"].as_array().unwrap().len(), 0);
        assert_eq!(v["failures"].as_array().unwrap().len(), 1);
    }
    // Truncated results JSON for eval.
    let res = d.join("results.json");
    std::fs::write(&res, r#"{"estimates": [{"scene_id": 0, "#).unwrap();
    if let Some(root) = ycbv() {
        let o = anybox(&[
            "eval",
            "--dataset",
            root.to_str().unwrap(),
            "--results",
            res.to_str().unwrap(),
        ]);
        assert_clean_failure(&o, "results.json");
    }
    // No leftover temporary files.
    for e in std::fs::read_dir(d).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        assert!(!name.ends_with(".tmp"), "leftover {name}");
    }
}

#[test]
fn synth_then_eval_ground_truth_scores_one() {
    let dir = tempfile::tempdir().unwrap();
    let ds = dir.path().join("ds");
    let o = anybox(&[
        "synth",
        "--out",
        ds.to_str().unwrap(),
        "--layout",
        "table",
        "--scenes",
        "1",
        "--views",
        "1",
        "--seed",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Ground truth as estimates, through the public results format.
    let gt: serde_json::Value =
        serde_json::from_slice(&std::fs::read(ds.join("test/000000/scene_gt.json")).unwrap())
            .unwrap();
    let mut ests = Vec::new();
    for (im, list) in gt.as_object().unwrap() {
        for (i, g) in list.as_array().unwrap().iter().enumerate() {
            let obj = g["obj_id"].as_u64().unwrap();
            let info: serde_json::Value =
                serde_json::from_slice(&std::fs::read(ds.join("models_info.json")).unwrap())
                    .unwrap();
            let m = &info[obj.to_string()];
            ests.push(serde_json::json!({
                "scene_id": 0, "im_id": im.parse::<u32>().unwrap(), "score": 1.0,
                "R": g["cam_R_m2c"], "t": g["cam_t_m2c"],
                "size": [m["size_x"], m["size_y"], m["size_z"]], "time": 0.0, "gt_index": i
            }));
        }
    }
    let res = dir.path().join("gt_results.json");
    std::fs::write(
        &res,
        serde_json::to_vec(&serde_json::json!({"estimates": ests})).unwrap(),
    )
    .unwrap();
    let report = dir.path().join("r.json");
    let o = anybox(&[
        "eval",
        "--dataset",
        ds.to_str().unwrap(),
        "--results",
        res.to_str().unwrap(),
        "--json",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    for (k, v) in r["iou_ap"].as_object().unwrap() {
        assert!((v.as_f64().unwrap() - 1.0).abs() < 1e-9, "iou_ap {k} = {v}");
    }
}

#[test]
fn detect_masks_in_dataset_mode_and_clear_error_without_depth() {
    let Some(root) = ycbv() else { return };
    let dir = tempfile::tempdir().unwrap();
    let res = dir.path().join("det.json");
    let o = anybox(&[
        "estimate",
        "--dataset",
        root.to_str().unwrap(),
        "--masks",
        "detect",
        "--out",
        res.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&res).unwrap()).unwrap();
    let ests = v["estimates"].as_array().unwrap();
    assert!(!ests.is_empty(), "the detector finds boxes on ycbv");
    assert!(ests.iter().all(|e| e["gt_index"].is_null()));
    // A frame with no valid depth: the detector reports it, the run does not crash.
    let cam = dir.path().join("camera.json");
    std::fs::write(
        &cam,
        r#"{"cam_K": [500, 0, 32, 0, 500, 24, 0, 0, 1], "depth_scale": 1.0}"#,
    )
    .unwrap();
    let depth = dir.path().join("zero.png");
    image::ImageBuffer::<image::Luma<u16>, _>::new(64, 48)
        .save(&depth)
        .unwrap();
    let out = dir.path().join("o.json");
    let o = anybox(&[
        "estimate",
        "--depth",
        depth.to_str().unwrap(),
        "--camera",
        cam.to_str().unwrap(),
        "--masks",
        "detect",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_clean_failure(&o, "no valid pixel");
}

/// `bench --detect-only --detect-seeds` runs only the generated detection rows, once per seed,
/// and ends with the per-seed summary, in the printed output and in the markdown file.
#[test]
fn bench_over_several_seeds_ends_with_the_seed_summary() {
    let dir = tempfile::tempdir().unwrap();
    let md = dir.path().join("bench.md");
    let md_arg = md.display().to_string();
    let missing = dir.path().join("no-ycbv").display().to_string();
    let o = anybox(&[
        "bench",
        "--ycbv",
        &missing,
        "--detect-only",
        "--detect-frames",
        "1",
        "--detect-seeds",
        "3,4",
        "--markdown",
        &md_arg,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "Detection, generated (realistic noise, seed 3,",
        "Detection, generated (realistic noise, seed 4,",
        "**Detection AP@0.5 by seed**",
        "| set | seed 3 | seed 4 | mean AP@0.5 |",
    ] {
        assert!(out.contains(needle), "{needle:?} missing from\n{out}");
    }
    // Five sets and the row over all of them, each with two seed cells.
    let summary: Vec<&str> = out
        .lines()
        .skip_while(|l| !l.starts_with("| set | seed 3 | seed 4 |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert_eq!(summary.len(), 6, "{summary:?}");
    assert!(summary[5].starts_with("| all sets |"), "{summary:?}");
    // --detect-only: no estimator variant table.
    assert!(!out.contains("| variant |"), "{out}");
    let written = std::fs::read_to_string(&md).expect("the markdown file is written");
    assert!(written.contains("**Detection AP@0.5 by seed**"));
}
