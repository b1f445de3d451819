use super::*;
use crate::accel::Bvh;
use crate::radiosity::{solve, SolveSettings};
use crate::render::{Filter, Output, Settings};
use crate::testutil::{looking, quad, scene};
use std::f32::consts::PI;

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// A floor-level square `[x0,x1] x [y0,y1]` at height z, facing up (or down).
fn square(x0: f32, x1: f32, y0: f32, y1: f32, z: f32, down: bool) -> crate::geometry::TriMesh {
    let mut m = quad([v(x0, y0, z), v(x1, y0, z), v(x1, y1, z), v(x0, y1, z)]);
    if down {
        m.flip_normals();
    }
    m
}

fn solve_settings(mesh_size: f32, n: u32) -> SolveSettings {
    SolveSettings {
        mesh_size,
        sources_per_patch: n,
        shoot_samples: 64,
        tolerance: 0.01,
        max_shots: 40,
        seed: 1,
    }
}

/// Shapes: 0 a fully lit floor square, 1 a floor square half in the shadow of
/// occluder 2, 3 a nearly black floor square, 4 a floor square right under the big
/// area light 5 (1 cm above it, a little larger: 4 is in its shadow from the point
/// light). Lights: 0 a point light above, 1 the area light.
fn criteria_scene() -> Scene {
    let rho = Vec3::splat(0.5);
    scene(
        vec![
            (square(1.0, 2.0, -0.5, 0.5, 0.0, false), rho),
            (square(-2.0, -1.0, -0.5, 0.5, 0.0, false), rho),
            (square(-1.2, -1.0, -1.0, 1.0, 1.0, true), rho),
            (square(-0.5, 0.5, 1.0, 2.0, 0.0, false), Vec3::splat(0.02)),
            (square(-0.5, 0.5, -2.5, -1.5, 0.0, false), rho),
            (square(-0.6, 0.6, -2.6, -1.4, 0.01, true), Vec3::ZERO),
        ],
        vec![Light::Point {
            position: v(0.0, 0.0, 3.0),
            intensity: Vec3::splat(10.0),
        }],
        &[(5, Vec3::splat(1.0))],
    )
}

/// The verdicts on `source` for the front patch of shape `shape`.
fn verdict(sel: &Selection, shape: usize, source: SourceId) -> Criteria {
    let p = sel.solution.mesh.shape_first_patch[shape] as usize;
    sel.criteria[p]
        .iter()
        .find(|(s, _)| *s == source)
        .unwrap_or_else(|| panic!("shape {shape}: {source:?} not listed: {:?}", sel.criteria[p]))
        .1
}

#[test]
fn each_criterion_decides_its_constructed_case() {
    let s = criteria_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), None);
    let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let point = SourceId::Light(0);

    // A fully lit patch: the gradient criterion says no (nothing to find).
    let lit = verdict(&sel, 0, point);
    assert!(!lit.gradient && lit.visibility_spread == 0.0, "{lit:?}");
    assert!(lit.radiance && lit.reflectivity && lit.solid_angle && lit.view);
    assert!(!lit.selected());

    // A half-shadowed patch: yes, and every other criterion agrees: one ray.
    let half = verdict(&sel, 1, point);
    assert!(half.gradient && half.visibility_spread == 1.0, "{half:?}");
    assert!(half.selected() && half.rays == 1, "{half:?}");

    // A (nearly) black patch: the reflectivity criterion says no.
    let black = verdict(&sel, 3, point);
    assert!(!black.reflectivity && black.radiance, "{black:?}");

    // A huge area light right above a patch: the solid angle criterion says no, it
    // sees nearly the whole hemisphere.
    let under = verdict(&sel, 4, SourceId::Light(1));
    assert!(
        !under.solid_angle && under.solid_angle_sr > 0.8 * 2.0 * PI,
        "{under:?}"
    );

    // The picks follow the verdicts: only the half-shadowed patch casts rays.
    let picks = |shape: usize| sel.picks(sol.mesh.shape_first_patch[shape]).to_vec();
    assert_eq!(picks(1), vec![Pick { source: 0, rays: 1 }]);
    assert!(picks(0).is_empty() && picks(3).is_empty() && picks(4).is_empty());
}

