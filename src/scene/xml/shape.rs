//! Shape plugins: `obj`, `ply`, `serialized`, `bezier` (radtrace's `.bpt` files), `rectangle`,
//! `cube`, `disk`, `sphere` and `cylinder`, with their bsdf and area emitter; `shapegroup`,
//! `instance` and `merge`.

use std::collections::HashMap;
use std::path::PathBuf;

use glam::{Mat3, Mat4, Vec3};
use rayon::prelude::*;
use roxmltree::Node;

use super::document::{child_value, tag, Loader, Src};
use super::parse;
use super::properties::{Child, Target};
use crate::error::Error;
use crate::geometry::obj::parse_obj;
use crate::geometry::ply::parse_ply;
use crate::geometry::serialized::parse_serialized;
use crate::geometry::{bezier, shapes, TriMesh};
use crate::scene::{Light, Rgb, Shape};
use crate::Result;

/// The mesh file formats a shape reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum MeshFormat {
    Obj,
    Ply,
    Serialized,
}

/// A mesh as a shape reads it from a file: the file, its format, `face_normals`
/// and (in a `serialized` file) `shape_index`.
pub(super) type MeshKey = (PathBuf, MeshFormat, bool, u32);

/// The mesh `key` names, from the file's contents `bytes`.
fn parse_mesh(key: &MeshKey, bytes: &[u8]) -> Result<TriMesh> {
    let (path, format, face_normals, index) = key;
    match format {
        MeshFormat::Obj => parse_obj(path, bytes, *face_normals),
        MeshFormat::Ply => parse_ply(path, bytes, *face_normals),
        MeshFormat::Serialized => parse_serialized(path, bytes, *index, *face_normals),
    }
}

impl Loader {
    /// Reads the mesh files that the `obj`, `ply` and `serialized` shapes of file `s`
    /// name, all at once and in parallel (each file's bytes once, however many
    /// shapes it holds), before the walk (which meets them one after another) takes
    /// them: a file that several shapes name is parsed once. Only names without `$`
    /// parameters are read ahead, with `face_normals` and `shape_index` as written
    /// there; the walk reads whatever else it needs, and errors are reported where
    /// the walk meets them.
    pub(super) fn read_meshes_ahead(&mut self, s: Src) {
        // How many shapes take each mesh, and each file's meshes.
        let mut uses: HashMap<MeshKey, u32> = HashMap::new();
        let mut by_file: HashMap<PathBuf, Vec<MeshKey>> = HashMap::new();
        for n in s
            .doc
            .descendants()
            .filter(|n| n.is_element() && tag(*n) == "shape")
        {
            let format = match n.attribute("type") {
                Some("obj") => MeshFormat::Obj,
                Some("ply") => MeshFormat::Ply,
                Some("serialized") => MeshFormat::Serialized,
                _ => continue,
            };
            let Some(name) = child_value(n, "string", &["filename"]).filter(|f| !f.contains('$')) else {
                continue;
            };
            let face_normals = match child_value(n, "boolean", &["face_normals", "faceNormals"]) {
                None => false,
                Some(v) => match parse::boolean(v) {
                    Ok(b) => b,
                    Err(_) => continue,
                },
            };
            let index = match (format, child_value(n, "integer", &["shape_index", "shapeIndex"])) {
                (MeshFormat::Serialized, Some(v)) => match v.trim().parse::<u32>() {
                    Ok(i) => i,
                    Err(_) => continue,
                },
                _ => 0,
            };
            let path = self.resolve(s, name);
            if !path.is_file() {
                continue;
            }
            let key = (path, format, face_normals, index);
            if let Some((_, left)) = self.meshes_ahead.get_mut(&key) {
                // Read ahead for a file round this one.
                *left += 1;
                continue;
            }
            let count = uses.entry(key.clone()).or_insert(0);
            *count += 1;
            if *count == 1 {
                by_file.entry(key.0.clone()).or_default().push(key);
            }
        }
        let read: Vec<(MeshKey, Result<TriMesh>)> = by_file
            .into_par_iter()
            .flat_map(|(path, keys)| {
                // Unreadable: the walk reports it.
                let Ok(bytes) = std::fs::read(&path) else {
                    return Vec::new();
                };
                keys.into_par_iter()
                    .map(|k| {
                        let mesh = parse_mesh(&k, &bytes);
                        (k, mesh)
                    })
                    .collect()
            })
            .collect();
        for (key, mesh) in read {
            let left = uses.get(&key).copied().unwrap_or(1);
            self.meshes_ahead.insert(key, (mesh, left));
        }
    }

