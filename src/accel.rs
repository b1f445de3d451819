//! Acceleration: a BVH over all triangles of the scene, answering closest-hit and
//! early-exit occlusion queries (paper Sect. 4, "conventional ray tracing
//! efficiency techniques").
//!
//! [`Accel`] is the small interface the renderer uses; [`Bvh`] implements it, so
//! another BVH can replace it. The tree is built by the `obvhs` crate (PLOC, then
//! collapsed into a compressed 8-wide BVH, CWBVH); its nodes are then decoded to f32
//! child boxes and traversed here (CWBVH order, Ylitie et al. 2017), which takes 25-35%
//! fewer instructions per ray than obvhs's own traversal of the quantised nodes
//! (see the README's Performance section). Triangles are stored in leaf order, four
//! to a block, and tested four at a time (Moeller-Trumbore).

use glam::{Vec2, Vec3, Vec3A, Vec4};
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, node::CwBvhNode};
use obvhs::rt_triangle::RtTriangle;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use crate::scene::Scene;

/// A ray segment `origin + t * dir` for `t` in `[tmin, tmax]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Direction (need not be unit length; `t` is measured in its units).
    pub dir: Vec3,
    /// Start of the segment.
    pub tmin: f32,
    /// End of the segment.
    pub tmax: f32,
}

impl Ray {
    /// A ray from `origin` along `dir` to infinity.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// Where a ray hit: which triangle of which shape, and the barycentrics there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Index of the shape in [`Scene::shapes`].
    pub shape: u32,
    /// Index of the triangle within that shape's mesh.
    pub tri: u32,
    /// Barycentric weights `(b1, b2)` of the triangle's second and third corners.
    pub bary: Vec2,
}

/// Ray queries over a scene's triangles.
pub trait Accel: Send + Sync {
    /// The closest hit in `[ray.tmin, ray.tmax]`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything lies in `[ray.tmin, ray.tmax]`; stops at the first hit found.
    fn occluded(&self, ray: &Ray) -> bool;
}

/// Identifies a triangle of the scene.
#[derive(Debug, Clone, Copy)]
struct TriRef {
    shape: u32,
    tri: u32,
}

/// Four consecutive triangles (in leaf order) side by side, x/y/z in separate
/// vectors, so that one 4-wide Moeller-Trumbore test covers a whole leaf (CWBVH
/// leaves hold at most three triangles) instead of one test per triangle. The layout
/// of obvhs's `RtTriangle`: `e1 = v0 - v1`, `e2 = v2 - v0`, `ng = e1 x e2`. Lanes past
/// the last triangle are zero (`ng = 0`: never hit).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
struct Tri4 {
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
    ng: [Vec4; 3],
}

impl Tri4 {
    fn pack(tris: &[RtTriangle]) -> Vec<Tri4> {
        tris.chunks(4)
            .map(|c| {
                let mut b = Tri4::default();
                for (k, t) in c.iter().enumerate() {
                    for a in 0..3 {
                        b.v0[a][k] = t.v0[a];
                        b.e1[a][k] = t.e1[a];
                        b.e2[a][k] = t.e2[a];
                        b.ng[a][k] = t.ng[a];
                    }
                }
                b
            })
            .collect()
    }

    /// Hits of `r` on the lanes in `lanes` (bit k: lane k) within `[r.tmin, tmax]`:
    /// the bit mask of lanes hit, and per lane t and the barycentrics (b1, b2).
    #[inline(always)]
    fn intersect(&self, r: &PreparedRay, lanes: u32, tmax: f32) -> (u32, Vec4, Vec4, Vec4) {
        let [ox, oy, oz] = r.org;
        let [dx, dy, dz] = r.dir;
        let cx = self.v0[0] - ox;
        let cy = self.v0[1] - oy;
        let cz = self.v0[2] - oz;
        // r = d x c
        let rx = dy * cz - dz * cy;
        let ry = dz * cx - dx * cz;
        let rz = dx * cy - dy * cx;
        let [nx, ny, nz] = self.ng;
        let det = nx * dx + ny * dy + nz * dz;
        let inv_det = Vec4::ONE / det;
        let u = (rx * self.e2[0] + ry * self.e2[1] + rz * self.e2[2]) * inv_det;
        let v = (rx * self.e1[0] + ry * self.e1[1] + rz * self.e1[2]) * inv_det;
        let w = Vec4::ONE - u - v;
        let t = (nx * cx + ny * cy + nz * cz) * inv_det;
        let zero = Vec4::ZERO;
        let inside = u.cmpge(zero) & v.cmpge(zero) & w.cmpge(zero) & det.cmpne(zero);
        // (An overflow to t = inf is no hit, even on an unbounded ray.)
        let within = t.cmpge(Vec4::splat(r.tmin)) & t.cmple(Vec4::splat(tmax)) & t.cmplt(Vec4::INFINITY);
        ((inside & within).bitmask() & lanes, t, u, v)
    }
}

