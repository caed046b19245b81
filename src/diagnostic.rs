//! One diagnostic type for every stage, rendered with ariadne.

use crate::source::{SourceMap, Span};
use ariadne::{CharSet, Config, IndexType, Label as ALabel, Report, ReportKind};
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
/// How bad a diagnostic is: an error stops the scene from rendering, a warning does not.
pub enum Severity {
    /// Suspicious but renderable; the scene still compiles.
    Warning,
    /// The scene cannot be rendered; [`crate::Compilation::into_scene`] fails.
    Error,
}

/// A labelled span. The primary label is the one the report is anchored at.
#[derive(Clone, Debug, PartialEq)]
pub struct Label {
    /// The source range the label underlines.
    pub span: Span,
    /// The text shown next to the underline.
    pub message: String,
}

#[derive(Clone, Debug, PartialEq)]
/// One message from the parser or the checker: a severity, a stable code, the spans it points at,
/// and notes and a hint for fixing it.
pub struct Diagnostic {
    /// Whether it stops the render.
    pub severity: Severity,
    /// Stable code, e.g. `E0201`; `docs/language.md` lists them all.
    pub code: &'static str,
    /// The one-line headline, without the code.
    pub message: String,
    /// The first label is the primary one.
    pub labels: Vec<Label>,
    /// Extra lines shown under the report (`= note: ...`).
    pub notes: Vec<String>,
    /// The suggested fix (`= help: ...`), when there is one.
    pub help: Option<String>,
}

impl Diagnostic {
    /// A new error with `code` and headline `message`, with no labels yet.
    pub fn error(code: &'static str, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Error,
            code,
            message: message.into(),
            labels: vec![],
            notes: vec![],
            help: None,
        }
    }

    /// A new warning with `code` and headline `message`, with no labels yet.
    pub fn warning(code: &'static str, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Warning,
            ..Self::error(code, message)
        }
    }

    /// Add a label under `span`; the first one added is the primary label.
    pub fn label(mut self, span: Span, message: impl Into<String>) -> Self {
        self.labels.push(Label {
            span,
            message: message.into(),
        });
        self
    }

    /// Add a note line.
    pub fn note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }

    /// Set the hint, replacing any earlier one.
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    /// A help line only when there is something to say.
    pub fn maybe_help(self, help: Option<String>) -> Self {
        match help {
            Some(h) => self.help(h),
            None => self,
        }
    }

    /// Whether this diagnostic stops the scene from compiling.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// Where the diagnostic is anchored: its first label's span, if it has one.
    pub fn primary_span(&self) -> Option<Span> {
        self.labels.first().map(|l| l.span)
    }

    /// Render with ariadne. `color` is off for pipes and tests.
    pub fn render(&self, sources: &SourceMap, color: bool) -> String {
        // Nothing from the scene reaches the terminal raw: names, messages and the echoed source
        // show control characters as pictures.
        let name = |span: Span| escape_controls(&sources.get(span.file).name).into_owned();
        let kind = match self.severity {
            Severity::Error => ReportKind::Error,
            Severity::Warning => ReportKind::Warning,
        };
        let mut out = Vec::new();
        // Overlong lines are echoed only up to a little past their labels; spans move with the
        // cut text.
        let clips: Vec<(crate::source::FileId, Clip)> = sources
            .files()
            .map(|(id, f)| {
                let starts: Vec<usize> = (self.labels.iter())
                    .filter(|l| l.span.file == id)
                    .map(|l| l.span.start as usize)
                    .collect();
                (id, Clip::new(&f.text, &starts))
            })
            .collect();
        let clip = |span: Span| {
            let c = &clips[span.file.0 as usize].1;
            c.map(span.start as usize, false)..c.map(span.end as usize, true)
        };
        match self.primary_span() {
            Some(primary) => {
                let config = Config::new()
                    .with_color(color)
                    .with_index_type(IndexType::Byte)
                    .with_char_set(if color {
                        CharSet::Unicode
                    } else {
                        CharSet::Ascii
                    });
                let mut report = Report::build(kind, (name(primary), clip(primary)))
                    .with_config(config)
                    .with_code(self.code)
                    .with_message(escape_controls(&self.message));
                for (i, l) in self.labels.iter().enumerate() {
                    let mut label = ALabel::new((name(l.span), clip(l.span))).with_order(i as i32);
                    if !l.message.is_empty() {
                        label = label.with_message(escape_controls(&l.message));
                    }
                    if color {
                        let c = if i == 0 {
                            ariadne::Color::Red
                        } else {
                            ariadne::Color::Blue
                        };
                        label = label.with_color(c);
                    }
                    report.add_label(label);
                }
                for n in &self.notes {
                    report.add_note(escape_controls(n));
                }
                if let Some(h) = &self.help {
                    report.add_help(escape_controls(h));
                }
                let cache = ariadne::sources(sources.files().map(|(id, f)| {
                    (
                        escape_controls(&f.name).into_owned(),
                        clips[id.0 as usize].1.apply(&f.text),
                    )
                }));
                if report.finish().write(cache, &mut out).is_err() {
                    return self.to_string();
                }
                String::from_utf8_lossy(&out).into_owned()
            }
            None => format!("{self}\n"),
        }
    }
}

