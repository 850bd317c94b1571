//! The wavefront renderer's device state, described once, here: the group-0 buffers of
//! every stage, the words of the control buffer, the queues and the path fields. The WGSL
//! side (`wavefront` module) is generated from these constants, so the two cannot drift.
//!
//! - `batch` (uniform, [`BatchUniform`]): which pixels and camera samples the batch holds.
//! - `control` (`array<atomic<u32>>`, [`control`]): the bounce, queue lengths, ray and NaN
//!   counters.
//! - `queues` (`array<u32>`): queue q holds path slots at `q·capacity ..`.
//! - `paths` (`array<vec4<f32>>`) and `words` (`array<vec4<u32>>`): structure-of-arrays path
//!   state, field f of slot s at `f·capacity + s` ([`path_field`], [`word_field`]). These,
//!   `shadow` and `film` are read and written through generated accessors (`paths_get(i)`,
//!   `paths_set(i, v)`), which on llvmpipe hold the same bytes as `array<vec2<u64>>`
//!   ([`FeatureSet::wide_words`]).
//! - `shadow` (`array<vec4<f32>>`): per path, `batch.shadow_rays` shadow rays of three vec4 each.
//! - `deferred_refs` (`array<u32>`): per path, the CSG trees its closest-hit query met.
//! - `film` (`array<vec4<f32>>`): per pixel of the batch, the sum of its camera samples.
//! - `csg_pool` (`array<CsgPoolEntry>`): per path, the spans of the leaves of the CSG tree
//!   its query evaluates, then their faces ([`csg_pool_entries`] entries each; the host bounds
//!   the batch so that the pool stays within a memory budget however large a tree).
//! - `args_rays`, `args_hits`, `args_csg` (`array<atomic<u32>>`): indirect dispatch
//!   arguments (x, y, z) at `3·q` for the queues q each holds ([`launch_args`]), grown by the
//!   pushes themselves (`wf_push`). Three buffers, because a dispatch may not use one buffer
//!   both as its indirect arguments and as writable storage: every stage pushes only to
//!   queues whose arguments live in buffers other than the one it is launched from.

use bytemuck::{Pod, Zeroable};

use crate::gpu::features::FeatureSet;
use crate::gpu::layout::brdf_kind;

/// Invocations per workgroup of every queue-driven stage.
pub const WORKGROUP: u32 = 64;
/// Widest launch grid, in workgroups (WebGPU's minimum per-dimension limit).
pub const MAX_GRID: u32 = 65_535;
/// Most path slots per batch: then every launch (over a queue, the slots or the batch's
/// pixels, never more than the slots) is one row of at most `MAX_GRID` workgroups, so the
/// pushes can keep a queue's launch arguments as (shards · ⌈longest shard / 64⌉, 1, 1)
/// (`wf_push`, with [`Control::max_slots`] for the shards' rounding) and an invocation finds
/// its slot from its workgroup's x (`wf_slot`, `wf_direct_slot`). Four million paths in
/// flight is more than the largest GPU keeps resident (an H200: 132 SMs × 2,048 threads).
pub const MAX_SLOTS: u32 = WORKGROUP * MAX_GRID;

/// Workgroups of a direct launch over `count` invocations (at most [`MAX_SLOTS`]).
pub fn launch_groups(count: u32) -> u32 {
    debug_assert!(count <= MAX_SLOTS, "a launch over {count} invocations");
    count.div_ceil(WORKGROUP)
}

/// A queue entry past the queue's end.
pub const NONE: u32 = u32::MAX;
/// Set in a hit record's face word when the surface's normal is flipped (CSG DIFF).
pub const HIT_FLIP: u32 = 0x8000_0000;

/// Queues (indices of `control` counters and of `queues` regions).
pub mod queue {
    use super::brdf_kind;
    /// Rays to intersect, by bounce parity: `RAY + (bounce & 1)`.
    pub const RAY: u32 = 0;
    /// Rays whose closest-hit query met CSG trees (evaluated by the CSG stage). Rays that
    /// hit nothing have no queue: their paths end where the query does (`classify`).
    pub const CSG: u32 = 2;
    /// Paths with shadow rays to trace.
    pub const SHADOW: u32 = 3;
    /// Paths whose shadow rays met CSG trees and nothing else: the CSG stage's second
    /// launch of the bounce evaluates those trees.
    pub const SHADOW_CSG: u32 = 4;
    /// Hits to shade, by BRDF kind: `SHADE + Material::brdf`.
    pub const SHADE: u32 = 5;
    /// The shading queue of a BRDF kind.
    pub const fn shade(brdf: u32) -> u32 {
        SHADE + brdf
    }
    /// Number of queues.
    pub const COUNT: u32 = SHADE + brdf_kind::COUNT;
}

