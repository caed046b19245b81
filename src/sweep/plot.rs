//! The sweep as a picture: two panels, RMSE of linear radiance and RMSE of the displayed image
//! against wall time, all on log scales; one colour and line per curve family, markers for the
//! single-setting families, and each panel's Pareto front as a dashed line. Text needs a font
//! from the system; without one the plot is drawn without text.

use super::{Family, Metric, Row, SweepError, pareto_front, sig};
use crate::output::write_atomic;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::path::Path;
use std::sync::OnceLock;

/// Plot size in pixels.
pub const WIDTH: u32 = 1800;
pub const HEIGHT: u32 = 700;

/// The font family the plot's text uses (registered by [`font`]).
const FONT: &str = "sans-serif";

/// Where a sans-serif TrueType font is looked for, first found first.
pub const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/noto/NotoSans-Regular.ttf",
    "/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    r"C:\Windows\Fonts\arial.ttf",
];

/// Register the first font of [`FONT_PATHS`] that exists and parses (once per process).
pub fn font() -> Result<(), SweepError> {
    static FOUND: OnceLock<bool> = OnceLock::new();
    let found = *FOUND.get_or_init(|| {
        FONT_PATHS.iter().any(|path| {
            let Ok(bytes) = std::fs::read(path) else {
                return false;
            };
            // plotters keeps fonts for the life of the process.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            register_font(FONT, FontStyle::Normal, bytes).is_ok()
        })
    });
    if found {
        Ok(())
    } else {
        Err(SweepError::NoFont {
            looked_for: FONT_PATHS,
        })
    }
}

/// How the plot came out.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotOutcome {
    /// Whether it has its title, axis labels and legend.
    pub labels: bool,
    /// Why it has none, when it has none.
    pub note: Option<String>,
}

fn colour(family: Family) -> RGBColor {
    match family {
        Family::Baseline => RGBColor(31, 119, 180),
        Family::NoLightSampling => RGBColor(214, 39, 40),
        Family::Random => RGBColor(188, 189, 34),
        Family::Median => RGBColor(44, 160, 44),
        Family::Atrous => RGBColor(255, 127, 14),
        Family::Epsilon => RGBColor(148, 103, 189),
        Family::MaxSteps => RGBColor(140, 86, 75),
        Family::Bounces => RGBColor(227, 119, 194),
        Family::Preset => RGBColor(23, 190, 207),
    }
}

/// A log-scale axis range around `values` (positive, finite), out to whole decades (plotters
/// labels a log axis only from its first power of ten on).
fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return 0.1..10.0;
    }
    // Just past the powers of ten, or rounding makes plotters skip the first one.
    let lo = 10f64.powf(lo.log10().floor()) * 0.999;
    let hi = 10f64.powf(hi.log10().ceil()) * 1.001;
    lo..hi
}

/// [`SweepError::Plot`] from what plotters reports.
fn err(e: impl std::error::Error + Send + Sync + 'static) -> SweepError {
    SweepError::Plot(Box::new(e))
}

/// The plot as RGB8 pixels, `width * height * 3` bytes: the linear-RMSE panel on the left, the
/// display-RMSE panel on the right. `title` `None` draws no text at all (no title, tick
/// labels, axis names or legend); each panel's caption is `title: <metric> against time`.
pub fn draw(
    rows: &[Row],
    width: u32,
    height: u32,
    title: Option<&str>,
) -> Result<Vec<u8>, SweepError> {
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (left, right) = root.split_horizontally(width / 2);
        for (area, metric) in [(left, Metric::Rmse), (right, Metric::DisplayRmse)] {
            let caption = title.map(|t| format!("{t}: {} against time", metric.name()));
            panel(&area, rows, caption.as_deref(), metric)?;
        }
        root.present().map_err(err)?;
    }
    Ok(buf)
}

