//! Instance masks supplied by the caller (SPEC §1, "masks given by the caller"):
//!
//! - a folder of instance PNGs, one instance per file, ordered by file name
//!   ([`read_mask_folder`]);
//! - a label image, 8- or 16-bit, each distinct non-zero value one instance, ordered by value
//!   ([`masks_from_label_image`]);
//! - SAM-6D's `detection_ism.json` (notes §3.1): a list of
//!   `{scene_id, image_id, category_id, bbox, score, time, segmentation: {size: [h, w], counts}}`
//!   where `counts` is COCO RLE, either the compressed string or a list of run lengths
//!   ([`read_coco_rle_json`]).
//!
//! COCO RLE: runs over the pixels in **column-major** order (down each column, then the next
//! column), alternating background/foreground and starting with background (a leading run of
//! length 0 when pixel (0, 0) is inside). The string form is pycocotools' `rleToString`: each
//! count (from the fourth on, as the difference to the count two places before) is written in
//! 5-bit groups, least significant first, each group + 48 as an ASCII character, bit 0x20
//! meaning "more groups follow" and bit 0x10 of the last group the sign.

use std::path::{Path, PathBuf};

use ::image::DynamicImage;
use serde::{Deserialize, Serialize};

use crate::fsutil::{read_bytes, read_json, write_json_pretty};
use crate::image::{check_size, describe_color, read_mask_png};
use crate::{IoError, Mask};

/// What is wrong with a COCO run-length encoding.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RleError {
    /// No runs at all.
    #[error("empty RLE (no runs)")]
    Empty,
    /// `size` has a zero dimension.
    #[error("mask size must be positive, got [h, w] = [{h}, {w}]")]
    ZeroSize {
        /// Height, px.
        h: u32,
        /// Width, px.
        w: u32,
    },
    /// The runs do not cover exactly `h·w` pixels.
    #[error("runs sum to {sum} pixels but size [h, w] = [{h}, {w}] has {expected}")]
    WrongTotal {
        /// Sum of the runs.
        sum: u64,
        /// Height, px.
        h: u32,
        /// Width, px.
        w: u32,
        /// `h·w`.
        expected: u64,
    },
    /// A run decoded from the string is negative.
    #[error("run {index} is negative ({value})")]
    NegativeRun {
        /// Index of the run.
        index: usize,
        /// Decoded value.
        value: i64,
    },
    /// A character outside the codec's alphabet (`'0'..='o'`).
    #[error("invalid character {ch:?} at byte {pos} of the counts string")]
    BadChar {
        /// The character.
        ch: char,
        /// Byte offset.
        pos: usize,
    },
    /// The string ends in the middle of a number (last group has the continuation bit).
    #[error("counts string ends in the middle of a number")]
    Truncated,
    /// The mask would be unreasonably large (more than [`MAX_RLE_PIXELS`]).
    #[error("mask size [h, w] = [{h}, {w}] exceeds the limit of {MAX_RLE_PIXELS} pixels")]
    TooLarge {
        /// Height, px.
        h: u32,
        /// Width, px.
        w: u32,
    },
    /// A number with more groups than fit in 64 bits.
    #[error("number at byte {pos} of the counts string is too long")]
    Overflow {
        /// Byte offset where the number starts.
        pos: usize,
    },
}

/// Largest mask (h·w, px) an RLE may decode to: 2^28, far above any camera image, low enough
/// that a corrupt `size` cannot exhaust memory.
pub const MAX_RLE_PIXELS: u64 = 1 << 28;

/// The `counts` of a COCO RLE: compressed string or explicit list.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum RleCounts {
    /// pycocotools' compressed string.
    Compressed(String),
    /// Explicit run lengths.
    Uncompressed(Vec<u64>),
}

/// A COCO RLE: `size` is `[height, width]` (px), as pycocotools writes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CocoRle {
    /// `[height, width]`, px.
    pub size: [u32; 2],
    /// Run lengths.
    pub counts: RleCounts,
}

/// Decodes pycocotools' compressed counts string into run lengths.
pub fn rle_string_to_counts(s: &str) -> Result<Vec<u64>, RleError> {
    let bytes = s.as_bytes();
    let mut counts: Vec<u64> = Vec::new();
    let mut p = 0;
    while p < bytes.len() {
        let start = p;
        let mut x: i64 = 0;
        let mut k = 0u32;
        loop {
            let Some(&b) = bytes.get(p) else {
                return Err(RleError::Truncated);
            };
            if !(48..48 + 64).contains(&b) {
                // Report the full UTF-8 character, not a byte of it.
                let ch = s[p..].chars().next().unwrap_or('\u{fffd}');
                return Err(RleError::BadChar { ch, pos: p });
            }
            if k >= 13 {
                return Err(RleError::Overflow { pos: start });
            }
            let c = i64::from(b - 48);
            x |= (c & 0x1f) << (5 * k);
            p += 1;
            k += 1;
            if c & 0x20 == 0 {
                if c & 0x10 != 0 && 5 * k < 64 {
                    x |= -1i64 << (5 * k);
                }
                break;
            }
        }
        let m = counts.len();
        if m > 2 {
            // counts[m - 2] <= i64::MAX because every stored count came from an i64.
            x = x.saturating_add(counts[m - 2] as i64);
        }
        if x < 0 {
            return Err(RleError::NegativeRun { index: m, value: x });
        }
        counts.push(x as u64);
    }
    Ok(counts)
}

