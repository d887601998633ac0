//! Masked depth → 3D observation (SPEC §1 "pose hypotheses", input side; paper §3.2).
//!
//! In: a depth map (mm, 0 = invalid), the camera [`Intrinsics`] and one instance [`Mask`] of the
//! same size. Out: an [`Observation`] — the back-projected points (camera frame, mm) of the mask
//! pixels with valid depth, their pixels, unit normals oriented toward the camera, and a few
//! precomputed helpers that keep the pose loop cheap (a fixed subsample for scoring/ICP, the
//! mask's row prefix sums for silhouette IoU).
//!
//! Outlier handling, in order:
//! 1. *flying pixels*: a pixel whose depth differs from the median of its 3×3 in-mask valid
//!    neighbourhood by more than `max(flying_abs_mm, flying_rel · z)` is dropped (mixed pixels at
//!    depth edges, where a sensor interpolates between the box and the background). Implemented
//!    as "more than half of the valid 3×3 neighbourhood (itself included) lies within the
//!    tolerance", which is the median test without a sort;
//! 2. *depth fragments*: the mask is split into pieces joined through 4-neighbours within the
//!    flying-pixel tolerance; a piece smaller than `fragment_max_fraction` of the largest that
//!    borders a larger piece across a depth jump is a leak onto another surface (the background
//!    past a box's rim, a neighbour) and is dropped. Pieces set apart by holes or by pixels
//!    outside the mask (the box seen past an occluder) stay;
//! 3. *far outliers*: a robust distance-to-centroid cut — points farther from the component-wise
//!    median than `median(d) + outlier_k · 1.4826 · MAD(d)` are dropped (segmentation leaks).
//!
//! Normals: the "average 3D gradient" estimator (as PCL's integral-image normals): with integral
//! images of the kept points over the mask's bounding box, the normal at a pixel is
//! `(mean right − mean left) × (mean below − mean above)` over `(2r+1) × r` half-windows of in-mask
//! kept neighbours — O(1) per point, exact on planes, and it never mixes in points outside the
//! mask. (A per-point PCA eigen-solve costs ~10× more and the scale loop budget is ~10 ms per box.)
//! `r` grows where the mask's own depth noise is large for its depth
//! ([`ObservationConfig::normal_radius_noise_ref`]): far stereo depth comes in bumps a few
//! pixels wide.

use anybox_geom::Intrinsics;
use anybox_io::image::{DepthMap, Mask};
use nalgebra::{Matrix3, Point3, Vector3};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::OnceLock;

use crate::depth_filter::CellMinDepth;
use crate::error::EstimateError;
use crate::hypotheses::{FrameSet, HypothesisConfig};

/// Parameters of [`observe`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObservationConfig {
    /// Minimum number of usable 3D points; fewer gives [`EstimateError::TooFewPoints`]. Default 30
    /// (a box face needs a few dozen points for a stable plane and normal).
    pub min_points: usize,
    /// Flying-pixel cut, absolute part, mm. Default 10 mm.
    pub flying_abs_mm: f64,
    /// Flying-pixel cut, relative part (fraction of the pixel's depth). Default 0.03 (3 %: a face
    /// at 80° to the view ray changes depth by ~1 % of z per pixel at 600 px focal length).
    pub flying_rel: f64,
    /// Depth fragments: the mask's pixels are split into pieces connected through 4-neighbours
    /// whose depths differ by at most the flying-pixel tolerance; a piece with fewer points than
    /// this fraction of the largest piece is dropped when it borders a larger piece across a
    /// depth jump (a strip of the surface behind a box's rim, or of a neighbour, caught by the
    /// segmenter). Pieces set apart by holes or by pixels outside the mask stay. Default 0.1;
    /// 0 disables it.
    pub fragment_max_fraction: f64,
    /// Robust distance-to-centroid cut in MAD units. Default 3.5. Non-positive disables it.
    pub outlier_k: f64,
    /// Normal-estimation window radius, px (half-windows of `(2r+1) × r` px). Default 3.
    pub normal_radius_px: u32,
    /// The window grows where the mask's depth is noisy for its depth: with the mask's noise
    /// index `k` (1/mm: the median over its pixels of |z − mean of the 8 neighbours| / z²; the
    /// mean is exact on a plane, and stereo noise grows with the square of depth) and its
    /// median depth `z`, the radius is `normal_radius_px · k · z / normal_radius_noise_ref`
    /// when that is larger (rounded, at most `normal_radius_max_px`). On the generated views a
    /// mask reads `k` ≈ 1.9 × 10⁻⁶ /mm from the RealSense-like camera and 0.87 × 10⁻⁶ from the
    /// Kinect-like one, so at 2.3 × 10⁻³ the radius grows from about 1.4 m with the first
    /// (5 px at 2 m) and stays 3 px with the second up to about 2.6 m. 0 disables. Default
    /// 2.3 × 10⁻³ (detection bench, 48 views, six seeds 2026 / 7 / 11 / 3 / 5 / 13: mean AP@0.5
    /// of the 30 rows 0.7211 → 0.7227, pallets 0.7507 → 0.7602; with ground-truth masks
    /// 0.8941 → 0.8998, pallets 0.9197 → 0.9463, tables the same. A fixed radius of 5 px on
    /// every mask gave pallets 0.9435 with ground-truth masks too, but cost the estimator
    /// bench's generated scenes AP@0.9 0.612 → 0.598; 1.8 / 3.0 × 10⁻³ gave 0.7232 / 0.7226,
    /// with ground-truth masks 0.9003 / 0.8968).
    pub normal_radius_noise_ref: f64,
    /// Cap of the grown normal window radius, px. Default 6.
    pub normal_radius_max_px: u32,
    /// Size of the fixed subsample used for scoring and ICP. Default 400.
    pub max_subsample: usize,
    /// A pixel outside the mask is an occluder when nearer than the median observed depth by
    /// more than this (or 3 % of the depth), mm. Default 20 mm.
    pub occluder_margin_mm: f64,
    /// The reference depth of the occluder test is this quantile of the observed depths (0 =
    /// nearest point, 0.5 = median). Default 0.5 (0.02 and 0.1 measured no better).
    pub occluder_ref_quantile: f64,
    /// Pixels outside the mask with missing depth explain a silhouette overflowing the mask (as
    /// an occluder does). Default false: missing depth next to a box is usually free space
    /// (background out of range), so a pose whose silhouette spills into it is wrong (bench,
    /// oracle size, AP@0.9 3-dims: 0.837 → 0.855 seed 2026, 0.719 → 0.739 seed 7).
    pub missing_explains: bool,
    /// Trim a mask's leak onto the surface around it (a table or a neighbouring face caught by
    /// the segmenter): see [`trim_support_leak`]. Default true.
    pub leak_trim: bool,
    /// Width of the ring around the mask whose dominant plane is the candidate support, px.
    /// Default 8.
    pub leak_ring_px: u32,
    /// The ring's plane must hold at least this fraction of the ring's points. Default 0.5.
    pub leak_min_ring_fraction: f64,
    /// At most this fraction of the mask's points may lie on it (more: the plane is the box's
    /// own face, flush with its neighbours, and nothing is trimmed). Default 0.35.
    pub leak_max_fraction: f64,
    /// Plane tolerance: constant part, mm. Default 6.
    pub leak_tol_mm: f64,
    /// Plane tolerance: part relative to depth. Default 0.01.
    pub leak_tol_rel: f64,
    /// Second try: an estimate whose score (0..1) is below this is redone from the mask cut
    /// down to its box faces ([`box_faces_mask`]), and the better-scoring estimate is kept; 0
    /// disables. Default 0.35 (`anybox bench --no-detect`, ground-truth masks, AP@0.5 of the
    /// default variant on seeds 2026 / 7 / 11: 0.863 / 0.834 / 0.873 → 0.881 / 0.851 / 0.879,
    /// median time per box +0.15 ms, p90 +1.5 to +3 ms; 0.5 gained no more and cost twice the
    /// time). A strip of a shelf board, an upright or the table caught along a mask's rim can
    /// otherwise blow the size up; such estimates score low.
    pub retry_below_score: f64,
    /// [`box_faces_mask`]: a face holds at least this fraction of the mask's points. Default
    /// 0.05.
    pub retry_min_face_fraction: f64,
}