/// Words of the control buffer, for a render whose queues have `shards` shards
/// (`FeatureSet::queue_shards`).
///
/// Every queue length has a 64-byte line of its own: the pushes of one launch add to several
/// lengths at once from every core (llvmpipe runs a launch's workgroups on all of them), and
/// lengths sharing a line made each push move the line between cores even when they pushed
/// to different queues: false sharing, 9 % of glass.sl's CPU time on lavapipe (BENCHMARKS.md
/// "Queue lengths on lines of their own"). Shards go one step further for the pushes to the
/// *same* queue: each queue is split into `shards` regions with a length each, and a path
/// always lives in one shard: slots go to the shards by workgroup-sized blocks in turn
/// (`wf_shard`), so that every shard holds a like share of the image. A launch over a queue
/// runs shard after shard, `groups(q)` workgroups each, and a launch over all slots (camera,
/// bounce 0's closest hits, first hits) likewise runs the blocks of shard 0, then shard 1's
/// (`wf_direct_slot`). Where the driver hands each of its threads one run of a launch's
/// workgroups (llvmpipe: `launch / threads` in a row, Mesa's `lp_cs_tpool`) and there is
/// one shard per thread, a thread's pushes all go to the lengths of its own shard and no
/// line travels between cores during a launch (cornell.sl spent 20 % of lavapipe's kernel
/// time on the push atomics with one shard, BENCHMARKS.md "Queue shards").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Control {
    shards: u32,
}

impl Control {
    /// Words per line: 64 bytes, the cache line of x86-64 and Arm cores (a GPU's atomics
    /// work on lines of 32 to 128 bytes).
    pub const LINE: u32 = 16;
    /// The bounce the stages of the current launch work on (read by every invocation,
    /// written only between launches).
    pub const BOUNCE: u32 = 0;

    /// The layout for `shards` shards per queue (0 counts as 1).
    pub fn new(shards: u32) -> Self {
        Control { shards: shards.max(1) }
    }

    /// Shards per queue.
    pub fn shards(self) -> u32 {
        self.shards
    }

    /// The word of queue q's length in shard s (a line each, after the bounce's).
    pub fn count(self, q: u32, s: u32) -> u32 {
        Self::LINE * (1 + s * queue::COUNT + q)
    }

    /// The word of queue q's workgroups per shard (a line each): its launch is
    /// `shards · groups(q)` workgroups, grown by the pushes (`wf_grow_launch`). Kept only
    /// with two shards or more (with one, the launch's own size is the same number).
    pub fn groups(self, q: u32) -> u32 {
        Self::LINE * (1 + self.shards * queue::COUNT + q)
    }

    /// Words from 0 that every batch starts afresh: the bounce, the lengths and the
    /// workgroups per shard.
    pub fn batch_words(self) -> u32 {
        self.groups(queue::COUNT)
    }

    /// Shadow rays traced by the paths of shard s (64-bit: low, high word), summed by the
    /// stages that trace them; a line per shard.
    pub fn shadow_rays(self, s: u32) -> u32 {
        self.batch_words() + Self::LINE * s
    }

    /// Closest-hit rays traced (64-bit), summed by the `advance` kernel.
    pub fn rays(self) -> u32 {
        self.shadow_rays(self.shards)
    }

    /// Estimates that were NaN or infinite (written as 0).
    pub fn nan(self) -> u32 {
        self.rays() + 2
    }

    /// Set when a CSG query gave up after its walk budget in kernels without the sweeps
    /// (shaders/csg.wgsl): the batch is void and the render starts again with them.
    pub fn csg_over(self) -> u32 {
        self.nan() + 1
    }

    /// Words in the buffer.
    pub fn words(self) -> u32 {
        self.csg_over() + 1
    }

    /// Most path slots per batch: `MAX_SLOTS` (64 · 65,535) less what rounding each shard up to whole
    /// blocks may add to a launch, so that `shards` runs of a shard's workgroups stay within
    /// one row.
    pub fn max_slots(self) -> u32 {
        MAX_SLOTS - WORKGROUP * (self.shards - 1)
    }

