//! Synthetic warehouse-like RGB-D scenes in BOP layout (SPEC §5) — anybox's benchmark.
//!
//! In: a [`SynthConfig`] (layout, number of scenes and views, distractors, seed, noise model,
//! image size). Out: [`SynthView`]s in memory ([`generate_view`], [`generate_views`]) or a BOP
//! dataset on disk ([`write_dataset`], via `anybox_io::bop::DatasetWriter`).
//!
//! What a scene contains (world frame: mm, z up, floor at z = 0):
//! - **pallet**: an EUR pallet with 1–4 layers of touching cartons of one or two sizes, some
//!   missing, jittered by ≤ 5 mm / ≤ 2° in ways that keep neighbours touching; a few loose cartons
//!   on the floor; camera 1.2–2.5 m away looking down at 30–70°.
//! - **table**: a table with 3–10 boxes of 40–400 mm — flat, touching, stacked on boxes, leaning
//!   10–45° against another box — and 0–32 distractors (spheres, cylinders, irregular ellipsoid
//!   clusters); camera 0.5–1.5 m, 35–75° down.
//! - **shelf**: boards, front beams and uprights that occlude rows of boxes; front view −10…30°.
//! - **mixed**: pallet, table, shelf by `scene % 3`.
//!
//! Each scene is shot with one of two cameras (RealSense D435-like, f ≈ 615 px; Kinect-like with
//! Azure Kinect NFOV intrinsics, f ≈ 504 px), rendered by an exact CPU ray caster
//! (`render`), textured procedurally (cardboard, tape, labels, print) and passed
//! through a documented depth-sensor model (`noise` module). Ground truth is exact: the visible
//! mask of a box is the set of pixels whose nearest hit is that box (before noise); `px_count_all`
//! counts its silhouette rendered alone on a 3× canvas (bop_toolkit's convention), so
//! `visib_fract` accounts for both occlusion and truncation; `px_count_valid` (BOP's definition)
//! counts in-image silhouette pixels with valid depth after noise.
//!
//! Files written by [`write_dataset`]: the BOP layout of SPEC §3 under split [`SPLIT`]
//! (`models_info.json`, `rgb/`, `depth/` as uint16 mm with `depth_scale` 1.0, `mask_visib/`,
//! `scene_camera.json`, `scene_gt.json`, `scene_gt_info.json`), plus per scene
//! `scene_meta.json` (layout, camera, distractor count, supports, and per view the camera pose in
//! the world frame). Costs (release, 2 cores): ≈ 0.1–0.2 s per 640×480 view; each in-memory
//! view holds one full-size mask per visible box, so [`generate_views`] on a large config needs
//! memory in proportion — prefer [`generate_view`] in a loop or [`write_dataset`].
//!
//! Determinism: the scene depends on `(seed, scene)`, the camera on `(seed, scene, view)`,
//! per-pixel noise on counter-based hashes; the same config gives the same bytes.
//! Each distinct box size (quantised to 0.1 mm) gets its own `obj_id`, numbered in order of first
//! appearance over scenes 0, 1, …, so ids agree between [`generate_view`] and [`write_dataset`].

mod noise;
mod render;
mod rng;
mod scene;
mod shape;
mod texture;

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;

use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::bop::{DatasetWriter, GtRecordOut, ModelInfo, ViewRecord};
use anybox_io::{DepthMap, IoError, Mask, RgbImage};
use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use noise::{D435_BASELINE_MM, D435_DEPTH_FOCAL_PX, D435_SUBPIXEL_PX};

/// Axial depth-noise σ (mm) of the RealSense D435-like camera at depth `z_mm` (Intel's RMS
/// formula, see the `noise` module).
pub fn realsense_sigma_mm(z_mm: f64) -> f64 {
    noise::axial_sigma_mm(CameraKind::RealSenseD435, z_mm, 0.0)
}

