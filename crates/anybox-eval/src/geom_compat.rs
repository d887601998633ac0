//! The geometric metrics the evaluator uses, in one place: `anybox_geom::iou::iou` (3D IoU),
//! `anybox_geom::symmetry::match_axes` (rotation error over symmetries and relabellings, matched
//! size error) and `anybox_geom::adds::adds_mm` (ADD-S).
//!
//! The tests keep independent implementations to cross-check them: exact IoU by polyhedron
//! clipping with caps (volume by the divergence theorem), and ADD-S on a deterministic
//! per-face grid instead of random samples.

use anybox_geom::nalgebra::{Point3, Vector3};
use anybox_geom::OrientedBox;

pub use anybox_geom::adds::adds_mm;
use anybox_geom::adds::{sample_surface_mm, ADDS_SEED};

/// A ground truth's ADD-S surface samples, drawn once and reused for every estimate.
///
/// [`AddsReference::adds_mm`] equals `anybox_geom::adds::adds_mm(est, gt, n)` exactly (same
/// samples — `sample_surface_mm(gt, n, ADDS_SEED)` — same summation order; a test checks it).
pub struct AddsReference {
    pts: Vec<Point3<f64>>,
    mean: Point3<f64>,
}

impl AddsReference {
    /// Samples `n` points (> 0) on the true box's surface.
    pub fn new(gt: &OrientedBox, n: usize) -> Self {
        let pts = sample_surface_mm(gt, n.max(1), ADDS_SEED);
        let sum = pts.iter().fold(Vector3::zeros(), |s, p| s + p.coords);
        let mean = Point3::from(sum / pts.len().max(1) as f64);
        Self { pts, mean }
    }

    /// ADD-S of `est` against this ground truth, mm.
    pub fn adds_mm(&self, est: &OrientedBox) -> f64 {
        let sum: f64 = self
            .pts
            .iter()
            .map(|p| (p - est.closest_surface_point(p)).norm())
            .sum();
        sum / self.pts.len() as f64
    }

    /// ADD-S of `est`, or `None` when it certainly is at least `limit_mm`.
    ///
    /// The cheap certificate: the distance to the surface is at least the distance to the solid
    /// box, which is convex, so by Jensen the mean over the samples is at least the distance of
    /// the samples' mean point to the solid box.
    pub fn adds_mm_below(&self, est: &OrientedBox, limit_mm: f64) -> Option<f64> {
        let l = est.to_local(&self.mean);
        let h = est.half_size_mm();
        let outside = Vector3::new(
            (l.x.abs() - h.x).max(0.0),
            (l.y.abs() - h.y).max(0.0),
            (l.z.abs() - h.z).max(0.0),
        );
        if outside.norm() >= limit_mm {
            return None;
        }
        Some(self.adds_mm(est))
    }
}
pub use anybox_geom::iou::{iou, IouMethod};
pub use anybox_geom::symmetry::{match_axes, rotation_error_deg, size_error_mm};

