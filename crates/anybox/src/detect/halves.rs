//! Rejoining the two halves of a carton top that its flap seam cuts in two.
//!
//! In: the colour-level regions (labels per cell and their plane fits), the cells that
//! `regions::bridge_tape` moved into a region. Out: the labels with each pair of halves made
//! one region.
//!
//! A carton's flaps meet along the middle of its top, along the long side, and the thin line
//! they leave looks just like the joint between two flush cartons. Locally the two cannot be
//! told apart: on a layer of identical cartons the lines are evenly spaced and alternate, flap
//! seam, joint, flap seam. But a layer ends at a carton's edge. So the halves are found as
//! *chains*: planar patches side by side across their long sides, coplanar, of about the same
//! colour, length, width and position along the line, each at least `halves_min_aspect` times
//! as long as wide (a half of an L × W top with L ≥ W is L × W/2). A chain whose end patch has
//! no coplanar surface beyond its outer side starts at a carton's edge, and its patches pair
//! off from there. Left alone: chains holding a top whose tape was bridged (that carton shows
//! no flap seam, and on a layer of one product neither do the others), chains with no clean
//! end, and chains of odd length with two clean ends.
//!
//! Where the support's up is known, only tops chain (`halves_side_chains`): the fronts of
//! cartons stacked flush, one above the other, chain just as halves do. A top may chain at any
//! aspect (`halves_top_min_aspect`): the flap seam may run along the top's short side, and its
//! halves are then nearly square.
//!
//! Two plain boxes (no flap seam) side by side look the same from above. Where an end face
//! shows, the joint between them runs on down it and a flap seam does not, so two patches
//! whose line is seen on an end face are not linked (`halves_joint_check`), and neither are
//! two whose end face is two colour patches cut at the line (`halves_joint_labels`: the
//! fronts of two cartons, where the joint is too faint to see). Where no end face shows, such
//! a pair is taken for one carton: the image holds nothing that tells them apart.
//!
//! A second pass (`halves_isolated_pairs`) takes the tops the chains miss: a seam along the
//! top's short side, or halves too square for `halves_min_aspect`. There, a layer of cartons
//! gives no order to pair along, so only a pair standing alone is joined: two patches touching
//! along a whole side, each the other's only candidate, with the surface ending beyond all
//! their other sides. Where the support's up is known, it too takes only tops
//! (`halves_isolated_sides`): the fronts of two flush cartons side by side are such a pair.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use super::boxes::{is_face, is_top, robust_range, v3};
use super::grid::Grid;
use super::regions::{compact_labels, plane_tol, Region, NONE};
use super::DetectConfig;

/// What pairing needs of one planar region.
#[derive(Clone)]
struct Half {
    /// Region label.
    label: usize,
    /// Centre of its rectangle, camera frame, mm.
    centre: Vector3<f64>,
    normal: Vector3<f64>,
    /// Unit long in-plane axis.
    long: Vector3<f64>,
    /// Unit in-plane axis across it (`normal × long`).
    across: Vector3<f64>,
    len_mm: f64,
    width_mm: f64,
    colour: Vector3<f64>,
}

/// Joins chained halves (see the module doc) into one region each, relabelling `labels`
/// compactly. `strip`: cells that `bridge_tape` moved into a region. Returns the new number of
/// regions (`regions.len()` when nothing was joined; the caller refits otherwise).
pub(crate) fn pair_halves(
    g: &Grid,
    labels: &mut [u32],
    regions: &[Region],
    strip: &[bool],
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> usize {
    let n = regions.len();
    if cfg.halves_min_aspect <= 0.0 || n < 2 {
        return n;
    }
    let mut cells: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut taped = vec![false; n];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE {
            cells[l as usize].push(i);
            taped[l as usize] |= strip[i];
        }
    }
    // Each untaped face's rectangle, once for the band test and both passes. A patch with a
    // band of tape along its own middle is a whole top (tape runs along a carton's flap
    // seam), not a half whose flap seam is the line beside it.
    let rects = regions
        .iter()
        .enumerate()
        .map(|(l, r)| {
            if taped[l] || !is_face(r, cfg) {
                return None;
            }
            rect_of(g, l, r, &cells[l], cfg).filter(|h| {
                cfg.halves_tape_band_contrast <= 0.0 || !tape_along_middle(g, h, &cells[l], cfg)
            })
        })
        .collect();
    let patches = Patches {
        rects,
        up,
        labels: &*labels,
    };
    let mut parent: Vec<usize> = (0..n).collect();
    let mut joined = patches.pair_chains(g, &mut parent, cfg);
    if cfg.halves_isolated_pairs {
        joined |= patches.pair_isolated(g, &mut parent, cfg);
    }
    if !joined {
        return n;
    }
    // Pairs are disjoint, so every label's root is its parent.
    compact_labels(labels, n, |l| parent[l])
}

