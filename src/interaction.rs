//! The surface interaction at a ray hit: the hit's frame (position, geometric and
//! shading normals, side) and the one rule by which rays leave a surface.

use glam::{Vec2, Vec3};
use std::borrow::Cow;

use crate::accel::{Accel, Hit, Ray};
use crate::scene::{Bsdf, BsdfKind, Light, Rgb, Scene};

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
    /// Width of the camera ray's footprint here, across the ray (scene units), which
    /// mipmapped textures are read over ([`SurfacePoint::uv_footprint`]); 0 for a
    /// point (every other ray).
    pub footprint: f32,
    /// The shading normal before a bump or normal map tilted it
    /// ([`SurfacePoint::bumped`]); `ns` itself without one.
    pub flat: Vec3,
    /// Whether the map's reflection is weighed by the terminator term
    /// ([`SurfacePoint::terminator`]; Mitsuba's `use_shadowing_function`).
    pub shadowing: bool,
}

impl SurfacePoint {
    /// The surface point where `ray` met `hit`.
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit) -> Self {
        let mesh = &scene.shapes[hit.shape as usize].mesh;
        let (p, mut ng, mut ns) = match &mesh.quadric {
            // A sphere or disk: the exact point and normal (both normals alike).
            Some(q) => {
                let (p, n) = q.project(ray.at(hit.t));
                (p, n, n)
            }
            None => {
                let [ia, ib, ic] = mesh.indices[hit.tri as usize].map(|i| i as usize);
                let (a, b, c) = (mesh.positions[ia], mesh.positions[ib], mesh.positions[ic]);
                let (b1, b2) = (hit.bary.x, hit.bary.y);
                let b0 = 1.0 - b1 - b2;
                let ng = (b - a).cross(c - a).normalize();
                let ns = if mesh.normals.is_empty() {
                    ng
                } else {
                    (mesh.normals[ia] * b0 + mesh.normals[ib] * b1 + mesh.normals[ic] * b2).normalize_or(ng)
                };
                (a * b0 + b * b1 + c * b2, ng, ns)
            }
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
            footprint: 0.0,
            flat: ns,
            shadowing: false,
        }
    }

    /// The surface parameters (u, v) here: the mesh's, interpolated over the
    /// triangle; a mesh without them gives the barycentrics (b1, b2), as Mitsuba 3.
    pub fn uv(&self, scene: &Scene) -> Vec2 {
        scene.shapes[self.shape as usize].mesh.uv_at(self.tri, self.bary)
    }

    /// The direction of increasing u here (dp/du), which orients an anisotropic
    /// lobe as Mitsuba 3 does: a mesh's from its triangle's (u, v) where it has them
    /// and they span the triangle, an exact sphere's or disk's from its
    /// parameterisation ([`crate::geometry::Quadric::dpdu`]), else the first axis of
    /// the branchless frame (Duff et al. 2017, Mitsuba's `coordinate_system`) round
    /// the surface's own (unflipped) normal. Not normalised.
    pub fn dpdu(&self, scene: &Scene) -> Vec3 {
        let mesh = &scene.shapes[self.shape as usize].mesh;
        let n = if self.front { self.ng } else { -self.ng };
        let fallback = || n.any_orthonormal_pair().0;
        if let Some(q) = &mesh.quadric {
            return q.dpdu(self.p).unwrap_or_else(fallback);
        }
        let Some(&[i, j, k]) = mesh.indices.get(self.tri as usize) else {
            return fallback();
        };
        let (Some(uv0), Some(uv1), Some(uv2)) = (
            mesh.uvs.get(i as usize),
            mesh.uvs.get(j as usize),
            mesh.uvs.get(k as usize),
        ) else {
            return fallback();
        };
        let [a, b, c] = [i, j, k].map(|x| mesh.positions[x as usize]);
        let (dp0, dp1) = (b - a, c - a);
        let (duv0, duv1) = (*uv1 - *uv0, *uv2 - *uv0);
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        let d = (dp0 * duv1.y - dp1 * duv0.y) / det;
        if det != 0.0 && d.is_finite() && d.length_squared() > 0.0 {
            d
        } else {
            fallback()
        }
    }

    /// The radiance the area light of this point's shape sends from here: its
    /// texture's value at this point (over its footprint) where it has one, else its
    /// radiance; `None` on a shape that is no area light. (Whether the ray meets its
    /// emitting side is the caller's test.)
    pub fn emitted(&self, scene: &Scene) -> Option<Rgb> {
        let e = scene.shapes[self.shape as usize].emitter?;
        match scene.lights.get(e as usize)? {
            Light::Area { texture: Some(t), .. } => Some(
                scene
                    .textures
                    .get(*t as usize)?
                    .eval_over(self.uv(scene), self.uv_footprint(scene)),
            ),
            Light::Area { radiance, .. } => Some(*radiance),
            _ => None,
        }
    }

    /// The material here: the shape's BSDF, and its reflection model with its
    /// textures looked up at this point's (u, v) (the model itself when untextured),
    /// over its footprint.
    pub fn material<'s>(&self, scene: &'s Scene) -> (&'s Bsdf, Cow<'s, BsdfKind>) {
        let bsdf = &scene.bsdfs[scene.shapes[self.shape as usize].bsdf as usize];
        let kind = if bsdf.textures.is_empty() {
            Cow::Borrowed(&bsdf.kind)
        } else {
            bsdf.kind_at(self.uv(scene), self.uv_footprint(scene), &scene.textures)
        };
        (bsdf, kind)
    }

    /// Whether light from direction `dir` (unit, away from the point) reaches the
    /// point's front by both its normals: no shadow ray is cast towards a light
    /// behind the surface (paper Sect. 6).
    pub fn faces(&self, dir: Vec3) -> bool {
        self.ns.dot(dir) > 0.0 && self.ng.dot(dir) > 0.0
    }

    /// This point seen by a camera ray whose footprint is `width` wide here (scene
    /// units, across the ray).
    pub fn with_footprint(mut self, width: f32) -> Self {
        self.footprint = width;
        self
    }

    /// The footprint in surface parameters (u, v): its width by the square root of
    /// the triangle's (u, v) area over its area (isotropic: the width across the ray,
    /// not its stretch along a surface seen at a slant, which would blur a floor seen
    /// far off). Found only where a textured material is looked up. Meshes without
    /// (u, v), exact spheres and disks, and rays without a footprint give 0 (a point).
    pub fn uv_footprint(&self, scene: &Scene) -> f32 {
        let mesh = &scene.shapes[self.shape as usize].mesh;
        if mesh.quadric.is_some() || mesh.uvs.is_empty() || !(self.footprint > 0.0) {
            return 0.0;
        }
        let [a, b, c] = mesh.triangle(self.tri as usize);
        let [i, j, k] = mesh.indices[self.tri as usize].map(|i| i as usize);
        let uv = |i: usize| mesh.uvs.get(i).copied().unwrap_or_default();
        let area = (b - a).cross(c - a).length();
        let uv_area = (uv(j) - uv(i)).perp_dot(uv(k) - uv(i)).abs();
        if area > 0.0 && uv_area.is_finite() {
            self.footprint * (uv_area / area).sqrt()
        } else {
            0.0
        }
    }

    /// This point with its shading normal tilted by the material's bump or normal
    /// map, if it has one (as Mitsuba 3's `bumpmap` and `normalmap`: the surface's
    /// derivatives in (u, v) from its triangle, the height's gradient added along the
    /// normal, or the map's normal in the frame of the normal and the u derivative),
    /// kept on the side the ray arrived from. Where the ray arriving along `-wi` would
    /// see the tilted normal from behind, the tilt is mirrored about the untilted
    /// normal, as Mitsuba 3 does since 3.7.1 (its `flip_invalid_normals`, on by
    /// default; Schüssler et al. 2017): the textbook's black bands on the flanks of
    /// steep bumps turned away from the eye are not Mitsuba's picture. Exact spheres
    /// and disks are left as they are.
    pub fn bumped(mut self, scene: &Scene, bsdf: &Bsdf, wi: Vec3) -> Self {
        use crate::scene::TexField;
        let Some((slot, rules)) = bsdf
            .textures
            .iter()
            .find_map(|t| Some((t, t.field.bump_rules()?)))
        else {
            return self;
        };
        let Some(tex) = scene.textures.get(slot.texture as usize) else {
            return self;
        };
        let mesh = &scene.shapes[self.shape as usize].mesh;
        if mesh.quadric.is_some() {
            return self;
        }
        let Some(&[a, b, c]) = mesh.indices.get(self.tri as usize) else {
            return self;
        };
        let p = |i: u32| mesh.positions[i as usize];
        let (dp1, dp2) = (p(b) - p(a), p(c) - p(a));
        // The (u, v) of the corners by the one rule (the barycentrics without any).
        let uv0 = mesh.uv_at(self.tri, Vec2::ZERO);
        let (du1, du2) = (
            mesh.uv_at(self.tri, Vec2::X) - uv0,
            mesh.uv_at(self.tri, Vec2::Y) - uv0,
        );
        let det = du1.x * du2.y - du1.y * du2.x;
        if !(det.abs() > 1e-20) {
            return self;
        }
        let dp_du = (dp1 * du2.y - dp2 * du1.y) / det;
        let dp_dv = (dp2 * du1.x - dp1 * du2.x) / det;
        // The unbumped shading normal on the front side, the frame's z.
        let n = if self.front { self.ns } else { -self.ns };
        let uv = self.uv(scene);
        let bent = match slot.field {
            TexField::Bump(_) => {
                let g = tex.gradient(uv) * slot.factor.x;
                let du = dp_du + n * (g.x - n.dot(dp_du));
                let dv = dp_dv + n * (g.y - n.dot(dp_dv));
                du.cross(dv)
            }
            _ => {
                let m = tex.eval(uv) * 2.0 - Vec3::ONE;
                let s = (dp_du - n * n.dot(dp_du)).normalize_or(n.any_orthonormal_vector());
                let t = n.cross(s);
                s * m.x + t * m.y + n * m.z
            }
        };
        let Some(bent) = bent.try_normalize() else {
            return self;
        };
        let bent = if bent.dot(self.ng) < 0.0 { -bent } else { bent };
        let flat = self.ns;
        self.shadowing = rules.shadowing;
        self.ns = if rules.flip && wi.dot(flat) * wi.dot(bent) <= 0.0 {
            (2.0 * bent.dot(flat) * flat - bent).normalize_or(flat)
        } else {
            bent
        };
        self
    }

    /// What Mitsuba 3 (since 3.7.1: its `use_shadowing_function`, on by default;
    /// Conty Estevez et al. 2019) multiplies a bumped surface's reflection towards
    /// the unit direction `dir` by: the microfacet shadowing of a surface whose
    /// normals tilt as this point's does, so light from low over the surface falls
    /// off smoothly; none below the untilted normal (Mitsuba's orientation test).
    /// 1 where no map tilts the normal, and above it where the file turned the
    /// term off.
    pub fn terminator(&self, dir: Vec3) -> f32 {
        if !self.is_bumped() {
            return 1.0;
        }
        let c = self.flat.dot(dir);
        if c <= 0.0 {
            return 0.0;
        }
        if !self.shadowing {
            return 1.0;
        }
        terminator(self.flat.dot(self.ns), c)
    }

    /// The share of light arriving evenly from over the surface that this point's
    /// tilted normal takes, under Mitsuba's rules ([`SurfacePoint::terminator`]):
    /// what the light read from the solution and the gather (both found at the
    /// untilted normal) is scaled by on a bumped surface. 1 where no map tilts it.
    pub fn hemisphere_share(&self) -> f32 {
        let c = self.flat.dot(self.ns);
        match (self.is_bumped(), self.shadowing) {
            (false, _) => 1.0,
            (true, true) => hemisphere_share(c),
            // No terminator term: the even light over both normals' hemispheres.
            (true, false) => 0.5 * (1.0 + c),
        }
    }

    /// Whether a bump or normal map tilted the shading normal here.
    pub fn is_bumped(&self) -> bool {
        self.ns != self.flat
    }

    /// How opaque the material is here (`mask`'s opacity; 1 without a mask).
    pub fn opacity(&self, scene: &Scene, bsdf: &Bsdf) -> f32 {
        if !bsdf.masked() {
            return 1.0;
        }
        bsdf.opacity_at(self.uv(scene), &scene.textures)
    }

    /// Whether a ray that meets this point goes on through it (a `mask`ed surface,
    /// drawn by its opacity from `u` in [0, 1)).
    pub fn passes(&self, scene: &Scene, bsdf: &Bsdf, u: f32) -> bool {
        bsdf.masked() && u >= bsdf.opacity_at(self.uv(scene), &scene.textures)
    }

    /// A ray leaving this point in `dir` (on the side `dir` points to), ending at
    /// distance `tmax` from the point.
    pub fn spawn(&self, dir: Vec3, tmax: f32) -> Ray {
        let eps = ray_epsilon(self.p);
        Ray {
            origin: offset_from(self.p, self.ng, dir),
            dir,
            tmin: 0.0,
            tmax: (tmax - eps).max(0.0),
        }
    }

    /// The shadow ray from this point to light point `q` (see [`shadow_ray`]).
    pub fn shadow_ray(&self, q: Vec3, q_normal: Option<Vec3>) -> Ray {
        shadow_ray(self.p, self.ng, q, q_normal)
    }
}

