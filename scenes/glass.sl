# Glass (lumen's Brdf.Dielectric): a solid sphere that refracts the floor, a hollow shell,
# a cube whose faces show total internal reflection, and the caustics they focus onto the
# floor from a small, bright area light.

SET
    glass    Material(.brdf Brdf.Dielectric(.ior 1.5))
    tinted   Material(.brdf Brdf.Dielectric(.pigment Pigment.Uniform(<0.75, 0.9, 1>), .ior 1.5))
    diamond  Material(.brdf Brdf.Dielectric(.ior 2.42))
    water    Material(.brdf Brdf.Dielectric(.ior 1.33))
    floor    Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 4, .color_on <0.8, 0.8, 0.8>, .color_off <0.25, 0.25, 0.3>)))
    backdrop Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.6, 0.55, 0.5>)))
    lamp     Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), .emitted_radiance Pigment.Uniform(<60, 58, 54>))

SPAWN
    Shape.Plane(.material floor)
    Shape.Plane(.material backdrop, .transformation TRANSLATE(.X 4) * ROTATE(.Y -90))

    # The light: high above, small enough for crisp caustics, large enough to converge.
    Shape.Sphere(.material lamp, .transformation TRANSLATE(0.5, -1, 5) * SCALE 0.6)

    # A solid sphere: a caustic focus below it.
    Shape.Sphere(.material glass, .transformation TRANSLATE(1, -1.2, 0.8) * SCALE 0.8)
    # A hollow shell (glass minus a smaller sphere).
    DIFF(Shape.Sphere(.material water), Shape.Sphere(.material water, .transformation SCALE 0.9),
         .transformation TRANSLATE(1.2, 1.2, 0.7) * SCALE 0.7)
    # A cube seen through a face at a grazing angle: total internal reflection.
    Shape.Cube(.material tinted, .transformation TRANSLATE(0, 0.1, 0.5) * ROTATE(.Z 40 * .X 10))
    # A small high-index gem.
    Shape.Sphere(.material diamond, .transformation TRANSLATE(-0.6, -1.6, 0.3) * SCALE 0.3)

USING
    Camera.Perspective(.aspect_ratio 1.5, .screen_distance 1.5, .transformation TRANSLATE(-2.2, 0, 1.6) * ROTATE(.Y 22))
    Image(600, 400)
    Renderer.PathTracer(.n 1, .max_depth 10, .roulette_depth 5)
    Tracer(.samples_per_side 8)
    Environment.Uniform(<0.15, 0.15, 0.18>)
