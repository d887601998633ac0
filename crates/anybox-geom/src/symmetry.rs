//! Box symmetries, the canonical choice of axes, and symmetry-aware pose errors (SPEC §2, §4).
//!
//! In: [`OrientedBox`]es (camera frame, mm). Out: symmetry rotations (box frame), a canonical
//! description of a box, rotation error (degrees) and per-axis size error (mm).
//!
//! **Relabelling.** The same physical box has 24 descriptions: for a proper signed permutation
//! matrix `P` (see [`signed_permutations`]), `(R·P, t, |P|ᵀ·s)` is the same box as `(R, t, s)` —
//! new axis `j` is `±` old axis `π(j)` and carries its extent. [`relabel`] applies one.
//!
//! **Symmetry group.** The rotations `S` (in the box frame) with `(R·S, t, s)` the same box *with
//! the same size vector*: the 4 half-turns about the box axes (D2) when the three extents differ,
//! 8 with a square cross-section, all 24 for a cube ([`symmetry_group`]).
//!
//! **Canonical axes** ([`canonicalize`]): among the three box axes, the one most parallel to the
//! camera's optical axis (largest `|z|` component in the camera frame) becomes the box `z` axis,
//! signed to point away from the camera (`z_cam > 0`); of the other two, the one most parallel to
//! the camera `x` axis (largest `|x|` component) becomes the box `x` axis, signed so that its
//! camera-`x` component is positive; `y = z × x`. Sizes follow their axes. Exact ties go to the
//! axis that is already `z` (resp. `x`), which makes the map idempotent; it maps all 24
//! descriptions of a box to the same one (up to exact ties).
//!
//! **Rotation error** ([`rotation_error_deg`], [`match_axes`]): boxes are symmetric and their
//! axis order is arbitrary, so the estimate is first relabelled. For each of the 6 axis
//! permutations `π` the size cost is `c(π) = Σ_j |s_est,π(j) − s_gt,j|`. With `π*` the cheapest
//! (the closest to `π` among those tied for cheapest, up to rounding), `π` is admissible when
//! `c(π) − c(π*) <= τ · Σ_{j : π(j) ≠ π*(j)} s_gt,j`, `τ =` [`AXIS_MATCH_REL_TOL`]. The slack is
//! relative to the ground-truth extents of the axes that `π` moves, so that with a perfect size
//! estimate two axes `a`, `b` are interchangeable exactly when `2·|a − b| <= τ·(a + b)`, i.e.
//! when their extents differ by about `τ` or less, as in [`symmetry_group`]. Each admissible
//! permutation brings its 4 sign variants (the proper ones). The rotation error is the smallest
//! geodesic angle `∠(R_est·P, R_gt)` over those relabellings `P`. Consequences: a box with three
//! clearly distinct extents is compared modulo its D2 symmetry (180° turns about its axes cost
//! 0), a square cross-section or a cube also modulo the 90° turns (the swapped permutations tie in
//! cost), and an estimate that got the size order wrong is *not* excused by relabelling. The size
//! error ([`size_error_mm`]) uses the same relabelling: `|s_est,π(j) − s_gt,j|` for the `P` that
//! attains the rotation error (ties: lower size cost).

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::OrientedBox;

/// Suggested relative tolerance for [`symmetry_group`]: two extents are "equal" when they differ
/// by at most 5 % of the larger one.
pub const DEFAULT_SYMMETRY_REL_TOL: f64 = 0.05;

/// Admissibility tolerance `τ` of the axis matching in [`rotation_error_deg`] (module docs): a
/// permutation is admissible when its size cost exceeds the best by at most 5 % of the
/// ground-truth extents of the axes it moves relative to the best permutation.
pub const AXIS_MATCH_REL_TOL: f64 = 0.05;

/// The 24 proper (det +1) signed permutation matrices, as rotations; the identity first.
///
/// Matrix `P` has exactly one `±1` per row and column; `R·P` relabels a box's axes.
pub fn signed_permutations() -> Vec<Rotation3<f64>> {
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut out = Vec::with_capacity(24);
    for perm in PERMS {
        for signs in 0..8u8 {
            let mut m = Matrix3::zeros();
            for (j, &i) in perm.iter().enumerate() {
                // Column j is ±e_{π(j)}.
                m[(i, j)] = if signs & (1 << j) != 0 { -1.0 } else { 1.0 };
            }
            if m.determinant() > 0.0 {
                out.push(Rotation3::from_matrix_unchecked(m));
            }
        }
    }
    out
}

