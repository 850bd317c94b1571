//! SceneLang, the scene language of Raytracer.jl, with lumen's extensions
//! (specification: `SCENELANG.md`; decisions: the "SceneLang" section of `docs/DESIGN.md`).
//!
//! A script evaluates, instruction by instruction, to a [`Scene`]. Scripts written for
//! Raytracer.jl load unchanged; errors name `file:line:col`, show the line with a caret and
//! say what was expected.
//!
//! ```
//! use lumen::scenelang::{load_str, LoadOptions};
//! let script = r#"
//!     SET red Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.1, 0.1>)))
//!     SPAWN Shape.Sphere(.material red, .transformation TRANSLATE(.X 3) * SCALE $r / 2$)
//!     USING Camera.Perspective(.aspect_ratio $16/9$) Image(160, 90)
//!           Renderer.PathTracer(.n 4) Tracer(.samples_per_side 2)
//! "#;
//! let opts = LoadOptions { time: 0.0, vars: vec!["r 2".into()] };
//! let scene = load_str(script, "inline.sl", std::path::Path::new("."), &opts).unwrap();
//! assert_eq!((scene.width, scene.height, scene.shapes.len()), (160, 90, 1));
//!
//! let err = load_str("SET x <1, 2>", "bad.sl", std::path::Path::new("."), &LoadOptions::default()).unwrap_err();
//! assert_eq!((err.line, err.col), (1, 12));
//! assert!(err.to_string().starts_with("bad.sl:1:12: error:"));
//! ```
//!
//! lumen's choices where Raytracer.jl is silent or lumen extends it:
//! - a CSG node takes its own placement as a trailing keyword:
//!   `UNITE(a, b, .transformation T)` (also INTERSECT, DIFF, FUSE); it applies after the
//!   children's own transformations; CSG needs at least two shapes;
//! - `USING` takes a fifth, optional setting `Environment.Uniform/Gradient/Image(...)`;
//! - `Brdf.Dielectric(.pigment, .ior 1.5)`; `Pigment.Image(.image, .filter "nearest")` where
//!   `.filter` is `"nearest"` (Raytracer.jl's lookup, the default) or `"bilinear"`;
//! - `Environment.Uniform(.color <1,1,1>)`, `Environment.Gradient(.zenith <1,1,1>,
//!   .horizon <1,1,1>, .nadir <0,0,0>)`, `Environment.Image(.image Image(1, 1), .intensity 1,
//!   .rotation 0)` (degrees about z);
//! - a colour where a pigment is expected is short for `Pigment.Uniform` of it;
//! - `Transformation([...])` reads its 16 numbers row by row, and only affine matrices
//!   (last row 0 0 0 1) are supported (Raytracer.jl takes any invertible one);
//! - names share their values, and scripts whose shapes expand beyond
//!   [`crate::scene::MAX_PRIMITIVES`] or [`crate::scene::MAX_CSG_DEPTH`] are refused where
//!   they cross the limit;
//! - `ROTATE(.X a * .Z b)` is the product `ROTATE(.X a) * ROTATE(.Z b)`: the rightmost
//!   rotation acts on points first, like any `*` chain;
//! - math expressions also know `pi`, `TIME`, `sqrt` and `abs`;
//! - `--vars` names win over the script: the script's `SET` of such a name is parsed (so its
//!   errors are still reported) and then ignored;
//! - `DUMP name` prints one variable, and `DUMP.environment` the environment;
//! - `SET a b` copies the value of `b`; `Image()` is one black pixel;
//! - a blank `Image(w, h)` is only a size until used as a texture, so `USING Image(...)`
//!   never allocates pixels.

mod constructors;
mod dump;
mod error;
mod interpreter;
mod lexer;
pub mod math;
mod summary;
mod value;

use std::io::Write;
use std::path::Path;

pub use error::{ErrorKind, SceneLangError, Span};
pub use summary::{MeshSummary, SceneSummary};

use crate::scene::Scene;
use interpreter::{Interp, Vars};

