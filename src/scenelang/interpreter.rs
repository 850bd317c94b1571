//! The interpreter: reads tokens and evaluates them at once, like Raytracer.jl, so values
//! exist as soon as they are written and the first error in the file stops the run.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use glam::DVec3;

use super::dump;
use super::error::{did_you_mean, ErrorKind, SceneLangError, Span};
use super::lexer::{Command, Lexer, Tok, Token};
use super::math::{self, Lookup, MathValue};
use super::value::{ImageValue, ShapeNode, ShapeValue, Value, PER_USE};
use crate::color::Color;
use crate::scene::{
    renderable_size, renderable_size_rule, Camera, CsgOp, Environment, MaterialId, Renderer, Scene, SceneBuilder,
    Shape, ShapeOrigins, Tracer, MAX_PRIMITIVES,
};

type Res<T> = Result<T, SceneLangError>;

/// Deepest nesting of values (CSG inside CSG, …) before the interpreter refuses: keeps
/// hostile scripts from overflowing the stack.
const MAX_DEPTH: usize = 100;

/// A defined name.
#[derive(Debug, Clone)]
pub struct Var {
    pub value: Value,
    /// Where it was defined: `file:line:col`, or `--vars`.
    pub origin: String,
    /// Defined by `--vars`: the script's own SET of this name is parsed, then ignored.
    pub from_cli: bool,
}

pub type Vars = HashMap<String, Var>;

/// Everything `USING` and `SPAWN` have set so far.
pub struct World {
    pub builder: SceneBuilder,
    /// Primitives spawned so far, CSG leaves counted once per use (at most [`MAX_PRIMITIVES`]).
    pub primitives: u64,
    pub camera: Option<(Camera, Span)>,
    pub image: Option<(ImageValue, Span)>,
    pub renderer: Option<(Renderer, Span)>,
    pub tracer: Option<(Tracer, Span)>,
    pub environment: Option<(Environment, Span)>,
    /// Line and column of each spawned shape's SPAWN item ([`crate::scene::ShapeOrigins`]).
    pub shape_origins: Vec<(u32, u32)>,
}

impl World {
    fn new() -> Self {
        Self {
            builder: SceneBuilder::new(1, 1),
            primitives: 0,
            camera: None,
            image: None,
            renderer: None,
            tracer: None,
            environment: None,
            shape_origins: Vec::new(),
        }
    }
}

pub struct Interp<'a> {
    pub lx: Lexer<'a>,
    pub vars: Vars,
    pub world: World,
    time: f64,
    pub(super) base_dir: &'a Path,
    out: &'a mut dyn Write,
    depth: usize,
    /// Meshes loaded so far, by their path: a file used by several `Shape.Mesh` is read and
    /// stored once.
    pub(super) meshes: std::collections::HashMap<std::path::PathBuf, Arc<crate::scene::TriangleMesh>>,
}

impl<'a> Interp<'a> {
    pub fn new(
        source: &'a str,
        file: &'a str,
        time: f64,
        base_dir: &'a Path,
        out: &'a mut dyn Write,
        vars: Vars,
    ) -> Self {
        Self {
            lx: Lexer::new(source, file),
            vars,
            world: World::new(),
            time,
            base_dir,
            out,
            depth: 0,
            meshes: Default::default(),
        }
    }

    pub(super) fn err(&self, span: Span, kind: ErrorKind, msg: impl Into<String>) -> SceneLangError {
        self.lx.error(span, kind, msg)
    }

    fn origin(&self, span: Span) -> String {
        let (l, c) = self.lx.line_col(span.start);
        format!("{}:{l}:{c}", self.lx.file)
    }

    /// `err` of a value of the wrong type read at `span`, noting where the name is defined
    /// when the value is a name: its SET may be far away, or on the command line (`--vars`),
    /// where the script does not show it.
    pub(super) fn type_err(&self, span: Span, msg: impl Into<String>) -> SceneLangError {
        let e = self.err(span, ErrorKind::WrongType, msg);
        let text = self.lx.source.get(span.start..span.start + span.len).unwrap_or_default();
        match self.vars.get(text) {
            Some(v) if v.from_cli => e.with_note(format!("`{text}` was set on the command line (--vars)")),
            Some(v) => e.with_note(format!("`{text}` was defined at {}", v.origin)),
            None => e,
        }
    }

