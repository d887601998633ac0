//! Times the evaluator's per-pair geometry: `cargo run --release -p anybox-geom --example geom_timing`.
//!
//! Prints microseconds per call for exact / aabb / nocs-legacy IoU, the axis matching
//! (rotation + size error) and ADD-S with 1000 samples, on random overlapping box pairs.

use std::time::Instant;

use anybox_geom::adds::adds_mm;
use anybox_geom::iou::{iou, IouMethod};
use anybox_geom::nalgebra::{Rotation3, Vector3};
use anybox_geom::symmetry::match_axes;
use anybox_geom::OrientedBox;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_box(rng: &mut ChaCha8Rng, centre: Vector3<f64>) -> OrientedBox {
    let mut u = || rng.random::<f64>();
    let r = Rotation3::new(Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 6.4);
    let s = Vector3::new(50.0 + 300.0 * u(), 50.0 + 300.0 * u(), 50.0 + 300.0 * u());
    let c = centre + Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 150.0;
    // Sizes are in [50, 350] mm, so the constructor cannot fail.
    OrientedBox::new(r, c, s).expect("positive finite size")
}

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let n = 20_000;
    let pairs: Vec<(OrientedBox, OrientedBox)> = (0..n)
        .map(|_| {
            let a = random_box(&mut rng, Vector3::new(0.0, 0.0, 1000.0));
            let b = random_box(&mut rng, a.center_mm);
            (a, b)
        })
        .collect();
    for m in IouMethod::ALL {
        let t = Instant::now();
        let s: f64 = pairs.iter().map(|(a, b)| iou(a, b, m)).sum();
        let us = t.elapsed().as_secs_f64() * 1e6 / n as f64;
        println!(
            "iou {m:<12} {us:8.3} us/pair (mean IoU {:.3})",
            s / n as f64
        );
    }
    let t = Instant::now();
    let s: f64 = pairs
        .iter()
        .map(|(a, b)| match_axes(a, b).rotation_error_deg)
        .sum();
    let us = t.elapsed().as_secs_f64() * 1e6 / n as f64;
    println!(
        "match_axes       {us:8.3} us/pair (mean rot err {:.1} deg)",
        s / n as f64
    );
    let m = 2000;
    let t = Instant::now();
    let s: f64 = pairs.iter().take(m).map(|(a, b)| adds_mm(a, b, 1000)).sum();
    let us = t.elapsed().as_secs_f64() * 1e6 / m as f64;
    println!(
        "adds_mm (1000)   {us:8.3} us/pair (mean {:.1} mm)",
        s / m as f64
    );
}
