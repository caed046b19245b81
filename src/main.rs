//! The `hyperslice` command line.

use clap::{Parser, Subcommand, ValueEnum};
use hyperslice::scene::Scene;
use hyperslice::{At, Compilation};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

mod bench_command;
mod compile_command;
mod render_command;

#[derive(Parser)]
#[command(
    name = "hyperslice",
    version,
    about = "Render four-dimensional scenes written in the .4ds language"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Colour in diagnostics: auto (when stderr is a terminal), always or never.
    #[arg(long, global = true, default_value = "auto")]
    color: ColorChoice,
}

#[derive(Clone, Copy, ValueEnum)]
enum ColorChoice {
    Auto,
    Always,
    Never,
}

#[derive(Subcommand)]
enum Command {
    /// Parse and type-check scenes; print diagnostics. Exit 1 if any has an error.
    Check {
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Render a scene to an animated GIF, PNG frames or EXR frames.
    Render(render_command::RenderArgs),
    /// Measure speed against accuracy: a reference render, then a sweep of settings, each
    /// timed and compared with it; writes a table, CSV and a plot.
    Bench(bench_command::BenchArgs),
    /// Compile a scene and print one stage of it, write it to a file, or check it against one.
    Compile(compile_command::CompileArgs),
    /// Explain a diagnostic code (such as E0201) with an example and its fix.
    Explain { code: String },
}

/// Compile `file` for a command that renders it and print its diagnostics (in colour when
/// `color`); the scene when it compiled.
fn compile(file: &Path, color: bool) -> Option<Scene> {
    let c = Compilation::from_path(file);
    eprint!("{}", c.render_diagnostics(color));
    c.scene
}

/// The exit status of a command that ended with `result`, its error printed.
fn finish(result: hyperslice::error::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let color = match cli.color {
        ColorChoice::Auto => {
            std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none()
        }
        ColorChoice::Always => true,
        ColorChoice::Never => false,
    };
    match cli.command {
        Command::Check { files } => {
            let mut failed = false;
            for file in &files {
                let c = Compilation::from_path(file);
                eprint!("{}", c.render_diagnostics(color));
                if c.has_errors() {
                    failed = true;
                } else if let Some(scene) = &c.scene {
                    let warnings = c.diagnostics.len();
                    let Some(tape) = c.program(At::default()).map(|p| p.scene) else {
                        continue;
                    };
                    eprintln!(
                        "{}: ok ({} object{}, {} frame{}, scene tape {} ops in {} registers{})",
                        file.display(),
                        scene.objects.len(),
                        if scene.objects.len() == 1 { "" } else { "s" },
                        scene.render.frames,
                        if scene.render.frames == 1 { "" } else { "s" },
                        tape.code.len(),
                        tape.regs,
                        if warnings > 0 {
                            format!(
                                ", {warnings} warning{}",
                                if warnings == 1 { "" } else { "s" }
                            )
                        } else {
                            String::new()
                        }
                    );
                }
            }
            if failed {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            }
        }
        Command::Render(args) => render_command::run(args, color),
        Command::Bench(args) => bench_command::run(args, color),
        Command::Compile(args) => compile_command::run(args, color),
        Command::Explain { code } => match hyperslice::codes::find(&code) {
            Some(c) => {
                print!("{}", hyperslice::codes::explain(c));
                ExitCode::SUCCESS
            }
            None => {
                let known: Vec<&str> = hyperslice::codes::CODES.iter().map(|c| c.code).collect();
                eprintln!(
                    "error: no diagnostic code `{code}`; the codes are {}",
                    known.join(", ")
                );
                ExitCode::FAILURE
            }
        },
    }
}
