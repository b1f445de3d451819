//! Patches that follow surfaces, not triangles.
//!
//! The scene's polygons are grouped, per shape, into *clusters*: polygons that share
//! an edge and face the same way (the same dominant axis of the normal) are joined when
//! they are coplanar, or when both are small (no edge longer than the mesh size) and
//! lie in one *slab* across that axis, a quarter of the mesh size thick. A
//! cluster of one large polygon is meshed by its own grid (see `mod.rs`); every other
//! cluster becomes one patch meshed by a *lattice*: a regular square grid of side
//! `mesh size` in the plane perpendicular to the cluster's dominant axis. Its vertices
//! are the corners of the lattice cells the cluster's triangles overlap, each placed
//! at the nearest point of the surface; a point of the surface is interpolated
//! bilinearly from the four corners of its cell. So a plane cut into 10,000 triangles
//! is one patch with (area / mesh size^2) elements, and a finely tessellated chair gets
//! vertices no closer than the mesh size, whatever its triangle count.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::Interp;
use crate::geometry::{Patch, TriMesh};

/// A lattice over one cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    /// The axis the lattice plane is perpendicular to (0 x, 1 y, 2 z).
    pub axis: u8,
    /// Lattice coordinates of the lower corner of cell (0, 0).
    pub origin: Vec2,
    /// Cell side (world units, in the lattice plane).
    pub cell: f32,
    /// Cells along the two lattice coordinates.
    pub n: u32,
    /// See `n`.
    pub m: u32,
    /// The nodes that are vertices: (node key `j * (n + 1) + i`, vertex offset in the
    /// patch), sorted by key.
    pub nodes: Vec<(u32, u32)>,
    /// Node key to vertex offset (`u32::MAX`: not a vertex) over the whole lattice,
    /// where the vertices fill at least a quarter of its nodes; empty otherwise (then
    /// `nodes` is searched). Looking up a point's four corners was a tenth of the
    /// conference room's solve as binary searches.
    index: Vec<u32>,
    /// The cells used (key `j * n + i`), sorted: the elements.
    pub cells: Vec<u32>,
    /// The cluster's triangles (the exact surface), wound to face the patch's side.
    pub surface: Vec<[Vec3; 3]>,
    /// Per vertex offset: covered by geometry resting on the surface (a baseboard, a
    /// panel a centimetre in front of a wall), so it sees no light. Covered vertices
    /// take no part in interpolating the cells they share with uncovered ones: their
    /// darkness would bleed a cell wide into the visible surface around every object
    /// standing on it. Empty unless the mesh was built by
    /// [`RadiosityMesh::build_covered`](super::RadiosityMesh::build_covered).
    pub covered: Vec<bool>,
}

/// The world axes of the two lattice coordinates of a lattice perpendicular to `axis`
/// (counter-clockwise in them faces +`axis`).
fn plane_axes(axis: u8) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    }
}

/// The two lattice coordinates of `p` for a lattice perpendicular to `axis`.
pub fn project(axis: u8, p: Vec3) -> Vec2 {
    let (u, v) = plane_axes(axis);
    Vec2::new(p[u], p[v])
}

fn tri_normal(t: &[Vec3; 3]) -> Vec3 {
    (t[1] - t[0]).cross(t[2] - t[0])
}