/// A node of the wide BVH: obvhs's CWBVH node with its eight child boxes decoded
/// from 8-bit quantised planes to f32 once, at build time. Traversal then tests four
/// children at a time with plain SIMD arithmetic (glam's `Vec4`), instead of
/// dequantising 48 bytes per visited node as obvhs's own traversal does (half of its
/// instructions in the profile).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct WideNode {
    /// `planes[g][axis][0]`: the children `4g..4g+4`'s lower bounds on `axis`;
    /// `[1]`: their upper bounds. Empty slots have lower +inf and upper -inf.
    planes: [[[Vec4; 2]; 3]; 2],
    /// The CWBVH child metadata (one byte per slot: leaf primitive offset and unary
    /// count, or inner-node slot + 24).
    meta: u64,
    /// Index of the first inner child in `nodes`.
    child_base: u32,
    /// Index of the first primitive of the leaf children in `tris`.
    prim_base: u32,
    /// Which slots hold inner nodes.
    imask: u32,
}

impl WideNode {
    fn decode(n: &CwBvhNode) -> Self {
        let e = n.compute_extent();
        let p = Vec3A::from(n.p);
        let mut planes = [[[Vec4::ZERO; 2]; 3]; 2];
        for c in 0..8 {
            let (g, k) = (c / 4, c % 4);
            let empty = n.child_meta[c] == 0;
            let lo = [n.child_min_x[c], n.child_min_y[c], n.child_min_z[c]];
            let hi = [n.child_max_x[c], n.child_max_y[c], n.child_max_z[c]];
            for a in 0..3 {
                // p + e q is exact in f64 (e is a power of two); widening by a few ulps
                // keeps the f32 box conservative.
                let l = p[a] as f64 + e[a] as f64 * lo[a] as f64;
                let h = p[a] as f64 + e[a] as f64 * hi[a] as f64;
                let pad = 4.0 * f32::EPSILON as f64 * l.abs().max(h.abs());
                planes[g][a][0][k] = if empty { f32::INFINITY } else { (l - pad) as f32 };
                planes[g][a][1][k] = if empty {
                    f32::NEG_INFINITY
                } else {
                    (h + pad) as f32
                };
            }
        }
        WideNode {
            planes,
            meta: u64::from_le_bytes(n.child_meta),
            child_base: n.child_base_idx,
            prim_base: n.primitive_base_idx,
            imask: n.imask as u32,
        }
    }

