//! The renderer with a selection: each source's light arrives by one route, whatever
//! the method.

use glam::Vec3;

use super::*;
use crate::accel::Bvh;
use crate::radiosity::{solve, SolveSettings, SourceId};
use crate::scene::mean;
use crate::selection::tests::solve_settings;
use crate::selection::{select, select_unchecked, Pick, SelectSettings};
use crate::testutil::{open_scene, room};

/// Renders without progress bars.
fn draw(s: &Scene, bvh: &Bvh, st: &Settings, sel: Option<&Selection>) -> Output {
    render(s, bvh, st, sel, &crate::progress::Silent).unwrap()
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
        gather: 0,
        filter: Filter::Box,
        sampler: Sampler::Uniform,
        refine: Refine::default(),
    }
}

/// The centres of a 4 x 4 grid over pixel (x, y), in film coordinates: where the
/// closed-form tests evaluate what a pixel should show.
fn subpixels(x: usize, y: usize) -> impl Iterator<Item = (f32, f32)> {
    (0..16).map(move |k| {
        (
            x as f32 + (k % 4) as f32 / 4.0 + 0.125,
            y as f32 + (k / 4) as f32 / 4.0 + 0.125,
        )
    })
}

fn image_mean(img: &crate::image::Image) -> f32 {
    img.pixels.iter().map(|p| mean(*p)).sum::<f32>() / img.pixels.len() as f32
}

/// Every method routes each source's light once: the image means agree (within the
/// mesh's interpolation error and noise), and norm's ray-traced light is direct's.
#[test]
fn no_light_is_counted_twice() {
    let s = room();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
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

/// Where local selects every listed source with the rays norm uses, the two are the
/// same renderer: the same picture from the same seed.
#[test]
fn norm_and_local_agree_where_every_source_is_selected() {
    let s = open_scene();
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 4), &crate::progress::Silent).unwrap();
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
    let norm_sel = select_unchecked(&s, &sol, Method::Norm, &all, None).unwrap();
    let local_sel = select_unchecked(&s, &sol, Method::Local, &all, None).unwrap();
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
    let sol = solve(&s, &bvh, &solve_settings(0.1, 8), &crate::progress::Silent).unwrap();
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
    let local = select_unchecked(&s, &sol, Method::Local, &every, None).unwrap();
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

/// `global` ray traces a source only where the solve kept it apart: with one source
/// kept per patch (of two lights), the other one is in the general radiosity there and
/// must not be ray traced on top of it.
#[test]
fn global_traces_a_light_only_where_it_is_kept_apart() {
    // The lamp as strong as the point light, so that each is kept apart on some
    // patches and folded on others.
    let mut s = room();
    assert_eq!(s.lights.len(), 2);
    if let crate::scene::Light::Area { radiance, .. } = &mut s.lights[1] {
        *radiance = Vec3::splat(40.0);
    }
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.1, 1), &crate::progress::Silent).unwrap();
    let st = SelectSettings {
        area_samples: 16,
        global_sources: 1000,
        ..Default::default()
    };
    let twopass = select(&s, &sol, Method::Twopass, &st, None).unwrap();
    let global = select(&s, &sol, Method::Global, &st, None).unwrap();
    for p in 0..sol.mesh.patches.len() {
        for k in global.picks(p as u32) {
            let id = global.sources[k.source as usize];
            assert!(
                sol.lists[p].iter().any(|e| e.source == id),
                "patch {p}: {id:?} not listed"
            );
        }
    }
    let a = image_mean(&draw(&s, &bvh, &settings(Method::Twopass), Some(&twopass)).image);
    let b = image_mean(&draw(&s, &bvh, &settings(Method::Global), Some(&global)).image);
    assert!((a - b).abs() < 0.03 * a, "twopass {a} vs global {b}");
}

/// The message of a usage error, or a panic.
fn usage<T>(r: crate::Result<T>) -> String {
    match r {
        Err(crate::Error::Usage(m)) => m,
        Err(e) => panic!("expected a usage error, got {e}"),
        Ok(_) => panic!("expected a usage error, got success"),
    }
}

/// The library's entry points refuse bad settings with the command line's one-line
/// error, whoever calls them (CLI, bench, fuzz targets, library users).
#[test]
fn entry_points_refuse_bad_settings_with_the_flags_message() {
    let s = room();
    let bvh = Bvh::build(&s);
    let quiet = &crate::progress::Silent;
    // render::render
    let bad = |f: fn(&mut Settings)| {
        let mut st = settings(Method::Direct);
        f(&mut st);
        usage(render(&s, &bvh, &st, None, quiet))
    };
    assert_eq!(bad(|st| st.width = 0), "--width 0: must be at least 1");
    assert_eq!(bad(|st| st.height = 0), "--height 0: must be at least 1");
    assert_eq!(bad(|st| st.spp = 0), "--spp 0: must be at least 1");
    assert_eq!(
        bad(|st| st.area_samples = 0),
        "--area-samples 0: must be at least 1"
    );
    assert_eq!(
        bad(|st| st.refine.contrast = 2.0),
        "--contrast 2: must be between 0 and 1"
    );
    assert_eq!(
        bad(|st| st.refine.contrast = f32::NAN),
        "--contrast NaN: must be between 0 and 1"
    );
    assert_eq!(
        bad(|st| st.refine.max_level = 5),
        "--max-level 5: must be at most 4"
    );
    // radiosity::solve
    let bad = |f: fn(&mut SolveSettings)| {
        let mut st = solve_settings(0.1, 4);
        f(&mut st);
        usage(solve(&s, &bvh, &st, quiet))
    };
    assert_eq!(
        bad(|st| st.mesh_size = 0.0),
        "--mesh-size 0: must be a positive length"
    );
    assert_eq!(
        bad(|st| st.mesh_size = -1.0),
        "--mesh-size -1: must be a positive length"
    );
    assert_eq!(
        bad(|st| st.tolerance = 2.0),
        "--solve-tolerance 2: must be a fraction between 0 and 1"
    );
    assert_eq!(
        bad(|st| st.shoot_samples = 0),
        "--shoot-samples 0: must be at least 1"
    );
    // selection::select
    let sol = solve(&s, &bvh, &solve_settings(0.2, 4), quiet).unwrap();
    let bad = |f: fn(&mut SelectSettings)| {
        let mut st = SelectSettings::default();
        f(&mut st);
        usage(select(&s, &sol, Method::Local, &st, None))
    };
    assert_eq!(
        bad(|st| st.reflectivity_threshold = 2.0),
        "--reflectivity-threshold 2: must be between 0 and 1"
    );
    assert_eq!(
        bad(|st| st.radiance_threshold = -1.0),
        format!("--radiance-threshold -1: must be between 0 and {}", f32::MAX)
    );
    assert_eq!(
        bad(|st| st.max_solid_angle = 20.0),
        "--max-solid-angle 20: must be between 0 and 12.566371"
    );
    assert_eq!(
        bad(|st| st.hemisphere_rays = 0),
        "--hemisphere-rays 0: must be at least 1"
    );
}

