//! A box's faces seen again past a nearer thing that cuts them in two.
//!
//! In: a candidate's fitted cuboid (camera frame, mm), its grid cells, and who holds each
//! cell. Out: the unclaimed cells that continue the cuboid's visible faces beyond an
//! occluder, and the other candidates lying there (the same box's other piece).
//!
//! A box with a nearer box or stick standing across it shows two disconnected pieces, and the
//! segmentations (which join neighbouring cells) see two objects; the smaller piece is then
//! lost or detected as a box of its own, and the estimator, given one piece, measures a box
//! too short. Geometry says where the rest must lie: the cuboid extended along one of its
//! axes. Along each axis and each way where the candidate's cells meet a nearer neighbour
//! near that end, the cells whose rays meet the extension are sorted into three kinds by
//! their depth against its surface: *on* it, *in front* of it (an occluder) or *behind* it
//! (the extension is seen through, so the box does not go on there). Going outwards from the
//! cuboid's end in bins of distance, an occluder first (bins mostly in front), then a run of
//! bins mostly on the surface, of about the candidate's colour (or of its colour in shadow), is
//! taken as the same box seen past its occluder (see [`DetectConfig::occluded_reach_mm`]).
//! Flush neighbours on a pallet or a table are coplanar too, but nothing stands in front
//! between them, so they are never reached; an occluder of the candidate's own colour is not
//! trusted (on a pallet it is a carton of the same product, whose faces line up with the
//! candidate's).
//!
//! The paper has no such step: its masks come from SAM.

use anybox_geom::projection::{project_corners_px, ray_box_intersection};
use anybox_geom::OrientedBox;
use nalgebra::{Point3, Vector3};

use super::boxes::v3;
use super::grid::{jump_tol, Grid};
use super::regions::plane_tol;
use super::DetectConfig;

/// Width of the distance bins along the extended axis, mm.
const BIN_MM: f64 = 10.0;

/// How a cell's depth compares with the surface of an extension of the cuboid.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// Nearer than the surface: an occluder.
    Front,
    /// On the surface (within the plane tolerance).
    On,
    /// Farther than the extension's back: it is seen through.
    Behind,
}

/// Who holds a grid cell, for [`continuation`].
pub(crate) struct Holders<'a> {
    /// Cells never taken in (supports, cells already filled in).
    pub claimed: &'a [bool],
    /// The candidate whose own cells a cell is, `u32::MAX` for none.
    pub owner: &'a [u32],
    /// Own cells per candidate.
    pub sizes: &'a [usize],
}

/// What continues a candidate past an occluder.
#[derive(Default)]
pub(crate) struct Continuation {
    /// Unclaimed cells (unsorted; a cell found along two axes appears twice).
    pub cells: Vec<u32>,
    /// Other candidates lying there: the same box's other piece (in the order found).
    pub absorbed: Vec<usize>,
}

/// What continues `bx`'s faces past an occluder, along any of its axes (see the module doc):
/// unclaimed cells, and other candidates lying there (at least
/// [`DetectConfig::occluded_absorb_fraction`] of their own cells). `me`: the candidate's
/// index in `holders`; `cells`: its cells (for its colour).
pub(crate) fn continuation(
    g: &Grid,
    bx: &OrientedBox,
    me: usize,
    cells: &[u32],
    holders: &Holders,
    cfg: &DetectConfig,
) -> Continuation {
    let mut out = Continuation::default();
    if cfg.occluded_reach_mm <= 0.0 || cells.is_empty() {
        return out;
    }
    // Cheap test first: the candidate's cells with a nearer neighbour (a depth jump towards
    // the camera), which an occluder must give near the end it cuts.
    let edge: Vec<Vector3<f64>> = cells
        .iter()
        .map(|&i| i as usize)
        .filter(|&i| {
            let z = g.z[i];
            let (u, v) = (i % g.w, i / g.w);
            let nearer = |j: usize| g.z[j] > 0.0 && g.z[j] < z - jump_tol(cfg, z);
            (u > 0 && nearer(i - 1))
                || (u + 1 < g.w && nearer(i + 1))
                || (v > 0 && nearer(i - g.w))
                || (v + 1 < g.h && nearer(i + g.w))
        })
        .map(|i| v3(&g.p[i]) - bx.center_mm)
        .collect();
    if edge.len() < 2 {
        return out;
    }
    let tol_c = plane_tol(cfg, bx.center_mm.z.max(1.0));
    for axis in 0..3 {
        // A single face's thickness axis (1 mm) has nothing to extend.
        if bx.size_mm[axis] < 2.0 * tol_c {
            continue;
        }
        let a = bx.axis(axis);
        let half = bx.size_mm[axis] / 2.0;
        let band = (0.2 * bx.size_mm[axis]).max(2.0 * BIN_MM);
        for sign in [-1.0, 1.0] {
            let at_end = edge
                .iter()
                .filter(|p| sign * a.dot(p) >= half - band)
                .count();
            if at_end < 2 {
                continue;
            }
            let found = along(g, bx, axis, sign, me, cells, holders, cfg);
            out.cells.extend(found.cells);
            out.absorbed.extend(found.absorbed);
        }
    }
    // Two axes may find the same cells and candidates: the caller's `fill` dedups cells
    // with the rest of the candidate's, and skips a candidate already absorbed.
    out
}

