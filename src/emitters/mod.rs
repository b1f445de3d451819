//! Light sources prepared for sampling: a light *point* on each source, with the
//! light it sends to a receiving point.
//!
//! A point or spot light is one light point. An area light (or a selected radiant
//! patch) is split into `n` *sub-sources* of equal area (the paper's Sect. 5 and 7: "both
//! area light sources are subdivided into 64 small light sources"): consecutive
//! stretches of a Hilbert curve over the emitter's sampling square, so that each
//! sub-source, and each run of consecutive sub-sources, is a compact piece of the
//! emitter. A patch that asks for fewer rays than there are sub-sources groups them
//! ([`group_bounds`]); each ray goes to a jittered point of its group
//! ([`sub_source_uv`]).

pub mod infinite;

use glam::{Vec2, Vec3};

pub use infinite::{Sky, Sun};

use crate::geometry::{point_polygon_form_factor, Quadric};
use crate::sampling::{cone_direction, sphere_cone, Stratum};
use crate::scene::{mean, Light, Rgb, Scene};

/// A point on a light source as seen from a receiver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// The point on the source.
    pub point: Vec3,
    /// Unit direction from the receiver to the point.
    pub dir: Vec3,
    /// Distance from the receiver to the point.
    pub dist: f32,
    /// Irradiance-like weight: for a point light I / r^2 (with the spot's falloff);
    /// for an area light Le cos(theta_l) A / r^2 (the estimate of one sample with
    /// density 1/A), for an exact sphere seen from outside Le times the solid angle
    /// it fills. Multiply by the BRDF and the receiver's cosine.
    pub value: Rgb,
    /// The source's surface normal at the point, for a surface source (the shadow
    /// ray must stop short of it); `None` for a point or spot light.
    pub normal: Option<Vec3>,
}

/// Most triangles of an area light whose unoccluded light the render sums in closed
/// form ([`AreaEmitter::unoccluded_irradiance`]); a finer one is only sampled.
pub const CLOSED_FORM_TRIANGLES: usize = 16;

/// Triangles of an emitting shape with an area table for uniform sampling.
#[derive(Debug, Clone)]
pub struct AreaEmitter {
    tris: Vec<[Vec3; 3]>,
    normals: Vec<Vec3>,
    /// Cumulative triangle areas, normalised to end at 1.
    cdf: Vec<f32>,
    /// Total area.
    pub area: f32,
    /// Emitted radiance (of a light source: the same everywhere).
    pub radiance: Rgb,
    /// For a radiant patch sampled like a light (paper Sect. 6): the radiance at the
    /// corners of each triangle, interpolated linearly; empty for light sources.
    pub corner_radiance: Vec<[Rgb; 3]>,
    /// When the emitter is one parallelogram (two triangles; every `rectangle`), its
    /// corner and edges: the sampling square maps onto it linearly, so sub-sources are
    /// small parallelograms.
    parallelogram: Option<[Vec3; 3]>,
    /// When the emitter is an exact sphere or disk: sampled on its true surface
    /// ([`Quadric::sample`]), not on its triangles.
    exact: Option<Box<Quadric>>,
    /// When `exact` is a sphere emitting outwards: its centre and radius, which
    /// [`AreaEmitter::visible_sphere`] samples over from outside.
    sphere: Option<(Vec3, f32)>,
}

/// A light source ready for sampling.
#[derive(Debug, Clone)]
pub enum SampledLight {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Intensity (W/sr).
        intensity: Rgb,
    },
    /// Mitsuba-style spot light.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit axis.
        axis: Vec3,
        /// Intensity on the axis (W/sr).
        intensity: Rgb,
        /// Cutoff angle (radians).
        cutoff: f32,
        /// cos(cutoff).
        cos_cutoff: f32,
        /// cos(beam width).
        cos_beam: f32,
        /// 1 / (cutoff - beam width).
        inv_transition: f32,
    },
    /// Area light: a diffuse emitting surface.
    Area(AreaEmitter),
    /// The sun (`directional`).
    Sun(Sun),
    /// The sky (`constant`, `envmap`).
    Sky(Box<Sky>),
}

/// Light leaving a source: see [`SampledLight::emit_towards`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emission {
    /// Where it leaves.
    pub origin: Vec3,
    /// The surface normal there (area lights).
    pub normal: Option<Vec3>,
    /// Unit direction.
    pub dir: Vec3,
    /// Power the choice stands for.
    pub power: Rgb,
}

/// Mitsuba's spot falloff: 1 inside the beam width, falling linearly in angle to 0
/// at the cutoff.
pub fn spot_falloff(cos_theta: f32, cutoff: f32, cos_cutoff: f32, cos_beam: f32, inv_transition: f32) -> f32 {
    if cos_theta <= cos_cutoff {
        0.0
    } else if cos_theta >= cos_beam {
        1.0
    } else {
        (cutoff - cos_theta.clamp(-1.0, 1.0).acos()) * inv_transition
    }
}

impl SampledLight {
    /// Prepares every light of `scene`, in the scene's order.
    pub fn prepare_all(scene: &Scene) -> Vec<SampledLight> {
        (0..scene.lights.len() as u32)
            .map(|l| Self::prepare(scene, l))
            .collect()
    }

    /// Prepares light `l` of `scene`.
    pub fn prepare(scene: &Scene, l: u32) -> SampledLight {
        match scene.lights[l as usize] {
            Light::Point { position, intensity } => SampledLight::Point { position, intensity },
            Light::Spot {
                position,
                direction,
                intensity,
                cutoff_angle,
                beam_width,
            } => {
                let beam = beam_width.min(cutoff_angle);
                let width = cutoff_angle - beam;
                SampledLight::Spot {
                    position,
                    axis: direction.normalize(),
                    intensity,
                    cutoff: cutoff_angle,
                    cos_cutoff: cutoff_angle.cos(),
                    cos_beam: beam.cos(),
                    inv_transition: if width > 0.0 { 1.0 / width } else { f32::INFINITY },
                }
            }
            Light::Area { shape, radiance, .. } => {
                let mesh = &scene.shapes[shape as usize].mesh;
                if let Some(q) = mesh.quadric {
                    return SampledLight::Area(AreaEmitter::exact(q, radiance));
                }
                let tris = (0..mesh.triangle_count()).map(|t| mesh.triangle(t));
                SampledLight::Area(AreaEmitter::new(tris, radiance, Vec::new()))
            }
            Light::Directional {
                direction,
                irradiance,
            } => SampledLight::Sun(Sun::new(scene, l, direction, irradiance)),
            Light::Environment {
                radiance,
                texture,
                to_local,
            } => SampledLight::Sky(Box::new(Sky::new(scene, radiance, texture, to_local))),
        }
    }

