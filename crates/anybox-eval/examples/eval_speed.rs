//! Times `evaluate` on a synthetic set: `cargo run --release -p anybox-eval --example eval_speed
//! [images] [boxes_per_image]` (defaults 200 × 12). Estimates are the truths perturbed by a
//! few mm and degrees, plus one false positive per image.

use std::time::Instant;

use anybox_eval::{evaluate, EstEntry, EvalOptions, GtEntry};
use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::OrientedBox;

fn main() {
    let mut args = std::env::args().skip(1);
    let images: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(200);
    let per: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(12);
    let mut state = 42u64;
    let mut rnd = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut gts = Vec::new();
    let mut ests = Vec::new();
    for im in 0..images {
        for i in 0..per {
            let size = Vector3::new(
                100.0 + 200.0 * rnd(),
                100.0 + 200.0 * rnd(),
                80.0 + 150.0 * rnd(),
            );
            // A 4 x 3 grid of touching-ish boxes.
            let c = Vector3::new(
                (i % 4) as f64 * 320.0 - 480.0,
                (i / 4) as f64 * 320.0 - 320.0,
                1500.0,
            );
            let r = Rotation3::from_euler_angles(rnd() - 0.5, rnd() - 0.5, rnd() * 3.0);
            let pose = OrientedBox::new(r, c, size).expect("positive size");
            gts.push(GtEntry {
                scene_id: im / 10,
                im_id: im % 10,
                gt_index: i,
                pose,
                visib_fract: rnd(),
                observed_dims: None,
            });
            let mut e = pose;
            e.center_mm += Vector3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 40.0;
            e.rotation *= Rotation3::from_euler_angles(0.1 * rnd(), 0.1 * rnd(), 0.1 * rnd());
            e.size_mm += Vector3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 30.0;
            ests.push(EstEntry {
                scene_id: im / 10,
                im_id: im % 10,
                score: rnd(),
                pose: e,
                gt_index: Some(i),
            });
        }
    }
    let opts = EvalOptions::default();
    let t0 = Instant::now();
    let r = evaluate(&gts, &ests, &opts);
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "{} GTs, {} estimates, {} images: evaluate {:.3} s ({:.1} µs per estimate), threads {}",
        gts.len(),
        ests.len(),
        images,
        dt,
        1e6 * dt / ests.len() as f64,
        rayon::current_num_threads()
    );
    println!(
        "{}",
        r.to_table().lines().take(20).collect::<Vec<_>>().join("\n")
    );
}
