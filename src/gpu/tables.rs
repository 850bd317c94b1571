//! Where the kernels read the scene's read-only tables from: a storage buffer, a uniform
//! buffer of fixed length, or a texture (DESIGN.md "Scene tables").
//!
//! On llvmpipe (lavapipe) a storage-buffer load at an index that differs between lanes is
//! compiled into one branch and one scalar load per lane and word, while a uniform-buffer
//! load at any index is a straight-line gather and a `textureLoad` one call of a fetch
//! function compiled outside the kernel. Reading the small tables from uniform buffers
//! halved the cold compile time of cornell.sl and made it render 39 % faster there, and
//! reading the larger ones from textures in the shading stages cut the LLVM IR of
//! meshes.sl's and spheres_10k.sl's kernels by 6–10 % at the same render speed; the stages
//! that walk the BVH keep storage buffers, where a texel fetch (a call) runs slower
//! (BENCHMARKS.md). Hardware GPUs serve divergent uniform reads from a constant cache that
//! serialises them, so there the tables stay in storage buffers. A table goes in a uniform
//! buffer only when it fits one ([`UNIFORM_TABLE_BYTES`], WebGPU's default limit, which
//! every adapter offers), in a texture only when its rows fit the adapter's texture height.
//!
//! Each table is described here once: its binding, WGSL name, element type and accessor,
//! the features that declare it, and its bytes. [`tables_wgsl`] generates the declarations
//! in the three forms and the accessor every read goes through (for textures, built from
//! `shaders/layout.wgsl`'s member offsets), and the renderer uploads through
//! [`Table::bytes`], so no binding number or offset is written twice.

use super::layout;
use super::pack::PackedScene;
use crate::accel::QuantizedNode;

/// Bytes of every uniform table buffer: WebGPU's default `max_uniform_buffer_binding_size`.
/// The WGSL arrays have a fixed length, so the buffer always holds the whole array.
pub const UNIFORM_TABLE_BYTES: usize = 65536;

/// A read-only group-1 table that may live in a uniform buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Table {
    /// Placed primitives, mesh instances and CSG leaves ([`layout::Shape`]).
    Shapes,
    /// Object references (u32), packed four to a `vec4<u32>` in the uniform form.
    Indices,
    /// The quantized BVH nodes, top level then each mesh's ([`QuantizedNode`]).
    BvhNodes,
    /// The top-level CSG trees ([`layout::CsgTree`]).
    CsgTrees,
    /// [`layout::Material`], one per scene material.
    Materials,
    /// [`layout::Pigment`], two per material (its BSDF's and its emitted one).
    Pigments,
    /// [`layout::PointLight`], in the camera frame.
    PointLights,
    /// [`layout::AreaLight`], the emissive shapes next-event estimation samples.
    AreaLights,
    /// Texels and sampling tables (f32), packed four to a `vec4<f32>` in the uniform form.
    Floats,
    /// The microfacet materials' energy rows (f32), packed like `Floats`.
    Rows,
    /// Mesh triangles' object-space vertices (`layout::TRI_POSITION_VEC4S` vec4 each).
    TriPositions,
    /// Their vertex normals and uvs (`layout::TRI_SHADING_VEC4S` vec4 each).
    TriShading,
}

