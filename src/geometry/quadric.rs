//! Mitsuba's `sphere` and `disk` as exact surfaces: ray intersection in closed form,
//! the true normal, Mitsuba's parametrisation, and uniform sampling by area.
//!
//! A [`Quadric`] is the unit sphere or the unit disk (z = 0, normal +z) of object
//! space under an affine `to_world` (a sphere's is a similarity; a disk's may be any
//! affine map, which makes it an ellipse). Rays are intersected in object space,
//! where the direction is not renormalised, so the ray parameter `t` is the world
//! one. Normals are mapped by the inverse transpose, which keeps their side under
//! any map, mirrors included.
//!
//! The shape's triangle mesh ([`super::shapes`]) stays: it is what the shape's
//! records are indexed by (a hit names a triangle with barycentrics,
//! [`Quadric::triangle_at`]), but no ray ever meets its facets.

use std::f64::consts::{PI, TAU};

use glam::{DMat4, DVec3, Mat3, Mat4, Vec2, Vec3};

use super::shapes::{disk_rim, RINGS, SEGMENTS};

/// Which unit shape a [`Quadric`] maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuadricKind {
    /// The unit sphere; `u = phi / 2pi`, `v = theta / pi` (theta from +z).
    Sphere,
    /// The unit disk in z = 0, normal +z; `u = r`, `v = phi / 2pi`.
    Disk,
}

/// An exact sphere or disk in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadric {
    /// The unit shape.
    pub kind: QuadricKind,
    /// Object to world (affine); rays and points are mapped in f64.
    to_world: Mat4,
    /// World to object (inverted in f64).
    to_local: Mat4,
    /// The normal points inward (`flip_normals`).
    pub flipped: bool,
}

impl Quadric {
    /// The unit `kind` under `to_world`.
    pub fn new(kind: QuadricKind, to_world: Mat4) -> Self {
        Quadric {
            kind,
            to_world,
            to_local: to_world.as_dmat4().inverse().as_mat4(),
            flipped: false,
        }
    }

    fn world(&self) -> DMat4 {
        self.to_world.as_dmat4()
    }

    fn local_map(&self) -> DMat4 {
        self.to_local.as_dmat4()
    }

    /// Applies a further affine map `m` (after the present one).
    pub fn transform(&mut self, m: &Mat4) {
        let w = m.as_dmat4() * self.world();
        self.to_world = w.as_mat4();
        self.to_local = w.inverse().as_mat4();
    }

    /// The object-to-world map.
    pub fn to_world(&self) -> Mat4 {
        self.to_world
    }

    /// Whether the map is a similarity (a sphere stays a sphere) within `tol`,
    /// relative.
    pub fn is_similarity(&self, tol: f32) -> bool {
        let l = Mat3::from_mat4(self.to_world());
        let (x, y, z) = (l.x_axis, l.y_axis, l.z_axis);
        let s = x.length();
        let t = tol * s;
        (x.length() - y.length()).abs() <= t
            && (x.length() - z.length()).abs() <= t
            && x.dot(y).abs() <= t * s
            && x.dot(z).abs() <= t * s
            && y.dot(z).abs() <= t * s
    }

