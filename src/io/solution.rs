//! The solution file: the view-independent result of pass 1, saved once and reused
//! for any view (`radtrace solve`, `radtrace render --solution`).
//!
//! # Format (version 8: the solve settings gained `gathered`; version 7: a textured material's vertices hold radiosity made with the
//! texture's mean about each vertex, not over its patch; version 6: the caustic
//! part of the general radiosity, after it; version
//! 5: the solve statistics gained `reused_shots`; version 4: the
//! mesh leaves covered vertices out of its interpolation, and the solve settings
//! gained `max_photons`; version 3 gained `photons` and `time_limit`)
//!
//! All integers are little-endian.
//!
//! | offset | size | what |
//! | ---: | ---: | --- |
//! | 0 | 18 | magic: `RADTRACE-SOLUTION\n` |
//! | 18 | 4 | format version, `u32` (8; version 1 let radiant patches evict lights from the lists) |
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
//! its caustic part ([`Solution::caustic`]: the same, or an empty sequence),
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
use crate::scene::{BsdfKind, Fresnel, Light, Rgb, Scene};
use crate::{Error, Result};

/// The first bytes of every solution file.
pub const MAGIC: &[u8; 18] = b"RADTRACE-SOLUTION\n";

/// The format version this build writes and reads.
pub const FORMAT_VERSION: u32 = 8;

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
    caustic: &'a [Rgb],
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
    caustic: Vec<Rgb>,
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

    fn fresnel(&mut self, fresnel: &Fresnel) {
        match *fresnel {
            Fresnel::Conductor { eta, k } => {
                self.u8(0);
                self.vec3(eta);
                self.vec3(k);
            }
            Fresnel::Schlick { f0 } => {
                self.u8(1);
                self.vec3(f0);
            }
            Fresnel::Dielectric { eta } => {
                self.u8(2);
                self.f32(eta);
            }
        }
    }

    fn bsdf_kind(&mut self, kind: &BsdfKind) {
        match kind {
            BsdfKind::Diffuse { reflectance } => {
                self.u8(0);
                self.vec3(*reflectance);
            }
            BsdfKind::Conductor {
                specular_reflectance,
                fresnel,
            } => {
                self.u8(1);
                self.vec3(*specular_reflectance);
                self.fresnel(fresnel);
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
            BsdfKind::RoughConductor { lobe } => {
                self.u8(4);
                self.f32(lobe.distribution.alpha_u);
                self.f32(lobe.distribution.alpha_v);
                self.bool(lobe.distribution.beckmann);
                self.fresnel(&lobe.fresnel);
                self.vec3(lobe.scale);
            }
            BsdfKind::Dielectric {
                eta,
                specular_reflectance,
                specular_transmittance,
                thin,
                // (Pass 1 lets light through rough glass as through smooth.)
                rough: _,
            } => {
                self.u8(6);
                self.f32(*eta);
                self.vec3(*specular_reflectance);
                self.vec3(*specular_transmittance);
                self.bool(*thin);
            }
            BsdfKind::RoughPlastic {
                diffuse_reflectance,
                lobe,
                nonlinear,
                pplastic,
                ..
            } => {
                // The coating is made from the lobe. A `pplastic` (its own tag) may be
                // anisotropic; the rough plastics' fingerprints are as before it came.
                self.u8(if *pplastic { 7 } else { 5 });
                self.vec3(*diffuse_reflectance);
                self.f32(lobe.distribution.alpha_u);
                if *pplastic {
                    self.f32(lobe.distribution.alpha_v);
                }
                self.bool(lobe.distribution.beckmann);
                if let Fresnel::Dielectric { eta } = lobe.fresnel {
                    self.f32(eta);
                }
                self.vec3(lobe.scale);
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
            Light::Area { shape, radiance, .. } => {
                self.u8(2);
                self.u32(*shape);
                self.vec3(*radiance);
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                self.u8(3);
                self.vec3(*direction);
                self.vec3(*irradiance);
            }
            Light::Environment {
                radiance,
                texture,
                to_local,
            } => {
                self.u8(4);
                self.vec3(*radiance);
                self.u32(texture.map_or(u32::MAX, |t| t));
                for c in to_local.to_cols_array() {
                    self.f32(c);
                }
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
                Patch::Quadric { face, u, v } => {
                    h.u8(2);
                    h.u8(*face);
                    u.iter().chain(v).for_each(|&x| h.f32(x));
                }
            }
        }
        h.count(m.bezier.len());
        for b in &m.bezier {
            b.ctrl.iter().for_each(|&c| h.vec3(c));
            h.bool(b.flipped);
        }
        // (Only for meshes with an exact surface, so that the fingerprints of all
        // other scenes, and the solution files made for them, stay as they were.)
        if let Some(q) = &m.quadric {
            h.u8(u8::from(q.kind == crate::geometry::QuadricKind::Sphere));
            let w = q.to_world();
            [w.x_axis, w.y_axis, w.z_axis, w.w_axis]
                .iter()
                .for_each(|c| h.vec3(c.truncate()));
            h.bool(q.flipped);
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
    caustic: &[Rgb],
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
    if let Some(v) = caustic.iter().position(|c| !c.is_finite()) {
        return Some(format!("a non-finite caustic radiosity at vertex {v}"));
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
        &solution.caustic,
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
        && (solution.caustic.is_empty() || solution.caustic.len() == mesh.vertices.len())
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
        caustic: &solution.caustic,
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
        && (p.caustic.is_empty() || p.caustic.len() as u64 == p.vertex_count)
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
    if let Some(what) = non_finite(&p.settings, &p.general, &p.caustic, &p.lists, &p.stats) {
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
        caustic: p.caustic,
        lists: p.lists,
        stats: p.stats,
    })
}

#[cfg(test)]
mod tests;