impl Table {
    /// Every table, in declaration order.
    pub const ALL: [Table; 12] = [
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
        Table::TriPositions,
        Table::TriShading,
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
            Table::TriPositions => 13,
            Table::TriShading => 14,
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
            Table::TriPositions => "UNIFORM_TRI_POSITIONS",
            Table::TriShading => "UNIFORM_TRI_SHADING",
        }
    }

    /// The assembly feature that declares the table as a texture.
    pub fn texture_feature(self) -> &'static str {
        match self {
            Table::Shapes => "TEXTURE_SHAPES",
            Table::Indices => "TEXTURE_INDICES",
            Table::BvhNodes => "TEXTURE_BVH_NODES",
            Table::CsgTrees => "TEXTURE_CSG_TREES",
            Table::Materials => "TEXTURE_MATERIALS",
            Table::Pigments => "TEXTURE_PIGMENTS",
            Table::PointLights => "TEXTURE_POINT_LIGHTS",
            Table::AreaLights => "TEXTURE_AREA_LIGHTS",
            Table::Floats => "TEXTURE_FLOATS",
            Table::Rows => "TEXTURE_ROWS",
            Table::TriPositions => "TEXTURE_TRI_POSITIONS",
            Table::TriShading => "TEXTURE_TRI_SHADING",
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
            Table::TriPositions => "tri_positions",
            Table::TriShading => "tri_shading",
        }
    }

    /// The table named for a person: its WGSL name and what it holds (errors).
    ///
    /// ```
    /// use lumen::gpu::tables::Table;
    /// assert_eq!(Table::Floats.described(), "the floats table (image texels and sampling tables)");
    /// ```
    pub fn described(self) -> String {
        let holds = match self {
            Table::Shapes => "shapes",
            Table::Indices => "object references",
            Table::BvhNodes => "BVH nodes",
            Table::CsgTrees => "CSG trees",
            Table::Materials => "materials",
            Table::Pigments => "pigments",
            Table::PointLights => "point lights",
            Table::AreaLights => "area lights",
            Table::Floats => "image texels and sampling tables",
            Table::Rows => "microfacet energy rows",
            Table::TriPositions => "mesh triangles' vertices",
            Table::TriShading => "mesh triangles' normals and uvs",
        };
        format!("the {} table ({holds})", self.wgsl_name())
    }

    /// The WGSL element type of the storage form (the uniform form packs u32 and f32 four
    /// to a vec4).
    fn wgsl_element(self) -> &'static str {
        match self {
            Table::Shapes => "Shape",
            Table::Indices => "u32",
            Table::BvhNodes => "QuantizedNode",
            Table::CsgTrees => "CsgTree",
            Table::Materials => "Material",
            Table::Pigments => "Pigment",
            Table::PointLights => "PointLight",
            Table::AreaLights => "AreaLight",
            Table::Floats | Table::Rows => "f32",
            Table::TriPositions | Table::TriShading => "vec4<f32>",
        }
    }

    /// The assembly features under which a kernel declares the table (all must hold).
    fn declared_when(self) -> &'static [&'static str] {
        match self {
            Table::Shapes => &["GEOMETRY"],
            Table::Indices => &["OBJECT_REFS"],
            Table::BvhNodes => &["BVH"],
            // Where trees are evaluated, and object lists (their bounds).
            Table::CsgTrees => &["CSG_TREES"],
            Table::Materials => &["MATERIALS"],
            Table::Pigments => &["PIGMENTS"],
            Table::PointLights => &["POINT_LIGHTS"],
            Table::AreaLights => &["AREA_LIGHTS"],
            Table::Floats => &["TEXTURES"],
            Table::Rows => &["ENERGY_ROWS"],
            Table::TriPositions => &["MESH"],
            Table::TriShading => &["MESH", "SHADING"],
        }
    }

    /// The function every read of an element goes through, whatever the table's form.
    pub fn accessor(self) -> &'static str {
        match self {
            Table::Shapes => "shape_at",
            Table::Indices => "object_ref",
            Table::BvhNodes => "bvh_node_at",
            Table::CsgTrees => "csg_tree_at",
            Table::Materials => "material_at",
            Table::Pigments => "pigment_at",
            Table::PointLights => "point_light_at",
            Table::AreaLights => "area_light_at",
            Table::Floats => "float_at",
            Table::Rows => "row_at",
            Table::TriPositions => "tri_position_at",
            Table::TriShading => "tri_shading_at",
        }
    }

    /// For the u32 and f32 tables, held four to a vec4 in the uniform and texture forms:
    /// what the table holds.
    fn packed(self) -> Option<&'static str> {
        match self {
            Table::Indices => Some("BVH leaf object references from 0, then the plane list and CSG children"),
            Table::Floats => Some(
                "texels (rgb triples) of image pigments and the environment, the environment's \
                 importance-sampling arrays and mesh-light CDFs",
            ),
            Table::Rows => Some("the microfacet materials' energy rows (Material::rows)"),
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
            Table::Indices | Table::Floats | Table::Rows | Table::TriPositions | Table::TriShading => 16,
            Table::BvhNodes => size_of::<QuantizedNode>(),
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
            Table::TriPositions => bytemuck::cast_slice(&p.tri_positions),
            Table::TriShading => bytemuck::cast_slice(&p.tri_shading),
        }
    }

    fn bit(self) -> u16 {
        1 << self as u16
    }
}

