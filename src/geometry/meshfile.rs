//! Mesh files: Wavefront OBJ and PLY readers, and an OBJ writer.

use std::path::Path;

use crate::geometry::TriMesh;
use crate::Result;

/// Reads an OBJ file as one mesh (materials ignored, as Mitsuba's `obj` does); each
/// face becomes one `Patch::Polygon`.
pub fn read_obj(_path: &Path, _face_normals: bool) -> Result<TriMesh> {
    todo!("helper: geometry")
}

/// Reads a PLY file (ASCII or binary) as one mesh; each face becomes one patch.
pub fn read_ply(_path: &Path, _face_normals: bool) -> Result<TriMesh> {
    todo!("helper: geometry")
}

/// Writes `mesh` as an OBJ file with normals (if any).
pub fn write_obj(_mesh: &TriMesh, _path: &Path) -> Result<()> {
    todo!("helper: geometry")
}