/// The colour-level regions both passes pair: each label's rectangle, `None` where it is no
/// face, `bridge_tape` moved cells into it, it has tape along its middle, or it is degenerate.
struct Patches<'a> {
    rects: Vec<Option<Half>>,
    up: Option<Vector3<f64>>,
    /// The colour-level labels per cell (for [`joint_split`]).
    labels: &'a [u32],
}

impl Patches<'_> {
    /// The first pass: elongated halves side by side across their long sides, in chains paired
    /// off from a clean end (see the module doc). Sets `parent` of each pair's second label to
    /// its first; returns whether anything was paired.
    fn pair_chains(&self, g: &Grid, parent: &mut [usize], cfg: &DetectConfig) -> bool {
        let end_tilt = (cfg.halves_end_max_tilt_deg > 0.0)
            .then(|| cfg.halves_end_max_tilt_deg.to_radians().cos());
        let halves: Vec<Half> = self
            .rects
            .iter()
            .flatten()
            .filter(|h| elongated(h, self.up, cfg))
            .cloned()
            .collect();
        if halves.len() < 2 {
            return false;
        }
        // Best neighbour on either side of each half: (index into `halves`, gap error).
        let mut side: Vec<[Option<(usize, f64)>; 2]> = vec![[None, None]; halves.len()];
        for (a, ha) in halves.iter().enumerate() {
            for (b, hb) in halves.iter().enumerate() {
                if a == b {
                    continue;
                }
                if let Some((s, err)) = neighbour(ha, hb, cfg) {
                    if side[a][s].is_none_or(|(_, e)| err < e) {
                        side[a][s] = Some((b, err));
                    }
                }
            }
        }
        // A side whose line is seen running down an end face is a carton's edge: no link there,
        // and a chain ending there ends cleanly.
        let mut joint = vec![[false; 2]; halves.len()];
        if cfg.halves_joint_check {
            for a in 0..halves.len() {
                for s in 0..2 {
                    if let Some((b, _)) = side[a][s] {
                        if self.joint(g, &halves[a], &halves[b], cfg) {
                            joint[a][s] = true;
                            side[a][s] = None;
                        }
                    }
                }
            }
        }
        // Mutual links only: b is a's best on one side and a is b's best on one side.
        let nbrs: Vec<Vec<usize>> = (0..halves.len())
            .map(|a| {
                side[a]
                    .iter()
                    .flatten()
                    .map(|&(b, _)| b)
                    .filter(|&b| side[b].iter().flatten().any(|&(x, _)| x == a))
                    .collect()
            })
            .collect();
        let mut seen = vec![false; halves.len()];
        let mut joined = false;
        for start in 0..halves.len() {
            if seen[start] || nbrs[start].len() != 1 {
                continue;
            }
            // Walk the chain from this end.
            let mut chain = vec![start];
            seen[start] = true;
            let (mut prev, mut cur) = (start, nbrs[start][0]);
            while !seen[cur] {
                seen[cur] = true;
                chain.push(cur);
                let Some(&next) = nbrs[cur].iter().find(|&&x| x != prev) else {
                    break;
                };
                (prev, cur) = (cur, next);
            }
            let k = chain.len();
            let end_clean = |e: usize, inner: usize| {
                let (he, hi) = (&halves[e], &halves[inner]);
                let inward = (hi.centre - he.centre).dot(&he.across);
                // `neighbour`'s side index: 1 = along +across.
                joint[e][usize::from(inward <= 0.0)]
                    || clean_end(
                        g,
                        he,
                        &(-inward.signum() * he.across),
                        end_tilt,
                        cfg.halves_end_max_on_plane,
                        cfg,
                    )
            };
            let first = end_clean(chain[0], chain[1]);
            let last = end_clean(chain[k - 1], chain[k - 2]);
            if log::log_enabled!(log::Level::Debug) {
                let desc: Vec<String> = chain
                    .iter()
                    .map(|&c| {
                        let h = &halves[c];
                        let q = g.k.project(&h.centre.into()).unwrap_or_default() * g.step as f64;
                        format!("({:.0},{:.0} {:.0}x{:.0})", q.x, q.y, h.len_mm, h.width_mm)
                    })
                    .collect();
                log::debug!("halves chain {k} clean {first} {last}: {}", desc.join(" "));
            }
            // Pair off from a clean end (for an even count both ends give the same pairs).
            let order: Vec<usize> = match (k % 2 == 0, first, last) {
                (true, true, _) | (true, false, true) | (false, true, false) => chain,
                (false, false, true) => chain.into_iter().rev().collect(),
                _ => continue,
            };
            for p in order.chunks_exact(2) {
                let (a, b) = (halves[p[0]].label, halves[p[1]].label);
                parent[b] = a;
                joined = true;
            }
        }
        joined
    }

    /// Whether the line between `a` and `b` is seen to be a joint between two cartons: as a
    /// seam running on down an end face ([`joint_seen`]), or, with
    /// [`DetectConfig::halves_joint_labels`], as a cut between two colour patches there
    /// ([`joint_split`]).
    fn joint(&self, g: &Grid, a: &Half, b: &Half, cfg: &DetectConfig) -> bool {
        joint_seen(g, a, b) || (cfg.halves_joint_labels && joint_split(g, self.labels, a, b))
    }

    /// The second pass ([`DetectConfig::halves_isolated_pairs`]): two patches left unpaired, of
    /// any aspect (tops only where up is known: [`DetectConfig::halves_isolated_sides`]),
    /// touching along a whole side (either of their sides), each the other's only such
    /// neighbour, with the surface ending beyond the pair's six other sides. Sets `parent` as
    /// [`Patches::pair_chains`] does; returns whether anything was paired.
    fn pair_isolated(&self, g: &Grid, parent: &mut [usize], cfg: &DetectConfig) -> bool {
        let n = self.rects.len();
        let mut used = vec![false; n];
        for l in 0..n {
            if parent[l] != l {
                used[l] = true;
                used[parent[l]] = true;
            }
        }
        let rects: Vec<Half> = (0..n)
            .filter(|&l| !used[l])
            .filter_map(|l| self.rects[l].clone())
            .filter(|h| cfg.halves_isolated_sides || is_top(&h.normal, self.up, cfg) != Some(false))
            .collect();
        // Every touching pair, with the unit in-plane direction from the first to the second.
        let mut pairs: Vec<(usize, usize, Vector3<f64>)> = Vec::new();
        let mut partners = vec![0usize; rects.len()];
        for a in 0..rects.len() {
            for b in a + 1..rects.len() {
                if let Some(out) = touching(&rects[a], &rects[b], cfg) {
                    pairs.push((a, b, out));
                    partners[a] += 1;
                    partners[b] += 1;
                }
            }
        }
        let mut joined = false;
        for (a, b, out) in pairs {
            if partners[a] != 1 || partners[b] != 1 {
                continue;
            }
            // Each patch as a half whose seam side faces the other: `long` along the seam.
            let (ha, hb) = (seam_frame(&rects[a], &out), seam_frame(&rects[b], &(-out)));
            let ends = |h: &Half, inner: &Vector3<f64>| {
                let side = h.normal.cross(inner);
                let side_ends = |out: &Vector3<f64>| {
                    let (len, width) = (h.len_mm, h.width_mm);
                    surface_ends(g, h, out, len, inner, width, None, PLAIN_ON_PLANE, cfg)
                };
                clean_end(g, h, &-inner, None, PLAIN_ON_PLANE, cfg)
                    && side_ends(&side)
                    && side_ends(&-side)
            };
            let isolated = ends(&ha, &out) && ends(&hb, &-out);
            let joint = cfg.halves_joint_check && self.joint(g, &ha, &hb, cfg);
            if log::log_enabled!(log::Level::Debug) {
                let q =
                    |h: &Half| g.k.project(&h.centre.into()).unwrap_or_default() * g.step as f64;
                let (qa, qb) = (q(&ha), q(&hb));
                let desc = |q: nalgebra::Point2<f64>, h: &Half| {
                    format!("({:.0},{:.0} {:.0}x{:.0})", q.x, q.y, h.len_mm, h.width_mm)
                };
                log::debug!(
                    "halves pair {} {} isolated {isolated} joint {joint}",
                    desc(qa, &ha),
                    desc(qb, &hb)
                );
            }
            if isolated && !joint {
                parent[rects[b].label] = rects[a].label;
                joined = true;
            }
        }
        joined
    }
}

