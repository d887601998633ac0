//! Whether one box repeats another's size: `k` copies of it end to end, or a shorter piece of
//! it (not in the paper).
//!
//! In: two oriented boxes (camera frame, mm) and the tolerances of
//! [`DetectConfig`](crate::detect::DetectConfig) (`tiled_union_max_angle_deg`,
//! `repeat_split_tol`, `repeat_split_max_parts`, `repeat_extend_min_ratio`).
//! Out: [`Repeat`], or nothing; and, for a frame's boxes, how many others share each one's
//! size ([`same_size_counts`]).
//!
//! Two stages ask the same question, so they share this one answer: the detector (stage 2)
//! splits a coarse candidate made of copies of a whole carton inside it
//! (`split_carton_min_faces`), and the pipeline (stage 7) reads an estimate anew by another's
//! size ([`crate::pipeline::repeat_readings`]).

use anybox_geom::OrientedBox;

/// Whether `a` is `k` ≥ 2 copies of `b` laid end to end, as
/// [`crate::pipeline::repeat_readings`] judges it
/// (`tiled_union_max_angle_deg`, `repeat_split_tol`, `repeat_split_max_parts`).
pub(crate) fn is_copies_of(
    a: &OrientedBox,
    b: &OrientedBox,
    cfg: &crate::detect::DetectConfig,
) -> bool {
    matches!(repeat_of(a, b, cfg), Some(Repeat::Copies { .. }))
}

/// A box's extents, mm, shortest first: its size whichever way it is turned.
pub(crate) fn sorted_extents_mm(b: &OrientedBox) -> [f64; 3] {
    let mut e = [b.size_mm.x, b.size_mm.y, b.size_mm.z];
    e.sort_by(f64::total_cmp);
    e
}

/// Whether sorted extents `f` measure like `e` (both from [`sorted_extents_mm`]): each within
/// `tol`, relative, of `e`'s.
pub(crate) fn measures_like(e: &[f64; 3], f: &[f64; 3], tol: f64) -> bool {
    (0..3).all(|a| (f[a] / e[a] - 1.0).abs() <= tol)
}

/// For each box, how many other boxes have its size turned any way (sorted extents, each
/// within `tol`, relative, of the box's): counted greedily in order, each sharing at most
/// `max_shared` of the smaller one's volume with the box and with every box already counted,
/// since two estimates of one carton are not two cartons.
pub(crate) fn same_size_counts(boxes: &[OrientedBox], tol: f64, max_shared: f64) -> Vec<usize> {
    let sorted: Vec<[f64; 3]> = boxes.iter().map(sorted_extents_mm).collect();
    let tol = tol.max(0.0);
    let apart = |i: usize, j: usize| {
        let shared = anybox_geom::iou::intersection_volume_mm3(&boxes[i], &boxes[j]);
        shared <= max_shared * boxes[i].volume_mm3().min(boxes[j].volume_mm3())
    };
    (0..sorted.len())
        .map(|i| {
            let mut counted: Vec<usize> = Vec::new();
            for j in (0..sorted.len()).filter(|&j| j != i) {
                if measures_like(&sorted[i], &sorted[j], tol)
                    && apart(i, j)
                    && counted.iter().all(|&k| apart(j, k))
                {
                    counted.push(j);
                }
            }
            counted.len()
        })
        .collect()
}

/// How one box repeats another's size ([`repeat_of`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Repeat {
    /// `k` copies along `axis` (of the first box).
    Copies { axis: usize, k: u32 },
    /// Shorter along `axis`; the other's extent there is `to_mm`.
    Extend { axis: usize, to_mm: f64 },
}

