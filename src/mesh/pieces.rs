//! The surface of a patch in triangles no bigger than an element, with the
//! interpolation weights at any point of them: where photons leave a radiant patch
//! from, and where a light shot's projection samples a receiving patch.

use glam::{Vec2, Vec3};

use super::{barycentric, Domain, Interp, RadiosityMesh};
use crate::geometry::{cuts_for, triangle_pieces};

/// A piece of a patch's surface, no bigger than an element ([`RadiosityMesh::pieces`]).
#[derive(Debug, Clone, Copy)]
pub struct Piece {
    /// Corners (the exact surface, or an element over it).
    pub corners: [Vec3; 3],
    /// The patch.
    pub patch: u32,
    /// The element's vertices (`None`: a merged patch's own triangle, whose weights
    /// come from its lattice).
    pub verts: Option<[u32; 3]>,
}

impl RadiosityMesh {
    /// The surface of patch `p` in triangles no bigger than an element: a merged
    /// patch's own triangles cut to its lattice's cell (weights from the lattice), else
    /// its element triangles (weights barycentric).
    pub fn pieces(&self, p: u32) -> Vec<Piece> {
        let mp = &self.patches[p as usize];
        match mp.grids.first().map(|g| &g.domain) {
            Some(Domain::Lattice(l)) if mp.grids.len() == 1 => l
                .surface
                .iter()
                .flat_map(|t| triangle_pieces(*t, cuts_for(t, l.cell, 256)))
                .map(|corners| Piece {
                    corners,
                    patch: p,
                    verts: None,
                })
                .collect(),
            _ => self
                .element_triangles(p)
                .into_iter()
                .map(|t| Piece {
                    corners: t.map(|v| self.vertices[v as usize].p),
                    patch: p,
                    verts: Some(t),
                })
                .collect(),
        }
    }

    /// For a piece of a curved surface (a Bezier patch, sphere or disk), whose corners
    /// are a chord of it: the surface point over point `x` of the piece and the unit
    /// normal there (on the patch's side), at the parameters `x`'s barycentrics give.
    /// `None` on a flat patch, where `x` is on the surface already. Rays must leave a
    /// curved surface from here: from the chord, which lies inside a convex surface,
    /// they would meet the surface itself.
    pub fn surface_at(&self, e: &Piece, x: Vec3) -> Option<(Vec3, Vec3)> {
        let t = e.verts?;
        let g = self.patches[e.patch as usize].grids.iter().find(|g| {
            matches!(g.domain, Domain::Curved { .. })
                && t[0] >= g.first_vertex
                && t[0] - g.first_vertex < (g.n + 1) * (g.m + 1)
        })?;
        let st = |v: u32| {
            let k = v - g.first_vertex;
            Vec2::new(
                (k % (g.n + 1)) as f32 / g.n as f32,
                (k / (g.n + 1)) as f32 / g.m as f32,
            )
        };
        let b = barycentric(e.corners, x);
        let st = st(t[0]) * (1.0 - b.x - b.y) + st(t[1]) * b.x + st(t[2]) * b.y;
        Some(g.eval(st.x.clamp(0.0, 1.0), st.y.clamp(0.0, 1.0)))
    }

    /// The interpolation weights at point `x` of piece `e` (see [`Self::pieces`]).
    pub fn weights_on(&self, e: &Piece, x: Vec3) -> Interp {
        let mp = &self.patches[e.patch as usize];
        match (e.verts, mp.grids.first().map(|g| &g.domain)) {
            (None, Some(Domain::Lattice(l))) => l.interp(mp.grids[0].first_vertex, x),
            (Some(t), _) => {
                let b = barycentric(e.corners, x);
                Interp {
                    vertices: [t[0], t[1], t[2], t[0]],
                    weights: [1.0 - b.x - b.y, b.x, b.y, 0.0],
                }
            }
            (None, _) => Interp {
                vertices: [mp.first_vertex; 4],
                weights: [0.0; 4],
            },
        }
    }
}