/// Whether `a` and `b` lie in one plane: normals within `perpendicular_tol_deg`, and `b`'s
/// centre within three plane tolerances of `a`'s plane.
fn coplanar(a: &Half, b: &Half, cfg: &DetectConfig) -> bool {
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let tol = plane_tol(cfg, a.centre.z.max(1.0));
    a.normal.dot(&b.normal) >= cos_par && (b.centre - a.centre).dot(&a.normal).abs() <= 3.0 * tol
}

/// Whether `b` touches `a` along a whole side of either (coplanar, about the same colour, the
/// same extent along the shared side and across it, aligned along it, with a gap within
/// `halves_gap_mm` plus the ratio's slack): the unit in-plane direction from `a` to `b`.
fn touching(a: &Half, b: &Half, cfg: &DetectConfig) -> Option<Vector3<f64>> {
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let d = b.centre - a.centre;
    if !coplanar(a, b, cfg) || (a.colour - b.colour).norm() > cfg.tape_colour_delta {
        return None;
    }
    // b's extents along a's axes (near-square patches may have them swapped).
    let (b_long, b_across) = if a.long.dot(&b.long).abs() >= cos_par {
        (b.len_mm, b.width_mm)
    } else if a.long.dot(&b.across).abs() >= cos_par {
        (b.width_mm, b.len_mm)
    } else {
        return None;
    };
    let ratio = |x: f64, y: f64| x.min(y) / x.max(y);
    let slack = 1.0 - cfg.halves_min_ratio;
    let axes = [
        (a.across, a.width_mm, b_across, a.long, a.len_mm, b_long),
        (a.long, a.len_mm, b_long, a.across, a.width_mm, b_across),
    ];
    for (ax, ea, eb, along, fa, fb) in axes {
        if ratio(ea, eb) < cfg.halves_min_ratio
            || ratio(fa, fb) < cfg.halves_min_ratio
            || d.dot(&along).abs() > slack * fa.max(fb)
        {
            continue;
        }
        let gap_err = (d.dot(&ax).abs() - (ea + eb) / 2.0).abs();
        if gap_err <= cfg.halves_gap_mm + slack * (ea + eb) / 2.0 {
            return Some(ax * d.dot(&ax).signum());
        }
    }
    None
}

