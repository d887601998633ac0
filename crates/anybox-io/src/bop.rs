//! The BOP dataset layout (SPEC §3; bop_toolkit `docs/bop_datasets_format.md`, notes §2).
//!
//! ```text
//! DATASET/models_info.json                        (or DATASET/models/models_info.json)
//! DATASET/SPLIT/SCENE(6)/rgb/IM(6).png|jpg
//!                        depth/IM(6).png          uint16, depth_mm = value * depth_scale
//!                        mask_visib/IM(6)_GT(6).png
//!                        scene_camera.json, scene_gt.json, scene_gt_info.json (optional)
//! ```
//!
//! Reading ([`BopDataset::open`]) parses every JSON file up front and loads pixels lazily
//! ([`BopView::load_frame`], [`BopView::load_mask_visib`]). Ground-truth poses are converted to
//! box poses: BOP's `cam_t_m2c` is the model origin, anybox's `t` is the box centre, which in
//! the model frame is `(min_x + size_x/2, min_y + size_y/2, min_z + size_z/2)`; so
//! `centre_cam = R·c_model + t` and the size comes from `models_info`.
//!
//! Writing ([`DatasetWriter`]) produces the same layout (model origin = box centre unless the
//! given `models_info` says otherwise), with JSON keys sorted numerically, every file atomic.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anybox_geom::nalgebra::Vector3;
use anybox_geom::{Intrinsics, OrientedBox};
use serde::{Deserialize, Serialize};

use crate::camera::CameraJson;
use crate::frame::Frame;
use crate::fsutil::{read_json, to_compact, write_atomic};
use crate::image::{
    check_size, image_size, read_depth_png, read_mask_png_sized, read_rgb, write_depth_png,
    write_mask_png, write_rgb_png, DepthMap, Mask, RgbImage,
};
use crate::IoError;

// ---------------------------------------------------------------------------------------------
// models_info.json
// ---------------------------------------------------------------------------------------------

/// One `models_info.json` entry: the model's 3D axis-aligned bounding box in its own frame (mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    /// Minimum x of the model's bounding box, mm.
    pub min_x: f64,
    /// Minimum y, mm.
    pub min_y: f64,
    /// Minimum z, mm.
    pub min_z: f64,
    /// Extent along x, mm.
    pub size_x: f64,
    /// Extent along y, mm.
    pub size_y: f64,
    /// Extent along z, mm.
    pub size_z: f64,
    /// Largest distance between two model points, mm (for a box: its space diagonal).
    /// Filled with the bounding-box diagonal when the file omits it.
    #[serde(default)]
    pub diameter: f64,
    /// Any further keys (`name`, `symmetries_discrete`, …), kept on a read → write round trip.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl ModelInfo {
    /// A cuboid model centred at its origin with the given full extents, mm.
    pub fn cuboid(size_mm: [f64; 3]) -> Self {
        let [x, y, z] = size_mm;
        Self {
            min_x: -x / 2.0,
            min_y: -y / 2.0,
            min_z: -z / 2.0,
            size_x: x,
            size_y: y,
            size_z: z,
            diameter: (x * x + y * y + z * z).sqrt(),
            extra: serde_json::Map::new(),
        }
    }

    /// Full extents `(size_x, size_y, size_z)`, mm.
    pub fn size_mm(&self) -> Vector3<f64> {
        Vector3::new(self.size_x, self.size_y, self.size_z)
    }

    /// Box centre in the model frame, mm: `min + size/2` (SPEC §3). Zero for a centred model.
    pub fn center_offset_mm(&self) -> Vector3<f64> {
        Vector3::new(
            self.min_x + self.size_x / 2.0,
            self.min_y + self.size_y / 2.0,
            self.min_z + self.size_z / 2.0,
        )
    }

    fn validate(&self, path: &Path, obj_id: u32) -> Result<(), IoError> {
        let vals = [
            self.min_x,
            self.min_y,
            self.min_z,
            self.size_x,
            self.size_y,
            self.size_z,
        ];
        let sizes_ok = [self.size_x, self.size_y, self.size_z]
            .iter()
            .all(|s| s.is_finite() && *s > 0.0);
        if !vals.iter().all(|v| v.is_finite()) || !sizes_ok {
            return Err(IoError::BadValue {
                path: path.to_path_buf(),
                context: format!("obj_id {obj_id}"),
                reason: format!(
                    "sizes must be finite and > 0 mm and minima finite, got min ({}, {}, {}) \
                     size ({}, {}, {})",
                    self.min_x, self.min_y, self.min_z, self.size_x, self.size_y, self.size_z
                ),
            });
        }
        Ok(())
    }
}

