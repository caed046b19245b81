//! Animated GIF: per-frame NeuQuant palettes, Floyd–Steinberg dithering.

use std::collections::HashMap;
use std::io::Write;

use color_quant::NeuQuant;
use rayon::prelude::*;

/// One frame reduced to at most 256 colours.
pub(crate) struct Quantised {
    /// RGB triples, at most 256 of them.
    pub palette: Vec<[u8; 3]>,
    /// One palette index per pixel.
    pub indices: Vec<u8>,
    /// PSNR (dB) of the result against the input; infinite when exact.
    pub psnr: f64,
}

/// Quantise one 8-bit frame. Frames with at most 256 colours keep them exactly.
pub(crate) fn quantise(pixels: &[[u8; 3]], width: usize) -> Quantised {
    if let Some((palette, indices)) = exact_palette(pixels) {
        return Quantised {
            palette,
            indices,
            psnr: f64::INFINITY,
        };
    }
    let mut palette = neuquant_palette(pixels);
    refine(pixels, &mut palette, REFINE_PASSES);
    let indices = dither(pixels, width, &palette);
    let psnr = psnr(pixels, &palette, &indices);
    Quantised {
        palette,
        indices,
        psnr,
    }
}

/// The frame's own colours, if there are at most 256.
fn exact_palette(pixels: &[[u8; 3]]) -> Option<(Vec<[u8; 3]>, Vec<u8>)> {
    let mut map: HashMap<[u8; 3], u8> = HashMap::new();
    let mut palette = Vec::new();
    let mut indices = Vec::with_capacity(pixels.len());
    for &p in pixels {
        let i = match map.get(&p) {
            Some(&i) => i,
            None => {
                if palette.len() == 256 {
                    return None;
                }
                let i = palette.len() as u8;
                palette.push(p);
                map.insert(p, i);
                i
            }
        };
        indices.push(i);
    }
    Some((palette, indices))
}

fn neuquant_palette(pixels: &[[u8; 3]]) -> Vec<[u8; 3]> {
    let rgba: Vec<u8> = pixels
        .iter()
        .flat_map(|&[r, g, b]| [r, g, b, 255])
        .collect();
    // Sampling every 10th pixel is the usual speed/quality compromise, but small frames need
    // every pixel for the network to train at all.
    let sample = if pixels.len() < 100_000 { 1 } else { 10 };
    let nq = NeuQuant::new(sample, 256, &rgba);
    nq.color_map_rgb()
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

/// Lloyd (k-means) passes after NeuQuant: its network under-serves sparse regions of colour
/// space, and a few passes move each entry to the mean of the pixels it stands for.
const REFINE_PASSES: usize = 3;

fn refine(pixels: &[[u8; 3]], palette: &mut [[u8; 3]], passes: usize) {
    for _ in 0..passes {
        let mut sums = vec![[0u64; 3]; palette.len()];
        let mut counts = vec![0u64; palette.len()];
        let mut nearest = Nearest::new(palette);
        for &p in pixels {
            let i = nearest.find(p) as usize;
            counts[i] += 1;
            for k in 0..3 {
                sums[i][k] += p[k] as u64;
            }
        }
        for ((entry, sum), &n) in palette.iter_mut().zip(&sums).zip(&counts) {
            if n > 0 {
                *entry = sum.map(|s| ((s + n / 2) / n) as u8);
            }
        }
    }
}

/// Exact nearest-colour search, accelerated by a lazily built grid of 32³ cells, each holding
/// only the palette entries that can be nearest to some point in the cell.
struct Nearest<'a> {
    palette: &'a [[u8; 3]],
    cells: Vec<Option<Box<[u8]>>>,
}

impl<'a> Nearest<'a> {
    const SHIFT: u32 = 3; // 8 values per cell side

    fn new(palette: &'a [[u8; 3]]) -> Self {
        Nearest {
            palette,
            cells: vec![None; 32 * 32 * 32],
        }
    }

