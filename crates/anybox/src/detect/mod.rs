//! Zero-shot box detection without given masks (issue #4): instance masks of box candidates,
//! with a box-likeness score, from one RGB-D frame — no learned weights.
//!
//! In: a depth map (mm), optionally the registered RGB image, and the intrinsics. Out:
//! [`Detection`]s (mask, score in 0..1, faces grouped), best first. The paper (§3) gets its
//! masks from SAM + DINOv2 matching (SAM-6D's ISM); anybox replaces that stage (SPEC §1 stage 2)
//! with geometry and colour:
//! 1. `grid`: the frame on a grid downsampled by [`DetectConfig::grid_step_px`]; per cell the
//!    nearest surface's depth, its 3D point, a normal from guarded-smoothed depth (over more
//!    cells far away where the frame's measured depth noise is large:
//!    [`DetectConfig::radius_noise_ref`]), a smoothed colour;
//! 2. `regions`: union-find over 4-neighbours, cut at depth jumps, normal changes and colour
//!    changes — flush faces of touching cartons are separated by their printed edges, tape,
//!    shadowed gaps and colour differences, which depth alone cannot see; a plane per region;
//!    colour patches are cut along straight seam lines whose gaps let flush cartons merge
//!    (`lines`), and side faces at joints too faint to see per pixel that stand out of the
//!    face's luminance profile along the line (`profiles`); tops cut in two by tape or by
//!    their own flap seam are rejoined (`halves` pairs flap-seam halves off from a carton's
//!    edge);
//! 3. `boxes`: support planes (floor, table, shelf boards, walls) removed; up to three mutually
//!    perpendicular faces sharing a convex edge grouped into one box; curved (sphere, cylinder),
//!    irregular, too small and too large segments rejected; a cuboid fitted per group and scored
//!    by plane fit × silhouette IoU × depth consistency (the paper's filter);
//! 4. `blobs`: the same cuboid fit and score for every connected convex object (depth
//!    continuity, cut at concave creases, at steps between touching boxes (read side by
//!    side and stacked: [`DetectConfig::blob_stack_max_tilt_deg`]), at changes of plain
//!    colour across all its faces and where its cross-section steps along a box axis), which
//!    finds isolated boxes whose faces the grouping could not tie together.
//!
//! Object-, surface- and colour-level candidates then compete by score; a coarse candidate with
//! a seam between coplanar colour patches (flush cartons), one whose parallel colour patches
//! are not one plane, or one that is copies of a whole carton found inside it, gives way to
//! the finer ones; what
//! the selected candidates leave of an object is tried as a box again
//! ([`DetectConfig::residual_score_factor`]), and what is still left touching a one-face
//! candidate joins it where the two score as a box about as well as the face alone
//! (`remains`, [`DetectConfig::remain_join_min_score_ratio`]: the side face of a box seen at a
//! grazing angle or cut off at a printed edge). A candidate cut in two by a nearer thing takes
//! in its other piece past the occluder (`occluded`, [`DetectConfig::occluded_reach_mm`]). A
//! one-face candidate's mask also takes in the side faces seen as thin strips past its edges
//! ([`DetectConfig::side_strip_max_mm`]).
//! Output masks lose the spurs that the fill stitched on (an opening,
//! [`DetectConfig::mask_open_px`]) and keep, per pixel, only the front
//! surface of their grid cell; with RGB they then take in the depth dropouts next to them
//! that continue their face (a face seen at a grazing angle,
//! [`DetectConfig::hole_grow_max_fraction`]); output scores are the box-likeness times an
//! evidence factor that grows with the mask's size ([`DetectConfig::evidence_half_pixels`]).
//! A few candidates that lost a split decision come back as alternative readings, flagged
//! and scored low ([`DetectConfig::alternatives_max`]), as do the parts of a profile cut that
//! lost to its whole ([`DetectConfig::blob_profile_cut_alternatives`]) and those of a step's
//! reading not taken ([`DetectConfig::blob_stack_margin`]).
//!
//! Every threshold is a documented field of [`DetectConfig`] (`Config::detect`). The detector is
//! deterministic: the same input and config give the same detections in the same order.

mod blobs;
mod boxes;
mod grid;
mod halves;
mod lines;
mod occluded;
mod profiles;
mod regions;
mod remains;

use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::{DepthMap, Mask, RgbImage};
use nalgebra::Vector3;

use crate::observation::dilate_square;
use rayon::prelude::*;
use regions::Cues;
use serde::{Deserialize, Serialize};