    pub(super) fn peek(&mut self) -> Res<Token> {
        self.lx.peek().cloned()
    }

    /// Reads what follows an item of a list: `true` after `sep` (another item follows),
    /// `false` after `close` (`None`: the end of the text). `place` completes the message
    /// "expected `,` or `)`…"; `expected` says what would do.
    pub(super) fn separator(&mut self, sep: char, close: Option<char>, place: &str, expected: &str) -> Res<bool> {
        let t = self.lx.next()?;
        match t.tok {
            Tok::Sym(c) if c == sep => Ok(true),
            Tok::Sym(c) if Some(c) == close => Ok(false),
            Tok::Eof if close.is_none() => Ok(false),
            other => {
                let close = close.map_or("the end".to_string(), |c| format!("`{c}`"));
                Err(self
                    .err(
                        t.span,
                        ErrorKind::Syntax,
                        format!("expected `{sep}` or {close}{place}, found {}", other.describe()),
                    )
                    .with_expected(expected))
            }
        }
    }

    pub(super) fn expect_sym(&mut self, c: char, what: &str) -> Res<Span> {
        let t = self.lx.next()?;
        if t.tok == Tok::Sym(c) {
            Ok(t.span)
        } else {
            Err(self
                .err(t.span, ErrorKind::Syntax, format!("expected `{c}` {what}, found {}", t.tok.describe()))
                .with_expected(format!("`{c}`")))
        }
    }

    // ----------------------------------------------------------------- instructions

    /// Runs every instruction of the script.
    pub fn run(&mut self) -> Res<()> {
        loop {
            let t = self.peek()?;
            match t.tok {
                Tok::Eof => return Ok(()),
                Tok::Command(Command::Set) => self.set()?,
                Tok::Command(Command::Unset) => self.unset()?,
                Tok::Command(Command::Spawn) => self.spawn()?,
                Tok::Command(Command::Using) => self.using()?,
                Tok::Command(Command::Dump) => self.dump()?,
                other => {
                    return Err(self
                        .err(t.span, ErrorKind::Syntax, format!("expected an instruction, found {}", other.describe()))
                        .with_expected(
                            "SET, UNSET, SPAWN, USING or DUMP (the previous instruction ended before this)",
                        ))
                }
            }
        }
    }

    fn set(&mut self) -> Res<()> {
        let set = self.lx.next()?;
        let mut count = 0;
        loop {
            let t = self.peek()?;
            let Tok::Ident(name) = t.tok else { break };
            self.lx.next()?;
            // Checked before the value is read: the name comes first in the file.
            let from_cli = match self.vars.get(&name) {
                Some(v) if v.from_cli => true,
                Some(v) => {
                    return Err(self
                        .err(t.span, ErrorKind::RedefinedName, format!("`{name}` is already defined"))
                        .with_expected(format!("a new name, or `UNSET {name}` before setting it again"))
                        .with_note(format!("`{name}` was defined at {}", v.origin)))
                }
                None => false,
            };
            let (value, _) = self.value()?;
            count += 1;
            // A name given on the command line wins: the script's value is parsed, then ignored.
            if !from_cli {
                let origin = self.origin(t.span);
                self.vars.insert(name, Var { value, origin, from_cli: false });
            }
        }
        if count == 0 {
            let t = self.peek()?;
            return Err(self
                .err(t.span, ErrorKind::Syntax, format!("expected a name after SET, found {}", t.tok.describe()))
                .with_expected("`SET name value`")
                .with_note(format!("SET is at {}", self.origin(set.span))));
        }
        Ok(())
    }

