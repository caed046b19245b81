//! Source text to syntax tree: lexing, a delimiter and nesting pre-pass, then the chumsky parser.

pub mod ast;
pub mod format;
pub mod parser;
pub mod print;
pub mod token;

use crate::diagnostic::Diagnostic;
use crate::source::{FileId, Span};
use ast::Ast;
use chumsky::error::{RichPattern, RichReason};
use chumsky::{input::Input as _, prelude::*};
use token::{LexError, Token};

/// Deepest allowed nesting of brackets, prefix operators and expressions. Far beyond what a
/// scene needs, and low enough that every recursive pass stays well inside the stack.
pub const MAX_NESTING: usize = 256;

/// Parse one file. Always returns a tree (possibly partial) and the diagnostics found.
pub fn parse(file: FileId, src: &str) -> (Ast, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    let tokens = tokens(file, src, &mut diags);
    let structural = check_structure(file, &tokens);
    if !structural.is_empty() {
        // Unbalanced or absurdly deep input: the parser would only echo these.
        diags.extend(structural);
        return (Ast::default(), diags);
    }

    let eoi = SimpleSpan::from(src.len()..src.len());
    let input = tokens.as_slice().map(eoi, |(t, s)| (t, s));
    let mut state = chumsky::extra::SimpleState(parser::Builder {
        ast: Ast::default(),
        file,
    });
    let (items, errors) = parser::file()
        .parse_with_state(input, &mut state)
        .into_output_errors();
    let mut ast = state.0.ast;
    ast.items = items.unwrap_or_default();
    diags.extend(errors.into_iter().map(|e| parse_error(file, src, e)));

    if diags.is_empty()
        && let Some((id, depth)) = ast.deepest()
        && depth > MAX_NESTING
    {
        diags.push(too_deep(ast.span(id), "this expression"));
        ast = Ast::default();
    }
    (ast, diags)
}

/// A command-line override `NAME=VALUE`, held as a source file of its own so that its
/// diagnostics point into it: the name and the value's expression, or the diagnostics.
pub fn parse_define(
    file: FileId,
    src: &str,
) -> (Option<(ast::Ident, ast::ExprId)>, Ast, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    let tokens = tokens(file, src, &mut diags);
    diags.extend(check_structure(file, &tokens));
    let mut state = chumsky::extra::SimpleState(parser::Builder {
        ast: Ast::default(),
        file,
    });
    let name = match tokens.as_slice() {
        [(Token::Ident(name), nspan), (Token::Eq, _), _, ..] if diags.is_empty() => ast::Ident {
            name: name.to_string(),
            span: Span::new(file, nspan.start, nspan.end),
        },
        _ => {
            if diags.is_empty() {
                diags.push(
                    Diagnostic::error("E0010", "`-D` takes NAME=VALUE")
                        .label(Span::new(file, 0, src.len()), "this is not `NAME=VALUE`")
                        .help("override a top-level `let`, as in `-D radius=0.5`"),
                );
            }
            return (None, state.0.ast, diags);
        }
    };
    let eoi = SimpleSpan::from(src.len()..src.len());
    let input = tokens[2..].map(eoi, |(t, s)| (t, s));
    let (value, errors) = parser::expr()
        .then_ignore(end())
        .parse_with_state(input, &mut state)
        .into_output_errors();
    diags.extend(errors.into_iter().map(|e| parse_error(file, src, e)));
    let value = value.filter(|_| diags.is_empty());
    (value.map(|v| (name, v)), state.0.ast, diags)
}

/// Lex a file into the parser's tokens, reporting lexing errors and standing in what was meant.
fn tokens<'s>(
    file: FileId,
    src: &'s str,
    diags: &mut Vec<Diagnostic>,
) -> Vec<(Token<'s>, SimpleSpan)> {
    let mut tokens = Vec::new();
    for (tok, range) in token::lex(src) {
        let span = Span::new(file, range.start, range.end);
        match tok {
            Token::Error(e) => {
                let text = &src[range.clone()];
                diags.push(lex_error(e, span, text));
                // Stand in what was meant, so the parser does not report the mistake again.
                let stand_in = match e {
                    LexError::GluedNumber => Some(Token::Number("0")),
                    LexError::NonAsciiName => Some(Token::Ident("_")),
                    LexError::UnterminatedString => Some(Token::Str("\"\"")),
                    LexError::BadChar if text == "%" => Some(Token::Mod),
                    _ => None,
                };
                if let Some(t) = stand_in {
                    tokens.push((t, SimpleSpan::from(range)));
                }
            }
            tok => tokens.push((tok, SimpleSpan::from(range))),
        }
    }
    tokens
}

