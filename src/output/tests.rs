use super::*;

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
            Err(OutputError::BadFrameData { expected: None, .. })
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