    /// The source's unoccluded irradiance at `p` (unit normal `n`) in closed form,
    /// where it has one: see [`AreaEmitter::unoccluded_irradiance`]; `None` for point
    /// and spot lights.
    pub fn unoccluded_irradiance(&self, p: Vec3, n: Vec3) -> Option<Rgb> {
        match self {
            SampledLight::Area(e) => e.unoccluded_irradiance(p, n),
            _ => None,
        }
    }

    /// What a point or spot light brings to a point `x` with unit normal `n`:
    /// irradiance (I x falloff / r^2 x cos; nothing behind the point or outside the
    /// cone) and the light's position, for the shadow ray. The one rule of a light's
    /// unoccluded light at a point, for pass 1's shots and projections and the
    /// selection's falloff test. (For an area light: its light at one point of it.)
    pub fn point_light_at(&self, x: Vec3, n: Vec3) -> Option<(Rgb, Vec3)> {
        let s = self.sample(x, Vec2::ZERO)?;
        let cos = n.dot(s.dir);
        (cos > 0.0).then(|| (s.value * cos, s.point))
    }

    /// The density per steradian, seen from `p`, with which [`SampledLight::sample`]
    /// draws the light point `point` of unit normal `normal` on an area light (by
    /// area, or over the cone an exact sphere fills): what multiple importance
    /// sampling weighs a light sample and a BSDF's ray that meets the light by.
    /// `None` for other lights.
    pub fn density(&self, p: Vec3, point: Vec3, normal: Vec3) -> Option<f32> {
        let SampledLight::Area(e) = self else {
            return None;
        };
        if let Some(cap) = e.visible_sphere(p) {
            return Some(1.0 / cap.solid_angle);
        }
        let d = point - p;
        let cos_l = (d.dot(normal) / d.length()).abs();
        Some(d.length_squared() / (cos_l * e.area).max(1e-12))
    }

    /// Whether this is an area (surface) source.
    /// An area light's area (its light points are drawn uniformly over it).
    pub fn area(&self) -> Option<f32> {
        match self {
            SampledLight::Area(e) => Some(e.area),
            _ => None,
        }
    }

    /// Whether this is an extended source, sampled at many points: an area light or
    /// the sky.
    pub fn is_area(&self) -> bool {
        matches!(self, SampledLight::Area(_) | SampledLight::Sky(_))
    }

    /// The sky, if this is it.
    pub fn sky(&self) -> Option<&Sky> {
        match self {
            SampledLight::Sky(s) => Some(s),
            _ => None,
        }
    }

    /// The light point chosen by `u` in `[0,1)^2` (ignored by point and spot lights)
    /// as seen from `p`. `None` when the source sends no light towards `p` (outside a
    /// spot's cone, behind an area light, or an empty area light).
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            SampledLight::Point { position, intensity } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                (dist > 0.0).then(|| LightSample {
                    point: *position,
                    dir: d / dist,
                    dist,
                    value: *intensity / dist2,
                    normal: None,
                })
            }
            SampledLight::Spot {
                position,
                axis,
                intensity,
                cutoff,
                cos_cutoff,
                cos_beam,
                inv_transition,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if !(dist > 0.0) {
                    return None;
                }
                let dir = d / dist;
                let falloff = spot_falloff(-dir.dot(*axis), *cutoff, *cos_cutoff, *cos_beam, *inv_transition);
                (falloff > 0.0).then(|| LightSample {
                    point: *position,
                    dir,
                    dist,
                    value: *intensity * (falloff / dist2),
                    normal: None,
                })
            }
            SampledLight::Area(e) => e.sample(p, u),
            SampledLight::Sun(s) => Some(s.sample(p, u)),
            SampledLight::Sky(s) => s.sample(p, u),
        }
    }

    /// Light leaving the source in a direction of the caller's choice: the origin is
    /// chosen by `u` (uniform by area on an area light; a point or spot light's
    /// position), then `aim(origin)` gives a unit direction and its probability
    /// density per steradian. The power is what the light sends into that direction
    /// over the density (a point's or spot's intensity there; an area light's radiance
    /// times the cosine times its area): the whole power, on average, for a density
    /// that covers every direction the light sends into. `None` where it sends nothing
    /// (outside a spot's cone, behind an area light) or `aim` gives no direction.
    ///
    /// The sun's light leaves its disk across the scene along its one direction
    /// (`aim` is not asked); the sky's photons are [`Sky::emit_at`]'s (here `None`: they
    /// need a direction and a place on the disk, four numbers).
    pub fn emit_towards(&self, u: Vec2, aim: impl FnOnce(Vec3) -> Option<(Vec3, f32)>) -> Option<Emission> {
        let (origin, normal, value) = match self {
            SampledLight::Sun(s) => return Some(s.emit(u)),
            SampledLight::Sky(_) => return None,
            SampledLight::Point { position, intensity } => (*position, None, *intensity),
            SampledLight::Spot {
                position, intensity, ..
            } => (*position, None, *intensity),
            SampledLight::Area(e) => {
                let (origin, n, radiance) = e.point(u)?;
                (origin, Some(n), radiance * e.area)
            }
        };
        let (dir, pdf) = aim(origin)?;
        let scale = match self {
            SampledLight::Point { .. } => 1.0,
            SampledLight::Spot {
                axis,
                cutoff,
                cos_cutoff,
                cos_beam,
                inv_transition,
                ..
            } => spot_falloff(dir.dot(*axis), *cutoff, *cos_cutoff, *cos_beam, *inv_transition),
            SampledLight::Area(_) => normal.map_or(0.0, |n| n.dot(dir)),
            SampledLight::Sun(_) | SampledLight::Sky(_) => 0.0,
        };
        (scale > 0.0 && pdf > 0.0).then(|| Emission {
            origin,
            normal,
            dir,
            power: value * (scale / pdf),
        })
    }
}