/// `h` re-framed for a seam on its side facing `towards` (a unit in-plane axis of `h`):
/// `across` = `towards`, `long` along the seam.
fn seam_frame(h: &Half, towards: &Vector3<f64>) -> Half {
    let along_long = h.long.dot(towards).abs() >= h.across.dot(towards).abs();
    let (len_mm, width_mm) = if along_long {
        (h.width_mm, h.len_mm)
    } else {
        (h.len_mm, h.width_mm)
    };
    let across = *towards;
    Half {
        label: h.label,
        centre: h.centre,
        normal: h.normal,
        long: across.cross(&h.normal),
        across,
        len_mm,
        width_mm,
        colour: h.colour,
    }
}

/// Whether a region's rectangle is elongated enough to be a half.
fn elongated(h: &Half, up: Option<Vector3<f64>>, cfg: &DetectConfig) -> bool {
    let min_aspect = match is_top(&h.normal, up, cfg) {
        Some(true) if cfg.halves_top_min_aspect > 0.0 => cfg.halves_top_min_aspect,
        Some(false) if !cfg.halves_side_chains => return false,
        _ => cfg.halves_min_aspect,
    };
    h.len_mm >= min_aspect * h.width_mm
}

/// A planar region as a rectangle along its in-plane principal axes (`long` the longer side);
/// `None` when degenerate.
fn rect_of(
    g: &Grid,
    label: usize,
    r: &Region,
    cells: &[usize],
    cfg: &DetectConfig,
) -> Option<Half> {
    // An even stride of at most 512 points: the quantiles barely move.
    let stride = cells.len().div_ceil(512).max(1);
    let pts: Vec<Vector3<f64>> = cells.iter().step_by(stride).map(|&i| v3(&g.p[i])).collect();
    // In-plane principal axes: along the sides of an elongated rectangle.
    let normal = r.normal;
    let mut cov = Matrix3::zeros();
    for p in &pts {
        let d = p - r.centroid;
        let d = d - normal * d.dot(&normal);
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov);
    let b: Vector3<f64> = eig.eigenvectors.column(eig.eigenvalues.imax()).into_owned();
    let c = normal.cross(&b).try_normalize(1e-9)?;
    let b = c.cross(&normal);
    let range = |ax: &Vector3<f64>| {
        let mut vals: Vec<f64> = pts.iter().map(|p| p.dot(ax)).collect();
        robust_range(&mut vals, cfg.extent_quantile)
    };
    let ((b0, b1), (c0, c1)) = (range(&b), range(&c));
    let (sb, sc) = (b1 - b0, c1 - c0);
    let (long, len_mm, width_mm) = if sb >= sc { (b, sb, sc) } else { (c, sc, sb) };
    if width_mm <= 0.0 {
        return None;
    }
    let centre = normal * normal.dot(&r.centroid) + b * (b0 + b1) / 2.0 + c * (c0 + c1) / 2.0;
    Some(Half {
        label,
        centre,
        normal,
        long,
        across: normal.cross(&long),
        len_mm,
        width_mm,
        colour: Vector3::from(r.colour),
    })
}

