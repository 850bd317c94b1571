# Rough materials (issue 14): from left to right roughness (GGX α) 0, 0.05, 0.2, 0.5 and 1;
# top: a gold-tinted F = 1 conductor, middle: rough glass, bottom: red plastic under a clear
# coat. Energy-compensated (Kulla & Conty 2017), lit by the sky of scenes/sky.hdr.

SET
    sky   LOAD "sky.hdr"
    floor Material(.brdf Brdf.Diffuse(Pigment.Checkered(8, <0.5, 0.5, 0.5>, <0.3, 0.3, 0.3>)))
    metal0 Material(.brdf Brdf.Conductor(.pigment Pigment.Uniform(<1, 0.78, 0.45>), .roughness 0))
    metal1 Material(.brdf Brdf.Conductor(.pigment Pigment.Uniform(<1, 0.78, 0.45>), .roughness 0.05))
    metal2 Material(.brdf Brdf.Conductor(.pigment Pigment.Uniform(<1, 0.78, 0.45>), .roughness 0.2))
    metal3 Material(.brdf Brdf.Conductor(.pigment Pigment.Uniform(<1, 0.78, 0.45>), .roughness 0.5))
    metal4 Material(.brdf Brdf.Conductor(.pigment Pigment.Uniform(<1, 0.78, 0.45>), .roughness 1))
    glass0 Material(.brdf Brdf.Dielectric(.ior 1.5, .roughness 0))
    glass1 Material(.brdf Brdf.Dielectric(.ior 1.5, .roughness 0.05))
    glass2 Material(.brdf Brdf.Dielectric(.ior 1.5, .roughness 0.2))
    glass3 Material(.brdf Brdf.Dielectric(.ior 1.5, .roughness 0.5))
    glass4 Material(.brdf Brdf.Dielectric(.ior 1.5, .roughness 1))
    plastic0 Material(.brdf Brdf.Plastic(.pigment Pigment.Uniform(<0.7, 0.12, 0.1>), .ior 1.5, .roughness 0))
    plastic1 Material(.brdf Brdf.Plastic(.pigment Pigment.Uniform(<0.7, 0.12, 0.1>), .ior 1.5, .roughness 0.05))
    plastic2 Material(.brdf Brdf.Plastic(.pigment Pigment.Uniform(<0.7, 0.12, 0.1>), .ior 1.5, .roughness 0.2))
    plastic3 Material(.brdf Brdf.Plastic(.pigment Pigment.Uniform(<0.7, 0.12, 0.1>), .ior 1.5, .roughness 0.5))
    plastic4 Material(.brdf Brdf.Plastic(.pigment Pigment.Uniform(<0.7, 0.12, 0.1>), .ior 1.5, .roughness 1))

SPAWN
    Shape.Plane(.material floor, .transformation TRANSLATE(.Z -0.9) * SCALE 4)
    Shape.Sphere(.material metal0, .transformation TRANSLATE(0, 4.4, 4.4) * SCALE 0.95)
    Shape.Sphere(.material metal1, .transformation TRANSLATE(0, 2.2, 4.4) * SCALE 0.95)
    Shape.Sphere(.material metal2, .transformation TRANSLATE(0, 0.0, 4.4) * SCALE 0.95)
    Shape.Sphere(.material metal3, .transformation TRANSLATE(0, -2.2, 4.4) * SCALE 0.95)
    Shape.Sphere(.material metal4, .transformation TRANSLATE(0, -4.4, 4.4) * SCALE 0.95)
    Shape.Sphere(.material glass0, .transformation TRANSLATE(0, 4.4, 2.2) * SCALE 0.95)
    Shape.Sphere(.material glass1, .transformation TRANSLATE(0, 2.2, 2.2) * SCALE 0.95)
    Shape.Sphere(.material glass2, .transformation TRANSLATE(0, 0.0, 2.2) * SCALE 0.95)
    Shape.Sphere(.material glass3, .transformation TRANSLATE(0, -2.2, 2.2) * SCALE 0.95)
    Shape.Sphere(.material glass4, .transformation TRANSLATE(0, -4.4, 2.2) * SCALE 0.95)
    Shape.Sphere(.material plastic0, .transformation TRANSLATE(0, 4.4, 0.0) * SCALE 0.95)
    Shape.Sphere(.material plastic1, .transformation TRANSLATE(0, 2.2, 0.0) * SCALE 0.95)
    Shape.Sphere(.material plastic2, .transformation TRANSLATE(0, 0.0, 0.0) * SCALE 0.95)
    Shape.Sphere(.material plastic3, .transformation TRANSLATE(0, -2.2, 0.0) * SCALE 0.95)
    Shape.Sphere(.material plastic4, .transformation TRANSLATE(0, -4.4, 0.0) * SCALE 0.95)

USING
    Camera.Perspective(.aspect_ratio 1.6, .screen_distance 1.4, .transformation TRANSLATE(-7, 0, 2.2))
    Image(480, 300)
    Renderer.PathTracer(.n 1, .max_depth 6)
    Tracer(.samples_per_side 4)
    Environment.Image(.image sky, .intensity 1, .rotation 30)
