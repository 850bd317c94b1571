//! PLY through `ply-rs-bw`: ASCII, binary little-endian and binary big-endian.
//!
//! The header is read first and decides which properties lumen takes: the `vertex`
//! element's x, y, z (any scalar type), nx, ny, nz if all three are there, and the first
//! complete uv pair of (u, v), (s, t), (texture_u, texture_v), (texture_s, texture_t); the
//! `face` element's `vertex_indices` (or `vertex_index`), a list of any integer type.
//! Their definitions are then handed to the payload reader renamed to fixed slot names, so
//! that the per-element setters below match a handful of constant strings and nothing a file
//! declares beside them (a stray `v` when the uvs are s, t) can land in a slot. Elements are
//! read in the header's order (the payload's layout), other elements skipped, and reading
//! stops once vertices and faces are in.

use std::io::Cursor;

use glam::{DVec2, DVec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, KeyMap, Property, PropertyAccess, PropertyAccessResult, PropertyDef,
    PropertyType, ScalarType,
};

use super::{check_count, MeshError, MeshErrorKind, MeshLocation, MeshParts, TriangleMesh};

const UV_NAMES: [(&str, &str); 4] = [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")];

/// Slot names the renamed vertex properties get (index = slot in [`PlyVertex::values`]).
const VERTEX_SLOTS: [&str; 8] = ["x", "y", "z", "nx", "ny", "nz", "u", "v"];
/// Slot name of the face index list.
const FACE_INDICES: &str = "indices";

pub(super) fn parse(name: &str, bytes: &[u8]) -> Result<TriangleMesh, MeshError> {
    let mut reader = Reader::new(Cursor::new(bytes));
    let size = bytes.len();
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| parse_error(name, e, true, size))?;
    let layout = Layout::from_header(name, &header)?;

    let mut vertices: Option<Vec<PlyVertex>> = None;
    let mut faces: Option<Vec<PlyFace>> = None;
    let ascii = header.encoding == Encoding::Ascii;
    for (key, def) in &header.elements {
        if vertices.is_some() && faces.is_some() {
            break;
        }
        let context = |e| parse_error(name, e, ascii, size).in_element(key);
        if *key == layout.vertex.name {
            vertices =
                Some(Parser::new().read_payload_for_element(&mut reader, &layout.vertex, &header).map_err(context)?);
        } else if *key == layout.face.name {
            faces = Some(Parser::new().read_payload_for_element(&mut reader, &layout.face, &header).map_err(context)?);
        } else if ascii || !def.properties.is_empty() {
            // A binary element without properties occupies no bytes: nothing to skip (and
            // reading a huge declared count of nothing would only spin).
            Parser::<Skip>::new().read_payload_for_element(&mut reader, def, &header).map_err(context)?;
        }
    }
    let (vertices, faces) = (vertices.unwrap_or_default(), faces.unwrap_or_default());

    let n = vertices.len();
    let mut parts = MeshParts {
        positions: vertices.iter().map(|v| DVec3::new(v.values[0], v.values[1], v.values[2])).collect(),
        normals: layout
            .normals
            .then(|| vertices.iter().map(|v| DVec3::new(v.values[3], v.values[4], v.values[5])).collect()),
        uvs: layout.uvs.then(|| vertices.iter().map(|v| DVec2::new(v.values[6], v.values[7])).collect()),
        ..MeshParts::default()
    };
    drop(vertices);
    for (j, face) in faces.iter().enumerate() {
        let at = || MeshLocation::Element { element: "face", index: j };
        if let Some(&bad) = face.signed.iter().find(|&&i| i < 0 || i as usize >= n) {
            let kind = MeshErrorKind::IndexOutOfRange { at: at(), what: "vertex", index: bad.into(), count: n };
            return Err(MeshError::new(name, kind));
        }
        if let Some(&bad) = face.unsigned.iter().find(|&&i| i as usize >= n) {
            let kind = MeshErrorKind::IndexOutOfRange { at: at(), what: "vertex", index: bad.into(), count: n };
            return Err(MeshError::new(name, kind));
        }
        // In range, so below 2³¹ (the vertex count was checked against the header).
        let corners: Vec<u32> = face.unsigned.iter().copied().chain(face.signed.iter().map(|&i| i as u32)).collect();
        if corners.len() < 3 {
            parts.dropped_faces += 1;
            continue;
        }
        check_count(name, "triangles", (parts.triangles.len() + corners.len() - 2) as u64)?;
        parts.triangles.extend(corners.windows(2).skip(1).map(|w| [corners[0], w[0], w[1]]));
    }
    TriangleMesh::from_parts(name, parts)
}