/// The part of `bx` extended along `axis` (the way of `sign`) that lies from `from_mm` to
/// `to_mm` beyond its end.
fn slab(bx: &OrientedBox, axis: usize, sign: f64, from_mm: f64, to_mm: f64) -> OrientedBox {
    let a = bx.axis(axis);
    let mut size = bx.size_mm;
    size[axis] = to_mm - from_mm;
    OrientedBox {
        center_mm: bx.center_mm + a * sign * (bx.size_mm[axis] / 2.0 + (from_mm + to_mm) / 2.0),
        size_mm: size,
        ..*bx
    }
}

/// Per cell (every `stride`-th each way, within the grid's bounding box of `ext`'s
/// silhouette) whose ray meets `ext` but not `bx`: the cell, its kind, and its distance
/// beyond `bx`'s end along the axis, mm (of its own point when on the surface, else of where
/// its ray enters the extension).
fn classify(
    g: &Grid,
    bx: &OrientedBox,
    ext: &OrientedBox,
    end: &Vector3<f64>,
    a: &Vector3<f64>,
    stride: usize,
    cfg: &DetectConfig,
) -> Vec<(usize, Kind, f64)> {
    let mut out = Vec::new();
    let Some(corners) = project_corners_px(ext, &g.k) else {
        return out;
    };
    let (mut u0, mut v0, mut u1, mut v1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for c in &corners {
        (u0, v0, u1, v1) = (u0.min(c.x), v0.min(c.y), u1.max(c.x), v1.max(c.y));
    }
    if !(u0.is_finite() && v0.is_finite() && u1.is_finite() && v1.is_finite()) {
        return out;
    }
    let clamp = |x: f64, n: usize| x.clamp(0.0, (n - 1) as f64) as usize;
    let (u0, u1) = (clamp(u0.floor(), g.w), clamp(u1.ceil(), g.w));
    let (v0, v1) = (clamp(v0.floor(), g.h), clamp(v1.ceil(), g.h));
    for v in (v0..=v1).step_by(stride) {
        for u in (u0..=u1).step_by(stride) {
            let i = v * g.w + u;
            let z = g.z[i] as f64;
            if z <= 0.0 {
                continue;
            }
            let dir = g.k.ray(u as f64, v as f64);
            let Some((t0, t1, _)) = ray_box_intersection(&Point3::origin(), &dir, ext) else {
                continue;
            };
            // Rays through the cuboid itself see it (or what stands before it), not the
            // extension: an extension going away from the camera hides behind its own box.
            if ray_box_intersection(&Point3::origin(), &dir, bx).is_some() {
                continue;
            }
            let tol = plane_tol(cfg, z);
            let (kind, p) = if z < t0 - tol {
                (Kind::Front, dir * t0)
            } else if z <= t1 + tol {
                (Kind::On, v3(&g.p[i]))
            } else {
                (Kind::Behind, dir * t0)
            };
            out.push((i, kind, a.dot(&(p - end))));
        }
    }
    out
}

/// The continuation along one axis and way, if any.
#[allow(clippy::too_many_arguments)]
fn along(
    g: &Grid,
    bx: &OrientedBox,
    axis: usize,
    sign: f64,
    me: usize,
    cells: &[u32],
    holders: &Holders,
    cfg: &DetectConfig,
) -> Continuation {
    let none = Continuation::default();
    // Whether a cell may be taken: unclaimed, or another candidate's own.
    let free = |i: usize| !holders.claimed[i];
    let other = |i: usize| {
        let o = holders.owner[i];
        (o != u32::MAX && o as usize != me).then_some(o as usize)
    };
    let a = bx.axis(axis) * sign;
    let end = bx.center_mm + a * bx.size_mm[axis] / 2.0;
    // Cheap test first: right past the end, the cells must be mostly in front.
    // Every other cell each way: only the shares count.
    let near = classify(
        g,
        bx,
        &slab(bx, axis, sign, 0.0, 2.0 * BIN_MM),
        &end,
        &a,
        2,
        cfg,
    );
    let front = near.iter().filter(|c| c.1 == Kind::Front).count();
    if (front as f64) < cfg.occluded_min_front * near.len() as f64 || front < 2 {
        return none;
    }
    let reach = cfg.occluded_reach_mm;
    // The bins from every other cell each way too; the run's cells are read again in full.
    let all = classify(g, bx, &slab(bx, axis, sign, 0.0, reach), &end, &a, 2, cfg);
    let n_bins = (reach / BIN_MM).ceil() as usize;
    // Per bin: cells in front, on the surface (free or another candidate's), on it but
    // claimed otherwise, behind.
    let mut bins = vec![[0usize; 4]; n_bins];
    let bin_of = |d: f64| ((d / BIN_MM).floor().max(0.0) as usize).min(n_bins - 1);
    for &(i, kind, d) in &all {
        let k = match kind {
            Kind::Front => 0,
            Kind::On if free(i) || other(i).is_some() => 1,
            Kind::On => 2,
            Kind::Behind => 3,
        };
        bins[bin_of(d)][k] += 1;
    }
    // Occluder, then a run of surface: [start, stop) in bins.
    let mostly = |b: &[usize; 4], k: usize| {
        let n: usize = b.iter().sum();
        n > 0 && b[k] as f64 >= cfg.occluded_min_front * n as f64
    };
    // Before the occluder, cells on the surface but claimed (the candidate's own rim past its
    // fitted end, a support) say nothing of it: with `occluded_lead_skips_claimed` they are
    // left out of the leading bins' shares.
    let lead = |b: &[usize; 4]| {
        if cfg.occluded_lead_skips_claimed {
            [b[0], b[1], 0, b[3]]
        } else {
            *b
        }
    };
    let mut k = 0;
    while k < n_bins && {
        let b = lead(&bins[k]);
        mostly(&b, 0) || b.iter().sum::<usize>() == 0
    } {
        k += 1;
    }
    if k == 0 || k == n_bins || !mostly(&bins[k], 1) {
        return none;
    }
    let start = k;
    while k < n_bins && mostly(&bins[k], 1) {
        k += 1;
    }
    let (lo, hi) = (start as f64 * BIN_MM, k as f64 * BIN_MM);
    let run_cells = classify(g, bx, &slab(bx, axis, sign, lo, hi), &end, &a, 1, cfg);
    let run = run_cells
        .iter()
        .filter(|&&(_, kind, d)| kind == Kind::On && d >= lo && d < hi);
    let mut found = Continuation::default();
    let mut held: std::collections::BTreeMap<usize, usize> = Default::default();
    let mut seen: Vec<u32> = Vec::new();
    for &(i, _, _) in run {
        if free(i) {
            found.cells.push(i as u32);
            seen.push(i as u32);
        } else if let Some(o) = other(i) {
            *held.entry(o).or_default() += 1;
            seen.push(i as u32);
        }
    }
    found.absorbed = held
        .into_iter()
        .filter(|&(o, n)| n as f64 >= cfg.occluded_absorb_fraction * holders.sizes[o] as f64)
        .map(|(o, _)| o)
        .collect();
    seen.retain(|&i| {
        free(i as usize) || other(i as usize).is_some_and(|o| found.absorbed.contains(&o))
    });
    if seen.len() < cfg.occluded_min_cells as usize {
        return none;
    }
    // Of about the colour of the candidate's end next to the occluder.
    let reach_in = (bx.size_mm[axis] / 2.0).min(6.0 * BIN_MM);
    let near_end: Vec<u32> = cells
        .iter()
        .copied()
        .filter(|&i| {
            let d = a.dot(&(v3(&g.p[i as usize]) - end));
            d <= 0.0 && d >= -reach_in
        })
        .collect();
    let mean = |cs: &[u32]| -> Option<Vector3<f64>> {
        if cs.is_empty() {
            return None;
        }
        let s = cs
            .iter()
            .fold(Vector3::zeros(), |s, &i| s + v3(&g.c[i as usize]));
        Some(s / cs.len() as f64)
    };
    // The occluder (the gap's cells in front) of another colour: a nearer thing of the
    // box's own colour may be a carton of the same product in the same stack, whose planes
    // line up with the box's (a pallet's layers), and the run past it another such carton.
    let gap: Vec<u32> = all
        .iter()
        .filter(|&&(_, kind, d)| kind == Kind::Front && d < lo)
        .map(|&(i, _, _)| i as u32)
        .collect();
    // The run may lie in the occluder's shadow: with `occluded_shading`, a darker run's
    // colour is compared at the near end's brightness (at most `occluded_shading_max_ratio`
    // times its own).
    let like = |m0: &Vector3<f64>, m1: &Vector3<f64>| {
        let (b0, b1) = (m0.sum(), m1.sum());
        let ratio = 1.0..=cfg.occluded_shading_max_ratio;
        if cfg.occluded_shading && b1 > 0.0 && ratio.contains(&(b0 / b1)) {
            (m0 - m1 * (b0 / b1)).norm() <= cfg.occluded_colour_max
        } else {
            (m0 - m1).norm() <= cfg.occluded_colour_max
        }
    };
    match (mean(&near_end), mean(&seen), mean(&gap)) {
        (Some(m0), Some(m1), Some(mg))
            if like(&m0, &m1) && (m0 - mg).norm() > cfg.occluded_colour_max =>
        {
            log::debug!(
                "occluded continuation axis {axis} sign {sign} gap {lo:.0} mm to {hi:.0} mm cells {} absorbed {:?}",
                found.cells.len(),
                found.absorbed
            );
            found
        }
        _ => none,
    }
}
