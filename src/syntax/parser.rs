//! The chumsky parser: tokens to an arena `Ast`. Expressions use a Pratt parser; items and block
//! settings recover from errors by skipping to the next item or setting, so one run reports several.

use super::ast::*;
use super::token::Token;
use crate::source::{FileId, Span};
use chumsky::{extra::SimpleState, input::ValueInput, pratt::*, prelude::*};

/// Parser state: the arena being built and the file the spans belong to.
pub struct Builder {
    pub ast: Ast,
    pub file: FileId,
}

impl Builder {
    fn span(&self, s: SimpleSpan) -> Span {
        Span::new(self.file, s.start, s.end)
    }
    fn alloc(&mut self, e: Expr, s: SimpleSpan) -> ExprId {
        let span = self.span(s);
        self.ast.alloc(e, span)
    }
}

pub type Extra<'t, 's> = extra::Full<Rich<'t, Token<'s>>, SimpleState<Builder>, ()>;
type Mx<'t, 'b, 's, I> = chumsky::input::MapExtra<'t, 'b, I, Extra<'t, 's>>;

/// Allocate a node spanning what the current parser consumed.
fn node<'t, 's: 't, I>(e: &mut Mx<'t, '_, 's, I>, expr: Expr) -> ExprId
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    let s = e.span();
    e.state().alloc(expr, s)
}

fn span_of<'t, 's: 't, I>(e: &mut Mx<'t, '_, 's, I>) -> Span
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    let s = e.span();
    e.state().span(s)
}

fn ident<'t, 's: 't, I>() -> impl Parser<'t, I, Ident, Extra<'t, 's>> + Clone
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    select! { Token::Ident(s) => s }
        .map_with(|s: &str, e| Ident {
            name: s.to_string(),
            span: span_of(e),
        })
        .labelled("a name")
}

/// A balanced group of tokens, or one token that is neither a delimiter nor `stop`. Used to skip
/// over broken input without losing track of nesting.
fn token_tree<'t, 's: 't, I>() -> impl Parser<'t, I, (), Extra<'t, 's>> + Clone
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    recursive(|tree| {
        let group = |open, close| {
            tree.clone()
                .repeated()
                .delimited_by(just(open), just(close))
        };
        group(Token::LParen, Token::RParen)
            .or(group(Token::LBracket, Token::RBracket))
            .or(group(Token::LBrace, Token::RBrace))
            .or(none_of([
                Token::LParen,
                Token::RParen,
                Token::LBracket,
                Token::RBracket,
                Token::LBrace,
                Token::RBrace,
            ])
            .ignored())
    })
}

pub fn type_expr<'t, 's: 't, I>() -> impl Parser<'t, I, TypeExpr, Extra<'t, 's>> + Clone
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    recursive(|ty| {
        ident()
            .then(
                ty.delimited_by(just(Token::LBracket), just(Token::RBracket))
                    .or_not(),
            )
            .map_with(|(name, inner), e| {
                let span = span_of(e);
                match inner {
                    Some(inner) if name.name == "list" => TypeExpr {
                        kind: TypeKind::List(Box::new(inner)),
                        span,
                    },
                    _ => TypeExpr {
                        kind: TypeKind::Named(name.name),
                        span,
                    },
                }
            })
            .labelled("a type")
    })
}

