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
