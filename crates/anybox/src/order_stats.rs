//! Exact order statistics of `f64` lists: the low and high ends of robust ranges.
//!
//! In: a list of values (mm or px, already projected) and two ranks. Out: the values of those
//! ranks, exactly as two `select_nth_unstable_by(.., f64::total_cmp)` calls give them. The scale
//! search and the detector ask for such pairs on every mask pixel, many times per box, with
//! ranks near the ends; one pass collects the values beyond two thresholds read off a small
//! sample, so only those few are selected among, instead of the whole list twice.

/// Values in the strided sample that sets the thresholds.
const SAMPLE: usize = 64;

/// Sample ranks added beyond the wanted fraction, against an unlucky sample.
const MARGIN: usize = 3;

/// Below this length, plain selection is as fast.
const SMALL: usize = 128;

// The sample's stride, `n / SAMPLE`, must be at least 1.
const _: () = assert!(SMALL >= SAMPLE);

/// The `k_lo`-th and `k_hi`-th smallest values of `v` (0-based ranks in the order of
/// [`f64::total_cmp`]; ranks past the end are clamped to the last). Reorders `v`. `None` when
/// `v` is empty.
pub(crate) fn rank_pair(v: &mut [f64], k_lo: usize, k_hi: usize) -> Option<(f64, f64)> {
    let n = v.len();
    if n == 0 {
        return None;
    }
    let (k_lo, k_hi) = (k_lo.min(n - 1), k_hi.min(n - 1));
    if n >= SMALL {
        if let Some(pair) = by_thresholds(v, k_lo, k_hi) {
            return Some(pair);
        }
    }
    Some(by_selection(v, k_lo, k_hi))
}

/// Two selections, the second only among the values the first left on its side.
fn by_selection(v: &mut [f64], k_lo: usize, k_hi: usize) -> (f64, f64) {
    let (a, b) = (k_lo.min(k_hi), k_lo.max(k_hi));
    let va = *v.select_nth_unstable_by(a, f64::total_cmp).1;
    let vb = if b == a {
        va
    } else {
        // After the first selection every value right of `a` ranks after it.
        *v[a + 1..]
            .select_nth_unstable_by(b - a - 1, f64::total_cmp)
            .1
    };
    if k_lo <= k_hi {
        (va, vb)
    } else {
        (vb, va)
    }
}

