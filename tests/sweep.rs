//! The speed/accuracy sweep (`hyperslice bench`): the Pareto front, time-to-error
//! interpolation, a quick sweep end to end through the library, and the command line.

mod common;

use common::{LIT_BALL, hyperslice, scene_dir};
use hyperslice::Compilation;
use hyperslice::render::sampler::SamplerKind;
use hyperslice::scene::Scene;
use hyperslice::sweep::costs::{self, CostOptions, CostPoint, Knob};
use hyperslice::sweep::{
    self, Family, Reach, SweepOptions, pareto_front, plot, report, time_to_error,
};
use std::process::Command;

fn scene() -> Scene {
    let c = Compilation::from_source("bench.4ds", LIT_BALL);
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
    c.scene.expect("a scene")
}

#[test]
fn pareto_front_excludes_dominated_points_and_keeps_ties() {
    let points = [
        (1.0, 10.0),      // 0: fastest but one
        (2.0, 5.0),       // 1
        (3.0, 5.0),       // 2: slower than 1, no better
        (2.0, 5.0),       // 3: ties 1 exactly: both stay
        (4.0, 1.0),       // 4: most accurate
        (5.0, 2.0),       // 5: beaten by 4 on both
        (0.5, 20.0),      // 6: fastest
        (1.0, 11.0),      // 7: as fast as 0, less accurate
        (f64::NAN, 0.1),  // 8: unmeasured: never on the front, beats nothing
        (0.75, f64::NAN), // 9
    ];
    let front = pareto_front(&points);
    assert_eq!(
        front,
        [
            true, true, false, true, true, false, true, false, false, false
        ]
    );
    assert_eq!(pareto_front(&[]), Vec::<bool>::new());
    assert_eq!(pareto_front(&[(1.0, 1.0)]), [true]);
}

#[test]
fn time_to_error_is_exact_on_a_power_law() {
    // time = 3 / error^2: Monte Carlo's error falls as one over the square root of time.
    let curve: Vec<(f64, f64)> = [1.0, 0.5, 0.25, 0.125]
        .iter()
        .map(|&e: &f64| (3.0 / (e * e), e))
        .collect();
    for target in [0.9, 0.3, 0.2, 0.13, 0.125] {
        let Reach::At(t) = time_to_error(&curve, target) else {
            panic!("{target} is reached between points");
        };
        let exact = 3.0 / (target * target);
        assert!((t / exact - 1.0).abs() < 1e-12, "{target}: {t} vs {exact}");
    }
    // A steeper law, and uneven spacing.
    let curve: Vec<(f64, f64)> = [0.8, 0.3, 0.29, 0.01]
        .iter()
        .map(|&e: &f64| (0.5 * e.powf(-3.5), e))
        .collect();
    let t = time_to_error(&curve, 0.05).time().expect("reached");
    assert!((t / (0.5 * 0.05_f64.powf(-3.5)) - 1.0).abs() < 1e-12, "{t}");
}

#[test]
fn time_to_error_says_when_a_curve_never_gets_there() {
    let curve = [(1.0, 0.4), (2.0, 0.3), (4.0, 0.2)];
    assert_eq!(time_to_error(&curve, 0.1), Reach::NotReached);
    assert_eq!(time_to_error(&curve, 0.1).time(), None);
    assert_eq!(time_to_error(&[], 0.1), Reach::NotReached);
    // Already there at the first point: no earlier time can be read off.
    assert_eq!(time_to_error(&curve, 0.5), Reach::AtMost(1.0));
    // A noisy curve: the first crossing counts.
    let noisy = [(1.0, 0.4), (2.0, 0.2), (4.0, 0.3), (8.0, 0.1)];
    let t = time_to_error(&noisy, 0.25).time().expect("reached");
    assert!(t > 1.0 && t < 2.0, "{t}");
    // Unusable points are skipped.
    let holes = [(1.0, f64::NAN), (0.0, 0.5), (2.0, 0.4), (4.0, 0.1)];
    let t = time_to_error(&holes, 0.2).time().expect("reached");
    assert!(t > 2.0 && t < 4.0, "{t}");
}

