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
    /// The script's bytes are not UTF-8 text (located at the first byte that is not).
    Encoding,
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
    /// The class of error, for telling errors apart without matching on the message.
    pub kind: ErrorKind,
    /// The script's name as given to the loader (a path, or `--vars`).
    pub file: String,
    /// 1-based line of the culprit; 0 for an error about the whole file.
    pub line: usize,
    /// 1-based column (in characters) of the culprit; 0 for an error about the whole file.
    pub col: usize,
    /// The one-line description after `error:` (without the location, excerpt or hints).
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
    /// The offending line, or for a long one the part around the culprit (see [`excerpt`]).
    source_line: String,
    /// Characters of `source_line` before the caret, and the caret's length.
    caret_at: usize,
    caret_len: usize,
}

/// Longest source line an error shows whole, in characters; a longer one (a generated
/// script on one line) shows this many around its culprit.
pub(crate) const MAX_EXCERPT_CHARS: usize = 100;

/// Characters of a cut line shown before the culprit, where there are as many.
const EXCERPT_LEAD: usize = MAX_EXCERPT_CHARS / 3;

/// The excerpt of `line` for a culprit at character `col0` spanning `len` characters:
/// (text, characters before the caret, caret length). A line longer than
/// [`MAX_EXCERPT_CHARS`] is cut to a window of that many characters with the culprit
/// about a third of the way in (or the line's end in view), each cut marked `…`; the caret
/// ends at the window's end.
fn excerpt(line: &str, col0: usize, len: usize) -> (String, usize, usize) {
    let chars = line.chars().count();
    if chars <= MAX_EXCERPT_CHARS {
        return (line.to_string(), col0, len);
    }
    let first = col0.saturating_sub(EXCERPT_LEAD).min(chars - MAX_EXCERPT_CHARS);
    let end = first + MAX_EXCERPT_CHARS;
    let mut text = String::new();
    if first > 0 {
        text.push('…');
    }
    text.extend(line.chars().skip(first).take(MAX_EXCERPT_CHARS));
    if end < chars {
        text.push('…');
    }
    let caret_at = col0 - first + usize::from(first > 0);
    (text, caret_at, len.min(end.saturating_sub(col0)).max(1))
}

/// A byte range in the source being read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    /// Byte offset of the first byte.
    pub start: usize,
    /// Length in bytes (0 for a point, such as the end of the input).
    pub len: usize,
}

impl Span {
    /// The `len` bytes starting at byte offset `start`.
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
    /// Lines end at `\n`, `\r\n` or a lone `\r` (`crate::line_ends`).
    pub fn new(source: &str) -> Self {
        let bytes = source.as_bytes();
        let ends = (0..bytes.len()).filter(|&i| crate::line_ends::ends_line(bytes, i)).map(|i| i + 1);
        Self { starts: std::iter::once(0).chain(ends).collect() }
    }

    /// Byte offset of the start of 1-based `line`.
    fn start_of(&self, line: usize) -> usize {
        self.starts[line - 1]
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
        let lines = LineIndex::new(source);
        let (line, col) = lines.line_col(source, start);
        let line_start = lines.start_of(line);
        let line_end = source[start..].find(crate::line_ends::ends_text).map_or(source.len(), |i| start + i);
        // The caret covers the span's characters on this line (at least one).
        let span_end = floor_char_boundary(source, (start + span.len).min(line_end));
        let caret_len = source[start..span_end.max(start)].chars().count().max(1);
        let (source_line, caret_at, caret_len) = excerpt(&source[line_start..line_end], col - 1, caret_len);
        Self {
            kind,
            file: file.to_string(),
            line,
            col,
            message: message.into(),
            detail: Box::new(Detail { expected: None, note: None, source_line, caret_at, caret_len }),
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
            detail: Box::new(Detail {
                expected: None,
                note: None,
                source_line: String::new(),
                caret_at: 0,
                caret_len: 1,
            }),
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
    /// The offending source line as the error shows it, without its line end: whole, or
    /// for a line longer than 100 characters the 100 around the culprit, with `…` where it
    /// was cut.
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
        let lead: String = self
            .detail
            .source_line
            .chars()
            .take(self.detail.caret_at)
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
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
        assert_eq!(LineIndex::new("é x").line_col("é x", 3), (1, 3));
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
        }
        // Inside a two-byte character: the column of that character; past the end: clamped.
        assert_eq!(idx.line_col(src, 5), (3, 1));
        assert_eq!(idx.line_col(src, 99), (4, 5));
        assert_eq!(LineIndex::new("").line_col("", 0), (1, 1));
    }