/// How a kernel reads one table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TableForm {
    /// A runtime-sized storage array (hardware GPUs; any table).
    Storage,
    /// A fixed-length uniform array of [`UNIFORM_TABLE_BYTES`] (software adapters, small
    /// tables).
    Uniform,
    /// A 2D `rgba32uint` texture of [`TEXTURE_ROW_TEXELS`]-texel rows read with
    /// `textureLoad` (software adapters, tables too large for a uniform buffer).
    Texture,
}

/// Which tables a render's kernels read from uniform buffers and which from textures (the
/// others: storage buffers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct TableForms {
    uniform: u16,
    texture: u16,
    /// Whether the stages that walk the BVH or evaluate CSG trees read the texture tables
    /// as textures too; else they read them from storage buffers ([`Self::for_stage`]).
    hot_textures: bool,
}

/// How a render places its tables ([`super::render::GpuRenderOptions::tables`]; also
/// `lumen render --tables`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum TablePlacement {
    /// On software adapters a uniform buffer for each table that fits one and, for each
    /// larger one, a texture in the stages that read it a few times per path vertex and a
    /// storage buffer in those that walk the BVH or evaluate CSG trees (a texel fetch is a
    /// call, slower there: DESIGN.md "Scene tables"), except `floats`, whose CDFs are
    /// binary-searched (a storage buffer when large); storage buffers on hardware GPUs.
    #[default]
    Auto,
    /// Uniform buffers wherever a table fits, storage buffers elsewhere, on any adapter
    /// (for measurements and tests).
    Uniform,
    /// Textures for every table that fits the adapter's texture size, in every stage, on
    /// any adapter (for measurements and tests).
    Texture,
    /// Storage buffers only.
    Storage,
}

/// What the adapter allows the table forms: the bytes of a uniform binding and the rows
/// of a 2D texture (0: no texture tables on this adapter).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableLimits {
    /// The adapter's `max_uniform_buffer_binding_size`, in bytes: uniform tables need at
    /// least [`UNIFORM_TABLE_BYTES`].
    pub max_uniform_bytes: u64,
    /// The most rows of [`TEXTURE_ROW_TEXELS`] texels a table texture may have (the
    /// adapter's `max_texture_dimension_2d`); 0 disables texture tables.
    pub max_texture_rows: u32,
}

impl TableLimits {
    /// The limits of an adapter with `limits`, named by `info`: no texture rows where its
    /// texel fetches are not trusted ([`crate::gpu::texel_fetches_trusted`]).
    pub fn of(limits: &wgpu::Limits, info: &wgpu::AdapterInfo) -> Self {
        Self::from_limits(limits, crate::gpu::texel_fetches_trusted(info))
    }

    /// WebGPU's defaults, which every adapter offers.
    pub fn webgpu_default() -> Self {
        Self::from_limits(&wgpu::Limits::default(), true)
    }

    fn from_limits(limits: &wgpu::Limits, textures: bool) -> Self {
        TableLimits {
            max_uniform_bytes: limits.max_uniform_buffer_binding_size,
            max_texture_rows: if textures { limits.max_texture_dimension_2d } else { 0 },
        }
    }
}

impl TableForms {
    /// Every table in a storage buffer.
    pub const NONE: TableForms = TableForms { uniform: 0, texture: 0, hot_textures: false };

    /// Every table in form `form`, in every stage (as [`TablePlacement::Uniform`] or
    /// [`TablePlacement::Texture`] places a scene's tables that fit).
    pub fn all(form: TableForm) -> Self {
        Table::ALL.into_iter().fold(Self::NONE, |s, t| s.with(t, form)).with_hot_textures(form == TableForm::Texture)
    }

    /// This placement with table `t` in form `form`.
    pub fn with(self, t: Table, form: TableForm) -> Self {
        let (uniform, texture) = (self.uniform & !t.bit(), self.texture & !t.bit());
        let hot_textures = self.hot_textures;
        match form {
            TableForm::Storage => TableForms { uniform, texture, hot_textures },
            TableForm::Uniform => TableForms { uniform: uniform | t.bit(), texture, hot_textures },
            TableForm::Texture => TableForms { uniform, texture: texture | t.bit(), hot_textures },
        }
    }

    /// This placement, with the texture tables read as textures also by the stages that
    /// walk the BVH or evaluate CSG trees (`hot`) or not.
    pub fn with_hot_textures(self, hot: bool) -> Self {
        TableForms { hot_textures: hot, ..self }
    }

