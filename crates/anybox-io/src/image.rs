//! In-memory images: depth in millimetres, binary masks, RGB.

/// 8-bit RGB image (the `image` crate's type).
pub type RgbImage = ::image::RgbImage;

/// A depth map in millimetres, row-major, `depth_mm[v * width + u]`.
///
/// `0.0` means "no measurement" (as a zero in a BOP depth PNG). Non-finite values are never
/// stored: loaders map them to 0.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// Depth along the optical axis, mm; 0 = invalid.
    pub depth_mm: Vec<f32>,
}

impl DepthMap {
    /// A map of the given size with every pixel invalid.
    pub fn zeros(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            depth_mm: vec![0.0; width as usize * height as usize],
        }
    }

    /// Depth at `(u, v)` in mm, or `None` outside the image or where invalid.
    #[inline]
    pub fn get(&self, u: u32, v: u32) -> Option<f32> {
        if u >= self.width || v >= self.height {
            return None;
        }
        let d = self.depth_mm[v as usize * self.width as usize + u as usize];
        (d > 0.0 && d.is_finite()).then_some(d)
    }

    /// Number of valid (positive, finite) pixels.
    pub fn valid_count(&self) -> usize {
        self.depth_mm
            .iter()
            .filter(|d| **d > 0.0 && d.is_finite())
            .count()
    }
}

/// A binary mask, row-major, `data[v * width + u]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mask {
    /// Width, px.
    pub width: u32,
    /// Height, px.
    pub height: u32,
    /// `true` inside the mask.
    pub data: Vec<bool>,
}

impl Mask {
    /// An empty mask of the given size.
    pub fn empty(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            data: vec![false; width as usize * height as usize],
        }
    }

    /// Value at `(u, v)`; `false` outside the image.
    #[inline]
    pub fn get(&self, u: u32, v: u32) -> bool {
        u < self.width
            && v < self.height
            && self.data[v as usize * self.width as usize + u as usize]
    }

    /// Sets `(u, v)`; ignored outside the image.
    #[inline]
    pub fn set(&mut self, u: u32, v: u32, value: bool) {
        if u < self.width && v < self.height {
            self.data[v as usize * self.width as usize + u as usize] = value;
        }
    }

    /// Number of pixels inside the mask.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|b| **b).count()
    }

    /// Pixel bounding box `(u_min, v_min, u_max, v_max)`, inclusive; `None` for an empty mask.
    pub fn bbox(&self) -> Option<(u32, u32, u32, u32)> {
        let mut bb: Option<(u32, u32, u32, u32)> = None;
        for v in 0..self.height {
            for u in 0..self.width {
                if self.data[v as usize * self.width as usize + u as usize] {
                    bb = Some(match bb {
                        None => (u, v, u, v),
                        Some((a, b, c, d)) => (a.min(u), b.min(v), c.max(u), d.max(v)),
                    });
                }
            }
        }
        bb
    }
}