/// Closest point of triangle `t` to `x`, both in lattice coordinates; returns its
/// barycentrics (of corners 1 and 2).
fn closest_2d(t: [Vec2; 3], x: Vec2) -> Vec2 {
    let (a, b, c) = (t[0], t[1], t[2]);
    let cross = |u: Vec2, v: Vec2| u.x * v.y - u.y * v.x;
    let area = cross(b - a, c - a);
    if area.abs() > 1e-20 {
        let l1 = cross(x - a, c - a) / area;
        let l2 = cross(b - a, x - a) / area;
        if l1 >= 0.0 && l2 >= 0.0 && l1 + l2 <= 1.0 {
            return Vec2::new(l1, l2);
        }
    }
    // On an edge: the nearest of the three edge projections.
    let seg = |p: Vec2, q: Vec2| {
        let d = q - p;
        let l = d.length_squared();
        let s = if l > 0.0 {
            ((x - p).dot(d) / l).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (s, (p + d * s - x).length_squared())
    };
    let (s0, d0) = seg(a, b);
    let (s1, d1) = seg(b, c);
    let (s2, d2) = seg(c, a);
    if d0 <= d1 && d0 <= d2 {
        Vec2::new(s0, 0.0)
    } else if d1 <= d2 {
        Vec2::new(1.0 - s1, s1)
    } else {
        Vec2::new(0.0, 1.0 - s2)
    }
}

/// Whether triangle `t` overlaps the square `[lo, lo + side]^2` (separating axes).
fn overlaps(t: [Vec2; 3], lo: Vec2, side: f32) -> bool {
    let hi = lo + Vec2::splat(side);
    let tlo = t[0].min(t[1]).min(t[2]);
    let thi = t[0].max(t[1]).max(t[2]);
    if tlo.x > hi.x || tlo.y > hi.y || thi.x < lo.x || thi.y < lo.y {
        return false;
    }
    let corners = [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)];
    for k in 0..3 {
        let (p, q, r) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let e = q - p;
        let nrm = Vec2::new(-e.y, e.x);
        let side_r = nrm.dot(r - p);
        // The square lies wholly on the side away from r: separated.
        let eps = 1e-6 * (e.length() * side).max(1e-30);
        if corners.iter().all(|c| nrm.dot(*c - p) * side_r.signum() < -eps) {
            return false;
        }
    }
    true
}

impl Lattice {
    /// The cluster cut into about `count` blocks of lattice cells for shooting, when it
    /// is planar: each block a rectangle of the lattice plane, cut to the cluster's
    /// bounds and lifted onto its plane, counter-clockwise seen from the front; only
    /// blocks holding a used cell. So the cells tile the surface, and a receiver near
    /// any part of it sees that part (a sample of the cluster's triangles would leave
    /// gaps next to it). `None` for a cluster that is not planar.
    pub fn blocks(&self, count: u32) -> Option<Vec<[Vec3; 4]>> {
        let first = self.surface.first()?[0];
        let normal: Vec3 = self
            .surface
            .iter()
            .map(tri_normal)
            .sum::<Vec3>()
            .normalize_or_zero();
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        let mut extent = 0.0f32;
        for p in self.surface.iter().flatten() {
            let x = project(self.axis, *p);
            lo = lo.min(x);
            hi = hi.max(x);
            extent = extent.max((*p - first).abs().max_element());
        }
        let d = normal.dot(first);
        let along = normal[self.axis as usize];
        // Coplanar within the rounding of the positions (as the clustering allows).
        let tol = 1e-4 * extent.max(first.abs().max_element());
        if along.abs() < 0.5
            || self
                .surface
                .iter()
                .flatten()
                .any(|p| (normal.dot(*p) - d).abs() > tol)
        {
            return None;
        }
        // A point of the lattice plane lifted onto the cluster's plane.
        let lift = |x: Vec2| {
            let mut p = Vec3::ZERO;
            let (u, v) = plane_axes(self.axis);
            p[u] = x.x;
            p[v] = x.y;
            p[self.axis as usize] = (d - normal[u] * x.x - normal[v] * x.y) / along;
            p
        };
        // Square blocks of `side` cells, the smallest side that makes at most `count`.
        let blocks_of = |side: u32| {
            let mut b: Vec<(u32, u32)> = self
                .cells
                .iter()
                .map(|&c| ((c % self.n) / side, (c / self.n) / side))
                .collect();
            b.sort_unstable_by_key(|&(bi, bj)| (bj, bi));
            b.dedup();
            b
        };
        let used = self.cells.len().max(1) as f32;
        let mut side = ((used / count.max(1) as f32).sqrt().ceil() as u32).max(1);
        let mut blocks = blocks_of(side);
        while blocks.len() > count.max(1) as usize {
            let grow = (blocks.len() as f32 / count.max(1) as f32).sqrt();
            side = ((side as f32 * grow).ceil() as u32).max(side + 1);
            blocks = blocks_of(side);
        }
        let flip = along < 0.0;
        Some(
            blocks
                .into_iter()
                .map(|(bi, bj)| {
                    let a = self.origin + Vec2::new((bi * side) as f32, (bj * side) as f32) * self.cell;
                    let b = a + Vec2::splat((side as f32) * self.cell);
                    let (a, b) = (a.max(lo), b.min(hi));
                    let quad = [a, Vec2::new(b.x, a.y), b, Vec2::new(a.x, b.y)].map(lift);
                    // Counter-clockwise in (u, v) faces +axis: reversed for a cluster
                    // facing the other way.
                    if flip {
                        [quad[0], quad[3], quad[2], quad[1]]
                    } else {
                        quad
                    }
                })
                .collect(),
        )
    }

