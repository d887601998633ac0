//! The working grid: the frame downsampled by `grid_step_px` (2 by default), with per-cell depth,
//! camera-frame point, smoothed normal and smoothed colour.
//!
//! In: a depth map (mm), optional RGB, intrinsics. Out: [`Grid`]. Everything later in the
//! detector works on this grid, so that a 640×480 frame costs 320×240 cells. The smoothing and
//! normal radii grow with depth where the frame's own depth noise, measured here, is large
//! for its depth (`DetectConfig::radius_noise_ref`).

use anybox_geom::Intrinsics;
use anybox_io::{DepthMap, RgbImage};

use super::DetectConfig;
use rayon::prelude::*;

/// Per-cell data of the downsampled frame.
pub(crate) struct Grid {
    /// Cells per row.
    pub w: usize,
    /// Rows.
    pub h: usize,
    /// Original pixels per cell side.
    pub step: usize,
    /// Intrinsics of the grid (cell centres at integer coordinates).
    pub k: Intrinsics,
    /// Depth of the nearest surface in the cell, mm; 0 = invalid.
    pub z: Vec<f32>,
    /// Camera-frame point of the cell, mm (zero where invalid).
    pub p: Vec<[f32; 3]>,
    /// Unit normal from the smoothed depth, facing the camera; zero where unknown.
    pub n: Vec<[f32; 3]>,
    /// Colour of the cell smoothed over 3×3 cells (0..255 per channel); grey when no RGB.
    pub c: Vec<[f32; 3]>,
    /// The cell holds a thin dark (or bright) line of the full-resolution image (a seam between
    /// flush cartons, a printed edge); such cells join nothing in the colour-aware segmentation.
    pub seam: Vec<bool>,
    /// Depth beyond which the smoothing and normal radii grow, mm (0: they do not), from the
    /// frame's measured noise (see [`DetectConfig::radius_noise_ref`]).
    pub grow_from_mm: f32,
}

/// A radius of `base` cells at depth `z_mm`: grown in proportion to depth beyond
/// `grow_from_mm` (0: never; see [`DetectConfig::radius_noise_ref`]), at most
/// `radius_max_cells`.
pub(crate) fn radius_at(base: u32, z_mm: f32, grow_from_mm: f32, cfg: &DetectConfig) -> usize {
    if grow_from_mm <= 0.0 || z_mm <= grow_from_mm {
        return base as usize;
    }
    let grown = (base as f32 * z_mm / grow_from_mm).round() as u32;
    grown.clamp(base, cfg.radius_max_cells.max(base)) as usize
}

/// The frame's depth-noise index, 1/mm: the median over cells of |z − mean of its 8
/// neighbours| / z², where the 8 lie within the jump tolerance (the mean is exact on a plane,
/// so what is left is noise, and sensor noise grows with the square of depth). `None` from
/// under 500 such cells.
fn noise_index(z: &[f32], w: usize, h: usize, cfg: &DetectConfig) -> Option<f32> {
    let vals: Vec<f64> = (1..h.saturating_sub(1))
        .into_par_iter()
        .flat_map_iter(|v| {
            (1..w.saturating_sub(1)).filter_map(move |u| {
                let i = v * w + u;
                let zc = z[i];
                let tol = jump_tol(cfg, zc);
                crate::depth_noise::relative_residual(z, w, i, |j| {
                    z[j] > 0.0 && (z[j] - zc).abs() <= tol
                })
                .map(f64::from)
            })
        })
        .collect();
    if vals.len() < 500 {
        return None;
    }
    // Exact: the median is one of the f32 values.
    Some(crate::observation::median(vals) as f32)
}

/// Depth jump tolerance at depth `z_mm`: neighbours farther apart than this are different
/// surfaces.
#[inline]
pub(crate) fn jump_tol(cfg: &DetectConfig, z_mm: f32) -> f32 {
    cfg.depth_jump_abs_mm as f32 + cfg.depth_jump_rel as f32 * z_mm
}

