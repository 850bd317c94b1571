//! What a memory access costs a compute kernel on the selected adapter, to compile and to
//! run: the measurements behind DESIGN.md's "Uniform scene tables" and "Path-state
//! accesses" (on llvmpipe, compile time grows with the number of storage-access *sites*).
//!
//! Each variant is a kernel of `--sites` (default 32) accesses at lane-divergent indices
//! (an LCG per invocation), run once on one workgroup (on lavapipe that first dispatch
//! holds the JIT compile) and then timed over 2^20 invocations.
//!
//! Run: `MESA_SHADER_CACHE_DISABLE=true cargo run --release --example access_costs [SITES]`
//! (the variable makes every run compile cold; `LUMEN_ADAPTER` picks the adapter).

use std::time::Instant;

use lumen::gpu::{AdapterChoice, Gpu};

/// Elements (vec4) of the storage buffer and texture; the uniform array holds 64 KiB.
const ELEMENTS: u32 = 1 << 16;
const INVOCATIONS: u32 = 1 << 20;

#[derive(Clone, Copy, PartialEq)]
enum Variant {
    StorageLoad,
    UniformLoad,
    TextureLoad,
    StorageStore,
    TextureStore,
    /// One storage load site in a loop whose trip count is a uniform (not unrolled).
    StorageLoadLoop,
    /// Eight fields of one slot (structure of arrays) loaded by eight sites...
    FieldsDirect,
    /// ... by one site in a loop into a private array ...
    FieldsPrivateArray,
    /// ... or by one site in a loop selecting into eight variables.
    FieldsSelect,
}

impl Variant {
    const ALL: [Variant; 9] = [
        Variant::StorageLoad,
        Variant::UniformLoad,
        Variant::TextureLoad,
        Variant::StorageStore,
        Variant::TextureStore,
        Variant::StorageLoadLoop,
        Variant::FieldsDirect,
        Variant::FieldsPrivateArray,
        Variant::FieldsSelect,
    ];

