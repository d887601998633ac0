//! Geometric pose hypotheses (SPEC §1 "pose hypotheses"; replaces the paper's learned
//! point-matching proposals of §3.2 "Hypothesis Generation").
//!
//! In: an [`Observation`] and the template size. Out: a few dozen candidate [`OrientedBox`]es.
//!
//! Rotations come from *frames* (orthonormal, right-handed bases) read off the geometry:
//! - dominant face planes: normals are clustered on the sphere, each cluster's plane refit by
//!   RANSAC (fixed-seed ChaCha) + PCA over its points; pairs of near-perpendicular planes are
//!   orthogonalised into a frame;
//! - the minimum-area rectangle (rotating calipers over the 2D convex hull) of each main face's
//!   points projected on its plane, which gives the in-plane axes when only one face is seen;
//! - PCA of all points.
//!
//! Each frame yields 6 box rotations: the 6 assignments of the template's axes to the frame's
//! axes (the template is not a cube, so this matters). The remaining sign flips of the 24 signed
//! permutations are the box's own 180° symmetries and give the *same* box, so they are not
//! generated. Near-identical frames (modulo the 24 axis relabelings) are de-duplicated first.
//!
//! Translation puts the box *behind* its visible faces: for box axis `a` with camera-facing sign
//! `σ = −sign(a · viewdir)`, the centre coordinate along `a` is the robust extreme (percentile) of
//! the points on the camera-facing side minus `σ · size/2`; along an axis seen edge-on
//! (`|a · viewdir|` small) it is the midpoint of the points' robust extent.

use anybox_geom::OrientedBox;
use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::observation::{smallest_eigenvector, sym3_eigenvalues, sym3_eigenvector, Observation};
use crate::order_stats::rank_pair;

/// Parameters of hypothesis generation.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HypothesisConfig {
    /// Normals within this angle belong to the same face cluster, degrees. Default 15.
    pub cluster_angle_deg: f64,
    /// At most this many face clusters. Default 3 (a box shows at most 3 faces).
    pub max_clusters: usize,
    /// A cluster needs at least this fraction of the (subsampled) points. Default 0.04.
    pub min_cluster_fraction: f64,
    /// Two planes within this angle of perpendicular form a frame, degrees. Default 20.
    pub perpendicular_tol_deg: f64,
    /// RANSAC iterations per face plane. Default 40; 0 = PCA of the cluster only.
    pub ransac_iterations: usize,
    /// RANSAC inlier distance, mm (at least 1 % of the depth is used). Default 4 mm.
    pub ransac_inlier_mm: f64,
    /// Add the PCA frame of all points. Default true.
    pub use_pca: bool,
    /// Add the minimum-area-rectangle frame of each main face. Default true.
    pub use_min_area_rect: bool,
    /// Frames closer than this (modulo axis relabeling) are merged, degrees. Default 4.
    pub dedup_angle_deg: f64,
    /// Robust extreme for the translation rule: this fraction of points is ignored on each side.
    /// Default 0.02.
    pub extent_trim: f64,
    /// An axis with `|axis · viewdir|` below this is treated as seen edge-on (centre on the
    /// points' extent midpoint). Default 0.1 (≈ 84° from the view ray).
    pub edge_on_cos: f64,
    /// With a prior pose, each frame contributes only its axis assignment closest to the
    /// prior's (instead of all 6): cheaper, and the scale loop's axes stay put. Default true.
    pub prior_restricts: bool,
    /// RANSAC seed.
    pub seed: u64,
}

impl Default for HypothesisConfig {
    fn default() -> Self {
        Self {
            cluster_angle_deg: 15.0,
            max_clusters: 3,
            min_cluster_fraction: 0.04,
            perpendicular_tol_deg: 20.0,
            ransac_iterations: 40,
            ransac_inlier_mm: 4.0,
            use_pca: true,
            use_min_area_rect: true,
            dedup_angle_deg: 4.0,
            extent_trim: 0.02,
            edge_on_cos: 0.1,
            prior_restricts: true,
            seed: 0xb0c5,
        }
    }
}

