//! PoseEstimate(C(s)) of the paper (§3.2): the 6D pose of a cuboid template of a *given* size.
//!
//! In: an [`Observation`], the depth map and camera, the template size (mm) and optionally a prior
//! pose (the previous estimate inside the scale-search loop). Out: a [`PoseEstimate`].
//!
//! Stages (SPEC §1):
//! 0. size-independent analysis, cached in the observation on the first call: face planes
//!    (normal clusters + RANSAC + PCA), candidate frames, a depth-noise estimate σ̂ from the
//!    plane residuals (thresholds below are raised to multiples of σ̂, `noise_scale`), and the
//!    depth cells of the filter;
//! 1. hypotheses ([`crate::hypotheses`]): geometric frames × 6 axis assignments, placed behind the
//!    visible faces; with a prior, the prior itself and, per frame, only the assignment closest to
//!    the prior (`HypothesisConfig::prior_restricts`);
//! 2. every hypothesis is translation-aligned (`coarse_align_iters` robust steps) to ~150
//!    observed points, then gets a cheap coarse score: the mean truncated distance of those points
//!    to its camera-facing surface divided by the truncation (in [0, 1], lower is better);
//! 3. depth-consistency penalty ([`crate::depth_filter`], the paper's filter) added to the coarse
//!    score to re-rank (`key = coarse + rank_weight · penalty`; switched off by
//!    `depth_filter.enabled = false`, the paper's ablation);
//! 4. for each of the `top_k` best keys (plus, with a prior, the best one keeping the prior's axes):
//!    placement variants along axes seen edge-on whose observed extent is shorter than the
//!    template (occlusion, wrong size) are compared by a quick score, the best is refined by
//!    robust ICP ([`crate::refine`]);
//! 5. ranking by confidence `score = inlier_fraction · silhouette_iou · (1 − depth_penalty)` (the
//!    last factor only when the filter is enabled), all three in [0, 1]. The silhouette is the
//!    convex hull of the projected corners, compared with the observed mask by an
//!    occlusion-aware IoU ([`silhouette_iou`]). With a prior, a result that changes the prior's
//!    axis assignment must win by `prior_switch_margin`; the returned rotation is the symmetric
//!    variant closest to the prior, so the loop's rotation-change test sees no spurious flips.
//!
//! Deterministic: every random choice uses fixed seeds from the config.
//!
//! Measured (release, one 2-core machine under load, thread CPU time, ~18k-point observation):
//! `observe` ≈ 2–3.5 ms, `estimate_pose` ≈ 1 ms without a prior, ≈ 0.6 ms with one; the SCALE
//! pipeline's whole loop (3 pose calls) ≈ 7.7 ms. See the ignored `report_*` tests.

use std::borrow::Cow;

use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::image::DepthMap;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

use crate::depth_filter::{depth_penalty, CellMinDepth, DepthFilterConfig, SurfaceSamples};
use crate::error::EstimateError;
use crate::hypotheses::{cached_analysis, generate, robust_extent, HypothesisConfig};
use crate::observation::Observation;
use crate::refine::{
    align_translation, closest_on_faces, inlier_stats, refine_pose, visible_faces, RefineConfig,
};

/// How the cheap pre-refinement score measures point-to-template distance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CoarseScore {
    /// Distance to the camera-facing faces only (default; visibility-aware).
    VisibleSurface,
    /// Distance to the whole surface, like symmetric point-cloud matching without visibility
    /// reasoning (what a learned matcher sees; lets "hovering" poses score well, which is what
    /// the depth filter is for).
    AllFaces,
}

