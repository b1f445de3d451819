//! Rays through glass at render time: a hit on `dielectric` or `thindielectric`
//! continues as its mirror reflection and its transmission ([`BsdfKind::split`]);
//! on `roughdielectric`, as those about one microfacet normal drawn at the hit
//! ([`BsdfKind::facet`]).
//! Near the eye both are followed; deeper, one of them, drawn by its weight, so
//! that a stack of panes or a glass object costs rays linear in its depth.

use glam::{Vec2, Vec3};

use crate::accel::Ray;
use crate::bsdf::glass::Split;
use crate::interaction::{reflect, SurfacePoint};
use crate::sampling::{derive, uniform2, uniform3, Stream};
use crate::scene::{mean, BsdfKind, Rgb};

/// Glass hits at fewer than this many bounces from the eye follow both rays.
pub const GLASS_SPLIT_DEPTH: u32 = 2;

/// Microfacet normals drawn (stratified) where a camera ray meets rough glass, each
/// followed by both its rays; one at deeper hits. One left a frosted sphere speckled
/// where the adaptive sampler's 16 samples a pixel could not smooth it: `frosted.xml`
/// FLIP against Mitsuba 0.0353 -> 0.0333 (Mitsuba's 64 spp: 0.0352), RMSE 0.0176 ->
/// 0.0119, for 7 % more time (1.77 -> 1.89 s); four: 0.0325 at 2.36 s.
pub const PRIMARY_FACETS: u32 = 2;

/// The rays that leave glass of model `kind` hit at `sp` by a ray of direction `dir`
/// at bounce `depth`: each with its weight and its path's seed (at most two; none if
/// `kind` is not glass).
pub fn rays(
    kind: &BsdfKind,
    sp: &SurfacePoint,
    dpdu: Vec3,
    dir: Vec3,
    depth: u32,
    seed: u32,
) -> Vec<(Ray, Rgb, u32)> {
    let [u, v, _] = uniform3(derive(seed, Stream::Transmission), 1);
    rays_about(kind, sp, dpdu, dir, depth, seed, Vec2::new(u, v))
}

