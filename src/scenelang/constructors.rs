//! Named and command constructors (`Pigment.Uniform(...)`, `SCALE`, `ROTATE`, `UNITE`, images):
//! argument lists with positional-then-keyword arguments, defaults, type and range checks.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use super::error::{did_you_mean, ErrorKind, SceneLangError, Span};
use super::interpreter::Interp;
use super::lexer::{Lexer, Tok};
use super::value::{ImageValue, ShapeNode, ShapeValue, Ty, Value, PER_USE};
use crate::color::Color;
use crate::image::HdrImage;
use crate::scene::{
    Brdf, Camera, CsgOp, Environment, ImageFilter, Material, PathTracerSettings, PcgSeed, Pigment, PointLight,
    Projection, Renderer, SceneError, ShapeKind, Tracer, Transform, DEFAULT_THRESHOLD_ANGLE_RAD, MAX_CSG_DEPTH,
    MAX_IMAGE_SIDE, MAX_PRIMITIVES,
};

type Res<T> = Result<T, SceneLangError>;

/// Largest blank `Image(w, h)` that may be turned into pixels (as a texture or environment).
const MAX_BLANK_TEXTURE_PIXELS: u64 = 1 << 22;

/// One constructor parameter: its keyword (also its position in the list) and its type.
struct Param {
    name: &'static str,
    ty: Ty,
}

const fn p(name: &'static str, ty: Ty) -> Param {
    Param { name, ty }
}

/// Arguments of one constructor call, by parameter index.
struct Args {
    vals: Vec<Option<(Value, Span)>>,
}

impl Args {
    fn span(&self, i: usize) -> Option<Span> {
        self.vals[i].as_ref().map(|(_, s)| *s)
    }
    fn num(&self, i: usize, default: f64) -> f64 {
        match &self.vals[i] {
            Some((Value::Number(v), _)) => *v,
            _ => default,
        }
    }
    fn color(&self, i: usize, default: Color) -> Color {
        match &self.vals[i] {
            Some((Value::Color(v), _)) => *v,
            _ => default,
        }
    }
    fn point(&self, i: usize, default: DVec3) -> DVec3 {
        match &self.vals[i] {
            Some((Value::Point(v), _)) => *v,
            _ => default,
        }
    }
    fn transform(&self, i: usize) -> Transform {
        match &self.vals[i] {
            Some((Value::Transformation(v), _)) => *v,
            _ => Transform::IDENTITY,
        }
    }
    fn pigment(&self, i: usize) -> Pigment {
        match &self.vals[i] {
            Some((Value::Pigment(v), _)) => v.clone(),
            _ => Pigment::Uniform(Color::WHITE),
        }
    }
    fn pcg(&self, i: usize) -> PcgSeed {
        match &self.vals[i] {
            Some((Value::Pcg(v), _)) => *v,
            _ => PcgSeed::default(),
        }
    }
    fn take(&mut self, i: usize) -> Option<(Value, Span)> {
        self.vals[i].take()
    }
}

/// "one of Ty.a, Ty.b, …": what may follow a type's name.
fn kinds_of(ty: Ty, valid: &[&str]) -> String {
    format!("one of {}", valid.iter().map(|v| format!("{}.{v}", ty.name())).collect::<Vec<_>>().join(", "))
}

fn subtype_error(lx: &Lexer<'_>, ty: Ty, span: Span, found: &str, valid: &[&str]) -> SceneLangError {
    let mut e = lx
        .error(span, ErrorKind::UnknownKeyword, format!("unknown kind `{found}` of {}", ty.name()))
        .with_expected(kinds_of(ty, valid));
    if let Some(s) = did_you_mean(found.trim_start_matches('.'), valid.iter().copied()) {
        e = e.with_note(format!("did you mean `{}.{s}`?", ty.name()));
    }
    e
}

