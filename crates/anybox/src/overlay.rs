//! Overlay drawing: each estimated box's projected wireframe, its axes and its size in mm,
//! drawn over the RGB image (or a grey rendering of the depth map).
//!
//! In: an RGB image, intrinsics, posed boxes. Out: the image with the drawings. Text uses a
//! built-in 5×7 pixel font, so no font file is needed.

use anybox_geom::cuboid::EDGES;
use anybox_geom::nalgebra::Point3;
use anybox_geom::{Intrinsics, OrientedBox};
use anybox_io::{DepthMap, RgbImage};

/// Colours of the box axes x, y, z (red, green, blue, as most 3D tools draw them).
pub const AXIS_COLOURS: [[u8; 3]; 3] = [[230, 40, 40], [40, 200, 40], [50, 90, 255]];

/// One box to draw.
#[derive(Debug, Clone, Copy)]
pub struct OverlayBox {
    /// The box in the camera frame (mm).
    pub pose: OrientedBox,
    /// Wireframe colour.
    pub colour: [u8; 3],
    /// Whether to print the size label.
    pub label: bool,
}

/// A grey-scale visualisation of a depth map (near = bright), for frames without RGB.
pub fn depth_to_rgb(depth: &DepthMap) -> RgbImage {
    let valid: Vec<f32> = depth
        .depth_mm
        .iter()
        .copied()
        .filter(|d| *d > 0.0 && d.is_finite())
        .collect();
    let (lo, hi) = valid.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), d| {
        (lo.min(*d), hi.max(*d))
    });
    let span = (hi - lo).max(1.0);
    RgbImage::from_fn(depth.width, depth.height, |u, v| {
        let d = depth.depth_mm[v as usize * depth.width as usize + u as usize];
        if d > 0.0 && d.is_finite() {
            let g = (255.0 - 200.0 * (d - lo) / span) as u8;
            image::Rgb([g, g, g])
        } else {
            image::Rgb([0, 0, 0])
        }
    })
}

/// Draws every box onto `img` in place.
pub fn draw_boxes(img: &mut RgbImage, intrinsics: &Intrinsics, boxes: &[OverlayBox]) {
    for b in boxes {
        draw_box(img, intrinsics, b);
    }
}

fn draw_box(img: &mut RgbImage, k: &Intrinsics, b: &OverlayBox) {
    let corners = b.pose.corners_mm();
    for [i, j] in EDGES {
        draw_segment_3d(img, k, &corners[i], &corners[j], b.colour);
    }
    let c = Point3::from(b.pose.center_mm);
    for a in 0..3 {
        let tip = c + b.pose.axis(a) * (b.pose.size_mm[a] * 0.5);
        draw_segment_3d(img, k, &c, &tip, AXIS_COLOURS[a]);
    }
    if b.label {
        // Label above the highest projected corner.
        let mut top: Option<(f64, f64)> = None;
        for p in &corners {
            if let Some(px) = k.project(p) {
                if top.is_none_or(|(_, v)| px.y < v) {
                    top = Some((px.x, px.y));
                }
            }
        }
        if let Some((u, v)) = top {
            let s = b.pose.size_mm;
            let text = format!("{:.0}x{:.0}x{:.0}mm", s.x, s.y, s.z);
            let w = text.len() as i64 * 6;
            draw_text(img, u as i64 - w / 2, v as i64 - 12, &text, b.colour);
        }
    }
}

/// Projects a 3D segment, clipping it at a near plane of 1 mm so that points behind the
/// camera never produce wrapped-around lines.
fn draw_segment_3d(
    img: &mut RgbImage,
    k: &Intrinsics,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: [u8; 3],
) {
    const NEAR_MM: f64 = 1.0;
    let (mut a, mut b) = (*a, *b);
    if a.z < NEAR_MM && b.z < NEAR_MM {
        return;
    }
    let clip = |p: &mut Point3<f64>, q: &Point3<f64>| {
        if p.z < NEAR_MM {
            let t = (NEAR_MM - p.z) / (q.z - p.z);
            *p += (q - *p) * t;
        }
    };
    clip(&mut a, &b);
    clip(&mut b, &a);
    if let (Some(pa), Some(pb)) = (k.project(&a), k.project(&b)) {
        draw_line(img, pa.x, pa.y, pb.x, pb.y, c);
    }
}

