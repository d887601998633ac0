//! Cross-check of `evaluate` against a direct transcription of NOCS's `compute_3d_matches`,
//! `compute_match_from_degree_cm` and `compute_ap_from_matches_scores` (notes §1.1), run over
//! the whole set at once (no caching, no scopes), on random cluttered images.

use anybox_eval::{evaluate, EstEntry, EvalOptions, GtEntry, IouMethod};
use anybox_geom::iou::iou;
use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::symmetry::rotation_error_deg;
use anybox_geom::OrientedBox;

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `compute_ap_from_matches_scores`: `matched[i]` for predictions already in score order.
fn nocs_ap(matched: &[bool], n_gt: usize) -> f64 {
    let mut prec = vec![0.0];
    let mut rec = vec![0.0];
    let mut tp = 0.0;
    for (i, m) in matched.iter().enumerate() {
        if *m {
            tp += 1.0;
        }
        prec.push(tp / (i as f64 + 1.0));
        rec.push(tp / n_gt as f64);
    }
    prec.push(0.0);
    rec.push(1.0);
    for i in (0..prec.len() - 1).rev() {
        prec[i] = f64::max(prec[i], prec[i + 1]);
    }
    let mut ap = 0.0;
    for i in 0..rec.len() - 1 {
        if rec[i] != rec[i + 1] {
            ap += (rec[i + 1] - rec[i]) * prec[i + 1];
        }
    }
    ap
}

type Image = (Vec<OrientedBox>, Vec<(f64, OrientedBox)>);

fn make_images(seed: u64, n_images: usize) -> Vec<Image> {
    let mut r = Lcg(seed);
    let mut out = Vec::new();
    for _ in 0..n_images {
        let n_gt = 1 + (r.next() * 6.0) as usize;
        let mut gts = Vec::new();
        for i in 0..n_gt {
            let c = Vector3::new(i as f64 * 150.0 + r.next() * 40.0, r.next() * 60.0, 900.0);
            let s = Vector3::new(
                80.0 + r.next() * 150.0,
                80.0 + r.next() * 150.0,
                60.0 + r.next() * 120.0,
            );
            let rot = Rotation3::from_euler_angles(r.next(), r.next(), r.next() * 6.0);
            gts.push(OrientedBox::new(rot, c, s).unwrap());
        }
        let mut ests = Vec::new();
        for g in &gts {
            // 0, 1 or 2 estimates per GT, of varying quality.
            let k = (r.next() * 3.0) as usize;
            for _ in 0..k {
                let mut e = *g;
                let q = r.next();
                e.center_mm +=
                    Vector3::new(r.next() - 0.5, r.next() - 0.5, r.next() - 0.5) * 120.0 * q;
                e.rotation *= Rotation3::from_euler_angles(
                    q * (r.next() - 0.5),
                    q * (r.next() - 0.5),
                    q * (r.next() - 0.5),
                );
                e.size_mm += Vector3::new(r.next(), r.next(), r.next()) * 40.0 * q;
                // Scores on a coarse grid, so that ties across images happen.
                ests.push(((r.next() * 10.0).floor() / 10.0, e));
            }
        }
        // A false positive now and then.
        if r.next() < 0.3 {
            let mut e = gts[0];
            e.center_mm.z += 1500.0;
            ests.push(((r.next() * 10.0).floor() / 10.0, e));
        }
        out.push((gts, ests));
    }
    out
}

/// Flattens to evaluator entries (one scene, im_id = image index) and the global rank of
/// every estimate (score desc, input order asc) that the transcription uses.
fn entries(images: &[Image]) -> (Vec<GtEntry>, Vec<EstEntry>) {
    let mut gts = Vec::new();
    let mut ests = Vec::new();
    for (im, (g, e)) in images.iter().enumerate() {
        for (i, p) in g.iter().enumerate() {
            gts.push(GtEntry {
                scene_id: 0,
                im_id: im as u32,
                gt_index: i,
                pose: *p,
                visib_fract: 1.0,
                observed_dims: None,
            });
        }
        for (s, p) in e {
            ests.push(EstEntry {
                scene_id: 0,
                im_id: im as u32,
                score: *s,
                pose: *p,
                gt_index: None,
            });
        }
    }
    (gts, ests)
}

/// Per image: estimate indices (into the flattened list) in score order, stable.
fn ranked(images: &[Image]) -> Vec<Vec<usize>> {
    let mut base = 0;
    let mut out = Vec::new();
    for (_, e) in images {
        let mut idx: Vec<usize> = (0..e.len()).collect();
        idx.sort_by(|&a, &b| e[b].0.partial_cmp(&e[a].0).unwrap().then(a.cmp(&b)));
        out.push(idx.iter().map(|i| base + i).collect());
        base += e.len();
    }
    out
}

/// Global AP from per-estimate TP flags (indexed by the flattened estimate list).
fn global_ap(ests: &[EstEntry], tp: &[bool], n_gt: usize) -> f64 {
    let mut order: Vec<usize> = (0..ests.len()).collect();
    order.sort_by(|&a, &b| {
        ests[b]
            .score
            .partial_cmp(&ests[a].score)
            .unwrap()
            .then(a.cmp(&b))
    });
    let m: Vec<bool> = order.iter().map(|&i| tp[i]).collect();
    nocs_ap(&m, n_gt)
}

