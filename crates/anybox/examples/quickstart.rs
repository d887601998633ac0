//! The library in a dozen lines: generate one table scene, estimate every box from its visible
//! mask, and compare with the ground truth.
//!
//! `cargo run --release -p anybox --example quickstart`

use anybox::config::Config;
use anybox::geom::iou::{iou, IouMethod};
use anybox::pipeline::estimate_frame;
use anybox::synth::{generate_view, Layout, SynthConfig};

fn main() {
    let synth = SynthConfig {
        layout: Layout::Table,
        ..SynthConfig::default()
    };
    let view = generate_view(&synth, 0, 0);
    let masks: Vec<_> = view.boxes.iter().map(|b| b.mask_visib.clone()).collect();
    let results = estimate_frame(&view.depth, &view.intrinsics, &masks, &Config::default());
    for (truth, result) in view.boxes.iter().zip(results) {
        match result {
            Ok(est) => {
                let s = est.pose.size_mm;
                // Both in the canonical axis order, so the sizes line up.
                let t = anybox::geom::symmetry::canonicalize(&truth.pose).size_mm;
                println!(
                    "size {:5.0} x {:5.0} x {:5.0} mm (true {:5.0} x {:5.0} x {:5.0}), 3D IoU {:.2}, score {:.2}, visible {:.0}%",
                    s.x, s.y, s.z, t.x, t.y, t.z,
                    iou(&est.pose, &truth.pose, IouMethod::Exact),
                    est.score,
                    100.0 * truth.visib_fract
                );
            }
            Err(e) => println!("no estimate: {e}"),
        }
    }
}