    /// The placement a stage's kernel reads: the texture tables are storage buffers in a
    /// stage that walks the BVH or evaluates CSG trees (`hot`), unless the placement asked
    /// for textures there too.
    pub fn for_stage(self, hot: bool) -> Self {
        if hot && !self.hot_textures {
            TableForms { texture: 0, ..self }
        } else {
            self
        }
    }

    /// The form of table `t`.
    pub fn form(self, t: Table) -> TableForm {
        if self.uniform & t.bit() != 0 {
            TableForm::Uniform
        } else if self.texture & t.bit() != 0 {
            TableForm::Texture
        } else {
            TableForm::Storage
        }
    }

    /// The forms for the tables of `packed` under `placement`, on an adapter of type
    /// `device` with `limits`.
    ///
    /// ```
    /// use lumen::gpu::tables::{Table, TableForm, TableForms, TableLimits, TablePlacement};
    /// let mut b = lumen::scene::SceneBuilder::new(4, 4);
    /// let m = b.diffuse(lumen::color::Color::gray(0.5));
    /// b.sphere(lumen::scene::Transform::IDENTITY, m);
    /// let packed = lumen::gpu::pack::pack(&b.build().unwrap(), None).unwrap();
    /// let limits = TableLimits::webgpu_default();
    /// let lavapipe = TableForms::choose(&packed, TablePlacement::Auto, wgpu::DeviceType::Cpu, limits);
    /// assert_eq!(lavapipe.form(Table::Shapes), TableForm::Uniform);
    /// let hardware = TableForms::choose(&packed, TablePlacement::Auto, wgpu::DeviceType::DiscreteGpu, limits);
    /// assert_eq!(hardware, TableForms::NONE);
    /// ```
    pub fn choose(
        packed: &PackedScene,
        placement: TablePlacement,
        device: wgpu::DeviceType,
        limits: TableLimits,
    ) -> Self {
        let (uniform, texture) = match placement {
            TablePlacement::Storage => (false, false),
            TablePlacement::Uniform => (true, false),
            TablePlacement::Texture => (false, true),
            TablePlacement::Auto => (device == wgpu::DeviceType::Cpu, device == wgpu::DeviceType::Cpu),
        };
        let uniform = uniform && limits.max_uniform_bytes >= UNIFORM_TABLE_BYTES as u64;
        let forced = placement == TablePlacement::Texture;
        let forms = Self::NONE.with_hot_textures(forced);
        Table::ALL.into_iter().fold(forms, |s, t| {
            let bytes = t.bytes(packed).len();
            // `floats` is binary-searched (the environment's and mesh lights' CDFs): a
            // texel fetch per step of a loop runs slower than the storage load it replaces.
            let fetched = forced || t != Table::Floats;
            if uniform && bytes <= UNIFORM_TABLE_BYTES {
                s.with(t, TableForm::Uniform)
            } else if texture && fetched && texture_rows(bytes) <= limits.max_texture_rows as usize {
                s.with(t, TableForm::Texture)
            } else {
                s
            }
        })
    }

    /// The assembly features of the tables held in uniform buffers and textures.
    pub fn names(self) -> Vec<&'static str> {
        Table::ALL
            .into_iter()
            .filter_map(|t| match self.form(t) {
                TableForm::Storage => None,
                TableForm::Uniform => Some(t.feature()),
                TableForm::Texture => Some(t.texture_feature()),
            })
            .collect()
    }
}

/// Texels (16 bytes each) in one row of a table texture: the element at texel index k is at
/// (k mod 4096, k / 4096), a mask and a shift in WGSL.
pub const TEXTURE_ROW_TEXELS: usize = 4096;

/// Rows of the texture holding `bytes` (at least one).
fn texture_rows(bytes: usize) -> usize {
    bytes.div_ceil(16 * TEXTURE_ROW_TEXELS).max(1)
}

/// The `scene_tables` WGSL module: for each table, guarded by the features that use it,
/// its uniform declaration (`UNIFORM_<TABLE>`, a fixed-length array of
/// `UNIFORM_<TABLE>_LEN` elements), its texture declaration (`TEXTURE_<TABLE>`) or else
/// its storage declaration, and the accessor every read goes through ([`Table::accessor`]),
/// which in the texture form assembles the element from its texels, member by member, as
/// `shaders/layout.wgsl` lays it out. The text depends on no scene, so it is generated once
/// per process (every stage of every render assembles with it).
pub fn tables_wgsl() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(generate_tables_wgsl)
}