/// Mitsuba 3's bump terminator term (Conty Estevez, Lecocq & Stein 2019): for a
/// normal tilted by an angle of cosine `cos_tilt` from the surface's, the shadowing
/// of light from an angle of cosine `cos_dir` over the surface, with the facets'
/// roughness alpha^2 = min(tan^2 tilt / 8, 1).
pub fn terminator(cos_tilt: f32, cos_dir: f32) -> f32 {
    let tan2 = |c: f32| (1.0 - c * c).max(0.0) / (c * c).max(1e-12);
    let alpha2 = (0.125 * tan2(cos_tilt)).min(1.0);
    2.0 / (1.0 + (1.0 + alpha2 * tan2(cos_dir)).sqrt())
}

/// Cosines of tilt at which [`hemisphere_share`] is tabulated, evenly from 0 to 1.
const SHARE_STEPS: usize = 64;

/// The share of light arriving evenly over a surface (radiance L over the untilted
/// normal's hemisphere, irradiance pi L) that a normal tilted by an angle of cosine
/// `cos_tilt` takes, as Mitsuba 3 lights a bumped diffuse surface: directions below
/// either normal bring nothing, the rest their cosine to the tilted normal times
/// [`terminator`]. (Without the terminator term it would be (1 + cos tilt) / 2.)
/// Tabulated once, then read linearly: per ring of directions at angle theta from
/// the untilted normal the terminator term is one value and the cosine's positive
/// part integrates over the ring in closed form ([`ring_cosine`]); the rings are
/// summed by a midpoint rule.
pub fn hemisphere_share(cos_tilt: f32) -> f32 {
    static TABLE: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        const RINGS: usize = 512;
        let d_theta = std::f64::consts::FRAC_PI_2 / RINGS as f64;
        (0..=SHARE_STEPS)
            .map(|k| {
                let c = k as f64 / SHARE_STEPS as f64;
                let s = (1.0 - c * c).max(0.0).sqrt();
                let sum: f64 = (0..RINGS)
                    .map(|i| {
                        let (st, ct) = ((i as f64 + 0.5) * d_theta).sin_cos();
                        // On the ring, the tilted normal's cosine is
                        // st s cos(phi) + ct c.
                        ring_cosine(st * s, ct * c) * f64::from(terminator(c as f32, ct as f32)) * st
                    })
                    .sum();
                (sum * d_theta / std::f64::consts::PI) as f32
            })
            .collect()
    });
    let x = cos_tilt.clamp(0.0, 1.0) * SHARE_STEPS as f32;
    let k = (x as usize).min(SHARE_STEPS - 1);
    let t = x - k as f32;
    table[k] * (1.0 - t) + table[k + 1] * t
}