/// Parameters of [`estimate_pose`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseConfig {
    /// Hypothesis generation.
    pub hypotheses: HypothesisConfig,
    /// The depth-consistency filter (paper defaults: 5 px cells, 1000 samples, threshold 0).
    pub depth_filter: DepthFilterConfig,
    /// ICP refinement.
    pub refine: RefineConfig,
    /// Coarse-score flavour. Default [`CoarseScore::VisibleSurface`].
    pub coarse: CoarseScore,
    /// Observed points used for the coarse score. Default 150.
    pub coarse_points: usize,
    /// Truncation of the coarse point distance, mm. Default 20 mm.
    pub coarse_trunc_mm: f64,
    /// Translation-only alignment steps applied to every hypothesis before the coarse score.
    /// Default 2; 0 scores hypotheses where the placement rule put them.
    pub coarse_align_iters: usize,
    /// Hypotheses refined by ICP. Default 2: refining 4 (the setting until 2026-12-01, kept by
    /// [`crate::config::Config::paper`]) took ~9 % more instructions per frame and scored
    /// lower on the generated benchmark (README, "Measured results").
    pub top_k: usize,
    /// Axes with `|axis · viewdir|` below this get placement variants (see
    /// [`ScoringContext::placement_variants`]). Default 0.35 (faces > 70° from the view ray).
    pub variant_cos: f64,
    /// Thresholds follow the depth noise estimated from the face planes (σ̂): the coarse
    /// truncation is at least `noise_scale · 3σ̂`, the Huber threshold `1.5σ̂`, the inlier residual
    /// `2σ̂`, the correspondence cut `6σ̂`. Default 1; 0 disables the adaptation.
    pub noise_scale: f64,
    /// With a prior: a result within this angle of the prior (modulo the box's 180° symmetries)
    /// keeps the prior's axis assignment, degrees. Default 20.
    pub prior_gate_deg: f64,
    /// With a prior: a result that changes the axis assignment must beat the best one that
    /// keeps it by this fraction of its score. Default 0.1.
    pub prior_switch_margin: f64,
    /// Without a prior, candidates are ranked by `score · size_agreement^weight` (see
    /// [`size_agreement`]); the reported score stays the plain confidence. Default 1; 0 = off.
    pub size_agreement_weight: f64,
    /// The depth-cell region is the mask's bounding box grown by this fraction of its larger
    /// side on every side. Default 1.0.
    pub region_margin: f64,
    /// Candidates are ranked by `score · plain_iou^weight`, where `plain_iou` is the silhouette
    /// IoU without the occlusion credit ([`silhouette_ious`]): of two poses that explain the
    /// observation equally well, the one hiding less of the box behind occluders wins (an
    /// occluded box's hidden part is otherwise unconstrained, e.g. two sides swapped). The
    /// reported score is unchanged. Default 0 = off (0.25–1 measured within ±1 box of off with
    /// the oracle size on two seeds).
    pub hidden_weight: f64,
    /// The reported confidence is multiplied by `plain_iou^score_hidden_weight` (see
    /// `hidden_weight`): a box mostly hidden behind occluders is less certain. Default 0 = off
    /// (measured: lower Spearman(score, IoU) on the synthetic bench).
    pub score_hidden_weight: f64,
    /// The reported confidence is multiplied by `exp(−w · max(0, rmse/σ̂ − 1))`, with `rmse` the
    /// inlier residual of the refined pose and σ̂ the estimated depth noise. Default 0 = off
    /// (measured: no better Spearman(score, IoU) on the synthetic bench).
    pub score_rmse_weight: f64,
}

impl Default for PoseConfig {
    fn default() -> Self {
        Self {
            hypotheses: HypothesisConfig::default(),
            depth_filter: DepthFilterConfig::default(),
            refine: RefineConfig::default(),
            coarse: CoarseScore::VisibleSurface,
            coarse_points: 150,
            coarse_trunc_mm: 20.0,
            coarse_align_iters: 2,
            top_k: 2,
            variant_cos: 0.35,
            noise_scale: 1.0,
            prior_gate_deg: 20.0,
            prior_switch_margin: 0.1,
            size_agreement_weight: 1.0,
            region_margin: 1.0,
            hidden_weight: 0.0,
            score_hidden_weight: 0.0,
            score_rmse_weight: 0.0,
        }
    }
}

/// The result of [`estimate_pose`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseEstimate {
    /// The best pose, with `size_mm` equal to the requested template size.
    pub pose: OrientedBox,
    /// Confidence in [0, 1] (module docs).
    pub score: f64,
    /// Fraction of (subsampled) observed points on the visible surface, [0, 1].
    pub inlier_fraction: f64,
    /// Occlusion-aware IoU of the cuboid silhouette with the observed mask, [0, 1] (see
    /// [`silhouette_iou`]).
    pub silhouette_iou: f64,
    /// Depth-consistency penalty of the returned pose, [0, 1].
    pub depth_penalty: f64,
    /// Hypotheses generated (after de-duplication of frames).
    pub n_hypotheses: usize,
}

