//! Scene construction in a world frame (mm, z up, floor at z = 0): pallets of stacked touching
//! cartons, table-top piles with stacked, leaning boxes and distractors, shelves with occluding
//! boards (SPEC §5). The camera-independent part of a scene depends only on `(seed, scene)`.

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::shape::{Obb, Shape};
use crate::texture::{CartonTexture, Material};
use crate::Layout;

/// What a rendered primitive belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ObjKind {
    /// Ground-truth box number `i` of [`Scene::boxes`].
    GtBox(usize),
    /// Distractor object `i` (all parts of an irregular object share it).
    Distractor(u32),
    /// Floor, pallet, table, shelf: not an instance.
    Structure,
}

/// One renderable primitive.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WorldObject {
    pub shape: Shape,
    pub material: Material,
    pub kind: ObjKind,
}

/// A ground-truth box in the world frame.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PlacedBox {
    /// World pose; `half` = size / 2 with size quantised to 0.1 mm.
    pub obb: Obb,
    /// What it rests on: "floor" | "pallet" | "table" | "shelf" | "box".
    pub support: &'static str,
}

/// Which sensor a scene is shot with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CameraKind {
    /// Intel RealSense D435-like active stereo (colour-aligned depth, 640×480, f ≈ 615 px).
    RealSenseD435,
    /// Kinect-like (Azure Kinect NFOV intrinsics cropped to 640×480, f ≈ 504 px).
    KinectLike,
}

/// Ranges for camera placement around [`Scene::target`] (spherical coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ViewRange {
    pub dist_mm: (f64, f64),
    pub elev_deg: (f64, f64),
    pub azim_deg: (f64, f64),
    pub target_jitter_mm: f64,
}

/// A whole scene in world coordinates.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Scene {
    pub layout: Layout,
    pub objects: Vec<WorldObject>,
    pub boxes: Vec<PlacedBox>,
    pub distractors: u32,
    pub camera: CameraKind,
    pub target: Vector3<f64>,
    pub views: ViewRange,
    /// Direction *towards* the main light, world frame (unit).
    pub light_dir: Vector3<f64>,
}

/// Rounds to 0.1 mm so that equal sizes share an `obj_id`.
pub(crate) fn quantise_mm(x: f64) -> f64 {
    (x * 10.0).round() / 10.0
}

fn rz(yaw: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), yaw)
}

fn slab(center: Vector3<f64>, size: Vector3<f64>, material: Material) -> WorldObject {
    WorldObject {
        shape: Shape::Cuboid {
            rot: Matrix3::identity(),
            center,
            half: size * 0.5,
        },
        material,
        kind: ObjKind::Structure,
    }
}

/// Builds scene `scene_idx` for a concrete layout (not `Mixed`).
pub(crate) fn build_scene(layout: Layout, rng: &mut ChaCha8Rng, distractors: Option<u32>) -> Scene {
    let camera = if rng.random_bool(0.5) {
        CameraKind::RealSenseD435
    } else {
        CameraKind::KinectLike
    };
    let az = rng.random_range(0.0..std::f64::consts::TAU);
    let el = rng.random_range(35f64.to_radians()..70f64.to_radians());
    let light_dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let mut b = Builder {
        objects: vec![slab(
            Vector3::new(0.0, 0.0, -10.0),
            Vector3::new(40_000.0, 40_000.0, 20.0),
            Material::Concrete,
        )],
        boxes: Vec::new(),
        obstacles: Vec::new(),
        distractors: 0,
    };
    // Warehouse walls 7 m from the origin so that no pixel sees the void.
    let wall = Material::Solid([0.72, 0.72, 0.7]);
    for (c, s) in [
        (
            Vector3::new(7000.0, 0.0, 3000.0),
            Vector3::new(100.0, 14_000.0, 6000.0),
        ),
        (
            Vector3::new(-7000.0, 0.0, 3000.0),
            Vector3::new(100.0, 14_000.0, 6000.0),
        ),
        (
            Vector3::new(0.0, 7000.0, 3000.0),
            Vector3::new(14_000.0, 100.0, 6000.0),
        ),
        (
            Vector3::new(0.0, -7000.0, 3000.0),
            Vector3::new(14_000.0, 100.0, 6000.0),
        ),
        (
            Vector3::new(0.0, 0.0, 6050.0),
            Vector3::new(14_000.0, 14_000.0, 100.0),
        ),
    ] {
        b.objects.push(slab(c, s, wall.clone()));
    }
    let (target, views) = match layout {
        Layout::Pallet | Layout::Mixed => build_pallet(&mut b, rng, distractors.unwrap_or(0)),
        Layout::Table => {
            let n = distractors.unwrap_or_else(|| rng.random_range(0..=32));
            build_table(&mut b, rng, n)
        }
        Layout::Shelf => build_shelf(&mut b, rng, distractors.unwrap_or(0)),
    };
    Scene {
        layout,
        objects: b.objects,
        boxes: b.boxes,
        distractors: b.distractors,
        camera,
        target,
        views,
        light_dir,
    }
}