/// The permutation of a signed permutation matrix: `π(j)` is the row of the non-zero in column `j`.
fn perm_of(p: &Rotation3<f64>) -> [usize; 3] {
    let m = p.matrix();
    let mut out = [0usize; 3];
    for (j, o) in out.iter_mut().enumerate() {
        let mut best = 0;
        for i in 1..3 {
            if m[(i, j)].abs() > m[(best, j)].abs() {
                best = i;
            }
        }
        *o = best;
    }
    out
}

/// The same physical box described with its axes relabelled by `p` (a signed permutation, see
/// [`signed_permutations`]): rotation `R·P`, size `|P|ᵀ·s`.
pub fn relabel(b: &OrientedBox, p: &Rotation3<f64>) -> OrientedBox {
    let pi = perm_of(p);
    OrientedBox {
        rotation: Rotation3::from_matrix_unchecked(b.rotation.matrix() * p.matrix()),
        center_mm: b.center_mm,
        size_mm: Vector3::new(b.size_mm[pi[0]], b.size_mm[pi[1]], b.size_mm[pi[2]]),
    }
}

/// Equivalence classes of the three extents under a relative tolerance, forced to be a valid
/// partition (a chain `a ≈ b ≈ c` with `a ≉ c` keeps only the closer pair).
fn size_classes(s: &Vector3<f64>, rel_tol: f64) -> [u8; 3] {
    let rd = |i: usize, j: usize| {
        let m = s[i].abs().max(s[j].abs());
        if m > 0.0 {
            (s[i] - s[j]).abs() / m
        } else {
            0.0
        }
    };
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|a, b| s[*a].total_cmp(&s[*b]));
    let [lo, mid, hi] = idx;
    let mut cls = [0u8, 1, 2];
    if rd(lo, hi) <= rel_tol {
        return [0, 0, 0];
    }
    let (c_lo, c_hi) = (rd(lo, mid) <= rel_tol, rd(mid, hi) <= rel_tol);
    let join_low = match (c_lo, c_hi) {
        (true, true) => Some(rd(lo, mid) <= rd(mid, hi)),
        (true, false) => Some(true),
        (false, true) => Some(false),
        (false, false) => None,
    };
    match join_low {
        Some(true) => cls[mid] = cls[lo],
        Some(false) => cls[mid] = cls[hi],
        None => {}
    }
    cls
}

/// Rotational symmetry group of a box with extents `size_mm` (box frame; apply as `R·S`):
/// 4 elements (three distinct extents), 8 (two equal within `rel_tol`) or 24 (a cube).
///
/// Two extents are equal when `|a − b| <= rel_tol · max(a, b)`; if that relation is not
/// transitive (a ≈ b ≈ c but a ≉ c) only the closer pair counts, so the result is always a group.
/// The identity comes first.
pub fn symmetry_group(size_mm: &Vector3<f64>, rel_tol: f64) -> Vec<Rotation3<f64>> {
    let cls = size_classes(size_mm, rel_tol);
    signed_permutations()
        .into_iter()
        .filter(|p| {
            let pi = perm_of(p);
            (0..3).all(|j| cls[pi[j]] == cls[j])
        })
        .collect()
}

/// The canonical description of a box (module docs): `z` is the axis most parallel to the optical
/// axis, pointing away from the camera; `x` the remaining axis most parallel to camera `x`, with
/// a positive camera-`x` component. The result is the same physical box (same corners), and
/// `canonicalize(canonicalize(b)) == canonicalize(b)` exactly.
pub fn canonicalize(b: &OrientedBox) -> OrientedBox {
    let m = b.rotation.matrix();
    // z: largest |camera-z component|; ">=" lets the current z (index 2) win exact ties.
    let mut kz = 0;
    for k in 1..3 {
        if m[(2, k)].abs() >= m[(2, kz)].abs() {
            kz = k;
        }
    }
    let others: Vec<usize> = (0..3).filter(|k| *k != kz).collect();
    let (o0, o1) = match others.as_slice() {
        [a, c] => (*a, *c),
        // Exactly two indices remain by construction.
        _ => (0, 1),
    };
    // x: largest |camera-x component|; strict ">" keeps the lower index (the current x) on ties.
    let kx = if m[(0, o1)].abs() > m[(0, o0)].abs() {
        o1
    } else {
        o0
    };
    let ky = 3 - kz - kx;
    let sz = if m[(2, kz)] < 0.0 { -1.0 } else { 1.0 };
    let sx = if m[(0, kx)] < 0.0 { -1.0 } else { 1.0 };
    let z = m.column(kz) * sz;
    let x = m.column(kx) * sx;
    // y = ±(old axis ky) with the sign that makes the frame right-handed; copying the column
    // (rather than computing z × x) keeps every entry bit-identical, hence exact idempotence.
    let sy = if z.cross(&x).dot(&m.column(ky)) < 0.0 {
        -1.0
    } else {
        1.0
    };
    let y = m.column(ky) * sy;
    let r = Matrix3::from_columns(&[x, y, z]);
    OrientedBox {
        rotation: Rotation3::from_matrix_unchecked(r),
        center_mm: b.center_mm,
        size_mm: Vector3::new(b.size_mm[kx], b.size_mm[ky], b.size_mm[kz]),
    }
}

