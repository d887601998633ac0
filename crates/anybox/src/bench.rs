//! The benchmark behind `anybox bench`: every estimator variant on the same instances, scored
//! with the evaluator, timed per box (single-threaded) and per frame (all cores).
//!
//! In: a [`BenchSet`] (generated with a fixed seed, or read from a BOP dataset) and a list of
//! [`Variant`]s. Out: one [`VariantResult`] per variant and a markdown table.
//!
//! Every figure is reported twice: for boxes whose three dimensions are all observed in the
//! view (`anybox_eval::observed_dims` count = 3) and for all boxes.

use std::time::Instant;

use rayon::prelude::*;

use anybox_eval::{evaluate, observed_dims, EstEntry, EvalOptions, GtEntry, Report};
use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::bop::BopDataset;
use anybox_io::{DepthMap, IoError, Mask, RgbImage};
use anybox_synth::{generate_view, Layout, NoiseModel, SynthConfig};

use crate::config::Config;
use crate::pipeline::{estimate_box, estimate_frame};

/// One ground-truth instance of a benchmark frame.
#[derive(Debug, Clone)]
pub struct BenchInstance {
    /// Index of the ground truth in its view.
    pub gt_index: usize,
    /// The visible mask (ground truth).
    pub mask: Mask,
    /// The true box.
    pub gt: OrientedBox,
    /// Visible fraction of the box.
    pub visib_fract: f64,
    /// How many of the box's dimensions the view shows (0–3).
    pub observed_dims: u8,
}

/// One frame of a benchmark set.
#[derive(Debug, Clone)]
pub struct BenchFrame {
    /// BOP scene id.
    pub scene_id: u32,
    /// BOP image id.
    pub im_id: u32,
    /// Layout name (`pallet`, `table`, `shelf`, or the dataset name).
    pub layout: String,
    /// Colour image (used by the detector; `None` when the dataset has none).
    pub rgb: Option<RgbImage>,
    /// Depth, mm.
    pub depth: DepthMap,
    /// Camera.
    pub intrinsics: Intrinsics,
    /// Instances to estimate (visible fraction at or above the set's threshold).
    pub instances: Vec<BenchInstance>,
}

impl BenchFrame {
    /// The frame's instances as evaluator ground truths.
    pub fn gt_entries(&self) -> impl Iterator<Item = GtEntry> + '_ {
        self.instances.iter().map(|inst| GtEntry {
            scene_id: self.scene_id,
            im_id: self.im_id,
            gt_index: inst.gt_index,
            pose: inst.gt,
            visib_fract: inst.visib_fract,
            observed_dims: Some(inst.observed_dims),
        })
    }
}

/// A named set of frames.
#[derive(Debug, Clone)]
pub struct BenchSet {
    /// Name printed in the table heading.
    pub name: String,
    /// Frames.
    pub frames: Vec<BenchFrame>,
}

impl BenchSet {
    /// Number of instances.
    pub fn n_instances(&self) -> usize {
        self.frames.iter().map(|f| f.instances.len()).sum()
    }

    /// Number of instances with all three dimensions observed.
    pub fn n_full_dims(&self) -> usize {
        self.frames
            .iter()
            .flat_map(|f| &f.instances)
            .filter(|i| i.observed_dims == 3)
            .count()
    }
}

/// The default generated benchmark: mixed pallet/table/shelf scenes with realistic noise and a
/// fixed seed, grown scene by scene until it holds at least `min_instances` boxes with a
/// visible fraction of at least `min_visib`.
pub fn synthetic_set(seed: u64, min_instances: usize, min_visib: f64) -> BenchSet {
    let cfg = SynthConfig {
        layout: Layout::Mixed,
        scenes: u32::MAX,
        views: 1,
        distractors: None,
        seed,
        noise: NoiseModel::Realistic,
        ..SynthConfig::default()
    };
    let name = format!("generated (mixed, realistic noise, seed {seed}, visib >= {min_visib})");
    generated_set(&cfg, name, min_instances, usize::MAX, min_visib)
}

