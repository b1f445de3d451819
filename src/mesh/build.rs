//! Building the radiosity mesh: each shape's scene patches merged into clusters and
//! meshed by lattices or grids of their polygons (in parallel, shape by shape), then the
//! back twins of two-sided patches.

use glam::Vec3;
use rayon::prelude::*;

use super::*;

impl RadiosityMesh {
    /// Meshes every patch of `scene` with elements no larger than `mesh_size`,
    /// after merging its polygons into clusters (see [`lattice`]). A surface with no
    /// diffuse reflectance that emits nothing keeps no radiosity: it gets the fewest
    /// vertices that still locate a hit (one element per patch).
    pub fn build(scene: &Scene, mesh_size: f32) -> Self {
        let parts = Self::shape_parts(scene, mesh_size, &std::collections::HashMap::new(), &|_| true);
        let mut mesh = Self::assemble(scene, mesh_size, 0, parts.into_iter().flatten());
        mesh.area_shares(|g| matches!(g.domain, Domain::Lattice(_)));
        mesh
    }

    /// The vertices' shares of their patch's area ([`Grid::area_shares`], covered
    /// corners left out), times the patch's open share, for the grids `redo` picks,
    /// in parallel. Every lattice's are computed here, once, on the finished mesh:
    /// [`RadiosityMesh::build_covered`] meshes some shapes twice and learns only at
    /// the end which vertices are covered, which had the shares of those shapes and
    /// of every covered lattice computed twice. (Other grids get theirs when they
    /// are built, and again here if they have covered vertices.)
    pub(super) fn area_shares(&mut self, redo: impl Fn(&Grid) -> bool + Sync) {
        let shares: Vec<(usize, Vec<f32>)> = self
            .patches
            .par_iter()
            .flat_map_iter(|p| {
                p.grids.iter().filter(|g| redo(g)).map(move |g| {
                    (
                        g.first_vertex as usize,
                        g.area_shares().into_iter().map(|a| a * p.opacity).collect(),
                    )
                })
            })
            .collect();
        for (first, shares) in shares {
            for (v, a) in self.vertices[first..].iter_mut().zip(shares) {
                v.area = a;
            }
        }
    }

    /// Each shape's patches and vertices apart, in parallel (its indices counted from
    /// its own first, see [`RadiosityMesh::shape_part`]), for the shapes `redo` names
    /// (`None` for the rest). The patches named in `fine` (by shape and the index of
    /// their first polygon: [`MeshPatch::shape`], [`MeshPatch::local`]) are meshed at
    /// that fraction of the mesh size (see [`contact`] and [`near_light`]); polygons
    /// merge into patches as at the full size, so the patches are the same.
    pub(super) fn shape_parts(
        scene: &Scene,
        mesh_size: f32,
        fine: &std::collections::HashMap<(u32, u32), f32>,
        redo: &(dyn Fn(usize) -> bool + Sync),
    ) -> Vec<Option<Self>> {
        let emitting: std::collections::HashSet<u32> = scene
            .lights
            .iter()
            .filter_map(|l| match l {
                Light::Area { shape, .. } => Some(*shape),
                _ => None,
            })
            .collect();
        // Per shape, the bounds of all the others (how far a cut piece lies from them).
        let bounds: Vec<(Vec3, Vec3)> = scene
            .shapes
            .iter()
            .map(|s| s.mesh.bounds().unwrap_or((Vec3::INFINITY, Vec3::NEG_INFINITY)))
            .collect();
        let union = |a: (Vec3, Vec3), b: (Vec3, Vec3)| (a.0.min(b.0), a.1.max(b.1));
        let empty = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let mut before = vec![empty; bounds.len() + 1];
        for (k, b) in bounds.iter().enumerate() {
            before[k + 1] = union(before[k], *b);
        }
        let mut rest_of = vec![empty; bounds.len()];
        let mut after = empty;
        for k in (0..bounds.len()).rev() {
            rest_of[k] = union(before[k], after);
            after = union(after, bounds[k]);
        }
        (0..scene.shapes.len())
            .into_par_iter()
            .map(|si| redo(si).then(|| Self::shape_part(scene, si, mesh_size, fine, &emitting, rest_of[si])))
            .collect()
    }