/// The gather in a closed box whose surfaces all have radiosity c (and no lists):
/// every gather ray meets a wall of radiosity c, so the irradiance is c at every point
/// and each pixel shows rho c / pi, the closed form, whether a hit read the records
/// made at the screen's grid or gathered anew.
#[test]
fn a_gather_in_a_box_of_constant_radiosity_gives_the_closed_form() {
    use crate::radiosity::{Solution, SolveStats};
    use crate::testutil::{box_inside, looking, scene, v};
    let rho = Vec3::new(0.6, 0.5, 0.4);
    let shapes = box_inside(v(0.0, 0.0, 0.0), v(2.0, 3.0, 1.5))
        .into_iter()
        .map(|f| (f, rho))
        .collect();
    let mut s = scene(shapes, Vec::new(), &[]);
    s.sensors
        .push(looking(v(0.3, 0.4, 1.2), v(1.8, 2.5, 0.1), 70.0, 40, 32));
    let bvh = Bvh::build(&s);
    let mesh = crate::mesh::RadiosityMesh::build_covered(&s, 0.25, &bvh);
    let c = Vec3::new(2.0, 1.0, 0.5);
    let sol = Solution {
        general: vec![c; mesh.vertices.len()],
        caustic: Vec::new(),
        lists: vec![Vec::new(); mesh.patches.len()],
        mesh,
        settings: solve_settings(0.25, 4),
        stats: SolveStats::default(),
    };
    let sel = select(&s, &sol, Method::Twopass, &SelectSettings::default(), None).unwrap();
    let mut st = settings(Method::Twopass);
    st.width = 40;
    st.height = 32;
    st.gather = 16;
    st.filter = Filter::Box;
    let out = draw(&s, &bvh, &st, Some(&sel));
    let want = rho * c * std::f32::consts::FRAC_1_PI;
    for p in &out.image.pixels {
        assert!(
            (*p - want).abs().max_element() < 1e-4 * want.max_element(),
            "{p} vs {want}"
        );
    }
    let n = &out.counters;
    assert_eq!(n.gather_records, 10 * 8);
    assert!(n.gather_reused > 0 && n.gather_reused < n.diffuse_hits, "{n:?}");
    // Without the gather, the pixels show the stored c / pi instead.
    st.gather = 0;
    let plain = draw(&s, &bvh, &st, Some(&sel));
    // `direct` has no solution to gather from: a clear error, not a silent no-op.
    let mut direct = settings(Method::Direct);
    direct.gather = 16;
    let err = render(&s, &bvh, &direct, None, &crate::progress::Silent).unwrap_err();
    assert!(err.to_string().contains("--method direct"), "{err}");
    let stored = sol.general[0] * std::f32::consts::FRAC_1_PI;
    assert!((plain.image.pixels[0] - stored).abs().max_element() < 1e-4 * stored.max_element());
}

/// The gather replaces the general radiosity without counting a source twice or
/// losing one: in the closed room (a point light and a lamp, photons carrying what
/// the shots leave, so that the solution is converged), the image means with and
/// without it agree, with both lights on every list (n = 4) and with one of them
/// folded into the general radiosity of each patch (n = 1: the gather then samples
/// the folded light with shadow rays).
#[test]
fn the_gather_keeps_each_source_to_one_route() {
    let s = room();
    let bvh = Bvh::build(&s);
    for n in [4, 1] {
        let solve_st = SolveSettings {
            photons: 256,
            ..solve_settings(0.1, n)
        };
        let sol = solve(&s, &bvh, &solve_st, &crate::progress::Silent).unwrap();
        let short = sol.lists.iter().filter(|l| l.len() < 2).count();
        assert_eq!(n == 1, short == sol.lists.len(), "n = {n}: {short} short lists");
        for m in [Method::Twopass, Method::Local] {
            let sel = select(&s, &sol, m, &SelectSettings::default(), None).unwrap();
            let mut st = settings(m);
            st.width = 96;
            st.height = 96;
            st.spp = 1;
            let plain = image_mean(&draw(&s, &bvh, &st, Some(&sel)).image);
            st.gather = 64;
            let out = draw(&s, &bvh, &st, Some(&sel));
            let gathered = image_mean(&out.image);
            assert!(out.counters.gather_rays > 0);
            // The lamp's direct light is 5 % of the mean, the point light's 30 %: a
            // source counted twice or lost would show. (Measured: within 0.9 %.)
            assert!(
                (gathered - plain).abs() < 0.02 * plain,
                "n = {n}, {m:?}: {gathered} with the gather, {plain} without"
            );
        }
    }
}

/// A sphere under a point light renders as the closed form `rho / pi * I cos / d^2`
/// of the true sphere: every pixel well inside its silhouette within 1%, and the
/// whole image (silhouette pixels included) within 1%.
#[test]
fn a_sphere_renders_as_the_closed_form_of_the_true_sphere() {
    use crate::geometry::shapes;
    let (r, rho, i0) = (1.0f32, 0.6f32, 10.0f32);
    let light = Vec3::new(0.0, 3.0, 3.0);
    let mut s = crate::testutil::scene(
        vec![(shapes::sphere(Vec3::ZERO, r), Vec3::splat(rho))],
        vec![crate::scene::Light::Point {
            position: light,
            intensity: Vec3::splat(i0),
        }],
        &[],
    );
    s.sensors.push(crate::testutil::looking(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::ZERO,
        40.0,
        48,
        48,
    ));
    let bvh = Bvh::build(&s);
    let mut st = settings(Method::Direct);
    st.spp = 64;
    let img = draw(&s, &bvh, &st, None).image;
    // The closed form at film position (x, y), from the quadratic in world space.
    let cam = crate::camera::Camera::new(&s.sensors[0], 48, 48);
    let at = |x: f32, y: f32| -> Option<f32> {
        let ray = cam.ray(x, y);
        let b = ray.origin.dot(ray.dir);
        let disc = b * b - (ray.origin.length_squared() - r * r);
        if disc < 0.0 {
            return None;
        }
        let p = ray.origin + ray.dir * (-b - disc.sqrt());
        let to = light - p;
        let cos = (p / r).dot(to.normalize()).max(0.0);
        Some(rho / std::f32::consts::PI * i0 * cos / to.length_squared())
    };
    let (mut want_sum, mut got_sum, mut inner) = (0.0, 0.0, 0);
    for y in 0..48 {
        for x in 0..48 {
            let sub: Vec<Option<f32>> = subpixels(x, y).map(|(fx, fy)| at(fx, fy)).collect();
            let want = sub.iter().map(|v| v.unwrap_or(0.0)).sum::<f32>() / 16.0;
            let got = img.pixels[y * 48 + x].x;
            want_sum += want;
            got_sum += got;
            // Well inside and well lit: the pixels around it on the sphere too, and
            // far from the terminator.
            let (fx, fy) = (x as f32, y as f32);
            let clear = [(-1.0, -1.0), (2.0, -1.0), (-1.0, 2.0), (2.0, 2.0)]
                .iter()
                .all(|&(dx, dy)| at(fx + dx, fy + dy).is_some_and(|v| v > 0.5 * want));
            if clear && want > 0.05 {
                inner += 1;
                assert!(
                    (got / want - 1.0).abs() < 0.01,
                    "pixel ({x}, {y}): {got} vs {want}"
                );
            }
        }
    }
    assert!(inner > 300, "{inner} inner pixels");
    assert!(
        (got_sum / want_sum - 1.0).abs() < 0.01,
        "image {got_sum} vs {want_sum}"
    );
}

