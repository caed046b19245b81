//! `hyperslice lsp`: a language server over standard input and output. It checks each open
//! document as it changes (imports relative to its file) and answers hovers, definitions,
//! completions, document symbols, semantic tokens and formatting from the same front end as
//! `check` and `fmt`.

use hyperslice::Compilation;
use hyperslice::check::Resolved;
use hyperslice::diagnostic::{Diagnostic, Severity};
use hyperslice::scene::MathFn;
use hyperslice::scene::builtins::{self as table, ParamSpec};
use hyperslice::source::{FileId, SourceMap, Span};
use hyperslice::syntax::ast::{BlockKind, ItemKind, OBJECT_SETTINGS};
use hyperslice::syntax::format;
use hyperslice::syntax::token::{self, Token};
use lsp_server::{Connection, Message, Notification, Request, Response};
use lsp_types as lsp;
use lsp_types::notification::Notification as _;
use lsp_types::request::Request as _;
use std::collections::HashMap;
use std::path::PathBuf;
use std::process::ExitCode;

/// Token types of the semantic-token legend, in the order their indices name them.
const TOKEN_TYPES: [lsp::SemanticTokenType; 7] = [
    lsp::SemanticTokenType::KEYWORD,
    lsp::SemanticTokenType::NUMBER,
    lsp::SemanticTokenType::STRING,
    lsp::SemanticTokenType::COMMENT,
    lsp::SemanticTokenType::FUNCTION,
    lsp::SemanticTokenType::VARIABLE,
    lsp::SemanticTokenType::OPERATOR,
];

pub fn run() -> ExitCode {
    let (connection, io) = Connection::stdio();
    let caps = lsp::ServerCapabilities {
        text_document_sync: Some(lsp::TextDocumentSyncCapability::Kind(
            lsp::TextDocumentSyncKind::FULL,
        )),
        hover_provider: Some(lsp::HoverProviderCapability::Simple(true)),
        definition_provider: Some(lsp::OneOf::Left(true)),
        completion_provider: Some(lsp::CompletionOptions::default()),
        document_symbol_provider: Some(lsp::OneOf::Left(true)),
        document_formatting_provider: Some(lsp::OneOf::Left(true)),
        semantic_tokens_provider: Some(
            lsp::SemanticTokensServerCapabilities::SemanticTokensOptions(
                lsp::SemanticTokensOptions {
                    legend: lsp::SemanticTokensLegend {
                        token_types: TOKEN_TYPES.to_vec(),
                        token_modifiers: vec![],
                    },
                    full: Some(lsp::SemanticTokensFullOptions::Bool(true)),
                    ..Default::default()
                },
            ),
        ),
        ..Default::default()
    };
    let caps = serde_json::to_value(caps).unwrap_or_default();
    if let Err(e) = connection.initialize(caps) {
        eprintln!("error: the language server could not start: {e}");
        return ExitCode::FAILURE;
    }
    let mut server = Server {
        docs: HashMap::new(),
        connection: &connection,
    };
    let ok = server.serve();
    drop(connection);
    let _ = io.join();
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

struct Doc {
    text: String,
    compiled: Compilation,
}

struct Server<'c> {
    docs: HashMap<lsp::Url, Doc>,
    connection: &'c Connection,
}

