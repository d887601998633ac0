//! Depth-sensor model (SPEC §5): turns the exact rendered depth into what a consumer RGB-D camera
//! would report.
//!
//! Effects, in the order applied (each draws from a counter-based hash of the pixel index, so the
//! result is independent of threads and identical for identical inputs):
//! 1. **Stereo occlusion shadows** (RealSense-like only): a pixel that the second imager cannot
//!    see (a nearer surface to its right covers it after the disparity shift) has no depth. Exact
//!    test on disparities `d = f·B/z`: pixel `u` is occluded when `max_{j>u}(d_j − j) ≥ d_u − u`.
//! 2. **Depth discontinuities**: where a 4-neighbour is nearer by more than
//!    `15 mm + 2 % · z`, the far-side pixel is dropped with probability 0.45 or becomes a
//!    *flying pixel* (depth mixed between the two surfaces) with probability 0.15; the near-side
//!    pixel is dropped with probability 0.1.
//! 3. **Grazing angles**: incidence angle above 80° → dropped; 70°–80° → dropped with a
//!    probability rising linearly from 0 to 1.
//! 4. **Holes**: 0–8 elliptic blobs of 1.5–8 px radius per frame, plus 0.2 % isolated dropouts.
//! 5. **Axial noise**: `z += σ(z, θ) · N(0, 1)` with the camera's model:
//!    - RealSense D400-like: `σ = z² · s / (f_d · B)` — Intel's RMS depth-error formula
//!      (Grunnet-Jepsen, Sweetser & Woodfill, "Best-Known-Methods for Tuning Intel RealSense D400
//!      Depth Cameras for Best Performance", Intel white paper, 2018, §"Depth RMS error") with
//!      subpixel RMS `s = 0.08 px`, baseline `B = 50 mm` (D435) and depth-imager focal length
//!      `f_d = 383 px` (1280×720 → 640×480 scaled, HFOV ≈ 87°). σ(1 m) ≈ 4.2 mm, σ(2 m) ≈ 16.7 mm.
//!    - Kinect-like: Nguyen, Izadi & Lovell, "Modeling Kinect Sensor Noise for Improved 3D
//!      Reconstruction and Tracking", 3DIMPVT 2012, eq. for axial noise:
//!      `σ_z(z, θ) = 1.2 mm + 1.9 mm · (z_m − 0.4)²` for θ ≤ 60°, plus
//!      `0.1 mm / √z_m · θ² / (π/2 − θ)²` above 60° (z_m = depth in metres, θ = incidence angle).
//!      σ(1 m) ≈ 1.9 mm, σ(2 m) ≈ 6.1 mm.
//!
//!    The noise is split between a per-pixel white part and a spatially correlated part (a
//!    bilinearly interpolated Gaussian field on a grid of `cell` px, renormalised to unit
//!    variance), because stereo and structured-light sensors match windows of several pixels and
//!    so produce smooth bumps rather than independent per-pixel errors. Share of the variance in
//!    the correlated part: 60 % on an 8 px grid (RealSense-like), 40 % on a 6 px grid
//!    (Kinect-like) — our choice; the total σ is the cited model's.
//! 6. **Quantisation** to 1 mm (the PNG's `depth_scale` 1.0) and the **working range**
//!    (RealSense-like 200–10 000 mm; Kinect-like 500–3860 mm, Azure Kinect NFOV unbinned).
//!
//! `NoiseModel::None` keeps the exact depth (the PNG writer still rounds it to 1 mm).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::render::{RenderOut, NO_HIT};
use crate::rng::{gauss, hash3, unit};
use crate::scene::CameraKind;

/// D435 stereo baseline, mm.
pub const D435_BASELINE_MM: f64 = 50.0;
/// D435 subpixel disparity RMS, px (Intel BKM white paper, typical value).
pub const D435_SUBPIXEL_PX: f64 = 0.08;
/// D435 depth-imager focal length at 640×480, px.
pub const D435_DEPTH_FOCAL_PX: f64 = 383.0;

