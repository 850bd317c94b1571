// #requires shapes constants
// The closest-hit rule, as cpu::world's `replaces`: the least t, and of crossings at the
// same t the object that comes first in the scene. Where surfaces of two objects coincide
// (the coplanar tops of two boxes of equal height) the hit then does not depend on the
// order an object list, a BVH walk or the CSG stage meets the objects in.

// An object's place in the scene's order: a shape's index, a CSG tree's first leaf's
// (gpu::pack stores the top-level objects in scene order, a tree's leaves at its place).
fn scene_order(object: u32) -> u32 {
// #if CSG_TREES
    if ((object & CSG_NODE_BIT) != 0u) {
        return csg_tree_at(object & ~CSG_NODE_BIT).first_leaf;
    }
// #endif
    return object;
}

// Whether `cand`, a crossing within the query's range, replaces `best` as the closest
// candidate. The range ends at end_past(best's t) once there is a best, so cand's t is at
// most best's, and a t that is not less is equal: one order comparison decides (on llvmpipe
// every listed object's test holds a copy of this, so it is kept to two comparisons).
fn replaces(cand: Candidate, best: Candidate) -> bool {
    return cand.c.t < best.c.t || scene_order(cand.object) < scene_order(best.object);
}

// Where a query's range ends once its closest crossing so far is at `t` (> 0): the next
// float above it, so that a crossing at the same t is still met, for `replaces`.
fn end_past(t: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(t) + 1u);
}
