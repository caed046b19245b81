use super::files::{io_error, is_numbered_name, write_temp};
use super::sink::Kind;
use super::*;
use std::ffi::OsStr;
use std::fs;
use std::io::Write;
use std::path::PathBuf;

fn settings() -> OutputSettings {
    OutputSettings {
        exposure: 1.0,
        fps: 25.0,
    }
}

/// A smooth colour gradient with far more than 256 colours, varying with `t`.
fn gradient(width: usize, height: usize, t: f32) -> HdrImage {
    HdrImage::from_fn(width, height, |x, y| {
        let u = x as f32 / (width - 1) as f32;
        let v = y as f32 / (height - 1) as f32;
        [
            2.0 * u * u,
            1.5 * v,
            0.2 + 0.8 * (1.0 - u) * (0.5 + 0.5 * (t + v).sin()),
        ]
    })
}

fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A GIF decoded into RGB frames.
struct Decoded {
    size: (u16, u16),
    frames: Vec<Vec<[u8; 3]>>,
    delays: Vec<u16>,
    repeat: ::gif::Repeat,
}

fn decode_gif(path: &Path) -> Decoded {
    let mut opts = ::gif::DecodeOptions::new();
    opts.set_color_output(::gif::ColorOutput::RGBA);
    let mut dec = opts.read_info(fs::File::open(path).unwrap()).unwrap();
    let (w, h) = (dec.width(), dec.height());
    let mut frames = Vec::new();
    let mut delays = Vec::new();
    while let Some(f) = dec.read_next_frame().unwrap() {
        assert_eq!((f.width, f.height, f.left, f.top), (w, h, 0, 0));
        delays.push(f.delay);
        frames.push(
            f.buffer
                .chunks_exact(4)
                .map(|p| [p[0], p[1], p[2]])
                .collect(),
        );
    }
    Decoded {
        size: (w, h),
        frames,
        delays,
        repeat: dec.repeat(),
    }
}

fn psnr_db(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    let sse: f64 = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] as f64 - q[k] as f64).powi(2)))
        .sum();
    10.0 * (255.0f64.powi(2) / (sse / (a.len() * 3) as f64)).log10()
}

#[test]
fn format_from_extension() {
    assert_eq!(Format::from_path(Path::new("a.gif")).unwrap(), Format::Gif);
    assert_eq!(
        Format::from_path(Path::new("a/b.PNG")).unwrap(),
        Format::Png
    );
    assert_eq!(Format::from_path(Path::new("c.Exr")).unwrap(), Format::Exr);
    let e = Format::from_path(Path::new("x.jpg")).unwrap_err();
    assert_eq!(
        e.to_string(),
        "unknown output format `.jpg` (expected .gif, .png or .exr)"
    );
    let e = Format::from_path(Path::new("noext")).unwrap_err();
    assert!(e.to_string().contains("`noext` has no extension"), "{e}");
}

#[test]
fn gif_gradient_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anim.gif");
    let frames: Vec<HdrImage> = (0..4).map(|i| gradient(96, 64, i as f32 * 0.7)).collect();
    let written = write(&path, &frames, &settings()).unwrap();
    assert_eq!(written.files, vec![path.clone()]);
    let psnr = written.gif_psnr.unwrap();
    assert!(psnr.is_finite() && psnr > 30.0, "psnr {psnr}");

    let Decoded {
        size,
        frames: decoded,
        delays,
        repeat,
    } = decode_gif(&path);
    assert_eq!(size, (96, 64));
    assert_eq!(decoded.len(), 4);
    assert_eq!(delays, vec![4; 4]);
    assert_eq!(repeat, ::gif::Repeat::Infinite);
    // The reported PSNR is what the decoded file really has.
    let mut total = 0.0;
    for (f, d) in frames.iter().zip(&decoded) {
        let reference = tonemap::to_srgb8(f, 1.0);
        let p = psnr_db(&reference, d);
        assert!(p > 30.0, "frame psnr {p}");
        total += p;
    }
    assert!((total / 4.0 - psnr).abs() < 1e-9);
    assert_eq!(listing(dir.path()), vec!["anim.gif"]);
}

