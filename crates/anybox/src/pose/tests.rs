//! End-to-end tests of `estimate_pose` on ray-cast scenes (the shared test renderer, independent
//! of the estimator: slab intersection of camera rays with oriented boxes and a floor plane).

use super::*;
use crate::observation::{observe, ObservationConfig};
use anybox_io::image::Mask;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) use crate::pipeline::test_scene::cam;

/// Renders boxes (plus an optional plane `n · p = d` behind them) into depth and per-box masks,
/// with the shared test renderer (`pipeline::test_scene`, its own slab ray caster).
pub(crate) fn render(
    boxes: &[OrientedBox],
    plane: Option<(Vector3<f64>, f64)>,
    noise_mm: f64,
    seed: u64,
) -> (DepthMap, Vec<Mask>) {
    use crate::pipeline::test_scene::{render_noisy, Plane};
    let planes: Vec<Plane> = plane.map(|(n, d)| Plane { n, d }).into_iter().collect();
    render_noisy(boxes, &planes, &cam(), 640, 480, noise_mm, seed)
}

/// Rotation error modulo the box's symmetries, degrees (GEOM's independent implementation).
pub(crate) fn rot_err_deg(a: &OrientedBox, b: &OrientedBox) -> f64 {
    anybox_geom::symmetry::rotation_error_deg(a, b)
}