/// Axial depth-noise σ (mm) of the Kinect-like camera at depth `z_mm` and incidence angle
/// `theta_rad` (Nguyen, Izadi & Lovell 2012, see the `noise` module).
pub fn kinect_like_sigma_mm(z_mm: f64, theta_rad: f64) -> f64 {
    noise::axial_sigma_mm(CameraKind::KinectLike, z_mm, theta_rad)
}

use crate::render::CamObject;
use crate::rng::{hash3, purpose, stream};
use crate::scene::{CameraKind, Scene};

/// Scene layout (SPEC §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// Pallet of stacked, touching cartons.
    Pallet,
    /// Table-top pile with leaning/stacked boxes and distractors.
    Table,
    /// Shelf unit with occluding boards.
    Shelf,
    /// Pallet, table, shelf in turn by scene index.
    Mixed,
}

impl Layout {
    /// The concrete layout of scene `scene_idx` (resolves `Mixed`).
    pub fn for_scene(self, scene_idx: u32) -> Layout {
        match self {
            Layout::Mixed => {
                [Layout::Pallet, Layout::Table, Layout::Shelf][(scene_idx % 3) as usize]
            }
            l => l,
        }
    }

    /// Lower-case name as in the CLI and `scene_meta.json`.
    pub fn name(self) -> &'static str {
        match self {
            Layout::Pallet => "pallet",
            Layout::Table => "table",
            Layout::Shelf => "shelf",
            Layout::Mixed => "mixed",
        }
    }
}

impl fmt::Display for Layout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Layout {
    type Err = SynthError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "pallet" => Ok(Layout::Pallet),
            "table" => Ok(Layout::Table),
            "shelf" => Ok(Layout::Shelf),
            "mixed" => Ok(Layout::Mixed),
            _ => Err(SynthError::InvalidConfig(format!(
                "unknown layout {s:?}; expected pallet|table|shelf|mixed"
            ))),
        }
    }
}

/// Depth-sensor model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NoiseModel {
    /// Exact rendered depth (rounded to 1 mm only when written to PNG); clean RGB.
    None,
    /// Axial noise σ(z) ∝ z², 1 mm quantisation, edge/grazing dropouts, flying pixels, holes,
    /// stereo shadows, working range; RGB sensor noise (see the `noise` module for sources).
    Realistic,
}

impl fmt::Display for NoiseModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NoiseModel::None => "none",
            NoiseModel::Realistic => "realistic",
        })
    }
}

impl FromStr for NoiseModel {
    type Err = SynthError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "none" => Ok(NoiseModel::None),
            "realistic" => Ok(NoiseModel::Realistic),
            _ => Err(SynthError::InvalidConfig(format!(
                "unknown noise model {s:?}; expected none|realistic"
            ))),
        }
    }
}

/// Generator settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SynthConfig {
    /// Scene layout.
    pub layout: Layout,
    /// Number of scenes.
    pub scenes: u32,
    /// Views (camera poses) per scene.
    pub views: u32,
    /// Distractor objects per scene; `None` = random 0..=32 on tables, none elsewhere.
    pub distractors: Option<u32>,
    /// Master seed.
    pub seed: u64,
    /// Depth-sensor model.
    pub noise: NoiseModel,
    /// Image width, px (intrinsics scale with width / 640).
    pub width: u32,
    /// Image height, px.
    pub height: u32,
}

impl Default for SynthConfig {
    fn default() -> Self {
        Self {
            layout: Layout::Mixed,
            scenes: 4,
            views: 2,
            distractors: None,
            seed: 0,
            noise: NoiseModel::Realistic,
            width: 640,
            height: 480,
        }
    }
}