    fn find(&mut self, c: [u8; 3]) -> u8 {
        let cell = c.map(|v| (v >> Self::SHIFT) as usize);
        let key = (cell[0] << 10) | (cell[1] << 5) | cell[2];
        let palette = self.palette;
        let candidates = self.cells[key].get_or_insert_with(|| candidates(palette, cell));
        let mut best = candidates[0];
        let mut best_d = u32::MAX;
        for &i in candidates.iter() {
            let d = dist2(palette[i as usize], c);
            if d < best_d {
                best_d = d;
                best = i;
            }
        }
        best
    }
}

fn dist2(a: [u8; 3], b: [u8; 3]) -> u32 {
    (0..3)
        .map(|k| {
            let d = a[k] as i32 - b[k] as i32;
            (d * d) as u32
        })
        .sum()
}

/// Palette entries whose smallest distance to the cell is within the smallest largest distance
/// of any entry: the nearest entry of every point in the cell is among them.
fn candidates(palette: &[[u8; 3]], cell: [usize; 3]) -> Box<[u8]> {
    let lo = cell.map(|v| (v << Nearest::SHIFT) as i32);
    let hi = lo.map(|v| v + (1 << Nearest::SHIFT) - 1);
    let bounds: Vec<(u32, u32)> = palette
        .iter()
        .map(|p| {
            let (mut dmin, mut dmax) = (0u32, 0u32);
            for k in 0..3 {
                let v = p[k] as i32;
                let near = if v < lo[k] {
                    lo[k] - v
                } else if v > hi[k] {
                    v - hi[k]
                } else {
                    0
                };
                let far = (v - lo[k]).abs().max((hi[k] - v).abs());
                dmin += (near * near) as u32;
                dmax += (far * far) as u32;
            }
            (dmin, dmax)
        })
        .collect();
    let limit = bounds.iter().map(|b| b.1).min().unwrap_or(0);
    bounds
        .iter()
        .enumerate()
        .filter(|(_, b)| b.0 <= limit)
        .map(|(i, _)| i as u8)
        .collect()
}

/// Floyd–Steinberg error diffusion with a serpentine scan, in 8-bit sRGB space.
fn dither(pixels: &[[u8; 3]], width: usize, palette: &[[u8; 3]]) -> Vec<u8> {
    let height = pixels.len() / width;
    let mut nearest = Nearest::new(palette);
    let mut indices = vec![0u8; pixels.len()];
    // One cell of padding on each side so the kernel never leaves the buffer.
    let mut cur = vec![[0f32; 3]; width + 2];
    let mut next = vec![[0f32; 3]; width + 2];
    for y in 0..height {
        let forward = y % 2 == 0;
        for step in 0..width {
            let x = if forward { step } else { width - 1 - step };
            let src = pixels[y * width + x];
            let e = cur[x + 1];
            let want: [f32; 3] = std::array::from_fn(|k| (src[k] as f32 + e[k]).clamp(0.0, 255.0));
            let i = nearest.find(want.map(|v| v.round() as u8));
            indices[y * width + x] = i;
            let got = palette[i as usize];
            let err: [f32; 3] = std::array::from_fn(|k| want[k] - got[k] as f32);
            let (ahead, behind) = if forward { (x + 2, x) } else { (x, x + 2) };
            for k in 0..3 {
                cur[ahead][k] += err[k] * (7.0 / 16.0);
                next[behind][k] += err[k] * (3.0 / 16.0);
                next[x + 1][k] += err[k] * (5.0 / 16.0);
                next[ahead][k] += err[k] * (1.0 / 16.0);
            }
        }
        std::mem::swap(&mut cur, &mut next);
        next.fill([0.0; 3]);
    }
    indices
}

/// PSNR over all three channels, peak 255.
fn psnr(pixels: &[[u8; 3]], palette: &[[u8; 3]], indices: &[u8]) -> f64 {
    let sse: u64 = pixels
        .iter()
        .zip(indices)
        .map(|(&p, &i)| dist2(p, palette[i as usize]) as u64)
        .sum();
    if sse == 0 {
        return f64::INFINITY;
    }
    let mse = sse as f64 / (pixels.len() * 3) as f64;
    10.0 * (255.0 * 255.0 / mse).log10()
}

