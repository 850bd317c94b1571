//! Text made safe to show on a terminal: what lumen prints quotes its input (a script's
//! lines, file names and words, mesh statements), and input may be hostile.
//!
//! A control character written to a terminal is obeyed, not shown: `ESC [ 2 J` in a
//! script's comment clears the screen when the line is quoted in an error, other sequences
//! retitle the window, move the cursor over earlier output or (in some terminals) answer
//! back, and a lone carriage return makes the rest of the line overwrite its start. So every
//! diagnostic ([`crate::diag!`]) and everything a command prints ([`crate::cli::output`])
//! shows them instead, one visible character for each, as compilers do (rustc prints
//! the Unicode "Control Pictures" block for them): C0 controls other than tab and newline
//! become `␀`…`␟`, DEL `␡`; C1 controls (U+0080–U+009F, which some terminals read as
//! escape sequences) and the bidirectional overrides and isolates (which reorder what a
//! reader sees: "Trojan Source", CVE-2021-42574) become `�`. Each stays one character, so
//! a caret under a quoted line stays under its culprit.
//!
//! Diagnostics also shorten very long lines ([`for_terminal`]): a script of one 2-MB line,
//! or a 300,000-character word, made an error of several megabytes. SceneLang excerpts
//! cut their own lines around the culprit first (`scenelang::error`), so the cut here only
//! meets messages that quote long input.

use std::borrow::Cow;

/// Longest line a diagnostic prints whole, in characters. Longer ones keep their first and
/// last 200 characters, enough for any message lumen writes about its input.
pub const MAX_LINE_CHARS: usize = 500;

/// Characters kept at each end of a shortened line.
const KEEP: usize = 200;

/// The visible stand-in for `c`, or `None` where `c` prints as itself.
fn stand_in(c: char) -> Option<char> {
    match c {
        '\t' | '\n' => None,
        // U+2400 CONTROL PICTURE FOR NULL and the 31 after it, in code order.
        '\0'..='\x1f' => char::from_u32(0x2400 + c as u32),
        '\x7f' => Some('\u{2421}'),
        '\u{80}'..='\u{9f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' => Some('\u{fffd}'),
        _ => None,
    }
}

/// `text` with each control character shown rather than obeyed (see the module
/// documentation); borrowed when it has none.
///
/// ```
/// use lumen::printable::printable;
/// assert_eq!(printable("SET x 1\t# ok\n"), "SET x 1\t# ok\n");
/// assert_eq!(printable("a\x1b[2Jb\r"), "a\u{241b}[2Jb\u{240d}");
/// assert_eq!(printable("\u{202e}cba"), "\u{fffd}cba");
/// ```
pub fn printable(text: &str) -> Cow<'_, str> {
    if !text.chars().any(|c| stand_in(c).is_some()) {
        return Cow::Borrowed(text);
    }
    Cow::Owned(text.chars().map(|c| stand_in(c).unwrap_or(c)).collect())
}

/// `text`'s first `most` non-empty lines, trimmed and joined by `separator`: a message of
/// several lines (a decoder's, which may end in a newline; a script error with its
/// excerpt) kept to the one line that an error message or a table cell needs.
///
/// ```
/// use lumen::printable::one_line;
/// assert_eq!(one_line("bad header\r\n\n  at byte 4 \n", "; ", usize::MAX), "bad header; at byte 4");
/// assert_eq!(one_line("a\nb\nc", " ", 2), "a b");
/// ```
pub fn one_line(text: &str, separator: &str, most: usize) -> String {
    text.lines().map(str::trim).filter(|l| !l.is_empty()).take(most).collect::<Vec<_>>().join(separator)
}

