//! The `hyperslice` command line.

use clap::{Parser, Subcommand, ValueEnum};
use hyperslice::scene::Scene;
use hyperslice::{At, Compilation};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Every line the commands print on standard error goes through `escape_controls`: a file
/// name, an argument or an error's text echoed raw could hold ESC (recolouring the terminal), CR
/// (overwriting the line) or a bidirectional override (reordering it). Defined before the
/// modules, it stands in for the standard `eprintln!` in all of them. Reports, whose colours are
/// escapes on purpose, are printed with `eprint!`, after escaping what they quote themselves.
macro_rules! eprintln {
    () => {
        ::std::eprintln!()
    };
    ($($arg:tt)*) => {
        ::std::eprintln!(
            "{}",
            hyperslice::diagnostic::escape_controls(&::std::format!($($arg)*))
        )
    };
}

mod bench_command;
mod compile_command;
mod cpu_check;
mod fmt_command;
mod lsp_command;
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

/// What every command that compiles a scene takes: overrides and the diagnostics' format.
#[derive(clap::Args, Clone, Default)]
pub struct SceneArgs {
    /// Override a top-level `let` of the scene: NAME=VALUE, with VALUE a constant expression of
    /// the same type (repeat for several).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<String>,
    /// Diagnostics as reports with the source (human), or as one JSON object per line on
    /// standard output (json), like cargo's.
    #[arg(long, value_enum, default_value_t)]
    pub message_format: MessageFormat,
}

#[derive(Clone, Copy, Default, PartialEq, Eq, ValueEnum)]
pub enum MessageFormat {
    #[default]
    Human,
    Json,
}

impl SceneArgs {
    pub fn compile(&self, file: &Path) -> Compilation {
        Compilation::from_path_with(file, &self.define)
    }

    /// Print the diagnostics of `c` in the chosen format.
    pub fn report(&self, c: &Compilation, color: bool) {
        match self.message_format {
            MessageFormat::Human => eprint!("{}", c.render_diagnostics(color)),
            MessageFormat::Json => {
                for d in &c.diagnostics {
                    println!(
                        "{}",
                        hyperslice::diagnostic::json_line(&d.to_json(&c.sources))
                    );
                }
            }
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Parse and type-check scenes; print diagnostics. Exit 1 if any has an error.
    Check {
        #[arg(required = true)]
        files: Vec<PathBuf>,
        #[command(flatten)]
        scene: SceneArgs,
    },
    /// Render a scene to an animated GIF, PNG frames or EXR frames.
    Render(render_command::RenderArgs),
    /// Put the films of a sharded render (`render --shard K/N --films DIR`) together: check
    /// that every shard is there and finished, sum sample ranges, denoise across frames and
    /// encode, exactly as one machine's render would.
    Merge(render_command::MergeArgs),
    /// Measure speed against accuracy: a reference render, then a sweep of settings, each
    /// timed and compared with it; writes a table, CSV and a plot.
    Bench(bench_command::BenchArgs),
    /// Compile a scene and print one stage of it, write it to a file, or check it against one.
    Compile(compile_command::CompileArgs),
    /// Format scenes in place (`--check`: only list those that would change; `-`: standard
    /// input to standard output).
    Fmt(fmt_command::FmtArgs),
    /// Run the language server over standard input and output (for editors).
    Lsp,
    /// Explain a diagnostic code (such as E0201) with an example and its fix.
    Explain { code: String },
}

/// Compile `file` for a command that renders it and print its diagnostics (in colour when
/// `color`); the scene when it compiled.
fn compile(file: &Path, args: &SceneArgs, color: bool) -> Option<Scene> {
    let c = args.compile(file);
    args.report(&c, color);
    c.scene
}

/// The exit status of a command that ended with `result`, its error printed.
fn finish(result: hyperslice::error::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // Interrupted: what was kept and how to resume is already said.
        Err(hyperslice::Error::Cancelled) => ExitCode::from(130),
        Err(e) => {
            eprintln!("error: {e}");
            if let Some(hint) = render_command::flags_for(&e) {
                eprintln!("  hint: {hint}");
            }
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
        Command::Check { files, scene: args } => {
            let mut failed = false;
            for file in &files {
                let c = args.compile(file);
                args.report(&c, color);
                if c.has_errors() {
                    failed = true;
                    let errors = c.diagnostics.iter().filter(|d| d.is_error()).count();
                    let warnings = c.diagnostics.len() - errors;
                    let count = |n: usize, what: &str| {
                        format!("{n} {what}{}", if n == 1 { "" } else { "s" })
                    };
                    eprintln!(
                        "{}: error: {}{}",
                        file.display(),
                        count(errors, "error"),
                        if warnings > 0 {
                            format!(", {}", count(warnings, "warning"))
                        } else {
                            String::new()
                        }
                    );
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
        Command::Merge(args) => finish(render_command::merge(args)),
        Command::Bench(args) => bench_command::run(args, color),
        Command::Compile(args) => compile_command::run(args, color),
        Command::Fmt(args) => fmt_command::run(args, color),
        Command::Lsp => lsp_command::run(),
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