/// The normal change that cuts colour patches at depth `z_mm`, degrees: `normal_cut_deg`, grown
/// by `patch_normal_cut_deg_per_m` per metre beyond `patch_normal_cut_from_mm`, capped at
/// `patch_normal_cut_max_deg` (and never below `normal_cut_deg`).
pub(crate) fn patch_cut_deg(cfg: &DetectConfig, z_mm: f64) -> f64 {
    let beyond_m = ((z_mm - cfg.patch_normal_cut_from_mm) / 1000.0).max(0.0);
    (cfg.normal_cut_deg + cfg.patch_normal_cut_deg_per_m * beyond_m)
        .min(cfg.patch_normal_cut_max_deg)
        .max(cfg.normal_cut_deg)
}

impl Grid {
    pub(crate) fn build(
        rgb: Option<&RgbImage>,
        depth: &DepthMap,
        k: &Intrinsics,
        cfg: &DetectConfig,
    ) -> Grid {
        let step = cfg.grid_step_px.clamp(1, 8) as usize;
        let (fw, fh) = (depth.width as usize, depth.height as usize);
        let w = fw.div_ceil(step);
        let h = fh.div_ceil(step);
        let n = w * h;
        // Cell centre (in original px) of cell (gu, gv) is gu·step + (step−1)/2.
        let off = (step as f64 - 1.0) / 2.0;
        let s = step as f64;
        let gk = Intrinsics {
            fx: k.fx / s,
            fy: k.fy / s,
            cx: (k.cx - off) / s,
            cy: (k.cy - off) / s,
        };
        // Seams (full resolution) and the depth cells are independent: built in parallel.
        let (seam, (z, c)) = rayon::join(
            || match rgb {
                Some(img) if cfg.seam_valley_levels > 0.0 => seams(img, w, h, step, cfg),
                _ => vec![false; n],
            },
            || cells(rgb, depth, w, h, step, cfg),
        );
        let p = points(&z, w, h, &gk);
        let noise = (cfg.radius_noise_ref > 0.0)
            .then(|| noise_index(&z, w, h, cfg))
            .flatten();
        let grow_from_mm = match noise {
            Some(k) if k > 0.0 => cfg.radius_noise_ref as f32 / k,
            _ => 0.0,
        };
        log::debug!("noise index {noise:?}: radii grow from {grow_from_mm:.0} mm");
        let zs = smooth_depth(&z, w, h, grow_from_mm, cfg);
        let ps = points(&zs, w, h, &gk);
        let nrm = normals(&zs, &ps, w, h, grow_from_mm, cfg);
        let c = if rgb.is_some() { box3(&c, w, h) } else { c };
        Grid {
            w,
            h,
            step,
            k: gk,
            z,
            p,
            n: nrm,
            c,
            seam,
            grow_from_mm,
        }
    }

    /// The cell a camera-frame point (mm) projects into (nearest cell centre); `None` behind
    /// the camera or outside the grid.
    pub(crate) fn cell_at(&self, p: &nalgebra::Vector3<f64>) -> Option<usize> {
        let q = self.k.project(&nalgebra::Point3::from(*p))?;
        let (u, v) = (q.x.round(), q.y.round());
        if u < 0.0 || v < 0.0 || u >= self.w as f64 || v >= self.h as f64 {
            return None;
        }
        Some(v as usize * self.w + u as usize)
    }
}

