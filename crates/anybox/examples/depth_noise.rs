//! Depth roughness of generated views and of a BOP dataset's frames: the second difference
//! of depth along image rows at a 2 px step, `z[u-2] − 2 z[u] + z[u+2]` (mm), over pixels with
//! all three depths valid, between `NEAR_MM` and `FAR_MM` (default 500 and 1100), leaving out
//! steps over 30 mm (edges). On a plane seen head-on it is zero but for noise and
//! quantisation, so its mean, 90th percentile and share of zeros compare sensors.
//!
//! `cargo run --release -p anybox --example depth_noise -- [views-per-set] [bop-root]`
//! (defaults 12 and `../shared/data/ycbv-boxes`; generated sets with seed `SEED`, default
//! 2026).

use std::path::PathBuf;

use anybox::io::DepthMap;
use anybox::synth::{generate_view, Layout, NoiseModel, SynthConfig};

/// `(mean |d2|, p90 |d2|, share of zeros, samples)`; `None` without samples.
fn roughness(d: &DepthMap, near_mm: f64, far_mm: f64) -> Option<(f64, f64, f64, usize)> {
    let (w, h) = (d.width as usize, d.height as usize);
    let mut v: Vec<f64> = Vec::new();
    for y in 0..h {
        for x in 2..w.saturating_sub(2) {
            let i = y * w + x;
            let (a, b, c) = (
                d.depth_mm[i - 2] as f64,
                d.depth_mm[i] as f64,
                d.depth_mm[i + 2] as f64,
            );
            if a <= 0.0 || c <= 0.0 || b < near_mm || b > far_mm {
                continue;
            }
            let d2 = (a - 2.0 * b + c).abs();
            if d2 <= 30.0 {
                v.push(d2);
            }
        }
    }
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let zeros = v.iter().filter(|x| **x < 0.5).count() as f64 / v.len() as f64;
    Some((mean, v[v.len() * 9 / 10], zeros, v.len()))
}

fn line(name: &str, d: &DepthMap, near: f64, far: f64) {
    match roughness(d, near, far) {
        Some((m, p90, z, n)) => {
            println!("{name:14} mean {m:5.2} mm  p90 {p90:4.1} mm  zeros {z:.2}  samples {n}")
        }
        None => println!("{name:14} no depth between {near} and {far} mm"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let views: u32 = args.get(1).and_then(|x| x.parse().ok()).unwrap_or(12);
    let root = PathBuf::from(
        args.get(2)
            .map_or("../shared/data/ycbv-boxes", |s| s.as_str()),
    );
    let env = |k: &str, d: f64| {
        std::env::var(k)
            .ok()
            .and_then(|x| x.parse().ok())
            .unwrap_or(d)
    };
    let (near, far) = (env("NEAR_MM", 500.0), env("FAR_MM", 1100.0));
    let seed = env("SEED", 2026.0) as u64;
    for (name, layout, distractors) in [
        ("table-d0", Layout::Table, Some(0)),
        ("pallet", Layout::Pallet, None),
        ("shelf", Layout::Shelf, None),
    ] {
        let sc = SynthConfig {
            layout,
            scenes: views,
            views: 1,
            distractors,
            seed,
            noise: NoiseModel::Realistic,
            ..SynthConfig::default()
        };
        for s in 0..views {
            line(
                &format!("{name} {s}"),
                &generate_view(&sc, s, 0).depth,
                near,
                far,
            );
        }
    }
    match anybox::io::bop::BopDataset::open(&root, "test") {
        Ok(ds) => {
            for (i, view) in ds.views.iter().enumerate() {
                match view.load_frame() {
                    Ok(f) => line(&format!("bop {i}"), &f.depth, near, far),
                    Err(e) => println!("bop {i}: {e}"),
                }
            }
        }
        Err(e) => println!("{}: {e}", root.display()),
    }
}
