use super::*;
use crate::accel::Bvh;
use crate::render::{Filter, Method, Sampler};
use crate::scene::{Light, Scene};
use crate::testutil::{looking, quad, scene, square, v};

/// A floor `[-20, 20]^2` at z = 0 facing up, a point light 4 above the origin, and
/// optionally a blocker at z = 2 over `x < -0.5` whose shadow edge on the floor is
/// the line x = -1. The camera looks straight down from z = 1.5 (below the
/// blocker), seeing x and y in [-1.5, 1.5].
fn floor_scene(blocker: bool, w: u32, h: u32) -> Scene {
    let floor = quad([
        Vec3::new(-20.0, -20.0, 0.0),
        Vec3::new(20.0, -20.0, 0.0),
        Vec3::new(20.0, 20.0, 0.0),
        Vec3::new(-20.0, 20.0, 0.0),
    ]);
    let mut shapes = vec![(floor, Vec3::splat(0.5))];
    if blocker {
        shapes.push((
            quad([
                Vec3::new(-20.0, -20.0, 2.0),
                Vec3::new(-20.0, 20.0, 2.0),
                Vec3::new(-0.5, 20.0, 2.0),
                Vec3::new(-0.5, -20.0, 2.0),
            ]),
            Vec3::splat(0.5),
        ));
    }
    let light = Light::Point {
        position: Vec3::new(0.0, 0.0, 4.0),
        intensity: Vec3::splat(20.0),
    };
    let mut s = scene(shapes, vec![light], &[]);
    s.sensors = vec![looking(Vec3::new(0.0, 0.0, 1.5), Vec3::ZERO, 90.0, w, h)];
    s
}

fn settings(w: u32, h: u32, sib: bool) -> Settings {
    Settings {
        method: Method::Direct,
        view: 0,
        width: w,
        height: h,
        spp: 1,
        seed: 7,
        area_samples: 16,
        max_depth: 2,
        gather: 0,
        filter: Filter::Box,
        sampler: Sampler::Adaptive,
        refine: Refine {
            max_level: 2,
            contrast: 0.05,
            exposure: 0.0,
            sib,
            retexture: false,
        },
    }
}

fn run(scene: &Scene, st: &Settings) -> AdaptiveOutput {
    let bvh = Bvh::build(scene);
    let tracer = Tracer::new(scene, &bvh, st);
    let camera = Camera::new(&scene.sensors[0], st.width, st.height);
    render_adaptive(&tracer, &camera, st, &st.refine, &crate::progress::Silent)
}

/// Where a sample's primary ray meets the floor (z = 0).
fn floor_x(scene: &Scene, st: &Settings, s: &Sample) -> f32 {
    let ray = Camera::new(&scene.sensors[0], st.width, st.height).ray(s.pos.x, s.pos.y);
    let t = -ray.origin.z / ray.dir.z;
    ray.at(t).x
}

#[test]
fn levels_follow_the_cell_hierarchy() {
    let (w, h) = (9, 7);
    let sc = floor_scene(true, w, h);
    let st = settings(w, h, true);
    let out = run(&sc, &st);
    let set = &out.set;
    // Level -1: one sample per 2 x 2 block (5 x 4 blocks), level 0 the other pixels.
    assert_eq!(out.levels[0].level, -1);
    assert_eq!(out.levels[0].samples, 20);
    assert_eq!(out.levels[1].samples, 63 - 20);
    // Every pixel holds 1, 4 or 16 samples, one per cell of its level, and its stored
    // sample is one of them.
    let mut refined = 0;
    for p in 0..w * h {
        let samples = set.pixel(p);
        assert!(samples.contains(&set.base[p as usize]));
        let n = samples.len();
        assert!([1, 4, 16].contains(&n), "pixel {p}: {n} samples");
        let cells = (n as f32).sqrt() as u32;
        let mut seen = vec![false; n];
        let (x, y) = ((p % w) as f32, (p / w) as f32);
        for &i in samples {
            let s = set.samples[i as usize].pos;
            let (cx, cy) = (
                ((s.x - x) * cells as f32) as u32,
                ((s.y - y) * cells as f32) as u32,
            );
            let c = (cy * cells + cx) as usize;
            assert!(!seen[c], "pixel {p}: two samples in cell {c}");
            seen[c] = true;
        }
        refined += (n > 1) as u32;
    }
    assert!(refined > 0, "the shadow edge refines some pixels");
    // The per-level counts add up to the totals.
    let sum: u64 = out.levels.iter().map(|l| l.samples).sum();
    assert_eq!(sum, out.counters.primary_rays);
    assert_eq!(sum as usize, set.samples.len());
}

