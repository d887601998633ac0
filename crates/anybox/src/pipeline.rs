//! One mask (or one frame of masks) in, posed boxes out (SPEC §1, paper §3 end to end).
//!
//! [`estimate_box`]: observation ([`crate::observation::observe`]) → scale search with the pose
//! estimator in the loop ([`crate::scale::scale_search`], which makes the first pose estimate
//! from the template) → hidden dimensions from context ([`crate::context`]) with one last pose
//! estimate when they changed the size → canonical axes (`anybox_geom::symmetry::canonicalize`)
//! with the observed-axis flags carried along.
//!
//! [`estimate_frame`]: [`estimate_box`]'s stages for every mask in parallel (rayon), then the
//! cross-instance context pass (boxes in one layer share their height,
//! [`crate::context::share_layer_heights`]), then canonical axes.

use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::{DepthMap, Mask};
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::config::Config;
use crate::context::{
    infer_hidden, observed_axes, share_layer_heights, ContextInputs, HiddenSource, LayerMember,
};
use crate::error::EstimateError;
use crate::observation::{observe, Observation};
use crate::pose::estimate_pose;
use crate::scale::{scale_search, PoseSample, ScaleInputs, ScaleMode};
use crate::silhouette::mask_pixels;

/// One estimated box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxEstimate {
    /// The box in the camera frame, mm, with canonical axes (SPEC §2).
    pub pose: OrientedBox,
    /// Confidence, 0..1 (the pose estimator's score of the final estimate).
    pub score: f64,
    /// Per (canonical) axis: was its extent observed (true) or inferred from context (false).
    pub observed_axes: [bool; 3],
    /// Scale-loop iterations.
    pub iterations: u32,
    /// Algorithm 2 (early stopping) fired.
    pub stopped_early: bool,
    /// Calls to PoseEstimate(C(s)).
    pub pose_calls: u32,
    /// Depth-consistency penalty of the final pose (paper §3).
    pub depth_penalty: f64,
}

/// Before canonicalisation: what the cross-instance pass needs.
struct Stage {
    obs: Observation,
    pose: OrientedBox,
    score: f64,
    depth_penalty: f64,
    observed: [bool; 3],
    sources: [HiddenSource; 3],
    iterations: u32,
    stopped_early: bool,
    pose_calls: u32,
}

fn sample_of(
    obs: &Observation,
    depth: &DepthMap,
    k: &Intrinsics,
    size: &Vector3<f64>,
    prior: Option<&OrientedBox>,
    cfg: &Config,
) -> Result<PoseSample, EstimateError> {
    let e = estimate_pose(obs, depth, k, size, prior, &cfg.pose)?;
    let mut pose = e.pose;
    // The scale loop owns the size: keep exactly the size it asked for.
    pose.size_mm = *size;
    Ok(PoseSample {
        pose,
        score: e.score,
        depth_penalty: e.depth_penalty,
    })
}

fn stage_one(
    depth: &DepthMap,
    k: &Intrinsics,
    mask: &Mask,
    cfg: &Config,
) -> Result<Stage, EstimateError> {
    let obs = observe(depth, k, mask, &cfg.observation)?;
    let pixels = mask_pixels(mask);
    let inputs = ScaleInputs {
        intrinsics: k,
        depth,
        mask_pixels: &pixels,
        points_mm: &obs.points_mm,
        normals: &obs.normals,
    };
    let ctx_in = ContextInputs {
        depth,
        intrinsics: k,
        mask,
        points_mm: &obs.points_mm,
    };
    let mut est =
        |s: &Vector3<f64>, prior: Option<&OrientedBox>| sample_of(&obs, depth, k, s, prior, cfg);
    let mut fill =
        |p: &OrientedBox, observed: [bool; 3]| infer_hidden(p, observed, &ctx_in, &cfg.context).0;
    let hidden: Option<&mut crate::scale::HiddenFill<'_>> = if cfg.context.enabled {
        Some(&mut fill)
    } else {
        None
    };
    let out = scale_search(&mut est, &inputs, &cfg.scale, &cfg.context, hidden)?;
    let mut pose = out.pose;
    let mut score = out.score;
    let mut depth_penalty = out.depth_penalty;
    let mut pose_calls = out.pose_calls;
    let observed = observed_axes(&pose, &obs.points_mm, &obs.normals, &cfg.context);
    let mut sources = observed.map(|o| {
        if o {
            HiddenSource::Observed
        } else {
            HiddenSource::Fallback
        }
    });
    let size_is_free = !matches!(cfg.scale.mode, ScaleMode::Canonical | ScaleMode::Oracle(_));
    if cfg.context.enabled && size_is_free && observed.iter().any(|o| !o) {
        let (size, src) = infer_hidden(&pose, observed, &ctx_in, &cfg.context);
        sources = src;
        if (size - pose.size_mm).abs().max() > 0.5 {
            let s = sample_of(&obs, depth, k, &size, Some(&pose), cfg)?;
            pose_calls += 1;
            pose = s.pose;
            score = s.score;
            depth_penalty = s.depth_penalty;
        }
    }
    Ok(Stage {
        obs,
        pose,
        score,
        depth_penalty,
        observed,
        sources,
        iterations: out.iterations,
        stopped_early: out.stopped_early,
        pose_calls,
    })
}

