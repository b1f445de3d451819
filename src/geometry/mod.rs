//! Geometry: triangle meshes with the patches (input polygons or pieces of curved
//! surfaces) they were made from, the built-in shapes, and bicubic Bezier patches.
//!
//! Everything is ray traced as triangles but spheres and disks, which rays meet
//! exactly ([`quadric`]). Each triangle remembers its *patch*: the input polygon, or
//! the piece of a Bezier patch, sphere or disk, that the radiosity pass meshes.

pub mod bezier;
mod form_factor;
pub mod obj;
pub mod ply;
pub mod quadric;
pub mod serialized;
pub mod shapes;
mod solid_angle;
mod text;
mod trimesh_build;

use glam::{Mat3, Mat4, Vec2, Vec3};

pub use bezier::BezierPatch;
pub use form_factor::{edge_term, point_polygon_form_factor, polygon_vector_form_factor};
pub use quadric::{Param, Quadric, QuadricKind};
pub use solid_angle::{front_solid_angle, triangle_solid_angle, Subtense};

/// What a radiosity patch is: an input polygon, or a parametric piece of a Bezier patch.
#[derive(Debug, Clone, PartialEq)]
pub enum Patch {
    /// A planar polygon; indices into the mesh's `positions`, counter-clockwise
    /// seen from the side the normal points to.
    Polygon(Vec<u32>),
    /// The piece `u0..u1 x v0..v1` of the mesh's Bezier patch `surface`.
    Bezier {
        /// Index into [`TriMesh::bezier`].
        surface: u32,
        /// Parameter range in u.
        u: [f32; 2],
        /// Parameter range in v.
        v: [f32; 2],
    },
    /// The piece `u0..u1 x v0..v1` of face `face` of the mesh's exact surface
    /// ([`TriMesh::quadric`]).
    Quadric {
        /// The face (see [`quadric`]).
        face: u8,
        /// Parameter range in u.
        u: [f32; 2],
        /// Parameter range in v.
        v: [f32; 2],
    },
}

/// A curved surface given by parameters `(u, v)`: what a Bezier or quadric patch is
/// a piece of, and what the radiosity mesh places its vertices on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamSurface {
    /// A bicubic Bezier patch.
    Bezier(BezierPatch),
    /// A face of a sphere or disk.
    Quadric(Quadric, u8),
}

impl ParamSurface {
    /// Point and partial derivatives `(p, dp/du, dp/dv)` at `(u, v)`.
    pub fn eval(&self, u: f32, v: f32) -> (Vec3, Vec3, Vec3) {
        match self {
            ParamSurface::Bezier(b) => b.eval(u, v),
            ParamSurface::Quadric(q, f) => q.eval(*f, u, v),
        }
    }

    /// The unit normal at `(u, v)` on the surface's front side.
    pub fn normal(&self, u: f32, v: f32) -> Vec3 {
        match self {
            ParamSurface::Bezier(b) => b.normal(u, v),
            ParamSurface::Quadric(q, f) => q.normal(*f, u, v),
        }
    }

    /// Whether the normal turns over it (all but a disk, which is flat).
    pub fn bends(&self) -> bool {
        !matches!(self, ParamSurface::Quadric(q, _) if q.kind == QuadricKind::Disk)
    }

    /// Whether rays meet this very surface (a sphere or disk), not a tessellation
    /// of it (a Bezier patch).
    pub fn traced_exactly(&self) -> bool {
        matches!(self, ParamSurface::Quadric(..))
    }
}

/// Largest coordinate a mesh may have: beyond it areas and squared distances
/// overflow `f32` (a triangle 1e19 wide has an infinite area).
pub const MAX_COORD: f32 = 1e15;

/// A triangle mesh in world space, with the patches it was made from.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals; empty for flat shading.
    pub normals: Vec<Vec3>,
    /// Per-vertex surface parameters (u, v); empty when the mesh has none.
    pub uvs: Vec<Vec2>,
    /// Triangles, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
    /// For each triangle, the index of its patch in `patches`.
    pub tri_patch: Vec<u32>,
    /// The patches (radiosity's unit of meshing).
    pub patches: Vec<Patch>,
    /// Bezier surfaces that `Patch::Bezier` entries refer to.
    pub bezier: Vec<BezierPatch>,
    /// The exact surface of a `sphere` or `disk`, which rays meet instead of the
    /// triangles (these stay as the index of its records: see [`Quadric::triangle_at`]).
    pub quadric: Option<Quadric>,
}

