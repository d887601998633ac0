//! COCO RLE codec, mask sources, image readers, results JSON and BOP19 CSV.

use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::OrientedBox;
use anybox_io::image::{read_depth_png, read_mask_png, read_rgb, write_depth_png, write_mask_png};
use anybox_io::masks::{
    counts_to_rle_string, decode_coco_rle, encode_coco_rle, masks_from_label_image,
    read_coco_rle_json, read_mask_folder, rle_string_to_counts, write_coco_rle_json, CocoRle,
    DetectionMask, RleCounts,
};
use anybox_io::results::{
    read_results, write_bop19_csv, write_results, EstimateRecord, ResultsFile,
};
use anybox_io::{DepthMap, Mask};
use proptest::prelude::*;

#[test]
fn mask_iou_of_overlapping_rectangles_is_the_closed_form() {
    // 10 × 4 and 6 × 6 px rectangles on a 20 × 10 image, overlapping in 4 × 4 px:
    // IoU = 16 / (40 + 36 − 16) = 16 / 60.
    let rect = |u0: u32, v0: u32, w: u32, h: u32| {
        let mut m = Mask::empty(20, 10);
        for v in v0..v0 + h {
            for u in u0..u0 + w {
                m.set(u, v, true);
            }
        }
        m
    };
    let (a, b) = (rect(0, 0, 10, 4), rect(6, 0, 6, 6));
    assert!((a.iou(&b) - 16.0 / 60.0).abs() < 1e-12, "{}", a.iou(&b));
    assert_eq!(a.iou(&b), b.iou(&a));
    assert_eq!(a.iou(&a), 1.0);
    assert_eq!(a.iou(&rect(12, 5, 3, 3)), 0.0);
    assert_eq!(Mask::empty(20, 10).iou(&Mask::empty(20, 10)), 0.0);
    // Masks of different sizes share no pixels.
    assert_eq!(a.iou(&Mask::empty(10, 20)), 0.0);
}

#[test]
fn rle_string_hand_worked_example() {
    // Worked by hand from pycocotools' rleToString (see masks.rs docs):
    // 100 → groups 4 (more), 3 → 'T' '3'; 200 → 8 (more), 6 → 'X' '6';
    // 50 → 18 (more; bit 0x10 set so "more" tests x != -1), 1 → 'b' '1';
    // 30 is the 4th count, stored as 30 − 200 = −170 → 22 (more), 26 (last, sign) → 'f' 'J'.
    assert_eq!(counts_to_rle_string(&[100, 200, 50, 30]), "T3X6b1fJ");
    assert_eq!(
        rle_string_to_counts("T3X6b1fJ").unwrap(),
        vec![100, 200, 50, 30]
    );
    // 0 → '0'; 1 → '1'; 31 has bit 0x10 set, so a positive 31 needs a second (zero) group:
    // 31|0x20 → 'o', then '0'; 16 is stored as 16 − 1 = 15 → '?'.
    assert_eq!(counts_to_rle_string(&[0, 1, 31, 16]), "01o0?");
    assert_eq!(rle_string_to_counts("01o0?").unwrap(), vec![0, 1, 31, 16]);
}

#[test]
fn rle_is_column_major_and_starts_with_background() {
    // h = 2, w = 3:   row 0: 0 1 1
    //                 row 1: 0 1 0
    // column-major sequence 0 0 | 1 1 | 1 0 → runs [2, 3, 1].
    let rle = CocoRle {
        size: [2, 3],
        counts: RleCounts::Uncompressed(vec![2, 3, 1]),
    };
    let m = decode_coco_rle(&rle).unwrap();
    assert_eq!((m.width, m.height), (3, 2));
    assert_eq!(m.data, vec![false, true, true, false, true, false]);
    let enc = encode_coco_rle(&m);
    assert_eq!(enc.size, [2, 3]);
    assert_eq!(enc.counts, RleCounts::Compressed("231".into()));
    // Pixel (0, 0) inside: a leading zero-length background run.
    let mut m2 = Mask::empty(2, 2);
    m2.set(0, 0, true);
    let RleCounts::Compressed(s) = encode_coco_rle(&m2).counts else {
        panic!("compressed expected")
    };
    assert_eq!(rle_string_to_counts(&s).unwrap(), vec![0, 1, 3]);
}

