//! The radiosity mesh (paper Sect. 6): the scene's polygons are merged into patches
//! that follow surfaces ([`lattice`]), and every patch is split into elements no
//! larger than a mesh size, with vertices shared inside the patch. Radiosity values
//! live at the vertices and are Gouraud-interpolated at hit points.
//!
//! A merged patch is meshed by a square lattice (see [`Lattice`]); a lone polygon or
//! Bezier piece as below.
//!
//! A patch is meshed as one or more regular *grids* over a parameter domain:
//! a triangle as a triangular grid (barycentric), a quadrilateral as a bilinear grid,
//! a piece of a Bezier patch as a grid in (u, v), and a polygon of five or more
//! corners as a fan of triangular grids. A hit point is located in its grid by its
//! parameters, which gives the element and the interpolation weights at once.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::accel::Hit;
use crate::geometry::{ParamSurface, Patch};
use crate::scene::{Light, Rgb, Scene};

mod albedo;
mod cells;
mod contact;
mod cover;
mod lattice;
mod midpoints;
mod near_light;
mod pieces;
mod size;

pub use albedo::{mean_albedo, textured_albedo};
pub use cells::{point_in_polygon, quarter, ShootCell};
pub use lattice::Lattice;
pub use midpoints::{Between, Midpoints};
pub use pieces::Piece;
pub use size::{default_mesh_size, lit_diagonal};

/// The parameter domain of one grid.
#[derive(Debug, Clone, PartialEq)]
pub enum Domain {
    /// A triangle, parameterised by barycentrics of corners 1 and 2.
    Tri([Vec3; 3]),
    /// A (planar) quadrilateral, parameterised bilinearly: corner 0 at (0,0),
    /// 1 at (1,0), 2 at (1,1), 3 at (0,1).
    Quad([Vec3; 4]),
    /// The piece `u x v` of a curved surface (Bezier, sphere, disk).
    Curved {
        /// The surface.
        surface: ParamSurface,
        /// Parameter range in u.
        u: [f32; 2],
        /// Parameter range in v.
        v: [f32; 2],
    },
    /// A cluster of polygons meshed by a square lattice (see [`Lattice`]); its
    /// vertices are found by position, not by parameters.
    Lattice(Box<Lattice>),
}

/// A regular grid of elements over a domain.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// The domain.
    pub domain: Domain,
    /// Subdivisions: for `Tri` both are k (k^2 triangles); otherwise n along the first
    /// parameter and m along the second (n x m quads).
    pub n: u32,
    /// See `n`.
    pub m: u32,
    /// Index of the grid's first vertex in [`RadiosityMesh::vertices`].
    pub first_vertex: u32,
    /// Normals point the other way (the back twin of a two-sided patch).
    pub flip: bool,
    /// Surface area (the sum of its elements' areas).
    pub area: f32,
    /// Per vertex offset: covered by geometry resting on the surface (see
    /// [`RadiosityMesh::build_covered`]); empty when none is. A lattice keeps its own
    /// ([`Lattice::covered`]), which its `interp` reads.
    pub covered: Vec<bool>,
}

/// A radiosity patch: the unit that keeps a source list.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshPatch {
    /// Shape index in the scene.
    pub shape: u32,
    /// Index, within the shape's mesh, of the first scene patch merged into it.
    pub local: u32,
    /// Its grids (one, or a fan for polygons of five or more corners).
    pub grids: Vec<Grid>,
    /// First vertex (the patch's vertices are contiguous).
    pub first_vertex: u32,
    /// Number of vertices.
    pub vertex_count: u32,
    /// Number of elements.
    pub element_count: u32,
    /// Surface area.
    pub area: f32,
    /// Diffuse reflectance used by the radiosity pass (for a textured material, its
    /// mean over the patch's surface that a `mask` leaves).
    pub reflectance: Rgb,
    /// The share of the patch's area that a `mask` leaves (1 without one): it scales
    /// the light the patch sends (its cells) and its vertices' areas.
    pub opacity: f32,
    /// For a patch with a two-sided material: its back twin (the same surface with
    /// the normal reversed and vertices of its own), which holds the light on the
    /// back side. Radiosity is one-sided: each side keeps its own values.
    pub twin: Option<u32>,
}