/// The header's vertex and face elements, renamed for the readers (see the module doc).
struct Layout {
    vertex: ElementDef,
    face: ElementDef,
    normals: bool,
    uvs: bool,
}

impl Layout {
    fn from_header(name: &str, header: &Header) -> Result<Self, MeshError> {
        let bad = |message: String| MeshError::syntax(name, None, message);
        let vertex = header.elements.get("vertex").ok_or_else(|| bad("no `vertex` element".into()))?;
        let scalar =
            |p: &str| matches!(vertex.properties.get(p), Some(PropertyDef { data_type: PropertyType::Scalar(_), .. }));
        for axis in ["x", "y", "z"] {
            if !scalar(axis) {
                return Err(bad(format!("element `vertex` has no scalar property `{axis}`")));
            }
        }
        let normals = ["nx", "ny", "nz"].iter().all(|p| scalar(p));
        let uv = UV_NAMES.iter().find(|(u, v)| scalar(u) && scalar(v)).copied();
        let mut sources: Vec<&str> = vec!["x", "y", "z"];
        if normals {
            sources.extend(["nx", "ny", "nz"]);
        }
        if let Some((u, v)) = uv {
            sources.extend([u, v]);
        }
        let slot = |p: &str| {
            let i = sources.iter().position(|s| *s == p)?;
            Some(if i < 3 || normals { VERTEX_SLOTS[i] } else { VERTEX_SLOTS[i + 3] })
        };
        let vertex = renamed(vertex, slot);

        let Some(face) = header.elements.get("face") else {
            // A point cloud.
            return Err(MeshError::new(name, MeshErrorKind::NoTriangles { dropped: 0 }));
        };
        let list = ["vertex_indices", "vertex_index"].into_iter().find(|p| face.properties.contains_key(*p));
        let Some(list) = list else {
            return Err(bad("element `face` has no `vertex_indices` (or `vertex_index`) property".into()));
        };
        match &face.properties[list].data_type {
            PropertyType::List(_, t) if !matches!(t, ScalarType::Float | ScalarType::Double) => {}
            other => {
                return Err(bad(format!("face property `{list}` must be a list of integers, not {}", ply_type(other))))
            }
        }
        let face = renamed(face, |p| (p == list).then_some(FACE_INDICES));

        check_count(name, "vertices", vertex.count as u64)?;
        check_count(name, "faces", face.count as u64)?;
        Ok(Self { vertex, face, normals, uvs: uv.is_some() })
    }
}

/// `def` with each property renamed by `slot`, or to a name no setter takes; the order (the
/// payload's layout) is kept.
fn renamed<'a>(def: &ElementDef, slot: impl Fn(&str) -> Option<&'a str>) -> ElementDef {
    let mut properties = KeyMap::new();
    for (i, (key, p)) in def.properties.iter().enumerate() {
        let key = slot(key).map_or_else(|| format!("#{i}"), str::to_string);
        properties.insert(key.clone(), PropertyDef::new(key, p.data_type.clone()));
    }
    ElementDef { name: def.name.clone(), count: def.count, properties }
}

/// One vertex: position, normal and uv slots (unset ones stay 0 and are not used).
struct PlyVertex {
    values: [f64; 8],
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self { values: [0.0; 8] }
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some(slot) = VERTEX_SLOTS.iter().position(|s| *s == name) else {
            return PropertyAccessResult::Ignored;
        };
        let value = match property {
            Property::Char(v) => v.into(),
            Property::UChar(v) => v.into(),
            Property::Short(v) => v.into(),
            Property::UShort(v) => v.into(),
            Property::Int(v) => v.into(),
            Property::UInt(v) => v.into(),
            Property::Float(v) => v.into(),
            Property::Double(v) => v,
            // The header check admits scalars only into slots.
            _ => return PropertyAccessResult::UnsupportedType,
        };
        self.values[slot] = value;
        PropertyAccessResult::Set
    }
}