/// Parses a JSON object key as a numeric id (BOP keys are decimal strings).
fn parse_id(path: &Path, what: &str, key: &str) -> Result<u32, IoError> {
    key.trim().parse::<u32>().map_err(|_| IoError::BadValue {
        path: path.to_path_buf(),
        context: format!("key \"{key}\""),
        reason: format!("{what} ids must be non-negative integers"),
    })
}

/// Reads `models_info.json`: `{obj_id: {min_x, …, size_z, diameter}}`, mm.
pub fn read_models_info(path: &Path) -> Result<BTreeMap<u32, ModelInfo>, IoError> {
    let raw: BTreeMap<String, ModelInfo> = read_json(path)?;
    let mut out = BTreeMap::new();
    for (key, mut info) in raw {
        let id = parse_id(path, "object", &key)?;
        info.validate(path, id)?;
        if !(info.diameter.is_finite() && info.diameter > 0.0) {
            info.diameter = info.size_mm().norm();
        }
        out.insert(id, info);
    }
    Ok(out)
}

/// Writes `models_info.json` atomically, keys sorted numerically.
pub fn write_models_info(path: &Path, models: &BTreeMap<u32, ModelInfo>) -> Result<(), IoError> {
    for (id, m) in models {
        m.validate(path, *id)?;
    }
    let entries = models
        .iter()
        .map(|(id, m)| Ok((*id, to_compact(path, m)?)))
        .collect::<Result<Vec<_>, IoError>>()?;
    write_atomic(path, id_map_json(&entries).as_bytes())
}

/// `{ "id": value, … }` with one entry per line, in the given (numeric) order.
fn id_map_json(entries: &[(u32, String)]) -> String {
    let mut s = String::from("{");
    for (i, (id, v)) in entries.iter().enumerate() {
        s.push_str(if i == 0 { "\n  \"" } else { ",\n  \"" });
        s.push_str(&id.to_string());
        s.push_str("\": ");
        s.push_str(v);
    }
    s.push_str(if entries.is_empty() { "}\n" } else { "\n}\n" });
    s
}

/// `{ "id": [item, …], … }` with one list item per line.
fn id_list_map_json(entries: &[(u32, Vec<String>)]) -> String {
    let lists: Vec<(u32, String)> = entries
        .iter()
        .map(|(id, items)| {
            let body = if items.is_empty() {
                "[]".to_string()
            } else {
                format!("[\n    {}\n  ]", items.join(",\n    "))
            };
            (*id, body)
        })
        .collect();
    id_map_json(&lists)
}

// ---------------------------------------------------------------------------------------------
// Per-scene JSON records.
// ---------------------------------------------------------------------------------------------

/// One `scene_gt.json` entry.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct GtJson {
    obj_id: u32,
    #[serde(rename = "cam_R_m2c")]
    cam_r_m2c: [f64; 9],
    /// Model origin in the camera frame, mm.
    cam_t_m2c: [f64; 3],
}