/// A scored hypothesis before refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RankedHypothesis {
    /// The hypothesis.
    pub pose: OrientedBox,
    /// Coarse score in [0, 1], lower is better.
    pub coarse: f64,
    /// Depth-consistency penalty in [0, 1].
    pub penalty: f64,
    /// Ranking key (`coarse + rank_weight · penalty` when the filter is enabled, else `coarse`).
    pub key: f64,
}

/// The pixel rectangle `[u0, v0, u1, v1]` (inclusive; clipped to the image when the cells are
/// built) whose depth cells the filter reads for `obs`: the mask's bounding box grown by
/// `region_margin` times its larger side.
fn cells_region(obs: &Observation, cfg: &PoseConfig) -> [u32; 4] {
    let mr = &obs.mask_rows;
    let grow = (mr.width.max(mr.height) as f64 * cfg.region_margin.max(0.0)).ceil() as u32;
    [
        mr.u0.saturating_sub(grow),
        mr.v0.saturating_sub(grow),
        mr.u0.saturating_add(mr.width).saturating_add(grow),
        mr.v0.saturating_add(mr.height).saturating_add(grow),
    ]
}

/// The settings the cached depth cells were built with.
fn cells_key(cfg: &PoseConfig) -> (u32, u64) {
    (cfg.depth_filter.cell_px, cfg.region_margin.to_bits())
}

/// Fills `obs`'s depth-cell cache from `frame_cells`, cells of the whole depth map `obs` was
/// built from ([`CellMinDepth::full`] with `cfg.depth_filter.cell_px`), so that
/// [`estimate_pose`] copies its region instead of reading the pixels again: a frame's masks
/// share one pass over the depth map. The estimates are the same. Does nothing when the cache
/// is already filled or the cell sizes differ.
pub fn share_frame_cells(obs: &Observation, frame_cells: &CellMinDepth, cfg: &PoseConfig) {
    if frame_cells.cell_px != cfg.depth_filter.cell_px.max(1) || obs.cache.cells.get().is_some() {
        return;
    }
    let [u0, v0, u1, v1] = cells_region(obs, cfg);
    if let Some(cells) = frame_cells.window(u0, v0, u1, v1) {
        let key = cells_key(cfg);
        // Already filled (by another thread): that one is the same.
        let _ = obs.cache.cells.set((key.0, key.1, cells));
    }
}

/// Per-call context shared by every hypothesis (built once in [`estimate_pose`]).
pub struct ScoringContext<'a> {
    obs: &'a Observation,
    intrinsics: &'a Intrinsics,
    cells: Cow<'a, CellMinDepth>,
    samples: SurfaceSamples,
    coarse_pts: Vec<Point3<f64>>,
}

impl<'a> ScoringContext<'a> {
    /// Builds the depth cells over the mask's neighbourhood and the surface samples for `size_mm`.
    pub fn new(
        obs: &'a Observation,
        depth: &DepthMap,
        intrinsics: &'a Intrinsics,
        size_mm: &Vector3<f64>,
        cfg: &PoseConfig,
    ) -> Self {
        let build = || {
            let [u0, v0, u1, v1] = cells_region(obs, cfg);
            CellMinDepth::new(depth, cfg.depth_filter.cell_px, u0, v0, u1, v1)
        };
        let key = cells_key(cfg);
        let cached = obs.cache.cells.get_or_init(|| (key.0, key.1, build()));
        let cells = if (cached.0, cached.1) == key {
            Cow::Borrowed(&cached.2)
        } else {
            Cow::Owned(build())
        };
        let samples =
            SurfaceSamples::new(size_mm, cfg.depth_filter.n_samples, cfg.depth_filter.seed);
        let sub = &obs.subsample;
        let m = cfg.coarse_points.max(1);
        let coarse_pts = if sub.len() <= m {
            sub.iter().map(|&i| obs.points_mm[i]).collect()
        } else {
            (0..m)
                .map(|j| obs.points_mm[sub[j * sub.len() / m]])
                .collect()
        };
        Self {
            obs,
            intrinsics,
            cells,
            samples,
            coarse_pts,
        }
    }