impl SynthConfig {
    /// Checks sizes and counts.
    pub fn validate(&self) -> Result<(), SynthError> {
        if !(16..=8192).contains(&self.width) || !(16..=8192).contains(&self.height) {
            return Err(SynthError::InvalidConfig(format!(
                "image size {}x{} px out of range 16..=8192",
                self.width, self.height
            )));
        }
        if self.scenes == 0 || self.views == 0 {
            return Err(SynthError::InvalidConfig(format!(
                "scenes ({}) and views ({}) must be at least 1",
                self.scenes, self.views
            )));
        }
        if self.distractors.is_some_and(|n| n > 256) {
            return Err(SynthError::InvalidConfig(
                "at most 256 distractors per scene".to_string(),
            ));
        }
        Ok(())
    }
}

/// Errors of the generator.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// A configuration value is out of range.
    #[error("invalid synth configuration: {0}")]
    InvalidConfig(String),
    /// Writing the dataset failed.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// One ground-truth box of a view.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthBox {
    /// Model id (one per distinct size, dataset-wide).
    pub obj_id: u32,
    /// Box in the camera frame (centre, size in mm).
    pub pose: OrientedBox,
    /// Exact visible mask (pixels whose nearest surface is this box, before sensor noise).
    pub mask_visib: Mask,
    /// `px_count_visib / px_count_all`.
    pub visib_fract: f64,
    /// Silhouette pixels when rendered alone, on a canvas extended by one image size per side.
    pub px_count_all: u64,
    /// In-image silhouette pixels with valid depth after noise (BOP's `px_count_valid`).
    pub px_count_valid: u64,
    /// Bounding box `[x, y, w, h]` of the full silhouette (may extend outside the image), px.
    pub bbox_obj: [i32; 4],
    /// What the box rests on: "floor" | "pallet" | "table" | "shelf" | "box".
    pub support: Option<String>,
}

/// One generated RGB-D view with ground truth.
#[derive(Debug, Clone)]
pub struct SynthView {
    /// Scene index.
    pub scene_id: u32,
    /// View index within the scene.
    pub im_id: u32,
    /// Concrete layout of the scene.
    pub layout: Layout,
    /// Distractors placed in the scene.
    pub distractors: u32,
    /// Colour image.
    pub rgb: RgbImage,
    /// Depth, mm (0 = invalid).
    pub depth: DepthMap,
    /// Camera intrinsics, px.
    pub intrinsics: Intrinsics,
    /// Depth PNG scale (mm per unit): 1.0.
    pub depth_scale: f64,
    /// Visible boxes (at least one visible pixel), in scene order.
    pub boxes: Vec<SynthBox>,
    /// Camera name ("realsense-d435" | "kinect-like").
    pub camera: String,
    /// Camera pose in the scene's world frame (mm; z up, floor at z = 0): maps camera-frame
    /// points to world points. Ground truth for support-plane checks; not for estimators.
    pub world_from_camera: Isometry3<f64>,
}

/// What [`write_dataset`] wrote.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Dataset root.
    pub root: PathBuf,
    /// Scenes written.
    pub scenes: u32,
    /// Views written.
    pub views: u32,
    /// Ground-truth box instances over all views.
    pub boxes: u64,
    /// Distinct box models (`obj_id`s).
    pub models: usize,
    /// Distractors over all scenes.
    pub distractors: u64,
    /// Wall time, s.
    pub elapsed_s: f64,
}

/// BOP split name written by [`write_dataset`].
pub const SPLIT: &str = "test";

fn camera_name(c: CameraKind) -> &'static str {
    match c {
        CameraKind::RealSenseD435 => "realsense-d435",
        CameraKind::KinectLike => "kinect-like",
    }
}

/// Intrinsics of a camera kind at the configured size (640×480 reference, scaled by width/640).
fn intrinsics_for(c: CameraKind, width: u32, height: u32) -> Intrinsics {
    // D435 colour stream at 640×480 (typical factory calibration); Azure Kinect NFOV unbinned
    // depth (640×576, f ≈ 504 px) cropped to 640×480 around the centre.
    let (fx, fy, cx, cy) = match c {
        CameraKind::RealSenseD435 => (615.0, 615.3, 321.3, 238.7),
        CameraKind::KinectLike => (504.2, 504.4, 320.6, 240.8),
    };
    let s = width as f64 / 640.0;
    let sy = height as f64 / 480.0;
    Intrinsics {
        fx: fx * s,
        fy: fy * s,
        cx: cx * s,
        cy: cy * sy,
    }
}