    /// `\n`, `\r\n` and a lone `\r` (classic Mac OS) each end a line, for line numbers
    /// and for the excerpt, which never holds a line end.
    #[test]
    fn every_line_end_counts_once() {
        for (src, starts) in [
            ("a\nb\nc", vec![0, 2, 4]),
            ("a\r\nb\r\nc", vec![0, 3, 6]),
            ("a\rb\rc", vec![0, 2, 4]),
            ("a\r\n\rb\n\r\nc\r", vec![0, 3, 4, 6, 8, 10]),
        ] {
            assert_eq!(LineIndex::new(src).starts, starts, "{src:?}");
        }
        for src in ["SET x 1\nSET y ?\nSET z 3", "SET x 1\r\nSET y ?\r\nSET z 3", "SET x 1\rSET y ?\rSET z 3"] {
            let at = src.find('?').unwrap();
            let e = SceneLangError::at(src, "f.sl", Span::new(at, 1), ErrorKind::Syntax, "unexpected `?`");
            assert_eq!((e.line, e.col, e.source_line()), (2, 7, "SET y ?"), "{src:?}");
            assert_eq!(e.to_string(), "f.sl:2:7: error: unexpected `?`\n 2 | SET y ?\n   |       ^", "{src:?}");
        }
        // A span that runs into the line end stops its caret there.
        let e = SceneLangError::at("ab\r\ncd", "f", Span::new(0, 9), ErrorKind::Syntax, "m");
        assert_eq!((e.source_line(), e.detail.caret_len), ("ab", 2));
    }

    /// A long line shows the 100 characters around its culprit, cuts marked `…`, the caret
    /// under the culprit (its length clipped at the window's end); short lines show whole.
    #[test]
    fn long_lines_show_a_window_around_the_culprit() {
        let shown = |src: &str, at: usize, len: usize| {
            let e = SceneLangError::at(src, "f", Span::new(at, len), ErrorKind::Syntax, "m");
            let text = e.to_string();
            let lines: Vec<String> = text.lines().skip(1).map(|l| l[5..].to_string()).collect();
            (lines[0].clone(), lines[1].clone())
        };
        let line: String = (0..1000).map(|i| char::from(b'a' + (i % 26) as u8)).collect();
        // Culprit in the middle: 33 characters before it, cuts at both ends.
        let (text, caret) = shown(&line, 500, 3);
        assert_eq!(text, format!("…{}…", &line[467..567]));
        assert_eq!(caret, format!("{}^^^", " ".repeat(34)));
        assert_eq!(&text[3 + 33..3 + 36], &line[500..503], "the caret's characters");
        // Near the start: no cut there.
        let (text, caret) = shown(&line, 10, 1);
        assert_eq!((text, caret), (format!("{}…", &line[..100]), format!("{}^", " ".repeat(10))));
        // Near the end: the line's end in view, no cut there.
        let (text, caret) = shown(&line, 990, 50);
        assert_eq!((text, caret), (format!("…{}", &line[900..]), format!("{}{}", " ".repeat(91), "^".repeat(10))));
        // A culprit longer than the window: the caret stops at the window's end.
        let (_, caret) = shown(&line, 400, 500);
        assert_eq!(caret, format!("{}{}", " ".repeat(34), "^".repeat(67)));
        // Exactly the limit: whole, no marks.
        let (text, _) = shown(&line[..MAX_EXCERPT_CHARS], 99, 1);
        assert_eq!(text, &line[..MAX_EXCERPT_CHARS]);
        // Characters, not bytes: a window of 100 two-byte characters, tabs kept before the caret.
        let wide = format!("\t{}", "é".repeat(999));
        let e = SceneLangError::at(&wide, "f", Span::new(1 + 2 * 500, 2), ErrorKind::Syntax, "m");
        assert_eq!((e.col, e.source_line().chars().count()), (502, 102));
        assert!(e.to_string().ends_with(&format!(" |  {}^", " ".repeat(33))), "{e}");
        let e = SceneLangError::at(&wide, "f", Span::new(1, 2), ErrorKind::Syntax, "m");
        assert!(e.to_string().ends_with(" | \t^"), "{e}");
    }

    #[test]
    fn suggestions() {
        assert_eq!(did_you_mean("Pigmnet", ["Pigment", "Point"]), Some("Pigment"));
        assert_eq!(did_you_mean("zzz", ["Pigment", "Point"]), None);
        assert_eq!(did_you_mean("X", ["R", "G", "B"]), None);
        assert_eq!(did_you_mean("x", ["X", "Y", "Z"]), Some("X"));
    }
}
