//! Assembly of WGSL programs from the modules in `shaders/`.
//!
//! WGSL has no `#include` and no conditional compilation, yet a renderer wants one shader
//! file per concern and kernels that only contain what a scene uses (no CSG code for a
//! scene without CSG: smaller, faster to compile, fewer registers). The scheme, kept small:
//!
//! - A module is one `.wgsl` file, named by its file stem unless it says `// #provides NAME`.
//! - `// #requires A B …` lists modules that must come before it; [`ShaderLibrary::assemble`]
//!   concatenates the roots and everything they require, dependencies first, once each.
//! - `// #if FEATURE`, `// #if !FEATURE`, `// #else`, `// #endif` (nestable) keep or drop
//!   lines according to the [`FeatureNames`]. Directives inside a dropped section are
//!   ignored, so `#requires` can itself be conditional.
//! - Every feature named in a directive or a feature set must be one the library declares:
//!   a typo is an error with file and line, not a silently missing feature.
//!
//! [`Assembled::validate`] validates the result with naga (a render does so once per new
//! kernel, on the thread that creates its pipeline); errors are mapped back to the module
//! file and line.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use thiserror::Error;

use super::compute::{validate_wgsl, ComputeKernel, ValidatedModule};
use super::device::{Gpu, GpuError};

/// Errors of the preprocessor and of module resolution, each with its location.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum AssembleError {
    /// A `// #if` or a feature set names a feature the library does not declare (a typo).
    #[error("{file}:{line}: unknown feature {name:?} (known: {known})")]
    UnknownFeature {
        /// The module's file, or `<feature set>` when the feature set passed to
        /// [`ShaderLibrary::assemble`] names it.
        file: String,
        /// 1-based line of the `// #if`; 0 for a feature set.
        line: usize,
        /// The unknown feature.
        name: String,
        /// The declared features, comma-separated.
        known: String,
    },
    /// A malformed directive: an unknown `// #word`, an `// #else` or `// #endif` without its
    /// `// #if`, a second `// #else`, a bad `// #if` argument, or a `// #provides` that is
    /// empty, repeated or inside `// #if`.
    #[error("{file}:{line}: {message}")]
    Directive {
        /// The module's file.
        file: String,
        /// 1-based line of the directive.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The file ends inside a `// #if` section.
    #[error("{file}: `// #if` opened at line {line} has no `// #endif`")]
    Unclosed {
        /// The module's file.
        file: String,
        /// 1-based line of the innermost `// #if` left open.
        line: usize,
    },
    /// A root or a `// #requires` names a module the library does not hold.
    #[error("module {name:?} required by {required_by} is not in the shader library")]
    MissingModule {
        /// The missing module's name.
        name: String,
        /// The requiring module as `name (file)`, or `the caller` for a root.
        required_by: String,
    },
    /// Modules require each other in a loop; holds the chain, `a -> b -> a`.
    #[error("modules require each other in a cycle: {0}")]
    Cycle(String),
    /// Two files provide a module of the same name (file stem or `// #provides`).
    #[error("module {name:?} is provided by both {first} and {second}")]
    Duplicate {
        /// The module name both provide.
        name: String,
        /// The file added first.
        first: String,
        /// The file whose addition was refused.
        second: String,
    },
}

/// The names of the `// #if` sections a kernel is assembled with (e.g. `CSG`, `ENV_IMAGE`);
/// [`crate::gpu::features::FeatureSet`] is the scene-level description they are derived from.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FeatureNames(BTreeSet<String>);

impl FeatureNames {
    /// No features: every `// #if NAME` section dropped, every `// #if !NAME` kept.
    pub fn new() -> Self {
        Self::default()
    }
    /// Builder form of [`Self::insert`].
    pub fn with(mut self, feature: &str) -> Self {
        self.insert(feature);
        self
    }
    /// Turns `feature` on (a no-op if it already is); whether the library declares it is
    /// checked only at assembly.
    pub fn insert(&mut self, feature: &str) {
        self.0.insert(feature.to_string());
    }
    /// Whether `feature` is on, i.e. its `// #if` sections are kept.
    pub fn contains(&self, feature: &str) -> bool {
        self.0.contains(feature)
    }
    /// The features that are on, in sorted order.
    pub fn iter(&self) -> impl Iterator<Item = &str> {
        self.0.iter().map(String::as_str)
    }
}

