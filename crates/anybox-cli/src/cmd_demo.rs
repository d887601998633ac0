//! `anybox demo`: the README's first command. Generates a small mixed scene set with a fixed
//! seed, estimates every box from its ground-truth mask, prints the metric table and the time
//! per box, and writes overlay PNGs.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use clap::Args;

use anybox::eval::{evaluate, EstEntry, EvalOptions, GtEntry};
use anybox::overlay::{draw_boxes, OverlayBox};
use anybox::pipeline::estimate_frame;
use anybox::synth::{generate_views, Layout, NoiseModel, SynthConfig};

use crate::cmd_estimate::load_config;

/// Run the whole job on built-in generated scenes: no files needed.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for the overlay PNGs (created if missing).
    #[arg(long, default_value = "anybox-demo")]
    pub out: PathBuf,
    /// Number of generated scenes (pallet, table, shelf in turn).
    #[arg(long, default_value_t = 6)]
    pub scenes: u32,
    /// Generator seed.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
    /// Estimator configuration: a JSON file of anybox::config::Config's fields (missing =
    /// defaults).
    #[arg(long, value_name = "JSON")]
    pub config: Option<PathBuf>,
}

/// Ground truths below this visible fraction are not estimated (the evaluator's default).
const MIN_VISIB: f64 = 0.1;

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let config = load_config(args.config.as_deref())?;
    let synth = SynthConfig {
        layout: Layout::Mixed,
        scenes: args.scenes,
        views: 1,
        seed: args.seed,
        noise: NoiseModel::Realistic,
        ..SynthConfig::default()
    };
    let t0 = Instant::now();
    let views = generate_views(&synth);
    println!(
        "generated {} views ({} boxes) in {:.2} s",
        views.len(),
        views.iter().map(|v| v.boxes.len()).sum::<usize>(),
        t0.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the output folder", args.out.display()))?;
    let mut gts = Vec::new();
    let mut ests = Vec::new();
    let mut frame_ms = Vec::new();
    let mut failures = 0usize;
    for v in &views {
        let idx: Vec<usize> = (0..v.boxes.len())
            .filter(|&i| v.boxes[i].visib_fract >= MIN_VISIB)
            .collect();
        let masks: Vec<_> = idx.iter().map(|&i| v.boxes[i].mask_visib.clone()).collect();
        let start = Instant::now();
        let results = estimate_frame(&v.depth, &v.intrinsics, &masks, &config);
        frame_ms.push(start.elapsed().as_secs_f64() * 1e3);
        let mut overlay = Vec::new();
        for (i, b) in v.boxes.iter().enumerate() {
            gts.push(GtEntry {
                scene_id: v.scene_id,
                im_id: v.im_id,
                gt_index: i,
                pose: b.pose,
                visib_fract: b.visib_fract,
                observed_dims: None,
            });
        }
        for (&i, r) in idx.iter().zip(&results) {
            overlay.push(OverlayBox {
                pose: v.boxes[i].pose,
                colour: [40, 220, 40],
                label: false,
            });
            match r {
                Ok(e) => {
                    ests.push(EstEntry {
                        scene_id: v.scene_id,
                        im_id: v.im_id,
                        score: e.score,
                        pose: e.pose,
                        gt_index: Some(i),
                    });
                    overlay.push(OverlayBox {
                        pose: e.pose,
                        colour: [255, 220, 0],
                        label: true,
                    });
                }
                Err(_) => failures += 1,
            }
        }
        let mut img = v.rgb.clone();
        draw_boxes(&mut img, &v.intrinsics, &overlay);
        let path = args
            .out
            .join(format!("{:06}_{:06}_{}.png", v.scene_id, v.im_id, v.layout));
        anybox::io::image::write_rgb_png(&path, &img)?;
    }
    let report = evaluate(&gts, &ests, &EvalOptions::default());
    println!("\n{}", report.to_table());
    let n_boxes = ests.len() + failures;
    let total_ms: f64 = frame_ms.iter().sum();
    println!(
        "{} boxes estimated ({} failed) in {:.1} ms: {:.2} ms per box, {} threads",
        ests.len(),
        failures,
        total_ms,
        total_ms / n_boxes.max(1) as f64,
        rayon::current_num_threads()
    );
    println!(
        "overlays (green = ground truth, yellow = estimate with size in mm): {}",
        args.out
            .canonicalize()
            .unwrap_or_else(|_| args.out.clone())
            .display()
    );
    Ok(())
}
