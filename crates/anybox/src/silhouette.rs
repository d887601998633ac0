//! The cuboid silhouette and per-axis pixel extents (paper §3 "Scale Estimation", SPEC §1).
//!
//! In: a posed box ([`OrientedBox`]), the camera [`Intrinsics`], and an observed instance mask.
//! Out: the rendered silhouette (the convex hull of the projected corners, rasterised on demand)
//! and, for each of the three box axes, the pixel extent of the rendered and of the observed mask
//! measured along that axis' image direction ([`Extents`]).
//!
//! Definitions used throughout the scale search:
//! - The *image direction* `d_a` of box axis `a` is the unit 2D direction of the projection of the
//!   axis at the box centre (the Jacobian of the pinhole projection applied to the axis).
//! - `px_per_mm[a]` is the length of that projection, pixels per millimetre of box extent, and the
//!   *foreshortening* `px_per_mm[a] / (f / z)` is in `[0, 1]`: 1 for an axis parallel to the image
//!   plane, 0 for an axis along the viewing ray. Below [`MIN_FORESHORTENING`] the silhouette says
//!   nothing useful about that axis (its direction is ill-defined and its extent does not react to
//!   its size), so the axis is marked not observable here.
//! - The extent `e_a` is `max − min` of `pixel · d_a`: over the projected corners for the rendered
//!   box (the hull's extreme points are corners), over the mask pixels for the observed mask. Mask
//!   pixels are centres at integer coordinates, so a mask spanning `n` pixels has centres `n − 1`
//!   apart; one pixel is added to the observed extent so that both measure the same thing.

// Projection and the hull are the geometry crate's (one convention for every caller).
use crate::order_stats::rank_pair;
pub use anybox_geom::projection::{
    convex_hull_2d as convex_hull, project_corners_px, silhouette_hull_px,
};
use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::Mask;
use nalgebra::{Point2, Point3, Vector2, Vector3};
use std::ops::Range;

/// Axes whose foreshortening is below this (≈ 11.5° between the axis and the viewing ray) have
/// no usable silhouette extent.
pub const MIN_FORESHORTENING: f64 = 0.2;

/// Image directions of the three box axes at the current pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisDirections {
    /// Unit image direction of each box axis (px space); `None` where not observable.
    pub dirs: [Option<Vector2<f64>>; 3],
    /// Projected length of one millimetre of each axis at the box centre, px/mm.
    pub px_per_mm: [f64; 3],
    /// `px_per_mm` divided by the focal length over depth: 1 = parallel to the image plane.
    pub foreshortening: [f64; 3],
}

/// Per-axis pixel extents along [`AxisDirections`]; `None` where the axis is not observable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extents {
    /// Extent along each axis' image direction, px.
    pub px: [Option<f64>; 3],
}

impl Extents {
    /// Largest absolute difference over the axes both extents define, px (0 when none).
    pub fn max_abs_diff_px(&self, other: &Extents) -> f64 {
        (0..3)
            .filter_map(|a| match (self.px[a], other.px[a]) {
                (Some(x), Some(y)) => Some((x - y).abs()),
                _ => None,
            })
            .fold(0.0, f64::max)
    }
}

/// Image directions of the box axes at the box centre.
///
/// Returns `None` when the box centre is not in front of the camera.
pub fn axis_directions(pose: &OrientedBox, k: &Intrinsics) -> Option<AxisDirections> {
    let c = pose.center_mm;
    if !c.iter().all(|x| x.is_finite()) || c.z <= 1e-6 {
        return None;
    }
    let z = c.z;
    let f_mean = 0.5 * (k.fx + k.fy);
    let mut out = AxisDirections {
        dirs: [None; 3],
        px_per_mm: [0.0; 3],
        foreshortening: [0.0; 3],
    };
    for a in 0..3 {
        let r = pose.axis(a);
        // Jacobian of (fx x/z + cx, fy y/z + cy) at c, applied to r.
        let du = k.fx * (r.x / z - c.x * r.z / (z * z));
        let dv = k.fy * (r.y / z - c.y * r.z / (z * z));
        let v = Vector2::new(du, dv);
        let len = v.norm();
        out.px_per_mm[a] = len;
        // Normalise by the projection of a unit vector parallel to the image plane at depth z.
        let fs = len * z / f_mean;
        out.foreshortening[a] = fs;
        if fs >= MIN_FORESHORTENING && len > 0.0 {
            out.dirs[a] = Some(v / len);
        }
    }
    Some(out)
}

