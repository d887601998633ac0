//! `anybox bench`: every estimator variant on the same instances, as a markdown table.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;

use anybox::bench::{
    bop_set, default_variants, detection_sets, detection_table, markdown_table, run_detection,
    run_variant, seed_summary_table, synthetic_set, BenchSet,
};
use anybox::io::bop::BopDataset;

/// Benchmark the estimator variants (full, no depth filter, no early stopping, canonical size,
/// oracle size, our own modes) on a generated benchmark and on ycbv-boxes. Ground-truth masks;
/// sizes and errors in mm; time per box single-threaded, frame time with all cores.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Run on this BOP dataset instead of the generated benchmark.
    #[arg(long, value_name = "DIR")]
    pub dataset: Option<PathBuf>,
    /// Split of --dataset.
    #[arg(long, default_value = "test")]
    pub split: String,
    /// The real ycbv-boxes dataset (skipped with a note when absent).
    #[arg(long, value_name = "DIR", default_value = "../shared/data/ycbv-boxes")]
    pub ycbv: PathBuf,
    /// Seed of the generated benchmark.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Minimum number of boxes in the generated benchmark.
    #[arg(long, default_value_t = 150)]
    pub instances: usize,
    /// Only boxes with at least this visible fraction are estimated and counted.
    #[arg(long, default_value_t = 0.5, value_name = "F")]
    pub min_visib: f64,
    /// Only run the variants whose name contains this text.
    #[arg(long)]
    pub only: Option<String>,
    /// Generated views per detection set (pallet; table with 0, 8, 32 distractors; shelf).
    /// 24 by default: with 8, AP@0.5 of one set moved by up to 0.2 between view samples.
    #[arg(long, default_value_t = 24, value_name = "N")]
    pub detect_frames: usize,
    /// Runs of each detection frame; its time is the fastest (interference on a shared machine
    /// only adds time). The accuracy columns do not depend on it.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub detect_reps: usize,
    /// Skip the detection rows (`--masks detect`).
    #[arg(long)]
    pub no_detect: bool,
    /// Only the detection rows: no estimator variant tables (and no generated set for them).
    #[arg(long, conflicts_with_all = ["dataset", "only", "no_detect"])]
    pub detect_only: bool,
    /// Run the generated detection rows on each of these seeds (comma-separated, e.g.
    /// `2026,7,11`) instead of `--seed` alone, and end with a table of AP@0.5 per set and seed
    /// and the means over the seeds. Judge a change on seeds it was not chosen on.
    #[arg(long, value_name = "S,S,...", value_delimiter = ',', num_args = 1..)]
    pub detect_seeds: Vec<u64>,
    /// Also write the markdown to this file.
    #[arg(long, value_name = "MD")]
    pub markdown: Option<PathBuf>,
    /// Configuration of the detection rows: a JSON file of anybox::config::Config's fields
    /// (e.g. holding `{"detect": {"blobs": false}}`; missing = defaults). The variant rows keep
    /// their own.
    #[arg(long, value_name = "JSON")]
    pub config: Option<PathBuf>,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let mut sets: Vec<BenchSet> = Vec::new();
    match &args.dataset {
        _ if args.detect_only => {}
        Some(root) => {
            let ds = BopDataset::open(root, &args.split)?;
            sets.push(bop_set(&ds, &root.display().to_string(), args.min_visib)?);
        }
        None => {
            eprintln!("generating the benchmark (seed {}) …", args.seed);
            sets.push(synthetic_set(args.seed, args.instances, args.min_visib));
        }
    }
    if args.ycbv.join("test").is_dir() {
        let ds = BopDataset::open(&args.ycbv, "test")?;
        sets.push(bop_set(&ds, "ycbv-boxes (real, Asus Xtion)", 0.1)?);
    } else {
        eprintln!(
            "note: {} not found; skipping the ycbv-boxes table",
            args.ycbv.display()
        );
    }
    let variants: Vec<_> = default_variants()
        .into_iter()
        .filter(|v| {
            !args.detect_only
                && args
                    .only
                    .as_ref()
                    .is_none_or(|o| v.name.contains(o.as_str()))
        })
        .collect();
    let mut md = String::new();
    for set in sets.iter().filter(|_| !variants.is_empty()) {
        let min_visib = if set.name.starts_with("ycbv") {
            0.1
        } else {
            args.min_visib
        };
        let mut results = Vec::new();
        for v in &variants {
            eprintln!("{}: {} …", set.name, v.name);
            results.push(run_variant(set, v, min_visib));
        }
        let table = markdown_table(set, &results);
        println!("{table}");
        md.push_str(&table);
        md.push('\n');
    }
    if !args.no_detect {
        let config = crate::cmd_estimate::load_config(args.config.as_deref())?;
        let seeds = if args.detect_seeds.is_empty() {
            vec![args.seed]
        } else {
            args.detect_seeds.clone()
        };
        let mut table = String::new();
        let mut per_seed = Vec::new();
        for &seed in &seeds {
            let mut rows = Vec::new();
            for set in detection_sets(seed, args.detect_frames) {
                eprintln!("detection (seed {seed}): {} …", set.name);
                rows.push(run_detection(
                    &set,
                    &config,
                    args.min_visib,
                    args.detect_reps,
                ));
            }
            let title = format!(
                "Detection, generated (realistic noise, seed {seed}, visib >= {})",
                args.min_visib
            );
            if !table.is_empty() {
                table.push('\n');
            }
            table.push_str(&detection_table(&title, &rows));
            per_seed.push((seed, rows.iter().map(|r| r.aps()).collect::<Vec<_>>()));
        }
        if !args.detect_seeds.is_empty() {
            table.push('\n');
            table.push_str(&seed_summary_table(&per_seed));
        }
        if let Some(ycbv) = sets.iter().find(|s| s.name.starts_with("ycbv")) {
            eprintln!("detection: {} …", ycbv.name);
            let row = run_detection(ycbv, &config, 0.1, args.detect_reps);
            table.push('\n');
            table.push_str(&detection_table("Detection, ycbv-boxes (real)", &[row]));
        }
        println!("{table}");
        md.push_str(&table);
    }
    if let Some(p) = &args.markdown {
        anybox::io::write_atomic(p, md.as_bytes())
            .with_context(|| format!("{}: cannot write markdown", p.display()))?;
    }
    Ok(())
}
