//! Mitsuba's `.serialized` meshes (file versions 3 and 4), as its `serialized` shape
//! reads them: a little-endian header (0x041C, version), then a zlib stream of flags,
//! (version 4) a name, the vertex and triangle counts, positions, optional normals,
//! (u, v) and colours (skipped), and the triangles; several meshes follow one another,
//! and the file ends with each mesh's offset and their count. The (u, v) are taken as
//! stored (Mitsuba flips OBJ's, not these).

use std::io::Read;
use std::path::Path;

use glam::{Vec2, Vec3};

use crate::geometry::trimesh_build::{build_mesh, RawMesh};
use crate::geometry::TriMesh;
use crate::{Error, Result};

const HEADER: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const DOUBLE_PRECISION: u32 = 0x2000;

/// Mesh `shape_index` of a `.serialized` file, from its contents `bytes`; `path` only
/// names the file in errors. (The scene loader reads each file's bytes once for all
/// the shapes it holds.)
pub fn parse_serialized(path: &Path, bytes: &[u8], shape_index: u32, face_normals: bool) -> Result<TriMesh> {
    let bad = |msg: String| Error::input(path, None, msg);
    let u16_at = |at: usize| bytes.get(at..at + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
    let u32_at = |at: usize| {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")))
    };
    let u64_at = |at: usize| {
        bytes
            .get(at..at + 8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
    };
    let header = |at: usize| -> Result<u16> {
        match (u16_at(at), u16_at(at + 2)) {
            (Some(HEADER), Some(v @ (3 | 4))) => Ok(v),
            (Some(HEADER), Some(v)) => Err(bad(format!(
                "serialized mesh of file version {v} (versions 3 and 4 are read)"
            ))),
            _ => Err(bad(format!(
                "not a Mitsuba .serialized mesh (no 0x041C header at byte {at})"
            ))),
        }
    };
    let version = header(0)?;
    let offset = if shape_index == 0 {
        0
    } else {
        let end = bytes.len();
        let count = end.checked_sub(4).and_then(u32_at).unwrap_or(0);
        if shape_index >= count {
            return Err(bad(format!(
                "shape_index = {shape_index}, but the file holds {count} mesh(es)"
            )));
        }
        let back = (count - shape_index) as usize;
        let offset = if version == 4 {
            end.checked_sub(4 + 8 * back).and_then(u64_at)
        } else {
            end.checked_sub(4 * (back + 1)).and_then(u32_at).map(u64::from)
        };
        let offset = offset
            .and_then(|o| usize::try_from(o).ok())
            .filter(|&o| o + 4 <= end);
        let offset =
            offset.ok_or_else(|| bad(format!("mesh {shape_index}'s offset lies outside the file")))?;
        header(offset)?;
        offset
    };
    let mut z = Stream {
        inner: flate2::read::ZlibDecoder::new(&bytes[offset + 4..]),
        path,
        mesh: shape_index,
    };
    let flags = z.u32()?;
    if version == 4 {
        // The mesh's name, null-terminated.
        let mut len = 0;
        while z.bytes::<1>()?[0] != 0 {
            len += 1;
            if len > 65536 {
                return Err(z.fail("a mesh name over 64 KiB"));
            }
        }
    }
    let vertices = z.u64()?;
    let triangles = z.u64()?;
    if vertices > u64::from(u32::MAX) {
        return Err(z.fail(&format!("{vertices} vertices (at most 2^32 - 1 are read)")));
    }
    let (n, double) = (vertices as usize, flags & DOUBLE_PRECISION != 0);
    let positions: Vec<Vec3> = z
        .reals(3 * n, double)?
        .chunks_exact(3)
        .map(Vec3::from_slice)
        .collect();
    let normals = if flags & HAS_NORMALS != 0 {
        z.reals(3 * n, double)?
            .chunks_exact(3)
            .map(|c| Some(Vec3::from_slice(c)))
            .collect()
    } else {
        vec![None; n]
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        z.reals(2 * n, double)?
            .chunks_exact(2)
            .map(Vec2::from_slice)
            .collect()
    } else {
        Vec::new()
    };
    if flags & HAS_COLORS != 0 {
        z.reals(3 * n, double)?;
    }
    let mut faces = Vec::with_capacity(triangles.min(1 << 16) as usize);
    for t in 0..triangles {
        let f = [z.u32()?, z.u32()?, z.u32()?];
        if let Some(&i) = f.iter().find(|&&i| i as usize >= n) {
            return Err(z.fail(&format!("triangle {t} names vertex {i} of {n}")));
        }
        faces.push(f.to_vec());
    }
    let raw = RawMesh {
        positions,
        normals,
        uvs,
        faces,
    };
    build_mesh(path, raw, face_normals || flags & FACE_NORMALS != 0)
}

/// The decompressed stream of one mesh.
struct Stream<'a, R> {
    inner: R,
    path: &'a Path,
    mesh: u32,
}

impl<R: Read> Stream<'_, R> {
    fn fail(&self, what: &str) -> Error {
        Error::input(self.path, None, format!("serialized mesh {}: {what}", self.mesh))
    }

    fn bytes<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        self.inner
            .read_exact(&mut b)
            .map_err(|e| self.fail(&format!("data ends early or is not zlib ({e})")))?;
        Ok(b)
    }

    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }

    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }

    /// `count` numbers, f32 or f64 in the file; growing as they are read, so a forged
    /// count ends at the data's end, not in an allocation.
    fn reals(&mut self, count: usize, double: bool) -> Result<Vec<f32>> {
        let mut out = Vec::with_capacity(count.min(1 << 16));
        for _ in 0..count {
            out.push(if double {
                f64::from_le_bytes(self.bytes()?) as f32
            } else {
                f32::from_le_bytes(self.bytes()?)
            });
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    /// One mesh of a `.serialized` file: header and zlib stream.
    fn mesh_bytes(version: u16, double: bool, uvs: bool, normals: bool) -> Vec<u8> {
        // A unit square in z = 0 from two triangles, and one more vertex unused.
        let pos = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [5.0, 5.0, 5.0],
        ];
        let mut data = Vec::new();
        let flags = (if double { DOUBLE_PRECISION } else { 0x1000 })
            | if uvs { HAS_TEXCOORDS } else { 0 }
            | if normals { HAS_NORMALS } else { 0 }
            | HAS_COLORS;
        data.extend(flags.to_le_bytes());
        if version == 4 {
            data.extend(b"square\0");
        }
        data.extend(5u64.to_le_bytes());
        data.extend(2u64.to_le_bytes());
        let mut reals = |v: &[f64]| {
            for &x in v {
                if double {
                    data.extend(x.to_le_bytes());
                } else {
                    data.extend((x as f32).to_le_bytes());
                }
            }
        };
        reals(&pos.concat());
        if normals {
            reals(&[[0.0, 0.0, 2.0]; 5].concat());
        }
        if uvs {
            reals(&[0.0, 0.0, 0.25, 0.0, 0.25, 0.75, 0.0, 0.75, 1.0, 1.0]);
        }
        reals(&[0.5; 15]);
        for i in [0u32, 1, 2, 0, 2, 3] {
            data.extend(i.to_le_bytes());
        }
        let mut out = Vec::new();
        out.extend(HEADER.to_le_bytes());
        out.extend(version.to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(out, flate2::Compression::default());
        z.write_all(&data).unwrap();
        z.finish().unwrap()
    }

    /// A file of the given meshes with its end-of-file dictionary.
    fn file(version: u16, meshes: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for m in meshes {
            offsets.push(out.len() as u64);
            out.extend(m);
        }
        for o in offsets {
            if version == 4 {
                out.extend(o.to_le_bytes());
            } else {
                out.extend((o as u32).to_le_bytes());
            }
        }
        out.extend((meshes.len() as u32).to_le_bytes());
        out
    }

    #[test]
    fn meshes_are_read_by_index_in_both_versions_and_precisions() {
        let p = Path::new("m.serialized");
        for version in [3, 4] {
            let bytes = file(
                version,
                &[
                    mesh_bytes(version, false, true, false),
                    mesh_bytes(version, true, false, true),
                ],
            );
            let a = parse_serialized(p, &bytes, 0, false).unwrap();
            assert_eq!(a.positions.len(), 5);
            assert_eq!(a.indices, vec![[0, 1, 2], [0, 2, 3]]);
            assert_eq!(a.patches.len(), 2);
            assert!((a.area() - 1.0).abs() < 1e-6);
            // (u, v) as stored, not flipped.
            assert_eq!(a.uvs[2], Vec2::new(0.25, 0.75));
            // No normals in the file: computed (+z for the square).
            assert!((a.normals[0] - Vec3::Z).length() < 1e-6);
            let b = parse_serialized(p, &bytes, 1, false).unwrap();
            assert!(b.uvs.is_empty());
            assert_eq!(b.positions[4], Vec3::splat(5.0));
            // Normals from the file, normalized.
            assert!((b.normals[3] - Vec3::Z).length() < 1e-6);
            let flat = parse_serialized(p, &bytes, 1, true).unwrap();
            assert!(flat.normals.is_empty());
        }
    }

    #[test]
    fn bad_files_are_errors_naming_the_problem() {
        let p = Path::new("m.serialized");
        let one = file(4, &[mesh_bytes(4, false, false, false)]);
        let msg = |b: &[u8], i: u32| parse_serialized(p, b, i, false).unwrap_err().to_string();
        assert!(msg(&one, 1).contains("holds 1 mesh"), "{}", msg(&one, 1));
        assert!(msg(b"PK\x03\x04junk", 0).contains("0x041C"));
        let mut v9 = one.clone();
        v9[2] = 9;
        assert!(msg(&v9, 0).contains("version 9"));
        let cut = &one[..one.len() / 2];
        assert!(msg(cut, 0).contains("ends early"), "{}", msg(cut, 0));
        // A triangle naming a vertex past the end.
        let mut data = mesh_bytes(3, false, false, false);
        let mut raw = Vec::new();
        flate2::read::ZlibDecoder::new(&data[4..])
            .read_to_end(&mut raw)
            .unwrap();
        let k = raw.len() - 4;
        raw[k..].copy_from_slice(&9u32.to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(data[..4].to_vec(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        data = z.finish().unwrap();
        assert!(msg(&data, 0).contains("names vertex 9"), "{}", msg(&data, 0));
    }
}
