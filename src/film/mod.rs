//! The film of one frame: the mean radiance of every pixel, its spread, and the first-hit
//! buffers that guide denoising (albedo, 4D normal, 4D position, depth).
//!
//! A module of its own, not part of `render`: the renderer fills films and `denoise` filters
//! them, and neither needs the other.

pub mod file;

use crate::image::HdrImage;
use glam::{DVec3, DVec4};

/// The sums one pixel accumulates over its samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    /// Sum of the samples' radiance (linear RGB).
    pub radiance: DVec3,
    /// Sum of squared radiance, for the per-pixel standard error.
    pub radiance_sq: DVec3,
    /// Sum of the albedo of the first surface each sample hit (zero where it saw the sky).
    pub albedo: DVec3,
    /// Sum of the 4D unit normals at the first hits.
    pub normal: DVec4,
    /// Sum of the 4D world positions of the first hits.
    pub position: DVec4,
    /// Sum of the distances along the camera ray to the first hits.
    pub depth: f64,
    /// Samples accumulated: the divisor that turns the sums into means.
    pub samples: u32,
}

impl PixelSums {
    /// Count one more sample with radiance `l`; the first-hit sums are added by the integrator
    /// itself.
    pub fn add_radiance(&mut self, l: DVec3) {
        self.radiance += l;
        self.radiance_sq += l * l;
        self.samples += 1;
    }

    /// Add the sums of other samples of the same pixel (another sample range).
    pub fn merge(&mut self, o: &PixelSums) {
        self.radiance += o.radiance;
        self.radiance_sq += o.radiance_sq;
        self.albedo += o.albedo;
        self.normal += o.normal;
        self.position += o.position;
        self.depth += o.depth;
        self.samples += o.samples;
    }
}

/// One rendered frame, every buffer holding per-pixel means, row-major from the top left.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Mean radiance per pixel, linear RGB (1.0 is a white sky seen directly), before exposure and
    /// tone mapping.
    pub color: Vec<DVec3>,
    /// Standard error of each pixel's mean radiance.
    pub std_error: Vec<DVec3>,
    /// Mean first-hit albedo, a denoising guide.
    pub albedo: Vec<DVec3>,
    /// Mean first-hit 4D normal (not renormalised), a denoising guide.
    pub normal: Vec<DVec4>,
    /// Mean first-hit 4D world position, a denoising guide.
    pub position: Vec<DVec4>,
    /// Mean distance to the first hit, in world units.
    pub depth: Vec<f64>,
    /// Samples each pixel took (they differ under adaptive sampling).
    pub samples: Vec<u32>,
}

impl Film {
    /// A black film of `width` x `height` pixels with every buffer zero.
    pub fn new(width: usize, height: usize) -> Film {
        let n = width * height;
        Film {
            width,
            height,
            color: vec![DVec3::ZERO; n],
            std_error: vec![DVec3::ZERO; n],
            albedo: vec![DVec3::ZERO; n],
            normal: vec![DVec4::ZERO; n],
            position: vec![DVec4::ZERO; n],
            depth: vec![0.0; n],
            samples: vec![0; n],
        }
    }

    /// A film of the means of a whole frame's sums (row-major).
    pub fn from_sums(width: usize, height: usize, sums: &[PixelSums]) -> Film {
        let mut film = Film::new(width, height);
        for (i, s) in sums.iter().enumerate() {
            film.set(i, s);
        }
        film
    }

    /// Store a pixel's means from its sums.
    pub fn set(&mut self, i: usize, s: &PixelSums) {
        let n = s.samples.max(1) as f64;
        let mean = s.radiance / n;
        self.color[i] = mean;
        let var = (s.radiance_sq / n - mean * mean).max(DVec3::ZERO);
        self.std_error[i] = if s.samples > 1 {
            (var / (n - 1.0)).map(f64::sqrt)
        } else {
            DVec3::ZERO
        };
        self.albedo[i] = s.albedo / n;
        self.normal[i] = s.normal / n;
        self.position[i] = s.position / n;
        self.depth[i] = s.depth / n;
        self.samples[i] = s.samples;
    }

    /// The radiance as a linear-HDR image for output.
    pub fn image(&self) -> HdrImage {
        HdrImage {
            width: self.width,
            height: self.height,
            data: self.color.iter().map(|c| c.as_vec3().to_array()).collect(),
        }
    }

    /// Mean radiance over all pixels.
    pub fn mean(&self) -> DVec3 {
        self.color.iter().sum::<DVec3>() / self.color.len().max(1) as f64
    }
}