#[test]
fn radiance_and_view_criteria_follow_their_thresholds() {
    let s = criteria_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), None);
    let half = |st: &SelectSettings, view: Option<&ViewScale>| {
        let sel = select(&s, &sol, Method::Local, st, view).unwrap();
        verdict(&sel, 1, SourceId::Light(0))
    };
    let st = SelectSettings::default();
    let c = half(&st, None);
    // The point light is the only light on that patch: its share is about 1.
    assert!(c.share > 0.9 && c.radiance, "{c:?}");
    let strict = SelectSettings {
        radiance_threshold: 1.5,
        ..st
    };
    assert!(!half(&strict, None).radiance);
    // Seen from 100 units away through a 1-pixel-per-radian camera, elements of 0.1
    // look 0.001 pixels large: left to the mesh, unless the criterion is off.
    let far = ViewScale {
        eye: v(0.0, 0.0, 100.0),
        pixels_per_radian: 1.0,
    };
    let c = half(&st, Some(&far));
    assert!(!c.view && c.element_pixels < 0.01, "{c:?}");
    let off = SelectSettings {
        view_criterion: false,
        ..st
    };
    assert!(half(&off, Some(&far)).view);
    let near = ViewScale {
        eye: v(-1.5, 0.0, 2.0),
        pixels_per_radian: 500.0,
    };
    assert!(half(&st, Some(&near)).view);
}

#[test]
fn solid_angles_match_the_closed_form_and_set_the_ray_count() {
    // A square of side 2a seen on its axis from distance d: 4 asin(a^2 / (a^2 + d^2)).
    let (a, d) = (0.5f32, 2.0f32);
    let sq = [v(-a, -a, d), v(a, -a, d), v(a, a, d), v(-a, a, d)];
    let tris = [[sq[0], sq[2], sq[1]], [sq[0], sq[3], sq[2]]];
    let expect = 4.0 * (a * a / (a * a + d * d)).asin();
    let got = solid_angle(Vec3::ZERO, &tris);
    assert!((got - expect).abs() < 1e-5 * expect, "{got} vs {expect}");
    // Seen from behind: nothing (the source emits on its front only).
    assert_eq!(solid_angle(v(0.0, 0.0, 4.0), &tris), 0.0);
    // Rays: Omega / 2pi x hemisphere rays, between 1 and area_samples.
    let s = criteria_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), None);
    let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let far = verdict(&sel, 0, SourceId::Light(1));
    let want = (far.solid_angle_sr / (2.0 * PI) * 4096.0)
        .round()
        .clamp(1.0, 64.0) as u32;
    assert_eq!(far.rays, want, "{far:?}");
    assert!(far.solid_angle_sr > 0.0 && far.solid_angle_sr < 0.25);
}

/// A closed box lit by a point light and a small ceiling lamp, with a table that
/// casts shadows from both onto the floor; a camera looking down at the table.
fn room() -> Scene {
    let lo = v(0.0, 0.0, 0.0);
    let hi = v(2.0, 2.0, 2.0);
    let mut shapes: Vec<(crate::geometry::TriMesh, Rgb)> = crate::testutil::box_inside(lo, hi)
        .into_iter()
        .map(|f| (f, Vec3::new(0.6, 0.5, 0.4)))
        .collect();
    shapes.push((square(0.7, 1.3, 0.7, 1.3, 0.8, false), Vec3::splat(0.7)));
    shapes.push((square(0.7, 1.3, 0.7, 1.3, 0.8, true), Vec3::splat(0.7)));
    shapes.push((square(0.8, 1.2, 0.8, 1.2, 1.99, true), Vec3::ZERO));
    let lamp = shapes.len() - 1;
    let mut s = scene(
        shapes,
        vec![Light::Point {
            position: v(0.4, 0.5, 1.6),
            intensity: Vec3::splat(1.5),
        }],
        &[(lamp, Vec3::splat(2.0))],
    );
    s.sensors
        .push(looking(v(1.0, 0.2, 1.7), v(1.0, 1.0, 0.4), 80.0, 48, 48));
    s
}

/// Renders without progress bars.
fn draw(s: &Scene, bvh: &Bvh, st: &Settings, sel: Option<&Selection>) -> Output {
    crate::render::render(s, bvh, st, sel, &crate::render::no_progress).unwrap()
}

fn settings(method: Method) -> Settings {
    Settings {
        method,
        view: 0,
        width: 48,
        height: 48,
        spp: 4,
        seed: 7,
        area_samples: 16,
        max_depth: 2,
        filter: Filter::Box,
        sampler: crate::render::Sampler::Uniform,
        refine: crate::render::Refine::default(),
    }
}

fn image_mean(img: &crate::io::Image) -> f32 {
    img.pixels.iter().map(|p| mean(*p)).sum::<f32>() / img.pixels.len() as f32
}

