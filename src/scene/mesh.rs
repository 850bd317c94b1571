//! Triangle meshes from OBJ and PLY files: one validated triangle set per file.
//!
//! The files are parsed by maintained crates (`tobj`, `ply-rs-bw`; docs/DESIGN.md, "Mesh
//! loading"); this module turns what they return into the one form the renderers use and
//! enforces what those crates do not: finite coordinates, indices in range, at most
//! [`MAX_MESH_ELEMENTS`] vertices and triangles, at least one non-degenerate triangle, and
//! errors that name the file. No input makes it panic (property-tested below).

mod error;
mod icosphere;
mod obj;
mod ply;

use std::path::Path;

use glam::{DVec2, DVec3};

pub use error::{MeshError, MeshErrorKind, MeshLocation};
pub use icosphere::icosphere;

use super::Aabb;

/// Most vertices, and most triangles, one mesh may have: 2³¹, so that every index fits a
/// u32 with the top bit free (and an i32 on the GPU), and triangle counts stay far from
/// u32 overflow when meshes are combined.
pub const MAX_MESH_ELEMENTS: u64 = 1 << 31;

/// The file formats lumen reads, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ text (`.obj`).
    Obj,
    /// Stanford PLY, ASCII or binary of either endianness (`.ply`).
    Ply,
}

impl MeshFormat {
    /// The format of `path` by its extension, in any case (`.obj`, `.OBJ`, `.Ply`, ...);
    /// `None` for any other extension or none.
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?;
        if ext.eq_ignore_ascii_case("obj") {
            Some(Self::Obj)
        } else if ext.eq_ignore_ascii_case("ply") {
            Some(Self::Ply)
        } else {
            None
        }
    }
}

/// The raw arrays a loader (or a generator) hands to [`TriangleMesh::from_parts`], which
/// validates them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshParts {
    /// Vertex positions in the mesh's object space (the file's own coordinates).
    pub positions: Vec<DVec3>,
    /// Per-vertex normals, any length (they are used only if there is one per vertex).
    pub normals: Option<Vec<DVec3>>,
    /// Per-vertex texture coordinates, as in the file (used only if one per vertex).
    pub uvs: Option<Vec<DVec2>>,
    /// Each triangle's three 0-based indices into `positions`, not yet range-checked; for
    /// corners a, b, c in this order, (b − a) × (c − a) points to the outside.
    pub triangles: Vec<[u32; 3]>,
    /// Faces the loader already dropped as degenerate (a PLY face of fewer than 3
    /// vertices); added to the count of dropped triangles.
    pub dropped_faces: usize,
}

/// An indexed triangle set with optional per-vertex normals and uvs.
///
/// Invariants (established by every constructor): at most [`MAX_MESH_ELEMENTS`] vertices
/// and triangles, at least one triangle, every index in range, finite positions, no
/// triangle with a repeated index or an exactly zero cross product; normals, when present,
/// are unit length and one per vertex; uvs, when present, finite and one per vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    positions: Vec<DVec3>,
    normals: Option<Vec<DVec3>>,
    uvs: Option<Vec<DVec2>>,
    triangles: Vec<[u32; 3]>,
    dropped_degenerate: usize,
    dropped_normals: bool,
    dropped_uvs: bool,
    bounds: Aabb,
}

impl TriangleMesh {
    /// Loads an `.obj` or `.ply` file (extension in any case). Errors name `path` as given.
    pub fn load(path: &Path) -> Result<Self, MeshError> {
        let name = path.display().to_string();
        // The extension first: a wrong one is the clearer message, and costs no read.
        let Some(format) = MeshFormat::from_path(path) else {
            let extension = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
            return Err(MeshError::new(name, MeshErrorKind::UnknownExtension { extension }));
        };
        let bytes = crate::regular_file::read(path).map_err(|e| MeshError::io(&name, &e))?;
        Self::from_bytes(&name, format, &bytes)
    }

    /// Parses a file's contents; `name` is what error messages call the file.
    pub fn from_bytes(name: &str, format: MeshFormat, bytes: &[u8]) -> Result<Self, MeshError> {
        match format {
            MeshFormat::Obj => Self::from_obj_bytes(name, bytes),
            MeshFormat::Ply => Self::from_ply_bytes(name, bytes),
        }
    }

