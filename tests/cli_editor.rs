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
    assert!(stats["shadow_rays"].as_u64().is_some(), "{stats}");
    assert_eq!(stats["files"][0], "d.png");
}

/// Every example, valid scene and error file that parses: formatting keeps the syntax tree
/// (and so the meaning, comments aside) and the compiled scene, and a second pass changes
/// nothing.
#[test]
fn fmt_keeps_meaning_and_is_idempotent() {
    use hyperslice::Compilation;
    use hyperslice::syntax::format::format;
    let mut seen = 0;
    for dir in ["examples", "tests/in", "tests/in/errors", "tests/in/lib"] {
        for entry in std::fs::read_dir(dir).expect("listed") {
            let path = entry.expect("entry").path();
            if path.extension().is_none_or(|e| e != "4ds") {
                continue;
            }
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            let before = Compilation::from_text(&path, &text);
            let Ok(out) = format(hyperslice::source::FileId(0), &text) else {
                continue;
            };
            seen += 1;
            let after = Compilation::from_text(&path, &out);
            let what = path.display();
            assert_eq!(
                before.emit_ast(),
                after.emit_ast(),
                "{what}: the tree changed:\n{out}"
            );
            assert_eq!(
                before.emit_scene(),
                after.emit_scene(),
                "{what}: the scene changed"
            );
            let codes = |c: &Compilation| -> Vec<(String, String)> {
                (c.diagnostics.iter())
                    .map(|d| (d.code.to_string(), d.message.clone()))
                    .collect()
            };
            assert_eq!(
                codes(&before),
                codes(&after),
                "{what}: the diagnostics changed"
            );
            let again = format(hyperslice::source::FileId(0), &out).expect("formatted text parses");
            assert_eq!(again, out, "{what}: a second pass changed it");
            let comments = |s: &str| s.matches("//").count() + s.matches("/*").count();
            assert_eq!(comments(&text), comments(&out), "{what}: comments lost");
        }
    }
    assert!(seen > 100, "only {seen} files formatted");
}