#[test]
fn gif_with_few_colours_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("flat.GIF");
    let colours = [
        [0.0, 0.0, 0.0],
        [1.0, 0.2, 0.05],
        [0.1, 0.5, 3.0],
        [20.0; 3],
    ];
    let frames: Vec<HdrImage> = (0..3)
        .map(|i| HdrImage::from_fn(37, 11, |x, y| colours[(x / 5 + y + i) % 4]))
        .collect();
    let settings = OutputSettings {
        exposure: 0.5,
        fps: 1000.0,
    };
    let written = write(&path, &frames, &settings).unwrap();
    assert_eq!(written.gif_psnr, Some(f64::INFINITY));
    let Decoded {
        frames: decoded,
        delays,
        repeat,
        ..
    } = decode_gif(&path);
    assert_eq!(delays, vec![2; 3], "delay clamped to 2");
    assert_eq!(repeat, ::gif::Repeat::Infinite);
    for (f, d) in frames.iter().zip(&decoded) {
        assert_eq!(&tonemap::to_srgb8(f, 0.5), d);
    }
}

#[test]
fn gif_mixed_exact_and_dithered_frames() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mixed.gif");
    let frames = vec![gradient(64, 64, 0.0), HdrImage::new(64, 64)];
    let written = write(&path, &frames, &settings()).unwrap();
    let psnr = written.gif_psnr.unwrap();
    assert!(psnr.is_finite() && psnr > 30.0, "{psnr}");
}

#[test]
fn gif_rejects_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.gif");
    let mismatched = vec![HdrImage::new(4, 4), HdrImage::new(5, 4)];
    assert!(matches!(
        write(&path, &mismatched, &settings()),
        Err(OutputError::MismatchedFrames { frame: 1, .. })
    ));
    let frames = vec![HdrImage::new(4, 4)];
    for fps in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let s = OutputSettings { fps, ..settings() };
        assert!(matches!(
            write(&path, &frames, &s),
            Err(OutputError::InvalidSetting { name: "fps", .. })
        ));
    }
    let wide = vec![HdrImage::new(70_000, 1)];
    assert!(matches!(
        write(&path, &wide, &settings()),
        Err(OutputError::TooLarge { .. })
    ));
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn png_numbering_and_single_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shot.png");
    let frames: Vec<HdrImage> = (0..3).map(|i| gradient(20, 10, i as f32)).collect();
    let written = write(&path, &frames, &settings()).unwrap();
    let names = ["shot_0000.png", "shot_0001.png", "shot_0002.png"];
    assert_eq!(
        written.files,
        names.iter().map(|n| dir.path().join(n)).collect::<Vec<_>>()
    );
    assert_eq!(written.gif_psnr, None);
    assert_eq!(listing(dir.path()), names);
    for (f, file) in frames.iter().zip(&written.files) {
        let img = image::open(file).unwrap().into_rgb8();
        assert_eq!(img.dimensions(), (20, 10));
        let expected: Vec<u8> = tonemap::to_srgb8(f, 1.0).into_flattened();
        assert_eq!(img.into_raw(), expected);
    }

    let single = dir.path().join("one.png");
    let written = write(&single, &frames[..1], &settings()).unwrap();
    assert_eq!(written.files, vec![single.clone()]);
    assert!(single.is_file());
    assert!(!dir.path().join("one_0000.png").exists());
}

