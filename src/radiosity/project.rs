//! What a point or spot light's shot passes on.
//!
//! A vertex stands for the surface its interpolation weight covers, and the light it
//! reflects onward (its unshot radiosity) should be the mean of the irradiance over
//! that surface, weighted as the interpolation weighs it: then a patch passes on just
//! the power it received (the weights sum to one everywhere). The irradiance at the
//! vertex itself is that mean wherever the light varies smoothly over its elements,
//! but not across the sharp edge of a spot's cone or of a shadow a point light casts:
//! there point values over- or under-count the power by where the vertices happen to
//! fall (on the paper room's floor and table, by 1.7 % of everything the two spots
//! bring, and so 2-3 % too much indirect light on every wall; 0.4 % at half the mesh
//! size). So, as the shadow image buffer casts rays only where shadows change, a
//! piece of surface is sampled at [`POINTS`] stratified points, each point's light
//! going to the vertices by their weights there, only where it is *mixed*: its
//! vertices disagree (one under half as bright as another), or the light at its
//! centre is not what they interpolate to there (a beam's edge or a shadow between
//! them), or, all its vertices dark, light reaches its centre or the middle of an
//! edge. Elsewhere the vertex value stands. On the paper room this costs 50,000
//! rays of 8 million.
//!
//! The per-vertex values the lists keep (for the selection's radiance and gradient
//! criteria) stay point values: the render ray-traces a listed light itself.

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::Accel;
use crate::emitters::SampledLight;
use crate::interaction::{shadow_ray, transmittance};
use crate::mesh::{point_in_polygon, RadiosityMesh};
use crate::sampling::{derive, stratum, Stream};
use crate::scene::{mean, Rgb, Scene};

/// Stratified points on a mixed piece as large as half an element of the mesh size
/// (a square of its side cut along a diagonal), at most: see [`points_on`].
pub const POINTS: u32 = 16;

/// Stratified points on a mixed piece of `area` in a mesh of `mesh_size`: [`POINTS`]
/// times its area over half an element's (a square of the mesh size), rounded up to a
/// power of two, at least one, at most [`POINTS`]. The power a piece's points can
/// misplace is at most its own, so a small piece needs fewer: the classroom's chairs,
/// cut into pieces far smaller than its 0.29 m elements, drew 3.9 M rays of the three
/// spots' shots, 1.1 s of their 1.4 s; with fewer points the shots take 0.5 s less at
/// the same FLIP against Mitsuba (0.0816 / 0.0810 -> 0.0805 / 0.0809, two seeds).
fn points_on(area: f32, mesh_size: f32) -> u32 {
    let half = 0.5 * mesh_size * mesh_size;
    if !(half > 0.0) || !half.is_finite() {
        return POINTS;
    }
    let n = (POINTS as f32 * area / half).ceil();
    if !(n >= 1.0) {
        return 1;
    }
    (n.min(POINTS as f32) as u32).next_power_of_two().min(POINTS)
}

/// A vertex value at most this fraction of the brightest of its piece makes the
/// piece mixed.
const MIXED: f32 = 0.5;

/// So does light at the piece's centre further than this fraction of its brightest
/// vertex from what the vertices interpolate to there.
const OFF: f32 = 0.02;