/// Every method routes each source's light once: the image means agree (within the
/// mesh's interpolation error and noise), and norm's ray-traced light is direct's.
#[test]
fn no_light_is_counted_twice() {
    let s = room();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), None);
    let st = SelectSettings {
        area_samples: 16,
        global_sources: 1,
        ..Default::default()
    };
    let mut means = Vec::new();
    for m in [Method::Twopass, Method::Norm, Method::Local, Method::Global] {
        let sel = select(&s, &sol, m, &st, None).unwrap();
        let out = draw(&s, &bvh, &settings(m), Some(&sel));
        means.push((m, image_mean(&out.image), out.counters.shadow_rays));
    }
    let norm = means[1].1;
    for &(m, mean, _) in &means {
        assert!(
            (mean - norm).abs() < 0.03 * norm,
            "{m:?}: {mean} vs norm {norm} ({means:?})"
        );
    }
    // Twopass casts no shadow rays; norm casts the most.
    assert_eq!(means[0].2, 0);
    assert!(means.iter().all(|&(_, _, r)| r <= means[1].2), "{means:?}");
    // Norm = direct light by rays + indirect light from the mesh (a closed box of
    // reflectance 0.4..0.6 reflects a lot: more than the direct light).
    let direct = draw(&s, &bvh, &settings(Method::Direct), None);
    let d = image_mean(&direct.image);
    assert!(1.5 * d < norm && norm < 5.0 * d, "direct {d} norm {norm}");
}

/// An open scene: a floor and a one-sided table top, both lit by a point light and
/// a lamp above; nothing else reflects onto them, so their lists hold only lights.
fn open_scene() -> Scene {
    let mut s = scene(
        vec![
            (square(-1.0, 1.0, -1.0, 1.0, 0.0, false), Vec3::splat(0.5)),
            (square(-0.3, 0.3, -0.3, 0.3, 0.5, false), Vec3::splat(0.7)),
            (square(0.2, 0.6, 0.2, 0.6, 1.5, true), Vec3::ZERO),
        ],
        vec![Light::Point {
            position: v(-0.5, 0.2, 1.2),
            intensity: Vec3::splat(1.5),
        }],
        &[(2, Vec3::splat(2.0))],
    );
    s.sensors
        .push(looking(v(0.0, -1.5, 1.5), v(0.0, 0.0, 0.2), 70.0, 48, 48));
    s
}

/// Where local selects every listed source with the rays norm uses, the two are the
/// same renderer: the same picture from the same seed.
#[test]
fn norm_and_local_agree_where_every_source_is_selected() {
    let s = open_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), None);
    assert!(sol
        .lists
        .iter()
        .flatten()
        .all(|e| matches!(e.source, SourceId::Light(_))));
    let all = SelectSettings {
        radiance_threshold: 0.0,
        reflectivity_threshold: 0.0,
        gradient_threshold: -1.0,
        max_solid_angle: 100.0,
        hemisphere_rays: 1_000_000,
        view_criterion: false,
        area_samples: 16,
        ..Default::default()
    };
    let norm_sel = select(&s, &sol, Method::Norm, &all, None).unwrap();
    let local_sel = select(&s, &sol, Method::Local, &all, None).unwrap();
    let norm = draw(&s, &bvh, &settings(Method::Norm), Some(&norm_sel));
    let local = draw(&s, &bvh, &settings(Method::Local), Some(&local_sel));
    // Every receiving patch lists both lights, so both methods pick both everywhere.
    for (p, mp) in sol.mesh.patches.iter().enumerate() {
        if mp.reflectance.max_element() > 0.0 && !sol.lists[p].is_empty() {
            let mut a: Vec<Pick> = norm_sel.picks(p as u32).to_vec();
            let mut b: Vec<Pick> = local_sel.picks(p as u32).to_vec();
            a.sort_by_key(|k| k.source);
            b.sort_by_key(|k| k.source);
            assert_eq!(a, b, "patch {p}");
        }
    }
    assert_eq!(norm.counters.shadow_rays, local.counters.shadow_rays);
    for (a, b) in norm.image.pixels.iter().zip(&local.image.pixels) {
        assert!(
            (*a - *b).abs().max_element() <= 1e-5 * (1.0 + a.max_element()),
            "{a} vs {b}"
        );
    }
}

