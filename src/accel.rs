//! Acceleration: a BVH over all triangles of the scene, answering closest-hit and
//! early-exit occlusion queries (paper Sect. 4, "conventional ray tracing
//! efficiency techniques").
//!
//! [`Accel`] is the small interface the renderer uses; [`Bvh`] implements it with
//! the `obvhs` crate's compressed wide BVH (CWBVH), so another BVH can replace it.

use glam::{Vec2, Vec3, Vec3A};
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::ray::Ray as BvhRay;
use obvhs::rt_triangle::RtTriangle;
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

/// A compressed wide BVH (obvhs) over the scene's triangles, stored in BVH order.
pub struct Bvh {
    bvh: CwBvh,
    /// Triangles in the order of the BVH's leaves.
    tris: Vec<RtTriangle>,
    /// For each entry of `tris`, the scene triangle it is.
    refs: Vec<TriRef>,
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
                bvh: CwBvh::default(),
                tris,
                refs,
                skipped,
            };
        }
        let mut build_time = Default::default();
        let bvh = build_cwbvh(&tris, BvhBuildParams::medium_build(), &mut build_time);
        // Reorder the triangles into leaf order so traversal reads them contiguously.
        let tris: Vec<RtTriangle> = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
        let refs: Vec<TriRef> = bvh.primitive_indices.iter().map(|&i| refs[i as usize]).collect();
        Bvh {
            bvh,
            tris,
            refs,
            skipped,
        }
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    fn to_bvh_ray(ray: &Ray) -> BvhRay {
        // Adding +0.0 turns -0.0 into +0.0: obvhs takes the inverse of -0.0 as a large
        // negative number but the octant of -0.0 as positive, and then misses
        // everything. Axis-aligned rays (e.g. `-Vec3::Z`) carry such zeros.
        let dir = Vec3A::from(ray.dir) + Vec3A::ZERO;
        BvhRay::new(Vec3A::from(ray.origin), dir, ray.tmin, ray.tmax)
    }
}

impl Accel for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let r = Self::to_bvh_ray(ray);
        let mut hit = obvhs::ray::RayHit::none();
        if !self
            .bvh
            .ray_traverse(r, &mut hit, |r, i| self.tris[i].intersect(r))
        {
            return None;
        }
        let i = hit.primitive_id as usize;
        let bary = self.tris[i].compute_barycentric(&r);
        let TriRef { shape, tri } = self.refs[i];
        Some(Hit {
            t: hit.t,
            shape,
            tri,
            bary,
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let r = Self::to_bvh_ray(ray);
        !self.bvh.ray_traverse_miss(r, |r, i| self.tris[i].intersect(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let brute = |ray: &Ray| {
            tris.iter()
                .filter_map(|[a, b, c]| {
                    let t = RtTriangle::new((*a).into(), (*b).into(), (*c).into())
                        .intersect(&Bvh::to_bvh_ray(ray));
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