    /// Coarse score of one hypothesis, [0, 1], lower is better.
    pub fn coarse(&self, pose: &OrientedBox, cfg: &PoseConfig) -> f64 {
        const ALL: [(usize, f64); 6] = [
            (0, 1.0),
            (0, -1.0),
            (1, 1.0),
            (1, -1.0),
            (2, 1.0),
            (2, -1.0),
        ];
        let (vis, nv) = visible_faces(pose);
        let faces: &[(usize, f64)] = match cfg.coarse {
            CoarseScore::VisibleSurface => &vis[..nv],
            CoarseScore::AllFaces => &ALL,
        };
        let trunc = cfg.coarse_trunc_mm.max(1e-6);
        let rt = pose.rotation.matrix().transpose();
        let h = pose.half_size_mm();
        let mut s = 0.0;
        for p in &self.coarse_pts {
            let l = rt * (p.coords - pose.center_mm);
            let d = match closest_on_faces(&l, &h, faces) {
                Some((q, _, _)) => (l - q).norm(),
                None => trunc,
            };
            s += d.min(trunc);
        }
        if self.coarse_pts.is_empty() {
            1.0
        } else {
            s / (trunc * self.coarse_pts.len() as f64)
        }
    }

    /// Depth-consistency penalty of one hypothesis (its size must be the context's size).
    pub fn penalty(&self, pose: &OrientedBox, cfg: &PoseConfig) -> f64 {
        depth_penalty(
            pose,
            &self.samples,
            &self.cells,
            self.intrinsics,
            cfg.depth_filter.threshold_mm,
        )
    }

    /// Scores and sorts hypotheses by key, best first (stable: ties keep the input order).
    /// Each hypothesis is first translation-aligned (`cfg.coarse_align_iters` steps) to the
    /// coarse points; the ranked pose is the aligned one.
    pub fn rank(&self, hyps: &[OrientedBox], cfg: &PoseConfig) -> Vec<RankedHypothesis> {
        let mut out: Vec<RankedHypothesis> = hyps
            .iter()
            .map(|h0| {
                let h = &align_translation(
                    h0,
                    &self.coarse_pts,
                    cfg.coarse_align_iters,
                    cfg.refine.huber_mm,
                    cfg.refine.max_corr_mm,
                );
                let coarse = self.coarse(h, cfg);
                let penalty = self.penalty(h, cfg);
                let key = if cfg.depth_filter.enabled {
                    coarse + cfg.depth_filter.rank_weight * penalty
                } else {
                    coarse
                };
                RankedHypothesis {
                    pose: *h,

                    coarse,
                    penalty,
                    key,
                }
            })
            .filter(|r| r.key.is_finite())
            .collect();
        out.sort_by(|a, b| a.key.total_cmp(&b.key));
        out
    }

    /// IoU of the pose's silhouette (convex hull of the projected corners) with the observed mask.
    pub fn silhouette_iou(&self, pose: &OrientedBox) -> f64 {
        silhouette_iou(pose, self.obs, self.intrinsics)
    }

    /// Cheap confidence without ICP: coarse-point inlier fraction × silhouette IoU ×
    /// (1 − penalty) (the last factor only with the filter enabled).
    pub fn quick_score(&self, pose: &OrientedBox, cfg: &PoseConfig) -> f64 {
        let (inl, _) = inlier_stats(pose, &self.coarse_pts, &cfg.refine);
        let mut s = inl * self.silhouette_iou(pose);
        if cfg.depth_filter.enabled {
            s *= 1.0 - self.penalty(pose, cfg);
        }
        s
    }

