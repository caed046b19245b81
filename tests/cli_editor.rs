//! The editor-facing commands end to end: `explain`, `--message-format json`, `-D`, `fmt`,
//! `render --watch` and the language server over stdio.

mod common;

use common::hyperslice;
use std::path::Path;
use std::process::Output;

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn explain_prints_the_long_form_of_a_code() {
    let here = Path::new(".");
    let o = hyperslice(here, &["explain", "E0201"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.starts_with("E0201: wrong type"), "{text}");
    assert!(text.contains("hypersphere(radius: true)"), "{text}");
    assert!(text.contains("Fixed:"), "{text}");
    // Lower case works too; an unknown code fails and lists the known ones.
    assert!(hyperslice(here, &["explain", "w0001"]).status.success());
    let o = hyperslice(here, &["explain", "E9999"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("E0201"), "{}", stderr(&o));
}

fn json_lines(o: &Output) -> Vec<serde_json::Value> {
    stdout(o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn check_prints_one_json_object_per_diagnostic() {
    let dir = tempfile::tempdir().expect("temp dir");
    // The mistake is on line 3, after a line with a two-byte character, so columns count
    // characters and byte offsets count bytes.
    let scene = "// é\nlet unused = 1\nobject ball { shape = hypersphere(radius: -1) }\n";
    std::fs::write(dir.path().join("s.4ds"), scene).expect("written");
    let o = hyperslice(dir.path(), &["check", "--message-format", "json", "s.4ds"]);
    assert!(!o.status.success());
    let msgs = json_lines(&o);
    assert_eq!(msgs.len(), 2, "{}", stdout(&o));
    // In source order: the warning on line 2, then the error.
    let e = &msgs[1];
    assert_eq!(e["type"], "diagnostic");
    assert_eq!(e["severity"], "error");
    assert_eq!(e["code"], "E0301");
    assert_eq!(e["file"], "s.4ds");
    assert_eq!(
        (e["line"].as_u64(), e["column"].as_u64()),
        (Some(3), Some(43))
    );
    assert_eq!(
        (e["end_line"].as_u64(), e["end_column"].as_u64()),
        (Some(3), Some(45))
    );
    let start = e["byte_start"].as_u64().expect("a byte offset") as usize;
    assert_eq!(
        &scene[start..e["byte_end"].as_u64().unwrap() as usize],
        "-1"
    );
    assert_eq!(e["labels"][0]["primary"], true);
    assert!(e["help"].as_str().is_some_and(|h| h.contains("at least 0")));
    let w = &msgs[0];
    assert_eq!(
        (w["severity"].as_str(), w["code"].as_str()),
        (Some("warning"), Some("W0001"))
    );
    assert_eq!(w["line"].as_u64(), Some(2));
    assert!(w["notes"].is_array());
}

#[test]
fn defines_reach_check_compile_and_render() {
    let dir = common::scene_dir();
    let scene = "let r = 1\nrender { size = 8 x 6  spp = 1  denoise = \"none\" }\n\
                 object ball { shape = hypersphere(r) }\n";
    std::fs::write(dir.path().join("d.4ds"), scene).expect("written");
    let o = hyperslice(dir.path(), &["compile", "d.4ds", "-D", "r=0.5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("hypersphere(radius: 0.5)"),
        "{}",
        stdout(&o)
    );
    let o = hyperslice(dir.path(), &["check", "d.4ds", "-D", "r=\"big\""]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("`-D r` must be a num"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("-D:1:3"), "{}", stderr(&o));
    // A render with an override, and its statistics as the last JSON line.
    let o = hyperslice(
        dir.path(),
        &[
            "render",
            "d.4ds",
            "-o",
            "d.png",
            "-D",
            "r=0.75",
            "--message-format",
            "json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let msgs = json_lines(&o);
    let stats = msgs.last().expect("render statistics");
    assert_eq!(stats["type"], "render-stats");
    assert_eq!(
        (stats["width"].as_u64(), stats["height"].as_u64()),
        (Some(8), Some(6))
    );
    assert_eq!(stats["samples"].as_u64(), Some(48));
    assert_eq!(stats["files"][0], "d.png");
}