impl ObservationConfig {
    /// The flying-pixel tolerance at depth `z_mm`: `max(flying_abs_mm, flying_rel · z)`, mm.
    fn flying_tol_mm(&self, z_mm: f32) -> f32 {
        self.flying_abs_mm.max(self.flying_rel * z_mm as f64) as f32
    }

    /// The plane tolerance of [`trim_support_leak`] and [`box_faces_mask`] at depth `z_mm`:
    /// `max(leak_tol_mm, leak_tol_rel · z)`, mm.
    fn plane_tol_mm(&self, z_mm: f64) -> f64 {
        self.leak_tol_mm.max(self.leak_tol_rel * z_mm)
    }
}

impl Default for ObservationConfig {
    fn default() -> Self {
        Self {
            min_points: 30,
            flying_abs_mm: 10.0,
            flying_rel: 0.03,
            fragment_max_fraction: 0.1,
            outlier_k: 3.5,
            normal_radius_px: 3,
            normal_radius_noise_ref: 2.3e-3,
            normal_radius_max_px: 6,
            max_subsample: 400,
            occluder_margin_mm: 20.0,
            occluder_ref_quantile: 0.5,
            missing_explains: false,
            leak_trim: true,
            leak_ring_px: 8,
            leak_min_ring_fraction: 0.5,
            leak_max_fraction: 0.35,
            leak_tol_mm: 6.0,
            leak_tol_rel: 0.01,
            retry_below_score: 0.35,
            retry_min_face_fraction: 0.05,
        }
    }
}

/// Square dilation of a `w × h` bitmap (row-major) by `r`: a position is set when some set
/// position lies within `r` of it along both axes; positions outside the bitmap are unset.
/// Separable and streamed with a lag of r: along each row, then down the columns row by row
/// (position i is set when the last set position up to i + r lies at i - r or later).
pub(crate) fn dilate_square(bits: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    let within = |last: Option<usize>, j: usize| last.is_some_and(|l| l + 2 * r >= j);
    let mut rows = vec![false; w * h];
    for (src, dst) in bits
        .chunks_exact(w.max(1))
        .zip(rows.chunks_exact_mut(w.max(1)))
    {
        let mut last = None;
        for j in 0..w + r {
            if j < w && src[j] {
                last = Some(j);
            }
            if j >= r {
                dst[j - r] = within(last, j);
            }
        }
    }
    let mut out = vec![false; w * h];
    let mut last = vec![None; w];
    for j in 0..h + r {
        if j < h {
            for (l, &b) in last.iter_mut().zip(&rows[j * w..(j + 1) * w]) {
                if b {
                    *l = Some(j);
                }
            }
        }
        if j >= r {
            for (o, &l) in out[(j - r) * w..(j - r + 1) * w].iter_mut().zip(&last) {
                *o = within(l, j);
            }
        }
    }
    out
}

/// The best of `iters` planes through three random points of `pts` (most points within
/// `tol(p)` mm of it), skipping normals that `accept` rejects: (inlier count, unit normal of
/// either sign, a point on the plane). Deterministic for a given `rng` state.
fn ransac_plane(
    pts: &[Point3<f64>],
    iters: usize,
    rng: &mut ChaCha8Rng,
    tol: impl Fn(&Point3<f64>) -> f64,
    accept: impl Fn(&Vector3<f64>) -> bool,
) -> Option<(usize, Vector3<f64>, Point3<f64>)> {
    if pts.is_empty() {
        return None;
    }
    let mut best: Option<(usize, Vector3<f64>, Point3<f64>)> = None;
    // Coordinates and tolerances as separate arrays: each hypothesis' count then vectorises.
    // (`(p - a).dot(&n)` term by term, in nalgebra's order: the same counts.)
    let xs: Vec<f64> = pts.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = pts.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = pts.iter().map(|p| p.z).collect();
    let tols: Vec<f64> = pts.iter().map(&tol).collect();
    for _ in 0..iters {
        let (a, b, c) = (
            pts[rng.random_range(0..pts.len())],
            pts[rng.random_range(0..pts.len())],
            pts[rng.random_range(0..pts.len())],
        );
        let Some(n) = (b - a).cross(&(c - a)).try_normalize(1e-9) else {
            continue;
        };
        if !accept(&n) {
            continue;
        }
        let count = xs
            .iter()
            .zip(&ys)
            .zip(&zs)
            .zip(&tols)
            .filter(|(((x, y), z), t)| {
                ((*x - a.x) * n.x + (*y - a.y) * n.y + (*z - a.z) * n.z).abs() <= **t
            })
            .count();
        if best.as_ref().is_none_or(|x| count > x.0) {
            best = Some((count, n, a));
        }
    }
    best
}