fn build(cfg: &SynthConfig, scene_idx: u32) -> Scene {
    let mut rng = stream(cfg.seed, scene_idx, 0, purpose::SCENE);
    scene::build_scene(cfg.layout.for_scene(scene_idx), &mut rng, cfg.distractors)
}

fn size_key(s: &Vector3<f64>) -> [i64; 3] {
    [
        (s.x * 10.0).round() as i64,
        (s.y * 10.0).round() as i64,
        (s.z * 10.0).round() as i64,
    ]
}

/// Size → obj_id over scenes `0..n_scenes`, ids from 1 in order of first appearance.
fn registry(cfg: &SynthConfig, n_scenes: u32) -> BTreeMap<[i64; 3], u32> {
    let mut reg = BTreeMap::new();
    for s in 0..n_scenes {
        for b in build(cfg, s).boxes {
            let next = reg.len() as u32 + 1;
            reg.entry(size_key(&(b.obb.half * 2.0))).or_insert(next);
        }
    }
    reg
}

/// Box models of the dataset (`obj_id` → centred cuboid), as written to `models_info.json`.
pub fn models(cfg: &SynthConfig) -> BTreeMap<u32, ModelInfo> {
    registry(cfg, cfg.scenes)
        .into_iter()
        .map(|(k, id)| {
            (
                id,
                ModelInfo::cuboid([k[0] as f64 / 10.0, k[1] as f64 / 10.0, k[2] as f64 / 10.0]),
            )
        })
        .collect()
}

/// Camera pose for a view: world → camera rotation and camera centre (world, mm).
fn camera_pose(
    cfg: &SynthConfig,
    sc: &Scene,
    scene_idx: u32,
    view_idx: u32,
    attempt: u32,
) -> (Matrix3<f64>, Vector3<f64>) {
    let mut rng = stream(
        cfg.seed,
        scene_idx,
        view_idx,
        purpose::CAMERA + ((attempt as u64) << 8),
    );
    let v = &sc.views;
    let dist = rng.random_range(v.dist_mm.0..v.dist_mm.1);
    let el = rng.random_range(v.elev_deg.0..v.elev_deg.1).to_radians();
    let az = rng.random_range(v.azim_deg.0..v.azim_deg.1).to_radians();
    let j = v.target_jitter_mm;
    let target = sc.target
        + Vector3::new(
            rng.random_range(-j..=j),
            rng.random_range(-j..=j),
            rng.random_range(-j..=j) * 0.5,
        );
    let eye = target + dist * Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let fwd = (target - eye).normalize();
    let mut right = fwd.cross(&Vector3::z());
    if right.norm() < 1e-6 {
        right = Vector3::x();
    }
    let right = right.normalize();
    let down = fwd.cross(&right);
    let roll = rng.random_range(-4f64..4.0).to_radians();
    let (r2, d2) = (
        right * roll.cos() + down * roll.sin(),
        down * roll.cos() - right * roll.sin(),
    );
    let r_cw = Matrix3::from_columns(&[r2, d2, fwd]);
    (r_cw.transpose(), eye)
}

/// Generates view `view_idx` of scene `scene_idx` in memory (deterministic).
pub fn generate_view(cfg: &SynthConfig, scene_idx: u32, view_idx: u32) -> SynthView {
    let reg = registry(cfg, scene_idx + 1);
    let sc = build(cfg, scene_idx);
    render_view(cfg, &sc, &reg, scene_idx, view_idx)
}