/// Canonical axes (SPEC §2) with the per-axis flags following the axes.
fn finish(st: &Stage) -> BoxEstimate {
    let canon = canonicalize(&st.pose);
    let mut flags = [true; 3];
    for (i, f) in flags.iter_mut().enumerate() {
        let ci = canon.axis(i);
        let mut best = 0;
        for j in 1..3 {
            if st.pose.axis(j).dot(&ci).abs() > st.pose.axis(best).dot(&ci).abs() {
                best = j;
            }
        }
        *f = st.observed[best];
    }
    BoxEstimate {
        pose: canon,
        score: st.score,
        observed_axes: flags,
        iterations: st.iterations,
        stopped_early: st.stopped_early,
        pose_calls: st.pose_calls,
        depth_penalty: st.depth_penalty,
    }
}

/// Canonical axes: `anybox_geom::symmetry::canonicalize` once it lands; identity until then.
fn canonicalize(b: &OrientedBox) -> OrientedBox {
    *b
}

/// Estimates one box from its instance mask (see the module docs).
///
/// Errors: those of [`observe`] (empty mask, too few points, size mismatch) and of the pose
/// estimator.
pub fn estimate_box(
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    mask: &Mask,
    cfg: &Config,
) -> Result<BoxEstimate, EstimateError> {
    stage_one(depth, intrinsics, mask, cfg).map(|s| finish(&s))
}

/// Estimates every masked box of a frame: per-instance stages in parallel, then neighbours in
/// the same layer share hidden extents that had no support of their own.
pub fn estimate_frame(
    depth: &DepthMap,
    intrinsics: &Intrinsics,
    masks: &[Mask],
    cfg: &Config,
) -> Vec<Result<BoxEstimate, EstimateError>> {
    let mut stages: Vec<Result<Stage, EstimateError>> = masks
        .par_iter()
        .map(|m| stage_one(depth, intrinsics, m, cfg))
        .collect();
    let size_is_free = !matches!(cfg.scale.mode, ScaleMode::Canonical | ScaleMode::Oracle(_));
    if cfg.context.enabled && size_is_free {
        let idx: Vec<usize> = (0..stages.len()).filter(|&i| stages[i].is_ok()).collect();
        let members: Vec<LayerMember> = idx
            .iter()
            .filter_map(|&i| stages[i].as_ref().ok())
            .map(|s| LayerMember {
                pose: s.pose,
                sources: s.sources,
            })
            .collect();
        let updates = share_layer_heights(&members, &cfg.context);
        let work: Vec<(usize, Vector3<f64>)> = idx
            .iter()
            .zip(updates)
            .filter_map(|(&i, u)| u.map(|s| (i, s)))
            .collect();
        let redone: Vec<(usize, Result<PoseSample, EstimateError>)> = work
            .par_iter()
            .filter_map(|(i, size)| {
                let st = stages[*i].as_ref().ok()?;
                Some((
                    *i,
                    sample_of(&st.obs, depth, intrinsics, size, Some(&st.pose), cfg),
                ))
            })
            .collect();
        for (i, r) in redone {
            if let (Ok(s), Some(Ok(st))) = (r, stages.get_mut(i)) {
                st.pose = s.pose;
                st.score = s.score;
                st.depth_penalty = s.depth_penalty;
                st.pose_calls += 1;
                for a in 0..3 {
                    if st.sources[a] == HiddenSource::Fallback {
                        st.sources[a] = HiddenSource::Neighbour;
                    }
                }
            }
        }
    }
    stages.into_iter().map(|r| r.map(|s| finish(&s))).collect()
}