    /// The mesh of the shapes' `parts` (one per shape, in shape order) appended one
    /// after another, then the back twins of two-sided patches; `refined` patches of
    /// them were meshed finer.
    pub(super) fn assemble(
        scene: &Scene,
        mesh_size: f32,
        refined: u32,
        parts: impl IntoIterator<Item = Self>,
    ) -> Self {
        let mut mesh = RadiosityMesh {
            mesh_size,
            patches: Vec::new(),
            vertices: Vec::new(),
            shape_first_patch: Vec::with_capacity(scene.shapes.len()),
            patch_map: Vec::with_capacity(scene.shapes.len()),
            front_patches: 0,
            refined,
            splits: std::collections::HashMap::new(),
            albedo: Vec::new(),
        };
        for part in parts {
            mesh.append(part);
        }
        mesh.front_patches = mesh.patches.len() as u32;
        // Back twins of two-sided patches.
        for p in 0..mesh.front_patches as usize {
            let shape = &scene.shapes[mesh.patches[p].shape as usize];
            if !scene.bsdfs[shape.bsdf as usize].twosided {
                continue;
            }
            let twin_index = mesh.patches.len() as u32;
            let mut twin = mesh.patches[p].clone();
            let front_first = twin.first_vertex as usize;
            twin.first_vertex = mesh.vertices.len() as u32;
            for g in &mut twin.grids {
                let offset = g.first_vertex as usize - front_first;
                g.first_vertex = mesh.vertices.len() as u32;
                g.flip = true;
                if let Domain::Lattice(l) = &mut g.domain {
                    for t in &mut l.surface {
                        t.swap(1, 2);
                    }
                    let count = l.nodes.len();
                    let verts: Vec<MeshVertex> = (0..count)
                        .map(|k| {
                            let v = mesh.vertices[front_first + offset + k];
                            MeshVertex {
                                n: -v.n,
                                patch: twin_index,
                                ..v
                            }
                        })
                        .collect();
                    mesh.vertices.extend(verts);
                } else {
                    let (verts, _) = grid_vertices(g, twin_index);
                    let opacity = twin.opacity;
                    mesh.vertices.extend(verts.into_iter().map(|v| MeshVertex {
                        area: v.area * opacity,
                        ..v
                    }));
                }
            }
            mesh.patches[p].twin = Some(twin_index);
            mesh.patches.push(twin);
        }
        mesh
    }

