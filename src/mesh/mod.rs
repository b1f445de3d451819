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

use crate::accel::Hit;
use crate::geometry::{ParamSurface, Patch};
use crate::scene::{Light, Rgb, Scene};

mod albedo;
mod build;
mod cells;
mod contact;
mod cover;
mod lattice;
mod midpoints;
mod near_light;
mod pieces;
mod size;

pub use albedo::{mean_albedo, textured_albedo};
pub use cells::{
    point_in_polygon, quarter, quarter_of_sixteenth, sixteenth_of, vector_area, Parting, ShootCell,
};
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

/// Whether the quadrilateral's fourth corner lies in the plane of the first three
/// (within 1e-5 of its diagonal).
fn planar([a, b, c, d]: [Vec3; 4]) -> bool {
    let n = (b - a).cross(c - a).normalize_or_zero();
    n.dot(d - a).abs() <= 1e-5 * (c - a).length().max((d - b).length())
}

/// Most elements along a side of a lone polygon's own grid, and most pieces along a
/// side of a cut surface: a tiny `--mesh-size` must not make either unbounded.
pub const MAX_DIVISIONS: u32 = 256;

impl Grid {
    /// The weights at point `p` of a flat grid (a lattice's, a triangle's, a
    /// quadrilateral's), covered vertices left out as everywhere; `None` for a curved
    /// grid, whose points are found by their parameters.
    pub fn flat_interp(&self, p: Vec3) -> Option<Interp> {
        let st = match &self.domain {
            Domain::Lattice(l) => return Some(l.interp(self.first_vertex, p)),
            Domain::Tri(t) => barycentric(*t, p),
            Domain::Quad(q) => inverse_bilinear(*q, p),
            Domain::Curved { .. } => return None,
        };
        Some(self.interp(st.x, st.y))
    }

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
            Domain::Lattice(_) | Domain::Tri(_) | Domain::Quad(_) => {
                return grid
                    .flat_interp(p)
                    .expect("a flat grid has weights at every point")
            }
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

    /// [`Grid::flat_interp`] of grid `grid` of patch `patch` (the grid of a flat
    /// shooting cell, [`ShootCell::grid`]).
    pub fn flat_interp(&self, patch: u32, grid: u32, p: Vec3) -> Option<Interp> {
        self.patches
            .get(patch as usize)?
            .grids
            .get(grid as usize)?
            .flat_interp(p)
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

#[cfg(test)]
mod tests;