impl Diagnostic {
    /// The machine-readable form `--message-format json` prints, one object per line like
    /// cargo's: severity, code, message, where (1-based line and column in characters, the
    /// end too, and the byte span), every label, notes and help.
    pub fn to_json(&self, sources: &SourceMap) -> serde_json::Value {
        let place = |span: Span| {
            let (line, column) = sources.line_col(span.file, span.start as usize);
            let (end_line, end_column) = sources.line_col(span.file, span.end as usize);
            serde_json::json!({
                "file": sources.get(span.file).name,
                "line": line,
                "column": column,
                "end_line": end_line,
                "end_column": end_column,
                "byte_start": span.start,
                "byte_end": span.end,
            })
        };
        let labels: Vec<serde_json::Value> = (self.labels.iter().enumerate())
            .map(|(i, l)| {
                let mut v = place(l.span);
                v["message"] = l.message.clone().into();
                v["primary"] = (i == 0).into();
                v
            })
            .collect();
        let mut v = match self.primary_span() {
            Some(span) => place(span),
            None => serde_json::json!({
                "file": null, "line": null, "column": null, "end_line": null,
                "end_column": null, "byte_start": null, "byte_end": null,
            }),
        };
        v["type"] = "diagnostic".into();
        v["severity"] = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
        .into();
        v["code"] = self.code.into();
        v["message"] = self.message.clone().into();
        v["labels"] = labels.into();
        v["notes"] = self.notes.clone().into();
        v["help"] = self.help.clone().into();
        v
    }
}

/// The plain one-paragraph form, used where there is no source to show (missing files).
impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kind = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        let message = escape_controls(&self.message);
        write!(f, "[{}] {}: {}", self.code, kind, message)?;
        for n in &self.notes {
            write!(f, "\n  note: {}", escape_controls(n))?;
        }
        if let Some(h) = &self.help {
            write!(f, "\n  help: {}", escape_controls(h))?;
        }
        Ok(())
    }
}

/// Longest stretch of a line a report echoes past the last label that starts on it.
const ECHO_PAST_LABEL: usize = 80;
/// Lines up to this long are echoed whole.
const MAX_ECHOED_LINE: usize = 200;

/// How a control character is shown in a report, as rustc does: a C0 character or DEL as its
/// Unicode control picture (`\u{1b}` as `␛`), any other as `\u{..}`. A raw one would reach the
/// terminal: ESC `[31m` recolours it, NUL and DEL garble it, CR overwrites the line. The
/// bidirectional embeddings, overrides and isolates (U+202A to U+202E, U+2066 to U+2069) are
/// shown as `\u{..}` too: raw, they reorder the rest of the line on the terminal, so a report
/// would not show the text as the compiler reads it. Tabs and LF stay.
pub fn control_picture(c: char) -> Option<String> {
    if c == '\t' || c == '\n' || !(c.is_control() || is_bidi_control(c)) {
        return None;
    }
    Some(match c as u32 {
        n @ 0..0x20 => char::from_u32(0x2400 + n).map_or_else(String::new, String::from),
        0x7f => "\u{2421}".to_string(),
        n => format!("\\u{{{n:x}}}"),
    })
}

