//! Evaluation of 9-DoF box estimates (SPEC §4; protocols from notes §1–2).
//!
//! In: ground truths ([`GtEntry`]) and estimates ([`EstEntry`]), each tagged with its image
//! `(scene_id, im_id)`, poses as [`OrientedBox`] (mm). Out: a [`Report`] with
//!
//! - **detection AP** at 3D IoU 0.25, 0.5, 0.7, 0.75, 0.8, 0.9 (IoU variant chosen by
//!   [`EvalOptions::iou`]);
//! - **pose AP** at single (rotation°, translation cm) thresholds, rotation-only and
//!   translation-only, and the **PACE** threshold-averaged variants;
//! - **ADD-S AP** at 0.1 d and 0.15 d (d = the true box's diagonal);
//! - **size error** (median, p90, mm) over pairs matched at IoU 0.25;
//! - counts, and all of it broken down by scene and by visibility band.
//!
//! # Matching and AP (NOCS `compute_3d_matches` / `compute_ap_from_matches_scores`)
//! Within each image, estimates are ranked by score (descending; ties keep input order). Each
//! estimate in turn walks the ground truths by descending IoU, skips those already matched, stops
//! at the first with IoU below the threshold, and matches one with IoU strictly above it
//! (greedy, one-to-one). AP is VOC all-point interpolated over the whole set, `recall =
//! TP_cum / #GT`. AP is `null` (`None`) where a scope has no counted ground truth.
//!
//! Pose matching follows NOCS `compute_match_from_degree_cm`: each estimate walks the ground
//! truths by ascending `degrees + centimetres` and takes the first unmatched one within both
//! thresholds (`≤`, with a 1e-3° / 1e-3 mm rounding tolerance so that exact estimates pass the
//! 0° and 0 cm thresholds of the PACE averages). Rotation-only AP uses a 100 cm translation
//! bound, translation-only a 360° rotation bound, as NOCS does. Rotation error is
//! `anybox_geom::symmetry`'s: the smallest geodesic angle over the box's symmetries and
//! size-consistent axis relabellings; translation error is the centre distance.
//!
//! With `pose_gating` (NOCS `use_matches_for_pose`), estimates and ground truths not matched at
//! IoU 0.1 are dropped before pose and ADD-S matching, so those recalls are over the detected
//! ground truths only (`n_pose_gt`). ADD-S matching (BOP `match_poses`): each estimate takes the
//! unmatched ground truth with the smallest ADD-S/d, if ADD-S < f·d. ADD-S samples each box at
//! its own size, so it mixes size and pose error (notes §2).
//!
//! Size error pools the three per-axis absolute errors (axes matched by
//! `anybox_geom::symmetry`) of every pair matched at IoU > 0.25.
//!
//! # Ignored ground truths
//! A ground truth is *ignored* when its `visib_fract` is below [`EvalOptions::min_visib`], or
//! when it is known to show fewer than [`EvalOptions::min_observed_dims`] of its dimensions
//! (`GtEntry::observed_dims`; `None` = unknown = not ignored). Ignored ground truths take part in
//! matching like any other (so they are consumed one-to-one), but do not count in #GT, and:
//! - an estimate whose match is an ignored ground truth is removed (neither TP nor FP);
//! - an estimate that matches nothing, but whose highest-IoU ground truth (IoU > 0) is ignored,
//!   is removed as well — a poor estimate of a box we chose not to score is not a false alarm.
//!
//! Breakdowns reuse the same matching: a scene's figures use its images only; a visibility band
//! ignores every ground truth outside the band (so estimates that belong to them are removed,
//! by the rules above), while estimates that overlap no ground truth at all stay false
//! positives in every band.

mod ap;
mod dataset;
mod evaluate;
pub mod geom_compat;
mod observed;
mod report;

pub use ap::{voc_ap, ScoredMatch};
pub use dataset::{evaluate_dataset, EvalError};
pub use evaluate::{
    evaluate, ADDS_FRACTIONS, ADDS_SAMPLES, IOU_THRESHOLDS, PACE_STEPS, POSE_THRESHOLDS,
    SIZE_MATCH_IOU, VISIBILITY_BANDS,
};
pub use geom_compat::IouMethod;
pub use observed::{observed_dims, ObservedDims, MIN_FACE_FRACTION, MIN_FACE_PX};
pub use report::{Figures, Report, SizeError, TimeSummary};

use anybox_geom::OrientedBox;
use serde::{Deserialize, Serialize};

/// Options of an evaluation run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EvalOptions {
    /// Which 3D IoU is used for detection AP, pose gating and size-error pairing.
    pub iou: IouMethod,
    /// Ground truths with `visib_fract` below this are ignored (default 0.1).
    pub min_visib: f64,
    /// NOCS `use_matches_for_pose`: drop estimates and ground truths not matched at IoU 0.1
    /// before pose and ADD-S matching (default off).
    pub pose_gating: bool,
    /// Ground truths showing fewer than this many of their dimensions are ignored (default 0 =
    /// off; 3 = score only boxes whose three extents are all observable).
    pub min_observed_dims: u8,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            iou: IouMethod::Exact,
            min_visib: 0.1,
            pose_gating: false,
            min_observed_dims: 0,
        }
    }
}

/// One ground-truth box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GtEntry {
    /// BOP scene id.
    pub scene_id: u32,
    /// BOP image id.
    pub im_id: u32,
    /// Index of this instance in the image's `scene_gt.json` list.
    pub gt_index: usize,
    /// True box (centre, rotation, size), camera frame, mm.
    pub pose: OrientedBox,
    /// Visible fraction of the box's projection (BOP `visib_fract`, 0..1).
    pub visib_fract: f64,
    /// How many of the box's three dimensions the view shows (see [`observed_dims`]);
    /// `None` when not computed.
    pub observed_dims: Option<u8>,
}

/// One estimated box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EstEntry {
    /// BOP scene id.
    pub scene_id: u32,
    /// BOP image id.
    pub im_id: u32,
    /// Confidence; higher ranks first.
    pub score: f64,
    /// Estimated box, camera frame, mm.
    pub pose: OrientedBox,
    /// Ground-truth index of the mask the estimate came from, when known. Informational only:
    /// matching is geometric, as in NOCS.
    pub gt_index: Option<usize>,
}