    /// Placement variants along axes seen nearly edge-on (`|axis · viewdir| < variant_cos`)
    /// whose observed extent falls short of the template size (occlusion or a wrong size): the
    /// box anchored at either end of the observed extent as well as where it is. The depth filter
    /// and the silhouette decide between them (a box overhanging the background is in front of
    /// it; one overhanging an occluder is behind it).
    pub fn placement_variants(&self, pose: &OrientedBox, cfg: &PoseConfig) -> Vec<OrientedBox> {
        let view = self.obs.view_dir();
        let mut scratch = Vec::with_capacity(self.obs.subsample.len());
        let mut shifts: Vec<Vec<f64>> = Vec::with_capacity(3);
        for k in 0..3 {
            let a = pose.axis(k);
            let mut opts = vec![0.0];
            if a.dot(&view).abs() < cfg.variant_cos {
                let (lo, hi) =
                    robust_extent(self.obs, &a, cfg.hypotheses.extent_trim, &mut scratch);
                let s = pose.size_mm[k];
                let short = s - (hi - lo);
                if short > (0.05 * s).max(10.0) {
                    let c = a.dot(&pose.center_mm);
                    opts.push(lo + 0.5 * s - c);
                    opts.push(hi - 0.5 * s - c);
                }
            }
            shifts.push(opts);
        }
        let mut out = Vec::new();
        for &dx in &shifts[0] {
            for &dy in &shifts[1] {
                for &dz in &shifts[2] {
                    let mut b = *pose;
                    b.center_mm += pose.rotation * Vector3::new(dx, dy, dz);
                    out.push(b);
                }
            }
        }
        out
    }
}

/// Occlusion-aware IoU between the convex hull of `pose`'s projected corners and `obs.mask`
/// (0 when a corner is behind the camera): hull pixels outside the mask that are explained by a
/// nearer occluder (or missing depth, when so configured; [`Observation::explained_rows`]) are left out of the
/// union, so a partly occluded box is not pushed to shrink into its visible part. Scanline over
/// the hull rows, counts from the row prefix sums (O(rows)).
pub fn silhouette_iou(pose: &OrientedBox, obs: &Observation, k: &Intrinsics) -> f64 {
    silhouette_ious(pose, obs, k).0
}

/// `(occlusion-aware IoU, plain IoU)` of the pose's silhouette with the mask: the first is
/// [`silhouette_iou`]; the second counts every silhouette pixel outside the mask as
/// disagreement (how much of the box is hidden behind occluders or missing depth).
pub fn silhouette_ious(pose: &OrientedBox, obs: &Observation, k: &Intrinsics) -> (f64, f64) {
    let Some(hull) = anybox_geom::projection::silhouette_hull_px(pose, k) else {
        return (0.0, 0.0);
    };
    if hull.len() < 3 {
        return (0.0, 0.0);
    }
    let (w, h) = (obs.mask.width as i64, obs.mask.height as i64);
    let ymin = hull.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let ymax = hull.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
    let v0 = (ymin.ceil().max(0.0) as i64).min(h);
    let v1 = (ymax.floor().min((h - 1) as f64) as i64).max(-1);
    let mut hull_n: u64 = 0;
    let mut inter: u64 = 0;
    let mut explained: u64 = 0;
    for v in v0..=v1 {
        let y = v as f64;
        let (mut xa, mut xb) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..hull.len() {
            let a = hull[i];
            let b = hull[(i + 1) % hull.len()];
            if (a.y - y) * (b.y - y) <= 0.0 {
                if (b.y - a.y).abs() < 1e-12 {
                    xa = xa.min(a.x.min(b.x));
                    xb = xb.max(a.x.max(b.x));
                } else {
                    let x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
                    xa = xa.min(x);
                    xb = xb.max(x);
                }
            }
        }
        if !(xa.is_finite() && xb.is_finite()) {
            continue;
        }
        let ua = (xa.ceil().max(0.0) as i64).min(w);
        let ub = (xb.floor().min((w - 1) as f64) as i64).max(-1);
        if ub < ua {
            continue;
        }
        hull_n += (ub - ua + 1) as u64;
        inter += obs.mask_rows.count_in_row(v, ua, ub) as u64;
        explained += obs.explained_rows.count_in_row(v, ua, ub) as u64;
    }
    // Silhouette pixels outside the mask that an occluder or missing depth explains are not
    // disagreement: leave them out of the union.
    let plain_union = (obs.mask_rows.count as u64 + hull_n).saturating_sub(inter);
    let union = plain_union.saturating_sub(explained);
    let ratio = |u: u64| if u == 0 { 0.0 } else { inter as f64 / u as f64 };
    (ratio(union), ratio(plain_union))
}

/// Geodesic angle between two rotations, degrees (clamped, never NaN for finite input).
pub fn rotation_angle_deg(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let c = (((a.matrix().transpose() * b.matrix()).trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    c.acos().to_degrees()
}

/// The 4 rotations of a box that keep every box with distinct sides onto itself.
fn box_symmetries() -> [Matrix3<f64>; 4] {
    [
        Matrix3::identity(),
        Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)),
        Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, -1.0)),
        Matrix3::from_diagonal(&Vector3::new(-1.0, -1.0, 1.0)),
    ]
}

