//! CPU ray caster: one primary ray per pixel centre, nearest hit over the scene's primitives.
//!
//! In: primitives in the camera frame (OpenCV, mm), intrinsics, image size, light direction.
//! Out: exact depth `z` (mm, along the optical axis), instance id, cosine of the incidence angle
//! and a shaded RGB image per pixel, plus for every ground-truth box the number of pixels its
//! silhouette covers when rendered alone (`px_count_all`, counted on a canvas three times the
//! image size as bop_toolkit's `calc_gt_info` does, so that truncation lowers `visib_fract`).
//!
//! Speed: each primitive's screen rectangle (projected camera-frame AABB) is computed once and
//! bucketed by row, so a pixel only tests the primitives whose rectangle covers it. Rows render
//! in parallel (rayon); nothing random happens here, so the result does not depend on threads.

use anybox_geom::Intrinsics;
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::scene::ObjKind;
use crate::shape::Shape;
use crate::texture::Material;

/// Instance id of pixels that hit nothing.
pub(crate) const NO_HIT: u32 = u32::MAX;
/// Instance ids of distractors start here (ground-truth boxes use their index).
pub(crate) const DISTRACTOR_BASE: u32 = 0x4000_0000;
/// Instance id of structure (floor, pallet, table, shelf).
pub(crate) const STRUCTURE: u32 = 0x8000_0000;

/// A primitive in the camera frame with its precomputed ray-origin in local coordinates.
pub(crate) struct CamObject<'a> {
    pub shape: Shape,
    pub material: &'a Material,
    pub kind: ObjKind,
    o_local: Vector3<f64>,
    /// Inclusive pixel rectangle `[u0, u1] × [v0, v1]` (may extend beyond the image).
    rect: [i64; 4],
}

impl<'a> CamObject<'a> {
    /// Prepares a camera-frame primitive for rendering with intrinsics `k`.
    pub(crate) fn new(shape: Shape, material: &'a Material, kind: ObjKind, k: &Intrinsics) -> Self {
        let (lo, hi) = shape.aabb();
        let rect = if hi.z < 1.0 {
            // Entirely behind the camera: never visible.
            [i64::MAX / 4, i64::MIN / 4, i64::MAX / 4, i64::MIN / 4]
        } else if lo.z < 1.0 {
            // Reaches behind the camera: no finite projected bound; test it everywhere.
            [i64::MIN / 4, i64::MAX / 4, i64::MIN / 4, i64::MAX / 4]
        } else {
            let mut r = [i64::MAX, i64::MIN, i64::MAX, i64::MIN];
            for i in 0..8 {
                let p = Vector3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let u = k.fx * p.x / p.z + k.cx;
                let v = k.fy * p.y / p.z + k.cy;
                r[0] = r[0].min(u.floor() as i64);
                r[1] = r[1].max(u.ceil() as i64);
                r[2] = r[2].min(v.floor() as i64);
                r[3] = r[3].max(v.ceil() as i64);
            }
            r
        };
        CamObject {
            o_local: shape.local_origin(),
            shape,
            material,
            kind,
            rect,
        }
    }
}

/// Everything a frame render produces (row-major, `width × height`).
pub(crate) struct RenderOut {
    /// Exact depth along the optical axis, mm; 0 where nothing was hit.
    pub depth_mm: Vec<f64>,
    /// Instance id per pixel: GT box index, `DISTRACTOR_BASE + i`, `STRUCTURE` or `NO_HIT`.
    pub inst: Vec<u32>,
    /// `|cos|` of the angle between the viewing ray and the surface normal.
    pub cos_inc: Vec<f32>,
    /// Shaded colour, RGB8 interleaved.
    pub rgb: Vec<u8>,
    /// Per GT box: pixels of its silhouette when rendered alone (3× canvas).
    pub px_all: Vec<u64>,
    /// Per GT box: bounding box `[u0, v0, u1, v1]` (inclusive) of its full silhouette on the
    /// 3× canvas; `None` when it covers no pixel centre.
    pub sil_bbox: Vec<Option<[i64; 4]>>,
    /// In-image silhouette pixels `(pixel index, GT box)` of every GT box rendered alone.
    pub sil_pixels: Vec<(u32, u32)>,
}

