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
//! alternative, mask pixels, depth penalty, observed axes, best 3D IoU with a counted ground
//! truth and with an ignored one, that ground truth's index).
//! Tiled unions (`pipeline::tiled_unions`) are left out, so the as-scored AP can differ from
//! the bench's by a few thousandths.

use anybox::bench::detection_sets;
use anybox::config::Config;
use anybox::eval::{evaluate, EstEntry, EvalOptions, Report};
use anybox::geom::iou::{iou, IouMethod};

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
        "set,frame,score,det_score,est_score,faces,alternative,px,depth_penalty,observed,iou,iou_ignored,gt,size_min_mm,size_mid_mm,size_max_mm\n",
    );
    println!("set | AP@0.5 | ranked by true IoU | clear FPs dropped");
    for set in detection_sets(seed, frames) {
        let mut gts = Vec::new();
        let (mut scored, mut oracle, mut clean) = (Vec::new(), Vec::new(), Vec::new());
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
            let plain: Vec<_> = masks.iter().map(|m| m.mask.clone()).collect();
            let alt: Vec<bool> = masks.iter().map(|m| m.alternative).collect();
            let results = anybox::pipeline::estimate_frame_with_alternatives(
                &f.depth,
                &f.intrinsics,
                &plain,
                &alt,
                &est_cfg,
            );
            for (m, r) in masks.iter().zip(results) {
                let Ok(e) = r else { continue };
                // Best 3D IoU with a counted ground truth (visible fraction ≥ 0.5) and with
                // an ignored one.
                let (mut best, mut best_ign, mut best_k) = (0.0f64, 0.0f64, None);
                for (k, g) in f.instances.iter().enumerate() {
                    let v = iou(&e.pose, &g.gt, IouMethod::Exact);
                    if g.visib_fract < 0.5 {
                        best_ign = best_ign.max(v);
                    } else if v > best {
                        (best, best_k) = (v, Some(k));
                    }
                }
                let score = e.score * m.score;
                let mut sz = [e.pose.size_mm.x, e.pose.size_mm.y, e.pose.size_mm.z];
                sz.sort_by(f64::total_cmp);
                let faces = m.name.split('(').nth(1).and_then(|x| x.chars().next());
                csv += &format!(
                    "{},{fi},{score:.5},{:.5},{:.5},{},{},{},{:.4},{},{best:.3},{best_ign:.3},{},{:.0},{:.0},{:.0}\n",
                    set.name.replace(',', ""),
                    m.score,
                    e.score,
                    faces.unwrap_or('?'),
                    m.alternative as u8,
                    m.mask.count(),
                    e.depth_penalty,
                    e.observed_axes.iter().filter(|o| **o).count(),
                    best_k.map_or(-1, |k| k as i64),
                    sz[0],
                    sz[1],
                    sz[2],
                );
                let entry = |s: f64| EstEntry {
                    scene_id: f.scene_id,
                    im_id: f.im_id,
                    score: s,
                    pose: e.pose,
                    gt_index: None,
                };
                scored.push(entry(score));
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
            ap50(&evaluate(&gts, &scored, &opts)),
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