impl Server<'_> {
    /// Serve until `shutdown` and `exit`; false if the connection broke.
    fn serve(&mut self) -> bool {
        while let Ok(msg) = self.connection.receiver.recv() {
            match msg {
                Message::Request(req) => {
                    match self.connection.handle_shutdown(&req) {
                        Ok(true) => return true,
                        Ok(false) => {}
                        Err(_) => return false,
                    }
                    let resp = self.request(req);
                    if self.connection.sender.send(resp.into()).is_err() {
                        return false;
                    }
                }
                Message::Notification(n) => self.notification(n),
                Message::Response(_) => {}
            }
        }
        false
    }

    fn notification(&mut self, n: Notification) {
        use lsp::notification as note;
        let uri_text = match n.method.as_str() {
            note::DidOpenTextDocument::METHOD => n
                .extract::<lsp::DidOpenTextDocumentParams>(note::DidOpenTextDocument::METHOD)
                .ok()
                .map(|p| (p.text_document.uri, p.text_document.text)),
            note::DidChangeTextDocument::METHOD => n
                .extract::<lsp::DidChangeTextDocumentParams>(note::DidChangeTextDocument::METHOD)
                .ok()
                .and_then(|p| {
                    let text = p.content_changes.into_iter().last()?.text;
                    Some((p.text_document.uri, text))
                }),
            note::DidCloseTextDocument::METHOD => {
                if let Ok(p) =
                    n.extract::<lsp::DidCloseTextDocumentParams>(note::DidCloseTextDocument::METHOD)
                {
                    self.docs.remove(&p.text_document.uri);
                    self.publish(&p.text_document.uri, vec![]);
                }
                None
            }
            _ => None,
        };
        if let Some((uri, text)) = uri_text {
            let path = uri
                .to_file_path()
                .unwrap_or_else(|_| PathBuf::from(uri.path()));
            let compiled = Compilation::from_text(&path, &text);
            let diags = (compiled.diagnostics.iter())
                .map(|d| to_lsp_diagnostic(d, &compiled.sources, &text))
                .collect();
            self.publish(&uri, diags);
            self.docs.insert(uri, Doc { text, compiled });
        }
    }

    fn publish(&self, uri: &lsp::Url, diagnostics: Vec<lsp::Diagnostic>) {
        let params = lsp::PublishDiagnosticsParams {
            uri: uri.clone(),
            diagnostics,
            version: None,
        };
        let n = Notification::new(
            lsp::notification::PublishDiagnostics::METHOD.to_string(),
            params,
        );
        let _ = self.connection.sender.send(n.into());
    }

    fn request(&self, req: Request) -> Response {
        use lsp::request as r;
        let id = req.id.clone();
        let result = match req.method.as_str() {
            r::HoverRequest::METHOD => req
                .extract::<lsp::HoverParams>(r::HoverRequest::METHOD)
                .ok()
                .map(|(_, p)| p)
                .and_then(|p| self.hover(&p.text_document_position_params))
                .map(serde_json::to_value),
            r::GotoDefinition::METHOD => req
                .extract::<lsp::GotoDefinitionParams>(r::GotoDefinition::METHOD)
                .ok()
                .map(|(_, p)| p)
                .and_then(|p| self.definition(&p.text_document_position_params))
                .map(serde_json::to_value),
            r::Completion::METHOD => req
                .extract::<lsp::CompletionParams>(r::Completion::METHOD)
                .ok()
                .map(|(_, p)| p)
                .map(|p| self.completion(&p.text_document_position))
                .map(serde_json::to_value),
            r::DocumentSymbolRequest::METHOD => req
                .extract::<lsp::DocumentSymbolParams>(r::DocumentSymbolRequest::METHOD)
                .ok()
                .map(|(_, p)| p)
                .and_then(|p| self.symbols(&p.text_document.uri))
                .map(serde_json::to_value),
            r::SemanticTokensFullRequest::METHOD => req
                .extract::<lsp::SemanticTokensParams>(r::SemanticTokensFullRequest::METHOD)
                .ok()
                .map(|(_, p)| p)
                .and_then(|p| self.docs.get(&p.text_document.uri))
                .map(|d| semantic_tokens(&d.text))
                .map(serde_json::to_value),
            r::Formatting::METHOD => req
                .extract::<lsp::DocumentFormattingParams>(r::Formatting::METHOD)
                .ok()
                .map(|(_, p)| p)
                .and_then(|p| self.docs.get(&p.text_document.uri))
                .map(|d| formatting(&d.text))
                .map(serde_json::to_value),
            _ => {
                return Response::new_err(
                    id,
                    lsp_server::ErrorCode::MethodNotFound as i32,
                    format!("`{}` is not supported", req.method),
                );
            }
        };
        match result {
            Some(Ok(v)) => Response::new_ok(id, v),
            _ => Response::new_ok(id, serde_json::Value::Null),
        }
    }

    /// The document and the byte offset of a position in it.
    fn at(&self, p: &lsp::TextDocumentPositionParams) -> Option<(&Doc, usize)> {
        let doc = self.docs.get(&p.text_document.uri)?;
        Some((doc, offset(&doc.text, p.position)))
    }

    fn hover(&self, p: &lsp::TextDocumentPositionParams) -> Option<lsp::Hover> {
        let (doc, at) = self.at(p)?;
        let (word, range) = word_at(&doc.text, at)?;
        let text = match resolved_at(&doc.compiled.resolved, at) {
            Some(r) => {
                let def = &doc.compiled.sources.get(r.def_span.file).text;
                let line = line_of(def, r.def_span.start as usize).trim();
                let value = r
                    .value
                    .as_ref()
                    .map_or(String::new(), |v| format!(" = {v}"));
                format!("```\n{}: {}{value}\n```\n\n`{line}`", r.name, r.ty)
            }
            None => builtin_doc(word)?,
        };
        Some(lsp::Hover {
            contents: lsp::HoverContents::Markup(lsp::MarkupContent {
                kind: lsp::MarkupKind::Markdown,
                value: text,
            }),
            range: Some(lsp_range(&doc.text, range)),
        })
    }

    fn definition(
        &self,
        p: &lsp::TextDocumentPositionParams,
    ) -> Option<lsp::GotoDefinitionResponse> {
        let (doc, at) = self.at(p)?;
        let sources = &doc.compiled.sources;
        // On an import's path: the imported file.
        for item in &doc.compiled.ast.items {
            if let ItemKind::Import { path_span, .. } = &item.kind
                && (path_span.start as usize..=path_span.end as usize).contains(&at)
            {
                let base = p.text_document.uri.to_file_path().ok()?;
                let target = base
                    .parent()?
                    .join(sources.snippet(*path_span).trim_matches('"'));
                let uri = lsp::Url::from_file_path(target).ok()?;
                let start = lsp::Position::new(0, 0);
                return Some(lsp::GotoDefinitionResponse::Scalar(lsp::Location::new(
                    uri,
                    lsp::Range::new(start, start),
                )));
            }
        }
        let r = resolved_at(&doc.compiled.resolved, at)?;
        let def = r.def_span;
        let (uri, text) = if def.file == FileId(0) {
            (p.text_document.uri.clone(), &doc.text)
        } else {
            let f = sources.get(def.file);
            (lsp::Url::from_file_path(f.path.as_ref()?).ok()?, &f.text)
        };
        Some(lsp::GotoDefinitionResponse::Scalar(lsp::Location::new(
            uri,
            lsp_range(text, def.start as usize..def.end as usize),
        )))
    }

    fn completion(&self, p: &lsp::TextDocumentPositionParams) -> Vec<lsp::CompletionItem> {
        let Some((doc, at)) = self.at(p) else {
            return vec![];
        };
        if let Some(settings) = block_settings(&doc.text, at) {
            return (settings.iter())
                .map(|s| lsp::CompletionItem {
                    label: s.to_string(),
                    kind: Some(lsp::CompletionItemKind::PROPERTY),
                    insert_text: Some(format!("{s} = ")),
                    ..Default::default()
                })
                .collect();
        }
        let mut items: Vec<lsp::CompletionItem> = vec![];
        let mut seen = std::collections::HashSet::new();
        for r in &doc.compiled.resolved {
            if r.use_span == r.def_span && seen.insert(r.name.clone()) {
                items.push(lsp::CompletionItem {
                    label: r.name.clone(),
                    kind: Some(if r.ty == "function" {
                        lsp::CompletionItemKind::FUNCTION
                    } else {
                        lsp::CompletionItemKind::VARIABLE
                    }),
                    detail: Some(r.ty.clone()),
                    ..Default::default()
                });
            }
        }
        for name in builtin_names() {
            if seen.insert(name.to_string()) {
                items.push(lsp::CompletionItem {
                    label: name.to_string(),
                    kind: Some(lsp::CompletionItemKind::FUNCTION),
                    detail: signature(name),
                    ..Default::default()
                });
            }
        }
        items
    }

    fn symbols(&self, uri: &lsp::Url) -> Option<lsp::DocumentSymbolResponse> {
        let doc = self.docs.get(uri)?;
        let ast = &doc.compiled.ast;
        let mut out = vec![];
        for item in &ast.items {
            let (name, kind, at) = match &item.kind {
                ItemKind::Let(l) => (l.name.name.clone(), lsp::SymbolKind::VARIABLE, l.name.span),
                ItemKind::Fn(f) => (f.name.name.clone(), lsp::SymbolKind::FUNCTION, f.name.span),
                ItemKind::Object { name, .. } => {
                    (name.name.clone(), lsp::SymbolKind::OBJECT, name.span)
                }
                ItemKind::Block { kind, .. } => {
                    let head = Span {
                        end: item.span.start + kind.keyword().len() as u32,
                        ..item.span
                    };
                    (kind.keyword().to_string(), lsp::SymbolKind::NAMESPACE, head)
                }
                _ => continue,
            };
            #[allow(deprecated)] // `deprecated` is a required field of the type
            out.push(lsp::DocumentSymbol {
                name,
                detail: None,
                kind,
                tags: None,
                deprecated: None,
                range: lsp_range(&doc.text, item.span.range()),
                selection_range: lsp_range(&doc.text, at.range()),
                children: None,
            });
        }
        Some(lsp::DocumentSymbolResponse::Nested(out))
    }
}

