// #requires shapes constants
// #if GEOMETRY
// #requires nearest
// #endif
// #if OBJECT_LIST
// #requires unrolled
// #endif
// #if UNROLLED_PLANES
// #requires unrolled
// #endif
// #if CSG
// #if !CSG_QUEUE
// #requires csg
// #endif
// #endif
// Closest hit and occlusion over the scene: the flattened BVH of finite objects (the
// same 32-byte nodes the CPU traverses) plus the list of infinite planes tested by every
// ray. Mirrors cpu::World. With CSG_QUEUE (the wavefront's closest-hit stage) the CSG trees
// a traversal meets are only recorded in `deferred`; the CSG stage evaluates them.

// #if CSG
// CSG references met by one traversal, evaluated after it (as cpu::World does).
struct Deferred {
    refs: array<u32, CSG_DEFER_SLOTS>,
    count: u32,
}

var<private> deferred: Deferred;

// Whether `r` is a CSG tree to evaluate later; if so it is recorded (the scene has at most
// CSG_DEFER_SLOTS trees, each met at most once per traversal).
fn defer_csg(r: u32) -> bool {
    if (CSG_DEFER && (r & CSG_NODE_BIT) != 0u && deferred.count < CSG_DEFER_SLOTS) {
        deferred.refs[deferred.count] = r;
        deferred.count++;
        return true;
    }
    return false;
}
// #endif

// #if BVH
// Slab test against the box [lo, hi]; the exit is widened by 2 ulps-ish (Ize 2013) so f32
// rounding cannot drop a box the ray grazes. `inv_dir` has no infinities, so no slab
// distance is NaN, and the minima and maxima are comparisons and selects: llvmpipe compiles
// WGSL's min and max with a NaN test each (a third more instructions in the walk's step).
fn box_entry(lo: vec3<f32>, hi: vec3<f32>, origin: vec3<f32>, inv_dir: vec3<f32>, tmin: f32, tmax: f32) -> f32 {
    let a = (lo - origin) * inv_dir;
    let b = (hi - origin) * inv_dir;
    let swap = b < a;
    let near = select(a, b, swap);
    let far = select(b, a, swap);
    let e0 = select(near.x, near.y, near.y > near.x);
    let e1 = select(near.z, tmin, tmin > near.z);
    let enter = select(e0, e1, e1 > e0);
    let x0 = select(far.x, far.y, far.y < far.x);
    let x1 = select(far.z, tmax, tmax < far.z);
    let exit = select(x0, x1, x1 < x0) * 1.0000004;
    return select(OPEN, enter, enter <= exit);
}

// Node `n`'s grid step per axis: 2^e from the biased exponents in its `scales`.
fn grid_step(n: QuantizedNode) -> vec3<f32> {
    let e = (vec3<u32>(n.scales) >> vec3<u32>(0u, BVH_GRID_BITS, 2u * BVH_GRID_BITS)) & vec3<u32>((1u << BVH_GRID_BITS) - 1u);
    return bitcast<vec3<f32>>(e << vec3<u32>(23u));
}

// #if BVH_WALK
// The entries of the ray into inner node `n`'s left (x) and right (y) child boxes (OPEN
// where it misses), decoded from the node's grid: corner + q * 2^e, where the product is
// exact, so the bounds are the ones accel::quantized made to contain the children.
fn child_entries(n: QuantizedNode, origin: vec3<f32>, inv_dir: vec3<f32>, tmin: f32, tmax: f32) -> vec2<f32> {
    let mask = vec3<u32>((1u << BVH_GRID_BITS) - 1u);
    let bits = vec3<u32>(BVH_GRID_BITS);
    let step = grid_step(n);
    let g = n.grid;
    let left_lo = n.corner + vec3<f32>(g & mask) * step;
    let left_hi = n.corner + vec3<f32>((g >> bits) & mask) * step;
    let right_lo = n.corner + vec3<f32>((g >> (2u * bits)) & mask) * step;
    let right_hi = n.corner + vec3<f32>(g >> (3u * bits)) * step;
    return vec2<f32>(box_entry(left_lo, left_hi, origin, inv_dir, tmin, tmax), box_entry(right_lo, right_hi, origin, inv_dir, tmin, tmax));
}
// #endif

