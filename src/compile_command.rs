//! `hyperslice compile`: print one compiled stage of a scene, write it to a file, or check it
//! against a file written earlier (a snapshot test for users without Rust).

use clap::{Args, ValueEnum};
use hyperslice::At;
use hyperslice::output;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args)]
pub struct CompileArgs {
    file: PathBuf,
    /// The stage to print.
    #[arg(long, default_value = "scene")]
    emit: Emit,
    /// For `ir` and `bytecode`: the frame whose tapes to show (0 is the first; the default).
    #[arg(long, conflicts_with = "t", allow_hyphen_values = true, value_parser = crate::render_command::parse_frame)]
    frame: Option<u32>,
    /// For `ir` and `bytecode`: the animation time `t` whose tapes to show (0 to 1).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_t)]
    t: Option<f64>,
    /// For `bytecode`: instead of the whole tapes, those of the cell that the cells' marcher
    /// runs at the point X,Y,Z,W (world coordinates) in that frame.
    #[arg(long, value_name = "X,Y,Z,W", allow_hyphen_values = true, value_parser = parse_point)]
    cell: Option<[f64; 4]>,
    /// Write the text to FILE (atomically) instead of standard output.
    #[arg(long, value_name = "FILE", conflicts_with = "check")]
    out: Option<PathBuf>,
    /// Compare the text with FILE (written earlier with `--out`); exit 1 with a diff if the
    /// compiled scene changed.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
    #[command(flatten)]
    scene: crate::SceneArgs,
}

/// `--t`: a time of the animation, from 0 (the first frame) to 1 (the last).
fn parse_t(s: &str) -> Result<f64, String> {
    let range = "t must be a number from 0 to 1";
    match s.trim().parse::<f64>() {
        Ok(t) if (0.0..=1.0).contains(&t) => Ok(t),
        Ok(t) if t.is_finite() => Err(format!("`{s}` is out of range: {range}")),
        _ => Err(format!("`{s}` is not a number: {range}")),
    }
}

/// `--cell`: a point as four finite numbers separated by commas.
fn parse_point(s: &str) -> Result<[f64; 4], String> {
    let form = "--cell takes a point as four finite numbers X,Y,Z,W, such as 0,1.5,-2,0";
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 4 {
        return Err(format!(
            "`{s}` has {} coordinate{}: {form}",
            parts.len(),
            if parts.len() == 1 { "" } else { "s" }
        ));
    }
    let mut point = [0.0; 4];
    for (x, part) in point.iter_mut().zip(parts) {
        match part.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => *x = v,
            _ => return Err(format!("`{}` is not a finite number: {form}", part.trim())),
        }
    }
    Ok(point)
}

#[derive(Clone, Copy, ValueEnum)]
enum Emit {
    /// The syntax tree.
    Ast,
    /// The typed, constant-evaluated scene.
    Scene,
    /// The optimised SDF IR one frame renders with.
    Ir,
    /// The bytecode tapes one frame renders with.
    Bytecode,
}

pub fn run(args: CompileArgs, color: bool) -> ExitCode {
    let c = args.scene.compile(&args.file);
    args.scene.report(&c, color);
    if c.has_errors() {
        return ExitCode::FAILURE;
    }
    let at = match (args.frame, args.t) {
        (_, Some(t)) => At::Time(t),
        (f, None) => At::Frame(f.unwrap_or(0)),
    };
    if let (Some(f), Some(scene)) = (args.frame, &c.scene)
        && f >= scene.render.frames
    {
        eprintln!(
            "error: frame {f} does not exist; the scene has {} frame{} (0 to {})",
            scene.render.frames,
            if scene.render.frames == 1 { "" } else { "s" },
            scene.render.frames - 1
        );
        return ExitCode::FAILURE;
    }
    let text = match (args.emit, args.cell) {
        (Emit::Bytecode, Some(p)) => c.emit_cell_bytecode(at, p),
        (_, Some(_)) => {
            eprintln!("error: --cell shows the tapes of one cell: use it with --emit bytecode");
            return ExitCode::from(2);
        }
        (Emit::Ast, None) => Some(c.emit_ast()),
        (Emit::Scene, None) => c.emit_scene(),
        (Emit::Ir, None) => c.emit_ir(at),
        (Emit::Bytecode, None) => c.emit_bytecode(at),
    }
    .unwrap_or_default();
    if let Some(path) = &args.out {
        return match output::write_derived(path, &args.file, text.as_bytes()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    if let Some(path) = &args.check {
        return check(path, &text);
    }
    print!("{text}");
    ExitCode::SUCCESS
}

/// Exit 0 when `path` holds exactly `text`; otherwise print a line diff and exit 1.
fn check(path: &Path, text: &str) -> ExitCode {
    let old = match std::fs::read_to_string(path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: cannot read `{}`: {e}", path.display());
            eprintln!("help: write it first with `--out {}`", path.display());
            return ExitCode::FAILURE;
        }
    };
    if old == text {
        return ExitCode::SUCCESS;
    }
    let diff = similar::TextDiff::from_lines(old.as_str(), text);
    eprintln!(
        "error: the compiled scene differs from `{}` (- was, + now):",
        path.display()
    );
    let name = path.display().to_string();
    // The file may hold anything; its lines reach the terminal escaped.
    eprint!(
        "{}",
        hyperslice::diagnostic::escape_controls(
            &diff
                .unified_diff()
                .context_radius(2)
                .header(&name, "now")
                .to_string()
        )
    );
    eprintln!(
        "help: if the change is intended, write it again with `--out {}`",
        path.display()
    );
    ExitCode::FAILURE
}
