//! The rest of a box that selection left beside the piece it chose.
//!
//! In: the selected candidates (the residual candidates included), the grid, its depth joins
//! and the cells that belong to no object (supports). Out: the same candidates, some of them
//! grown by one touching remain, their cuboids refitted.
//!
//! A box often comes out of selection as a piece: one face, its neighbouring side face (seen
//! at a grazing angle, or cut off at a printed edge or a label) left out. The rest of its
//! visible surface is then held by no candidate: tried alone as a residual candidate, it is
//! no box by itself (a thin band, a part of a face). The estimator, given one face, must guess
//! the box's thickness. Here each candidate of at most
//! [`DetectConfig::remain_join_max_faces`] faces (one by default) is scored together with
//! each remain that touches it across a depth join (the remains: what is left of the
//! depth-connected convex objects once every candidate's cells are taken out); a union whose
//! box-likeness reaches
//! [`DetectConfig::remain_join_min_score_ratio`] times the candidate's own, both scored as
//! uncut objects (`blobs`), takes the remain in. A remain touched by several candidates goes to
//! the one whose score it raises most, and a candidate takes at most one remain. A remain
//! larger than the candidate by [`DetectConfig::remain_join_max_size_ratio`] is more likely
//! other boxes than the candidate's rest: on a pallet, a row of flush cartons is as good a
//! cuboid as one of them.
//!
//! The paper has no such step: its masks come from SAM.

use rayon::prelude::*;

use super::boxes::Raw;
use super::grid::Grid;
use super::regions::{self, Cues, Joins, NONE};
use super::{blobs, DetectConfig};

/// Grows the candidates in `chosen` by the remains that complete them (see the module doc).
/// `off`: cells on no object (supports and what lies flat next to them).
pub(crate) fn join_remains(
    g: &Grid,
    joins: &Joins,
    off: &[bool],
    chosen: &mut [Raw],
    cfg: &DetectConfig,
) {
    if cfg.remain_join_min_score_ratio <= 0.0 || chosen.is_empty() {
        return;
    }
    let mut held = off.to_vec();
    for c in chosen.iter() {
        for &i in &c.cells {
            held[i as usize] = true;
        }
    }
    let (labels, n) = regions::label(g, joins, Cues::Depth, Some(&held), cfg);
    if n == 0 {
        return;
    }
    let mut cells_of: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE {
            cells_of[l as usize].push(i as u32);
        }
    }
    let min_cells = cfg.min_face_cells as usize;
    let max_cells = cfg.residual_max_cells as usize;
    // Per candidate: (remain, score gain, union) for every union that qualifies.
    let offers: Vec<Vec<(usize, f64, Raw)>> = chosen
        .par_iter()
        .map(|c| {
            if c.lost_cut || c.n_faces > cfg.remain_join_max_faces {
                return Vec::new();
            }
            let max_cells =
                max_cells.min((cfg.remain_join_max_size_ratio * c.cells.len() as f64) as usize);
            let mut touch = touching_remains(g, joins, &labels, &c.cells);
            touch.retain(|&l| (min_cells..=max_cells).contains(&cells_of[l as usize].len()));
            if touch.is_empty() {
                return Vec::new();
            }
            // Scored as the objects are: cells of no remain and no candidate count neither
            // for nor against the silhouette; the other candidates' cells are judged by depth.
            let Some(own) = blobs::score_whole(g, &c.cells, &labels, &held, cfg) else {
                return Vec::new();
            };
            let mut out = Vec::new();
            for l in touch {
                let mut union: Vec<u32> = c
                    .cells
                    .iter()
                    .chain(&cells_of[l as usize])
                    .copied()
                    .collect();
                union.sort_unstable();
                if let Some(r) = blobs::score_whole(g, &union, &labels, &held, cfg) {
                    if r.score >= own.score * cfg.remain_join_min_score_ratio {
                        out.push((l as usize, r.score / own.score.max(1e-9), r));
                    }
                }
            }
            out
        })
        .collect();
    // Each remain to the candidate it raises most (the first on ties), then each candidate
    // its best remain.
    let mut by_remain: Vec<Option<(f64, usize, Raw)>> = (0..n).map(|_| None).collect();
    for (k, offers) in offers.into_iter().enumerate() {
        for (l, gain, r) in offers {
            if by_remain[l].as_ref().is_none_or(|b| gain > b.0) {
                by_remain[l] = Some((gain, k, r));
            }
        }
    }
    let mut by_candidate: Vec<Option<(f64, Raw)>> = (0..chosen.len()).map(|_| None).collect();
    for (gain, k, r) in by_remain.into_iter().flatten() {
        if by_candidate[k].as_ref().is_none_or(|b| gain > b.0) {
            by_candidate[k] = Some((gain, r));
        }
    }
    for (c, best) in chosen.iter_mut().zip(by_candidate) {
        if let Some((_, r)) = best {
            log::debug!(
                "remain joined: {} + {} cells, faces {} -> {}",
                c.cells.len(),
                r.cells.len() - c.cells.len(),
                c.n_faces,
                r.n_faces
            );
            // The score stays the candidate's: selection ranked it, and the mask's larger
            // size raises the detection's evidence factor.
            c.cells = r.cells;
            c.bx = r.bx;
            c.n_faces = r.n_faces;
            c.normal = r.normal;
        }
    }
}

/// The remains (labels) that 4-neighbour one of `cells` across a depth join, ascending.
fn touching_remains(g: &Grid, joins: &Joins, labels: &[u32], cells: &[u32]) -> Vec<u32> {
    let mut touch: Vec<u32> = cells
        .iter()
        .flat_map(|&i| joins.depth_neighbours(i as usize, g.w, g.h))
        .map(|j| labels[j])
        .filter(|&l| l != NONE)
        .collect();
    touch.sort_unstable();
    touch.dedup();
    touch
}
