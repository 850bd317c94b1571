//! A small, general compute runner: Pod buffers in, one WGSL entry point, Pod values out.
//!
//! Shaders are parsed and validated with naga first, so a mistake is reported with the
//! line and a source excerpt instead of wgpu's terser message. Bind group layouts are built
//! from the module's own declarations (every `var<uniform>` / `var<storage>` of every group)
//! rather than wgpu's "auto" layout, which silently drops bindings the entry point does not
//! use and so makes bind groups fail in confusing ways.

use std::collections::BTreeMap;

use bytemuck::Pod;

use super::device::{Gpu, GpuError};

/// Smallest buffer the runner creates: wgpu rejects zero-sized bindings, and scenes have
/// legitimately empty arrays (no lights, no planes). Kernels index by their own counts.
pub const MIN_BUFFER_BYTES: u64 = 16;

/// What kind of resource a binding declares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum BindingKind {
    /// A `var<uniform>` buffer.
    Uniform,
    /// A `var<storage>` buffer.
    Storage {
        /// Declared without `write` access: the kernel only reads it.
        read_only: bool,
    },
    /// A `texture_2d<u32>` read with `textureLoad` (a scene table: `tables::TableForm`).
    TextureU32,
}

/// What one binding holds: a buffer, or a texture's view (`BindingKind::TextureU32`).
#[derive(Debug)]
pub enum BoundResource {
    /// A uniform or storage buffer, bound whole.
    Buffer(wgpu::Buffer),
    /// The view of a `texture_2d<u32>` table.
    Texture(wgpu::TextureView),
}

impl BoundResource {
    /// The resource as a bind group entry takes it.
    pub fn binding(&self) -> wgpu::BindingResource<'_> {
        match self {
            BoundResource::Buffer(b) => b.as_entire_binding(),
            BoundResource::Texture(v) => wgpu::BindingResource::TextureView(v),
        }
    }
}

/// A validated WGSL module: naga's IR plus its validation info.
#[derive(Debug)]
pub struct ValidatedModule {
    /// The parsed module.
    pub module: naga::Module,
    /// naga's analysis of it, per function and entry point (such as the globals each uses).
    pub info: naga::valid::ModuleInfo,
}

/// What naga's validation allows: its defaults and 64-bit integers, which only the kernels
/// of a render with `FeatureSet::wide_words` use, on a device opened with them (wgpu checks
/// each module against its device's features again).
const CAPABILITIES: naga::valid::Capabilities = naga::valid::Capabilities::MULTISAMPLED_SHADING
    .union(naga::valid::Capabilities::CUBE_ARRAY_TEXTURES)
    .union(naga::valid::Capabilities::SHADER_INT64);

/// Parses and validates WGSL with naga; errors carry a rendered excerpt of the source.
///
/// ```
/// let ok = lumen::gpu::validate_wgsl("t", "@compute @workgroup_size(1) fn main() {}");
/// assert!(ok.is_ok());
/// let err = lumen::gpu::validate_wgsl("t", "fn f() -> u32 { return 1.5; }").unwrap_err();
/// assert!(err.to_string().contains("t"));
/// ```
pub fn validate_wgsl(label: &str, source: &str) -> Result<ValidatedModule, GpuError> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| GpuError::Shader { label: label.into(), message: e.emit_to_string_with_path(source, label) })?;
    let mut validator = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), CAPABILITIES);
    let info = validator
        .validate(&module)
        .map_err(|e| GpuError::Shader { label: label.into(), message: e.emit_to_string_with_path(source, label) })?;
    Ok(ValidatedModule { module, info })
}

/// One compute entry point, ready to dispatch.
#[derive(Debug)]
pub struct ComputeKernel {
    /// The name given at compilation, used in errors and as the wgpu objects' label.
    pub label: String,
    /// The compiled pipeline, whose layout is built from `layouts`.
    pub pipeline: wgpu::ComputePipeline,
    /// One layout per bind group index 0..=max declared (empty for unused indices).
    pub layouts: Vec<wgpu::BindGroupLayout>,
    /// Declared bindings per group, sorted by binding number.
    pub bindings: Vec<Vec<(u32, BindingKind)>>,
    /// The smallest buffer each of those bindings accepts (the declared type's size, one
    /// element of a runtime-sized array), in the same order.
    pub binding_bytes: Vec<Vec<u64>>,
    /// `@workgroup_size` of the entry point.
    pub workgroup_size: [u32; 3],
}