/// A diagnostic of the open document. One whose place is in an imported file is shown where
/// the document points at it (the import), or at its start, naming the file.
fn to_lsp_diagnostic(d: &Diagnostic, sources: &SourceMap, text: &str) -> lsp::Diagnostic {
    let primary = d.primary_span();
    let here = primary.filter(|s| s.file == FileId(0)).or_else(|| {
        (d.labels.iter())
            .map(|l| l.span)
            .find(|s| s.file == FileId(0))
    });
    let range = here.map_or_else(Default::default, |s| lsp_range(text, s.range()));
    let mut message = match primary {
        Some(p) if p.file != FileId(0) => {
            let (line, col) = sources.line_col(p.file, p.start as usize);
            format!("{}:{line}:{col}: {}", sources.get(p.file).name, d.message)
        }
        _ => d.message.clone(),
    };
    if let Some(l) = d.labels.first().filter(|l| !l.message.is_empty()) {
        message.push_str(&format!("\n{}", l.message));
    }
    for n in &d.notes {
        message.push_str(&format!("\nnote: {n}"));
    }
    if let Some(h) = &d.help {
        message.push_str(&format!("\nhelp: {h}"));
    }
    lsp::Diagnostic {
        range,
        severity: Some(match d.severity {
            Severity::Error => lsp::DiagnosticSeverity::ERROR,
            Severity::Warning => lsp::DiagnosticSeverity::WARNING,
        }),
        code: Some(lsp::NumberOrString::String(d.code.to_string())),
        source: Some("hyperslice".to_string()),
        message,
        ..Default::default()
    }
}

