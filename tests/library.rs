//! The embedding API: a compile failure as an error, a render stopped from its progress
//! callback, frames written through the facade, and a long render's job refusing bad input.

use hyperslice::{Compilation, Error, Monitor, RenderOptions};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

const SCENE: &str = "render { size = 32 x 24  frames = 4  spp = 8 }
object ball { shape = hypersphere(1) }
object lamp { shape = hypersphere(0.5) |> translate([1, 2, -1, 0]) material = light(intensity: 5) }";

#[test]
fn a_failed_compile_is_an_error_with_its_diagnostics() {
    let c = Compilation::from_source("bad.4ds", "object o { shape = hypersphre(1) }");
    let e = c.into_scene().map(|_| ()).unwrap_err();
    let message = e.to_string();
    let Error::Compile {
        scene, diagnostics, ..
    } = e
    else {
        panic!("expected a compile error, got {message}");
    };
    assert_eq!(scene, "bad.4ds");
    assert!(diagnostics.iter().any(|d| d.is_error()));
    assert!(message.contains("hypersphere"), "{message}");
    let missing = Compilation::from_path(std::path::Path::new("no/such/scene.4ds"));
    let err = missing.into_scene().map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("cannot read"), "{err}");
}

#[test]
fn a_render_stops_when_cancelled() {
    let scene = Compilation::from_source("s.4ds", SCENE)
        .into_scene()
        .expect("compiles");
    let cancel = AtomicBool::new(false);
    let seen = AtomicU64::new(0);
    let progress = |n: u64| {
        // Stop after the first piece of work reports.
        seen.fetch_add(n, Ordering::Relaxed);
        cancel.store(true, Ordering::Relaxed);
    };
    let monitor = Monitor {
        progress: &progress,
        cancel: Some(&cancel),
    };
    let options = RenderOptions {
        threads: Some(1),
        ..RenderOptions::default()
    };
    let result = hyperslice::render(&scene, &options, monitor);
    assert!(matches!(result, Err(Error::Cancelled)), "not cancelled");
    let full = 32 * 24 * 4 * 8;
    let done = seen.load(Ordering::Relaxed);
    assert!(
        done > 0 && done < full / 4,
        "{done} of {full} samples taken"
    );
}

#[test]
fn rendered_frames_are_written_through_the_facade() {
    let scene = Compilation::from_source("s.4ds", SCENE)
        .into_scene()
        .expect("compiles");
    let progress = |_: u64| {};
    let monitor = Monitor {
        progress: &progress,
        cancel: None,
    };
    let rendered = hyperslice::render(&scene, &RenderOptions::default(), monitor).expect("renders");
    assert_eq!(rendered.frames.len(), 4);
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("out.gif");
    hyperslice::write(&path, &rendered, &scene).expect("written");
    let decoder = gif::DecodeOptions::new();
    let mut d = decoder
        .read_info(std::fs::File::open(&path).expect("opened"))
        .expect("a gif");
    let mut frames = 0;
    while d.read_next_frame().expect("a frame").is_some() {
        frames += 1;
    }
    assert_eq!(frames, 4);
}

#[test]
fn a_job_refuses_frames_and_shards_outside_the_render() {
    use hyperslice::farm::job::{Frames, Job};
    use hyperslice::farm::refusal::Refusal;
    let scene = Compilation::from_source("s.4ds", SCENE)
        .into_scene()
        .expect("compiles");
    let dir = tempfile::tempdir().expect("temp dir");
    let job = Job::new(scene, "s.4ds", dir.path().join("out.png"));
    // Refusals are structured, and say what to change in the library's terms: the scene's
    // settings, not the command line's flags.
    let refused = |job: &Job| match job.run(&mut (), None) {
        Err(Error::Refused(r)) => {
            let m = r.to_string();
            assert!(!m.contains("--"), "a library refusal names a flag: {m}");
            (r, m)
        }
        other => panic!("not refused: {other:?}"),
    };
    let mut late = job.clone();
    late.frames = Frames::Range("2..9".parse().expect("a range"));
    let (r, m) = refused(&late);
    assert!(
        matches!(r, Refusal::FramesOutside { frames: 4, .. }),
        "{r:?}"
    );
    assert!(m.starts_with("frames 2..9 are not all in the animation: it has 4 frames"));
    assert!(m.contains("set the scene's `frames`"), "{m}");
    let mut beyond = job.clone();
    beyond.frames = Frames::One(4);
    let (r, m) = refused(&beyond);
    assert!(
        matches!(
            r,
            Refusal::FrameOutside {
                frame: 4,
                frames: 4
            }
        ),
        "{r:?}"
    );
    assert!(m.starts_with("frame 4 is not in the animation"));
    let mut shard = job;
    shard.shard = (2, 2);
    let (r, m) = refused(&shard);
    assert!(matches!(r, Refusal::Shard { k: 2, n: 2 }), "{r:?}");
    assert!(m.contains("shard 2/2 is not a part of a render"));
    assert_eq!(std::fs::read_dir(dir.path()).expect("listed").count(), 0);
}
