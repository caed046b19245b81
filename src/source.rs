//! Source files and byte spans. Every diagnostic points into a `SourceMap` by `Span`.

use std::path::{Path, PathBuf};

/// Index of a file in the `SourceMap`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct FileId(pub u32);

/// A byte range in one source file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// The file the range is in.
    pub file: FileId,
    /// Byte offset of the first byte.
    pub start: u32,
    /// Byte offset one past the last byte.
    pub end: u32,
}

impl Span {
    /// The range `start..end` of `file`, in bytes (offsets are stored as `u32`).
    pub fn new(file: FileId, start: usize, end: usize) -> Self {
        Span {
            file,
            start: start as u32,
            end: end as u32,
        }
    }

    /// The smallest span covering both (same file assumed; the left file wins otherwise).
    pub fn to(self, other: Span) -> Span {
        if self.file != other.file {
            return self;
        }
        Span {
            file: self.file,
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    /// The byte range, for slicing the file's text.
    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }
}

/// The characters that end a line: the set ariadne counts lines by (a CR LF pair is one break),
/// so the lexer (comments and strings end at each), the reports and `--message-format json`
/// agree on every line number.
pub const LINE_BREAKS: [char; 7] = ['\r', '\n', '\x0B', '\x0C', '\u{85}', '\u{2028}', '\u{2029}'];

/// One loaded file: its display name, its directory for relative imports, and its text.
#[derive(Debug, Clone)]
pub struct SourceFile {
    /// The name diagnostics show: the path as given, or the name of in-memory text.
    pub name: String,
    /// Where the file was read from; `None` for in-memory text (imports then resolve from the
    /// current directory).
    pub path: Option<PathBuf>,
    /// The whole file as loaded.
    pub text: String,
}

/// All files of one compilation: the root file and everything it imports.
#[derive(Debug, Default, Clone)]
pub struct SourceMap {
    files: Vec<SourceFile>,
}

impl SourceMap {
    /// An empty map.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add a file and return its id; ids count up from 0 in the order files are added.
    pub fn add(
        &mut self,
        name: impl Into<String>,
        path: Option<&Path>,
        text: impl Into<String>,
    ) -> FileId {
        self.files.push(SourceFile {
            name: name.into(),
            path: path.map(Path::to_path_buf),
            text: text.into(),
        });
        FileId(self.files.len() as u32 - 1)
    }

    /// The file with id `id`; panics if there is no such file.
    pub fn get(&self, id: FileId) -> &SourceFile {
        &self.files[id.0 as usize]
    }

    /// Every file with its id, in the order they were added (the root file first).
    pub fn files(&self) -> impl Iterator<Item = (FileId, &SourceFile)> {
        self.files
            .iter()
            .enumerate()
            .map(|(i, f)| (FileId(i as u32), f))
    }

    /// The file already loaded from this path, if any (imports load each file once).
    pub fn find_path(&self, path: &Path) -> Option<FileId> {
        self.files()
            .find(|(_, f)| f.path.as_deref() == Some(path))
            .map(|(id, _)| id)
    }

    /// The 1-based line and column (in characters) of a byte offset of `file`.
    pub fn line_col(&self, file: FileId, offset: usize) -> (usize, usize) {
        let text = &self.get(file).text;
        let offset = offset.min(text.len());
        let mut line = 1;
        let mut start = 0;
        let mut chars = text[..offset].char_indices().peekable();
        while let Some((i, c)) = chars.next() {
            if LINE_BREAKS.contains(&c) {
                // CR LF is one break.
                if c == '\r' && chars.peek().is_some_and(|(_, n)| *n == '\n') {
                    continue;
                }
                line += 1;
                start = i + c.len_utf8();
            }
        }
        let col = text.get(start..offset).map_or(0, |s| s.chars().count()) + 1;
        (line, col)
    }

    /// The text under a span.
    pub fn snippet(&self, span: Span) -> &str {
        self.get(span.file).text.get(span.range()).unwrap_or("")
    }
}
