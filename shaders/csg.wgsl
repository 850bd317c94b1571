// #requires shapes constants bindings wavefront
// Constructive solid geometry by classifying the leaves' crossings: the algorithm of
// cpu::csg, which says what the bits mean and why. A query's first crossings are classified
// by walks of the tree, as cpu::csg does for its first 16. In a tree of more than 64
// leaves (one with a sweep table) a query that passes CSG_WALKED_RUNS runs of walks goes on
// with the sweeps at the end of this file, which give the same classifications in
// O(n log n) (DESIGN.md "Sweeps for rays with many hidden crossings"). Their code is
// compiled in (CSG_SWEEPS) only once a render needs it: kernels without it give up on such
// a query and raise CTRL_CSG_OVER, and the host renders again with the sweeps.
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

// #if !CSG_POOL_PRIVATE
// Runs of walks before the sweeps take over (CSG_BATCH crossings each: about cpu::csg's
// WALKED_CROSSINGS) in a tree with a sweep table.
const CSG_WALKED_RUNS: u32 = 6u;
// #endif

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
// #if !CSG_POOL_PRIVATE
    var runs = 0u;
// #endif
    // Each run of the program classifies `batch` and gathers the crossings after it.
    while (batch.t.x < ray.tmax) {
// #if !CSG_POOL_PRIVATE
        // A ray still passing hidden crossings of a tree with a sweep table: the sweeps
        // classify the rest, from the batch's first crossing on. Kernels compiled without
        // them give up and say so; the host then renders again with them.
        if (tree.node_count != 0u && runs == CSG_WALKED_RUNS) {
// #if CSG_SWEEPS
            best = csg_sweep_first(tree, ray, object, batch.t.x, batch.key.x);
// #else
            atomicStore(&control[CTRL_CSG_OVER], 1u);
// #endif
            break;
        }
        runs++;
// #endif
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

// #if CSG_SWEEPS
// Sweeps (cpu::csg's, which say why they give the walks' classifications): after
// CSG_WALKED_RUNS runs of walks (CSG_BATCH crossings each, about cpu::csg's
// WALKED_CROSSINGS), a tree with a sweep table (layout::csg_sweep: parents, operations,
// places and child counts of its nodes in program order, then each leaf's node) classifies
// its remaining crossings by two sweeps, one per probe, moving forward along the ray. Each
// keeps per node whether its solid holds the probe and how many children do, updated from a
// leaf up to the first ancestor whose answer stays the same; a crossing is classified by
// folding its own bits up its path. With the span ends sorted once (heap sort, in place in
// the pool), a ray through n leaves' hidden crossings costs O(n log n) instead of a walk of
// all n per crossing. Pool entries past the faces: CSG_POOL_LEAVES orders (`a` the leaves
// by entry, `b` by exit), then the nodes' states (`a` the probe before, `b` after). The
// crossings start at the walks' first unclassified one, after tmin.

// A sweep's node state: whether the node's solid holds the probe, whether a DIFF's first
// child does, and how many of its other children do.
const CSG_HOLDS: u32 = 1u;
const CSG_FIRST_HOLDS: u32 = 2u;
const CSG_COUNT_ONE: u32 = 4u;
// Where the orders and the states start in a lane's pool.
const CSG_ORDERS: u32 = 2u * CSG_POOL_LEAVES;
const CSG_STATES: u32 = 3u * CSG_POOL_LEAVES;

// Word `side` (0: `a`, 1: `b`) of pool entry i. Every access of the sweeps goes through
// these two, from as few call sites as possible: llvmpipe inlines each site's per-lane
// storage access.
fn csg_word(i: u32, side: u32) -> u32 {
    let e = csg_pool[csg_base + i];
    return select(e.a, e.b, side == 1u);
}

fn csg_set_word(i: u32, side: u32, v: u32) {
    let e = csg_pool[csg_base + i];
    csg_pool[csg_base + i] = CsgPoolEntry(select(v, e.a, side == 1u), select(e.b, v, side == 1u));
}

// An f32 bit pattern as a key whose unsigned order is the floats' (−0 as +0; NaNs past
// the infinities), so that the orders are total whatever a span holds.
fn csg_order_key(bits: u32) -> u32 {
    let b = select(bits, 0u, bits == 0x80000000u);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

// Sorts the leaves by span entry (order `a`) and by exit (`b`), ties by leaf number: heap
// sort, in place, O(n log n) whatever the spans. Keys are (end key, leaf) pairs.
fn csg_sort_ends(n: u32) {
    for (var side = 0u; side < 2u; side++) {
        for (var i = 0u; i < n; i++) {
            csg_set_word(CSG_ORDERS + i, side, i);
        }
        // Build the heap (sift down from n/2 − 1 to 0), then move the largest to the end
        // n − 1 times; each sift moves a hole down from `hole` and drops `v` into it.
        var heap = n;
        var start = n / 2u;
        loop {
            var hole = 0u;
            var v = 0u;
            if (start > 0u) {
                start--;
                hole = start;
                v = csg_word(CSG_ORDERS + start, side);
            } else {
                if (heap <= 1u) {
                    break;
                }
                heap--;
                v = csg_word(CSG_ORDERS + heap, side);
                csg_set_word(CSG_ORDERS + heap, side, csg_word(CSG_ORDERS, side));
            }
            let kv = csg_order_key(csg_word(v, side));
            loop {
                var child = 2u * hole + 1u;
                if (child >= heap) {
                    break;
                }
                var c = csg_word(CSG_ORDERS + child, side);
                var kc = csg_order_key(csg_word(c, side));
                if (child + 1u < heap) {
                    let r = csg_word(CSG_ORDERS + child + 1u, side);
                    let kr = csg_order_key(csg_word(r, side));
                    if (kc < kr || (kc == kr && c < r)) {
                        child++;
                        c = r;
                        kc = kr;
                    }
                }
                if (!(kv < kc || (kv == kc && v < c))) {
                    break;
                }
                csg_set_word(CSG_ORDERS + hole, side, c);
                hole = child;
            }
            csg_set_word(CSG_ORDERS + hole, side, v);
        }
    }
}

// Node k's sweep-table words: parent, then its flags (operation | FIRST_CHILD | children).
fn csg_sweep_node(tree: CsgTree, k: u32) -> vec2<u32> {
    return vec2<u32>(object_ref(tree.sweep + 2u * k), csg_sweep_flags(tree, k));
}

// Node k's flags alone (a parent's operation and child count, without its own parent).
fn csg_sweep_flags(tree: CsgTree, k: u32) -> u32 {
    return object_ref(tree.sweep + 2u * k + 1u);
}

// The node of leaf `leaf` (the table's words after the nodes').
fn csg_leaf_node(tree: CsgTree, leaf: u32) -> u32 {
    return object_ref(tree.sweep + 2u * tree.node_count + leaf);
}

// The probe of sweep `side` has passed an end of `leaf` (cpu::csg::Sweep::advance and
// leaf_changed): the leaf's answer at x, read from its span, then its ancestors' up to the
// first that stays the same.
fn csg_leaf_changed(tree: CsgTree, side: u32, leaf: u32, x: f32) {
    let span = csg_span(leaf);
    var holds = span.x < x && x < span.y;
    var k = csg_leaf_node(tree, leaf);
    var s = csg_word(CSG_STATES + k, side);
    if (((s & CSG_HOLDS) != 0u) == holds) {
        return;
    }
    s ^= CSG_HOLDS;
    var stop = false;
    loop {
        csg_set_word(CSG_STATES + k, side, s);
        if (stop) {
            break;
        }
        let node = csg_sweep_node(tree, k);
        if (node.x == CSG_SWEEP_NO_PARENT) {
            break;
        }
        let up = csg_sweep_flags(tree, node.x);
        let op = up & CSG_SWEEP_OP_BITS;
        var sp = csg_word(CSG_STATES + node.x, side);
        if (op == CSG_DIFF && (node.y & CSG_SWEEP_FIRST_CHILD) != 0u) {
            sp = select(sp & ~CSG_FIRST_HOLDS, sp | CSG_FIRST_HOLDS, holds);
        } else if (holds) {
            sp += CSG_COUNT_ONE;
        } else {
            sp -= CSG_COUNT_ONE;
        }
        let count = sp / CSG_COUNT_ONE;
        var now = count > 0u;
        if (op == CSG_INTERSECT) {
            now = count == up >> CSG_SWEEP_CHILDREN_SHIFT;
        } else if (op == CSG_DIFF) {
            now = (sp & CSG_FIRST_HOLDS) != 0u && count == 0u;
        }
        // The parent's count changed; its answer too, or the walk up ends there.
        stop = ((sp & CSG_HOLDS) != 0u) == now;
        if (!stop) {
            sp ^= CSG_HOLDS;
        }
        holds = now;
        k = node.x;
        s = sp;
    }
}

// What the root says about the crossing of `leaf` (its exit when `exit`), the sweeps
// standing at its probes (cpu::csg::CsgTree::classify): the crossing's own bits folded up
// its path, each node's other children folded in as one child.
fn csg_sweep_classify(tree: CsgTree, leaf: u32, exit: bool) -> u32 {
    var k = csg_leaf_node(tree, leaf);
    var b = select(CSG_OWN | CSG_AFTER | CSG_ENTERS, CSG_OWN | CSG_BEFORE | CSG_EXITS, exit);
    loop {
        let node = csg_sweep_node(tree, k);
        if (node.x == CSG_SWEEP_NO_PARENT) {
            break;
        }
        let up = csg_sweep_flags(tree, node.x);
        let op = up & CSG_SWEEP_OP_BITS;
        let own_is_first = op == CSG_DIFF && (node.y & CSG_SWEEP_FIRST_CHILD) != 0u;
        var others = 0u;
        var first = 0u;
        for (var side = 0u; side < 2u; side++) {
            let sp = csg_word(CSG_STATES + node.x, side);
            let own = (csg_word(CSG_STATES + k, side) & CSG_HOLDS) != 0u && !own_is_first;
            // Children other than this one (cutters, in a DIFF) that hold the probe.
            let n = sp / CSG_COUNT_ONE - select(0u, 1u, own);
            var held = n > 0u;
            if (op == CSG_INTERSECT) {
                held = n + 1u == up >> CSG_SWEEP_CHILDREN_SHIFT;
            }
            others |= select(0u, CSG_BEFORE << side, held);
            first |= select(0u, CSG_BEFORE << side, (sp & CSG_FIRST_HOLDS) != 0u);
        }
        // A DIFF's first child is folded on its own, before the cutters.
        var acc: u32;
        if (op == CSG_DIFF && !own_is_first) {
            acc = csg_fold(op, csg_fold(op, first, false, others), false, b);
        } else {
            acc = csg_fold(op, csg_fold(op, 0u, true, b), false, others);
        }
        b = csg_finish(op, acc);
        k = node.x;
    }
    return b;
}

// The closest surface of `tree` along `ray` from the crossing (t0, key0) on, by the
// sweeps; the leaves' spans are in the pool (csg_first stored them).
fn csg_sweep_first(tree: CsgTree, ray: Ray, object: u32, t0: f32, key0: u32) -> Candidate {
    let n = tree.leaf_count;
    csg_sort_ends(n);
    for (var k = 0u; k < tree.node_count; k++) {
        csg_pool[csg_base + CSG_STATES + k] = CsgPoolEntry(0u, 0u);
    }
    // Per order: the next end the crossings (`next`) and the two probes have not passed.
    var next = vec2<u32>(0u);
    var probe = array<vec2<u32>, 2>(vec2<u32>(0u), vec2<u32>(0u));
    // The crossings in order are the two orders merged by (t, key): start at (t0, key0).
    let k0 = csg_order_key(bitcast<u32>(t0));
    for (var side = 0u; side < 2u; side++) {
        loop {
            if (next[side] >= n) {
                break;
            }
            let leaf = csg_word(CSG_ORDERS + next[side], side);
            let k = csg_order_key(csg_word(leaf, side));
            if (k > k0 || (k == k0 && 2u * leaf + side >= key0)) {
                break;
            }
            next[side]++;
        }
    }
    loop {
        // The nearer of the next entry and the next exit (at equal t, by key). Open ends
        // and NaNs are sorted last: a side that reaches one has no crossing left.
        var t = OPEN;
        var key = 0xFFFFFFFFu;
        for (var side = 0u; side < 2u; side++) {
            if (next[side] < n) {
                let leaf = csg_word(CSG_ORDERS + next[side], side);
                let te = bitcast<f32>(csg_word(leaf, side));
                if (abs(te) < OPEN && (key == 0xFFFFFFFFu || csg_before(te, 2u * leaf + side, t, key))) {
                    t = te;
                    key = 2u * leaf + side;
                }
            }
        }
        if (key == 0xFFFFFFFFu || !(t < ray.tmax)) {
            break;
        }
        next[key & 1u]++;
        // Both probes forward: past every entry before the probe, every exit at or before.
        let s = CSG_SLIVER * abs(t);
        for (var p = 0u; p < 2u; p++) {
            let x = select(t - s, t + s, p == 1u);
            let kx = csg_order_key(bitcast<u32>(x));
            loop {
                var leaf = 0xFFFFFFFFu;
                for (var side = 0u; side < 2u; side++) {
                    if (leaf == 0xFFFFFFFFu && probe[p][side] < n) {
                        let l = csg_word(CSG_ORDERS + probe[p][side], side);
                        let k = csg_order_key(csg_word(l, side));
                        if (k < kx || (side == 1u && k == kx)) {
                            leaf = l;
                            probe[p][side]++;
                        }
                    }
                }
                if (leaf == 0xFFFFFFFFu) {
                    break;
                }
                csg_leaf_changed(tree, p, leaf, x);
            }
        }
        let exit = (key & 1u) != 0u;
        let b = csg_sweep_classify(tree, key >> 1u, exit);
        if ((b & (CSG_ENTERS | CSG_EXITS)) != 0u) {
            let leaf = key >> 1u;
            let faces = csg_pool[csg_base + CSG_POOL_LEAVES + leaf];
            return Candidate(Crossing(t, select(faces.a, faces.b, exit)), tree.first_leaf + leaf, (b & CSG_FLIP) != 0u, object);
        }
    }
    return no_candidate();
}
// #endif
