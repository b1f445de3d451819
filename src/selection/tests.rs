use super::*;
use crate::accel::Bvh;
use crate::geometry::front_solid_angle as solid_angle;
use crate::radiosity::{solve, SolveSettings};
use crate::testutil::{room, scene, square, v};
use std::f32::consts::PI;

/// Pass 1 settings of the selection and rendering tests.
pub(crate) fn solve_settings(mesh_size: f32, n: u32) -> SolveSettings {
    SolveSettings {
        mesh_size,
        sources_per_patch: n,
        shoot_samples: 64,
        tolerance: 0.01,
        max_shots: 40,
        seed: 1,
        photons: 0,
        max_photons: 0,
        time_limit: 0.0,
        gathered: false,
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
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
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
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
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
        scale: PixelScale {
            per_unit: 1.0,
            parallel: false,
        },
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
        scale: PixelScale {
            per_unit: 500.0,
            parallel: false,
        },
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
    let got = Subtense::new(tris.to_vec()).from(Vec3::ZERO);
    assert!((got - expect).abs() < 1e-5 * expect, "{got} vs {expect}");
    // Seen from behind: nothing (the source emits on its front only).
    assert_eq!(Subtense::new(tris.to_vec()).from(v(0.0, 0.0, 4.0)), 0.0);
    // Rays: Omega / 2pi x hemisphere rays, between 1 and area_samples.
    let s = criteria_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
    let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let far = verdict(&sel, 0, SourceId::Light(1));
    let want = (far.solid_angle_sr / (2.0 * PI) * 4096.0)
        .round()
        .clamp(1.0, 64.0) as u32;
    assert_eq!(far.rays, want, "{far:?}");
    assert!(far.solid_angle_sr > 0.0 && far.solid_angle_sr < 0.25);
}

#[test]
fn per_object_selection_shares_one_choice_across_an_objects_patches() {
    let s = room();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 2), &crate::progress::Silent).unwrap();
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
    let sol = solve(&s, &bvh, &solve_settings(0.2, 1), &crate::progress::Silent).unwrap();
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
    let sol = solve(
        &sc,
        &Bvh::build(&sc),
        &solve_settings(0.2, 4),
        &crate::progress::Silent,
    )
    .unwrap();
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

/// The progressive display's selections keep one route per source: on every vertex,
/// what `only(keep)` stores plus the stored (occluded) light of the sources it still
/// ray traces there is the whole radiosity of `twopass`; with nothing kept it stores
/// that, with everything kept it is the selection itself. The strongest source comes
/// first (the point light sends 4 pi 10 W, the area light pi x 1.44 W).
#[test]
fn a_selection_of_the_strongest_sources_keeps_one_route_per_source() {
    let s = criteria_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
    let set = SelectSettings::default();
    let full = select(&s, &sol, Method::Norm, &set, None).unwrap();
    let whole = select(&s, &sol, Method::Twopass, &set, None).unwrap().stored;
    let ranked = full.ranked(&s);
    assert_eq!(ranked, vec![0, 1]);
    let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 1e-5 * b.abs().max_element().max(1e-3);
    for k in 0..=ranked.len() {
        let sel = full.only(&ranked[..k]);
        assert!(sel.picks.iter().all(|p| ranked[..k].contains(&p.source)));
        let mut sum = sel.stored.clone();
        for (p, mp) in sol.mesh.patches.iter().enumerate() {
            let first = mp.first_vertex as usize;
            // (`norm` picks every light on every patch, also where one never arrived
            // and is not listed: it brings nothing there.)
            for pick in sel.picks(p as u32) {
                let source = sel.sources[pick.source as usize];
                let Some(e) = sol.lists[p].iter().find(|e| e.source == source) else {
                    continue;
                };
                for (i, c) in e.occluded.iter().enumerate() {
                    sum[first + i] += *c;
                }
            }
        }
        assert!(
            sum.iter().zip(&whole).all(|(&a, &b)| close(a, b)),
            "{k} kept: stored plus traced differs from the whole radiosity"
        );
        if k == 0 {
            assert!(sel.picks.is_empty());
        }
    }
    let all = full.only(&ranked);
    assert_eq!(
        (all.picks, all.offsets, all.stored),
        (full.picks.clone(), full.offsets.clone(), full.stored.clone())
    );
    // The point light is ray traced somewhere, so the first step differs from the last.
    assert!(full.picks.iter().any(|p| p.source == 0));
}

