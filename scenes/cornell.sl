# The Cornell box, built from thin cubes, with an emissive panel (a flat cube, hence an area
# light) under the ceiling. The box spans x ∈ [0, 2], y ∈ [-1, 1], z ∈ [0, 2]; its open
# side faces the camera on the −x side.

SET
    white Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.73, 0.73, 0.73>)))
    red   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.65, 0.05, 0.05>)))
    green Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.12, 0.45, 0.15>)))
    lamp  Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.78, 0.78, 0.78>)),
                   .emitted_radiance Pigment.Uniform(<17, 12, 4>))

    thickness 0.05

SPAWN
    # Walls: floor, ceiling, back, left (red, +y) and right (green, −y).
    Shape.Cube(.material white, .transformation TRANSLATE(1, 0, $-thickness/2$) * SCALE(2.1, 2.1, thickness))
    Shape.Cube(.material white, .transformation TRANSLATE(1, 0, $2 + thickness/2$) * SCALE(2.1, 2.1, thickness))
    Shape.Cube(.material white, .transformation TRANSLATE($2 + thickness/2$, 0, 1) * SCALE(thickness, 2.1, 2.1))
    Shape.Cube(.material red,   .transformation TRANSLATE(1, $1 + thickness/2$, 1) * SCALE(2.1, thickness, 2.1))
    Shape.Cube(.material green, .transformation TRANSLATE(1, $-1 - thickness/2$, 1) * SCALE(2.1, thickness, 2.1))

    # The light: a thin panel just under the ceiling.
    Shape.Cube(.material lamp, .transformation TRANSLATE(1, 0, 1.99) * SCALE(0.5, 0.4, 0.02))

    # The two blocks.
    Shape.Cube(.material white, .transformation TRANSLATE(1.3, 0.35, 0.6) * ROTATE(.Z 17) * SCALE(0.6, 0.6, 1.2))
    Shape.Cube(.material white, .transformation TRANSLATE(0.7, -0.4, 0.3) * ROTATE(.Z -18) * SCALE 0.6)

USING
    # The screen sits just in front of the opening; the eye is screen_distance behind it.
    Camera.Perspective(.screen_distance 2.5, .transformation TRANSLATE(-0.15, 0, 1))
    Image(400, 400)
    Renderer.PathTracer(.n 1, .max_depth 6, .roulette_depth 3)
    Tracer(.samples_per_side 8)