/// Whether `a` repeats `b`'s size: each of `a`'s axes within `tiled_union_max_angle_deg` of
/// one of `b`'s (per axis; [`crate::pipeline::tiled_union`] bounds the geodesic angle between
/// the frames instead, which is stricter), two extent ratios within `repeat_split_tol` of 1
/// and the third either within that tolerance of a whole `k` in 2..=`repeat_split_max_parts`
/// or below 1 − tolerance and at least `repeat_extend_min_ratio` (when that is above 0).
pub(crate) fn repeat_of(
    a: &OrientedBox,
    b: &OrientedBox,
    cfg: &crate::detect::DetectConfig,
) -> Option<Repeat> {
    let cos_max = cfg.tiled_union_max_angle_deg.to_radians().cos();
    let tol = cfg.repeat_split_tol.max(0.0);
    let mut ratio = [0.0f64; 3];
    let mut other = [0usize; 3];
    let mut used = [false; 3];
    for i in 0..3 {
        let ai = a.axis(i);
        let (j, c) = (0..3)
            .map(|j| (j, ai.dot(&b.axis(j)).abs()))
            .fold((0, -1.0), |m, x| if x.1 > m.1 { x } else { m });
        if c < cos_max || used[j] || b.size_mm[j] <= 0.0 {
            return None;
        }
        used[j] = true;
        other[i] = j;
        ratio[i] = a.size_mm[i] / b.size_mm[j];
    }
    let mut odd = (0..3).filter(|&i| (ratio[i] - 1.0).abs() > tol);
    let (axis, None) = (odd.next()?, odd.next()) else {
        return None;
    };
    let q = ratio[axis];
    let k = q.round();
    if k >= 2.0 && k <= f64::from(cfg.repeat_split_max_parts) && (q - k).abs() <= tol * k {
        return Some(Repeat::Copies { axis, k: k as u32 });
    }
    let min = cfg.repeat_extend_min_ratio;
    (min > 0.0 && q >= min && q < 1.0 - tol).then(|| Repeat::Extend {
        axis,
        to_mm: b.size_mm[other[axis]],
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    /// Three cartons of 300 × 250 × 180 mm in a row along their 250 mm side (tilted), the
    /// box they fill together, in axes turned 90° about z (its x and y swapped), and one more
    /// such carton beside the row, turned `turn_deg` about z, 4 % longer in x.
    pub(crate) fn carton_row(turn_deg: f64) -> ([OrientedBox; 3], OrientedBox, OrientedBox) {
        let rot = Rotation3::from_euler_angles(0.35, -0.2, 0.6);
        let c = Vector3::new(100.0, -50.0, 1800.0);
        let size = Vector3::new(300.0, 250.0, 180.0);
        let carton = |i: f64| OrientedBox {
            rotation: rot,
            center_mm: c + rot * Vector3::new(0.0, i * 250.0, 0.0),
            size_mm: size,
        };
        let row = [carton(-1.0), carton(0.0), carton(1.0)];
        let quarter = Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        let merged = OrientedBox {
            rotation: rot * quarter,
            center_mm: c,
            size_mm: Vector3::new(750.0, 300.0, 180.0),
        };
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), turn_deg.to_radians());
        let other = OrientedBox {
            rotation: rot * turn,
            center_mm: c + rot * Vector3::new(400.0, 0.0, 0.0),
            size_mm: Vector3::new(312.0, 250.0, 180.0),
        };
        (row, merged, other)
    }

    #[test]
    fn copies_need_parallel_axes_two_equal_extents_and_a_whole_multiple() {
        let cfg = crate::detect::DetectConfig::default();
        let (row, merged, other) = carton_row(3.0);
        assert!(is_copies_of(&merged, &other, &cfg), "three copies");
        assert!(
            is_copies_of(&merged, &row[1], &cfg),
            "three copies, overlapping"
        );
        assert!(
            !is_copies_of(&other, &merged, &cfg),
            "a third of a row is no row"
        );
        assert!(
            !is_copies_of(&row[0], &other, &cfg),
            "one carton is not copies"
        );
        let (_, _, turned) = carton_row(30.0);
        assert!(!is_copies_of(&merged, &turned, &cfg), "turned 30°");
        let mut long = merged;
        long.size_mm.x = 625.0;
        assert!(!is_copies_of(&long, &other, &cfg), "2.5 cartons long");
        let mut short = merged;
        short.size_mm.x = 200.0;
        assert!(
            !is_copies_of(&short, &other, &cfg),
            "a short box is an extension"
        );
        let mut wide = merged;
        wide.size_mm.y = 400.0;
        assert!(!is_copies_of(&wide, &other, &cfg), "two extents differ");
    }
}
