# Raytracer.jl-style script (compatibility check): path tracer with explicit seeds, a
# transformation written as a matrix, lists, LOAD-free images and an emissive sky.

SET
	# An explicit translation by (0, 0, -1), row by row.
	down Transformation([1, 0, 0,  0,
	                     0, 1, 0,  0,
	                     0, 0, 1, -1,
	                     0, 0, 0,  1])
	weights List(0.2, 0.7, 0.8)

	sky_material   Material(Brdf.Diffuse(Pigment.Uniform(<0, 0, 0>)), Pigment.Uniform(<1, 0.95, 0.9>))
	floor_material Material(.brdf Brdf.Diffuse(Pigment.Checkered(6, <0.3, 0.5, 0.1>, <0.1, 0.2, 0.5>)))
	blue_mirror    Material(.brdf Brdf.Specular(Pigment.Uniform(<0.2, 0.7, 0.8>), 0.0017453294))
	red_matte      Material(.brdf Brdf.Diffuse(.pigment Pigment.Uniform(.color <0.6, 0.2, 0.3>)))

SPAWN
	Shape.Sphere(sky_material, SCALE 20)
	Shape.Plane(floor_material, down)
	Shape.Sphere(blue_mirror, TRANSLATE(0, 0, -0.2) * SCALE 0.8)
	Shape.Sphere(red_matte, TRANSLATE(-0.2, -1.6, -0.6) * SCALE(.X 0.4, .Y 0.4, .Z 0.4))

USING
	Camera.Perspective(1.5, TRANSLATE(.X -3), 1.3)
	Renderer.PathTracer(.background_color <0, 0, 0>, .rng Pcg(.state 1, .inc 7), .n 3, .max_depth 3, .roulette_depth 2)
	Image(300, 200)
	Tracer(.samples_per_side 1, .rng Pcg(7, 11))
