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
//! to a block, and tested four at a time with the watertight test of Woop, Benthin &
//! Wald (2013), as in pbrt-v4 and Embree: a ray passing exactly through an edge or a
//! vertex shared by triangles hits at least one of them, so rays never leak through
//! a closed mesh ([`triangle`]). Spheres and disks are not in the tree as triangles:
//! they are met exactly, through a small tree of their own ([`quadrics`]).

use glam::{Vec2, Vec3, Vec3A, Vec4};

mod bvh;
mod quadrics;
#[cfg(test)]
mod tests;
mod triangle;

pub use bvh::Bvh;

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
    /// Whether anything that stops shadow rays lies in `[ray.tmin, ray.tmax]` (every
    /// surface but thin glass, [`Scene::passes_shadows`]); stops at the first hit found.
    ///
    /// [`Scene::passes_shadows`]: crate::scene::Scene::passes_shadows
    fn occluded(&self, ray: &Ray) -> bool;
    /// The surfaces [`Accel::occluded`] passes through, alone (`None` if there are
    /// none): `interaction::transmittance` finds how much light they let through.
    fn panes(&self) -> Option<&dyn Accel> {
        None
    }
}

/// Identifies a triangle of the scene.
#[derive(Debug, Clone, Copy)]
struct TriRef {
    shape: u32,
    tri: u32,
}

/// A ray with what every node test needs precomputed.
struct PreparedRay {
    /// The ray's segment end.
    tmax: f32,
    /// The triangle test's axes `[kx, ky, kz]`: kz that of the largest |direction|
    /// component, kx and ky the next two cyclically ([`triangle`]).
    k: [usize; 3],
    /// The origin's coordinates on those axes, splatted.
    org_k: [Vec4; 3],
    /// The triangle test's shear, splatted: `-d[kx] sz`, `-d[ky] sz`, `sz = 1 / d[kz]`.
    shear: [Vec4; 3],
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
        // The watertight triangle test's permutation and shear, once per ray.
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let k = [(kz + 1) % 3, (kz + 2) % 3, kz];
        let (d, o) = (dir.to_array(), origin.to_array());
        let sz = 1.0 / d[kz];
        let shear = [-d[k[0]] * sz, -d[k[1]] * sz, sz];
        PreparedRay {
            tmax: ray.tmax,
            k,
            org_k: k.map(|a| Vec4::splat(o[a])),
            shear: shear.map(Vec4::splat),
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            org_inv: [Vec4::splat(oi.x), Vec4::splat(oi.y), Vec4::splat(oi.z)],
            near,
            tmin: ray.tmin,
            oct_inv8: oct as u64 * 0x0101_0101_0101_0101,
        }
    }
}
