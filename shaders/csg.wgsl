// #requires shapes constants bindings wavefront
// Constructive solid geometry by interval lists along the ray: mirrors cpu::csg.
//
// WGSL has neither recursion nor dynamic arrays, so the tree is evaluated depth-first with
// an explicit frame stack, and interval lists live in fixed slots of CSG_MAX_INTERVALS
// entries (the bound csg::max_intervals computes from the scene). Frame f (a node at
// depth f) keeps its accumulated list in slot 2f and, for DIFF, the list to cut in slot
// 2f + 1; a child's result arrives in slot 2(f + 1); the last slot is scratch.
//
// Large lists live in the `csg_pool` storage buffer, CSG_POOL_SIZE intervals per path
// slot, not in private arrays: the kernel's code and private memory stay bounded whatever
// the scene's bound (a UNITE of 1,000 spheres compiles like one of 100), and the host keeps
// the pool within a memory budget by the number of slots per batch.

const CSG_SLOTS: u32 = 2u * CSG_MAX_DEPTH + 2u;
const CSG_SCRATCH: u32 = CSG_SLOTS - 1u;
// Pieces no longer than CSG_SLIVER relative to their ends are dropped (csg::SLIVER, which
// is 256 f64 ulps; this is 256 f32 ulps, 2⁻¹⁵).
const CSG_SLIVER: f32 = 3.0517578125e-5;

// One end of an interval: the ray parameter and the surface bounding the solid there,
// packed into one word (`tag`): the leaf's shape index above CSG_END_FACE_BITS + 1 bits,
// then the flip bit (a carved surface), then the face (layout::CSG_END_FACE_BITS; the
// packer keeps shape indices below layout::CSG_LEAF_LIMIT). An open end (no surface) has
// the all-ones leaf field, whatever its flip bit. Two words per end instead of four nearly
// halved streetlamp.sl's time on llvmpipe (GL backend), where every private-array access
// is a per-lane gather or scatter.
struct End {
    t: f32,
    tag: u32,
}

const CSG_END_FLIP: u32 = 1u << CSG_END_FACE_BITS;
const CSG_END_LEAF_SHIFT: u32 = CSG_END_FACE_BITS + 1u;
const CSG_END_OPEN: u32 = 0xFFFFFFFFu >> CSG_END_LEAF_SHIFT;

fn end_leaf(e: End) -> u32 {
    return e.tag >> CSG_END_LEAF_SHIFT;
}

fn end_face(e: End) -> u32 {
    return e.tag & (CSG_END_FLIP - 1u);
}

fn end_flipped(e: End) -> bool {
    return (e.tag & CSG_END_FLIP) != 0u;
}

struct Interval {
    enter: End,
    exit: End,
}

// Small lists (CSG_POOL_PRIVATE: at most wavefront::CSG_PRIVATE_POOL_MAX intervals per
// path) stay in private memory, which llvmpipe accesses far faster than a storage buffer.
// #if CSG_POOL_PRIVATE
var<private> csg_pool: array<Interval, CSG_POOL_SIZE>;
// #endif

// This invocation's first interval in `csg_pool`: set by the stage (csg_use_slot); 0 for
// the private pool.
var<private> csg_base: u32;
var<private> csg_len: array<u32, CSG_SLOTS>;
// Where each slot's list lives, in units of intervals from csg_base: the slots own the
// CSG_SLOTS buffers of CSG_MAX_INTERVALS entries in some order, and moving a whole list to
// another slot swaps two buffers (OP_SWAP) instead of copying it.
var<private> csg_off: array<u32, CSG_SLOTS>;

// The stages that evaluate trees call this first, for the path slot they work on.
fn csg_use_slot(slot: u32) {
// #if !CSG_POOL_PRIVATE
    csg_base = slot * CSG_POOL_SIZE;
// #endif
}

// The pool index of entry i of a list slot.
fn csg_at(slot: u32, i: u32) -> u32 {
    return csg_base + csg_off[slot] + i;
}