/// Whether the patch `h` (its `cells`) shows a band of another colour along the middle of its
/// long axis over its whole length: in each quarter of its length, the cells within a tenth
/// of its width of the centre line differ in mean colour from those beyond a quarter of its
/// width by at least `halves_tape_band_contrast` (RGB levels), with at least 4 cells in each.
fn tape_along_middle(g: &Grid, h: &Half, cells: &[usize], cfg: &DetectConfig) -> bool {
    let mut sums = [[(Vector3::<f64>::zeros(), 0usize); 2]; 4];
    for &i in cells {
        let d = v3(&g.p[i]) - h.centre;
        let (x, y) = (
            d.dot(&h.long) / h.len_mm + 0.5,
            d.dot(&h.across) / h.width_mm,
        );
        let q = (x * 4.0).floor();
        if !(0.0..4.0).contains(&q) {
            continue;
        }
        let band = if y.abs() < 0.1 {
            0
        } else if y.abs() > 0.25 {
            1
        } else {
            continue;
        };
        let c = g.c[i];
        let s = &mut sums[q as usize][band];
        s.0 += Vector3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        s.1 += 1;
    }
    sums.iter().all(|[(m, nm), (o, no)]| {
        *nm >= 4
            && *no >= 4
            && (m / *nm as f64 - o / *no as f64).norm() >= cfg.halves_tape_band_contrast
    })
}

/// Whether `b` lies beside `a` across one of `a`'s long sides as its possible other half:
/// the side (0 or 1) and how far the gap between them is from a touching pair, mm.
fn neighbour(a: &Half, b: &Half, cfg: &DetectConfig) -> Option<(usize, f64)> {
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let d = b.centre - a.centre;
    if !coplanar(a, b, cfg) || a.long.dot(&b.long).abs() < cos_par {
        return None;
    }
    let ratio = |x: f64, y: f64| x.min(y) / x.max(y);
    let slack = 1.0 - cfg.halves_min_ratio;
    if ratio(a.len_mm, b.len_mm) < cfg.halves_min_ratio
        || ratio(a.width_mm, b.width_mm) < cfg.halves_min_ratio
        || (a.colour - b.colour).norm() > cfg.tape_colour_delta
        || d.dot(&a.long).abs() > slack * a.len_mm.max(b.len_mm)
    {
        return None;
    }
    let across = d.dot(&a.across);
    let err = (across.abs() - (a.width_mm + b.width_mm) / 2.0).abs();
    if err > cfg.halves_gap_mm + slack * (a.width_mm + b.width_mm) / 2.0 {
        return None;
    }
    Some((usize::from(across > 0.0), err))
}

