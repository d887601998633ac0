//! Stage 2 of SPEC §1: segmentation — where the instance masks come from.
//!
//! In: a mask source and the frame size. Out: [`InstanceMask`]s (a binary mask, a score and a
//! name saying where it came from).
//!
//! The paper runs SAM with DINOv2 template matching (SAM-6D's ISM). No network weights can be
//! downloaded here, so anybox takes masks from the caller, in any of these formats:
//! - **the built-in detector** (`detect`, [`crate::detect`]): zero-shot box segmentation from
//!   depth, normals and colour, scored by box-likeness;
//! - **ground truth** of a BOP dataset (`mask_visib/IM_GT.png`), used by dataset mode;
//! - **instance PNGs**: one binary PNG per instance (any non-zero pixel is inside), given as
//!   files or as a folder (sorted by file name);
//! - **a label image**: one 8- or 16-bit PNG in which every distinct non-zero value is one
//!   instance (ordered by value; 0 is background);
//! - **COCO-RLE JSON** in SAM-6D's `detection_ism.json` layout: a list of
//!   `{scene_id, image_id, category_id, bbox, score, time, segmentation: {size: [h, w], counts}}`;
//!   the detection scores carry through to the estimates.

use std::path::{Path, PathBuf};

use anybox_io::{IoError, Mask};

