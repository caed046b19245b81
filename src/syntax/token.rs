//! The lexer: logos turns source text into tokens with byte spans. A lexing error becomes an
//! `Error` token (with a reason) so that parsing carries on and reports more.

use logos::Logos;
use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum LexError {
    #[default]
    BadChar,
    UnterminatedString,
    UnterminatedComment,
    /// A number running straight into a name, such as `512x384` or `3px`.
    GluedNumber,
    /// A name with letters outside ASCII, such as `café`.
    NonAsciiName,
}

#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[logos(error = LexError)]
// Line breaks are `source::LINE_BREAKS`, the set the reports count lines by: a `//` comment and
// a string end at any of them, so a line number means the same to the lexer and the report.
#[logos(skip r"[ \t\r\n\x0B\x0C\u{85}\u{2028}\u{2029}]+")]
#[logos(skip(r"//[^\r\n\x0B\x0C\u{85}\u{2028}\u{2029}]*", allow_greedy = true))]
#[logos(skip r"/\*([^*]|\*+[^*/])*\*+/")]
pub enum Token<'src> {
    /// A lexing error, with why; the span says where.
    Error(LexError),

    #[regex(r"/\*([^*]|\*+[^*/])*\**", callback = unterminated_comment, priority = 1)]
    #[regex(r#""([^"\\\r\n\x0B\x0C\u{85}\u{2028}\u{2029}]|\\[^\r\n\x0B\x0C\u{85}\u{2028}\u{2029}])*"#, callback = unterminated_string, priority = 1, allow_greedy = true)]
    #[regex(r"[\p{L}_][\p{L}\p{N}_]*", callback = non_ascii_name, priority = 1)]
    #[regex(r"[0-9]+(\.[0-9]+)?[A-Za-z_][A-Za-z0-9_]*", callback = glued_number, priority = 1)]
    Unused,

    /// A number, possibly with an angle unit suffix (`15deg`, `0.25turn`, `1.2rad`).
    #[regex(r"[0-9]+(\.[0-9]+)?([eE][+-]?[0-9]+)?(deg|rad|turn)?", priority = 10)]
    Number(&'src str),
    /// A hex colour `#rrggbb`.
    #[regex(r"#[0-9a-fA-F]{6}")]
    Hex(&'src str),
    #[regex(
        r#""([^"\\\r\n\x0B\x0C\u{85}\u{2028}\u{2029}]|\\[^\r\n\x0B\x0C\u{85}\u{2028}\u{2029}])*""#
    )]
    Str(&'src str),
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident(&'src str),

    #[token("let")]
    Let,
    #[token("fn")]
    Fn,
    #[token("object")]
    Object,
    #[token("render")]
    Render,
    #[token("camera")]
    Camera,
    #[token("sky")]
    Sky,
    #[token("medium")]
    Medium,
    #[token("import")]
    Import,
    #[token("if")]
    If,
    #[token("else")]
    Else,
    #[token("for")]
    For,
    #[token("in")]
    In,
    #[token("true")]
    True,
    #[token("false")]
    False,
    #[token("sdf")]
    Sdf,
    #[token("mod")]
    Mod,

    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token(":")]
    Colon,
    #[token(".")]
    Dot,
    #[token("..")]
    DotDot,
    #[token("->")]
    Arrow,
    #[token("|>")]
    Pipe,
    #[token("|")]
    Bar,
    #[token("=")]
    Eq,
    #[token("==")]
    EqEq,
    #[token("!=")]
    NotEq,
    #[token("<")]
    Lt,
    #[token("<=")]
    Le,
    #[token(">")]
    Gt,
    #[token(">=")]
    Ge,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("!")]
    Bang,
    #[token("&&")]
    AndAnd,
    #[token("||")]
    OrOr,
}

impl Token<'_> {
    /// A reserved word (`true` and `false` included), which can't be a name.
    pub fn is_keyword(&self) -> bool {
        matches!(
            self,
            Token::Let
                | Token::Fn
                | Token::Object
                | Token::Render
                | Token::Camera
                | Token::Sky
                | Token::Medium
                | Token::Import
                | Token::If
                | Token::Else
                | Token::For
                | Token::In
                | Token::True
                | Token::False
                | Token::Sdf
                | Token::Mod
        )
    }
}

fn unterminated_comment<'s>(_: &mut logos::Lexer<'s, Token<'s>>) -> Result<(), LexError> {
    Err(LexError::UnterminatedComment)
}

fn glued_number<'s>(_: &mut logos::Lexer<'s, Token<'s>>) -> Result<(), LexError> {
    Err(LexError::GluedNumber)
}

fn non_ascii_name<'s>(_: &mut logos::Lexer<'s, Token<'s>>) -> Result<(), LexError> {
    Err(LexError::NonAsciiName)
}