    /// Workgroups per shard of a launch over `slots` slots: the most blocks of 64 slots any
    /// shard holds.
    fn shard_groups(self, slots: u32) -> u32 {
        slots.div_ceil(WORKGROUP).div_ceil(self.shards)
    }

    /// Workgroups of a launch over the first `path_count` slots (`wf_direct_slot`): a run
    /// per shard.
    pub fn slot_groups(self, path_count: u32) -> u32 {
        self.shards * self.shard_groups(path_count)
    }

    /// Entries of one shard's region of a queue, for batches of up to `capacity` slots
    /// (`BatchUniform::shard_slots`): a queue holds `shards` regions.
    pub fn shard_slots(self, capacity: u32) -> u32 {
        WORKGROUP * self.shard_groups(capacity).max(1)
    }
}

/// Fields of `paths` (`vec4<f32>` each).
pub mod path_field {
    /// Ray origin, tmin.
    pub const RAY_ORIGIN: u32 = 0;
    /// Ray direction, tmax.
    pub const RAY_DIR: u32 = 1;
    /// Throughput β, and the BSDF pdf of the previous vertex, negative when it scattered by
    /// a delta BSDF or is the camera (MIS reads the density only of non-delta vertices).
    pub const BETA: u32 = 2;
    /// Radiance gathered so far.
    pub const RADIANCE: u32 = 3;
    pub const COUNT: u32 = 4;
}

/// Fields of `words` (`vec4<u32>` each).
pub mod word_field {
    /// The closest hit: t (bits), shape, face | HIT_FLIP, top-level object.
    pub const HIT: u32 = 0;
    /// The previous vertex's point (f32 bits: integer moves keep every bit) and object, for
    /// emission MIS at the next hit (written only in scenes with area lights).
    pub const PREV: u32 = 1;
    pub const COUNT: u32 = 2;
}

/// The per-batch uniform: `Batch` in the generated WGSL.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct BatchUniform {
    /// The batch's pixels (row-major indices) are `pixel_begin + i · pixel_stride` for
    /// `i < pixel_count`: a batch holds whole pixels, interleaved with the other batches of
    /// its round where several devices share them (`schedule::batches`).
    pub pixel_begin: u32,
    /// Pixels the batch holds; the film stage sums one per invocation.
    pub pixel_count: u32,
    /// Camera samples `[sample_begin, sample_begin + samples)` of the round.
    pub sample_begin: u32,
    /// Camera samples per pixel in the batch (see `sample_begin`).
    pub samples: u32,
    /// Paths per camera sample (n; 1 for the first-hit integrators).
    pub paths_per_sample: u32,
    /// `pixel_count · samples · paths_per_sample` path slots in use.
    pub path_count: u32,
    /// Slots of every state array and queue.
    pub capacity: u32,
    /// Shadow rays a path vertex may queue (point lights + 1 for NEE): the stride of `shadow`.
    pub shadow_rays: u32,
    /// Always 0. Kernels XOR values with it where arithmetic must run as written (the film
    /// stage's TwoSum): a compiler cannot fold across a value it cannot know, while it may
    /// simplify `(s + x) − s` to `x` under the reassociation WGSL allows (Mesa's lavapipe
    /// does, and the compensated sum's error term came out 0).
    pub zero: u32,
    /// Entries of a queue shard's region ([`Control::shard_slots`]): shard s of queue q
    /// starts at `(q · shards + s) · shard_slots` in `queues`.
    pub shard_slots: u32,
    /// See `pixel_begin`.
    pub pixel_stride: u32,
    /// Padding to 48 bytes, a multiple of 16 (`_pad0` of the WGSL `Batch`); always 0.
    pub _pad: [u32; 1],
}

const BATCH_WGSL: &str = "struct Batch {
    pixel_begin: u32,
    pixel_count: u32,
    sample_begin: u32,
    samples: u32,
    paths_per_sample: u32,
    path_count: u32,
    capacity: u32,
    shadow_rays: u32,
    zero: u32,
    shard_slots: u32,
    pixel_stride: u32,
    _pad0: u32,
}
";

