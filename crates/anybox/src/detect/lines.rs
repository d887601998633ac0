//! Cutting colour patches along straight seam lines that have gaps.
//!
//! In: the colour-level labels (seam cells are unlabelled there) and the grid's seam flags.
//! Out: the labels with every patch that a straight, well-supported seam line crosses cut in
//! two along it.
//!
//! The joint between two flush cartons is a straight line, but at the grid's resolution its
//! seam cells come out dashed, and it often stops a cell or two short of the patch's rim.
//! Region growing joins across one gap, so a whole layer of cartons can become one patch. Here
//! the seam cells around each patch vote for lines (a Hough transform); a line with enough
//! cells at enough density has its gaps bridged and is carried on to the rim, and the patch is
//! cut when that leaves it in two or more pieces of `min_region_cells`. Noise and print make
//! no such lines: their seam cells are scattered or short.

use rayon::prelude::*;

use super::grid::{flag_at, on_both_sides, Grid, LINE_DIRS};
use super::regions::{compact_labels, Dsu, NONE};
use super::DetectConfig;

/// Hough angle bins over 180°.
const ANGLES: usize = 90;
/// Most lines looked for per patch.
const MAX_LINES: usize = 12;

/// Cuts the patches of `labels` (values below `n`) along straight seam lines (see the module
/// doc). Returns the new number of labels (`n` when nothing was cut); labels are compacted
/// in scan order.
pub(crate) fn cut_along_seam_lines(
    g: &Grid,
    labels: &mut [u32],
    n: usize,
    cfg: &DetectConfig,
) -> usize {
    if cfg.seam_line_min_cells == 0 || n == 0 {
        return n;
    }
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE {
            cells[l as usize].push(i as u32);
        }
    }
    let min_piece = cfg.min_region_cells.max(3) as usize;
    let cuts: Vec<Option<(Vec<u32>, u32)>> = cells
        .par_iter()
        .map(|c| {
            if c.len() < 2 * min_piece {
                None
            } else {
                cut_patch(g, c, cfg)
            }
        })
        .collect();
    if cuts.iter().all(Option::is_none) {
        return n;
    }
    // Piece k > 0 of a cut patch gets a fresh label; piece 0 keeps the patch's.
    let mut next = n as u32;
    for (l, cut) in cuts.iter().enumerate() {
        let Some((piece, n_pieces)) = cut else {
            continue;
        };
        for (&i, &p) in cells[l].iter().zip(piece) {
            labels[i as usize] = match p {
                NONE => NONE,
                0 => l as u32,
                p => next + p - 1,
            };
        }
        next += n_pieces - 1;
    }
    compact_labels(labels, next as usize, |l| l)
}

/// A line in the patch's window, cells: through `p`, along the unit direction `d`.
#[derive(Clone, Copy)]
pub(super) struct Line {
    p: (f32, f32),
    pub(super) d: (f32, f32),
}

impl Line {
    /// Signed distance of `q` from the line, cells.
    fn dist(&self, q: (f32, f32)) -> f32 {
        (q.0 - self.p.0) * -self.d.1 + (q.1 - self.p.1) * self.d.0
    }

    /// Position of `q` along the line, cells.
    fn t(&self, q: (f32, f32)) -> f32 {
        (q.0 - self.p.0) * self.d.0 + (q.1 - self.p.1) * self.d.1
    }

    /// Total-least-squares line through `pts` (the principal axis of their scatter); `None`
    /// for fewer than two points.
    pub(super) fn fit(pts: impl Iterator<Item = (f32, f32)> + Clone) -> Option<Line> {
        let n = pts.clone().count();
        if n < 2 {
            return None;
        }
        let (mut mx, mut my) = (0f32, 0f32);
        for (x, y) in pts.clone() {
            mx += x;
            my += y;
        }
        let (mx, my) = (mx / n as f32, my / n as f32);
        let (mut sxx, mut sxy, mut syy) = (0f32, 0f32, 0f32);
        for (x, y) in pts {
            let (dx, dy) = (x - mx, y - my);
            sxx += dx * dx;
            sxy += dx * dy;
            syy += dy * dy;
        }
        // Angle of the major axis of the 2×2 scatter matrix.
        let a = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        Some(Line {
            p: (mx, my),
            d: (a.cos(), a.sin()),
        })
    }
}

