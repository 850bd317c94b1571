//! Wavefront OBJ through `tobj`, behind a line pre-scan.
//!
//! tobj parses; the pre-scan (one pass over the lines, by first word) does what tobj does
//! not: it checks every face index against the vertices, texture coordinates and normals
//! defined above it, so that an out-of-range index is an error naming its line (tobj finds
//! it later, without a line, and an index before the start of the list would overflow its
//! index arithmetic), and it blanks the statements lumen ignores, on a private copy:
//! - `o`, `g`: all objects and groups merge into one triangle set, and without the split
//!   tobj de-duplicates vertices across group seams (one index space, shared vertices);
//! - `usemtl`, `mtllib`: one material per mesh comes from the scene, so no .mtl is read
//!   (a missing one is no error) and material changes do not split the mesh either;
//! - `l`: polylines are not surfaces, but tobj would read one of three or more points as a
//!   polygon.
//!
//! Blanking turns the keyword's first byte into `#`, so line numbers do not move. Syntax
//! errors that tobj reports while reading a line get that line through [`LineCounter`].

use std::borrow::Cow;
use std::io::{BufRead, Read};

use glam::{DVec2, DVec3};

use super::{check_count, MeshError, MeshErrorKind, MeshLocation, MeshParts, TriangleMesh};

pub(super) fn parse(name: &str, bytes: &[u8]) -> Result<TriangleMesh, MeshError> {
    let scan = prescan(name, bytes);
    if let Some((error, line_start)) = scan.error {
        // tobj reports a bad line above the pre-scan's first error first: file order.
        return Err(match run_tobj(name, &scan.text[..line_start]) {
            Err(earlier) => earlier,
            Ok(_) => error,
        });
    }
    let parts = run_tobj(name, &scan.text)?;
    TriangleMesh::from_parts(name, parts).map_err(|e| match e.kind {
        // tobj's vertex order is not the file's: find the line.
        MeshErrorKind::NonFinite { .. } => nonfinite_vertex_line(&scan.text)
            .map(|line| MeshError::new(name, MeshErrorKind::NonFinite { at: MeshLocation::Line(line) }))
            .unwrap_or(e),
        _ => e,
    })
}

/// The text tobj will read, and the first error the pre-scan found with the byte offset of
/// its line.
struct Prescan<'a> {
    text: Cow<'a, [u8]>,
    error: Option<(MeshError, usize)>,
}

const INDEX_KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];

fn prescan<'a>(name: &str, bytes: &'a [u8]) -> Prescan<'a> {
    let mut counts = [0usize; 3];
    let mut blank = Vec::new();
    let mut error = None;
    let mut start = 0;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_start = start;
        start += line.len() + 1;
        // Not UTF-8: tobj rejects the line, with its number.
        let Ok(text) = std::str::from_utf8(line) else { continue };
        let mut words = text.split_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "v" => counts[0] += 1,
            "vt" => counts[1] += 1,
            "vn" => counts[2] += 1,
            "f" => {
                if let Err(kind) = check_face(words, counts, MeshLocation::Line(i + 1)) {
                    error = Some((MeshError::new(name, kind), line_start));
                    break;
                }
            }
            "o" | "g" | "l" | "usemtl" | "mtllib" => blank.push(line_start + text.len() - text.trim_start().len()),
            _ => {}
        }
    }
    let text = if blank.is_empty() {
        Cow::Borrowed(bytes)
    } else {
        let mut owned = bytes.to_vec();
        for at in blank {
            owned[at] = b'#';
        }
        Cow::Owned(owned)
    };
    Prescan { text, error }
}

/// Checks a face's `v`, `v/vt`, `v//vn`, `v/vt/vn` tokens against the counts of vertices,
/// texture coordinates and normals defined so far (1-based; negative counts back from the
/// last one). Tokens tobj cannot parse are left to tobj, which rejects the line.
fn check_face<'a>(
    words: impl Iterator<Item = &'a str>,
    counts: [usize; 3],
    at: MeshLocation,
) -> Result<(), MeshErrorKind> {
    let mut any = false;
    for token in words {
        any = true;
        for (slot, part) in token.split('/').enumerate() {
            if slot >= 3 {
                return Ok(());
            }
            if part.is_empty() {
                if slot == 0 {
                    return Err(MeshErrorKind::Syntax {
                        at: Some(at),
                        message: "face corner without a vertex index".into(),
                    });
                }
                continue;
            }
            // tobj's own integer type, so that the same tokens parse.
            let Ok(x) = part.parse::<isize>() else { return Ok(()) };
            let count = counts[slot];
            if x == 0 || x.unsigned_abs() > count {
                return Err(MeshErrorKind::IndexOutOfRange { at, what: INDEX_KINDS[slot], index: x as i64, count });
            }
        }
    }
    if any {
        Ok(())
    } else {
        Err(MeshErrorKind::Syntax { at: Some(at), message: "face without vertices".into() })
    }
}