/// Every threshold of the detector. Defaults were tuned on the generated benchmark
/// (`anybox_synth`, realistic noise) at 640×480; lengths in mm, angles in degrees, colour
/// differences in 8-bit RGB levels (Euclidean over the three channels).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectConfig {
    /// Original pixels per grid cell side (1..=8). Default 2: 640×480 → 320×240 cells.
    pub grid_step_px: u32,
    /// Radius of the guarded box filter applied to the depth before normals, cells. Default 2.
    pub smooth_radius_cells: u32,
    /// Half baseline of the central differences giving normals, and how far outside a pair of
    /// cells normals are compared, cells. Default 2.
    pub normal_radius_cells: u32,
    /// Both radii above grow with depth where the frame's depth noise is large for its depth.
    /// The frame's noise index `k` (1/mm) is the median over cells of |z − mean of the 8
    /// neighbours| / z² (the mean is exact on a plane, so what is left is noise; a stereo
    /// camera's noise grows with the square of depth). Beyond the depth `radius_noise_ref / k`,
    /// where the median residual reaches `radius_noise_ref` times the depth, the radii grow in
    /// proportion to depth (rounded, at most `radius_max_cells`). Such noise comes in bumps a
    /// few pixels wide, and central differences two cells apart turn it into normals tilted
    /// by tens of degrees: far cartons came out merged or in pieces. On the generated views
    /// `k` is about 1.0 × 10⁻⁶ /mm with the RealSense-like camera and 0.5 × 10⁻⁶ with the
    /// Kinect-like one, so at 1.3 × 10⁻³ the radii grow from about 1.3 m with the first and
    /// 2.6 m with the second. 0 disables. Default 1.3 × 10⁻³ (bench, 48 views, six seeds
    /// 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 rows against 0: 0.7184 → 0.7211,
    /// pallets 0.7435 → 0.7507; 1.0 / 1.15 / 1.45 / 1.6 × 10⁻³ gave 0.7141 / 0.7190 / 0.7189 /
    /// 0.7181, pallets up to 0.7528 but tables down to 0.7615 at 1.0).
    pub radius_noise_ref: f64,
    /// Cap of the grown radii, cells. Default 4 (3 and 6 gave 0.7211 and 0.7219 on the bench
    /// above, but at 6 the far taped carton of the test `slivers_along_a_tape_do_not_keep_its_
    /// halves_apart` comes out at mask IoU 0.64). The smoothing window's cost grows with the
    /// square of its radius, but only the noisiest, farthest cells get it.
    pub radius_max_cells: u32,
    /// Depth jump between neighbouring cells that separates surfaces: constant part, mm. Default 10.
    pub depth_jump_abs_mm: f64,
    /// Depth jump between neighbouring cells that separates surfaces: part relative to depth.
    /// Default 0.02 (2 % of z; consumer sensors' noise grows ∝ z²).
    pub depth_jump_rel: f64,
    /// Normal change across a pair of cells (compared `normal_radius_cells` outside) that
    /// separates faces, degrees. Default 30 (a box fold is 90°). 40 keeps more grazing side
    /// faces whole and raised detection AP@0.5 on tables with 32 distractors (seeds 2026 / 7 /
    /// 11: 0.589 / 0.485 / 0.536 → 0.622 / 0.500 / 0.525), but lost one ycbv-boxes box
    /// (AP@0.5 1.000 → 0.950) and shelves (0.545 → 0.476, seed 2026); 35 lost the same ycbv box.
    pub normal_cut_deg: f64,
    /// The colour patches (the segmentation that separates flush cartons by colour and seams)
    /// cut at a crease only where the normals change by more than `normal_cut_deg` plus this
    /// many degrees per metre of depth beyond `patch_normal_cut_from_mm`, up to
    /// `patch_normal_cut_max_deg`. Consumer depth noise grows about as z² while the normals'
    /// baseline (`normal_radius_cells`) grows as z, so beyond a metre or two noise alone makes
    /// 30° creases inside flat carton tops, and their colour patches fell apart into pieces too
    /// small to keep; colour and seams still cut the patches there. The surfaces and objects
    /// keep `normal_cut_deg`. Default 10 (mask AP@0.5 of `detect_dev`, seed 2026, 24 views:
    /// pallets 0.783 → 0.809, shelves 0.808 → 0.825; see the README for the bench). 0 disables.
    pub patch_normal_cut_deg_per_m: f64,
    /// Depth beyond which the colour patches' normal cut grows, mm. Default 1000.
    pub patch_normal_cut_from_mm: f64,
    /// Largest normal cut of the colour patches, degrees (a box fold is 90°). Default 60.
    pub patch_normal_cut_max_deg: f64,
    /// Colour change across a pair of cells (compared one cell outside, on 3×3-smoothed colour)
    /// that separates regions, RGB levels. Default 12.
    pub colour_cut: f64,
    /// A pixel darker than both pixels two to either side (row or column) by more than this is
    /// on a thin dark line (seam between flush cartons, printed edge), luminance levels; 0
    /// disables seams. Default 3 (1.5 σ of the generated images' sensor noise; averaging
    /// along the line and the relative test below keep most noise out, and a stray seam cell
    /// only leaves a hole in a region, while a missed one lets two cartons merge; 12 missed
    /// the creases of dark cartons, about 7 levels deep).
    pub seam_valley_levels: f64,
    /// ... and darker by at least this fraction of their brightness. Default 0.05 (cardboard
    /// grain varies by up to 6 %, but in short stripes that do not cut a face in two).
    pub seam_valley_rel: f64,
    /// Thin bright lines count as seams too, with the same thresholds: where a stacked layer
    /// is set back, the lower carton's lit top shows as a sliver. Default true.
    pub seam_ridges: bool,
    /// A grid cell with at least this many seam pixels separates regions. Default 1.
    pub seam_min_pixels: u32,
    /// Gaps in seam lines up to `2 r − 1` cells long are bridged (a cell between seam cells
    /// within `r` on both sides, along a row, column or diagonal, with no seam cell beside it
    /// across that line, becomes one): creases 1–2 px wide alias into dashed lines, and one
    /// gap merges two flush cartons. 0 disables. Default 1 (`detect_dev`, 30 views: 2 gained
    /// a little more pallet mask AP on seeds 7 and 11 but lost on tables, seed 7 0.769 →
    /// 0.743; it also bridges between nearby parallel lines and print).
    pub seam_close_cells: u32,
    /// Colour patches are cut along straight seam lines of at least this many seam cells
    /// (see `lines`: Hough lines through the seam cells around a patch, gaps bridged, carried
    /// on to the patch's rim) where that leaves pieces of `min_region_cells`: the dashed
    /// joints between flush cartons, through whose gaps a stack's fronts merged. 0 disables.
    /// Default 10 (bench, 24 views, AP@0.5 against 0: pallets 0.577 → 0.638, 0.423 → 0.535,
    /// 0.302 → 0.506 on seeds 2026 / 7 / 11; tables and shelves within ±0.02; 7 and 14 no
    /// better).
    pub seam_line_min_cells: u32,
    /// Gaps along a seam line that are bridged, and how far past its last seam cells it is
    /// carried, cells. Default 6 (4–14 were within ±0.03 on pallets; 20 lost on shelves).
    pub seam_line_gap_cells: u32,
    /// A seam line's cells cover at least this fraction of its span. Default 0.5 (0.25–0.7
    /// within ±0.03 on pallets).
    pub seam_line_density: f64,
    /// A seam cell votes for a patch's seam lines when it touches the patch (8-neighbours) or
    /// when patch cells lie on both sides of it within this many cells along a row, a column
    /// or a diagonal (1: touching cells only). The cells beside a joint are often unlabelled
    /// too, so a joint through a patch can run a cell away from it, and only the seam cells
    /// at its gaps touched it. Default 2 (six-seed 48-view bench, mean AP@0.5 of the 30 sets
    /// 0.7345 → 0.7349: pallets 0.7658 → 0.7678, seed 5 0.683 → 0.715 (white cartons whose
    /// joints were flanked so), seed 3 0.775 → 0.755 (dashed flap seams cut, their halves
    /// not rejoined), tables unchanged, shelves −0.0002; every seam cell within 2 cells of
    /// the patch instead lost on seed 2026: mean of its 5 sets 0.7768 → 0.7698).
    pub seam_line_reach_cells: u32,
    /// Faint seams in a side face's luminance profile (`profiles`): the mean luminance
    /// (levels, 0..255, the mean of the three channels) of the pixels in a bin one pixel wide
    /// along a straight line across a planar colour patch must lie this far below the mean of
    /// the bins 2–3 bins to either side (and below both); 0 disables. Default 1.5.
    pub profile_seam_min_dip: f64,
    /// ... and this fraction of their brightness below them. Default 0.02.
    pub profile_seam_min_rel: f64,
    /// ... and this many times the profile's roughness (1.4826 × the median absolute
    /// deviation of the same dip statistic over all its bins) beyond its median: cardboard
    /// grain and print make every bin a small dip or bump, a seam stands out of them.
    /// Default 6 (seed 2026: joints between stacked cartons at 6–14, grain on dark faces
    /// up to 3.3).
    pub profile_seam_min_z: f64,
    /// The seam's bin and the bins beside it differ in chromaticity (each channel's share of
    /// their sum) by at most this: a joint darkens the carton's own colour, a printed stripe
    /// changes it. Default 0.03.
    pub profile_seam_max_chroma: f64,
    /// Narrowest bin of the profile, mm (a joint between two cartons is 3–6 mm wide; at arm's
    /// length a pixel is under 1 mm). Default 2.
    pub profile_seam_bin_mm: f64,
    /// A faint seam lies at least this far inside the patch, mm. Default 40.
    pub profile_seam_min_piece_mm: f64,
    /// Of the four quarters of the seam's length, this many (of at least three that can be
    /// measured) must each show 40 % of the dip, below both sides. Default 3.
    pub profile_seam_quarters: u32,
    /// Patches whose normal lies within this angle of up (the floor's normal, else
    /// `support_up_hint`) are tops and are not cut at faint seams, degrees; with neither, no
    /// patch is. Default 45.
    pub profile_seam_top_deg: f64,
    /// Tape and printed bands narrower than this that cut a face in two are bridged (the two
    /// halves become one region), mm; 0 disables. Default 90 (tape is 40–60 mm wide). Before
    /// `tape_min_contrast`, 60–70 raised the 48-view pallet rows by 0.015–0.033 by leaving
    /// such strips of a face's own colour (80 mm wide) unbridged, but would not bridge 72 mm
    /// (3") tape; with the contrast test 65 changes nothing.
    pub tape_max_width_mm: f64,
    /// ... and only a strip whose mean colour differs from the mean of the two halves' by at
    /// least this, RGB levels: tape and printed bands stand out from the face they cross, but
    /// seam lines also cut strips of a face's own colour, such as the halves either side of
    /// the joint between two rows of cartons, and bridging those joined the rows. Default 15
    /// (0 bridges any strip). Bench, 48 views, seeds 2026 / 7 / 11, AP@0.5 against 0, when
    /// the default was 25: pallets 0.563 / 0.605 / 0.526 → 0.595 / 0.635 / 0.531, shelves
    /// 0.559 / 0.551 / 0.465 → 0.562 / 0.559 / 0.474, tables within ±0.006 (mean of the 15
    /// rows 0.6222 → 0.6284); 12 gave 0.6280 and 40 0.6257 (pallets 0.574). Since then the
    /// rules that pair tape with its halves have grown, and 15 against 25 (seeds 2026 / 7 /
    /// 11 / 3 / 5 / 13, with `blob_upright_fallback`) raised the mean from 0.7042 to 0.7055,
    /// every seed up (pallets +0.0017, shelves +0.0039, tables +0.0003 to +0.0005): a
    /// darker printed band 19 levels from its face now bridges (seed 2026's 48-view shelf
    /// view 47).
    pub tape_min_contrast: f64,
    /// Bridged halves differ in mean colour by at most this, RGB levels. Default 25.
    pub tape_colour_delta: f64,
    /// Bridged halves overlap along the strip by at least this fraction of the longer.
    /// Print or noise cuts a half into pieces, each shorter than the other half: in a pallet
    /// view, a top's near half in two pieces (127 and 220 cells) overlapped the far half by
    /// 0.58 and 0.68 of it, and the carton lost its top. Default 0.5, with
    /// `corner_alternatives` (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5
    /// of the 15 rows: 0.7 0.6757, 0.5 0.6794; pallets 0.6652 → 0.6710, tables 0.7363 /
    /// 0.7213 / 0.6963 → 0.7403 / 0.7255 / 0.7003; the mean rose on every seed. Without
    /// `corner_alternatives`, 0.35 gave 0.6790 against 0.6779 at 0.5, less evenly by seed,
    /// and 0.85 gave 0.6712).
    pub tape_overlap: f64,
    /// A strip's sides are the regions it meets along rows and columns within a few cells,
    /// looking past regions of fewer cells than this (slivers): a tape's edge or shading
    /// makes patches of a few dozen cells along it, and where they lay between the tape and
    /// one half, that half was no side of the tape and the top stayed in two halves. 0 looks
    /// past none. Default 128 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5
    /// of the 15 rows: 0 0.6989, 32 0.7005, 64 0.7010, 128 0.7014, 256 or more 0.7012;
    /// pallets 0.6880 → 0.6912, shelves 0.5675 → 0.5753, tables +0.0003 to +0.0007; the
    /// mean rose on every seed).
    pub tape_sliver_cells: u32,
    /// ... and within this many grid cells of it along rows and columns: the far half of a
    /// top can lie past a tape's shaded edge and a sliver. Default 10 (bench, 48 views, seeds
    /// 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 rows: 4 0.6825, 6 0.7014, 10
    /// 0.7022, 14 0.7024; pallets 0.6912 → 0.6935 from 6 to 10, and no seed's mean fell,
    /// while 14 lowered seeds 7 and 13 by up to 0.0012).
    pub tape_side_gap_cells: u32,
    /// A strip is bridged whatever the tilt of its own fitted plane (the halves must still be
    /// one plane, and the strip lie in it) when it runs along at least this fraction of the
    /// halves' overlap; shorter pieces must also be coplanar with the halves by their own
    /// fit, as every strip was before. A tape a few cells wide fits a plane tilted about its
    /// axis by depth noise, which left taped tops in two; a short piece's axis is as unsure,
    /// and with any length (0) a piece cut off at the joint between two cartons bridged the
    /// far half of one top to the near half of the next (seed 2026, pallet view 40). Default
    /// 0.4 (bench, 48 views, six seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 against 0:
    /// pallets 0.6550 → 0.6573, tables −0.001, shelves −0.001, all from one box of seed 13
    /// whose bridge was a strip perpendicular to the top; 0.25: as 0).
    pub tape_tilted_min_length: f64,
    /// ... and no strip's own plane may lie further than this from the halves', degrees:
    /// depth noise tilts a strip a few cells wide (bridged strips, seed 2026, 48 pallet and
    /// 48 table views: 143 of 159 within 15°, 15 at 15–45°, a few beyond), while the lit
    /// sliver of a lower carton's top between the fronts of two stacked cartons lies at
    /// 93–120° and bridged them (seed 2026, pallet view 19 of 24). Default 75 (bench, 48
    /// views, six seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 against no limit: pallets
    /// 0.6620 → 0.6627, tables +0.0001 to +0.0004, shelves unchanged; 45: pallets 0.6605, as
    /// it also kept out printed bands across side faces seen at a grazing angle).
    pub tape_strip_max_tilt_deg: f64,
    /// ... and no strip is bridged to a side whose edge along it is lined with seam cells:
    /// of the walks across the strip into that side (from each strip cell, along the grid
    /// direction most across the strip, through at most `tape_side_gap_cells` unlabelled
    /// cells to the first labelled one), at least `tape_joint_min_walks`, at least this share
    /// pass a seam cell (the strip's own cell not counted, the side's first cell counted). A
    /// band printed at a carton's bottom edge meets the joint to the carton stacked flush
    /// below it, and bridged, it joined the two cartons' fronts into one face (seed 19,
    /// pallet view 28: three layers of banded cartons, the top carton's mask half in the one
    /// below; without bands, held-out pallets rose by 0.018). Tape and bands end at colour
    /// steps, which are not seam lines. 0 disables. Default 0.8 (bench, 48 views per set,
    /// mean AP@0.5 against 0: pallets 0.8075 → 0.8095 on seeds 2026 / 7 / 11 / 3 / 5 / 13
    /// and 0.7697 → 0.7769 on 17 / 19 / 23 / 29 / 31 / 37, shelves 0.6071 → 0.6060 and
    /// unchanged, tables within ±0.0004, all sets 0.7474 → 0.7476 and 0.7261 → 0.7273; 0.5
    /// with 6 walks and the strip's own cell counted: pallets 0.8093 / 0.7778, shelves
    /// 0.6040 / unchanged).
    pub tape_joint_min_share: f64,
    /// See `tape_joint_min_share`: fewer walks into a side say nothing. Default 10 (6 let a
    /// 6-walk contact through a dark sliver between two cartons' fronts stop a bridge on
    /// seed 3's shelves, 0.599 → 0.586).
    pub tape_joint_min_walks: u32,
    /// Regions with fewer cells are dropped (noise, edge bands); also the smallest piece a
    /// seam line may cut off a colour patch. Default 12 (bench, 48 views per set, seeds 2026 /
    /// 7 / 11, mean AP@0.5 of the 15 rows against 20, the default before: 0.6479 → 0.6523;
    /// 8: 0.6515, 16: lower on seeds 2026 and 7).
    pub min_region_cells: u32,
    /// Plane tolerance, constant part, mm. Default 4.
    pub plane_tol_abs_mm: f64,
    /// Plane tolerance, quadratic part: mm per (z in metres)². Default 6 (≈ 3σ of a D435 at 1 m
    /// is 12 mm; Kinect-like sensors are better).
    pub plane_tol_quad_mm: f64,
    /// A face needs at least this fraction of its cells within the plane tolerance. Default 0.8.
    pub min_plane_inlier_frac: f64,
    /// A face's cell normals may deviate from its plane normal by this much on average, degrees
    /// (curved surfaces deviate more). Default 25.
    pub max_normal_spread_deg: f64,
    /// A face's two halves (split across either in-plane principal axis) have plane normals
    /// within this angle, degrees: spheres and cylinders bend, planes do not. Default 10
    /// (8 before the flap-seam check and per-face extents; 10 is better on both seeds).
    pub max_bend_deg: f64,
    /// Beyond this depth, `max_bend_deg` grows with the plane tolerance (`plane_tol_abs_mm`,
    /// `plane_tol_quad_mm`): far faces are noisy enough that their halves' plane fits part by
    /// more than a near face's. A dark carton at 2.6 m seen by the RealSense model bent by
    /// 11–17° and was no face (at 2.6 m the limit is now 16°, with the tolerances' defaults).
    /// The curved-surface veto uses the same limit. 0 keeps `max_bend_deg` at every depth.
    /// Default 2000 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15
    /// rows against 0: 0.6802 → 0.6811, pallets 0.6743 → 0.6787 with no row lower on any
    /// seed; 1500 gave 0.6813 but shelves −0.011 on seeds 7 and 13; a flat 14° limit at every
    /// depth lost 0.013 on the tables with 32 distractors, letting round ones in).
    pub bend_ref_depth_mm: f64,
    /// A half of a region (for the bend test of `max_bend_deg`) is a strip when its
    /// in-plane spread across is under this fraction of its spread along (second eigenvalue
    /// of its points' covariance over the largest): a strip's plane may turn about its length
    /// at random, so in a region of at least `bend_strip_min_cells` the split giving it is
    /// left out. 0 disables. Default 0.05 (a strip about 4.5 times longer than wide; see
    /// `bend_strip_min_cells` for the measurement).
    pub bend_strip_max_ratio: f64,
    /// Regions of at least this many cells leave splits with a strip for a half out of their
    /// bend (`bend_strip_max_ratio`); smaller ones keep them. Why: on a pallet of flush
    /// cartons with tape across their tops, the top of the front row and its tape band are one
    /// colour patch, half of it a strip, whose halves' planes part by 17–20°: no face, so the
    /// tops were lost (seed 7, pallet view 47: 5 of 6 cartons). A small region with a strip
    /// for a half is mostly a tape band or an edge seen at a grazing angle, and better no face.
    /// A region over about 9 times longer than wide has strips for halves both ways and no
    /// bend: a long, gently curved strip is left to `max_normal_spread_deg`. Default 800
    /// (bench, 48 views per set, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 rows
    /// against the test without strips left out: 0.7440 → 0.7464; pallets 0.7948 → 0.8035,
    /// tables +0.0003 / +0.0007 / +0.0005 with 0 / 8 / 32 distractors, shelves 0.6037 →
    /// 0.6053, no row down by more than 0.004; AP@0.25 0.8735 → 0.8770. An offline replay
    /// of the same frames gave, with 400, pallets +0.016 but each table set −0.001, and with
    /// no size limit pallets +0.020 but tables −0.005 to −0.009: tape bands became faces and
    /// cut cartons in two).
    pub bend_strip_min_cells: u32,
    /// A lone face touching a curved surface (bent beyond `max_bend_deg`) is part of a round
    /// thing (a cylinder's cap) and dropped, but only when that surface has at least this
    /// fraction of the face's cells: the thin strip of a box's side face seen at a grazing angle
    /// looks bent after smoothing and must not veto the box's big top. Default 0.25 (0 vetoes on
    /// any curved contact, the behaviour before; 0.25 raised mask AP50 on every generated layout,
    /// seeds 2026 and 7, e.g. pallet 0.652 → 0.679, table with 0 distractors 0.745 → 0.767).
    pub curved_veto_min_ratio: f64,
    /// ... and only when that surface's halves are bent by at least this angle, degrees: depth
    /// noise bends a small flat face seen at a grazing angle by 10–15°, and it must not veto the
    /// box's other face. Default 15 (10, i.e. `max_bend_deg`, before; 15 raised detection
    /// AP@0.5 on pallets by 0.026 with seed 2026 and on tables by 0.001–0.008 with seeds 2026,
    /// 7 and 11, and lowered three of the fifteen rows by at most 0.002; 20 and 30 gained less).
    pub curved_veto_min_bend_deg: f64,
    /// A curved surface does not veto a top it lies on: where the support's up is known, a
    /// face within `halves_top_max_tilt_deg` of it that touches no perpendicular face (a top
    /// seen alone), larger than the curved surface, with at least this share of the curved
    /// surface's cells within a plane tolerance of the top's plane. A tape band across a
    /// carton's top looks bent (its narrow halves' normals are noise) but lies on the top
    /// (seed 83, 48-view pallet view 45: seven flush cartons' tops were vetoed by the tapes
    /// between them, 0.76–0.98 of whose cells lie on the tops' planes); a cylinder's mantle
    /// leaves its cap's plane, a sphere's ring lies behind its flat-looking patch. Where the
    /// top touches a side face, the group reads the box, and the lone top would only compete
    /// with it, its thickness guessed. Above 1 every curved contact vetoes, as before.
    /// Default 0.75 (bench, 48 views, six seed groups of six seeds against above 1:
    /// pallets +0.0030 / −0.0001 / −0.0003 / +0.0048 / +0.0005 / +0.0048, seed 83 +0.023;
    /// tables −0.0010 to +0.0005 per group, shelves 0 to +0.0005; every face spared, as the
    /// first version: tuning seeds −0.0007, seed 13's pallets −0.014, a lone top
    /// outranking its own group; share 0.9 in that version no better on seed 13).
    pub curved_veto_max_on_plane: f64,
    /// Planar regions at least this large are support candidates (floor, table top, shelf board,
    /// wall), mm². Default 250 000 (0.25 m²).
    pub support_min_area_mm2: f64,
    /// Smaller planar regions, down to this area, are supports only when things stand on them
    /// and no support lies beneath them (a desk seen from close by, not a box top), mm².
    /// Default 60 000 (0.06 m²).
    pub support_small_area_mm2: f64,
    /// Planar surfaces at least this large are always supports (floors, walls), mm².
    /// Default 2 000 000 (2 m²; a full EUR-pallet face is 1.4 m²).
    pub support_always_area_mm2: f64,
    /// Things standing on a support candidate: cells between `support_side_margin_mm` and this
    /// far in front of its plane, mm. Default 600.
    pub support_window_mm: f64,
    /// See `support_window_mm`, mm. Default 30.
    pub support_side_margin_mm: f64,
    /// A support candidate is a support when the cells standing on it (over its convex
    /// footprint) number at least this fraction of its own cells. Default 0.05.
    pub support_min_front_fraction: f64,
    /// A large support candidate that things stand on is no support but a layer of cartons
    /// (their tops, flush) when it lies over an accepted support and the cells under its rim
    /// number at least this fraction of its own cells: cells between
    /// `support_layer_min_depth_mm` and `support_layer_max_depth_mm` below its plane, within
    /// `support_side_margin_mm` (plus a plane tolerance) of its convex footprint's edge. The
    /// cartons' faces go on down under a layer's rim; a table top or a shelf board is a
    /// board, with open space or another thing's top farther below. 0 disables. Default 0.05
    /// (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 rows against
    /// 0: 0.6794 → 0.6802, pallets 0.6710 → 0.6743 (+0.012 on seed 2026, +0.008 on seed 3,
    /// none lower), tables unchanged, shelves 0.5600 → 0.5605 (seeds 7 +0.009, 5 −0.003); 0.1
    /// the same, 0.2 0.6798. In seed 2026's 48 views, the large standing candidates of the
    /// tables measure at most 0.006, a layer of pallet view 19 0.134, shelf boards up to 0.6:
    /// some shelf boards are not held by this, which the shelves' figures show).
    pub support_layer_min_fraction: f64,
    /// The same layer test for the planes that RANSAC finds (`support_ransac_planes`), with
    /// this fraction of the plane's cells under its rim. Lower than
    /// `support_layer_min_fraction`: such a plane takes in every coplanar cell of the frame
    /// (a whole layer's tops, the stacks beside it), so its rim is a smaller share. Seen
    /// from above, a layer with one carton standing on it was a RANSAC support plane, and
    /// its cartons vanished with it (seed 13, 48-view pallet view 39: four cartons, mask IoU
    /// 0 → 0.55–0.62). 0 disables (RANSAC planes are then never layers). Default 0.01 (bench,
    /// 48 views, six seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 rows against 0:
    /// 0.7064 → 0.7073; pallets 0.6973 → 0.7038, shelves 0.5783 → 0.5762 (a shelf board
    /// with a beam under its front, seed 3 view 15), tables within ±0.0002; 0.0167 and
    /// 0.0042 the same, 0.05 pallets 0.6990; comparing the hue of the cells under the rim
    /// with the plane's did not keep the shelf boards without losing pallets).
    pub support_layer_ransac_min_fraction: f64,
    /// See `support_layer_min_fraction`, mm. Default 60.
    pub support_layer_min_depth_mm: f64,
    /// See `support_layer_min_fraction`, mm. Default 150.
    pub support_layer_max_depth_mm: f64,
    /// A support candidate with fewer than this fraction of the frame's valid cells behind
    /// its plane bounds the scene (floor, wall) and is a support. Default 0.02.
    pub support_max_behind_fraction: f64,
    /// When true, "up" (the direction things stand along) is the normal of the largest plane
    /// that bounds the scene or has things standing on it; false: of the largest plane that
    /// bounds the scene (a wall behind a table then makes the table top a non-support).
    /// Default true (it makes such table tops supports; AP50 within ±0.003 of false on seeds
    /// 7 and 2026 when introduced). See also `support_up_hint`.
    pub support_up_from_standing: bool,
    /// Which way is up, roughly, in camera coordinates (x right, y down, z forward; any
    /// length; `[0, 0, 0]`: no hint). "Up" is taken only from a plane whose camera-facing
    /// normal lies within `support_up_max_angle_deg` of it; when none does, from any plane.
    /// Default `[0, -1, 0]`, the image's up, for a camera held upright: a wall behind a table,
    /// seen from above, faces the camera and *down* the image, and, larger in view than the
    /// table, was taken for the floor (the table top then came out as a box). Among the
    /// planes within the angle, the one with the largest area seen along the hint (area ×
    /// cos of its angle to the hint) wins: a shelf's back wall at 78°, larger in view than the
    /// floor, made the cartons flush with the shelf's front "stand" on it and vanish as
    /// supports (seed 2026, shelves, 48 views: AP@0.5 0.536 → 0.540, AP@0.7 0.331 → 0.340;
    /// every other set of seeds 2026 / 7 / 11 unchanged). A robot that knows gravity in its
    /// camera frame can pass it here.
    pub support_up_hint: [f64; 3],
    /// See `support_up_hint`, degrees. Default 80: floors seen from up to 80° of elevation
    /// qualify (a floor's normal lies at the camera's elevation angle from the image's up);
    /// from straight above no plane does, and "up" falls back to the largest one, as without
    /// a hint. A shelf's back wall (about 85° off) is ruled out too. Bench, 24 views, AP@0.5
    /// against no hint, seeds 2026 / 7 / 11: tables +0.000 to +0.034, shelves +0.000 to
    /// +0.004, pallets unchanged (at 100° the back wall qualified on some shelf views and
    /// became up: `detect_dev`, seed 2026, 3 fewer good shelf boxes of 193).
    pub support_up_max_angle_deg: f64,
    /// Dominant planes sought by RANSAC over all cells (floors and tables cut into pieces by
    /// noise or texture). Default 3.
    pub support_ransac_planes: u32,
    /// RANSAC hypotheses per plane. Default 150.
    pub support_ransac_iters: u32,
    /// A cell belongs to a support plane when its normal is within this angle of the plane's,
    /// degrees. Default 20.
    pub support_normal_tol_deg: f64,
    /// A cell belongs to a support plane when within this multiple of the plane tolerance
    /// (and single-face candidates within it are support fragments; RANSAC counts inliers
    /// within it). Default 1.5: at 1.4–1.6 m, 2.5 tolerances (the default before) are 39–50
    /// mm, and that band took in up to half of some boxes' visible masks (seed 7 shelves, 48
    /// views: four boxes whose shortest side is 84–153 mm, with 20–51 % of their mask on a
    /// support, went from 3D IoU ≤ 0.43 to ≥ 0.82). Bench, 48 views per set, seeds 2026 / 7 /
    /// 11, mean AP@0.5 of the 15 rows against 2.5: 0.6437 → 0.6479 (shelves +0.010, pallets
    /// +0.004); 2.0: 0.6449, 1.2: 0.6474, 1.0: 0.6472.
    pub support_tol_factor: f64,
    /// Faces need at least this many cells. Default 25.
    pub min_face_cells: u32,
    /// Two faces touch when their cells are at most this many cells apart along a row or
    /// column (the edge band between them is unlabelled). Default 12.
    pub contact_gap_cells: u32,
    /// Contact cells must be near in 3D and near the other face's plane (a shared edge, not an
    /// occlusion boundary), within this multiple of the plane tolerance. Default 3.
    pub edge_tol_factor: f64,
    /// Two faces are adjacent with at least this many contacts. Default 3.
    pub min_contact_cells: u32,
    /// Faces of one box are perpendicular within this angle, degrees. Default 15.
    pub perpendicular_tol_deg: f64,
    /// Convex edge: each face's centroid lies at least this far behind the other's plane, mm.
    /// Default 5.
    pub convex_margin_mm: f64,
    /// Two faces of one box share an edge: their extents along it agree within this ratio
    /// (shorter / longer; partly occluded faces are shorter). Default 0.4.
    pub edge_length_ratio: f64,
    /// Colour-level faces are grouped greedily, and a face joins a group only when it fits
    /// every face there it touches (`edge_length_ratio` included). A face mostly hidden
    /// touches a third face of its box at the corner only, where the shared edge is short on
    /// it: a carton's narrow visible top touched its front over 59 mm of a 506 mm edge, and
    /// the carton lost its top. With this on, a merge refused only by such a contact (the
    /// pair is convex, perpendicular faces) still yields the faces together as one more
    /// candidate, scored like any other: the better reading wins in selection. Surfaces are
    /// left alone (a surface-level alternative joining two stacked cartons outscored the
    /// cartons). Default true.
    pub corner_alternatives: bool,
    /// Colour can cut a strip off a face (a band of tape or print along a carton's edge).
    /// Grouped first, the strip keeps the face it belongs to out of the group: in a table
    /// view a carton's top took a 114-cell strip of its front, the front itself (1279 cells)
    /// was then refused as parallel to the strip, and the carton came out as its top and the
    /// strip, 36 mm deep. With this on, a face refused only because one face of the group is
    /// parallel to it yields one more candidate where the two are one face, when they touch,
    /// are coplanar and the smaller is a strip of the larger (at most half its cells and no
    /// wider than `tape_max_width_mm` across); each face of that candidate also takes in the
    /// strips coplanar with it that it touches. Every two faces must still share an edge of
    /// about the same length (`edge_length_ratio`). Colour level only. Default true (bench,
    /// 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 rows: 0.6811 →
    /// 0.6817, the three table rows of seed 7 +0.006 each, every other row the same; joining
    /// any coplanar region, not strips only, cost seed 7's pallets 0.035: a layer's flush
    /// tops joined into one box).
    pub coplanar_alternatives: bool,
    /// Colour-level groups of two or three faces also yield one more candidate each, with the
    /// strips coplanar with their faces that those faces touch taken in (as
    /// `coplanar_alternatives` takes them in: at most half the face's cells, no wider than
    /// `tape_max_width_mm`, every two faces still sharing an edge of about the same length),
    /// when there are any: a band of tape or print along an edge, left out of the group, cut
    /// the cuboid short. Scored like any other; the better reading wins. Default true (bench,
    /// 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 rows: 0.6830 →
    /// 0.6879, every seed higher; pallets 0.6787 → 0.6847, shelves 0.5605 → 0.5687, tables
    /// +0.003 / +0.003 / +0.005).
    pub strip_alternatives: bool,
    /// With `strip_alternatives` on, colour-level groups of two or three faces also yield one
    /// more candidate each (after the strips, where there were any), in which each face takes
    /// in, repeatedly, the coplanar regions it touches that are no wider than
    /// `tape_max_width_mm` across and run the whole length of every edge the face shares with
    /// another face of the group (`edge_length_ratio`), whatever their size: the rest of a
    /// carton's top that tape or a grazing view cut into bands parallel to its front edge,
    /// which left the group a front with a sliver of top and the cuboid a third of its depth.
    /// Every two faces must still share an edge of about the same length. Scored like any
    /// other; the better reading wins. Default true (bench, 48 views, seeds 2026 / 7 / 11 /
    /// 3 / 5 / 13, mean AP@0.5 of the 15 rows: 0.6972 → 0.6989; pallets 0.6840 → 0.6880,
    /// tables +0.001 / +0.0016 / +0.002, shelves −0.0007. Without the whole-length rule
    /// 0.6988, with the regions' colours also within `tape_colour_delta` 0.6983, with no
    /// region larger than the face's largest 0.6971.)
    pub band_alternatives: bool,
    /// With `strip_alternatives` on, colour-level groups of two or three faces also yield one
    /// more candidate each in which a face that is only a band (no wider than
    /// `tape_max_width_mm` across, all its regions together) takes in the wider coplanar
    /// region it touches most, of any size, while every two faces still share an edge of
    /// about the same length: the rest of a carton's front that a printed line or a tape band
    /// near its top edge cut off, which left the group a top with a sliver of front, about
    /// 50 mm deep. Scored like any other; the band reading is scored down
    /// (`band_open_factor`). Default true (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13,
    /// mean AP@0.5 of the 30 rows: 0.7136 → 0.7184, AP@0.7 0.5564 → 0.5618; pallets 0.7260 →
    /// 0.7435, tables +0.002 to +0.003, shelves the same. Testing each region for narrowness
    /// rather than the face as a whole grew tops already bridged whole into the next carton:
    /// 0.7182).
    pub band_face_alternatives: bool,
    /// See `band_face_alternatives`: a group one of whose band faces grows so is scored this
    /// times its own score, since that band ends at a line across the face rather than at an
    /// edge of the box; otherwise the flat reading (a top and a band, often with a sliver of
    /// side as a third face) outscores the whole one. 1 leaves it as it was. Default 0.6
    /// (mean AP@0.5 as above: 1 0.7161, 0.6 0.7184, 0.4 0.7184).
    pub band_open_factor: f64,
    /// See `band_face_alternatives`: a face is a band when it is no wider than this across,
    /// mm. Default 90, as `tape_max_width_mm` (mean AP@0.5 as above: 60 0.7168, 130 0.7161
    /// with tables +0.002 and pallets 0.7272, 110 0.7192, 100 0.7198 with every set up or
    /// the same; 100 was not taken because shelf frames then took 100.6, 102.9 and 90.9 ms
    /// median in three README bench runs against 94.8 and 94.6 at 90, too near the 100 ms
    /// target on this VM).
    pub band_face_max_width_mm: f64,
    /// Each face of a colour-level group of two or three faces that scores as no box, where
    /// some face of it is no box alone either (a top spanning two flush cartons, joined to
    /// one of their fronts: too wide), is scored alone too, since grouping took it from every
    /// other candidate. Default true (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean
    /// AP@0.5 of the 30 rows 0.7271 → 0.7274: pallets 0.7582 → 0.7595, no row lower. Also at
    /// the surface level, a lone surface face displaced cartons' colour patches in `select`:
    /// 994 of the six seeds' 1316 pallet cartons found at 3D IoU > 0.5 by `detect_dev`,
    /// against 999 at the colour level only and 994 without).
    pub lone_faces_of_failed_groups: bool,
    /// Extents are measured between these quantiles of the points (and 1 − it). Default 0.02.
    pub extent_quantile: f64,
    /// Extents of a two- or three-face candidate are the union of each face's robust range
    /// (`extent_quantile` per face) instead of quantiles over all its points, which cut a
    /// narrow side face (a flat carton's rim) and made the box look paper-thin. Default true.
    pub per_face_extents: bool,
    /// Candidates with an observed dimension above this are rejected (pallets, shelf beams,
    /// walls, whole pallet loads), mm. Default 800.
    pub max_box_extent_mm: f64,
    /// Candidates with an observed dimension below this are rejected (too small to estimate),
    /// mm. Default 25 (the benchmark's smallest boxes are 40 mm).
    pub min_box_extent_mm: f64,
    /// Depth consistency: a cell inside the cuboid's silhouette that the sensor sees this far
    /// (plus twice the plane tolerance) behind the cuboid's surface is a see-through violation,
    /// mm. Default 10.
    pub see_through_margin_mm: f64,
    /// Cells inside a candidate's silhouette that lie nearer than its cuboid by more than the
    /// see-through margin (`see_through_margin_mm` plus twice the plane tolerance) are
    /// occluders: left out of the silhouette IoU, as unlabelled cells are, instead of counted
    /// against it. A box with another lying on it or standing before it is seen with a bite
    /// out of its silhouette, which says nothing of its shape. Default true (bench, 48 views
    /// per set, seeds 2026 / 7 / 11, mean AP@0.5 of the 15 rows 0.6381 → 0.6437, 13 rows up;
    /// seeds 3 / 5, not used to choose it, 0.6165 → 0.6277, all 10 rows up).
    pub occluders_unknown: bool,
    /// Score factor for a single visible face (its thickness is unseen, and flat clutter is
    /// one face too). Default 0.45 (0.7 before: lone faces, most of the false positives, then
    /// ranked above true multi-face boxes; 0.45 raises AP50 on every synthetic layout).
    pub one_face_factor: f64,
    /// A single-face candidate needs at least this silhouette IoU with its fitted rectangle
    /// (a disc reaches π/4 ≈ 0.79). Default 0.84.
    pub min_one_face_iou: f64,
    /// ... and at least this corner occupancy: the share of its cells in the four corner
    /// squares of its fitted rectangle (both in-plane coordinates beyond 3/4 of the
    /// half-extents), over the share a full rectangle puts there. A rectangle scores about 1,
    /// even with holes (seams, labels); a disc 0, as its rim passes inside the corners. The
    /// silhouette IoU alone let the caps of flat tins through: unlabelled edge bands in the
    /// corners count neither way. Default 0.2 (generated lone faces of boxes: 0.2–1.3; tin
    /// caps: 0.00–0.05).
    pub min_one_face_corners: f64,
    /// The largest face of a group of two or three faces, if it has at least
    /// `face_corners_min_cells` cells, needs at least this corner occupancy (as
    /// `min_one_face_corners`, in the face's own rectangle along the group's other two axes,
    /// measured to its full extents): an upright tin reads as its cap, a disc, and a band of
    /// its mantle. 0 disables. Default 0.05 (faces of groups, `detect_dev`, seed 2026, 24 tables
    /// without distractors: 0.6 % below 0.05, 3 % below 0.2; the tins' caps looked at:
    /// 0.00–0.18; 48-view bench, seeds 2026 / 7 / 11: clear false positives on the tables with
    /// 32 distractors 204 / 201 / 189 → 184 / 186 / 172; six seeds' mean AP@0.5 of that row
    /// 0.686 → 0.688. Testing every face of the group lost boxes: tables without distractors
    /// AP@0.5 −0.005 at 0.05, −0.016 at 0.2; the largest face at 0.2, −0.004).
    pub face_min_corners: f64,
    /// See `face_min_corners`, cells. Default 40.
    pub face_corners_min_cells: u32,
    /// A single-face candidate is dropped when more than this fraction of the valid cells in
    /// a 3-cell ring around it lie in front of its plane (continued to them) by more than
    /// twice the plane tolerance: it is background framed by nearer things (a patch of wall
    /// between shelf boards and uprights), not a box's face, which stands in front of its
    /// surroundings. Default 0.5 (generated shelves, seeds 2026 / 7: false positives 184 → 166
    /// and 164 → 153 with the same true positives; 0.3–0.4 began to cost true boxes).
    pub max_framed_fraction: f64,
    /// A single-face candidate whose mask covers fewer pixels than this (at 640 × 480; scaled
    /// by image area) is dropped: two of its dimensions would be guesses, and such small lone
    /// faces are mostly slivers and clutter. Default 500: the top of a small box lying flat
    /// far off is such a face too (bench, 48 views per set, seeds 2026 / 7 / 11, mean AP@0.5
    /// of the 15 rows against 1000, the default before: 0.6351 → 0.6381, the tables up in all
    /// nine rows; 700: 0.6380, 300: 0.6376; seeds 3 / 5, not used to choose it: 0.6133 →
    /// 0.6165).
    pub one_face_min_pixels: u32,
    /// Evidence: the final score of a detection is its box-likeness times `px / (px + this)`,
    /// `px` its mask's pixel count (at 640 × 480; scaled by image area). A small mask is more
    /// often a partial face, a sliver or clutter, and its box is estimated from fewer points.
    /// It only ranks the output: selection between candidates uses box-likeness alone.
    /// 0 disables. Default 2000 (3D AP@0.5 of the estimates, generated views, seeds 2026 / 7 /
    /// 11, four layouts: higher in 11 of 12 sets, by up to 0.05 on shelves, −0.002 at worst).
    pub evidence_half_pixels: f64,
    /// Score factor for two visible faces (three faces count 1, one face `one_face_factor`):
    /// a box seen on two faces has one edge less to prove it, and more of its pieces and
    /// merges look like it. It weighs both the choice between overlapping candidates and the
    /// detection's rank. Default 0.8 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean
    /// AP@0.5 of the 15 rows: 0.9 0.6950, 0.85 not run, 0.8 0.6972, 0.75 0.6967, 0.7 0.6959; at
    /// 0.8 the mean of the 5 rows rose on five seeds, by up to 0.005, and fell by 0.0006 on
    /// seed 7).
    pub two_face_factor: f64,
    /// Candidates whose box-likeness (before the evidence factor) is below this are dropped.
    /// Default 0.3.
    pub min_score: f64,
    /// The estimator's second try on low scores (`observation.retry_below_score`) on detected
    /// masks ([`crate::config::Config::for_detected_masks`]); alternative readings never get
    /// one (`pipeline::estimate_frame_with_alternatives`): they are more than half of a
    /// frame's masks and score low anyway. Default 0.35 (bench, 48 views, seeds 2026 / 7 / 11 /
    /// 3 / 5 / 13, mean AP@0.5 of the 15 rows: 0 0.7073, 0.2 0.7089, 0.35 0.7098, 0.5 0.7110;
    /// at 0.35 pallets 0.7038 → 0.7093, shelves 0.5762 → 0.5822, tables within ±0.002;
    /// retrying the alternatives too gave the same AP. Frame time, `anybox bench --detect-reps
    /// 5`, seed 2026, 24 views, 2-core VM: shelves 81.2 → 86.3 ms median at 0.35, 94.4 ms at
    /// 0.5; ycbv-boxes 46.2 → 56.2 ms).
    pub estimate_retry_below_score: f64,
    /// Depth-consistency samples per hypothesis (`pose.depth_filter.n_samples`, 1000 on
    /// given masks) for the estimates of detected masks
    /// ([`crate::config::Config::for_detected_masks`]): the whole-frame path has a time
    /// budget. Default 300 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5
    /// of the 30 rows: 1000 0.7373, 500 0.7376, 300 0.7377, 200 0.7372; 500 took 4.4 % fewer
    /// estimator instructions per mask, `valgrind --tool=cachegrind`).
    pub estimate_depth_samples: usize,
    /// Detections (the detector's masks, not given ones) scored below this get no second
    /// try (`estimate_retry_below_score`): they end at the bottom of the ranking whatever
    /// their estimate, and a second try costs a whole estimate. Default 0.2 (same bench, with
    /// the other two settings: 0 0.7386, 0.2 0.7384, 0.3 0.7382, shelves 0.6042 / 0.6033 /
    /// 0.6017; shelf frames of seed 2026's 24 views 105.3 ms at 0, 100.8 at 0.2, 101.9 and
    /// 102.5 at 0.3, README bench, 2-core Intel VM).
    pub estimate_retry_min_detection_score: f64,
    /// PointFit's first re-estimate takes the start's pose as a prior
    /// (`scale.pointfit_free_reestimate` off) on detected masks: with the measured start
    /// (`scale.measured_start`) the start's axes are the box's, and a prior's search is
    /// cheaper. Default on (same bench: alone 0.7373 → 0.7369, with 300 depth samples
    /// 0.7386; 6.7 % fewer estimator instructions per mask alone, 11.9 % with 300 samples).
    pub estimate_prior_reestimate: bool,
    /// Alternative readings of split cartons ([`crate::pipeline::tiled_unions`]): two
    /// estimates that tile one cuboid also give that cuboid, scored this factor times the
    /// lower of their scores; 0 disables. Default 0.3. Bench, 24 views, seeds 2026 / 7 / 11:
    /// AP@0.5 +0.004 to +0.014 on the tables, +0.001 to +0.007 on pallets, +0.000 to +0.003
    /// on shelves, no row lower (0.5: pallets lower; 0.8: pallets −0.016), no estimator run.
    pub tiled_union_score_factor: f64,
    /// A union of two estimates (tiled, across a gap or at a corner) is scaled by this too
    /// when another estimate of the frame, apart from both parts (sharing at most
    /// `tiled_union_max_shared` of the smaller volume), measures like one of the parts
    /// (sorted extents within `repeat_split_tol`) and none measures like the union: the frame
    /// holds whole cartons of the part's size, so the parts are two cartons side by side, not
    /// the halves of one. 1 disables. Default 0.1 (bench, 48 views, six seeds 2026 / 7 / 11 /
    /// 3 / 5 / 13, against 1: mean AP@0.5 of the 30 rows 0.7424 → 0.7436, pallets 0.7870 →
    /// 0.7947 (every seed up, +0.004 to +0.011), tables −0.0004 / −0.0008 / −0.0005,
    /// shelves unchanged; 0.3 and 0 gave 0.7436 and 0.7435, pallets 0.7938 and 0.7948. Of
    /// the unions of seed 7's pallets before, 221 were false positives and 2 true.)
    pub tiled_union_repeated_part_factor: f64,
    /// ... when the parts' axes agree within this angle, degrees. Default 10.
    pub tiled_union_max_angle_deg: f64,
    /// ... and fill at least this fraction of the union's volume. Default 0.83.
    pub tiled_union_min_fill: f64,
    /// ... and share at most this fraction of the smaller part's volume. Default 0.1.
    pub tiled_union_max_shared: f64,
    /// Gap unions ([`crate::pipeline::gap_unions`]): pairs that fill their union by at least
    /// this fraction (and less than `tiled_union_min_fill`) are also joined when the camera
    /// cannot see past the union. At or above `tiled_union_min_fill`: off. Default 0.45.
    pub gap_union_min_fill: f64,
    /// ... when at most this fraction of the union's silhouette (pixels with valid depth) shows
    /// a surface behind the union's front. Default 0.1.
    pub gap_union_max_see_through: f64,
    /// A pixel shows a surface behind the union when its depth exceeds the union's front
    /// there by more than the larger of this, mm (default 25) ...
    pub gap_union_see_through_tol_mm: f64,
    /// ... and this fraction of the front's depth (default 0.01, 1 %: sensor noise grows with
    /// depth).
    pub gap_union_see_through_tol_rel: f64,
    /// Corner unions ([`crate::pipeline::corner_unions`]): pairs that share more than
    /// `tiled_union_max_shared` and at most this fraction of the smaller part's volume (a top
    /// and a front read apart, each with a guessed thickness reaching into the other) are
    /// joined when they fill their union by `corner_union_min_fill` and the camera cannot see
    /// past it (`gap_union_max_see_through`). 0 disables. Default 0.6 (bench, 48 views, seeds
    /// 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 rows 0.7357 → 0.7361, tables
    /// +0.0006 to +0.0009, shelves −0.0002, pallets the same; AP@0.7 0.5698 → 0.5711; 0.8
    /// with `corner_union_min_fill` 0.4: 0.7361; asking for a part with a guessed extent:
    /// the same sets).
    pub corner_union_max_shared: f64,
    /// ... and fill their union (both parts' volume, the shared part counted once) by at least
    /// this fraction. Default 0.5.
    pub corner_union_min_fill: f64,
    /// Repeat readings ([`crate::pipeline::repeat_readings`]): an estimate that is `k` copies
    /// (2 ≤ k ≤ `repeat_split_max_parts`) of another estimate of the frame laid end to end
    /// (parallel axes, two extents equal and the third `k` times, all within
    /// `repeat_split_tol`) also gives those `k` boxes, and one whose third extent is shorter
    /// (down to `repeat_extend_min_ratio`) also gives itself extended to the other's; each
    /// scored this factor times the lower of the two estimates' scores; 0 disables both.
    /// Default 0.3 (bench, 48 views per set, seeds 2026 / 7 / 11, copies only: pallets AP@0.5
    /// 0.546 / 0.471 / 0.513 → 0.598 / 0.481 / 0.544, tables and shelves within ±0.002, mean
    /// AP@0.7 of the 15 rows 0.444 → 0.451; 0.15 gained less, 0.6 less again, 1.0 lost 0.03 on
    /// shelves; with extensions, 0.4 lost 0.001).
    pub repeat_split_score_factor: f64,
    /// ... within this relative tolerance per extent (`|ratio − k| ≤ tol × k`). Default 0.12
    /// (0.08 and 0.18 measured within 0.005 of it on every row).
    pub repeat_split_tol: f64,
    /// ... for at most this many copies. Default 4.
    pub repeat_split_max_parts: u32,
    /// Extensions: the third extent is at least this fraction of the other's (and below 1 −
    /// `repeat_split_tol`); 0 disables extensions. Default 0.15 (bench, 48 views per set,
    /// seeds 2026 / 7 / 11, AP@0.5 against splits alone: pallets 0.598 / 0.481 / 0.544 →
    /// 0.600 / 0.483 / 0.551, shelves 0.539 / 0.464 / 0.556 → 0.546 / 0.466 / 0.559, tables
    /// within −0.001; mean AP@0.7 of the 15 rows 0.451 → 0.453; 0.3 gained a little less).
    pub repeat_extend_min_ratio: f64,
    /// ... when the repeated estimate scores at least this times the split one: a carton's
    /// half, detected on its own and scored far below the whole carton, must not cut it in
    /// two. Default 0.5 (the same AP as no bound, with 20 % fewer copies on pallets and
    /// shelves; 1.0 lost 0.007 on pallets: it also kept out true merges scored a little
    /// above the carton they repeat).
    pub repeat_split_min_reference_ratio: f64,
    /// A repeat reading outranks its source (the two swap scores: the reading takes the lower
    /// of the two estimates' scores, the source `repeat_split_score_factor` times its own)
    /// when at least this many other estimates of the frame have the repeated estimate's size
    /// and none has the source's (sorted extents within `repeat_split_tol`): a frame of
    /// cartons of one size says the odd one out is a merge or a piece. 0 disables. Default 2
    /// (bench, 48 views per set, AP@0.5 against 0: pallets, seeds 2026 / 7 / 11, 0.654 /
    /// 0.578 / 0.587 → 0.667 / 0.579 / 0.608, seeds 3 / 5 0.583 / 0.458 → 0.596 / 0.486;
    /// shelves −0.002 to +0.004, tables unchanged; 1 and 3 gained less, 1 lowered the
    /// shelves).
    pub repeat_promote_min_copies: u32,
    /// An estimate whose size at least this many other estimates of the frame have (sorted
    /// extents within `repeat_split_tol`, the outranked ones left out) scores higher: its
    /// odds `s / (1 − s)` times `repeat_boost_odds`
    /// ([`crate::pipeline::size_consensus_scores`]). Three cartons that measure alike are
    /// seldom all wrong; on a pallet this ranks them above the frame's merges and pieces, and
    /// above other frames' doubtful boxes. 0 disables. Default 2 (bench, 48 views per set,
    /// AP@0.5 against 0: pallets 0.667 / 0.579 / 0.608 → 0.696 / 0.594 / 0.630 on seeds 2026
    /// / 7 / 11 and 0.596 / 0.486 → 0.617 / 0.483 on seeds 3 / 5, shelves −0.005 to +0.001,
    /// tables unchanged; 3: pallets 0.698 / 0.584 on seeds 2026 / 7).
    pub repeat_boost_min_copies: u32,
    /// See `repeat_boost_min_copies`; 1 disables. Default 3 (mean AP@0.5 of the 15 rows of
    /// seeds 2026 / 7 / 11 0.6647; 2: 0.6638; 5: 0.6655, but the shelves of seed 7 0.522 →
    /// 0.516).
    pub repeat_boost_odds: f64,
    /// ... only for boxes whose middle extent is at least this fraction of their longest: a
    /// shelf's rack uprights, 60 × 60 × 300 mm bars seen between boards, repeat one another
    /// as well. Default 0.35.
    pub repeat_boost_min_aspect: f64,
    /// ... and whose longest extent is at least this, mm: pieces of one small object and
    /// small clutter measure alike within `repeat_split_tol` by chance (in seed 2026's table
    /// view 31 of the bench, three 45 mm pieces of one box). Default 200.
    pub repeat_boost_min_extent_mm: f64,
    /// The estimate of a one-face detection whose hidden extent the estimator inferred (one
    /// axis unobserved: it saw one face and took the thickness from the scene, as a box
    /// standing on a table or a shelf board) scores this factor times the product of the two
    /// scores, at most 1 ([`crate::pipeline::detection_score`]). The detector's score carries
    /// `one_face_factor` for the unseen thickness and the estimator's its doubt over the
    /// inferred extent: the same doubt counted twice. Such estimates were true positives
    /// about as often as two-face ones scored 1.7 to 2 times higher (replay of `anybox
    /// estimate --masks detect` on generated tables, pallets and shelves alike; at 0.2–0.3,
    /// 69–89 % of them against 30–38 % of two-face ones). 1 disables. Default 1.7 (bench, 48
    /// views per set, mean AP@0.5 of the 15 rows of seeds 2026 / 7 / 11 against 1: 0.6647 →
    /// 0.6723, AP@0.7 0.5086 → 0.5170; 1.5: 0.6715, 2.0: 0.6710; seeds 3 / 5, not used to
    /// choose it: 0.6448 → 0.6494).
    pub one_face_inferred_factor: f64,
    /// A detection whose estimate's points fit a circle across one of its axes better than
    /// its own rectangle there ([`crate::roundness`]: mean profile distance to the circle
    /// below this fraction of that to the rectangle) is a tin or a rod read as a box: its
    /// score is multiplied by [`DetectConfig::round_score_factor`]. 0 disables. Default 0.5
    /// (the top-scored false positives on generated tables with 32 distractors were mostly
    /// tins and rods, cap and side read as faces of a box; bench, 48 views per set, mean
    /// AP@0.5 of the 30 rows of seeds 2026 / 7 / 11 / 3 / 5 / 13 against 0: 0.7280 → 0.7290,
    /// 32 distractors 0.7415 → 0.7453, up on every seed, no row down; 0.7: 0.7293, but
    /// tables without distractors 0.7820 → 0.7815). Thin rods (diameter under about 45 mm)
    /// mostly pass: their profile leaves a square by less than the depth noise.
    pub round_max_ratio: f64,
    /// Points (with depth, in the middle half of the box along the tried axis) the
    /// roundness test needs. Default 150: fewer leave the profile to noise.
    pub round_min_points: usize,
    /// ... and the share of all the mask's points (with depth) they must make. Default 0.1:
    /// a 60 × 307 × 361 mm carton seen over its large face read round across its thin axis
    /// from the 2.5 % of its points that noise threw off the face's rim (generated table
    /// with 32 distractors, seed 2026, view 12).
    pub round_min_share: f64,
    /// A thin rod's profile leaves its square by less than the depth noise, so its ratio
    /// stays near 1. Below this ratio, a detection also reads as round when at least
    /// [`DetectConfig::round_normals_min_share`] of its observation's surface normals lie
    /// more than 30° off every face of its estimate ([`crate::roundness::share_off_faces`]).
    /// 0 disables. Default 1.0 (bench, 48 views per set, mean AP@0.5 of the 30 rows of seeds
    /// 2026 / 7 / 11 / 3 / 5 / 13 against 0: 0.7290 → 0.7301, 32 distractors 0.7453 →
    /// 0.7488, up on every seed, shelves +0.0015, tables without distractors and pallets
    /// −0.0002 and −0.0005. Chosen on an offline replay of `detect_dev`'s estimates, 48
    /// views: 1.2 scored alike, 1.5 lowered the tables without distractors).
    pub round_normals_max_ratio: f64,
    /// ... the share of normals off the faces that makes it round. Default 0.2 (true boxes'
    /// estimates: most under 0.1, a few up to 0.4 with noisy or rounded edges; tins and rods
    /// 0.1–0.4; 0.15 took in cartons, 0.3 left out most rods).
    pub round_normals_min_share: f64,
    /// A detection whose estimate has a face towards the camera with at least this many
    /// points (within [`DetectConfig::round_cap_tol_mm`] of its plane) that leaves at least
    /// [`DetectConfig::round_cap_min_empty`] corners of its outline empty
    /// ([`crate::roundness::face_corners`]) is a tin's or a rod's flat cap read as a box's
    /// face: it reads as round ([`DetectConfig::round_score_factor`]). The side tests above
    /// miss many tins: a side seen over less than half its circle fits the box's rectangle
    /// about as well; the cap, a disc, leaves a rectangle's four corners empty. The
    /// detector's own corner test ([`DetectConfig::face_min_corners`]) sees only a group's
    /// largest face, which for a tin taller than wide is a band of its side. 0 disables (as
    /// does [`DetectConfig::round_max_ratio`] 0, which turns every roundness test off).
    /// Default 100 (bench, 48 views per set, mean AP@0.5 of the 30 rows of seeds 2026 / 7 /
    /// 11 / 3 / 5 / 13 against 0: 0.7436 → 0.7440, 32 distractors 0.7538 → 0.7555, up by
    /// 0.001–0.003 on every seed, no row down by more than 0.001; on seed 2026's
    /// 32-distractor frames the records reading no carton that score ≥ 0.1 fall from 47 to
    /// 32, no true positive lowered).
    pub round_cap_min_points: usize,
    /// How far from the face's plane a point counts as on it, mm. Default 8 (a few times
    /// the depth noise at 1–2 m; a cap's rim, the side's points within 8 mm of it, lies on
    /// the disc's edge and leaves the corners empty).
    pub round_cap_tol_mm: f64,
    /// Empty corners (of 4) that make a face a cap. Default 4 (same bench, on the test's
    /// first version, which always turned the outline, 3: 32 distractors 0.7563, but
    /// tables without distractors 0.7903 → 0.7895, mean 0.7438).
    pub round_cap_min_empty: usize,
    /// Score factor of a detection read as round ([`DetectConfig::round_max_ratio`]).
    /// Default 0.3 (kept, not dropped: a carton misread as round stays in the ranking).
    pub round_score_factor: f64,
    /// A box of a frame's output (detection or alternative reading) whose 3D IoU with a
    /// higher-scored box exceeds this repeats it ([`crate::pipeline::duplicate_factors`]).
    /// Default 0.5, the IoU at which AP@0.5 matches a box: two boxes above it with each
    /// other can rarely both match (with a factor of 0.5, in the replay of
    /// [`DetectConfig::duplicate_score_factor`]: 0.45 0.7336, 0.5 0.7342, 0.55 0.7341).
    pub duplicate_iou: f64,
    /// Score factor of a box that repeats a higher-scored one ([`DetectConfig::duplicate_iou`]).
    /// 1 disables. Default 0.3 (kept, not dropped: where the higher one is wrong, the repeat
    /// may be the right reading. Bench, 48 views per set, mean AP@0.5 of the 30 rows of seeds
    /// 2026 / 7 / 11 / 3 / 5 / 13 against 1: 0.7327 → 0.7345, every layout up; offline
    /// replay of the same records, the `rank_replay` example: 0.7328 → 0.7345, 0.5 0.7342,
    /// 0 (dropped) 0.7310).
    pub duplicate_score_factor: f64,
    /// A surface-level candidate splits into its colour-level candidates when at least this
    /// many seam cells lie next to two of them with coplanar faces (flush cartons). Default 9
    /// (bench, 48 views per set, seeds 2026 / 7 / 11, mean AP@0.5 of the 15 rows against 6,
    /// the default before: 0.6523 → 0.6543, only the tables moving, by −0.005 to +0.010; seeds
    /// 3 / 5, not used to choose it: 0.6325 → 0.6357, all six table rows up; 4: 0.6509).
    pub split_min_seam_cells: u32,
    /// A seam that stops at the candidate's perpendicular side face (seen there, not
    /// continuing down it) is the carton's own flap seam and does not split it. Default true.
    pub split_flap_check: bool,
    /// ... but only when the colour-level candidates on either side of it differ in mean
    /// colour, over their cells facing one way (same shading), by less than this, RGB levels:
    /// a carton is one colour on both sides of its own seam, while a box standing on a box of
    /// another colour makes the same seam-and-side picture. 0 turns the colour test off (the
    /// behaviour before). Default 40 (bench, 24 views, AP@0.5 before → after, seeds 2026 / 11:
    /// tables 0.650 / 0.653 / 0.599 → 0.666 / 0.670 / 0.619 and 0.604 / 0.593 / 0.553 →
    /// 0.611 / 0.605 / 0.565; seed 7, pallets and shelves unchanged; 25 and 60 measured the
    /// same).
    pub split_flap_max_colour_delta: f64,
    /// Flap-seam halves (see `halves`): a single-face candidate at least this many times as
    /// long as wide may be half a carton top; chains of such halves pair off from a carton's
    /// edge into whole tops. 0 disables pairing (this and `halves_isolated_pairs`). Default
    /// 1.6 (a half of an L × W top with L ≥ W is L × W/2, aspect ≥ 2). Where the support's
    /// up is known, tops follow `halves_top_min_aspect` instead and other faces
    /// `halves_side_chains`.
    pub halves_min_aspect: f64,
    /// Where the support's up is known, a top (a patch within `halves_top_max_tilt_deg` of
    /// it) may be a half in a chain from this aspect on, whatever `halves_min_aspect` says: a
    /// carton's flap seam runs along one side of its top, not always the long one (a 250 × 377
    /// mm top cut along its 250 mm side gives two 250 × 188 mm halves, aspect 1.33, and a
    /// layer of such cartons came out as half-cartons: seed 7, pallet view 38). 1 takes every
    /// top; 0 leaves tops to `halves_min_aspect`. Default 1 (with the three settings below
    /// and `halves_tape_band_contrast` 7; see `halves_tape_band_contrast` for the bench).
    pub halves_top_min_aspect: f64,
    /// A patch within this many degrees of the support's up is a top for
    /// `halves_top_min_aspect` and `halves_side_chains`. Default 45 (20 left out a carton
    /// lying tilted by 25° on the table, whose top's halves chain: seed 5, table view 21).
    pub halves_top_max_tilt_deg: f64,
    /// Where the support's up is known, patches that are not tops chain as halves too. Off by
    /// default: a layer is horizontal, and the fronts of two cartons stacked flush, one above
    /// the other, make a chain of two long coplanar patches that paired into one face (seed 7,
    /// pallet view 25). The isolated pairs (`halves_isolated_pairs`) follow
    /// `halves_isolated_sides`.
    pub halves_side_chains: bool,
    /// Two halves agree in length, width and position along their shared side within this
    /// ratio (shorter / longer). Default 0.8.
    pub halves_min_ratio: f64,
    /// Two halves touch: the gap between them is within this (plus the ratio's slack), mm;
    /// also how far beyond a chain's end patch the surface must have ended. Default 15.
    pub halves_gap_mm: f64,
    /// Two patches are not halves when the line between them is seen to run on down an end
    /// face of theirs (the joint of two cartons; a flap seam stops at the top's edge).
    /// Default true.
    pub halves_joint_check: bool,
    /// With `halves_joint_check`, the line between two patches is also a joint where an end
    /// face of theirs is two colour patches cut at the line, each well seen and neither
    /// reaching across it (the fronts of two flush cartons, their joint too faint for a seam;
    /// the face below a flap seam is one). Seed 59, 48-view pallet view 15: two white taped
    /// cartons' tops, a chain of two with clean ends, paired as one carton's halves (mask IoU
    /// 0.58 and 0.35 → 0.98 and 0.98). Default true (bench, 48 views, six seed groups of
    /// six seeds against false: pallets +0.0034 / +0.0000 / +0.0031 / +0.0014 / +0.0000 /
    /// +0.0002, tables 0 except seeds 41–61 −0.0002 / −0.0008 / −0.0009, shelves 0; with
    /// 12 cells a side instead of 40, a carton's own end face cut at its flap seam's line
    /// (seed 137, pallet view 38, 20 and 19 cells) lost pallets 0.0014 on seeds 127–151).
    pub halves_joint_labels: bool,
    /// Also pair two patches that are halves of a top cut across its short side, or not
    /// elongated enough for `halves_min_aspect` (a 120 × 300 mm top with its flap seam along
    /// the 120 mm side gives two 120 × 150 mm halves), when the pair stands alone: the two are
    /// coplanar, of about the same colour and size (`halves_min_ratio`), touch along a whole
    /// side, neither touches another such patch, and the surface ends beyond every other side
    /// of both. Default true.
    pub halves_isolated_pairs: bool,
    /// Where the support's up is known, the isolated pairs (`halves_isolated_pairs`) take
    /// faces that are not tops (`halves_top_max_tilt_deg`) too. Off by default: a flap seam
    /// runs across a top, and the fronts of two flush cartons side by side, each below its
    /// own top, are two coplanar patches of one colour and size touching along a whole side
    /// with the surface ending beyond the rest: such a pair joined them into one face, and
    /// the two cartons came out as one box (seed 149, 48-view pallet view 42: 3D IoU 0.50
    /// and 0.47 → found at mask IoU 0.96 and 0.97). Bench, 48 views, six seed groups of six
    /// seeds against on: pallets +0.0000 / +0.0022 / +0.0000 / +0.0022 / +0.0000 / +0.0051
    /// (seeds 131 and 149 +0.016 and +0.015), shelves +0.0027 on seeds 97–113 (seed 109
    /// +0.016) and unchanged elsewhere, tables within −0.0001.
    pub halves_isolated_sides: bool,
    /// A chain of halves ends cleanly where its end patch's plane does not go on beyond it
    /// (`halves_gap_mm`); a point there counts as on the plane only when its cell's normal is
    /// also within this many degrees of the plane's. Without it, the front face below a
    /// top's near edge, seen just past the edge, lay within the plane tolerance (three times
    /// `plane_tol_*`, 34 mm at 1.1 m) and a layer's tops never ended towards the camera: on
    /// seed 5's 48-view pallet view 2 a chain of four halves (two cartons' tops) stayed
    /// unpaired. The isolated pairs (`halves_isolated_pairs`) keep the plain test. 0
    /// disables. Default 30 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, with
    /// `estimate_retry_below_score` 0: mean AP@0.5 of the 15 rows 0.7073 → 0.7083, pallets
    /// 0.7038 → 0.7088, tables within 0.0006, shelves +0.001; 18° and 32° gave the same
    /// means within 0.0002, 46° pallets 0.7030; at 32° in both passes, tables +0.003 and
    /// pallets 0.6968, in the isolated pairs alone pallets 0.6890).
    pub halves_end_max_tilt_deg: f64,
    /// A chain of halves ends cleanly where fewer than this share of the nine points just past
    /// its end patch's outer side lie on its plane (`halves_end_max_tilt_deg` for which
    /// count). Default 1/3. Where the next column's carton stands beside part of that side
    /// only, 4 of 9 lie on the plane and the chain stays unpaired (seed 11, pallet view 9:
    /// chains of 4 and 6 halves); 0.5 pairs one of its cartons (3D IoU 0.46 → 0.80), but on
    /// the bench (48 views, six seeds, mean AP@0.5 of the 30 rows) 0.5 and 0.67 both gave
    /// 0.7188 against 0.7184, pallets 0.7438 / 0.7430 against 0.7435 (seed 2026 −0.006),
    /// shelves +0.0014 / +0.0024: within what the bench moves by, so not taken.
    pub halves_end_max_on_plane: f64,
    /// A patch with a band of another colour along the middle of its long axis, over its
    /// whole length, differing from the patch's outer parts by at least this, RGB levels, is
    /// a whole taped top and is not paired as a half by either pass: two flush cartons, each
    /// with its tape along its middle, looked like the halves of one carton's top, their
    /// joint like its flap seam (seed 2026, pallet view 33). 0 disables. Default 7 (25 before
    /// tops of any aspect chained, `halves_top_min_aspect`: bench, 48 views, six seeds 2026 /
    /// 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the pallets against 0: 0.6573 → 0.6620, every
    /// other row unchanged, and 15 and 40 the same; with every top in the chains, whole taped
    /// tops whose tape differs by 8–15 levels paired off with their neighbours: seed 11,
    /// pallet view 23. Plain faces measure 0–1 levels. With the three settings above, against
    /// the settings before: mean AP@0.5 of the 30 rows 0.7384 → 0.7424, pallets 0.7767 →
    /// 0.7870, tables +0.003 each, shelves +0.0004, no row lower by more than 0.005. Parts:
    /// the side chains off alone (tops at 45°) 0.7401, pallets 0.7847; tops of any aspect
    /// with side chains, tops at 20° and contrast 25, 0.7377, pallets 0.7638; contrast 10
    /// instead of 7, 0.7420, pallets 0.7852; tops from aspect 1.2, seed 2026's tables 0.806 /
    /// 0.798 / 0.778 against 0.812 / 0.804 / 0.784, the other three seeds run the same).
    pub halves_tape_band_contrast: f64,
    /// "Next to" for `split_min_seam_cells`: within this many cells. Default 3.
    pub split_seam_reach_cells: u32,
    /// Colour-level candidates count for a split when they hold at least this fraction of the
    /// surface-level candidate's cells. Default 0.03.
    pub split_min_fraction: f64,
    /// A coarse candidate (object or surface level) is also split when a colour-level
    /// candidate inside it is a whole carton on its own: at least this many faces, scored at
    /// least `split_carton_min_score_ratio` times the coarse one, holding at most
    /// `split_carton_max_fraction` of its cells, and the coarse cuboid is `k` ≥ 2 copies of
    /// its cuboid laid end to end (as the repeat readings judge it: `repeat_split_tol`,
    /// `repeat_split_max_parts`, `tiled_union_max_angle_deg`). Two cartons of one size side by
    /// side with flush faces make a cuboid that fits and scores as well as either, and the
    /// seam between them may show too little to count. 0 disables. Default 3 (bench, 48
    /// views per set, seeds 2026 / 7 / 11, mean AP@0.5 of the 15 rows against 0: 0.6543 →
    /// 0.6555; seeds 3 / 5, not used to choose it: 0.6357 → 0.6364; 2: 0.6504; without the
    /// copies condition 0.6553 but 0.6340 on seeds 3 / 5).
    pub split_carton_min_faces: u32,
    /// A coarse candidate (object or surface level) is also split when two colour-level
    /// candidates inside it face the same way (within `perpendicular_tol_deg`) but are not
    /// one plane: a plane fitted to both their faces leaves a root-mean-square residual, beyond
    /// what a plane fitted to each leaves, of more than this, mm. A box's face is flat; two
    /// touching cartons of different heights, or a carton on another, make one surface and one
    /// object when their step is under the depth-jump tolerance and their colour is the same.
    /// Two equal patches side by side, a step of s apart, leave s/4. 0 disables. Default 3
    /// (bench, 48 views, six seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 rows
    /// against 0: 0.7227 → 0.7244, every set up by 0.001–0.002; 1.5: 0.7246).
    pub split_step_min_mm: f64,
    /// See `split_carton_min_faces`. Default 0.85.
    pub split_carton_min_score_ratio: f64,
    /// See `split_carton_min_faces`. Default 0.75.
    pub split_carton_max_fraction: f64,
    /// A candidate is dropped when more than this fraction of its cells belongs to a better
    /// one. Default 0.3.
    pub max_overlap: f64,
    /// Residual objects: once candidates are selected, what is left of each connected object
    /// (its cells that no selected candidate took) is tried as a box again, as objects are
    /// (see `blobs`), and kept when it scores at least `min_score` times this factor; 0
    /// disables. Finds a box whose object also held a better-scoring neighbour (a small box
    /// standing on a larger one). Default 1.7: AP@0.5 on the generated tables rose on all
    /// nine rows of seeds 2026 / 7 / 11 (mean +0.006), pallets and shelves unchanged within
    /// ±0.005; 1.0 also let in junk (mean ±0), 2.1 gained less.
    pub residual_score_factor: f64,
    /// ... for what is left of an object up to this many grid cells: larger remains (shelf
    /// structure, the rest of a stack) cost a cuboid fit each, and on the generated
    /// benchmark (seeds 2026 / 7 / 11) no box kept from a remain had more than 2100 cells.
    /// Default 2500.
    pub residual_max_cells: u32,
    /// Remains joined to a piece (`remains`): once candidates (the residual ones included) are
    /// selected, each of at most `remain_join_max_faces` faces is scored together with each
    /// remain touching it across a depth join (what is left of a connected object, from
    /// `min_face_cells` to `residual_max_cells` cells), and takes the remain in when the
    /// union scores at least this times the candidate alone (both as uncut objects). Finds
    /// the rest of a box cut from the face selection chose (a side face seen at a grazing
    /// angle, cut off at a printed edge or a label). ≤ 0 disables. Default 0.9 (bench, 48
    /// views per set, against the join off: see `remain_join_max_faces`; with two faces,
    /// seeds 41–61, 1.0 gained about 0.003 less on the tables, 0.8 lost twice as much on
    /// pallets).
    pub remain_join_min_score_ratio: f64,
    /// See `remain_join_min_score_ratio`: candidates of more faces take nothing in. Default 1
    /// (bench, 48 views per set, tables with 0 / 8 / 32 distractors, pallets, shelves against
    /// the join off: seeds 2026 / 7 / 11 / 3 / 5 / 13 +0.0012 / +0.0021 / +0.0037, −0.0045,
    /// −0.0032; 17–37 +0.0037 / +0.0041 / +0.0036, +0.0028, −0.0020; 41–61 +0.0080 / +0.0075
    /// / +0.0031, 0, +0.0005; 67–89 +0.0003 / +0.0003 / +0.0022, +0.0037, +0.0070; 97–113,
    /// drawn after this default was fixed, +0.0023 / +0.0008 / +0.0028, −0.0026, −0.0032.
    /// With 2 the tables gained more on seeds 41–61 and 67–89
    /// but lost on the first six (−0.0087 / −0.0065 / +0.0020) and pallets lost 0.009–0.021
    /// on the first twelve: a piece of two faces is often a whole carton whose flush
    /// neighbours are the remain.)
    pub remain_join_max_faces: u8,
    /// See `remain_join_min_score_ratio`: remains of more than this times the candidate's
    /// cells stay out (on a pallet, a remain that large is the candidate's flush neighbours,
    /// and a row of flush cartons is as good a cuboid as one of them). Default 1.5 (measured
    /// with `remain_join_max_faces` 2, seeds 41–61: pallets −0.0080 → −0.0044 against the
    /// join off, tables unchanged within 0.002).
    pub remain_join_max_size_ratio: f64,
    /// Final masks take in the cells within the candidate's cuboid grown by this multiple of
    /// the plane tolerance on every side (edge bands, grazing side faces, a box's foot next to
    /// its support). Default 1 (2 takes in too much on shelves).
    pub fill_margin_factor: f64,
    /// A one-face candidate also takes in the side faces seen past its edges, up to this far
    /// behind its face, mm: cells behind the face's plane that project onto one of its edges,
    /// where the side face hanging from that edge faces the camera, reached through
    /// depth-continuous neighbours. Seen at a grazing angle those faces are strips too thin
    /// to be faces of their own, and without them the estimator cannot measure the box's
    /// depth. 0 disables. Default 600.
    pub side_strip_max_mm: f64,
    /// A candidate whose cuboid ends above a support plane (parallel to up) by at most this
    /// many plane tolerances, with an axis along the plane's normal, is filled down to half a
    /// tolerance above the plane: the foot of its side faces, cut off its object near the
    /// support (`blob_support_gap_factor`), belongs to it, and without it the estimator reads
    /// the box as shorter. 0 disables. Default 2.5, the cut band plus the fill margin (bench,
    /// 48 views per set, mean AP@0.5 of the 15 rows of seeds 2026 / 7 / 11 against 0: 0.6555
    /// → 0.6582, AP@0.7 0.4977 → 0.5003; seeds 3 / 5, not used to choose it: 0.6364 → 0.6395,
    /// AP@0.7 0.4802 → 0.4814; 3.5: 0.6561. Filling down to the plane itself took in the
    /// table at the foot: 0.6587 but AP@0.7 0.4945, and 0.6347 on seeds 3 / 5; stopping a
    /// whole tolerance above it: 0.6549).
    pub fill_support_reach_factor: f64,
    /// Morphological opening of each output mask with a square of side `2 × mask_open_px + 1`
    /// px, before the side strips are added: lines and spurs thinner than that go, faces stay.
    /// The fill above takes in, within its margin of the cuboid, whatever lies at about the
    /// box's depth, which includes thin lines along a touching neighbour's rim that run on
    /// past the box's corners; a few hundred such pixels stretch the estimator's extents
    /// (one slab on a table: 3D IoU 0.21 → 0.88). 0 disables. Default 3. Bench, 48 views
    /// per set, seeds 2026 / 7 / 11, mean of the 15 detection rows: AP@0.7 0.411 → 0.431
    /// (up in 12 of 15 rows), AP@0.5 0.577 → 0.578 (up in 7, down in 8); with 2, 0.421 /
    /// 0.580, and with 4, 0.431 / 0.574 (both with the frame's edge counted as unset).
    pub mask_open_px: u32,
    /// Each mask is taken on into the dropouts next to it that continue its face (a face
    /// seen at a grazing angle loses most of its depth, and the estimator then reads the
    /// box's extent from the mask): reached through pixels without depth, and through the
    /// face's valid pixels among them, that lie among valid pixels on the plane of the face
    /// of the detector's cuboid they start from, past no seam, each within
    /// `hole_grow_step_colour` of the pixel it is reached from and `hole_grow_colour` of the
    /// face's colour next to the mask; up to this fraction of the mask's pixels, the
    /// detections growing together (each pixel to the first to reach it). Needs RGB. 0
    /// disables. Default 0.5 (bench, 48 views, seeds 2026 / 7 / 11, mean of the 15 rows
    /// against 0: AP@0.5 0.6302 → 0.6351, AP@0.7 0.4764 → 0.4858, AP@0.25 0.7957 → 0.7927;
    /// shelves +0.015 / +0.027 / −0.010, tables −0.003 to +0.012, pallets within ±0.004; see
    /// `docs/detection-log.md` for the variants measured).
    pub hole_grow_max_fraction: f64,
    /// See `hole_grow_max_fraction`: each connected piece grown must hold at least this
    /// fraction of the mask's pixels, or it goes. Default 0.02.
    pub hole_grow_min_piece: f64,
    /// See `hole_grow_max_fraction`: a pixel without depth is grown into only when at least
    /// this fraction of the pixels around it (5 × 5, detections' pixels left out) have depth,
    /// and a valid one only when at least this fraction have none. Default 0.15.
    pub hole_grow_min_valid: f64,
    /// See `hole_grow_max_fraction`, RGB levels (Euclidean). Default 15.
    pub hole_grow_step_colour: f64,
    /// See `hole_grow_max_fraction`, RGB levels (Euclidean). Default 40.
    pub hole_grow_colour: f64,
    /// ... with this much slack for the face normal's error: the band around an edge widens
    /// by tan(slack) × distance behind the face, degrees. Default 4.
    pub side_strip_slack_deg: f64,
    /// ... and only where at least this many cells lie behind one edge. Default 60.
    pub side_strip_min_cells: u32,
    /// A candidate's faces cut in two by a nearer thing standing across them are taken in past
    /// it, up to this far beyond the candidate's end along each of its cuboid's axes, mm (see
    /// `occluded`): going outwards, an occluder (distance bins of 10 mm mostly in front of the
    /// extended cuboid's surface), then a run of bins mostly on that surface (unclaimed cells,
    /// or another candidate's own), of about the candidate's colour. 0 disables. Default 400.
    pub occluded_reach_mm: f64,
    /// ... a bin is "mostly" one kind with at least this fraction of its cells (also the share
    /// of cells right past the end that must lie in front). Default 0.5.
    pub occluded_min_front: f64,
    /// ... and the run takes in at least this many cells. Default 12.
    pub occluded_min_cells: u32,
    /// ... whose mean colour is within this of the candidate's cells next to the occluder,
    /// RGB levels; the occluder's mean colour must differ from theirs by more than this (an
    /// occluder of the candidate's own colour may be a carton of the same product whose
    /// faces line up with it). Default 30.
    pub occluded_colour_max: f64,
    /// ... the run's colour compared at the brightness of the candidate's cells next to the
    /// occluder when the run is darker, by a factor of at most `occluded_shading_max_ratio`:
    /// it may lie in the occluder's shadow (seed 3's 48-view table view 34: a 212 × 52 × 151 mm box behind a
    /// leaning one, 3D IoU 0.28 → 0.82). Default on (bench, 48 views, seeds 2026 / 7 / 11 /
    /// 3 / 5 / 13, mean AP@0.5 of the 15 rows 0.7060 → 0.7064: tables +0.0003 to +0.0011,
    /// seed 3 +0.0034, seed 11 −0.0006; darker or brighter by up to a factor of two:
    /// 0.7062, seeds 7 and 5 −0.001 and −0.0016).
    pub occluded_shading: bool,
    /// See `occluded_shading`: the largest brightness ratio (near cells' summed RGB over the
    /// run's) compared that way. Default 1.6.
    pub occluded_shading_max_ratio: f64,
    /// Another candidate lying on the run with at least this fraction of its own cells is the
    /// same box's other piece: it joins the candidate (which keeps the higher score). Default
    /// 0.6.
    pub occluded_absorb_fraction: f64,
    /// In the bins between the candidate's end and the occluder, cells on the extended surface
    /// that are claimed already (the candidate's own rim past its fitted end, a support) are
    /// left out of the shares: a first bin of a few rim cells and a few occluder cells was
    /// neither, and no occluder was seen (seed 2026's 48-view table view 6: a 345 mm box
    /// behind a standing one, 3D IoU 0.28 → 0.54). Default true (bench, 48 views, seeds 2026
    /// / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 sets 0.7350 → 0.7357: seed 2026's tables
    /// +0.004 to +0.008, its shelf −0.006; AP@0.25 0.8686 → 0.8692, AP@0.7 0.5694 → 0.5698).
    pub occluded_lead_skips_claimed: bool,
    /// Object-level candidates: every connected object left after support removal (cells
    /// joined by depth continuity alone) is also tried as one box (see `blobs`). Default true.
    pub blobs: bool,
    /// Objects are also cut at concave creases (where a box meets another box or anything
    /// else; a box's own edges are convex). Default true.
    pub blob_split_concave: bool,
    /// An object is cut in two where one face direction holds two parallel planes further
    /// apart than this multiple of the plane tolerance (a step between touching boxes), along
    /// the box axis that separates them; 0 disables. Default 4.
    pub blob_step_factor: f64,
    /// An object that fits a cuboid, and that no step or colour change cuts, is also cut
    /// where its cross-section steps along a box axis: the near or far edge of its cells along
    /// another axis moves by more than this, mm (and four plane tolerances), between two runs
    /// of slabs that each hold it steady (two boxes of one colour stacked, or side by side or
    /// end to end, their faces flush). The whole competes with its parts. A move that the
    /// nearer depth of an occluder explains does not cut. 0 disables. Default 15 (bench, 48
    /// views, six seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 rows against 0, at
    /// margin 0.05: 0.7236 → 0.7263, tables +0.004 to +0.006, pallets −0.001, shelves −0.001;
    /// 10 / 25 mm: 0.7268 / 0.7251).
    pub blob_profile_cut_min_mm: f64,
    /// Both sides of a profile cut (`blob_profile_cut_min_mm`) are at least this long along
    /// the cut axis, mm. Default 30.
    pub blob_profile_cut_min_part_mm: f64,
    /// A profile cut (`blob_profile_cut_min_mm`) stands only when its two parts, scored as
    /// boxes, beat the whole by at least this much: their mean score weighted by cells, each
    /// score divided by its face-count factor (`one_face_factor`, `two_face_factor`: a part
    /// may show fewer faces than the whole); a part that is no box scores 0, and an object
    /// that is no box as a whole is not cut. Default 0.1 (bench, 48 views, six seeds, mean
    /// AP@0.5 of the 30 rows: 0.05 / 0.1 / 0.15 gave 0.7263 / 0.7271 / 0.7266; six seeds' 48
    /// table views without distractors and pallet views, `detect_dev` with `EST3D=1`, boxes
    /// found at 3D IoU > 0.5, of 1488 and 1316: 1197 and 994 at 0.1, 1196 and 995 at 0.05;
    /// margin 0 with wholes that are no box cut too: 1192 and 987; no cut: 1190 and 994; a
    /// first version that took every cut it found, the largest move first, hidden only past
    /// the depth-jump tolerance: 1178 and 966).
    pub blob_profile_cut_margin: f64,
    /// A profile cut that loses to its whole (`blob_profile_cut_margin`) still gives its two
    /// parts, scored as boxes, as alternative readings ([`Detection::alternative`], scored
    /// `alternative_score_factor` times their own score, on top of `alternatives_max`): two
    /// boxes stacked, one on the other, are often as good a cuboid together as apart, and the
    /// whole then hides both. Default true (bench, 48 views, mean AP@0.5 against false:
    /// tables +0.0010 / +0.0015 / +0.0013 (0 / 8 / 32 distractors) on seeds 2026 / 7 / 11 /
    /// 3 / 5 / 13, +0.0024 / +0.0024 / +0.0022 on 17 / 19 / 23 / 29 / 31 / 37, +0.0023 /
    /// +0.0019 / +0.0013 on 41 / 43 / 47 / 53 / 59 / 61; pallets 0 / −0.0001 / −0.0007,
    /// shelves within ±0.0002. Counted within `alternatives_max`, where most frames' two
    /// are taken already: +0.0011 / +0.0011 / +0.0007 on 41…61, pallets −0.0008; their scores
    /// × 3: tables −0.0070 / −0.0094 / −0.0076 there, × 0.4: +0.0006 / +0.0006 / +0.0004).
    pub blob_profile_cut_alternatives: bool,
    /// See `blob_profile_cut_min_mm`: the first-ranked cut is not made when at least this
    /// share (and 3) of the object's cells within two bins of it lie within two cells of a
    /// cell of another thing nearer by more than the jump tolerance: a box lying or standing
    /// across the object steps its outline there, and nothing parts it. 0 disables. Default
    /// 0.125 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 30 rows
    /// against 0: 0.7274 → 0.7280, tables +0.0008 to +0.001, pallets and shelves the same;
    /// 0.05 found as many boxes in `detect_dev` but three tables' mask IoUs 0.07–0.15 lower;
    /// testing every candidate cut rather than the first-ranked let a second cut part boxes
    /// with a box standing across them).
    pub blob_profile_cut_occluder_share: f64,
    /// A step of at least this many plane tolerances but under `blob_step_factor` is weak:
    /// the object is scored whole and cut at it as well, and the whole and the parts compete
    /// in `select` (a sure step cuts alone). Two touching boxes whose tops differ by 45 mm at
    /// 1.2 m, or a box on a carton barely set back from its edges, step by less than four
    /// plane tolerances; at one, most boxes' noisy faces do too, and then the whole wins.
    /// 0 (or not below `blob_step_factor`) disables. Default 1 (bench, 48 views, seeds 2026 /
    /// 7 / 11 / 3 / 5 / 13, with `blob_fit_colour_split_min_chroma`: mean AP@0.5 of the 15
    /// rows 0.6914 → 0.6950, tables +0.007 / +0.006 / +0.009, pallets −0.002, shelves −0.001;
    /// 1.5 gave 0.6944, and alone 1 / 1.5 / 2 / 2.5 / 3 gave 0.6919 / 0.6912 / 0.6907 /
    /// 0.6887 / 0.6882 against 0.6879; the cut along the planes' normal in front of the
    /// farther plane, tried as well, added 0.0001 and cost shelves 0.004).
    pub blob_weak_step_factor: f64,
    /// ... when each plane holds at least this fraction of the face's cells. Default 0.15.
    pub blob_step_min_fraction: f64,
    /// A step (`blob_step_factor`, `blob_weak_step_factor`) between two planes that face the
    /// support's up within this angle, degrees, is read two ways: two boxes side by side (the
    /// step's own cut, between the planes' cells along another box axis) and one box stacked
    /// on another (the object cut across the up just past the farther plane: what stands out
    /// of it is the upper box). With flush faces of one colour the two look the same. A weak
    /// step adds the stacked parts as alternative readings; for a sure one see
    /// `blob_stack_margin`. 0 disables (a step is then only cut side by side). Default 20,
    /// not varied (bench, 48 views, mean AP@0.5 against 0 over six groups of six seeds, README
    /// item 56: tables +0.004 to +0.024 per group, pallets −0.003 to +0.002, shelves −0.002
    /// to +0.0004, all sets +0.0034 to +0.0138; seeds 127 / 131 / 137 / 139 / 149 / 151,
    /// drawn after it was fixed, tables +0.0114 / +0.0090 / +0.0112 with 0 / 8 / 32
    /// distractors, all sets +0.0053).
    pub blob_stack_max_tilt_deg: f64,
    /// A sure step read both ways (`blob_stack_max_tilt_deg`) is cut the stacked way when
    /// those two parts, scored as boxes, beat the side-by-side parts by at least this: their
    /// shape (score over face-count factor) weighted by cells, as `blob_profile_cut_margin`
    /// compares a cut with its whole. The reading not taken gives its parts as alternative
    /// readings ([`Detection::alternative`], scored `alternative_score_factor` times their own
    /// score, on top of `alternatives_max`). 1 or more: always side by side. Default 0.05
    /// (bench, 48 views, all sets' mean AP@0.5, the stacked cut at a quarter of the gap,
    /// against 1: +0.0022 and +0.0044 on seeds 41–61 and 97–113, where it was chosen; 0 gave
    /// +0.0011 and +0.0032. With `blob_stack_cut_tols` 1 too, against that first version (1,
    /// a quarter of the gap): +0.0056 and +0.0059 there, +0.0013, −0.0017 and +0.0025 on
    /// seeds 2026–13, 17–37 and 67–89. 0.1 against 0.05: +0.0009 on 17–37, −0.0011 on
    /// 41–61).
    pub blob_stack_margin: f64,
    /// The stacked reading (`blob_stack_max_tilt_deg`) cuts this many plane tolerances past
    /// the farther plane's nearest cell (at most halfway to the nearer plane): the upper
    /// box's sides start at that plane, and a cut further up would give their foot to the
    /// lower box. Default 1 (bench, 48 views, all sets' mean AP@0.5 against a quarter of the
    /// gap, with `blob_stack_margin` 0.05: +0.0034 on seeds 41–61 (tables +0.0050 / +0.0063
    /// / +0.0044), +0.0015 on 97–113; with `blob_stack_margin` 1: +0.0009 on 41–61).
    pub blob_stack_cut_tols: f64,
    /// An object is also cut in two where its colour changes across it by at least this
    /// much on every face the cut crosses: the norm of the RGB difference of the two sides
    /// over their mean norm (boxes of different colours end to end or stacked with flush
    /// sides; see `blobs`); 0 disables. Default 0.35 (with the spread cap below: bench AP@0.5
    /// on the generated tables +0.011 on average over seeds 2026 / 7 / 11, pallets, shelves
    /// and ycbv-boxes unchanged; without the cap, 0.4 and 0.45 gained less on the tables and
    /// 0.3 to 0.45 all cut a printed ycbv box).
    pub blob_colour_cut_delta: f64,
    /// ... with at least this fraction of the object's cells on either side. Default 0.15.
    pub blob_colour_cut_min_fraction: f64,
    /// ... and both sides plain: the colour's spread along the object (see `blobs`) at most
    /// this. Generated boxes measure 0.01–0.06, the printed boxes of ycbv-boxes 0.1–0.3.
    /// Default 0.1.
    pub blob_colour_cut_max_spread: f64,
    /// Objects that fit no cuboid (`blob_min_fit`, `blob_min_agree`, `max_bend_deg`) are not
    /// dropped at once: the colour cut is tried on them too, and failing that, a split of
    /// their cells into two clusters of chromaticity (`blob_colour_split_min_chroma`). Two
    /// boxes of different colours touching, or turned to each other, make one such object.
    /// Each part is then tried as a box again. Default true. Bench AP@0.5 over the 15
    /// generated rows of seeds 2026 / 7 / 11, 48 frames each: 0.6048 → 0.6098 on average
    /// with the cut alone (every table row +0.005 to +0.010, shelves +0.006 on seed 2026,
    /// nothing lower), 0.6113 with the clusters up to `blob_colour_split_max_cells`.
    pub blob_colour_cut_misfits: bool,
    /// ... the clusters are tried on objects of at most this many grid cells. Larger ones
    /// (shelf structure, walls) were split again and again, each part fitted anew: without a
    /// bound, shelf frames took about 10 ms longer (median 80.7–84.3 → 92.0–93.2 ms, two
    /// alternating runs each) for AP@0.5 0.6117 instead of 0.6113 (shelves +0.004 on
    /// average, the tables up to 0.004 lower). Default 2500 (8000 gave 0.6111).
    pub blob_colour_split_max_cells: u32,
    /// The two clusters of `blob_colour_cut_misfits` part an object only when their centres'
    /// chromaticities ((r, g, b) / (r + g + b), 8-bit colours) differ by at least this
    /// (Euclidean), and each holds `blob_colour_cut_min_fraction` of its cells. Brightness
    /// does not count: clustering on the colours themselves split curved distractors into
    /// their lit and shaded sides (clear false positives with 32 distractors, seeds 2026 / 7 /
    /// 11: 451 → 542, against 457 with chromaticity; AP@0.5 0.6131 against 0.6117, both
    /// without `blob_colour_split_max_cells`). Default 0.08 (0.05 gave the same AP@0.5 and 5
    /// more clear false positives over the 15 rows).
    pub blob_colour_split_min_chroma: f64,
    /// An object that fits one cuboid, and that no step or colour cut parts, is scored whole
    /// and, where its cells fall into two clusters of chromaticity at least this far apart
    /// (as `blob_colour_split_min_chroma`) that a plane across a box axis parts
    /// (`blob_fit_colour_split_min_agree`), its two sides of that plane are tried as well:
    /// a box standing on a carton of another colour, their joint hidden or flush, fits one
    /// cuboid well enough, and the colour cut wants two faces changing colour across it where
    /// the box's narrow sides give one. The whole and the parts compete in `select`. 0
    /// disables. Default 0.1 (bench, 48 views, seeds 2026 / 7 / 11 / 3 / 5 / 13: mean AP@0.5
    /// of the 15 rows 0.6879 → 0.6914; tables +0.005 / +0.008 / +0.005 for 0 / 8 / 32
    /// distractors, no row of any seed lower by more than 0.003).
    pub blob_fit_colour_split_min_chroma: f64,
    /// See `blob_fit_colour_split_min_chroma`: at least this share of the cells lies on its
    /// cluster's side of the plane (the clusters of two boxes lie apart, those of one box's
    /// shading or print do not; with no such test, cuts at every print and shadow). Default
    /// 0.9.
    pub blob_fit_colour_split_min_agree: f64,
    /// At most this many successive cuts per object (steps, colour cuts and colour clusters
    /// alike). Default 6.
    pub blob_max_cuts: u32,
    /// Cells within this multiple of the plane tolerance of a support plane are cut off
    /// objects (so a box does not join the table at its foot). Default 1.5.
    pub blob_support_gap_factor: f64,
    /// An object's cell belongs to a face when its normal is within this angle of the face's
    /// axis, degrees. Default 20.
    pub blob_normal_tol_deg: f64,
    /// An object's second and third faces need at least this fraction of its cells (and
    /// `min_face_cells`). Default 0.05.
    pub blob_min_face_fraction: f64,
    /// An object is a box candidate when at least this fraction of its cells lies on one of
    /// its face planes. Default 0.85.
    pub blob_min_fit: f64,
    /// ... and at least this fraction of its cell normals agrees with a face (normals blur
    /// over a few cells at every fold, so small boxes agree less). Default 0.5: against 0.6,
    /// bench AP@0.5 +0.03 to +0.06 on seed 11, within 0.005 on seeds 7 and 2026.
    pub blob_min_agree: f64,
    /// An object of three faces that fits (`blob_min_fit`, `blob_min_agree`) and bends past
    /// `max_bend_deg` but no more than this, degrees, is not dropped when no colour cut or
    /// two-colour split parts it (these are tried on misfits with `blob_colour_cut_misfits`,
    /// the default; without it such objects are dropped as before): it is scored as a box.
    /// A small box's faces are a few cells across, and the smoothed normals along their
    /// edges tilt towards the next face: a
    /// 99 × 60 × 58 mm box at 1.06 m (seed 11's 48-view table view 20) bent 10.5° and had no
    /// detection. Round things seldom show three perpendicular faces. 0 (or anything up to
    /// `max_bend_deg`) turns this off. Default 13 (bench, 48 views, seeds 2026 / 7 / 11 / 3 /
    /// 5 / 13, mean AP@0.5 of the 15 rows, with `blob_three_face_min_score` 0.8: 0.6817 →
    /// 0.6830, tables +0.002 on each row; 15° without trying the colour splits first gave
    /// 0.6827 with seed 2026's tables −0.002 to −0.004).
    pub blob_three_face_max_bend_deg: f64,
    /// ... and kept only when it scores at least this (silhouette IoU and depth consistency):
    /// two boxes of one colour touching also make a slightly bent object of three faces, and
    /// fit no cuboid well (one scored 0.56 and took a box's mask from 0.93 to 0.55 in seed
    /// 2026's table view 23). Default 0.8.
    pub blob_three_face_min_score: f64,
    /// An object of which no candidate came (it fit no cuboid, its faces bent, or its lone
    /// face filled no rectangle) is read once more as a box standing on the support: one axis
    /// along the support's up, the others those of the smallest rectangle around its cells
    /// seen along up, each cell on the nearest visible face plane (see
    /// `blobs::upright_frame`); failing that, its largest face alone. A box 41 × 45 × 156 mm
    /// standing 1.6 m away (seed 2026's 48-view table view 27) has sides a few cells wide
    /// whose smoothed normals blur into each other: it fit no cuboid of its own axes and had
    /// no detection. Tins, balls and other small round things are read so too, and nothing
    /// tried tells a small one from a box (the share of normals on a face, or the change of
    /// brightness across it, did not): the reading, kept when it scores `min_score` like
    /// any candidate, is then scored `blob_upright_score_factor` times that, below the
    /// detector's other candidates. Needs a support. Default on (bench, 48 views, seeds 2026
    /// / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 rows 0.7022 → 0.7042: tables with 0 / 8
    /// / 32 distractors +0.0035 / +0.0032 / +0.0032, pallets +0.0018, shelves −0.0015; with
    /// the reading's own score, not scaled down, 0.6867: the distractors' tins, scored
    /// 0.5–0.9, took the 32 distractors' row to 0.665). Costs about 14 ms a frame on the
    /// bench's tables with 32 distractors, whose tins it reads and the estimator then fits.
    pub blob_upright_fallback: bool,
    /// ... and it may be as thin as this along any axis, mm (in place of `min_box_extent_mm`):
    /// the cells next to the support are cut off the object, and a low box's sides with
    /// them (seed 2026's 48-view table view 21: a 53 × 100 × 46 mm box at 1.5 m showed 19
    /// mm of them). Default 10 (mean AP@0.5 on the bench above: 0.7055 → 0.7061 against
    /// 25, tables +0.0007 to +0.0010).
    pub blob_upright_min_extent_mm: f64,
    /// ... a cell belongs to the nearest visible face plane within this multiple of the plane
    /// tolerance at its depth. Default 2 (1.5 and 3 gave the same mean within 0.0001).
    pub blob_upright_face_tol_factor: f64,
    /// ... and only objects of at most this many cells are read so: the normals blur on a
    /// box a few cells across, and a large object that fits no cuboid is seldom a box (on
    /// ycbv-boxes, the desk's clutter). Default 1000 (mean AP@0.5 on the bench above:
    /// 0.7061 without a limit, 0.7060 with 1000, 0.7058 with 600 and 0.7055 with 300; on
    /// ycbv-boxes 105 clear false positives without a limit, 75 with 1000, against 47 with
    /// no upright reading).
    pub blob_upright_max_cells: u32,
    /// ... and it is then scored this times its own score: a last resort, below the other
    /// candidates. Default 0.05 (0.15: mean AP@0.5 0.7041, 0.3: 0.7034).
    pub blob_upright_score_factor: f64,
    /// Alternative readings: up to this many candidates per frame that lost a split decision
    /// (a coarse candidate cut into cartons by a seam, or the colour patches of one kept
    /// whole) are returned as well, flagged [`Detection::alternative`] and scored
    /// `alternative_score_factor` times their own score: where the chosen reading of a cluster
    /// is wrong (two cartons merged, one carton in pieces) the other may be right. Each costs
    /// one more estimate. The parts of profile cuts that lost to their whole
    /// (`blob_profile_cut_alternatives`) come on top of this many. 0 disables every
    /// alternative. Default 2 (bench, 24 views, AP@0.5 against 0, seeds
    /// 2026 / 7 / 11: pallets +0.018 / +0.004 / +0.010, tables +0.003 to +0.025, shelves
    /// +0.008 / +0.005 / 0, none lower; 4 gained up to +0.012 more on tables of seed 2026 only,
    /// at about 30 ms more per shelf frame; candidates dropped for overlapping a better one
    /// as well: no more AP, 50 % more alternatives).
    pub alternatives_max: u32,
    /// See `alternatives_max`. Default 0.1: most alternatives then rank below every detection
    /// (0.3 and 0.5 ranked them above weak true detections, which then lost their match:
    /// AP@0.25 fell by up to 0.06).
    pub alternative_score_factor: f64,
    /// Alternatives have at least this many faces. Default 2 (one-face alternatives, about a
    /// third of them, added no AP).
    pub alternative_min_faces: u8,
    /// An alternative differs from every detection and every other alternative: grid-cell
    /// IoU below this. Default 0.7.
    pub alternative_max_iou: f64,
    /// Readings of an estimate's one unseen extent as the larger visible one and as half of
    /// itself ([`crate::pipeline::hidden_extent_readings`]), scored this factor times the
    /// estimate; 0 disables. Default 0.1 (48-view bench, seeds 2026 / 7 / 11: mean AP@0.5 of the
    /// 15 rows 0.6795 → 0.6876, tables +0.006 to +0.009, shelves +0.016, pallets +0.001; 0.3
    /// 0.6865, 0.05 0.6875; only the larger visible one 0.6845, only the half 0.6837; adding
    /// twice the extent too 0.6881).
    pub hidden_reading_score_factor: f64,
    /// ... each only where it differs from the inferred extent by at least this fraction of
    /// it. Default 0.25.
    pub hidden_reading_min_change: f64,
    /// Readings of a carton at the next places of its layer's lattice
    /// ([`crate::pipeline::lattice_readings`]): the estimate moved by one of its own extents
    /// across its face towards the camera, where the depth shows that face, scored this factor
    /// times the estimate; 0 disables. Default 0.3. `anybox bench --detect-frames 48`, seeds
    /// 2026 / 7 / 11 / 3 / 5 / 13, mean AP@0.5 of the 15 detection rows, with
    /// `context.stand_on_min_share` 0.1: 0.7116 → 0.7126 (`lattice_min_on_face` 0.7 and
    /// `lattice_depth_tol_mm` 15; 0.8:
    /// 0.7124, and with the factor 0.5 0.7125), pallets 0.7155 → 0.7207, the other sets
    /// unchanged (shelves −0.0001 at 0.5). At 0.1 (0.8, with `stand_on_min_share` 0.3):
    /// 0.7116, pallets 0.7177.
    pub lattice_score_factor: f64,
    /// ... only for estimates whose size at least this many other estimates of the frame
    /// share (sorted extents within `repeat_split_tol`): a layer of one carton. Default 1
    /// (0, every estimate: the same mean AP@0.5, pallets +0.0016 and shelves −0.0013).
    pub lattice_min_copies: usize,
    /// ... where at least this share of a 7 × 7 grid over the moved face finds depth within
    /// `lattice_depth_tol_mm` of it. Default 0.6: at 1.5 m the depth noise leaves a face
    /// that is there with 0.8–0.95 of the grid, but a carton two places from the one it is
    /// read from, behind a pallet's front row at 2 m, showed 0.59–0.65 (seed 7's 48-view
    /// pallet view 40, tilt and noise; its source's own top 0.65–0.90). Six-seed bench as for
    /// `lattice_score_factor`, with `lattice_max_shared` 0.6 and `lattice_stack_min_facing`
    /// 0.3: mean AP@0.5 of the 30 detection rows 0.7363 at 0.7, 0.7373 at 0.6; alone,
    /// 0.7361 → 0.7364 at 0.6 and 0.7363 at 0.55 (pallets of seed 7 +0.008); a 40 mm
    /// tolerance instead: 0.7363.
    pub lattice_min_on_face: f64,
    /// ... tolerance of that depth test, mm. Default 25 (six seeds as for
    /// `lattice_score_factor`: 15 0.7126, 25 0.7131 with pallets 0.7207 → 0.7230 and no row
    /// lower, 40 0.7131 with pallets 0.7235 but tables with 32 distractors and shelves
    /// −0.0003).
    pub lattice_depth_tol_mm: f64,
    /// ... and where no estimate of the frame fills more than this share of the moved box.
    /// Default 0.6: a merge of two cartons (an estimate of twice the size) fills the place
    /// of the one behind it by a third to a half and hid it. Six-seed bench as above, with
    /// `lattice_min_on_face` 0.6 and stacks: 0.4: 0.7366, 0.5: 0.7371, 0.6: 0.7373, 0.8:
    /// 0.7375 (tables and shelves −0.0002), 1 (never filled): 0.7376 (tables without
    /// distractors −0.0004); alone (0.25 → 0.5): 0.7361 → 0.7365, pallets +0.0022.
    pub lattice_max_shared: f64,
    /// Readings of the next carton of a stack: the estimate moved along the normal of its face
    /// towards the camera, read on the face seen next best, only where that face's normal
    /// makes at least this |cos| with the viewing ray (a face seen edge-on shows no depth to
    /// read); above 1 disables. Default 0.3. Six-seed bench as for `lattice_score_factor`,
    /// with `lattice_min_on_face` 0.6 and `lattice_max_shared` 0.6: off 0.7371, on 0.7373
    /// (pallets 0.7733 → 0.7750: seed 13 +0.007, seed 11 +0.004, seed 3 −0.001), the same at
    /// 0.15 and 0.45; alone, on the defaults before: 0.7361 → 0.7363.
    pub lattice_stack_min_facing: f64,
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self {
            grid_step_px: 2,
            smooth_radius_cells: 2,
            normal_radius_cells: 2,
            radius_noise_ref: 1.3e-3,
            radius_max_cells: 4,
            depth_jump_abs_mm: 10.0,
            depth_jump_rel: 0.02,
            normal_cut_deg: 30.0,
            patch_normal_cut_deg_per_m: 10.0,
            patch_normal_cut_from_mm: 1000.0,
            patch_normal_cut_max_deg: 60.0,
            colour_cut: 12.0,
            seam_valley_levels: 3.0,
            seam_valley_rel: 0.05,
            seam_ridges: true,
            seam_min_pixels: 1,
            seam_close_cells: 1,
            seam_line_min_cells: 10,
            seam_line_gap_cells: 6,
            seam_line_density: 0.5,
            seam_line_reach_cells: 2,
            profile_seam_min_dip: 1.5,
            profile_seam_min_rel: 0.02,
            profile_seam_min_z: 6.0,
            profile_seam_max_chroma: 0.03,
            profile_seam_bin_mm: 2.0,
            profile_seam_min_piece_mm: 40.0,
            profile_seam_quarters: 3,
            profile_seam_top_deg: 45.0,
            tape_max_width_mm: 90.0,
            tape_min_contrast: 15.0,
            tape_colour_delta: 25.0,
            tape_overlap: 0.5,
            tape_sliver_cells: 128,
            tape_side_gap_cells: 10,
            tape_tilted_min_length: 0.4,
            tape_strip_max_tilt_deg: 75.0,
            tape_joint_min_share: 0.8,
            tape_joint_min_walks: 10,
            min_region_cells: 12,
            plane_tol_abs_mm: 4.0,
            plane_tol_quad_mm: 6.0,
            min_plane_inlier_frac: 0.8,
            max_normal_spread_deg: 25.0,
            max_bend_deg: 10.0,
            bend_ref_depth_mm: 2000.0,
            bend_strip_max_ratio: 0.05,
            bend_strip_min_cells: 800,
            curved_veto_min_ratio: 0.25,
            curved_veto_min_bend_deg: 15.0,
            curved_veto_max_on_plane: 0.75,
            support_min_area_mm2: 250_000.0,
            support_small_area_mm2: 60_000.0,
            support_always_area_mm2: 2_000_000.0,
            support_window_mm: 600.0,
            support_side_margin_mm: 30.0,
            support_min_front_fraction: 0.05,
            support_layer_min_fraction: 0.05,
            support_layer_min_depth_mm: 60.0,
            support_layer_max_depth_mm: 150.0,
            support_max_behind_fraction: 0.02,
            support_up_from_standing: true,
            support_up_hint: [0.0, -1.0, 0.0],
            support_up_max_angle_deg: 80.0,
            support_ransac_planes: 3,
            support_layer_ransac_min_fraction: 0.01,
            support_ransac_iters: 150,
            support_normal_tol_deg: 20.0,
            support_tol_factor: 1.5,
            min_face_cells: 25,
            contact_gap_cells: 12,
            edge_tol_factor: 3.0,
            min_contact_cells: 3,
            perpendicular_tol_deg: 15.0,
            convex_margin_mm: 5.0,
            edge_length_ratio: 0.4,
            corner_alternatives: true,
            coplanar_alternatives: true,
            strip_alternatives: true,
            band_alternatives: true,
            band_face_alternatives: true,
            band_open_factor: 0.6,
            band_face_max_width_mm: 90.0,
            lone_faces_of_failed_groups: true,
            extent_quantile: 0.02,
            per_face_extents: true,
            max_box_extent_mm: 800.0,
            min_box_extent_mm: 25.0,
            see_through_margin_mm: 10.0,
            occluders_unknown: true,
            one_face_factor: 0.45,
            min_one_face_iou: 0.84,
            min_one_face_corners: 0.2,
            face_min_corners: 0.05,
            face_corners_min_cells: 40,
            max_framed_fraction: 0.5,
            one_face_min_pixels: 500,
            evidence_half_pixels: 2000.0,
            two_face_factor: 0.8,
            min_score: 0.3,
            estimate_retry_below_score: 0.35,
            estimate_depth_samples: 300,
            estimate_retry_min_detection_score: 0.2,
            estimate_prior_reestimate: true,
            tiled_union_score_factor: 0.3,
            tiled_union_repeated_part_factor: 0.1,
            tiled_union_max_angle_deg: 10.0,
            tiled_union_min_fill: 0.83,
            tiled_union_max_shared: 0.1,
            gap_union_min_fill: 0.45,
            gap_union_max_see_through: 0.1,
            gap_union_see_through_tol_mm: 25.0,
            gap_union_see_through_tol_rel: 0.01,
            corner_union_max_shared: 0.6,
            corner_union_min_fill: 0.5,
            repeat_split_score_factor: 0.3,
            repeat_split_tol: 0.12,
            repeat_split_max_parts: 4,
            repeat_extend_min_ratio: 0.15,
            repeat_split_min_reference_ratio: 0.5,
            repeat_promote_min_copies: 2,
            repeat_boost_min_copies: 2,
            repeat_boost_odds: 3.0,
            repeat_boost_min_aspect: 0.35,
            repeat_boost_min_extent_mm: 200.0,
            one_face_inferred_factor: 1.7,
            round_max_ratio: 0.5,
            round_min_points: 150,
            round_min_share: 0.1,
            round_normals_max_ratio: 1.0,
            round_normals_min_share: 0.2,
            round_cap_min_points: 100,
            round_cap_tol_mm: 8.0,
            round_cap_min_empty: 4,
            round_score_factor: 0.3,
            duplicate_iou: 0.5,
            duplicate_score_factor: 0.3,
            split_min_seam_cells: 9,
            split_flap_check: true,
            split_flap_max_colour_delta: 40.0,
            halves_min_aspect: 1.6,
            halves_top_min_aspect: 1.0,
            halves_top_max_tilt_deg: 45.0,
            halves_side_chains: false,
            halves_tape_band_contrast: 7.0,
            halves_min_ratio: 0.8,
            halves_gap_mm: 15.0,
            halves_joint_check: true,
            halves_joint_labels: true,
            halves_isolated_pairs: true,
            halves_isolated_sides: false,
            halves_end_max_tilt_deg: 30.0,
            halves_end_max_on_plane: 1.0 / 3.0,
            split_seam_reach_cells: 3,
            split_min_fraction: 0.03,
            split_carton_min_faces: 3,
            split_step_min_mm: 3.0,
            split_carton_min_score_ratio: 0.85,
            split_carton_max_fraction: 0.75,
            max_overlap: 0.3,
            residual_score_factor: 1.7,
            residual_max_cells: 2500,
            remain_join_min_score_ratio: 0.9,
            remain_join_max_faces: 1,
            remain_join_max_size_ratio: 1.5,
            fill_margin_factor: 1.0,
            side_strip_max_mm: 600.0,
            fill_support_reach_factor: 2.5,
            mask_open_px: 3,
            hole_grow_max_fraction: 0.5,
            hole_grow_min_valid: 0.15,
            hole_grow_min_piece: 0.02,
            hole_grow_step_colour: 15.0,
            hole_grow_colour: 40.0,
            side_strip_slack_deg: 4.0,
            side_strip_min_cells: 60,
            occluded_reach_mm: 400.0,
            occluded_min_front: 0.5,
            occluded_min_cells: 12,
            occluded_colour_max: 30.0,
            occluded_shading: true,
            occluded_shading_max_ratio: 1.6,
            occluded_absorb_fraction: 0.6,
            occluded_lead_skips_claimed: true,
            blobs: true,
            blob_split_concave: true,
            blob_colour_cut_misfits: true,
            blob_colour_split_min_chroma: 0.08,
            blob_fit_colour_split_min_chroma: 0.1,
            blob_fit_colour_split_min_agree: 0.9,
            blob_colour_split_max_cells: 2500,
            blob_max_cuts: 6,
            blob_colour_cut_delta: 0.35,
            blob_colour_cut_min_fraction: 0.15,
            blob_colour_cut_max_spread: 0.1,
            blob_step_factor: 4.0,
            blob_profile_cut_min_mm: 15.0,
            blob_profile_cut_min_part_mm: 30.0,
            blob_profile_cut_margin: 0.1,
            blob_profile_cut_alternatives: true,
            blob_profile_cut_occluder_share: 0.125,
            blob_weak_step_factor: 1.0,
            blob_step_min_fraction: 0.15,
            blob_stack_max_tilt_deg: 20.0,
            blob_stack_margin: 0.05,
            blob_stack_cut_tols: 1.0,
            blob_support_gap_factor: 1.5,
            blob_normal_tol_deg: 20.0,
            blob_min_face_fraction: 0.05,
            blob_min_fit: 0.85,
            blob_min_agree: 0.5,
            blob_three_face_max_bend_deg: 13.0,
            blob_three_face_min_score: 0.8,
            blob_upright_fallback: true,
            blob_upright_face_tol_factor: 2.0,
            blob_upright_min_extent_mm: 10.0,
            blob_upright_max_cells: 1000,
            blob_upright_score_factor: 0.05,
            alternatives_max: 2,
            alternative_score_factor: 0.1,
            alternative_min_faces: 2,
            alternative_max_iou: 0.7,
            hidden_reading_score_factor: 0.1,
            hidden_reading_min_change: 0.25,
            lattice_score_factor: 0.3,
            lattice_min_copies: 1,
            lattice_min_on_face: 0.6,
            lattice_depth_tol_mm: 25.0,
            lattice_max_shared: 0.6,
            lattice_stack_min_facing: 0.3,
        }
    }
}

