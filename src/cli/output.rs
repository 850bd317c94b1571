//! Standard output for every subcommand: results go through [`print()`], never `println!`,
//! which panics when stdout is a closed pipe (`lumen check … | head -0`) or a full disk
//! (`>/dev/full`). A failed write becomes a [`StdoutError`] that [`super::main`] turns into
//! a quiet exit (broken pipe) or one error line (anything else), both non-zero.

use std::fmt;
use std::io::{self, Write as _};

/// Exit status after a broken pipe: 128 + SIGPIPE, what a shell reports for a program the
/// signal killed, so pipelines read it as "the reader went away".
pub const BROKEN_PIPE_EXIT: u8 = 141;

/// Writing to standard output failed.
#[derive(Debug, thiserror::Error)]
#[error("cannot write to standard output: {0}")]
pub struct StdoutError(pub io::Error);

impl StdoutError {
    /// The reader closed the pipe: not worth a message.
    pub fn is_broken_pipe(&self) -> bool {
        self.0.kind() == io::ErrorKind::BrokenPipe
    }
}

/// Writes `text` to standard output and flushes it, so a failure is reported here rather
/// than lost when the process exits (std ignores errors of its final flush). Control
/// characters in it (a mesh's file name in `lumen check`'s summary) are shown, not
/// obeyed ([`crate::printable::printable`]).
pub fn print(text: impl fmt::Display) -> Result<(), StdoutError> {
    let text = text.to_string();
    let mut out = io::stdout().lock();
    write!(out, "{}", crate::printable::printable(&text)).and_then(|()| out.flush()).map_err(StdoutError)
}

/// Collects lines for one [`print()`]: commands build their whole result, then write it once.
#[derive(Debug, Default)]
pub struct Lines(String);

impl Lines {
    /// Appends `line` and a newline.
    pub fn line(&mut self, line: impl fmt::Display) -> &mut Self {
        use fmt::Write as _;
        // Writing to a String cannot fail.
        let _ = writeln!(self.0, "{line}");
        self
    }

    /// Writes the collected lines to standard output.
    pub fn print(&self) -> Result<(), StdoutError> {
        print(&self.0)
    }
}
