//! Input and output for anybox (pipeline stage 1 of SPEC §1, the data formats of SPEC §3).
//!
//! - [`image`]: in-memory depth maps (mm), masks and RGB images, and their PNG/JPEG readers
//!   and atomic writers.
//! - [`camera`]: SAM-6D / BOP `camera.json` → intrinsics (px) and depth scale.
//! - [`frame`]: one RGB-D frame read from files, sizes checked.
//! - [`bop`]: the BOP dataset layout, reading ([`bop::BopDataset`]) and writing
//!   ([`bop::DatasetWriter`]).
//! - [`results`]: anybox's results JSON and the BOP19 results CSV.
//! - [`masks`]: instance masks from a folder, a label image or SAM-6D's COCO-RLE JSON.
//!
//! Millimetres everywhere: a uint16 depth PNG holds `value`, and `depth_mm = value * depth_scale`.
//! Every writer is atomic (`<path>.tmp`, then rename). Every error is an [`IoError`] naming the
//! file and what is wrong with it.

pub mod bop;
pub mod camera;
pub mod error;
pub mod frame;
mod fsutil;
pub mod image;
pub mod masks;
pub mod results;

pub use crate::error::IoError;
pub use crate::frame::{read_frame, Frame};
pub use crate::fsutil::write_atomic;
pub use crate::image::{DepthMap, Mask, RgbImage};