/// The resolved name whose use covers byte `at` of the root file.
fn resolved_at(resolved: &[Resolved], at: usize) -> Option<&Resolved> {
    resolved.iter().find(|r| {
        r.use_span.file == FileId(0)
            && (r.use_span.start as usize..=r.use_span.end as usize).contains(&at)
    })
}

/// The name under byte `at`, and its range.
fn word_at(text: &str, at: usize) -> Option<(&str, std::ops::Range<usize>)> {
    token::lex(text).into_iter().find_map(|(t, r)| match t {
        Token::Ident(name) if r.start <= at && at <= r.end => Some((name, r)),
        _ => None,
    })
}

fn line_of(text: &str, at: usize) -> &str {
    let start = text[..at.min(text.len())].rfind('\n').map_or(0, |i| i + 1);
    let end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    &text[start..end]
}

/// The settings to offer when byte `at` is directly inside a `render`, `camera` or `object`
/// block.
fn block_settings(text: &str, at: usize) -> Option<&'static [&'static str]> {
    let mut stack: Vec<Option<&'static [&'static str]>> = vec![];
    let tokens = token::lex(text);
    for (i, (t, r)) in tokens.iter().enumerate() {
        if r.start >= at {
            break;
        }
        match t {
            Token::LBrace | Token::LParen | Token::LBracket => {
                let before = |k: usize| i.checked_sub(k).map(|j| tokens[j].0);
                let settings: Option<&'static [&'static str]> = match (before(1), before(2)) {
                    (Some(Token::Render), _) => Some(BlockKind::Render.settings()),
                    (Some(Token::Camera), _) => Some(BlockKind::Camera.settings()),
                    (Some(Token::Ident(_)), Some(Token::Object)) => Some(&OBJECT_SETTINGS),
                    _ => None,
                };
                stack.push(settings.filter(|_| *t == Token::LBrace));
            }
            Token::RBrace | Token::RParen | Token::RBracket => {
                stack.pop();
            }
            _ => {}
        }
    }
    // Only where a setting can start: after `{`, `,` or `;`, or at the start of a line, with
    // perhaps the beginning of a name typed.
    let before: Vec<&(Token, std::ops::Range<usize>)> = tokens
        .iter()
        .filter(|(t, r)| r.end < at || (r.end == at && !matches!(t, Token::Ident(_))))
        .collect();
    let starts = match before.last() {
        Some((Token::LBrace | Token::Comma | Token::Semi, _)) => true,
        Some((_, r)) => text[r.end..at].contains('\n'),
        None => false,
    };
    stack.last().copied().flatten().filter(|_| starts)
}

