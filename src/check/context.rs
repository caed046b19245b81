//! The checker's context: the diagnostics it collects, the work limits that keep any input
//! from running away, the field arena, the global table, and the reports every part of the
//! checker shares (type mismatches, values that must be constants, argument binding).

use super::suggest::did_you_mean;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::source::{FileId, Span};
use crate::syntax::ast::*;
use std::collections::HashMap;
use std::rc::Rc;

/// Deepest chain of function calls.
pub const MAX_CALL_DEPTH: usize = 64;
/// Most items a list, range or `for` may produce.
pub const MAX_LIST: usize = 100_000;
/// Most evaluation steps and field nodes one compilation may take.
pub const MAX_WORK: usize = 1_000_000;
/// Deepest shape tree.
pub const MAX_SHAPE_DEPTH: u32 = 1000;

pub enum GlobalKind {
    Let(LetStmt),
    Fn(Rc<FnDef>),
}

pub(super) enum GlobalState {
    Pending,
    InProgress,
    Done(Value),
}

pub struct Global {
    pub name: Ident,
    pub file: FileId,
    pub kind: GlobalKind,
    pub(super) state: GlobalState,
    pub used: bool,
    /// A `-D NAME=VALUE` that replaces this `let`'s value.
    pub(super) overridden: Option<Override>,
}

/// `-D NAME=VALUE`: the value's expression lives in a source file of its own.
#[derive(Clone)]
pub struct Override {
    pub name: Ident,
    pub file: FileId,
    pub value: ExprId,
}

/// A name resolved to its definition, with the type (and the value, for a constant) it had:
/// what an editor shows on hover and jumps to.
#[derive(Clone, Debug)]
pub struct Resolved {
    pub name: String,
    pub use_span: Span,
    pub def_span: Span,
    pub ty: String,
    pub value: Option<String>,
}

pub struct Checker<'a> {
    /// Every name use resolved so far, by where it is (the first evaluation wins).
    pub resolved: HashMap<(FileId, u32), Resolved>,
    pub(super) asts: &'a [Ast],
    pub diags: Vec<Diagnostic>,
    pub fields: Fields,
    pub globals: Vec<Global>,
    pub(super) file_globals: Vec<HashMap<String, usize>>,
    pub(super) file_imports: Vec<Vec<FileId>>,
    pub(super) call_depth: usize,
    pub(super) work: usize,
    pub(super) aborted: bool,
    /// Set once a runaway recursion is reported, until the outermost call returns.
    pub(super) recursion_reported: bool,
}
impl<'a> Checker<'a> {
    pub fn new(asts: &'a [Ast], imports: Vec<Vec<FileId>>) -> Self {
        let mut ck = Checker {
            resolved: HashMap::new(),
            asts,
            diags: vec![],
            fields: Fields::default(),
            globals: vec![],
            file_globals: vec![HashMap::new(); asts.len()],
            file_imports: imports,
            call_depth: 0,
            work: 0,
            aborted: false,
            recursion_reported: false,
        };
        for (f, ast) in asts.iter().enumerate() {
            for item in &ast.items {
                let (name, kind) = match &item.kind {
                    ItemKind::Let(l) => (l.name.clone(), GlobalKind::Let(l.clone())),
                    ItemKind::Fn(d) => (d.name.clone(), GlobalKind::Fn(Rc::new(d.clone()))),
                    _ => continue,
                };
                let id = ck.globals.len();
                if let Some(&prev) = ck.file_globals[f].get(&name.name) {
                    let first = ck.globals[prev].name.span;
                    ck.diags.push(duplicate(&name, first));
                    continue;
                }
                ck.file_globals[f].insert(name.name.clone(), id);
                ck.globals.push(Global {
                    name,
                    file: FileId(f as u32),
                    kind,
                    state: GlobalState::Pending,
                    used: false,
                    overridden: None,
                });
            }
        }
        ck
    }

