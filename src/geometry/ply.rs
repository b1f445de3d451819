//! PLY reader (ASCII or binary, either byte order).
//!
//! It gives one mesh per file in which every input face (polygon) becomes one
//! [`Patch::Polygon`](crate::geometry::Patch::Polygon), fan-triangulated into triangles of that patch. Shading
//! normals: the file's own (`nx ny nz`) when it has them; otherwise smooth normals,
//! the angle-weighted average of the face normals around each vertex that faces
//! share; none at all (flat shading) when `face_normals` is asked for. Zero-area
//! faces are kept (the BVH skips them). Every problem in a file is an [`Error`]
//! naming the file (and the line where known); no input makes it panic.

use std::path::Path;

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{Encoding, Header, Property, PropertyAccess, PropertyType, ScalarType};

use crate::error::Pos;
use crate::geometry::trimesh_build::{build_mesh, vertex_count_error, RawMesh};
use crate::geometry::{TriMesh, MAX_COORD};
use crate::{Error, Result};

/// A PLY `vertex` element as we keep it.
#[derive(Default)]
struct PlyVertex {
    p: [f64; 3],
    n: [f64; 3],
    uv: [f64; 2],
}

fn scalar_f64(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x.into(),
        Property::UChar(x) => x.into(),
        Property::Short(x) => x.into(),
        Property::UShort(x) => x.into(),
        Property::Int(x) => x.into(),
        Property::UInt(x) => x.into(),
        Property::Float(x) => x.into(),
        Property::Double(x) => x,
        _ => return None,
    })
}

/// Which slot of [`PlyVertex`] a vertex property name fills.
fn vertex_slot(name: &str) -> Option<(usize, usize)> {
    Some(match name {
        "x" => (0, 0),
        "y" => (0, 1),
        "z" => (0, 2),
        "nx" => (1, 0),
        "ny" => (1, 1),
        "nz" => (1, 2),
        "u" | "s" | "texture_u" | "texture_s" => (2, 0),
        "v" | "t" | "texture_v" | "texture_t" => (2, 1),
        _ => return None,
    })
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> ply_rs_bw::ply::PropertyAccessResult {
        use ply_rs_bw::ply::PropertyAccessResult as R;
        let Some((slot, k)) = vertex_slot(name) else {
            return R::Ignored;
        };
        let Some(x) = scalar_f64(&property) else {
            return R::UnsupportedType;
        };
        match slot {
            0 => self.p[k] = x,
            1 => self.n[k] = x,
            _ => self.uv[k] = x,
        }
        R::Set
    }
}

/// A PLY `face` element: its vertex indices.
#[derive(Default)]
struct PlyFace(Vec<i64>);

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, property: Property) -> ply_rs_bw::ply::PropertyAccessResult {
        use ply_rs_bw::ply::PropertyAccessResult as R;
        if name != "vertex_indices" && name != "vertex_index" {
            return R::Ignored;
        }
        fn conv<T: Copy + Into<i64>>(v: &[T]) -> Vec<i64> {
            v.iter().map(|&x| x.into()).collect()
        }
        self.0 = match &property {
            Property::ListChar(v) => conv(v),
            Property::ListUChar(v) => conv(v),
            Property::ListShort(v) => conv(v),
            Property::ListUShort(v) => conv(v),
            Property::ListInt(v) => conv(v),
            Property::ListUInt(v) => conv(v),
            _ => return R::UnsupportedType,
        };
        R::Set
    }
}

/// An element we do not use: read and dropped.
struct PlySkip;

impl PropertyAccess for PlySkip {
    fn new() -> Self {
        PlySkip
    }
}