/// Encodes run lengths as pycocotools' compressed counts string (counts must be below 2^62,
/// as any real mask's are).
pub fn counts_to_rle_string(counts: &[u64]) -> String {
    let mut s = String::new();
    for (i, &c) in counts.iter().enumerate() {
        let mut x = c as i64;
        if i > 2 {
            x = x.wrapping_sub(counts[i - 2] as i64);
        }
        loop {
            let mut ch = x & 0x1f;
            x >>= 5;
            let more = if ch & 0x10 != 0 { x != -1 } else { x != 0 };
            if more {
                ch |= 0x20;
            }
            s.push(char::from((ch + 48) as u8));
            if !more {
                break;
            }
        }
    }
    s
}

/// Decodes a COCO RLE into a row-major [`Mask`] of `w × h` px.
pub fn decode_coco_rle(rle: &CocoRle) -> Result<Mask, RleError> {
    let [h, w] = rle.size;
    if h == 0 || w == 0 {
        return Err(RleError::ZeroSize { h, w });
    }
    let counts = match &rle.counts {
        RleCounts::Compressed(s) => rle_string_to_counts(s)?,
        RleCounts::Uncompressed(v) => v.clone(),
    };
    if counts.is_empty() {
        return Err(RleError::Empty);
    }
    let expected = u64::from(h) * u64::from(w);
    if expected > MAX_RLE_PIXELS {
        return Err(RleError::TooLarge { h, w });
    }
    let sum = counts
        .iter()
        .try_fold(0u64, |a, &c| a.checked_add(c))
        .unwrap_or(u64::MAX);
    if sum != expected {
        return Err(RleError::WrongTotal {
            sum,
            h,
            w,
            expected,
        });
    }
    let mut mask = Mask::empty(w, h);
    let hh = h as usize;
    let ww = w as usize;
    let mut idx = 0usize; // column-major pixel index
    for (run_i, &c) in counts.iter().enumerate() {
        let c = c as usize; // sum == h·w, which is a usize-sized buffer
        if run_i % 2 == 1 {
            // In bounds: the runs sum to exactly h·w (checked above), so j < h·w.
            for j in idx..idx + c {
                let (col, row) = (j / hh, j % hh);
                mask.data[row * ww + col] = true;
            }
        }
        idx += c;
    }
    Ok(mask)
}

/// Encodes a mask as a COCO RLE with a compressed counts string.
pub fn encode_coco_rle(mask: &Mask) -> CocoRle {
    let (w, h) = (mask.width as usize, mask.height as usize);
    let mut counts = Vec::new();
    let mut current = false;
    let mut run = 0u64;
    for col in 0..w {
        for row in 0..h {
            let v = mask.data.get(row * w + col).copied().unwrap_or(false);
            if v != current {
                counts.push(run);
                run = 0;
                current = v;
            }
            run += 1;
        }
    }
    counts.push(run);
    CocoRle {
        size: [mask.height, mask.width],
        counts: RleCounts::Compressed(counts_to_rle_string(&counts)),
    }
}

/// One detection of SAM-6D's `detection_ism.json`, decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectionMask {
    /// Instance mask.
    pub mask: Mask,
    /// Detection score (higher is better).
    pub score: f64,
    /// Scene id (0 when absent).
    pub scene_id: u32,
    /// Image id (0 when absent).
    pub image_id: u32,
    /// Category / object id (0 when absent).
    pub category_id: u32,
}

/// One raw `detection_ism.json` entry.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct DetectionJson {
    #[serde(default)]
    scene_id: u32,
    #[serde(default)]
    image_id: u32,
    #[serde(default)]
    category_id: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    bbox: Option<[f64; 4]>,
    score: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    time: Option<f64>,
    segmentation: CocoRle,
}

/// Reads SAM-6D's `detection_ism.json` (a JSON list of detections with COCO-RLE masks).
/// When `expected` `(width, height)` is given, every mask must have that size.
pub fn read_coco_rle_json(
    path: &Path,
    expected: Option<(u32, u32)>,
) -> Result<Vec<DetectionMask>, IoError> {
    let raw: Vec<DetectionJson> = read_json(path)?;
    let mut out = Vec::with_capacity(raw.len());
    for (i, d) in raw.into_iter().enumerate() {
        let mask = decode_coco_rle(&d.segmentation).map_err(|source| IoError::Rle {
            path: path.to_path_buf(),
            context: format!("detection {i}"),
            source,
        })?;
        if let Some(size) = expected {
            check_size(
                path,
                &format!("mask of detection {i} (vs the frame)"),
                size,
                (mask.width, mask.height),
            )?;
        }
        if !d.score.is_finite() {
            return Err(IoError::BadValue {
                path: path.to_path_buf(),
                context: format!("detection {i}"),
                reason: format!("score must be finite, got {}", d.score),
            });
        }
        out.push(DetectionMask {
            mask,
            score: d.score,
            scene_id: d.scene_id,
            image_id: d.image_id,
            category_id: d.category_id,
        });
    }
    Ok(out)
}