/// Why masks could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SegmentationError {
    /// A mask file is missing, corrupt or of the wrong size (the error names the file).
    #[error(transparent)]
    Io(#[from] IoError),
    /// No mask source was given.
    #[error("no masks given: pass instance PNGs, a folder, a label image or a COCO-RLE JSON")]
    NoMasks,
    /// The built-in detector could not process the frame.
    #[error("box detection failed: {0}")]
    Detect(#[from] crate::detect::DetectError),
    /// [`MaskSource::Detect`] needs the frame: call [`detect_masks`].
    #[error("detection needs the frame; call detect_masks")]
    DetectNeedsFrame,
    /// `gt` was asked for outside dataset mode.
    #[error("ground-truth masks (`gt`) exist only in dataset mode (--dataset)")]
    GroundTruthOutsideDataset,
}

/// Where instance masks come from.
#[derive(Debug, Clone, PartialEq)]
pub enum MaskSource {
    /// The dataset's own `mask_visib` ground truth (BOP dataset mode only).
    GroundTruth,
    /// The built-in zero-shot box detector ([`crate::detect`]); its box-likeness scores carry
    /// through.
    Detect,
    /// Instance PNGs; a PNG holding several non-zero values is read as a label image.
    Pngs(Vec<PathBuf>),
    /// A folder of binary instance PNGs, read in file-name order.
    Folder(PathBuf),
    /// COCO-RLE detections in SAM-6D's `detection_ism.json` layout.
    CocoRle(PathBuf),
}

impl MaskSource {
    /// Picks the format from what the user gave: `gt`, a `.json` file, a folder, or PNG files.
    pub fn from_paths(paths: &[PathBuf]) -> Result<MaskSource, SegmentationError> {
        match paths {
            [] => Err(SegmentationError::NoMasks),
            [p] if p.as_os_str() == "gt" => Ok(MaskSource::GroundTruth),
            [p] if p.as_os_str() == "detect" => Ok(MaskSource::Detect),
            [p] if has_ext(p, "json") => Ok(MaskSource::CocoRle(p.clone())),
            [p] if p.is_dir() => Ok(MaskSource::Folder(p.clone())),
            many => Ok(MaskSource::Pngs(many.to_vec())),
        }
    }
}

fn has_ext(p: &Path, ext: &str) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// One instance mask with its detection score.
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceMask {
    /// The visible mask.
    pub mask: Mask,
    /// Detection score; 1 for masks without a score (PNGs, label images).
    pub score: f64,
    /// Where it came from, for messages and result records (file, label value, detection index).
    pub name: String,
    /// An alternative reading of boxes other masks already stand for (the built-in detector's
    /// [`crate::detect::Detection::alternative`]; false for caller-side masks): its record
    /// carries `"alternative": true`, and it gives no hidden extents to its neighbours
    /// ([`crate::pipeline::estimate_frame_with_alternatives`]).
    pub alternative: bool,
    /// Visible faces the built-in detector grouped into this box
    /// ([`crate::detect::Detection::n_faces`]); `None` for caller-side masks.
    pub faces: Option<u8>,
}

impl AsRef<Mask> for InstanceMask {
    fn as_ref(&self) -> &Mask {
        &self.mask
    }
}

/// Loads the instance masks of one `width`×`height` px frame from a caller-side source. Every
/// mask must have the frame's size.
///
/// A PNG is read as a label image: a binary mask (one non-zero value) gives one instance, a
/// label image (several values) one instance per value, in increasing value order. An all-zero
/// PNG gives one empty instance, which the estimator then reports as unusable.
pub fn load_masks(
    source: &MaskSource,
    width: u32,
    height: u32,
) -> Result<Vec<InstanceMask>, SegmentationError> {
    let size = Some((width, height));
    let mut out = Vec::new();
    match source {
        MaskSource::GroundTruth => return Err(SegmentationError::GroundTruthOutsideDataset),
        MaskSource::Detect => return Err(SegmentationError::DetectNeedsFrame),
        MaskSource::Pngs(paths) => {
            for p in paths {
                let mut labelled = anybox_io::masks::masks_from_label_image(p, size)?;
                if labelled.is_empty() {
                    // An all-zero PNG is still an instance the user asked for: keep it so the
                    // estimator reports it as an empty mask instead of dropping it silently.
                    labelled.push((0, Mask::empty(width, height)));
                }
                let several = labelled.len() > 1;
                for (label, mask) in labelled {
                    let name = if several {
                        format!("{} label {label}", p.display())
                    } else {
                        p.display().to_string()
                    };
                    out.push(InstanceMask {
                        mask,
                        score: 1.0,
                        name,
                        alternative: false,
                        faces: None,
                    });
                }
            }
        }
        MaskSource::Folder(dir) => {
            for (p, mask) in anybox_io::masks::read_mask_folder(dir, size)? {
                out.push(InstanceMask {
                    mask,
                    score: 1.0,
                    name: p.display().to_string(),
                    alternative: false,
                    faces: None,
                });
            }
        }
        MaskSource::CocoRle(p) => {
            for (i, d) in anybox_io::masks::read_coco_rle_json(p, size)?
                .into_iter()
                .enumerate()
            {
                out.push(InstanceMask {
                    mask: d.mask,
                    score: d.score,
                    name: format!("{} detection {i}", p.display()),
                    alternative: false,
                    faces: None,
                });
            }
        }
    }
    Ok(out)
}

/// Runs the built-in zero-shot detector ([`crate::detect::detect_boxes`]) on one frame: one
/// mask per detection, named `detection <i> (<n> faces)`, or `alternative detection <i> (<n>
/// faces)` for alternative readings.
pub fn detect_masks(
    rgb: Option<&anybox_io::RgbImage>,
    depth: &anybox_io::DepthMap,
    intrinsics: &anybox_geom::Intrinsics,
    cfg: &crate::detect::DetectConfig,
) -> Result<Vec<InstanceMask>, SegmentationError> {
    let dets = crate::detect::detect_boxes(rgb, depth, intrinsics, cfg)?;
    Ok(dets
        .into_iter()
        .enumerate()
        .map(|(i, d)| InstanceMask {
            mask: d.mask,
            score: d.score,
            name: if d.alternative {
                format!("alternative detection {i} ({} faces)", d.n_faces)
            } else {
                format!("detection {i} ({} faces)", d.n_faces)
            },
            alternative: d.alternative,
            faces: Some(d.n_faces),
        })
        .collect())
}