/// Geodesic angle between two rotations, degrees (clamped: no NaN at exactly 0).
pub(crate) fn angle_deg(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let c = (((a.matrix().transpose() * b.matrix()).trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    c.acos().to_degrees()
}

/// A box resting on the floor-ish, seen obliquely so that three faces are visible.
pub(crate) fn oblique_box(yaw: f64, size: Vector3<f64>) -> OrientedBox {
    // Camera looks down at ~35°: rotate the box about its vertical axis, then tilt.
    let r = Rotation3::from_axis_angle(&Vector3::x_axis(), -0.6)
        * Rotation3::from_axis_angle(&Vector3::y_axis(), yaw);
    OrientedBox::new(r, Vector3::new(20.0, 30.0, 1100.0), size).unwrap()
}

fn run(truth: &OrientedBox, noise: f64, cfg: &PoseConfig) -> PoseEstimate {
    let (depth, masks) = render(&[*truth], None, noise, 7);
    let obs = observe(&depth, &cam(), &masks[0], &ObservationConfig::default()).unwrap();
    estimate_pose(&obs, &depth, &cam(), &truth.size_mm, None, cfg).unwrap()
}

#[test]
fn recovers_oblique_boxes_noiseless() {
    let sizes = [
        Vector3::new(300.0, 200.0, 120.0),
        Vector3::new(150.0, 400.0, 250.0),
        Vector3::new(220.0, 90.0, 330.0),
    ];
    for (i, s) in sizes.iter().enumerate() {
        for yaw in [0.4, 1.1, 2.3] {
            let truth = oblique_box(yaw + i as f64 * 0.2, *s);
            let est = run(&truth, 0.0, &PoseConfig::default());
            let re = rot_err_deg(&est.pose, &truth);
            let te = (est.pose.center_mm - truth.center_mm).norm();
            assert!(
                re < 2.0 && te < 3.0,
                "size {s:?} yaw {yaw}: rot {re:.2}° trans {te:.2} mm"
            );
            assert!(est.score > 0.5, "score {}", est.score);
        }
    }
}

#[test]
fn recovers_oblique_boxes_with_noise() {
    let truth = oblique_box(0.7, Vector3::new(300.0, 200.0, 120.0));
    let est = run(&truth, 2.0, &PoseConfig::default());
    let re = rot_err_deg(&est.pose, &truth);
    let te = (est.pose.center_mm - truth.center_mm).norm();
    assert!(re < 4.0 && te < 8.0, "rot {re:.2}° trans {te:.2} mm");
}

#[test]
fn prior_keeps_the_symmetric_variant_and_the_answer() {
    let truth = oblique_box(0.9, Vector3::new(260.0, 180.0, 140.0));
    let (depth, masks) = render(&[truth], None, 0.0, 1);
    let obs = observe(&depth, &cam(), &masks[0], &ObservationConfig::default()).unwrap();
    let mut prior = truth;
    prior.rotation = Rotation3::from_euler_angles(0.03, 0.02, -0.02) * truth.rotation;
    let est = estimate_pose(
        &obs,
        &depth,
        &cam(),
        &truth.size_mm,
        Some(&prior),
        &PoseConfig::default(),
    )
    .unwrap();
    // The returned rotation is the literal closest variant, not just equal modulo symmetry.
    let lit = angle_deg(&est.pose.rotation, &truth.rotation);
    assert!(lit < 2.0, "{lit}");
    assert!((est.pose.center_mm - truth.center_mm).norm() < 3.0);
}

#[test]
fn depth_filter_rejects_hovering_hypothesis() {
    // A box seen face-on in front of a wall; the "hovering" hypothesis is the same box moved
    // toward the camera by its depth extent: its hidden back face coincides with the observed
    // front face, so symmetric point matching (AllFaces) cannot tell them apart.
    let size = Vector3::new(200.0, 150.0, 100.0);
    let truth =
        OrientedBox::new(Rotation3::identity(), Vector3::new(0.0, 0.0, 1050.0), size).unwrap();
    let (depth, masks) = render(&[truth], Some((Vector3::z(), 1400.0)), 0.0, 0);
    let k = cam();
    let obs = observe(&depth, &k, &masks[0], &ObservationConfig::default()).unwrap();
    let mut hover = truth;
    hover.center_mm.z -= size.z;
    // The true hypothesis slightly off (1 mm) so that without the filter the hover wins.
    let mut near_truth = truth;
    near_truth.center_mm.z += 1.0;
    // Symmetric point matching without visibility reasoning and without pre-alignment: what a
    // learned matcher sees.
    let mut cfg = PoseConfig {
        coarse: CoarseScore::AllFaces,
        coarse_align_iters: 0,
        ..PoseConfig::default()
    };
    let ctx = ScoringContext::new(&obs, &depth, &k, &size, &cfg);
    let p_true = ctx.penalty(&near_truth, &cfg);
    let p_hover = ctx.penalty(&hover, &cfg);
    assert!(p_true < 0.05, "true penalty {p_true}");
    assert!(p_hover > 0.3, "hover penalty {p_hover}");
    let ranked = ctx.rank(&[hover, near_truth], &cfg);
    assert_eq!(ranked[0].pose, near_truth, "filter on: true pose first");
    cfg.depth_filter.enabled = false;
    let ranked = ctx.rank(&[hover, near_truth], &cfg);
    assert_eq!(
        ranked[0].pose, hover,
        "filter off: the hover wins on point distance alone"
    );
    // And the full estimator with the filter on returns the true placement.
    cfg.depth_filter.enabled = true;
    let est = estimate_pose(&obs, &depth, &k, &size, Some(&hover), &cfg).unwrap();
    assert!(
        (est.pose.center_mm - truth.center_mm).norm() < 3.0,
        "{:?}",
        est.pose.center_mm
    );
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let truth = oblique_box(0.5, Vector3::new(300.0, 200.0, 120.0));
    let (depth, masks) = render(&[truth], None, 0.0, 0);
    let k = cam();
    let oc = ObservationConfig::default();
    let obs = observe(&depth, &k, &masks[0], &oc).unwrap();
    let cfg = PoseConfig::default();
    for bad in [
        Vector3::new(0.0, 1.0, 1.0),
        Vector3::new(f64::NAN, 1.0, 1.0),
        Vector3::new(-5.0, 1.0, 1.0),
    ] {
        assert!(matches!(
            estimate_pose(&obs, &depth, &k, &bad, None, &cfg),
            Err(EstimateError::BadTemplateSize(_))
        ));
    }
    let small = DepthMap::zeros(10, 10);
    assert!(matches!(
        estimate_pose(&obs, &small, &k, &truth.size_mm, None, &cfg),
        Err(EstimateError::SizeMismatch { .. })
    ));
    // A NaN prior is ignored rather than poisoning the result.
    let mut nan_prior = truth;
    nan_prior.center_mm.x = f64::NAN;
    let est = estimate_pose(&obs, &depth, &k, &truth.size_mm, Some(&nan_prior), &cfg).unwrap();
    assert!(est.pose.center_mm.iter().all(|v| v.is_finite()));
    // Bad masks through observe.
    assert_eq!(
        observe(&depth, &k, &Mask::empty(640, 480), &oc).unwrap_err(),
        EstimateError::EmptyMask
    );
    let mut three = Mask::empty(640, 480);
    let (u, v) = (320, 240);
    for i in 0..3 {
        three.set(u + i, v, true);
    }
    assert!(matches!(
        observe(&depth, &k, &three, &oc),
        Err(EstimateError::TooFewPoints { .. })
    ));
    assert!(matches!(
        observe(&depth, &k, &Mask::empty(320, 480), &oc),
        Err(EstimateError::SizeMismatch { .. })
    ));
    assert!(matches!(
        observe(&DepthMap::zeros(640, 480), &k, &masks[0], &oc),
        Err(EstimateError::TooFewPoints { valid: 0, .. })
    ));
}

/// Rotation error modulo all 24 axis relabelings, degrees (for wrong-size templates, where the
/// axis assignment is the scale loop's business).
fn frame_err_deg(a: &OrientedBox, b: &OrientedBox) -> f64 {
    crate::hypotheses::frame_distance_deg(a.rotation.matrix(), b.rotation.matrix())
}

/// Report (not a pass/fail test): behaviour with wrong template sizes and release timing.
/// `cargo test -p anybox --release --lib pose::tests::report_wrong_sizes_and_timing -- --ignored --nocapture`
#[test]
#[ignore]
fn report_wrong_sizes_and_timing() {
    let k = cam();
    let oc = ObservationConfig::default();
    let cfg = PoseConfig::default();
    let mut worst = 0.0f64;
    for (i, yaw) in [0.3, 0.8, 1.3, 2.0].iter().enumerate() {
        let truth = oblique_box(*yaw, Vector3::new(260.0, 170.0, 120.0 + 20.0 * i as f64));
        let (depth, masks) = render(
            &[truth],
            Some((Vector3::new(0.0, -0.5, 1.0).normalize(), 1300.0)),
            1.0,
            3,
        );
        let obs = observe(&depth, &k, &masks[0], &oc).unwrap();
        for f in [
            [0.5, 0.5, 0.5],
            [0.75, 1.0, 1.25],
            [1.0, 1.0, 1.0],
            [1.5, 1.2, 0.8],
            [2.0, 2.0, 2.0],
        ] {
            let s = truth.size_mm.component_mul(&Vector3::from(f));
            let t0 = std::time::Instant::now();
            let n = 20;
            let mut est = None;
            for _ in 0..n {
                est = Some(estimate_pose(&obs, &depth, &k, &s, None, &cfg).unwrap());
            }
            let dt = t0.elapsed().as_secs_f64() / n as f64;
            let est = est.unwrap();
            let t1 = std::time::Instant::now();
            let with_prior = estimate_pose(&obs, &depth, &k, &s, Some(&est.pose), &cfg).unwrap();
            let dtp = t1.elapsed().as_secs_f64();
            let fe = frame_err_deg(&est.pose, &truth);
            worst = worst.max(fe);
            println!(
                "yaw {yaw:.1} f {f:?}: frame err {fe:.2}°, centre err {:.1} mm, score {:.3} iou {:.3} inl {:.3} pen {:.3} nh {} | {:.3} ms, with prior {:.3} ms (frame err {:.2}°), pts {}",
                (est.pose.center_mm - truth.center_mm).norm(),
                est.score, est.silhouette_iou, est.inlier_fraction, est.depth_penalty, est.n_hypotheses,
                dt * 1e3, dtp * 1e3, frame_err_deg(&with_prior.pose, &truth), obs.points_mm.len()
            );
        }
    }
    println!("worst frame error {worst:.2}°");
    let truth = oblique_box(0.8, Vector3::new(260.0, 170.0, 120.0));
    let (depth, masks) = render(&[truth], None, 1.0, 3);
    let t0 = std::time::Instant::now();
    for _ in 0..20 {
        observe(&depth, &k, &masks[0], &oc).unwrap();
    }
    println!("observe: {:.3} ms", t0.elapsed().as_secs_f64() / 20.0 * 1e3);
}

/// CPU time of the calling thread, ns (Linux schedstat; 0 elsewhere). Wall time on a loaded
/// 2-core machine is meaningless, CPU time much less so.
fn thread_cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|t| t.parse().ok()))
        .unwrap_or(0)
}