fn render_view(
    cfg: &SynthConfig,
    sc: &Scene,
    reg: &BTreeMap<[i64; 3], u32>,
    scene_idx: u32,
    view_idx: u32,
) -> SynthView {
    let (w, h) = (cfg.width.max(1), cfg.height.max(1));
    let k = intrinsics_for(sc.camera, w, h);
    let n_gt = sc.boxes.len();
    // A camera pose that sees at least one box (retries are rare and deterministic).
    let mut chosen = None;
    for attempt in 0..12u32 {
        let (r_wc, eye) = camera_pose(cfg, sc, scene_idx, view_idx, attempt);
        let t = -(r_wc * eye);
        let objs: Vec<CamObject<'_>> = sc
            .objects
            .iter()
            .map(|o| CamObject::new(o.shape.transformed(&r_wc, &t), &o.material, o.kind, &k))
            .collect();
        let light = r_wc * sc.light_dir;
        let out = render::render(&objs, n_gt, &k, w, h, &light);
        let seen = out.inst.iter().any(|&i| (i as usize) < n_gt);
        let last = attempt == 11;
        if seen || last {
            chosen = Some((r_wc, t, out));
            break;
        }
    }
    // The loop always stores a result on its last attempt.
    let (r_wc, t, out) = chosen.expect("last attempt always stores a render");
    let view_key = hash3(
        cfg.seed,
        ((scene_idx as u64) << 32) | view_idx as u64,
        purpose::NOISE,
    );
    let depth_mm: Vec<f32> = match cfg.noise {
        NoiseModel::None => out.depth_mm.iter().map(|&z| z as f32).collect(),
        NoiseModel::Realistic => {
            let mut hole_rng = stream(cfg.seed, scene_idx, view_idx, purpose::HOLES);
            noise::apply_realistic(&out, sc.camera, k.fx, w, h, view_key, &mut hole_rng)
        }
    };
    let rgb_bytes = if cfg.noise == NoiseModel::Realistic {
        realistic_rgb(&out.rgb, w as usize, h as usize, view_key)
    } else {
        out.rgb.clone()
    };
    // Image buffer length is exactly w·h·3 by construction.
    let rgb = RgbImage::from_raw(w, h, rgb_bytes).expect("buffer is width*height*3 bytes");
    let depth = DepthMap {
        width: w,
        height: h,
        depth_mm,
    };
    // Ground truth.
    let mut visib = vec![0u64; n_gt];
    for &i in &out.inst {
        if (i as usize) < n_gt {
            visib[i as usize] += 1;
        }
    }
    let mut valid = vec![0u64; n_gt];
    for &(p, g) in &out.sil_pixels {
        if depth.depth_mm.get(p as usize).is_some_and(|&d| d > 0.0) {
            valid[g as usize] += 1;
        }
    }
    let r_wc_rot = Rotation3::from_matrix_unchecked(r_wc);
    // All visible masks in one pass over the instance image.
    let mut masks: Vec<Option<Mask>> = visib
        .iter()
        .map(|&n| (n > 0).then(|| Mask::empty(w, h)))
        .collect();
    for (p, &i) in out.inst.iter().enumerate() {
        if let Some(Some(m)) = masks.get_mut(i as usize) {
            m.data[p] = true;
        }
    }
    let mut boxes = Vec::new();
    for (g, pb) in sc.boxes.iter().enumerate() {
        let Some(mask) = masks[g].take() else {
            continue;
        };
        let size = pb.obb.half * 2.0;
        let rot = r_wc_rot * Rotation3::from_matrix_unchecked(pb.obb.rot);
        let pose = OrientedBox {
            rotation: Rotation3::from_matrix(rot.matrix()),
            center_mm: r_wc * pb.obb.center + t,
            size_mm: size,
        };
        let all = out.px_all[g].max(visib[g]);
        let bbox_obj = match out.sil_bbox[g] {
            Some([u0, v0, u1, v1]) => [
                u0 as i32,
                v0 as i32,
                (u1 - u0 + 1) as i32,
                (v1 - v0 + 1) as i32,
            ],
            None => [0, 0, 0, 0],
        };
        boxes.push(SynthBox {
            obj_id: reg.get(&size_key(&size)).copied().unwrap_or(0),
            pose,
            mask_visib: mask,
            visib_fract: visib[g] as f64 / all as f64,
            px_count_all: all,
            px_count_valid: valid[g],
            bbox_obj,
            support: Some(pb.support.to_string()),
        });
    }
    SynthView {
        scene_id: scene_idx,
        im_id: view_idx,
        layout: sc.layout,
        distractors: sc.distractors,
        rgb,
        depth,
        intrinsics: k,
        depth_scale: 1.0,
        boxes,
        camera: camera_name(sc.camera).to_string(),
        world_from_camera: {
            // r_wc is orthonormal by construction (look-at frame).
            let r_cw = Rotation3::from_matrix(&r_wc.transpose());
            Isometry3::from_parts(
                Translation3::from(-(r_wc.transpose() * t)),
                UnitQuaternion::from_rotation_matrix(&r_cw),
            )
        },
    }
}