#[test]
fn exr_round_trips_linear_values() {
    use exr::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hdr.exr");
    let mut a = gradient(13, 7, 0.3);
    a.data[5] = [1e-8, 12345.678, 0.1];
    let b = gradient(13, 7, 1.1);
    let s = OutputSettings {
        exposure: 2.0,
        ..settings()
    };
    let written = write(&path, &[a.clone(), b.clone()], &s).unwrap();
    assert_eq!(
        written.files,
        vec![
            dir.path().join("hdr_0000.exr"),
            dir.path().join("hdr_0001.exr")
        ]
    );
    for (orig, file) in [a, b].iter().zip(&written.files) {
        let read = read_first_rgba_layer_from_file(
            file,
            |res, _| HdrImage::new(res.width(), res.height()),
            |img: &mut HdrImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width;
                img.data[pos.y() * w + pos.x()] = [r, g, b];
            },
        )
        .unwrap();
        let got = read.layer_data.channel_data.pixels;
        // Scaling by a power of two is exact in f32.
        let expected: Vec<[f32; 3]> = orig.data.iter().map(|p| p.map(|c| c * 2.0)).collect();
        assert_eq!((got.width, got.height), (13, 7));
        assert_eq!(got.data, expected);
    }
    assert_eq!(listing(dir.path()), vec!["hdr_0000.exr", "hdr_0001.exr"]);
}

#[test]
fn check_writable_accepts_and_rejects() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.4ds");
    fs::write(&scene, "scene").unwrap();

    let ok = dir.path().join("out.gif");
    assert_eq!(check_writable(&ok, &scene).unwrap(), Format::Gif);

    let missing = dir.path().join("nope").join("x.gif");
    let e = check_writable(&missing, &scene).unwrap_err();
    assert!(matches!(e, OutputError::MissingDirectory { .. }), "{e}");
    assert!(e.to_string().contains("does not exist"), "{e}");
    assert!(e.to_string().contains("x.gif"), "{e}");

    let e = check_writable(&dir.path().join("x.jpg"), &scene).unwrap_err();
    assert!(matches!(e, OutputError::UnknownFormat { .. }), "{e}");

    let e = check_writable(&scene, &scene).unwrap_err();
    assert!(matches!(e, OutputError::IsInput { .. }), "{e}");
    assert!(
        e.to_string()
            .ends_with("is the scene file; refusing to overwrite it")
    );
    // The same file by another spelling.
    let other = dir.path().join(".").join("scene.4ds");
    assert!(matches!(
        check_writable(&other, &scene),
        Err(OutputError::IsInput { .. })
    ));
    // Even when it has an image extension.
    let png_scene = dir.path().join("scene.png");
    fs::write(&png_scene, "scene").unwrap();
    assert!(matches!(
        check_writable(&png_scene, &png_scene),
        Err(OutputError::IsInput { .. })
    ));

    let sub = dir.path().join("frames.png");
    fs::create_dir(&sub).unwrap();
    assert!(matches!(
        check_writable(&sub, &scene),
        Err(OutputError::IsDirectory { .. })
    ));

    // The parent is a file, not a directory.
    let e = check_writable(&scene.join("x.png"), Path::new("elsewhere.4ds")).unwrap_err();
    assert!(matches!(e, OutputError::NotADirectory { .. }), "{e}");

    // Nothing was left behind by the probes.
    assert_eq!(
        listing(dir.path()),
        vec!["frames.png", "scene.4ds", "scene.png"]
    );
}

#[test]
fn write_rejects_bad_frames_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.gif", "a.png", "a.exr"] {
        let path = dir.path().join(name);
        assert!(matches!(
            write(&path, &[], &settings()),
            Err(OutputError::NoFrames { .. })
        ));
        for (w, h) in [(0, 5), (5, 0), (0, 0)] {
            assert!(matches!(
                write(&path, &[HdrImage::new(w, h)], &settings()),
                Err(OutputError::EmptyFrame { .. })
            ));
        }
        let bad = HdrImage {
            width: 3,
            height: 3,
            data: vec![[0.0; 3]; 8],
        };
        assert!(matches!(
            write(&path, &[bad], &settings()),
            Err(OutputError::BadFrameData { .. })
        ));
        let overflow = HdrImage {
            width: usize::MAX,
            height: 2,
            data: vec![],
        };
        assert!(matches!(
            write(&path, &[overflow], &settings()),
            Err(OutputError::ImpossibleSize { .. })
        ));
        let s = OutputSettings {
            exposure: f64::NAN,
            ..settings()
        };
        assert!(matches!(
            write(&path, &[HdrImage::new(2, 2)], &s),
            Err(OutputError::InvalidSetting { .. })
        ));
        let missing = dir.path().join("missing").join(name);
        assert!(matches!(
            write(&missing, &[HdrImage::new(2, 2)], &settings()),
            Err(OutputError::MissingDirectory { .. })
        ));
    }
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn writes_leave_no_temporary_files_and_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<HdrImage> = (0..2).map(|i| gradient(16, 16, i as f32)).collect();
    for _ in 0..2 {
        // Writing twice replaces the files in place.
        write(&dir.path().join("a.gif"), &frames, &settings()).unwrap();
        write(&dir.path().join("b.png"), &frames, &settings()).unwrap();
        write(&dir.path().join("c.exr"), &frames, &settings()).unwrap();
        write(&dir.path().join("d.png"), &frames[..1], &settings()).unwrap();
    }
    assert_eq!(
        listing(dir.path()),
        vec![
            "a.gif",
            "b_0000.png",
            "b_0001.png",
            "c_0000.exr",
            "c_0001.exr",
            "d.png"
        ]
    );
}

