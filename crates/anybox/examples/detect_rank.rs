//! How much of the detection bench's AP is lost to ranking (issue #4): per detection set of
//! `anybox bench` (`anybox::bench::detection_sets`), AP@0.5 of the detector + estimator as
//! scored, with the estimates ranked by their true best 3D IoU instead (the ceiling of any
//! rescoring: same estimates, perfect order), and with the clear false positives (best 3D IoU
//! ≤ 0.1 with every ground truth) dropped.
//!
//! `cargo run --release -p anybox --example detect_rank`
//! Env: `SEED=<u64>` (default 2026), `FRAMES=<n>` (views per set, default 24), `DETECT_CFG=<json>`
//! (detector fields to change, as a partial `DetectConfig`), `EST_CFG=<json>` (the whole
//! configuration as a partial `Config`, e.g. `{"scale":{"measured_start":false}}`), `CSV=<path>`
//! (one row per estimate: set, frame, score, detector score, estimator score, faces,
//! kind (0 detection, 1 the detector's alternative, 2 union of two detections, 3 and 4 a
//! repeat reading's split and extension, 5 a reading of an unseen extent, 6 a lattice
//! reading), mask pixels, depth
//! penalty, observed axes, best 3D
//! IoU with a counted ground truth and with an ignored one, that ground truth's index, sizes
//! (mm, sorted), the largest share of its volume inside a higher-scored estimate of the
//! frame, how many of the frame's other estimates lie at least 60 % inside it, its mask's
//! pixels on the image's outermost rows and columns (0 for unions and repeats), every ground
//! truth overlapped by IoU > 0.3 as `k:iou` (`i` before ignored ones)).
//! The estimates are those of `anybox bench`'s detection rows (`runner::run_detected_frame`):
//! the detections and their alternative readings (`pipeline::alternative_readings`: the
//! unions and the repeat readings; `pipeline::hidden_extent_readings`;
//! `pipeline::lattice_readings`).

use anybox::bench::detection_sets;
use anybox::config::Config;
use anybox::eval::{evaluate, EstEntry, EvalOptions, Report};
use anybox::geom::iou::{iou, IouMethod};
use anybox::geom::OrientedBox;
use anybox::pipeline;

fn ap50(r: &Report) -> f64 {
    r.overall
        .iou_ap
        .get("0.5")
        .copied()
        .flatten()
        .unwrap_or(f64::NAN)
}