/// The integral over phi in [0, 2 pi) of max(0, a cos phi + b), for a >= 0.
fn ring_cosine(a: f64, b: f64) -> f64 {
    use std::f64::consts::PI;
    if b >= a {
        2.0 * PI * b
    } else if b <= -a {
        0.0
    } else {
        // Positive for |phi| < phi0, where a cos phi0 = -b.
        let phi0 = (-b / a).acos();
        2.0 * (a * phi0.sin() + b * phi0)
    }
}

/// The one offset: how far a ray's ends are moved off their surfaces, relative to
/// the magnitude of the coordinates (floating-point error grows with them).
pub fn ray_epsilon(p: Vec3) -> f32 {
    2e-5 * (1.0 + p.abs().max_element())
}

/// How much shorter than the distance between its (offset) ends a shadow ray to a
/// point on a surface is, relative to that distance (pbrt-v4's `ShadowEpsilon`).
pub const SHADOW_EPSILON: f32 = 1e-4;

/// The mirror reflection of direction `d` about the unit normal `n` (the one rule of
/// both passes: shading, the gather, the photons).
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// `p`, on a surface with normal `n`, moved off it by [`ray_epsilon`] to the side
/// that `towards` points to.
pub fn offset_from(p: Vec3, n: Vec3, towards: Vec3) -> Vec3 {
    let side = if towards.dot(n) >= 0.0 { n } else { -n };
    p + side * ray_epsilon(p)
}

