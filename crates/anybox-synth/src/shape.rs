//! Analytic primitives of the ray caster: oriented cuboids (slab test), spheres, capped
//! cylinders and ellipsoids; their rigid transforms, bounding boxes and an OBB–OBB overlap test
//! used to keep generated scenes free of interpenetration.
//!
//! All lengths in mm. A ray starts at the camera centre (origin) with direction
//! `d = ((u − cx)/fx, (v − cy)/fy, 1)`, so the ray parameter `t` of a hit *is* its depth `z`.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// A solid primitive in some frame (world or camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Shape {
    /// Oriented box: `rot` maps box frame → this frame, `half` are half extents.
    Cuboid {
        rot: Matrix3<f64>,
        center: Vector3<f64>,
        half: Vector3<f64>,
    },
    /// Sphere.
    Sphere { center: Vector3<f64>, radius: f64 },
    /// Capped cylinder along unit `axis`, total length `2 · half_len`.
    Cylinder {
        center: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        half_len: f64,
    },
    /// Ellipsoid with semi-axes `radii` along the columns of `rot`.
    Ellipsoid {
        rot: Matrix3<f64>,
        center: Vector3<f64>,
        radii: Vector3<f64>,
    },
}

/// A ray hit: parameter (= depth z when `d.z = 1`), outward unit normal, and for cuboids the
/// hit point in box coordinates plus the entered face axis.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Hit {
    pub t: f64,
    pub normal: Vector3<f64>,
    /// Hit point in the primitive's own frame (cuboids: box frame), mm.
    pub local: Vector3<f64>,
    /// Cuboids: face axis 0..3; others: 3.
    pub face_axis: usize,
}

