//! Object-level candidates: each connected object left after support removal (cells joined
//! by depth continuity and convex creases, cut at concave ones) is hypothesised to be one box.
//!
//! Face grouping ([`super::boxes::group_candidates`]) has to prove that two patches share a
//! convex edge, which fails on small, far or noisy boxes whose edge bands are wide; an isolated
//! box is, however, simply a connected convex object that a cuboid fits. Per object: the
//! dominant normal direction, the dominant one perpendicular to it and their cross product give
//! the axes; cells are assigned to the face whose normal they agree with; the cuboid and the
//! score are those of a face group ([`super::boxes::score_faces`]). An object whose face
//! direction holds two parallel planes (touching boxes of different heights joined through a
//! flush side) is cut along the axis that separates them, recursively; a step that parts
//! them by less than `blob_step_factor` but more than `blob_weak_step_factor` plane
//! tolerances cuts the object too, but leaves it scored whole beside its parts. A step
//! between two planes facing the support's up is also read as a box stacked on another (cut
//! across the up, just past the farther plane; `blob_stack_max_tilt_deg`): flush faces of
//! one colour look the same either way, so a sure step is cut the way whose parts are the
//! better boxes (`blob_stack_margin`), and the other reading's parts come back as
//! alternatives. Objects that
//! fit a cuboid badly (`blob_min_fit`, `blob_min_agree`) or whose faces bend (`max_bend_deg`:
//! a cylinder's side) are dropped, unless their plain colour changes across every face a cut
//! crosses, or failing that, their cells fall into two clusters of clearly different hue
//! (`blob_colour_cut_misfits`: two boxes of different colours touching, or turned to each
//! other, make one object that fits no cuboid); the parts are then tried again. One that passes
//! is still cut where its plain colour changes so (`blob_colour_cut_delta`: two boxes of
//! different colours stacked or end to end, sides flush). One that no cut parts but whose
//! cells fall into two clusters of clearly different hue, either side of a plane across a box
//! axis, is scored whole and also cut there (`blob_fit_colour_split_min_chroma`: a box
//! standing on a carton of another colour); the whole and the parts compete in `select`.
//! One that fits and that neither a step nor colour cuts is still cut where its
//! cross-section steps along a box axis (`blob_profile_cut_min_mm`: two boxes of one colour
//! side by side, end to end or stacked, their faces flush), when the parts, as boxes, fit
//! better than the whole and no nearer thing explains the step; the whole competes too.
//! Where the whole wins, its parts still come back as alternative readings
//! (`blob_profile_cut_alternatives`).
//! Flush cartons of one colour that fit one cuboid are split in `select` by their seams, as
//! surfaces are. A small box's faces bend a little past `max_bend_deg` (its edges' smoothed
//! normals cover much of each face): an object of three faces that bends no more than
//! `blob_three_face_max_bend_deg`, and that no colour cut or split parts, is still scored, and
//! kept when it scores at least `blob_three_face_min_score`. An object of which nothing came
//! is read once more as a box standing on the support (`blob_upright_fallback`): one axis along
//! the support's up, its cells on the nearest face plane, scored as a last resort.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::boxes::{faces_factor, rectangle_axes, robust_range, score_faces, v3, Raw};
use super::grid::Grid;
use super::regions::{plane_tol, NONE};
use super::DetectConfig;

/// The direction (unit, facing the camera) most cell normals agree with within `cos_tol`,
/// among `cands` of them; returns it (refined as the mean of its inliers) and the inlier count.
fn dominant(
    normals: &[Vector3<f64>],
    cands: &[usize],
    cos_tol: f64,
) -> Option<(Vector3<f64>, usize)> {
    // Coordinates apart, so that the counts below run several normals at a time (the same
    // products and sums as `Vector3::dot`, in its order).
    let xs: Vec<f64> = normals.iter().map(|m| m.x).collect();
    let ys: Vec<f64> = normals.iter().map(|m| m.y).collect();
    let zs: Vec<f64> = normals.iter().map(|m| m.z).collect();
    let mut best: Option<(usize, usize)> = None;
    for &c in cands {
        let d = normals[c];
        let n = xs
            .iter()
            .zip(&ys)
            .zip(&zs)
            .filter(|((x, y), z)| *x * d.x + *y * d.y + *z * d.z >= cos_tol)
            .count();
        if best.is_none_or(|b| n > b.1) {
            best = Some((c, n));
        }
    }
    let (c, n) = best?;
    let d = normals[c];
    let mean: Vector3<f64> = normals.iter().filter(|m| m.dot(&d) >= cos_tol).sum();
    Some((mean.try_normalize(1e-9)?, n))
}

/// Candidates of evenly spread indices (at most `k`) of the items passing `keep`.
fn spread(n: usize, k: usize, keep: impl Fn(usize) -> bool) -> Vec<usize> {
    let idx: Vec<usize> = (0..n).filter(|&i| keep(i)).collect();
    let stride = idx.len().div_ceil(k.max(1)).max(1);
    idx.into_iter().step_by(stride).collect()
}

/// An object's box frame: axes (the dominant face normal first, each facing the camera), the
/// cells assigned to each axis's face, and how well the cells fit those face planes.
struct Frame {
    axes: Vec<Vector3<f64>>,
    faces: Vec<Vec<u32>>,
    /// Fraction of the cells within the plane tolerance of a face plane.
    fit: f64,
    /// Fraction of the cells with a normal whose normal agrees with a face.
    agree: f64,
    /// All three box axes: `axes` completed by the unseen ones (for a lone face, the in-plane
    /// axes of the smallest rectangle around its cells).
    full: [Vector3<f64>; 3],
    /// The largest bend of a face: the angle between the mean normals of its two halves,
    /// split at the median along either in-plane axis, degrees (a cylinder's side bends, a
    /// box face does not).
    bend_deg: f64,
}