/// The stretch of a seam line where the patch is cut, with `seam_line_gap_cells` added at
/// both ends.
struct Segment {
    line: Line,
    /// From, to: positions along the line, cells.
    t0: f32,
    t1: f32,
}

impl Segment {
    /// Whether the patch cell at `q` is cut: within 0.75 cells of the line, on the stretch.
    fn cuts(&self, q: (f32, f32)) -> bool {
        let t = self.line.t(q);
        self.line.dist(q).abs() <= 0.75 && t >= self.t0 && t <= self.t1
    }
}

/// Per cell of the patch `cells`: the piece it falls in after cutting along the seam lines
/// around it (`NONE` for cut cells and crumbs), and the number of pieces (at least 2); `None`
/// when it stays whole.
fn cut_patch(g: &Grid, cells: &[u32], cfg: &DetectConfig) -> Option<(Vec<u32>, u32)> {
    let w = g.w;
    let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0usize, 0usize);
    for &i in cells {
        let (u, v) = (i as usize % w, i as usize / w);
        u0 = u0.min(u);
        v0 = v0.min(v);
        u1 = u1.max(u);
        v1 = v1.max(v);
    }
    // Local window with a one-cell rim: the seam cells bordering the patch lie there (those
    // flanked by it lie inside its bounding box).
    let (u0, v0) = (u0.saturating_sub(1), v0.saturating_sub(1));
    let (u1, v1) = ((u1 + 1).min(w - 1), (v1 + 1).min(g.h - 1));
    let (bw, bh) = (u1 - u0 + 1, v1 - v0 + 1);
    let mut inside = vec![false; bw * bh];
    for &i in cells {
        let (u, v) = (i as usize % w - u0, i as usize / w - v0);
        inside[v * bw + u] = true;
    }
    // Seam cells touching the patch (8-neighbours), and those with patch cells on both sides
    // within `reach` cells along a row, a column or a diagonal: a joint inside the patch
    // whose neighbouring cells are unlabelled too. (Every cell within `reach` would add the
    // seams along the patch's rim, and lost on the bench.)
    let reach = cfg.seam_line_reach_cells.max(1) as usize;
    let at = |u: isize, v: isize| flag_at(&inside, bw, bh, u, v);
    let mut seam = Vec::new();
    for v in 0..bh {
        for u in 0..bw {
            if !g.seam[(v + v0) * w + u + u0] || inside[v * bw + u] {
                continue;
            }
            let (ui, vi) = (u as isize, v as isize);
            let touches = (-1..=1).any(|dv| (-1..=1).any(|du| at(ui + du, vi + dv)));
            let flanked = || {
                LINE_DIRS
                    .iter()
                    .any(|&d| on_both_sides(at, ui, vi, reach, d))
            };
            if touches || flanked() {
                seam.push((u as f32, v as f32));
            }
        }
    }
    let min_cells = cfg.seam_line_min_cells as usize;
    if seam.len() < min_cells {
        return None;
    }
    let (cu, cv) = (bw as f32 / 2.0, bh as f32 / 2.0);
    let r_max = ((cu * cu + cv * cv).sqrt()).ceil() as i32 + 1;
    let n_rho = (2 * r_max + 1) as usize;
    let trig: Vec<(f32, f32)> = (0..ANGLES)
        .map(|k| {
            let t = k as f32 * std::f32::consts::PI / ANGLES as f32;
            (t.cos(), t.sin())
        })
        .collect();
    let rho = |p: (f32, f32), k: usize| (p.0 - cu) * trig[k].0 + (p.1 - cv) * trig[k].1;
    let bin = |r: f32| (r.round() as i32 + r_max) as usize;
    let mut acc = vec![0u32; ANGLES * n_rho];
    let vote = |acc: &mut [u32], p: (f32, f32), add: bool| {
        for k in 0..ANGLES {
            let b = k * n_rho + bin(rho(p, k));
            acc[b] = if add {
                acc[b] + 1
            } else {
                acc[b].saturating_sub(1)
            };
        }
    };
    for &p in &seam {
        vote(&mut acc, p, true);
    }
    let mut used = vec![false; seam.len()];
    let gap = cfg.seam_line_gap_cells as f32;
    let mut segments: Vec<Segment> = Vec::new();
    for _ in 0..MAX_LINES {
        // Peak over three neighbouring rho bins: a slanted line's cells straddle two.
        let band = |b: usize| {
            let r = b % n_rho;
            acc[b] + if r > 0 { acc[b - 1] } else { 0 } + if r + 1 < n_rho { acc[b + 1] } else { 0 }
        };
        let Some((best, votes)) = (0..acc.len())
            .map(|b| (b, band(b)))
            .max_by_key(|&(b, c)| (c, std::cmp::Reverse(b)))
        else {
            break;
        };
        if (votes as usize) < min_cells {
            break;
        }
        let k = best / n_rho;
        let r0 = (best % n_rho) as f32 - r_max as f32;
        // The bin's line, then twice: the seam cells within 1.5 cells of it, refitted.
        let (c, s) = trig[k];
        let mut line = Line {
            p: (cu + r0 * c, cv + r0 * s),
            d: (-s, c),
        };
        let mut on: Vec<usize> = Vec::new();
        for _ in 0..2 {
            on = (0..seam.len())
                .filter(|&j| !used[j] && line.dist(seam[j]).abs() <= 1.5)
                .collect();
            let Some(fit) = Line::fit(on.iter().map(|&j| seam[j])) else {
                break;
            };
            line = fit;
        }
        let mut along: Vec<f32> = on
            .iter()
            .filter(|&&j| line.dist(seam[j]).abs() <= 1.0)
            .map(|&j| line.t(seam[j]))
            .collect();
        along.sort_by(f32::total_cmp);
        // Runs with gaps up to `gap` cells, dense enough, long enough: at least `min_cells`
        // along the line too (a blob of print has many cells but no length).
        let mut start = 0;
        for e in 1..=along.len() {
            if e < along.len() && along[e] - along[e - 1] <= gap + 1.0 {
                continue;
            }
            let run = &along[start..e];
            let span = run[run.len() - 1] - run[0] + 1.0;
            let long = run.len() >= min_cells && span >= min_cells as f32;
            if long && run.len() as f64 >= cfg.seam_line_density * span as f64 {
                segments.push(Segment {
                    line,
                    t0: run[0] - gap,
                    t1: run[run.len() - 1] + gap,
                });
            }
            start = e;
        }
        // These cells vote no more (whether or not they made a segment).
        for &j in &on {
            used[j] = true;
            vote(&mut acc, seam[j], false);
        }
    }
    if segments.is_empty() {
        return None;
    }
    // Patch cells on a segment are cut.
    let mut open = inside.clone();
    for v in 0..bh {
        for u in 0..bw {
            let p = (u as f32, v as f32);
            if inside[v * bw + u] && segments.iter().any(|sg| sg.cuts(p)) {
                open[v * bw + u] = false;
            }
        }
    }
    // Pieces: 4-connected components of what is left, numbered in scan order.
    let mut dsu = Dsu::new(bw * bh);
    for v in 0..bh {
        for u in 0..bw {
            let x = v * bw + u;
            if !open[x] {
                continue;
            }
            if u + 1 < bw && open[x + 1] {
                dsu.union(x as u32, (x + 1) as u32);
            }
            if v + 1 < bh && open[x + bw] {
                dsu.union(x as u32, (x + bw) as u32);
            }
        }
    }
    let (piece, n_pieces) = dsu.label_large(cfg.min_region_cells.max(3), |x| open[x]);
    if n_pieces < 2 {
        return None;
    }
    let per_cell = cells
        .iter()
        .map(|&i| piece[(i as usize / w - v0) * bw + i as usize % w - u0])
        .collect();
    Some((per_cell, n_pieces))
}