/// The mask without its leak onto the surface it stands on or lies against: the dominant plane
/// of a ring of `leak_ring_px` around the mask (RANSAC, deterministic; at least
/// `leak_min_ring_fraction` of the ring) is the support; mask pixels on that plane and facing
/// like it (within 30°: a box's side face at its foot faces sideways) are removed
/// when they are at most `leak_max_fraction` of the mask and the rest of the mask lies in front
/// of the plane (towards the camera). `None` when nothing is trimmed. A few per cent of table
/// pixels at a box's foot otherwise pull the face hypotheses and the size fit onto the table.
pub fn trim_support_leak(
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    mask: &Mask,
    cfg: &ObservationConfig,
) -> Option<Mask> {
    if !cfg.leak_trim || depth.width != mask.width || depth.height != mask.height {
        return None;
    }
    let (w, h) = (mask.width as usize, mask.height as usize);
    let (u0, v0, u1, v1) = mask.bbox()?;
    let r = cfg.leak_ring_px.max(1) as usize;
    let (eu0, ev0) = (
        (u0 as usize).saturating_sub(r),
        (v0 as usize).saturating_sub(r),
    );
    let (eu1, ev1) = ((u1 as usize + r + 1).min(w), (v1 as usize + r + 1).min(h));
    let (bw, bh) = (eu1 - eu0, ev1 - ev0);
    // The pixel's 3D point where it has valid depth.
    let point_at = |u: usize, v: usize| -> Option<Point3<f64>> {
        let d = *depth.depth_mm.get(v * w + u)?;
        (d.is_finite() && d > 0.0).then(|| intrinsics.back_project(u as f64, v as f64, d as f64))
    };
    // Square dilation of the mask by r; the ring is what it adds, column by column.
    let window: Vec<bool> = (ev0..ev1)
        .flat_map(|v| mask.data[v * w + eu0..v * w + eu1].iter().copied())
        .collect();
    let dilated = dilate_square(&window, bw, bh, r);
    let mut ring_pts: Vec<Point3<f64>> = Vec::new();
    for x in 0..bw {
        for y in 0..bh {
            let (u, v) = (eu0 + x, ev0 + y);
            if dilated[y * bw + x] && !mask.data[v * w + u] {
                ring_pts.extend(point_at(u, v));
            }
        }
    }
    if ring_pts.len() < 30 {
        return None;
    }
    let stride = ring_pts.len().div_ceil(1500).max(1);
    let ring: Vec<Point3<f64>> = ring_pts.into_iter().step_by(stride).collect();
    let tol = |p: &Point3<f64>| cfg.plane_tol_mm(p.z);
    // RANSAC over the ring with a fixed seed: deterministic.
    let mut rng = ChaCha8Rng::seed_from_u64(0x1EA4);
    let (count, mut n, a) = ransac_plane(&ring, 100, &mut rng, tol, |_| true)?;
    if (count as f64) < cfg.leak_min_ring_fraction * ring.len() as f64 {
        return None;
    }
    // Normal towards the camera: "in front" is positive.
    if n.dot(&a.coords) > 0.0 {
        n = -n;
    }
    // Whether the surface at pixel (u, v) faces like the plane (within 30°): a box's side
    // face at its foot lies within the tolerance of the table too, but faces sideways.
    let faces_like = |u: usize, v: usize, n: &Vector3<f64>| -> bool {
        let q = 2;
        if u < q || v < q || u + q >= w || v + q >= h {
            return false;
        }
        let (Some(l), Some(r), Some(t), Some(b)) = (
            point_at(u - q, v),
            point_at(u + q, v),
            point_at(u, v - q),
            point_at(u, v + q),
        ) else {
            return false;
        };
        (r - l)
            .cross(&(b - t))
            .try_normalize(1e-9)
            .is_some_and(|m| m.dot(n).abs() >= 0.866)
    };
    let mut on_plane = Vec::new();
    let mut in_front: Vec<f64> = Vec::new();
    for v in v0 as usize..=v1 as usize {
        for u in u0 as usize..=u1 as usize {
            let i = v * w + u;
            if !mask.data[i] {
                continue;
            }
            let Some(p) = point_at(u, v) else {
                continue;
            };
            let s = (p - a).dot(&n);
            if s.abs() <= tol(&p) && faces_like(u, v, &n) {
                on_plane.push(i);
            } else {
                in_front.push(s);
            }
        }
    }
    let total = on_plane.len() + in_front.len();
    if on_plane.is_empty()
        || in_front.is_empty()
        || on_plane.len() as f64 > cfg.leak_max_fraction * total as f64
        || median(in_front) <= 0.0
    {
        return None;
    }
    let mut out = mask.clone();
    for i in on_plane {
        out.data[i] = false;
    }
    Some(out)
}

/// The mask's pixels with valid depth (finite, positive), row by row within its bounding box:
/// their indices into the frame and their back-projected points, mm. Empty when the mask is
/// empty or its size is not the depth map's.
pub fn mask_points(
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    mask: &Mask,
) -> (Vec<usize>, Vec<Point3<f64>>) {
    let (mut idx, mut pts) = (Vec::new(), Vec::new());
    if depth.width != mask.width || depth.height != mask.height {
        return (idx, pts);
    }
    let Some((u0, v0, u1, v1)) = mask.bbox() else {
        return (idx, pts);
    };
    let w = mask.width as usize;
    for v in v0 as usize..=v1 as usize {
        for u in u0 as usize..=u1 as usize {
            let i = v * w + u;
            let z = depth.depth_mm[i];
            if mask.data[i] && z.is_finite() && z > 0.0 {
                idx.push(i);
                pts.push(intrinsics.back_project(u as f64, v as f64, z as f64));
            }
        }
    }
    (idx, pts)
}

/// The mask cut down to what a box would show: up to three mutually perpendicular planes of
/// its own points (RANSAC, deterministic, tolerance as [`trim_support_leak`]'s), each holding
/// at least `retry_min_face_fraction` of the points, each with the others' points behind it
/// (a box is convex); pixels with valid depth on none of them go. Pixels without depth stay.
/// `None` when no plane is found or nothing would go. The mask of a box seen with a strip of
/// a shelf board, an upright or a neighbour caught along its rim becomes the box's faces.
pub fn box_faces_mask(
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    mask: &Mask,
    cfg: &ObservationConfig,
) -> Option<Mask> {
    if depth.width != mask.width || depth.height != mask.height {
        return None;
    }
    let (idx, pts) = mask_points(depth, intrinsics, mask);
    if pts.len() < 30 {
        return None;
    }
    let tol = |p: &Point3<f64>| cfg.plane_tol_mm(p.z);
    let stride = pts.len().div_ceil(1500).max(1);
    let sample: Vec<usize> = (0..pts.len()).step_by(stride).collect();
    let min_in = (cfg.retry_min_face_fraction * sample.len() as f64).max(10.0) as usize;
    let mut rng = ChaCha8Rng::seed_from_u64(0xB0C5);
    // Planes found so far: unit normal towards the camera and a point on it.
    let mut planes: Vec<(Vector3<f64>, Point3<f64>)> = Vec::new();
    let mut free: Vec<bool> = vec![true; pts.len()];
    for _ in 0..3 {
        let cand: Vec<Point3<f64>> = sample
            .iter()
            .filter(|&&i| free[i])
            .map(|&i| pts[i])
            .collect();
        if cand.len() < min_in {
            break;
        }
        // Perpendicular to the planes already found (within about 15°).
        let perpendicular = |n: &Vector3<f64>| planes.iter().all(|(m, _)| m.dot(n).abs() <= 0.26);
        let Some((count, mut n, a)) = ransac_plane(&cand, 150, &mut rng, tol, perpendicular) else {
            break;
        };
        if count < min_in {
            break;
        }
        if n.dot(&a.coords) > 0.0 {
            n = -n;
        }
        for (i, f) in free.iter_mut().enumerate() {
            if *f && (pts[i] - a).dot(&n).abs() <= tol(&pts[i]) {
                *f = false;
            }
        }
        planes.push((n, a));
    }
    if planes.is_empty() {
        return None;
    }
    // Convexity: a face has the other faces' points behind it (median signed distance ≤ tol).
    let on = |k: usize, p: &Point3<f64>| (p - planes[k].1).dot(&planes[k].0).abs() <= tol(p);
    let mut keep = vec![true; planes.len()];
    for k in 1..planes.len() {
        for j in 0..k {
            let front: Vec<f64> = sample
                .iter()
                .map(|&i| &pts[i])
                .filter(|p| on(j, p) && !on(k, p))
                .map(|p| (p - planes[k].1).dot(&planes[k].0) - tol(p))
                .collect();
            if !front.is_empty() && median(front) > 0.0 {
                keep[k] = false;
            }
        }
    }
    let mut out = mask.clone();
    let mut removed = 0usize;
    for (p, &i) in pts.iter().zip(&idx) {
        if !(0..planes.len()).any(|k| keep[k] && on(k, p)) {
            out.data[i] = false;
            removed += 1;
        }
    }
    (removed > 0 && removed < pts.len()).then_some(out)
}

/// Row prefix sums of a mask over its bounding box: O(1) count of mask pixels in any row interval.
#[derive(Debug, Clone, PartialEq)]
pub struct MaskRows {
    /// Bounding box origin column, px.
    pub u0: u32,
    /// Bounding box origin row, px.
    pub v0: u32,
    /// Bounding box width, px.
    pub width: u32,
    /// Bounding box height, px.
    pub height: u32,
    /// `prefix[r * (width + 1) + k]` = mask pixels in row `v0 + r`, columns `u0 .. u0 + k`.
    pub prefix: Vec<u32>,
    /// Total mask pixels.
    pub count: usize,
}

