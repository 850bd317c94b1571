// #requires wf_hit bindings
// The end of a closest-hit query: the candidate is stored as the path's hit, and the path
// queued for the CSG stage (`to_csg`: CSG trees the query met are still to be evaluated
// against the candidate), else for the escape stage or for the shading stage of its
// material's BRDF kind. One store and one push site whatever the queue: llvmpipe inlines
// every call site, and a push is a per-lane atomic and store.
fn classify(slot: u32, cand: Candidate, to_csg: bool) {
    var q = Q_ESCAPE;
// #if GEOMETRY
    if (cand.c.t < OPEN || to_csg) {
        store_hit(slot, cand);
        if (to_csg) {
            q = Q_CSG;
        } else {
            var brdf = material_at(shape_at(cand.shape).material).brdf;
// #if SMOOTH_GLASS_AS_ROUGH
            // Smooth glass is shaded by the rough-dielectric stage (stages::glass_shaded_as_rough).
            if (brdf == BRDF_DIELECTRIC) {
                brdf = BRDF_ROUGH_DIELECTRIC;
            }
// #endif
            q = Q_SHADE + brdf;
        }
    }
// #endif
    wf_push(q, slot);
}
