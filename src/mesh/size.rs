//! The default element size: from the scene's bounds, or from the region its lights
//! light where a ground plane or a long corridor makes the bounds far larger.

use glam::{Vec2, Vec3};

use crate::accel::{Accel, Hit, Ray};
use crate::interaction::{emission_ray, SurfacePoint};
use crate::scene::Scene;

/// The default element size: 1/40 of the bounding-box diagonal of the surfaces that
/// keep radiosity, or of the region the lights light ([`lit_diagonal`]) where that is
/// under a third of it: a ground plane 221 m across under a classroom 15 m across
/// (Mitsuba's `classroom`) made elements 7.8 m wide, and the indirect light came out
/// at 0.64 of Mitsuba's; at 0.4 m, 0.98.
pub fn default_mesh_size(scene: &Scene, accel: &dyn Accel) -> f32 {
    let full = surface_diagonal(scene);
    // (Never under a hundredth of the whole: the mesh stays bounded by the scene.)
    let d = match lit_diagonal(scene, accel) {
        Some(lit) if lit < full / 3.0 => lit.max(full / 100.0),
        _ => full,
    };
    if d.is_finite() && d > 0.0 {
        d / 40.0
    } else {
        1.0
    }
}

/// The bounding-box diagonal of the surfaces that keep radiosity (a sky dome around
/// the scene, an emitting sphere with no reflectance, would make every element as
/// coarse as its size asks); of all of them if none does.
fn surface_diagonal(scene: &Scene) -> f32 {
    let reflects = |s: &crate::scene::Shape| {
        scene
            .bsdfs
            .get(s.bsdf as usize)
            .is_some_and(|b| b.kind.diffuse_albedo().max_element() > 0.0)
    };
    let any = scene.shapes.iter().any(reflects);
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for s in scene.shapes.iter().filter(|s| !any || reflects(s)) {
        if let Some((a, b)) = s.mesh.bounds() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    (hi - lo).length()
}

/// The first surface `ray` meets that is not glass, the ray going on straight through
/// glass (a lamp's bulb, a window pane: the light they pass lights the room beyond;
/// a bulb round a lamp made the lit region the bulb, and the elements a centimetre
/// wide). `None` if it meets none (or only a stack of 16 glass surfaces).
fn past_glass(scene: &Scene, accel: &dyn Accel, mut ray: Ray) -> Option<(Ray, Hit)> {
    for _ in 0..16 {
        let hit = accel.intersect(&ray)?;
        let shape = &scene.shapes[hit.shape as usize];
        if !scene.bsdfs[shape.bsdf as usize].kind.is_glass() {
            return Some((ray, hit));
        }
        ray = SurfacePoint::new(scene, &ray, &hit).spawn(ray.dir, f32::INFINITY);
    }
    None
}

/// Rays the lights send to find the region they light.
const LIT_RAYS: u32 = 8192;

/// The diagonal of the region the lights light: where [`LIT_RAYS`] rays from the
/// lights (in proportion to their power, each weighted by the power it carries)
/// first meet a surface and where a diffuse bounce from there meets the next, from
/// the 5th to the 95th percentile of those points along each axis (the few rays that
/// leave by a window or a door do not count). `None`
/// without lights that send rays (a sky alone) or when too few meet anything.
pub fn lit_diagonal(scene: &Scene, accel: &dyn Accel) -> Option<f32> {
    let lights = crate::emitters::SampledLight::prepare_all(scene);
    let power: Vec<f64> = scene
        .lights
        .iter()
        .zip(&lights)
        .map(|(l, s)| {
            if s.sky().is_some() {
                0.0
            } else {
                crate::emitters::light_power(scene, l)
            }
        })
        .collect();
    let total: f64 = power.iter().sum();
    if !(total > 0.0) {
        return None;
    }
    let mut hits: Vec<(Vec3, f32)> = Vec::new();
    for (l, light) in lights.iter().enumerate() {
        let count = (f64::from(LIT_RAYS) * power[l] / total).ceil() as u32;
        // A fixed seed: the mesh must not depend on `--seed` (a solution file
        // rebuilds it from its size alone, and the size from this).
        let seed = crate::sampling::shot_seed(0x11_7e, l as u64);
        for k in 0..count {
            let [a, b, c] = crate::sampling::uniform3(seed, 2 * k);
            let [d, f, g] = crate::sampling::uniform3(seed, 2 * k + 1);
            // A uniform direction over the sphere (the light's own falloff weighs it).
            let z = 1.0 - 2.0 * c;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * d;
            let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let Some(e) = light.emit_towards(Vec2::new(a, b), |_| Some((dir, 0.25 / std::f32::consts::PI)))
            else {
                continue;
            };
            let w = e.power.x + e.power.y + e.power.z;
            let Some((ray, hit)) = past_glass(scene, accel, emission_ray(&e)).filter(|_| w > 0.0) else {
                continue;
            };
            let sp = SurfacePoint::new(scene, &ray, &hit);
            hits.push((sp.p, w));
            // And where that light goes next (a diffuse bounce): a narrow spot on a
            // mirror ball lights the room around it.
            let n = if sp.ng.dot(e.dir) > 0.0 { -sp.ng } else { sp.ng };
            let next = sp.spawn(
                crate::sampling::cosine_direction(n, Vec2::new(f, g)),
                f32::INFINITY,
            );
            if let Some((next, h)) = past_glass(scene, accel, next) {
                hits.push((next.at(h.t), w));
            }
        }
    }
    if hits.len() < 64 {
        return None;
    }
    let weight: f32 = hits.iter().map(|h| h.1).sum();
    let mut lo = Vec3::ZERO;
    let mut hi = Vec3::ZERO;
    for axis in 0..3 {
        hits.sort_by(|a, b| a.0[axis].total_cmp(&b.0[axis]));
        let at = |q: f32| {
            let mut acc = 0.0;
            for h in &hits {
                acc += h.1;
                if acc >= q * weight {
                    return h.0[axis];
                }
            }
            hits[hits.len() - 1].0[axis]
        };
        lo[axis] = at(0.05);
        hi[axis] = at(0.95);
    }
    Some((hi - lo).length())
}