/// Grid bounds `(u0, u1, v0, v1)` of the slab around the line between `a` and `b` (in `a`'s
/// frame): `half_across_mm` either side of it, the longer half's length plus 30 mm, down to
/// 150 mm below the top; `None` where a corner lies behind the camera.
fn end_slab(
    g: &Grid,
    a: &Half,
    b: &Half,
    half_across_mm: f64,
) -> Option<(usize, usize, usize, usize)> {
    let m = (a.centre + b.centre) / 2.0;
    let half_len = a.len_mm.max(b.len_mm) / 2.0;
    let (mut u0, mut v0, mut u1, mut v1) = (f64::INFINITY, f64::INFINITY, 0f64, 0f64);
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for dz in [0.0, -150.0] {
                let p = m
                    + a.across * (half_across_mm * sx)
                    + a.long * ((half_len + 30.0) * sy)
                    + a.normal * dz;
                let q = g.k.project(&p.into()).filter(|_| p.z > 1.0)?;
                (u0, v0, u1, v1) = (u0.min(q.x), v0.min(q.y), u1.max(q.x), v1.max(q.y));
            }
        }
    }
    let clamp = |x: f64, n: usize| x.clamp(0.0, n as f64 - 1.0) as usize;
    Some((
        clamp(u0, g.w),
        clamp(u1, g.w),
        clamp(v0, g.h),
        clamp(v1, g.h),
    ))
}

/// Whether the line between halves `a` and `b` is seen to be the joint of two cartons: where
/// it meets an end face (perpendicular to the long axis, below the top), a seam runs on down
/// that face along the line: at least 4 cells of the face within 10 mm of the line, at least
/// 30 % of them seam cells, and twice the seam fraction of the face 10–25 mm to either side
/// (print and labels darken both alike). A flap seam stops at the top's edge.
fn joint_seen(g: &Grid, a: &Half, b: &Half) -> bool {
    let m = (a.centre + b.centre) / 2.0;
    let (across, long, up) = (a.across, a.long, a.normal);
    let half_len = a.len_mm.max(b.len_mm) / 2.0;
    let Some((u0, u1, v0, v1)) = end_slab(g, a, b, 25.0) else {
        return false;
    };
    // Cells and seam cells on the line (0) and beside it (1).
    let mut count = [[0usize; 2]; 2];
    for v in v0..=v1 {
        for u in u0..=u1 {
            let i = v * g.w + u;
            if g.z[i] <= 0.0 {
                continue;
            }
            let n = v3(&g.n[i]);
            let d = v3(&g.p[i]) - m;
            let below = -d.dot(&up);
            let off = d.dot(&across).abs();
            if n.dot(&long).abs() < 0.7
                || off > 25.0
                || !(5.0..=150.0).contains(&below)
                || (d.dot(&long).abs() - half_len).abs() > 30.0
            {
                continue;
            }
            let k = usize::from(off > 10.0);
            count[k][0] += 1;
            count[k][1] += g.seam[i] as usize;
        }
    }
    let frac = |[n, s]: [usize; 2]| s as f64 / n.max(1) as f64;
    count[0][0] >= 4 && frac(count[0]) >= 0.3 && frac(count[0]) >= 2.0 * frac(count[1])
}

/// Whether an end face of the pair `a`, `b` (a face along the line between them, 5–150 mm
/// below their plane, at either end of the line) is two colour patches cut at the line: of
/// its cells 15 mm to 0.8 of the narrower half's width from the line, those on each side
/// number at least 40 and a quarter of the other side's, are mostly (≥ 60 %) of one label,
/// and the two labels differ, each under a tenth of the other side's cells. A carton's own
/// flap seam stops at the top's edge, and the face below it is one patch.
fn joint_split(g: &Grid, labels: &[u32], a: &Half, b: &Half) -> bool {
    let m = (a.centre + b.centre) / 2.0;
    let (across, long, up) = (a.across, a.long, a.normal);
    let half_len = a.len_mm.max(b.len_mm) / 2.0;
    let reach = 0.8 * a.width_mm.min(b.width_mm);
    if reach <= 15.0 {
        return false;
    }
    let Some((u0, u1, v0, v1)) = end_slab(g, a, b, reach) else {
        return false;
    };
    // Label counts per end (−long, +long) and side (−across, +across).
    let mut counts: [[Vec<(u32, usize)>; 2]; 2] = Default::default();
    for v in v0..=v1 {
        for u in u0..=u1 {
            let i = v * g.w + u;
            if g.z[i] <= 0.0 || labels[i] == NONE {
                continue;
            }
            let n = v3(&g.n[i]);
            let d = v3(&g.p[i]) - m;
            let along = d.dot(&long);
            let off = d.dot(&across);
            if n.dot(&long).abs() < 0.7
                || !(15.0..=reach).contains(&off.abs())
                || !(5.0..=150.0).contains(&-d.dot(&up))
                || (along.abs() - half_len).abs() > 30.0
            {
                continue;
            }
            let c = &mut counts[usize::from(along > 0.0)][usize::from(off > 0.0)];
            match c.iter_mut().find(|(l, _)| *l == labels[i]) {
                Some(e) => e.1 += 1,
                None => c.push((labels[i], 1)),
            }
        }
    }
    let total = |c: &[(u32, usize)]| c.iter().map(|e| e.1).sum::<usize>();
    let dominant = |c: &[(u32, usize)]| {
        c.iter()
            .max_by_key(|e| e.1)
            .filter(|e| total(c) >= 40 && e.1 as f64 >= 0.6 * total(c) as f64)
            .map(|e| e.0)
    };
    // Cells of label `l` on side `c`.
    let of = |c: &[(u32, usize)], l: u32| c.iter().find(|e| e.0 == l).map_or(0, |e| e.1);
    counts.iter().any(|[lo, hi]| {
        let (a, b) = (total(lo), total(hi));
        let (Some(x), Some(y)) = (dominant(lo), dominant(hi)) else {
            return false;
        };
        // Cut at the line: neither side's patch reaches across it.
        4 * a.min(b) >= a.max(b) && x != y && 10 * of(hi, x) < b && 10 * of(lo, y) < a
    })
}