/// Extents of the rendered cuboid silhouette along `dirs`: over the projected corners, px.
///
/// `None` when a corner is behind the camera.
pub fn rendered_extents(
    pose: &OrientedBox,
    k: &Intrinsics,
    dirs: &AxisDirections,
) -> Option<Extents> {
    let px = project_corners_px(pose, k)?;
    Some(extents_of_points(&px, dirs))
}

/// Extents of a point set (e.g. projected corners) along `dirs`, px.
pub fn extents_of_points(px: &[Point2<f64>], dirs: &AxisDirections) -> Extents {
    let mut out = Extents { px: [None; 3] };
    for a in 0..3 {
        if let Some(d) = dirs.dirs[a] {
            let (lo, hi) = px
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    let s = p.coords.dot(&d);
                    (lo.min(s), hi.max(s))
                });
            if lo.is_finite() && hi.is_finite() {
                out.px[a] = Some(hi - lo);
            }
        }
    }
    out
}

/// Robust extreme values of `pixel · d` over the observed mask pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskSpan {
    /// Low end (after trimming), px along `d`.
    pub lo: f64,
    /// High end (after trimming), px along `d`.
    pub hi: f64,
}

/// Span of the mask pixels along `d`, dropping `trim` pixels at each end against ragged edges.
///
/// `scratch` is reused between calls to avoid allocation. `None` for an empty pixel list.
pub fn mask_span(
    pixels: &[[u32; 2]],
    d: &Vector2<f64>,
    trim: usize,
    scratch: &mut Vec<f64>,
) -> Option<MaskSpan> {
    mask_span_in_rows(pixels, raster_rows(pixels).as_deref(), d, trim, scratch)
}

/// Index ranges of the rows of a pixel list in raster order (`v` ascending, and `u` strictly
/// ascending within a row, as [`mask_pixels`] gives them); `None` when the list is not in
/// that order.
pub fn raster_rows(pixels: &[[u32; 2]]) -> Option<Vec<Range<usize>>> {
    let mut rows = Vec::new();
    let mut start = 0;
    for (i, pair) in pixels.windows(2).enumerate() {
        let ([u0, v0], [u1, v1]) = (pair[0], pair[1]);
        if v1 < v0 || (v1 == v0 && u1 <= u0) {
            return None;
        }
        if v1 > v0 {
            rows.push(start..i + 1);
            start = i + 1;
        }
    }
    if !pixels.is_empty() {
        rows.push(start..pixels.len());
    }
    Some(rows)
}

