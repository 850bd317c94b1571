// #requires wf_path shapes
// #if WF_HIT_STORE
// #requires words_set
// #endif
// #if WF_HIT_LOAD
// #requires words_get
// #endif
// The path's hit record (`words` field W_HIT): the closest candidate a query found, as the
// closest-hit and CSG stages store it and the CSG and shading stages read it back.

// #if WF_HIT_STORE
fn store_hit(slot: u32, cand: Candidate) {
    let face = cand.c.face | select(0u, HIT_FLIP, cand.flip);
    words_set(field(W_HIT, slot), vec4<u32>(bitcast<u32>(cand.c.t), cand.shape, face, cand.object));
}
// #endif

// #if WF_HIT_LOAD
fn load_hit(slot: u32) -> Candidate {
    let h = words_get(field(W_HIT, slot));
    return Candidate(Crossing(bitcast<f32>(h.x), h.z & ~HIT_FLIP), h.y, (h.z & HIT_FLIP) != 0u, h.w);
}
// #endif