/// Geodesic angle between two rotations, degrees, computed stably for small angles.
pub fn geodesic_deg(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let rel = a.inverse() * b;
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(&rel);
    let (w, v) = (q.scalar().abs(), q.vector().norm());
    (2.0 * v.atan2(w)).to_degrees()
}

/// The outcome of matching an estimate's axes to the ground truth's (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisMatch {
    /// Signed permutation `P` applied to the estimate (`R_est·P`, see [`relabel`]).
    pub relabel: Rotation3<f64>,
    /// Smallest geodesic angle between `R_est·P` and `R_gt` over admissible `P`, degrees.
    pub rotation_error_deg: f64,
    /// The estimate's extents after relabelling, in the ground truth's axis order, mm.
    pub matched_size_mm: Vector3<f64>,
    /// Per-axis absolute size error `|s_est,π(j) − s_gt,j|`, ground-truth axis order, mm.
    pub size_error_mm: Vector3<f64>,
    /// Size cost `Σ_j |s_est,π(j) − s_gt,j|` of the chosen permutation, mm.
    pub size_cost_mm: f64,
}

/// Matches `est`'s axes to `gt`'s with the default tolerance [`AXIS_MATCH_REL_TOL`].
pub fn match_axes(est: &OrientedBox, gt: &OrientedBox) -> AxisMatch {
    match_axes_with_tol(est, gt, AXIS_MATCH_REL_TOL)
}

/// Matches `est`'s axes to `gt`'s (module docs); `rel_tol` is the admissibility tolerance `τ`.
pub fn match_axes_with_tol(est: &OrientedBox, gt: &OrientedBox, rel_tol: f64) -> AxisMatch {
    let perms = signed_permutations();
    let cost = |p: &Rotation3<f64>| -> f64 {
        let pi = perm_of(p);
        (0..3)
            .map(|j| (est.size_mm[pi[j]] - gt.size_mm[j]).abs())
            .sum()
    };
    let costs: Vec<f64> = perms.iter().map(cost).collect();
    let best = costs.iter().copied().fold(f64::INFINITY, f64::min);
    // L1 assignment costs tie exactly in many configurations, and rounding then picks one of
    // them arbitrarily: treat every permutation within rounding of the best as a "best", and
    // measure the moved axes against the closest of them, so that the result does not depend on
    // how either box is described.
    let round = 1e-9 * gt.size_mm.iter().map(|s| s.abs()).sum::<f64>();
    let best_perms: Vec<[usize; 3]> = perms
        .iter()
        .zip(costs.iter())
        .filter(|(_, c)| **c <= best + round)
        .map(|(p, _)| perm_of(p))
        .collect();
    let tol = rel_tol.max(0.0);
    let mut out: Option<AxisMatch> = None;
    for (p, c) in perms.iter().zip(costs.iter()) {
        let pi = perm_of(p);
        let moved = best_perms
            .iter()
            .map(|b| {
                (0..3)
                    .filter(|j| pi[*j] != b[*j])
                    .map(|j| gt.size_mm[j].abs())
                    .sum::<f64>()
            })
            .fold(f64::INFINITY, f64::min);
        // NaN sizes make every comparison false: fall back to considering all relabellings.
        if *c - best > tol * moved + round {
            continue;
        }
        let err = geodesic_deg(&(est.rotation * p), &gt.rotation);
        let better = match &out {
            None => true,
            Some(m) => {
                err < m.rotation_error_deg - 1e-9
                    || (err <= m.rotation_error_deg + 1e-9 && *c < m.size_cost_mm)
            }
        };
        if better {
            let pi = perm_of(p);
            let matched = Vector3::new(est.size_mm[pi[0]], est.size_mm[pi[1]], est.size_mm[pi[2]]);
            out = Some(AxisMatch {
                relabel: *p,
                rotation_error_deg: err,
                matched_size_mm: matched,
                size_error_mm: (matched - gt.size_mm).abs(),
                size_cost_mm: *c,
            });
        }
    }
    out.unwrap_or_else(|| {
        // Only reachable with non-finite sizes (every cost NaN): report the plain comparison.
        let err = geodesic_deg(&est.rotation, &gt.rotation);
        AxisMatch {
            relabel: Rotation3::identity(),
            rotation_error_deg: err,
            matched_size_mm: est.size_mm,
            size_error_mm: (est.size_mm - gt.size_mm).abs(),
            size_cost_mm: f64::NAN,
        }
    })
}

