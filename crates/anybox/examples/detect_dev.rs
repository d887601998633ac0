//! Development harness of `anybox::detect` (issue #4): detection precision/recall/AP per layout
//! on generated views and on `/work/shared/data/ycbv-boxes`, with timing.
//!
//! `cargo run --release -p anybox --example detect_dev -- [views-per-config] [dump-dir]`
//! Env: `SEED=<u64>` (default 7), `ONLY=<layout>`, `NOISE=none`, `DETECT_CFG=<json>`, `LABELS=1`,
//! `EST=1`, `VERBOSE=1` (with `LEVEL=0|1|2`: which labels a missed box's cover and purity
//! come from: surfaces, colour patches, objects; default objects), `VIEW=<index>` (one view
//! only), `KIND=1` (per detection: exact, part of one box, bleeding into others, mixed or junk,
//! by precision and recall against the GT mask it overlaps most). With `EST3D=1`, each GT line
//! also gives `nz` (share of its mask without depth), `cc` (pieces of its mask), `cam` (the
//! simulated camera) and `inter` (3D IoU of the estimate from the best detection's mask cut
//! down to the GT mask: a bleeding mask scores well there, a partial one does not), `bst`
//! (the share of that detection's pixels outside the GT mask that lie on no box: its bleed
//! into the floor, pallet, table or shelf rather than into other boxes; with
//! `BLEEDDIR=<dir>`, that best detection's mask is also written as `<set>_<view>_gt<k>.png`,
//! a crop of the image with the mask's pixels inside the GT mask green, outside it red and
//! the GT's pixels it missed blue);
//! `DET3D=1` adds, per detection, the 3D
//! interpenetration with the other estimates (`pin`, `pout`, `pinhi`), the depth penalty and
//! the estimated and best GT's sorted sizes; `UNION=<r>` lists every pair of estimates
//! whose axes agree and whose union is at most r times their volume (`pipeline::tiled_union`,
//! e.g. r = 1.2) with the fill, the parts' and the union's best
//! 3D IoU, and the share of the union's silhouette seen past it (`st`, tolerance 10 and 25 mm;
//! `depth_filter::see_through_fraction`, as `pipeline::gap_unions` uses it). `RAW=1` with a
//! dump dir also writes the image with invalid depth in red. `REPS=n` times the detector (with
//! `EST=1`, detection and estimation) as the fastest of n runs. `RAWRGB=<dir>` writes each
//! view's colour image (`rgb_<view>.png`) and its depth as grey (`depth_<view>.png`; black: no
//! depth).
//! `DETECT_DEBUG=1` prints the detector's `log::debug!` diagnostics (planes, regions, face
//! pairs, selection) to stderr. With `EST3D=1` each GT line ends with `gsz` and `gobs`: the
//! size (mm) and observed-axis count of the estimate from the GT mask. `RUNFRAME=<json>` runs
//! the bench's frame (`runner::run_detected_frame`, config `<json>`, e.g. `{}`) and prints
//! each record's kind (detection, union, repeat, unseen-extent or lattice reading), score and
//! best 3D IoU with a GT box.
//! View `i` of `SEED=S` is view `i` of the same set in `anybox bench --seed S`: a view is drawn
//! from its scene index and the seed alone (`synth::generate_view`), and the sets ask for the
//! bench's distractors (none for pallets and shelves).
//! A GT box counts when its visible fraction is ≥ 0.5; a detection is a true positive when its
//! mask IoU with an unmatched such GT is > 0.5 (greedy in score order); detections matching a
//! GT with lower visibility are ignored (neither TP nor FP).

use std::path::Path;
use std::time::Instant;

use anybox::detect::{detect_boxes, DetectConfig, Detection};
use anybox::io::Mask;
use anybox::synth::{generate_view, Layout, NoiseModel, SynthConfig};

/// Detections of one frame and the time taken, ms: detection alone, or with `EST=1` the whole
/// frame (detection plus estimation of every detected box).
fn detect_timed(
    rgb: Option<&image::RgbImage>,
    depth: &anybox::io::DepthMap,
    k: &anybox::geom::Intrinsics,
    cfg: &DetectConfig,
) -> (Vec<Detection>, f64) {
    // `REPS=n`: the fastest of n runs (timing noise on a shared machine is one-sided).
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(1);
    let mut best = f64::INFINITY;
    let mut best_det = f64::INFINITY;
    let mut dets = Vec::new();
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        dets = detect_boxes(rgb, depth, k, cfg).expect("detect");
        best_det = best_det.min(t0.elapsed().as_secs_f64() * 1e3);
        if std::env::var("EST").is_ok() {
            let masks: Vec<Mask> = dets.iter().map(|d| d.mask.clone()).collect();
            let _ = anybox::pipeline::estimate_frame(
                depth,
                k,
                &masks,
                &anybox::config::Config::default().for_detected_masks(),
            );
        }
        best = best.min(t0.elapsed().as_secs_f64() * 1e3);
    }
    // `TIMES=1`: per frame, the fastest whole run and the fastest detection alone.
    if std::env::var("TIMES").is_ok() {
        println!(
            "  t {best:.1} ms, detect {best_det:.1} ms, {} detections",
            dets.len()
        );
    }
    (dets, best)
}

#[derive(Default)]
struct Tally {
    n_gt: usize,
    scored: Vec<(f64, bool)>,
    ignored: usize,
    times_ms: Vec<f64>,
    frames_all_found: usize,
    frames: usize,
    merged: usize,
}

impl Tally {
    fn ap(&self) -> f64 {
        let mut s = self.scored.clone();
        s.sort_by(|a, b| b.0.total_cmp(&a.0));
        let (mut tp, mut fp) = (0usize, 0usize);
        let mut pr = Vec::new();
        for (_, t) in &s {
            if *t {
                tp += 1
            } else {
                fp += 1
            }
            pr.push((
                tp as f64 / self.n_gt.max(1) as f64,
                tp as f64 / (tp + fp) as f64,
            ));
        }
        // VOC all-point: precision envelope integrated over recall.
        let mut ap = 0.0;
        let mut prev_r = 0.0;
        for i in 0..pr.len() {
            let p_env = pr[i..].iter().map(|x| x.1).fold(0.0, f64::max);
            ap += (pr[i].0 - prev_r) * p_env;
            prev_r = pr[i].0;
        }
        ap
    }
    fn line(&self, name: &str) -> String {
        let tp = self.scored.iter().filter(|x| x.1).count();
        let fp = self.scored.len() - tp;
        let mut t = self.times_ms.clone();
        t.sort_by(|a, b| a.total_cmp(b));
        let med = t.get(t.len() / 2).copied().unwrap_or(0.0);
        format!(
            "{name:<14} frames {:>3} gt {:>4} det {:>4} tp {:>4} fp {:>4} ign {:>3} | P {:.3} R {:.3} AP50 {:.3} | all-found frames {}/{} | merged {} | median {:.1} ms",
            self.frames,
            self.n_gt,
            self.scored.len(),
            tp,
            fp,
            self.ignored,
            tp as f64 / self.scored.len().max(1) as f64,
            tp as f64 / self.n_gt.max(1) as f64,
            self.ap(),
            self.frames_all_found,
            self.frames,
            self.merged,
            med
        )
    }
}

