//! hyperslice: a renderer for four-dimensional scenes written in the `.4ds` language.
//!
//! The pipeline runs one way: source -> tokens -> AST -> typed scene (see `docs/`).

pub mod check;
pub mod compile;
pub mod denoise;
pub mod diagnostic;
pub mod error;
pub mod ir;
pub mod math;
pub mod metrics;
pub mod output;
pub mod render;
pub mod scene;
pub mod source;
pub mod sweep;
pub mod syntax;
pub mod vm;

use diagnostic::Diagnostic;
use source::SourceMap;
use std::path::Path;

/// Which frame `--emit ir|bytecode` shows: tapes are specialised per frame, so the text is
/// exactly what that frame renders with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum At {
    /// Frame number (0 is the first).
    Frame(u32),
    /// An animation time `t` (0 on the first frame, 1 on the last).
    Time(f64),
}

impl std::default::Default for At {
    fn default() -> At {
        At::Frame(0)
    }
}

/// Everything one compilation produced: the loaded sources, the diagnostics of every stage,
/// the root file's syntax tree and, when there were no errors, the typed scene.
pub struct Compilation {
    pub sources: SourceMap,
    pub diagnostics: Vec<Diagnostic>,
    pub ast: syntax::ast::Ast,
    pub scene: Option<scene::Scene>,
}

impl From<check::Checked> for Compilation {
    fn from(c: check::Checked) -> Compilation {
        Compilation {
            sources: c.sources,
            diagnostics: c.diagnostics,
            ast: c.ast,
            scene: c.scene,
        }
    }
}

impl Compilation {
    /// Compile a file from disk; imports resolve relative to it.
    pub fn from_path(path: &Path) -> Compilation {
        check::compile_path(path).into()
    }

    /// Compile text held in memory; imports resolve relative to the current directory.
    pub fn from_source(name: &str, text: &str) -> Compilation {
        check::compile_source(name, text).into()
    }

    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }

    pub fn render_diagnostics(&self, color: bool) -> String {
        diagnostic::render_all(&self.diagnostics, &self.sources, color)
    }

    /// `--emit ast`
    pub fn emit_ast(&self) -> String {
        syntax::print::print_ast(&self.ast)
    }

    /// `--emit scene`: the typed, constant-evaluated scene, if it compiled.
    pub fn emit_scene(&self) -> Option<String> {
        self.scene.as_ref().map(|s| s.to_string())
    }

    /// `--emit ir`: the optimised SDF IR that frame `at` renders with.
    pub fn emit_ir(&self, at: At) -> Option<String> {
        self.program(at).map(|p| p.ir.to_string())
    }

    /// `--emit bytecode`: every tape that frame `at` renders with.
    pub fn emit_bytecode(&self, at: At) -> Option<String> {
        self.program(at).map(|p| p.to_string())
    }

    /// The scene lowered once, if it compiled.
    pub fn compiled(&self) -> Option<compile::Compiled> {
        self.scene.as_ref().map(compile::Compiled::new)
    }

    /// The tapes of frame `at`, if the scene compiled.
    pub fn program(&self, at: At) -> Option<vm::Program> {
        let scene = self.scene.as_ref()?;
        let t = match at {
            At::Frame(f) => compile::frame_time(f, scene.render.frames),
            At::Time(t) => t,
        };
        self.compiled().map(|c| c.program(Some(t)))
    }
}
