// #requires shapes constants bindings wavefront
// Constructive solid geometry by classifying the leaves' crossings: the algorithm of
// cpu::csg, which says what the bits mean and why.
//
// WGSL has no recursion, so each classification is one depth-first walk of the tree with
// an explicit frame stack; one loop does every walk. The first walk computes the leaves'
// spans along the ray's line and stores them in `csg_pool` (one Interval per leaf, in the
// walk's order) and finds the first crossing after tmin; every later walk classifies the
// crossing found by the walk before and finds the next one, until the root shows a
// crossing or none is left before tmax. The code is one walk whatever the tree, and the
// memory one span per leaf: no interval lists, whose per-lane private-array traffic was
// the slow part of CSG on SIMD software GPUs.
//
// Spans of trees with many leaves live in the `csg_pool` storage buffer, CSG_POOL_SIZE per
// path slot, not in private arrays: the kernel's code and private memory stay bounded
// whatever the scene (a UNITE of 1,000 spheres compiles like one of 100), and the host
// keeps the pool within a memory budget by the number of slots per batch.

// Probes lie CSG_SLIVER·|t| before and after a crossing (cpu::csg::SLIVER is 256 f64
// ulps; this is 256 f32 ulps, 2⁻¹⁵).
const CSG_SLIVER: f32 = 3.0517578125e-5;

// One end of a leaf's span: the ray parameter and the surface there, packed into one word
// (`tag`): the leaf's shape index above the face's CSG_END_FACE_BITS bits (the packer keeps
// shape indices below layout::CSG_LEAF_LIMIT). An open end (no surface) has the all-ones
// leaf field.
struct End {
    t: f32,
    tag: u32,
}

const CSG_END_LEAF_SHIFT: u32 = CSG_END_FACE_BITS;
const CSG_END_OPEN: u32 = 0xFFFFFFFFu >> CSG_END_LEAF_SHIFT;

fn end_leaf(e: End) -> u32 {
    return e.tag >> CSG_END_LEAF_SHIFT;
}

fn end_face(e: End) -> u32 {
    return e.tag & ((1u << CSG_END_FACE_BITS) - 1u);
}

struct Interval {
    enter: End,
    exit: End,
}

// Small trees (CSG_POOL_PRIVATE: at most wavefront::CSG_PRIVATE_POOL_MAX leaves) keep their
// spans in private memory, which llvmpipe accesses faster than a storage buffer.
// #if CSG_POOL_PRIVATE
var<private> csg_pool: array<Interval, CSG_POOL_SIZE>;
// #endif

// This invocation's first span in `csg_pool`: set by the stage (csg_use_slot); 0 for the
// private pool.
var<private> csg_base: u32;

// The stages that evaluate trees call this first, for the path slot they work on.
fn csg_use_slot(slot: u32) {
// #if !CSG_POOL_PRIVATE
    csg_base = slot * CSG_POOL_SIZE;
// #endif
}

fn end_from_crossing(c: Crossing, leaf: u32) -> End {
    let l = select(CSG_END_OPEN, leaf, abs(c.t) < OPEN);
    return End(c.t, (l << CSG_END_LEAF_SHIFT) | c.face);
}

