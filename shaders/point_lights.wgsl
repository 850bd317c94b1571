// #requires bindings offset
// Point lights at a surface point (cpu::point_light_factor): the direction to light i, its
// colour times the falloff f(d), and the shadow ray, which stops just short of the light
// (t < 1, exclusive). `lit` is false when the light is behind the surface (unless
// `two_sided`: a BSDF that transmits, where the shading and geometric normals agree on the
// light's side): then no shadow ray is traced (and none counted), as on the CPU.

struct PointLightSample {
    l: vec3<f32>,
    radiance: vec3<f32>,
    ray: Ray,
    lit: bool,
}

fn point_light_sample(i: u32, hit: Hit, two_sided: bool) -> PointLightSample {
    let light = point_light_at(i);
    let to_light = light.position.xyz - hit.point;
    let dist = length(to_light);
    let l = to_light / dist;
    let origin = offset_origin(hit.point, hit.scale, hit.geometric, l);
    var falloff = 1.0;
    if (light.position.w > 0.0) {
        let q = light.position.w / dist;
        falloff = q * q;
    }
    let ray = Ray(origin, light.position.xyz - origin, 0.0, 1.0);
    let cn = dot(hit.normal, l);
    let cg = dot(hit.geometric, l);
    let lit = dist > 0.0 && ((cn > 0.0 && cg > 0.0) || (two_sided && cn < 0.0 && cg < 0.0));
    return PointLightSample(l, light.color.xyz * falloff, ray, lit);
}
