//! Procedural surface appearance: cardboard cartons with tape, labels and print, wood, concrete,
//! painted metal. Colours are linear RGB in `[0, 1]`; [`crate::render`] shades them.

use nalgebra::Vector3;
use rand::Rng;

use crate::rng::{hash3, unit};

/// Appearance of a carton (box frame coordinates, mm; local +z is the carton's "top" as placed).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CartonTexture {
    pub base: [f64; 3],
    /// Tape across the top along local x: (half width mm, colour, how far it runs down the ±x faces, mm).
    pub tape: Option<(f64, [f64; 3], f64)>,
    /// Label on the face `(axis, sign)`: centre (a, b) in face coordinates, half sizes, with text blocks.
    pub label: Option<Label>,
    /// A printed band around the sides: (z centre, half height, colour).
    pub band: Option<(f64, f64, [f64; 3])>,
    /// Seed for text-like blocks and small stains.
    pub key: u64,
}

/// A white label with text-like dark blocks.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Label {
    pub axis: usize,
    pub sign: f64,
    pub center: [f64; 2],
    pub half: [f64; 2],
}

/// Surface materials.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Material {
    Carton(Box<CartonTexture>),
    Solid([f64; 3]),
    /// Wood with grain along local x.
    Wood([f64; 3]),
    /// Concrete floor tiles (uses world-like local x, y of a large slab).
    Concrete,
}

impl CartonTexture {
    /// A random carton appearance for a box of the given half extents.
    pub(crate) fn random<R: Rng>(rng: &mut R, half: &Vector3<f64>) -> CartonTexture {
        let kind = rng.random::<f64>();
        let base = if kind < 0.62 {
            // Kraft cardboard browns.
            let l = rng.random_range(0.75..1.05);
            [0.62 * l, 0.45 * l, 0.28 * l]
        } else if kind < 0.8 {
            let l = rng.random_range(0.85..0.97);
            [l, l, l * 0.97]
        } else {
            let hue = rng.random_range(0..6);
            let palette = [
                [0.75, 0.18, 0.15],
                [0.15, 0.35, 0.7],
                [0.2, 0.55, 0.25],
                [0.85, 0.7, 0.15],
                [0.35, 0.35, 0.38],
                [0.6, 0.3, 0.55],
            ];
            palette[hue]
        };
        let tape = if rng.random_bool(0.6) {
            let w = rng.random_range(20.0..30.0_f64).min(half.y * 0.6);
            let c = if rng.random_bool(0.6) {
                [0.7, 0.55, 0.3]
            } else {
                [0.92, 0.92, 0.9]
            };
            Some((w, c, rng.random_range(30.0..80.0_f64).min(half.z)))
        } else {
            None
        };
        let label = if rng.random_bool(0.55) {
            let axis = rng.random_range(0..2usize);
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            // Face coordinates: the other two axes in increasing order.
            let (ia, ib) = other_axes(axis);
            let ha = half[ia] * rng.random_range(0.25..0.6);
            let hb = half[ib] * rng.random_range(0.2..0.5);
            let ca = rng.random_range(-(half[ia] - ha)..=(half[ia] - ha));
            let cb = rng.random_range(-(half[ib] - hb)..=(half[ib] - hb));
            Some(Label {
                axis,
                sign,
                center: [ca, cb],
                half: [ha, hb],
            })
        } else {
            None
        };
        let band = if rng.random_bool(0.3) {
            let hh = half.z * rng.random_range(0.05..0.15);
            let zc = rng.random_range(-(half.z - hh)..=(half.z - hh));
            let c = [
                rng.random_range(0.05..0.9),
                rng.random_range(0.05..0.9),
                rng.random_range(0.05..0.9),
            ];
            Some((zc, hh, c))
        } else {
            None
        };
        CartonTexture {
            base,
            tape,
            label,
            band,
            key: rng.random(),
        }
    }