impl<'a> FromIterator<&'a str> for FeatureNames {
    fn from_iter<I: IntoIterator<Item = &'a str>>(iter: I) -> Self {
        Self(iter.into_iter().map(str::to_string).collect())
    }
}

impl fmt::Display for FeatureNames {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return f.write_str("(none)");
        }
        f.write_str(&self.iter().collect::<Vec<_>>().join(","))
    }
}

/// One kept line of a module after preprocessing.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceLine {
    /// 1-based line number in the module's file.
    pub line: usize,
    /// The line as written, without its line ending.
    pub text: String,
}

/// A module after preprocessing: kept lines and its (kept) `#requires`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Preprocessed {
    /// The name given by `// #provides NAME`, if the module has one (else its file stem names it).
    pub provides: Option<String>,
    /// Module names from the `// #requires` lines in kept sections, in order of appearance.
    pub requires: Vec<String>,
    /// The kept lines that are not directives, in file order.
    pub lines: Vec<SourceLine>,
}

fn directive(line: &str) -> Option<(&str, &str)> {
    let rest = line.trim().strip_prefix("//")?.trim_start().strip_prefix('#')?;
    let (word, arg) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
    Some((word, arg.trim()))
}

/// Runs the conditional-section preprocessor over one file (see the module docs).
///
/// ```
/// use lumen::gpu::{preprocess, FeatureNames};
/// let known = ["csg".to_string()].into_iter().collect();
/// let src = "a\n// #if csg\nb\n// #else\nc\n// #endif\n";
/// let with: Vec<String> = preprocess("x.wgsl", src, &FeatureNames::new().with("csg"), &known).unwrap()
///     .lines.into_iter().map(|l| l.text).collect();
/// assert_eq!(with, ["a", "b"]);
/// ```
pub fn preprocess(
    file: &str,
    text: &str,
    features: &FeatureNames,
    known: &BTreeSet<String>,
) -> Result<Preprocessed, AssembleError> {
    // One frame per open `#if`: (line it opened on, its condition, whether `#else` was seen,
    // whether the enclosing context was active).
    struct Frame {
        line: usize,
        cond: bool,
        in_else: bool,
        parent_active: bool,
    }
    let mut stack: Vec<Frame> = Vec::new();
    let mut out = Preprocessed { provides: None, requires: Vec::new(), lines: Vec::new() };
    let err = |line: usize, message: String| AssembleError::Directive { file: file.into(), line, message };
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let active = stack.last().is_none_or(|f| f.parent_active && (f.cond != f.in_else));
        let Some((word, arg)) = directive(raw) else {
            if active {
                out.lines.push(SourceLine { line, text: raw.to_string() });
            }
            continue;
        };
        match word {
            "if" => {
                let (negate, name) = match arg.strip_prefix('!') {
                    Some(n) => (true, n.trim()),
                    None => (false, arg),
                };
                if name.is_empty() || name.contains(char::is_whitespace) {
                    return Err(err(line, format!("`// #if` takes one feature name or `!name`, got {arg:?}")));
                }
                if !known.contains(name) {
                    return Err(AssembleError::UnknownFeature {
                        file: file.into(),
                        line,
                        name: name.into(),
                        known: known.iter().cloned().collect::<Vec<_>>().join(", "),
                    });
                }
                stack.push(Frame {
                    line,
                    cond: features.contains(name) != negate,
                    in_else: false,
                    parent_active: active,
                });
            }
            "else" => match stack.last_mut() {
                Some(f) if !f.in_else => f.in_else = true,
                Some(_) => return Err(err(line, "second `// #else` for the same `// #if`".into())),
                None => return Err(err(line, "`// #else` without `// #if`".into())),
            },
            "endif" => {
                if stack.pop().is_none() {
                    return Err(err(line, "`// #endif` without `// #if`".into()));
                }
            }
            "provides" if active => {
                if stack.is_empty() && out.provides.is_none() && !arg.is_empty() && !arg.contains(char::is_whitespace) {
                    out.provides = Some(arg.to_string());
                } else {
                    return Err(err(line, "`// #provides NAME` must appear once, outside `// #if`".into()));
                }
            }
            "requires" if active => out.requires.extend(arg.split_whitespace().map(str::to_string)),
            "provides" | "requires" => {}
            other => {
                return Err(err(
                    line,
                    format!("unknown directive `// #{other}` (known: if, else, endif, provides, requires)"),
                ))
            }
        }
    }
    if let Some(f) = stack.last() {
        return Err(AssembleError::Unclosed { file: file.into(), line: f.line });
    }
    Ok(out)
}

