//! Where the kernels read the scene's small tables from: a storage buffer, or a uniform
//! buffer of fixed length (DESIGN.md "Uniform scene tables").
//!
//! On llvmpipe (lavapipe) a storage-buffer load at an index that differs between lanes is
//! compiled into one branch and one scalar load per lane and word, while a uniform-buffer
//! load at any index is a straight-line gather. Reading shapes, BVH nodes, materials and
//! the other read-only tables (texels and sampling tables too, when small) from uniform
//! buffers halved the cold compile time of cornell.sl and made it render 39 % faster there
//! (BENCHMARKS.md). Hardware GPUs serve
//! divergent uniform reads from a constant cache that serialises them, so there the tables
//! stay in storage buffers. A table goes in a uniform buffer only when it fits one
//! ([`UNIFORM_TABLE_BYTES`], WebGPU's default limit, which every adapter offers); larger
//! tables of the same scene stay in storage buffers.
//!
//! Each table is described here once: its binding, WGSL name and element type, the
//! features that declare it, and its bytes. [`tables_wgsl`] generates the declarations in
//! either form (and the accessors of the packed ones), and the renderer uploads through
//! [`Table::bytes`], so no binding number is written twice.

use super::layout;
use super::pack::PackedScene;
use crate::accel::BvhNode;

/// Bytes of every uniform table buffer: WebGPU's default `max_uniform_buffer_binding_size`.
/// The WGSL arrays have a fixed length, so the buffer always holds the whole array.
pub const UNIFORM_TABLE_BYTES: usize = 65536;

/// A read-only group-1 table that may live in a uniform buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Table {
    Shapes,
    /// Object references (u32), packed four to a `vec4<u32>` in the uniform form.
    Indices,
    BvhNodes,
    CsgTrees,
    Materials,
    Pigments,
    PointLights,
    AreaLights,
    /// Texels and sampling tables (f32), packed four to a `vec4<f32>` in the uniform form.
    Floats,
    /// The microfacet materials' energy rows (f32), packed like `Floats`.
    Rows,
}

impl Table {
    pub const ALL: [Table; 10] = [
        Table::Shapes,
        Table::Indices,
        Table::BvhNodes,
        Table::CsgTrees,
        Table::Materials,
        Table::Pigments,
        Table::PointLights,
        Table::AreaLights,
        Table::Floats,
        Table::Rows,
    ];

    /// The `@group(1) @binding` of the table.
    pub fn binding(self) -> u32 {
        match self {
            Table::Shapes => 3,
            Table::Indices => 4,
            Table::BvhNodes => 5,
            Table::CsgTrees => 6,
            Table::Materials => 7,
            Table::Pigments => 8,
            Table::PointLights => 11,
            Table::AreaLights => 12,
            Table::Floats => 10,
            Table::Rows => 15,
        }
    }

    /// The table whose binding is `binding`, if it is one.
    pub fn from_binding(binding: u32) -> Option<Table> {
        Table::ALL.into_iter().find(|t| t.binding() == binding)
    }