fn lex_error(e: LexError, span: Span, text: &str) -> Diagnostic {
    match e {
        LexError::BadChar => {
            let c = text.chars().next().unwrap_or('?');
            let d = Diagnostic::error(
                "E0001",
                format!("unexpected character `{}`", c.escape_default()),
            )
            .label(span, "this character is not part of the language");
            let hint = match c {
                '%' => Some("the remainder operator is written `mod`, as in `i mod 7`".to_string()),
                '^' => Some("powers are written `pow(x, y)`".to_string()),
                '&' | '|' => Some("logical operators are `&&` and `||`".to_string()),
                '#' => {
                    Some("colours are written `#rrggbb` with exactly six hex digits".to_string())
                }
                '\'' => Some("strings use double quotes: \"like this\"".to_string()),
                '°' => Some(
                    "angles are written with a unit: `60deg`, `0.5rad` or `0.25turn`".to_string(),
                ),
                _ => None,
            };
            d.maybe_help(hint)
        }
        LexError::NonAsciiName => {
            let ascii: String = deunicode::deunicode(text)
                .chars()
                .map(|c| if c == ' ' { '_' } else { c })
                .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            let hint = if ascii.is_empty() || ascii.starts_with(|c: char| c.is_ascii_digit()) {
                "use ASCII letters, digits and `_`, as in `ball_2`".to_string()
            } else {
                format!("use ASCII letters, digits and `_`, as in `{ascii}`")
            };
            Diagnostic::error("E0001", format!("`{text}` is not a valid name"))
                .label(span, "names are ASCII letters, digits and `_`")
                .help(hint)
        }
        LexError::UnterminatedString => Diagnostic::error("E0002", "unterminated string")
            .label(span, "this string has no closing `\"`")
            .help("strings end on the same line with `\"`"),
        LexError::GluedNumber => {
            let split = text
                .find(|c: char| c.is_ascii_alphabetic() || c == '_')
                .unwrap_or(text.len());
            let (num, name) = text.split_at(split);
            let hint = match name.strip_prefix('x') {
                Some(h) if !h.is_empty() && h.chars().all(|c| c.is_ascii_digit()) => {
                    format!("an image size is written with spaces around `x`: `{num} x {h}`")
                }
                _ => format!(
                    "put a space or an operator between `{num}` and `{name}`; the angle units are `deg`, `rad` and `turn`"
                ),
            };
            Diagnostic::error(
                "E0004",
                format!("the number `{num}` runs into the name `{name}`"),
            )
            .label(span, "a number cannot be followed directly by letters")
            .help(hint)
        }
        LexError::UnterminatedComment => Diagnostic::error("E0003", "unterminated block comment")
            .label(
                Span {
                    end: span.start + 2,
                    ..span
                },
                "this comment is never closed",
            )
            .help("close it with `*/`"),
    }
}

fn too_deep(span: Span, what: &str) -> Diagnostic {
    Diagnostic::error("E0012", "nested too deeply")
        .label(
            span,
            format!("{what} goes more than {MAX_NESTING} levels deep"),
        )
        .note(format!(
            "the parser accepts at most {MAX_NESTING} levels of nesting"
        ))
        .help("split the expression into `let` bindings or use a `for` comprehension")
}