fn arb_mask() -> impl Strategy<Value = Mask> {
    (1u32..24, 1u32..24, any::<u64>(), 0.0f64..1.0).prop_map(|(w, h, seed, p)| {
        let mut x = seed | 1;
        let data = (0..w * h)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x % 1000) as f64 / 1000.0 < p
            })
            .collect();
        Mask {
            width: w,
            height: h,
            data,
        }
    })
}

proptest! {
    #[test]
    fn rle_round_trip(m in arb_mask()) {
        let enc = encode_coco_rle(&m);
        let dec = decode_coco_rle(&enc).unwrap();
        prop_assert_eq!(&dec, &m);
        // The uncompressed form decodes to the same mask.
        let RleCounts::Compressed(s) = &enc.counts else { unreachable!() };
        let counts = rle_string_to_counts(s).unwrap();
        prop_assert_eq!(counts.iter().sum::<u64>(), u64::from(m.width * m.height));
        let unc = CocoRle { size: enc.size, counts: RleCounts::Uncompressed(counts) };
        prop_assert_eq!(decode_coco_rle(&unc).unwrap(), m);
    }

    #[test]
    fn bbox_matches_a_brute_force_scan(m in arb_mask()) {
        let mut bb: Option<(u32, u32, u32, u32)> = None;
        for v in 0..m.height {
            for u in 0..m.width {
                if m.get(u, v) {
                    let (a, b, c, d) = bb.unwrap_or((u, v, u, v));
                    bb = Some((a.min(u), b.min(v), c.max(u), d.max(v)));
                }
            }
        }
        prop_assert_eq!(m.bbox(), bb);
    }

    #[test]
    fn rle_string_round_trip(counts in prop::collection::vec(0u64..5_000_000, 0..40)) {
        let s = counts_to_rle_string(&counts);
        prop_assert!(s.bytes().all(|b| (48..112).contains(&b)));
        prop_assert_eq!(rle_string_to_counts(&s).unwrap(), counts);
    }

    #[test]
    fn rle_decoder_never_panics(s in "[0-o]{0,30}", h in 0u32..50, w in 0u32..50) {
        let rle = CocoRle { size: [h, w], counts: RleCounts::Compressed(s) };
        let _ = decode_coco_rle(&rle);
    }
}

#[test]
fn detection_json_round_trip_and_sam6d_layout() {
    let t = tempfile::tempdir().unwrap();
    let mut a = Mask::empty(6, 5);
    for v in 1..4 {
        for u in 2..5 {
            a.set(u, v, true);
        }
    }
    let mut b = Mask::empty(6, 5);
    b.set(0, 0, true);
    b.set(5, 4, true);
    let dets = vec![
        DetectionMask {
            mask: a.clone(),
            score: 0.9,
            scene_id: 3,
            image_id: 7,
            category_id: 1,
        },
        DetectionMask {
            mask: b,
            score: 0.25,
            scene_id: 3,
            image_id: 7,
            category_id: 2,
        },
    ];
    let p = t.path().join("detection_ism.json");
    write_coco_rle_json(&p, &dets).unwrap();
    assert_eq!(read_coco_rle_json(&p, Some((6, 5))).unwrap(), dets);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    assert_eq!(v[0]["segmentation"]["size"], serde_json::json!([5, 6]));
    assert_eq!(v[0]["bbox"], serde_json::json!([2.0, 1.0, 3.0, 3.0]));
    // An uncompressed list, as some tools write it (SAM-6D with a list of counts).
    let list = r#"[{"scene_id": 1, "image_id": 2, "category_id": 3, "bbox": [0,0,1,1],
        "score": 0.5, "time": 1.2, "segmentation": {"size": [5, 6], "counts": [11, 3, 2, 3, 2, 3, 6]}}]"#;
    std::fs::write(&p, list).unwrap();
    let d = read_coco_rle_json(&p, None).unwrap();
    assert_eq!(d[0].mask, a);
    assert_eq!((d[0].scene_id, d[0].image_id, d[0].category_id), (1, 2, 3));
}