/// Frames of `cfg` (one view per scene), generated in parallel batches until the set holds at
/// least `min_instances` instances with a visible fraction of at least `min_visib`, or
/// `max_frames` frames.
pub fn generated_set(
    cfg: &SynthConfig,
    name: String,
    min_instances: usize,
    max_frames: usize,
    min_visib: f64,
) -> BenchSet {
    let mut frames = Vec::new();
    let mut n = 0;
    let mut scene = 0;
    while n < min_instances && frames.len() < max_frames && scene < 10_000 {
        let batch_len = 8.min(max_frames - frames.len()) as u32;
        let batch: Vec<BenchFrame> = (scene..scene + batch_len)
            .into_par_iter()
            .map(|s| {
                let v = generate_view(cfg, s, 0);
                let instances = v
                    .boxes
                    .iter()
                    .enumerate()
                    .filter(|(_, b)| b.visib_fract >= min_visib)
                    .map(|(i, b)| BenchInstance {
                        gt_index: i,
                        mask: b.mask_visib.clone(),
                        gt: b.pose,
                        visib_fract: b.visib_fract,
                        observed_dims: observed_dims(&b.pose, &b.mask_visib, &v.intrinsics).count,
                    })
                    .collect();
                BenchFrame {
                    scene_id: v.scene_id,
                    im_id: v.im_id,
                    layout: v.layout.to_string(),
                    rgb: Some(v.rgb),
                    depth: v.depth,
                    intrinsics: v.intrinsics,
                    instances,
                }
            })
            .collect();
        scene += batch_len;
        for f in batch {
            n += f.instances.len();
            frames.push(f);
        }
    }
    BenchSet { name, frames }
}

/// A benchmark set from a BOP dataset's ground truth (e.g. `ycbv-boxes`).
pub fn bop_set(ds: &BopDataset, name: &str, min_visib: f64) -> Result<BenchSet, IoError> {
    let mut frames = Vec::new();
    for view in &ds.views {
        let frame = view.load_frame()?;
        let mut instances = Vec::new();
        for g in view.gts.iter().filter(|g| g.visib_fract >= min_visib) {
            let mask = view.load_mask_visib(g.gt_index)?;
            let od = observed_dims(&g.pose, &mask, &frame.intrinsics).count;
            instances.push(BenchInstance {
                gt_index: g.gt_index,
                mask,
                gt: g.pose,
                visib_fract: g.visib_fract,
                observed_dims: od,
            });
        }
        frames.push(BenchFrame {
            scene_id: view.scene_id,
            im_id: view.im_id,
            layout: name.to_string(),
            rgb: frame.rgb,
            depth: frame.depth,
            intrinsics: frame.intrinsics,
            instances,
        });
    }
    Ok(BenchSet {
        name: name.to_string(),
        frames,
    })
}

/// The paper's Algorithms 1 + 2 plus anybox's hidden-dimension context.
fn paper_with_context() -> Config {
    let mut c = Config::paper();
    c.context.enabled = true;
    c
}

/// An estimator variant.
#[derive(Debug, Clone)]
pub struct Variant {
    /// Row name.
    pub name: String,
    /// Configuration.
    pub config: Config,
    /// Give the estimator the true size (the paper's "GT CAD" oracle).
    pub oracle_size: bool,
}

/// The variants of issue #3: full pipeline, the paper's ablations, the oracle, and our modes.
pub fn default_variants() -> Vec<Variant> {
    let v = |name: &str, config: Config, oracle_size: bool| Variant {
        name: name.to_string(),
        config,
        oracle_size,
    };
    vec![
        v("full (paper: Alg. 1 + 2)", Config::paper(), false),
        v("no depth filter", Config::paper().no_depth_filter(), false),
        v(
            "no early stopping (Alg. 1 only)",
            Config::paper().binary_search_only(),
            false,
        ),
        v(
            "canonical size (no scale search)",
            Config::paper().canonical(),
            false,
        ),
        v("oracle size (GT CAD)", Config::paper(), true),
        v("paper + hidden-dim context", paper_with_context(), false),
        v(
            "anybox default (point-fit + context)",
            Config::anybox(),
            false,
        ),
        v(
            "anybox, no depth filter",
            Config::anybox().no_depth_filter(),
            false,
        ),
    ]
}