/// One detected box candidate.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Visible-surface mask at the frame's size.
    pub mask: Mask,
    /// Confidence, 0..1: box-likeness (plane fit × silhouette IoU × depth consistency ×
    /// face-count factor) times the evidence factor of the mask's size
    /// ([`DetectConfig::evidence_half_pixels`]).
    pub score: f64,
    /// Visible faces grouped into this box (1..=3).
    pub n_faces: u8,
    /// An alternative reading ([`DetectConfig::alternatives_max`]): it overlaps detections
    /// that won the selection, and at most one of them is the right reading.
    pub alternative: bool,
}

/// Why a frame could not be processed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DetectError {
    /// The depth map has no valid (positive, finite) pixel.
    #[error("depth map has no valid pixel ({width}x{height} px, all zero or non-finite)")]
    NoValidDepth {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
    },
    /// RGB and depth differ in size.
    #[error("RGB image is {rgb_width}x{rgb_height} px but depth is {depth_width}x{depth_height} px; they must be registered at one size")]
    SizeMismatch {
        /// RGB width, px.
        rgb_width: u32,
        /// RGB height, px.
        rgb_height: u32,
        /// Depth width, px.
        depth_width: u32,
        /// Depth height, px.
        depth_height: u32,
    },
    /// The depth buffer's length is not width × height (or the frame is empty).
    #[error("depth map is {width}x{height} px but holds {len} values")]
    BadDepthBuffer {
        /// Width, px.
        width: u32,
        /// Height, px.
        height: u32,
        /// Values in the buffer.
        len: usize,
    },
    /// Intrinsics not finite or focal lengths not positive.
    #[error("invalid intrinsics: fx {fx}, fy {fy}, cx {cx}, cy {cy} px")]
    BadIntrinsics {
        /// fx, px.
        fx: f64,
        /// fy, px.
        fy: f64,
        /// cx, px.
        cx: f64,
        /// cy, px.
        cy: f64,
    },
}

