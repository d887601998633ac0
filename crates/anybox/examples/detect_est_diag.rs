//! Why estimates from detected masks fail (issue #4 diagnostics).
//!
//! For every ground-truth box (visible fraction ≥ 0.5) of a generated detection set whose best
//! detection has mask IoU ≥ 0.5 with it, but whose estimate from that detection's mask has 3D
//! IoU < 0.5, both boxes are re-scored by the pose estimator under the *same* observation
//! (the detection's mask), each refined from itself:
//! - `SEARCH`: the ground-truth box scores higher, so the estimator's search missed a better
//!   answer that the mask supports;
//! - `score`: the estimate scores higher, so the mask itself (partial, bleeding) misleads.
//!
//! Each line also gives the estimate's number of observed axes (`obs`; fewer than 3 means an
//! extent came from scene context) and both sizes, mm. The indented line under it estimates the
//! same box from its ground-truth mask, and counts the pixels in which the two masks differ.
//!
//! `cargo run --release -p anybox --example detect_est_diag`
//! Env: `SEED=<u64>` (default 2026), `ONLY=pallet|table-d0|table-d8|table-d32|shelf` (default
//! table-d0), `VIEWS=<n>` (default 24), `EST_CFG=<json>` (a partial `Config`, e.g.
//! `{"scale":{"template_mm":[250,150,60]}}`).
//! The views are those of `detect_dev` and of `anybox bench --seed <SEED>` alike (view `i` is
//! drawn from its scene index and the seed alone, `synth::generate_view`).

use anybox::config::Config;
use anybox::detect::detect_boxes;
use anybox::geom::iou::{iou, IouMethod};
use anybox::observation::observe;
use anybox::pose::estimate_pose;
use anybox::synth::{generate_view, Layout, NoiseModel, SynthConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let only = std::env::var("ONLY").unwrap_or_else(|_| "table-d0".into());
    let (layout, distractors) = match only.as_str() {
        "pallet" => (Layout::Pallet, None),
        "shelf" => (Layout::Shelf, None),
        "table-d8" => (Layout::Table, Some(8)),
        "table-d32" => (Layout::Table, Some(32)),
        "table-d0" => (Layout::Table, Some(0)),
        other => return Err(format!("ONLY: unknown set {other}").into()),
    };
    let views = env("VIEWS", 24) as u32;
    let sc = SynthConfig {
        layout,
        scenes: views,
        views: 1,
        distractors,
        seed: env("SEED", 2026),
        noise: NoiseModel::Realistic,
        ..SynthConfig::default()
    };
    let cfg: Config = match std::env::var("EST_CFG") {
        Ok(j) => serde_json::from_str(&j)?,
        Err(_) => Config::default(),
    };
    let (mut n, mut search, mut scoring, mut hidden) = (0, 0, 0, 0);
    for s in 0..views {
        let v = generate_view(&sc, s, 0);
        let dets = detect_boxes(Some(&v.rgb), &v.depth, &v.intrinsics, &cfg.detect)?;
        for (k, g) in v.boxes.iter().enumerate() {
            if g.visib_fract < 0.5 {
                continue;
            }
            let best = dets
                .iter()
                .map(|d| (d.mask.iou(&g.mask_visib), &d.mask))
                .max_by(|a, b| a.0.total_cmp(&b.0));
            let Some((mi, det)) = best.filter(|b| b.0 >= 0.5) else {
                continue;
            };
            n += 1;
            let Ok(e) = anybox::pipeline::estimate_box(&v.depth, &v.intrinsics, det, &cfg) else {
                continue;
            };
            let i3 = iou(&e.pose, &g.pose, IouMethod::Exact);
            if i3 >= 0.5 {
                continue;
            }
            let obs = observe(&v.depth, &v.intrinsics, det, &cfg.observation)?;
            let rescore = |b: &anybox::geom::OrientedBox| {
                estimate_pose(
                    &obs,
                    &v.depth,
                    &v.intrinsics,
                    &b.size_mm,
                    Some(b),
                    &cfg.pose,
                )
            };
            let (pe, pg) = (rescore(&e.pose)?, rescore(&g.pose)?);
            let kind = if pg.score > pe.score {
                search += 1;
                "SEARCH"
            } else {
                scoring += 1;
                "score"
            };
            let n_obs = e.observed_axes.iter().filter(|o| **o).count();
            hidden += usize::from(n_obs < 3);
            println!(
                "s{s} gt{k} mask {mi:.2} iou3d {i3:.2} obs {n_obs} est {:.3} gt {:.3} {kind} size {:.0?} gt {:.0?}",
                pe.score,
                pg.score,
                e.pose.size_mm.as_slice(),
                g.pose.size_mm.as_slice()
            );
            // The same box from its ground-truth mask, and how the two masks differ.
            if let Ok(eg) =
                anybox::pipeline::estimate_box(&v.depth, &v.intrinsics, &g.mask_visib, &cfg)
            {
                let pairs = || g.mask_visib.data.iter().zip(&det.data);
                let only_gt = pairs().filter(|(a, b)| **a && !**b).count();
                let only_det = pairs().filter(|(a, b)| !**a && **b).count();
                println!(
                    "  from the GT mask: iou3d {:.2} obs {:?} size {:.0?}; detection obs {:?}, \
                     depth penalty {:.3}; px only in GT {only_gt}, only in detection {only_det}",
                    iou(&eg.pose, &g.pose, IouMethod::Exact),
                    eg.observed_axes,
                    eg.pose.size_mm.as_slice(),
                    e.observed_axes,
                    e.depth_penalty,
                );
            }
        }
    }
    println!(
        "{only}: {n} boxes with a detection at mask IoU >= 0.5; {} estimated below 3D IoU 0.5: \
         {search} search, {scoring} scoring failures; {hidden} with an unobserved axis",
        search + scoring
    );
    Ok(())
}
