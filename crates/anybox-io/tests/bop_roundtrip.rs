//! Write → read round trip of a small generated BOP dataset, and reading the shared
//! real dataset `ycbv-boxes`.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::bop::{BopDataset, DatasetWriter, GtRecordOut, ModelInfo, ViewRecord};
use anybox_io::{DepthMap, Mask, RgbImage};

fn ycbv_root() -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/ycbv-boxes");
    if p.join("models_info.json").exists() {
        Some(p)
    } else {
        eprintln!(
            "NOTE: {} not found; skipping the ycbv-boxes test",
            p.display()
        );
        None
    }
}

#[test]
fn ycbv_boxes_counts_sizes_and_offset() {
    let Some(root) = ycbv_root() else { return };
    let ds = BopDataset::open(&root, "test").unwrap();
    assert_eq!(ds.views.len(), 10);
    assert_eq!(ds.n_gt(), 20);
    assert_eq!(ds.scene_ids(), vec![0]);
    let ids: Vec<u32> = ds.views.iter().map(|v| v.im_id).collect();
    assert_eq!(ids, (0..10).collect::<Vec<_>>());
    let s1 = ds.models[&1].size_mm();
    let s2 = ds.models[&2].size_mm();
    for (got, want) in [(s1, [88.84, 72.76, 29.73]), (s2, [77.42, 51.66, 50.93])] {
        for i in 0..3 {
            assert!((got[i] - want[i]).abs() < 0.006, "{got:?} vs {want:?}");
        }
    }
    // Box-centre offset by hand from the raw JSON: c = R (min + size/2) + t.
    let raw: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("test/000000/scene_gt.json")).unwrap(),
    )
    .unwrap();
    let mi: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("models_info.json")).unwrap())
            .unwrap();
    for v in &ds.views {
        let list = &raw[v.im_id.to_string()];
        for g in &v.gts {
            let e = &list[g.gt_index];
            let r: Vec<f64> = (0..9)
                .map(|i| e["cam_R_m2c"][i].as_f64().unwrap())
                .collect();
            let t: Vec<f64> = (0..3)
                .map(|i| e["cam_t_m2c"][i].as_f64().unwrap())
                .collect();
            let m = &mi[e["obj_id"].as_u64().unwrap().to_string()];
            let off = [
                m["min_x"].as_f64().unwrap() + m["size_x"].as_f64().unwrap() / 2.0,
                m["min_y"].as_f64().unwrap() + m["size_y"].as_f64().unwrap() / 2.0,
                m["min_z"].as_f64().unwrap() + m["size_z"].as_f64().unwrap() / 2.0,
            ];
            for row in 0..3 {
                let c = t[row]
                    + r[3 * row] * off[0]
                    + r[3 * row + 1] * off[1]
                    + r[3 * row + 2] * off[2];
                assert!((g.pose.center_mm[row] - c).abs() < 1e-9);
            }
            assert!(g.visib_fract > 0.0 && g.visib_fract <= 1.0);
        }
    }
    let f = ds.views[0].load_frame().unwrap();
    assert_eq!((f.depth.width, f.depth.height), (640, 480));
    assert!(f.rgb.is_some());
    assert!((f.intrinsics.fx - 1066.778).abs() < 1e-9);
    let m = ds.views[0].load_mask_visib(1).unwrap();
    assert_eq!(m.count() as u64, ds.views[0].gts[1].px_count_visib);
    assert_eq!(m.bbox_xywh(), ds.views[0].gts[1].bbox_visib);
}

/// A synthetic view: gradient RGB, a tilted depth plane, a rectangular mask per box.
fn make_view(im_id: u32, w: u32, h: u32, sizes: &[(u32, [f64; 3])]) -> ViewRecord {
    let mut rgb = RgbImage::new(w, h);
    for (u, v, p) in rgb.enumerate_pixels_mut() {
        *p = ::image::Rgb([
            (u * 7 % 256) as u8,
            (v * 5 % 256) as u8,
            ((u + v + im_id) % 256) as u8,
        ]);
    }
    let mut depth = DepthMap::zeros(w, h);
    for v in 0..h {
        for u in 0..w {
            depth.depth_mm[(v * w + u) as usize] = if (u + v) % 11 == 0 {
                0.0
            } else {
                700.0 + 0.37 * u as f32 + 1.13 * v as f32
            };
        }
    }
    let mut gts = Vec::new();
    for (i, (obj_id, size)) in sizes.iter().enumerate() {
        let mut mask = Mask::empty(w, h);
        for v in 3 + i as u32..10 + 2 * i as u32 {
            for u in 5..20 + i as u32 {
                mask.set(u, v, true);
            }
        }
        let rot = Rotation3::from_euler_angles(0.3 + i as f64, -0.7, 1.1 * im_id as f64);
        gts.push(GtRecordOut {
            obj_id: *obj_id,
            pose: OrientedBox::new(
                rot,
                Vector3::new(10.0 * i as f64, -20.0, 800.0 + im_id as f64),
                Vector3::from(*size),
            )
            .unwrap(),
            px_count_valid: mask.count() as u64,
            px_count_all: mask.count() as u64 + 7,
            visib_fract: mask.count() as f64 / (mask.count() as f64 + 7.0),
            bbox_obj: [1, 2, 30, 40],
            mask_visib: mask,
        });
    }
    ViewRecord {
        im_id,
        rgb,
        depth,
        intrinsics: Intrinsics::new(500.0 + im_id as f64, 510.0, w as f64 / 2.0, h as f64 / 2.0)
            .unwrap(),
        depth_scale: 0.1,
        gts,
    }
}