impl MaskRows {
    /// Prefix sums of an arbitrary per-pixel predicate over the rectangle `u0.., v0..` of
    /// `width × height` px, given a row at a time: `row(v, out)` sets `out[k]` for pixel
    /// `(u0 + k, v)` (`out` has `width` entries), so that callers can read their frames' rows
    /// as slices.
    pub fn from_rows(
        u0: u32,
        v0: u32,
        width: u32,
        height: u32,
        row: impl Fn(u32, &mut [bool]),
    ) -> Self {
        let stride = width as usize + 1;
        let mut prefix = vec![0u32; stride * height as usize];
        let mut bits = vec![false; width as usize];
        let mut count = 0usize;
        for (r, sums) in prefix.chunks_exact_mut(stride).enumerate() {
            bits.fill(false);
            row(v0 + r as u32, &mut bits);
            let mut acc = 0u32;
            for (s, &b) in sums[1..].iter_mut().zip(&bits) {
                acc += u32::from(b);
                *s = acc;
            }
            count += acc as usize;
        }
        Self {
            u0,
            v0,
            width,
            height,
            prefix,
            count,
        }
    }

    /// Builds the prefix sums; `None` for an empty mask (or a buffer shorter than w × h).
    pub fn new(mask: &Mask) -> Option<Self> {
        let w = mask.width as usize;
        if w == 0 || mask.data.len() < w * mask.height as usize {
            return None;
        }
        // Bounding box from row slices (much faster than a per-pixel scan).
        let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0usize, 0usize);
        for (v, row) in mask
            .data
            .chunks_exact(w)
            .take(mask.height as usize)
            .enumerate()
        {
            // Most rows of a full-frame instance mask are empty: a branch-free OR (which
            // vectorises) rejects them faster than the early-exit search (as `Mask::bbox`).
            if !row.iter().fold(false, |a, &b| a | b) {
                continue;
            }
            if let Some(a) = row.iter().position(|b| *b) {
                // `a` exists, so `rposition` finds at least that pixel.
                let b = row.iter().rposition(|b| *b).unwrap_or(a);
                u0 = u0.min(a);
                u1 = u1.max(b);
                v0 = v0.min(v);
                v1 = v;
            }
        }
        if u0 == usize::MAX {
            return None;
        }
        let (bw, bh) = (u1 - u0 + 1, v1 - v0 + 1);
        Some(Self::from_rows(
            u0 as u32,
            v0 as u32,
            bw as u32,
            bh as u32,
            |v, out| {
                let line = v as usize * w;
                out.copy_from_slice(&mask.data[line + u0..line + u1 + 1]);
            },
        ))
    }

    /// Mask pixels in row `v`, columns `ua..=ub` (any values; clipped to the bounding box).
    #[inline]
    pub fn count_in_row(&self, v: i64, ua: i64, ub: i64) -> u32 {
        let r = v - self.v0 as i64;
        if r < 0 || r >= self.height as i64 {
            return 0;
        }
        let a = (ua - self.u0 as i64).clamp(0, self.width as i64) as usize;
        let b = (ub + 1 - self.u0 as i64).clamp(0, self.width as i64) as usize;
        if b <= a {
            return 0;
        }
        let base = r as usize * (self.width as usize + 1);
        match (self.prefix.get(base + b), self.prefix.get(base + a)) {
            (Some(hi), Some(lo)) => hi - lo,
            _ => 0,
        }
    }
}

/// The 3D observation of one instance (camera frame, mm).
#[derive(Debug, Clone)]
pub struct Observation {
    /// Back-projected points of the mask pixels with valid depth that survived outlier rejection, mm.
    pub points_mm: Vec<Point3<f64>>,
    /// Unit normals, one per point, oriented toward the camera (`n · p < 0`).
    pub normals: Vec<Vector3<f64>>,
    /// Pixel `[u, v]` of each point.
    pub pixels: Vec<[u32; 2]>,
    /// The caller's mask (unchanged).
    pub mask: Mask,
    /// Mean of the points, mm.
    pub centroid_mm: Point3<f64>,
    /// Indices into `points_mm` of a fixed, spatially spread subsample (≤ `max_subsample`) used for
    /// scoring and ICP.
    pub subsample: Vec<usize>,
    /// Row prefix sums of `mask` (silhouette IoU in O(rows)).
    pub mask_rows: MaskRows,
    /// Row prefix sums of the pixels *outside* the mask whose appearance a box behind them
    /// explains: depth missing (only with `missing_explains`), or nearer than the observation's
    /// median depth (`occluder_ref_quantile`) minus
    /// `max(occluder_margin_mm, 3 % z)` (an occluder). Over the mask's bounding box grown by half
    /// its larger side (+8 px); outside that region silhouette pixels count as disagreement. Used by the occlusion-aware silhouette agreement.
    pub explained_rows: MaskRows,
    /// Per-observation caches filled by the first `estimate_pose` call (depth cells, hypothesis
    /// frames), reused by the later calls of the scale loop.
    pub(crate) cache: ObsCache,
}

/// Lazily filled, size-independent intermediate results of `estimate_pose`.
#[derive(Debug, Clone, Default)]
pub(crate) struct ObsCache {
    /// `(cell_px, region_margin bits, cells)` of the depth map this observation was built from.
    pub(crate) cells: OnceLock<(u32, u64, CellMinDepth)>,
    /// `(config, frames + noise)` from `hypotheses::analyse`.
    pub(crate) frames: OnceLock<(HypothesisConfig, FrameSet)>,
}

impl Observation {
    /// Unit viewing direction from the camera toward the centroid.
    pub fn view_dir(&self) -> Vector3<f64> {
        let c = self.centroid_mm.coords;
        let n = c.norm();
        if n > 0.0 && n.is_finite() {
            c / n
        } else {
            Vector3::z()
        }
    }
}

/// Checks that mask and depth agree in size and buffer length.
pub(crate) fn check_sizes(depth: &DepthMap, mask: &Mask) -> Result<(), EstimateError> {
    if mask.width != depth.width || mask.height != depth.height {
        return Err(EstimateError::SizeMismatch {
            mask_width: mask.width,
            mask_height: mask.height,
            depth_width: depth.width,
            depth_height: depth.height,
        });
    }
    let expected = depth.width as usize * depth.height as usize;
    if depth.depth_mm.len() != expected {
        return Err(EstimateError::BadBuffer {
            what: "depth map",
            len: depth.depth_mm.len(),
            expected,
        });
    }
    if mask.data.len() != expected {
        return Err(EstimateError::BadBuffer {
            what: "mask",
            len: mask.data.len(),
            expected,
        });
    }
    Ok(())
}

