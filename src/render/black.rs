//! Why a rendered image is black: a render never goes black without saying why.
//!
//! A black picture is almost always a scene mistake, not a renderer's: a camera outside
//! the room looking at the backs of its walls (one-sided surfaces are black from
//! behind, in Mitsuba as here), a camera looking out into the void of a scene with no
//! sky, or lights that reach nothing the camera sees. [`why_black`] tells these apart
//! by probing the view with a grid of camera rays.

use rayon::prelude::*;

use crate::accel::Accel;
use crate::camera::Camera;
use crate::image::Image;
use crate::interaction::SurfacePoint;
use crate::scene::Scene;

/// An image is black when no more than this fraction of its pixels holds any light.
const LIT_FRACTION: f64 = 1e-3;

/// The probe grid's cells along the image's long side.
const PROBES: u32 = 64;

/// Surfaces a probe ray goes straight on through (glass, a mask's open part) before
/// it is called lost.
const MAX_PASSES: u32 = 8;

/// What a camera ray meets first (through glass and a mask's open part).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Probe {
    /// Nothing, and the scene has no sky.
    Void,
    /// The sky.
    Sky,
    /// The back of a one-sided surface (black).
    Back,
    /// The side of a surface that reflects (or an emitter's lit side).
    Front,
}

/// Why `image` (rendered through `camera`) is black, in one line; `None` when it is
/// not black (more than [`LIT_FRACTION`] of its pixels hold some light).
pub fn why_black(image: &Image, scene: &Scene, accel: &dyn Accel, camera: &Camera) -> Option<String> {
    let lit = image.pixels.iter().filter(|p| p.max_element() > 0.0).count();
    if lit as f64 > LIT_FRACTION * image.pixels.len() as f64 {
        return None;
    }
    let head = "the image is black";
    if scene.lights.is_empty() {
        return Some(format!("{head}: the scene has no light sources"));
    }
    let step = (image.width.max(image.height) as f32 / PROBES as f32).max(1.0);
    let (nx, ny) = (
        ((image.width as f32 / step).ceil() as u32).max(1),
        ((image.height as f32 / step).ceil() as u32).max(1),
    );
    let probes: Vec<Probe> = (0..nx * ny)
        .into_par_iter()
        .map(|i| {
            let x = ((i % nx) as f32 + 0.5) * image.width as f32 / nx as f32;
            let y = ((i / nx) as f32 + 0.5) * image.height as f32 / ny as f32;
            probe(scene, accel, camera, x, y)
        })
        .collect();
    let share = |k: Probe| probes.iter().filter(|&&p| p == k).count() as f64 / probes.len() as f64;
    let mut reasons: Vec<(f64, &str)> = vec![
        (
            share(Probe::Back),
            "meet the backs of one-sided surfaces, black as in Mitsuba (is the camera outside the room, \
             or inside a closed object? `twosided` makes a material reflect on both sides)",
        ),
        (
            share(Probe::Void),
            "leave the scene, which has no sky (is the camera facing away from it?)",
        ),
        (
            share(Probe::Front),
            "meet surfaces that no light reaches (is the camera outside the lit room, or are the lights \
             enclosed, facing away, or too weak?)",
        ),
        (share(Probe::Sky), "see a sky that is black there"),
    ];
    reasons.sort_by(|a, b| b.0.total_cmp(&a.0));
    let said: Vec<String> = reasons
        .iter()
        .filter(|(f, _)| *f > 0.0)
        .map(|(f, why)| format!("{:.0} % {why}", 100.0 * f))
        .collect();
    Some(format!("{head}: of the camera's rays, {}", said.join("; ")))
}