/// One `scene_gt_info.json` entry; every field optional on reading.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
struct GtInfoJson {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bbox_obj: Option<[i32; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bbox_visib: Option<[i32; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    px_count_all: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    px_count_valid: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    px_count_visib: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    visib_fract: Option<f64>,
}

// ---------------------------------------------------------------------------------------------
// Reading.
// ---------------------------------------------------------------------------------------------

/// One ground-truth box of a view.
#[derive(Debug, Clone, PartialEq)]
pub struct GtInstance {
    /// Index in the image's `scene_gt.json` list (names the mask file `IM_GT.png`).
    pub gt_index: usize,
    /// BOP object id (one per distinct box size in a box dataset).
    pub obj_id: u32,
    /// The true box in the camera frame: rotation box → camera, centre (mm, the
    /// `min + size/2` offset of SPEC §3 applied), size from `models_info`, mm.
    pub pose: OrientedBox,
    /// Visible fraction of the object's silhouette, 0..1 (1 when `scene_gt_info.json` is absent).
    pub visib_fract: f64,
    /// Visible pixels (0 when `scene_gt_info.json` is absent; see [`BopView::visib_counts`]).
    pub px_count_visib: u64,
    /// Visible-mask bounding box `[x, y, w, h]`, px (`[-1; 4]` when empty or unknown).
    pub bbox_visib: [i32; 4],
}

/// One image of a BOP split with its camera and ground truth; pixels are loaded on demand.
#[derive(Debug, Clone)]
pub struct BopView {
    /// Scene id (the 6-digit folder name).
    pub scene_id: u32,
    /// Image id within the scene.
    pub im_id: u32,
    /// Pinhole intrinsics, px.
    pub intrinsics: Intrinsics,
    /// uint16 depth value × depth_scale = mm.
    pub depth_scale: f64,
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// Colour image path (`rgb/IM.png`, or `rgb/IM.jpg` when that is what exists).
    pub rgb_path: PathBuf,
    /// Depth PNG path.
    pub depth_path: PathBuf,
    /// Ground-truth boxes, in `scene_gt.json` order.
    pub gts: Vec<GtInstance>,
    /// Whether `scene_gt_info.json` supplied `visib_fract`, `px_count_visib`, `bbox_visib`.
    pub gt_info_present: bool,
}

impl BopView {
    /// The scene folder `SPLIT/SCENE`.
    pub fn scene_dir(&self) -> PathBuf {
        self.depth_path
            .parent()
            .and_then(Path::parent)
            .map(Path::to_path_buf)
            .unwrap_or_default()
    }

    /// Path of the visible mask of ground truth `gt_index`: `mask_visib/IM_GT.png`.
    pub fn mask_visib_path(&self, gt_index: usize) -> PathBuf {
        self.scene_dir()
            .join("mask_visib")
            .join(format!("{:06}_{:06}.png", self.im_id, gt_index))
    }

    /// Loads RGB (when the file exists), depth (mm) and intrinsics; checks sizes.
    pub fn load_frame(&self) -> Result<Frame, IoError> {
        let depth = read_depth_png(&self.depth_path, self.depth_scale)?;
        check_size(
            &self.depth_path,
            "depth image (vs scene_camera.json / the scene's images)",
            (self.width, self.height),
            (depth.width, depth.height),
        )?;
        let rgb = if self.rgb_path.exists() {
            let img = read_rgb(&self.rgb_path)?;
            check_size(
                &self.rgb_path,
                "RGB image (vs the depth image)",
                (self.width, self.height),
                img.dimensions(),
            )?;
            Some(img)
        } else {
            None
        };
        Ok(Frame {
            rgb,
            depth,
            intrinsics: self.intrinsics,
        })
    }

    /// Loads the visible mask of ground truth `gt_index`, checking its size against the view.
    pub fn load_mask_visib(&self, gt_index: usize) -> Result<Mask, IoError> {
        let path = self.mask_visib_path(gt_index);
        if gt_index >= self.gts.len() {
            return Err(IoError::BadValue {
                path,
                context: format!("scene {} image {}", self.scene_id, self.im_id),
                reason: format!(
                    "gt index {gt_index} out of range: the image has {} ground truths",
                    self.gts.len()
                ),
            });
        }
        read_mask_png_sized(&path, self.width, self.height)
    }

    /// `(px_count_visib, bbox_visib)` of a ground truth: from `scene_gt_info.json` when it was
    /// present, otherwise computed from the visible mask (which is read for it).
    pub fn visib_counts(&self, gt_index: usize) -> Result<(u64, [i32; 4]), IoError> {
        match self.gts.get(gt_index) {
            Some(g) if self.gt_info_present => Ok((g.px_count_visib, g.bbox_visib)),
            _ => {
                let m = self.load_mask_visib(gt_index)?;
                Ok((m.count() as u64, m.bbox_xywh()))
            }
        }
    }

    /// Fills `px_count_visib` and `bbox_visib` of every ground truth from the masks when
    /// `scene_gt_info.json` was absent (no-op otherwise).
    pub fn fill_visib_from_masks(&mut self) -> Result<(), IoError> {
        if self.gt_info_present {
            return Ok(());
        }
        for i in 0..self.gts.len() {
            let (n, bb) = self.visib_counts(i)?;
            if let Some(g) = self.gts.get_mut(i) {
                g.px_count_visib = n;
                g.bbox_visib = bb;
            }
        }
        self.gt_info_present = true;
        Ok(())
    }
}

/// A BOP dataset split, with every view's camera and ground truth parsed.
#[derive(Debug, Clone)]
pub struct BopDataset {
    /// Dataset root (holds `models_info.json` and the split folders).
    pub root: PathBuf,
    /// Split name (`test`, `val`, `train_pbr`, …).
    pub split: String,
    /// Models by object id.
    pub models: BTreeMap<u32, ModelInfo>,
    /// All views, sorted by `(scene_id, im_id)`.
    pub views: Vec<BopView>,
}

impl BopDataset {
    /// Opens `root/split`: reads `models_info.json` (at the root or under `models/`), then every
    /// scene folder (6-digit names, numeric order) with its `scene_camera.json`, `scene_gt.json`
    /// and optional `scene_gt_info.json`. Images are not read (only their headers when
    /// `scene_camera.json` has no `width`/`height`).
    pub fn open(root: &Path, split: &str) -> Result<BopDataset, IoError> {
        let models_path = {
            let a = root.join("models_info.json");
            let b = root.join("models").join("models_info.json");
            if a.exists() {
                a
            } else if b.exists() {
                b
            } else {
                return Err(IoError::NotFound { path: a });
            }
        };
        let models = read_models_info(&models_path)?;
        let split_dir = root.join(split);
        let entries =
            std::fs::read_dir(&split_dir).map_err(|e| IoError::from_read(&split_dir, e))?;
        let mut scenes: Vec<(u32, PathBuf)> = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| IoError::from_read(&split_dir, e))?;
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().to_string();
            if !path.is_dir() || name.is_empty() || !name.bytes().all(|b| b.is_ascii_digit()) {
                continue;
            }
            if let Ok(id) = name.parse::<u32>() {
                scenes.push((id, path));
            }
        }
        scenes.sort();
        let mut views = Vec::new();
        for (scene_id, dir) in &scenes {
            views.extend(read_scene(&dir.clone(), *scene_id, &models)?);
        }
        Ok(BopDataset {
            root: root.to_path_buf(),
            split: split.to_string(),
            models,
            views,
        })
    }

