//! Long renders as a render farm runs them: frame ranges, films, resume after an interrupt,
//! shards merged, fingerprints, and what is left on disk.

mod common;

use common::{LIT_BALL, hyperslice, scene_dir};
use hyperslice::Compilation;
use hyperslice::render::driver::{self, MemoryStore, Monitor, Options, Store};
use std::path::Path;
use std::process::Output;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: Output) -> String {
    assert!(o.status.success(), "{}", stderr(&o));
    stderr(&o)
}

fn read(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Every file under `dir`, relative, sorted (hidden ones too).
fn tree(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(dir).expect("listed") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(p.strip_prefix(base).unwrap().display().to_string());
            }
        }
    }
    let mut v = vec![];
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// `hyperslice render scene.4ds` at a tiny size, 4 spp and 5 frames unless `extra` says
/// otherwise.
fn render(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["render", "scene.4ds", "--size", "20x14"];
    for (flag, default) in [("--spp", "4"), ("--frames", "5")] {
        if !extra.contains(&flag) {
            args.extend([flag, default]);
        }
    }
    args.extend(extra);
    hyperslice(dir, &args)
}

/// Two files hold the same bytes (without printing them when they do not).
fn same(dir: &Path, a: &str, b: &str) -> bool {
    read(dir, a) == read(dir, b)
}

#[test]
fn frame_ranges_are_the_same_frames_as_the_whole_render() {
    let dir = scene_dir();
    let d = dir.path();
    ok(render(d, &["-o", "all.png", "--denoise", "none"]));
    let err = ok(render(
        d,
        &[
            "-o",
            "part.png",
            "--denoise",
            "none",
            "--frame-range",
            "1..3",
        ],
    ));
    assert!(err.contains("frames 1..3 of 5"), "{err}");
    ok(render(
        d,
        &[
            "-o",
            "incl.png",
            "--denoise",
            "none",
            "--frame-range",
            "3..=4",
        ],
    ));
    ok(render(
        d,
        &["-o", "one.png", "--denoise", "none", "--frame", "2"],
    ));
    for (file, frame) in [
        ("part_0001.png", 1),
        ("part_0002.png", 2),
        ("incl_0003.png", 3),
        ("incl_0004.png", 4),
        ("one_0002.png", 2),
    ] {
        assert!(same(d, file, &format!("all_{frame:04}.png")), "{file}");
    }
    assert!(!d.join("part_0000.png").exists() && !d.join("part_0003.png").exists());
    // Films of a range are the whole render's films, bit for bit.
    ok(render(d, &["-o", "a.gif", "--films", "fa"]));
    ok(render(d, &["-o", "b.gif", "--films", "fb", "--frame", "3"]));
    let sums = |p: &str| {
        hyperslice::film::file::FilmFile::read(&d.join(p))
            .expect("a film")
            .sums
    };
    assert_eq!(sums("fa/frame_0003.exr"), sums("fb/frame_0003.exr"));

    let o = render(d, &["-o", "x.png", "--frame-range", "4..9"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("frames 4..9 are not all in the animation: it has 5 frames"),
        "{err}"
    );
    let o = render(d, &["-o", "x.png", "--frame-range", "3..3"]);
    assert!(stderr(&o).contains("holds no frames"), "{}", stderr(&o));
}

#[test]
fn frame_shards_merge_into_the_same_bytes() {
    let dir = scene_dir();
    let d = dir.path();
    ok(render(d, &["-o", "one.gif"]));
    for k in 0..3 {
        let shard = format!("{k}/3");
        let err = ok(render(d, &["--shard", &shard, "--films", &format!("s{k}")]));
        assert!(err.contains(&format!("rendered shard {k}/3")), "{err}");
    }
    // Shards may keep their films apart (one directory each) or share one.
    let err = ok(hyperslice(
        d,
        &["merge", "s0", "s1", "s2", "-o", "merged.gif"],
    ));
    assert!(err.contains("3 shards"), "{err}");
    // `merge` reports the GIF's quantisation as `render` does.
    assert!(err.contains("GIF quantisation: PSNR"), "{err}");
    assert!(same(d, "merged.gif", "one.gif"));
    // No image is written by a shard, and the shards' films stay.
    assert!(!d.join("scene.gif").exists());
    assert_eq!(tree(&d.join("s0")), ["frame_0000.exr"]);
}

/// A render keeps the denoiser's scales of each finished frame in its film's header, and
/// finishing takes them from there instead of reading every film once more: the same GIF as
/// finishing films whose headers lack them (rendered without a denoiser, merged with one),
/// which reads them all first. The scene is 1e24 times too bright (and exposed down again):
/// its colours' `f32` squares overflow at the wrong scales (zero scales in the headers make
/// another GIF), where the filter of a scene of ordinary brightness gives the same bytes at
/// any scale.
#[test]
fn scales_from_the_headers_finish_as_a_pass_over_the_films_does() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    let scene = "render { size = 20 x 14  frames = 5  spp = 4  exposure = 1e-24 }
        sky = rgb(0.6e24, 0.7e24, 0.9e24)
        object ball { shape = hypersphere(1) material = diffuse(albedo: rgb(0.8, 0.3, 0.2)) }
        object lamp { shape = hypersphere(0.5) |> translate([1, 2, 0, 0])
          material = light(intensity: 5e24) }";
    std::fs::write(d.join("scene.4ds"), scene).expect("scene written");
    ok(render(
        d,
        &["-o", "headers.gif", "--films", "fa", "--denoise", "atrous"],
    ));
    ok(render(
        d,
        &["-o", "none.gif", "--films", "fb", "--denoise", "none"],
    ));
    let header = |p: &str| hyperslice::film::file::read_header(&d.join(p)).expect("a film");
    assert!(header("fa/frame_0002.exr").contains("\"scales\""));
    assert!(!header("fb/frame_0002.exr").contains("\"scales\""));
    ok(hyperslice(
        d,
        &["merge", "fb", "--denoise", "atrous", "-o", "pass.gif"],
    ));
    assert!(same(d, "headers.gif", "pass.gif"));
    assert!(!same(d, "headers.gif", "none.gif"));
}