fn frame_of(g: &Grid, cells: &[u32], cfg: &DetectConfig) -> Option<Frame> {
    let cos_tol = cfg.blob_normal_tol_deg.to_radians().cos();
    let sin_perp = cfg.perpendicular_tol_deg.to_radians().sin();
    let valid: Vec<u32> = cells
        .iter()
        .copied()
        .filter(|&i| {
            let n = g.n[i as usize];
            n[0] * n[0] + n[1] * n[1] + n[2] * n[2] > 0.5
        })
        .collect();
    let normals: Vec<Vector3<f64>> = valid.iter().map(|&i| v3(&g.n[i as usize])).collect();
    let min_face = (cfg.min_face_cells as usize)
        .max((cfg.blob_min_face_fraction * cells.len() as f64) as usize);
    let cands = spread(normals.len(), 48, |_| true);
    let (a, na) = dominant(&normals, &cands, cos_tol)?;
    if na < min_face {
        return None;
    }
    let perp = spread(normals.len(), 48, |k| normals[k].dot(&a).abs() <= sin_perp);
    let mut axes = vec![a];
    if let Some((b0, nb)) = dominant(&normals, &perp, cos_tol) {
        if nb >= min_face {
            if let Some(bn) = (b0 - a * a.dot(&b0)).try_normalize(1e-9) {
                axes.push(bn);
                // The third face, if seen: the cross product, turned towards the camera.
                let c = a.cross(&bn);
                let nc = normals
                    .iter()
                    .filter(|m| m.dot(&c).abs() >= cos_tol)
                    .count();
                if nc >= min_face {
                    let toward: f64 = normals.iter().map(|m| m.dot(&c)).sum();
                    axes.push(if toward >= 0.0 { c } else { -c });
                }
            }
        }
    }
    // Assign cells to faces by normal.
    let mut faces: Vec<Vec<u32>> = vec![Vec::new(); axes.len()];
    for (k, m) in normals.iter().enumerate() {
        let best = axes
            .iter()
            .enumerate()
            .map(|(f, ax)| (f, m.dot(ax)))
            .max_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((f, d)) = best {
            if d >= cos_tol {
                faces[f].push(valid[k]);
            }
        }
    }
    // Plane fit: cells within the plane tolerance of their nearest face plane (each face
    // plane at the median offset of its cells).
    let offsets: Vec<f64> = faces
        .iter()
        .zip(&axes)
        .map(|(f, ax)| {
            let mut d: Vec<f64> = f.iter().map(|&i| v3(&g.p[i as usize]).dot(ax)).collect();
            if d.is_empty() {
                return 0.0;
            }
            let mid = d.len() / 2;
            *d.select_nth_unstable_by(mid, |x, y| x.total_cmp(y)).1
        })
        .collect();
    let on_plane = cells
        .iter()
        .filter(|&&i| {
            let p = v3(&g.p[i as usize]);
            let tol = plane_tol(cfg, g.z[i as usize] as f64);
            axes.iter()
                .zip(&offsets)
                .any(|(ax, &o)| (p.dot(ax) - o).abs() <= tol)
        })
        .count();
    let assigned: usize = faces.iter().map(Vec::len).sum();
    let full: [Vector3<f64>; 3] = match axes.len() {
        1 => {
            let pts: Vec<Vector3<f64>> = cells.iter().map(|&i| v3(&g.p[i as usize])).collect();
            rectangle_axes(&a, &pts, cfg.extent_quantile)
        }
        _ => [axes[0], axes[1], axes[0].cross(&axes[1])],
    };
    let mut bend_deg = 0.0f64;
    for (f, face) in faces.iter().enumerate() {
        if face.len() < 2 * cfg.min_face_cells as usize {
            continue;
        }
        for (k, e) in full.iter().enumerate() {
            if k == f || e.dot(&axes[f]).abs() > 0.5 {
                continue;
            }
            let mut t: Vec<(f64, u32)> = face
                .iter()
                .map(|&i| (v3(&g.p[i as usize]).dot(e), i))
                .collect();
            let mid = t.len() / 2;
            t.select_nth_unstable_by(mid, |x, y| x.0.total_cmp(&y.0));
            let mean = |cells: &[(f64, u32)]| -> Vector3<f64> {
                cells.iter().map(|c| v3(&g.n[c.1 as usize])).sum()
            };
            let (m0, m1) = (mean(&t[..mid]), mean(&t[mid..]));
            if let (Some(m0), Some(m1)) = (m0.try_normalize(1e-9), m1.try_normalize(1e-9)) {
                bend_deg = bend_deg.max(m0.dot(&m1).clamp(-1.0, 1.0).acos().to_degrees());
            }
        }
    }
    Some(Frame {
        axes,
        faces,
        fit: on_plane as f64 / cells.len().max(1) as f64,
        agree: assigned as f64 / valid.len().max(1) as f64,
        bend_deg,
        full,
    })
}

/// A step found by [`find_step`].
#[derive(Clone, Copy)]
struct Step {
    /// The cut {p·e = s0} between the two planes' cells, `(e, s0)`.
    cut: (Vector3<f64>, f64),
    /// The planes part by `blob_step_factor` plane tolerances, not only
    /// `blob_weak_step_factor`.
    sure: bool,
    /// The other reading of the step: the cut {p·a = s0} along the two planes' own normal
    /// `a` (facing the camera), just past the farther plane, which parts what stands out of
    /// it from the rest (a box stacked on another when `a` is the support's up).
    stack: (Vector3<f64>, f64),
}

/// A step between two parallel planes of one face direction (the tops of two touching boxes
/// of different heights, the fronts of two cartons set back from each other): the object is
/// several boxes. Returns the cut {p·e = s0} along another box axis that separates the two
/// planes' cells (the riser between them), if one does; a sure step before a weak one, then
/// the wider separation.
fn find_step(g: &Grid, fr: &Frame, cfg: &DetectConfig) -> Option<Step> {
    if cfg.blob_step_factor <= 0.0 {
        return None;
    }
    let min_cells = cfg.min_face_cells as usize;
    // The best step and its separation.
    let mut best: Option<(Step, f64)> = None;
    for (k, face) in fr.faces.iter().enumerate() {
        if face.len() < 2 * min_cells {
            continue;
        }
        let ax = &fr.axes[k];
        let mut t: Vec<(f64, u32)> = face
            .iter()
            .map(|&i| (v3(&g.p[i as usize]).dot(ax), i))
            .collect();
        // The face's cells ascend, so ties by cell give a stable sort's order, unstably.
        t.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let zmed = g.z[t[t.len() / 2].1 as usize] as f64;
        let tol = plane_tol(cfg, zmed);
        let gap_tol = cfg.blob_step_factor * tol;
        let weak_tol = if cfg.blob_weak_step_factor > 0.0 {
            gap_tol.min(cfg.blob_weak_step_factor * tol)
        } else {
            gap_tol
        };
        // The widest gap with enough cells on both sides (each plane a real face, not a
        // few stray cells from a neighbouring face's rim).
        let side = min_cells.max((cfg.blob_step_min_fraction * t.len() as f64) as usize);
        if t.len() < 2 * side {
            continue;
        }
        let mut split: Option<(usize, f64)> = None;
        for x in side..=(t.len() - side) {
            let gap = t[x].0 - t[x - 1].0;
            if gap > weak_tol && split.is_none_or(|s| gap > s.1) {
                split = Some((x, gap));
            }
        }
        if log::log_enabled!(log::Level::Debug) && t.len() > 500 {
            log::debug!(
                "  step? face {k} n {} side {side} gap_tol {gap_tol:.0} range {:.0}..{:.0} split {:?}",
                t.len(),
                t[0].0,
                t[t.len() - 1].0,
                split.map(|s| (t[s.0 - 1].0, t[s.0].0))
            );
        }
        let Some((x, gap)) = split else {
            continue;
        };
        let sure = gap > gap_tol;
        let (lo_cells, hi_cells) = (&t[..x], &t[x..]);
        // Every box axis, the unseen third one too (the riser between two tops is often
        // hidden); a lone face's in-plane axes are guesses and are not used.
        let axes: &[Vector3<f64>] = if fr.axes.len() >= 2 {
            &fr.full
        } else {
            &fr.axes
        };
        for (j, e) in axes.iter().enumerate() {
            if j == k {
                continue;
            }
            let range = |cells: &[(f64, u32)]| {
                let mut u: Vec<f64> = cells
                    .iter()
                    .map(|c| v3(&g.p[c.1 as usize]).dot(e))
                    .collect();
                robust_range(&mut u, 0.02)
            };
            let (a0, a1) = range(lo_cells);
            let (b0, b1) = range(hi_cells);
            // Separation (positive: disjoint along e) and where to cut.
            let (sep, s0) = if a1 < b0 + gap_tol {
                (b0 - a1, (a1 + b0) / 2.0)
            } else if b1 < a0 + gap_tol {
                (a0 - b1, (b1 + a0) / 2.0)
            } else {
                continue;
            };
            if best.is_none_or(|(b, bsep)| (sure, sep) > (b.sure, bsep)) {
                let cut = (*e, s0);
                let stack = (
                    *ax,
                    t[x - 1].0 + (cfg.blob_stack_cut_tols * tol).min(gap / 2.0),
                );
                best = Some((Step { cut, sure, stack }, sep));
            }
        }
    }
    best.map(|(step, _)| step)
}

