//! What a scene needs from the GPU kernel, so the assembled WGSL holds nothing else.
//!
//! Specialising the kernel per scene keeps register pressure and compile time down (a
//! spheres-only scene never compiles CSG interval lists or texture lookups) and lets
//! fixed-size arrays (CSG interval lists) be sized from the scene instead of a worst case.

use crate::scene::{Brdf, Environment, Pigment, Renderer, Scene, Shape, ShapeKind};

/// Environment kinds, for specialisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum EnvKind {
    /// No environment: escaping rays see the renderer's background colour.
    #[default]
    Background,
    Uniform,
    Gradient,
    Image,
}

/// Integrator kinds, for specialisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RendererKind {
    OnOff,
    Flat,
    PointLight,
    #[default]
    PathTracer,
}

/// Everything the kernel can be specialised on. Derived from a scene by
/// [`FeatureSet::of`]; any value (even one no scene produces) assembles to valid WGSL.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct FeatureSet {
    pub sphere: bool,
    pub plane: bool,
    pub cube: bool,
    pub cylinder: bool,
    /// Some top-level shape is a CSG tree.
    pub csg: bool,
    /// Bound on the length of any CSG interval list (`csg::max_intervals`); ≥ 1 when `csg`.
    pub csg_max_intervals: u32,
    /// Bound on the depth of any CSG tree (sizes the evaluation stack).
    pub csg_max_depth: u32,
    /// Top-level CSG trees: up to `cpu::CSG_DEFER_MAX` of them are evaluated after the BVH
    /// traversal rather than inside it (as `cpu::World` does; DESIGN.md "Software adapters").
    pub csg_trees: u32,
    pub pigment_uniform: bool,
    pub pigment_checkered: bool,
    pub pigment_image: bool,
    pub diffuse: bool,
    pub specular: bool,
    pub dielectric: bool,
    pub point_lights: bool,
    pub area_lights: bool,
    pub environment: EnvKind,
    pub renderer: RendererKind,
    /// Finite objects exist, traversed through the BVH (planes are tested separately).
    pub bvh: bool,
    /// Next-event estimation with MIS (path tracer with some diffuse material only: light
    /// sampling happens at diffuse vertices).
    pub nee: bool,
}

impl FeatureSet {
    /// The features `scene` uses. Only materials actually referenced by a shape count.
    pub fn of(scene: &Scene) -> Self {
        let mut f = FeatureSet { renderer: RendererKind::of(&scene.renderer), ..Default::default() };
        let mut used = vec![false; scene.materials.len()];
        for shape in &scene.shapes {
            match shape {
                Shape::Primitive(p) => {
                    if p.kind != ShapeKind::Plane {
                        f.bvh = true;
                    }
                }
                Shape::Csg(_) => {
                    f.csg = true;
                    f.bvh = true;
                    f.csg_trees += 1;
                    f.csg_max_intervals = f.csg_max_intervals.max(crate::cpu::csg::max_intervals(shape) as u32);
                    f.csg_max_depth = f.csg_max_depth.max(shape.csg_depth() as u32);
                }
            }
            shape.for_each_primitive(&mut |p, _| {
                match p.kind {
                    ShapeKind::Sphere => f.sphere = true,
                    ShapeKind::Plane => f.plane = true,
                    ShapeKind::Cube => f.cube = true,
                    ShapeKind::Cylinder => f.cylinder = true,
                }
                if let Some(u) = used.get_mut(p.material.0 as usize) {
                    *u = true;
                }
            });
        }
        let needs_shading = match f.renderer {
            RendererKind::OnOff => false,
            RendererKind::PointLight => !scene.point_lights.is_empty(),
            _ => true,
        };
        for (m, _) in scene.materials.iter().zip(&used).filter(|(_, u)| **u) {
            if needs_shading {
                f.add_pigment(m.brdf.pigment());
                if !m.emitted.is_black() {
                    f.add_pigment(&m.emitted);
                }
            }
            match m.brdf {
                Brdf::Diffuse { .. } => f.diffuse = true,
                Brdf::Specular { .. } => f.specular = true,
                Brdf::Dielectric { .. } => f.dielectric = true,
            }
        }
        // Only integrators that scatter need BRDF code.
        if !matches!(f.renderer, RendererKind::PathTracer | RendererKind::PointLight) {
            f.diffuse = false;
            f.specular = false;
            f.dielectric = false;
        }
        if f.renderer == RendererKind::PointLight {
            // Only the diffuse BRDF value is evaluated; delta BRDFs contribute 0.
            f.specular = false;
            f.dielectric = false;
        }
        f.point_lights =
            !scene.point_lights.is_empty() && matches!(f.renderer, RendererKind::PointLight | RendererKind::PathTracer);
        if let Renderer::PathTracer(p) = &scene.renderer {
            // Light sampling happens only at diffuse vertices.
            f.nee = p.nee && f.diffuse;
            f.area_lights = f.nee && !scene.area_lights().is_empty();
        }
        if f.renderer != RendererKind::OnOff {
            f.environment = match &scene.environment {
                None => EnvKind::Background,
                Some(Environment::Uniform(_)) => EnvKind::Uniform,
                Some(Environment::Gradient { .. }) => EnvKind::Gradient,
                Some(Environment::Image { .. }) => EnvKind::Image,
            };
        }
        f
    }

