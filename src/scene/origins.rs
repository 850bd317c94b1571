//! Where a scene's shapes were written, for messages about a shape that only a later
//! stage refuses (the GPU packer's f32 range), which a script's interpreter cannot foresee:
//! the message can then point at the script's line, as SceneLang's own errors do.

/// The script position of each top-level shape ([`super::Scene::shapes`], spawn order): one
/// file and a 1-based line and column per shape (8 bytes a shape, so that a script of
/// millions of SPAWN items pays little). Empty for a scene built in code.
///
/// ```
/// use lumen::scene::ShapeOrigins;
/// let o = ShapeOrigins::new("room.sl", vec![(3, 5), (4, 5)]);
/// assert_eq!(o.of(1).as_deref(), Some("room.sl:4:5"));
/// assert_eq!(o.of(2), None);
/// ```
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ShapeOrigins {
    file: String,
    at: Vec<(u32, u32)>,
}

impl ShapeOrigins {
    /// Shape i was written at `at[i]` (line, column) of `file`.
    pub fn new(file: impl Into<String>, at: Vec<(u32, u32)>) -> Self {
        Self { file: file.into(), at }
    }

    /// `file:line:column` of shape `shape`, if known.
    pub fn of(&self, shape: usize) -> Option<String> {
        self.at.get(shape).map(|(line, column)| format!("{}:{line}:{column}", self.file))
    }
}