struct Builder {
    objects: Vec<WorldObject>,
    boxes: Vec<PlacedBox>,
    /// Solid volumes that new boxes/distractors must not enter (pallet, table top, legs, shelf).
    obstacles: Vec<Obb>,
    distractors: u32,
}

impl Builder {
    fn add_structure(&mut self, center: Vector3<f64>, size: Vector3<f64>, material: Material) {
        self.objects.push(slab(center, size, material));
        self.obstacles
            .push(Obb::new(Rotation3::identity(), center, size));
    }

    /// True when `o` is clear of every box, obstacle and distractor (exact contact allowed).
    fn is_free(&self, o: &Obb, skip_box: Option<usize>) -> bool {
        let touch = -0.05;
        self.boxes
            .iter()
            .enumerate()
            .all(|(i, pb)| Some(i) == skip_box || !pb.obb.overlaps(o, touch))
            && self.obstacles.iter().all(|ob| !ob.overlaps(o, touch))
    }

    fn add_box<R: Rng>(&mut self, rng: &mut R, obb: Obb, support: &'static str) {
        let tex = CartonTexture::random(rng, &obb.half);
        self.add_box_textured(obb, support, tex);
    }

    fn add_box_textured(&mut self, obb: Obb, support: &'static str, tex: CartonTexture) {
        let i = self.boxes.len();
        self.objects.push(WorldObject {
            shape: obb.shape(),
            material: Material::Carton(Box::new(tex)),
            kind: ObjKind::GtBox(i),
        });
        self.boxes.push(PlacedBox { obb, support });
    }

