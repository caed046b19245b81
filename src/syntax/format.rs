//! `hyperslice fmt`: one layout for `.4ds` files. The formatter works on the token stream, so
//! the tokens (and so the syntax tree) stay exactly those of the input except for trailing
//! commas it adds when it wraps a list and the commas between settings it puts on lines of their
//! own: it cannot change what a scene means. The author's line
//! breaks stay; runs of blank lines become one; every comment is kept where it was.
//!
//! The style:
//! - two spaces of indentation per open bracket, and two more on a line that continues an
//!   expression (it starts with `|>`, a binary operator, `.` or `else`, or the line before
//!   ends with `=`, `->`, an operator or a lambda's `|p, n|`);
//! - one space around binary operators, `=`, `->` and `|>`, after `,` and `:`, and none
//!   inside brackets, before `(` and `[` of a call or an index, around `.` and `..`, after a
//!   prefix `-` or `!`, or inside a lambda's bars;
//! - a line longer than [`WIDTH`] columns is broken outermost first: its least nested
//!   bracketed list that holds a comma gets one item per line (call arguments and list items
//!   each followed by a comma, a block's settings without), or, when that list is in the head
//!   of a `let`, `fn` or setting or nested in its value, the line breaks after the `=`; then
//!   again inside the new lines while they are too long.

use super::token::{self, Token};
use crate::diagnostic::Diagnostic;
use crate::source::{FileId, LINE_BREAKS};

/// The widest a line may be before its lists are wrapped.
pub const WIDTH: usize = 100;
const INDENT: &str = "  ";

/// The formatted text of a file, or the diagnostics that stop it from parsing.
pub fn format(file: FileId, src: &str) -> Result<String, Vec<Diagnostic>> {
    let (_, diags) = super::parse(file, src);
    if diags.iter().any(Diagnostic::is_error) {
        return Err(diags);
    }
    let pieces = pieces(src);
    let lines = lines(pieces);
    Ok(layout(lines))
}

#[derive(Clone, Debug)]
enum Kind<'s> {
    Code(Token<'s>),
    /// `// ...` (which ends its line) or `/* ... */`, kept as written.
    Comment,
}

#[derive(Clone, Debug)]
struct Piece<'s> {
    text: &'s str,
    kind: Kind<'s>,
    /// Line breaks between this piece and the one before.
    breaks: usize,
    /// For code: a prefix `-`, an opening or closing lambda bar, an infix `x`.
    role: Role,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Role {
    Plain,
    Prefix,
    BarOpen,
    BarClose,
    Infix,
}

/// The byte ranges of the comments of a file (for an editor's highlighting).
pub fn comment_ranges(src: &str) -> Vec<std::ops::Range<usize>> {
    pieces(src)
        .iter()
        .filter(|p| matches!(p.kind, Kind::Comment))
        .map(|p| {
            let at = p.text.as_ptr() as usize - src.as_ptr() as usize;
            at..at + p.text.len()
        })
        .collect()
}

/// Tokens and comments in order, each with the line breaks before it.
fn pieces(src: &str) -> Vec<Piece<'_>> {
    let mut out = vec![];
    let mut at = if src.starts_with('\u{feff}') { 3 } else { 0 };
    for (tok, range) in token::lex(src) {
        let breaks = gap(src, at, range.start, &mut out);
        out.push(Piece {
            text: &src[range.clone()],
            kind: Kind::Code(tok),
            breaks,
            role: Role::Plain,
        });
        at = range.end;
    }
    gap(src, at, src.len(), &mut out);
    assign_roles(&mut out);
    out
}

/// Push the comments in `src[from..to]` (whitespace and comments only); the line breaks
/// after the last of them.
fn gap<'s>(src: &'s str, from: usize, to: usize, out: &mut Vec<Piece<'s>>) -> usize {
    let mut i = from;
    let mut breaks = 0;
    while i < to {
        let rest = &src[i..to];
        let len = if rest.starts_with("//") {
            rest.find(LINE_BREAKS).unwrap_or(rest.len())
        } else if rest.starts_with("/*") {
            rest.find("*/").map_or(rest.len(), |e| e + 2)
        } else {
            let c = rest.chars().next().unwrap_or(' ');
            if LINE_BREAKS.contains(&c) && !rest.starts_with("\r\n") {
                breaks += 1;
            }
            i += c.len_utf8();
            continue;
        };
        out.push(Piece {
            text: &src[i..i + len],
            kind: Kind::Comment,
            breaks,
            role: Role::Plain,
        });
        breaks = 0;
        i += len;
    }
    breaks
}

/// Whether a token ends an operand, so that what follows is an operator or a call.
fn ends_operand(t: &Token) -> bool {
    matches!(
        t,
        Token::Number(_)
            | Token::Hex(_)
            | Token::Str(_)
            | Token::Ident(_)
            | Token::True
            | Token::False
            | Token::RParen
            | Token::RBracket
            | Token::RBrace
    )
}