#[cfg(test)]
mod tests {
    use super::*;
    use anybox_geom::Intrinsics;
    use proptest::prelude::*;

    const W: usize = 60;
    const H: usize = 40;

    /// A flat grid 1 m away whose seam cells are `seam(u, v)`, and its labels as the
    /// colour-level segmentation leaves them: every other cell in one patch (leaked through
    /// the seam line's gaps).
    fn leaked(seam: impl Fn(usize, usize) -> bool) -> (Grid, Vec<u32>) {
        let mut s = vec![false; W * H];
        for v in 0..H {
            for u in 0..W {
                s[v * W + u] = seam(u, v);
            }
        }
        let labels = s.iter().map(|&x| if x { NONE } else { 0 }).collect();
        let g = Grid {
            w: W,
            h: H,
            step: 2,
            k: Intrinsics {
                fx: 300.0,
                fy: 300.0,
                cx: 30.0,
                cy: 20.0,
            },
            z: vec![1000.0; W * H],
            p: vec![[0.0, 0.0, 1000.0]; W * H],
            n: vec![[0.0, 0.0, -1.0]; W * H],
            c: vec![[128.0; 3]; W * H],
            seam: s,
            grow_from_mm: 0.0,
        };
        (g, labels)
    }

    /// Cutting leaves the single patch of `labels` as it is.
    fn assert_uncut(g: &Grid, mut labels: Vec<u32>, cfg: &DetectConfig) {
        let before = labels.clone();
        assert_eq!(cut_along_seam_lines(g, &mut labels, 1, cfg), 1);
        assert_eq!(labels, before);
    }

