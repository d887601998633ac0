//! Cutting planar colour patches at faint straight seams, found in their luminance profile.
//!
//! In: the colour-level labels after `lines`, the grid (cell points, the full-resolution
//! image), "up". Out: the labels with a side face's patch cut where a thin dark line runs
//! straight across all of it along one of its edge directions, and the cells beside each cut
//! (they become seam cells: `select`'s evidence that a coarse candidate is several cartons).
//!
//! The joint between two flush cartons is a pair of creased, darkened edges a few millimetres
//! wide. On a face in shade, or beyond about 1.5 m where it is under two pixels wide, its
//! per-pixel valleys sink into the sensor noise (`grid::seams` finds a few dashes of it or
//! nothing), and one patch spans two stacked cartons. Averaged along the line over the whole
//! patch, the dip stands out:
//! - each patch's pixels are put on its plane and binned by their distance across the line
//!   (bins one pixel wide, at least `profile_seam_bin_mm`);
//! - a joint runs along a carton face's edges, so only the two edge directions of the patch's
//!   smallest enclosing rectangle on its plane are tried, each turned by up to 2° (the
//!   rectangle of a noisy, partly hidden patch is that far off, and 2° smear a seam over
//!   10 mm on a 300 mm face); the pixels are binned once per direction, in 16 segments
//!   along it, and a turned line's profile is those segments' profiles shifted (a shear;
//!   binning every turned line afresh cost 2.4 times as many instructions, for 0.001 more
//!   mean AP@0.5 on the 48-view bench);
//! - a bin is a seam when its mean luminance lies below the mean of the bins a few
//!   millimetres to either side (`profile_seam_min_dip`, `profile_seam_min_rel`) and below
//!   both (a joint between cartons of two tones is a dip on a step; a plain step is not a
//!   seam), by `profile_seam_min_z` times the profile's own roughness (grain and print make
//!   every bin a small dip or bump);
//! - the dip must show in `profile_seam_quarters` of the line's four quarters (print, labels
//!   and stains do not run the patch's whole length), and must not change the colour's
//!   chromaticity (`profile_seam_max_chroma`: a joint is a shadowed crease, a printed stripe
//!   is another colour).
//!
//! Tops (normal within `profile_seam_top_deg` of up) are left alone: a carton's own flap seam
//! runs straight across its top as a joint does, and only the whole scene (`halves`) tells
//! them apart.

use nalgebra::Vector3;
use rayon::prelude::*;

use anybox_io::RgbImage;

use super::grid::Grid;
use super::regions::{plane_tol, Region, NONE};
use super::DetectConfig;

/// Turns of each edge direction tried, degrees.
const TURNS_DEG: [f64; 5] = [-2.0, -1.0, 0.0, 1.0, 2.0];