    /// The CWBVH hit mask of the children whose boxes `r` crosses within
    /// `[r.tmin, tmax]`: inner children as bits 24..32 (in the ray octant's order),
    /// leaf children as their primitives' bits 0..24 (Ylitie et al. 2017).
    #[inline(always)]
    fn intersect(&self, r: &PreparedRay, tmax: f32) -> u32 {
        let tmin4 = Vec4::splat(r.tmin);
        let tmax4 = Vec4::splat(tmax);
        let mut hits = 0u32;
        for (g, planes) in self.planes.iter().enumerate() {
            let [x, y, z] = planes;
            let tx0 = x[r.near[0]] * r.inv[0] - r.org_inv[0];
            let tx1 = x[r.near[0] ^ 1] * r.inv[0] - r.org_inv[0];
            let ty0 = y[r.near[1]] * r.inv[1] - r.org_inv[1];
            let ty1 = y[r.near[1] ^ 1] * r.inv[1] - r.org_inv[1];
            let tz0 = z[r.near[2]] * r.inv[2] - r.org_inv[2];
            let tz1 = z[r.near[2] ^ 1] * r.inv[2] - r.org_inv[2];
            let t0 = tx0.max(ty0).max(tz0.max(tmin4));
            let t1 = tx1.min(ty1).min(tz1.min(tmax4));
            hits |= t0.cmple(t1).bitmask() << (4 * g);
        }
        if hits == 0 {
            return 0;
        }
        // Per slot: the bits to set (1 for an inner child, the unary primitive count
        // for a leaf) and where (24 + the slot in octant order, or the primitive offset).
        const INNER: u64 = 0x1010_1010_1010_1010;
        const INDEX: u64 = 0x1f1f_1f1f_1f1f_1f1f;
        const COUNT: u64 = 0x0707_0707_0707_0707;
        let m = self.meta;
        let inner8 = ((m & (m << 1) & INNER) >> 4) * 0xff;
        let bit_index8 = (m ^ (r.oct_inv8 & inner8)) & INDEX;
        let child_bits8 = (m >> 5) & COUNT;
        let mut mask = 0u32;
        while hits != 0 {
            let c = hits.trailing_zeros();
            hits &= hits - 1;
            let bits = (child_bits8 >> (8 * c)) as u32 & 0xff;
            let at = (bit_index8 >> (8 * c)) as u32 & 0xff;
            mask |= bits << at;
        }
        mask
    }
}

/// A ray with what every node test needs precomputed.
struct PreparedRay {
    /// The ray's segment end.
    tmax: f32,
    /// Splatted origin per axis.
    org: [Vec4; 3],
    /// Splatted direction per axis.
    dir: [Vec4; 3],
    /// Splatted inverse direction per axis.
    inv: [Vec4; 3],
    /// Splatted origin x inverse direction per axis.
    org_inv: [Vec4; 3],
    /// Per axis, 0 if the ray enters the slabs at their lower plane, else 1.
    near: [usize; 3],
    tmin: f32,
    /// The ray octant, inverted, in every byte (CWBVH child order).
    oct_inv8: u64,
}

impl PreparedRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let origin = Vec3A::from(ray.origin);
        let dir = Vec3A::from(ray.dir);
        // obvhs's safe inverse (+-1/EPSILON for tiny components), branch-free. -0.0
        // gets a negative inverse, and the inverse's sign decides the near plane, so
        // -0.0 is handled like any negative component.
        let tiny = dir.abs().cmple(Vec3A::splat(f32::EPSILON));
        let inv = Vec3A::select(tiny, dir.signum() / f32::EPSILON, Vec3A::ONE / dir);
        let neg = inv.cmplt(Vec3A::ZERO).bitmask();
        let near = [(neg & 1) as usize, (neg >> 1 & 1) as usize, (neg >> 2) as usize];
        // The CWBVH child order: the inverted octant (x 4, y 2, z 1) in every byte.
        let oct = (((neg & 1) << 2) | (neg & 2) | (neg >> 2 & 1)) ^ 7;
        let oi = origin * inv;
        PreparedRay {
            tmax: ray.tmax,
            org: [
                Vec4::splat(origin.x),
                Vec4::splat(origin.y),
                Vec4::splat(origin.z),
            ],
            dir: [Vec4::splat(dir.x), Vec4::splat(dir.y), Vec4::splat(dir.z)],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            org_inv: [Vec4::splat(oi.x), Vec4::splat(oi.y), Vec4::splat(oi.z)],
            near,
            tmin: ray.tmin,
            oct_inv8: oct as u64 * 0x0101_0101_0101_0101,
        }
    }
}

/// Node groups (first child index, hit mask) still to visit: at most one per level
/// of the tree.
trait GroupStack {
    fn push(&mut self, g: (u32, u32));
    fn pop(&mut self) -> Option<(u32, u32)>;
}

/// A stack in an array, for trees at most `N + 1` levels deep. A group is packed in
/// a `u64`, so that setting the array up is a plain zero fill.
struct ArrayStack<const N: usize> {
    items: [u64; N],
    len: usize,
}

impl<const N: usize> ArrayStack<N> {
    #[inline(always)]
    fn new() -> Self {
        ArrayStack {
            items: [0; N],
            len: 0,
        }
    }
}

