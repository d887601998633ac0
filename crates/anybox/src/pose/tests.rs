//! End-to-end tests of `estimate_pose` on ray-cast scenes (a local renderer, independent of the
//! estimator: slab intersection of camera rays with oriented boxes and a floor plane).

use super::*;
use crate::observation::{observe, ObservationConfig};
use anybox_io::image::Mask;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) fn cam() -> Intrinsics {
    Intrinsics::new(600.0, 600.0, 320.0, 240.0).unwrap()
}

/// Ray parameter of the first hit of the ray `t · dir` (camera at the origin) with the box.
fn hit_box(b: &OrientedBox, dir: &Vector3<f64>) -> Option<f64> {
    let rt = b.rotation.matrix().transpose();
    let o = rt * (-b.center_mm);
    let d = rt * dir;
    let h = b.half_size_mm();
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for k in 0..3 {
        if d[k].abs() < 1e-15 {
            if o[k].abs() > h[k] {
                return None;
            }
            continue;
        }
        let a = (-h[k] - o[k]) / d[k];
        let c = (h[k] - o[k]) / d[k];
        t0 = t0.max(a.min(c));
        t1 = t1.min(a.max(c));
    }
    (t0 <= t1 && t0 > 0.0).then_some(t0)
}

/// Standard normal sample (Box–Muller).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let a: f64 = rng.random::<f64>().max(1e-300);
    let b: f64 = rng.random();
    (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
}

/// Renders boxes (plus an optional plane `n · p = d` behind them) into depth and per-box masks.
pub(crate) fn render(
    boxes: &[OrientedBox],
    plane: Option<(Vector3<f64>, f64)>,
    noise_mm: f64,
    seed: u64,
) -> (DepthMap, Vec<Mask>) {
    let k = cam();
    let (w, h) = (640u32, 480u32);
    let mut depth = DepthMap::zeros(w, h);
    let mut masks = vec![Mask::empty(w, h); boxes.len()];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for v in 0..h {
        for u in 0..w {
            let dir = k.ray(u as f64, v as f64);
            let mut best: Option<(f64, usize)> = None;
            for (i, b) in boxes.iter().enumerate() {
                if let Some(t) = hit_box(b, &dir) {
                    if best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, i));
                    }
                }
            }
            let mut z = best.map(|(t, _)| t);
            if let Some((n, d)) = plane {
                let den = n.dot(&dir);
                if den.abs() > 1e-12 {
                    let t = d / den;
                    if t > 0.0 && z.is_none_or(|zz| t < zz) {
                        z = Some(t);
                        best = None;
                    }
                }
            }
            if let Some(z) = z {
                let zn = if noise_mm > 0.0 {
                    z + noise_mm * gauss(&mut rng)
                } else {
                    z
                };
                depth.depth_mm[(v * w + u) as usize] = zn as f32;
            }
            if let Some((_, i)) = best {
                masks[i].set(u, v, true);
            }
        }
    }
    (depth, masks)
}

/// Rotation error modulo the 4 symmetries of a box with distinct sides, degrees.
pub(crate) fn rot_err_deg(a: &OrientedBox, b: &OrientedBox) -> f64 {
    let v = closest_variant(a, &b.rotation);
    angle_deg(&v.rotation, &b.rotation)
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
    let mut cfg = PoseConfig {
        coarse: CoarseScore::AllFaces,
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