/// The ray of light leaving a source as `e`: from its origin, moved off an area
/// light's surface ([`offset_from`]) towards its direction.
pub fn emission_ray(e: &crate::emitters::Emission) -> Ray {
    Ray {
        origin: match e.normal {
            Some(n) => offset_from(e.origin, n, e.dir),
            None => e.origin,
        },
        dir: e.dir,
        tmin: 0.0,
        tmax: f32::INFINITY,
    }
}

/// The one shadow-ray constructor of both passes (pbrt-v4's `SpawnRayTo`): from `p`,
/// on a surface with normal `n`, to the light point `q`, which lies on a surface with
/// normal `q_normal` (an area light, a radiant patch) or in space (`None`: a point or
/// spot light). Each end on a surface is moved off it towards the other end
/// ([`offset_from`]), and the ray stops [`SHADOW_EPSILON`] of its length short, so
/// that neither surface occludes the ray and the visibility pass 1 stores is the
/// visibility pass 2 finds.
pub fn shadow_ray(p: Vec3, n: Vec3, q: Vec3, q_normal: Option<Vec3>) -> Ray {
    let from = offset_from(p, n, q - p);
    let to = match q_normal {
        Some(nq) => offset_from(q, nq, p - q),
        None => q,
    };
    let d = to - from;
    let len = d.length();
    let (dir, len) = if len > 0.0 { (d / len, len) } else { (Vec3::Z, 0.0) };
    // Short of a light in space too, as pbrt-v4's and Mitsuba 3's rays to a light: a
    // point light on a surface (the classroom's blue spot sits in its floor's plane)
    // would otherwise be hidden by that surface at random, wherever rounding puts the
    // hit before the ray's end.
    let tmax = len * (1.0 - SHADOW_EPSILON);
    Ray {
        origin: from,
        dir,
        tmin: 0.0,
        tmax,
    }
}

