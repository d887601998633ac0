//! The paper's depth-consistency filter (paper §3.2 "Depth-Consistency Filter"; SPEC §1).
//!
//! In: the observed depth map, a pose hypothesis (an [`OrientedBox`]) and the camera.
//! Out: a penalty in `[0, 1]` — the fraction of the hypothesis' surface samples that sit in
//! front of the observed surface.
//!
//! Exactly as the paper: the observed depth is split into `cell_px × cell_px` cells (default 5)
//! and the minimum valid depth of each cell is recorded ([`CellMinDepth`], built once per frame
//! region and reused for every hypothesis); `n_samples` (default 1000) points are sampled
//! area-uniformly on the hypothesis cuboid's surface and projected; a point whose depth is smaller
//! than its cell's minimum depth minus `threshold_mm` (default 0) is *in front* of the observation
//! and counts. A correct pose puts its visible surface at the observed depth and its hidden faces
//! behind it, so almost nothing counts; a symmetric "hovering" pose (a visible face swapped with
//! its opposite, the box floating in front of the scene) puts a whole face in front.
//!
//! Our exact reading of "compare its depth with the observed depth inside the predicted mask":
//! every sample that projects onto the image (inside the region the [`CellMinDepth`] covers) onto a
//! cell holding at least one valid depth is *compared*; the penalty is
//! `in_front / compared` (0 when nothing is compared). Samples behind the camera, outside the
//! region, or on cells without valid depth are not compared (no evidence either way). The
//! predicted mask is thus the set of cells the projected template covers — all faces are
//! projected, hidden ones included, as the paper projects the whole CAD point set.

use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::image::DepthMap;
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Parameters of the depth-consistency filter (paper defaults).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DepthFilterConfig {
    /// Apply the filter when re-ranking hypotheses. `false` = the paper's "no depth filter"
    /// ablation (the penalty is still reported but does not influence the ranking or the score).
    pub enabled: bool,
    /// Cell side, px. Paper: 5.
    pub cell_px: u32,
    /// Surface samples per hypothesis. Paper: 1000.
    pub n_samples: usize,
    /// A sample counts when it is in front of its cell's minimum depth by more than this, mm.
    /// Paper: 0.
    pub threshold_mm: f64,
    /// Weight of the penalty in the pre-refinement ranking key (`coarse + weight · penalty`, both
    /// in [0, 1]). Ours; default 1.
    pub rank_weight: f64,
    /// Seed of the surface samples.
    pub seed: u64,
}

impl Default for DepthFilterConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            cell_px: 5,
            n_samples: 1000,
            threshold_mm: 0.0,
            rank_weight: 1.0,
            seed: 0x5eed_d3b7,
        }
    }
}

/// Minimum valid depth per `cell_px × cell_px` cell over a rectangular image region.
///
/// Cells are aligned to the global image grid (cell `(i, j)` covers columns `i·cell_px ..`), so
/// the result does not depend on the region's origin.
#[derive(Debug, Clone, PartialEq)]
pub struct CellMinDepth {
    /// Cell side, px.
    pub cell_px: u32,
    /// First covered cell column index.
    pub ci0: u32,
    /// First covered cell row index.
    pub cj0: u32,
    /// Covered cells along u.
    pub ncu: u32,
    /// Covered cells along v.
    pub ncv: u32,
    /// Minimum depth per covered cell, mm; 0 = no valid pixel in the cell.
    pub min_mm: Vec<f32>,
    /// Cell column (from `ci0`) of each pixel column from `ci0 · cell_px`, and likewise rows:
    /// [`Self::at`] looks the cell up instead of dividing twice per surface sample, in the
    /// estimator's hottest loop.
    col_cell: Vec<u32>,
    row_cell: Vec<u32>,
    /// The depth map's width and height, px: [`Self::window`] clips to them as [`Self::new`]
    /// does.
    image_px: (u32, u32),
}

