//! Diagnostics: every SceneLang error names `file:line:col`, shows the offending line with a
//! caret under the culprit and says what was expected.

use std::fmt;

/// What went wrong, so that callers and tests can tell errors apart without parsing text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// A token that cannot appear here (a missing `)`, a stray symbol, …).
    Syntax,
    /// An all-uppercase word that is not a command.
    UnknownCommand,
    /// A capitalised word that is not a type.
    UnknownType,
    /// A keyword that the constructor (or DUMP, ROTATE, …) does not take.
    UnknownKeyword,
    /// A value of the wrong type for the place it appears in.
    WrongType,
    /// A value of the right type but outside its allowed range (a negative count, …).
    BadValue,
    /// Too many positional arguments, a keyword repeating a positional one, …
    BadArguments,
    /// An identifier used but never `SET` (or already `UNSET`).
    UndefinedName,
    /// `SET` of a name that is still defined.
    RedefinedName,
    /// A `USING` setting that the script never gives.
    MissingSetting,
    /// A `USING` setting given twice.
    RepeatedSetting,
    /// A malformed or out-of-range number literal.
    BadNumber,
    /// A string without its closing quote.
    UnterminatedString,
    /// A `$` math expression without its closing `$`.
    UnterminatedExpression,
    /// A malformed math expression, an unknown function or a wrong argument count.
    BadExpression,
    /// A math expression (or one of its parts) that is infinite or NaN.
    NonFinite,
    /// An image file that is missing or cannot be decoded.
    ImageFile,
    /// A mesh file (`Shape.Mesh`) that is missing, malformed or unusable.
    MeshFile,
    /// An image size that is zero, fractional or larger than [`crate::scene::MAX_IMAGE_SIDE`].
    BadImageSize,
    /// The scene model refused the value (singular transformation, …).
    InvalidScene,
    /// Nesting deeper than the interpreter allows (protects the stack), or a CSG tree
    /// deeper than [`crate::scene::MAX_CSG_DEPTH`].
    TooDeep,
    /// A shape that would expand beyond lumen's limits: more primitives than
    /// [`crate::scene::MAX_PRIMITIVES`].
    TooLarge,
    /// The script file could not be read, or DUMP could not write.
    Io,
}

/// A located SceneLang error. `Display` renders the full diagnostic:
///
/// ```text
/// scene.sl:3:23: error: unknown keyword `.colr` for Pigment.Uniform
///     3 | SET p Pigment.Uniform(.colr <1, 0, 0>)
///       |                       ^^^^^
///   expected: one of .color
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SceneLangError {
    pub kind: ErrorKind,
    /// The script's name as given to the loader (a path, or `--vars`).
    pub file: String,
    /// 1-based line of the culprit; 0 for an error about the whole file.
    pub line: usize,
    /// 1-based column (in characters) of the culprit; 0 for an error about the whole file.
    pub col: usize,
    pub message: String,
    /// Boxed to keep `Result<_, SceneLangError>` small.
    detail: Box<Detail>,
}

#[derive(Debug, Clone, PartialEq)]
struct Detail {
    /// What would have been accepted there.
    expected: Option<String>,
    /// Extra context, such as where a name was first defined.
    note: Option<String>,
    source_line: String,
    caret_len: usize,
}

/// A byte range in the source being read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    pub start: usize,
    pub len: usize,
}

impl Span {
    pub fn new(start: usize, len: usize) -> Self {
        Self { start, len }
    }
    /// The span from the start of `self` to the end of `other`.
    pub fn to(self, other: Span) -> Span {
        let end = (other.start + other.len).max(self.start + self.len);
        Span { start: self.start, len: end - self.start }
    }
}

/// Where each line of a source starts, so that a byte offset becomes (line, column) by a
/// binary search plus a scan of one line: loading records the origin of every `SET`, and
/// rescanning the source from its start each time made loading quadratic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineIndex {
    /// Byte offset of the start of each line; `starts[0] == 0`.
    starts: Vec<usize>,
}