fn generate_tables_wgsl() -> String {
    let layout = naga::front::wgsl::parse_str(layout::LAYOUT_WGSL).expect("shaders/layout.wgsl parses");
    let mut out = String::from(
        "// #provides scene_tables\n// #requires layout\n\
         // The scene's read-only tables in bind group 1, generated by src/gpu/tables.rs: uniform\n\
         // arrays or textures where the render chose so (software adapters), else storage arrays.\n",
    );
    for t in Table::ALL {
        let (b, name, elem, f) = (t.binding(), t.wgsl_name(), t.wgsl_element(), t.accessor());
        out += &format!("\nconst {}: u32 = {}u;\n", t.length_constant(), t.uniform_length());
        for guard in t.declared_when() {
            out += &format!("// #if {guard}\n");
        }
        let vec4 = if elem == "u32" { "vec4<u32>" } else { "vec4<f32>" };
        if let Some(what) = t.packed() {
            out += &format!("// {name}: {what}.\n");
        }
        // 16-byte elements in 64-bit words where the render holds its words wide (DESIGN.md
        // "Wide words"), in the uniform and the storage form alike: llvmpipe gathers a
        // lane-dependent uniform load and checks its bounds word by word too. The u32 and f32
        // tables, read a word at a time, gain nothing from them. `buffer_form` gives a buffer
        // form's declaration and accessor: `narrow` alone, or under `WIDE_WORDS` an array of
        // `vec2<u64>` in address space `space` (of `length`, e.g. ", 4096"; "" for a
        // runtime-sized one) with the accessor rebuilding the element from its words.
        let buffer_form = |space: &str, length: &str, narrow: String| {
            if t.packed().is_some() {
                return narrow;
            }
            let read = element_from_texels(&layout, t, elem, &|i| format!("words_of({name}[{i}])"));
            format!(
                "// #if WIDE_WORDS\n// #requires words_of\n@group(1) @binding({b}) var<{space}> {name}: array<vec2<u64>{length}>;\n\nfn {f}(k: u32) -> {elem} {{\n{read}}}\n// #else\n{narrow}// #endif\n"
            )
        };
        let uniform_elem = if t.packed().is_some() { vec4 } else { elem };
        let uniform_read = if t.packed().is_some() { format!("{name}[k >> 2u][k & 3u]") } else { format!("{name}[k]") };
        let words = t.uniform_length() * t.stride() / 16;
        out += &format!("// #if {}\n", t.feature());
        out += &buffer_form(
            "uniform",
            &format!(", {words}"),
            format!(
                "@group(1) @binding({b}) var<uniform> {name}: array<{uniform_elem}, {}>;\n\nfn {f}(k: u32) -> {elem} {{\n    return {uniform_read};\n}}\n",
                t.length_constant()
            ),
        );
        let texture_read = if t.packed().is_some() {
            let word = format!("{}[k & 3u]", texel_load(name, "k >> 2u"));
            let value = if elem == "u32" { word } else { format!("bitcast<f32>({word})") };
            format!("    return {value};\n")
        } else {
            element_from_texels(&layout, t, elem, &|i| texel_load(name, i))
        };
        out += &format!(
            "// #else\n// #if {}\n@group(1) @binding({b}) var {name}: texture_2d<u32>;\n\nfn {f}(k: u32) -> {elem} {{\n{texture_read}}}\n",
            t.texture_feature()
        );
        out += "// #else\n";
        out += &buffer_form(
            "storage, read",
            "",
            format!(
                "@group(1) @binding({b}) var<storage, read> {name}: array<{elem}>;\n\nfn {f}(k: u32) -> {elem} {{\n    return {name}[k];\n}}\n"
            ),
        );
        out += "// #endif\n// #endif\n";
        for _ in t.declared_when() {
            out += "// #endif\n";
        }
    }
    out
}

/// The body of an accessor of struct or vec4 table `t` that reads its element k as 16-byte
/// words (a texture's texels, or pairs of 64-bit words): each word (a `vec4<u32>`, loaded
/// by the WGSL that `load` gives for its index expression), then the element built from
/// them.
fn element_from_texels(layout: &naga::Module, t: Table, elem: &str, load: &dyn Fn(&str) -> String) -> String {
    let texels = t.stride() / 16;
    let mut body = format!("    let base = k * {texels}u;\n");
    for i in 0..texels {
        body += &format!("    let t{i} = {};\n", load(&format!("base + {i}u")));
    }
    let value = if elem == "vec4<f32>" {
        "bitcast<vec4<f32>>(t0)".to_string()
    } else {
        let (handle, _) = layout
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some(elem))
            .unwrap_or_else(|| panic!("struct {elem} is not in shaders/layout.wgsl"));
        decode(layout, handle, 0)
    };
    body + &format!("    return {value};\n")
}