/// Stage timings (report only).
#[test]
#[ignore]
fn report_stage_timing() {
    let k = cam();
    let oc = ObservationConfig::default();
    let cfg = PoseConfig::default();
    let truth = oblique_box(0.8, Vector3::new(260.0, 170.0, 120.0));
    let (depth, masks) = render(&[truth], None, 1.0, 3);
    let obs = observe(&depth, &k, &masks[0], &oc).unwrap();
    let n = 50;
    let time = |name: &str, f: &mut dyn FnMut()| {
        let t0 = std::time::Instant::now();
        let c0 = thread_cpu_ns();
        for _ in 0..n {
            f();
        }
        let cpu = (thread_cpu_ns() - c0) as f64 / n as f64 / 1e3;
        println!(
            "{name}: {:.1} µs wall, {cpu:.1} µs thread CPU",
            t0.elapsed().as_secs_f64() / n as f64 * 1e6
        );
    };
    time("observe", &mut || {
        observe(&depth, &k, &masks[0], &oc).unwrap();
    });
    time("frames", &mut || {
        crate::hypotheses::candidate_frames(&obs, &cfg.hypotheses);
    });
    let frames = crate::hypotheses::candidate_frames(&obs, &cfg.hypotheses);
    time("generate", &mut || {
        generate(&obs, &frames, &truth.size_mm, None, &cfg.hypotheses);
    });
    let hyps = generate(&obs, &frames, &truth.size_mm, None, &cfg.hypotheses);
    time("context", &mut || {
        ScoringContext::new(&obs, &depth, &k, &truth.size_mm, &cfg);
    });
    let ctx = ScoringContext::new(&obs, &depth, &k, &truth.size_mm, &cfg);
    time("rank", &mut || {
        ctx.rank(&hyps, &cfg);
    });
    let pts: Vec<Point3<f64>> = obs.subsample.iter().map(|&i| obs.points_mm[i]).collect();
    time("refine x1", &mut || {
        refine_pose(&hyps[0], &pts, &cfg.refine);
    });
    time("iou x1", &mut || {
        ctx.silhouette_iou(&hyps[0]);
    });
    time("estimate_pose", &mut || {
        estimate_pose(&obs, &depth, &k, &truth.size_mm, None, &cfg).unwrap();
    });
    let first = estimate_pose(&obs, &depth, &k, &truth.size_mm, None, &cfg).unwrap();
    let bigger = truth.size_mm * 1.2;
    time("estimate_pose with prior (size +20 %)", &mut || {
        estimate_pose(&obs, &depth, &k, &bigger, Some(&first.pose), &cfg).unwrap();
    });
    let full = crate::config::Config::default();
    time(
        "pipeline::estimate_box (whole loop, default config)",
        &mut || {
            crate::pipeline::estimate_box(&depth, &k, &masks[0], &full).unwrap();
        },
    );
    let e = crate::pipeline::estimate_box(&depth, &k, &masks[0], &full).unwrap();
    println!("  pose calls {}, iterations {}", e.pose_calls, e.iterations);
}