#[test]
fn plan_covers_every_family_and_the_reference_outsamples_it() {
    let s = scene();
    let opts = SweepOptions::default();
    let configs = sweep::plan(&opts.settings(&s.render), &opts);
    for f in Family::ALL {
        assert!(configs.iter().any(|c| c.family == f), "{f:?}");
    }
    assert_eq!(sweep::middle_spp(&opts.spp_list), 8);
    // The final preset's 256 spp are the most measured.
    assert_eq!(sweep::reference_spp(&configs, None), 100 * 256);
    assert_eq!(sweep::reference_spp(&configs, Some(100_000)), 100_000);
    // Only the denoiser families denoise, and only the plain family turns light sampling off.
    for c in &configs {
        assert_eq!(
            c.denoise != hyperslice::scene::Denoise::None,
            matches!(c.family, Family::Median | Family::Atrous),
            "{}",
            c.label
        );
        assert_eq!(
            c.light_sampling,
            c.family != Family::NoLightSampling,
            "{}",
            c.label
        );
        // Only the random family leaves the default (Sobol) sampler.
        assert_eq!(
            c.sampler == SamplerKind::Random,
            c.family == Family::Random,
            "{}",
            c.label
        );
    }
    // The reference is as accurate as the most accurate configuration.
    let accurate = sweep::reference_settings(&configs, &opts.settings(&s.render));
    assert_eq!(
        (accurate.bounces, accurate.epsilon, accurate.max_steps),
        (16, 1e-5, 5000)
    );
    // A family filter keeps only those families.
    let only = SweepOptions {
        families: vec![Family::Baseline, Family::Random],
        ..SweepOptions::default()
    };
    let kept = sweep::plan(&only.settings(&s.render), &only);
    assert_eq!(kept.len(), 2 * only.spp_list.len());
    assert!(kept.iter().all(|c| only.families.contains(&c.family)));
}

