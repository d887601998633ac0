//! The in-memory evaluator: per-image pair errors, greedy matching, AP per scope.

use std::collections::BTreeMap;

use rayon::prelude::*;

use crate::ap::{voc_ap, ScoredMatch};
use crate::geom_compat::{iou, match_axes, AddsReference, IouMethod};
use crate::report::{Figures, Report, SizeError};
use crate::{EstEntry, EvalOptions, GtEntry};

/// Detection AP thresholds on 3D IoU (match when IoU is strictly greater).
pub const IOU_THRESHOLDS: [f64; 6] = [0.25, 0.5, 0.7, 0.75, 0.8, 0.9];

/// IoU at which NOCS gates pose matching (`iou_pose_thres`).
const GATING_IOU: f64 = 0.1;

/// Pairs for the size error are those matched at this IoU.
pub const SIZE_MATCH_IOU: f64 = 0.25;

/// Single-threshold pose AP: `(key, max rotation error °, max translation error cm)`.
/// Rotation-only rows use NOCS's 100 cm bound, translation-only rows its 360° bound.
pub const POSE_THRESHOLDS: [(&str, f64, f64); 12] = [
    ("5deg_1cm", 5.0, 1.0),
    ("5deg_2cm", 5.0, 2.0),
    ("5deg_5cm", 5.0, 5.0),
    ("10deg_2cm", 10.0, 2.0),
    ("10deg_5cm", 10.0, 5.0),
    ("20deg_5cm", 20.0, 5.0),
    ("rot_5deg", 5.0, NO_TRANS_LIMIT_CM),
    ("rot_10deg", 10.0, NO_TRANS_LIMIT_CM),
    ("rot_20deg", 20.0, NO_TRANS_LIMIT_CM),
    ("trans_1cm", NO_ROT_LIMIT_DEG, 1.0),
    ("trans_2cm", NO_ROT_LIMIT_DEG, 2.0),
    ("trans_5cm", NO_ROT_LIMIT_DEG, 5.0),
];

const NO_TRANS_LIMIT_CM: f64 = 100.0;
const NO_ROT_LIMIT_DEG: f64 = 360.0;

/// Numerical tolerance on the pose thresholds, so that a perfect estimate passes the 0° / 0 cm
/// thresholds that the PACE averages include: a pose written to a results file and read back
/// (decimal round trip, re-orthonormalisation) differs from the truth by ~1e-6°, and `acos` near
/// 1 amplifies rounding. 1e-3° and 1e-4 cm (1 µm) are far below any meaningful error.
const ROT_TOL_DEG: f64 = 1e-3;
const TRANS_TOL_CM: f64 = 1e-4;

/// PACE averaging: `k = 0..=20`, rotation `k`°, translation `k/4` cm (21 values each).
pub const PACE_STEPS: usize = 21;

/// ADD-S AP thresholds as fractions of the true box diagonal: `(key, fraction)`.
pub const ADDS_FRACTIONS: [(&str, f64); 2] = [("0.1d", 0.1), ("0.15d", 0.15)];

/// Surface samples per ADD-S evaluation.
pub const ADDS_SAMPLES: usize = 1000;

/// Visibility bands `(key, low, high)`: `low ≤ visib < high`, the last band includes 1.0
/// (and anything above, from rounding).
pub const VISIBILITY_BANDS: [(&str, f64, f64); 4] = [
    ("[0.1,0.3)", 0.1, 0.3),
    ("[0.3,0.5)", 0.3, 0.5),
    ("[0.5,0.8)", 0.5, 0.8),
    ("[0.8,1.0]", 0.8, f64::INFINITY),
];

/// The pose thresholds actually matched: the 12 singles, then PACE rotation-only,
/// translation-only and diagonal (21 each).
fn pose_threshold_list() -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = POSE_THRESHOLDS.iter().map(|t| (t.1, t.2)).collect();
    for k in 0..PACE_STEPS {
        v.push((k as f64, NO_TRANS_LIMIT_CM));
    }
    for k in 0..PACE_STEPS {
        v.push((NO_ROT_LIMIT_DEG, k as f64 * 0.25));
    }
    for k in 0..PACE_STEPS {
        v.push((k as f64, k as f64 * 0.25));
    }
    v
}