impl<const N: usize> GroupStack for ArrayStack<N> {
    #[inline(always)]
    fn push(&mut self, g: (u32, u32)) {
        self.items[self.len] = (g.0 as u64) << 32 | g.1 as u64;
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, u32)> {
        self.len = self.len.checked_sub(1)?;
        let g = self.items[self.len];
        Some(((g >> 32) as u32, g as u32))
    }
}

impl GroupStack for Vec<(u32, u32)> {
    fn push(&mut self, g: (u32, u32)) {
        Vec::push(self, g);
    }

    fn pop(&mut self) -> Option<(u32, u32)> {
        Vec::pop(self)
    }
}

/// A wide BVH (obvhs's CWBVH build, decoded to f32 child boxes) over the scene's
/// triangles, stored in BVH order.
pub struct Bvh {
    nodes: Vec<WideNode>,
    /// Levels of the tree (the root alone is 1).
    depth: usize,
    /// Triangles in the order of the BVH's leaves, four to a block.
    blocks: Vec<Tri4>,
    /// For each triangle in leaf order, the scene triangle it is (a split triangle
    /// appears more than once).
    refs: Vec<TriRef>,
    /// Distinct triangles.
    count: usize,
    /// Number of degenerate (zero-area or non-finite) triangles of input meshes left
    /// out (those of collapsed Bezier patch edges are left out too, but not counted).
    pub skipped: usize,
}

impl Bvh {
    /// Builds the BVH over every non-degenerate triangle of `scene`.
    pub fn build(scene: &Scene) -> Self {
        let mut tris = Vec::new();
        let mut refs = Vec::new();
        let mut skipped = 0;
        for (s, shape) in scene.shapes.iter().enumerate() {
            for t in 0..shape.mesh.triangle_count() {
                let [a, b, c] = shape.mesh.triangle(t);
                let n = (b - a).cross(c - a);
                if !(n.length_squared() > 0.0) || !(a + b + c).is_finite() {
                    // Collapsed edges of Bezier patches (the teapot's lid and bottom)
                    // give zero-area triangles by construction: not worth a warning.
                    let patch = &shape.mesh.patches[shape.mesh.tri_patch[t] as usize];
                    if !matches!(patch, crate::geometry::Patch::Bezier { .. }) {
                        skipped += 1;
                    }
                    continue;
                }
                tris.push(RtTriangle::new(a.into(), b.into(), c.into()));
                refs.push(TriRef {
                    shape: s as u32,
                    tri: t as u32,
                });
            }
        }
        Self::from_triangles(tris, refs, skipped)
    }

