// #requires shapes constants bindings wavefront
// Constructive solid geometry by classifying the leaves' crossings: the algorithm of
// cpu::csg, which says what the bits mean and why. Every crossing is classified by a walk
// of the tree, as cpu::csg does for a query's first 16; past those the CPU switches to
// sweeps that give the same classifications in O(n log n) (DESIGN.md "Sweeps for rays with
// many hidden crossings"). The GPU has no sweeps yet, so a ray through many hidden
// crossings costs it O(n²).
//
// A query first computes the leaves' spans along the ray's line in one loop, stores them
// in `csg_pool` (in program order) and gathers the first CSG_BATCH crossings after tmin.
// Each classification is then one run of the tree's program (layout::csg_instr: the nodes
// and leaves depth first, built by gpu::pack), which replaces recursion: BEGIN opens a
// node, LEAF folds the next leaf into the innermost open node, END finishes that node and
// folds it into its parent. A run classifies the batch and gathers the crossings after it,
// until the root shows a crossing or none is left before tmax. One loop does every run, so
// the code is one walk whatever the tree, and the memory one span per leaf: no interval
// lists, whose per-lane private-array traffic was the slow part of CSG on SIMD software
// GPUs.
//
// Spans of trees with many leaves live in the `csg_pool` storage buffer, CSG_POOL_SIZE per
// path slot, not in private arrays: the kernel's code and private memory stay bounded
// whatever the scene (a UNITE of 1,000 spheres compiles like one of 100), and the host
// keeps the pool within a memory budget by the number of slots per batch.

// Probes lie CSG_SLIVER·|t| before and after a crossing (cpu::csg::SLIVER is 256 f64
// ulps; this is 256 f32 ulps, 2⁻¹⁵).
const CSG_SLIVER: f32 = 3.0517578125e-5;

// A tree's leaf spans, in `csg_pool` from csg_base: entry `leaf` holds the span's entry
// and exit t (bit patterns), entry CSG_POOL_LEAVES + `leaf` their faces. Classification
// reads only the first half, two words per leaf; the faces are read once, for the hit. A
// line that misses a leaf gets the empty span (OPEN, -OPEN); open ends (|t| = OPEN) have
// no surface. Small trees (CSG_POOL_PRIVATE: at most wavefront::CSG_PRIVATE_POOL_MAX
// entries, 64 leaves) keep their spans in private memory, which llvmpipe accesses faster
// than a storage buffer.
struct CsgPoolEntry {
    a: u32,
    b: u32,
}

const CSG_POOL_LEAVES: u32 = CSG_POOL_SIZE / 2u;

// #if CSG_POOL_PRIVATE
var<private> csg_pool: array<CsgPoolEntry, CSG_POOL_SIZE>;
// #endif

// This invocation's first entry in `csg_pool`: set by the stage (csg_use_slot); 0 for the
// private pool.
var<private> csg_base: u32;

// The stages that evaluate trees call this first, for the path slot they work on.
fn csg_use_slot(slot: u32) {
// #if !CSG_POOL_PRIVATE
    csg_base = slot * CSG_POOL_SIZE;
// #endif
}

// Computes and stores leaf number `leaf`'s span (shape `shape`); returns its t's.
fn csg_store_span(leaf: u32, shape: u32, ray: Ray) -> vec2<f32> {
    let sp = shape_span(shape, ray);
    var t = vec2<f32>(OPEN, -OPEN);
    if (sp.valid) {
        t = clamp(vec2<f32>(sp.enter.t, sp.exit.t), vec2<f32>(-OPEN), vec2<f32>(OPEN));
    }
    csg_pool[csg_base + leaf] = CsgPoolEntry(bitcast<u32>(t.x), bitcast<u32>(t.y));
    csg_pool[csg_base + CSG_POOL_LEAVES + leaf] = CsgPoolEntry(sp.enter.face, sp.exit.face);
    return t;
}

fn csg_span(leaf: u32) -> vec2<f32> {
    let e = csg_pool[csg_base + leaf];
    return vec2<f32>(bitcast<f32>(e.a), bitcast<f32>(e.b));
}

// What a node says about a crossing being classified (cpu::csg's bits). A walk classifies
// up to CSG_BATCH crossings at once, each in its own CSG_FIELD-bit field of one word, so
// that a ray passing many hidden crossings (a hollow lamp, a carved block) needs a third
// of the walks; every operation below works on all fields at once.
const CSG_BATCH: u32 = 3u;
const CSG_FIELD: u32 = 10u;
const CSG_ONES: u32 = 1u | (1u << CSG_FIELD) | (1u << (2u * CSG_FIELD));
const CSG_BEFORE: u32 = 1u;
const CSG_AFTER: u32 = 2u;
const CSG_ENTERS: u32 = 4u;
const CSG_EXITS: u32 = 8u;
const CSG_OWN: u32 = 16u;
const CSG_FLIP: u32 = 32u;
// Bits 64, 128 and 256: a DIFF's CUT_BEFORE, CUT_AFTER and CUT_OWN.
const CSG_CUT_SHIFT: u32 = 6u;
const CSG_SOLID: u32 = 3u * CSG_ONES;