/// Per-image matching results, all indices local to the image.
struct ImageResult {
    scene_id: u32,
    /// Indices into the caller's `gts`.
    gts: Vec<usize>,
    /// Indices into the caller's `ests`, in rank order.
    ests: Vec<usize>,
    /// `iou_assign[t][e]`: the GT matched by ranked estimate `e` at `IOU_THRESHOLDS[t]`.
    iou_assign: Vec<Vec<Option<usize>>>,
    /// Estimates / GTs that take part in pose and ADD-S matching (all, unless gating).
    pose_est_kept: Vec<bool>,
    pose_gt_kept: Vec<bool>,
    pose_assign: Vec<Vec<Option<usize>>>,
    adds_assign: Vec<Vec<Option<usize>>>,
    /// Highest-IoU GT of each estimate (IoU > 0).
    home: Vec<Option<usize>>,
    /// Per-axis size error of the estimate's match at `SIZE_MATCH_IOU`.
    size_err: Vec<Option<[f64; 3]>>,
}

/// Greedy NOCS IoU matching of ranked estimates; `iou_m` is row-major `n_est × n_gt`.
fn match_iou(
    iou_m: &[f64],
    order: &[Vec<usize>],
    n_gt: usize,
    thr: f64,
    est_ok: &[bool],
) -> Vec<Option<usize>> {
    let mut gt_used = vec![false; n_gt];
    let mut out = vec![None; order.len()];
    for (e, gts) in order.iter().enumerate() {
        if !est_ok[e] {
            continue;
        }
        for &g in gts {
            if gt_used[g] {
                continue;
            }
            let v = iou_m[e * n_gt + g];
            if v < thr {
                break;
            }
            if v > thr {
                gt_used[g] = true;
                out[e] = Some(g);
                break;
            }
        }
    }
    out
}

/// Greedy "first unmatched GT in the given order that passes `ok`" matching.
fn match_first(
    order: &[Vec<usize>],
    n_gt: usize,
    est_ok: &[bool],
    gt_ok: &[bool],
    ok: impl Fn(usize, usize) -> bool,
) -> Vec<Option<usize>> {
    let mut gt_used = vec![false; n_gt];
    let mut out = vec![None; order.len()];
    for (e, gts) in order.iter().enumerate() {
        if !est_ok[e] {
            continue;
        }
        for &g in gts {
            if gt_used[g] || !gt_ok[g] {
                continue;
            }
            if ok(e, g) {
                gt_used[g] = true;
                out[e] = Some(g);
                break;
            }
        }
    }
    out
}

/// Indices `0..n` sorted ascending by `key` (NaN last), ties by index.
fn argsort(n: usize, key: impl Fn(usize) -> f64) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&a, &b| {
        let (ka, kb) = (key(a), key(b));
        let ka = if ka.is_nan() { f64::INFINITY } else { ka };
        let kb = if kb.is_nan() { f64::INFINITY } else { kb };
        ka.total_cmp(&kb).then(a.cmp(&b))
    });
    idx
}

