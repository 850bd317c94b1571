# An equirectangular sky (scenes/sky.hdr, made by `cargo run --example make_sky`) reflected
# by a mirror sphere, Escher's "Hand with Reflecting Sphere" without the hand, beside a glass
# sphere that shows the sky upside down.

SET
    sky    LOAD "sky.hdr"
    mirror Material(.brdf Brdf.Specular(Pigment.Uniform(<0.95, 0.95, 0.95>)))
    glass  Material(.brdf Brdf.Dielectric(.ior 1.5))
    stand  Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.5, 0.45, 0.4>)))

SPAWN
    Shape.Sphere(.material mirror, .transformation TRANSLATE(.Z 1.1))
    Shape.Sphere(.material glass,  .transformation TRANSLATE(-0.6, 1.9, 0.6) * SCALE 0.6)
    Shape.Cylinder(.material stand, .transformation TRANSLATE(.Z 0.05) * SCALE(1.2, 1.2, 0.1))

USING
    Camera.Perspective(.aspect_ratio 1.5, .screen_distance 1.6, .transformation TRANSLATE(-3.2, 0.6, 1.6) * ROTATE(.Y 12))
    Image(600, 400)
    Renderer.PathTracer(.n 1, .max_depth 6)
    Tracer(.samples_per_side 4)
    Environment.Image(.image sky, .intensity 1, .rotation 30)