#[test]
fn without_occluders_shadow_rays_are_cast_only_at_level_minus_one() {
    let (w, h) = (24, 24);
    let sc = floor_scene(false, w, h);
    let out = run(&sc, &settings(w, h, true));
    let l = &out.levels;
    assert_eq!(l[0].shadow_rays, l[0].samples, "level -1: one ray per sample");
    assert_eq!(l[0].shadow_rays_saved, 0);
    for lv in &l[1..] {
        assert_eq!(lv.shadow_rays, 0, "level {}", lv.level);
        assert_eq!(lv.shadow_rays_saved, lv.samples, "level {}", lv.level);
    }
}

#[test]
fn shadow_rays_are_cast_only_along_the_shadow_edge() {
    let (w, h) = (48, 48);
    let sc = floor_scene(true, w, h);
    let st = settings(w, h, true);
    let out = run(&sc, &st);
    // A pixel is 3 / 48 units of floor; the SIB neighbours of a sample are at most
    // about two pixels away, so rays are cast within three pixels of the edge.
    let reach = 3.0 * 3.0 / w as f32;
    let mut near_edge = 0;
    for s in out.set.samples.iter().filter(|s| s.level >= 0) {
        let x = floor_x(&sc, &st, s);
        if s.rays > 0 {
            assert!((x + 1.0).abs() < reach, "ray cast at x = {x}, level {}", s.level);
            near_edge += 1;
        }
        // Far from the edge the value is exact: black in the shadow, lit outside.
        if (x + 1.0).abs() > reach {
            assert_eq!(s.value == Vec3::ZERO, x < -1.0, "x = {x}");
        }
    }
    assert!(near_edge > 0);
    // Level 0 saves most of its rays.
    let l0 = &out.levels[1];
    assert!(l0.shadow_rays_saved > 4 * l0.shadow_rays, "{l0:?}");
}

#[test]
fn sib_on_and_off_agree_wherever_no_value_was_reused() {
    let (w, h) = (40, 40);
    let sc = floor_scene(true, w, h);
    let on = run(&sc, &settings(w, h, true));
    let off = run(&sc, &settings(w, h, false));
    assert_eq!(off.counters.shadow_rays_saved, 0);
    assert!(on.counters.shadow_rays < off.counters.shadow_rays);
    // Positions are fixed per cell: match the samples by position.
    let key = |s: &Sample| (s.pos.x.to_bits(), s.pos.y.to_bits());
    let off_by_pos: std::collections::HashMap<_, _> = off.set.samples.iter().map(|s| (key(s), s)).collect();
    let mut compared = 0;
    for s in on.set.samples.iter().filter(|s| s.saved == 0) {
        if let Some(o) = off_by_pos.get(&key(s)) {
            assert_eq!(s.value, o.value, "at {:?}", s.pos);
            compared += 1;
        }
    }
    assert!(compared > 100, "{compared}");
    // Where values were reused they are right here too: same pixels, same image.
    let (a, b) = (on.set.reconstruct(Filter::Box), off.set.reconstruct(Filter::Box));
    let differing = a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x != y).count();
    assert!(differing <= w as usize / 4, "{differing} pixels differ");
}

