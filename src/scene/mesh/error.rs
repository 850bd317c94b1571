//! Mesh loading errors: every message starts with the file it is about.

use std::fmt;

/// Where in a mesh file a problem is: a line (OBJ text, ASCII PLY) or an element by index
/// (binary PLY, or data that no longer has a line once parsed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeshLocation {
    /// 1-based line number.
    Line(usize),
    /// 0-based index of an element: `vertex 7`, `face 3`, `triangle 12`.
    Element {
        /// The element's kind as messages spell it: `vertex`, `face` or `triangle`.
        element: &'static str,
        /// Its 0-based position among the elements of that kind.
        index: usize,
    },
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
    /// What went wrong, and where in the file when that is known.
    pub kind: MeshErrorKind,
}

/// What went wrong, without the file name (see [`MeshError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshErrorKind {
    /// The file could not be read (missing, unreadable). The I/O error is kept as its kind
    /// and message so that the error stays `Clone` and comparable, like the scene model.
    #[error("cannot read the file: {message}")]
    Io {
        /// The I/O error's kind (`NotFound`, `PermissionDenied`, ...), for callers to match.
        kind: std::io::ErrorKind,
        /// The I/O error's message, as its `Display` gives it.
        message: String,
    },
    /// The path's extension is neither `obj` nor `ply` in any case; found before any read.
    #[error("unknown mesh format {extension:?}: expected a .obj or .ply file")]
    UnknownExtension {
        /// The extension as given, without the dot; empty when the path has none.
        extension: String,
    },
    /// The file is malformed: rejected by the parser (`tobj`, `ply-rs-bw`) or by lumen's own
    /// checks (an OBJ face without vertices, say).
    #[error("{}{message}", at.as_ref().map(|l| format!("{l}: ")).unwrap_or_default())]
    Syntax {
        /// The line, when known (OBJ or ASCII PLY text); `None` otherwise, as in binary PLY.
        at: Option<MeshLocation>,
        /// What is wrong, in words for the user.
        message: String,
    },
    /// A face refers to a vertex (or, in OBJ, a texture coordinate or normal) that does not
    /// exist.
    #[error("{at}: {what} index {index} is out of range (the file has {count} {}){}", noun(what, *count), counts_from_1(*index, *count))]
    IndexOutOfRange {
        /// The face: its OBJ line, PLY face index, or triangle index.
        at: MeshLocation,
        /// What the index refers to: `vertex`, `texture coordinate` or `normal`.
        what: &'static str,
        /// The index as written: 1-based or negative (counting back from the last) in OBJ,
        /// 0-based in PLY (which may write a negative one) and in [`MeshParts`](super::MeshParts).
        index: i64,
        /// How many of `what` there are (in OBJ, defined above the face's line).
        count: usize,
    },
    /// A vertex position has a NaN or infinite coordinate.
    #[error("{at}: coordinate is not finite (NaN or infinity)")]
    NonFinite {
        /// The vertex: its OBJ line, else its index.
        at: MeshLocation,
    },
    /// No triangle is left: the file has none, or every one was degenerate.
    #[error("no triangles{}", if *dropped > 0 { format!(" ({dropped} degenerate dropped)") } else { String::new() })]
    NoTriangles {
        /// How many degenerate triangles (and PLY faces of fewer than 3 vertices) were dropped.
        dropped: usize,
    },
    /// More than [`MAX_MESH_ELEMENTS`](super::MAX_MESH_ELEMENTS) vertices, triangles or
    /// PLY faces.
    #[error("too many {what}: {count} (at most {} are supported)", super::MAX_MESH_ELEMENTS)]
    TooMany {
        /// What there are too many of: `vertices`, `triangles` or `faces`.
        what: &'static str,
        /// The count past the limit: a PLY header's declared count, or the number reached
        /// while reading.
        count: u64,
    },
}

/// The element names used in [`MeshErrorKind::IndexOutOfRange`], for `count` of them.
fn noun(what: &str, count: usize) -> String {
    match (what, count) {
        (w, 1) => w.to_string(),
        ("vertex", _) => "vertices".to_string(),
        (w, _) => format!("{w}s"),
    }
}

/// Index 0 of a file that has elements is out of range only in OBJ, which counts from 1.
fn counts_from_1(index: i64, count: usize) -> &'static str {
    if index == 0 && count > 0 {
        "; OBJ indices start at 1"
    } else {
        ""
    }
}

impl MeshError {
    /// An error about `file`, which messages name exactly as given.
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