/// Per cell: the depth of the nearest surface (mm; 0 = no valid pixel) and the mean colour
/// (grey without RGB), rows in parallel.
fn cells(
    rgb: Option<&RgbImage>,
    depth: &DepthMap,
    w: usize,
    h: usize,
    step: usize,
    cfg: &DetectConfig,
) -> (Vec<f32>, Vec<[f32; 3]>) {
    let (fw, fh) = (depth.width as usize, depth.height as usize);
    let rgb_raw = rgb.map(|img| img.as_raw().as_slice());
    let mut z = vec![0f32; w * h];
    let mut c = vec![[128f32; 3]; w * h];
    // Rows in parallel, reading the frame's slices directly (no per-pixel bounds checks); the
    // sums run row-major through the cell.
    z.par_chunks_mut(w)
        .zip(c.par_chunks_mut(w))
        .enumerate()
        .for_each(|(gv, (z, c))| {
            // step ≤ 8 (clamped in `Grid::build`): at most 64 pixels per cell.
            let mut vals = [0f32; 64];
            let v0 = gv * step;
            let v1 = (v0 + step).min(fh);
            for gu in 0..w {
                let u0 = gu * step;
                let u1 = (u0 + step).min(fw);
                let mut nv = 0usize;
                let mut col = [0f32; 3];
                let mut nc = 0f32;
                for v in v0..v1 {
                    for &d in &depth.depth_mm[v * fw + u0..v * fw + u1] {
                        if d > 0.0 && d.is_finite() {
                            vals[nv] = d;
                            nv += 1;
                        }
                    }
                    if let Some(raw) = rgb_raw {
                        for px in raw[(v * fw + u0) * 3..(v * fw + u1) * 3].chunks_exact(3) {
                            col[0] += px[0] as f32;
                            col[1] += px[1] as f32;
                            col[2] += px[2] as f32;
                            nc += 1.0;
                        }
                    }
                }
                if nc > 0.0 {
                    c[gu] = [col[0] / nc, col[1] / nc, col[2] / nc];
                }
                let vals = &vals[..nv];
                if let Some(&zmin) = vals.iter().min_by(|a, b| a.total_cmp(b)) {
                    // The nearest surface in the cell: mixed cells keep the front one.
                    let tol = jump_tol(cfg, zmin);
                    let (mut sum, mut cnt) = (0f32, 0f32);
                    for &d in vals {
                        if d - zmin <= tol {
                            sum += d;
                            cnt += 1.0;
                        }
                    }
                    z[gu] = sum / cnt;
                }
            }
        });
    (z, c)
}

/// Thin lines: a pixel darker than both pixels two to either side (along a row or a column)
/// by more than `seam_valley_levels` and by more than `seam_valley_rel` of their brightness,
/// on luminance averaged over 3 px along the line (sensor noise drops, the line does not);
/// with `seam_ridges`, also a pixel brighter than both by as much. A cell is a seam cell when
/// it holds at least `seam_min_pixels` such pixels.
fn seams(img: &RgbImage, w: usize, h: usize, step: usize, cfg: &DetectConfig) -> Vec<bool> {
    let (fw, fh) = (img.width() as usize, img.height() as usize);
    let raw = img.as_raw();
    let lum: Vec<i32> = raw
        .par_chunks_exact(3)
        .map(|p| (p[0] as i32) + (p[1] as i32) + (p[2] as i32))
        .collect();
    // Sums of 3 px: along columns (for vertical lines, valley across x) and along rows. Zero
    // on the frame's outermost rows and columns.
    let mut col3 = vec![0i32; fw * fh];
    let mut row3 = vec![0i32; fw * fh];
    if fw >= 3 && fh >= 3 {
        col3.par_chunks_mut(fw)
            .zip(row3.par_chunks_mut(fw))
            .enumerate()
            .skip(1)
            .take(fh - 2)
            .for_each(|(v, (c, r))| {
                let (up, mid, dn) = (
                    &lum[(v - 1) * fw..v * fw],
                    &lum[v * fw..(v + 1) * fw],
                    &lum[(v + 1) * fw..(v + 2) * fw],
                );
                for u in 1..fw - 1 {
                    c[u] = up[u] + mid[u] + dn[u];
                    r[u] = mid[u - 1] + mid[u] + mid[u + 1];
                }
            });
    }
    // Both sums cover 9 channel values: levels × 9.
    let t = (cfg.seam_valley_levels * 9.0) as i32;
    let rel = cfg.seam_valley_rel;
    let ridges = cfg.seam_ridges;
    // A line `d` deeper (or higher) than the side it is compared with, `side`.
    let deep = |d: i32, side: i32| d > t && d as f64 > rel * side as f64;
    // Per grid row (its `step` pixel rows) in parallel.
    let mut count = vec![0u16; w * h];
    count
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(gv, counts)| {
            let lo = (gv * step).max(3);
            let hi = ((gv + 1) * step).min(fh.saturating_sub(3));
            for v in lo..hi {
                let c = &col3[v * fw..(v + 1) * fw];
                let (r, r_up, r_dn) = (
                    &row3[v * fw..(v + 1) * fw],
                    &row3[(v - 2) * fw..(v - 1) * fw],
                    &row3[(v + 2) * fw..(v + 3) * fw],
                );
                for u in 3..fw.saturating_sub(3) {
                    let bx = c[u - 2].min(c[u + 2]);
                    let by = r_up[u].min(r_dn[u]);
                    // Absolute and relative depth of the valley: most sensor noise and printed
                    // grain (a few per cent of the brightness) are not seams.
                    let hx = deep(bx - c[u], bx);
                    let vy = deep(by - r[u], by);
                    // A bright ridge: the lit sliver of a lower carton's top where a stacked layer
                    // is set back by a few millimetres.
                    let ridge = ridges && {
                        let tx = c[u - 2].max(c[u + 2]);
                        let ty = r_up[u].max(r_dn[u]);
                        deep(c[u] - tx, tx) || deep(r[u] - ty, ty)
                    };
                    if hx || vy || ridge {
                        counts[u / step] += 1;
                    }
                }
            }
        });
    let m = cfg.seam_min_pixels.max(1) as u16;
    let seam: Vec<bool> = count.iter().map(|&c| c >= m).collect();
    close_seam_gaps(&seam, w, h, cfg.seam_close_cells as usize)
}