/// Two faces of thick glass whose normals part by less than this (as a cosine) are
/// parallel: light that crosses the glass between them leaves it in the direction it
/// came (a window pane, the wall of a bulb or a bottle), so shadow rays cross there
/// unbent ([`transmittance`]) and photons that leave by such a face are still the
/// light the shots deliver. A ray leaves a 5.7-degree wedge of glass turned by about
/// 3 degrees.
pub const PARALLEL_FACES: f32 = 0.995;

/// The share of light that arrives along shadow ray `ray`: 0 if a surface that stops
/// shadow rays lies on it ([`Accel::occluded`]), else [`pane_transmittance`]: the one
/// visibility query of both passes.
pub fn transmittance(scene: &Scene, accel: &dyn Accel, ray: &Ray) -> f32 {
    if accel.occluded(ray) {
        0.0
    } else {
        pane_transmittance(scene, accel, ray)
    }
}

/// The share of light glass and masks let through along shadow ray `ray` (1 if it
/// meets none; those surfaces are traced alone, [`Accel::panes`]): the product of
/// each face's transmittance at the ray's angle, unbent
/// ([`BsdfKind::straight_transmittance`]). A thin pane only dims. Thick glass is
/// crossed only between parallel faces ([`PARALLEL_FACES`]: exact for a window pane,
/// whose faces leave the ray's direction as it was; a solid glass object's focusing
/// is the photons' part, and stops the ray here). Mitsuba's path tracer finds the
/// light of an area light or a sky behind a pane by rays that refract through it,
/// to the same value; a point, spot or directional light it cannot find that way,
/// and leaves a room behind a `dielectric` pane dark where the sun would light it.
/// Kept apart from the occlusion, which the shadow image buffer reuses, so that a
/// reused "lit" is dimmed as a cast one is.
pub fn pane_transmittance(scene: &Scene, accel: &dyn Accel, ray: &Ray) -> f32 {
    let Some(panes) = accel.panes() else {
        return 1.0;
    };
    let mut r = *ray;
    let mut share = 1.0;
    // Inside thick glass: the normal of the face the ray entered by.
    let mut entered: Option<Vec3> = None;
    // Such surfaces are few along a ray; a bound keeps a degenerate stack finite.
    for _ in 0..64 {
        let Some(hit) = panes.intersect(&r) else {
            break;
        };
        let sp = SurfacePoint::new(scene, &r, &hit);
        let cos = sp.ng.dot(r.dir) / r.dir.length();
        let bsdf = &scene.bsdfs[scene.shapes[hit.shape as usize].bsdf as usize];
        if bsdf.kind.is_thick_glass() {
            if let Some(n) = entered.take() {
                if n.dot(sp.ng).abs() < PARALLEL_FACES {
                    return 0.0;
                }
            } else {
                entered = Some(sp.ng);
            }
        }
        let masked = bsdf.masked();
        let through = bsdf
            .kind
            .straight_transmittance(cos)
            .unwrap_or(if masked { 1.0 } else { 0.0 });
        let open = if masked {
            1.0 - sp.opacity(scene, bsdf)
        } else {
            1.0
        };
        share *= through * open;
        if share <= 0.0 {
            return 0.0;
        }
        r.tmin = hit.t + ray_epsilon(sp.p) / r.dir.length();
    }
    share
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both ends leave their surfaces towards each other; the ray stops short of a
    /// surface end and reaches a point light; a ray of zero length is empty.
    #[test]
    fn a_shadow_ray_leaves_both_surfaces_towards_the_other_end() {
        let p = Vec3::new(1.0, 2.0, 0.0);
        let q = Vec3::new(1.0, 2.0, 3.0);
        let n = Vec3::Z;
        // The receiver's normal faces away from q: the origin still moves towards q.
        let r = shadow_ray(p, -n, q, Some(-n));
        let eps_p = ray_epsilon(p);
        let eps_q = ray_epsilon(q);
        assert!((r.origin - (p + n * eps_p)).length() < 1e-7, "{:?}", r.origin);
        assert!((r.dir - n).length() < 1e-6);
        let end = r.origin + r.dir * r.tmax;
        assert!(end.z < q.z - eps_q && end.z > q.z - eps_q - 4e-4, "{end}");
        // A point light: the ray stops just short of the light, by the same share.
        let r = shadow_ray(p, n, q, None);
        let end = r.origin + r.dir * r.tmax;
        let short = (q - end).length() / (q - r.origin).length();
        assert!((short - SHADOW_EPSILON).abs() < 1e-5, "{short}");
        assert_eq!(r.tmin, 0.0);
        // Between coincident points the ray spans only the offset gap.
        assert!(shadow_ray(p, n, p, None).tmax <= 1.001 * eps_p);
    }

    /// A ray offset by the rule does not hit the surface it leaves, however far from
    /// the origin the surface is (the offset grows with the coordinates).
    #[test]
    fn an_offset_ray_does_not_see_its_own_surface() {
        use crate::accel::{Accel, Bvh};
        use crate::testutil::{quad, scene};
        for &far in &[0.0f32, 1e2, 1e4] {
            let c = Vec3::new(far, far, 0.0);
            let floor = quad([
                c + Vec3::new(-1.0, -1.0, 0.0),
                c + Vec3::new(1.0, -1.0, 0.0),
                c + Vec3::new(1.0, 1.0, 0.0),
                c + Vec3::new(-1.0, 1.0, 0.0),
            ]);
            let s = scene(vec![(floor, Vec3::splat(0.5))], vec![], &[]);
            let bvh = Bvh::build(&s);
            for k in 0..64 {
                let a = k as f32 * 0.098;
                let p = c + Vec3::new(0.3 * a.cos(), 0.3 * a.sin(), 0.0);
                let light = p + Vec3::new(5.0 * a.sin(), 0.5 * a.cos(), 0.01 + 0.05 * k as f32);
                assert!(
                    !bvh.occluded(&shadow_ray(p, Vec3::Z, light, None)),
                    "far {far} k {k}"
                );
            }
        }
    }

    /// A bump map of heights rising 1 a texel along u (scale 0.1, a 4-texel image
    /// over the unit square: gradient 0.4 per unit u) tilts a floor's normal to
    /// (-0.4, 0, 1), Mitsuba's formula for a flat surface; a normal map gives its own
    /// normal in the frame (u, v, n); both keep the side the ray came from.
    #[test]
    fn a_camera_footprint_is_measured_in_the_triangles_uv() {
        // A 4 x 2 rectangle whose (u, v) run over [0, 1] x [0, 1]: 1/8 of (u, v)'s
        // area per unit of area, so a footprint w wide is w / sqrt(8) in (u, v).
        let mut m = crate::testutil::square(0.0, 4.0, 0.0, 2.0, 0.0, false);
        m.uvs = m
            .positions
            .iter()
            .map(|p| Vec2::new(p.x / 4.0, p.y / 2.0))
            .collect();
        let bare = crate::testutil::square(0.0, 4.0, 0.0, 2.0, 0.0, false);
        let diffuse = BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.5),
        };
        let s = crate::testutil::scene_with(vec![(m, diffuse.clone()), (bare, diffuse)], vec![], &[]);
        let ray = Ray::new(Vec3::new(1.0, 1.0, 1.0), -Vec3::Z);
        let hit = |shape| Hit {
            t: 1.0,
            shape,
            tri: 0,
            bary: Vec2::new(0.2, 0.3),
        };
        let sp = SurfacePoint::new(&s, &ray, &hit(0));
        assert_eq!(sp.uv_footprint(&s), 0.0);
        let f = sp.with_footprint(0.02).uv_footprint(&s);
        assert!((f - 0.02 / 8f32.sqrt()).abs() < 1e-7, "{f}");
        // Without (u, v): a point.
        assert_eq!(
            SurfacePoint::new(&s, &ray, &hit(1))
                .with_footprint(0.02)
                .uv_footprint(&s),
            0.0
        );
    }

    #[test]
    fn bump_and_normal_maps_tilt_the_shading_normal() {
        use crate::accel::Accel;
        use crate::accel::Bvh;
        use crate::scene::{TexField, TexSlot, Texture};
        use crate::testutil::{quad, scene};
        let mut floor = quad([
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]);
        floor.uvs = floor.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect();
        let mut s = scene(vec![(floor, Vec3::splat(0.5))], vec![], &[]);
        let ramp: Vec<[f32; 3]> = (0..16).map(|i| [(i % 4) as f32; 3]).collect();
        let mut t = Texture::from_linear("ramp", 4, 4, ramp).unwrap();
        t.wrap = crate::scene::texture::TexWrap::Clamp;
        s.textures.push(t);
        // Tangent-space normal (0.6, 0, 0.8), stored as (n + 1) / 2.
        s.textures
            .push(Texture::from_linear("n", 1, 1, vec![[0.8, 0.5, 0.9]]).unwrap());
        let bvh = Bvh::build(&s);
        let at = |s: &Scene, from: Vec3| {
            let ray = Ray::new(from, Vec3::new(0.5, 0.5, 0.0) - from);
            let hit = bvh.intersect(&ray).unwrap();
            let sp = SurfacePoint::new(s, &ray, &hit);
            sp.bumped(s, &s.bsdfs[0], -ray.dir)
        };
        for (field, factor, expect) in [
            (
                TexField::Bump(Default::default()),
                0.1,
                Vec3::new(-0.4, 0.0, 1.0).normalize(),
            ),
            (
                TexField::Normal(Default::default()),
                1.0,
                Vec3::new(0.6, 0.0, 0.8),
            ),
        ] {
            s.bsdfs[0].textures = vec![TexSlot {
                path: Vec::new(),
                field,
                texture: if matches!(field, TexField::Bump(_)) { 0 } else { 1 },
                factor: Vec3::splat(factor),
            }];
            let sp = at(&s, Vec3::new(0.5, 0.5, 2.0));
            assert!(
                (sp.ns - expect).length() < 1e-4,
                "{field:?}: {} vs {expect}",
                sp.ns
            );
            // From below: the same tilt, turned to the ray's side.
            let sp = at(&s, Vec3::new(0.5, 0.5, -2.0));
            assert!(
                sp.ns.z < 0.0 && (sp.ns.x.abs() - expect.x.abs()).abs() < 1e-4,
                "{}",
                sp.ns
            );
        }
    }

    /// A normal map's light against Mitsuba 3.9.1's `normalmap` over a `diffuse` of
    /// reflectance 0.5 (its `eval(ctx, si, wo)`, the cosine included, on the plane
    /// z = 0 with dp/du along x), for a constant map normal `n` seen from `wi`, under
    /// both rules and with each turned off: rho / pi max(0, ns . wo) times the
    /// terminator term, nothing where the eye sees `ns` from behind (the shading's
    /// rule), where `ns` is the tilted normal after [`SurfacePoint::bumped`] mirrored
    /// it when `wi` would see it from behind (cases two, three and five).
    #[test]
    fn a_normal_maps_light_is_mitsubas_with_its_flip_and_terminator_term() {
        use crate::accel::{Accel, Bvh};
        use crate::scene::{BumpRules, TexField, TexSlot, Texture};
        use crate::testutil::{quad, scene};
        let mut floor = quad([
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ]);
        floor.uvs = floor.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect();
        let mut s = scene(vec![(floor, Vec3::splat(0.5))], vec![], &[]);
        let bvh = Bvh::build(&s);
        let unit = |x: f32, y: f32, z: f32| Vec3::new(x, y, z).normalize();
        let (a, b) = (unit(0.6, 0.0, 0.8), unit(0.8, 0.0, 0.6));
        let both = BumpRules::default();
        let no_shadowing = BumpRules {
            shadowing: false,
            ..both
        };
        let no_flip = BumpRules { flip: false, ..both };
        for (rules, n, wi, wo, mitsuba) in [
            (both, a, unit(0.0, 0.0, 1.0), unit(0.5, 0.0, 1.0), 0.155_905_6),
            (both, a, unit(-1.0, 0.0, 0.3), unit(0.5, 0.0, 1.0), 0.070_866_18),
            (both, a, unit(-1.0, 0.0, 0.3), unit(-0.5, 0.2, 1.0), 0.153_363_1),
            (both, b, unit(0.2, 0.1, 1.0), unit(-0.3, -0.4, 0.5), 0.012_827_81),
            (both, b, unit(-0.9, 0.1, 0.2), unit(0.9, 0.0, 0.3), 0.0),
            (
                no_shadowing,
                a,
                unit(-1.0, 0.0, 0.3),
                unit(0.5, 0.0, 1.0),
                0.071_176_25,
            ),
            (
                no_shadowing,
                b,
                unit(0.2, 0.1, 1.0),
                unit(-0.3, -0.4, 0.5),
                0.013_504_75,
            ),
            (
                no_shadowing,
                a,
                unit(-1.0, 0.0, 0.3),
                unit(-0.5, 0.2, 1.0),
                0.154_140_9,
            ),
            (no_flip, a, unit(-1.0, 0.0, 0.3), unit(0.5, 0.0, 1.0), 0.0),
            (
                no_flip,
                b,
                unit(0.2, 0.1, 1.0),
                unit(-0.3, -0.4, 0.5),
                0.012_827_81,
            ),
        ] {
            let texel = ((n + Vec3::ONE) * 0.5).to_array();
            s.textures = vec![Texture::from_linear("n", 1, 1, vec![texel]).unwrap()];
            s.bsdfs[0].textures = vec![TexSlot {
                path: Vec::new(),
                field: TexField::Normal(rules),
                texture: 0,
                factor: Vec3::ONE,
            }];
            let ray = Ray::new(wi, -wi);
            let hit = bvh.intersect(&ray).unwrap();
            let sp = SurfacePoint::new(&s, &ray, &hit).bumped(&s, &s.bsdfs[0], wi);
            let ours = if sp.ns.dot(wi) > 0.0 {
                0.5 * std::f32::consts::FRAC_1_PI * sp.ns.dot(wo).max(0.0) * sp.terminator(wo)
            } else {
                0.0
            };
            assert!(
                (ours - mitsuba).abs() < 2e-5,
                "{rules:?} n {n} wi {wi} wo {wo}: {ours} vs {mitsuba}"
            );
        }
    }

    /// [`hemisphere_share`] against the same integral of Mitsuba 3.9.1's `normalmap`
    /// over a `diffuse` (its `eval` over a 200 x 400 grid of directions, uniform
    /// radiance, over the reflectance; the eye straight above), for tilts of cosine
    /// 0.9 to 0.3. Without the terminator term the share would be (1 + cos) / 2: 0.95
    /// to 0.65.
    #[test]
    fn the_share_of_even_light_a_tilted_normal_takes_is_mitsubas() {
        assert!((hemisphere_share(1.0) - 1.0).abs() < 1e-3);
        for (c, mitsuba) in [(0.9, 0.908_03), (0.7, 0.737_69), (0.5, 0.565_47), (0.3, 0.397_35)] {
            let ours = hemisphere_share(c);
            assert!((ours - mitsuba).abs() < 2e-3, "cos {c}: {ours} vs {mitsuba}");
        }
    }

    /// dp/du as Mitsuba 3 gives it: a rectangle's along its local x (turned here a
    /// quarter turn about its normal: world y), a sphere's round its axis, a disk's
    /// outward from its centre, and on a mesh without (u, v) the first axis of the
    /// branchless frame round the face normal ((1, 0, 0) for +z).
    #[test]
    fn dpdu_follows_each_shapes_parameterisation() {
        let xml = r#"<scene version="3.0.0">
            <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
            <emitter type="constant"/>
            <shape type="rectangle"><transform name="to_world"><rotate z="1" angle="90"/><translate z="-1"/></transform></shape>
            <shape type="sphere"><point name="center" x="5" y="0" z="0"/><float name="radius" value="1"/></shape>
            <shape type="disk"><transform name="to_world"><translate x="-5"/></transform></shape>
        </scene>"#;
        let scene = crate::scene::xml::load_str(std::path::Path::new("t.xml"), xml, &[])
            .unwrap()
            .scene;
        let bvh = crate::accel::Bvh::build(&scene);
        let at = |origin: Vec3, dir: Vec3| {
            let ray = Ray::new(origin, dir);
            let hit = bvh.intersect(&ray).expect("a hit");
            SurfacePoint::new(&scene, &ray, &hit).dpdu(&scene).normalize()
        };
        let near = |a: Vec3, b: Vec3| (a - b).length() < 1e-3;
        let d = at(Vec3::new(0.3, 0.2, 5.0), Vec3::NEG_Z);
        assert!(near(d, Vec3::Y), "rectangle {d}");
        // The sphere's point (5, -1, 0): round its z axis, (-y, x, 0) = (1, 0, 0).
        let d = at(Vec3::new(5.0, -5.0, 0.0), Vec3::Y);
        assert!(near(d, Vec3::X), "sphere {d}");
        // The disk's point (-5, 0.5, 0): outward, +y.
        let d = at(Vec3::new(-5.0, 0.5, 3.0), Vec3::NEG_Z);
        assert!(near(d, Vec3::Y), "disk {d}");
        // A mesh without (u, v), facing +z.
        let quad = crate::testutil::quad([
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ]);
        assert!(quad.uvs.is_empty());
        let s = crate::testutil::scene(vec![(quad, Vec3::splat(0.5))], Vec::new(), &[]);
        let bvh = crate::accel::Bvh::build(&s);
        let ray = Ray::new(Vec3::new(0.2, 0.1, 1.0), Vec3::NEG_Z);
        let hit = bvh.intersect(&ray).expect("a hit");
        let d = SurfacePoint::new(&s, &ray, &hit).dpdu(&s).normalize();
        assert!(near(d, Vec3::X), "no uv {d}");
    }
}