impl AreaEmitter {
    /// The unoccluded irradiance at `p` (unit normal `n`) in closed form: pi times
    /// the radiance times Lambert's point-to-polygon form factor of each triangle that
    /// `p` sees the front of (of the parallelogram, when the emitter is one), each
    /// clipped to the hemisphere above `p`; an exact sphere's cap seen from outside,
    /// clipped alike. For emitters of one radiance made of at most
    /// [`CLOSED_FORM_TRIANGLES`] triangles, or exact spheres; `None` for others (exact
    /// disks, a point inside a sphere, radiant patches, whose radiance varies, and
    /// finely tessellated lights).
    pub fn unoccluded_irradiance(&self, p: Vec3, n: Vec3) -> Option<Rgb> {
        if let Some(e) = self.sphere_irradiance(p, n) {
            return Some(e);
        }
        if self.exact.is_some()
            || !self.corner_radiance.is_empty()
            || self.tris.is_empty()
            || self.tris.len() > CLOSED_FORM_TRIANGLES
        {
            return None;
        }
        let f = match self.parallelogram {
            Some([o, e1, e2]) => {
                if self.normals[0].dot(p - o) > 0.0 {
                    point_polygon_form_factor(p, n, &[o, o + e1, o + e1 + e2, o + e2])
                } else {
                    0.0
                }
            }
            None => self
                .tris
                .iter()
                .zip(&self.normals)
                .filter(|(t, m)| m.dot(p - t[0]) > 0.0)
                .map(|(t, _)| point_polygon_form_factor(p, n, t))
                .sum(),
        };
        Some(self.radiance * (std::f32::consts::PI * f))
    }

    /// An emitter over `tris` (emitting on the side their winding faces) with
    /// radiance `radiance`, or, when `corner_radiance` is not empty, the radiance
    /// given at each triangle's corners. Zero-area triangles are dropped.
    pub fn new(
        tris: impl IntoIterator<Item = [Vec3; 3]>,
        radiance: Rgb,
        corner_radiance: Vec<[Rgb; 3]>,
    ) -> Self {
        let mut kept = Vec::new();
        let mut normals = Vec::new();
        let mut cdf = Vec::new();
        let mut corners = Vec::new();
        let mut total = 0.0;
        for (k, [a, b, c]) in tris.into_iter().enumerate() {
            let n = (b - a).cross(c - a);
            let area = 0.5 * n.length();
            if !(area > 0.0) {
                continue;
            }
            total += area;
            kept.push([a, b, c]);
            normals.push(n.normalize());
            cdf.push(total);
            if let Some(cr) = corner_radiance.get(k) {
                corners.push(*cr);
            }
        }
        for c in &mut cdf {
            *c /= total;
        }
        let parallelogram = if corners.is_empty() {
            parallelogram(&kept)
        } else {
            None
        };
        AreaEmitter {
            tris: kept,
            normals,
            cdf,
            area: total,
            radiance,
            corner_radiance: corners,
            parallelogram,
            exact: None,
            sphere: None,
        }
    }

    /// An emitter of radiance `radiance` over the exact surface `q` (on its front).
    pub fn exact(q: Quadric, radiance: Rgb) -> Self {
        let sphere = if q.flipped { None } else { q.sphere() };
        AreaEmitter {
            tris: Vec::new(),
            normals: Vec::new(),
            cdf: Vec::new(),
            area: q.area(),
            radiance,
            corner_radiance: Vec::new(),
            parallelogram: None,
            exact: Some(Box::new(q)),
            sphere,
        }
    }