/// How naga compiles a kernel's loops (wgpu's `ShaderRuntimeChecks::force_loop_bounding`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Loops {
    /// Every loop gets a hidden iteration bound, so that no backend compiler may treat an
    /// endless loop as unreachable: safe for any WGSL ([`Gpu::compute_kernel`]).
    Bounded,
    /// Loops as written, for lumen's own stage kernels only: every loop in `shaders/` ends by
    /// construction (DESIGN.md "Loops that end"), and the hidden bound, a 64-bit counter
    /// carried through each loop, costs 7–13 % of a render's instructions on llvmpipe.
    Unbounded,
}

impl ComputeKernel {
    /// Workgroup counts covering `threads` invocations in each dimension (rounded up).
    pub fn workgroups_for(&self, threads: [u32; 3]) -> [u32; 3] {
        std::array::from_fn(|i| threads[i].div_ceil(self.workgroup_size[i].max(1)))
    }

    /// A bind group for `group` whose bindings are `buffers`, in increasing binding order.
    pub fn bind_group(&self, gpu: &Gpu, group: u32, buffers: &[&wgpu::Buffer]) -> Result<wgpu::BindGroup, GpuError> {
        let resources: Vec<wgpu::BindingResource> = buffers.iter().map(|b| b.as_entire_binding()).collect();
        self.bind_group_of(gpu, group, resources)
    }

    /// A bind group for `group` whose bindings are `resources` (buffers and texture views),
    /// in increasing binding order.
    pub fn bind_group_of(
        &self,
        gpu: &Gpu,
        group: u32,
        resources: Vec<wgpu::BindingResource>,
    ) -> Result<wgpu::BindGroup, GpuError> {
        let declared = self
            .bindings
            .get(group as usize)
            .ok_or_else(|| GpuError::Validation(format!("kernel {:?} declares no @group({group})", self.label)))?;
        if declared.len() != resources.len() {
            return Err(GpuError::Validation(format!(
                "kernel {:?} @group({group}) declares {} bindings {:?}, got {} resources",
                self.label,
                declared.len(),
                declared.iter().map(|b| b.0).collect::<Vec<_>>(),
                resources.len()
            )));
        }
        let entries: Vec<wgpu::BindGroupEntry> = declared
            .iter()
            .zip(resources)
            .map(|(&(binding, _), resource)| wgpu::BindGroupEntry { binding, resource })
            .collect();
        gpu.scoped(|| {
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(&self.label),
                layout: &self.layouts[group as usize],
                entries: &entries,
            })
        })
    }

    /// Records one dispatch of this kernel into `encoder`; bind group `i` is `groups[i]`.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, groups: &[&wgpu::BindGroup], workgroups: [u32; 3]) {
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&self.label), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        for (i, g) in groups.iter().enumerate() {
            pass.set_bind_group(i as u32, *g, &[]);
        }
        pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
    }
}

impl Gpu {
    /// Compiles `entry` of a WGSL compute shader. `label` names it in errors (use the file).
    ///
    /// ```
    /// use lumen::gpu::gpu_for_tests;
    /// let Some(gpu) = gpu_for_tests("compute_kernel_doc") else { return };
    /// let src = "@group(0) @binding(0) var<storage, read_write> v: array<u32>;
    /// @compute @workgroup_size(64)
    /// fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    ///     if (id.x < arrayLength(&v)) { v[id.x] = v[id.x] * 3u; }
    /// }";
    /// let kernel = gpu.compute_kernel("triple.wgsl", src, "main").unwrap();
    /// let buf = gpu.storage_buffer("v", &[1u32, 2, 3, 4]).unwrap();
    /// let group = kernel.bind_group(&gpu, 0, &[&buf]).unwrap();
    /// gpu.dispatch(&kernel, &[&group], kernel.workgroups_for([4, 1, 1])).unwrap();
    /// assert_eq!(gpu.read_buffer::<u32>(&buf, 4).unwrap(), [3, 6, 9, 12]);
    /// ```
    pub fn compute_kernel(&self, label: &str, source: &str, entry: &str) -> Result<ComputeKernel, GpuError> {
        self.kernel_with_loops(label, source, entry, Loops::Bounded)
    }

