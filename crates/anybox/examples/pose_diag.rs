//! Pose diagnostic (helper POSE2): per-box rotation error, centre error, IoU, layout, visible
//! fraction and score on the synthetic bench set, for the oracle size and the default config,
//! plus Spearman(score, IoU) and the per-box time.
//!
//! `cargo run --release -p anybox --example pose_diag -- [seed] [oracle|default] [verbose]`

use std::time::Instant;

use anybox::bench::synthetic_set;
use anybox::config::Config;
use anybox::geom::iou::{iou, IouMethod};
use anybox::geom::symmetry::rotation_error_deg;
use anybox::pipeline::estimate_box;

fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        for k in i..=j {
            r[idx[k]] = (i + j) as f64 / 2.0;
        }
        i = j + 1;
    }
    r
}

fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let (ra, rb) = (ranks(a), ranks(b));
    let n = a.len() as f64;
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for i in 0..a.len() {
        sab += (ra[i] - ma) * (rb[i] - mb);
        saa += (ra[i] - ma).powi(2);
        sbb += (rb[i] - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2026);
    let oracle = args.get(2).is_none_or(|s| s == "oracle");
    let verbose = args.get(3).is_some_and(|s| s == "verbose");
    if args.get(3).is_some_and(|s| s == "time") {
        // Whole `estimate_box` (default config), min of 3 runs per box, median over boxes.
        let set = synthetic_set(seed, 150, 0.5);
        let cfg = Config::default();
        let mut t_all = Vec::new();
        for f in &set.frames {
            for inst in &f.instances {
                let mut best = f64::INFINITY;
                for _ in 0..3 {
                    let t = Instant::now();
                    let _ = estimate_box(&f.depth, &f.intrinsics, &inst.mask, &cfg);
                    best = best.min(t.elapsed().as_secs_f64() * 1e3);
                }
                t_all.push(best);
            }
        }
        t_all.sort_by(f64::total_cmp);
        println!(
            "estimate_box ms median {:.3} p90 {:.3}",
            t_all[t_all.len() / 2],
            t_all[t_all.len() * 9 / 10]
        );
        return;
    }
    if args.get(3).is_some_and(|s| s == "observe") {
        // Time `observe` alone (min of 5 runs per box), median over boxes.
        let set = synthetic_set(seed, 150, 0.5);
        let cfg = Config::default();
        let mut t_obs = Vec::new();
        let mut npts = Vec::new();
        for f in &set.frames {
            for inst in &f.instances {
                let mut best = f64::INFINITY;
                for _ in 0..5 {
                    let t = Instant::now();
                    let o = anybox::observation::observe(
                        &f.depth,
                        &f.intrinsics,
                        &inst.mask,
                        &cfg.observation,
                    );
                    best = best.min(t.elapsed().as_secs_f64() * 1e3);
                    if let Ok(o) = o {
                        npts.push(o.points_mm.len() as f64);
                    }
                }
                t_obs.push(best);
            }
        }
        t_obs.sort_by(f64::total_cmp);
        npts.sort_by(f64::total_cmp);
        println!(
            "observe ms median {:.3} p90 {:.3}  points median {}",
            t_obs[t_obs.len() / 2],
            t_obs[t_obs.len() * 9 / 10],
            npts[npts.len() / 2]
        );
        return;
    }
    let set = synthetic_set(seed, 150, 0.5);
    let (mut scores, mut ious, mut ms) = (Vec::new(), Vec::new(), Vec::new());
    let mut n_full = 0;
    let mut good = [0usize; 4];
    for f in &set.frames {
        for inst in &f.instances {
            if inst.visib_fract < 0.5 {
                continue;
            }
            let gt = inst.gt;
            let mut cfg = if oracle {
                Config::paper().oracle([gt.size_mm.x, gt.size_mm.y, gt.size_mm.z])
            } else {
                Config::default()
            };
            let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
            if let Some(v) = env("HW") {
                cfg.pose.hidden_weight = v;
            }
            if let Some(v) = env("SHW") {
                cfg.pose.score_hidden_weight = v;
            }
            if let Some(v) = env("SRW") {
                cfg.pose.score_rmse_weight = v;
            }
            if let Some(v) = env("MISS") {
                cfg.observation.missing_explains = v > 0.5;
            }
            let t = Instant::now();
            let r = estimate_box(&f.depth, &f.intrinsics, &inst.mask, &cfg);
            ms.push(t.elapsed().as_secs_f64() * 1e3);
            let Ok(e) = r else {
                println!("{} {} FAIL", f.scene_id, f.im_id);
                continue;
            };
            let i3 = iou(&e.pose, &gt, IouMethod::Exact);
            let rot = rotation_error_deg(&e.pose, &gt);
            let dc = (e.pose.center_mm - gt.center_mm).norm();
            if inst.observed_dims == 3 {
                n_full += 1;
                for (k, th) in [0.5, 0.7, 0.8, 0.9].iter().enumerate() {
                    if i3 >= *th {
                        good[k] += 1;
                    }
                }
            }
            scores.push(e.score);
            ious.push(i3);
            if i3 < 0.5 && oracle {
                let c = &cfg.pose;
                if let Ok(obs) = anybox::observation::observe(
                    &f.depth,
                    &f.intrinsics,
                    &inst.mask,
                    &cfg.observation,
                ) {
                    let ctx = anybox::pose::ScoringContext::new(
                        &obs,
                        &f.depth,
                        &f.intrinsics,
                        &gt.size_mm,
                        c,
                    );
                    let pts: Vec<_> = obs.subsample.iter().map(|&i| obs.points_mm[i]).collect();
                    for (name, b) in [("gt", gt), ("est", e.pose)] {
                        let (inl, rmse) = anybox::refine::inlier_stats(&b, &pts, &c.refine);
                        println!(
                            "   {name}: sil {:.3} inl {:.3} rmse {:.2} pen {:.3} quick {:.3}",
                            ctx.silhouette_iou(&b),
                            inl,
                            rmse,
                            ctx.penalty(&b, c),
                            ctx.quick_score(&b, c)
                        );
                    }
                    println!(
                        "   mask px {} explained-region px {}",
                        obs.mask_rows.count, obs.explained_rows.count
                    );
                }

                let rr = gt.rotation.inverse() * e.pose.rotation;
                let m = rr.matrix();
                println!("   R_gt^T R_est rows [{:.0} {:.0} {:.0}] [{:.0} {:.0} {:.0}] [{:.0} {:.0} {:.0}] est size {:?} est ctr {:?} gt ctr {:?}", m[(0,0)], m[(0,1)], m[(0,2)], m[(1,0)], m[(1,1)], m[(1,2)], m[(2,0)], m[(2,1)], m[(2,2)], e.pose.size_mm.as_slice(), e.pose.center_mm.as_slice(), gt.center_mm.as_slice());
            }
            if verbose || i3 < 0.9 {
                let d = e.pose.center_mm - gt.center_mm;
                let rc = gt.rotation.inverse() * d;
                let vd = gt.center_mm.normalize();
                let va = [
                    gt.axis(0).dot(&vd).abs(),
                    gt.axis(1).dot(&vd).abs(),
                    gt.axis(2).dot(&vd).abs(),
                ];
                println!(
                    "s{} i{} g{} {:>7} vis {:.2} dims {} iou {:.3} rot {:5.1} dc {:5.1} [{:6.1} {:6.1} {:6.1}] size [{:.0} {:.0} {:.0}] score {:.3} pen {:.3} view [{:.2} {:.2} {:.2}] z {:.0}",
                    f.scene_id, f.im_id, inst.gt_index, f.layout, inst.visib_fract, inst.observed_dims,
                    i3, rot, dc, rc.x, rc.y, rc.z, gt.size_mm.x, gt.size_mm.y, gt.size_mm.z, e.score, e.depth_penalty, va[0], va[1], va[2], gt.center_mm.z
                );
            }
        }
    }
    ms.sort_by(f64::total_cmp);
    println!(
        "n {} full {}  full-dims IoU>=.5/.7/.8/.9: {:?}  spearman(score,iou) {:.3}  median ms {:.2}",
        ious.len(),
        n_full,
        good,
        spearman(&scores, &ious),
        ms[ms.len() / 2]
    );
}