/// Bridges gaps of up to `2 r − 1` cells in seam lines: a cell becomes a seam cell when seam
/// cells lie within `r` cells on both sides of it along a row, a column or a diagonal, and
/// neither cell beside it across that direction is one (a thin line, not a patch of noise). A
/// crease a pixel or two wide aliases into a dashed line, and one gap lets the cartons on
/// either side merge.
fn close_seam_gaps(seam: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    if r == 0 {
        return seam.to_vec();
    }
    // Seam cells per (2r + 1)² window, from a summed-area table: a bridge needs one on each
    // side, so cells whose window holds fewer than two are skipped (most of the frame).
    let sw = w + 1;
    let mut sat = vec![0u32; sw * (h + 1)];
    for v in 0..h {
        let mut run = 0u32;
        for u in 0..w {
            run += u32::from(seam[v * w + u]);
            sat[(v + 1) * sw + u + 1] = sat[v * sw + u + 1] + run;
        }
    }
    let window = |u: usize, v: usize| {
        let (u0, v0) = (u.saturating_sub(r), v.saturating_sub(r));
        let (u1, v1) = ((u + r + 1).min(w), (v + r + 1).min(h));
        sat[v1 * sw + u1] + sat[v0 * sw + u0] - sat[v0 * sw + u1] - sat[v1 * sw + u0]
    };
    let mut out = seam.to_vec();
    for v in 0..h {
        for u in 0..w {
            if !seam[v * w + u] && window(u, v) >= 2 && bridges_gap(seam, w, h, r, u, v) {
                out[v * w + u] = true;
            }
        }
    }
    out
}

/// The rule of [`close_seam_gaps`] at cell `(u, v)`: seam cells within `r` on both sides along
/// a row, a column or a diagonal, and none beside it across that direction.
fn bridges_gap(seam: &[bool], w: usize, h: usize, r: usize, u: usize, v: usize) -> bool {
    let at = |u: isize, v: isize| flag_at(seam, w, h, u, v);
    let (u, v) = (u as isize, v as isize);
    LINE_DIRS.iter().any(|&(du, dv)| {
        let thin = !(at(u - dv, v + du) || at(u + dv, v - du));
        thin && on_both_sides(at, u, v, r, (du, dv))
    })
}

/// A row, a column and the two diagonals, as cell steps `(du, dv)`.
pub(crate) const LINE_DIRS: [(isize, isize); 4] = [(1, 0), (0, 1), (1, 1), (1, -1)];

/// `flags[v * w + u]` of a `w` × `h` grid of flags; false outside it.
pub(crate) fn flag_at(flags: &[bool], w: usize, h: usize, u: isize, v: isize) -> bool {
    u >= 0 && v >= 0 && (u as usize) < w && (v as usize) < h && flags[v as usize * w + u as usize]
}

/// Whether `at` holds within `r` cells of `(u, v)` on both sides along the step `(du, dv)`.
pub(crate) fn on_both_sides(
    at: impl Fn(isize, isize) -> bool,
    u: isize,
    v: isize,
    r: usize,
    (du, dv): (isize, isize),
) -> bool {
    let side = |s: isize| (1..=r as isize).any(|d| at(u + s * d * du, v + s * d * dv));
    side(1) && side(-1)
}

