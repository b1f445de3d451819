//! Wavefront OBJ reader.
//!
//! It gives one mesh per file in which every input face (polygon) becomes one
//! [`Patch::Polygon`](crate::geometry::Patch::Polygon), fan-triangulated into triangles of that patch. Shading
//! normals: the file's own (`vn`) when it has them; otherwise smooth normals, the
//! angle-weighted average of the face normals around each vertex that faces share;
//! none at all (flat shading) when `face_normals` is asked for. Zero-area faces are
//! kept (the BVH skips them). Every problem in a file is an [`Error`] naming the
//! file (and the line where known); no input makes it panic.

use std::collections::HashMap;
use std::path::Path;

use glam::{Vec2, Vec3};

use crate::error::Pos;
use crate::geometry::text::{parse_coord, parse_finite, text_lines, tokens};
use crate::geometry::trimesh_build::{build_mesh, vertex_count_error, RawMesh};
use crate::geometry::TriMesh;
use crate::{Error, Result};

/// One corner of an OBJ face as written: 0-based indices (positive ones not yet
/// range-checked), and where it was written.
#[derive(Clone, Copy)]
struct ObjCorner {
    v: i64,
    vt: Option<i64>,
    vn: Option<i64>,
    line: u32,
    col: u32,
}

/// Parses one face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`; negative indices are
/// made absolute against the counts so far.
fn parse_corner(path: &Path, line: u32, col: u32, tok: &str, counts: [usize; 3]) -> Result<ObjCorner> {
    let pos = Some(Pos { line, col });
    let parts: Vec<&str> = tok.split('/').collect();
    if parts.len() > 3 || parts[0].is_empty() {
        return Err(Error::input(
            path,
            pos,
            format!("bad face vertex '{tok}' (expected v, v/vt, v//vn or v/vt/vn)"),
        ));
    }
    const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut idx = [None; 3];
    for (k, part) in parts.iter().enumerate() {
        if part.is_empty() {
            continue;
        }
        let i: i64 = part.parse().map_err(|_| {
            Error::input(
                path,
                pos,
                format!("bad face vertex '{tok}': '{part}' is not an index"),
            )
        })?;
        let n = counts[k] as i64;
        idx[k] = Some(match i {
            0 => {
                return Err(Error::input(
                    path,
                    pos,
                    format!("{} index 0 in '{tok}' (OBJ indices start at 1)", WHAT[k]),
                ))
            }
            i if i < 0 => {
                if i < -n {
                    return Err(Error::input(
                        path,
                        pos,
                        format!(
                            "relative {} index {i} in '{tok}' reaches before the first (only {n} defined)",
                            WHAT[k]
                        ),
                    ));
                }
                n + i
            }
            i => i - 1,
        });
    }
    Ok(ObjCorner {
        v: idx[0].unwrap_or(0),
        vt: idx[1],
        vn: idx[2],
        line,
        col,
    })
}

/// Reads an OBJ file as one mesh (materials ignored, as Mitsuba's `obj` does); each
/// face becomes one `Patch::Polygon`, fan-triangulated.
///
/// Understands `v` (extra values such as `w` or colours are ignored), `vt`, `vn`
/// and `f` (with relative indices); every other statement (`o`, `g`, `s`,
/// `usemtl`, `mtllib`, `l`, `p`, ...) is ignored, so a missing `.mtl` does no harm.
/// Normals as described in the [module docs](self); with `face_normals` the `vn`
/// are ignored and `normals` is left empty.
pub fn read_obj(path: &Path, face_normals: bool) -> Result<TriMesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_obj(path, &bytes, face_normals)
}