    /// Attach each `-D` override to the root file's `let` it names, or report it.
    pub fn apply_overrides(&mut self, root: FileId, overrides: Vec<Override>) {
        for o in overrides {
            let found = self.file_globals[root.0 as usize]
                .get(&o.name.name)
                .copied();
            match found {
                Some(g) if matches!(self.globals[g].kind, GlobalKind::Let(_)) => {
                    self.globals[g].overridden = Some(o);
                }
                _ => {
                    let lets: Vec<&str> = (self.globals.iter())
                        .filter(|g| g.file == root && matches!(g.kind, GlobalKind::Let(_)))
                        .map(|g| g.name.name.as_str())
                        .collect();
                    let what = if found.is_some() {
                        "is a function, not a `let`"
                    } else {
                        "is not a top-level `let` of the scene"
                    };
                    let hint = did_you_mean(&o.name.name, lets.iter().copied()).or_else(|| {
                        Some(if lets.is_empty() {
                            "the scene has no top-level `let` to override".to_string()
                        } else {
                            let lets: Vec<String> = lets.iter().map(|l| format!("`{l}`")).collect();
                            format!("the scene's top-level `let`s are {}", lets.join(", "))
                        })
                    });
                    self.error(
                        Diagnostic::error("E0101", format!("`-D {}`: no such `let`", o.name.name))
                            .label(o.name.span, format!("`{}` {what}", o.name.name))
                            .note("`-D NAME=VALUE` replaces the value of a top-level `let`")
                            .maybe_help(hint),
                    );
                }
            }
        }
    }

    pub fn record_use(&mut self, name: &Ident, def_span: Span, v: &Value) {
        if self.aborted {
            return;
        }
        self.resolved
            .entry((name.span.file, name.span.start))
            .or_insert_with(|| Resolved {
                name: name.name.clone(),
                use_span: name.span,
                def_span,
                ty: v.ty().to_string(),
                value: v.describe(),
            });
    }