/// Mean PSNR: infinite frames are exact, so they are left out unless every frame is.
pub(crate) fn mean_psnr(values: &[f64]) -> f64 {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        f64::INFINITY
    } else {
        finite.iter().sum::<f64>() / finite.len() as f64
    }
}

/// Frame delay in hundredths of a second; at least 2 because browsers slow smaller delays down.
pub(crate) fn frame_delay(fps: f64) -> u16 {
    let d = (100.0 / fps).round();
    if d.is_nan() {
        return 2;
    }
    d.clamp(2.0, u16::MAX as f64) as u16
}

/// An infinitely looping animated GIF, written a batch of frames at a time.
pub(crate) struct Writer<W: Write> {
    encoder: ::gif::Encoder<W>,
    width: u16,
    height: u16,
    delay: u16,
    psnrs: Vec<f64>,
}

impl<W: Write> Writer<W> {
    /// Write the header of a `width` × `height` animation at `fps`.
    pub(crate) fn new(
        w: W,
        width: u16,
        height: u16,
        fps: f64,
    ) -> Result<Self, ::gif::EncodingError> {
        let mut encoder = ::gif::Encoder::new(w, width, height, &[])?;
        encoder.set_repeat(::gif::Repeat::Infinite)?;
        Ok(Writer {
            encoder,
            width,
            height,
            delay: frame_delay(fps),
            psnrs: Vec::new(),
        })
    }

    /// Quantise 8-bit frames (all `width` × `height`) in parallel, then append them in order.
    pub(crate) fn write_frames(
        &mut self,
        frames: &[Vec<[u8; 3]>],
    ) -> Result<(), ::gif::EncodingError> {
        let (width, height) = (self.width, self.height);
        let quantised: Vec<Quantised> = frames
            .par_iter()
            .map(|f| quantise(f, width as usize))
            .collect();
        for q in quantised {
            let palette: Vec<u8> = q.palette.iter().flatten().copied().collect();
            let mut frame =
                ::gif::Frame::from_palette_pixels(width, height, q.indices, palette, None);
            frame.delay = self.delay;
            self.encoder.write_frame(&frame)?;
            self.psnrs.push(q.psnr);
        }
        Ok(())
    }

    /// Write the trailer. Returns the writer and the mean PSNR of the quantised frames.
    pub(crate) fn finish(self) -> Result<(W, f64), ::gif::EncodingError> {
        let w = self.encoder.into_inner()?;
        Ok((w, mean_psnr(&self.psnrs)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_matches_brute_force() {
        let palette: Vec<[u8; 3]> = (0..256u32)
            .map(|i| {
                let h = i.wrapping_mul(2_654_435_761);
                [(h >> 8) as u8, (h >> 16) as u8, (h >> 24) as u8]
            })
            .collect();
        let mut nearest = Nearest::new(&palette);
        for i in 0..20_000u32 {
            let h = i.wrapping_mul(0x9E37_79B9) ^ (i << 7);
            let c = [h as u8, (h >> 8) as u8, (h >> 16) as u8];
            let got = nearest.find(c);
            let best = palette.iter().map(|&p| dist2(p, c)).min().unwrap();
            assert_eq!(dist2(palette[got as usize], c), best);
        }
    }

    #[test]
    fn delay_and_mean() {
        assert_eq!(frame_delay(25.0), 4);
        assert_eq!(frame_delay(100.0), 2);
        assert_eq!(frame_delay(1000.0), 2);
        assert_eq!(frame_delay(0.0), u16::MAX);
        assert_eq!(frame_delay(f64::NAN), 2);
        assert_eq!(mean_psnr(&[30.0, f64::INFINITY, 40.0]), 35.0);
        assert_eq!(mean_psnr(&[f64::INFINITY]), f64::INFINITY);
    }
}
