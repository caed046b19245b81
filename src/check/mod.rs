//! From syntax to a typed scene: loads imports, evaluates the constant stage, checks types and
//! ranges, and collects what depends on `p`, `n` or `t` as field expressions.

mod builtins;
pub(crate) mod context;
mod eval;
mod ops;
mod scene;
mod suggest;
pub(crate) mod value;

pub use context::Resolved;

use crate::diagnostic::Diagnostic;
use crate::source::{FileId, SourceMap, Span};
use crate::syntax::{self, ast::Ast, ast::ItemKind};
use std::path::{Path, PathBuf};

/// What checking produced: the loaded sources, the diagnostics of every stage so far, the root
/// file's syntax tree and, when there were no errors, the typed scene.
pub struct Checked {
    pub sources: SourceMap,
    pub diagnostics: Vec<Diagnostic>,
    pub ast: Ast,
    pub scene: Option<crate::scene::Scene>,
    /// Every name use resolved to its definition (empty when parsing failed).
    pub resolved: Vec<context::Resolved>,
}

/// Longest chain of imports, and most files in one compilation.
const MAX_IMPORT_DEPTH: usize = 64;
const MAX_FILES: usize = 1000;
/// Diagnostics beyond this many are summarised.
const MAX_DIAGNOSTICS: usize = 100;

/// Compile a file; `defines` are `-D NAME=VALUE` overrides of its top-level `let`s.
pub fn compile_path(path: &Path, defines: &[String]) -> Checked {
    let mut loader = Loader::default();
    match loader.read(path, &path.display().to_string(), None) {
        Ok(root) => loader.finish(root, defines),
        Err(d) => Checked {
            sources: loader.sources,
            diagnostics: vec![d],
            ast: Ast::default(),
            scene: None,
            resolved: vec![],
        },
    }
}

/// Compile the text of the file at `path` as it is in an editor, not on disk: imports resolve
/// relative to `path`.
pub fn compile_text(path: &Path, text: &str) -> Checked {
    let mut loader = Loader::default();
    let root = loader
        .sources
        .add(path.display().to_string(), Some(path), text);
    loader.finish(root, &[])
}

pub fn compile_source(name: &str, text: &str) -> Checked {
    let mut loader = Loader::default();
    let root = loader.sources.add(name, None, text);
    loader.finish(root, &[])
}

#[derive(Default)]
struct Loader {
    sources: SourceMap,
    asts: Vec<Ast>,
    imports: Vec<Vec<FileId>>,
    diags: Vec<Diagnostic>,
}