/// Detects boxes in one frame: instance masks with box-likeness scores, sorted by score
/// (descending), deterministic. `rgb`, when given, must have the depth map's size; without it
/// only depth and normal cues separate boxes.
pub fn detect_boxes(
    rgb: Option<&RgbImage>,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    cfg: &DetectConfig,
) -> Result<Vec<Detection>, DetectError> {
    validate(rgb, depth, intrinsics)?;
    let (w, h) = (depth.width, depth.height);
    let mut g = grid::Grid::build(rgb, depth, intrinsics, cfg);
    let p = pool(&g, rgb, cfg);
    // The faint joints are seams from here on: the split evidence and the hole filling read
    // them.
    for &i in &p.faint_seams {
        g.seam[i as usize] = true;
    }
    let (mut chosen, alts) = select(&g, p.objects, p.geo, p.col, cfg);
    // Support cells, and cells next to a support facing like it, are never filled in: at a
    // box's foot they lie inside its silhouette at about its depth, and the estimator would
    // take them for the box. (The box's own foot, cut off its object, faces sideways.)
    let base_claims: Vec<bool> = (0..g.z.len())
        .into_par_iter()
        .map(|i| p.on_support[i] || (p.off[i] && flat_near_support(&g, &p.planes, i, cfg)))
        .collect();
    // Each alternative is filled on its own, beside the detections: it may take what they
    // took. The alternatives need neither the residual candidates nor the detections' fill,
    // so they are filled while those run.
    let (cands, alt_cands): (_, Vec<boxes::Candidate>) = rayon::join(
        || {
            let residual = residual_candidates(&g, &p.joins, &p.off, &p.planes, &chosen, p.up, cfg);
            chosen.extend(residual);
            remains::join_remains(&g, &p.joins, &p.off, &mut chosen, cfg);
            let mut claimed = base_claims.clone();
            boxes::fill(&g, chosen, &mut claimed, &p.planes, p.up, cfg)
        },
        || {
            alts.into_par_iter()
                .flat_map(|a| {
                    boxes::fill(&g, vec![a], &mut base_claims.clone(), &p.planes, p.up, cfg)
                })
                .collect()
        },
    );
    let (fw, fh) = (w as usize, h as usize);
    let area = (fw * fh) as f64 / (640.0 * 480.0);
    let one_face_min = cfg.one_face_min_pixels as f64 * area;
    let half = cfg.evidence_half_pixels.max(0.0) * area;
    // Frame-sized masks, built in parallel (the order is kept).
    let mut out: Vec<(Detection, Shape)> = cands
        .into_par_iter()
        .map(|c| (c, false))
        .chain(alt_cands.into_par_iter().map(|c| (c, true)))
        .filter_map(|(c, alternative)| {
            let mut mask = cells_to_mask(&g, depth, &c.cells, Some(cfg));
            // Spurs of the fill go before the mask is weighed and before the side strips
            // (thin by nature) come in.
            open_mask(&mut mask, cfg.mask_open_px as usize);
            let px = mask.count() as f64;
            if c.n_faces == 1 && px < one_face_min {
                return None;
            }
            paint_cells(&mut mask, &g, depth, &c.strip, Some(cfg));
            let factor = if alternative {
                cfg.alternative_score_factor
            } else {
                1.0
            };
            let d = Detection {
                mask,
                score: c.score * evidence(px, half) * factor,
                n_faces: c.n_faces,
                alternative,
            };
            // The mask lies within its cells' pixels (the opening only removes).
            let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0, 0);
            for &i in c.cells.iter().chain(&c.strip) {
                let (gu, gv) = (i as usize % g.w, i as usize / g.w);
                (u0, v0, u1, v1) = (u0.min(gu), v0.min(gv), u1.max(gu), v1.max(gv));
            }
            let bounds = (u0 <= u1).then(|| {
                let s = g.step;
                (
                    u0 * s,
                    v0 * s,
                    ((u1 + 1) * s).min(fw) - 1,
                    ((v1 + 1) * s).min(fh) - 1,
                )
            });
            Some((d, Shape { bx: c.bx, bounds }))
        })
        .collect();
    // Best first (stable: equal scores keep the selection order).
    out.sort_by(|a, b| b.0.score.total_cmp(&a.0.score));
    let (mut out, shapes): (Vec<Detection>, Vec<Shape>) = out.into_iter().unzip();
    if let Some(rgb) = rgb {
        grow_into_holes(&mut out, &shapes, &g, rgb, depth, intrinsics, cfg);
    }
    Ok(out)
}