    /// The assembly feature that declares the table as a uniform array.
    pub fn feature(self) -> &'static str {
        match self {
            Table::Shapes => "UNIFORM_SHAPES",
            Table::Indices => "UNIFORM_INDICES",
            Table::BvhNodes => "UNIFORM_BVH_NODES",
            Table::CsgTrees => "UNIFORM_CSG_TREES",
            Table::Materials => "UNIFORM_MATERIALS",
            Table::Pigments => "UNIFORM_PIGMENTS",
            Table::PointLights => "UNIFORM_POINT_LIGHTS",
            Table::AreaLights => "UNIFORM_AREA_LIGHTS",
            Table::Floats => "UNIFORM_FLOATS",
            Table::Rows => "UNIFORM_ROWS",
        }
    }

    /// The WGSL constant holding the uniform array's length.
    pub fn length_constant(self) -> String {
        format!("{}_LEN", self.feature())
    }

    /// The name of the WGSL global.
    pub fn wgsl_name(self) -> &'static str {
        match self {
            Table::Shapes => "shapes",
            Table::Indices => "indices",
            Table::BvhNodes => "bvh_nodes",
            Table::CsgTrees => "csg_trees",
            Table::Materials => "materials",
            Table::Pigments => "pigments",
            Table::PointLights => "point_lights",
            Table::AreaLights => "area_lights",
            Table::Floats => "floats",
            Table::Rows => "rows",
        }
    }

    /// The WGSL element type of the storage form (the uniform form packs u32 and f32 four
    /// to a vec4).
    fn wgsl_element(self) -> &'static str {
        match self {
            Table::Shapes => "Shape",
            Table::Indices => "u32",
            Table::BvhNodes => "BvhNode",
            Table::CsgTrees => "CsgTree",
            Table::Materials => "Material",
            Table::Pigments => "Pigment",
            Table::PointLights => "PointLight",
            Table::AreaLights => "AreaLight",
            Table::Floats | Table::Rows => "f32",
        }
    }

    /// The assembly features under which a kernel declares the table (all must hold).
    fn declared_when(self) -> &'static [&'static str] {
        match self {
            Table::Shapes => &["GEOMETRY"],
            Table::Indices => &["SPANS"],
            Table::BvhNodes => &["BVH"],
            // Where trees are evaluated, and object lists (their bounds).
            Table::CsgTrees => &["CSG_TREES"],
            Table::Materials => &["MATERIALS"],
            Table::Pigments => &["PIGMENTS"],
            Table::PointLights => &["POINT_LIGHTS"],
            Table::AreaLights => &["AREA_LIGHTS"],
            Table::Floats => &["TEXTURES"],
            Table::Rows => &["ENERGY_ROWS"],
        }
    }

    /// For the u32 and f32 tables, the accessor every read goes through (the uniform form
    /// holds them packed) and what the table holds.
    fn accessor(self) -> Option<(&'static str, &'static str)> {
        match self {
            Table::Indices => {
                Some(("object_ref", "BVH leaf object references from 0, then the plane list and CSG children"))
            }
            Table::Floats => Some((
                "float_at",
                "texels (rgb triples) of image pigments and the environment, the environment's \
                 importance-sampling arrays and mesh-light CDFs",
            )),
            Table::Rows => Some(("row_at", "the microfacet materials' energy rows (Material::rows)")),
            _ => None,
        }
    }

    /// Bytes of one element of the storage form (a binding holds at least one).
    pub fn storage_element_bytes(self) -> usize {
        match self {
            Table::Indices | Table::Floats | Table::Rows => 4,
            _ => self.stride(),
        }
    }

    /// Bytes of one element of the WGSL array (uniform arrays need a 16-byte stride, so
    /// the indices and floats are held as vec4s).
    pub fn stride(self) -> usize {
        use std::mem::size_of;
        match self {
            Table::Shapes => size_of::<layout::Shape>(),
            Table::Indices | Table::Floats | Table::Rows => 16,
            Table::BvhNodes => size_of::<BvhNode>(),
            Table::CsgTrees => size_of::<layout::CsgTree>(),
            Table::Materials => size_of::<layout::Material>(),
            Table::Pigments => size_of::<layout::Pigment>(),
            Table::PointLights => size_of::<layout::PointLight>(),
            Table::AreaLights => size_of::<layout::AreaLight>(),
        }
    }

    /// Length of the uniform WGSL array.
    pub fn uniform_length(self) -> usize {
        UNIFORM_TABLE_BYTES / self.stride()
    }

    /// The packed table as bytes.
    pub fn bytes(self, p: &PackedScene) -> &[u8] {
        match self {
            Table::Shapes => bytemuck::cast_slice(&p.shapes),
            Table::Indices => bytemuck::cast_slice(&p.indices),
            Table::BvhNodes => bytemuck::cast_slice(&p.bvh_nodes),
            Table::CsgTrees => bytemuck::cast_slice(&p.csg_trees),
            Table::Materials => bytemuck::cast_slice(&p.materials),
            Table::Pigments => bytemuck::cast_slice(&p.pigments),
            Table::PointLights => bytemuck::cast_slice(&p.point_lights),
            Table::AreaLights => bytemuck::cast_slice(&p.area_lights),
            Table::Floats => bytemuck::cast_slice(&p.floats),
            Table::Rows => bytemuck::cast_slice(&p.rows),
        }
    }

    fn bit(self) -> u16 {
        1 << self as u16
    }
}

/// Which tables a render's kernels read from uniform buffers (the others: storage buffers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct UniformTables(u16);

/// How a render places its tables ([`super::render::GpuRenderOptions::tables`]; also
/// `lumen render --tables`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum TablePlacement {
    /// Uniform buffers on software adapters (where each table fits), storage elsewhere.
    #[default]
    Auto,
    /// Uniform buffers wherever a table fits, on any adapter (for measurements and tests).
    Uniform,
    /// Storage buffers only.
    Storage,
}