#[test]
fn the_image_of_a_seed_does_not_depend_on_the_threads() {
    let (w, h) = (32, 20);
    let sc = floor_scene(true, w, h);
    let st = settings(w, h, true);
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let one = pool(1).install(|| run(&sc, &st));
    let two = pool(2).install(|| run(&sc, &st));
    assert_eq!(one.set.samples, two.set.samples);
    assert_eq!(one.counters, two.counters);
    assert_eq!(one.levels, two.levels);
}

#[test]
fn the_difference_criterion_refines_only_where_values_differ() {
    let a = Sample {
        pos: Vec2::ZERO,
        value: Vec3::splat(0.5),
        object: 1,
        level: 0,
        rays: 0,
        saved: 0,
        lighting: None,
    };
    let at = |value: Vec3| Sample { value, ..a };
    // One point light, known and lit.
    let lit: &[u64] = &[1, 1];
    let r = Refine::default();
    let c = at(Vec3::new(0.5, 0.5, 0.7));
    let small = at(Vec3::new(0.5, 0.5, 0.52));
    assert!(!differ([(&a, lit), (&small, lit)], &r), "small");
    assert!(differ([(&a, lit), (&c, lit)], &r), "difference");
    assert!(
        differ([(&a, lit), (&Sample { object: 2, ..a }, lit)], &r),
        "object"
    );
    assert!(differ([(&a, lit), (&a, &[1, 0][..])], &r), "point light shadow");
    assert!(
        !differ([(&a, lit), (&a, &[0, 0][..])], &r),
        "unknown is no shadow edge"
    );
    // The 70th point light (word 1, bit 5) lit at one sample and shadowed at the other.
    let (on, off): (&[u64], &[u64]) = (&[0, 1 << 5, 0, 1 << 5], &[0, 1 << 5, 0, 0]);
    assert!(differ([(&a, on), (&a, off)], &r), "point light past the 64th");
    assert!(!differ([(&a, on), (&a, on)], &r));
    // Exposure: -8 stops makes the same difference invisible.
    let dark = Refine { exposure: -8.0, ..r };
    assert!(!differ([(&a, lit), (&c, lit)], &dark));
    // The display value is sRGB: mid grey 0.214 encodes to about 0.5.
    assert!((encode(exposed(Vec3::splat(0.214), 0.0)).x - 0.5).abs() < 0.002);
    assert_eq!(encode(exposed(Vec3::splat(7.0), 0.0)), Vec3::ONE);
    // Both white on the display: alike there, but the sun's image in a mirror ball is
    // hundreds of times its surroundings.
    let (white, sun) = (at(Vec3::splat(5.0)), at(Vec3::new(8751.0, 7900.0, 6500.0)));
    assert_eq!(encode(exposed(white.value, 0.0)), encode(exposed(sun.value, 0.0)));
    assert!(differ([(&white, lit), (&sun, lit)], &r), "a light's image");
    assert!(
        !differ([(&white, lit), (&at(Vec3::splat(70.0)), lit)], &r),
        "within 16 times"
    );
    // ...and where neither is white, the display values alone decide (two dark
    // samples 20 times apart, within the contrast).
    assert!(!differ(
        [(&at(Vec3::splat(1e-4)), lit), (&at(Vec3::splat(2e-3)), lit)],
        &r
    ));
}

