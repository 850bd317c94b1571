//! SceneLang: constructors and defaults, diagnostics, math, conventions, the shipped scenes
//! and `lumen check`.

use std::path::{Path, PathBuf};

use glam::DVec3;
use lumen::color::{Color, Rgb32};
use lumen::image::{write_image, HdrImage, ToneMap};
use lumen::scene::*;
use lumen::scenelang::{
    load_file, load_str, load_str_with_output, ErrorKind, LoadOptions, SceneLangError, SceneSummary,
};
use proptest::prelude::*;

const SETTINGS: &str = "\nUSING Camera.Perspective() Image(4, 2) Renderer.Flat() Tracer()\n";

fn load(src: &str) -> Result<Scene, SceneLangError> {
    load_str(src, "t.sl", Path::new("."), &LoadOptions::default())
}
fn with_settings(body: &str) -> Scene {
    load(&format!("{body}{SETTINGS}")).unwrap_or_else(|e| panic!("{e}"))
}
fn err(src: &str) -> SceneLangError {
    match load(src) {
        Ok(_) => panic!("expected an error for {src:?}"),
        Err(e) => e,
    }
}
/// Asserts kind and location of the error of `src`, and that the diagnostic renders it.
fn check_err(src: &str, kind: ErrorKind, line: usize, col: usize, needle: &str) -> SceneLangError {
    let e = err(src);
    assert_eq!((e.kind, e.line, e.col), (kind, line, col), "{e}");
    let text = e.to_string();
    assert!(text.contains(needle), "{needle:?} not in:\n{text}");
    assert!(text.starts_with(&format!("t.sl:{line}:{col}: error: ")), "{text}");
    assert!(text.contains('^') && text.contains("expected"), "{text}");
    e
}
fn material(scene: &Scene, shape: usize) -> &Material {
    match &scene.shapes[shape] {
        Shape::Primitive(p) => scene.material(p.material),
        Shape::Mesh(m) => scene.material(m.material),
        Shape::Csg(_) => panic!("not a primitive"),
    }
}
fn transform(scene: &Scene, shape: usize) -> Transform {
    match &scene.shapes[shape] {
        Shape::Primitive(p) => p.transform,
        Shape::Csg(c) => c.transform,
        Shape::Mesh(m) => m.transform,
    }
}
fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-12
}
fn light(src_light: &str) -> PointLight {
    with_settings(&format!("SPAWN {src_light}")).point_lights[0]
}

// ------------------------------------------------------------------ constructors and defaults

#[test]
fn colors_points_and_their_defaults() {
    let l = light("Light()");
    assert_eq!(l, PointLight { position: DVec3::ZERO, color: Color::WHITE, linear_radius: 0.0 });
    let l = light("Light(Point(.Y 2), Color(1, .B 0.5, .G 0.75), 3)");
    assert_eq!((l.position, l.color, l.linear_radius), (DVec3::new(0.0, 2.0, 0.0), Color::new(1.0, 0.75, 0.5), 3.0));
    let l = light("Light(.color Color(), .position Point())");
    assert_eq!((l.position, l.color), (DVec3::ZERO, Color::BLACK));
    let l = light("Light({1, -2, 3e1}, <0.5, 1., +.25>)");
    assert_eq!((l.position, l.color), (DVec3::new(1.0, -2.0, 30.0), Color::new(0.5, 1.0, 0.25)));
}

#[test]
fn pigments_brdfs_materials_and_defaults() {
    let s = with_settings(
        "SPAWN Shape.Sphere()
               Shape.Sphere(Material(Brdf.Specular()))
               Shape.Sphere(Material(Brdf.Dielectric(), Pigment.Checkered()))
               Shape.Sphere(Material(.emitted_radiance Pigment.Uniform(<2, 2, 2>), .brdf Brdf.Diffuse(Pigment.Checkered(3, <1, 0, 0>))))
               Shape.Sphere(Material(Brdf.Specular(.threshold_angle_rad 0.5, .pigment Pigment.Uniform())))
               Shape.Sphere(Material(Brdf.Dielectric(.ior 2.4, .pigment Pigment.Uniform(.color <0.5, 0.5, 0.5>))))",
    );
    assert_eq!(*material(&s, 0), Material::default());
    assert_eq!(material(&s, 0).emitted, Pigment::Uniform(Color::BLACK));
    assert_eq!(
        material(&s, 1).brdf,
        Brdf::Specular { pigment: Pigment::Uniform(Color::WHITE), threshold_angle_rad: 0.0017453294 }
    );
    assert_eq!(
        material(&s, 2).brdf,
        Brdf::Dielectric {
            pigment: Pigment::Uniform(Color::WHITE),
            ior: 1.5,
            roughness: 0.0,
            multiple_scattering: true
        }
    );
    assert_eq!(material(&s, 2).emitted, Pigment::Checkered { n: 2, on: Color::WHITE, off: Color::BLACK });
    assert_eq!(
        material(&s, 3).brdf,
        Brdf::Diffuse { pigment: Pigment::Checkered { n: 3, on: Color::new(1.0, 0.0, 0.0), off: Color::BLACK } }
    );
    assert_eq!(material(&s, 3).emitted, Pigment::Uniform(Color::gray(2.0)));
    assert_eq!(
        material(&s, 4).brdf,
        Brdf::Specular { pigment: Pigment::Uniform(Color::WHITE), threshold_angle_rad: 0.5 }
    );
    assert_eq!(
        material(&s, 5).brdf,
        Brdf::Dielectric {
            pigment: Pigment::Uniform(Color::gray(0.5)),
            ior: 2.4,
            roughness: 0.0,
            multiple_scattering: true
        }
    );
    // Equal materials are stored once.
    assert_eq!(with_settings("SPAWN Shape.Sphere() Shape.Cube(Material())").materials.len(), 1);
}

#[test]
fn shapes_and_their_defaults() {
    let s = with_settings("SPAWN Shape.Sphere() Shape.Plane() Shape.Cube() Shape.Cylinder(.transformation SCALE 2)");
    let kinds: Vec<ShapeKind> = s
        .shapes
        .iter()
        .map(|x| match x {
            Shape::Primitive(p) => p.kind,
            _ => panic!(),
        })
        .collect();
    assert_eq!(kinds, ShapeKind::ALL);
    assert!(transform(&s, 0).is_identity());
    assert!(close(transform(&s, 3).point(DVec3::ONE), DVec3::splat(2.0)));
}

/// Each spawned shape remembers where its SPAWN item starts (a name, a constructor or a CSG
/// command), for the GPU's messages about a shape it cannot take; lights take no entry.
#[test]
fn spawned_shapes_know_where_they_were_written() {
    let s = with_settings(
        "SET ball Shape.Sphere()\nSPAWN ball Light(.position {0, 0, 1})\n  Shape.Plane() UNITE(ball, Shape.Cube())\n",
    );
    assert_eq!(s.shapes.len(), 3);
    let at: Vec<Option<String>> = (0..4).map(|i| s.origins.of(i)).collect();
    assert_eq!(at, [Some("t.sl:2:7".to_string()), Some("t.sl:3:3".into()), Some("t.sl:3:17".into()), None]);
}