/// A lamp 12 cm over a floor of 0.5 m elements: `local` ray traces it there (its light
/// falls off within an element, see the selection's gradient criterion), so the floor
/// round the lamp shows Lambert's closed form `rho / pi * pi L F(x -> lamp)` within
/// 2 % (measured 0.8 %), where the elements' interpolation was up to 4.3 times off (the
/// test fails so without the falloff test). Nothing else reflects onto the floor:
/// there is no indirect light.
#[test]
fn the_floor_round_a_lamp_close_to_it_shows_the_closed_form() {
    use crate::geometry::point_polygon_form_factor;
    use crate::testutil::{scene, square, v};
    let (rho, le) = (0.5f32, 5.0f32);
    let lamp = [
        v(0.3, 0.3, 0.12),
        v(0.5, 0.3, 0.12),
        v(0.5, 0.5, 0.12),
        v(0.3, 0.5, 0.12),
    ];
    let mut s = scene(
        vec![
            (square(0.0, 4.0, 0.0, 4.0, 0.0, false), Vec3::splat(rho)),
            (square(0.3, 0.5, 0.3, 0.5, 0.12, true), Vec3::ZERO),
        ],
        vec![],
        &[(1, Vec3::splat(le))],
    );
    let (eye, target) = (v(1.6, 0.9, 1.1), v(0.4, 0.4, 0.0));
    s.sensors
        .push(crate::testutil::looking(eye, target, 50.0, 48, 48));
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.5, 4), &crate::progress::Silent).unwrap();
    let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let mut st = settings(Method::Local);
    st.spp = 16;
    st.area_samples = 64;
    let img = draw(&s, &bvh, &st, Some(&sel)).image;
    let cam = crate::camera::Camera::new(&s.sensors[0], 48, 48);
    // The floor point a film position sees, unless the lamp or nothing is in the way.
    let floor = |x: f32, y: f32| -> Option<Vec3> {
        let ray = cam.ray(x, y);
        let over_lamp = |t: f32| {
            let p = ray.origin + ray.dir * t;
            (0.3..=0.5).contains(&p.x) && (0.3..=0.5).contains(&p.y)
        };
        let t = -ray.origin.z / ray.dir.z;
        let p = ray.origin + ray.dir * t;
        let on = t > 0.0 && (0.0..=4.0).contains(&p.x) && (0.0..=4.0).contains(&p.y);
        (on && !over_lamp((0.12 - ray.origin.z) / ray.dir.z)).then_some(p)
    };
    // Seen from below, the lamp's corners wind the other way round.
    let seen = [lamp[0], lamp[3], lamp[2], lamp[1]];
    let want_at = |p: Vec3| {
        rho / std::f32::consts::PI * std::f32::consts::PI * le * point_polygon_form_factor(p, Vec3::Z, &seen)
    };
    let (mut checked, mut worst) = (0, 0.0f32);
    for y in 0..48 {
        for x in 0..48 {
            let pts: Option<Vec<Vec3>> = subpixels(x, y).map(|(fx, fy)| floor(fx, fy)).collect();
            let Some(pts) = pts else { continue };
            let want = pts.iter().map(|&p| want_at(p)).sum::<f32>() / 16.0;
            // Only where the lamp's light is well above the noise and near it.
            if want < 0.05 {
                continue;
            }
            let got = img.pixels[y * 48 + x].x;
            worst = worst.max((got / want - 1.0).abs());
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked} pixels checked");
    assert!(worst < 0.02, "worst pixel off by {worst}");
}