/// Brackets must balance and nest at most `MAX_NESTING` deep; runs of prefix operators too.
fn check_structure(file: FileId, tokens: &[(Token, SimpleSpan)]) -> Vec<Diagnostic> {
    let sp = |s: &SimpleSpan| Span::new(file, s.start, s.end);
    let mut stack: Vec<(Token, SimpleSpan)> = Vec::new();
    let mut diags = Vec::new();
    let mut prefix_run = 0usize;
    // Constructs the parser nests without brackets: lambda heads `|a, b|` in a row and
    // `else if` chains. Each counts as one level.
    let mut lambda_run = 0usize;
    let mut else_if_run: Vec<usize> = vec![0];
    let mut i = 0;
    while i < tokens.len() {
        let (tok, span) = &tokens[i];
        if *tok == Token::Bar {
            let mut j = i + 1;
            while matches!(tokens.get(j), Some((Token::Ident(_), _)))
                && matches!(tokens.get(j + 1), Some((Token::Comma, _)))
            {
                j += 2;
            }
            if matches!(tokens.get(j), Some((Token::Ident(_), _)))
                && matches!(tokens.get(j + 1), Some((Token::Bar, _)))
            {
                lambda_run += 1;
                if lambda_run > MAX_NESTING {
                    return vec![too_deep(sp(span), "this chain of functions")];
                }
                i = j + 2;
                continue;
            }
        }
        lambda_run = 0;
        if *tok == Token::Else && matches!(tokens.get(i + 1), Some((Token::If, _))) {
            let run = else_if_run.last_mut().expect("never empty");
            *run += 1;
            if *run > MAX_NESTING {
                return vec![too_deep(sp(span), "this `else if` chain")];
            }
        }
        match tok {
            // A new binding, setting or list item starts a new chain.
            Token::Let | Token::Fn | Token::Object | Token::Comma | Token::Semi => {
                *else_if_run.last_mut().expect("never empty") = 0;
            }
            Token::LBrace => else_if_run.push(0),
            Token::RBrace if else_if_run.len() > 1 => {
                else_if_run.pop();
            }
            _ => {}
        }
        i += 1;
        if matches!(tok, Token::Minus | Token::Bang) {
            prefix_run += 1;
            if prefix_run > MAX_NESTING {
                return vec![too_deep(sp(span), "this run of prefix operators")];
            }
        } else {
            prefix_run = 0;
        }
        match tok {
            Token::LParen | Token::LBracket | Token::LBrace => {
                stack.push((*tok, *span));
                if stack.len() > MAX_NESTING {
                    return vec![too_deep(sp(span), "this bracket")];
                }
            }
            Token::RParen | Token::RBracket | Token::RBrace => {
                let want = |open: &Token| match open {
                    Token::LParen => Token::RParen,
                    Token::LBracket => Token::RBracket,
                    _ => Token::RBrace,
                };
                let opener_open = stack.iter().any(|(open, _)| want(open) == *tok);
                match stack.pop() {
                    Some((open, _)) if want(&open) == *tok => {}
                    Some((open, ospan)) if opener_open => {
                        diags.push(
                            Diagnostic::error(
                                "E0011",
                                format!("mismatched closing delimiter {tok}"),
                            )
                            .label(sp(span), format!("expected {} here", want(&open)))
                            .label(sp(&ospan), format!("this {open} is closed by {tok}")),
                        );
                        return diags;
                    }
                    // Nothing open that this closes: a stray, most likely one too many.
                    inner => {
                        let mut d = Diagnostic::error(
                            "E0011",
                            format!("unexpected closing delimiter {tok}"),
                        )
                        .label(sp(span), "there is nothing here for it to close");
                        if let Some((open, ospan)) = inner {
                            d = d.label(
                                sp(&ospan),
                                format!("the innermost open group is this {open}"),
                            );
                        }
                        diags.push(d.help(format!("delete this {tok}")));
                        return diags;
                    }
                }
            }
            _ => {}
        }
    }
    if let Some((open, ospan)) = stack.pop() {
        let closer = match open {
            Token::LParen => ")",
            Token::LBracket => "]",
            _ => "}",
        };
        diags.push(
            Diagnostic::error("E0011", format!("unclosed delimiter {open}"))
                .label(sp(&ospan), format!("this {open} is never closed"))
                .help(format!("add `{closer}` where the group should end")),
        );
    }
    diags
}

