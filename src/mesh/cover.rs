//! Vertices covered by geometry that rests on their surface.
//!
//! A vertex is a corner of an element wherever on the surface that corner falls:
//! behind a baseboard, under the frame of a board, a centimetre behind a panel
//! standing in front of a wall. Such a vertex sees no light, and interpolation spreads
//! its darkness an element wide into the visible surface around every such object; in
//! a furnished room those bands add up (the conference room's ceiling lost a tenth of
//! its light through them). A vertex is *covered* when the ray along its normal and
//! all but one in eight of a fixed set of 64 rays from its receiving point over its
//! hemisphere meet a surface within half an element, or meet one from behind: no
//! light reaches it but through a gap narrower than the mesh resolves (the
//! centimetre between a wall and a window or light fitting on it, which a vertex
//! near the fitting's edge sees out through at grazing angles), or it lies inside a
//! closed object (the floor under a box
//! resting on it, the wall behind a cabinet; the objects' faces wound outwards, as
//! Mitsuba's shapes and most models are).
//! Covered vertices drop out of the interpolation of every element they share with an
//! uncovered vertex ([`Interp::uncover`](super::Interp::uncover), used by
//! [`Lattice::interp`](super::Lattice::interp) and the grids'), and the area shares
//! are recomputed under that rule, so deposits in proportion to the weights over the
//! shares stay unbiased.

use std::collections::{HashMap, HashSet};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::{Domain, Grid, RadiosityMesh};
use crate::accel::{Accel, Hit, Ray};
use crate::interaction::offset_from;
use crate::sampling::cosine_direction;
use crate::scene::Scene;

/// Strata per side of the fixed cosine-distributed directions (64 rays at most).
const STRATA: u32 = 8;

/// Rays of the `STRATA^2` that may escape a covered vertex: one in eight. A vertex a
/// centimetre or two behind the edge of a panel that stands a centimetre off its
/// surface (a window or a light fitting on a wall) sees out only through that gap, at
/// grazing angles; a vertex in the corner of a room sees out through a quarter of its
/// hemisphere, and is not covered.
const MAX_OPEN: u32 = STRATA * STRATA / 8;

/// How far, in cells, a covered vertex sees at most in every direction.
const REACH: f32 = 0.5;

impl RadiosityMesh {
    /// The mesh the solver and a solution file use: [`RadiosityMesh::build`], again
    /// with the small patches near a small light (see [`super::near_light`]) and
    /// those that hold a small object (see [`super::contact`]) meshed finer if there
    /// are any, then [`RadiosityMesh::cover`].
    pub fn build_covered(scene: &Scene, mesh_size: f32, accel: &dyn Accel) -> Self {
        let mut parts: Vec<Self> = Self::shape_parts(scene, mesh_size, &HashMap::new(), &|_| true)
            .into_iter()
            .flatten()
            .collect();
        let mut mesh = Self::assemble(scene, mesh_size, 0, parts.iter().cloned());
        let (mut fine, used) = mesh.near_light(scene);
        for (k, f) in mesh.holding(scene, accel, used) {
            let e = fine.entry(k).or_insert(f);
            *e = e.min(f);
        }
        if !fine.is_empty() {
            // Only the shapes that hold a finer patch are meshed again.
            let shapes: HashSet<u32> = fine.keys().map(|k| k.0).collect();
            let redone = Self::shape_parts(scene, mesh_size, &fine, &|si| shapes.contains(&(si as u32)));
            for (part, new) in parts.iter_mut().zip(redone) {
                if let Some(new) = new {
                    *part = new;
                }
            }
            mesh = Self::assemble(scene, mesh_size, fine.len() as u32, parts);
        }
        mesh.cover(scene, accel);
        mesh.albedo = mesh.vertex_albedo(scene);
        mesh
    }

    /// Finds the covered vertices of every patch (see the module text), recomputes
    /// the area shares of the grids that have some, and gives every lattice its
    /// shares ([`RadiosityMesh::area_shares`]). Deterministic: fixed directions,
    /// no seed, so a solution file's mesh is rebuilt the same way.
    fn cover(&mut self, scene: &Scene, accel: &dyn Accel) {
        // Per vertex: how far its rays must reach (0: an inert surface, which keeps
        // no light: one element, infinite mesh size).
        let mut reach = vec![0.0f32; self.vertices.len()];
        for p in &self.patches {
            for g in &p.grids {
                let first = g.first_vertex as usize;
                let cell = match &g.domain {
                    Domain::Lattice(l) => l.cell,
                    _ => self.mesh_size,
                };
                if cell.is_finite() {
                    reach[first..first + g.vertex_count() as usize].fill(REACH * cell);
                }
            }
        }
        let covered: Vec<bool> = (0..self.vertices.len())
            .into_par_iter()
            .map(|v| reach[v] > 0.0 && self.enclosed(v, reach[v], scene, accel))
            .collect();
        // The grids with covered vertices keep their flags.
        self.patches
            .par_iter_mut()
            .flat_map_iter(|p| p.grids.iter_mut())
            .for_each(|grid| {
                let first = grid.first_vertex as usize;
                let flags = &covered[first..first + grid.vertex_count() as usize];
                if !flags.iter().any(|&c| c) {
                    return;
                }
                match &mut grid.domain {
                    Domain::Lattice(l) => l.covered = flags.to_vec(),
                    _ => grid.covered = flags.to_vec(),
                }
            });
        // Every lattice's shares, and those of the other grids that have covered
        // vertices.
        self.area_shares(|g| matches!(g.domain, Domain::Lattice(_)) || !g.covered.is_empty());
    }

