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
use crate::geometry::{Patch, TriMesh, MAX_COORD};
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
            let col = String::from_utf8_lossy(&l[..e.valid_up_to()]).chars().count() + 1;
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

/// Parses a coordinate: a finite `f32` no larger than [`MAX_COORD`] in magnitude.
pub(crate) fn parse_coord(path: &Path, line: u32, col: u32, tok: &str) -> Result<f32> {
    let x = parse_finite(path, line, col, tok)?;
    if x.abs() > MAX_COORD {
        return Err(Error::input(
            path,
            Some(Pos { line, col }),
            format!("coordinate '{tok}' is absurdly large (at most {MAX_COORD:e})"),
        ));
    }
    Ok(x)
}

/// Parses a finite `f32`; anything else is an error at `line:col`.
pub(crate) fn parse_finite(path: &Path, line: u32, col: u32, tok: &str) -> Result<f32> {
    let pos = Some(Pos { line, col });
    match tok.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(Error::input(path, pos, format!("'{tok}' is not a finite number"))),
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
    crate::io::write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    use crate::testutil::{mesh_data as data, teapot_bpt};

    fn write(dir: &tempfile::TempDir, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

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

    /// Checks the things every cube [0,1]^3 made of 6 quads must satisfy.
    fn check_cube(m: &TriMesh) {
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
        assert!(matches!(write_obj(&meshes[1], &bad), Err(Error::Io { .. })));
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
