//! `--emit ast`: a stable, readable S-expression form of the syntax tree (no spans, so
//! snapshots do not churn when whitespace moves).

use super::ast::*;
use std::fmt::Write;

pub fn print_ast(ast: &Ast) -> String {
    let mut p = Printer {
        ast,
        out: String::new(),
    };
    for item in &ast.items {
        p.item(item);
        p.out.push('\n');
    }
    p.out
}

struct Printer<'a> {
    ast: &'a Ast,
    out: String,
}

fn ty(t: &TypeExpr) -> String {
    match &t.kind {
        TypeKind::Named(n) => n.clone(),
        TypeKind::List(inner) => format!("list[{}]", ty(inner)),
    }
}

impl Printer<'_> {
    fn item(&mut self, item: &Item) {
        match &item.kind {
            ItemKind::Error => self.out.push_str("(error-item)"),
            ItemKind::Import { path, .. } => {
                let _ = write!(self.out, "(import {path:?})");
            }
            ItemKind::Let(l) => self.let_stmt(l, 0),
            ItemKind::Fn(f) => {
                let _ = write!(self.out, "(fn {}", f.name.name);
                for p in &f.params {
                    let _ = write!(self.out, "\n  (param {} {}", p.name.name, ty(&p.ty));
                    if let Some(d) = p.default {
                        self.out.push(' ');
                        self.expr(d, 2);
                    }
                    self.out.push(')');
                }
                if let Some(r) = &f.ret {
                    let _ = write!(self.out, "\n  (returns {})", ty(r));
                }
                self.out.push_str("\n  ");
                self.expr(f.body, 2);
                self.out.push(')');
            }
            ItemKind::Object { name, settings } => {
                let _ = write!(self.out, "(object {}", name.name);
                self.settings(settings);
            }
            ItemKind::Block { kind, settings } => {
                let _ = write!(self.out, "({}", kind.keyword());
                self.settings(settings);
            }
            ItemKind::Sky(e) => {
                self.out.push_str("(sky ");
                self.expr(*e, 1);
                self.out.push(')');
            }
            ItemKind::Medium(e) => {
                self.out.push_str("(medium ");
                self.expr(*e, 1);
                self.out.push(')');
            }
        }
    }

    fn settings(&mut self, settings: &[Setting]) {
        for s in settings {
            let _ = write!(self.out, "\n  ({} ", s.name.name);
            self.expr(s.value, 2);
            self.out.push(')');
        }
        self.out.push(')');
    }

    fn let_stmt(&mut self, l: &LetStmt, indent: usize) {
        let _ = write!(self.out, "(let {}", l.name.name);
        if let Some(t) = &l.ty {
            let _ = write!(self.out, ": {}", ty(t));
        }
        self.out.push(' ');
        self.expr(l.value, indent + 1);
        self.out.push(')');
    }

    fn newline(&mut self, indent: usize) {
        self.out.push('\n');
        for _ in 0..indent {
            self.out.push_str("  ");
        }
    }

    fn expr(&mut self, id: ExprId, indent: usize) {
        match self.ast.expr(id) {
            Expr::Error => self.out.push_str("<error>"),
            Expr::Number { value, unit } => {
                let _ = write!(self.out, "{value}{}", unit.map_or("", |u| u.name()));
            }
            Expr::Bool(b) => {
                let _ = write!(self.out, "{b}");
            }
            Expr::Str(s) => {
                let _ = write!(self.out, "{s:?}");
            }
            Expr::Hex([r, g, b]) => {
                let _ = write!(self.out, "#{r:02x}{g:02x}{b:02x}");
            }
            Expr::Name(n) => self.out.push_str(&n.name),
            Expr::List(xs) => {
                self.out.push('[');
                for (i, x) in xs.iter().enumerate() {
                    if i > 0 {
                        self.out.push_str(", ");
                    }
                    self.expr(*x, indent);
                }
                self.out.push(']');
            }
            Expr::Unary(op, a) => {
                self.out.push_str(match op {
                    UnOp::Neg => "(neg ",
                    UnOp::Not => "(not ",
                });
                self.expr(*a, indent);
                self.out.push(')');
            }
            Expr::Binary(op, a, b) => {
                let _ = write!(self.out, "({} ", op.symbol());
                self.expr(*a, indent);
                self.out.push(' ');
                self.expr(*b, indent);
                self.out.push(')');
            }
            Expr::Pipe(a, b) => {
                self.out.push_str("(|>");
                self.newline(indent + 1);
                self.expr(*a, indent + 1);
                self.newline(indent + 1);
                self.expr(*b, indent + 1);
                self.out.push(')');
            }
            Expr::Call { callee, args } => {
                self.out.push_str("(call ");
                self.expr(*callee, indent);
                for a in args {
                    self.out.push(' ');
                    if let Some(n) = &a.name {
                        let _ = write!(self.out, "{}: ", n.name);
                    }
                    self.expr(a.value, indent);
                }
                self.out.push(')');
            }
            Expr::Field(a, f) => {
                self.out.push_str("(. ");
                self.expr(*a, indent);
                let _ = write!(self.out, " {})", f.name);
            }
            Expr::Index(a, i) => {
                self.out.push_str("(index ");
                self.expr(*a, indent);
                self.out.push(' ');
                self.expr(*i, indent);
                self.out.push(')');
            }
            Expr::If {
                cond,
                then,
                otherwise,
            } => {
                self.out.push_str("(if ");
                self.expr(*cond, indent + 1);
                self.newline(indent + 1);
                self.expr(*then, indent + 1);
                self.newline(indent + 1);
                self.expr(*otherwise, indent + 1);
                self.out.push(')');
            }
            Expr::For { var, iter, body } => {
                let _ = write!(self.out, "(for {} ", var.name);
                self.expr(*iter, indent + 1);
                self.newline(indent + 1);
                self.expr(*body, indent + 1);
                self.out.push(')');
            }
            Expr::Lambda { params, body } => {
                let names: Vec<_> = params.iter().map(|p| p.name.as_str()).collect();
                let _ = write!(self.out, "(lambda |{}|", names.join(", "));
                self.newline(indent + 1);
                self.expr(*body, indent + 1);
                self.out.push(')');
            }
            Expr::Sdf { param, body } => {
                let _ = write!(self.out, "(sdf |{}|", param.name);
                self.newline(indent + 1);
                self.expr(*body, indent + 1);
                self.out.push(')');
            }
            Expr::Block { lets, result } => {
                self.out.push_str("(block");
                for l in lets {
                    self.newline(indent + 1);
                    self.let_stmt(l, indent + 1);
                }
                self.newline(indent + 1);
                self.expr(*result, indent + 1);
                self.out.push(')');
            }
        }
    }
}