/// A selected radiant patch is sampled with its radiosity: replacing its stored
/// contribution by rays keeps the image mean, and costs rays.
#[test]
fn a_selected_radiant_patch_gives_the_light_it_stored() {
    let s = room();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 8), None);
    let patches_listed = sol
        .lists
        .iter()
        .flatten()
        .filter(|e| matches!(e.source, SourceId::Patch(_)))
        .count();
    assert!(patches_listed > 0);
    let twopass = select(&s, &sol, Method::Twopass, &SelectSettings::default(), None).unwrap();
    let every = SelectSettings {
        radiance_threshold: 0.0,
        reflectivity_threshold: 0.0,
        gradient_threshold: -1.0,
        max_solid_angle: 100.0,
        view_criterion: false,
        area_samples: 64,
        ..Default::default()
    };
    let local = select(&s, &sol, Method::Local, &every, None).unwrap();
    assert!(
        local.sources.len() > s.lights.len(),
        "radiant patches are ray traced"
    );
    let mut st = settings(Method::Local);
    st.spp = 16;
    let a = draw(&s, &bvh, &settings(Method::Twopass), Some(&twopass));
    let b = draw(&s, &bvh, &st, Some(&local));
    let (ma, mb) = (image_mean(&a.image), image_mean(&b.image));
    assert!((ma - mb).abs() < 0.03 * ma, "twopass {ma} vs all selected {mb}");
    let patch_rays: u64 = b.counters.sources[s.lights.len()..]
        .iter()
        .map(|c| c.shadow_rays)
        .sum();
    assert!(patch_rays > 0);
}

#[test]
fn per_object_selection_shares_one_choice_across_an_objects_patches() {
    let s = room();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 2), None);
    let per_patch = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let object = SelectSettings {
        per: SelectPer::Object,
        ..Default::default()
    };
    let per_object = select(&s, &sol, Method::Local, &object, None).unwrap();
    // Every patch of a shape picks the union of what its patches picked.
    for (shape, _) in s.shapes.iter().enumerate() {
        let patches: Vec<u32> = (0..sol.mesh.patches.len() as u32)
            .filter(|&p| sol.mesh.patches[p as usize].shape == shape as u32)
            .collect();
        let mut union: Vec<u32> = patches
            .iter()
            .flat_map(|&p| per_patch.picks(p).iter().map(|k| k.source))
            .collect();
        union.sort_unstable();
        union.dedup();
        for &p in &patches {
            let listed: Vec<u32> = sol.lists[p as usize]
                .iter()
                .map(|e| match e.source {
                    SourceId::Light(l) => l,
                    SourceId::Patch(_) => u32::MAX,
                })
                .collect();
            let mut got: Vec<u32> = per_object.picks(p).iter().map(|k| k.source).collect();
            got.sort_unstable();
            let want: Vec<u32> = union.iter().copied().filter(|u| listed.contains(u)).collect();
            assert_eq!(got, want, "shape {shape} patch {p}");
        }
    }
    assert!(per_object.pick_count() >= per_patch.pick_count());
}

#[test]
fn norm_needs_every_light_kept_apart() {
    let s = room();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.2, 1), None);
    let err = select(&s, &sol, Method::Norm, &SelectSettings::default(), None)
        .err()
        .expect("n = 1 < 2 lights")
        .to_string();
    assert!(err.contains("--sources-per-patch 2"), "{err}");
    assert!(select(&s, &sol, Method::Local, &SelectSettings::default(), None).is_ok());
}

/// A radiant patch's solid angle comes from its flat domain (one or two triangles),
/// and equals that of its elements, from in front and from the side.
#[test]
fn patch_source_solid_angle_from_the_domain_equals_the_elements() {
    let rho = Vec3::splat(0.5);
    let sc = scene(
        vec![
            (square(-1.0, 1.0, -1.0, 1.0, 0.0, false), rho),
            (crate::geometry::shapes::rectangle(), rho),
        ],
        vec![],
        &[],
    );
    let sol = solve(&sc, &Bvh::build(&sc), &solve_settings(0.2, 4), None);
    let p = sol.mesh.shape_first_patch[0];
    let flat = source_triangles(&sc, &sol, SourceId::Patch(p));
    assert_eq!(flat.len(), 2);
    let elements: Vec<[Vec3; 3]> = sol
        .mesh
        .element_triangles(p)
        .iter()
        .map(|t| t.map(|i| sol.mesh.vertices[i as usize].p))
        .collect();
    assert!(elements.len() >= 200, "{}", elements.len());
    for x in [
        v(0.0, 0.0, 1.0),
        v(0.3, -0.2, 0.05),
        v(3.0, 1.0, 2.0),
        v(0.0, 0.0, -1.0),
    ] {
        let (a, b) = (solid_angle(x, &flat), solid_angle(x, &elements));
        assert!((a - b).abs() <= 1e-4 * b.max(1e-3), "{x}: {a} vs {b}");
    }
    assert!(solid_angle(v(0.0, 0.0, 1.0), &flat) > 1.0);
}
