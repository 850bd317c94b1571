//! SceneLang tokens, read lazily so that the first error in file order is the one reported.

use super::error::{did_you_mean, ErrorKind, LineIndex, SceneLangError, Span};
use super::value::Ty;

/// What a malformed number should have looked like (errors' `expected` line).
const NUMBER_EXAMPLES: &str = "a number such as `1`, `1.0`, `1.`, `1e2` or `-0.5`";

/// What a number written out of f64's range should have been (lexer and math expressions).
pub(super) const FINITE_NUMBER: &str = "a finite number (magnitude below about 1.8e308)";

/// The fixed list of commands (all-uppercase words).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    Set,
    Unset,
    Spawn,
    Using,
    Dump,
    Time,
    Load,
    Scale,
    Translate,
    Rotate,
    Unite,
    Intersect,
    Diff,
    Fuse,
}

impl Command {
    pub const ALL: [(&'static str, Command); 14] = [
        ("SET", Command::Set),
        ("UNSET", Command::Unset),
        ("SPAWN", Command::Spawn),
        ("USING", Command::Using),
        ("DUMP", Command::Dump),
        ("TIME", Command::Time),
        ("LOAD", Command::Load),
        ("SCALE", Command::Scale),
        ("TRANSLATE", Command::Translate),
        ("ROTATE", Command::Rotate),
        ("UNITE", Command::Unite),
        ("INTERSECT", Command::Intersect),
        ("DIFF", Command::Diff),
        ("FUSE", Command::Fuse),
    ];
    pub fn name(self) -> &'static str {
        Self::ALL.iter().find(|(_, c)| *c == self).map_or("?", |(n, _)| n)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    Command(Command),
    /// A type word: one of [`Ty::WORDS`].
    Type(Ty),
    /// A word right after a dot (the dot is part of the token's span).
    Keyword(String),
    Ident(String),
    Number(f64),
    Str(String),
    /// The text between `$` signs; `content_start` is its byte offset in the source.
    Math {
        text: String,
        content_start: usize,
    },
    /// One of `( ) < > { } [ ] , *`.
    Sym(char),
    Eof,
}

impl Tok {
    /// How the token reads in messages.
    pub fn describe(&self) -> String {
        match self {
            Tok::Command(c) => format!("command `{}`", c.name()),
            Tok::Type(t) => format!("type `{}`", t.name()),
            Tok::Keyword(k) => format!("keyword `.{k}`"),
            Tok::Ident(i) => format!("identifier `{i}`"),
            Tok::Number(n) => format!("number `{n}`"),
            Tok::Str(s) => format!("string {s:?}"),
            Tok::Math { text, .. } => format!("math expression `${text}$`"),
            Tok::Sym(c) => format!("`{c}`"),
            Tok::Eof => "end of file".to_string(),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    pub tok: Tok,
    pub span: Span,
}

/// A lazy tokenizer with one token of lookahead.
pub struct Lexer<'a> {
    pub source: &'a str,
    pub file: &'a str,
    pos: usize,
    peeked: Option<Token>,
    /// End of the last token taken with [`Lexer::next`] (for "missing after" spans).
    pub last_end: usize,
    /// Built once, so that naming the line of any token costs a binary search.
    lines: LineIndex,
}

fn is_word_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

impl<'a> Lexer<'a> {
    pub fn new(source: &'a str, file: &'a str) -> Self {
        Self { source, file, pos: 0, peeked: None, last_end: 0, lines: LineIndex::new(source) }
    }

    pub fn error(&self, span: Span, kind: ErrorKind, msg: impl Into<String>) -> SceneLangError {
        SceneLangError::at(self.source, self.file, span, kind, msg)
    }

    /// 1-based (line, column) of byte `offset` of the source.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        self.lines.line_col(self.source, offset)
    }

    pub fn peek(&mut self) -> Result<&Token, SceneLangError> {
        if self.peeked.is_none() {
            let t = self.lex()?;
            self.peeked = Some(t);
        }
        Ok(self.peeked.as_ref().expect("just filled"))
    }

