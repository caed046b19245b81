//! `hyperslice bench`: measure speed against accuracy on one scene (see `sweep`), print the
//! table, and write `results.csv`, `results.md` and `plot.png`.

use crate::render_command::{extent, parse_frames, parse_size, parse_threads};
use clap::Args;
use hyperslice::output::write_atomic;
use hyperslice::scene::Scene;
use hyperslice::sweep::corpus;
use hyperslice::sweep::costs::{self, CostOptions, CostProgress};
use hyperslice::sweep::{self, Family, Progress, SweepOptions, report, sig};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args)]
pub struct BenchArgs {
    /// The scene to measure (not with --marcher-corpus).
    #[arg(required_unless_present = "marcher_corpus")]
    file: Option<PathBuf>,
    /// Image size, as WIDTHxHEIGHT (e.g. 64x48). Default: the scene's (32x24 with --quick).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Number of frames. Default: the scene's (1 with --quick).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_frames)]
    frames: Option<u32>,
    /// Least samples per pixel of the reference render; it takes at least 100 times the most
    /// samples of any configuration measured.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_reference_spp, conflicts_with = "reference")]
    reference_spp: Option<u32>,
    /// Compare with this linear OpenEXR instead of rendering a reference: one file, or numbered
    /// frames `stem_0000.exr`, ... (as `render -o REF.exr` writes them), at the sweep's size and
    /// frame count; render it with `--denoise none` and a seed other than the scene's.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Samples per pixel of the curves, comma-separated (default 1,2,4,8,16,32; 1,2,4 with
    /// --quick).
    #[arg(long, value_parser = parse_spp_list)]
    spp_list: Option<SppList>,
    /// Directory for results.csv, results.md and plot.png (created if missing). Default:
    /// bench-<scene name>.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Worker threads (0: every core). Default: the scene's setting (2 with --marcher-corpus).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_threads)]
    threads: Option<u32>,
    /// Renders of each configuration; the time reported is their median. Default 5 (1 with
    /// --quick, 3 with --marcher-corpus).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_repeats)]
    repeats: Option<u32>,
    /// Measure only these families, comma-separated: baseline, no-light-sampling, random,
    /// median, atrous, epsilon, max-steps, bounces, preset. Default: all.
    #[arg(long, value_parser = parse_families)]
    families: Option<Families>,
    /// Measure cost curves instead of the speed/accuracy sweep: render time against pixels,
    /// samples per pixel, frames, threads and number of objects (costs.csv, costs.md).
    #[arg(long, conflicts_with_all = ["reference", "reference_spp", "spp_list", "families"])]
    costs: bool,
    /// Time the default marcher against `--marcher plain` on the marcher corpus (the five
    /// examples, sphere unions of 16 and 1024, a custom field, a tiling, a room of rounded
    /// boxes, a turned slab, far glass and generated scenes), paired and alternating, and print each
    /// scene's ratio (default / plain) and their geometric mean. Run it from the repository
    /// root. --repeats sets the least pairs of renders of each (default 3; a scene takes more, up to
    /// 61, until its default renders add up to a second), --threads the threads (default 2).
    /// Each ratio comes with a 95% confidence interval (the sign test's, from six pairs).
    #[arg(long, conflicts_with_all = ["file", "costs", "reference", "reference_spp", "spp_list", "families", "size", "frames", "quick", "out"])]
    marcher_corpus: bool,
    /// With --marcher-corpus: how many generated scenes (seeds 1, 2, ...).
    #[arg(long, default_value_t = 20, requires = "marcher_corpus", allow_hyphen_values = true, value_parser = parse_generated)]
    generated: u64,
    /// Shrink everything for a fast check: 32x24, one frame, 1,2,4 spp (a 400-spp reference),
    /// only the draft preset.
    #[arg(long)]
    quick: bool,
}

/// The counts the bench takes, refused like the render settings: with the value and the range.
macro_rules! count_flags {
    ($($f:ident: $t:ty = $name:literal in $lo:literal ..= $hi:literal,)*) => {$(
        fn $f(s: &str) -> Result<$t, String> {
            hyperslice::scene::ranges::whole($name, $lo, $hi).parse(s).map(|x| x as $t)
        }
    )*};
}

count_flags! {
    parse_reference_spp: u32 = "the reference's spp" in 1.0 ..= 100_000_000.0,
    parse_repeats: u32 = "repeats" in 1.0 ..= 100.0,
    parse_generated: u64 = "generated" in 0.0 ..= 10_000.0,
}

#[derive(Clone)]
struct SppList(Vec<u32>);

#[derive(Clone)]
struct Families(Vec<Family>);

