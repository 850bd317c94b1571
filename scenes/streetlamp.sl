# A row of street lamps at night: point lights inside CSG lamp heads, rendered by the
# point-light renderer (direct light and shadows from each lamp, plus a faint ambient term).
# Lamp spacing and brightness can be changed from the command line, e.g.
#   lumen check scenes/streetlamp.sl --vars "spacing 6, power 300"

SET
    spacing 8
    power   500
    white   <1, 0.85, 0.6>

    iron    Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.12, 0.12, 0.14>)))
    glow    Material(.brdf Brdf.Diffuse(Pigment.Uniform(<1, 0.9, 0.7>)), .emitted_radiance Pigment.Uniform(<1, 0.85, 0.6>))
    asphalt Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.28, 0.28, 0.3>)))
    grass   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.1, 0.35, 0.1>)))

    # A lamp at the origin: a bowl (hollow sphere cut open at the bottom by two fused boxes)
    # holding a glowing bulb, on a pole. Its light sits at the bulb's centre.
    bowl DIFF(UNITE(Shape.Sphere(.material iron), Shape.Sphere(.material glow, .transformation SCALE 0.99)),
              FUSE(Shape.Cube(.material iron, .transformation TRANSLATE(.Z -0.5) * SCALE(.X 2)),
                   Shape.Cube(.material iron, .transformation TRANSLATE(.Z -0.5) * SCALE(.Y 2))))
    pole Shape.Cylinder(.material iron, .transformation TRANSLATE(.Z -2.5) * SCALE(0.3, 0.3, 3))
    lamp UNITE(bowl, pole)

SPAWN
    # Grass everywhere, and a road (a flat box) along the row of lamps.
    Shape.Plane(.material grass, .transformation TRANSLATE(.Z -4))
    Shape.Cube(.material asphalt, .transformation TRANSLATE(8, 0, -4) * SCALE(60, 4, 0.02))

    UNITE(lamp, Shape.Cube(.material iron, .transformation TRANSLATE(.Z -4)), .transformation TRANSLATE(.Y 3))
    UNITE(lamp, Shape.Cube(.material iron, .transformation TRANSLATE(.Z -4)), .transformation TRANSLATE($spacing$, 3, 0))
    UNITE(lamp, Shape.Cube(.material iron, .transformation TRANSLATE(.Z -4)), .transformation TRANSLATE($2spacing$, 3, 0))

    Light(.position {0, 3, -0.2},             .color $white * power$, .linear_radius 0.5)
    Light(.position $Point(spacing, 3, -0.2)$, .color $white * power$, .linear_radius 0.5)
    Light(.position $Point(2spacing, 3, -0.2)$, .color $white * power$, .linear_radius 0.5)

USING
    Camera.Perspective(.aspect_ratio $16/9$, .screen_distance 1.2,
                       .transformation TRANSLATE(-5, -2, -2.2) * ROTATE(.Z 22 * .Y -6))
    Image(640, 360)
    Renderer.PointLight(.ambient_color <0.002, 0.002, 0.004>, .background_color <0.005, 0.005, 0.02>)
    Tracer(.samples_per_side 2)