/// A face plane found in the observation.
#[derive(Debug, Clone, PartialEq)]
pub struct FacePlane {
    /// Unit normal, toward the camera.
    pub normal: Vector3<f64>,
    /// Plane offset: points satisfy `normal · p = offset_mm`.
    pub offset_mm: f64,
    /// Indices into `Observation::points_mm` of the plane's inliers (within the subsample).
    pub inliers: Vec<usize>,
    /// Robust residual scale (1.4826 · median |distance|) of the normal cluster's members to the
    /// refit plane, mm: an estimate of the depth noise.
    pub noise_mm: f64,
}

/// Dominant face planes: normal clusters refined by RANSAC + PCA, largest first.
pub fn face_planes(obs: &Observation, cfg: &HypothesisConfig) -> Vec<FacePlane> {
    let sub = &obs.subsample;
    if sub.len() < 3 {
        return Vec::new();
    }
    let cos_t = cfg.cluster_angle_deg.to_radians().cos();
    // Cluster seeds from at most 256 normals: O(m²) neighbour counts.
    let step = sub.len().div_ceil(256).max(1);
    let cand: Vec<usize> = sub.iter().step_by(step).copied().collect();
    let mut counts: Vec<(usize, usize)> = cand
        .iter()
        .map(|&i| {
            let n = obs.normals[i];
            let c = cand
                .iter()
                .filter(|&&j| obs.normals[j].dot(&n) > cos_t)
                .count();
            (c, i)
        })
        .collect();
    counts.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    let min_support = ((cfg.min_cluster_fraction * cand.len() as f64).ceil() as usize).max(3);
    let mut centres: Vec<Vector3<f64>> = Vec::new();
    for &(c, i) in &counts {
        if centres.len() >= cfg.max_clusters || c < min_support {
            break;
        }
        let n = obs.normals[i];
        if centres.iter().any(|m| m.dot(&n) > cos_t) {
            continue;
        }
        // Mean of the member normals over the whole subsample.
        let mut s = Vector3::zeros();
        for &j in sub {
            if obs.normals[j].dot(&n) > cos_t {
                s += obs.normals[j];
            }
        }
        let m = s.try_normalize(1e-12).unwrap_or(n);
        if centres.iter().all(|c| c.dot(&m) <= cos_t) {
            centres.push(m);
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut planes = Vec::new();
    for m in centres {
        let members: Vec<usize> = sub
            .iter()
            .copied()
            .filter(|&j| obs.normals[j].dot(&m) > cos_t)
            .collect();
        if members.len() < 3 {
            continue;
        }
        if let Some(p) = fit_plane(obs, &members, m, cfg, &mut rng) {
            planes.push(p);
        }
    }
    planes.sort_by_key(|p| std::cmp::Reverse(p.inliers.len()));
    planes
}

/// RANSAC over a normal cluster's members (the hypothesised normal must stay within the cluster
/// angle of the cluster mean), then a PCA refit on the inliers.
fn fit_plane(
    obs: &Observation,
    members: &[usize],
    mean_normal: Vector3<f64>,
    cfg: &HypothesisConfig,
    rng: &mut ChaCha8Rng,
) -> Option<FacePlane> {
    let pts = &obs.points_mm;
    let zref = obs.centroid_mm.z.abs();
    let tol = cfg.ransac_inlier_mm.max(0.01 * zref);
    let cos_t = cfg.cluster_angle_deg.to_radians().cos();
    let count_inliers = |n: &Vector3<f64>, d: f64| {
        members
            .iter()
            .filter(|&&j| (n.dot(&pts[j].coords) - d).abs() <= tol)
            .count()
    };
    // Start from the cluster mean normal through the members' median offset.
    let offs: Vec<f64> = members
        .iter()
        .map(|&j| mean_normal.dot(&pts[j].coords))
        .collect();
    let mut best_n = mean_normal;
    let mut best_d = crate::observation::median(offs);
    let mut best_c = count_inliers(&best_n, best_d);
    for _ in 0..cfg.ransac_iterations {
        let a = members[rng.random_range(0..members.len())];
        let b = members[rng.random_range(0..members.len())];
        let c = members[rng.random_range(0..members.len())];
        let n = (pts[b] - pts[a]).cross(&(pts[c] - pts[a]));
        let Some(mut n) = n.try_normalize(1e-9) else {
            continue;
        };
        if n.dot(&mean_normal) < 0.0 {
            n = -n;
        }
        if n.dot(&mean_normal) < cos_t {
            continue;
        }
        let d = n.dot(&pts[a].coords);
        let cnt = count_inliers(&n, d);
        if cnt > best_c {
            best_c = cnt;
            best_n = n;
            best_d = d;
        }
    }
    let inliers: Vec<usize> = members
        .iter()
        .copied()
        .filter(|&j| (best_n.dot(&pts[j].coords) - best_d).abs() <= tol)
        .collect();
    if inliers.len() < 3 {
        return None;
    }
    let mean = inliers
        .iter()
        .fold(Vector3::zeros(), |s, &j| s + pts[j].coords)
        / inliers.len() as f64;
    let mut cov = Matrix3::zeros();
    for &j in &inliers {
        let q = pts[j].coords - mean;
        cov += q * q.transpose();
    }
    let mut n = smallest_eigenvector(&cov).unwrap_or(best_n);
    if n.dot(&mean_normal) < 0.0 {
        n = -n;
    }
    let offset_mm = n.dot(&mean);
    let noise_mm = 1.4826
        * crate::observation::median(
            members
                .iter()
                .map(|&j| (n.dot(&pts[j].coords) - offset_mm).abs())
                .collect(),
        );
    Some(FacePlane {
        normal: n,
        offset_mm,
        inliers,
        noise_mm,
    })
}

/// Makes a right-handed orthonormal frame from two directions (`x` kept exactly).
fn frame_from(x: &Vector3<f64>, y_hint: &Vector3<f64>) -> Option<Matrix3<f64>> {
    let x = x.try_normalize(1e-12)?;
    let y = (y_hint - x * x.dot(y_hint)).try_normalize(1e-9)?;
    let z = x.cross(&y);
    Some(Matrix3::from_columns(&[x, y, z]))
}

/// 2D convex hull (Andrew's monotone chain), counter-clockwise, no collinear points.
pub fn convex_hull_2d(pts: &[Vector2<f64>]) -> Vec<Vector2<f64>> {
    let mut p: Vec<Vector2<f64>> = pts
        .iter()
        .copied()
        .filter(|q| q.x.is_finite() && q.y.is_finite())
        .collect();
    p.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    // Relative tolerance: drops points that are collinear up to rounding.
    let cross = |o: &Vector2<f64>, a: &Vector2<f64>, b: &Vector2<f64>| {
        let (u, w) = (a - o, b - o);
        let c = u.x * w.y - u.y * w.x;
        if c.abs() <= 1e-9 * u.norm() * w.norm() {
            0.0
        } else {
            c
        }
    };
    let mut hull: Vec<Vector2<f64>> = Vec::with_capacity(2 * p.len());
    for q in &p {
        while hull.len() >= 2 && cross(&hull[hull.len() - 2], &hull[hull.len() - 1], q) <= 0.0 {
            hull.pop();
        }
        hull.push(*q);
    }
    let lower = hull.len() + 1;
    for q in p.iter().rev().skip(1) {
        while hull.len() >= lower && cross(&hull[hull.len() - 2], &hull[hull.len() - 1], q) <= 0.0 {
            hull.pop();
        }
        hull.push(*q);
    }
    hull.pop();
    hull
}

/// Direction (unit, 2D) of one side of the minimum-area enclosing rectangle (rotating calipers:
/// the optimal rectangle has a side collinear with a hull edge). `None` for < 3 hull points.
pub fn min_area_rect_dir(pts: &[Vector2<f64>]) -> Option<Vector2<f64>> {
    let hull = convex_hull_2d(pts);
    if hull.len() < 3 {
        return None;
    }
    let mut best: Option<(f64, Vector2<f64>)> = None;
    for i in 0..hull.len() {
        let e = hull[(i + 1) % hull.len()] - hull[i];
        let Some(d) = e.try_normalize(1e-12) else {
            continue;
        };
        let nrm = Vector2::new(-d.y, d.x);
        let (mut a0, mut a1, mut b0, mut b1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for q in &hull {
            let (a, b) = (q.dot(&d), q.dot(&nrm));
            a0 = a0.min(a);
            a1 = a1.max(a);
            b0 = b0.min(b);
            b1 = b1.max(b);
        }
        let area = (a1 - a0) * (b1 - b0);
        if best.is_none_or(|(ba, _)| area < ba) {
            best = Some((area, d));
        }
    }
    best.map(|(_, d)| d)
}

/// Size-independent analysis of an observation: candidate frames and a depth-noise estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSet {
    /// Candidate frames (see [`candidate_frames`]).
    pub frames: Vec<Matrix3<f64>>,
    /// Depth noise estimated from the largest face plane's residuals, mm (0 if no plane).
    pub noise_mm: f64,
}

/// Frames and noise estimate (see [`candidate_frames`] and [`FacePlane::noise_mm`]).
pub fn analyse(obs: &Observation, cfg: &HypothesisConfig) -> FrameSet {
    let planes = face_planes(obs, cfg);
    let noise_mm = planes.first().map_or(0.0, |p| p.noise_mm);
    FrameSet {
        frames: frames_from_planes(obs, &planes, cfg),
        noise_mm,
    }
}

/// [`analyse`] of `obs` under `cfg`, from the observation's cache: filled on the first call,
/// reused by the later ones (the scale loop's pose estimates); computed afresh, uncached, for a
/// `cfg` other than the one the cache was filled with.
pub(crate) fn cached_analysis<'a>(
    obs: &'a Observation,
    cfg: &HypothesisConfig,
) -> std::borrow::Cow<'a, FrameSet> {
    let cached = obs
        .cache
        .frames
        .get_or_init(|| (cfg.clone(), analyse(obs, cfg)));
    if cached.0 == *cfg {
        std::borrow::Cow::Borrowed(&cached.1)
    } else {
        std::borrow::Cow::Owned(analyse(obs, cfg))
    }
}