/// A bidirectional formatting character that changes the order of what follows it on the
/// line: the embeddings and overrides U+202A to U+202E and the isolates U+2066 to U+2069.
pub fn is_bidi_control(c: char) -> bool {
    matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` with every control character but tabs and LF, and every bidirectional control,
/// shown as [`control_picture`] gives it. Everything the command line prints about a file name,
/// an argument or a scene goes through it.
pub fn escape_controls(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(|c| control_picture(c).is_some()) {
        return text.into();
    }
    text.chars()
        .map(|c| control_picture(c).unwrap_or_else(|| c.to_string()))
        .collect::<String>()
        .into()
}

/// `value` as one line of JSON in which nothing reaches a terminal raw: serde_json escapes
/// the C0 controls, and this the rest that [`control_picture`] escapes (DEL, the C1 controls
/// and the bidirectional controls), as `\uXXXX`, which any JSON reader reads back as the
/// same character. Such characters stand only inside strings.
pub fn json_line(value: &serde_json::Value) -> String {
    let text = value.to_string();
    if !text.chars().any(|c| control_picture(c).is_some()) {
        return text;
    }
    text.chars()
        .map(|c| match control_picture(c) {
            Some(_) => format!("\\u{:04x}", c as u32),
            None => c.to_string(),
        })
        .collect()
}

/// How the text of one file is changed for a report: each overlong line is cut a little past
/// its labels (a 300 KB line would otherwise be printed once per diagnostic) and shown as
/// `...`, and each control character is shown as its picture. Spans move with the changed
/// text.
struct Clip {
    /// Byte ranges of the text, in order and apart, and what each is shown as.
    cuts: Vec<(usize, usize, String)>,
}

impl Clip {
    fn new(text: &str, label_starts: &[usize]) -> Clip {
        let mut cuts: Vec<(usize, usize, String)> = vec![];
        let mut start = 0;
        for line in text.split_inclusive(crate::source::LINE_BREAKS) {
            let body = line.trim_end_matches(crate::source::LINE_BREAKS);
            let end = start + body.len();
            let mut cut = end;
            if body.len() > MAX_ECHOED_LINE && !label_starts.is_empty() {
                let last = (label_starts.iter())
                    .filter(|s| (start..=end).contains(*s))
                    .max()
                    .map_or(start, |s| *s);
                let mut keep = (last + ECHO_PAST_LABEL).max(start + MAX_ECHOED_LINE);
                while keep < end && !text.is_char_boundary(keep) {
                    keep += 1;
                }
                if keep + 3 < end {
                    cut = keep;
                }
            }
            for (i, c) in text[start..cut].char_indices() {
                if let Some(picture) = control_picture(c) {
                    cuts.push((start + i, start + i + c.len_utf8(), picture));
                }
            }
            if cut < end {
                cuts.push((cut, end, "...".to_string()));
            }
            start += line.len();
        }
        Clip { cuts }
    }

    /// The text with every cut replaced.
    fn apply(&self, text: &str) -> String {
        let mut out = String::with_capacity(text.len().min(1 << 16));
        let mut at = 0;
        for (a, b, with) in &self.cuts {
            out.push_str(&text[at..*a]);
            out.push_str(with);
            at = *b;
        }
        out.push_str(&text[at..]);
        out
    }

    /// Where byte `p` of the text is in the changed text; inside a cut, a span's start goes to
    /// the start of what replaces it and its end past it.
    fn map(&self, p: usize, is_end: bool) -> usize {
        let mut shift: isize = 0;
        for (a, b, with) in &self.cuts {
            if p >= *b {
                shift += with.len() as isize - (b - a) as isize;
            } else if p > *a {
                let at = (*a as isize + shift) as usize;
                return at + if is_end { with.len() } else { 0 };
            } else {
                break;
            }
        }
        (p as isize + shift) as usize
    }
}

/// Render a list of diagnostics, errors and warnings in source order.
pub fn render_all(diags: &[Diagnostic], sources: &SourceMap, color: bool) -> String {
    diags.iter().map(|d| d.render(sources, color)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_and_bidi_controls_are_escaped() {
        assert_eq!(
            escape_controls("a\u{202e}b\u{2066}c\u{2069}\rd\u{1b}[0m\te\n"),
            "a\\u{202e}b\\u{2066}c\\u{2069}\u{240d}d\u{241b}[0m\te\n"
        );
        // Other right-to-left text is left alone: only the controls reorder a line.
        assert_eq!(escape_controls("שלום ok"), "שלום ok");
        let v = serde_json::json!({ "file": "a\u{202e}\u{7f}\u{9b}\u{1b}.4ds" });
        let line = json_line(&v);
        assert_eq!(line, r#"{"file":"a\u202e\u007f\u009b\u001b.4ds"}"#);
        assert_eq!(serde_json::from_str::<serde_json::Value>(&line).unwrap(), v);
    }
}