    /// The patches and vertices of shape `si` alone, its indices counted from its own
    /// first patch and vertex ([`RadiosityMesh::append`] moves them into place).
    fn shape_part(
        scene: &Scene,
        si: usize,
        mesh_size: f32,
        fine: &std::collections::HashMap<(u32, u32), f32>,
        emitting: &std::collections::HashSet<u32>,
        rest_of: (Vec3, Vec3),
    ) -> Self {
        let shape = &scene.shapes[si];
        let mut mesh = RadiosityMesh {
            mesh_size,
            patches: Vec::new(),
            vertices: Vec::new(),
            shape_first_patch: Vec::new(),
            patch_map: Vec::new(),
            front_patches: 0,
            refined: 0,
            splits: std::collections::HashMap::new(),
            albedo: Vec::new(),
        };
        let bsdf = &scene.bsdfs[shape.bsdf as usize];
        let reflectance = bsdf.kind.diffuse_albedo();
        // A textured material's patches each take the texture's mean over their own
        // triangles: the triangles of each of the shape's patches.
        let tris_of: Vec<Vec<u32>> = if textured_albedo(bsdf) {
            let mut v = vec![Vec::new(); shape.mesh.patches.len()];
            for (t, &p) in shape.mesh.tri_patch.iter().enumerate() {
                if let Some(list) = v.get_mut(p as usize) {
                    list.push(t as u32);
                }
            }
            v
        } else {
            Vec::new()
        };
        // A surface without diffuse reflectance keeps no radiosity: one element per
        // patch. An emitting one (a lamp's black shade, a sky dome) keeps its
        // patches, which its light is shot from, but needs no finer elements.
        let black = !(reflectance.max_element() > 0.0);
        let inert = black && !emitting.contains(&(si as u32));
        let size = if black { f32::INFINITY } else { mesh_size };
        let groups = lattice::clusters(&shape.mesh, mesh_size, inert);
        // Per cluster, the offset of its (first) patch from the shape's first.
        let mut cluster_patch = Vec::with_capacity(groups.members.len());
        for members in &groups.members {
            // (A surface cut into pieces keeps the mesh size: `fine` names the
            // cluster by its first polygon, which all its pieces share.)
            let base = size;
            let size = fine.get(&(si as u32, members[0])).map_or(size, |f| f * size);
            cluster_patch.push(mesh.patches.len() as u32);
            let (reflectance, opacity) = if tris_of.is_empty() {
                (reflectance, 1.0)
            } else {
                let tris = members
                    .iter()
                    .flat_map(|&m| tris_of.get(m as usize).into_iter().flatten().copied());
                mean_albedo(&shape.mesh, tris, bsdf, &scene.textures)
            };
            let domains = if members.len() == 1 {
                patch_domains(&shape.mesh, &shape.mesh.patches[members[0] as usize])
            } else {
                Vec::new()
            };
            // A surface too large for one patch: pieces, each meshed by a lattice.
            let flat = domains
                .iter()
                .all(|d| matches!(d, Domain::Tri(_) | Domain::Quad(_)));
            let large = members.len() > 1
                || flat
                    && domains.iter().any(|d| {
                        let (n, m) = grid_size(d, base);
                        n.max(m) > SPLIT_ABOVE
                    });
            // (At most MAX_DIVISIONS pieces a side: a tiny `--mesh-size` must not
            // make the cut itself unbounded. Far pieces are coarse, so the pieces at
            // the mesh size cover about the rest of the scene, as its own mesh does.)
            let tris = if large && base.is_finite() {
                cluster_triangles(&shape.mesh, members)
            } else {
                Vec::new()
            };
            let cut = if !tris.is_empty() {
                lattice::cut(&tris, base, SPLIT_ABOVE, SPLIT_SIDE, MAX_DIVISIONS)
            } else {
                None
            };
            let (lattices, pieces): (Vec<(Surface, f32)>, Vec<Vec<Domain>>) = match cut {
                Some((parts, cut)) => {
                    mesh.splits.insert(mesh.patches.len() as u32, cut);
                    let rest = rest_of;
                    let graded = parts
                        .into_iter()
                        .map(|tris| {
                            let (lo, hi) = tri_bounds(&tris);
                            let d = if rest.0.x <= rest.1.x {
                                (lo.max(rest.0) - hi.min(rest.1)).max(Vec3::ZERO).length()
                            } else {
                                0.0
                            };
                            let t = (SPLIT_SIDE as f32 * base).max(0.25 * (rest.1 - rest.0).length());
                            let s = base * (d / t).max(1.0).powi(2);
                            (tris, s)
                        })
                        .collect();
                    (graded, Vec::new())
                }
                None if members.len() > 1 => {
                    (vec![(cluster_triangles(&shape.mesh, members), size)], Vec::new())
                }
                None => (Vec::new(), vec![domains]),
            };
            // Appends a patch of this cluster made of `grids`.
            let push = |mesh: &mut RadiosityMesh, grids, first_vertex, elements, area| {
                mesh.push_patch(
                    si as u32,
                    members[0],
                    grids,
                    first_vertex,
                    elements,
                    area,
                    reflectance,
                    opacity,
                );
            };
            for (surface, size) in lattices {
                let patch_index = mesh.patches.len() as u32;
                let first_vertex = mesh.vertices.len() as u32;
                let (lat, verts, a) = lattice::build(surface, size);
                let elements = lat.cells.len() as u32;
                mesh.vertices.extend(verts.into_iter().map(|v| MeshVertex {
                    p: v.p,
                    n: v.n,
                    q: v.q,
                    // Filled by `area_shares`.
                    area: 0.0,
                    patch: patch_index,
                }));
                let grids = vec![Grid {
                    n: lat.n,
                    m: lat.m,
                    domain: Domain::Lattice(Box::new(lat)),
                    first_vertex,
                    flip: false,
                    area: a,
                    covered: Vec::new(),
                }];
                push(&mut mesh, grids, first_vertex, elements, a);
            }
            for domains in pieces {
                let patch_index = mesh.patches.len() as u32;
                let first_vertex = mesh.vertices.len() as u32;
                let mut grids = Vec::new();
                let mut area = 0.0;
                let mut elements = 0;
                for domain in domains {
                    let (n, m) = grid_size(&domain, size);
                    let mut grid = Grid {
                        domain,
                        n,
                        m,
                        first_vertex: mesh.vertices.len() as u32,
                        flip: false,
                        area: 0.0,
                        covered: Vec::new(),
                    };
                    let (verts, a) = grid_vertices(&grid, patch_index);
                    grid.area = a;
                    area += a;
                    elements += grid.element_count();
                    mesh.vertices.extend(verts);
                    grids.push(grid);
                }
                push(&mut mesh, grids, first_vertex, elements, area);
            }
        }
        mesh.patch_map.push(
            groups
                .of_patch
                .iter()
                .map(|&c| cluster_patch[c as usize])
                .collect(),
        );
        mesh
    }

