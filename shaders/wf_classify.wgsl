// #requires wf_hit bindings
// The end of a closest-hit query: the candidate is stored as the path's hit, and the path
// queued for the escape stage or for the shading stage of its material's BRDF kind.

fn classify(slot: u32, cand: Candidate) {
// #if GEOMETRY
    if (cand.c.t < OPEN) {
        store_hit(slot, cand);
        let brdf = material_at(shape_at(cand.shape).material).brdf;
        wf_push(Q_SHADE + brdf, slot);
        return;
    }
// #endif
    wf_push(Q_ESCAPE, slot);
}