/// The WGSL modules a program can be assembled from, and the features they may test.
#[derive(Debug, Clone, Default)]
pub struct ShaderLibrary {
    known: BTreeSet<String>,
    /// Module name → (file name, source).
    modules: BTreeMap<String, (String, String)>,
}

/// An assembled program: WGSL source plus where each of its lines came from.
#[derive(Debug, Clone)]
pub struct Assembled {
    /// The WGSL program: each module's kept lines after a `// ---- module NAME (FILE) ----`
    /// header line, dependencies first.
    pub source: String,
    /// Modules in the order they were concatenated.
    pub modules: Vec<String>,
    /// For each line of `source` (0-based), its file and 1-based line.
    origins: Vec<(String, usize)>,
}

impl ShaderLibrary {
    /// An empty library whose modules may test `known_features`.
    pub fn new(known_features: &[&str]) -> Self {
        Self { known: known_features.iter().map(|s| s.to_string()).collect(), modules: BTreeMap::new() }
    }

    /// Adds the module in `file` (a name for messages, e.g. `"shaders/csg.wgsl"`). Its name
    /// is its `// #provides` or else the file stem. Directive errors are reported here, for
    /// every branch (all features off), and again at assembly for the branch taken.
    pub fn add(&mut self, file: &str, source: &str) -> Result<(), AssembleError> {
        let pre = preprocess(file, source, &FeatureNames::new(), &self.known)?;
        let stem = std::path::Path::new(file).file_stem().and_then(|s| s.to_str()).unwrap_or(file);
        let name = pre.provides.unwrap_or_else(|| stem.to_string());
        if let Some((first, _)) = self.modules.get(&name) {
            return Err(AssembleError::Duplicate { name, first: first.clone(), second: file.into() });
        }
        self.modules.insert(name, (file.into(), source.into()));
        Ok(())
    }

    /// Module names in the library.
    pub fn module_names(&self) -> impl Iterator<Item = &str> {
        self.modules.keys().map(String::as_str)
    }

    /// Concatenates `roots` and their requirements (dependencies first, each once) with the
    /// sections `features` selects.
    ///
    /// ```
    /// use lumen::gpu::{FeatureNames, ShaderLibrary};
    /// let mut lib = ShaderLibrary::new(&["double"]);
    /// lib.add("consts.wgsl", "const K: f32 = 2.0;").unwrap();
    /// lib.add("main.wgsl", "// #requires consts\n\
    ///     fn f(x: f32) -> f32 {\n\
    ///     // #if double\n    return K * x;\n// #else\n    return x;\n// #endif\n}").unwrap();
    /// let a = lib.assemble(&["main"], &FeatureNames::new().with("double")).unwrap();
    /// assert_eq!(a.modules, ["consts", "main"]);
    /// assert!(a.source.contains("return K * x;") && !a.source.contains("return x;"));
    /// a.validate().unwrap();
    /// ```
    pub fn assemble(&self, roots: &[&str], features: &FeatureNames) -> Result<Assembled, AssembleError> {
        for f in features.iter() {
            if !self.known.contains(f) {
                return Err(AssembleError::UnknownFeature {
                    file: "<feature set>".into(),
                    line: 0,
                    name: f.into(),
                    known: self.known.iter().cloned().collect::<Vec<_>>().join(", "),
                });
            }
        }
        let mut order: Vec<(String, Preprocessed)> = Vec::new();
        let mut visiting: Vec<String> = Vec::new();
        for root in roots {
            self.visit(root, "the caller", features, &mut visiting, &mut order)?;
        }
        let mut source = String::new();
        let mut origins = Vec::new();
        let mut modules = Vec::new();
        for (name, pre) in order {
            let file = &self.modules[&name].0;
            source.push_str(&format!("// ---- module {name} ({file}) ----\n"));
            origins.push((file.clone(), 0));
            for l in pre.lines {
                source.push_str(&l.text);
                source.push('\n');
                origins.push((file.clone(), l.line));
            }
            modules.push(name);
        }
        Ok(Assembled { source, modules, origins })
    }

