//! What the OBJ and PLY readers share: the mesh as read from a file ([`RawMesh`]),
//! and building the [`TriMesh`] from it: one [`Patch::Polygon`] per input face,
//! fan-triangulated, and the shading normals.

use std::path::Path;

use glam::{Vec2, Vec3};

use crate::geometry::{Patch, TriMesh};
use crate::{Error, Result};

/// A mesh as read from a file, before triangulation and normals.
pub(super) struct RawMesh {
    pub(super) positions: Vec<Vec3>,
    /// Per-vertex normals given by the file (`None`: compute one).
    pub(super) normals: Vec<Option<Vec3>>,
    /// Per-vertex uvs, or empty.
    pub(super) uvs: Vec<Vec2>,
    /// Faces as vertex indices (each at least 3, all in range).
    pub(super) faces: Vec<Vec<u32>>,
}

/// Fan-triangulates the faces (one patch each) and sets up the normals.
pub(super) fn build_mesh(path: &Path, raw: RawMesh, face_normals: bool) -> Result<TriMesh> {
    if raw.faces.is_empty() {
        return Err(Error::input(path, None, "no faces"));
    }
    let ntri: usize = raw.faces.iter().map(|f| f.len() - 2).sum();
    let mut mesh = TriMesh {
        positions: raw.positions,
        uvs: raw.uvs,
        ..TriMesh::default()
    };
    mesh.indices.reserve(ntri);
    mesh.tri_patch.reserve(ntri);
    mesh.patches.reserve(raw.faces.len());
    for (p, f) in raw.faces.into_iter().enumerate() {
        for i in 1..f.len() - 1 {
            mesh.indices.push([f[0], f[i], f[i + 1]]);
            mesh.tri_patch.push(p as u32);
        }
        mesh.patches.push(Patch::Polygon(f));
    }
    if !face_normals {
        let given: Vec<Option<Vec3>> = raw
            .normals
            .iter()
            .map(|n| n.and_then(|n| n.try_normalize()))
            .collect();
        let smooth = if given.iter().all(Option::is_some) {
            Vec::new()
        } else {
            smooth_normals(&mesh)
        };
        mesh.normals = given
            .iter()
            .enumerate()
            .map(|(i, n)| n.unwrap_or_else(|| smooth[i]))
            .collect();
    }
    mesh.validate().map_err(|m| Error::input(path, None, m))?;
    Ok(mesh)
}

/// Angle-weighted vertex normals from the triangles' normals (as Mitsuba computes
/// them for meshes without normals). Vertices touched only by zero-area triangles
/// get `+z`.
fn smooth_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; mesh.positions.len()];
    for t in 0..mesh.indices.len() {
        let idx = mesh.indices[t];
        let p = mesh.triangle(t);
        let Some(fnorm) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let e1 = p[(k + 1) % 3] - p[k];
            let e2 = p[(k + 2) % 3] - p[k];
            let angle = e1.cross(e2).length().atan2(e1.dot(e2));
            if angle.is_finite() {
                acc[idx[k] as usize] += fnorm * angle;
            }
        }
    }
    acc.into_iter().map(|n| n.normalize_or(Vec3::Z)).collect()
}

pub(super) fn vertex_count_error(path: &Path) -> Error {
    Error::input(path, None, "more than 2^32 - 1 vertices")
}

#[cfg(test)]
pub(super) mod tests {
    //! Also the helpers the OBJ and PLY readers' tests share.

    use std::path::PathBuf;

    use super::*;
    use crate::geometry::obj::read_obj;

    pub(in crate::geometry) fn write(
        dir: &tempfile::TempDir,
        name: &str,
        bytes: impl AsRef<[u8]>,
    ) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// Checks the things every cube [0,1]^3 made of 6 quads must satisfy.
    pub(in crate::geometry) fn check_cube(m: &TriMesh) {
        m.validate().unwrap();
        assert_eq!(m.patches.len(), 6);
        assert_eq!(m.triangle_count(), 12);
        assert!((m.area() - 6.0).abs() < 1e-6);
        assert_eq!(m.bounds(), Some((Vec3::ZERO, Vec3::ONE)));
        let centre = Vec3::splat(0.5);
        for t in 0..12 {
            let [a, b, c] = m.triangle(t);
            let g = (b - a).cross(c - a);
            // Counter-clockwise seen from outside.
            assert!(g.dot(a - centre) > 0.0, "triangle {t}");
            assert_eq!(m.tri_patch[t] as usize, t / 2);
        }
    }

    #[test]
    fn smooth_normals_are_angle_weighted() {
        // A vertex shared by a big and a small face at right angles, where the
        // small face is split in two triangles; angle weighting sees 90 degrees
        // from each face, whatever the triangulation.
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            "l.obj",
            "v 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nv 0 0 -1\nv 0 10 -1\nv 0 5 -1\n\
             f 1 2 3 4\nf 1 4 6 7 5\n",
        );
        let m = read_obj(&p, false).unwrap();
        assert_eq!(m.patches.len(), 2);
        assert_eq!(m.triangle_count(), 2 + 3);
        let n0 = m.normals[0];
        let want = Vec3::new(-1.0, 0.0, 1.0).normalize();
        assert!((n0 - want).length() < 1e-5, "{n0}");
    }
}