    /// Scene ids present, ascending.
    pub fn scene_ids(&self) -> Vec<u32> {
        let mut ids: Vec<u32> = self.views.iter().map(|v| v.scene_id).collect();
        ids.dedup();
        ids
    }

    /// The views of one scene, in image-id order.
    pub fn scene_views(&self, scene_id: u32) -> impl Iterator<Item = &BopView> {
        self.views.iter().filter(move |v| v.scene_id == scene_id)
    }

    /// Total number of ground-truth boxes over all views.
    pub fn n_gt(&self) -> usize {
        self.views.iter().map(|v| v.gts.len()).sum()
    }
}

/// Reads one scene folder into views sorted by image id.
fn read_scene(
    dir: &Path,
    scene_id: u32,
    models: &BTreeMap<u32, ModelInfo>,
) -> Result<Vec<BopView>, IoError> {
    let cam_path = dir.join("scene_camera.json");
    let gt_path = dir.join("scene_gt.json");
    let info_path = dir.join("scene_gt_info.json");
    let cams_raw: BTreeMap<String, CameraJson> = read_json(&cam_path)?;
    let gts_raw: BTreeMap<String, Vec<GtJson>> = if gt_path.exists() {
        read_json(&gt_path)?
    } else {
        BTreeMap::new()
    };
    let info_raw: Option<BTreeMap<String, Vec<GtInfoJson>>> = if info_path.exists() {
        Some(read_json(&info_path)?)
    } else {
        None
    };

    let mut cams = BTreeMap::new();
    for (k, c) in cams_raw {
        let id = parse_id(&cam_path, "image", &k)?;
        let (intr, scale) = c.validate(&cam_path).map_err(|e| match e {
            IoError::BadValue { path, reason, .. } => IoError::BadValue {
                path,
                context: format!("image {id}"),
                reason,
            },
            other => other,
        })?;
        cams.insert(id, (intr, scale, c.size()));
    }
    let mut gts: BTreeMap<u32, Vec<GtJson>> = BTreeMap::new();
    for (k, g) in gts_raw {
        let id = parse_id(&gt_path, "image", &k)?;
        if !cams.contains_key(&id) {
            return Err(IoError::Inconsistent {
                path: gt_path.clone(),
                reason: format!("image {id} has ground truth but no entry in scene_camera.json"),
            });
        }
        gts.insert(id, g);
    }
    let mut infos: Option<BTreeMap<u32, Vec<GtInfoJson>>> = None;
    if let Some(raw) = info_raw {
        let mut m = BTreeMap::new();
        for (k, v) in raw {
            let id = parse_id(&info_path, "image", &k)?;
            let n_gt = gts.get(&id).map_or(0, Vec::len);
            if v.len() != n_gt {
                return Err(IoError::Inconsistent {
                    path: info_path.clone(),
                    reason: format!(
                        "image {id}: scene_gt_info.json has {} entries but scene_gt.json has {n_gt}",
                        v.len()
                    ),
                });
            }
            m.insert(id, v);
        }
        for (id, g) in &gts {
            if !g.is_empty() && !m.contains_key(id) {
                return Err(IoError::Inconsistent {
                    path: info_path.clone(),
                    reason: format!(
                        "image {id} has {} ground truths in scene_gt.json but no scene_gt_info.json entry",
                        g.len()
                    ),
                });
            }
        }
        infos = Some(m);
    }

    let mut views = Vec::with_capacity(cams.len());
    for (im_id, (intrinsics, depth_scale, size)) in cams {
        let depth_path = dir.join("depth").join(format!("{im_id:06}.png"));
        let rgb_png = dir.join("rgb").join(format!("{im_id:06}.png"));
        let rgb_jpg = dir.join("rgb").join(format!("{im_id:06}.jpg"));
        let rgb_path = if !rgb_png.exists() && rgb_jpg.exists() {
            rgb_jpg
        } else {
            rgb_png
        };
        let (width, height) = match size {
            Some(s) => s,
            None => image_size(&depth_path)?,
        };
        let mut instances = Vec::new();
        let empty = Vec::new();
        let gt_list = gts.get(&im_id).unwrap_or(&empty);
        let info_list = infos.as_ref().and_then(|m| m.get(&im_id));
        for (gt_index, g) in gt_list.iter().enumerate() {
            let ctx = format!("scene {scene_id}, image {im_id}, gt {gt_index}");
            let model = models.get(&g.obj_id).ok_or_else(|| IoError::Inconsistent {
                path: gt_path.clone(),
                reason: format!("{ctx}: obj_id {} is not in models_info.json", g.obj_id),
            })?;
            let size = model.size_mm();
            let origin =
                OrientedBox::from_arrays(g.cam_r_m2c, g.cam_t_m2c, [size.x, size.y, size.z])
                    .map_err(|e| IoError::BadValue {
                        path: gt_path.clone(),
                        context: ctx.clone(),
                        reason: e.to_string(),
                    })?;
            if g.cam_t_m2c.iter().any(|v| !v.is_finite()) {
                return Err(IoError::BadValue {
                    path: gt_path.clone(),
                    context: ctx,
                    reason: format!("cam_t_m2c must be finite, got {:?}", g.cam_t_m2c),
                });
            }
            let center = origin.rotation * model.center_offset_mm() + origin.center_mm;
            let pose = OrientedBox {
                center_mm: center,
                ..origin
            };
            let info = info_list.and_then(|l| l.get(gt_index));
            let (visib_fract, px_count_visib, bbox_visib) = match info {
                Some(i) => {
                    let vf = match (i.visib_fract, i.px_count_visib, i.px_count_all) {
                        (Some(v), _, _) => v,
                        (None, Some(vis), Some(all)) if all > 0 => vis as f64 / all as f64,
                        _ => 1.0,
                    };
                    if !vf.is_finite() {
                        return Err(IoError::BadValue {
                            path: info_path.clone(),
                            context: ctx,
                            reason: format!("visib_fract must be finite, got {vf}"),
                        });
                    }
                    (
                        vf,
                        i.px_count_visib.unwrap_or(0),
                        i.bbox_visib.unwrap_or([-1; 4]),
                    )
                }
                None => (1.0, 0, [-1; 4]),
            };
            instances.push(GtInstance {
                gt_index,
                obj_id: g.obj_id,
                pose,
                visib_fract,
                px_count_visib,
                bbox_visib,
            });
        }
        views.push(BopView {
            scene_id,
            im_id,
            intrinsics,
            depth_scale,
            width,
            height,
            rgb_path,
            depth_path,
            gts: instances,
            gt_info_present: infos.is_some(),
        });
    }
    Ok(views)
}