#[test]
fn special_values_do_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let weird = HdrImage::from_fn(300, 3, |x, _| match x % 5 {
        0 => [f32::NAN, f32::INFINITY, f32::NEG_INFINITY],
        1 => [-1.0, f32::MAX, f32::MIN_POSITIVE],
        _ => [x as f32 / 30.0, (x * x) as f32 / 9e4, 0.5],
    });
    let frames = vec![weird.clone(), weird];
    for name in ["w.gif", "w.png", "w.exr"] {
        write(&dir.path().join(name), &frames, &settings()).unwrap();
    }
    let huge = OutputSettings {
        exposure: 1e300,
        ..settings()
    };
    write(&dir.path().join("h.gif"), &frames, &huge).unwrap();
    // A 1x1 frame and a single-row frame.
    write(
        &dir.path().join("tiny.gif"),
        &[HdrImage::new(1, 1)],
        &settings(),
    )
    .unwrap();
    let row = HdrImage::from_fn(1000, 1, |x, _| {
        [x as f32 / 100.0, 0.3, 1.0 - x as f32 / 1e3]
    });
    let w = write(&dir.path().join("row.gif"), &[row], &settings()).unwrap();
    assert!(w.gif_psnr.unwrap() > 20.0);
}

#[test]
fn numbered_paths() {
    assert_eq!(
        numbered_path(Path::new("out/x.PNG"), 12),
        PathBuf::from("out/x_0012.PNG")
    );
    assert_eq!(
        numbered_path(Path::new("y.exr"), 12345),
        PathBuf::from("y_12345.exr")
    );
}

#[cfg(unix)]
fn mode(path: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    fs::metadata(path).unwrap().permissions().mode() & 0o7777
}

#[cfg(unix)]
#[test]
fn new_files_follow_the_umask() {
    let dir = tempfile::tempdir().unwrap();
    let expected = permissions::new_file_mode(permissions::umask());
    let frames: Vec<HdrImage> = (0..2).map(|i| gradient(8, 8, i as f32)).collect();
    let mut files = write(&dir.path().join("a.gif"), &frames, &settings())
        .unwrap()
        .files;
    files.extend(
        write(&dir.path().join("b.png"), &frames, &settings())
            .unwrap()
            .files,
    );
    files.extend(
        write(&dir.path().join("c.exr"), &frames[..1], &settings())
            .unwrap()
            .files,
    );
    let bytes = dir.path().join("d.txt");
    write_atomic(&bytes, b"text").unwrap();
    files.push(bytes);
    for file in &files {
        assert_eq!(mode(file), expected, "{}", file.display());
    }
}

#[cfg(unix)]
#[test]
fn new_file_mode_masks_0666() {
    assert_eq!(permissions::new_file_mode(0o022), 0o644);
    assert_eq!(permissions::new_file_mode(0o027), 0o640);
    assert_eq!(permissions::new_file_mode(0o077), 0o600);
    assert_eq!(permissions::new_file_mode(0), 0o666);
}