/// Values of the ranks `k_lo` (from the bottom) and `k_hi` (from the top), each the one
/// selected among the values beyond a threshold read off a small strided sample; a threshold
/// that does not hold enough values gives `None` (the caller selects plainly), as do NaN and
/// ranks in the middle half.
fn by_thresholds(v: &[f64], k_lo: usize, k_hi: usize) -> Option<(f64, f64)> {
    let n = v.len();
    let (k_lo, k_hi, swapped) = if k_lo <= k_hi {
        (k_lo, k_hi, false)
    } else {
        (k_hi, k_lo, true)
    };
    // From the top: rank n - 1 - k_hi.
    let top = n - 1 - k_hi;
    if k_lo >= n / 4 || top >= n / 4 {
        return None;
    }
    let step = n / SAMPLE;
    let mut sample = [0.0f64; SAMPLE];
    for (i, s) in sample.iter_mut().enumerate() {
        *s = v[i * step];
    }
    sample.sort_unstable_by(f64::total_cmp);
    // Sample ranks a few past the wanted fraction, so that the threshold holds the rank.
    let j = |k: usize| ((k + 1) * SAMPLE).div_ceil(n) + MARGIN;
    let t_lo = sample[j(k_lo).min(SAMPLE - 1)];
    let t_hi = sample[SAMPLE - 1 - j(top).min(SAMPLE - 1)];
    let mut low = Vec::with_capacity(n / 8);
    let mut high = Vec::with_capacity(n / 8);
    // `x * 0.0` is NaN exactly for NaN and infinite x; the sum keeps it.
    let mut poison = 0.0f64;
    for &x in v {
        poison += x * 0.0;
        if x <= t_lo {
            low.push(x);
        }
        if x >= t_hi {
            high.push(x);
        }
    }
    // With NaN the `<=` sets are not closed under the total order (NaN has a place at either
    // end of it); infinities are fine, but they poison the sum too, and are rare.
    if poison.is_nan() || low.len() <= k_lo || high.len() <= top {
        return None;
    }
    // `low` holds every value ranking at or below any of its members (a value ranking lower
    // is numerically no larger), so rank k_lo of all is rank k_lo of `low`; likewise `high`.
    let x_lo = *low.select_nth_unstable_by(k_lo, f64::total_cmp).1;
    let r = high.len() - 1 - top;
    let x_hi = *high.select_nth_unstable_by(r, f64::total_cmp).1;
    Some(if swapped { (x_hi, x_lo) } else { (x_lo, x_hi) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The reference: a full sort in the same total order.
    fn sorted_pair(v: &[f64], k_lo: usize, k_hi: usize) -> (f64, f64) {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        (s[k_lo.min(n - 1)], s[k_hi.min(n - 1)])
    }

    fn same(a: (f64, f64), b: (f64, f64)) -> bool {
        a.0.to_bits() == b.0.to_bits() && a.1.to_bits() == b.1.to_bits()
    }

    #[test]
    fn empty_gives_none_and_one_value_is_both_ends() {
        assert_eq!(rank_pair(&mut [], 0, 0), None);
        assert_eq!(rank_pair(&mut [3.5], 0, 7), Some((3.5, 3.5)));
    }

    #[test]
    fn ties_signed_zeros_and_non_finite_values_rank_as_total_cmp() {
        // Long enough for the threshold path; NaN and infinities send it to plain selection.
        let base: Vec<f64> = (0..2000)
            .map(|i| ((i * 7919) % 613) as f64 * 0.25)
            .collect();
        for special in [
            vec![],
            vec![-0.0, 0.0, -0.0],
            vec![f64::INFINITY],
            vec![f64::NEG_INFINITY, f64::INFINITY],
            vec![f64::NAN],
            vec![-f64::NAN, 1.0],
        ] {
            let mut v = base.clone();
            v.extend(&special);
            let n = v.len();
            for (k_lo, k_hi) in [
                (0, n - 1),
                (40, n - 41),
                (n / 2, n / 2),
                (n - 3, 2),
                (5, n + 9),
            ] {
                let want = sorted_pair(&v, k_lo, k_hi);
                let got = rank_pair(&mut v.clone(), k_lo, k_hi).unwrap();
                assert!(
                    same(got, want),
                    "{special:?} {k_lo} {k_hi}: {got:?} vs {want:?}"
                );
            }
        }
        let mut v = vec![2.0; 1500];
        assert_eq!(rank_pair(&mut v, 10, 1400), Some((2.0, 2.0)));
    }

    #[test]
    fn a_misleading_sample_still_gives_exact_ranks() {
        // The strided sample sees only the extreme values (thresholds too tight: too few
        // values beyond them) or only the middle ones (too loose: most values beyond them).
        let n = 6400;
        let step = n / SAMPLE;
        // Sampled values: far below the rest, far above, or all in the middle.
        for pattern in [-1.0e6, 1.0e6, 0.0] {
            let v: Vec<f64> = (0..n)
                .map(|i| {
                    let x = ((i * 37) % 1000) as f64;
                    if i % step != 0 {
                        x
                    } else if pattern == 0.0 {
                        500.0
                    } else {
                        pattern + x
                    }
                })
                .collect();
            for (k_lo, k_hi) in [(0, n - 1), (10, n - 11), (200, n - 201), (1500, n - 1501)] {
                let want = sorted_pair(&v, k_lo, k_hi);
                let got = rank_pair(&mut v.clone(), k_lo, k_hi).unwrap();
                assert!(same(got, want), "{pattern} {k_lo}: {got:?} vs {want:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Against a full sort, on short and long lists, with heavy ties (coarse values) and
        /// far outliers.
        #[test]
        fn matches_a_full_sort(
            raw in prop::collection::vec(-1000i32..1000, 1..3000),
            coarse in 1i32..200,
            spike in 0usize..4,
            a in 0.0f64..1.0,
            b in 0.0f64..1.0,
        ) {
            let mut v: Vec<f64> = raw.iter().map(|&r| f64::from(r / coarse) * 0.37).collect();
            for i in 0..spike.min(v.len()) {
                v[i] = 1e9 * if i % 2 == 0 { 1.0 } else { -1.0 };
            }
            let n = v.len();
            let k_lo = (a * n as f64) as usize;
            let k_hi = (b * n as f64) as usize;
            let want = sorted_pair(&v, k_lo, k_hi);
            let got = rank_pair(&mut v, k_lo, k_hi).unwrap();
            prop_assert!(same(got, want), "{:?} vs {:?}", got, want);
        }
    }
}
