//! Crate tests: determinism, exact masks and depth against independent geometry
//! (`anybox_geom::projection`), visibility fractions, touching pallet cartons, noise statistics,
//! and the BOP round trip through `anybox_io`.

use anybox_geom::projection::{rasterize_convex_polygon, ray_box_intersection, silhouette_hull_px};
use anybox_geom::{Intrinsics, OrientedBox};
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

use crate::render::{render, CamObject};
use crate::scene::{build_scene, CameraKind, ObjKind};
use crate::shape::Shape;
use crate::texture::Material;
use crate::*;

fn k640() -> Intrinsics {
    Intrinsics::new(615.0, 615.0, 320.0, 240.0).unwrap()
}

fn cuboid(b: &OrientedBox) -> Shape {
    Shape::Cuboid {
        rot: *b.rotation.matrix(),
        center: b.center_mm,
        half: b.size_mm * 0.5,
    }
}

/// A tilted box in front of a floor-like slab far behind it.
fn box_on_floor() -> (OrientedBox, Shape) {
    let b = OrientedBox::new(
        Rotation3::from_euler_angles(0.4, -0.5, 0.9),
        Vector3::new(30.0, -20.0, 900.0),
        Vector3::new(260.0, 180.0, 120.0),
    )
    .unwrap();
    let floor = Shape::Cuboid {
        rot: *Rotation3::from_euler_angles(-0.9, 0.0, 0.0).matrix(),
        center: Vector3::new(0.0, 0.0, 1400.0),
        half: Vector3::new(5000.0, 5000.0, 10.0),
    };
    (b, floor)
}

/// True when the 3×3 neighbourhood of `(u, v)` in `m` holds both values (a boundary pixel).
fn on_boundary(m: &[bool], w: usize, h: usize, u: usize, v: usize) -> bool {
    let mut seen = [false; 2];
    for dv in -1i64..=1 {
        for du in -1i64..=1 {
            let (x, y) = (u as i64 + du, v as i64 + dv);
            if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                seen[m[y as usize * w + x as usize] as usize] = true;
            }
        }
    }
    seen[0] && seen[1]
}

#[test]
fn single_box_mask_and_depth_are_exact() {
    let (b, floor) = box_on_floor();
    let k = k640();
    let mat = Material::Solid([0.5, 0.5, 0.5]);
    let objs = vec![
        CamObject::new(floor, &mat, ObjKind::Structure, &k),
        CamObject::new(cuboid(&b), &mat, ObjKind::GtBox(0), &k),
    ];
    let out = render(&objs, 1, &k, 640, 480, &Vector3::new(0.0, -1.0, 0.0));
    let hull = silhouette_hull_px(&b, &k).unwrap();
    let raster = rasterize_convex_polygon(&hull, 640, 480);
    let mut n_mask = 0;
    let mut mismatches = 0;
    for v in 0..480usize {
        for u in 0..640usize {
            let i = v * 640 + u;
            let ours = out.inst[i] == 0;
            n_mask += ours as usize;
            if ours != raster[i] {
                mismatches += 1;
                assert!(
                    on_boundary(&raster, 640, 480, u, v),
                    "interior mismatch at ({u}, {v})"
                );
            }
            if ours {
                let dir = Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0);
                let (t, _, _) = ray_box_intersection(&Point3::origin(), &dir, &b).unwrap();
                assert!(
                    (out.depth_mm[i] - t).abs() < 1e-6,
                    "depth {} vs {t}",
                    out.depth_mm[i]
                );
            }
        }
    }
    assert!(n_mask > 5000, "box too small: {n_mask}");
    assert!(mismatches < n_mask / 50, "{mismatches} boundary mismatches");
    // Alone in the scene except for a floor behind it: fully visible.
    assert_eq!(out.px_all[0], n_mask as u64);
}