impl UniformTables {
    /// No table in a uniform buffer.
    pub const NONE: UniformTables = UniformTables(0);

    /// Every table in a uniform buffer (what a scene gets when all its tables fit).
    pub fn all() -> Self {
        Table::ALL.into_iter().fold(Self::NONE, |s, t| s.with(t))
    }

    pub fn with(self, t: Table) -> Self {
        UniformTables(self.0 | t.bit())
    }

    pub fn contains(self, t: Table) -> bool {
        self.0 & t.bit() != 0
    }

    /// The tables of `packed` to read from uniform buffers under `placement`, on an adapter
    /// of type `device` whose uniform bindings may hold `max_uniform_bytes`.
    ///
    /// ```
    /// use lumen::gpu::tables::{Table, TablePlacement, UniformTables};
    /// let mut b = lumen::scene::SceneBuilder::new(4, 4);
    /// let m = b.diffuse(lumen::color::Color::gray(0.5));
    /// b.sphere(lumen::scene::Transform::IDENTITY, m);
    /// let packed = lumen::gpu::pack::pack(&b.build().unwrap(), None).unwrap();
    /// let lavapipe = UniformTables::choose(&packed, TablePlacement::Auto, wgpu::DeviceType::Cpu, 65536);
    /// assert!(lavapipe.contains(Table::Shapes) && lavapipe.contains(Table::BvhNodes));
    /// let hardware = UniformTables::choose(&packed, TablePlacement::Auto, wgpu::DeviceType::DiscreteGpu, 65536);
    /// assert_eq!(hardware, UniformTables::NONE);
    /// ```
    pub fn choose(
        packed: &PackedScene,
        placement: TablePlacement,
        device: wgpu::DeviceType,
        max_uniform_bytes: u64,
    ) -> Self {
        let wanted = match placement {
            TablePlacement::Storage => false,
            TablePlacement::Uniform => true,
            TablePlacement::Auto => device == wgpu::DeviceType::Cpu,
        };
        if !wanted || max_uniform_bytes < UNIFORM_TABLE_BYTES as u64 {
            return Self::NONE;
        }
        Table::ALL
            .into_iter()
            .filter(|t| t.bytes(packed).len() <= UNIFORM_TABLE_BYTES)
            .fold(Self::NONE, |s, t| s.with(t))
    }

    /// The assembly features of the tables held in uniform buffers.
    pub fn names(self) -> Vec<&'static str> {
        Table::ALL.into_iter().filter(|t| self.contains(*t)).map(Table::feature).collect()
    }
}

/// The `scene_tables` WGSL module: for each table, guarded by the features that use it,
/// its uniform declaration (`UNIFORM_<TABLE>`, a fixed-length array of
/// `UNIFORM_<TABLE>_LEN` elements) or else its storage declaration, and for the u32 and f32
/// tables the accessor that reads either form.
pub fn tables_wgsl() -> String {
    let mut out = String::from(
        "// #provides scene_tables\n// #requires layout\n\
         // The scene's read-only tables in bind group 1, generated by src/gpu/tables.rs: uniform\n\
         // arrays where the render chose so (software adapters), else storage arrays.\n",
    );
    for t in Table::ALL {
        let (b, name, elem) = (t.binding(), t.wgsl_name(), t.wgsl_element());
        out += &format!("const {}: u32 = {}u;\n", t.length_constant(), t.uniform_length());
        for guard in t.declared_when() {
            out += &format!("// #if {guard}\n");
        }
        let packed = t.accessor().map(|(f, what)| (f, what, if elem == "u32" { "vec4<u32>" } else { "vec4<f32>" }));
        if let Some((_, what, _)) = packed {
            out += &format!("// {}: {what}.\n", name);
        }
        let uniform_elem = packed.map_or(elem, |(_, _, v)| v);
        out += &format!(
            "// #if {}\n@group(1) @binding({b}) var<uniform> {name}: array<{uniform_elem}, {}>;\n",
            t.feature(),
            t.length_constant()
        );
        if let Some((f, _, _)) = packed {
            out += &format!("\nfn {f}(k: u32) -> {elem} {{\n    return {name}[k >> 2u][k & 3u];\n}}\n");
        }
        out += &format!("// #else\n@group(1) @binding({b}) var<storage, read> {name}: array<{elem}>;\n");
        if let Some((f, _, _)) = packed {
            out += &format!("\nfn {f}(k: u32) -> {elem} {{\n    return {name}[k];\n}}\n");
        }
        out += "// #endif\n";
        for _ in t.declared_when() {
            out += "// #endif\n";
        }
    }
    out
}