/// [`mask_span`] given the pixel list's [`raster_rows`] (`None`: look at every pixel).
///
/// Along `d`, the projections within a row are monotone in `u` (non-decreasing for
/// `d.x ≥ 0`, non-increasing otherwise: the same rounded products plus one constant), so the
/// `trim + 1` lowest and highest values of the whole list are among the `trim + 1` first and
/// last pixels of the rows; only those are ranked, and the values are the same.
pub(crate) fn mask_span_in_rows(
    pixels: &[[u32; 2]],
    rows: Option<&[Range<usize>]>,
    d: &Vector2<f64>,
    trim: usize,
    scratch: &mut Vec<f64>,
) -> Option<MaskSpan> {
    if pixels.is_empty() {
        return None;
    }
    let n = pixels.len();
    let trim = trim.min((n - 1) / 2);
    let proj = |p: &[u32; 2]| f64::from(p[0]) * d.x + f64::from(p[1]) * d.y;
    scratch.clear();
    // Monotone rows need a finite direction.
    match rows.filter(|_| d.x.is_finite() && d.y.is_finite()) {
        Some(rows) => {
            for r in rows {
                let row = &pixels[r.clone()];
                if row.len() <= 2 * (trim + 1) {
                    scratch.extend(row.iter().map(proj));
                } else {
                    scratch.extend(row[..=trim].iter().map(proj));
                    scratch.extend(row[row.len() - 1 - trim..].iter().map(proj));
                }
            }
        }
        None => scratch.extend(pixels.iter().map(proj)),
    }
    let m = scratch.len();
    let (lo, hi) = if trim == 0 {
        (
            scratch.iter().copied().fold(f64::INFINITY, f64::min),
            scratch.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    } else {
        // Every value ranking beyond the wanted ones is in `scratch`, so their ranks from
        // either end are the same as in the whole list.
        rank_pair(scratch, trim, m - 1 - trim)?
    };
    Some(MaskSpan { lo, hi })
}

/// Number of pixels to trim at each end for `n` mask pixels and a trim fraction.
pub fn trim_count(n: usize, trim_fraction: f64) -> usize {
    if trim_fraction.is_nan() || trim_fraction <= 0.0 {
        return 0;
    }
    ((n as f64) * trim_fraction).floor() as usize
}

/// Extents of the observed mask along `dirs`, px (one pixel added, see the module docs).
pub fn observed_extents(
    pixels: &[[u32; 2]],
    dirs: &AxisDirections,
    trim_fraction: f64,
    scratch: &mut Vec<f64>,
) -> Extents {
    let trim = trim_count(pixels.len(), trim_fraction);
    let mut out = Extents { px: [None; 3] };
    for a in 0..3 {
        if let Some(d) = dirs.dirs[a] {
            out.px[a] = mask_span(pixels, &d, trim, scratch).map(|s| s.hi - s.lo + 1.0);
        }
    }
    out
}

/// The pixels of a mask as `[u, v]` pairs, row-major order.
pub fn mask_pixels(mask: &Mask) -> Vec<[u32; 2]> {
    let w = mask.width as usize;
    if w == 0 {
        return Vec::new();
    }
    let mut out = Vec::new();
    for (v, row) in mask.data.chunks(w).enumerate() {
        // Most rows of a full-frame instance mask are empty: a branch-free OR (which
        // vectorises) skips them.
        if !row.iter().fold(false, |a, &b| a | b) {
            continue;
        }
        out.extend(
            row.iter()
                .enumerate()
                .filter(|(_, b)| **b)
                .map(|(u, _)| [u as u32, v as u32]),
        );
    }
    out
}

/// Row spans `(v, u_first, u_last)` of the pixels whose centre lies inside a convex polygon,
/// clipped to a `width × height` image.
pub fn convex_spans(poly: &[Point2<f64>], width: u32, height: u32) -> Vec<(u32, u32, u32)> {
    let mut out = Vec::new();
    if poly.len() < 3 || width == 0 || height == 0 {
        return out;
    }
    let (ymin, ymax) = poly
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.y), b.max(p.y))
        });
    let v0 = ymin.ceil().max(0.0);
    let v1 = ymax.floor().min(f64::from(height) - 1.0);
    if v0.is_nan() || v1.is_nan() || v0 > v1 {
        return out;
    }
    let n = poly.len();
    let mut v = v0;
    while v <= v1 {
        let mut xl = f64::INFINITY;
        let mut xr = f64::NEG_INFINITY;
        for i in 0..n {
            let p = poly[i];
            let q = poly[(i + 1) % n];
            let (lo, hi) = if p.y <= q.y { (p, q) } else { (q, p) };
            if v < lo.y || v > hi.y {
                continue;
            }
            if (hi.y - lo.y).abs() < 1e-12 {
                xl = xl.min(lo.x.min(hi.x));
                xr = xr.max(lo.x.max(hi.x));
            } else {
                let x = lo.x + (v - lo.y) * (hi.x - lo.x) / (hi.y - lo.y);
                xl = xl.min(x);
                xr = xr.max(x);
            }
        }
        let u0 = xl.ceil().max(0.0);
        let u1 = xr.floor().min(f64::from(width) - 1.0);
        if u0 <= u1 {
            out.push((v as u32, u0 as u32, u1 as u32));
        }
        v += 1.0;
    }
    out
}

/// Rasterises a convex polygon: pixel `(u, v)` is set when its centre `(u, v)` lies inside.
pub fn rasterize_convex(poly: &[Point2<f64>], width: u32, height: u32) -> Mask {
    let mut mask = Mask::empty(width, height);
    for (v, u0, u1) in convex_spans(poly, width, height) {
        let row = v as usize * width as usize;
        for u in u0..=u1 {
            mask.data[row + u as usize] = true;
        }
    }
    mask
}