#[test]
fn fmt_check_in_place_and_stdin() {
    let dir = tempfile::tempdir().expect("temp dir");
    let messy = "object ball{shape=hypersphere( 1 )}\n";
    let tidy = "object ball { shape = hypersphere(1) }\n";
    std::fs::write(dir.path().join("a.4ds"), messy).expect("written");
    std::fs::write(dir.path().join("b.4ds"), tidy).expect("written");
    let o = hyperslice(dir.path(), &["fmt", "--check", "a.4ds", "b.4ds"]);
    assert!(!o.status.success());
    assert_eq!(stdout(&o), "a.4ds\n");
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).expect("read");
    assert_eq!(read("a.4ds"), messy, "--check changed a file");
    let mode = |f: &str| {
        use std::os::unix::fs::PermissionsExt;
        std::fs::metadata(dir.path().join(f))
            .expect("metadata")
            .permissions()
            .mode()
    };
    let before = mode("a.4ds");
    let o = hyperslice(dir.path(), &["fmt", "a.4ds", "b.4ds"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(read("a.4ds"), tidy);
    assert_eq!(mode("a.4ds"), before, "fmt changed the file's permissions");
    assert!(
        hyperslice(dir.path(), &["fmt", "--check", "a.4ds"])
            .status
            .success()
    );
    // A file that does not parse is reported and left alone.
    std::fs::write(dir.path().join("c.4ds"), "let a = (\n").expect("written");
    let o = hyperslice(dir.path(), &["fmt", "c.4ds"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("E0011"), "{}", stderr(&o));
    assert_eq!(read("c.4ds"), "let a = (\n");
    // Standard input to standard output.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_hyperslice"))
        .args(["fmt", "-"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("started");
    use std::io::Write;
    child
        .stdin
        .take()
        .expect("stdin")
        .write_all(messy.as_bytes())
        .expect("fed");
    let o = child.wait_with_output().expect("ran");
    assert!(o.status.success());
    assert_eq!(stdout(&o), tidy);
}

/// The examples are kept in the formatter's style.
#[test]
fn examples_are_formatted() {
    let o = hyperslice(
        Path::new("examples"),
        &[
            "fmt",
            "--check",
            "d4_packing.4ds",
            "glass_box.4ds",
            "polytopes.4ds",
            "room.4ds",
            "tesseract.4ds",
        ],
    );
    assert!(
        o.status.success(),
        "not formatted: {}{}",
        stdout(&o),
        stderr(&o)
    );
}

/// A language server session driven as an editor drives it, over the binary's stdio.
struct Lsp {
    child: std::process::Child,
    stdin: std::process::ChildStdin,
    stdout: std::io::BufReader<std::process::ChildStdout>,
}

impl Lsp {
    fn start() -> Lsp {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_hyperslice"))
            .arg("lsp")
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("started");
        let stdin = child.stdin.take().expect("stdin");
        let stdout = std::io::BufReader::new(child.stdout.take().expect("stdout"));
        Lsp {
            child,
            stdin,
            stdout,
        }
    }

    fn send(&mut self, msg: serde_json::Value) {
        use std::io::Write;
        let body = msg.to_string();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).expect("sent");
        self.stdin.flush().expect("flushed");
    }

    fn read(&mut self) -> serde_json::Value {
        use std::io::{BufRead, Read};
        let mut len = 0;
        loop {
            let mut line = String::new();
            assert!(
                self.stdout.read_line(&mut line).expect("a header") > 0,
                "server closed"
            );
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            if let Some(n) = line.strip_prefix("Content-Length: ") {
                len = n.parse().expect("a length");
            }
        }
        let mut body = vec![0; len];
        self.stdout.read_exact(&mut body).expect("a body");
        serde_json::from_slice(&body).expect("JSON")
    }

    /// Send a request and read up to its response, keeping notifications that come first.
    fn request(&mut self, id: u64, method: &str, params: serde_json::Value) -> serde_json::Value {
        self.send(
            serde_json::json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params}),
        );
        loop {
            let msg = self.read();
            if msg["id"] == id {
                return msg["result"].clone();
            }
        }
    }

    fn notify(&mut self, method: &str, params: serde_json::Value) {
        self.send(serde_json::json!({"jsonrpc": "2.0", "method": method, "params": params}));
    }
}

#[test]
fn language_server_session() {
    use serde_json::json;
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().canonicalize().expect("a path").join("scene.4ds");
    let text = "let radius = 0.5\nobject ball { shape = hypersphere( radius ) }\nobject b2 { shape = hypersfere(1) }\nsky = rgb(0.5)\n";
    std::fs::write(&path, text).expect("written");
    let uri = format!("file://{}", path.display());
    let doc = json!({"uri": uri});
    let at = |line: u32, character: u32| json!({"textDocument": doc, "position": {"line": line, "character": character}});

    let mut lsp = Lsp::start();
    let init = lsp.request(
        1,
        "initialize",
        json!({"capabilities": {}, "processId": null, "rootUri": null}),
    );
    assert_eq!(init["capabilities"]["hoverProvider"], true, "{init}");
    lsp.notify("initialized", json!({}));
    lsp.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": uri, "languageId": "4ds", "version": 1, "text": text}}),
    );
    // Diagnostics at the mistake, with the same code as `check`.
    let diags = loop {
        let msg = lsp.read();
        if msg["method"] == "textDocument/publishDiagnostics" {
            break msg["params"]["diagnostics"].clone();
        }
    };
    assert_eq!(diags.as_array().map(Vec::len), Some(1), "{diags}");
    assert_eq!(diags[0]["code"], "E0101");
    assert_eq!(
        diags[0]["range"]["start"],
        json!({"line": 2, "character": 20})
    );
    assert_eq!(
        diags[0]["range"]["end"],
        json!({"line": 2, "character": 30})
    );
    assert!(
        diags[0]["message"]
            .as_str()
            .unwrap_or("")
            .contains("hypersphere"),
        "{diags}"
    );

    // Hover on a use of `radius`: its type and value.
    let hover = lsp.request(2, "textDocument/hover", at(1, 37));
    let shown = hover["contents"]["value"]
        .as_str()
        .unwrap_or("")
        .to_string();
    assert!(shown.contains("radius: num = 0.5"), "{hover}");
    // Hover on a definition shows it too.
    let hover = lsp.request(11, "textDocument/hover", at(0, 6));
    let shown = hover["contents"]["value"]
        .as_str()
        .unwrap_or("")
        .to_string();
    assert!(shown.contains("radius: num = 0.5"), "{hover}");
    // Hover on a builtin: its signature from the table and its line from the reference.
    let hover = lsp.request(3, "textDocument/hover", at(1, 25));
    let shown = hover["contents"]["value"]
        .as_str()
        .unwrap_or("")
        .to_string();
    assert!(shown.contains("hypersphere(radius: num = 1)"), "{hover}");

    // Definition: the `let`'s name.
    let def = lsp.request(4, "textDocument/definition", at(1, 37));
    assert_eq!(def["uri"], uri.as_str());
    assert_eq!(def["range"]["start"], json!({"line": 0, "character": 4}));

    // Completion offers an object's settings inside its block, builtins elsewhere.
    let items = lsp.request(5, "textDocument/completion", at(2, 12));
    let labels: Vec<&str> = items
        .as_array()
        .expect("items")
        .iter()
        .filter_map(|i| i["label"].as_str())
        .collect();
    assert_eq!(labels, ["shape", "material"]);
    let items = lsp.request(6, "textDocument/completion", at(1, 22));
    let labels: Vec<&str> = items
        .as_array()
        .expect("items")
        .iter()
        .filter_map(|i| i["label"].as_str())
        .collect();
    assert!(
        labels.contains(&"hyperbox") && labels.contains(&"radius"),
        "{labels:?}"
    );

    let symbols = lsp.request(
        7,
        "textDocument/documentSymbol",
        json!({"textDocument": doc}),
    );
    let names: Vec<&str> = symbols
        .as_array()
        .expect("symbols")
        .iter()
        .filter_map(|s| s["name"].as_str())
        .collect();
    assert_eq!(names, ["radius", "ball", "b2"]);
    let tokens = lsp.request(
        8,
        "textDocument/semanticTokens/full",
        json!({"textDocument": doc}),
    );
    assert_eq!(tokens["data"].as_array().map(|d| d.len() % 5), Some(0));
    assert!(tokens["data"].as_array().is_some_and(|d| !d.is_empty()));

    // Formatting through `fmt`: one edit with the formatted text.
    let edits = lsp.request(
        9,
        "textDocument/formatting",
        json!({"textDocument": doc, "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    assert_eq!(
        edits[0]["newText"],
        "let radius = 0.5\nobject ball { shape = hypersphere(radius) }\nobject b2 { shape = hypersfere(1) }\nsky = rgb(0.5)\n"
    );

    // Fixing the mistake clears the diagnostics.
    let fixed = text.replace("hypersfere", "hypersphere");
    lsp.notify(
        "textDocument/didChange",
        json!({"textDocument": {"uri": uri, "version": 2}, "contentChanges": [{"text": fixed}]}),
    );
    let diags = loop {
        let msg = lsp.read();
        if msg["method"] == "textDocument/publishDiagnostics" {
            break msg["params"]["diagnostics"].clone();
        }
    };
    assert_eq!(diags, json!([]));

    let shutdown = lsp.request(10, "shutdown", json!(null));
    assert!(shutdown.is_null());
    lsp.notify("exit", json!(null));
    let status = lsp.child.wait().expect("exited");
    assert!(status.success());
}

/// The VS Code grammar is valid JSON and highlights every keyword of the lexer.
#[test]
fn textmate_grammar_knows_the_keywords() {
    let text = std::fs::read_to_string("docs/editors/vscode/syntaxes/4ds.tmLanguage.json")
        .expect("the grammar");
    let grammar: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let all = grammar["patterns"].to_string();
    for kw in [
        "let", "fn", "object", "render", "camera", "sky", "medium", "import", "if", "else", "for",
        "in", "true", "false", "sdf", "mod",
    ] {
        assert!(
            all.contains(&format!("|{kw}|"))
                || all.contains(&format!("({kw}|"))
                || all.contains(&format!("|{kw})")),
            "{kw}"
        );
    }
}

/// `render --watch` renders, reports a broken edit without stopping, and renders the fix.
#[test]
fn render_watch_rerenders_on_change() {
    use std::io::BufRead;
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = |size: &str, radius: &str| {
        format!(
            "render {{ size = {size}  spp = 1  denoise = \"none\" }}\nobject ball {{ shape = hypersphere({radius}) }}\n"
        )
    };
    std::fs::write(dir.path().join("w.4ds"), scene("8 x 6", "1")).expect("written");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_hyperslice"))
        .current_dir(dir.path())
        .args(["render", "--watch", "w.4ds", "-o", "w.png"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("started");
    let (tx, rx) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().expect("stderr");
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // Everything printed up to the next "watching" line.
    let until_watching = || {
        let deadline = Instant::now() + Duration::from_secs(60);
        let mut seen = String::new();
        while Instant::now() < deadline {
            if let Ok(line) = rx.recv_timeout(Duration::from_millis(100)) {
                seen.push_str(&line);
                seen.push('\n');
                if line.starts_with("watching") {
                    return seen;
                }
            }
        }
        panic!("no `watching` line; saw:\n{seen}");
    };
    let size = || {
        let img = image::open(dir.path().join("w.png")).expect("a PNG");
        (img.width(), img.height())
    };
    let first = until_watching();
    assert!(first.contains("wrote w.png"), "{first}");
    assert_eq!(size(), (8, 6));
    std::fs::write(dir.path().join("w.4ds"), scene("8 x 6", "-1")).expect("written");
    let broken = until_watching();
    assert!(broken.contains("E0301"), "{broken}");
    std::fs::write(dir.path().join("w.4ds"), scene("10 x 4", "1")).expect("written");
    let fixed = until_watching();
    assert!(fixed.contains("wrote w.png"), "{fixed}");
    assert_eq!(size(), (10, 4));
    child.kill().expect("stopped");
    let _ = child.wait();
}

/// The tutorial's scenes check, are formatted, and each appears whole in the text.
#[test]
fn tutorial_scenes_check_and_are_formatted() {
    let tutorial = std::fs::read_to_string("docs/tutorial.md").expect("the tutorial");
    for step in 1..=4 {
        let path = format!("docs/tutorial/step{step}.4ds");
        let text = std::fs::read_to_string(&path).expect("a step");
        let c = hyperslice::Compilation::from_path(Path::new(&path));
        assert!(
            c.diagnostics.is_empty(),
            "{path}: {}",
            c.render_diagnostics(false)
        );
        let formatted = hyperslice::syntax::format::format(hyperslice::source::FileId(0), &text);
        assert_eq!(
            formatted.as_deref(),
            Ok(text.as_str()),
            "{path} is not formatted"
        );
        assert!(
            tutorial.contains(&text),
            "docs/tutorial.md does not show {path} as it is"
        );
    }
}

/// Every snippet of the tutorial that is a whole scene (it has a `render` block) is lit: copied
/// as shown, it does not render black.
#[test]
fn tutorial_scenes_are_lit() {
    let text = std::fs::read_to_string("docs/tutorial.md").expect("the tutorial");
    let mut checked = 0;
    for block in text.split("```").skip(1).step_by(2) {
        let Some(body) = block.strip_prefix('\n') else {
            continue;
        };
        if !body.contains("render {") {
            continue;
        }
        checked += 1;
        let c = hyperslice::Compilation::from_source("snippet.4ds", body);
        let codes: Vec<&str> = c.diagnostics.iter().map(|d| d.code).collect();
        assert!(codes.is_empty(), "{codes:?} for the snippet\n{body}");
    }
    assert!(checked >= 2, "only {checked} whole scenes in the tutorial");
}

/// Every code block of the reference and the tutorial that is a whole scene is formatted.
#[test]
fn docs_snippets_are_formatted() {
    use hyperslice::syntax::format::format;
    for doc in ["docs/language.md", "docs/tutorial.md"] {
        let text = std::fs::read_to_string(doc).expect("the docs");
        let mut blocks = text.split("```").skip(1).step_by(2);
        let mut checked = 0;
        for block in &mut blocks {
            // Only unlabelled blocks hold scenes; shell, TOML and Lua blocks are labelled.
            let Some(body) = block.strip_prefix('\n') else {
                continue;
            };
            if let Ok(out) = format(hyperslice::source::FileId(0), body) {
                checked += 1;
                assert_eq!(out, body, "{doc}: a snippet is not formatted");
            }
        }
        assert!(checked > 0, "{doc}: no snippet checked");
    }
}

/// A mistake in an imported file shows on the document's `import`, imports resolving
/// relative to the document.
#[test]
fn language_server_reports_imported_files_at_the_import() {
    use serde_json::json;
    let dir = tempfile::tempdir().expect("temp dir");
    let root = dir.path().canonicalize().expect("a path");
    std::fs::create_dir(root.join("lib")).expect("a folder");
    std::fs::write(
        root.join("lib/shapes.4ds"),
        "object stray { shape = hypersphere(1) }\n",
    )
    .expect("written");
    let path = root.join("scene.4ds");
    let text = "import \"lib/shapes.4ds\"\nobject ball { shape = hypersphere(1) }\n";
    let uri = format!("file://{}", path.display());
    let mut lsp = Lsp::start();
    lsp.request(
        1,
        "initialize",
        json!({"capabilities": {}, "processId": null, "rootUri": null}),
    );
    lsp.notify("initialized", json!({}));
    lsp.notify(
        "textDocument/didOpen",
        json!({"textDocument": {"uri": uri, "languageId": "4ds", "version": 1, "text": text}}),
    );
    let diags = loop {
        let msg = lsp.read();
        if msg["method"] == "textDocument/publishDiagnostics" {
            break msg["params"]["diagnostics"].clone();
        }
    };
    assert_eq!(diags[0]["code"], "E0504", "{diags}");
    assert_eq!(
        diags[0]["range"]["start"],
        json!({"line": 0, "character": 7})
    );
    assert!(
        diags[0]["message"]
            .as_str()
            .unwrap_or("")
            .contains("lib/shapes.4ds:1:1: "),
        "{diags}"
    );
    // Go to definition on the path opens the imported file.
    let def = lsp.request(
        2,
        "textDocument/definition",
        json!({"textDocument": {"uri": uri}, "position": {"line": 0, "character": 10}}),
    );
    assert_eq!(
        def["uri"],
        format!("file://{}", root.join("lib/shapes.4ds").display())
    );
    lsp.request(3, "shutdown", json!(null));
    lsp.notify("exit", json!(null));
    assert!(lsp.child.wait().expect("exited").success());
}

/// Control characters in a scene never reach the terminal raw: the excerpt of every diagnostic
/// shows them as pictures (ESC as `␛`, NUL as `␀`), with the marker under the right column.
#[test]
fn diagnostics_show_control_characters_escaped() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scenes: [(&str, &[u8]); 3] = [
        (
            "esc.4ds",
            b"let a = 1 \x1b[31m\nrender { denoise = \"\x1b[31mred\" }\nobject ball { shape = hypersphere(1) }\n",
        ),
        (
            "nul.4ds",
            b"let \x00b = 1\x7f\nobject ball { shape = hypersphere(1) \xc2\x9b }\n",
        ),
        ("binary.4ds", b"\x7fELF\x02\x01\x00\x00\xff\xfe\x1b[2J\x00\x7f\n"),
    ];
    for (name, bytes) in scenes {
        std::fs::write(dir.path().join(name), bytes).expect("written");
        for command in ["check", "render"] {
            let o = hyperslice(dir.path(), &[command, "--color", "never", name]);
            assert!(!o.status.success(), "{name}: {}", stderr(&o));
            let all = [o.stdout.as_slice(), o.stderr.as_slice()].concat();
            let text = String::from_utf8_lossy(&all);
            assert!(text.contains("Error"), "{name}: {text}");
            let raw: Vec<char> = (text.chars())
                .filter(|c| c.is_control() && *c != '\n')
                .collect();
            assert!(raw.is_empty(), "{name} {command}: {raw:?} in\n{text}");
        }
    }
    // The marker stays under the character it points at.
    let o = hyperslice(dir.path(), &["check", "--color", "never", "nul.4ds"]);
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    let at = (lines.iter())
        .position(|l| l.ends_with("let \u{2400}b = 1\u{2421}"))
        .unwrap_or_else(|| panic!("no excerpt with pictures in\n{err}"));
    let column = |l: &str| l.chars().position(|c| c == '|' || c == '^');
    let excerpt = lines[at];
    let marker = lines[at + 1];
    let nul = excerpt.chars().position(|c| c == '\u{2400}');
    let bar = excerpt
        .find(" | ")
        .map(|i| excerpt[..i].chars().count() + 3);
    assert_eq!(
        column(&marker[bar.unwrap_or(0)..]).map(|c| c + bar.unwrap_or(0)),
        nul,
        "{err}"
    );
}

/// A line too long is broken outermost first: an object's settings one per line, a short
/// vector kept whole, a `fn`'s short parameter list kept on its line with the body after the
/// `=`, a call's arguments one per line only when the call alone is the value; and a second
/// pass changes nothing, nor the syntax tree.
#[test]
fn fmt_breaks_the_outermost_group_first() {
    use hyperslice::Compilation;
    use hyperslice::syntax::format::format;
    let text = "\
object left { shape = hyperbox(0.5) |> translate([-2, 0, 0, 0]), material = diffuse(albedo: rgb(0.8, 0.3, 0.2)) }
fn pillar(x: num, z: num) -> shape = spherinder(radius: 0.25, height: 3) |> translate([x, 0, z, 0]) |> rotate(xw, 10deg)
fn short(k: num, r: num) -> shape = hypersphere(r) |> translate([k, 0, 0, 0])
let big = union(hypersphere(1), hyperbox(0.5) |> translate([1, 0, 0, 0]), cell24(0.7) |> translate([0, 2, 0, 0]))
render { size = 320 x 200, spp = 8, bounces = 4, epsilon = 0.0001, max_steps = 300, denoise = \"atrous\" }
";
    let out = format(hyperslice::source::FileId(0), text).expect("it parses");
    insta::assert_snapshot!(out);
    let again = format(hyperslice::source::FileId(0), &out).expect("it parses");
    assert_eq!(again, out, "a second pass changed it");
    let ast = |s: &str| Compilation::from_source("f.4ds", s).emit_ast();
    assert_eq!(ast(text), ast(&out), "the tree changed");
}