/// The radiosity each vertex of patch `p` passes on from a point or spot `light`:
/// `point` holds the reflected radiosity at every mesh vertex (its albedo,
/// [`RadiosityMesh::albedo`], times irradiance); the result is the patch's vertices' weighted means over their
/// surfaces, and the shadow rays cast. `None` where no piece of the patch is mixed
/// (the point values stand).
pub fn project(
    scene: &Scene,
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    light: &SampledLight,
    p: u32,
    point: &[Rgb],
    seed: u32,
) -> Option<(Vec<Rgb>, u64)> {
    let patch = &mesh.patches[p as usize];
    let opacity = if patch.opacity > 0.0 { patch.opacity } else { 1.0 };
    let first = patch.first_vertex as usize;
    let count = patch.vertex_count as usize;
    if !point[first..first + count].iter().any(|c| c.max_element() > 0.0) {
        return None;
    }
    let seed = derive(seed, Stream::Piece(p));
    // Per vertex of the patch: the sampled light and the weight it came with.
    let mut sum = vec![Vec3::ZERO; count];
    let mut weight = vec![0.0f32; count];
    let mut rays = 0u64;
    // The irradiance at `x` on a surface with normal `n`, with its shadow ray; and a
    // vertex's, its radiosity over the albedo it was made with (a texture's mean
    // there, which varies over a textured patch).
    let mut at = |x: Vec3, n: Vec3| -> Rgb {
        let Some((e, q)) = light.point_light_at(x, n) else {
            return Vec3::ZERO;
        };
        rays += 1;
        e * transmittance(scene, accel, &shadow_ray(x, n, q, None))
    };
    let irradiance = |v: u32| -> Rgb {
        let rho = mesh.albedo(v);
        Vec3::select(
            rho.cmpgt(Vec3::ZERO),
            point[v as usize] / rho.max(Vec3::splat(f32::MIN_POSITIVE)),
            Vec3::ZERO,
        )
    };
    let exact = patch.surface().is_some_and(|s| s.traced_exactly());
    for (i, e) in mesh.pieces(p).iter().enumerate() {
        let c = e.corners;
        let centre = (c[0] + c[1] + c[2]) / 3.0;
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        // The weights at the corners and the centre (the last).
        let ws = [c[0], c[1], c[2], centre].map(|x| mesh.weights_on(e, x));
        for w in &ws {
            for k in 0..4 {
                if w.weights[k] > 0.0 {
                    let b = mean(irradiance(w.vertices[k]));
                    lo = lo.min(b);
                    hi = hi.max(b);
                }
            }
        }
        let cross = (c[1] - c[0]).cross(c[2] - c[0]);
        let area = 0.5 * cross.length();
        if !(area > 0.0) {
            continue;
        }
        // The piece's normal, on the side the patch faces.
        let n = cross / (2.0 * area);
        let n = if n.dot(mesh.vertices[first].n) < 0.0 {
            -n
        } else {
            n
        };
        // Mixed: the vertices disagree, or the light at the centre is not what they
        // interpolate to there (the edge of a spot's beam, a shadow between them).
        // A piece whose vertices are all dark may still hold light between them (a
        // spot's beam edge bulging past an element's edge): its centre and the
        // middles of its edges tell.
        // On a sphere or disk light is taken on the exact surface, which the rays
        // meet: the piece is a chord of it, inside it and in its shadow. (A Bezier
        // piece keeps its chord: light taken on the exact surface measured worse on
        // the paper room's view b, FLIP 0.0468 against 0.0424, though better on view
        // a, 0.0377 against 0.0397.)
        let mut at = |x: Vec3| {
            let (x, n) = if exact {
                mesh.surface_at(e, x).unwrap_or((x, n))
            } else {
                (x, n)
            };
            at(x, n)
        };
        let mixed = if hi > 0.0 {
            lo < MIXED * hi || {
                let w = &ws[3];
                let guess: f32 = (0..4)
                    .map(|k| w.weights[k] * mean(irradiance(w.vertices[k])))
                    .sum();
                (mean(at(centre)) - guess).abs() > OFF * hi
            }
        } else {
            [
                centre,
                (c[0] + c[1]) * 0.5,
                (c[1] + c[2]) * 0.5,
                (c[2] + c[0]) * 0.5,
            ]
            .iter()
            .any(|&x| at(x).max_element() > 0.0)
        };
        if !mixed {
            continue;
        }
        let points = points_on(area, mesh.mesh_size);
        let a = area / points as f32;
        for j in 0..points {
            let x = point_in_polygon(&c, stratum(seed, (i as u32) << 7, j, points));
            let w = mesh.weights_on(e, x);
            let b = at(x);
            for k in 0..4 {
                let wk = w.weights[k];
                if wk > 0.0 {
                    let v = w.vertices[k] as usize - first;
                    sum[v] += b * (wk * a);
                    weight[v] += wk * a;
                }
            }
        }
    }
    if weight.iter().all(|&w| w == 0.0) {
        return None;
    }
    // The part of a vertex's surface on no mixed piece keeps the vertex's value.
    let out = (0..count)
        .map(|v| {
            // The vertex's geometric share (its area counts only what a mask leaves).
            let share = mesh.vertices[first + v].area / opacity;
            let rest = (share - weight[v]).max(0.0);
            let total = share.max(weight[v]);
            if total > 0.0 {
                let i = first as u32 + v as u32;
                (irradiance(i) * rest + sum[v]) / total * mesh.albedo(i)
            } else {
                point[first + v]
            }
        })
        .collect();
    Some((out, rays))
}

/// [`project`] over every patch that `receives`, in parallel: per patch, its
/// projected values (or `None`), and the rays cast in all.
pub fn project_all(
    scene: &Scene,
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    light: &SampledLight,
    receives: impl Fn(usize) -> bool + Sync,
    point: &[Rgb],
    seed: u32,
) -> (Vec<Option<Vec<Rgb>>>, u64) {
    let out: Vec<Option<(Vec<Rgb>, u64)>> = (0..mesh.patches.len())
        .into_par_iter()
        .map(|p| {
            if !receives(p) {
                return None;
            }
            project(scene, mesh, accel, light, p as u32, point, seed)
        })
        .collect();
    let rays = out.iter().flatten().map(|x| x.1).sum();
    (out.into_iter().map(|x| x.map(|y| y.0)).collect(), rays)
}