/// A step in the object's cross-section along one box axis `e` (two boxes of one colour
/// stacked, or side by side or end to end, with faces flush or too little set back for
/// [`find_step`]): slabs across `e` are a box's full width along each other axis, so the
/// near or far edge of the cells along another axis stays put along `e` on one box but moves
/// by the difference of the boxes' extents where one box ends and the other begins. Returns
/// the cut {p·e = s0} at such a move of more than `blob_profile_cut_min_mm` (and three grid
/// cells), with both sides at least `blob_profile_cut_min_part_mm` long and each side's edge
/// steady within a third of the move, that crosses fewest of the object's faces, then moves
/// most; unless the cells the wider side would have had past the narrower one's edge, moved
/// along `e`, are hidden by something nearer (a box occluded in part is not two boxes).
fn find_profile_cut(
    g: &Grid,
    fr: &Frame,
    blob: &[u32],
    cfg: &DetectConfig,
) -> Option<(Vector3<f64>, f64)> {
    let min_move = cfg.blob_profile_cut_min_mm;
    if min_move <= 0.0 || blob.len() < 4 * cfg.min_face_cells as usize {
        return None;
    }
    let pts: Vec<Vector3<f64>> = blob
        .iter()
        .map(|&i| i as usize)
        .filter(|&i| g.z[i] > 0.0)
        .map(|i| v3(&g.p[i]))
        .collect();
    let mut zs: Vec<f64> = pts.iter().map(|p| p.z).collect();
    let mid = zs.len() / 2;
    let zmed = *zs.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    // Edges are found to about a cell: three cells' width at the median depth at least.
    let cell_mm = zmed / g.k.fx.max(1.0);
    let min_move = min_move.max(3.0 * cell_mm);
    let min_part = cfg.blob_profile_cut_min_part_mm;
    // A lone face's in-plane axes are guesses: cut only along them, never across the face.
    let cut_axes: Vec<usize> = if fr.axes.len() >= 2 {
        (0..3).collect()
    } else {
        (1..3).collect()
    };
    // Faces (of at least a few cells) that a cut {p·e = s0} crosses: with cells on both
    // sides beyond a tenth of the face.
    let crossed = |e: &Vector3<f64>, s0: f64| -> usize {
        fr.faces
            .iter()
            .filter(|f| f.len() >= cfg.min_face_cells as usize)
            .filter(|f| {
                let lo = f
                    .iter()
                    .filter(|&&i| v3(&g.p[i as usize]).dot(e) < s0)
                    .count();
                let min = f.len() / 10;
                lo > min && f.len() - lo > min
            })
            .count()
    };
    // (faces crossed, move, cut along e at s0): two boxes side by side with flush faces
    // make an L whose both cuts leave two cuboids; the one between the boxes crosses only
    // the faces they share (their coplanar tops), the other one a box's side face as well.
    let mut best: Option<(usize, f64, Vector3<f64>, f64, f64)> = None;
    for &k in &cut_axes {
        let e = fr.full[k];
        let mut t: Vec<f64> = pts.iter().map(|p| p.dot(&e)).collect();
        let (t0, t1) = robust_range(&mut t, 0.01);
        let len = t1 - t0;
        if len < 2.0 * min_part {
            continue;
        }
        const BINS: usize = 24;
        let bw = len / BINS as f64;
        let bin_of = |p: &Vector3<f64>| {
            let b = ((p.dot(&e) - t0) / bw).floor();
            (b >= 0.0 && b < BINS as f64).then_some(b as usize)
        };
        for j in (0..3).filter(|&j| j != k) {
            let f = fr.full[j];
            let mut by_bin: Vec<Vec<f64>> = vec![Vec::new(); BINS];
            for p in &pts {
                if let Some(b) = bin_of(p) {
                    by_bin[b].push(p.dot(&f));
                }
            }
            // Per bin, the low and high edges along f (robust to a stray cell or two).
            let edges: Vec<Option<(f64, f64)>> = by_bin
                .iter_mut()
                .map(|v| (v.len() >= 8).then(|| robust_range(v, 0.03)))
                .collect();
            for side in 0..2 {
                let edge = |b: usize| edges[b].map(|(lo, hi)| if side == 0 { lo } else { hi });
                // Cut between bins c − 1 and c.
                let min_bins = ((min_part / bw).ceil() as usize).max(3);
                for c in min_bins..=(BINS - min_bins) {
                    let left: Vec<f64> = (0..c).filter_map(edge).collect();
                    let right: Vec<f64> = (c..BINS).filter_map(edge).collect();
                    if left.len() < 3 || right.len() < 3 {
                        continue;
                    }
                    let (ml, sl) = median_spread(left);
                    let (mr, sr) = median_spread(right);
                    let mv = (ml - mr).abs();
                    // The edge right at the cut must have moved too (not a slow drift).
                    let (Some(a), Some(b)) = (edge(c - 1), edge(c)) else {
                        continue;
                    };
                    if mv <= min_move || sl.max(sr) > mv / 3.0 || (a - b).abs() < mv / 2.0 {
                        continue;
                    }
                    let s0 = t0 + c as f64 * bw;
                    let nc = crossed(&e, s0);
                    if best.is_some_and(|(bn, bm, _, _, _)| (bn, -bm) <= (nc, -mv)) {
                        continue;
                    }
                    // The narrower side: its edge is inside the wider one's.
                    let wide_left = if side == 0 { ml < mr } else { ml > mr };
                    if hidden_past_edge(g, &pts, &e, s0, &f, (ml, mr), wide_left, bw, cfg) {
                        continue;
                    }
                    best = Some((nc, mv, e, s0, 2.0 * bw));
                }
            }
        }
    }
    // The cut ranked first, not the best one clear of occluders: the outline there steps
    // where something lies across the object, and a cut elsewhere would part one box.
    best.filter(|&(_, _, e, s0, reach)| !occluder_at_cut(g, blob, &e, s0, reach, cfg))
        .map(|(_, _, e, s0, _)| (e, s0))
}