fn evaluate_image(
    gts_all: &[GtEntry],
    ests_all: &[EstEntry],
    scene_id: u32,
    gts: Vec<usize>,
    mut ests: Vec<usize>,
    opts: &EvalOptions,
    pose_thresholds: &[(f64, f64)],
) -> ImageResult {
    // Rank: score descending (NaN last), ties by input order.
    ests.sort_by(|&a, &b| {
        let key = |i: usize| {
            let s = ests_all[i].score;
            if s.is_nan() {
                f64::NEG_INFINITY
            } else {
                s
            }
        };
        key(b).total_cmp(&key(a)).then(a.cmp(&b))
    });
    let (ne, ng) = (ests.len(), gts.len());
    let gt_box = |g: usize| &gts_all[gts[g]].pose;
    let est_box = |e: usize| &ests_all[ests[e]].pose;

    // Pair errors. Bounding spheres that cannot overlap skip the expensive metrics.
    let mut iou_m = vec![0.0; ne * ng];
    let mut rot_m = vec![f64::INFINITY; ne * ng];
    let mut cm_m = vec![f64::INFINITY; ne * ng];
    let mut adds_m = vec![f64::INFINITY; ne * ng];
    let mut size_m = vec![[f64::NAN; 3]; ne * ng];
    let max_frac = ADDS_FRACTIONS.iter().map(|f| f.1).fold(0.0, f64::max);
    // Surface samples of each GT, drawn once per image instead of once per pair.
    let adds_refs: Vec<AddsReference> = (0..ng)
        .map(|g| AddsReference::new(gt_box(g), ADDS_SAMPLES))
        .collect();
    for e in 0..ne {
        for g in 0..ng {
            let (a, b) = (est_box(e), gt_box(g));
            let k = e * ng + g;
            let dist = (a.center_mm - b.center_mm).norm();
            let reach = a.half_size_mm().norm() + b.half_size_mm().norm();
            // Skip IoU where it is certainly 0: the exact IoU needs the bounding spheres to
            // overlap, the AABB variant their bounding cubes; the legacy NOCS number is not
            // geometric (it can be non-zero for disjoint boxes) and is always computed.
            let may_overlap = match opts.iou {
                IouMethod::Exact => dist < reach,
                IouMethod::Aabb => (a.center_mm - b.center_mm).amax() < reach,
                IouMethod::NocsLegacy => true,
            };
            if may_overlap {
                iou_m[k] = iou(a, b, opts.iou);
            }
            cm_m[k] = dist / 10.0;
            // One axis matching per pair gives the rotation error (min over symmetries and
            // relabellings, `rotation_error_deg`) and the matched size error (`size_error_mm`).
            let m = match_axes(a, b);
            let r = m.rotation_error_deg;
            rot_m[k] = if r.is_nan() { f64::INFINITY } else { r };
            size_m[k] = [m.size_error_mm.x, m.size_error_mm.y, m.size_error_mm.z];
            let d = b.diagonal_mm();
            if let Some(v) = adds_refs[g].adds_mm_below(a, max_frac * d) {
                adds_m[k] = v / d;
            }
        }
    }
    let all_est = vec![true; ne];
    let all_gt = vec![true; ng];
    let iou_order: Vec<Vec<usize>> = (0..ne)
        .map(|e| argsort(ng, |g| -iou_m[e * ng + g]))
        .collect();
    let iou_assign: Vec<Vec<Option<usize>>> = IOU_THRESHOLDS
        .iter()
        .map(|&t| match_iou(&iou_m, &iou_order, ng, t, &all_est))
        .collect();
    let home: Vec<Option<usize>> = (0..ne)
        .map(|e| {
            iou_order[e]
                .first()
                .copied()
                .filter(|&g| iou_m[e * ng + g] > 0.0)
        })
        .collect();
    let size_idx = IOU_THRESHOLDS
        .iter()
        .position(|&t| t == SIZE_MATCH_IOU)
        .unwrap_or(0);
    let size_err = iou_assign
        .get(size_idx)
        .map(|assign| {
            assign
                .iter()
                .enumerate()
                .map(|(e, m)| m.map(|g| size_m[e * ng + g]))
                .collect()
        })
        .unwrap_or_else(|| vec![None; ne]);

    let (pose_est_kept, pose_gt_kept) = if opts.pose_gating {
        let gate = match_iou(&iou_m, &iou_order, ng, GATING_IOU, &all_est);
        let mut gk = vec![false; ng];
        for g in gate.iter().flatten() {
            gk[*g] = true;
        }
        (gate.iter().map(Option::is_some).collect(), gk)
    } else {
        (all_est.clone(), all_gt.clone())
    };
    let pose_order: Vec<Vec<usize>> = (0..ne)
        .map(|e| argsort(ng, |g| rot_m[e * ng + g] + cm_m[e * ng + g]))
        .collect();
    let pose_assign = pose_thresholds
        .iter()
        .map(|&(deg, cm)| {
            match_first(&pose_order, ng, &pose_est_kept, &pose_gt_kept, |e, g| {
                rot_m[e * ng + g] <= deg + ROT_TOL_DEG && cm_m[e * ng + g] <= cm + TRANS_TOL_CM
            })
        })
        .collect();
    let adds_order: Vec<Vec<usize>> = (0..ne)
        .map(|e| argsort(ng, |g| adds_m[e * ng + g]))
        .collect();
    let adds_assign = ADDS_FRACTIONS
        .iter()
        .map(|&(_, f)| {
            match_first(&adds_order, ng, &pose_est_kept, &pose_gt_kept, |e, g| {
                adds_m[e * ng + g] < f
            })
        })
        .collect();
    ImageResult {
        scene_id,
        gts,
        ests,
        iou_assign,
        pose_est_kept,
        pose_gt_kept,
        pose_assign,
        adds_assign,
        home,
        size_err,
    }
}

/// Whether a GT counts in #GT for the whole evaluation (not ignored).
fn counted(gt: &GtEntry, opts: &EvalOptions) -> bool {
    let visible = gt.visib_fract >= opts.min_visib;
    let dims_ok = match gt.observed_dims {
        Some(n) => n >= opts.min_observed_dims,
        None => true,
    };
    visible && dims_ok
}

