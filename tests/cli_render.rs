//! `hyperslice render` end to end: files written, overrides applied, and every bad request
//! refused with a clear message before any rendering starts.

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