impl Interp<'_> {
    /// Parses `( positional..., .keyword value, ... )` against `params`, checking types.
    fn args(&mut self, ctor: &str, params: &[Param]) -> Res<Args> {
        self.expect_sym('(', &format!("after {ctor}"))?;
        let mut args = Args { vals: params.iter().map(|_| None).collect() };
        let mut positional = 0;
        let mut seen_keyword = false;
        if self.peek()?.tok == Tok::Sym(')') {
            self.lx.next()?;
            return Ok(args);
        }
        loop {
            let t = self.peek()?;
            let index = if let Tok::Keyword(k) = &t.tok {
                self.lx.next()?;
                seen_keyword = true;
                let Some(i) = params.iter().position(|p| p.name == k) else {
                    let names: Vec<&str> = params.iter().map(|p| p.name).collect();
                    let mut e = self
                        .err(t.span, ErrorKind::UnknownKeyword, format!("unknown keyword `.{k}` for {ctor}"))
                        .with_expected(if names.is_empty() {
                            format!("{ctor} takes no keywords")
                        } else {
                            format!("one of {}", names.iter().map(|n| format!(".{n}")).collect::<Vec<_>>().join(" "))
                        });
                    if let Some(s) = did_you_mean(k, names.iter().copied()) {
                        e = e.with_note(format!("did you mean `.{s}`?"));
                    }
                    return Err(e);
                };
                if args.vals[i].is_some() {
                    let how = if i < positional { "positionally" } else { "already" };
                    return Err(self
                        .err(t.span, ErrorKind::BadArguments, format!("`.{k}` of {ctor} is given twice ({how} before)"))
                        .with_expected("each argument at most once"));
                }
                i
            } else {
                if seen_keyword {
                    return Err(self
                        .err(
                            t.span,
                            ErrorKind::BadArguments,
                            format!("positional argument after keyword arguments in {ctor}"),
                        )
                        .with_expected("positional arguments first, then `.keyword value` pairs"));
                }
                if positional >= params.len() {
                    return Err(self
                        .err(t.span, ErrorKind::BadArguments, format!("too many arguments for {ctor}"))
                        .with_expected(format!(
                            "at most {} argument{}",
                            params.len(),
                            if params.len() == 1 { "" } else { "s" }
                        )));
                }
                positional += 1;
                positional - 1
            };
            let (v, s) = self.value()?;
            let param = &params[index];
            // Extension: a colour where a pigment is expected is that uniform pigment.
            let v = match v {
                Value::Color(c) if param.ty == Ty::Pigment => Value::Pigment(Pigment::Uniform(c)),
                v => v,
            };
            if v.ty() != param.ty {
                return Err(self
                    .type_err(
                        s,
                        format!(
                            "`.{}` of {ctor} must be {}, found {}",
                            param.name,
                            param.ty.article(),
                            v.ty().article()
                        ),
                    )
                    .with_expected(if param.ty == Ty::Pigment {
                        "a Pigment (or a colour `<r, g, b>`, short for Pigment.Uniform)".to_string()
                    } else {
                        param.ty.article()
                    }));
            }
            args.vals[index] = Some((v, s));
            if !self.separator(',', Some(')'), &format!(" in {ctor}"), "`,` or `)`")? {
                return Ok(args);
            }
        }
    }

    /// A whole number in `min..=max` from argument `i`, or `default`.
    fn int(&self, a: &Args, i: usize, name: &str, default: u64, min: u64, max: u64) -> Res<u64> {
        let Some(span) = a.span(i) else { return Ok(default) };
        let v = a.num(i, default as f64);
        if v.fract() != 0.0 || v < min as f64 || v > max as f64 {
            return Err(self
                .err(
                    span,
                    ErrorKind::BadValue,
                    format!("`.{name}` must be a whole number from {min} to {max}, got {v}"),
                )
                .with_expected(format!("a whole number from {min} to {max}")));
        }
        Ok(v as u64)
    }

    /// A finite number `> 0` (or `>= 0` when `allow_zero`) from argument `i`, or `default`.
    /// A relative index of refraction: finite and > 0.
    fn ior(&self, a: &Args, i: usize) -> Res<f64> {
        let v = self.positive(a, i, "ior", 1.5, false)?;
        if !v.is_finite() {
            let span = a.span(i).unwrap_or_default();
            return Err(self
                .err(span, ErrorKind::BadValue, format!("`.ior` must be finite, got {v}"))
                .with_expected("a finite number > 0"));
        }
        Ok(v)
    }

    /// A GGX roughness (α): finite, 0 ≤ r ≤ 1.
    fn roughness(&self, a: &Args, i: usize, default: f64) -> Res<f64> {
        let v = a.num(i, default);
        if !(0.0..=1.0).contains(&v) {
            let span = a.span(i).unwrap_or_default();
            return Err(self
                .err(span, ErrorKind::BadValue, format!("`.roughness` must be in [0, 1], got {v}"))
                .with_expected("a number 0 ≤ r ≤ 1"));
        }
        Ok(v)
    }

    fn positive(&self, a: &Args, i: usize, name: &str, default: f64, allow_zero: bool) -> Res<f64> {
        let v = a.num(i, default);
        let ok = if allow_zero { v >= 0.0 } else { v > 0.0 };
        if !ok {
            let span = a.span(i).unwrap_or_default();
            let bound = if allow_zero { "≥ 0" } else { "> 0" };
            return Err(self
                .err(span, ErrorKind::BadValue, format!("`.{name}` must be {bound}, got {v}"))
                .with_expected(format!("a number {bound}")));
        }
        Ok(v)
    }

    /// Maps the scene model's refusal of a transformation to a located error, and refuses
    /// transformations whose matrix or inverse overflowed.
    pub(super) fn checked(&self, t: Result<Transform, SceneError>, span: Span) -> Res<Transform> {
        let t = t.map_err(|e| {
            let expected = match e {
                // Raytracer.jl takes any invertible 4×4 matrix; lumen's shapes and bounds
                // assume affine ones.
                SceneError::NotAffine => "an affine matrix: last row 0 0 0 1 (projective matrices are not supported)",
                _ => "an invertible affine transformation (no zero scale factors)",
            };
            self.err(span, ErrorKind::InvalidScene, format!("invalid transformation: {e}")).with_expected(expected)
        })?;
        if !(t.matrix().is_finite() && t.inverse_matrix().is_finite()) {
            return Err(self
                .err(span, ErrorKind::InvalidScene, "invalid transformation: matrix or inverse is not finite")
                .with_expected("scale factors and translations of moderate size"));
        }
        Ok(t)
    }

    /// `TRANSLATE(.X 0, .Y 0, .Z 0)`.
    pub(super) fn translate(&mut self, span: Span) -> Res<Value> {
        let a = self.args("TRANSLATE", &[p("X", Ty::Number), p("Y", Ty::Number), p("Z", Ty::Number)])?;
        let v = DVec3::new(a.num(0, 0.0), a.num(1, 0.0), a.num(2, 0.0));
        Ok(Value::Transformation(self.checked(Ok(Transform::translation(v)), span.to(Span::new(self.lx.last_end, 0)))?))
    }

    pub(super) fn scale(&mut self, span: Span) -> Res<Value> {
        let t = if self.peek()?.tok == Tok::Sym('(') {
            let a = self.args("SCALE", &[p("X", Ty::Number), p("Y", Ty::Number), p("Z", Ty::Number)])?;
            Transform::try_scaling(DVec3::new(a.num(0, 1.0), a.num(1, 1.0), a.num(2, 1.0)))
        } else {
            let (s, ns) = self.number("SCALE")?;
            return Ok(Value::Transformation(self.checked(Transform::try_scaling(DVec3::splat(s)), span.to(ns))?));
        };
        Ok(Value::Transformation(self.checked(t, span.to(Span::new(self.lx.last_end, 0)))?))
    }

    /// `ROTATE(.X a * .Z b ...)` = the product Rx(a)·Rz(b)·…, written left to right exactly as
    /// `ROTATE(.X a) * ROTATE(.Z b)` would be: the rightmost rotation acts on points first.
    pub(super) fn rotate(&mut self) -> Res<Value> {
        self.expect_sym('(', "after ROTATE")?;
        let mut t = Transform::IDENTITY;
        loop {
            let k = self.lx.next()?;
            let Tok::Keyword(axis) = &k.tok else {
                return Err(self
                    .err(k.span, ErrorKind::Syntax, format!("expected an axis in ROTATE, found {}", k.tok.describe()))
                    .with_expected("`.X`, `.Y` or `.Z` followed by an angle in degrees"));
            };
            let (deg, ds) = self.number("a rotation angle")?;
            let r = match axis.as_str() {
                "X" => Transform::rotation_x(deg),
                "Y" => Transform::rotation_y(deg),
                "Z" => Transform::rotation_z(deg),
                _ => {
                    return Err(self
                        .err(k.span, ErrorKind::UnknownKeyword, format!("unknown rotation axis `.{axis}`"))
                        .with_expected("`.X`, `.Y` or `.Z`"))
                }
            };
            t = self.checked(Ok(t * r), k.span.to(ds))?;
            if !self.separator('*', Some(')'), " in ROTATE", "`*` between rotations, `)` after the last")? {
                break;
            }
        }
        Ok(Value::Transformation(t))
    }

    /// `UNITE(a, b, ..., .transformation T)` (the trailing keyword is lumen's way to place a
    /// CSG node; it applies after the children's own transformations).
    ///
    /// The node is refused, at its own span, where it crosses a limit of the tree it stands
    /// for (see [`Self::check_size`]); nothing is expanded here, children are shared.
    pub(super) fn csg(&mut self, op: CsgOp, start: Span) -> Res<Value> {
        let name = op.keyword();
        self.expect_sym('(', &format!("after {name}"))?;
        let mut children = Vec::new();
        let mut transform = Transform::IDENTITY;
        loop {
            let t = self.peek()?;
            if let Tok::Keyword(k) = &t.tok {
                self.lx.next()?;
                if k != "transformation" {
                    return Err(self
                        .err(t.span, ErrorKind::UnknownKeyword, format!("unknown keyword `.{k}` for {name}"))
                        .with_expected("`.transformation` (after the shapes)"));
                }
                let (v, s) = self.value()?;
                let Value::Transformation(tr) = v else {
                    return Err(self
                        .type_err(
                            s,
                            format!("`.transformation` of {name} must be a Transformation, found {}", v.ty().article()),
                        )
                        .with_expected("a Transformation"));
                };
                transform = tr;
                let close = self.lx.next()?;
                if close.tok != Tok::Sym(')') {
                    return Err(self
                        .err(
                            close.span,
                            ErrorKind::Syntax,
                            format!("expected `)` after `.transformation` in {name}, found {}", close.tok.describe()),
                        )
                        .with_expected("`)`: `.transformation` is the last argument"));
                }
                break;
            }
            let (v, s) = self.value()?;
            let Value::Shape(shape) = v else {
                return Err(self
                    .type_err(s, format!("{name} combines shapes, found {}", v.ty().article()))
                    .with_expected("a Shape"));
            };
            if let ShapeNode::Mesh { file, .. } = shape.node() {
                return Err(self
                    .err(s, ErrorKind::WrongType, format!("a mesh ({file}) cannot be a CSG operand"))
                    .with_expected("spheres, planes, cubes, cylinders or CSG nodes of them")
                    .with_note("triangle meshes have no inside for CSG's solid logic; spawn the mesh on its own"));
            }
            children.push((shape, s));
            if !self.separator(',', Some(')'), &format!(" in {name}"), "`,` or `)`")? {
                break;
            }
        }
        if children.len() < 2 {
            let span = children.first().map_or(Span::new(self.lx.last_end, 1), |c| c.1);
            return Err(self
                .err(span, ErrorKind::BadArguments, format!("{name} needs at least two shapes, got {}", children.len()))
                .with_expected("two or more shapes"));
        }
        let shape = ShapeValue::csg(op, children.into_iter().map(|c| c.0).collect(), transform);
        self.check_size(&shape, start.to(Span::new(self.lx.last_end, 0)))?;
        Ok(Value::Shape(shape))
    }

    /// Refuses a CSG node whose tree exceeds [`MAX_PRIMITIVES`] or [`MAX_CSG_DEPTH`]; its
    /// children were checked when they were made, so the first node to cross a limit is the
    /// one reported.
    fn check_size(&self, shape: &ShapeValue, span: Span) -> Res<()> {
        let size = shape.size();
        let name = match shape.node() {
            ShapeNode::Csg { op, .. } => op.keyword(),
            ShapeNode::Primitive { .. } | ShapeNode::Mesh { .. } => return Ok(()),
        };
        if size.depth > MAX_CSG_DEPTH {
            let msg =
                format!("this {name} nests CSG {} levels deep, more than the limit of {MAX_CSG_DEPTH}", size.depth);
            return Err(self
                .err(span, ErrorKind::TooDeep, msg)
                .with_expected(format!("CSG trees at most {MAX_CSG_DEPTH} levels deep"))
                .with_note("a CSG node of many shapes, UNITE(a, b, c, ...), is one level"));
        }
        if size.primitives > MAX_PRIMITIVES {
            let msg = format!(
                "this {name} stands for {} primitives, more than the limit of {MAX_PRIMITIVES}",
                size.primitives
            );
            return Err(self
                .err(span, ErrorKind::TooLarge, msg)
                .with_expected(format!("at most {MAX_PRIMITIVES} primitives in a scene"))
                .with_note(PER_USE));
        }
        Ok(())
    }

    /// Reads the `.Kind` after a type word.
    fn subtype(&mut self, ty: Ty, valid: &[&'static str]) -> Res<&'static str> {
        let t = self.lx.next()?;
        match &t.tok {
            Tok::Keyword(k) => match valid.iter().find(|v| **v == k) {
                Some(v) => Ok(v),
                None => Err(subtype_error(&self.lx, ty, t.span, &format!(".{k}"), valid)),
            },
            other => Err(self
                .err(
                    t.span,
                    ErrorKind::Syntax,
                    format!("expected the kind of {} after `{}`, found {}", ty.name(), ty.name(), other.describe()),
                )
                .with_expected(kinds_of(ty, valid))),
        }
    }

    pub(super) fn constructor(&mut self, ty: Ty) -> Res<Value> {
        use Ty as T;
        Ok(match ty {
            Ty::Color => {
                let a = self.args("Color", &[p("R", T::Number), p("G", T::Number), p("B", T::Number)])?;
                Value::Color(Color::new(a.num(0, 0.0), a.num(1, 0.0), a.num(2, 0.0)))
            }
            Ty::Point => {
                let a = self.args("Point", &[p("X", T::Number), p("Y", T::Number), p("Z", T::Number)])?;
                Value::Point(DVec3::new(a.num(0, 0.0), a.num(1, 0.0), a.num(2, 0.0)))
            }
            Ty::List => {
                self.expect_sym('(', "after List")?;
                Value::List(self.number_list(')')?)
            }
            Ty::Transformation => {
                let a = self.args("Transformation", &[p("matrix", T::List)])?;
                let Some((Value::List(l), ls)) = &a.vals[0] else {
                    return Ok(Value::Transformation(Transform::IDENTITY));
                };
                let Ok(rows) = <[f64; 16]>::try_from(&l[..]) else {
                    return Err(self
                        .err(
                            *ls,
                            ErrorKind::BadValue,
                            format!("a transformation matrix needs 16 numbers, got {}", l.len()),
                        )
                        .with_expected("16 numbers, row by row"));
                };
                Value::Transformation(self.checked(Transform::from_rows(rows), *ls)?)
            }
            Ty::Image => self.image_constructor()?,
            Ty::Pigment => {
                let kind = self.subtype(ty, &["Uniform", "Checkered", "Image"])?;
                Value::Pigment(match kind {
                    "Uniform" => {
                        Pigment::Uniform(self.args("Pigment.Uniform", &[p("color", T::Color)])?.color(0, Color::WHITE))
                    }
                    "Checkered" => {
                        let a = self.args(
                            "Pigment.Checkered",
                            &[p("N", T::Number), p("color_on", T::Color), p("color_off", T::Color)],
                        )?;
                        let n = self.int(&a, 0, "N", 2, 1, 1 << 20)? as u32;
                        Pigment::Checkered { n, on: a.color(1, Color::WHITE), off: a.color(2, Color::BLACK) }
                    }
                    _ => {
                        let mut a = self.args("Pigment.Image", &[p("image", T::Image), p("filter", T::Str)])?;
                        let filter = match a.take(1) {
                            None => ImageFilter::Nearest,
                            Some((Value::Str(s), fs)) => match s.as_str() {
                                "nearest" => ImageFilter::Nearest,
                                "bilinear" => ImageFilter::Bilinear,
                                _ => {
                                    return Err(self
                                        .err(fs, ErrorKind::BadValue, format!("unknown image filter {s:?}"))
                                        .with_expected("\"nearest\" or \"bilinear\""))
                                }
                            },
                            Some(_) => ImageFilter::Nearest,
                        };
                        Pigment::Image { image: self.pixels(a.take(0))?, filter }
                    }
                })
            }
            Ty::Brdf => {
                let kind = self.subtype(ty, &["Diffuse", "Specular", "Dielectric", "Conductor", "Plastic"])?;
                Value::Brdf(match kind {
                    "Diffuse" => {
                        Brdf::Diffuse { pigment: self.args("Brdf.Diffuse", &[p("pigment", T::Pigment)])?.pigment(0) }
                    }
                    "Specular" => {
                        let a = self
                            .args("Brdf.Specular", &[p("pigment", T::Pigment), p("threshold_angle_rad", T::Number)])?;
                        let threshold_angle_rad =
                            self.positive(&a, 1, "threshold_angle_rad", DEFAULT_THRESHOLD_ANGLE_RAD, true)?;
                        Brdf::Specular { pigment: a.pigment(0), threshold_angle_rad }
                    }
                    "Conductor" => {
                        let mut a = self.args(
                            "Brdf.Conductor",
                            &[
                                p("pigment", T::Pigment),
                                p("roughness", T::Number),
                                p("eta", T::Color),
                                p("k", T::Color),
                                p("metal", T::Str),
                                p("multiple_scattering", T::Number),
                            ],
                        )?;
                        let roughness = self.roughness(&a, 1, 0.0)?;
                        let multiple_scattering = self.int(&a, 5, "multiple_scattering", 1, 0, 1)? == 1;
                        let metal = match a.take(4) {
                            Some((Value::Str(s), span)) => {
                                if let Some(other) = a.span(2).or(a.span(3)) {
                                    return Err(self
                                        .err(
                                            other,
                                            ErrorKind::BadArguments,
                                            "`.metal` already gives `.eta` and `.k`: give one or the other",
                                        )
                                        .with_expected("either `.metal \"Au\"` or `.eta <..>, .k <..>`"));
                                }
                                match crate::optics::metals::metal(&s) {
                                    Some(m) => Some((m.eta, m.k)),
                                    None => {
                                        return Err(self
                                            .err(span, ErrorKind::BadValue, format!("unknown metal {s:?}"))
                                            .with_expected("\"Au\", \"Ag\", \"Cu\" or \"Al\""))
                                    }
                                }
                            }
                            _ => None,
                        };
                        let fresnel = match (a.span(2), a.span(3)) {
                            _ if metal.is_some() => metal,
                            (None, None) => None,
                            _ => {
                                let (eta, k) = (a.color(2, Color::WHITE), a.color(3, Color::BLACK));
                                for (i, name, c) in [(2, "eta", eta), (3, "k", k)] {
                                    let ok = c.is_finite()
                                        && c.min_component() >= 0.0
                                        && (i == 3 || c.min_component() > 0.0);
                                    if !ok {
                                        let span = a.span(i).unwrap_or_default();
                                        return Err(self
                                            .err(
                                                span,
                                                ErrorKind::BadValue,
                                                format!(
                                                    "`.{name}` must be finite and positive, got {}",
                                                    super::dump::describe(&Value::Color(c))
                                                ),
                                            )
                                            .with_expected(if i == 2 {
                                                "a colour of numbers > 0"
                                            } else {
                                                "a colour of numbers ≥ 0"
                                            }));
                                    }
                                }
                                Some((eta, k))
                            }
                        };
                        Brdf::Conductor { pigment: a.pigment(0), roughness, fresnel, multiple_scattering }
                    }
                    "Plastic" => {
                        let a = self.args(
                            "Brdf.Plastic",
                            &[p("pigment", T::Pigment), p("ior", T::Number), p("roughness", T::Number)],
                        )?;
                        let ior = self.ior(&a, 1)?;
                        let roughness = self.roughness(&a, 2, 0.1)?;
                        Brdf::Plastic { pigment: a.pigment(0), ior, roughness }
                    }
                    _ => {
                        let a = self.args(
                            "Brdf.Dielectric",
                            &[
                                p("pigment", T::Pigment),
                                p("ior", T::Number),
                                p("roughness", T::Number),
                                p("multiple_scattering", T::Number),
                            ],
                        )?;
                        let ior = self.ior(&a, 1)?;
                        let roughness = self.roughness(&a, 2, 0.0)?;
                        let multiple_scattering = self.int(&a, 3, "multiple_scattering", 1, 0, 1)? == 1;
                        Brdf::Dielectric { pigment: a.pigment(0), ior, roughness, multiple_scattering }
                    }
                })
            }
            Ty::Material => {
                let mut a = self.args("Material", &[p("brdf", T::Brdf), p("emitted_radiance", T::Pigment)])?;
                let brdf = match a.take(0) {
                    Some((Value::Brdf(b), _)) => b,
                    _ => Brdf::default(),
                };
                let emitted = match a.take(1) {
                    Some((Value::Pigment(p), _)) => p,
                    _ => Pigment::Uniform(Color::BLACK),
                };
                Value::Material(Material::new(brdf, emitted))
            }
            Ty::Shape => {
                let kind = self.subtype(ty, &["Sphere", "Plane", "Cube", "Cylinder", "Mesh"])?;
                if kind == "Mesh" {
                    return self.mesh_constructor();
                }
                let kind = match kind {
                    "Sphere" => ShapeKind::Sphere,
                    "Plane" => ShapeKind::Plane,
                    "Cube" => ShapeKind::Cube,
                    _ => ShapeKind::Cylinder,
                };
                let ctor = format!("Shape.{}", kind_name(kind));
                let mut a = self.args(&ctor, &[p("material", T::Material), p("transformation", T::Transformation)])?;
                let transform = a.transform(1);
                let material = match a.take(0) {
                    Some((Value::Material(m), _)) => m,
                    _ => Material::default(),
                };
                Value::Shape(ShapeValue::primitive(kind, transform, material))
            }
            Ty::Light => {
                let a = self
                    .args("Light", &[p("position", T::Point), p("color", T::Color), p("linear_radius", T::Number)])?;
                let linear_radius = self.positive(&a, 2, "linear_radius", 0.0, true)?;
                Value::Light(PointLight {
                    position: a.point(0, DVec3::ZERO),
                    color: a.color(1, Color::WHITE),
                    linear_radius,
                })
            }
            Ty::Pcg => {
                let a = self.args("Pcg", &[p("state", T::Number), p("inc", T::Number)])?;
                let state = self.int(&a, 0, "state", 42, 0, 1 << 53)?;
                let inc = self.int(&a, 1, "inc", 54, 0, 1 << 53)?;
                Value::Pcg(PcgSeed { state, inc })
            }
            Ty::Camera => {
                let kind = self.subtype(ty, &["Perspective", "Orthogonal"])?;
                if kind == "Perspective" {
                    let a = self.args(
                        "Camera.Perspective",
                        &[
                            p("aspect_ratio", T::Number),
                            p("transformation", T::Transformation),
                            p("screen_distance", T::Number),
                        ],
                    )?;
                    let aspect_ratio = self.positive(&a, 0, "aspect_ratio", 1.0, false)?;
                    let screen_distance = self.positive(&a, 2, "screen_distance", 1.0, false)?;
                    Value::Camera(Camera {
                        projection: Projection::Perspective { screen_distance },
                        aspect_ratio,
                        transform: a.transform(1),
                    })
                } else {
                    let a = self.args(
                        "Camera.Orthogonal",
                        &[p("aspect_ratio", T::Number), p("transformation", T::Transformation)],
                    )?;
                    let aspect_ratio = self.positive(&a, 0, "aspect_ratio", 1.0, false)?;
                    Value::Camera(Camera {
                        projection: Projection::Orthogonal,
                        aspect_ratio,
                        transform: a.transform(1),
                    })
                }
            }
            Ty::Renderer => {
                let kind = self.subtype(ty, &["OnOff", "Flat", "PointLight", "PathTracer"])?;
                Value::Renderer(match kind {
                    "OnOff" => {
                        let a = self.args("Renderer.OnOff", &[p("on_color", T::Color), p("off_color", T::Color)])?;
                        Renderer::OnOff { on: a.color(0, Color::WHITE), off: a.color(1, Color::BLACK) }
                    }
                    "Flat" => Renderer::Flat {
                        background: self
                            .args("Renderer.Flat", &[p("background_color", T::Color)])?
                            .color(0, Color::BLACK),
                    },
                    "PointLight" => {
                        let a = self.args(
                            "Renderer.PointLight",
                            &[p("background_color", T::Color), p("ambient_color", T::Color)],
                        )?;
                        Renderer::PointLight {
                            background: a.color(0, Color::BLACK),
                            ambient: a.color(1, Color::gray(1e-3)),
                        }
                    }
                    _ => {
                        let a = self.args(
                            "Renderer.PathTracer",
                            &[
                                p("background_color", T::Color),
                                p("rng", T::Pcg),
                                p("n", T::Number),
                                p("max_depth", T::Number),
                                p("roulette_depth", T::Number),
                                p("nee", T::Number),
                            ],
                        )?;
                        let d = PathTracerSettings::default();
                        Renderer::PathTracer(PathTracerSettings {
                            background: a.color(0, d.background),
                            rng: a.pcg(1),
                            n: self.int(&a, 2, "n", d.n.into(), 1, 1 << 20)? as u32,
                            max_depth: self.int(&a, 3, "max_depth", d.max_depth.into(), 0, 1024)? as u32,
                            roulette_depth: self.int(&a, 4, "roulette_depth", d.roulette_depth.into(), 0, 1024)? as u32,
                            // Extension: `.nee 0` turns next-event estimation off (plain BSDF
                            // sampling, as Raytracer.jl's path tracer); 1, the default, keeps it.
                            nee: self.int(&a, 5, "nee", u64::from(d.nee), 0, 1)? == 1,
                        })
                    }
                })
            }
            Ty::Tracer => {
                let a = self.args("Tracer", &[p("samples_per_side", T::Number), p("rng", T::Pcg)])?;
                let samples_per_side = self.int(&a, 0, "samples_per_side", 0, 0, 1024)? as u32;
                Value::Tracer(Tracer { samples_per_side, rng: a.pcg(1) })
            }
            Ty::Environment => {
                let kind = self.subtype(ty, &["Uniform", "Gradient", "Image"])?;
                Value::Environment(match kind {
                    "Uniform" => Environment::Uniform(
                        self.args("Environment.Uniform", &[p("color", T::Color)])?.color(0, Color::WHITE),
                    ),
                    "Gradient" => {
                        let a = self.args(
                            "Environment.Gradient",
                            &[p("zenith", T::Color), p("horizon", T::Color), p("nadir", T::Color)],
                        )?;
                        Environment::Gradient {
                            zenith: a.color(0, Color::WHITE),
                            horizon: a.color(1, Color::WHITE),
                            nadir: a.color(2, Color::BLACK),
                        }
                    }
                    _ => {
                        let mut a = self.args(
                            "Environment.Image",
                            &[p("image", T::Image), p("intensity", T::Number), p("rotation", T::Number)],
                        )?;
                        let intensity = self.positive(&a, 1, "intensity", 1.0, true)?;
                        let rotation_deg = a.num(2, 0.0);
                        Environment::Image { image: self.pixels(a.take(0))?, intensity, rotation_deg }
                    }
                })
            }
            // Not type words: the lexer never yields them as `Tok::Type`.
            Ty::Number | Ty::Str => {
                return Err(self
                    .err(
                        Span::new(self.lx.last_end, 0),
                        ErrorKind::Syntax,
                        format!("{} has no constructor", ty.article()),
                    )
                    .with_expected("a constructor such as `Color(...)`"))
            }
        })
    }

    /// The pixels of an image argument (`Image(1, 1)`, i.e. one black pixel, when absent).
    fn pixels(&self, arg: Option<(Value, Span)>) -> Res<Arc<HdrImage>> {
        match arg {
            Some((Value::Image(ImageValue::Loaded(img)), _)) => Ok(img),
            Some((Value::Image(ImageValue::Blank { width, height }), s)) => {
                if u64::from(width) * u64::from(height) > MAX_BLANK_TEXTURE_PIXELS {
                    return Err(self
                        .err(
                            s,
                            ErrorKind::BadImageSize,
                            format!("blank image {width}×{height} is too large to use as a texture"),
                        )
                        .with_expected(format!("at most {MAX_BLANK_TEXTURE_PIXELS} pixels")));
                }
                // Bounded above, but still sized by input: a refusal is an error at the argument.
                let img = HdrImage::try_new(width as usize, height as usize)
                    .map_err(|e| self.err(s, ErrorKind::BadImageSize, e.to_string()))?;
                Ok(Arc::new(img))
            }
            _ => Ok(Arc::new(HdrImage::new(1, 1))),
        }
    }

    /// `Image(width, height)` (black), `Image("file")`, or `Image()` (1×1, black).
    fn image_constructor(&mut self) -> Res<Value> {
        self.expect_sym('(', "after Image")?;
        if self.peek()?.tok == Tok::Sym(')') {
            // Every argument has a default: `Image()` is one black pixel.
            self.lx.next()?;
            return Ok(Value::Image(ImageValue::Blank { width: 1, height: 1 }));
        }
        let (first, fs) = self.value()?;
        match first {
            Value::Str(path) => {
                self.expect_sym(')', "after the file name in Image(\"file\")")?;
                Ok(Value::Image(self.load_image(&path, fs)?))
            }
            Value::Number(w) => {
                self.expect_sym(',', "between width and height in Image(width, height)")?;
                let (h, hs) = self.number("the image height")?;
                self.expect_sym(')', "after Image(width, height)")?;
                let side = |v: f64, s: Span, what: &str| -> Res<u32> {
                    if v.fract() != 0.0 || v < 1.0 || v > f64::from(MAX_IMAGE_SIDE) {
                        return Err(self
                            .err(
                                s,
                                ErrorKind::BadImageSize,
                                format!("image {what} {v} is not a whole number from 1 to {MAX_IMAGE_SIDE}"),
                            )
                            .with_expected(format!("a whole number of pixels from 1 to {MAX_IMAGE_SIDE}")));
                    }
                    Ok(v as u32)
                };
                let width = side(w, fs, "width")?;
                let height = side(h, hs, "height")?;
                Ok(Value::Image(ImageValue::Blank { width, height }))
            }
            other => Err(self
                .type_err(fs, format!("Image takes a size or a file name, found {}", other.ty().article()))
                .with_expected("`Image(width, height)` or `Image(\"file\")`")),
        }
    }

    /// `Shape.Mesh(.file "model.obj", .material m, .transformation T, .smooth 1)`: the file
    /// relative to the script's directory, loaded once however many shapes use it.
    fn mesh_constructor(&mut self) -> Res<Value> {
        use Ty as T;
        let mut a = self.args(
            "Shape.Mesh",
            &[
                p("file", T::Str),
                p("material", T::Material),
                p("transformation", T::Transformation),
                p("smooth", T::Number),
            ],
        )?;
        let transform = a.transform(2);
        let smooth = self.int(&a, 3, "smooth", 1, 0, 1)? == 1;
        let material = match a.take(1) {
            Some((Value::Material(m), _)) => m,
            _ => Material::default(),
        };
        let Some((Value::Str(file), span)) = a.take(0) else {
            let span = Span::new(self.lx.last_end, 1);
            return Err(self
                .err(span, ErrorKind::BadArguments, "Shape.Mesh needs a `.file`")
                .with_expected("`Shape.Mesh(.file \"model.obj\", ...)`"));
        };
        let path = Path::new(&file);
        let full: PathBuf = if path.is_absolute() { path.to_path_buf() } else { self.base_dir.join(path) };
        let mesh = match self.meshes.get(&full) {
            Some(m) => m.clone(),
            None => {
                let m = crate::scene::TriangleMesh::load(&full).map_err(|e| {
                    use crate::scene::MeshErrorKind as K;
                    let expected = match e.kind {
                        K::Io { .. } | K::UnknownExtension { .. } => {
                            "a readable .obj or .ply file (relative paths start at the script's folder)"
                        }
                        K::Syntax { .. } => "a well-formed OBJ or PLY file",
                        K::IndexOutOfRange { .. } => "faces that refer only to what the file defines",
                        K::NonFinite { .. } => "finite vertex coordinates",
                        K::NoTriangles { .. } => "at least one triangle of nonzero area",
                        K::TooMany { .. } => "a smaller mesh",
                    };
                    self.err(span, ErrorKind::MeshFile, format!("cannot load mesh: {e}")).with_expected(expected)
                })?;
                let m = Arc::new(m);
                self.meshes.insert(full, m.clone());
                m
            }
        };
        Ok(Value::Shape(ShapeValue::mesh(&file, mesh, transform, material, smooth)))
    }

    /// Loads an image file, relative to the script's directory.
    pub(super) fn load_image(&self, path: &str, span: Span) -> Res<ImageValue> {
        let p = Path::new(path);
        let full: PathBuf = if p.is_absolute() { p.to_path_buf() } else { self.base_dir.join(p) };
        // A directory or a special file is there, not missing: reading it says what it is.
        if !full.exists() {
            return Err(self
                .err(span, ErrorKind::ImageFile, format!("image file {} not found", full.display()))
                .with_expected(
                    "an existing .pfm, .exr, .hdr, .png or .jpg file (relative paths start at the script's folder)",
                ));
        }
        match crate::image::read_image(&full) {
            Ok(img) => {
                if img.width() == 0 || img.height() == 0 {
                    return Err(self
                        .err(span, ErrorKind::BadImageSize, format!("image {} is empty", full.display()))
                        .with_expected("an image with at least one pixel"));
                }
                Ok(ImageValue::Loaded(Arc::new(img)))
            }
            Err(e) => Err(self
                .err(span, ErrorKind::ImageFile, format!("cannot load image: {e}"))
                .with_expected("a readable .pfm, .exr, .hdr, .png or .jpg file")),
        }
    }
}
fn kind_name(k: ShapeKind) -> &'static str {
    match k {
        ShapeKind::Sphere => "Sphere",
        ShapeKind::Plane => "Plane",
        ShapeKind::Cube => "Cube",
        ShapeKind::Cylinder => "Cylinder",
    }
}