/// A buffer of bind group 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum StateBuffer {
    /// `batch`, the uniform [`BatchUniform`]: which pixels and camera samples the batch holds.
    Batch,
    /// `control`: the bounce, the queue lengths and the ray and NaN counters, in the words
    /// [`Control`] lays out.
    Control,
    /// `queues`: the path slots in each queue, shard s of queue q from
    /// `(q · shards + s) · shard_slots`.
    Queues,
    /// `paths`: the `vec4<f32>` path fields (ray, throughput, radiance), field f of slot s at
    /// `f · capacity + s`.
    Paths,
    /// `words`: the `vec4<u32>` path fields (closest hit, previous vertex), laid out as `paths`.
    Words,
    /// `shadow`: per slot, `batch.shadow_rays` shadow rays of three `vec4<f32>` each.
    Shadow,
    /// `deferred_refs`: per slot, the CSG trees that its closest-hit query and each of its
    /// shadow rays met (a count, then the tree references).
    DeferredRefs,
    /// `film`: per pixel of the batch, the compensated sum of its camera samples (the sum,
    /// then its error term).
    Film,
    /// `args_rays`: indirect launch arguments of the two ray queues and the shadow queue.
    ArgsRays,
    /// `args_hits`: indirect launch arguments of the shading queues.
    ArgsHits,
    /// `args_csg`: indirect launch arguments of the CSG and shadow-CSG queues.
    ArgsCsg,
    /// `csg_pool`: per slot, the working entries of the CSG query it evaluates (leaf spans,
    /// faces, sweep state; [`csg_pool_entries`] entries each).
    CsgPool,
    /// The shading queue a launch of a shading kernel drains (`shade_queue.x`): one small
    /// uniform per shading stage, so that the kinds sharing a kernel
    /// (`Stage::kernel_kinds`) each launch it over their own queue.
    ShadeQueue,
}

impl StateBuffer {
    /// Every buffer, in binding order.
    pub const ALL: [StateBuffer; 13] = [
        StateBuffer::Batch,
        StateBuffer::Control,
        StateBuffer::Queues,
        StateBuffer::Paths,
        StateBuffer::Words,
        StateBuffer::Shadow,
        StateBuffer::DeferredRefs,
        StateBuffer::Film,
        StateBuffer::ArgsRays,
        StateBuffer::ArgsHits,
        StateBuffer::ArgsCsg,
        StateBuffer::CsgPool,
        StateBuffer::ShadeQueue,
    ];

    /// The three buffers of launch arguments.
    pub const ARGS: [StateBuffer; 3] = [StateBuffer::ArgsRays, StateBuffer::ArgsHits, StateBuffer::ArgsCsg];

    /// Its binding number in group 0.
    pub fn binding(self) -> u32 {
        self as u32
    }

    /// Its WGSL name.
    pub(crate) fn declaration_name(self) -> &'static str {
        match self {
            StateBuffer::Batch => "batch",
            StateBuffer::Control => "control",
            StateBuffer::Queues => "queues",
            StateBuffer::Paths => "paths",
            StateBuffer::Words => "words",
            StateBuffer::Shadow => "shadow",
            StateBuffer::DeferredRefs => "deferred_refs",
            StateBuffer::Film => "film",
            StateBuffer::ArgsRays => "args_rays",
            StateBuffer::ArgsHits => "args_hits",
            StateBuffer::ArgsCsg => "args_csg",
            StateBuffer::CsgPool => "csg_pool",
            StateBuffer::ShadeQueue => "shade_queue",
        }
    }

    /// Its WGSL declaration; with `wide` (the render's [`FeatureSet::wide_words`]) the
    /// buffers of 16-byte words are declared as 64-bit words ([`Self::words_declaration`]).
    fn declaration(self, wide: bool) -> String {
        let name = self.declaration_name();
        let ty = match self {
            StateBuffer::Batch => return format!("@group(0) @binding({}) var<uniform> batch: Batch;", self.binding()),
            StateBuffer::ShadeQueue => {
                return format!("@group(0) @binding({}) var<uniform> shade_queue: vec4<u32>;", self.binding())
            }
            StateBuffer::Control | StateBuffer::ArgsRays | StateBuffer::ArgsHits | StateBuffer::ArgsCsg => {
                "array<atomic<u32>>"
            }
            StateBuffer::Queues | StateBuffer::DeferredRefs => "array<u32>",
            // `CsgPoolEntry` is declared by the csg module, the only one that binds this.
            StateBuffer::CsgPool => "array<CsgPoolEntry>",
            StateBuffer::Paths | StateBuffer::Words | StateBuffer::Shadow | StateBuffer::Film => {
                return self.words_declaration(wide);
            }
        };
        format!("@group(0) @binding({}) var<storage, read_write> {name}: {ty};", self.binding())
    }

    /// The declaration of a buffer of 16-byte words ([`Self::word_element`]: `paths`,
    /// `words`, `shadow`, `film`), which the stages read and write only through its accessors
    /// ([`accessor_modules`]). With `wide` it is declared as `array<vec2<u64>>`, the same
    /// bytes in half as many words.
    fn words_declaration(self, wide: bool) -> String {
        let (b, name) = (self.binding(), self.declaration_name());
        let elem = if wide { "vec2<u64>" } else { self.word_element().expect("a buffer of 16-byte words") };
        format!("@group(0) @binding({b}) var<storage, read_write> {name}: array<{elem}>;")
    }

    /// The type of an element of a buffer of 16-byte words, as its accessors see it.
    fn word_element(self) -> Option<&'static str> {
        match self {
            StateBuffer::Paths | StateBuffer::Shadow | StateBuffer::Film => Some("vec4<f32>"),
            StateBuffer::Words => Some("vec4<u32>"),
            _ => None,
        }
    }
}

