//! The solution file: the view-independent result of pass 1, saved once and reused
//! for any view (`radtrace solve`, `radtrace render --solution`).

use std::path::Path;

use crate::radiosity::Solution;
use crate::scene::Scene;
use crate::Result;

/// A fingerprint of everything in `scene` that the radiosity solution depends on
/// (geometry, materials, lights), so that a file made for another scene is refused.
pub fn scene_fingerprint(_scene: &Scene) -> u64 {
    todo!("helper: solution file")
}

/// Saves `solution` (computed for `scene`) to `path`, atomically.
pub fn save(_solution: &Solution, _scene: &Scene, _path: &Path) -> Result<()> {
    todo!("helper: solution file")
}

/// Loads a solution for `scene` from `path`: refuses a file that is not a solution
/// file, of another version, damaged (checksum), or made for another scene.
pub fn load(_path: &Path, _scene: &Scene) -> Result<Solution> {
    todo!("helper: solution file")
}