#[test]
fn occlusion_lowers_visib_fract_and_truncation_counts() {
    let (b, floor) = box_on_floor();
    let k = k640();
    let mat = Material::Solid([0.5, 0.5, 0.5]);
    let front = OrientedBox::new(
        Rotation3::identity(),
        Vector3::new(80.0, 0.0, 600.0),
        Vector3::new(100.0, 100.0, 100.0),
    )
    .unwrap();
    let objs = vec![
        CamObject::new(floor, &mat, ObjKind::Structure, &k),
        CamObject::new(cuboid(&b), &mat, ObjKind::GtBox(0), &k),
        CamObject::new(cuboid(&front), &mat, ObjKind::GtBox(1), &k),
    ];
    let out = render(&objs, 2, &k, 640, 480, &Vector3::new(0.0, -1.0, 0.0));
    let visib0 = out.inst.iter().filter(|&&i| i == 0).count() as u64;
    let visib1 = out.inst.iter().filter(|&&i| i == 1).count() as u64;
    let hull0 = rasterize_convex_polygon(&silhouette_hull_px(&b, &k).unwrap(), 640, 480);
    let n_hull0 = hull0.iter().filter(|x| **x).count() as u64;
    // px_count_all is the unoccluded silhouette (up to boundary pixels), not the visible part.
    assert!((out.px_all[0] as f64 - n_hull0 as f64).abs() < 0.02 * n_hull0 as f64);
    assert!(
        visib0 < out.px_all[0] * 9 / 10,
        "occluder must hide part of box 0"
    );
    assert_eq!(visib1, out.px_all[1], "front box is unoccluded");
    // A box cut by the image border: px_count_all counts the part outside the image too.
    let cut = OrientedBox::new(
        Rotation3::identity(),
        Vector3::new(-400.0, 0.0, 800.0),
        Vector3::new(200.0, 200.0, 200.0),
    )
    .unwrap();
    let objs = vec![CamObject::new(cuboid(&cut), &mat, ObjKind::GtBox(0), &k)];
    let out = render(&objs, 1, &k, 640, 480, &Vector3::new(0.0, -1.0, 0.0));
    let visib = out.inst.iter().filter(|&&i| i == 0).count() as u64;
    // Front face spans x ∈ [−500, −300] at z = 700: u ∈ [−119, 56.4], so ~1/3 is in the image.
    let expected_all = {
        let kk = Intrinsics::new(615.0, 615.0, 320.0 + 640.0, 240.0 + 480.0).unwrap();
        let h = silhouette_hull_px(&cut, &kk).unwrap();
        rasterize_convex_polygon(&h, 3 * 640, 3 * 480)
            .iter()
            .filter(|x| **x)
            .count() as f64
    };
    assert!((out.px_all[0] as f64 - expected_all).abs() < 0.02 * expected_all);
    assert!(visib < out.px_all[0] / 2);
    let bb = out.sil_bbox[0].unwrap();
    assert!(
        bb[0] < 0,
        "silhouette bbox extends left of the image: {bb:?}"
    );
}

#[test]
fn same_seed_same_bytes_different_seed_differs() {
    for layout in [Layout::Pallet, Layout::Table, Layout::Shelf] {
        let cfg = SynthConfig {
            layout,
            seed: 11,
            ..SynthConfig::default()
        };
        let a = generate_view(&cfg, 1, 1);
        let b = generate_view(&cfg, 1, 1);
        assert_eq!(a.rgb.as_raw(), b.rgb.as_raw());
        assert_eq!(a.depth, b.depth);
        assert_eq!(a.boxes, b.boxes);
        let c = generate_view(&SynthConfig { seed: 12, ..cfg }, 1, 1);
        assert_ne!(a.depth, c.depth, "{layout}: seed must matter");
    }
}

#[test]
fn api_depth_matches_analytic_intersection_without_noise() {
    for layout in [Layout::Pallet, Layout::Table, Layout::Shelf] {
        let cfg = SynthConfig {
            layout,
            noise: NoiseModel::None,
            seed: 3,
            ..SynthConfig::default()
        };
        let v = generate_view(&cfg, 0, 0);
        let k = v.intrinsics;
        assert!(!v.boxes.is_empty());
        let mut checked = 0;
        for b in &v.boxes {
            let n = b.mask_visib.count() as u64;
            assert!(n > 0);
            assert!((b.visib_fract - n as f64 / b.px_count_all as f64).abs() < 1e-12);
            assert!(b.visib_fract > 0.0 && b.visib_fract <= 1.0);
            for (i, _) in b
                .mask_visib
                .data
                .iter()
                .enumerate()
                .filter(|(_, m)| **m)
                .step_by(7)
            {
                let (u, q) = ((i % 640) as f64, (i / 640) as f64);
                let dir = Vector3::new((u - k.cx) / k.fx, (q - k.cy) / k.fy, 1.0);
                let (t, _, _) = ray_box_intersection(&Point3::origin(), &dir, &b.pose)
                    .expect("a mask pixel's ray hits its box");
                let z = v.depth.depth_mm[i] as f64;
                assert!(
                    (z - t).abs() < 1e-3 * t,
                    "{layout}: depth {z} vs analytic {t}"
                );
                checked += 1;
            }
        }
        assert!(checked > 100);
    }
}

