//! 3D intersection-over-union of two posed boxes (SPEC §4 "3D IoU", paper §4).
//!
//! In: two [`OrientedBox`]es in the same (camera) frame, mm. Out: IoU in `[0, 1]`.
//!
//! Three variants, because published numbers use different ones ([`IouMethod`]):
//! - [`IouMethod::Exact`] (default): the IoU of the oriented boxes themselves. The intersection
//!   volume is computed exactly by clipping A (a convex polyhedron: 6 quadrilateral faces) with
//!   each of B's 6 half-spaces in turn — Sutherland–Hodgman on every face, plus a cap face on the
//!   cutting plane (the convex hull of the cut points) — and summing `⅓·area·height` pyramids from
//!   an interior point. A plane that no vertex crosses by more than a tolerance of `1e-9 ×` the
//!   largest extent is skipped, which keeps identical, flush (coplanar-face) and touching boxes
//!   exact instead of producing slivers or doubled caps. Same result as the Objectron/PACE `IoU`
//!   class (face clipping + convex hull volume).
//! - [`IouMethod::Aabb`]: IoU of the camera-frame axis-aligned hulls of each box's rotated
//!   corners — NOCS's `asymmetric_3d_iou` with the reduction fixed to `axis=1`, what HouseCat6D
//!   prints as "CATRE IoU". It over-estimates the volume of rotated boxes.
//! - [`IouMethod::NocsLegacy`]: NOCS's original `asymmetric_3d_iou` as published
//!   (`hughw19/NOCS_CVPR2019/utils.py`), which applies `np.amax/np.amin(..., axis=0)` to the 3×8
//!   corner array and thereby reduces over x/y/z *per corner*: its "IoU" is a ratio of products
//!   of 8 per-corner ranges. Reproduced faithfully, including NOCS's corner order (which matters,
//!   since corner `i` of one box is compared with corner `i` of the other) so that legacy figures
//!   are comparable like for like. It is not invariant to relabelling the box axes nor to
//!   translation; it *is* invariant to the length unit (mm here, metres in NOCS).

use std::fmt;
use std::str::FromStr;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::{GeomError, OrientedBox};

/// Which 3D IoU definition to use (see the module docs). Text form: `exact`, `aabb`,
/// `nocs-legacy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IouMethod {
    /// Exact IoU of the oriented boxes (default).
    #[default]
    Exact,
    /// IoU of the camera-frame axis-aligned hulls of the rotated corners (NOCS `axis=1`, "CATRE").
    Aabb,
    /// NOCS's original `asymmetric_3d_iou` with its `axis=0` reduction, reproduced bug for bug.
    NocsLegacy,
}

impl IouMethod {
    /// All variants, in their documented order.
    pub const ALL: [IouMethod; 3] = [IouMethod::Exact, IouMethod::Aabb, IouMethod::NocsLegacy];

    /// The text form used in files and on the command line.
    pub fn as_str(&self) -> &'static str {
        match self {
            IouMethod::Exact => "exact",
            IouMethod::Aabb => "aabb",
            IouMethod::NocsLegacy => "nocs-legacy",
        }
    }
}

impl fmt::Display for IouMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // `pad` honours width/alignment flags, e.g. in tables.
        f.pad(self.as_str())
    }
}

/// Parses `exact`, `aabb` (alias `catre`) or `nocs-legacy` (aliases `nocs_legacy`, `legacy`),
/// case-insensitively.
impl FromStr for IouMethod {
    type Err = GeomError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "exact" => Ok(IouMethod::Exact),
            "aabb" | "catre" => Ok(IouMethod::Aabb),
            "nocs-legacy" | "nocs_legacy" | "legacy" => Ok(IouMethod::NocsLegacy),
            _ => Err(GeomError::UnknownIouMethod(s.to_string())),
        }
    }
}

