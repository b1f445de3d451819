//! Patches that hold a small object, meshed finer.
//!
//! A teapot on a table darkens the table round its foot: the teapot's shadows and the
//! light its belly keeps off. The table top is a small patch, a few elements of the
//! mesh size across, and its vertices, 0.2 m apart in the paper room, cannot hold a
//! shadow a teapot wide: the light of the lit vertices round it spreads under the
//! teapot, and from there, by the table's shot and photons, onto the teapot's belly,
//! which the gather then reads back onto the table (paper room view b: the table
//! round the teapot 20-30 % bright against Mitsuba, mean FLIP 0.095 in that band).
//! The paper meshes "the most important surfaces" finer (Sect. 6); here a planar
//! patch of a few elements on which another surface comes within a mesh size over
//! enough of it is meshed at half the mesh size.
//!
//! Measured on view b (`--quality good`, FLIP against a 1024-spp Mitsuba reference):
//! the table top alone refined 0.0384 -> 0.0359, for 600 vertices (4 %); the teapot's
//! own pieces refined as well, nothing more (0.0353), the teapot's alone nothing
//! (0.0391), a quarter of the mesh size no better than a half (0.0360). Large
//! patches (floors, walls) have elements small beside what stands on them and are
//! left alone.

use std::collections::{HashMap, HashSet};

use rayon::prelude::*;

use super::cover::shuts;
use super::{Domain, RadiosityMesh};
use crate::accel::{Accel, Ray};
use crate::interaction::offset_from;
use crate::scene::Scene;

/// A patch is refined only if it has at least this many elements (something two
/// elements across rests on it)...
const MIN_ELEMENTS: u32 = 4;
/// ...and at most this many (a larger patch's elements are small beside what it holds).
pub(super) const MAX_ELEMENTS: u32 = 64;
/// Share of the patch's area over which another surface must come within a mesh size
/// (along the normal), or which lies under a closed object: a teapot on a 1.2 x 0.8 m
/// table covers 7 %, a table's four legs under its top 1 %...
const MIN_SHARE: f32 = 1.0 / 32.0;
/// ...and at most this: a patch covered over more than half of it is a hidden face
/// (a shelf's end against the cabinet's side, a block's bottom) or the floor of a
/// slot narrower than an element, not a surface something stands on.
const MAX_SHARE: f32 = 0.5;
/// Vertices the refinement may add, as a share of the mesh's (the conference room's
/// 281 patches that hold something add 4 %)...
const BUDGET: f32 = 0.25;
/// ...or this many, in a small scene.
const MIN_BUDGET: f32 = 4096.0;

impl RadiosityMesh {
    /// The patches to mesh at half the mesh size (see the module text), by shape and
    /// first polygon, with that fraction (1/2); the most covered first while the
    /// vertex budget lasts ([`BUDGET`], less `used`). Deterministic: fixed sample
    /// points, no seed.
    pub(super) fn holding(&self, scene: &Scene, accel: &dyn Accel, used: f32) -> HashMap<(u32, u32), f32> {
        let cut = self.cut_surfaces();
        let mut near: Vec<(u32, f32)> = (0..self.front_patches)
            .into_par_iter()
            .filter(|&p| {
                let mp = &self.patches[p as usize];
                !cut.contains(&(mp.shape, mp.local))
                    && (MIN_ELEMENTS..=MAX_ELEMENTS).contains(&mp.element_count)
                    && mp
                        .grids
                        .iter()
                        .all(|g| !matches!(g.domain, Domain::Curved { .. }))
            })
            .map(|p| (p, self.near_share(p, scene, accel)))
            .filter(|&(_, share)| (MIN_SHARE..=MAX_SHARE).contains(&share))
            .collect();
        near.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        self.refine_within(near.into_iter().map(|(p, _)| p), 0.5, used).0
    }

    /// The patches of `order` to mesh at `fraction` of the mesh size, in that
    /// order, while the vertices they add (about 1 / fraction^2 - 1 times theirs, on
    /// both sides of a two-sided patch) stay within the budget that the refinements
    /// share ([`BUDGET`], less `used` by an earlier one), by shape and first polygon;
    /// and the vertices they add.
    pub(super) fn refine_within(
        &self,
        order: impl Iterator<Item = u32>,
        fraction: f32,
        used: f32,
    ) -> (HashMap<(u32, u32), f32>, f32) {
        let mut budget = (BUDGET * self.vertices.len() as f32).max(MIN_BUDGET) - used;
        let mut added_all = 0.0;
        let mut fine = HashMap::new();
        for p in order {
            let mp = &self.patches[p as usize];
            let sides = if mp.twin.is_some() { 2.0 } else { 1.0 };
            let added = (1.0 / (fraction * fraction) - 1.0) * mp.vertex_count as f32 * sides;
            if added > budget {
                continue;
            }
            budget -= added;
            added_all += added;
            fine.insert((mp.shape, mp.local), fraction);
        }
        (fine, added_all)
    }

    /// The surfaces cut into several patches, by shape and first polygon: their
    /// pieces share it, so they are never refined (the whole surface would be).
    pub(super) fn cut_surfaces(&self) -> HashSet<(u32, u32)> {
        self.splits
            .keys()
            .map(|&p| (self.patches[p as usize].shape, self.patches[p as usize].local))
            .collect()
    }

    /// The share of patch `p`'s area over which a ray along its normal meets another
    /// patch within the mesh size, or from behind: four fixed points of each of its
    /// pieces.
    fn near_share(&self, p: u32, scene: &Scene, accel: &dyn Accel) -> f32 {
        let (mut hit_area, mut area) = (0.0f32, 0.0f32);
        for piece in self.pieces(p) {
            let [a, b, c] = piece.corners;
            let cross = (b - a).cross(c - a);
            let piece_area = 0.5 * cross.length();
            let Some(n) = cross.try_normalize() else {
                continue;
            };
            area += piece_area;
            for w in [[1.0, 1.0, 1.0], [4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]] {
                let x = (a * w[0] + b * w[1] + c * w[2]) / (w[0] + w[1] + w[2]);
                let ray = Ray {
                    origin: offset_from(x, n, n),
                    dir: n,
                    tmin: 0.0,
                    tmax: f32::INFINITY,
                };
                // Met within the mesh size, or from behind: the point is under a
                // closed object resting on the patch (a box's bottom on a table).
                if accel.intersect(&ray).is_some_and(|hit| {
                    shuts(scene, &hit, n, self.mesh_size) && self.patch_of(scene, &hit) != p
                }) {
                    hit_area += 0.25 * piece_area;
                }
            }
        }
        if area > 0.0 {
            hit_area / area
        } else {
            0.0
        }
    }
}