    fn from_triangles(tris: Vec<RtTriangle>, refs: Vec<TriRef>, skipped: usize) -> Self {
        if tris.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                depth: 0,
                blocks: Vec::new(),
                refs,
                count: 0,
                skipped,
            };
        }
        let mut build_time = Default::default();
        // obvhs's slow preset (wider PLOC search, more reinsertion, large triangles'
        // boxes pre-split): about 1.5x the medium preset's build time for 5-15% fewer
        // instructions per ray (callgrind, `radtrace bench`; the pre-splits are 4% of
        // that on the conference room). A split triangle is listed in several leaves.
        let corners: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle {
                v0: t.v0,
                v1: t.v0 - t.e1,
                v2: t.v0 + t.e2,
            })
            .collect();
        let bvh = build_cwbvh_from_tris(&corners, BvhBuildParams::slow_build(), &mut build_time);
        // Reorder the triangles into leaf order so traversal reads them contiguously.
        let tris: Vec<RtTriangle> = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
        let refs: Vec<TriRef> = bvh.primitive_indices.iter().map(|&i| refs[i as usize]).collect();
        let nodes: Vec<WideNode> = bvh.nodes.iter().map(WideNode::decode).collect();
        Bvh {
            depth: depth(&nodes),
            nodes,
            blocks: Tri4::pack(&tris),
            refs,
            count: corners.len(),
            skipped,
        }
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.count
    }

    /// Walks the tree for `r`. `leaf(b, lanes, tmax)` tests the triangles `lanes`
    /// (bit k: triangle 4b + k) of block `b` and returns the new `tmax` (smaller on a
    /// closer hit) or `None` to stop at once.
    #[inline(always)]
    fn traverse(&self, r: &PreparedRay, leaf: impl FnMut(usize, u32, f32) -> Option<f32>) {
        // Small stacks are cheap to set up; few trees are deeper than 17 levels.
        if self.depth <= 17 {
            self.traverse_with(r, ArrayStack::<16>::new(), leaf)
        } else if self.depth <= 65 {
            self.traverse_with(r, ArrayStack::<64>::new(), leaf)
        } else {
            self.traverse_with(r, Vec::with_capacity(self.depth), leaf)
        }
    }

    #[inline(always)]
    fn traverse_with(
        &self,
        r: &PreparedRay,
        mut stack: impl GroupStack,
        mut leaf: impl FnMut(usize, u32, f32) -> Option<f32>,
    ) {
        let mut tmax = r.tmax;
        // The root is reached through a group whose only hit bit is slot 7 at base 0.
        let mut group: (u32, u32) = (0, 0x8000_0000);
        let mut prims: (u32, u32) = (0, 0);
        loop {
            while prims.1 != 0 {
                // The highest primitive left, with those of its block of four still
                // to test (prims.1's bit k is primitive prims.0 + k).
                let k = 31 - prims.1.leading_zeros();
                let first = (prims.0 + k) & !3;
                let (lanes, done) = if first >= prims.0 {
                    let sh = first - prims.0;
                    ((prims.1 >> sh) & 0xf, 0xf << sh)
                } else {
                    let sh = prims.0 - first;
                    ((prims.1 << sh) & 0xf, 0xf >> sh)
                };
                prims.1 &= !done;
                match leaf(first as usize / 4, lanes, tmax) {
                    Some(t) => tmax = t,
                    None => return,
                }
            }
            if group.1 & 0xff00_0000 != 0 {
                let hits = group.1;
                let bit = 31 - hits.leading_zeros();
                group.1 &= !(1 << bit);
                if group.1 & 0xff00_0000 != 0 {
                    stack.push(group);
                }
                let slot = (bit - 24) ^ (r.oct_inv8 as u32 & 0xff);
                let rel = (hits & !(u32::MAX << slot)).count_ones();
                let node = &self.nodes[(group.0 + rel) as usize];
                let mask = node.intersect(r, tmax);
                group = (node.child_base, (mask & 0xff00_0000) | node.imask);
                prims = (node.prim_base, mask & 0x00ff_ffff);
            } else {
                group.1 = 0;
            }
            if prims.1 == 0 && group.1 & 0xff00_0000 == 0 {
                match stack.pop() {
                    Some(g) => group = g,
                    None => return,
                }
            }
        }
    }
}

/// Levels of the tree of `nodes` (the root alone is 1).
fn depth(nodes: &[WideNode]) -> usize {
    let mut deepest = 0;
    let mut todo = vec![(0usize, 1usize)];
    while let Some((i, d)) = todo.pop() {
        deepest = deepest.max(d);
        let n = &nodes[i];
        for k in 0..n.imask.count_ones() {
            todo.push((n.child_base as usize + k as usize, d + 1));
        }
    }
    deepest
}