/// Candidate frames (columns = orthonormal right-handed axes, camera frame) from the geometry,
/// de-duplicated modulo axis relabeling.
pub fn candidate_frames(obs: &Observation, cfg: &HypothesisConfig) -> Vec<Matrix3<f64>> {
    let planes = face_planes(obs, cfg);
    frames_from_planes(obs, &planes, cfg)
}

fn frames_from_planes(
    obs: &Observation,
    planes: &[FacePlane],
    cfg: &HypothesisConfig,
) -> Vec<Matrix3<f64>> {
    let mut frames: Vec<Matrix3<f64>> = Vec::new();
    let sin_tol = cfg.perpendicular_tol_deg.to_radians().sin();
    for i in 0..planes.len() {
        for j in (i + 1)..planes.len() {
            if planes[i].normal.dot(&planes[j].normal).abs() < sin_tol {
                if let Some(f) = frame_from(&planes[i].normal, &planes[j].normal) {
                    frames.push(f);
                }
            }
        }
    }
    if cfg.use_min_area_rect {
        for p in planes.iter().take(2) {
            let n = p.normal;
            let Some(f0) = frame_from(&n, &any_perpendicular(&n)) else {
                continue;
            };
            let (e1, e2) = (f0.column(1).into_owned(), f0.column(2).into_owned());
            let pts2: Vec<Vector2<f64>> = p
                .inliers
                .iter()
                .map(|&j| {
                    let q = obs.points_mm[j].coords;
                    Vector2::new(q.dot(&e1), q.dot(&e2))
                })
                .collect();
            if let Some(d) = min_area_rect_dir(&pts2) {
                if let Some(f) = frame_from(&n, &(e1 * d.x + e2 * d.y)) {
                    frames.push(f);
                }
            }
        }
    }
    if cfg.use_pca || frames.is_empty() {
        if let Some(f) = pca_frame(obs) {
            frames.push(f);
        }
    }
    dedup_frames(frames, cfg.dedup_angle_deg)
}