impl Loader {
    /// Read a file into the source map; missing and non-UTF-8 files are errors at `from`.
    fn read(&mut self, path: &Path, name: &str, from: Option<Span>) -> Result<FileId, Diagnostic> {
        let bytes = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) => {
                let d =
                    Diagnostic::error("E0502", format!("cannot read `{name}`: {}", io_reason(&e)));
                let d = match from {
                    Some(span) => d
                        .label(span, "imported here")
                        .help("import paths are relative to the importing file"),
                    None => d.help("check the path and that the file is readable"),
                };
                return Err(d);
            }
        };
        match String::from_utf8(bytes) {
            Ok(text) => Ok(self.sources.add(name, Some(path), text)),
            Err(e) => {
                let at = e.utf8_error().valid_up_to();
                let text = String::from_utf8_lossy(e.as_bytes()).into_owned();
                let id = self.sources.add(name, Some(path), text);
                let line = self.sources.line_col(id, at).0;
                let mut d = Diagnostic::error("E0503", format!("`{name}` is not valid UTF-8"))
                    .label(
                        Span::new(id, at, at + '\u{FFFD}'.len_utf8()),
                        format!("byte {at} (line {line}) is not UTF-8"),
                    )
                    .help("save the file as UTF-8 text; a .4ds file is plain text");
                if let Some(span) = from {
                    d = d.label(span, "imported here");
                }
                Err(d)
            }
        }
    }

    /// Parse a file and, depth first, everything it imports.
    fn load(&mut self, file: FileId, stack: &mut Vec<(PathBuf, FileId)>) {
        while self.asts.len() <= file.0 as usize {
            self.asts.push(Ast::default());
            self.imports.push(vec![]);
        }
        let (ast, diags) = syntax::parse(file, &self.sources.get(file).text);
        self.diags.extend(diags);
        let dir = self
            .sources
            .get(file)
            .path
            .as_ref()
            .and_then(|p| p.parent().map(Path::to_path_buf))
            .unwrap_or_default();
        let imports: Vec<(String, Span)> = ast
            .items
            .iter()
            .filter_map(|i| match &i.kind {
                ItemKind::Import { path, path_span } => Some((path.clone(), *path_span)),
                _ => None,
            })
            .collect();
        self.asts[file.0 as usize] = ast;
        for (rel, span) in imports {
            // An unterminated path was reported by the lexer; reading it would only add noise.
            if !self.sources.snippet(span).ends_with('"') || self.sources.snippet(span).len() < 2 {
                continue;
            }
            let path = dir.join(&rel);
            let canon = std::fs::canonicalize(&path).unwrap_or(path.clone());
            if let Some(pos) = stack.iter().position(|(p, _)| *p == canon) {
                let chain: Vec<String> = stack[pos..]
                    .iter()
                    .map(|(_, f)| format!("`{}`", self.sources.get(*f).name))
                    .chain([format!("`{}`", self.sources.get(stack[pos].1).name)])
                    .collect();
                self.diags.push(
                    Diagnostic::error("E0501", "import cycle")
                        .label(span, format!("`{rel}` is already being imported"))
                        .note(format!("the cycle: {}", chain.join(" imports ")))
                        .help("move the shared definitions into a third file that both import"),
                );
                continue;
            }
            if stack.len() >= MAX_IMPORT_DEPTH || self.asts.len() >= MAX_FILES {
                self.diags.push(
                    Diagnostic::error("E0402", "too many imports")
                        .label(span, format!("imports may nest {MAX_IMPORT_DEPTH} deep and load {MAX_FILES} files at most")),
                );
                continue;
            }
            let id = match self.sources.find_path(&canon) {
                Some(id) => id,
                None => {
                    let name = display_relative(&path);
                    match self.read(&canon, &name, Some(span)) {
                        Ok(id) => {
                            stack.push((canon.clone(), id));
                            self.load(id, stack);
                            stack.pop();
                            self.check_library(id, span);
                            id
                        }
                        Err(d) => {
                            self.diags.push(d);
                            continue;
                        }
                    }
                }
            };
            self.imports[file.0 as usize].push(id);
        }
    }

    /// An imported file holds definitions only.
    fn check_library(&mut self, file: FileId, import: Span) {
        for item in &self.asts[file.0 as usize].items {
            let what = match &item.kind {
                ItemKind::Object { .. } => "an object",
                ItemKind::Block { kind, .. } => kind.keyword(),
                ItemKind::Sky(_) => "sky",
                ItemKind::Medium(_) => "medium",
                _ => continue,
            };
            let head = Span {
                end: (item.span.start + 6).min(item.span.end),
                ..item.span
            };
            self.diags.push(
                Diagnostic::error(
                    "E0504",
                    format!(
                        "an imported file may only define `let`s and `fn`s, but this has {what}"
                    ),
                )
                .label(head, "not allowed in an imported file")
                .label(import, "imported here")
                .help("keep scene items in the main file and import only definitions"),
            );
        }
    }

    /// Each override is a source file of its own (named `-D`, or `-D #2` and so on when there
    /// are several) that sees the root file's definitions.
    fn add_defines(&mut self, root: FileId, defines: &[String]) -> Vec<context::Override> {
        let mut out = vec![];
        for (i, text) in defines.iter().enumerate() {
            let name = if defines.len() == 1 {
                "-D".to_string()
            } else {
                format!("-D #{}", i + 1)
            };
            let id = self.sources.add(name, None, text.as_str());
            let (define, ast, diags) = syntax::parse_define(id, text);
            self.diags.extend(diags);
            while self.asts.len() <= id.0 as usize {
                self.asts.push(Ast::default());
                self.imports.push(vec![]);
            }
            self.asts[id.0 as usize] = ast;
            self.imports[id.0 as usize] = vec![root];
            if let Some((name, value)) = define {
                out.push(context::Override {
                    name,
                    file: id,
                    value,
                });
            }
        }
        out
    }

    fn finish(mut self, root: FileId, defines: &[String]) -> Checked {
        let root_path = self.sources.get(root).path.clone();
        let canon = root_path
            .as_ref()
            .map(|p| std::fs::canonicalize(p).unwrap_or(p.clone()));
        let mut stack: Vec<(PathBuf, FileId)> = canon.map(|c| (c, root)).into_iter().collect();
        self.load(root, &mut stack);
        let overrides = self.add_defines(root, defines);
        let parse_failed = self.diags.iter().any(Diagnostic::is_error);
        let mut scene = None;
        let mut resolved = vec![];
        if !parse_failed {
            let mut ck = context::Checker::new(&self.asts, std::mem::take(&mut self.imports));
            ck.apply_overrides(root, overrides);
            let s = scene::build(&mut ck, root);
            ck.finish_globals(root);
            resolved = ck.resolved.drain().map(|(_, r)| r).collect();
            resolved.sort_by_key(|r: &context::Resolved| (r.use_span.file, r.use_span.start));
            let failed = ck.diags.iter().any(Diagnostic::is_error);
            self.diags.extend(ck.diags);
            if !failed {
                scene = Some(s);
            }
        }
        let mut diags = self.diags;
        diags.sort_by_key(|d| d.primary_span().map(|s| (s.file, s.start)));
        // A function called several times reports the same problem once.
        let mut seen = std::collections::HashSet::new();
        diags.retain(|d| seen.insert((d.code, d.message.clone(), d.primary_span())));
        if diags.len() > MAX_DIAGNOSTICS {
            let more = diags.len() - MAX_DIAGNOSTICS;
            diags.truncate(MAX_DIAGNOSTICS);
            diags.push(
                Diagnostic::error("E0000", format!("{more} more diagnostics not shown"))
                    .help("fix the ones above first"),
            );
        }
        let ast = std::mem::take(&mut self.asts[root.0 as usize]);
        Checked {
            sources: self.sources,
            diagnostics: diags,
            ast,
            scene,
            resolved,
        }
    }
}

fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        std::io::ErrorKind::IsADirectory => "it is a directory".to_string(),
        _ => e.to_string(),
    }
}

/// Paths in messages stay relative to where the user is, so output and snapshots are portable.
fn display_relative(path: &Path) -> String {
    let cwd = std::env::current_dir().ok();
    let shown = cwd
        .as_deref()
        .and_then(|c| path.strip_prefix(c).ok())
        .unwrap_or(path);
    let s = shown.display().to_string();
    // Drop `./` and collapse `dir/../` for readability.
    let mut parts: Vec<&str> = vec![];
    for part in s.split('/') {
        match part {
            "." => {}
            ".." if parts.last().is_some_and(|p| *p != "..") => {
                parts.pop();
            }
            p => parts.push(p),
        }
    }
    parts.join("/")
}
