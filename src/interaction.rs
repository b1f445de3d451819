//! The surface interaction at a ray hit: the hit's frame (position, geometric and
//! shading normals, side) and the one rule by which rays leave a surface.

use glam::{Vec2, Vec3};

use crate::accel::{Hit, Ray};
use crate::scene::Scene;

/// The local geometry at a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position.
    pub p: Vec3,
    /// Geometric normal, turned towards the arriving ray for two-sided materials.
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals), on the same side as `ng`.
    pub ns: Vec3,
    /// Whether the ray arrived on the front side (the side the winding faces).
    pub front: bool,
    /// Shape index.
    pub shape: u32,
    /// Triangle index within the shape.
    pub tri: u32,
    /// Barycentrics of corners 1 and 2.
    pub bary: Vec2,
}

impl SurfacePoint {
    /// The surface point where `ray` met `hit`.
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit) -> Self {
        let mesh = &scene.shapes[hit.shape as usize].mesh;
        let [ia, ib, ic] = mesh.indices[hit.tri as usize].map(|i| i as usize);
        let (a, b, c) = (mesh.positions[ia], mesh.positions[ib], mesh.positions[ic]);
        let (b1, b2) = (hit.bary.x, hit.bary.y);
        let b0 = 1.0 - b1 - b2;
        let p = a * b0 + b * b1 + c * b2;
        let mut ng = (b - a).cross(c - a).normalize();
        let mut ns = if mesh.normals.is_empty() {
            ng
        } else {
            (mesh.normals[ia] * b0 + mesh.normals[ib] * b1 + mesh.normals[ic] * b2).normalize_or(ng)
        };
        // Keep the shading normal on the geometric normal's side.
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let front = ng.dot(ray.dir) < 0.0;
        if !front {
            ng = -ng;
            ns = -ns;
        }
        SurfacePoint {
            p,
            ng,
            ns,
            front,
            shape: hit.shape,
            tri: hit.tri,
            bary: hit.bary,
        }
    }

    /// A ray leaving this point in `dir` (on the side `dir` points to), ending at
    /// distance `tmax` from the point.
    pub fn spawn(&self, dir: Vec3, tmax: f32) -> Ray {
        let eps = ray_epsilon(self.p);
        let side = if dir.dot(self.ng) >= 0.0 {
            self.ng
        } else {
            -self.ng
        };
        Ray {
            origin: self.p + side * eps,
            dir,
            tmin: 0.0,
            tmax: (tmax - eps).max(0.0),
        }
    }
}

/// Offset used to move secondary ray origins off their surface, relative to the
/// magnitude of the coordinates (floating-point error grows with them).
pub fn ray_epsilon(p: Vec3) -> f32 {
    2e-5 * (1.0 + p.abs().max_element())
}