#[cfg(any(target_os = "linux", target_os = "android"))]
#[test]
fn umask_from_proc_status() {
    let status = "Name:\tx\nUmask:\t0027\nState:\tR (running)\n";
    assert_eq!(permissions::parse_status_umask(status), Some(0o027));
    assert_eq!(permissions::parse_status_umask("Name:\tx\n"), None);
    // This kernel reports it (4.7 and later), so no thread ever has the umask changed under it.
    let status = fs::read_to_string("/proc/self/status").unwrap();
    assert!(permissions::parse_status_umask(&status).is_some());
}

#[cfg(unix)]
#[test]
fn overwriting_keeps_the_mode() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let frames = vec![gradient(8, 8, 0.0)];
    for (name, m) in [
        ("a.gif", 0o640),
        ("b.png", 0o604),
        ("c.exr", 0o660),
        ("d.txt", 0o600),
    ] {
        let path = dir.path().join(name);
        fs::write(&path, "old").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(m)).unwrap();
        if name.ends_with(".txt") {
            write_atomic(&path, b"new").unwrap();
        } else {
            write(&path, &frames, &settings()).unwrap();
        }
        assert_ne!(fs::read(&path).unwrap(), b"old");
        assert_eq!(mode(&path), m, "{name}");
    }
}

/// A GIF as `write` encoded it before frames were streamed: every frame tone-mapped and
/// quantised first, then all encoded in one go. Streaming must not change a byte.
fn unstreamed_gif(frames: &[HdrImage], s: &OutputSettings) -> Vec<u8> {
    let (w, h) = (frames[0].width as u16, frames[0].height as u16);
    let quantised: Vec<gif::Quantised> = frames
        .iter()
        .map(|f| gif::quantise(&tonemap::to_srgb8(f, s.exposure), w as usize))
        .collect();
    let mut out = Vec::new();
    let mut encoder = ::gif::Encoder::new(&mut out, w, h, &[]).unwrap();
    encoder.set_repeat(::gif::Repeat::Infinite).unwrap();
    for q in &quantised {
        let palette: Vec<u8> = q.palette.iter().flatten().copied().collect();
        let mut frame =
            ::gif::Frame::from_palette_pixels(w, h, q.indices.as_slice(), palette, None);
        frame.delay = gif::frame_delay(s.fps);
        encoder.write_frame(&frame).unwrap();
    }
    encoder.into_inner().unwrap();
    out
}

/// More frames than one batch of one per thread, and a last batch that is not full; dithered
/// frames and frames with few enough colours to keep exactly.
fn animation() -> Vec<HdrImage> {
    let n = 2 * rayon::current_num_threads() + 1;
    (0..n)
        .map(|i| {
            if i % 3 == 1 {
                HdrImage::from_fn(40, 30, |x, y| {
                    [((x + i) / 8) as f32 * 0.2, (y / 6) as f32 * 0.3, 0.5]
                })
            } else {
                gradient(40, 30, i as f32 * 0.4)
            }
        })
        .collect()
}

#[test]
fn gif_write_matches_the_unstreamed_encoder() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anim.gif");
    let frames = animation();
    let s = OutputSettings {
        exposure: 1.3,
        fps: 12.0,
    };
    write(&path, &frames, &s).unwrap();
    assert!(fs::read(&path).unwrap() == unstreamed_gif(&frames, &s));
}

#[test]
fn gif_sink_streams_in_batches_and_matches_the_unstreamed_encoder() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anim.gif");
    let frames = animation();
    let s = settings();
    let mut sink = Sink::create(&path, &s, false).unwrap();
    for (i, f) in frames.iter().enumerate() {
        sink.push(i, f).unwrap();
        let Kind::Gif(gif) = &sink.kind else {
            panic!("a GIF sink writes from its first frame")
        };
        // Frames do not pile up: at most a batch short of one per thread waits.
        assert!(
            gif.pending.len() < gif.batch.max(2),
            "{} waiting",
            gif.pending.len()
        );
        // The output appears only when finished.
        assert!(!path.exists());
    }
    let written = sink.finish().unwrap();
    assert_eq!(written.files, vec![path.clone()]);
    assert!(fs::read(&path).unwrap() == unstreamed_gif(&frames, &s));
    let decoded = decode_gif(&path);
    assert_eq!(decoded.frames.len(), frames.len());
    assert_eq!(decoded.delays, vec![gif::frame_delay(s.fps); frames.len()]);
    // The mean PSNR over all frames, not just the last batch.
    let psnrs: Vec<f64> = frames
        .iter()
        .map(|f| gif::quantise(&tonemap::to_srgb8(f, s.exposure), f.width).psnr)
        .collect();
    assert_eq!(written.gif_psnr, Some(gif::mean_psnr(&psnrs)));
    assert_eq!(listing(dir.path()), vec!["anim.gif"]);
}