impl Shape {
    /// The same shape after the rigid transform `p ↦ r · p + t`.
    pub(crate) fn transformed(&self, r: &Matrix3<f64>, t: &Vector3<f64>) -> Shape {
        match *self {
            Shape::Cuboid { rot, center, half } => Shape::Cuboid {
                rot: r * rot,
                center: r * center + t,
                half,
            },
            Shape::Sphere { center, radius } => Shape::Sphere {
                center: r * center + t,
                radius,
            },
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_len,
            } => Shape::Cylinder {
                center: r * center + t,
                axis: r * axis,
                radius,
                half_len,
            },
            Shape::Ellipsoid { rot, center, radii } => Shape::Ellipsoid {
                rot: r * rot,
                center: r * center + t,
                radii,
            },
        }
    }

    /// Axis-aligned bounding box `(min, max)` in this shape's frame, mm.
    pub(crate) fn aabb(&self) -> (Vector3<f64>, Vector3<f64>) {
        let (c, e) = match *self {
            Shape::Cuboid { rot, center, half } => (center, rot.abs() * half),
            Shape::Sphere { center, radius } => (center, Vector3::repeat(radius)),
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_len,
            } => {
                let e = Vector3::from_fn(|i, _| {
                    half_len * axis[i].abs() + radius * (1.0 - axis[i] * axis[i]).max(0.0).sqrt()
                });
                (center, e)
            }
            Shape::Ellipsoid { rot, center, radii } => {
                let e = Vector3::from_fn(|i, _| {
                    (0..3)
                        .map(|j| (rot[(i, j)] * radii[j]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                });
                (center, e)
            }
        };
        (c - e, c + e)
    }

    /// Nearest intersection with `t > 0` of the ray `o + t·d` (o = origin), or `None`.
    ///
    /// `o_local` must be [`Shape::local_origin`] of this shape (precomputed once per frame).
    #[inline]
    pub(crate) fn intersect(&self, o_local: &Vector3<f64>, d: &Vector3<f64>) -> Option<Hit> {
        match *self {
            Shape::Cuboid { rot, half, .. } => {
                let dl = rot.tr_mul(d);
                let mut t_near = f64::NEG_INFINITY;
                let mut t_far = f64::INFINITY;
                let mut axis = 0usize;
                for i in 0..3 {
                    if dl[i].abs() < 1e-15 {
                        if o_local[i].abs() > half[i] {
                            return None;
                        }
                        continue;
                    }
                    let inv = 1.0 / dl[i];
                    let mut t1 = (-half[i] - o_local[i]) * inv;
                    let mut t2 = (half[i] - o_local[i]) * inv;
                    if t1 > t2 {
                        std::mem::swap(&mut t1, &mut t2);
                    }
                    if t1 > t_near {
                        t_near = t1;
                        axis = i;
                    }
                    t_far = t_far.min(t2);
                }
                if t_near > t_far || t_near <= 0.0 {
                    return None;
                }
                let mut nl = Vector3::zeros();
                nl[axis] = if dl[axis] > 0.0 { -1.0 } else { 1.0 };
                Some(Hit {
                    t: t_near,
                    normal: rot * nl,
                    local: o_local + dl * t_near,
                    face_axis: axis,
                })
            }
            Shape::Sphere { center, radius } => {
                let t = sphere_t(&(-center), d, radius)?;
                let p = d * t;
                Some(Hit {
                    t,
                    normal: (p - center) / radius,
                    local: p - center,
                    face_axis: 3,
                })
            }
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_len,
            } => {
                let o = -center;
                let da = d.dot(&axis);
                let oa = o.dot(&axis);
                let dp = d - axis * da;
                let op = o - axis * oa;
                let mut best: Option<(f64, Vector3<f64>)> = None;
                let a = dp.norm_squared();
                if a > 1e-18 {
                    let b = 2.0 * dp.dot(&op);
                    let c = op.norm_squared() - radius * radius;
                    let disc = b * b - 4.0 * a * c;
                    if disc >= 0.0 {
                        let t = (-b - disc.sqrt()) / (2.0 * a);
                        if t > 0.0 && (oa + t * da).abs() <= half_len {
                            best = Some((t, (op + dp * t) / radius));
                        }
                    }
                }
                if da.abs() > 1e-15 {
                    for s in [-1.0, 1.0] {
                        let t = (s * half_len - oa) / da;
                        if t > 0.0
                            && (op + dp * t).norm_squared() <= radius * radius
                            && best.is_none_or(|(bt, _)| t < bt)
                        {
                            best = Some((t, axis * s));
                        }
                    }
                }
                best.map(|(t, n)| Hit {
                    t,
                    normal: n,
                    local: d * t - center,
                    face_axis: 3,
                })
            }
            Shape::Ellipsoid { rot, radii, .. } => {
                let dl = rot.tr_mul(d).component_div(&radii);
                let ol = o_local.component_div(&radii);
                let t = sphere_t(&ol, &dl, 1.0)?;
                let q = ol + dl * t;
                let nl = q.component_div(&radii).normalize();
                Some(Hit {
                    t,
                    normal: rot * nl,
                    local: q.component_mul(&radii),
                    face_axis: 3,
                })
            }
        }
    }

    /// The ray origin (camera centre, 0) in the shape's local frame, as [`Shape::intersect`] needs.
    pub(crate) fn local_origin(&self) -> Vector3<f64> {
        match *self {
            Shape::Cuboid { rot, center, .. } | Shape::Ellipsoid { rot, center, .. } => {
                rot.tr_mul(&(-center))
            }
            Shape::Sphere { center, .. } | Shape::Cylinder { center, .. } => -center,
        }
    }
}

/// Smallest positive root of `|o + t·d|² = r²`.
#[inline]
fn sphere_t(o: &Vector3<f64>, d: &Vector3<f64>, r: f64) -> Option<f64> {
    let a = d.norm_squared();
    let b = 2.0 * o.dot(d);
    let c = o.norm_squared() - r * r;
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let t0 = (-b - sq) / (2.0 * a);
    if t0 > 0.0 {
        return Some(t0);
    }
    let t1 = (-b + sq) / (2.0 * a);
    (t1 > 0.0).then_some(t1)
}

/// An oriented box for overlap tests: rotation columns = axes, centre, half extents (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Obb {
    pub rot: Matrix3<f64>,
    pub center: Vector3<f64>,
    pub half: Vector3<f64>,
}

impl Obb {
    /// Builds from a rotation, centre and full size.
    pub(crate) fn new(rot: Rotation3<f64>, center: Vector3<f64>, size: Vector3<f64>) -> Obb {
        Obb {
            rot: *rot.matrix(),
            center,
            half: size * 0.5,
        }
    }

    /// Highest z of the box, mm.
    pub(crate) fn max_z(&self) -> f64 {
        self.center.z + (self.rot.row(2).abs() * self.half)[0]
    }