impl LineIndex {
    pub fn new(source: &str) -> Self {
        let starts = std::iter::once(0).chain(source.match_indices('\n').map(|(i, _)| i + 1)).collect();
        Self { starts }
    }

    /// 1-based (line, column) of byte `offset` in `source` (the text this index was built
    /// from), columns counted in characters.
    pub fn line_col(&self, source: &str, offset: usize) -> (usize, usize) {
        let offset = floor_char_boundary(source, offset.min(source.len()));
        // The last line start at or before `offset`.
        let line = self.starts.partition_point(|&s| s <= offset);
        let line_start = self.starts[line - 1];
        (line, source[line_start..offset].chars().count() + 1)
    }
}

/// 1-based (line, column) of byte `offset` in `source`, for a single lookup (it reads the
/// whole source; keep a [`LineIndex`] for many).
pub fn line_col(source: &str, offset: usize) -> (usize, usize) {
    LineIndex::new(source).line_col(source, offset)
}

fn floor_char_boundary(s: &str, mut i: usize) -> usize {
    while i > 0 && !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

impl SceneLangError {
    /// Builds an error located at `span` of `source` (the text of `file`).
    pub fn at(source: &str, file: &str, span: Span, kind: ErrorKind, message: impl Into<String>) -> Self {
        let start = floor_char_boundary(source, span.start.min(source.len()));
        let (line, col) = line_col(source, start);
        let line_start = source[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = source[start..].find('\n').map_or(source.len(), |i| start + i);
        let source_line = source[line_start..line_end].trim_end_matches('\r').to_string();
        // The caret covers the span's characters on this line (at least one).
        let span_end = floor_char_boundary(source, (start + span.len).min(line_end));
        let caret_len = source[start..span_end.max(start)].chars().count().max(1);
        Self {
            kind,
            file: file.to_string(),
            line,
            col,
            message: message.into(),
            detail: Box::new(Detail { expected: None, note: None, source_line, caret_len }),
        }
    }

    /// An error about the file as a whole (e.g. it cannot be read).
    pub fn whole_file(file: &str, kind: ErrorKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            file: file.to_string(),
            line: 0,
            col: 0,
            message: message.into(),
            detail: Box::new(Detail { expected: None, note: None, source_line: String::new(), caret_len: 1 }),
        }
    }

    /// Adds what would have been accepted.
    pub fn with_expected(mut self, e: impl Into<String>) -> Self {
        self.detail.expected = Some(e.into());
        self
    }
    /// Adds context (where a name was defined, a suggestion).
    pub fn with_note(mut self, n: impl Into<String>) -> Self {
        self.detail.note = Some(n.into());
        self
    }
    /// What would have been accepted at the error's location.
    pub fn expected(&self) -> Option<&str> {
        self.detail.expected.as_deref()
    }
    /// Extra context, such as where a name was first defined or a "did you mean".
    pub fn note(&self) -> Option<&str> {
        self.detail.note.as_deref()
    }
    /// The offending source line, without its newline.
    pub fn source_line(&self) -> &str {
        &self.detail.source_line
    }
}

impl fmt::Display for SceneLangError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            // About the whole file: no position, no excerpt.
            write!(f, "{}: error: {}", self.file, self.message)?;
            for (label, text) in [("expected", &self.detail.expected), ("note", &self.detail.note)] {
                if let Some(t) = text {
                    write!(f, "\n   = {label}: {t}")?;
                }
            }
            return Ok(());
        }
        writeln!(f, "{}:{}:{}: error: {}", self.file, self.line, self.col, self.message)?;
        let num = self.line.to_string();
        let pad = " ".repeat(num.len());
        // Tabs keep their width in the caret line so the caret stays under the culprit.
        let lead: String =
            self.detail.source_line.chars().take(self.col - 1).map(|c| if c == '\t' { '\t' } else { ' ' }).collect();
        writeln!(f, " {num} | {}", self.detail.source_line)?;
        write!(f, " {pad} | {lead}{}", "^".repeat(self.detail.caret_len))?;
        if let Some(e) = &self.detail.expected {
            write!(f, "\n {pad} = expected: {e}")?;
        }
        if let Some(n) = &self.detail.note {
            write!(f, "\n {pad} = note: {n}")?;
        }
        Ok(())
    }
}

