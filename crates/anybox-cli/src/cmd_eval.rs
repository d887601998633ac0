//! `anybox eval`: score a results file against a BOP dataset split (SPEC §4).

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;

use anybox::eval::{evaluate_dataset, EvalOptions};
use anybox::geom::iou::IouMethod;

/// Evaluate 9-DoF box estimates against BOP ground truth: detection AP at 3D IoU 0.25, 0.5,
/// 0.7, 0.75, 0.8, 0.9; pose AP (single threshold and PACE-averaged); ADD-S AP at 0.1d/0.15d;
/// size error (median, p90, mm); broken down by scene and visibility band. Poses in mm, OpenCV
/// camera frame; results JSON holds `scene_id, im_id, score, R (row-major), t (mm), size (mm)`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// BOP dataset root (holds models_info.json and the split folder).
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    /// Split to evaluate.
    #[arg(long, default_value = "test")]
    pub split: String,
    /// anybox results JSON (`{"estimates": [...]}`).
    #[arg(long, value_name = "FILE")]
    pub results: PathBuf,
    /// 3D IoU variant: exact (oriented boxes), aabb (camera-frame axis-aligned hulls, "CATRE"),
    /// nocs-legacy (NOCS's original code, for comparing with published NOCS/HouseCat6D figures).
    #[arg(long, default_value = "exact", value_name = "exact|aabb|nocs-legacy")]
    pub iou: IouMethod,
    /// Ground truths with visib_fract below this are ignored (neither misses nor matches).
    #[arg(long, default_value_t = 0.1, value_name = "F")]
    pub min_visib: f64,
    /// Ignore ground truths whose view shows fewer than N of their dimensions (0 = off;
    /// computed by ray-casting the true box at the visible-mask pixels).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub min_observed_dims: u8,
    /// NOCS `use_matches_for_pose`: drop estimates and ground truths not matched at IoU 0.1
    /// before pose and ADD-S matching.
    #[arg(long)]
    pub pose_gating: bool,
    /// Also write the report as JSON to this file (written atomically).
    #[arg(long, value_name = "OUT")]
    pub json: Option<PathBuf>,
}

/// Runs `anybox eval`: prints the table and writes `--json` when given.
pub fn run(args: &EvalArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (0.0..=1.0).contains(&args.min_visib),
        "--min-visib must be in 0..=1, got {}",
        args.min_visib
    );
    anyhow::ensure!(
        args.min_observed_dims <= 3,
        "--min-observed-dims must be 0..=3, got {}",
        args.min_observed_dims
    );
    let opts = EvalOptions {
        iou: args.iou,
        min_visib: args.min_visib,
        pose_gating: args.pose_gating,
        min_observed_dims: args.min_observed_dims,
    };
    let report =
        evaluate_dataset(&args.dataset, &args.split, &args.results, &opts).with_context(|| {
            format!(
                "evaluating {} against {} (split {})",
                args.results.display(),
                args.dataset.display(),
                args.split
            )
        })?;
    println!("{}", report.to_table());
    if let Some(out) = &args.json {
        let text = serde_json::to_string_pretty(&report).context("serialising the report")?;
        anybox::io::write_atomic(out, text.as_bytes())
            .with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