/// Linear-interpolated percentile (numpy's default), `q` in 0..=100, of sorted data.
pub(crate) fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let pos = q / 100.0 * (sorted.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let (a, b) = (sorted.get(lo)?, sorted.get(hi)?);
    Some(a + (b - a) * (pos - lo as f64))
}

/// Figures for one scope: the images `imgs` and the predicate `in_scope(global gt index)` that
/// says which GTs count (all others in those images are ignored).
fn figures(
    imgs: &[&ImageResult],
    ests_all: &[EstEntry],
    in_scope: &dyn Fn(usize) -> bool,
) -> Figures {
    let n_gt: usize = imgs
        .iter()
        .map(|im| im.gts.iter().filter(|&&g| in_scope(g)).count())
        .sum();
    let n_all_gt: usize = imgs.iter().map(|im| im.gts.len()).sum();
    let n_est: usize = imgs.iter().map(|im| im.ests.len()).sum();
    let n_pose_gt: usize = imgs
        .iter()
        .map(|im| {
            im.gts
                .iter()
                .zip(&im.pose_gt_kept)
                .filter(|(&g, &k)| k && in_scope(g))
                .count()
        })
        .sum();

    // Labels the ranked estimates of one assignment; `kept` filters estimates out of the
    // contest (pose gating).
    let label = |im: &ImageResult,
                 assign: &[Option<usize>],
                 kept: Option<&[bool]>,
                 out: &mut Vec<ScoredMatch>| {
        for (e, m) in assign.iter().enumerate() {
            if kept.is_some_and(|k| !k[e]) {
                continue;
            }
            let tp = match m {
                Some(g) => {
                    if !in_scope(im.gts[*g]) {
                        continue;
                    }
                    true
                }
                None => {
                    if im.home[e].is_some_and(|h| !in_scope(im.gts[h])) {
                        continue;
                    }
                    false
                }
            };
            let idx = im.ests[e];
            out.push(ScoredMatch {
                score: ests_all[idx].score,
                order: idx,
                tp,
            });
        }
    };
    let ap_of = |get: &dyn Fn(&ImageResult) -> &[Option<usize>], gated: bool, n: usize| {
        let mut v = Vec::with_capacity(n_est);
        for im in imgs {
            let kept = gated.then_some(im.pose_est_kept.as_slice());
            label(im, get(im), kept, &mut v);
        }
        voc_ap(&v, n)
    };

    let mut iou_ap = BTreeMap::new();
    for (t, thr) in IOU_THRESHOLDS.iter().enumerate() {
        let ap = ap_of(&|im| &im.iou_assign[t], false, n_gt);
        iou_ap.insert(format!("{thr}"), ap);
    }
    let pose_ap_at = |i: usize| ap_of(&|im| &im.pose_assign[i], true, n_pose_gt);
    let mut pose_ap = BTreeMap::new();
    for (i, (key, _, _)) in POSE_THRESHOLDS.iter().enumerate() {
        pose_ap.insert((*key).to_string(), pose_ap_at(i));
    }
    let mean_of = |start: usize| -> Option<f64> {
        let mut sum = 0.0;
        for k in 0..PACE_STEPS {
            sum += pose_ap_at(start + k)?;
        }
        Some(sum / PACE_STEPS as f64)
    };
    let base = POSE_THRESHOLDS.len();
    let mut pace = BTreeMap::new();
    pace.insert("20deg".to_string(), mean_of(base));
    pace.insert("5cm".to_string(), mean_of(base + PACE_STEPS));
    pace.insert("20deg_5cm".to_string(), mean_of(base + 2 * PACE_STEPS));
    let mut adds_ap = BTreeMap::new();
    for (i, (key, _)) in ADDS_FRACTIONS.iter().enumerate() {
        adds_ap.insert(
            (*key).to_string(),
            ap_of(&|im| &im.adds_assign[i], true, n_pose_gt),
        );
    }

    let size_idx = IOU_THRESHOLDS
        .iter()
        .position(|&t| t == SIZE_MATCH_IOU)
        .unwrap_or(0);
    let mut errs = Vec::new();
    let mut n_pairs = 0;
    for im in imgs {
        for (e, m) in im.iou_assign[size_idx].iter().enumerate() {
            if let (Some(g), Some(err)) = (m, im.size_err[e]) {
                if in_scope(im.gts[*g]) {
                    n_pairs += 1;
                    errs.extend_from_slice(&err);
                }
            }
        }
    }
    errs.sort_by(f64::total_cmp);
    Figures {
        iou_ap,
        pose_ap,
        pace,
        adds_ap,
        size_err_mm: SizeError {
            median: percentile(&errs, 50.0),
            p90: percentile(&errs, 90.0),
            n_pairs,
            matched_at_iou: SIZE_MATCH_IOU,
        },
        n_gt,
        n_est,
        n_ignored: n_all_gt - n_gt,
        n_pose_gt,
    }
}

