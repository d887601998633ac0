//! Every bad input gives its typed error naming the file, never a panic.

use std::path::{Path, PathBuf};

use anybox_io::camera::read_camera_json;
use anybox_io::image::{
    read_depth_png, read_mask_png, read_mask_png_sized, read_rgb, write_depth_png, write_mask_png,
    write_rgb_png,
};
use anybox_io::masks::{masks_from_label_image, read_coco_rle_json, read_mask_folder};
use anybox_io::results::read_results;
use anybox_io::{read_frame, DepthMap, IoError, Mask, RgbImage};

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn camera(dir: &Path, body: &str) -> PathBuf {
    write(dir, "camera.json", body.as_bytes())
}

const GOOD_CAM: &str =
    r#"{"cam_K": [600.0, 0.0, 320.0, 0.0, 600.0, 240.0, 0.0, 0.0, 1.0], "depth_scale": 1.0}"#;

fn gray8(dir: &Path, name: &str, w: u32, h: u32) -> PathBuf {
    let p = dir.join(name);
    ::image::GrayImage::from_pixel(w, h, ::image::Luma([9]))
        .save(&p)
        .unwrap();
    p
}

fn rgb8(dir: &Path, name: &str, w: u32, h: u32) -> PathBuf {
    let p = dir.join(name);
    RgbImage::from_pixel(w, h, ::image::Rgb([1, 2, 3]))
        .save(&p)
        .unwrap();
    p
}

fn depth16(dir: &Path, name: &str, w: u32, h: u32) -> PathBuf {
    let p = dir.join(name);
    let mut d = DepthMap::zeros(w, h);
    d.depth_mm.iter_mut().for_each(|v| *v = 500.0);
    write_depth_png(&p, &d, 1.0).unwrap();
    p
}

/// Asserts the error's message names the file and contains `needle`.
fn check(err: IoError, path: &Path, needle: &str) {
    let msg = err.to_string();
    assert_eq!(err.path(), path, "{msg}");
    assert!(msg.contains(&path.display().to_string()), "{msg}");
    assert!(msg.contains(needle), "`{needle}` not in: {msg}");
}

#[test]
fn missing_files() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("nope.png");
    let e = read_depth_png(&p, 1.0).unwrap_err();
    assert!(matches!(e, IoError::NotFound { .. }));
    check(e, &p, "not found");
    assert!(matches!(read_rgb(&p), Err(IoError::NotFound { .. })));
    assert!(matches!(read_mask_png(&p), Err(IoError::NotFound { .. })));
    let c = t.path().join("camera.json");
    assert!(matches!(
        read_camera_json(&c),
        Err(IoError::NotFound { .. })
    ));
    assert!(matches!(read_results(&c), Err(IoError::NotFound { .. })));
    assert!(matches!(
        read_coco_rle_json(&c, None),
        Err(IoError::NotFound { .. })
    ));
    assert!(matches!(
        read_mask_folder(&t.path().join("dir"), None),
        Err(IoError::NotFound { .. })
    ));
    let e = anybox_io::bop::BopDataset::open(&t.path().join("ds"), "test").unwrap_err();
    assert!(matches!(e, IoError::NotFound { .. }), "{e}");
}

#[test]
fn depth_of_wrong_pixel_format() {
    let t = tempfile::tempdir().unwrap();
    let p8 = gray8(t.path(), "d8.png", 4, 3);
    let e = read_depth_png(&p8, 1.0).unwrap_err();
    assert!(matches!(e, IoError::PixelFormat { .. }));
    check(
        e,
        &p8,
        "expected 16-bit grayscale depth PNG, got 8-bit grayscale PNG",
    );
    let prgb = rgb8(t.path(), "drgb.png", 4, 3);
    let e = read_depth_png(&prgb, 1.0).unwrap_err();
    check(e, &prgb, "got 8-bit RGB PNG");
    let pjpg = t.path().join("d.jpg");
    RgbImage::from_pixel(8, 8, ::image::Rgb([1, 2, 3]))
        .save(&pjpg)
        .unwrap();
    check(read_depth_png(&pjpg, 1.0).unwrap_err(), &pjpg, "JPEG");
    // A 16-bit image passed as RGB is caught too.
    let p16 = depth16(t.path(), "d16.png", 4, 3);
    check(read_rgb(&p16).unwrap_err(), &p16, "16-bit grayscale");
}