    fn node_key(&self, i: u32, j: u32) -> u32 {
        j * (self.n + 1) + i
    }

    /// The vertex offset of node (i, j), if it is a vertex.
    pub fn node(&self, i: u32, j: u32) -> Option<u32> {
        let k = self.node_key(i, j);
        if !self.index.is_empty() {
            return self.index.get(k as usize).copied().filter(|&v| v != u32::MAX);
        }
        self.nodes
            .binary_search_by_key(&k, |e| e.0)
            .ok()
            .map(|x| self.nodes[x].1)
    }

    /// Lattice cell and offsets of a point given in lattice coordinates.
    fn cell_of(&self, x: Vec2) -> (u32, u32, f32, f32) {
        let f = (x - self.origin) / self.cell;
        let i = (f.x.floor().max(0.0) as u32).min(self.n - 1);
        let j = (f.y.floor().max(0.0) as u32).min(self.m - 1);
        let a = (f.x - i as f32).clamp(0.0, 1.0);
        let b = (f.y - j as f32).clamp(0.0, 1.0);
        (i, j, a, b)
    }

    /// Bilinear weights at point `p` of the surface over the vertices of its cell
    /// (`base` is the patch's first vertex). Corners that are not vertices (only at
    /// the rim of the cluster, within rounding) drop out and the rest are scaled up,
    /// as do covered corners ([`Interp::uncover`]); a point in no used cell takes the
    /// nearest vertex.
    pub fn interp(&self, base: u32, p: Vec3) -> Interp {
        let x = project(self.axis, p);
        let (i, j, a, b) = self.cell_of(x);
        let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
        let w = [(1.0 - a) * (1.0 - b), a * (1.0 - b), a * b, (1.0 - a) * b];
        let mut out = Interp {
            vertices: [base; 4],
            weights: [0.0; 4],
        };
        let mut sum = 0.0;
        for k in 0..4 {
            if let Some(v) = self.node(corners[k].0, corners[k].1) {
                out.vertices[k] = base + v;
                out.weights[k] = w[k];
                sum += w[k];
            }
        }
        if sum > 1e-6 {
            for wk in &mut out.weights {
                *wk /= sum;
            }
            if self.covered.is_empty() {
                return out;
            }
            return out.uncover(|v| self.covered[(v - base) as usize]);
        }
        // Nearest vertex node.
        let best = self
            .nodes
            .iter()
            .min_by(|u, v| {
                let d = |e: &(u32, u32)| {
                    let (ni, nj) = (e.0 % (self.n + 1), e.0 / (self.n + 1));
                    (self.origin + Vec2::new(ni as f32, nj as f32) * self.cell - x).length_squared()
                };
                d(u).total_cmp(&d(v))
            })
            .map(|e| e.1)
            .unwrap_or(0);
        Interp {
            vertices: [base + best; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
        }
    }

    /// Each vertex's share of the surface's area: each triangle's area spread by the
    /// interpolation weights at the centres of its pieces (pieces no larger than half
    /// a cell), so that a field deposited in proportion to the weights over the
    /// shares is unbiased.
    pub fn area_shares(&self) -> Vec<f32> {
        let mut area = vec![0.0f32; self.nodes.len()];
        for t in &self.surface {
            let a = 0.5 * tri_normal(t).length();
            let k = crate::geometry::cuts_for(t, 0.5 * self.cell, 64);
            let piece = a / (k * k) as f32;
            for q in crate::geometry::triangle_pieces(*t, k) {
                let w = self.interp(0, (q[0] + q[1] + q[2]) / 3.0);
                for c in 0..4 {
                    area[w.vertices[c] as usize] += piece * w.weights[c];
                }
            }
        }
        area
    }

    /// Vertex offsets of the corners of used cell `c`, counter-clockwise in lattice
    /// coordinates.
    pub fn cell_vertices(&self, c: u32) -> [u32; 4] {
        let (i, j) = (c % self.n, c / self.n);
        [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            .map(|(a, b)| self.node(a, b).expect("corner of a used cell"))
    }
}

/// A vertex made by [`build`]: position on the surface, normal and receiving point
/// (its area share comes later, from [`Lattice::area_shares`], once the mesh knows
/// which vertices are covered: see [`RadiosityMesh::area_shares`]).
///
/// [`RadiosityMesh::area_shares`]: super::RadiosityMesh::area_shares
pub struct LatticeVertex {
    pub p: Vec3,
    pub n: Vec3,
    pub q: Vec3,
}

/// Meshes the triangles `surface` (one cluster, wound to face its front) by a lattice
/// of side `cell`; returns the lattice, its vertices (in offset order) and the area.
pub fn build(surface: Vec<[Vec3; 3]>, cell: f32) -> (Lattice, Vec<LatticeVertex>, f32) {
    let axis = dominant_axis(&surface);
    let flat: Vec<[Vec2; 3]> = surface.iter().map(|t| t.map(|p| project(axis, p))).collect();
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for t in &flat {
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    let span = (hi - lo).max(Vec2::ZERO);
    let cells_along = |s: f32| ((s / cell).ceil() as u32).clamp(1, 1 << 14);
    let (n, m) = (cells_along(span.x), cells_along(span.y));
    // Centre the lattice on the cluster.
    let origin = lo - (Vec2::new(n as f32, m as f32) * cell - span) * 0.5;
    let mut lat = Lattice {
        axis,
        origin,
        cell,
        n,
        m,
        nodes: Vec::new(),
        index: Vec::new(),
        cells: Vec::new(),
        surface,
        covered: Vec::new(),
    };

    // Cells the triangles overlap.
    let mut used = Vec::new();
    for t in &flat {
        let tlo = t[0].min(t[1]).min(t[2]);
        let thi = t[0].max(t[1]).max(t[2]);
        let (i0, j0, _, _) = lat.cell_of(tlo);
        let (i1, j1, _, _) = lat.cell_of(thi);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let corner = origin + Vec2::new(i as f32, j as f32) * cell;
                if (i0 == i1 && j0 == j1) || overlaps(*t, corner, cell) {
                    used.push(j * n + i);
                }
            }
        }
    }
    used.sort_unstable();
    used.dedup();
    let mut keys: Vec<u32> = used
        .iter()
        .flat_map(|&c| {
            let (i, j) = (c % n, c / n);
            [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)].map(|(a, b)| b * (n + 1) + a)
        })
        .collect();
    keys.sort_unstable();
    keys.dedup();
    lat.cells = used;
    lat.nodes = keys.iter().enumerate().map(|(k, &key)| (key, k as u32)).collect();
    let all = (n as usize + 1) * (m as usize + 1);
    if all <= 4 * keys.len() {
        lat.index = vec![u32::MAX; all];
        for &(key, k) in &lat.nodes {
            lat.index[key as usize] = k;
        }
    }