    /// Parses Wavefront OBJ text: polygons are fan-triangulated, all objects and groups
    /// merge into one triangle set, materials (`mtllib`, `usemtl`) and polylines (`l`) are
    /// ignored.
    pub fn from_obj_bytes(name: &str, bytes: &[u8]) -> Result<Self, MeshError> {
        obj::parse(name, &lone_cr_as_newline(without_bom(bytes)))
    }

    /// Parses a PLY file (ASCII, binary little- or big-endian): the `vertex` element's
    /// x, y, z (optionally nx, ny, nz and u, v / s, t / texture_u, texture_v), and the
    /// `face` element's `vertex_indices` (or `vertex_index`), fan-triangulated.
    pub fn from_ply_bytes(name: &str, bytes: &[u8]) -> Result<Self, MeshError> {
        ply::parse(name, without_bom(bytes))
    }

    /// Validates raw arrays into a mesh (see the type's invariants). Triangles with a
    /// repeated index or zero area are dropped and counted. Normals that are not one per
    /// vertex, or of which any is zero or not finite, are dropped altogether (the mesh is
    /// then flat-shaded) rather than failing the file: exporters write such normals for
    /// degenerate faces, and the geometric normal is always a correct fallback. Uvs that are
    /// not one per vertex or not all finite are dropped likewise (uv falls back to the
    /// barycentric coordinates).
    pub fn from_parts(name: &str, parts: MeshParts) -> Result<Self, MeshError> {
        let MeshParts { positions, normals, uvs, triangles, dropped_faces } = parts;
        check_count(name, "vertices", positions.len() as u64)?;
        check_count(name, "triangles", triangles.len() as u64)?;
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            let at = MeshLocation::Element { element: "vertex", index: i };
            return Err(MeshError::new(name, MeshErrorKind::NonFinite { at }));
        }
        let n = positions.len();

        let (normals, dropped_normals) = match normals {
            None => (None, false),
            Some(ns) => match unit_normals(&ns, n) {
                Some(ns) => (Some(ns), false),
                None => (None, true),
            },
        };
        let (uvs, dropped_uvs) = match uvs {
            None => (None, false),
            Some(uv) if uv.len() == n && uv.iter().all(|t| t.is_finite()) => (Some(uv), false),
            Some(_) => (None, true),
        };

        let mut kept = Vec::with_capacity(triangles.len());
        let mut dropped_degenerate = dropped_faces;
        let mut bounds = Aabb::EMPTY;
        for (i, tri) in triangles.into_iter().enumerate() {
            if let Some(&bad) = tri.iter().find(|&&k| k as usize >= n) {
                let at = MeshLocation::Element { element: "triangle", index: i };
                return Err(MeshError::new(
                    name,
                    MeshErrorKind::IndexOutOfRange { at, what: "vertex", index: bad.into(), count: n },
                ));
            }
            let [a, b, c] = tri.map(|k| positions[k as usize]);
            if is_degenerate(tri, a, b, c) {
                dropped_degenerate += 1;
                continue;
            }
            bounds = bounds.grow(a).grow(b).grow(c);
            kept.push(tri);
        }
        if kept.is_empty() {
            return Err(MeshError::new(name, MeshErrorKind::NoTriangles { dropped: dropped_degenerate }));
        }
        Ok(Self { positions, normals, uvs, triangles: kept, dropped_degenerate, dropped_normals, dropped_uvs, bounds })
    }

    /// Vertex positions in object space, one per vertex, including any no triangle uses.
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }
    /// Unit per-vertex normals, if the file had usable ones.
    pub fn normals(&self) -> Option<&[DVec3]> {
        self.normals.as_deref()
    }
    /// Per-vertex texture coordinates as in the file, if it had usable ones.
    pub fn uvs(&self) -> Option<&[DVec2]> {
        self.uvs.as_deref()
    }
    /// The kept triangles (never empty) as indices into [`Self::positions`], all in range;
    /// for corners a, b, c in this order, (b − a) × (c − a) points to the outside.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }
    /// Number of vertices, used by a triangle or not.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
    /// Number of triangles kept (at least 1; degenerate ones are not counted).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
    /// The corners of triangle `i` (panics if `i` is out of range, like slice indexing).
    pub fn triangle(&self, i: usize) -> [DVec3; 3] {
        self.triangles[i].map(|k| self.positions[k as usize])
    }
    /// Triangles dropped while loading: repeated indices, zero area, PLY faces of fewer
    /// than three vertices.
    pub fn dropped_degenerate(&self) -> usize {
        self.dropped_degenerate
    }
    /// The file had normals that could not be used (see [`Self::from_parts`]).
    pub fn dropped_normals(&self) -> bool {
        self.dropped_normals
    }
    /// The file had uvs that could not be used (see [`Self::from_parts`]).
    pub fn dropped_uvs(&self) -> bool {
        self.dropped_uvs
    }
    /// Bounds of the triangles' vertices (vertices no triangle uses do not count).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// Errors past [`MAX_MESH_ELEMENTS`] of `what`.
