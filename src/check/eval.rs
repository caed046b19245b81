//! The constant evaluator: walks the syntax tree, computes every value that does not depend on
//! `p`, `n` or `t`, builds field expressions for those that do, and reports type and value
//! errors at their spans. An erroneous expression evaluates to `Value::Error`, which silences
//! follow-on errors, so one run reports every independent mistake.

use super::builtins;
use super::context::*;
use super::ops;
use super::suggest::did_you_mean;
use super::value::*;
use crate::diagnostic::Diagnostic;
use crate::math::color;
use crate::source::{FileId, Span};
use crate::syntax::ast::*;
use std::collections::HashMap;
use std::rc::Rc;

impl Checker<'_> {
    /// Evaluate an expression; never fails, errors become diagnostics and `Value::Error`.
    pub fn eval(&mut self, file: FileId, env: &Env, id: ExprId) -> Value {
        stacker::maybe_grow(64 * 1024, 2 * 1024 * 1024, || {
            self.eval_inner(file, env, id)
        })
    }

    fn eval_inner(&mut self, file: FileId, env: &Env, id: ExprId) -> Value {
        let span = self.span(file, id);
        if !self.tick(span) {
            return Value::Error;
        }
        match self.ast(file).expr(id) {
            Expr::Error => Value::Error,
            Expr::Number { value, unit } => {
                if !value.is_finite() {
                    return self.error(
                        Diagnostic::error("E0301", "number too large")
                            .label(span, "this is past the largest number (about 1.8e308)")
                            .help("write `inf` where an unlimited value is meant"),
                    );
                }
                match unit {
                    Some(u) => Value::Angle(value * u.radians()),
                    None => Value::Num(*value),
                }
            }
            Expr::Bool(b) => Value::Bool(*b),
            Expr::Str(s) => Value::Str(s.as_str().into()),
            Expr::Hex(rgb) => Value::Color(rgb.map(|c| color::srgb_to_linear(c as f64 / 255.0))),
            Expr::Name(name) => self.lookup(file, env, name),
            Expr::List(xs) => self.list(file, env, xs, span),
            Expr::Unary(op, a) => {
                let v = self.eval(file, env, *a);
                ops::unary(self, *op, v, span)
            }
            Expr::Binary(op, a, b) => self.binary(file, env, *op, *a, *b, span),
            Expr::Pipe(lhs, rhs) => {
                let first = self.eval(file, env, *lhs);
                let first = ArgVal {
                    name: None,
                    value: first,
                    span: self.span(file, *lhs),
                };
                // A problem with the call is reported at the call after `|>`, not the chain.
                let rspan = self.span(file, *rhs);
                match self.ast(file).expr(*rhs) {
                    Expr::Call { callee, args } => {
                        let f = self.eval(file, env, *callee);
                        let mut argv = vec![first];
                        argv.extend(self.eval_args(file, env, args));
                        self.call(&f, argv, rspan, self.span(file, *callee))
                    }
                    _ => {
                        let f = self.eval(file, env, *rhs);
                        self.call(&f, vec![first], rspan, rspan)
                    }
                }
            }
            Expr::Call { callee, args } => {
                let f = self.eval(file, env, *callee);
                let argv = self.eval_args(file, env, args);
                self.call(&f, argv, span, self.span(file, *callee))
            }
            Expr::Field(a, field) => {
                let v = self.eval(file, env, *a);
                ops::component(self, v, field, self.span(file, *a))
            }
            Expr::Index(a, i) => {
                let list = self.eval(file, env, *a);
                let index = self.eval(file, env, *i);
                ops::index(self, list, index, self.span(file, *a), self.span(file, *i))
            }
            Expr::If {
                cond,
                then,
                otherwise,
            } => self.if_expr(file, env, *cond, *then, *otherwise),
            Expr::For { var, iter, body } => self.for_expr(file, env, var, *iter, *body, span),
            Expr::Lambda { params, body } => Value::Function(Rc::new(Function::Lambda {
                file,
                params: params.clone(),
                body: *body,
                env: env.clone(),
            })),
            Expr::Sdf { param, body } => {
                if let Some(d) = self.pipe_into_sdf(file, *body) {
                    return self.error(d);
                }
                let p = self.field(FieldOp::Input(Input::P), Type::Vec4);
                let (inner, _) = env.bind(&param.name, p, param.span);
                let d = self.eval(file, &inner, *body);
                let body_span = self.span(file, *body);
                if !self.expect(&d, &Type::Num, body_span, "a distance function's result") {
                    return Value::Error;
                }
                let distance = crate::scene::Param::Field(self.lift(&d));
                builtins::make_shape(self, ShapeKind::Custom { distance }, span)
            }
            Expr::Block { lets, result } => {
                let mut env = env.clone();
                let mut scopes = vec![];
                for l in lets {
                    let v = self.eval(file, &env, l.value);
                    let v = self.annotate(file, l, v);
                    // Definitions resolve to themselves, for hovers on them.
                    self.record_use(&l.name, l.name.span, &v);
                    let (e, s) = env.bind(&l.name.name, v, l.name.span);
                    env = e;
                    scopes.push(s);
                }
                let out = self.eval(file, &env, *result);
                for s in scopes {
                    self.warn_unused_scope(&s, "binding");
                }
                out
            }
        }
    }

    /// `sdf |p| d |> op(...)` reads as `sdf |p| (d |> op(...))`: the body extends as far right
    /// as it can. When `op` is a shape operation the author meant to apply it to the shape.
    fn pipe_into_sdf(&self, file: FileId, body: ExprId) -> Option<Diagnostic> {
        let ast = self.ast(file);
        let Expr::Pipe(lhs, rhs) = ast.expr(body) else {
            return None;
        };
        let callee = match ast.expr(*rhs) {
            Expr::Call { callee, .. } => *callee,
            _ => *rhs,
        };
        let Expr::Name(op) = ast.expr(callee) else {
            return None;
        };
        if !builtins::is_shape_operation(&op.name) {
            return None;
        }
        let sdf = ast.span(*lhs);
        Some(
            Diagnostic::error(
                "E0201",
                format!("`|> {}` is part of the distance function's body", op.name),
            )
            .label(
                self.span(file, *rhs),
                format!(
                    "this applies `{}` to the distance, a num, not to the shape",
                    op.name
                ),
            )
            .label(sdf, "this distance is what it is applied to")
            .note("the body of `sdf |p| ...` reaches as far right as it can, `|>` included")
            .help(format!(
                "put the `sdf` in parentheses and pipe the shape: `(sdf |p| ...) |> {}(...)`",
                op.name
            )),
        )
    }

    /// The value of `-D NAME=VALUE`: a constant of the type the scene's own value has.
    fn override_value(&mut self, l: &LetStmt, original: Value, o: &Override) -> Value {
        let v = self.eval(o.file, &Env::default(), o.value);
        let span = self.span(o.file, o.value);
        let what = format!("`-D {}`", l.name.name);
        if v.is_error() || !self.require_const(&v, span, &what) {
            return Value::Error;
        }
        if original.is_error() {
            return Value::Error;
        }
        let want = original.ty();
        let v = ops::coerce(self, v, &want);
        if !want.accepts(&v.ty()) {
            let found = v.ty();
            return self.error(
                Diagnostic::error(
                    "E0201",
                    format!(
                        "mismatched types: `-D {}` must be {}",
                        l.name.name,
                        article(&want)
                    ),
                )
                .label(span, format!("expected {want}, found {found}"))
                .label(
                    l.name.span,
                    format!("`{}` is {} in the scene", l.name.name, article(&want)),
                )
                .help("an override has the type of the value it replaces"),
            );
        }
        // The original passed its annotation, if any, so `want` already is that type.
        v
    }

    pub fn warn_unused_scope(&mut self, s: &Scope, what: &str) {
        if !s.used.get() && !s.name.starts_with('_') && !self.aborted {
            self.diags.push(unused(&s.name, s.span, what));
        }
    }

    /// Check a `let`'s annotation, if any.
    fn annotate(&mut self, file: FileId, l: &LetStmt, v: Value) -> Value {
        let Some(ty) = &l.ty else { return v };
        let Some(want) = self.resolve_type(ty) else {
            return Value::Error;
        };
        let span = self.span(file, l.value);
        if self.expect(&v, &want, span, &format!("`{}`", l.name.name)) {
            v
        } else {
            Value::Error
        }
    }

    pub fn resolve_type(&mut self, ty: &TypeExpr) -> Option<Type> {
        match &ty.kind {
            TypeKind::List(inner) => self.resolve_type(inner).map(|t| Type::List(Box::new(t))),
            TypeKind::Named(n) => match Type::from_name(n) {
                Some(t) => Some(t),
                None => {
                    let hint = did_you_mean(n, Type::NAMES);
                    self.error(
                        Diagnostic::error("E0101", format!("unknown type `{n}`"))
                            .label(ty.span, "not a type")
                            .note(format!("the types are {}", Type::NAMES.join(", ")))
                            .maybe_help(hint),
                    );
                    None
                }
            },
        }
    }

    fn lookup(&mut self, file: FileId, env: &Env, name: &Ident) -> Value {
        if let Some(s) = env.lookup(&name.name) {
            s.used.set(true);
            let v = s.value.clone();
            self.record_use(name, s.span, &v);
            return v;
        }
        if let Some(g) = self.find_global(file, &name.name) {
            let v = self.global_value(g, name.span);
            let def = self.globals[g].name.span;
            self.record_use(name, def, &v);
            return v;
        }
        if let Some(v) = builtins::constant(self, &name.name) {
            return v;
        }
        if builtins::is_function(&name.name) {
            return Value::Function(Rc::new(Function::Builtin(builtins::intern(&name.name))));
        }
        let mut candidates: Vec<&str> = env.names();
        let globals: Vec<String> = self.visible_globals(file);
        candidates.extend(globals.iter().map(String::as_str));
        candidates.extend(builtins::names().map(|n| -> &str { n }));
        let hint = did_you_mean(&name.name, candidates.iter().copied());
        let hint = synonym(&name.name)
            .or(hint)
            .or_else(|| match name.name.as_str() {
                "p" | "n" => Some(format!(
                    "`{}` exists inside material maps `|p, n| ...` and `sdf |p| ...`",
                    name.name
                )),
                "true_" | "True" | "False" => Some("booleans are `true` and `false`".to_string()),
                _ => None,
            });
        self.error(
            Diagnostic::error("E0101", format!("unknown name `{}`", name.name))
                .label(name.span, "not found in this scope")
                .maybe_help(hint),
        )
    }

    fn find_global(&self, file: FileId, name: &str) -> Option<usize> {
        if let Some(&g) = self.file_globals[file.0 as usize].get(name) {
            return Some(g);
        }
        self.file_imports[file.0 as usize]
            .iter()
            .find_map(|f| self.file_globals[f.0 as usize].get(name).copied())
    }

    fn visible_globals(&self, file: FileId) -> Vec<String> {
        std::iter::once(&file)
            .chain(self.file_imports[file.0 as usize].iter())
            .flat_map(|f| self.file_globals[f.0 as usize].keys().cloned())
            .collect()
    }

    fn global_value(&mut self, g: usize, use_span: Span) -> Value {
        self.globals[g].used = true;
        match &self.globals[g].state {
            GlobalState::Done(v) => return v.clone(),
            GlobalState::InProgress => {
                let name = self.globals[g].name.clone();
                return self.error(
                    Diagnostic::error(
                        "E0403",
                        format!("`{}` is defined in terms of itself", name.name),
                    )
                    .label(use_span, "this use needs the value being defined")
                    .label(name.span, format!("`{}` is defined here", name.name))
                    .help("a `let` cannot refer to itself; use a `fn` for recursion"),
                );
            }
            GlobalState::Pending => {}
        }
        let file = self.globals[g].file;
        let v = match &self.globals[g].kind {
            GlobalKind::Fn(def) => Value::Function(Rc::new(Function::User {
                file,
                def: def.clone(),
            })),
            GlobalKind::Let(l) => {
                let l = l.clone();
                self.globals[g].state = GlobalState::InProgress;
                let v = self.eval(file, &Env::default(), l.value);
                let v = self.annotate(file, &l, v);
                match self.globals[g].overridden.clone() {
                    Some(o) => self.override_value(&l, v, &o),
                    None => v,
                }
            }
        };
        self.globals[g].state = GlobalState::Done(v.clone());
        v
    }

    /// Evaluate every global (so errors in unused definitions are still reported) and warn
    /// about unused ones in the root file.
    pub fn finish_globals(&mut self, root: FileId) {
        let roots: Vec<usize> = (0..self.globals.len())
            .filter(|g| self.globals[*g].file == root)
            .collect();
        for &g in &roots {
            let name = self.globals[g].name.clone();
            let used = self.globals[g].used;
            match &self.globals[g].kind {
                GlobalKind::Let(_) => {
                    self.global_value(g, name.span);
                    // Evaluating for errors is not a use.
                    self.globals[g].used = used;
                }
                GlobalKind::Fn(def) => {
                    let def = def.clone();
                    self.check_fn_signature(self.globals[g].file, &def);
                }
            }
        }
        // A definition resolves to itself, so hovering over it shows it too.
        for &g in &roots {
            let name = self.globals[g].name.clone();
            if let GlobalState::Done(v) = &self.globals[g].state {
                let v = v.clone();
                self.record_use(&name, name.span, &v);
            }
        }
        for &g in &roots {
            let name = &self.globals[g].name;
            if !self.globals[g].used && !name.name.starts_with('_') && !self.aborted {
                let what = if matches!(self.globals[g].kind, GlobalKind::Fn(_)) {
                    "function"
                } else {
                    "binding"
                };
                self.diags.push(unused(&name.name, name.span, what));
            }
        }
    }

    fn check_fn_signature(&mut self, file: FileId, def: &FnDef) {
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for p in &def.params {
            if let Some(first) = seen.insert(&p.name.name, p.name.span) {
                self.error(duplicate(&p.name, first));
            }
            let ty = self.resolve_type(&p.ty);
            if let (Some(ty), Some(d)) = (ty, p.default) {
                let v = self.eval(file, &Env::default(), d);
                let span = self.span(file, d);
                self.expect(&v, &ty, span, &format!("the default of `{}`", p.name.name));
            }
        }
        if let Some(r) = &def.ret {
            self.resolve_type(r);
        }
    }

    fn eval_args(&mut self, file: FileId, env: &Env, args: &[Arg]) -> Vec<ArgVal> {
        args.iter()
            .map(|a| ArgVal {
                name: a.name.clone(),
                value: self.eval(file, env, a.value),
                span: self.span(file, a.value),
            })
            .collect()
    }

    pub fn call(&mut self, f: &Value, args: Vec<ArgVal>, span: Span, callee_span: Span) -> Value {
        if args.iter().any(|a| a.value.is_error()) {
            return Value::Error;
        }
        let f = match f {
            Value::Function(f) => f.clone(),
            Value::Error => return Value::Error,
            other => {
                let ty = other.ty();
                return self.error(
                    Diagnostic::error("E0206", format!("a {ty} is not a function")).label(
                        callee_span,
                        format!("this is a {ty}, which cannot be called"),
                    ),
                );
            }
        };
        if self.call_depth >= MAX_CALL_DEPTH {
            // One report per runaway recursion: the calls still pending as it unwinds (other
            // arguments, builtins) are at the limit too, but they are not the cause.
            if self.recursion_reported {
                return Value::Error;
            }
            self.recursion_reported = true;
            return self.error(
                Diagnostic::error("E0401", "recursion too deep")
                    .label(span, format!("this call is {MAX_CALL_DEPTH} calls deep"))
                    .note(format!(
                        "functions may nest at most {MAX_CALL_DEPTH} calls deep at compile time"
                    ))
                    .help("check that the recursion reaches its base case"),
            );
        }
        self.call_depth += 1;
        let out = match &*f {
            Function::Builtin(name) => builtins::call(self, name, args, span),
            Function::User { file, def, .. } => self.call_user(*file, def, args, span),
            Function::Lambda {
                file,
                params,
                body,
                env,
                ..
            } => {
                if args.len() != params.len() || args.iter().any(|a| a.name.is_some()) {
                    let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
                    self.error(
                        Diagnostic::error(
                            "E0202",
                            format!(
                                "this function takes {} argument{}",
                                params.len(),
                                plural(params.len())
                            ),
                        )
                        .label(
                            span,
                            format!("called with {} argument{}", args.len(), plural(args.len())),
                        )
                        .note(format!(
                            "the function is `|{}| ...`, and takes positional arguments only",
                            names.join(", ")
                        )),
                    )
                } else {
                    let mut inner = env.clone();
                    for (p, a) in params.iter().zip(args) {
                        self.record_use(p, p.span, &a.value);
                        inner = inner.bind(&p.name, a.value, p.span).0;
                    }
                    self.eval(*file, &inner, *body)
                }
            }
        };
        self.call_depth -= 1;
        if self.call_depth == 0 {
            self.recursion_reported = false;
        }
        out
    }

    fn call_user(&mut self, file: FileId, def: &FnDef, args: Vec<ArgVal>, span: Span) -> Value {
        let names: Vec<&str> = def.params.iter().map(|p| p.name.name.as_str()).collect();
        let Some(slots) = self.bind(&def.name.name, &names, args, span) else {
            return Value::Error;
        };
        let mut env = Env::default();
        let mut scopes = vec![];
        let mut ok = true;
        for (p, slot) in def.params.iter().zip(slots) {
            let Some(ty) = self.resolve_type(&p.ty) else {
                ok = false;
                continue;
            };
            let (v, vspan) = match (slot, p.default) {
                (Some(a), _) => (a.value, a.span),
                (None, Some(d)) => (self.eval(file, &Env::default(), d), self.span(file, d)),
                (None, None) => {
                    self.missing(&def.name.name, &p.name.name, span);
                    ok = false;
                    continue;
                }
            };
            let v = ops::coerce(self, v, &ty);
            if !self.expect(
                &v,
                &ty,
                vspan,
                &format!("argument `{}` of `{}`", p.name.name, def.name.name),
            ) {
                ok = false;
                continue;
            }
            self.record_use(&p.name, p.name.span, &v);
            let (e, s) = env.bind(&p.name.name, v, p.name.span);
            env = e;
            scopes.push(s);
        }
        if !ok {
            return Value::Error;
        }
        let out = self.eval(file, &env, def.body);
        if self.call_depth == 1 {
            // Warn once, at the outermost call, not once per recursion level.
            for s in &scopes {
                self.warn_unused_scope(s, "parameter");
            }
        }
        match &def.ret {
            Some(r) => {
                let Some(ty) = self.resolve_type(r) else {
                    return Value::Error;
                };
                let out = ops::coerce(self, out, &ty);
                let body_span = self.span(file, def.body);
                if self.expect(
                    &out,
                    &ty,
                    body_span,
                    &format!("the result of `{}`", def.name.name),
                ) {
                    out
                } else {
                    Value::Error
                }
            }
            None => out,
        }
    }

    fn list(&mut self, file: FileId, env: &Env, xs: &[ExprId], span: Span) -> Value {
        if xs.len() > MAX_LIST {
            return self.error(
                Diagnostic::error("E0402", "list too large")
                    .label(span, format!("this list has {} items", xs.len()))
                    .note(format!("a range or list may have at most {MAX_LIST} items"))
                    .help("use `tile` to repeat a shape instead of listing copies"),
            );
        }
        let vals: Vec<Value> = xs.iter().map(|x| self.eval(file, env, *x)).collect();
        if vals.iter().any(Value::is_error) {
            return Value::Error;
        }
        if vals.len() == 4 && vals.iter().all(|v| v.ty() == Type::Num) {
            return ops::make_vec4(self, &vals);
        }
        let Some(first) = vals.first() else {
            return Value::List(Rc::new(vec![]));
        };
        let ty = first.ty();
        for (v, x) in vals.iter().zip(xs).skip(1) {
            if !ty.accepts(&v.ty()) {
                let xspan = self.span(file, *x);
                return self.error(
                    Diagnostic::error("E0201", "list elements must all have one type")
                        .label(xspan, format!("this is {}", article(&v.ty())))
                        .label(
                            self.span(file, xs[0]),
                            format!("the first element is {}", article(&ty)),
                        )
                        .label(span, "in this list"),
                );
            }
        }
        Value::List(Rc::new(vals))
    }

    fn binary(
        &mut self,
        file: FileId,
        env: &Env,
        op: BinOp,
        a: ExprId,
        b: ExprId,
        span: Span,
    ) -> Value {
        let av = self.eval(file, env, a);
        // Short-circuit constant booleans so guards like `n > 0 && xs[n - 1] > 0` work.
        match (op, &av) {
            (BinOp::And, Value::Bool(false)) => return Value::Bool(false),
            (BinOp::Or, Value::Bool(true)) => return Value::Bool(true),
            _ => {}
        }
        let bv = self.eval(file, env, b);
        ops::binary(
            self,
            op,
            av,
            bv,
            self.span(file, a),
            self.span(file, b),
            span,
        )
    }

    fn if_expr(
        &mut self,
        file: FileId,
        env: &Env,
        cond: ExprId,
        then: ExprId,
        otherwise: ExprId,
    ) -> Value {
        let c = self.eval(file, env, cond);
        let cspan = self.span(file, cond);
        match c {
            Value::Bool(true) => self.eval(file, env, then),
            Value::Bool(false) => self.eval(file, env, otherwise),
            Value::Error => Value::Error,
            Value::Field(cid, Type::Bool) => {
                let a = self.eval(file, env, then);
                let b = self.eval(file, env, otherwise);
                ops::select(
                    self,
                    cid,
                    a,
                    b,
                    self.span(file, then),
                    self.span(file, otherwise),
                )
            }
            other => {
                self.expect(&other, &Type::Bool, cspan, "the condition of `if`");
                Value::Error
            }
        }
    }

    fn for_expr(
        &mut self,
        file: FileId,
        env: &Env,
        var: &Ident,
        iter: ExprId,
        body: ExprId,
        span: Span,
    ) -> Value {
        let it = self.eval(file, env, iter);
        let ispan = self.span(file, iter);
        if !self.require_const(&it, ispan, "what a `for` loops over") {
            return Value::Error;
        }
        let items: Vec<Value> = match it {
            Value::List(xs) => xs.to_vec(),
            Value::Vec4(v) => v.iter().map(|x| Value::Num(*x)).collect(),
            Value::Error => return Value::Error,
            other => {
                let ty = other.ty();
                return self.error(
                    Diagnostic::error("E0201", format!("cannot loop over {}", article(&ty)))
                        .label(ispan, format!("expected a list or a range, found {ty}"))
                        .help("loop over a range such as `0..8` or a list such as `[1, 2, 3]`"),
                );
            }
        };
        let mut out = Vec::with_capacity(items.len());
        let mut used = false;
        for item in items {
            self.record_use(var, var.span, &item);
            let (inner, scope) = env.bind(&var.name, item, var.span);
            let v = self.eval(file, &inner, body);
            used |= scope.used.get();
            if v.is_error() {
                return Value::Error;
            }
            out.push(v);
            if !self.tick(span) {
                return Value::Error;
            }
        }
        if !used && !var.name.starts_with('_') && !out.is_empty() && !self.aborted {
            self.diags
                .push(unused(&var.name, var.span, "loop variable"));
        }
        if let Some(first) = out.first() {
            let ty = first.ty();
            if let Some(bad) = out.iter().find(|v| !ty.accepts(&v.ty())) {
                let bty = bad.ty();
                return self.error(
                    Diagnostic::error("E0201", "a `for` must give one type of value").label(
                        self.span(file, body),
                        format!("this gives {} and also {}", article(&ty), article(&bty)),
                    ),
                );
            }
        }
        Value::List(Rc::new(out))
    }
}

/// Names authors reach for from other tools, and what this language calls them.
fn synonym(name: &str) -> Option<String> {
    let (ours, why) = match name {
        "hypercube" | "tesseract" | "cube" | "box" => ("hyperbox", "a 4D box, as in `hyperbox(1)`"),
        "sphere" | "ball" | "glome" => ("hypersphere", "the 4D ball, as in `hypersphere(1)`"),
        "metal" | "metallic" | "specular" => (
            "shiny",
            "a metal-like surface, as in `shiny(roughness: 0.2)`",
        ),
        "plane" | "ground" => ("halfspace", "everything on one side of a plane"),
        "lambert" | "matte" => ("diffuse", "a matte surface, as in `diffuse(rgb(0.8))`"),
        "emissive" | "lamp" | "emitter" => {
            ("light", "a glowing surface, as in `light(intensity: 10)`")
        }
        "difference" | "minus" => ("subtract", "`subtract(shape, cut)`"),
        "intersection" => ("intersect", "`intersect(a, b)`"),
        "move" | "translated" => ("translate", "`translate([x, y, z, w])`"),
        _ => return None,
    };
    Some(format!("this language calls it `{ours}`: {why}"))
}