pub fn expr<'t, 's: 't, I>() -> impl Parser<'t, I, ExprId, Extra<'t, 's>> + Clone
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    recursive(|expr| {
        let alloc = |e: Expr| move |_, x: &mut Mx<'t, '_, 's, I>| node(x, e.clone());

        let number = select! { Token::Number(s) => s }.map_with(|s: &str, e| {
            let (digits, unit) = split_unit(s);
            let value = digits.parse::<f64>().unwrap_or(f64::INFINITY);
            node(e, Expr::Number { value, unit })
        });
        let hex = select! { Token::Hex(s) => s }.map_with(|s: &str, e| {
            let byte = |i: usize| u8::from_str_radix(&s[i..i + 2], 16).unwrap_or(0);
            node(e, Expr::Hex([byte(1), byte(3), byte(5)]))
        });
        let string = select! { Token::Str(s) => s }.map_with(|s: &str, e| {
            let text = unescape(&s[1..s.len() - 1]);
            node(e, Expr::Str(text))
        });
        let boolean = just(Token::True)
            .map_with(alloc(Expr::Bool(true)))
            .or(just(Token::False).map_with(alloc(Expr::Bool(false))));
        let name = ident().map_with(|id, e| node(e, Expr::Name(id)));

        let items = expr
            .clone()
            .separated_by(just(Token::Comma))
            .allow_trailing()
            .collect::<Vec<_>>();

        let list = items
            .clone()
            .delimited_by(just(Token::LBracket), just(Token::RBracket))
            .map_with(|xs, e| node(e, Expr::List(xs)))
            .labelled("a list")
            .as_context();

        let paren = expr
            .clone()
            .delimited_by(just(Token::LParen), just(Token::RParen));

        let let_stmt = just(Token::Let)
            .ignore_then(ident())
            .then(just(Token::Colon).ignore_then(type_expr()).or_not())
            .then_ignore(just(Token::Eq))
            .then(expr.clone())
            .then_ignore(just(Token::Semi).or_not())
            .map_with(|((name, ty), value), e| {
                let span = span_of(e);
                LetStmt {
                    name,
                    ty,
                    value,
                    span,
                }
            })
            .labelled("a `let` binding");

        let block = let_stmt
            .repeated()
            .collect::<Vec<_>>()
            .then(expr.clone())
            .delimited_by(just(Token::LBrace), just(Token::RBrace))
            .map_with(|(lets, result), e| {
                if lets.is_empty() {
                    result
                } else {
                    node(e, Expr::Block { lets, result })
                }
            })
            .recover_with(via_parser(
                nested_delimiters(
                    Token::LBrace,
                    Token::RBrace,
                    [
                        (Token::LParen, Token::RParen),
                        (Token::LBracket, Token::RBracket),
                    ],
                    |_| (),
                )
                .map_with(|_, e| node(e, Expr::Error)),
            ))
            .labelled("a block")
            .boxed();

        let if_ = recursive(|if_| {
            just(Token::If)
                .ignore_then(expr.clone())
                .then(block.clone())
                .then_ignore(just(Token::Else))
                .then(block.clone().or(if_))
                .map_with(|((cond, then), otherwise), e| {
                    node(
                        e,
                        Expr::If {
                            cond,
                            then,
                            otherwise,
                        },
                    )
                })
                .labelled("an `if` expression")
                .as_context()
        });

        let for_ = just(Token::For)
            .ignore_then(ident())
            .then_ignore(just(Token::In))
            .then(expr.clone())
            .then(block.clone())
            .map_with(|((var, iter), body), e| node(e, Expr::For { var, iter, body }))
            .labelled("a `for` comprehension")
            .as_context();

        let params = ident()
            .separated_by(just(Token::Comma))
            .collect::<Vec<_>>()
            .delimited_by(just(Token::Bar), just(Token::Bar));

        let lambda = params
            .clone()
            .then(expr.clone())
            .map_with(|(params, body), e| node(e, Expr::Lambda { params, body }))
            .labelled("a function `|p, n| ...`");

        let sdf = just(Token::Sdf)
            .ignore_then(ident().delimited_by(just(Token::Bar), just(Token::Bar)))
            .then(expr.clone())
            .map_with(|(param, body), e| node(e, Expr::Sdf { param, body }))
            .labelled("a distance function `sdf |p| ...`")
            .as_context();

        let atom = choice((
            number, hex, string, boolean, name, list, paren, block, if_, for_, sdf, lambda,
        ))
        .recover_with(via_parser(
            nested_delimiters(
                Token::LParen,
                Token::RParen,
                [
                    (Token::LBracket, Token::RBracket),
                    (Token::LBrace, Token::RBrace),
                ],
                |_| (),
            )
            .map_with(|_, e| node(e, Expr::Error)),
        ))
        .recover_with(via_parser(
            nested_delimiters(
                Token::LBracket,
                Token::RBracket,
                [
                    (Token::LParen, Token::RParen),
                    (Token::LBrace, Token::RBrace),
                ],
                |_| (),
            )
            .map_with(|_, e| node(e, Expr::Error)),
        ))
        .labelled("an expression")
        .boxed();

        let arg = ident()
            .then_ignore(just(Token::Colon))
            .or_not()
            .then(expr.clone())
            .map(|(name, value)| Arg { name, value });
        let args = arg
            .separated_by(just(Token::Comma))
            .allow_trailing()
            .collect::<Vec<_>>()
            .delimited_by(just(Token::LParen), just(Token::RParen))
            .recover_with(via_parser(nested_delimiters(
                Token::LParen,
                Token::RParen,
                [
                    (Token::LBracket, Token::RBracket),
                    (Token::LBrace, Token::RBrace),
                ],
                |_| Vec::new(),
            )))
            .labelled("arguments");

        enum Post {
            Call(Vec<Arg>),
            Index(ExprId),
            Field(Ident),
        }
        let postfix = choice((
            args.map(Post::Call),
            expr.clone()
                .delimited_by(just(Token::LBracket), just(Token::RBracket))
                .map(Post::Index),
            just(Token::Dot).ignore_then(ident()).map(Post::Field),
        ));
        let call = atom.foldl_with(postfix.repeated(), |lhs, post, e| {
            let n = match post {
                Post::Call(args) => Expr::Call { callee: lhs, args },
                Post::Index(i) => Expr::Index(lhs, i),
                Post::Field(f) => Expr::Field(lhs, f),
            };
            node(e, n)
        });

        let bin =
            |op: BinOp| move |l, _, r, e: &mut Mx<'t, '_, 's, I>| node(e, Expr::Binary(op, l, r));
        let un = |op: UnOp| move |_, a, e: &mut Mx<'t, '_, 's, I>| node(e, Expr::Unary(op, a));
        call.pratt((
            prefix(10, just(Token::Minus), un(UnOp::Neg)),
            prefix(10, just(Token::Bang), un(UnOp::Not)),
            infix(left(8), just(Token::Star), bin(BinOp::Mul)),
            infix(left(8), just(Token::Slash), bin(BinOp::Div)),
            infix(left(8), just(Token::Mod), bin(BinOp::Mod)),
            infix(left(7), just(Token::Plus), bin(BinOp::Add)),
            infix(left(7), just(Token::Minus), bin(BinOp::Sub)),
            infix(left(6), just(Token::DotDot), bin(BinOp::Range)),
            infix(left(5), just(Token::Ident("x")), bin(BinOp::Dims)),
            infix(left(4), just(Token::EqEq), bin(BinOp::Eq)),
            infix(left(4), just(Token::NotEq), bin(BinOp::Ne)),
            infix(left(4), just(Token::Lt), bin(BinOp::Lt)),
            infix(left(4), just(Token::Le), bin(BinOp::Le)),
            infix(left(4), just(Token::Gt), bin(BinOp::Gt)),
            infix(left(4), just(Token::Ge), bin(BinOp::Ge)),
            infix(left(3), just(Token::AndAnd), bin(BinOp::And)),
            infix(left(2), just(Token::OrOr), bin(BinOp::Or)),
            infix(
                left(1),
                just(Token::Pipe),
                |l, _, r, e: &mut Mx<'t, '_, 's, I>| node(e, Expr::Pipe(l, r)),
            ),
        ))
        .labelled("an expression")
        .boxed()
    })
}