/// The generated accessors of the buffers of 16-byte words among `buffers` (`paths`,
/// `words`, `shadow`, `film`), as (file name, source) of one module per function: for
/// `paths`, `paths_get(i) -> vec4<f32>` provided as module `paths_get` and `paths_set(i,
/// v)` as `paths_set`, so a stage holds only the accessors its modules `// #requires`. With
/// `wide` ([`FeatureSet::wide_words`]) they split and join 64-bit words
/// ([`wide_word_modules`]; DESIGN.md "Wide words"): llvmpipe accesses a storage buffer
/// at a lane-dependent index word by word and lane by lane, each word with its own bounds
/// check and branch, so an element costs two such accesses instead of four.
pub fn accessor_modules(buffers: &[StateBuffer], wide: bool) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for b in buffers {
        let Some(elem) = b.word_element() else { continue };
        let name = b.declaration_name();
        let (read, write) = match (wide, elem) {
            (false, _) => (format!("{name}[i]"), format!("{name}[i] = v")),
            (true, "vec4<u32>") => (format!("words_of({name}[i])"), format!("{name}[i] = wide_of(v)")),
            (true, _) => (
                format!("bitcast<vec4<f32>>(words_of({name}[i]))"),
                format!("{name}[i] = wide_of(bitcast<vec4<u32>>(v))"),
            ),
        };
        let requires = |helper: &str| format!("// #requires wavefront{}\n", if wide { helper } else { "" });
        out.push((
            format!("<generated {name}_get>"),
            format!(
                "// #provides {name}_get\n{}fn {name}_get(i: u32) -> {elem} {{\n    return {read};\n}}\n",
                requires(" words_of")
            ),
        ));
        out.push((
            format!("<generated {name}_set>"),
            format!(
                "// #provides {name}_set\n{}fn {name}_set(i: u32, v: {elem}) {{\n    {write};\n}}\n",
                requires(" wide_of")
            ),
        ));
    }
    out
}

/// The two conversions of 64-bit words (DESIGN.md "Wide words"), as (file name, source) of
/// a module each, `words_of` and `wide_of`, which the wide accessors ([`accessor_modules`])
/// and the scene tables' wide form (`gpu::tables`) require: 16 bytes as two 64-bit words
/// (`vec2<u64>`) to four 32-bit ones and back, in a few vector instructions. Word 2k + 1 is
/// the high half of 64-bit word k (little-endian, as every host llvmpipe runs on), so the
/// bytes are those of the `vec4<u32>`: the host's uploads, clears and read-backs do not
/// change.
pub fn wide_word_modules() -> [(String, String); 2] {
    [
        (
            "<generated words_of>".into(),
            "// #provides words_of\nfn words_of(w: vec2<u64>) -> vec4<u32> {\n    \
             return vec4<u32>(u32(w.x & 0xfffffffflu), u32(w.x >> 32u), u32(w.y & 0xfffffffflu), u32(w.y >> 32u));\n}\n"
                .into(),
        ),
        (
            "<generated wide_of>".into(),
            "// #provides wide_of\nfn wide_of(u: vec4<u32>) -> vec2<u64> {\n    \
             return vec2<u64>(u64(u.x) | (u64(u.y) << 32u), u64(u.z) | (u64(u.w) << 32u));\n}\n"
                .into(),
        ),
    ]
}