fn main() {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let (seed, frames) = (env("SEED", 2026), env("FRAMES", 24) as usize);
    // `DETECT_CFG=<json>`: detector fields to change (partial `DetectConfig`).
    // `EST_CFG=<json>`: the whole configuration (partial `Config`; missing = defaults).
    let mut cfg: Config = match std::env::var("EST_CFG") {
        Ok(j) => serde_json::from_str(&j).expect("EST_CFG: a Config JSON"),
        Err(_) => Config::default(),
    };
    if let Ok(j) = std::env::var("DETECT_CFG") {
        cfg.detect = serde_json::from_str(&j).expect("DETECT_CFG: a DetectConfig JSON");
    }
    let est_cfg = cfg.for_detected_masks();
    let mut csv = String::from(
        "set,frame,score,det_score,est_score,faces,kind,px,depth_penalty,observed,iou,iou_ignored,gt,size_min_mm,size_mid_mm,size_max_mm,pin_hi,contains,border,overlaps\n",
    );
    println!("set | AP@0.5 | ranked by true IoU | clear FPs dropped");
    for set in detection_sets(seed, frames) {
        let mut gts = Vec::new();
        let (mut scored_entries, mut oracle, mut clean) = (Vec::new(), Vec::new(), Vec::new());
        for (fi, f) in set.frames.iter().enumerate() {
            gts.extend(f.gt_entries());
            let Ok(masks) = anybox::segmentation::detect_masks(
                f.rgb.as_ref(),
                &f.depth,
                &f.intrinsics,
                &cfg.detect,
            ) else {
                continue;
            };
            let roles = pipeline::detected_mask_roles(&masks, &est_cfg.detect);
            let results = pipeline::estimate_frame_with_roles(
                &f.depth,
                &f.intrinsics,
                &masks,
                &roles,
                &est_cfg,
            );
            // Rows: (pose, score, detector score, estimator score, faces, kind, mask pixels,
            // depth penalty, observed axes). Kind: 0 detection, 1 the detector's alternative,
            // 2 union, 3 repeat split, 4 repeat extension, 5 a reading of an unseen extent, 6 a
            // lattice reading (as `runner::run_detected_frame`).
            type Row = (OrientedBox, f64, f64, f64, char, u8, usize, f64, usize);
            let mut rows: Vec<Row> = Vec::new();
            // Observed axes per row (for the readings of an unseen extent).
            let mut observed: Vec<[bool; 3]> = Vec::new();
            // Mask pixels on the image's outermost rows and columns, per row (0 for readings
            // that have no mask of their own).
            let mut border: Vec<usize> = Vec::new();
            for (m, r) in masks.iter().zip(results) {
                let Ok(e) = r else { continue };
                let (w, h) = (m.mask.width, m.mask.height);
                border.push(
                    (0..h)
                        .flat_map(|v| (0..w).map(move |u| (u, v)))
                        .filter(|&(u, v)| {
                            (u == 0 || v == 0 || u + 1 == w || v + 1 == h) && m.mask.get(u, v)
                        })
                        .count(),
                );
                let faces = m.faces.and_then(|f| char::from_digit(f.into(), 10));
                observed.push(e.observed_axes);
                rows.push((
                    e.pose,
                    pipeline::detection_score(m.score, m.faces, &e, &cfg.detect),
                    m.score,
                    e.score,
                    faces.unwrap_or('?'),
                    m.alternative as u8,
                    m.mask.count(),
                    e.depth_penalty,
                    e.observed_axes.iter().filter(|o| **o).count(),
                ));
            }
            let primary: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].5 == 0).collect();
            let scored: Vec<(OrientedBox, f64)> =
                primary.iter().map(|&i| (rows[i].0, rows[i].1)).collect();
            let readings =
                pipeline::alternative_readings(&scored, &f.depth, &f.intrinsics, &cfg.detect);
            for u in readings.unions {
                rows.push((u.pose, u.score, f64::NAN, f64::NAN, '?', 2, 0, f64::NAN, 0));
            }
            // Outranked sources scaled down, repeated sizes raised (as the runner does).
            let ranked = pipeline::ranked_scores(&scored, &readings.repeats, &cfg.detect);
            for (&i, s) in primary.iter().zip(ranked) {
                rows[i].1 = s;
            }
            for rd in readings.repeats {
                let kind = match rd.kind {
                    pipeline::RepeatKind::Split => 3,
                    pipeline::RepeatKind::Extend => 4,
                };
                for part in &rd.parts {
                    rows.push((
                        *part,
                        rd.score,
                        f64::NAN,
                        f64::NAN,
                        '?',
                        kind,
                        0,
                        f64::NAN,
                        0,
                    ));
                }
            }
            // Readings of an unseen extent, from the final scores (as the runner does).
            let inferred: Vec<(OrientedBox, f64, [bool; 3])> = primary
                .iter()
                .map(|&i| (rows[i].0, rows[i].1, observed[i]))
                .collect();
            let min_mm = est_cfg.context.min_hidden_mm;
            for h in pipeline::hidden_extent_readings(&inferred, min_mm, &cfg.detect) {
                rows.push((h.pose, h.score, f64::NAN, f64::NAN, '?', 5, 0, f64::NAN, 2));
            }
            // Lattice readings, from the final scores (as the runner does); they keep their
            // source's observed axes.
            let placed: Vec<(OrientedBox, f64)> =
                primary.iter().map(|&i| (rows[i].0, rows[i].1)).collect();
            for l in pipeline::lattice_readings(&placed, &f.depth, &f.intrinsics, &cfg.detect) {
                let obs = rows[primary[l.source]].8;
                rows.push((
                    l.pose,
                    l.score,
                    f64::NAN,
                    f64::NAN,
                    '?',
                    6,
                    0,
                    f64::NAN,
                    obs,
                ));
            }
            // Interpenetration with the frame's other estimates: the largest share of this
            // one's volume inside a higher-scored one, and how many others lie at least 60 %
            // inside this one.
            let inter: Vec<(f64, usize)> = rows
                .iter()
                .enumerate()
                .map(|(a, ra)| {
                    let (mut pin_hi, mut contains) = (0.0f64, 0usize);
                    for (b, rb) in rows.iter().enumerate() {
                        if a == b {
                            continue;
                        }
                        let vi = anybox::geom::iou::intersection_volume_mm3(&ra.0, &rb.0);
                        if rb.1 > ra.1 {
                            pin_hi = pin_hi.max(vi / ra.0.volume_mm3());
                        }
                        if vi >= 0.6 * rb.0.volume_mm3() {
                            contains += 1;
                        }
                    }
                    (pin_hi, contains)
                })
                .collect();
            border.resize(rows.len(), 0);
            for (
                ((pose, score, det_score, est_score, faces, kind, px, dp, obs), (pin_hi, contains)),
                border,
            ) in rows.into_iter().zip(inter).zip(border)
            {
                // Best 3D IoU with a counted ground truth (visible fraction ≥ 0.5) and with
                // an ignored one.
                let (mut best, mut best_ign, mut best_k) = (0.0f64, 0.0f64, None);
                // Every ground truth it overlaps by 3D IoU > 0.3, `k:iou`, `i` before an
                // ignored one (to replay the evaluator's greedy matching offline).
                let mut overlaps = Vec::new();
                for (k, g) in f.instances.iter().enumerate() {
                    let v = iou(&pose, &g.gt, IouMethod::Exact);
                    if v > 0.3 {
                        let ign = if g.visib_fract < 0.5 { "i" } else { "" };
                        overlaps.push(format!("{ign}{k}:{v:.3}"));
                    }
                    if g.visib_fract < 0.5 {
                        best_ign = best_ign.max(v);
                    } else if v > best {
                        (best, best_k) = (v, Some(k));
                    }
                }
                let mut sz = [pose.size_mm.x, pose.size_mm.y, pose.size_mm.z];
                sz.sort_by(f64::total_cmp);
                csv += &format!(
                    "{},{fi},{score:.5},{det_score:.5},{est_score:.5},{faces},{kind},{px},{dp:.4},{obs},{best:.3},{best_ign:.3},{},{:.0},{:.0},{:.0},{pin_hi:.3},{contains},{border},{}\n",
                    set.name.replace(',', ""),
                    best_k.map_or(-1, |k| k as i64),
                    sz[0],
                    sz[1],
                    sz[2],
                    overlaps.join(";"),
                );
                let entry = |s: f64| EstEntry {
                    scene_id: f.scene_id,
                    im_id: f.im_id,
                    score: s,
                    pose,
                    gt_index: None,
                };
                scored_entries.push(entry(score));
                oracle.push(entry(best.max(best_ign)));
                if best > 0.1 || best_ign > 0.1 {
                    clean.push(entry(score));
                }
            }
        }
        let opts = EvalOptions {
            min_visib: 0.5,
            ..EvalOptions::default()
        };
        println!(
            "{} | {:.3} | {:.3} | {:.3}",
            set.name,
            ap50(&evaluate(&gts, &scored_entries, &opts)),
            ap50(&evaluate(&gts, &oracle, &opts)),
            ap50(&evaluate(&gts, &clean, &opts)),
        );
    }
    if let Ok(p) = std::env::var("CSV") {
        if let Err(e) = std::fs::write(&p, csv) {
            eprintln!("cannot write {p}: {e}");
        }
    }
}
