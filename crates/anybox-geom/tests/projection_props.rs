//! Property tests of the projection helpers: the rasterised silhouette agrees with ray casting.

use anybox_geom::nalgebra::{Point2, Point3, Rotation3, Vector3};
use anybox_geom::projection::{
    convex_hull_2d, convex_polygon_spans, project_corners_px, rasterize_convex_polygon,
    ray_box_intersection, silhouette_hull_px,
};
use anybox_geom::{Intrinsics, OrientedBox};
use proptest::prelude::*;

const W: u32 = 80;
const H: u32 = 60;

fn k() -> Intrinsics {
    Intrinsics::new(70.0, 72.0, 39.5, 30.2).unwrap()
}

fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
    (-3.2f64..3.2, -3.2f64..3.2, -3.2f64..3.2)
        .prop_map(|(a, b, c)| Rotation3::new(Vector3::new(a, b, c)))
}

/// Boxes fully in front of the camera, mostly inside the small image.
fn visible_box() -> impl Strategy<Value = OrientedBox> {
    (
        rotation(),
        (50.0f64..400.0, 50.0f64..400.0, 50.0f64..400.0),
        (-300.0f64..300.0, -250.0f64..250.0, 700.0f64..1500.0),
    )
        .prop_map(|(r, s, c)| {
            OrientedBox::new(r, Vector3::new(c.0, c.1, c.2), Vector3::new(s.0, s.1, s.2)).unwrap()
        })
}

/// Signed distance-like test: min over edges of the cross product, for a ccw convex polygon.
fn inside_margin(poly: &[Point2<f64>], p: &Point2<f64>) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / (b - a).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn silhouette_raster_agrees_with_ray_casting(b in visible_box()) {
        prop_assume!(b.corners_mm().iter().all(|c| c.z > 10.0));
        let hull = silhouette_hull_px(&b, &k()).unwrap();
        let mask = rasterize_convex_polygon(&hull, W, H);
        prop_assert_eq!(mask.len(), (W * H) as usize);
        for v in 0..H {
            for u in 0..W {
                let (uf, vf) = (u as f64, v as f64);
                // Skip pixel centres within 1e-6 px of the outline, where rounding decides.
                if inside_margin(&hull, &Point2::new(uf, vf)).abs() < 1e-6 {
                    continue;
                }
                let hit = ray_box_intersection(&Point3::origin(), &k().ray(uf, vf), &b).is_some();
                prop_assert_eq!(mask[(v * W + u) as usize], hit, "pixel ({}, {})", u, v);
            }
        }
        // The spans, walked in order, visit exactly the set pixels, row-major, each once.
        let spans = convex_polygon_spans(&hull, W, H);
        prop_assert!(spans.windows(2).all(|p| p[0].0 < p[1].0), "rows increase");
        let walked: Vec<usize> = spans
            .iter()
            .flat_map(|&(v, u0, u1)| (u0..=u1).map(move |u| (v * W + u) as usize))
            .collect();
        let set: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
        prop_assert_eq!(walked, set);
    }

    #[test]
    fn hull_is_ccw_convex_and_contains_all_corners(b in visible_box()) {
        prop_assume!(b.corners_mm().iter().all(|c| c.z > 10.0));
        let pts = project_corners_px(&b, &k()).unwrap();
        let hull = convex_hull_2d(&pts);
        prop_assert!((4..=6).contains(&hull.len()), "a box silhouette has 4 to 6 vertices");
        for i in 0..hull.len() {
            let (a, c, d) = (hull[i], hull[(i + 1) % hull.len()], hull[(i + 2) % hull.len()]);
            prop_assert!((c.x - a.x) * (d.y - a.y) - (c.y - a.y) * (d.x - a.x) > 0.0);
        }
        for p in &pts {
            prop_assert!(inside_margin(&hull, p) > -1e-9);
        }
    }

    #[test]
    fn ray_entry_point_is_on_the_reported_face(b in visible_box(), u in 0.0f64..80.0, v in 0.0f64..60.0) {
        let dir = k().ray(u, v);
        if let Some((t0, t1, axis)) = ray_box_intersection(&Point3::origin(), &dir, &b) {
            prop_assert!(t0 <= t1);
            let l = b.to_local(&Point3::from(dir * t0));
            let h = b.half_size_mm();
            prop_assert!((l[axis].abs() - h[axis]).abs() < 1e-6 * h.amax());
            for i in 0..3 {
                prop_assert!(l[i].abs() <= h[i] + 1e-6 * h.amax());
            }
            // The entry face faces the camera.
            let n = b.axis(axis) * l[axis].signum();
            prop_assert!(n.dot(&dir) <= 1e-12);
        }
    }
}
