//! The solution file: the view-independent result of pass 1, saved once and reused
//! for any view (`radtrace solve`, `radtrace render --solution`).
//!
//! # Format (version 5: the solve statistics gained `reused_shots`; version 4: the
//! mesh leaves covered vertices out of its interpolation, and the solve settings
//! gained `max_photons`; version 3 gained `photons` and `time_limit`)
//!
//! All integers are little-endian.
//!
//! | offset | size | what |
//! | ---: | ---: | --- |
//! | 0 | 18 | magic: `RADTRACE-SOLUTION\n` |
//! | 18 | 4 | format version, `u32` (5; version 1 let radiant patches evict lights from the lists) |
//! | 22 | 8 | scene fingerprint, `u64` ([`scene_fingerprint`]) |
//! | 30 | 8 | payload length in bytes, `u64` |
//! | 38 | 4 | checksum, `u32`: CRC-32 (IEEE) of bytes 18..38 followed by the payload |
//! | 42 | n | payload |
//!
//! The checksum covers the version, fingerprint and length fields as well as the
//! payload, so any damaged byte after the magic is caught.
//!
//! The payload is the bincode 1.3 encoding (fixed-width little-endian integers,
//! sequences prefixed by a `u64` length, `f32`/`f64` as their IEEE bits, enums by a
//! `u32` variant index) of, in this order:
//! [`SolveSettings`], the general radiosity (one RGB `[f32; 3]` per mesh vertex),
//! the source lists (per patch, a sequence of [`ListEntry`]), [`SolveStats`], the
//! mesh's vertex count (`u64`) and its per-patch vertex counts (sequence of `u32`).
//!
//! The radiosity mesh itself is not stored: loading rebuilds it with
//! [`RadiosityMesh::build_covered`]`(scene, settings.mesh_size, accel)` (deterministic)
//! and refuses the file unless the vertex counts agree with what it says.
//!
//! # Loading
//!
//! [`load`] checks, in order: the magic, the version, the length and checksum, the
//! scene fingerprint, the decoding, the payload's internal structure, the rebuilt
//! mesh against the stored vertex counts, and finally the values (all finite, source
//! indices in range). Each refusal is one line naming the file. Nothing is allocated
//! beyond the file's own size: the file is read through its header first, at most
//! the declared payload length is read, and bincode decodes under a byte limit equal
//! to the payload length.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use bincode::Options;
use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::Xxh3Default;

use crate::accel::Accel;
use crate::geometry::Patch;
use crate::mesh::RadiosityMesh;
use crate::radiosity::{ListEntry, Solution, SolveSettings, SolveStats, SourceId};
use crate::scene::{BsdfKind, Light, Rgb, Scene};
use crate::{Error, Result};

/// The first bytes of every solution file.
pub const MAGIC: &[u8; 18] = b"RADTRACE-SOLUTION\n";

/// The format version this build writes and reads.
pub const FORMAT_VERSION: u32 = 5;

/// Bytes before the payload: magic, version, fingerprint, length, checksum.
const HEADER_LEN: usize = MAGIC.len() + 4 + 8 + 8 + 4;

/// Offset of the version field (the checksum covers `VERSION_AT..CHECKSUM_AT`).
const VERSION_AT: usize = MAGIC.len();
const FINGERPRINT_AT: usize = VERSION_AT + 4;
const LENGTH_AT: usize = FINGERPRINT_AT + 8;
const CHECKSUM_AT: usize = LENGTH_AT + 8;

/// The payload as written (borrowing the solution).
#[derive(Serialize)]
struct PayloadOut<'a> {
    settings: &'a SolveSettings,
    general: &'a [Rgb],
    lists: &'a [Vec<ListEntry>],
    stats: &'a SolveStats,
    vertex_count: u64,
    patch_vertex_counts: Vec<u32>,
}

/// The payload as read: the same fields in the same order as [`PayloadOut`].
#[derive(Deserialize)]
struct PayloadIn {
    settings: SolveSettings,
    general: Vec<Rgb>,
    lists: Vec<Vec<ListEntry>>,
    stats: SolveStats,
    vertex_count: u64,
    patch_vertex_counts: Vec<u32>,
}

/// The bincode options of the payload; `limit` bounds what decoding may consume
/// (and so allocate).
fn codec(limit: u64) -> impl Options {
    bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_little_endian()
        .reject_trailing_bytes()
        .with_limit(limit)
}

/// A stable 64-bit hash (XXH3) fed with explicitly encoded, length-prefixed fields,
/// so the value depends only on the data, not on the platform or Rust version.
struct Fingerprint(Xxh3Default);