    /// Whether the ray nearest the normal and all but [`MAX_OPEN`] of the fixed rays
    /// from vertex `v`'s receiving point meet a surface within `reach` or from behind
    /// (the inside of a closed object: the floor under a box resting on it), the rays
    /// nearest the normal first (most vertices end at the first).
    fn enclosed(&self, v: usize, reach: f32, scene: &Scene, accel: &dyn Accel) -> bool {
        let vx = &self.vertices[v];
        // Whether ray k of the strata x strata cosine-distributed set is shut.
        let shut = |k: u32, strata: u32| {
            let u = Vec2::new(
                ((k / strata) as f32 + 0.5) / strata as f32,
                ((k % strata) as f32 + 0.5) / strata as f32,
            );
            let dir = cosine_direction(vx.n, u);
            let ray = Ray {
                origin: offset_from(vx.q, vx.n, dir),
                dir,
                tmin: 0.0,
                tmax: f32::INFINITY,
            };
            // Anything within reach shuts it, and the early-exit query over that
            // short segment settles it cheaply; only a ray clear of it needs the
            // closest hit, to see whether it meets a surface from behind. (The same
            // answer as the closest hit alone: a pane the query passes is met there.)
            accel.occluded(&Ray { tmax: reach, ..ray })
                || accel
                    .intersect(&ray)
                    .is_some_and(|hit| shuts(scene, &hit, dir, reach))
        };
        // Rays `from..` of the strata x strata set that are open, counted up to one
        // past `limit`.
        let open = |strata: u32, from: u32, limit: u32| {
            let mut n = 0;
            for k in from..strata * strata {
                n += u32::from(!shut(k, strata));
                if n > limit {
                    break;
                }
            }
            n
        };
        // The ray nearest the normal decides alone: a vertex that sees out along its
        // normal is in the open (one ray for most vertices). Then a coarse look, half
        // the strata per side: all shut is covered, more than a quarter open is not
        // (twice the fine set's share: sixteen rays are a rough count); only what is
        // left takes the fine set.
        let coarse = STRATA / 2;
        if !shut(0, coarse) {
            return false;
        }
        match open(coarse, 1, coarse * coarse / 4) {
            0 => true,
            n if n > coarse * coarse / 4 => false,
            _ => open(STRATA, 0, MAX_OPEN) <= MAX_OPEN,
        }
    }
}

/// Whether `hit`, met by a ray along `dir`, shuts it in: the surface lies within
/// `reach`, or the ray met it from behind (it started inside a closed object: the floor
/// under a box resting on it).
pub(super) fn shuts(scene: &Scene, hit: &Hit, dir: Vec3, reach: f32) -> bool {
    let [a, b, c] = scene.shapes[hit.shape as usize].mesh.triangle(hit.tri as usize);
    hit.t <= reach || (b - a).cross(c - a).dot(dir) > 0.0
}

impl Grid {
    /// Each vertex's share of the grid's area under [`Grid::interp`] (covered
    /// vertices left out): the area element at the centres of 4 x 4 pieces of every
    /// element (pieces of the parameter triangle for a triangular grid), spread by
    /// the weights there, scaled to the grid's area; a lattice's are
    /// [`Lattice::area_shares`](super::Lattice::area_shares).
    pub(super) fn area_shares(&self) -> Vec<f32> {
        if let Domain::Lattice(l) = &self.domain {
            return l.area_shares();
        }
        let mut share = vec![0.0f32; self.vertex_count() as usize];
        let base = self.first_vertex;
        let mut add = |s: f32, t: f32, da: f32| {
            let w = self.interp(s, t);
            for k in 0..4 {
                share[(w.vertices[k] - base) as usize] += da * w.weights[k];
            }
        };
        const Q: u32 = 4;
        match self.domain {
            Domain::Tri(_) => {
                // Parameter triangles of side 1 / (k Q): Q^2 k^2 of them, each
                // 1 / (2 Q^2 k^2) of the unit triangle's parameter area.
                let k = self.n * Q;
                let piece = 0.5 / (k * k) as f32;
                for j in 0..k {
                    for i in 0..k - j {
                        let (s, t) = (i as f32 / k as f32, j as f32 / k as f32);
                        let h = 1.0 / k as f32;
                        add(s + h / 3.0, t + h / 3.0, piece * self.jacobian(s, t));
                        if i + j + 1 < k {
                            add(s + 2.0 * h / 3.0, t + 2.0 * h / 3.0, piece * self.jacobian(s, t));
                        }
                    }
                }
            }
            _ => {
                let (n, m) = (self.n * Q, self.m * Q);
                let cell = 1.0 / (n * m) as f32;
                for j in 0..m {
                    for i in 0..n {
                        let (s, t) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / m as f32);
                        add(s, t, cell * self.jacobian(s, t));
                    }
                }
            }
        }
        let sum: f32 = share.iter().sum();
        if sum > 0.0 {
            for a in &mut share {
                *a *= self.area / sum;
            }
        }
        share
    }
}