fn csg_get(slot: u32, i: u32) -> Interval {
    return csg_pool[csg_at(slot, i)];
}

// Appends to a slot; the scene's bound guarantees room (an overflow would drop the rest).
fn csg_push(slot: u32, iv: Interval) {
    let n = csg_len[slot];
    if (n < CSG_MAX_INTERVALS) {
        csg_pool[csg_at(slot, n)] = iv;
        csg_len[slot] = n + 1u;
    }
}

fn csg_append(dst: u32, src: u32) {
    for (var i = 0u; i < csg_len[src]; i++) {
        csg_push(dst, csg_get(src, i));
    }
}

// Stable insertion sort by entry (csg::sort).
fn csg_sort(slot: u32) {
    let base = csg_at(slot, 0u);
    for (var i = 1u; i < csg_len[slot]; i++) {
        let iv = csg_pool[base + i];
        var j = i;
        while (j > 0u && csg_pool[base + j - 1u].enter.t > iv.enter.t) {
            csg_pool[base + j] = csg_pool[base + j - 1u];
            j--;
        }
        csg_pool[base + j] = iv;
    }
}

// A sorted list's union into disjoint intervals, in place (csg::merge after its sort).
fn csg_coalesce(slot: u32) {
    let base = csg_at(slot, 0u);
    var out = 0u;
    for (var i = 0u; i < csg_len[slot]; i++) {
        let iv = csg_pool[base + i];
        if (out > 0u && iv.enter.t <= csg_pool[base + out - 1u].exit.t) {
            if (iv.exit.t > csg_pool[base + out - 1u].exit.t) {
                csg_pool[base + out - 1u].exit = iv.exit;
            }
        } else {
            csg_pool[base + out] = iv;
            out++;
        }
    }
    csg_len[slot] = out;
}

// Whether the piece [a, b] is longer than a sliver (csg::solid). Open ends are ±OPEN,
// finite, so one formula covers them.
fn csg_solid(a: f32, b: f32) -> bool {
    return b - a > CSG_SLIVER * max(abs(a), abs(b));
}

// scratch := pairwise intersection of a and b, pieces longer than a sliver, unsorted
// (csg::intersect before its sort).
fn csg_intersect(a: u32, b: u32) {
    csg_len[CSG_SCRATCH] = 0u;
    for (var i = 0u; i < csg_len[a]; i++) {
        let x = csg_get(a, i);
        for (var k = 0u; k < csg_len[b]; k++) {
            let y = csg_get(b, k);
            var enter = x.enter;
            if (y.enter.t > x.enter.t) {
                enter = y.enter;
            }
            var exit = x.exit;
            if (y.exit.t < x.exit.t) {
                exit = y.exit;
            }
            if (csg_solid(enter.t, exit.t)) {
                csg_push(CSG_SCRATCH, Interval(enter, exit));
            }
        }
    }
}

fn flipped(e: End) -> End {
    return End(e.t, e.tag ^ CSG_END_FLIP);
}

// scratch := a minus the disjoint sorted `cut`, unsorted; cut ends become carved surfaces
// (csg::subtract before its sort).
fn csg_subtract(a: u32, cut: u32) {
    csg_len[CSG_SCRATCH] = 0u;
    for (var i = 0u; i < csg_len[a]; i++) {
        let x = csg_get(a, i);
        var start = x.enter;
        var open = true;
        for (var k = 0u; k < csg_len[cut]; k++) {
            if (!open) {
                break;
            }
            let y = csg_get(cut, k);
            if (y.exit.t <= start.t) {
                continue;
            }
            if (y.enter.t >= x.exit.t) {
                break;
            }
            if (csg_solid(start.t, y.enter.t)) {
                csg_push(CSG_SCRATCH, Interval(start, flipped(y.enter)));
            }
            open = y.exit.t < x.exit.t;
            start = flipped(y.exit);
        }
        if (open && csg_solid(start.t, x.exit.t)) {
            csg_push(CSG_SCRATCH, Interval(start, x.exit));
        }
    }
}