    /// Cells that kept a label, per label, and the labels on either side of `u = at`.
    fn sides(labels: &[u32], at: usize) -> (Vec<u32>, Vec<u32>) {
        let (mut left, mut right) = (Vec::new(), Vec::new());
        for v in 0..H {
            for u in 0..W {
                let l = labels[v * W + u];
                if l == NONE {
                    continue;
                }
                if u + 1 < at {
                    left.push(l);
                } else if u > at + 1 {
                    right.push(l);
                }
            }
        }
        left.dedup();
        right.dedup();
        left.sort_unstable();
        left.dedup();
        right.sort_unstable();
        right.dedup();
        (left, right)
    }

    #[test]
    fn a_dashed_joint_that_stops_short_of_the_rim_cuts_the_patch() {
        // Vertical joint at u = 30: 3-cell dashes with 2-cell gaps, starting 3 cells below the
        // top rim and stopping 4 above the bottom one.
        let (g, mut labels) = leaked(|u, v| u == 30 && (3..36).contains(&v) && v % 5 < 3);
        let cfg = DetectConfig::default();
        let n = cut_along_seam_lines(&g, &mut labels, 1, &cfg);
        assert_eq!(n, 2);
        let (left, right) = sides(&labels, 30);
        assert_eq!(left.len(), 1, "left side in one piece: {left:?}");
        assert_eq!(right.len(), 1, "right side in one piece: {right:?}");
        assert_ne!(left, right);
        // Only cells within a cell of the joint lose their label.
        for v in 0..H {
            for u in 0..W {
                if labels[v * W + u] == NONE {
                    assert!(u.abs_diff(30) <= 1, "cell ({u}, {v}) cut");
                }
            }
        }
    }

    #[test]
    fn a_joint_with_unlabelled_cells_beside_it_cuts_the_patch() {
        // Vertical joint at u = 30 with a 4-cell gap in the middle, where the patch leaks
        // across; along the joint the cells on either side are unlabelled too (as where a
        // carton's edge blurs the colour), so most seam cells lie two cells from the patch.
        let on = |u: usize, v: usize| u == 30 && ((2..18).contains(&v) || (22..38).contains(&v));
        let (g, mut labels) = leaked(on);
        for v in 0..H {
            for u in 29..=31 {
                if on(30, v) {
                    labels[v * W + u] = NONE;
                }
            }
        }
        // Premise: only the seam cells at the gap's and rims' ends touch the patch, too few
        // for a line.
        let near_only = DetectConfig {
            seam_line_reach_cells: 1,
            ..DetectConfig::default()
        };
        assert_uncut(&g, labels.clone(), &near_only);
        let n = cut_along_seam_lines(&g, &mut labels, 1, &DetectConfig::default());
        assert_eq!(n, 2);
        let (left, right) = sides(&labels, 30);
        assert_eq!(left.len(), 1, "left side in one piece: {left:?}");
        assert_eq!(right.len(), 1, "right side in one piece: {right:?}");
        assert_ne!(left, right);
    }

