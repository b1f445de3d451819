//! The wide BVH: obvhs's CWBVH build, its nodes decoded to f32 child boxes, and its
//! traversal for closest-hit and occlusion queries.

use glam::{Vec2, Vec3, Vec3A, Vec4};
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, node::CwBvhNode};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::quadrics::Quadrics;
use super::triangle::Tri4;
use super::{Accel, Hit, PreparedRay, Ray, TriRef};
use crate::scene::Scene;

/// A node of the wide BVH: obvhs's CWBVH node with its eight child boxes decoded
/// from 8-bit quantised planes to f32 once, at build time. Traversal then tests four
/// children at a time with plain SIMD arithmetic (glam's `Vec4`), instead of
/// dequantising 48 bytes per visited node as obvhs's own traversal does (half of its
/// instructions in the profile).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct WideNode {
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
    pub(super) nodes: Vec<WideNode>,
    /// Levels of the tree (the root alone is 1).
    pub(super) depth: usize,
    /// Triangles in the order of the BVH's leaves, four to a block.
    pub(super) blocks: Vec<Tri4>,
    /// For each triangle in leaf order, the scene triangle it is (a split triangle
    /// appears more than once).
    pub(super) refs: Vec<TriRef>,
    /// Distinct triangles.
    pub(super) count: usize,
    /// Number of degenerate (zero-area or non-finite) triangles of input meshes left
    /// out (those of collapsed Bezier patch edges are left out too, but not counted).
    pub skipped: usize,
    /// The exact spheres and disks, whose triangles are not in the tree.
    pub(super) quadrics: Quadrics,
    /// Per block, the lanes (bit k: triangle 4b + k) that stop shadow rays; empty
    /// when all do (no thin glass in the scene).
    pub(super) opaque: Vec<u8>,
    /// The thin panes alone, if the scene has any.
    pub(super) panes: Option<Box<Bvh>>,
}

/// A render whose scene has more than this many triangles per pixel builds its BVH
/// with obvhs's medium preset instead of the slow one ([`Bvh::build_for`]). The slow
/// preset's 5-15 % fewer instructions per ray cost about 0.4 us more build per
/// triangle on 2 threads, which a default render (some 100 rays per pixel, pass 1's
/// besides) earns back only while triangles are few per pixel. Measured on
/// 2026-11-28, render seed 0, whole process, twice each (slow / medium): a scene of
/// my own of 1.58 M triangles at 480 x 320 (10 per pixel) 5.25 / 4.45 s and 5.00 /
/// 4.54 s (BVH 1.84 -> 1.17 s, render and solve within noise, image md5-identical);
/// the wooden staircase (1.8 per pixel) 11.77 / 12.14 s and 12.74 / 13.43 s; the
/// conference room (1.3) 5.93 / 5.90 s and 6.11 / 6.13 s; the classroom (0.66) 5.39
/// / 5.50 s and 5.04 / 5.14 s.
pub const QUICK_BUILD_TRIANGLES_PER_PIXEL: u64 = 4;

impl Bvh {
    /// Builds the BVH over every non-degenerate triangle of `scene`; with thin glass
    /// in the scene, also one of the panes alone ([`Accel::panes`]). obvhs's slow
    /// preset, for the most rays.
    pub fn build(scene: &Scene) -> Self {
        Self::build_for(scene, None)
    }

    /// [`Bvh::build`] for a render of `pixels` pixels (`None`: unknown, as many rays
    /// as may come): with more than [`QUICK_BUILD_TRIANGLES_PER_PIXEL`] triangles per
    /// pixel, obvhs's medium preset.
    pub fn build_for(scene: &Scene, pixels: Option<u64>) -> Self {
        let mut bvh = Self::build_of(scene, &|_| true, pixels);
        if (0..scene.shapes.len()).any(|s| scene.passes_shadows(s as u32)) {
            bvh.opaque = bvh
                .refs
                .chunks(4)
                .map(|c| {
                    c.iter()
                        .enumerate()
                        .filter(|(_, r)| !scene.passes_shadows(r.shape))
                        .fold(0u8, |m, (k, _)| m | 1 << k)
                })
                .collect();
            bvh.panes = Some(Box::new(Self::build_of(
                scene,
                &|s| scene.passes_shadows(s),
                pixels,
            )));
        }
        bvh
    }