impl TriMesh {
    /// The surface parameters (u, v) at barycentrics `b` (the weights of the second and
    /// third corners) of triangle `tri`: the mesh's, interpolated over the triangle; a
    /// mesh without them gives `b` itself, as Mitsuba 3.
    pub fn uv_at(&self, tri: u32, b: Vec2) -> Vec2 {
        match self.indices.get(tri as usize) {
            Some(&[i, j, k]) if !self.uvs.is_empty() => {
                let uv = |i: u32| self.uvs.get(i as usize).copied().unwrap_or_default();
                uv(i) * (1.0 - b.x - b.y) + uv(j) * b.x + uv(k) * b.y
            }
            _ => b,
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The three corners of triangle `t`.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f32 {
        let [a, b, c] = self.triangle(t);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Total surface area (of a sphere or disk: the exact surface's).
    pub fn area(&self) -> f32 {
        match &self.quadric {
            Some(q) => q.area(),
            None => (0..self.triangle_count()).map(|t| self.triangle_area(t)).sum(),
        }
    }

    /// Appends `other`, renumbering its vertices, patches and Bezier surfaces. Neither
    /// may have an exact surface ([`Self::quadric`]), which stands for its whole mesh.
    pub fn append(&mut self, other: &TriMesh) {
        debug_assert!(self.quadric.is_none() && other.quadric.is_none());
        let v0 = self.positions.len() as u32;
        let p0 = self.patches.len() as u32;
        let b0 = self.bezier.len() as u32;
        // Keep per-vertex arrays aligned: fill missing normals/uvs only if either side has them.
        if !other.normals.is_empty() || !self.normals.is_empty() {
            self.fill_normals();
            let mut o = other.clone();
            o.fill_normals();
            self.normals.extend_from_slice(&o.normals);
        }
        if !other.uvs.is_empty() || !self.uvs.is_empty() {
            self.uvs.resize(self.positions.len(), Vec2::ZERO);
            if other.uvs.is_empty() {
                self.uvs
                    .extend(std::iter::repeat_n(Vec2::ZERO, other.positions.len()));
            } else {
                self.uvs.extend_from_slice(&other.uvs);
            }
        }
        self.positions.extend_from_slice(&other.positions);
        self.indices
            .extend(other.indices.iter().map(|t| t.map(|i| i + v0)));
        self.tri_patch.extend(other.tri_patch.iter().map(|p| p + p0));
        self.patches.extend(other.patches.iter().map(|p| match p {
            Patch::Polygon(v) => Patch::Polygon(v.iter().map(|i| i + v0).collect()),
            Patch::Bezier { surface, u, v } => Patch::Bezier {
                surface: surface + b0,
                u: *u,
                v: *v,
            },
            Patch::Quadric { face, u, v } => Patch::Quadric {
                face: *face,
                u: *u,
                v: *v,
            },
        }));
        self.bezier.extend_from_slice(&other.bezier);
    }

    /// Gives every vertex a normal (area-weighted face normals where none were set).
    fn fill_normals(&mut self) {
        if self.normals.len() == self.positions.len() {
            return;
        }
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in 0..self.indices.len() {
            let [a, b, c] = self.triangle(t);
            let fnorm = (b - a).cross(c - a);
            for &i in &self.indices[t] {
                n[i as usize] += fnorm;
            }
        }
        self.normals = n.into_iter().map(|v| v.normalize_or(Vec3::Z)).collect();
    }

    /// Applies an affine transform: points by `m`, normals by its inverse transpose.
    /// A transform that mirrors (negative determinant) keeps the front side by
    /// reversing the winding, as Mitsuba does.
    pub fn transform(&mut self, m: &Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let nm = Mat3::from_mat4(*m).inverse().transpose();
        for n in &mut self.normals {
            *n = (nm * *n).normalize_or(Vec3::Z);
        }
        for b in &mut self.bezier {
            for c in &mut b.ctrl {
                *c = m.transform_point3(*c);
            }
        }
        if let Some(q) = &mut self.quadric {
            q.transform(m);
        }
        if Mat3::from_mat4(*m).determinant() < 0.0 {
            self.reverse_winding();
        }
    }

    /// Turns the mesh inside out: reverses winding and negates shading normals.
    pub fn flip_normals(&mut self) {
        self.reverse_winding();
        for n in &mut self.normals {
            *n = -*n;
        }
        for b in &mut self.bezier {
            b.flipped = !b.flipped;
        }
        if let Some(q) = &mut self.quadric {
            q.flipped = !q.flipped;
        }
    }

    fn reverse_winding(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        for p in &mut self.patches {
            if let Patch::Polygon(v) = p {
                v.reverse();
            }
        }
    }

    /// Axis-aligned bounds `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }

    /// Checks the invariants every mesh must hold (indices in range, finite
    /// coordinates no larger than [`MAX_COORD`]); returns a description of the first
    /// violation. Loaders call this so that bad input becomes an error, not a panic.
    pub fn validate(&self) -> Result<(), String> {
        let nv = self.positions.len();
        if !self.normals.is_empty() && self.normals.len() != nv {
            return Err(format!("{} normals for {} vertices", self.normals.len(), nv));
        }
        if !self.uvs.is_empty() && self.uvs.len() != nv {
            return Err(format!("{} uvs for {} vertices", self.uvs.len(), nv));
        }
        if self.tri_patch.len() != self.indices.len() {
            return Err("triangle-to-patch map has the wrong length".into());
        }
        if let Some(p) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {p} has a non-finite coordinate"));
        }
        if let Some(p) = self
            .positions
            .iter()
            .position(|p| p.abs().max_element() > MAX_COORD)
        {
            return Err(format!(
                "vertex {p} is absurdly far from the origin ({}; at most {MAX_COORD:e} per coordinate)",
                self.positions[p]
            ));
        }
        for (t, tri) in self.indices.iter().enumerate() {
            if tri.iter().any(|&i| i as usize >= nv) {
                return Err(format!("triangle {t} refers to a vertex past the {nv} defined"));
            }
            if self.tri_patch[t] as usize >= self.patches.len() {
                return Err(format!("triangle {t} refers to a missing patch"));
            }
        }
        Ok(())
    }
}

/// Triangle `t` cut into `k x k` similar pieces of equal area, row by row: in each row
/// a piece pointing up, then (but for the last) one pointing down, all wound as `t`.
pub fn triangle_pieces(t: [Vec3; 3], k: u32) -> impl Iterator<Item = [Vec3; 3]> {
    let k = k.max(1);
    let at = move |i: u32, j: u32| {
        t[0] + (t[1] - t[0]) * (i as f32 / k as f32) + (t[2] - t[0]) * (j as f32 / k as f32)
    };
    (0..k).flat_map(move |j| {
        (0..k - j).flat_map(move |i| {
            let up = [at(i, j), at(i + 1, j), at(i, j + 1)];
            let down = (i + j + 1 < k).then(|| [at(i + 1, j + 1), at(i, j + 1), at(i + 1, j)]);
            std::iter::once(up).chain(down)
        })
    })
}

/// The least number of cuts along each edge (at least 1, at most `max`) for which
/// [`triangle_pieces`] makes pieces with no edge longer than `size`.
pub fn cuts_for(t: &[Vec3; 3], size: f32, max: u32) -> u32 {
    let longest = (0..3)
        .map(|i| (t[(i + 1) % 3] - t[i]).length())
        .fold(0.0, f32::max);
    if size > 0.0 {
        ((longest / size).ceil() as u32).clamp(1, max.max(1))
    } else {
        1
    }
}

/// The point of triangle `t` nearest to `p`: inside it, on an edge or at a corner,
/// by the regions of the triangle's plane that `p`'s projection falls in.
pub fn closest_on_triangle(p: Vec3, t: [Vec3; 3]) -> Vec3 {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if !(denom.abs() > 0.0) {
        // A degenerate triangle: its nearest corner.
        return [a, b, c]
            .into_iter()
            .min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared()))
            .unwrap_or(a);
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

#[cfg(test)]
mod closest_tests {
    use super::*;

    /// Against a brute-force search over a fine grid of the triangle's points.
    #[test]
    fn the_closest_point_of_a_triangle_is_the_nearest_of_its_points() {
        let t = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.2, 0.0),
            Vec3::new(0.5, 1.5, 0.3),
        ];
        let n = 200;
        let grid: Vec<Vec3> = (0..=n)
            .flat_map(|i| (0..=n - i).map(move |j| (i, j)))
            .map(|(i, j)| {
                t[0] + (t[1] - t[0]) * (i as f32 / n as f32) + (t[2] - t[0]) * (j as f32 / n as f32)
            })
            .collect();
        for p in [
            Vec3::new(0.7, 0.5, 1.0),
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(3.0, 0.0, -0.5),
            Vec3::new(1.5, 1.5, 0.2),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, -0.5, 0.1),
            Vec3::new(-0.5, 0.8, 0.0),
        ] {
            let got = closest_on_triangle(p, t);
            let best = grid
                .iter()
                .map(|q| (*q - p).length())
                .fold(f32::INFINITY, f32::min);
            assert!(
                ((got - p).length() - best).abs() < 0.01,
                "{p}: {got} at {} vs {best}",
                (got - p).length()
            );
        }
        // Degenerate: all corners in a line.
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!((closest_on_triangle(Vec3::new(3.0, 1.0, 0.0), line) - Vec3::X * 2.0).length() < 1e-6);
    }
}
