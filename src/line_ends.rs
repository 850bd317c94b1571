//! Where lines end in the text lumen reads (SceneLang scripts, OBJ meshes): at `\n` (also
//! the end of a Windows `\r\n`) and at a lone `\r`, the line end of classic Mac OS files.
//! One rule for every reader, so that the line an error names in a script, and the lines
//! tobj reads in a mesh, are the lines an editor shows.

/// Whether the byte at `i` ends a line: a `\n`, or a `\r` not followed by `\n` (in `\r\n`
/// the `\n` is the end, so the pair counts once).
///
/// ```
/// use lumen::line_ends::ends_line;
/// let text = b"a\r\nb\rc\n";
/// let ends: Vec<usize> = (0..text.len()).filter(|&i| ends_line(text, i)).collect();
/// assert_eq!(ends, [2, 4, 6]);
/// ```
pub fn ends_line(bytes: &[u8], i: usize) -> bool {
    match bytes[i] {
        b'\n' => true,
        b'\r' => bytes.get(i + 1) != Some(&b'\n'),
        _ => false,
    }
}

/// Whether `c` stops a line's text: `\n`, or a `\r` (lone, or the first of `\r\n`). Where a
/// line's *end* is (for counting lines) is [`ends_line`].
///
/// ```
/// use lumen::line_ends::ends_text;
/// assert_eq!("ab\r\ncd".find(ends_text), Some(2));
/// assert_eq!("ab\rcd".find(ends_text), Some(2));
/// ```
pub fn ends_text(c: char) -> bool {
    c == '\n' || c == '\r'
}