    /// The mesh `key` names: read ahead (a copy while other shapes will take it
    /// too), or read now.
    fn mesh_file(&mut self, key: MeshKey) -> Result<TriMesh> {
        if let Some((mesh, left)) = self.meshes_ahead.get_mut(&key) {
            if let (Ok(mesh), 2..) = (&*mesh, *left) {
                *left -= 1;
                return Ok(mesh.clone());
            }
            if let Some((mesh, _)) = self.meshes_ahead.remove(&key) {
                return mesh;
            }
        }
        let bytes = std::fs::read(&key.0).map_err(|e| Error::io(&key.0, e))?;
        parse_mesh(&key, &bytes)
    }

    pub(super) fn shape(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let id = self.attr(s, c, "id")?;
        match ty.as_str() {
            "shapegroup" => return self.shapegroup(s, c, id),
            "instance" => return self.instance(s, c),
            "merge" => return self.merge(s, c),
            _ => {}
        }
        self.register(s, c, Target::Other("shape"))?;
        let index = self.scene.shapes.len();
        let obj = self.collect(s, c, format!("shape '{ty}'"))?;
        let (mut mesh, auto_name): (TriMesh, String) = match ty.as_str() {
            "obj" | "ply" => {
                let (path, fname) = self.file_param(&obj, "filename")?;
                let face_normals = obj.boolean("face_normals", false)?;
                // As Mitsuba's loaders: v runs up the image in the file, down it in
                // a texture lookup.
                let flip = obj.boolean("flip_tex_coords", true)?;
                let format = if ty == "obj" {
                    MeshFormat::Obj
                } else {
                    MeshFormat::Ply
                };
                let mut mesh = self.mesh_file((path, format, face_normals, 0))?;
                if flip {
                    for uv in &mut mesh.uvs {
                        uv.y = 1.0 - uv.y;
                    }
                }
                (mesh, format!("{ty}:{fname}"))
            }
            "serialized" => {
                let (path, fname) = self.file_param(&obj, "filename")?;
                let face_normals = obj.boolean("face_normals", false)?;
                let index = obj.int("shape_index")?.unwrap_or(0);
                let index = u32::try_from(index)
                    .map_err(|_| obj.err_param("shape_index", format!("= {index} must be 0 or more")))?;
                (
                    self.mesh_file((path, MeshFormat::Serialized, face_normals, index))?,
                    format!("serialized:{fname}@{index}"),
                )
            }
            "bezier" => {
                let (path, fname) = self.file_param(&obj, "filename")?;
                let level = |name: &str, default: i64| -> Result<u32> {
                    let v = obj.int(name)?.unwrap_or(default);
                    if !(1..=256).contains(&v) {
                        return Err(obj.err_param(name, format!("= {v} is outside [1, 256]")));
                    }
                    Ok(v as u32)
                };
                let coarse = level("coarse", 4)?;
                let fine = level("fine", 8)?;
                let patches = bezier::read_bpt(&path)?;
                let tris = bezier::tessellated_triangles(patches.len(), coarse, fine);
                if tris > bezier::MAX_TESSELLATED_TRIANGLES {
                    return Err(obj.err_param(
                        "fine",
                        format!(
                            "{} patches at coarse {coarse} x fine {fine} would make {tris} triangles \
                             (at most {})",
                            patches.len(),
                            bezier::MAX_TESSELLATED_TRIANGLES
                        ),
                    ));
                }
                (
                    bezier::tessellate(&patches, coarse, fine),
                    format!("bezier:{fname}"),
                )
            }
            "rectangle" => (shapes::rectangle(), format!("rectangle#{index}")),
            "cube" => (shapes::cube(), format!("cube#{index}")),
            "disk" => (shapes::disk(), format!("disk#{index}")),
            "cylinder" => {
                let p0 = obj.vec3("p0")?.unwrap_or(Vec3::ZERO);
                let p1 = obj.vec3("p1")?.unwrap_or(Vec3::Z);
                let radius = obj.float("radius")?.unwrap_or(1.0);
                let mesh = shapes::cylinder(p0, p1, radius).ok_or_else(|| {
                    obj.err_param(
                        "radius",
                        format!("= {radius} with p0 = {p0}, p1 = {p1}: no tube there"),
                    )
                })?;
                (mesh, format!("cylinder#{index}"))
            }
            "sphere" => {
                let center = obj.vec3("center")?.unwrap_or(Vec3::ZERO);
                let radius = obj.float("radius")?.unwrap_or(1.0);
                if radius <= 0.0 {
                    return Err(obj.err_param("radius", format!("= {radius} must be positive")));
                }
                (shapes::sphere(center, radius), format!("sphere#{index}"))
            }
            t => {
                obj.mark_all();
                self.warn(s, c, format!("unknown shape type '{t}' ignored"));
                return Ok(());
            }
        };
        let name = id.clone().unwrap_or(auto_name);

        if let Some(m) = obj.transform("to_world")? {
            if !invertible(&m) {
                return Err(obj.err_param("to_world", "is singular (it flattens the shape)"));
            }
            mesh = self.place(s, c, mesh, &m);
        }
        if obj.boolean("flip_normals", false)? {
            mesh.flip_normals();
        }
        mesh.validate()
            .map_err(|e| s.err(c, format!("shape '{name}': invalid mesh: {e}")))?;
        if mesh.triangle_count() == 0 {
            self.warn(s, c, format!("shape '{name}' has no triangles"));
        }

        let mut bsdf = None;
        let mut null = false;
        let mut emitter: Option<(Rgb, Option<u32>, Node)> = None;
        for ch in &obj.children {
            match ch {
                Child::Elem(n) if tag(*n) == "bsdf" => {
                    if bsdf.is_some() {
                        return Err(s.err(*n, format!("shape '{name}' has more than one bsdf")));
                    }
                    null = self.attr(s, *n, "type")?.as_deref() == Some("null");
                    let b = self.bsdf(s, *n)?;
                    let bid = self.attr(s, *n, "id")?;
                    bsdf = Some(self.add_bsdf(b, bid.as_deref()));
                }
                Child::Ref {
                    node,
                    id,
                    target: Target::Bsdf(b),
                } => {
                    if bsdf.is_some() {
                        return Err(s.err(*node, format!("shape '{name}' has more than one bsdf")));
                    }
                    null = self.null_bsdfs.contains(id);
                    bsdf = Some(self.add_bsdf(b.clone(), Some(id)));
                }
                Child::Ref { node, id, target } => {
                    return Err(s.err_attr(
                        *node,
                        "id",
                        format!("id '{id}' names a {}, not a bsdf", target.kind()),
                    ))
                }
                Child::Elem(n) if tag(*n) == "emitter" => {
                    if let Some((r, t)) = self.area_emitter(s, *n)? {
                        if emitter.is_some() {
                            return Err(s.err(*n, format!("shape '{name}' has more than one area emitter")));
                        }
                        emitter = Some((r, t, *n));
                    }
                }
                Child::Elem(n) => {
                    let msg = format!("<{}> inside shape '{name}' ignored", tag(*n));
                    self.warn(s, *n, msg);
                }
            }
        }
        self.finish(&obj);
        // A `null` bsdf makes the surface invisible, as in Mitsuba: rays pass it (it
        // bounds a medium there, which radtrace does not render). An emitter on it
        // still glows; its surface then stops rays, black.
        if null {
            match emitter {
                None => return Ok(()),
                Some((_, _, n)) => self.warn(
                    s,
                    n,
                    format!(
                        "area emitter on shape '{name}' with a 'null' bsdf: its surface stops \
                         rays (black), where Mitsuba lets them pass"
                    ),
                ),
            }
        }

        let bsdf = match bsdf {
            Some(b) => b,
            None => self.default_bsdf(emitter.is_some()),
        };
        let light = match emitter {
            None => None,
            Some((radiance, texture, n)) => {
                let area = mesh.area();
                if !(area > 0.0 && area.is_finite()) {
                    return Err(s.err(n, format!("area emitter on shape '{name}', which has zero area")));
                }
                if radiance == Vec3::ZERO {
                    self.warn(s, n, format!("area emitter on '{name}' has zero radiance"));
                }
                if texture.is_some() {
                    let msg = format!(
                        "area emitter on '{name}': its radiance texture shows where the light is seen; \
                         it lights the scene with the texture's mean ({:.4}, {:.4}, {:.4})",
                        radiance.x, radiance.y, radiance.z
                    );
                    self.note(s, n, msg);
                }
                self.scene.lights.push(Light::Area {
                    shape: index as u32,
                    radiance,
                    texture,
                });
                Some(self.scene.lights.len() as u32 - 1)
            }
        };
        self.scene.shapes.push(Shape {
            name,
            mesh,
            bsdf,
            emitter: light,
        });
        Ok(())
    }

