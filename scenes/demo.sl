# lumen's demo scene (the README's default): coloured spheres on a checkered floor under an
# emissive sky dome, lit by a small bright sun. Renders cleanly with the path tracer at
# modest sample counts, e.g. `lumen render scenes/demo.sl --spp 64`.

SET
    # Sky: a large emissive dome around everything, plus a sun (both are area lights).
    sky_material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)),
                          .emitted_radiance Pigment.Uniform(<0.3, 0.42, 0.7>))
    sun_material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)),
                          .emitted_radiance Pigment.Uniform(<3000, 2800, 2400>))

    # Floor
    floor_material Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 2,
                                                                 .color_on  <0.75, 0.75, 0.7>,
                                                                 .color_off <0.15, 0.2, 0.3>)))

    # Spheres
    red    Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.15, 0.1>)))
    green  Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.2, 0.7, 0.25>)))
    blue   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.15, 0.3, 0.8>)))
    gold   Material(.brdf Brdf.Specular(Pigment.Uniform(<0.95, 0.75, 0.35>)))
    glass  Material(.brdf Brdf.Dielectric(.ior 1.5))

SPAWN
    Shape.Sphere(.material sky_material, .transformation SCALE 200)
    Shape.Sphere(.material sun_material, .transformation TRANSLATE(60, -50, 90) * SCALE 3)
    Shape.Plane(.material floor_material)

    Shape.Sphere(.material gold,  .transformation TRANSLATE(.X 3, .Z 1))
    Shape.Sphere(.material red,   .transformation TRANSLATE(1.2, 2.2, 0.6) * SCALE 0.6)
    Shape.Sphere(.material green, .transformation TRANSLATE(2.0, -2.1, 0.7) * SCALE 0.7)
    Shape.Sphere(.material blue,  .transformation TRANSLATE(5.5, 2.5, 0.9) * SCALE 0.9)
    Shape.Sphere(.material glass, .transformation TRANSLATE(0.6, -0.4, 0.45) * SCALE 0.45)

USING
    Camera.Perspective(.aspect_ratio $16/9$, .screen_distance 1.5,
                       .transformation TRANSLATE(.X -1.5, .Z 1.3) * ROTATE(.Y 10))
    Image(640, 360)
    Renderer.PathTracer(.n 1, .max_depth 5, .roulette_depth 3)
    Tracer(.samples_per_side 4)