    pub fn next(&mut self) -> Result<Token, SceneLangError> {
        let t = match self.peeked.take() {
            Some(t) => t,
            None => self.lex()?,
        };
        self.last_end = t.span.start + t.span.len;
        Ok(t)
    }

    fn rest(&self) -> &'a str {
        &self.source[self.pos..]
    }

    fn skip_blank(&mut self) {
        loop {
            let r = self.rest();
            let trimmed = r.trim_start();
            self.pos += r.len() - trimmed.len();
            if trimmed.starts_with('#') {
                // A comment ends with its line, whichever line end the file uses (`\n`,
                // `\r\n`, or classic Mac OS's lone `\r`, which the whitespace skip eats).
                self.pos += trimmed.find(crate::line_ends::ends_text).unwrap_or(trimmed.len());
            } else {
                return;
            }
        }
    }

    fn lex(&mut self) -> Result<Token, SceneLangError> {
        self.skip_blank();
        let start = self.pos;
        let Some(c) = self.rest().chars().next() else {
            return Ok(Token { tok: Tok::Eof, span: Span::new(start, 0) });
        };
        let tok = match c {
            '(' | ')' | '<' | '>' | '{' | '}' | '[' | ']' | ',' | '*' => {
                self.pos += 1;
                Tok::Sym(c)
            }
            '"' => self.string(start)?,
            '$' => self.math(start)?,
            '.' => {
                let word: String = self.source[start + 1..].chars().take_while(|c| is_word_char(*c)).collect();
                if word.is_empty() {
                    return Err(self
                        .error(Span::new(start, 1), ErrorKind::Syntax, "a dot must be followed by a keyword")
                        .with_expected("a keyword such as `.color`"));
                }
                if word.starts_with(|c: char| c.is_ascii_digit()) {
                    return Err(self
                        .error(
                            Span::new(start, 1 + word.len()),
                            ErrorKind::BadNumber,
                            format!("`.{word}` is not a number"),
                        )
                        .with_expected(format!("`0.{word}` (a number may not start with a dot)")));
                }
                self.pos += 1 + word.len();
                Tok::Keyword(word)
            }
            '0'..='9' | '+' | '-' => self.number(start)?,
            c if c.is_ascii_alphabetic() || c == '_' => self.word(start)?,
            other => {
                return Err(self
                    .error(Span::new(start, other.len_utf8()), ErrorKind::Syntax, format!("unexpected character `{other}`"))
                    .with_expected("a command, type, keyword, identifier, number, string, `$expression$` or one of ( ) < > { } [ ] , *"));
            }
        };
        Ok(Token { tok, span: Span::new(start, self.pos - start) })
    }

    fn string(&mut self, start: usize) -> Result<Tok, SceneLangError> {
        let mut out = String::new();
        let mut chars = self.source[start + 1..].char_indices();
        while let Some((i, c)) = chars.next() {
            match c {
                '"' => {
                    self.pos = start + 1 + i + 1;
                    return Ok(Tok::Str(out));
                }
                '\\' => {
                    let Some((j, e)) = chars.next() else { break };
                    out.push(match e {
                        'n' => '\n',
                        't' => '\t',
                        'r' => '\r',
                        '0' => '\0',
                        '\\' | '"' | '$' | '\'' => e,
                        other => {
                            let at = start + 1 + j - 1;
                            return Err(self
                                .error(
                                    Span::new(at, 1 + other.len_utf8()),
                                    ErrorKind::Syntax,
                                    format!("unknown escape `\\{other}` in string"),
                                )
                                .with_expected("one of \\n \\t \\r \\0 \\\\ \\\" \\$ \\'"));
                        }
                    });
                }
                c => out.push(c),
            }
        }
        Err(self
            .error(Span::new(start, 1), ErrorKind::UnterminatedString, "unterminated string")
            .with_expected("a closing `\"` before the end of the file"))
    }