fn points(z: &[f32], w: usize, h: usize, k: &Intrinsics) -> Vec<[f32; 3]> {
    let (ifx, ify) = (1.0 / k.fx as f32, 1.0 / k.fy as f32);
    let (cx, cy) = (k.cx as f32, k.cy as f32);
    let mut p = vec![[0f32; 3]; w * h];
    for v in 0..h {
        for u in 0..w {
            let i = v * w + u;
            let d = z[i];
            if d > 0.0 {
                p[i] = [(u as f32 - cx) * d * ifx, (v as f32 - cy) * d * ify, d];
            }
        }
    }
    p
}

/// Guarded box filter of the depth: only neighbours on the same surface (within the jump
/// tolerance of the centre) are averaged, so edges stay sharp while sensor noise drops. The
/// window's radius is `smooth_radius_cells`, grown beyond `grow_from_mm` ([`radius_at`]).
fn smooth_depth(z: &[f32], w: usize, h: usize, grow_from_mm: f32, cfg: &DetectConfig) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
        let v = v as isize;
        for (u, o) in row.iter_mut().enumerate() {
            let u = u as isize;
            let zc = z[v as usize * w + u as usize];
            if zc <= 0.0 {
                continue;
            }
            let r = radius_at(cfg.smooth_radius_cells, zc, grow_from_mm, cfg) as isize;
            let tol = jump_tol(cfg, zc);
            let (mut s, mut n) = (0f32, 0f32);
            let (u0, u1) = (
                (u - r).max(0) as usize,
                (u + r).min(w as isize - 1) as usize,
            );
            for vv in (v - r).max(0)..=(v + r).min(h as isize - 1) {
                let line = vv as usize * w;
                for &zn in &z[line + u0..=line + u1] {
                    if zn > 0.0 && (zn - zc).abs() <= tol {
                        s += zn;
                        n += 1.0;
                    }
                }
            }
            *o = s / n;
        }
    });
    out
}

fn sub(a: &[f32; 3], b: &[f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Normals from central differences at ±`normal_radius_cells`, grown beyond `grow_from_mm`
/// ([`radius_at`]) (one-sided next to holes and depth jumps), oriented towards the camera.
fn normals(
    zs: &[f32],
    ps: &[[f32; 3]],
    w: usize,
    h: usize,
    grow_from_mm: f32,
    cfg: &DetectConfig,
) -> Vec<[f32; 3]> {
    let mut out = vec![[0f32; 3]; w * h];
    let same = |i: usize, j: usize| -> bool {
        zs[j] > 0.0 && (zs[j] - zs[i]).abs() <= jump_tol(cfg, zs[i])
    };
    // Rows in parallel: each normal reads the depth around it only.
    out.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
        for u in 0..w {
            let i = v * w + u;
            if zs[i] <= 0.0 {
                continue;
            }
            let r = radius_at(cfg.normal_radius_cells.max(1), zs[i], grow_from_mm, cfg);
            let tangent = |lo: Option<usize>, hi: Option<usize>| -> Option<[f32; 3]> {
                let lo = lo.filter(|&j| same(i, j));
                let hi = hi.filter(|&j| same(i, j));
                match (lo, hi) {
                    (Some(a), Some(b)) => Some(sub(&ps[b], &ps[a])),
                    (None, Some(b)) => Some(sub(&ps[b], &ps[i])),
                    (Some(a), None) => Some(sub(&ps[i], &ps[a])),
                    (None, None) => None,
                }
            };
            let tx = tangent((u >= r).then(|| i - r), (u + r < w).then(|| i + r));
            let ty = tangent((v >= r).then(|| i - r * w), (v + r < h).then(|| i + r * w));
            let (Some(a), Some(b)) = (tx, ty) else {
                continue;
            };
            let mut n = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len <= 0.0 || !len.is_finite() {
                continue;
            }
            let p = &ps[i];
            let sign = if n[0] * p[0] + n[1] * p[1] + n[2] * p[2] > 0.0 {
                -1.0
            } else {
                1.0
            };
            for x in n.iter_mut() {
                *x *= sign / len;
            }
            row[u] = n;
        }
    });
    out
}

