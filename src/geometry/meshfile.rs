//! Mesh files: Wavefront OBJ and PLY readers, and an OBJ writer.
//!
//! Both readers give one mesh per file in which every input face (polygon) becomes
//! one [`Patch::Polygon`], fan-triangulated into triangles of that patch. Shading
//! normals: the file's own (OBJ `vn`, PLY `nx ny nz`) when it has them; otherwise
//! smooth normals, the angle-weighted average of the face normals around each vertex
//! that faces share; none at all (flat shading) when `face_normals` is asked for.
//! Zero-area faces are kept (the BVH skips them). Every problem in a file is an
//! [`Error`] naming the file (and the line where known); no input makes them panic.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{Encoding, Header, Property, PropertyAccess, PropertyType, ScalarType};

use crate::error::Pos;
use crate::geometry::{Patch, TriMesh};
use crate::{Error, Result};

// ---------------------------------------------------------------------------
// Text helpers (shared with the `.bpt` reader)
// ---------------------------------------------------------------------------

/// Splits `bytes` into lines `(1-based number, text)`, dropping `\r` before `\n`.
/// Text that is not UTF-8 is an error naming its line.
pub(crate) fn text_lines<'a>(path: &Path, bytes: &'a [u8]) -> Result<Vec<(u32, &'a str)>> {
    let mut out = Vec::new();
    let mut rest = bytes;
    let mut line: u32 = 0;
    while !rest.is_empty() {
        line = line.saturating_add(1);
        let (l, r) = match rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        rest = r;
        let l = l.strip_suffix(b"\r").unwrap_or(l);
        let s = std::str::from_utf8(l).map_err(|e| {
            let col = String::from_utf8_lossy(&l[..e.valid_up_to()])
                .chars()
                .count()
                + 1;
            Error::input(
                path,
                Some(Pos {
                    line,
                    col: col.try_into().unwrap_or(u32::MAX),
                }),
                "not UTF-8 text",
            )
        })?;
        out.push((line, s));
    }
    Ok(out)
}

/// Whitespace-separated tokens of `line` with their 1-based (character) columns.
pub(crate) fn tokens(line: &str) -> Vec<(u32, &str)> {
    let mut out = Vec::new();
    let mut start: Option<(usize, u32)> = None;
    let mut col: u32 = 0;
    for (i, ch) in line.char_indices() {
        col = col.saturating_add(1);
        if ch.is_whitespace() {
            if let Some((s, c)) = start.take() {
                out.push((c, &line[s..i]));
            }
        } else if start.is_none() {
            start = Some((i, col));
        }
    }
    if let Some((s, c)) = start {
        out.push((c, &line[s..]));
    }
    out
}

/// Parses a finite `f32`; anything else is an error at `line:col`.
pub(crate) fn parse_finite(path: &Path, line: u32, col: u32, tok: &str) -> Result<f32> {
    let pos = Some(Pos { line, col });
    match tok.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(Error::input(
            path,
            pos,
            format!("'{tok}' is not a finite number"),
        )),
        Err(_) => Err(Error::input(path, pos, format!("'{tok}' is not a number"))),
    }
}

// ---------------------------------------------------------------------------
// Building the mesh
// ---------------------------------------------------------------------------

/// A mesh as read from a file, before triangulation and normals.
struct RawMesh {
    positions: Vec<Vec3>,
    /// Per-vertex normals given by the file (`None`: compute one).
    normals: Vec<Option<Vec3>>,
    /// Per-vertex uvs, or empty.
    uvs: Vec<Vec2>,
    /// Faces as vertex indices (each at least 3, all in range).
    faces: Vec<Vec<u32>>,
}

/// Fan-triangulates the faces (one patch each) and sets up the normals.
fn build_mesh(path: &Path, raw: RawMesh, face_normals: bool) -> Result<TriMesh> {
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

fn vertex_count_error(path: &Path) -> Error {
    Error::input(path, None, "more than 2^32 - 1 vertices")
}

// ---------------------------------------------------------------------------
// OBJ
// ---------------------------------------------------------------------------

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
fn parse_corner(
    path: &Path,
    line: u32,
    col: u32,
    tok: &str,
    counts: [usize; 3],
) -> Result<ObjCorner> {
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
    let lines = text_lines(path, &bytes)?;
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
        let numbers = |n: usize, what: &str| -> Result<Vec<f32>> {
            if args.len() < n {
                return Err(Error::input(
                    path,
                    Some(Pos { line, col: 1 }),
                    format!("'{kw}' needs {what}, found {} values", args.len()),
                ));
            }
            args[..n]
                .iter()
                .map(|&(col, t)| parse_finite(path, line, col, t))
                .collect()
        };
        match kw {
            "v" => {
                let x = numbers(3, "3 coordinates")?;
                pos.push(Vec3::new(x[0], x[1], x[2]));
            }
            "vn" => {
                let x = numbers(3, "3 coordinates")?;
                nor.push(Vec3::new(x[0], x[1], x[2]));
            }
            "vt" => {
                let x = numbers(1, "at least 1 coordinate")?;
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
                    let id =
                        u32::try_from(raw.positions.len()).map_err(|_| vertex_count_error(path))?;
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

// ---------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------

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
    fn set_property(
        &mut self,
        name: &str,
        property: Property,
    ) -> ply_rs_bw::ply::PropertyAccessResult {
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
    fn set_property(
        &mut self,
        name: &str,
        property: Property,
    ) -> ply_rs_bw::ply::PropertyAccessResult {
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
    let mut msg: String = text
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect::<String>()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
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
    let mut reader = Reader::new(&bytes[..]);
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
                        .ok_or_else(|| {
                            bad(format!(
                                "vertex index {i} out of range (only {nv} vertices)"
                            ))
                        })
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

// ---------------------------------------------------------------------------
// OBJ writer
// ---------------------------------------------------------------------------

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
    std::fs::write(path, s).map_err(|e| Error::io(path, e))
}