    fn name(self) -> &'static str {
        match self {
            Variant::StorageLoad => "storage load",
            Variant::UniformLoad => "uniform load",
            Variant::TextureLoad => "texture load (textureLoad)",
            Variant::StorageStore => "storage store",
            Variant::TextureStore => "storage-texture store",
            Variant::StorageLoadLoop => "storage load, one site in a loop",
            Variant::FieldsDirect => "8 fields, 8 load sites",
            Variant::FieldsPrivateArray => "8 fields, 1 site, private array",
            Variant::FieldsSelect => "8 fields, 1 site, selects",
        }
    }

    /// Accesses per invocation.
    fn accesses(self, sites: u32) -> u32 {
        match self {
            Variant::FieldsDirect | Variant::FieldsPrivateArray | Variant::FieldsSelect => 8,
            _ => sites,
        }
    }

    fn source(self, sites: u32) -> String {
        let data = match self {
            Variant::StorageLoad
            | Variant::StorageLoadLoop
            | Variant::FieldsDirect
            | Variant::FieldsPrivateArray
            | Variant::FieldsSelect => "var<storage, read> data: array<vec4<f32>>;",
            Variant::UniformLoad => "var<uniform> data: array<vec4<f32>, 4096>;",
            Variant::TextureLoad => "var data: texture_2d<f32>;",
            Variant::StorageStore => "var<storage, read_write> data: array<vec4<f32>>;",
            Variant::TextureStore => "var data: texture_storage_2d<rgba32float, write>;",
        };
        let step = "idx = idx * 1664525u + 1013904223u;";
        let mut body = String::new();
        let mut repeat = |access: &str| {
            for _ in 0..sites {
                body += &format!("    {step}\n    {access}\n");
            }
        };
        match self {
            Variant::StorageLoad => repeat("acc += data[idx % 65536u]; idx ^= bitcast<u32>(acc.x) & 1023u;"),
            Variant::UniformLoad => repeat("acc += data[idx % 4096u]; idx ^= bitcast<u32>(acc.x) & 1023u;"),
            Variant::TextureLoad => repeat(
                "acc += textureLoad(data, vec2<u32>(idx % 256u, (idx >> 8u) % 256u), 0); idx ^= bitcast<u32>(acc.x) & 1023u;",
            ),
            Variant::StorageStore => repeat("acc += vec4<f32>(f32(idx)); data[idx % 65536u] = acc;"),
            Variant::TextureStore => {
                repeat("acc += vec4<f32>(f32(idx)); textureStore(data, vec2<u32>(idx % 256u, (idx >> 8u) % 256u), acc);")
            }
            Variant::StorageLoadLoop => {
                body += &format!(
                    "    for (var i = 0u; i < n.x; i++) {{\n        {step}\n        acc += data[idx % 65536u]; idx ^= bitcast<u32>(acc.x) & 1023u;\n    }}\n"
                )
            }
            Variant::FieldsDirect => {
                body += "    var st: array<vec4<f32>, 8>;\n";
                for f in 0..8 {
                    body += &format!("    st[{f}] = data[{f}u * 8192u + slot];\n");
                }
            }
            Variant::FieldsPrivateArray => {
                body += "    var st: array<vec4<f32>, 8>;\n    for (var f = 0u; f < n.y; f++) {\n        st[f] = data[f * 8192u + slot];\n    }\n";
            }
            Variant::FieldsSelect => {
                body += "    var s0 = vec4<f32>(0.0);\n    var s1 = s0;\n    var s2 = s0;\n    var s3 = s0;\n    var s4 = s0;\n    var s5 = s0;\n    var s6 = s0;\n    var s7 = s0;\n";
                body += "    for (var f = 0u; f < n.y; f++) {\n        let v = data[f * 8192u + slot];\n";
                for f in 0..8 {
                    body += &format!("        s{f} = select(s{f}, v, f == {f}u);\n");
                }
                body += "    }\n    let st = array<vec4<f32>, 8>(s0, s1, s2, s3, s4, s5, s6, s7);\n";
            }
        }
        if matches!(self, Variant::FieldsDirect | Variant::FieldsPrivateArray | Variant::FieldsSelect) {
            body += "    acc = st[0] * st[1] + st[2] * st[3] + st[4] * st[5] + st[6] * st[7];\n";
        }
        format!(
            "@group(0) @binding(0) {data}\n\
             @group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;\n\
             @group(0) @binding(2) var<uniform> n: vec4<u32>;\n\
             @compute @workgroup_size(64)\n\
             fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{\n\
             \x20   var idx = gid.x * 2654435761u;\n\
             \x20   let slot = idx % 8192u;\n\
             \x20   var acc = vec4<f32>(f32(n.z));\n{body}\
             \x20   out[gid.x] = acc;\n}}\n"
        )
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let sites: u32 = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(32);
    let gpu = Gpu::new(&AdapterChoice::from_env())?;
    let d = &gpu.device;
    let buffer = |size: u64, usage| {
        d.create_buffer(&wgpu::BufferDescriptor { label: None, size, usage, mapped_at_creation: false })
    };
    let out = buffer(u64::from(INVOCATIONS) * 16, wgpu::BufferUsages::STORAGE);
    let storage = buffer(u64::from(ELEMENTS) * 16, wgpu::BufferUsages::STORAGE);
    let uniform = buffer(65536, wgpu::BufferUsages::UNIFORM);
    let counts = gpu.uniform_buffer("counts", &[sites, 8u32, 0, 0])?;
    let texture = d.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d { width: 256, height: 256, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    println!("{} ({sites} sites)\n", gpu.description());
    println!("| access | per invocation | compile + first dispatch (s) | ns per access |\n|---|---|---|---|");
    for v in Variant::ALL {
        let t0 = Instant::now();
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(v.source(sites).into()),
        });
        let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: None,
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let data = match v {
            Variant::UniformLoad => uniform.as_entire_binding(),
            Variant::TextureLoad | Variant::TextureStore => wgpu::BindingResource::TextureView(&view),
            _ => storage.as_entire_binding(),
        };
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: data },
                wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: counts.as_entire_binding() },
            ],
        });
        let run = |workgroups: u32| -> Result<(), Box<dyn std::error::Error>> {
            let mut encoder = d.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups(workgroups, 1, 1);
            }
            gpu.queue.submit([encoder.finish()]);
            gpu.wait_idle()?;
            Ok(())
        };
        run(1)?;
        let t1 = Instant::now();
        run(INVOCATIONS / 64)?;
        let t2 = Instant::now();
        let per = (t2 - t1).as_secs_f64() * 1e9 / (f64::from(INVOCATIONS) * f64::from(v.accesses(sites)));
        println!("| {} | {} | {:.3} | {per:.1} |", v.name(), v.accesses(sites), (t1 - t0).as_secs_f64());
    }
    Ok(())
}