/// Masks taken on into the dropouts next to them that continue their face (see
/// [`DetectConfig::hole_grow_max_fraction`]). The detections grow together, each pixel going
/// to the mask that reaches it first, into what no detection holds; each alternative grows
/// on its own into what no primary detection holds.
fn grow_into_holes(
    dets: &mut [Detection],
    shapes: &[Shape],
    g: &grid::Grid,
    rgb: &RgbImage,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    cfg: &DetectConfig,
) {
    if cfg.hole_grow_max_fraction <= 0.0 {
        return;
    }
    let (w, h) = (depth.width as usize, depth.height as usize);
    let mut held = vec![false; w * h];
    for (d, sh) in dets.iter().zip(shapes).filter(|(d, _)| !d.alternative) {
        or_into(&mut held, &d.mask, sh.bounds);
    }
    let primary: Vec<usize> = (0..dets.len()).filter(|&k| !dets[k].alternative).collect();
    let ctx = Grow {
        g,
        rgb: rgb.as_raw(),
        depth,
        k: intrinsics,
        cfg,
        held: &held,
        w,
        h,
    };
    let masks: Vec<(&Mask, &Shape)> = primary
        .iter()
        .map(|&k| (&dets[k].mask, &shapes[k]))
        .collect();
    let alts: Vec<usize> = (0..dets.len()).filter(|&k| dets[k].alternative).collect();
    // The detections grow together, beside the alternatives (each on its own).
    let (added, grown): (_, Vec<Vec<usize>>) = rayon::join(
        || ctx.grow(&masks, held.clone()),
        || {
            alts.par_iter()
                .map(|&k| {
                    let mut taken = held.clone();
                    or_into(&mut taken, &dets[k].mask, shapes[k].bounds);
                    ctx.grow(&[(&dets[k].mask, &shapes[k])], taken)
                        .swap_remove(0)
                })
                .collect()
        },
    );
    // Every growth above read the masks as they were; each takes its pixels only now.
    for (&k, px) in primary.iter().zip(added).chain(alts.iter().zip(grown)) {
        for i in px {
            dets[k].mask.data[i] = true;
        }
    }
}