    // Each vertex at the nearest surface point (nearest in the lattice plane), with
    // that triangle's normal; the receiving point a little towards the triangle's centre.
    let mut best: Vec<(f32, Vec3, Vec3, Vec3)> =
        vec![(f32::INFINITY, Vec3::ZERO, Vec3::Z, Vec3::ZERO); keys.len()];
    for (t, f) in lat.surface.iter().zip(&flat) {
        let nrm = tri_normal(t).normalize_or(Vec3::Z);
        let centre = (t[0] + t[1] + t[2]) / 3.0;
        let tlo = f[0].min(f[1]).min(f[2]) - Vec2::splat(cell);
        let thi = f[0].max(f[1]).max(f[2]) + Vec2::splat(cell);
        let (i0, j0, _, _) = lat.cell_of(tlo);
        let (i1, j1, _, _) = lat.cell_of(thi);
        for j in j0..=(j1 + 1).min(m) {
            for i in i0..=(i1 + 1).min(n) {
                let Some(v) = lat.node(i, j) else { continue };
                let x = origin + Vec2::new(i as f32, j as f32) * cell;
                let b = closest_2d(*f, x);
                let q2 = f[0] + (f[1] - f[0]) * b.x + (f[2] - f[0]) * b.y;
                let d = (q2 - x).length_squared();
                if d < best[v as usize].0 {
                    let p = t[0] + (t[1] - t[0]) * b.x + (t[2] - t[0]) * b.y;
                    best[v as usize] = (d, p, nrm, centre);
                }
            }
        }
    }
    let verts: Vec<LatticeVertex> = best
        .iter()
        .map(|&(_, p, n, c)| LatticeVertex {
            p,
            n,
            // A twentieth of a cell (at most half-way to the centre): from a point
            // nearer a corner of two walls than the ray offset, shadow rays would meet
            // the other wall at their start.
            q: p + (c - p) * (0.05 * cell / (c - p).length().max(1e-30)).min(0.5),
        })
        .collect();

