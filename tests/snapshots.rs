//! Snapshot tests: every file under `tests/in/errors/` renders its diagnostics, every valid scene
//! under `tests/in/` and `examples/` prints its syntax tree, its checked scene, its optimised IR
//! and its bytecode.
//!
//! Update with `INSTA_UPDATE=always cargo test --release` (or `cargo insta review`).

use hyperslice::Compilation;
use std::path::{Path, PathBuf};

/// The path relative to the crate root, with `/` separators, so that file names in diagnostics
/// and snapshots do not depend on where the repository is checked out. Integration tests run
/// with the crate root as the working directory, so the relative path opens the same file.
fn relative(path: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let root = root.canonicalize().unwrap_or_else(|_| root.to_path_buf());
    let rel = path
        .strip_prefix(&root)
        .or_else(|_| path.strip_prefix(env!("CARGO_MANIFEST_DIR")))
        .unwrap_or_else(|_| panic!("{} is outside the crate", path.display()));
    PathBuf::from(rel.to_string_lossy().replace('\\', "/"))
}

fn compile(path: &Path) -> (PathBuf, Compilation) {
    let rel = relative(path);
    let c = Compilation::from_path(&rel);
    (rel, c)
}

/// Every label of every diagnostic lies inside the text of the file it names.
fn assert_spans_in_bounds(c: &Compilation, what: &Path) {
    for d in &c.diagnostics {
        for l in &d.labels {
            let len = c.sources.get(l.span.file).text.len();
            assert!(
                l.span.start <= l.span.end && (l.span.end as usize) <= len,
                "{}: [{}] label {}..{} outside its file of {len} bytes",
                what.display(),
                d.code,
                l.span.start,
                l.span.end
            );
            let text = &c.sources.get(l.span.file).text;
            assert!(
                text.is_char_boundary(l.span.start as usize)
                    && text.is_char_boundary(l.span.end as usize),
                "{}: [{}] label {}..{} splits a character",
                what.display(),
                d.code,
                l.span.start,
                l.span.end
            );
        }
    }
}

fn assert_no_absolute_paths(text: &str, what: &Path) {
    let root = env!("CARGO_MANIFEST_DIR");
    assert!(
        !text.contains(root),
        "{}: output contains the absolute path {root}",
        what.display()
    );
}

#[test]
fn error_diagnostics() {
    insta::glob!("in/errors/*.4ds", |path| {
        let (rel, c) = compile(path);
        assert!(
            !c.diagnostics.is_empty(),
            "{}: expected at least one diagnostic",
            rel.display()
        );
        assert_spans_in_bounds(&c, &rel);
        let rendered = c.render_diagnostics(false);
        assert_no_absolute_paths(&rendered, &rel);
        let codes: Vec<&str> = c.diagnostics.iter().map(|d| d.code).collect();
        insta::with_settings!({ description => format!("codes: {}", codes.join(" ")), omit_expression => true }, {
            insta::assert_snapshot!("diagnostics", rendered);
        });
    });
}

/// Valid scenes: no errors, and a stable printed tree and scene.
fn check_valid(path: &Path, with_ast: bool, scene_name: &str) {
    let (rel, c) = compile(path);
    assert!(
        !c.has_errors(),
        "{} should compile without errors:\n{}",
        rel.display(),
        c.render_diagnostics(false)
    );
    assert_spans_in_bounds(&c, &rel);
    let scene = c
        .emit_scene()
        .unwrap_or_else(|| panic!("{}: no scene despite no errors", rel.display()));
    assert_no_absolute_paths(&scene, &rel);
    let warnings = c.render_diagnostics(false);
    insta::with_settings!({ omit_expression => true }, {
        if with_ast {
            insta::assert_snapshot!("ast", c.emit_ast());
        }
        insta::assert_snapshot!(scene_name, scene);
        insta::assert_snapshot!(format!("{scene_name}_ir"), c.emit_ir(hyperslice::At::default()).unwrap_or_default());
        insta::assert_snapshot!(format!("{scene_name}_bytecode"), c.emit_bytecode(hyperslice::At::default()).unwrap_or_default());
        if !warnings.is_empty() {
            insta::assert_snapshot!("warnings", warnings);
        }
    });
}