/// On a sphere under a point light, fully visible to it, the gradient criterion
/// still passes the light where its unoccluded light turns with the normal by more
/// than a fifth over the patch (the mesh flattens that: on a sphere's pieces, a
/// quarter of a cube face each, it always does), but not on a flat floor lit evenly.
#[test]
fn the_gradient_criterion_passes_a_light_whose_falloff_a_curved_patch_flattens() {
    use crate::geometry::shapes;
    let rho = Vec3::splat(0.5);
    let s = scene(
        vec![
            (shapes::sphere(v(0.0, 0.0, 0.0), 0.5), rho),
            (square(3.0, 3.5, -0.25, 0.25, -0.5, false), rho),
        ],
        vec![Light::Point {
            position: v(0.0, 0.0, 6.0),
            intensity: Vec3::splat(10.0),
        }],
        &[],
    );
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
    let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let light = SourceId::Light(0);
    let mut curved = 0;
    let first = sol.mesh.shape_first_patch[0] as usize;
    for p in first..first + 24 {
        let Some((_, c)) = sel.criteria[p].iter().find(|(s, _)| *s == light) else {
            continue;
        };
        let entry = sol.lists[p].iter().find(|e| e.source == light).unwrap();
        let u: Vec<f32> = entry.unoccluded.iter().map(|u| mean(*u)).collect();
        let (lo, hi) = u
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
        if c.visibility_spread > 0.0 || hi <= 0.0 {
            continue;
        }
        // Fully visible: only the falloff decides.
        assert_eq!(c.gradient, lo < 0.8 * hi, "patch {p}: {lo} .. {hi}");
        curved += usize::from(c.gradient);
    }
    // The four pieces of the face towards the light.
    assert!(curved >= 4, "{curved} passed");
    let floor = verdict(&sel, 1, light);
    assert!(!floor.gradient, "{floor:?}");
}

/// A lamp 12 cm over a floor lights a spot smaller than the floor's elements: no
/// shadow anywhere (the visibility spread is 0), but the elements' interpolation of
/// its light is far off at their centres, so the gradient criterion ray traces it. A
/// point light 3 m over another floor lights it smoothly: left to the mesh. The
/// interpolation error falls as the elements shrink. (The lamp's floor is 6 m
/// across, over the elements a patch near a light is meshed finer at, see
/// `mesh::near_light`.)
#[test]
fn a_lamp_close_to_a_floor_is_ray_traced_where_its_light_falls_off_within_an_element() {
    let rho = Vec3::splat(0.5);
    let s = scene(
        vec![
            (square(0.0, 6.0, 0.0, 6.0, 0.0, false), rho),
            (square(20.0, 24.0, 0.0, 4.0, 0.0, false), rho),
            (square(0.3, 0.5, 0.3, 0.5, 0.12, true), Vec3::ZERO),
        ],
        vec![Light::Point {
            position: v(22.0, 2.0, 3.0),
            intensity: Vec3::splat(20.0),
        }],
        &[(2, Vec3::splat(5.0))],
    );
    let bvh = Bvh::build(&s);
    let (point, lamp) = (SourceId::Light(0), SourceId::Light(1));
    let verdicts = |mesh_size: f32| {
        let sol = solve(&s, &bvh, &solve_settings(mesh_size, 4), &crate::progress::Silent).unwrap();
        let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
        (verdict(&sel, 0, lamp), verdict(&sel, 1, point))
    };
    let (near, far) = verdicts(0.5);
    assert!(
        near.visibility_spread == 0.0 && near.falloff_error > 0.5,
        "{near:?}"
    );
    assert!(near.gradient && near.selected(), "{near:?}");
    assert!(
        far.visibility_spread == 0.0 && far.falloff_error < 0.03,
        "{far:?}"
    );
    assert!(!far.gradient && !far.selected(), "{far:?}");
    // Measured: 0.95 at elements of 0.5, 0.30 at 0.1, 0.14 at 0.05.
    let (fine, _) = verdicts(0.1);
    let (finer, _) = verdicts(0.05);
    assert!(
        fine.falloff_error < near.falloff_error / 2.0,
        "{fine:?} vs {near:?}"
    );
    assert!(
        finer.falloff_error < fine.falloff_error / 1.5,
        "{finer:?} vs {fine:?}"
    );
}
