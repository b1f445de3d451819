//! The watertight ray/triangle test (Woop, Benthin & Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013; pbrt-v4's `IntersectTriangle`), four triangles at a
//! time.
//!
//! Per ray ([`PreparedRay`]): kz, the axis of the direction's largest component, kx and
//! ky the next two cyclically, and the shear `(-d[kx] sz, -d[ky] sz, sz = 1/d[kz])`
//! that maps the ray onto the +z axis from the origin. Per triangle: its corners
//! translated by the ray origin, permuted and sheared; the 2D edge functions `U`, `V`,
//! `W` of the origin with respect to the edges opposite corners 0, 1, 2. The ray hits
//! if they are all `>= 0` or all `<= 0` (both windings: materials may be two-sided) and
//! not all zero; `det = U + V + W`, the hit distance is `(U z0 + V z1 + W z2) / det`
//! and the barycentrics of corners 1 and 2 are `V / det`, `W / det`.
//!
//! An edge function depends only on its edge's two corners, transformed the same way
//! in every triangle (blocks store the corners, not edges, so a shared corner has
//! bit-identical coordinates), and a neighbour that shares the edge computes exactly
//! the same value or its negation: a ray through a shared edge or corner passes the
//! test of at least one of the triangles there, never of none. Edge functions that come out exactly 0 in
//! f32 are recomputed in f64 (exact products), as in the paper and pbrt-v4.

use glam::{Vec3, Vec4};

use super::PreparedRay;

/// Four consecutive triangles (in leaf order) side by side, x/y/z in separate
/// vectors, so that one 4-wide test covers a whole leaf (CWBVH leaves hold at most
/// three triangles) instead of one test per triangle. Lanes past the last triangle
/// are zero (a point triangle: never hit).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub(super) struct Tri4 {
    /// `v[i][axis]`: corner `i`'s coordinate on `axis`, per lane. (`v[i][3]` is unused:
    /// a row of four lets the test pick the ray's axes by `k & 3` without bounds
    /// checks; the block is 192 bytes, three cache lines, with or without it.)
    v: [[Vec4; 4]; 3],
}

impl Tri4 {
    pub(super) fn pack(tris: &[[Vec3; 3]]) -> Vec<Tri4> {
        tris.chunks(4)
            .map(|c| {
                let mut b = Tri4::default();
                for (k, t) in c.iter().enumerate() {
                    for (i, p) in t.iter().enumerate() {
                        for a in 0..3 {
                            b.v[i][a][k] = p[a];
                        }
                    }
                }
                b
            })
            .collect()
    }

    /// Hits of `r` on the lanes in `lanes` (bit k: lane k) within `[r.tmin, tmax]`:
    /// the bit mask of lanes hit, and per lane t and the barycentrics (b1, b2) of
    /// corners 1 and 2.
    #[inline(always)]
    pub(super) fn intersect(&self, r: &PreparedRay, lanes: u32, tmax: f32) -> (u32, Vec4, Vec4, Vec4) {
        let [kx, ky, kz] = r.k.map(|k| k & 3);
        let [sx, sy, sz] = r.shear;
        let [ox, oy, oz] = r.org_k;
        // Translated, permuted and sheared in x and y (z is scaled only if needed). No
        // fused multiply-adds: each corner must come out the same in every triangle.
        let corner = |v: &[Vec4; 4]| {
            let z = v[kz] - oz;
            (v[kx] - ox + sx * z, v[ky] - oy + sy * z, z)
        };
        let (ax, ay, az) = corner(&self.v[0]);
        let (bx, by, bz) = corner(&self.v[1]);
        let (cx, cy, cz) = corner(&self.v[2]);
        let mut e = [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax];
        let zero = Vec4::ZERO;
        let zeros = (e[0].cmpeq(zero) | e[1].cmpeq(zero) | e[2].cmpeq(zero)).bitmask() & lanes;
        if zeros != 0 {
            e = edges_f64([ax, bx, cx], [ay, by, cy], e, zeros);
        }
        let [u, v, w] = e;
        // (NaN fails both.)
        let pos = u.cmpge(zero) & v.cmpge(zero) & w.cmpge(zero);
        let neg = u.cmple(zero) & v.cmple(zero) & w.cmple(zero);
        let inside = (pos | neg).bitmask() & lanes;
        if inside == 0 {
            return (0, zero, zero, zero);
        }
        let det = u + v + w;
        let (az, bz, cz) = (sz * az, sz * bz, sz * cz);
        let t_scaled = u * az + v * bz + w * cz;
        // t = t_abs / det_abs: the segment test without a division.
        let t_abs = Vec4::select(det.cmplt(zero), -t_scaled, t_scaled);
        let det_abs = det.abs();
        // t > 0 strictly: a ray never hits the surface it starts on at t = 0. (pbrt-v4
        // also requires t to exceed a bound on its rounding error; radtrace's rays leave
        // surfaces offset by `interaction::ray_epsilon`, far more than that bound, so
        // the bound's 25 operations per block are left out.)
        let within =
            det.cmpne(zero) & t_abs.cmpgt(zero) & t_abs.cmpge(det_abs * r.tmin) & t_abs.cmple(det_abs * tmax);
        let inv_det = Vec4::ONE / det;
        let t = t_scaled * inv_det;
        // (An overflow to t = inf is no hit, even on an unbounded ray.)
        let hit = (within & t.cmplt(Vec4::INFINITY)).bitmask() & inside;
        (hit, t, v * inv_det, w * inv_det)
    }
}

/// The edge functions `e` with those of the lanes in `lanes` that are exactly zero
/// recomputed in f64 from the transformed corners' `x` and `y` (the products of two
/// f32 are exact in f64, so the sign is right). Only the zero ones: the others keep
/// the f32 values that a neighbour sharing the edge computes too.
#[cold]
#[inline(never)]
fn edges_f64(x: [Vec4; 3], y: [Vec4; 3], mut e: [Vec4; 3], lanes: u32) -> [Vec4; 3] {
    for k in (0..4).filter(|k| lanes >> k & 1 != 0) {
        for (i, ei) in e.iter_mut().enumerate() {
            if ei[k] == 0.0 {
                // Edge i runs from corner i + 2 to corner i + 1, as in the f32 formula.
                let (p, q) = ((i + 2) % 3, (i + 1) % 3);
                let d = x[p][k] as f64 * y[q][k] as f64 - y[p][k] as f64 * x[q][k] as f64;
                ei[k] = d as f32;
            }
        }
    }
    e
}