/// Cuts the patches of `labels` (values below `n`, the patches' plane fits `regions[..n]`) at
/// faint seams (see the module doc) in `rgb` (the frame's image, the grid's frame size; none:
/// no cut). Returns the new number of labels (new pieces are numbered from `n` on) and the
/// cells beside the cuts.
pub(crate) fn cut_at_faint_seams(
    g: &Grid,
    rgb: Option<&RgbImage>,
    labels: &mut [u32],
    regions: &[Region],
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> (usize, Vec<u32>) {
    let n = regions.len();
    let Some(up) = up else {
        return (n, Vec::new());
    };
    let Some(img) = rgb else {
        return (n, Vec::new());
    };
    if cfg.profile_seam_min_dip <= 0.0 || n == 0 {
        return (n, Vec::new());
    }
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (i, &l) in labels.iter().enumerate() {
        if l != NONE && (l as usize) < n {
            cells[l as usize].push(i as u32);
        }
    }
    let min_piece = cfg.min_region_cells.max(3) as usize;
    let cuts: Vec<Option<Vec<u32>>> = cells
        .par_iter()
        .zip(regions)
        .map(|(c, r)| {
            if c.len() < 2 * min_piece {
                None
            } else {
                cut_patch(g, img, c, r, min_piece, &up, cfg)
            }
        })
        .collect();
    let mut next = n as u32;
    let mut seam = Vec::new();
    for (l, cut) in cuts.iter().enumerate() {
        let Some(piece) = cut else { continue };
        let k = piece.iter().copied().max().unwrap_or(0);
        let base = next;
        next += k;
        let label_of = |p: u32| if p == 0 { l as u32 } else { base + p - 1 };
        for (&c, &p) in cells[l].iter().zip(piece) {
            labels[c as usize] = label_of(p);
        }
        let mine = |x: u32| x == l as u32 || (base..next).contains(&x);
        for &c in &cells[l] {
            let i = c as usize;
            let (u, v) = (i % g.w, i / g.w);
            let nbrs = [
                (u > 0).then(|| i - 1),
                (u + 1 < g.w).then(|| i + 1),
                (v > 0).then(|| i - g.w),
                (v + 1 < g.h).then(|| i + g.w),
            ];
            if nbrs
                .into_iter()
                .flatten()
                .any(|j| mine(labels[j]) && labels[j] != labels[i])
            {
                seam.push(c);
            }
        }
    }
    (next as usize, seam)
}

/// A seam found across one patch: its direction across the line, its offset from the patch's
/// centroid along that direction (mm) and its strength (the mean dip of its quarters, levels).
#[derive(Clone, Copy)]
struct Seam {
    across: [f64; 2],
    offset: f64,
    strength: f64,
    /// Bin width of its profile, mm.
    bw: f64,
}

/// The piece (0 = uncut) of each of `cells`, or `None` when the patch is not cut.
fn cut_patch(
    g: &Grid,
    img: &RgbImage,
    cells: &[u32],
    region: &Region,
    min_piece: usize,
    up: &Vector3<f64>,
    cfg: &DetectConfig,
) -> Option<Vec<u32>> {
    let pt = |i: u32| {
        let p = g.p[i as usize];
        Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    };
    let (centroid, normal) = (region.centroid, region.normal);
    // A top: its flap seam is as straight and as long as a joint (left to `halves`).
    if normal.dot(up).abs() >= cfg.profile_seam_top_deg.to_radians().cos() {
        return None;
    }
    if region.inlier_frac < cfg.min_plane_inlier_frac {
        return None;
    }
    let e1 = -crate::hypotheses::any_perpendicular(&normal).normalize();
    let e2 = normal.cross(&e1);
    let ab: Vec<[f64; 2]> = cells
        .iter()
        .map(|&i| {
            let d = pt(i) - centroid;
            [d.dot(&e1), d.dot(&e2)]
        })
        .collect();
    let theta = rectangle_angle(&ab);

    // Every pixel of the patch on its plane: (a, b) in the e1/e2 frame, R, G, B.
    let s = g.step as f64;
    let off = (s - 1.0) / 2.0;
    let (fx, fy) = (g.k.fx * s, g.k.fy * s);
    let (cx, cy) = (g.k.cx * s + off, g.k.cy * s + off);
    let plane_d = normal.dot(&centroid);
    // The seam cells beside the patch too (no patch holds them): where `grid::seams` saw
    // stretches of the line, only they hold its dark pixels.
    let mut beside: Vec<u32> = Vec::new();
    for &c in cells {
        let i = c as usize;
        let (u, v) = (i % g.w, i / g.w);
        for (du, dv) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
            let (uu, vv) = (u as i64 + du, v as i64 + dv);
            if uu < 0 || vv < 0 || uu >= g.w as i64 || vv >= g.h as i64 {
                continue;
            }
            let j = vv as usize * g.w + uu as usize;
            if g.seam[j]
                && g.z[j] > 0.0
                && (pt(j as u32) - centroid).dot(&normal).abs() <= plane_tol(cfg, g.z[j] as f64)
            {
                beside.push(j as u32);
            }
        }
    }
    beside.sort_unstable();
    beside.dedup();
    // Millimetres per pixel along `d` (unit, on the plane) at the centroid: the bins are one
    // pixel wide across the line.
    let mm_per_px = |d: &Vector3<f64>| {
        let z = centroid.z;
        let du = fx * (d.x * z - centroid.x * d.z) / (z * z);
        let dv = fy * (d.y * z - centroid.y * d.z) / (z * z);
        1.0 / du.hypot(dv).max(1e-6)
    };
    let max_turn = TURNS_DEG
        .iter()
        .fold(0.0f64, |m, t| m.max(t.abs()))
        .to_radians();
    // The two edge directions, each binned in one pass over the pixels.
    let mut binned: [Option<Binned>; 2] = [0, 1].map(|axis| {
        let base = theta + axis as f64 * std::f64::consts::FRAC_PI_2;
        let bw = mm_per_px(&(e1 * base.cos() + e2 * base.sin())).max(cfg.profile_seam_bin_mm);
        Binned::new(&ab, base, bw, max_turn, cfg)
    });
    if binned.iter().all(Option::is_none) {
        return None;
    }
    let (fw, fh, raw) = (img.width() as usize, img.height() as usize, img.as_raw());
    for &c in cells.iter().chain(&beside) {
        let (gu, gv) = (c as usize % g.w, c as usize / g.w);
        for v in gv * g.step..((gv + 1) * g.step).min(fh) {
            for u in gu * g.step..((gu + 1) * g.step).min(fw) {
                let ray = Vector3::new((u as f64 - cx) / fx, (v as f64 - cy) / fy, 1.0);
                let den = normal.dot(&ray);
                if den.abs() < 1e-6 {
                    continue;
                }
                let t = plane_d / den;
                if t <= 0.0 {
                    continue;
                }
                let d = ray * t - centroid;
                let c = &raw[3 * (v * fw + u)..3 * (v * fw + u) + 3];
                let p = [
                    d.dot(&e1),
                    d.dot(&e2),
                    c[0] as f64,
                    c[1] as f64,
                    c[2] as f64,
                ];
                for b in binned.iter_mut().flatten() {
                    b.add(&p);
                }
            }
        }
    }

    let mut piece = vec![0u32; cells.len()];
    let mut mult = 1u32;
    for binned in binned.iter().flatten() {
        let mut found: Vec<Seam> = TURNS_DEG
            .iter()
            .flat_map(|t| profile_seams(binned, &ab, t.to_radians(), cfg))
            .collect();
        found.sort_by(|x, y| y.strength.total_cmp(&x.strength));
        // Strongest first; one seam per place, and no piece under `min_piece` cells.
        let mut kept: Vec<Seam> = Vec::new();
        for sm in found {
            if kept
                .iter()
                .any(|k| (k.offset - sm.offset).abs() < 4.0 * sm.bw)
            {
                continue;
            }
            let mut trial = kept.clone();
            trial.push(sm);
            let idx: Vec<usize> = ab.iter().map(|p| side_index(&trial, p)).collect();
            let mut count = vec![0usize; trial.len() + 1];
            for &k in &idx {
                count[k] += 1;
            }
            if count.iter().all(|&c| c >= min_piece) {
                kept = trial;
            }
        }
        if kept.is_empty() {
            continue;
        }
        for k in &kept {
            log::debug!(
                "faint seam: patch of {} cells cut {:.0} mm from its centroid, dip {:.1} levels, bins {:.1} mm",
                cells.len(),
                k.offset,
                k.strength,
                k.bw
            );
        }
        for (p, q) in piece.iter_mut().zip(&ab) {
            *p += side_index(&kept, q) as u32 * mult;
        }
        mult *= kept.len() as u32 + 1;
    }
    if mult == 1 {
        return None;
    }
    // Compact the piece numbers, in order of first appearance (piece 0 keeps the label).
    let mut map = std::collections::HashMap::new();
    for p in piece.iter_mut() {
        let next = map.len() as u32;
        *p = *map.entry(*p).or_insert(next);
    }
    Some(piece)
}