#[test]
fn label_image_and_mask_folder() {
    let t = tempfile::tempdir().unwrap();
    // 16-bit label image with labels 300, 7, 0 (background).
    let labels: Vec<u16> = (0..20).map(|i| [0, 300, 7, 300][i % 4]).collect();
    let img =
        ::image::ImageBuffer::<::image::Luma<u16>, _>::from_raw(5, 4, labels.clone()).unwrap();
    let p = t.path().join("labels.png");
    img.save(&p).unwrap();
    let masks = masks_from_label_image(&p, Some((5, 4))).unwrap();
    assert_eq!(
        masks.iter().map(|(l, _)| *l).collect::<Vec<_>>(),
        vec![7, 300]
    );
    for (l, m) in &masks {
        for (i, &x) in labels.iter().enumerate() {
            assert_eq!(m.data[i], u32::from(x) == *l);
        }
    }
    // Folder: sorted by name, non-PNG files ignored.
    let dir = t.path().join("inst");
    std::fs::create_dir(&dir).unwrap();
    let mut m1 = Mask::empty(3, 2);
    m1.set(0, 0, true);
    let mut m2 = Mask::empty(3, 2);
    m2.set(2, 1, true);
    write_mask_png(&dir.join("b_002.png"), &m1).unwrap();
    write_mask_png(&dir.join("a_010.png"), &m2).unwrap();
    std::fs::write(dir.join("notes.txt"), "x").unwrap();
    let got = read_mask_folder(&dir, Some((3, 2))).unwrap();
    assert_eq!(got.len(), 2);
    assert!(got[0].0.ends_with("a_010.png"));
    assert_eq!(got[0].1, m2);
    assert_eq!(got[1].1, m1);
}

#[test]
fn mask_png_color_types_nonzero_test() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("m.png");
    let g16 = ::image::ImageBuffer::<::image::Luma<u16>, _>::from_raw(3, 1, vec![0u16, 1, 65535])
        .unwrap();
    g16.save(&p).unwrap();
    assert_eq!(read_mask_png(&p).unwrap().data, vec![false, true, true]);
    let rgb = ::image::RgbImage::from_raw(3, 1, vec![0, 0, 0, 0, 0, 9, 255, 255, 255]).unwrap();
    rgb.save(&p).unwrap();
    assert_eq!(read_mask_png(&p).unwrap().data, vec![false, true, true]);
    let rgba =
        ::image::RgbaImage::from_raw(3, 1, vec![0, 0, 0, 255, 5, 0, 0, 255, 9, 9, 9, 0]).unwrap();
    rgba.save(&p).unwrap();
    assert_eq!(read_mask_png(&p).unwrap().data, vec![false, true, false]);
}

#[test]
fn depth_quantisation_and_clamping() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("d.png");
    let d = DepthMap {
        width: 6,
        height: 1,
        depth_mm: vec![0.0, 123.46, 6553.5, 7000.0, -3.0, f32::NAN],
    };
    write_depth_png(&p, &d, 0.1).unwrap();
    let r = read_depth_png(&p, 0.1).unwrap();
    let want = [0.0, 123.5, 6553.5, 6553.5, 0.0, 0.0];
    for (a, b) in r.depth_mm.iter().zip(want) {
        assert!((a - b).abs() < 1e-3, "{a} vs {b}");
    }
    // Raw values are value = round(mm / scale).
    let raw = ::image::open(&p).unwrap().into_luma16();
    assert_eq!(raw.as_raw(), &vec![0u16, 1235, 65535, 65535, 0, 0]);
    // Reading the same file with another scale scales linearly.
    let r1 = read_depth_png(&p, 1.0).unwrap();
    assert!((r1.depth_mm[1] - 1235.0).abs() < 1e-6);
}