/// Whether something nearer than the object borders it along the cut {p·e = s0}: at least
/// `blob_profile_cut_occluder_share` (and 3) of its cells within `reach_mm` of the cut lie
/// next to (within two cells of) a cell of no part of it whose depth is nearer by more than
/// the jump tolerance. A box lying across another cuts its outline where it crosses it;
/// flush boxes' outlines step against what lies behind them.
fn occluder_at_cut(
    g: &Grid,
    blob: &[u32],
    e: &Vector3<f64>,
    s0: f64,
    reach_mm: f64,
    cfg: &DetectConfig,
) -> bool {
    let share = cfg.blob_profile_cut_occluder_share;
    if share <= 0.0 {
        return false;
    }
    let mut members = blob.to_vec();
    members.sort_unstable();
    let of_blob = |j: usize| members.binary_search(&(j as u32)).is_ok();
    let (w, h) = (g.w as isize, g.h as isize);
    let (mut n, mut bordered) = (0usize, 0usize);
    for &c in blob {
        let i = c as usize;
        let z = g.z[i];
        if z <= 0.0 || (v3(&g.p[i]).dot(e) - s0).abs() > reach_mm {
            continue;
        }
        n += 1;
        let tol = super::grid::jump_tol(cfg, z);
        let (u, v) = ((i % g.w) as isize, (i / g.w) as isize);
        let near = (-2..=2isize).any(|dv| {
            (-2..=2isize).any(|du| {
                let (uu, vv) = (u + du, v + dv);
                if uu < 0 || vv < 0 || uu >= w || vv >= h {
                    return false;
                }
                let j = (vv * w + uu) as usize;
                g.z[j] > 0.0 && g.z[j] < z - tol && !of_blob(j)
            })
        });
        bordered += near as usize;
    }
    bordered >= 3 && bordered as f64 >= share * n as f64
}

/// Median of `v` and its spread (1.4826 × median absolute deviation).
fn median_spread(v: Vec<f64>) -> (f64, f64) {
    let m = crate::observation::median(v.clone());
    let d = v.into_iter().map(|x| (x - m).abs()).collect();
    (m, 1.4826 * crate::observation::median(d))
}

/// Whether what the wider side of a profile cut would have shown past the narrower side's edge
/// is hidden by something nearer: the wider side's cells beyond the narrower edge (edges at
/// `ml` left, `mr` right of the cut s0 along `f`), moved along `e` into the narrower side by
/// two bins, land mostly behind nearer depth.
#[allow(clippy::too_many_arguments)]
fn hidden_past_edge(
    g: &Grid,
    pts: &[Vector3<f64>],
    e: &Vector3<f64>,
    s0: f64,
    f: &Vector3<f64>,
    (ml, mr): (f64, f64),
    wide_left: bool,
    bw: f64,
    cfg: &DetectConfig,
) -> bool {
    let (m_wide, m_narrow) = if wide_left { (ml, mr) } else { (mr, ml) };
    let beyond = |x: f64| {
        if m_wide > m_narrow {
            x > m_narrow
        } else {
            x < m_narrow
        }
    };
    let shift = if wide_left { 2.0 * bw } else { -2.0 * bw };
    let (mut n, mut hidden) = (0usize, 0usize);
    for p in pts {
        let t = p.dot(e) - s0;
        let near_cut = if wide_left {
            (-2.0 * bw..0.0).contains(&t)
        } else {
            (0.0..2.0 * bw).contains(&t)
        };
        if !near_cut || !beyond(p.dot(f)) {
            continue;
        }
        let q = p + e * shift;
        let Some(i) = g.cell_at(&q) else {
            continue;
        };
        let zi = g.z[i] as f64;
        n += 1;
        // Nearer than the face's plane tolerance: a box standing on the face hides it from
        // its foot upwards, within a jump tolerance of the face at first.
        if zi > 0.0 && zi < q.z - plane_tol(cfg, q.z) {
            hidden += 1;
        }
    }
    n > 0 && 2 * hidden >= n
}