#[test]
fn corrupt_pngs() {
    let t = tempfile::tempdir().unwrap();
    // Random bytes (deterministic LCG).
    let mut x: u32 = 12345;
    let junk: Vec<u8> = (0..500)
        .map(|_| {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (x >> 16) as u8
        })
        .collect();
    let pj = write(t.path(), "junk.png", &junk);
    for e in [
        read_depth_png(&pj, 1.0).unwrap_err(),
        read_rgb(&pj).unwrap_err(),
        read_mask_png(&pj).unwrap_err(),
    ] {
        assert!(matches!(e, IoError::CorruptImage { .. }), "{e}");
        check(e, &pj, "corrupt");
    }
    // A valid PNG cut in half.
    let good = depth16(t.path(), "good.png", 64, 48);
    let bytes = std::fs::read(&good).unwrap();
    for cut in [bytes.len() / 2, 20, bytes.len() - 13] {
        let pt = write(t.path(), "trunc.png", &bytes[..cut]);
        let e = read_depth_png(&pt, 1.0).unwrap_err();
        assert!(matches!(e, IoError::CorruptImage { .. }), "cut {cut}: {e}");
        check(e, &pt, "corrupt");
    }
    // Empty file.
    let pe = write(t.path(), "empty.png", b"");
    assert!(matches!(read_rgb(&pe), Err(IoError::CorruptImage { .. })));
}

#[test]
fn frame_sizes_must_agree() {
    let t = tempfile::tempdir().unwrap();
    let cam = camera(t.path(), GOOD_CAM);
    let rgb = rgb8(t.path(), "rgb.png", 8, 6);
    let d_ok = depth16(t.path(), "depth.png", 8, 6);
    let f = read_frame(Some(&rgb), &d_ok, &cam).unwrap();
    assert_eq!(f.size(), (8, 6));
    assert!((f.depth.depth_mm[0] - 500.0).abs() < 1e-6);
    let d_bad = depth16(t.path(), "depth_small.png", 8, 5);
    let e = read_frame(Some(&rgb), &d_bad, &cam).unwrap_err();
    assert!(matches!(e, IoError::WrongSize { .. }));
    check(e, &d_bad, "expected 8x6 px, got 8x5 px");
    // Depth-only frames are fine.
    assert!(read_frame(None, &d_bad, &cam).unwrap().rgb.is_none());
    // width/height in camera.json are checked.
    let cam2 = camera(
        t.path(),
        r#"{"cam_K": [600, 0, 320, 0, 600, 240, 0, 0, 1], "depth_scale": 1, "width": 640, "height": 480}"#,
    );
    check(
        read_frame(None, &d_ok, &cam2).unwrap_err(),
        &d_ok,
        "expected 640x480 px",
    );
}