#[test]
fn sample_shards_merge_within_rounding() {
    let dir = scene_dir();
    let d = dir.path();
    let flags = ["--frames", "1", "--denoise", "none"];
    let mut whole = vec!["-o", "one.exr"];
    whole.extend(flags);
    ok(render(d, &whole));
    for k in 0..2 {
        let shard = format!("{k}/2");
        let mut args = vec!["--shard", &shard, "--films", "films"];
        args.extend(flags);
        let err = ok(render(d, &args));
        assert!(
            err.contains(&format!("samples {}..{}", 2 * k, 2 * k + 2)),
            "{err}"
        );
    }
    assert_eq!(
        tree(&d.join("films")),
        ["frame_0000.samples_0-2.exr", "frame_0000.samples_2-4.exr"]
    );
    ok(hyperslice(d, &["merge", "films", "-o", "merged.exr"]));
    let pixels = |name: &str| -> Vec<f32> {
        let img = exr::prelude::read_first_rgba_layer_from_file(
            d.join(name),
            |res, _| vec![0f32; res.width() * res.height() * 3],
            |v: &mut Vec<f32>, p, (r, g, b, _): (f32, f32, f32, f32)| {
                let i = 3 * (p.y() * 20 + p.x());
                v[i..i + 3].copy_from_slice(&[r, g, b]);
            },
        )
        .expect("an EXR");
        img.layer_data.channel_data.pixels
    };
    let (a, b) = (pixels("one.exr"), pixels("merged.exr"));
    assert_eq!(a.len(), 20 * 14 * 3);
    let mut worst = 0f32;
    for (x, y) in a.iter().zip(&b) {
        worst = worst.max((x - y).abs() / x.abs().max(1e-3));
    }
    assert!(worst <= 1e-6, "largest relative difference {worst}");
    // Sums in another order differ in the last bits, so the files are not compared whole.
}