/// A colour change across the object (two boxes of different colours stacked or end to end,
/// their sides flush, so that no step or crease parts them): the cut {p·e = s0} along a box
/// axis, at a quantile of the object's cells between `blob_colour_cut_min_fraction` and its
/// complement, where every face with cells on both sides changes colour by at least
/// `blob_colour_cut_delta` (the norm of the RGB difference over the sides' mean norm), and
/// there are two such faces at least. A side's colour is the channel-wise median of the mean
/// colours of eight equal runs of its cells along `e`, so that tape, labels and print
/// covering under half of a side do not count; its spread, the median distance of the runs
/// from that colour over its norm, must stay within `blob_colour_cut_max_spread` on both
/// sides of every face (plain colours, not printed graphics). The largest change wins.
fn find_colour_cut(
    g: &Grid,
    fr: &Frame,
    blob: &[u32],
    cfg: &DetectConfig,
) -> Option<(Vector3<f64>, f64)> {
    const RUNS: usize = 8;
    const MIN_SIDE: usize = 16;
    let delta = cfg.blob_colour_cut_delta;
    let frac = cfg.blob_colour_cut_min_fraction;
    if delta <= 0.0 || blob.len() < 2 * MIN_SIDE || !(0.0..0.5).contains(&frac) {
        return None;
    }
    // A box boundary must cross two faces: a one-face object has nothing to show.
    if fr.faces.iter().filter(|f| f.len() >= 2 * MIN_SIDE).count() < 2 {
        return None;
    }
    // Colour of the cells a..b of a face (sorted along the axis; `sum` its colour prefix
    // sums) and its spread.
    let side_colour = |sum: &[Vector3<f64>], a: usize, b: usize| -> (Vector3<f64>, f64) {
        let n = b - a;
        let means: Vec<Vector3<f64>> = (0..RUNS)
            .map(|r| {
                let (s, e) = (a + r * n / RUNS, a + (r + 1) * n / RUNS);
                (sum[e] - sum[s]) / (e - s).max(1) as f64
            })
            .collect();
        let mut out = Vector3::zeros();
        for ch in 0..3 {
            let mut c: Vec<f64> = means.iter().map(|m| m[ch]).collect();
            c.sort_by(f64::total_cmp);
            out[ch] = (c[RUNS / 2 - 1] + c[RUNS / 2]) / 2.0;
        }
        // Spread: the median distance of the runs from that colour, relative to it.
        let mut dev: Vec<f64> = means.iter().map(|m| (m - out).norm()).collect();
        dev.sort_by(f64::total_cmp);
        let spread = (dev[RUNS / 2 - 1] + dev[RUNS / 2]) / 2.0 / out.norm().max(1.0);
        (out, spread)
    };
    // The face of each of the object's cells (`u8::MAX`: none, or a face too small to count).
    // Faces are subsequences of the object's (ascending) cells, so a merge finds them.
    let big: Vec<&Vec<u32>> = fr
        .faces
        .iter()
        .filter(|f| f.len() >= 2 * MIN_SIDE)
        .collect();
    debug_assert!(blob.windows(2).all(|w| w[0] < w[1]), "object cells ascend");
    let mut face_of = vec![u8::MAX; blob.len()];
    for (f, cells) in big.iter().enumerate() {
        let mut k = 0;
        for c in cells.iter() {
            while k < blob.len() && blob[k] < *c {
                k += 1;
            }
            if k < blob.len() && blob[k] == *c {
                face_of[k] = f as u8;
            }
        }
    }
    let mut best: Option<(f64, Vector3<f64>, f64)> = None;
    for e in &fr.full {
        // One sort of the object's cells along e, ties by cell: each face's cells in that
        // order are its own sort (faces of other orientations shade differently, so each
        // gets its positions and colour prefix sums).
        let mut t: Vec<(f64, u32, u8)> = blob
            .iter()
            .zip(&face_of)
            .map(|(&i, &f)| (v3(&g.p[i as usize]).dot(e), i, f))
            .collect();
        t.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let all: Vec<f64> = t.iter().map(|c| c.0).collect();
        let mut faces: Vec<(Vec<f64>, Vec<Vector3<f64>>)> = big
            .iter()
            .map(|f| {
                let mut sum = Vec::with_capacity(f.len() + 1);
                sum.push(Vector3::zeros());
                (Vec::with_capacity(f.len()), sum)
            })
            .collect();
        for &(x, i, f) in &t {
            if let Some((pos, sum)) = faces.get_mut(f as usize) {
                pos.push(x);
                let last = sum[sum.len() - 1];
                sum.push(last + v3(&g.c[i as usize]));
            }
        }
        let steps = 20;
        for q in 0..=steps {
            let q = frac + (1.0 - 2.0 * frac) * q as f64 / steps as f64;
            let x = ((q * all.len() as f64) as usize).clamp(1, all.len() - 1);
            let s0 = (all[x - 1] + all[x]) / 2.0;
            let (mut weakest, mut crossed): (Option<f64>, usize) = (None, 0);
            for (t, sum) in &faces {
                let k = t.partition_point(|&c| c < s0);
                if k < MIN_SIDE || t.len() - k < MIN_SIDE {
                    continue;
                }
                let ((lo, slo), (hi, shi)) = (side_colour(sum, 0, k), side_colour(sum, k, t.len()));
                // Relative to the sides' brightness: a shaded face shows the same change in
                // fewer levels.
                let d = (lo - hi).norm() / ((lo.norm() + hi.norm()) / 2.0).max(1.0);
                // A printed side (graphics, not a plain box of another colour) is no evidence.
                let d = if slo.max(shi) <= cfg.blob_colour_cut_max_spread {
                    d
                } else {
                    0.0
                };
                weakest = Some(weakest.map_or(d, |w: f64| w.min(d)));
                crossed += 1;
            }
            // Two faces at least: a box's boundary crosses all its faces that run along e,
            // while a band of colour on one face (tape along an edge) crosses only that one.
            if let Some(d) = weakest.filter(|&d| d >= delta && crossed >= 2) {
                if best.is_none_or(|b| d > b.0) {
                    best = Some((d, *e, s0));
                }
            }
        }
    }
    best.map(|(_, e, s0)| (e, s0))
}

/// Scored candidates of the connected objects (`labels`: object index per cell, [`NONE`] for
/// support and unlabelled cells), each object cut recursively at steps between touching
/// boxes. Objects (or parts) with a plane fit below `blob_min_fit` are dropped.
pub(crate) fn blob_candidates(
    g: &Grid,
    labels: &[u32],
    n_blobs: usize,
    off: &[bool],
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> Vec<Raw> {
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); n_blobs];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE {
            cells[l as usize].push(i as u32);
        }
    }
    // Objects are independent (cutting one relabels only its own cells): in parallel. The
    // candidates come in the order of a sequential last-object-first walk, so that equal
    // scores keep their order whatever the thread count.
    let per_object: Vec<Vec<Raw>> = cells
        .into_par_iter()
        .enumerate()
        .map(|(b, c)| object_candidates(g, labels, b as u32, c, off, up, cfg))
        .collect();
    let mut out: Vec<Raw> = per_object.into_iter().rev().flatten().collect();
    out.sort_by(|a, b| b.score.total_cmp(&a.score));
    out
}

/// `cells` (ascending) scored as one box, uncut: non-member cells labelled [`NONE`] and not
/// `off` count neither for nor against the silhouette.
pub(crate) fn score_whole(
    g: &Grid,
    cells: &[u32],
    labels: &[u32],
    off: &[bool],
    cfg: &DetectConfig,
) -> Option<Raw> {
    if cells.len() < cfg.min_face_cells as usize {
        return None;
    }
    let fr = frame_of(g, cells, cfg)?;
    score_in_frame(g, cells, &fr, labels, off, cfg)
}

/// `part` (ascending cells) scored as one box with the faces and axes of `fr`: its own cells
/// are members, cells labelled [`NONE`] and not `off` are unknown, and any other cell is
/// judged by depth like any other.
fn score_in_frame(
    g: &Grid,
    part: &[u32],
    fr: &Frame,
    labels: &[u32],
    off: &[bool],
    cfg: &DetectConfig,
) -> Option<Raw> {
    let face_refs: Vec<&[u32]> = fr.faces.iter().map(Vec::as_slice).collect();
    let member = |i: usize| part.binary_search(&(i as u32)).is_ok();
    let unknown = |i: usize| labels[i] == NONE && !off[i];
    score_faces(
        g,
        part.to_vec(),
        &face_refs,
        &fr.axes,
        fr.fit,
        &member,
        &unknown,
        cfg,
    )
}

