//! anybox: zero-shot 9-DoF box pose and size from one RGB-D frame (the AnyBox method), on a CPU.
//!
//! The modules follow the pipeline of SPEC §1, in order:
//! 1. frame and camera I/O — [`io`] (the `anybox-io` crate);
//! 2. [`segmentation`] — where instance masks come from; [`detect`] finds box masks itself
//!    from geometry and colour (no learned weights);
//! 3. [`observation`] and [`hypotheses`] — masked depth → 3D points → pose hypotheses;
//! 4. [`depth_filter`] — the paper's depth-consistency filter;
//! 5. [`refine`] and [`pose`] — robust ICP to the cuboid, confidence, ranking;
//! 6. [`scale`] (with [`silhouette`] and [`context`]) — Algorithms 1 and 2, hidden dimensions;
//! 7. [`pipeline`] — one mask or one frame in, boxes out; [`roundness`] tells a detected
//!    tin or rod from a box by its estimate's cross-section. [`config`] holds every parameter.
//!
//! Around the pipeline: [`runner`] runs it over a BOP dataset or one frame and writes result
//! records, [`overlay`] draws the boxes, [`bench`](mod@bench) compares the estimator variants.
//! The crate-internal `repeat` module judges whether one box is copies of another's size, for
//! the detector (stage 2) and the pipeline's repeat readings (stage 7) alike; `depth_noise`
//! reads how noisy the depth is for its depth, for the detector's grid and the observation.
//!
//! Evaluation ([`eval`]) and the synthetic generator ([`synth`]) are their own crates,
//! re-exported here.

pub mod bench;
pub mod config;
pub mod context;
pub mod depth_filter;
mod depth_noise;
pub mod detect;
pub mod error;
pub mod hypotheses;
pub mod observation;
mod order_stats;
pub mod overlay;
pub mod pipeline;
pub mod pose;
pub mod refine;
mod repeat;
pub mod roundness;
pub mod runner;
pub mod scale;
pub mod segmentation;
pub mod silhouette;

pub use anybox_eval as eval;
pub use anybox_geom as geom;
pub use anybox_io as io;
pub use anybox_synth as synth;