/// Profiling target: observe only (report only).
#[test]
#[ignore]
fn profile_observe() {
    let k = cam();
    let oc = ObservationConfig::default();
    let truth = oblique_box(0.8, Vector3::new(260.0, 170.0, 120.0));
    let (depth, masks) = render(&[truth], None, 1.0, 3);
    let c0 = thread_cpu_ns();
    for _ in 0..300 {
        observe(&depth, &k, &masks[0], &oc).unwrap();
    }
    println!(
        "observe {:.1} µs CPU",
        (thread_cpu_ns() - c0) as f64 / 300.0 / 1e3
    );
}

/// A box on a table seen from `pitch_deg` above the horizon (same geometry as the pipeline's
/// table test), with the table plane.
fn table_box(
    size: Vector3<f64>,
    yaw: f64,
    pitch_deg: f64,
    dist_mm: f64,
) -> (OrientedBox, (Vector3<f64>, f64)) {
    let p = pitch_deg.to_radians();
    let up = Vector3::new(0.0, -p.cos(), -p.sin());
    let hit = Vector3::new(0.0, 0.0, dist_mm);
    let fwd = (Vector3::z() - up * up.dot(&Vector3::z())).normalize();
    let right = fwd.cross(&up).normalize();
    let bx = right * yaw.cos() + fwd * yaw.sin();
    let by = up.cross(&bx);
    let rot = Rotation3::from_basis_unchecked(&[bx, by, up]);
    let center = hit + up * (size.z / 2.0);
    (
        OrientedBox::new(rot, center, size).unwrap(),
        (up, up.dot(&hit)),
    )
}

/// Diagnostic (report only): wrong-size templates on a table scene.
#[test]
#[ignore]
fn report_table_scene() {
    let k = cam();
    let size = Vector3::new(240.0, 160.0, 110.0);
    for (yaw, pitch) in [(0.5, 40.0), (1.0, 30.0), (0.3, 60.0), (0.3, 90.0)] {
        let (gt, plane) = table_box(size, yaw, pitch, 900.0);
        let (depth, masks) = render(&[gt], Some(plane), 0.0, 0);
        let obs = observe(&depth, &k, &masks[0], &ObservationConfig::default()).unwrap();
        let mut prior: Option<OrientedBox> = None;
        for s in [
            Vector3::new(300.0, 200.0, 150.0),
            Vector3::new(150.0, 100.0, 75.0),
            Vector3::new(225.0, 150.0, 112.0),
            Vector3::new(262.0, 175.0, 131.0),
            size,
        ] {
            let e = estimate_pose(&obs, &depth, &k, &s, prior.as_ref(), &PoseConfig::default())
                .unwrap();
            // Which template axis went to which true axis?
            let assign: Vec<usize> = (0..3)
                .map(|a| {
                    (0..3)
                        .max_by(|&i, &j| {
                            e.pose
                                .axis(a)
                                .dot(&gt.axis(i))
                                .abs()
                                .total_cmp(&e.pose.axis(a).dot(&gt.axis(j)).abs())
                        })
                        .unwrap()
                })
                .collect();
            println!(
                "yaw {yaw} pitch {pitch} size {:?}: frame err {:.2}° assign {assign:?} centre err {:.1} score {:.3} iou {:.3} inl {:.3} pen {:.3}",
                s.as_slice(), frame_err_deg(&e.pose, &gt), (e.pose.center_mm - gt.center_mm).norm(), e.score, e.silhouette_iou, e.inlier_fraction, e.depth_penalty
            );
            prior = Some(e.pose);
        }
    }
}

/// Per-box errors of `estimate_pose` with the true size on synthetic views:
/// `(layout, visib, rot_err_deg, centre_err_mm, score)`.
fn synth_errors(
    noise: anybox_synth::NoiseModel,
    layout: anybox_synth::Layout,
    views: u32,
    cfg: &PoseConfig,
) -> Vec<(String, f64, f64, f64, f64)> {
    let sc = anybox_synth::SynthConfig {
        layout,
        noise,
        scenes: views,
        views: 1,
        ..Default::default()
    };
    let mut out = Vec::new();
    for s in 0..views {
        let v = anybox_synth::generate_view(&sc, s, 0);
        for b in &v.boxes {
            if b.visib_fract < 0.5 || b.px_count_valid < 400 {
                continue;
            }
            let Ok(obs) = observe(
                &v.depth,
                &v.intrinsics,
                &b.mask_visib,
                &ObservationConfig::default(),
            ) else {
                continue;
            };
            let e =
                estimate_pose(&obs, &v.depth, &v.intrinsics, &b.pose.size_mm, None, cfg).unwrap();
            out.push((
                format!("{:?}", v.layout),
                b.visib_fract,
                anybox_geom::symmetry::rotation_error_deg(&e.pose, &b.pose),
                (e.pose.center_mm - b.pose.center_mm).norm(),
                e.score,
            ));
        }
    }
    out
}