/// Renders the frame.
pub(crate) fn render(
    objects: &[CamObject<'_>],
    n_gt: usize,
    k: &Intrinsics,
    width: u32,
    height: u32,
    light_cam: &Vector3<f64>,
) -> RenderOut {
    let (w, h) = (width as i64, height as i64);
    // Row buckets of candidate primitives.
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); height as usize];
    for (i, o) in objects.iter().enumerate() {
        if o.rect[1] < 0 || o.rect[0] >= w || o.rect[3] < 0 || o.rect[2] >= h {
            continue;
        }
        let v0 = o.rect[2].max(0) as usize;
        let v1 = o.rect[3].min(h - 1) as usize;
        for row in &mut rows[v0..=v1] {
            row.push(i as u32);
        }
    }
    struct Row {
        depth: Vec<f64>,
        inst: Vec<u32>,
        cos: Vec<f32>,
        rgb: Vec<u8>,
        all: Vec<u64>,
        sil: Vec<(u32, u32)>,
    }
    let rendered: Vec<Row> = (0..height as usize)
        .into_par_iter()
        .map(|v| {
            let mut r = Row {
                depth: vec![0.0; width as usize],
                inst: vec![NO_HIT; width as usize],
                cos: vec![0.0; width as usize],
                rgb: vec![0; 3 * width as usize],
                all: vec![0; n_gt],
                sil: Vec::new(),
            };
            let cands = &rows[v];
            for u in 0..width as usize {
                let d = Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0);
                let mut best: Option<(f64, usize, crate::shape::Hit)> = None;
                for &ci in cands {
                    let o = &objects[ci as usize];
                    let ui = u as i64;
                    if ui < o.rect[0] || ui > o.rect[1] {
                        continue;
                    }
                    if let Some(hit) = o.shape.intersect(&o.o_local, &d) {
                        if let ObjKind::GtBox(g) = o.kind {
                            if let Some(c) = r.all.get_mut(g) {
                                *c += 1;
                            }
                            r.sil.push(((v * width as usize + u) as u32, g as u32));
                        }
                        if best.as_ref().is_none_or(|b| hit.t < b.0) {
                            best = Some((hit.t, ci as usize, hit));
                        }
                    }
                }
                if let Some((t, oi, hit)) = best {
                    let o = &objects[oi];
                    r.depth[u] = t;
                    r.inst[u] = match o.kind {
                        ObjKind::GtBox(g) => g as u32,
                        ObjKind::Distractor(j) => DISTRACTOR_BASE + j,
                        ObjKind::Structure => STRUCTURE,
                    };
                    let dn = d.normalize();
                    let cos = hit.normal.dot(&dn).abs();
                    r.cos[u] = cos as f32;
                    let half = match o.shape {
                        Shape::Cuboid { half, .. } => half,
                        _ => Vector3::zeros(),
                    };
                    let albedo = o.material.albedo(&hit.local, hit.face_axis, &half);
                    // Lambertian key light + ambient + a weak headlight (sensor's IR/flash).
                    let shade = 0.28 + 0.6 * hit.normal.dot(light_cam).max(0.0) + 0.17 * cos;
                    for c in 0..3 {
                        r.rgb[3 * u + c] =
                            (albedo[c] * shade * 255.0).round().clamp(0.0, 255.0) as u8;
                    }
                }
            }
            r
        })
        .collect();
    let mut out = RenderOut {
        depth_mm: Vec::with_capacity((w * h) as usize),
        inst: Vec::with_capacity((w * h) as usize),
        cos_inc: Vec::with_capacity((w * h) as usize),
        rgb: Vec::with_capacity((3 * w * h) as usize),
        px_all: vec![0; n_gt],
        sil_bbox: vec![None; n_gt],
        sil_pixels: Vec::new(),
    };
    for r in rendered {
        out.sil_pixels.extend_from_slice(&r.sil);
        out.depth_mm.extend_from_slice(&r.depth);
        out.inst.extend_from_slice(&r.inst);
        out.cos_inc.extend_from_slice(&r.cos);
        out.rgb.extend_from_slice(&r.rgb);
        for (a, b) in out.px_all.iter_mut().zip(&r.all) {
            *a += b;
        }
    }
    // Silhouette pixels outside the image, on a canvas extended by one image size on each side.
    for o in objects {
        let ObjKind::GtBox(g) = o.kind else { continue };
        let u0 = o.rect[0].max(-w);
        let u1 = o.rect[1].min(2 * w - 1);
        let v0 = o.rect[2].max(-h);
        let v1 = o.rect[3].min(2 * h - 1);
        let mut extra = 0u64;
        let mut bb: Option<[i64; 4]> = None;
        for v in v0..=v1 {
            for u in u0..=u1 {
                let inside = (0..w).contains(&u) && (0..h).contains(&v);
                let hit = if inside {
                    // Already counted; only needed for the bounding box.
                    out.inst.len() > (v * w + u) as usize && {
                        let d =
                            Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0);
                        o.shape.intersect(&o.o_local, &d).is_some()
                    }
                } else {
                    let d = Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0);
                    let hit = o.shape.intersect(&o.o_local, &d).is_some();
                    if hit {
                        extra += 1;
                    }
                    hit
                };
                if hit {
                    bb = Some(match bb {
                        None => [u, v, u, v],
                        Some([a, b, c, e]) => [a.min(u), b.min(v), c.max(u), e.max(v)],
                    });
                }
            }
        }
        if let Some(c) = out.px_all.get_mut(g) {
            *c += extra;
        }
        if let Some(slot) = out.sil_bbox.get_mut(g) {
            *slot = bb;
        }
    }
    out
}