    fn math(&mut self, start: usize) -> Result<Tok, SceneLangError> {
        match self.source[start + 1..].find('$') {
            Some(i) => {
                self.pos = start + 1 + i + 1;
                Ok(Tok::Math { text: self.source[start + 1..start + 1 + i].to_string(), content_start: start + 1 })
            }
            None => Err(self
                .error(Span::new(start, 1), ErrorKind::UnterminatedExpression, "unterminated math expression")
                .with_expected("a closing `$` before the end of the file")),
        }
    }

    /// `[+-]? (digits ('.' digits?)? | '.' digits) ([eE] [+-]? digits)?`; the `.digits` form
    /// needs a sign (a bare `.1` is a keyword, as in Raytracer.jl).
    fn number(&mut self, start: usize) -> Result<Tok, SceneLangError> {
        let b = self.source.as_bytes();
        let mut i = start;
        let signed = b[i] == b'+' || b[i] == b'-';
        if signed {
            i += 1;
        }
        let digits = |mut i: usize| {
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            i
        };
        let int_end = digits(i);
        let mut end = int_end;
        let mut mantissa_digits = int_end > i;
        if end < b.len()
            && b[end] == b'.'
            && (mantissa_digits || (signed && end + 1 < b.len() && b[end + 1].is_ascii_digit()))
        {
            let frac_end = digits(end + 1);
            mantissa_digits |= frac_end > end + 1;
            end = frac_end;
        }
        if !mantissa_digits {
            let sign = &self.source[start..start + 1];
            return Err(self
                .error(Span::new(start, 1), ErrorKind::Syntax, format!("unexpected `{sign}`"))
                .with_expected(format!("a number right after the sign, such as `{sign}1` or `{sign}0.5`")));
        }
        if end < b.len() && (b[end] == b'e' || b[end] == b'E') {
            let mut j = end + 1;
            if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
                j += 1;
            }
            let exp_end = digits(j);
            if exp_end == j {
                return Err(self.bad_number(
                    start,
                    self.word_end(end),
                    "digits after the exponent, as in `1e2` or `1E-2`",
                ));
            }
            end = exp_end;
        }
        // A number glued to letters or another dot (`12abc`, `1.2.3`) is one bad token.
        if end < b.len() && (is_word_char(b[end] as char) || b[end] == b'.') {
            return Err(self.bad_number(start, self.word_end(end), NUMBER_EXAMPLES));
        }
        let text = &self.source[start..end];
        let v: f64 = text.parse().map_err(|_| self.bad_number(start, end, NUMBER_EXAMPLES))?;
        if !v.is_finite() {
            return Err(self
                .error(Span::new(start, end - start), ErrorKind::BadNumber, format!("number `{text}` is out of range"))
                .with_expected(FINITE_NUMBER));
        }
        self.pos = end;
        Ok(Tok::Number(v))
    }

    /// The error for the malformed number in `source[start..end]`, with what was expected.
    fn bad_number(&self, start: usize, end: usize, expected: &str) -> SceneLangError {
        self.error(
            Span::new(start, end - start),
            ErrorKind::BadNumber,
            format!("bad number `{}`", &self.source[start..end]),
        )
        .with_expected(expected)
    }

    fn word_end(&self, from: usize) -> usize {
        from + self.source[from..]
            .chars()
            .take_while(|c| is_word_char(*c) || *c == '.')
            .map(char::len_utf8)
            .sum::<usize>()
    }

    fn word(&mut self, start: usize) -> Result<Tok, SceneLangError> {
        let len = self.source[start..].chars().take_while(|c| is_word_char(*c)).count();
        let w = &self.source[start..start + len];
        let span = Span::new(start, len);
        let first = w.chars().next().expect("non-empty word");
        let tok = if first.is_ascii_lowercase() || first == '_' {
            Tok::Ident(w.to_string())
        } else if !w.chars().any(|c| c.is_ascii_lowercase()) {
            match Command::ALL.iter().find(|(n, _)| *n == w) {
                Some((_, c)) => Tok::Command(*c),
                None => {
                    let mut e =
                        self.error(span, ErrorKind::UnknownCommand, format!("unknown command `{w}`")).with_expected(
                            format!("one of {}", Command::ALL.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(" ")),
                        );
                    if let Some(s) = did_you_mean(w, Command::ALL.iter().map(|(n, _)| *n)) {
                        e = e.with_note(format!("did you mean `{s}`?"));
                    }
                    return Err(e);
                }
            }
        } else {
            match Ty::from_word(w) {
                Some(t) => Tok::Type(t),
                None => {
                    let mut e = self
                        .error(span, ErrorKind::UnknownType, format!("unknown type `{w}`"))
                        .with_expected(format!("one of {}", Ty::WORDS.map(Ty::name).join(" ")));
                    if let Some(s) = did_you_mean(w, Ty::WORDS.map(Ty::name)) {
                        e = e.with_note(format!("did you mean `{s}`?"));
                    }
                    return Err(e);
                }
            }
        };
        self.pos = start + len;
        Ok(tok)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toks(s: &str) -> Result<Vec<Tok>, SceneLangError> {
        let mut l = Lexer::new(s, "t");
        let mut v = Vec::new();
        loop {
            let t = l.next()?;
            if t.tok == Tok::Eof {
                return Ok(v);
            }
            v.push(t.tok);
        }
    }

    #[test]
    fn numbers_and_keywords() {
        assert_eq!(
            toks("1 1.0 1. 1e2 1E-2 -3 +.5 -.1").unwrap(),
            vec![
                Tok::Number(1.0),
                Tok::Number(1.0),
                Tok::Number(1.0),
                Tok::Number(100.0),
                Tok::Number(0.01),
                Tok::Number(-3.0),
                Tok::Number(0.5),
                Tok::Number(-0.1),
            ]
        );
        assert_eq!(toks(".1").unwrap_err().kind, ErrorKind::BadNumber);
        assert_eq!(toks("1e+").unwrap_err().kind, ErrorKind::BadNumber);
        assert_eq!(toks("12abc").unwrap_err().kind, ErrorKind::BadNumber);
        assert_eq!(toks("1e999").unwrap_err().kind, ErrorKind::BadNumber);
    }

    #[test]
    fn words_strings_math_comments() {
        assert_eq!(
            toks("SET x_1 Pigment.Uniform # c\n\"a\\\"b\" $1 + 2$").unwrap(),
            vec![
                Tok::Command(Command::Set),
                Tok::Ident("x_1".into()),
                Tok::Type(Ty::Pigment),
                Tok::Keyword("Uniform".into()),
                Tok::Str("a\"b".into()),
                Tok::Math { text: "1 + 2".into(), content_start: 36 },
            ]
        );
        let words = Ty::WORDS.map(Ty::name).join(" ");
        assert_eq!(toks(&words).unwrap(), Ty::WORDS.map(Tok::Type).to_vec());
        let e = toks("Strin").unwrap_err();
        assert_eq!(e.kind, ErrorKind::UnknownType);
        assert!(e.expected().unwrap().starts_with("one of Color Point List Transformation"), "{e}");
        assert_eq!(toks("DROP").unwrap_err().kind, ErrorKind::UnknownCommand);
        assert_eq!(toks("PIgment").unwrap_err().kind, ErrorKind::UnknownType);
        assert_eq!(toks("\"abc").unwrap_err().kind, ErrorKind::UnterminatedString);
        assert_eq!(toks("$1 + 2").unwrap_err().kind, ErrorKind::UnterminatedExpression);
        assert_eq!(toks("@").unwrap_err().kind, ErrorKind::Syntax);
    }

    /// A comment ends with its line whatever the line end: with classic Mac OS's lone `\r`
    /// it ran to the end of the file and took every instruction after it along.
    #[test]
    fn comments_end_at_every_line_end() {
        for end in ["\n", "\r\n", "\r"] {
            let src = format!("# first{end}SET x 1 # second{end}UNSET x{end}");
            let expect = vec![
                Tok::Command(Command::Set),
                Tok::Ident("x".into()),
                Tok::Number(1.0),
                Tok::Command(Command::Unset),
                Tok::Ident("x".into()),
            ];
            assert_eq!(toks(&src).unwrap(), expect, "{end:?}");
        }
    }
}