    /// Places up to `n` distractors resting on height `z0` inside the xy rectangle `[lo, hi]`.
    fn add_distractors<R: Rng>(
        &mut self,
        rng: &mut R,
        n: u32,
        z0: f64,
        lo: (f64, f64),
        hi: (f64, f64),
    ) {
        for _ in 0..n {
            let colour = [
                rng.random_range(0.05..0.95),
                rng.random_range(0.05..0.95),
                rng.random_range(0.05..0.95),
            ];
            let kind = rng.random_range(0..4u32);
            let parts: Vec<Shape> = match kind {
                0 => {
                    let r = rng.random_range(20.0..60.0);
                    vec![Shape::Sphere {
                        center: Vector3::new(0.0, 0.0, r),
                        radius: r,
                    }]
                }
                1 => {
                    let r = rng.random_range(20.0..50.0);
                    let h = rng.random_range(40.0..220.0);
                    vec![Shape::Cylinder {
                        center: Vector3::new(0.0, 0.0, h / 2.0),
                        axis: Vector3::z(),
                        radius: r,
                        half_len: h / 2.0,
                    }]
                }
                2 => {
                    let r = rng.random_range(15.0..45.0);
                    let len = rng.random_range(60.0..250.0);
                    let yaw: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                    vec![Shape::Cylinder {
                        center: Vector3::new(0.0, 0.0, r),
                        axis: Vector3::new(yaw.cos(), yaw.sin(), 0.0),
                        radius: r,
                        half_len: len / 2.0,
                    }]
                }
                _ => {
                    // Irregular: a cluster of 2–4 random ellipsoids.
                    let k = rng.random_range(2..=4);
                    let mut v: Vec<Shape> = (0..k)
                        .map(|_| {
                            let rot = Rotation3::from_euler_angles(
                                rng.random_range(-3.1..3.1),
                                rng.random_range(-3.1..3.1),
                                rng.random_range(-3.1..3.1),
                            );
                            Shape::Ellipsoid {
                                rot: *rot.matrix(),
                                center: Vector3::new(
                                    rng.random_range(-35.0..35.0),
                                    rng.random_range(-35.0..35.0),
                                    rng.random_range(0.0..40.0),
                                ),
                                radii: Vector3::new(
                                    rng.random_range(15.0..55.0),
                                    rng.random_range(15.0..45.0),
                                    rng.random_range(12.0..35.0),
                                ),
                            }
                        })
                        .collect();
                    let min_z = v.iter().map(|s| s.aabb().0.z).fold(f64::INFINITY, f64::min);
                    let lift = Vector3::new(0.0, 0.0, -min_z);
                    v = v
                        .iter()
                        .map(|s| s.transformed(&Matrix3::identity(), &lift))
                        .collect();
                    v
                }
            };
            // Bounding box of the object at the origin, for the free-space test.
            let (mut lo3, mut hi3) = (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            );
            for s in &parts {
                let (a, b) = s.aabb();
                lo3 = lo3.inf(&a);
                hi3 = hi3.sup(&b);
            }
            let size = hi3 - lo3;
            let mid = (lo3 + hi3) * 0.5;
            let mut placed = None;
            for _ in 0..60 {
                let x = rng.random_range(lo.0..hi.0.max(lo.0 + 1.0));
                let y = rng.random_range(lo.1..hi.1.max(lo.1 + 1.0));
                let off = Vector3::new(x, y, z0 + 0.01);
                let bb = Obb::new(Rotation3::identity(), mid + off, size);
                if self.is_free(&bb, None) {
                    placed = Some((off, bb));
                    break;
                }
            }
            let Some((off, bb)) = placed else {
                continue;
            };
            let id = self.distractors;
            for s in parts {
                self.objects.push(WorldObject {
                    shape: s.transformed(&Matrix3::identity(), &off),
                    material: Material::Solid(colour),
                    kind: ObjKind::Distractor(id),
                });
            }
            self.obstacles.push(bb);
            self.distractors += 1;
        }
    }
}

/// A box size with quantised extents, mm.
fn qsize(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(quantise_mm(x), quantise_mm(y), quantise_mm(z))
}