// Adds a child's classification `b` to a node's accumulator (cpu::csg::fold); `first`
// for the node's first child.
fn csg_fold(op: u32, acc: u32, first: bool, b: u32) -> u32 {
    if (op == CSG_UNITE || op == CSG_FUSE) {
        return acc | b;
    }
    if (first) {
        return b;
    }
    if (op == CSG_INTERSECT) {
        return (acc & b & CSG_SOLID) | ((acc | b) & ~CSG_SOLID);
    }
    // DIFF: the cut's solid, and where the cut owns the crossing, CUT_OWN and a flip.
    let own = b & (CSG_OWN * CSG_ONES);
    return acc | ((b & CSG_SOLID) << CSG_CUT_SHIFT) | own | (own << 4u) | ((b & (CSG_FLIP * CSG_ONES)) ^ (own << 1u));
}

// Bit `k` of every field, moved to the field's bit 0.
fn csg_field_bit(acc: u32, k: u32) -> u32 {
    return (acc >> k) & CSG_ONES;
}

// A node's classification from its accumulator (cpu::csg::finish), on every field.
fn csg_finish(op: u32, acc: u32) -> u32 {
    let had_before = csg_field_bit(acc, 0u);
    let had_after = csg_field_bit(acc, 1u);
    var enters = csg_field_bit(acc, 2u);
    var exits = csg_field_bit(acc, 3u);
    let own = csg_field_bit(acc, 4u);
    let cut_before = csg_field_bit(acc, 6u);
    let cut_after = csg_field_bit(acc, 7u);
    let cut_own = csg_field_bit(acc, 8u);
    var before = had_before;
    var after = had_after;
    if (op == CSG_FUSE) {
        enters = own & ~before & after;
        exits = own & before & ~after;
    } else if (op == CSG_INTERSECT) {
        enters = enters & after;
        exits = exits & before;
    } else if (op == CSG_DIFF) {
        before = had_before & ~cut_before;
        after = had_after & ~cut_after;
        enters = (cut_own & cut_before & ~cut_after & had_after) | (~cut_own & enters & ~cut_after);
        exits = (cut_own & ~cut_before & cut_after & had_before) | (~cut_own & exits & ~cut_before);
    }
    let bits = (before & CSG_ONES) | ((after & CSG_ONES) << 1u) | ((enters & CSG_ONES) << 2u) | ((exits & CSG_ONES) << 3u);
    return bits | (acc & ((CSG_OWN | CSG_FLIP) * CSG_ONES));
}

// The walk's state for an open node, one word: the accumulator's fields in bits 0-29, bit
// 9 (spare in every field) set once a child was folded in, the operation in bits 30-31.
// The innermost open node's word stays in a register; the walk pushes the others on a
// stack only when it opens a node.
const CSG_OPEN_SEEN: u32 = 1u << 9u;
const CSG_OPEN_OP_SHIFT: u32 = 30u;
const CSG_OPEN_ACC: u32 = 0x1FFu * CSG_ONES;

// Crossing (t, key) comes before (u, l): keys (2·leaf number + 1 for an exit) break ties.
fn csg_before(t: f32, key: u32, u: f32, l: u32) -> bool {
    return t < u || (t == u && key < l);
}

// Up to CSG_BATCH crossings in order, by t and key (2·leaf + 1 for an exit); unused ones
// have t = tmax.
struct CsgBatch {
    t: vec3<f32>,
    key: vec3<u32>,
}

// Offers the crossing (t, key k) to `next`, the first CSG_BATCH crossings with a surface
// inside (tmin, tmax) after (after_t, after_key).
fn csg_offer(next: ptr<function, CsgBatch>, t: f32, k: u32, after_t: f32, after_key: u32, tmin: f32) {
    if (abs(t) >= OPEN || t <= tmin || !csg_before(after_t, after_key, t, k)
        || !csg_before(t, k, (*next).t.z, (*next).key.z)) {
        return;
    }
    if (!csg_before(t, k, (*next).t.y, (*next).key.y)) {
        (*next).t.z = t;
        (*next).key.z = k;
        return;
    }
    (*next).t.z = (*next).t.y;
    (*next).key.z = (*next).key.y;
    if (!csg_before(t, k, (*next).t.x, (*next).key.x)) {
        (*next).t.y = t;
        (*next).key.y = k;
        return;
    }
    (*next).t.y = (*next).t.x;
    (*next).key.y = (*next).key.x;
    (*next).t.x = t;
    (*next).key.x = k;
}