/// Camera effects on the ideal shaded image: per-view exposure (×0.8–1.2) and white balance
/// (±5 % per channel), optical blur (separable [1 2 1]/4 kernel, ≈ 0.7 px σ), and sensor noise
/// (σ = 2 grey levels per channel).
fn realistic_rgb(ideal: &[u8], w: usize, h: usize, view_key: u64) -> Vec<u8> {
    let rgb_key = hash3(view_key, 0, purpose::RGB);
    let u = |i: u64| rng::unit(hash3(rgb_key, u64::MAX - i, 1));
    let gain = 0.8 + 0.4 * u(0);
    let wb = [0.95 + 0.1 * u(1), 0.95 + 0.1 * u(2), 0.95 + 0.1 * u(3)];
    let at = |x: usize, y: usize, c: usize| ideal[3 * (y * w + x) + c] as f64;
    let blur_x: Vec<f64> = (0..w * h * 3)
        .map(|i| {
            let (p, c) = (i / 3, i % 3);
            let (x, y) = (p % w, p / w);
            let (xl, xr) = (x.saturating_sub(1), (x + 1).min(w - 1));
            0.25 * at(xl, y, c) + 0.5 * at(x, y, c) + 0.25 * at(xr, y, c)
        })
        .collect();
    (0..w * h * 3)
        .map(|i| {
            let (p, c) = (i / 3, i % 3);
            let (x, y) = (p % w, p / w);
            let (yu, yd) = (y.saturating_sub(1), (y + 1).min(h - 1));
            let b = 0.25 * blur_x[3 * (yu * w + x) + c]
                + 0.5 * blur_x[i]
                + 0.25 * blur_x[3 * (yd * w + x) + c];
            let n = 2.0 * rng::gauss_fast(hash3(rgb_key, i as u64, 0));
            (b * gain * wb[c] + n).round().clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// Generates every view of every scene in memory (scenes × views, in order), in parallel.
pub fn generate_views(cfg: &SynthConfig) -> Vec<SynthView> {
    let reg = registry(cfg, cfg.scenes);
    let scenes: Vec<Scene> = (0..cfg.scenes).map(|s| build(cfg, s)).collect();
    let jobs: Vec<(u32, u32)> = (0..cfg.scenes)
        .flat_map(|s| (0..cfg.views).map(move |v| (s, v)))
        .collect();
    jobs.par_iter()
        .map(|&(s, v)| render_view(cfg, &scenes[s as usize], &reg, s, v))
        .collect()
}

/// Writes the whole dataset in BOP layout under `out` (split [`SPLIT`]), plus
/// `SCENE/scene_meta.json` with the layout, camera and distractor count of each scene.
pub fn write_dataset(cfg: &SynthConfig, out: &Path) -> Result<Summary, SynthError> {
    cfg.validate()?;
    let t0 = Instant::now();
    let reg = registry(cfg, cfg.scenes);
    let models = models(cfg);
    let writer = DatasetWriter::create(out, SPLIT, &models)?;
    let mut summary = Summary {
        root: out.to_path_buf(),
        scenes: 0,
        views: 0,
        boxes: 0,
        models: models.len(),
        distractors: 0,
        elapsed_s: 0.0,
    };
    // Scenes in parallel (the writer takes `&self`); results gathered in scene order.
    let per_scene: Vec<(u32, u64, u32)> = (0..cfg.scenes)
        .into_par_iter()
        .map(|s| write_scene(cfg, &reg, &writer, s))
        .collect::<Result<_, SynthError>>()?;
    for (views, boxes, distractors) in per_scene {
        summary.scenes += 1;
        summary.views += views;
        summary.boxes += boxes;
        summary.distractors += distractors as u64;
    }
    summary.elapsed_s = t0.elapsed().as_secs_f64();
    Ok(summary)
}

/// Renders and writes one scene; returns `(views, GT boxes, distractors)`.
fn write_scene(
    cfg: &SynthConfig,
    reg: &BTreeMap<[i64; 3], u32>,
    writer: &DatasetWriter,
    s: u32,
) -> Result<(u32, u64, u32), SynthError> {
    let sc = build(cfg, s);
    let views: Vec<SynthView> = (0..cfg.views)
        .into_par_iter()
        .map(|v| render_view(cfg, &sc, reg, s, v))
        .collect();
    let n_views = views.len() as u32;
    let n_boxes = views.iter().map(|v| v.boxes.len() as u64).sum::<u64>();
    let view_poses: Vec<(u32, Isometry3<f64>)> = views
        .iter()
        .map(|v| (v.im_id, v.world_from_camera))
        .collect();
    let records: Vec<ViewRecord> = views
        .into_iter()
        .map(|v| ViewRecord {
            im_id: v.im_id,
            rgb: v.rgb,
            depth: v.depth,
            intrinsics: v.intrinsics,
            depth_scale: v.depth_scale,
            gts: v
                .boxes
                .into_iter()
                .map(|b| GtRecordOut {
                    obj_id: b.obj_id,
                    pose: b.pose,
                    mask_visib: b.mask_visib,
                    px_count_all: b.px_count_all,
                    px_count_valid: b.px_count_valid,
                    visib_fract: b.visib_fract,
                    bbox_obj: b.bbox_obj,
                })
                .collect(),
        })
        .collect();
    writer.write_scene(s, &records)?;
    let view_meta: BTreeMap<String, serde_json::Value> = view_poses
        .iter()
        .map(|(im, iso)| {
            let fwd = iso.rotation * Vector3::z();
            let m = iso.to_homogeneous();
            let row_major: Vec<f64> = (0..4)
                .flat_map(|r| (0..4).map(move |c| (r, c)))
                .map(|(r, c)| m[(r, c)])
                .collect();
            (
                im.to_string(),
                serde_json::json!({
                    "camera_height_mm": iso.translation.vector.z,
                    "elevation_deg": (-fwd.z).clamp(-1.0, 1.0).asin().to_degrees(),
                    "world_from_camera": row_major,
                }),
            )
        })
        .collect();
    let supports: BTreeMap<String, usize> = sc.boxes.iter().fold(BTreeMap::new(), |mut m, b| {
        *m.entry(b.support.to_string()).or_insert(0) += 1;
        m
    });
    let meta = serde_json::json!({
        "layout": sc.layout.name(),
        "distractors": sc.distractors,
        "camera": camera_name(sc.camera),
        "noise": cfg.noise.to_string(),
        "seed": cfg.seed,
        "boxes_in_scene": sc.boxes.len(),
        "supports": supports,
        "units": "mm; depth PNG value × depth_scale (1.0) = depth in mm",
        "world_frame": "z up, floor at z = 0, mm; world_from_camera is a row-major 4x4",
        "views": view_meta,
    });
    writer.write_scene_meta(s, &meta)?;
    Ok((n_views, n_boxes, sc.distractors))
}

#[cfg(test)]
mod tests;
