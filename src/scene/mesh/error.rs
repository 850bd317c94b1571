//! Mesh loading errors: every message starts with the file it is about.

use std::fmt;

/// Where in a mesh file a problem is: a line (OBJ text, ASCII PLY) or an element by index
/// (binary PLY, or data that no longer has a line once parsed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeshLocation {
    /// 1-based line number.
    Line(usize),
    /// 0-based index of an element: `vertex 7`, `face 3`, `triangle 12`.
    Element { element: &'static str, index: usize },
}

impl fmt::Display for MeshLocation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshLocation::Line(n) => write!(f, "line {n}"),
            MeshLocation::Element { element, index } => write!(f, "{element} {index}"),
        }
    }
}

/// A mesh file that could not be loaded. `Display` gives `file: what (where)`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {kind}")]
pub struct MeshError {
    /// The path or name the caller gave (messages name it as given).
    pub file: String,
    pub kind: MeshErrorKind,
}

/// What went wrong, without the file name (see [`MeshError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshErrorKind {
    /// The file could not be read (missing, unreadable). The I/O error is kept as its kind
    /// and message so that the error stays `Clone` and comparable, like the scene model.
    #[error("cannot read the file: {message}")]
    Io { kind: std::io::ErrorKind, message: String },
    #[error("unknown mesh format {extension:?}: expected a .obj or .ply file")]
    UnknownExtension { extension: String },
    #[error("{}{message}", at.as_ref().map(|l| format!("{l}: ")).unwrap_or_default())]
    Syntax { at: Option<MeshLocation>, message: String },
    #[error("{at}: {what} index {index} is out of range (the file has {count} {})", plural(what))]
    IndexOutOfRange { at: MeshLocation, what: &'static str, index: i64, count: usize },
    #[error("{at}: coordinate is not finite (NaN or infinity)")]
    NonFinite { at: MeshLocation },
    #[error("no triangles{}", if *dropped > 0 { format!(" ({dropped} degenerate dropped)") } else { String::new() })]
    NoTriangles { dropped: usize },
    #[error("too many {what}: {count} (at most {} are supported)", super::MAX_MESH_ELEMENTS)]
    TooMany { what: &'static str, count: u64 },
}

/// The plural of the element names used in [`MeshErrorKind::IndexOutOfRange`].
fn plural(what: &str) -> String {
    match what {
        "vertex" => "vertices".to_string(),
        w => format!("{w}s"),
    }
}

impl MeshError {
    pub fn new(file: impl Into<String>, kind: MeshErrorKind) -> Self {
        Self { file: file.into(), kind }
    }

    pub(super) fn syntax(file: &str, at: Option<MeshLocation>, message: impl Into<String>) -> Self {
        Self::new(file, MeshErrorKind::Syntax { at, message: message.into() })
    }

    pub(super) fn io(file: &str, e: &std::io::Error) -> Self {
        Self::new(file, MeshErrorKind::Io { kind: e.kind(), message: e.to_string() })
    }
}