#[test]
fn bad_camera_files() {
    let t = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str)] = &[
        (r#"{"cam_K": [600.0, 0.0, 320.0, 0.0"#, "truncated"),
        (
            r#"{"cam_K": "six hundred", "depth_scale": 1.0}"#,
            "invalid type",
        ),
        (
            r#"{"cam_K": [600, 0, 320, 0, 600, 240, 0, 0], "depth_scale": 1.0}"#,
            "invalid length",
        ),
        (
            r#"{"cam_K": [600, 0, 320, 0, 600, 240, 0, 0, 1]}"#,
            "missing key `depth_scale`",
        ),
        (r#"{"depth_scale": 1.0}"#, "missing key `cam_K`"),
        (
            r#"{"cam_K": [0, 0, 320, 0, 600, 240, 0, 0, 1], "depth_scale": 1}"#,
            "focal lengths",
        ),
        (
            r#"{"cam_K": [-5, 0, 320, 0, 600, 240, 0, 0, 1], "depth_scale": 1}"#,
            "focal lengths",
        ),
        (
            r#"{"cam_K": [600, 0, 320, 0, 600, 240, 0, 0, 1], "depth_scale": 0}"#,
            "depth_scale",
        ),
        (
            r#"{"cam_K": [600, 0, 320, 0, 600, 240, 0, 0, 1], "depth_scale": -0.1}"#,
            "depth_scale",
        ),
        (
            r#"{"cam_K": [600, 3, 320, 0, 600, 240, 0, 0, 1], "depth_scale": 1}"#,
            "camera matrix",
        ),
        ("", "truncated"),
    ];
    for (body, needle) in cases {
        let p = camera(t.path(), body);
        let e = read_camera_json(&p).unwrap_err();
        check(e, &p, needle);
    }
    let p = camera(t.path(), r#"{"cam_K": [600.0, 0.0, 320.0,"#);
    match read_camera_json(&p).unwrap_err() {
        IoError::Json { line, column, .. } => assert_eq!((line, column), (1, 29)),
        other => panic!("{other}"),
    }
    // depth_scale <= 0 is also rejected by the depth reader and writer.
    let d = depth16(t.path(), "d.png", 2, 2);
    assert!(matches!(
        read_depth_png(&d, 0.0),
        Err(IoError::BadDepthScale { .. })
    ));
    assert!(matches!(
        read_depth_png(&d, f64::NAN),
        Err(IoError::BadDepthScale { .. })
    ));
    let out = t.path().join("w.png");
    assert!(matches!(
        write_depth_png(&out, &DepthMap::zeros(2, 2), -1.0),
        Err(IoError::BadDepthScale { .. })
    ));
    assert!(!out.exists());
}

#[test]
fn masks_of_the_wrong_size() {
    let t = tempfile::tempdir().unwrap();
    let mut m = Mask::empty(5, 4);
    m.set(1, 1, true);
    let p = t.path().join("m.png");
    write_mask_png(&p, &m).unwrap();
    let e = read_mask_png_sized(&p, 6, 4).unwrap_err();
    check(e, &p, "expected 6x4 px, got 5x4 px");
    let dir = t.path().join("inst");
    std::fs::create_dir(&dir).unwrap();
    write_mask_png(&dir.join("a.png"), &m).unwrap();
    write_mask_png(&dir.join("b.png"), &Mask::empty(3, 3)).unwrap();
    let e = read_mask_folder(&dir, Some((5, 4))).unwrap_err();
    check(e, &dir.join("b.png"), "has the wrong size");
    let lab = gray8(t.path(), "labels.png", 7, 7);
    check(
        masks_from_label_image(&lab, Some((5, 4))).unwrap_err(),
        &lab,
        "expected 5x4 px",
    );
    let rle = write(
        t.path(),
        "det.json",
        br#"[{"scene_id": 0, "image_id": 0, "category_id": 1, "score": 0.9,
             "segmentation": {"size": [3, 2], "counts": [6]}}]"#,
    );
    check(
        read_coco_rle_json(&rle, Some((5, 4))).unwrap_err(),
        &rle,
        "expected 5x4 px",
    );
}

#[test]
fn depth_image_given_as_label_image() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("depth.png");
    let mut d = DepthMap::zeros(64, 48);
    for (i, v) in d.depth_mm.iter_mut().enumerate() {
        *v = 400.0 + i as f32;
    }
    write_depth_png(&p, &d, 1.0).unwrap();
    check(
        masks_from_label_image(&p, None).unwrap_err(),
        &p,
        "not a label image",
    );
    let rgb = rgb8(t.path(), "rgb.png", 4, 4);
    check(
        masks_from_label_image(&rgb, None).unwrap_err(),
        &rgb,
        "got 8-bit RGB PNG",
    );
}

