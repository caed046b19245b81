//! A sweep's results as CSV and Markdown, and writing them (with the plot) into a directory,
//! every file atomically (a temporary file beside it, renamed into place once complete).

use super::{Bench, Family, Metric, Reach, Row, SweepError};
use crate::error::{Error, Result};
use crate::output::write_atomic;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What the Markdown report says about how the numbers were made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Context {
    /// The scene's name.
    pub scene: String,
    /// The command line that made the numbers.
    pub command: String,
    /// The machine (see [`machine`]).
    pub machine: String,
}

/// The CPU model, cores and system, as well as this process can tell.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{cpu}, {cores} core{} available, {}-{}",
        if cores == 1 { "" } else { "s" },
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

/// A CSV field, quoted when it must be.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The CSV header.
pub const CSV_HEADER: &str = "family,configuration,spp,bounces,epsilon,max_steps,light_sampling,sampler,denoise,time_s,rmse,psnr_db,ssim,bias_pct,pareto,out_of_steps,dropped";

/// Every row as CSV, full precision, with a header line.
pub fn csv(rows: &[Row]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let c = &r.config;
        let e = &r.error;
        let _ = writeln!(
            out,
            "{},{},{},{},{:e},{},{},{},{},{},{},{},{},{},{},{},{}",
            field(c.family.name()),
            field(&c.label),
            c.spp,
            c.bounces,
            c.epsilon,
            c.max_steps,
            c.light_sampling,
            c.sampler.name(),
            c.denoise.name(),
            r.time,
            e.rmse,
            e.psnr,
            e.ssim,
            e.bias * 100.0,
            r.pareto,
            r.out_of_steps,
            r.dropped
        );
    }
    out
}

/// The Markdown table: configuration, spp, time, RMSE, PSNR, SSIM, bias, and `*` on the
/// Pareto front of (time, RMSE).
pub fn markdown_table(rows: &[Row]) -> String {
    let mut out = String::from(
        "| configuration | spp | time (s) | RMSE | PSNR (dB) | SSIM | bias (%) | Pareto |\n\
         |---|--:|--:|--:|--:|--:|--:|:-:|\n",
    );
    for r in rows {
        let e = &r.error;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {:.2} | {:.4} | {:+.2} | {} |",
            r.config.label,
            r.config.spp,
            sig(r.time, 3),
            sig(e.rmse, 4),
            e.psnr,
            e.ssim,
            e.bias * 100.0,
            if r.pareto { "*" } else { "" }
        );
    }
    out
}

/// The speed-ups against plain path tracing in `metric`, as Markdown (empty without plain
/// path tracing).
pub fn speedup_markdown(bench: &Bench, metric: Metric) -> String {
    let Some(s) = bench.speedups(metric) else {
        return String::new();
    };
    let mut out = format!(
        "Time to reach the {m} of plain path tracing (no light sampling, no denoiser) at {} spp, {}, which took {} s there\n\
         (log time interpolated against log {m} along each curve):\n\n",
        s.spp,
        sig(s.target, 4),
        sig(s.time, 3),
        m = metric.name()
    );
    for &(family, reach) in &s.curves {
        let name = match family {
            Family::Baseline => "light sampling (baseline)",
            Family::Random => "light sampling, random sampler",
            Family::Median => "light sampling + median denoiser",
            Family::Atrous => "light sampling + atrous denoiser",
            other => other.name(),
        };
        let text = match (reach, s.factor(reach)) {
            (Reach::At(t), Some(f)) => format!("{} s, speed-up {}x", sig(t, 3), sig(f, 3)),
            (Reach::AtMost(t), Some(f)) => format!(
                "at most {} s (already there at its fewest samples), speed-up at least {}x",
                sig(t, 3),
                sig(f, 3)
            ),
            _ => "not reached".to_string(),
        };
        let _ = writeln!(out, "- {name}: {text}");
    }
    out
}

/// The reference in words: where it came from, and its own error against the errors measured.
pub fn reference_summary(bench: &Bench) -> String {
    let r = &bench.reference;
    let mut out = format!("reference: {}", r.source);
    if let Some(t) = r.time {
        let _ = write!(out, ", {} s", sig(t, 3));
    }
    match (r.noise, bench.reference_ratio()) {
        (Some(noise), Some(ratio)) => {
            let _ = write!(
                out,
                "; its own error (RMS of its pixels' standard errors) {} = {} of the smallest RMSE measured",
                sig(noise, 3),
                sig(ratio, 2)
            );
        }
        (Some(noise), None) => {
            let _ = write!(out, "; its own error {}", sig(noise, 3));
        }
        _ => out.push_str("; its own error is unknown (an EXR holds no standard errors)"),
    }
    out
}