/// Diagnostic (report only): synthetic scenes, true size.
#[test]
#[ignore]
fn report_synth() {
    use anybox_synth::{Layout, NoiseModel};
    for noise in [NoiseModel::None, NoiseModel::Realistic] {
        for layout in [Layout::Pallet, Layout::Table, Layout::Shelf] {
            let e = synth_errors(noise, layout, 3, &PoseConfig::default());
            let n = e.len();
            let ok = e.iter().filter(|x| x.2 < 5.0 && x.3 < 10.0).count();
            let mut r: Vec<f64> = e.iter().map(|x| x.2).collect();
            let mut t: Vec<f64> = e.iter().map(|x| x.3).collect();
            r.sort_by(f64::total_cmp);
            t.sort_by(f64::total_cmp);
            println!(
                "{noise:?} {layout:?}: n {n}, within 5°/10 mm {ok}, median rot {:.2}° trans {:.1} mm, p90 rot {:.1}° trans {:.1} mm",
                r.get(n / 2).unwrap_or(&0.0), t.get(n / 2).unwrap_or(&0.0), r.get(n * 9 / 10).unwrap_or(&0.0), t.get(n * 9 / 10).unwrap_or(&0.0)
            );
            for x in e.iter().filter(|x| x.2 >= 5.0 || x.3 >= 10.0) {
                println!(
                    "   bad: visib {:.2} rot {:.1}° trans {:.1} mm score {:.3}",
                    x.1, x.2, x.3, x.4
                );
            }
        }
    }
}

/// Diagnostic (report only): generation vs ranking failures on noisy pallets.
#[test]
#[ignore]
fn report_synth_diagnose() {
    use anybox_synth::{Layout, NoiseModel};
    let cfg = PoseConfig::default();
    let layout = match std::env::var("LAYOUT").as_deref() {
        Ok("shelf") => Layout::Shelf,
        Ok("table") => Layout::Table,
        _ => Layout::Pallet,
    };
    let sc = anybox_synth::SynthConfig {
        layout,
        noise: NoiseModel::Realistic,
        scenes: 3,
        views: 1,
        ..Default::default()
    };
    for s in 0..3 {
        let v = anybox_synth::generate_view(&sc, s, 0);
        for b in &v.boxes {
            if b.visib_fract < 0.5 || b.px_count_valid < 400 {
                continue;
            }
            let Ok(obs) = observe(
                &v.depth,
                &v.intrinsics,
                &b.mask_visib,
                &ObservationConfig::default(),
            ) else {
                continue;
            };
            let k = v.intrinsics;
            let e = estimate_pose(&obs, &v.depth, &k, &b.pose.size_mm, None, &cfg).unwrap();
            let frames = crate::hypotheses::candidate_frames(&obs, &cfg.hypotheses);
            let best_frame = frames
                .iter()
                .map(|f| crate::hypotheses::frame_distance_deg(f, b.pose.rotation.matrix()))
                .fold(f64::INFINITY, f64::min);
            let ctx = ScoringContext::new(&obs, &v.depth, &k, &b.pose.size_mm, &cfg);
            let pts: Vec<Point3<f64>> = obs.subsample.iter().map(|&i| obs.points_mm[i]).collect();
            let (inl, _) = crate::refine::inlier_stats(&b.pose, &pts, &cfg.refine);
            let gt_score = inl * ctx.silhouette_iou(&b.pose) * (1.0 - ctx.penalty(&b.pose, &cfg));
            let planes = crate::hypotheses::face_planes(&obs, &cfg.hypotheses);
            println!(
                "z {:.0} visib {:.2} pts {}: rot {:.1}° trans {:.1} | best frame {:.1}° of {} ({} planes {:?}) | score est {:.3} (inl {:.2} iou {:.2} pen {:.2}) gt {:.3} (inl {:.2} iou {:.2} pen {:.2})",
                b.pose.center_mm.z, b.visib_fract, obs.points_mm.len(),
                anybox_geom::symmetry::rotation_error_deg(&e.pose, &b.pose),
                (e.pose.center_mm - b.pose.center_mm).norm(), best_frame, frames.len(), planes.len(),
                planes.iter().map(|p| p.inliers.len()).collect::<Vec<_>>(),
                e.score, e.inlier_fraction, e.silhouette_iou, e.depth_penalty,
                gt_score, inl, ctx.silhouette_iou(&b.pose), ctx.penalty(&b.pose, &cfg)
            );
        }
    }
}