    /// `mesh` moved by `m`; a sphere under a non-uniform map stays a sphere, as in
    /// Mitsuba (with a warning).
    fn place(&mut self, s: Src, c: Node, mut mesh: TriMesh, m: &Mat4) -> TriMesh {
        let ellipsoid = mesh.quadric.filter(|q| {
            let mut q = *q;
            q.transform(m);
            q.kind == crate::geometry::QuadricKind::Sphere && !q.is_similarity(1e-4)
        });
        if let Some(q) = ellipsoid {
            // Mitsuba keeps a sphere a sphere: the centre moved, the radius scaled by
            // the map's scale along x.
            let centre = m.transform_point3(q.to_world().transform_point3(Vec3::ZERO));
            let radius = m
                .transform_vector3(q.to_world().transform_vector3(Vec3::X))
                .length();
            self.warn(
                s,
                c,
                format!(
                    "sphere with a non-uniform to_world: rendered, as Mitsuba does, as the \
                     sphere of radius {radius} (the scale along x) at {centre}"
                ),
            );
            shapes::sphere(centre, radius)
        } else {
            mesh.transform(m);
            mesh
        }
    }

    /// `shapegroup`: its shapes are read (each with its own `to_world`) and kept aside,
    /// by the group's id, for the `instance`s that name it. As in Mitsuba, a group holds
    /// no emitters.
    fn shapegroup(&mut self, s: Src, c: Node, id: Option<String>) -> Result<()> {
        let Some(id) = id else {
            return Err(s.err(c, "a 'shapegroup' needs an id (its instances name it)"));
        };
        self.register(s, c, Target::Other("shapegroup"))?;
        let (first_shape, first_light) = (self.scene.shapes.len(), self.scene.lights.len());
        self.nested_shapes(s, c, &format!("shapegroup '{id}'"))?;
        if self.scene.lights.len() != first_light {
            return Err(s.err(
                c,
                format!("shapegroup '{id}' holds an area emitter (Mitsuba allows none in a shapegroup)"),
            ));
        }
        let group = self.scene.shapes.drain(first_shape..).collect();
        self.groups.insert(id, group);
        Ok(())
    }

