//! `anybox estimate`: dataset mode (BOP dataset + ground-truth masks) and single-frame mode
//! (RGB + depth + camera.json + caller masks).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use anybox::config::Config;
use anybox::io::bop::BopDataset;
use anybox::overlay::{draw_boxes, OverlayBox};
use anybox::runner::{
    run_dataset, run_detected_frame, run_frame, DatasetMasks, DatasetRunOptions, RunOutput,
};
use anybox::segmentation::{load_masks, MaskSource};

/// Estimate 9-DoF boxes. All lengths in files are millimetres: depth PNG value × depth_scale =
/// depth in mm; output `t` (box centre) and `size` are mm, `R` is row-major box→camera.
#[derive(Debug, Args)]
pub struct EstimateArgs {
    /// Dataset mode: the BOP dataset root (holds models_info.json and SPLIT/).
    #[arg(long, value_name = "DIR")]
    pub dataset: Option<PathBuf>,
    /// Dataset mode: the split to run on.
    #[arg(long, default_value = "test")]
    pub split: String,
    /// Masks. `detect`: the built-in zero-shot box detector (both modes). Dataset mode: `gt`
    /// (the dataset's mask_visib). Single-frame mode: instance PNG files, a folder of them, one
    /// label image (each non-zero value an instance), or a COCO-RLE JSON as SAM-6D's
    /// detection_ism.json (its scores carry through).
    #[arg(long, num_args = 1.., value_name = "MASKS", required = true)]
    pub masks: Vec<PathBuf>,
    /// Dataset mode: skip ground truths whose visible fraction is below this.
    #[arg(long, default_value_t = 0.1, value_name = "F")]
    pub min_visib: f64,
    /// Single-frame mode: colour image (PNG/JPEG); optional, used for the overlay.
    #[arg(long, value_name = "PNG")]
    pub rgb: Option<PathBuf>,
    /// Single-frame mode: uint16 depth PNG (value × depth_scale = mm).
    #[arg(long, value_name = "PNG")]
    pub depth: Option<PathBuf>,
    /// Single-frame mode: camera.json with `cam_K` (px, row-major) and `depth_scale` (→ mm).
    #[arg(long, value_name = "JSON")]
    pub camera: Option<PathBuf>,
    /// Results JSON: {"estimates": [{scene_id, im_id, score, R, t (mm), size (mm), time (s), gt_index}]}.
    #[arg(long, value_name = "JSON")]
    pub out: PathBuf,
    /// Also write a BOP19 results CSV (t in mm, time per image in s).
    #[arg(long, value_name = "CSV")]
    pub bop_csv: Option<PathBuf>,
    /// Single-frame mode: write an overlay PNG (wireframes, axes, sizes in mm).
    #[arg(long, value_name = "PNG")]
    pub overlay: Option<PathBuf>,
    /// Estimator configuration: a JSON file of anybox::config::Config's fields (missing =
    /// defaults; an unknown field is an error).
    #[arg(long, value_name = "JSON")]
    pub config: Option<PathBuf>,
}

pub fn load_config(path: Option<&Path>) -> anyhow::Result<Config> {
    match path {
        None => Ok(Config::default()),
        Some(p) => {
            // `--config '{"detect": ...}'` is a natural mistake: say what is expected.
            if !p.exists() && p.to_string_lossy().trim_start().starts_with('{') {
                anyhow::bail!(
                    "--config takes the path of a JSON file, not the JSON itself: write {} to a \
                     file and pass its path",
                    p.display()
                );
            }
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("{}: cannot read config", p.display()))?;
            serde_json::from_str(&text)
                .with_context(|| format!("{}: invalid config JSON", p.display()))
        }
    }
}

pub fn run(args: &EstimateArgs) -> anyhow::Result<()> {
    let config = load_config(args.config.as_deref())?;
    let output = match &args.dataset {
        Some(root) => estimate_dataset(args, root, config)?,
        None => run_single(args, config)?,
    };
    for f in &output.failures {
        eprintln!(
            "warning: no estimate for scene {} image {}{}{}: {}",
            f.scene_id,
            f.im_id,
            f.gt_index.map(|g| format!(" gt {g}")).unwrap_or_default(),
            f.mask
                .as_ref()
                .map(|m| format!(" ({m})"))
                .unwrap_or_default(),
            f.error
        );
    }
    let json = serde_json::to_vec_pretty(&output)?;
    anybox::io::write_atomic(&args.out, &json)?;
    if let Some(csv) = &args.bop_csv {
        anybox::io::results::write_bop19_csv(csv, &output.estimates)?;
    }
    println!(
        "{} boxes estimated, {} failed; results written to {}",
        output.estimates.len(),
        output.failures.len(),
        args.out.display()
    );
    Ok(())
}

fn estimate_dataset(args: &EstimateArgs, root: &Path, config: Config) -> anyhow::Result<RunOutput> {
    let masks = match MaskSource::from_paths(&args.masks)? {
        MaskSource::GroundTruth => DatasetMasks::GroundTruth,
        MaskSource::Detect => DatasetMasks::Detect,
        _ => bail!("dataset mode takes --masks gt (the dataset's mask_visib) or --masks detect"),
    };
    if args.rgb.is_some() || args.depth.is_some() || args.camera.is_some() {
        bail!("--rgb/--depth/--camera are for single-frame mode; drop --dataset or them");
    }
    if args.overlay.is_some() {
        bail!("--overlay is for single-frame mode");
    }
    let ds = BopDataset::open(root, &args.split)?;
    let bar = ProgressBar::new(ds.views.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} views  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let opts = DatasetRunOptions {
        masks,
        min_visib: args.min_visib,
        config,
    };
    let out = run_dataset(&ds, &opts, &|| bar.inc(1));
    bar.finish_and_clear();
    Ok(out)
}

fn run_single(args: &EstimateArgs, config: Config) -> anyhow::Result<RunOutput> {
    let (Some(depth), Some(camera)) = (&args.depth, &args.camera) else {
        bail!("single-frame mode needs --depth and --camera (or use --dataset DIR)");
    };
    let frame = anybox::io::read_frame(args.rgb.as_deref(), depth, camera)?;
    let source = MaskSource::from_paths(&args.masks)?;
    let out = match source {
        MaskSource::Detect => {
            run_detected_frame(frame.rgb.as_ref(), &frame.depth, &frame.intrinsics, &config)?
        }
        _ => {
            let masks = load_masks(&source, frame.depth.width, frame.depth.height)?;
            run_frame(&frame.depth, &frame.intrinsics, &masks, &config)
        }
    };
    if let Some(path) = &args.overlay {
        let mut img = match &frame.rgb {
            Some(rgb) => rgb.clone(),
            None => anybox::overlay::depth_to_rgb(&frame.depth),
        };
        let boxes: Vec<OverlayBox> = out
            .estimates
            .iter()
            // One reading per box in the picture: alternatives overlap their parts.
            .filter(|e| e.extra.get("alternative").is_none())
            .filter_map(|e| e.pose().ok())
            .map(|pose| OverlayBox {
                pose,
                colour: [255, 220, 0],
                label: true,
            })
            .collect();
        draw_boxes(&mut img, &frame.intrinsics, &boxes);
        anybox::io::image::write_rgb_png(path, &img)?;
        println!("overlay written to {}", path.display());
    }
    Ok(out)
}