impl MeshPatch {
    /// The curved surface the patch is a piece of (a Bezier patch, sphere or disk);
    /// `None` for a polygon.
    pub fn surface(&self) -> Option<&ParamSurface> {
        self.grids.iter().find_map(|g| match &g.domain {
            Domain::Curved { surface, .. } => Some(surface),
            _ => None,
        })
    }
}

/// A mesh vertex: where radiosity is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshVertex {
    /// Position.
    pub p: Vec3,
    /// Unit normal (front side).
    pub n: Vec3,
    /// Where the vertex receives light: its position moved a hair (1e-3 of the
    /// patch's parameter range) into the patch, so that vertices on an edge shared
    /// with another patch do not lie in that patch's plane (where the point form
    /// factor to it jumps to zero).
    pub q: Vec3,
    /// The share of the patch's area this vertex stands for.
    pub area: f32,
    /// The patch it belongs to.
    pub patch: u32,
}

/// The whole radiosity mesh of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct RadiosityMesh {
    /// The element size it was made with.
    pub mesh_size: f32,
    /// All patches, shape by shape.
    pub patches: Vec<MeshPatch>,
    /// All vertices, patch by patch.
    pub vertices: Vec<MeshVertex>,
    /// For each shape, the index of its first patch in `patches`.
    pub shape_first_patch: Vec<u32>,
    /// For each shape, for each of its scene patches, its radiosity patch (counted
    /// from the shape's first): several scene patches share one when they merge.
    pub patch_map: Vec<Vec<u32>>,
    /// Number of front patches: `patches[..front_patches]` follow the scene's shapes
    /// and patches in order; the back twins of two-sided patches come after them.
    pub front_patches: u32,
    /// Front patches meshed finer than the mesh size: they hold a small object (see
    /// [`contact`]) or lie near a small light (see [`near_light`]).
    pub refined: u32,
    /// Surfaces too large for one patch, cut into several (see [`SPLIT_ABOVE`]), by
    /// the index of their first patch.
    pub splits: std::collections::HashMap<u32, lattice::Cut>,
    /// Per vertex, the diffuse albedo its radiosity is made with: the mean of its
    /// material's texture over the surface around it ([`Self::albedo`]). Empty where
    /// no material is textured: each vertex takes its patch's reflectance.
    pub albedo: Vec<Rgb>,
}

/// A surface (one polygon, or a cluster of them) with more than [`SPLIT_ABOVE`]
/// elements along a side (a ground plane reaching far past the rooms on it) is cut
/// into patches of at most [`SPLIT_SIDE`] elements a side ([`lattice::cut`]): a patch
/// is what shoots light and keeps a source list, and one patch far larger than the
/// rooms it runs through shoots from cells larger than the rooms too (the
/// classroom's floor, 221 m across: a third of the indirect light was lost). A piece
/// farther from the rest of the scene's bounds than a quarter of their diagonal (and than
/// [`SPLIT_SIDE`] elements) gets elements larger by the square of how many times
/// farther.
pub const SPLIT_ABOVE: u32 = 64;
/// See [`SPLIT_ABOVE`].
pub const SPLIT_SIDE: u32 = 32;

/// Vertex weights for interpolating at a point: up to four vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interp {
    /// Vertex indices.
    pub vertices: [u32; 4],
    /// Their weights (summing to 1; unused entries 0).
    pub weights: [f32; 4],
}

impl Interp {
    /// Interpolates a per-vertex quantity.
    pub fn apply(&self, values: &[Rgb]) -> Rgb {
        let mut s = Vec3::ZERO;
        for k in 0..4 {
            if self.weights[k] != 0.0 {
                s += values[self.vertices[k] as usize] * self.weights[k];
            }
        }
        s
    }