/// What the camera ray through image point (`x`, `y`) meets first, going straight on
/// through glass and through masks' mostly open parts.
fn probe(scene: &Scene, accel: &dyn Accel, camera: &Camera, x: f32, y: f32) -> Probe {
    let mut ray = camera.ray(x, y);
    for _ in 0..MAX_PASSES {
        let Some(hit) = accel.intersect(&ray) else {
            return if scene.environment().is_some() {
                Probe::Sky
            } else {
                Probe::Void
            };
        };
        let sp = SurfacePoint::new(scene, &ray, &hit);
        let (bsdf, kind) = sp.material(scene);
        if kind.is_glass() || sp.opacity(scene, bsdf) < 0.5 {
            ray = sp.spawn(ray.dir, f32::INFINITY);
            continue;
        }
        return if sp.front || bsdf.twosided {
            Probe::Front
        } else {
            Probe::Back
        };
    }
    Probe::Front
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::Bvh;
    use crate::scene::Light;
    use crate::testutil::{box_inside, box_outside, looking, scene, v};

    fn grey() -> Vec3 {
        Vec3::splat(0.5)
    }

    /// Why a black 40 x 30 picture of `s` from `eye` looking at `target` is black.
    fn why(s: &crate::scene::Scene, eye: Vec3, target: Vec3) -> Option<String> {
        let bvh = Bvh::build(s);
        let camera = Camera::new(&looking(eye, target, 60.0, 40, 30), 40, 30);
        why_black(&Image::new(40, 30), s, &bvh, &camera)
    }

    /// A 4 x 3 x 2.5 m room (one-sided walls facing in) with a point light in it, and
    /// `more` grey shapes.
    fn room_with(more: Vec<crate::geometry::TriMesh>) -> crate::scene::Scene {
        let mut shapes = box_inside(v(0.0, 0.0, 0.0), v(4.0, 3.0, 2.5));
        shapes.extend(more);
        let light = Light::Point {
            position: v(2.0, 1.5, 2.0),
            intensity: Vec3::splat(10.0),
        };
        scene(
            shapes.into_iter().map(|m| (m, grey())).collect(),
            vec![light],
            &[],
        )
    }

    fn room() -> crate::scene::Scene {
        room_with(Vec::new())
    }

    #[test]
    fn a_lit_image_is_not_black_even_with_few_lit_pixels() {
        let s = room();
        let bvh = Bvh::build(&s);
        let camera = Camera::new(
            &looking(v(-1.0, 1.5, 1.2), v(2.0, 1.5, 1.2), 60.0, 40, 30),
            40,
            30,
        );
        let mut img = Image::new(40, 30);
        img.pixels[0] = Vec3::new(0.0, 1e-6, 0.0);
        img.pixels[1] = Vec3::new(0.0, 1e-6, 0.0);
        assert_eq!(why_black(&img, &s, &bvh, &camera), None, "2 of 1200 pixels lit");
        img.pixels[1] = Vec3::ZERO;
        assert!(
            why_black(&img, &s, &bvh, &camera).is_some(),
            "1 of 1200 pixels lit"
        );
    }

    #[test]
    fn a_camera_outside_the_room_sees_the_backs_of_its_walls() {
        let why = why(&room(), v(-1.0, 1.5, 1.2), v(2.0, 1.5, 1.2)).unwrap();
        // 1 m in front of the wall x = 0: every probe ray meets its outside.
        assert!(
            why.contains(": of the camera's rays, 100 % meet the backs of one-sided surfaces"),
            "{why}"
        );
        assert!(!why.contains("leave the scene"), "{why}");
    }

    #[test]
    fn a_camera_facing_away_from_the_scene_sees_the_void() {
        let why = why(&room(), v(-3.0, 1.5, 1.2), v(-8.0, 1.5, 1.2)).unwrap();
        assert!(why.contains("100 % leave the scene, which has no sky"), "{why}");
    }

    #[test]
    fn a_camera_half_on_the_room_sees_half_backs_and_half_void() {
        // On the plane of the wall x = 0, 1 m in front of the room: the wall's plane
        // cuts the view into two halves of 20 probe columns each.
        let why = why(&room(), v(0.0, -1.0, 1.25), v(0.0, 0.0, 1.25)).unwrap();
        assert!(
            why.contains("50 % meet the backs") && why.contains("50 % leave the scene"),
            "{why}"
        );
    }

    #[test]
    fn a_camera_in_a_room_whose_light_is_boxed_in_sees_unlit_surfaces() {
        // A closed box (facing out) around the light.
        let s = room_with(box_outside(v(1.8, 1.3, 1.8), v(2.2, 1.7, 2.2)));
        let why = why(&s, v(0.5, 0.5, 1.2), v(4.0, 3.0, 1.2)).unwrap();
        assert!(why.contains("100 % meet surfaces that no light reaches"), "{why}");
    }

    #[test]
    fn a_scene_without_lights_says_so() {
        let walls = box_inside(v(0.0, 0.0, 0.0), v(4.0, 3.0, 2.5));
        let s = scene(walls.into_iter().map(|m| (m, grey())).collect(), vec![], &[]);
        let why = why(&s, v(2.0, 1.5, 1.2), v(4.0, 3.0, 1.2)).unwrap();
        assert_eq!(why, "the image is black: the scene has no light sources");
    }
}