/// 3×3 box filter of the colours (edges clamp).
fn box3(c: &[[f32; 3]], w: usize, h: usize) -> Vec<[f32; 3]> {
    let mut out = vec![[0f32; 3]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
        for (u, o) in row.iter_mut().enumerate() {
            let mut s = [0f32; 3];
            let mut n = 0f32;
            for vv in v.saturating_sub(1)..(v + 2).min(h) {
                for uu in u.saturating_sub(1)..(u + 2).min(w) {
                    let x = &c[vv * w + uu];
                    s[0] += x[0];
                    s[1] += x[1];
                    s[2] += x[2];
                    n += 1.0;
                }
            }
            *o = [s[0] / n, s[1] / n, s[2] / n];
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dark carton face (32 grey levels, sensor noise of σ ≈ 2 levels) with a crease 2 px
    /// wide at 72 % brightness along row 20 and a lit sliver 2 px wide at 160 % along row 40.
    fn dark_face() -> RgbImage {
        let (w, h) = (64u32, 64u32);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut noise = move || {
            // Sum of four uniforms on [-1.7, 1.7]: σ ≈ 2 levels.
            (0..4)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 11) as f64 / (1u64 << 53) as f64 * 3.4 - 1.7
                })
                .sum::<f64>()
        };
        RgbImage::from_fn(w, h, |_, v| {
            let base = match v {
                20 | 21 => 32.0 * 0.72,
                40 | 41 => 32.0 * 1.6,
                _ => 32.0,
            };
            let c = (base + noise()).round().clamp(0.0, 255.0) as u8;
            image::Rgb([c, c, c])
        })
    }

    /// Fraction of the cells of grid row `gv` (columns 4..28, away from the border) that are
    /// seam cells.
    fn row_share(seam: &[bool], w: usize, gv: usize) -> f64 {
        (4..28).filter(|&u| seam[gv * w + u]).count() as f64 / 24.0
    }

    #[test]
    fn dashed_seam_lines_are_closed_and_nothing_else_grows() {
        let (w, h) = (24usize, 24usize);
        let mut seam = vec![false; w * h];
        // A diagonal line with one-cell gaps (every third cell missing), and a row with a
        // two-cell gap.
        for i in 2..17 {
            seam[i * w + i] = i % 3 != 0;
        }
        for u in 2..20 {
            seam[21 * w + u] = !(10..12).contains(&u);
        }
        let closed = close_seam_gaps(&seam, w, h, 1);
        for i in 2..17 {
            assert!(closed[i * w + i], "diagonal cell {i} still open");
        }
        // r = 1 bridges one-cell gaps only; r = 2 bridges the two-cell gap too.
        assert!(!closed[21 * w + 10] && !closed[21 * w + 11]);
        let wide = close_seam_gaps(&seam, w, h, 2);
        assert!(wide[21 * w + 10] && wide[21 * w + 11]);
        // No cell off the two lines turns into a seam cell.
        let on_lines = |u: usize, v: usize| u == v && (2..17).contains(&u) || v == 21;
        for v in 0..h {
            for u in 0..w {
                if !on_lines(u, v) {
                    assert!(!closed[v * w + u] && !wide[v * w + u], "({u}, {v}) grew");
                }
            }
        }
        // A gap beside a parallel seam cell is a patch, not a line: left open.
        let mut patch = vec![false; w * h];
        for (u, v) in [(5, 5), (7, 5), (6, 4)] {
            patch[v * w + u] = true;
        }
        assert!(!close_seam_gaps(&patch, w, h, 1)[5 * w + 6]);
        assert_eq!(close_seam_gaps(&seam, w, h, 0), seam);
    }

    #[test]
    fn seams_find_a_dark_crease_and_a_bright_sliver_but_not_noise() {
        let img = dark_face();
        let cfg = DetectConfig::default();
        let (w, h) = (32, 32);
        let seam = seams(&img, w, h, 2, &cfg);
        assert!(row_share(&seam, w, 10) >= 0.9, "crease");
        assert!(row_share(&seam, w, 20) >= 0.9, "sliver");
        // Rows more than two cells from both lines see noise alone: scattered seam cells
        // (about 5 % here; each leaves a hole in a region) but no line.
        let quiet: Vec<f64> = (2..30)
            .filter(|&v: &usize| v.abs_diff(10) > 2 && v.abs_diff(20) > 2)
            .map(|v| row_share(&seam, w, v))
            .collect();
        let stray = quiet.iter().sum::<f64>() / quiet.len() as f64;
        assert!(stray < 0.1, "stray seam cells {stray}");
        assert!(quiet.iter().all(|&s| s < 0.3), "a noise line: {quiet:?}");
        // The old thresholds missed the crease of a dark carton; without ridges the sliver
        // is no seam.
        let old = DetectConfig {
            seam_valley_levels: 12.0,
            seam_valley_rel: 0.12,
            seam_ridges: false,
            ..DetectConfig::default()
        };
        let seam = seams(&img, w, h, 2, &old);
        assert!(row_share(&seam, w, 10) < 0.2, "old crease");
        assert!(row_share(&seam, w, 20) < 0.2, "old sliver");
    }

    /// The summed-area shortcut of `close_seam_gaps` skips only cells that cannot be bridged:
    /// on random sparse patterns it agrees with the plain rule applied to every cell.
    #[test]
    fn seam_gap_shortcut_matches_the_plain_rule() {
        // The rule applied to every cell, with no window shortcut.
        let plain = |seam: &[bool], w: usize, h: usize, r: usize| -> Vec<bool> {
            (0..w * h)
                .map(|i| seam[i] || bridges_gap(seam, w, h, r, i % w, i / w))
                .collect::<Vec<bool>>()
        };
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let (w, h) = (37, 23);
        let mut bridged_cells = 0;
        for trial in 0..200 {
            let density = [0.03, 0.08, 0.2][trial % 3];
            let seam: Vec<bool> = (0..w * h)
                .map(|_| {
                    state = state
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    ((state >> 33) as f64 / (1u64 << 31) as f64) < density
                })
                .collect();
            for r in 1..=3 {
                let want = plain(&seam, w, h, r);
                assert_eq!(close_seam_gaps(&seam, w, h, r), want, "trial {trial} r {r}");
                bridged_cells += want.iter().zip(&seam).filter(|(a, b)| **a && !**b).count();
            }
        }
        // Premise: the patterns do bridge gaps, so the comparison covers that branch.
        assert!(bridged_cells > 1000, "only {bridged_cells} bridged cells");
    }

    /// Cells of a gently tilted plane about 2 m away, plus white noise of `sigma_mm`.
    fn noisy_plane(w: usize, h: usize, sigma_mm: f64) -> Vec<f32> {
        use crate::pipeline::test_scene::gauss;
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        (0..w * h)
            .map(|i| {
                let (u, v) = ((i % w) as f64, (i / w) as f64);
                (2000.0 + 0.05 * u + 0.03 * v + sigma_mm * gauss(&mut rng)) as f32
            })
            .collect()
    }

    #[test]
    fn noise_index_reads_white_noise_against_a_closed_form() {
        let (w, h) = (120, 90);
        let cfg = DetectConfig::default();
        // The mean of 8 neighbours is exact on a plane: no noise, no index.
        let clean = noise_index(&noisy_plane(w, h, 0.0), w, h, &cfg).expect("enough cells");
        assert!(clean < 2e-10, "noise index {clean:e} of a clean plane");
        // z − mean of 8 is normal with variance σ²·(1 + 1/8); the median of its absolute
        // value is 0.6745 times its σ.
        let sigma = 6.0;
        let want = 0.6745 * sigma * (9.0f64 / 8.0).sqrt() / (2000.0 * 2000.0);
        let got = noise_index(&noisy_plane(w, h, sigma), w, h, &cfg).expect("enough cells");
        assert!(
            (f64::from(got) - want).abs() < 0.06 * want,
            "noise index {got:e}, closed form {want:e}"
        );
        // Too few cells to tell.
        assert!(noise_index(&noisy_plane(20, 20, sigma), 20, 20, &cfg).is_none());
    }

    #[test]
    fn radii_grow_with_depth_past_the_noise_depth_up_to_the_cap() {
        let cfg = DetectConfig {
            radius_max_cells: 5,
            ..DetectConfig::default()
        };
        assert_eq!(radius_at(2, 3000.0, 0.0, &cfg), 2, "0 disables");
        assert_eq!(radius_at(2, 900.0, 1000.0, &cfg), 2);
        assert_eq!(radius_at(2, 1600.0, 1000.0, &cfg), 3);
        assert_eq!(radius_at(2, 2000.0, 1000.0, &cfg), 4);
        assert_eq!(radius_at(2, 4000.0, 1000.0, &cfg), 5, "capped");
        assert_eq!(radius_at(3, 1000.0, 1000.0, &cfg), 3);
    }
}