    /// Appends the patches of one shape made by [`RadiosityMesh::shape_part`], their
    /// vertex and patch indices moved past those already here.
    fn append(&mut self, part: RadiosityMesh) {
        let first_patch = self.patches.len() as u32;
        let first_vertex = self.vertices.len() as u32;
        self.shape_first_patch.push(first_patch);
        self.patch_map.extend(part.patch_map);
        self.splits
            .extend(part.splits.into_iter().map(|(p, cut)| (p + first_patch, cut)));
        self.vertices
            .extend(part.vertices.into_iter().map(|v| MeshVertex {
                patch: v.patch + first_patch,
                ..v
            }));
        self.patches.extend(part.patches.into_iter().map(|mut p| {
            p.first_vertex += first_vertex;
            for g in &mut p.grids {
                g.first_vertex += first_vertex;
            }
            p
        }));
    }

    /// Appends a front patch of shape `shape` (first scene patch `local`) made of
    /// `grids`, whose vertices start at `first_vertex`; a mask's open share
    /// `opacity` scales its vertices' areas.
    #[allow(clippy::too_many_arguments)]
    fn push_patch(
        &mut self,
        shape: u32,
        local: u32,
        grids: Vec<Grid>,
        first_vertex: u32,
        element_count: u32,
        area: f32,
        reflectance: Rgb,
        opacity: f32,
    ) {
        if opacity < 1.0 {
            for v in &mut self.vertices[first_vertex as usize..] {
                v.area *= opacity;
            }
        }
        self.patches.push(MeshPatch {
            shape,
            local,
            grids,
            first_vertex,
            vertex_count: self.vertices.len() as u32 - first_vertex,
            element_count,
            area,
            reflectance,
            opacity,
            twin: None,
        });
    }

    /// A cheap upper estimate of the vertices [`RadiosityMesh::build`] makes (to refuse
    /// a forged tiny mesh size before building): four per polygon, plus the surface
    /// area over the element area, on both sides.
    pub fn estimate_vertices(scene: &Scene, mesh_size: f32) -> f64 {
        let mut total = 0.0f64;
        for shape in &scene.shapes {
            let m = &shape.mesh;
            let area: f64 = (0..m.triangle_count())
                .map(|t| {
                    let [a, b, c] = m.triangle(t);
                    0.5 * f64::from((b - a).cross(c - a).length())
                })
                .sum();
            let s = f64::from(mesh_size);
            total += 2.0 * (4.0 * m.patches.len() as f64 + 4.0 * area / (s * s));
        }
        total
    }
}

