//! `hyperslice fmt`: format scenes in place, check that they are formatted, or format standard
//! input to standard output.

use clap::Args;
use hyperslice::diagnostic;
use hyperslice::source::SourceMap;
use hyperslice::syntax::format::format;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args)]
pub struct FmtArgs {
    /// Files to format in place; `-` formats standard input to standard output.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Change nothing: list the files that would change and exit 1 if there are any.
    #[arg(long)]
    check: bool,
}

/// The formatted text, or the diagnostics (printed) of a file that does not parse.
fn formatted(name: &str, text: &str, color: bool) -> Option<String> {
    let mut sources = SourceMap::new();
    let id = sources.add(name, None, text);
    match format(id, text) {
        Ok(out) => Some(out),
        Err(diags) => {
            eprint!("{}", diagnostic::render_all(&diags, &sources, color));
            eprintln!("error: `{name}` does not parse, so it was not formatted");
            None
        }
    }
}

pub fn run(args: FmtArgs, color: bool) -> ExitCode {
    let mut failed = false;
    let mut changed = vec![];
    for file in &args.files {
        if file == Path::new("-") {
            let mut text = String::new();
            if let Err(e) = std::io::stdin().read_to_string(&mut text) {
                eprintln!("error: cannot read standard input: {e}");
                return ExitCode::FAILURE;
            }
            match formatted("<stdin>", &text, color) {
                Some(out) if args.check => {
                    if out != text {
                        changed.push("<stdin>".to_string());
                    }
                }
                Some(out) => {
                    let _ = std::io::stdout().write_all(out.as_bytes());
                }
                None => failed = true,
            }
            continue;
        }
        let name = file.display().to_string();
        let text = match std::fs::read(file).map(String::from_utf8) {
            Ok(Ok(t)) => t,
            Ok(Err(_)) => {
                eprintln!("error: `{name}` is not UTF-8 text");
                failed = true;
                continue;
            }
            Err(e) => {
                eprintln!("error: cannot read `{name}`: {e}");
                failed = true;
                continue;
            }
        };
        let Some(out) = formatted(&name, &text, color) else {
            failed = true;
            continue;
        };
        if out == text {
            continue;
        }
        if args.check {
            changed.push(name);
        } else {
            // The atomic write makes a new file; it keeps the old one's permissions.
            let permissions = std::fs::metadata(file).map(|m| m.permissions());
            let written = hyperslice::output::write_atomic(file, out.as_bytes())
                .map_err(|e| e.to_string())
                .and_then(|()| match permissions {
                    Ok(p) => std::fs::set_permissions(file, p).map_err(|e| e.to_string()),
                    Err(_) => Ok(()),
                });
            if let Err(e) = written {
                eprintln!("error: cannot write `{name}`: {e}");
                failed = true;
            }
        }
    }
    for name in &changed {
        println!("{name}");
    }
    if failed || !changed.is_empty() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