/// Settings `name = value`, optionally separated by `,` or `;`, inside `{ }`. A broken setting
/// is skipped up to the next `name =` or the closing brace.
fn settings<'t, 's: 't, I>() -> impl Parser<'t, I, Vec<Setting>, Extra<'t, 's>> + Clone
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    let setting_start = ident().then(just(Token::Eq)).ignored();
    let skip = none_of([Token::RBrace])
        .ignored()
        .then(
            setting_start
                .clone()
                .rewind()
                .not()
                .ignore_then(token_tree())
                .repeated(),
        )
        .ignored();
    let setting = ident()
        .then_ignore(just(Token::Eq))
        .then(expr())
        .map(|(name, value)| Some(Setting { name, value }))
        .recover_with(via_parser(skip.to(None)))
        .then_ignore(one_of([Token::Comma, Token::Semi]).or_not());
    setting
        .repeated()
        .collect::<Vec<_>>()
        .map(|v| v.into_iter().flatten().collect())
        .delimited_by(just(Token::LBrace), just(Token::RBrace))
}

const ITEM_KEYWORDS: [Token<'static>; 8] = [
    Token::Let,
    Token::Fn,
    Token::Object,
    Token::Render,
    Token::Camera,
    Token::Sky,
    Token::Medium,
    Token::Import,
];

