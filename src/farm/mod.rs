//! Long renders as a render farm runs them: the work split into units (frames, or sample ranges
//! of frames), kept in film files as it finishes so that a render resumes where it stopped,
//! split into shards for several machines, and merged into exactly the image one machine makes.
//!
//! - [`plan`]: which units a render (or the K-th of N shards of it) takes.
//! - [`films`]: a directory of film files, the [`Store`](crate::render::driver::Store) a render
//!   keeps its work in, with a fingerprint of the scene and settings in every file.
//! - [`assemble`]: films into final frames: sample ranges summed, denoised across frames, and
//!   encoded, one frame at a time.
//! - [`job`]: all of it in one call: a long render planned, resumed, rendered with
//!   checkpoints until done or cancelled, and finished; shards merged.

pub mod assemble;
pub mod films;
pub mod job;
pub mod memory;
pub mod plan;
pub mod refusal;

use crate::denoise::Scales;
use crate::render::driver::Options;
use crate::render::integrator::Stats;
use crate::scene::{Denoise, Quality, Scene};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// Bump when the meaning of a film file changes.
const FORMAT: u32 = 1;

/// What a film file holds, stored as JSON in its header.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilmMeta {
    /// The film format version; a film of another version is refused, not misread.
    pub format: u32,
    /// A digest of everything that decides the film's pixels (see [`Fingerprint`]).
    pub fingerprint: String,
    /// The text the fingerprint digests, to say what differs when two films disagree.
    pub description: String,
    /// The scene file's name, for messages.
    pub scene: String,
    /// The frame this film belongs to (0-based).
    pub frame: u32,
    /// Frames of the whole animation.
    pub frames: u32,
    /// The sample range this film accumulates, `[start, end)`.
    pub samples: [u32; 2],
    /// Samples per pixel of the whole render.
    pub spp: u32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Every pass ran: the film is final.
    pub complete: bool,
    /// The work counts of the samples in this film (summed when films are merged).
    pub stats: Stats,
    /// The part of the render this film belongs to (what `merge` checks is all there).
    pub part: plan::Part,
    /// How the frames are finished: these do not change the films, so they are not in the
    /// fingerprint, and `merge` may override them. The denoiser is stored by name; a name this
    /// hyperslice does not know makes the header unreadable.
    pub denoise: Denoise,
    /// Exposure multiplier the frames are finished with.
    pub exposure: f64,
    /// Frames per second of an animated GIF.
    pub fps: f64,
    /// The denoiser's scales of this film's pixels (`Scales::of`), where the film is a whole
    /// frame's finished samples and its denoiser needs them: finishing then takes the
    /// animation's scales from the headers instead of reading every film once more (a fifth
    /// of finishing 41 frames at 512 x 384). Absent in older films and sample shards.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scales: Option<Scales>,
}

/// What decides a render's pixels: the scene (shapes, materials, camera, and the render
/// settings that change samples), the options that change the estimator, and whether the
/// render is progressive (which groups samples into other passes); not the denoiser, exposure,
/// frame rate, threads or the budget's length, which only finish or pace the samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Fingerprint {
    /// The SHA-256 of `description`, in hex: what every film header stores and is compared by.
    pub digest: String,
    /// The text digested: hyperslice's version, the film format, the estimator's options and the
    /// scene as printed, with the settings that only finish frames set to their defaults.
    pub description: String,
}

impl Fingerprint {
    /// The fingerprint of rendering `scene` with `options`.
    pub fn of(scene: &Scene, options: &Options) -> Fingerprint {
        let mut s = scene.clone();
        let r = &mut s.render;
        let defaults = crate::scene::RenderSettings::default();
        (r.denoise, r.quality, r.fps, r.exposure, r.threads) = (
            Denoise::None,
            Quality::Custom,
            defaults.fps,
            defaults.exposure,
            0,
        );
        let description = format!(
            "hyperslice {} film format {FORMAT}\n\
             options light_sampling {}  sampler {:?}  roulette_from {}  general {}  noise_threshold {:?}  progressive {}  marcher {}\n\
             {s}",
            env!("CARGO_PKG_VERSION"),
            options.light_sampling,
            options.sampler,
            options.roulette_from,
            options.general,
            options.noise_threshold,
            // A time budget changes how samples are grouped into passes (and how many are
            // taken), so films of a budgeted render are not those of a fixed-spp one.
            options.time_budget.is_some() || options.noise_threshold.is_some(),
            // Always named: the default changed from cells to auto, so films of the old
            // default must not pass for films of the new one.
            options.marcher.name(),
        );
        let digest = Sha256::digest(description.as_bytes());
        Fingerprint {
            digest: digest.iter().map(|b| format!("{b:02x}")).collect(),
            description,
        }
    }

    /// The first line where `other`'s description differs from this one's, for messages.
    pub fn difference(&self, other: &str) -> Option<(String, String)> {
        let (mut a, mut b) = (self.description.lines(), other.lines());
        loop {
            match (a.next(), b.next()) {
                (None, None) => return None,
                (x, y) if x != y => {
                    let show = |l: Option<&str>| l.unwrap_or("(nothing)").trim().to_string();
                    return Some((show(x), show(y)));
                }
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_name_the_denoiser_as_scenes_do() {
        for d in Denoise::ALL {
            let json = serde_json::to_string(&d).unwrap();
            assert_eq!(json, format!("\"{}\"", d.name()));
            assert_eq!(serde_json::from_str::<Denoise>(&json).unwrap(), d);
        }
        assert!(serde_json::from_str::<Denoise>("\"blur\"").is_err());
    }
}
