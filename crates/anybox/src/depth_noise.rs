//! The depth-noise index that the detector's grid (stage 2) and the estimator's observation
//! (stage 3) both read, to widen their normals where far stereo depth is noisy.
//!
//! In: a row-major depth grid (mm; cells or pixels). Out: per point, its residual against the
//! mean of its 8 neighbours over its depth squared. The mean of the 8 is exact on a plane (and
//! on any linear depth), so what is left is noise, and stereo depth noise grows with the
//! square of depth: the median of these values is one number per frame or mask, in 1/mm.

/// |z − mean of the 8 neighbours| / z² at index `i` of the depth grid `z` (`w` wide, row-major,
/// mm), or `None` where `i` lies on the grid's border, has no depth, or `usable` refuses one of
/// its neighbours (no depth, another surface, outside a mask).
pub(crate) fn relative_residual(
    z: &[f32],
    w: usize,
    i: usize,
    usable: impl Fn(usize) -> bool,
) -> Option<f32> {
    let (u, v) = (i % w, i / w);
    let zc = *z.get(i)?;
    if u == 0 || u + 1 >= w || v == 0 || i + w + 1 >= z.len() || zc <= 0.0 {
        return None;
    }
    let mut sum = 0f32;
    for j in [
        i - w - 1,
        i - w,
        i - w + 1,
        i - 1,
        i + 1,
        i + w - 1,
        i + w,
        i + w + 1,
    ] {
        if !usable(j) {
            return None;
        }
        sum += z[j];
    }
    Some((zc - sum / 8.0).abs() / (zc * zc))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_reads_nothing_and_a_bump_reads_its_height() {
        // 5 × 4 grid of a tilted plane, z = 1000 + 3u + 2v mm.
        let w = 5;
        let mut z: Vec<f32> = (0..20)
            .map(|i| 1000.0 + 3.0 * (i % w) as f32 + 2.0 * (i / w) as f32)
            .collect();
        let all = |_: usize| true;
        assert_eq!(relative_residual(&z, w, 7, all), Some(0.0));
        // Border cells have no 8 neighbours.
        for i in [0, 4, 5, 9, 15, 19] {
            assert_eq!(relative_residual(&z, w, i, all), None, "cell {i}");
        }
        // A 10 mm bump on cell 7 (z 1008 → 1018): residual 10 mm over 1018².
        z[7] += 10.0;
        let r = relative_residual(&z, w, 7, all).unwrap();
        assert!((r - 10.0 / (1018.0 * 1018.0)).abs() < 1e-11, "{r}");
        // A refused neighbour leaves the cell out.
        assert_eq!(relative_residual(&z, w, 7, |j| j != 2), None);
    }
}