pub fn file<'t, 's: 't, I>() -> impl Parser<'t, I, Vec<Item>, Extra<'t, 's>>
where
    I: ValueInput<'t, Token = Token<'s>, Span = SimpleSpan>,
{
    let import = just(Token::Import)
        .ignore_then(
            select! { Token::Str(s) => s }
                .map_with(|s: &str, e| (unescape(&s[1..s.len() - 1]), e.span())),
        )
        .map_with(|(path, ps), e| {
            let path_span = (e.state() as &mut Builder).span(ps);
            ItemKind::Import { path, path_span }
        })
        .labelled("an import");

    let let_ = just(Token::Let)
        .ignore_then(ident())
        .then(just(Token::Colon).ignore_then(type_expr()).or_not())
        .then_ignore(just(Token::Eq))
        .then(expr())
        .map_with(|((name, ty), value), e| {
            let span = span_of(e);
            ItemKind::Let(LetStmt {
                name,
                ty,
                value,
                span,
            })
        })
        .labelled("a `let` binding")
        .as_context();

    let param = ident()
        .then_ignore(just(Token::Colon))
        .then(type_expr())
        .then(just(Token::Eq).ignore_then(expr()).or_not())
        .map(|((name, ty), default)| Param { name, ty, default })
        .labelled("a parameter `name: type`");
    let fn_ = just(Token::Fn)
        .ignore_then(ident())
        .then(
            param
                .separated_by(just(Token::Comma))
                .allow_trailing()
                .collect::<Vec<_>>()
                .delimited_by(just(Token::LParen), just(Token::RParen)),
        )
        .then(just(Token::Arrow).ignore_then(type_expr()).or_not())
        .then_ignore(just(Token::Eq))
        .then(expr())
        .map(|(((name, params), ret), body)| {
            ItemKind::Fn(FnDef {
                name,
                params,
                ret,
                body,
            })
        })
        .labelled("a function definition")
        .as_context();

    let object = just(Token::Object)
        .ignore_then(ident())
        .then(settings())
        .map(|(name, settings)| ItemKind::Object { name, settings })
        .labelled("an object")
        .as_context();
    let render = just(Token::Render)
        .ignore_then(settings())
        .map(|settings| ItemKind::Block {
            kind: BlockKind::Render,
            settings,
        })
        .labelled("the `render` block")
        .as_context();
    let camera = just(Token::Camera)
        .ignore_then(settings())
        .map(|settings| ItemKind::Block {
            kind: BlockKind::Camera,
            settings,
        })
        .labelled("the `camera` block")
        .as_context();
    let sky = just(Token::Sky)
        .ignore_then(just(Token::Eq))
        .ignore_then(expr())
        .map(ItemKind::Sky);
    let medium = just(Token::Medium)
        .ignore_then(just(Token::Eq))
        .ignore_then(expr())
        .map(ItemKind::Medium);

    let skip_item = any()
        .ignored()
        .then(
            one_of(ITEM_KEYWORDS)
                .rewind()
                .not()
                .ignore_then(token_tree())
                .repeated(),
        )
        .to(ItemKind::Error);

    choice((import, let_, fn_, object, render, camera, sky, medium))
        .labelled(
            "an item (`let`, `fn`, `object`, `render`, `camera`, `sky`, `medium` or `import`)",
        )
        .then_ignore(just(Token::Semi).or_not())
        .recover_with(via_parser(skip_item))
        .map_with(|kind, e| {
            let span = span_of(e);
            Item { kind, span }
        })
        .repeated()
        .collect::<Vec<_>>()
        .then_ignore(end())
}

/// `15deg` -> ("15", Some(Deg)).
fn split_unit(s: &str) -> (&str, Option<Unit>) {
    for (suffix, unit) in [("deg", Unit::Deg), ("rad", Unit::Rad), ("turn", Unit::Turn)] {
        if let Some(digits) = s.strip_suffix(suffix) {
            return (digits, Some(unit));
        }
    }
    (s, None)
}

fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.next() {
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some(other) => out.push(other),
                None => {}
            }
        } else {
            out.push(c);
        }
    }
    out
}