/// The detection whose mask overlaps `gt` best: (index, mask IoU).
fn best_mask_iou(dets: &[Detection], gt: &Mask) -> Option<(usize, f64)> {
    dets.iter()
        .enumerate()
        .map(|(j, d)| (j, d.mask.iou(gt)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Scores one frame: GT masks with their visibility.
fn score_frame(dets: &[Detection], gts: &[(Mask, f64)], objs: Option<&[u32]>, tally: &mut Tally) {
    let n = gts.len();
    let mut gt_area = vec![0usize; n];
    let mut label = vec![u16::MAX; gts.first().map_or(0, |g| g.0.data.len())];
    for (k, (m, _)) in gts.iter().enumerate() {
        for (i, &b) in m.data.iter().enumerate() {
            if b {
                label[i] = k as u16;
                gt_area[k] += 1;
            }
        }
    }
    let mut matched = vec![false; n];
    let want: Vec<bool> = gts.iter().map(|g| g.1 >= 0.5).collect();
    tally.n_gt += want.iter().filter(|x| **x).count();
    for d in dets {
        let mut inter_all = vec![0usize; n];
        for (i, &b) in d.mask.data.iter().enumerate() {
            if b {
                if let Some(&l) = label.get(i) {
                    if (l as usize) < n {
                        inter_all[l as usize] += 1;
                    }
                }
            }
        }
        let covering = (0..n)
            .filter(|&k| gt_area[k] > 500 && inter_all[k] * 2 > gt_area[k])
            .count();
        if covering >= 2 {
            tally.merged += 1;
        }
        let mut inter = vec![0usize; n];
        let mut area = 0usize;
        for (i, &b) in d.mask.data.iter().enumerate() {
            if b {
                area += 1;
                if let Some(&l) = label.get(i) {
                    if (l as usize) < n {
                        inter[l as usize] += 1;
                    }
                }
            }
        }
        if std::env::var("KIND").is_ok() {
            let (k, i) = inter
                .iter()
                .enumerate()
                .max_by_key(|x| *x.1)
                .unwrap_or((0, &0));
            let prec = *i as f64 / area.max(1) as f64;
            let rec = *i as f64 / gt_area.get(k).copied().unwrap_or(1).max(1) as f64;
            let kind = match (prec > 0.85, rec > 0.85) {
                (true, true) => "exact",
                (true, false) => "part",
                (false, true) => "bleed",
                _ if prec < 0.3 => "junk",
                _ => "mixed",
            };
            println!(
                "KIND {kind} prec {prec:.2} rec {rec:.2} score {:.3} faces {} dup {} frame {} gt {k} bbox {:?}",
                d.score,
                d.n_faces,
                matched.get(k).copied().unwrap_or(false), tally.frames, d.mask.bbox()
            );
        }
        let mut best: Option<(usize, f64)> = None;
        for k in 0..n {
            let iou = inter[k] as f64 / (area + gt_area[k] - inter[k]).max(1) as f64;
            if iou > 0.5 && !matched[k] && best.is_none_or(|b| iou > b.1) {
                best = Some((k, iou));
            }
        }
        if std::env::var("VERBOSE").is_ok() {
            let tag = match best {
                Some((k, _)) if want[k] => format!("TP gt {k}"),
                Some((k, _)) => format!("ign gt {k}"),
                None => "FP".to_string(),
            };
            println!(
                "  det score {:.3} faces {} px {} bbox {:?} {tag}",
                d.score,
                d.n_faces,
                d.mask.count(),
                d.mask.bbox()
            );
        }
        match best {
            Some((k, _)) if want[k] => {
                matched[k] = true;
                tally.scored.push((d.score, true));
            }
            Some((k, _)) => {
                matched[k] = true;
                tally.ignored += 1;
            }
            None => tally.scored.push((d.score, false)),
        }
    }
    if std::env::var("MISS").is_ok() {
        // Why each wanted GT went unmatched: no detection on it, only a part of it detected,
        // or its best detection also takes in other surfaces.
        for k in (0..n).filter(|&k| want[k] && !matched[k]) {
            let (mut rec, mut prec) = (0.0f64, 0.0f64);
            for d in dets {
                let (mut i, mut a) = (0usize, 0usize);
                for (p, &b) in d.mask.data.iter().enumerate() {
                    if b {
                        a += 1;
                        i += (label.get(p) == Some(&(k as u16))) as usize;
                    }
                }
                let r = i as f64 / gt_area[k].max(1) as f64;
                if r > rec {
                    rec = r;
                    prec = i as f64 / a.max(1) as f64;
                }
            }
            let why = if rec < 0.1 {
                "none"
            } else if prec > 0.85 {
                "split"
            } else {
                "merged"
            };
            println!(
                "MISS {why} visib {:.2} px {} rec {rec:.2} prec {prec:.2} frame {} bbox {:?}",
                gts[k].1,
                gt_area[k],
                tally.frames,
                gts[k].0.bbox()
            );
        }
    }
    if std::env::var("VERBOSE").is_ok() {
        for k in 0..n {
            if want[k] && !matched[k] {
                let best = best_mask_iou(dets, &gts[k].0);
                // The connected object covering most of the GT: its share of the GT, and
                // the GT's share of it (1 = isolated; lower = merged with others).
                let obj = objs.map(|o| {
                    let mut c: std::collections::BTreeMap<u32, usize> = Default::default();
                    for (i, &b) in gts[k].0.data.iter().enumerate() {
                        if b {
                            *c.entry(o[i]).or_insert(0) += 1;
                        }
                    }
                    let (l, n) = c
                        .into_iter()
                        .filter(|x| x.0 != u32::MAX)
                        .max_by_key(|x| x.1)
                        .unwrap_or((u32::MAX, 0));
                    let size = o.iter().filter(|&&x| x == l && l != u32::MAX).count();
                    (n as f64 / gt_area[k] as f64, n as f64 / size.max(1) as f64)
                });
                println!(
                    "  missed gt {k} visib {:.2} px {} bbox {:?} best det {:?} obj cover/purity {:?}",
                    gts[k].1,
                    gt_area[k],
                    gts[k].0.bbox(),
                    best,
                    obj
                );
            }
        }
    }
    tally.frames += 1;
    if (0..n).all(|k| !want[k] || matched[k]) {
        tally.frames_all_found += 1;
    }
}

/// Paints the mask's boundary pixels (set, with a 4-neighbour unset) in `rgb`.
fn outline(img: &mut image::RgbImage, m: &Mask, rgb: [u8; 3]) {
    for v in 1..m.height - 1 {
        for u in 1..m.width - 1 {
            if m.get(u, v)
                && !(m.get(u - 1, v) && m.get(u + 1, v) && m.get(u, v - 1) && m.get(u, v + 1))
            {
                img.put_pixel(u, v, image::Rgb(rgb));
            }
        }
    }
}

fn dump(path: &Path, rgb: &image::RgbImage, dets: &[Detection], gts: &[(Mask, f64)]) {
    let mut img = rgb.clone();
    let w = img.width();
    for (k, d) in dets.iter().enumerate() {
        let col = [
            (k * 97 % 255) as u8,
            (k * 53 % 255 + 60) as u8,
            (k * 151 % 255) as u8,
        ];
        for (i, &b) in d.mask.data.iter().enumerate() {
            if b {
                let p = img.get_pixel_mut(i as u32 % w, i as u32 / w);
                for c in 0..3 {
                    p.0[c] = ((p.0[c] as u16 + col[c] as u16 * 2) / 3) as u8;
                }
            }
        }
    }
    // Detection outlines in saturated colours, drawn after all tints.
    const OUTLINE: [[u8; 3]; 6] = [
        [255, 0, 0],
        [0, 0, 255],
        [255, 255, 0],
        [0, 255, 255],
        [255, 0, 255],
        [0, 255, 0],
    ];
    for (k, d) in dets.iter().enumerate() {
        outline(&mut img, &d.mask, OUTLINE[k % OUTLINE.len()]);
    }
    // GT outlines in white (grey below the visibility threshold).
    for (m, v) in gts {
        let c = if *v >= 0.5 { 255 } else { 128 };
        outline(&mut img, m, [c, c, c]);
    }
    let _ = img.save(path);
}

fn dump_labels(
    base: &Path,
    rgb: &image::RgbImage,
    depth: &anybox::io::DepthMap,
    k: &anybox::geom::Intrinsics,
    cfg: &DetectConfig,
) {
    if std::env::var("LABELS").is_err() {
        return;
    }
    let Ok(ls) = anybox::detect::segment_labels(Some(rgb), depth, k, cfg) else {
        return;
    };
    for (li, name) in [(0usize, "geo"), (1, "col"), (2, "obj")] {
        let mut img = rgb.clone();
        for (i, &l) in ls[li].iter().enumerate() {
            let p = img.get_pixel_mut(i as u32 % rgb.width(), i as u32 / rgb.width());
            if ls[4][i] == 1 && li != 2 {
                p.0 = [255, 0, 0];
            } else if ls[3][i] == 1 {
                p.0 = [p.0[0] / 4, p.0[1] / 4, p.0[2] / 4];
            } else if l == u32::MAX {
                p.0 = [255, 255, 255];
            } else {
                let h = (l + 1).wrapping_mul(2654435761);
                p.0 = [(h >> 24) as u8, (h >> 16) as u8, (h >> 8) as u8];
            }
        }
        let _ = img.save(format!("{}_{name}.png", base.display()));
    }
}

/// The labels `VERBOSE` reports on, from [`anybox::detect::segment_labels`]: `LEVEL=0|1|2`
/// for surfaces, colour patches or objects (default objects).
fn level_labels(mut l: [Vec<u32>; 5]) -> Vec<u32> {
    let lv = std::env::var("LEVEL")
        .ok()
        .and_then(|x| x.parse().ok())
        .unwrap_or(2usize);
    std::mem::take(&mut l[lv.min(2)])
}

/// Prints `log` records to stderr (the detector's diagnostics with `DETECT_DEBUG=1`).
struct StderrLog;

impl log::Log for StderrLog {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        eprintln!("{}", record.args());
    }
    fn flush(&self) {}
}

fn main() {
    if std::env::var("DETECT_DEBUG").is_ok() && log::set_logger(&StderrLog).is_ok() {
        log::set_max_level(log::LevelFilter::Debug);
    }
    let args: Vec<String> = std::env::args().collect();
    let n_views: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(6);
    let dump_dir = args.get(2).map(std::path::PathBuf::from);
    let cfg = match std::env::var("DETECT_CFG") {
        Ok(j) => serde_json::from_str(&j).expect("DETECT_CFG json"),
        Err(_) => DetectConfig::default(),
    };
    let only = std::env::var("ONLY").ok();
    let configs: [(&str, Layout, Option<u32>); 5] = [
        ("table-d0", Layout::Table, Some(0)),
        ("table-d8", Layout::Table, Some(8)),
        ("table-d32", Layout::Table, Some(32)),
        ("pallet", Layout::Pallet, None),
        ("shelf", Layout::Shelf, None),
    ];
    let mut total = Tally::default();
    for (name, layout, distractors) in configs {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let sc = SynthConfig {
            layout,
            scenes: n_views,
            views: 1,
            distractors,
            seed: std::env::var("SEED")
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(7),
            noise: if std::env::var("NOISE").is_ok_and(|n| n == "none") {
                NoiseModel::None
            } else {
                NoiseModel::Realistic
            },
            ..SynthConfig::default()
        };
        let mut tally = Tally::default();
        let view: Option<u32> = std::env::var("VIEW").ok().and_then(|x| x.parse().ok());
        for s in 0..n_views {
            if view.is_some_and(|x| x != s) {
                continue;
            }
            let v = generate_view(&sc, s, 0);
            let (dets, ms) = detect_timed(Some(&v.rgb), &v.depth, &v.intrinsics, &cfg);
            if let Ok(dir) = std::env::var("RAWRGB") {
                // The view's colour image, and its depth as grey (near dark, far light, no
                // depth black), stretched over the frame's 1st–99th percentile.
                let _ = v.rgb.save(format!("{dir}/rgb_{s}.png"));
                let mut zs: Vec<f32> = v
                    .depth
                    .depth_mm
                    .iter()
                    .copied()
                    .filter(|z| *z > 0.0)
                    .collect();
                zs.sort_by(|a, b| a.total_cmp(b));
                let at = |f: f64| {
                    zs.get((zs.len().saturating_sub(1) as f64 * f) as usize)
                        .copied()
                        .unwrap_or(0.0)
                };
                let (lo, hi) = (at(0.01), at(0.99).max(at(0.01) + 1.0));
                let grey = image::GrayImage::from_fn(v.rgb.width(), v.rgb.height(), |x, y| {
                    let z = v.depth.depth_mm[(y * v.rgb.width() + x) as usize];
                    let g = if z > 0.0 {
                        1.0 + 254.0 * ((z - lo) / (hi - lo)).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    image::Luma([g as u8])
                });
                let _ = grey.save(format!("{dir}/depth_{s}.png"));
            }
            if std::env::var("EST3D").is_ok() {
                // Per GT (visib ≥ 0.5): best detection mask IoU, and the 3D IoU of the estimate
                // from that detection's mask versus from the GT mask.
                use anybox::geom::iou::{iou, IouMethod};
                let cfg_e: anybox::config::Config = std::env::var("EST_CFG")
                    .ok()
                    .map(|j| serde_json::from_str(&j).expect("EST_CFG: a Config JSON"))
                    .unwrap_or_default();
                let masks: Vec<Mask> = dets.iter().map(|d| d.mask.clone()).collect();
                let est_d =
                    anybox::pipeline::estimate_frame(&v.depth, &v.intrinsics, &masks, &cfg_e);
                let erode_r: usize = std::env::var("ERODE")
                    .ok()
                    .and_then(|x| x.parse().ok())
                    .unwrap_or(0);
                let eroded: Vec<Mask> = masks
                    .iter()
                    .map(|m| {
                        let (w, h) = (m.width as usize, m.height as usize);
                        let mut out = m.clone();
                        if erode_r == 0 {
                            return out;
                        }
                        let r = erode_r as isize;
                        for y in 0..h {
                            for x in 0..w {
                                if !m.data[y * w + x] {
                                    continue;
                                }
                                let mut keep = true;
                                'o: for dy in -r..=r {
                                    for dx in -r..=r {
                                        let (xx, yy) = (x as isize + dx, y as isize + dy);
                                        if xx < 0
                                            || yy < 0
                                            || xx >= w as isize
                                            || yy >= h as isize
                                            || !m.data[yy as usize * w + xx as usize]
                                        {
                                            keep = false;
                                            break 'o;
                                        }
                                    }
                                }
                                out.data[y * w + x] = keep;
                            }
                        }
                        out
                    })
                    .collect();
                let est_e =
                    anybox::pipeline::estimate_frame(&v.depth, &v.intrinsics, &eroded, &cfg_e);
                let gtm: Vec<Mask> = v.boxes.iter().map(|b| b.mask_visib.clone()).collect();
                let est_g = anybox::pipeline::estimate_frame(&v.depth, &v.intrinsics, &gtm, &cfg_e);
                let sup_px =
                    anybox::detect::segment_labels(Some(&v.rgb), &v.depth, &v.intrinsics, &cfg)
                        .ok()
                        .map(|l| l[3].clone());
                if std::env::var("DET3D").is_ok() {
                    // Per detection: its score and the best 3D IoU of its estimate with any
                    // GT box (and that GT's visibility).
                    for (j, d) in dets.iter().enumerate() {
                        let best = v
                            .boxes
                            .iter()
                            .enumerate()
                            .map(|(gi, b)| {
                                let i = est_d[j]
                                    .as_ref()
                                    .map_or(0.0, |e| iou(&e.pose, &b.pose, IouMethod::Exact));
                                (i, b.visib_fract, b.pose.size_mm, gi)
                            })
                            .fold((0.0, 0.0, nalgebra::Vector3::zeros(), 0), |a, x| {
                                if x.0 > a.0 {
                                    x
                                } else {
                                    a
                                }
                            });
                        let mut gsz = [best.2.x, best.2.y, best.2.z];
                        gsz.sort_by(|a, b| a.total_cmp(b));
                        let (es, obs) = est_d[j].as_ref().map_or((-1.0, 0), |e| {
                            (e.score, e.observed_axes.iter().filter(|o| **o).count())
                        });
                        // Interpenetration with the other detections' estimates: largest
                        // share of this one's volume inside another, and of another's inside
                        // this one (only others with a higher detection score: `hi`).
                        let (mut pin, mut pout, mut pin_hi) = (0.0f64, 0.0f64, 0.0f64);
                        let (mut dp, mut sz) = (-1.0, [0.0; 3]);
                        if let Some(Ok(e)) = est_d.get(j) {
                            dp = e.depth_penalty;
                            sz = [e.pose.size_mm.x, e.pose.size_mm.y, e.pose.size_mm.z];
                            for (o, x) in est_d.iter().enumerate() {
                                let Some(x) = x.as_ref().ok().filter(|_| o != j) else {
                                    continue;
                                };
                                let vi =
                                    anybox::geom::iou::intersection_volume_mm3(&e.pose, &x.pose);
                                pin = pin.max(vi / e.pose.volume_mm3());
                                pout = pout.max(vi / x.pose.volume_mm3());
                                if dets[o].score > d.score {
                                    pin_hi = pin_hi.max(vi / e.pose.volume_mm3());
                                }
                            }
                        }
                        sz.sort_by(|a, b| a.total_cmp(b));
                        // Cross-section roundness of the estimate (`roundness`).
                        let rnd = est_d[j].as_ref().ok().and_then(|e| {
                            let (_, pts) =
                                anybox::observation::mask_points(&v.depth, &v.intrinsics, &d.mask);
                            anybox::roundness::round_cross_section(&e.pose, &pts, 50, 0.0)
                        });
                        // Share of the mask's points whose normal is over 30° off every
                        // face normal of the estimate.
                        let off30 = est_d[j].as_ref().ok().and_then(|e| {
                            let o = anybox::observation::observe(
                                &v.depth,
                                &v.intrinsics,
                                &d.mask,
                                &cfg_e.observation,
                            )
                            .ok()?;
                            Some(anybox::roundness::share_off_faces(
                                &e.pose, &o.normals, 30.0,
                            ))
                        });
                        print!(" off30 {:.2}", off30.unwrap_or(-1.0));
                        if let Some(c) = rnd {
                            print!(
                                " rnd {:.2} c {:.1} b {:.1} r {:.0} arc {:.0} n {}",
                                c.ratio(),
                                c.circle_mm,
                                c.box_mm,
                                c.radius_mm,
                                c.arc_deg,
                                c.points
                            );
                        } else {
                            print!(" rnd -");
                        }
                        println!(
                            "  d3 {name} s{s} gti {} score {:.3} faces {} px {} est {:.3} obs {} iou3d {:.2} visib {:.2} pin {pin:.2} pout {pout:.2} pinhi {pin_hi:.2} dp {dp:.3} sz {:.0} {:.0} {:.0} gsz {:.0} {:.0} {:.0}",
                            best.3,
                            d.score,
                            d.n_faces,
                            d.mask.count(),
                            es,
                            obs,
                            best.0,
                            best.1,
                            sz[0], sz[1], sz[2],
                            gsz[0], gsz[1], gsz[2]
                        );
                    }
                }
                if std::env::var("UNION").is_ok() {
                    // Pairs of estimates that tile one cuboid (same axes, union's bounding
                    // box about their summed volume): the union's best 3D IoU with a GT, and
                    // the parts' best.
                    let tile: f64 = std::env::var("UNION")
                        .ok()
                        .and_then(|x| x.parse().ok())
                        .unwrap_or(1.15);
                    let best_iou = |bx: &anybox::geom::OrientedBox| {
                        v.boxes
                            .iter()
                            .enumerate()
                            .filter(|(_, b)| b.visib_fract >= 0.5)
                            .map(|(k, b)| (iou(bx, &b.pose, IouMethod::Exact), k as i64))
                            .fold((0.0, -1), |a, x| if x.0 > a.0 { x } else { a })
                    };
                    for a in 0..est_d.len() {
                        for c in a + 1..est_d.len() {
                            let (Ok(ea), Ok(ec)) = (&est_d[a], &est_d[c]) else {
                                continue;
                            };
                            let Some(u) =
                                anybox::pipeline::tiled_union(&ea.pose, &ec.pose, 10.0, 0.0)
                            else {
                                continue;
                            };
                            let (va, vc, vu) =
                                (ea.pose.volume_mm3(), ec.pose.volume_mm3(), u.volume_mm3());
                            if vu > tile * (va + vc) {
                                continue;
                            }
                            let (ia, ka) = best_iou(&ea.pose);
                            let (ic, kc) = best_iou(&ec.pose);
                            let (iu, ku) = best_iou(&u);
                            let st = |tol: f64| {
                                anybox::depth_filter::see_through_fraction(
                                    &u,
                                    &v.depth,
                                    &v.intrinsics,
                                    1000,
                                    tol,
                                    0.01,
                                    1.0,
                                )
                                .unwrap_or(-1.0)
                            };
                            println!(
                                "  union {name} s{s} {a} {c} fill {:.2} parts {ia:.2} (gt {ka}) {ic:.2} (gt {kc}) union {iu:.2} (gt {ku}) scores {:.3} {:.3} st {:.3} {:.3}",
                                (va + vc) / vu,
                                dets[a].score * ea.score,
                                dets[c].score * ec.score,
                                st(10.0),
                                st(25.0)
                            );
                        }
                    }
                }
                if std::env::var("PAIRS").is_ok() {
                    // Every pair of touching detections: which GT each lies in (precision ≥ 0.8),
                    // and the estimate from the union of their masks.
                    let w = v.depth.width as usize;
                    let owner = |m: &Mask| -> (i64, f64) {
                        let mut best = (-1i64, 0.0);
                        let a = m.count().max(1) as f64;
                        for (k, b) in v.boxes.iter().enumerate() {
                            let i = m
                                .data
                                .iter()
                                .zip(&b.mask_visib.data)
                                .filter(|(x, y)| **x && **y)
                                .count() as f64;
                            if i / a > best.1 {
                                best = (k as i64, i / a);
                            }
                        }
                        if best.1 >= 0.8 {
                            best
                        } else {
                            (-1, best.1)
                        }
                    };
                    let owners: Vec<(i64, f64)> = dets.iter().map(|d| owner(&d.mask)).collect();
                    for a in 0..dets.len() {
                        for c in a + 1..dets.len() {
                            let (ma, mc) = (&dets[a].mask.data, &dets[c].mask.data);
                            let mut touch = 0;
                            for i in 0..ma.len() {
                                if !ma[i] {
                                    continue;
                                }
                                let x = i % w;
                                let y = i / w;
                                for (dx, dy) in [
                                    (-2i64, 0i64),
                                    (2, 0),
                                    (0, -2),
                                    (0, 2),
                                    (-1, 0),
                                    (1, 0),
                                    (0, -1),
                                    (0, 1),
                                ] {
                                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                                    if nx >= 0
                                        && ny >= 0
                                        && (nx as usize) < w
                                        && (ny as usize) < ma.len() / w
                                        && mc[ny as usize * w + nx as usize]
                                    {
                                        touch += 1;
                                        break;
                                    }
                                }
                            }
                            if touch < 5 {
                                continue;
                            }
                            let mut uni = dets[a].mask.clone();
                            for (u, &x) in uni.data.iter_mut().zip(mc) {
                                *u |= x;
                            }
                            let eu = anybox::pipeline::estimate_box(
                                &v.depth,
                                &v.intrinsics,
                                &uni,
                                &cfg_e,
                            );
                            let best3 = |e: &Result<anybox::pipeline::BoxEstimate, _>| {
                                e.as_ref().map_or(-1.0, |e| {
                                    v.boxes
                                        .iter()
                                        .filter(|b| b.visib_fract >= 0.5)
                                        .map(|b| iou(&e.pose, &b.pose, IouMethod::Exact))
                                        .fold(0.0, f64::max)
                                })
                            };
                            let es = |e: &Result<anybox::pipeline::BoxEstimate, _>| {
                                e.as_ref().map_or(-1.0, |e| e.score)
                            };
                            println!(
                                "  pair {name} s{s} same {} own {} {} touch {touch} fa {} fc {} pa {} pc {} da {:.3} dc {:.3} ea {:.3} ec {:.3} eu {:.3} ia {:.2} ic {:.2} iu {:.2}",
                                (owners[a].0 >= 0 && owners[a].0 == owners[c].0) as u8,
                                owners[a].0, owners[c].0,
                                dets[a].n_faces, dets[c].n_faces,
                                dets[a].mask.count(), dets[c].mask.count(),
                                dets[a].score, dets[c].score,
                                es(&est_d[a]), es(&est_d[c]), es(&eu),
                                best3(&est_d[a]), best3(&est_d[c]), best3(&eu)
                            );
                        }
                    }
                }
                if std::env::var("SPLIT").is_ok() {
                    // Per counted GT: detections lying mostly inside its mask (precision ≥ 0.8);
                    // with two or more, the 3D IoU of each one's estimate and of the union's.
                    for (k, b) in v.boxes.iter().enumerate() {
                        if b.visib_fract < 0.5 {
                            continue;
                        }
                        let mut parts = Vec::new();
                        for (j, d) in dets.iter().enumerate() {
                            let (mut a, mut i) = (0usize, 0usize);
                            for (&x, &y) in d.mask.data.iter().zip(&b.mask_visib.data) {
                                a += x as usize;
                                i += (x && y) as usize;
                            }
                            if a > 0 && i as f64 / a as f64 >= 0.8 {
                                parts.push((j, i as f64 / b.mask_visib.count().max(1) as f64));
                            }
                        }
                        if parts.len() < 2 {
                            continue;
                        }
                        let mut uni = Mask::empty(v.depth.width, v.depth.height);
                        for (j, _) in &parts {
                            for (u, &x) in uni.data.iter_mut().zip(&dets[*j].mask.data) {
                                *u |= x;
                            }
                        }
                        let eu =
                            anybox::pipeline::estimate_box(&v.depth, &v.intrinsics, &uni, &cfg_e);
                        let i3 = |e: &Result<anybox::pipeline::BoxEstimate, _>| {
                            e.as_ref()
                                .map_or(-1.0, |e| iou(&e.pose, &b.pose, IouMethod::Exact))
                        };
                        let each: Vec<String> = parts
                            .iter()
                            .map(|(j, r)| {
                                format!(
                                    "[d{j} f{} rec {r:.2} sc {:.2} iou {:.2} est {:.2}]",
                                    dets[*j].n_faces,
                                    dets[*j].score,
                                    i3(&est_d[*j]),
                                    est_d[*j].as_ref().map_or(-1.0, |e| e.score)
                                )
                            })
                            .collect();
                        let pair = match (&est_d[parts[0].0], &est_d[parts[1].0]) {
                            (Ok(a), Ok(c)) => iou(&a.pose, &c.pose, IouMethod::Exact),
                            _ => -1.0,
                        };
                        if let Ok(dir) = std::env::var("SPLIT_DIR") {
                            let mut img = v.rgb.clone();
                            let cols = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 0]];
                            for (c, (j, _)) in parts.iter().enumerate() {
                                for (i, &x) in dets[*j].mask.data.iter().enumerate() {
                                    if x {
                                        let px = img.get_pixel_mut(
                                            i as u32 % v.rgb.width(),
                                            i as u32 / v.rgb.width(),
                                        );
                                        for ch in 0..3 {
                                            px.0[ch] =
                                                (px.0[ch] / 2).saturating_add(cols[c % 4][ch] / 2);
                                        }
                                    }
                                }
                            }
                            let _ = img.save(format!("{dir}/split_{name}_{s}_{k}.png"));
                        }
                        println!(
                            "  split {name} s{s} gt {k} n {} pair {pair:.2} union iou {:.2} est {:.2} | {}",
                            parts.len(),
                            i3(&eu),
                            eu.as_ref().map_or(-1.0, |e| e.score),
                            each.join(" ")
                        );
                    }
                }
                for (k, b) in v.boxes.iter().enumerate() {
                    if b.visib_fract < 0.5 {
                        continue;
                    }
                    let best = best_mask_iou(&dets, &b.mask_visib);
                    let i3 = |e: &Result<anybox::pipeline::BoxEstimate, _>| {
                        e.as_ref()
                            .map_or(-1.0, |e| iou(&e.pose, &b.pose, IouMethod::Exact))
                    };
                    let (j, miou) = best.unwrap_or((usize::MAX, 0.0));
                    let d3 = if j == usize::MAX { -1.0 } else { i3(&est_d[j]) };
                    let d1 = if j == usize::MAX {
                        -1.0
                    } else {
                        i3(&anybox::pipeline::estimate_box(
                            &v.depth,
                            &v.intrinsics,
                            &masks[j],
                            &cfg_e,
                        ))
                    };
                    let g1 = i3(&anybox::pipeline::estimate_box(
                        &v.depth,
                        &v.intrinsics,
                        &gtm[k],
                        &cfg_e,
                    ));
                    if j != usize::MAX && std::env::var("DIFF").is_ok() {
                        // Pixels only in the detection / only in the GT mask.
                        let (mut d_only, mut g_only, mut d_only_valid) = (0, 0, 0);
                        let (mut z_only, mut z_both) = (Vec::new(), Vec::new());
                        for (i, (&a, &c)) in masks[j].data.iter().zip(&gtm[k].data).enumerate() {
                            if a && c && v.depth.depth_mm[i] > 0.0 {
                                z_both.push(v.depth.depth_mm[i]);
                            }
                            if a && !c {
                                d_only += 1;
                                if v.depth.depth_mm[i] > 0.0 {
                                    d_only_valid += 1;
                                    z_only.push(v.depth.depth_mm[i]);
                                }
                            }
                            if c && !a {
                                g_only += 1;
                            }
                        }
                        let q = |mut z: Vec<f32>| {
                            z.sort_by(|a, b| a.total_cmp(b));
                            if z.is_empty() {
                                return String::from("-");
                            }
                            let at = |f: f64| z[((z.len() - 1) as f64 * f) as usize];
                            format!("{:.0}/{:.0}/{:.0}", at(0.1), at(0.5), at(0.9))
                        };
                        println!(
                            "  diff s{s} gt {k}: det-only {d_only} (valid depth {d_only_valid}) gt-only {g_only} of gt {}; depth p10/50/90 det-only {} shared {}",
                            gtm[k].count(),
                            q(z_only),
                            q(z_both)
                        );
                        let show = |e: &Result<anybox::pipeline::BoxEstimate, _>| match e {
                            Ok(e) => format!(
                                "size {:.0?} centre {:.0?} observed {:?} score {:.2}",
                                e.pose.size_mm.as_slice(),
                                e.pose.center_mm.as_slice(),
                                e.observed_axes,
                                e.score
                            ),
                            Err(x) => format!("{x}"),
                        };
                        println!(
                            "    det est {}\n    gt  est {}\n    truth size {:.0?} centre {:.0?}",
                            show(&est_d[j]),
                            show(&est_g[k]),
                            b.pose.size_mm.as_slice(),
                            b.pose.center_mm.as_slice()
                        );
                        if let Ok(dir) = std::env::var("DIFF") {
                            let mut img = v.rgb.clone();
                            for (i, (&a, &c)) in masks[j].data.iter().zip(&gtm[k].data).enumerate()
                            {
                                let px = img.get_pixel_mut(
                                    i as u32 % v.rgb.width(),
                                    i as u32 / v.rgb.width(),
                                );
                                if a && !c {
                                    px.0 = [255, 0, 0];
                                } else if c && !a {
                                    px.0 = [0, 0, 255];
                                } else if a && c {
                                    px.0 = [px.0[0] / 2, 255, px.0[2] / 2];
                                }
                            }
                            let _ = img.save(format!("{dir}/diff_{name}_{s}_{k}.png"));
                        }
                    }
                    // Precision and recall of the best detection's mask against this GT.
                    let (prec, rec) = if j == usize::MAX {
                        (0.0, 0.0)
                    } else {
                        let (mut i, mut a) = (0usize, 0usize);
                        for (&x, &y) in masks[j].data.iter().zip(&gtm[k].data) {
                            a += x as usize;
                            i += (x && y) as usize;
                        }
                        (
                            i as f64 / a.max(1) as f64,
                            i as f64 / gtm[k].count().max(1) as f64,
                        )
                    };
                    let faces = dets.get(j).map_or(0, |d| d.n_faces);
                    // Largest share of this estimate's volume inside another detection's.
                    let pen = match est_d.get(j) {
                        Some(Ok(e)) => est_d
                            .iter()
                            .enumerate()
                            .filter(|(o, _)| *o != j)
                            .filter_map(|(_, x)| x.as_ref().ok())
                            .map(|x| {
                                anybox::geom::iou::intersection_volume_mm3(&e.pose, &x.pose)
                                    / e.pose.volume_mm3()
                            })
                            .fold(0.0, f64::max),
                        _ => -1.0,
                    };
                    print!("  pen {pen:.2}");
                    // The best detection's mask cut down to the GT's (its bleed removed): what
                    // the estimator makes of that detection's right pixels alone.
                    if j != usize::MAX {
                        let mut cut = masks[j].clone();
                        for (c, &g) in cut.data.iter_mut().zip(&gtm[k].data) {
                            *c &= g;
                        }
                        let e =
                            anybox::pipeline::estimate_box(&v.depth, &v.intrinsics, &cut, &cfg_e);
                        print!(" inter {:.2}", i3(&e));
                        // Where the bleed goes: share of the mask's pixels outside this GT
                        // that lie on no box at all (floor, pallet, table, shelf).
                        let (mut out_n, mut out_s) = (0usize, 0usize);
                        for (i, (&m, &g)) in masks[j].data.iter().zip(&gtm[k].data).enumerate() {
                            if m && !g {
                                out_n += 1;
                                out_s += (!gtm.iter().any(|o| o.data[i])) as usize;
                            }
                        }
                        print!(" bst {:.2}", out_s as f64 / out_n.max(1) as f64);
                        if let Ok(dir) = std::env::var("BLEEDDIR") {
                            // Crop: mask pixels in the GT green, outside it red, GT only blue.
                            let mut img = v.rgb.clone();
                            let (w, _h) = (img.width() as usize, img.height() as usize);
                            let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0, 0);
                            for (i, (&m, &g)) in masks[j].data.iter().zip(&gtm[k].data).enumerate()
                            {
                                let (u, vv) = (i % w, i / w);
                                if m || g {
                                    (u0, v0, u1, v1) =
                                        (u0.min(u), v0.min(vv), u1.max(u), v1.max(vv));
                                }
                                let px = img.get_pixel_mut(u as u32, vv as u32);
                                let c = match (m, g) {
                                    (true, true) => Some([0u8, 200, 0]),
                                    (true, false) => Some([230, 0, 0]),
                                    (false, true) => Some([0, 0, 230]),
                                    _ => None,
                                };
                                if let Some(c) = c {
                                    for ch in 0..3 {
                                        px[ch] = ((px[ch] as u16 + c[ch] as u16) / 2) as u8;
                                    }
                                }
                            }
                            let pad = 30;
                            let (u0, v0) = (u0.saturating_sub(pad), v0.saturating_sub(pad));
                            let u1 = (u1 + pad).min(img.width() as usize - 1);
                            let v1 = (v1 + pad).min(img.height() as usize - 1);
                            let crop = image::imageops::crop_imm(
                                &img,
                                u0 as u32,
                                v0 as u32,
                                (u1 - u0) as u32,
                                (v1 - v0) as u32,
                            )
                            .to_image();
                            let _ = crop.save(format!("{dir}/{name}_{s}_gt{k}.png"));
                        }
                    }
                    if erode_r > 0 && j != usize::MAX {
                        print!(
                            " ero {:.2} es {:.3} ee {:.3}",
                            i3(&est_e[j]),
                            est_d[j].as_ref().map_or(-1.0, |e| e.score),
                            est_e[j].as_ref().map_or(-1.0, |e| e.score)
                        );
                    }
                    // Share of the GT mask without valid depth (grazing faces, holes).
                    let nz = {
                        let (mut n, mut z0) = (0usize, 0usize);
                        for (i, &y) in gtm[k].data.iter().enumerate() {
                            if y {
                                n += 1;
                                z0 += (v.depth.depth_mm[i] <= 0.0) as usize;
                            }
                        }
                        z0 as f64 / n.max(1) as f64
                    };
                    print!(" nz {nz:.2}");
                    // Pieces of the GT mask (4-connected, each ≥ 5 % of it): a box occluded
                    // across its middle shows as two.
                    let pieces = {
                        let (w, h) = (gtm[k].width as usize, gtm[k].height as usize);
                        let mut seen = vec![false; w * h];
                        let tot = gtm[k].count().max(1);
                        let mut n = 0;
                        for st in 0..w * h {
                            if !gtm[k].data[st] || seen[st] {
                                continue;
                            }
                            let mut stack = vec![st];
                            seen[st] = true;
                            let mut c = 0usize;
                            while let Some(i) = stack.pop() {
                                c += 1;
                                let (u, vv) = (i % w, i / w);
                                let nb = [
                                    (u > 0).then(|| i - 1),
                                    (u + 1 < w).then(|| i + 1),
                                    (vv > 0).then(|| i - w),
                                    (vv + 1 < h).then(|| i + w),
                                ];
                                for j in nb.into_iter().flatten() {
                                    if gtm[k].data[j] && !seen[j] {
                                        seen[j] = true;
                                        stack.push(j);
                                    }
                                }
                            }
                            if c * 20 >= tot {
                                n += 1;
                            }
                        }
                        n
                    };
                    print!(
                        " cc {pieces} gpx {} zm {:.0} cam {}",
                        gtm[k].count(),
                        b.pose.center_mm.z,
                        v.camera
                    );
                    // Share of the GT mask on support cells (eaten by the table's band).
                    if let Some(sup) = &sup_px {
                        let on = gtm[k]
                            .data
                            .iter()
                            .zip(sup)
                            .filter(|(m, s)| **m && **s == 1)
                            .count();
                        print!(" sup {:.2}", on as f64 / gtm[k].count().max(1) as f64);
                    }
                    println!(
                        "  3d {name} s{s} gt {k} visib {:.2} size {:.0}x{:.0}x{:.0} mask-iou {miou:.2} iou3d det {d3:.2} gt {:.2} alone det {d1:.2} gt {g1:.2} prec {prec:.2} rec {rec:.2} faces {faces} gsz {} gobs {}",
                        b.visib_fract, b.pose.size_mm.x, b.pose.size_mm.y, b.pose.size_mm.z, i3(&est_g[k]),
                        est_g[k].as_ref().map_or("-".into(), |e| format!("{:.0}x{:.0}x{:.0}", e.pose.size_mm.x, e.pose.size_mm.y, e.pose.size_mm.z)),
                        est_g[k].as_ref().map_or(0, |e| e.observed_axes.iter().filter(|o| **o).count())
                    );
                }
            }
            if let Ok(j) = std::env::var("RUNFRAME") {
                // The bench's frame (`runner::run_detected_frame`) with config `j`: each
                // record's kind, score and best 3D IoU with a GT box.
                use anybox::geom::iou::{iou, IouMethod};
                let c: anybox::config::Config =
                    serde_json::from_str(&j).expect("RUNFRAME: a Config JSON");
                let out =
                    anybox::runner::run_detected_frame(Some(&v.rgb), &v.depth, &v.intrinsics, &c)
                        .expect("frame");
                for r in &out.estimates {
                    let Ok(p) = r.pose() else { continue };
                    let (mut bi, mut bk) = (0.0, 0);
                    for (k, b) in v.boxes.iter().enumerate() {
                        let i = iou(&p, &b.pose, IouMethod::Exact);
                        if i > bi {
                            (bi, bk) = (i, k);
                        }
                    }
                    let kind = anybox::runner::record_kind(r);
                    println!(
                        "  rec {name} s{s} {kind} score {:.3} best {bi:.2} gt {bk} vis {:.2} size {:.0}x{:.0}x{:.0}",
                        r.score, v.boxes[bk].visib_fract, p.size_mm.x, p.size_mm.y, p.size_mm.z
                    );
                }
            }
            if std::env::var("POOL").is_ok() {
                // Per counted GT: best mask IoU of the final detections, and of each level of
                // the candidate pool (cells only, before selection and fill).
                let pool =
                    anybox::detect::candidate_pool(Some(&v.rgb), &v.depth, &v.intrinsics, &cfg)
                        .expect("pool");
                let labs =
                    anybox::detect::segment_labels(Some(&v.rgb), &v.depth, &v.intrinsics, &cfg)
                        .expect("labels");
                for (k, b) in v.boxes.iter().enumerate() {
                    if b.visib_fract < 0.5 {
                        continue;
                    }
                    let fin = best_mask_iou(&dets, &b.mask_visib).map_or(0.0, |x| x.1);
                    let mut best = [(0.0f64, 0.0f64, 0u8); 3];
                    for (src, d) in &pool {
                        let l = match src {
                            'o' => 0,
                            's' => 1,
                            _ => 2,
                        };
                        let iou = d.mask.iou(&b.mask_visib);
                        if iou > best[l].0 {
                            best[l] = (iou, d.score, d.n_faces);
                        }
                    }
                    // Share of the GT's pixels in regions that lie ≥ 80 % inside it (pure
                    // faces), per label level (surfaces, colour patches).
                    let pure = |lab: &[u32]| {
                        let mut inside: std::collections::HashMap<u32, (usize, usize)> =
                            Default::default();
                        for (i, &l) in lab.iter().enumerate() {
                            if l == u32::MAX {
                                continue;
                            }
                            let e = inside.entry(l).or_insert((0, 0));
                            e.1 += 1;
                            if b.mask_visib.data[i] {
                                e.0 += 1;
                            }
                        }
                        let n: usize = inside
                            .values()
                            .filter(|(a, t)| *a as f64 >= 0.8 * *t as f64)
                            .map(|(a, _)| a)
                            .sum();
                        n as f64 / b.mask_visib.count().max(1) as f64
                    };
                    println!(
                        "  pure {name} s{s} gt {k} final {fin:.2} geo {:.2} col {:.2}",
                        pure(&labs[0]),
                        pure(&labs[1])
                    );
                    println!(
                        "  pool {name} s{s} gt {k} final {fin:.2} obj {:.2} ({:.2},{}) surf {:.2} ({:.2},{}) col {:.2} ({:.2},{})",
                        best[0].0, best[0].1, best[0].2, best[1].0, best[1].1, best[1].2, best[2].0, best[2].1, best[2].2
                    );
                }
            }
            if std::env::var("VERBOSE").is_ok() {
                println!("  {name} s{s}");
            }
            tally.times_ms.push(ms);
            total.times_ms.push(ms);
            let gts: Vec<(Mask, f64)> = v
                .boxes
                .iter()
                .map(|b| (b.mask_visib.clone(), b.visib_fract))
                .collect();
            let objs = std::env::var("VERBOSE").ok().and_then(|_| {
                anybox::detect::segment_labels(Some(&v.rgb), &v.depth, &v.intrinsics, &cfg)
                    .ok()
                    .map(level_labels)
            });
            score_frame(&dets, &gts, objs.as_deref(), &mut tally);
            if let Some(d) = &dump_dir {
                if let Ok(c) = std::env::var("CROP") {
                    let c: Vec<u32> = c.split(',').filter_map(|x| x.parse().ok()).collect();
                    let sub = image::imageops::crop_imm(&v.rgb, c[0], c[1], c[2], c[3]).to_image();
                    let big = image::imageops::resize(
                        &sub,
                        c[2] * 3,
                        c[3] * 3,
                        image::imageops::FilterType::Nearest,
                    );
                    let _ = big.save(d.join(format!("{name}_{s}_crop.png")));
                }
                dump_labels(
                    &d.join(format!("{name}_{s}")),
                    &v.rgb,
                    &v.depth,
                    &v.intrinsics,
                    &cfg,
                );
                dump(&d.join(format!("{name}_{s}.png")), &v.rgb, &dets, &gts);
                if std::env::var("RAW").is_ok() {
                    let _ = v.rgb.save(d.join(format!("{name}_{s}_raw.png")));
                    // Valid depth in the image: invalid pixels in red.
                    let mut dz = v.rgb.clone();
                    for (i, z) in v.depth.depth_mm.iter().enumerate() {
                        if *z <= 0.0 {
                            let w = v.rgb.width();
                            dz.put_pixel(i as u32 % w, i as u32 / w, image::Rgb([255, 0, 0]));
                        }
                    }
                    let _ = dz.save(d.join(format!("{name}_{s}_valid.png")));
                }
            }
        }
        println!("{}", tally.line(name));
    }
    let root = Path::new("/work/shared/data/ycbv-boxes");
    if only.as_deref().is_none_or(|o| o == "ycbv") && root.exists() {
        let ds = anybox::io::bop::BopDataset::open(root, "test").expect("ycbv");
        let mut tally = Tally::default();
        for (vi, view) in ds.views.iter().enumerate() {
            let f = view.load_frame().expect("frame");
            let (dets, ms) = detect_timed(f.rgb.as_ref(), &f.depth, &f.intrinsics, &cfg);
            tally.times_ms.push(ms);
            let gts: Vec<(Mask, f64)> = (0..view.gts.len())
                .map(|i| (view.load_mask_visib(i).expect("mask"), 1.0))
                .collect();
            let objs = std::env::var("VERBOSE").ok().and_then(|_| {
                anybox::detect::segment_labels(f.rgb.as_ref(), &f.depth, &f.intrinsics, &cfg)
                    .ok()
                    .map(level_labels)
            });
            score_frame(&dets, &gts, objs.as_deref(), &mut tally);
            if let (Some(d), Some(rgb)) = (&dump_dir, &f.rgb) {
                dump_labels(
                    &d.join(format!("ycbv_{vi}")),
                    rgb,
                    &f.depth,
                    &f.intrinsics,
                    &cfg,
                );
                dump(&d.join(format!("ycbv_{vi}.png")), rgb, &dets, &gts);
            }
        }
        println!("{}", tally.line("ycbv-boxes"));
    }
}
