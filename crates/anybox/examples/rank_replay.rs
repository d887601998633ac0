//! Offline replay of the detection bench's ranking: how the final scores of a frame's records
//! (detections and alternative readings) order them, without running the detector again.
//!
//! `cargo run --release -p anybox --example rank_replay -- dump DIR` runs
//! `runner::run_detected_frame` on the bench's detection sets (`bench::detection_sets`,
//! `FRAMES` views per set, 48 by default) of each seed in `SEEDS` (default `2026 7 11 3 5 13`)
//! with the duplicate pass off (`detect.duplicate_score_factor` 1), and writes every record's
//! pose, score and kind with the frame's ground truths to `DIR/records.SEED.json` (about
//! 3 MB per seed, 30 s per seed on two cores).
//!
//! `cargo run --release -p anybox --example rank_replay -- eval DIR` rescores those records
//! by a few variants of the duplicate pass (`pipeline::duplicate_factors`), by a factor per
//! kind of record, and by a perfect ranking, and prints the mean AP@0.5 of the 30 cells
//! (5 sets × 6 seeds) and of each set over the seeds, with the evaluator's own matching
//! (`anybox_eval::evaluate`, visible fraction ≥ 0.5). `base` and `duplicates, default`
//! are what `anybox bench --detect-frames 48` gives without and with the pass.

use anybox::config::Config;
use anybox::detect::DetectConfig;
use anybox::geom::iou::{iou, IouMethod};
use anybox::geom::OrientedBox;
use anybox_eval::{evaluate, EstEntry, EvalOptions, GtEntry};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One record of a frame's output.
#[derive(Serialize, Deserialize)]
struct Rec {
    pose: OrientedBox,
    score: f64,
    /// `det`, `alt` (the detector's alternative), or the key naming a reading's source.
    kind: String,
}

/// One frame: its set, ground truths and records.
#[derive(Serialize, Deserialize)]
struct Frame {
    set: String,
    gts: Vec<GtEntry>,
    recs: Vec<Rec>,
}

fn dump(seed: u64, frames: usize, cfg: &Config) -> Vec<Frame> {
    let mut out = Vec::new();
    for set in anybox::bench::detection_sets(seed, frames) {
        let done: Vec<Frame> = set
            .frames
            .par_iter()
            .map(|f| {
                let o = anybox::runner::run_detected_frame(
                    f.rgb.as_ref(),
                    &f.depth,
                    &f.intrinsics,
                    cfg,
                )
                .expect("generated frames are valid");
                let recs = o
                    .estimates
                    .iter()
                    .filter_map(|r| {
                        Some(Rec {
                            pose: r.pose().ok()?,
                            score: r.score,
                            kind: anybox::runner::record_kind(r).to_string(),
                        })
                    })
                    .collect();
                Frame {
                    set: set.name.clone(),
                    gts: f.gt_entries().collect(),
                    recs,
                }
            })
            .collect();
        out.extend(done);
    }
    out
}

/// AP@0.5 of `frames` with the records scored by `score` (records scored ≤ 0 left out).
fn ap(frames: &[&Frame], score: &(dyn Fn(&Frame) -> Vec<f64> + Sync)) -> f64 {
    let (mut gts, mut ests) = (Vec::new(), Vec::new());
    for (k, f) in frames.iter().enumerate() {
        // One image per frame: the sets' own ids repeat across sets.
        for g in &f.gts {
            gts.push(GtEntry {
                scene_id: k as u32,
                im_id: 0,
                ..*g
            });
        }
        for (r, s) in f.recs.iter().zip(score(f)) {
            if s > 0.0 {
                ests.push(EstEntry {
                    scene_id: k as u32,
                    im_id: 0,
                    score: s,
                    pose: r.pose,
                    gt_index: None,
                });
            }
        }
    }
    let opts = EvalOptions {
        min_visib: 0.5,
        ..EvalOptions::default()
    };
    evaluate(&gts, &ests, &opts).overall.iou_ap["0.5"].unwrap_or(0.0)
}

type Scoring = Box<dyn Fn(&Frame) -> Vec<f64> + Sync>;

fn duplicates(cfg: DetectConfig, only_readings: bool) -> Scoring {
    Box::new(move |f: &Frame| {
        let boxes: Vec<(OrientedBox, f64)> = f.recs.iter().map(|r| (r.pose, r.score)).collect();
        let factors = anybox::pipeline::duplicate_factors(&boxes, &cfg);
        f.recs
            .iter()
            .zip(factors)
            .map(|(r, k)| {
                if only_readings && r.kind == "det" {
                    r.score
                } else {
                    r.score * k
                }
            })
            .collect()
    })
}