/// Extents of the rasterised convex hull of `px` along `dirs`, measured exactly like
/// [`observed_extents`] (pixel centres, `trim` pixels dropped at each end, one pixel added), so
/// that the rendered and observed extents carry the same pixelisation bias.
pub fn raster_extents(
    px: &[Point2<f64>],
    dirs: &AxisDirections,
    width: u32,
    height: u32,
    trim: usize,
    scratch: &mut Vec<f64>,
) -> Extents {
    let hull = convex_hull(px);
    let spans = convex_spans(&hull, width, height);
    let mut out = Extents { px: [None; 3] };
    for a in 0..3 {
        let Some(d) = dirs.dirs[a] else { continue };
        if trim == 0 {
            // Extremes of a row lie at its ends.
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            for &(v, u0, u1) in &spans {
                for u in [u0, u1] {
                    let s = f64::from(u) * d.x + f64::from(v) * d.y;
                    lo = lo.min(s);
                    hi = hi.max(s);
                }
            }
            if lo.is_finite() {
                out.px[a] = Some(hi - lo + 1.0);
            }
        } else {
            scratch.clear();
            for &(v, u0, u1) in &spans {
                for u in u0..=u1 {
                    scratch.push(f64::from(u) * d.x + f64::from(v) * d.y);
                }
            }
            let n = scratch.len();
            if n == 0 {
                continue;
            }
            let t = trim.min((n - 1) / 2);
            out.px[a] = rank_pair(scratch, t, n - 1 - t).map(|(lo, hi)| hi - lo + 1.0);
        }
    }
    out
}

/// Rasterised extents of the whole cuboid silhouette (the paper's Extents(RenderMask(C(s), T, K))).
pub fn rendered_raster_extents(
    pose: &OrientedBox,
    k: &Intrinsics,
    dirs: &AxisDirections,
    width: u32,
    height: u32,
    trim: usize,
    scratch: &mut Vec<f64>,
) -> Option<Extents> {
    let px = project_corners_px(pose, k)?;
    Some(raster_extents(&px, dirs, width, height, trim, scratch))
}

/// Renders the cuboid silhouette mask (the paper's RenderMask(C(s), T, K)).
pub fn render_silhouette(pose: &OrientedBox, k: &Intrinsics, width: u32, height: u32) -> Mask {
    match silhouette_hull_px(pose, k) {
        Some(h) => rasterize_convex(&h, width, height),
        None => Mask::empty(width, height),
    }
}

/// Extents of the hull of an arbitrary set of box-frame points (e.g. the corners of the observed
/// faces only), px; `None` if a point is behind the camera.
pub fn extents_of_local_points(
    pose: &OrientedBox,
    k: &Intrinsics,
    local_mm: &[Vector3<f64>],
    dirs: &AxisDirections,
) -> Option<Extents> {
    let mut px = Vec::with_capacity(local_mm.len());
    for l in local_mm {
        let p: Point3<f64> = pose.to_camera(l);
        px.push(k.project(&p)?);
    }
    Some(extents_of_points(&px, dirs))
}