// #if OBJECT_LIST
// The ray's entry into the whole tree rooted at inner node `root` (OPEN where it misses):
// one box test against the union of its children's decoded boxes, which starts at the
// node's corner (the least of their minima) and ends at the larger of their maxima.
fn tree_entry(root: u32, origin: vec3<f32>, inv_dir: vec3<f32>, tmin: f32, tmax: f32) -> f32 {
    let n = bvh_node_at(root);
    let mask = vec3<u32>((1u << BVH_GRID_BITS) - 1u);
    let step = grid_step(n);
    let top = max((n.grid >> vec3<u32>(BVH_GRID_BITS)) & mask, n.grid >> vec3<u32>(3u * BVH_GRID_BITS));
    return box_entry(n.corner, n.corner + vec3<f32>(top) * step, origin, inv_dir, tmin, tmax);
}
// #endif
// #endif

// #if GEOMETRY
fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = vec3<f32>(1e-30);
    let m = select(d, select(-tiny, tiny, d >= vec3<f32>(0.0)), abs(d) < tiny);
    return 1.0 / m;
}
// #endif

// #if BVH_WALK
// One BVH walk's state (the scene's tree, or a mesh's bottom-level tree in the same
// table): the current reference (an inner node's index, or a leaf's range as
// accel::quantized::LEAF_REF packs it), and the references still to visit with the
// distances at which the ray enters them. A descent step loads one node for both children
// and their leaves' ranges (a node fetch is a per-lane loop or gather on llvmpipe), and a
// pop loads nothing: a pushed child is skipped when its entry lies beyond the nearest hit
// found since.
//
// The stacks are module-scope private arrays, a region of BVH_STACK_SIZE entries per walk
// (the scene's walk from 0; a mesh's bottom-level walk, which runs inside a leaf of the
// scene's, from BVH_STACK_SIZE), and the walk's own state is three words. Why: on wgpu's
// OpenGL backend naga writes a pointer parameter as a GLSL `inout` one, copied in and out
// at every call, so with the arrays inside the walk each bvh_descend and bvh_pop call
// moved all 67 words: 29 % of spheres_10k.sl's instructions, 48 % of meshes.sl's, over
// Mesa 22.3's llvmpipe (on Vulkan, where pointers stay pointers, 1 %: BENCHMARKS.md "BVH
// stacks out of the walk's struct").
struct BvhWalk {
    at: u32,
    top: u32,
    bottom: u32,
}

var<private> bvh_stack: array<u32, BVH_STACK_WORDS>;
var<private> bvh_entry: array<f32, BVH_STACK_WORDS>;

// A walk of the tree whose root node is `root`, its stack region starting at `bottom`.
fn bvh_walk(root: u32, bottom: u32) -> BvhWalk {
    return BvhWalk(root, bottom, bottom);
}

// The reference to the leaf of `count` primitives from `first`.
fn leaf_ref(first: u32, count: u32) -> u32 {
    return BVH_LEAF_REF | (count << BVH_REF_COUNT_SHIFT) | first;
}

// The first primitive and the count of the leaf the walk is at.
fn leaf_first(w: BvhWalk) -> u32 {
    return w.at & ((1u << BVH_REF_COUNT_SHIFT) - 1u);
}

fn leaf_count(w: BvhWalk) -> u32 {
    return (w.at >> BVH_REF_COUNT_SHIFT) & BVH_COUNT_MASK;
}

// Descends from the current node to a leaf, nearer child first, the other pushed; false
// when both children of an inner node are missed (the caller pops). Lanes that reach a leaf
// wait here for the others (Aila and Laine's while-while order), so the caller's leaf code
// runs once per round, not masked on every inner step.
fn bvh_descend(w: ptr<function, BvhWalk>, origin: vec3<f32>, inv_dir: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    while (((*w).at & BVH_LEAF_REF) == 0u) {
        let n = bvh_node_at((*w).at);
        let t = child_entries(n, origin, inv_dir, tmin, tmax);
        if (t.x >= OPEN && t.y >= OPEN) {
            return false;
        }
        // accel::QuantizedNode::child: a leaf on the left has a leaf on its right too,
        // starting where it ends.
        let left_leaf = (n.scales & BVH_LEFT_LEAF) != 0u;
        let left_count = (n.scales >> BVH_LEFT_COUNT_SHIFT) & BVH_COUNT_MASK;
        let right_count = (n.scales >> BVH_RIGHT_COUNT_SHIFT) & BVH_COUNT_MASK;
        let left = select((*w).at + 1u, leaf_ref(n.link, left_count), left_leaf);
        let right_first = n.link + select(0u, left_count, left_leaf);
        let right = select(n.link, leaf_ref(right_first, right_count), (n.scales & BVH_RIGHT_LEAF) != 0u);
        var near = left;
        var far = right;
        var t_far = t.y;
        if (t.y < t.x) {
            near = right;
            far = left;
            t_far = t.x;
        }
        if (t_far < OPEN && (*w).top < (*w).bottom + BVH_STACK_SIZE) {
            bvh_stack[(*w).top] = far;
            bvh_entry[(*w).top] = t_far;
            (*w).top++;
        }
        (*w).at = near;
    }
    return true;
}