/// A texture scales what a surface reflects point by point, and pass 1 reads it per
/// vertex: the room's walls given a two-texel texture (1.5 and 0.5 times rho; an
/// untextured quad reads its barycentrics as (u, v), so u < 0.5, texel 0, on 3/4 of
/// each triangle, and the mean is 1.25 rho) against walls of that mean, with only the
/// lights' shots, so that both solves see the same irradiance. Pass 1: each vertex's
/// radiosity is the plain one times the texture's mean about the vertex over 1.25 rho,
/// 1.2 for a vertex amid texel 0 and 0.4 amid texel 1 (so light bleeds from the part
/// of a wall it leaves), and the walls' mean over their vertices is the texture's.
/// Render: each pixel is the plain one times its texel over the mean (1.2 or 0.4)
/// where its element's vertices agree, within 1 % of that elsewhere; the table and
/// the lamp (untextured) stay as they were.
#[test]
fn a_texture_scales_what_a_surface_reflects_by_its_texel_over_its_vertices_mean() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{BsdfKind, TexField, Texture};
    let rho = Vec3::new(0.6, 0.5, 0.4);
    let mut plain = room();
    for b in &mut plain.bsdfs {
        if b.kind == (BsdfKind::Diffuse { reflectance: rho }) {
            b.kind = BsdfKind::Diffuse {
                reflectance: rho * 1.25,
            };
        }
    }
    let mut textured = room();
    let mut t =
        Texture::from_linear("t", 2, 1, vec![(rho * 1.5).to_array(), (rho * 0.5).to_array()]).unwrap();
    t.filter = TexFilter::Nearest;
    assert!((t.mean - rho).abs().max_element() < 1e-6);
    textured.textures.push(t);
    let mut walls = 0;
    for b in &mut textured.bsdfs {
        if b.kind == (BsdfKind::Diffuse { reflectance: rho }) {
            b.textures.push(crate::testutil::slot(TexField::Diffuse, 0));
            walls += 1;
        }
    }
    assert_eq!(walls, 6);
    let st = SolveSettings {
        max_shots: 0,
        ..solve_settings(0.1, 4)
    };
    let (bp, bt) = (Bvh::build(&plain), Bvh::build(&textured));
    let sp = solve(&plain, &bp, &st, &crate::progress::Silent).unwrap();
    let stx = solve(&textured, &bt, &st, &crate::progress::Silent).unwrap();
    let (tp, tt) = (sp.total(), stx.total());
    assert_eq!(tp.len(), tt.len());
    let textured_shape = |p: u32| {
        let shape = &textured.shapes[stx.mesh.patches[p as usize].shape as usize];
        !textured.bsdfs[shape.bsdf as usize].textures.is_empty()
    };
    let (mut amid0, mut amid1, mut lit) = (0, 0, 0);
    let (mut rho_sum, mut area) = (Vec3::ZERO, 0.0);
    for (i, (x, y)) in tp.iter().zip(&tt).enumerate() {
        let v = stx.mesh.vertices[i];
        if !textured_shape(v.patch) {
            assert!(
                (*x - *y).abs().max_element() <= 1e-5 * x.max_element().max(1e-3),
                "{x} {y}"
            );
            continue;
        }
        rho_sum += stx.mesh.albedo(i as u32) * v.area;
        area += v.area;
        if x.max_element() < 1e-4 {
            continue;
        }
        lit += 1;
        let r = *y / *x;
        assert!(
            r.min_element() > 0.4 - 1e-4 && r.max_element() < 1.2 + 1e-4,
            "vertex {i}: {y} over {x}"
        );
        amid0 += usize::from((r - Vec3::splat(1.2)).abs().max_element() < 1e-4);
        amid1 += usize::from((r - Vec3::splat(0.4)).abs().max_element() < 1e-4);
    }
    assert!(amid0 > lit / 4 && amid1 > lit / 20, "{amid0} {amid1} of {lit}");
    let mean_rho = rho_sum / area;
    assert!(
        (mean_rho - rho * 1.25).abs().max_element() < 0.03 * rho.max_element(),
        "{mean_rho}"
    );
    let sel = SelectSettings {
        area_samples: 16,
        ..Default::default()
    };
    let mut rs = settings(Method::Local);
    rs.refine = Refine {
        max_level: 0,
        sib: false,
        ..Refine::default()
    };
    let a = draw(
        &plain,
        &bp,
        &rs,
        Some(&select(&plain, &sp, Method::Local, &sel, None).unwrap()),
    );
    let b = draw(
        &textured,
        &bt,
        &rs,
        Some(&select(&textured, &stx, Method::Local, &sel, None).unwrap()),
    );
    let (mut high, mut low, mut same) = (0, 0, 0);
    for (p, q) in a.image.pixels.iter().zip(&b.image.pixels) {
        if p.min_element() <= 1e-4 {
            continue;
        }
        let r = *q / *p;
        // (Where the vertices' albedos differ, the radiosity's interpolation over
        // theirs leans a little to where the light is: within 1 %.)
        assert!(
            r.min_element() > 0.4 * 0.99 && r.max_element() < 1.2 * 1.01,
            "{q} over {p}"
        );
        let near = |k: f32| (r - Vec3::splat(k)).abs().max_element() < 1e-3;
        high += usize::from(near(1.2));
        low += usize::from(near(0.4));
        same += usize::from(near(1.0));
    }
    let n = a.image.pixels.len();
    assert!(
        high > n / 4 && low > n / 20 && same > n / 50,
        "{high} {low} {same} of {n}"
    );
}