/// How many of `seams` a point at `p` (mm, plane frame) lies beyond.
fn side_index(seams: &[Seam], p: &[f64; 2]) -> usize {
    seams
        .iter()
        .filter(|s| p[0] * s.across[0] + p[1] * s.across[1] > s.offset)
        .count()
}

/// The angle (radians, in 0..π/2) of the smallest-area rectangle holding `pts`, in 1° steps,
/// on at most 400 of them (an even stride), measured on their convex hull.
fn rectangle_angle(pts: &[[f64; 2]]) -> f64 {
    let stride = pts.len() / 400 + 1;
    // Only the hull's corners reach a rectangle's sides.
    let sample: Vec<nalgebra::Vector2<f64>> = pts
        .iter()
        .step_by(stride)
        .map(|p| nalgebra::Vector2::new(p[0], p[1]))
        .collect();
    let hull = crate::hypotheses::convex_hull_2d(&sample);
    let mut best = (f64::INFINITY, 0.0);
    for deg in 0..90 {
        let a = (deg as f64).to_radians();
        let (c, s) = (a.cos(), a.sin());
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &hull {
            let x = p[0] * c + p[1] * s;
            let y = -p[0] * s + p[1] * c;
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        let area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
        if area < best.0 {
            best = (area, a);
        }
    }
    best.1
}

/// Segments of a line's length that are binned apart: the profiles of the turned lines are
/// these segments' profiles shifted by their offsets (a shear; within a segment of a 300 mm
/// face a 2° turn moves the line by 0.7 mm, under any bin).
const SEGMENTS: usize = 16;

/// A patch's pixels binned across one edge direction: bins `bw` mm wide from `s0` (mm from
/// the centroid), each in `SEGMENTS` equal segments of the length along it (`q0` + k ·
/// `qseg`), with luminance and colour sums and counts.
struct Binned {
    angle: f64,
    /// Unit vectors across and along the line (plane frame).
    across: [f64; 2],
    along: [f64; 2],
    bw: f64,
    s0: f64,
    nb: usize,
    q0: f64,
    qseg: f64,
    /// Per segment and bin (segment-major): luminance sum, count, R, G, B sums.
    lum: Vec<f64>,
    cnt: Vec<u32>,
    rgb: Vec<[f64; 3]>,
}

impl Binned {
    /// Empty bins across direction `angle` (radians in the plane frame) over the cells' (`ab`)
    /// extent. `None` when the patch is under 12 or over 2048 bins across, too narrow for two
    /// pieces, or under 4 bins long.
    fn new(
        ab: &[[f64; 2]],
        angle: f64,
        bw: f64,
        max_turn: f64,
        cfg: &DetectConfig,
    ) -> Option<Binned> {
        let (across, along) = ([angle.cos(), angle.sin()], [-angle.sin(), angle.cos()]);
        let (mut smin, mut smax, mut qmin, mut qmax) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in ab {
            let (s, q) = (dot(p, across), dot(p, along));
            (smin, smax) = (smin.min(s), smax.max(s));
            (qmin, qmax) = (qmin.min(q), qmax.max(q));
        }
        let nb = ((smax - smin) / bw).ceil() as usize + 1;
        // A seam lies `profile_seam_min_piece_mm` inside either end, across this line or
        // one turned by up to `max_turn` (which widens it by at most its length × sin).
        let widest = smax - smin + (qmax - qmin) * max_turn.sin();
        if !(12..=2048).contains(&nb)
            || qmax - qmin < 4.0 * bw
            || widest < 2.0 * cfg.profile_seam_min_piece_mm
        {
            return None;
        }
        Some(Binned {
            angle,
            across,
            along,
            bw,
            s0: smin,
            nb,
            q0: qmin,
            qseg: (qmax - qmin) / SEGMENTS as f64,
            lum: vec![0.0; SEGMENTS * nb],
            cnt: vec![0; SEGMENTS * nb],
            rgb: vec![[0.0; 3]; SEGMENTS * nb],
        })
    }

    /// Adds a pixel `p` ([a, b] on the plane (mm), R, G, B) to its bin, if it has one.
    fn add(&mut self, p: &[f64; 5]) {
        // Truncation is the floor of a value ≥ 0, without a call to `floor` (x86-64's
        // baseline has no rounding instruction); NaN lands in bin 0 and segment 0, as a
        // NaN floor cast to an integer did.
        let x = (dot(p, self.across) - self.s0) / self.bw;
        if x < 0.0 || x >= self.nb as f64 {
            return;
        }
        let y = (dot(p, self.along) - self.q0) / self.qseg;
        let k = if y >= 0.0 {
            (y as usize).min(SEGMENTS - 1)
        } else {
            0
        };
        let i = k * self.nb + x as usize;
        self.lum[i] += (p[2] + p[3] + p[4]) / 3.0;
        self.cnt[i] += 1;
        for c in 0..3 {
            self.rgb[i][c] += p[2 + c];
        }
    }
}

/// `p`'s first two coordinates dotted with `d`.
fn dot(p: &[f64], d: [f64; 2]) -> f64 {
    p[0] * d[0] + p[1] * d[1]
}

/// Seams across the line turned by `turn` (radians) from `b`'s direction: dips in its
/// luminance profile, at least `profile_seam_min_piece_mm` from the ends of the cells `ab`,
/// of the sides' chromaticity (see the module doc).
fn profile_seams(b: &Binned, ab: &[[f64; 2]], turn: f64, cfg: &DetectConfig) -> Vec<Seam> {
    let angle = b.angle + turn;
    let across = [angle.cos(), angle.sin()];
    let bw = b.bw;
    // Segment k's bins move by its offset along the line × sin(turn).
    let shift = |k: usize| ((b.q0 + (k as f64 + 0.5) * b.qseg) * turn.sin() / bw).round() as i64;
    let pad = (0..SEGMENTS)
        .map(|k| shift(k).unsigned_abs())
        .max()
        .unwrap_or(0) as usize;
    let nb = b.nb + 2 * pad;
    let offset: [usize; SEGMENTS] = std::array::from_fn(|k| (shift(k) + pad as i64) as usize);
    // The whole line's luminance sums and counts per bin. The quarters' (of the line's
    // length) and the colour sums are taken for the few bins that get that far.
    let mut sum = vec![0f64; nb];
    let mut cnt = vec![0u32; nb];
    for (k, &d) in offset.iter().enumerate() {
        let row = k * b.nb..(k + 1) * b.nb;
        let dst = sum[d..d + b.nb].iter_mut().zip(&mut cnt[d..d + b.nb]);
        for ((s, c), (&l, &n)) in dst.zip(b.lum[row.clone()].iter().zip(&b.cnt[row])) {
            *s += l;
            *c += n;
        }
    }
    // Segment k's bin that lands on bin `j` of the turned line.
    let source = |k: usize, j: usize| -> Option<usize> {
        let src = j.checked_sub(offset[k])?;
        (src < b.nb).then_some(k * b.nb + src)
    };
    // Bin `j`'s sum and count over quarter `q` (0..4) of the line, or over all of it (4).
    let bin = |j: usize, q: usize| -> (f64, u32) {
        if q == 4 {
            return (sum[j], cnt[j]);
        }
        let per = SEGMENTS / 4;
        (q * per..(q + 1) * per)
            .filter_map(|k| source(k, j))
            .fold((0.0, 0), |(s, c), i| (s + b.lum[i], c + b.cnt[i]))
    };
    let colour = |j: usize| -> [f64; 3] {
        (0..SEGMENTS)
            .filter_map(|k| source(k, j))
            .fold([0.0; 3], |a, i| {
                let c = &b.rgb[i];
                [a[0] + c[0], a[1] + c[1], a[2] + c[2]]
            })
    };
    let smin_bins = b.s0 - pad as f64 * bw;
    let mean = |lo: usize, hi: usize, k: usize| -> Option<f64> {
        let (s, c) = (lo..=hi).fold((0.0, 0u32), |(s, c), j| {
            let (bs, bc) = bin(j, k);
            (s + bs, c + bc)
        });
        (c >= 3).then(|| s / c as f64)
    };
    let margin = cfg.profile_seam_min_piece_mm;
    // The profile's own roughness: the spread (1.4826 × median absolute deviation) of the
    // dip statistic over all its bins. Grain, print and noise make a rough profile; a seam is
    // an outlier of it.
    let dips: Vec<f64> = (3..nb - 3)
        .filter_map(|j| {
            let v = mean(j, j, 4)?;
            Some(0.5 * (mean(j - 3, j - 2, 4)? + mean(j + 2, j + 3, 4)?) - v)
        })
        .collect();
    // Nothing as deep as the least dip asked for: no seam, and no roughness needed.
    let floor = cfg.profile_seam_min_dip.max(0.0);
    if dips.len() < 8 || !dips.iter().any(|&d| d >= floor) {
        return Vec::new();
    }
    // The cells' extent across the turned line, for the margins.
    let (mut smin, mut smax) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in ab {
        let s = dot(p, across);
        (smin, smax) = (smin.min(s), smax.max(s));
    }
    let med = crate::observation::median(dips.clone());
    let dev: Vec<f64> = dips.iter().map(|d| (d - med).abs()).collect();
    let rough = 1.4826 * crate::observation::median(dev);
    let mut out = Vec::new();
    for j in 3..nb - 3 {
        let sj = smin_bins + (j as f64 + 0.5) * bw;
        if sj - smin < margin || smax - sj < margin {
            continue;
        }
        let (Some(val), Some(l1), Some(r1)) =
            (mean(j, j, 4), mean(j - 1, j - 1, 4), mean(j + 1, j + 1, 4))
        else {
            continue;
        };
        // A local minimum of the whole profile.
        if val > l1 || val > r1 {
            continue;
        }
        let (Some(left), Some(right)) = (mean(j - 3, j - 2, 4), mean(j + 2, j + 3, 4)) else {
            continue;
        };
        // The mean of the two sides: a joint between cartons of two tones is a dip on a
        // step, and a plain step (a print's edge) has its middle there.
        let reference = 0.5 * (left + right);
        let thr = cfg
            .profile_seam_min_dip
            .max(cfg.profile_seam_min_rel * reference);
        let dip = reference - val;
        let z = (dip - med) / rough.max(1e-6);
        // Below both sides: a sharp step puts its edge bin on its dark side, half the step
        // below the mean of the two.
        if dip < thr || z < cfg.profile_seam_min_z || left.min(right) - val < 0.5 * dip {
            continue;
        }
        // A joint is a shadowed crease: it darkens the carton's own colour. A printed stripe
        // (a coloured band) changes it.
        let chroma = |bins: &[usize]| {
            let c = bins.iter().fold([0.0; 3], |a, &b| {
                let cb = colour(b);
                [a[0] + cb[0], a[1] + cb[1], a[2] + cb[2]]
            });
            let t = (c[0] + c[1] + c[2]).max(1e-9);
            [c[0] / t, c[1] / t, c[2] / t]
        };
        let (cj, cs) = (chroma(&[j]), chroma(&[j - 3, j - 2, j + 2, j + 3]));
        if (0..3).any(|c| (cj[c] - cs[c]).abs() > cfg.profile_seam_max_chroma) {
            continue;
        }
        // Along the line: each quarter's dip, a bin either way allowed.
        let (mut valid, mut pass, mut sum_dip) = (0, 0, 0.0);
        for k in 0..4 {
            let vals = [mean(j - 1, j - 1, k), mean(j, j, k), mean(j + 1, j + 1, k)];
            let (Some(l), Some(r)) = (mean(j - 3, j - 2, k), mean(j + 2, j + 3, k)) else {
                continue;
            };
            let Some(v) = vals.iter().flatten().copied().reduce(f64::min) else {
                continue;
            };
            valid += 1;
            sum_dip += 0.5 * (l + r) - v;
            if 0.5 * (l + r) - v >= 0.4 * dip && l.min(r) > v {
                pass += 1;
            }
        }
        if valid >= 3 && pass >= cfg.profile_seam_quarters.min(valid) {
            out.push(Seam {
                across,
                offset: sj,
                // The line turned 1–2° off crosses the seam and shows it in some quarters
                // only: the mean over the quarters prefers the line along it. (Not over the
                // roughness: the turned lines smear the grain too, and would win by that.)
                strength: sum_dip / valid as f64,
                bw,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use anybox_geom::Intrinsics;

    /// Grid cells per side of the test frame (2 px each).
    const W: usize = 120;
    const H: usize = 90;
    const FX: f64 = 600.0;

    /// Deterministic noise in -0.5..0.5 from a pixel index.
    fn jitter(i: u64) -> f64 {
        let mut x = i.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
        x ^= x >> 29;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 32;
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    /// A plane facing the camera 1.5 m away filling the frame, and its image.
    struct Wall {
        g: Grid,
        img: RgbImage,
    }

    impl Wall {
        /// `cut_at_faint_seams` on the wall's one patch.
        fn cut(
            &self,
            labels: &mut [u32],
            up: Option<Vector3<f64>>,
            cfg: &DetectConfig,
        ) -> (usize, Vec<u32>) {
            let fit = crate::detect::regions::fit_regions(
                &self.g,
                &[0u32; W * H],
                1,
                &DetectConfig::default(),
            );
            cut_at_faint_seams(&self.g, Some(&self.img), labels, &fit, up, cfg)
        }
    }

    /// The wall, one patch, whose pixels' luminance (mean of the channels) is `lum(u, v)` plus
    /// sensor noise (σ ≈ 2 levels).
    fn wall(lum: impl Fn(usize, usize) -> f64) -> (Wall, Vec<u32>) {
        let (fw, fh) = (2 * W, 2 * H);
        let k = Intrinsics {
            fx: FX / 2.0,
            fy: FX / 2.0,
            cx: W as f64 / 2.0,
            cy: H as f64 / 2.0,
        };
        let z = 1500.0f32;
        let p = (0..W * H)
            .map(|i| {
                let (u, v) = ((i % W) as f64, (i / W) as f64);
                [
                    ((u - k.cx) / k.fx * z as f64) as f32,
                    ((v - k.cy) / k.fy * z as f64) as f32,
                    z,
                ]
            })
            .collect();
        // Grey: every channel the luminance, with its own noise.
        let px = (0..3 * fw * fh)
            .map(|i| {
                let l = lum(i / 3 % fw, i / 3 / fw) + 7.0 * jitter(i as u64);
                l.round().clamp(0.0, 255.0) as u8
            })
            .collect();
        let img = RgbImage::from_raw(fw as u32, fh as u32, px)
            .expect("3 bytes for each of fw × fh pixels");
        let g = Grid {
            w: W,
            h: H,
            step: 2,
            k,
            z: vec![z; W * H],
            p,
            n: vec![[0.0, 0.0, -1.0]; W * H],
            c: vec![[128.0; 3]; W * H],
            seam: vec![false; W * H],
            grow_from_mm: 0.0,
        };
        (Wall { g, img }, vec![0; W * H])
    }

    /// Camera y points down: up is −y, and the wall is a side face.
    fn up() -> Vector3<f64> {
        -Vector3::y()
    }

    /// Cardboard grain as the generator renders it at 1.5 m: stripes 2 mm wide, each up to
    /// 6 % darker, one per pixel column after the camera's blur (up to 4 %), across the whole
    /// wall.
    fn grain(u: usize) -> f64 {
        1.0 - 0.04 * (jitter(1_000_003 + u as u64) + 0.5)
    }

    proptest::proptest! {
        /// The hull's corners give the angle that all the (strided) points give: the
        /// rectangle's sides only ever touch hull points.
        #[test]
        fn rectangle_angle_on_the_hull_is_the_angle_on_all_points(
            seed in 0u64..1_000_000,
            n in 3usize..1500,
            turn_deg in 0.0f64..90.0,
            aspect in 0.1f64..1.0,
        ) {
            let (c, s) = (turn_deg.to_radians().cos(), turn_deg.to_radians().sin());
            let pts: Vec<[f64; 2]> = (0..n as u64)
                .map(|i| {
                    // A noisy rectangle, 300 × (300 · aspect) mm, turned.
                    let x = 300.0 * jitter(3 * i + seed) + 3.0 * jitter(3 * i + 1 + seed);
                    let y = 300.0 * aspect * jitter(3 * i + 2 + seed);
                    [x * c - y * s, x * s + y * c]
                })
                .collect();
            let stride = pts.len() / 400 + 1;
            let area = |a: f64| {
                let (c, s) = (a.cos(), a.sin());
                let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
                for p in pts.iter().step_by(stride) {
                    let (x, y) = (p[0] * c + p[1] * s, -p[0] * s + p[1] * c);
                    lo = [lo[0].min(x), lo[1].min(y)];
                    hi = [hi[0].max(x), hi[1].max(y)];
                }
                (hi[0] - lo[0]) * (hi[1] - lo[1])
            };
            let brute = (0..90)
                .map(|d| (d as f64).to_radians())
                .min_by(|a, b| area(*a).total_cmp(&area(*b)))
                .unwrap_or(0.0);
            let got = rectangle_angle(&pts);
            // The same angle, or one whose area ties it up to rounding.
            proptest::prop_assert!(
                (area(got) - area(brute)).abs() <= 1e-9 * area(brute),
                "hull angle {got} vs brute force {brute}"
            );
        }
    }

    #[test]
    fn a_faint_joint_across_the_whole_wall_cuts_it_there() {
        // Two px at column 150 (cell 75) 12 % darker: at 1.5 m the joint of two creased, 28 %
        // darker edges 2.5 mm wide, blurred over its neighbours.
        let (w, mut labels) = wall(|u, _| 70.0 * grain(u) * if u / 2 == 75 { 0.88 } else { 1.0 });
        let (n, seam) = w.cut(&mut labels, Some(up()), &DetectConfig::default());
        assert_eq!(n, 2);
        // Every cell left of the joint is in one piece, every cell right of it in the other.
        for v in 0..H {
            assert!((0..74).all(|u| labels[v * W + u] == labels[v * W]));
            assert!((77..W).all(|u| labels[v * W + u] == labels[v * W + W - 1]));
            assert_ne!(labels[v * W], labels[v * W + W - 1]);
        }
        assert!(!seam.is_empty());
        assert!(seam.iter().all(|&i| (74..=76).contains(&(i as usize % W))));
    }

    #[test]
    fn grain_alone_cuts_nothing() {
        let (w, mut labels) = wall(|u, _| 70.0 * grain(u));
        let (n, seam) = w.cut(&mut labels, Some(up()), &DetectConfig::default());
        assert_eq!(n, 1);
        assert!(seam.is_empty());
        assert!(labels.iter().all(|&l| l == 0));
    }

    #[test]
    fn a_line_over_half_the_wall_is_print_not_a_joint() {
        // As dark as the joint above, but only over the upper half of the wall.
        let (w, mut labels) =
            wall(|u, v| 70.0 * grain(u) * if u / 2 == 75 && v < H { 0.88 } else { 1.0 });
        let (n, _) = w.cut(&mut labels, Some(up()), &DetectConfig::default());
        assert_eq!(n, 1);
    }

    #[test]
    fn tops_are_left_to_the_halves() {
        // The same joint, but the plane faces up: it could be the carton's own flap seam.
        let (w, mut labels) = wall(|u, _| 70.0 * grain(u) * if u / 2 == 75 { 0.88 } else { 1.0 });
        let facing_up = Vector3::new(0.0, 0.0, -1.0);
        let (n, _) = w.cut(&mut labels, Some(facing_up), &DetectConfig::default());
        assert_eq!(n, 1);
        // Disabled: nothing is cut either.
        let cfg = DetectConfig {
            profile_seam_min_dip: 0.0,
            ..DetectConfig::default()
        };
        let (n, _) = w.cut(&mut labels, Some(up()), &cfg);
        assert_eq!(n, 1);
        // No up known: no patch is known to be a side face.
        let (n, _) = w.cut(&mut labels, None, &DetectConfig::default());
        assert_eq!(n, 1);
    }
}