/// A vector perpendicular to `n` (not unit): the cross product with whichever of x and y lies
/// farther from it.
pub(crate) fn any_perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    if n.x.abs() < 0.9 {
        Vector3::x().cross(n)
    } else {
        Vector3::y().cross(n)
    }
}

/// PCA axes of the subsampled points (right-handed).
pub fn pca_frame(obs: &Observation) -> Option<Matrix3<f64>> {
    let sub = &obs.subsample;
    if sub.len() < 3 {
        return None;
    }
    let mean = sub
        .iter()
        .fold(Vector3::zeros(), |s, &j| s + obs.points_mm[j].coords)
        / sub.len() as f64;
    let mut cov = Matrix3::zeros();
    for &j in sub {
        let q = obs.points_mm[j].coords - mean;
        cov += q * q.transpose();
    }
    let e = sym3_eigenvalues(&cov);
    let a = sym3_eigenvector(&cov, e[0])?;
    let b = sym3_eigenvector(&cov, e[1]).unwrap_or_else(|| any_perpendicular(&a));
    frame_from(&a, &b)
}

/// Angle (degrees) between two frames modulo the 24 signed axis permutations.
pub fn frame_distance_deg(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let m = a.transpose() * b;
    // Nearest signed permutation: the largest entry of each row.
    let mut p = Matrix3::zeros();
    let mut used = [false; 3];
    for r in 0..3 {
        let mut best = 0;
        for c in 1..3 {
            if m[(r, c)].abs() > m[(r, best)].abs() {
                best = c;
            }
        }
        if used[best] {
            return 180.0;
        }
        used[best] = true;
        p[(r, best)] = m[(r, best)].signum();
    }
    // m · pᵀ is the residual rotation (p orthogonal; its det may be −1 only if m is far off).
    let c = (((m * p.transpose()).trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    c.acos().to_degrees()
}

fn dedup_frames(frames: Vec<Matrix3<f64>>, tol_deg: f64) -> Vec<Matrix3<f64>> {
    let mut out: Vec<Matrix3<f64>> = Vec::new();
    for f in frames {
        if out.iter().all(|g| frame_distance_deg(g, &f) > tol_deg) {
            out.push(f);
        }
    }
    out
}

/// The 6 box rotations of a frame: template axis `k` ↦ frame column `perm[k]`, the last column
/// sign-fixed for det +1.
pub fn frame_rotations(frame: &Matrix3<f64>) -> [Rotation3<f64>; 6] {
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [1, 2, 0],
        [2, 0, 1],
        [0, 2, 1],
        [2, 1, 0],
        [1, 0, 2],
    ];
    PERMS.map(|p| {
        let x = frame.column(p[0]).into_owned();
        let y = frame.column(p[1]).into_owned();
        let z = x.cross(&y);
        Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]))
    })
}

