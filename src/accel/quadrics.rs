//! The scene's exact spheres and disks ([`Quadric`]), met by rays in closed form
//! instead of through their triangles. Their boxes are kept in a binary BVH of their
//! own (obvhs's PLOC build and traversal); a ray is tested against it after the
//! triangles, up to the triangles' closest hit.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::{builder::build_bvh2, Bvh2};
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::BvhBuildParams;

use super::{Hit, Ray};
use crate::geometry::Quadric;
use crate::scene::Scene;

/// The exact surfaces of a scene, with their shape indices.
pub(super) struct Quadrics {
    /// In the BVH's primitive order: the shape and its surface.
    items: Vec<(u32, Quadric)>,
    bvh: Option<Bvh2>,
    /// Per item: whether shadow rays pass through it ([`Scene::passes_shadows`]).
    see_through: Vec<bool>,
}

impl Quadrics {
    /// The exact surfaces of every shape `keep` takes that has one.
    pub(super) fn build(scene: &Scene, keep: &dyn Fn(u32) -> bool) -> Self {
        // Each with its box, padded: a disk's box is flat, and a slab test may miss a
        // flat box.
        let (items, boxes): (Vec<(u32, Quadric)>, Vec<Aabb>) = scene
            .shapes
            .iter()
            .enumerate()
            .filter(|(s, _)| keep(*s as u32))
            .filter_map(|(s, shape)| {
                let q = shape.mesh.quadric?;
                let (lo, hi) = q.bounds();
                let pad = 1e-4 * (hi - lo).length() + 1e-6 * (1.0 + lo.abs().max(hi.abs()).max_element());
                (lo.is_finite() && hi.is_finite())
                    .then(|| ((s as u32, q), Aabb::new((lo - pad).into(), (hi + pad).into())))
            })
            .unzip();
        if items.is_empty() {
            return Quadrics::empty();
        }
        let bvh = build_bvh2(&boxes, BvhBuildParams::medium_build(), &mut Default::default());
        let items: Vec<(u32, Quadric)> = bvh.primitive_indices.iter().map(|&i| items[i as usize]).collect();
        Quadrics {
            see_through: items.iter().map(|(s, _)| scene.passes_shadows(*s)).collect(),
            items,
            bvh: Some(bvh),
        }
    }

    /// None.
    pub(super) fn empty() -> Self {
        Quadrics {
            items: Vec::new(),
            bvh: None,
            see_through: Vec::new(),
        }
    }

    /// Number of exact surfaces.
    pub(super) fn len(&self) -> usize {
        self.items.len()
    }

    fn bvh_ray(ray: &Ray, tmax: f32) -> BvhRay {
        BvhRay::new(
            Vec3A::from(ray.origin),
            Vec3A::from(ray.dir),
            ray.tmin.max(0.0),
            tmax,
        )
    }

    /// The closest hit of `ray` nearer than `tmax`.
    pub(super) fn closest(&self, ray: &Ray, tmax: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let mut best = None;
        let mut hit = RayHit::none();
        bvh.ray_traverse(Self::bvh_ray(ray, tmax), &mut hit, |r, i| {
            match self.items[i].1.hit(ray.origin, ray.dir, ray.tmin, r.tmax) {
                Some((t, at)) => {
                    best = Some((i, t, at));
                    t
                }
                None => f32::INFINITY,
            }
        });
        // The surface parameters of the nearest hit only.
        let (i, t, at) = best?;
        let (shape, q) = &self.items[i];
        let (tri, bary) = q.triangle_at(q.param_at(at));
        Some(Hit {
            t,
            shape: *shape,
            tri,
            bary,
        })
    }

    /// Whether `ray` meets any exact surface that stops shadow rays.
    pub(super) fn any(&self, ray: &Ray) -> bool {
        let Some(bvh) = &self.bvh else { return false };
        !bvh.ray_traverse_miss(Self::bvh_ray(ray, ray.tmax), |r, i| {
            if self.see_through[i] {
                return f32::INFINITY;
            }
            match self.items[i].1.hit(ray.origin, ray.dir, ray.tmin, r.tmax) {
                Some((t, _)) => t,
                None => f32::INFINITY,
            }
        })
    }
}