/// Runs tobj over `text` and merges its models into one triangle set.
fn run_tobj(name: &str, text: &[u8]) -> Result<MeshParts, MeshError> {
    let options = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let mut reader = LineCounter { data: text, pos: 0, newlines: 0 };
    let loaded = tobj::load_obj_buf(&mut reader, &options, |_| Err(tobj::LoadError::OpenFileFailed));
    let (models, _materials) = loaded.map_err(|e| tobj_error(name, e, reader.line()))?;

    let mut parts = MeshParts::default();
    let (mut normals, mut uvs) = (Vec::new(), Vec::new());
    let (mut all_normals, mut all_uvs) = (true, true);
    for model in models {
        let mesh = model.mesh;
        let base = parts.positions.len();
        let n = mesh.positions.len() / 3;
        check_count(name, "vertices", (base + n) as u64)?;
        check_count(name, "triangles", (parts.triangles.len() + mesh.indices.len() / 3) as u64)?;
        parts.positions.extend(mesh.positions.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
        // single_index gives one normal (uv) per vertex when every face corner has one.
        all_normals &= mesh.normals.len() == 3 * n;
        all_uvs &= mesh.texcoords.len() == 2 * n;
        normals.extend(mesh.normals.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
        uvs.extend(mesh.texcoords.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])));
        let base = base as u32; // ≤ MAX_MESH_ELEMENTS, checked above
        parts.triangles.extend(mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]].map(|k| base + k)));
    }
    // Normals on some corners only: handed on incomplete, so that from_parts drops them and
    // says so.
    parts.normals = (!normals.is_empty()).then(|| if all_normals { normals } else { Vec::new() });
    parts.uvs = (!uvs.is_empty()).then(|| if all_uvs { uvs } else { Vec::new() });
    Ok(parts)
}

/// A tobj error as a lumen one. tobj reports most errors while reading the line at fault
/// (`line`); those it finds when assembling the mesh have no line.
fn tobj_error(name: &str, e: tobj::LoadError, line: usize) -> MeshError {
    use tobj::LoadError as E;
    let (message, has_line) = match e {
        E::ReadError | E::OpenFileFailed => ("not UTF-8 text".to_string(), true),
        E::PositionParseError => ("bad vertex: `v` takes x y z, x y z w or x y z r g b".into(), true),
        E::ScalingByZeroError => ("vertex weight w is 0".into(), true),
        E::ColorParseError => ("bad vertex colour: `v` takes x y z, x y z w or x y z r g b".into(), true),
        E::NormalParseError => ("bad normal: `vn` takes x y z".into(), true),
        E::TexcoordParseError => ("bad texture coordinate: `vt` takes u v".into(), true),
        E::FaceParseError => ("bad face: `f` takes indices v, v/vt, v//vn or v/vt/vn".into(), true),
        E::FaceColorOutOfBounds => ("vertex colours are given for some vertices only".into(), false),
        other => (other.to_string(), false),
    };
    MeshError::syntax(name, has_line.then_some(MeshLocation::Line(line)), message)
}

/// The first `v` line whose position (divided by its weight, as tobj does) is not finite.
fn nonfinite_vertex_line(text: &[u8]) -> Option<usize> {
    text.split(|&b| b == b'\n').enumerate().find_map(|(i, line)| {
        let mut words = std::str::from_utf8(line).ok()?.split_whitespace();
        if words.next()? != "v" {
            return None;
        }
        let rest: Vec<f64> = words.map_while(|w| w.parse().ok()).collect();
        let p = DVec3::new(*rest.first()?, *rest.get(1)?, *rest.get(2)?);
        let p = if rest.len() == 4 { p / rest[3] } else { p };
        (!p.is_finite()).then_some(i + 1)
    })
}

/// An in-memory `BufRead` that counts the lines consumed, so that the line tobj was reading
/// when it failed is known (it reads with `lines()`, one `read_line` per line).
struct LineCounter<'a> {
    data: &'a [u8],
    pos: usize,
    newlines: usize,
}

impl LineCounter<'_> {
    /// 1-based number of the line read last.
    fn line(&self) -> usize {
        let partial = self.pos > 0 && self.data[self.pos - 1] != b'\n';
        self.newlines + usize::from(partial)
    }
}