/// Robust `(lo, hi)` extent of the subsampled points along a unit axis, mm.
pub fn robust_extent(
    obs: &Observation,
    axis: &Vector3<f64>,
    trim: f64,
    scratch: &mut Vec<f64>,
) -> (f64, f64) {
    scratch.clear();
    scratch.extend(
        obs.subsample
            .iter()
            .map(|&j| obs.points_mm[j].coords.dot(axis)),
    );
    let n = scratch.len();
    if n == 0 {
        return (0.0, 0.0);
    }
    let k = ((trim.clamp(0.0, 0.49) * n as f64).floor() as usize).min(n - 1);
    rank_pair(scratch, k, n - 1 - k).unwrap_or((0.0, 0.0))
}

/// Extents of the observation's points along the columns of `frame`, mm: the robust extent
/// ([`robust_extent`], `trim` of the points ignored at each end) per axis.
pub fn frame_extents_mm(obs: &Observation, frame: &Matrix3<f64>, trim: f64) -> Vector3<f64> {
    let mut scratch = Vec::with_capacity(obs.subsample.len());
    Vector3::from_fn(|k, _| {
        let (lo, hi) = robust_extent(obs, &frame.column(k).into_owned(), trim, &mut scratch);
        hi - lo
    })
}

/// Centre of a box of `size_mm` with rotation `rot` placed behind its visible faces (module docs).
/// `extents[k]` is the robust `(lo, hi)` extent of the points along `rot`'s column `k`.
pub fn place_center(
    rot: &Rotation3<f64>,
    size_mm: &Vector3<f64>,
    extents: &[(f64, f64); 3],
    view_dir: &Vector3<f64>,
    edge_on_cos: f64,
) -> Vector3<f64> {
    let mut c = Vector3::zeros();
    for k in 0..3 {
        let a = rot.matrix().column(k).into_owned();
        let (lo, hi) = extents[k];
        let dot = a.dot(view_dir);
        let ck = if dot.abs() < edge_on_cos {
            0.5 * (lo + hi)
        } else if dot < 0.0 {
            // +a faces the camera: that face sits at the high extreme.
            hi - 0.5 * size_mm[k]
        } else {
            lo + 0.5 * size_mm[k]
        };
        c += a * ck;
    }
    c
}

