# Raytracer.jl-style script (compatibility check): the classic "demo" scene of the course
# these renderers come from. Eight small spheres on the corners of a cube, one checkered
# sphere under it and one on its side, seen by the flat renderer.

SET
	# Shapes
	corner_material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.9, 0.9, 0.9>)))
	check_material  Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 4, .color_on <1, 0.2, 0.2>, .color_off <0.2, 0.2, 1>)))
	small           SCALE 0.1

SPAWN
	Shape.Sphere(.material corner_material, .transformation TRANSLATE( 0.5,  0.5,  0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE(-0.5,  0.5,  0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE( 0.5, -0.5,  0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE(-0.5, -0.5,  0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE( 0.5,  0.5, -0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE(-0.5,  0.5, -0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE( 0.5, -0.5, -0.5) * small)
	Shape.Sphere(.material corner_material, .transformation TRANSLATE(-0.5, -0.5, -0.5) * small)
	Shape.Sphere(.material check_material,  .transformation TRANSLATE(.Z -0.5) * small)
	Shape.Sphere(.material check_material,  .transformation TRANSLATE(.Y 0.5) * small)

USING
	Camera.Perspective(.aspect_ratio $4/3$, .transformation ROTATE(.Z 30) * TRANSLATE(.X -1), .screen_distance 1)
	Renderer.Flat()
	Image(640, 480)
	Tracer()