/// The candidates of one object (label `b`, its `cells` ascending), cut recursively (depth
/// first, the far side of a cut first).
fn object_candidates(
    g: &Grid,
    labels: &[u32],
    b: u32,
    cells: Vec<u32>,
    off: &[bool],
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> Vec<Raw> {
    let dbg = log::log_enabled!(log::Level::Debug);
    // Kept for the upright reading below, only where it may be needed.
    let whole = (cfg.blob_upright_fallback
        && up.is_some()
        && cells.len() <= cfg.blob_upright_max_cells as usize)
        .then(|| cells.clone());
    // Parts are numbered for the log only: every part's cells stay ascending (cuts keep
    // order), and membership is a binary search.
    let mut next = 1u32;
    // A part scored as one box: the object's other cells are judged by depth.
    let score_in = |part: &[u32], fr: &Frame, cfg: &DetectConfig| {
        score_in_frame(g, part, fr, labels, off, cfg)
    };
    let score_part = |part: &[u32], fr: &Frame| score_in(part, fr, cfg);
    // A part of a step's cut scored as a box in its own frame; a sliver past the plane (the
    // riser's noisy foot) is no box: `score_whole` asks for `min_face_cells`.
    let reading_part = |p: &[u32]| score_whole(g, p, labels, off, cfg);
    // Shape alone (plane fit × silhouette IoU × depth consistency): a part may show fewer
    // faces than the whole, which says nothing of the cut.
    let shape = |r: &Raw| {
        let f = faces_factor(r.n_faces as usize, cfg);
        if f > 0.0 {
            r.score / f
        } else {
            0.0
        }
    };
    // The shape of a cut's two parts, weighted by cells; a part that is no box counts as 0.
    let cut_shape = |(lo, hi): (&[u32], &[u32]), (ra, rb): (&Option<Raw>, &Option<Raw>)| {
        (ra.as_ref().map_or(0.0, shape) * lo.len() as f64
            + rb.as_ref().map_or(0.0, shape) * hi.len() as f64)
            / (lo.len() + hi.len()).max(1) as f64
    };
    // Parts of a cut not made, kept as alternative readings.
    let lost = |parts: [Option<Raw>; 2]| {
        parts.into_iter().flatten().map(|r| Raw {
            lost_cut: true,
            ..r
        })
    };
    // (part, cells, cuts so far)
    let mut work: Vec<(u32, Vec<u32>, u32)> = vec![(0, cells, 0)];
    let mut out = Vec::new();
    while let Some((pi, blob, depth)) = work.pop() {
        if blob.len() < cfg.min_face_cells as usize {
            continue;
        }
        let Some(fr) = frame_of(g, &blob, cfg) else {
            continue;
        };
        let step = if depth < cfg.blob_max_cuts {
            find_step(g, &fr, cfg)
        } else {
            None
        };
        // The object's cells either side of the plane {p·e = s0}, logged.
        let by_plane = |(e, s0): (Vector3<f64>, f64), why: &str| {
            let (lo, hi): (Vec<u32>, Vec<u32>) = blob
                .iter()
                .partition(|&&i| v3(&g.p[i as usize]).dot(&e) < s0);
            if dbg && blob.len() > 200 {
                log::debug!(
                    "blob {b}.{pi} n {} {why} cut at {s0:.0} along {:.2} {:.2} {:.2}: {} + {}",
                    blob.len(),
                    e.x,
                    e.y,
                    e.z,
                    lo.len(),
                    hi.len()
                );
            }
            (lo, hi)
        };
        // Three faces that fit, bending past `max_bend_deg` but no more than a small box's
        // faces do.
        let bent_box = fr.axes.len() == 3
            && fr.fit >= cfg.blob_min_fit
            && fr.agree >= cfg.blob_min_agree
            && fr.bend_deg > cfg.max_bend_deg
            && fr.bend_deg <= cfg.blob_three_face_max_bend_deg;
        // The whole scored once where the profile test needs it, for the end as well.
        let mut whole_scored: Option<Option<Raw>> = None;
        // A step between two planes facing the support's up is read both ways: two boxes side
        // by side (cut between the planes' cells) or one stacked on the other (cut across the
        // up, past the farther plane). Flush faces of one colour look the same either way; a
        // sure step is cut the stacked way when those parts are the better boxes by
        // `blob_stack_margin`, and the reading not taken comes back as alternatives.
        let stacked = step
            .zip(up)
            .filter(|(st, u)| {
                cfg.blob_stack_max_tilt_deg > 0.0
                    && st.stack.0.dot(u) >= cfg.blob_stack_max_tilt_deg.to_radians().cos()
            })
            .map(|(st, _)| {
                let (lo, hi) = by_plane(st.stack, "stacked reading");
                let scored = (reading_part(&lo), reading_part(&hi));
                (lo, hi, scored)
            });
        let parts = match step {
            Some(Step {
                cut, sure: true, ..
            }) => {
                let side = by_plane(cut, "step");
                match stacked {
                    Some((lo, hi, (ra, rb))) => {
                        let side_scored = (reading_part(&side.0), reading_part(&side.1));
                        let (st_shape, side_shape) = (
                            cut_shape((&lo, &hi), (&ra, &rb)),
                            cut_shape((&side.0, &side.1), (&side_scored.0, &side_scored.1)),
                        );
                        if dbg && blob.len() > 200 {
                            log::debug!(
                                "blob {b}.{pi} stacked {st_shape:.2} side by side {side_shape:.2}"
                            );
                        }
                        if st_shape >= side_shape + cfg.blob_stack_margin {
                            out.extend(lost([side_scored.0, side_scored.1]));
                            Some((lo, hi))
                        } else {
                            out.extend(lost([ra, rb]));
                            Some(side)
                        }
                    }
                    None => Some(side),
                }
            }
            Some(Step {
                cut, sure: false, ..
            }) => {
                // A weak step: the whole object competes with its parts.
                out.extend(score_part(&blob, &fr));
                if let Some((_, _, (ra, rb))) = stacked {
                    out.extend(lost([ra, rb]));
                }
                Some(by_plane(cut, "weak step"))
            }
            None => {
                if dbg && blob.len() > 200 {
                    log::debug!(
                        "blob {b}.{pi} n {} faces {} fit {:.2} agree {:.2} bend {:.1}",
                        blob.len(),
                        fr.axes.len(),
                        fr.fit,
                        fr.agree,
                        fr.bend_deg
                    );
                }
                let misfit = fr.fit < cfg.blob_min_fit
                    || fr.agree < cfg.blob_min_agree
                    || fr.bend_deg > cfg.max_bend_deg;
                if misfit && !cfg.blob_colour_cut_misfits {
                    continue;
                }
                // A box-like object may still be two boxes of different colours, flush; one
                // that fits no cuboid may be two boxes of different colours touching.
                let cut = if depth < cfg.blob_max_cuts {
                    find_colour_cut(g, &fr, &blob, cfg)
                } else {
                    None
                };
                // Failing that, a fitting object may be two boxes of one colour, flush: its
                // cross-section steps along one axis. Cut there when the two parts, scored
                // as boxes, beat the whole by `blob_profile_cut_margin` (a part of one box is
                // as good a cuboid as the whole, so only a misfit whole gives way); the
                // whole then competes with its parts.
                let try_profile = cut.is_none()
                    && !misfit
                    && depth < cfg.blob_max_cuts
                    && cfg.blob_profile_cut_min_mm > 0.0;
                let whole = try_profile.then(|| score_part(&blob, &fr));
                // Parts score at most 1: a whole that fits too well to be beaten is not
                // searched for a cut; nor is one that is no box (a whole stack), whose parts
                // would escape the seam splits that `select` makes of coarse candidates.
                let room = whole
                    .as_ref()
                    .and_then(|w| w.as_ref())
                    .is_some_and(|w| shape(w) + cfg.blob_profile_cut_margin <= 1.0);
                let profile = room.then(|| find_profile_cut(g, &fr, &blob, cfg)).flatten();
                if let Some(c) = profile {
                    let (lo, hi) = by_plane(c, "profile");
                    let part = |p: &[u32]| frame_of(g, p, cfg).and_then(|f| score_part(p, &f));
                    let (ra, rb) = (part(&lo), part(&hi));
                    let mean = cut_shape((&lo, &hi), (&ra, &rb));
                    // `room` held: the whole is a box.
                    let w = whole.as_ref().and_then(|w| w.as_ref()).map_or(0.0, shape);
                    if dbg && blob.len() > 200 {
                        log::debug!("blob {b}.{pi} profile parts {mean:.2} whole {w:.2}");
                    }
                    if mean >= w + cfg.blob_profile_cut_margin {
                        out.extend(whole.flatten());
                        work.push((pi, lo, depth + 1));
                        work.push((next, hi, depth + 1));
                        next += 1;
                        continue;
                    }
                    // The whole stands; its parts may still be the right reading (two
                    // boxes stacked whose union is as good a cuboid).
                    if cfg.blob_profile_cut_alternatives {
                        out.extend(lost([ra, rb]));
                    }
                }
                whole_scored = whole;
                match cut {
                    Some(c) => Some(by_plane(c, "colour")),
                    None if misfit => {
                        // Turned to each other, two boxes share no axis to cut along: their
                        // colours part them.
                        let small = blob.len() <= cfg.blob_colour_split_max_cells as usize;
                        let split = (depth < cfg.blob_max_cuts && small)
                            .then(|| two_colours(g, &blob, cfg.blob_colour_split_min_chroma, cfg))
                            .flatten();
                        match split {
                            Some((lo, hi)) => {
                                if dbg && blob.len() > 200 {
                                    log::debug!(
                                        "blob {b}.{pi} n {} two colours: {} + {}",
                                        blob.len(),
                                        lo.len(),
                                        hi.len()
                                    );
                                }
                                Some((lo, hi))
                            }
                            // Bent only a little, three faces and of one colour: scored below.
                            None if bent_box => None,
                            None => continue,
                        }
                    }
                    // It fits, yet may be two boxes of clearly different colours, one on the
                    // other: scored whole, and its colour clusters tried as well.
                    None => (cfg.blob_fit_colour_split_min_chroma > 0.0
                        && depth < cfg.blob_max_cuts)
                        .then(|| two_colours(g, &blob, cfg.blob_fit_colour_split_min_chroma, cfg))
                        .flatten()
                        .and_then(|(lo, _)| colour_plane(g, &blob, &lo, &fr.full, cfg))
                        .map(|c| {
                            let whole = whole_scored.take();
                            out.extend(whole.unwrap_or_else(|| score_part(&blob, &fr)));
                            by_plane(c, "fits, two colours")
                        }),
                }
            }
        };
        if let Some((lo, hi)) = parts {
            work.push((pi, lo, depth + 1));
            work.push((next, hi, depth + 1));
            next += 1;
            continue;
        }
        let raw = match whole_scored {
            Some(w) => w,
            None => score_part(&blob, &fr),
        };
        if let Some(raw) = raw {
            if !bent_box || raw.score >= cfg.blob_three_face_min_score {
                out.push(raw);
            }
        }
    }
    // Nothing came of the object: read it once more as a box standing on the support.
    if let (true, Some(whole), Some(up)) = (out.is_empty(), whole, up) {
        if let Some(fr) = upright_frame(g, &whole, &up, cfg) {
            let (n_faces, fit) = (fr.axes.len(), fr.fit);
            let raw = if fit < cfg.blob_min_fit {
                None
            } else if let Some(raw) = score_in(&whole, &fr, &upright_cfg(cfg)) {
                Some(raw)
            } else if fr.axes.len() > 1 {
                // The largest face alone, then.
                let lone = Frame {
                    axes: vec![fr.axes[0]],
                    faces: vec![fr.faces[0].clone()],
                    ..fr
                };
                score_part(&whole, &lone)
            } else {
                None
            };
            // A last resort: scored below the other candidates.
            let raw = raw.map(|mut r| {
                r.score *= cfg.blob_upright_score_factor;
                r
            });
            if dbg && whole.len() > 100 {
                let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0, 0);
                for &i in &whole {
                    let (u, v) = (i as usize % g.w, i as usize / g.w);
                    (u0, v0, u1, v1) = (u0.min(u), v0.min(v), u1.max(u), v1.max(v));
                }
                log::debug!(
                    "blob {b} n {} upright faces {n_faces} fit {fit:.2} score {:?} bbox ({u0}, {v0}, {u1}, {v1})",
                    whole.len(),
                    raw.as_ref().map(|r| (r.score * 100.0).round() / 100.0),
                );
            }
            out.extend(raw);
        }
    }
    out
}