    /// The BVH over the shapes `keep` takes, for a render of `pixels` pixels.
    fn build_of(scene: &Scene, keep: &dyn Fn(u32) -> bool, pixels: Option<u64>) -> Self {
        let mut tris = Vec::new();
        let mut refs = Vec::new();
        let mut skipped = 0;
        for (s, shape) in scene.shapes.iter().enumerate() {
            if shape.mesh.quadric.is_some() || !keep(s as u32) {
                continue;
            }
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
                tris.push([a, b, c]);
                refs.push(TriRef {
                    shape: s as u32,
                    tri: t as u32,
                });
            }
        }
        let params = match pixels {
            Some(px) if tris.len() as u64 > QUICK_BUILD_TRIANGLES_PER_PIXEL.saturating_mul(px) => {
                BvhBuildParams::medium_build()
            }
            _ => BvhBuildParams::slow_build(),
        };
        Bvh {
            quadrics: Quadrics::build(scene, keep),
            ..Self::from_triangles_with(tris, refs, skipped, params)
        }
    }

    /// The BVH over `tris` (corners as the scene's meshes give them: the blocks keep
    /// them bit for bit), triangle `i` being `refs[i]`, with the slow preset.
    #[cfg(test)]
    pub(super) fn from_triangles(tris: Vec<[Vec3; 3]>, refs: Vec<TriRef>, skipped: usize) -> Self {
        Self::from_triangles_with(tris, refs, skipped, BvhBuildParams::slow_build())
    }

    /// [`Bvh::from_triangles`] with obvhs's build `params`.
    pub(super) fn from_triangles_with(
        tris: Vec<[Vec3; 3]>,
        refs: Vec<TriRef>,
        skipped: usize,
        params: BvhBuildParams,
    ) -> Self {
        if tris.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                depth: 0,
                blocks: Vec::new(),
                refs,
                count: 0,
                skipped,
                quadrics: Quadrics::empty(),
                opaque: Vec::new(),
                panes: None,
            };
        }
        let mut build_time = Default::default();
        // obvhs's slow preset (wider PLOC search, more reinsertion, large triangles'
        // boxes pre-split) takes about 1.5x the medium preset's build time for 5-15%
        // fewer instructions per ray (callgrind, `radtrace bench`; the pre-splits are
        // 4% of that on the conference room): see [`QUICK_BUILD_TRIANGLES_PER_PIXEL`].
        // A split triangle is listed in several leaves.
        let corners: Vec<Triangle> = tris
            .iter()
            .map(|&[v0, v1, v2]| Triangle {
                v0: v0.into(),
                v1: v1.into(),
                v2: v2.into(),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(&corners, params, &mut build_time);
        // Reorder the triangles into leaf order so traversal reads them contiguously.
        let tris: Vec<[Vec3; 3]> = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
        let refs: Vec<TriRef> = bvh.primitive_indices.iter().map(|&i| refs[i as usize]).collect();
        let nodes: Vec<WideNode> = bvh.nodes.iter().map(WideNode::decode).collect();
        Bvh {
            depth: depth(&nodes),
            nodes,
            blocks: Tri4::pack(&tris),
            refs,
            count: corners.len(),
            skipped,
            quadrics: Quadrics::empty(),
            opaque: Vec::new(),
            panes: None,
        }
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.count
    }

    /// Number of exact spheres and disks.
    pub fn quadric_count(&self) -> usize {
        self.quadrics.len()
    }

    /// Walks the tree for `r`. `leaf(b, lanes, tmax)` tests the triangles `lanes`
    /// (bit k: triangle 4b + k) of block `b` and returns the new `tmax` (smaller on a
    /// closer hit) or `None` to stop at once.
    #[inline(always)]
    fn traverse(&self, r: &PreparedRay, leaf: &mut impl Leaf) {
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
    fn traverse_with(&self, r: &PreparedRay, mut stack: impl GroupStack, leaf: &mut impl Leaf) {
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
                match leaf.test(first as usize / 4, lanes, tmax) {
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

impl Bvh {
    /// The closest hit: (triangle in leaf order, t, barycentrics).
    #[inline(always)]
    fn closest(&self, r: &PreparedRay) -> Option<(usize, f32, Vec2)> {
        let mut leaf = Closest {
            bvh: self,
            r,
            best: None,
        };
        self.traverse(r, &mut leaf);
        leaf.best
    }

    /// The leaf test of [`Bvh::closest`] (a method, so that it is inlined into the
    /// traversal loop: as a closure body it was not).
    #[inline(always)]
    fn closest_in_block(
        &self,
        r: &PreparedRay,
        b: usize,
        lanes: u32,
        tmax: f32,
        best: &mut Option<(usize, f32, Vec2)>,
    ) -> Option<f32> {
        let (hit, t, u, v) = self.blocks[b].intersect(r, lanes, tmax);
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
            *best = Some((4 * b + k, t[k], Vec2::new(u[k], v[k])));
            Some(t[k])
        } else {
            Some(tmax)
        }
    }

    /// Whether the ray hits anything; stops at the first hit.
    #[inline(always)]
    fn any_hit(&self, r: &PreparedRay) -> bool {
        let mut leaf = AnyHit {
            bvh: self,
            r,
            hit: false,
        };
        self.traverse(r, &mut leaf);
        leaf.hit
    }

    #[inline(always)]
    fn any_in_block(&self, r: &PreparedRay, b: usize, lanes: u32, tmax: f32, hit: &mut bool) -> Option<f32> {
        let lanes = match self.opaque.get(b) {
            Some(&m) => lanes & u32::from(m),
            None => lanes,
        };
        if lanes != 0 && self.blocks[b].intersect(r, lanes, tmax).0 != 0 {
            *hit = true;
            None
        } else {
            Some(tmax)
        }
    }
}

impl Accel for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let tri = if self.nodes.is_empty() {
            None
        } else {
            let r = PreparedRay::new(ray);
            self.closest(&r).map(|(i, t, bary)| {
                let TriRef { shape, tri } = self.refs[i];
                Hit { t, shape, tri, bary }
            })
        };
        let tmax = tri.map_or(ray.tmax, |h| h.t);
        self.quadrics.closest(ray, tmax).or(tri)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        (!self.nodes.is_empty() && self.any_hit(&PreparedRay::new(ray))) || self.quadrics.any(ray)
    }

    fn panes(&self) -> Option<&dyn Accel> {
        self.panes.as_deref().map(|b| b as &dyn Accel)
    }
}

/// The test of a leaf's triangles during traversal: `test(b, lanes, tmax)` tests the
/// triangles `lanes` (bit k: triangle 4b + k) of block `b` and returns the new `tmax`
/// (smaller on a closer hit) or `None` to stop at once. (A trait with an
/// always-inlined method rather than a closure, so that the test is inlined into the
/// traversal loop.)
trait Leaf {
    fn test(&mut self, b: usize, lanes: u32, tmax: f32) -> Option<f32>;
}

/// The leaf test of [`Bvh::closest`].
struct Closest<'a> {
    bvh: &'a Bvh,
    r: &'a PreparedRay,
    best: Option<(usize, f32, Vec2)>,
}

impl Leaf for Closest<'_> {
    #[inline(always)]
    fn test(&mut self, b: usize, lanes: u32, tmax: f32) -> Option<f32> {
        self.bvh.closest_in_block(self.r, b, lanes, tmax, &mut self.best)
    }
}

/// The leaf test of [`Bvh::any_hit`].
struct AnyHit<'a> {
    bvh: &'a Bvh,
    r: &'a PreparedRay,
    hit: bool,
}

impl Leaf for AnyHit<'_> {
    #[inline(always)]
    fn test(&mut self, b: usize, lanes: u32, tmax: f32) -> Option<f32> {
        self.bvh.any_in_block(self.r, b, lanes, tmax, &mut self.hit)
    }
}