/// The radiance scene `s`, solved with `solve_st` and selected with the defaults, sends
/// from the origin towards `eye`, averaged over `n` render seeds.
fn mean_radiance_at_origin(s: &Scene, solve_st: &SolveSettings, eye: Vec3, n: u32) -> f32 {
    let bvh = Bvh::build(s);
    let sol = solve(s, &bvh, solve_st, &crate::progress::Silent).unwrap();
    let sel = select(s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    let st = settings(Method::Local);
    let tracer = crate::render::Tracer::with_selection(s, &bvh, &st, &sel);
    let ray = crate::accel::Ray::new(eye, -eye.normalize());
    let mut c = crate::render::Counters::default();
    (0..n).map(|k| tracer.radiance(&ray, 0, k, &mut c).x).sum::<f32>() / n as f32
}

/// A 6 x 6 m floor of `floor` at z = 0 under a 0.4 x 0.4 m square lamp of radiance 5
/// at height 1, nothing else, seen from (-0.5, 0, 1) towards the origin (so that the
/// lamp sits in a lobe's peak): the radiance the tracer returns, averaged over 4000
/// seeds, and a fine quadrature over the lamp of `brdf(wi, wo)` x Le x cos x cos / r^2.
fn floor_under_a_lamp(floor: crate::scene::BsdfKind, brdf: impl Fn(Vec3, Vec3) -> f32) -> (f32, f32) {
    use crate::scene::BsdfKind;
    use crate::testutil::{scene_with, square};
    let (x0, x1, y0, y1, h) = (0.3f32, 0.7, -0.2, 0.2, 1.0);
    let le = 5.0f32;
    let s = scene_with(
        vec![
            (square(-3.0, 3.0, -3.0, 3.0, 0.0, false), floor),
            (
                square(x0, x1, y0, y1, h, true),
                BsdfKind::Diffuse {
                    reflectance: Vec3::ZERO,
                },
            ),
        ],
        vec![],
        &[(1, Vec3::splat(le))],
    );
    let eye = Vec3::new(-0.5, 0.0, 1.0);
    let est = mean_radiance_at_origin(&s, &solve_settings(0.2, 4), eye, 4000);
    (
        est,
        crate::testutil::lamp_integral([x0, x1, y0, y1], h, le, eye.normalize(), brdf),
    )
}

/// A glossy floor under a small square lamp, nothing else: the radiance the floor
/// reflects towards a viewer, averaged over many seeds, is the lobe integrated over
/// the lamp, for a wide and a sharp lobe: the lamp's light samples and the lobe's
/// rays that meet it, weighed against each other, count it once.
#[test]
fn a_glossy_floor_reflects_an_area_light_once_by_light_samples_and_lobe_rays() {
    use crate::scene::{BsdfKind, Fresnel, Glossy, Microfacet};
    for alpha in [0.4f32, 0.08] {
        let lobe = Glossy {
            distribution: Microfacet {
                alpha_u: alpha,
                alpha_v: alpha,
                beckmann: false,
            },
            fresnel: Fresnel::Schlick { f0: Vec3::splat(0.9) },
            scale: Vec3::ONE,
        };
        let (est, want) = floor_under_a_lamp(BsdfKind::RoughConductor { lobe }, |wi, wo| lobe.eval(wi, wo).x);
        assert!(want > 0.1, "{want}");
        assert!((est - want).abs() < 0.03 * want, "alpha {alpha}: {est} vs {want}");
    }
}

/// A rough glass floor under a small square lamp, nothing else below or beside: the
/// radiance it reflects towards a viewer, averaged over many seeds, is Walter et
/// al.'s (2007) microfacet BRDF, F D G / (4 |cos i| |cos o|), integrated over the
/// lamp, for a wide and a sharp lobe: the lamp's light samples and the rays drawn
/// from the facets, weighed against each other, count it once (the transmitted rays
/// meet nothing).
#[test]
fn a_rough_glass_floor_reflects_an_area_light_once_by_light_samples_and_facet_rays() {
    use crate::bsdf::fresnel_dielectric;
    use crate::scene::{BsdfKind, Microfacet};
    for (alpha, beckmann) in [(0.3f32, false), (0.1, true)] {
        let d = Microfacet {
            alpha_u: alpha,
            alpha_v: alpha,
            beckmann,
        };
        let glass = BsdfKind::Dielectric {
            eta: 1.5,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
            thin: false,
            rough: Some(d),
        };
        let (est, want) = floor_under_a_lamp(glass, |wi, wo| {
            let h = (wi + wo).normalize();
            fresnel_dielectric(wo.dot(h), 1.5) * d.d(h) * d.g(wo, wi, h) / (4.0 * wi.z * wo.z)
        });
        assert!(want > 0.01, "{want}");
        assert!((est - want).abs() < 0.04 * want, "alpha {alpha}: {est} vs {want}");
    }
}

/// A rough plastic floor under a point light, nothing else: the radiance seen from
/// the side is the whole BSDF, the coating's lobe plus the base seen through the
/// coating (Mitsuba's `roughplastic`, whose values the bsdf tests check), times
/// I cos / r^2: the lobe's light sample and the diffuse part's shadow ray each
/// bring their share, once. The lobe's rays meet nothing.
#[test]
fn a_rough_plastic_floor_reflects_a_point_light_by_its_lobe_and_its_base() {
    use crate::accel::Ray;
    use crate::scene::Light;
    use crate::testutil::{scene_with, square};
    let kind = crate::testutil::rough_plastic(Vec3::new(0.6, 0.3, 0.1), 0.2, false);
    let (h, i) = (2.0f32, 10.0f32);
    let s = scene_with(
        vec![(square(-10.0, 10.0, -10.0, 10.0, 0.0, false), kind.clone())],
        vec![Light::Point {
            position: Vec3::new(0.0, 0.0, h),
            intensity: Vec3::splat(i),
        }],
        &[],
    );
    let bvh = Bvh::build(&s);
    let mut st = settings(Method::Direct);
    st.area_samples = 1;
    let tracer = crate::render::Tracer::new(&s, &bvh, &st);
    let eye = Vec3::new(-1.0, 0.0, 1.0);
    let lobe = kind.glossy().unwrap();
    // The lobe's peak is at x = -2/3.
    for x in [-0.67f32, -0.3, 1.0] {
        let p = Vec3::new(x, 0.0, 0.0);
        let wo = (eye - p).normalize();
        let mut c = crate::render::Counters::default();
        let l = tracer.radiance(&Ray::new(eye, -wo), 0, 1, &mut c);
        let r2 = h * h + x * x;
        let wi = Vec3::new(-x, 0.0, h) / r2.sqrt();
        let f = lobe.eval(wi, wo) + kind.diffuse_brdf(wi.z, wo.z);
        let expect = f * (i / r2 * wi.z);
        assert!(
            (l - expect).abs().max_element() < 1e-4 * expect.max_element(),
            "x {x}: {l} vs {expect}"
        );
        // Both parts count: neither alone is the whole.
        let diffuse = kind.diffuse_brdf(wi.z, wo.z).x * i / r2 * wi.z;
        assert!(diffuse > 0.05 * expect.x, "x {x}: {diffuse} of {}", expect.x);
        if x < -0.5 {
            assert!(diffuse < 0.8 * expect.x, "x {x}: {diffuse} of {}", expect.x);
        }
        assert_eq!(c.shadow_rays, 2);
    }
}

/// A floor far below the camera with a checker of one-texel squares, many texels
/// to a pixel, under the sun (`direct`, one sample a pixel): read from its mipmap
/// over the camera rays' footprints (Mitsuba 0.6's `trilinear`), every pixel shows
/// the checker's mean, rho E / pi (its levels past the first are that mean); read
/// bilinearly, each pixel shows whichever texels its one sample meets.
#[test]
fn a_mipmapped_texture_far_off_shows_its_mean_in_every_pixel() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{BsdfKind, Light, TexField, Texture};
    let mut floor = crate::testutil::square(-50.0, 50.0, -50.0, 50.0, 0.0, false);
    floor.uvs = floor
        .positions
        .iter()
        .map(|p| p.truncate() / 100.0 + 0.5)
        .collect();
    let e = 2.0f32;
    let mut s = crate::testutil::scene_with(
        vec![(
            floor,
            BsdfKind::Diffuse {
                reflectance: Vec3::ONE,
            },
        )],
        vec![Light::Directional {
            direction: -Vec3::Z,
            irradiance: Vec3::splat(e),
        }],
        &[],
    );
    let texels = (0..64 * 64)
        .map(|k| {
            if (k % 64 + k / 64) % 2 == 0 {
                [0.8; 3]
            } else {
                [0.2; 3]
            }
        })
        .collect();
    let mut t = Texture::from_linear("checker", 64, 64, texels).unwrap();
    // 80 repeats: 5,120 texels over the floor's 100 m, about 30 to a pixel.
    t.to_uv = glam::Affine2::from_scale(glam::Vec2::splat(80.0));
    crate::testutil::texture_on(&mut s, 0, TexField::Diffuse, t);
    s.sensors.push(crate::testutil::looking(
        Vec3::new(0.0, -1.0, 40.0),
        Vec3::ZERO,
        40.0,
        48,
        48,
    ));
    let want = 0.5 * e / std::f32::consts::PI;
    let mut st = settings(Method::Direct);
    st.spp = 1;
    let spread = |s: &Scene| {
        let img = draw(s, &Bvh::build(s), &st, None).image;
        img.pixels
            .iter()
            .map(|p| (p.x / want - 1.0).abs())
            .fold(0.0f32, f32::max)
    };
    s.textures[0].filter = TexFilter::Trilinear;
    s.textures[0].build_mipmap();
    let mipmapped = spread(&s);
    assert!(mipmapped < 0.01, "{mipmapped}");
    s.textures[0].filter = TexFilter::Bilinear;
    let point = spread(&s);
    assert!(point > 0.3, "{point}");
}