fn unterminated_string<'s>(_: &mut logos::Lexer<'s, Token<'s>>) -> Result<(), LexError> {
    Err(LexError::UnterminatedString)
}

impl fmt::Display for Token<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Token::*;
        let s = match self {
            Error(_) | Unused => "invalid text",
            Number(_) => "a number",
            Hex(_) => "a hex colour",
            Str(_) => "a string",
            Ident(s) => return write!(f, "`{s}`"),
            Let => "`let`",
            Fn => "`fn`",
            Object => "`object`",
            Render => "`render`",
            Camera => "`camera`",
            Sky => "`sky`",
            Medium => "`medium`",
            Import => "`import`",
            If => "`if`",
            Else => "`else`",
            For => "`for`",
            In => "`in`",
            True => "`true`",
            False => "`false`",
            Sdf => "`sdf`",
            Mod => "`mod`",
            LParen => "`(`",
            RParen => "`)`",
            LBracket => "`[`",
            RBracket => "`]`",
            LBrace => "`{`",
            RBrace => "`}`",
            Comma => "`,`",
            Semi => "`;`",
            Colon => "`:`",
            Dot => "`.`",
            DotDot => "`..`",
            Arrow => "`->`",
            Pipe => "`|>`",
            Bar => "`|`",
            Eq => "`=`",
            EqEq => "`==`",
            NotEq => "`!=`",
            Lt => "`<`",
            Le => "`<=`",
            Gt => "`>`",
            Ge => "`>=`",
            Plus => "`+`",
            Minus => "`-`",
            Star => "`*`",
            Slash => "`/`",
            Bang => "`!`",
            AndAnd => "`&&`",
            OrOr => "`||`",
        };
        f.write_str(s)
    }
}

/// Lex a whole file: every token with its byte range. Never fails; errors are `Error` tokens.
/// A leading byte-order mark, which some editors write, is not part of the text.
pub fn lex(src: &str) -> Vec<(Token<'_>, std::ops::Range<usize>)> {
    let bom = if src.starts_with('\u{feff}') { 3 } else { 0 };
    Token::lexer(&src[bom..])
        .spanned()
        .map(|(t, span)| {
            (
                t.unwrap_or_else(Token::Error),
                span.start + bom..span.end + bom,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lexes_units_hex_and_comments() {
        let toks: Vec<_> = lex("15deg /* c */ #ff0080 // x\n a..b |> |")
            .into_iter()
            .map(|t| t.0)
            .collect();
        assert_eq!(
            toks,
            vec![
                Token::Number("15deg"),
                Token::Hex("#ff0080"),
                Token::Ident("a"),
                Token::DotDot,
                Token::Ident("b"),
                Token::Pipe,
                Token::Bar
            ]
        );
    }

    #[test]
    fn lexing_errors_are_tokens() {
        let toks: Vec<_> = lex("a $ \"open").into_iter().map(|t| t.0).collect();
        assert_eq!(toks[1], Token::Error(LexError::BadChar));
        assert_eq!(toks[2], Token::Error(LexError::UnterminatedString));
        let toks: Vec<_> = lex("512x384 15deg 2e3").into_iter().map(|t| t.0).collect();
        assert_eq!(
            toks,
            vec![
                Token::Error(LexError::GluedNumber),
                Token::Number("15deg"),
                Token::Number("2e3")
            ]
        );
        let toks: Vec<_> = lex("/* never closed").into_iter().map(|t| t.0).collect();
        assert_eq!(toks, vec![Token::Error(LexError::UnterminatedComment)]);
        let toks: Vec<_> = lex("café x").into_iter().map(|t| t.0).collect();
        assert_eq!(
            toks,
            vec![Token::Error(LexError::NonAsciiName), Token::Ident("x")]
        );
    }

    /// Every line break the reports count ends a comment and a string, and nothing else does.
    #[test]
    fn line_breaks_are_the_reports_line_breaks() {
        for brk in crate::source::LINE_BREAKS {
            let src = format!("// c{brk}x \"s{brk}y");
            let toks: Vec<_> = lex(&src).into_iter().map(|t| t.0).collect();
            assert_eq!(
                toks,
                vec![
                    Token::Ident("x"),
                    Token::Error(LexError::UnterminatedString),
                    Token::Ident("y")
                ],
                "{brk:?}"
            );
        }
        let toks: Vec<_> = lex("// c\u{a0}x").into_iter().map(|t| t.0).collect();
        assert!(toks.is_empty());
    }

    #[test]
    fn byte_order_mark_is_skipped() {
        let toks = lex("\u{feff}let");
        assert_eq!(toks, vec![(Token::Let, 3..6)]);
    }
}
