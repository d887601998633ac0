//! From planar patches to scored box candidates: support-plane removal, grouping of up to three
//! mutually perpendicular faces that share a convex edge, a cuboid fit per group and the
//! box-likeness score (issue #4).
//!
//! Score = plane fit × silhouette IoU × depth consistency × a factor for the number of faces:
//! - **plane fit**: the fraction of the candidate's cells within the plane tolerance of their
//!   face's plane (curved and irregular surfaces score low);
//! - **silhouette**: IoU between the candidate's cells and the convex hull of the fitted cuboid's
//!   projected corners (`anybox_geom::projection`), the cuboid-silhouette test of SPEC §1;
//!   unlabelled cells and cells nearer than the cuboid (occluders, with
//!   `DetectConfig::occluders_unknown`) count neither for nor against it;
//! - **depth consistency**: the paper's filter (§3, `crate::depth_filter`) in image form — inside
//!   the cuboid's silhouette, the sensor must not see *through* the cuboid: the fraction of cells
//!   whose measured depth lies behind the cuboid's front surface by more than the tolerance is
//!   the penalty.

use std::collections::BTreeMap;

use anybox_geom::projection::{
    convex_hull_2d, convex_polygon_spans, ray_box_intersection, silhouette_hull_px,
};
use anybox_geom::OrientedBox;
use nalgebra::{Matrix3, Point2, Point3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::grid::Grid;
use super::regions::{plane_tol, Region, NONE};
use super::DetectConfig;
use crate::observation::median;

/// A scored candidate on the grid.
pub(crate) struct Candidate {
    /// Grid cells of the detection (the faces plus filled-in unlabelled cells), row-major.
    pub cells: Vec<u32>,
    /// Side-face strips taken in past a one-face candidate's edges (`side_strips`), row-major;
    /// part of the mask, but not of the size that decides whether the face is big enough.
    pub strip: Vec<u32>,
    /// Box-likeness, 0..1.
    pub score: f64,
    /// Faces grouped.
    pub n_faces: u8,
    /// The cuboid fitted to the faces (camera frame, mm), before the fill.
    pub bx: OrientedBox,
}

/// A grid point or normal as `f64`.
pub(crate) fn v3(p: &[f32; 3]) -> Vector3<f64> {
    Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Support planes (floor, table, shelf boards, walls): a planar surface of at least
/// `support_always_area_mm2`, or of at least `support_min_area_mm2` with things standing on it
/// (cells in front of the plane, within `support_window_mm`, whose foot lies inside the
/// surface's convex footprint, at least `support_min_front_fraction` of its cells), or with
/// almost nothing behind it (fewer than `support_max_behind_fraction` of the valid cells: it
/// bounds the scene, like a floor or a wall). Returns, per cell, whether it belongs
/// to such a surface, and the support planes themselves (their fragments between boxes are
/// dropped later by [`drop_support_fragments`]). `ransac`: [`ransac_planes`]' planes when the
/// caller found them already (they need no surfaces: found beside the segmentation), else
/// they are found here.
pub(crate) fn support_mask(
    g: &Grid,
    surface_labels: &[u32],
    surfaces: &[Region],
    ransac: Option<Vec<(Region, bool, bool, f64)>>,
    cfg: &DetectConfig,
) -> (Vec<bool>, Vec<Region>, Option<Vector3<f64>>) {
    let mut is_support = vec![false; surfaces.len()];
    let mut planes = Vec::new();
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); surfaces.len()];
    for (i, &l) in surface_labels.iter().enumerate() {
        if l != NONE {
            members[l as usize].push(i);
        }
    }
    // (surface index or None for a RANSAC plane, plane, bounds-the-scene, things-stand-on-it,
    // share under its rim)
    let mut cands: Vec<(Option<usize>, Region, bool, bool, f64)> = Vec::new();
    let big: Vec<usize> = (0..surfaces.len())
        .filter(|&r| {
            surfaces[r].area_mm2 >= cfg.support_small_area_mm2
                && surfaces[r].inlier_frac >= cfg.min_plane_inlier_frac
        })
        .collect();
    // The surfaces' tests and the RANSAC planes are independent.
    let (tests, ransac): (Vec<(bool, bool, f64)>, _) = rayon::join(
        || {
            big.par_iter()
                .map(|&r| support_tests(g, &surfaces[r], &members[r], cfg))
                .collect()
        },
        || ransac.unwrap_or_else(|| ransac_planes(g, cfg)),
    );
    for (&r, (strong, standing, rim)) in big.iter().zip(tests) {
        cands.push((Some(r), surfaces[r].clone(), strong, standing, rim));
    }
    // RANSAC planes take in every coplanar cell of the frame, the tops of a whole layer
    // and of the stacks beside it, so their share under the rim is held to a lower bar.
    for (reg, strong, standing, rim) in ransac {
        cands.push((None, reg, strong, standing, rim));
    }
    // "Up": the normal of the plane that bounds the scene (the floor), picked by
    // `up_from_planes`. Things stand on planes parallel to it (tables, shelf boards); a
    // vertical face with floor in front of it does not count.
    let up = up_from_planes(
        cands
            .iter()
            .filter(|c| c.2 || (cfg.support_up_from_standing && c.3))
            .map(|c| (c.1.normal, c.1.area_mm2)),
        Vector3::from(cfg.support_up_hint).try_normalize(1e-9),
        cfg.support_up_max_angle_deg.to_radians().cos(),
    );
    // Which candidates are supports, largest first: a large one that bounds the scene or has
    // things standing on it (parallel to up); a small one (a desk seen from close by) only
    // with things standing on it and no support beneath it (else it is a box top).
    let cos_up = cfg.support_normal_tol_deg.to_radians().cos();
    let mut order: Vec<usize> = (0..cands.len()).collect();
    order.sort_by(|&a, &b| cands[b].1.area_mm2.total_cmp(&cands[a].1.area_mm2));
    let mut accept = vec![false; cands.len()];
    for &c in &order {
        let (src, reg, strong, standing, rim) = &cands[c];
        let layer_min = if src.is_some() {
            cfg.support_layer_min_fraction
        } else {
            cfg.support_layer_ransac_min_fraction
        };
        let parallel = up.is_none_or(|u| u.dot(&reg.normal).abs() >= cos_up);
        // Asked only where it decides (it scans the accepted candidates).
        let above_support = || {
            order.iter().any(|&o| {
                accept[o]
                    && cands[o].1.normal.dot(&reg.normal) >= cos_up
                    && cands[o].1.dist(&[
                        reg.centroid.x as f32,
                        reg.centroid.y as f32,
                        reg.centroid.z as f32,
                    ]) > cfg.support_side_margin_mm
            })
        };
        // A layer of cartons: its tops over a support, the cartons' bodies under its rim.
        let layer = || layer_min > 0.0 && *rim >= layer_min && above_support();
        accept[c] = if reg.area_mm2 >= cfg.support_min_area_mm2 {
            *strong || (*standing && parallel && !layer())
        } else {
            *standing && parallel && !above_support()
        };
    }
    if log::log_enabled!(log::Level::Debug) {
        for c in &cands {
            log::debug!(
                "support cand {:?} area {:.0} n {} normal {:.2} {:.2} {:.2} strong {} standing {} rim {:.3} up {:?}",
                c.0, c.1.area_mm2, c.1.n, c.1.normal.x, c.1.normal.y, c.1.normal.z, c.2, c.3, c.4, up
            );
        }
    }
    // Surface planes first, then RANSAC planes (their cells are marked by plane alone).
    let mut cands: Vec<_> = cands.into_iter().zip(accept).collect();
    cands.sort_by_key(|c| c.0 .0.is_none());
    let mut n_surface_planes = 0;
    for ((src, reg, _, _, _), accepted) in cands {
        if accepted {
            if let Some(r) = src {
                is_support[r] = true;
                n_surface_planes += 1;
            }
            planes.push(reg);
        }
    }
    // Only cells on the support's plane: a box top that leaked into the table's surface (a
    // low box seen at a grazing angle) stays.
    let cos_n = cfg.support_normal_tol_deg.to_radians().cos();
    let on_plane = |i: usize, reg: &Region| {
        let n = v3(&g.n[i]);
        reg.dist(&g.p[i]).abs() <= cfg.support_tol_factor * plane_tol(cfg, g.z[i] as f64)
            && (n.norm_squared() < 0.5 || n.dot(&reg.normal) >= cos_n)
    };
    // Cells of RANSAC support planes too: a table whose surface leaked into the tops of low
    // boxes (seen from above, their sides hidden) is no support surface of its own.
    let ransac: Vec<&Region> = planes[n_surface_planes..].iter().collect();
    let on = surface_labels
        .iter()
        .enumerate()
        .map(|(i, &l)| {
            (l != NONE && is_support[l as usize] && on_plane(i, &surfaces[l as usize]))
                || (g.z[i] > 0.0 && ransac.iter().any(|pl| on_plane(i, pl)))
        })
        .collect();
    (on, planes, up)
}

/// "Up" from the candidate planes `(camera-facing unit normal, area mm²)` (see
/// [`DetectConfig::support_up_hint`]): among the planes within `acos(cos_hint)` of the `hint`,
/// the one with the largest area seen along the hint (`area · normal·hint`): the floor rather
/// than a larger wall that qualifies only at a grazing angle. With no hint, or no plane within
/// it, the largest plane.
pub(crate) fn up_from_planes(
    planes: impl Iterator<Item = (Vector3<f64>, f64)> + Clone,
    hint: Option<Vector3<f64>>,
    cos_hint: f64,
) -> Option<Vector3<f64>> {
    let along_hint = hint.and_then(|h| {
        let seen_along = |&(n, area): &(Vector3<f64>, f64)| area * n.dot(&h);
        planes
            .clone()
            .filter(|(n, _)| n.dot(&h) >= cos_hint)
            .max_by(|a, b| seen_along(a).total_cmp(&seen_along(b)))
            .map(|(n, _)| n)
    });
    along_hint.or_else(|| planes.max_by(|a, b| a.1.total_cmp(&b.1)).map(|(n, _)| n))
}