#[test]
fn valid_scenes() {
    insta::glob!("in/*.4ds", |path| check_valid(path, true, "scene"));
}

#[test]
fn examples() {
    insta::glob!("../examples", "*.4ds", |path| check_valid(
        path,
        false,
        "example_scene"
    ));
}

/// Every diagnostic code in the language reference is produced by at least one error file.
#[test]
fn every_code_is_covered() {
    let mut seen = std::collections::BTreeSet::new();
    let dir = Path::new("tests/in/errors");
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "4ds") {
            for d in Compilation::from_path(&path).diagnostics {
                seen.insert(d.code);
            }
        }
    }
    let mut codes: Vec<String> = Vec::new();
    for (prefix, nums) in [
        ("E00", &[1, 2, 3, 10, 11, 12][..]),
        ("E01", &[1, 2, 3, 4, 5]),
        ("E02", &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10]),
        ("E03", &[1, 2]),
        ("E04", &[1, 2, 3]),
        ("E05", &[1, 2, 3, 4]),
        ("W00", &[1, 2, 3, 4, 5]),
    ] {
        for n in nums {
            codes.push(format!("{prefix}{n:02}"));
        }
    }
    let missing: Vec<&String> = codes
        .iter()
        .filter(|c| !seen.contains(c.as_str()))
        .collect();
    assert!(missing.is_empty(), "no error file produces {missing:?}");
}

/// A call with 100,000 extra arguments on one 300 KB line: one error for all of them, and the
/// line echoed only up to a little past the labels.
#[test]
fn many_extra_arguments_on_one_line() {
    let source = format!(
        "object a {{ shape = hypersphere(1{}) }}\n",
        ", 1".repeat(100_000)
    );
    let c = Compilation::from_source("many_arguments.4ds", &source);
    let rendered = c.render_diagnostics(false);
    assert_eq!(c.diagnostics.len(), 1, "{rendered}");
    assert!(rendered.len() < 4_000, "{} bytes echoed", rendered.len());
    insta::assert_snapshot!(rendered);
}

/// A list literal is bound by the same 100,000-item limit as a range.
#[test]
fn list_literal_too_large() {
    let source = format!(
        "let xs = [{}]\nobject a {{ shape = hypersphere(len(xs)) }}\n",
        vec!["1"; 100_001].join(", ")
    );
    let c = Compilation::from_source("big_list.4ds", &source);
    let codes: Vec<&str> = c.diagnostics.iter().map(|d| d.code).collect();
    assert_eq!(codes, ["E0402"]);
    insta::assert_snapshot!(c.render_diagnostics(false));
}

/// `-D NAME=VALUE` replaces a top-level `let`: the compiled scene changes, and a grey `num`
/// stands for a colour as it does in the scene.
#[test]
fn defines_override_lets() {
    let path = Path::new("tests/in/overrides/scene.4ds");
    let defines = ["radius=0.5".to_string(), "tint=0.25 * 2".to_string()];
    let c = Compilation::from_path_with(path, &defines);
    assert!(!c.has_errors(), "{}", c.render_diagnostics(false));
    let scene = c.emit_scene().unwrap_or_default();
    assert!(scene.contains("hypersphere(radius: 0.5)"), "{scene}");
    let plain = Compilation::from_path(path)
        .emit_scene()
        .unwrap_or_default();
    assert!(plain.contains("hypersphere(radius: 1)"), "{plain}");
}

