//! Mitsuba 3 XML scene reader (the subset documented in README.md).

use std::path::Path;

use crate::scene::Scene;
use crate::Result;

/// A loaded scene and the warnings met on the way (unknown plugins or parameters),
/// each naming the file and line.
#[derive(Debug)]
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// One line per warning.
    pub warnings: Vec<String>,
}

/// Loads a Mitsuba 3 scene file; `defines` set `$name` parameters (`-D name=value`).
pub fn load(_path: &Path, _defines: &[(String, String)]) -> Result<Loaded> {
    todo!("helper: scene")
}