impl CellMinDepth {
    /// Builds the cells covering the pixel rectangle `[u0, u1] × [v0, v1]` (inclusive, clipped to
    /// the image). A zero `cell_px` is treated as 1; a depth buffer shorter than width × height is
    /// read as invalid where it is missing.
    pub fn new(depth: &DepthMap, cell_px: u32, u0: u32, v0: u32, u1: u32, v1: u32) -> Self {
        let c = cell_px.max(1);
        let empty = Self::covering(c, (depth.width, depth.height), 0, 0, 0, 0, Vec::new());
        if depth.width == 0 || depth.height == 0 {
            return empty;
        }
        let u1 = u1.min(depth.width - 1);
        let v1 = v1.min(depth.height - 1);
        if u0 > u1 || v0 > v1 {
            return empty;
        }
        let (ci0, cj0) = (u0 / c, v0 / c);
        let (ci1, cj1) = (u1 / c, v1 / c);
        let (ncu, ncv) = (ci1 - ci0 + 1, cj1 - cj0 + 1);
        let mut min_mm = vec![f32::INFINITY; ncu as usize * ncv as usize];
        let ua = ci0 * c;
        let ub = ((ci1 + 1) * c).min(depth.width);
        let va = cj0 * c;
        let vb = ((cj1 + 1) * c).min(depth.height);
        let w = depth.width as usize;
        for v in va..vb {
            let row = ((v / c - cj0) * ncu) as usize;
            let line = v as usize * w;
            // The row's pixels `ua..ub`, one chunk of `c` per cell (missing buffer = invalid).
            let lo = (line + ua as usize).min(depth.depth_mm.len());
            let hi = (line + ub as usize).min(depth.depth_mm.len());
            let slots = &mut min_mm[row..row + ncu as usize];
            for (slot, chunk) in slots
                .iter_mut()
                .zip(depth.depth_mm[lo..hi].chunks(c as usize))
            {
                // NaN and non-positive depths never win; +inf stays "no depth". Branch-free:
                // whether a pixel lowers its cell's minimum is not predictable.
                *slot = chunk
                    .iter()
                    .map(|&d| if d > 0.0 { d } else { f32::INFINITY })
                    .fold(*slot, f32::min);
            }
        }
        for m in &mut min_mm {
            if !m.is_finite() {
                *m = 0.0;
            }
        }
        Self::covering(c, (depth.width, depth.height), ci0, cj0, ncu, ncv, min_mm)
    }

    /// The cells `ci0 .. ci0 + ncu` × `cj0 .. cj0 + ncv` of side `c` px holding `min_mm`, with
    /// the lookup tables of [`Self::at`].
    fn covering(
        c: u32,
        image_px: (u32, u32),
        ci0: u32,
        cj0: u32,
        ncu: u32,
        ncv: u32,
        min_mm: Vec<f32>,
    ) -> Self {
        let cells_of = |n: u32| (0..n * c).map(|k| k / c).collect();
        Self {
            cell_px: c,
            ci0,
            cj0,
            ncu,
            ncv,
            min_mm,
            col_cell: cells_of(ncu),
            row_cell: cells_of(ncv),
            image_px,
        }
    }

    /// What [`Self::new`] builds over the pixel rectangle `[u0, u1] × [v0, v1]` of the same depth
    /// map, copied from `self` instead of read from the pixels again (the cells are aligned to
    /// the image grid, so a cell's minimum does not depend on the region). `None` when `self`
    /// does not cover every cell of the rectangle; [`Self::full`] covers any.
    pub fn window(&self, u0: u32, v0: u32, u1: u32, v1: u32) -> Option<Self> {
        let c = self.cell_px;
        let (w, h) = self.image_px;
        let u1 = u1.min(w.saturating_sub(1));
        let v1 = v1.min(h.saturating_sub(1));
        if w == 0 || h == 0 || u0 > u1 || v0 > v1 {
            return Some(Self::covering(c, self.image_px, 0, 0, 0, 0, Vec::new()));
        }
        let (ci0, cj0, ci1, cj1) = (u0 / c, v0 / c, u1 / c, v1 / c);
        let covers = ci0 >= self.ci0
            && cj0 >= self.cj0
            && ci1 < self.ci0 + self.ncu
            && cj1 < self.cj0 + self.ncv;
        if !covers {
            return None;
        }
        let (ncu, ncv) = (ci1 - ci0 + 1, cj1 - cj0 + 1);
        let mut min_mm = Vec::with_capacity(ncu as usize * ncv as usize);
        for j in cj0 - self.cj0..=cj1 - self.cj0 {
            let row = (j * self.ncu + ci0 - self.ci0) as usize;
            min_mm.extend_from_slice(&self.min_mm[row..row + ncu as usize]);
        }
        Some(Self::covering(c, self.image_px, ci0, cj0, ncu, ncv, min_mm))
    }