#[test]
fn synthetic_scenes_end_to_end_with_true_size() {
    use anybox_synth::{Layout, NoiseModel};
    let cfg = PoseConfig::default();
    // Noiseless, well-visible boxes: the strict bounds of the task.
    let mut n = 0;
    for layout in [Layout::Table, Layout::Pallet] {
        let sc = anybox_synth::SynthConfig {
            layout,
            noise: NoiseModel::None,
            scenes: 2,
            views: 1,
            ..Default::default()
        };
        for s in 0..2 {
            let v = anybox_synth::generate_view(&sc, s, 0);
            for b in v
                .boxes
                .iter()
                .filter(|b| b.visib_fract >= 0.9 && b.px_count_valid >= 1000)
            {
                let obs = observe(
                    &v.depth,
                    &v.intrinsics,
                    &b.mask_visib,
                    &ObservationConfig::default(),
                )
                .unwrap();
                let e = estimate_pose(&obs, &v.depth, &v.intrinsics, &b.pose.size_mm, None, &cfg)
                    .unwrap();
                let re = anybox_geom::symmetry::rotation_error_deg(&e.pose, &b.pose);
                let te = (e.pose.center_mm - b.pose.center_mm).norm();
                assert!(
                    re < 2.0 && te < 3.0,
                    "{layout:?} scene {s}: rot {re:.2}° trans {te:.2} mm"
                );
                n += 1;
            }
        }
    }
    assert!(n >= 5, "only {n} boxes checked");
    // Realistic sensor noise (RealSense-like σ ≈ 4 mm at 1 m, ≈ 17 mm at 2 m): medians.
    let e = synth_errors(NoiseModel::Realistic, Layout::Table, 2, &cfg);
    assert!(e.len() >= 5);
    let mut r: Vec<f64> = e.iter().map(|x| x.2).collect();
    let mut t: Vec<f64> = e.iter().map(|x| x.3).collect();
    r.sort_by(f64::total_cmp);
    t.sort_by(f64::total_cmp);
    assert!(
        r[r.len() / 2] < 3.0 && t[t.len() / 2] < 6.0,
        "median rot {} trans {}",
        r[r.len() / 2],
        t[t.len() / 2]
    );
}

#[test]
fn wrong_template_sizes_keep_the_rotation() {
    // Inside the scale loop the template is wrong: the frame (rotation modulo axis relabeling)
    // must still be right, and the camera-facing corner must stay on the observed one.
    let truth = oblique_box(0.8, Vector3::new(260.0, 170.0, 120.0));
    let (depth, masks) = render(&[truth], None, 0.0, 0);
    let obs = observe(&depth, &cam(), &masks[0], &ObservationConfig::default()).unwrap();
    let nearest = |b: &OrientedBox| {
        b.corners_mm()
            .into_iter()
            .min_by(|a, c| a.coords.norm().total_cmp(&c.coords.norm()))
            .unwrap()
    };
    for f in [0.8, 1.25] {
        let s = truth.size_mm * f;
        let e = estimate_pose(&obs, &depth, &cam(), &s, None, &PoseConfig::default()).unwrap();
        let fe = frame_err_deg(&e.pose, &truth);
        assert!(fe < 2.0, "factor {f}: frame error {fe:.2}°");
        if f > 1.0 {
            // A too-large box keeps all points on its visible faces: its nearest corner is the
            // observed one.
            let d = (nearest(&e.pose) - nearest(&truth)).norm();
            assert!(d < 5.0, "factor {f}: nearest corner off by {d:.1} mm");
        }
    }
}

/// Report (needs the shared real data): `estimate_pose` with the true size and the BOP visible
/// masks on the ycbv-boxes frames.
/// `cargo test -p anybox --release --lib pose::tests::report_ycbv_boxes -- --ignored --nocapture`
#[test]
#[ignore]
fn report_ycbv_boxes() {
    let root = std::path::Path::new("/work/shared/data/ycbv-boxes");
    let ds = anybox_io::bop::BopDataset::open(root, "test").unwrap();
    let cfg = PoseConfig::default();
    for v in &ds.views {
        let frame = v.load_frame().unwrap();
        for g in &v.gts {
            let mask = v.load_mask_visib(g.gt_index).unwrap();
            let obs = match observe(
                &frame.depth,
                &frame.intrinsics,
                &mask,
                &ObservationConfig::default(),
            ) {
                Ok(o) => o,
                Err(e) => {
                    println!("im {} obj {}: {e}", v.im_id, g.obj_id);
                    continue;
                }
            };
            let c0 = thread_cpu_ns();
            let e = estimate_pose(
                &obs,
                &frame.depth,
                &frame.intrinsics,
                &g.pose.size_mm,
                None,
                &cfg,
            )
            .unwrap();
            let cpu = (thread_cpu_ns() - c0) as f64 / 1e6;
            println!(
                "im {} obj {} visib {:.2} pts {}: rot {:.1}° trans {:.1} mm (z {:.0}) score {:.3} iou {:.2} inl {:.2} pen {:.2} [{cpu:.1} ms CPU]",
                v.im_id, g.obj_id, g.visib_fract, obs.points_mm.len(),
                anybox_geom::symmetry::rotation_error_deg(&e.pose, &g.pose),
                (e.pose.center_mm - g.pose.center_mm).norm(), g.pose.center_mm.z,
                e.score, e.silhouette_iou, e.inlier_fraction, e.depth_penalty
            );
        }
    }
}

