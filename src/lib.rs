//! hyperslice: a renderer for four-dimensional scenes written in the `.4ds` language.
//!
//! The pipeline runs one way: source -> tokens -> AST -> typed scene (see `docs/`).

pub mod check;
pub mod denoise;
pub mod diagnostic;
pub mod film;
pub mod ir;
pub mod metrics;
pub mod output;
pub mod render;
pub mod simd;
pub mod source;
pub mod sweep;
pub mod syntax;
pub mod vm;

use diagnostic::Diagnostic;
use source::SourceMap;
use std::path::Path;

/// Everything one compilation produced: the loaded sources, the diagnostics of every stage,
/// the root file's syntax tree and, when there were no errors, the typed scene.
pub struct Compilation {
    pub sources: SourceMap,
    pub diagnostics: Vec<Diagnostic>,
    pub ast: syntax::ast::Ast,
    pub scene: Option<check::Scene>,
}

impl Compilation {
    /// Compile a file from disk; imports resolve relative to it.
    pub fn from_path(path: &Path) -> Compilation {
        check::compile_path(path)
    }

    /// Compile text held in memory; imports resolve relative to the current directory.
    pub fn from_source(name: &str, text: &str) -> Compilation {
        check::compile_source(name, text)
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

    /// `--emit ir`: the optimised SDF IR, with `t` left free.
    pub fn emit_ir(&self) -> Option<String> {
        self.program().map(|p| p.ir.to_string())
    }

    /// `--emit bytecode`: every tape of the scene.
    pub fn emit_bytecode(&self) -> Option<String> {
        self.program().map(|p| p.to_string())
    }

    /// The compiled VM program, if the scene compiled.
    pub fn program(&self) -> Option<vm::Program> {
        self.scene.as_ref().map(|s| vm::Program::new(s, None))
    }
}