/// Drops the depth fragments of `keep` (see [`ObservationConfig::fragment_max_fraction`]).
/// `z` and `keep` cover the mask's `bw × bh` bounding box.
fn drop_fragments(z: &[f32], keep: &mut [bool], bw: usize, bh: usize, cfg: &ObservationConfig) {
    // Flood fill; `label[i]` is the 1-based piece of pixel i (0 = not kept).
    let mut label = vec![0u32; bw * bh];
    let mut sizes = vec![0usize];
    let mut stack = Vec::new();
    for start in 0..bw * bh {
        if !keep[start] || label[start] != 0 {
            continue;
        }
        let id = sizes.len() as u32;
        label[start] = id;
        stack.push(start);
        let mut n = 0usize;
        while let Some(i) = stack.pop() {
            n += 1;
            let (r, k) = (i / bw, i % bw);
            let mut visit = |j: usize| {
                if keep[j]
                    && label[j] == 0
                    && (z[j] - z[i]).abs() <= cfg.flying_tol_mm(z[i].max(z[j]))
                {
                    label[j] = id;
                    stack.push(j);
                }
            };
            if k > 0 {
                visit(i - 1);
            }
            if k + 1 < bw {
                visit(i + 1);
            }
            if r > 0 {
                visit(i - bw);
            }
            if r + 1 < bh {
                visit(i + bw);
            }
        }
        sizes.push(n);
    }
    if sizes.len() <= 2 {
        return;
    }
    // A piece is a leak only where it borders a larger piece (within 2 px: the flying-pixel
    // cut thins the seam) across a depth jump. A piece set apart by pixels outside the mask is
    // the box seen past an occluder, and its extent counts.
    let mut beside_larger = vec![false; sizes.len()];
    for i in 0..bw * bh {
        let l = label[i] as usize;
        if l == 0 {
            continue;
        }
        let (r, k) = (i / bw, i % bw);
        for (dr, dk) in [(0, 1), (0, 2), (1, 0), (2, 0)] {
            let (rr, kk) = (r + dr, k + dk);
            if rr >= bh || kk >= bw {
                continue;
            }
            let j = rr * bw + kk;
            let m = label[j] as usize;
            // A depth jump between the two, and no hole between them (a pixel two away
            // counts only across a flying pixel, which has depth).
            let across = m != 0
                && m != l
                && (z[j] - z[i]).abs() > cfg.flying_tol_mm(z[i].max(z[j]))
                && (dr + dk == 1 || z[(r + dr / 2) * bw + k + dk / 2] > 0.0);
            if across {
                if sizes[m] > sizes[l] {
                    beside_larger[l] = true;
                } else if sizes[l] > sizes[m] {
                    beside_larger[m] = true;
                }
            }
        }
    }
    let largest = sizes.iter().copied().max().unwrap_or(0);
    let min = (cfg.fragment_max_fraction * largest as f64).ceil() as usize;
    for (k, &l) in keep.iter_mut().zip(&label) {
        if *k && sizes[l as usize] < min && beside_larger[l as usize] {
            *k = false;
        }
    }
}

/// The normal window's radius for one mask, px: `normal_radius_px`, grown with the mask's depth
/// noise (see [`ObservationConfig::normal_radius_noise_ref`]). `z_box` and `keep`: the depth
/// over the mask's bounding box (`bw` × `bh`) and the pixels kept; `points`: the kept points.
fn normal_radius(
    z_box: &[f32],
    keep: &[bool],
    bw: usize,
    bh: usize,
    points: &[Point3<f64>],
    cfg: &ObservationConfig,
) -> u32 {
    let base = cfg.normal_radius_px;
    if cfg.normal_radius_noise_ref <= 0.0 {
        return base;
    }
    // Border pixels of the box have no 8 neighbours: `relative_residual` leaves them out.
    let vals: Vec<f64> = (0..bw * bh)
        .filter(|&i| keep[i])
        .filter_map(|i| crate::depth_noise::relative_residual(z_box, bw, i, |j| keep[j]))
        .map(f64::from)
        .collect();
    if vals.len() < 200 {
        return base;
    }
    let k = median(vals);
    let z = median(points.iter().map(|p| p.z).collect());
    let grown = (f64::from(base) * k * z / cfg.normal_radius_noise_ref).round();
    log::debug!("observation noise index {k:e} at {z:.0} mm: normal radius {grown}");
    if grown.is_finite() && grown > f64::from(base) {
        (grown as u32).min(cfg.normal_radius_max_px.max(base))
    } else {
        base
    }
}

/// Builds the [`Observation`] of one masked instance (see the module docs for the filters).
///
/// Errors: [`EstimateError::SizeMismatch`] / [`EstimateError::BadBuffer`] when mask and depth
/// disagree, [`EstimateError::EmptyMask`], [`EstimateError::TooFewPoints`] when fewer than
/// `cfg.min_points` usable points remain, [`EstimateError::Geom`] for invalid intrinsics.
pub fn observe(
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    mask: &Mask,
    cfg: &ObservationConfig,
) -> Result<Observation, EstimateError> {
    check_sizes(depth, mask)?;
    // Re-validate: the struct fields are public, so a zero focal length can reach us.
    Intrinsics::new(intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy)?;
    let mask_rows = MaskRows::new(mask).ok_or(EstimateError::EmptyMask)?;
    let needed = cfg.min_points.max(3);
    let (u0, v0) = (mask_rows.u0, mask_rows.v0);
    let (bw, bh) = (mask_rows.width as usize, mask_rows.height as usize);
    let w = depth.width as usize;

    // Valid in-mask depth over the bounding box (0 = unusable).
    let mut z_box = vec![0f32; bw * bh];
    for r in 0..bh {
        for k in 0..bw {
            let (u, v) = (u0 as usize + k, v0 as usize + r);
            let i = v * w + u;
            if mask.data.get(i).copied().unwrap_or(false) {
                let d = depth.depth_mm.get(i).copied().unwrap_or(0.0);
                if d.is_finite() && d > 0.0 {
                    z_box[r * bw + k] = d;
                }
            }
        }
    }

    // 1. Flying pixels: compare with the 3×3 in-mask valid median.
    let mut keep = vec![false; bw * bh];
    for r in 0..bh {
        for k in 0..bw {
            let z = z_box[r * bw + k];
            if z <= 0.0 {
                continue;
            }
            // |z − median(3×3 in-mask valid)| ≤ tol ⇔ (up to ties) at least half of the valid
            // neighbourhood lies within tol of z; counting avoids a sort per pixel.
            let tol = cfg.flying_tol_mm(z);
            let (mut n, mut close) = (0u32, 0u32);
            for rr in r.saturating_sub(1)..(r + 2).min(bh) {
                for kk in k.saturating_sub(1)..(k + 2).min(bw) {
                    let zz = z_box[rr * bw + kk];
                    if zz > 0.0 {
                        n += 1;
                        if (zz - z).abs() <= tol {
                            close += 1;
                        }
                    }
                }
            }
            keep[r * bw + k] = 2 * close > n;
        }
    }

    if cfg.fragment_max_fraction > 0.0 {
        drop_fragments(&z_box, &mut keep, bw, bh, cfg);
    }

    let kept = keep.iter().filter(|k| **k).count();
    let mut points = Vec::with_capacity(kept);
    let mut pixels = Vec::with_capacity(kept);
    for r in 0..bh {
        for k in 0..bw {
            if keep[r * bw + k] {
                let (u, v) = (u0 + k as u32, v0 + r as u32);
                let z = z_box[r * bw + k] as f64;
                points.push(intrinsics.back_project(u as f64, v as f64, z));
                pixels.push([u, v]);
            }
        }
    }
    if points.len() < needed {
        return Err(EstimateError::TooFewPoints {
            valid: points.len(),
            needed,
        });
    }

    // 2. Robust distance-to-centroid cut.
    if cfg.outlier_k > 0.0 {
        // Statistics from an even stride of ≤ 4096 points: the cut only needs a threshold.
        let stride = points.len().div_ceil(4096).max(1);
        let probe: Vec<Point3<f64>> = points.iter().step_by(stride).copied().collect();
        let med = Point3::new(
            median(probe.iter().map(|p| p.x).collect()),
            median(probe.iter().map(|p| p.y).collect()),
            median(probe.iter().map(|p| p.z).collect()),
        );
        let dp: Vec<f64> = probe.iter().map(|p| (p - med).norm()).collect();
        let dm = median(dp.clone());
        let mad = median(dp.iter().map(|x| (x - dm).abs()).collect());
        let d: Vec<f64> = points.iter().map(|p| (p - med).norm()).collect();
        let cut = dm + cfg.outlier_k * 1.4826 * mad;
        if cut.is_finite() && mad > 0.0 {
            let mut j = 0;
            for i in 0..points.len() {
                if d[i] <= cut {
                    points[j] = points[i];
                    pixels[j] = pixels[i];
                    j += 1;
                }
            }
            points.truncate(j);
            pixels.truncate(j);
        }
    }
    if points.len() < needed {
        return Err(EstimateError::TooFewPoints {
            valid: points.len(),
            needed,
        });
    }

    let radius = normal_radius(&z_box, &keep, bw, bh, &points, cfg);
    let normals = gradient_normals(&points, &pixels, u0, v0, bw, bh, radius);

    let n = points.len();
    let centroid =
        Point3::from(points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n as f64);
    let m = cfg.max_subsample.max(1);
    let subsample: Vec<usize> = if n <= m {
        (0..n).collect()
    } else {
        // Pixels are in raster order, so an even stride spreads the subsample over the mask.
        (0..m).map(|j| (j * n + n / (2 * m)) / m).collect()
    };
    let z_med = quantile(
        points
            .iter()
            .step_by(n.div_ceil(2048).max(1))
            .map(|p| p.z)
            .collect(),
        cfg.occluder_ref_quantile,
    );
    let z_cut = (z_med - cfg.occluder_margin_mm.max(0.03 * z_med)) as f32;
    let grow = mask_rows.width.max(mask_rows.height) / 2 + 8;
    let (eu0, ev0) = (u0.saturating_sub(grow), v0.saturating_sub(grow));
    let eu1 = (u0 + mask_rows.width + grow).min(depth.width);
    let ev1 = (v0 + mask_rows.height + grow).min(depth.height);
    let explained_rows = MaskRows::from_rows(eu0, ev0, eu1 - eu0, ev1 - ev0, |v, out| {
        // In bounds: the region is clipped to the image and both buffers were checked.
        let line = v as usize * w + eu0 as usize;
        let depth_row = &depth.depth_mm[line..line + out.len()];
        let mask_row = &mask.data[line..line + out.len()];
        for ((o, &d), &m) in out.iter_mut().zip(depth_row).zip(mask_row) {
            let missing = d.is_nan() || d <= 0.0;
            *o = !m && ((missing && cfg.missing_explains) || (!missing && d < z_cut));
        }
    });
    Ok(Observation {
        points_mm: points,
        normals,
        pixels,
        mask: mask.clone(),
        centroid_mm: centroid,
        subsample,
        mask_rows,
        explained_rows,
        cache: ObsCache::default(),
    })
}

