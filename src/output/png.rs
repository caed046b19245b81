//! 8-bit RGB PNG of the tone-mapped frame.

use std::io::Write;

use image::ImageEncoder;
use image::codecs::png::PngEncoder;

pub(crate) fn encode<W: Write>(
    w: W,
    pixels: &[[u8; 3]],
    width: u32,
    height: u32,
) -> image::ImageResult<()> {
    let bytes: &[u8] = pixels.as_flattened();
    PngEncoder::new(w).write_image(bytes, width, height, image::ExtendedColorType::Rgb8)
}
