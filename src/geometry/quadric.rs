//! Mitsuba's `sphere` and `disk` as exact surfaces: ray intersection in closed form,
//! the true normal, a parametrisation for meshing, and uniform sampling by area.
//!
//! A [`Quadric`] is the unit sphere or the unit disk (z = 0, normal +z) of object
//! space under an affine `to_world` (a sphere's is a similarity; a disk's may be any
//! affine map, which makes it an ellipse). Rays are intersected in object space,
//! where the direction is not renormalised, so the ray parameter `t` is the world
//! one. Normals are mapped by the inverse transpose, which keeps their side under
//! any map, mirrors included.
//!
//! The surface is parameterised without poles or a centre where elements would
//! crowd: a sphere as the six faces of a cube, each mapped equi-angularly onto it
//! (`(u, v)` in `[0,1]^2` per face; elements differ in area by at most 1.4x), a disk
//! by Shirley and Chiu's concentric map of the square (which keeps areas). The
//! radiosity patches are pieces of these squares ([`super::shapes`]), and so is the
//! shape's triangle mesh, which stays as what the shape's records are indexed by (a
//! hit names a triangle with barycentrics, [`Quadric::triangle_at`]); no ray ever
//! meets its facets.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use glam::{DMat4, DVec3, Mat3, Mat4, Vec2, Vec3};

use super::shapes::{QUADRIC_CELLS, QUADRIC_PIECES};

/// Which unit shape a [`Quadric`] maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuadricKind {
    /// The unit sphere: six faces of a cube, mapped equi-angularly.
    Sphere,
    /// The unit disk in z = 0, normal +z: one face, the concentric map of the square.
    Disk,
}

impl QuadricKind {
    /// Number of faces (parameter squares).
    pub fn faces(self) -> u8 {
        match self {
            QuadricKind::Sphere => 6,
            QuadricKind::Disk => 1,
        }
    }
}

/// Surface parameters: a face and `(u, v)` in `[0,1]^2` on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// The face (0 for a disk).
    pub face: u8,
    /// The position on the face.
    pub uv: Vec2,
}

/// The cube's faces: outward axis `n` and in-face axes `a`, `b` with `a x b = n`, so
/// that `d/du x d/dv` points outward.
pub(crate) const CUBE_FACES: [(DVec3, DVec3, DVec3); 6] = [
    (DVec3::X, DVec3::Y, DVec3::Z),
    (DVec3::NEG_X, DVec3::Z, DVec3::Y),
    (DVec3::Y, DVec3::Z, DVec3::X),
    (DVec3::NEG_Y, DVec3::X, DVec3::Z),
    (DVec3::Z, DVec3::X, DVec3::Y),
    (DVec3::NEG_Z, DVec3::Y, DVec3::X),
];

/// The unit-sphere point at `(u, v)` of `face`: the cube face's point at
/// `tan(pi/4 (2u - 1))`, `tan(pi/4 (2v - 1))`, normalised.
fn sphere_point(face: u8, u: f64, v: f64) -> DVec3 {
    let (n, a, b) = CUBE_FACES[usize::from(face.min(5))];
    let x = (FRAC_PI_4 * (2.0 * u - 1.0)).tan();
    let y = (FRAC_PI_4 * (2.0 * v - 1.0)).tan();
    (n + a * x + b * y).normalize()
}

/// The face and parameters of the unit-sphere point `l`.
fn sphere_param(l: DVec3) -> Param {
    let face = (0..6)
        .max_by(|&x, &y| l.dot(CUBE_FACES[x].0).total_cmp(&l.dot(CUBE_FACES[y].0)))
        .unwrap_or(0);
    let (n, a, b) = CUBE_FACES[face];
    let d = l.dot(n).max(1e-300);
    let to = |x: f64| (((x / d).atan() / FRAC_PI_4 + 1.0) * 0.5).clamp(0.0, 1.0) as f32;
    Param {
        face: face as u8,
        uv: Vec2::new(to(l.dot(a)), to(l.dot(b))),
    }
}

/// Shirley and Chiu's concentric map of `(u, v)` in `[0,1]^2` onto the unit disk.
fn disk_point(u: f64, v: f64) -> DVec3 {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return DVec3::ZERO;
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, FRAC_PI_2 - FRAC_PI_4 * (a / b))
    };
    DVec3::new(r * phi.cos(), r * phi.sin(), 0.0)
}

