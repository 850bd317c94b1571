//! What lumen records about a render in the EXR files it writes, so that `lumen merge` can
//! combine shards rendered anywhere and refuse parts that do not belong together.
//!
//! Attributes (in the EXR header; PFM and Radiance HDR have nowhere to keep them, so
//! shards must be EXR):
//! - `samplesPerPixel` (int, pbrt-v4's name): camera samples per pixel in the file;
//! - `lumen.samples` (text): the sample ranges, `A:B` or `A:B,C:D,…` after a merge with gaps;
//! - `lumen.fingerprint` (text): a hash of everything that determines the image except the
//!   samples taken (the loaded scene with its size, vars, time, seed and renderer settings,
//!   the sample layout, lumen's version);
//! - `lumen.device` (text), `lumen.renderSeconds` (double), `lumen.version` (text).

use std::collections::HashMap;
use std::fmt::Write as _;

use exr::meta::attribute::{AttributeValue, Text};

use super::digest::Digest;
use crate::prepare::SampleRange;
use crate::scene::{Scene, Shape};

/// The metadata of one render, or of a merge of renders.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderMetadata {
    /// Disjoint sample ranges, sorted (one range for a render).
    pub ranges: Vec<SampleRange>,
    /// [`fingerprint`] of the render's inputs.
    pub fingerprint: String,
    /// Where it was rendered (`+`-joined after a merge of different devices).
    pub device: String,
    /// Render time in seconds (summed over merged parts).
    pub seconds: f64,
    /// The lumen version that rendered it.
    pub version: String,
}

/// Why a file's attributes are not lumen render metadata.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MetadataError {
    /// A required attribute, named here, is absent: the file was not written by `lumen render`.
    #[error("not written by lumen render (no `{0}` attribute)")]
    Missing(&'static str),
    /// An attribute has the wrong type or an unreadable value, the sample ranges overlap or
    /// are out of order, or `samplesPerPixel` disagrees with the ranges.
    #[error("attribute `{name}` is malformed: {value:?}")]
    Malformed {
        /// The attribute's name in the EXR header.
        name: &'static str,
        /// What the file holds: the text of `lumen.samples`, else the value's `Debug` form.
        value: String,
    },
}

const SPP: &str = "samplesPerPixel";
const SAMPLES: &str = "lumen.samples";
const FINGERPRINT: &str = "lumen.fingerprint";
const DEVICE: &str = "lumen.device";
const SECONDS: &str = "lumen.renderSeconds";
const VERSION: &str = "lumen.version";

/// A 64-bit hash ([`Digest`]), fed through `fmt::Write` so that `Debug` text (which writes
/// every f64 exactly, and images as a digest of their texels' bits) is hashed without being
/// held in memory.
struct Hasher {
    hash: Digest,
    /// Meshes already hashed (by the address of their `Arc`), each with its order of first
    /// use: an instance of one of them hashes that number, not its triangles again.
    meshes: Vec<usize>,
}

impl Hasher {
    fn bytes(&mut self, bytes: &[u8]) {
        self.hash.bytes(bytes);
    }

    fn f64s(&mut self, values: &[f64]) {
        self.hash.scalars::<8, _>(values);
    }

    /// A shape tree by its bits: formatting a tree of millions of primitives would take
    /// longer than rendering it.
    fn shape(&mut self, shape: &Shape) {
        match shape {
            Shape::Primitive(p) => {
                self.bytes(&[0, p.kind as u8]);
                self.f64s(&p.transform.matrix().to_cols_array());
                self.bytes(&p.material.0.to_le_bytes());
            }
            Shape::Csg(c) => {
                self.bytes(&[1, c.op as u8]);
                self.bytes(&(c.children.len() as u64).to_le_bytes());
                self.f64s(&c.transform.matrix().to_cols_array());
                c.children.iter().for_each(|child| self.shape(child));
            }
            Shape::Mesh(m) => {
                self.bytes(&[2, u8::from(m.smooth)]);
                self.f64s(&m.transform.matrix().to_cols_array());
                self.bytes(&m.material.0.to_le_bytes());
                let key = std::sync::Arc::as_ptr(&m.mesh) as usize;
                if let Some(k) = self.meshes.iter().position(|&x| x == key) {
                    self.bytes(&[3]);
                    self.bytes(&(k as u64).to_le_bytes());
                    return;
                }
                self.meshes.push(key);
                let mesh = &m.mesh;
                self.bytes(&(mesh.triangle_count() as u64).to_le_bytes());
                self.hash.scalars::<8, _>(mesh.positions());
                self.hash.scalars::<4, _>(mesh.triangles());
                // Presence is marked, so that normals cannot pass for uvs or vertices.
                self.bytes(&[u8::from(mesh.normals().is_some()), u8::from(mesh.uvs().is_some())]);
                self.hash.scalars::<8, _>(mesh.normals().unwrap_or_default());
                self.hash.scalars::<8, _>(mesh.uvs().unwrap_or_default());
            }
        }
    }
}

