//! Size diagnostics of a configuration on the synthetic bench set: per box IoU, per-axis size
//! error, layout, observed flags (estimate vs evaluator), hidden-extent source and score.
//!
//! `cargo run --release -p anybox --example size_diag -- [seed] [paper]`
//!
//! `DETECT_SET=<text>` runs on the ground-truth masks of the detection sets of `anybox bench`
//! instead (`bench::detection_sets`, the first whose name contains the text, e.g. `"table, 0"`;
//! `FRAMES=<n>` views, default 48; boxes with a visible fraction of at least 0.5, as the bench
//! counts them). Last, per hidden-extent source of the box's axes (`O` all observed, else the
//! sources other than observed), how many boxes and how many below 3D IoU 0.5.

use anybox::bench::{detection_sets, synthetic_set};
use anybox::config::Config;
use anybox::geom::iou::{iou, IouMethod};
use anybox::pipeline::estimate_box_traced;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2026);
    let mut cfg = if args.iter().any(|a| a == "paper") {
        Config::paper()
    } else {
        Config::default()
    };
    // DIAG_CFG: a JSON config patch (fields not named keep the defaults above).
    if let Ok(j) = std::env::var("DIAG_CFG") {
        let mut v = serde_json::to_value(&cfg).expect("config serialises");
        let patch: serde_json::Value = serde_json::from_str(&j).expect("DIAG_CFG is JSON");
        merge(&mut v, &patch);
        cfg = serde_json::from_value(v).expect("patched config");
    }
    let set = match std::env::var("DETECT_SET") {
        Ok(name) => {
            let frames = std::env::var("FRAMES")
                .ok()
                .and_then(|f| f.parse().ok())
                .unwrap_or(48);
            detection_sets(seed, frames)
                .into_iter()
                .find(|s| s.name.contains(&name))
                .expect("DETECT_SET names a detection set")
        }
        Err(_) => synthetic_set(seed, 150, 0.5),
    };
    // Per source kind: boxes, and boxes below 3D IoU 0.5.
    let mut tally = std::collections::BTreeMap::<String, (usize, usize)>::new();
    println!("layout scene idx dims iou score | gt size | est size (gt-axis order) | err | est_obs gt_obs src");
    for f in &set.frames {
        for inst in f.instances.iter().filter(|i| i.visib_fract >= 0.5) {
            let gt = inst.gt;
            let od = anybox::eval::observed_dims(&gt, &inst.mask, &f.intrinsics);
            match estimate_box_traced(&f.depth, &f.intrinsics, &inst.mask, &cfg) {
                Ok((e, tr)) => {
                    let i = iou(&e.pose, &gt, IouMethod::Exact);
                    // Map estimate axes onto gt axes.
                    let mut est = [0.0; 3];
                    let mut eo = ['?'; 3];
                    let mut src = ['?'; 3];
                    for j in 0..3 {
                        let g = gt.axis(j);
                        let mut b = 0;
                        for k in 1..3 {
                            if e.pose.axis(k).dot(&g).abs() > e.pose.axis(b).dot(&g).abs() {
                                b = k;
                            }
                        }
                        est[j] = e.pose.size_mm[b];
                        eo[j] = if e.observed_axes[b] { 'o' } else { 'h' };
                        src[j] = match tr.sources[b] {
                            anybox::context::HiddenSource::Observed => 'O',
                            anybox::context::HiddenSource::Support => 'S',
                            anybox::context::HiddenSource::Neighbour => 'N',
                            anybox::context::HiddenSource::Fallback => 'F',
                        };
                    }
                    let px = anybox::silhouette::mask_pixels(&inst.mask);
                    let inputs = anybox::scale::ScaleInputs {
                        intrinsics: &f.intrinsics,
                        depth: &f.depth,
                        mask_pixels: &px,
                        points_mm: &[],
                        normals: &[],
                        start_size_mm: None,
                    };
                    let mut lb = ['-'; 3];
                    if let Some(d) = anybox::silhouette::axis_directions(&e.pose, &f.intrinsics) {
                        let mut sc = Vec::new();
                        let o = anybox::scale::observed_extents_checked(
                            &inputs, &d, &cfg.scale, &mut sc,
                        );
                        for j in 0..3 {
                            let g = gt.axis(j);
                            let mut b = 0;
                            for k in 1..3 {
                                if e.pose.axis(k).dot(&g).abs() > e.pose.axis(b).dot(&g).abs() {
                                    b = k;
                                }
                            }
                            if o.lower_bound_only[b] {
                                lb[j] = 'L';
                            }
                        }
                    }
                    let mut sup = [-1.0f64; 3];
                    let mut cop = [-1.0f64; 3];
                    let mut vis = [0.0f64; 3];
                    let view = e.pose.center_mm.normalize();
                    if let Ok(obs) = anybox::observation::observe(
                        &f.depth,
                        &f.intrinsics,
                        &inst.mask,
                        &cfg.observation,
                    ) {
                        for j in 0..3 {
                            let g = gt.axis(j);
                            let mut b = 0;
                            for k in 1..3 {
                                if e.pose.axis(k).dot(&g).abs() > e.pose.axis(b).dot(&g).abs() {
                                    b = k;
                                }
                            }
                            vis[j] = (0..3)
                                .filter(|&c| c != b)
                                .map(|c| e.pose.axis(c).dot(&view).abs())
                                .fold(0.0, f64::max);
                            if let Some(su) = anybox::context::find_support(
                                &e.pose,
                                b,
                                &obs.points_mm,
                                &f.depth,
                                &f.intrinsics,
                                &inst.mask,
                                &cfg.context,
                            ) {
                                sup[j] = su.offset_mm;
                                cop[j] = su.coplanar_fraction;
                            }
                        }
                    }
                    let mut kind: Vec<char> = src.iter().copied().filter(|c| *c != 'O').collect();
                    kind.sort_unstable();
                    kind.dedup();
                    let kind: String = if kind.is_empty() {
                        "O".into()
                    } else {
                        kind.into_iter().collect()
                    };
                    let t = tally.entry(kind).or_default();
                    t.0 += 1;
                    t.1 += usize::from(i < 0.5);
                    let go: String = od.axes.iter().map(|a| if *a { 'o' } else { 'h' }).collect();
                    println!(
                        "{:6} {:3} {:2} {} {:.3} {:.3} | {:4.0} {:4.0} {:4.0} | {:4.0} {:4.0} {:4.0} | {:+5.0} {:+5.0} {:+5.0} | {} {} {} {} vis {:.2} sup {:.0} {:.0} {:.0} cop {:.2} {:.2} {:.2} fv {:.2} {:.2} {:.2} it {} pc {} es {}",
                        f.layout,
                        f.scene_id,
                        inst.gt_index,
                        od.count,
                        i,
                        e.score,
                        gt.size_mm.x,
                        gt.size_mm.y,
                        gt.size_mm.z,
                        est[0],
                        est[1],
                        est[2],
                        est[0] - gt.size_mm.x,
                        est[1] - gt.size_mm.y,
                        est[2] - gt.size_mm.z,
                        eo.iter().collect::<String>(),
                        go,
                        src.iter().collect::<String>(),
                        lb.iter().collect::<String>(),
                        inst.visib_fract,
                        sup[0],
                        sup[1],
                        sup[2],
                        cop[0],
                        cop[1],
                        cop[2],
                        vis[0],
                        vis[1],
                        vis[2],
                        e.iterations,
                        e.pose_calls,
                        e.stopped_early,
                    );
                }
                Err(err) => println!(
                    "{:6} {:3} {:2} FAIL {err}",
                    f.layout, f.scene_id, inst.gt_index
                ),
            }
        }
    }
    for (kind, (n, below)) in tally {
        println!("sources {kind}: {n} boxes, {below} below 3D IoU 0.5");
    }
}

fn merge(a: &mut serde_json::Value, b: &serde_json::Value) {
    match (a, b) {
        (serde_json::Value::Object(a), serde_json::Value::Object(b)) => {
            for (k, v) in b {
                merge(a.entry(k.clone()).or_insert(serde_json::Value::Null), v);
            }
        }
        (a, b) => *a = b.clone(),
    }
}