fn check_count(name: &str, what: &'static str, count: u64) -> Result<(), MeshError> {
    if count > MAX_MESH_ELEMENTS {
        return Err(MeshError::new(name, MeshErrorKind::TooMany { what, count }));
    }
    Ok(())
}

/// The normals made unit length, or `None` if they are not one per vertex or any is zero
/// or not finite. Dividing by the largest component first keeps huge and tiny (but
/// non-zero) normals from overflowing or underflowing the length.
fn unit_normals(ns: &[DVec3], n: usize) -> Option<Vec<DVec3>> {
    if ns.len() != n {
        return None;
    }
    ns.iter()
        .map(|&v| {
            let m = v.abs().max_element();
            (m > 0.0 && m.is_finite()).then(|| (v / m).normalize())
        })
        .collect()
}

/// A repeated index, or a cross product that is exactly zero in f64 (collinear or
/// coincident corners). Near-degenerate slivers are kept: the watertight intersection
/// handles them, and dropping them could open cracks.
fn is_degenerate(tri: [u32; 3], a: DVec3, b: DVec3, c: DVec3) -> bool {
    tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || (b - a).cross(c - a) == DVec3::ZERO
}

/// `bytes` without a leading UTF-8 byte-order mark, which Windows tools write before text:
/// tobj would read it as part of an unknown first statement (an OBJ lost its first vertex,
/// every face index after it one vertex off) and a PLY header would not start with `ply`.
fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes)
}