    fn add_pigment(&mut self, p: &Pigment) {
        match p {
            Pigment::Uniform(_) => self.pigment_uniform = true,
            Pigment::Checkered { .. } => self.pigment_checkered = true,
            Pigment::Image { .. } => self.pigment_image = true,
        }
    }

    /// True when some texel buffer is read (image pigments or an image environment).
    pub fn textures(&self) -> bool {
        self.pigment_image || self.environment == EnvKind::Image
    }

    /// True when escaping rays see the environment (every renderer but OnOff).
    pub fn shading(&self) -> bool {
        self.renderer != RendererKind::OnOff
    }

    /// True when the kernel reads materials (not OnOff, nor PointLight without lights).
    pub fn materials(&self) -> bool {
        match self.renderer {
            RendererKind::OnOff => false,
            RendererKind::PointLight => self.point_lights,
            _ => true,
        }
    }

    /// Every feature name a shader may test (see [`Self::names`]).
    pub const ALL_NAMES: [&'static str; 27] = [
        "MATERIALS",
        "GEOMETRY",
        "SHADOWS",
        "SPHERE",
        "PLANE",
        "CUBE",
        "CYLINDER",
        "CSG",
        "BVH",
        "SHADING",
        "PIGMENT_UNIFORM",
        "PIGMENT_CHECKERED",
        "PIGMENT_IMAGE",
        "TEXTURES",
        "DIFFUSE",
        "SPECULAR",
        "DIELECTRIC",
        "POINT_LIGHTS",
        "AREA_LIGHTS",
        "NEE",
        "ENV_UNIFORM",
        "ENV_GRADIENT",
        "ENV_IMAGE",
        "ONOFF",
        "FLAT",
        "POINTLIGHT",
        "PATHTRACER",
    ];