/// The buffer that holds queue `q`'s launch arguments. Each stage pushes only to queues of
/// buffers other than the one it is launched from: the closest-hit stage (from `ArgsRays`)
/// to the shading and CSG queues; the CSG stage (from `ArgsCsg`) to the shading queues;
/// the shading stages (from `ArgsHits`) to the shadow queue and the next ray queue; the
/// shadow stage (from `ArgsRays`) to the shadow rays' CSG queue.
pub fn launch_args(q: u32) -> StateBuffer {
    if q == queue::RAY || q == queue::RAY + 1 || q == queue::SHADOW {
        StateBuffer::ArgsRays
    } else if q == queue::CSG || q == queue::SHADOW_CSG {
        StateBuffer::ArgsCsg
    } else {
        StateBuffer::ArgsHits
    }
}

/// The generated control-word helpers ([`Control`]): `ctrl_count(q, s)` and
/// `ctrl_groups(q)` in the stages that read or write lengths (`WF_LENGTHS`: the queued
/// stages and the control kernels), `ctrl_shadow_rays(s)` in those that count shadow rays
/// (`WF_COUNT`).
fn control_wgsl(c: Control) -> String {
    let (line, queues, shards) = (Control::LINE, queue::COUNT, c.shards());
    format!(
        "// #if WF_LENGTHS\n// The word of queue q's length in shard s (contract::Control::count).\n\
         fn ctrl_count(q: u32, s: u32) -> u32 {{\n    return {line}u * (1u + s * {queues}u + q);\n}}\n\
         // The word of queue q's workgroups per shard (contract::Control::groups).\n\
         fn ctrl_groups(q: u32) -> u32 {{\n    return {line}u * ({}u + q);\n}}\n// #endif\n\
         // #if WF_COUNT\n// The shadow-ray counter of shard s (contract::Control::shadow_rays).\n\
         fn ctrl_shadow_rays(s: u32) -> u32 {{\n    return {}u + {line}u * s;\n}}\n// #endif\n",
        1 + shards * queues,
        c.batch_words(),
    )
}

/// The generated WGSL that keeps launch arguments, for a stage binding `buffers`:
/// `wf_grow_launch` (pushing stages) and `wf_clear_launch` (control kernels), each touching
/// only the argument buffers the stage binds. With shards, a launch is `WF_SHARDS` runs of
/// `ctrl_groups(q)` workgroups, both kept here.
fn launch_args_wgsl(buffers: &[StateBuffer]) -> String {
    let mut grow =
        String::from("    if (WF_SHARDS > 1u) {\n        atomicMax(&control[ctrl_groups(q)], groups);\n    }\n");
    let mut clear =
        String::from("    if (WF_SHARDS > 1u) {\n        atomicStore(&control[ctrl_groups(q)], 0u);\n    }\n");
    let mut any = false;
    for b in StateBuffer::ARGS.into_iter().filter(|b| buffers.contains(b)) {
        let queues: Vec<String> =
            (0..queue::COUNT).filter(|&q| launch_args(q) == b).map(|q| format!("q == {q}u")).collect();
        let name = b.declaration_name();
        let test = queues.join(" || ");
        grow.push_str(&format!(
            "    if ({test}) {{\n        atomicMax(&{name}[3u * q], WF_SHARDS * groups);\n    }}\n"
        ));
        clear.push_str(&format!("    if ({test}) {{\n        atomicStore(&{name}[3u * q], 0u);\n    }}\n"));
        any = true;
    }
    if !any {
        return String::new();
    }
    format!(
        "// #if WF_PUSH\n// Grows queue q's launch to at least `groups` workgroups per shard (contract::launch_args).\n\
         fn wf_grow_launch(q: u32, groups: u32) {{\n{grow}}}\n// #endif\n\
         // #if STAGE_CONTROL\n// Queue q's launch is empty again.\nfn wf_clear_launch(q: u32) {{\n{clear}}}\n// #endif\n"
    )
}

/// Bytes of one `csg_pool` entry (two 32-bit words: a leaf span's t's, or its faces; a
/// test checks the WGSL struct).
pub const CSG_POOL_ENTRY_BYTES: u64 = 8;

/// Most pool entries per path kept in private memory instead of the storage pool (1 KiB,
/// trees of 64 leaves): every example scene's trees fit (streetlamp.sl's have 7 leaves);
/// larger trees keep their spans in the pool, so that private memory, and with it compile
/// time, stay bounded whatever the tree.
pub const CSG_PRIVATE_POOL_MAX: u64 = 128;