#[test]
fn anti_aliasing_samples_share_the_shadow_rays_of_a_penumbra_without_losing_it() {
    // The floor and blocker of `floor_scene` under a square area light of side 1 at
    // z = 4 (radiance 10, facing down) in place of the point light. A floor point
    // (x, y, 0) sees the light where lx >= -1 - x (the segment to it crosses z = 2
    // right of the blocker's edge x = -0.5): the penumbra runs from x = -1.5 to -0.5.
    let (w, h) = (32, 32);
    let mut sc = floor_scene(true, w, h);
    let light = square(-0.5, 0.5, -0.5, 0.5, 4.0, true);
    let radiance = 10.0;
    let lit = scene(
        vec![(light, Vec3::ZERO)],
        Vec::new(),
        &[(0, Vec3::splat(radiance))],
    );
    sc.lights.clear();
    let base = sc.shapes.len() as u32;
    sc.shapes.extend(lit.shapes);
    sc.bsdfs.extend(lit.bsdfs.iter().cloned());
    for s in &mut sc.shapes[base as usize..] {
        s.bsdf += base;
    }
    sc.lights.push(Light::Area {
        shape: base,
        radiance: Vec3::splat(radiance),
        texture: None,
    });
    // The penumbra's pixels against Lambert's closed form for the part of the light
    // each one's centre sees (rho Le F): unbiased, and nearly as close as with the
    // rays of a stored sample in every anti-aliasing sample. 16 groups: RMS 13.8 %
    // here (12.7 % with every group at every sample; 13.7 % with 16 / 2^L at level L
    // and no strata, 28 % with 16 / 4^L, 21.9 % with 16 / 4^L in strata). 64 groups
    // (the default): 7.9 % (7.3 % with 64 / 2^L and no strata).
    for (groups, most_rms, rays) in [(16, 0.15, [16, 16, 4, 4]), (64, 0.09, [64, 64, 16, 4])] {
        let mut st = settings(w, h, true);
        st.area_samples = groups;
        let out = run(&sc, &st);
        let image = out.set.reconstruct(Filter::Box);
        let camera = Camera::new(&sc.sensors[0], w, h);
        let errors: Vec<f32> = (0..w * h)
            .filter_map(|p| {
                let ray = camera.ray((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
                let x = ray.at(-ray.origin.z / ray.dir.z);
                if !(-1.4..-0.6).contains(&x.x) {
                    return None;
                }
                let lo = (-1.0 - x.x).max(-0.5);
                let visible = [
                    v(lo, -0.5, 4.0),
                    v(0.5, -0.5, 4.0),
                    v(0.5, 0.5, 4.0),
                    v(lo, 0.5, 4.0),
                ];
                let exact = 0.5 * radiance * crate::geometry::point_polygon_form_factor(x, Vec3::Z, &visible);
                Some(image.pixels[p as usize].x / exact - 1.0)
            })
            .collect();
        assert!(errors.len() > 200, "{}", errors.len());
        let n = errors.len() as f32;
        let mean = errors.iter().sum::<f32>() / n;
        let rms = (errors.iter().map(|e| e * e).sum::<f32>() / n).sqrt();
        assert!(
            mean.abs() < 0.05 && rms < most_rms,
            "{groups} groups: mean {mean}, rms {rms}"
        );
        // A stored sample (levels -1 and 0) takes all groups of light points, cast
        // or read from the SIB; an anti-aliasing sample of level L 1 / 4^L of them,
        // but at least 4.
        let most = |level: i8| {
            out.set
                .samples
                .iter()
                .filter(|s| s.level == level)
                .map(|s| s.rays + s.saved)
                .max()
        };
        for (level, rays) in (-1..=2).zip(rays) {
            assert_eq!(most(level), Some(rays), "{groups} groups, level {level}");
        }
    }
}

/// [`floor_scene`] with a texture of random grey texels on the floor, each 40 / 512
/// units (about a pixel at 40 x 40), looked up at the nearest texel.
fn textured_floor(w: u32, h: u32) -> Scene {
    use crate::scene::texture::TexFilter;
    use crate::scene::{TexField, Texture};
    let mut s = floor_scene(true, w, h);
    s.shapes[0].mesh.uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
    ];
    let n = 512;
    let texels = (0..n * n)
        .map(|i| [0.15 + 0.7 * crate::sampling::uniform2(i).x; 3])
        .collect();
    let mut t = Texture::from_linear("grain", n, n, texels).unwrap();
    t.filter = TexFilter::Nearest;
    crate::testutil::texture_on(&mut s, 0, TexField::Diffuse, t);
    s
}

/// `sc` rendered at `w` x `h` with every sample traced in full and with retextured
/// samples, and the settings of the second.
fn full_and_retextured(sc: &Scene, w: u32, h: u32) -> (AdaptiveOutput, AdaptiveOutput, Settings) {
    let full = settings(w, h, true);
    let mut st = full.clone();
    st.refine.retexture = true;
    let (a, b) = (run(sc, &full), run(sc, &st));
    assert_eq!(a.counters.retextured, 0);
    (a, b, st)
}

/// Between two renders' pixels (box filter), relative to `a`'s: the largest where
/// both refined the pixel to the same level, the mean over all, and how many pixels
/// were refined to another level (where the sampling of the pixel differs).
fn pixel_differences(a: &AdaptiveOutput, b: &AdaptiveOutput) -> (f32, f32, u32) {
    let (ia, ib) = (a.set.reconstruct(Filter::Box), b.set.reconstruct(Filter::Box));
    let (mut worst, mut mean, mut other_level) = (0.0f32, 0.0f32, 0);
    for (k, (p, q)) in ia.pixels.iter().zip(&ib.pixels).enumerate() {
        let d = ((*p - *q).abs() / p.max(Vec3::splat(0.01))).max_element();
        mean += d / ia.pixels.len() as f32;
        if a.set.pixel(k as u32).len() == b.set.pixel(k as u32).len() {
            worst = worst.max(d);
        } else {
            other_level += 1;
        }
    }
    (worst, mean, other_level)
}

/// Where only the floor's texels vary, anti-aliasing samples take their pixel's light
/// and look up their own texel; the picture is the one traced in full, within the
/// point light's change across a pixel, and the pixels on and beside the shadow edge
/// at x = -1 are traced in full.
#[test]
fn retextured_samples_keep_the_picture_where_only_a_texture_varies() {
    let (w, h) = (40, 40);
    let sc = textured_floor(w, h);
    let (a, b, st) = full_and_retextured(&sc, w, h);
    let aa = b.set.samples.iter().filter(|s| s.level >= 1).count() as u64;
    assert!(
        b.counters.retextured > aa / 2 && b.counters.retextured < aa,
        "{} of {aa}",
        b.counters.retextured
    );
    // Retextured samples cast nothing and save nothing; none lies in a pixel the
    // shadow edge crosses, nor in one beside it.
    let mut near_edge = 0;
    for p in 0..w * h {
        let xs: Vec<f32> = b
            .set
            .pixel(p)
            .iter()
            .map(|&i| floor_x(&sc, &st, &b.set.samples[i as usize]))
            .collect();
        let pitch = 3.0 / w as f32;
        if xs.iter().any(|&x| (x + 1.0).abs() < pitch) {
            near_edge += 1;
            for &i in b.set.pixel(p) {
                let s = &b.set.samples[i as usize];
                assert!(
                    s.rays + s.saved > 0,
                    "a sample at x = {} took its light",
                    floor_x(&sc, &st, s)
                );
            }
        }
    }
    assert!(near_edge >= 2 * h, "{near_edge}");
    // Pixel by pixel, within the light's change across a pixel (up to 1.6 % at the
    // corners; 0.27 % on the mean here, 1.3 % at worst). A pixel refined to another
    // level (the criteria compare values that moved by that much) differs by the
    // sampling of its texels.
    let (worst, mean, other_level) = pixel_differences(&a, &b);
    assert!(worst < 0.02, "worst relative difference {worst}");
    assert!(mean < 0.004, "mean relative difference {mean}");
    assert!(
        other_level < w * h / 100,
        "{other_level} pixels refined otherwise"
    );
}

/// A floor (object 0) and on it one box (object 1: its five faces one shape) lit
/// from the side by a point light, seen from above and in front: the box's top, its
/// front face (turned from the light) and its right face (towards it) are lit
/// three ways, and it casts a shadow on the floor.
fn box_on_floor(w: u32, h: u32) -> Scene {
    use crate::testutil::box_outside;
    let floor = quad([
        Vec3::new(-20.0, -20.0, 0.0),
        Vec3::new(20.0, -20.0, 0.0),
        Vec3::new(20.0, 20.0, 0.0),
        Vec3::new(-20.0, 20.0, 0.0),
    ]);
    let faces = box_outside(Vec3::new(-0.6, -0.6, 0.0), Vec3::new(0.6, 0.6, 0.5));
    let mut solid = faces[1].clone();
    for f in &faces[2..] {
        solid.append(f);
    }
    let light = Light::Point {
        position: Vec3::new(1.5, 1.0, 4.0),
        intensity: Vec3::splat(20.0),
    };
    let mut s = scene(
        vec![(floor, Vec3::splat(0.5)), (solid, Vec3::splat(0.7))],
        vec![light],
        &[],
    );
    s.sensors = vec![looking(Vec3::new(0.8, -2.5, 2.5), Vec3::ZERO, 60.0, w, h)];
    s
}

/// Across an object's edge, each side's anti-aliasing samples take the light of
/// their pixel's nearest sample on the object they hit, where that object's samples
/// around agree, and face the same way (a box's top lends nothing to its sides); the
/// picture is the one traced in full, and the box's shadow edge is traced in full.
#[test]
fn samples_across_an_edge_take_the_light_of_the_object_they_hit() {
    let (w, h) = (48, 40);
    let sc = box_on_floor(w, h);
    let (a, b, _) = full_and_retextured(&sc, w, h);
    // The refined pixels are the box's outline and its shadow's edge.
    let aa = b.set.samples.iter().filter(|s| s.level >= 1).count() as u64;
    assert!(aa > 1000, "{aa}");
    assert!(
        b.counters.retextured > aa / 3 && b.counters.retextured < aa,
        "{} of {aa}",
        b.counters.retextured
    );
    // Pixel by pixel, within the point light's change across a pixel.
    let (worst, mean, other_level) = pixel_differences(&a, &b);
    // In pixels across the outline, floor samples took light (202 in 34 pixels
    // here; a floor sample traced casts or saves a ray to the light above it).
    let across = (0..w * h)
        .filter(|&p| {
            let on = |object: u32| {
                b.set
                    .pixel(p)
                    .iter()
                    .any(|&i| b.set.samples[i as usize].object == object)
            };
            on(0) && on(1)
        })
        .collect::<Vec<u32>>();
    let took = across
        .iter()
        .flat_map(|&p| b.set.pixel(p))
        .filter(|&&i| {
            let s = &b.set.samples[i as usize];
            s.object == 0 && s.level >= 1 && s.rays + s.saved == 0
        })
        .count();
    assert!(
        across.len() > 20 && took > 100,
        "{took} in {} pixels",
        across.len()
    );
    // Worst 2.4 %, in pixels beside the outline refined whole on one side, where
    // the light changes by that much across a pixel; 10 % if the box's sides took
    // its top's light (no normal test).
    assert!(worst < 0.03, "worst relative difference {worst}");
    assert!(mean < 0.001, "mean relative difference {mean}");
    assert!(
        other_level < w * h / 100,
        "{other_level} pixels refined otherwise"
    );
}

/// Per object among a refined pixel's samples: its group (there and around) judged
/// alone, and too few samples of it lend nothing.
#[test]
fn relightable_judges_each_side_of_an_edge_alone() {
    let lit: &[u64] = &[1, 1];
    let at = |light: f32, object: u32| Sample {
        pos: Vec2::ZERO,
        value: Vec3::splat(0.5 * light),
        object,
        level: 0,
        rays: 0,
        saved: 0,
        lighting: Lighting::new(Vec3::splat(0.5), Vec3::splat(0.5 * light), Vec3::Z),
    };
    let r = Refine::default();
    let (floor, floor2, boxtop, dark) = (at(1.0, 0), at(1.0, 0), at(0.3, 1), at(0.2, 1));
    let own = [(&floor, lit), (&boxtop, lit)];
    // The floor's light agrees; the box's differs (0.15 -> 0.10 in radiance).
    let around = [(&floor2, lit), (&floor, lit), (&dark, lit)];
    assert_eq!(
        relightable(&own, &around, &r),
        [(0, Takes::All), (1, Takes::Nothing)]
    );
    // The box's agrees too.
    let around = [(&floor2, lit), (&floor2, lit), (&boxtop, lit), (&boxtop, lit)];
    assert_eq!(relightable(&own, &around, &r), [(0, Takes::All), (1, Takes::All)]);
    // Two samples of the box are too few.
    let around = [(&floor2, lit), (&floor, lit), (&boxtop, lit)];
    assert_eq!(
        relightable(&own, &around, &r),
        [(0, Takes::All), (1, Takes::Nothing)]
    );
    // A third object in the pixel lends nothing; nor does the floor at a shadow edge.
    let third = at(1.0, 2);
    let own = [(&floor, lit), (&floor2, &[1, 0][..]), (&third, lit)];
    let around = [(&floor2, lit), (&third, lit), (&third, lit)];
    assert_eq!(
        relightable(&own, &around, &r),
        [(0, Takes::Nothing), (2, Takes::All)]
    );
    let own = [(&floor, lit), (&boxtop, lit), (&third, lit)];
    let objects = relightable(&own, &around, &r).map(|(object, _)| object);
    assert_eq!(objects, [0, 1], "the first two objects");
}

/// Samples differ by their texture alone when, with the first's texel put in for
/// each, the refinement criteria no longer fire; by their texture and their glossy
/// part when the criteria are quiet on the diffuse light alone.
#[test]
fn texture_alone_separates_texels_from_light() {
    let lit: &[u64] = &[1, 1];
    // A sample of albedo `albedo` under diffuse light `light` per unit albedo, with
    // a glossy part `glossy`.
    let at = |albedo: f32, light: f32, glossy: f32, object: u32| {
        let diffuse = Vec3::splat(albedo * light);
        let value = diffuse + Vec3::splat(glossy);
        Sample {
            pos: Vec2::ZERO,
            value,
            object,
            level: 0,
            rays: 0,
            saved: 0,
            lighting: Lighting::new(Vec3::splat(albedo), diffuse, Vec3::Z),
        }
    };
    let r = Refine::default();
    let (a, b) = (at(0.2, 1.0, 0.02, 1), at(0.8, 1.0, 0.02, 1));
    let alone = |x: &Sample, y: &Sample, bits: &[u64]| texture_alone([(x, lit), (y, bits)], &r);
    assert!(
        differ([(&a, lit), (&b, lit)], &r),
        "the texels differ on the display"
    );
    assert_eq!(alone(&a, &b, lit), Takes::All);
    // The light differs too: by half at albedo 0.2, 0.22 -> 0.32 in radiance, 0.51
    // -> 0.60 on the display, over the contrast.
    assert_eq!(alone(&a, &at(0.8, 1.5, 0.02, 1), lit), Takes::Nothing);
    // By 1 %: within it.
    assert_eq!(alone(&a, &at(0.8, 1.01, 0.02, 1), lit), Takes::All);
    // The glossy part differs (0.22 -> 0.32 again), the diffuse light not: the new
    // samples take the diffuse light and trace the glossy part anew.
    assert_eq!(alone(&a, &at(0.8, 1.0, 0.12, 1), lit), Takes::Diffuse);
    assert_eq!(alone(&a, &at(0.8, 1.0, 0.02, 2), lit), Takes::Nothing, "object");
    assert_eq!(alone(&a, &b, &[1, 0]), Takes::Nothing, "shadow");
    let untextured = Sample { lighting: None, ..b };
    assert_eq!(alone(&a, &untextured, lit), Takes::Nothing, "no lighting");
    assert_eq!(texture_alone(std::iter::empty(), &r), Takes::Nothing);
}

/// Eight lights 1.7 cm square, 0.5 below a camera looking down (90-degree fov, 32 x
/// 32 pixels): each one's image is 0.3 square pixels, which a pixel's one level-0
/// sample meets by chance, and the criteria refine only round a sample that met it.
/// Each light's light in the image (the sum over the pixels about it, radiance times
/// the pixel's share) must be its radiance times its image's area, within 30 %, and
/// the eight together within 15 %: small lights' pixels are refined at every level
/// ([`small_light_pixels`]; now each within 17 %). Without that, at this seed, four
/// of the eight were missed (none of their light in the image) and one came out at
/// 47 %: the eight together 43 %.
#[test]
fn a_light_smaller_than_a_pixel_is_found_and_weighed() {
    let (w, h) = (32, 32);
    let side = 0.017;
    let centres: Vec<Vec2> = (0..8)
        .map(|k| Vec2::new(-0.35 + 0.1 * k as f32, if k % 2 == 0 { 0.2 } else { -0.25 }))
        .collect();
    let floor = quad([
        Vec3::new(-20.0, -20.0, 0.0),
        Vec3::new(20.0, -20.0, 0.0),
        Vec3::new(20.0, 20.0, 0.0),
        Vec3::new(-20.0, 20.0, 0.0),
    ]);
    let radiance = 1000.0;
    let mut shapes = vec![(floor, Vec3::splat(0.5))];
    for c in &centres {
        let (a, b) = (*c - Vec2::splat(side / 2.0), *c + Vec2::splat(side / 2.0));
        // Facing up, towards the camera (and away from the floor).
        shapes.push((
            quad([
                Vec3::new(a.x, a.y, 1.0),
                Vec3::new(b.x, a.y, 1.0),
                Vec3::new(b.x, b.y, 1.0),
                Vec3::new(a.x, b.y, 1.0),
            ]),
            Vec3::ZERO,
        ));
    }
    let emitters: Vec<(usize, Rgb)> = (1..=centres.len()).map(|i| (i, Vec3::splat(radiance))).collect();
    let light = Light::Point {
        position: Vec3::new(0.0, 0.0, 4.0),
        intensity: Vec3::splat(20.0),
    };
    let mut sc = scene(shapes, vec![light], &emitters);
    sc.sensors = vec![looking(Vec3::new(0.0, 0.0, 1.5), Vec3::ZERO, 90.0, w, h)];
    let mut st = settings(w, h, true);
    st.refine.max_level = 3;
    let image = run(&sc, &st).set.reconstruct(Filter::Box);
    let camera = Camera::new(&sc.sensors[0], w, h);
    // A pixel is (2 x 0.5 / 32) m wide at the lights' depth.
    let expected = radiance * (side * w as f32).powi(2);
    let mut total = 0.0;
    for c in &centres {
        let (px, py) = camera.project(Vec3::new(c.x, c.y, 1.0)).unwrap();
        let mut got = 0.0;
        for y in (py as i32 - 2).max(0)..=(py as i32 + 2).min(h as i32 - 1) {
            for x in (px as i32 - 2).max(0)..=(px as i32 + 2).min(w as i32 - 1) {
                // Less the lit floor about it (at most a few units a pixel).
                got += (image.pixels[(y as u32 * w + x as u32) as usize].x - 2.0).max(0.0);
            }
        }
        assert!(
            (got / expected - 1.0).abs() < 0.3,
            "light at {c}: {got} in the image, {expected} expected"
        );
        total += got;
    }
    let all = expected * centres.len() as f32;
    assert!((total / all - 1.0).abs() < 0.15, "{total} against {all}");
}