/// The symmetric variant of `pose` (same physical box) whose rotation is closest to `reference`.
pub fn closest_variant(pose: &OrientedBox, reference: &Rotation3<f64>) -> OrientedBox {
    let mut best = *pose;
    let mut best_tr = f64::NEG_INFINITY;
    for s in box_symmetries() {
        let r = pose.rotation.matrix() * s;
        let tr = (reference.matrix().transpose() * r).trace();
        if tr > best_tr {
            best_tr = tr;
            best.rotation = Rotation3::from_matrix_unchecked(r);
        }
    }
    best
}

/// Agreement in [0, 1] between the template's extents and the observed points' robust extents
/// along the pose's axes: `Π_k min(e_k, s_k) / max(e_k, s_k)`. With a wrong (canonical) template
/// it prefers the axis assignment whose size order matches the observation — long template side
/// on the long observed side, short template side on a hidden or short one — which is the
/// assignment a per-axis scale search can correct.
pub fn size_agreement(obs: &Observation, pose: &OrientedBox, cfg: &HypothesisConfig) -> f64 {
    let mut scratch = Vec::with_capacity(obs.subsample.len());
    let mut a = 1.0;
    for k in 0..3 {
        let (lo, hi) = robust_extent(obs, &pose.axis(k), cfg.extent_trim, &mut scratch);
        // A hidden axis still has a few mm of extent from noise; floor it.
        let e = (hi - lo).max(1.0);
        let s = pose.size_mm[k];
        let r = e.min(s) / e.max(s);
        if r.is_finite() {
            a *= r;
        }
    }
    a
}

/// `cfg` with its distance thresholds raised to the estimated depth noise (`noise_scale`).
fn adapt_to_noise(cfg: &PoseConfig, noise_mm: f64) -> PoseConfig {
    let mut c = cfg.clone();
    let s = noise_mm * cfg.noise_scale;
    if s.is_finite() && s > 0.0 {
        c.coarse_trunc_mm = c.coarse_trunc_mm.max(3.0 * s);
        c.refine.huber_mm = c.refine.huber_mm.max(1.5 * s);
        c.refine.inlier_abs_mm = c.refine.inlier_abs_mm.max(2.0 * s);
        c.refine.max_corr_mm = c.refine.max_corr_mm.max(6.0 * s);
    }
    c
}

