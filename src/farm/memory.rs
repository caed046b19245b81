//! How much memory a render needs, so that one the machine cannot hold is refused before any
//! work starts, with the figure, instead of aborting part-way with a failed allocation.
//!
//! The figures are peak resident memory measured per pixel (`/usr/bin/time -f %M`, 512 x 512
//! and 1024 x 1024, one sample per pixel): they are what the renderer really holds, and a
//! little under it, so that a render that fits is never refused.

use crate::scene::Denoise;

/// Each frame in flight while rendering: its pixels' sums (`PixelSums`, 152 bytes), the film
/// they are saved as, and the frame's scene. Measured: 0.51 KB a pixel with one frame in
/// flight, twice that with two.
pub const RENDER_BYTES_PER_PIXEL: u64 = 512;

/// Bytes a pixel while the films of `frames` frames are denoised and encoded: the denoiser
/// holds a window of neighbouring frames' films and guides, and the next film is read while
/// one is filtered. Measured with `atrous` (2026-12-05, the render's peak, 512 x 512,
/// `d4_packing` at 1 sample and 1 bounce): 0.65 KB for one frame, 1.25 KB for two, 1.60 KB
/// for three, 2.16 KB for four and 2.53 KB for eight; `median` over eight: 1.37 KB; `none`:
/// 1.28 KB (two frames in flight while rendering).
pub fn finishing_bytes_per_pixel(denoise: Denoise, frames: usize) -> u64 {
    match (denoise, frames) {
        (Denoise::None, _) | (_, 0 | 1) => 512,
        (Denoise::Median, _) => 1000,
        (Denoise::Atrous, 2) => 1200,
        (Denoise::Atrous, 3) => 1500,
        (Denoise::Atrous, _) => 2100,
    }
}

/// The memory a render of `width` x `height` needs at its peak: `in_flight` frames rendered at
/// once, then (when `finishing`) `frames` frames denoised with `denoise` and encoded.
pub fn needed(
    width: u32,
    height: u32,
    in_flight: usize,
    finishing: Option<(Denoise, usize)>,
) -> u64 {
    let pixels = width as u64 * height as u64;
    let render = RENDER_BYTES_PER_PIXEL * in_flight.max(1) as u64;
    let finish = finishing.map_or(0, |(d, frames)| finishing_bytes_per_pixel(d, frames));
    pixels.saturating_mul(render.max(finish))
}

/// Used when the memory available cannot be read: far more than any render that fits needs,
/// far less than the sizes that cannot fit anywhere.
pub const UNKNOWN_AVAILABLE: u64 = 1 << 40;

/// The memory available to a new process: `MemAvailable` of `/proc/meminfo` on Linux, `None`
/// where it cannot be read.
pub fn available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo(&text)
}

fn parse_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let n: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => n.checked_mul(1024),
        None => Some(n),
        Some(_) => None,
    }
}

/// `bytes` for a person: `137.4 GiB`, `512 MiB`.
pub fn human(bytes: u64) -> String {
    const GIB: f64 = (1u64 << 30) as f64;
    const MIB: f64 = (1u64 << 20) as f64;
    let b = bytes as f64;
    if b >= GIB {
        format!("{:.1} GiB", b / GIB)
    } else {
        format!("{:.0} MiB", (b / MIB).ceil())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_mem_available() {
        let text =
            "MemTotal:       24683664 kB\nMemFree:         1000 kB\nMemAvailable:   24200200 kB\n";
        assert_eq!(parse_meminfo(text), Some(24200200 * 1024));
        assert_eq!(parse_meminfo("MemTotal: 5 kB\n"), None);
    }

    #[test]
    fn the_largest_image_needs_more_than_a_hundred_gigabytes() {
        let n = needed(16384, 16384, 1, Some((Denoise::Atrous, 1)));
        assert_eq!(human(n), "128.0 GiB");
        assert_eq!(needed(320, 240, 2, None), 320 * 240 * 1024);
    }
}
