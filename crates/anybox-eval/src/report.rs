//! The evaluation report: JSON layout (SPEC §4 / issue keys) and a fixed-width text table.
//!
//! JSON top level: `iou_method`, `pose_gating`, `min_visib`, `min_observed_dims`, then the
//! overall [`Figures`] flattened (`iou_ap`, `pose_ap`, `pace`, `adds_ap`, `size_err_mm`, `n_gt`,
//! `n_est`, `n_ignored`, `n_pose_gt`), then `by_scene` (scene id → [`Figures`]) and
//! `by_visibility` (band → [`Figures`]). APs are fractions in 0..1, `null` where the scope has
//! no counted ground truth.
//!
//! Keys:
//! - `iou_ap`: the IoU threshold as a string: `"0.25"`, `"0.5"`, `"0.7"`, `"0.75"`, `"0.8"`,
//!   `"0.9"` (a match needs IoU strictly above it).
//! - `pose_ap`: `"5deg_1cm"`, `"5deg_2cm"`, `"5deg_5cm"`, `"10deg_2cm"`, `"10deg_5cm"`,
//!   `"20deg_5cm"` (rotation ≤ and translation ≤), `"rot_5deg"`, `"rot_10deg"`, `"rot_20deg"`
//!   (rotation only), `"trans_1cm"`, `"trans_2cm"`, `"trans_5cm"` (translation only).
//! - `pace`: `"20deg"` (mean rotation-only AP over 0,1,…,20°), `"5cm"` (mean translation-only AP
//!   over 0,0.25,…,5 cm), `"20deg_5cm"` (mean over the pairs (k°, k/4 cm), k = 0..20).
//! - `adds_ap`: `"0.1d"`, `"0.15d"` (ADD-S < f × true box diagonal).
//! - `size_err_mm`: `median`, `p90` (mm, per-axis absolute errors of the pairs matched at IoU
//!   `matched_at_iou` = 0.25, pooled over the three axes; linear-interpolated percentiles),
//!   `n_pairs`.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::evaluate::{ADDS_FRACTIONS, IOU_THRESHOLDS, POSE_THRESHOLDS};
use crate::IouMethod;

/// Size-error summary, mm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SizeError {
    /// Median per-axis absolute size error, mm (`None` without matched pairs).
    pub median: Option<f64>,
    /// 90th percentile of the per-axis absolute size error, mm.
    pub p90: Option<f64>,
    /// Number of matched (estimate, ground truth) pairs the errors come from.
    pub n_pairs: usize,
    /// The IoU threshold at which the pairs were matched (0.25).
    pub matched_at_iou: f64,
}

/// Wall time read from the results file's `time` field, s (SPEC §4 "Time").
///
/// The results file holds the time of the whole image on every record of that image (BOP19
/// convention, as `anybox estimate` writes it); a frame's time is the largest `time` of its
/// records, an instance's time is its frame's time divided by the frame's record count. Negative
/// times (unknown) are skipped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimeSummary {
    /// Frames with a known time.
    pub n_frames: usize,
    /// Mean time per frame, s.
    pub per_frame_mean: f64,
    /// Median time per frame, s.
    pub per_frame_median: f64,
    /// 90th percentile of the time per frame, s.
    pub per_frame_p90: f64,
    /// Mean time per instance (frame time / instances in the frame), s.
    pub per_instance_mean: f64,
}

/// All figures of one scope (the whole set, one scene, or one visibility band).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Figures {
    /// Detection AP by IoU threshold (`"0.5"` …).
    pub iou_ap: BTreeMap<String, Option<f64>>,
    /// Single-threshold pose AP (`"5deg_1cm"`, `"rot_5deg"`, `"trans_1cm"` …).
    pub pose_ap: BTreeMap<String, Option<f64>>,
    /// PACE threshold-averaged pose AP (`"20deg"`, `"5cm"`, `"20deg_5cm"`).
    pub pace: BTreeMap<String, Option<f64>>,
    /// ADD-S AP (`"0.1d"`, `"0.15d"`).
    pub adds_ap: BTreeMap<String, Option<f64>>,
    /// Size error of pairs matched at IoU 0.25, mm.
    pub size_err_mm: SizeError,
    /// Counted (not ignored) ground truths.
    pub n_gt: usize,
    /// Estimates in scope.
    pub n_est: usize,
    /// Ground truths in the scope's images that were not counted: ignored (visibility,
    /// observed dims) or, for a visibility band, outside the band. Shown as "excluded".
    pub n_ignored: usize,
    /// Ground truths the pose and ADD-S APs count (= `n_gt` unless pose gating dropped some).
    pub n_pose_gt: usize,
}

/// The result of an evaluation run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The 3D IoU variant used.
    pub iou_method: IouMethod,
    /// Whether pose/ADD-S matching was gated by IoU > 0.1 (NOCS `use_matches_for_pose`).
    pub pose_gating: bool,
    /// Visibility below which ground truths were ignored.
    pub min_visib: f64,
    /// Observed-dimension count below which ground truths were ignored (0 = off).
    pub min_observed_dims: u8,
    /// Figures over the whole set.
    #[serde(flatten)]
    pub overall: Figures,
    /// Figures per scene id.
    pub by_scene: BTreeMap<u32, Figures>,
    /// Figures per visibility band (`"[0.1,0.3)"`, `"[0.3,0.5)"`, `"[0.5,0.8)"`, `"[0.8,1.0]"`).
    pub by_visibility: BTreeMap<String, Figures>,
    /// Ground truths (all, before ignoring) showing 0, 1, 2, 3 of their dimensions, when
    /// observed dimensions were computed (`--min-observed-dims`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observed_dims_counts: Option<[usize; 4]>,
    /// Timing from the results file (set by `evaluate_dataset`; absent from `evaluate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_s: Option<TimeSummary>,
}

