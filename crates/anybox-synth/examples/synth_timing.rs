//! Times the generator and writes preview images.
//!
//! `cargo run --release -p anybox-synth --example synth_timing -- [OUT_DIR or -] [N_VIEWS]`
//! prints the time of one 640×480 view per layout and of N views (default 100, mixed layout),
//! and, when OUT_DIR is given, writes `LAYOUT_rgb.png`, `LAYOUT_depth.png` (grey, near = bright)
//! and `LAYOUT_masks.png` (visible masks in false colour) there.

use std::time::Instant;

use anybox_synth::{generate_view, Layout, NoiseModel, SynthConfig};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = args.get(1).filter(|s| !s.is_empty() && *s != "-").cloned();
    let n: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(100);
    for layout in [Layout::Pallet, Layout::Table, Layout::Shelf] {
        let cfg = SynthConfig {
            layout,
            noise: NoiseModel::Realistic,
            ..SynthConfig::default()
        };
        let t0 = Instant::now();
        let v = generate_view(&cfg, 0, 0);
        let dt = t0.elapsed().as_secs_f64();
        println!(
            "{layout}: one view {:.1} ms, {} boxes, {} distractors, camera {}, visib {:?}",
            dt * 1e3,
            v.boxes.len(),
            v.distractors,
            v.camera,
            v.boxes
                .iter()
                .map(|b| (b.visib_fract * 100.0).round() / 100.0)
                .collect::<Vec<_>>()
        );
        if let Some(dir) = &out {
            std::fs::create_dir_all(dir).expect("create preview dir");
            v.rgb
                .save(format!("{dir}/{layout}_rgb.png"))
                .expect("write rgb");
            let (w, h) = (v.depth.width, v.depth.height);
            let zmax = v.depth.depth_mm.iter().cloned().fold(1.0f32, f32::max);
            let grey = image::GrayImage::from_fn(w, h, |u, q| {
                let d = v.depth.depth_mm[(q * w + u) as usize];
                image::Luma([if d > 0.0 {
                    (255.0 * (1.0 - d / zmax)) as u8
                } else {
                    0
                }])
            });
            grey.save(format!("{dir}/{layout}_depth.png"))
                .expect("write depth");
            let mut m = image::RgbImage::new(w, h);
            for (i, b) in v.boxes.iter().enumerate() {
                let c = [
                    (i * 97 % 200 + 55) as u8,
                    (i * 57 % 200 + 55) as u8,
                    (i * 151 % 200 + 55) as u8,
                ];
                for q in 0..h {
                    for u in 0..w {
                        if b.mask_visib.get(u, q) {
                            m.put_pixel(u, q, image::Rgb(c));
                        }
                    }
                }
            }
            m.save(format!("{dir}/{layout}_masks.png"))
                .expect("write masks");
        }
    }
    let cfg = SynthConfig {
        layout: Layout::Mixed,
        scenes: n.div_ceil(4),
        views: 4,
        ..SynthConfig::default()
    };
    let t0 = Instant::now();
    let mut boxes = 0;
    let mut count = 0;
    'outer: for s in 0..cfg.scenes {
        for v in 0..cfg.views {
            if count == n {
                break 'outer;
            }
            boxes += generate_view(&cfg, s, v).boxes.len();
            count += 1;
        }
    }
    let dt = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let _ = anybox_synth::models(&SynthConfig { scenes: 200, ..cfg });
    println!(
        "model registry over 200 scenes: {:.1} ms",
        t1.elapsed().as_secs_f64() * 1e3
    );
    for layout in [Layout::Pallet, Layout::Table, Layout::Shelf] {
        let c = SynthConfig {
            layout,
            scenes: 12,
            views: 2,
            ..SynthConfig::default()
        };
        let views = anybox_synth::generate_views(&c);
        let all: Vec<&anybox_synth::SynthBox> = views.iter().flat_map(|v| v.boxes.iter()).collect();
        let big = all
            .iter()
            .filter(|b| b.bbox_obj[2] >= 40 && b.bbox_obj[3] >= 40)
            .count();
        let vis10 = all.iter().filter(|b| b.visib_fract >= 0.1).count();
        let vis50 = all.iter().filter(|b| b.visib_fract >= 0.5).count();
        let valid: f64 = views
            .iter()
            .map(|v| v.depth.valid_count() as f64 / (v.depth.width * v.depth.height) as f64)
            .sum::<f64>()
            / views.len() as f64;
        println!(
            "{layout}: {:.1} boxes/view, {:.0}% >= 40x40 px, {:.0}% visib>=0.1, {:.0}% visib>=0.5, valid depth {:.0}%, min boxes/view {}",
            all.len() as f64 / views.len() as f64,
            100.0 * big as f64 / all.len() as f64,
            100.0 * vis10 as f64 / all.len() as f64,
            100.0 * vis50 as f64 / all.len() as f64,
            100.0 * valid,
            views.iter().map(|v| v.boxes.len()).min().unwrap_or(0)
        );
    }
    println!(
        "{count} views (mixed, sequential calls): {:.2} s total, {:.1} ms/view, {boxes} boxes",
        dt,
        dt * 1e3 / count as f64
    );
}