/// The inverse of [`disk_point`] (`l` in the plane z = 0, within the unit disk).
fn disk_param(l: DVec3) -> Param {
    let r = l.truncate().length().min(1.0);
    let t = l.y.atan2(l.x);
    let (a, b) = if r == 0.0 {
        (0.0, 0.0)
    } else if (-FRAC_PI_4..=FRAC_PI_4).contains(&t) {
        // a = r > |b|: phi = pi/4 b / a.
        (r, r * t / FRAC_PI_4)
    } else if (FRAC_PI_4..=3.0 * FRAC_PI_4).contains(&t) {
        // b = r: phi = pi/2 - pi/4 a / b.
        (r * (FRAC_PI_2 - t) / FRAC_PI_4, r)
    } else if (-3.0 * FRAC_PI_4..=-FRAC_PI_4).contains(&t) {
        // b = -r: the point is the map's (r, phi) turned by pi.
        (-r * (FRAC_PI_2 - (t + PI)) / FRAC_PI_4, -r)
    } else {
        // a = -r.
        let p = if t > 0.0 { t - PI } else { t + PI };
        (-r, -r * p / FRAC_PI_4)
    };
    let to = |x: f64| ((x + 1.0) * 0.5).clamp(0.0, 1.0) as f32;
    Param {
        face: 0,
        uv: Vec2::new(to(a), to(b)),
    }
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
    /// its `t` and the surface parameters there.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Param)> {
        self.hit(origin, dir, tmin, tmax)
            .map(|(t, at)| (t, self.param_at(at)))
    }

    /// The surface parameters of a hit's object-space point ([`Quadric::hit`]).
    pub fn param_at(&self, at: DVec3) -> Param {
        match self.kind {
            QuadricKind::Sphere => sphere_param(at.normalize()),
            QuadricKind::Disk => disk_param(at),
        }
    }

    /// As [`Quadric::intersect`], with the hit's object-space point in place of its
    /// surface parameters (which cost inverse tangents: an occlusion test, or a hit
    /// that a nearer one replaces, needs none; [`Quadric::param_at`] gives them).
    pub fn hit(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<(f32, DVec3)> {
        let m = self.local_map();
        let (o, d) = (
            m.transform_point3(origin.as_dvec3()),
            m.transform_vector3(dir.as_dvec3()),
        );
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
                Some((t as f32, o + d * t))
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
                (x * x + y * y <= 1.0).then(|| (t as f32, DVec3::new(x, y, 0.0)))
            }
        }
    }

    /// The parameters of the surface point nearest to `p` (`p` on or near the
    /// surface).
    pub fn param_of(&self, p: Vec3) -> Param {
        let l = self.local_map().transform_point3(p.as_dvec3());
        match self.kind {
            QuadricKind::Sphere => sphere_param(l.normalize_or(DVec3::Z)),
            QuadricKind::Disk => disk_param(DVec3::new(l.x, l.y, 0.0)),
        }
    }

    /// The object-space point at `(u, v)` of `face`.
    fn local(&self, face: u8, u: f64, v: f64) -> DVec3 {
        match self.kind {
            QuadricKind::Sphere => sphere_point(face, u, v),
            QuadricKind::Disk => disk_point(u, v),
        }
    }

    /// Point and partial derivatives `(p, dp/du, dp/dv)` at `(u, v)` of `face`
    /// (derivatives by central differences in f64, one-sided at the square's edges).
    pub fn eval(&self, face: u8, u: f32, v: f32) -> (Vec3, Vec3, Vec3) {
        let (u, v) = (f64::from(u), f64::from(v));
        let h = 1e-6;
        let diff = |f: &dyn Fn(f64) -> DVec3, x: f64| {
            let (a, b) = ((x - h).max(0.0), (x + h).min(1.0));
            (f(b) - f(a)) / (b - a)
        };
        let du = diff(&|x| self.local(face, x, v), u);
        let dv = diff(&|y| self.local(face, u, y), v);
        let m = self.world();
        (
            m.transform_point3(self.local(face, u, v)).as_vec3(),
            m.transform_vector3(du).as_vec3(),
            m.transform_vector3(dv).as_vec3(),
        )
    }

    /// The unit normal at `(u, v)` of `face`: outward (a disk: along its +z),
    /// inward when [`flipped`](Self::flipped).
    pub fn normal(&self, face: u8, u: f32, v: f32) -> Vec3 {
        let n = match self.kind {
            QuadricKind::Sphere => self.local(face, f64::from(u), f64::from(v)),
            QuadricKind::Disk => DVec3::Z,
        };
        self.world_normal(n)
    }

    /// The surface point nearest to `p` and the unit normal there (see
    /// [`Self::normal`]): for a point a ray found, the exact point.
    /// The direction of increasing u at `p` (on or near the surface), as Mitsuba 3's
    /// sphere and disk give it: round the sphere's axis (`(-y, x, 0)` in object
    /// space), out from the disk's centre; `None` on the sphere's axis, where there is
    /// none. Its length is not meaningful.
    pub fn dpdu(&self, p: Vec3) -> Option<Vec3> {
        let l = self.local_map().transform_point3(p.as_dvec3());
        let r = l.truncate().length();
        let local = match self.kind {
            QuadricKind::Sphere if r > 0.0 => DVec3::new(-l.y, l.x, 0.0),
            QuadricKind::Sphere => return None,
            QuadricKind::Disk if r > 0.0 => DVec3::new(l.x / r, l.y / r, 0.0),
            QuadricKind::Disk => DVec3::X,
        };
        let d = self.world().transform_vector3(local).as_vec3();
        (d.length_squared() > 0.0 && d.is_finite()).then_some(d)
    }

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

    /// A sphere's centre and radius (under a similarity: the mean of its axes'
    /// lengths); `None` for a disk.
    pub fn sphere(&self) -> Option<(Vec3, f32)> {
        if self.kind != QuadricKind::Sphere {
            return None;
        }
        let m = self.world();
        let r = (m.x_axis.truncate().length() + m.y_axis.truncate().length() + m.z_axis.truncate().length())
            / 3.0;
        Some((m.w_axis.truncate().as_vec3(), r as f32))
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
        let l = match self.kind {
            // Archimedes: z uniform in [-1, 1] is uniform by area.
            QuadricKind::Sphere => {
                let z = (1.0 - 2.0 * f64::from(s.x)).clamp(-1.0, 1.0);
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (sp, cp) = (2.0 * PI * f64::from(s.y)).sin_cos();
                DVec3::new(r * cp, r * sp, z)
            }
            // The concentric map keeps areas.
            QuadricKind::Disk => disk_point(f64::from(s.x), f64::from(s.y)),
        };
        let n = match self.kind {
            QuadricKind::Sphere => l,
            QuadricKind::Disk => DVec3::Z,
        };
        (self.world().transform_point3(l).as_vec3(), self.world_normal(n))
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
    /// [`super::shapes::disk`]) that parameters `at` fall in, with barycentrics of
    /// its corners 1 and 2 measured in the parameters: each face is cut into
    /// [`QUADRIC_PIECES`]^2 pieces (the radiosity patches), each piece into
    /// [`QUADRIC_CELLS`]^2 cells, each cell into two triangles `[a, b, c]`,
    /// `[a, c, d]` (corners `a (0,0)`, `b (1,0)`, `c (1,1)`, `d (0,1)`).
    pub fn triangle_at(&self, at: Param) -> (u32, Vec2) {
        let n = QUADRIC_PIECES * QUADRIC_CELLS;
        let cell = |x: f32| {
            let f = (x * n as f32).clamp(0.0, n as f32);
            let i = (f.floor() as u32).min(n - 1);
            (i, f - i as f32)
        };
        let (i, s) = cell(at.uv.x);
        let (j, t) = cell(at.uv.y);
        let (c, m) = (QUADRIC_CELLS, QUADRIC_PIECES);
        let piece = u32::from(at.face.min(self.kind.faces() - 1)) * m * m + (j / c) * m + i / c;
        let first = 2 * (piece * c * c + (j % c) * c + i % c);
        if s >= t {
            (first, Vec2::new(s - t, t))
        } else {
            (first + 1, Vec2::new(s, t - s))
        }
    }
}

#[cfg(test)]
mod tests;