#[test]
fn pallet_cartons_touch_and_never_interpenetrate() {
    let mut adjacent_pairs = 0;
    for s in 0..12u32 {
        let mut rng = crate::rng::stream(5, s, 0, crate::rng::purpose::SCENE);
        let sc = build_scene(Layout::Pallet, &mut rng, None);
        let boxes: Vec<_> = sc.boxes.iter().filter(|b| b.support != "floor").collect();
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                let (oa, ob) = (a.obb, b.obb);
                let d = oa.rot.tr_mul(&(ob.center - oa.center));
                let same_layer = (oa.center.z - ob.center.z).abs() < 1e-6
                    && (oa.rot - ob.rot).abs().max() < 1e-12
                    && oa.half == ob.half;
                if !same_layer {
                    continue;
                }
                let gap_x = d.x.abs() - 2.0 * oa.half.x;
                let gap_y = d.y.abs() - 2.0 * oa.half.y;
                assert!(
                    gap_x.max(gap_y) > -1e-6,
                    "interpenetrating cartons in scene {s}"
                );
                // Grid neighbours (centres one pitch apart up to jitter) must share a face.
                let x_nb = gap_x.abs() < 12.0 && d.y.abs() < 12.0;
                let y_nb = gap_y.abs() < 12.0 && d.x.abs() < 12.0;
                if x_nb {
                    assert!(
                        gap_x.abs() < 1.0,
                        "scene {s}: x-neighbours {gap_x} mm apart"
                    );
                    adjacent_pairs += 1;
                }
                if y_nb {
                    assert!(
                        gap_y.abs() < 1.0,
                        "scene {s}: y-neighbours {gap_y} mm apart"
                    );
                    adjacent_pairs += 1;
                }
            }
        }
        // Vertical contact: every carton above the pallet rests exactly on the layer below.
        for a in &boxes {
            if a.support == "box" {
                let bottom = a.obb.center.z - a.obb.half.z;
                assert!(
                    boxes
                        .iter()
                        .any(|b| (b.obb.center.z + b.obb.half.z - bottom).abs() < 1e-6),
                    "scene {s}: floating carton"
                );
            }
        }
    }
    assert!(
        adjacent_pairs > 30,
        "too few touching pairs: {adjacent_pairs}"
    );
}

fn plane_noise(camera: CameraKind, z_mm: f64) -> Vec<f32> {
    let k = k640();
    let mat = Material::Solid([0.5, 0.5, 0.5]);
    let wall = Shape::Cuboid {
        rot: Matrix3::identity(),
        center: Vector3::new(0.0, 0.0, z_mm + 50.0),
        half: Vector3::new(50_000.0, 50_000.0, 50.0),
    };
    let objs = vec![CamObject::new(wall, &mat, ObjKind::Structure, &k)];
    let out = render(&objs, 0, &k, 640, 480, &Vector3::new(0.0, 0.0, -1.0));
    let mut rng = crate::rng::stream(1, 2, 3, 4);
    crate::noise::apply_realistic(&out, camera, k.fx, 640, 480, 77, &mut rng)
}

fn plane_noise_std(camera: CameraKind, z_mm: f64) -> (f64, f64) {
    let d = plane_noise(camera, z_mm);
    let res: Vec<f64> = d
        .iter()
        .filter(|&&x| x > 0.0)
        .map(|&x| x as f64 - z_mm)
        .collect();
    assert!(
        res.len() > 640 * 480 * 8 / 10,
        "too many dropouts on a flat wall"
    );
    let mean = res.iter().sum::<f64>() / res.len() as f64;
    let var = res.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / res.len() as f64;
    (mean, var.sqrt())
}

#[test]
fn noise_std_matches_model_at_1_and_2_m() {
    for camera in [CameraKind::RealSenseD435, CameraKind::KinectLike] {
        for z in [1000.0, 2000.0] {
            let (mean, std) = plane_noise_std(camera, z);
            let sigma = crate::noise::axial_sigma_mm(camera, z, 0.0);
            println!("{camera:?} at {z} mm: measured σ {std:.2} mm, model {sigma:.2} mm");
            assert!(
                (std / sigma - 1.0).abs() < 0.2,
                "{camera:?} at {z} mm: measured σ {std:.2} vs model {sigma:.2}"
            );
            assert!(mean.abs() < 0.5, "biased noise: {mean}");
        }
    }
}

#[test]
fn noise_is_spatially_correlated_like_window_matching() {
    // Correlation of horizontally adjacent residuals: white noise would give ≈ 0.
    let d = plane_noise(CameraKind::RealSenseD435, 1500.0);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for v in 0..480 {
        for u in 0..639 {
            let (a, b) = (d[v * 640 + u], d[v * 640 + u + 1]);
            if a > 0.0 && b > 0.0 {
                let (a, b) = (a as f64 - 1500.0, b as f64 - 1500.0);
                sxy += a * b;
                sxx += a * a;
            }
        }
    }
    let corr = sxy / sxx;
    assert!(corr > 0.3 && corr < 0.7, "neighbour correlation {corr}");
}