#[test]
fn png_and_exr_sinks_write_each_frame_when_pushed() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["png", "exr"] {
        let path = dir.path().join(format!("seq.{ext}"));
        let mut sink = Sink::create(&path, &settings(), true).unwrap();
        let mut expected = Vec::new();
        for index in [3, 4, 10] {
            sink.push(index, &gradient(12, 9, index as f32)).unwrap();
            let file = dir.path().join(format!("seq_{index:04}.{ext}"));
            assert!(file.is_file(), "{} written at once", file.display());
            expected.push(file);
        }
        let written = sink.finish().unwrap();
        assert_eq!(written.files, expected);
        assert_eq!(written.gif_psnr, None);
    }
    let png = image::open(dir.path().join("seq_0010.png"))
        .unwrap()
        .into_rgb8();
    assert_eq!(
        png.into_raw(),
        tonemap::to_srgb8(&gradient(12, 9, 10.0), 1.0).into_flattened()
    );

    // Not numbered: the one frame is the file itself, whatever its index.
    let single = dir.path().join("one.png");
    let mut sink = Sink::create(&single, &settings(), false).unwrap();
    sink.push(7, &gradient(4, 4, 0.0)).unwrap();
    assert!(matches!(
        sink.push(8, &gradient(4, 4, 1.0)),
        Err(OutputError::FrameOrder {
            frame: 8,
            previous: 7,
            ..
        })
    ));
    assert_eq!(sink.finish().unwrap().files, vec![single]);
    assert_eq!(
        listing(dir.path()),
        vec![
            "one.png",
            "seq_0003.exr",
            "seq_0003.png",
            "seq_0004.exr",
            "seq_0004.png",
            "seq_0010.exr",
            "seq_0010.png"
        ]
    );
}