#[test]
fn merge_refuses_missing_unfinished_and_foreign_shards() {
    let dir = scene_dir();
    let d = dir.path();
    for k in [0, 2] {
        ok(render(
            d,
            &["--shard", &format!("{k}/3"), "--films", "films"],
        ));
    }
    let o = hyperslice(d, &["merge", "films", "-o", "m.gif"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("the shards are not complete"), "{err}");
    assert!(
        err.contains("frame_0001.exr is missing (shard 1/3 renders it)"),
        "{err}"
    );
    assert!(!d.join("m.gif").exists());
    // A shard of other settings is refused when it starts, not only at merge.
    let o = render(d, &["--shard", "1/3", "--films", "films", "--spp", "3"]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("spp 4") && err.contains("spp 3"), "{err}");
    assert!(!d.join("films/frame_0001.exr").exists(), "{err}");
    // So is one split another number of ways.
    let o = render(d, &["--shard", "1/4", "--films", "films"]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("in 4 shards") && err.contains("in 3 shards"),
        "{err}"
    );
    // A shard of another render (other samples) is refused, saying what differs.
    ok(render(
        d,
        &["--shard", "1/3", "--films", "other", "--spp", "3"],
    ));
    let o = hyperslice(d, &["merge", "films", "other", "-o", "m.gif"]);
    let err = stderr(&o);
    assert!(err.contains("another scene or other settings"), "{err}");
    assert!(err.contains("spp 4") && err.contains("spp 3"), "{err}");
    let o = hyperslice(d, &["merge", "empty", "-o", "m.gif"]);
    assert!(
        stderr(&o).contains("cannot read film directory `empty`"),
        "{}",
        stderr(&o)
    );
    std::fs::create_dir(d.join("empty")).unwrap();
    let o = hyperslice(d, &["merge", "empty", "-o", "m.gif"]);
    assert!(stderr(&o).contains("no film files"), "{}", stderr(&o));
}

#[test]
fn a_film_directory_of_another_render_is_refused() {
    let dir = scene_dir();
    let d = dir.path();
    ok(render(d, &["-o", "a.gif", "--films", "films"]));
    // Finishing settings do not change the films: a new exposure reuses them.
    let err = ok(render(
        d,
        &["-o", "b.gif", "--films", "films", "--exposure", "2"],
    ));
    assert!(
        err.contains("resuming from films: 5 of 5 frames finished"),
        "{err}"
    );
    assert!(
        !err.contains("rendered in") || err.contains("0 samples"),
        "{err}"
    );
    // Anything that changes the pixels is refused before any work.
    let o = render(d, &["-o", "c.gif", "--films", "films", "--seed", "7"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("films holds the films of another scene or other settings"),
        "{err}"
    );
    assert!(err.contains("seed 7") && err.contains("seed 0"), "{err}");
    assert!(
        err.contains("pass --restart to discard them (or render into another --films directory)"),
        "{err}"
    );
    assert!(!d.join("c.gif").exists());
    // A time budget groups samples into other passes: its films are not these.
    let o = render(
        d,
        &["-o", "c.gif", "--films", "films", "--time-budget", "1m"],
    );
    let err = stderr(&o);
    assert!(
        err.contains("progressive false") && err.contains("progressive true"),
        "{err}"
    );
    // The hidden films of an interrupted render are its work: another setting is refused,
    // naming it, and they are discarded only with --restart.
    ok(render(d, &["-o", "h.gif", "--films", ".h.gif.films"]));
    let o = render(d, &["-o", "h.gif", "--seed", "7"]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(".h.gif.films holds the films of another scene or other settings"),
        "{err}"
    );
    assert!(err.contains("seed 7") && err.contains("--restart"), "{err}");
    assert_eq!(tree(&d.join(".h.gif.films")).len(), 5);
    let err = ok(render(d, &["-o", "h.gif", "--seed", "7", "--restart"]));
    assert!(!err.contains("resuming"), "{err}");
    assert!(!d.join(".h.gif.films").exists());
    let o = render(d, &["-o", "x.gif", "--frame-range", "0..=4294967295"]);
    assert!(
        stderr(&o).contains("is not a frame range"),
        "{}",
        stderr(&o)
    );
    std::fs::write(
        d.join("scene2.4ds"),
        LIT_BALL.replace("0.8, 0.3", "0.7, 0.3"),
    )
    .unwrap();
    let args = ["render", "scene2.4ds", "-o", "d.gif", "--films", "films"];
    let o = hyperslice(
        d,
        &[
            &args[..],
            &["--size", "20x14", "--spp", "4", "--frames", "5"],
        ]
        .concat(),
    );
    assert!(stderr(&o).contains("another scene"), "{}", stderr(&o));
    // In a named --films folder too, --restart discards this render's films.
    let err = ok(render(
        d,
        &[
            "-o",
            "c.gif",
            "--films",
            "films",
            "--seed",
            "7",
            "--restart",
        ],
    ));
    assert!(!err.contains("resuming"), "{err}");
}

/// Cancelling from the progress callback at several points, then resuming from what was
/// kept, gives exactly the sums of an uninterrupted render: passes are taken whole per tile
/// and which pixels take the next pass is judged from the sums alone.
#[test]
fn resumed_renders_add_exactly_the_missing_samples() {
    for threshold in [None, Some(0.05)] {
        let src = format!(
            "render {{ size = 40 x 24  frames = 3  spp = 40  denoise = \"none\" }}\n{}",
            LIT_BALL.lines().skip(1).collect::<Vec<_>>().join("\n")
        );
        let scene = Compilation::from_source("s.4ds", &src)
            .into_scene()
            .expect("scene");
        let options = Options {
            threads: Some(2),
            noise_threshold: threshold,
            ..Options::default()
        };
        let frames = hyperslice::compile::Frames::new(&scene);
        let units = driver::whole(&frames.shot);
        let none = &|_: u64| {};
        let reference = MemoryStore::default();
        let monitor = Monitor {
            progress: none,
            cancel: None,
        };
        driver::render_units(&frames, &options, &units, &reference, monitor).expect("rendered");
        let reference = reference.into_map();
        for stop_after in [1_000u64, 9_000, 30_000] {
            let store = MemoryStore::default();
            let cancel = AtomicBool::new(false);
            let taken = AtomicU64::new(0);
            let progress = |n: u64| {
                if taken.fetch_add(n, Ordering::Relaxed) + n >= stop_after {
                    cancel.store(true, Ordering::Relaxed);
                }
            };
            let monitor = Monitor {
                progress: &progress,
                cancel: Some(&cancel),
            };
            let first = driver::render_units(&frames, &options, &units, &store, monitor);
            assert!(matches!(first, Err(hyperslice::Error::Cancelled)));
            let kept = store
                .load(&units[0])
                .expect("loaded")
                .expect("frame 0 kept");
            assert!(!kept.complete);
            let monitor = Monitor {
                progress: none,
                cancel: None,
            };
            driver::render_units(&frames, &options, &units, &store, monitor).expect("resumed");
            let resumed = store.into_map();
            for (unit, want) in &reference {
                let got = &resumed[unit];
                assert!(got.complete);
                assert!(
                    got.sums == want.sums,
                    "frame {} after {stop_after}",
                    unit.frame
                );
                assert_eq!(got.stats.samples, want.stats.samples);
            }
        }
    }
}

/// A real interrupt: the render exits 130 having saved its work and left no temporary file,
/// and the same command again writes the bytes of an uninterrupted render.
#[cfg(unix)]
#[test]
fn an_interrupted_render_resumes_to_the_same_bytes() {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let dir = scene_dir();
    let d = dir.path();
    // Long enough (2 to 3 s on the 2-core development machine) that the interrupt lands
    // mid-render: at 96 spp it took 0.6 s, and a faster marcher had it finish first.
    let args = [
        "render",
        "scene.4ds",
        "--size",
        "96x64",
        "--spp",
        "384",
        "--frames",
        "3",
        "--threads",
        "1",
        "-o",
        "out.gif",
    ];
    let start = Instant::now();
    let child = Command::new(env!("CARGO_BIN_EXE_hyperslice"))
        .current_dir(d)
        .args(args)
        .stderr(Stdio::piped())
        .spawn()
        .expect("started");
    std::thread::sleep(Duration::from_millis(700));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill ran");
    assert!(status.success());
    let out = child.wait_with_output().expect("waited");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("run the same command again to resume"),
        "{err}"
    );
    let first = start.elapsed();
    let left = tree(d);
    assert!(left.iter().all(|f| !f.contains(".tmp")), "{left:?}");
    assert!(!d.join("out.gif").exists());
    assert!(
        left.iter()
            .any(|f| f.starts_with(".out.gif.films/frame_0000")),
        "{left:?}"
    );

    let err = ok(hyperslice(d, &args));
    assert!(err.contains("resuming from .out.gif.films"), "{err}");
    // The hidden films are gone once the output is written.
    assert_eq!(tree(d), ["out.gif", "scene.4ds"]);
    let mut fresh = args.to_vec();
    let last = fresh.len() - 1;
    fresh[last] = "fresh.gif";
    ok(hyperslice(d, &fresh));
    assert!(same(d, "out.gif", "fresh.gif"));
    assert!(first < Duration::from_secs(60));
}

/// Peak memory (resident set) of a `hyperslice` run in `dir`, in kilobytes, from the kernel's
/// own count for the child (`wait4`).
#[cfg(target_os = "linux")]
#[allow(clippy::zombie_processes)] // reaped by `wait4`, which `Child::wait` cannot stand in for
fn peak_kb(dir: &Path, args: &[&str]) -> i64 {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_hyperslice"))
        .current_dir(dir)
        .args(args)
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("started");
    let mut status = 0;
    // SAFETY: `rusage` is plain data, filled in by the call; the child is ours and unwaited.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32);
    assert!(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0);
    usage.ru_maxrss
}

/// Frames stream through the renderer, the denoiser and the encoder: three times the frames
/// take about the same memory (each frame here is 300 KB of radiance sums and 2 MB of
/// denoiser state). Both renders have more frames than the denoiser's window and the film
/// read ahead of it, which hold the same memory however many frames follow; against 4
/// frames, which fill neither, 16 took up to 1.5 times the memory on a loaded machine.
#[cfg(target_os = "linux")]
#[test]
fn peak_memory_does_not_grow_with_the_frames() {
    let dir = scene_dir();
    let d = dir.path();
    let run = |frames: &str, out: &str| {
        let args = [
            "render",
            "scene.4ds",
            "--size",
            "256x192",
            "--spp",
            "1",
            "--frames",
            frames,
            "-o",
            out,
        ];
        peak_kb(d, &args)
    };
    let eight = run("8", "eight.gif");
    let many = run("24", "many.gif");
    let ratio = many as f64 / eight as f64;
    eprintln!("peak memory: 8 frames {eight} KB, 24 frames {many} KB, ratio {ratio:.2}");
    assert!(
        ratio < 1.5,
        "24 frames take {ratio:.2} times the memory of 8"
    );
}

/// Films remember which marcher made them: each marcher's images differ in the last bits, so a
/// film of one must not be resumed or merged into a render with another (the default, auto,
/// included: it was cells before).
#[test]
fn each_marcher_has_its_own_film_fingerprint() {
    use hyperslice::RenderOptions;
    use hyperslice::farm::Fingerprint;
    use hyperslice::render::march::MarcherKind;
    let scene = hyperslice::Compilation::from_source(
        "ball.4ds",
        "object ball { shape = hypersphere(1) material = diffuse() }",
    )
    .into_scene()
    .expect("a scene");
    let kinds = [
        MarcherKind::Auto,
        MarcherKind::Cells,
        MarcherKind::Whole,
        MarcherKind::Plain,
    ];
    let digests: Vec<String> = (kinds.into_iter())
        .map(|marcher| {
            let options = RenderOptions {
                marcher,
                ..RenderOptions::default()
            };
            Fingerprint::of(&scene, &options).digest
        })
        .collect();
    for (i, a) in digests.iter().enumerate() {
        assert!(
            !digests[..i].contains(a),
            "{} shares a fingerprint",
            kinds[i].name()
        );
    }
}