// ---------------------------------------------------------------------------------------------
// Writing.
// ---------------------------------------------------------------------------------------------

/// One ground-truth box to write.
#[derive(Debug, Clone)]
pub struct GtRecordOut {
    /// Object id; must be a key of the writer's models, whose size must equal `pose.size_mm`.
    pub obj_id: u32,
    /// The box in the camera frame (centre and size in mm).
    pub pose: OrientedBox,
    /// Visible mask, same size as the view.
    pub mask_visib: Mask,
    /// Pixels of the full (unoccluded) silhouette.
    pub px_count_all: u64,
    /// Pixels of the full silhouette with valid depth.
    pub px_count_valid: u64,
    /// Visible fraction, 0..1.
    pub visib_fract: f64,
    /// Bounding box of the full silhouette `[x, y, w, h]`, px.
    pub bbox_obj: [i32; 4],
}

/// One image to write.
#[derive(Debug, Clone)]
pub struct ViewRecord {
    /// Image id within the scene.
    pub im_id: u32,
    /// Colour image.
    pub rgb: RgbImage,
    /// Depth, mm.
    pub depth: DepthMap,
    /// Pinhole intrinsics, px.
    pub intrinsics: Intrinsics,
    /// Stored uint16 value = round(depth_mm / depth_scale).
    pub depth_scale: f64,
    /// Ground-truth boxes; the list index is the GT index of the mask files.
    pub gts: Vec<GtRecordOut>,
}