/// Tell prefix `-` from binary, opening lambda bars from closing ones and the size operator
/// `x` from a name, by what comes before.
fn assign_roles(pieces: &mut [Piece]) {
    let mut prev: Option<(Token, Role)> = None;
    let mut in_params = false;
    for p in pieces.iter_mut() {
        let Kind::Code(t) = p.kind else { continue };
        let after_operand = prev
            .as_ref()
            .is_some_and(|(t, r)| ends_operand(t) && *r != Role::Infix);
        p.role = match t {
            Token::Minus | Token::Bang if !after_operand => Role::Prefix,
            Token::Bar if in_params => {
                in_params = false;
                Role::BarClose
            }
            Token::Bar => {
                in_params = true;
                Role::BarOpen
            }
            Token::Ident("x") if after_operand => Role::Infix,
            _ => Role::Plain,
        };
        prev = Some((t, p.role));
    }
}

/// One output line before layout: its pieces and whether a blank line comes before it.
#[derive(Clone, Debug)]
struct Line<'s> {
    pieces: Vec<Piece<'s>>,
    blank_before: bool,
}

fn lines(pieces: Vec<Piece<'_>>) -> Vec<Line<'_>> {
    let mut out: Vec<Line> = vec![];
    for p in pieces {
        match out.last_mut() {
            Some(line) if p.breaks == 0 => line.pieces.push(p),
            _ => {
                let blank_before = p.breaks >= 2 && !out.is_empty();
                out.push(Line {
                    pieces: vec![p],
                    blank_before,
                });
            }
        }
    }
    out
}

fn code<'s>(p: &Piece<'s>) -> Option<Token<'s>> {
    match p.kind {
        Kind::Code(t) => Some(t),
        Kind::Comment => None,
    }
}

fn is_open(t: &Token) -> bool {
    matches!(t, Token::LParen | Token::LBracket | Token::LBrace)
}

fn is_close(t: &Token) -> bool {
    matches!(t, Token::RParen | Token::RBracket | Token::RBrace)
}

fn is_binary(t: &Token, role: Role) -> bool {
    use Token::*;
    matches!(
        t,
        Plus | Star
            | Slash
            | Mod
            | EqEq
            | NotEq
            | Lt
            | Le
            | Gt
            | Ge
            | AndAnd
            | OrOr
            | Pipe
            | Dot
            | DotDot
            | Arrow
    ) || (*t == Minus && role != Role::Prefix)
        || role == Role::Infix
}

/// Whether a space goes between two neighbouring pieces of a line.
fn space(a: &Piece, b: &Piece) -> bool {
    let (Some(ta), Some(tb)) = (code(a), code(b)) else {
        return true;
    };
    use Token::*;
    // `| |` (no parameters) must not become the token `||`.
    if ta == Bar && tb == Bar {
        return true;
    }
    if matches!(tb, Comma | Semi | Colon | RParen | RBracket | Dot | DotDot)
        || matches!(ta, LParen | LBracket | Dot | DotDot)
        || a.role == Role::Prefix
        || a.role == Role::BarOpen
        || b.role == Role::BarClose
    {
        return false;
    }
    // A call or an index: `f(x)`, `xs[i]`.
    if matches!(tb, LParen | LBracket) && matches!(ta, Ident(_) | RParen | RBracket) {
        return a.role == Role::Infix;
    }
    true
}

/// Whether `line` continues the expression of the line before, whose last token is `prev`.
fn continues(line: &Line, prev: Option<&Piece>) -> bool {
    let first = line.pieces.iter().find(|p| code(p).is_some());
    let Some(first) = first else { return false };
    let Some(t) = code(first) else { return false };
    // `else` on its own line belongs to the `if` before it.
    if is_binary(&t, first.role) || t == Token::Else {
        return true;
    }
    match prev.and_then(|p| code(p).map(|t| (t, p.role))) {
        Some((Token::Eq | Token::Colon | Token::If | Token::In | Token::Else, _)) => {
            !is_close(&t) && t != Token::LBrace
        }
        Some((t, role)) => is_binary(&t, role) || role == Role::BarClose,
        None => false,
    }
}

fn render(line: &Line, indent: usize) -> String {
    let mut s = INDENT.repeat(indent);
    for (i, p) in line.pieces.iter().enumerate() {
        if i > 0 && space(&line.pieces[i - 1], p) {
            s.push(' ');
        }
        s.push_str(p.text);
    }
    s
}

/// Columns of the last line of `s` (block comments may span lines).
fn width(s: &str) -> usize {
    s.rsplit('\n').next().unwrap_or("").chars().count()
}