    /// Uniform sample of the surface by area, mapped from `u` so that stratified `u`
    /// gives well-spread points. An exact sphere seen from outside is sampled
    /// uniformly over the cone of directions it fills instead (pbrt's and Mitsuba's
    /// rule): by area, half its points lay on its far side, hidden, and the
    /// rest far from uniform in the solid angle, so one or a few rays per hit (what
    /// the selection gives a small source far off) lit a floor in grains.
    fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        if let Some(s) = self.visible_sphere(p) {
            return s.sample(p, u, self.radiance);
        }
        let (point, normal, radiance) = self.point(u)?;
        self.light_sample(p, point, normal, radiance)
    }

    /// The unoccluded irradiance at `p` (unit normal `n`) of this emitter if it is an
    /// exact sphere of one radiance emitting outwards and `p` is outside it: its cap
    /// above the horizon in closed form ([`SphereCap::irradiance`]).
    pub fn sphere_irradiance(&self, p: Vec3, n: Vec3) -> Option<Rgb> {
        if !self.is_sphere() {
            return None;
        }
        Some(self.radiance * self.visible_sphere(p)?.irradiance(n))
    }

    /// Whether this emitter is an exact sphere of one radiance emitting outwards.
    pub fn is_sphere(&self) -> bool {
        self.sphere.is_some() && self.corner_radiance.is_empty()
    }

    /// The sphere (emitting outwards) this emitter is, if `p` is outside it.
    fn visible_sphere(&self, p: Vec3) -> Option<SphereCap> {
        let (centre, radius) = self.sphere?;
        let (axis, solid_angle) = sphere_cone(p, centre, radius)?;
        Some(SphereCap {
            centre,
            radius,
            axis,
            solid_angle,
        })
    }

    /// The surface point `u` maps to (uniform by area): the point, the unit normal
    /// there and the radiance there.
    fn point(&self, u: Vec2) -> Option<(Vec3, Vec3, Rgb)> {
        if let Some(q) = &self.exact {
            let (p, n) = q.sample(u);
            return Some((p, n, self.radiance));
        }
        if self.tris.is_empty() {
            return None;
        }
        if let Some([o, e1, e2]) = self.parallelogram {
            return Some((o + e1 * u.x + e2 * u.y, self.normals[0], self.radiance));
        }
        let i = self.cdf.partition_point(|&c| c <= u.x).min(self.tris.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let hi = self.cdf[i];
        let ux = if hi > lo {
            ((u.x - lo) / (hi - lo)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let s = ux.sqrt();
        let (b1, b2) = (s * (1.0 - u.y), s * u.y);
        let [a, b, c] = self.tris[i];
        let point = a + (b - a) * b1 + (c - a) * b2;
        let radiance = match self.corner_radiance.get(i) {
            Some([ra, rb, rc]) => *ra * (1.0 - b1 - b2) + *rb * b1 + *rc * b2,
            None => self.radiance,
        };
        Some((point, self.normals[i], radiance))
    }

    /// The sample at `point`, of unit normal `normal`, with `radiance`, seen from `p`.
    fn light_sample(&self, p: Vec3, point: Vec3, normal: Vec3, radiance: Rgb) -> Option<LightSample> {
        let d = point - p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if !(dist > 0.0) {
            return None;
        }
        let dir = d / dist;
        let cos_l = -dir.dot(normal);
        if !(cos_l > 0.0) {
            return None;
        }
        Some(LightSample {
            point,
            dir,
            dist,
            value: radiance * (cos_l * self.area / dist2),
            normal: Some(normal),
        })
    }
}

/// The cone of directions from a point outside a sphere that the sphere fills.
struct SphereCap {
    centre: Vec3,
    radius: f32,
    /// Unit direction to the centre.
    axis: Vec3,
    solid_angle: f32,
}

impl SphereCap {
    /// The point of the sphere seen from `p` along the direction `u` picks uniformly
    /// in the cone; its value is the radiance times the cone's solid angle (the
    /// inverse of the direction's density).
    fn sample(&self, p: Vec3, u: Vec2, radiance: Rgb) -> Option<LightSample> {
        let dir = cone_direction(self.axis, self.solid_angle, u);
        // The nearer crossing of the sphere (a grazing direction: where it touches).
        let oc = p - self.centre;
        let b = oc.dot(dir);
        let disc = (b * b - (oc.length_squared() - self.radius * self.radius)).max(0.0);
        let dist = -b - disc.sqrt();
        if !(dist > 0.0) {
            return None;
        }
        let point = p + dir * dist;
        Some(LightSample {
            point,
            dir,
            dist,
            value: radiance * self.solid_angle,
            normal: Some((point - self.centre) / self.radius),
        })
    }

    /// A sphere of unit radiance's irradiance at a surface of unit normal `n`: pi
    /// sin^2(alpha) cos(theta) where it lies wholly above the surface's horizon (alpha
    /// the cone's half angle, theta the angle to its axis; Lambert), 0 where wholly
    /// below, and where the horizon cuts it, the cut cap's closed form (Snyder 1996,
    /// "Area light sources for real-time graphics"): with x = cot(alpha) and
    /// y = -x cot(theta), sin^2(alpha) (cos(theta) acos(y) - x sin(theta) sqrt(1 - y^2))
    /// + atan(sin(theta) sqrt(1 - y^2) / x).
    fn irradiance(&self, n: Vec3) -> f32 {
        let cos_t = n.dot(self.axis).clamp(-1.0, 1.0);
        let one_minus_cos_a = self.solid_angle / (2.0 * std::f32::consts::PI);
        let cos_a = 1.0 - one_minus_cos_a;
        let sin2_a = (one_minus_cos_a * (2.0 - one_minus_cos_a)).max(0.0);
        let sin_a = sin2_a.sqrt();
        // Wholly above: theta <= pi/2 - alpha, i.e. cos(theta) >= sin(alpha).
        if cos_t >= sin_a {
            std::f32::consts::PI * sin2_a * cos_t
        } else if cos_t <= -sin_a {
            0.0
        } else {
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let x = cos_a / sin_a.max(1e-12);
            let y = (-x * cos_t / sin_t.max(1e-12)).clamp(-1.0, 1.0);
            let w = sin_t * (1.0 - y * y).max(0.0).sqrt();
            let e = sin2_a * (cos_t * y.acos() - x * w) + (w / x.max(1e-12)).atan();
            e.max(0.0)
        }
    }
}

/// The corner and edges of the parallelogram two triangles form, if they do: they
/// share an edge, and the corners off it are symmetric about its midpoint.
fn parallelogram(tris: &[[Vec3; 3]]) -> Option<[Vec3; 3]> {
    let [t, u] = tris else { return None };
    // Rotate t so that its corners 1 and 2 are the shared edge.
    for k in 0..3 {
        let (a, s0, s1) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        let shared = |x: Vec3| u.contains(&x);
        if !(shared(s0) && shared(s1)) {
            continue;
        }
        let d = *u.iter().find(|&&y| y != s0 && y != s1)?;
        let scale = (s1 - s0).length() + (d - a).length();
        if ((a + d) - (s0 + s1)).length() > 1e-5 * scale {
            return None;
        }
        return Some([a, s0 - a, s1 - a]);
    }
    None
}

/// Group `g` of `r` of an emitter's `n` sub-sources ([`group_bounds`]) and a point of
/// it on the sampling square, jittered by the draws of `seed` at `g`
/// ([`sub_source_uv`]; a point, spot or directional light takes no point). The one
/// rule by which pass 2 places its shadow rays on a light. A single sub-source is
/// the whole square, jittered too: it was the square's corner, so that one light
/// sample at a glossy hit seen through a mirror or a lobe (or every shadow ray with
/// `--area-samples 1`) took an area light's corner every time.
pub fn group_point(g: u32, r: u32, n: u32, seed: u32) -> (u32, u32, Vec2) {
    group_point_in(g, r, n, seed, Stratum::WHOLE)
}

/// [`group_point`] for sample `stratum` of several that share the group's light
/// points: the point lies in the `stratum`'s stretch of the group's run of the curve.
pub fn group_point_in(g: u32, r: u32, n: u32, seed: u32, stratum: Stratum) -> (u32, u32, Vec2) {
    let n = n.max(1);
    let (a, b) = group_bounds(g, r, n);
    let mut xi = crate::sampling::uniform3(seed, g);
    xi[0] = stratum.stretch(xi[0], g);
    (a, b, sub_source_uv(a, b, n, xi))
}

/// Sub-sources `[g n / r, (g+1) n / r)` of `n`: group `g` of `r`. Groups are runs of
/// consecutive sub-sources, as equal as whole sub-sources allow; `r` is at most `n`.
pub fn group_bounds(g: u32, r: u32, n: u32) -> (u32, u32) {
    let r = r.clamp(1, n.max(1)) as u64;
    let n = n as u64;
    ((g as u64 * n / r) as u32, ((g as u64 + 1) * n / r) as u32)
}

/// A point, uniform over sub-sources `[start, end)` of `n`, of the emitter's sampling
/// square: `xi[0]` picks the place along the Hilbert curve, `xi[1..]` jitters within
/// the curve's finest cell (four levels finer than the sub-sources). The curve's stretch `[k/n, (k+1)/n)` is sub-source k; the
/// curve is measure preserving, so sub-sources have equal area.
pub fn sub_source_uv(start: u32, end: u32, n: u32, xi: [f32; 3]) -> Vec2 {
    // Four levels of the curve below the sub-sources' own: a group's ends fall inside
    // a finest cell at most 1/256 of a sub-source wide.
    let order = (n.max(1).next_power_of_two().trailing_zeros().div_ceil(2) + 4).min(16);
    let t = (start as f64 + xi[0] as f64 * (end - start) as f64) / n.max(1) as f64;
    let cells = 1u64 << (2 * order);
    let d = ((t * cells as f64) as u64).min(cells - 1);
    let (x, y) = hilbert_d2xy(order, d);
    let side = (1u32 << order) as f32;
    Vec2::new(
        ((x as f32 + xi[1]) / side).min(1.0 - f32::EPSILON),
        ((y as f32 + xi[2]) / side).min(1.0 - f32::EPSILON),
    )
}

/// One step of the Hilbert curve from its top level down: entry `state << 2 | q` for
/// the quadrant digit `q` (two bits of the curve's index) gives the cell's x bit (bit
/// 0), its y bit (bit 1) and the next state (bits 2-3). A state is how the levels
/// above turned the square: bit 0 swaps x and y, bit 1 mirrors both; a digit whose
/// y bit is 0 turns the rest (swap, and mirror too where its x bit is 1), and turns
/// compose by xor (swapping and mirroring both commute).
const HILBERT_STEP: [u8; 16] = {
    let mut t = [0u8; 16];
    let mut state = 0;
    while state < 4 {
        let mut q = 0;
        while q < 4 {
            let rx = (q >> 1) & 1;
            let ry = (q ^ rx) & 1;
            let (mut a, mut b) = if state & 1 == 1 { (ry, rx) } else { (rx, ry) };
            if state & 2 == 2 {
                a ^= 1;
                b ^= 1;
            }
            let turn = if ry == 0 { 1 | rx << 1 } else { 0 };
            t[state << 2 | q] = (a | b << 1 | (state ^ turn) << 2) as u8;
            q += 1;
        }
        state += 1;
    }
    t
};

/// Two steps of [`HILBERT_STEP`] at once: entry `state << 4 | qq` for the digits `qq`
/// (four bits, the upper level's first) gives x's two bits (bits 0-1), y's (bits 2-3)
/// and the state after both (bits 4-5).
const HILBERT_STEP2: [u8; 64] = {
    let mut t = [0u8; 64];
    let mut i = 0;
    while i < 64 {
        let (state, qq) = (i >> 4, i & 15);
        let e1 = HILBERT_STEP[state << 2 | qq >> 2];
        let e2 = HILBERT_STEP[(e1 >> 2) as usize * 4 + (qq & 3)];
        let x = (e1 & 1) << 1 | (e2 & 1);
        let y = (e1 >> 1 & 1) << 1 | (e2 >> 1 & 1);
        t[i] = x | y << 2 | (e2 >> 2) << 4;
        i += 1;
    }
    t
};

/// Cell `(x, y)` visited `d`-th by the Hilbert curve over a `2^order` square grid
/// (the curve of Wikipedia's `d2xy`, walked from the top level down by tables, two
/// levels a step: the area lights' sub-source points take one per shadow-ray
/// candidate, and the arithmetic walk was a seventh of the Cornell box's render).
pub fn hilbert_d2xy(order: u32, d: u64) -> (u32, u32) {
    let (mut x, mut y, mut state) = (0u32, 0u32, 0usize);
    let mut level = order;
    if level % 2 == 1 {
        level -= 1;
        let e = HILBERT_STEP[((d >> (2 * level)) & 3) as usize];
        (x, y, state) = (u32::from(e & 1), u32::from(e >> 1 & 1), usize::from(e >> 2));
    }
    while level > 0 {
        level -= 2;
        let e = HILBERT_STEP2[state << 4 | ((d >> (2 * level)) & 15) as usize];
        x = x << 2 | u32::from(e & 3);
        y = y << 2 | u32::from(e >> 2 & 3);
        state = usize::from(e >> 4);
    }
    (x, y)
}

/// Radiant power of a light (mean over RGB), in closed form.
pub fn light_power(scene: &Scene, light: &Light) -> f64 {
    match *light {
        Light::Point { intensity, .. } => 4.0 * std::f64::consts::PI * mean(intensity) as f64,
        Light::Spot {
            intensity,
            cutoff_angle,
            beam_width,
            ..
        } => {
            // I times the integral of Mitsuba's falloff (1 inside the beam width b,
            // falling linearly in angle to 0 at the cutoff c) over the sphere:
            // 2 pi (1 - (sin c - sin b) / (c - b)), or 2 pi (1 - cos c) when b = c.
            let b = beam_width.min(cutoff_angle) as f64;
            let c = cutoff_angle as f64;
            let solid = if c - b > 1e-9 {
                1.0 - (c.sin() - b.sin()) / (c - b)
            } else {
                1.0 - c.cos()
            };
            2.0 * std::f64::consts::PI * solid * mean(intensity) as f64
        }
        Light::Area { shape, radiance, .. } => {
            std::f64::consts::PI * mean(radiance) as f64 * scene.shapes[shape as usize].mesh.area() as f64
        }
        Light::Directional { .. } | Light::Environment { .. } => infinite::power(scene, light),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spot's power in closed form against a fine numerical integral of its falloff
    /// over the sphere, and the limits: a hard-edged cone and a full sphere.
    #[test]
    fn spot_power_is_the_integral_of_its_falloff() {
        use crate::testutil::scene;
        let s = scene(vec![], vec![], &[]);
        let spot = |cutoff: f32, beam: f32| Light::Spot {
            position: Vec3::ZERO,
            direction: Vec3::Z,
            intensity: Vec3::splat(2.0),
            cutoff_angle: cutoff,
            beam_width: beam,
        };
        for (c, b) in [(0.5f64, 0.3f64), (1.2, 0.1), (0.3, 0.3), (3.0, 2.0)] {
            let n = 200_000;
            let mut sum = 0.0;
            for k in 0..n {
                let th = (k as f64 + 0.5) / n as f64 * c;
                let f = if th <= b { 1.0 } else { (c - th) / (c - b) };
                sum += f * th.sin() * c / n as f64;
            }
            let want = 2.0 * std::f64::consts::PI * sum * 2.0;
            let got = light_power(&s, &spot(c as f32, b as f32));
            assert!((got - want).abs() < 1e-5 * want, "c {c} b {b}: {got} vs {want}");
        }
        let cone = light_power(&s, &spot(0.4, 0.4));
        assert!((cone - 4.0 * std::f64::consts::PI * (1.0 - 0.4f64.cos())).abs() < 1e-6);
        let point = light_power(
            &s,
            &Light::Point {
                position: Vec3::ZERO,
                intensity: Vec3::splat(2.0),
            },
        );
        assert!((point - 8.0 * std::f64::consts::PI).abs() < 1e-9);
    }

    #[test]
    fn hilbert_curve_visits_every_cell_once_in_adjacent_steps() {
        for order in 1..=6u32 {
            let side = 1usize << order;
            let mut seen = vec![false; side * side];
            let mut last = None;
            for d in 0..(side * side) as u64 {
                let (x, y) = hilbert_d2xy(order, d);
                assert!(!seen[x as usize * side + y as usize], "order {order}, d {d}");
                seen[x as usize * side + y as usize] = true;
                if let Some((lx, ly)) = last {
                    let step = (x as i32 - lx as i32).abs() + (y as i32 - ly as i32).abs();
                    assert_eq!(step, 1, "order {order}, step {d}");
                }
                last = Some((x, y));
            }
            // From one corner to the next along x.
            assert_eq!(hilbert_d2xy(order, 0), (0, 0));
            assert_eq!(last, Some((side as u32 - 1, 0)), "order {order}");
        }
    }

    /// The table walk is Wikipedia's `d2xy` (the curve the sub-sources have always
    /// followed, so images do not change), written out here the arithmetic way.
    #[test]
    fn hilbert_table_walk_is_the_textbook_curve() {
        fn d2xy(order: u32, d: u64) -> (u32, u32) {
            let (mut x, mut y, mut t, mut s) = (0u32, 0u32, d, 1u32);
            while s < (1u32 << order) {
                let rx = (1 & (t / 2)) as u32;
                let ry = (1 & (t ^ rx as u64)) as u32;
                if ry == 0 {
                    if rx == 1 {
                        x = s - 1 - x;
                        y = s - 1 - y;
                    }
                    std::mem::swap(&mut x, &mut y);
                }
                x += s * rx;
                y += s * ry;
                t /= 4;
                s *= 2;
            }
            (x, y)
        }
        for order in 0..=8u32 {
            for d in 0..1u64 << (2 * order) {
                assert_eq!(hilbert_d2xy(order, d), d2xy(order, d), "order {order}, d {d}");
            }
        }
        for d in [0, 1, 12345, 1 << 31, (1u64 << 32) - 1] {
            assert_eq!(hilbert_d2xy(16, d), d2xy(16, d), "order 16, d {d}");
        }
    }

    #[test]
    fn sub_sources_are_cells_and_groups_are_compact_blocks() {
        // 64 sub-sources are the cells of an 8 x 8 grid.
        let mut cells = std::collections::BTreeSet::new();
        for k in 0..64 {
            let lo = sub_source_uv(k, k + 1, 64, [0.0, 0.0, 0.0]);
            let hi = sub_source_uv(k, k + 1, 64, [0.999_99, 0.999, 0.999]);
            let c = ((lo.x * 8.0) as u32, (lo.y * 8.0) as u32);
            assert_eq!(c, ((hi.x * 8.0) as u32, (hi.y * 8.0) as u32), "{k}");
            cells.insert(c);
        }
        assert_eq!(cells.len(), 64);
        // 16 groups of 64: each group is a 2 x 2 block of cells (a quarter of a side).
        for g in 0..16 {
            let (a, b) = group_bounds(g, 16, 64);
            assert_eq!(b - a, 4);
            let (mut lo, mut hi) = (Vec2::splat(1.0), Vec2::ZERO);
            for i in 0..200 {
                let f = i as f32 / 200.0;
                let uv = sub_source_uv(a, b, 64, [f, 0.5, 0.5]);
                lo = lo.min(uv);
                hi = hi.max(uv);
            }
            assert!((hi - lo).max_element() <= 0.25, "group {g}: {lo:?}..{hi:?}");
        }
        // Groups partition the sub-sources whatever r.
        for r in [1, 3, 7, 37, 64] {
            let mut next = 0;
            for g in 0..r {
                let (a, b) = group_bounds(g, r, 64);
                assert_eq!(a, next);
                assert!(b > a);
                next = b;
            }
            assert_eq!(next, 64);
        }
    }

    #[test]
    fn samples_in_strata_take_each_stretch_of_a_group_once() {
        // 64 sub-sources in 4 groups of 16 (a 4 x 4 block of an 8 x 8 grid each);
        // `count` samples of one pixel, one point per group each, in strata: in every
        // group the i-th point along the curve lies in the i-th stretch of `count`
        // (sub-sources 16 i / count ..< 16 (i + 1) / count), whatever the seeds; with
        // 16 samples, one point in each of its cells.
        let cell = |uv: Vec2| ((uv.x * 8.0) as u32, (uv.y * 8.0) as u32);
        let sub_source: std::collections::BTreeMap<_, _> = (0..64)
            .map(|k| (cell(sub_source_uv(k, k + 1, 64, [0.5; 3])), k))
            .collect();
        for count in [16, 12, 5] {
            for g in 0..4 {
                let mut found: Vec<u32> = (0..count)
                    .map(|index| {
                        let seed = crate::sampling::derive(index * 7919 + 13, crate::sampling::Stream::Path);
                        let (a, b, uv) = group_point_in(g, 4, 64, seed, Stratum { index, count });
                        assert_eq!((a, b), (16 * g, 16 * g + 16));
                        sub_source[&cell(uv)] - a
                    })
                    .collect();
                found.sort();
                for (i, j) in found.into_iter().enumerate() {
                    let (lo, hi) = (16 * i as u32 / count, (16 * (i as u32 + 1)).div_ceil(count));
                    assert!(
                        (lo..hi).contains(&j),
                        "count {count}, group {g}: point {i} in {j}"
                    );
                }
            }
        }
        // Without strata, 16 points of 16 cells meet twice in a cell somewhere.
        let clash = (0..4).any(|g| {
            let mut cells = std::collections::BTreeSet::new();
            (0..16).any(|i| !cells.insert(cell(group_point(g, 4, 64, i * 7919 + 13).2)))
        });
        assert!(clash);
    }

    #[test]
    fn a_rectangle_light_is_sampled_as_a_parallelogram() {
        let a = Vec3::new(0.0, 0.0, 1.0);
        let (x, y) = (Vec3::X * 2.0, Vec3::Y);
        // Mitsuba's rectangle winding [0,1,2], [0,2,3], facing down.
        let tris = vec![[a, a + y, a + x + y], [a, a + x + y, a + x]];
        let e = AreaEmitter::new(tris, Vec3::ONE, Vec::new());
        assert!(e.parallelogram.is_some());
        let below = Vec3::new(1.0, 0.5, 0.0);
        let s = e.sample(below, Vec2::new(0.25, 0.75)).unwrap();
        let [o, e1, e2] = e.parallelogram.unwrap();
        assert!((s.point - (o + e1 * 0.25 + e2 * 0.75)).length() < 1e-6);
        // The corners of the unit square reach the four corners.
        let mut corners: Vec<Vec3> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(u, v)| o + e1 * u + e2 * v)
            .collect();
        corners.sort_by(|p, q| (p.x, p.y).partial_cmp(&(q.x, q.y)).unwrap());
        assert_eq!(corners, vec![a, a + y, a + x, a + x + y]);
        // A triangle pair that is not a parallelogram keeps the triangle sampling.
        let kite = vec![[a, a + y, a + x + y], [a, a + x + y, a + x * 0.5]];
        assert!(AreaEmitter::new(kite, Vec3::ONE, Vec::new())
            .parallelogram
            .is_none());
    }

    #[test]
    fn spot_falloff_matches_mitsuba() {
        let (cut, beam) = (30f32.to_radians(), 20f32.to_radians());
        let f = |deg: f32| {
            spot_falloff(
                deg.to_radians().cos(),
                cut,
                cut.cos(),
                beam.cos(),
                1.0 / (cut - beam),
            )
        };
        assert_eq!(f(0.0), 1.0);
        assert_eq!(f(19.9), 1.0);
        assert!((f(25.0) - 0.5).abs() < 1e-4);
        assert!((f(27.5) - 0.25).abs() < 1e-4);
        assert_eq!(f(30.5), 0.0);
        assert_eq!(f(120.0), 0.0);
    }

    /// Irradiance at `p` (normal `n`) from `e` by a stratified `k x k` estimate.
    fn irradiance(e: &SampledLight, p: Vec3, n: Vec3, k: u32) -> f32 {
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let u = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                if let Some(s) = e.sample(p, u) {
                    sum += s.value.x * s.dir.dot(n).max(0.0);
                }
            }
        }
        sum / (k * k) as f32
    }

    #[test]
    fn exact_sphere_and_disk_lights_give_the_closed_form_irradiance() {
        use crate::geometry::shapes;
        // A sphere light of radius R and radiance L seen face on from distance d:
        // E = pi L (R / d)^2.
        let (c, r) = (Vec3::new(0.0, 3.0, 0.0), 0.5);
        let q = shapes::sphere(c, r).quadric.unwrap();
        let e = SampledLight::Area(AreaEmitter::exact(q, Vec3::ONE));
        let want = std::f32::consts::PI * (r / 3.0) * (r / 3.0);
        let got = irradiance(&e, Vec3::ZERO, Vec3::Y, 256);
        assert!((got / want - 1.0).abs() < 0.01, "sphere: {got} vs {want}");
        // A disk of radius a at height h, parallel, straight below its centre:
        // E = pi L a^2 / (a^2 + h^2); and off axis at distance x (Sparrow):
        // E = pi L / 2 (1 - (h^2 + x^2 - a^2) / sqrt((h^2 + x^2 + a^2)^2 - 4 a^2 x^2)).
        let (a, h) = (0.5f32, 1.0f32);
        let mut m = shapes::disk();
        m.transform(
            &(glam::Mat4::from_translation(Vec3::new(0.0, 0.0, h))
                * glam::Mat4::from_rotation_x(std::f32::consts::PI)
                * glam::Mat4::from_scale(Vec3::splat(a))),
        );
        let e = SampledLight::Area(AreaEmitter::exact(m.quadric.unwrap(), Vec3::ONE));
        let pi = std::f32::consts::PI;
        for x in [0.0f32, 0.4, 1.5] {
            let (s, t) = (h * h + x * x, 4.0 * a * a * x * x);
            let want = 0.5 * pi * (1.0 - (s - a * a) / ((s + a * a) * (s + a * a) - t).sqrt());
            let got = irradiance(&e, Vec3::new(x, 0.0, 0.0), Vec3::Z, 128);
            assert!((got / want - 1.0).abs() < 0.01, "disk at {x}: {got} vs {want}");
        }
        // Its back sends nothing.
        assert_eq!(irradiance(&e, Vec3::new(0.0, 0.0, 2.0), Vec3::NEG_Z, 8), 0.0);
    }

    /// The closed form equals the sampled irradiance (a 256 x 256 midpoint rule) for
    /// a rectangle and for a light of two triangles that are no parallelogram, seen
    /// straight on, askew and across the receiver's plane (clipped); behind the light
    /// it is zero; exact quadrics, radiant patches and finely tessellated lights have
    /// none.
    #[test]
    fn closed_form_irradiance_is_the_integral_of_the_samples() {
        let a = Vec3::new(0.0, 0.0, 1.0);
        let (x, y) = (Vec3::X * 2.0, Vec3::Y);
        let rect = vec![[a, a + y, a + x + y], [a, a + x + y, a + x]];
        let kite = vec![[a, a + y, a + x + y], [a, a + x + y, a + x * 0.5]];
        for tris in [rect, kite] {
            let e = AreaEmitter::new(tris.clone(), Vec3::splat(2.0), Vec::new());
            let light = SampledLight::Area(e.clone());
            for (p, n) in [
                (Vec3::new(1.0, 0.5, 0.0), Vec3::Z),
                (Vec3::new(-0.5, 2.0, 0.2), Vec3::new(0.6, -0.3, 0.74).normalize()),
                // The receiver's plane cuts the light: only the part above counts.
                (Vec3::new(1.0, 0.5, 0.5), Vec3::new(1.0, 0.0, 0.2).normalize()),
            ] {
                let want = irradiance(&light, p, n, 256);
                let got = light.unoccluded_irradiance(p, n).expect("a closed form").x;
                assert!(
                    want > 0.01 && (got / want - 1.0).abs() < 2e-3,
                    "{got} vs {want} at {p:?}"
                );
            }
            let behind = light.unoccluded_irradiance(Vec3::new(1.0, 0.5, 2.0), Vec3::NEG_Z);
            assert_eq!(behind, Some(Vec3::ZERO));
            let radiant = AreaEmitter::new(
                tris.clone(),
                Vec3::ZERO,
                tris.iter().map(|_| [Vec3::ONE; 3]).collect(),
            );
            assert_eq!(radiant.unoccluded_irradiance(Vec3::ZERO, Vec3::Z), None);
        }
        let fine: Vec<[Vec3; 3]> = (0..=CLOSED_FORM_TRIANGLES)
            .map(|i| {
                let o = a + Vec3::X * i as f32;
                [o, o + Vec3::Y, o + Vec3::X]
            })
            .collect();
        assert_eq!(
            AreaEmitter::new(fine, Vec3::ONE, Vec::new()).unoccluded_irradiance(Vec3::ZERO, Vec3::Z),
            None
        );
        let q = crate::geometry::shapes::sphere(Vec3::Y * 3.0, 0.5)
            .quadric
            .unwrap();
        // A sphere of radius R at distance d wholly above the horizon: pi (R/d)^2
        // cos(theta) (Lambert); below it: 0; cut by the horizon: the cut cap's
        // closed form, against a quadrature of the cosine over the cap's directions.
        let sphere = AreaEmitter::exact(q, Vec3::ONE);
        let e = sphere.unoccluded_irradiance(Vec3::ZERO, Vec3::Y).unwrap().x;
        let want = std::f32::consts::PI * (0.5f32 / 3.0).powi(2);
        assert!((e / want - 1.0).abs() < 1e-4, "{e} vs {want}");
        let tilted = Vec3::new(0.6, 0.8, 0.0);
        let e = sphere.unoccluded_irradiance(Vec3::ZERO, tilted).unwrap().x;
        assert!((e / (want * 0.8) - 1.0).abs() < 1e-4, "{e}");
        let (axis, omega) = crate::sampling::sphere_cone(Vec3::ZERO, Vec3::Y * 3.0, 0.5).unwrap();
        let (m, k) = (2048, 512);
        for angle in [75.0f32, 85.0, 90.0, 95.0, 99.0] {
            let t = angle.to_radians();
            let n = Vec3::new(t.sin(), t.cos(), 0.0);
            let mut sum = 0.0f64;
            for i in 0..m {
                for j in 0..k {
                    let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / k as f32);
                    sum += f64::from(crate::sampling::cone_direction(axis, omega, u).dot(n).max(0.0));
                }
            }
            let want = (sum / f64::from(m * k) * f64::from(omega)) as f32;
            let e = sphere.unoccluded_irradiance(Vec3::ZERO, n).unwrap().x;
            assert!(
                (e - want).abs() < 1e-3 * std::f32::consts::PI * (0.5f32 / 3.0).powi(2),
                "{angle}: {e} vs {want}"
            );
        }
        assert_eq!(
            sphere.unoccluded_irradiance(Vec3::ZERO, -Vec3::Y),
            Some(Vec3::ZERO)
        );
        // Every sample of it seen from outside lands on its near side (its normal
        // towards the point), carrying L times the cone's solid angle.
        let omega = crate::sampling::sphere_cone(Vec3::ZERO, Vec3::Y * 3.0, 0.5)
            .unwrap()
            .1;
        for k in 0..64 {
            let u = Vec2::new((k % 8) as f32 / 8.0 + 0.06, (k / 8) as f32 / 8.0 + 0.06);
            let s = sphere.sample(Vec3::ZERO, u).unwrap();
            assert!(s.normal.unwrap().dot(-s.dir) > 0.0);
            assert!(((s.point - Vec3::Y * 3.0).length() - 0.5).abs() < 1e-4);
            assert!((s.value.x - omega).abs() < 1e-6);
        }
        // What multiple importance sampling weighs its samples by: 1 / Omega per
        // steradian (not the area rule's r^2 / (cos A)).
        let light = SampledLight::Area(sphere);
        let s = light.sample(Vec3::ZERO, Vec2::new(0.3, 0.7)).unwrap();
        let p = light.density(Vec3::ZERO, s.point, s.normal.unwrap()).unwrap();
        assert!((p * omega - 1.0).abs() < 1e-5, "{p} vs {}", 1.0 / omega);
    }

    #[test]
    fn point_light_is_inverse_square() {
        let l = SampledLight::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Vec3::splat(8.0),
        };
        let s = l.sample(Vec3::ZERO, Vec2::ZERO).unwrap();
        assert_eq!(s.value, Vec3::splat(2.0));
        assert_eq!(s.dir, Vec3::Z);
        assert_eq!(s.dist, 2.0);
    }

    #[test]
    fn area_light_samples_are_uniform_and_one_sided() {
        // A unit square at z = 1 facing down (-z), radiance 1.
        let a = Vec3::new(0.0, 0.0, 1.0);
        let tris = vec![
            [a, a + Vec3::Y, a + Vec3::X + Vec3::Y],
            [a, a + Vec3::X + Vec3::Y, a + Vec3::X],
        ];
        let e = AreaEmitter::new(tris.clone(), Vec3::ONE, Vec::new());
        assert_eq!((e.cdf.clone(), e.area), (vec![0.5, 1.0], 1.0));
        // Mean position of a grid of samples is the centre.
        let n = 64;
        let mut mean = Vec3::ZERO;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                mean += e.sample(Vec3::new(0.5, 0.5, 0.0), u).unwrap().point;
            }
        }
        mean /= (n * n) as f32;
        assert!((mean - Vec3::new(0.5, 0.5, 1.0)).length() < 2e-3, "{mean:?}");
        // Seen from above (behind the emitting side) it sends nothing.
        assert!(e.sample(Vec3::new(0.5, 0.5, 2.0), Vec2::splat(0.3)).is_none());
        // With radiance at the corners (a radiant patch), a sample carries the
        // linear interpolation: here radiance = x, so its mean over the square is 1/2.
        let x = |p: Vec3| Vec3::splat(p.x);
        let corners = tris.iter().map(|t| t.map(x)).collect();
        let e = AreaEmitter::new(tris, Vec3::ZERO, corners);
        let below = Vec3::new(0.5, 0.5, 0.0);
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let s = e.sample(below, u).unwrap();
                let cos = s.dir.dot(Vec3::Z);
                let radiance = s.value.x * s.dist * s.dist / (cos * e.area);
                assert!((radiance - s.point.x).abs() < 1e-4, "{radiance} at {:?}", s.point);
                sum += radiance;
            }
        }
        assert!((sum / (n * n) as f32 - 0.5).abs() < 1e-3);
    }

    /// Light aimed by the caller carries, on average, the light's whole power when
    /// the aim covers every direction: uniform over the sphere, a point light gives
    /// 4 pi I, a spot its falloff's integral, and a one-sided area light pi L A
    /// (nothing behind it, half the directions).
    #[test]
    fn light_aimed_over_the_sphere_carries_the_whole_power() {
        use crate::sampling::cone_direction;
        use crate::testutil::scene;
        use std::f32::consts::PI;
        let spot = Light::Spot {
            position: Vec3::ONE,
            direction: Vec3::new(0.0, 0.6, 0.8),
            intensity: Vec3::splat(2.0),
            cutoff_angle: 0.5,
            beam_width: 0.3,
        };
        let point = Light::Point {
            position: Vec3::ZERO,
            intensity: Vec3::splat(3.0),
        };
        let s = scene(vec![], vec![spot.clone(), point.clone()], &[]);
        let a = Vec3::new(0.0, 0.0, 1.0);
        let square = AreaEmitter::new(
            vec![
                [a, a + Vec3::Y, a + Vec3::X + Vec3::Y],
                [a, a + Vec3::X + Vec3::Y, a + Vec3::X],
            ],
            Vec3::splat(1.5),
            Vec::new(),
        );
        let cases = [
            (SampledLight::prepare(&s, 0), light_power(&s, &spot)),
            (SampledLight::prepare(&s, 1), light_power(&s, &point)),
            (SampledLight::Area(square), f64::from(PI * 1.5)),
        ];
        let n = 256;
        for (light, want) in cases {
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let v = Vec2::new(u.y, u.x);
                    let e = light.emit_towards(u, |_| {
                        Some((cone_direction(Vec3::Z, 4.0 * PI, v), 1.0 / (4.0 * PI)))
                    });
                    sum += e.map_or(0.0, |e| f64::from(e.power.x));
                }
            }
            let got = sum / f64::from(n * n);
            assert!((got - want).abs() < 0.01 * want, "{light:?}: {got} vs {want}");
        }
    }
}