    fn unset(&mut self) -> Res<()> {
        self.lx.next()?;
        let mut count = 0;
        loop {
            let t = self.peek()?;
            let Tok::Ident(name) = t.tok else { break };
            self.lx.next()?;
            if self.vars.remove(&name).is_none() {
                return Err(self.undefined(&name, t.span));
            }
            count += 1;
        }
        if count == 0 {
            let t = self.peek()?;
            return Err(self
                .err(t.span, ErrorKind::Syntax, format!("expected a name after UNSET, found {}", t.tok.describe()))
                .with_expected("`UNSET name ...`"));
        }
        Ok(())
    }

    fn undefined(&self, name: &str, span: Span) -> SceneLangError {
        let mut e = self
            .err(span, ErrorKind::UndefinedName, format!("undefined identifier `{name}`"))
            .with_expected("a name defined with SET (or --vars) and not UNSET");
        if let Some(s) = did_you_mean(name, self.vars.keys().map(String::as_str)) {
            e = e.with_note(format!("did you mean `{s}`?"));
        }
        e
    }

    fn spawn(&mut self) -> Res<()> {
        let spawn = self.lx.next()?;
        let mut count = 0;
        loop {
            let t = self.peek()?;
            let continues = matches!(
                t.tok,
                Tok::Ident(_)
                    | Tok::Type(_)
                    | Tok::Command(Command::Unite | Command::Intersect | Command::Diff | Command::Fuse)
            );
            if !continues {
                break;
            }
            let (v, span) = self.value()?;
            match v {
                Value::Shape(s) => {
                    // Checked before expanding: a shape of shared names may stand for far
                    // more primitives than memory holds.
                    let total = self.world.primitives.saturating_add(s.size().primitives);
                    if total > MAX_PRIMITIVES {
                        return Err(self
                            .err(
                                span,
                                ErrorKind::TooLarge,
                                format!(
                                    "the scene would hold {total} primitives, more than the limit of {MAX_PRIMITIVES}"
                                ),
                            )
                            .with_expected(format!("at most {MAX_PRIMITIVES} primitives in all"))
                            .with_note(PER_USE));
                    }
                    self.world.primitives = total;
                    let shape = self.place_shape(&s, &mut HashMap::new());
                    self.world.builder.shape(shape);
                    let (line, column) = self.lx.line_col(span.start);
                    let clamp = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
                    self.world.shape_origins.push((clamp(line), clamp(column)));
                }
                Value::Light(l) => {
                    self.world.builder.point_light(l);
                }
                other => {
                    return Err(self
                        .type_err(span, format!("cannot SPAWN {}", other.ty().article()))
                        .with_expected("a Shape or a Light"))
                }
            }
            count += 1;
        }
        if count == 0 {
            let t = self.peek()?;
            return Err(self
                .err(
                    t.span,
                    ErrorKind::Syntax,
                    format!("expected a shape or light after SPAWN, found {}", t.tok.describe()),
                )
                .with_expected("a Shape, a Light, a CSG command or a name bound to one")
                .with_note(format!("SPAWN is at {}", self.origin(spawn.span))));
        }
        Ok(())
    }

    /// Expands a script shape into a model shape, registering its materials. `materials`
    /// remembers the id of each shared primitive, so that a leaf used a million times is
    /// looked up among the scene's materials once.
    fn place_shape(&mut self, s: &ShapeValue, materials: &mut HashMap<*const ShapeNode, MaterialId>) -> Shape {
        match s.node() {
            ShapeNode::Primitive { kind, transform, material } => {
                let builder = &mut self.world.builder;
                let id = *materials.entry(s.key()).or_insert_with(|| builder.material(material.clone()));
                Shape::primitive(*kind, *transform, id)
            }
            ShapeNode::Csg { op, children, transform, .. } => {
                let children = children.iter().map(|c| self.place_shape(c, materials)).collect();
                Shape::csg(*op, children, *transform)
            }
            ShapeNode::Mesh { file, mesh, transform, material, smooth } => {
                let builder = &mut self.world.builder;
                let id = *materials.entry(s.key()).or_insert_with(|| builder.material(material.clone()));
                Shape::mesh(mesh.clone(), file, *transform, id, *smooth)
            }
        }
    }