/// `text` with every line longer than [`MAX_LINE_CHARS`] characters cut in the middle,
/// saying how much was left out; borrowed when no line is that long.
///
/// ```
/// use lumen::printable::shortened_lines;
/// let long = format!("unknown command `{}`", "O".repeat(5000));
/// let short = shortened_lines(&long);
/// assert!(short.starts_with("unknown command `OOO") && short.ends_with("OOO`"));
/// assert!(short.contains("[4,618 characters left out]"));
/// assert_eq!(shortened_lines("short\nlines"), "short\nlines");
/// ```
pub fn shortened_lines(text: &str) -> Cow<'_, str> {
    // Counting characters is only needed where the bytes could be too many.
    if text.split('\n').all(|line| line.len() <= MAX_LINE_CHARS) {
        return Cow::Borrowed(text);
    }
    let lines: Vec<Cow<str>> = text
        .split('\n')
        .map(|line| {
            let chars = line.chars().count();
            if chars <= MAX_LINE_CHARS {
                return Cow::Borrowed(line);
            }
            let head: String = line.chars().take(KEEP).collect();
            let tail: String = line.chars().skip(chars - KEEP).collect();
            Cow::Owned(format!("{head} … [{} characters left out] … {tail}", group_thousands(chars - 2 * KEEP)))
        })
        .collect();
    Cow::Owned(lines.join("\n"))
}

/// `n` with commas between groups of three digits.
fn group_thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, d) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(d);
    }
    out
}

/// A diagnostic as it reaches the terminal: [`printable`], with long lines
/// [`shortened_lines`].
///
/// ```
/// let said = lumen::printable::for_terminal("bad name `\x07\x07`");
/// assert_eq!(said, "bad name `\u{2407}\u{2407}`");
/// ```
pub fn for_terminal(text: &str) -> Cow<'_, str> {
    match shortened_lines(text) {
        Cow::Borrowed(t) => printable(t),
        Cow::Owned(t) => Cow::Owned(printable(&t).into_owned()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every C0 control but tab and newline, DEL, every C1 control and the bidirectional
    /// controls print as one visible character each, none of them a control; everything
    /// else, multi-byte letters included, passes unchanged.
    #[test]
    fn every_control_character_is_shown_as_one_visible_character() {
        for c in (0u32..0x3000).filter_map(char::from_u32) {
            let shown = printable(&c.to_string()).into_owned();
            let mut it = shown.chars();
            let (one, none) = (it.next().unwrap(), it.next());
            assert_eq!(none, None, "{c:?} became {shown:?}");
            let control = c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}');
            if control && c != '\t' && c != '\n' {
                assert!(!one.is_control() && one != c, "{c:?} became {one:?}");
            } else {
                assert_eq!(one, c);
            }
        }
        assert_eq!(printable("\x00\x1b\x1f\x7f"), "\u{2400}\u{241b}\u{241f}\u{2421}");
        assert!(matches!(printable("plain é ✓ text\twith\nlines"), Cow::Borrowed(_)));
    }

    /// A long line keeps its ends and says how many characters went, counted in
    /// characters (not bytes); lines around it and short texts are untouched.
    #[test]
    fn long_lines_keep_their_ends() {
        let line = format!("{}{}", "é".repeat(700), "x".repeat(700));
        let text = format!("first\n{line}\nlast");
        let short = shortened_lines(&text).into_owned();
        let lines: Vec<&str> = short.split('\n').collect();
        assert_eq!((lines[0], lines[2]), ("first", "last"));
        let expected = format!("{} … [1,000 characters left out] … {}", "é".repeat(200), "x".repeat(200));
        assert_eq!(lines[1], expected);
        let just_fits = "y".repeat(MAX_LINE_CHARS);
        assert!(matches!(shortened_lines(&just_fits), Cow::Borrowed(_)));
        // 500 characters in 1,000 bytes: not shortened.
        let wide = "é".repeat(MAX_LINE_CHARS);
        assert_eq!(shortened_lines(&wide), wide);
        assert_eq!(group_thousands(1_234_567), "1,234,567");
        assert_eq!(group_thousands(999), "999");
    }
}
