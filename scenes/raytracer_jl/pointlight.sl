# Raytracer.jl-style script (compatibility check): point-light renderer, positional
# constructors, mixed positional and keyword arguments, ROTATE chains, UNSET and re-SET.

SET
	light_color <1, 1, 1>
	intensity 2e1

USING
	Camera.Orthogonal(.aspect_ratio 1.5, .transformation ROTATE(.X 5 * .Y 10 * .Z 20 * .Y 10) * TRANSLATE(.X -3, .Z 0.5))
	Image(600, 400)
	Renderer.PointLight()
	Tracer(.samples_per_side 2)

SET
	cyl Shape.Cylinder(
		.transformation SCALE(1, 2.5, 2),
		.material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.2, 1, 0.2>)))
	)
	ball Shape.Sphere(
		.material Material(Brdf.Diffuse(Pigment.Uniform(Color(0.2, .B 1, .G 0.2))))
	)
	bar Shape.Cube(
		.transformation ROTATE(.X 45) * SCALE(2, 0.75, 0.75),
		.material Material(.brdf Brdf.Specular(Pigment.Uniform(<1, 0.2, 0.2>)))
	)

	ground_material Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 4, .color_on <1, 0, 0>, .color_off <1, 1, 0>)))

SPAWN
	DIFF(INTERSECT(cyl, ball), bar)
	Shape.Plane(.transformation TRANSLATE(.Z -1), .material ground_material)
	Light(.position Point(.X -2, .Z 4), .color $light_color * intensity$, .linear_radius 1)

UNSET intensity
SET intensity 5

SPAWN
	Light({2, -3, 3}, $light_color * intensity$)