/// Drops single-face candidates that lie on a support plane (pieces of a table or floor cut off
/// between boxes): at least half their cells within `support_tol_factor` plane tolerances of the
/// plane, with the face normal within `support_normal_tol_deg`. Multi-face candidates stay (a
/// box face may be flush with a support, e.g. with a desk's front edge).
pub(crate) fn drop_support_fragments(
    g: &Grid,
    raws: Vec<Raw>,
    planes: &[Region],
    cfg: &DetectConfig,
) -> Vec<Raw> {
    let cos_n = cfg.support_normal_tol_deg.to_radians().cos();
    raws.into_iter()
        .filter(|c| {
            c.n_faces > 1
                || !planes.iter().any(|pl| {
                    if pl.normal.dot(&c.bx.axis(0)).abs() < cos_n {
                        return false;
                    }
                    let on = c
                        .cells
                        .iter()
                        .filter(|&&i| {
                            let z = g.z[i as usize] as f64;
                            pl.dist(&g.p[i as usize]).abs()
                                <= cfg.support_tol_factor * plane_tol(cfg, z)
                        })
                        .count();
                    2 * on >= c.cells.len()
                })
        })
        .collect()
}

/// Support tests of a plane with its member cells: (at least `support_always_area_mm2` or
/// (almost) nothing behind it, things standing on it, the cells under its rim as a share of
/// its own; see [`DetectConfig::support_layer_min_fraction`]).
fn support_tests(g: &Grid, reg: &Region, cells: &[usize], cfg: &DetectConfig) -> (bool, bool, f64) {
    // Things standing on the plane: cells in front of it whose foot (projection onto the
    // plane) lies inside the member cells' convex footprint.
    let t = if reg.normal.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    // |normal × t| ≥ sin(25°) by the choice of t.
    let e1 = reg.normal.cross(&t).normalize();
    let e2 = reg.normal.cross(&e1);
    let to2 = |p: &Vector3<f64>| {
        let d = p - reg.centroid;
        Point2::new(d.dot(&e1), d.dot(&e2))
    };
    let pts: Vec<Point2<f64>> = cells
        .iter()
        .step_by(4)
        .map(|&i| to2(&v3(&g.p[i])))
        .collect();
    let hull = convex_hull_2d(&pts);
    // The hull's bounding box rejects most cells before the polygon test.
    let (lo, hi) = hull.iter().fold(
        (
            Point2::new(f64::INFINITY, f64::INFINITY),
            Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
        ),
        |(lo, hi), q| {
            (
                Point2::new(lo.x.min(q.x), lo.y.min(q.y)),
                Point2::new(hi.x.max(q.x), hi.y.max(q.y)),
            )
        },
    );
    let inside = |q: &Point2<f64>| {
        q.x >= lo.x && q.x <= hi.x && q.y >= lo.y && q.y <= hi.y && inside_convex(&hull, q)
    };
    let (mut front, mut behind_in, mut behind, mut valid) = (0usize, 0usize, 0usize, 0usize);
    // Cells of a body under the plane's rim (see `support_layer_min_fraction`).
    let mut under_rim = 0usize;
    let (rim_lo, rim_hi) = (
        cfg.support_layer_min_depth_mm,
        cfg.support_layer_max_depth_mm,
    );
    // Only large candidates are held to the layer test: the rim is not measured on others.
    let rim_wanted =
        cfg.support_layer_min_fraction > 0.0 && reg.area_mm2 >= cfg.support_min_area_mm2;
    // Every third cell: the tests compare fractions, and the frame's cells are many.
    const SUB: usize = 3;
    for (i, &z) in g.z.iter().enumerate().step_by(SUB) {
        if z <= 0.0 {
            continue;
        }
        valid += 1;
        let d = reg.dist(&g.p[i]);
        if d < -cfg.support_side_margin_mm {
            behind += 1;
        }
        if rim_wanted && -d >= rim_lo && -d <= rim_hi {
            let q = to2(&v3(&g.p[i]));
            let reach = cfg.support_side_margin_mm + plane_tol(cfg, z as f64);
            if boundary_distance(&hull, &q) <= reach {
                under_rim += 1;
            }
        }
        if d.abs() <= cfg.support_side_margin_mm || d.abs() > cfg.support_window_mm {
            continue;
        }
        if inside(&to2(&v3(&g.p[i]))) {
            if d > 0.0 {
                front += 1;
            } else {
                behind_in += 1;
            }
        }
    }
    // A plane with (almost) nothing behind it bounds the scene: floor, wall.
    (
        reg.area_mm2 >= cfg.support_always_area_mm2
            || (behind as f64) < cfg.support_max_behind_fraction * valid as f64,
        // A box top (a carton layer) has the boxes' bodies under it; a table has legs at most.
        (SUB * front) as f64 >= cfg.support_min_front_fraction * cells.len() as f64
            && front > behind_in,
        (SUB * under_rim) as f64 / cells.len().max(1) as f64,
    )
}

/// Distance from `p` to the boundary of the polygon `poly` (its edges), in its units.
fn boundary_distance(poly: &[Point2<f64>], p: &Point2<f64>) -> f64 {
    let mut best = f64::INFINITY;
    let Some(&last) = poly.last() else {
        return best;
    };
    // Every edge once, the closing one first (no index wraps).
    let mut a = last;
    for &b in poly {
        let ab = b - a;
        let t = ((p - a).dot(&ab) / ab.norm_squared().max(1e-12)).clamp(0.0, 1.0);
        best = best.min((p - (a + ab * t)).norm());
        a = b;
    }
    best
}

/// Dominant planes by RANSAC over all cells (deterministic), with their support tests
/// (bounds the scene, things stand on it, share of its cells under its rim): finds floors
/// and tables that sensor noise or texture cut into many small surfaces.
pub(crate) fn ransac_planes(g: &Grid, cfg: &DetectConfig) -> Vec<(Region, bool, bool, f64)> {
    // The pool holds every `POOL_STEP`-th valid cell: a plane's inliers stand for that many
    // cells each.
    const POOL_STEP: usize = 3;
    let mut pool: Vec<usize> = (0..g.z.len())
        .filter(|&i| g.z[i] > 0.0)
        .step_by(POOL_STEP)
        .collect();
    let mut found: Vec<(Region, Vec<usize>)> = Vec::new();
    // A fixed seed keeps the detector deterministic.
    let mut rng = ChaCha8Rng::seed_from_u64(0x005E_ED0F_5077);
    let mut next = |n: usize| -> usize { rng.random_range(0..n.max(1)) };
    let cell_area = 1.0 / (g.k.fx * g.k.fy);
    let cos_n = cfg.support_normal_tol_deg.to_radians().cos();
    for _ in 0..cfg.support_ransac_planes {
        if pool.len() < 3 {
            break;
        }
        // Hypotheses drawn in order from the fixed stream, scored in parallel; the first best
        // wins, so the result does not depend on the thread count.
        let hyps: Vec<(Vector3<f64>, Vector3<f64>)> = (0..cfg.support_ransac_iters)
            .filter_map(|_| {
                let (a, b, c) = (
                    v3(&g.p[pool[next(pool.len())]]),
                    v3(&g.p[pool[next(pool.len())]]),
                    v3(&g.p[pool[next(pool.len())]]),
                );
                let mut n = (b - a).cross(&(c - a)).try_normalize(1e-9)?;
                if n.dot(&a) > 0.0 {
                    n = -n;
                }
                Some((a, n))
            })
            .collect();
        // The scoring sample, gathered once per plane into contiguous memory rather than
        // re-read from the grid for every hypothesis.
        let sample: Vec<PlaneCell> = pool
            .iter()
            .step_by(8)
            .map(|&i| PlaneCell::new(g, i, cfg))
            .collect();
        let counts: Vec<usize> = hyps
            .par_iter()
            .map(|(a, n)| sample.iter().filter(|c| c.fits(a, n, cos_n)).count())
            .collect();
        let mut best: Option<(usize, Vector3<f64>, Vector3<f64>)> = None;
        for ((a, n), count) in hyps.into_iter().zip(counts) {
            if best.as_ref().is_none_or(|b| count > b.0) {
                best = Some((count, a, n));
            }
        }
        let Some((_, c, n)) = best else {
            break;
        };
        let inl: Vec<usize> = pool
            .iter()
            .copied()
            .filter(|&i| PlaneCell::new(g, i, cfg).fits(&c, &n, cos_n))
            .collect();
        if inl.len() < 3 {
            break;
        }
        // Refit on the inliers.
        let m = inl.len() as f64;
        let centroid = inl.iter().map(|&i| v3(&g.p[i])).sum::<Vector3<f64>>() / m;
        let mut cov = Matrix3::zeros();
        for &i in &inl {
            let d = v3(&g.p[i]) - centroid;
            cov += d * d.transpose();
        }
        let eig = cov.symmetric_eigen();
        let k = eig.eigenvalues.imin();
        let mut normal: Vector3<f64> = eig.eigenvectors.column(k).into_owned();
        if normal.dot(&centroid) > 0.0 {
            normal = -normal;
        }
        // Scale the area back to all of the plane's cells.
        let area: f64 = inl
            .iter()
            .map(|&i| {
                let p = v3(&g.p[i]);
                let cos = p.normalize().dot(&normal).abs().max(0.2);
                POOL_STEP as f64 * p.z * p.z * cell_area / cos
            })
            .sum();
        let reg = Region {
            n: inl.len(),
            centroid,
            normal,
            inlier_frac: 1.0,
            normal_spread_deg: 0.0,
            bend_deg: 0.0,
            colour: [0.0; 3],
            area_mm2: area,
        };
        if log::log_enabled!(log::Level::Debug) {
            log::debug!(
                "ransac plane n {} area {:.0} normal {:?} support {:?}",
                inl.len(),
                area,
                normal.as_slice(),
                support_tests(g, &reg, &inl, cfg)
            );
        }
        if area < cfg.support_small_area_mm2 {
            break;
        }
        // `inl` is a subsequence of `pool` (both ascending): one merge pass removes it.
        let mut taken = inl.iter().peekable();
        pool.retain(|i| {
            if taken.peek() == Some(&i) {
                taken.next();
                false
            } else {
                true
            }
        });
        found.push((reg, inl));
    }
    // The support tests do not steer the search: run them once it is done, in parallel.
    found
        .into_par_iter()
        .map(|(reg, inl)| {
            let (strong, standing, rim) = support_tests(g, &reg, &inl, cfg);
            // The share under the rim, of all of the plane's cells.
            (reg, strong, standing, rim / POOL_STEP as f64)
        })
        .collect()
}

