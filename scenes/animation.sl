# An animation driven by TIME (`--time T`, in degrees of a turn): the camera circles the
# scene while a ball bounces. Render frames with e.g. `--time 0`, `--time 10`, … `--time 350`.

SET
    ball_height $0.4 + 1.5abs(sin(4TIME * pi / 180))$
    ball_squash $1 - 0.15exp(-ball_height * 4)$

    ball   Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.85, 0.2, 0.15>)))
    column Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.2, 0.7, 0.8>)))
    floor  Material(.brdf Brdf.Diffuse(Pigment.Checkered(.N 6, .color_on <0.3, 0.5, 0.1>, .color_off <0.1, 0.2, 0.5>)))

SPAWN
    Shape.Sphere(.material ball, .transformation TRANSLATE(.Z ball_height) * SCALE(0.4, 0.4, $0.4ball_squash$))
    Shape.Cylinder(.material column, .transformation TRANSLATE(1.2, 1, 0.75) * SCALE(0.6, 0.6, 1.5))
    Shape.Plane(.material floor)
    Light(.position {1, 5, 10}, .color <1, 1, 1>)
    Light(.position {-6, -4, 8}, .color <0.3, 0.3, 0.4>)

USING
    Camera.Perspective(.aspect_ratio $16/9$, .screen_distance 2,
                       .transformation ROTATE(.Z TIME) * TRANSLATE(-5, 0, 1.5) * ROTATE(.Y 10))
    Renderer.PointLight(.background_color <0.5, 0.6, 0.8>)
    Image(480, 270)
    Tracer(.samples_per_side 2)