/// The paper's PoseEstimate(C(s)) for a cuboid template of size `size_mm` (module docs).
///
/// The size-independent parts (depth cells, hypothesis frames) are cached in `obs` on the first
/// call, so the scale loop's later calls are cheaper; `depth` must therefore be the depth map the
/// observation was built from (as it is in the pipeline).
///
/// Errors: [`EstimateError::BadTemplateSize`] for a non-finite or non-positive size,
/// [`EstimateError::SizeMismatch`] when the depth map and the observation's mask differ in size,
/// [`EstimateError::TooFewPoints`] for an observation with < 3 points, [`EstimateError::Geom`]
/// for invalid intrinsics,
/// [`EstimateError::NoHypothesis`] if nothing could be scored.
pub fn estimate_pose(
    obs: &Observation,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    size_mm: &Vector3<f64>,
    prior: Option<&OrientedBox>,
    cfg: &PoseConfig,
) -> Result<PoseEstimate, EstimateError> {
    if size_mm.iter().any(|s| !s.is_finite() || *s <= 0.0) {
        return Err(EstimateError::BadTemplateSize([
            size_mm.x, size_mm.y, size_mm.z,
        ]));
    }
    crate::observation::check_sizes(depth, &obs.mask)?;
    Intrinsics::new(intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy)?;
    if obs.subsample.len() < 3
        || obs.points_mm.len() != obs.normals.len()
        || obs.subsample.iter().any(|&i| i >= obs.points_mm.len())
    {
        return Err(EstimateError::TooFewPoints {
            valid: obs.subsample.len().min(obs.points_mm.len()),
            needed: 3,
        });
    }
    let prior = prior.filter(|p| {
        p.center_mm.iter().all(|v| v.is_finite())
            && p.rotation.matrix().iter().all(|v| v.is_finite())
    });
    let fs = cached_analysis(obs, &cfg.hypotheses);
    let adapted = adapt_to_noise(cfg, fs.noise_mm);
    let cfg = &adapted;
    let hyps = generate(obs, &fs.frames, size_mm, prior, &cfg.hypotheses);
    let n_hypotheses = hyps.len();
    let ctx = ScoringContext::new(obs, depth, intrinsics, size_mm, cfg);
    let ranked = ctx.rank(&hyps, cfg);
    if ranked.is_empty() {
        return Err(EstimateError::NoHypothesis("no hypothesis could be scored"));
    }
    let pts: Vec<Point3<f64>> = obs.subsample.iter().map(|&i| obs.points_mm[i]).collect();
    // With a prior, the best-ranked hypothesis that keeps the prior's axis assignment is always
    // refined, and a candidate that changes it must win by `prior_switch_margin`: the scale
    // loop's per-axis search needs a stable axis assignment.
    let near_prior = |b: &OrientedBox| {
        prior.is_some_and(|p| {
            let v = closest_variant(b, &p.rotation);
            rotation_angle_deg(&v.rotation, &p.rotation) <= cfg.prior_gate_deg
        })
    };
    let k = cfg.top_k.max(1);
    let mut chosen: Vec<&RankedHypothesis> = ranked.iter().take(k).collect();
    if prior.is_some() && !chosen.iter().any(|r| near_prior(&r.pose)) {
        if let Some(r) = ranked.iter().find(|r| near_prior(&r.pose)) {
            chosen.push(r);
        }
    }
    let mut best: Option<(f64, PoseEstimate)> = None;
    for r in chosen {
        // Best placement variant (occlusion / wrong size along edge-on axes), then ICP.
        let variants = ctx.placement_variants(&r.pose, cfg);
        let start = if variants.len() > 1 {
            variants
                .iter()
                .map(|v| (ctx.quick_score(v, cfg), v))
                .fold(None, |acc: Option<(f64, &OrientedBox)>, (s, v)| match acc {
                    Some((bs, _)) if bs >= s => acc,
                    _ => Some((s, v)),
                })
                .map_or(r.pose, |(_, v)| *v)
        } else {
            r.pose
        };
        let refined = refine_pose(&start, &pts, &cfg.refine);
        let pose = refined.pose;
        let (iou, plain_iou) = silhouette_ious(&pose, obs, intrinsics);
        let pen = ctx.penalty(&pose, cfg);
        let mut score = refined.inlier_fraction * iou;
        if cfg.depth_filter.enabled {
            score *= 1.0 - pen;
        }
        if cfg.score_hidden_weight > 0.0 {
            score *= plain_iou.max(0.0).powf(cfg.score_hidden_weight);
        }
        if cfg.score_rmse_weight > 0.0 && fs.noise_mm > 0.0 {
            let excess = (refined.inlier_rmse_mm / fs.noise_mm - 1.0).max(0.0);
            score *= (-cfg.score_rmse_weight * excess).exp();
        }
        if !score.is_finite() {
            continue;
        }
        let hidden = if cfg.hidden_weight > 0.0 {
            plain_iou.max(1e-6).powf(cfg.hidden_weight)
        } else {
            1.0
        };
        let rank_score = hidden
            * if prior.is_some() {
                if near_prior(&pose) {
                    score
                } else {
                    score * (1.0 - cfg.prior_switch_margin)
                }
            } else if cfg.size_agreement_weight > 0.0 {
                score * size_agreement(obs, &pose, &cfg.hypotheses).powf(cfg.size_agreement_weight)
            } else {
                score
            };
        if best.as_ref().is_none_or(|b| rank_score > b.0) {
            best = Some((
                rank_score,
                PoseEstimate {
                    pose,
                    score,
                    inlier_fraction: refined.inlier_fraction,
                    silhouette_iou: iou,
                    depth_penalty: pen,
                    n_hypotheses,
                },
            ));
        }
    }
    let best = best.map(|b| b.1);
    let mut best = best.ok_or(EstimateError::NoHypothesis(
        "every refined hypothesis failed",
    ))?;
    if let Some(p) = prior {
        best.pose = closest_variant(&best.pose, &p.rotation);
    }
    Ok(best)
}

#[cfg(test)]
mod tests;