// Pops the next node the ray enters before tmax (widened as box_entry widens its exit);
// false when none is left.
fn bvh_pop(w: ptr<function, BvhWalk>, tmax: f32) -> bool {
    while ((*w).top > (*w).bottom) {
        (*w).top--;
        if (bvh_entry[(*w).top] <= tmax * 1.0000004) {
            (*w).at = bvh_stack[(*w).top];
            return true;
        }
    }
    return false;
}
// #endif

// #if GEOMETRY
// Keeps `cand` when it is the closest so far (nearest.wgsl's rule): it becomes `best` and
// shortens the ray to just past it.
fn keep_nearer(cand: Candidate, ray: ptr<function, Ray>, best: ptr<function, Candidate>) -> bool {
    if (cand.c.t < (*ray).tmax && replaces(cand, *best)) {
        *best = cand;
        (*ray).tmax = end_past(cand.c.t);
        return true;
    }
    return false;
}
// #endif

// #if CSG
// CSG tree reference `r` along `ray`, as `keep_nearer`: recorded in `deferred` when
// deferring (CSG_DEFER), else evaluated here (without CSG_DEFER the CSG code is compiled
// into the traversal loop, which costs every iteration on SIMD software GPUs: DESIGN.md,
// "Software adapters"). `inv_dir` = safe_inverse(ray.dir), for the box test of a listed tree.
fn csg_nearer(r: u32, ray: ptr<function, Ray>, inv_dir: vec3<f32>, best: ptr<function, Candidate>) -> bool {
// #if OBJECT_LIST
    // A list meets every tree: like a walk, go on only where the ray crosses its box.
    let tree = csg_tree_at(r & ~CSG_NODE_BIT);
    if (box_entry(tree.min, tree.max, (*ray).origin, inv_dir, (*ray).tmin, (*ray).tmax) >= OPEN) {
        return false;
    }
// #endif
    if (defer_csg(r)) {
        return false;
    }
// #if !CSG_QUEUE
    if (!CSG_DEFER) {
        return keep_nearer(csg_first(r & ~CSG_NODE_BIT, *ray, r), ray, best);
    }
// #endif
    return false;
}
// #endif

// #if BVH
// #if !OBJECT_LIST
// Object `r` of a BVH leaf (a bounded shape or CSG tree) along `ray`, as `keep_nearer`.
fn nearer(r: u32, ray: ptr<function, Ray>, inv_dir: vec3<f32>, best: ptr<function, Candidate>) -> bool {
// #if CSG
    if ((r & CSG_NODE_BIT) != 0u) {
        return csg_nearer(r, ray, inv_dir, best);
    }
// #endif
    return keep_nearer(Candidate(shape_first_crossing(r, *ray), r, false, r), ray, best);
}
// #endif
// #endif

// #if PLANE
// Object `r` of the unbounded list along `ray`, as `keep_nearer`. The list holds planes
// and CSG trees only (prepare::SceneBvh lists what has infinite bounds, and any other
// shape would need a transform beyond f32's range, which pack refuses), so only the
// plane's test is compiled here: the general test would inline every shape kind's code,
// meshes' bottom-level walks included, a second time into each traversing kernel.
fn nearer_unbounded(r: u32, ray: ptr<function, Ray>, inv_dir: vec3<f32>, best: ptr<function, Candidate>) -> bool {
// #if CSG
    if ((r & CSG_NODE_BIT) != 0u) {
        return csg_nearer(r, ray, inv_dir, best);
    }
// #endif
    return keep_nearer(Candidate(plane_first_crossing(r, *ray), r, false, r), ray, best);
}
// #endif

