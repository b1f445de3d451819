//! Mitsuba 3 XML scene reader (the subset documented in README.md).
//!
//! The reader walks the document once, in document order, as Mitsuba does:
//! `<default>` declares a `$name` parameter from there on, `<ref>` refers to an
//! object declared earlier, `<include>` reads another file in place. Everything it
//! cannot represent is a warning naming the file and line; everything wrong is an
//! [`Error::Input`] naming the file, line and column.
//!
//! Supported: shapes `obj`, `ply`, `rectangle`, `cube`, `sphere`, `disk` and the
//! radtrace extension `bezier` (a `.bpt` file); BSDFs `diffuse`, `conductor`,
//! `plastic`, `twosided`, `blendbsdf` (rough variants become their smooth
//! counterparts); emitters `point`, `spot` and `area` (inside a shape); sensors
//! `perspective` with `hdrfilm` and a `sampler`.

mod bsdf;
mod document;
mod emitter;
mod parse;
mod properties;
mod sensor;
mod shape;
#[cfg(test)]
mod tests;
mod texture;
mod transform;

use std::path::Path;

use document::Loader;

use crate::error::Error;
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
    /// One line per notice (a Mitsuba 0.6 file upgraded in memory).
    pub notes: Vec<String>,
}

/// Loads a Mitsuba 3 scene file; `defines` set `$name` parameters (`-D name=value`).
///
/// Defines override the scene's `<default>`s; a define the scene neither declares nor
/// uses is an error naming the ones it declares, as Mitsuba 3 refuses it ("Found
/// unused parameters"): a misspelt size would otherwise render the scene's own size,
/// perhaps for minutes.
pub fn load(path: &Path, defines: &[(String, String)]) -> Result<Loaded> {
    load_with(path, None, defines)
}

/// [`load`] of a scene given as text: `path` names it in errors, and files it refers
/// to (meshes, includes) are looked for beside `path`.
pub fn load_str(path: &Path, text: &str, defines: &[(String, String)]) -> Result<Loaded> {
    load_with(path, Some(text), defines)
}

fn load_with(path: &Path, text: Option<&str>, defines: &[(String, String)]) -> Result<Loaded> {
    let mut l = Loader::new(path);
    for (k, v) in defines {
        if k.is_empty() || k.contains('$') {
            return Err(Error::Usage(format!(
                "-D {k}={v}: a parameter name must be non-empty and without '$'"
            )));
        }
        l.params.insert(k.clone(), v.clone());
    }
    match text {
        Some(text) => l.load_text(path, text, true)?,
        None => l.load_file(path, true)?,
    }
    let unused: Vec<&str> = defines
        .iter()
        .map(|(k, _)| k.as_str())
        .filter(|k| !l.declared.contains(*k) && !l.used.borrow().contains(*k))
        .collect();
    if !unused.is_empty() {
        let mut declared: Vec<&str> = l.declared.iter().map(String::as_str).collect();
        declared.sort_unstable();
        let declared = if declared.is_empty() {
            "none".to_string()
        } else {
            declared.join(", ")
        };
        return Err(Error::Usage(format!(
            "{}: -D {}: neither declared by a <default> nor used in the scene (it declares: {declared})",
            path.display(),
            unused.join(", -D ")
        )));
    }
    Ok(Loaded {
        scene: l.scene,
        warnings: l.warnings,
        notes: l.notes,
    })
}
