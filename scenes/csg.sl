# Constructive solid geometry: all four operations, nested, each tree placed by its own
# `.transformation` (lumen's trailing keyword on UNITE / INTERSECT / DIFF / FUSE).

SET
    steel  Material(.brdf Brdf.Specular(Pigment.Uniform(<0.8, 0.8, 0.85>)))
    red    Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.2, 0.15>)))
    blue   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.2, 0.35, 0.8>)))
    yellow Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.9, 0.75, 0.2>)))
    glass  Material(.brdf Brdf.Dielectric(.ior 1.5))
    floor  Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 2, .color_on <0.7, 0.7, 0.7>, .color_off <0.3, 0.3, 0.3>)))

    # The classic: (cube ∩ sphere) − (three crossed cylinders fused into one solid).
    rounded_cube INTERSECT(Shape.Cube(.material red, .transformation SCALE 1.5),
                           Shape.Sphere(.material blue, .transformation SCALE 0.95))
    cross        FUSE(Shape.Cylinder(.material yellow, .transformation SCALE(1.1, 1.1, 2)),
                      Shape.Cylinder(.material yellow, .transformation ROTATE(.X 90) * SCALE(1.1, 1.1, 2)),
                      Shape.Cylinder(.material yellow, .transformation ROTATE(.Y 90) * SCALE(1.1, 1.1, 2)))
    carved       DIFF(rounded_cube, cross, .transformation TRANSLATE(.Z 1) * ROTATE(.Z 30 * .X 20))

    # A lens: the intersection of two glass spheres.
    lens INTERSECT(Shape.Sphere(.material glass, .transformation TRANSLATE(.X 0.7)),
                   Shape.Sphere(.material glass, .transformation TRANSLATE(.X -0.7)),
                   .transformation TRANSLATE(-0.5, 2.2, 1) * ROTATE(.Z -30))

    # A snowman-ish union (inner surfaces kept) next to a fused capsule (inner surfaces removed).
    snowman UNITE(Shape.Sphere(.material steel, .transformation TRANSLATE(.Z 0.5) * SCALE 0.5),
                  Shape.Sphere(.material steel, .transformation TRANSLATE(.Z 1.2) * SCALE 0.35),
                  .transformation TRANSLATE(0.5, -2.3, 0))
    capsule FUSE(Shape.Cylinder(.material glass, .transformation SCALE(0.6, 0.6, 1.2)),
                 Shape.Sphere(.material glass, .transformation TRANSLATE(.Z 0.6) * SCALE 0.3),
                 Shape.Sphere(.material glass, .transformation TRANSLATE(.Z -0.6) * SCALE 0.3),
                 .transformation TRANSLATE(2, -1.2, 0.9))

    # Nested three deep: a union of the carved cube and a DIFF of a half-space.
    half_dome DIFF(Shape.Sphere(.material yellow), Shape.Plane(.material yellow),
                   .transformation TRANSLATE(3.5, 1.8, 0) * SCALE 0.8)

SPAWN
    UNITE(carved, half_dome)
    lens
    snowman
    capsule
    Shape.Plane(.material floor)

USING
    Camera.Perspective(.aspect_ratio 1.5, .screen_distance 1.2,
                       .transformation TRANSLATE(-1.2, 0.2, 2.1) * ROTATE(.Z 4 * .Y 16))
    Image(600, 400)
    Renderer.PathTracer(.n 1, .max_depth 6)
    Tracer(.samples_per_side 4)
    Environment.Gradient(.zenith <0.35, 0.5, 0.9>, .horizon <1, 0.95, 0.9>, .nadir <0.1, 0.1, 0.1>)