// The closest surface of tree `root` inside (tmin, tmax): csg::CsgTree::closest.
fn csg_first(root: u32, ray: Ray, object: u32) -> Candidate {
    let tree = csg_tree_at(root);
    let none = CsgBatch(vec3<f32>(ray.tmax), vec3<u32>(0u));
    // The leaves' spans, and the first crossings after tmin.
    var batch = none;
    for (var leaf = 0u; leaf < tree.leaf_count; leaf++) {
        let span = csg_store_span(leaf, tree.first_leaf + leaf, ray);
        csg_offer(&batch, span.x, 2u * leaf, ray.tmin, 0xFFFFFFFFu, ray.tmin);
        csg_offer(&batch, span.y, 2u * leaf + 1u, ray.tmin, 0xFFFFFFFFu, ray.tmin);
    }
    // One entry more than the tree's depth: a one-element private array indexed by a
    // variable once mis-executed on wgpu's OpenGL backend over Mesa's llvmpipe (22.3).
    var stack: array<u32, CSG_MAX_DEPTH + 1u>;
    var best = no_candidate();
    // Each run of the program classifies `batch` and gathers the crossings after it.
    while (batch.t.x < ray.tmax) {
        let s = CSG_SLIVER * abs(batch.t);
        let before = batch.t - s;
        let after = batch.t + s;
        let own_leaf = batch.key >> vec3<u32>(1u);
        let own_bits = select(
            vec3<u32>(CSG_OWN | CSG_AFTER | CSG_ENTERS),
            vec3<u32>(CSG_OWN | CSG_BEFORE | CSG_EXITS),
            (batch.key & vec3<u32>(1u)) != vec3<u32>(0u)
        );
        var next = none;
        var open = 0u;
        var depth = 0u;
        var leaf = 0u;
        var root_bits = 0u;
        var word = 0u;
        for (var pc = 0u; pc < tree.length; pc++) {
            let slot = pc % CSG_INSTR_PER_WORD;
            if (slot == 0u) {
                word = object_ref(tree.program + pc / CSG_INSTR_PER_WORD);
            }
            let instr = (word >> (slot * CSG_INSTR_BITS)) & ((1u << CSG_INSTR_BITS) - 1u);
            if (instr >= CSG_INSTR_BEGIN) {
                stack[depth] = open;
                depth++;
                open = (instr - CSG_INSTR_BEGIN) << CSG_OPEN_OP_SHIFT;
                continue;
            }
            var b = 0u;
            if (instr == CSG_INSTR_END) {
                b = csg_finish(open >> CSG_OPEN_OP_SHIFT, open & CSG_OPEN_ACC);
                depth--;
                open = stack[depth];
                if (depth == 0u) {
                    root_bits = b;
                    break;
                }
            } else {
                let span = csg_span(leaf);
                let in_before = (vec3<f32>(span.x) < before) & (before < vec3<f32>(span.y));
                let in_after = (vec3<f32>(span.x) < after) & (after < vec3<f32>(span.y));
                let inside = select(vec3<u32>(0u), vec3<u32>(CSG_BEFORE), in_before)
                    | select(vec3<u32>(0u), vec3<u32>(CSG_AFTER), in_after);
                let bits = select(inside, own_bits, own_leaf == vec3<u32>(leaf));
                b = bits.x | (bits.y << CSG_FIELD) | (bits.z << (2u * CSG_FIELD));
                csg_offer(&next, span.x, 2u * leaf, batch.t.z, batch.key.z, ray.tmin);
                csg_offer(&next, span.y, 2u * leaf + 1u, batch.t.z, batch.key.z, ray.tmin);
                leaf++;
            }
            // Fold b into the innermost open node.
            let acc = csg_fold(open >> CSG_OPEN_OP_SHIFT, open & CSG_OPEN_ACC, (open & CSG_OPEN_SEEN) == 0u, b);
            open = (open & ~CSG_OPEN_ACC) | CSG_OPEN_SEEN | acc;
        }
        // The first crossing of the batch that the root shows, if any.
        let shown = (vec3<u32>(root_bits) >> vec3<u32>(2u, CSG_FIELD + 2u, 2u * CSG_FIELD + 2u)) & vec3<u32>(3u);
        let flips = (vec3<u32>(root_bits) >> vec3<u32>(5u, CSG_FIELD + 5u, 2u * CSG_FIELD + 5u)) & vec3<u32>(1u);
        let hit = (batch.t < vec3<f32>(ray.tmax)) & (shown != vec3<u32>(0u));
        if (any(hit)) {
            var q = 2u;
            if (hit.y) {
                q = 1u;
            }
            if (hit.x) {
                q = 0u;
            }
            let leaf = batch.key[q] >> 1u;
            let faces = csg_pool[csg_base + CSG_POOL_LEAVES + leaf];
            let face = select(faces.a, faces.b, (batch.key[q] & 1u) != 0u);
            best = Candidate(Crossing(batch.t[q], face), tree.first_leaf + leaf, flips[q] != 0u, object);
            break;
        }
        batch = next;
    }
    return best;
}
