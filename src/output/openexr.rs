//! Linear 32-bit float RGB OpenEXR, scaled by the exposure but not tone-mapped.

use std::io::{Seek, Write};

use exr::prelude::*;

use super::HdrImage;

pub(crate) fn encode<W: Write + Seek>(
    w: W,
    img: &HdrImage,
    exposure: f64,
) -> exr::error::Result<()> {
    let exposure = exposure as f32;
    let width = img.width;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let [r, g, b] = img.data[y * width + x];
        (r * exposure, g * exposure, b * exposure)
    });
    // exr's parallel writer builds a thread pool of its own on every call, that is per frame.
    Image::from_channels((img.width, img.height), channels)
        .write()
        .non_parallel()
        .to_buffered(w)
}