    /// Cells covering the whole image.
    pub fn full(depth: &DepthMap, cell_px: u32) -> Self {
        Self::new(
            depth,
            cell_px,
            0,
            0,
            depth.width.saturating_sub(1),
            depth.height.saturating_sub(1),
        )
    }

    /// Minimum depth (mm) of the cell holding the continuous pixel position `(u, v)` (pixel centres
    /// at integers); `None` outside the region or on a cell without valid depth.
    #[inline]
    pub fn at(&self, u: f64, v: f64) -> Option<f32> {
        // Nearest pixel: `(x + 0.5) as u32` truncates, i.e. rounds for x ≥ −0.5 (no libm call).
        let (ur, vr) = (u + 0.5, v + 0.5);
        if !(ur >= 0.0 && vr >= 0.0 && ur < 1e9 && vr < 1e9) {
            return None;
        }
        // Pixel (x, y) lies in cell (x / cell_px − ci0, y / cell_px − cj0): left of or above the
        // region the subtraction fails, right of or below it the table ends.
        let x = (ur as u32).checked_sub(self.ci0 * self.cell_px)?;
        let y = (vr as u32).checked_sub(self.cj0 * self.cell_px)?;
        let i = *self.col_cell.get(x as usize)?;
        let j = *self.row_cell.get(y as usize)?;
        let d = *self.min_mm.get((j * self.ncu + i) as usize)?;
        (d > 0.0).then_some(d)
    }
}

/// Area-uniform samples on a box surface, stored in the box frame so that one set serves every
/// hypothesis of the same size.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceSamples {
    /// Sample positions in the box frame (origin at the centre), mm.
    pub local_mm: Vec<Vector3<f64>>,
}

impl SurfaceSamples {
    /// `n` samples, area-uniform over the 6 faces of a box of `size_mm`, from a fixed seed.
    ///
    /// The random stream does not depend on the size (a face is picked by inverting the area
    /// CDF with one uniform number), so samples move continuously as the size changes.
    pub fn new(size_mm: &Vector3<f64>, n: usize, seed: u64) -> Self {
        let h = size_mm * 0.5;
        let areas = [
            size_mm.y * size_mm.z,
            size_mm.y * size_mm.z,
            size_mm.x * size_mm.z,
            size_mm.x * size_mm.z,
            size_mm.x * size_mm.y,
            size_mm.x * size_mm.y,
        ];
        let total: f64 = areas.iter().sum();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut local_mm = Vec::with_capacity(n);
        for _ in 0..n {
            let r: f64 = rng.random::<f64>() * total;
            let a: f64 = rng.random::<f64>() * 2.0 - 1.0;
            let b: f64 = rng.random::<f64>() * 2.0 - 1.0;
            let mut acc = 0.0;
            let mut face = 5;
            for (f, ar) in areas.iter().enumerate() {
                acc += ar;
                if r < acc {
                    face = f;
                    break;
                }
            }
            let axis = face / 2;
            let sign = if face % 2 == 0 { 1.0 } else { -1.0 };
            let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut p = Vector3::zeros();
            p[axis] = sign * h[axis];
            p[j] = a * h[j];
            p[k] = b * h[k];
            local_mm.push(p);
        }
        Self { local_mm }
    }
}