/// WGSL loading texel `index` (an expression) of table texture `name`: column index mod
/// [`TEXTURE_ROW_TEXELS`], row index / [`TEXTURE_ROW_TEXELS`].
fn texel_load(name: &str, index: &str) -> String {
    let (mask, shift) = (TEXTURE_ROW_TEXELS - 1, TEXTURE_ROW_TEXELS.trailing_zeros());
    format!("textureLoad({name}, vec2<u32>(({index}) & {mask}u, ({index}) >> {shift}u), 0)")
}

/// WGSL building a value of type `ty` from the texel words at byte `offset` (`t<i>.xyzw`).
fn decode(module: &naga::Module, ty: naga::Handle<naga::Type>, offset: u32) -> String {
    use naga::TypeInner;
    let word = |o: u32| format!("t{}.{}", o / 16, ["x", "y", "z", "w"][(o % 16 / 4) as usize]);
    let scalar = |s: naga::Scalar, o: u32| match s.kind {
        naga::ScalarKind::Uint => word(o),
        naga::ScalarKind::Sint => format!("bitcast<i32>({})", word(o)),
        naga::ScalarKind::Float => format!("bitcast<f32>({})", word(o)),
        other => panic!("a table holds no {other:?}"),
    };
    let ty = &module.types[ty];
    match &ty.inner {
        TypeInner::Scalar(s) => scalar(*s, offset),
        TypeInner::Vector { size, scalar: s } => {
            let n = *size as u32;
            let parts: Vec<String> = (0..n).map(|i| scalar(*s, offset + 4 * i)).collect();
            format!("vec{n}<{}>({})", scalar_name(*s), parts.join(", "))
        }
        TypeInner::Struct { members, .. } => {
            let parts: Vec<String> = members.iter().map(|m| decode(module, m.ty, offset + m.offset)).collect();
            format!("{}({})", ty.name.as_deref().expect("structs are named"), parts.join(", "))
        }
        TypeInner::Array { base, size: naga::ArraySize::Constant(n), stride } => {
            let parts: Vec<String> = (0..n.get()).map(|i| decode(module, *base, offset + i * stride)).collect();
            let base_name = wgsl_type(module, *base);
            format!("array<{base_name}, {n}>({})", parts.join(", "))
        }
        other => panic!("no texture decoding for {other:?}"),
    }
}

fn scalar_name(s: naga::Scalar) -> &'static str {
    match s.kind {
        naga::ScalarKind::Uint => "u32",
        naga::ScalarKind::Sint => "i32",
        _ => "f32",
    }
}