fn builtin_names() -> impl Iterator<Item = &'static str> {
    (MathFn::ALL.iter().map(|(n, _)| *n))
        .chain(table::TABLE.iter().map(|b| b.name))
        .chain(table::SPECIAL)
        .chain(table::CONSTANTS)
}

/// A builtin's signature: `hypersphere(radius: num = 1)`.
fn signature(name: &str) -> Option<String> {
    let param = |p: &ParamSpec| match table::show_default(p) {
        Some(d) => format!("{}: {} = {d}", p.name, p.ty.ty()),
        None => format!("{}: {}", p.name, p.ty.ty()),
    };
    if let Some(b) = table::find(name) {
        let ps: Vec<String> = b.params.iter().map(param).collect();
        return Some(format!("{name}({})", ps.join(", ")));
    }
    MathFn::from_name(name).map(|f| format!("{name}({})", f.params().join(", ")))
}

/// The signature and the reference's line about a builtin (docs/language.md is compiled in).
fn builtin_doc(name: &str) -> Option<String> {
    const DOCS: &str = include_str!("../docs/language.md");
    let sig = signature(name);
    let plain = format!("| `{name}` |");
    let call = format!("`{name}(");
    let row = DOCS.lines().find(|l| l.starts_with(&plain)).or_else(|| {
        DOCS.lines()
            .find(|l| l.starts_with("| ") && l.split('|').nth(1).is_some_and(|c| c.contains(&call)))
    })?;
    let cells: Vec<&str> = row
        .split(" | ")
        .map(|c| c.trim_matches(['|', ' ']))
        .collect();
    let line = match cells.as_slice() {
        [_, _, doc, ..] if table::find(name).is_some() => doc.to_string(),
        [_, takes, returns] => format!("takes {takes}, returns {returns}"),
        [_, rest @ ..] => rest.join("; "),
        [] => String::new(),
    };
    let sig = sig.unwrap_or_else(|| name.to_string());
    Some(format!("```\n{sig}\n```\n\n{line}"))
}