#[test]
fn write_read_round_trip() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("ds");
    let mut models = BTreeMap::new();
    models.insert(1, ModelInfo::cuboid([300.0, 200.0, 150.0]));
    models.insert(2, ModelInfo::cuboid([120.5, 80.25, 60.0]));
    // A model whose origin is not the box centre: the writer must subtract the offset.
    let mut off = ModelInfo::cuboid([50.0, 40.0, 30.0]);
    off.min_x = 0.0;
    off.min_y = -5.0;
    off.min_z = 3.0;
    models.insert(12, off);
    let writer = DatasetWriter::create(&root, "test", &models).unwrap();
    let (w, h) = (40, 30);
    let scenes: Vec<(u32, Vec<ViewRecord>)> = vec![
        (
            2,
            vec![
                make_view(
                    5,
                    w,
                    h,
                    &[(1, [300.0, 200.0, 150.0]), (12, [50.0, 40.0, 30.0])],
                ),
                make_view(1, w, h, &[(2, [120.5, 80.25, 60.0])]),
            ],
        ),
        (10, vec![make_view(0, w, h, &[])]),
        (1, vec![make_view(3, w, h, &[(2, [120.5, 80.25, 60.0])])]),
    ];
    for (sid, views) in &scenes {
        writer.write_scene(*sid, views).unwrap();
    }
    writer
        .write_scene_meta(
            2,
            &serde_json::json!({"layout": "pallet", "distractors": 3}),
        )
        .unwrap();

    // Layout exactly as SPEC §3.
    let sd = root.join("test/000002");
    for f in [
        "rgb/000005.png",
        "depth/000005.png",
        "mask_visib/000005_000001.png",
        "scene_camera.json",
        "scene_gt.json",
        "scene_gt_info.json",
        "scene_meta.json",
    ] {
        assert!(sd.join(f).exists(), "{f}");
    }
    assert!(root.join("models_info.json").exists());
    // Numeric key order in JSON text (10 after 2 would fail a string sort).
    let mi = std::fs::read_to_string(root.join("models_info.json")).unwrap();
    assert!(mi.find("\"2\"").unwrap() < mi.find("\"12\"").unwrap());
    // No temporary files left behind.
    for e in walk(&root) {
        assert!(!e.to_string_lossy().ends_with(".tmp"), "{}", e.display());
    }

    let ds = BopDataset::open(&root, "test").unwrap();
    assert_eq!(ds.scene_ids(), vec![1, 2, 10]);
    let order: Vec<(u32, u32)> = ds.views.iter().map(|v| (v.scene_id, v.im_id)).collect();
    assert_eq!(order, vec![(1, 3), (2, 1), (2, 5), (10, 0)]);
    assert_eq!(ds.models, models);
    for (sid, views) in &scenes {
        for rec in views {
            let v = ds
                .views
                .iter()
                .find(|v| v.scene_id == *sid && v.im_id == rec.im_id)
                .unwrap();
            assert_eq!(v.intrinsics, rec.intrinsics);
            assert_eq!((v.width, v.height), (w, h));
            assert_eq!(v.gts.len(), rec.gts.len());
            let f = v.load_frame().unwrap();
            assert_eq!(f.rgb.as_ref().unwrap(), &rec.rgb);
            for (a, b) in f.depth.depth_mm.iter().zip(&rec.depth.depth_mm) {
                // Quantisation: half a depth_scale step (0.05 mm), plus f32 rounding.
                assert!((a - b).abs() <= 0.05 + 1e-3, "{a} vs {b}");
                assert_eq!(*a == 0.0, *b == 0.0);
            }
            for (g, r) in v.gts.iter().zip(&rec.gts) {
                assert_eq!(g.obj_id, r.obj_id);
                assert!((g.pose.center_mm - r.pose.center_mm).norm() < 1e-9);
                assert!(
                    (g.pose.rotation.matrix() - r.pose.rotation.matrix())
                        .abs()
                        .max()
                        < 1e-12
                );
                assert!((g.pose.size_mm - r.pose.size_mm).norm() < 1e-12);
                assert!((g.visib_fract - r.visib_fract).abs() < 1e-12);
                assert_eq!(g.px_count_visib, r.mask_visib.count() as u64);
                assert_eq!(g.bbox_visib, r.mask_visib.bbox_xywh());
                assert_eq!(v.load_mask_visib(g.gt_index).unwrap(), r.mask_visib);
            }
        }
    }
}

fn walk(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}