/// A grid cell as RANSAC tests it against a support-plane hypothesis: point (mm), normal,
/// plane tolerance (mm, with `support_tol_factor`), and whether its normal is unknown.
struct PlaneCell {
    p: Vector3<f64>,
    n: Vector3<f64>,
    tol: f64,
    any_normal: bool,
}

impl PlaneCell {
    fn new(g: &Grid, i: usize, cfg: &DetectConfig) -> Self {
        let (p, n) = (v3(&g.p[i]), v3(&g.n[i]));
        PlaneCell {
            p,
            n,
            tol: cfg.support_tol_factor * plane_tol(cfg, p.z),
            any_normal: n.norm_squared() < 0.5,
        }
    }

    /// On the plane through `c` with unit normal `n` (within the tolerance), facing like it
    /// (within `cos_n`, any normal when unknown).
    fn fits(&self, c: &Vector3<f64>, n: &Vector3<f64>, cos_n: f64) -> bool {
        (self.p - c).dot(n).abs() <= self.tol && (self.any_normal || self.n.dot(n) >= cos_n)
    }
}

/// Point in a convex polygon (either orientation; no three vertices collinear, as
/// [`convex_hull_2d`] gives it), its boundary included: in the wedge at the first vertex,
/// then on the inner side of the edge of the fan triangle holding the point's direction,
/// found by bisection (the support tests ask this of every third cell of the frame, per
/// plane).
fn inside_convex(poly: &[Point2<f64>], p: &Point2<f64>) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    // Twice the signed area of (a, b, p): positive with p left of a → b.
    let cross =
        |a: &Point2<f64>, b: &Point2<f64>| (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    let o = &poly[0];
    let turn = (poly[1].x - o.x) * (poly[2].y - o.y) - (poly[1].y - o.y) * (poly[2].x - o.x);
    let s = if turn >= 0.0 { 1.0 } else { -1.0 };
    if s * cross(o, &poly[1]) < 0.0 || s * cross(&poly[n - 1], o) < 0.0 {
        return false;
    }
    let (mut lo, mut hi) = (1, n - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if s * cross(o, &poly[mid]) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    s * cross(&poly[lo], &poly[hi]) >= 0.0
}

/// Whether a surface with unit `normal` is a top: within `halves_top_max_tilt_deg` of the
/// support's `up`; `None` where up is not known.
pub(crate) fn is_top(
    normal: &Vector3<f64>,
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> Option<bool> {
    up.map(|u| normal.dot(&u).abs() >= cfg.halves_top_max_tilt_deg.to_radians().cos())
}

/// Whether a region can be a box face: big enough, planar, not curved.
pub(crate) fn is_face(r: &Region, cfg: &DetectConfig) -> bool {
    r.n >= cfg.min_face_cells as usize
        && r.inlier_frac >= cfg.min_plane_inlier_frac
        && r.normal_spread_deg <= cfg.max_normal_spread_deg
        && r.bend_deg <= super::regions::bend_limit(cfg, r.centroid.z)
}

/// Robust range (low and high quantiles) of values.
pub(crate) fn robust_range(vals: &mut [f64], q: f64) -> (f64, f64) {
    if vals.is_empty() {
        return (0.0, 0.0);
    }
    let n = vals.len();
    let lo_i = ((n as f64 * q) as usize).min(n - 1);
    let hi_i = ((n as f64 * (1.0 - q)) as usize).min(n - 1);
    crate::order_stats::rank_pair(vals, lo_i, hi_i).unwrap_or((0.0, 0.0))
}

/// The axes of a lone face with normal `a`: `a` and the in-plane pair of the smallest
/// robust bounding rectangle (quantile `q` each end) of its points, in 3° steps over a quarter
/// turn (every 9° first, then 3° around the best). Faces of more than 512 points are measured
/// on an even stride of them: the quantiles barely move, and this runs for every lone face of
/// every object (a quarter of detection time before).
pub(crate) fn rectangle_axes(a: &Vector3<f64>, pts: &[Vector3<f64>], q: f64) -> [Vector3<f64>; 3] {
    let stride = pts.len().div_ceil(512).max(1);
    let t = if a.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    // |a × t| ≥ sin(25°) by the choice of t.
    let b0 = a.cross(&t).normalize();
    let c0 = a.cross(&b0);
    let mut xs = Vec::with_capacity(pts.len());
    let mut ys = Vec::with_capacity(pts.len());
    let mut area_at = |k: i64| {
        let th = (k as f64 * 3.0).to_radians();
        let b = b0 * th.cos() + c0 * th.sin();
        let c = a.cross(&b);
        xs.clear();
        ys.clear();
        xs.extend(pts.iter().step_by(stride).map(|p| p.dot(&b)));
        ys.extend(pts.iter().step_by(stride).map(|p| p.dot(&c)));
        let (x0, x1) = robust_range(&mut xs, q);
        let (y0, y1) = robust_range(&mut ys, q);
        ((x1 - x0) * (y1 - y0), b, c)
    };
    // Every third step first, then the two steps either side of the best (the area varies
    // slowly with the angle).
    let mut best = (f64::INFINITY, b0, c0);
    let mut best_k = 0;
    for k in (0..30).step_by(3) {
        let r = area_at(k);
        if r.0 < best.0 {
            (best, best_k) = (r, k);
        }
    }
    for k in [best_k - 2, best_k - 1, best_k + 1, best_k + 2] {
        let r = area_at(k.rem_euclid(30));
        if r.0 < best.0 {
            best = r;
        }
    }
    [*a, best.1, best.2]
}

/// The cells of a `w × h` grid whose centres lie in the convex polygon `hull` (grid
/// coordinates), row-major: the cells a frame-sized scan of its raster would meet, in that
/// order, at a cost that grows with the polygon.
fn hull_cells(hull: &[Point2<f64>], w: usize, h: usize) -> impl Iterator<Item = usize> {
    convex_polygon_spans(hull, w as u32, h as u32)
        .into_iter()
        .flat_map(move |(v, u0, u1)| (u0..=u1).map(move |u| v as usize * w + u as usize))
}

/// A scored group of faces with its fitted cuboid, before the final mask fill.
pub(crate) struct Raw {
    /// Grid cells of the grouped faces.
    pub cells: Vec<u32>,
    /// Box-likeness, 0..1.
    pub score: f64,
    /// Faces grouped.
    pub n_faces: u8,
    /// Fitted cuboid (camera frame, mm; a single face gets a 1 mm thickness).
    pub bx: OrientedBox,
    /// Plane normal of the largest face.
    pub normal: Vector3<f64>,
    /// A part of a cut not made: a profile cut that lost to the whole object it would have
    /// cut ([`DetectConfig::blob_profile_cut_alternatives`]) or a step's reading not taken
    /// ([`DetectConfig::blob_stack_margin`]). An alternative reading only.
    pub lost_cut: bool,
}

/// Whether a face-grouping take-in admits region `r` into face `fi` of the faces given
/// (`f0`: the face's largest region); see `group_candidates`.
type Admit<'a> = dyn Fn(&[Vec<usize>], usize, usize, usize) -> bool + 'a;

/// Groups faces into box candidates and scores them. Returns candidates sorted by score.
/// On colour patches (`colour_level`), with [`DetectConfig::corner_alternatives`], a
/// three-face merge refused only by a corner contact's short shared edge is scored as well;
/// with [`DetectConfig::coplanar_alternatives`], so is a group in which a face refused as
/// parallel to a strip of itself is joined to that strip; with
/// [`DetectConfig::strip_alternatives`], so is every group of two or three faces with the
/// coplanar strips it touches taken in; with [`DetectConfig::band_face_alternatives`], so is
/// every such group with each face that is only a band grown into the wider coplanar region
/// past it, and the group it grew from is scored down. `up`: the support's up, where known
/// (which faces are tops, for [`DetectConfig::curved_veto_max_on_plane`]).
pub(crate) fn group_candidates(
    g: &Grid,
    labels: &[u32],
    regions: &[Region],
    on_support: &[bool],
    colour_level: bool,
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> Vec<Raw> {
    // The alternatives are for colour patches only (see each flag's documentation).
    let corner_alternatives = colour_level && cfg.corner_alternatives;
    let coplanar_alternatives = colour_level && cfg.coplanar_alternatives;
    let strip_alternatives = colour_level && cfg.strip_alternatives;
    let n = regions.len();
    let face: Vec<bool> = regions.iter().map(|r| is_face(r, cfg)).collect();
    if log::log_enabled!(log::Level::Debug) {
        for (k, r) in regions.iter().enumerate() {
            if r.n >= 100 {
                log::debug!(
                    "region {k} n {} face {} inl {:.2} spread {:.1} bend {:.1} normal {:.2} {:.2} {:.2} at {:?}",
                    r.n, face[k], r.inlier_frac, r.normal_spread_deg, r.bend_deg,
                    r.normal.x, r.normal.y, r.normal.z,
                    g.k.project(&Point3::from(r.centroid)).map(|p| (p.x as i32, p.y as i32))
                );
            }
        }
    }
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE {
            cells[l as usize].push(i as u32);
        }
    }
    // Contacts: cells of two faces at most `contact_gap_cells` apart that both lie on the
    // other face's plane (the shared edge), counted along rows and columns.
    let (w, h) = (g.w, g.h);
    let gap = cfg.contact_gap_cells.max(1) as usize;
    let mut contact: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    for v in 0..h {
        for u in 0..w {
            let i = v * w + u;
            let a = labels[i];
            if a == NONE || !face[a as usize] {
                continue;
            }
            for (du, dv) in [(1usize, 0usize), (0, 1)] {
                for d in 1..=gap {
                    let (uu, vv) = (u + du * d, v + dv * d);
                    if uu >= w || vv >= h {
                        break;
                    }
                    let j = vv * w + uu;
                    let b = labels[j];
                    if b == a {
                        break;
                    }
                    if b == NONE {
                        continue;
                    }
                    let (ra, rb) = (&regions[a as usize], &regions[b as usize]);
                    let zi = g.z[i] as f64;
                    let tol = cfg.edge_tol_factor * plane_tol(cfg, zi);
                    // Near in 3D (no occluding jump across the band), and each cell no farther
                    // from the other face's plane than from the other cell: they meet at an edge.
                    let d3 = (v3(&g.p[i]) - v3(&g.p[j])).norm();
                    let cell_mm = zi / g.k.fx;
                    if d3 <= 3.0 * d as f64 * cell_mm + tol
                        && rb.dist(&g.p[i]).abs() <= d3 + tol
                        && ra.dist(&g.p[j]).abs() <= d3 + tol
                    {
                        *contact.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                    }
                    if face[b as usize] {
                        break;
                    }
                }
            }
        }
    }
    // Faces touching a curved surface (a cylinder's cap, a sphere's flat-looking patch) are
    // parts of round things; contacts with non-faces are not grouped.
    let curved = |r: usize| {
        let reg = &regions[r];
        // Smoothly bent: fits a plane loosely, normals not noisy, but its halves disagree.
        reg.n >= cfg.min_face_cells as usize
            && reg.bend_deg > super::regions::bend_limit(cfg, reg.centroid.z)
            && reg.inlier_frac >= cfg.min_plane_inlier_frac
            && reg.normal_spread_deg <= cfg.max_normal_spread_deg
    };
    let sin_perp = cfg.perpendicular_tol_deg.to_radians().sin();
    let perp = |a: usize, b: usize| regions[a].normal.dot(&regions[b].normal).abs() <= sin_perp;
    // Faces touching a face across an edge (perpendicular): their box is read by the group.
    let mut has_edge = vec![false; n];
    for (&(a, b), &c) in &contact {
        let (a, b) = (a as usize, b as usize);
        if c >= cfg.min_contact_cells && face[a] && face[b] && perp(a, b) {
            has_edge[a] = true;
            has_edge[b] = true;
        }
    }
    // A "curved" surface smaller than a top seen alone, whose cells lie on the top's own
    // plane, is flat there: a tape band across a carton top, whose narrow halves' normals
    // are noise (`curved_veto_max_on_plane`).
    let on_face_plane = |c: usize, f: usize| {
        if is_top(&regions[f].normal, up, cfg) != Some(true)
            || has_edge[f]
            || regions[c].n >= regions[f].n
        {
            return false;
        }
        let on = cells[c]
            .iter()
            .filter(|&&i| {
                regions[f].dist(&g.p[i as usize]).abs() <= plane_tol(cfg, g.z[i as usize] as f64)
            })
            .count();
        on as f64 >= cfg.curved_veto_max_on_plane * cells[c].len() as f64
    };
    // A curved surface `c` vetoes face `f` when it is large enough beside it, really bent, and
    // not lying on the face.
    let vetoes = |c: usize, f: usize| {
        regions[c].n as f64 >= cfg.curved_veto_min_ratio * regions[f].n as f64
            && regions[c].bend_deg >= cfg.curved_veto_min_bend_deg
            && !on_face_plane(c, f)
    };
    let mut touches_curved = vec![false; n];
    for (&(a, b), &c) in &contact {
        if c >= cfg.min_contact_cells {
            let (a, b) = (a as usize, b as usize);
            if face[a] && curved(b) && vetoes(b, a) {
                touches_curved[a] = true;
            }
            if face[b] && curved(a) && vetoes(a, b) {
                touches_curved[b] = true;
            }
        }
    }
    contact.retain(|&(a, b), _| face[a as usize] && face[b as usize]);
    // Extent of a face's cells along a direction (robust); a face may be several regions
    // (one that colour cut in pieces).
    let extent_of = |rs: &[usize], e: &Vector3<f64>| -> f64 {
        let mut vals: Vec<f64> = rs
            .iter()
            .flat_map(|&r| cells[r].iter())
            .map(|&i| v3(&g.p[i as usize]).dot(e))
            .collect();
        let (lo, hi) = robust_range(&mut vals, cfg.extent_quantile);
        hi - lo
    };
    let extent_along = |r: usize, e: &Vector3<f64>| extent_of(&[r], e);
    // Convex edge: each face's centroid lies behind the other face's plane.
    let convex = |a: usize, b: usize| -> bool {
        let (ra, rb) = (&regions[a], &regions[b]);
        let m = cfg.convex_margin_mm;
        (rb.centroid - ra.centroid).dot(&ra.normal) <= -m
            && (ra.centroid - rb.centroid).dot(&rb.normal) <= -m
    };
    let compatible = |a: usize, b: usize| -> bool {
        let (ra, rb) = (&regions[a], &regions[b]);
        if !perp(a, b) || !convex(a, b) {
            return false;
        }
        // The shared edge has about the same length on both faces.
        let e = ra.normal.cross(&rb.normal);
        if e.norm() < 1e-6 {
            return false;
        }
        let e = e.normalize();
        let (la, lb) = (extent_along(a, &e), extent_along(b, &e));
        la.min(lb) >= cfg.edge_length_ratio * la.max(lb)
    };
    if log::log_enabled!(log::Level::Debug) {
        for (&(a, b), &c) in &contact {
            let (ra, rb) = (&regions[a as usize], &regions[b as usize]);
            let e = ra.normal.cross(&rb.normal);
            let e = e.normalize();
            log::debug!(
                "pair {a}({}) {b}({}) contacts {c} dot {:.2} convex {:.0} {:.0} edge {:.0} {:.0} compat {}",
                ra.n,
                rb.n,
                ra.normal.dot(&rb.normal),
                (rb.centroid - ra.centroid).dot(&ra.normal),
                (ra.centroid - rb.centroid).dot(&rb.normal),
                extent_along(a as usize, &e),
                extent_along(b as usize, &e),
                compatible(a as usize, b as usize)
            );
        }
    }
    let mut pairs: Vec<((u32, u32), u32)> = contact
        .iter()
        .filter(|(_, &c)| c >= cfg.min_contact_cells)
        .map(|(&k, &c)| (k, c))
        .collect();
    pairs.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    // A lone face `b` refused by group `ga` (holding `a`, with which `b` is compatible) only
    // because one other face `x` of the group is parallel to it: when `x` and `b` touch and are
    // coplanar, they are one face split by colour (a tape strip along a carton's edge), and
    // the group with `b` joined to `x` is an alternative.
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let coplanar = |x: usize, b: usize| {
        let (rx, rb) = (&regions[x], &regions[b]);
        let tol = plane_tol(cfg, rb.centroid.z);
        rx.normal.dot(&rb.normal) >= cos_par
            && (rb.centroid - rx.centroid).dot(&rx.normal).abs() <= tol
            && (rx.centroid - rb.centroid).dot(&rb.normal).abs() <= tol
    };
    // Band `x` lies on the plane of the wider region `r`: a band's own normal, fitted across
    // a few cells, is too loose to test `r` against.
    let on_plane_of = |x: usize, r: usize| {
        let (rx, rr) = (&regions[x], &regions[r]);
        rx.normal.dot(&rr.normal) >= cos_par
            && (rx.centroid - rr.centroid).dot(&rr.normal).abs() <= plane_tol(cfg, rx.centroid.z)
    };
    // Regions `rs` together are no wider than `width_mm` along one of eight directions in
    // face region `f`'s plane (22.5° apart).
    let narrow_within = |rs: &[usize], f: usize, width_mm: f64| {
        let rf = &regions[f];
        let u = rf
            .normal
            .cross(&Vector3::x())
            .try_normalize(1e-6)
            .unwrap_or_else(|| rf.normal.cross(&Vector3::y()).normalize());
        let v = rf.normal.cross(&u);
        (0..8).any(|k| {
            let t = k as f64 * std::f64::consts::PI / 8.0;
            extent_of(rs, &(u * t.cos() + v * t.sin())) <= width_mm
        })
    };
    // Region `r` is no wider than a tape.
    let narrow = |r: usize, f: usize| narrow_within(&[r], f, cfg.tape_max_width_mm);
    // Region `r` is a strip of face region `f`: narrow, and at most half its size.
    let strip = |r: usize, f: usize| 2 * regions[r].n <= regions[f].n && narrow(r, f);
    // The largest region of a face of several (whose normal is the face's).
    let largest = |f: &[usize]| f.iter().copied().max_by_key(|&r| regions[r].n).unwrap_or(0);
    // Every two faces still share an edge of about the same length on both: the join
    // must not run past the box (two flush cartons' fronts).
    let edges_fit = |faces: &[Vec<usize>]| {
        faces.iter().enumerate().all(|(i, f)| {
            faces[i + 1..].iter().all(|g| {
                let e = regions[largest(f)]
                    .normal
                    .cross(&regions[largest(g)].normal);
                let Some(e) = e.try_normalize(1e-9) else {
                    return false;
                };
                let (lf, lg) = (extent_of(f, &e), extent_of(g, &e));
                lf.min(lg) >= cfg.edge_length_ratio * lf.max(lg)
            })
        })
    };
    // The region of contact `(p, q)` that is not in `face`, when the other one is.
    let across = |face: &[usize], p: u32, q: u32| -> Option<usize> {
        let (p, q) = (p as usize, q as usize);
        if face.contains(&p) {
            Some(q)
        } else if face.contains(&q) {
            Some(p)
        } else {
            None
        }
    };
    // One pass over the faces: each takes in the coplanar regions it touches (by at least
    // `min_contact_cells`) that `admit(faces, fi, f0, r)` lets in (`f0` its largest region),
    // one at a time while the edges still fit. Whether any was.
    let take_in_pass = |faces: &mut Vec<Vec<usize>>, admit: &Admit| -> bool {
        let mut added = false;
        for fi in 0..faces.len() {
            let f0 = largest(&faces[fi]);
            for (&(p, q), &c) in &contact {
                let Some(r) = across(&faces[fi], p, q) else {
                    continue;
                };
                if c >= cfg.min_contact_cells && coplanar(f0, r) && admit(faces, fi, f0, r) {
                    faces[fi].push(r);
                    if edges_fit(faces) {
                        added = true;
                    } else {
                        faces[fi].pop();
                    }
                }
            }
            faces[fi].sort_unstable();
        }
        added
    };
    // Each face also takes in the other regions coplanar with it that it touches (the rest
    // of a top that print or tape cut in pieces), while the edges still fit. Whether any was.
    let absorb_strips = |faces: &mut Vec<Vec<usize>>| -> bool {
        let taken: Vec<usize> = faces.iter().flatten().copied().collect();
        take_in_pass(faces, &|faces, fi, f0, r| {
            !taken.contains(&r) && !faces[fi].contains(&r) && strip(r, f0)
        })
    };
    // Each face also takes in, until none is left, the narrow coplanar regions it touches
    // that run the whole length of each edge it shares with another face of the group
    // (`edge_length_ratio`), of any size, while the edges still fit: the rest of a top or
    // front that tape, print or a grazing view cut into bands parallel to the box's edge.
    // Whether any was.
    let bridge_bands = |faces: &mut Vec<Vec<usize>>| -> bool {
        // A band along every edge of face `fi` shared with another face.
        let band = |faces: &[Vec<usize>], fi: usize, f0: usize, r: usize| {
            faces.iter().enumerate().all(|(gi, gf)| {
                if gi == fi {
                    return true;
                }
                let Some(e) = regions[f0]
                    .normal
                    .cross(&regions[largest(gf)].normal)
                    .try_normalize(1e-9)
                else {
                    return false;
                };
                extent_along(r, &e) >= cfg.edge_length_ratio * extent_of(&faces[fi], &e)
            })
        };
        let mut added = false;
        while take_in_pass(faces, &|faces, fi, f0, r| {
            !faces.iter().any(|f| f.contains(&r)) && narrow(r, f0) && band(faces, fi, f0, r)
        }) {
            added = true;
        }
        added
    };
    // A face that is only a band (no wider than `band_face_max_width_mm` across, over all
    // its regions) takes in the wider coplanar region it touches most, while the edges still fit:
    // the rest of a front cut off below a band along its top edge. Whether any face did.
    let grow_bands = |faces: &mut Vec<Vec<usize>>| -> bool {
        // The region band face `fi` of `faces` would take in.
        let wider = |faces: &[Vec<usize>], fi: usize| -> Option<usize> {
            let f0 = largest(&faces[fi]);
            if !narrow_within(&faces[fi], f0, cfg.band_face_max_width_mm) {
                return None;
            }
            contact
                .iter()
                .filter(|(_, &c)| c >= cfg.min_contact_cells)
                .filter_map(|(&(p, q), &c)| across(&faces[fi], p, q).map(|r| (r, c)))
                .filter(|&(r, _)| {
                    !faces.iter().any(|f| f.contains(&r)) && on_plane_of(f0, r) && !narrow(r, f0)
                })
                .max_by_key(|&(r, c)| (c, std::cmp::Reverse(r)))
                .map(|(r, _)| r)
        };
        // Every band face at once first: a line printed round a carton cuts its front and its
        // side alike, and grown one at a time neither would fit the other.
        let mut all = faces.clone();
        for fi in 0..faces.len() {
            if let Some(r) = wider(faces, fi) {
                if !all.iter().any(|f| f.contains(&r)) {
                    log::debug!("band face {:?} grows by {r}({})", faces[fi], regions[r].n);
                    all[fi].push(r);
                    all[fi].sort_unstable();
                }
            }
        }
        if all != *faces && edges_fit(&all) {
            *faces = all;
            return true;
        }
        let mut added = false;
        for fi in 0..faces.len() {
            if let Some(r) = wider(faces, fi) {
                faces[fi].push(r);
                if edges_fit(faces) {
                    faces[fi].sort_unstable();
                    added = true;
                } else {
                    faces[fi].pop();
                }
            }
        }
        added
    };
    let coplanar_join = |ga: &[usize], gb: &[usize], a: usize, b: usize| {
        let (ga, b) = if gb.len() == 1 && gb[0] == b {
            (ga, b)
        } else if ga.len() == 1 && ga[0] == a {
            (gb, a)
        } else {
            return None;
        };
        let mut parallel = ga.iter().copied().filter(|&x| !perp(x, b));
        // The pair is compatible, so `x` is not the group's face that `b` touched.
        let x = parallel.next()?;
        if parallel.next().is_some() {
            return None;
        }
        let touch = contact.contains_key(&(x.min(b) as u32, x.max(b) as u32));
        let others_fit = ga.iter().filter(|&&y| y != x).all(|&y| {
            perp(y, b)
                && (!contact.contains_key(&(y.min(b) as u32, y.max(b) as u32)) || compatible(y, b))
        });
        if !(coplanar(x, b) && touch && others_fit) {
            return None;
        }
        // Only a strip joins a face: two faces of their own (two flush cartons' tops) stay
        // apart.
        let (small, big) = if regions[x].n <= regions[b].n {
            (x, b)
        } else {
            (b, x)
        };
        if !strip(small, big) {
            return None;
        }
        let mut faces: Vec<Vec<usize>> = ga
            .iter()
            .map(|&y| if y == x { vec![x, b] } else { vec![y] })
            .collect();
        if !edges_fit(&faces) {
            return None;
        }
        absorb_strips(&mut faces);
        faces.sort_unstable();
        Some(faces)
    };
    let mut group_of: Vec<usize> = (0..n).collect();
    let mut members: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
    // Alternative groups, face by face (a face may be several coplanar regions).
    let mut extra: Vec<Vec<Vec<usize>>> = Vec::new();
    for ((a, b), _) in pairs {
        let (a, b) = (a as usize, b as usize);
        let (ga, gb) = (group_of[a], group_of[b]);
        if ga == gb || members[ga].len() + members[gb].len() > 3 {
            continue;
        }
        // Whether every pair of faces across the two groups may be faces of one box; `loose`
        // holds pairs other than (a, b) to convexity only.
        let fits = |loose: bool| {
            members[ga].iter().all(|&x| {
                members[gb].iter().all(|&y| {
                    perp(x, y)
                        && (!contact.contains_key(&(x.min(y) as u32, x.max(y) as u32))
                            || if loose && (x, y) != (a, b) && (x, y) != (b, a) {
                                convex(x, y)
                            } else {
                                compatible(x, y)
                            })
                })
            })
        };
        if !fits(false) {
            if corner_alternatives && fits(true) {
                let mut union: Vec<usize> =
                    members[ga].iter().chain(&members[gb]).copied().collect();
                union.sort_unstable();
                let union: Vec<Vec<usize>> = union.into_iter().map(|f| vec![f]).collect();
                if !extra.contains(&union) {
                    extra.push(union);
                }
            }
            if coplanar_alternatives && compatible(a, b) {
                if let Some(faces) = coplanar_join(&members[ga], &members[gb], a, b) {
                    if !extra.contains(&faces) {
                        extra.push(faces);
                    }
                }
            }
            continue;
        }
        let moved = std::mem::take(&mut members[gb]);
        for &x in &moved {
            group_of[x] = ga;
        }
        members[ga].extend(moved);
    }
    // Every group of two or three faces also yields one more candidate with the coplanar
    // strips its faces touch taken in (a tape band or a printed edge left out of a carton's
    // top or front), when there are any.
    if strip_alternatives {
        for (gi, mem) in members.iter().enumerate() {
            if mem.len() < 2 || group_of[gi] != gi {
                continue;
            }
            let mut faces: Vec<Vec<usize>> = mem.iter().map(|&f| vec![f]).collect();
            if absorb_strips(&mut faces) {
                faces.sort_unstable();
                if !extra.contains(&faces) {
                    extra.push(faces.clone());
                }
            }
            if cfg.band_alternatives && bridge_bands(&mut faces) {
                faces.sort_unstable();
                if !extra.contains(&faces) {
                    extra.push(faces);
                }
            }
        }
    }
    let mut groups: Vec<Vec<Vec<usize>>> = members
        .iter()
        .enumerate()
        .filter(|&(gi, mem)| {
            !mem.is_empty()
                && group_of[gi] == gi
                && mem.iter().all(|&f| face[f])
                && !(mem.len() == 1 && touches_curved[mem[0]])
        })
        .map(|(_, mem)| mem.iter().map(|&f| vec![f]).collect())
        .chain(
            extra
                .into_iter()
                .filter(|mem| mem.iter().flatten().all(|&f| face[f])),
        )
        .collect();
    // A group with a face that is only a band, and that band continues on its plane into a
    // wider region past a line that is no edge of the box, is read again with that region
    // taken in; the band reading is then scored down (`band_open_factor`).
    let mut open = vec![false; groups.len()];
    if strip_alternatives && cfg.band_face_alternatives {
        for gi in 0..groups.len() {
            if groups[gi].len() < 2 {
                continue;
            }
            let mut faces = groups[gi].clone();
            absorb_strips(&mut faces);
            if grow_bands(&mut faces) {
                open[gi] = true;
                faces.sort_unstable();
                if !groups.contains(&faces) {
                    groups.push(faces);
                    open.push(false);
                }
            }
        }
    }
    // Groups are scored independently: in parallel (the order is kept).
    let scored: Vec<Option<Raw>> = groups
        .par_iter()
        .zip(open)
        .map(|(mem, open)| {
            let mut raw = score_group(g, labels, regions, on_support, &cells, mem, cfg)?;
            if open {
                raw.score *= cfg.band_open_factor;
            }
            Some(raw)
        })
        .collect();
    // A grouping that is no box because one of its faces is none (a top spanning two flush
    // cartons, joined to one of their fronts) leaves its other faces in no candidate: each
    // is read alone too, when some face of the group is no box alone.
    let lone: Vec<Vec<Raw>> = if colour_level && cfg.lone_faces_of_failed_groups {
        groups
            .iter()
            .zip(&scored)
            .filter(|(mem, raw)| raw.is_none() && mem.len() > 1 && mem.iter().all(|f| f.len() == 1))
            .map(|(mem, _)| mem)
            .collect::<Vec<_>>()
            .into_par_iter()
            .filter_map(|mem| {
                let alone: Vec<Option<Raw>> = mem
                    .iter()
                    .map(|f| {
                        let one = vec![f.clone()];
                        if touches_curved[f[0]] || groups.contains(&one) {
                            return None;
                        }
                        score_group(g, labels, regions, on_support, &cells, &one, cfg)
                    })
                    .collect();
                alone
                    .iter()
                    .any(Option::is_none)
                    .then(|| alone.into_iter().flatten().collect())
            })
            .collect()
    } else {
        Vec::new()
    };
    let mut out: Vec<Raw> = scored
        .into_iter()
        .flatten()
        .chain(lone.into_iter().flatten())
        .collect();
    out.sort_by(|a, b| b.score.total_cmp(&a.score));
    out
}

/// Final masks: cells that lie within each candidate's cuboid grown by
/// `fill_margin_factor` plane tolerances (edge bands, a grazing side face, the foot of a box
/// cut off next to its support, missing depth inside the silhouette) are added, best
/// candidates first. `claimed` marks cells that are never added: supports and every
/// candidate's own cells. A candidate then takes in its faces' continuation past an occluder
/// (`occluded`), absorbing another candidate found there (the joined candidate keeps the
/// higher score; the absorbed one is dropped).
pub(crate) fn fill(
    g: &Grid,
    raws: Vec<Raw>,
    claimed: &mut [bool],
    planes: &[Region],
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> Vec<Candidate> {
    let (w, h) = (g.w, g.h);
    // Each cell's candidate, for the occluded continuations (which may absorb another).
    let mut owner = vec![u32::MAX; g.z.len()];
    for (k, raw) in raws.iter().enumerate() {
        for &i in &raw.cells {
            claimed[i as usize] = true;
            owner[i as usize] = k as u32;
        }
    }
    let sizes: Vec<usize> = raws.iter().map(|r| r.cells.len()).collect();
    let mut result: Vec<Option<Candidate>> = Vec::with_capacity(raws.len());
    let mut absorbed = vec![false; raws.len()];
    for (k, raw) in raws.iter().enumerate() {
        if absorbed[k] {
            result.push(None);
            continue;
        }
        let mut cells = raw.cells.clone();
        let mut score = raw.score;
        let tol_c = plane_tol(cfg, raw.bx.center_mm.z.max(1.0));
        let margin = cfg.fill_margin_factor * tol_c;
        let bx = down_to_support(&raw.bx, planes, up, tol_c, cfg);
        let grown = OrientedBox {
            size_mm: bx.size_mm.add_scalar(2.0 * margin),
            ..bx
        };
        let inner = silhouette_hull_px(&bx, &g.k)
            .map(|hull| convex_polygon_spans(&hull, w as u32, h as u32));
        if let (Some(hull), Some(inner)) = (silhouette_hull_px(&grown, &g.k), inner) {
            for i in hull_cells(&hull, w, h) {
                if claimed[i] {
                    continue;
                }
                let z = g.z[i] as f64;
                // No depth: inside the cuboid's own silhouette only.
                let fits = if z <= 0.0 {
                    let (u, v) = ((i % w) as u32, (i / w) as u32);
                    // Rows are increasing and unique.
                    inner
                        .binary_search_by_key(&v, |s| s.0)
                        .is_ok_and(|k| (inner[k].1..=inner[k].2).contains(&u))
                } else {
                    let (u, v) = ((i % w) as f64, (i / w) as f64);
                    let dir = g.k.ray(u, v);
                    let tol = plane_tol(cfg, z);
                    ray_box_intersection(&Point3::origin(), &dir, &grown).is_some_and(
                        |(t0, t1, _)| z >= t0 - tol && z <= t1.min(t0 + 2.0 * margin + 3.0 * tol),
                    )
                };
                if fits {
                    claimed[i] = true;
                    cells.push(i as u32);
                }
            }
        }
        let holders = super::occluded::Holders {
            claimed,
            owner: &owner,
            sizes: &sizes,
        };
        let cont = super::occluded::continuation(g, &raw.bx, k, &cells, &holders, cfg);
        for i in cont.cells {
            claimed[i as usize] = true;
            cells.push(i);
        }
        for j in cont.absorbed {
            if absorbed[j] {
                continue;
            }
            absorbed[j] = true;
            score = score.max(raws[j].score);
            match result.get_mut(j).and_then(Option::take) {
                // Filled already: its cells and strips.
                Some(c) => cells.extend(c.cells.into_iter().chain(c.strip)),
                None => cells.extend(&raws[j].cells),
            }
        }
        let mut strip = Vec::new();
        if raw.n_faces == 1 {
            strip = side_strips(g, &raw.bx, &cells, claimed, cfg);
            for &i in &strip {
                claimed[i as usize] = true;
            }
        }
        // An absorbed candidate may share cells with this one (candidates overlap a little).
        cells.sort_unstable();
        cells.dedup();
        strip.sort_unstable();
        result.push(Some(Candidate {
            cells,
            strip,
            score,
            n_faces: raw.n_faces,
            bx: raw.bx,
        }));
    }
    result.into_iter().flatten().collect()
}

/// `bx` extended towards the support plane it stands just above, for filling: objects lose
/// the cells within `blob_support_gap_factor` plane tolerances (`tol_mm`, at the box's depth)
/// of a support, so a box's side faces come out short and its cuboid ends above the plane.
/// When one of `bx`'s axes is within `perpendicular_tol_deg` of the normal of a support
/// parallel to `up` (within `support_normal_tol_deg`; none without `up`) and its lowest
/// corner lies above that plane by at most `fill_support_reach_factor` tolerances, the box is
/// extended along that axis until, grown by the fill margin (`fill_margin_factor`), it ends
/// half a tolerance above the plane. Otherwise `bx` unchanged.
fn down_to_support(
    bx: &OrientedBox,
    planes: &[Region],
    up: Option<Vector3<f64>>,
    tol_mm: f64,
    cfg: &DetectConfig,
) -> OrientedBox {
    let reach = cfg.fill_support_reach_factor * tol_mm;
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let cos_up = cfg.support_normal_tol_deg.to_radians().cos();
    let Some(up) = up.filter(|_| reach > 0.0) else {
        return *bx;
    };
    let corners = bx.corners_mm();
    // Only planes things stand on (parallel to up): a box near a wall does not reach it.
    for pl in planes
        .iter()
        .filter(|pl| pl.normal.dot(&up).abs() >= cos_up)
    {
        let Some(a) = (0..3).find(|&a| bx.axis(a).dot(&pl.normal).abs() >= cos_par) else {
            continue;
        };
        let low = corners
            .iter()
            .map(|c| pl.dist(&[c.x as f32, c.y as f32, c.z as f32]))
            .fold(f64::INFINITY, f64::min);
        // The filled box is `bx` grown by the fill margin: its bottom stops half a tolerance
        // above the plane, so that the support's own cells at the foot stay out.
        let ext = low - (cfg.fill_margin_factor + 0.5) * tol_mm;
        if ext > 0.0 && low <= reach {
            let e = bx.axis(a);
            // Towards the plane: against its normal.
            let down = if e.dot(&pl.normal) > 0.0 { -e } else { e };
            let mut size = bx.size_mm;
            size[a] += ext;
            return OrientedBox {
                rotation: bx.rotation,
                center_mm: bx.center_mm + down * (ext / 2.0),
                size_mm: size,
            };
        }
    }
    *bx
}

/// The side faces of a one-face candidate seen past its edges, as unclaimed grid cells.
///
/// A box's side faces are too thin in view to become faces of their own when seen at a
/// grazing angle (a strip a few cells wide has no reliable normal), yet without them the
/// estimator cannot measure the box's depth. Geometry says where they must lie: a side face
/// hangs from an edge of the front face straight back, so its points lie behind the face's
/// plane and project onto the plane on that edge; and it is seen only when it faces the
/// camera. Cells meeting that, reached from the candidate through depth-continuous
/// 4-neighbours, are taken in (see [`DetectConfig::side_strip_max_mm`]), as are cells on the
/// face's own plane within its rectangle that the candidate missed.
fn side_strips(
    g: &Grid,
    face: &OrientedBox,
    cells: &[u32],
    claimed: &[bool],
    cfg: &DetectConfig,
) -> Vec<u32> {
    if cfg.side_strip_max_mm <= 0.0 {
        return Vec::new();
    }
    let c = face.center_mm;
    // The thin axis is the face normal; turned towards the camera.
    let thin = (0..3)
        .min_by(|&a, &b| face.size_mm[a].total_cmp(&face.size_mm[b]))
        .unwrap_or(0);
    let mut n = face.axis(thin);
    if n.dot(&c) > 0.0 {
        n = -n;
    }
    let (e1, e2) = (face.axis((thin + 1) % 3), face.axis((thin + 2) % 3));
    let (h1, h2) = (
        face.size_mm[(thin + 1) % 3] / 2.0,
        face.size_mm[(thin + 2) % 3] / 2.0,
    );
    let slack = cfg.side_strip_slack_deg.to_radians().tan();
    // Which edge's side face a cell lies on (0..4: −u, +u, −v, +v), 4 for the face's own
    // plane, `None` when it lies on neither.
    let side_of = |i: usize| -> Option<usize> {
        if g.z[i] <= 0.0 || claimed[i] {
            return None;
        }
        let p = v3(&g.p[i]);
        let d = n.dot(&(p - c));
        let tol = plane_tol(cfg, g.z[i] as f64);
        if d > tol || d < -cfg.side_strip_max_mm {
            return None;
        }
        // Within the face's rectangle (grown by the tolerance and, the further back, by the
        // slack for a tilted normal) ...
        let band = tol + slack * (-d).max(0.0);
        let (u, v) = (e1.dot(&(p - c)), e2.dot(&(p - c)));
        if u.abs() > h1 + band || v.abs() > h2 + band {
            return None;
        }
        if d >= -tol {
            return Some(4);
        }
        // ... and, behind the plane, on an edge whose side face the camera sees.
        let on = |x: f64, h: f64, e: &Vector3<f64>| {
            x.abs() >= h - band && (e * x.signum()).dot(&p) < 0.0
        };
        if on(u, h1, &e1) {
            Some(if u < 0.0 { 0 } else { 1 })
        } else if on(v, h2, &e2) {
            Some(if v < 0.0 { 2 } else { 3 })
        } else {
            None
        }
    };
    let (w, h) = (g.w, g.h);
    let mut seen: rustc_hash::FxHashSet<u32> = cells.iter().copied().collect();
    let mut stack: Vec<u32> = cells.to_vec();
    let mut found: [Vec<u32>; 5] = Default::default();
    while let Some(i) = stack.pop() {
        let i = i as usize;
        let (u, v) = (i % w, i / w);
        let nb = [
            (u > 0).then(|| i - 1),
            (u + 1 < w).then(|| i + 1),
            (v > 0).then(|| i - w),
            (v + 1 < h).then(|| i + w),
        ];
        for j in nb.into_iter().flatten() {
            if seen.contains(&(j as u32)) {
                continue;
            }
            let (zi, zj) = (g.z[i], g.z[j]);
            if zi <= 0.0 || (zi - zj).abs() > super::grid::jump_tol(cfg, zi.min(zj)) {
                continue;
            }
            if let Some(s) = side_of(j) {
                seen.insert(j as u32);
                found[s].push(j as u32);
                stack.push(j as u32);
            }
        }
    }
    // A few cells behind an edge are a sliver, not a side face: the estimator would take
    // their width for the box's depth.
    let min = cfg.side_strip_min_cells as usize;
    let mut out = std::mem::take(&mut found[4]);
    for f in found.into_iter().take(4) {
        if f.len() >= min {
            out.extend(f);
        }
    }
    out
}

/// Cuboid fit and box-likeness of one group of faces; `None` when rejected.
fn score_group(
    g: &Grid,
    labels: &[u32],
    regions: &[Region],
    on_support: &[bool],
    cells: &[Vec<u32>],
    faces_of: &[Vec<usize>],
    cfg: &DetectConfig,
) -> Option<Raw> {
    let mem: Vec<usize> = faces_of.iter().flatten().copied().collect();
    let all: Vec<u32> = mem.iter().flat_map(|&f| cells[f].iter().copied()).collect();
    let joined: Vec<Vec<u32>>;
    let faces: Vec<&[u32]> = if faces_of.iter().all(|f| f.len() == 1) {
        mem.iter().map(|&f| cells[f].as_slice()).collect()
    } else {
        joined = faces_of
            .iter()
            .map(|f| f.iter().flat_map(|&r| cells[r].iter().copied()).collect())
            .collect();
        joined.iter().map(Vec::as_slice).collect()
    };
    // A face of several regions takes the normal of its largest.
    let normals: Vec<Vector3<f64>> = faces_of
        .iter()
        .filter_map(|f| f.iter().max_by_key(|&&r| regions[r].n))
        .map(|&r| regions[r].normal)
        .collect();
    // Plane fit.
    let fit = mem
        .iter()
        .map(|&f| regions[f].inlier_frac * regions[f].n as f64)
        .sum::<f64>()
        / mem.iter().map(|&f| regions[f].n as f64).sum::<f64>();
    let member = |i: usize| labels[i] != NONE && mem.contains(&(labels[i] as usize));
    // Unlabelled cells (edge bands, noise, holes) are unknown: neither for nor against;
    // support cells are background seen inside the silhouette: against.
    let unknown = |i: usize| labels[i] == NONE && !on_support[i];
    score_faces(g, all, &faces, &normals, fit, &member, &unknown, cfg)
}

/// The factor a candidate's score carries for showing `n_faces` faces
/// (`one_face_factor`, `two_face_factor`; 1 for three).
pub(crate) fn faces_factor(n_faces: usize, cfg: &DetectConfig) -> f64 {
    match n_faces {
        1 => cfg.one_face_factor,
        2 => cfg.two_face_factor,
        _ => 1.0,
    }
}

/// How much of a lone face lies in the corners of its fitted rectangle (`bx`, axis 0 the
/// normal): the fraction of its cells whose in-plane coordinates are both beyond
/// `CORNER` of the half-extents, over the fraction a uniformly covered rectangle puts there
/// ((1 − `CORNER`)²). About 1 for a rectangle, even one with holes; 0 for a disc, whose
/// rim passes inside the corner squares (at `CORNER` = 0.75, (0.75, 0.75) is 1.06 radii out).
fn corner_occupancy(g: &Grid, cells: &[u32], bx: &OrientedBox) -> f64 {
    let (a1, a2) = (bx.axis(1), bx.axis(2));
    let (h1, h2) = (bx.size_mm.y / 2.0, bx.size_mm.z / 2.0);
    if cells.is_empty() || h1 <= 0.0 || h2 <= 0.0 {
        return 0.0;
    }
    let c = bx.center_mm;
    corner_share(
        cells.len(),
        cells.iter().map(|&i| {
            let d = v3(&g.p[i as usize]) - c;
            (d.dot(&a1) / h1, d.dot(&a2) / h2)
        }),
    )
}

/// The share of `n` points whose offsets from a rectangle's middle, in half-extents
/// (`offsets`), are both beyond `CORNER`, over the share a uniformly covered rectangle puts
/// there ((1 − `CORNER`)²): [`corner_occupancy`] and [`face_corner_share`].
fn corner_share(n: usize, offsets: impl Iterator<Item = (f64, f64)>) -> f64 {
    const CORNER: f64 = 0.75;
    let k = offsets
        .filter(|(a, b)| a.abs() > CORNER && b.abs() > CORNER)
        .count();
    k as f64 / n as f64 / ((1.0 - CORNER) * (1.0 - CORNER))
}

/// [`corner_occupancy`] of one face of a group, in its own rectangle: along the in-plane
/// axes `e1` and `e2`, its cells' full extents (0.5 % quantiles, as a lone face's) and their
/// middle.
fn face_corner_share(g: &Grid, cells: &[u32], e1: &Vector3<f64>, e2: &Vector3<f64>) -> f64 {
    let t1: Vec<f64> = cells
        .iter()
        .map(|&i| v3(&g.p[i as usize]).dot(e1))
        .collect();
    let t2: Vec<f64> = cells
        .iter()
        .map(|&i| v3(&g.p[i as usize]).dot(e2))
        .collect();
    // The quantiles reorder their input: on copies.
    let (lo1, hi1) = robust_range(&mut t1.clone(), 0.005);
    let (lo2, hi2) = robust_range(&mut t2.clone(), 0.005);
    let (h1, h2) = ((hi1 - lo1) / 2.0, (hi2 - lo2) / 2.0);
    if cells.is_empty() || h1 <= 0.0 || h2 <= 0.0 {
        return 0.0;
    }
    let (c1, c2) = ((lo1 + hi1) / 2.0, (lo2 + hi2) / 2.0);
    corner_share(
        cells.len(),
        t1.iter()
            .zip(&t2)
            .map(|(a, b)| ((a - c1) / h1, (b - c2) / h2)),
    )
}

/// Figure or ground: of the valid cells in a ring `FRAME_RING` cells wide around a lone face,
/// the fraction whose surface lies in front of the face's plane (continued to them) by more
/// than twice the plane tolerance. A box's face stands in front of what surrounds it; a patch
/// of wall seen between shelf boards and uprights is framed by nearer things.
fn framed_fraction(g: &Grid, cells: &[u32], n: &Vector3<f64>, cfg: &DetectConfig) -> f64 {
    const FRAME_RING: usize = 3;
    let (w, h) = (g.w, g.h);
    if cells.is_empty() {
        return 0.0;
    }
    let d = median(cells.iter().map(|&i| v3(&g.p[i as usize]).dot(n)).collect());
    // Marks on the face's bounding box grown by the ring, not on the whole grid: this runs for
    // every lone face.
    let (mut u_lo, mut v_lo, mut u_hi, mut v_hi) = (usize::MAX, usize::MAX, 0, 0);
    for &c in cells {
        let (u, v) = (c as usize % w, c as usize / w);
        (u_lo, v_lo, u_hi, v_hi) = (u_lo.min(u), v_lo.min(v), u_hi.max(u), v_hi.max(v));
    }
    let (u_lo, v_lo) = (
        u_lo.saturating_sub(FRAME_RING),
        v_lo.saturating_sub(FRAME_RING),
    );
    let (u_hi, v_hi) = (
        (u_hi + FRAME_RING).min(w - 1),
        (v_hi + FRAME_RING).min(h - 1),
    );
    let bw = u_hi - u_lo + 1;
    let at = |u: usize, v: usize| (v - v_lo) * bw + (u - u_lo);
    let mut mark = vec![0u8; bw * (v_hi - v_lo + 1)];
    for &c in cells {
        mark[at(c as usize % w, c as usize / w)] = 1;
    }
    let (mut closer, mut valid) = (0usize, 0usize);
    for &c in cells {
        let (u0, v0) = (c as usize % w, c as usize / w);
        for v in v0.saturating_sub(FRAME_RING)..=(v0 + FRAME_RING).min(h - 1) {
            for u in u0.saturating_sub(FRAME_RING)..=(u0 + FRAME_RING).min(w - 1) {
                if mark[at(u, v)] != 0 {
                    continue;
                }
                mark[at(u, v)] = 2;
                let z = g.z[v * w + u] as f64;
                if z <= 0.0 {
                    continue;
                }
                let r = g.k.ray(u as f64, v as f64);
                let den = r.dot(n);
                if den.abs() < 1e-6 {
                    continue;
                }
                let z_plane = d / den;
                valid += 1;
                if z < z_plane - 2.0 * plane_tol(cfg, z) {
                    closer += 1;
                }
            }
        }
    }
    closer as f64 / valid.max(1) as f64
}

/// Cuboid fit and box-likeness of up to three faces (`faces[k]`: the cells of the face with
/// plane normal `normals[k]`, the largest first), given the plane `fit` (0..1) of their cells.
/// `member(i)`: cell `i` belongs to the candidate; `unknown(i)`: a non-member cell that counts
/// neither for nor against the silhouette. `None` when rejected.
#[allow(clippy::too_many_arguments)]
pub(crate) fn score_faces(
    g: &Grid,
    all: Vec<u32>,
    faces: &[&[u32]],
    normals: &[Vector3<f64>],
    fit: f64,
    member: &dyn Fn(usize) -> bool,
    unknown: &dyn Fn(usize) -> bool,
    cfg: &DetectConfig,
) -> Option<Raw> {
    if all.len() < cfg.min_face_cells as usize || faces.is_empty() || faces.len() > 3 {
        return None;
    }
    let n_faces = faces.len();
    let pts: Vec<Vector3<f64>> = all.iter().map(|&i| v3(&g.p[i as usize])).collect();
    // Axes from the face normals.
    let axes: [Vector3<f64>; 3] = match normals.len() {
        3 => {
            let m = Matrix3::from_columns(&[normals[0], normals[1], normals[2]]);
            let svd = m.svd(true, true);
            let (u, vt) = (svd.u?, svd.v_t?);
            let r = u * vt;
            [
                r.column(0).into_owned(),
                r.column(1).into_owned(),
                r.column(2).into_owned(),
            ]
        }
        2 => {
            let a = normals[0];
            let b = (normals[1] - a * a.dot(&normals[1])).try_normalize(1e-9)?;
            [a, b, a.cross(&b)]
        }
        _ => rectangle_axes(&normals[0], &pts, cfg.extent_quantile),
    };
    let mut size = Vector3::zeros();
    let mut centre = Vector3::zeros();
    let mut vals = Vec::with_capacity(pts.len());
    // A lone face is judged by how well a rectangle covers it: measure it out to its edges
    // (robust quantiles would cut a disc's rim and flatter it).
    let q = if n_faces == 1 {
        cfg.extent_quantile.min(0.005)
    } else {
        cfg.extent_quantile
    };
    for (k, ax) in axes.iter().enumerate() {
        let (lo, hi) = if n_faces > 1 && cfg.per_face_extents {
            // Union of each face's robust range: a narrow side face (a few per cent of the
            // points) still spans the box's depth, which quantiles over all points would cut.
            let mut r = (f64::INFINITY, f64::NEG_INFINITY);
            for face in faces {
                vals.clear();
                vals.extend(face.iter().map(|&i| v3(&g.p[i as usize]).dot(ax)));
                let (a, b) = robust_range(&mut vals, q);
                r = (r.0.min(a), r.1.max(b));
            }
            r
        } else {
            vals.clear();
            vals.extend(pts.iter().map(|p| p.dot(ax)));
            robust_range(&mut vals, q)
        };
        let (lo, hi) = if n_faces == 1 && k == 0 {
            // A single face: its thickness is unseen; the silhouette test uses the face itself.
            let mid = (lo + hi) / 2.0;
            (mid - 0.5, mid + 0.5)
        } else {
            (lo, hi)
        };
        size[k] = hi - lo;
        centre += ax * ((lo + hi) / 2.0);
    }
    // Observed dimensions: every axis for two or three faces, the two in-plane axes for one.
    let observed: Vec<f64> = if n_faces == 1 {
        vec![size[1], size[2]]
    } else {
        vec![size[0], size[1], size[2]]
    };
    let max_dim = observed.iter().cloned().fold(0.0, f64::max);
    let min_dim = observed.iter().cloned().fold(f64::INFINITY, f64::min);
    let dbg = log::log_enabled!(log::Level::Debug);
    if max_dim > cfg.max_box_extent_mm || min_dim < cfg.min_box_extent_mm {
        if dbg && all.len() > 300 {
            log::debug!(
                "group of {n_faces} n {} rejected size {max_dim:.0} {min_dim:.0}",
                all.len()
            );
        }
        return None;
    }
    // A group's largest face must look like a rectangle too: an upright tin's cap is a disc
    // beside a band of its mantle.
    let largest = (0..n_faces).max_by_key(|&k| faces[k].len())?;
    if n_faces > 1
        && cfg.face_min_corners > 0.0
        && faces[largest].len() >= cfg.face_corners_min_cells as usize
    {
        let k = largest;
        let occ = face_corner_share(g, faces[k], &axes[(k + 1) % 3], &axes[(k + 2) % 3]);
        if occ < cfg.face_min_corners {
            if dbg && all.len() > 300 {
                log::debug!(
                    "group of {n_faces} n {} rejected: largest face corners {occ:.2}",
                    all.len()
                );
            }
            return None;
        }
    }
    let mut rot = Matrix3::from_columns(&axes);
    if rot.determinant() < 0.0 {
        rot.set_column(2, &(-axes[2]));
    }
    let bx = OrientedBox {
        rotation: Rotation3::from_matrix_unchecked(rot),
        center_mm: centre,
        size_mm: size,
    };
    // Silhouette IoU and depth consistency inside the hull.
    let hull = silhouette_hull_px(&bx, &g.k)?;
    let (w, h) = (g.w, g.h);
    let mut inter = 0usize;
    let mut hull_n = 0usize;
    let mut see_through = 0usize;
    for i in hull_cells(&hull, w, h) {
        if member(i) {
            hull_n += 1;
            inter += 1;
            continue;
        }
        if unknown(i) {
            continue;
        }
        let z = g.z[i] as f64;
        let (u, v) = ((i % w) as f64, (i / w) as f64);
        let hit = (z > 0.0)
            .then(|| ray_box_intersection(&Point3::origin(), &g.k.ray(u, v), &bx))
            .flatten();
        if let Some((t, _, _)) = hit {
            let margin = cfg.see_through_margin_mm + 2.0 * plane_tol(cfg, z);
            // A nearer thing hides this part of the box: it says nothing of its shape.
            if cfg.occluders_unknown && z < t - margin {
                continue;
            }
            if z > t + margin {
                see_through += 1;
            }
        }
        hull_n += 1;
    }
    let union = hull_n + all.len() - inter;
    let iou = inter as f64 / union.max(1) as f64;
    let depth_ok = 1.0 - see_through as f64 / hull_n.max(1) as f64;
    let score = (fit * iou * depth_ok * faces_factor(n_faces, cfg)).clamp(0.0, 1.0);
    if dbg && n_faces == 1 && all.len() > 300 {
        log::debug!(
            "lone n {} iou {iou:.2} corners {:.2} framed {:.2} score {score:.2}",
            all.len(),
            corner_occupancy(g, faces[0], &bx),
            framed_fraction(g, &all, &normals[0], cfg)
        );
    }
    // A lone face must look like a rectangle: a disc (a cylinder's cap) covers π/4 of its box.
    if n_faces == 1 && iou < cfg.min_one_face_iou {
        return None;
    }
    // ... and fill its corners: a disc's rim passes inside them.
    if n_faces == 1 && corner_occupancy(g, faces[0], &bx) < cfg.min_one_face_corners {
        return None;
    }
    // A lone face framed by nearer surfaces is background seen through a gap (last: the ring
    // walk costs the most of the three).
    if n_faces == 1 && framed_fraction(g, &all, &normals[0], cfg) > cfg.max_framed_fraction {
        return None;
    }
    if dbg && all.len() > 300 {
        log::debug!(
            "group of {n_faces} n {} size {:.0} {:.0} {:.0} fit {fit:.2} iou {iou:.2} depth {depth_ok:.2} score {score:.2}",
            all.len(),
            size[0],
            size[1],
            size[2]
        );
    }
    if score < cfg.min_score {
        return None;
    }
    Some(Raw {
        cells: all,
        score,
        n_faces: n_faces as u8,
        bx,
        normal: normals[largest],
        lost_cut: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boundary_distance_matches_a_densely_sampled_outline() {
        // A convex pentagon, mm; the outline sampled every 0.01 mm is the brute-force answer.
        let poly = [
            Point2::new(0.0, 0.0),
            Point2::new(300.0, 0.0),
            Point2::new(380.0, 150.0),
            Point2::new(200.0, 260.0),
            Point2::new(-40.0, 120.0),
        ];
        let mut outline = Vec::new();
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            let steps = ((b - a).norm() / 0.01) as usize;
            outline.extend((0..=steps).map(|s| a + (b - a) * (s as f64 / steps as f64)));
        }
        for (x, y) in [
            (150.0, 100.0),
            (-100.0, -50.0),
            (400.0, 300.0),
            (299.0, 1.0),
            (0.0, 0.0),
        ] {
            let p = Point2::new(x, y);
            let brute = outline
                .iter()
                .map(|q| (q - p).norm())
                .fold(f64::INFINITY, f64::min);
            let d = boundary_distance(&poly, &p);
            assert!((d - brute).abs() < 0.02, "({x}, {y}): {d} against {brute}");
        }
    }

    proptest::proptest! {
        /// The bisection answers as the plain test over every edge (inside when no edge has
        /// the point strictly on its outer side), on hulls of random points in either
        /// orientation, at random points, the vertices and the edges' midpoints.
        #[test]
        fn inside_convex_matches_the_test_of_every_edge(
            pts in proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0), 3..40),
            queries in proptest::collection::vec((-60.0f64..60.0, -60.0f64..60.0), 1..40),
            reversed in proptest::bool::ANY,
        ) {
            let pts: Vec<Point2<f64>> = pts.iter().map(|&(x, y)| Point2::new(x, y)).collect();
            let mut hull = convex_hull_2d(&pts);
            if reversed {
                hull.reverse();
            }
            let every_edge = |p: &Point2<f64>| {
                let n = hull.len();
                let c: Vec<f64> = (0..n)
                    .map(|k| {
                        let (a, b) = (hull[k], hull[(k + 1) % n]);
                        (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)
                    })
                    .collect();
                n >= 3 && (c.iter().all(|&x| x >= 0.0) || c.iter().all(|&x| x <= 0.0))
            };
            let mut probes: Vec<Point2<f64>> =
                queries.iter().map(|&(x, y)| Point2::new(x, y)).collect();
            probes.extend(hull.iter().copied());
            for k in 0..hull.len() {
                let b = hull[(k + 1) % hull.len()];
                probes.push(Point2::from((hull[k].coords + b.coords) / 2.0));
            }
            for p in &probes {
                proptest::prop_assert_eq!(inside_convex(&hull, p), every_edge(p), "{:?}", p);
            }
        }
    }
}
