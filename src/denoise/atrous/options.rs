//! The a-trous filter's settings, and what they mean for each pass (read alike by the filter
//! and by its reference).

use std::ops::Range;

/// Passes beyond this are ignored (their hole spacing would exceed any image).
const MAX_PASSES: u32 = 24;

/// Which passes also take taps from the neighbouring frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Temporal {
    /// Spatial only: every frame is filtered on its own.
    Off,
    /// Neighbouring frames on the first pass only (temporal support +-1 frame): as good as
    /// every pass in the scenes measured, holding the fewest frames (see the module notes).
    #[default]
    FirstPass,
    /// Neighbouring frames on every pass (temporal support grows by one frame per pass).
    AllPasses,
}

/// Settings of the a-trous filter. Every sigma may be `f64::INFINITY` to switch its guide off.
#[derive(Clone, Debug, PartialEq)]
pub struct AtrousOptions {
    /// Number of passes; pass `i` has hole spacing `2^i` (5 passes: 1 .. 16, a 61x61 support).
    pub passes: u32,
    /// Colour sigma on the first pass, in standard errors of the two pixels' difference;
    /// multiplied by `sigma_color_decay` every pass.
    pub sigma_color: f64,
    /// Factor of the colour sigma from one pass to the next (the paper's 1/2).
    pub sigma_color_decay: f64,
    /// Sigma of the 4D normal difference.
    pub sigma_normal: f64,
    /// Sigma of the 4D position difference, in pixel footprints at the tap's offset.
    pub sigma_position: f64,
    /// Sigma of the albedo difference.
    pub sigma_albedo: f64,
    /// Which passes reach into the neighbouring frames.
    pub temporal: Temporal,
    /// Update in flux form, which keeps the image's sum (see the module notes).
    pub conserve: bool,
}

impl Default for AtrousOptions {
    fn default() -> AtrousOptions {
        AtrousOptions {
            passes: 5,
            sigma_color: 4.0,
            sigma_color_decay: 0.5,
            sigma_normal: 0.3,
            sigma_position: 2.0,
            sigma_albedo: 0.25,
            temporal: Temporal::default(),
            conserve: true,
        }
    }
}

impl Temporal {
    /// Whether pass `pass` takes taps from the neighbouring frames.
    pub(super) fn reaches(self, pass: u32) -> bool {
        match self {
            Temporal::Off => false,
            Temporal::FirstPass => pass == 0,
            Temporal::AllPasses => true,
        }
    }
}

impl AtrousOptions {
    /// The passes that run.
    pub(super) fn pass_range(&self) -> Range<u32> {
        0..self.passes.min(MAX_PASSES)
    }

    /// The colour sigma of pass `pass`.
    pub(super) fn sigma_color_at(&self, pass: u32) -> f64 {
        self.sigma_color * self.sigma_color_decay.powi(pass as i32)
    }
}