impl Fingerprint {
    fn bytes(&mut self, b: &[u8]) {
        self.0.update(b);
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn count(&mut self, n: usize) {
        self.bytes(&(n as u64).to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    fn vec3(&mut self, v: glam::Vec3) {
        self.f32(v.x);
        self.f32(v.y);
        self.f32(v.z);
    }
    fn bool(&mut self, v: bool) {
        self.u8(u8::from(v));
    }

    fn bsdf_kind(&mut self, kind: &BsdfKind) {
        match kind {
            BsdfKind::Diffuse { reflectance } => {
                self.u8(0);
                self.vec3(*reflectance);
            }
            BsdfKind::Conductor { specular_reflectance } => {
                self.u8(1);
                self.vec3(*specular_reflectance);
            }
            BsdfKind::Plastic {
                diffuse_reflectance,
                specular_reflectance,
                eta,
                nonlinear,
            } => {
                self.u8(2);
                self.vec3(*diffuse_reflectance);
                self.vec3(*specular_reflectance);
                self.f32(*eta);
                self.bool(*nonlinear);
            }
            BsdfKind::Blend { weight, a, b } => {
                self.u8(3);
                self.f32(*weight);
                self.bsdf_kind(a);
                self.bsdf_kind(b);
            }
        }
    }

    fn light(&mut self, light: &Light) {
        match light {
            Light::Point { position, intensity } => {
                self.u8(0);
                self.vec3(*position);
                self.vec3(*intensity);
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cutoff_angle,
                beam_width,
            } => {
                self.u8(1);
                self.vec3(*position);
                self.vec3(*direction);
                self.vec3(*intensity);
                self.f32(*cutoff_angle);
                self.f32(*beam_width);
            }
            Light::Area { shape, radiance } => {
                self.u8(2);
                self.u32(*shape);
                self.vec3(*radiance);
            }
        }
    }
}

/// A fingerprint of everything in `scene` that the radiosity solution depends on
/// (geometry, materials, lights), so that a file made for another scene is refused.
///
/// Covered: each shape's positions, triangles, triangle-to-patch map, patches, Bezier
/// control points (and their orientation), material index and emitter index; each
/// material's reflection model and two-sidedness; each light, in order. Floats are
/// hashed by their bits. Not covered, because the solution does not depend on them:
/// names, the scene's path, shading normals, texture coordinates and the views.
pub fn scene_fingerprint(scene: &Scene) -> u64 {
    let mut h = Fingerprint(Xxh3Default::new());
    h.bytes(b"radtrace scene fingerprint 1");
    h.count(scene.shapes.len());
    for shape in &scene.shapes {
        let m = &shape.mesh;
        h.count(m.positions.len());
        for p in &m.positions {
            h.vec3(*p);
        }
        h.count(m.indices.len());
        for t in &m.indices {
            t.iter().for_each(|&i| h.u32(i));
        }
        h.count(m.tri_patch.len());
        m.tri_patch.iter().for_each(|&p| h.u32(p));
        h.count(m.patches.len());
        for p in &m.patches {
            match p {
                Patch::Polygon(idx) => {
                    h.u8(0);
                    h.count(idx.len());
                    idx.iter().for_each(|&i| h.u32(i));
                }
                Patch::Bezier { surface, u, v } => {
                    h.u8(1);
                    h.u32(*surface);
                    u.iter().chain(v).for_each(|&x| h.f32(x));
                }
            }
        }
        h.count(m.bezier.len());
        for b in &m.bezier {
            b.ctrl.iter().for_each(|&c| h.vec3(c));
            h.bool(b.flipped);
        }
        h.u32(shape.bsdf);
        match shape.emitter {
            None => h.u8(0),
            Some(e) => {
                h.u8(1);
                h.u32(e);
            }
        }
    }
    h.count(scene.bsdfs.len());
    for b in &scene.bsdfs {
        h.bsdf_kind(&b.kind);
        h.bool(b.twosided);
    }
    h.count(scene.lights.len());
    for l in &scene.lights {
        h.light(l);
    }
    h.0.digest()
}

/// The checksum of a file: CRC-32 of the version, fingerprint and length fields
/// followed by the payload.
fn checksum(header: &[u8], payload: &[u8]) -> u32 {
    let mut c = crc32fast::Hasher::new();
    c.update(&header[VERSION_AT..CHECKSUM_AT]);
    c.update(payload);
    c.finalize()
}

/// The header of a file whose payload is `len` bytes, with the checksum left 0.
fn header(version: u32, fingerprint: u64, len: u64, capacity: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(capacity);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&fingerprint.to_le_bytes());
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&[0; 4]);
    out
}

/// Fills in the checksum of a whole file (header then payload).
fn seal(file: &mut [u8]) {
    let sum = checksum(&file[..HEADER_LEN], &file[HEADER_LEN..]);
    file[CHECKSUM_AT..HEADER_LEN].copy_from_slice(&sum.to_le_bytes());
}

/// A whole file: header then `payload`.
#[cfg(test)]
fn encode_file(version: u32, fingerprint: u64, payload: &[u8]) -> Vec<u8> {
    let mut out = header(
        version,
        fingerprint,
        payload.len() as u64,
        HEADER_LEN + payload.len(),
    );
    out.extend_from_slice(payload);
    seal(&mut out);
    out
}

/// The first non-finite value in the solution's numbers, described.
fn non_finite(
    settings: &SolveSettings,
    general: &[Rgb],
    lists: &[Vec<ListEntry>],
    stats: &SolveStats,
) -> Option<String> {
    if !(settings.mesh_size.is_finite() && settings.tolerance.is_finite()) {
        return Some("a non-finite setting".into());
    }
    if ![stats.emitted_power, stats.residual, stats.time_s]
        .iter()
        .all(|x| x.is_finite())
    {
        return Some("a non-finite statistic".into());
    }
    if let Some(v) = general.iter().position(|c| !c.is_finite()) {
        return Some(format!("a non-finite general radiosity at vertex {v}"));
    }
    for (p, list) in lists.iter().enumerate() {
        for e in list {
            let bad = !e.power.is_finite() || e.occluded.iter().chain(&e.unoccluded).any(|c| !c.is_finite());
            if bad {
                return Some(format!("a non-finite value in the source list of patch {p}"));
            }
        }
    }
    None
}

/// Saves `solution` (computed for `scene`) to `path`, atomically.
///
/// Refuses (without writing) a solution holding non-finite numbers, which could
/// never be loaded again.
pub fn save(solution: &Solution, scene: &Scene, path: &Path) -> Result<()> {
    if let Some(what) = non_finite(
        &solution.settings,
        &solution.general,
        &solution.lists,
        &solution.stats,
    ) {
        return Err(Error::Usage(format!(
            "cannot write '{}': the solution has {what}",
            path.display()
        )));
    }
    let mesh = &solution.mesh;
    let fits = solution.general.len() == mesh.vertices.len()
        && solution.lists.len() == mesh.patches.len()
        && solution.lists.iter().zip(&mesh.patches).all(|(list, p)| {
            list.iter().all(|e| {
                e.occluded.len() == p.vertex_count as usize && e.unoccluded.len() == p.vertex_count as usize
            })
        });
    if !fits {
        return Err(Error::Usage(format!(
            "cannot write '{}': the solution's values do not fit its mesh",
            path.display()
        )));
    }
    let payload = PayloadOut {
        settings: &solution.settings,
        general: &solution.general,
        lists: &solution.lists,
        stats: &solution.stats,
        vertex_count: solution.mesh.vertices.len() as u64,
        patch_vertex_counts: solution.mesh.patches.iter().map(|p| p.vertex_count).collect(),
    };
    // Encoded straight behind the header: a large solution is held in memory once.
    let failed = |e: bincode::Error| {
        Error::Usage(format!(
            "cannot write '{}': encoding the solution failed: {e}",
            path.display()
        ))
    };
    let len = codec(u64::MAX).serialized_size(&payload).map_err(failed)?;
    let capacity = usize::try_from(len).map_or(0, |l| l.saturating_add(HEADER_LEN));
    let mut file = header(FORMAT_VERSION, scene_fingerprint(scene), len, capacity);
    codec(u64::MAX)
        .serialize_into(&mut file, &payload)
        .map_err(failed)?;
    seal(&mut file);
    super::write_atomic(path, &file)
}

/// Reads the header and at most the declared payload length (plus one byte, to
/// notice extra data) of `file`, named `path` in errors.
fn read_file(path: &Path, mut file: impl Read) -> Result<([u8; HEADER_LEN], Vec<u8>)> {
    let bad = |msg: String| Error::input(path, None, msg);
    let mut head = Vec::with_capacity(HEADER_LEN);
    (&mut file)
        .take(HEADER_LEN as u64)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, e))?;

    // Magic.
    let m = head.len().min(MAGIC.len());
    if head[..m] != MAGIC[..m] || head.is_empty() {
        let what = if head.is_empty() { "an empty file, " } else { "" };
        return Err(bad(format!("{what}not a radtrace solution file")));
    }
    if head.len() < VERSION_AT + 4 {
        return Err(bad(format!(
            "damaged: truncated ({} bytes, the header alone is {HEADER_LEN})",
            head.len()
        )));
    }
    // Version.
    let version = u32::from_le_bytes(head[VERSION_AT..VERSION_AT + 4].try_into().expect("4 bytes"));
    if version != FORMAT_VERSION {
        return Err(bad(format!(
            "made by another version of radtrace (format {version}, this one reads {FORMAT_VERSION})"
        )));
    }
    let Ok(head) = <[u8; HEADER_LEN]>::try_from(head.as_slice()) else {
        return Err(bad(format!(
            "damaged: truncated ({} bytes, the header alone is {HEADER_LEN})",
            head.len()
        )));
    };
    // Length: read no more than it says, plus one byte to notice a longer file.
    let len = u64::from_le_bytes(head[LENGTH_AT..LENGTH_AT + 8].try_into().expect("8 bytes"));
    let mut payload = Vec::new();
    file.take(len.saturating_add(1))
        .read_to_end(&mut payload)
        .map_err(|e| Error::io(path, e))?;
    let got = payload.len() as u64;
    if got < len {
        return Err(bad(format!(
            "damaged: truncated (payload is {got} bytes of the {len} the header says)"
        )));
    }
    if got > len {
        return Err(bad(format!(
            "damaged: longer than its header says ({len} payload bytes)"
        )));
    }
    Ok((head, payload))
}

