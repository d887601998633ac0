//! The `anybox` command-line tool. It only parses arguments, calls the library and prints.
//!
//! Units: millimetres in every file (depth PNG value × depth_scale = mm; box `t` and `size` in
//! mm), pixels for intrinsics, seconds for times. Camera: OpenCV (x right, y down, z forward).

use clap::{Parser, Subcommand};

mod cmd_bench;
mod cmd_demo;
mod cmd_estimate;
mod cmd_eval;
mod cmd_synth;

/// anybox — zero-shot 9-DoF box pose and size from one RGB-D frame, on a CPU.
///
/// Files use millimetres (as BOP): depth PNG value × depth_scale = depth in mm; a box is R
/// (row-major, box→camera), t (box centre, mm) and size (full extents, mm). Camera: OpenCV
/// pinhole, x right, y down, z forward, intrinsics in pixels.
#[derive(Debug, Parser)]
#[command(name = "anybox", version)]
struct Cli {
    /// Worker threads (default: all cores).
    #[arg(long, global = true, value_name = "N")]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Generate scenes, estimate every box, print accuracy and time, write overlays (no files needed).
    Demo(cmd_demo::DemoArgs),
    /// Estimate boxes on a BOP dataset (--dataset) or on one frame (--rgb/--depth/--camera).
    Estimate(cmd_estimate::EstimateArgs),
    /// Compare the estimator variants on a generated benchmark and on ycbv-boxes.
    Bench(cmd_bench::BenchArgs),
    /// Score a results file against a BOP dataset (SPEC §4 metrics).
    Eval(cmd_eval::EvalArgs),
    /// Write a synthetic warehouse-like BOP dataset.
    Synth(cmd_synth::SynthArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()?;
    }
    match &cli.command {
        Command::Demo(a) => cmd_demo::run(a),
        Command::Estimate(a) => cmd_estimate::run(a),
        Command::Bench(a) => cmd_bench::run(a),
        Command::Eval(a) => cmd_eval::run(a),
        Command::Synth(a) => cmd_synth::run(a),
    }
}
