//! anybox's results JSON and the BOP19 results CSV (SPEC §3).
//!
//! JSON, one record per estimated box:
//! `{"estimates": [{"scene_id", "im_id", "score", "R": [9, row-major, box → camera],
//! "t": [3, mm, box centre], "size": [3, mm], "time": s, "gt_index": int | null, …}]}`.
//! Unknown fields are kept in [`EstimateRecord::extra`] and written back.
//!
//! CSV (bop_toolkit `inout.save_bop_results`, version "bop19"): header
//! `scene_id,im_id,obj_id,score,R,t,time`, `R` 9 space-separated floats row-major, `t` mm,
//! `time` in seconds per image, identical for every row of an image (the BOP evaluator checks).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anybox_geom::{GeomError, OrientedBox};
use serde::{Deserialize, Serialize};

use crate::fsutil::{read_json, write_atomic, write_json_pretty};
use crate::IoError;

/// One estimated box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateRecord {
    /// Scene id.
    pub scene_id: u32,
    /// Image id.
    pub im_id: u32,
    /// Confidence, higher is better.
    pub score: f64,
    /// Rotation box → camera, row-major 3x3.
    #[serde(rename = "R")]
    pub r: [f64; 9],
    /// Box centre in the camera frame, mm.
    pub t: [f64; 3],
    /// Full box extents along the box axes, mm.
    pub size: [f64; 3],
    /// Processing time, s (per box or per image as the producer documents; −1 if unknown).
    pub time: f64,
    /// Index of the ground truth whose mask produced this estimate, when masks came from the
    /// dataset; `null` otherwise.
    #[serde(default)]
    pub gt_index: Option<usize>,
    /// Any further fields (e.g. `obj_id`, per-stage timings), kept verbatim.
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

impl EstimateRecord {
    /// Builds a record from a pose.
    pub fn from_pose(
        scene_id: u32,
        im_id: u32,
        pose: &OrientedBox,
        score: f64,
        time_s: f64,
        gt_index: Option<usize>,
    ) -> Self {
        Self {
            scene_id,
            im_id,
            score,
            r: pose.rotation_row_major(),
            t: [pose.center_mm.x, pose.center_mm.y, pose.center_mm.z],
            size: [pose.size_mm.x, pose.size_mm.y, pose.size_mm.z],
            time: time_s,
            gt_index,
            extra: serde_json::Map::new(),
        }
    }

    /// The estimated box; fails on a non-rotation `R` or a non-positive size.
    pub fn pose(&self) -> Result<OrientedBox, GeomError> {
        OrientedBox::from_arrays(self.r, self.t, self.size)
    }

    /// `obj_id` from `extra` when present and a non-negative integer, else 1.
    pub fn obj_id(&self) -> u64 {
        self.extra
            .get("obj_id")
            .and_then(serde_json::Value::as_u64)
            .unwrap_or(1)
    }
}

/// The whole results file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ResultsFile {
    /// All estimates.
    pub estimates: Vec<EstimateRecord>,
}

/// Reads a results JSON file, checking that every record holds finite numbers and a valid pose.
pub fn read_results(path: &Path) -> Result<ResultsFile, IoError> {
    let file: ResultsFile = read_json(path)?;
    for (i, e) in file.estimates.iter().enumerate() {
        let ctx = format!("estimate {i} (scene {}, image {})", e.scene_id, e.im_id);
        let finite = e.score.is_finite()
            && e.time.is_finite()
            && e.r.iter().chain(&e.t).chain(&e.size).all(|v| v.is_finite());
        if !finite {
            return Err(IoError::BadValue {
                path: path.to_path_buf(),
                context: ctx,
                reason: "score, time, R, t and size must be finite numbers".into(),
            });
        }
        e.pose().map_err(|err| IoError::BadValue {
            path: path.to_path_buf(),
            context: ctx,
            reason: err.to_string(),
        })?;
    }
    Ok(file)
}

/// Writes a results JSON file atomically (pretty-printed).
pub fn write_results(path: &Path, results: &ResultsFile) -> Result<(), IoError> {
    write_json_pretty(path, results)
}

/// Writes the BOP19 results CSV atomically. `obj_id` comes from `extra["obj_id"]` (default 1);
/// the time of every row of an image is the largest non-negative `time` among that image's
/// records (−1 when none is known), because bop_toolkit requires one time per image.
pub fn write_bop19_csv(path: &Path, estimates: &[EstimateRecord]) -> Result<(), IoError> {
    let mut image_time: BTreeMap<(u32, u32), f64> = BTreeMap::new();
    for e in estimates {
        let t = if e.time.is_finite() && e.time >= 0.0 {
            e.time
        } else {
            -1.0
        };
        let slot = image_time.entry((e.scene_id, e.im_id)).or_insert(-1.0);
        *slot = slot.max(t);
    }
    let mut s = String::from("scene_id,im_id,obj_id,score,R,t,time\n");
    let join = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    for e in estimates {
        let time = image_time
            .get(&(e.scene_id, e.im_id))
            .copied()
            .unwrap_or(-1.0);
        // Writing to a String cannot fail.
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{}",
            e.scene_id,
            e.im_id,
            e.obj_id(),
            e.score,
            join(&e.r),
            join(&e.t),
            time
        );
    }
    write_atomic(path, s.as_bytes())
}