/// Axial depth noise σ in mm at depth `z_mm` and incidence angle `theta_rad` for a camera kind.
pub(crate) fn axial_sigma_mm(camera: CameraKind, z_mm: f64, theta_rad: f64) -> f64 {
    match camera {
        CameraKind::RealSenseD435 => {
            z_mm * z_mm * D435_SUBPIXEL_PX / (D435_DEPTH_FOCAL_PX * D435_BASELINE_MM)
        }
        CameraKind::KinectLike => {
            let z_m = z_mm / 1000.0;
            let mut s = 1.2 + 1.9 * (z_m - 0.4).powi(2);
            let lim = 60f64.to_radians();
            if theta_rad > lim {
                let th = theta_rad.min(1.5);
                s += 0.1 / z_m.max(0.1).sqrt() * th * th
                    / (std::f64::consts::FRAC_PI_2 - th).powi(2);
            }
            s
        }
    }
}

/// `(share of variance, grid cell px)` of the spatially correlated part of the axial noise.
pub(crate) fn correlated_part(camera: CameraKind) -> (f64, f64) {
    match camera {
        CameraKind::RealSenseD435 => (0.6, 8.0),
        CameraKind::KinectLike => (0.4, 6.0),
    }
}

/// Unit-variance smooth Gaussian field: bilinear interpolation of independent normals on a
/// `cell`-px grid, divided by the root of the summed squared weights (so every pixel has unit
/// variance). The grid normals are drawn once per frame.
struct SmoothField {
    cell: f64,
    nx: usize,
    grid: Vec<f64>,
}

impl SmoothField {
    fn new(key: u64, width: usize, height: usize, cell: f64) -> SmoothField {
        let nx = (width as f64 / cell).ceil() as usize + 2;
        let ny = (height as f64 / cell).ceil() as usize + 2;
        let grid = (0..nx * ny)
            .map(|i| gauss(hash3(key, i as u64, 0xF1E1D)))
            .collect();
        SmoothField { cell, nx, grid }
    }

    fn at(&self, u: f64, v: f64) -> f64 {
        let (gx, gy) = (u / self.cell, v / self.cell);
        let (x0, y0) = (gx.floor(), gy.floor());
        let (fx, fy) = (gx - x0, gy - y0);
        let i = y0 as usize * self.nx + x0 as usize;
        let g = |j: usize| self.grid.get(j).copied().unwrap_or(0.0);
        let w = [
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        ];
        let val = w[0] * g(i) + w[1] * g(i + 1) + w[2] * g(i + self.nx) + w[3] * g(i + self.nx + 1);
        val / w.iter().map(|x| x * x).sum::<f64>().sqrt()
    }
}

/// The sensor's working range `(min, max)`, mm.
pub(crate) fn range_mm(camera: CameraKind) -> (f64, f64) {
    match camera {
        CameraKind::RealSenseD435 => (200.0, 10_000.0),
        CameraKind::KinectLike => (500.0, 3860.0),
    }
}

