//! Meshes out: Wavefront OBJ (the `tessellate` command's output).

use std::fmt::Write as _;
use std::path::Path;

use super::write_atomic;
use crate::geometry::TriMesh;
use crate::Result;

/// Writes `mesh` as an OBJ file: `v`, `vn` (if the mesh has normals), `vt` (if it
/// has uvs) and one `f` per triangle (1-based). Values are written so that they
/// read back exactly.
pub fn write_obj(mesh: &TriMesh, path: &Path) -> Result<()> {
    let mut s = String::with_capacity(64 * (mesh.positions.len() + mesh.indices.len()) + 64);
    s.push_str("# written by radtrace\n");
    for p in &mesh.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    let has_n = !mesh.normals.is_empty();
    let has_t = !mesh.uvs.is_empty();
    for t in &mesh.uvs {
        let _ = writeln!(s, "vt {} {}", t.x, t.y);
    }
    for n in &mesh.normals {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for tri in &mesh.indices {
        s.push('f');
        for &i in tri {
            let i = u64::from(i) + 1;
            let _ = match (has_t, has_n) {
                (false, false) => write!(s, " {i}"),
                (true, false) => write!(s, " {i}/{i}"),
                (false, true) => write!(s, " {i}//{i}"),
                (true, true) => write!(s, " {i}/{i}/{i}"),
            };
        }
        s.push('\n');
    }
    write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::obj::read_obj;
    use crate::testutil::{mesh_data as data, teapot_bpt};
    use crate::Error;

    #[test]
    fn write_obj_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let teapot = crate::geometry::bezier::read_bpt(&teapot_bpt()).unwrap();
        let meshes = [
            crate::geometry::bezier::tessellate(&teapot, 2, 3),
            read_obj(&data("cube_shared.obj"), true).unwrap(),
            read_obj(&data("cube_vn.obj"), false).unwrap(),
        ];
        for (k, m) in meshes.iter().enumerate() {
            let p = dir.path().join(format!("out{k}.obj"));
            write_obj(m, &p).unwrap();
            let text = std::fs::read_to_string(&p).unwrap();
            assert!(text.starts_with("# written by radtrace\n"));
            let r = read_obj(&p, false).unwrap();
            r.validate().unwrap();
            assert_eq!(r.triangle_count(), m.triangle_count());
            // Vertices are renumbered in order of first use: compare triangle by triangle.
            for t in 0..m.triangle_count() {
                assert_eq!(r.triangle(t), m.triangle(t), "mesh {k} triangle {t}");
                for c in 0..3 {
                    let (i, j) = (m.indices[t][c] as usize, r.indices[t][c] as usize);
                    if !m.normals.is_empty() {
                        assert!((r.normals[j] - m.normals[i]).length() < 1e-6);
                    }
                    if !m.uvs.is_empty() {
                        assert_eq!(r.uvs[j], m.uvs[i]);
                    }
                }
            }
            assert_eq!(r.uvs.is_empty(), m.uvs.is_empty());
        }
        let bad = dir.path().join("no/such/dir/x.obj");
        assert!(matches!(write_obj(&meshes[1], &bad), Err(Error::Output { .. })));
    }
}