/// Split a line that is too long, outermost first: a bracketed list with a comma whose closer
/// is on the line, the least nested one (a settings block before the calls in its fields, a
/// call's arguments before the vectors in them), becomes the head up to the opener, one line per
/// item and the closer with the rest. Call and list items end in a comma; a settings block's
/// fields stand one per line without them. When the least nested list lies in the head of a
/// `let`, `fn` or setting (`fn f(a, b) -> shape = ...`), or inside its value rather than ending
/// it (`a |> f(x, y) |> g`), the line breaks after the `=` instead, and the value is wrapped on
/// its own if need be.
fn wrap<'s>(line: &Line<'s>) -> Option<Vec<Line<'s>>> {
    let ps = &line.pieces;
    let at = |v: &[Piece<'s>]| Line {
        pieces: v.to_vec(),
        blank_before: false,
    };
    // Each list: (opener, closer, its commas, its nesting on this line).
    let mut lists: Vec<(usize, usize, Vec<usize>, i32)> = vec![];
    let mut open: Vec<(usize, Vec<usize>)> = vec![];
    // The first `=` outside every bracket with code after it.
    let mut eq = None;
    let last_code = ps.iter().rposition(|p| code(p).is_some());
    for (j, q) in ps.iter().enumerate() {
        match code(q) {
            Some(t) if is_open(&t) => open.push((j, vec![])),
            Some(t) if is_close(&t) => {
                if let Some((i, commas)) = open.pop()
                    && !commas.is_empty()
                {
                    lists.push((i, j, commas, open.len() as i32));
                }
            }
            Some(Token::Comma) => {
                if let Some((_, commas)) = open.last_mut() {
                    commas.push(j);
                }
            }
            Some(Token::Eq) if open.is_empty() && eq.is_none() && Some(j) != last_code => {
                eq = Some(j);
            }
            _ => {}
        }
    }
    // The least nested list, and among those the first after the `=`, else the first.
    let least = lists.iter().map(|l| l.3).min();
    let outer: Vec<_> = lists.iter().filter(|l| Some(l.3) == least).collect();
    let best = outer
        .iter()
        .find(|l| eq.is_some_and(|e| l.0 > e))
        .or(outer.iter().min_by_key(|l| l.0))
        .copied();
    if let Some(e) = eq
        && best.is_none_or(|l| l.0 < e || l.3 > 0 || Some(l.1) != last_code)
    {
        return Some(vec![
            Line {
                pieces: ps[..=e].to_vec(),
                blank_before: line.blank_before,
            },
            at(&ps[e + 1..]),
        ]);
    }
    let (i, close, commas, _) = best?;
    let brace = code(&ps[*i]) == Some(Token::LBrace);
    let mut out = vec![Line {
        pieces: ps[..=*i].to_vec(),
        blank_before: line.blank_before,
    }];
    let mut from = i + 1;
    for &c in commas.iter().chain([close]) {
        let mut item = ps[from..c].to_vec();
        if !item.is_empty() {
            if brace {
                // Settings stand on lines of their own without commas.
            } else if c == *close {
                item.push(Piece {
                    text: ",",
                    kind: Kind::Code(Token::Comma),
                    breaks: 0,
                    role: Role::Plain,
                });
            } else {
                item.push(ps[c].clone());
            }
            out.push(at(&item));
        }
        from = c + 1;
    }
    out.push(at(&ps[*close..]));
    Some(out)
}

/// One laid-out line: its text, where its trailing `//` comment starts (after code), and
/// whether a blank line comes before it.
struct Out {
    text: String,
    comment_at: Option<usize>,
    blank_before: bool,
}

/// Trailing `//` comments of neighbouring lines start in one column, when that fits.
fn align_comments(lines: &mut [Out]) {
    let mut i = 0;
    while i < lines.len() {
        let mut j = i;
        while j < lines.len() && lines[j].comment_at.is_some() && (j == i || !lines[j].blank_before)
        {
            j += 1;
        }
        if j - i >= 2 {
            let run = &mut lines[i..j];
            let code = |o: &Out| {
                o.text[..o.comment_at.unwrap_or(0)]
                    .trim_end()
                    .chars()
                    .count()
            };
            let column = run.iter().map(code).max().unwrap_or(0) + 1;
            let fits = run
                .iter()
                .all(|o| column + width(&o.text[o.comment_at.unwrap_or(0)..]) <= WIDTH);
            if fits {
                for o in run.iter_mut() {
                    let at = o.comment_at.unwrap_or(0);
                    let code_text = o.text[..at].trim_end().to_string();
                    let pad = column - code_text.chars().count();
                    o.text = format!("{code_text}{}{}", " ".repeat(pad), &o.text[at..]);
                }
            }
        }
        i = j.max(i + 1);
    }
}