/// The configuration an upright reading is scored with: its sides are seen only above the
/// cells cut off at the support (`blob_support_gap_factor` plane tolerances, 26 mm at 1.5 m),
/// so a low box's may be thinner than `min_box_extent_mm`.
fn upright_cfg(cfg: &DetectConfig) -> DetectConfig {
    DetectConfig {
        min_box_extent_mm: cfg.min_box_extent_mm.min(cfg.blob_upright_min_extent_mm),
        ..cfg.clone()
    }
}

/// An object's box frame with one axis along the support's `up` (unit) and the other two
/// those of the smallest rectangle around its cells seen along `up`: a box resting on a
/// support, or on a box that does, stands on one of its faces. Cells are assigned to the
/// visible face plane they lie nearest to (not by normal: on a box a few cells across, the
/// smoothed normals blur from one face into the next), within
/// `blob_upright_face_tol_factor` plane tolerances; faces with fewer cells than
/// `min_face_cells` (or `blob_min_face_fraction` of the object's) are left out.
fn upright_frame(g: &Grid, cells: &[u32], up: &Vector3<f64>, cfg: &DetectConfig) -> Option<Frame> {
    let pts: Vec<Vector3<f64>> = cells.iter().map(|&i| v3(&g.p[i as usize])).collect();
    if pts.len() < cfg.min_face_cells as usize {
        return None;
    }
    let mean = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
    let full = rectangle_axes(up, &pts, cfg.extent_quantile);
    // Each axis turned to the camera (at the origin): its visible face is the plane at the
    // top of the cells' range along it.
    let axes: [Vector3<f64>; 3] = full.map(|a| if a.dot(&mean) > 0.0 { -a } else { a });
    let mut vals = Vec::with_capacity(pts.len());
    let offsets: [f64; 3] = axes.map(|a| {
        vals.clear();
        vals.extend(pts.iter().map(|p| p.dot(&a)));
        robust_range(&mut vals, cfg.extent_quantile).1
    });
    let min_face = (cfg.min_face_cells as usize)
        .max((cfg.blob_min_face_fraction * cells.len() as f64) as usize);
    let mut faces: [Vec<u32>; 3] = Default::default();
    let mut on_plane = 0usize;
    for (&i, p) in cells.iter().zip(&pts) {
        let tol = plane_tol(cfg, g.z[i as usize] as f64);
        let (k, d) = (0..3)
            .map(|k| (k, (offsets[k] - p.dot(&axes[k])).abs()))
            .min_by(|x, y| x.1.total_cmp(&y.1))?;
        if d <= tol {
            on_plane += 1;
        }
        if d <= cfg.blob_upright_face_tol_factor * tol {
            faces[k].push(i);
        }
    }
    let assigned: usize = faces.iter().map(Vec::len).sum();
    // Largest face first, as `frame_of` has its dominant normal first.
    let mut kept: Vec<(Vector3<f64>, Vec<u32>)> = axes
        .into_iter()
        .zip(faces)
        .filter(|(_, f)| f.len() >= min_face)
        .collect();
    if kept.is_empty() {
        return None;
    }
    kept.sort_by_key(|(_, f)| std::cmp::Reverse(f.len()));
    let (axes, faces): (Vec<_>, Vec<_>) = kept.into_iter().unzip();
    Some(Frame {
        axes,
        faces,
        fit: on_plane as f64 / cells.len() as f64,
        // The share assigned to a face, by position here, not by normal.
        agree: assigned as f64 / cells.len() as f64,
        full,
        // Not judged: the faces are cut by position, and a small box's edge cells tilt.
        bend_deg: 0.0,
    })
}