#[test]
fn settings_and_their_defaults() {
    let s = load("USING Camera.Perspective() Image(4, 2) Renderer.PathTracer() Tracer()").unwrap();
    assert_eq!(s.camera, Camera::default());
    assert_eq!((s.width, s.height), (4, 2));
    assert_eq!(s.renderer, Renderer::PathTracer(PathTracerSettings::default()));
    assert_eq!(
        PathTracerSettings::default(),
        PathTracerSettings {
            background: Color::BLACK,
            rng: PcgSeed { state: 42, inc: 54 },
            n: 10,
            max_depth: 2,
            roulette_depth: 3,
            nee: true
        }
    );
    assert_eq!(s.tracer, Tracer { samples_per_side: 0, rng: PcgSeed { state: 42, inc: 54 } });
    assert_eq!(s.environment, None);

    let s = load("USING Tracer(3, Pcg(1, 2)) Image(1, 1) Camera.Orthogonal() Renderer.OnOff()").unwrap();
    assert_eq!(s.tracer, Tracer { samples_per_side: 3, rng: PcgSeed { state: 1, inc: 2 } });
    assert_eq!(
        s.camera,
        Camera { projection: Projection::Orthogonal, aspect_ratio: 1.0, transform: Transform::IDENTITY }
    );
    assert_eq!(s.renderer, Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });

    let r = |src: &str| load(&format!("USING {src} Image(1, 1) Camera.Orthogonal() Tracer()")).unwrap().renderer;
    assert_eq!(r("Renderer.Flat()"), Renderer::Flat { background: Color::BLACK });
    assert_eq!(
        r("Renderer.PointLight()"),
        Renderer::PointLight { background: Color::BLACK, ambient: Color::gray(1e-3) }
    );
    assert_eq!(
        r("Renderer.PathTracer(<1, 0, 0>, Pcg(.inc 9), 4, .roulette_depth 7, .max_depth 5)"),
        Renderer::PathTracer(PathTracerSettings {
            background: Color::new(1.0, 0.0, 0.0),
            rng: PcgSeed { state: 42, inc: 9 },
            n: 4,
            max_depth: 5,
            roulette_depth: 7,
            nee: true
        })
    );
    // Extension: `.nee 0` turns next-event estimation off; only 0 and 1 are accepted.
    let nee = |v: &str| match r(&format!("Renderer.PathTracer(.nee {v})")) {
        Renderer::PathTracer(p) => p.nee,
        other => panic!("{other:?}"),
    };
    assert!(!nee("0"));
    assert!(nee("1"));
    let err = load("USING Renderer.PathTracer(.nee 2) Image(1, 1) Camera.Orthogonal() Tracer()").unwrap_err();
    assert!(err.to_string().contains("`.nee` must be a whole number from 0 to 1"), "{err}");
    let c =
        load("USING Camera.Perspective(2, TRANSLATE(.X -1), 3) Image(1, 1) Renderer.Flat() Tracer()").unwrap().camera;
    assert_eq!((c.aspect_ratio, c.projection), (2.0, Projection::Perspective { screen_distance: 3.0 }));
    assert!(close(c.transform.point(DVec3::ZERO), DVec3::new(-1.0, 0.0, 0.0)));
    // The camera convention: the central ray leaves the screen along +x.
    let c = load("USING Camera.Perspective(.screen_distance 2) Image(1, 1) Renderer.Flat() Tracer()").unwrap().camera;
    let ray = c.ray(0.5, 0.5);
    assert_eq!((ray.origin, ray.dir), (DVec3::new(-2.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0)));
}

#[test]
fn environments_and_their_defaults() {
    let e = |src: &str| load(&format!("{SETTINGS} USING {src}")).unwrap().environment.unwrap();
    assert_eq!(e("Environment.Uniform()"), Environment::Uniform(Color::WHITE));
    assert_eq!(e("Environment.Uniform(<1, 2, 3>)"), Environment::Uniform(Color::new(1.0, 2.0, 3.0)));
    assert_eq!(
        e("Environment.Gradient()"),
        Environment::Gradient { zenith: Color::WHITE, horizon: Color::WHITE, nadir: Color::BLACK }
    );
    assert_eq!(
        e("Environment.Gradient(.nadir <1, 0, 0>)"),
        Environment::Gradient { zenith: Color::WHITE, horizon: Color::WHITE, nadir: Color::new(1.0, 0.0, 0.0) }
    );
    match e("Environment.Image()") {
        Environment::Image { image, intensity, rotation_deg } => {
            assert_eq!((image.width(), image.height(), intensity, rotation_deg), (1, 1, 1.0, 0.0));
            assert_eq!(image.get(0, 0), Rgb32::BLACK);
        }
        other => panic!("{other:?}"),
    }
    match e("Environment.Image(Image(8, 4), 2, .rotation 90)") {
        Environment::Image { image, intensity, rotation_deg } => {
            assert_eq!((image.width(), image.height(), intensity, rotation_deg), (8, 4, 2.0, 90.0))
        }
        other => panic!("{other:?}"),
    }
}

/// A 3×2 PFM with distinct pixels, and a broken one, in a temporary folder.
fn image_dir() -> (tempfile::TempDir, HdrImage) {
    let dir = tempfile::tempdir().unwrap();
    let img = HdrImage::from_fn(3, 2, |c, r| Rgb32::new(c as f32, r as f32, 0.5));
    write_image(&dir.path().join("tex.pfm"), &img, &ToneMap::default()).unwrap();
    std::fs::write(dir.path().join("broken.pfm"), b"PF\n3 2\n-1\nshort").unwrap();
    (dir, img)
}