/// Bytes a scalar of type `t` takes in a binary PLY file.
fn scalar_size(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// ply-rs's error as one line of ours; its line number only means a line in ASCII
/// data (in binary data it counts elements).
fn ply_error(path: &Path, e: ParseError, ascii_lines: bool, element: &str) -> Error {
    let text = e.to_string();
    let text = match e.line() {
        Some(l) => text
            .strip_prefix(&format!("Line {l}: "))
            .unwrap_or(&text)
            .to_string(),
        None => text,
    };
    // Quoted input lines come with their line break.
    let text = text.replace("\r\n'", "'").replace("\n'", "'");
    let mut msg: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect::<String>()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    // ply-rs appends its parser's internal state after " Error: "; keep the gist.
    if let Some(i) = msg.find(" Error: ") {
        msg.truncate(i);
    }
    if msg.chars().count() > 200 {
        msg = msg.chars().take(200).collect::<String>() + "...";
    }
    if !ascii_lines && e.kind() == std::io::ErrorKind::UnexpectedEof && !element.is_empty() {
        msg = format!("binary data ends early, in element '{element}'");
    }
    let pos = if ascii_lines {
        e.line().map(|l| Pos {
            line: l.try_into().unwrap_or(u32::MAX),
            col: 0,
        })
    } else {
        None
    };
    Error::input(path, pos, msg)
}

/// Reads a PLY file (ASCII or binary, either byte order) as one mesh; each face
/// becomes one patch, fan-triangulated.
///
/// Uses the `vertex` element's `x y z` (any numeric type), optional `nx ny nz` and
/// optional texture coordinates (`u v`, `s t`, `texture_u texture_v` or
/// `texture_s texture_t`), and the `face` element's `vertex_indices` (or
/// `vertex_index`) list; other elements and properties are skipped. Normals as
/// described in the [module docs](self).
pub fn read_ply(path: &Path, face_normals: bool) -> Result<TriMesh> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_ply(path, &bytes, face_normals)
}

/// [`read_ply`] on the file's contents; `path` only names the file in errors.
pub fn parse_ply(path: &Path, bytes: &[u8], face_normals: bool) -> Result<TriMesh> {
    let mut reader = Reader::new(bytes);
    let header = Parser::<PlySkip>::new()
        .read_header(&mut reader)
        .map_err(|e| ply_error(path, e, true, ""))?;
    let ascii = header.encoding == Encoding::Ascii;
    let first_data_line = reader.line();
    check_ply_header(path, &header, reader.get_ref().len() as u64)?;

    let mut verts: Vec<PlyVertex> = Vec::new();
    let mut faces: Vec<PlyFace> = Vec::new();
    let mut face_line0 = first_data_line;
    let mut lines_before = first_data_line;
    let has = |n: &str| {
        header
            .elements
            .get("vertex")
            .is_some_and(|v| v.properties.contains_key(n))
    };
    let has_normals = has("nx") && has("ny") && has("nz");
    let has_uv = ["u", "s", "texture_u", "texture_s"].iter().any(|n| has(n))
        && ["v", "t", "texture_v", "texture_t"].iter().any(|n| has(n));
    let mut vert_line0 = first_data_line;
    for (name, def) in &header.elements {
        let err = |e| ply_error(path, e, ascii, name);
        match name.as_str() {
            "vertex" => {
                vert_line0 = lines_before;
                verts = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(err)?;
            }
            "face" => {
                face_line0 = lines_before;
                faces = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(err)?;
            }
            _ => {
                Parser::<PlySkip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(err)?;
            }
        }
        lines_before = lines_before.saturating_add(def.count);
    }

    // Where element `k` is: its line in ASCII data (binary data has no lines).
    let at = |line0: usize, k: usize| -> Option<Pos> {
        ascii.then(|| Pos {
            line: line0.saturating_add(k).try_into().unwrap_or(u32::MAX),
            col: 0,
        })
    };
    let nv = verts.len();
    if u32::try_from(nv).is_err() {
        return Err(vertex_count_error(path));
    }
    let mut raw = RawMesh {
        positions: Vec::with_capacity(nv),
        normals: Vec::with_capacity(nv),
        uvs: Vec::new(),
        faces: Vec::with_capacity(faces.len()),
    };
    for (k, v) in verts.iter().enumerate() {
        let p = glam::DVec3::from_array(v.p).as_vec3();
        let n = glam::DVec3::from_array(v.n).as_vec3();
        if !p.is_finite() || (has_normals && !n.is_finite()) {
            let what = if p.is_finite() { "normal" } else { "position" };
            return Err(Error::input(
                path,
                at(vert_line0, k),
                format!("vertex {k}: {what} is not finite"),
            ));
        }
        if p.abs().max_element() > MAX_COORD {
            return Err(Error::input(
                path,
                at(vert_line0, k),
                format!("vertex {k}: position {p} is absurdly large (at most {MAX_COORD:e})"),
            ));
        }
        raw.positions.push(p);
        raw.normals.push(has_normals.then_some(n));
        if has_uv {
            raw.uvs.push(glam::DVec2::from_array(v.uv).as_vec2());
        }
    }
    for (k, f) in faces.into_iter().enumerate() {
        let bad = |msg: String| Error::input(path, at(face_line0, k), format!("face {k}: {msg}"));
        if f.0.len() < 3 {
            return Err(bad(format!("{} vertices; at least 3 needed", f.0.len())));
        }
        let idx =
            f.0.iter()
                .map(|&i| {
                    u32::try_from(i)
                        .ok()
                        .filter(|&i| (i as usize) < nv)
                        .ok_or_else(|| bad(format!("vertex index {i} out of range (only {nv} vertices)")))
                })
                .collect::<Result<Vec<u32>>>()?;
        raw.faces.push(idx);
    }
    build_mesh(path, raw, face_normals)
}