/// NOCS `compute_3d_matches` per image: TP flag per estimate, matched flag per GT (per image).
fn iou_matches(
    images: &[Image],
    ests: &[EstEntry],
    rank: &[Vec<usize>],
    method: IouMethod,
    thr: f64,
) -> (Vec<bool>, Vec<Vec<bool>>) {
    let mut tp = vec![false; ests.len()];
    let mut all_gt_match = Vec::new();
    for (im, (g, _)) in images.iter().enumerate() {
        let mut gt_match = vec![false; g.len()];
        for &ei in &rank[im] {
            let ov: Vec<f64> = g.iter().map(|gb| iou(&ests[ei].pose, gb, method)).collect();
            let mut sorted: Vec<usize> = (0..g.len()).collect();
            sorted.sort_by(|&a, &b| ov[b].partial_cmp(&ov[a]).unwrap().then(a.cmp(&b)));
            for j in sorted {
                if gt_match[j] {
                    continue;
                }
                if ov[j] < thr {
                    break;
                }
                if ov[j] > thr {
                    gt_match[j] = true;
                    tp[ei] = true;
                    break;
                }
            }
        }
        all_gt_match.push(gt_match);
    }
    (tp, all_gt_match)
}

#[test]
fn detection_ap_matches_nocs_transcription() {
    for (seed, method) in [
        (1, IouMethod::Exact),
        (2, IouMethod::Aabb),
        (3, IouMethod::NocsLegacy),
    ] {
        let images = make_images(seed, 40);
        let (gts, ests) = entries(&images);
        let rank = ranked(&images);
        let opts = EvalOptions {
            iou: method,
            min_visib: 0.0,
            ..EvalOptions::default()
        };
        let report = evaluate(&gts, &ests, &opts);
        for thr in anybox_eval::IOU_THRESHOLDS {
            let (tp, _) = iou_matches(&images, &ests, &rank, method, thr);
            let expected = global_ap(&ests, &tp, gts.len());
            let got = report.overall.iou_ap[&format!("{thr}")].unwrap();
            assert!(
                (got - expected).abs() < 1e-12,
                "{method} AP@{thr}: {got} vs {expected}"
            );
        }
        // The set is not degenerate.
        let a = report.overall.iou_ap["0.5"].unwrap();
        assert!(a > 0.1 && a < 0.95, "{method}: {a}");
    }
}

#[test]
fn pose_ap_matches_nocs_transcription() {
    for gating in [false, true] {
        check_pose_ap(gating);
    }
}

/// With `gating` (NOCS `use_matches_for_pose`): estimates and GTs not matched at IoU 0.1 are
/// dropped before pose matching, and #GT counts the kept GTs only.
fn check_pose_ap(gating: bool) {
    let images = make_images(9, 40);
    let (gts, ests) = entries(&images);
    let rank = ranked(&images);
    let report = evaluate(
        &gts,
        &ests,
        &EvalOptions {
            min_visib: 0.0,
            pose_gating: gating,
            ..EvalOptions::default()
        },
    );
    let (est_kept, gt_kept) = if gating {
        iou_matches(&images, &ests, &rank, IouMethod::Exact, 0.1)
    } else {
        (
            vec![true; ests.len()],
            images.iter().map(|(g, _)| vec![true; g.len()]).collect(),
        )
    };
    let n_gt: usize = gt_kept.iter().flatten().filter(|k| **k).count();
    assert_eq!(report.overall.n_pose_gt, n_gt);
    if gating {
        assert!(n_gt < gts.len());
    }
    let mut nontrivial = 0;
    for (key, deg_thr, cm_thr) in anybox_eval::POSE_THRESHOLDS {
        let mut tp = vec![false; ests.len()];
        for (im, (g, _)) in images.iter().enumerate() {
            let mut gt_match = vec![false; g.len()];
            for &ei in &rank[im] {
                if !est_kept[ei] {
                    continue;
                }
                let e = &ests[ei].pose;
                let err: Vec<(f64, f64)> = g
                    .iter()
                    .map(|gb| {
                        (
                            rotation_error_deg(e, gb),
                            (e.center_mm - gb.center_mm).norm() / 10.0,
                        )
                    })
                    .collect();
                let mut sorted: Vec<usize> = (0..g.len()).collect();
                sorted.sort_by(|&a, &b| {
                    (err[a].0 + err[a].1)
                        .partial_cmp(&(err[b].0 + err[b].1))
                        .unwrap()
                        .then(a.cmp(&b))
                });
                for j in sorted {
                    if gt_match[j] || !gt_kept[im][j] {
                        continue;
                    }
                    if err[j].0 > deg_thr || err[j].1 > cm_thr {
                        continue;
                    }
                    gt_match[j] = true;
                    tp[ei] = true;
                    break;
                }
            }
        }
        // Dropped estimates are not in the list at all.
        let kept: Vec<EstEntry> = ests
            .iter()
            .zip(&est_kept)
            .filter(|(_, k)| **k)
            .map(|(e, _)| *e)
            .collect();
        let kept_tp: Vec<bool> = tp
            .iter()
            .zip(&est_kept)
            .filter(|(_, k)| **k)
            .map(|(t, _)| *t)
            .collect();
        let expected = global_ap(&kept, &kept_tp, n_gt);
        let got = report.overall.pose_ap[key].unwrap();
        assert!(
            (got - expected).abs() < 1e-12,
            "gating {gating} {key}: {got} vs {expected}"
        );
        if expected > 0.05 && expected < 0.95 {
            nontrivial += 1;
        }
    }
    assert!(nontrivial >= 6, "only {nontrivial} non-trivial pose APs");
}
