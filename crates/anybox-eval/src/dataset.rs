//! Evaluating a results file against a BOP dataset split (`anybox eval`).
//!
//! In: a BOP dataset root and split (read with `anybox_io::bop::BopDataset`), and an anybox
//! results JSON (`anybox_io::results`). Out: the [`Report`] of [`evaluate`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use anybox_io::bop::BopDataset;
use anybox_io::IoError;
use rayon::prelude::*;

use crate::evaluate::percentile;
use crate::{evaluate, observed_dims, EstEntry, EvalOptions, GtEntry, Report, TimeSummary};

/// What can go wrong in [`evaluate_dataset`].
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// Reading the dataset, a mask or the results file failed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// An estimate names an image that the dataset split does not have.
    #[error(
        "{}: estimate {index} is for scene {scene_id} image {im_id}, which split '{split}' of the dataset does not contain",
        path.display()
    )]
    UnknownImage {
        /// The results file.
        path: PathBuf,
        /// Position of the estimate in the file.
        index: usize,
        /// Its scene id.
        scene_id: u32,
        /// Its image id.
        im_id: u32,
        /// The split evaluated.
        split: String,
    },
    /// An estimate's pose is not a valid box (rotation not orthonormal, size not positive …).
    #[error("{}: estimate {index}: {reason}", path.display())]
    BadEstimate {
        /// The results file.
        path: PathBuf,
        /// Position of the estimate in the file.
        index: usize,
        /// What is wrong.
        reason: String,
    },
    /// An option is out of range.
    #[error("invalid evaluation option: {0}")]
    BadOption(String),
}

/// Reads the ground truth of `dataset/split` and the estimates of `results`, and evaluates them.
///
/// When `opts.min_observed_dims > 0`, every ground truth's visible mask is loaded and
/// [`observed_dims`] is computed from the true pose and the view's intrinsics.
pub fn evaluate_dataset(
    dataset: &Path,
    split: &str,
    results: &Path,
    opts: &EvalOptions,
) -> Result<Report, EvalError> {
    if !(0.0..=1.0).contains(&opts.min_visib) {
        return Err(EvalError::BadOption(format!(
            "min_visib must be in 0..=1, got {}",
            opts.min_visib
        )));
    }
    if opts.min_observed_dims > 3 {
        return Err(EvalError::BadOption(format!(
            "min_observed_dims must be 0..=3, got {}",
            opts.min_observed_dims
        )));
    }
    let ds = BopDataset::open(dataset, split)?;
    let gts = load_gts(&ds, opts.min_observed_dims > 0)?;
    let (ests, times) = load_estimates(&ds, results)?;
    let mut report = evaluate(&gts, &ests, opts);
    report.time_s = time_summary(&times);
    Ok(report)
}

/// Ground truths of every view; with `with_dims`, observed dimensions from the masks.
fn load_gts(ds: &BopDataset, with_dims: bool) -> Result<Vec<GtEntry>, EvalError> {
    let per_view: Vec<Result<Vec<GtEntry>, EvalError>> = ds
        .views
        .par_iter()
        .map(|view| {
            view.gts
                .iter()
                .map(|g| {
                    let observed = if with_dims {
                        let mask = view.load_mask_visib(g.gt_index)?;
                        Some(observed_dims(&g.pose, &mask, &view.intrinsics).count)
                    } else {
                        None
                    };
                    Ok(GtEntry {
                        scene_id: view.scene_id,
                        im_id: view.im_id,
                        gt_index: g.gt_index,
                        pose: g.pose,
                        visib_fract: g.visib_fract,
                        observed_dims: observed,
                    })
                })
                .collect()
        })
        .collect();
    let mut out = Vec::with_capacity(ds.n_gt());
    for v in per_view {
        out.extend(v?);
    }
    Ok(out)
}

/// `(scene_id, im_id, time_s)` of one results record.
type RecordTime = (u32, u32, f64);

/// Per-image `(max time, record count)` from `(scene, image, time)` triples; see
/// [`TimeSummary`] for the convention.
fn time_summary(times: &[RecordTime]) -> Option<TimeSummary> {
    let mut per_image: BTreeMap<(u32, u32), (f64, usize)> = BTreeMap::new();
    for &(s, i, t) in times {
        let e = per_image.entry((s, i)).or_insert((f64::NEG_INFINITY, 0));
        e.0 = e.0.max(t);
        e.1 += 1;
    }
    let known: Vec<(f64, usize)> = per_image.into_values().filter(|(t, _)| *t >= 0.0).collect();
    if known.is_empty() {
        return None;
    }
    let mut frame: Vec<f64> = known.iter().map(|(t, _)| *t).collect();
    frame.sort_by(f64::total_cmp);
    let n_inst: usize = known.iter().map(|(_, n)| n).sum();
    let total: f64 = frame.iter().sum();
    Some(TimeSummary {
        n_frames: frame.len(),
        per_frame_mean: total / frame.len() as f64,
        per_frame_median: percentile(&frame, 50.0)?,
        per_frame_p90: percentile(&frame, 90.0)?,
        per_instance_mean: total / n_inst as f64,
    })
}

/// Estimates of the results file, and `(scene, image, time)` of every record.
fn load_estimates(
    ds: &BopDataset,
    results: &Path,
) -> Result<(Vec<EstEntry>, Vec<RecordTime>), EvalError> {
    let file = anybox_io::results::read_results(results)?;
    let images: BTreeSet<(u32, u32)> = ds.views.iter().map(|v| (v.scene_id, v.im_id)).collect();
    let mut out = Vec::with_capacity(file.estimates.len());
    let mut times = Vec::with_capacity(file.estimates.len());
    for (index, e) in file.estimates.iter().enumerate() {
        if !images.contains(&(e.scene_id, e.im_id)) {
            return Err(EvalError::UnknownImage {
                path: results.to_path_buf(),
                index,
                scene_id: e.scene_id,
                im_id: e.im_id,
                split: ds.split.clone(),
            });
        }
        let pose = e.pose().map_err(|err| EvalError::BadEstimate {
            path: results.to_path_buf(),
            index,
            reason: err.to_string(),
        })?;
        if !e.score.is_finite() || pose.center_mm.iter().any(|v| !v.is_finite()) {
            return Err(EvalError::BadEstimate {
                path: results.to_path_buf(),
                index,
                reason: format!("score and t must be finite (score {})", e.score),
            });
        }
        times.push((e.scene_id, e.im_id, e.time));
        out.push(EstEntry {
            scene_id: e.scene_id,
            im_id: e.im_id,
            score: e.score,
            pose,
            gt_index: e.gt_index,
        });
    }
    Ok((out, times))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_summary_by_frame_and_instance() {
        // Image (0,0): 0.4 s on both records; (0,1): 0.2 s; (0,2): unknown (−1), skipped.
        // Frames [0.2, 0.4]: mean 0.3, median 0.3, p90 = 0.2 + 0.9·0.2 = 0.38;
        // per instance (0.4 + 0.2) / 3 records = 0.2.
        let t = time_summary(&[(0, 0, 0.4), (0, 0, 0.4), (0, 1, 0.2), (0, 2, -1.0)]).unwrap();
        assert_eq!(t.n_frames, 2);
        assert!((t.per_frame_mean - 0.3).abs() < 1e-12);
        assert!((t.per_frame_median - 0.3).abs() < 1e-12);
        assert!((t.per_frame_p90 - 0.38).abs() < 1e-12);
        assert!((t.per_instance_mean - 0.2).abs() < 1e-12);
        assert!(time_summary(&[(0, 0, -1.0)]).is_none());
    }
}
