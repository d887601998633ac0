//! Input and output for anybox (pipeline stage 1 of SPEC §1: frame and camera I/O).
//!
//! - [`image`]: in-memory depth maps (mm), masks and RGB images, and the PNG/JPEG readers and
//!   writers for them.
//! - Millimetres everywhere: a uint16 depth PNG holds `value`, and `depth_mm = value * depth_scale`.

pub mod image;

pub use crate::image::{DepthMap, Mask, RgbImage};