/// The contents of table `t`'s storage buffer: the packed table, or one zeroed element
/// when it is empty (a binding must hold one element of its array; kernels read by count).
pub fn storage_contents(t: Table, packed: &PackedScene) -> std::borrow::Cow<'_, [u8]> {
    let bytes = t.bytes(packed);
    if bytes.is_empty() {
        std::borrow::Cow::Owned(vec![0u8; t.storage_element_bytes()])
    } else {
        std::borrow::Cow::Borrowed(bytes)
    }
}

/// The contents of table `t`'s uniform buffer: the packed table zero-padded to the WGSL
/// array's full length (a uniform binding must hold the whole declared array).
pub fn uniform_contents(t: Table, packed: &PackedScene) -> Option<Vec<u8>> {
    let bytes = t.bytes(packed);
    if bytes.len() > UNIFORM_TABLE_BYTES {
        return None;
    }
    let mut out = vec![0u8; t.uniform_length() * t.stride()];
    out[..bytes.len()].copy_from_slice(bytes);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Color;
    use crate::scene::{SceneBuilder, Transform};

    #[test]
    fn uniform_arrays_have_16_byte_strides_and_fit_the_default_limit() {
        for t in Table::ALL {
            assert_eq!(t.stride() % 16, 0, "{t:?}: uniform arrays need a 16-byte stride");
            assert!(t.uniform_length() * t.stride() <= UNIFORM_TABLE_BYTES, "{t:?}");
            assert!(t.uniform_length() >= 1, "{t:?}");
            assert_eq!(Table::from_binding(t.binding()), Some(t));
        }
        let bindings: std::collections::BTreeSet<u32> = Table::ALL.iter().map(|t| t.binding()).collect();
        assert_eq!(bindings.len(), Table::ALL.len());
        assert_eq!(Table::Shapes.uniform_length(), 65536 / 112);
        assert_eq!(Table::Indices.uniform_length(), 4096);
    }

    fn spheres(n: usize) -> PackedScene {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        for i in 0..n {
            b.sphere(Transform::translation(glam::DVec3::new(3.0 * i as f64, 0.0, 0.0)), m);
        }
        crate::gpu::pack::pack(&b.build().unwrap(), None).unwrap()
    }

    #[test]
    fn tables_that_do_not_fit_stay_in_storage() {
        let small = spheres(3);
        let cpu = wgpu::DeviceType::Cpu;
        let all = UniformTables::choose(&small, TablePlacement::Auto, cpu, 1 << 16);
        assert_eq!(all, UniformTables::all());
        // 600 shapes of 112 bytes exceed 64 KiB; their BVH (< 2048 nodes) and material do not.
        let large = spheres(600);
        let some = UniformTables::choose(&large, TablePlacement::Auto, cpu, 1 << 16);
        assert!(!some.contains(Table::Shapes));
        assert!(some.contains(Table::BvhNodes) && some.contains(Table::Materials));
        assert!(uniform_contents(Table::Shapes, &large).is_none());
        let bytes = uniform_contents(Table::Materials, &large).unwrap();
        assert_eq!(bytes.len(), Table::Materials.uniform_length() * Table::Materials.stride());
        assert_eq!(&bytes[..large.materials.len() * 96], bytemuck::cast_slice::<_, u8>(&large.materials));
        assert!(bytes[large.materials.len() * 96..].iter().all(|b| *b == 0));
    }

    #[test]
    fn placement_follows_the_adapter_and_the_limit() {
        let p = spheres(2);
        let gpu = wgpu::DeviceType::DiscreteGpu;
        assert_eq!(UniformTables::choose(&p, TablePlacement::Auto, gpu, 1 << 16), UniformTables::NONE);
        assert_eq!(UniformTables::choose(&p, TablePlacement::Uniform, gpu, 1 << 16), UniformTables::all());
        let cpu = wgpu::DeviceType::Cpu;
        assert_eq!(UniformTables::choose(&p, TablePlacement::Storage, cpu, 1 << 16), UniformTables::NONE);
        // An adapter below WebGPU's default limit cannot hold the fixed-length arrays.
        assert_eq!(UniformTables::choose(&p, TablePlacement::Uniform, cpu, 16384), UniformTables::NONE);
        let names = UniformTables::NONE.with(Table::Shapes).with(Table::AreaLights).names();
        assert_eq!(names, ["UNIFORM_SHAPES", "UNIFORM_AREA_LIGHTS"]);
    }
}