/// Penalty of one hypothesis: `in_front / compared` over the surface samples (module docs).
///
/// `samples` must have been built for `pose.size_mm`.
pub fn depth_penalty(
    pose: &OrientedBox,
    samples: &SurfaceSamples,
    cells: &CellMinDepth,
    intrinsics: &Intrinsics,
    threshold_mm: f64,
) -> f64 {
    let (in_front, compared) = depth_counts(pose, samples, cells, intrinsics, threshold_mm);
    if compared == 0 {
        0.0
    } else {
        in_front as f64 / compared as f64
    }
}

/// `(in_front, compared)` counts behind [`depth_penalty`].
pub fn depth_counts(
    pose: &OrientedBox,
    samples: &SurfaceSamples,
    cells: &CellMinDepth,
    intrinsics: &Intrinsics,
    threshold_mm: f64,
) -> (usize, usize) {
    let m = pose.rotation.matrix();
    let c = pose.center_mm;
    let mut in_front = 0;
    let mut compared = 0;
    for l in &samples.local_mm {
        let p: Point3<f64> = Point3::from(m * l + c);
        if p.z <= 0.0 {
            continue;
        }
        let u = intrinsics.fx * p.x / p.z + intrinsics.cx;
        let v = intrinsics.fy * p.y / p.z + intrinsics.cy;
        if let Some(d) = cells.at(u, v) {
            compared += 1;
            if p.z < d as f64 - threshold_mm {
                in_front += 1;
            }
        }
    }
    (in_front, compared)
}

