//! Robustness: the front end never panics, never hangs, keeps every diagnostic inside its file,
//! bounds nesting, reports several mistakes per run, and the CLI exits with the right status.

use hyperslice::Compilation;
use proptest::prelude::*;
use proptest::sample::Index;
use std::path::Path;
use std::process::Command;
use std::sync::LazyLock;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What a compilation produced, in a form that can leave the worker thread.
#[derive(Debug)]
struct Outcome {
    codes: Vec<&'static str>,
    has_errors: bool,
    elapsed: Duration,
}

/// Every label lies inside the text of the file it points into, on character boundaries.
fn check_spans(c: &Compilation) -> Result<(), String> {
    for d in &c.diagnostics {
        for l in &d.labels {
            let text = &c.sources.get(l.span.file).text;
            let (start, end) = (l.span.start as usize, l.span.end as usize);
            if start > end || end > text.len() {
                return Err(format!(
                    "[{}] {}: label {start}..{end} outside a file of {} bytes",
                    d.code,
                    d.message,
                    text.len()
                ));
            }
            if !text.is_char_boundary(start) || !text.is_char_boundary(end) {
                return Err(format!(
                    "[{}] {}: label {start}..{end} splits a character",
                    d.code, d.message
                ));
            }
        }
    }
    Ok(())
}

/// Compile `text` on a worker thread (default 2 MiB stack, stricter than a main thread), check
/// the spans and render the diagnostics (which must not panic either). Gives up after `limit`
/// so that a hang fails the test instead of stalling the suite.
fn compile(name: &str, text: String, limit: Duration) -> Result<Outcome, String> {
    let (tx, rx) = mpsc::channel();
    let name = name.to_string();
    let worker = std::thread::Builder::new()
        .name(format!("compile {name}"))
        .spawn(move || {
            let start = Instant::now();
            let c = Compilation::from_source(&name, &text);
            let elapsed = start.elapsed();
            let result = check_spans(&c).map(|()| {
                let _ = c.render_diagnostics(false);
                let _ = c.emit_ast();
                let _ = c.emit_scene();
                Outcome {
                    codes: c.diagnostics.iter().map(|d| d.code).collect(),
                    has_errors: c.has_errors(),
                    elapsed,
                }
            });
            let _ = tx.send(result);
        })
        .expect("spawn worker");
    match rx.recv_timeout(limit) {
        Ok(result) => {
            let _ = worker.join();
            result
        }
        Err(mpsc::RecvTimeoutError::Timeout) => Err(format!("no result within {limit:?}")),
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            Err("the compiler panicked (see the output above)".to_string())
        }
    }
}

const LIMIT: Duration = Duration::from_secs(20);

/// The valid scenes and examples, as mutation seeds.
static SEEDS: LazyLock<Vec<String>> = LazyLock::new(|| {
    let mut seeds = Vec::new();
    for dir in ["tests/in", "examples"] {
        let mut paths: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "4ds"))
            .collect();
        paths.sort();
        for p in paths {
            seeds.push(std::fs::read_to_string(&p).unwrap());
        }
    }
    assert!(!seeds.is_empty());
    seeds
});

/// Tokens likely to break things when dropped into a scene.
const TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    "|>",
    "|",
    "||",
    "&&",
    "let",
    "fn",
    "-",
    "!",
    ",",
    ";",
    ":",
    "=",
    "==",
    "..",
    " x ",
    "if",
    "else",
    "for",
    "in",
    "sdf",
    "t",
    "p",
    "n",
    "\"",
    "/*",
    "*/",
    "//",
    "#",
    "#ff",
    "0",
    "-1",
    "1e999",
    "1e-999",
    "0deg",
    "deg",
    "import",
    "object",
    "render",
    "camera",
    "sky",
    "medium",
    "\n",
    "mod",
    "0..100000",
    "99999999999999999999",
    "->",
    ".",
    ".x",
    "é",
    "\u{0}",
    "true",
    "union(",
    "tile(",
    "hypersphere(",
    "[0, 0, 0, 0]",
];

#[derive(Debug, Clone)]
enum Mutation {
    Delete(Index, Index),
    Duplicate(Index, Index),
    Insert(Index, &'static str),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::Delete(a, b)),
        (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::Duplicate(a, b)),
        (any::<Index>(), prop::sample::select(TOKENS)).prop_map(|(a, t)| Mutation::Insert(a, t)),
    ]
}