/// The plane {p·e = s0}, `e` one of the box `axes`, that best parts the colour cluster `lo`
/// (a subset of `blob`, ascending) from the rest, if at least `blob_fit_colour_split_min_agree`
/// of the cells fall on their cluster's side and each side holds
/// `blob_colour_cut_min_fraction` of them: the clusters of two boxes lie apart, those of a
/// box's shading or print do not.
fn colour_plane(
    g: &Grid,
    blob: &[u32],
    lo: &[u32],
    axes: &[Vector3<f64>; 3],
    cfg: &DetectConfig,
) -> Option<(Vector3<f64>, f64)> {
    let n = blob.len();
    let min_side = (cfg.blob_colour_cut_min_fraction * n as f64).ceil() as usize;
    let in_lo: Vec<bool> = blob.iter().map(|i| lo.binary_search(i).is_ok()).collect();
    let n_lo = in_lo.iter().filter(|&&x| x).count();
    let mut best: Option<(usize, Vector3<f64>, f64)> = None;
    for e in axes {
        let mut t: Vec<(f64, bool)> = blob
            .iter()
            .zip(&in_lo)
            .map(|(i, &l)| (v3(&g.p[*i as usize]).dot(e), l))
            .collect();
        // Cuts fall only between distinct values: the order of ties does not matter.
        t.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        // Errors with the cluster below the cut: its cells above plus the others below.
        let mut lo_above = n_lo;
        let mut other_below = 0usize;
        for x in 1..n {
            if t[x - 1].1 {
                lo_above -= 1;
            } else {
                other_below += 1;
            }
            if x < min_side || n - x < min_side || t[x].0 <= t[x - 1].0 {
                continue;
            }
            let err_a = lo_above + other_below;
            let err = err_a.min(n - err_a);
            if best.is_none_or(|b| err < b.0) {
                best = Some((err, *e, (t[x - 1].0 + t[x].0) / 2.0));
            }
        }
    }
    let (err, e, s0) = best?;
    (err as f64 <= (1.0 - cfg.blob_fit_colour_split_min_agree) * n as f64).then_some((e, s0))
}

/// The cells of an object parted by colour: two clusters of the cells' chromaticities
/// ((r, g, b) / (r + g + b) of their smoothed colours; 2-means, 8 rounds, seeded with the one
/// farthest from the mean and the one farthest from that), when their centres differ by at
/// least `min_chroma` (`blob_colour_split_min_chroma` for an object that fits no cuboid,
/// `blob_fit_colour_split_min_chroma` for one that does) and each holds at least
/// `blob_colour_cut_min_fraction` of the cells. Deterministic.
fn two_colours(
    g: &Grid,
    blob: &[u32],
    min_chroma: f64,
    cfg: &DetectConfig,
) -> Option<(Vec<u32>, Vec<u32>)> {
    let n = blob.len();
    if n < 32 {
        return None;
    }
    // Chromaticity: shading scales a face's colour and leaves it unchanged.
    let chroma: Vec<Vector3<f64>> = blob
        .iter()
        .map(|&i| {
            let c = Vector3::from(g.c[i as usize]).cast::<f64>();
            c / (c.x + c.y + c.z).max(1.0)
        })
        .collect();
    let mean: Vector3<f64> = chroma.iter().sum::<Vector3<f64>>() / n as f64;
    let far = |from: &Vector3<f64>| {
        chroma.iter().copied().max_by(|a, b| {
            (a - from)
                .norm_squared()
                .total_cmp(&(b - from).norm_squared())
        })
    };
    let mut ca = far(&mean)?;
    let mut cb = far(&ca)?;
    let mut in_a = vec![false; n];
    let mut na = 0;
    for _ in 0..8 {
        let (mut sa, mut sb) = (Vector3::zeros(), Vector3::zeros());
        na = 0;
        for (k, c) in chroma.iter().enumerate() {
            in_a[k] = (c - ca).norm_squared() <= (c - cb).norm_squared();
            if in_a[k] {
                sa += c;
                na += 1;
            } else {
                sb += c;
            }
        }
        if na == 0 || na == n {
            return None;
        }
        (ca, cb) = (sa / na as f64, sb / (n - na) as f64);
    }
    let frac = cfg.blob_colour_cut_min_fraction;
    if (ca - cb).norm() < min_chroma || (na.min(n - na) as f64) < frac * n as f64 {
        return None;
    }
    let (mut lo, mut hi) = (Vec::with_capacity(na), Vec::with_capacity(n - na));
    for (&i, a) in blob.iter().zip(in_a) {
        if a {
            lo.push(i);
        } else {
            hi.push(i);
        }
    }
    Some((lo, hi))
}