/// Writes detections in SAM-6D's `detection_ism.json` layout (compressed RLE, `bbox` as
/// `[x, y, w, h]` px of the mask, `time` 0), atomically.
pub fn write_coco_rle_json(path: &Path, detections: &[DetectionMask]) -> Result<(), IoError> {
    let raw: Vec<DetectionJson> = detections
        .iter()
        .map(|d| {
            let bb = d.mask.bbox_xywh();
            DetectionJson {
                scene_id: d.scene_id,
                image_id: d.image_id,
                category_id: d.category_id,
                bbox: Some(bb.map(f64::from)),
                score: d.score,
                time: Some(0.0),
                segmentation: encode_coco_rle(&d.mask),
            }
        })
        .collect();
    write_json_pretty(path, &raw)
}

/// Reads every `*.png` in `dir` as one instance mask, ordered by file name. When `expected`
/// `(width, height)` is given, every mask must have that size. Returns `(path, mask)` pairs.
pub fn read_mask_folder(
    dir: &Path,
    expected: Option<(u32, u32)>,
) -> Result<Vec<(PathBuf, Mask)>, IoError> {
    let entries = std::fs::read_dir(dir).map_err(|e| IoError::from_read(dir, e))?;
    let mut paths = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| IoError::from_read(dir, e))?;
        let p = entry.path();
        let is_png = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if p.is_file() && is_png {
            paths.push(p);
        }
    }
    paths.sort();
    let mut out = Vec::with_capacity(paths.len());
    for p in paths {
        let m = read_mask_png(&p)?;
        if let Some(size) = expected {
            check_size(&p, "mask (vs the frame)", size, (m.width, m.height))?;
        }
        out.push((p, m));
    }
    Ok(out)
}

/// Splits a label image (8- or 16-bit grayscale PNG) into one mask per distinct non-zero
/// value, ordered by value. Returns `(label, mask)` pairs.
pub fn masks_from_label_image(
    path: &Path,
    expected: Option<(u32, u32)>,
) -> Result<Vec<(u32, Mask)>, IoError> {
    let bytes = read_bytes(path)?;
    let img =
        ::image::load_from_memory_with_format(&bytes, ::image::ImageFormat::Png).map_err(|e| {
            IoError::CorruptImage {
                path: path.to_path_buf(),
                reason: format!("PNG decoder: {e}"),
            }
        })?;
    let (w, h) = (img.width(), img.height());
    if let Some(size) = expected {
        check_size(path, "label image (vs the frame)", size, (w, h))?;
    }
    let labels: Vec<u32> = match img {
        DynamicImage::ImageLuma8(b) => b.into_raw().into_iter().map(u32::from).collect(),
        DynamicImage::ImageLuma16(b) => b.into_raw().into_iter().map(u32::from).collect(),
        other => {
            return Err(IoError::PixelFormat {
                path: path.to_path_buf(),
                expected: "8- or 16-bit single-channel label PNG".into(),
                got: format!("{} PNG", describe_color(other.color())),
            })
        }
    };
    let mut distinct: Vec<u32> = labels.iter().copied().filter(|&l| l != 0).collect();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() > MAX_LABELS {
        return Err(IoError::BadValue {
            path: path.to_path_buf(),
            context: String::new(),
            reason: format!(
                "{} distinct labels (more than {MAX_LABELS}): not a label image (a depth image?)",
                distinct.len()
            ),
        });
    }
    Ok(label_values_to_masks(&labels, w, h))
}

/// Most distinct labels accepted from one label image: more means the file is probably not a
/// label image (e.g. a depth PNG given by mistake), and one mask per value would exhaust memory.
pub const MAX_LABELS: usize = 1024;

/// One mask per distinct non-zero label in a row-major label buffer of `w × h`, ordered by
/// label value.
pub fn label_values_to_masks(labels: &[u32], w: u32, h: u32) -> Vec<(u32, Mask)> {
    let mut values: Vec<u32> = labels.iter().copied().filter(|&l| l != 0).collect();
    values.sort_unstable();
    values.dedup();
    let mut masks: Vec<Mask> = values.iter().map(|_| Mask::empty(w, h)).collect();
    for (i, &l) in labels.iter().enumerate() {
        if l == 0 {
            continue;
        }
        if let Ok(k) = values.binary_search(&l) {
            if let Some(d) = masks.get_mut(k).and_then(|m| m.data.get_mut(i)) {
                *d = true;
            }
        }
    }
    values.into_iter().zip(masks).collect()
}