/// The share of the points past a side that may lie on the plane where the plane ends
/// there, outside chain ends (see [`DetectConfig::halves_end_max_on_plane`]).
const PLAIN_ON_PLANE: f64 = 1.0 / 3.0;

/// Whether the surface beyond half `h`, in direction `out` (in its plane), ends: fewer than
/// `max_on_plane` of nine points along its outer side, just beyond it, lie on `h`'s plane.
/// Points outside the frame count for neither; with fewer than five inside, the end is not
/// clean. With `max_tilt_cos`, a point counts as on the plane only where its cell's normal
/// (when known) is within that cosine of the plane's: see
/// [`DetectConfig::halves_end_max_tilt_deg`].
fn clean_end(
    g: &Grid,
    h: &Half,
    out: &Vector3<f64>,
    max_tilt_cos: Option<f64>,
    max_on_plane: f64,
    cfg: &DetectConfig,
) -> bool {
    surface_ends(
        g,
        h,
        out,
        h.width_mm,
        &h.long,
        h.len_mm,
        max_tilt_cos,
        max_on_plane,
        cfg,
    )
}

/// Whether `h`'s plane ends beyond its side facing `out`, where `h` extends `extent_mm` along
/// `out`: as in [`clean_end`], over nine points along `along` spanning 0.7 of `side_mm`, at
/// `extent_mm / 2` plus `halves_gap_mm` (at least a quarter of `extent_mm`) from its centre.
fn surface_ends(
    g: &Grid,
    h: &Half,
    out: &Vector3<f64>,
    extent_mm: f64,
    along: &Vector3<f64>,
    side_mm: f64,
    max_tilt_cos: Option<f64>,
    max_on_plane: f64,
    cfg: &DetectConfig,
) -> bool {
    let reach = extent_mm / 2.0 + cfg.halves_gap_mm.max(0.25 * extent_mm);
    let tol = plane_tol(cfg, h.centre.z.max(1.0));
    let (mut n, mut on_plane) = (0usize, 0usize);
    for k in 0..9 {
        let t = (k as f64 / 8.0 - 0.5) * 0.7 * side_mm;
        let p = h.centre + out * reach + along * t;
        let Some(i) = g.cell_at(&p) else {
            continue;
        };
        n += 1;
        // A face beyond the edge, seen past it, can lie within the tolerance of the plane
        // (the front below a top's near edge): it is no continuation of the plane.
        let nc = v3(&g.n[i]);
        let parallel =
            max_tilt_cos.is_none_or(|c| nc.norm_squared() < 0.25 || nc.dot(&h.normal).abs() >= c);
        if g.z[i] > 0.0 && parallel && (v3(&g.p[i]) - h.centre).dot(&h.normal).abs() <= 3.0 * tol {
            on_plane += 1;
        }
    }
    n >= 5 && (on_plane as f64) < max_on_plane * n as f64
}