/// EUR pallet (1200 × 800 × 144 mm) centred at the origin, long side along x, loaded with layers
/// of touching cartons; a few loose cartons on the floor.
fn build_pallet(
    b: &mut Builder,
    rng: &mut ChaCha8Rng,
    n_distractors: u32,
) -> (Vector3<f64>, ViewRange) {
    let wood = Material::Wood([0.78, 0.64, 0.45]);
    let (pl, pw, ph) = (1200.0, 800.0, 144.0);
    for y in [-350.0, 0.0, 350.0] {
        b.add_structure(
            Vector3::new(0.0, y, 11.0),
            Vector3::new(pl, 100.0, 22.0),
            wood.clone(),
        );
        for x in [-527.5, 0.0, 527.5] {
            b.add_structure(
                Vector3::new(x, y, 61.0),
                Vector3::new(145.0, 100.0, 78.0),
                wood.clone(),
            );
        }
    }
    for x in [-527.5, 0.0, 527.5] {
        b.add_structure(
            Vector3::new(x, 0.0, 111.0),
            Vector3::new(145.0, pw, 22.0),
            wood.clone(),
        );
    }
    let deck = [
        (-327.5, 145.0),
        (-163.75, 100.0),
        (0.0, 145.0),
        (163.75, 100.0),
        (327.5, 145.0),
    ];
    for (y, w) in deck {
        b.add_structure(
            Vector3::new(0.0, y, 133.0),
            Vector3::new(pl, w, 22.0),
            wood.clone(),
        );
    }
    // Carton sizes: one or two per pallet.
    let n_sizes = rng.random_range(1..=2);
    let sizes: Vec<Vector3<f64>> = (0..n_sizes)
        .map(|_| {
            qsize(
                rng.random_range(250.0..600.0),
                rng.random_range(200.0..400.0),
                rng.random_range(150.0..400.0),
            )
        })
        .collect();
    // One product per size: cartons of the same size look identical (same print and label),
    // as on a real single-SKU pallet — the hard case for instance segmentation.
    let textures: Vec<CartonTexture> = sizes
        .iter()
        .map(|s| CartonTexture::random(rng, &(s * 0.5)))
        .collect();
    let interlock = rng.random_bool(0.5);
    let p_missing: f64 = rng.random_range(0.0..0.25);
    let max_layers = rng.random_range(1..=4);
    let mut z = ph;
    // Present boxes of the layer below, as world OBBs.
    let mut below: Vec<Obb> = Vec::new();
    let mut top_z = z;
    for layer in 0..max_layers {
        let si = rng.random_range(0..sizes.len());
        let s = sizes[si];
        // Interlocking layers turn the cartons by 90° (same model, footprint swapped).
        let turned = interlock && layer % 2 == 1;
        let (fx, fy) = if turned { (s.y, s.x) } else { (s.x, s.y) };
        if z + s.z > 1900.0 {
            break;
        }
        let nx = ((pl / fx).floor() as usize).max(1);
        let ny = ((pw / fy).floor() as usize).max(1);
        // Jitter that keeps neighbours touching: whole-layer shift and yaw, per-column shift
        // along y (columns slide along their shared faces).
        let layer_shift = Vector3::new(
            rng.random_range(-2.5..2.5),
            rng.random_range(-2.5..2.5),
            0.0,
        );
        let layer_yaw = rng.random_range(-2f64..2.0).to_radians();
        let rot = rz(layer_yaw);
        let col_shift: Vec<f64> = (0..nx).map(|_| rng.random_range(-2.5..2.5)).collect();
        let is_top = layer + 1 == max_layers;
        let p = if is_top {
            (p_missing * 2.0).min(0.6)
        } else {
            p_missing
        };
        let mut this_layer = Vec::new();
        for i in 0..nx {
            for j in 0..ny {
                let lx = (i as f64 + 0.5) * fx - nx as f64 * fx / 2.0;
                let ly = (j as f64 + 0.5) * fy - ny as f64 * fy / 2.0 + col_shift[i];
                let c = rot * Vector3::new(lx, ly, 0.0)
                    + layer_shift
                    + Vector3::new(0.0, 0.0, z + s.z / 2.0);
                let missing = rng.random::<f64>() < p;
                let supported = layer == 0
                    || below.iter().any(|o| {
                        let l = o.rot.tr_mul(&(c - o.center));
                        l.x.abs() <= o.half.x && l.y.abs() <= o.half.y
                    });
                if missing || !supported {
                    continue;
                }
                let box_rot = if turned {
                    rot * rz(std::f64::consts::FRAC_PI_2)
                } else {
                    rot
                };
                let obb = Obb::new(box_rot, c, s);
                this_layer.push(obb);
                let support = if layer == 0 { "pallet" } else { "box" };
                b.add_box_textured(obb, support, textures[si].clone());
            }
        }
        if this_layer.is_empty() {
            break;
        }
        top_z = z + s.z;
        z += s.z;
        below = this_layer;
    }
    if b.boxes.is_empty() {
        // Never leave a pallet empty: one carton in the middle.
        let s = sizes[0];
        let obb = Obb::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, ph + s.z / 2.0),
            s,
        );
        top_z = ph + s.z;
        b.add_box(rng, obb, "pallet");
    }
    // The load as an obstacle for floor boxes and distractors.
    b.obstacles.push(Obb::new(
        Rotation3::identity(),
        Vector3::new(0.0, 0.0, top_z / 2.0),
        Vector3::new(pl + 30.0, pw + 30.0, top_z),
    ));
    let n_floor = rng.random_range(0..=2);
    for _ in 0..n_floor {
        let s = qsize(
            rng.random_range(200.0..500.0),
            rng.random_range(150.0..400.0),
            rng.random_range(120.0..400.0),
        );
        for _ in 0..30 {
            let ang: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let r = rng.random_range(800.0..1300.0);
            let c = Vector3::new(r * ang.cos(), r * ang.sin(), s.z / 2.0);
            let obb = Obb::new(rz(rng.random_range(-0.6..0.6)), c, s);
            if b.is_free(&obb, None) {
                b.add_box(rng, obb, "floor");
                break;
            }
        }
    }
    b.add_distractors(
        rng,
        n_distractors,
        0.0,
        (-1500.0, -1300.0),
        (1500.0, 1300.0),
    );
    let target = Vector3::new(
        rng.random_range(-150.0..150.0),
        rng.random_range(-100.0..100.0),
        top_z * 0.5,
    );
    let views = ViewRange {
        dist_mm: (1200.0, 2500.0),
        elev_deg: (30.0, 70.0),
        azim_deg: (-180.0, 180.0),
        target_jitter_mm: 120.0,
    };
    (target, views)
}

