//! VOC all-point interpolated average precision, exactly as NOCS
//! `utils.py::compute_ap_from_matches_scores` (notes §1.1).

/// One scored prediction after matching: its score, its position in the caller's input (the
/// stable tie-break: among equal scores the earlier input ranks first) and whether it is a true
/// positive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoredMatch {
    /// Confidence score; higher ranks first.
    pub score: f64,
    /// Index in the caller's input list; breaks score ties (lower first).
    pub order: usize,
    /// True positive (matched a counted ground truth).
    pub tp: bool,
}

/// Sorts predictions by score (descending; NaN scores rank last) with the stable input-order
/// tie-break used everywhere in this crate.
pub fn sort_by_score(preds: &mut [ScoredMatch]) {
    preds.sort_by(|a, b| {
        let sa = if a.score.is_nan() {
            f64::NEG_INFINITY
        } else {
            a.score
        };
        let sb = if b.score.is_nan() {
            f64::NEG_INFINITY
        } else {
            b.score
        };
        sb.total_cmp(&sa).then(a.order.cmp(&b.order))
    });
}

/// VOC all-point AP of `preds` against `n_gt` counted ground truths.
///
/// Precision and recall are accumulated in score order (`recall = TP_cum / n_gt` over the whole
/// set), padded with precision 0 at both ends and recall 0 / 1, precision is made non-increasing
/// from the right, and `Σ Δrecall · precision` is summed at the recall change points.
///
/// Returns `None` when `n_gt == 0` (AP is undefined; NOCS would divide by zero). With ground
/// truths but no predictions the AP is 0.
pub fn voc_ap(preds: &[ScoredMatch], n_gt: usize) -> Option<f64> {
    if n_gt == 0 {
        return None;
    }
    let mut sorted = preds.to_vec();
    sort_by_score(&mut sorted);
    let n = sorted.len();
    let mut precision = Vec::with_capacity(n + 2);
    let mut recall = Vec::with_capacity(n + 2);
    precision.push(0.0);
    recall.push(0.0);
    let mut tp = 0usize;
    for (i, p) in sorted.iter().enumerate() {
        if p.tp {
            tp += 1;
        }
        precision.push(tp as f64 / (i + 1) as f64);
        recall.push(tp as f64 / n_gt as f64);
    }
    precision.push(0.0);
    recall.push(1.0);
    for i in (0..precision.len() - 1).rev() {
        precision[i] = precision[i].max(precision[i + 1]);
    }
    let mut ap = 0.0;
    for i in 1..recall.len() {
        if recall[i] != recall[i - 1] {
            ap += (recall[i] - recall[i - 1]) * precision[i];
        }
    }
    Some(ap)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(score: f64, tp: bool) -> ScoredMatch {
        ScoredMatch {
            score,
            order: 0,
            tp,
        }
    }

    fn seq(v: &[(f64, bool)]) -> Vec<ScoredMatch> {
        v.iter()
            .enumerate()
            .map(|(i, &(score, tp))| ScoredMatch {
                score,
                order: i,
                tp,
            })
            .collect()
    }

    #[test]
    fn perfect_and_empty() {
        // Two TPs for two GTs: precision 1 at recall 0.5 and 1 → AP 1.
        assert_eq!(voc_ap(&seq(&[(0.9, true), (0.8, true)]), 2), Some(1.0));
        // No predictions: recall never rises above 0 → AP 0.
        assert_eq!(voc_ap(&[], 3), Some(0.0));
        // No GTs: undefined.
        assert_eq!(voc_ap(&[m(0.5, false)], 0), None);
    }

    #[test]
    fn one_miss() {
        // Two TPs, 3 GTs: recall reaches 2/3 at precision 1; the last third never is reached
        // (padded recall 1 has precision 0) → AP = 2/3.
        let ap = voc_ap(&seq(&[(0.9, true), (0.8, true)]), 3).unwrap();
        assert!((ap - 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn fp_ranked_above_tp() {
        // FP (0.9), TP (0.8), TP (0.7), 2 GTs.
        // precision: 0, 1/2, 2/3; recall: 0, 1/2, 1. Interpolated precision at recall 1/2 is
        // max(1/2, 2/3) = 2/3, at 1 it is 2/3 → AP = 1/2·2/3 + 1/2·2/3 = 2/3.
        let ap = voc_ap(&seq(&[(0.9, false), (0.8, true), (0.7, true)]), 2).unwrap();
        assert!((ap - 2.0 / 3.0).abs() < 1e-12);
        // TP (0.9), FP (0.8), TP (0.7): precision 1, 1/2, 2/3; recall 1/2, 1/2, 1 →
        // 1/2·1 + 1/2·2/3 = 5/6.
        let ap = voc_ap(&seq(&[(0.9, true), (0.8, false), (0.7, true)]), 2).unwrap();
        assert!((ap - 5.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn ties_break_by_input_order() {
        // Equal scores: the input order decides. FP first then TP (1 GT): precision 1/2 at
        // recall 1 → AP 1/2. TP first: AP 1.
        let ap = voc_ap(&seq(&[(0.5, false), (0.5, true)]), 1).unwrap();
        assert!((ap - 0.5).abs() < 1e-12);
        let ap = voc_ap(&seq(&[(0.5, true), (0.5, false)]), 1).unwrap();
        assert!((ap - 1.0).abs() < 1e-12);
    }
}
