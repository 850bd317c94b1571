// #requires wavefront
// #if WF_RAY_LOAD
// #requires ray paths_get
// #endif
// #if WF_RAY_STORE
// #requires ray paths_set
// #endif
// #if WF_RADIANCE_ADD
// #requires paths_get paths_set
// #endif
// #if WF_BETA_LOAD
// #requires paths_get
// #endif
// #if WF_QUEUED
// #requires divide
// #endif
// #if WF_DIRECT
// #requires divide
// #endif
// #if WF_PATH_ID
// #requires divide
// #endif
// Helpers of the wavefront stages (docs/DESIGN.md "Wavefront renderer"): the slot an
// invocation takes, queue shards and pushes, path fields and the (pixel, sample) a path
// slot stands for. Which of them a stage gets is decided by src/gpu/wavefront/stages.rs.

// Index of field `f` of path `slot` in the structure-of-arrays `paths` and `words`.
fn field(f: u32, slot: u32) -> u32 {
    return f * batch.capacity + slot;
}

// Stages name their lane by `local_invocation_id.x`, never `local_invocation_index`: llvmpipe
// derives the index from all three components, a dozen scalar divisions per group of lanes.

// Every launch is one row of workgroups (a batch has at most contract::MAX_SLOTS =
// 64 · 65,535 slots), and its size is never read from `num_workgroups`, which D3D12 reports
// as 0 for indirect launches without wgpu's indirect validation (src/gpu/device.rs,
// instance_flags): the launches over queues find their shards' runs in ctrl_groups.

// #if WF_SHARD
// The queue shard of path `slot` (contract::Control): blocks of WF_WORKGROUP slots go to the
// shards in turn, and a path stays in the shard of its slot.
fn wf_shard(slot: u32) -> u32 {
    return (slot / WF_WORKGROUP) % WF_SHARDS;
}
// #endif

// #if WF_DIRECT
// The slot that invocation `lane` of workgroup `group` of a launch over all of the batch's
// slots takes (Control::slot_groups workgroups), or WF_NONE past batch.path_count: run s of
// the launch takes shard s's blocks, so a driver thread that runs one run of the launch
// writes, and later pushes, only its own shard's paths.
fn wf_direct_slot(group: u32, lane: u32) -> u32 {
    var block = group;
    if (WF_SHARDS > 1u) {
        let runs = ((batch.path_count + WF_WORKGROUP - 1u) / WF_WORKGROUP + WF_SHARDS - 1u) / WF_SHARDS;
        let s = div_small(group, runs);
        block = (group - s * runs) * WF_SHARDS + s;
    }
    let slot = block * WF_WORKGROUP + lane;
    return select(WF_NONE, slot, slot < batch.path_count);
}
// #endif

// #if WF_QUEUED
// The path slot that invocation `lane` of workgroup `group` of a launch over queue q takes,
// or WF_NONE past the end of its shard. The launch is WF_SHARDS runs of ctrl_groups(q)
// workgroups, run s over shard s (contract::Control); with one shard, entry group·64 + lane.
fn wf_slot(q: u32, group: u32, lane: u32) -> u32 {
    var s = 0u;
    var k = group * WF_WORKGROUP + lane;
    if (WF_SHARDS > 1u) {
        let per = max(atomicLoad(&control[ctrl_groups(q)]), 1u);
        s = min(div_small(group, per), WF_SHARDS - 1u);
        k = (group - s * per) * WF_WORKGROUP + lane;
    }
    if (k >= atomicLoad(&control[ctrl_count(q, s)])) {
        return WF_NONE;
    }
    return queues[(q * WF_SHARDS + s) * batch.shard_slots + k];
}
// #endif

// #if WF_DEFERRED
// #requires constants
// Where record r of path `slot` starts in `deferred_refs` (a count, then up to
// CSG_DEFER_SLOTS tree references): r = 0 for the closest-hit query, 1 + k for shadow ray k.
fn deferred_record(slot: u32, r: u32) -> u32 {
    return (slot * (1u + batch.shadow_rays) + r) * (CSG_DEFER_SLOTS + 1u);
}
// #endif

// #if WF_PUSH
// Appends path `slot` to its shard of queue q (each path is in at most one queue of a kind
// per bounce, so a shard never holds more entries than its slots, which its region of
// batch.shard_slots entries holds: Control::shard_slots). The push that starts a
// workgroup's worth of entries grows the queue's launch to cover it: the largest such k
// makes it WF_SHARDS runs of the longest shard's ⌈length / WF_WORKGROUP⌉ workgroups, one
// row (Control::max_slots), so no control kernel has to turn lengths into launch arguments
// between stages.
fn wf_push(q: u32, slot: u32) {
    let s = wf_shard(slot);
    let k = atomicAdd(&control[ctrl_count(q, s)], 1u);
    queues[(q * WF_SHARDS + s) * batch.shard_slots + k] = slot;
    if (k % WF_WORKGROUP == 0u) {
        wf_grow_launch(q, k / WF_WORKGROUP + 1u);
    }
}
// #endif

// #if WF_RADIANCE_ADD
// Adds `e` to the path's radiance. Most contributions are zero (a surface that emits
// nothing, a black sky): those skip the read-modify-write, eight per-lane storage accesses
// on llvmpipe, without changing any sum (x + 0 = x; a NaN is added, for the film to count).
fn add_radiance(slot: u32, e: vec3<f32>) {
    if (any(e != vec3<f32>(0.0))) {
        let i = field(F_RADIANCE, slot);
        paths_set(i, vec4<f32>(paths_get(i).xyz + e, 0.0));
    }
}
// #endif

// #if WF_BETA_LOAD
// The path's throughput and the previous vertex's BSDF density (F_BETA). The camera stage
// does not store it: at bounce 0 every path has throughput 1 and comes from the camera, a
// delta vertex (negative density), so bounce 0's vertices skip the load.
fn load_beta(slot: u32, bounce: u32) -> vec4<f32> {
    var beta = vec4<f32>(1.0, 1.0, 1.0, -1.0);
    if (bounce != 0u) {
        beta = paths_get(field(F_BETA, slot));
    }
    return beta;
}
// #endif

// #if WF_RAY_LOAD
fn load_ray(slot: u32) -> Ray {
    let o = paths_get(field(F_RAY_ORIGIN, slot));
    let d = paths_get(field(F_RAY_DIR, slot));
    return Ray(o.xyz, d.xyz, o.w, d.w);
}
// #endif

// #if WF_RAY_STORE
fn store_ray(slot: u32, ray: Ray) {
    paths_set(field(F_RAY_ORIGIN, slot), vec4<f32>(ray.origin, ray.tmin));
    paths_set(field(F_RAY_DIR, slot), vec4<f32>(ray.dir, ray.tmax));
}
// #endif

// #if WF_PATH_ID
// The pixel (row-major index) and camera sample j of path `slot`, and its index in the
// stream rule: sample j·n + i for path i of camera sample j (DESIGN.md "Pixel estimate").
struct PathId {
    pixel: u32,
    j: u32,
    sample: u32,
}

fn path_id(slot: u32) -> PathId {
    let n = batch.paths_per_sample;
    let per_pixel = batch.samples * n;
    let p = div_small(slot, per_pixel);
    let r = slot - p * per_pixel;
    let i = div_small(r, n);
    let j = batch.sample_begin + i;
    return PathId(batch.pixel_begin + p * batch.pixel_stride, j, j * n + r - i * n);
}
// #endif