    /// [`Gpu::compute_kernel`] with its loops compiled as `loops` says: [`Loops::Unbounded`]
    /// only for sources whose every loop ends by construction (lumen's stage kernels).
    pub(crate) fn kernel_with_loops(
        &self,
        label: &str,
        source: &str,
        entry: &str,
        loops: Loops,
    ) -> Result<ComputeKernel, GpuError> {
        let ValidatedModule { module, .. } = validate_wgsl(label, source)?;
        self.kernel_from_module(label, module, entry, loops)
    }

    /// [`Gpu::kernel_with_loops`] from a module [`validate_wgsl`] has already parsed and
    /// validated: lumen's stage kernels, each validated once and made from copies of its
    /// module on this device and on twin devices (`parallel_jit`), whose SPIR-V is then the
    /// same.
    pub(crate) fn kernel_from_module(
        &self,
        label: &str,
        module: naga::Module,
        entry: &str,
        loops: Loops,
    ) -> Result<ComputeKernel, GpuError> {
        let ep = module
            .entry_points
            .iter()
            .find(|e| e.name == entry && e.stage == naga::ShaderStage::Compute)
            .ok_or_else(|| GpuError::NoEntryPoint { label: label.into(), entry: entry.into() })?;
        let workgroup_size = ep.workgroup_size;

        let mut groups: BTreeMap<u32, Vec<(u32, BindingKind, u64)>> = BTreeMap::new();
        for (_, var) in module.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            let kind = match var.space {
                naga::AddressSpace::Uniform => BindingKind::Uniform,
                naga::AddressSpace::Storage { access } => {
                    BindingKind::Storage { read_only: !access.contains(naga::StorageAccess::STORE) }
                }
                naga::AddressSpace::Handle
                    if matches!(
                        module.types[var.ty].inner,
                        naga::TypeInner::Image {
                            dim: naga::ImageDimension::D2,
                            arrayed: false,
                            class: naga::ImageClass::Sampled { kind: naga::ScalarKind::Uint, multi: false },
                        }
                    ) =>
                {
                    BindingKind::TextureU32
                }
                other => {
                    return Err(GpuError::UnsupportedBinding {
                        label: label.into(),
                        group: rb.group,
                        binding: rb.binding,
                        kind: format!("{other:?}"),
                    })
                }
            };
            let bytes = u64::from(module.types[var.ty].inner.size(module.to_ctx()));
            groups.entry(rb.group).or_default().push((rb.binding, kind, bytes));
        }
        let n_groups = groups.keys().next_back().map_or(0, |g| g + 1) as usize;
        if n_groups > self.limits.max_bind_groups as usize {
            return Err(GpuError::Validation(format!(
                "shader {label:?} uses {n_groups} bind groups; this adapter allows {}",
                self.limits.max_bind_groups
            )));
        }
        let storage =
            groups.values().flatten().filter(|(_, k, _)| matches!(k, BindingKind::Storage { .. })).count() as u32;
        if storage > self.limits.max_storage_buffers_per_shader_stage {
            return Err(GpuError::Validation(format!(
                "shader {label:?} needs {storage} storage buffers; this adapter allows {} per shader stage",
                self.limits.max_storage_buffers_per_shader_stage
            )));
        }
        let mut bindings = vec![Vec::new(); n_groups];
        let mut binding_bytes = vec![Vec::new(); n_groups];
        for (g, mut list) in groups {
            list.sort_by_key(|b| b.0);
            bindings[g as usize] = list.iter().map(|&(b, k, _)| (b, k)).collect();
            binding_bytes[g as usize] = list.iter().map(|b| b.2).collect();
        }