#[test]
fn every_layout_gives_boxes_and_finite_values() {
    for layout in [Layout::Pallet, Layout::Table, Layout::Shelf, Layout::Mixed] {
        let cfg = SynthConfig {
            layout,
            width: 320,
            height: 240,
            seed: 9,
            scenes: 3,
            views: 2,
            ..SynthConfig::default()
        };
        for v in generate_views(&cfg) {
            assert!(
                !v.boxes.is_empty(),
                "{layout} scene {} view {}: no box",
                v.scene_id,
                v.im_id
            );
            assert!(v.depth.depth_mm.iter().all(|d| d.is_finite() && *d >= 0.0));
            assert!(v.depth.valid_count() > 320 * 240 / 2);
            // The floor (world z = 0) lies below every box: box centres are above it.
            for b in &v.boxes {
                let cw = v.world_from_camera * Point3::from(b.pose.center_mm);
                assert!(
                    cw.z > b.pose.size_mm.min() / 2.0 - 1e-6,
                    "box centre below the floor"
                );
                assert!(b.visib_fract.is_finite() && b.visib_fract > 0.0 && b.visib_fract <= 1.0);
                assert!(b.pose.center_mm.iter().all(|x| x.is_finite()));
                assert!(
                    b.pose.size_mm.iter().all(|s| (40.0..=600.0).contains(s)),
                    "{:?}",
                    b.pose.size_mm
                );
                assert!(b.px_count_valid <= b.px_count_all);
                assert!(b.obj_id >= 1);
            }
        }
    }
}

#[test]
fn table_scenes_have_tilted_stacked_boxes_and_distractors() {
    let (mut tilted, mut stacked, mut distractors) = (0, 0, 0);
    for s in 0..10 {
        let mut rng = crate::rng::stream(1, s, 0, crate::rng::purpose::SCENE);
        let sc = build_scene(Layout::Table, &mut rng, None);
        for b in &sc.boxes {
            let tilt = b.obb.rot[(2, 2)].abs().acos().to_degrees();
            assert!(tilt < 45.0 + 1e-6);
            tilted += (tilt > 5.0) as u32;
            stacked += (b.support == "box") as u32;
        }
        assert!(sc.distractors <= 32);
        distractors += sc.distractors;
    }
    assert!(
        tilted > 0 && stacked > 0 && distractors > 0,
        "{tilted} {stacked} {distractors}"
    );
    let mut rng = crate::rng::stream(1, 0, 0, crate::rng::purpose::SCENE);
    let sc = build_scene(Layout::Table, &mut rng, Some(32));
    assert!(
        sc.distractors >= 20,
        "only {} of 32 distractors placed",
        sc.distractors
    );
}

#[test]
fn obj_ids_agree_with_models() {
    let cfg = SynthConfig {
        scenes: 3,
        views: 1,
        width: 320,
        height: 240,
        ..SynthConfig::default()
    };
    let models = models(&cfg);
    for v in generate_views(&cfg) {
        for b in &v.boxes {
            let m = &models[&b.obj_id];
            assert!((m.size_mm() - b.pose.size_mm).abs().max() < 1e-6);
        }
    }
}