// A leaf's span; a line that misses it gets an empty span with no surfaces.
fn csg_leaf_span(shape: u32, ray: Ray) -> Interval {
    let sp = shape_span(shape, ray);
    if (!sp.valid) {
        let none = CSG_END_OPEN << CSG_END_LEAF_SHIFT;
        return Interval(End(OPEN, none), End(-OPEN, none));
    }
    return Interval(end_from_crossing(sp.enter, shape), end_from_crossing(sp.exit, shape));
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

// Adds child number `i`'s classification `b` to a node's accumulator (cpu::csg::fold).
fn csg_fold(op: u32, acc: u32, i: u32, b: u32) -> u32 {
    if (op == CSG_UNITE || op == CSG_FUSE) {
        return acc | b;
    }
    if (i == 0u) {
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

// A frame of the walk: the node index | op << 30, its next child, its accumulator.
const CSG_FRAME_OP_SHIFT: u32 = 30u;

fn csg_frame(node: u32) -> vec3<u32> {
    return vec3<u32>(node | (csg_nodes[node].op << CSG_FRAME_OP_SHIFT), 0u, 0u);
}

// Crossing (t, key) comes before (u, l): keys (2·leaf number + 1 for an exit) break ties.
fn csg_before(t: f32, key: u32, u: f32, l: u32) -> bool {
    return t < u || (t == u && key < l);
}

// The closest surface of the tree inside (tmin, tmax): csg::CsgTree::closest.
fn csg_first(root: u32, ray: Ray, object: u32) -> Candidate {
    // One frame more than the tree's depth: with a one-element array (trees one level
    // deep) wgpu's OpenGL backend on Mesa's llvmpipe (22.3, LLVM 15) mis-executed the walk
    // of the interval evaluator this replaced; the spare frame is never written.
    var frames: array<vec3<u32>, CSG_MAX_DEPTH + 1u>;
    // The crossings being classified, in order (none in the first walk); unused ones have
    // t = tmax. Every crossing after the last one is classified later.
    var batch_t = vec3<f32>(ray.tmax);
    var batch_key = vec3<u32>(0u);
    var batch_tag = vec3<u32>(0u);
    var last_t = ray.tmin;
    var last_key = 0xFFFFFFFFu;
    var first = true;
    var best = no_candidate();
    loop {
        let s = CSG_SLIVER * abs(batch_t);
        let before = batch_t - s;
        let after = batch_t + s;
        let own_leaf = batch_key >> vec3<u32>(1u);
        let own_bits = select(
            vec3<u32>(CSG_OWN | CSG_AFTER | CSG_ENTERS),
            vec3<u32>(CSG_OWN | CSG_BEFORE | CSG_EXITS),
            (batch_key & vec3<u32>(1u)) != vec3<u32>(0u)
        );
        // The next batch: the CSG_BATCH first crossings after (last_t, last_key).
        var n0 = vec3<u32>(0u);
        var n1 = vec3<u32>(0u);
        var n2 = vec3<u32>(0u);
        var n_t = vec3<f32>(ray.tmax);
        frames[0] = csg_frame(root);
        var depth = 1u;
        var leaf = 0u;
        var root_bits = 0u;
        loop {
            let f = depth - 1u;
            let frame = frames[f];
            let node = csg_nodes[frame.x & ~(3u << CSG_FRAME_OP_SHIFT)];
            var b = 0u;
            if (frame.y == node.child_count) {
                b = csg_finish(frame.x >> CSG_FRAME_OP_SHIFT, frame.z);
                if (f == 0u) {
                    root_bits = b;
                    break;
                }
                depth = f;
            } else {
                frames[f].y = frame.y + 1u;
                let r = object_ref(node.first_child + frame.y);
                if ((r & CSG_NODE_BIT) != 0u) {
                    frames[depth] = csg_frame(r & ~CSG_NODE_BIT);
                    depth++;
                    continue;
                }
                var span: Interval;
                if (first) {
                    span = csg_leaf_span(r, ray);
                    csg_pool[csg_base + leaf] = span;
                } else {
                    span = csg_pool[csg_base + leaf];
                }
                let in_before = (vec3<f32>(span.enter.t) < before) & (before < vec3<f32>(span.exit.t));
                let in_after = (vec3<f32>(span.enter.t) < after) & (after < vec3<f32>(span.exit.t));
                let inside = select(vec3<u32>(0u), vec3<u32>(CSG_BEFORE), in_before)
                    | select(vec3<u32>(0u), vec3<u32>(CSG_AFTER), in_after);
                let bits = select(inside, own_bits, own_leaf == vec3<u32>(leaf));
                b = bits.x | (bits.y << CSG_FIELD) | (bits.z << (2u * CSG_FIELD));
                for (var side = 0u; side < 2u; side++) {
                    var e = span.enter;
                    if (side == 1u) {
                        e = span.exit;
                    }
                    let k = 2u * leaf + side;
                    if (end_leaf(e) != CSG_END_OPEN && e.t > ray.tmin && csg_before(last_t, last_key, e.t, k)
                        && csg_before(e.t, k, n_t.z, n2.x)) {
                        // Insert into the sorted next batch.
                        let c = vec3<u32>(k, e.tag, 0u);
                        if (csg_before(e.t, k, n_t.y, n1.x)) {
                            n2 = n1;
                            n_t.z = n_t.y;
                            if (csg_before(e.t, k, n_t.x, n0.x)) {
                                n1 = n0;
                                n_t.y = n_t.x;
                                n0 = c;
                                n_t.x = e.t;
                            } else {
                                n1 = c;
                                n_t.y = e.t;
                            }
                        } else {
                            n2 = c;
                            n_t.z = e.t;
                        }
                    }
                }
                leaf++;
            }
            // Fold b into the frame on top: the finished node's parent, or the leaf's node.
            let top = depth - 1u;
            let parent = frames[top];
            frames[top].z = csg_fold(parent.x >> CSG_FRAME_OP_SHIFT, parent.z, parent.y - 1u, b);
        }
        // The first crossing of the batch that the root shows, if any.
        let shown = (vec3<u32>(root_bits) >> vec3<u32>(2u, CSG_FIELD + 2u, 2u * CSG_FIELD + 2u)) & vec3<u32>(3u);
        let flips = (vec3<u32>(root_bits) >> vec3<u32>(5u, CSG_FIELD + 5u, 2u * CSG_FIELD + 5u)) & vec3<u32>(1u);
        let valid = batch_t < vec3<f32>(ray.tmax);
        var q = CSG_BATCH;
        if (valid.z && shown.z != 0u) {
            q = 2u;
        }
        if (valid.y && shown.y != 0u) {
            q = 1u;
        }
        if (valid.x && shown.x != 0u) {
            q = 0u;
        }
        if (!first && q < CSG_BATCH) {
            let e = End(batch_t[q], batch_tag[q]);
            best = Candidate(Crossing(e.t, end_face(e)), end_leaf(e), flips[q] != 0u, object);
            break;
        }
        if (n_t.x >= ray.tmax) {
            break;
        }
        batch_t = n_t;
        batch_key = vec3<u32>(n0.x, n1.x, n2.x);
        batch_tag = vec3<u32>(n0.y, n1.y, n2.y);
        last_t = n_t.z;
        last_key = n2.x;
        first = false;
    }
    return best;
}