/// OBJ text with classic Mac OS line ends (a lone `\r`, `crate::line_ends`) turned into
/// `\n`, which is all tobj splits lines at: it read such a file as one line, a vertex with
/// every other statement as its numbers. `\r\n` is left alone (tobj trims the `\r`). PLY
/// is not converted: its binary bodies hold any bytes, and its header must end in `\n`.
fn lone_cr_as_newline(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    use crate::line_ends::ends_line;
    if !(0..bytes.len()).any(|i| bytes[i] == b'\r' && ends_line(bytes, i)) {
        return std::borrow::Cow::Borrowed(bytes);
    }
    std::borrow::Cow::Owned((0..bytes.len()).map(|i| if ends_line(bytes, i) { b'\n' } else { bytes[i] }).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

    fn ply_ascii_tetrahedron() -> String {
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 4\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
            .to_string()
    }

    #[test]
    fn parts_are_validated() {
        let p =
            |positions: Vec<DVec3>, triangles: Vec<[u32; 3]>| MeshParts { positions, triangles, ..Default::default() };
        let tri = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        let m = TriangleMesh::from_parts("t", p(tri.clone(), vec![[0, 1, 2]])).unwrap();
        assert_eq!(m.bounds(), Aabb::new(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)));
        assert_eq!(m.triangle(0), [DVec3::ZERO, DVec3::X, DVec3::Y]);

        let e = TriangleMesh::from_parts("t", p(tri.clone(), vec![[0, 1, 3]])).unwrap_err();
        assert_eq!(e.to_string(), "t: triangle 0: vertex index 3 is out of range (the file has 3 vertices)");
        // Degenerate: repeated index, collinear, coincident.
        let mut four = tri.clone();
        four.push(DVec3::X * 2.0);
        let m =
            TriangleMesh::from_parts("t", p(four.clone(), vec![[0, 0, 1], [0, 1, 3], [1, 1, 1], [0, 1, 2]])).unwrap();
        assert_eq!((m.triangle_count(), m.dropped_degenerate()), (1, 3));
        let e = TriangleMesh::from_parts("t", p(four, vec![[0, 1, 3]])).unwrap_err();
        assert_eq!(e.kind, MeshErrorKind::NoTriangles { dropped: 1 });
        assert_eq!(e.to_string(), "t: no triangles (1 degenerate dropped)");
        assert_eq!(TriangleMesh::from_parts("t", p(tri.clone(), vec![])).unwrap_err().to_string(), "t: no triangles");
        let mut nan = tri.clone();
        nan[1].y = f64::NAN;
        let e = TriangleMesh::from_parts("t", p(nan, vec![[0, 1, 2]])).unwrap_err();
        assert_eq!(e.to_string(), "t: vertex 1: coordinate is not finite (NaN or infinity)");
    }

    #[test]
    fn normals_and_uvs_are_kept_normalised_or_dropped() {
        let base = || MeshParts {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        };
        let m = TriangleMesh::from_parts(
            "t",
            MeshParts {
                normals: Some(vec![DVec3::Z * 3.0, DVec3::new(0.0, 1e-300, 1e-300), DVec3::new(1e300, 0.0, 1e300)]),
                uvs: Some(vec![DVec2::ZERO, DVec2::X, DVec2::Y]),
                ..base()
            },
        )
        .unwrap();
        let ns = m.normals().unwrap();
        assert_eq!(ns[0], DVec3::Z);
        assert!((ns[1] - DVec3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-15);
        assert!((ns[2] - DVec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-15);
        assert_eq!(m.uvs().unwrap()[1], DVec2::X);
        assert!(!m.dropped_normals() && !m.dropped_uvs());

        for bad in [DVec3::ZERO, DVec3::NAN, DVec3::new(0.0, f64::INFINITY, 0.0)] {
            let m = TriangleMesh::from_parts("t", MeshParts { normals: Some(vec![DVec3::Z, bad, DVec3::Z]), ..base() })
                .unwrap();
            assert!(m.normals().is_none() && m.dropped_normals(), "{bad}");
        }
        let m = TriangleMesh::from_parts("t", MeshParts { normals: Some(vec![DVec3::Z]), ..base() }).unwrap();
        assert!(m.normals().is_none() && m.dropped_normals());
        let m = TriangleMesh::from_parts(
            "t",
            MeshParts { uvs: Some(vec![DVec2::ZERO, DVec2::NAN, DVec2::ZERO]), ..base() },
        )
        .unwrap();
        assert!(m.uvs().is_none() && m.dropped_uvs());
    }

    #[test]
    fn too_many_elements() {
        assert!(check_count("big.ply", "vertices", MAX_MESH_ELEMENTS).is_ok());
        let e = check_count("big.ply", "vertices", MAX_MESH_ELEMENTS + 1).unwrap_err();
        assert_eq!(e.kind, MeshErrorKind::TooMany { what: "vertices", count: MAX_MESH_ELEMENTS + 1 });
        assert_eq!(e.to_string(), "big.ply: too many vertices: 2147483649 (at most 2147483648 are supported)");
    }

    #[test]
    fn extension_picks_the_format_in_any_case() {
        assert_eq!(MeshFormat::from_path(Path::new("a/b.obj")), Some(MeshFormat::Obj));
        assert_eq!(MeshFormat::from_path(Path::new("B.OBJ")), Some(MeshFormat::Obj));
        assert_eq!(MeshFormat::from_path(Path::new("c.Ply")), Some(MeshFormat::Ply));
        assert_eq!(MeshFormat::from_path(Path::new("c.stl")), None);
        assert_eq!(MeshFormat::from_path(Path::new("obj")), None);
    }

    #[test]
    fn load_reads_files_by_extension() {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("Quad.OBJ");
        std::fs::write(&obj, QUAD_OBJ).unwrap();
        assert_eq!(TriangleMesh::load(&obj).unwrap().triangle_count(), 2);
        let ply = dir.path().join("tet.PlY");
        std::fs::write(&ply, ply_ascii_tetrahedron()).unwrap();
        assert_eq!(TriangleMesh::load(&ply).unwrap().triangle_count(), 4);
        // The same bytes under a .ply name are not PLY: the format follows the extension.
        let wrong = dir.path().join("quad.ply");
        std::fs::write(&wrong, QUAD_OBJ).unwrap();
        let e = TriangleMesh::load(&wrong).unwrap_err();
        assert!(e.to_string().starts_with(&format!("{}: line 1: ", wrong.display())), "{e}");
    }

    #[test]
    fn missing_file_and_bad_extension_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope.obj");
        let e = TriangleMesh::load(&missing).unwrap_err();
        assert!(matches!(e.kind, MeshErrorKind::Io { kind: std::io::ErrorKind::NotFound, .. }), "{e:?}");
        assert!(e.to_string().starts_with(&format!("{}: cannot read the file: ", missing.display())), "{e}");

        let stl = dir.path().join("model.stl");
        std::fs::write(&stl, "solid x").unwrap();
        let e = TriangleMesh::load(&stl).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{}: unknown mesh format \"stl\": expected a .obj or .ply file", stl.display())
        );
        let e = TriangleMesh::load(&dir.path().join("noext")).unwrap_err();
        assert_eq!(e.kind, MeshErrorKind::UnknownExtension { extension: String::new() });
        // A directory named like a mesh is a read error, not a panic.
        let d = dir.path().join("dir.ply");
        std::fs::create_dir(&d).unwrap();
        assert!(matches!(TriangleMesh::load(&d).unwrap_err().kind, MeshErrorKind::Io { .. }));
    }

    #[test]
    fn garbage_is_an_error_naming_the_file() {
        let garbage: &[u8] = b"\x00\xff\xfe garbage \x80\x81 ply\n\x01\x02";
        for (e, name) in [
            (TriangleMesh::from_obj_bytes("junk.obj", garbage).unwrap_err(), "junk.obj"),
            (TriangleMesh::from_ply_bytes("junk.ply", garbage).unwrap_err(), "junk.ply"),
        ] {
            assert!(e.to_string().starts_with(&format!("{name}: ")), "{e}");
        }
    }

    /// A small binary PLY (little-endian when `le`) with a few faces: the fuzzing seed.
    fn binary_ply(le: bool) -> Vec<u8> {
        let enc = if le { "binary_little_endian" } else { "binary_big_endian" };
        let mut b = format!(
            "ply\nformat {enc} 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n\
             element face 2\nproperty list uchar uint vertex_indices\nend_header\n"
        )
        .into_bytes();
        for p in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
            for c in p {
                b.extend(if le { c.to_le_bytes() } else { c.to_be_bytes() });
            }
        }
        for f in [[0u32, 1, 2], [0, 2, 3]] {
            b.push(3);
            for i in f {
                b.extend(if le { i.to_le_bytes() } else { i.to_be_bytes() });
            }
        }
        b
    }

    fn seeds() -> Vec<Vec<u8>> {
        vec![
            QUAD_OBJ.as_bytes().to_vec(),
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\no a\nf 1/1/1 2/2/1 3/1/1\ng b\nf -3//1 -2//1 -1//1\n"
                .to_vec(),
            ply_ascii_tetrahedron().into_bytes(),
            binary_ply(true),
            binary_ply(false),
        ]
    }

    // proptest's default of 256 cases each (PROPTEST_CASES raises it for a longer hunt).
    proptest! {
        /// Arbitrary bytes, as either format: an error or a mesh, never a panic.
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            let _ = TriangleMesh::from_obj_bytes("fuzz.obj", &bytes);
            let _ = TriangleMesh::from_ply_bytes("fuzz.ply", &bytes);
        }

        /// Valid files truncated anywhere and with a few bytes overwritten (by random bytes
        /// or by characters that matter to the formats): never a panic, and errors name the
        /// file.
        #[test]
        fn damaged_valid_files_never_panic(
            seed in 0usize..5,
            edits in proptest::collection::vec((any::<usize>(), any::<u8>(), any::<bool>()), 0..4),
            cut in any::<usize>(),
        ) {
            let mut bytes = seeds()[seed].clone();
            const SPECIAL: &[u8] = b"0123456789-+/ \n.evfntxyz";
            for (pos, value, special) in edits {
                let n = bytes.len();
                bytes[pos % n] = if special { SPECIAL[value as usize % SPECIAL.len()] } else { value };
            }
            bytes.truncate(cut % (bytes.len() + 1));
            for (name, result) in [
                ("cut.obj", TriangleMesh::from_obj_bytes("cut.obj", &bytes)),
                ("cut.ply", TriangleMesh::from_ply_bytes("cut.ply", &bytes)),
            ] {
                match result {
                    Ok(m) => prop_assert!(m.triangle_count() > 0),
                    Err(e) => prop_assert!(e.to_string().starts_with(name), "{}", e),
                }
            }
        }
    }
}
