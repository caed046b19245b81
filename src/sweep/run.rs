//! The whole sweep: the reference, then every configuration of the plan, with progress.

use super::{
    Config, Metric, REFERENCE_NOISE_RATIO, Reference, Row, Speedups, SweepError, SweepOptions,
    load_reference, mark_pareto, measure, plan, reference_settings, reference_spp,
    render_reference, speedups,
};
use crate::error::Result;
use crate::scene::{RenderSettings, Scene};
use std::path::Path;

/// What a sweep is doing, for progress lines.
#[derive(Debug)]
pub enum Progress<'a> {
    /// The reference render starts.
    Reference { spp: u32 },
    /// The reference is ready (rendered or loaded).
    ReferenceDone { reference: &'a Reference },
    /// Configuration `index` (from 1) of `total` starts.
    Start {
        index: usize,
        total: usize,
        config: &'a Config,
    },
    /// Configuration `index` of `total` is measured.
    Done {
        index: usize,
        total: usize,
        row: &'a Row,
    },
}

/// A finished sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Bench {
    /// The scene's settings as swept (size and frames overridden).
    pub settings: RenderSettings,
    pub threads: Option<usize>,
    /// Renders of each configuration (its time is their median).
    pub repeats: u32,
    pub reference: Reference,
    /// Every configuration measured, in plan order, with the Pareto front marked.
    pub rows: Vec<Row>,
}

impl Bench {
    /// The reference's own error over the smallest RMSE measured (it should be below
    /// `REFERENCE_NOISE_RATIO`); `None` when the reference's error is unknown.
    pub fn reference_ratio(&self) -> Option<f64> {
        let noise = self.reference.noise?;
        let best = self
            .rows
            .iter()
            .map(|r| r.error.rmse)
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        best.is_finite().then(|| noise / best)
    }

    /// Samples per pixel a rendered reference would need to bring its error ratio down to
    /// `REFERENCE_NOISE_RATIO` (noise falls as one over the square root of samples).
    pub fn reference_spp_needed(&self) -> Option<u32> {
        let ratio = self.reference_ratio()?;
        let spp = self.reference.spp? as f64;
        let need = spp * (ratio / REFERENCE_NOISE_RATIO).powi(2);
        Some(need.ceil().min(u32::MAX as f64) as u32)
    }

    /// How much faster the error of plain path tracing at its most samples is reached with
    /// light sampling and with each denoiser.
    pub fn speedups(&self, metric: Metric) -> Option<Speedups> {
        speedups(&self.rows, metric)
    }
}

/// Run the whole sweep: the reference (rendered, or loaded from `reference_file`), then every
/// configuration of [`plan`]; `progress` hears of each step.
pub fn bench(
    scene: &Scene,
    opts: &SweepOptions,
    reference_file: Option<&Path>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Bench> {
    let mut scene = scene.clone();
    scene.render = opts.settings(&scene.render);
    let configs = plan(&scene.render, opts);
    if configs.is_empty() {
        return Err(SweepError::NothingToMeasure.into());
    }
    let reference = match reference_file {
        Some(path) => load_reference(path, &scene.render)?,
        None => {
            let spp = reference_spp(&configs, opts.reference_spp);
            progress(Progress::Reference { spp });
            let mut accurate = scene.clone();
            accurate.render = reference_settings(&configs, &scene.render);
            render_reference(&accurate, spp, opts.threads)?
        }
    };
    progress(Progress::ReferenceDone {
        reference: &reference,
    });
    let total = configs.len();
    let mut rows = Vec::with_capacity(total);
    for (i, config) in configs.iter().enumerate() {
        progress(Progress::Start {
            index: i + 1,
            total,
            config,
        });
        let row = measure(&scene, config, &reference, opts.threads, opts.repeats)?;
        progress(Progress::Done {
            index: i + 1,
            total,
            row: &row,
        });
        rows.push(row);
    }
    mark_pareto(&mut rows);
    Ok(Bench {
        settings: scene.render,
        threads: opts.threads,
        repeats: opts.repeats.max(1),
        reference,
        rows,
    })
}