/// A `sunsky`'s sun seen by the camera, straight and in a mirror floor: summed over
/// the image (each pixel's radiance above the sky's times its solid angle), the disk
/// gives back the sun's irradiance E, as a disk of radiance E / its solid angle must;
/// a rough metal floor, whose lobe rays leave the sun to its light samples, renders
/// as without the disk (the sun is not counted twice), within the noise of the light
/// samples spread over the disk.
#[test]
fn the_suns_disk_is_seen_directly_and_in_a_mirror_and_carries_its_irradiance() {
    use crate::scene::{BsdfKind, Fresnel, Glossy, Light, Microfacet, SunDisk};
    let (e, sky) = (500.0f32, 1.0f32);
    let towards = Vec3::new(0.3, 0.2, 1.0).normalize();
    let floor_of = |kind: BsdfKind| {
        let mut s = crate::testutil::scene_with(
            vec![(
                crate::testutil::square(-50.0, 50.0, -50.0, 50.0, 0.0, false),
                kind,
            )],
            vec![
                crate::testutil::uniform_sky(sky),
                Light::Directional {
                    direction: -towards,
                    irradiance: Vec3::splat(e),
                },
            ],
            &[],
        );
        s.sun_disk = Some(SunDisk {
            light: 1,
            solid_angle: crate::sampling::cone_solid_angle((0.5f32 * 0.5358).to_radians()),
        });
        s
    };
    let mirror = BsdfKind::Conductor {
        specular_reflectance: Vec3::ONE,
        fresnel: Fresnel::Schlick { f0: Vec3::ONE },
    };
    // A 2-degree view (the disk is 0.54 degrees across), 48 x 48, 16 samples a pixel.
    let (fov, w) = (2.0f32, 48u32);
    let pixel_solid_angle = (2.0 * (0.5 * fov).to_radians().tan() / w as f32).powi(2);
    let mut st = settings(Method::Direct);
    st.spp = 16;
    let reflected = Vec3::new(towards.x, towards.y, -towards.z);
    for (eye, look) in [
        (Vec3::new(0.0, 0.0, 1.0), towards),
        (Vec3::new(0.0, 0.0, 1.0), reflected),
    ] {
        let mut s = floor_of(mirror.clone());
        s.sensors
            .push(crate::testutil::looking(eye, eye + look, fov, w, w));
        let img = draw(&s, &Bvh::build(&s), &st, None).image;
        let got: f32 = img.pixels.iter().map(|p| (p.x - sky) * pixel_solid_angle).sum();
        assert!((got - e).abs() < 0.02 * e, "looking along {look}: {got} vs {e}");
        // Away from the disk, the sky alone.
        assert!((img.pixels[0].x - sky).abs() < 1e-4, "{}", img.pixels[0].x);
    }
    // A rough metal floor seen from above, lit by the sun: with and without the disk.
    let rough = BsdfKind::RoughConductor {
        lobe: Glossy {
            distribution: Microfacet {
                alpha_u: 0.2,
                alpha_v: 0.2,
                beckmann: false,
            },
            fresnel: Fresnel::Schlick { f0: Vec3::splat(0.9) },
            scale: Vec3::ONE,
        },
    };
    let mut s = floor_of(rough);
    s.sensors.push(crate::testutil::looking(
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(-0.6, -0.4, 0.0),
        40.0,
        24,
        24,
    ));
    let with = draw(&s, &Bvh::build(&s), &st, None).image;
    assert!(
        with.pixels.iter().any(|p| p.x > 2.0 * sky),
        "the sun's highlight is in view"
    );
    s.sun_disk = None;
    let without = draw(&s, &Bvh::build(&s), &st, None).image;
    // The disk's light samples spread over its 0.27 degrees: the same light, within
    // their noise (counted twice, the highlight would double).
    let (a, b) = (image_mean(&with), image_mean(&without));
    assert!((a - b).abs() < 0.01 * b, "{a} vs {b}");
}

/// The sun of a sky (a [`SunDisk`](crate::scene::SunDisk)) shines from its disk, so an
/// edge's shadow has a penumbra: under a sun overhead of angular radius a, a floor
/// point at (x, 0, 0) beside the straight edge x = 0 of a plate at height h sees the
/// part of the disk on its side of the chord at d = -x / (h a), 1 - (acos d - d
/// sqrt(1 - d^2)) / pi of it. A plain `directional` (no disk) casts a hard shadow.
#[test]
fn a_suns_disk_casts_the_penumbra_of_its_size() {
    use crate::scene::{Light, SunDisk};
    use crate::testutil::{looking, scene, square, v};
    let (e, h, solid_angle) = (2.0f32, 1.0f32, 0.01f32);
    let a = (solid_angle / std::f32::consts::PI).sqrt();
    let mut s = scene(
        vec![
            (square(-5.0, 5.0, -5.0, 5.0, 0.0, false), Vec3::splat(0.5)),
            (square(0.0, 5.0, -5.0, 5.0, h, false), Vec3::ZERO),
        ],
        vec![Light::Directional {
            direction: -Vec3::Z,
            irradiance: Vec3::splat(e),
        }],
        &[],
    );
    let ds = [0.5f32, 0.0, -0.5, 1.5];
    for d in ds {
        let x = -d * h * a;
        s.sensors.push(looking(v(x, 0.0, 0.5), v(x, 0.0, 0.0), 0.5, 8, 8));
    }
    let mut st = settings(Method::Direct);
    st.spp = 256;
    for disk in [true, false] {
        s.sun_disk = disk.then_some(SunDisk {
            light: 0,
            solid_angle,
        });
        let bvh = Bvh::build(&s);
        for (view, d) in ds.into_iter().enumerate() {
            st.view = view;
            let got = image_mean(&draw(&s, &bvh, &st, None).image) / (0.5 * e / std::f32::consts::PI);
            let want = match (disk, d) {
                (true, d) if d.abs() < 1.0 => {
                    1.0 - (d.acos() - d * (1.0 - d * d).sqrt()) / std::f32::consts::PI
                }
                // The edge halves the hard shadow's pixels.
                (false, 0.0) => 0.5,
                (_, d) => f32::from(u8::from(d > 0.0)),
            };
            assert!((got - want).abs() < 0.02, "disk {disk}, d {d}: {got} vs {want}");
        }
    }
}