/// Full hypothesis set for one template size: every frame's 6 rotations, placed behind the
/// visible faces; plus, with a `prior`, the prior itself (resized) and its frame's axis
/// assignments placed the same way. With a prior and `cfg.prior_restricts`, every frame (the
/// prior's included) contributes only the assignment closest to the prior. Boxes that cannot be
/// built are skipped.
pub fn generate(
    obs: &Observation,
    frames: &[Matrix3<f64>],
    size_mm: &Vector3<f64>,
    prior: Option<&OrientedBox>,
    cfg: &HypothesisConfig,
) -> Vec<OrientedBox> {
    let view = obs.view_dir();
    let mut scratch = Vec::with_capacity(obs.subsample.len());
    let mut out = Vec::new();
    let mut all_frames: Vec<Matrix3<f64>> = Vec::with_capacity(frames.len() + 1);
    if let Some(p) = prior {
        all_frames.push(*p.rotation.matrix());
        if let Ok(b) = OrientedBox::new(p.rotation, p.center_mm, *size_mm) {
            out.push(b);
        }
    }
    all_frames.extend_from_slice(frames);
    for f in &all_frames {
        let mut ext = [(0.0, 0.0); 3];
        for k in 0..3 {
            ext[k] = robust_extent(
                obs,
                &f.column(k).into_owned(),
                cfg.extent_trim,
                &mut scratch,
            );
        }
        const PERMS: [[usize; 3]; 6] = [
            [0, 1, 2],
            [1, 2, 0],
            [2, 0, 1],
            [0, 2, 1],
            [2, 1, 0],
            [1, 0, 2],
        ];
        let rots = frame_rotations(f);
        // With a prior (and `prior_restricts`), a frame only contributes the axis assignment
        // closest to the prior's (modulo the box's 180° symmetries): the scale loop keeps its axes.
        let keep: [bool; 6] = match prior {
            Some(pr) if cfg.prior_restricts => {
                let m = pr.rotation.matrix().transpose();
                let sim = |r: &Rotation3<f64>| {
                    let d = (m * r.matrix()).diagonal();
                    // max over the 4 sign patterns with an even number of flips.
                    [
                        d.x + d.y + d.z,
                        d.x - d.y - d.z,
                        -d.x + d.y - d.z,
                        -d.x - d.y + d.z,
                    ]
                    .into_iter()
                    .fold(f64::NEG_INFINITY, f64::max)
                };
                let best = (0..6)
                    .max_by(|&a, &b| sim(&rots[a]).total_cmp(&sim(&rots[b])))
                    .unwrap_or(0);
                std::array::from_fn(|i| i == best)
            }
            _ => [true; 6],
        };
        for ((r, p), _) in rots.iter().zip(PERMS).zip(keep).filter(|x| x.1) {
            // Column 2 of r is ±frame column p[2]; its extent flips with the sign.
            let z_sign = r.matrix().column(2).dot(&f.column(p[2]));
            let e2 = if z_sign >= 0.0 {
                ext[p[2]]
            } else {
                (-ext[p[2]].1, -ext[p[2]].0)
            };
            let e = [ext[p[0]], ext[p[1]], e2];
            let c = place_center(r, size_mm, &e, &view, cfg.edge_on_cos);
            if let Ok(b) = OrientedBox::new(*r, c, *size_mm) {
                out.push(b);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_extents_measure_the_visible_faces_along_the_frame() {
        use crate::observation::{observe, ObservationConfig};
        use crate::pipeline::test_scene::{cam, render};
        let k = cam();
        let size = Vector3::new(260.0, 170.0, 120.0);
        let extents = |b: &OrientedBox, frame: &Matrix3<f64>| {
            let (depth, masks) = render(&[*b], &[], &k, 640, 480);
            let obs = observe(&depth, &k, &masks[0], &ObservationConfig::default()).unwrap();
            frame_extents_mm(&obs, frame, 0.0)
        };
        // Three faces in view: together they span the whole box along each of its axes. The
        // points are a subsample of pixel centres, so the extents fall a little short.
        let turned = OrientedBox::new(
            Rotation3::from_euler_angles(0.5, -0.6, 0.4),
            Vector3::new(30.0, -20.0, 950.0),
            size,
        )
        .unwrap();
        let e = extents(&turned, turned.rotation.matrix());
        for a in 0..3 {
            assert!(
                e[a] > 0.9 * size[a] && e[a] < size[a] + 2.0,
                "axis {a}: {e:?} for {size:?}"
            );
        }
        // One face, straight on: nothing along the viewing axis; along a frame turned by 45°
        // about it, the face's projection onto the diagonals, (260 + 170) / √2 mm.
        let front =
            OrientedBox::new(Rotation3::identity(), Vector3::new(0.0, 0.0, 1000.0), size).unwrap();
        let e = extents(&front, &Matrix3::identity());
        assert!(e.z < 1.0, "{e:?}");
        assert!(
            e.x > 0.9 * 260.0 && e.x < 262.0 && e.y > 0.9 * 170.0 && e.y < 172.0,
            "{e:?}"
        );
        let diag = Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_4);
        let e = extents(&front, diag.matrix());
        let want = (260.0 + 170.0) / std::f64::consts::SQRT_2;
        for a in 0..2 {
            assert!((e[a] - want).abs() < 0.1 * want, "{e:?} vs {want}");
        }
    }

    #[test]
    fn min_area_rect_finds_rotated_rectangle() {
        let t = 0.37f64;
        let (d, n) = (
            Vector2::new(t.cos(), t.sin()),
            Vector2::new(-t.sin(), t.cos()),
        );
        let mut pts = Vec::new();
        for i in 0..=20 {
            for j in 0..=8 {
                pts.push(d * (i as f64 * 10.0) + n * (j as f64 * 5.0) + Vector2::new(3.0, -7.0));
            }
        }
        let got = min_area_rect_dir(&pts).unwrap();
        assert!(
            got.dot(&d).abs() > 0.99999 || got.dot(&n).abs() > 0.99999,
            "{got:?}"
        );
        assert_eq!(convex_hull_2d(&pts).len(), 4);
    }

    #[test]
    fn frame_distance_ignores_axis_relabeling() {
        let r = Rotation3::from_euler_angles(0.3, 0.2, -0.5);
        let f = *r.matrix();
        for q in frame_rotations(&f) {
            assert!(frame_distance_deg(&f, q.matrix()) < 1e-6);
        }
        let g = (r * Rotation3::from_euler_angles(0.0, 0.0, 10f64.to_radians())).into_inner();
        assert!((frame_distance_deg(&f, &g) - 10.0).abs() < 1e-6);
        for q in frame_rotations(&f) {
            assert!((q.matrix().determinant() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn centre_sits_behind_the_visible_faces() {
        // Axis-aligned box seen straight on: front face points at z = 1000 spanning x ∈ [-50, 50],
        // y ∈ [-30, 30]; depth 80 → centre z = 1040, not 1000.
        let ext = [(-50.0, 50.0), (-30.0, 30.0), (1000.0, 1000.0)];
        let c = place_center(
            &Rotation3::identity(),
            &Vector3::new(100.0, 60.0, 80.0),
            &ext,
            &Vector3::z(),
            0.1,
        );
        assert!((c - Vector3::new(0.0, 0.0, 1040.0)).norm() < 1e-9);
        // Flipped z axis: the same physical placement.
        let flip = Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        let ext2 = [(-50.0, 50.0), (-30.0, 30.0), (-1000.0, -1000.0)];
        let c2 = place_center(
            &flip,
            &Vector3::new(100.0, 60.0, 80.0),
            &ext2,
            &Vector3::z(),
            0.1,
        );
        assert!((c2 - c).norm() < 1e-9, "{c2:?}");
    }
}