/// Checks what ply-rs does not: that the elements we need are there with the right
/// property types, and that the declared element counts fit in the file (so a
/// huge count cannot make us loop or allocate without end).
fn check_ply_header(path: &Path, header: &Header, data_bytes: u64) -> Result<()> {
    let err = |msg: String| Error::input(path, None, msg);
    let Some(v) = header.elements.get("vertex") else {
        return Err(err("no 'vertex' element".into()));
    };
    for name in ["x", "y", "z"] {
        match v.properties.get(name) {
            None => return Err(err(format!("'vertex' element has no '{name}' property"))),
            Some(p) if matches!(p.data_type, PropertyType::List(..)) => {
                return Err(err(format!("vertex property '{name}' is a list")))
            }
            Some(_) => {}
        }
    }
    let Some(f) = header.elements.get("face").filter(|f| f.count > 0) else {
        return Err(err("no faces".into()));
    };
    let list = ["vertex_indices", "vertex_index"]
        .iter()
        .find_map(|n| f.properties.get(*n));
    match list {
        None => return Err(err("'face' element has no 'vertex_indices' list".into())),
        Some(p) => match &p.data_type {
            PropertyType::List(_, t) if !matches!(t, ScalarType::Float | ScalarType::Double) => {}
            _ => return Err(err("face 'vertex_indices' is not a list of integers".into())),
        },
    }
    let mut need: u64 = 0;
    for (name, def) in &header.elements {
        let each: u64 = if header.encoding == Encoding::Ascii {
            1
        } else {
            def.properties
                .values()
                .map(|p| match &p.data_type {
                    PropertyType::Scalar(t) => scalar_size(t),
                    PropertyType::List(c, _) => scalar_size(c),
                })
                .sum::<u64>()
                .max(1)
        };
        need = need.saturating_add((def.count as u64).saturating_mul(each));
        if need > data_bytes {
            return Err(err(format!(
                "file too short: {} '{name}' elements declared, but only {data_bytes} bytes of data",
                def.count
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};

    use super::*;
    use crate::geometry::trimesh_build::tests::{check_cube, write};
    use crate::testutil::mesh_data as data;

    /// A cube [0,1]^3 as a PLY file; `fmt` is the format name.
    fn cube_ply(fmt: &str, double: bool, normals: bool, uv: bool) -> Vec<u8> {
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                let [x, y] = [[0, 0], [1, 0], [1, 1], [0, 1]][i % 4];
                [x as f64, y as f64, (i / 4) as f64]
            })
            .collect();
        let faces: [[i32; 4]; 6] = [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [3, 7, 6, 2],
            [0, 4, 7, 3],
            [1, 2, 6, 5],
        ];
        let ty = if double { "double" } else { "float" };
        let mut h = format!("ply\nformat {fmt} 1.0\ncomment cube\nelement vertex 8\n");
        for n in ["x", "y", "z"] {
            h += &format!("property {ty} {n}\n");
        }
        if normals {
            h += "property float nx\nproperty float ny\nproperty float nz\n";
        }
        if uv {
            h += "property float s\nproperty float t\n";
        }
        h += "property uchar red\nelement face 6\nproperty list uchar int vertex_indices\n\
              property int flags\nelement edge 1\nproperty int vertex1\nproperty int vertex2\n\
              end_header\n";
        let mut out = h.into_bytes();
        let vals = |i: usize| -> Vec<f64> {
            let c = corners[i];
            let mut v = c.to_vec();
            if normals {
                v.extend(
                    (Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) - 0.5)
                        .normalize()
                        .to_array()
                        .map(f64::from),
                );
            }
            if uv {
                v.extend([c[0], c[1]]);
            }
            v
        };
        if fmt == "ascii" {
            let mut s = String::new();
            for i in 0..8 {
                for x in vals(i) {
                    s += &format!("{x} ");
                }
                s += "255\n";
            }
            for f in faces {
                s += &format!("4 {} {} {} {} 0\n", f[0], f[1], f[2], f[3]);
            }
            s += "0 1\n";
            out.extend(s.into_bytes());
        } else {
            let be = fmt == "binary_big_endian";
            let f32b = |x: f32| if be { x.to_be_bytes() } else { x.to_le_bytes() };
            let i32b = |x: i32| if be { x.to_be_bytes() } else { x.to_le_bytes() };
            for i in 0..8 {
                for (k, x) in vals(i).into_iter().enumerate() {
                    if double && k < 3 {
                        out.extend(if be { x.to_be_bytes() } else { x.to_le_bytes() });
                    } else {
                        out.extend(f32b(x as f32));
                    }
                }
                out.push(255);
            }
            for f in faces {
                out.push(4);
                for i in f {
                    out.extend(i32b(i));
                }
                out.extend(i32b(7));
            }
            out.extend(i32b(0));
            out.extend(i32b(1));
        }
        out
    }

    #[test]
    fn ply_cube_all_formats() {
        let dir = tempfile::tempdir().unwrap();
        let fixture = read_ply(&data("cube_ascii.ply"), false).unwrap();
        check_cube(&fixture);
        for fmt in ["ascii", "binary_little_endian", "binary_big_endian"] {
            for (double, normals, uv) in [(false, false, false), (true, true, false), (false, true, true)] {
                let p = write(&dir, "cube.ply", cube_ply(fmt, double, normals, uv));
                let m = read_ply(&p, false).unwrap_or_else(|e| panic!("{fmt}: {e}"));
                check_cube(&m);
                assert_eq!(m.positions, fixture.positions, "{fmt}");
                assert_eq!(m.indices, fixture.indices, "{fmt}");
                assert_eq!(m.patches, fixture.patches, "{fmt}");
                assert_eq!(m.normals.len(), 8);
                for (p, n) in m.positions.iter().zip(&m.normals) {
                    assert!((*n - (*p - 0.5).normalize()).length() < 1e-5);
                }
                if uv {
                    assert_eq!(m.uvs[2], Vec2::new(1.0, 1.0));
                } else {
                    assert!(m.uvs.is_empty());
                }
                let f = read_ply(&p, true).unwrap();
                assert!(f.normals.is_empty());
                assert_eq!(f.indices, m.indices);
            }
        }
    }

    #[test]
    fn ply_errors() {
        let dir = tempfile::tempdir().unwrap();
        let err = |name: &str, bytes: Vec<u8>| -> String {
            let p = write(&dir, name, bytes);
            let e = read_ply(&p, false).expect_err("should fail").to_string();
            assert!(e.starts_with(&p.display().to_string()), "{e}");
            assert!(!e.contains('\n'), "{e:?}");
            e
        };
        // Truncated binary data, at every length short of complete.
        for fmt in ["binary_little_endian", "binary_big_endian"] {
            let full = cube_ply(fmt, false, false, false);
            let header = full.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
            for cut in header..full.len() {
                let e = err("trunc.ply", full[..cut].to_vec());
                assert!(
                    e.contains("file too short") || e.contains("binary data ends early"),
                    "{fmt} cut at {cut}: {e}"
                );
            }
        }
        // Truncated ASCII data names the line where it ran out.
        let full = cube_ply("ascii", false, false, false);
        let text = String::from_utf8(full).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let e = err("t.ply", (lines[..lines.len() - 3].join("\n") + "\n").into_bytes());
        assert!(
            e.contains("t.ply:28: Unexpected end of file while reading element 'face' (expected 6, got 4)"),
            "{e}"
        );

        let ascii = |body: &str| {
            format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                 end_header\n{body}"
            )
            .into_bytes()
        };
        let e = err("range.ply", ascii("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"));
        assert!(e.contains(":13: face 0: vertex index 3 out of range"), "{e}");
        let e = err("neg.ply", ascii("0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n"));
        assert!(e.contains("vertex index -1 out of range"), "{e}");
        let e = err("two.ply", ascii("0 0 0\n1 0 0\n0 1 0\n2 0 1\n"));
        assert!(e.contains(":13: face 0: 2 vertices"), "{e}");
        let e = err("junk.ply", ascii("0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"));
        assert!(
            e.ends_with("junk.ply:11: Couldn't read element line. String: '1 x 0'"),
            "{e}"
        );
        let e = err("short.ply", ascii("0 0 0\n1 0 0\n0 1 0\n"));
        assert!(
            e.contains("short.ply:13: Unexpected end of file while reading element 'face'"),
            "{e}"
        );

        // Binary NaN coordinates.
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                      property float y\nproperty float z\nelement face 1\n\
                      property list uchar uint vertex_indices\nend_header\n"
            .to_vec();
        for x in [0.0f32, 0.0, 0.0, 1.0, 0.0, f32::NAN, 0.0, 1.0, 0.0] {
            b.extend(x.to_le_bytes());
        }
        b.push(3);
        for i in [0u32, 1, 2] {
            b.extend(i.to_le_bytes());
        }
        let e = err("nan.ply", b.clone());
        assert!(e.ends_with(": vertex 1: position is not finite"), "{e}");
        // Huge list count in binary data.
        let n = b.len();
        b[n - 13] = 255;
        let e = err("list.ply", b);
        assert!(e.contains("binary data ends early, in element 'face'"), "{e}");

        // Header problems.
        let head = |s: &str| s.as_bytes().to_vec();
        for (bytes, want) in [
            (head(""), "magic"),
            (head("ply\n"), "end_header"),
            (
                head("plx\nformat ascii 1.0\nend_header\n"),
                "h.ply:1: Expected magic number 'ply'. String: 'plx'",
            ),
            (head("ply\nformat ascii 1.0\nend_header\n"), "no 'vertex' element"),
            (
                head("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nend_header\n"),
                "no 'y' property",
            ),
            (
                head(
                    "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n\
                     property float z\nend_header\n",
                ),
                "no faces",
            ),
            (
                head(
                    "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n\
                     property float z\nelement face 0\nproperty list uchar int vertex_indices\n\
                     end_header\n",
                ),
                "no faces",
            ),
            (
                head(
                    "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
                     property float x\nproperty float y\nproperty float z\nelement face 1\n\
                     property list uchar int vertex_indices\nend_header\n",
                ),
                "file too short: 4000000000 'vertex' elements",
            ),
            (
                head(
                    "ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
                     property float x\nproperty float y\nproperty float z\nelement face 1\n\
                     property list uchar float vertex_indices\nend_header\n",
                ),
                "not a list of integers",
            ),
            (
                head(
                    "ply\nformat binary_little_endian 1.0\nelement nothing 99999999999\n\
                     element vertex 3\n\
                     property float x\nproperty float y\nproperty float z\nelement face 1\n\
                     property list uchar int vertex_indices\nend_header\n",
                ),
                "file too short",
            ),
        ] {
            let e = err("h.ply", bytes);
            assert!(e.contains(want), "{e:?} lacks {want:?}");
        }
        let p = dir.path().join("missing.ply");
        assert!(matches!(read_ply(&p, false), Err(Error::Io { .. })));
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

        #[test]
        fn ply_random_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..300)) {
            let dir = tempfile::tempdir().unwrap();
            let p = write(&dir, "x.ply", &bytes);
            let _ = read_ply(&p, false);
        }

        #[test]
        fn ply_mutated_never_panics(
            fmt in 0usize..3,
            edits in proptest::collection::vec((0usize..1000, proptest::num::u8::ANY), 1..6),
            cut in 0usize..1000,
        ) {
            let fmt = ["ascii", "binary_little_endian", "binary_big_endian"][fmt];
            let mut b = cube_ply(fmt, false, true, false);
            for (at, x) in edits {
                let n = b.len();
                b[at % n] = x;
            }
            b.truncate(b.len() - cut % b.len());
            let dir = tempfile::tempdir().unwrap();
            let p = write(&dir, "x.ply", &b);
            if let Ok(m) = read_ply(&p, false) {
                proptest::prop_assert!(m.validate().is_ok());
            }
        }
    }
}