#[test]
fn median_of_odd_even_and_empty() {
    assert_eq!(sweep::median(&mut [3.0, 1.0, 2.0]), 2.0);
    assert_eq!(sweep::median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    assert!(sweep::median(&mut []).is_nan());
}

#[test]
fn cost_exponent_is_exact_on_a_power_law() {
    let points: Vec<CostPoint> = [1u64, 2, 4, 8]
        .iter()
        .map(|&x| CostPoint {
            knob: Knob::Spp,
            x,
            time: 0.3 * (x as f64).powf(0.8),
            samples: x,
            evaluations_per_sample: 100.0,
        })
        .collect();
    let refs: Vec<&CostPoint> = points.iter().collect();
    let k = costs::exponent(&refs).expect("an exponent");
    assert!((k - 0.8).abs() < 1e-12, "{k}");
    assert_eq!(costs::exponent(&refs[..1]), None);
}

#[test]
fn the_generated_object_scenes_compile_with_n_objects() {
    for n in [1u32, 2, 5, 16, 17, 64, 81] {
        let c = Compilation::from_source("objects.4ds", &costs::objects_scene(n));
        assert!(!c.has_errors(), "{n}: {}", c.render_diagnostics(false));
        assert_eq!(
            c.scene.expect("a scene").objects.len(),
            n as usize + 2,
            "{n}"
        );
    }
}

#[test]
fn quick_cost_curves_cover_every_knob_and_count_samples() {
    let s = scene();
    let mut events = 0;
    let points = costs::cost_curves(&s, &CostOptions::quick(), &mut |_| events += 1)
        .expect("the curves run");
    assert_eq!(events, 2 * points.len());
    for knob in Knob::ALL {
        assert!(points.iter().any(|p| p.knob == knob), "{knob:?}");
    }
    for p in &points {
        assert!(p.time > 0.0 && p.evaluations_per_sample > 0.0, "{p:?}");
    }
    // Samples grow exactly with spp, frames and pixels.
    let samples = |knob, x| {
        points
            .iter()
            .find(|p| p.knob == knob && p.x == x)
            .map(|p| p.samples)
            .expect("measured")
    };
    assert_eq!(samples(Knob::Spp, 2), 2 * samples(Knob::Spp, 1));
    assert_eq!(samples(Knob::Frames, 2), 2 * samples(Knob::Frames, 1));
    assert_eq!(
        samples(Knob::Pixels, 4 * 3 * 4),
        4 * samples(Knob::Pixels, 4 * 3)
    );
    let md = costs::markdown(&points);
    assert!(md.contains("fitted exponent"), "{md}");
    assert_eq!(costs::csv(&points).lines().count(), points.len() + 1);
}

#[test]
fn the_bench_command_writes_cost_curves() {
    let dir = scene_dir();
    let o = hyperslice(
        dir.path(),
        &["bench", "scene.4ds", "--costs", "--quick", "--out", "out"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("**objects**"));
    for f in ["costs.csv", "costs.md"] {
        assert!(dir.path().join("out").join(f).is_file(), "{f}: {err}");
    }
}

#[test]
fn a_quick_sweep_end_to_end() {
    let s = scene();
    let mut events = 0;
    let bench = sweep::bench(&s, &SweepOptions::quick(), None, &mut |_| events += 1)
        .expect("the sweep runs");
    let opts = SweepOptions::quick();
    let planned = sweep::plan(&opts.settings(&s.render), &opts);
    assert_eq!(bench.rows.len(), planned.len());
    assert_eq!(events, 2 + 2 * planned.len());
    assert_eq!((bench.settings.width, bench.settings.height), (32, 24));
    for r in &bench.rows {
        let e = &r.error;
        assert!(
            r.time.is_finite()
                && r.time > 0.0
                && e.rmse.is_finite()
                && e.rmse > 0.0
                && e.psnr.is_finite()
                && e.ssim.is_finite()
                && e.bias.is_finite(),
            "{}: {r:?}",
            r.config.label
        );
    }
    assert!(bench.rows.iter().any(|r| r.pareto));
    // Error falls as samples grow.
    let baseline = sweep::curve(&bench.rows, Family::Baseline, sweep::Metric::Rmse);
    assert_eq!(baseline.len(), 3);
    assert!(
        baseline[2].1 < baseline[0].1,
        "RMSE at 4 spp {} not below 1 spp's {}",
        baseline[2].1,
        baseline[0].1
    );
    // The reference reports its own error, and it is well below the errors measured.
    assert_eq!(bench.reference.spp, Some(400));
    let noise = bench.reference.noise.expect("the reference's own error");
    assert!(noise.is_finite() && noise > 0.0);
    let ratio = bench.reference_ratio().expect("a ratio");
    assert!(ratio > 0.0 && ratio < 1.0, "{ratio}");
    assert!(report::reference_summary(&bench).contains("its own error"));
    for metric in [sweep::Metric::Rmse, sweep::Metric::DisplayRmse] {
        let speedups = bench
            .speedups(metric)
            .expect("plain path tracing was measured");
        assert_eq!(speedups.spp, 4);
        assert_eq!(speedups.curves.len(), 4);
    }

    let csv = report::csv(&bench.rows);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], report::CSV_HEADER);
    assert_eq!(lines.len(), bench.rows.len() + 1);
    let columns = report::CSV_HEADER.split(',').count();
    assert!(lines.iter().all(|l| l.split(',').count() == columns));

    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("results");
    report::prepare_out_dir(&out).expect("writable");
    let ctx = report::Context {
        scene: "bench".into(),
        command: "test".into(),
        machine: report::machine(),
    };
    let written = report::write_results(&out, &bench, &ctx).expect("written");
    assert_eq!(std::fs::read_to_string(&written.csv).expect("csv"), csv);
    let md = std::fs::read_to_string(&written.markdown).expect("md");
    assert!(md.contains("| configuration | spp | time (s) |"), "{md}");
    assert!(md.contains("| * |"), "{md}");
    assert!(
        md.contains("Time to reach the RMSE of plain path tracing"),
        "{md}"
    );
    let png = image::open(&written.plot).expect("the plot decodes");
    assert_eq!((png.width(), png.height()), (plot::WIDTH, plot::HEIGHT));
    // Only the three results are left behind (no temporary files).
    assert_eq!(std::fs::read_dir(&out).expect("listed").count(), 3);

    // Without text (no font), the plot is still drawn.
    let pixels = plot::draw(&bench.rows, 200, 150, None).expect("drawn");
    assert_eq!(pixels.len(), 200 * 150 * 3);
    assert!(pixels.iter().any(|&p| p != 255), "something is drawn");
}