    fn using(&mut self) -> Res<()> {
        let using = self.lx.next()?;
        let mut count = 0;
        loop {
            let t = self.peek()?;
            if !matches!(t.tok, Tok::Ident(_) | Tok::Type(_) | Tok::Command(Command::Load)) {
                break;
            }
            let (v, span) = self.value()?;
            macro_rules! setting {
                ($field:ident, $val:expr, $name:literal) => {{
                    if let Some((_, first)) = &self.world.$field {
                        return Err(self
                            .err(span, ErrorKind::RepeatedSetting, concat!("the ", $name, " is already set"))
                            .with_expected(concat!("one ", $name, " per script"))
                            .with_note(format!("first set at {}", self.origin(*first))));
                    }
                    self.world.$field = Some(($val, span));
                }};
            }
            match v {
                Value::Camera(c) => setting!(camera, c, "camera"),
                Value::Image(i) => setting!(image, i, "image"),
                Value::Renderer(r) => setting!(renderer, r, "renderer"),
                Value::Tracer(t) => setting!(tracer, t, "tracer"),
                Value::Environment(e) => setting!(environment, e, "environment"),
                other => {
                    return Err(self
                        .type_err(span, format!("cannot use {} as a setting", other.ty().article()))
                        .with_expected(SETTINGS))
                }
            }
            count += 1;
        }
        if count == 0 {
            let t = self.peek()?;
            return Err(self
                .err(t.span, ErrorKind::Syntax, format!("expected a setting after USING, found {}", t.tok.describe()))
                .with_expected(SETTINGS)
                .with_note(format!("USING is at {}", self.origin(using.span))));
        }
        Ok(())
    }

    fn dump(&mut self) -> Res<()> {
        self.lx.next()?;
        let t = self.lx.next()?;
        let text = match &t.tok {
            Tok::Keyword(k) => match dump::section(k, &self.vars, &self.world) {
                Some(text) => text,
                None => {
                    return Err(self
                        .err(t.span, ErrorKind::UnknownKeyword, format!("unknown DUMP section `.{k}`"))
                        .with_expected(format!("one of {}", dump_sections())))
                }
            },
            Tok::Ident(name) => match self.vars.get(name) {
                Some(v) => format!("{name} = {}\n", dump::describe(&v.value)),
                None => return Err(self.undefined(name, t.span)),
            },
            other => {
                return Err(self
                    .err(t.span, ErrorKind::Syntax, format!("expected what to DUMP, found {}", other.describe()))
                    .with_expected(format!("one of {} or a variable name", dump_sections())))
            }
        };
        self.out.write_all(text.as_bytes()).map_err(|e| {
            self.err(t.span, ErrorKind::Io, format!("cannot write DUMP output: {e}")).with_expected("a writable output")
        })
    }

    // ----------------------------------------------------------------- values

    /// Parses one value of any type, including a `*` chain of transformations.
    pub fn value(&mut self) -> Res<(Value, Span)> {
        let (v, span) = self.value_no_chain()?;
        let Value::Transformation(mut tr) = v else { return Ok((v, span)) };
        let mut span = span;
        while self.peek()?.tok == Tok::Sym('*') {
            let star = self.lx.next()?;
            let (w, ws) = self.value_no_chain()?;
            let Value::Transformation(w) = w else {
                return Err(self
                    .type_err(ws, format!("cannot multiply a Transformation by {}", w.ty().article()))
                    .with_expected("a Transformation after `*`"));
            };
            tr = self.checked(Ok(tr * w), star.span.to(ws))?;
            span = span.to(ws);
        }
        Ok((Value::Transformation(tr), span))
    }

