//! Bicubic Bezier patches (the Newell teapot): evaluation and tessellation.

use glam::Vec3;

/// A bicubic Bezier patch: a 4x4 control net, row by row (`ctrl[4 * i + j]`, row i
/// along v, column j along u).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BezierPatch {
    /// Control points.
    pub ctrl: [Vec3; 16],
    /// True when the surface's normal is to be taken reversed (after `flip_normals`).
    pub flipped: bool,
}

use std::path::Path;

use crate::geometry::TriMesh;
use crate::Result;

impl BezierPatch {
    /// Point and partial derivatives `(p, dp/du, dp/dv)` at `(u, v)` in `[0,1]^2`.
    pub fn eval(&self, _u: f32, _v: f32) -> (Vec3, Vec3, Vec3) {
        todo!("helper: geometry")
    }
}

/// Reads a `.bpt` file (see data/teapot/SOURCE.md for the format).
pub fn read_bpt(_path: &Path) -> Result<Vec<BezierPatch>> {
    todo!("helper: geometry")
}

/// Tessellates `patches` into a mesh with smooth normals and per-vertex (u, v):
/// each patch becomes `coarse x coarse` radiosity patches (`Patch::Bezier`), each
/// of those `fine x fine` quads split into two triangles.
pub fn tessellate(_patches: &[BezierPatch], _coarse: u32, _fine: u32) -> TriMesh {
    todo!("helper: geometry")
}