/// The parameter domains a scene patch is meshed over: a triangle, a quadrilateral,
/// a fan of triangles for larger polygons, or a piece of a Bezier patch.
fn patch_domains(mesh: &crate::geometry::TriMesh, patch: &Patch) -> Vec<Domain> {
    match patch {
        Patch::Polygon(idx) => {
            let pts: Vec<Vec3> = idx.iter().map(|&i| mesh.positions[i as usize]).collect();
            match pts.len() {
                0..=2 => vec![],
                3 => vec![Domain::Tri([pts[0], pts[1], pts[2]])],
                4 if planar([pts[0], pts[1], pts[2], pts[3]]) => {
                    vec![Domain::Quad([pts[0], pts[1], pts[2], pts[3]])]
                }
                // A warped quadrilateral is the two triangles the geometry fans it into
                // (the bilinear surface strays from them, and its receiving points
                // would sit in front of or behind the surface the rays meet).
                _ => (1..pts.len() - 1)
                    .map(|k| Domain::Tri([pts[0], pts[k], pts[k + 1]]))
                    .collect(),
            }
        }
        Patch::Bezier { surface, u, v } => {
            vec![Domain::Curved {
                surface: ParamSurface::Bezier(mesh.bezier[*surface as usize]),
                u: *u,
                v: *v,
            }]
        }
        Patch::Quadric { face, u, v } => match mesh.quadric {
            Some(q) => vec![Domain::Curved {
                surface: ParamSurface::Quadric(q, *face),
                u: *u,
                v: *v,
            }],
            None => vec![],
        },
    }
}

/// Triangles of a surface, wound to face its front.
type Surface = Vec<[Vec3; 3]>;

/// The bounds of triangles.
fn tri_bounds(tris: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    tris.iter()
        .flatten()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        })
}

/// The triangles of the scene patches `members` of `mesh` (polygons as fans).
fn cluster_triangles(mesh: &crate::geometry::TriMesh, members: &[u32]) -> Vec<[Vec3; 3]> {
    let mut out = Vec::new();
    for &m in members {
        for d in patch_domains(mesh, &mesh.patches[m as usize]) {
            match d {
                Domain::Tri(t) => out.push(t),
                Domain::Quad([a, b, c, e]) => {
                    out.push([a, b, c]);
                    out.push([a, c, e]);
                }
                _ => {}
            }
        }
    }
    out
}

/// Most the normal may turn across an element of a curved surface (radians; 15
/// degrees: a sphere's pieces of 45 x 45 degrees get 3 x 3 elements, unless that
/// makes them shorter than a quarter of the mesh size).
const MAX_BEND: f32 = 0.2618;

/// Subdivisions for a length: at least 1, at most [`MAX_DIVISIONS`].
fn divisions(len: f32, size: f32) -> u32 {
    if !(len > 0.0) || !(size > 0.0) {
        return 1;
    }
    ((len / size).ceil() as u32).clamp(1, MAX_DIVISIONS)
}

