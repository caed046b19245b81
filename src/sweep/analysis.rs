//! What measured rows say: the Pareto front of time against error, when a curve reaches an
//! error, and how much faster light sampling and the denoisers reach it.

use super::{Family, Row};
use crate::metrics::ImageError;

/// Set every row's `pareto` flag from its (time, RMSE).
pub fn mark_pareto(rows: &mut [Row]) {
    let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.time, r.error.rmse)).collect();
    for (row, on) in rows.iter_mut().zip(pareto_front(&points)) {
        row.pareto = on;
    }
}

/// Which of the (cost, error) points are on the Pareto front: no other point is at most as
/// costly and at most as wrong while strictly better in one of the two. Points that tie
/// exactly are all on the front (neither beats the other); points with a NaN coordinate are
/// never on it and beat nothing.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let valid = |p: &(f64, f64)| !p.0.is_nan() && !p.1.is_nan();
    points
        .iter()
        .map(|p| {
            valid(p)
                && !points
                    .iter()
                    .any(|q| valid(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect()
}

/// When a curve reaches an error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// At this time, interpolated between two of the curve's points.
    At(f64),
    /// The curve's first point is already there: at this time or sooner.
    AtMost(f64),
    /// None of the curve's points gets there.
    NotReached,
}

impl Reach {
    /// The time, when reached.
    pub fn time(self) -> Option<f64> {
        match self {
            Reach::At(t) | Reach::AtMost(t) => Some(t),
            Reach::NotReached => None,
        }
    }
}

/// When the curve of (time, error) points, in order of increasing effort, first reaches
/// `target` error: log time is interpolated linearly against log error between the last point
/// above the target and the first at or below it (exact on a power law `time = c error^k`).
/// Points with a non-positive or non-finite coordinate are ignored.
pub fn time_to_error(curve: &[(f64, f64)], target: f64) -> Reach {
    let pts: Vec<(f64, f64)> = curve
        .iter()
        .copied()
        .filter(|&(t, e)| t.is_finite() && e.is_finite() && t > 0.0 && e > 0.0)
        .collect();
    let Some(&(t0, e0)) = pts.first() else {
        return Reach::NotReached;
    };
    if e0 <= target {
        return Reach::AtMost(t0);
    }
    for w in pts.windows(2) {
        let ((ta, ea), (tb, eb)) = (w[0], w[1]);
        if ea > target && eb <= target {
            let f = (target.ln() - ea.ln()) / (eb.ln() - ea.ln());
            return Reach::At((ta.ln() + f * (tb.ln() - ta.ln())).exp());
        }
    }
    Reach::NotReached
}

/// How much faster than plain path tracing a target error is reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Speedups {
    /// The error compared.
    pub metric: Metric,
    /// The error of plain path tracing (no light sampling, no denoiser) at its most samples.
    pub target: f64,
    /// Samples per pixel and seconds plain path tracing took to get there.
    pub spp: u32,
    pub time: f64,
    /// For the baseline (light sampling), random-sampler, median and atrous curves: when each
    /// reaches the target.
    pub curves: Vec<(Family, Reach)>,
}

impl Speedups {
    /// Plain path tracing's time over a curve's (at least this when the curve reached the
    /// target at its first point already).
    pub fn factor(&self, reach: Reach) -> Option<f64> {
        reach.time().map(|t| self.time / t)
    }
}

/// Which error the speed-ups compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// RMSE of linear radiance: every firefly counts at full strength.
    Rmse,
    /// RMSE of the displayed image, `10^(-PSNR / 20)`: what a viewer sees, after the tone
    /// curve has compressed the highlights.
    DisplayRmse,
}

impl Metric {
    pub fn of(self, e: &ImageError) -> f64 {
        match self {
            Metric::Rmse => e.rmse,
            Metric::DisplayRmse => 10f64.powf(-e.psnr / 20.0),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Metric::Rmse => "RMSE",
            Metric::DisplayRmse => "display RMSE",
        }
    }
}

/// The (time, error) points of one family's curve, in order of samples per pixel.
pub fn curve(rows: &[Row], family: Family, metric: Metric) -> Vec<(f64, f64)> {
    let mut v: Vec<&Row> = rows.iter().filter(|r| r.config.family == family).collect();
    v.sort_by_key(|r| r.config.spp);
    v.iter().map(|r| (r.time, metric.of(&r.error))).collect()
}

/// See [`Speedups`]; `None` without rows of plain path tracing.
pub fn speedups(rows: &[Row], metric: Metric) -> Option<Speedups> {
    let plain = rows
        .iter()
        .filter(|r| r.config.family == Family::NoLightSampling)
        .max_by_key(|r| r.config.spp)?;
    let target = metric.of(&plain.error);
    let curves = [
        Family::Baseline,
        Family::Random,
        Family::Median,
        Family::Atrous,
    ]
    .into_iter()
    .filter(|f| rows.iter().any(|r| r.config.family == *f))
    .map(|f| (f, time_to_error(&curve(rows, f, metric), target)))
    .collect();
    Some(Speedups {
        metric,
        target,
        spp: plain.config.spp,
        time: plain.time,
        curves,
    })
}