#[test]
fn garbage_inputs_never_panic() {
    // Random masks over random depth with hostile values: every call returns Ok or Err.
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let k = Intrinsics::new(300.0, 300.0, 40.0, 30.0).unwrap();
    let hostile = [
        0.0f32,
        -5.0,
        f32::NAN,
        f32::INFINITY,
        1e30,
        1e-30,
        500.0,
        501.0,
        3000.0,
    ];
    let (mut observed, mut estimated) = (0, 0);
    for trial in 0..60 {
        let (w, h) = (80u32, 60u32);
        let mut depth = DepthMap::zeros(w, h);
        let mut mask = Mask::empty(w, h);
        let density: f64 = rng.random();
        for i in 0..(w * h) as usize {
            depth.depth_mm[i] = if rng.random::<f64>() < 0.2 {
                hostile[rng.random_range(0..hostile.len())]
            } else {
                400.0 + 200.0 * rng.random::<f32>()
            };
            mask.data[i] = rng.random::<f64>() < density;
        }
        let Ok(obs) = observe(&depth, &k, &mask, &ObservationConfig::default()) else {
            continue;
        };
        observed += 1;
        let sizes = [
            Vector3::new(100.0, 50.0, 30.0),
            Vector3::new(1e-6, 1e-6, 1e-6),
            Vector3::new(1e12, 1.0, 1.0),
        ];
        let s = sizes[trial % sizes.len()];
        if let Ok(e) = estimate_pose(&obs, &depth, &k, &s, None, &PoseConfig::default()) {
            assert!((0.0..=1.0).contains(&e.score), "score {}", e.score);
            estimated += 1;
            let _ = estimate_pose(&obs, &depth, &k, &s, Some(&e.pose), &PoseConfig::default());
        }
    }
    // The loop must actually reach the estimator, not just bounce off observe.
    assert!(
        observed >= 20 && estimated >= 10,
        "{observed} observed, {estimated} estimated"
    );
}

/// Report: the SCALE pipeline on synthetic scenes with variants of the pose config (median
/// IoU of the final boxes), to see which pose-stage choices help the whole loop.
#[test]
#[ignore]
fn report_pipeline_pose_variants() {
    use anybox_synth::{generate_view, SynthConfig};
    let scfg = SynthConfig {
        scenes: 8,
        views: 1,
        ..Default::default()
    };
    let views: Vec<_> = (0..scfg.scenes)
        .map(|s| generate_view(&scfg, s, 0))
        .collect();
    let base = crate::config::Config::default();
    let mut variants: Vec<(&str, crate::config::Config)> =
        vec![("oracle size", base.clone()), ("default", base.clone())];
    let mut c = base.clone();
    c.pose.hypotheses.prior_restricts = false;
    variants.push(("no prior restriction", c));
    let paper = crate::config::Config::paper();
    variants.push(("paper (Alg. 1+2)", paper.clone()));
    let mut c = paper.clone();
    c.pose.depth_filter.enabled = false;
    variants.push(("paper, no depth filter", c));
    let mut c = paper.clone();
    c.pose.hypotheses.prior_restricts = false;
    variants.push(("paper, no prior restriction", c));
    let mut c = base.clone();
    c.pose.depth_filter.enabled = false;
    variants.push(("default, no depth filter", c));
    let mut c = base.clone();
    c.pose.size_agreement_weight = 0.0;
    variants.push(("no size agreement", c));
    let mut c = base.clone();
    c.pose.variant_cos = 0.0;
    variants.push(("no placement variants", c));
    let mut c = base.clone();
    c.pose.coarse_align_iters = 0;
    variants.push(("no pre-alignment", c));
    let mut c = base.clone();
    c.pose.noise_scale = 0.0;
    variants.push(("no noise adaptation", c));
    for (name, cfg) in &variants {
        let mut all = Vec::new();
        let c0 = thread_cpu_ns();
        let mut n = 0;
        for v in &views {
            for b in v.boxes.iter().filter(|b| b.visib_fract >= 0.5) {
                let cfg = if *name == "oracle size" {
                    &cfg.clone()
                        .oracle([b.pose.size_mm.x, b.pose.size_mm.y, b.pose.size_mm.z])
                } else {
                    cfg
                };
                let i = crate::pipeline::estimate_box(&v.depth, &v.intrinsics, &b.mask_visib, cfg)
                    .map(|e| {
                        anybox_geom::iou::iou(&e.pose, &b.pose, anybox_geom::iou::IouMethod::Exact)
                    })
                    .unwrap_or(0.0);
                all.push(i);
                n += 1;
            }
        }
        let cpu = (thread_cpu_ns() - c0) as f64 / 1e6 / n as f64;
        all.sort_by(f64::total_cmp);
        println!(
            "{name}: n {n}, median IoU {:.3}, share > 0.5 {:.2}, {cpu:.1} ms CPU/box",
            all[all.len() / 2],
            all.iter().filter(|x| **x > 0.5).count() as f64 / n as f64
        );
    }
}