/// A random carton size with every extent in `[lo, hi]` mm.
fn random_size(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Vector3<f64> {
    // Log-uniform so that small and large boxes are equally common.
    let mut f = || (rng.random_range(lo.ln()..hi.ln())).exp();
    let (a, b, c) = (f(), f(), f());
    qsize(a, b, c)
}

/// A table with a pile of 3–10 boxes (flat, touching, stacked, leaning up to ±45°) and distractors.
fn build_table(
    b: &mut Builder,
    rng: &mut ChaCha8Rng,
    n_distractors: u32,
) -> (Vector3<f64>, ViewRange) {
    let (tl, tw, th, tt) = (
        rng.random_range(1400.0..2000.0),
        rng.random_range(800.0..1000.0),
        750.0,
        30.0,
    );
    let top_mat = match rng.random_range(0..3) {
        0 => Material::Wood([0.72, 0.55, 0.36]),
        1 => Material::Solid([0.85, 0.85, 0.83]),
        _ => Material::Solid([0.35, 0.38, 0.42]),
    };
    b.add_structure(
        Vector3::new(0.0, 0.0, th - tt / 2.0),
        Vector3::new(tl, tw, tt),
        top_mat,
    );
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            b.add_structure(
                Vector3::new(
                    sx * (tl / 2.0 - 60.0),
                    sy * (tw / 2.0 - 60.0),
                    (th - tt) / 2.0,
                ),
                Vector3::new(50.0, 50.0, th - tt),
                Material::Solid([0.25, 0.25, 0.27]),
            );
        }
    }
    let wall = rng.random_bool(0.5);
    if wall {
        b.add_structure(
            Vector3::new(0.0, tw / 2.0 + 250.0, 1500.0),
            Vector3::new(8000.0, 40.0, 3000.0),
            Material::Solid([0.8, 0.78, 0.72]),
        );
    }
    let pile_r = rng.random_range(250.0..500.0);
    let pile_c = Vector3::new(
        rng.random_range(-(tl / 2.0 - pile_r - 100.0)..(tl / 2.0 - pile_r - 100.0)),
        rng.random_range(-(tw / 2.0 - pile_r).max(1.0)..(tw / 2.0 - pile_r).max(1.0)) * 0.3,
        th,
    );
    let n_boxes = rng.random_range(3..=10usize);
    let on_table = |o: &Obb| {
        let (lo, hi) = o.shape().aabb();
        lo.x >= -tl / 2.0 && hi.x <= tl / 2.0 && lo.y >= -tw / 2.0 && hi.y <= tw / 2.0
    };
    let mut attempts = 0;
    while b.boxes.len() < n_boxes && attempts < 400 {
        attempts += 1;
        let s = random_size(rng, 40.0, 400.0);
        // Keep most boxes comfortably visible: at least one extent of 90 mm or more.
        if s.max() < 90.0 {
            continue;
        }
        let flat: Vec<usize> = (0..b.boxes.len())
            .filter(|&i| b.boxes[i].support == "table" && b.boxes[i].obb.rot[(2, 2)].abs() > 0.999)
            .collect();
        let role = rng.random::<f64>();
        let candidate: Option<(Obb, &'static str, Option<usize>)> = if role < 0.2
            && !flat.is_empty()
        {
            // Stacked on top of a flat box, footprint within the lower box's top face.
            let base = b.boxes[flat[rng.random_range(0..flat.len())]].obb;
            // Never smaller than 40 mm, never wider than the box below.
            let s = qsize(
                s.x.min(base.half.x * 2.0 * rng.random_range(0.5..1.0))
                    .max(40.0)
                    .min(base.half.x * 2.0),
                s.y.min(base.half.y * 2.0 * rng.random_range(0.5..1.0))
                    .max(40.0)
                    .min(base.half.y * 2.0),
                s.z,
            );
            let rot = Rotation3::from_matrix_unchecked(base.rot) * rz(rng.random_range(-0.3..0.3));
            let ox = rng.random_range(-0.5..0.5) * (base.half.x * 2.0 - s.x).max(0.0);
            let oy = rng.random_range(-0.5..0.5) * (base.half.y * 2.0 - s.y).max(0.0);
            let c = base.center + base.rot * Vector3::new(ox, oy, 0.0);
            let c = Vector3::new(c.x, c.y, base.max_z() + s.z / 2.0);
            Some((Obb::new(rot, c, s), "box", None))
        } else if role < 0.4 && !flat.is_empty() {
            // Leaning: tilted 10–45° about its x axis, resting on the table, slid towards a flat
            // box until the two touch (bisection on the separating distance).
            let si = flat[rng.random_range(0..flat.len())];
            let sup = b.boxes[si].obb;
            let theta = rng.random_range(10f64..45.0).to_radians()
                * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let rot = rz(rng.random_range(0.0..std::f64::consts::TAU))
                * Rotation3::from_axis_angle(&Vector3::x_axis(), theta);
            let up = rot * Vector3::z();
            let lean = Vector3::new(up.x, up.y, 0.0).normalize();
            let zc = th + (rot.matrix().row(2).abs() * (s * 0.5))[0] + 0.01;
            let at = |d: f64| {
                let c = sup.center - lean * d;
                Obb::new(rot, Vector3::new(c.x, c.y, zc), s)
            };
            let (mut near, mut far) = (0.0, sup.half.norm() + s.norm() + 10.0);
            for _ in 0..50 {
                let mid = 0.5 * (near + far);
                if at(mid).overlaps(&sup, 0.0) {
                    near = mid;
                } else {
                    far = mid;
                }
            }
            Some((at(far + 0.02), "table", Some(si)))
        } else {
            // Flat on the table: touching a neighbour, or free in the pile area.
            let rot_perm = rng.random_range(0..3);
            let s = match rot_perm {
                0 => s,
                1 => Vector3::new(s.x, s.z, s.y),
                _ => Vector3::new(s.z, s.y, s.x),
            };
            if !flat.is_empty() && rng.random_bool(0.35) {
                let nb = b.boxes[flat[rng.random_range(0..flat.len())]].obb;
                let k = rng.random_range(0..2usize);
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let mut off = Vector3::zeros();
                off[k] = sign * (nb.half[k] + s[k] / 2.0);
                let other = 1 - k;
                off[other] = rng.random_range(-0.4..0.4) * (nb.half[other] * 2.0);
                let c = nb.center + nb.rot * off;
                let c = Vector3::new(c.x, c.y, th + s.z / 2.0);
                Some((
                    Obb::new(Rotation3::from_matrix_unchecked(nb.rot), c, s),
                    "table",
                    None,
                ))
            } else {
                let ang: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                let r = pile_r * rng.random::<f64>().sqrt();
                let c = pile_c + Vector3::new(r * ang.cos(), r * ang.sin(), s.z / 2.0);
                Some((
                    Obb::new(rz(rng.random_range(0.0..std::f64::consts::TAU)), c, s),
                    "table",
                    None,
                ))
            }
        };
        if let Some((obb, support, _)) = candidate {
            if on_table(&obb) && b.is_free(&obb, None) {
                b.add_box(rng, obb, support);
            }
        }
    }
    b.add_distractors(
        rng,
        n_distractors,
        th,
        (-tl / 2.0 + 40.0, -tw / 2.0 + 40.0),
        (tl / 2.0 - 40.0, tw / 2.0 - 40.0),
    );
    let views = ViewRange {
        dist_mm: (500.0 + pile_r * 0.5, 1500.0),
        elev_deg: (35.0, 75.0),
        azim_deg: if wall {
            (-160.0, -20.0)
        } else {
            (-180.0, 180.0)
        },
        target_jitter_mm: 60.0,
    };
    (pile_c + Vector3::new(0.0, 0.0, 80.0), views)
}