/// Results of one variant on one set.
#[derive(Debug, Clone)]
pub struct VariantResult {
    /// Variant name.
    pub name: String,
    /// Figures over boxes with all three dimensions observed.
    pub full_dims: Report,
    /// Figures over all boxes.
    pub all: Report,
    /// Estimation time per box, single-threaded, ms (one entry per instance, failures included).
    pub box_ms: Vec<f64>,
    /// Wall time per frame with all cores, ms.
    pub frame_ms: Vec<f64>,
    /// Instances without an estimate.
    pub failures: usize,
}

fn config_for(v: &Variant, gt: &OrientedBox) -> Config {
    if v.oracle_size {
        v.config
            .clone()
            .oracle([gt.size_mm.x, gt.size_mm.y, gt.size_mm.z])
    } else {
        v.config.clone()
    }
}

/// Runs one variant on a set.
///
/// - Accuracy: the whole-frame pipeline (`estimate_frame`, with its cross-instance context such
///   as shared layer heights) on all cores, which also gives the frame time. The oracle variant
///   needs one size per box, so it runs `estimate_box` per instance instead.
/// - Time per box: a second, sequential pass of `estimate_box` on one thread.
pub fn run_variant(set: &BenchSet, v: &Variant, min_visib: f64) -> VariantResult {
    let mut gts = Vec::new();
    let mut ests = Vec::new();
    let mut frame_ms = Vec::new();
    let mut failures = 0;
    for f in &set.frames {
        gts.extend(f.gt_entries());
        if f.instances.is_empty() {
            continue;
        }
        let start = Instant::now();
        let results: Vec<_> = if v.oracle_size {
            f.instances
                .par_iter()
                .map(|i| estimate_box(&f.depth, &f.intrinsics, &i.mask, &config_for(v, &i.gt)))
                .collect()
        } else {
            let masks: Vec<Mask> = f.instances.iter().map(|i| i.mask.clone()).collect();
            estimate_frame(&f.depth, &f.intrinsics, &masks, &v.config)
        };
        frame_ms.push(start.elapsed().as_secs_f64() * 1e3);
        for (inst, r) in f.instances.iter().zip(results) {
            match r {
                Ok(e) => ests.push(EstEntry {
                    scene_id: f.scene_id,
                    im_id: f.im_id,
                    score: e.score,
                    pose: e.pose,
                    gt_index: Some(inst.gt_index),
                }),
                Err(_) => failures += 1,
            }
        }
    }
    let mut box_ms = Vec::new();
    for f in &set.frames {
        for inst in &f.instances {
            let cfg = config_for(v, &inst.gt);
            let start = Instant::now();
            let _ = estimate_box(&f.depth, &f.intrinsics, &inst.mask, &cfg);
            box_ms.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    let base = EvalOptions {
        min_visib,
        ..EvalOptions::default()
    };
    let all = evaluate(&gts, &ests, &base);
    let full_dims = evaluate(
        &gts,
        &ests,
        &EvalOptions {
            min_observed_dims: 3,
            ..base
        },
    );
    VariantResult {
        name: v.name.clone(),
        full_dims,
        all,
        box_ms,
        frame_ms,
        failures,
    }
}

/// The `q`-quantile (0..1) of `xs` by nearest rank; NaN for an empty slice.
pub fn quantile(xs: &[f64], q: f64) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let i = ((q * (v.len() - 1) as f64).round() as usize).min(v.len() - 1);
    v[i]
}

fn cell(v: Option<&Option<f64>>) -> String {
    match v.copied().flatten() {
        Some(x) => format!("{x:.3}"),
        None => "–".to_string(),
    }
}

/// Markdown table of a set of variant results: one row per variant and box group.
pub fn markdown_table(set: &BenchSet, results: &[VariantResult]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "**{}** — {} frames, {} boxes ({} with all three dimensions observed); exact 3D IoU, AP = VOC all-point, no pose gating; time per box single-threaded, frame time with all cores ({} threads).\n",
        set.name,
        set.frames.len(),
        set.n_instances(),
        set.n_full_dims(),
        rayon::current_num_threads()
    );
    let _ = writeln!(
        s,
        "| variant | boxes | n | AP@0.5 | AP@0.7 | AP@0.8 | AP@0.9 | 5°1cm | 20°5cm | ADD-S 0.1d | size err med (mm) | ms/box med | ms/box p90 | ms/frame (all cores) |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in results {
        for (group, rep) in [("3 dims seen", &r.full_dims), ("all", &r.all)] {
            let f = &rep.overall;
            let size = f
                .size_err_mm
                .median
                .map(|m| format!("{m:.1}"))
                .unwrap_or_else(|| "–".into());
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.1} |",
                r.name,
                group,
                f.n_gt,
                cell(f.iou_ap.get("0.5")),
                cell(f.iou_ap.get("0.7")),
                cell(f.iou_ap.get("0.8")),
                cell(f.iou_ap.get("0.9")),
                cell(f.pose_ap.get("5deg_1cm")),
                cell(f.pose_ap.get("20deg_5cm")),
                cell(f.adds_ap.get("0.1d")),
                size,
                quantile(&r.box_ms, 0.5),
                quantile(&r.box_ms, 0.9),
                quantile(&r.frame_ms, 0.5),
            );
        }
    }
    s
}

