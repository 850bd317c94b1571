// #requires wf_hit bindings mis environment
// The end of a closest-hit query. A ray that hit something has its candidate stored as the
// path's hit, and the path queued for the CSG stage (`to_csg`: CSG trees the query met are
// still to be evaluated against the candidate) or for the shading stage of its material's
// BRDF kind. A ray that hit nothing adds the environment's radiance, MIS-weighted against
// NEE (cpu::path_tracer), and its path ends here: handling escapes where the query ends
// saves a launch per bounce, a queue push and reloading the ray and throughput (skybox.sl,
// whose rays mostly escape, renders 8-10 % faster on lavapipe than with a stage of its own;
// DESIGN.md "Wavefront renderer"). One store and one push site whatever the queue: llvmpipe
// inlines every call site, and a push is a per-lane atomic and store.
fn classify(slot: u32, cand: Candidate, to_csg: bool, dir: vec3<f32>, bounce: u32) {
// #if GEOMETRY
    if (cand.c.t < OPEN || to_csg) {
        store_hit(slot, cand);
        var q = Q_CSG;
        if (!to_csg) {
            var brdf = material_at(shape_at(cand.shape).material).brdf;
// #if SMOOTH_GLASS_AS_ROUGH
            // Smooth glass is shaded by the rough-dielectric stage (stages::glass_shaded_as_rough).
            if (brdf == BRDF_DIELECTRIC) {
                brdf = BRDF_ROUGH_DIELECTRIC;
            }
// #endif
            q = Q_SHADE + brdf;
        }
        wf_push(q, slot);
        return;
    }
// #endif
    let beta = load_beta(slot, bounce);
    add_radiance(slot, beta.xyz * pt_escaped(beta.w, normalize(dir)));
}