/// [`read_obj`] on the file's contents; `path` only names the file in errors.
pub fn parse_obj(path: &Path, bytes: &[u8], face_normals: bool) -> Result<TriMesh> {
    let lines = text_lines(path, bytes)?;
    let mut pos: Vec<Vec3> = Vec::new();
    let mut tex: Vec<Vec2> = Vec::new();
    let mut nor: Vec<Vec3> = Vec::new();
    let mut faces: Vec<Vec<ObjCorner>> = Vec::new();
    for &(line, text) in &lines {
        let text = text.split('#').next().unwrap_or("");
        let toks = tokens(text);
        let Some(&(_, kw)) = toks.first() else {
            continue;
        };
        let args = &toks[1..];
        let numbers =
            |n: usize, what: &str, parse: fn(&Path, u32, u32, &str) -> Result<f32>| -> Result<Vec<f32>> {
                if args.len() < n {
                    return Err(Error::input(
                        path,
                        Some(Pos { line, col: 1 }),
                        format!("'{kw}' needs {what}, found {} values", args.len()),
                    ));
                }
                args[..n]
                    .iter()
                    .map(|&(col, t)| parse(path, line, col, t))
                    .collect()
            };
        match kw {
            "v" => {
                let x = numbers(3, "3 coordinates", parse_coord)?;
                pos.push(Vec3::new(x[0], x[1], x[2]));
            }
            "vn" => {
                let x = numbers(3, "3 coordinates", parse_finite)?;
                nor.push(Vec3::new(x[0], x[1], x[2]));
            }
            "vt" => {
                let x = numbers(1, "at least 1 coordinate", parse_finite)?;
                let v = match args.get(1) {
                    Some(&(col, t)) => parse_finite(path, line, col, t)?,
                    None => 0.0,
                };
                tex.push(Vec2::new(x[0], v));
            }
            "f" => {
                if args.len() < 3 {
                    return Err(Error::input(
                        path,
                        Some(Pos { line, col: 1 }),
                        format!("face has {} vertices; at least 3 needed", args.len()),
                    ));
                }
                let counts = [pos.len(), tex.len(), nor.len()];
                let face = args
                    .iter()
                    .map(|&(col, t)| parse_corner(path, line, col, t, counts))
                    .collect::<Result<Vec<_>>>()?;
                faces.push(face);
            }
            _ => {}
        }
    }

    // Resolve corners to mesh vertices, one per distinct (v, vt, vn).
    let mut raw = RawMesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        faces: Vec::with_capacity(faces.len()),
    };
    let has_uv = faces.iter().flatten().any(|c| c.vt.is_some());
    let mut map: HashMap<(i64, Option<i64>, Option<i64>), u32> = HashMap::new();
    for face in &faces {
        let mut f = Vec::with_capacity(face.len());
        for c in face {
            let at = Some(Pos {
                line: c.line,
                col: c.col,
            });
            let check = |i: i64, n: usize, what: &str| -> Result<usize> {
                usize::try_from(i).ok().filter(|&i| i < n).ok_or_else(|| {
                    Error::input(
                        path,
                        at,
                        format!("{what} index {} out of range (only {n} defined)", i + 1),
                    )
                })
            };
            let vi = check(c.v, pos.len(), "vertex")?;
            let ti =
                c.vt.map(|t| check(t, tex.len(), "texture coordinate"))
                    .transpose()?;
            let ni = if face_normals {
                None
            } else {
                c.vn.map(|n| check(n, nor.len(), "normal")).transpose()?
            };
            let key = (vi as i64, ti.map(|t| t as i64), ni.map(|n| n as i64));
            let id = match map.get(&key) {
                Some(&id) => id,
                None => {
                    let id = u32::try_from(raw.positions.len()).map_err(|_| vertex_count_error(path))?;
                    raw.positions.push(pos[vi]);
                    raw.normals.push(ni.map(|n| nor[n]));
                    if has_uv {
                        raw.uvs.push(ti.map_or(Vec2::ZERO, |t| tex[t]));
                    }
                    map.insert(key, id);
                    id
                }
            };
            f.push(id);
        }
        raw.faces.push(f);
    }
    build_mesh(path, raw, face_normals)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geometry::trimesh_build::tests::{check_cube, write};
    use crate::geometry::Patch;
    use crate::testutil::mesh_data as data;

    fn obj_err(p: &Path) -> String {
        read_obj(p, false).expect_err("should fail").to_string()
    }

    /// Positions of the corners of patch `k` (a polygon).
    fn polygon(m: &TriMesh, k: usize) -> Vec<Vec3> {
        let Patch::Polygon(v) = &m.patches[k] else {
            panic!("not a polygon");
        };
        v.iter().map(|&i| m.positions[i as usize]).collect()
    }

    #[test]
    fn obj_quad_is_one_patch_two_triangles() {
        let m = read_obj(&data("quad.obj"), false).unwrap();
        m.validate().unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.patches, vec![Patch::Polygon(vec![0, 1, 2, 3])]);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.tri_patch, vec![0, 0]);
        assert!(m.uvs.is_empty());
        // No vn: smooth (here: flat) normals, +z.
        assert_eq!(m.normals, vec![Vec3::Z; 4]);
        let flat = read_obj(&data("quad.obj"), true).unwrap();
        assert!(flat.normals.is_empty());
        assert_eq!(flat.indices, m.indices);
    }

    #[test]
    fn obj_relative_indices() {
        let m = read_obj(&data("relative.obj"), false).unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(
            m.triangle(0),
            [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)]
        );
        assert_eq!(
            m.triangle(1),
            [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]
        );
        // Vertices shared between the two faces are one vertex.
        assert_eq!(m.positions.len(), 4);
    }

    #[test]
    fn obj_keeps_given_normals() {
        let m = read_obj(&data("cube_vn.obj"), false).unwrap();
        check_cube(&m);
        assert_eq!(m.positions.len(), 24);
        for t in 0..12 {
            let [a, b, c] = m.triangle(t);
            let g = (b - a).cross(c - a).normalize();
            for &i in &m.indices[t] {
                assert_eq!(m.normals[i as usize], g);
            }
        }
        assert_eq!(polygon(&m, 1)[0], Vec3::new(0.0, 0.0, 1.0));
        // face_normals: vn ignored, corners shared again.
        let f = read_obj(&data("cube_vn.obj"), true).unwrap();
        check_cube(&f);
        assert!(f.normals.is_empty());
        assert_eq!(f.positions.len(), 8);
    }

    #[test]
    fn obj_shared_vertices_get_smooth_normals() {
        let m = read_obj(&data("cube_shared.obj"), false).unwrap();
        check_cube(&m);
        assert_eq!(m.positions.len(), 8);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            // Each corner: three faces meeting at right angles, equally weighted.
            let want = (*p - Vec3::splat(0.5)).normalize();
            assert!((*n - want).length() < 1e-5, "{p} {n}");
        }
    }

    #[test]
    fn obj_uvs_and_polygons() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            "hex.obj",
            "v 1 0 0\nv 0.5 0.8 0\nv -0.5 0.8 0\nv -1 0 0\nv -0.5 -0.8 0\nv 0.5 -0.8 0\n\
             vt 0.1 0.2\nvt 0.3\nvn 0 0 2\n\
             f 1/1/1 2/2/1 3/1/1 4/2/1 5/1/1 6/2/1\n",
        );
        let m = read_obj(&p, false).unwrap();
        assert_eq!(m.patches.len(), 1);
        assert_eq!(m.triangle_count(), 4);
        assert_eq!(m.uvs[0], Vec2::new(0.1, 0.2));
        assert_eq!(m.uvs[1], Vec2::new(0.3, 0.0));
        assert!(m.normals.iter().all(|&n| n == Vec3::Z));
        assert_eq!(m.indices[3], [0, 4, 5]);
    }

    #[test]
    fn obj_degenerate_face_is_kept() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(&dir, "d.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
        let m = read_obj(&p, false).unwrap();
        assert_eq!(m.triangle_count(), 1);
        assert_eq!(m.area(), 0.0);
        assert!(m.normals.iter().all(|n| n.is_finite() && n.length() > 0.99));
    }

    #[test]
    fn obj_errors() {
        let dir = tempfile::tempdir().unwrap();
        let e = obj_err(&data("bad_index.obj"));
        assert!(
            e.contains("bad_index.obj:5:7: vertex index 5 out of range (only 3 defined)"),
            "{e}"
        );

        let cases: &[(&str, &str)] = &[
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ":4:3: vertex index 0"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n",
                ":4:3: relative vertex index -4",
            ),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", ":4:1: face has 2 vertices"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", ":4:1: face has 0 vertices"),
            (
                "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                ":1:7: 'nan' is not a finite number",
            ),
            ("v 0 0 1e39\n", ":1:7: '1e39' is not a finite number"),
            ("v 0 0 -inf\n", ":1:7: '-inf' is not a finite number"),
            ("v 0 0 x\n", ":1:7: 'x' is not a number"),
            ("v 0 0\n", ":1:1: 'v' needs 3 coordinates"),
            ("vn 0 0\n", ":1:1: 'vn' needs 3 coordinates"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1\n",
                ":4:7: texture coordinate index 1 out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
                ":5:13: normal index 2 out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/1/1\n",
                ":4:7: bad face vertex",
            ),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 /3\n", ":4:7: bad face vertex"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n",
                ":4:7: bad face vertex 'a'",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
                ":4:7: bad face vertex",
            ),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", ": no faces"),
            ("", ": no faces"),
            ("# only a comment\n", ": no faces"),
        ];
        for (i, (text, want)) in cases.iter().enumerate() {
            let p = write(&dir, &format!("case{i}.obj"), text);
            let e = obj_err(&p);
            assert!(
                e.starts_with(&p.display().to_string()) && e.contains(want),
                "case {i}: {e:?} lacks {want:?}"
            );
            assert!(!e.contains('\n'));
        }
        // `3/` (an empty texture coordinate index) means none.
        let p = write(&dir, "slash.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/ 2/ 3/\n");
        assert_eq!(read_obj(&p, false).unwrap().triangle_count(), 1);

        let p = dir.path().join("missing.obj");
        assert!(matches!(read_obj(&p, false), Err(Error::Io { .. })));
        assert!(obj_err(&p).starts_with(&p.display().to_string()));
        let p = write(&dir, "bin.obj", [b'v', b' ', 0xff, 0xfe, b'\n']);
        assert!(obj_err(&p).contains(":1:3: not UTF-8"));
    }

    #[test]
    fn obj_forward_references_and_ignored_statements() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            &dir,
            "fwd.obj",
            "mtllib nope.mtl\no a\ng b c\ns 1\nusemtl x\nf 1 2 3 # comment\nl 1 2\np 1\n\
             v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nvp 0.1\n",
        );
        let m = read_obj(&p, false).unwrap();
        assert_eq!(m.triangle_count(), 1);
        assert_eq!(m.patches.len(), 1);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

        #[test]
        fn obj_random_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300)) {
            let dir = tempfile::tempdir().unwrap();
            let p = write(&dir, "x.obj", &bytes);
            if let Ok(m) = read_obj(&p, false) {
                proptest::prop_assert!(m.validate().is_ok());
            }
        }

        #[test]
        fn obj_random_text_never_panics(text in "([vtnf/ 0-9.\\-e]{0,12}\n){0,12}") {
            let dir = tempfile::tempdir().unwrap();
            let p = write(&dir, "x.obj", &text);
            for flat in [false, true] {
                if let Ok(m) = read_obj(&p, flat) {
                    proptest::prop_assert!(m.validate().is_ok());
                    proptest::prop_assert!(m.normals.iter().all(|n| n.is_finite()));
                }
            }
        }
    }
}