    #[test]
    fn scattered_seam_cells_and_short_print_do_not_cut() {
        // About 6 % noise cells (a fixed hash) plus an 8-cell printed dash.
        let noise = |u: usize, v: usize| {
            // SplitMix64 finaliser of the cell index: no lattice structure.
            let mut x = (v * W + u) as u64 ^ 0x9e37_79b9_7f4a_7c15;
            x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            (x ^ (x >> 31)) % 100 < 6
        };
        let (g, labels) = leaked(|u, v| noise(u, v) || (v == 20 && (10..18).contains(&u)));
        assert_uncut(&g, labels, &DetectConfig::default());
    }

    #[test]
    fn a_blob_of_print_across_a_narrow_patch_does_not_cut() {
        // A 14-row band with a 6 × 8 blob of seam cells in it (a printed logo): the blob's
        // left rim alone is 8 cells in a column, with 4 more beside it, but no line is 10
        // cells long.
        let (g, mut labels) = leaked(|u, v| (28..34).contains(&u) && (17..25).contains(&v));
        for (i, l) in labels.iter_mut().enumerate() {
            if !(13..27).contains(&(i / W)) {
                *l = NONE;
            }
        }
        assert_uncut(&g, labels, &DetectConfig::default());
    }

    #[test]
    fn a_line_that_does_not_cross_the_patch_leaves_it_whole() {
        // A full-density line 20 cells long from the left rim: it cannot separate anything,
        // even carried on `seam_line_gap_cells` past its end.
        let (g, labels) = leaked(|u, v| v == 20 && u < 20);
        assert_uncut(&g, labels, &DetectConfig::default());
    }

    #[test]
    fn disabled_with_zero_min_cells() {
        let (g, labels) = leaked(|u, v| u == 30 && v % 5 < 3);
        let cfg = DetectConfig {
            seam_line_min_cells: 0,
            ..DetectConfig::default()
        };
        assert_uncut(&g, labels, &cfg);
    }

    proptest! {
        /// Any slanted joint across the patch, dashed with gaps up to `seam_line_gap_cells`
        /// and density ≥ `seam_line_density`, splits it in two along that line: every cell
        /// clear of the line keeps the side it is on (checked against the line's equation).
        #[test]
        fn slanted_dashed_joints_split_by_side(
            x0 in 15.0f64..45.0,
            slope in -0.4f64..0.4,
            dash in 3usize..7,
            gap in 1usize..3,
        ) {
            let on = |u: usize, v: usize| {
                let x = x0 + slope * (v as f64 - 20.0);
                (u as f64 - x).abs() < 0.5 && v % (dash + gap) < dash
            };
            let (g, mut labels) = leaked(on);
            let n = cut_along_seam_lines(&g, &mut labels, 1, &DetectConfig::default());
            prop_assert_eq!(n, 2);
            let mut side_label = [NONE; 2];
            for v in 0..H {
                for u in 0..W {
                    let l = labels[v * W + u];
                    let d = u as f64 - (x0 + slope * (v as f64 - 20.0));
                    if l == NONE || d.abs() < 2.0 {
                        continue;
                    }
                    let s = (d > 0.0) as usize;
                    if side_label[s] == NONE {
                        side_label[s] = l;
                    }
                    prop_assert_eq!(side_label[s], l, "cell ({}, {}) on side {}", u, v, s);
                }
            }
            prop_assert_ne!(side_label[0], side_label[1]);
        }
    }
}
