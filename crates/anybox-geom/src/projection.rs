//! Projecting boxes into the image: corners, silhouettes, polygon rasterisation, ray casting.
//!
//! In: an [`OrientedBox`] in the camera frame (mm) and pinhole [`Intrinsics`] (px).
//! Out: pixel coordinates (px, pixel centres at integer coordinates, SPEC §2), the cuboid's
//! silhouette as a convex polygon, a row-major mask of that polygon, and ray/box intersections.
//!
//! The silhouette of a convex body under a pinhole projection is the convex hull of its
//! projected corners, provided the whole box lies in front of the camera; this is the
//! "rendered silhouette" the scale search of the paper (§3.2, SPEC §1) compares with the
//! observed mask.

use nalgebra::{Point2, Point3, Vector3};

use crate::{Intrinsics, OrientedBox};

/// The 8 box corners projected to pixels, in [`crate::cuboid::CORNER_SIGNS`] order.
///
/// `None` when any corner has `z <= 0` mm (behind or on the camera plane), because the
/// projection of such a box is not the hull of its projected corners.
pub fn project_corners_px(b: &OrientedBox, k: &Intrinsics) -> Option<[Point2<f64>; 8]> {
    let corners = b.corners_mm();
    let mut out = [Point2::origin(); 8];
    for (o, c) in out.iter_mut().zip(corners.iter()) {
        *o = k.project(c)?;
    }
    Some(out)
}

/// Twice the signed area of triangle `(o, a, b)`: positive when `o → a → b` turns counter-clockwise
/// in the `(u, v)` coordinate system taken as a standard right-handed plane.
#[inline]
fn cross2(o: &Point2<f64>, a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x)
}

/// Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, no repeated or
/// collinear vertices.
///
/// "Counter-clockwise" is with respect to `(u, v)` read as a standard x/y plane, i.e. the
/// signed shoelace area `Σ (uᵢ vᵢ₊₁ − uᵢ₊₁ vᵢ) / 2` is positive; since image `v` points down,
/// the polygon appears clockwise on screen. Non-finite points are ignored. Fewer than 3
/// distinct non-collinear points give the 0, 1 or 2 extreme points.
pub fn convex_hull_2d(points: &[Point2<f64>]) -> Vec<Point2<f64>> {
    let mut pts: Vec<Point2<f64>> = points
        .iter()
        .copied()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
        .collect();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    // Points closer than this count as one: rounding leaves copies of one vertex ~1e-15 of the
    // coordinates apart (clipped polygons), and the edge between two such copies points in a
    // random direction, so the turn test after it keeps points that are not on the hull.
    let scale = pts
        .iter()
        .fold(0.0f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
    let tol = 1e-10 * scale;
    let near =
        |a: &Point2<f64>, b: &Point2<f64>| (a.x - b.x).abs() <= tol && (a.y - b.y).abs() <= tol;
    pts.dedup_by(|b, a| near(a, b));
    if pts.len() < 3 {
        return pts;
    }
    let mut hull: Vec<Point2<f64>> = Vec::with_capacity(2 * pts.len());
    // Lower chain, then upper chain; `<= 0` drops collinear points, and a point on top of the
    // previous one is dropped too.
    let turns_wrong = |hull: &[Point2<f64>], p: &Point2<f64>| {
        let (o, a) = (&hull[hull.len() - 2], &hull[hull.len() - 1]);
        near(o, a) || cross2(o, a, p) <= 0.0
    };
    for p in pts.iter() {
        while hull.len() >= 2 && turns_wrong(&hull, p) {
            hull.pop();
        }
        if hull.last().is_none_or(|l| !near(l, p)) {
            hull.push(*p);
        }
    }
    let lower_len = hull.len() + 1;
    for p in pts.iter().rev().skip(1) {
        while hull.len() >= lower_len && turns_wrong(&hull, p) {
            hull.pop();
        }
        if hull.last().is_none_or(|l| !near(l, p)) {
            hull.push(*p);
        }
    }
    // The last point repeats the first (or lies on top of it).
    if hull.len() > 1 && near(&hull[0], &hull[hull.len() - 1]) {
        hull.pop();
    }
    hull
}

/// The cuboid's silhouette in the image: counter-clockwise (in the sense of [`convex_hull_2d`])
/// convex hull of the projected corners, px. `None` when a corner is not in front of the camera.
pub fn silhouette_hull_px(b: &OrientedBox, k: &Intrinsics) -> Option<Vec<Point2<f64>>> {
    let c = project_corners_px(b, k)?;
    Some(convex_hull_2d(&c))
}

/// Scanline fill of a convex polygon (vertices in either orientation, px) into a row-major
/// `width × height` mask.
///
/// Pixel `(u, v)` (index `v·width + u`) is set when its centre, the point `(u, v)`, lies inside
/// or on the polygon. A polygon of 1 or 2 vertices sets the pixel centres lying on that point or
/// segment. An empty polygon, a non-finite vertex, or a `width × height` that overflows `usize`
/// gives an all-false mask (empty in the overflow case). [`convex_polygon_spans`] gives the
/// same pixels as row intervals, without a frame-sized mask.
pub fn rasterize_convex_polygon(poly: &[Point2<f64>], width: u32, height: u32) -> Vec<bool> {
    let Some(n_px) = (width as usize).checked_mul(height as usize) else {
        return Vec::new();
    };
    let mut mask = vec![false; n_px];
    for (v, u_lo, u_hi) in convex_polygon_spans(poly, width, height) {
        let row = v as usize * width as usize;
        mask[row + u_lo as usize..=row + u_hi as usize].fill(true);
    }
    mask
}

/// The pixels of [`rasterize_convex_polygon`] as row intervals `(v, u_lo, u_hi)` (inclusive,
/// within `width × height`), rows increasing and each at most once: a walk over the spans
/// visits the polygon's pixels in row-major order at a cost that grows with the polygon, not
/// the frame. Empty for an empty polygon or a non-finite vertex.
pub fn convex_polygon_spans(poly: &[Point2<f64>], width: u32, height: u32) -> Vec<(u32, u32, u32)> {
    let mut spans = Vec::new();
    if width == 0
        || height == 0
        || poly.is_empty()
        || poly.iter().any(|p| !p.x.is_finite() || !p.y.is_finite())
    {
        return spans;
    }
    let (mut v_min, mut v_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in poly {
        v_min = v_min.min(p.y);
        v_max = v_max.max(p.y);
    }
    let row_lo = v_min.ceil().max(0.0);
    let row_hi = v_max.floor().min(height as f64 - 1.0);
    if row_lo > row_hi {
        return spans;
    }
    let n = poly.len();
    // Both bounds are clamped to [0, height-1], so the casts are exact.
    for v in (row_lo as u32)..=(row_hi as u32) {
        let y = f64::from(v);
        // The intersection of a horizontal line with a convex polygon is one interval:
        // the min/max over the edges' crossings (including edges lying on the line).
        let (mut u_lo, mut u_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let p = poly[i];
            let q = poly[(i + 1) % n];
            let (dp, dq) = (p.y - y, q.y - y);
            if dp * dq > 0.0 {
                continue;
            }
            if dp == 0.0 {
                u_lo = u_lo.min(p.x);
                u_hi = u_hi.max(p.x);
            }
            if dq == 0.0 {
                u_lo = u_lo.min(q.x);
                u_hi = u_hi.max(q.x);
            }
            if dp != dq {
                let x = p.x + (q.x - p.x) * (dp / (dp - dq));
                u_lo = u_lo.min(x);
                u_hi = u_hi.max(x);
            }
        }
        if u_lo > u_hi {
            continue;
        }
        let c_lo = u_lo.ceil().max(0.0);
        let c_hi = u_hi.floor().min(width as f64 - 1.0);
        if c_lo > c_hi {
            continue;
        }
        // Clamped to [0, width-1]: exact.
        spans.push((v, c_lo as u32, c_hi as u32));
    }
    spans
}

/// Intersection of the ray `origin + t·dir` (camera frame, mm; `dir` need not be unit) with a
/// solid box, by the slab method in the box frame.
///
/// Returns `(t_enter, t_exit, entry_face_axis)` with `t` in units of `dir` (mm when `dir` is
/// unit): `t_enter` is where the *line* enters the box (negative when `origin` is inside),
/// `t_exit` where it leaves, and `entry_face_axis` the box axis (0 = x, 1 = y, 2 = z) whose face
/// the line enters through. `None` when the line misses the box, the box lies entirely behind
/// the origin (`t_exit < 0`), `dir` is zero, or any input is not finite.
pub fn ray_box_intersection(
    origin: &Point3<f64>,
    dir: &Vector3<f64>,
    b: &OrientedBox,
) -> Option<(f64, f64, usize)> {
    ray_box_intersection_local(
        &b.to_local(origin),
        &(b.rotation.inverse() * dir),
        &b.half_size_mm(),
    )
}

/// [`ray_box_intersection`] with the ray already in the box frame: `origin` and `dir` relative
/// to the box centre along its axes, `half_size` the box's half extents (mm). For many rays
/// against one box, transform once and call this per ray.
pub fn ray_box_intersection_local(
    origin: &Vector3<f64>,
    dir: &Vector3<f64>,
    half_size: &Vector3<f64>,
) -> Option<(f64, f64, usize)> {
    let (o, d, h) = (origin, dir, half_size);
    if !o.iter().chain(d.iter()).all(|x| x.is_finite()) || d.norm_squared() == 0.0 {
        return None;
    }
    let mut t_enter = f64::NEG_INFINITY;
    let mut t_exit = f64::INFINITY;
    let mut axis = 0usize;
    for i in 0..3 {
        if d[i] == 0.0 {
            // Parallel to this slab: inside it for all t, or never.
            if o[i].abs() > h[i] {
                return None;
            }
            continue;
        }
        let t1 = (-h[i] - o[i]) / d[i];
        let t2 = (h[i] - o[i]) / d[i];
        let (near, far) = if t1 <= t2 { (t1, t2) } else { (t2, t1) };
        if near > t_enter {
            t_enter = near;
            axis = i;
        }
        t_exit = t_exit.min(far);
    }
    if t_enter > t_exit || t_exit < 0.0 {
        return None;
    }
    Some((t_enter, t_exit, axis))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn k() -> Intrinsics {
        Intrinsics::new(500.0, 500.0, 320.0, 240.0).unwrap()
    }

    fn shoelace(poly: &[Point2<f64>]) -> f64 {
        let n = poly.len();
        (0..n)
            .map(|i| {
                let (p, q) = (poly[i], poly[(i + 1) % n]);
                p.x * q.y - q.x * p.y
            })
            .sum::<f64>()
            / 2.0
    }

    #[test]
    fn hull_of_square_with_interior_and_collinear_points() {
        let pts = [
            Point2::new(0.0, 0.0),
            Point2::new(2.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(2.0, 2.0),
            Point2::new(0.0, 2.0),
            Point2::new(1.0, 1.0),
            Point2::new(0.0, 0.0),
            Point2::new(f64::NAN, 1.0),
        ];
        let h = convex_hull_2d(&pts);
        assert_eq!(h.len(), 4);
        assert!((shoelace(&h) - 4.0).abs() < 1e-12, "ccw, area 4");
        assert!(convex_hull_2d(&[]).is_empty());
        assert_eq!(convex_hull_2d(&[Point2::new(1.0, 1.0); 3]).len(), 1);
    }

    /// A long thin parallelogram (the cap of a 2 mm slab clipped by a box face, from a failing
    /// `thin_boxes_match_monte_carlo` case) whose every vertex comes twice, 1e-13 apart, as
    /// clipping leaves them: the hull is still the parallelogram, four vertices, its area.
    #[test]
    fn hull_ignores_copies_of_a_vertex_a_rounding_error_apart() {
        let base = [
            Point2::new(-137.6659, -119.9009),
            Point2::new(-133.0153, -118.3772),
            Point2::new(135.6674, 118.1416),
            Point2::new(135.0138, 120.1365),
        ];
        let want = shoelace(&base);
        let mut state = 1u64;
        let mut jitter = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-12
        };
        let mut worst: f64 = 0.0;
        for _ in 0..500 {
            let pts: Vec<Point2<f64>> = base
                .iter()
                .flat_map(|p| [*p, *p])
                .map(|p| Point2::new(p.x + jitter(), p.y + jitter()))
                .collect();
            let h = convex_hull_2d(&pts);
            assert_eq!(h.len(), 4, "{h:?}");
            worst = worst.max((shoelace(&h) - want).abs());
        }
        // The area is ~700 mm²; without the tolerance the hull was off by up to 350.
        assert!(worst < 1e-6, "area off by {worst}");
    }

    #[test]
    fn fronto_parallel_box_projects_to_rectangle() {
        // 200 x 100 x 50 mm box at z = 1000 mm, axis-aligned: front face at z = 975.
        let b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(200.0, 100.0, 50.0),
        )
        .unwrap();
        let h = silhouette_hull_px(&b, &k()).unwrap();
        assert_eq!(h.len(), 4);
        // The silhouette is the front face: half-width 100 mm at 975 mm → 51.28 px.
        let hw = 500.0 * 100.0 / 975.0;
        let hh = 500.0 * 50.0 / 975.0;
        assert!((shoelace(&h) - 4.0 * hw * hh).abs() < 1e-6);
        for p in &h {
            assert!(((p.x - 320.0).abs() - hw).abs() < 1e-9);
            assert!(((p.y - 240.0).abs() - hh).abs() < 1e-9);
        }
    }

    #[test]
    fn behind_camera_gives_none() {
        let b = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, 20.0),
            Vector3::new(100.0, 100.0, 100.0),
        )
        .unwrap();
        assert!(project_corners_px(&b, &k()).is_none());
        assert!(silhouette_hull_px(&b, &k()).is_none());
    }

    #[test]
    fn rasterize_counts_pixel_centres() {
        // Rectangle [1.5, 4.5] x [0.5, 2.0]: columns 2..=4, rows 1..=2 → 6 pixels.
        let poly = [
            Point2::new(1.5, 0.5),
            Point2::new(4.5, 0.5),
            Point2::new(4.5, 2.0),
            Point2::new(1.5, 2.0),
        ];
        let m = rasterize_convex_polygon(&poly, 8, 5);
        assert_eq!(m.len(), 40);
        assert_eq!(m.iter().filter(|x| **x).count(), 6);
        for v in 0..5 {
            for u in 0..8 {
                let want = (2..=4).contains(&u) && (1..=2).contains(&v);
                assert_eq!(m[v * 8 + u], want, "pixel ({u}, {v})");
            }
        }
        // Clockwise order gives the same mask.
        let mut rev = poly;
        rev.reverse();
        assert_eq!(rasterize_convex_polygon(&rev, 8, 5), m);
    }

    #[test]
    fn rasterize_triangle_matches_brute_force_and_clips() {
        let tri = [
            Point2::new(-3.2, 1.1),
            Point2::new(17.7, 4.9),
            Point2::new(5.3, 13.6),
        ];
        let (w, h) = (12u32, 10u32);
        let m = rasterize_convex_polygon(&tri, w, h);
        for v in 0..h as usize {
            for u in 0..w as usize {
                let p = Point2::new(u as f64, v as f64);
                let s = [
                    cross2(&tri[0], &tri[1], &p),
                    cross2(&tri[1], &tri[2], &p),
                    cross2(&tri[2], &tri[0], &p),
                ];
                let inside = s.iter().all(|x| *x >= 0.0) || s.iter().all(|x| *x <= 0.0);
                assert_eq!(m[v * w as usize + u], inside, "pixel ({u}, {v})");
            }
        }
        assert!(rasterize_convex_polygon(&[], 4, 4).iter().all(|x| !x));
    }

    #[test]
    fn ray_hits_front_face() {
        let b = OrientedBox::new(
            Rotation3::from_axis_angle(&Vector3::y_axis(), 0.2),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(200.0, 100.0, 50.0),
        )
        .unwrap();
        let (t0, t1, axis) =
            ray_box_intersection(&Point3::origin(), &Vector3::new(0.0, 0.0, 1.0), &b).unwrap();
        assert_eq!(axis, 2);
        // Along the camera z axis the box's z slab has half-width 25 / cos(0.2).
        let hw = 25.0 / 0.2f64.cos();
        assert!((t0 - (1000.0 - hw)).abs() < 1e-9);
        assert!((t1 - (1000.0 + hw)).abs() < 1e-9);
        // A ray well to the side misses; a ray pointing away misses.
        assert!(ray_box_intersection(
            &Point3::new(500.0, 0.0, 0.0),
            &Vector3::new(0.0, 0.0, 1.0),
            &b
        )
        .is_none());
        assert!(
            ray_box_intersection(&Point3::origin(), &Vector3::new(0.0, 0.0, -1.0), &b).is_none()
        );
        // From the inside, t_enter < 0 < t_exit.
        let (t0, t1, _) = ray_box_intersection(
            &Point3::new(0.0, 0.0, 1000.0),
            &Vector3::new(1.0, 0.0, 0.0),
            &b,
        )
        .unwrap();
        assert!(t0 < 0.0 && t1 > 0.0);
        assert!((t0 + t1).abs() < 1e-9);
    }
}