/// Average-3D-gradient normals from integral images over the bounding box (module docs).
fn gradient_normals(
    points: &[Point3<f64>],
    pixels: &[[u32; 2]],
    u0: u32,
    v0: u32,
    bw: usize,
    bh: usize,
    radius_px: u32,
) -> Vec<Vector3<f64>> {
    // integral[(r) * (bw + 1) + k] = [count, Σx, Σy, Σz] over rows < r, columns < k.
    let stride = bw + 1;
    let mut integral = vec![[0f64; 4]; stride * (bh + 1)];
    for (p, px) in points.iter().zip(pixels) {
        let (k, r) = ((px[0] - u0) as usize, (px[1] - v0) as usize);
        let cell = &mut integral[(r + 1) * stride + k + 1];
        *cell = [1.0, p.x, p.y, p.z];
    }
    for r in 1..=bh {
        let mut row = [0f64; 4];
        for k in 1..=bw {
            let i = r * stride + k;
            let above = integral[i - stride];
            for c in 0..4 {
                row[c] += integral[i][c];
                integral[i][c] = row[c] + above[c];
            }
        }
    }
    let rect = |k0: i64, k1: i64, r0: i64, r1: i64| -> [f64; 4] {
        let k0 = k0.max(0) as usize;
        let r0 = r0.max(0) as usize;
        let k1 = k1.min(bw as i64 - 1);
        let r1 = r1.min(bh as i64 - 1);
        if k1 < k0 as i64 || r1 < r0 as i64 {
            return [0.0; 4];
        }
        let (k1, r1) = (k1 as usize + 1, r1 as usize + 1);
        let (a, b) = (integral[r1 * stride + k1], integral[r0 * stride + k1]);
        let (c, d) = (integral[r1 * stride + k0], integral[r0 * stride + k0]);
        [
            a[0] - b[0] - c[0] + d[0],
            a[1] - b[1] - c[1] + d[1],
            a[2] - b[2] - c[2] + d[2],
            a[3] - b[3] - c[3] + d[3],
        ]
    };
    let mean = |s: [f64; 4], fallback: &Point3<f64>| {
        if s[0] > 0.5 {
            Vector3::new(s[1], s[2], s[3]) / s[0]
        } else {
            fallback.coords
        }
    };
    let rad = radius_px.clamp(1, 16) as i64;
    let mut normals = Vec::with_capacity(points.len());
    for (p, px) in points.iter().zip(pixels) {
        let (k, r) = ((px[0] - u0) as i64, (px[1] - v0) as i64);
        let left = mean(rect(k - rad, k - 1, r - rad, r + rad), p);
        let right = mean(rect(k + 1, k + rad, r - rad, r + rad), p);
        let up = mean(rect(k - rad, k + rad, r - rad, r - 1), p);
        let down = mean(rect(k - rad, k + rad, r + 1, r + rad), p);
        let n = (right - left).cross(&(down - up));
        let fallback = -p.coords / p.coords.norm().max(1e-12);
        let mut nrm = n.try_normalize(1e-12).unwrap_or(fallback);
        if nrm.dot(&p.coords) > 0.0 {
            nrm = -nrm;
        }
        normals.push(nrm);
    }
    normals
}

/// Median of a non-empty vector (upper median); 0 for an empty one.
pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    *m
}

/// The `q`-quantile (0..1, clamped; nearest rank) of a vector; 0 for an empty one.
pub(crate) fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let q = if q.is_finite() {
        q.clamp(0.0, 1.0)
    } else {
        0.5
    };
    let k = ((q * v.len() as f64) as usize).min(v.len() - 1);
    let (_, m, _) = v.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    *m
}

/// Eigenvalues of a symmetric 3×3 matrix, descending (closed form, Smith 1961).
pub(crate) fn sym3_eigenvalues(a: &Matrix3<f64>) -> [f64; 3] {
    let p1 = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    let q = a.trace() / 3.0;
    let p2 = (a[(0, 0)] - q).powi(2) + (a[(1, 1)] - q).powi(2) + (a[(2, 2)] - q).powi(2) + 2.0 * p1;
    if p2 <= 1e-300 {
        return [q, q, q];
    }
    let p = (p2 / 6.0).sqrt();
    let b = (a - Matrix3::identity() * q) / p;
    let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let e1 = q + 2.0 * p * phi.cos();
    let e3 = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    [e1, 3.0 * q - e1 - e3, e3]
}