#[test]
fn sinks_reject_frames_out_of_order() {
    let dir = tempfile::tempdir().unwrap();
    let frame = gradient(4, 4, 0.0);
    let mut png = Sink::create(&dir.path().join("a.png"), &settings(), true).unwrap();
    png.push(2, &frame).unwrap();
    for index in [2, 1] {
        let e = png.push(index, &frame).unwrap_err();
        assert!(
            matches!(e, OutputError::FrameOrder { previous: 2, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("cannot follow frame 2"), "{e}");
    }
    png.push(5, &frame).unwrap();

    // A GIF has no gaps.
    let mut gif = Sink::create(&dir.path().join("b.gif"), &settings(), true).unwrap();
    gif.push(4, &frame).unwrap();
    assert!(matches!(
        gif.push(6, &frame),
        Err(OutputError::FrameOrder {
            frame: 6,
            previous: 4,
            ..
        })
    ));
    gif.push(5, &frame).unwrap();
    assert_eq!(decode_gif_len(gif), 2);
}

fn decode_gif_len(sink: Sink) -> usize {
    let written = sink.finish().unwrap();
    decode_gif(&written.files[0]).frames.len()
}

#[test]
fn sinks_check_each_frame_and_stay_usable() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.gif");
    let mut sink = Sink::create(&path, &settings(), false).unwrap();
    sink.push(0, &HdrImage::new(4, 4)).unwrap();
    assert!(matches!(
        sink.push(1, &HdrImage::new(5, 4)),
        Err(OutputError::MismatchedFrames {
            frame: 1,
            size: (5, 4),
            first: (4, 4),
            ..
        })
    ));
    assert!(matches!(
        sink.push(1, &HdrImage::new(0, 4)),
        Err(OutputError::EmptyFrame { frame: 1, .. })
    ));
    let bad = HdrImage {
        width: 4,
        height: 4,
        data: vec![[0.0; 3]; 15],
    };
    assert!(matches!(
        sink.push(1, &bad),
        Err(OutputError::BadFrameData { frame: 1, .. })
    ));
    // The rejected frames were not counted: frame 1 still follows frame 0.
    sink.push(1, &HdrImage::new(4, 4)).unwrap();
    assert_eq!(decode_gif_len(sink), 2);

    let mut sink = Sink::create(&dir.path().join("w.gif"), &settings(), false).unwrap();
    assert!(matches!(
        sink.push(0, &HdrImage::new(70_000, 1)),
        Err(OutputError::TooLarge { limit: 65535, .. })
    ));
    drop(sink);
    assert_eq!(listing(dir.path()), vec!["c.gif"]);
}

#[test]
fn sink_settings_are_checked_when_created() {
    let dir = tempfile::tempdir().unwrap();
    let gif = dir.path().join("a.gif");
    for fps in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let s = OutputSettings { fps, ..settings() };
        assert!(matches!(
            Sink::create(&gif, &s, false),
            Err(OutputError::InvalidSetting { name: "fps", .. })
        ));
        // Only a GIF has a frame rate.
        Sink::create(&dir.path().join("a.png"), &s, true).unwrap();
    }
    for exposure in [-1.0, f64::NAN, f64::INFINITY] {
        let s = OutputSettings {
            exposure,
            ..settings()
        };
        for name in ["a.gif", "a.png", "a.exr"] {
            assert!(matches!(
                Sink::create(&dir.path().join(name), &s, false),
                Err(OutputError::InvalidSetting {
                    name: "exposure",
                    ..
                })
            ));
        }
    }
    assert!(matches!(
        Sink::create(&dir.path().join("a.jpg"), &settings(), false),
        Err(OutputError::UnknownFormat { .. })
    ));
    assert!(matches!(
        Sink::create(&dir.path().join("no").join("a.gif"), &settings(), false),
        Err(OutputError::MissingDirectory { .. })
    ));
    let sub = dir.path().join("d.gif");
    fs::create_dir(&sub).unwrap();
    assert!(matches!(
        Sink::create(&sub, &settings(), false),
        Err(OutputError::IsDirectory { .. })
    ));
    fs::remove_dir(&sub).unwrap();
    for name in ["a.gif", "a.png", "a.exr"] {
        let sink = Sink::create(&dir.path().join(name), &settings(), true).unwrap();
        assert!(matches!(sink.finish(), Err(OutputError::NoFrames { .. })));
    }
    assert!(listing(dir.path()).is_empty());
}

/// A renderer may hand the sink to another thread.
#[test]
fn sink_is_send() {
    fn send<T: Send>() {}
    send::<Sink>();
}

#[test]
fn dropping_an_unfinished_gif_sink_removes_its_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anim.gif");
    let frames = animation();
    let mut sink = Sink::create(&path, &settings(), false).unwrap();
    for (i, f) in frames.iter().enumerate() {
        sink.push(i, f).unwrap();
    }
    // Only the temporary file, which holds the frames so far.
    let names = listing(dir.path());
    assert_eq!(names.len(), 1);
    assert_ne!(names[0], "anim.gif");
    drop(sink);
    assert!(listing(dir.path()).is_empty());
}

#[test]
fn write_checks_every_frame_before_writing_any() {
    let dir = tempfile::tempdir().unwrap();
    let bad = HdrImage {
        width: 4,
        height: 4,
        data: vec![[0.0; 3]; 3],
    };
    for name in ["a.png", "a.exr", "a.gif"] {
        let frames = vec![gradient(4, 4, 0.0), gradient(4, 4, 1.0), bad.clone()];
        assert!(matches!(
            write(&dir.path().join(name), &frames, &settings()),
            Err(OutputError::BadFrameData { frame: 2, .. })
        ));
    }
    let mismatched = vec![gradient(4, 4, 0.0), gradient(4, 5, 1.0)];
    assert!(matches!(
        write(&dir.path().join("m.gif"), &mismatched, &settings()),
        Err(OutputError::MismatchedFrames { frame: 1, .. })
    ));
    // Numbered PNGs may differ in size, as they always could.
    write(&dir.path().join("m.png"), &mismatched, &settings()).unwrap();
    assert_eq!(listing(dir.path()), vec!["m_0000.png", "m_0001.png"]);
}