/// A glossy floor, a square lamp at half a metre facing up (the floor sees only its
/// back) and a mirror ceiling at one metre: the floor reflects the lamp's image in the
/// mirror, which no light sample finds. Averaged over many seeds, the radiance towards
/// a viewer is the lobe integrated over that image (the lamp mirrored to 1.5 m, facing
/// down); before the lobe's rays counted a light met past a mirror, none of it.
#[test]
fn a_glossy_floor_reflects_a_lamps_image_in_a_mirror() {
    use crate::scene::{BsdfKind, Fresnel, Glossy, Microfacet};
    use crate::testutil::{scene_with, square};
    let lobe = Glossy {
        distribution: Microfacet {
            alpha_u: 0.4,
            alpha_v: 0.4,
            beckmann: false,
        },
        fresnel: Fresnel::Schlick { f0: Vec3::splat(0.9) },
        scale: Vec3::ONE,
    };
    let (x0, x1, y0, y1, h, top) = (0.3f32, 0.7, -0.2, 0.2, 0.5, 1.0);
    let le = 5.0f32;
    let s = scene_with(
        vec![
            (
                square(-3.0, 3.0, -3.0, 3.0, 0.0, false),
                BsdfKind::RoughConductor { lobe },
            ),
            (
                square(x0, x1, y0, y1, h, false),
                BsdfKind::Diffuse {
                    reflectance: Vec3::ZERO,
                },
            ),
            (
                square(-3.0, 3.0, -3.0, 3.0, top, true),
                BsdfKind::Conductor {
                    specular_reflectance: Vec3::ONE,
                    fresnel: Fresnel::Schlick { f0: Vec3::ONE },
                },
            ),
        ],
        vec![],
        &[(1, Vec3::splat(le))],
    );
    let eye = Vec3::new(-0.3, 0.0, 0.9);
    let est = mean_radiance_at_origin(&s, &solve_settings(0.2, 4), eye, 128000);
    // The image: the lamp mirrored in z = top, at 2 top - h, facing down.
    let want =
        crate::testutil::lamp_integral([x0, x1, y0, y1], 2.0 * top - h, le, eye.normalize(), |wi, wo| {
            lobe.eval(wi, wo).x
        });
    assert!(want > 0.05, "{want}");
    assert!((est - want).abs() < 0.03 * want, "{est} vs {want}");
}

/// A lamp inside a glass cube as clear as air (index 1.0001) lights the floor as the
/// bare lamp does: the shots' shadow rays end inside the glass and count its
/// crossing, and the photons that leave the glass the lamp sits in keep to that (they
/// counted its light a second time: the floor twice as bright).
#[test]
fn a_lamp_inside_clear_glass_lights_the_floor_as_the_bare_lamp() {
    let radiance = |glass: &str| {
        let xml = format!(
            r#"<scene version="3.0.0">
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="0.05"/>
    <emitter type="area"><rgb name="radiance" value="20"/></emitter></shape>
  {glass}
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
</scene>"#
        );
        let s = crate::scene::xml::load_str(std::path::Path::new("clear.xml"), &xml, &[])
            .unwrap()
            .scene;
        // With photons, which carry what the glass passes on.
        let st = SolveSettings {
            photons: 64,
            ..solve_settings(0.2, 4)
        };
        mean_radiance_at_origin(&s, &st, Vec3::new(0.6, 0.5, 0.0), 64)
    };
    let bare = radiance("");
    let boxed = radiance(
        r#"<shape type="cube"><transform name="to_world"><scale value="0.2"/><translate y="1"/></transform>
    <bsdf type="dielectric"><float name="int_ior" value="1.0001"/></bsdf></shape>"#,
    );
    // The bare lamp's closed form: rho / pi x L pi (r / d)^2 = 0.5 x 20 x 0.05^2.
    assert!((bare / 0.025 - 1.0).abs() < 0.03, "{bare}");
    assert!((boxed / bare - 1.0).abs() < 0.03, "{boxed} against {bare}");
}

/// A smooth plastic floor under a uniform sky of radiance L, nothing ray traced (the
/// sky's light read from the solution): seen head on and at a grazing angle, a pixel
/// shows L times the diffuse albedo towards the view plus the coating's mirror image
/// of the sky, F(cos_v) L. Read as the albedo's mean over the views, the head-on view
/// came out 6 % dark (0.761 against 0.809) and the grazing one a quarter bright.
#[test]
fn a_plastic_floor_under_a_uniform_sky_shows_its_albedo_towards_the_view() {
    use crate::scene::BsdfKind;
    use crate::testutil::{looking, scene_with, square, uniform_sky};
    let plastic = BsdfKind::Plastic {
        diffuse_reflectance: Vec3::splat(0.8),
        specular_reflectance: Vec3::ONE,
        eta: 1.5,
        nonlinear: false,
    };
    let l = 1.0f32;
    for (eye, at) in [
        (Vec3::new(0.0, 0.0, 3.0), Vec3::new(0.2, 0.0, 0.0)),
        (Vec3::new(0.0, 0.0, 0.5), Vec3::new(3.0, 0.0, 0.0)),
    ] {
        let mut s = scene_with(
            vec![(square(-5.0, 5.0, -5.0, 5.0, 0.0, false), plastic.clone())],
            vec![uniform_sky(l)],
            &[],
        );
        s.sensors.push(looking(eye, at, 4.0, 8, 8));
        let bvh = Bvh::build(&s);
        let sol = solve(&s, &bvh, &solve_settings(0.5, 1), &crate::progress::Silent).unwrap();
        let none = SelectSettings {
            radiance_threshold: f32::INFINITY,
            ..Default::default()
        };
        let sel = select_unchecked(&s, &sol, Method::Local, &none, None).unwrap();
        assert!((0..sol.mesh.patches.len()).all(|p| sel.picks(p as u32).is_empty()));
        let mut st = settings(Method::Local);
        (st.width, st.height, st.spp) = (8, 8, 16);
        let img = draw(&s, &bvh, &st, Some(&sel)).image;
        let centre: f32 = [27, 28, 35, 36].iter().map(|&i| img.pixels[i].x).sum::<f32>() / 4.0;
        let cos_v = (eye - at).normalize().z;
        let want = l * (plastic.diffuse_albedo_at(cos_v).x + crate::bsdf::fresnel_dielectric(cos_v, 1.5));
        assert!(
            (centre - want).abs() < 0.03 * want,
            "cos_v {cos_v}: {centre} vs {want} (the mean albedo would give {})",
            l * (plastic.diffuse_albedo().x + crate::bsdf::fresnel_dielectric(cos_v, 1.5))
        );
    }
}