fn wgsl_type(module: &naga::Module, ty: naga::Handle<naga::Type>) -> String {
    let ty = &module.types[ty];
    match &ty.inner {
        naga::TypeInner::Scalar(s) => scalar_name(*s).into(),
        naga::TypeInner::Vector { size, scalar } => format!("vec{}<{}>", *size as u32, scalar_name(*scalar)),
        _ => ty.name.clone().expect("named type"),
    }
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

    fn limits(max_uniform_bytes: u64, max_texture_rows: u32) -> TableLimits {
        TableLimits { max_uniform_bytes, max_texture_rows }
    }

    #[test]
    fn tables_too_large_for_a_uniform_buffer_become_textures() {
        let small = spheres(3);
        let cpu = wgpu::DeviceType::Cpu;
        let all = TableForms::choose(&small, TablePlacement::Auto, cpu, limits(1 << 16, 8192));
        assert_eq!(all, TableForms::all(TableForm::Uniform));
        // 600 shapes of 112 bytes exceed 64 KiB; their BVH (< 2048 nodes) and material do not.
        let large = spheres(600);
        let some = TableForms::choose(&large, TablePlacement::Auto, cpu, limits(1 << 16, 8192));
        assert_eq!(some.form(Table::Shapes), TableForm::Texture);
        assert_eq!(some.form(Table::BvhNodes), TableForm::Uniform);
        assert_eq!(some.form(Table::Materials), TableForm::Uniform);
        // Where the uniform placement is asked for, the shapes stay in storage.
        let uniform = TableForms::choose(&large, TablePlacement::Uniform, cpu, limits(1 << 16, 8192));
        assert_eq!(uniform.form(Table::Shapes), TableForm::Storage);
        assert!(uniform_contents(Table::Shapes, &large).is_none());
        let bytes = uniform_contents(Table::Materials, &large).unwrap();
        assert_eq!(bytes.len(), Table::Materials.uniform_length() * Table::Materials.stride());
        assert_eq!(&bytes[..large.materials.len() * 96], bytemuck::cast_slice::<_, u8>(&large.materials));
        assert!(bytes[large.materials.len() * 96..].iter().all(|b| *b == 0));
        // 600 × 112 bytes = 4200 texels: two rows of 4096 (Gpu::u32_texture pads the last).
        assert_eq!(texture_rows(Table::Shapes.bytes(&large).len()), 2);
        assert_eq!((texture_rows(0), texture_rows(16 * 4096), texture_rows(16 * 4096 + 4)), (1, 1, 2));
        // Large `floats` (an image environment's texels and CDFs) stay in storage: they are
        // binary-searched, faster from storage. Only the texture placement moves them.
        let mut sky = spheres(3);
        sky.floats = vec![0.5; 20_000];
        let auto = TableForms::choose(&sky, TablePlacement::Auto, cpu, limits(1 << 16, 8192));
        assert_eq!((auto.form(Table::Floats), auto.form(Table::Shapes)), (TableForm::Storage, TableForm::Uniform));
        let forced = TableForms::choose(&sky, TablePlacement::Texture, cpu, limits(1 << 16, 8192));
        assert_eq!(forced.form(Table::Floats), TableForm::Texture);
        // A table taller than the adapter's textures stays in storage.
        let low = TableForms::choose(&large, TablePlacement::Texture, cpu, limits(1 << 16, 1));
        assert_eq!((low.form(Table::Shapes), low.form(Table::Materials)), (TableForm::Storage, TableForm::Texture));
    }

    #[test]
    fn placement_follows_the_adapter_and_the_limit() {
        let p = spheres(2);
        let webgpu = TableLimits::webgpu_default();
        let gpu = wgpu::DeviceType::DiscreteGpu;
        assert_eq!(TableForms::choose(&p, TablePlacement::Auto, gpu, webgpu), TableForms::NONE);
        assert_eq!(TableForms::choose(&p, TablePlacement::Uniform, gpu, webgpu), TableForms::all(TableForm::Uniform));
        assert_eq!(TableForms::choose(&p, TablePlacement::Texture, gpu, webgpu), TableForms::all(TableForm::Texture));
        let cpu = wgpu::DeviceType::Cpu;
        assert_eq!(TableForms::choose(&p, TablePlacement::Storage, cpu, webgpu), TableForms::NONE);
        // An adapter below WebGPU's default limit cannot hold the fixed-length arrays.
        assert_eq!(TableForms::choose(&p, TablePlacement::Uniform, cpu, limits(16384, 8192)), TableForms::NONE);
        let f = TableForms::NONE.with(Table::Shapes, TableForm::Texture).with(Table::AreaLights, TableForm::Uniform);
        assert_eq!(f.names(), ["TEXTURE_SHAPES", "UNIFORM_AREA_LIGHTS"]);
        assert_eq!(f.with(Table::Shapes, TableForm::Storage).names(), ["UNIFORM_AREA_LIGHTS"]);
        // The stages that walk the BVH read the textures' tables from storage, unless the
        // texture placement was asked for.
        assert_eq!(f.for_stage(false), f);
        assert_eq!(f.for_stage(true).names(), ["UNIFORM_AREA_LIGHTS"]);
        assert_eq!(f.with_hot_textures(true).for_stage(true).names(), ["TEXTURE_SHAPES", "UNIFORM_AREA_LIGHTS"]);
        let large = spheres(600);
        let auto = TableForms::choose(&large, TablePlacement::Auto, cpu, webgpu);
        assert_eq!(auto.for_stage(true).form(Table::Shapes), TableForm::Storage);
        let texture = TableForms::choose(&large, TablePlacement::Texture, cpu, webgpu);
        assert_eq!(texture.for_stage(true).form(Table::Shapes), TableForm::Texture);
    }

    /// An adapter whose texel fetches are not trusted (Mesa 26.1's llvmpipe, at any width)
    /// gets no texture rows, so its tables stay in buffers, even where textures are asked for.
    #[test]
    fn untrusted_texel_fetches_keep_the_tables_in_buffers() {
        let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
        info.name = "llvmpipe (LLVM 19.1.7, 256 bits)".into();
        info.driver_info = "Mesa 26.1.6-1~bpo13+1 (LLVM 19.1.7)".into();
        let wgpu_limits = wgpu::Limits::default();
        let untrusted = TableLimits::of(&wgpu_limits, &info);
        assert_eq!(untrusted, limits(wgpu_limits.max_uniform_buffer_binding_size, 0));
        let large = spheres(600);
        let cpu = wgpu::DeviceType::Cpu;
        let auto = TableForms::choose(&large, TablePlacement::Auto, cpu, untrusted);
        assert_eq!((auto.form(Table::Shapes), auto.form(Table::Materials)), (TableForm::Storage, TableForm::Uniform));
        let forced = TableForms::choose(&large, TablePlacement::Texture, cpu, untrusted);
        assert_eq!(forced, TableForms::NONE.with_hot_textures(true));
        // The same driver at 128 bits too (it crashed there on an AMD Zen 4 host).
        info.name = "llvmpipe (LLVM 19.1.7, 128 bits)".into();
        assert_eq!(TableLimits::of(&wgpu_limits, &info), untrusted);
        // Mesa 25.0 at 128 and 256 bits, and every hardware driver keep them.
        for (name, driver) in [
            ("llvmpipe (LLVM 15.0.6, 128 bits)", "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"),
            ("llvmpipe (LLVM 15.0.6, 256 bits)", "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"),
            ("NVIDIA H200", "580.159.04"),
        ] {
            (info.name, info.driver_info) = (name.into(), driver.into());
            assert_eq!(TableLimits::of(&wgpu_limits, &info), TableLimits::webgpu_default(), "{name}");
        }
    }

    /// The texture accessors rebuild each struct from the words at its members' offsets
    /// (shaders/layout.wgsl, checked against Rust by layout's tests): a BVH node is two
    /// texels, the corner in the first three words of the first, the grid in the second's.
    /// The wide forms read the same words as pairs of 64-bit words, from a uniform array of
    /// the same bytes as the narrow one.
    #[test]
    fn texture_accessors_read_members_at_their_offsets() {
        let wgsl = tables_wgsl();
        // A struct table's accessor in its forms: uniform wide and narrow, texture, storage
        // wide and narrow.
        let forms: Vec<&str> = wgsl
            .split("fn bvh_node_at(k: u32) -> QuantizedNode {")
            .skip(1)
            .map(|f| f.split("\n}").next().unwrap())
            .collect();
        assert_eq!(forms.len(), 5, "{forms:?}");
        let node = forms[2];
        let uniform_words = Table::BvhNodes.uniform_length() * Table::BvhNodes.stride() / 16;
        assert_eq!(uniform_words * 16, UNIFORM_TABLE_BYTES);
        let wide_uniform = format!("var<uniform> bvh_nodes: array<vec2<u64>, {uniform_words}>;");
        assert!(wgsl.contains(&wide_uniform), "{wide_uniform}");
        for wide in [forms[0], forms[3]] {
            assert!(wide.contains("let t1 = words_of(bvh_nodes[base + 1u]);"), "{wide}");
            assert!(wide.contains("vec3<u32>(t1.x, t1.y, t1.z), t1.w);"), "{wide}");
        }
        assert!(node.contains("let base = k * 2u;"), "{node}");
        assert!(
            node.contains(
                "return QuantizedNode(vec3<f32>(bitcast<f32>(t0.x), bitcast<f32>(t0.y), bitcast<f32>(t0.z)), t0.w, \
                 vec3<u32>(t1.x, t1.y, t1.z), t1.w);"
            ),
            "{node}"
        );
        let floats = wgsl.split("fn float_at(k: u32) -> f32 {").nth(2).unwrap().split("\n}").next().unwrap();
        assert!(
            floats.contains(
                "bitcast<f32>(textureLoad(floats, vec2<u32>((k >> 2u) & 4095u, (k >> 2u) >> 12u), 0)[k & 3u])"
            ),
            "{floats}"
        );
        let t1 = "let t1 = textureLoad(bvh_nodes, vec2<u32>((base + 1u) & 4095u, (base + 1u) >> 12u), 0);";
        assert!(node.contains(t1), "{node}");
    }
}