    /// The first hit of the segment `origin + t dir`, `t` in `(max(tmin, 0), tmax]`:
    /// its `t` and the surface parameters `(u, v)` there.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec2)> {
        let o = self.local_map().transform_point3(origin.as_dvec3());
        let d = self.local_map().transform_vector3(dir.as_dvec3());
        let lo = f64::from(tmin.max(0.0));
        let hi = f64::from(tmax);
        let ok = |t: f64| t > lo && t <= hi && t > 0.0;
        match self.kind {
            QuadricKind::Sphere => {
                // |o + t d|^2 = 1, in the cancellation-free form (Numerical Recipes).
                let a = d.length_squared();
                let b = o.dot(d);
                // The discriminant as |d|^2 (1 - |o_perp|^2) with o_perp the origin's
                // part across the ray (pbrt-v4): accurate for grazing rays.
                let perp = o - d * (b / a);
                let disc = a * (1.0 - perp.length_squared());
                if !(a > 0.0) || disc < 0.0 {
                    return None;
                }
                let q = -(b + b.signum() * disc.sqrt());
                let c = o.length_squared() - 1.0;
                let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
                if t0 > t1 {
                    std::mem::swap(&mut t0, &mut t1);
                }
                let t = [t0, t1].into_iter().find(|&t| ok(t))?;
                Some((t as f32, sphere_uv((o + d * t).normalize())))
            }
            QuadricKind::Disk => {
                if d.z == 0.0 {
                    return None;
                }
                let t = -o.z / d.z;
                if !ok(t) {
                    return None;
                }
                let x = o.x + d.x * t;
                let y = o.y + d.y * t;
                let r2 = x * x + y * y;
                (r2 <= 1.0).then(|| (t as f32, Vec2::new(r2.sqrt() as f32, angle(y, x))))
            }
        }
    }

    /// The parameters `(u, v)` of the surface point nearest to `p` (`p` on or near
    /// the surface).
    pub fn uv_of(&self, p: Vec3) -> Vec2 {
        let l = self.local_map().transform_point3(p.as_dvec3());
        match self.kind {
            QuadricKind::Sphere => sphere_uv(l.normalize_or(DVec3::Z)),
            QuadricKind::Disk => Vec2::new(l.truncate().length().min(1.0) as f32, angle(l.y, l.x)),
        }
    }

    /// The object-space point at `(u, v)`.
    fn local(&self, u: f32, v: f32) -> DVec3 {
        let (u, v) = (f64::from(u), f64::from(v));
        match self.kind {
            QuadricKind::Sphere => {
                let (st, ct) = (PI * v).sin_cos();
                let (sp, cp) = (TAU * u).sin_cos();
                DVec3::new(st * cp, st * sp, ct)
            }
            QuadricKind::Disk => {
                let (sp, cp) = (TAU * v).sin_cos();
                DVec3::new(u * cp, u * sp, 0.0)
            }
        }
    }

    /// Point and partial derivatives `(p, dp/du, dp/dv)` at `(u, v)`.
    pub fn eval(&self, u: f32, v: f32) -> (Vec3, Vec3, Vec3) {
        let l = self.local(u, v);
        let (du, dv) = match self.kind {
            QuadricKind::Sphere => {
                let (st, ct) = (PI * f64::from(v)).sin_cos();
                let (sp, cp) = (TAU * f64::from(u)).sin_cos();
                (
                    DVec3::new(-st * sp, st * cp, 0.0) * TAU,
                    DVec3::new(ct * cp, ct * sp, -st) * PI,
                )
            }
            QuadricKind::Disk => {
                let (sp, cp) = (TAU * f64::from(v)).sin_cos();
                (
                    DVec3::new(cp, sp, 0.0),
                    DVec3::new(-sp, cp, 0.0) * (TAU * f64::from(u)),
                )
            }
        };
        let m = self.world();
        (
            m.transform_point3(l).as_vec3(),
            m.transform_vector3(du).as_vec3(),
            m.transform_vector3(dv).as_vec3(),
        )
    }

    /// The unit normal at `(u, v)`: outward (a disk: along its +z), inward when
    /// [`flipped`](Self::flipped).
    pub fn normal(&self, u: f32, v: f32) -> Vec3 {
        let n = match self.kind {
            QuadricKind::Sphere => self.local(u, v),
            QuadricKind::Disk => DVec3::Z,
        };
        self.world_normal(n)
    }

    /// The surface point nearest to `p` and the unit normal there (see
    /// [`Self::normal`]): for a point a ray found, the exact point.
    pub fn project(&self, p: Vec3) -> (Vec3, Vec3) {
        let mut l = self.local_map().transform_point3(p.as_dvec3());
        let n = match self.kind {
            QuadricKind::Sphere => {
                l = l.normalize_or(DVec3::Z);
                l
            }
            QuadricKind::Disk => {
                l.z = 0.0;
                DVec3::Z
            }
        };
        (self.world().transform_point3(l).as_vec3(), self.world_normal(n))
    }

    fn world_normal(&self, n: DVec3) -> Vec3 {
        // The inverse transpose's linear part: rows of `to_local` as columns.
        let m = self.local_map();
        let w = DVec3::new(
            m.x_axis.x * n.x + m.x_axis.y * n.y + m.x_axis.z * n.z,
            m.y_axis.x * n.x + m.y_axis.y * n.y + m.y_axis.z * n.z,
            m.z_axis.x * n.x + m.z_axis.y * n.y + m.z_axis.z * n.z,
        )
        .normalize_or(DVec3::Z)
        .as_vec3();
        if self.flipped {
            -w
        } else {
            w
        }
    }

    /// Surface area (a sphere's under a similarity; a disk's under any affine map).
    pub fn area(&self) -> f32 {
        let m = self.world();
        let (x, y) = (m.x_axis.truncate(), m.y_axis.truncate());
        match self.kind {
            QuadricKind::Sphere => (4.0 * PI * x.length() * y.length()) as f32,
            QuadricKind::Disk => (PI * x.cross(y).length()) as f32,
        }
    }

    /// The point that `s` in `[0,1)^2` maps to, uniformly by area under a
    /// similarity (a disk: any affine map), with its unit normal. The map is
    /// continuous, so compact cells of `s` are compact pieces of the surface.
    pub fn sample(&self, s: Vec2) -> (Vec3, Vec3) {
        let (u, v) = match self.kind {
            // Archimedes: z uniform in [-1, 1] is uniform by area.
            QuadricKind::Sphere => (
                s.y,
                (1.0 - 2.0 * s.x).clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
            ),
            QuadricKind::Disk => (s.x.sqrt(), s.y),
        };
        let (p, _, _) = self.eval(u, v);
        (p, self.normal(u, v))
    }

    /// World-space bounds `(min, max)`: the image of the object-space box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let z = match self.kind {
            QuadricKind::Sphere => 1.0,
            QuadricKind::Disk => 0.0,
        };
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for k in 0..8 {
            let c = DVec3::new(
                if k & 1 == 0 { -1.0 } else { 1.0 },
                if k & 2 == 0 { -1.0 } else { 1.0 },
                if k & 4 == 0 { -z } else { z },
            );
            let w = self.world().transform_point3(c).as_vec3();
            lo = lo.min(w);
            hi = hi.max(w);
        }
        (lo, hi)
    }

    /// The triangle of the shape's tessellation ([`super::shapes::sphere`],
    /// [`super::shapes::disk`]) that parameters `uv` fall in, with barycentrics of
    /// its corners 1 and 2 measured in the parameters (so that the tessellation's
    /// per-vertex `uv`s interpolate back to `uv`, but at the poles and the centre).
    pub fn triangle_at(&self, uv: Vec2) -> (u32, Vec2) {
        let cell = |x: f32, n: u32| {
            let f = (x * n as f32).clamp(0.0, n as f32);
            let i = (f.floor() as u32).min(n - 1);
            (i, f - i as f32)
        };
        match self.kind {
            QuadricKind::Sphere => {
                let (ns, nr) = (SEGMENTS, RINGS);
                let (i, s) = cell(uv.y, nr);
                let (j, t) = cell(uv.x, ns);
                // Triangles before ring i: one per segment in the first ring, two in
                // the middle ones.
                let first = if i == 0 { 0 } else { ns + (i - 1) * 2 * ns };
                if i == 0 {
                    // [pole, b, c].
                    (first + j, Vec2::new(s * (1.0 - t), s * t))
                } else if i == nr - 1 {
                    // [a, pole, d].
                    (first + j, Vec2::new(s, (1.0 - s) * t))
                } else if s >= t {
                    // [a, b, c].
                    (first + 2 * j, Vec2::new(s - t, t))
                } else {
                    // [a, c, d].
                    (first + 2 * j + 1, Vec2::new(s, t - s))
                }
            }
            QuadricKind::Disk => {
                let (j, t) = cell(uv.y, SEGMENTS);
                // [centre, rim j, rim j+1], the rim a little outside the unit circle.
                let r = (uv.x / disk_rim()).clamp(0.0, 1.0);
                (j, Vec2::new(r * (1.0 - t), r * t))
            }
        }
    }
}

/// The angle of `(x, y)` as a fraction of a turn, in `[0, 1)`.
fn angle(y: f64, x: f64) -> f32 {
    let a = y.atan2(x) / TAU;
    let a = if a < 0.0 { a + 1.0 } else { a };
    (a as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// `(u, v)` of the unit-sphere point `l`.
fn sphere_uv(l: DVec3) -> Vec2 {
    Vec2::new(angle(l.y, l.x), (l.z.clamp(-1.0, 1.0).acos() / PI) as f32)
}

#[cfg(test)]
mod tests;