/// A 2 px wide line; pixels outside the image are skipped.
fn draw_line(img: &mut RgbImage, x0: f64, y0: f64, x1: f64, y1: f64, c: [u8; 3]) {
    let len = ((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt();
    // Bound the work for lines that project absurdly far off-screen.
    let limit = 4.0 * (img.width() + img.height()) as f64;
    if !len.is_finite() || len > 50.0 * limit {
        return;
    }
    let steps = len.ceil().max(1.0) as usize;
    for i in 0..=steps {
        let t = i as f64 / steps as f64;
        let x = x0 + (x1 - x0) * t;
        let y = y0 + (y1 - y0) * t;
        for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            put(
                img,
                (x + dx - 0.5).round() as i64,
                (y + dy - 0.5).round() as i64,
                c,
            );
        }
    }
}

#[inline]
fn put(img: &mut RgbImage, x: i64, y: i64, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, image::Rgb(c));
    }
}

/// 5×7 glyphs, one byte per row, bit 4 = leftmost column.
fn glyph(ch: char) -> [u8; 7] {
    match ch {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '#' => [0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A],
        _ => [0; 7],
    }
}

/// Draws `text` with its top-left corner at `(x, y)`, on a dark backing for legibility.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, c: [u8; 3]) {
    let w = text.chars().count() as i64 * 6;
    for yy in y - 1..y + 8 {
        for xx in x - 1..x + w {
            put(img, xx, yy, [0, 0, 0]);
        }
    }
    for (i, ch) in text.chars().enumerate() {
        let g = glyph(ch);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) != 0 {
                    put(img, x + i as i64 * 6 + col, y + row as i64, c);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anybox_geom::nalgebra::{Rotation3, Unit, Vector3};

    #[test]
    fn draws_inside_the_projected_box_and_survives_boxes_behind_the_camera() {
        let k = Intrinsics::new(500.0, 500.0, 320.0, 240.0).unwrap();
        let mut img = RgbImage::new(640, 480);
        let pose = OrientedBox::new(
            Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 1.0, 0.0)), 0.4),
            Vector3::new(0.0, 0.0, 1000.0),
            Vector3::new(200.0, 150.0, 100.0),
        )
        .unwrap();
        let behind = OrientedBox::new(
            Rotation3::identity(),
            Vector3::new(0.0, 0.0, -50.0),
            Vector3::new(200.0, 200.0, 200.0),
        )
        .unwrap();
        draw_boxes(
            &mut img,
            &k,
            &[
                OverlayBox {
                    pose,
                    colour: [255, 255, 0],
                    label: true,
                },
                OverlayBox {
                    pose: behind,
                    colour: [255, 0, 255],
                    label: true,
                },
            ],
        );
        // Every drawn yellow pixel lies within the projected corners' bounding rectangle.
        let pts: Vec<_> = pose
            .corners_mm()
            .iter()
            .filter_map(|p| k.project(p))
            .collect();
        let (umin, umax) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.x), a.1.max(p.x)));
        let (vmin, vmax) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p.y), a.1.max(p.y)));
        let mut n = 0;
        for (u, v, p) in img.enumerate_pixels() {
            if p.0 == [255, 255, 0] && (v as f64) > vmin - 1.0 {
                assert!(
                    (u as f64) >= umin - 2.0 && (u as f64) <= umax + 2.0,
                    "u {u} outside [{umin}, {umax}]"
                );
                assert!((v as f64) <= vmax + 2.0);
                n += 1;
            }
        }
        assert!(n > 200, "wireframe drawn ({n} px)");
    }
}