        self.scoped(|| {
            let layouts: Vec<wgpu::BindGroupLayout> = bindings
                .iter()
                .map(|list| {
                    let entries: Vec<wgpu::BindGroupLayoutEntry> = list
                        .iter()
                        .map(|&(binding, kind)| wgpu::BindGroupLayoutEntry {
                            binding,
                            visibility: wgpu::ShaderStages::COMPUTE,
                            ty: match kind {
                                BindingKind::Uniform => wgpu::BindingType::Buffer {
                                    ty: wgpu::BufferBindingType::Uniform,
                                    has_dynamic_offset: false,
                                    min_binding_size: None,
                                },
                                BindingKind::Storage { read_only } => wgpu::BindingType::Buffer {
                                    ty: wgpu::BufferBindingType::Storage { read_only },
                                    has_dynamic_offset: false,
                                    min_binding_size: None,
                                },
                                BindingKind::TextureU32 => wgpu::BindingType::Texture {
                                    sample_type: wgpu::TextureSampleType::Uint,
                                    view_dimension: wgpu::TextureViewDimension::D2,
                                    multisampled: false,
                                },
                            },
                            count: None,
                        })
                        .collect();
                    self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some(label),
                        entries: &entries,
                    })
                })
                .collect();
            let layout_refs: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(Some).collect();
            let pipeline_layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &layout_refs,
                immediate_size: 0,
            });
            // naga's module, already parsed and validated above, rather than the WGSL text:
            // wgpu would parse it again (5-9 % of a warm start's instructions) into the same
            // module, so the SPIR-V, and with it Mesa's cache key, is the same either way.
            let descriptor = wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
            };
            let shader = match loops {
                Loops::Bounded => self.device.create_shader_module(descriptor),
                Loops::Unbounded => {
                    let mut checks = wgpu::ShaderRuntimeChecks::checked();
                    checks.force_loop_bounding = false;
                    // SAFETY: wgpu's condition for dropping the loop bound is that the
                    // shader has no endless loop; `Loops::Unbounded` is only passed for
                    // lumen's stage kernels, whose loops all end (DESIGN.md "Loops that
                    // end", kept true by the test `every_shader_loop_is_one_that_ends`).
                    // Bounds and division checks stay on.
                    unsafe { self.device.create_shader_module_trusted(descriptor, checks) }
                }
            };
            let pipeline = self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                module: &shader,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: self.pipeline_cache.as_ref().map(|c| &c.cache),
            });
            // Persist the new binaries now (a later crash keeps them); a failure only costs
            // compile time in a later run.
            if let Some(cache) = &self.pipeline_cache {
                let _ = cache.save();
            }
            ComputeKernel { label: label.into(), pipeline, layouts, bindings, binding_bytes, workgroup_size }
        })
    }

    /// The most bytes one storage buffer may hold on this device, and the name of the limit
    /// that sets it: the smaller of a storage binding and a buffer.
    pub fn storage_limit(&self) -> (u64, &'static str) {
        let l = &self.limits;
        if l.max_storage_buffer_binding_size <= l.max_buffer_size {
            (l.max_storage_buffer_binding_size, "storage buffer binding")
        } else {
            (l.max_buffer_size, "buffer")
        }
    }

    fn check_storage_size(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let (limit, limit_name) = self.storage_limit();
        if bytes > limit {
            return Err(GpuError::TooLarge { what: what.into(), needed: bytes, limit, limit_name });
        }
        Ok(())
    }

    /// A storage buffer holding `data` (also copyable both ways, so it can be read back or
    /// rewritten). Padded to a multiple of 4 bytes and at least [`MIN_BUFFER_BYTES`].
    pub fn storage_buffer<T: Pod>(&self, label: &str, data: &[T]) -> Result<wgpu::Buffer, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let padded = padded_len(bytes.len() as u64);
        self.check_storage_size(label, padded)?;
        let buffer = self.storage_buffer_zeroed(label, padded)?;
        self.upload(&buffer, bytes)?;
        Ok(buffer)
    }

    /// A buffer the host maps to read what the device copied into it (at least 16 bytes).
    pub fn readback_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer, GpuError> {
        self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })
    }

    /// A zero-filled storage buffer of `bytes` bytes (padded like [`Self::storage_buffer`]).
    pub fn storage_buffer_zeroed(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer, GpuError> {
        let size = padded_len(bytes);
        self.check_storage_size(label, size)?;
        self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })
    }

    /// A uniform buffer holding `value` (rewritable with `queue.write_buffer`). The WGSL
    /// struct must match `T`'s layout, including uniform alignment rules (16-byte vectors).
    pub fn uniform_buffer<T: Pod>(&self, label: &str, value: &T) -> Result<wgpu::Buffer, GpuError> {
        self.uniform_buffer_bytes(label, bytemuck::bytes_of(value))
    }

    /// A uniform buffer holding `bytes` (zero-padded to a multiple of 16).
    pub fn uniform_buffer_bytes(&self, label: &str, bytes: &[u8]) -> Result<wgpu::Buffer, GpuError> {
        let size = bytes.len().next_multiple_of(16).max(16);
        let mut contents = bytes.to_vec();
        contents.resize(size, 0);
        if size as u64 > self.limits.max_uniform_buffer_binding_size {
            return Err(GpuError::TooLarge {
                what: label.into(),
                needed: size as u64,
                limit: self.limits.max_uniform_buffer_binding_size,
                limit_name: "uniform buffer binding",
            });
        }
        let buffer = self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        self.upload(&buffer, &contents)?;
        Ok(buffer)
    }

    /// A 2D `rgba32uint` texture of `row_texels`-texel rows holding `bytes` (words from
    /// texel (0, 0) on, row after row, the last row zero-padded; one zero row when `bytes`
    /// is empty), for `textureLoad` (a scene table in `tables::TableForm::Texture`), and its
    /// view. Whole rows are uploaded straight from `bytes`: only the last row is copied.
    ///
    /// ```
    /// use lumen::gpu::gpu_for_tests;
    /// let Some(gpu) = gpu_for_tests("u32_texture_doc") else { return };
    /// if !lumen::gpu::texel_fetches_trusted(&gpu.adapter_info) {
    ///     return; // a driver whose texel fetches lumen never uses (Mesa 26.1's llvmpipe)
    /// }
    /// let src = "@group(0) @binding(0) var t: texture_2d<u32>;
    /// @group(0) @binding(1) var<storage, read_write> v: array<u32>;
    /// @compute @workgroup_size(1)
    /// fn main() { v[0] = textureLoad(t, vec2<u32>(1u, 1u), 0).x; v[1] = textureLoad(t, vec2<u32>(1u, 1u), 0).z; }";
    /// let kernel = gpu.compute_kernel("texel.wgsl", src, "main").unwrap();
    /// // 14 words in rows of two texels: texel (1, 1) holds words 12 and 13, then padding.
    /// let words: Vec<u32> = (0..14).collect();
    /// let view = gpu.u32_texture("t", bytemuck::cast_slice(&words), 2).unwrap();
    /// let out = gpu.storage_buffer("v", &[7u32, 7]).unwrap();
    /// let group = kernel
    ///     .bind_group_of(&gpu, 0, vec![wgpu::BindingResource::TextureView(&view), out.as_entire_binding()])
    ///     .unwrap();
    /// gpu.dispatch(&kernel, &[&group], [1, 1, 1]).unwrap();
    /// assert_eq!(gpu.read_buffer::<u32>(&out, 2).unwrap(), [12, 0]);
    /// assert!(gpu.u32_texture("bad", &[0; 6], 2).is_err(), "not whole words");
    /// ```
    pub fn u32_texture(&self, label: &str, bytes: &[u8], row_texels: u32) -> Result<wgpu::TextureView, GpuError> {
        let row_bytes = row_texels as usize * 16;
        if row_texels == 0 || bytes.len() % 4 != 0 {
            return Err(GpuError::Internal(format!("{label}: {} bytes are not words in rows of texels", bytes.len())));
        }
        let rows = bytes.len().div_ceil(row_bytes).max(1);
        let limit = self.limits.max_texture_dimension_2d;
        if row_texels > limit || rows > limit as usize {
            // In bytes, like every TooLarge: as many full rows (of at most `limit` texels)
            // as the texture may have.
            return Err(GpuError::TooLarge {
                what: label.into(),
                needed: bytes.len() as u64,
                limit: u64::from(limit) * u64::from(row_texels.min(limit)) * 16,
                limit_name: "2D texture",
            });
        }
        let extent =
            |height: usize| wgpu::Extent3d { width: row_texels, height: height as u32, depth_or_array_layers: 1 };
        let texture = self.scoped(|| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent(rows),
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Uint,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })?;
        let write = |first_row: usize, data: &[u8], height: usize| {
            let at = wgpu::TexelCopyTextureInfo {
                origin: wgpu::Origin3d { x: 0, y: first_row as u32, z: 0 },
                ..texture.as_image_copy()
            };
            let layout = wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row_bytes as u32),
                rows_per_image: Some(height as u32),
            };
            self.scoped(|| self.queue.write_texture(at, data, layout, extent(height)))
        };
        let full = bytes.len() / row_bytes;
        if full > 0 {
            write(0, &bytes[..full * row_bytes], full)?;
        }
        if full < rows {
            let mut tail = vec![0u8; row_bytes];
            tail[..bytes.len() - full * row_bytes].copy_from_slice(&bytes[full * row_bytes..]);
            write(full, &tail, 1)?;
        }
        Ok(texture.create_view(&wgpu::TextureViewDescriptor::default()))
    }

    /// Writes `bytes` at the start of `buffer` (through the queue, not a mapping: a buffer
    /// that failed to allocate then yields an error instead of wgpu's panic on mapping).
    fn upload(&self, buffer: &wgpu::Buffer, bytes: &[u8]) -> Result<(), GpuError> {
        if bytes.is_empty() {
            return Ok(());
        }
        // Queue writes must be whole 4-byte words.
        let padded: Vec<u8>;
        let data = if bytes.len() % 4 == 0 {
            bytes
        } else {
            padded = bytes.iter().copied().chain(std::iter::repeat(0)).take(bytes.len().next_multiple_of(4)).collect();
            &padded
        };
        self.scoped(|| self.queue.write_buffer(buffer, 0, data))
    }

    /// Records and submits one dispatch, then waits for it; errors surface here.
    pub fn dispatch(
        &self,
        kernel: &ComputeKernel,
        groups: &[&wgpu::BindGroup],
        workgroups: [u32; 3],
    ) -> Result<(), GpuError> {
        self.scoped(|| {
            let mut encoder =
                self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(&kernel.label) });
            kernel.encode(&mut encoder, groups, workgroups);
            self.queue.submit([encoder.finish()]);
        })?;
        self.wait_idle()
    }

    /// Copies the first `count` elements of `buffer` back to the host.
    pub fn read_buffer<T: Pod>(&self, buffer: &wgpu::Buffer, count: usize) -> Result<Vec<T>, GpuError> {
        let bytes = (count * std::mem::size_of::<T>()) as u64;
        if bytes > buffer.size() {
            return Err(GpuError::Readback(format!(
                "asked for {bytes} bytes from a buffer of {} bytes",
                buffer.size()
            )));
        }
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let copy = bytes.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        let staging = self.readback_buffer("readback", copy)?;
        self.scoped(|| {
            let mut encoder =
                self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
            encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, copy);
            self.queue.submit([encoder.finish()]);
        })?;
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait_idle()?;
        rx.recv()
            .map_err(|_| GpuError::Readback("map callback never ran".into()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let out = {
            let view = staging.get_mapped_range(..).map_err(|e| GpuError::Readback(e.to_string()))?;
            bytemuck::pod_collect_to_vec(&view[..bytes as usize])
        };
        staging.unmap();
        Ok(out)
    }
}

fn padded_len(bytes: u64) -> u64 {
    bytes.next_multiple_of(4).max(MIN_BUFFER_BYTES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn syntax_errors_name_the_file_and_line() {
        let src = "@compute @workgroup_size(1)\nfn main() {\n  let x: u32 = ;\n}\n";
        let err = validate_wgsl("broken.wgsl", src).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("broken.wgsl:3"), "{msg}");
    }

    #[test]
    fn type_errors_are_caught_by_validation() {
        let src = "fn f() -> u32 { return 1.5; }";
        assert!(matches!(validate_wgsl("t.wgsl", src), Err(GpuError::Shader { .. })));
    }

    #[test]
    fn padding_keeps_bindings_legal() {
        assert_eq!(padded_len(0), MIN_BUFFER_BYTES);
        assert_eq!(padded_len(17), 20);
        assert_eq!(padded_len(64), 64);
    }
}