#[test]
fn a_failed_write_removes_its_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.png");
    let e = write_temp(&path, |w| {
        w.write_all(&[0; 100_000]).map_err(io_error(&path))?;
        Err(OutputError::Encode {
            path: path.clone(),
            format: Format::Png,
            message: "broken".to_string(),
        })
    })
    .unwrap_err();
    assert!(matches!(e, OutputError::Encode { .. }), "{e}");
    assert!(listing(dir.path()).is_empty());

    // A GIF whose file cannot be moved into place: a directory has taken its name.
    let gif = dir.path().join("anim.gif");
    let mut sink = Sink::create(&gif, &settings(), false).unwrap();
    sink.push(0, &gradient(8, 8, 0.0)).unwrap();
    fs::create_dir(&gif).unwrap();
    fs::write(gif.join("inside"), "x").unwrap();
    assert!(matches!(sink.finish(), Err(OutputError::Io { .. })));
    assert_eq!(listing(dir.path()), vec!["anim.gif"]);
    assert!(gif.is_dir());
}

#[test]
fn stale_frames_lists_older_numbered_frames() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("seq.png");
    for name in [
        "seq_0000.png",
        "seq_0001.png",
        "seq_0006.PNG",
        "seq_12345.png",
        "seq_0003.png.bak",
        "seq_003.png",
        "seq_00a1.png",
        "seq_0004.exr",
        "seq0005.png",
        "seq-0006.png",
        "seq.png",
        "other_0007.png",
        "xseq_0008.png",
        "seq_0009_0001.png",
    ] {
        fs::write(dir.path().join(name), "").unwrap();
    }
    fs::create_dir(dir.path().join("seq_0010.png")).unwrap();
    let written = vec![dir.path().join("seq_0000.png")];
    assert_eq!(
        stale_frames(&path, &written),
        ["seq_0001.png", "seq_0006.PNG", "seq_12345.png"]
            .iter()
            .map(|n| dir.path().join(n))
            .collect::<Vec<_>>()
    );
    assert_eq!(stale_frames(&path, &[]).len(), 4);
    // What `write` wrote is never stale.
    let frames = vec![HdrImage::new(2, 2); 3];
    let written = write(&path, &frames, &settings()).unwrap();
    assert_eq!(
        stale_frames(&path, &written.files),
        vec![
            dir.path().join("seq_0006.PNG"),
            dir.path().join("seq_12345.png")
        ]
    );
    assert_eq!(
        stale_frames(&dir.path().join("seq.exr"), &[]),
        vec![dir.path().join("seq_0004.exr")]
    );
    assert!(stale_frames(&dir.path().join("missing").join("seq.png"), &[]).is_empty());
}

#[test]
fn numbered_names_are_what_numbered_path_makes() {
    for (path, ext) in [
        ("a/seq.png", Some("PNG")),
        ("x.y.exr", Some("exr")),
        ("bare", None),
    ] {
        let p = Path::new(path);
        let stem = p.file_stem().unwrap();
        for i in [0, 7, 9999, 123_456] {
            let numbered = numbered_path(p, i);
            let name = numbered.file_name().unwrap();
            assert!(
                is_numbered_name(name, stem, ext.map(OsStr::new)),
                "{name:?}"
            );
        }
    }
    let (a, png) = (OsStr::new("a"), Some(OsStr::new("png")));
    assert!(!is_numbered_name(OsStr::new("a_0001.png"), a, None));
    assert!(!is_numbered_name(OsStr::new("a_0001"), a, png));
    assert!(!is_numbered_name(OsStr::new("a_0001."), a, png));
    assert!(!is_numbered_name(OsStr::new("a_.png"), a, png));
}