fn end_from_crossing(c: Crossing, leaf: u32) -> End {
    let l = select(CSG_END_OPEN, leaf, abs(c.t) < OPEN);
    return End(c.t, (l << CSG_END_LEAF_SHIFT) | c.face);
}

// Appends the leaf's interval (if any) to `slot`.
fn csg_leaf(slot: u32, shape: u32, ray: Ray) {
    let sp = shape_span(shape, ray);
    if (sp.valid) {
        csg_push(slot, Interval(end_from_crossing(sp.enter, shape), end_from_crossing(sp.exit, shape)));
    }
}

// The list operations a step of the evaluation runs, as (operation, slot, slot) triples in
// `csg_ops`, executed by one loop (csg_run) that calls each list function from one place
// only: Mesa inlines every call, and the several call sites of sort and copy the nodes'
// rules would otherwise have made compiled the interval code several times over.
const OP_CLEAR: u32 = 0u;
const OP_APPEND: u32 = 1u;
const OP_SORT: u32 = 2u;
const OP_COALESCE: u32 = 3u;
const OP_INTERSECT: u32 = 4u;
const OP_SUBTRACT: u32 = 5u;
const OP_SWAP: u32 = 6u;
// A step plans at most a node's finish (DIFF: 5 operations) and its fold into the parent
// (INTERSECT: 3).
const CSG_MAX_OPS: u32 = 8u;

var<private> csg_ops: array<vec3<u32>, CSG_MAX_OPS>;
var<private> csg_op_count: u32;

fn csg_plan(op: u32, a: u32, b: u32) {
    csg_ops[csg_op_count] = vec3<u32>(op, a, b);
    csg_op_count++;
}

// Replaces list `dst` by the scratch list sorted (the end of INTERSECT and DIFF).
fn plan_sorted_scratch_into(dst: u32) {
    csg_plan(OP_SORT, CSG_SCRATCH, 0u);
    csg_plan(OP_SWAP, dst, CSG_SCRATCH);
}

// Where a leaf that is child number `i` of a node of frame f puts its interval: straight
// into the list the node folds it into, but for INTERSECT's later children, which are
// intersected from their own slot `own`. The caller clears the node's lists at i = 0.
fn leaf_target(op: u32, f: u32, i: u32, own: u32) -> u32 {
    let acc = 2u * f;
    if (i == 0u || op == CSG_UNITE || op == CSG_FUSE) {
        return acc;
    }
    if (op == CSG_DIFF) {
        return acc + 1u;
    }
    return own;
}

// Folds child number `i` (its list in `src`) into the node of frame f.
fn plan_combine(op: u32, f: u32, i: u32, src: u32) {
    let acc = 2u * f;
    if (i == 0u) {
        csg_plan(OP_SWAP, acc, src);
        csg_plan(OP_CLEAR, acc + 1u, 0u);
        return;
    }
    switch op {
        case CSG_INTERSECT: {
            csg_plan(OP_INTERSECT, acc, src);
            plan_sorted_scratch_into(acc);
        }
        case CSG_DIFF: {
            csg_plan(OP_APPEND, acc + 1u, src);
        }
        default: {
            csg_plan(OP_APPEND, acc, src);
        }
    }
}

// The node's final list, in its accumulator slot.
fn plan_finish(op: u32, f: u32) {
    let acc = 2u * f;
    switch op {
        case CSG_UNITE: {
            csg_plan(OP_SORT, acc, 0u);
        }
        case CSG_DIFF: {
            csg_plan(OP_SORT, acc + 1u, 0u);
            csg_plan(OP_COALESCE, acc + 1u, 0u);
            csg_plan(OP_SUBTRACT, acc, acc + 1u);
            plan_sorted_scratch_into(acc);
        }
        case CSG_FUSE: {
            csg_plan(OP_SORT, acc, 0u);
            csg_plan(OP_COALESCE, acc, 0u);
        }
        default: {}
    }
}