    let total = lat
        .surface
        .iter()
        .map(|t| 0.5 * f64::from(tri_normal(t).length()))
        .sum::<f64>();
    (lat, verts, total as f32)
}

/// How the polygons of one shape are grouped into patches.
pub struct Clusters {
    /// Per scene patch, its cluster.
    pub of_patch: Vec<u32>,
    /// Per cluster, its scene patches in order.
    pub members: Vec<Vec<u32>>,
}

/// Slabs per mesh size across a cluster's axis: small polygons that are not coplanar
/// join only within one slab. A cluster's lattice lies across its axis, so a cluster
/// deep along it lies on top of itself there: a vertical blind's slats, joined along
/// its 8 m width, all took the light of the 14 vertices placed on some of them
/// (conference room: the blinds 15 % bright, FLIP 0.0452; slabs of the mesh size
/// 0.0448, of a half 0.0431, a quarter 0.0411 at 8 % more vertices, an eighth 0.0403
/// at 12 % more).
const SLABS: f32 = 4.0;

/// Groups the polygons of `mesh` (see the module's text); Bezier pieces stay alone.
/// `merge_all` joins every edge-connected polygon facing the same way, whatever its
/// size (for surfaces that keep no radiosity).
pub fn clusters(mesh: &TriMesh, mesh_size: f32, merge_all: bool) -> Clusters {
    let np = mesh.patches.len();
    let mut parent: Vec<u32> = (0..np as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    // The smaller root wins, so clusters are numbered by their first polygon.
    fn union(parent: &mut [u32], a: u32, b: u32) {
        let (ra, rb) = (find(parent, a), find(parent, b));
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
    // Per polygon: normal, plane offset, dominant axis with sign, and whether small.
    struct Info {
        n: Vec3,
        d: f32,
        bucket: u8,
        small: bool,
        centre: Vec3,
        /// The slab across the dominant axis ([`SLABS`]) that holds the centre.
        slab: i64,
    }
    let mut scale = 0.0f32;
    if let Some((a, b)) = mesh.bounds() {
        scale = (b - a).length();
    }
    let info: Vec<Option<Info>> = mesh
        .patches
        .iter()
        .map(|p| match p {
            Patch::Polygon(idx) if idx.len() >= 3 => {
                let pts: Vec<Vec3> = idx.iter().map(|&i| mesh.positions[i as usize]).collect();
                let mut n = Vec3::ZERO;
                for k in 0..pts.len() {
                    let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
                    n += a.cross(b);
                }
                let n = n.normalize_or_zero();
                if n == Vec3::ZERO {
                    return None;
                }
                let axis = if n.x.abs() >= n.y.abs() && n.x.abs() >= n.z.abs() {
                    0
                } else if n.y.abs() >= n.z.abs() {
                    1
                } else {
                    2
                };
                let bucket = axis * 2 + u8::from(n[axis as usize] < 0.0);
                let centre = pts.iter().sum::<Vec3>() / pts.len() as f32;
                let longest = (0..pts.len())
                    .map(|k| (pts[(k + 1) % pts.len()] - pts[k]).length())
                    .fold(0.0, f32::max);
                // Small: no edge longer than the mesh size, or no more area than one
                // element (long slivers: a chair leg's sides).
                let area = 0.5
                    * (1..pts.len() - 1)
                        .map(|k| (pts[k] - pts[0]).cross(pts[k + 1] - pts[0]))
                        .sum::<Vec3>()
                        .length();
                Some(Info {
                    n,
                    d: n.dot(pts[0]),
                    bucket,
                    small: longest <= mesh_size || area <= mesh_size * mesh_size,
                    centre,
                    slab: if mesh_size > 0.0 {
                        (centre[axis as usize] * SLABS / mesh_size).floor() as i64
                    } else {
                        0
                    },
                })
            }
            _ => None,
        })
        .collect();
    // Vertices identified by position (meshes may repeat a position).
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let canon: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let next = ids.len() as u32;
            *ids.entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .or_insert(next)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    let tol = 1e-5 * scale.max(1e-6);
    for (pi, p) in mesh.patches.iter().enumerate() {
        let (Patch::Polygon(idx), Some(a)) = (p, &info[pi]) else {
            continue;
        };
        for k in 0..idx.len() {
            let (u, v) = (canon[idx[k] as usize], canon[idx[(k + 1) % idx.len()] as usize]);
            let key = (u.min(v), u.max(v));
            match edges.get(&key) {
                None => {
                    edges.insert(key, pi as u32);
                }
                Some(&other) => {
                    let b = info[other as usize].as_ref().expect("listed polygons have info");
                    // Plane offsets carry the rounding of positions far from the
                    // origin: allow for it (a few ulps of the coordinates).
                    let rounding = 1e-6 * a.centre.abs().max_element().max(b.centre.abs().max_element());
                    let coplanar = a.n.dot(b.n) > 1.0 - 1e-4 && (a.d - b.d).abs() <= tol + rounding;
                    let curved = a.small && b.small && a.slab == b.slab;
                    if a.bucket == b.bucket && (coplanar || merge_all || curved) {
                        union(&mut parent, pi as u32, other);
                    }
                }
            }
        }
    }
    // Small polygons facing the same way whose centres fall in one cube of the mesh
    // size (one slab deep along their axis) join too, connected or not: the parts of
    // a finely modelled object (a chair's slats, a lamp's ribs) share vertices no
    // closer than the mesh size.
    let mut cubes: HashMap<(u8, [i64; 3]), u32> = HashMap::new();
    for (pi, a) in info.iter().enumerate() {
        let Some(a) = a else { continue };
        if !(a.small || merge_all) || !(mesh_size > 0.0) {
            continue;
        }
        let c = (a.centre / mesh_size).floor();
        let mut key = (a.bucket, [c.x as i64, c.y as i64, c.z as i64]);
        key.1[usize::from(a.bucket / 2)] = a.slab;
        match cubes.get(&key) {
            None => {
                cubes.insert(key, pi as u32);
            }
            Some(&other) => union(&mut parent, pi as u32, other),
        }
    }
    let mut index: HashMap<u32, u32> = HashMap::new();
    let mut of_patch = Vec::with_capacity(np);
    let mut members: Vec<Vec<u32>> = Vec::new();
    for pi in 0..np as u32 {
        let r = find(&mut parent, pi);
        let next = members.len() as u32;
        let c = *index.entry(r).or_insert(next);
        if c == next {
            members.push(Vec::new());
        }
        members[c as usize].push(pi);
        of_patch.push(c);
    }
    Clusters { of_patch, members }
}

/// How a surface too large for one patch was cut into pieces: a grid of `kx` x `ky`
/// rectangles of side `step` from `lo`, in the plane perpendicular to `axis`.
#[derive(Debug, Clone, PartialEq)]
pub struct Cut {
    /// The axis the cutting plane is perpendicular to.
    pub axis: u8,
    /// Lattice coordinates of the lower corner of rectangle (0, 0).
    pub lo: Vec2,
    /// The rectangles' sides.
    pub step: Vec2,
    /// Rectangles along the first coordinate.
    pub kx: u32,
    /// Rectangles along the second.
    pub ky: u32,
    /// Per rectangle (row by row), its piece's patch counted from the first piece's
    /// (`u32::MAX`: no surface there).
    pub piece: Vec<u32>,
}

impl Cut {
    /// The piece (counted from the first) holding surface point `p`; the nearest
    /// rectangle's when rounding puts `p` in an empty one.
    pub fn piece_at(&self, p: Vec3) -> u32 {
        let x = (project(self.axis, p) - self.lo) / self.step;
        let i = (x.x.floor().max(0.0) as u32).min(self.kx - 1);
        let j = (x.y.floor().max(0.0) as u32).min(self.ky - 1);
        let k = (j * self.kx + i) as usize;
        if self.piece[k] != u32::MAX {
            return self.piece[k];
        }
        (0..self.piece.len())
            .filter(|&r| self.piece[r] != u32::MAX)
            .min_by_key(|&r| {
                let (a, b) = ((r as u32 % self.kx) as i64, (r as u32 / self.kx) as i64);
                (a - i as i64).abs() + (b - j as i64).abs()
            })
            .map_or(0, |r| self.piece[r])
    }
}

/// The axis a surface's lattice is perpendicular to: that of its summed normal's
/// largest component.
fn dominant_axis(surface: &[[Vec3; 3]]) -> u8 {
    let normal: Vec3 = surface.iter().map(tri_normal).sum();
    if normal.x.abs() >= normal.y.abs() && normal.x.abs() >= normal.z.abs() {
        0
    } else if normal.y.abs() >= normal.z.abs() {
        1
    } else {
        2
    }
}

/// Cuts a surface (triangles wound to face its front) whose lattice of side `cell`
/// would have more than `above` cells along a side into rectangles of at most `side`
/// cells a side (at most `most` rectangles a side, each then larger): the triangles
/// clipped to each rectangle that holds any, and the cut. `None` when the surface
/// fits in one patch.
pub fn cut(
    surface: &[[Vec3; 3]],
    cell: f32,
    above: u32,
    side: u32,
    most: u32,
) -> Option<(Vec<Vec<[Vec3; 3]>>, Cut)> {
    let axis = dominant_axis(surface);
    let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
    for t in surface {
        for p in t {
            lo = lo.min(project(axis, *p));
            hi = hi.max(project(axis, *p));
        }
    }
    let span = hi - lo;
    if !(span.x.is_finite() && span.y.is_finite() && cell > 0.0) {
        return None;
    }
    let along = |s: f32| (s / cell).ceil().max(1.0);
    let (n, m) = (along(span.x), along(span.y));
    if n <= above as f32 && m <= above as f32 {
        return None;
    }
    let pieces = |c: f32| ((c / side as f32).ceil() as u32).clamp(1, most);
    let (kx, ky) = (pieces(n), pieces(m));
    let step = Vec2::new(span.x / kx as f32, span.y / ky as f32).max(Vec2::splat(1e-30));
    let mut parts: Vec<Vec<[Vec3; 3]>> = vec![Vec::new(); (kx * ky) as usize];
    for t in surface {
        let f = t.map(|p| project(axis, p));
        let cross = |u: Vec2, v: Vec2| u.x * v.y - u.y * v.x;
        let area = cross(f[1] - f[0], f[2] - f[0]);
        let rect = |x: Vec2| {
            let r = ((x - lo) / step).floor();
            (
                (r.x.max(0.0) as u32).min(kx - 1),
                (r.y.max(0.0) as u32).min(ky - 1),
            )
        };
        let tlo = rect(f[0].min(f[1]).min(f[2]));
        let thi = rect(f[0].max(f[1]).max(f[2]));
        if tlo == thi || area.abs() <= 1e-12 * span.length_squared() {
            // Wholly in one rectangle (or seen edge-on): kept whole, where its centre is.
            let (i, j) = rect((f[0] + f[1] + f[2]) / 3.0);
            parts[(j * kx + i) as usize].push(*t);
            continue;
        }
        // The point of the triangle's plane over lattice coordinates x.
        let lift = |x: Vec2| {
            let l1 = cross(x - f[0], f[2] - f[0]) / area;
            let l2 = cross(f[1] - f[0], x - f[0]) / area;
            t[0] + (t[1] - t[0]) * l1 + (t[2] - t[0]) * l2
        };
        for j in tlo.1..=thi.1 {
            for i in tlo.0..=thi.0 {
                let r0 = lo + step * Vec2::new(i as f32, j as f32);
                let r1 = r0 + step;
                let poly = clip_to_rect(&f, r0, r1);
                for k in 1..poly.len().saturating_sub(1) {
                    let piece = [lift(poly[0]), lift(poly[k]), lift(poly[k + 1])];
                    if tri_normal(&piece).length_squared() > 0.0 {
                        parts[(j * kx + i) as usize].push(piece);
                    }
                }
            }
        }
    }
    let mut piece = vec![u32::MAX; parts.len()];
    let mut out = Vec::new();
    for (k, p) in parts.into_iter().enumerate() {
        if !p.is_empty() {
            piece[k] = out.len() as u32;
            out.push(p);
        }
    }
    Some((
        out,
        Cut {
            axis,
            lo,
            step,
            kx,
            ky,
            piece,
        },
    ))
}

/// The polygon `poly` clipped to the rectangle [r0, r1] (Sutherland-Hodgman).
fn clip_to_rect(poly: &[Vec2], r0: Vec2, r1: Vec2) -> Vec<Vec2> {
    let mut cur: Vec<Vec2> = poly.to_vec();
    // (axis, bound, keep below)
    for (axis, bound, below) in [
        (0, r0.x, false),
        (0, r1.x, true),
        (1, r0.y, false),
        (1, r1.y, true),
    ] {
        if cur.is_empty() {
            break;
        }
        let inside = |p: Vec2| if below { p[axis] <= bound } else { p[axis] >= bound };
        let mut next = Vec::with_capacity(cur.len() + 2);
        for k in 0..cur.len() {
            let (a, b) = (cur[k], cur[(k + 1) % cur.len()]);
            let (ia, ib) = (inside(a), inside(b));
            if ia {
                next.push(a);
            }
            if ia != ib {
                let s = (bound - a[axis]) / (b[axis] - a[axis]);
                let mut x = a + (b - a) * s;
                x[axis] = bound;
                next.push(x);
            }
        }
        cur = next;
    }
    cur
}