    pub fn ast(&self, file: FileId) -> &'a Ast {
        &self.asts[file.0 as usize]
    }

    pub fn span(&self, file: FileId, id: ExprId) -> Span {
        self.ast(file).span(id)
    }

    pub fn error(&mut self, d: Diagnostic) -> Value {
        if !self.aborted {
            self.diags.push(d);
        }
        Value::Error
    }

    /// Count one unit of compile-time work; past the limit, stop evaluating.
    pub fn tick(&mut self, span: Span) -> bool {
        self.work += 1;
        if self.work > MAX_WORK && !self.aborted {
            self.diags.push(
                Diagnostic::error("E0402", "the scene takes too much work to evaluate")
                    .label(span, format!("evaluation passed {MAX_WORK} steps here"))
                    .note("loops, recursion and large lists are expanded at compile time")
                    .help("use `tile` to repeat a shape instead of listing copies"),
            );
            self.aborted = true;
        }
        !self.aborted
    }

    pub fn field(&mut self, op: FieldOp, ty: Type) -> Value {
        self.work += 1;
        Value::Field(self.fields.push(op, ty.clone()), ty)
    }

    /// Lift a constant or field into a field node. Only the types a field can hold are
    /// lifted (the callers check); anything else becomes NaN.
    pub fn lift(&mut self, v: &Value) -> FieldId {
        match v {
            Value::Field(id, _) => *id,
            other => {
                let c = other.to_const().unwrap_or(Const::Num(f64::NAN));
                self.fields.push(FieldOp::Const(c), other.ty())
            }
        }
    }

    pub fn deps(&self, v: &Value) -> u8 {
        deps(&self.fields, v)
    }

    /// Report when a value that must be known at compile time depends on p, n or t.
    pub fn require_const(&mut self, v: &Value, span: Span, what: &str) -> bool {
        let deps = self.deps(v);
        if deps == 0 {
            return true;
        }
        self.error(
            Diagnostic::error("E0208", format!("{what} must be known before rendering"))
                .label(span, format!("this depends on {}", describe_deps(deps)))
                .note("values of `p` and `n` are known only per point, and `t` only per frame")
                .help(format!(
                    "give {what} a value that does not use {}",
                    describe_deps(deps)
                )),
        );
        false
    }

    /// Report a type mismatch unless `v` has type `want`; lists of four numbers already became vec4.
    pub fn expect(&mut self, v: &Value, want: &Type, span: Span, what: &str) -> bool {
        if v.is_error() {
            return false;
        }
        let found = v.ty();
        if want.accepts(&found) {
            return true;
        }
        let mut d = Diagnostic::error(
            "E0201",
            format!("mismatched types: {what} must be {}", article(want)),
        )
        .label(span, format!("expected {want}, found {found}"));
        d = match (want, &found) {
            (Type::Angle, Type::Num) => Diagnostic { code: "E0210", ..d }
                .help("give the number a unit, as in `30deg`, `0.5rad` or `0.25turn`, or multiply by `1deg`"),
            (Type::Num, Type::Angle) => {
                Diagnostic { code: "E0210", ..d }.help("divide by a unit to get a number, as in `a / 1deg`")
            }
            (Type::Color, Type::Vec4) => d.help("colours are written `rgb(r, g, b)` or `#rrggbb`"),
            (Type::Vec4, Type::List(_)) => d.help("a vec4 is a list of exactly four numbers, as in `[0, 1, 0, 0]`"),
            (Type::Shape, Type::Material) | (Type::Material, Type::Shape) => {
                d.help("an object has `shape = ...` and `material = ...` settings")
            }
            (Type::Material, Type::Function) => d.help("a material map takes the point and normal: `|p, n| diffuse(...)`"),
            _ => d,
        };
        self.error(d);
        false
    }

    /// Match arguments to parameter names: positional first, then named. Reports too many,
    /// unknown and repeated arguments; missing ones are `None` for the caller to default.
    pub fn bind(
        &mut self,
        fname: &str,
        params: &[&str],
        args: Vec<ArgVal>,
        call: Span,
    ) -> Option<Vec<Option<ArgVal>>> {
        let mut slots: Vec<Option<ArgVal>> = vec![None; params.len()];
        let mut ok = true;
        let mut next = 0;
        let mut seen_named = false;
        let positional = args.iter().filter(|a| a.name.is_none()).count();
        let mut extra_reported = false;
        for a in args {
            match &a.name {
                None if seen_named => {
                    self.error(
                        Diagnostic::error("E0202", "positional argument after a named one")
                            .label(a.span, "this argument has no name")
                            .help("put positional arguments first, or name this one"),
                    );
                    ok = false;
                }
                None if next < params.len() => {
                    slots[next] = Some(a);
                    next += 1;
                }
                // One report for all the extra arguments of a call, at the first.
                None if extra_reported => {}
                None => {
                    extra_reported = true;
                    let extra = positional.saturating_sub(params.len());
                    let what = if extra == 1 {
                        "this argument is extra".to_string()
                    } else {
                        format!("this and {} more arguments are extra", extra - 1)
                    };
                    self.error(
                        Diagnostic::error("E0202", format!("too many arguments to `{fname}`"))
                            .label(a.span, what)
                            .label(
                                call,
                                format!(
                                    "`{fname}` takes {} argument{}",
                                    params.len(),
                                    plural(params.len())
                                ),
                            )
                            .note(format!("`{fname}` takes {}", param_list(params))),
                    );
                    ok = false;
                }
                Some(n) => {
                    seen_named = true;
                    match params.iter().position(|p| *p == n.name) {
                        Some(i) if slots[i].is_some() => {
                            let first = slots[i].as_ref().map(|s| s.span).unwrap_or(call);
                            self.error(
                                Diagnostic::error(
                                    "E0205",
                                    format!("argument `{}` given twice", n.name),
                                )
                                .label(n.span, "given again here")
                                .label(first, "first given here"),
                            );
                            ok = false;
                        }
                        Some(i) => slots[i] = Some(a),
                        None => {
                            let hint = did_you_mean(&n.name, params.iter().copied());
                            self.error(
                                Diagnostic::error(
                                    "E0203",
                                    format!("`{fname}` has no parameter `{}`", n.name),
                                )
                                .label(n.span, "unknown argument name")
                                .note(format!("`{fname}` takes {}", param_list(params)))
                                .maybe_help(hint),
                            );
                            ok = false;
                        }
                    }
                }
            }
        }
        ok.then_some(slots)
    }

    pub fn missing(&mut self, fname: &str, param: &str, call: Span) -> Value {
        self.error(
            Diagnostic::error("E0204", format!("missing argument `{param}` to `{fname}`"))
                .label(call, format!("`{param}` is required"))
                .help(format!("pass it by position or as `{param}: ...`")),
        )
    }
}

pub fn duplicate(name: &Ident, first: Span) -> Diagnostic {
    Diagnostic::error("E0102", format!("`{}` is defined twice", name.name))
        .label(name.span, "defined again here")
        .label(first, "first defined here")
        .help("rename one of them")
}

pub(super) fn unused(name: &str, span: Span, what: &str) -> Diagnostic {
    Diagnostic::warning("W0001", format!("unused {what} `{name}`"))
        .label(span, "never used")
        .help(format!("remove it, or name it `_{name}` to keep it"))
}
pub fn article(t: &Type) -> String {
    let s = t.to_string();
    let vowel = s.starts_with(['a', 'e', 'i', 'o', 'u']);
    format!("{} {s}", if vowel { "an" } else { "a" })
}

pub fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

fn param_list(params: &[&str]) -> String {
    if params.is_empty() {
        "no arguments".to_string()
    } else {
        params
            .iter()
            .map(|p| format!("`{p}`"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