/// The detection benchmark of issue #4: one generated set per layout and clutter level
/// (pallet; table with 0, 8 and 32 distractors; shelf), `frames` views each, realistic noise.
/// Every ground truth is kept; the evaluator ignores those below its visibility threshold.
pub fn detection_sets(seed: u64, frames: usize) -> Vec<BenchSet> {
    let mk = |layout: Layout, distractors: u32, name: &str| {
        let cfg = SynthConfig {
            layout,
            scenes: u32::MAX,
            views: 1,
            distractors: Some(distractors),
            seed,
            noise: NoiseModel::Realistic,
            ..SynthConfig::default()
        };
        generated_set(&cfg, name.to_string(), usize::MAX, frames, 0.0)
    };
    vec![
        mk(Layout::Pallet, 0, "pallet"),
        mk(Layout::Table, 0, "table, 0 distractors"),
        mk(Layout::Table, 8, "table, 8 distractors"),
        mk(Layout::Table, 32, "table, 32 distractors"),
        mk(Layout::Shelf, 0, "shelf"),
    ]
}

/// Detection results on one set: detector + estimator on whole frames, false positives counted.
#[derive(Debug, Clone)]
pub struct DetectionResult {
    /// Set name.
    pub name: String,
    /// Frames.
    pub frames: usize,
    /// Evaluation (estimates carry no ground-truth index; matching is by 3D IoU).
    pub report: Report,
    /// Estimates from the detector's masks (alternatives excluded), summed over frames; a mask
    /// the estimator rejects is not counted.
    pub n_detections: usize,
    /// Alternative readings per frame, summed: the detector's
    /// ([`crate::detect::Detection::alternative`]), the unions of split cartons
    /// ([`crate::pipeline::tiled_unions`], [`crate::pipeline::gap_unions`]) and the repeat
    /// readings ([`crate::pipeline::repeat_readings`]); evaluated with the detections, not
    /// counted in `n_detections`.
    pub n_alternatives: usize,
    /// Estimates whose best 3D IoU with every ground truth of the frame is ≤ 0.1 (clear false
    /// positives), summed.
    pub n_false_positives: usize,
    /// Whole-frame time (detection + estimation of every box + unions, all cores; the
    /// fastest of `reps` runs), ms.
    pub frame_ms: Vec<f64>,
    /// Runs per frame behind `frame_ms`.
    pub reps: usize,
    /// Frames where the detector returned an error.
    pub errors: usize,
    /// The same frames estimated from the ground-truth visible masks instead of detections
    /// (one estimate per counted box, same configuration and matching): what the estimator
    /// reaches with perfect segmentation, the reference the detection AP is read against.
    pub gt_masks: Report,
}