/// A floor of albedo 0.5 beside a long black wall 0.2 m high under a uniform sky of
/// radiance 1: at distance d from the wall the floor sees the sky but for the wall's
/// form factor `(1 - d / sqrt(d^2 + h^2)) / 2` (an infinitely long strip), so it
/// shows 0.5 x that share of the sky. The gather's rays read the sky (1.7 % off at d =
/// 0.1 m); the sky's stored light, which the mesh (0.5 m cells) interpolates, was 31 %
/// dark there.
#[test]
fn the_gather_reads_a_skys_shadow_at_the_foot_of_a_wall() {
    use crate::testutil::{box_outside, looking, scene, square, uniform_sky, v};
    let h = 0.2f32;
    let mut shapes = vec![(square(-5.0, 5.0, -5.0, 5.0, 0.0, false), Vec3::splat(0.5))];
    for f in box_outside(v(0.0, -5.0, 0.0), v(0.2, 5.0, h)) {
        shapes.push((f, Vec3::ZERO));
    }
    let mut s = scene(shapes, vec![uniform_sky(1.0)], &[]);
    for d in [0.1f32, 3.0] {
        s.sensors
            .push(looking(v(-d, 0.0, 3.0), v(-d, 0.0, 0.0), 2.0, 8, 8));
    }
    let bvh = Bvh::build(&s);
    let sol = solve(&s, &bvh, &solve_settings(0.5, 1), &crate::progress::Silent).unwrap();
    let sel = select(&s, &sol, Method::Local, &SelectSettings::default(), None).unwrap();
    for (view, d) in [0.1f32, 3.0].into_iter().enumerate() {
        let mut st = settings(Method::Local);
        (st.view, st.width, st.height, st.spp, st.gather) = (view, 8, 8, 16, 128);
        let img = draw(&s, &bvh, &st, Some(&sel)).image;
        let centre: f32 = [27, 28, 35, 36].iter().map(|&i| img.pixels[i].x).sum::<f32>() / 4.0;
        let want = 0.5 * (1.0 - 0.5 * (1.0 - d / (d * d + h * h).sqrt()));
        assert!((centre - want).abs() < 0.04 * want, "d {d}: {centre} vs {want}");
    }
}

/// An area light with a texture of its radiance (a screen) shows each texel where the
/// camera sees it, as Mitsuba's `area` emitter of a `bitmap` radiance does; the light it
/// sends is the texture's mean (the light's `radiance`).
#[test]
fn a_textured_area_light_shows_its_texture_where_seen() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{BsdfKind, Light, Texture};
    let (a, b) = ([4.0, 1.0, 0.5], [0.5, 2.0, 6.0]);
    let mut screen = crate::testutil::square(-1.0, 1.0, -1.0, 1.0, 0.0, false);
    screen.uvs = screen
        .positions
        .iter()
        .map(|p| p.truncate() * 0.5 + 0.5)
        .collect();
    let mean = (Vec3::from(a) + Vec3::from(b)) * 0.5;
    let mut s = crate::testutil::scene_with(
        vec![(
            screen,
            BsdfKind::Diffuse {
                reflectance: Vec3::ZERO,
            },
        )],
        Vec::new(),
        &[(0, mean)],
    );
    let mut t = Texture::from_linear("screen", 2, 1, vec![a, b]).unwrap();
    t.filter = TexFilter::Nearest;
    s.textures.push(t);
    let Light::Area { texture, .. } = &mut s.lights[0] else {
        panic!("{:?}", s.lights[0]);
    };
    *texture = Some(0);
    s.sensors.push(crate::testutil::looking(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        20.0,
        48,
        48,
    ));
    let mut st = settings(Method::Direct);
    st.spp = 1;
    let img = draw(&s, &Bvh::build(&s), &st, None).image;
    // u runs along +x: texel a on the left half of the screen, b on the right.
    let (w, h) = (img.width as usize, img.height as usize);
    for y in (h / 8)..(7 * h / 8) {
        for (x, want) in [(w / 8, a), (w / 3, a), (2 * w / 3, b), (7 * w / 8, b)] {
            let got = img.pixels[y * w + x];
            assert!(
                (got - Vec3::from(want)).length() < 1e-4,
                "({x}, {y}): {got} not {want:?}"
            );
        }
    }
}

/// Through a thin lens the adaptive sampler refines wherever neighbouring samples
/// differ at all (the blur is noise the difference criterion cannot tell from an
/// edge): a plane under a lamp, whose light changes too slowly across a pixel for a
/// pinhole to refine it, takes 4^L samples in every pixel.
#[test]
fn a_thin_lens_refines_every_pixel() {
    use crate::scene::{BsdfKind, Lens, Light};
    let floor = crate::testutil::square(-50.0, 50.0, -50.0, 50.0, 0.0, false);
    let mut s = crate::testutil::scene_with(
        vec![(
            floor,
            BsdfKind::Diffuse {
                reflectance: Vec3::splat(0.5),
            },
        )],
        vec![Light::Point {
            position: Vec3::new(0.0, 0.0, 5.0),
            intensity: Vec3::splat(20.0),
        }],
        &[],
    );
    s.sensors.push(crate::testutil::looking(
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::ZERO,
        30.0,
        16,
        16,
    ));
    let mut st = settings(Method::Direct);
    st.sampler = Sampler::Adaptive;
    st.width = 16;
    st.height = 16;
    let refined = |s: &Scene| -> u64 {
        let out = draw(s, &Bvh::build(s), &st, None);
        out.levels
            .iter()
            .filter(|l| l.level >= 1)
            .map(|l| l.samples)
            .sum()
    };
    assert_eq!(
        refined(&s),
        0,
        "a pinhole refines nothing on the slowly lit plane"
    );
    s.sensors[0].lens = Some(Lens {
        radius: 0.1,
        focus: 10.0,
    });
    let max_level = st.refine.max_level;
    // Every pixel holds 4^L samples at the top level, of which the coarser levels hold
    // 4^(L-1) (and one at levels -1 and 0 between them).
    let want = 16 * 16 * (4u64.pow(max_level) - 1);
    assert_eq!(refined(&s), want);
}