/// Loads a solution for `scene` from `path`: refuses a file that is not a solution
/// file, of another version, damaged (checksum), or made for another scene.
pub fn load(path: &Path, scene: &Scene, accel: &dyn Accel) -> Result<Solution> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    load_from(path, file, scene, accel)
}

/// [`load`] from a reader (the file's contents); `path` only names the file in errors.
pub fn load_from(path: &Path, reader: impl Read, scene: &Scene, accel: &dyn Accel) -> Result<Solution> {
    let bad = |msg: String| Error::input(path, None, msg);
    let (head, payload) = read_file(path, reader)?;

    // Checksum.
    let stored = u32::from_le_bytes(head[CHECKSUM_AT..HEADER_LEN].try_into().expect("4 bytes"));
    if checksum(&head, &payload) != stored {
        return Err(bad("damaged: checksum mismatch".into()));
    }

    // Scene.
    let fingerprint = u64::from_le_bytes(head[FINGERPRINT_AT..LENGTH_AT].try_into().expect("8 bytes"));
    if fingerprint != scene_fingerprint(scene) {
        return Err(bad(
            "was computed for another scene (or the scene changed since): run `radtrace solve` again".into(),
        ));
    }

    // Decoding, bounded by the payload's own size.
    let p: PayloadIn = codec(payload.len() as u64)
        .deserialize(&payload)
        .map_err(|e| bad(format!("damaged: cannot decode the solution: {e}")))?;

    // Internal structure.
    let patches = p.patch_vertex_counts.len();
    let structure_ok = p.general.len() as u64 == p.vertex_count
        && p.lists.len() == patches
        && p.patch_vertex_counts.iter().map(|&c| u64::from(c)).sum::<u64>() == p.vertex_count
        && p.lists.iter().zip(&p.patch_vertex_counts).all(|(list, &count)| {
            list.iter()
                .all(|e| e.occluded.len() == count as usize && e.unoccluded.len() == count as usize)
        });
    if !structure_ok {
        return Err(bad(
            "damaged: the radiosity values do not fit the mesh the file describes".into(),
        ));
    }
    if !(p.settings.mesh_size.is_finite() && p.settings.mesh_size > 0.0) {
        return Err(bad(format!(
            "damaged: invalid mesh size {}",
            p.settings.mesh_size
        )));
    }

    // The mesh, rebuilt, once its size is known to be the one the file describes
    // (a forged tiny mesh size must not make us build a gigantic mesh first).
    let estimate = RadiosityMesh::estimate_vertices(scene, p.settings.mesh_size);
    if estimate > 1e9 && estimate > 16.0 * p.vertex_count as f64 {
        return Err(bad(format!(
            "was computed on another radiosity mesh ({} vertices; this radtrace would make about {estimate:.0} at mesh size {}): run `radtrace solve` again",
            p.vertex_count, p.settings.mesh_size
        )));
    }
    let mesh = RadiosityMesh::build_covered(scene, p.settings.mesh_size, accel);
    let fits = mesh.vertices.len() as u64 == p.vertex_count
        && mesh.patches.len() == patches
        && mesh
            .patches
            .iter()
            .zip(&p.patch_vertex_counts)
            .all(|(mp, &c)| mp.vertex_count == c);
    if !fits {
        return Err(bad(format!(
            "was computed on another radiosity mesh ({} vertices in {} patches; \
             this radtrace makes {} vertices in {} patches at mesh size {}): run `radtrace solve` again",
            p.vertex_count,
            patches,
            mesh.vertices.len(),
            mesh.patches.len(),
            p.settings.mesh_size
        )));
    }

    // Values.
    if let Some(what) = non_finite(&p.settings, &p.general, &p.lists, &p.stats) {
        return Err(bad(format!("damaged: {what}")));
    }
    let source_ok = |s: &SourceId| match *s {
        SourceId::Light(l) => (l as usize) < scene.lights.len(),
        SourceId::Patch(q) => (q as usize) < patches,
    };
    if let Some(q) = p
        .lists
        .iter()
        .position(|list| !list.iter().all(|e| source_ok(&e.source)))
    {
        return Err(bad(format!(
            "damaged: the source list of patch {q} names a source the scene does not have"
        )));
    }

    Ok(Solution {
        mesh,
        settings: p.settings,
        general: p.general,
        lists: p.lists,
        stats: p.stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Bvh;
    use crate::geometry::{shapes, BezierPatch, TriMesh};
    use crate::scene::{Bsdf, Sensor, Shape};
    use glam::Vec3;
    use proptest::prelude::*;
    use std::fs;
    use std::sync::OnceLock;

    fn settings() -> SolveSettings {
        SolveSettings {
            mesh_size: 0.5,
            sources_per_patch: 2,
            shoot_samples: 4,
            tolerance: 0.05,
            max_shots: 50,
            seed: 1,
            photons: 0,
            max_photons: 0,
            time_limit: 0.0,
        }
    }

    /// A square of half-size `s` at height `z`, facing up (+z).
    fn square(s: f32, z: f32) -> TriMesh {
        TriMesh {
            positions: vec![
                Vec3::new(-s, -s, z),
                Vec3::new(s, -s, z),
                Vec3::new(s, s, z),
                Vec3::new(-s, s, z),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            tri_patch: vec![0, 0],
            patches: vec![Patch::Polygon(vec![0, 1, 2, 3])],
            ..Default::default()
        }
    }

    /// A closed box `[-1,1]^3` facing inwards (six quads, grey), a small white
    /// square table inside and a point light above it.
    fn box_scene() -> Scene {
        let mut walls = shapes::cube();
        walls.flip_normals();
        Scene {
            path: "box.xml".into(),
            shapes: vec![
                Shape {
                    name: "walls".into(),
                    mesh: walls,
                    bsdf: 0,
                    emitter: None,
                },
                Shape {
                    name: "table".into(),
                    mesh: square(0.3, -0.5),
                    bsdf: 1,
                    emitter: None,
                },
            ],
            bsdfs: vec![
                Bsdf {
                    name: "grey".into(),
                    kind: BsdfKind::Diffuse {
                        reflectance: Vec3::new(0.5, 0.4, 0.3),
                    },
                    twosided: false,
                },
                Bsdf {
                    name: "white".into(),
                    kind: BsdfKind::Diffuse {
                        reflectance: Vec3::splat(0.8),
                    },
                    twosided: true,
                },
            ],
            lights: vec![Light::Point {
                position: Vec3::new(0.1, 0.2, 0.6),
                intensity: Vec3::new(3.0, 2.0, 1.0),
            }],
            light_ids: vec![],
            sensors: vec![],
        }
    }

    fn load_for(path: &Path, scene: &Scene) -> Result<Solution> {
        load(path, scene, &Bvh::build(scene))
    }

    /// The box scene and its solution, computed once for all tests.
    fn solved() -> &'static (Scene, Solution) {
        static SOLVED: OnceLock<(Scene, Solution)> = OnceLock::new();
        SOLVED.get_or_init(|| {
            let scene = box_scene();
            let sol =
                crate::radiosity::solve(&scene, &Bvh::build(&scene), &settings(), &crate::progress::Silent)
                    .unwrap();
            (scene, sol)
        })
    }

    fn tmpdir() -> tempfile::TempDir {
        tempfile::tempdir().unwrap()
    }

    /// The box solution saved to a fresh file: (dir, path, bytes).
    fn saved(name: &str) -> (tempfile::TempDir, std::path::PathBuf, Vec<u8>) {
        let (scene, sol) = solved();
        let dir = tmpdir();
        let path = dir.path().join(name);
        save(sol, scene, &path).unwrap();
        let bytes = fs::read(&path).unwrap();
        (dir, path, bytes)
    }

    /// Loading `bytes` (written to a file named `name`) for the box scene must fail;
    /// returns the message after checking that it names the file.
    fn load_err(dir: &Path, name: &str, bytes: &[u8]) -> String {
        let path = dir.join(name);
        fs::write(&path, bytes).unwrap();
        let Err(err) = load_for(&path, &solved().0) else {
            panic!("{name} was accepted");
        };
        assert!(matches!(err, Error::Input { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.starts_with(&format!("{}: ", path.display())), "{msg}");
        msg
    }

    /// A payload encoded as `save` does, from parts (to forge files in tests).
    fn payload(
        settings: &SolveSettings,
        general: &[Rgb],
        lists: &[Vec<ListEntry>],
        stats: &SolveStats,
        vertex_count: u64,
        patch_vertex_counts: Vec<u32>,
    ) -> Vec<u8> {
        codec(u64::MAX)
            .serialize(&PayloadOut {
                settings,
                general,
                lists,
                stats,
                vertex_count,
                patch_vertex_counts,
            })
            .unwrap()
    }

    fn counts(sol: &Solution) -> Vec<u32> {
        sol.mesh.patches.iter().map(|p| p.vertex_count).collect()
    }

    /// A well-formed file for the box scene with the given payload.
    fn forged(payload: &[u8]) -> Vec<u8> {
        encode_file(FORMAT_VERSION, scene_fingerprint(&solved().0), payload)
    }

    #[test]
    fn the_test_solution_is_not_trivial() {
        let (scene, sol) = solved();
        // 6 walls of 2x2 at mesh size 0.5: 4x4 quads, 25 vertices each; the table
        // (0.6 wide) 2x2 quads, 9 vertices.
        // The table is two-sided, so it has a back twin with 9 more vertices.
        assert_eq!(sol.mesh.patches.len(), 8);
        assert_eq!(sol.mesh.vertices.len(), 6 * 25 + 9 + 9);
        assert_eq!(sol.general.len(), 168);
        assert_eq!(sol.stats.light_shots, 1);
        assert!(sol.stats.patch_shots > 0);
        assert!(sol.lists.iter().all(|l| !l.is_empty() && l.len() <= 2));
        assert!(sol.lists.iter().flatten().any(|e| e.source == SourceId::Light(0)));
        assert!(sol.general.iter().any(|c| c.x > 0.0));
        assert_eq!(scene.lights.len(), 1);
    }

    #[test]
    fn round_trip_gives_the_same_solution() {
        let (scene, sol) = solved();
        let (_dir, path, bytes) = saved("box.rts");
        let back = load_for(&path, scene).unwrap();
        assert_eq!(back.settings, sol.settings);
        assert_eq!(back.stats, sol.stats);
        assert_eq!(back.lists, sol.lists);
        assert_eq!(back.general.len(), sol.general.len());
        for (a, b) in back.general.iter().zip(&sol.general) {
            assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
        }
        assert_eq!(back.mesh, sol.mesh);
        assert_eq!(back.total(), sol.total());

        // The header, field by field.
        assert_eq!(&bytes[..18], b"RADTRACE-SOLUTION\n");
        assert_eq!(&bytes[18..22], &[5, 0, 0, 0]);
        assert_eq!(
            u64::from_le_bytes(bytes[22..30].try_into().unwrap()),
            scene_fingerprint(scene)
        );
        let len = u64::from_le_bytes(bytes[30..38].try_into().unwrap());
        assert_eq!(len as usize, bytes.len() - 42);
        let mut crc = crc32fast::Hasher::new();
        crc.update(&bytes[18..38]);
        crc.update(&bytes[42..]);
        assert_eq!(
            u32::from_le_bytes(bytes[38..42].try_into().unwrap()),
            crc.finalize()
        );
        // The payload opens with the settings: mesh size 0.5 as f32 bits, n = 2...
        assert_eq!(&bytes[42..46], &0.5f32.to_le_bytes());
        assert_eq!(&bytes[46..50], &2u32.to_le_bytes());
        // ...followed (after the 44 bytes of settings) by the vertex count of general.
        assert_eq!(&bytes[86..94], &168u64.to_le_bytes());

        // Saving again replaces the file with the same bytes (deterministic).
        save(sol, scene, &path).unwrap();
        assert_eq!(fs::read(&path).unwrap(), bytes);
    }

    #[test]
    fn fingerprint_is_stable_and_sees_what_matters() {
        let scene = box_scene();
        let fp = scene_fingerprint(&scene);
        assert_eq!(fp, scene_fingerprint(&scene.clone()));
        assert_eq!(fp, scene_fingerprint(&box_scene()));
        // Pinned (on a scene made here only, so other modules' shapes can't move it)
        // so that an accidental change to the hashing, which would refuse every
        // existing file, is noticed.
        let mut small = scene.clone();
        small.shapes.remove(0);
        small.shapes[0].bsdf = 0;
        small.bsdfs.truncate(1);
        assert_eq!(
            scene_fingerprint(&small),
            16_009_516_134_389_156_963,
            "the fingerprint function changed"
        );

        // Names, the path, shading normals and views do not matter.
        let mut same = scene.clone();
        same.path = "elsewhere/other.xml".into();
        same.shapes[0].name = "renamed".into();
        same.bsdfs[1].name = "renamed".into();
        same.shapes[1].mesh.normals = vec![Vec3::Z; 4];
        same.sensors.push(Sensor {
            to_world: glam::Mat4::IDENTITY,
            fov: 45.0,
            fov_axis: crate::scene::FovAxis::X,
            width: 8,
            height: 8,
            near_clip: 0.01,
            far_clip: 100.0,
            spp: None,
        });
        assert_eq!(scene_fingerprint(&same), fp);

        let differs = |f: &dyn Fn(&mut Scene)| {
            let mut s = scene.clone();
            f(&mut s);
            let g = scene_fingerprint(&s);
            assert_ne!(g, fp);
            g
        };
        let mut all = vec![
            differs(&|s| s.shapes[0].mesh.positions[5].y += 1e-3),
            differs(&|s| {
                s.shapes[1].mesh.positions[0].x =
                    f32::from_bits(s.shapes[1].mesh.positions[0].x.to_bits() + 1)
            }),
            differs(&|s| s.shapes[0].mesh.indices[3].swap(0, 1)),
            differs(&|s| s.shapes[0].mesh.tri_patch[0] = 1),
            differs(&|s| {
                if let Patch::Polygon(v) = &mut s.shapes[0].mesh.patches[2] {
                    v.rotate_left(1);
                }
            }),
            differs(&|s| {
                s.bsdfs[0].kind = BsdfKind::Diffuse {
                    reflectance: Vec3::new(0.5, 0.4, 0.31),
                }
            }),
            differs(&|s| {
                s.bsdfs[0].kind = BsdfKind::Conductor {
                    specular_reflectance: Vec3::new(0.5, 0.4, 0.3),
                }
            }),
            differs(&|s| s.bsdfs[1].twosided = false),
            differs(&|s| s.shapes[1].bsdf = 0),
            differs(&|s| {
                s.lights[0] = Light::Point {
                    position: Vec3::new(0.1, 0.2, 0.6),
                    intensity: Vec3::new(3.0, 2.0, 1.5),
                }
            }),
            differs(&|s| {
                s.lights[0] = Light::Point {
                    position: Vec3::new(0.1, 0.2, 0.61),
                    intensity: Vec3::new(3.0, 2.0, 1.0),
                }
            }),
            differs(&|s| {
                s.lights.push(Light::Area {
                    shape: 1,
                    radiance: Vec3::ONE,
                });
                s.shapes[1].emitter = Some(1);
            }),
            // Moving a shape's data into another shape is a different scene too.
            differs(&|s| {
                let table = s.shapes.pop().unwrap();
                s.shapes[0].mesh.append(&table.mesh);
            }),
        ];
        // Bezier patches: control points and orientation.
        let mut bez = scene.clone();
        bez.shapes[1].mesh.bezier.push(BezierPatch {
            ctrl: [Vec3::ZERO; 16],
            flipped: false,
        });
        let base = scene_fingerprint(&bez);
        let mut moved = bez.clone();
        moved.shapes[1].mesh.bezier[0].ctrl[7].z = 0.25;
        let mut flipped = bez.clone();
        flipped.shapes[1].mesh.bezier[0].flipped = true;
        all.extend([base, scene_fingerprint(&moved), scene_fingerprint(&flipped)]);
        all.push(fp);
        let n = all.len();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), n, "two different scenes got one fingerprint");
    }

    #[test]
    fn any_damaged_byte_is_refused() {
        let (dir, _path, bytes) = saved("box.rts");
        let n = bytes.len();
        // Every byte of the header after the magic, and a spread of payload bytes
        // including the first and the last.
        let mut at: Vec<usize> = (18..42).collect();
        at.extend((42..n).step_by(97));
        at.push(n - 1);
        for i in at {
            let mut b = bytes.clone();
            b[i] ^= 0x10;
            let msg = load_err(dir.path(), "flipped.rts", &b);
            let expected = match i {
                18..=21 => "made by another version",
                30..=37 => "damaged",
                _ => "damaged: checksum mismatch",
            };
            assert!(msg.contains(expected), "byte {i}: {msg}");
        }
    }

    #[test]
    fn truncated_or_extended_files_are_refused() {
        let (dir, _path, bytes) = saved("box.rts");
        let n = bytes.len();
        for cut in [5, 18, 20, 22, 30, 41, 42, 43, n / 2, n - 1] {
            let msg = load_err(dir.path(), "cut.rts", &bytes[..cut]);
            assert!(msg.contains("damaged: truncated"), "cut at {cut}: {msg}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        let msg = load_err(dir.path(), "long.rts", &longer);
        assert!(msg.contains("damaged: longer than its header says"), "{msg}");
    }

    #[test]
    fn other_files_are_not_solution_files() {
        let dir = tmpdir();
        for (name, bytes) in [
            ("empty.rts", &b""[..]),
            ("png.rts", &[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a][..]),
            ("text.rts", &b"<scene version=\"3.0.0\"/>\n"[..]),
            ("lower.rts", &b"radtrace-solution\n\x01\0\0\0"[..]),
        ] {
            let msg = load_err(dir.path(), name, bytes);
            assert!(msg.ends_with("not a radtrace solution file"), "{msg}");
        }
        // Another magic in front of an otherwise valid file.
        let (dir, _path, mut bytes) = saved("box.rts");
        bytes[9] = b'X';
        let msg = load_err(dir.path(), "magic.rts", &bytes);
        assert!(msg.ends_with(": not a radtrace solution file"), "{msg}");
    }

    #[test]
    fn another_version_is_refused_by_number() {
        let (dir, _path, mut bytes) = saved("box.rts");
        // Version 3 files (covered vertices interpolated like the rest) are refused.
        bytes[18..22].copy_from_slice(&3u32.to_le_bytes());
        let msg = load_err(dir.path(), "v3.rts", &bytes);
        assert!(
            msg.ends_with("made by another version of radtrace (format 3, this one reads 5)"),
            "{msg}"
        );
        // Even with nothing after the version field.
        let msg = load_err(dir.path(), "v7.rts", &[&MAGIC[..], &7u32.to_le_bytes()].concat());
        assert!(msg.contains("(format 7, this one reads 5)"), "{msg}");
    }

    #[test]
    fn a_file_for_another_scene_is_refused() {
        let (_dir, path, _bytes) = saved("box.rts");
        let mut other = box_scene();
        other.shapes[0].mesh.positions[0].x -= 0.01;
        let err = load_for(&path, &other).unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        assert!(
            msg.ends_with(
                "was computed for another scene (or the scene changed since): run `radtrace solve` again"
            ),
            "{msg}"
        );
        // A wholly different scene.
        let mut b = box_scene();
        b.shapes.truncate(1);
        b.lights[0] = Light::Point {
            position: Vec3::ZERO,
            intensity: Vec3::ONE,
        };
        assert!(load_for(&path, &b)
            .unwrap_err()
            .to_string()
            .contains("another scene"));
    }

    #[test]
    fn a_file_on_another_mesh_is_refused() {
        let (_, sol) = solved();
        let dir = tmpdir();
        let (st, g, l, ss) = (&sol.settings, &sol.general, &sol.lists, &sol.stats);
        // The same values, claimed for mesh size 0.25: the rebuilt mesh is finer.
        let finer = SolveSettings {
            mesh_size: 0.25,
            ..*st
        };
        let msg = load_err(
            dir.path(),
            "finer.rts",
            &forged(&payload(&finer, g, l, ss, 168, counts(sol))),
        );
        assert!(
            msg.contains("was computed on another radiosity mesh (168 vertices in")
                && msg.contains("this radtrace makes 518 vertices")
                && msg.contains("run `radtrace solve` again"),
            "{msg}"
        );
        // Per-patch counts that do not match (the total does).
        let mut c = counts(sol);
        c[0] += 1;
        c[1] -= 1;
        let mut lists = l.clone();
        for (k, list) in lists.iter_mut().enumerate().take(2) {
            for e in list {
                e.occluded.resize(c[k] as usize, Vec3::ZERO);
                e.unoccluded.resize(c[k] as usize, Vec3::ZERO);
            }
        }
        let msg = load_err(
            dir.path(),
            "shifted.rts",
            &forged(&payload(st, g, &lists, ss, 168, c)),
        );
        assert!(msg.contains("another radiosity mesh"), "{msg}");
        // The values do not fit the counts the file itself gives.
        let msg = load_err(
            dir.path(),
            "short.rts",
            &forged(&payload(st, &g[1..], l, ss, 168, counts(sol))),
        );
        assert!(msg.contains("damaged: the radiosity values do not fit"), "{msg}");
        let msg = load_err(
            dir.path(),
            "lists.rts",
            &forged(&payload(st, g, &l[1..], ss, 168, counts(sol))),
        );
        assert!(msg.contains("damaged: the radiosity values do not fit"), "{msg}");
    }

    #[test]
    fn bad_values_are_damage() {
        let (_, sol) = solved();
        let dir = tmpdir();
        let (st, g, l, ss) = (&sol.settings, &sol.general, &sol.lists, &sol.stats);
        let mut nan = g.clone();
        nan[17].y = f32::NAN;
        let msg = load_err(
            dir.path(),
            "nan.rts",
            &forged(&payload(st, &nan, l, ss, 168, counts(sol))),
        );
        assert!(
            msg.ends_with("damaged: a non-finite general radiosity at vertex 17"),
            "{msg}"
        );
        let mut inf = l.clone();
        inf[3][0].unoccluded[2].x = f32::INFINITY;
        let msg = load_err(
            dir.path(),
            "inf.rts",
            &forged(&payload(st, g, &inf, ss, 168, counts(sol))),
        );
        assert!(
            msg.ends_with("damaged: a non-finite value in the source list of patch 3"),
            "{msg}"
        );
        let stats = SolveStats {
            residual: f64::NAN,
            ..*ss
        };
        let msg = load_err(
            dir.path(),
            "stats.rts",
            &forged(&payload(st, g, l, &stats, 168, counts(sol))),
        );
        assert!(msg.contains("damaged: a non-finite statistic"), "{msg}");
        for size in [0.0, -0.5, f32::NAN, f32::INFINITY] {
            let s = SolveSettings {
                mesh_size: size,
                ..*st
            };
            let msg = load_err(
                dir.path(),
                "size.rts",
                &forged(&payload(&s, g, l, ss, 168, counts(sol))),
            );
            assert!(msg.contains("damaged: invalid mesh size"), "{msg}");
        }
        let mut src = l.clone();
        src[5][0].source = SourceId::Light(1);
        let msg = load_err(
            dir.path(),
            "light.rts",
            &forged(&payload(st, g, &src, ss, 168, counts(sol))),
        );
        assert!(
            msg.contains("the source list of patch 5 names a source the scene does not have"),
            "{msg}"
        );
        src[5][0].source = SourceId::Patch(8);
        let msg = load_err(
            dir.path(),
            "patch.rts",
            &forged(&payload(st, g, &src, ss, 168, counts(sol))),
        );
        assert!(msg.contains("patch 5 names a source"), "{msg}");
        // Trailing bytes inside the payload, and a payload cut short.
        let mut p = payload(st, g, l, ss, 168, counts(sol));
        p.push(0);
        let msg = load_err(dir.path(), "trail.rts", &forged(&p));
        assert!(msg.contains("damaged: cannot decode"), "{msg}");
        p.truncate(p.len() - 9);
        let msg = load_err(dir.path(), "cut.rts", &forged(&p));
        assert!(msg.contains("damaged: cannot decode"), "{msg}");
    }

    #[test]
    fn absurd_lengths_are_refused_without_allocating() {
        let dir = tmpdir();
        let st = solved().1.settings;
        // Settings, then a general radiosity "of 2^60 vertices".
        let mut p = codec(u64::MAX).serialize(&st).unwrap();
        p.extend_from_slice(&(1u64 << 60).to_le_bytes());
        p.extend_from_slice(&[0; 64]);
        let msg = load_err(dir.path(), "huge.rts", &forged(&p));
        assert!(msg.contains("damaged: cannot decode"), "{msg}");
        // A header claiming an exabyte of payload, with a few bytes of it.
        let mut f = forged(&[1, 2, 3]);
        f[30..38].copy_from_slice(&(1u64 << 60).to_le_bytes());
        let msg = load_err(dir.path(), "exa.rts", &f);
        assert!(
            msg.contains("damaged: truncated (payload is 3 bytes of the 1152921504606846976"),
            "{msg}"
        );
    }

    #[test]
    fn io_errors_name_the_file() {
        let (scene, sol) = solved();
        let dir = tmpdir();
        let missing = dir.path().join("missing.rts");
        let err = load_for(&missing, scene).unwrap_err();
        assert!(matches!(err, Error::Io { .. }));
        assert!(err.to_string().contains("missing.rts"));
        let nowhere = dir.path().join("no/such/dir/x.rts");
        let err = save(sol, scene, &nowhere).unwrap_err();
        assert!(matches!(err, Error::Output { .. }));
        assert!(err.to_string().contains("no/such/dir/x.rts"));
        // A directory is not a solution file either.
        assert!(load_for(dir.path(), scene).is_err());
    }

    #[test]
    fn a_solution_with_non_finite_values_is_not_saved() {
        let (scene, sol) = solved();
        let dir = tmpdir();
        let path = dir.path().join("nan.rts");
        let mut bad = sol.clone();
        bad.general[3].z = f32::NAN;
        let err = save(&bad, scene, &path).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("nan.rts") && msg.contains("non-finite general radiosity at vertex 3"),
            "{msg}"
        );
        assert!(!path.exists());
        let mut short = sol.clone();
        short.lists[2][0].occluded.pop();
        let msg = save(&short, scene, &path).unwrap_err().to_string();
        assert!(
            msg.contains("nan.rts") && msg.contains("values do not fit its mesh"),
            "{msg}"
        );
        assert!(!path.exists());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]

        /// Random bytes, bare or behind the magic and version, are refused.
        #[test]
        fn random_bytes_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..600), prefix in 0..3u8) {
            let dir = tmpdir();
            let file = match prefix {
                0 => bytes.clone(),
                1 => [&MAGIC[..], &1u32.to_le_bytes(), &bytes].concat(),
                _ => forged(&bytes),
            };
            let path = dir.path().join("random.rts");
            fs::write(&path, &file).unwrap();
            let err = load_for(&path, &solved().0).unwrap_err();
            prop_assert!(err.to_string().contains("random.rts"));
        }

        /// Random damage to a real file (a few bytes overwritten) is refused.
        #[test]
        fn random_damage_is_refused(edits in proptest::collection::vec((any::<prop::sample::Index>(), 1..=255u8), 1..4)) {
            let (dir, _path, mut bytes) = saved("box.rts");
            let original = bytes.clone();
            for (i, x) in edits {
                let k = 18 + i.index(bytes.len() - 18);
                bytes[k] ^= x;
            }
            prop_assume!(bytes != original);
            let path = dir.path().join("edited.rts");
            fs::write(&path, &bytes).unwrap();
            prop_assert!(load_for(&path, &solved().0).is_err());
        }
    }
}