/// A warning when the reference's own error is not below a tenth of the smallest error
/// measured (the errors measured then partly measure the reference).
pub fn reference_warning(bench: &Bench) -> Option<String> {
    let ratio = bench.reference_ratio()?;
    if ratio < super::REFERENCE_NOISE_RATIO {
        return None;
    }
    let mut msg = format!(
        "the reference's own error is {} of the smallest RMSE measured (it should be below {}); \
         the smallest errors are partly the reference's noise",
        sig(ratio, 2),
        super::REFERENCE_NOISE_RATIO
    );
    if let Some(spp) = bench.reference_spp_needed() {
        let _ = write!(msg, ": give --reference-spp {spp} or more");
    }
    Some(msg)
}

/// The whole report: how it was made, the reference, the table and the speed-ups.
pub fn markdown(bench: &Bench, ctx: &Context) -> String {
    let r = &bench.settings;
    let mut out = format!("# Speed against accuracy: {}\n\n", ctx.scene);
    if !ctx.command.is_empty() {
        let _ = writeln!(out, "- command: `{}`", ctx.command);
    }
    if !ctx.machine.is_empty() {
        let _ = writeln!(out, "- machine: {}", ctx.machine);
    }
    let _ = writeln!(
        out,
        "- settings: {} x {}, {} frame{}, bounces {}, epsilon {:e}, max steps {}, seed {}, exposure {}, threads {}",
        r.width,
        r.height,
        r.frames,
        if r.frames == 1 { "" } else { "s" },
        r.bounces,
        r.epsilon,
        r.max_steps,
        r.seed,
        r.exposure,
        bench
            .threads
            .map_or("all cores".to_string(), |n| n.to_string())
    );
    let _ = writeln!(out, "- {}", reference_summary(bench));
    let _ = writeln!(
        out,
        "- time is the whole render's wall time, denoising included, the median of {} render{}; \
         RMSE and bias on linear radiance, PSNR, SSIM and display RMSE (10^(-PSNR/20)) on the displayed image",
        bench.repeats,
        if bench.repeats == 1 { "" } else { "s" }
    );
    if let Some(w) = reference_warning(bench) {
        let _ = writeln!(out, "- warning: {w}");
    }
    out.push('\n');
    out.push_str(&markdown_table(&bench.rows));
    for metric in [Metric::Rmse, Metric::DisplayRmse] {
        let s = speedup_markdown(bench, metric);
        if !s.is_empty() {
            out.push('\n');
            out.push_str(&s);
        }
    }
    out
}

/// Make sure results can be written into `dir` before any rendering: create it if needed and
/// check a file can be created there (the probe is removed at once).
pub fn prepare_out_dir(dir: &Path) -> Result<()> {
    let path = dir.to_path_buf();
    if dir.exists() && !dir.is_dir() {
        return Err(SweepError::NotADirectory { path }.into());
    }
    if let Err(source) = std::fs::create_dir_all(dir) {
        return Err(Error::CreateDirectory { path, source });
    }
    tempfile::NamedTempFile::new_in(dir)
        .map(drop)
        .map_err(|source| SweepError::DirectoryNotWritable { path, source }.into())
}

/// What [`write_results`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Written {
    pub csv: PathBuf,
    pub markdown: PathBuf,
    pub plot: PathBuf,
    /// Why the plot has no text, when it has none.
    pub plot_note: Option<String>,
}

/// Write `results.csv`, `results.md` and `plot.png` into `dir` (which must exist).
pub fn write_results(dir: &Path, bench: &Bench, ctx: &Context) -> Result<Written> {
    let csv_path = dir.join("results.csv");
    let md_path = dir.join("results.md");
    let plot_path = dir.join("plot.png");
    write_atomic(&csv_path, csv(&bench.rows).as_bytes())?;
    write_atomic(&md_path, markdown(bench, ctx).as_bytes())?;
    let outcome = super::plot::write_png(&bench.rows, &plot_path, &ctx.scene)?;
    Ok(Written {
        csv: csv_path,
        markdown: md_path,
        plot: plot_path,
        plot_note: outcome.note,
    })
}

/// A number to `digits` significant digits, fixed-point when that stays short (for tables,
/// progress lines and the plot's tick labels).
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "NaN".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..5).contains(&mag) {
        let decimals = (digits as i32 - 1 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits.saturating_sub(1))
    }
}