/// Projects box-frame points to pixels; `None` if one is behind the camera.
pub fn project_local_points(
    pose: &OrientedBox,
    k: &Intrinsics,
    local_mm: &[Vector3<f64>],
) -> Option<Vec<Point2<f64>>> {
    local_mm
        .iter()
        .map(|l| k.project(&pose.to_camera(l)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn cam() -> Intrinsics {
        Intrinsics::new(600.0, 600.0, 320.0, 240.0).unwrap()
    }

    fn pose() -> OrientedBox {
        OrientedBox::new(
            Rotation3::from_euler_angles(0.4, -0.3, 0.7),
            Vector3::new(20.0, -10.0, 900.0),
            Vector3::new(300.0, 200.0, 150.0),
        )
        .unwrap()
    }

    #[test]
    fn rendered_and_rasterised_extents_agree() {
        let k = cam();
        let b = pose();
        let dirs = axis_directions(&b, &k).unwrap();
        let analytic = rendered_extents(&b, &k, &dirs).unwrap();
        let m = render_silhouette(&b, &k, 640, 480);
        let pix = mask_pixels(&m);
        let mut s = Vec::new();
        let raster = observed_extents(&pix, &dirs, 0.0, &mut s);
        for a in 0..3 {
            let (x, y) = (analytic.px[a].unwrap(), raster.px[a].unwrap());
            // Pixel centres lose at most ~1 px at sharp corners.
            assert!((x - y).abs() < 2.0, "axis {a}: {x} vs {y}");
        }
        // The raster area matches the hull's shoelace area.
        let h = silhouette_hull_px(&b, &k).unwrap();
        let area: f64 = (0..h.len())
            .map(|i| {
                let (p, q) = (h[i], h[(i + 1) % h.len()]);
                p.x * q.y - q.x * p.y
            })
            .sum::<f64>()
            .abs()
            / 2.0;
        let n = m.count() as f64;
        assert!((n - area).abs() / area < 0.02, "{n} vs {area}");
    }

    #[test]
    fn axis_along_view_ray_is_not_observable() {
        let k = cam();
        // Box straight ahead with its z axis along the optical axis.
        let b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(100.0, 100.0, 100.0),
        )
        .unwrap();
        let d = axis_directions(&b, &k).unwrap();
        assert!(d.dirs[0].is_some() && d.dirs[1].is_some());
        assert!(d.dirs[2].is_none());
        assert!((d.px_per_mm[0] - 0.6).abs() < 1e-9);
        assert!((d.foreshortening[0] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn extents_grow_linearly_with_size_for_parallel_axis() {
        let k = cam();
        let mut b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(100.0, 80.0, 60.0),
        )
        .unwrap();
        let d = axis_directions(&b, &k).unwrap();
        let e0 = rendered_extents(&b, &k, &d).unwrap();
        // Front face at z = 970 is closest: x extent = 100 * 600 / 970.
        assert!((e0.px[0].unwrap() - 100.0 * 600.0 / 970.0).abs() < 1e-6);
        b.size_mm.x = 200.0;
        let e1 = rendered_extents(&b, &k, &d).unwrap();
        assert!((e1.px[0].unwrap() - 200.0 * 600.0 / 970.0).abs() < 1e-6);
    }

    #[test]
    fn trimmed_span_ignores_outliers() {
        let mut pix: Vec<[u32; 2]> = (0..100).map(|i| [i, 0]).collect();
        pix.push([500, 0]);
        let mut s = Vec::new();
        let d = Vector2::new(1.0, 0.0);
        let full = mask_span(&pix, &d, 0, &mut s).unwrap();
        assert_eq!(full.hi, 500.0);
        let t = mask_span(&pix, &d, 1, &mut s).unwrap();
        assert_eq!((t.lo, t.hi), (1.0, 99.0));
    }

    #[test]
    fn raster_rows_split_rows_and_reject_other_orders() {
        assert_eq!(raster_rows(&[]), Some(vec![]));
        assert_eq!(
            raster_rows(&[[0, 0], [3, 0], [1, 2], [2, 2], [9, 2]]),
            Some(vec![0..2, 2..5])
        );
        assert_eq!(raster_rows(&[[3, 0], [1, 0]]), None);
        assert_eq!(raster_rows(&[[0, 2], [0, 1]]), None);
        assert_eq!(raster_rows(&[[4, 1], [4, 1]]), None);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        /// The span from the rows' ends equals the span from every pixel, bit for bit, for
        /// ragged masks with holes, any direction (including the axes) and any trim.
        #[test]
        fn span_from_row_ends_matches_every_pixel(
            cells in proptest::collection::vec(proptest::prelude::any::<u8>(), 40 * 30),
            density in 1u8..255,
            angle_deg in proptest::sample::select(vec![0.0, 90.0, 180.0, 270.0, 33.0, 121.0, 250.5, 301.0, 359.9]),
            trim in 0usize..12,
        ) {
            let pix: Vec<[u32; 2]> = (0..30u32)
                .flat_map(|v| (0..40u32).map(move |u| [u, v]))
                .filter(|p| cells[(p[1] * 40 + p[0]) as usize] < density)
                .collect();
            let a = f64::to_radians(angle_deg);
            let d = Vector2::new(a.cos(), a.sin());
            let rows = raster_rows(&pix);
            proptest::prop_assert!(rows.is_some());
            let mut s = Vec::new();
            let fast = mask_span_in_rows(&pix, rows.as_deref(), &d, trim, &mut s);
            let every = mask_span_in_rows(&pix, None, &d, trim, &mut s);
            let bits = |m: Option<MaskSpan>| m.map(|m| (m.lo.to_bits(), m.hi.to_bits()));
            proptest::prop_assert_eq!(bits(fast), bits(every));
        }
    }
}