/// A shelf unit (front faces −y) with 3–4 boards holding rows of boxes; boards and uprights occlude.
fn build_shelf(
    b: &mut Builder,
    rng: &mut ChaCha8Rng,
    n_distractors: u32,
) -> (Vector3<f64>, ViewRange) {
    let w = rng.random_range(1200.0..1800.0);
    let d = rng.random_range(400.0..600.0);
    let levels = rng.random_range(3..=4usize);
    let spacing = rng.random_range(380.0..520.0);
    let (z0, bt) = (150.0, 25.0);
    let board_mat = Material::Solid([0.55, 0.56, 0.58]);
    let post_mat = Material::Solid([0.85, 0.45, 0.1]);
    let top = z0 + (levels - 1) as f64 * spacing;
    for k in 0..levels {
        let zt = z0 + k as f64 * spacing;
        b.add_structure(
            Vector3::new(0.0, 0.0, zt - bt / 2.0),
            Vector3::new(w, d, bt),
            board_mat.clone(),
        );
        // Front beam under each board.
        b.add_structure(
            Vector3::new(0.0, -d / 2.0 + 20.0, zt - bt - 35.0),
            Vector3::new(w, 40.0, 70.0),
            post_mat.clone(),
        );
    }
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            b.add_structure(
                Vector3::new(
                    sx * (w / 2.0 + 30.0),
                    sy * (d / 2.0 - 30.0),
                    (top + 60.0) / 2.0,
                ),
                Vector3::new(60.0, 60.0, top + 60.0),
                post_mat.clone(),
            );
        }
    }
    b.add_structure(
        Vector3::new(0.0, d / 2.0 + 10.0, (top + 60.0) / 2.0),
        Vector3::new(w + 120.0, 20.0, top + 60.0),
        Material::Solid([0.7, 0.7, 0.68]),
    );
    for k in 0..levels {
        let zt = z0 + k as f64 * spacing;
        let max_h = if k + 1 < levels {
            spacing - bt - 40.0
        } else {
            450.0
        };
        let mut x = -w / 2.0 + rng.random_range(5.0..80.0);
        loop {
            let s = qsize(
                rng.random_range(100.0..450.0),
                rng.random_range(120.0..(d - 20.0)),
                rng.random_range(80.0..max_h),
            );
            if x + s.x > w / 2.0 - 5.0 {
                break;
            }
            let yc = d / 2.0 - 5.0 - s.y / 2.0 - rng.random_range(0.0..(d - 10.0 - s.y).max(0.1));
            let c = Vector3::new(x + s.x / 2.0, yc, zt + s.z / 2.0 + 0.01);
            let yaw = if rng.random_bool(0.3) {
                rng.random_range(-0.12..0.12)
            } else {
                0.0
            };
            let obb = Obb::new(rz(yaw), c, s);
            if rng.random_bool(0.85) && b.is_free(&obb, None) {
                b.add_box(rng, obb, "shelf");
            }
            let gap = if rng.random_bool(0.35) {
                0.0
            } else {
                rng.random_range(10.0..150.0)
            };
            x += s.x + gap;
        }
    }
    if b.boxes.is_empty() {
        let s = qsize(300.0, 250.0, 200.0);
        let obb = Obb::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, z0 + s.z / 2.0 + 0.01),
            s,
        );
        b.add_box(rng, obb, "shelf");
    }
    b.add_distractors(
        rng,
        n_distractors,
        0.0,
        (-w / 2.0, -d / 2.0 - 900.0),
        (w / 2.0, -d / 2.0 - 150.0),
    );
    let target = Vector3::new(
        rng.random_range(-w / 4.0..w / 4.0),
        0.0,
        rng.random_range(z0..top),
    );
    let views = ViewRange {
        dist_mm: (1000.0, 2000.0),
        elev_deg: (-10.0, 30.0),
        azim_deg: (-125.0, -55.0),
        target_jitter_mm: 100.0,
    };
    (target, views)
}