    /// `merge`: Mitsuba 3 joins its nested meshes into one per material, for speed;
    /// the picture is the same, so each nested shape is read as a shape of its own.
    fn merge(&mut self, s: Src, c: Node) -> Result<()> {
        self.nested_shapes(s, c, "shape 'merge'")
    }

    /// Reads the `<shape>`s nested in `c` (a `what`), warning of anything else there.
    fn nested_shapes(&mut self, s: Src, c: Node, what: &str) -> Result<()> {
        for ch in c.children().filter(Node::is_element) {
            match tag(ch) {
                "shape" => self.shape(s, ch)?,
                t => self.warn(s, ch, format!("<{t}> inside {what} ignored")),
            }
        }
        Ok(())
    }

    /// `instance`: a copy of a `shapegroup`'s shapes moved by the instance's `to_world`.
    fn instance(&mut self, s: Src, c: Node) -> Result<()> {
        self.register(s, c, Target::Other("shape"))?;
        let obj = self.collect(s, c, "shape 'instance'".into())?;
        let m = obj.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        if !invertible(&m) {
            return Err(obj.err_param("to_world", "is singular (it flattens the shape)"));
        }
        let mut group = None;
        for ch in &obj.children {
            match ch {
                Child::Ref {
                    id,
                    target: Target::Other("shapegroup"),
                    ..
                } => group = Some(id.clone()),
                Child::Ref { node, id, target } => {
                    return Err(s.err_attr(
                        *node,
                        "id",
                        format!("id '{id}' names a {}, not a shapegroup", target.kind()),
                    ))
                }
                Child::Elem(n) => {
                    let msg = format!("<{}> inside an instance ignored", tag(*n));
                    self.warn(s, *n, msg);
                }
            }
        }
        self.finish(&obj);
        let Some(group) = group else {
            return Err(s.err(c, "an 'instance' needs a <ref> to a shapegroup"));
        };
        let copy = self.groups.get(&group).cloned().unwrap_or_default();
        let n = self.scene.shapes.len();
        for (k, shape) in copy.into_iter().enumerate() {
            let mesh = self.place(s, c, shape.mesh, &m);
            self.scene.shapes.push(Shape {
                name: format!("{}@{group}#{}", shape.name, n + k),
                mesh,
                ..shape
            });
        }
        Ok(())
    }
}

/// Whether `m`'s linear part can be undone (a shape keeps its area).
fn invertible(m: &Mat4) -> bool {
    let det = Mat3::from_mat4(*m).determinant();
    det != 0.0 && det.is_finite()
}