fn parse_families(s: &str) -> Result<Families, String> {
    let list = s
        .split(',')
        .map(|v| {
            let v = v.trim();
            Family::ALL
                .into_iter()
                .find(|f| f.name().replace(' ', "-") == v)
                .ok_or_else(|| {
                    let names: Vec<String> = Family::ALL
                        .iter()
                        .map(|f| f.name().replace(' ', "-"))
                        .collect();
                    format!("`{v}` is not a family; choose from {}", names.join(", "))
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Families(list))
}

fn parse_spp_list(s: &str) -> Result<SppList, String> {
    let list = s
        .split(',')
        .map(|v| match v.trim().parse::<u32>() {
            Ok(n) if (1..=1_000_000).contains(&n) => Ok(n),
            _ => Err(format!(
                "`{}` is not a sample count; write whole numbers in 1..=1000000 separated by commas, e.g. 1,2,4,8",
                v.trim()
            )),
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(SppList(list))
}

/// The command line as typed, for the report (the program by its name only).
fn command_line() -> String {
    std::env::args()
        .enumerate()
        .map(|(i, a)| {
            let a = if i == 0 {
                Path::new(&a)
                    .file_stem()
                    .map_or(a.clone(), |s| s.to_string_lossy().into_owned())
            } else {
                a
            };
            if a.is_empty() || a.contains(|c: char| c.is_whitespace() || c == '\'') {
                format!("'{}'", a.replace('\'', r"'\''"))
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

impl BenchArgs {
    /// Worker threads: the flag's (0: every core), else the scene's (`None`).
    fn threads(&self, scene: &Scene) -> Option<usize> {
        match self.threads {
            Some(0) => Some(hyperslice::render::driver::every_core()),
            Some(n) => Some(n as usize),
            None => scene.render.threads(),
        }
    }
}

pub fn run(args: BenchArgs, color: bool) -> ExitCode {
    let Some(file) = &args.file else {
        return crate::finish(marcher_corpus(&args));
    };
    match crate::compile(file, &crate::SceneArgs::default(), color) {
        Some(scene) => crate::finish(bench(&args, file, &scene)),
        None => ExitCode::FAILURE,
    }
}

/// `--marcher-corpus`: the default marcher against the plain one on every corpus scene.
fn marcher_corpus(args: &BenchArgs) -> hyperslice::error::Result<()> {
    let runs = args.repeats.unwrap_or(3);
    let threads = match args.threads {
        Some(0) => hyperslice::render::driver::every_core(),
        Some(n) => n as usize,
        None => 2,
    };
    if !Path::new("examples").is_dir() {
        return Err(hyperslice::Error::Usage(
            "the marcher corpus reads the repository's scenes (examples/, benches/scenes/, \
             tests/in/): run `hyperslice bench --marcher-corpus` from the repository root"
                .to_string(),
        ));
    }
    let entries = corpus::entries(args.generated);
    println!("# The marcher corpus: default (auto) against --marcher plain\n");
    println!("- command: `{}`", command_line());
    println!("- machine: {}", report::machine());
    println!(
        "- at least {runs} paired render(s) of each scene, alternating (each pair in the other \
         order), and more until the \
         default's add up to a second (at most 61 pairs); {} thread(s), no denoiser; times are \
         medians, ratio = the median of the pairs' default / plain, with a distribution-free 95% \
         confidence interval (the sign test's; none below 6 pairs)\n",
        threads
    );
    println!(
        "| scene | pairs | default (s) | plain (s) | ratio | 95% interval | out of steps (default) | out of steps (plain) | choice (first frame) |"
    );
    println!("|---|--:|--:|--:|--:|--:|--:|--:|---|");
    let mut rows = vec![];
    for entry in &entries {
        let scene = entry.scene(Path::new("."))?;
        let m = corpus::measure(&entry.name, &scene, runs, Some(threads))?;
        println!(
            "| {} | {} | {} | {} | {:.2} | {} | {} | {} | {} |",
            m.name,
            m.pairs,
            sig(m.default_s, 3),
            sig(m.plain_s, 3),
            m.ratio,
            m.interval
                .map_or("-".to_string(), |(lo, hi)| format!("{lo:.2}-{hi:.2}")),
            m.default_out_of_steps,
            m.plain_out_of_steps,
            m.choice.name()
        );
        rows.push(m);
    }
    // Above 1 beyond the noise (its whole interval), or only within it.
    let above = |beyond: bool| {
        let listed: Vec<String> = (rows.iter())
            .filter(|m| m.ratio > 1.0 && m.interval.is_some_and(|(lo, _)| lo > 1.0) == beyond)
            .map(|m| format!("{} ({:.2}, {})", m.name, m.ratio, m.choice.name()))
            .collect();
        match listed.is_empty() {
            true => "none".to_string(),
            false => listed.join(", "),
        }
    };
    println!(
        "\ngeometric mean of the ratios: {:.2}; above 1 (the whole 95% interval): {}; above 1 \
         within the noise (the interval holds 1, or too few pairs for one): {}",
        corpus::geometric_mean(&rows),
        above(true),
        above(false)
    );
    Ok(())
}

fn bench(args: &BenchArgs, file: &Path, scene: &Scene) -> hyperslice::error::Result<()> {
    let stem = file
        .file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned();
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("bench-{stem}")));
    // Fail on an unwritable directory before spending any time rendering.
    report::prepare_out_dir(&out)?;
    if args.costs {
        return run_costs(args, file, scene, &out);
    }
    let mut opts = if args.quick {
        SweepOptions::quick()
    } else {
        SweepOptions::default()
    };
    if args.size.is_some() {
        opts.size = args.size;
    }
    if args.frames.is_some() {
        opts.frames = args.frames;
    }
    if let Some(SppList(list)) = &args.spp_list {
        opts.spp_list = list.clone();
    }
    if let Some(n) = args.repeats {
        opts.repeats = n;
    }
    if let Some(Families(list)) = &args.families {
        opts.families = list.clone();
    }
    if args.reference_spp.is_some() {
        opts.reference_spp = args.reference_spp;
    }
    opts.threads = args.threads(scene);

    let r = opts.settings(&scene.render);
    let configs = sweep::plan(&r, &opts);
    let reference = match &args.reference {
        Some(path) => format!("reference from `{}`", path.display()),
        None => format!(
            "reference {} spp",
            sweep::reference_spp(&configs, opts.reference_spp)
        ),
    };
    eprintln!(
        "bench {}: {}, {} configurations (middle {} spp), {reference}",
        file.display(),
        extent(&r),
        configs.len(),
        sweep::middle_spp(&opts.spp_list),
    );
    // Whether a progress line is waiting for its time.
    let mut open = false;
    let mut progress = |p: Progress| {
        match p {
            Progress::Reference { spp } => eprint!("[ref] reference, {spp} spp ... "),
            Progress::ReferenceDone { reference } => match reference.time {
                Some(t) => eprintln!("{} s", sig(t, 3)),
                None => eprintln!("[ref] reference {}", reference.source),
            },
            Progress::Start {
                index,
                total,
                config,
            } => eprint!(
                "[{index}/{total}] {}, {} spp ... ",
                config.label, config.spp
            ),
            Progress::Done { row, .. } => {
                eprintln!("{} s (RMSE {})", sig(row.time, 3), sig(row.error.rmse, 3))
            }
        }
        open = matches!(p, Progress::Reference { .. } | Progress::Start { .. });
    };
    let result = sweep::bench(scene, &opts, args.reference.as_deref(), &mut progress);
    if result.is_err() && open {
        eprintln!();
    }
    let bench = result?;
    let ctx = report::Context {
        scene: stem,
        command: command_line(),
        machine: report::machine(),
    };
    print!("{}", report::markdown(&bench, &ctx));
    eprintln!("{}", report::reference_summary(&bench));
    if let Some(w) = report::reference_warning(&bench) {
        eprintln!("warning: {w}");
    }
    let w = report::write_results(&out, &bench, &ctx)?;
    if let Some(note) = &w.plot_note {
        eprintln!("note: {note}");
    }
    eprintln!(
        "wrote {}, {} and {}",
        w.csv.display(),
        w.markdown.display(),
        w.plot.display()
    );
    Ok(())
}

/// `--costs`: the cost curves, printed and written as costs.csv and costs.md.
fn run_costs(
    args: &BenchArgs,
    file: &Path,
    scene: &Scene,
    out: &Path,
) -> hyperslice::error::Result<()> {
    let mut opts = if args.quick {
        CostOptions::quick()
    } else {
        CostOptions::default()
    };
    if let Some(size) = args.size {
        opts.size = size;
    }
    if let Some(f) = args.frames {
        opts.frames = f;
    }
    if let Some(n) = args.repeats {
        opts.repeats = n;
    }
    opts.threads = args.threads(scene);
    eprintln!(
        "cost curves of {}: base {} x {}, {} spp, {} frame(s), median of {} render(s) per point",
        file.display(),
        opts.size.0,
        opts.size.1,
        opts.spp,
        opts.frames,
        opts.repeats
    );
    let mut progress = |p: CostProgress| match p {
        CostProgress::Start { knob, x } => eprint!("{} {x} ... ", knob.name()),
        CostProgress::Done { point } => eprintln!("{} s", sig(point.time, 3)),
    };
    let points = costs::cost_curves(scene, &opts, &mut progress)?;
    let md = format!(
        "# Cost curves: {}\n\n- command: `{}`\n- machine: {}\n- base: {} x {}, {} spp, {} frame(s), no denoiser; each point the median of {} render(s)\n{}",
        file.display(),
        command_line(),
        report::machine(),
        opts.size.0,
        opts.size.1,
        opts.spp,
        opts.frames,
        opts.repeats,
        costs::markdown(&points)
    );
    print!("{md}");
    let (csv_path, md_path) = (out.join("costs.csv"), out.join("costs.md"));
    write_atomic(&csv_path, costs::csv(&points).as_bytes())?;
    write_atomic(&md_path, md.as_bytes())?;
    eprintln!("wrote {} and {}", csv_path.display(), md_path.display());
    Ok(())
}