/// A detection's cuboid and a pixel box holding its mask (`u0, v0, u1, v1`, inclusive;
/// `None`: empty), for [`grow_into_holes`].
struct Shape {
    bx: OrientedBox,
    bounds: Option<(usize, usize, usize, usize)>,
}

/// Sets the pixels of `m` in `acc` (frame-sized), within `bounds` (which hold `m`).
fn or_into(acc: &mut [bool], m: &Mask, bounds: Option<(usize, usize, usize, usize)>) {
    let w = m.width as usize;
    if let Some((u0, v0, u1, v1)) = bounds {
        for v in v0..=v1 {
            let row = v * w + u0..=v * w + u1;
            for (a, &x) in acc[row.clone()].iter_mut().zip(&m.data[row]) {
                *a |= x;
            }
        }
    }
}

/// A face plane: unit normal (facing the camera) and offset (mm): `n · p = d` on it.
type Plane = (Vector3<f64>, f64);

/// The colour (RGB levels) and plane of the face a growth keeps to.
type FaceRef = ([f64; 3], Plane);

/// What [`grow_into_holes`] grows with.
struct Grow<'a> {
    g: &'a grid::Grid,
    rgb: &'a [u8],
    depth: &'a DepthMap,
    k: &'a Intrinsics,
    cfg: &'a DetectConfig,
    /// Pixels of every primary detection before growing: never taken.
    held: &'a [bool],
    w: usize,
    h: usize,
}