/// Evaluates estimates against ground truths (pure, in memory, deterministic).
///
/// Images are the distinct `(scene_id, im_id)` pairs of either list; an estimate in an image
/// without ground truth is a false positive. See the crate docs for the matching rules.
///
/// ```
/// use anybox_eval::{evaluate, EstEntry, EvalOptions, GtEntry};
/// use anybox_geom::nalgebra::{Rotation3, Vector3};
/// use anybox_geom::OrientedBox;
///
/// let truth = OrientedBox::new(
///     Rotation3::identity(),
///     Vector3::new(0.0, 0.0, 800.0),   // centre, mm
///     Vector3::new(200.0, 100.0, 300.0), // size, mm
/// )?;
/// let mut guess = truth;
/// guess.center_mm.x += 40.0; // IoU = (200 − 40) / (200 + 40) = 2/3
/// let gts = [GtEntry { scene_id: 1, im_id: 0, gt_index: 0, pose: truth, visib_fract: 1.0,
///                      observed_dims: None }];
/// let ests = [EstEntry { scene_id: 1, im_id: 0, score: 0.9, pose: guess, gt_index: Some(0) }];
/// let report = evaluate(&gts, &ests, &EvalOptions::default());
/// assert_eq!(report.overall.iou_ap["0.5"], Some(1.0));
/// assert_eq!(report.overall.iou_ap["0.7"], Some(0.0));
/// assert_eq!(report.overall.pose_ap["trans_5cm"], Some(1.0)); // 4 cm off
/// println!("{}", report.to_table());
/// # Ok::<(), anybox_geom::GeomError>(())
/// ```
pub fn evaluate(gts: &[GtEntry], ests: &[EstEntry], opts: &EvalOptions) -> Report {
    let mut by_image: BTreeMap<(u32, u32), (Vec<usize>, Vec<usize>)> = BTreeMap::new();
    for (i, g) in gts.iter().enumerate() {
        by_image.entry((g.scene_id, g.im_id)).or_default().0.push(i);
    }
    for (i, e) in ests.iter().enumerate() {
        by_image.entry((e.scene_id, e.im_id)).or_default().1.push(i);
    }
    let thresholds = pose_threshold_list();
    let images: Vec<ImageResult> = by_image
        .into_par_iter()
        .map(|((scene, _), (g, e))| evaluate_image(gts, ests, scene, g, e, opts, &thresholds))
        .collect();
    let all: Vec<&ImageResult> = images.iter().collect();
    let counted_all = |g: usize| gts.get(g).is_some_and(|x| counted(x, opts));
    let overall = figures(&all, ests, &counted_all);

    let mut by_scene = BTreeMap::new();
    let mut scenes: Vec<u32> = images.iter().map(|im| im.scene_id).collect();
    scenes.dedup();
    for s in scenes {
        let imgs: Vec<&ImageResult> = images.iter().filter(|im| im.scene_id == s).collect();
        by_scene.insert(s, figures(&imgs, ests, &counted_all));
    }
    let mut by_visibility = BTreeMap::new();
    for (key, lo, hi) in VISIBILITY_BANDS {
        let in_band = |g: usize| {
            gts.get(g)
                .is_some_and(|x| counted(x, opts) && x.visib_fract >= lo && x.visib_fract < hi)
        };
        by_visibility.insert(key.to_string(), figures(&all, ests, &in_band));
    }
    let mut observed_dims_counts: Option<[usize; 4]> = None;
    for g in gts {
        if let Some(n) = g.observed_dims {
            let c = observed_dims_counts.get_or_insert([0; 4]);
            c[usize::from(n.min(3))] += 1;
        }
    }
    Report {
        iou_method: opts.iou,
        pose_gating: opts.pose_gating,
        min_visib: opts.min_visib,
        min_observed_dims: opts.min_observed_dims,
        overall,
        by_scene,
        by_visibility,
        observed_dims_counts,
        time_s: None,
    }
}