    fn visit(
        &self,
        name: &str,
        required_by: &str,
        features: &FeatureNames,
        visiting: &mut Vec<String>,
        order: &mut Vec<(String, Preprocessed)>,
    ) -> Result<(), AssembleError> {
        if order.iter().any(|(n, _)| n == name) {
            return Ok(());
        }
        if let Some(pos) = visiting.iter().position(|n| n == name) {
            let mut chain = visiting[pos..].to_vec();
            chain.push(name.to_string());
            return Err(AssembleError::Cycle(chain.join(" -> ")));
        }
        let (file, src) = self
            .modules
            .get(name)
            .ok_or_else(|| AssembleError::MissingModule { name: name.into(), required_by: required_by.into() })?;
        let pre = preprocess(file, src, features, &self.known)?;
        visiting.push(name.to_string());
        for dep in &pre.requires {
            self.visit(dep, &format!("{name} ({file})"), features, visiting, order)?;
        }
        visiting.pop();
        order.push((name.to_string(), pre));
        Ok(())
    }
}

impl Assembled {
    /// The module file and 1-based line that assembled line `line` (1-based) came from.
    pub fn origin(&self, line: usize) -> Option<(&str, usize)> {
        let (file, l) = self.origins.get(line.checked_sub(1)?)?;
        Some((file.as_str(), *l))
    }

    /// Validates with naga; an error names the module file and line it points at.
    pub fn validate(&self) -> Result<ValidatedModule, GpuError> {
        validate_wgsl("assembled.wgsl", &self.source).map_err(|e| self.map_error(e))
    }

    /// Validates, then compiles `entry` as a compute kernel labelled `label`.
    pub fn kernel(&self, gpu: &Gpu, label: &str, entry: &str) -> Result<ComputeKernel, GpuError> {
        self.validate()?;
        gpu.compute_kernel(label, &self.source, entry)
    }