impl Grow<'_> {
    /// The pixels within `r` of pixel `i` (a square, clipped to the frame): `(u, v, index)`.
    fn window(&self, i: usize, r: isize) -> impl Iterator<Item = (isize, isize, usize)> {
        let (w, h) = (self.w as isize, self.h as isize);
        let (u, v) = ((i % self.w) as isize, (i / self.w) as isize);
        ((v - r).max(0)..=(v + r).min(h - 1))
            .flat_map(move |y| ((u - r).max(0)..=(u + r).min(w - 1)).map(move |x| (x, y)))
            .map(move |(x, y)| (x, y, (y * w + x) as usize))
    }

    fn col(&self, i: usize) -> [f64; 3] {
        [
            self.rgb[3 * i] as f64,
            self.rgb[3 * i + 1] as f64,
            self.rgb[3 * i + 2] as f64,
        ]
    }

    /// The colour and plane of the face a growth starts from at mask pixel `i`: the mean
    /// colour of the pixels within 4 px whose neighbours 2 px away along the row and column
    /// are in the mask (clear of the mixed colours along its outline), and the plane of the
    /// cuboid's camera-facing face ([`crate::refine::visible_faces`]) nearest to the mask's
    /// valid points there.
    fn reference(&self, m: &Mask, bx: &OrientedBox, i: usize) -> Option<FaceRef> {
        let (w, h) = (self.w, self.h);
        let interior = |j: usize| -> bool {
            let (u, v) = (j % w, j / w);
            u >= 2
                && v >= 2
                && u + 2 < w
                && v + 2 < h
                && m.data[j - 2]
                && m.data[j + 2]
                && m.data[j - 2 * w]
                && m.data[j + 2 * w]
        };
        let (mut sum, mut n) = ([0.0; 3], 0usize);
        let (mut ps, mut np) = (Vector3::zeros(), 0usize);
        for (x, y, j) in self.window(i, 4) {
            if !m.data[j] {
                continue;
            }
            if interior(j) {
                let c = self.col(j);
                (0..3).for_each(|k| sum[k] += c[k]);
                n += 1;
            }
            let z = self.depth.depth_mm[j] as f64;
            if z > 0.0 {
                ps += self.k.back_project(x as f64, y as f64, z).coords;
                np += 1;
            }
        }
        if n < 5 || np < 5 {
            return None;
        }
        let p = ps / np as f64;
        let half = bx.half_size_mm();
        let (faces, n_faces) = crate::refine::visible_faces(bx);
        let mut best: Option<(f64, Plane)> = None;
        for &(a, sign) in &faces[..n_faces] {
            let nrm = bx.axis(a) * sign;
            let off = nrm.dot(&bx.center_mm) + half[a];
            let d = (nrm.dot(&p) - off).abs();
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, (nrm, off)));
            }
        }
        best.map(|b| (sum.map(|x| x / n as f64), b.1))
    }

    /// Whether pixel `j` lies among dropouts of the face plane `(n, d)`. Around it (5 × 5,
    /// detections' pixels left out) most valid pixels must lie within twice the plane
    /// tolerance of the plane (a stereo shadow or hole on the background lies off the face).
    /// A pixel without depth needs `hole_grow_min_valid` of them valid (a solid hole is no
    /// face's); a valid one must itself lie on the plane, with `hole_grow_min_valid` of them
    /// without depth (the valid pixels of a speckled band, which its dropouts alone do not
    /// connect, and not the rest of a face the segmentation left out).
    fn among_dropouts(&self, j: usize, plane: &Plane) -> bool {
        let (ju, jv) = ((j % self.w) as isize, (j / self.w) as isize);
        let on_plane = |x: isize, y: isize, z: f64| -> bool {
            let p = self.k.back_project(x as f64, y as f64, z).coords;
            (plane.0.dot(&p) - plane.1).abs() <= 2.0 * regions::plane_tol(self.cfg, z)
        };
        let zj = self.depth.depth_mm[j] as f64;
        if zj > 0.0 && !on_plane(ju, jv, zj) {
            return false;
        }
        let (mut valid, mut near, mut all) = (0usize, 0usize, 0usize);
        for (x, y, k) in self.window(j, 2) {
            if self.held[k] {
                continue;
            }
            all += 1;
            let z = self.depth.depth_mm[k] as f64;
            if z > 0.0 {
                valid += 1;
                near += on_plane(x, y, z) as usize;
            }
        }
        let share = self.cfg.hole_grow_min_valid * all as f64;
        let enough = if zj > 0.0 {
            (all - valid) as f64 >= share
        } else {
            valid as f64 >= share
        };
        enough && near > 0 && 2 * near > valid
    }

    /// Grows `masks` together (breadth first: each pixel to the first mask to reach it) into
    /// what `taken` leaves (it holds the masks themselves); returns the pixels each takes on.
    fn grow(&self, masks: &[(&Mask, &Shape)], mut taken: Vec<bool>) -> Vec<Vec<usize>> {
        let (w, h, cfg) = (self.w, self.h, self.cfg);
        let dist = |a: &[f64; 3], b: &[f64; 3]| -> f64 {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        };
        let mut owner = vec![u32::MAX; w * h];
        // The last mask (+ 1) that found the pixel off its face; 0: none.
        let mut refused = vec![0u32; w * h];
        let mut caps = Vec::with_capacity(masks.len());
        let mut sizes = Vec::with_capacity(masks.len());
        // (pixel, mask, the face its growth keeps to; None: a mask pixel, not yet known)
        type Item = (usize, usize, Option<FaceRef>);
        let mut queue: std::collections::VecDeque<Item> = Default::default();
        for (k, (m, sh)) in masks.iter().enumerate() {
            let mut n = 0usize;
            if let Some((u0, v0, u1, v1)) = sh.bounds {
                for v in v0..=v1 {
                    for u in u0..=u1 {
                        let i = v * w + u;
                        if !m.data[i] {
                            continue;
                        }
                        n += 1;
                        owner[i] = k as u32;
                        // Growth starts on the outline only.
                        let edge = u == 0
                            || v == 0
                            || u + 1 == w
                            || v + 1 == h
                            || !m.data[i - 1]
                            || !m.data[i + 1]
                            || !m.data[i - w]
                            || !m.data[i + w];
                        if edge {
                            queue.push_back((i, k, None));
                        }
                    }
                }
            }
            caps.push((cfg.hole_grow_max_fraction * n as f64) as usize);
            sizes.push(n);
        }
        let mut added: Vec<Vec<usize>> = vec![Vec::new(); masks.len()];
        let mut refs: rustc_hash::FxHashMap<(usize, usize, usize), Option<FaceRef>> =
            Default::default();
        let nbrs = |i: usize| {
            let (u, v) = (i % w, i / w);
            [
                (u > 0).then(|| i - 1),
                (u + 1 < w).then(|| i + 1),
                (v > 0).then(|| i - w),
                (v + 1 < h).then(|| i + w),
            ]
        };
        while let Some((i, k, known)) = queue.pop_front() {
            if added[k].len() >= caps[k] {
                continue;
            }
            let ci = self.col(i);
            let mut keep = known;
            for j in nbrs(i).into_iter().flatten() {
                if taken[j] {
                    continue;
                }
                // Seams part flush cartons here too.
                let cell = (j / w / self.g.step) * self.g.w + (j % w) / self.g.step;
                if self.g.seam.get(cell).copied().unwrap_or(true) {
                    continue;
                }
                // The colour step first: cheap, and it turns most neighbours away.
                let cj = self.col(j);
                if dist(&cj, &ci) > cfg.hole_grow_step_colour {
                    continue;
                }
                if keep.is_none() {
                    // One reference per 4 × 4 block of a mask's outline: neighbouring
                    // windows nearly coincide, and each costs a few hundred pixel reads.
                    let block = (k, i / w / 4, (i % w) / 4);
                    keep = *refs
                        .entry(block)
                        .or_insert_with(|| self.reference(masks[k].0, &masks[k].1.bx, i));
                }
                let Some((c_ref, plane)) = keep else {
                    break;
                };
                if dist(&cj, &c_ref) > cfg.hole_grow_colour {
                    continue;
                }
                // A pixel off the face for one mask is, nearly always, for it from another
                // side too: tried once per mask.
                if refused[j] == k as u32 + 1 {
                    continue;
                }
                if !self.among_dropouts(j, &plane) {
                    refused[j] = k as u32 + 1;
                    continue;
                }
                taken[j] = true;
                owner[j] = k as u32;
                added[k].push(j);
                queue.push_back((j, k, Some((c_ref, plane))));
                if added[k].len() >= caps[k] {
                    break;
                }
            }
        }
        // Pixels with depth left inside a grown part (the speckle's valid ones): those with
        // three or four neighbours of that mask.
        for _ in 0..2 {
            let mut fill: Vec<(usize, usize)> = Vec::new();
            for (k, px) in added.iter().enumerate() {
                for &i in px {
                    for j in nbrs(i).into_iter().flatten() {
                        if taken[j] {
                            continue;
                        }
                        let inn = nbrs(j)
                            .into_iter()
                            .flatten()
                            .filter(|&x| owner[x] == k as u32)
                            .count();
                        if inn >= 3 {
                            fill.push((j, k));
                        }
                    }
                }
            }
            for (j, k) in fill {
                if !taken[j] {
                    taken[j] = true;
                    owner[j] = k as u32;
                    added[k].push(j);
                }
            }
        }
        // Small grown pieces go: a few pixels past a mask's edge stretch its silhouette,
        // which the estimator cannot check without depth; a face's missing band is large.
        for (k, px) in added.iter_mut().enumerate() {
            let min = (cfg.hole_grow_min_piece * sizes[k] as f64).ceil() as usize;
            if min <= 1 || px.is_empty() {
                continue;
            }
            let mut seen: rustc_hash::FxHashSet<usize> = Default::default();
            let mut keep = Vec::with_capacity(px.len());
            for &start in px.iter() {
                if !seen.insert(start) {
                    continue;
                }
                let mut piece = vec![start];
                let mut at = 0;
                while at < piece.len() {
                    let i = piece[at];
                    at += 1;
                    // Pieces of a speckled band join across the valid pixels between.
                    for (_, _, j) in self.window(i, 2) {
                        if owner[j] == k as u32 && !masks[k].0.data[j] && seen.insert(j) {
                            piece.push(j);
                        }
                    }
                }
                if piece.len() >= min {
                    keep.extend(piece);
                }
            }
            *px = keep;
        }
        added
    }
}

/// Score factor for a mask of `px` pixels: `px / (px + half)`, 1 when `half` is 0 (see
/// [`DetectConfig::evidence_half_pixels`], already scaled to the image).
fn evidence(px: f64, half: f64) -> f64 {
    if half > 0.0 {
        px / (px + half)
    } else {
        1.0
    }
}

/// The candidates of the three segmentations, before selection, and what selection and fill
/// need of the support analysis.
struct Pool {
    /// Connected objects (depth continuity, cut at creases and steps).
    objects: Vec<boxes::Raw>,
    /// Groups of smooth surfaces.
    geo: Vec<boxes::Raw>,
    /// Groups of colour-uniform patches.
    col: Vec<boxes::Raw>,
    /// Cells beside the cuts at faint seams (`profiles`): seam cells from here on.
    faint_seams: Vec<u32>,
    /// Support cells (floors, tables, shelf boards).
    on_support: Vec<bool>,
    /// Cells cut off every object (near a support).
    off: Vec<bool>,
    /// Support planes.
    planes: Vec<regions::Region>,
    /// "Up": the normal of the floor-like support (see `support_up_hint`), if one was found.
    up: Option<nalgebra::Vector3<f64>>,
    /// The cell joins every segmentation used.
    joins: regions::Joins,
}

/// "Up" for telling side faces from tops: the floor-like support's normal, else the
/// configured hint (unit), else `None` (no face is known to be a side face).
fn side_face_up(
    up: Option<nalgebra::Vector3<f64>>,
    cfg: &DetectConfig,
) -> Option<nalgebra::Vector3<f64>> {
    up.or_else(|| nalgebra::Vector3::from(cfg.support_up_hint).try_normalize(1e-9))
}