/// Runs detection + estimation on every frame of a set, exactly as `anybox estimate --masks
/// detect` does ([`crate::runner::run_detected_frame`]), and evaluates the boxes against all
/// ground truths (visible fraction below `min_visib` ignored). The estimate's score is the
/// detection score times the pose score.
///
/// Each frame runs `reps` times (at least once) and its time is the fastest run: on a shared
/// machine interference only ever adds time, so the minimum is the repeatable figure. The
/// output is deterministic, so the first run's estimates are the ones evaluated.
pub fn run_detection(
    set: &BenchSet,
    config: &Config,
    min_visib: f64,
    reps: usize,
) -> DetectionResult {
    let mut gts = Vec::new();
    let mut ests = Vec::new();
    let mut gt_mask_ests = Vec::new();
    let mut frame_ms = Vec::new();
    let (mut n_det, mut n_alt, mut n_fp, mut errors) = (0, 0, 0, 0);
    for f in &set.frames {
        gts.extend(f.gt_entries());
        let gt_masks: Vec<Mask> = f
            .instances
            .iter()
            .filter(|i| i.visib_fract >= min_visib)
            .map(|i| i.mask.clone())
            .collect();
        let from_gt = estimate_frame(&f.depth, &f.intrinsics, &gt_masks, config);
        for r in from_gt.into_iter().flatten() {
            gt_mask_ests.push(EstEntry {
                scene_id: f.scene_id,
                im_id: f.im_id,
                score: r.score,
                pose: r.pose,
                gt_index: None,
            });
        }
        let run = || {
            let start = Instant::now();
            let out =
                crate::runner::run_detected_frame(f.rgb.as_ref(), &f.depth, &f.intrinsics, config);
            (out, start.elapsed().as_secs_f64() * 1e3)
        };
        let (out, mut fastest_ms) = run();
        let Ok(out) = out else {
            errors += 1;
            continue;
        };
        for _ in 1..reps {
            fastest_ms = fastest_ms.min(run().1);
        }
        frame_ms.push(fastest_ms);
        // Detections first, then the alternative readings (the detector's and the unions):
        // clear false positives counted alike.
        let (primary, alternatives): (Vec<_>, Vec<_>) = out
            .estimates
            .iter()
            .partition(|r| r.extra.get("alternative").is_none());
        n_det += primary.len();
        n_alt += alternatives.len();
        for rec in primary.into_iter().chain(alternatives) {
            // Records written by `run_detected_frame` come from valid poses.
            let Ok(pose) = rec.pose() else { continue };
            let best = f
                .instances
                .iter()
                .map(|i| anybox_geom::iou::iou(&pose, &i.gt, anybox_geom::iou::IouMethod::Exact))
                .fold(0.0, f64::max);
            if best <= 0.1 {
                n_fp += 1;
            }
            ests.push(EstEntry {
                scene_id: f.scene_id,
                im_id: f.im_id,
                score: rec.score,
                pose,
                gt_index: None,
            });
        }
    }
    let opts = EvalOptions {
        min_visib,
        ..EvalOptions::default()
    };
    let report = evaluate(&gts, &ests, &opts);
    let gt_masks = evaluate(&gts, &gt_mask_ests, &opts);
    DetectionResult {
        name: set.name.clone(),
        frames: set.frames.len(),
        report,
        n_detections: n_det,
        n_alternatives: n_alt,
        n_false_positives: n_fp,
        frame_ms,
        reps: reps.max(1),
        errors,
        gt_masks,
    }
}

/// Markdown table of detection results.
pub fn detection_table(title: &str, rows: &[DetectionResult]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let reps_note = match rows.iter().map(|r| r.reps).max() {
        Some(n) if n > 1 => format!(", the fastest of {n} runs of each frame"),
        _ => String::new(),
    };
    let _ = writeln!(s, "**{title}** — built-in detector (`--masks detect`) + default estimator on whole frames; exact 3D IoU, VOC AP with false positives counted; ground truths below the visibility threshold ignored; frame time = detection + estimation of every box, all cores ({} threads){}. `detections`: the detector's, + alternative readings (the detector's other side of a split decision, unions of split cartons, merged or short boxes read by another's size, an unseen extent read as the larger visible one or half of itself, and a carton repeated at the next place of its layer; scored low, flagged in `estimate` output); a box that repeats a higher-scored one at 3D IoU > 0.5 (detection or reading) is scaled by `detect.duplicate_score_factor` (0.3 by default). `AP@0.5, GT masks`: the same frames and estimator with the ground-truth visible masks in place of detections (perfect segmentation; not timed).\n", rayon::current_num_threads(), reps_note);
    let _ = writeln!(s, "| set | frames | GT boxes | detections | clear FPs (IoU ≤ 0.1) | AP@0.25 | AP@0.5 | AP@0.7 | AP@0.5, GT masks | ms/frame med | ms/frame p90 |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let f = &r.report.overall;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} + {} | {} | {} | {} | {} | {} | {:.1} | {:.1} |",
            r.name,
            r.frames,
            f.n_gt,
            r.n_detections,
            r.n_alternatives,
            r.n_false_positives,
            cell(f.iou_ap.get("0.25")),
            cell(f.iou_ap.get("0.5")),
            cell(f.iou_ap.get("0.7")),
            cell(r.gt_masks.overall.iou_ap.get("0.5")),
            quantile(&r.frame_ms, 0.5),
            quantile(&r.frame_ms, 0.9),
        );
    }
    s
}