/// Exact oriented-box IoU: clip box `a` (as a polyhedron) by the six face planes of `b`, and
/// integrate the volume of the result with the divergence theorem.
#[cfg(test)]
fn exact_iou(a: &OrientedBox, b: &OrientedBox) -> f64 {
    let ra = a.half_size_mm().norm();
    let rb = b.half_size_mm().norm();
    if (a.center_mm - b.center_mm).norm() >= ra + rb {
        return 0.0;
    }
    // Work relative to a's centre for precision.
    let origin = a.center_mm;
    let mut faces = box_faces(a, &origin);
    for k in 0..3 {
        let axis = b.axis(k);
        let h = b.half_size_mm()[k];
        let c = b.center_mm - origin;
        for sign in [1.0, -1.0] {
            let n = axis * sign;
            let d = n.dot(&c) + h;
            faces = clip_polyhedron(&faces, &n, d);
            if faces.is_empty() {
                return 0.0;
            }
        }
    }
    let inter = polyhedron_volume(&faces).max(0.0);
    let union = a.volume_mm3() + b.volume_mm3() - inter;
    if union > 0.0 {
        (inter / union).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Plane-side tolerance, mm.
#[cfg(test)]
const EPS: f64 = 1e-9;

#[cfg(test)]
type Face = Vec<Vector3<f64>>;

#[cfg(test)]
fn box_faces(x: &OrientedBox, origin: &Vector3<f64>) -> Vec<Face> {
    let h = x.half_size_mm();
    let p = |sx: f64, sy: f64, sz: f64| {
        x.rotation * Vector3::new(sx * h.x, sy * h.y, sz * h.z) + x.center_mm - origin
    };
    // Counter-clockwise seen from outside (outward normal by the right-hand rule).
    vec![
        vec![
            p(1., -1., -1.),
            p(1., 1., -1.),
            p(1., 1., 1.),
            p(1., -1., 1.),
        ],
        vec![
            p(-1., -1., -1.),
            p(-1., -1., 1.),
            p(-1., 1., 1.),
            p(-1., 1., -1.),
        ],
        vec![
            p(-1., 1., -1.),
            p(-1., 1., 1.),
            p(1., 1., 1.),
            p(1., 1., -1.),
        ],
        vec![
            p(-1., -1., -1.),
            p(1., -1., -1.),
            p(1., -1., 1.),
            p(-1., -1., 1.),
        ],
        vec![
            p(-1., -1., 1.),
            p(1., -1., 1.),
            p(1., 1., 1.),
            p(-1., 1., 1.),
        ],
        vec![
            p(-1., -1., -1.),
            p(-1., 1., -1.),
            p(1., 1., -1.),
            p(1., -1., -1.),
        ],
    ]
}

/// Keeps the part of a closed convex polyhedron with `n·x <= d` and closes it with a cap face.
#[cfg(test)]
fn clip_polyhedron(faces: &[Face], n: &Vector3<f64>, d: f64) -> Vec<Face> {
    let mut out = Vec::with_capacity(faces.len() + 1);
    let mut cap: Vec<Vector3<f64>> = Vec::new();
    // A face already lying in the plane closes the polyhedron there: no cap needed.
    let mut face_in_plane = false;
    for f in faces {
        if f.iter().all(|p| (n.dot(p) - d).abs() <= EPS) {
            face_in_plane = true;
        }
        let mut poly = Vec::with_capacity(f.len() + 2);
        for i in 0..f.len() {
            let p = f[i];
            let q = f[(i + 1) % f.len()];
            let dp = n.dot(&p) - d;
            let dq = n.dot(&q) - d;
            if dp <= EPS {
                poly.push(p);
            }
            if dp.abs() <= EPS {
                cap.push(p);
            }
            if (dp < -EPS && dq > EPS) || (dp > EPS && dq < -EPS) {
                let t = dp / (dp - dq);
                let x = p + (q - p) * t;
                poly.push(x);
                cap.push(x);
            }
        }
        if poly.len() >= 3 {
            out.push(poly);
        }
    }
    if cap.len() >= 3 && !face_in_plane {
        // Order the cap points counter-clockwise about n (outward for the kept half-space).
        let c = cap.iter().fold(Vector3::zeros(), |s, p| s + p) / cap.len() as f64;
        let u = any_perpendicular(n);
        let v = n.cross(&u);
        let mut pts: Vec<(f64, Vector3<f64>)> = cap
            .iter()
            .map(|p| {
                let r = p - c;
                (r.dot(&v).atan2(r.dot(&u)), *p)
            })
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        out.push(pts.into_iter().map(|(_, p)| p).collect());
    }
    out
}

#[cfg(test)]
fn any_perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    n.cross(&a).normalize()
}

#[cfg(test)]
fn polyhedron_volume(faces: &[Face]) -> f64 {
    let mut v = 0.0;
    for f in faces {
        for i in 1..f.len().saturating_sub(1) {
            v += f[0].dot(&f[i].cross(&f[i + 1]));
        }
    }
    v / 6.0
}

/// Deterministic, area-uniform surface samples (test-only independent ADD-S reference) of a box (a grid on each face).
#[cfg(test)]
fn surface_samples(b: &OrientedBox, n: usize) -> Vec<Point3<f64>> {
    let s = b.size_mm;
    let areas = [s.y * s.z, s.x * s.z, s.x * s.y];
    let total = 2.0 * (areas[0] + areas[1] + areas[2]);
    let mut out = Vec::with_capacity(n + 16);
    for k in 0..3 {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let share = (n as f64 * areas[k] / total).max(1.0);
        // Grid resolution along i and j proportional to the edge lengths.
        let ni = ((share * s[i] / s[j]).sqrt().round() as usize).max(1);
        let nj = ((share / ni as f64).round() as usize).max(1);
        for sign in [-1.0, 1.0] {
            for a in 0..ni {
                for c in 0..nj {
                    let mut l = Vector3::zeros();
                    l[k] = sign * s[k] / 2.0;
                    l[i] = ((a as f64 + 0.5) / ni as f64 - 0.5) * s[i];
                    l[j] = ((c as f64 + 0.5) / nj as f64 - 0.5) * s[j];
                    out.push(b.to_camera(&l));
                }
            }
        }
    }
    out
}

/// ADD-S (BOP `adi`), mm: mean distance from points on the true box surface to the nearest
/// point of the estimated box surface.
#[cfg(test)]
fn grid_adds_mm(est: &OrientedBox, gt: &OrientedBox, n_samples: usize) -> f64 {
    let pts = surface_samples(gt, n_samples);
    if pts.is_empty() {
        return f64::INFINITY;
    }
    let sum: f64 = pts
        .iter()
        .map(|p| (est.closest_surface_point(p) - p).norm())
        .sum();
    sum / pts.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use anybox_geom::nalgebra::Rotation3;

    fn bx(r: Rotation3<f64>, c: [f64; 3], s: [f64; 3]) -> OrientedBox {
        OrientedBox::new(r, Vector3::from(c), Vector3::from(s)).unwrap()
    }

    #[test]
    fn geom_exact_iou_agrees_with_independent_clipping() {
        let mut state = 0x1234_5678_u64;
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..200 {
            let mut b = || {
                let r = Rotation3::from_euler_angles(rnd() * 6.0, rnd() * 6.0, rnd() * 6.0);
                let c = [rnd() * 80.0, rnd() * 80.0, 500.0 + rnd() * 80.0];
                let s = [
                    50.0 + rnd() * 150.0,
                    50.0 + rnd() * 150.0,
                    50.0 + rnd() * 150.0,
                ];
                bx(r, c, s)
            };
            let (a, c) = (b(), b());
            let mine = exact_iou(&a, &c);
            let theirs = iou(&a, &c, IouMethod::Exact);
            assert!((mine - theirs).abs() < 1e-7, "{mine} vs {theirs}");
        }
    }

    #[test]
    fn exact_iou_closed_forms() {
        let a = bx(Rotation3::identity(), [0., 0., 500.], [200., 100., 300.]);
        assert!((exact_iou(&a, &a) - 1.0).abs() < 1e-9);
        // Shift 50 mm along x: (200-50)/(200+50) = 0.6 (notes §1.1 table).
        let b = bx(Rotation3::identity(), [50., 0., 500.], [200., 100., 300.]);
        assert!((exact_iou(&a, &b) - 0.6).abs() < 1e-9);
        assert!((iou(&a, &b, IouMethod::Aabb) - 0.6).abs() < 1e-9);
        // Rotated by 90° about z with relabelled sizes: the same physical box.
        let r = Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2);
        let c = bx(r, [0., 0., 500.], [100., 200., 300.]);
        assert!((exact_iou(&a, &c) - 1.0).abs() < 1e-9);
        // A cube rotated 45° about z inside the same cube: intersection = octagon prism.
        let cube = bx(Rotation3::identity(), [0., 0., 0.], [2., 2., 2.]);
        let r45 = Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4);
        let cube45 = bx(r45, [0., 0., 0.], [2., 2., 2.]);
        // Octagon area = 8·(√2−1)·... for unit half-width: 8(√2−1); height 2.
        let inter = 8.0 * (2f64.sqrt() - 1.0) * 2.0;
        let expected = inter / (16.0 - inter);
        assert!((exact_iou(&cube, &cube45) - expected).abs() < 1e-9);
    }

    #[test]
    fn geom_adds_agrees_with_grid_reference() {
        let a = bx(Rotation3::identity(), [0., 0., 500.], [200., 100., 300.]);
        assert!(grid_adds_mm(&a, &a, 500) < 1e-9);
        assert!(adds_mm(&a, &a, 1000) < 1e-9);
        for (r, c) in [
            (Rotation3::identity(), [0., 0., 510.]),
            (
                Rotation3::from_euler_angles(0.2, 0.1, -0.3),
                [5., -8., 520.],
            ),
            (Rotation3::from_euler_angles(0.0, 0.0, 1.0), [40., 0., 500.]),
        ] {
            let b = bx(r, c, [190., 110., 280.]);
            let grid = grid_adds_mm(&b, &a, 20000);
            let geom = adds_mm(&b, &a, 4000);
            assert!((grid - geom).abs() < 0.03 * grid + 0.2, "{grid} vs {geom}");
            // The cached reference is bit-identical to anybox_geom's function.
            assert_eq!(AddsReference::new(&a, 4000).adds_mm(&b), geom);
        }
        // The pruning certificate never rejects an ADD-S below the limit.
        let refa = AddsReference::new(&a, 1000);
        for dx in [0.0, 50.0, 150.0, 250.0, 400.0, 800.0] {
            let b = bx(
                Rotation3::from_euler_angles(0.1, 0.4, 0.2),
                [dx, 0., 500.],
                [190., 110., 280.],
            );
            let v = adds_mm(&b, &a, 1000);
            for limit in [10.0, 30.0, 100.0, 300.0] {
                match refa.adds_mm_below(&b, limit) {
                    Some(w) => assert_eq!(w, v),
                    None => assert!(v >= limit, "pruned {v} < {limit}"),
                }
            }
        }
    }
}