#[test]
fn bad_rle_json() {
    let t = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str)] = &[
        (r#"{"size": [3, 2], "counts": []}"#, "empty RLE"),
        (r#"{"size": [3, 2], "counts": ""}"#, "empty RLE"),
        (
            r#"{"size": [3, 2], "counts": [2, 3]}"#,
            "runs sum to 5 pixels",
        ),
        (
            r#"{"size": [3, 2], "counts": [2, 3, 4]}"#,
            "runs sum to 9 pixels",
        ),
        (r#"{"size": [3, 2], "counts": "6 "}"#, "invalid character"),
        (r#"{"size": [3, 2], "counts": "T"}"#, "middle of a number"),
        (r#"{"size": [0, 2], "counts": [0]}"#, "must be positive"),
        (
            r#"{"size": [100000, 100000], "counts": [10000000000]}"#,
            "exceeds the limit",
        ),
    ];
    for (seg, needle) in cases {
        let body = format!(r#"[{{"score": 0.5, "segmentation": {seg}}}]"#);
        let p = write(t.path(), "d.json", body.as_bytes());
        let e = read_coco_rle_json(&p, None).unwrap_err();
        check(e, &p, needle);
    }
    let p = write(t.path(), "d.json", br#"[{"score": 0.5}]"#);
    check(
        read_coco_rle_json(&p, None).unwrap_err(),
        &p,
        "missing key `segmentation`",
    );
    let p = write(
        t.path(),
        "d.json",
        br#"[{"score": "high", "segmentation": {"size": [1,1], "counts": [1]}}]"#,
    );
    check(
        read_coco_rle_json(&p, None).unwrap_err(),
        &p,
        "invalid type",
    );
}

#[test]
fn bad_results_json() {
    let t = tempfile::tempdir().unwrap();
    let ok = r#"{"scene_id": 1, "im_id": 2, "score": 0.5, "R": [1,0,0,0,1,0,0,0,1],
                "t": [0, 0, 500], "size": [10, 20, 30], "time": 0.1, "gt_index": null}"#;
    let p = write(
        t.path(),
        "r.json",
        format!(r#"{{"estimates": [{ok}]}}"#).as_bytes(),
    );
    assert_eq!(read_results(&p).unwrap().estimates.len(), 1);
    let cases: &[(&str, &str)] = &[
        (
            &ok.replace("\"score\": 0.5", "\"score\": \"x\""),
            "invalid type",
        ),
        (&ok.replace("\"im_id\": 2,", ""), "missing key `im_id`"),
        (
            &ok.replace("[10, 20, 30]", "[10, -20, 30]"),
            "invalid box size",
        ),
        (
            &ok.replace("[1,0,0,0,1,0,0,0,1]", "[1,0,0,0,1,0,0,0,2]"),
            "rotation",
        ),
    ];
    for (est, needle) in cases {
        let p = write(
            t.path(),
            "r.json",
            format!(r#"{{"estimates": [{est}]}}"#).as_bytes(),
        );
        check(read_results(&p).unwrap_err(), &p, needle);
    }
    let full = format!(r#"{{"estimates": [{ok}]}}"#);
    let p = write(t.path(), "r.json", &full.as_bytes()[..80]);
    check(read_results(&p).unwrap_err(), &p, "truncated");
}

#[test]
fn bop_dataset_inconsistencies() {
    use anybox_io::bop::{BopDataset, DatasetWriter, ModelInfo};
    use std::collections::BTreeMap;
    let t = tempfile::tempdir().unwrap();
    let root = t.path();
    let mut models = BTreeMap::new();
    models.insert(1, ModelInfo::cuboid([10.0, 20.0, 30.0]));
    DatasetWriter::create(root, "test", &models).unwrap();
    let sd = root.join("test/000000");
    std::fs::create_dir_all(&sd).unwrap();
    let cam = format!(r#"{{"0": {GOOD_CAM}, "1": {GOOD_CAM}}}"#);
    std::fs::write(sd.join("scene_camera.json"), &cam).unwrap();
    let gt = r#"{"0": [{"obj_id": 1, "cam_R_m2c": [1,0,0,0,1,0,0,0,1], "cam_t_m2c": [0,0,500]}]}"#;
    std::fs::write(sd.join("scene_gt.json"), gt).unwrap();
    // scene_gt_info with the wrong number of entries.
    std::fs::write(
        sd.join("scene_gt_info.json"),
        r#"{"0": [{"visib_fract": 1.0}, {"visib_fract": 0.5}]}"#,
    )
    .unwrap();
    // Depth images are needed only for the size when scene_camera lacks it.
    depth16(&sd, "x.png", 2, 2);
    std::fs::create_dir_all(sd.join("depth")).unwrap();
    for i in 0..2 {
        std::fs::copy(sd.join("x.png"), sd.join(format!("depth/{i:06}.png"))).unwrap();
    }
    let e = BopDataset::open(root, "test").unwrap_err();
    assert!(matches!(e, IoError::Inconsistent { .. }), "{e}");
    check(
        e,
        &sd.join("scene_gt_info.json"),
        "2 entries but scene_gt.json has 1",
    );
    // Without scene_gt_info: visib_fract 1 and counts from the masks on demand.
    std::fs::remove_file(sd.join("scene_gt_info.json")).unwrap();
    let ds = BopDataset::open(root, "test").unwrap();
    assert_eq!(ds.views.len(), 2);
    assert_eq!(ds.views[0].gts[0].visib_fract, 1.0);
    assert!(!ds.views[0].gt_info_present);
    let mut m = Mask::empty(2, 2);
    m.set(1, 0, true);
    m.set(1, 1, true);
    write_mask_png(&sd.join("mask_visib/000000_000000.png"), &m).unwrap();
    assert_eq!(ds.views[0].visib_counts(0).unwrap(), (2, [1, 0, 1, 2]));
    assert!(ds.views[0].load_mask_visib(3).is_err());
    // Unknown obj_id.
    std::fs::write(
        sd.join("scene_gt.json"),
        gt.replace("\"obj_id\": 1", "\"obj_id\": 7"),
    )
    .unwrap();
    check(
        BopDataset::open(root, "test").unwrap_err(),
        &sd.join("scene_gt.json"),
        "obj_id 7 is not in models_info.json",
    );
    // Ground truth for an image without a camera entry.
    std::fs::write(sd.join("scene_gt.json"), gt.replace("\"0\"", "\"5\"")).unwrap();
    check(
        BopDataset::open(root, "test").unwrap_err(),
        &sd.join("scene_gt.json"),
        "no entry in scene_camera.json",
    );
    // Non-numeric image id.
    std::fs::write(sd.join("scene_gt.json"), gt.replace("\"0\"", "\"abc\"")).unwrap();
    check(
        BopDataset::open(root, "test").unwrap_err(),
        &sd.join("scene_gt.json"),
        "non-negative integers",
    );
    // Bad camera entry inside scene_camera.json.
    std::fs::write(sd.join("scene_gt.json"), gt).unwrap();
    std::fs::write(
        sd.join("scene_camera.json"),
        cam.replace("\"depth_scale\": 1.0", "\"depth_scale\": 0"),
    )
    .unwrap();
    check(
        BopDataset::open(root, "test").unwrap_err(),
        &sd.join("scene_camera.json"),
        "depth_scale",
    );
    // Truncated models_info.json.
    std::fs::write(root.join("models_info.json"), r#"{"1": {"min_x": -5"#).unwrap();
    check(
        BopDataset::open(root, "test").unwrap_err(),
        &root.join("models_info.json"),
        "truncated",
    );
}

#[test]
fn writers_reject_bad_buffers_and_leave_nothing() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("m.png");
    let bad = Mask {
        width: 4,
        height: 4,
        data: vec![true; 3],
    };
    assert!(matches!(
        write_mask_png(&p, &bad),
        Err(IoError::Encode { .. })
    ));
    let bad_d = DepthMap {
        width: 4,
        height: 4,
        depth_mm: vec![1.0; 5],
    };
    assert!(matches!(
        write_depth_png(&p, &bad_d, 1.0),
        Err(IoError::Encode { .. })
    ));
    assert!(matches!(
        write_rgb_png(&p, &RgbImage::new(0, 0)),
        Err(IoError::Encode { .. })
    ));
    assert_eq!(std::fs::read_dir(t.path()).unwrap().count(), 0);
}