/// Apply byte-level mutations; the result is made valid UTF-8 lossily.
fn mutate(seed: &str, mutations: &[Mutation]) -> String {
    let mut bytes = seed.as_bytes().to_vec();
    // Ranges are kept short so the mutant stays mostly recognisable.
    let range = |bytes: &Vec<u8>, a: &Index, b: &Index| {
        let start = a.index(bytes.len() + 1);
        let end = (start + b.index(24)).min(bytes.len());
        (start, end)
    };
    for m in mutations {
        match m {
            Mutation::Delete(a, b) => {
                let (s, e) = range(&bytes, a, b);
                bytes.drain(s..e);
            }
            Mutation::Duplicate(a, b) => {
                let (s, e) = range(&bytes, a, b);
                let copy = bytes[s..e].to_vec();
                bytes.splice(e..e, copy);
            }
            Mutation::Insert(a, tok) => {
                let at = a.index(bytes.len() + 1);
                bytes.splice(at..at, tok.bytes());
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

fn token_soup() -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(TOKENS), 0..80).prop_map(|ts| ts.join(" "))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_strings_never_panic(text in any::<String>()) {
        let r = compile("arbitrary.4ds", text, LIMIT);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let r = compile("bytes.4ds", text, LIMIT);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn token_soup_never_panics(text in token_soup()) {
        let r = compile("soup.4ds", text, LIMIT);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn mutated_scenes_never_panic(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let text = mutate(seed.get::<String>(&SEEDS), &mutations);
        let r = compile("mutant.4ds", text, LIMIT);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }
}

/// Every seed compiles without errors through `from_source` too (imports aside, which resolve
/// against the working directory there), so the mutation test starts from valid input.
#[test]
fn seeds_are_valid_without_imports() {
    for (i, seed) in SEEDS.iter().enumerate() {
        if seed.contains("import") {
            continue;
        }
        let r = compile("seed.4ds", seed.clone(), LIMIT).unwrap();
        assert!(!r.has_errors, "seed {i} has errors: {:?}", r.codes);
    }
}

// ---------------------------------------------------------------------------------------------
// Nesting bound: absurd depth is an error (E0012), found quickly, never a stack overflow.

const N: usize = 100_000;
// Generous for a loaded 2-core machine; quadratic behaviour on these inputs takes minutes.
const FAST: Duration = Duration::from_secs(4);

/// Timed tests run one at a time so that they do not slow each other down.
static TIMED: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn assert_deep_input_rejected(what: &str, text: String) {
    let _one_at_a_time = TIMED.lock().unwrap_or_else(|e| e.into_inner());
    let mut r = compile(what, text.clone(), LIMIT).unwrap_or_else(|e| panic!("{what}: {e}"));
    if r.elapsed >= FAST {
        // A busy machine can stall one run; a genuinely slow compile is slow twice.
        let again = compile(what, text, LIMIT).unwrap_or_else(|e| panic!("{what}: {e}"));
        r.elapsed = r.elapsed.min(again.elapsed);
    }
    assert!(r.has_errors, "{what}: expected an error, got {:?}", r.codes);
    assert!(
        r.codes.contains(&"E0012"),
        "{what}: expected E0012 (nested too deeply), got {:?}",
        r.codes
    );
    assert!(r.elapsed < FAST, "{what}: took {:?}", r.elapsed);
}

fn scene_with(expr: &str) -> String {
    format!("let deep = {expr}\nobject ball {{ shape = hypersphere(deep) }}\n")
}

#[test]
fn deep_parentheses_balanced() {
    let expr = format!("{}1{}", "(".repeat(N), ")".repeat(N));
    assert_deep_input_rejected("balanced parentheses", scene_with(&expr));
}

#[test]
fn deep_parentheses_unclosed() {
    assert_deep_input_rejected("unclosed parentheses", scene_with(&"(".repeat(N)));
}

#[test]
fn deep_brackets() {
    assert_deep_input_rejected("unclosed brackets", scene_with(&"[".repeat(N)));
    let expr = format!("{}1{}", "[".repeat(N), "]".repeat(N));
    assert_deep_input_rejected("balanced brackets", scene_with(&expr));
}

#[test]
fn deep_braces() {
    let expr = format!("{}1{}", "{".repeat(N), "}".repeat(N));
    assert_deep_input_rejected("balanced braces", scene_with(&expr));
}

#[test]
fn deep_prefix_minus() {
    assert_deep_input_rejected("prefix minus", scene_with(&format!("{}1", "-".repeat(N))));
    assert_deep_input_rejected("prefix not", scene_with(&format!("{}true", "!".repeat(N))));
    // Spaced out, so it is not one run of adjacent tokens in the source text.
    assert_deep_input_rejected("spaced minus", scene_with(&format!("{}1", "- ".repeat(N))));
    assert_deep_input_rejected(
        "alternating minus and not",
        scene_with(&format!("{}1", "-!".repeat(N / 2))),
    );
}

#[test]
fn long_pipe_chain() {
    let text = format!(
        "fn f(s: shape) -> shape = s\nobject ball {{ shape = hypersphere(1){} }}\n",
        " |> f".repeat(N)
    );
    assert_deep_input_rejected("pipe chain", text);
}

#[test]
fn long_binary_chain() {
    let expr = format!("1{}", " + 1".repeat(N));
    assert_deep_input_rejected("addition chain", scene_with(&expr));
}

#[test]
fn long_else_if_chain() {
    let expr = format!(
        "if false {{ 1 }}{} else {{ 2 }}",
        " else if false { 1 }".repeat(N)
    );
    assert_deep_input_rejected("else-if chain", scene_with(&expr));
}

#[test]
fn deep_lambda_and_sdf_chains() {
    assert_deep_input_rejected(
        "nested lambdas",
        scene_with(&format!("{}1", "|q| ".repeat(N))),
    );
    assert_deep_input_rejected(
        "nested sdf",
        format!("object o {{ shape = {}1 }}\n", "sdf |p| ".repeat(N)),
    );
}

#[test]
fn nesting_within_the_limit_is_fine() {
    let expr = format!("{}1{}", "(".repeat(200), ")".repeat(200));
    let r = compile("200 parentheses", scene_with(&expr), LIMIT).unwrap();
    assert!(
        !r.has_errors,
        "200 levels should be accepted: {:?}",
        r.codes
    );
}

/// Exponential work within the recursion depth limit must still be bounded.
#[test]
fn exponential_recursion_is_bounded() {
    let text = "fn fib(k: num) -> num = if k < 2 { k } else { fib(k - 1) + fib(k - 2) }\n\
                object ball { shape = hypersphere(fib(60) / fib(59)) }\n";
    let r = compile("fib", text.to_string(), Duration::from_secs(10))
        .unwrap_or_else(|e| panic!("fib(60): {e}"));
    assert!(
        r.has_errors,
        "fib(60) should hit an evaluation limit: {:?}",
        r.codes
    );
}

/// `hsv` of a hue that varies per point or frame is a colour field, as `rgb` of one is; a
/// constant out of range is still refused.
#[test]
fn hsv_takes_fields() {
    for (material, codes) in [
        ("diffuse(albedo: hsv(t * 1turn, 0.7, 0.9))", vec![]),
        ("|p, n| diffuse(albedo: hsv(p.x * 1turn, 0.7, 0.9))", vec![]),
        (
            "|p, n| diffuse(albedo: hsv(360deg * fract(p.w), 0.6, 0.9))",
            vec![],
        ),
        (
            "|p, n| diffuse(albedo: hsv(p.x * 1turn, 1.5, 0.9))",
            vec!["E0301"],
        ),
    ] {
        let text =
            format!("sky = rgb(1)\nobject o {{ shape = hypersphere(1), material = {material} }}\n");
        let r = compile("hsv.4ds", text, LIMIT).unwrap();
        assert_eq!(r.codes, codes, "{material}");
    }
}

// ---------------------------------------------------------------------------------------------
// Several mistakes, several diagnostics.

#[test]
fn several_mistakes_give_several_diagnostics() {
    let text = "\
object a { shape = hypersphre(1) }
object b { shape = hypersphere(-1) |> translate([2, 0, 0, 0]) }
object c { shape = hyperbox(1) |> rotate(xy, 30) }
render { szie = 64 x 64 }
";
    let r = compile("several.4ds", text.to_string(), LIMIT).unwrap();
    let errors = r.codes.iter().filter(|c| c.starts_with('E')).count();
    assert!(errors >= 4, "expected 4 errors, got {:?}", r.codes);
    for code in ["E0101", "E0301", "E0210", "E0103"] {
        assert!(r.codes.contains(&code), "missing {code} in {:?}", r.codes);
    }
}

#[test]
fn several_parse_errors_give_several_diagnostics() {
    let text = "\
let a = (1 + )
object ball { shape = hypersphere(radius = 1) }
let c = if true { 1 }
object cube { shape = hyperbox(1) }
";
    let r = compile("several_parse.4ds", text.to_string(), LIMIT).unwrap();
    assert!(
        r.codes.iter().filter(|c| **c == "E0010").count() >= 3,
        "expected three parse errors, got {:?}",
        r.codes
    );
}

// ---------------------------------------------------------------------------------------------
// The command line.

fn hyperslice(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_hyperslice"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run hyperslice")
}

fn text(out: &std::process::Output) -> String {
    format!(
        "status: {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

#[test]
fn cli_check_examples_succeeds() {
    let mut examples: Vec<String> =
        std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "4ds"))
            .map(|p| format!("examples/{}", p.file_name().unwrap().to_string_lossy()))
            .collect();
    examples.sort();
    assert!(!examples.is_empty());
    for ex in &examples {
        let out = hyperslice(&["check", ex]);
        assert_eq!(out.status.code(), Some(0), "check {ex}\n{}", text(&out));
    }
    // Several files in one call.
    let mut args = vec!["check"];
    args.extend(examples.iter().map(String::as_str));
    let out = hyperslice(&args);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}

#[test]
fn cli_check_error_file_fails() {
    let out = hyperslice(&["check", "tests/in/errors/negative_radius.4ds"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let all = text(&out);
    assert!(all.contains("E0301"), "the diagnostic is printed:\n{all}");
    // One bad file among good ones still fails the run.
    let out = hyperslice(&[
        "check",
        "tests/in/minimal.4ds",
        "tests/in/errors/unknown_name.4ds",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
}

#[test]
fn cli_check_missing_file() {
    let out = hyperslice(&["check", "tests/in/no_such_scene.4ds"]);
    assert!(!out.status.success(), "{}", text(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no_such_scene.4ds"),
        "the message names the file:\n{}",
        text(&out)
    );
    assert!(!stderr.contains("panicked"), "{}", text(&out));
}

#[test]
fn cli_warnings_do_not_fail() {
    let out = hyperslice(&["check", "tests/in/errors/unused_let.4ds"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(
        text(&out).contains("W0001"),
        "the warning is shown:\n{}",
        text(&out)
    );
}

#[test]
fn cli_compile_emits() {
    let out = hyperslice(&["compile", "examples/d4_packing.4ds", "--emit", "scene"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(!out.stdout.is_empty(), "{}", text(&out));
    let out = hyperslice(&["compile", "examples/d4_packing.4ds", "--emit", "ast"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(!out.stdout.is_empty(), "{}", text(&out));
    let out = hyperslice(&[
        "compile",
        "tests/in/errors/negative_radius.4ds",
        "--emit",
        "scene",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
}

#[test]
fn cli_rejects_bad_usage() {
    let out = hyperslice(&["frobnicate"]);
    assert!(!out.status.success(), "{}", text(&out));
    let out = hyperslice(&["compile", "examples/d4_packing.4ds", "--emit", "pixels"]);
    assert!(!out.status.success(), "{}", text(&out));
}

/// Formatting what parses keeps the syntax tree and is stable; nothing makes it panic.
fn format_keeps_the_tree(text: &str) -> Result<(), String> {
    use hyperslice::syntax::format::format;
    let Ok(out) = format(hyperslice::source::FileId(0), text) else {
        return Ok(());
    };
    let before = Compilation::from_source("a.4ds", text).emit_ast();
    let after = Compilation::from_source("a.4ds", &out).emit_ast();
    if before != after {
        return Err(format!("the tree changed:\n{text:?}\n->\n{out:?}"));
    }
    match format(hyperslice::source::FileId(0), &out) {
        Ok(again) if again == out => Ok(()),
        other => Err(format!("not idempotent:\n{out:?}\n->\n{other:?}")),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn formatting_mutants_keeps_their_tree(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 0..3),
    ) {
        let text = mutate(seed.get::<String>(&SEEDS), &mutations);
        let r = format_keeps_the_tree(&text);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn formatting_token_soup_keeps_its_tree(text in token_soup()) {
        let r = format_keeps_the_tree(&text);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }
}

// ---------------------------------------------------------------------------------------------
// What a new user types: bad flags, odd files and mistaken scenes, on every command.

/// What a case must do besides neither crashing nor garbling the terminal: succeed, or be
/// refused with a message holding every one of the strings (the value and the range).
enum Want {
    Accepted,
    Refused(&'static [&'static str]),
}

/// The files the cases use, written into a fresh directory.
fn mistakes_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    let lit = "sky = rgb(1)\nobject b { shape = hypersphere(1) }\n";
    let files: Vec<(&str, Vec<u8>)> = vec![
        (
            "good.4ds",
            format!("render {{ size = 8 x 6, spp = 1 }}\n{lit}").into_bytes(),
        ),
        (
            "anim.4ds",
            format!("render {{ size = 8 x 6, spp = 1, frames = 3 }}\n{lit}").into_bytes(),
        ),
        ("empty.4ds", vec![]),
        ("comment.4ds", b"// only a comment\n".to_vec()),
        ("binary.4ds", (0..=255u8).cycle().take(1024).collect()),
        (
            "latin1.4ds",
            b"sky = rgb(1) // caf\xe9\nobject b { shape = hypersphere(1) }\n".to_vec(),
        ),
        (
            "crlf.4ds",
            b"sky = rgb(1)\r\nobject b {\r\n\tshape = hypersfere(1)\r\n}\r\n".to_vec(),
        ),
        (
            "bidi.4ds",
            "sky = rgb(1) /* \u{202e} \u{2066} */\nobject b { shape = hypersphere(-1) } // \u{2069}\n"
                .into(),
        ),
        (
            "bidi_name.4ds",
            "sky = rgb(1)\nobject b { shape = hyper\u{202e}sphere(1) }\n".into(),
        ),
        (
            "escape.4ds",
            b"sky = rgb(1)\nobject b { shape = hypersphere(1) \x1b[31m\x9b }\n".to_vec(),
        ),
        (
            "parens.4ds",
            format!("{lit}let a = {}1\n", "(".repeat(10_000)).into_bytes(),
        ),
        (
            "long_line.4ds",
            format!("{lit}let _a = 1{} + hypersfere\n", " + 0".repeat(50)).into_bytes(),
        ),
        (
            "huge.4ds",
            b"sky = rgb(1)\nobject b { shape = hypersphere(1e400) }\n".to_vec(),
        ),
        (
            "overflow.4ds",
            b"let a = 1e308 * 10\nlet b = exp(1000)\nsky = rgb(1)\nobject o { shape = hypersphere(a + b), material = light(intensity: pow(10, 400)) }\n"
                .to_vec(),
        ),
        (
            "inf.4ds",
            b"let big = 2 * inf\nsky = rgb(1)\nobject o { shape = hypersphere(0.2) |> tile(grid(1, limit: [2, 0, big, 0])) }\n"
                .to_vec(),
        ),
        (
            "negative_zero.4ds",
            b"render { epsilon = -0 }\nsky = rgb(1)\nobject b { shape = hypersphere(-0) }\n"
                .to_vec(),
        ),
        (
            "div0.4ds",
            format!("let k = 1 / (2 - 2)\n{lit}").into_bytes(),
        ),
        (
            "recursion.4ds",
            format!("fn f(n: num) -> num = g(n + 1)\nfn g(n: num) -> num = f(n)\nlet _x = f(0)\n{lit}")
                .into_bytes(),
        ),
        ("cycle_a.4ds", format!("import \"cycle_b.4ds\"\n{lit}").into_bytes()),
        ("cycle_b.4ds", b"import \"cycle_c.4ds\"\n".to_vec()),
        ("cycle_c.4ds", b"import \"cycle_b.4ds\"\n".to_vec()),
        ("import_dir.4ds", format!("import \"folder.4ds\"\n{lit}").into_bytes()),
        ("import_binary.4ds", format!("import \"binary.4ds\"\n{lit}").into_bytes()),
        (
            "size.4ds",
            format!("render {{ size = 1 x 100000 }}\n{lit}").into_bytes(),
        ),
        (
            "seed.4ds",
            format!("render {{ seed = 1e300 }}\n{lit}").into_bytes(),
        ),
        (
            "fov.4ds",
            format!("camera {{ fov = 180deg }}\n{lit}").into_bytes(),
        ),
        (
            "fov_type.4ds",
            format!("camera {{ fov = 60 }}\n{lit}").into_bytes(),
        ),
        (
            "camera_typo.4ds",
            format!("camera {{ form = [0, 0, -4, 0] }}\n{lit}").into_bytes(),
        ),
        (
            "quality.4ds",
            format!("render {{ quality = \"fast\" }}\n{lit}").into_bytes(),
        ),
        (
            "threads.4ds",
            format!("render {{ threads = 1e10 }}\n{lit}").into_bytes(),
        ),
        (
            "let.4ds",
            b"let r = 1\nsky = rgb(1)\nobject b { shape = hypersphere(r) }\n".to_vec(),
        ),
    ];
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).expect("written");
    }
    std::fs::create_dir(dir.path().join("folder.4ds")).expect("a folder");
    std::fs::create_dir(dir.path().join("films")).expect("a folder");
    dir
}

/// Raw bytes that would act on a terminal: C0 controls but LF and tab, DEL, C1 controls and the
/// bidirectional embeddings, overrides and isolates.
fn raw_controls(bytes: &[u8]) -> Vec<char> {
    String::from_utf8_lossy(bytes)
        .chars()
        .filter(|&c| {
            (c.is_control() && c != '\n' && c != '\t')
                || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
        })
        .collect()
}

/// Every mistake below ends without a panic or an abort and without a raw control character in
/// what it prints, and every refusal gives the offending value and the allowed range.
#[test]
fn cli_new_user_mistakes() {
    use Want::*;
    let dir = mistakes_dir();
    let r = |flag: &'static str, value: &'static str| -> Vec<&'static str> {
        vec!["render", "good.4ds", "-o", "out.png", flag, value]
    };
    let cases: Vec<(Vec<&str>, Want)> = vec![
        // Render flags: every number, at and past its ends, NaN and infinities.
        (r("--size", "0x0"), Refused(&["`0`", "1 to 16384"])),
        (
            r("--size", "1x100000"),
            Refused(&["`100000`", "1 to 16384"]),
        ),
        (r("--size", "NaNxNaN"), Refused(&["`NaN`", "1 to 16384"])),
        (r("--size", "8x6x2"), Refused(&["`6x2`", "1 to 16384"])),
        (r("--spp", "inf"), Refused(&["`inf`", "1 to 1000000"])),
        (
            r("--spp", "1180591620717411303424"),
            Refused(&["`1180591620717411303424`", "1 to 1000000"]),
        ),
        (r("--bounces", "1e400"), Refused(&["`1e400`", "0 to 1000"])),
        (r("--bounces", "-0"), Accepted),
        (r("--epsilon", "NaN"), Refused(&["`NaN`", "(0, 1]"])),
        (r("--epsilon", "-0"), Refused(&["`-0`", "(0, 1]"])),
        (r("--epsilon", "1e-400"), Refused(&["`1e-400`", "(0, 1]"])),
        (
            r("--max-steps", "0x10"),
            Refused(&["`0x10`", "1 to 1000000"]),
        ),
        (
            r("--seed", "9007199254740993"),
            Refused(&["`9007199254740993`", "0 to 9007199254740992"]),
        ),
        (r("--threads", "NaN"), Refused(&["`NaN`", "0 to 1024"])),
        (
            r("--exposure", "-inf"),
            Refused(&["`-inf`", "(0, 1000000]"]),
        ),
        (r("--fps", "0"), Refused(&["`0`", "(0, 100]"])),
        (r("--frames", "1e9"), Refused(&["`1e9`", "1 to 10000"])),
        (r("--frame", "-1"), Refused(&["`-1`", "0 to 9999"])),
        (r("--frame", "NaN"), Refused(&["`NaN`", "0 to 9999"])),
        (r("--frame", "5"), Refused(&["frame 5", "1 frame"])),
        (
            r("--frame-range", "3..1"),
            Refused(&["`3..1`", "holds no frames"]),
        ),
        (r("--noise-threshold", "NaN"), Refused(&["`NaN`", "(0, 1)"])),
        (r("--noise-threshold", "-1"), Refused(&["`-1`", "(0, 1)"])),
        (
            r("--time-budget", "1e30h"),
            Refused(&["`1e30h`", "less than 10000000s"]),
        ),
        (
            r("--time-budget", "10parsecs"),
            Refused(&["`10parsecs`", "30s"]),
        ),
        (r("--shard", "3/2"), Refused(&["`3/2`", "0 <= K < N"])),
        (r("--quality", "ultra"), Refused(&["ultra", "draft"])),
        (
            vec!["render", "good.4ds", "-o", "folder.4ds"],
            Refused(&["folder.4ds", "directory"]),
        ),
        (
            vec!["render", "good.4ds", "-o", "o\x1b[31m.jpg"],
            Refused(&[".jpg", ".gif, .png or .exr"]),
        ),
        (
            vec!["render", "no\x1b[2J\u{202e}such.4ds"],
            Refused(&["such.4ds", "no such file"]),
        ),
        (
            vec!["render", "negative_zero.4ds"],
            Refused(&["-0", "(0, 1]"]),
        ),
        // Compile, merge, bench, fmt, explain.
        (
            vec!["compile", "anim.4ds", "--emit", "ir", "--frame", "99"],
            Refused(&["frame 99", "0 to 2"]),
        ),
        (
            vec!["compile", "anim.4ds", "--emit", "ir", "--t", "NaN"],
            Refused(&["`NaN`", "0 to 1"]),
        ),
        (
            vec!["compile", "anim.4ds", "--emit", "ir", "--t", "-inf"],
            Refused(&["`-inf`", "0 to 1"]),
        ),
        (
            vec!["compile", "anim.4ds", "--emit", "ir", "--t", "2"],
            Refused(&["`2`", "0 to 1"]),
        ),
        (
            vec!["compile", "good.4ds", "--check", "binary.4ds"],
            Refused(&["binary.4ds"]),
        ),
        (
            vec!["merge", "films", "-o", "m.gif", "--fps", "NaN"],
            Refused(&["`NaN`", "(0, 100]"]),
        ),
        (vec!["merge", "films", "-o", "m.gif"], Refused(&["films"])),
        (
            vec!["merge", "no\x1b[0mdir", "-o", "m.gif"],
            Refused(&["dir"]),
        ),
        (
            vec!["bench", "good.4ds", "--quick", "--repeats", "-1"],
            Refused(&["`-1`", "1 to 100"]),
        ),
        (
            vec!["bench", "good.4ds", "--quick", "--reference-spp", "NaN"],
            Refused(&["`NaN`", "1 to 100000000"]),
        ),
        (
            vec![
                "bench",
                "--marcher-corpus",
                "--generated",
                "99999999999999999999",
            ],
            Refused(&["`99999999999999999999`", "0 to 10000"]),
        ),
        (
            vec!["bench", "good.4ds", "--quick", "--spp-list", "0,1"],
            Refused(&["`0`", "1..=1000000"]),
        ),
        (
            vec!["fmt", "--check", "binary.4ds"],
            Refused(&["binary.4ds", "UTF-8"]),
        ),
        (vec!["fmt", "folder.4ds"], Refused(&["folder.4ds"])),
        (
            vec!["fmt", "--check", "parens.4ds"],
            Refused(&["parens.4ds", "256"]),
        ),
        (
            vec!["explain", "E\x1b[2J0201\u{202e}"],
            Refused(&["no diagnostic code", "E0201,"]),
        ),
        // Odd files.
        (vec!["check", "empty.4ds"], Accepted),
        (vec!["check", "comment.4ds"], Accepted),
        (
            vec!["check", "binary.4ds"],
            Refused(&["binary.4ds", "UTF-8"]),
        ),
        (
            vec!["check", "latin1.4ds"],
            Refused(&["latin1.4ds", "UTF-8"]),
        ),
        (
            vec!["check", "folder.4ds"],
            Refused(&["folder.4ds", "directory"]),
        ),
        (
            vec!["check", "crlf.4ds"],
            Refused(&["crlf.4ds:3:", "hypersphere"]),
        ),
        (
            vec!["check", "bidi.4ds"],
            Refused(&["-1", "at least 0", "\\u{2069}"]),
        ),
        (
            vec!["check", "--message-format", "json", "bidi.4ds"],
            Refused(&["-1", "at least 0"]),
        ),
        (vec!["check", "bidi_name.4ds"], Refused(&["\\u{202e}"])),
        (vec!["check", "escape.4ds"], Refused(&["\u{241b}"])),
        (vec!["check", "parens.4ds"], Refused(&["256"])),
        (
            vec!["check", "long_line.4ds"],
            Refused(&["hypersfere", "hypersphere"]),
        ),
        (vec!["check", "huge.4ds"], Refused(&["1e400", "1.8e308"])),
        (
            vec!["check", "overflow.4ds"],
            Refused(&["infinity", "1.8e308", "3 errors"]),
        ),
        (vec!["check", "inf.4ds"], Accepted),
        (
            vec!["check", "div0.4ds"],
            Refused(&["E0302", "this is zero"]),
        ),
        (vec!["check", "recursion.4ds"], Refused(&["E0401", "64"])),
        (
            vec!["check", "cycle_a.4ds"],
            Refused(&["E0501", "cycle_b.4ds"]),
        ),
        (
            vec!["check", "import_dir.4ds"],
            Refused(&["folder.4ds", "directory"]),
        ),
        (
            vec!["check", "import_binary.4ds"],
            Refused(&["binary.4ds", "UTF-8"]),
        ),
        // Scene mistakes.
        (
            vec!["check", "size.4ds"],
            Refused(&["1 x 100000", "1 to 16384"]),
        ),
        (
            vec!["check", "seed.4ds"],
            Refused(&["1e300", "0 to 9007199254740992"]),
        ),
        (
            vec!["check", "threads.4ds"],
            Refused(&["10000000000", "0 to 1024"]),
        ),
        (
            vec!["check", "fov.4ds"],
            Refused(&["180deg", "between 0deg and 180deg"]),
        ),
        (vec!["check", "fov_type.4ds"], Refused(&["E0210", "angle"])),
        (vec!["check", "camera_typo.4ds"], Refused(&["form", "from"])),
        (vec!["check", "quality.4ds"], Refused(&["fast", "draft"])),
        (
            vec!["check", "let.4ds", "-D", "r=1\u{202e}"],
            Refused(&["\\u{202e}"]),
        ),
        (
            vec!["check", "let.4ds", "-D", "r=-1"],
            Refused(&["-1", "at least 0"]),
        ),
        (
            vec!["check", "let.4ds", "-D", "r=1e308 * 10"],
            Refused(&["infinity", "1.8e308"]),
        ),
    ];
    let mut failures = vec![];
    for (args, want) in &cases {
        let out = Command::new(env!("CARGO_BIN_EXE_hyperslice"))
            .args(args)
            .current_dir(dir.path())
            .output()
            .expect("run hyperslice");
        let all = [out.stdout.as_slice(), out.stderr.as_slice()].concat();
        let text = String::from_utf8_lossy(&all);
        let mut wrong = vec![];
        match out.status.code() {
            None | Some(101 | 134) => wrong.push(format!("crashed: {:?}", out.status)),
            _ if text.contains("panicked") => wrong.push("panicked".to_string()),
            _ => {}
        }
        let raw = raw_controls(&all);
        if !raw.is_empty() {
            wrong.push(format!("raw {raw:?}"));
        }
        match want {
            Accepted if !out.status.success() => wrong.push("refused".to_string()),
            Refused(_) if out.status.success() => wrong.push("accepted".to_string()),
            Refused(says) => {
                for s in says.iter().filter(|s| !text.contains(*s)) {
                    wrong.push(format!("no {s:?}"));
                }
            }
            _ => {}
        }
        if !wrong.is_empty() {
            failures.push(format!("{args:?}: {}\n{text}", wrong.join(", ")));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// Standard input that is not a scene: `fmt -` refuses bytes that are not UTF-8, and the
/// language server ends on a stream that is not its protocol; neither panics nor echoes it raw.
#[test]
fn cli_odd_standard_input() {
    use std::io::Write;
    for (args, input) in [
        (["fmt", "-"], (0..=255u8).collect::<Vec<u8>>()),
        (
            ["lsp", "--color=never"],
            b"garbage\r\n\r\n\x00\x1b[2J".to_vec(),
        ),
        (
            ["lsp", "--color=never"],
            b"Content-Length: 99999999999999999999\r\n\r\n{}".to_vec(),
        ),
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_hyperslice"))
            .args(args)
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("run hyperslice");
        let mut stdin = child.stdin.take().expect("stdin");
        // The server may stop reading before the end; a broken pipe is fine.
        let _ = stdin.write_all(&input);
        drop(stdin);
        let out = child.wait_with_output().expect("it ends");
        let all = [out.stdout.as_slice(), out.stderr.as_slice()].concat();
        let text = String::from_utf8_lossy(&all);
        assert!(
            !matches!(out.status.code(), None | Some(101 | 134)) && !text.contains("panicked"),
            "{args:?}: {:?}\n{text}",
            out.status
        );
        assert!(!out.status.success(), "{args:?}: {text}");
        assert!(raw_controls(&all).is_empty(), "{args:?}: {text}");
    }
}