    /// True when the two boxes, each grown by `margin` mm on every side, overlap
    /// (separating-axis test over the 15 candidate axes; Gottschalk et al. 1996).
    pub(crate) fn overlaps(&self, other: &Obb, margin: f64) -> bool {
        let a = &self.rot;
        let b = &other.rot;
        let ha = self.half.add_scalar(margin);
        let hb = other.half.add_scalar(margin);
        let d = other.center - self.center;
        let mut axes: Vec<Vector3<f64>> = Vec::with_capacity(15);
        for i in 0..3 {
            axes.push(a.column(i).into_owned());
            axes.push(b.column(i).into_owned());
        }
        for i in 0..3 {
            for j in 0..3 {
                let c = a.column(i).cross(&b.column(j));
                if c.norm_squared() > 1e-12 {
                    axes.push(c.normalize());
                }
            }
        }
        for ax in axes {
            let ra: f64 = (0..3).map(|i| ha[i] * a.column(i).dot(&ax).abs()).sum();
            let rb: f64 = (0..3).map(|i| hb[i] * b.column(i).dot(&ax).abs()).sum();
            if d.dot(&ax).abs() > ra + rb {
                return false;
            }
        }
        true
    }

    /// As a renderable shape.
    pub(crate) fn shape(&self) -> Shape {
        Shape::Cuboid {
            rot: self.rot,
            center: self.center,
            half: self.half,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam_ray(x: f64, y: f64) -> Vector3<f64> {
        Vector3::new(x, y, 1.0)
    }

    #[test]
    fn cuboid_hit_matches_plane() {
        let s = Shape::Cuboid {
            rot: Matrix3::identity(),
            center: Vector3::new(0.0, 0.0, 1000.0),
            half: Vector3::new(100.0, 100.0, 50.0),
        };
        let o = s.local_origin();
        let h = s.intersect(&o, &cam_ray(0.05, -0.02)).unwrap();
        assert!((h.t - 950.0).abs() < 1e-9);
        assert!((h.normal - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        assert!(s.intersect(&o, &cam_ray(0.2, 0.0)).is_none());
    }

    #[test]
    fn sphere_and_cylinder_hits() {
        let s = Shape::Sphere {
            center: Vector3::new(0.0, 0.0, 1000.0),
            radius: 100.0,
        };
        let h = s.intersect(&s.local_origin(), &cam_ray(0.0, 0.0)).unwrap();
        assert!((h.t - 900.0).abs() < 1e-9);
        let c = Shape::Cylinder {
            center: Vector3::new(0.0, 0.0, 1000.0),
            axis: Vector3::new(0.0, 1.0, 0.0),
            radius: 50.0,
            half_len: 100.0,
        };
        let h = c.intersect(&c.local_origin(), &cam_ray(0.0, 0.0)).unwrap();
        assert!((h.t - 950.0).abs() < 1e-9);
        // Cap seen end-on.
        let c2 = Shape::Cylinder {
            center: Vector3::new(0.0, 0.0, 1000.0),
            axis: Vector3::new(0.0, 0.0, 1.0),
            radius: 50.0,
            half_len: 100.0,
        };
        let h = c2
            .intersect(&c2.local_origin(), &cam_ray(0.01, 0.0))
            .unwrap();
        assert!((h.t - 900.0).abs() < 1e-9);
        let e = Shape::Ellipsoid {
            rot: Matrix3::identity(),
            center: Vector3::new(0.0, 0.0, 1000.0),
            radii: Vector3::new(10.0, 20.0, 30.0),
        };
        let h = e.intersect(&e.local_origin(), &cam_ray(0.0, 0.0)).unwrap();
        assert!((h.t - 970.0).abs() < 1e-9);
    }

    #[test]
    fn obb_overlap_separation() {
        let r = Rotation3::identity();
        let a = Obb::new(r, Vector3::zeros(), Vector3::new(100.0, 100.0, 100.0));
        let b = Obb::new(
            r,
            Vector3::new(100.5, 0.0, 0.0),
            Vector3::new(100.0, 100.0, 100.0),
        );
        assert!(!a.overlaps(&b, 0.0));
        assert!(a.overlaps(&b, 0.5));
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4);
        let c = Obb::new(
            rz,
            Vector3::new(115.0, 0.0, 0.0),
            Vector3::new(100.0, 100.0, 100.0),
        );
        // Rotated 45°: reaches 70.7 mm from its centre, so it overlaps at 115 mm but not at 125.
        assert!(a.overlaps(&c, 0.0));
        let c2 = Obb::new(
            rz,
            Vector3::new(125.0, 0.0, 0.0),
            Vector3::new(100.0, 100.0, 100.0),
        );
        assert!(!a.overlaps(&c2, 0.0));
    }
}