#[test]
fn images_load_relative_to_the_script() {
    let (dir, img) = image_dir();
    let script = dir.path().join("s.sl");
    std::fs::write(
        &script,
        "SET a LOAD \"tex.pfm\"  b Image(\"tex.pfm\")
         SPAWN Shape.Sphere(Material(Brdf.Diffuse(Pigment.Image(a))))
               Shape.Sphere(Material(Brdf.Diffuse(Pigment.Image(.filter \"bilinear\", .image b))))
               Shape.Sphere(Material(Brdf.Diffuse(Pigment.Image())))
         USING LOAD \"tex.pfm\" Camera.Perspective() Renderer.Flat() Tracer()",
    )
    .unwrap();
    let s = load_file(&script, &LoadOptions::default()).unwrap();
    assert_eq!((s.width, s.height), (3, 2));
    match &material(&s, 0).brdf.pigment() {
        Pigment::Image { image, filter } => assert_eq!((**image == img, *filter), (true, ImageFilter::Nearest)),
        other => panic!("{other:?}"),
    }
    match &material(&s, 1).brdf.pigment() {
        Pigment::Image { image, filter } => assert_eq!((**image == img, *filter), (true, ImageFilter::Bilinear)),
        other => panic!("{other:?}"),
    }
    match &material(&s, 2).brdf.pigment() {
        Pigment::Image { image, .. } => assert_eq!((image.width(), image.height()), (1, 1)),
        other => panic!("{other:?}"),
    }
}

#[test]
fn image_errors() {
    let (dir, _) = image_dir();
    let load_in = |src: &str| load_str(src, "t.sl", dir.path(), &LoadOptions::default()).unwrap_err();
    let e = load_in("SET a LOAD \"missing.pfm\"");
    assert_eq!((e.kind, e.line, e.col), (ErrorKind::ImageFile, 1, 12));
    assert!(e.to_string().contains("missing.pfm") && e.to_string().contains("not found"), "{e}");
    // A directory is there, not missing (it was "not found" until 2026-12-07).
    std::fs::create_dir(dir.path().join("folder.png")).unwrap();
    let e = load_in("SET a LOAD \"folder.png\"");
    assert_eq!((e.kind, e.line, e.col), (ErrorKind::ImageFile, 1, 12));
    assert!(e.to_string().contains("folder.png: it is a directory") && !e.to_string().contains("not found"), "{e}");
    let e = load_in("SET a Image(\"broken.pfm\")");
    assert_eq!((e.kind, e.col), (ErrorKind::ImageFile, 13));
    assert!(e.to_string().contains("broken.pfm"), "{e}");
    std::fs::write(dir.path().join("tex.tga"), b"whatever").unwrap();
    let e = load_in("SET a Image(\"tex.tga\")");
    assert_eq!(e.kind, ErrorKind::ImageFile);
    check_err("SET a Image(0, 5)", ErrorKind::BadImageSize, 1, 13, "width 0");
    check_err("SET a Image(10, 1e9)", ErrorKind::BadImageSize, 1, 17, "height");
    check_err("SET a Image(2.5, 2)", ErrorKind::BadImageSize, 1, 13, "whole number");
    check_err("SET a Pigment.Image(Image(30000, 30000))", ErrorKind::BadImageSize, 1, 21, "too large");
}

#[test]
fn transformations_and_rotate_chains() {
    let t = |src: &str| transform(&with_settings(&format!("SPAWN Shape.Sphere(.transformation {src})")), 0);
    // `*` is the matrix product: the rightmost factor acts first.
    let a = t("TRANSLATE(.X 1) * SCALE 2");
    assert!(close(a.point(DVec3::ZERO), DVec3::X));
    assert!(close(a.point(DVec3::X), DVec3::new(3.0, 0.0, 0.0)));
    assert!(close(t("SCALE(1, 2)").point(DVec3::ONE), DVec3::new(1.0, 2.0, 1.0)));
    assert!(close(t("SCALE(.Z 3)").point(DVec3::ONE), DVec3::new(1.0, 1.0, 3.0)));
    assert!(close(t("TRANSLATE(1, 2, 3)").point(DVec3::ZERO), DVec3::new(1.0, 2.0, 3.0)));
    // Row-major matrix: the translation is the last column.
    let m = t("Transformation([1, 0, 0, 5,  0, 1, 0, 6,  0, 0, 1, 7,  0, 0, 0, 1])");
    assert!(close(m.point(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0)));
    assert!(t("Transformation()").is_identity());
    // ROTATE(.X 45 * .Z 30) = Rx(45)·Rz(30): x̂ is turned by 30° about z first, then by 45° about x.
    let r = t("ROTATE(.X 45 * .Z 30)");
    let (c30, s30, h) = (30f64.to_radians().cos(), 0.5, 0.5f64.sqrt());
    assert!(close(r.point(DVec3::X), DVec3::new(c30, s30 * h, s30 * h)));
    let product = t("ROTATE(.X 45) * ROTATE(.Z 30)");
    assert!(r.matrix().abs_diff_eq(product.matrix(), 1e-15));
    assert!(!r.matrix().abs_diff_eq(t("ROTATE(.Z 30 * .X 45)").matrix(), 1e-6));
    // Degrees, right-handed.
    assert!(close(t("ROTATE(.Z 90)").point(DVec3::X), DVec3::Y));
    assert!(close(t("ROTATE(.Y 90)").point(DVec3::Z), DVec3::X));
    // Products of names and commands chain across lines.
    let s = with_settings("SET up TRANSLATE(.Z 1)\nSPAWN Shape.Cube(.transformation up *\n SCALE 2 * up)");
    assert!(close(transform(&s, 0).point(DVec3::ZERO), DVec3::new(0.0, 0.0, 3.0)));
}

#[test]
fn csg_nodes_take_their_own_transformation() {
    let s = with_settings(
        "SET a Shape.Sphere() b Shape.Cube()
         SPAWN UNITE(a, b) INTERSECT(a, b, .transformation TRANSLATE(.X 2))
               DIFF(a, b, FUSE(a, b, a), .transformation SCALE 3) FUSE(INTERSECT(a, b), DIFF(a, b))",
    );
    let ops: Vec<(CsgOp, usize)> = s
        .shapes
        .iter()
        .map(|x| match x {
            Shape::Csg(c) => (c.op, c.children.len()),
            _ => panic!(),
        })
        .collect();
    assert_eq!(ops, [(CsgOp::Unite, 2), (CsgOp::Intersect, 2), (CsgOp::Diff, 3), (CsgOp::Fuse, 2)]);
    assert!(transform(&s, 0).is_identity());
    assert!(close(transform(&s, 1).point(DVec3::ZERO), DVec3::new(2.0, 0.0, 0.0)));
    assert_eq!(s.shapes[2].csg_depth(), 2);
    let sum = SceneSummary::of(&s);
    assert_eq!((sum.csg_nodes, sum.csg_max_depth, sum.count(ShapeKind::Sphere)), (7, 2, 7));
}

#[test]
fn set_unset_spawn_using() {
    let s = with_settings("SET a 1 b a\nUNSET a\nSET a 2\nSPAWN Light(.linear_radius a) Light(.linear_radius b)");
    assert_eq!(s.point_lights.iter().map(|l| l.linear_radius).collect::<Vec<_>>(), [2.0, 1.0]);
    // Settings in any order, by name or in place, across several USING instructions.
    let s = load("SET cam Camera.Orthogonal(2)\nUSING Tracer()\nUSING cam Image(3, 3) Renderer.Flat()").unwrap();
    assert_eq!(s.camera.projection, Projection::Orthogonal);
}

#[test]
fn time_and_command_line_variables() {
    let opts = LoadOptions { time: 12.5, vars: vec!["r 3, c <1, 0, 0>".into(), "m Material(Brdf.Specular())".into()] };
    let src = format!(
        "SET r 1 r_half $r / 2$ m Material()\nSPAWN Light(.linear_radius TIME, .color c) Light(.linear_radius $TIME * 2$)
         Light(.linear_radius r_half) Shape.Sphere(m){SETTINGS}"
    );
    let s = load_str(&src, "t.sl", Path::new("."), &opts).unwrap();
    let radii: Vec<f64> = s.point_lights.iter().map(|l| l.linear_radius).collect();
    assert_eq!(radii, [12.5, 25.0, 1.5], "--vars wins over the script's SET");
    assert_eq!(s.point_lights[0].color, Color::new(1.0, 0.0, 0.0));
    assert!(matches!(s.materials[0].brdf, Brdf::Specular { .. }));
    // The overridden SET is still parsed: its errors are reported.
    let e = load_str("SET r <1, 2>", "t.sl", Path::new("."), &opts).unwrap_err();
    assert_eq!((e.kind, e.line, e.col), (ErrorKind::Syntax, 1, 12));
    // Errors inside --vars point into the --vars text.
    let bad = LoadOptions { time: 0.0, vars: vec!["a 1, b $a +$".into()] };
    let e = load_str("", "t.sl", Path::new("."), &bad).unwrap_err();
    assert_eq!((e.file.as_str(), e.line, e.col), ("--vars", 1, 12));
    assert!(e.to_string().starts_with("--vars:1:12: error:"), "{e}");
    // A value of the wrong type read through a name says where the name was set: on the
    // command line, which the script does not show, or at its SET.
    let src = "SET white Material()\nSPAWN Shape.Sphere(.material white)";
    let three = LoadOptions { time: 0.0, vars: vec!["white 3".into()] };
    let e = load_str(src, "t.sl", Path::new("."), &three).unwrap_err();
    assert_eq!((e.kind, e.line, e.col), (ErrorKind::WrongType, 2, 30));
    assert!(e.to_string().contains("note: `white` was set on the command line (--vars)"), "{e}");
    let e = load_str("SET t 3\nSPAWN Shape.Cube(.transformation t)", "t.sl", Path::new("."), &LoadOptions::default())
        .unwrap_err();
    assert!(e.to_string().contains("note: `t` was defined at t.sl:1:5"), "{e}");
    let e =
        load_str("SET s 3\nSET u UNITE(Shape.Cube(), s)", "t.sl", Path::new("."), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("note: `s` was defined at t.sl:1:5"), "{e}");
    // The same wherever a number, a setting, a SPAWN item, a factor of a transformation,
    // LOAD's file name or Image's size is read through a name.
    let colour = LoadOptions { time: 0.0, vars: vec!["r <1, 2, 3>".into()] };
    for src in [
        "SPAWN Shape.Sphere(.transformation SCALE r)",
        "USING r",
        "SPAWN r",
        "SPAWN Shape.Sphere(.transformation SCALE 2 * r)",
        "SET i LOAD r",
        "SET i Image(r)",
    ] {
        let e = load_str(src, "t.sl", Path::new("."), &colour).unwrap_err();
        assert_eq!(e.kind, ErrorKind::WrongType, "{src}: {e}");
        assert!(e.to_string().contains("note: `r` was set on the command line (--vars)"), "{src}: {e}");
    }
}

#[test]
fn dump_writes_to_the_given_output() {
    let mut out = Vec::new();
    let src = format!(
        "SET x 1.5 c <1, 2, 3>\nDUMP.variables\nDUMP c\nSPAWN Light()\nDUMP.lights\nDUMP.camera{SETTINGS}DUMP.ALL"
    );
    load_str_with_output(&src, "t.sl", Path::new("."), &LoadOptions::default(), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(text.contains("x = 1.5") && text.contains("c = <1, 2, 3>"), "{text}");
    assert!(text.contains("lights (1)") && text.contains("camera: (not set)"), "{text}");
    assert!(text.contains("image: Image(4, 2)") && text.contains("renderer: Flat"), "{text}");
    check_err("DUMP.everything", ErrorKind::UnknownKeyword, 1, 5, "unknown DUMP section");
}

// ------------------------------------------------------------------ diagnostics

#[test]
fn lexical_errors() {
    check_err("SET a 1\nDROP", ErrorKind::UnknownCommand, 2, 1, "unknown command `DROP`");
    check_err("SET a PIgment.Uniform()", ErrorKind::UnknownType, 1, 7, "unknown type `PIgment`");
    check_err("SET a 1.2.3", ErrorKind::BadNumber, 1, 7, "bad number `1.2.3`");
    check_err("SET a 1e", ErrorKind::BadNumber, 1, 7, "bad number");
    check_err("SET a .5", ErrorKind::BadNumber, 1, 7, "not a number");
    check_err("SET a 1e400", ErrorKind::BadNumber, 1, 7, "out of range");
    check_err("SET\n  a \"abc", ErrorKind::UnterminatedString, 2, 5, "unterminated string");
    check_err("SET a $1 + 2", ErrorKind::UnterminatedExpression, 1, 7, "unterminated math expression");
    check_err("SET a 1 ; b 2", ErrorKind::Syntax, 1, 9, "unexpected character `;`");
}

#[test]
fn syntax_and_type_errors() {
    check_err(
        "SET m Material(.brdf Brdf.Diffuse(), .colr <1, 0, 0>)",
        ErrorKind::UnknownKeyword,
        1,
        38,
        "unknown keyword `.colr`",
    );
    check_err("SET p Pigment.Uniform(.colour <1, 0, 0>)", ErrorKind::UnknownKeyword, 1, 23, "did you mean `.color`");
    check_err("SET p Pigment.Plain()", ErrorKind::UnknownKeyword, 1, 14, "unknown kind `.Plain` of Pigment");
    check_err("SET p Pigment.Uniform(.color {1, 0, 0})", ErrorKind::WrongType, 1, 30, "must be a Color, found a Point");
    check_err("SET p Pigment.Uniform(1)", ErrorKind::WrongType, 1, 23, "found a number");
    check_err("SET c Color(1, .R 0.5)", ErrorKind::BadArguments, 1, 16, "given twice");
    check_err("SET c Color(.R 1, 0.75)", ErrorKind::BadArguments, 1, 19, "positional argument after keyword");
    check_err("SET c Color(1, 2, 3, 4)", ErrorKind::BadArguments, 1, 22, "too many arguments");
    check_err("SET c Color(.G 1, .G 2)", ErrorKind::BadArguments, 1, 19, "given twice");
    check_err("SET c <1, 2 3>", ErrorKind::Syntax, 1, 13, "expected `,`");
    check_err("SET c Color(1 2)", ErrorKind::Syntax, 1, 15, "expected `,` or `)`");
    check_err(
        "SET t TRANSLATE(1) * Pigment.Uniform()",
        ErrorKind::WrongType,
        1,
        22,
        "cannot multiply a Transformation",
    );
    check_err("SET t ROTATE(.W 3)", ErrorKind::UnknownKeyword, 1, 14, "unknown rotation axis");
    check_err("SET t ROTATE(.X 3, .Y 4)", ErrorKind::Syntax, 1, 18, "expected `*` or `)`");
    check_err("SET t Transformation([1, 2, 3])", ErrorKind::BadValue, 1, 22, "16 numbers, got 3");
    check_err("SET s UNITE(Shape.Sphere())", ErrorKind::BadArguments, 1, 13, "at least two shapes");
    check_err("SET s DIFF(Shape.Sphere(), 3)", ErrorKind::WrongType, 1, 28, "combines shapes");
    check_err(
        "SET s FUSE(Shape.Sphere(), Shape.Cube(), .material Material())",
        ErrorKind::UnknownKeyword,
        1,
        42,
        ".transformation",
    );
    check_err("SPAWN Material()", ErrorKind::WrongType, 1, 7, "cannot SPAWN a Material");
    check_err("USING Shape.Sphere()", ErrorKind::WrongType, 1, 7, "cannot use a Shape as a setting");
    check_err("SET a 1\n  SCALE 2", ErrorKind::Syntax, 2, 3, "expected an instruction");
    check_err("SET", ErrorKind::Syntax, 1, 4, "expected a name after SET");
    check_err("SET a SET", ErrorKind::Syntax, 1, 7, "found the instruction SET");
    check_err("SPAWN 3", ErrorKind::Syntax, 1, 7, "expected a shape or light after SPAWN");
    check_err("SET c Pigment.Checkered(.N 2.5)", ErrorKind::BadValue, 1, 28, "whole number");
    check_err("SET c Camera.Perspective(.aspect_ratio -1)", ErrorKind::BadValue, 1, 40, "must be > 0");
    check_err("SET b Brdf.Dielectric(.ior 0)", ErrorKind::BadValue, 1, 28, "must be > 0");
    check_err("SET p Pigment.Image(.filter \"cubic\")", ErrorKind::BadValue, 1, 29, "unknown image filter");
    check_err("SET a LOAD 3", ErrorKind::WrongType, 1, 12, "LOAD takes a file name");
}

#[test]
fn name_errors() {
    let e = check_err("SET a 1\nSET b 2 a 3", ErrorKind::RedefinedName, 2, 9, "`a` is already defined");
    assert!(e.note().unwrap().contains("t.sl:1:5"), "{e}");
    check_err(
        "SET a 1\nUNSET a\nSPAWN Light(.linear_radius a)",
        ErrorKind::UndefinedName,
        3,
        28,
        "undefined identifier `a`",
    );
    check_err("UNSET nothing", ErrorKind::UndefinedName, 1, 7, "undefined identifier `nothing`");
    let e = check_err("SET radius 1\nSET x radus", ErrorKind::UndefinedName, 2, 7, "undefined");
    assert_eq!(e.note(), Some("did you mean `radius`?"));
    check_err("DUMP nope", ErrorKind::UndefinedName, 1, 6, "undefined identifier");
}

#[test]
fn settings_errors() {
    check_err("SET x 1\nUSING Image(1, 1) Renderer.Flat() Tracer()\n", ErrorKind::MissingSetting, 2, 42, "camera");
    check_err("USING Camera.Orthogonal() Renderer.Flat() Tracer()", ErrorKind::MissingSetting, 1, 50, "image");
    check_err("USING Camera.Orthogonal() Image(1, 1) Tracer()", ErrorKind::MissingSetting, 1, 46, "renderer");
    check_err("USING Camera.Orthogonal() Image(1, 1) Renderer.Flat()", ErrorKind::MissingSetting, 1, 53, "tracer");
    let e = check_err(
        "USING Camera.Orthogonal() Image(1, 1)\nUSING Renderer.Flat() Tracer() Image(2, 2)",
        ErrorKind::RepeatedSetting,
        2,
        32,
        "the image is already set",
    );
    assert!(e.note().unwrap().contains("1:27"), "{e}");
    check_err(
        &format!("{SETTINGS}USING Environment.Uniform() Environment.Uniform()"),
        ErrorKind::RepeatedSetting,
        3,
        29,
        "environment",
    );
}

#[test]
fn math_errors_and_singular_transformations() {
    // The value in words, not Rust's debug form (`Num(inf)` until 2026-12-07).
    check_err("SET a $1 / 0$", ErrorKind::NonFinite, 1, 8, "gives a non-finite value: infinity");
    check_err("SET a $log(-1) + 1$", ErrorKind::NonFinite, 1, 8, "gives a non-finite value: NaN");
    check_err(
        "SET a $RGB(1, 0, 0) / 0$",
        ErrorKind::NonFinite,
        1,
        8,
        "gives a non-finite value: the colour <inf, NaN, NaN>",
    );
    check_err("SET a $1 + 2b$", ErrorKind::UndefinedName, 1, 13, "undefined identifier `b`");
    check_err("SET a $div(1, 2, 3)$", ErrorKind::BadExpression, 1, 8, "takes 2 arguments, got 3");
    check_err("SET m Material()\nSET a $m * 2$", ErrorKind::WrongType, 2, 8, "holds a Material");
    check_err("SET a $<1,2,3>$", ErrorKind::BadExpression, 1, 8, "unexpected character `<`");
    check_err("SET a $$", ErrorKind::BadExpression, 1, 7, "empty math expression");
    check_err("SET t SCALE 0", ErrorKind::InvalidScene, 1, 7, "singular");
    check_err("SET t SCALE(1, 0, 1)", ErrorKind::InvalidScene, 1, 7, "singular");
    check_err("SET t Transformation([1,0,0,0, 0,1,0,0, 0,0,0,0, 0,0,0,1])", ErrorKind::InvalidScene, 1, 22, "singular");
    check_err(
        "SET t Transformation([1,0,0,0, 0,1,0,0, 0,0,1,0, 1,0,0,1])",
        ErrorKind::InvalidScene,
        1,
        22,
        "only affine matrices (last row 0 0 0 1) are supported",
    );
    check_err("SET t SCALE 1e-200 * SCALE 1e-200", ErrorKind::InvalidScene, 1, 20, "not finite");
}

#[test]
fn math_in_scripts() {
    let s = with_settings(
        "SET a 9 white <1, 1, 1> p {1, 2, 3}
         SPAWN Light(.linear_radius $1 + 2a$, .color $white * 0.05$, .position $p * 2 - Point(1, 1, 1)$)
               Light(.linear_radius $-2^2 + 2^3^2 - div(7, 2) + 7 % 3$)
               Light(.linear_radius $round(2.5) + floor(-0.5) + atan(1, 1) * 4 / pi$, .color $RGB(1, 2, 3) / 2$)",
    );
    let l = &s.point_lights;
    assert_eq!((l[0].linear_radius, l[0].color, l[0].position), (19.0, Color::gray(0.05), DVec3::new(1.0, 3.0, 5.0)));
    assert_eq!(l[1].linear_radius, -4.0 + 512.0 - 3.0 + 1.0);
    assert!((l[2].linear_radius - (2.0 - 1.0 + 1.0)).abs() < 1e-15);
    assert_eq!(l[2].color, Color::new(0.5, 1.0, 1.5));
}

#[test]
fn the_diagnostic_format() {
    let e = err("SET\n\tm Material(\n\t\t.brdf Brdf.Diffuse(),\n\t\t.emitted Pigment.Uniform()\n\t)");
    assert_eq!(
        e.to_string(),
        "t.sl:4:3: error: unknown keyword `.emitted` for Material\n \
         4 | \t\t.emitted Pigment.Uniform()\n   \
         | \t\t^^^^^^^^\n   \
         = expected: one of .brdf .emitted_radiance"
    );
}

// ------------------------------------------------------------------ the shipped scenes

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

fn summary(name: &str) -> SceneSummary {
    let s = load_file(&scenes_dir().join(name), &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    SceneSummary::of(&s)
}

#[test]
fn every_shipped_scene_loads() {
    let mut n = 0;
    for dir in [scenes_dir(), scenes_dir().join("raytracer_jl")] {
        for entry in std::fs::read_dir(dir).unwrap() {
            let p = entry.unwrap().path();
            if p.extension().is_some_and(|e| e == "sl") {
                load_file(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
    }
    assert!(n >= 12, "only {n} scenes");
}

#[test]
fn shipped_scenes_have_what_they_promise() {
    let demo = summary("demo.sl");
    assert_eq!((demo.area_lights, demo.infinite_shapes, demo.dielectric_materials), (2, 1, 1));
    assert!(demo.renderer.starts_with("PathTracer"));
    let cornell = summary("cornell.sl");
    assert_eq!((cornell.count(ShapeKind::Cube), cornell.area_lights, cornell.infinite_shapes), (8, 1, 0));
    let csg = summary("csg.sl");
    assert!(csg.csg_max_depth >= 3 && csg.csg_nodes >= 4);
    assert!(csg.environment.starts_with("gradient"));
    let glass = summary("glass.sl");
    assert!(glass.dielectric_materials >= 3 && glass.area_lights == 1);
    let sky = summary("skybox.sl");
    assert!(sky.environment.starts_with("image 1024×512"), "{}", sky.environment);
    assert_eq!((sky.specular_materials, sky.dielectric_materials), (1, 1));
    let lamp = summary("streetlamp.sl");
    assert_eq!(lamp.point_lights, 3);
    assert!(lamp.renderer.starts_with("PointLight") && lamp.csg_nodes > 0);
    // Every BRDF kind is counted (counted by hand from the scripts).
    let mats = summary("materials.sl");
    let kinds = |s: &lumen::scenelang::SceneSummary| {
        (s.diffuse_materials, s.specular_materials, s.dielectric_materials, s.conductor_materials, s.plastic_materials)
    };
    assert_eq!((mats.materials, kinds(&mats)), (16, (1, 0, 5, 5, 5)));
    let meshes = summary("meshes.sl");
    assert_eq!((meshes.materials, kinds(&meshes), meshes.emissive_materials), (4, (2, 0, 0, 1, 1), 1));
    let many = summary("spheres_10k.sl");
    assert!(many.count(ShapeKind::Sphere) >= 10_000);
    // The animation moves with TIME.
    let at = |t: f64| load_file(&scenes_dir().join("animation.sl"), &LoadOptions { time: t, vars: vec![] }).unwrap();
    assert_ne!(at(0.0).camera, at(90.0).camera);
    assert_ne!(at(0.0).shapes[0], at(10.0).shapes[0]);
}

// ------------------------------------------------------------------ lumen check

fn lumen(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_lumen")).args(args).output().unwrap()
}

#[test]
fn lumen_check_summarises_scenes() {
    let path = scenes_dir().join("csg.sl");
    let out = lumen(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    // Counted by hand in the script: UNITE(carved = DIFF(INTERSECT, FUSE), half_dome = DIFF),
    // lens, snowman and capsule: 8 CSG nodes, UNITE → DIFF → INTERSECT the deepest path.
    assert!(text.contains("csg:          8 nodes, max depth 3"), "{text}");
    assert!(
        text.contains("image:        600×400") && text.contains("camera:       perspective, aspect ratio 1.5"),
        "{text}"
    );
    assert!(text.contains("8 sphere, 2 plane, 1 cube, 4 cylinder"), "{text}");

    let path = scenes_dir().join("streetlamp.sl");
    let out = lumen(&["check", path.to_str().unwrap(), "--vars", "spacing 5"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("lights:       3 point, 0 area") && text.contains("renderer:     PointLight"), "{text}");

    // --vars wins over the script's SET: the sphere's radius, hence the bounds, follow it.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("r.sl");
    std::fs::write(&p, format!("SET r 1\nSPAWN Shape.Sphere(.transformation SCALE r){SETTINGS}")).unwrap();
    let out = lumen(&["check", p.to_str().unwrap(), "--vars", "r 3"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("bounds:       [-3.0000, -3.0000, -3.0000] – [3.0000, 3.0000, 3.0000]"), "{text}");

    let out = lumen(&["check", scenes_dir().join("animation.sl").to_str().unwrap(), "--time", "-5"]);
    assert!(out.status.success());
}

#[test]
fn lumen_check_reports_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.sl");
    std::fs::write(&p, "SET a 1\nSET b Color(.X 1)\n").unwrap();
    let out = lumen(&["check", p.to_str().unwrap()]);
    assert!(!out.status.success());
    let text = String::from_utf8(out.stderr).unwrap();
    assert!(text.contains("bad.sl:2:13: error: unknown keyword `.X` for Color"), "{text}");
    assert!(
        text.contains("SET b Color(.X 1)") && text.contains("^^") && text.contains("expected: one of .R .G .B"),
        "{text}"
    );
    let out = lumen(&["check", dir.path().join("none.sl").to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8(out.stderr).unwrap().contains("cannot read script"));
}

// ------------------------------------------------------------------ robustness

fn sample_script() -> String {
    std::fs::read_to_string(scenes_dir().join("csg.sl")).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// Any text: an error or a scene, never a panic.
    #[test]
    fn random_text_never_panics(s in "[ -~\\n\\t]{0,200}") {
        let _ = load(&s);
    }

    /// Token soup from SceneLang's own vocabulary reaches deeper into the interpreter.
    #[test]
    fn random_token_soup_never_panics(words in prop::collection::vec(prop::sample::select(vec![
        "SET", "UNSET", "SPAWN", "USING", "DUMP", "TIME", "LOAD", "SCALE", "TRANSLATE", "ROTATE", "UNITE",
        "INTERSECT", "DIFF", "FUSE", "Color", "Point", "List", "Transformation", "Image", "Pigment", "Brdf",
        "Material", "Shape", "Light", "Pcg", "Camera", "Renderer", "Tracer", "Environment", ".Uniform", ".Sphere",
        ".X", ".Z", ".color", ".transformation", ".Perspective", ".PathTracer", ".Image", ".ALL", "(", ")", "<", ">",
        "{", "}", "[", "]", ",", "*", "a", "b", "1", "0", "-2.5", "1e300", "\"x.pfm\"", "$a+1$", "$1/0$", "$2a$",
    ]), 0..60)) {
        let mut sink = std::io::sink();
        let _ = load_str_with_output(&words.join(" "), "p.sl", Path::new("."), &LoadOptions::default(), &mut sink);
    }

    /// A real script with one span replaced by junk: never a panic.
    #[test]
    fn mutated_scripts_never_panic(at in 0.0f64..1.0, len in 0usize..20, junk in "[ -~]{0,8}") {
        let src = sample_script();
        // Anywhere in the script, its end included.
        let start = ((at * (src.len() + 1) as f64) as usize).min(src.len());
        let end = (start + len).min(src.len());
        if src.is_char_boundary(start) && src.is_char_boundary(end) {
            let mutated = format!("{}{}{}", &src[..start], junk, &src[end..]);
            let _ = load_str(&mutated, "m.sl", &scenes_dir(), &LoadOptions::default());
        }
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let deep = format!("SET s {}Shape.Sphere(){}", "UNITE(Shape.Cube(), ".repeat(5000), ")".repeat(5000));
    assert_eq!(err(&deep).kind, ErrorKind::TooDeep);
    let deep_math = format!("SET a ${}1{}$", "(".repeat(100_000), ")".repeat(100_000));
    assert_eq!(err(&deep_math).kind, ErrorKind::TooDeep);
}

#[test]
fn huge_images_are_sizes_not_allocations() {
    let s = load("USING Image() Camera.Orthogonal() Renderer.Flat() Tracer()").unwrap();
    assert_eq!((s.width, s.height), (1, 1));
    let s = load("USING Image(32768, 8192) Camera.Orthogonal() Renderer.Flat() Tracer()").unwrap();
    assert_eq!((s.width, s.height), (32768, 8192));
    check_err("USING Image(32769, 1)", ErrorKind::BadImageSize, 1, 13, "from 1 to 32768");
    // Each side may be rendered, but not the whole: more pixels than an image file of lumen
    // holds (2²⁸), which would fail only when the finished render is written.
    let e = check_err(
        "USING Image(32768, 32768) Camera.Orthogonal() Renderer.Flat() Tracer()",
        ErrorKind::BadImageSize,
        1,
        7,
        "image size 32768×32768 cannot be rendered",
    );
    assert!(e.to_string().contains("at most 268435456 pixels in all"), "{e}");
}

#[test]
fn dump_shows_images_by_size_and_values_in_scenelang_syntax() {
    let mut out = Vec::new();
    let src = format!(
        "SET m Material(Brdf.Specular(Pigment.Image(Image(64, 32))), Pigment.Checkered(3, <1, 0, 0>))
         SPAWN UNITE(Shape.Cube(m), Shape.Sphere(), .transformation SCALE 2)
         DUMP m DUMP.world{SETTINGS}USING Environment.Image(Image(8, 4)) DUMP.environment"
    );
    load_str_with_output(&src, "t.sl", Path::new("."), &LoadOptions::default(), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    let m = "Material(Brdf.Specular(Pigment.Image(<64×32 image>, .filter Nearest), 0.0017453294), \
             Pigment.Checkered(3, <1, 0, 0>, <0, 0, 0>))";
    assert!(text.contains(&format!("m = {m}")), "{text}");
    assert!(text.contains("UNITE Transformation([2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1])"), "{text}");
    assert!(text.contains("    Cube material #0") && text.contains(&format!("#0 {m}")), "{text}");
    assert!(text.contains("environment: Environment.Image(8×4 pixels, .intensity 1, .rotation 0)"), "{text}");
    assert!(text.len() < 2000, "DUMP must not print pixels:\n{text}");
}

// ------------------------------------------------------------------ limits and sharing (issue 16)

/// `SET c0 base`, then `SET c{i} OP(c{i-1}, c{i-1})` for i in 1..lines: line i+1 defines a
/// tree of 2^i copies of `base`.
fn doubling(op: &str, base: &str, lines: usize) -> String {
    let mut s = format!("SET c0 {base}\n");
    for i in 1..lines {
        s += &format!("SET c{i} {op}(c{}, c{})\n", i - 1, i - 1);
    }
    s
}

#[test]
fn shared_names_are_refused_where_they_cross_the_primitive_limit() {
    assert_eq!(MAX_PRIMITIVES, 1 << 21);
    // The reproducer of issue 16 (a FUSE chain of 23 lines took > 4 GiB), and the same
    // chain of INTERSECTs: c21 = 2^21 primitives is allowed, c22 on line 23 is not, and the
    // error points at its node.
    for op in ["FUSE", "INTERSECT"] {
        let e = check_err(
            &doubling(op, "Shape.Sphere()", 23),
            ErrorKind::TooLarge,
            23,
            9,
            &format!("this {op} stands for 4194304 primitives, more than the limit of 2097152"),
        );
        assert!(e.note().unwrap().contains("once per use"), "{e}");
    }
    // 64 lines would overflow a 64-bit count: the first crossing is still what is reported.
    check_err(&doubling("INTERSECT", "Shape.Sphere()", 70), ErrorKind::TooLarge, 23, 9, "4194304 primitives");
    // A scene of shared names that stays within the limits checks, names used thousands of
    // times included: each use is a pointer, so this takes no time, while copying c20
    // (2^20 spheres) per use would need some 10^10 nodes.
    let mut src = doubling("INTERSECT", "Shape.Sphere()", 21);
    for i in 0..5000 {
        src += &format!("SET d{i} UNITE(c20, c0)\n");
    }
    let s = with_settings(&src);
    assert!(s.shapes.is_empty());
}

#[test]
fn spawn_refuses_scenes_beyond_the_primitive_limit_before_expanding_them() {
    // c21 alone is 2^21 primitives, exactly the limit; one more sphere before it crosses it.
    let src = format!("{}SPAWN Shape.Sphere() c21", doubling("INTERSECT", "Shape.Sphere()", 22));
    let e = check_err(&src, ErrorKind::TooLarge, 23, 22, "the scene would hold 2097153 primitives");
    assert!(e.to_string().contains("limit of 2097152"), "{e}");
    // Within the limit, a spawned shared shape expands to every use of its leaves, with
    // their material looked up once: 2^10 leaves, one material.
    let src = doubling("FUSE", "Shape.Sphere(.material Material(Brdf.Diffuse(<0.5, 0.25, 1>)))", 11) + "SPAWN c10";
    let s = with_settings(&src);
    assert_eq!((s.shapes.len(), s.materials.len()), (1, 1));
    assert_eq!(s.shapes[0].csg_depth(), 10);
    let mut leaves = 0;
    s.shapes[0].for_each_primitive(&mut |p, _| {
        assert_eq!(p.material, MaterialId(0));
        leaves += 1;
    });
    assert_eq!(leaves, 1024);
}

#[test]
fn csg_depth_is_limited_and_long_chains_are_linear() {
    assert_eq!(MAX_CSG_DEPTH, 256);
    // The UNITE chain of issue 16 (4000 lines, each uniting the previous line's shape with a
    // sphere; memory grew with the square of its length): line i + 1 is depth i, so the
    // first line past the depth limit is refused, at its UNITE.
    let chain = |lines: usize| {
        let mut s = String::from("SET u0 Shape.Sphere()\n");
        for i in 1..lines {
            s += &format!("SET u{i} UNITE(u{}, Shape.Sphere())\n", i - 1);
        }
        s
    };
    let e =
        check_err(&chain(4000), ErrorKind::TooDeep, 258, 10, "nests CSG 257 levels deep, more than the limit of 256");
    assert!(e.note().unwrap().contains("UNITE(a, b, c, ...)"), "{e}");
    // At the limit it loads, spawns and keeps its shape: depth 256, 257 spheres.
    let s = with_settings(&format!("{}SPAWN u256", chain(257)));
    assert_eq!(s.shapes[0].csg_depth(), 256);
    let mut n = 0;
    s.shapes[0].for_each_primitive(&mut |_, _| n += 1);
    assert_eq!(n, 257);
    // The flat spelling of a long union is one level, however wide.
    let wide = format!("SPAWN UNITE({})", vec!["Shape.Sphere()"; 4000].join(", "));
    let s = with_settings(&wide);
    assert_eq!((s.shapes[0].csg_depth(), s.shapes[0].csg_node_count()), (1, 1));
}

#[test]
fn an_intersect_of_many_unites_loads() {
    // Issue 16, item 6: an INTERSECT of k two-sphere UNITEs may cross a ray in 2^k pieces
    // (each UNITE's two intervals overlap), which interval lists would have to hold; such
    // trees were refused beyond 2^16 pieces. Classifying crossings needs one span per leaf
    // (cpu::csg), so 64 of them load, 128 primitives.
    let intersect =
        |k: usize| format!("SET p UNITE(Shape.Sphere(), Shape.Sphere())\nSPAWN INTERSECT({})", vec!["p"; k].join(", "));
    let s = with_settings(&intersect(64));
    let mut n = 0;
    s.shapes[0].for_each_primitive(&mut |_, _| n += 1);
    assert_eq!((n, s.shapes[0].csg_depth()), (128, 2));
}

#[test]
fn a_colour_where_a_pigment_goes_is_a_uniform_pigment() {
    let s = with_settings(
        "SPAWN Shape.Sphere(.material Material(.brdf Brdf.Dielectric(.pigment <1, 1, 1>)))
               Shape.Cube(.material Material(Brdf.Diffuse(<0.5, 0.25, 0>), <2, 3, 4>))",
    );
    let glass = Material::new(
        Brdf::Dielectric {
            pigment: Pigment::Uniform(Color::new(1.0, 1.0, 1.0)),
            ior: 1.5,
            roughness: 0.0,
            multiple_scattering: true,
        },
        Pigment::Uniform(Color::BLACK),
    );
    assert_eq!(material(&s, 0), &glass);
    let lamp = Material::new(
        Brdf::Diffuse { pigment: Pigment::Uniform(Color::new(0.5, 0.25, 0.0)) },
        Pigment::Uniform(Color::new(2.0, 3.0, 4.0)),
    );
    assert_eq!(material(&s, 1), &lamp);
    // Only where a pigment is expected: a colour is still no number.
    check_err("SET b Brdf.Dielectric(.ior <1, 1, 1>)", ErrorKind::WrongType, 1, 28, "must be a number");
}

#[test]
fn loading_is_linear_in_the_number_of_names() {
    // Issue 16, item 4: each SET recorded its origin by rescanning the source from the
    // start, so 40 000 names took 10 s. A million names (14 MB) would take hours that way;
    // the redefinition at the end must also name the right line of the first one.
    let n = 1_000_000;
    let mut src = String::with_capacity(16 * n);
    for i in 0..n {
        src += &format!("SET n{i} {i}\n");
    }
    src += "SET n999998 1";
    let e = check_err(&src, ErrorKind::RedefinedName, n + 1, 5, "`n999998` is already defined");
    assert_eq!(e.note(), Some("`n999998` was defined at t.sl:999999:5"));
}

#[test]
fn rough_materials_and_their_defaults() {
    let s = with_settings(
        "SPAWN Shape.Sphere(Material(Brdf.Conductor()))
               Shape.Sphere(Material(Brdf.Conductor(<1, 0.8, 0.6>, 0.3, <0.2, 0.4, 1.4>, <3.9, 2.4, 1.6>)))
               Shape.Sphere(Material(Brdf.Dielectric(.roughness 0.5)))
               Shape.Sphere(Material(Brdf.Plastic(<0.5, 0.1, 0.1>)))
               Shape.Sphere(Material(Brdf.Plastic(.ior 1.4, .roughness 0)))",
    );
    let white = Pigment::Uniform(Color::WHITE);
    assert_eq!(
        material(&s, 0).brdf,
        Brdf::Conductor { pigment: white.clone(), roughness: 0.0, fresnel: None, multiple_scattering: true }
    );
    assert_eq!(
        material(&s, 1).brdf,
        Brdf::Conductor {
            pigment: Pigment::Uniform(Color::new(1.0, 0.8, 0.6)),
            roughness: 0.3,
            fresnel: Some((Color::new(0.2, 0.4, 1.4), Color::new(3.9, 2.4, 1.6))),
            multiple_scattering: true
        }
    );
    assert_eq!(
        material(&s, 2).brdf,
        Brdf::Dielectric { pigment: white.clone(), ior: 1.5, roughness: 0.5, multiple_scattering: true }
    );
    assert_eq!(
        material(&s, 3).brdf,
        Brdf::Plastic { pigment: Pigment::Uniform(Color::new(0.5, 0.1, 0.1)), ior: 1.5, roughness: 0.1 }
    );
    assert_eq!(material(&s, 4).brdf, Brdf::Plastic { pigment: white, ior: 1.4, roughness: 0.0 });
    assert!(!material(&s, 3).brdf.is_delta() && material(&s, 0).brdf.is_delta() && !material(&s, 2).brdf.is_delta());
}

#[test]
fn bad_rough_material_values_are_located_errors() {
    check_err("SET b Brdf.Conductor(.roughness -0.1)", ErrorKind::BadValue, 1, 33, "`.roughness` must be in [0, 1]");
    check_err("SET b Brdf.Conductor(.roughness 1.5)", ErrorKind::BadValue, 1, 33, "`.roughness` must be in [0, 1]");
    check_err("SET b Brdf.Dielectric(.roughness 2)", ErrorKind::BadValue, 1, 34, "`.roughness` must be in [0, 1]");
    check_err("SET b Brdf.Plastic(.ior -1)", ErrorKind::BadValue, 1, 25, "must be > 0");
    check_err("SET b Brdf.Conductor(.eta <0, 1, 1>)", ErrorKind::BadValue, 1, 27, "`.eta` must be finite and positive");
    check_err(
        "SET b Brdf.Conductor(.k <1, -1, 1>)",
        ErrorKind::BadValue,
        1,
        25,
        "`.k` must be finite and positive, got <1, -1, 1>",
    );
    check_err("SET b Brdf.Conductor(.metal \"Pt\")", ErrorKind::BadValue, 1, 29, "unknown metal \"Pt\"");
    check_err(
        "SET b Brdf.Conductor(.metal \"Au\", .k <1, 1, 1>)",
        ErrorKind::BadArguments,
        1,
        38,
        "`.metal` already gives `.eta` and `.k`",
    );
    check_err("SET b Brdf.Dielectric(.multiple_scattering 2)", ErrorKind::BadValue, 1, 44, "whole number from 0 to 1");
}

/// Named metals give the tabulated index; `.multiple_scattering 0` asks for single
/// scattering; both survive DUMP and reloading.
#[test]
fn named_metals_and_single_scattering() {
    let s = with_settings(
        "SPAWN Shape.Sphere(Material(Brdf.Conductor(.metal \"Cu\", .roughness 0.4, .multiple_scattering 0)))
               Shape.Sphere(Material(Brdf.Dielectric(.roughness 0.5, .multiple_scattering 0)))
               Shape.Sphere(Material(Brdf.Conductor(.metal \"Au\")))",
    );
    let cu = lumen::optics::metals::metal("Cu").unwrap();
    assert_eq!(
        material(&s, 0).brdf,
        Brdf::Conductor {
            pigment: Pigment::Uniform(Color::WHITE),
            roughness: 0.4,
            fresnel: Some((cu.eta, cu.k)),
            multiple_scattering: false
        }
    );
    assert!(matches!(material(&s, 1).brdf, Brdf::Dielectric { multiple_scattering: false, .. }));
    assert!(matches!(material(&s, 2).brdf, Brdf::Conductor { multiple_scattering: true, fresnel: Some(_), .. }));
    // DUMP writes the materials in SceneLang syntax; reading that back gives them again.
    let mut out = Vec::new();
    let src = format!(
        "SET a Material(Brdf.Conductor(.metal \"Cu\", .roughness 0.4, .multiple_scattering 0))
         SET b Material(Brdf.Dielectric(.roughness 0.5, .multiple_scattering 0)) DUMP a DUMP b{SETTINGS}"
    );
    load_str_with_output(&src, "t.sl", Path::new("."), &LoadOptions::default(), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(text.matches(".multiple_scattering 0").count() == 2, "{text}");
    let mut body = String::from("SPAWN");
    for line in text.lines() {
        let (_, value) = line.split_once(" = ").unwrap_or_else(|| panic!("{text}"));
        body += &format!(" Shape.Sphere({value})");
    }
    let again = with_settings(&body);
    for i in 0..2 {
        assert_eq!(material(&again, i).brdf, material(&s, i).brdf, "{text}");
    }
}

/// A leading UTF-8 byte-order mark (Windows editors write one) is skipped: the script loads
/// as without it, and columns on its first line count from after it.
#[test]
fn a_leading_byte_order_mark_is_skipped() {
    let src = "SPAWN Shape.Sphere(.transformation TRANSLATE(.X 2))\nUSING Camera.Perspective() Image(4, 3) Renderer.Flat() Tracer()\n";
    let with_bom = format!("\u{feff}{src}");
    assert_eq!(load(&with_bom).unwrap(), load(src).unwrap());
    check_err("\u{feff}SPAWN Shape.Sphere(.bogus 1)\n", ErrorKind::UnknownKeyword, 1, 20, ".bogus");
    // Only a leading one: elsewhere it is a stray character, as before.
    assert!(load(&format!("SPAWN Shape.Sphere()\n\u{feff}{src}")).is_err());
}

/// A script that is not UTF-8 (saved as Latin-1, or UTF-16 with its byte-order mark) is
/// refused at its first bad byte, with line, column and the line up to there: it was one
/// line without a position ("stream did not contain valid UTF-8").
#[test]
fn a_script_that_is_not_utf8_is_refused_where_it_stops_being_utf8() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[u8], usize, usize, &str, &str); 4] = [
        (b"SET x 1\nSET caf\xe9 2\n", 2, 8, "bytes 0xE9 0x20 0x32 0x0A", " 2 | SET caf\n   |        ^"),
        (b"\xef\xbb\xbfSET \xff 1\n", 1, 5, "bytes 0xFF 0x20 0x31 0x0A", " 1 | SET \n   |     ^"),
        (b"\xff\xfeS\x00E\x00T\x00", 1, 1, "bytes 0xFF 0xFE 0x53 0x00", " 1 | \n   | ^"),
        (b"# \xc3\xa9t\xc3\xa9\r\nSET a\xc3", 2, 6, "byte 0xC3", " 2 | SET a\n   |      ^"),
    ];
    for (k, (bytes, line, col, shown, excerpt)) in cases.into_iter().enumerate() {
        let path = dir.path().join(format!("s{k}.sl"));
        std::fs::write(&path, bytes).unwrap();
        let e = lumen::scenelang::load_file(&path, &LoadOptions::default()).unwrap_err();
        assert_eq!((e.kind, e.line, e.col), (ErrorKind::Encoding, line, col), "case {k}: {e}");
        assert_eq!(e.message, format!("the script is not UTF-8 text: {shown} here"), "case {k}");
        assert!(e.to_string().contains(excerpt), "case {k}: {e}");
    }
}