/// Applies the sensor model to a rendered frame; returns depth in mm (0 = invalid).
pub(crate) fn apply_realistic(
    r: &RenderOut,
    camera: CameraKind,
    fx: f64,
    width: u32,
    height: u32,
    key: u64,
    rng: &mut ChaCha8Rng,
) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    let z = &r.depth_mm;
    let mut keep: Vec<bool> = z.iter().map(|&d| d > 0.0).collect();
    let mut out: Vec<f64> = z.clone();
    let draw = |i: usize, p: u64| unit(hash3(key, i as u64, p));

    // 1. Stereo occlusion (the second imager sits at +B along x).
    if camera == CameraKind::RealSenseD435 {
        let fb = fx * D435_BASELINE_MM;
        for v in 0..h {
            let mut best = f64::NEG_INFINITY;
            for u in (0..w).rev() {
                let i = v * w + u;
                if z[i] <= 0.0 {
                    continue;
                }
                let d = fb / z[i];
                if best >= d - u as f64 + 0.5 {
                    keep[i] = false;
                }
                best = best.max(d - u as f64);
            }
        }
    }
    // 2. Discontinuities.
    for v in 0..h {
        for u in 0..w {
            let i = v * w + u;
            let zi = z[i];
            if zi <= 0.0 {
                continue;
            }
            let thr = 15.0 + 0.02 * zi;
            let mut nearest = zi;
            let mut farther = false;
            let nbs = [
                (u > 0).then(|| i - 1),
                (u + 1 < w).then(|| i + 1),
                (v > 0).then(|| i - w),
                (v + 1 < h).then(|| i + w),
            ];
            for j in nbs.into_iter().flatten() {
                let zj = z[j];
                if zj <= 0.0 || r.inst[j] == NO_HIT {
                    continue;
                }
                nearest = nearest.min(zj);
                if zj - zi > thr {
                    farther = true;
                }
            }
            if zi - nearest > thr {
                let p = draw(i, 10);
                if p < 0.45 {
                    keep[i] = false;
                } else if p < 0.6 {
                    out[i] = nearest + (zi - nearest) * draw(i, 11);
                }
            } else if farther && draw(i, 12) < 0.1 {
                keep[i] = false;
            }
        }
    }
    // 3. Grazing angles.
    for i in 0..w * h {
        let theta = (r.cos_inc[i] as f64).clamp(0.0, 1.0).acos().to_degrees();
        if theta > 80.0 || (theta > 70.0 && draw(i, 20) < (theta - 70.0) / 10.0) {
            keep[i] = false;
        }
    }
    // 4. Holes.
    let n_holes = rng.random_range(0..=8);
    for _ in 0..n_holes {
        let cu = rng.random_range(0.0..width as f64);
        let cv = rng.random_range(0.0..height as f64);
        let ra = rng.random_range(1.5..8.0);
        let rb = rng.random_range(1.5..8.0);
        let (u0, u1) = (
            (cu - ra).floor().max(0.0) as usize,
            ((cu + ra).ceil() as usize).min(w - 1),
        );
        let (v0, v1) = (
            (cv - rb).floor().max(0.0) as usize,
            ((cv + rb).ceil() as usize).min(h - 1),
        );
        for v in v0..=v1 {
            for u in u0..=u1 {
                let (du, dv) = ((u as f64 - cu) / ra, (v as f64 - cv) / rb);
                if du * du + dv * dv <= 1.0 {
                    keep[v * w + u] = false;
                }
            }
        }
    }
    // 5, 6. Axial noise, quantisation, range.
    let (zmin, zmax) = range_mm(camera);
    let (rho, cell) = correlated_part(camera);
    let (a_white, a_field) = ((1.0 - rho).sqrt(), rho.sqrt());
    let field = SmoothField::new(hash3(key, 0, 32), w, h, cell);
    (0..w * h)
        .map(|i| {
            if !keep[i] || draw(i, 30) < 0.002 {
                return 0.0;
            }
            let theta = (r.cos_inc[i] as f64).clamp(0.0, 1.0).acos();
            let n = a_white * gauss(hash3(key, i as u64, 31))
                + a_field * field.at((i % w) as f64, (i / w) as f64);
            let zn = out[i] + axial_sigma_mm(camera, out[i], theta) * n;
            let q = zn.round();
            if q < zmin || q > zmax {
                0.0
            } else {
                q as f32
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_values_match_sources() {
        // Intel formula at 1 m: 1e6 · 0.08 / (383 · 50).
        let s = axial_sigma_mm(CameraKind::RealSenseD435, 1000.0, 0.0);
        assert!((s - 4.1775).abs() < 1e-3, "{s}");
        // Nguyen et al. at 1 m: 1.2 + 1.9 · 0.36.
        let s = axial_sigma_mm(CameraKind::KinectLike, 1000.0, 0.0);
        assert!((s - 1.884).abs() < 1e-9, "{s}");
        // Grows at grazing angles.
        assert!(axial_sigma_mm(CameraKind::KinectLike, 1000.0, 1.3) > 1.884 + 0.5);
    }
}