/// Rotation error of an estimate, degrees: the smallest geodesic angle over the box's symmetries
/// and size-consistent axis relabellings (module docs; [`AXIS_MATCH_REL_TOL`]).
pub fn rotation_error_deg(est: &OrientedBox, gt: &OrientedBox) -> f64 {
    match_axes(est, gt).rotation_error_deg
}

/// Per-axis absolute size error after matching axes, in the ground truth's axis order, mm.
pub fn size_error_mm(est: &OrientedBox, gt: &OrientedBox) -> Vector3<f64> {
    match_axes(est, gt).size_error_mm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::iou::{iou, IouMethod};

    fn bx(r: Rotation3<f64>, s: [f64; 3]) -> OrientedBox {
        OrientedBox::new(r, Vector3::new(30.0, -40.0, 900.0), Vector3::from(s)).unwrap()
    }

    fn rot(axis: Vector3<f64>, deg: f64) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), deg.to_radians())
    }

    #[test]
    fn twenty_four_distinct_proper_permutations() {
        let ps = signed_permutations();
        assert_eq!(ps.len(), 24);
        assert_eq!(ps[0], Rotation3::identity());
        for (i, a) in ps.iter().enumerate() {
            assert!((a.matrix().determinant() - 1.0).abs() < 1e-12);
            for b in ps.iter().skip(i + 1) {
                assert!(geodesic_deg(a, b) > 1.0);
            }
        }
    }

    #[test]
    fn group_sizes_and_closure() {
        for (s, n) in [
            ([200.0, 100.0, 300.0], 4),
            ([100.0, 300.0, 102.0], 8),
            ([300.0, 100.0, 100.0], 8),
            ([100.0, 101.0, 99.0], 24),
            // 100 ≈ 104 ≈ 108 but 100 ≉ 108 (tol 5 %): only the closer pair (104, 108) counts.
            ([100.0, 104.0, 108.0], 8),
        ] {
            let g = symmetry_group(&Vector3::from(s), 0.05);
            assert_eq!(g.len(), n, "{s:?}");
            for a in &g {
                for b in &g {
                    let ab = a * b;
                    assert!(g.iter().any(|c| geodesic_deg(c, &ab) < 1e-9), "not closed");
                }
            }
        }
        // Every element of D2 is a half-turn about a box axis.
        for g in symmetry_group(&Vector3::new(1.0, 2.0, 3.0), 0.01)
            .iter()
            .skip(1)
        {
            assert!((g.angle().to_degrees() - 180.0).abs() < 1e-9);
        }
    }

    #[test]
    fn symmetry_elements_preserve_the_physical_box() {
        let b = bx(
            Rotation3::from_euler_angles(0.3, 0.2, -1.0),
            [100.0, 100.0, 250.0],
        );
        for s in symmetry_group(&b.size_mm, 0.05) {
            let c = OrientedBox {
                rotation: b.rotation * s,
                ..b
            };
            assert!((iou(&b, &c, IouMethod::Exact) - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn three_distinct_sides_half_turns_cost_nothing() {
        let gt = bx(
            Rotation3::from_euler_angles(0.1, -0.4, 0.9),
            [200.0, 100.0, 300.0],
        );
        for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
            let est = OrientedBox {
                rotation: gt.rotation * rot(axis, 180.0),
                ..gt
            };
            assert!(rotation_error_deg(&est, &gt) < 1e-6);
            assert_eq!(size_error_mm(&est, &gt), Vector3::zeros());
        }
        // A 90° turn without swapping sizes is a real 90° error.
        let est = OrientedBox {
            rotation: gt.rotation * rot(Vector3::z(), 90.0),
            ..gt
        };
        assert!((rotation_error_deg(&est, &gt) - 90.0).abs() < 1e-6);
        // The same physical box with its axes relabelled: size (100, 200, 300) with Rz90.
        let est = OrientedBox {
            rotation: gt.rotation * rot(Vector3::z(), 90.0),
            size_mm: Vector3::new(100.0, 200.0, 300.0),
            ..gt
        };
        assert!(rotation_error_deg(&est, &gt) < 1e-6);
        assert!(size_error_mm(&est, &gt).norm() < 1e-12);
        // A small tilt on top is measured as itself.
        let est = OrientedBox {
            rotation: est.rotation * rot(Vector3::new(1.0, 2.0, 0.5), 7.0),
            ..est
        };
        assert!((rotation_error_deg(&est, &gt) - 7.0).abs() < 1e-6);
    }

    #[test]
    fn cube_quarter_turns_cost_nothing() {
        let gt = bx(
            Rotation3::from_euler_angles(-0.5, 0.3, 0.2),
            [150.0, 150.0, 150.0],
        );
        for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
            for deg in [90.0, 180.0, 270.0] {
                let est = OrientedBox {
                    rotation: gt.rotation * rot(axis, deg),
                    ..gt
                };
                assert!(rotation_error_deg(&est, &gt) < 1e-6);
            }
        }
        // The largest possible error for a cube is well below 180°: a 45° turn stays 45°.
        let est = OrientedBox {
            rotation: gt.rotation * rot(Vector3::z(), 45.0),
            ..gt
        };
        assert!((rotation_error_deg(&est, &gt) - 45.0).abs() < 1e-6);
    }

    #[test]
    fn nearly_square_cross_section_follows_the_tolerance() {
        // Perfect size estimate, 90° turn about z. Swapping x and y costs 2·|s_x − s_y|; it is
        // admissible when that is at most 5 % of s_x + s_y.
        for (sy, want) in [(103.0, 0.0), (105.0, 0.0), (106.0, 90.0), (115.0, 90.0)] {
            let gt = bx(Rotation3::identity(), [100.0, sy, 300.0]);
            let est = OrientedBox {
                rotation: rot(Vector3::z(), 90.0),
                ..gt
            };
            let e = rotation_error_deg(&est, &gt);
            assert!((e - want).abs() < 1e-6, "s_y = {sy}: {e}");
            // With the match, the size error is the difference of the swapped extents.
            let m = match_axes(&est, &gt);
            let se = if want == 0.0 { sy - 100.0 } else { 0.0 };
            assert!((m.size_error_mm - Vector3::new(se, se, 0.0)).norm() < 1e-9);
        }
    }

    #[test]
    fn size_error_uses_matched_axes() {
        let gt = bx(Rotation3::identity(), [200.0, 100.0, 300.0]);
        // Relabelled estimate with errors +10 (x), -5 (y), +20 (z) in gt order.
        let est = OrientedBox {
            rotation: rot(Vector3::z(), 90.0),
            size_mm: Vector3::new(95.0, 210.0, 320.0),
            ..gt
        };
        let m = match_axes(&est, &gt);
        assert!(m.rotation_error_deg < 1e-6);
        assert!((m.size_error_mm - Vector3::new(10.0, 5.0, 20.0)).norm() < 1e-9);
        assert!((m.matched_size_mm - Vector3::new(210.0, 95.0, 320.0)).norm() < 1e-9);
    }

    #[test]
    fn canonical_form_is_same_box_idempotent_and_description_free() {
        let b = bx(
            Rotation3::from_euler_angles(0.7, -0.2, 2.5),
            [200.0, 100.0, 300.0],
        );
        let c = canonicalize(&b);
        assert!((iou(&b, &c, IouMethod::Exact) - 1.0).abs() < 1e-9);
        assert_eq!(canonicalize(&c), c);
        assert!(c.axis(2).z > 0.0 && c.axis(0).x > 0.0);
        for k in 0..3 {
            assert!(c.axis(2).z.abs() >= c.axis(k).z.abs());
        }
        assert!(c.axis(0).x.abs() >= c.axis(1).x.abs());
        assert!((c.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
        for p in signed_permutations() {
            assert_eq!(canonicalize(&relabel(&b, &p)), c);
        }
    }

    #[test]
    fn geodesic_is_accurate_for_tiny_angles() {
        let a = Rotation3::from_euler_angles(0.2, 0.1, -0.3);
        let b = a * rot(Vector3::new(0.3, -1.0, 0.2), 1e-6);
        assert!((geodesic_deg(&a, &b) - 1e-6).abs() < 1e-12);
    }
}