fn formatting(text: &str) -> Vec<lsp::TextEdit> {
    match format::format(FileId(0), text) {
        Ok(out) if out != text => vec![lsp::TextEdit {
            range: lsp_range(text, 0..text.len()),
            new_text: out,
        }],
        _ => vec![],
    }
}

fn semantic_tokens(text: &str) -> lsp::SemanticTokens {
    let mut spans: Vec<(std::ops::Range<usize>, u32)> = format::comment_ranges(text)
        .into_iter()
        .map(|r| (r, 3))
        .collect();
    let tokens = token::lex(text);
    for (i, (t, r)) in tokens.iter().enumerate() {
        let kind = match t {
            Token::Number(_) | Token::Hex(_) => 1,
            Token::Str(_) => 2,
            Token::Ident(_) if matches!(tokens.get(i + 1), Some((Token::LParen, _))) => 4,
            Token::Ident(_) => 5,
            Token::Error(_) | Token::Unused => continue,
            t if t.is_keyword() => 0,
            _ => 6,
        };
        spans.push((r.clone(), kind));
    }
    spans.sort_by_key(|(r, _)| r.start);
    let mut data = vec![];
    let (mut line, mut col) = (0, 0);
    for (r, kind) in spans {
        // A token over several lines (a block comment) is sent as its first line.
        let start = position(text, r.start);
        let end_of_line = text[r.start..r.end]
            .find('\n')
            .map_or(r.end, |i| r.start + i);
        let length = text[r.start..end_of_line].encode_utf16().count() as u32;
        let delta_line = start.line - line;
        let delta_start = if delta_line == 0 {
            start.character - col
        } else {
            start.character
        };
        data.push(lsp::SemanticToken {
            delta_line,
            delta_start,
            length,
            token_type: kind,
            token_modifiers_bitset: 0,
        });
        (line, col) = (start.line, start.character);
    }
    lsp::SemanticTokens {
        result_id: None,
        data,
    }
}

/// The LSP position (line, UTF-16 column; lines end at LF, CR LF or CR) of a byte offset.
fn position(text: &str, at: usize) -> lsp::Position {
    let at = at.min(text.len());
    let mut line = 0;
    let mut start = 0;
    let bytes = text.as_bytes();
    for (i, b) in bytes[..at].iter().enumerate() {
        let ends = *b == b'\n' || (*b == b'\r' && bytes.get(i + 1) != Some(&b'\n'));
        if ends {
            line += 1;
            start = i + 1;
        }
    }
    let col = text.get(start..at).map_or(0, |s| s.encode_utf16().count());
    lsp::Position::new(line, col as u32)
}

fn lsp_range(text: &str, r: std::ops::Range<usize>) -> lsp::Range {
    lsp::Range::new(position(text, r.start), position(text, r.end))
}

/// The byte offset of an LSP position.
fn offset(text: &str, p: lsp::Position) -> usize {
    let bytes = text.as_bytes();
    let mut line = 0;
    let mut i = 0;
    while line < p.line && i < bytes.len() {
        if bytes[i] == b'\n' || (bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n')) {
            line += 1;
        }
        i += 1;
    }
    let mut units = 0;
    for (j, c) in text[i..].char_indices() {
        if units >= p.character as usize || c == '\n' || c == '\r' {
            return i + j;
        }
        units += c.len_utf16();
    }
    text.len()
}