impl Accel for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let r = PreparedRay::new(ray);
        let mut best: Option<(usize, f32, Vec2)> = None;
        self.traverse(&r, |b, lanes, tmax| {
            let (hit, t, u, v) = self.blocks[b].intersect(&r, lanes, tmax);
            if hit == 0 {
                return Some(tmax);
            }
            // The nearest lane hit (the first of equals).
            let t = t.to_array();
            let mut k = hit.trailing_zeros() as usize;
            let mut rest = hit & (hit - 1);
            while rest != 0 {
                let j = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if t[j] < t[k] {
                    k = j;
                }
            }
            if t[k] < tmax {
                best = Some((4 * b + k, t[k], Vec2::new(u[k], v[k])));
                Some(t[k])
            } else {
                Some(tmax)
            }
        });
        let (i, t, bary) = best?;
        let TriRef { shape, tri } = self.refs[i];
        Some(Hit { t, shape, tri, bary })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let r = PreparedRay::new(ray);
        let mut hit = false;
        self.traverse(&r, |b, lanes, tmax| {
            if self.blocks[b].intersect(&r, lanes, tmax).0 != 0 {
                hit = true;
                None
            } else {
                Some(tmax)
            }
        });
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obvhs::ray::Ray as BvhRay;

    fn bvh_of(tris: &[[Vec3; 3]]) -> Bvh {
        let rt = tris
            .iter()
            .map(|[a, b, c]| RtTriangle::new((*a).into(), (*b).into(), (*c).into()));
        let refs = (0..tris.len()).map(|t| TriRef {
            shape: 0,
            tri: t as u32,
        });
        Bvh::from_triangles(rt.collect(), refs.collect(), 0)
    }

    /// A stack of unit triangles at z = 0, 1, ..., n-1.
    fn stack(n: usize) -> Bvh {
        let tris: Vec<_> = (0..n)
            .map(|k| {
                let z = k as f32;
                [
                    Vec3::new(0.0, 0.0, z),
                    Vec3::new(1.0, 0.0, z),
                    Vec3::new(0.0, 1.0, z),
                ]
            })
            .collect();
        bvh_of(&tris)
    }

    #[test]
    fn closest_hit_is_the_nearest_triangle_and_barycentrics_reconstruct_the_point() {
        let bvh = stack(50);
        let ray = Ray::new(Vec3::new(0.2, 0.3, 100.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = bvh.intersect(&ray).expect("hits the stack");
        assert_eq!(hit.tri, 49);
        assert!((hit.t - 51.0).abs() < 1e-4, "t = {}", hit.t);
        // b1 weights the second corner (1,0,z), b2 the third (0,1,z).
        assert!(
            (hit.bary - Vec2::new(0.2, 0.3)).abs().max_element() < 1e-5,
            "{:?}",
            hit.bary
        );
    }

    #[test]
    fn segments_respect_tmin_and_tmax() {
        let bvh = stack(10);
        let mut ray = Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z);
        ray.tmin = 3.5;
        ray.tmax = 6.5;
        assert_eq!(bvh.intersect(&ray).map(|h| h.tri), Some(3));
        assert!(bvh.occluded(&ray));
        ray.tmin = 3.2;
        ray.tmax = 3.8;
        assert!(bvh.intersect(&ray).is_none());
        assert!(!bvh.occluded(&ray));
    }

    #[test]
    fn axis_aligned_rays_with_negative_zero_components_hit() {
        // A flat scene hit by rays whose zero components are -0.0 (regression: obvhs
        // missed every triangle for such rays).
        let tris: Vec<_> = (0..9)
            .map(|k| {
                let x = 30.0 * k as f32;
                [
                    Vec3::new(x - 10.0, -10.0, 0.0),
                    Vec3::new(x + 10.0, -10.0, 0.0),
                    Vec3::new(x + 10.0, 10.0, 0.0),
                ]
            })
            .collect();
        let bvh = bvh_of(&tris);
        for dir in [-Vec3::Z, Vec3::new(-0.0, 0.0, -1.0), Vec3::new(0.0, -0.0, -1.0)] {
            let ray = Ray::new(Vec3::new(5.0, -5.0, 1.0), dir);
            assert_eq!(bvh.intersect(&ray).map(|h| h.tri), Some(0), "{dir:?}");
            assert!(bvh.occluded(&ray));
        }
        let up = Ray::new(Vec3::new(35.0, -5.0, -1.0), -(-Vec3::Z));
        assert_eq!(bvh.intersect(&up).map(|h| h.tri), Some(1));
    }

    #[test]
    fn misses_and_empty_scenes() {
        let bvh = stack(5);
        let ray = Ray::new(Vec3::new(2.0, 2.0, -1.0), Vec3::Z);
        assert!(bvh.intersect(&ray).is_none());
        assert!(!bvh.occluded(&ray));
        let empty = bvh_of(&[]);
        assert!(empty.intersect(&ray).is_none());
        assert!(!empty.occluded(&ray));
    }

    /// The closest hit and any hit in the ray's segment by testing every triangle
    /// with the same triangle test, one triangle at a time.
    fn brute(tris: &[[Vec3; 3]], ray: &Ray) -> (Option<(usize, f32)>, bool) {
        let r = PreparedRay::new(ray);
        let mut best: Option<(usize, f32)> = None;
        for (i, [a, b, c]) in tris.iter().enumerate() {
            let block = Tri4::pack(&[RtTriangle::new((*a).into(), (*b).into(), (*c).into())]);
            let (hit, t, _, _) = block[0].intersect(&r, 0b1, ray.tmax);
            if hit != 0 && best.is_none_or(|(_, bt)| t.x < bt) {
                best = Some((i, t.x));
            }
        }
        (best, best.is_some())
    }

    #[test]
    fn a_block_tests_only_the_lanes_asked_for_and_padding_lanes_never_hit() {
        let tri = |z: f32| {
            RtTriangle::new(
                Vec3A::new(0.0, 0.0, z),
                Vec3A::new(1.0, 0.0, z),
                Vec3A::new(0.0, 1.0, z),
            )
        };
        let blocks = Tri4::pack(&[tri(1.0), tri(2.0), tri(3.0), tri(4.0), tri(5.0)]);
        assert_eq!(blocks.len(), 2);
        let r = PreparedRay::new(&Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z));
        let (hit, t, u, v) = blocks[0].intersect(&r, 0b1111, f32::INFINITY);
        assert_eq!(hit, 0b1111);
        assert_eq!(t.to_array(), [1.0, 2.0, 3.0, 4.0]);
        assert_eq!((u.x, v.x), (0.25, 0.25));
        assert_eq!(blocks[0].intersect(&r, 0b0110, f32::INFINITY).0, 0b0110);
        assert_eq!(blocks[0].intersect(&r, 0b1111, 2.5).0, 0b0011);
        // Block 1 holds one triangle and three zero lanes.
        assert_eq!(blocks[1].intersect(&r, 0b1111, f32::INFINITY).0, 0b0001);
        let miss = PreparedRay::new(&Ray::new(Vec3::new(0.75, 0.75, 0.0), Vec3::Z));
        assert_eq!(blocks[0].intersect(&miss, 0b1111, f32::INFINITY).0, 0);
    }

    /// Checks `bvh` against [`brute`] on `rays`; returns the number of hits.
    fn check_against_brute(bvh: &Bvh, tris: &[[Vec3; 3]], rays: &[Ray]) -> usize {
        let mut hits = 0;
        for ray in rays {
            let (best, any) = brute(tris, ray);
            let hit = bvh.intersect(ray);
            assert_eq!(bvh.occluded(ray), any, "{ray:?}");
            match (hit, best) {
                (None, None) => {}
                (Some(h), Some((i, t))) => {
                    hits += 1;
                    assert_eq!(h.t, t, "{ray:?}");
                    // Another triangle at exactly the same distance is as right.
                    if h.tri as usize != i {
                        let (other, _) = brute(&tris[h.tri as usize..=h.tri as usize], ray);
                        assert_eq!(other.map(|o| o.1), Some(t), "{ray:?}");
                    }
                    let [a, b, c] = tris[h.tri as usize];
                    let p = a * (1.0 - h.bary.x - h.bary.y) + b * h.bary.x + c * h.bary.y;
                    assert!((p - ray.at(h.t)).length() < 1e-3 * (1.0 + ray.at(h.t).length()));
                }
                (h, b) => panic!("{ray:?}: BVH {h:?}, brute force {b:?}"),
            }
        }
        hits
    }

    fn random_rays(rng: &mut rand_pcg::Pcg32, n: usize, lo: f32, hi: f32) -> Vec<Ray> {
        use rand::Rng;
        (0..n)
            .map(|k| {
                let o = Vec3::new(rng.random(), rng.random(), rng.random()) * (hi - lo) + Vec3::splat(lo);
                let mut d = (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5).normalize();
                // Every fourth ray axis-aligned, with +-0.0 in the other components.
                if k % 4 == 0 {
                    let a = (k / 4) % 3;
                    let s = if k % 8 == 0 { 1.0 } else { -1.0 };
                    let z = if k % 3 == 0 { -0.0 } else { 0.0 };
                    d = Vec3::splat(z);
                    d[a] = s;
                }
                let mut ray = Ray::new(o, d);
                if k % 3 == 1 {
                    ray.tmin = rng.random::<f32>() * 2.0;
                    ray.tmax = ray.tmin + rng.random::<f32>() * 6.0;
                }
                ray
            })
            .collect()
    }

    #[test]
    fn closest_hits_and_occlusion_match_testing_every_triangle() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(11);
        // Small and large triangles, some axis-aligned (boxes of zero thickness).
        let mut tris: Vec<[Vec3; 3]> = (0..3000)
            .map(|k| {
                let c = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
                let size = if k % 50 == 0 { 4.0 } else { 0.3 };
                let mut d = || (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5) * size;
                let (d1, d2) = (d(), d());
                if k % 7 == 0 {
                    // Parallel to the xy plane: a box of zero thickness.
                    return [c, c + Vec3::new(d1.x, d1.y, 0.0), c + Vec3::new(d2.x, d2.y, 0.0)];
                }
                [c, c + d1, c + d2]
            })
            .collect();
        // A closed box around it all, so that most rays hit something.
        for f in crate::testutil::box_inside(Vec3::splat(-1.0), Vec3::splat(11.0)) {
            for t in 0..f.triangle_count() {
                tris.push(f.triangle(t));
            }
        }
        let bvh = bvh_of(&tris);
        assert!(bvh.depth <= 17, "a random scene is shallow ({})", bvh.depth);
        let rays = random_rays(&mut rng, 4000, 0.0, 10.0);
        let hits = check_against_brute(&bvh, &tris, &rays);
        assert!(hits > 3000, "most rays should hit ({hits})");
        // The same answers with the larger stacks of deep trees.
        for depth in [40, 1000] {
            let deep = Bvh {
                depth,
                ..bvh_of(&tris)
            };
            for ray in &rays[..500] {
                assert_eq!(deep.intersect(ray), bvh.intersect(ray));
                assert_eq!(deep.occluded(ray), bvh.occluded(ray));
            }
        }
    }

    #[test]
    fn a_deep_tree_is_traversed_completely() {
        use rand::SeedableRng;
        // Triangles at exponentially growing distances along x: an unbalanced tree
        // deeper than the small traversal stack.
        let tris: Vec<[Vec3; 3]> = (0..300)
            .map(|k| {
                let x = 1.15f32.powi(k);
                let s = 0.2 * x;
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + s, s, 0.0),
                    Vec3::new(x, s, s),
                ]
            })
            .collect();
        let bvh = bvh_of(&tris);
        assert!(bvh.depth > 17, "the tree should be deep ({})", bvh.depth);
        let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
        let mut rays = random_rays(&mut rng, 500, -1.0, 2.0);
        // Rays along the row, hitting triangles far out.
        for (k, t) in tris.iter().enumerate().step_by(3) {
            let target = (t[0] + t[1] + t[2]) / 3.0;
            let o = Vec3::new(target.x, target.y, -1.0 - k as f32);
            rays.push(Ray::new(o, (target - o).normalize()));
        }
        let hits = check_against_brute(&bvh, &tris, &rays);
        // (Far out, at 1e18, f32 loses some of them, in both.)
        assert!(hits > 60, "{hits}");
    }

    #[test]
    fn occlusion_agrees_with_closest_hit_on_random_rays() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        let tris: Vec<_> = (0..500)
            .map(|_| {
                let c = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
                let mut d = || (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5) * 2.0;
                let (d1, d2) = (d(), d());
                [c, c + d1, c + d2]
            })
            .collect();
        let bvh = bvh_of(&tris);
        let brute =
            |ray: &Ray| {
                tris.iter()
                    .filter_map(|[a, b, c]| {
                        let t = RtTriangle::new((*a).into(), (*b).into(), (*c).into()).intersect(
                            &BvhRay::new(ray.origin.into(), ray.dir.into(), ray.tmin, ray.tmax),
                        );
                        t.is_finite().then_some(t)
                    })
                    .fold(f32::INFINITY, f32::min)
            };
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rng.random(), rng.random(), rng.random()) * 12.0 - 1.0;
            let d = (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5).normalize();
            let mut ray = Ray::new(o, d);
            ray.tmax = rng.random::<f32>() * 8.0;
            let t = brute(&ray);
            let hit = bvh.intersect(&ray);
            assert_eq!(hit.is_some(), t.is_finite());
            assert_eq!(bvh.occluded(&ray), t.is_finite());
            if let Some(h) = hit {
                hits += 1;
                assert!((h.t - t).abs() < 1e-4);
            }
        }
        assert!(hits > 100, "the test should exercise hits too ({hits})");
    }
}