/// Every way a `-D` can be wrong is a diagnostic pointing into the command-line text.
#[test]
fn define_diagnostics() {
    let path = Path::new("tests/in/overrides/scene.4ds");
    let mut out = String::new();
    for define in [
        "radius=true",
        "raduis=2",
        "f=1",
        "radius",
        "radius=2 *",
        "radius=t",
        "radius=[1, 2]",
    ] {
        let c = Compilation::from_path_with(path, &[define.to_string()]);
        assert!(c.has_errors(), "-D {define} should be an error");
        assert!(
            c.diagnostics
                .iter()
                .all(|d| d
                    .primary_span()
                    .is_some_and(|s| c.sources.get(s.file).name == "-D")),
            "-D {define}: {}",
            c.render_diagnostics(false)
        );
        out.push_str(&format!("$ -D {define}\n{}", c.render_diagnostics(false)));
    }
    insta::assert_snapshot!(out);
}

/// W0002 compares the shape's reach towards each neighbour with the cell's facet that way: a
/// box that fits its grid cell along the axes is not warned about even though its corners reach
/// further than half the spacing, and turning a sphere about its centre changes nothing.
#[test]
fn tile_fit_uses_the_extent_towards_each_neighbour() {
    let cases = [
        ("hyperbox(0.5) |> tile(grid(spacing: 1.5))", false),
        ("hyperbox(0.75) |> tile(grid(spacing: 1.5))", false),
        ("hyperbox(0.9) |> tile(grid(spacing: 1.5))", true),
        (
            "hyperbox([0.9, 0.5, 0.5, 0.5]) |> tile(grid(spacing: [2, 1, 1, 1]))",
            false,
        ),
        // Along x the grid has one cell, so nothing neighbours it there.
        (
            "hyperbox([5, 0.5, 0.5, 0.5]) |> tile(grid(1, limit: [0, 3, 3, 3]))",
            false,
        ),
        ("hyperbox(0.5) |> tile(d4(scale: 1))", false),
        ("hyperbox(0.55) |> tile(d4(scale: 1))", true),
        ("hypersphere(0.7) |> tile(d4(scale: 1))", false),
        ("hypersphere(0.75) |> tile(d4(scale: 1))", true),
        (
            "hypersphere(0.7) |> rotate(xy, 30deg) |> tile(d4(scale: 1))",
            false,
        ),
        (
            "hypersphere(0.75) |> rotate(xy, 30deg) |> rotate(zw, 10deg) |> tile(d4(scale: 1))",
            true,
        ),
        (
            "hypersphere(0.7) |> rotate(xy, 30deg) |> tile(grid(1.5))",
            false,
        ),
        (
            "hypersphere(0.7) |> rotate(xw, 90deg * t) |> tile(grid(1.5))",
            false,
        ),
        (
            "hypersphere(0.8) |> rotate(xw, 90deg * t) |> tile(grid(1.5))",
            true,
        ),
        // Turned 45 degrees in xy, the box's corner points along x.
        (
            "hyperbox(0.6) |> rotate(xy, 45deg) |> tile(grid(1.5))",
            true,
        ),
        (
            "hyperbox(0.5) |> rotate(xy, 45deg) |> tile(grid(1.5))",
            false,
        ),
        (
            "hypersphere(0.5) |> translate([0.2, 0, 0, 0]) |> tile(grid(1.5))",
            false,
        ),
        (
            "hypersphere(0.5) |> translate([0.3, 0, 0, 0]) |> tile(grid(1.5))",
            true,
        ),
        ("cell16(0.7) |> tile(grid(1.5))", false),
        ("cell16(0.7) |> round(0.1) |> tile(grid(1.5))", true),
        ("cell24(1) |> tile(grid(1.5))", false),
    ];
    let mut wrong = Vec::new();
    for (shape, warns) in cases {
        let text = format!("object o {{ shape = {shape} }}\n");
        let c = Compilation::from_source("fit.4ds", &text);
        assert!(!c.has_errors(), "{shape}:\n{}", c.render_diagnostics(false));
        let got = c.diagnostics.iter().any(|d| d.code == "W0002");
        if got != warns {
            wrong.push(format!("{shape}: W0002 {got}, expected {warns}"));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
