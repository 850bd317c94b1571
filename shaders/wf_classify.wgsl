// #requires wf_hit bindings
// The end of a closest-hit query: the candidate is stored as the path's hit, and the path
// queued for the escape stage or for the shading stage of its material's BRDF kind.

fn classify(slot: u32, cand: Candidate) {
// #if GEOMETRY
    if (cand.c.t < OPEN) {
        store_hit(slot, cand);
        var brdf = material_at(shape_at(cand.shape).material).brdf;
// #if SMOOTH_GLASS_AS_ROUGH
        // Smooth glass is shaded by the rough-dielectric stage (stages::glass_shaded_as_rough).
        if (brdf == BRDF_DIELECTRIC) {
            brdf = BRDF_ROUGH_DIELECTRIC;
        }
// #endif
        wf_push(Q_SHADE + brdf, slot);
        return;
    }
// #endif
    wf_push(Q_ESCAPE, slot);
}