fn layout(lines: Vec<Line>) -> String {
    let mut done: Vec<Out> = vec![];
    // For each open bracket, the indentation of the line it opened on.
    let mut stack: Vec<usize> = vec![];
    let mut prev_code: Option<Piece> = None;
    let mut queue: std::collections::VecDeque<Line> = lines.into();
    while let Some(line) = queue.pop_front() {
        let first = line.pieces.iter().find_map(code);
        let base = stack.last().map_or(0, |i| i + 1);
        let indent = match first {
            Some(t) if is_close(&t) => stack.last().copied().unwrap_or(0),
            Some(_) => base + usize::from(continues(&line, prev_code.as_ref())),
            None => base,
        };
        let text = render(&line, indent);
        // A trailing `//` comment may run past the width; the code before it is what wraps.
        let code_end = line.pieces.iter().rposition(|p| code(p).is_some());
        let code_only = Line {
            pieces: line.pieces[..code_end.map_or(0, |e| e + 1)].to_vec(),
            blank_before: false,
        };
        if width(&render(&code_only, indent)) > WIDTH
            && let Some(split) = wrap(&line)
        {
            for l in split.into_iter().rev() {
                queue.push_front(l);
            }
            continue;
        }
        let text = text.trim_end().to_string();
        let has_code = line.pieces.iter().any(|p| code(p).is_some());
        let comment_at = match line.pieces.last() {
            Some(p) if has_code && code(p).is_none() && p.text.starts_with("//") => {
                Some(text.len() - p.text.trim_end().len())
            }
            _ => None,
        };
        done.push(Out {
            text,
            comment_at,
            blank_before: line.blank_before,
        });
        for p in &line.pieces {
            match code(p) {
                Some(t) if is_open(&t) => stack.push(indent),
                Some(t) if is_close(&t) => {
                    stack.pop();
                }
                _ => {}
            }
            if code(p).is_some() {
                prev_code = Some(p.clone());
            }
        }
    }
    align_comments(&mut done);
    let mut out = String::new();
    for o in done {
        if o.blank_before {
            out.push('\n');
        }
        out.push_str(&o.text);
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fmt(s: &str) -> String {
        format(FileId(0), s).unwrap_or_else(|d| panic!("{d:?}"))
    }

    #[test]
    fn spaces_indents_and_keeps_comments() {
        let src = "// top\n\n\n\nlet  a=-1+2*3 // trailing\nobject ball{shape=hypersphere( radius:a )|>translate([0,1,0,0])\n/* kept */ material=|p,n|diffuse(rgb(p.x))}\n";
        let want = "// top\n\nlet a = -1 + 2 * 3 // trailing\nobject ball { shape = hypersphere(radius: a) |> translate([0, 1, 0, 0])\n  /* kept */ material = |p, n| diffuse(rgb(p.x)) }\n";
        assert_eq!(fmt(src), want);
        assert_eq!(fmt(want), want);
    }

    #[test]
    fn continuation_lines_are_indented() {
        let src = "object b {\nshape = hypersphere(1)\n|> translate([1, 0, 0, 0])\nmaterial = diffuse()\n}\n";
        let want = "object b {\n  shape = hypersphere(1)\n    |> translate([1, 0, 0, 0])\n  material = diffuse()\n}\n";
        assert_eq!(fmt(src), want);
    }

    #[test]
    fn long_lists_wrap_one_item_per_line() {
        let items: Vec<String> = (0..30).map(|i| format!("item_{i}")).collect();
        let src = format!("let xs = [{}]\n", items.join(", "));
        let out = fmt(&src);
        assert!(
            out.starts_with("let xs = [\n  item_0,\n  item_1,\n"),
            "{out}"
        );
        assert!(out.ends_with("  item_29,\n]\n"), "{out}");
        assert!(out.lines().all(|l| l.len() <= WIDTH));
        assert_eq!(fmt(&out), out);
    }

    #[test]
    fn size_operator_and_prefix_minus() {
        assert_eq!(
            fmt("render{size=320 x 240}"),
            "render { size = 320 x 240 }\n"
        );
        assert_eq!(
            fmt("let a=[0,-1]-b\nlet b=2*-t"),
            "let a = [0, -1] - b\nlet b = 2 * -t\n"
        );
    }

    #[test]
    fn else_on_its_own_line_continues_the_if() {
        let src = "fn row(k: num) -> shape =\n  if k == 0 { hypersphere(0.3) }\n  else { hypersphere(1) }\n";
        assert_eq!(fmt(src), src);
    }

    #[test]
    fn never_glues_tokens_into_others() {
        assert_eq!(fmt("let f = | | 1"), "let f = | | 1\n");
    }

    #[test]
    fn refuses_what_does_not_parse() {
        assert!(format(FileId(0), "let a = (").is_err());
    }
}