#[test]
fn a_reference_from_exr_must_match_the_sweep() {
    let dir = tempfile::tempdir().expect("temp dir");
    let s = scene();
    let mut r = SweepOptions::quick().settings(&s.render);
    r.exposure = 2.0;
    let path = dir.path().join("ref.exr");
    let image = hyperslice::output::HdrImage::from_fn(32, 24, |x, y| [x as f32, y as f32, 1.0]);
    let settings = hyperslice::output::OutputSettings {
        exposure: 2.0,
        fps: 1.0,
    };
    hyperslice::output::write(&path, std::slice::from_ref(&image), &settings).expect("written");
    let reference = sweep::load_reference(&path, &r).expect("loaded");
    assert_eq!(reference.frames.len(), 1);
    // The exposure `render` multiplied in is divided out again.
    assert_eq!(
        reference.frames[0][3 + 2 * 32],
        glam::DVec3::new(3.0, 2.0, 1.0)
    );
    assert_eq!(reference.noise, None);
    r.width = 16;
    let e = sweep::load_reference(&path, &r)
        .expect_err("wrong size")
        .to_string();
    assert!(e.contains("is 32x24 but the sweep renders 16x24"), "{e}");
    r.width = 32;
    r.frames = 2;
    let e = sweep::load_reference(&path, &r)
        .expect_err("one frame")
        .to_string();
    assert!(e.contains("one frame but the sweep renders 2"), "{e}");
}

#[test]
fn the_bench_command_writes_its_results() {
    let dir = scene_dir();
    let o = hyperslice(
        dir.path(),
        &[
            "bench",
            "scene.4ds",
            "--quick",
            "--out",
            "out",
            "--threads",
            "2",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("[1/"), "{err}");
    assert!(err.contains("reference, 400 spp"), "{err}");
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("| baseline | 4 |"), "{table}");
    for f in ["results.csv", "results.md", "plot.png"] {
        assert!(dir.path().join("out").join(f).is_file(), "{f}: {err}");
    }
}