/// How to evaluate a script.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadOptions {
    /// The value of `TIME` (for animations).
    pub time: f64,
    /// Raw `--vars` strings, each `"name value, name value"` with values in SET syntax.
    /// They are read in order (a later one may redefine an earlier name) before the script.
    pub vars: Vec<String>,
}

/// The largest script [`load_file`] reads: far above any scene within
/// [`crate::scene::MAX_PRIMITIVES`] (10,000 spheres take 0.7 MB), far below what an endless
/// source (`/dev/zero`, a runaway pipe) would fill memory with before failing.
pub const MAX_SCRIPT_BYTES: u64 = 1 << 30;

/// Loads the script at `path` (a file, or a pipe such as `<(...)`); DUMP output goes to
/// stdout.
pub fn load_file(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneLangError> {
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    load_file_with_output(path, opts, &mut lock)
}

/// [`load_file`] with DUMP output written to `out` (`std::io::sink()` for a load that only
/// checks the script, such as each frame of an animation before the first is rendered).
pub fn load_file_with_output(path: &Path, opts: &LoadOptions, out: &mut dyn Write) -> Result<Scene, SceneLangError> {
    use std::io::Read;
    let name = path.display().to_string();
    let fail = |why: String| SceneLangError::whole_file(&name, ErrorKind::Io, format!("cannot read script: {why}"));
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_SCRIPT_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| fail(e.to_string()))?;
    if bytes.len() as u64 > MAX_SCRIPT_BYTES {
        return Err(fail(format!("it is larger than {} MiB", MAX_SCRIPT_BYTES >> 20)));
    }
    let source = String::from_utf8(bytes).map_err(|e| not_utf8(e.as_bytes(), e.utf8_error().valid_up_to(), &name))?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_str_with_output(&source, &name, base, opts, out)
}

/// The error for a script whose bytes stop being UTF-8 at `at`, located there (line and
/// column as an editor counts them, after a byte-order mark) with the line up to that byte:
/// a script saved as Latin-1 or UTF-16 is found, not just refused.
fn not_utf8(bytes: &[u8], at: usize, name: &str) -> SceneLangError {
    // Everything before `at` is valid UTF-8.
    let text = without_bom(std::str::from_utf8(&bytes[..at]).unwrap_or_default());
    let shown: Vec<String> = bytes[at..].iter().take(4).map(|b| format!("0x{b:02X}")).collect();
    SceneLangError::at(
        text,
        name,
        Span::new(text.len(), 1),
        ErrorKind::Encoding,
        format!(
            "the script is not UTF-8 text: {} {} here",
            if shown.len() == 1 { "byte" } else { "bytes" },
            shown.join(" ")
        ),
    )
    .with_expected("UTF-8 text (save the script as UTF-8; Latin-1 and UTF-16 files are not read)")
}

/// `source` without a leading byte-order mark (Windows editors write one): it is not part
/// of the script, and lines and columns count from after it, as an editor shows them.
fn without_bom(source: &str) -> &str {
    source.strip_prefix('\u{feff}').unwrap_or(source)
}

/// Loads a script from a string. `name` labels diagnostics; relative image paths resolve
/// against `base_dir`. DUMP output goes to stdout.
pub fn load_str(source: &str, name: &str, base_dir: &Path, opts: &LoadOptions) -> Result<Scene, SceneLangError> {
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    load_str_with_output(source, name, base_dir, opts, &mut lock)
}

/// [`load_str`] with DUMP output written to `out`.
pub fn load_str_with_output(
    source: &str,
    name: &str,
    base_dir: &Path,
    opts: &LoadOptions,
    out: &mut dyn Write,
) -> Result<Scene, SceneLangError> {
    let mut vars = Vars::new();
    for v in &opts.vars {
        let mut sink = std::io::sink();
        let mut it = Interp::new(v, "--vars", opts.time, base_dir, &mut sink, vars);
        it.cli_vars()?;
        vars = std::mem::take(&mut it.vars);
    }
    let source = without_bom(source);
    let mut it = Interp::new(source, name, opts.time, base_dir, out, vars);
    it.run()?;
    it.finish()
}
