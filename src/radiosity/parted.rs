//! Pieces of the mesh that an obstacle stands on between their vertices: a wall on a
//! floor, ceiling or wall that runs on under it into the next room. The radiosity
//! interpolated over such a piece mixes the two rooms' light, so a photon leaving it
//! takes its light from the vertices it sees ([`keep_visible`]). (A patch shot's
//! cell that a wall stands on aims its rays by its light instead,
//! `ShootPoint::from_patch_cell`.)

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{Accel, Ray};
use crate::mesh::{Interp, Piece, RadiosityMesh};
use crate::scene::{mean, Rgb};

/// How far above a piece's surface, in its side's lengths, [`parted_pieces`] and
/// [`keep_visible`] look for an obstacle between a point and a vertex.
const LIFT: f32 = 0.05;

/// A piece's vertices (where its field is interpolated from) whose light differs by
/// more than this factor may stand on either side of an obstacle ([`parted_pieces`]).
const CONTRAST: f32 = 2.0;

/// Whether an obstacle hides `b` from `a`, both lifted by `lift`.
fn hidden(accel: &dyn Accel, a: Vec3, b: Vec3, lift: Vec3) -> bool {
    let (a, b) = (a + lift, b + lift);
    accel.occluded(&Ray {
        origin: a,
        dir: b - a,
        tmin: 0.0,
        tmax: 1.0,
    })
}

/// The lift off a piece of area `area` with unit normal `n`.
fn lift(n: Vec3, area: f32) -> Vec3 {
    n * (LIFT * area.sqrt()).max(1e-4)
}

/// Per piece, whether an obstacle stands on it between its vertices. A photon from
/// such a piece takes its light from the vertices it sees ([`keep_visible`]):
/// interpolated across a wall, the lit room's light left from the dark side's strip
/// along the wall's foot (`scenes/two-rooms`: FLIP against Mitsuba 0.0350 / 0.0336 ->
/// 0.0314 / 0.0300 on render seeds 0 / 1; the Cornell box, paper room, hall, classroom
/// and wooden staircase within 0.0001). Only pieces whose vertices' `field` differs by
/// more than [`CONTRAST`] are tested, with a ray between each pair of its vertices
/// lifted off the surface by [`LIFT`] of its side. Returns the flags and the rays
/// cast.
pub(super) fn parted_pieces(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    pieces: &[Piece],
) -> (Vec<bool>, u64) {
    let out: Vec<(bool, u64)> = pieces
        .par_iter()
        .with_min_len(256)
        .map(|e| {
            let c = e.corners;
            let w = mesh.weights_on(e, (c[0] + c[1] + c[2]) / 3.0);
            let vs: Vec<u32> = (0..4)
                .filter(|&k| w.weights[k] > 0.0)
                .map(|k| w.vertices[k])
                .collect();
            let (lo, hi) = vs
                .iter()
                .map(|&v| mean(field[v as usize]))
                .fold((f32::INFINITY, 0.0f32), |(lo, hi), l| (lo.min(l), hi.max(l)));
            if !(hi > CONTRAST * lo) {
                return (false, 0);
            }
            let n = (c[1] - c[0]).cross(c[2] - c[0]);
            let up = lift(n.normalize_or(Vec3::Z), 0.5 * n.length());
            let mut rays = 0;
            for i in 0..vs.len() {
                for j in i + 1..vs.len() {
                    rays += 1;
                    let (a, b) = (mesh.vertices[vs[i] as usize].p, mesh.vertices[vs[j] as usize].p);
                    if hidden(accel, a, b, up) {
                        return (true, rays);
                    }
                }
            }
            (false, rays)
        })
        .collect();
    let rays = out.iter().map(|o| o.1).sum();
    (out.into_iter().map(|o| o.0).collect(), rays)
}

/// Drops from `w` (the weights at `x` on a piece of area `area`, unit normal `n`) the
/// vertices that an obstacle hides from `x` (both lifted off the surface by [`LIFT`]
/// of the piece's side), and scales the rest back to one; keeps `w` if that would
/// drop them all. Returns the rays cast.
pub(super) fn keep_visible(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    w: &mut Interp,
    x: Vec3,
    n: Vec3,
    area: f32,
) -> u64 {
    let up = lift(n, area);
    let mut kept = *w;
    let mut rays = 0;
    for k in 0..4 {
        if w.weights[k] > 0.0 {
            rays += 1;
            if hidden(accel, x, mesh.vertices[w.vertices[k] as usize].p, up) {
                kept.weights[k] = 0.0;
            }
        }
    }
    let sum: f32 = kept.weights.iter().sum();
    if sum > 0.0 {
        kept.weights.iter_mut().for_each(|x| *x /= sum);
        *w = kept;
    }
    rays
}