    /// One value without a following `*` chain (an operand of a chain is one of these).
    fn value_no_chain(&mut self) -> Res<(Value, Span)> {
        let t = self.peek()?;
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self
                .err(t.span, ErrorKind::TooDeep, format!("values nested deeper than {MAX_DEPTH} levels"))
                .with_expected("a flatter script (SET intermediate values)"));
        }
        let r = self.value_inner(t);
        self.depth -= 1;
        r
    }

    fn value_inner(&mut self, t: Token) -> Res<(Value, Span)> {
        let start = t.span;
        let v = match t.tok {
            Tok::Number(n) => {
                self.lx.next()?;
                Value::Number(n)
            }
            Tok::Str(s) => {
                self.lx.next()?;
                Value::Str(s)
            }
            Tok::Math { text, content_start } => {
                self.lx.next()?;
                self.math(&text, content_start)?
            }
            Tok::Ident(name) => {
                self.lx.next()?;
                match self.vars.get(&name) {
                    Some(v) => v.value.clone(),
                    None => return Err(self.undefined(&name, t.span)),
                }
            }
            Tok::Sym('<') => {
                self.lx.next()?;
                let [r, g, b] = self.triple('>', "colour")?;
                Value::Color(Color::new(r, g, b))
            }
            Tok::Sym('{') => {
                self.lx.next()?;
                let [x, y, z] = self.triple('}', "point")?;
                Value::Point(DVec3::new(x, y, z))
            }
            Tok::Sym('[') => {
                self.lx.next()?;
                Value::List(self.number_list(']')?)
            }
            Tok::Command(c) => {
                self.lx.next()?;
                match c {
                    Command::Time => Value::Number(self.time),
                    Command::Scale => self.scale(t.span)?,
                    Command::Translate => self.translate(t.span)?,
                    Command::Rotate => self.rotate()?,
                    Command::Unite => self.csg(CsgOp::Unite, t.span)?,
                    Command::Intersect => self.csg(CsgOp::Intersect, t.span)?,
                    Command::Diff => self.csg(CsgOp::Diff, t.span)?,
                    Command::Fuse => self.csg(CsgOp::Fuse, t.span)?,
                    Command::Load => {
                        let (v, s) = self.value()?;
                        let Value::Str(path) = v else {
                            return Err(self
                                .type_err(s, format!("LOAD takes a file name, found {}", v.ty().article()))
                                .with_expected("a string, as in `LOAD \"sky.hdr\"`"));
                        };
                        Value::Image(self.load_image(&path, s)?)
                    }
                    Command::Set | Command::Unset | Command::Spawn | Command::Using | Command::Dump => {
                        return Err(self
                            .err(
                                t.span,
                                ErrorKind::Syntax,
                                format!("expected a value, found the instruction {}", c.name()),
                            )
                            .with_expected("a value: a number, string, colour, point, constructor or name"))
                    }
                }
            }
            Tok::Type(ty) => {
                self.lx.next()?;
                self.constructor(ty)?
            }
            other => return Err(self
                .err(t.span, ErrorKind::Syntax, format!("expected a value, found {}", other.describe()))
                .with_expected(
                    "a value: a number, string, `<r, g, b>`, `{x, y, z}`, `[list]`, `$expr$`, a constructor or a name",
                )),
        };
        let end = Span::new(self.lx.last_end, 0);
        Ok((v, Span::new(start.start, end.start.saturating_sub(start.start).max(1))))
    }

    fn math(&mut self, text: &str, content_start: usize) -> Res<Value> {
        let vars = &self.vars;
        let lookup = |name: &str| match vars.get(name).map(|v| &v.value) {
            Some(Value::Number(n)) => Lookup::Value(MathValue::Num(*n)),
            Some(Value::Color(c)) => Lookup::Value(MathValue::Color(*c)),
            Some(Value::Point(p)) => Lookup::Value(MathValue::Point(*p)),
            Some(other) => Lookup::WrongType(other.ty()),
            None => Lookup::Undefined,
        };
        match math::evaluate(text, content_start, self.time, &lookup) {
            Ok(MathValue::Num(n)) => Ok(Value::Number(n)),
            Ok(MathValue::Color(c)) => Ok(Value::Color(c)),
            Ok(MathValue::Point(p)) => Ok(Value::Point(p)),
            Err(e) => {
                let out = self.err(e.span, e.kind, e.message);
                Err(match e.expected {
                    Some(x) => out.with_expected(x),
                    None => out,
                })
            }
        }
    }

    /// A number value (literal, name, TIME or expression).
    pub(super) fn number(&mut self, what: &str) -> Res<(f64, Span)> {
        let (v, s) = self.value()?;
        match v {
            Value::Number(n) => Ok((n, s)),
            other => Err(self
                .type_err(s, format!("expected a number for {what}, found {}", other.ty().article()))
                .with_expected("a number")),
        }
    }

    fn triple(&mut self, close: char, what: &str) -> Res<[f64; 3]> {
        let mut out = [0.0; 3];
        for (i, slot) in out.iter_mut().enumerate() {
            if i > 0 {
                self.expect_sym(',', &format!("between the components of a {what}"))?;
            }
            *slot = self.number(&format!("a {what} component"))?.0;
        }
        self.expect_sym(close, &format!("to close the {what}"))?;
        Ok(out)
    }

    pub(super) fn number_list(&mut self, close: char) -> Res<Arc<[f64]>> {
        let mut out = vec![self.number("a list element")?.0];
        while self.separator(',', Some(close), " in a list", &format!("`,` or `{close}`"))? {
            out.push(self.number("a list element")?.0);
        }
        Ok(out.into())
    }

    // ----------------------------------------------------------------- the result

    /// Checks that every setting was given and assembles the scene.
    pub fn finish(mut self) -> Res<Scene> {
        let end = Span::new(self.lx.source.trim_end().len().saturating_sub(1), 1);
        let missing = |what: &str, example: &str| {
            self.err(end, ErrorKind::MissingSetting, format!("the script never sets the {what}"))
                .with_expected(format!("a `USING {example}` instruction"))
        };
        let Some((camera, _)) = self.world.camera else { return Err(missing("camera", "Camera.Perspective(...)")) };
        let Some((image, image_span)) = &self.world.image else { return Err(missing("image", "Image(width, height)")) };
        let Some((renderer, _)) = &self.world.renderer else {
            return Err(missing("renderer", "Renderer.PathTracer(...)"));
        };
        let Some((tracer, _)) = self.world.tracer else { return Err(missing("tracer", "Tracer(...)")) };
        let (width, height) = image.size();
        if !renderable_size(width, height) {
            return Err(self
                .err(*image_span, ErrorKind::BadImageSize, format!("image size {width}×{height} cannot be rendered"))
                .with_expected(renderable_size_rule()));
        }
        let renderer = renderer.clone();
        let environment = self.world.environment.take().map(|(e, _)| e);
        // Moved, not copied: the shapes may be millions of primitives.
        let builder = std::mem::replace(&mut self.world.builder, SceneBuilder::new(1, 1));
        let mut scene = builder.into_scene().map_err(|e| {
            self.err(end, ErrorKind::InvalidScene, format!("invalid scene: {e}")).with_expected("a valid scene")
        })?;
        scene.width = width;
        scene.height = height;
        scene.camera = camera;
        scene.renderer = renderer;
        scene.tracer = tracer;
        scene.environment = environment;
        scene.origins = ShapeOrigins::new(self.lx.file, std::mem::take(&mut self.world.shape_origins));
        scene.validate().map_err(|e| {
            self.err(end, ErrorKind::InvalidScene, format!("invalid scene: {e}")).with_expected("a valid scene")
        })?;
        Ok(scene)
    }

    /// Reads `--vars` text: `name value, name value, ...` with values in SET syntax.
    pub fn cli_vars(&mut self) -> Res<()> {
        if self.peek()?.tok == Tok::Eof {
            return Ok(());
        }
        loop {
            let t = self.lx.next()?;
            let Tok::Ident(name) = t.tok else {
                return Err(self
                    .err(t.span, ErrorKind::Syntax, format!("expected a variable name, found {}", t.tok.describe()))
                    .with_expected("`name value, name value, ...`"));
            };
            let (value, _) = self.value()?;
            self.vars.insert(name, Var { value, origin: "--vars".into(), from_cli: true });
            if !self.separator(',', None, "", "`,` between `name value` pairs")? {
                return Ok(());
            }
        }
    }
}

/// What USING takes.
const SETTINGS: &str = "a Camera, an Image, a Renderer, a Tracer or an Environment";

/// DUMP's sections as a script writes them (".camera .image …").
fn dump_sections() -> String {
    dump::SECTIONS.map(|s| format!(".{s}")).join(" ")
}