fn parse_error(file: FileId, src: &str, e: Rich<Token>) -> Diagnostic {
    let span = Span::new(file, e.span().start, e.span().end);
    let found = e.found().map(|t| t.to_string());
    let mut expected: Vec<String> = match e.reason() {
        RichReason::ExpectedFound { expected, .. } => expected
            .iter()
            .filter(|p| !matches!(p, RichPattern::SomethingElse))
            .map(|p| match p {
                RichPattern::EndOfInput => "end of file".to_string(),
                RichPattern::Token(t) => t.to_string(),
                RichPattern::Label(l) => l.to_string(),
                RichPattern::Identifier(i) => format!("`{i}`"),
                RichPattern::Any => "any token".to_string(),
                other => other.to_string(),
            })
            .collect(),
        RichReason::Custom(msg) => vec![msg.to_string()],
    };
    expected.sort();
    expected.dedup();
    // After a complete operand any operator could follow; listing them all buries the point.
    const OPERATORS: [&str; 19] = [
        "`!=`",
        "`&&`",
        "`*`",
        "`+`",
        "`-`",
        "`..`",
        "`.`",
        "`/`",
        "`<=`",
        "`<`",
        "`==`",
        "`>=`",
        "`>`",
        "`[`",
        "`mod`",
        "`x`",
        "`|>`",
        "`||`",
        "arguments",
    ];
    if expected.iter().any(|e| e == "`+`") {
        expected.retain(|e| !OPERATORS.contains(&e.as_str()));
        expected.push("an operator".to_string());
    }
    let text = src.get(e.span().start..e.span().end).unwrap_or("");
    let found_text = match e.found() {
        None => "end of file".to_string(),
        Some(Token::Number(_)) => format!("number `{text}`"),
        Some(Token::Hex(_)) => format!("colour `{text}`"),
        Some(Token::Str(_)) => format!("string `{text}`"),
        Some(_) => found.clone().unwrap_or_default(),
    };
    let mut d = Diagnostic::error("E0010", format!("unexpected {found_text}"))
        .label(span, format!("expected {}", one_of_list(&expected)));
    for (label, cspan) in e.contexts() {
        let cspan = Span::new(file, cspan.start, cspan.end);
        if cspan != span {
            d = d.label(cspan, format!("while parsing {label}"));
        }
    }
    let after = src.get(e.span().end..).unwrap_or("");
    d.maybe_help(parse_hint(e.found(), text, after, &expected))
}

/// "a", "a or b", "one of a, b or c".
fn one_of_list(items: &[String]) -> String {
    match items {
        [] => "something else".to_string(),
        [one] => one.clone(),
        [init @ .., last] if init.len() == 1 => format!("{} or {last}", init[0]),
        [init @ .., last] => format!("one of {} or {last}", init.join(", ")),
    }
}

fn parse_hint(
    found: Option<&Token>,
    text: &str,
    after: &str,
    expected: &[String],
) -> Option<String> {
    let wants = |s: &str| expected.iter().any(|e| e.contains(s));
    match found {
        // `.5`: a number starts with a digit.
        Some(Token::Dot)
            if wants("an expression") && after.starts_with(|c: char| c.is_ascii_digit()) =>
        {
            let digits: String = after.chars().take_while(|c| c.is_ascii_digit()).collect();
            Some(format!("a number starts with a digit: write `0.{digits}`"))
        }
        Some(Token::Eq) if wants("`:`") || wants("`)`") => Some(
            "named arguments are written `name: value`, as in `hypersphere(radius: 1)`".to_string(),
        ),
        Some(Token::Colon) if wants("`=`") => {
            Some("settings and bindings use `=`, as in `spp = 16`".to_string())
        }
        Some(Token::EqEq) if wants("`=`") => Some("bindings use a single `=`".to_string()),
        Some(t)
            if t.is_keyword() && !matches!(t, Token::True | Token::False) && wants("a name") =>
        {
            Some(format!("`{text}` is a keyword and can't be used as a name"))
        }
        Some(Token::Else) => {
            Some("`else` must follow the closing `}` of an `if` block".to_string())
        }
        Some(Token::LBrace) if wants("`else`") => None,
        Some(Token::Ident(name)) if wants("an item") => {
            let block = [ast::BlockKind::Render, ast::BlockKind::Camera]
                .into_iter()
                .find(|b| b.settings().contains(name));
            match block {
                Some(b) => Some(format!(
                    "`{name}` is a setting of the `{}` block: write it inside `{} {{ {name} = ... }}`",
                    b.keyword(),
                    b.keyword()
                )),
                None if ast::OBJECT_SETTINGS.contains(name) => Some(format!(
                    "`{name}` is a setting of an object: write it inside `object name {{ {name} = ... }}`"
                )),
                None => None,
            }
        }
        _ if wants("`else`") => {
            Some("every `if` needs an `else`: both branches give the value".to_string())
        }
        _ => None,
    }
}