/// One detection row's accuracy: AP@0.25 / 0.5 / 0.7 and AP@0.5 from ground-truth masks
/// (`None` where the evaluator gives none, e.g. a set with no counted box).
#[derive(Debug, Clone, PartialEq)]
pub struct DetectionAps {
    /// Set name.
    pub name: String,
    /// AP@0.25, 3D IoU.
    pub ap25: Option<f64>,
    /// AP@0.5, 3D IoU.
    pub ap50: Option<f64>,
    /// AP@0.7, 3D IoU.
    pub ap70: Option<f64>,
    /// AP@0.5 of the same frames from the ground-truth visible masks.
    pub gt_ap50: Option<f64>,
}

impl DetectionResult {
    /// The row's AP columns.
    pub fn aps(&self) -> DetectionAps {
        let ap = |r: &Report, t: &str| r.overall.iou_ap.get(t).copied().flatten();
        DetectionAps {
            name: self.name.clone(),
            ap25: ap(&self.report, "0.25"),
            ap50: ap(&self.report, "0.5"),
            ap70: ap(&self.report, "0.7"),
            gt_ap50: ap(&self.gt_masks, "0.5"),
        }
    }
}

/// Markdown summary of the detection rows of several seeds (`anybox bench --detect-seeds`):
/// one row per set with its AP@0.5 on each seed and the mean over the seeds, then a row
/// over every set and seed (the mean of all cells), with the means of AP@0.25, AP@0.7 and
/// the ground-truth-mask AP@0.5 alongside. Means are of the unrounded APs and skip missing
/// ones; sets are matched by name, in the first seed's order.
pub fn seed_summary_table(per_seed: &[(u64, Vec<DetectionAps>)]) -> String {
    use std::fmt::Write as _;
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let fmt = |v: Option<f64>, d: usize| v.map_or("–".to_string(), |x| format!("{x:.d$}"));
    let names: Vec<&str> = per_seed
        .first()
        .map(|(_, rows)| rows.iter().map(|r| r.name.as_str()).collect())
        .unwrap_or_default();
    let row_of = |rows: &'_ [DetectionAps], name: &str| -> Option<DetectionAps> {
        rows.iter().find(|r| r.name == name).cloned()
    };
    let seeds: Vec<String> = per_seed.iter().map(|(s, _)| format!("seed {s}")).collect();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "**Detection AP@0.5 by seed** — the rows above, per seed; means over the seeds (of the unrounded APs).\n"
    );
    let _ = writeln!(
        s,
        "| set | {} | mean AP@0.5 | mean AP@0.25 | mean AP@0.7 | mean AP@0.5, GT masks |",
        seeds.join(" | ")
    );
    let _ = writeln!(s, "|---|{}---|---|---|---|", "---|".repeat(seeds.len()));
    // A row: its label, its per-seed cells, then the means of AP@0.5 / 0.25 / 0.7 / GT masks.
    let row = |s: &mut String, label: &str, cells: &[String], means: [&Vec<f64>; 4]| {
        let m: Vec<String> = means.iter().map(|v| fmt(mean(v), 4)).collect();
        let _ = writeln!(s, "| {label} | {} | {} |", cells.join(" | "), m.join(" | "));
    };
    let (mut all50, mut all25, mut all70, mut all_gt) = (vec![], vec![], vec![], vec![]);
    for name in &names {
        let rows: Vec<Option<DetectionAps>> =
            per_seed.iter().map(|(_, r)| row_of(r, name)).collect();
        let col = |f: fn(&DetectionAps) -> Option<f64>| -> Vec<f64> {
            rows.iter().flatten().filter_map(f).collect()
        };
        let (a50, a25, a70, gt) = (
            col(|r| r.ap50),
            col(|r| r.ap25),
            col(|r| r.ap70),
            col(|r| r.gt_ap50),
        );
        let cells: Vec<String> = rows
            .iter()
            .map(|r| fmt(r.as_ref().and_then(|r| r.ap50), 3))
            .collect();
        row(&mut s, name, &cells, [&a50, &a25, &a70, &gt]);
        all50.extend(a50);
        all25.extend(a25);
        all70.extend(a70);
        all_gt.extend(gt);
    }
    let per_seed_all: Vec<String> = per_seed
        .iter()
        .map(|(_, rows)| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| names.contains(&r.name.as_str()))
                .filter_map(|r| r.ap50)
                .collect();
            fmt(mean(&v), 3)
        })
        .collect();
    row(
        &mut s,
        "all sets",
        &per_seed_all,
        [&all50, &all25, &all70, &all_gt],
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The seed summary averages each set over the seeds and every cell over all, from the
    /// unrounded APs, skips missing APs, and matches sets by name whatever their order.
    #[test]
    fn seed_summary_averages_sets_over_seeds_and_all_cells() {
        let row = |name: &str, ap50: Option<f64>, ap25: f64| DetectionAps {
            name: name.into(),
            ap25: Some(ap25),
            ap50,
            ap70: Some(0.5 * ap25),
            gt_ap50: Some(0.9),
        };
        let per_seed = vec![
            (
                1,
                vec![
                    row("pallet", Some(0.8004), 0.9),
                    row("shelf", Some(0.6), 0.8),
                ],
            ),
            // Another order, and a missing AP@0.5.
            (
                2,
                vec![row("shelf", None, 0.7), row("pallet", Some(0.7002), 0.8)],
            ),
        ];
        let t = seed_summary_table(&per_seed);
        let line = |name: &str| -> Vec<String> {
            let l = t
                .lines()
                .find(|l| l.starts_with(&format!("| {name} |")))
                .unwrap_or_else(|| panic!("no row {name} in\n{t}"));
            l.split('|').map(|c| c.trim().to_string()).collect()
        };
        // | name | seed 1 | seed 2 | mean 0.5 | mean 0.25 | mean 0.7 | mean GT |
        let p = line("pallet");
        assert_eq!(
            &p[1..8],
            ["pallet", "0.800", "0.700", "0.7503", "0.8500", "0.4250", "0.9000"]
        );
        let sh = line("shelf");
        assert_eq!(&sh[1..5], ["shelf", "0.600", "–", "0.6000"]);
        // All cells: (0.8004 + 0.6 + 0.7002) / 3 at AP@0.5; per seed the mean of its sets.
        let all = line("all sets");
        assert_eq!(&all[2..5], ["0.700", "0.700", "0.7002"]);
        assert_eq!(all[5], "0.8000");
        assert!(t.contains("| set | seed 1 | seed 2 | mean AP@0.5 |"), "{t}");
    }

    /// The detection rows carry a ground-truth-mask reference over the same frames: the same
    /// counted boxes, one estimate per box (no false positives), and on uncluttered table
    /// frames it finds every counted box.
    #[test]
    fn detection_rows_carry_the_ground_truth_mask_reference() {
        let sets = detection_sets(2026, 2);
        let table = sets
            .iter()
            .find(|s| s.name == "table, 0 distractors")
            .expect("the table set exists");
        let r = run_detection(table, &Config::default(), 0.5, 2);
        assert_eq!((r.reps, r.frame_ms.len()), (2, table.frames.len()));
        assert!(r.frame_ms.iter().all(|ms| ms.is_finite() && *ms > 0.0));
        let (det, gt) = (&r.report.overall, &r.gt_masks.overall);
        assert!(det.n_gt > 0);
        assert_eq!(gt.n_gt, det.n_gt, "both rows count the same boxes");
        let counted = table
            .frames
            .iter()
            .flat_map(|f| &f.instances)
            .filter(|i| i.visib_fract >= 0.5)
            .count();
        assert_eq!(gt.n_est, counted, "one estimate per counted box");
        let ap = |t: &str| gt.iou_ap.get(t).copied().flatten();
        assert!(ap("0.25").is_some_and(|a| a >= 0.95), "{:?}", gt.iou_ap);
        assert!(ap("0.5").is_some_and(|a| a >= 0.8), "{:?}", gt.iou_ap);
    }
}