/// The colour patches (`labels`, fitted as `patches`) cut along seam lines (`lines`), then
/// side faces at faint seams in `rgb` (`profiles`, with `side_up`). Returns the pieces' plane
/// fits (refitted only where something was cut) and the cells beside the faint cuts.
fn cut_at_seams(
    g: &grid::Grid,
    rgb: Option<&RgbImage>,
    labels: &mut [u32],
    patches: Vec<regions::Region>,
    side_up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> (Vec<regions::Region>, Vec<u32>) {
    let refit = |labels: &[u32], patches: Vec<regions::Region>, n: usize| {
        if n == patches.len() {
            patches
        } else {
            regions::fit_regions(g, labels, n, cfg)
        }
    };
    let n_cut = lines::cut_along_seam_lines(g, labels, patches.len(), cfg);
    let patches = refit(labels, patches, n_cut);
    let (n_cut, faint) = profiles::cut_at_faint_seams(g, rgb, labels, &patches, side_up, cfg);
    (refit(labels, patches, n_cut), faint)
}

fn pool(g: &grid::Grid, rgb: Option<&RgbImage>, cfg: &DetectConfig) -> Pool {
    let has_rgb = rgb.is_some();
    // Two levels: smooth surfaces regardless of colour (a box face with its tape, labels and
    // print), and colour-uniform patches (which separate flush cartons). The dominant planes
    // need neither: found beside them.
    let ((joins, geo_labels, surfaces), ransac) = rayon::join(
        || {
            let joins = regions::joins(g, has_rgb, &g.seam, cfg);
            let (labels, surfaces) = regions::segment(g, &joins, Cues::Geometry, None, cfg);
            (joins, labels, surfaces)
        },
        || boxes::ransac_planes(g, cfg),
    );
    let (on_support, planes, up) =
        boxes::support_mask(g, &geo_labels, &surfaces, Some(ransac), cfg);
    let side_up = side_face_up(up, cfg);
    // Segment again without the support cells: what leaked into a support becomes its own.
    // Surfaces, colour patches and objects are independent from here: built in parallel.
    let (geo, ((col, faint_seams), (off, objects))) = rayon::join(
        || {
            let (labels, surfaces) =
                regions::segment(g, &joins, Cues::Geometry, Some(&on_support), cfg);
            let c = boxes::group_candidates(g, &labels, &surfaces, &on_support, false, up, cfg);
            boxes::drop_support_fragments(g, c, &planes, cfg)
        },
        || {
            rayon::join(
                || {
                    let (mut labels, patches) =
                        regions::segment(g, &joins, Cues::All, Some(&on_support), cfg);
                    let (patches, faint) = cut_at_seams(g, rgb, &mut labels, patches, side_up, cfg);
                    let mut strip = vec![false; g.z.len()];
                    let n_patches = regions::bridge_tape(g, &mut labels, &patches, &mut strip, cfg);
                    let patches = regions::fit_regions(g, &labels, n_patches, cfg);
                    let n_joined =
                        halves::pair_halves(g, &mut labels, &patches, &strip, side_up, cfg);
                    let patches = if n_joined == n_patches {
                        patches
                    } else {
                        regions::fit_regions(g, &labels, n_joined, cfg)
                    };
                    let c =
                        boxes::group_candidates(g, &labels, &patches, &on_support, true, up, cfg);
                    (boxes::drop_support_fragments(g, c, &planes, cfg), faint)
                },
                || {
                    let (obj_labels, off, n_obj) =
                        object_labels(g, &joins, &on_support, &planes, cfg);
                    let objects = if cfg.blobs {
                        let c = blobs::blob_candidates(g, &obj_labels, n_obj, &off, up, cfg);
                        boxes::drop_support_fragments(g, c, &planes, cfg)
                    } else {
                        Vec::new()
                    };
                    (off, objects)
                },
            )
        },
    );
    Pool {
        objects,
        geo,
        col,
        faint_seams,
        on_support,
        off,
        planes,
        up,
        joins,
    }
}

/// Candidates from what the selected candidates left of the connected objects (see
/// [`DetectConfig::residual_score_factor`]).
fn residual_candidates(
    g: &grid::Grid,
    joins: &regions::Joins,
    off: &[bool],
    planes: &[regions::Region],
    chosen: &[boxes::Raw],
    up: Option<Vector3<f64>>,
    cfg: &DetectConfig,
) -> Vec<boxes::Raw> {
    if cfg.residual_score_factor <= 0.0 || !cfg.blobs {
        return Vec::new();
    }
    let mut excl = off.to_vec();
    for c in chosen {
        for &i in &c.cells {
            excl[i as usize] = true;
        }
    }
    let (mut labels, n_objects) = regions::label(g, joins, Cues::Depth, Some(&excl), cfg);
    // Only what touches a selected candidate is new: any other object is whole, and was tried
    // (and lost) in the pool.
    let mut touches = vec![false; n_objects];
    for c in chosen {
        for &i in &c.cells {
            let (u, v) = (i as usize % g.w, i as usize / g.w);
            let mut mark = |j: usize| {
                if labels[j] != regions::NONE {
                    touches[labels[j] as usize] = true;
                }
            };
            if u > 0 {
                mark(i as usize - 1);
            }
            if u + 1 < g.w {
                mark(i as usize + 1);
            }
            if v > 0 {
                mark(i as usize - g.w);
            }
            if v + 1 < g.h {
                mark(i as usize + g.w);
            }
        }
    }
    let mut n_cells = vec![0u32; n_objects];
    for &l in &labels {
        if l != regions::NONE {
            n_cells[l as usize] += 1;
        }
    }
    // Remains left out (not touching, or too large) count against a candidate's silhouette
    // in the scoring, as other objects' cells do in the pool.
    for (l, x) in labels.iter_mut().zip(excl.iter_mut()) {
        if *l != regions::NONE
            && (!touches[*l as usize] || n_cells[*l as usize] > cfg.residual_max_cells)
        {
            *l = regions::NONE;
            *x = true;
        }
    }
    let c = blobs::blob_candidates(g, &labels, n_objects, &excl, up, cfg);
    let min = cfg.min_score * cfg.residual_score_factor;
    let c = boxes::drop_support_fragments(g, c, planes, cfg);
    let mut taken = vec![false; g.z.len()];
    let mut out = Vec::new();
    for c in c {
        if c.score < min || !claim(&c, &mut taken, cfg) {
            continue;
        }
        log::debug!(
            "residual score {:.3} faces {} cells {}",
            c.score,
            c.n_faces,
            c.cells.len()
        );
        out.push(c);
    }
    out
}

/// The frame-size mask of grid `cells`. With `drop_behind`, a cell keeps its front surface:
/// pixels well behind the cell's depth (by the jump tolerance) are the background seen past a
/// box's rim, which the estimator would take for box.
fn cells_to_mask(
    g: &grid::Grid,
    depth: &DepthMap,
    cells: &[u32],
    drop_behind: Option<&DetectConfig>,
) -> Mask {
    let mut mask = Mask::empty(depth.width, depth.height);
    paint_cells(&mut mask, g, depth, cells, drop_behind);
    mask
}

/// Morphological opening of `mask` with a `(2r+1) × (2r+1)` square: a pixel stays when some
/// such square holding it lies within the mask. Lines and spurs narrower than the square go,
/// faces stay. Pixels beyond the frame count as set (the object goes on past the image's edge),
/// so a mask cut by the border keeps its pixels along it.
fn open_mask(mask: &mut Mask, r: usize) {
    if r == 0 {
        return;
    }
    let Some((u0, v0, u1, v1)) = mask.bbox() else {
        return;
    };
    let (w, h) = (mask.width as isize, mask.height as isize);
    let ri = r as isize;
    // The bounding box grown by r, past the frame's edges too: every square centre that can
    // reach a pixel of the mask. The erosion is the dilation of the complement, which takes
    // what lies beyond the window as unset, so the erosion takes it as set: right past a frame
    // edge, and harmless elsewhere (a window position within r of the window's end is within
    // r of an unset pixel inside it).
    let (x0, y0) = (u0 as isize - ri, v0 as isize - ri);
    let (ww, wh) = (
        (u1 - u0) as usize + 1 + 2 * r,
        (v1 - v0) as usize + 1 + 2 * r,
    );
    // The window's columns inside the frame, and where each window row's part inside the
    // frame starts in the mask (`None` for rows outside the frame).
    let xs = (-x0).max(0) as usize..((w - x0) as usize).min(ww);
    let fx0 = (x0 + xs.start as isize) as usize;
    let frame_start = |y: usize| -> Option<usize> {
        let fy = y0 + y as isize;
        (0..h).contains(&fy).then(|| fy as usize * w as usize + fx0)
    };
    let mut outside = vec![false; ww * wh];
    for y in 0..wh {
        if let Some(s) = frame_start(y) {
            let win = &mut outside[y * ww + xs.start..y * ww + xs.end];
            for (o, &m) in win.iter_mut().zip(&mask.data[s..s + xs.len()]) {
                *o = !m;
            }
        }
    }
    let mut eroded = dilate_square(&outside, ww, wh, r);
    eroded.iter_mut().for_each(|b| *b = !*b);
    let opened = dilate_square(&eroded, ww, wh, r);
    for y in 0..wh {
        if let Some(s) = frame_start(y) {
            let win = &opened[y * ww + xs.start..y * ww + xs.end];
            for (m, &o) in mask.data[s..s + xs.len()].iter_mut().zip(win) {
                *m &= o;
            }
        }
    }
}

/// Sets the pixels of grid `cells` in `mask` (frame-sized), as [`cells_to_mask`] does.
fn paint_cells(
    mask: &mut Mask,
    g: &grid::Grid,
    depth: &DepthMap,
    cells: &[u32],
    drop_behind: Option<&DetectConfig>,
) {
    let (fw, fh) = (depth.width as usize, depth.height as usize);
    for &cell in cells {
        let (gu, gv) = (cell as usize % g.w, cell as usize / g.w);
        let z_cell = g.z[cell as usize];
        let far = drop_behind
            .filter(|_| z_cell > 0.0)
            .map(|cfg| z_cell + grid::jump_tol(cfg, z_cell));
        for v in gv * g.step..((gv + 1) * g.step).min(fh) {
            for u in gu * g.step..((gu + 1) * g.step).min(fw) {
                let z = depth.depth_mm[v * fw + u];
                if far.is_none_or(|far| !(z > 0.0 && z > far)) {
                    mask.data[v * fw + u] = true;
                }
            }
        }
    }
}

/// Diagnostic view of the candidate pool: every object-level (`'o'`), surface-level (`'s'`)
/// and colour-level (`'p'`) candidate before selection, as a mask of its own cells (no fill),
/// with its score and face count. For tuning the selection; [`detect_boxes`] validates the
/// same way.
pub fn candidate_pool(
    rgb: Option<&RgbImage>,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    cfg: &DetectConfig,
) -> Result<Vec<(char, Detection)>, DetectError> {
    validate(rgb, depth, intrinsics)?;
    let g = grid::Grid::build(rgb, depth, intrinsics, cfg);
    let p = pool(&g, rgb, cfg);
    let to_mask = |c: &boxes::Raw| Detection {
        mask: cells_to_mask(&g, depth, &c.cells, None),
        score: c.score,
        n_faces: c.n_faces,
        alternative: false,
    };
    let mut out = Vec::new();
    for (src, list) in [('o', &p.objects), ('s', &p.geo), ('p', &p.col)] {
        out.extend(list.iter().map(|c| (src, to_mask(c))));
    }
    Ok(out)
}

/// Whether cell `i` lies within `blob_support_gap_factor` plane tolerances of plane `pl`.
fn near_plane(g: &grid::Grid, pl: &regions::Region, i: usize, cfg: &DetectConfig) -> bool {
    pl.dist(&g.p[i]).abs() <= cfg.blob_support_gap_factor * regions::plane_tol(cfg, g.z[i] as f64)
}

/// Whether cell `i` (near a support plane) faces like one of `planes` (within 45°), or has no
/// normal: a piece of the support rather than the foot of a box's side.
fn flat_near_support(
    g: &grid::Grid,
    planes: &[regions::Region],
    i: usize,
    cfg: &DetectConfig,
) -> bool {
    let n = boxes::v3(&g.n[i]);
    n.norm_squared() < 0.5
        || planes.iter().any(|pl| {
            near_plane(g, pl, i, cfg) && pl.normal.dot(&n) >= std::f64::consts::FRAC_1_SQRT_2
        })
}

/// Connected objects (cells joined by depth continuity alone) once supports are removed:
/// labels per cell, the cells excluded (support cells, and every cell near a support plane:
/// cells at a box's foot have blurred normals and would join it to the table around it), and
/// the number of objects.
fn object_labels(
    g: &grid::Grid,
    joins: &regions::Joins,
    on_support: &[bool],
    planes: &[regions::Region],
    cfg: &DetectConfig,
) -> (Vec<u32>, Vec<bool>, usize) {
    let off: Vec<bool> = (0..g.z.len())
        .map(|i| {
            on_support[i] || (g.z[i] > 0.0 && planes.iter().any(|pl| near_plane(g, pl, i, cfg)))
        })
        .collect();
    let (labels, n_objects) = regions::label(g, joins, Cues::Depth, Some(&off), cfg);
    (labels, off, n_objects)
}

/// Diagnostic view of the detector's first stages: per-pixel labels (row-major, frame size,
/// `u32::MAX` = unlabelled or support) of the smooth surfaces, of the colour-uniform patches
/// and of the connected objects, after support-plane removal, plus per-pixel support and seam
/// flags. For overlays and tuning; [`detect_boxes`] validates the same way.
pub fn segment_labels(
    rgb: Option<&RgbImage>,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    cfg: &DetectConfig,
) -> Result<[Vec<u32>; 5], DetectError> {
    validate(rgb, depth, intrinsics)?;
    let g = grid::Grid::build(rgb, depth, intrinsics, cfg);
    let joins = regions::joins(&g, rgb.is_some(), &g.seam, cfg);
    let (geo_labels, surfaces) = regions::segment(&g, &joins, Cues::Geometry, None, cfg);
    let (on_support, planes, up) = boxes::support_mask(&g, &geo_labels, &surfaces, None, cfg);
    let up = side_face_up(up, cfg);
    let (geo_labels, _) = regions::label(&g, &joins, Cues::Geometry, Some(&on_support), cfg);
    let (obj_labels, _, _) = object_labels(&g, &joins, &on_support, &planes, cfg);
    let (mut col_labels, patches) = regions::segment(&g, &joins, Cues::All, Some(&on_support), cfg);
    let (_, faint) = cut_at_seams(&g, rgb, &mut col_labels, patches, up, cfg);
    let mut g = g;
    for &i in &faint {
        g.seam[i as usize] = true;
    }
    let sup: Vec<u32> = on_support.iter().map(|&b| b as u32).collect();
    let seam: Vec<u32> = g.seam.iter().map(|&b| b as u32).collect();
    let (fw, fh) = (depth.width as usize, depth.height as usize);
    let up = |cells: &[u32]| -> Vec<u32> {
        let mut out = vec![u32::MAX; fw * fh];
        for v in 0..fh {
            for u in 0..fw {
                out[v * fw + u] = cells[(v / g.step) * g.w + u / g.step];
            }
        }
        out
    };
    Ok([
        up(&geo_labels),
        up(&col_labels),
        up(&obj_labels),
        up(&sup),
        up(&seam),
    ])
}

fn validate(
    rgb: Option<&RgbImage>,
    depth: &DepthMap,
    intrinsics: &Intrinsics,
) -> Result<(), DetectError> {
    let (w, h) = (depth.width, depth.height);
    if w == 0 || h == 0 || depth.depth_mm.len() != w as usize * h as usize {
        return Err(DetectError::BadDepthBuffer {
            width: w,
            height: h,
            len: depth.depth_mm.len(),
        });
    }
    if let Some(img) = rgb {
        if img.width() != w || img.height() != h {
            return Err(DetectError::SizeMismatch {
                rgb_width: img.width(),
                rgb_height: img.height(),
                depth_width: w,
                depth_height: h,
            });
        }
    }
    let k = intrinsics;
    let focal_ok = k.fx.is_finite() && k.fy.is_finite() && k.fx > 0.0 && k.fy > 0.0;
    if !(focal_ok && k.cx.is_finite() && k.cy.is_finite()) {
        return Err(DetectError::BadIntrinsics {
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
        });
    }
    if depth.valid_count() == 0 {
        return Err(DetectError::NoValidDepth {
            width: w,
            height: h,
        });
    }
    Ok(())
}

/// Whether the seam cells `seam` on a face with normal `top` are a carton's own flap seam
/// rather than the joint of two flush cartons: the candidate's perpendicular (side) face is
/// seen where the seam line meets it, and no seam continues down it (two cartons' creased
/// edges would).
fn flap_seam(g: &grid::Grid, cells: &[u32], seam: &[usize], top: &nalgebra::Vector3<f64>) -> bool {
    use nalgebra::{Matrix3, Vector3};
    let v = |i: usize| Vector3::new(g.p[i][0] as f64, g.p[i][1] as f64, g.p[i][2] as f64);
    if seam.len() < 2 {
        return false;
    }
    let s0 = seam.iter().map(|&i| v(i)).sum::<Vector3<f64>>() / seam.len() as f64;
    let mut cov = Matrix3::zeros();
    for &i in seam {
        let d = v(i) - s0;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let Some(big) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
    else {
        return false;
    };
    let d = eig.eigenvectors.column(big.0).into_owned();
    let Some(m) = d.cross(top).try_normalize(1e-9) else {
        return false;
    };
    let (mut near, mut near_seam) = (0usize, 0usize);
    for &c in cells {
        let i = c as usize;
        let n = Vector3::new(g.n[i][0] as f64, g.n[i][1] as f64, g.n[i][2] as f64);
        if g.z[i] <= 0.0 || n.dot(top).abs() >= 0.5 {
            continue;
        }
        if (v(i) - s0).dot(&m).abs() < 20.0 {
            near += 1;
            near_seam += g.seam[i] as usize;
        }
    }
    near >= 6 && near_seam * 10 <= near
}

/// Mean colour (RGB levels) of a candidate's cells whose normal lies within 25° of `n`, and
/// how many there are: faces of one orientation share their shading, so colours compare.
fn facing_colour(
    g: &grid::Grid,
    c: &boxes::Raw,
    n: &nalgebra::Vector3<f64>,
) -> (nalgebra::Vector3<f64>, usize) {
    let cos = 25f64.to_radians().cos();
    let (mut sum, mut k) = (nalgebra::Vector3::zeros(), 0usize);
    for &i in &c.cells {
        let i = i as usize;
        if g.z[i] > 0.0 && boxes::v3(&g.n[i]).dot(n).abs() >= cos {
            sum += boxes::v3(&g.c[i]);
            k += 1;
        }
    }
    (sum / k.max(1) as f64, k)
}

/// Whether two coplanar colour-level candidates could be the halves of one carton cut by its
/// own flap seam: their faces along `a`'s normal differ in mean colour by less than
/// [`DetectConfig::split_flap_max_colour_delta`] (a carton is one colour on either side of its
/// seam). Too few such cells to compare (under 10 on either side) leaves the question open:
/// true.
fn same_colour(g: &grid::Grid, a: &boxes::Raw, b: &boxes::Raw, cfg: &DetectConfig) -> bool {
    let max = cfg.split_flap_max_colour_delta;
    if max <= 0.0 {
        return true;
    }
    let (ma, na) = facing_colour(g, a, &a.normal);
    let (mb, nb) = facing_colour(g, b, &a.normal);
    na < 10 || nb < 10 || (ma - mb).norm() < max
}

/// Which coarse candidates (objects or surfaces) are several cartons with flush faces: a seam
/// (thin dark line) runs between two of the colour-level candidates inside it (each
/// `split_min_fraction` of it) whose faces are coplanar, two of those face the same way off
/// one plane ([`stepped_faces`]), or one of those is a whole carton that the coarse cuboid
/// repeats ([`contains_carton`]). Returns, per coarse candidate, whether
/// it splits and the colour-level candidates inside it (≥ 80 % of their cells; one may lie
/// inside several overlapping coarse candidates), and the
/// colour-level candidates inside none. `planes`: one cache per colour-level candidate,
/// shared by the calls for objects and for surfaces.
fn split_evidence(
    g: &grid::Grid,
    coarse: &[boxes::Raw],
    col: &[boxes::Raw],
    planes: &[FacePlane],
    cfg: &DetectConfig,
) -> (Vec<bool>, Vec<Vec<usize>>, Vec<usize>) {
    // Coarse candidates overlap (an object scored whole beside its parts): every coarse
    // candidate holding a cell is listed for it (compressed rows: `start[i]..start[i + 1]`).
    let mut start = vec![0u32; g.z.len() + 1];
    for c in coarse {
        for &i in &c.cells {
            start[i as usize + 1] += 1;
        }
    }
    for i in 0..g.z.len() {
        start[i + 1] += start[i];
    }
    let mut owners = vec![0u32; start[g.z.len()] as usize];
    let mut fill = start.clone();
    for (k, c) in coarse.iter().enumerate() {
        for &i in &c.cells {
            owners[fill[i as usize] as usize] = k as u32;
            fill[i as usize] += 1;
        }
    }
    let mut inside: Vec<Vec<usize>> = vec![Vec::new(); coarse.len()];
    let mut free: Vec<usize> = Vec::new();
    for (k, c) in col.iter().enumerate() {
        let mut counts: std::collections::BTreeMap<u32, usize> = Default::default();
        for &i in &c.cells {
            let i = i as usize;
            for &o in &owners[start[i] as usize..start[i + 1] as usize] {
                *counts.entry(o).or_insert(0) += 1;
            }
        }
        let need = 0.8 * c.cells.len() as f64;
        let mut any = false;
        for (&o, &n) in &counts {
            if n as f64 >= need {
                inside[o as usize].push(k);
                any = true;
            }
        }
        if !any {
            free.push(k);
        }
    }
    let mut col_owner = vec![u32::MAX; g.z.len()];
    for (k, c) in col.iter().enumerate() {
        for &i in &c.cells {
            col_owner[i as usize] = k as u32;
        }
    }
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let reach = cfg.split_seam_reach_cells as isize;
    let (w, h) = (g.w as isize, g.h as isize);
    let mut split = vec![false; coarse.len()];
    for (k, gc) in coarse.iter().enumerate() {
        let big: Vec<usize> = inside[k]
            .iter()
            .copied()
            .filter(|&c| {
                col[c].cells.len() as f64 >= cfg.split_min_fraction * gc.cells.len() as f64
            })
            .collect();
        if big.len() < 2 {
            continue;
        }
        // Seam cells of this candidate next to two coplanar colour-level candidates: a seam
        // between flush faces of two cartons (a box's own faces are perpendicular, and tape or
        // print edges are colour steps, not thin dark lines).
        let mut between: std::collections::BTreeMap<(usize, usize), Vec<usize>> =
            Default::default();
        for &cell in &gc.cells {
            let i = cell as usize;
            if !g.seam[i] {
                continue;
            }
            let (u, v) = ((i % g.w) as isize, (i / g.w) as isize);
            let mut near: Vec<usize> = Vec::new();
            for dv in -reach..=reach {
                for du in -reach..=reach {
                    let (uu, vv) = (u + du, v + dv);
                    if uu < 0 || vv < 0 || uu >= w || vv >= h {
                        continue;
                    }
                    let o = col_owner[(vv * w + uu) as usize];
                    if o != u32::MAX && big.contains(&(o as usize)) && !near.contains(&(o as usize))
                    {
                        near.push(o as usize);
                    }
                }
            }
            for (x, &a) in near.iter().enumerate() {
                for &b in &near[x + 1..] {
                    if col[a].normal.dot(&col[b].normal) >= cos_par {
                        between.entry((a.min(b), a.max(b))).or_default().push(i);
                    }
                }
            }
        }
        let carton = contains_carton(gc, &big, col, cfg);
        if log::log_enabled!(log::Level::Debug) {
            for (&(a, b), seam) in &between {
                log::debug!(
                    "split? coarse {} cells {} pair {a}({}) {b}({}) seam {} flap {}",
                    k,
                    gc.cells.len(),
                    col[a].cells.len(),
                    col[b].cells.len(),
                    seam.len(),
                    flap_seam(g, &gc.cells, seam, &col[a].normal)
                );
            }
            log::debug!(
                "split? coarse {k} cells {} big {} carton {}",
                gc.cells.len(),
                big.len(),
                carton
            );
        }
        split[k] = between.iter().any(|(&(a, b), seam)| {
            seam.len() >= cfg.split_min_seam_cells as usize
                && !(cfg.split_flap_check
                    && flap_seam(g, &gc.cells, seam, &col[a].normal)
                    && same_colour(g, &col[a], &col[b], cfg))
        }) || carton
            || stepped_faces(g, &big, col, planes, cfg);
    }
    (split, inside, free)
}

/// A colour-level candidate's face as a plane: the grid points of its cells whose normals lie
/// within 25° of `n` (its largest face's), with outliers past three robust deviations of a
/// first fit dropped. Returns the points kept and their sum of squared plane residuals, mm²;
/// `None` under 30 points.
fn face_plane_points(
    g: &grid::Grid,
    c: &boxes::Raw,
    n: &nalgebra::Vector3<f64>,
) -> Option<(Vec<nalgebra::Vector3<f64>>, f64)> {
    let cos = 25f64.to_radians().cos();
    let pts: Vec<nalgebra::Vector3<f64>> = c
        .cells
        .iter()
        .map(|&i| i as usize)
        .filter(|&i| g.z[i] > 0.0 && boxes::v3(&g.n[i]).dot(n).abs() >= cos)
        .map(|i| boxes::v3(&g.p[i]))
        .collect();
    if pts.len() < 30 {
        return None;
    }
    let (nrm, c0, _) = plane_ssr(&pts)?;
    let res: Vec<f64> = pts.iter().map(|p| (p - c0).dot(&nrm).abs()).collect();
    let mad = crate::observation::median(res.clone());
    let keep = (3.0 * 1.4826 * mad).max(1.0);
    let kept: Vec<_> = pts
        .into_iter()
        .zip(res)
        .filter(|(_, r)| *r <= keep)
        .map(|(p, _)| p)
        .collect();
    if kept.len() < 30 {
        return None;
    }
    let (_, _, ssr) = plane_ssr(&kept)?;
    Some((kept, ssr))
}

/// A colour candidate's face as [`face_plane_points`] gives it, fitted once when first asked.
type FacePlane = std::sync::OnceLock<Option<(Vec<nalgebra::Vector3<f64>>, f64)>>;

/// Least-squares plane through `pts`: unit normal, centroid (mm) and sum of squared
/// residuals (mm²); `None` from fewer than 3 points.
fn plane_ssr(
    pts: &[nalgebra::Vector3<f64>],
) -> Option<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>, f64)> {
    if pts.len() < 3 {
        return None;
    }
    let c0 = pts.iter().sum::<nalgebra::Vector3<f64>>() / pts.len() as f64;
    let mut cov = nalgebra::Matrix3::zeros();
    for p in pts {
        let d = p - c0;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let (k, &ssr) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    Some((eig.eigenvectors.column(k).into_owned(), c0, ssr.max(0.0)))
}

/// Root-mean-square residual, mm, that one plane through the points `pa` and `pb` leaves
/// beyond what a plane through each leaves (`sa`, `sb`: their own sums of squared residuals,
/// mm²): zero for two patches of one plane.
fn plane_excess_mm(
    pa: &[nalgebra::Vector3<f64>],
    sa: f64,
    pb: &[nalgebra::Vector3<f64>],
    sb: f64,
) -> Option<f64> {
    let joint: Vec<_> = pa.iter().chain(pb.iter()).copied().collect();
    let (_, _, sj) = plane_ssr(&joint)?;
    Some(((sj - sa - sb) / joint.len() as f64).max(0.0).sqrt())
}

/// Whether two of the colour-level candidates `big` (inside one coarse candidate) face the
/// same way but are not one plane: fitted together, their faces leave a root-mean-square
/// residual beyond what each leaves alone of more than
/// [`DetectConfig::split_step_min_mm`]. A box's face is flat, so parallel patches of one
/// carton (tape, a label, the two halves of a flap seam) fit one plane as well as two; the
/// tops of two touching cartons of different heights, or of two stacked ones, do not.
/// `planes[c]` caches [`face_plane_points`] of `col[c]`: a colour candidate lies inside
/// several coarse candidates (an object, its parts, a surface).
fn stepped_faces(
    g: &grid::Grid,
    big: &[usize],
    col: &[boxes::Raw],
    planes: &[FacePlane],
    cfg: &DetectConfig,
) -> bool {
    let min = cfg.split_step_min_mm;
    if min <= 0.0 || big.len() < 2 {
        return false;
    }
    let cos_par = cfg.perpendicular_tol_deg.to_radians().cos();
    let plane = |c: usize| planes[c].get_or_init(|| face_plane_points(g, &col[c], &col[c].normal));
    for x in 0..big.len() {
        for y in x + 1..big.len() {
            let (a, b) = (&col[big[x]], &col[big[y]]);
            if a.normal.dot(&b.normal).abs() < cos_par {
                continue;
            }
            let (Some((pa, sa)), Some((pb, sb))) = (plane(big[x]), plane(big[y])) else {
                continue;
            };
            let Some(excess) = plane_excess_mm(pa, *sa, pb, *sb) else {
                continue;
            };
            log::debug!(
                "split? stepped {}({}) {}({}) excess {excess:.1} mm",
                big[x],
                a.cells.len(),
                big[y],
                b.cells.len()
            );
            if excess > min {
                return true;
            }
        }
    }
    false
}

/// Whether one of the colour-level candidates `inside` a coarse candidate is a whole carton
/// on its own (see [`DetectConfig::split_carton_min_faces`]).
fn contains_carton(
    coarse: &boxes::Raw,
    inside: &[usize],
    col: &[boxes::Raw],
    cfg: &DetectConfig,
) -> bool {
    let min_faces = cfg.split_carton_min_faces;
    min_faces > 0
        && inside.iter().any(|&c| {
            let p = &col[c];
            u32::from(p.n_faces) >= min_faces
                && p.score >= cfg.split_carton_min_score_ratio * coarse.score
                && p.cells.len() as f64 <= cfg.split_carton_max_fraction * coarse.cells.len() as f64
                && crate::repeat::is_copies_of(&coarse.bx, &p.bx, cfg)
        })
}

/// Chooses among the object-level, surface-level and colour-level candidates, then suppresses
/// overlaps. An object or surface candidate stands unless [`split_evidence`] shows it is
/// several cartons with flush faces; a split surface is replaced by its colour-level
/// candidates, a split object is dropped (its surfaces and patches remain). What is left
/// competes by score.
fn select(
    g: &grid::Grid,
    objects: Vec<boxes::Raw>,
    geo: Vec<boxes::Raw>,
    col: Vec<boxes::Raw>,
    cfg: &DetectConfig,
) -> (Vec<boxes::Raw>, Vec<boxes::Raw>) {
    // The parts of cuts not made (lost profile cuts, step readings not taken) are
    // alternatives only.
    let (cut_parts, objects): (Vec<_>, Vec<_>) = objects.into_iter().partition(|c| c.lost_cut);
    let planes: Vec<FacePlane> = col.iter().map(|_| FacePlane::new()).collect();
    // The two are independent (the colour patches' planes, fitted once, are shared).
    let ((obj_split, _, _), (geo_split, inside, free)) = rayon::join(
        || split_evidence(g, &objects, &col, &planes, cfg),
        || split_evidence(g, &geo, &col, &planes, cfg),
    );
    let mut take_col = vec![false; col.len()];
    for (k, &s) in geo_split.iter().enumerate() {
        if s {
            for &c in &inside[k] {
                take_col[c] = true;
            }
        }
    }
    for k in free {
        take_col[k] = true;
    }
    let mut all: Vec<(boxes::Raw, char)> = Vec::new();
    // The other side of each split decision (a coarse candidate split into cartons, or the
    // colour patches of one left whole), kept for alternative readings.
    let mut lost: Vec<boxes::Raw> = cut_parts;
    for (k, c) in objects.into_iter().enumerate() {
        if !obj_split[k] {
            all.push((c, 'o'));
        } else {
            lost.push(c);
        }
    }
    for (k, c) in geo.into_iter().enumerate() {
        if !geo_split[k] {
            all.push((c, 's'));
        } else {
            lost.push(c);
        }
    }
    for (k, c) in col.into_iter().enumerate() {
        if take_col[k] {
            all.push((c, 'p'));
        } else {
            lost.push(c);
        }
    }
    all.sort_by(|a, b| b.0.score.total_cmp(&a.0.score));
    let dbg = log::log_enabled!(log::Level::Debug);
    let mut taken = vec![false; g.z.len()];
    let mut out = Vec::new();
    for (c, src) in all {
        let skip = !claim(&c, &mut taken, cfg);
        if dbg {
            let (mut u0, mut v0, mut u1, mut v1) = (usize::MAX, usize::MAX, 0, 0);
            for &i in &c.cells {
                let (u, v) = (i as usize % g.w * g.step, i as usize / g.w * g.step);
                (u0, v0, u1, v1) = (u0.min(u), v0.min(v), u1.max(u), v1.max(v));
            }
            log::debug!(
                "select{} {src} score {:.3} faces {} cells {} bbox ({u0}, {v0}, {u1}, {v1}) size {:.0} {:.0} {:.0}",
                if skip { " SKIP" } else { "" },
                c.score,
                c.n_faces,
                c.cells.len(),
                c.bx.size_mm.x,
                c.bx.size_mm.y,
                c.bx.size_mm.z
            );
        }
        if !skip {
            out.push(c);
        }
    }
    let alts = alternatives(g, &out, lost, cfg);
    (out, alts)
}

/// Greedy overlap suppression, one candidate at a time (best first): takes `c`'s cells into
/// `taken` and returns true, unless more than `max_overlap` of them are taken already.
fn claim(c: &boxes::Raw, taken: &mut [bool], cfg: &DetectConfig) -> bool {
    let overlap = c.cells.iter().filter(|&&i| taken[i as usize]).count();
    if overlap as f64 > cfg.max_overlap * c.cells.len() as f64 {
        return false;
    }
    for &i in &c.cells {
        taken[i as usize] = true;
    }
    true
}

/// The alternative readings among the candidates that lost a split decision (see
/// [`DetectConfig::alternatives_max`]): best first, with `alternative_min_faces`, each
/// differing from every chosen candidate and every earlier alternative by grid-cell IoU below
/// `alternative_max_iou`.
fn alternatives(
    g: &grid::Grid,
    chosen: &[boxes::Raw],
    mut lost: Vec<boxes::Raw>,
    cfg: &DetectConfig,
) -> Vec<boxes::Raw> {
    let max = cfg.alternatives_max as usize;
    if max == 0 || lost.is_empty() {
        return Vec::new();
    }
    lost.sort_by(|a, b| b.score.total_cmp(&a.score));
    // Cells of each kept candidate, as (owner index) lists per cell: chosen candidates may
    // overlap a little, alternatives a lot.
    let mut owners: Vec<Vec<u32>> = vec![Vec::new(); g.z.len()];
    let mut sizes: Vec<usize> = Vec::new();
    for c in chosen {
        for &i in &c.cells {
            owners[i as usize].push(sizes.len() as u32);
        }
        sizes.push(c.cells.len());
    }
    let mut out = Vec::new();
    // Parts of cuts not made come on top of `alternatives_max`.
    let mut counted = 0;
    for c in lost {
        if !c.lost_cut && counted >= max {
            continue;
        }
        if c.score < cfg.min_score || c.n_faces < cfg.alternative_min_faces {
            continue;
        }
        let mut inter: std::collections::HashMap<u32, usize> = Default::default();
        for &i in &c.cells {
            for &o in &owners[i as usize] {
                *inter.entry(o).or_insert(0) += 1;
            }
        }
        let n = c.cells.len();
        let similar = inter.iter().any(|(&o, &x)| {
            x as f64 >= cfg.alternative_max_iou * (n + sizes[o as usize] - x) as f64
        });
        if similar {
            continue;
        }
        for &i in &c.cells {
            owners[i as usize].push(sizes.len() as u32);
        }
        sizes.push(n);
        counted += usize::from(!c.lost_cut);
        out.push(c);
    }
    out
}

#[cfg(test)]
pub(crate) mod tests;