impl std::fmt::Write for Hasher {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// The fingerprint of a render of `scene` (after every command-line override) with a
/// layout of `layout_spp` camera samples per pixel: equal for all shards of one render,
/// different when anything that changes the image differs. The device is left out on
/// purpose (CPU and GPU shards of one render may be merged).
pub fn fingerprint(scene: &Scene, layout_spp: u32) -> String {
    let mut h = Hasher { hash: Digest::new(), meshes: Vec::new() };
    // Where the script wrote the shapes does not change the image.
    let Scene { shapes, materials, point_lights, camera, width, height, renderer, tracer, environment, origins: _ } =
        scene;
    let _ = write!(
        h,
        "lumen {} layout {layout_spp} {width}x{height} {materials:?} {point_lights:?} {camera:?} {renderer:?} \
         {tracer:?} {environment:?}",
        env!("CARGO_PKG_VERSION")
    );
    h.bytes(&(shapes.len() as u64).to_le_bytes());
    shapes.iter().for_each(|s| h.shape(s));
    format!("{:016x}", h.hash.finish())
}

fn text(s: &str) -> Text {
    // EXR text is 8-bit; anything else (a device name in another script) becomes '?'.
    let clean: String = s.chars().map(|c| if (c as u32) < 256 { c } else { '?' }).collect();
    Text::new_or_none(&clean).unwrap_or_else(|| Text::from("?"))
}

impl RenderMetadata {
    /// Metadata of one render.
    pub fn new(range: SampleRange, fingerprint: String, device: &str, seconds: f64) -> Self {
        Self {
            ranges: vec![range],
            fingerprint,
            device: device.to_string(),
            seconds,
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// Camera samples per pixel in all ranges.
    pub fn spp(&self) -> u64 {
        self.ranges.iter().map(|r| u64::from(r.len())).sum()
    }

    /// `A:B,C:D`.
    pub fn ranges_text(&self) -> String {
        self.ranges.iter().map(|r| r.to_string()).collect::<Vec<_>>().join(",")
    }

    /// The EXR header attributes.
    pub fn to_attributes(&self) -> HashMap<Text, AttributeValue> {
        let spp = i32::try_from(self.spp()).unwrap_or(i32::MAX);
        HashMap::from([
            (Text::from(SPP), AttributeValue::I32(spp)),
            (Text::from(SAMPLES), AttributeValue::Text(text(&self.ranges_text()))),
            (Text::from(FINGERPRINT), AttributeValue::Text(text(&self.fingerprint))),
            (Text::from(DEVICE), AttributeValue::Text(text(&self.device))),
            (Text::from(SECONDS), AttributeValue::F64(self.seconds)),
            (Text::from(VERSION), AttributeValue::Text(text(&self.version))),
        ])
    }

    /// Reads the attributes [`Self::to_attributes`] wrote.
    pub fn from_attributes(attrs: &HashMap<Text, AttributeValue>) -> Result<Self, MetadataError> {
        let get = |name: &'static str| attrs.get(&Text::from(name)).ok_or(MetadataError::Missing(name));
        let text_of = |name: &'static str| -> Result<String, MetadataError> {
            match get(name)? {
                AttributeValue::Text(t) => Ok(t.to_string()),
                other => Err(MetadataError::Malformed { name, value: format!("{other:?}") }),
            }
        };
        let samples = text_of(SAMPLES)?;
        let malformed = || MetadataError::Malformed { name: SAMPLES, value: samples.clone() };
        let ranges = samples
            .split(',')
            .map(|r| SampleRange::parse(r).map_err(|_| malformed()))
            .collect::<Result<Vec<_>, _>>()?;
        if ranges.windows(2).any(|w| w[0].end > w[1].begin) {
            return Err(malformed());
        }
        let seconds = match get(SECONDS)? {
            AttributeValue::F64(s) => *s,
            AttributeValue::F32(s) => f64::from(*s),
            other => return Err(MetadataError::Malformed { name: SECONDS, value: format!("{other:?}") }),
        };
        let meta = Self {
            ranges,
            fingerprint: text_of(FINGERPRINT)?,
            device: text_of(DEVICE)?,
            seconds,
            version: text_of(VERSION)?,
        };
        match get(SPP)? {
            AttributeValue::I32(n) if i64::from(*n) == meta.spp() as i64 => Ok(meta),
            other => Err(MetadataError::Malformed { name: SPP, value: format!("{other:?}") }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;

    #[test]
    fn attributes_round_trip_and_missing_ones_are_named() {
        let mut m = RenderMetadata::new(SampleRange { begin: 4, end: 9 }, "00ff".into(), "llvmpipe — Ω", 1.5);
        m.ranges.push(SampleRange { begin: 12, end: 16 });
        let back = RenderMetadata::from_attributes(&m.to_attributes()).unwrap();
        assert_eq!(back.ranges, m.ranges);
        assert_eq!((back.spp(), back.ranges_text(), back.seconds), (9, "4:9,12:16".to_string(), 1.5));
        assert_eq!(back.device, "llvmpipe ? ?");
        let mut attrs = m.to_attributes();
        attrs.remove(&Text::from(FINGERPRINT));
        assert_eq!(RenderMetadata::from_attributes(&attrs), Err(MetadataError::Missing(FINGERPRINT)));
        let mut attrs = m.to_attributes();
        attrs.insert(Text::from(SPP), AttributeValue::I32(8));
        assert!(matches!(RenderMetadata::from_attributes(&attrs), Err(MetadataError::Malformed { name: SPP, .. })));
        let mut attrs = m.to_attributes();
        attrs.insert(Text::from(SAMPLES), AttributeValue::Text(Text::from("8:12,4:9")));
        assert!(matches!(RenderMetadata::from_attributes(&attrs), Err(MetadataError::Malformed { .. })));
    }

    #[test]
    fn fingerprints_follow_what_changes_the_image() {
        let scene = |w: u32| SceneBuilder::new(w, 4).build().unwrap();
        assert_eq!(fingerprint(&scene(4), 16), fingerprint(&scene(4), 16));
        assert_ne!(fingerprint(&scene(4), 16), fingerprint(&scene(5), 16));
        assert_ne!(fingerprint(&scene(4), 16), fingerprint(&scene(4), 9));
        let mut seeded = scene(4);
        seeded.tracer.rng.state += 1;
        assert_ne!(fingerprint(&scene(4), 16), fingerprint(&seeded, 16));
        // Shapes: a moved sphere, another material, another CSG operation.
        use crate::scene::{CsgOp, MaterialId, ShapeKind, Transform};
        let sphere = |x: f64, m: u32| {
            Shape::primitive(ShapeKind::Sphere, Transform::translation(glam::DVec3::new(x, 0.0, 0.0)), MaterialId(m))
        };
        let with = |shapes: Vec<Shape>| Scene { shapes, ..scene(4) };
        let csg = |op| Shape::csg(op, vec![sphere(0.0, 0), sphere(1.0, 0)], Transform::IDENTITY);
        let prints: Vec<String> = [
            with(vec![sphere(0.0, 0)]),
            with(vec![sphere(1e-12, 0)]),
            with(vec![sphere(0.0, 1)]),
            with(vec![csg(CsgOp::Unite)]),
            with(vec![csg(CsgOp::Fuse)]),
            with(vec![sphere(0.0, 0), sphere(1.0, 0)]),
        ]
        .iter()
        .map(|s| fingerprint(s, 16))
        .collect();
        for (i, a) in prints.iter().enumerate() {
            assert!(prints[i + 1..].iter().all(|b| b != a), "{prints:?}");
        }
    }
}