/// 3D IoU of two boxes with the chosen definition, in `[0, 1]`.
///
/// Degenerate inputs (zero or non-finite volume) give 0 rather than NaN.
pub fn iou(a: &OrientedBox, b: &OrientedBox, method: IouMethod) -> f64 {
    let r = match method {
        IouMethod::Exact => {
            let (va, vb) = (a.volume_mm3(), b.volume_mm3());
            let inter = intersection_volume_mm3(a, b);
            ratio(inter, va + vb - inter)
        }
        IouMethod::Aabb => aabb_iou(a, b),
        IouMethod::NocsLegacy => nocs_legacy_iou(a, b),
    };
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

fn ratio(num: f64, den: f64) -> f64 {
    if den > 0.0 && num.is_finite() && den.is_finite() {
        num / den
    } else {
        0.0
    }
}

/// A convex polygon's vertices in order, as offsets from a common origin, mm.
type Poly = Vec<Vector3<f64>>;

/// A plane `n·x = d` (unit outward normal `n`), with `x` relative to the common origin, mm.
#[derive(Clone, Copy)]
struct Plane {
    n: Vector3<f64>,
    d: f64,
}

/// The 6 faces of a box as (outward plane, 4 vertices in cyclic order), relative to `origin`.
fn faces(b: &OrientedBox, origin: &Vector3<f64>) -> [(Plane, Poly); 6] {
    let h = b.half_size_mm();
    let c = b.center_mm - origin;
    let ax = [b.axis(0), b.axis(1), b.axis(2)];
    std::array::from_fn(|f| {
        let i = f / 2;
        let s = if f % 2 == 0 { 1.0 } else { -1.0 };
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let n = ax[i] * s;
        let fc = c + n * h[i];
        let (u, v) = (ax[j] * h[j], ax[k] * h[k]);
        let poly = vec![fc + u + v, fc - u + v, fc - u - v, fc + u - v];
        (Plane { n, d: n.dot(&fc) }, poly)
    })
}

/// Sutherland–Hodgman: the part of `poly` with `n·x − d <= eps`.
fn clip(poly: &Poly, p: &Plane, eps: f64) -> Poly {
    let n = poly.len();
    let mut out = Vec::with_capacity(n + 2);
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let da = p.n.dot(&a) - p.d;
        let db = p.n.dot(&b) - p.d;
        let (ina, inb) = (da <= eps, db <= eps);
        if ina != inb {
            let t = (da / (da - db)).clamp(0.0, 1.0);
            out.push(a + (b - a) * t);
        }
        if inb {
            out.push(b);
        }
    }
    out
}

/// Area vector of a planar polygon (normal × area).
fn area_vector(poly: &Poly) -> Vector3<f64> {
    let n = poly.len();
    if n < 3 {
        return Vector3::zeros();
    }
    let o = poly[0];
    let mut s = Vector3::zeros();
    for i in 1..n - 1 {
        s += (poly[i] - o).cross(&(poly[i + 1] - o));
    }
    s * 0.5
}