#[test]
fn rgb_from_gray_png_and_jpeg() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("g.png");
    ::image::GrayImage::from_pixel(4, 3, ::image::Luma([77]))
        .save(&p)
        .unwrap();
    let rgb = read_rgb(&p).unwrap();
    assert_eq!(rgb.get_pixel(3, 2).0, [77, 77, 77]);
    let j = t.path().join("c.jpg");
    ::image::RgbImage::from_pixel(16, 16, ::image::Rgb([200, 50, 10]))
        .save(&j)
        .unwrap();
    let rgb = read_rgb(&j).unwrap();
    assert_eq!(rgb.dimensions(), (16, 16));
    let px = rgb.get_pixel(8, 8).0;
    assert!((i32::from(px[0]) - 200).abs() < 8 && (i32::from(px[1]) - 50).abs() < 8);
}

fn record(scene: u32, im: u32, time: f64, obj: Option<u64>) -> EstimateRecord {
    let pose = OrientedBox::new(
        Rotation3::from_euler_angles(0.1 * f64::from(im), 0.2, -0.3),
        Vector3::new(1.5, -2.25, 600.0 + f64::from(scene)),
        Vector3::new(100.0, 50.0, 25.5),
    )
    .unwrap();
    let mut r = EstimateRecord::from_pose(scene, im, &pose, 0.75, time, Some(im as usize));
    if let Some(o) = obj {
        r.extra.insert("obj_id".into(), serde_json::json!(o));
    }
    r.extra
        .insert("note".into(), serde_json::json!({"iterations": 4}));
    r
}

#[test]
fn results_json_round_trip_keeps_extra_fields() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("results.json");
    let mut file = ResultsFile {
        estimates: vec![record(1, 0, 0.5, Some(3)), record(1, 1, 0.25, None)],
    };
    file.estimates[1].gt_index = None;
    write_results(&p, &file).unwrap();
    let back = read_results(&p).unwrap();
    assert_eq!(back, file);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    assert!(v["estimates"][1]["gt_index"].is_null());
    assert_eq!(v["estimates"][0]["R"].as_array().unwrap().len(), 9);
    assert_eq!(v["estimates"][0]["note"]["iterations"], 4);
    let pose = back.estimates[0].pose().unwrap();
    assert!((pose.center_mm - Vector3::new(1.5, -2.25, 601.0)).norm() < 1e-12);
}

#[test]
fn bop19_csv_one_time_per_image() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("res.csv");
    let ests = vec![
        record(1, 0, 0.5, Some(3)),
        record(1, 0, 0.8, None),
        record(1, 1, -1.0, None),
        record(2, 0, 0.1, Some(2)),
    ];
    write_bop19_csv(&p, &ests).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "scene_id,im_id,obj_id,score,R,t,time");
    assert_eq!(lines.len(), 5);
    let rows: Vec<Vec<&str>> = lines[1..].iter().map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == 7));
    assert_eq!(rows[0][2], "3");
    assert_eq!(rows[1][2], "1");
    assert_eq!(rows[0][6], "0.8");
    assert_eq!(rows[1][6], "0.8");
    assert_eq!(rows[2][6], "-1");
    assert_eq!(rows[3][6], "0.1");
    for (row, e) in rows.iter().zip(&ests) {
        let r: Vec<f64> = row[4].split(' ').map(|x| x.parse().unwrap()).collect();
        let tt: Vec<f64> = row[5].split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!(r, e.r.to_vec());
        assert_eq!(tt, e.t.to_vec());
    }
}

#[test]
fn camera_json_round_trip() {
    use anybox_io::camera::{read_camera_info, read_camera_json, write_camera_json};
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("camera.json");
    let k = anybox_geom::Intrinsics::new(1066.778, 1067.487, 312.9869, 241.3109).unwrap();
    write_camera_json(&p, &k, 0.1, Some((640, 480))).unwrap();
    assert_eq!(read_camera_json(&p).unwrap(), (k, 0.1));
    let info = read_camera_info(&p).unwrap();
    assert_eq!(info.size, Some((640, 480)));
    // SAM-6D's example layout (integers, no size), extra keys ignored.
    std::fs::write(
        &p,
        r#"{"cam_K": [607, 0, 320, 0, 607, 240, 0, 0, 1], "depth_scale": 1, "view_level": 0}"#,
    )
    .unwrap();
    let info = read_camera_info(&p).unwrap();
    assert_eq!(info.intrinsics.fx, 607.0);
    assert_eq!(info.size, None);
}