#[test]
fn the_bench_command_refuses_an_unwritable_out_before_rendering() {
    let dir = scene_dir();
    std::fs::write(dir.path().join("taken"), "a file").expect("file written");
    let o = hyperslice(
        dir.path(),
        &["bench", "scene.4ds", "--quick", "--out", "taken"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("`taken`: it is not a directory"), "{err}");
    assert!(!err.contains("[ref]") && !err.contains("[1/"), "{err}");

    let o = hyperslice(
        dir.path(),
        &["bench", "missing.4ds", "--quick", "--out", "out"],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(!dir.path().join("out").exists());
}

/// Made-up rows over the default plan: error falling as one over the square root of time,
/// each family a little worse than the one before.
fn synthetic_rows() -> Vec<sweep::Row> {
    let opts = SweepOptions::default();
    let mut rows: Vec<sweep::Row> = sweep::plan(&opts.settings(&scene().render), &opts)
        .into_iter()
        .enumerate()
        .map(|(i, config)| {
            let time = 0.01 * config.spp as f64 * (1.0 + 0.1 * (i % 3) as f64);
            sweep::Row {
                error: hyperslice::metrics::ImageError {
                    rmse: (1.0 + 0.2 * config.family as u8 as f64) * 0.1 / time.sqrt(),
                    psnr: 30.0,
                    ssim: 0.9,
                    bias: 0.0,
                },
                time,
                config,
                out_of_steps: 0,
                dropped: 0,
                pareto: false,
            }
        })
        .collect();
    sweep::mark_pareto(&mut rows);
    rows
}

/// Runs in a process of its own (started by `the_plot_needs_no_font_without_text`), where no
/// font has been registered.
#[test]
#[ignore = "run by the_plot_needs_no_font_without_text in a fresh process"]
fn plot_in_a_process_without_fonts() {
    if std::env::var_os("HYPERSLICE_TEST_NO_FONT").is_none() {
        return;
    }
    let rows = synthetic_rows();
    let e = plot::draw(&rows, 300, 200, Some("title"))
        .expect_err("no font is registered")
        .to_string();
    assert!(e.contains("Font"), "{e}");
    let pixels = plot::draw(&rows, 300, 200, None).expect("drawn without text");
    assert!(pixels.iter().any(|&p| p != 255), "something is drawn");
}

#[test]
fn the_plot_needs_no_font_without_text() {
    let o = Command::new(std::env::current_exe().expect("this test binary"))
        .args([
            "--ignored",
            "--exact",
            "plot_in_a_process_without_fonts",
            "--test-threads",
            "1",
        ])
        .env("HYPERSLICE_TEST_NO_FONT", "1")
        .output()
        .expect("ran");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("1 passed"),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn the_plot_marks_the_front_and_writes_a_png() {
    let rows = synthetic_rows();
    assert!(rows.iter().any(|r| r.pareto) && rows.iter().any(|r| !r.pareto));
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("plot.png");
    let outcome = plot::write_png(&rows, &path, "synthetic").expect("written");
    assert_eq!(outcome.labels, outcome.note.is_none());
    let png = image::open(&path).expect("decodes").to_rgb8();
    // Every family's colour and the black front appear somewhere.
    let has = |rgb: [u8; 3]| png.pixels().any(|p| p.0 == rgb);
    assert!(has([31, 119, 180]), "baseline");
    assert!(has([255, 127, 14]), "atrous");
    assert!(has([0, 0, 0]), "black");
}

/// Every scene of the marcher corpus (`bench --marcher-corpus`) compiles from the repository
/// root at its corpus settings, so the bench cannot lose a scene to a moved file.
#[test]
fn every_marcher_corpus_scene_compiles() {
    use hyperslice::sweep::corpus;
    let entries = corpus::entries(20);
    assert_eq!(entries.len(), 32);
    for e in &entries {
        let scene = e.scene(std::path::Path::new(".")).expect(&e.name);
        assert_eq!(
            scene.render.denoise,
            hyperslice::scene::Denoise::None,
            "{}",
            e.name
        );
    }
}

/// The corpus takes more pairs of a short scene until its default renders add up to a second
/// (at most 61), and at least as many as asked; its ratio is the median of the pairs', within
/// their interval.
#[test]
fn the_corpus_times_short_scenes_more_often() {
    use hyperslice::sweep::corpus;
    // An 8 x 8 generated scene renders in well under a millisecond.
    let source = hyperslice::generate::generate(3).source;
    let scene = Compilation::from_source("tiny", &source)
        .into_scene_named("tiny")
        .expect("a generated scene compiles");
    let m = corpus::measure("tiny", &scene, 1, Some(1)).expect("renders");
    assert_eq!(m.pairs, 61, "{m:?}");
    assert!(m.ratio.is_finite() && m.ratio > 0.0, "{m:?}");
    let (lo, hi) = m.interval.expect("61 pairs give an interval");
    assert!(lo <= m.ratio && m.ratio <= hi, "{m:?}");
    let m = corpus::measure("tiny", &scene, 70, Some(1)).expect("renders");
    assert_eq!(m.pairs, 70, "{m:?}");
}

/// The corpus's interval of a median (`corpus::median_interval`) is the sign test's: none
/// from five samples (the extremes cover only 94%), the extremes from six, the 10th and 22nd
/// of 31; and it covers the median of the distribution the samples came from in 97% of draws
/// of 31 (the binomial's exact 1 - 2 P(B <= 9)), within 1.5 points over 4,000 draws.
#[test]
fn the_corpus_interval_covers_the_median() {
    use hyperslice::sweep::corpus::median_interval;
    use rand::{Rng, SeedableRng};
    let count = |n: usize| (1..=n).map(|x| x as f64).collect::<Vec<f64>>();
    assert_eq!(median_interval(&count(5)), None);
    assert_eq!(median_interval(&count(6)), Some((1.0, 6.0)));
    assert_eq!(median_interval(&count(31)), Some((10.0, 22.0)));
    assert_eq!(median_interval(&count(61)), Some((23.0, 39.0)));
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    let draws = 4000;
    let covered = (0..draws)
        .filter(|_| {
            // A skewed distribution, as render times are: exp of a normal-ish sum, median 1.
            let mut v: Vec<f64> = (0..31)
                .map(|_| ((0..4).map(|_| rng.random::<f64>() - 0.5).sum::<f64>()).exp())
                .collect();
            v.sort_by(f64::total_cmp);
            let (lo, hi) = median_interval(&v).expect("31 samples");
            lo <= 1.0 && 1.0 <= hi
        })
        .count();
    let share = covered as f64 / draws as f64;
    assert!((share - 0.9706).abs() < 0.015, "covered {share}");
}