    /// The same point with covered vertices (`covered(v)`) left out and the rest
    /// scaled up, unless that leaves (almost) nothing: a point amid covered vertices
    /// only keeps them.
    pub fn uncover(self, covered: impl Fn(u32) -> bool) -> Interp {
        let total: f32 = self.weights.iter().sum();
        let open: f32 = (0..4)
            .filter(|&k| self.weights[k] > 0.0 && !covered(self.vertices[k]))
            .map(|k| self.weights[k])
            .sum();
        if open >= total || open <= 1e-4 * total {
            return self;
        }
        let mut out = self;
        for k in 0..4 {
            out.weights[k] = if covered(self.vertices[k]) {
                0.0
            } else {
                self.weights[k] / open
            };
        }
        out
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

/// Whether the quadrilateral's fourth corner lies in the plane of the first three
/// (within 1e-5 of its diagonal).
fn planar([a, b, c, d]: [Vec3; 4]) -> bool {
    let n = (b - a).cross(c - a).normalize_or_zero();
    n.dot(d - a).abs() <= 1e-5 * (c - a).length().max((d - b).length())
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

/// Most elements along a side of a lone polygon's own grid, and most pieces along a
/// side of a cut surface: a tiny `--mesh-size` must not make either unbounded.
pub const MAX_DIVISIONS: u32 = 256;

/// Subdivisions for a length: at least 1, at most [`MAX_DIVISIONS`].
fn divisions(len: f32, size: f32) -> u32 {
    if !(len > 0.0) || !(size > 0.0) {
        return 1;
    }
    ((len / size).ceil() as u32).clamp(1, MAX_DIVISIONS)
}

impl Grid {
    fn vertex_count(&self) -> u32 {
        match &self.domain {
            Domain::Tri(_) => (self.n + 1) * (self.n + 2) / 2,
            Domain::Lattice(l) => l.nodes.len() as u32,
            _ => (self.n + 1) * (self.m + 1),
        }
    }

    fn element_count(&self) -> u32 {
        match &self.domain {
            Domain::Tri(_) => self.n * self.n,
            Domain::Lattice(l) => l.cells.len() as u32,
            _ => self.n * self.m,
        }
    }

    /// Position and normal at parameters (s, t).
    fn eval(&self, s: f32, t: f32) -> (Vec3, Vec3) {
        let (p, n) = self.eval_front(s, t);
        (p, if self.flip { -n } else { n })
    }

    fn eval_front(&self, s: f32, t: f32) -> (Vec3, Vec3) {
        match &self.domain {
            Domain::Tri([a, b, c]) => {
                let n = (*b - *a).cross(*c - *a).normalize_or(Vec3::Z);
                (*a + (*b - *a) * s + (*c - *a) * t, n)
            }
            Domain::Quad([a, b, c, d]) => {
                let p = (*a * (1.0 - s) + *b * s) * (1.0 - t) + (*d * (1.0 - s) + *c * s) * t;
                (p, quad_normal([*a, *b, *c, *d]))
            }
            Domain::Curved { surface, u, v } => {
                let uu = u[0] + (u[1] - u[0]) * s;
                let vv = v[0] + (v[1] - v[0]) * t;
                (surface.eval(uu, vv).0, surface.normal(uu, vv))
            }
            // A lattice has no parameterisation; its vertices are placed by position.
            Domain::Lattice(_) => (Vec3::ZERO, Vec3::Z),
        }
    }

    /// Area element |dP/ds x dP/dt| at (s, t) (for triangles: twice the area).
    fn jacobian(&self, s: f32, t: f32) -> f32 {
        match &self.domain {
            Domain::Tri([a, b, c]) => (*b - *a).cross(*c - *a).length(),
            Domain::Quad([a, b, c, d]) => {
                let ds = (*b - *a) * (1.0 - t) + (*c - *d) * t;
                let dt = (*d - *a) * (1.0 - s) + (*c - *b) * s;
                ds.cross(dt).length()
            }
            Domain::Curved { surface, u, v } => {
                let (_, du, dv) = surface.eval(u[0] + (u[1] - u[0]) * s, v[0] + (v[1] - v[0]) * t);
                du.cross(dv).length() * ((u[1] - u[0]) * (v[1] - v[0])).abs()
            }
            Domain::Lattice(_) => 0.0,
        }
    }

    /// The element containing parameters (s, t) and the weights of its corners
    /// (covered corners left out, see [`Interp::uncover`]).
    fn interp(&self, s: f32, t: f32) -> Interp {
        let w = self.interp_all(s, t);
        if self.covered.is_empty() {
            return w;
        }
        let base = self.first_vertex;
        w.uncover(|v| self.covered[(v - base) as usize])
    }

    /// [`Grid::interp`] over all the element's corners.
    fn interp_all(&self, s: f32, t: f32) -> Interp {
        let base = self.first_vertex;
        match self.domain {
            Domain::Tri(_) => {
                let k = self.n;
                let (fs, ft) = (s.clamp(0.0, 1.0) * k as f32, t.clamp(0.0, 1.0) * k as f32);
                let mut i = (fs.floor() as u32).min(k - 1);
                let mut j = (ft.floor() as u32).min(k - 1);
                // Rounding can put the cell past the diagonal: step back in.
                while i + j > k - 1 {
                    if i >= j {
                        i -= 1;
                    } else {
                        j -= 1;
                    }
                }
                let (a, b) = (fs - i as f32, ft - j as f32);
                let idx = |i: u32, j: u32| base + tri_vertex(k, i, j);
                if a + b <= 1.0 || i + j + 1 > k - 1 {
                    // Lower triangle (i,j), (i+1,j), (i,j+1).
                    let (a, b) = if a + b > 1.0 {
                        let sum = a + b;
                        (a / sum, b / sum)
                    } else {
                        (a, b)
                    };
                    Interp {
                        vertices: [idx(i, j), idx(i + 1, j), idx(i, j + 1), idx(i, j)],
                        weights: [1.0 - a - b, a, b, 0.0],
                    }
                } else {
                    // Upper triangle (i+1,j+1), (i,j+1), (i+1,j).
                    let (a2, b2) = (1.0 - a, 1.0 - b);
                    Interp {
                        vertices: [idx(i + 1, j + 1), idx(i, j + 1), idx(i + 1, j), idx(i, j)],
                        weights: [1.0 - a2 - b2, a2, b2, 0.0],
                    }
                }
            }
            _ => {
                let (n, m) = (self.n, self.m);
                let (fs, ft) = (s.clamp(0.0, 1.0) * n as f32, t.clamp(0.0, 1.0) * m as f32);
                let i = (fs.floor() as u32).min(n - 1);
                let j = (ft.floor() as u32).min(m - 1);
                let (a, b) = (fs - i as f32, ft - j as f32);
                let idx = |i: u32, j: u32| base + j * (n + 1) + i;
                Interp {
                    vertices: [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)],
                    weights: [(1.0 - a) * (1.0 - b), a * (1.0 - b), a * b, (1.0 - a) * b],
                }
            }
        }
    }
}

/// Local index of vertex (i, j) in a triangular grid of k subdivisions: rows of
/// constant j, each holding k + 1 - j vertices.
fn tri_vertex(k: u32, i: u32, j: u32) -> u32 {
    j * (k + 1) - j * j.saturating_sub(1) / 2 + i
}

/// Unit normal of a (nearly planar) quadrilateral by Newell's method.
fn quad_normal(q: [Vec3; 4]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for k in 0..4 {
        let (a, b) = (q[k], q[(k + 1) % 4]);
        n += Vec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n.normalize_or(Vec3::Z)
}

/// Parameters (s, t) of point `p` in quadrilateral `q` (inverse bilinear map), for a
/// planar quad; the point is projected into the quad's plane first.
fn inverse_bilinear(q: [Vec3; 4], p: Vec3) -> Vec2 {
    let n = quad_normal(q);
    // 2D frame in the quad's plane.
    let ex = (q[1] - q[0]).normalize_or(n.any_orthonormal_vector());
    let ey = n.cross(ex);
    let to2 = |v: Vec3| Vec2::new((v - q[0]).dot(ex), (v - q[0]).dot(ey));
    let (a, b, c, d, x) = (to2(q[0]), to2(q[1]), to2(q[2]), to2(q[3]), to2(p));
    // x = a + (b-a) s + (d-a) t + (a - b + c - d) s t
    let e = b - a;
    let f = d - a;
    let g = a - b + c - d;
    let h = x - a;
    let cross = |u: Vec2, v: Vec2| u.x * v.y - u.y * v.x;
    let k2 = cross(g, f);
    let k1 = cross(e, f) + cross(h, g);
    let k0 = cross(h, e);
    // k2 t^2 + k1 t + k0 = 0, its roots in the stable form (Numerical Recipes 5.6):
    // k0 / q and q / k2 with q = -(k1 + sign(k1) sqrt(disc)) / 2. The textbook form
    // (-k1 +- sqrt(disc)) / (2 k2) cancels catastrophically where the quad is nearly
    // a parallelogram (k2 is rounding noise): on the Cornell box's rotated block tops
    // it put points a fifth of the way across the top off (the light of the middle
    // shown 19 % bright, the photons' deposits piled on a few vertices).
    let disc = (k1 * k1 - 4.0 * k0 * k2).max(0.0).sqrt();
    let q = -0.5 * (k1 + disc.copysign(k1));
    let near = if q != 0.0 { k0 / q } else { 0.0 };
    let t = if (-0.01..=1.01).contains(&near) || k2 == 0.0 {
        near
    } else {
        q / k2
    };
    let denom_x = e.x + g.x * t;
    let denom_y = e.y + g.y * t;
    let s = if denom_x.abs() > denom_y.abs() {
        (h.x - f.x * t) / denom_x
    } else {
        (h.y - f.y * t) / denom_y
    };
    Vec2::new(s, t)
}

/// Barycentrics (of corners 1 and 2) of `p` projected into triangle `tri`.
fn barycentric(tri: [Vec3; 3], p: Vec3) -> Vec2 {
    let (e1, e2, v) = (tri[1] - tri[0], tri[2] - tri[0], p - tri[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (v1, v2) = (v.dot(e1), v.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if !(det.abs() > 0.0) {
        return Vec2::splat(1.0 / 3.0);
    }
    Vec2::new((d22 * v1 - d12 * v2) / det, (d11 * v2 - d12 * v1) / det)
}

impl RadiosityMesh {
    /// Meshes every patch of `scene` with elements no larger than `mesh_size`,
    /// after merging its polygons into clusters (see [`lattice`]). A surface with no
    /// diffuse reflectance that emits nothing keeps no radiosity: it gets the fewest
    /// vertices that still locate a hit (one element per patch).
    pub fn build(scene: &Scene, mesh_size: f32) -> Self {
        Self::build_refined(scene, mesh_size, &std::collections::HashMap::new())
    }

    /// [`RadiosityMesh::build`], with the patches named in `fine` (by shape and the
    /// index of their first polygon: [`MeshPatch::shape`], [`MeshPatch::local`])
    /// meshed at that fraction of the mesh size (see [`contact`] and [`near_light`]).
    /// Polygons merge into patches as at the full size, so the patches are the same.
    fn build_refined(
        scene: &Scene,
        mesh_size: f32,
        fine: &std::collections::HashMap<(u32, u32), f32>,
    ) -> Self {
        let mut mesh = RadiosityMesh {
            mesh_size,
            patches: Vec::new(),
            vertices: Vec::new(),
            shape_first_patch: Vec::with_capacity(scene.shapes.len()),
            patch_map: Vec::with_capacity(scene.shapes.len()),
            front_patches: 0,
            refined: fine.len() as u32,
            splits: std::collections::HashMap::new(),
            albedo: Vec::new(),
        };
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
        // Each shape's patches and vertices apart, in parallel (its indices counted
        // from its own first), then appended in shape order: the same mesh as one
        // shape after another.
        let parts: Vec<RadiosityMesh> = (0..scene.shapes.len())
            .into_par_iter()
            .map(|si| Self::shape_part(scene, si, mesh_size, fine, &emitting, rest_of[si]))
            .collect();
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
                    area: v.area,
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

    /// Number of elements.
    pub fn element_count(&self) -> usize {
        self.patches.iter().map(|p| p.element_count as usize).sum()
    }

    /// The (front) patch a ray hit: that of the hit triangle's polygon, or, where the
    /// polygon was cut into several ([`SPLIT_ABOVE`]), the piece holding the hit.
    pub fn patch_of(&self, scene: &Scene, hit: &Hit) -> u32 {
        let mesh = &scene.shapes[hit.shape as usize].mesh;
        let scene_patch = mesh.tri_patch[hit.tri as usize];
        let p = self.shape_first_patch[hit.shape as usize]
            + self.patch_map[hit.shape as usize][scene_patch as usize];
        // (Every hit of every pass asks: most scenes cut nothing and skip the lookup.)
        if self.splits.is_empty() {
            return p;
        }
        match self.splits.get(&p) {
            Some(cut) => {
                let [a, b, c] = mesh.triangle(hit.tri as usize);
                let x = a + (b - a) * hit.bary.x + (c - a) * hit.bary.y;
                p + cut.piece_at(x)
            }
            None => p,
        }
    }

    /// The patch a ray hit: the front patch of the hit triangle, or its back twin
    /// when the back of a two-sided patch was hit.
    pub fn patch_at(&self, scene: &Scene, hit: &Hit, front: bool) -> u32 {
        let p = self.patch_of(scene, hit);
        match (front, self.patches[p as usize].twin) {
            (false, Some(t)) => t,
            _ => p,
        }
    }

    /// Interpolation weights at a ray hit (its patch, element and corner weights);
    /// `front` tells which side was hit (the back of a two-sided patch has its own
    /// values). The patch is that of the first weighted vertex.
    pub fn locate(&self, scene: &Scene, hit: &Hit, p: Vec3, front: bool) -> Interp {
        self.locate_on(scene, self.patch_at(scene, hit, front), hit, p)
    }

    /// [`Self::locate`] on patch `patch`, already found by [`Self::patch_at`].
    pub fn locate_on(&self, scene: &Scene, patch: u32, hit: &Hit, p: Vec3) -> Interp {
        let patch = &self.patches[patch as usize];
        let grid = match patch.grids.len() {
            1 => &patch.grids[0],
            _ => {
                // A fan: the triangle whose barycentrics are most inside.
                patch
                    .grids
                    .iter()
                    .max_by(|a, b| {
                        let score = |g: &Grid| match g.domain {
                            Domain::Tri(t) => {
                                let b = barycentric(t, p);
                                b.x.min(b.y).min(1.0 - b.x - b.y)
                            }
                            _ => f32::NEG_INFINITY,
                        };
                        score(a).total_cmp(&score(b))
                    })
                    .expect("patch has grids")
            }
        };
        let st = match &grid.domain {
            Domain::Lattice(l) => return l.interp(grid.first_vertex, p),
            Domain::Tri(t) => barycentric(*t, p),
            Domain::Quad(q) => inverse_bilinear(*q, p),
            Domain::Curved {
                surface: ParamSurface::Quadric(q, _),
                u,
                v,
            } => {
                let uv = q.param_of(p).uv;
                Vec2::new((uv.x - u[0]) / (u[1] - u[0]), (uv.y - v[0]) / (v[1] - v[0]))
            }
            Domain::Curved { u, v, .. } => {
                let mesh = &scene.shapes[hit.shape as usize].mesh;
                let [a, b, c] = mesh.indices[hit.tri as usize].map(|i| mesh.uvs[i as usize]);
                let uv = a * (1.0 - hit.bary.x - hit.bary.y) + b * hit.bary.x + c * hit.bary.y;
                Vec2::new((uv.x - u[0]) / (u[1] - u[0]), (uv.y - v[0]) / (v[1] - v[0]))
            }
        };
        grid.interp(st.x, st.y)
    }

    /// The elements of patch `patch` as triangles of vertex indices (quadrilateral
    /// elements split along a diagonal), wound so that their normal is the patch's
    /// (for a back twin: the reversed one).
    pub fn element_triangles(&self, patch: u32) -> Vec<[u32; 3]> {
        self.triangles(patch, false)
    }

    /// The patch as few triangles of its vertices: the corners of each planar grid
    /// (one triangle or two), and a 2 x 2 grid of quads over a Bezier piece, which is
    /// curved. Wound like [`Self::element_triangles`]. For what depends only on the
    /// patch's shape, such as the solid angle it is seen under.
    pub fn outline_triangles(&self, patch: u32) -> Vec<[u32; 3]> {
        self.triangles(patch, true)
    }

    fn triangles(&self, patch: u32, outline: bool) -> Vec<[u32; 3]> {
        let p = &self.patches[patch as usize];
        let mut out = Vec::with_capacity(if outline { 8 } else { 2 * p.element_count as usize });
        for g in &p.grids {
            let base = g.first_vertex;
            match &g.domain {
                Domain::Lattice(l) => {
                    for &c in &l.cells {
                        let [a, b, cc, d] = l.cell_vertices(c).map(|v| base + v);
                        out.push([a, b, cc]);
                        out.push([a, cc, d]);
                    }
                }
                Domain::Tri(_) => {
                    let k = g.n;
                    let idx = |i: u32, j: u32| base + tri_vertex(k, i, j);
                    if outline {
                        out.push([idx(0, 0), idx(k, 0), idx(0, k)]);
                        continue;
                    }
                    for j in 0..k {
                        for i in 0..k - j {
                            out.push([idx(i, j), idx(i + 1, j), idx(i, j + 1)]);
                            if i + j + 1 < k {
                                out.push([idx(i + 1, j + 1), idx(i, j + 1), idx(i + 1, j)]);
                            }
                        }
                    }
                }
                _ => {
                    let idx = |i: u32, j: u32| base + j * (g.n + 1) + i;
                    // Grid lines kept: all, or the ends (and middles on a Bezier piece).
                    let lines = |n: u32| -> Vec<u32> {
                        match (outline, &g.domain) {
                            (false, _) => (0..=n).collect(),
                            (true, Domain::Curved { .. }) if n >= 2 => vec![0, n / 2, n],
                            (true, _) => vec![0, n],
                        }
                    };
                    let (us, vs) = (lines(g.n), lines(g.m));
                    for vj in vs.windows(2) {
                        for ui in us.windows(2) {
                            let (a, b, c, d) = (
                                idx(ui[0], vj[0]),
                                idx(ui[1], vj[0]),
                                idx(ui[1], vj[1]),
                                idx(ui[0], vj[1]),
                            );
                            out.push([a, b, c]);
                            out.push([a, c, d]);
                        }
                    }
                }
            }
        }
        // Parameter order follows the front's winding; turn triangles that face away
        // from their vertices' normals (back twins, and Bezier patches whose
        // parameterisation runs the other way).
        for t in &mut out {
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            let n = (b.p - a.p).cross(c.p - a.p);
            if n.dot(a.n + b.n + c.n) < 0.0 {
                t.swap(1, 2);
            }
        }
        out
    }
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

#[cfg(test)]
mod tests;
