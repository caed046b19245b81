//! Speed against accuracy (`hyperslice bench`, see `docs/performance.md`, "Speed against
//! accuracy: `hyperslice bench`"): a reference render, then a sweep of configurations, each
//! rendered, timed, and compared with the reference (RMSE, PSNR, SSIM, mean luminance bias).
//!
//! The families swept: samples per pixel with light sampling on and no denoiser (the baseline
//! curve, with the default Sobol sampler); the same without light sampling; the same with
//! independent random numbers; the median and a-trous denoisers on top of the baseline; marching
//! epsilon, marching step limit and bounce depth at a middle sample count; the quality presets.
//! Every configuration renders with the scene's seed and the reference
//! with a different one (`seed + REFERENCE_SEED_OFFSET`), so the reference's noise is
//! independent of every configuration's. Only the denoiser families denoise, whatever the
//! scene's `denoise` says. Renders are deterministic, so repeating one changes only its time:
//! each configuration is rendered `repeats` times and its time is the median.
//!
//! [`pareto_front`] marks the configurations no other beats on both time and error, and
//! [`time_to_error`] reads off a curve how long it takes to reach an error. The results become
//! CSV, Markdown ([`report`]) and a PNG plot ([`plot`]).
//!
//! Data flows one way through the modules: `config` (what to measure) -> `reference` (what to
//! compare with) -> `measure` (one configuration) -> `analysis` (what the rows say) -> `run`
//! (the whole sweep) -> [`report`] and [`plot`]. [`costs`] and [`corpus`] are measurements of
//! their own that share the helpers.

mod analysis;
mod config;
pub mod corpus;
pub mod costs;
mod error;
mod measure;
pub mod plot;
mod reference;
pub mod report;
mod run;

pub use analysis::{
    Metric, Reach, Speedups, curve, mark_pareto, pareto_front, speedups, time_to_error,
};
pub use config::{Config, Family, SweepOptions, middle_spp, plan};
pub use error::SweepError;
pub use measure::{Row, measure, median};
pub use reference::{
    REFERENCE_FACTOR, REFERENCE_NOISE_RATIO, REFERENCE_SEED_OFFSET, Reference, load_reference,
    reference_settings, reference_spp, render_reference,
};
pub use report::sig;
pub use run::{Bench, Progress, bench};