impl std::error::Error for SceneLangError {}

/// Levenshtein distance, for "did you mean" hints.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The candidate closest to `word` if it is plausibly a typo of it.
pub fn did_you_mean<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let lw = word.to_lowercase();
    candidates
        .into_iter()
        .map(|c| (edit_distance(&lw, &c.to_lowercase()), c))
        // Short names only match up to case (`.x` → `.X`, but not `.X` → `.R`).
        .filter(|(d, c)| if c.len() < 3 { *d == 0 } else { *d <= (c.len() / 3).max(1) })
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_location_line_caret_and_expectation() {
        let src = "SET a 1\nSET b <1, 2>\n";
        let e =
            SceneLangError::at(src, "x.sl", Span::new(19, 1), ErrorKind::Syntax, "unexpected `>`").with_expected("`,`");
        assert_eq!((e.line, e.col), (2, 12));
        assert_eq!(
            e.to_string(),
            "x.sl:2:12: error: unexpected `>`\n 2 | SET b <1, 2>\n   |            ^\n   = expected: `,`"
        );
    }

    /// An error about the whole file (it cannot be read) names the file alone: no line,
    /// column or excerpt, which would point at an empty first line.
    #[test]
    fn whole_file_errors_have_no_position() {
        let e = SceneLangError::whole_file("s.sl", ErrorKind::Io, "cannot read script: gone");
        assert_eq!(e.to_string(), "s.sl: error: cannot read script: gone");
        assert_eq!((e.line, e.col), (0, 0));
        let e = e.with_expected("a readable file");
        assert_eq!(e.to_string(), "s.sl: error: cannot read script: gone\n   = expected: a readable file");
    }

    #[test]
    fn columns_count_characters_and_offsets_past_the_end_are_clamped() {
        assert_eq!(line_col("é x", 3), (1, 3));
        let e = SceneLangError::at("abc", "f", Span::new(99, 4), ErrorKind::Syntax, "m");
        assert_eq!((e.line, e.col), (1, 4));
    }

    #[test]
    fn the_line_index_finds_lines_by_search() {
        let src = "ab\n\nçd\nlast";
        let idx = LineIndex::new(src);
        assert_eq!(idx.starts, vec![0, 3, 4, 8]);
        let expect = [(0, (1, 1)), (2, (1, 3)), (3, (2, 1)), (4, (3, 1)), (6, (3, 2)), (7, (3, 3)), (8, (4, 1))];
        for (offset, lc) in expect {
            assert_eq!(idx.line_col(src, offset), lc, "offset {offset}");
            assert_eq!(line_col(src, offset), lc, "offset {offset}");
        }
        // Inside a two-byte character: the column of that character; past the end: clamped.
        assert_eq!(idx.line_col(src, 5), (3, 1));
        assert_eq!(idx.line_col(src, 99), (4, 5));
        assert_eq!(LineIndex::new("").line_col("", 0), (1, 1));
    }

    #[test]
    fn suggestions() {
        assert_eq!(did_you_mean("Pigmnet", ["Pigment", "Point"]), Some("Pigment"));
        assert_eq!(did_you_mean("zzz", ["Pigment", "Point"]), None);
        assert_eq!(did_you_mean("X", ["R", "G", "B"]), None);
        assert_eq!(did_you_mean("x", ["X", "Y", "Z"]), Some("X"));
    }
}