#[test]
fn bop_round_trip_and_identical_files() {
    let cfg = SynthConfig {
        scenes: 3,
        views: 2,
        width: 320,
        height: 240,
        seed: 4,
        ..SynthConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    let sa = write_dataset(&cfg, &a).unwrap();
    write_dataset(&cfg, &b).unwrap();
    assert_eq!(sa.views, 6);
    let ds = anybox_io::bop::BopDataset::open(&a, SPLIT).unwrap();
    assert_eq!(ds.views.len(), 6);
    let views = generate_views(&cfg);
    let mut n = 0;
    for (bv, sv) in ds.views.iter().zip(&views) {
        assert_eq!((bv.scene_id, bv.im_id), (sv.scene_id, sv.im_id));
        assert_eq!(bv.gts.len(), sv.boxes.len());
        for (g, (gt, sb)) in bv.gts.iter().zip(&sv.boxes).enumerate() {
            assert_eq!(gt.obj_id, sb.obj_id);
            assert!((gt.pose.center_mm - sb.pose.center_mm).norm() < 1e-3);
            assert!(
                (gt.pose.rotation.matrix() - sb.pose.rotation.matrix())
                    .abs()
                    .max()
                    < 1e-6
            );
            assert_eq!(bv.load_mask_visib(g).unwrap(), sb.mask_visib);
            n += 1;
        }
        let f = bv.load_frame().unwrap();
        for (x, y) in f.depth.depth_mm.iter().zip(&sv.depth.depth_mm) {
            assert!((x - y.round()).abs() < 1e-3);
        }
    }
    assert!(n > 0);
    // Byte-identical output.
    let mut files: Vec<_> = walk(&a);
    files.sort();
    assert!(files.len() > 10);
    for f in files {
        let rel = f.strip_prefix(&a).unwrap();
        assert_eq!(
            std::fs::read(&f).unwrap(),
            std::fs::read(b.join(rel)).unwrap(),
            "{rel:?}"
        );
    }
}

fn walk(p: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(p).unwrap() {
        let e = e.unwrap().path();
        if e.is_dir() {
            out.extend(walk(&e));
        } else {
            out.push(e);
        }
    }
    out
}

#[test]
fn parses_names_and_rejects_bad_config() {
    assert_eq!("pallet".parse::<Layout>().unwrap(), Layout::Pallet);
    assert_eq!("Mixed".parse::<Layout>().unwrap(), Layout::Mixed);
    assert!("crate".parse::<Layout>().is_err());
    assert_eq!("none".parse::<NoiseModel>().unwrap(), NoiseModel::None);
    assert!("loud".parse::<NoiseModel>().is_err());
    let bad = SynthConfig {
        width: 0,
        ..SynthConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    assert!(matches!(
        write_dataset(&bad, dir.path()),
        Err(SynthError::InvalidConfig(_))
    ));
    assert_eq!(Layout::Mixed.for_scene(4), Layout::Table);
}

/// Timing (not an assertion): `cargo test --release -p anybox-synth -- --ignored --nocapture`.
#[test]
#[ignore]
fn timing_report() {
    let cfg = SynthConfig::default();
    let t0 = std::time::Instant::now();
    let _ = generate_view(&cfg, 0, 0);
    println!("one view: {:.1} ms", t0.elapsed().as_secs_f64() * 1e3);
    let cfg = SynthConfig {
        scenes: 25,
        views: 4,
        ..SynthConfig::default()
    };
    let t0 = std::time::Instant::now();
    let v = generate_views(&cfg);
    println!("{} views: {:.2} s", v.len(), t0.elapsed().as_secs_f64());
}

#[test]
fn no_box_interpenetrates_another_box_or_structure() {
    for layout in [Layout::Pallet, Layout::Table, Layout::Shelf] {
        for s in 0..10u32 {
            let mut rng = crate::rng::stream(21, s, 0, crate::rng::purpose::SCENE);
            let sc = build_scene(layout, &mut rng, None);
            let structures: Vec<crate::shape::Obb> = sc
                .objects
                .iter()
                .filter(|o| o.kind == ObjKind::Structure)
                .filter_map(|o| match o.shape {
                    Shape::Cuboid { rot, center, half } => {
                        Some(crate::shape::Obb { rot, center, half })
                    }
                    _ => None,
                })
                .collect();
            for (i, a) in sc.boxes.iter().enumerate() {
                for b in &sc.boxes[i + 1..] {
                    assert!(
                        !a.obb.overlaps(&b.obb, -0.05),
                        "{layout} scene {s}: boxes overlap"
                    );
                }
                for st in &structures {
                    assert!(
                        !a.obb.overlaps(st, -0.05),
                        "{layout} scene {s}: box inside structure"
                    );
                }
                // Every box rests on something: its lowest point is at most 0.1 mm above a
                // support surface (floor, pallet deck, table, board or a box top); leaning boxes too.
                let rot = a.obb.rot;
                let lowest = a.obb.center.z - (rot.row(2).abs() * a.obb.half)[0];
                let tops: Vec<f64> = structures
                    .iter()
                    .chain(sc.boxes.iter().map(|b| &b.obb))
                    .map(|o| o.center.z + (o.rot.row(2).abs() * o.half)[0])
                    .chain([0.0])
                    .collect();
                if rot[(2, 2)].abs() < 0.999 {
                    assert!(
                        sc.boxes
                            .iter()
                            .any(|b| b.obb != a.obb && a.obb.overlaps(&b.obb, 0.1)),
                        "{layout} scene {s}: tilted box leans on nothing"
                    );
                }
                assert!(
                    tops.iter().any(|t| (lowest - t).abs() < 0.1),
                    "{layout} scene {s}: box floating at z = {lowest} mm"
                );
            }
        }
    }
}