    /// Albedo at box-frame point `p` on the face with normal axis `axis`.
    pub(crate) fn albedo(&self, p: &Vector3<f64>, axis: usize, half: &Vector3<f64>) -> [f64; 3] {
        let sign = if p[axis] >= 0.0 { 1.0 } else { -1.0 };
        // Fibre-like variation so that flat faces are not perfectly uniform.
        let grain = 0.94 + 0.06 * unit(hash3(self.key, (p.x * 0.5) as i64 as u64, axis as u64));
        let mut c = self.base.map(|x| x * grain);
        if let Some((zc, hh, col)) = self.band {
            if axis != 2 && (p.z - zc).abs() <= hh {
                c = col;
            }
        }
        if let Some(l) = &self.label {
            if l.axis == axis && l.sign == sign {
                let (ia, ib) = other_axes(axis);
                let a = p[ia] - l.center[0];
                let b = p[ib] - l.center[1];
                if a.abs() <= l.half[0] && b.abs() <= l.half[1] {
                    c = [0.93, 0.93, 0.9];
                    // Text-like blocks: rows of words with 12 mm line pitch, 3 mm margins.
                    let ra = a + l.half[0] - 4.0;
                    let rb = b + l.half[1] - 4.0;
                    if ra > 0.0
                        && rb > 0.0
                        && ra < 2.0 * l.half[0] - 8.0
                        && rb < 2.0 * l.half[1] - 8.0
                    {
                        let line = (rb / 12.0).floor();
                        let in_line = rb - line * 12.0 < 7.0;
                        let word = (ra / 18.0).floor();
                        let on =
                            unit(hash3(self.key, line as i64 as u64, word as i64 as u64)) < 0.7;
                        let in_word = ra - word * 18.0 < 15.0;
                        if in_line && on && in_word {
                            c = [0.08, 0.08, 0.1];
                        }
                    }
                }
            }
        }
        // Creased, slightly dirty carton edges and the flap seam across the top: what makes
        // touching identical cartons separable in RGB at all.
        let (ia, ib) = other_axes(axis);
        let edge = (half[ia] - p[ia].abs()).min(half[ib] - p[ib].abs());
        if edge < 2.5 {
            c = c.map(|x| x * 0.72);
        } else if axis == 2 && p.y.abs() < 1.5 {
            c = c.map(|x| x * 0.55);
        }
        if let Some((hw, col, run)) = self.tape {
            let on_top = axis == 2 && sign > 0.0;
            let on_end = axis == 0 && p.z >= half.z - run;
            if (on_top || on_end) && p.y.abs() <= hw {
                c = col;
            }
        }
        c
    }
}

/// The two axes spanning the face whose normal is `axis`.
pub(crate) fn other_axes(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

impl Material {
    /// Albedo at a local hit point (`axis` = cuboid face axis, 3 for curved shapes).
    pub(crate) fn albedo(&self, p: &Vector3<f64>, axis: usize, half: &Vector3<f64>) -> [f64; 3] {
        match self {
            Material::Carton(t) => {
                if axis < 3 {
                    t.albedo(p, axis, half)
                } else {
                    t.base
                }
            }
            Material::Solid(c) => *c,
            Material::Wood(c) => {
                let g = 0.85 + 0.15 * (p.y * 0.21 + 2.5 * (p.x * 0.013).sin()).sin();
                c.map(|x| x * g)
            }
            Material::Concrete => {
                // 600 mm tiles with 6 mm joints and per-tile tone.
                let tx = (p.x / 600.0).floor();
                let ty = (p.y / 600.0).floor();
                let fx = p.x - tx * 600.0;
                let fy = p.y - ty * 600.0;
                if fx < 6.0 || fy < 6.0 {
                    return [0.3, 0.3, 0.3];
                }
                let tone = 0.5 + 0.12 * unit(hash3(tx as i64 as u64, ty as i64 as u64, 99));
                let speck = 0.04
                    * unit(hash3(
                        (p.x * 0.2) as i64 as u64,
                        (p.y * 0.2) as i64 as u64,
                        7,
                    ));
                let v = tone + speck;
                [v, v * 0.99, v * 0.96]
            }
        }
    }
}