/// One face's vertex indices, as read: unsigned list types in `unsigned`, signed ones in
/// `signed` (negative values are reported as out of range), filled in place by the parser
/// for the common `int` and `uint` lists.
#[derive(Default)]
struct PlyFace {
    unsigned: Vec<u32>,
    signed: Vec<i32>,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != FACE_INDICES {
            return PropertyAccessResult::Ignored;
        }
        match property {
            Property::ListUChar(v) => self.unsigned = v.into_iter().map(u32::from).collect(),
            Property::ListUShort(v) => self.unsigned = v.into_iter().map(u32::from).collect(),
            Property::ListUInt(v) => self.unsigned = v,
            Property::ListChar(v) => self.signed = v.into_iter().map(i32::from).collect(),
            Property::ListShort(v) => self.signed = v.into_iter().map(i32::from).collect(),
            Property::ListInt(v) => self.signed = v,
            _ => return PropertyAccessResult::UnsupportedType,
        }
        PropertyAccessResult::Set
    }
    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        if name == FACE_INDICES {
            BeginList::Fill(&mut self.signed)
        } else {
            BeginList::UseSetter
        }
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if name == FACE_INDICES {
            BeginList::Fill(&mut self.unsigned)
        } else {
            BeginList::UseSetter
        }
    }
}

/// An element lumen does not use: read (to get past it) and dropped. Zero-sized, so even a
/// long element costs no memory.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Longest parser message kept: ply-rs quotes the offending line, which may be long.
const MAX_MESSAGE: usize = 240;

/// A ply-rs error as a lumen one, on one line. ply-rs counts "lines" in binary payloads too
/// (one per element, after the header's), which names nothing a reader can find, so the
/// line is kept only for text (the header, ASCII payloads). A payload cut short says how
/// many of the declared elements it holds and the file's size, where ply-rs stacks its
/// readers' messages ("... Error: failed to fill whole buffer").
fn parse_error(name: &str, e: ply_rs_bw::parser::ParseError, text: bool, size: usize) -> MeshError {
    let at = if text { e.line().map(MeshLocation::Line) } else { None };
    if let Some((expected, got)) = early_end(&e) {
        let message = format!("the file ({size} bytes) ends after {got} of the {expected} the header declares");
        return MeshError::syntax(name, at, message);
    }
    let full = e.to_string();
    let message = match e.line() {
        Some(n) => full.strip_prefix(&format!("Line {n}: ")).unwrap_or(&full),
        None => &full,
    };
    let message: String = message.split(['\n', '\r', '\t']).filter(|s| !s.is_empty()).collect::<Vec<_>>().join(" ");
    // The parser's messages read "What failed. String: '<the text>' Error: <its own parser's
    // state, debug-printed>": keep what failed and the text it failed on.
    let mut message = match message.split_once(" String: '") {
        Some((what, rest)) => {
            let text = rest.split_once("' Error:").map_or(rest, |(text, _)| text);
            format!("{}: \"{}\"", what.trim_end_matches('.'), text.trim())
        }
        None => message,
    };
    if message.len() > MAX_MESSAGE {
        let mut cut = MAX_MESSAGE;
        while !message.is_char_boundary(cut) {
            cut -= 1;
        }
        message.truncate(cut);
        message.push('…');
    }
    MeshError::syntax(name, at, message)
}

/// The declared and the complete elements of a payload that ended early (ply-rs writes
/// "Unexpected end of file while reading [binary ]element 'face' (expected 4, got 1)").
fn early_end(e: &ply_rs_bw::parser::ParseError) -> Option<(u64, u64)> {
    if e.kind() != std::io::ErrorKind::UnexpectedEof {
        return None;
    }
    let text = e.to_string();
    let counts = text.split_once("' (expected ")?.1;
    let (expected, rest) = counts.split_once(", got ")?;
    let got = rest.split(')').next()?;
    Some((expected.parse().ok()?, got.parse().ok()?))
}

impl MeshError {
    /// Prefixes a syntax message with the element being read.
    fn in_element(mut self, element: &str) -> Self {
        if let MeshErrorKind::Syntax { message, .. } = &mut self.kind {
            *message = format!("in element `{element}`: {message}");
        }
        self
    }
}