// Runs the planned operations, in order.
fn csg_run() {
    for (var k = 0u; k < csg_op_count; k++) {
        let o = csg_ops[k];
        switch o.x {
            case OP_CLEAR: {
                csg_len[o.y] = 0u;
            }
            case OP_APPEND: {
                csg_append(o.y, o.z);
            }
            case OP_SORT: {
                csg_sort(o.y);
            }
            case OP_COALESCE: {
                csg_coalesce(o.y);
            }
            case OP_INTERSECT: {
                csg_intersect(o.y, o.z);
            }
            case OP_SWAP: {
                let off = csg_off[o.y];
                csg_off[o.y] = csg_off[o.z];
                csg_off[o.z] = off;
                let len = csg_len[o.y];
                csg_len[o.y] = csg_len[o.z];
                csg_len[o.z] = len;
            }
            default: {
                csg_subtract(o.y, o.z);
            }
        }
    }
    csg_op_count = 0u;
}

// Evaluates the tree rooted at node `root` along the ray's whole line; the result is in
// slot 0, sorted by entry.
fn csg_intervals(root: u32, ray: Ray) {
    // One frame more than the tree's depth: with a one-element array (trees one level
    // deep) wgpu's OpenGL backend on Mesa's llvmpipe (22.3, LLVM 15) mis-executes this loop,
    // running it to its loop limiter with carved surfaces taking the wrong leaf
    // (tests/gpu_render.rs, csg_one_level_deep_matches_the_cpu, with WGPU_BACKEND=gl;
    // Vulkan's lavapipe was right). The spare frame is never written.
    var frames: array<vec2<u32>, CSG_MAX_DEPTH + 1u>;
    frames[0] = vec2<u32>(root, 0u);
    var depth = 1u;
    for (var k = 0u; k < CSG_SLOTS; k++) {
        csg_off[k] = k * CSG_MAX_INTERVALS;
        csg_len[k] = 0u;
    }
    csg_op_count = 0u;
    var done = false;
    while (!done) {
        let f = depth - 1u;
        let node = csg_nodes[frames[f].x];
        let i = frames[f].y;
        if (i == node.child_count) {
            // The node is complete: finish it and fold it into its parent.
            plan_finish(node.op, f);
            if (f == 0u) {
                done = true;
            } else {
                depth = f;
                let parent = csg_nodes[frames[f - 1u].x];
                plan_combine(parent.op, f - 1u, frames[f - 1u].y - 1u, 2u * f);
            }
        } else {
            frames[f].y = i + 1u;
            let r = object_ref(node.first_child + i);
            if ((r & CSG_NODE_BIT) != 0u && depth < CSG_MAX_DEPTH) {
                frames[depth] = vec2<u32>(r & ~CSG_NODE_BIT, 0u);
                depth++;
                continue;
            }
            let own = 2u * depth;
            let dst = leaf_target(node.op, f, i, own);
            if (i == 0u) {
                csg_len[2u * f] = 0u;
                csg_len[2u * f + 1u] = 0u;
            }
            csg_len[own] = 0u;
            csg_leaf(dst, r & ~CSG_NODE_BIT, ray);
            if (dst == own) {
                plan_combine(node.op, f, i, own);
            }
        }
        csg_run();
    }
}

// The closest surface of the tree inside (tmin, tmax): csg::CsgTree::closest.
fn csg_first(root: u32, ray: Ray, object: u32) -> Candidate {
    csg_intervals(root, ray);
    var best = no_candidate();
    for (var i = 0u; i < csg_len[0]; i++) {
        let iv = csg_get(0u, i);
        for (var k = 0u; k < 2u; k++) {
            var e = iv.exit;
            if (k == 0u) {
                e = iv.enter;
            }
            if (end_leaf(e) != CSG_END_OPEN && e.t > ray.tmin && e.t < ray.tmax && e.t < best.c.t) {
                best = Candidate(Crossing(e.t, end_face(e)), end_leaf(e), end_flipped(e), object);
            }
        }
    }
    return best;
}