/// Unit eigenvector of a symmetric 3×3 matrix for eigenvalue `lambda`; `None` when degenerate.
pub(crate) fn sym3_eigenvector(a: &Matrix3<f64>, lambda: f64) -> Option<Vector3<f64>> {
    let m = a - Matrix3::identity() * lambda;
    let r0 = m.row(0).transpose();
    let r1 = m.row(1).transpose();
    let r2 = m.row(2).transpose();
    let c = [r0.cross(&r1), r0.cross(&r2), r1.cross(&r2)];
    let best = c
        .iter()
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))?;
    let n = best.norm();
    (n > 1e-12 * (1.0 + m.norm().powi(2)) && n.is_finite()).then(|| best / n)
}

/// Eigenvector of the smallest eigenvalue (the plane normal of a point covariance).
pub(crate) fn smallest_eigenvector(a: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let e = sym3_eigenvalues(a);
    sym3_eigenvector(a, e[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k() -> Intrinsics {
        Intrinsics::new(600.0, 600.0, 32.0, 24.0).unwrap()
    }

    /// A 60 × 40 px patch of a plane at `z_mm` with white noise of `sigma_mm`: depth, keep
    /// flags and points (their depth is all `normal_radius` reads of them).
    fn noisy_patch(z_mm: f64, sigma_mm: f64) -> (Vec<f32>, Vec<bool>, Vec<Point3<f64>>) {
        use crate::pipeline::test_scene::gauss;
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let z: Vec<f32> = (0..60 * 40)
            .map(|i| (z_mm + 0.1 * (i % 60) as f64 + sigma_mm * gauss(&mut rng)) as f32)
            .collect();
        let points = z
            .iter()
            .map(|&d| Point3::new(0.0, 0.0, f64::from(d)))
            .collect();
        (z, vec![true; 60 * 40], points)
    }

    #[test]
    fn normal_window_grows_with_the_masks_noise_for_its_depth() {
        let cfg = ObservationConfig {
            normal_radius_noise_ref: 2.3e-3,
            normal_radius_max_px: 6,
            ..ObservationConfig::default()
        };
        let radius = |z: f64, sigma: f64| {
            let (zb, keep, pts) = noisy_patch(z, sigma);
            normal_radius(&zb, &keep, 60, 40, &pts, &cfg)
        };
        // The index is 0.6745 σ √(9/8) / z²; the radius 3 · index · z / ref, rounded.
        // σ 16 mm at 2 m: index 2.86e-6, 3 · 2.86e-6 · 2000 / 2.3e-3 = 7.5 → the cap, 6.
        assert_eq!(radius(2000.0, 16.0), 6);
        // σ 6 mm at 2 m: 1.07e-6 → 2.8 → 3 (the base).
        assert_eq!(radius(2000.0, 6.0), 3);
        // σ 10 mm at 2 m: 1.79e-6 → 4.7 → 5.
        assert_eq!(radius(2000.0, 10.0), 5);
        // No noise, or the rule off: the base.
        assert_eq!(radius(2000.0, 0.0), 3);
        let (zb, keep, pts) = noisy_patch(2000.0, 16.0);
        let off = ObservationConfig {
            normal_radius_noise_ref: 0.0,
            ..cfg.clone()
        };
        assert_eq!(normal_radius(&zb, &keep, 60, 40, &pts, &off), 3);
    }

    #[test]
    fn closed_form_eigen_matches_nalgebra() {
        let m = Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 1.0);
        let ours = sym3_eigenvalues(&m);
        let mut theirs: Vec<f64> = m.symmetric_eigenvalues().iter().copied().collect();
        theirs.sort_by(|a, b| b.total_cmp(a));
        for i in 0..3 {
            assert!((ours[i] - theirs[i]).abs() < 1e-9, "{ours:?} {theirs:?}");
        }
        let v = smallest_eigenvector(&m).unwrap();
        assert!(((m * v) - v * ours[2]).norm() < 1e-8);
    }

    #[test]
    fn plane_normals_face_camera_and_flying_pixels_are_dropped() {
        // A tilted plane z = 500 + 0.5·x over a 64×48 image, one flying pixel in the middle.
        let kk = k();
        let mut depth = DepthMap::zeros(64, 48);
        let mut mask = Mask::empty(64, 48);
        for v in 4..44u32 {
            for u in 4..60u32 {
                // Solve z = 500 + 0.5·x with x = (u - cx) z / fx.
                let a = (u as f64 - kk.cx) / kk.fx;
                let z = 500.0 / (1.0 - 0.5 * a);
                depth.depth_mm[(v * 64 + u) as usize] = z as f32;
                mask.set(u, v, true);
            }
        }
        depth.depth_mm[(20 * 64 + 30) as usize] = 700.0;
        let obs = observe(&depth, &kk, &mask, &ObservationConfig::default()).unwrap();
        assert_eq!(obs.points_mm.len(), 40 * 56 - 1);
        assert!(!obs.pixels.contains(&[30, 20]));
        let expect = Vector3::new(0.5, 0.0, -1.0).normalize();
        for n in &obs.normals {
            assert!(n.dot(&expect) > 0.999, "{n:?}");
        }
        assert!(obs.subsample.len() <= 400);
        assert_eq!(obs.mask_rows.count, 40 * 56);
        assert_eq!(obs.mask_rows.count_in_row(10, 0, 100), 56);
        assert_eq!(obs.mask_rows.count_in_row(10, 10, 19), 10);
    }

    /// A 120×90 px image: a table (plane tilted about x, ~1 m away) and a box face parallel to
    /// the image at 700 mm; the mask is the face plus a 6 px strip of table below it.
    fn leaky_scene() -> (Intrinsics, DepthMap, Mask, Mask) {
        let kk = Intrinsics::new(300.0, 300.0, 60.0, 45.0).unwrap();
        let (w, h) = (120u32, 90u32);
        let mut depth = DepthMap::zeros(w, h);
        let (mut face, mut leaky) = (Mask::empty(w, h), Mask::empty(w, h));
        // Table: points with y·cos(40°) − z·sin(40°) = −700, i.e. z = (y·c + 700) / s with
        // y = (v − cy)·z / fy.
        let (c, s) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
        for v in 0..h {
            for u in 0..w {
                let b = (v as f64 - kk.cy) / kk.fy;
                let z_table = 700.0 / (s - b * c);
                let i = (v * w + u) as usize;
                let in_face = (40..80).contains(&u) && (20..50).contains(&v);
                depth.depth_mm[i] = if in_face { 700.0 } else { z_table as f32 };
                face.set(u, v, in_face);
                leaky.set(
                    u,
                    v,
                    in_face || ((40..80).contains(&u) && (50..56).contains(&v)),
                );
            }
        }
        (kk, depth, face, leaky)
    }

    #[test]
    fn support_leak_is_trimmed_and_clean_masks_are_left_alone() {
        let (kk, depth, face, leaky) = leaky_scene();
        let cfg = ObservationConfig::default();
        let trimmed = trim_support_leak(&depth, &kk, &leaky, &cfg).expect("the strip is trimmed");
        // The strip goes except its two rows next to the face, whose ±2 px normal window
        // reaches across the depth edge; no face pixel goes.
        let kept_strip = (trimmed.count() as i64 - face.count() as i64).max(0);
        assert!(kept_strip <= 80, "{kept_strip} strip pixels left of 240");
        assert!(face.data.iter().zip(&trimmed.data).all(|(f, t)| !*f || *t));
        assert_eq!(
            trim_support_leak(&depth, &kk, &face, &cfg),
            None,
            "nothing to trim"
        );
        // Off: untouched.
        let off = ObservationConfig {
            leak_trim: false,
            ..cfg.clone()
        };
        assert_eq!(trim_support_leak(&depth, &kk, &leaky, &off), None);
        // A mask that is mostly the plane (a box top flush with its neighbours, here the table
        // itself) is not trimmed.
        let mut table = Mask::empty(120, 90);
        for v in 55..85 {
            for u in 10..110 {
                table.set(u, v, true);
            }
        }
        assert_eq!(trim_support_leak(&depth, &kk, &table, &cfg), None);
    }

    #[test]
    fn leaks_across_depth_jumps_go_but_pieces_past_occluders_and_holes_stay() {
        let kk = k();
        let mut depth = DepthMap::zeros(64, 48);
        let mut mask = Mask::empty(64, 48);
        let mut put = |u: u32, v: u32, z: f32, m: bool| {
            depth.depth_mm[(v * 64 + u) as usize] = z;
            mask.set(u, v, m);
        };
        // A 30 × 28 px face at 800 mm.
        for v in 10..38 {
            for u in 10..40 {
                put(u, v, 800.0, true);
            }
        }
        // Leak: two rows (60 px, under a tenth of the face) of the surface 150 mm behind, just
        // above the face.
        for v in 8..10 {
            for u in 10..40 {
                put(u, v, 950.0, true);
            }
        }
        // An occluder (not in the mask), then two columns of the same face past it.
        for v in 10..38 {
            for u in 40..44 {
                put(u, v, 500.0, false);
            }
            for u in 44..46 {
                put(u, v, 800.0, true);
            }
        }
        // A lone valid pixel in a hole of the face.
        for v in 19..22 {
            for u in 24..27 {
                put(u, v, 0.0, true);
            }
        }
        put(25, 20, 805.0, true);
        // The far-outlier cut off, so that only this stage decides.
        let cfg = ObservationConfig {
            outlier_k: 0.0,
            ..ObservationConfig::default()
        };
        let obs = observe(&depth, &kk, &mask, &cfg).unwrap();
        let has = |f: &dyn Fn(&[u32; 2]) -> bool| obs.pixels.iter().any(f);
        assert!(!has(&|p| p[1] < 10), "the leak is dropped");
        assert!(has(&|p| p[0] >= 44), "the piece past the occluder stays");
        assert!(has(&|p| *p == [25, 20]), "the pixel in the hole stays");
        // Off: the leak stays.
        let off = ObservationConfig {
            fragment_max_fraction: 0.0,
            ..cfg
        };
        let obs = observe(&depth, &kk, &mask, &off).unwrap();
        assert!(obs.pixels.iter().any(|p| p[1] < 10));
    }

    #[test]
    fn missing_depth_explains_overflow_only_when_asked() {
        // A 20×20 patch at 800 mm, nothing else has depth except a nearer occluder strip.
        let kk = k();
        let mut depth = DepthMap::zeros(64, 48);
        let mut mask = Mask::empty(64, 48);
        for v in 10..30u32 {
            for u in 20..40u32 {
                depth.depth_mm[(v * 64 + u) as usize] = 800.0;
                mask.set(u, v, true);
            }
        }
        for v in 10..30u32 {
            depth.depth_mm[(v * 64 + 40) as usize] = 500.0;
        }
        let cfg = ObservationConfig::default();
        assert!(!cfg.missing_explains);
        let obs = observe(&depth, &kk, &mask, &cfg).unwrap();
        // Only the occluder strip explains anything.
        assert_eq!(obs.explained_rows.count, 20);
        let with = ObservationConfig {
            missing_explains: true,
            ..cfg
        };
        let obs = observe(&depth, &kk, &mask, &with).unwrap();
        assert!(
            obs.explained_rows.count > 20 + 400,
            "{}",
            obs.explained_rows.count
        );
    }

    #[test]
    fn bad_inputs_are_errors() {
        let kk = k();
        let depth = DepthMap::zeros(64, 48);
        let cfg = ObservationConfig::default();
        assert_eq!(
            observe(&depth, &kk, &Mask::empty(64, 48), &cfg).unwrap_err(),
            EstimateError::EmptyMask
        );
        assert!(matches!(
            observe(&depth, &kk, &Mask::empty(10, 48), &cfg),
            Err(EstimateError::SizeMismatch { .. })
        ));
        let mut m = Mask::empty(64, 48);
        for u in 0..3 {
            m.set(u, 0, true);
        }
        let mut d = depth.clone();
        d.depth_mm.iter_mut().for_each(|z| *z = 800.0);
        assert_eq!(
            observe(&d, &kk, &m, &cfg).unwrap_err(),
            EstimateError::TooFewPoints {
                valid: 3,
                needed: 30
            }
        );
        let full = Mask {
            width: 64,
            height: 48,
            data: vec![true; 64 * 48],
        };
        assert!(matches!(
            observe(&depth, &kk, &full, &cfg),
            Err(EstimateError::TooFewPoints { valid: 0, .. })
        ));
        let mut nan = d.clone();
        nan.depth_mm.iter_mut().for_each(|z| *z = f32::NAN);
        assert!(observe(&nan, &kk, &full, &cfg).is_err());
        let short = Mask {
            width: 64,
            height: 48,
            data: vec![true; 5],
        };
        assert!(matches!(
            observe(&d, &kk, &short, &cfg),
            Err(EstimateError::BadBuffer { .. })
        ));
        let bad_k = Intrinsics { fx: 0.0, ..kk };
        assert!(observe(&d, &bad_k, &full, &cfg).is_err());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        /// Against the definition: set when a set position lies within r on both axes.
        #[test]
        fn square_dilation_matches_its_definition(
            w in 1usize..24,
            h in 1usize..18,
            r in 0usize..5,
            bits in proptest::collection::vec(proptest::prelude::any::<u8>(), 24 * 18),
            density in 1u8..80,
        ) {
            let bits: Vec<bool> = bits[..w * h].iter().map(|b| *b < density).collect();
            let got = dilate_square(&bits, w, h, r);
            for y in 0..h {
                for x in 0..w {
                    let want = (y.saturating_sub(r)..(y + r + 1).min(h))
                        .any(|yy| (x.saturating_sub(r)..(x + r + 1).min(w)).any(|xx| bits[yy * w + xx]));
                    proptest::prop_assert_eq!(got[y * w + x], want, "({}, {})", x, y);
                }
            }
        }

        /// Row prefix sums of a predicate given a row at a time, against counting.
        #[test]
        fn row_prefix_sums_count_the_predicate(
            (w, h) in (0usize..20, 0usize..12),
            (u0, v0) in (0u32..50, 0u32..50),
            seed in proptest::prelude::any::<u64>(),
        ) {
            let bit = |u: u32, v: u32| (seed.rotate_left(u.wrapping_mul(7) ^ v.wrapping_mul(13)) & 1) == 1;
            let rows = MaskRows::from_rows(u0, v0, w as u32, h as u32, |v, out| {
                assert_eq!(out.len(), w);
                for (k, o) in out.iter_mut().enumerate() {
                    *o = bit(u0 + k as u32, v);
                }
            });
            let mut total = 0;
            for r in 0..h {
                for k in 0..=w {
                    let want = (0..k).filter(|&j| bit(u0 + j as u32, v0 + r as u32)).count();
                    proptest::prop_assert_eq!(rows.prefix[r * (w + 1) + k] as usize, want);
                }
                total += (0..w).filter(|&j| bit(u0 + j as u32, v0 + r as u32)).count();
            }
            proptest::prop_assert_eq!(rows.count, total);
        }
    }
}