/// Writes a dataset in the BOP layout (SPEC §3).
#[derive(Debug, Clone)]
pub struct DatasetWriter {
    root: PathBuf,
    split: String,
    models: BTreeMap<u32, ModelInfo>,
}

/// Largest allowed difference between a written pose's size and its model's size, mm.
const SIZE_TOL_MM: f64 = 0.01;

impl DatasetWriter {
    /// Creates `root/split` and writes `root/models_info.json`.
    pub fn create(
        root: &Path,
        split: &str,
        models: &BTreeMap<u32, ModelInfo>,
    ) -> Result<DatasetWriter, IoError> {
        let split_dir = root.join(split);
        std::fs::create_dir_all(&split_dir).map_err(|source| IoError::Write {
            path: split_dir.clone(),
            source,
        })?;
        write_models_info(&root.join("models_info.json"), models)?;
        Ok(DatasetWriter {
            root: root.to_path_buf(),
            split: split.to_string(),
            models: models.clone(),
        })
    }

    /// Dataset root.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Split name.
    pub fn split(&self) -> &str {
        &self.split
    }

    /// The scene folder `root/split/SCENE(6)`.
    pub fn scene_dir(&self, scene_id: u32) -> PathBuf {
        self.root.join(&self.split).join(format!("{scene_id:06}"))
    }

