// #requires wf_path shapes bindings
// The end of a closest-hit query: the candidate is stored as the path's hit, and the path
// queued for the escape stage or for the shading stage of its material's BRDF kind.

fn classify(slot: u32, cand: Candidate) {
// #if GEOMETRY
    if (cand.c.t < OPEN) {
        words[field(W_HIT, slot)] =
            vec4<u32>(bitcast<u32>(cand.c.t), cand.shape, cand.c.face | select(0u, HIT_FLIP, cand.flip), cand.object);
        let brdf = materials[shapes[cand.shape].material].brdf;
        wf_push(Q_SHADE + brdf, slot);
        return;
    }
// #endif
    wf_push(Q_ESCAPE, slot);
}