impl Read for LineCounter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = buf.len().min(self.data.len() - self.pos);
        buf[..n].copy_from_slice(&self.data[self.pos..self.pos + n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for LineCounter<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.data[self.pos..])
    }
    fn consume(&mut self, amt: usize) {
        let end = (self.pos + amt).min(self.data.len());
        self.newlines += self.data[self.pos..end].iter().filter(|&&b| b == b'\n').count();
        self.pos = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj(text: &str) -> Result<TriangleMesh, MeshError> {
        TriangleMesh::from_obj_bytes("model.obj", text.as_bytes())
    }

    #[test]
    fn quad_becomes_two_triangles() {
        let m = obj("# a unit quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        assert_eq!(m.vertex_count(), 4);
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.positions()[2], DVec3::new(1.0, 1.0, 0.0));
        assert!(m.normals().is_none() && m.uvs().is_none());
        assert_eq!(m.dropped_degenerate(), 0);
        assert_eq!(m.bounds().min, DVec3::ZERO);
        assert_eq!(m.bounds().max, DVec3::new(1.0, 1.0, 0.0));
    }

    /// A leading byte-order mark is skipped: the first vertex stays (it was dropped, and
    /// the face's last index was out of range).
    #[test]
    fn a_leading_byte_order_mark_is_skipped() {
        let m = obj("\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_eq!(m.vertex_count(), 3);
        assert_eq!(m.positions()[0], DVec3::ZERO);
    }

    /// Every line end reads the same mesh: `\n`, `\r\n`, and classic Mac OS's lone `\r`
    /// (tobj splits at `\n` only, and read such a file as one vertex statement).
    #[test]
    fn every_line_end_reads_the_same_mesh() {
        let text = "# tri\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
        let want = obj(text).unwrap();
        for end in ["\r\n", "\r"] {
            let m = obj(&text.replace('\n', end)).unwrap();
            assert_eq!((m.positions(), m.triangles()), (want.positions(), want.triangles()), "{end:?}");
            assert_eq!(m.normals(), want.normals(), "{end:?}");
        }
    }

    #[test]
    fn pentagon_is_fanned_into_three_triangles() {
        let m = obj("v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5").unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn normals_and_uvs_with_their_own_indices() {
        // Position, uv and normal indices differ per corner: single_index makes one vertex
        // per distinct (v, vt, vn) triple; relative (negative) indices count back.
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\n\
             vt 0.5 0.5\nvt 0 0\nvt 1 0\nvt 0 1\n\
             vn 0 0 2\nvn 0 1 0\n\
             f 1/2/1 2/3/1 3/4/1\n\
             f 1/1/2 3/-1/2 -2/-2/-1\n")
        .unwrap();
        assert_eq!(m.triangle_count(), 2);
        // Corner (1, 1, 2) is a different vertex from (1, 2, 1): 6 vertices.
        assert_eq!(m.vertex_count(), 6);
        let (p, n, uv) = (m.positions(), m.normals().unwrap(), m.uvs().unwrap());
        let corners = |t: usize| m.triangles()[t].map(|k| (p[k as usize], n[k as usize], uv[k as usize]));
        let z = DVec3::Z; // (0, 0, 2) normalised
        assert_eq!(
            corners(0),
            [
                (DVec3::ZERO, z, DVec2::new(0.0, 0.0)),
                (DVec3::X, z, DVec2::new(1.0, 0.0)),
                (DVec3::Y, z, DVec2::new(0.0, 1.0))
            ]
        );
        assert_eq!(
            corners(1),
            [
                (DVec3::ZERO, DVec3::Y, DVec2::new(0.5, 0.5)),
                (DVec3::Y, DVec3::Y, DVec2::new(0.0, 1.0)),
                (DVec3::X, DVec3::Y, DVec2::new(1.0, 0.0))
            ]
        );
    }

    #[test]
    fn objects_groups_and_materials_merge_into_one_mesh() {
        // Two objects sharing vertex 2 and 3, a material library that does not exist, a
        // polyline (ignored) and smoothing groups.
        let m = obj("mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
             o first\nusemtl red\ns 1\nf 1 2 3\n\
             g second\nusemtl blue\nf 2 4 3\nl 1 2 3 4\n")
        .unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2], [1, 3, 2]]);
        assert_eq!(m.vertex_count(), 4);
    }

    #[test]
    fn partial_normals_make_the_mesh_flat() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 2 4 3\n").unwrap();
        assert!(m.normals().is_none() && m.dropped_normals());
        let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n").unwrap();
        assert!(m.normals().is_none() && m.dropped_normals());
    }

    #[test]
    fn degenerate_triangles_are_dropped_and_counted() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\nf 1 2 4\n").unwrap();
        assert_eq!((m.triangle_count(), m.dropped_degenerate()), (1, 2));
        let e = obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 2 2 2\n").unwrap_err();
        assert_eq!(e.to_string(), "model.obj: no triangles (2 degenerate dropped)");
    }

    #[test]
    fn index_out_of_range_names_file_and_line() {
        let e = obj("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n").unwrap_err();
        assert_eq!(e.to_string(), "model.obj: line 3: vertex index 3 is out of range (the file has 2 vertices)");
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n").unwrap_err();
        assert_eq!(
            e.kind,
            MeshErrorKind::IndexOutOfRange { at: MeshLocation::Line(4), what: "vertex", index: -4, count: 3 }
        );
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "model.obj: line 5: texture coordinate index 2 is out of range (the file has 1 texture coordinate)"
        );
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n").unwrap_err();
        assert_eq!(
            e.kind,
            MeshErrorKind::IndexOutOfRange { at: MeshLocation::Line(4), what: "normal", index: 1, count: 0 }
        );
        // 0 is never an OBJ index, and the message says where they start; huge ones do not
        // overflow anything.
        let e = obj("v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert!(matches!(e.kind, MeshErrorKind::IndexOutOfRange { index: 0, .. }));
        assert_eq!(
            e.to_string(),
            "model.obj: line 2: vertex index 0 is out of range (the file has 1 vertex); OBJ indices start at 1"
        );
        let e = obj("v 0 0 0\nvt 0 0\nf 1/-9223372036854775808 1/1 1/1\n").unwrap_err();
        assert!(matches!(e.kind, MeshErrorKind::IndexOutOfRange { .. }), "{e}");
        let e = obj("v 0 0 0\nvt 0 0\nf 1/9223372036854775807 1/1 1/1\n").unwrap_err();
        assert!(matches!(e.kind, MeshErrorKind::IndexOutOfRange { .. }), "{e}");
    }

    #[test]
    fn syntax_errors_name_file_and_line() {
        let e = obj("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n").unwrap_err();
        assert!(matches!(e.kind, MeshErrorKind::Syntax { at: Some(MeshLocation::Line(2)), .. }), "{e:?}");
        assert!(e.to_string().starts_with("model.obj: line 2: bad vertex"), "{e}");
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x").unwrap_err();
        assert!(e.to_string().starts_with("model.obj: line 4: bad face"), "{e}");
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0\n").unwrap_err();
        assert!(e.to_string().starts_with("model.obj: line 4: bad normal"), "{e}");
        assert_eq!(obj("v 0 0 0\nf\n").unwrap_err().to_string(), "model.obj: line 2: face without vertices");
        // A syntax error above an index error is reported first.
        let e = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 1\nf 1 2 9\n").unwrap_err();
        assert!(e.to_string().starts_with("model.obj: line 4: bad texture coordinate"), "{e}");
        let e = obj("v 0 0 0\nv 1 0 0 0\nv 0 1 0\nf 1 2 3\n").unwrap_err();
        assert_eq!(e.to_string(), "model.obj: line 2: vertex weight w is 0");
        let e = obj("v 0 0 0\nf /1 1 1\n").unwrap_err();
        assert_eq!(e.to_string(), "model.obj: line 2: face corner without a vertex index");
        let e = TriangleMesh::from_obj_bytes("model.obj", b"v 0 0 0\n\xff\xfe\nf 1 1 1\n").unwrap_err();
        assert_eq!(e.to_string(), "model.obj: line 2: not UTF-8 text");
    }

    #[test]
    fn nan_and_infinite_coordinates_name_their_line() {
        for (text, line) in [
            ("v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n", 3),
            ("v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n", 2),
            ("v 0 0 0\nv 1 0 0\nv 0 1e999 0\nf 1 2 3\n", 3),
            // The weight divides: 1/1e-320 overflows.
            ("v 1 0 0 1e-320\nv 0 0 0\nv 0 1 0\nf 1 2 3\n", 1),
        ] {
            let e = obj(text).unwrap_err();
            assert_eq!(e.kind, MeshErrorKind::NonFinite { at: MeshLocation::Line(line) }, "{text}");
            assert_eq!(e.to_string(), format!("model.obj: line {line}: coordinate is not finite (NaN or infinity)"));
        }
    }

    #[test]
    fn no_faces_is_zero_triangles() {
        assert_eq!(obj("v 0 0 0\nv 1 0 0\n").unwrap_err().to_string(), "model.obj: no triangles");
        assert_eq!(obj("").unwrap_err().to_string(), "model.obj: no triangles");
        // Points and two-vertex faces are not triangles.
        assert_eq!(obj("v 0 0 0\nv 1 0 0\nf 1 2\np 1\n").unwrap_err().to_string(), "model.obj: no triangles");
    }

    #[test]
    fn line_counter_counts_the_line_being_read() {
        let mut r = LineCounter { data: b"a\nbb\r\nc", pos: 0, newlines: 0 };
        let mut lines = Vec::new();
        let mut s = String::new();
        while r.read_line(&mut s).unwrap() > 0 {
            lines.push(r.line());
            s.clear();
        }
        assert_eq!(lines, [1, 2, 3]);
    }
}