// The closest candidate along the ray among planes and BVH leaves (t = OPEN when nothing
// is hit), CSG trees met being recorded in `deferred` (when CSG_DEFER); with `any_hit` it
// returns as soon as something is found (occlusion queries).
fn traverse(ray_in: Ray, any_hit: bool) -> Candidate {
    var ray = ray_in;
    var best = no_candidate();
// #if GEOMETRY
    let inv_dir = safe_inverse(ray.dir);
// #endif
// #if CSG
    deferred.count = 0u;
// #endif
// #if PLANE
// #if UNROLLED_PLANES
    // A few planes: each under its constant reference (gpu::traversal::Unrolled).
    if (unrolled_planes(&ray, inv_dir, &best, any_hit)) {
        return best;
    }
// #else
    for (var i = 0u; i < settings.plane_count; i++) {
        if (nearer_unbounded(object_ref(settings.plane_offset + i), &ray, inv_dir, &best) && any_hit) {
            return best;
        }
    }
// #endif
// #endif
// #if OBJECT_LIST
    // A handful of objects (gpu::traversal chose a list): every one in turn behind the root
    // box, in reference order, each under its constant reference and with its own shape kind's
    // code only (generated: gpu::traversal::Unrolled), so an object's words are loaded once
    // for the SIMD group, where a walk loads lane-divergent nodes and objects per lane
    // (DESIGN.md "Object list").
    if (tree_entry(0u, ray.origin, inv_dir, ray.tmin, ray.tmax) < OPEN) {
        if (listed_nearest(&ray, inv_dir, &best, any_hit)) {
            return best;
        }
    }
// #else
// #if BVH
    var walk = bvh_walk(0u, 0u);
    // An empty tree skips the loop (not a return: deferred CSG trees are still to be
    // evaluated).
    var more = settings.bvh_node_count != 0u;
    while (more) {
        if (bvh_descend(&walk, ray.origin, inv_dir, ray.tmin, ray.tmax)) {
            let first = leaf_first(walk);
            for (var k = 0u; k < leaf_count(walk); k++) {
                if (nearer(object_ref(first + k), &ray, inv_dir, &best) && any_hit) {
                    return best;
                }
            }
        }
        more = bvh_pop(&walk, ray.tmax);
    }
// #endif
// #endif
    return best;
}

// #if CSG
// #if !CSG_QUEUE
// The deferred CSG trees against the best candidate so far: the only call of csg_first
// when CSG_DEFER, once per query, outside the traversal loops.
fn evaluate_deferred(ray_in: Ray, best_in: Candidate, any_hit: bool) -> Candidate {
    var ray = ray_in;
    var best = best_in;
    ray.tmax = min(ray.tmax, end_past(best.c.t));
    for (var k = 0u; k < deferred.count; k++) {
        let r = deferred.refs[k];
        let cand = csg_first(r & ~CSG_NODE_BIT, ray, r);
        if (cand.c.t < ray.tmax && replaces(cand, best)) {
            best = cand;
            ray.tmax = end_past(cand.c.t);
            if (any_hit) {
                return best;
            }
        }
    }
    return best;
}
// #endif
// #endif

// #if WF_COUNT
// Queries this invocation made (stages that trace several rays per path count them here
// and add the total once; the closest-hit stage's rays are counted by queue length).
var<private> rays_traced: u32;
// #endif

// #if !CSG_QUEUE
// The closest candidate along the ray, CSG trees included (t = OPEN when nothing is hit).
fn world_first(ray: Ray, any_hit: bool) -> Candidate {
// #if WF_COUNT
    rays_traced += 1u;
// #endif
    let best = traverse(ray, any_hit);
// #if CSG
    if (any_hit && best.c.t < OPEN) {
        return best;
    }
    return evaluate_deferred(ray, best, any_hit);
// #else
    return best;
// #endif
}
// #endif

// #if FIRST_HIT
// #if !ONOFF
// The surface a closest-hit query found along `ray`; `hit.t = OPEN` when it escaped.
fn hit_of(cand: Candidate, ray: Ray) -> Hit {
    if (cand.c.t >= OPEN) {
        return Hit(OPEN, vec3<f32>(0.0), 0.0, vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 0.0, 1.0), true, vec2<f32>(0.0), 0u, 0u);
    }
// #if GEOMETRY
    return shape_surface_hit(shape_at(cand.shape), ray, cand.c, cand.flip, cand.object);
// #else
    return Hit(OPEN, vec3<f32>(0.0), 0.0, vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 0.0, 1.0), true, vec2<f32>(0.0), 0u, 0u);
// #endif
}
// #endif

// #if FLAT
// The closest hit; `hit.t = OPEN` when the ray escapes.
fn closest_hit(ray: Ray) -> Hit {
    return hit_of(world_first(ray, false), ray);
}
// #endif
// #endif

// #if SHADOWS
// #if !POINTLIGHT
// #if !CSG_QUEUE
// True when something lies on the ray strictly inside (tmin, tmax). (The PointLight
// integrator queries world_first directly, from one call site; with CSG_QUEUE the shadow
// stage traverses and hands CSG trees to the CSG stage.)
fn occluded(ray: Ray) -> bool {
    return world_first(ray, true).c.t < OPEN;
}
// #endif
// #endif
// #endif