/// Entries of `csg_pool` one lane needs for the scene's trees (features `f`): two per leaf
/// of the largest tree (its span, its faces); where a tree has more leaves than private
/// memory holds and the kernels have the sweeps (`FeatureSet::csg_sweeps`), also the
/// sweeps' (shaders/csg.wgsl): one more per leaf (the span ends' orders) and one per node
/// of the largest swept tree (the two sweeps' states).
pub fn csg_pool_entries(f: &FeatureSet) -> u64 {
    let leaves = u64::from(f.csg_max_leaves.max(1));
    if 2 * leaves <= CSG_PRIVATE_POOL_MAX || !f.csg_sweeps {
        2 * leaves
    } else {
        3 * leaves + u64::from(f.csg_sweep_nodes)
    }
}

/// The generated `wavefront` module for a stage that binds `buffers`: every constant above,
/// the `Batch` struct and the declarations of those buffers (of 64-bit words with `wide`,
/// [`FeatureSet::wide_words`]), with the control buffer laid out as `control`.
pub fn wavefront_module(buffers: &[StateBuffer], control: Control, wide: bool) -> String {
    let mut s =
        String::from("// #provides wavefront\n// The wavefront state, generated by src/gpu/wavefront/contract.rs.\n");
    let consts: [(&str, u32); 20] = [
        ("WF_WORKGROUP", WORKGROUP),
        ("WF_SHARDS", control.shards()),
        ("WF_NONE", NONE),
        ("WF_QUEUES", queue::COUNT),
        ("HIT_FLIP", HIT_FLIP),
        ("Q_RAY", queue::RAY),
        ("Q_CSG", queue::CSG),
        ("Q_SHADOW", queue::SHADOW),
        ("Q_SHADOW_CSG", queue::SHADOW_CSG),
        ("Q_SHADE", queue::SHADE),
        ("CTRL_BOUNCE", Control::BOUNCE),
        ("CTRL_RAYS", control.rays()),
        ("CTRL_NAN", control.nan()),
        ("CTRL_CSG_OVER", control.csg_over()),
        ("F_RAY_ORIGIN", path_field::RAY_ORIGIN),
        ("F_RAY_DIR", path_field::RAY_DIR),
        ("F_BETA", path_field::BETA),
        ("F_RADIANCE", path_field::RADIANCE),
        ("W_HIT", word_field::HIT),
        ("W_PREV", word_field::PREV),
    ];
    for (name, value) in consts {
        s.push_str(&format!("const {name}: u32 = {value}u;\n"));
    }
    s.push_str(&control_wgsl(control));
    s.push_str(BATCH_WGSL);
    for b in buffers {
        s.push_str(&b.declaration(wide));
        s.push('\n');
    }
    s.push_str(&launch_args_wgsl(buffers));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_struct_matches_rust_and_buffers_have_distinct_bindings() {
        // The pool's element type lives in the csg module (checked with it, in gpu::kernels).
        let alone: Vec<StateBuffer> = StateBuffer::ALL.into_iter().filter(|b| *b != StateBuffer::CsgPool).collect();
        let src = wavefront_module(&alone, Control::new(2), false);
        let v = crate::gpu::validate_wgsl("wavefront", &src).unwrap();
        let ty = v.module.types.iter().find(|(_, t)| t.name.as_deref() == Some("Batch")).unwrap().1;
        let naga::TypeInner::Struct { members, span } = &ty.inner else { panic!("Batch is not a struct") };
        assert_eq!(*span as usize, std::mem::size_of::<BatchUniform>());
        let rust = [
            ("pixel_begin", std::mem::offset_of!(BatchUniform, pixel_begin)),
            ("pixel_count", std::mem::offset_of!(BatchUniform, pixel_count)),
            ("sample_begin", std::mem::offset_of!(BatchUniform, sample_begin)),
            ("samples", std::mem::offset_of!(BatchUniform, samples)),
            ("paths_per_sample", std::mem::offset_of!(BatchUniform, paths_per_sample)),
            ("path_count", std::mem::offset_of!(BatchUniform, path_count)),
            ("capacity", std::mem::offset_of!(BatchUniform, capacity)),
            ("shadow_rays", std::mem::offset_of!(BatchUniform, shadow_rays)),
            ("zero", std::mem::offset_of!(BatchUniform, zero)),
            ("shard_slots", std::mem::offset_of!(BatchUniform, shard_slots)),
            ("pixel_stride", std::mem::offset_of!(BatchUniform, pixel_stride)),
            ("_pad0", std::mem::offset_of!(BatchUniform, _pad)),
        ];
        assert_eq!(members.len(), rust.len());
        for (m, (name, offset)) in members.iter().zip(rust) {
            assert_eq!((m.name.as_deref(), m.offset as usize), (Some(name), offset));
        }
        // Each buffer is declared in group 0 at the binding the host binds it to, and no two
        // of the module's resources share a binding.
        let declared: Vec<(String, naga::ResourceBinding)> =
            v.module.global_variables.iter().filter_map(|(_, g)| Some((g.name.clone()?, g.binding?))).collect();
        for b in &alone {
            let at = declared.iter().find(|(name, _)| name == b.declaration_name()).map(|(_, r)| r);
            assert_eq!(at, Some(&naga::ResourceBinding { group: 0, binding: b.binding() }), "{b:?}");
        }
        let mut bindings: Vec<(u32, u32)> = declared.iter().map(|(_, r)| (r.group, r.binding)).collect();
        bindings.sort_unstable();
        bindings.dedup();
        assert_eq!(bindings.len(), declared.len(), "{declared:?}");
    }

    #[test]
    fn a_batch_fits_one_row_of_workgroups() {
        assert_eq!(launch_groups(MAX_SLOTS), MAX_GRID);
        assert_eq!(launch_groups(MAX_SLOTS - WORKGROUP + 1), MAX_GRID);
        assert_eq!((launch_groups(0), launch_groups(1), launch_groups(64), launch_groups(65)), (0, 1, 1, 2));
    }

    #[test]
    fn queues_and_control_words_do_not_overlap() {
        // One shading queue per BRDF kind, after the fixed queues.
        for brdf in 0..brdf_kind::COUNT {
            let q = queue::shade(brdf);
            assert!(q > queue::SHADOW_CSG && q < queue::COUNT);
        }
        assert_eq!(queue::COUNT, 11);
        // Each length, workgroup count and shadow-ray counter alone on its line, for any
        // number of shards; the 64-bit counters and flags after them, the bounce before.
        for shards in [1, 2, 3, 16] {
            let c = Control::new(shards);
            let mut lines: Vec<u32> = (0..shards).flat_map(|s| (0..queue::COUNT).map(move |q| c.count(q, s))).collect();
            lines.extend((0..queue::COUNT).map(|q| c.groups(q)));
            lines.extend((0..shards).map(|s| c.shadow_rays(s)));
            lines.push(c.rays());
            assert_eq!(lines[0], Control::LINE);
            for (a, b) in lines.iter().zip(&lines[1..]) {
                assert!(b - a == Control::LINE && a % Control::LINE == 0, "{shards} shards: {a} {b}");
            }
            assert_eq!(c.batch_words(), c.shadow_rays(0));
            assert!(c.rays() + 2 <= c.nan() && c.nan() < c.csg_over() && c.csg_over() < c.words());
        }
        assert_eq!(Control::new(0), Control::new(1));
    }

    /// A queue's shard regions hold their shards: slots go to shards by blocks of 64 in turn
    /// (block b to shard b mod shards), and a shard's entry count, counted block by block,
    /// never passes `shard_slots` for any batch up to the capacity; launches over the slots
    /// cover them in one row.
    #[test]
    fn shards_cover_the_slots_in_whole_workgroups() {
        for shards in [1, 2, 3, 7, 32] {
            let c = Control::new(shards);
            for capacity in [1, 63, 64, 65, 320, 1000, 4096, 100_003, c.max_slots() - 1, c.max_slots()] {
                let per = c.shard_slots(capacity);
                assert_eq!(per % WORKGROUP, 0);
                assert!(shards * (per / WORKGROUP) <= MAX_GRID, "{shards} {capacity}");
                for path_count in [1, capacity / 2 + 1, capacity] {
                    let mut entries = vec![0u64; shards as usize];
                    let blocks = path_count.div_ceil(WORKGROUP);
                    for b in 0..blocks {
                        let slots = (path_count - b * WORKGROUP).min(WORKGROUP);
                        entries[(b % shards) as usize] += u64::from(slots);
                    }
                    assert!(entries.iter().all(|&n| n <= u64::from(per)), "{shards} {capacity} {path_count}");
                    assert_eq!(entries.iter().sum::<u64>(), u64::from(path_count));
                    let groups = c.slot_groups(path_count);
                    assert!(groups % shards == 0 && groups * WORKGROUP >= path_count && groups <= MAX_GRID);
                    assert!(u64::from(groups / shards) * u64::from(WORKGROUP) <= u64::from(per));
                }
            }
        }
        assert_eq!(Control::new(1).max_slots(), MAX_SLOTS);
    }
}