/// One panel: `metric` against wall time.
fn panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    rows: &[Row],
    title: Option<&str>,
    metric: Metric,
) -> Result<(), SweepError> {
    let y = |r: &Row| metric.of(&r.error);
    let valid = |r: &&Row| r.time.is_finite() && r.time > 0.0 && y(r).is_finite() && y(r) > 0.0;
    let shown: Vec<&Row> = rows.iter().filter(valid).collect();
    let xs = range(shown.iter().map(|r| r.time));
    let ys = range(shown.iter().map(|r| y(r)));
    let mut builder = ChartBuilder::on(area);
    builder.margin(20);
    if let Some(t) = title {
        builder
            .caption(t, (FONT, 24))
            .x_label_area_size(55)
            .y_label_area_size(85);
    } else {
        builder.x_label_area_size(5).y_label_area_size(5);
    }
    let mut chart = builder
        .build_cartesian_2d(xs.clone().log_scale(), ys.clone().log_scale())
        .map_err(err)?;
    // Tick labels at 1, 2 and 5 times powers of ten only (the other ticks stay unlabelled).
    let label = |v: &f64| {
        let lead = *v / 10f64.powf(v.log10().floor());
        if [1.0, 2.0, 5.0, 10.0]
            .iter()
            .any(|m| (lead - m).abs() < 1e-6)
        {
            sig(*v, 1)
        } else {
            String::new()
        }
    };
    let mut mesh = chart.configure_mesh();
    if title.is_some() {
        mesh.x_desc("wall time (s)")
            .y_desc(format!("{} against the reference", metric.name()))
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .x_labels(40)
            .y_labels(40)
            .max_light_lines(0)
            .bold_line_style(BLACK.mix(0.15))
            .x_label_formatter(&label)
            .y_label_formatter(&label);
    } else {
        mesh.disable_axes();
    }
    mesh.draw().map_err(err)?;
    if title.is_none() {
        // The axes, without their tick labels.
        let frame = [(xs.start, ys.start), (xs.end, ys.end)];
        chart
            .draw_series(std::iter::once(Rectangle::new(
                frame,
                BLACK.stroke_width(1),
            )))
            .map_err(err)?;
    }

    for family in Family::ALL {
        let mut members: Vec<&Row> = shown
            .iter()
            .copied()
            .filter(|r| r.config.family == family)
            .collect();
        if members.is_empty() {
            continue;
        }
        members.sort_by(|a, b| {
            (a.config.spp, a.time)
                .partial_cmp(&(b.config.spp, b.time))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let pts: Vec<(f64, f64)> = members.iter().map(|r| (r.time, y(r))).collect();
        let c = colour(family);
        let name = family.name();
        if family.is_curve() {
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
                .map_err(err)?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
                .map_err(err)?;
        } else {
            // Each family its own marker, in the plot and in the legend.
            match family {
                Family::Epsilon => chart
                    .draw_series(pts.iter().map(|&p| TriangleMarker::new(p, 7, c.filled())))
                    .map_err(err)?
                    .label(name)
                    .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 7, c.filled())),
                Family::MaxSteps => chart
                    .draw_series(pts.iter().map(|&p| Cross::new(p, 6, c.stroke_width(2))))
                    .map_err(err)?
                    .label(name)
                    .legend(move |(x, y)| Cross::new((x + 10, y), 6, c.stroke_width(2))),
                Family::Bounces => chart
                    .draw_series(pts.iter().map(|&p| {
                        EmptyElement::at(p) + Rectangle::new([(-5, -5), (5, 5)], c.filled())
                    }))
                    .map_err(err)?
                    .label(name)
                    .legend(move |(x, y)| {
                        Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], c.filled())
                    }),
                _ => chart
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 7, c.filled())))
                    .map_err(err)?
                    .label(name)
                    .legend(move |(x, y)| Circle::new((x + 10, y), 7, c.filled())),
            };
        }
    }

    let points: Vec<(f64, f64)> = shown.iter().map(|r| (r.time, y(r))).collect();
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .zip(pareto_front(&points))
        .filter(|(_, on)| *on)
        .map(|(p, _)| *p)
        .collect();
    front.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    if !front.is_empty() {
        chart
            .draw_series(DashedLineSeries::new(front, 8, 5, BLACK.stroke_width(2)))
            .map_err(err)?
            .label("Pareto front")
            .legend(|(x, y)| {
                DashedPathElement::new(vec![(x, y), (x + 20, y)], 6, 3, BLACK.stroke_width(2))
            });
    }

    if title.is_some() {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 15))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

/// Encode RGB8 pixels as PNG.
fn encode_png(pixels: &[u8], width: u32, height: u32) -> Result<Vec<u8>, SweepError> {
    let mut out = vec![];
    crate::output::png::encode(&mut out, pixels.as_chunks().0, width, height)
        .map_err(SweepError::PlotEncoding)?;
    Ok(out)
}

/// Draw the plot and write it to `path` as PNG (atomically). Without a font, or when drawing
/// text fails, the plot is drawn without text and the outcome says why.
pub fn write_png(rows: &[Row], path: &Path, title: &str) -> crate::Result<PlotOutcome> {
    let (pixels, note) = match font().and_then(|()| draw(rows, WIDTH, HEIGHT, Some(title))) {
        Ok(p) => (p, None),
        Err(why) => (
            draw(rows, WIDTH, HEIGHT, None)?,
            Some(format!(
                "the plot has no title, axis labels or legend: {why}"
            )),
        ),
    };
    write_atomic(path, &encode_png(&pixels, WIDTH, HEIGHT)?)?;
    Ok(PlotOutcome {
        labels: note.is_none(),
        note,
    })
}
