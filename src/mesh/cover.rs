//! Vertices covered by geometry that rests on their surface.
//!
//! A lattice vertex is a corner of a cell that the surface overlaps, wherever on the
//! surface that corner falls: behind a baseboard, under the frame of a board, a
//! centimetre behind a panel standing in front of a wall. Such a vertex sees no light,
//! and bilinear interpolation spreads its darkness a cell wide into the visible
//! surface around every such object; in a furnished room those bands add up (the
//! conference room's ceiling lost a tenth of its light through them). A vertex is
//! *covered* when every one of a fixed set of rays from its receiving point over its
//! hemisphere meets a surface within half a cell: no light can reach it but through a
//! gap narrower than the mesh resolves. Covered vertices drop out of the interpolation
//! of every cell they share with an uncovered vertex (see [`Lattice::interp`]), and
//! the area shares are recomputed, so deposits stay unbiased.

use glam::Vec2;
use rayon::prelude::*;

use super::{Domain, Lattice, RadiosityMesh};
use crate::accel::{Accel, Ray};
use crate::interaction::offset_from;
use crate::sampling::cosine_direction;
use crate::scene::Scene;

/// Strata per side of the fixed cosine-distributed directions (16 rays at most).
const STRATA: u32 = 4;

/// How far, in cells, a covered vertex sees at most in every direction.
const REACH: f32 = 0.5;

impl RadiosityMesh {
    /// The mesh the solver and a solution file use: [`RadiosityMesh::build`], then
    /// [`RadiosityMesh::cover`].
    pub fn build_covered(scene: &Scene, mesh_size: f32, accel: &dyn Accel) -> Self {
        let mut mesh = Self::build(scene, mesh_size);
        mesh.cover(accel);
        mesh
    }

    /// Finds the covered vertices of every lattice patch (see the module text) and
    /// recomputes those lattices' area shares. Deterministic: fixed directions, no
    /// seed, so a solution file's mesh is rebuilt the same way.
    pub fn cover(&mut self, accel: &dyn Accel) {
        // Per vertex: how far its rays must reach (0: not a lattice vertex).
        let mut reach = vec![0.0f32; self.vertices.len()];
        for p in &self.patches {
            for g in &p.grids {
                if let Domain::Lattice(l) = &g.domain {
                    let first = g.first_vertex as usize;
                    reach[first..first + l.nodes.len()].fill(REACH * l.cell);
                }
            }
        }
        let covered: Vec<bool> = (0..self.vertices.len())
            .into_par_iter()
            .map(|v| reach[v] > 0.0 && self.sees_only_near(v, reach[v], accel))
            .collect();
        for p in 0..self.patches.len() {
            for g in 0..self.patches[p].grids.len() {
                let grid = &mut self.patches[p].grids[g];
                let first = grid.first_vertex as usize;
                let Domain::Lattice(l) = &mut grid.domain else {
                    continue;
                };
                let flags = &covered[first..first + l.nodes.len()];
                if !flags.iter().any(|&c| c) {
                    continue;
                }
                l.covered = flags.to_vec();
                let shares = l.area_shares();
                for (v, a) in self.vertices[first..].iter_mut().zip(shares) {
                    v.area = a;
                }
            }
        }
    }

    /// Whether every fixed ray from vertex `v`'s receiving point meets a surface
    /// within `reach` (the one nearest the normal first: most vertices end there).
    fn sees_only_near(&self, v: usize, reach: f32, accel: &dyn Accel) -> bool {
        let vx = &self.vertices[v];
        (0..STRATA * STRATA).all(|k| {
            let u = Vec2::new(
                ((k / STRATA) as f32 + 0.5) / STRATA as f32,
                ((k % STRATA) as f32 + 0.5) / STRATA as f32,
            );
            let dir = cosine_direction(vx.n, u);
            let ray = Ray {
                origin: offset_from(vx.q, vx.n, dir),
                dir,
                tmin: 0.0,
                tmax: reach,
            };
            accel.occluded(&ray)
        })
    }
}

impl Lattice {
    /// The number of covered vertices.
    pub fn covered_count(&self) -> usize {
        self.covered.iter().filter(|&&c| c).count()
    }
}