/// [`rays`], with rough glass's microfacet normal drawn by `facet_u`. `dpdu` orients
/// an anisotropic distribution ([`BsdfKind::glass_dpdu`]).
pub fn rays_about(
    kind: &BsdfKind,
    sp: &SurfacePoint,
    dpdu: Vec3,
    dir: Vec3,
    depth: u32,
    seed: u32,
    facet_u: Vec2,
) -> Vec<(Ray, Rgb, u32)> {
    // `sp.ns` faces the arriving ray; the glass's sides are told by `sp.front`.
    let outward = if sp.front { sp.ns } else { -sp.ns };
    // Rough glass: both rays leave about one microfacet normal.
    let Some(facet) = kind.facet(-dir, outward, dpdu, facet_u) else {
        return Vec::new();
    };
    let Split {
        reflect: r,
        transmit: t,
        dir: t_dir,
        ..
    } = facet.split;
    let mut out = Vec::with_capacity(2);
    let r_dir = reflect(dir, facet.m).normalize();
    let (r, t) = (r * facet.weight(-dir, r_dir), t * facet.weight(-dir, t_dir));
    let reflected = (r.max_element() > 0.0 && r_dir.dot(sp.ng) > 0.0)
        .then(|| (sp.spawn(r_dir, f32::INFINITY), derive(seed, Stream::Reflection)));
    let transmitted = (t.max_element() > 0.0 && t_dir.dot(sp.ng) < 0.0)
        .then(|| (sp.spawn(t_dir, f32::INFINITY), derive(seed, Stream::Transmission)));
    if depth < GLASS_SPLIT_DEPTH {
        if let Some((ray, s)) = reflected {
            out.push((ray, r, s));
        }
        if let Some((ray, s)) = transmitted {
            out.push((ray, t, s));
        }
        return out;
    }
    let (pr, pt) = (
        if reflected.is_some() { mean(r) } else { 0.0 },
        if transmitted.is_some() { mean(t) } else { 0.0 },
    );
    if !(pr + pt > 0.0) {
        return out;
    }
    let u = uniform2(derive(seed, Stream::Transmission)).x * (pr + pt);
    match (reflected, transmitted) {
        (Some((ray, s)), _) if u < pr => out.push((ray, r * ((pr + pt) / pr), s)),
        (_, Some((ray, s))) => out.push((ray, t * ((pr + pt) / pt), s)),
        _ => {}
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Bvh;
    use crate::bsdf::glass::thin_reflectance;
    use crate::render::counters::Counters;
    use crate::render::shading::Tracer;
    use crate::render::Settings;
    use crate::scene::{Light, Scene};
    use crate::testutil::{scene_with, square};
    use std::f32::consts::PI;

    fn glass(thin: bool) -> BsdfKind {
        BsdfKind::clear_glass(1.5, thin)
    }

    fn floor() -> BsdfKind {
        BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.5),
        }
    }

    /// One-sample settings of the direct method, mirrors and glass followed
    /// `max_depth` bounces.
    fn direct(max_depth: u32) -> Settings {
        Settings::direct_test(1, max_depth)
    }

    /// Radiance arriving at `from` looking straight down (direct light only).
    fn look_down(s: &Scene, from: Vec3, max_depth: u32) -> Rgb {
        let bvh = Bvh::build(s);
        let tracer = Tracer::new(s, &bvh, &direct(max_depth));
        tracer.radiance(&Ray::new(from, -Vec3::Z), 0, 1, &mut Counters::default())
    }

    /// A floor under a point light, a thin pane at height 1 over part of it: the
    /// floor behind the pane is lit through it, dimmed by its transmittance at the
    /// shadow ray's angle; seen through the pane it is dimmed once more (at normal
    /// incidence), and the pane's reflection shows nothing (the sky is black).
    #[test]
    fn a_thin_pane_dims_the_light_through_it_and_the_view_through_it() {
        let (h, i) = (2.0f32, 10.0f32);
        let s = scene_with(
            vec![
                (square(-10.0, 10.0, -10.0, 10.0, 0.0, false), floor()),
                (square(-1.0, 1.0, -1.0, 1.0, 1.0, false), glass(true)),
            ],
            vec![Light::Point {
                position: Vec3::new(0.0, 0.0, h),
                intensity: Vec3::splat(i),
            }],
            &[],
        );
        let t0 = 1.0 - thin_reflectance(1.0, 1.5);
        for x in [0.0f32, 0.5, 3.0] {
            let r2 = h * h + x * x;
            let cos = h / r2.sqrt();
            let closed = 0.5 / PI * i * cos / r2;
            // The shadow ray crosses the pane's plane at x / 2.
            let through = if x / 2.0 < 1.0 {
                1.0 - thin_reflectance(cos, 1.5)
            } else {
                1.0
            };
            let below = look_down(&s, Vec3::new(x, 0.0, 0.5), 4);
            assert!(
                (below.x - closed * through).abs() < 1e-5 * closed,
                "x {x}: {below} vs {}",
                closed * through
            );
            let above = look_down(&s, Vec3::new(x, 0.0, 1.5), 4);
            let seen = if x < 1.0 { t0 } else { 1.0 };
            assert!(
                (above.x - closed * through * seen).abs() < 1e-5 * closed,
                "x {x}: {above} vs {}",
                closed * through * seen
            );
        }
        // With no bounces allowed the pane is black.
        assert_eq!(look_down(&s, Vec3::new(0.0, 0.0, 1.5), 0), Vec3::ZERO);
    }

    /// A slab of thick glass (two faces 0.2 apart) seen straight down over a floor
    /// lit from the side below it: the floor through the slab is dimmed by the two
    /// faces' transmittances, (1 - r)^2 with r = 0.04 (the radiance's scaling by 1.5^2
    /// going in is undone coming out), plus the light bounced between the faces
    /// (r^2 of that, within the tolerance). A shadow ray crosses the slab's parallel
    /// faces unbent, dimmed by the same two faces; tilt one face by 10 degrees and
    /// the light it would bend is the photons' part: a shadow.
    #[test]
    fn a_thick_slab_passes_the_floor_behind_it_by_its_two_faces() {
        let (x_l, h, i) = (3.0f32, 0.5f32, 10.0f32);
        let light = Light::Point {
            position: Vec3::new(x_l, 0.0, h),
            intensity: Vec3::splat(i),
        };
        let s = scene_with(
            vec![
                (square(-10.0, 10.0, -10.0, 10.0, 0.0, false), floor()),
                (square(-1.0, 1.0, -1.0, 1.0, 1.2, false), glass(false)),
                (square(-1.0, 1.0, -1.0, 1.0, 1.0, true), glass(false)),
            ],
            vec![light],
            &[],
        );
        let r2 = x_l * x_l + h * h;
        let closed = 0.5 / PI * i * (h / r2.sqrt()) / r2;
        let seen = look_down(&s, Vec3::new(0.0, 0.0, 2.0), 6);
        let expect = closed * 0.96 * 0.96;
        assert!((seen.x - expect).abs() < 3e-3 * expect, "{seen} vs {expect}");
        // Under the slab, a light 3 above the floor: lit through both faces at
        // normal incidence.
        let above = Light::Point {
            position: Vec3::new(0.0, 0.0, 3.0),
            intensity: Vec3::splat(i),
        };
        let mut s2 = s.clone();
        s2.lights = vec![above];
        let under = look_down(&s2, Vec3::new(0.0, 0.0, 0.5), 6);
        let expect = 0.5 / PI * i / 9.0 * 0.96 * 0.96;
        assert!((under.x - expect).abs() < 1e-4 * expect, "{under} vs {expect}");
        // The lower face tilted by 10 degrees about the x axis: a wedge.
        let tilt = glam::Mat3::from_rotation_x(10f32.to_radians());
        let mut wedge = s2.clone();
        for p in &mut wedge.shapes[2].mesh.positions {
            *p = tilt * (*p - Vec3::new(0.0, 0.0, 1.0)) + Vec3::new(0.0, 0.0, 1.0);
        }
        assert_eq!(look_down(&wedge, Vec3::new(0.0, 0.0, 0.5), 6), Vec3::ZERO);
    }

    /// A mask of opacity 0.25 over a floor, both under a point light: the floor is
    /// lit through the mask's open three quarters (a shadow ray's dimming), and a
    /// ray looking down meets the mask a quarter of the time (drawn per ray: the mean
    /// of many rays).
    #[test]
    fn a_mask_lets_its_open_share_through() {
        use crate::scene::{TexField, Texture};
        let (h, i) = (2.0f32, 10.0f32);
        let mut s = scene_with(
            vec![
                (square(-10.0, 10.0, -10.0, 10.0, 0.0, false), floor()),
                (square(-1.0, 1.0, -1.0, 1.0, 1.0, false), floor()),
            ],
            vec![Light::Point {
                position: Vec3::new(0.0, 0.0, h),
                intensity: Vec3::splat(i),
            }],
            &[],
        );
        let t = Texture::from_linear("o", 1, 1, vec![[0.25; 3]]).unwrap();
        crate::testutil::texture_on(&mut s, 1, TexField::Opacity, t);
        let below = look_down(&s, Vec3::new(0.0, 0.0, 0.5), 4);
        let lit_floor = 0.5 / PI * i / (h * h);
        assert!(
            (below.x - 0.75 * lit_floor).abs() < 1e-5,
            "{below} vs {}",
            0.75 * lit_floor
        );
        let bvh = Bvh::build(&s);
        let tracer = Tracer::new(&s, &bvh, &direct(4));
        let n = 4000;
        let mean: f32 = (0..n)
            .map(|k| {
                let ray = Ray::new(Vec3::new(0.0, 0.0, 1.5), -Vec3::Z);
                tracer
                    .radiance(
                        &ray,
                        0,
                        crate::sampling::derive(k, crate::sampling::Stream::Path),
                        &mut Counters::default(),
                    )
                    .x
            })
            .sum::<f32>()
            / n as f32;
        let top = 0.5 / PI * i / 1.0;
        let expect = 0.25 * top + 0.75 * 0.75 * lit_floor;
        assert!((mean - expect).abs() < 0.04 * expect, "{mean} vs {expect}");
    }
}