fn grid_size(domain: &Domain, size: f32) -> (u32, u32) {
    match domain {
        Domain::Lattice(l) => (l.n, l.m),
        Domain::Tri([a, b, c]) => {
            let k = divisions(
                (*b - *a).length().max((*c - *a).length()).max((*c - *b).length()),
                size,
            );
            (k, k)
        }
        Domain::Quad([a, b, c, d]) => (
            divisions((*b - *a).length().max((*c - *d).length()), size),
            divisions((*d - *a).length().max((*c - *b).length()), size),
        ),
        Domain::Curved { surface, u, v } => {
            // Polyline lengths along the two parameter directions.
            let at = |s: f32, t: f32| surface.eval(u[0] + (u[1] - u[0]) * s, v[0] + (v[1] - v[0]) * t).0;
            let len = |f: &dyn Fn(f32) -> Vec3| {
                (0..8)
                    .map(|k| (f((k + 1) as f32 / 8.0) - f(k as f32 / 8.0)).length())
                    .sum::<f32>()
            };
            let mut lu: f32 = 0.0;
            let mut lv: f32 = 0.0;
            for w in [0.0, 0.5, 1.0] {
                lu = lu.max(len(&|s| at(s, w)));
                lv = lv.max(len(&|t| at(w, t)));
            }
            // How far the normal turns along the two directions: Gouraud shading of
            // light that varies with the normal (a small sphere under a lamp) needs
            // elements that bend no more than MAX_BEND, whatever their size.
            let normal = |s: f32, t: f32| surface.normal(u[0] + (u[1] - u[0]) * s, v[0] + (v[1] - v[0]) * t);
            let turn = |f: &dyn Fn(f32) -> Vec3| {
                (0..8)
                    .map(|k| {
                        f(k as f32 / 8.0)
                            .dot(f((k + 1) as f32 / 8.0))
                            .clamp(-1.0, 1.0)
                            .acos()
                    })
                    .sum::<f32>()
            };
            let (mut bu, mut bv): (f32, f32) = (0.0, 0.0);
            for w in [0.25, 0.5, 0.75] {
                bu = bu.max(turn(&|s| normal(s, w)));
                bv = bv.max(turn(&|t| normal(w, t)));
            }
            // (But no element shorter than a quarter of the mesh size: a small
            // curved object, a teapot's spout, keeps as few vertices as its area asks.)
            let bent = |b: f32, l: f32| {
                let most = (4.0 * l / size).floor().clamp(1.0, 16.0);
                (b / MAX_BEND).ceil().clamp(1.0, most) as u32
            };
            (
                divisions(lu, size).max(bent(bu, lu)),
                divisions(lv, size).max(bent(bv, lv)),
            )
        }
    }
}

/// How far receiving points move towards the patch centre, in parameter units.
const NUDGE: f32 = 2e-3;

/// The vertices of a grid with their area shares, and the grid's area.
fn grid_vertices(grid: &Grid, patch: u32) -> (Vec<MeshVertex>, f32) {
    let mut verts = Vec::with_capacity(grid.vertex_count() as usize);
    let mut total = 0.0;
    match grid.domain {
        Domain::Tri(_) => {
            let k = grid.n;
            for j in 0..=k {
                for i in 0..=k - j {
                    let (a, b) = (i as f32 / k as f32, j as f32 / k as f32);
                    let (p, n) = grid.eval(a, b);
                    let (q, _) = grid.eval(a + (1.0 / 3.0 - a) * NUDGE, b + (1.0 / 3.0 - b) * NUDGE);
                    verts.push(MeshVertex {
                        p,
                        n,
                        q,
                        area: 0.0,
                        patch,
                    });
                }
            }
            let elem = 0.5 * grid.jacobian(0.0, 0.0) / (k * k) as f32;
            for j in 0..k {
                for i in 0..k - j {
                    for v in [
                        tri_vertex(k, i, j),
                        tri_vertex(k, i + 1, j),
                        tri_vertex(k, i, j + 1),
                    ] {
                        verts[v as usize].area += elem / 3.0;
                    }
                    total += elem;
                    if i + j < k - 1 {
                        for v in [
                            tri_vertex(k, i + 1, j + 1),
                            tri_vertex(k, i, j + 1),
                            tri_vertex(k, i + 1, j),
                        ] {
                            verts[v as usize].area += elem / 3.0;
                        }
                        total += elem;
                    }
                }
            }
        }
        _ => {
            let (n, m) = (grid.n, grid.m);
            for j in 0..=m {
                for i in 0..=n {
                    let (a, b) = (i as f32 / n as f32, j as f32 / m as f32);
                    let (p, nn) = grid.eval(a, b);
                    let (q, _) = grid.eval(a + (0.5 - a) * NUDGE, b + (0.5 - b) * NUDGE);
                    verts.push(MeshVertex {
                        p,
                        n: nn,
                        q,
                        area: 0.0,
                        patch,
                    });
                }
            }
            for j in 0..m {
                for i in 0..n {
                    let (s, t) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / m as f32);
                    let a = grid.jacobian(s, t) / (n * m) as f32;
                    total += a;
                    for (di, dj) in [(0, 0), (1, 0), (1, 1), (0, 1)] {
                        verts[((j + dj) * (n + 1) + i + di) as usize].area += a / 4.0;
                    }
                }
            }
        }
    }
    (verts, total)
}