fn variants() -> Vec<(String, Scoring)> {
    let mut v: Vec<(String, Scoring)> = vec![(
        "base (no duplicate pass)".into(),
        Box::new(|f: &Frame| f.recs.iter().map(|r| r.score).collect()),
    )];
    let d = DetectConfig::default();
    v.push(("duplicates, default".into(), duplicates(d.clone(), false)));
    for (iou_thr, factor) in [(0.5, 0.0), (0.5, 0.5), (0.45, 0.5), (0.55, 0.5)] {
        let c = DetectConfig {
            duplicate_iou: iou_thr,
            duplicate_score_factor: factor,
            ..d.clone()
        };
        v.push((
            format!("duplicates, IoU > {iou_thr}, × {factor}"),
            duplicates(c, false),
        ));
    }
    let c = DetectConfig {
        duplicate_score_factor: 0.5,
        ..d.clone()
    };
    v.push((
        "duplicates, × 0.5, readings only".into(),
        duplicates(c, true),
    ));
    for k in anybox::runner::RECORD_KIND_KEYS
        .iter()
        .copied()
        .chain(["alt", "det"])
    {
        for factor in [0.6, 1.5] {
            let dup = duplicates(d.clone(), false);
            v.push((
                format!("duplicates, default; {k} × {factor}"),
                Box::new(move |f: &Frame| {
                    let s = dup(f);
                    f.recs
                        .iter()
                        .zip(s)
                        .map(|(r, s)| if r.kind == k { s * factor } else { s })
                        .collect()
                }),
            ));
        }
    }
    v.push((
        "perfect ranking".into(),
        Box::new(|f: &Frame| {
            f.recs
                .iter()
                .map(|r| {
                    let hit = f.gts.iter().any(|g| {
                        g.visib_fract >= 0.5 && iou(&r.pose, &g.pose, IouMethod::Exact) > 0.5
                    });
                    if hit {
                        1.0 + r.score
                    } else {
                        0.1 * r.score
                    }
                })
                .collect()
        }),
    ));
    v
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(mode), Some(dir)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: rank_replay dump|eval DIR");
        std::process::exit(2);
    };
    let seeds: Vec<u64> = std::env::var("SEEDS")
        .unwrap_or_else(|_| "2026 7 11 3 5 13".into())
        .split_whitespace()
        .map(|s| s.parse().expect("SEEDS: integers"))
        .collect();
    let path = |s: u64| std::path::Path::new(dir).join(format!("records.{s}.json"));
    if mode == "dump" {
        let frames: usize = std::env::var("FRAMES")
            .ok()
            .and_then(|f| f.parse().ok())
            .unwrap_or(48);
        let mut cfg = Config::default();
        cfg.detect.duplicate_score_factor = 1.0;
        std::fs::create_dir_all(dir).expect("DIR can be made");
        for s in seeds {
            let json = serde_json::to_string(&dump(s, frames, &cfg)).expect("serialises");
            std::fs::write(path(s), json).expect("DIR is writable");
            eprintln!("seed {s}: {}", path(s).display());
        }
        return;
    }
    let data: Vec<Vec<Frame>> = seeds
        .iter()
        .map(|&s| {
            let text = std::fs::read_to_string(path(s)).expect("run `dump` first");
            serde_json::from_str(&text).expect("written by `dump`")
        })
        .collect();
    let sets = ["pallet", "table, 0", "table, 8", "table, 32", "shelf"];
    println!("variant | mean | {}", sets.join(" | "));
    for (name, score) in variants() {
        let mut per_set = [0.0; 5];
        let mut cells = Vec::new();
        for frames in &data {
            for (k, set) in sets.iter().enumerate() {
                let fs: Vec<&Frame> = frames.iter().filter(|f| f.set.starts_with(set)).collect();
                let a = ap(&fs, &score);
                per_set[k] += a / data.len() as f64;
                cells.push(a);
            }
        }
        let mean = cells.iter().sum::<f64>() / cells.len() as f64;
        let cols: Vec<String> = per_set.iter().map(|x| format!("{x:.4}")).collect();
        println!("{name} | {mean:.4} | {}", cols.join(" | "));
    }
}