    /// Writes one whole scene: `rgb/`, `depth/`, `mask_visib/` images and the three JSON files
    /// (replacing any previous content of those files). `px_count_visib` and `bbox_visib` are
    /// computed from the masks; `cam_t_m2c` is the model origin, i.e. the box centre minus the
    /// model's `min + size/2` offset (zero for [`ModelInfo::cuboid`]).
    ///
    /// Checks before writing anything: unique image ids, positive depth scale, RGB / depth /
    /// mask sizes agree, every `obj_id` is in the models with the pose's size (±0.01 mm).
    /// Takes `&self`, so different scenes can be written in parallel.
    pub fn write_scene(&self, scene_id: u32, views: &[ViewRecord]) -> Result<(), IoError> {
        let dir = self.scene_dir(scene_id);
        let gt_path = dir.join("scene_gt.json");
        let mut sorted: Vec<&ViewRecord> = views.iter().collect();
        sorted.sort_by_key(|v| v.im_id);
        for w in sorted.windows(2) {
            if w[0].im_id == w[1].im_id {
                return Err(IoError::Inconsistent {
                    path: dir,
                    reason: format!("image id {} given twice", w[0].im_id),
                });
            }
        }
        // Validate everything first, so that a bad record leaves no half-written scene.
        for v in &sorted {
            let depth_path = dir.join("depth").join(format!("{:06}.png", v.im_id));
            crate::image::check_depth_scale(&dir.join("scene_camera.json"), v.depth_scale)?;
            let dsize = (v.depth.width, v.depth.height);
            if v.depth.depth_mm.len() != dsize.0 as usize * dsize.1 as usize {
                return Err(IoError::Inconsistent {
                    path: depth_path,
                    reason: format!(
                        "depth buffer holds {} values for {}x{} px",
                        v.depth.depth_mm.len(),
                        dsize.0,
                        dsize.1
                    ),
                });
            }
            check_size(
                &dir.join("rgb").join(format!("{:06}.png", v.im_id)),
                "RGB image (vs the depth image)",
                dsize,
                v.rgb.dimensions(),
            )?;
            for (gi, g) in v.gts.iter().enumerate() {
                let mpath = dir
                    .join("mask_visib")
                    .join(format!("{:06}_{:06}.png", v.im_id, gi));
                check_size(
                    &mpath,
                    "mask (vs the depth image)",
                    dsize,
                    (g.mask_visib.width, g.mask_visib.height),
                )?;
                let model = self
                    .models
                    .get(&g.obj_id)
                    .ok_or_else(|| IoError::Inconsistent {
                        path: gt_path.clone(),
                        reason: format!(
                            "image {} gt {gi}: obj_id {} is not in the writer's models",
                            v.im_id, g.obj_id
                        ),
                    })?;
                let diff = (model.size_mm() - g.pose.size_mm).abs().max();
                if diff.is_nan() || diff > SIZE_TOL_MM {
                    return Err(IoError::Inconsistent {
                        path: gt_path.clone(),
                        reason: format!(
                            "image {} gt {gi}: pose size {:?} mm differs from obj_id {} size \
                             {:?} mm (give each box size its own obj_id)",
                            v.im_id,
                            g.pose.size_mm.as_slice(),
                            g.obj_id,
                            model.size_mm().as_slice()
                        ),
                    });
                }
                if g.pose.center_mm.iter().any(|c| !c.is_finite()) || !g.visib_fract.is_finite() {
                    return Err(IoError::BadValue {
                        path: gt_path.clone(),
                        context: format!("image {} gt {gi}", v.im_id),
                        reason: "pose centre and visib_fract must be finite".into(),
                    });
                }
            }
        }

        let mut cam_entries = Vec::new();
        let mut gt_entries = Vec::new();
        let mut info_entries = Vec::new();
        for v in &sorted {
            let im = v.im_id;
            write_rgb_png(&dir.join("rgb").join(format!("{im:06}.png")), &v.rgb)?;
            write_depth_png(
                &dir.join("depth").join(format!("{im:06}.png")),
                &v.depth,
                v.depth_scale,
            )?;
            let cam = CameraJson::new(
                &v.intrinsics,
                v.depth_scale,
                Some((v.depth.width, v.depth.height)),
            );
            cam_entries.push((im, to_compact(&gt_path, &cam)?));
            let mut gt_items = Vec::new();
            let mut info_items = Vec::new();
            for (gi, g) in v.gts.iter().enumerate() {
                write_mask_png(
                    &dir.join("mask_visib").join(format!("{im:06}_{gi:06}.png")),
                    &g.mask_visib,
                )?;
                // Checked above: the model exists.
                let offset = self
                    .models
                    .get(&g.obj_id)
                    .map(ModelInfo::center_offset_mm)
                    .unwrap_or_else(Vector3::zeros);
                let origin = g.pose.center_mm - g.pose.rotation * offset;
                let rec = GtJson {
                    obj_id: g.obj_id,
                    cam_r_m2c: g.pose.rotation_row_major(),
                    cam_t_m2c: [origin.x, origin.y, origin.z],
                };
                gt_items.push(to_compact(&gt_path, &rec)?);
                let info = GtInfoJson {
                    bbox_obj: Some(g.bbox_obj),
                    bbox_visib: Some(g.mask_visib.bbox_xywh()),
                    px_count_all: Some(g.px_count_all),
                    px_count_valid: Some(g.px_count_valid),
                    px_count_visib: Some(g.mask_visib.count() as u64),
                    visib_fract: Some(g.visib_fract),
                };
                info_items.push(to_compact(&gt_path, &info)?);
            }
            gt_entries.push((im, gt_items));
            info_entries.push((im, info_items));
        }
        write_atomic(
            &dir.join("scene_camera.json"),
            id_map_json(&cam_entries).as_bytes(),
        )?;
        write_atomic(&gt_path, id_list_map_json(&gt_entries).as_bytes())?;
        write_atomic(
            &dir.join("scene_gt_info.json"),
            id_list_map_json(&info_entries).as_bytes(),
        )?;
        Ok(())
    }

    /// Writes free-form per-scene metadata (layout, distractor count, …) to
    /// `SCENE/scene_meta.json` (not part of BOP; BOP readers ignore it).
    pub fn write_scene_meta(&self, scene_id: u32, meta: &serde_json::Value) -> Result<(), IoError> {
        crate::fsutil::write_json_pretty(&self.scene_dir(scene_id).join("scene_meta.json"), meta)
    }
}
