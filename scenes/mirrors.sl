# Mirrors: tinted mirror spheres and two facing mirror walls that repeat them into the
# distance, on a checkered floor under an emissive sky dome.

SET
    sky   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), .emitted_radiance Pigment.Uniform(<1, 1, 1>))
    floor Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 6, .color_on <0.3, 0.5, 0.1>, .color_off <0.1, 0.2, 0.5>)))

    cyan_mirror   Material(.brdf Brdf.Specular(Pigment.Uniform(<0.2, 0.7, 0.8>)))
    rose_mirror   Material(.brdf Brdf.Specular(Pigment.Uniform(<0.8, 0.3, 0.4>)))
    lime_mirror   Material(.brdf Brdf.Specular(Pigment.Uniform(<0.6, 0.75, 0.2>)))
    clear_mirror  Material(.brdf Brdf.Specular(Pigment.Uniform(<0.9, 0.9, 0.9>), .threshold_angle_rad 0.0017453294))
    matte         Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.6, 0.2>)))

SPAWN
    Shape.Sphere(.material sky, .transformation SCALE 50)
    Shape.Plane(.material floor, .transformation TRANSLATE(.Z -1))

    Shape.Sphere(.material cyan_mirror, .transformation TRANSLATE(0, 0, -0.2) * SCALE 0.8)
    Shape.Sphere(.material rose_mirror, .transformation TRANSLATE(-2, 1.5, -0.5) * SCALE 0.5)
    Shape.Sphere(.material lime_mirror, .transformation TRANSLATE(1.5, -1.8, 0) * SCALE 1)
    Shape.Sphere(.material matte,       .transformation TRANSLATE(1, 1.4, -0.6) * SCALE 0.4)

    # Two parallel mirror walls, slightly tilted so that the reflections recede.
    Shape.Cube(.material clear_mirror, .transformation TRANSLATE(0, 3.5, 0.5) * ROTATE(.Z 3) * SCALE(8, 0.1, 3))
    Shape.Cube(.material clear_mirror, .transformation TRANSLATE(0, -3.5, 0.5) * ROTATE(.Z -3) * SCALE(8, 0.1, 3))

USING
    Camera.Perspective(.aspect_ratio 1.5, .screen_distance 1.3, .transformation TRANSLATE(.X -4, .Z 0.3) * ROTATE(.Y 8))
    Renderer.PathTracer(.n 1, .max_depth 8)
    Image(600, 400)
    Tracer(.samples_per_side 4)