    /// The names of the `// #if NAME` blocks enabled for this set.
    pub fn names(&self) -> Vec<&'static str> {
        let flags = [
            (self.materials(), "MATERIALS"),
            (self.bvh || self.plane, "GEOMETRY"),
            (self.renderer == RendererKind::OnOff || self.point_lights || self.nee, "SHADOWS"),
            (self.sphere, "SPHERE"),
            (self.plane, "PLANE"),
            (self.cube, "CUBE"),
            (self.cylinder, "CYLINDER"),
            (self.csg, "CSG"),
            (self.bvh, "BVH"),
            (self.shading(), "SHADING"),
            (self.pigment_uniform, "PIGMENT_UNIFORM"),
            (self.pigment_checkered, "PIGMENT_CHECKERED"),
            (self.pigment_image, "PIGMENT_IMAGE"),
            (self.textures(), "TEXTURES"),
            (self.diffuse, "DIFFUSE"),
            (self.specular, "SPECULAR"),
            (self.dielectric, "DIELECTRIC"),
            (self.point_lights, "POINT_LIGHTS"),
            (self.area_lights, "AREA_LIGHTS"),
            (self.nee, "NEE"),
            (matches!(self.environment, EnvKind::Uniform | EnvKind::Background) && self.shading(), "ENV_UNIFORM"),
            (self.environment == EnvKind::Gradient, "ENV_GRADIENT"),
            (self.environment == EnvKind::Image, "ENV_IMAGE"),
            (self.renderer == RendererKind::OnOff, "ONOFF"),
            (self.renderer == RendererKind::Flat, "FLAT"),
            (self.renderer == RendererKind::PointLight, "POINTLIGHT"),
            (self.renderer == RendererKind::PathTracer, "PATHTRACER"),
        ];
        flags.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect()
    }

    /// The set in the form the shader assembler takes.
    pub fn assembly_features(&self) -> crate::gpu::FeatureSet {
        self.names().into_iter().collect()
    }
}

impl RendererKind {
    pub fn of(r: &Renderer) -> Self {
        match r {
            Renderer::OnOff { .. } => RendererKind::OnOff,
            Renderer::Flat { .. } => RendererKind::Flat,
            Renderer::PointLight { .. } => RendererKind::PointLight,
            Renderer::PathTracer(_) => RendererKind::PathTracer,
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::color::Color;
    use crate::scene::{CsgOp, Material, PathTracerSettings, PointLight, SceneBuilder, Transform};

    #[test]
    fn features_follow_what_the_scene_uses() {
        let mut b = SceneBuilder::new(4, 4);
        let diffuse = b.diffuse(Color::gray(0.5));
        let glass = b.material(Material::new(
            Brdf::Dielectric { pigment: Pigment::Checkered { n: 2, on: Color::WHITE, off: Color::BLACK }, ior: 1.5 },
            Pigment::Uniform(Color::BLACK),
        ));
        // A material nobody uses does not count.
        b.material(Material::new(
            Brdf::Specular { pigment: Pigment::default(), threshold_angle_rad: 0.0 },
            Pigment::default(),
        ));
        let leaf = |k, m| Shape::primitive(k, Transform::translation(DVec3::X), m);
        let inner = Shape::csg(
            CsgOp::Diff,
            vec![leaf(ShapeKind::Cube, glass), leaf(ShapeKind::Cylinder, glass)],
            Transform::IDENTITY,
        );
        b.shape(Shape::csg(CsgOp::Unite, vec![inner, leaf(ShapeKind::Sphere, diffuse)], Transform::IDENTITY))
            .plane(Transform::IDENTITY, diffuse)
            .point_light(PointLight::default());
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(f.sphere && f.cube && f.cylinder && f.plane && f.csg && f.bvh);
        assert_eq!((f.csg_max_depth, f.csg_max_intervals), (2, 3));
        assert!(f.diffuse && f.dielectric && !f.specular);
        assert!(f.pigment_uniform && f.pigment_checkered && !f.pigment_image && !f.textures());
        assert!(f.point_lights && f.nee && !f.area_lights);
        assert_eq!((f.renderer, f.environment), (RendererKind::PathTracer, EnvKind::Background));
        let names = f.names();
        assert!(names.contains(&"ENV_UNIFORM") && names.contains(&"SHADOWS") && !names.contains(&"ONOFF"));
        assert!(names.iter().all(|n| FeatureSet::ALL_NAMES.contains(n)));

        // OnOff needs no materials, pigments, BRDFs, lights or environment.
        b.renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(!f.materials() && !f.diffuse && !f.pigment_uniform && !f.point_lights && !f.shading());
        // Without NEE the path tracer samples no lights but still visits point lights.
        b.renderer(Renderer::PathTracer(PathTracerSettings { nee: false, ..Default::default() }));
        let f = FeatureSet::of(&b.build().unwrap());
        assert!(!f.nee && f.point_lights);
    }
}