/// Report: frame error (rotation modulo axis relabeling) of the first, prior-free call with the
/// canonical template on synthetic scenes — what the scale loop starts from.
#[test]
#[ignore]
fn report_canonical_first_call() {
    use anybox_synth::{generate_view, SynthConfig};
    let scfg = SynthConfig {
        scenes: 8,
        views: 1,
        ..Default::default()
    };
    let cfg = PoseConfig::default();
    let t = Vector3::new(300.0, 200.0, 150.0);
    let mut errs = Vec::new();
    for s in 0..scfg.scenes {
        let v = generate_view(&scfg, s, 0);
        for b in v.boxes.iter().filter(|b| b.visib_fract >= 0.5) {
            let Ok(obs) = observe(
                &v.depth,
                &v.intrinsics,
                &b.mask_visib,
                &ObservationConfig::default(),
            ) else {
                continue;
            };
            let e = estimate_pose(&obs, &v.depth, &v.intrinsics, &t, None, &cfg).unwrap();
            let fe = frame_err_deg(&e.pose, &b.pose);
            let fr = frame_err_deg(
                &estimate_pose(&obs, &v.depth, &v.intrinsics, &b.pose.size_mm, None, &cfg)
                    .unwrap()
                    .pose,
                &b.pose,
            );
            println!("scene {s} {:?} size {:?} visib {:.2}: canonical frame err {fe:.1}°, true-size frame err {fr:.1}°", v.layout, b.pose.size_mm.as_slice(), b.visib_fract);
            errs.push(fe);
        }
    }
    errs.sort_by(f64::total_cmp);
    println!(
        "median {:.2}°, p90 {:.2}°",
        errs[errs.len() / 2],
        errs[errs.len() * 9 / 10]
    );
}

/// Debug helper (report only): one box through the pipeline with per-call pose logging.
#[test]
#[ignore]
fn report_pipeline_one_box() {
    use anybox_synth::{generate_view, SynthConfig};
    let scfg = SynthConfig {
        scenes: 8,
        views: 1,
        ..Default::default()
    };
    let s: u32 = std::env::var("SCENE")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(1);
    let v = generate_view(&scfg, s, 0);
    let cfg = crate::config::Config::default();
    for b in v.boxes.iter().filter(|b| b.visib_fract >= 0.5) {
        let e =
            crate::pipeline::estimate_box(&v.depth, &v.intrinsics, &b.mask_visib, &cfg).unwrap();
        println!(
            "gt size {:?} est size {:?} iou {:.3} rot err {:.1}° centre err {:.1} calls {}",
            b.pose.size_mm.as_slice(),
            e.pose.size_mm.as_slice(),
            anybox_geom::iou::iou(&e.pose, &b.pose, anybox_geom::iou::IouMethod::Exact),
            anybox_geom::symmetry::rotation_error_deg(&e.pose, &b.pose),
            (e.pose.center_mm - b.pose.center_mm).norm(),
            e.pose_calls
        );
    }
}

#[test]
fn silhouette_iou_matches_brute_force_rasterisation() {
    // A box in front of a far wall, partly hidden by a nearer box: the occluder's pixels are
    // "explained" (left out of the union), the wall's are disagreement.
    let size = Vector3::new(200.0, 150.0, 100.0);
    let truth = OrientedBox::new(
        Rotation3::from_euler_angles(0.2, -0.3, 0.1),
        Vector3::new(0.0, 0.0, 1100.0),
        size,
    )
    .unwrap();
    let occluder = OrientedBox::new(
        Rotation3::identity(),
        Vector3::new(-90.0, 0.0, 800.0),
        Vector3::new(80.0, 300.0, 50.0),
    )
    .unwrap();
    let k = cam();
    let (depth, masks) = render(&[truth, occluder], Some((Vector3::z(), 1600.0)), 0.0, 0);
    let obs = observe(&depth, &k, &masks[0], &ObservationConfig::default()).unwrap();
    for (i, pose) in [
        truth,
        OrientedBox {
            center_mm: truth.center_mm + Vector3::new(25.0, -10.0, 5.0),
            ..truth
        },
        OrientedBox {
            size_mm: size * 1.3,
            ..truth
        },
    ]
    .iter()
    .enumerate()
    {
        let hull = anybox_geom::projection::silhouette_hull_px(pose, &k).unwrap();
        let fill = anybox_geom::projection::rasterize_convex_polygon(&hull, 640, 480);
        let (mut inter, mut union) = (0usize, 0usize);
        for (j, (&h, &m)) in fill.iter().zip(&masks[0].data).enumerate() {
            let occluded = depth.depth_mm[j] < 1000.0; // only the occluder is this near
            inter += (h && m) as usize;
            union += (m || (h && !occluded)) as usize;
        }
        let brute = inter as f64 / union as f64;
        let ours = silhouette_iou(pose, &obs, &k);
        assert!((ours - brute).abs() < 1e-12, "case {i}: {ours} vs {brute}");
        if i == 0 {
            assert!(ours > 0.999, "the true box explains the mask: {ours}");
        }
    }
}