fn pct(v: Option<f64>) -> String {
    match v {
        Some(x) => format!("{:6.1}", 100.0 * x),
        None => format!("{:>6}", "-"),
    }
}

fn mm(v: Option<f64>) -> String {
    match v {
        Some(x) => format!("{x:8.1}"),
        None => format!("{:>8}", "-"),
    }
}

impl Report {
    /// Scopes in table order: all, scenes, bands.
    fn scopes(&self) -> Vec<(String, &Figures)> {
        let mut v = vec![("all".to_string(), &self.overall)];
        for (s, f) in &self.by_scene {
            v.push((format!("scene {s}"), f));
        }
        for (b, f) in &self.by_visibility {
            v.push((format!("visib {b}"), f));
        }
        v
    }

    /// A readable fixed-width table (APs in percent) that states the IoU variant and gating.
    pub fn to_table(&self) -> String {
        let mut s = String::new();
        let gating = if self.pose_gating {
            "on (pose/ADD-S AP over GTs matched at IoU > 0.1, NOCS use_matches_for_pose)"
        } else {
            "off (pose/ADD-S AP over all counted GTs)"
        };
        let _ = writeln!(s, "3D IoU: {}   pose gating: {gating}", self.iou_method);
        let _ = writeln!(
            s,
            "ignored: visib_fract < {}{}; AP = VOC all-point (NOCS), in %",
            self.min_visib,
            if self.min_observed_dims > 0 {
                format!(", fewer than {} observed dims", self.min_observed_dims)
            } else {
                String::new()
            }
        );
        if let Some(c) = self.observed_dims_counts {
            let _ = writeln!(
                s,
                "ground truths showing 0/1/2/3 dimensions: {}/{}/{}/{}",
                c[0], c[1], c[2], c[3]
            );
        }
        let scopes = self.scopes();
        let w = scopes
            .iter()
            .map(|(n, _)| n.len())
            .max()
            .unwrap_or(3)
            .max(5);

        let _ = writeln!(s, "\nCounts");
        let _ = writeln!(
            s,
            "{:w$}  {:>6} {:>6} {:>8} {:>8}",
            "", "n_gt", "n_est", "excluded", "pose_gt"
        );
        for (name, f) in &scopes {
            let _ = writeln!(
                s,
                "{name:w$}  {:>6} {:>6} {:>8} {:>8}",
                f.n_gt, f.n_est, f.n_ignored, f.n_pose_gt
            );
        }

        let _ = writeln!(s, "\nDetection AP (3D IoU > threshold)");
        let _ = write!(s, "{:w$} ", "");
        for t in IOU_THRESHOLDS {
            let _ = write!(s, " {:>6}", format!("{t}"));
        }
        let _ = writeln!(s);
        for (name, f) in &scopes {
            let _ = write!(s, "{name:w$} ");
            for t in IOU_THRESHOLDS {
                let _ = write!(
                    s,
                    " {}",
                    pct(f.iou_ap.get(&format!("{t}")).copied().flatten())
                );
            }
            let _ = writeln!(s);
        }

        let _ = writeln!(s, "\nPose AP (single threshold; rot ≤ deg, trans ≤ cm)");
        let _ = write!(s, "{:w$} ", "");
        for (k, _, _) in POSE_THRESHOLDS {
            let _ = write!(s, " {k:>9}");
        }
        let _ = writeln!(s);
        for (name, f) in &scopes {
            let _ = write!(s, "{name:w$} ");
            for (k, _, _) in POSE_THRESHOLDS {
                let _ = write!(s, "    {}", pct(f.pose_ap.get(k).copied().flatten()));
            }
            let _ = writeln!(s);
        }

        let _ = writeln!(
            s,
            "\nPACE averaged AP, ADD-S AP, size error (pairs at IoU > 0.25, per axis, mm)"
        );
        let _ = writeln!(
            s,
            "{:w$}  {:>6} {:>6} {:>9}  {:>6} {:>6}  {:>8} {:>8} {:>6}",
            "", "20deg", "5cm", "20deg_5cm", "0.1d", "0.15d", "median", "p90", "pairs"
        );
        for (name, f) in &scopes {
            let g = |m: &BTreeMap<String, Option<f64>>, k: &str| m.get(k).copied().flatten();
            let _ = writeln!(
                s,
                "{name:w$}  {} {} {:>9}  {} {}  {} {} {:>6}",
                pct(g(&f.pace, "20deg")),
                pct(g(&f.pace, "5cm")),
                pct(g(&f.pace, "20deg_5cm")),
                pct(g(&f.adds_ap, ADDS_FRACTIONS[0].0)),
                pct(g(&f.adds_ap, ADDS_FRACTIONS[1].0)),
                mm(f.size_err_mm.median),
                mm(f.size_err_mm.p90),
                f.size_err_mm.n_pairs
            );
        }
        if let Some(t) = &self.time_s {
            let _ = writeln!(
                s,
                "\nTime (results file): per frame mean {:.3} s, median {:.3} s, p90 {:.3} s \
                 over {} frames; per instance mean {:.3} s",
                t.per_frame_mean,
                t.per_frame_median,
                t.per_frame_p90,
                t.n_frames,
                t.per_instance_mean
            );
        }
        s
    }
}