/// A PLY property type as a PLY header writes it (`uchar`, `list of float`), for messages.
fn ply_type(t: &PropertyType) -> String {
    let scalar = |s: &ScalarType| match s {
        ScalarType::Char => "char",
        ScalarType::UChar => "uchar",
        ScalarType::Short => "short",
        ScalarType::UShort => "ushort",
        ScalarType::Int => "int",
        ScalarType::UInt => "uint",
        ScalarType::Float => "float",
        ScalarType::Double => "double",
    };
    match t {
        PropertyType::Scalar(s) => format!("a single {}", scalar(s)),
        PropertyType::List(_, s) => format!("a list of {}", scalar(s)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ply(bytes: &[u8]) -> Result<TriangleMesh, MeshError> {
        TriangleMesh::from_ply_bytes("model.ply", bytes)
    }

    fn header(format: &str, vertex_props: &str, nv: usize, face_prop: &str, nf: usize) -> Vec<u8> {
        format!(
            "ply\nformat {format} 1.0\ncomment made by hand\nelement vertex {nv}\n{vertex_props}\
             element face {nf}\nproperty {face_prop}\nend_header\n"
        )
        .into_bytes()
    }

    const XYZ_FLOAT: &str = "property float x\nproperty float y\nproperty float z\n";

    /// A leading byte-order mark before the header is skipped (the magic word was refused).
    #[test]
    fn a_leading_byte_order_mark_is_skipped() {
        let mut b = b"\xef\xbb\xbf".to_vec();
        b.extend(header("ascii", XYZ_FLOAT, 3, "list uchar int vertex_indices", 1));
        b.extend_from_slice(b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert_eq!(ply(&b).unwrap().triangles(), &[[0, 1, 2]]);
    }

    #[test]
    fn ascii_with_normals_uvs_and_a_pentagon() {
        let mut b = header(
            "ascii",
            "property double x\nproperty double y\nproperty double z\nproperty float nx\nproperty float ny\n\
             property float nz\nproperty uchar red\nproperty float s\nproperty float t\n",
            5,
            "list uchar int vertex_indices",
            1,
        );
        b.extend_from_slice(
            b"0 0 0 0 0 1 255 0 0\n2 0 0 0 0 2 255 1 0\n3 1 0 0 0 1 255 1 0.5\n1 2 0 0 0 1 255 0.5 1\n\
              -1 1 0 0 0 1 255 0 0.5\n5 0 1 2 3 4\n",
        );
        let m = ply(&b).unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert_eq!(m.positions()[4], DVec3::new(-1.0, 1.0, 0.0));
        assert_eq!(m.normals().unwrap()[1], DVec3::Z);
        assert_eq!(m.uvs().unwrap()[2], DVec2::new(1.0, 0.5));
        assert_eq!(m.bounds().min, DVec3::new(-1.0, 0.0, 0.0));
        assert_eq!(m.bounds().max, DVec3::new(3.0, 2.0, 0.0));
    }

    #[test]
    fn uv_pair_names_and_partial_normals() {
        for (u, v) in UV_NAMES {
            let props = format!("{XYZ_FLOAT}property float nx\nproperty double {u}\nproperty double {v}\n");
            let mut b = header("ascii", &props, 3, "list uchar uint vertex_index", 1);
            b.extend_from_slice(b"0 0 0 9 0.1 0.2\n1 0 0 9 0.3 0.4\n0 1 0 9 0.5 0.6\n3 0 1 2\n");
            let m = ply(&b).unwrap();
            // nx alone is not a normal; the uv pair is found under each name.
            assert!(m.normals().is_none() && !m.dropped_normals());
            assert_eq!(m.uvs().unwrap(), &[DVec2::new(0.1, 0.2), DVec2::new(0.3, 0.4), DVec2::new(0.5, 0.6)], "{u}");
        }
        // A stray `v` beside s, t does not end up in the uvs.
        let props = format!("{XYZ_FLOAT}property float v\nproperty double s\nproperty double t\n");
        let mut b = header("ascii", &props, 3, "list uchar uint vertex_indices", 1);
        b.extend_from_slice(b"0 0 0 7 0.1 0.2\n1 0 0 7 0.3 0.4\n0 1 0 7 0.5 0.6\n3 0 1 2\n");
        assert_eq!(ply(&b).unwrap().uvs().unwrap()[0], DVec2::new(0.1, 0.2));
    }

    /// A unit quad (two triangles, one face as a quad and one as a triangle) in a binary
    /// encoding; `f64` picks double or float coordinates.
    fn binary_quad(le: bool, f64_coords: bool, list: &str) -> Vec<u8> {
        let (enc, ty) = (
            if le { "binary_little_endian" } else { "binary_big_endian" },
            if f64_coords { "double" } else { "float" },
        );
        let props = format!("property {ty} x\nproperty {ty} y\nproperty {ty} z\nproperty uchar flags\n");
        let mut b = header(enc, &props, 5, list, 2);
        // A trailing element the loader skips.
        let end = b.len() - "end_header\n".len();
        b.splice(end..end, b"element material 1\nproperty uchar k\n".iter().copied());
        let coords = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 7.0]];
        for p in coords {
            for c in p {
                if f64_coords {
                    b.extend(if le { f64::to_le_bytes(c) } else { f64::to_be_bytes(c) });
                } else {
                    b.extend(if le { (c as f32).to_le_bytes() } else { (c as f32).to_be_bytes() });
                }
            }
            b.push(0xAA);
        }
        let index = |b: &mut Vec<u8>, i: u32| match list {
            l if l.ends_with("uchar vertex_indices") => b.push(i as u8),
            l if l.ends_with("short vertex_indices") => {
                b.extend(if le { (i as i16).to_le_bytes() } else { (i as i16).to_be_bytes() })
            }
            _ => b.extend(if le { i.to_le_bytes() } else { i.to_be_bytes() }),
        };
        let count = |b: &mut Vec<u8>, n: u32| {
            if list.starts_with("list uchar") {
                b.push(n as u8);
            } else {
                b.extend(if le { n.to_le_bytes() } else { n.to_be_bytes() });
            }
        };
        count(&mut b, 4);
        for i in [0, 1, 2, 3] {
            index(&mut b, i);
        }
        count(&mut b, 3);
        for i in [0, 1, 4] {
            index(&mut b, i);
        }
        b.push(1);
        b
    }

    #[test]
    fn binary_both_endiannesses_float_and_double_any_index_type() {
        for le in [true, false] {
            for f64_coords in [true, false] {
                for list in [
                    "list uchar int vertex_indices",
                    "list uchar uint vertex_indices",
                    "list uchar uchar vertex_indices",
                    "list int int vertex_indices",
                    "list uint short vertex_indices",
                ] {
                    let case = format!("le {le} f64 {f64_coords} {list}");
                    let m = ply(&binary_quad(le, f64_coords, list)).unwrap_or_else(|e| panic!("{case}: {e}"));
                    assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3], [0, 1, 4]], "{case}");
                    assert_eq!(m.positions()[4], DVec3::new(0.5, 0.5, 7.0), "{case}");
                    assert_eq!(m.bounds().max, DVec3::new(1.0, 1.0, 7.0), "{case}");
                }
            }
        }
    }

    #[test]
    fn integer_coordinates_are_accepted() {
        let props = "property int x\nproperty short y\nproperty uchar z\n";
        let mut b = header("ascii", props, 3, "list uchar int vertex_indices", 1);
        b.extend_from_slice(b"-5 0 0\n1 -2 0\n0 1 200\n3 0 1 2\n");
        let m = ply(&b).unwrap();
        assert_eq!(
            m.positions(),
            &[DVec3::new(-5.0, 0.0, 0.0), DVec3::new(1.0, -2.0, 0.0), DVec3::new(0.0, 1.0, 200.0)]
        );
    }

    #[test]
    fn errors_name_the_file() {
        let ascii = |props: &str, list: &str, body: &[u8]| {
            let mut b = header("ascii", props, 3, list, 1);
            b.extend_from_slice(body);
            ply(&b).unwrap_err()
        };
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
        assert_eq!(e.to_string(), "model.ply: face 0: vertex index 3 is out of range (the file has 3 vertices)");
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
        assert!(matches!(e.kind, MeshErrorKind::IndexOutOfRange { index: -1, .. }), "{e}");
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 0\n0 1 0\n3 0 0 1\n");
        assert_eq!(e.to_string(), "model.ply: no triangles (1 degenerate dropped)");
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n");
        assert_eq!(e.kind, MeshErrorKind::NoTriangles { dropped: 1 });
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
        assert_eq!(e.kind, MeshErrorKind::NoTriangles { dropped: 1 });
        // 1e999 is infinite; ASCII PLY numbers cannot spell NaN.
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 0\n0 1e999 0\n3 0 1 2\n");
        assert_eq!(e.to_string(), "model.ply: vertex 2: coordinate is not finite (NaN or infinity)");
        let e = ascii(XYZ_FLOAT, "list uchar int vertex_indices", b"0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n");
        assert!(e.to_string().starts_with("model.ply: line 12: in element `vertex`: "), "{e}");
        // The line that failed, not the parser's state (`ParseError { location: .. }`).
        assert!(e.to_string().ends_with(": \"1 0 x\""), "{e}");
        assert!(!e.to_string().contains("Error:") && !e.to_string().contains("expected one of"), "{e}");
        let e = ascii("property float x\nproperty float y\n", "list uchar int vertex_indices", b"");
        assert_eq!(e.to_string(), "model.ply: element `vertex` has no scalar property `z`");
        let e = ascii(XYZ_FLOAT, "list uchar float vertex_indices", b"");
        let says = "model.ply: face property `vertex_indices` must be a list of integers, not a list of float";
        assert!(e.to_string().starts_with(says), "{e}");
        let e = ascii(XYZ_FLOAT, "list uchar int corners", b"");
        assert!(e.to_string().starts_with("model.ply: element `face` has no `vertex_indices`"), "{e}");
        // A point cloud has no triangles.
        let mut b = b"ply\nformat ascii 1.0\nelement vertex 1\n".to_vec();
        b.extend_from_slice(XYZ_FLOAT.as_bytes());
        b.extend_from_slice(b"end_header\n0 0 0\n");
        assert_eq!(ply(&b).unwrap_err().to_string(), "model.ply: no triangles");
        // Header problems carry their line.
        let e = ply(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty floot x\nend_header\n").unwrap_err();
        assert!(e.to_string().starts_with("model.ply: line 4: "), "{e}");
        assert!(ply(b"").unwrap_err().to_string().starts_with("model.ply: "));
        assert!(ply(b"OFF\n3 1 0\n").unwrap_err().to_string().starts_with("model.ply: line 1: "));
    }

    #[test]
    fn nan_in_binary_names_the_vertex() {
        let mut b = binary_quad(true, false, "list uchar int vertex_indices");
        let start = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        // Vertex 1's y (13 bytes a vertex: three f32 and the flags byte).
        let at = start + 13 + 4;
        b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = ply(&b).unwrap_err();
        assert_eq!(e.to_string(), "model.ply: vertex 1: coordinate is not finite (NaN or infinity)");
    }

    #[test]
    fn truncated_binary_is_an_error_at_every_length() {
        for le in [true, false] {
            let b = binary_quad(le, true, "list uchar int vertex_indices");
            let payload = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
            // Cut anywhere before the last face's last byte (the skipped trailing element
            // after it is not needed).
            for cut in 0..b.len() - 1 {
                let e = ply(&b[..cut]).unwrap_err();
                assert!(e.to_string().starts_with("model.ply: "), "cut {cut}: {e}");
                if cut > payload {
                    assert!(matches!(e.kind, MeshErrorKind::Syntax { at: None, .. }), "cut {cut}: {e:?}");
                    assert!(e.to_string().contains("in element `"), "cut {cut}: {e}");
                    // What is there, not the parser's stacked reader errors.
                    let sized = format!("the file ({cut} bytes) ends after ");
                    assert!(
                        e.to_string().contains(&sized) && e.to_string().ends_with(" the header declares"),
                        "cut {cut}: {e}"
                    );
                }
            }
        }
        // Three bytes into vertex 2 (25 bytes a vertex: three f64 and the flags byte).
        let b = binary_quad(true, true, "list uchar int vertex_indices");
        let cut = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11 + 2 * 25 + 3;
        let want =
            format!("model.ply: in element `vertex`: the file ({cut} bytes) ends after 2 of the 5 the header declares");
        assert_eq!(ply(&b[..cut]).unwrap_err().to_string(), want);
    }

    #[test]
    fn huge_declared_counts_fail_fast() {
        let props = XYZ_FLOAT;
        let e = ply(&header("binary_little_endian", props, 1 << 40, "list uchar int vertex_indices", 1)).unwrap_err();
        assert_eq!(e.kind, MeshErrorKind::TooMany { what: "vertices", count: 1 << 40 });
        // Within the limit but far beyond the data: an end-of-file error, not an allocation.
        let e = ply(&header("binary_little_endian", props, 1 << 31, "list uchar int vertex_indices", 1)).unwrap_err();
        assert!(matches!(e.kind, MeshErrorKind::Syntax { .. }), "{e}");
        // An element without properties is no data at all, however many it declares.
        let mut b = format!(
            "ply\nformat binary_little_endian 1.0\nelement nothing 18446744073709551615\nelement vertex 3\n{props}\
             element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes();
        for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in p {
                b.extend(c.to_le_bytes());
            }
        }
        b.push(3);
        for i in [0i32, 1, 2] {
            b.extend(i.to_le_bytes());
        }
        assert_eq!(ply(&b).unwrap().triangle_count(), 1);
    }
}