    fn map_error(&self, e: GpuError) -> GpuError {
        let GpuError::Shader { label, message } = e else { return e };
        // naga renders locations as `assembled.wgsl:LINE:COL`; name the module line too.
        let origin = message
            .split("assembled.wgsl:")
            .nth(1)
            .and_then(|rest| rest.split(':').next())
            .and_then(|n| n.parse::<usize>().ok())
            .and_then(|n| self.origin(n));
        match origin {
            Some((file, line)) => GpuError::Shader { label: format!("{file}:{line}"), message },
            None => GpuError::Shader { label, message },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn known() -> BTreeSet<String> {
        ["a", "b"].into_iter().map(String::from).collect()
    }

    fn kept(src: &str, features: &[&str]) -> Vec<String> {
        let fs: FeatureNames = features.iter().copied().collect();
        preprocess("t.wgsl", src, &fs, &known()).unwrap().lines.into_iter().map(|l| l.text).collect()
    }

    #[test]
    fn nested_sections_follow_every_combination() {
        let src = "0\n// #if a\n1\n  // #if !b\n2\n  // #else\n3\n  // #endif\n4\n// #else\n5\n// #if b\n6\n// #endif\n// #endif\n7";
        assert_eq!(kept(src, &[]), ["0", "5", "7"]);
        assert_eq!(kept(src, &["b"]), ["0", "5", "6", "7"]);
        assert_eq!(kept(src, &["a"]), ["0", "1", "2", "4", "7"]);
        assert_eq!(kept(src, &["a", "b"]), ["0", "1", "3", "4", "7"]);
    }

    #[test]
    fn kept_lines_keep_their_file_line_numbers() {
        let fs = FeatureNames::new();
        let pre = preprocess("t.wgsl", "x\n// #if a\ny\n// #endif\nz", &fs, &known()).unwrap();
        let lines: Vec<usize> = pre.lines.iter().map(|l| l.line).collect();
        assert_eq!(lines, [1, 5]);
    }

    #[test]
    fn errors_name_file_and_line() {
        let fs = FeatureNames::new();
        let e = |src: &str| preprocess("m.wgsl", src, &fs, &known()).unwrap_err();
        assert_eq!(
            e("x\n// #if csg\n// #endif"),
            AssembleError::UnknownFeature { file: "m.wgsl".into(), line: 2, name: "csg".into(), known: "a, b".into() }
        );
        assert_eq!(e("// #if a\nx\n// #if b\n// #endif"), AssembleError::Unclosed { file: "m.wgsl".into(), line: 1 });
        assert!(matches!(e("x\n// #endif"), AssembleError::Directive { line: 2, .. }));
        assert!(matches!(e("// #else"), AssembleError::Directive { line: 1, .. }));
        assert!(matches!(e("// #if a\n// #else\n// #else\n// #endif"), AssembleError::Directive { line: 3, .. }));
        assert!(matches!(e("// #iff a"), AssembleError::Directive { line: 1, .. }));
        assert!(matches!(e("// #if a b\n// #endif"), AssembleError::Directive { line: 1, .. }));
        // Errors inside dropped sections are still errors: every branch must be well formed.
        assert!(matches!(
            e("// #if a\n// #if nope\n// #endif\n// #endif"),
            AssembleError::UnknownFeature { line: 2, .. }
        ));
        assert!(e("x\n// #endif").to_string().starts_with("m.wgsl:2:"));
    }

    #[test]
    fn requirements_come_first_once_and_may_be_conditional() {
        let mut lib = ShaderLibrary::new(&["a"]);
        lib.add("shaders/base.wgsl", "const BASE: u32 = 1u;").unwrap();
        lib.add("shaders/extra.wgsl", "// #requires base\nconst EXTRA: u32 = BASE + 1u;").unwrap();
        lib.add(
            "shaders/main.wgsl",
            "// #requires base\n// #if a\n// #requires extra\n// #endif\nfn main_value() -> u32 { return BASE; }",
        )
        .unwrap();
        let without = lib.assemble(&["main"], &FeatureNames::new()).unwrap();
        assert_eq!(without.modules, ["base", "main"]);
        let with = lib.assemble(&["main", "base"], &FeatureNames::new().with("a")).unwrap();
        assert_eq!(with.modules, ["base", "extra", "main"]);
        with.validate().unwrap();
        assert!(matches!(
            lib.assemble(&["main"], &FeatureNames::new().with("zzz")),
            Err(AssembleError::UnknownFeature { .. })
        ));
        assert!(matches!(lib.assemble(&["nope"], &FeatureNames::new()), Err(AssembleError::MissingModule { .. })));
    }

    #[test]
    fn cycles_and_duplicates_are_errors() {
        let mut lib = ShaderLibrary::new(&[]);
        lib.add("x.wgsl", "// #requires y").unwrap();
        lib.add("y.wgsl", "// #requires x").unwrap();
        let e = lib.assemble(&["x"], &FeatureNames::new()).unwrap_err();
        assert_eq!(e, AssembleError::Cycle("x -> y -> x".into()));
        assert!(matches!(lib.add("other/x.wgsl", ""), Err(AssembleError::Duplicate { .. })));
        lib.add("z.wgsl", "// #provides w\n").unwrap();
        assert!(lib.module_names().any(|n| n == "w"));
    }

    #[test]
    fn validation_errors_point_at_the_module_line() {
        let mut lib = ShaderLibrary::new(&[]);
        lib.add("shaders/ok.wgsl", "const A: f32 = 1.0;\nconst B: f32 = 2.0;").unwrap();
        lib.add("shaders/bad.wgsl", "// #requires ok\n\nfn f() -> u32 {\n    return A;\n}").unwrap();
        let a = lib.assemble(&["bad"], &FeatureNames::new()).unwrap();
        let err = a.validate().unwrap_err();
        let GpuError::Shader { label, .. } = &err else { panic!("{err}") };
        // naga's first label is the invalid function, which starts on line 3 of bad.wgsl.
        assert_eq!(label, "shaders/bad.wgsl:3");
        // A syntax error points at its own line.
        let mut lib = ShaderLibrary::new(&[]);
        lib.add("shaders/ok.wgsl", "const A: f32 = 1.0;").unwrap();
        lib.add("shaders/typo.wgsl", "// #requires ok\nconst B: f32 = 2.0;\nconst C: f32 = ;").unwrap();
        let err = lib.assemble(&["typo"], &FeatureNames::new()).unwrap().validate().unwrap_err();
        let GpuError::Shader { label, .. } = &err else { panic!("{err}") };
        assert_eq!(label, "shaders/typo.wgsl:3");
    }

    #[test]
    fn feature_sets_compare_by_content() {
        let x: FeatureNames = ["b", "a"].into_iter().collect();
        assert_eq!(x, FeatureNames::new().with("a").with("b"));
        assert_eq!(x.to_string(), "a,b");
        assert_eq!(FeatureNames::new().to_string(), "(none)");
    }
}
