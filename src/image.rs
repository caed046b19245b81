//! The plain linear-HDR image: what a film becomes once its means are taken, and what the
//! output writes. A module of its own so that `film` makes images without depending on
//! `output`.

/// One linear-HDR frame, row-major from the top-left pixel, RGB radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` pixels of linear RGB radiance, before exposure.
    pub data: Vec<[f32; 3]>,
}

impl HdrImage {
    /// A black image.
    ///
    /// # Panics
    /// If `width * height` overflows `usize`.
    pub fn new(width: usize, height: usize) -> Self {
        let n = width
            .checked_mul(height)
            .expect("image size overflows usize");
        HdrImage {
            width,
            height,
            data: vec![[0.0; 3]; n],
        }
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`.
    pub fn from_fn(
        width: usize,
        height: usize,
        mut f: impl FnMut(usize, usize) -> [f32; 3],
    ) -> Self {
        let mut img = HdrImage::new(width, height);
        for y in 0..height {
            for x in 0..width {
                img.data[y * width + x] = f(x, y);
            }
        }
        img
    }
}