/// Share of a cuboid's silhouette through which the camera sees *past* it: pixels (of an even
/// grid of about `max_samples` over the projected silhouette, with valid depth) whose observed
/// depth lies behind the cuboid's front surface along that pixel's ray by more than
/// `max(tol_mm, tol_rel · z)`, over all such pixels. Ours, not the paper's: [`depth_penalty`]
/// catches a box in front of the observation; this catches one where the camera sees empty
/// space, e.g. the gap between two boxes read as one. Pixels where the observation is nearer
/// (an occluder) or at the surface count as consistent.
///
/// Counting stops once more than `stop_above` of the silhouette's samples are known to see
/// past it; the share returned is then above `stop_above` but not exact (pass 1 for the exact
/// share). `None` when the cuboid is not wholly in front of the camera or no silhouette pixel
/// has valid depth.
pub fn see_through_fraction(
    pose: &OrientedBox,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    max_samples: usize,
    tol_mm: f64,
    tol_rel: f64,
    stop_above: f64,
) -> Option<f64> {
    let hull = anybox_geom::projection::silhouette_hull_px(pose, intrinsics)?;
    let all = crate::silhouette::convex_spans(&hull, depth.width, depth.height);
    let area: usize = all.iter().map(|&(_, u0, u1)| (u1 - u0) as usize + 1).sum();
    // Every `stride`-th row and column: about `max_samples` pixels.
    let stride = ((area as f64 / max_samples.max(1) as f64).sqrt().ceil() as usize).max(1);
    let spans: Vec<(u32, u32, u32)> = all.into_iter().step_by(stride).collect();
    let samples: usize = spans
        .iter()
        .map(|&(_, u0, u1)| (u1 - u0) as usize / stride + 1)
        .sum();
    // `through / compared > stop_above` is sure once `through` passes this (compared ≤ samples).
    let enough = (stop_above * samples as f64).floor();
    // Rays in the box frame: the camera centre once, each pixel's direction by one rotation.
    let to_box = pose.rotation.inverse();
    let origin = pose.to_local(&Point3::origin());
    let half = pose.half_size_mm();
    let (mut compared, mut through) = (0usize, 0usize);
    for (v, u0, u1) in spans {
        for u in (u0..=u1).step_by(stride) {
            let Some(z) = depth.get(u, v) else { continue };
            // The ray has unit z, so `t` is the depth of the entry point, mm.
            let ray = to_box * intrinsics.ray(f64::from(u), f64::from(v));
            let Some((t_enter, _, _)) =
                anybox_geom::projection::ray_box_intersection_local(&origin, &ray, &half)
            else {
                continue;
            };
            compared += 1;
            if f64::from(z) > t_enter + tol_mm.max(tol_rel * t_enter) {
                through += 1;
                if through as f64 > enough {
                    return Some(through as f64 / compared as f64);
                }
            }
        }
    }
    (compared > 0).then(|| through as f64 / compared as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    #[test]
    fn cells_hold_the_minimum_and_align_to_the_grid() {
        let mut d = DepthMap::zeros(12, 7);
        for (i, z) in d.depth_mm.iter_mut().enumerate() {
            *z = 100.0 + i as f32;
        }
        d.depth_mm[0] = 0.0; // invalid pixels never count
        let full = CellMinDepth::full(&d, 5);
        assert_eq!((full.ncu, full.ncv), (3, 2));
        // Brute force per pixel.
        for v in 0..7u32 {
            for u in 0..12u32 {
                let (ci, cj) = (u / 5, v / 5);
                let mut m = f32::INFINITY;
                for vv in cj * 5..((cj + 1) * 5).min(7) {
                    for uu in ci * 5..((ci + 1) * 5).min(12) {
                        let z = d.depth_mm[(vv * 12 + uu) as usize];
                        if z > 0.0 {
                            m = m.min(z);
                        }
                    }
                }
                assert_eq!(full.at(u as f64, v as f64), Some(m));
            }
        }
        let part = CellMinDepth::new(&d, 5, 6, 2, 11, 6);
        assert_eq!(part.at(7.0, 3.0), full.at(7.0, 3.0));
        assert_eq!(part.at(2.0, 3.0), None);
        assert_eq!(full.at(-1.0, 3.0), None);
        assert_eq!(full.at(f64::NAN, 3.0), None);
    }

    /// [`CellMinDepth::at`] by its definition: the minimum valid depth over the image pixels
    /// of the `cell_px` cell holding the nearest pixel, when that cell is among the covered
    /// ones.
    fn at_by_definition(
        d: &DepthMap,
        c: u32,
        region: (u32, u32, u32, u32),
        u: f64,
        v: f64,
    ) -> Option<f32> {
        let (u0, v0, u1, v1) = region;
        let (u1, v1) = (u1.min(d.width - 1), v1.min(d.height - 1));
        let (ur, vr) = (u + 0.5, v + 0.5);
        if u0 > u1 || v0 > v1 || !(ur >= 0.0 && vr >= 0.0) {
            return None;
        }
        let (ci, cj) = ((ur.floor() as u32) / c, (vr.floor() as u32) / c);
        if ci < u0 / c || ci > u1 / c || cj < v0 / c || cj > v1 / c {
            return None;
        }
        let mut m: Option<f32> = None;
        for y in cj * c..((cj + 1) * c).min(d.height) {
            for x in ci * c..((ci + 1) * c).min(d.width) {
                let z = d.depth_mm[(y * d.width + x) as usize];
                if z > 0.0 && z.is_finite() {
                    m = Some(m.map_or(z, |m: f32| m.min(z)));
                }
            }
        }
        m
    }

    proptest::proptest! {
        /// Cells over random regions (partly or wholly off the image) of random depth maps with
        /// holes, looked up at random positions in and around the image.
        #[test]
        fn cell_lookup_matches_its_definition(
            (w, h) in (1u32..30, 1u32..20),
            c in 1u32..7,
            seed in proptest::prelude::any::<u64>(),
            region in (0u32..35, 0u32..25, 0u32..40, 0u32..30),
            queries in proptest::collection::vec((-4.0f64..40.0, -4.0f64..28.0), 1..60),
        ) {
            let mut d = DepthMap::zeros(w, h);
            let mut s = seed;
            for z in d.depth_mm.iter_mut() {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                *z = match s >> 60 {
                    0..=2 => 0.0,
                    3 => f32::NAN,
                    _ => 500.0 + (s >> 40) as f32 % 1000.0,
                };
            }
            let (u0, v0, u1, v1) = region;
            let cells = CellMinDepth::new(&d, c, u0, v0, u1, v1);
            // A window of the whole image's cells, or of a larger region's, is what `new`
            // builds over the region.
            let full = CellMinDepth::full(&d, c).window(u0, v0, u1, v1);
            proptest::prop_assert_eq!(full.as_ref(), Some(&cells));
            let (a0, b0) = (u0.saturating_sub(seed as u32 % 9), v0.saturating_sub(seed as u32 % 7));
            let larger = CellMinDepth::new(&d, c, a0, b0, u1, v1).window(u0, v0, u1, v1);
            proptest::prop_assert_eq!(larger.as_ref(), Some(&cells));
            // A smaller region's cells do not cover it.
            if cells.ncu > 1 {
                let smaller = CellMinDepth::new(&d, c, u0 + c, v0, u1, v1);
                proptest::prop_assert_eq!(smaller.window(u0, v0, u1, v1), None);
            }
            for (u, v) in queries {
                proptest::prop_assert_eq!(
                    cells.at(u, v),
                    at_by_definition(&d, c, region, u, v),
                    "({}, {})", u, v
                );
            }
        }
    }

    #[test]
    fn samples_are_area_uniform_on_the_surface() {
        let size = Vector3::new(300.0, 100.0, 50.0);
        let s = SurfaceSamples::new(&size, 20000, 1);
        let mut per_axis = [0usize; 3];
        for p in &s.local_mm {
            let on: Vec<usize> = (0..3)
                .filter(|&a| (p[a].abs() - size[a] / 2.0).abs() < 1e-9)
                .collect();
            assert!(!on.is_empty());
            per_axis[on[0]] += 1;
            for a in 0..3 {
                assert!(p[a].abs() <= size[a] / 2.0 + 1e-9);
            }
        }
        let total = 2.0 * (300.0 * 100.0 + 300.0 * 50.0 + 100.0 * 50.0);
        let expect = [100.0 * 50.0, 300.0 * 50.0, 300.0 * 100.0].map(|a| 2.0 * a / total);
        for a in 0..3 {
            let f = per_axis[a] as f64 / 20000.0;
            assert!(
                (f - expect[a]).abs() < 0.015,
                "axis {a}: {f} vs {}",
                expect[a]
            );
        }
    }

    #[test]
    fn box_floating_in_front_of_a_wall_is_penalised() {
        let k = Intrinsics::new(500.0, 500.0, 80.0, 60.0).unwrap();
        let mut d = DepthMap::zeros(160, 120);
        d.depth_mm.iter_mut().for_each(|z| *z = 1000.0);
        let cells = CellMinDepth::full(&d, 5);
        let size = Vector3::new(100.0, 80.0, 60.0);
        let s = SurfaceSamples::new(&size, 1000, 3);
        let behind =
            OrientedBox::new(Rotation3::identity(), Vector3::new(0.0, 0.0, 1031.0), size).unwrap();
        let floating =
            OrientedBox::new(Rotation3::identity(), Vector3::new(0.0, 0.0, 900.0), size).unwrap();
        assert_eq!(depth_penalty(&behind, &s, &cells, &k, 0.0), 0.0);
        assert_eq!(depth_penalty(&floating, &s, &cells, &k, 0.0), 1.0);
        // A box straddling the wall: exactly the samples with z < 1000 count.
        let straddle =
            OrientedBox::new(Rotation3::identity(), Vector3::new(0.0, 0.0, 1000.0), size).unwrap();
        let expect = s.local_mm.iter().filter(|l| l.z + 1000.0 < 1000.0).count() as f64 / 1000.0;
        assert!((depth_penalty(&straddle, &s, &cells, &k, 0.0) - expect).abs() < 1e-12);
    }

    /// A 400 × 300 × 200 mm box straight ahead, front face at z = 1400 mm: its silhouette is
    /// the front face's rectangle (the back face projects inside it). Left of the image centre
    /// the depth shows that face; right of it, `right_mm`.
    fn half_seen(right_mm: f32) -> (OrientedBox, DepthMap, Intrinsics, [u32; 4]) {
        let k = Intrinsics::new(600.0, 600.0, 320.0, 240.0).unwrap();
        let b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 1500.0),
            Vector3::new(400.0, 300.0, 200.0),
        )
        .unwrap(); // positive sizes: cannot fail
                   // Pixel centres inside the front face: |u − 320| ≤ 600·200/1400 and
                   // |v − 240| ≤ 600·150/1400.
        let (hu, hv) = (600.0 * 200.0 / 1400.0, 600.0 * 150.0 / 1400.0);
        let rect = [
            (320.0f64 - hu).ceil() as u32,
            (320.0f64 + hu).floor() as u32,
            (240.0f64 - hv).ceil() as u32,
            (240.0f64 + hv).floor() as u32,
        ];
        let mut d = DepthMap::zeros(640, 480);
        for v in 0..480u32 {
            for u in 0..640u32 {
                let inside = (rect[0]..=rect[1]).contains(&u) && (rect[2]..=rect[3]).contains(&v);
                d.depth_mm[(v * 640 + u) as usize] = match (inside, u < 320) {
                    (true, true) => 1400.0,
                    (true, false) => right_mm,
                    (false, _) => 3000.0,
                };
            }
        }
        (b, d, k, rect)
    }

    #[test]
    fn see_through_share_counts_the_pixels_behind_the_front() {
        // Right half shows a wall 1.6 m behind the face: the share is that half's pixel count.
        let (b, d, k, r) = half_seen(3000.0);
        let cols = f64::from(r[1] - r[0] + 1);
        let expect = f64::from(r[1] - 320 + 1) / cols;
        let exact = see_through_fraction(&b, &d, &k, usize::MAX, 25.0, 0.01, 1.0).unwrap();
        assert!((exact - expect).abs() < 1e-9, "{exact} vs {expect}");
        let sampled = see_through_fraction(&b, &d, &k, 1000, 25.0, 0.01, 1.0).unwrap();
        assert!((sampled - expect).abs() < 0.03, "{sampled} vs {expect}");
        // Stopping early still reports a share above the stop.
        let early = see_through_fraction(&b, &d, &k, usize::MAX, 25.0, 0.01, 0.2).unwrap();
        assert!(early > 0.2 && early <= 1.0, "{early}");
        // Within the tolerance of the face (1 % of 1400 mm = 14 < 25 mm): nothing seen past.
        let (b, d, k, _) = half_seen(1420.0);
        assert_eq!(
            see_through_fraction(&b, &d, &k, 1000, 25.0, 0.01, 1.0),
            Some(0.0)
        );
        // … but past a 10 mm tolerance, a 20 mm step counts (1 % of 1400 mm = 14 mm).
        let s = see_through_fraction(&b, &d, &k, usize::MAX, 10.0, 0.01, 1.0).unwrap();
        assert!((s - expect).abs() < 1e-9, "{s}");
        // An occluder in front of the right half hides it: consistent, not seen past.
        let (b, d, k, _) = half_seen(800.0);
        assert_eq!(
            see_through_fraction(&b, &d, &k, 1000, 25.0, 0.01, 1.0),
            Some(0.0)
        );
        // No valid depth under the silhouette, or a box behind the camera: no answer.
        let empty = DepthMap::zeros(640, 480);
        assert_eq!(
            see_through_fraction(&b, &empty, &k, 1000, 25.0, 0.01, 1.0),
            None
        );
        let behind = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, -1500.0),
            Vector3::new(400.0, 300.0, 200.0),
        )
        .unwrap();
        assert_eq!(
            see_through_fraction(&behind, &d, &k, 1000, 25.0, 0.01, 1.0),
            None
        );
    }
}
