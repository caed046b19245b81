//! `hyperslice render` and `hyperslice compile` end to end: files written, overrides applied,
//! pinned compiled scenes checked, and every bad request refused with a clear message before
//! any work starts.

mod common;

use common::{LIT_BALL, hyperslice, scene_dir};
use std::path::Path;
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .expect("listed")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn renders_an_animated_gif_with_overrides() {
    let dir = scene_dir();
    let o = hyperslice(
        dir.path(),
        &[
            "render",
            "scene.4ds",
            "-o",
            "out.gif",
            "--size",
            "24x16",
            "--spp",
            "2",
            "--frames",
            "4",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("24 x 16, 4 frames, 2 spp"), "{err}");
    assert!(err.contains("GIF quantisation: PSNR"), "{err}");
    assert!(err.contains("samples ("), "{err}");
    let file = std::fs::File::open(dir.path().join("out.gif")).expect("gif written");
    let mut decoder = gif::DecodeOptions::new().read_info(file).expect("a GIF");
    assert_eq!((decoder.width(), decoder.height()), (24, 16));
    let mut frames = 0;
    while decoder.read_next_frame().expect("frame").is_some() {
        frames += 1;
    }
    assert_eq!(frames, 4);
    assert_eq!(files(dir.path()), ["out.gif", "scene.4ds"]);
}

#[test]
fn writes_numbered_png_and_exr_frames() {
    let dir = scene_dir();
    for ext in ["png", "exr"] {
        let out = format!("shot.{ext}");
        let o = hyperslice(
            dir.path(),
            &[
                "render",
                "scene.4ds",
                "-o",
                &out,
                "--size",
                "8x6",
                "--spp",
                "1",
                "--frames",
                "2",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(
        files(dir.path()),
        [
            "scene.4ds",
            "shot_0000.exr",
            "shot_0000.png",
            "shot_0001.exr",
            "shot_0001.png"
        ]
    );
}

/// Render `scene.4ds` at 40x20, 2 spp, one frame into `out` with the flag `flag value`, and
/// return the file's bytes.
fn small_png(dir: &Path, out: &str, flag: &str, value: &str) -> Vec<u8> {
    let args = [
        "render",
        "scene.4ds",
        "-o",
        out,
        "--size",
        "40x20",
        "--spp",
        "2",
        "--frames",
        "1",
        flag,
        value,
    ];
    let o = hyperslice(dir, &args);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::read(dir.join(out)).unwrap()
}

#[test]
fn the_same_seed_gives_the_same_file_whatever_the_threads() {
    let dir = scene_dir();
    let a = small_png(dir.path(), "a.png", "--threads", "1");
    assert_eq!(a, small_png(dir.path(), "b.png", "--threads", "2"));
    // `--sampler random` is another image, and `sobol` (the default) the same one.
    assert_ne!(a, small_png(dir.path(), "c.png", "--sampler", "random"));
    assert_eq!(a, small_png(dir.path(), "d.png", "--sampler", "sobol"));
}

#[test]
fn refuses_bad_outputs_before_rendering() {
    let dir = scene_dir();
    for (out, message) in [
        ("missing/out.gif", "does not exist"),
        ("out.jpg", "unknown output format"),
        ("scene.4ds", "refusing to overwrite"),
    ] {
        // The full-size render would take seconds; a refusal is immediate.
        let start = std::time::Instant::now();
        let o = hyperslice(dir.path(), &["render", "scene.4ds", "-o", out]);
        assert!(!o.status.success(), "{out}");
        assert!(stderr(&o).contains(message), "{out}: {}", stderr(&o));
        assert!(!stderr(&o).contains("rendering"), "{}", stderr(&o));
        assert!(start.elapsed().as_secs_f64() < 5.0);
    }
    assert_eq!(
        std::fs::read_to_string(dir.path().join("scene.4ds")).unwrap(),
        LIT_BALL
    );
    assert_eq!(files(dir.path()), ["scene.4ds"]);
}

#[test]
fn refuses_bad_flags_and_bad_scenes() {
    let dir = scene_dir();
    let o = hyperslice(dir.path(), &["render", "scene.4ds", "--size", "20by10"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("WIDTHxHEIGHT"), "{}", stderr(&o));
    let o = hyperslice(dir.path(), &["render", "scene.4ds", "--spp", "0"]);
    assert!(!o.status.success());
    let o = hyperslice(dir.path(), &["render", "scene.4ds", "--sampler", "halton"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("sobol"), "{}", stderr(&o));
    std::fs::write(
        dir.path().join("bad.4ds"),
        "object x { shape = hypersphre(1) }",
    )
    .unwrap();
    let o = hyperslice(dir.path(), &["render", "bad.4ds", "-o", "bad.gif"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("hypersphere"), "{}", stderr(&o));
    assert!(!dir.path().join("bad.gif").exists());
}

#[test]
fn compile_writes_and_checks_the_pinned_ir() {
    let dir = scene_dir();
    let d = dir.path();
    let out = hyperslice(
        d,
        &["compile", "scene.4ds", "--emit", "ir", "--out", "scene.ir"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let pinned = std::fs::read_to_string(d.join("scene.ir")).expect("written");
    let printed = hyperslice(d, &["compile", "scene.4ds", "--emit", "ir"]);
    assert_eq!(String::from_utf8_lossy(&printed.stdout), pinned);
    assert!(pinned.contains("light lamp: radius 0.5"), "{pinned}");

    let check = || {
        hyperslice(
            d,
            &[
                "compile",
                "scene.4ds",
                "--emit",
                "ir",
                "--check",
                "scene.ir",
            ],
        )
    };
    let same = check();
    assert!(same.status.success(), "{}", stderr(&same));

    // The lamp moves: the check fails with a diff naming the old and the new offset.
    let moved = LIT_BALL.replace("[1, 2, 0, 0]", "[1, 3, 0, 0]");
    std::fs::write(d.join("scene.4ds"), moved).expect("scene written");
    let changed = check();
    assert_eq!(changed.status.code(), Some(1));
    let err = stderr(&changed);
    assert!(err.contains("differs from `scene.ir`"), "{err}");
    assert!(
        err.contains("-light lamp: radius 0.5, translate [1 2 0 0]"),
        "{err}"
    );
    assert!(
        err.contains("+light lamp: radius 0.5, translate [1 3 0 0]"),
        "{err}"
    );
    assert!(err.contains("--out scene.ir"), "{err}");

    let missing = hyperslice(
        d,
        &["compile", "scene.4ds", "--emit", "ir", "--check", "nope.ir"],
    );
    assert_eq!(missing.status.code(), Some(1));
    assert!(
        stderr(&missing).contains("cannot read `nope.ir`"),
        "{}",
        stderr(&missing)
    );
    let itself = hyperslice(
        d,
        &["compile", "scene.4ds", "--emit", "ir", "--out", "scene.4ds"],
    );
    assert_eq!(itself.status.code(), Some(1));
    assert!(
        std::fs::read_to_string(d.join("scene.4ds"))
            .expect("kept")
            .contains("object ball")
    );
}

#[test]
fn compile_picks_the_frame() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let scene = "render { frames = 3 }\nobject ball { shape = hypersphere(1 + t) }\n";
    std::fs::write(d.join("anim.4ds"), scene).expect("scene written");
    let ir = |args: &[&str]| {
        let mut all = vec!["compile", "anim.4ds", "--emit", "ir"];
        all.extend(args);
        let o = hyperslice(d, &all);
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            stderr(&o),
        )
    };
    // Frame 1 of 3 is t = 0.5: the radius folds to 1.5.
    let (code, text, _) = ir(&["--frame", "1"]);
    assert_eq!(code, Some(0));
    assert!(text.contains("- 1.5"), "{text}");
    assert_eq!(ir(&["--t", "0.5"]).1, text);
    assert!(ir(&[]).1.contains("- 1\n"), "{}", ir(&[]).1);
    let (code, _, err) = ir(&["--frame", "3"]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("frame 3 does not exist; the scene has 3 frames (0 to 2)"),
        "{err}"
    );
}

/// `--emit bytecode --cell X,Y,Z,W` prints the cell the cells' marcher runs at a point (its
/// header, then its tapes); outside the cells' cube, the region there. A malformed point is
/// refused before anything compiles, naming the value and the flag's form, with clap's exit
/// code for a bad value (2), as `--cell` without `--emit bytecode` is.
#[test]
fn compile_emits_the_cell_at_a_point() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let scene = "sky = rgb(1)\n\
        object floor { shape = halfspace(normal: [0, 1, 0, 0], offset: -1) }\n\
        object ball { shape = hypersphere(1) material = glass() }\n";
    std::fs::write(d.join("ball.4ds"), scene).expect("scene written");
    let cell = |point: &str, emit: &str| {
        let o = hyperslice(d, &["compile", "ball.4ds", "--emit", emit, "--cell", point]);
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            stderr(&o),
        )
    };
    let (code, text, err) = cell("0,0.5,0,0", "bytecode");
    assert_eq!(code, Some(0), "{err}");
    let header = text.lines().next().expect("a header");
    assert!(header.starts_with("cell inside the cube: depth "), "{text}");
    for field in [", lo [", ", size ", ", origin [", ", reach "] {
        assert!(header.contains(field), "{header}");
    }
    assert!(text.contains("\ntape scene: "), "{text}");
    assert!(text.contains("\ntape interior: "), "{text}");
    // Not the whole tapes: no object's own.
    assert!(!text.contains("tape ball"), "{text}");
    // A negative first coordinate is a point, not a flag; far away is outside the cube, where
    // only the floor reaches, met exactly.
    let (code, text, err) = cell("-1e6,0,0,0", "bytecode");
    assert_eq!(code, Some(0), "{err}");
    assert!(
        text.starts_with("cell outside the cube: depth 0, lo [-inf"),
        "{text}"
    );
    assert!(text.contains("exact: 1 piece\n  plane [0 1 0 0]"), "{text}");

    for (point, says) in [
        ("1,2,3", "`1,2,3` has 3 coordinates"),
        ("1,2,3,4,5", "has 5 coordinates"),
        ("", "has 1 coordinate:"),
        ("1,2,x,4", "`x` is not a finite number"),
        ("1,2,inf,4", "`inf` is not a finite number"),
        ("NaN,0,0,0", "`NaN` is not a finite number"),
    ] {
        let (code, text, err) = cell(point, "bytecode");
        assert_eq!(code, Some(2), "{point}: {err}");
        assert!(text.is_empty(), "{text}");
        assert!(err.contains(says), "{point}: {err}");
        assert!(
            err.contains("--cell takes a point as four finite numbers X,Y,Z,W"),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
    let (code, _, err) = cell("0,0,0,0", "ir");
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("use it with --emit bytecode"), "{err}");
}

/// A scene in which nothing gives off light renders black: `check` and `render` both say so,
/// and say how to light it.
#[test]
fn an_unlit_scene_is_warned_about() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(
        dir.path().join("dark.4ds"),
        "object ball { shape = hypersphere(1) material = diffuse(albedo: rgb(0.8)) }\n",
    )
    .expect("written");
    let o = hyperslice(dir.path(), &["check", "--color", "never", "dark.4ds"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("[W0005]"), "{err}");
    assert!(
        err.contains("add a light, an emission, or a sky colour"),
        "{err}"
    );
    assert!(err.contains("1 warning"), "{err}");
    let o = hyperslice(
        dir.path(),
        &[
            "render", "--color", "never", "dark.4ds", "-o", "dark.png", "--size", "4x4", "--spp",
            "1",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("[W0005]"), "{err}");
    // Lit by the sky, by a lamp, by an emission, or by a material map that may emit: no word.
    for lit in [
        "sky = rgb(0.1)\nobject ball { shape = hypersphere(1) }",
        "object lamp { shape = hypersphere(1) material = light() }",
        "object ball { shape = hypersphere(1) material = diffuse(emission: rgb(0.5)) }",
        "object ball { shape = hypersphere(1) material = |p, n| if p.x > 0 { light() } else { diffuse() } }",
        "object ball { shape = hypersphere(1) material = |p, n| diffuse(emission: rgb(p.x)) }",
    ] {
        std::fs::write(dir.path().join("lit.4ds"), lit).expect("written");
        let o = hyperslice(dir.path(), &["check", "--color", "never", "lit.4ds"]);
        let err = stderr(&o);
        assert!(o.status.success() && !err.contains("W0005"), "{lit}: {err}");
    }
    // A map that only chooses between materials that cannot emit is certain to be dark.
    std::fs::write(
        dir.path().join("map.4ds"),
        "object ball { shape = hypersphere(1) material = |p, n| if p.x > 0 { mirror() } else { diffuse(albedo: rgb(p.y)) } }",
    )
    .expect("written");
    let o = hyperslice(dir.path(), &["check", "--color", "never", "map.4ds"]);
    assert!(stderr(&o).contains("[W0005]"), "{}", stderr(&o));
}

/// A flag takes the values its scene setting takes, and a refusal gives the value and the
/// range; a negative number gets the range, not clap's `-- -1` tip; a duration needs its unit.
#[test]
fn flags_take_the_ranges_of_the_scene_settings() {
    let dir = scene_dir();
    for (flag, value, says) in [
        (
            "--spp",
            "-1",
            "`-1` is out of range: spp must be a whole number from 1 to 1000000",
        ),
        (
            "--spp=-1",
            "",
            "`-1` is out of range: spp must be a whole number from 1 to 1000000",
        ),
        (
            "--spp",
            "1.5",
            "`1.5` is not a whole number: spp must be a whole number from 1 to 1000000",
        ),
        (
            "--fps",
            "1000",
            "`1000` is out of range: fps must be a number in (0, 100]",
        ),
        (
            "--fps",
            "-2",
            "`-2` is out of range: fps must be a number in (0, 100]",
        ),
        (
            "--frames",
            "0",
            "frames must be a whole number from 1 to 10000",
        ),
        (
            "--bounces",
            "-1",
            "bounces must be a whole number from 0 to 1000",
        ),
        (
            "--max-steps",
            "0",
            "max_steps must be a whole number from 1 to 1000000",
        ),
        (
            "--threads",
            "2000",
            "threads must be a whole number from 0 to 1024",
        ),
        (
            "--exposure",
            "0",
            "exposure must be a number in (0, 1000000]",
        ),
        ("--epsilon", "2", "epsilon must be a number in (0, 1]"),
        (
            "--seed",
            "-1",
            "seed must be a whole number from 0 to 9007199254740992",
        ),
        (
            "--size",
            "-4x3",
            "each side of the image must be a whole number from 1 to 16384",
        ),
        ("--time-budget", "5", "`5` has no unit; write 5s"),
        (
            "--time-budget",
            "0s",
            "`0s` is out of range: a duration must be more than 0s",
        ),
        ("--time-budget", "-1s", "`-1s` is out of range"),
    ] {
        let args: Vec<&str> = ["render", "scene.4ds", flag, value]
            .into_iter()
            .filter(|a| !a.is_empty())
            .collect();
        let o = hyperslice(dir.path(), &args);
        let err = stderr(&o);
        assert!(!o.status.success(), "{flag} {value}: {err}");
        assert!(err.contains(says), "{flag} {value}: {err}");
        assert!(
            !err.contains("as a value"),
            "{flag} {value}: clap's tip in {err}"
        );
    }
    // The scene's own settings say the same.
    std::fs::write(
        dir.path().join("fast.4ds"),
        "render { fps = 1000 }\nsky = rgb(1)\nobject b { shape = hypersphere(1) }",
    )
    .unwrap();
    let o = hyperslice(dir.path(), &["check", "--color", "never", "fast.4ds"]);
    assert!(
        stderr(&o).contains("this is 1000, but fps must lie in (0, 100]"),
        "{}",
        stderr(&o)
    );
}

/// A size the machine cannot hold is refused at once, with the memory it needs and what to do,
/// and leaves no films folder behind (the folder appears with the first film).
#[test]
fn refuses_a_render_too_large_for_memory() {
    let dir = scene_dir();
    let started = std::time::Instant::now();
    // 16384 x 16384 with 100 frames denoised across: over 500 GiB.
    let o = hyperslice(
        dir.path(),
        &[
            "render",
            "scene.4ds",
            "-o",
            "huge.gif",
            "--size",
            "16384x16384",
            "--frames",
            "100",
        ],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        started.elapsed().as_secs() < 20,
        "took {:?}",
        started.elapsed()
    );
    assert!(err.contains("render needs about"), "{err}");
    assert!(err.contains("GiB of memory"), "{err}");
    assert!(err.contains("--size"), "{err}");
    assert_eq!(files(dir.path()), ["scene.4ds"]);
    // A render that fits makes its films folder only to write films, and removes it after.
    let o = hyperslice(
        dir.path(),
        &[
            "render",
            "scene.4ds",
            "-o",
            "small.png",
            "--size",
            "8x6",
            "--spp",
            "1",
            "--frames",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(files(dir.path()), ["scene.4ds", "small.png"]);
}

/// Small things a new user meets: `check` sums up a file with errors, a frame range is echoed
/// as written, the printed scene spells settings as the language does, `.5` gets a hint, and
/// the maths functions take what the reference says.
#[test]
fn rough_edges() {
    let dir = scene_dir();
    let d = dir.path();
    std::fs::write(
        d.join("bad.4ds"),
        "let unused = 1\nobject b { shape = hypersfere(1) }\nobject c { shape = hypersfere(2) }\n",
    )
    .unwrap();
    let o = hyperslice(d, &["check", "--color", "never", "bad.4ds"]);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(err.contains("bad.4ds: error: 2 errors, 1 warning"), "{err}");
    std::fs::write(d.join("dot.4ds"), "let half = .5\n").unwrap();
    let o = hyperslice(d, &["check", "--color", "never", "dot.4ds"]);
    let err = stderr(&o);
    assert!(err.contains("write `0.5`"), "{err}");
    assert!(err.contains("dot.4ds: error: 1 error\n"), "{err}");

    let o = hyperslice(
        d,
        &[
            "render",
            "scene.4ds",
            "-o",
            "r.png",
            "--size",
            "8x6",
            "--spp",
            "1",
            "--frame-range",
            "0..=1",
        ],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("frames 0..=1 of 3"), "{err}");
    let o = hyperslice(d, &["render", "scene.4ds", "--frame-range", "2..=5"]);
    let err = stderr(&o);
    assert!(
        err.contains("frames 2..=5 are not all in the animation"),
        "{err}"
    );

    let o = hyperslice(d, &["compile", "scene.4ds", "--emit", "scene"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("denoise \"atrous\"  quality \"custom\""),
        "{out}"
    );

    let docs = std::fs::read_to_string("docs/language.md").unwrap();
    assert!(
        docs.contains(
            "| `sqrt(x)`, `exp(x)`, `log(x)` | `num` (or `vec4`, componentwise) | same type |"
        ),
        "the reference's row of sqrt, exp and log"
    );
    let c = hyperslice::Compilation::from_source(
        "maths.4ds",
        "sky = rgb(1)\nobject b { shape = hypersphere(1) |> translate(sqrt([1, 4, 9, 16]) + exp([0, 0, 0, 0]) + log([1, 1, 1, 1])) }",
    );
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
}

#[test]
fn draft_quality_does_not_cut_the_lattices_channels() {
    // Draft trades noise for time (fewer samples and bounces, a coarser epsilon); the step
    // limit it once lowered to 200 instead ended the rays along the D4 lattice's channels,
    // black crosses over the README's example (236 segments here, 34 at the default 1000).
    let dir = scene_dir();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/d4_packing.4ds");
    let scene = scene.to_str().expect("a UTF-8 path");
    let o = hyperslice(
        dir.path(),
        &[
            "render",
            scene,
            "-o",
            "d4.gif",
            "--size",
            "64x48",
            "--frames",
            "3",
            "--quality",
            "draft",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let lost: u64 = err
        .lines()
        .find_map(|l| {
            l.strip_prefix("warning: ")?
                .split_once(" ray segments ran out")
        })
        .map(|(n, _)| n)
        .map_or(0, |n| n.replace(',', "").parse().expect("a count"));
    // 36,864 samples: fewer than 1 in 500 of them end out of steps.
    assert!(lost * 500 < 36_864, "{lost} segments out of steps:\n{err}");
}