/// Clips the convex polyhedron `faces` by the half-space `n·x <= d` (tolerance `eps`), adding
/// the cap face. Returns `None` when nothing of positive thickness is left.
fn clip_polyhedron(faces: Vec<(Plane, Poly)>, p: &Plane, eps: f64) -> Option<Vec<(Plane, Poly)>> {
    let (mut dmin, mut dmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for (_, poly) in faces.iter() {
        for v in poly {
            let d = p.n.dot(v) - p.d;
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
    }
    if dmax <= eps {
        // Entirely inside (or flush with) the plane. Skipping here, rather than clipping, is
        // what keeps coplanar faces from being cut into slivers or duplicated by a cap.
        return Some(faces);
    }
    if dmin >= -eps {
        // Entirely outside, or a sliver at most `eps` thick.
        return None;
    }
    let mut out: Vec<(Plane, Poly)> = Vec::with_capacity(faces.len() + 1);
    let mut cap_pts: Vec<Vector3<f64>> = Vec::new();
    for (pl, poly) in faces {
        let c = clip(&poly, p, eps);
        if c.len() < 3 {
            continue;
        }
        cap_pts.extend(c.iter().filter(|v| (p.n.dot(v) - p.d).abs() <= eps));
        out.push((pl, c));
    }
    // The cap: convex hull of the clipped faces' vertices lying on the plane.
    if cap_pts.len() >= 3 {
        let centre = cap_pts.iter().sum::<Vector3<f64>>() / cap_pts.len() as f64;
        // Any unit vector orthogonal to n, then the third of a right-handed basis.
        let helper = if p.n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let u = p.n.cross(&helper).normalize();
        let w = p.n.cross(&u);
        let pts2: Vec<nalgebra::Point2<f64>> = cap_pts
            .iter()
            .map(|v| nalgebra::Point2::new((v - centre).dot(&u), (v - centre).dot(&w)))
            .collect();
        let hull = crate::projection::convex_hull_2d(&pts2);
        if hull.len() >= 3 {
            // Rebuilt on the plane itself, which also removes the within-eps scatter.
            let on_plane = centre - p.n * (p.n.dot(&centre) - p.d);
            let poly = hull.iter().map(|q| on_plane + u * q.x + w * q.y).collect();
            out.push((*p, poly));
        }
    }
    if out.len() < 4 {
        return None;
    }
    Some(out)
}

/// Exact volume of the intersection of two oriented boxes, mm³ (see the module docs).
///
/// Returns a value in `[0, min(vol a, vol b)]`; 0 for disjoint or merely touching boxes.
pub fn intersection_volume_mm3(a: &OrientedBox, b: &OrientedBox) -> f64 {
    // Work relative to A's centre so that face offsets are small and cancellation mild.
    let origin = a.center_mm;
    let scale = a.size_mm.amax().max(b.size_mm.amax());
    if !scale.is_finite() || scale <= 0.0 || !(b.center_mm - origin).norm().is_finite() {
        return 0.0;
    }
    // Points within `eps` of a plane count as on it: rounding noise is ~1e-16·scale, and the
    // volume error this tolerance can cause is at most ~eps·(surface area).
    let eps = 1e-9 * scale;
    // Separated bounding spheres: disjoint (the common case when matching many pairs).
    if (b.center_mm - origin).norm() > a.half_size_mm().norm() + b.half_size_mm().norm() + eps {
        return 0.0;
    }
    let mut poly: Vec<(Plane, Poly)> = faces(a, &origin).into_iter().collect();
    for (plane, _) in faces(b, &origin).iter() {
        match clip_polyhedron(poly, plane, eps) {
            Some(p) => poly = p,
            None => return 0.0,
        }
    }
    // V = Σ ⅓·area·height over faces, heights from an interior point (the vertex mean).
    let n_v: usize = poly.iter().map(|(_, f)| f.len()).sum();
    let reference = poly
        .iter()
        .flat_map(|(_, f)| f.iter())
        .sum::<Vector3<f64>>()
        / n_v as f64;
    let v: f64 = poly
        .iter()
        .map(|(pl, f)| {
            let area = pl.n.dot(&area_vector(f)).abs();
            let height = pl.d - pl.n.dot(&reference);
            area * height / 3.0
        })
        .sum();
    if !v.is_finite() {
        return 0.0;
    }
    v.clamp(0.0, a.volume_mm3().min(b.volume_mm3()))
}

/// Camera-frame axis-aligned bounds (min, max) of a box's corners, mm.
fn corner_aabb(b: &OrientedBox) -> (Vector3<f64>, Vector3<f64>) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for c in b.corners_mm() {
        lo = lo.inf(&c.coords);
        hi = hi.sup(&c.coords);
    }
    (lo, hi)
}

fn aabb_iou(a: &OrientedBox, b: &OrientedBox) -> f64 {
    let (alo, ahi) = corner_aabb(a);
    let (blo, bhi) = corner_aabb(b);
    let ext = (ahi.inf(&bhi) - alo.sup(&blo)).map(|x| x.max(0.0));
    let inter = ext.product();
    let (va, vb) = ((ahi - alo).product(), (bhi - blo).product());
    ratio(inter, va + vb - inter)
}

/// NOCS `get_3d_bbox` corner order: rows `(±x, ±y, ±z)/2` as listed in `utils.py`.
const NOCS_CORNER_SIGNS: [[f64; 3]; 8] = [
    [1.0, 1.0, 1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, 1.0],
    [-1.0, 1.0, -1.0],
    [1.0, -1.0, 1.0],
    [1.0, -1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [-1.0, -1.0, -1.0],
];

/// Per-corner (max, min) over the camera x/y/z coordinates: NOCS's `axis=0` reduction.
fn nocs_legacy_ranges(b: &OrientedBox) -> ([f64; 8], [f64; 8]) {
    let h = b.half_size_mm();
    let mut mx = [0.0; 8];
    let mut mn = [0.0; 8];
    for (i, s) in NOCS_CORNER_SIGNS.iter().enumerate() {
        let c = b.to_camera(&Vector3::new(s[0] * h.x, s[1] * h.y, s[2] * h.z));
        mx[i] = c.x.max(c.y).max(c.z);
        mn[i] = c.x.min(c.y).min(c.z);
    }
    (mx, mn)
}

fn nocs_legacy_iou(a: &OrientedBox, b: &OrientedBox) -> f64 {
    let (amax, amin) = nocs_legacy_ranges(a);
    let (bmax, bmin) = nocs_legacy_ranges(b);
    let mut overlap = [0.0; 8];
    for i in 0..8 {
        overlap[i] = amax[i].min(bmax[i]) - amin[i].max(bmin[i]);
    }
    // `if np.amin(overlap_max - overlap_min) < 0: intersections = 0`.
    let inter = if overlap.iter().any(|o| *o < 0.0) {
        0.0
    } else {
        overlap.iter().product()
    };
    let va: f64 = (0..8).map(|i| amax[i] - amin[i]).product();
    let vb: f64 = (0..8).map(|i| bmax[i] - bmin[i]).product();
    ratio(inter, va + vb - inter)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn bx(r: Rotation3<f64>, t: [f64; 3], s: [f64; 3]) -> OrientedBox {
        OrientedBox::new(r, Vector3::from(t), Vector3::from(s)).unwrap()
    }

    fn rz(deg: f64) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Vector3::z_axis(), deg.to_radians())
    }

    const S: [f64; 3] = [200.0, 100.0, 300.0];

    #[test]
    fn method_text_round_trip() {
        for m in IouMethod::ALL {
            assert_eq!(m.to_string().parse::<IouMethod>().unwrap(), m);
            let js = serde_json_like(m);
            assert_eq!(js, m.as_str());
        }
        assert!("volume".parse::<IouMethod>().is_err());
    }

    // serde's rename must agree with Display; checked without a serde_json dependency by
    // deserialising from a string through `serde::de::value`.
    fn serde_json_like(m: IouMethod) -> String {
        use serde::de::{value::StrDeserializer, IntoDeserializer};
        let d: StrDeserializer<'_, serde::de::value::Error> = m.as_str().into_deserializer();
        let back = IouMethod::deserialize(d).unwrap();
        back.as_str().to_string()
    }

    #[test]
    fn shift_along_x_matches_notes_table() {
        // SPEC notes §1.1: 200 x 100 x 300 mm, GT shifted 50 mm along x.
        let a = bx(Rotation3::identity(), [0.0; 3], S);
        let b = bx(Rotation3::identity(), [50.0, 0.0, 0.0], S);
        assert!((iou(&a, &b, IouMethod::Exact) - 0.6).abs() < 1e-12);
        assert!((iou(&a, &b, IouMethod::Aabb) - 0.6).abs() < 1e-12);
        let legacy = iou(&a, &b, IouMethod::NocsLegacy);
        assert!((legacy - 0.499).abs() < 5e-4, "legacy {legacy}");
    }

    #[test]
    fn z_extent_halved_matches_notes_table() {
        let a = bx(Rotation3::identity(), [0.0; 3], S);
        let b = bx(Rotation3::identity(), [0.0; 3], [200.0, 100.0, 150.0]);
        assert!((iou(&a, &b, IouMethod::Exact) - 0.5).abs() < 1e-12);
        assert!((iou(&a, &b, IouMethod::Aabb) - 0.5).abs() < 1e-12);
        let legacy = iou(&a, &b, IouMethod::NocsLegacy);
        assert!((legacy - 0.034).abs() < 5e-4, "legacy {legacy}");
    }

    #[test]
    fn rotated_30_about_z_matches_notes_table() {
        let a = bx(Rotation3::identity(), [0.0; 3], S);
        let b = bx(rz(30.0), [0.0; 3], S);
        let aabb = iou(&a, &b, IouMethod::Aabb);
        assert!((aabb - 0.480).abs() < 5e-4, "aabb {aabb}");
        let legacy = iou(&a, &b, IouMethod::NocsLegacy);
        assert!((legacy - 0.367).abs() < 5e-4, "legacy {legacy}");
        // Exact: the 2D overlap of a 200x100 rectangle with itself rotated 30°, times 300.
        let exact = iou(&a, &b, IouMethod::Exact);
        let area = polygon_overlap_area_2d(200.0, 100.0, 30.0);
        let want = area / (2.0 * 200.0 * 100.0 - area);
        assert!((exact - want).abs() < 1e-9, "exact {exact} want {want}");
    }

    #[test]
    fn relabelled_axes_matches_notes_table() {
        let a = bx(Rotation3::identity(), [0.0; 3], S);
        let b = bx(rz(90.0), [0.0; 3], [100.0, 200.0, 300.0]);
        assert!((iou(&a, &b, IouMethod::Exact) - 1.0).abs() < 1e-9);
        assert!((iou(&a, &b, IouMethod::Aabb) - 1.0).abs() < 1e-9);
        // The legacy value depends on where the boxes sit (the notes' 0.609 is for an unstated
        // placement; at 1 m depth it is 0.589): what matters is that it is far from 1.
        let legacy = iou(&a, &b, IouMethod::NocsLegacy);
        assert!((legacy - 0.0870).abs() < 5e-4, "legacy {legacy}");
        let t = [0.0, 0.0, 1000.0];
        let (a, b) = (
            bx(Rotation3::identity(), t, S),
            bx(rz(90.0), t, [100.0, 200.0, 300.0]),
        );
        let legacy = iou(&a, &b, IouMethod::NocsLegacy);
        assert!((legacy - 0.589).abs() < 5e-4, "legacy {legacy}");
    }

    #[test]
    fn both_at_45_yaw_10_apart_matches_notes_table() {
        // Notes row "both at 45° yaw, 10° apart" (about the camera z axis, 1 m in front).
        let t = [0.0, 0.0, 1000.0];
        let (a, b) = (bx(rz(45.0), t, S), bx(rz(55.0), t, S));
        let legacy = iou(&a, &b, IouMethod::NocsLegacy);
        assert!((legacy - 0.906).abs() < 5e-4, "legacy {legacy}");
        let aabb = iou(&a, &b, IouMethod::Aabb);
        assert!((aabb - 0.892).abs() < 5e-4, "aabb {aabb}");
        // Exact: rotation about the shared z axis → 2D overlap of rectangles rotated 10°.
        let area = polygon_overlap_area_2d(200.0, 100.0, 10.0);
        let want = area / (2.0 * 200.0 * 100.0 - area);
        let exact = iou(&a, &b, IouMethod::Exact);
        assert!((exact - want).abs() < 1e-9, "exact {exact} want {want}");
        assert!((exact - 0.825).abs() < 5e-4, "exact {exact}");
    }

    #[test]
    fn identical_touching_disjoint_contained() {
        let r = Rotation3::from_euler_angles(0.4, -0.3, 1.2);
        let a = bx(r, [10.0, 20.0, 900.0], S);
        for m in IouMethod::ALL {
            assert!((iou(&a, &a, m) - 1.0).abs() < 1e-9, "{m}");
        }
        // Face to face along the box's own x axis: touching, volume 0.
        let t = a.center_mm + a.axis(0) * 200.0;
        let b = bx(r, [t.x, t.y, t.z], S);
        assert!(intersection_volume_mm3(&a, &b).abs() < 1e-3);
        let t = a.center_mm + a.axis(0) * 250.0;
        let c = bx(r, [t.x, t.y, t.z], S);
        assert_eq!(iou(&a, &c, IouMethod::Exact), 0.0);
        // Flush inner box sharing three faces with the outer one: volume ratio.
        let t = a.to_camera(&Vector3::new(50.0, 25.0, 75.0));
        let d = bx(r, [t.x, t.y, t.z], [100.0, 50.0, 150.0]);
        let want = 100.0 * 50.0 * 150.0 / (200.0 * 100.0 * 300.0);
        assert!((iou(&a, &d, IouMethod::Exact) - want).abs() < 1e-9);
        assert!((iou(&d, &a, IouMethod::Exact) - want).abs() < 1e-9);
    }

    #[test]
    fn half_overlap_along_each_axis_with_rotation() {
        let r = Rotation3::from_euler_angles(-0.9, 0.5, 2.0);
        let a = bx(r, [0.0, 0.0, 1000.0], S);
        for i in 0..3 {
            let t = a.center_mm + a.axis(i) * (S[i] / 2.0);
            let b = bx(r, [t.x, t.y, t.z], S);
            let v = intersection_volume_mm3(&a, &b);
            assert!((v - a.volume_mm3() / 2.0).abs() < 1e-6 * a.volume_mm3());
            assert!((iou(&a, &b, IouMethod::Exact) - 1.0 / 3.0).abs() < 1e-9);
        }
    }

    /// Overlap area of a `w × h` rectangle and the same rotated by `deg` about its centre,
    /// by clipping in 2D (independent of the 3D code path).
    fn polygon_overlap_area_2d(w: f64, h: f64, deg: f64) -> f64 {
        let rect = |rot: f64| -> Vec<[f64; 2]> {
            let (c, s) = (rot.cos(), rot.sin());
            [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]
                .iter()
                .map(|p| {
                    let (x, y) = (p[0] * w / 2.0, p[1] * h / 2.0);
                    [c * x - s * y, s * x + c * y]
                })
                .collect()
        };
        let mut poly = rect(0.0);
        let clipper = rect(deg.to_radians());
        for i in 0..4 {
            let (p, q) = (clipper[i], clipper[(i + 1) % 4]);
            // Inside = left of the ccw edge p→q.
            let side = |x: [f64; 2]| (q[0] - p[0]) * (x[1] - p[1]) - (q[1] - p[1]) * (x[0] - p[0]);
            let mut out = Vec::new();
            for j in 0..poly.len() {
                let (a, b) = (poly[j], poly[(j + 1) % poly.len()]);
                let (sa, sb) = (side(a), side(b));
                if (sa >= 0.0) != (sb >= 0.0) {
                    let t = sa / (sa - sb);
                    out.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
                }
                if sb >= 0.0 {
                    out.push(b);
                }
            }
            poly = out;
        }
        let n = poly.len();
        (0..n)
            .map(|i| poly[i][0] * poly[(i + 1) % n][1] - poly[(i + 1) % n][0] * poly[i][1])
            .sum::<f64>()
            .abs()
            / 2.0
    }
}
