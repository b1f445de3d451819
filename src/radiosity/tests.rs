use super::*;
use crate::accel::Bvh;
use crate::geometry::{point_polygon_form_factor, TriMesh};
use crate::progress::Silent;
use crate::testutil::{box_inside, box_outside, quad, scene, v};
use std::f32::consts::PI;

fn settings(mesh_size: f32, samples: u32, max_shots: u32) -> SolveSettings {
    SolveSettings {
        mesh_size,
        sources_per_patch: 4,
        shoot_samples: samples,
        tolerance: 1e-4,
        max_shots,
        seed: 3,
        photons: 0,
        max_photons: 0,
        time_limit: 0.0,
        gathered: false,
    }
}

/// Area-weighted mean of the total radiosity over the vertices of patch `p`.
fn patch_mean(sol: &Solution, total: &[Rgb], p: usize) -> f32 {
    let patch = &sol.mesh.patches[p];
    let vs = patch.first_vertex as usize..(patch.first_vertex + patch.vertex_count) as usize;
    let (mut s, mut a) = (0.0, 0.0);
    for v in vs {
        s += total[v].x * sol.mesh.vertices[v].area;
        a += sol.mesh.vertices[v].area;
    }
    s / a
}

/// A closed 2 x 1 x 1.5 box of reflectance `rho` lit by a point light of 3 W/sr.
fn lit_box(rho: f32) -> Scene {
    let faces = box_inside(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.5));
    let light = Light::Point {
        position: Vec3::new(0.7, 0.6, 0.5),
        intensity: Vec3::splat(3.0),
    };
    scene(
        faces.into_iter().map(|f| (f, Vec3::splat(rho))).collect(),
        vec![light],
        &[],
    )
}

/// [`lit_box`] with a glossy metal floor (GGX, alpha 0.05, white): its light
/// goes on by photons. Returns the scene and the floor's BSDF.
fn lit_box_with_glossy_floor(rho: f32) -> (Scene, usize) {
    use crate::scene::{BsdfKind, Fresnel, Glossy, Microfacet};
    let mut s = lit_box(rho);
    let floor = s
        .shapes
        .iter()
        .position(|sh| sh.mesh.positions.iter().all(|p| p.y == 0.0))
        .unwrap();
    let b = s.shapes[floor].bsdf as usize;
    let lobe = Glossy {
        distribution: Microfacet {
            alpha_u: 0.05,
            alpha_v: 0.05,
            beckmann: false,
        },
        fresnel: Fresnel::Schlick { f0: Vec3::ONE },
        scale: Vec3::ONE,
    };
    s.bsdfs[b].kind = BsdfKind::RoughConductor { lobe };
    (s, b)
}

/// The settings of the photon tests in a lit box: 0.1 elements, 16 cells a shot,
/// at most `max_shots` patch shots down to 2 % of the power, `photons` a vertex.
fn photon_settings(max_shots: u32, photons: u32) -> SolveSettings {
    let mut st = settings(0.1, 16, max_shots);
    st.tolerance = 0.02;
    st.photons = photons;
    st
}

/// Asserts that surfaces of reflectance `rho` absorb between `lo` and `hi` times the
/// power emitted: the photons carried all the light.
fn assert_absorbs(sol: &Solution, rho: f32, lo: f64, hi: f64) {
    let emitted = sol.stats.emitted_power;
    let absorbed = absorbed_power(sol, rho);
    assert!(
        absorbed > emitted * lo && absorbed < emitted * hi,
        "{absorbed} vs {emitted}"
    );
}

/// The power absorbed by surfaces of reflectance `rho` (red channel), from their
/// total radiosity.
fn absorbed_power(sol: &Solution, rho: f32) -> f64 {
    sol.mesh
        .vertices
        .iter()
        .zip(&sol.total())
        .map(|(v, b)| (b.x / rho * (1.0 - rho) * v.area) as f64)
        .sum()
}

/// Form factor from receiver B (shape 0, reflectance 1) to emitter A (shape 1,
/// radiosity 1): the mean radiosity B gets from one light shot.
fn form_factor(receiver: [Vec3; 4], emitter: [Vec3; 4]) -> f32 {
    let s = scene(
        vec![(quad(receiver), Vec3::ONE), (quad(emitter), Vec3::ZERO)],
        vec![],
        &[(1, Vec3::splat(1.0 / PI))],
    );
    let sol = solve(&s, &Bvh::build(&s), &settings(0.05, 1024, 0), &Silent).unwrap();
    patch_mean(&sol, &sol.total(), 0)
}

#[test]
fn form_factor_between_parallel_unit_squares_one_apart() {
    let v = Vec3::new;
    let f = form_factor(
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
        [v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)],
    );
    assert!((f - 0.19982).abs() < 0.001, "F = {f}");
}

#[test]
fn form_factor_between_perpendicular_unit_squares_sharing_an_edge() {
    let v = Vec3::new;
    let f = form_factor(
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
        [v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)],
    );
    assert!((f - 0.20004).abs() < 0.002, "F = {f}");
}

/// Two rooms under one floor, ceiling and pair of side walls (each a single patch
/// spanning both), parted by a closed wall at x 1.45..1.55 (a box resting on the floor,
/// touching the ceiling and side walls), a point light in the right room: the solution
/// of `st`, and the mean radiosity of the floor (shape 2) over its vertices well inside
/// the left room and the right room.
fn two_rooms_under_one_floor(st: &SolveSettings) -> (Scene, Solution, f32, f32) {
    let light = Light::Point {
        position: Vec3::new(3.0, 0.6, 0.5),
        intensity: Vec3::splat(3.0),
    };
    let (s, sol) = two_rooms_lit_by(vec![light], 1.45, 0, st);
    let (left, right) = in_each_room(&sol, 2, 1.45);
    (s, sol, left, right)
}

/// [`two_rooms_under_one_floor`]'s rooms, the wall at x `wall`..`wall` + 0.1, lit by
/// `lights`, and their solution by `st`. With `split` > 0 the rooms' faces are each
/// `split` x `split` cells of two triangles (a mesh's triangles, which the radiosity
/// mesh merges into a lattice), not one quadrilateral.
fn two_rooms_lit_by(lights: Vec<Light>, wall: f32, split: u32, st: &SolveSettings) -> (Scene, Solution) {
    let v = Vec3::new;
    let mut shapes: Vec<(TriMesh, Rgb)> = box_inside(v(0., 0., 0.), v(4., 1., 1.))
        .into_iter()
        .map(|f| match split {
            0 => f,
            k => crate::testutil::split_quad(std::array::from_fn(|i| f.positions[i]), k),
        })
        .map(|f| (f, Vec3::splat(0.7)))
        .collect();
    shapes.extend(
        box_outside(v(wall, 0., 0.), v(wall + 0.1, 1., 1.))
            .into_iter()
            .map(|f| (f, Vec3::splat(0.7))),
    );
    let s = scene(shapes, lights, &[]);
    let sol = solve(&s, &Bvh::build(&s), st, &Silent).unwrap();
    (s, sol)
}

/// The mean total radiosity (red) of shape `p` of [`two_rooms_lit_by`]'s rooms (the
/// wall at `wall`) over its vertices well inside the left room and the right room.
fn in_each_room(sol: &Solution, p: u32, wall: f32) -> (f32, f32) {
    let total = sol.total();
    let mean_where = |inside: &dyn Fn(f32) -> bool| {
        let (mut sum, mut area) = (0.0, 0.0);
        for patch in sol.mesh.patches.iter().filter(|q| q.shape == p) {
            for i in patch.first_vertex..patch.first_vertex + patch.vertex_count {
                let vx = &sol.mesh.vertices[i as usize];
                if inside(vx.p.x) {
                    sum += total[i as usize].x * vx.area;
                    area += vx.area;
                }
            }
        }
        sum / area
    };
    (mean_where(&|x| x < wall - 0.25), mean_where(&|x| x > wall + 0.55))
}

/// [`two_rooms_lit_by`] a light in each room under the ceiling, the right one three
/// times the left one, the wall standing across the floor's and ceiling's shooting
/// cells (not on their edges): patch shots give each room's floor and ceiling the
/// light beyond the lights' own (the solution less that of the light shots alone)
/// that photons alone give them, within 3 %. A cell that straddles the wall once
/// aimed its rays by its light alone, so a left-room vertex near the wall weighed the
/// right part's light, which it sees under a smaller angle, as much as the left
/// part's it sees: the left room's ceiling got 3.6 % too little, its floor 2.6 %; now
/// 1.3 % and 2.0 % too much. Once with each face one quadrilateral, once with each a
/// mesh of triangles (the radiosity mesh's lattice): within 0.3 % on the left, 1.7 %
/// on the right.
#[test]
fn a_wall_leaves_each_room_its_own_light_where_both_are_lit() {
    for split in [0, 4] {
        both_rooms_lit(split);
    }
}

/// [`a_wall_leaves_each_room_its_own_light_where_both_are_lit`] on faces split as
/// [`two_rooms_lit_by`] takes `split`.
fn both_rooms_lit(split: u32) {
    let lights = vec![
        Light::Point {
            position: Vec3::new(0.7, 0.9, 0.5),
            intensity: Vec3::splat(1.0),
        },
        Light::Point {
            position: Vec3::new(3.0, 0.9, 0.5),
            intensity: Vec3::splat(3.0),
        },
    ];
    let wall = 1.6;
    let (_, direct) = two_rooms_lit_by(lights.clone(), wall, split, &settings(0.1, 64, 0));
    let (_, shots) = two_rooms_lit_by(lights.clone(), wall, split, &settings(0.1, 64, 100));
    assert!(
        shots.stats.patch_shots >= 4,
        "{} patch shots",
        shots.stats.patch_shots
    );
    let mut st = settings(0.1, 64, 0);
    st.photons = 1024;
    st.max_photons = 4_000_000;
    let (_, photons) = two_rooms_lit_by(lights, wall, split, &st);
    for (p, name) in [(2, "floor"), (3, "ceiling")] {
        let (direct_left, direct_right) = in_each_room(&direct, p, wall);
        let (shot_left, shot_right) = in_each_room(&shots, p, wall);
        let (photon_left, photon_right) = in_each_room(&photons, p, wall);
        let (shot_left, shot_right) = (shot_left - direct_left, shot_right - direct_right);
        let (photon_left, photon_right) = (photon_left - direct_left, photon_right - direct_right);
        assert!(
            (shot_left / photon_left - 1.0).abs() < 0.03,
            "split {split}: left room's {name}: {shot_left} by shots, {photon_left} by photons"
        );
        assert!(
            (shot_right / photon_right - 1.0).abs() < 0.03,
            "split {split}: right room's {name}: {shot_right} by shots, {photon_right} by photons"
        );
    }
}

/// A parted cell's pieces (`shot::piece_polygon`) tile it: a quadrilateral's 16
/// sixteenths and a triangle's 4 quarters each hold the points drawn in them
/// (`shot::piece_point`), and their areas sum to the cell's.
#[test]
fn a_parted_cells_pieces_tile_it_and_hold_their_points() {
    use crate::mesh::vector_area;
    let quad = [v(0., 0., 0.), v(2., 0., 0.), v(2.5, 1., 0.), v(0.5, 1., 0.)];
    let tri = [v(0., 0., 0.), v(2., 0., 0.), v(0.5, 1.5, 0.)];
    for (poly, pieces) in [(&quad[..], 16), (&tri[..], 4)] {
        let mut area = 0.0;
        for i in 0..pieces {
            let (c, len) = shot::piece_polygon(poly, i);
            let c = &c[..len];
            area += vector_area(c);
            // Inside a convex polygon (counter-clockwise in z = 0): left of every edge.
            let inside = |p: Vec3| (0..len).all(|e| (c[(e + 1) % len] - c[e]).cross(p - c[e]).z >= -1e-5);
            for j in 0..64 {
                let u = glam::Vec2::new((j % 8) as f32 / 8.0 + 0.06, (j / 8) as f32 / 8.0 + 0.06);
                let p = shot::piece_point(poly, i, u);
                assert!(
                    inside(p),
                    "piece {i} of {} corners: {p} outside {c:?}",
                    poly.len()
                );
            }
        }
        assert!(
            (area - vector_area(poly)).abs() < 1e-4,
            "{area} vs {}",
            vector_area(poly)
        );
    }
}

/// [`two_rooms_under_one_floor`] by patch shots. Their cells straddle the wall; a
/// cell's rays once aimed uniformly over it, so one from a left-room vertex found the
/// cell's dark left part visible and took it for the lit right part's light: the left
/// room, which no light can reach, got 1.8 % of the right room's (0 now that the rays
/// aim by the light over the cell's quarters).
#[test]
fn a_wall_keeps_the_light_of_patches_that_span_two_rooms_in_its_room() {
    let (_, sol, left, right) = two_rooms_under_one_floor(&settings(0.1, 16, 100));
    assert!(
        sol.stats.patch_shots >= 4,
        "{} patch shots",
        sol.stats.patch_shots
    );
    assert!(right > 0.1, "right room's floor {right}");
    assert!(
        left < 0.002 * right,
        "left room's floor {left} of the right's {right}"
    );
}

/// [`two_rooms_under_one_floor`] by photons alone (no patch shots), on elements 2.5
/// times the wall's thickness. A photon from a piece that straddles the wall once
/// took the light interpolated there from the vertices on both sides, so the left
/// side's strip along the wall's foot sent the right room's light into the left
/// room: 0.16 % of the right room's; 0.012 % now that such a photon takes its light
/// from the vertices it sees.
#[test]
fn a_wall_keeps_the_light_of_photons_from_patches_that_span_two_rooms_in_its_room() {
    let mut st = settings(0.25, 16, 0);
    st.photons = 256;
    st.max_photons = 400_000;
    let (_, sol, left, right) = two_rooms_under_one_floor(&st);
    assert_eq!(sol.stats.patch_shots, 0);
    assert!(right > 0.1, "right room's floor {right}");
    assert!(
        left < 0.0005 * right,
        "left room's floor {left} of the right's {right}"
    );
}

/// [`two_rooms_lit_by`] the point light in the right room, the wall at x 1.6..1.7,
/// by photons alone on 0.25 elements: the floor's element 1.5..1.75 runs under the
/// wall, its vertex at x 1.5 on the dark side. A photon landing on the lit side's
/// strip 1.7..1.75 once deposited a share of its light there by the plain weights,
/// and the dark side's reads of that vertex took it: the floor vertices within 0.2 of
/// the wall on the dark side had 1.0 % of the lit room's floor light (0.01 % farther
/// in); 0.075 % now that a deposit keeps to the vertices on its side
/// ([`Parted::keep_apart`]).
#[test]
fn a_photon_deposits_its_light_on_its_own_side_of_a_wall() {
    let light = Light::Point {
        position: Vec3::new(3.0, 0.6, 0.5),
        intensity: Vec3::splat(3.0),
    };
    let mut st = settings(0.25, 16, 0);
    st.photons = 256;
    st.max_photons = 400_000;
    let wall = 1.6;
    let (_, sol) = two_rooms_lit_by(vec![light], wall, 0, &st);
    assert_eq!(sol.stats.patch_shots, 0);
    let (_, right) = in_each_room(&sol, 2, wall);
    let total = sol.total();
    let (mut sum, mut area, mut count) = (0.0, 0.0, 0);
    for patch in sol.mesh.patches.iter().filter(|q| q.shape == 2) {
        for i in patch.first_vertex..patch.first_vertex + patch.vertex_count {
            let vx = &sol.mesh.vertices[i as usize];
            if vx.p.x > wall - 0.2 && vx.p.x < wall && vx.area > 0.0 {
                sum += total[i as usize].x * vx.area;
                area += vx.area;
                count += 1;
            }
        }
    }
    assert!(count >= 3, "{count} vertices beside the wall");
    let near = sum / area;
    assert!(right > 0.1, "right room's floor {right}");
    assert!(
        near < 0.002 * right,
        "dark side's floor beside the wall {near} of the lit room's {right}"
    );
}

/// `field` read on the floor below `above` (looking down): interpolated, and as
/// [`Parted`] reads it (the render's and the gather's reads).
fn read_floor(
    s: &Scene,
    sol: &Solution,
    bvh: &Bvh,
    parted: &Parted,
    field: &[Rgb],
    above: Vec3,
) -> (f32, f32) {
    let ray = crate::accel::Ray::new(above, v(0.0, -1.0, 0.0));
    let hit = bvh.intersect(&ray).expect("the floor");
    let p = ray.at(hit.t);
    let mut w = sol.mesh.locate(s, &hit, p, true);
    let plain = w.apply(field).x;
    parted.keep_visible(&sol.mesh, bvh, &mut w, p);
    (plain, w.apply(field).x)
}

/// [`two_rooms_under_one_floor`] on elements four times the wall's thickness, read
/// on the dark side of the wall, 5 cm from it: the floor's element there runs under
/// the wall to a vertex on the lit side, and its interpolated light is a quarter of
/// the lit room's floor's; read with [`Parted`] (as the render and the gather read),
/// the point takes only the vertices it sees: 0.16 %. Beside a column the vertex under it stays (its
/// light is less than the seen ones'): the lit side, read 5 cm from the wall, keeps
/// the interpolation.
#[test]
fn a_point_beside_a_wall_reads_the_light_of_its_own_side() {
    let (s, sol, _, right) = two_rooms_under_one_floor(&settings(0.4, 16, 100));
    let bvh = Bvh::build(&s);
    let total = sol.total();
    let parted = Parted::new(&sol.mesh, &bvh, total.clone());
    let read = |x: f32| read_floor(&s, &sol, &bvh, &parted, &total, v(x, 0.5, 0.5));
    let (plain, seen) = read(1.40);
    assert!(
        plain > 0.1 * right,
        "interpolated {plain} of the lit room's {right}"
    );
    assert!(seen < 0.01 * right, "read {seen} of the lit room's {right}");
    let (plain, seen) = read(1.60);
    assert_eq!(plain, seen, "the lit side");
}

/// [`Parted`]'s reads drop a hidden vertex only where its light is more than
/// `OTHER_SIDE` (4) times what the seen ones give: another room's light, not the far
/// side of a chair's leg (dropping every brighter one made the conference room 1 %
/// darker). On [`two_rooms_under_one_floor`]'s mesh, with a field of light made up
/// (left of the wall 0.6 or 1.0 by z, right of it 1.5 or 5.0): read at x = 1.40,
/// beside the wall, where the seen vertices give 0.9, the right-hand vertices stay in
/// the interpolation at 1.5 and 3.0, and are dropped at 5.0.
#[test]
fn a_point_beside_an_obstacle_drops_only_vertices_far_brighter_than_its_own() {
    let (s, sol, _, _) = two_rooms_under_one_floor(&settings(0.4, 16, 100));
    let bvh = Bvh::build(&s);
    let field = |right: f32| -> Vec<Rgb> {
        sol.mesh
            .vertices
            .iter()
            .map(|vx| {
                Vec3::splat(match (vx.p.x < 1.5, vx.p.z < 0.5) {
                    (true, true) => 0.6,
                    (true, false) => 1.0,
                    (false, _) => right,
                })
            })
            .collect()
    };
    let read = |right: f32| {
        let f = field(right);
        let parted = Parted::new(&sol.mesh, &bvh, f.clone());
        read_floor(&s, &sol, &bvh, &parted, &f, v(1.40, 0.5, 0.6))
    };
    for right in [1.5, 3.0] {
        let (plain, seen) = read(right);
        assert!(plain > 1.0, "interpolated {plain}");
        assert_eq!(
            plain, seen,
            "a hidden vertex of {right}, within four times the seen ones' light"
        );
    }
    let (plain, seen) = read(5.0);
    assert!(plain > 1.0, "interpolated {plain}");
    assert!(seen <= 1.0, "read {seen}: the other room's vertices dropped");
}

/// A closed cube whose faces all emit radiosity E and reflect rho: the reflected
/// radiosity converges to rho E / (1 - rho) (total E / (1 - rho)).
#[test]
fn furnace_converges_to_e_over_one_minus_rho() {
    let rho = 0.5;
    let e = 1.0;
    let faces = box_inside(Vec3::ZERO, Vec3::ONE);
    let emitters: Vec<(usize, Rgb)> = (0..6).map(|i| (i, Vec3::splat(e / PI))).collect();
    let s = scene(
        faces.into_iter().map(|f| (f, Vec3::splat(rho))).collect(),
        vec![],
        &emitters,
    );
    let mut st = settings(0.1, 64, 2000);
    st.tolerance = 1e-3;
    let sol = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    let total = sol.total();
    let expect = rho * e / (1.0 - rho);
    for p in 0..6 {
        let m = patch_mean(&sol, &total, p);
        assert!((m - expect).abs() < 0.005 * expect, "face {p}: {m} vs {expect}");
    }
    assert!(sol.stats.residual <= 1e-3, "residual {}", sol.stats.residual);
}

/// The furnace again with every face cut into 288 triangles, which the mesh merges
/// back into one lattice patch a face: every vertex, corners and edges included,
/// reaches E rho / (1 - rho). (Shooting from a sample of a merged patch's triangles
/// left dark seams where two faces meet and bright spots beside the triangles
/// taken; a receiving point too near a corner lost its rays to the other face.)
#[test]
fn furnace_of_merged_faces_is_even_to_the_corners() {
    let rho = 0.5;
    let e = 1.0;
    let faces = box_inside(Vec3::ZERO, Vec3::new(1.0, 0.8, 1.2));
    let split: Vec<(TriMesh, Rgb)> = faces
        .iter()
        .map(|f| {
            let c = [0, 1, 2, 3].map(|k| f.positions[k]);
            (crate::testutil::split_quad(c, 12), Vec3::splat(rho))
        })
        .collect();
    let emitters: Vec<(usize, Rgb)> = (0..6).map(|i| (i, Vec3::splat(e / PI))).collect();
    let s = scene(split, vec![], &emitters);
    let mut st = settings(0.1, 64, 2000);
    st.tolerance = 1e-3;
    let sol = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    assert_eq!(sol.mesh.patches.len(), 6);
    assert!(matches!(
        sol.mesh.patches[0].grids[0].domain,
        crate::mesh::Domain::Lattice(_)
    ));
    let total = sol.total();
    let expect = rho * e / (1.0 - rho);
    let worst = total
        .iter()
        .map(|t| (t.x - expect).abs() / expect)
        .fold(0.0, f32::max);
    assert!(worst < 0.03, "worst vertex off by {worst}");
}

/// A warped wall (one corner 2 cm out of the plane of the others on a 2 m wall,
/// as the Cornell box's left wall) sees a point light in front of it at every
/// vertex: its vertices lie on the two triangles the rays meet, not on a bilinear
/// surface up to 5 mm off them, behind which the light was hidden from blotches
/// of vertices. Both ways of warping.
#[test]
fn a_warped_wall_sees_a_light_in_front_of_it_everywhere() {
    for w in [0.02, -0.02] {
        let wall = quad([v(0., 0., 0.), v(2., 0., 0.), v(2., 2., w), v(0., 2., 0.)]);
        let light = Light::Point {
            position: v(1.0, 1.0, 1.0),
            intensity: Vec3::ONE,
        };
        let s = scene(vec![(wall, Vec3::splat(0.5))], vec![light], &[]);
        let sol = solve(&s, &Bvh::build(&s), &settings(0.1, 16, 0), &Silent).unwrap();
        let e = &sol.lists[0][0];
        assert_eq!(e.source, SourceId::Light(0));
        let hidden = e
            .occluded
            .iter()
            .zip(&e.unoccluded)
            .filter(|(o, u)| o.x < 0.999 * u.x)
            .count();
        assert_eq!(
            hidden,
            0,
            "warp {w}: {hidden} of {} vertices in shadow",
            e.occluded.len()
        );
        assert!(e.unoccluded.iter().all(|u| u.x > 0.0));
    }
}

/// A 2 x 2 floor at z = 0 (reflectance 0.5) lit by an area lamp past a black screen, solved at
/// `mesh_size` with up to 64 cells: each floor vertex's receiving point with the
/// visible fraction of the lamp there (its occluded over its unoccluded light).
fn lamp_past_a_screen(screen: [Vec3; 4], lamp: [Vec3; 4], mesh_size: f32) -> Vec<(Vec3, f32)> {
    let floor = quad([v(-1., -1., 0.), v(1., -1., 0.), v(1., 1., 0.), v(-1., 1., 0.)]);
    let s = scene(
        vec![
            (floor, Vec3::splat(0.5)),
            (quad(screen), Vec3::ZERO),
            (quad(lamp), Vec3::ZERO),
        ],
        vec![],
        &[(2, Vec3::ONE)],
    );
    let sol = solve(&s, &Bvh::build(&s), &settings(mesh_size, 64, 0), &Silent).unwrap();
    // The floor's patches (a floor of more than 64 elements a side is cut into several).
    let floor_patches = (0..sol.mesh.front_patches as usize).filter(|&p| sol.mesh.patches[p].shape == 0);
    floor_patches
        .flat_map(|p| {
            let e = &sol.lists[p][0];
            let first = sol.mesh.patches[p].first_vertex as usize;
            let mesh = &sol.mesh;
            e.occluded
                .iter()
                .zip(&e.unoccluded)
                .enumerate()
                .map(move |(k, (o, u))| (mesh.vertices[first + k].q, o.x / u.x))
        })
        .collect()
}

/// The penumbra of a small square light (0.2 m, 2 m up) behind the straight edge of
/// a screen halfway down: at floor vertex x the visible part of the light is
/// (0.1 + x) / 0.2 exactly. The light is one cell from there, so one shadow ray
/// would say 0 or 1 (mean error 0.30 across the penumbra). The first rays find the
/// light partly hidden, and the sixteen of the refinement follow it, only where they
/// disagree: with two first rays the error is 0.088 (a vertex with a tenth of the
/// light hidden passes for lit four times in five), with four 0.059, with eight 0.042.
#[test]
fn the_penumbra_of_a_small_light_follows_the_visible_part_of_it() {
    let screen = [v(-3., -3., 1.), v(-3., 3., 1.), v(0., 3., 1.), v(0., -3., 1.)];
    let lamp = [
        v(-0.1, -0.1, 2.),
        v(-0.1, 0.1, 2.),
        v(0.1, 0.1, 2.),
        v(0.1, -0.1, 2.),
    ];
    let (mut err, mut count) = (0.0, 0);
    for (q, got) in lamp_past_a_screen(screen, lamp, 0.02) {
        let x = q.x;
        let exact = ((0.1 + x) / 0.2).clamp(0.0, 1.0);
        if x.abs() < 0.1 {
            err += (got - exact).abs();
            count += 1;
        } else if x.abs() > 0.101 {
            assert!((got - exact).abs() < 1e-6, "x {x}: {got} outside the penumbra");
        }
    }
    let mean = err / count as f32;
    assert!(count > 500, "{count} vertices in the penumbra");
    assert!(
        mean < 0.07,
        "mean error {mean} of the visible part over {count} vertices"
    );
}

/// A 2 x 2 lamp half a unit above a screen's edge, seen from a floor a unit below
/// it: every floor vertex takes all 64 cells, and the screen's slanted edge crosses
/// several of them. The cells at the shadow's edge get more rays than one each, so
/// the visible fraction is close to the exact one (the form factor of the part of the
/// lamp the screen leaves, by Lambert's formula) at every vertex, not only on
/// average.
#[test]
fn cells_at_a_shadows_edge_are_sampled_again() {
    // The screen covers x + 0.3 y < 0 at height 0.5.
    let screen = [
        v(-3., -3., 0.5),
        v(-3., 3., 0.5),
        v(-0.9, 3., 0.5),
        v(0.9, -3., 0.5),
    ];
    let corners = [v(-1., -1., 1.), v(-1., 1., 1.), v(1., 1., 1.), v(1., -1., 1.)];
    let up = Vec3::Z;
    let (mut err, mut count) = (0.0, 0);
    for (q, got) in lamp_past_a_screen(screen, corners, 0.05) {
        // From q, a lamp point p is hidden where the midpoint of q and p is under
        // the screen: p.x + 0.3 p.y < -(q.x + 0.3 q.y). Clip the lamp to the rest.
        let g = |p: Vec3| p.x + 0.3 * p.y + q.x + 0.3 * q.y;
        let mut visible = Vec::new();
        for i in 0..4 {
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            if g(a) >= 0.0 {
                visible.push(a);
            }
            if (g(a) >= 0.0) != (g(b) >= 0.0) {
                visible.push(a + (b - a) * (g(a) / (g(a) - g(b))));
            }
        }
        let exact = if visible.len() >= 3 {
            point_polygon_form_factor(q, up, &visible) / point_polygon_form_factor(q, up, &corners)
        } else {
            0.0
        };
        if (0.05..0.95).contains(&exact) {
            err += (got - exact).abs();
            count += 1;
        }
    }
    let mean = err / count as f32;
    assert!(count > 300, "{count} vertices in the penumbra");
    // One ray per cell: 0.015; four at the edge: 0.0068; sixteen where four leave
    // more than 1 % standard error: 0.0052 (the seed is fixed).
    assert!(
        mean < 0.006,
        "mean error {mean} of the visible fraction over {count} vertices"
    );
}

/// Emitted = absorbed + unshot, in a closed box lit by a point light.
#[test]
fn energy_is_conserved_in_a_closed_box() {
    let rho = 0.6;
    let s = lit_box(rho);
    let mut st = settings(0.1, 32, 300);
    st.tolerance = 0.02;
    let sol = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    let absorbed = absorbed_power(&sol, rho);
    let unshot = sol.stats.residual * sol.stats.emitted_power;
    let emitted = sol.stats.emitted_power;
    assert!((emitted - 4.0 * std::f64::consts::PI * 3.0).abs() < 1e-3);
    assert!(
        ((absorbed + unshot) - emitted).abs() < 0.015 * emitted,
        "{absorbed} + {unshot} vs {emitted}"
    );
}

/// Keeping sources apart changes where light is stored, never how much.
#[test]
fn lists_plus_general_equal_the_total_of_an_unseparated_solve() {
    let faces = box_inside(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.5));
    let mut shapes: Vec<(crate::geometry::TriMesh, Rgb)> =
        faces.into_iter().map(|f| (f, Vec3::new(0.7, 0.5, 0.3))).collect();
    // An occluder, so that some contributions are partly shadowed.
    let v = Vec3::new;
    shapes.push((
        quad([
            v(0.8, 0.2, 0.7),
            v(1.2, 0.2, 0.7),
            v(1.2, 0.2, 1.1),
            v(0.8, 0.2, 1.1),
        ]),
        Vec3::splat(0.5),
    ));
    let lights = vec![
        Light::Point {
            position: v(0.5, 0.8, 0.7),
            intensity: Vec3::splat(2.0),
        },
        Light::Point {
            position: v(1.6, 0.5, 0.3),
            intensity: v(1.0, 2.0, 3.0),
        },
    ];
    let s = scene(shapes, lights, &[]);
    let bvh = Bvh::build(&s);
    let mut st = settings(0.2, 16, 60);
    st.sources_per_patch = 0;
    let plain = solve(&s, &bvh, &st, &Silent).unwrap();
    assert!(plain.lists.iter().all(|l| l.is_empty()));
    st.sources_per_patch = 2;
    let (sep, folded) = solve_traced(&s, &bvh, &st, &Silent).unwrap();
    assert!(
        sep.lists.iter().any(|l| l.len() == 2),
        "some patch keeps two sources"
    );
    let (a, b) = (plain.total(), sep.total());
    for (x, y) in a.iter().zip(&b) {
        assert!(
            (*x - *y).abs().max_element() <= 1e-4 * (1.0 + x.max_element()),
            "{x} vs {y}"
        );
    }
    // One route per source: nothing listed on a patch was folded into its general term.
    for (p, list) in sep.lists.iter().enumerate() {
        for e in list {
            assert!(
                !folded[p].contains(&e.source),
                "patch {p}: {:?} listed and folded",
                e.source
            );
        }
        assert!(list.len() <= 2);
    }
    // Unoccluded is never less than occluded.
    for e in sep.lists.iter().flatten() {
        for (o, u) in e.occluded.iter().zip(&e.unoccluded) {
            assert!((*u - *o).min_element() >= -1e-6);
        }
    }
}

/// A dim light and a bright white patch next to a receiver: with n = 1 the
/// patch brings the receiver more light than the light, but may not evict it.
#[test]
fn radiant_patches_never_evict_lights() {
    let v = Vec3::new;
    // Receiver: the floor square at z = 0 facing up; a bright white wall at x = 1
    // facing -x, lit by a strong narrow spot aimed at it (missing the floor); a dim
    // point light above the floor.
    let floor = quad([
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(0.0, 1.0, 0.0),
    ]);
    let wall = quad([
        v(1.0, 0.0, 0.0),
        v(1.0, 0.0, 1.0),
        v(1.0, 1.0, 1.0),
        v(1.0, 1.0, 0.0),
    ]);
    let lights = vec![
        Light::Spot {
            position: v(0.05, 0.5, 0.5),
            direction: v(1.0, 0.0, 0.0),
            intensity: Vec3::splat(50.0),
            cutoff_angle: 0.3,
            beam_width: 0.2,
        },
        Light::Point {
            position: v(0.5, 0.5, 2.0),
            intensity: Vec3::splat(0.01),
        },
    ];
    let s = scene(vec![(floor, Vec3::splat(0.5)), (wall, Vec3::ONE)], lights, &[]);
    let bvh = Bvh::build(&s);
    let mut st = settings(0.25, 16, 5);
    st.sources_per_patch = 1;
    let (sol, folded) = solve_traced(&s, &bvh, &st, &Silent).unwrap();
    let floor_list = &sol.lists[0];
    assert_eq!(floor_list.len(), 1);
    assert_eq!(
        floor_list[0].source,
        SourceId::Light(1),
        "the dim light stays listed"
    );
    assert!(
        folded[0].contains(&SourceId::Patch(1)),
        "the brighter wall went to the general radiosity: {:?}",
        folded[0]
    );
    // It was brighter: its share of the floor's general radiosity exceeds the light's.
    let first = sol.mesh.patches[0].first_vertex as usize;
    let n = sol.mesh.patches[0].vertex_count as usize;
    let general: f32 = sol.general[first..first + n].iter().map(|c| c.x).sum();
    let light: f32 = floor_list[0].occluded.iter().map(|c| c.x).sum();
    assert!(general > light, "{general} vs {light}");
}

#[test]
fn same_seed_same_solution() {
    let faces = box_inside(Vec3::ZERO, Vec3::ONE);
    let light = Light::Point {
        position: Vec3::splat(0.5),
        intensity: Vec3::ONE,
    };
    let s = scene(
        faces.into_iter().map(|f| (f, Vec3::splat(0.5))).collect(),
        vec![light],
        &[],
    );
    let bvh = Bvh::build(&s);
    let st = settings(0.25, 8, 30);
    let a = solve(&s, &bvh, &st, &Silent).unwrap();
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| solve(&s, &bvh, &st, &Silent).unwrap());
    assert_eq!(a.general, b.general);
    assert_eq!(a.lists, b.lists);
}

/// A point light at height h over a plane cut into many triangles (merged into one
/// patch): every vertex's radiosity is rho I h / r^3.
#[test]
fn point_light_over_a_merged_plane_matches_the_closed_form() {
    // A 4 x 4 plane centred on the origin, 40 x 40 cells of two triangles.
    let plane = crate::testutil::centred_square(4.0, 40);
    let (h, i0, rho) = (1.5f32, 2.0f32, 0.6f32);
    let light = Light::Point {
        position: Vec3::new(0.3, -0.2, h),
        intensity: Vec3::splat(i0),
    };
    let s = scene(vec![(plane, Vec3::splat(rho))], vec![light], &[]);
    let mut st = settings(0.5, 4, 0);
    st.photons = 16;
    let sol = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    assert_eq!(sol.mesh.patches.len(), 1);
    assert!(sol.mesh.vertices.len() < 200, "{}", sol.mesh.vertices.len());
    let e = &sol.lists[0][0];
    for (v, b) in sol.mesh.vertices.iter().zip(&e.occluded) {
        let d = Vec3::new(0.3, -0.2, h) - v.q;
        let r = d.length();
        let expect = rho * i0 * h / (r * r * r);
        assert!(
            (b.x - expect).abs() < 1e-3 * expect,
            "{:?}: {} vs {expect}",
            v.q,
            b.x
        );
    }
    // A plane alone reflects nothing back onto itself.
    assert!(sol.general.iter().all(|g| g.x == 0.0));
}

/// A small emitting sphere (radius 5 cm, radiance L, 1 m up) over a plane: each
/// vertex gets pi L sin^2(alpha) cos(theta), sin(alpha) = r / d, from the light's
/// shot. Its cells, pieces of the sphere cut by chords, brought 9 % too little
/// before their sum was scaled to that closed form.
#[test]
fn a_small_sphere_light_over_a_plane_matches_the_closed_form() {
    let plane = crate::testutil::centred_square(4.0, 16);
    let (c, r, l, rho) = (Vec3::new(0.3, -0.2, 1.0), 0.05f32, 40.0f32, 0.6f32);
    let s = scene(
        vec![
            (plane, Vec3::splat(rho)),
            (crate::geometry::shapes::sphere(c, r), Vec3::ZERO),
        ],
        vec![],
        &[(1, Vec3::splat(l))],
    );
    let sol = solve(&s, &Bvh::build(&s), &settings(0.5, 64, 0), &Silent).unwrap();
    let e = &sol.lists[0][0];
    let floor = sol.mesh.patches[0].vertex_count as usize;
    assert!(floor > 50, "{floor}");
    for (v, b) in sol.mesh.vertices[..floor].iter().zip(&e.unoccluded) {
        let d = c - v.q;
        let expect = rho * PI * l * (r * r / d.length_squared()) * (d.z / d.length());
        assert!(
            (b.x - expect).abs() < 2e-3 * expect,
            "{:?}: {} vs {expect}",
            v.q,
            b.x
        );
    }
    // Nothing stands between: all of it arrives.
    let (mut got, mut sent) = (0.0f64, 0.0f64);
    for (v, (o, u)) in sol.mesh.vertices[..floor]
        .iter()
        .zip(e.occluded.iter().zip(&e.unoccluded))
    {
        got += f64::from(o.x * v.area);
        sent += f64::from(u.x * v.area);
    }
    assert!((got / sent - 1.0).abs() < 0.01, "{got} vs {sent}");
}

/// A point light 10 cm over the middle of a 40 cm square (a lamp's reflector, a
/// shade's floor) sends it I times the square's solid angle, 4 atan(a b / (h
/// sqrt(h^2 + a^2 + b^2))) for half sides a, b. At a mesh size of 0.2 the square
/// would be 2 x 2 elements whose vertices, one under the light, take 31 % too
/// much; meshed at a quarter of it as a small patch near a small light, within 3 %.
/// A like square 2 m away is left at the mesh size.
#[test]
fn a_small_patch_near_a_light_is_meshed_finer_and_takes_the_power_it_gets() {
    let (a, h, i0, rho) = (0.2f32, 0.1f32, 2.0f32, 0.5f32);
    let square = |x: f32| {
        quad([
            v(x - a, -a, 0.0),
            v(x + a, -a, 0.0),
            v(x + a, a, 0.0),
            v(x - a, a, 0.0),
        ])
    };
    let light = Light::Point {
        position: v(0.0, 0.0, h),
        intensity: Vec3::splat(i0),
    };
    let s = scene(
        vec![(square(0.0), Vec3::splat(rho)), (square(2.0), Vec3::splat(rho))],
        vec![light],
        &[],
    );
    let sol = solve(&s, &Bvh::build(&s), &settings(0.2, 16, 0), &Silent).unwrap();
    let (near, far) = (&sol.mesh.patches[0], &sol.mesh.patches[1]);
    assert_eq!(sol.mesh.refined, 1);
    assert_eq!(near.element_count, 64);
    assert!(far.element_count < 16, "{}", far.element_count);
    let first = near.first_vertex as usize;
    let got: f32 = sol.mesh.vertices[first..first + near.vertex_count as usize]
        .iter()
        .zip(&sol.lists[0][0].unoccluded)
        .map(|(vx, b)| b.x / rho * vx.area)
        .sum();
    let want = i0 * 4.0 * (a * a / (h * (h * h + 2.0 * a * a).sqrt())).atan();
    assert!((got / want - 1.0).abs() < 0.03, "{got} vs {want}");
}

/// Photons: the same solution for a seed at 1 and 2 threads; energy still conserved.
#[test]
fn photons_give_the_same_solution_at_one_and_two_threads_and_conserve_energy() {
    let rho = 0.6;
    let s = lit_box(rho);
    let bvh = Bvh::build(&s);
    let mut st = photon_settings(3, 64);
    let a = solve(&s, &bvh, &st, &Silent).unwrap();
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| solve(&s, &bvh, &st, &Silent).unwrap());
    assert_eq!(a.general, b.general);
    assert_eq!(a.lists, b.lists);
    assert!(a.stats.photons > 0 && a.stats.patch_shots == 3);
    // Everything emitted is absorbed: rho / (1 - rho) of the direct light comes back.
    assert_absorbs(&a, rho, 0.98, 1.02);
    // --max-photons caps the photons in all (here a tenth of 64 per vertex), and
    // the fewer photons still carry all the power.
    let asked = a.stats.photons;
    st.max_photons = asked / 10;
    let c = solve(&s, &bvh, &st, &Silent).unwrap();
    assert_eq!(c.stats.photons, asked / 10);
    assert_absorbs(&c, rho, 0.97, 1.03);
}

/// The photons stop once their light has settled (`noise`): well before the 256 a
/// vertex asked for in a plain lit box, with all the power carried, and two seeds'
/// solutions then differ, vertex by vertex, by about what the rule allows.
#[test]
fn photons_stop_once_their_light_has_settled() {
    let rho = 0.6;
    let s = lit_box(rho);
    let bvh = Bvh::build(&s);
    let mut st = photon_settings(3, 256);
    let a = solve(&s, &bvh, &st, &Silent).unwrap();
    let receiving = a.mesh.vertices.len() as u64;
    assert!(
        a.stats.photons < 128 * receiving && a.stats.photons >= noise::FIRST_PER_VERTEX * receiving,
        "{} photons for {receiving} vertices",
        a.stats.photons
    );
    assert_absorbs(&a, rho, 0.97, 1.03);
    st.seed = 4;
    let b = solve(&s, &bvh, &st, &Silent).unwrap();
    let (ta, tb) = (a.total(), b.total());
    let (mut diff, mut area) = (0.0, 0.0);
    for (v, (x, y)) in a.mesh.vertices.iter().zip(ta.iter().zip(&tb)) {
        diff += v.area * ((x.x - y.x).abs() / (0.5 * (x.x + y.x)));
        area += v.area;
    }
    let diff = diff / area;
    assert!(diff < 3.0 * noise::SETTLED, "seeds {diff} apart");
}

/// A furnace with a box resting on its floor (faces wound outwards): every
/// surface emits and reflects alike, so the floor's radiosity is rho / (1 - rho)
/// right up to the box, where the vertices inside the box's footprint (in the
/// dark inside it) used to pull the cell around it down by half.
#[test]
fn furnace_with_a_box_resting_on_the_floor_stays_even_up_to_the_box() {
    let rho = 0.5;
    let mut shapes: Vec<TriMesh> = box_inside(Vec3::ZERO, Vec3::new(3.0, 1.5, 2.0));
    shapes.extend(box_outside(Vec3::new(1.0, 0.0, 0.6), Vec3::new(2.0, 0.4, 1.4)));
    let emitters: Vec<(usize, Rgb)> = (0..12).map(|i| (i, Vec3::splat(1.0 / PI))).collect();
    let s = scene(
        shapes.into_iter().map(|f| (f, Vec3::splat(rho))).collect(),
        vec![],
        &emitters,
    );
    let bvh = Bvh::build(&s);
    let mut st = settings(0.2, 64, 40);
    st.photons = 64;
    let sol = solve(&s, &bvh, &st, &Silent).unwrap();
    let total = sol.total();
    let expect = rho / (1.0 - rho);
    // Points of the floor (face 2) within a cell of the box, all round it.
    let mut worst = expect;
    for k in 0..40 {
        let t = k as f32 / 40.0;
        for p in [
            Vec3::new(1.0 + t, 0.0, 0.55),
            Vec3::new(1.0 + t, 0.0, 1.45),
            Vec3::new(0.95, 0.0, 0.6 + 0.8 * t),
            Vec3::new(2.05, 0.0, 0.6 + 0.8 * t),
        ] {
            let ray = crate::accel::Ray {
                origin: p + Vec3::Y * 0.01,
                dir: -Vec3::Y,
                tmin: 0.0,
                tmax: 1.0,
            };
            let hit = bvh.intersect(&ray).expect("the floor");
            assert_eq!(hit.shape, 2);
            let b = sol.mesh.locate(&s, &hit, p, true).apply(&total).x;
            worst = worst.min(b);
        }
    }
    assert!(
        worst > 0.93 * expect,
        "floor beside the box: {worst} against {expect}"
    );
}

/// The furnace with photons carrying all but the first shots.
#[test]
fn furnace_with_photons() {
    let rho = 0.5;
    let faces = box_inside(Vec3::ZERO, Vec3::ONE);
    let emitters: Vec<(usize, Rgb)> = (0..6).map(|i| (i, Vec3::splat(1.0 / PI))).collect();
    let s = scene(
        faces.into_iter().map(|f| (f, Vec3::splat(rho))).collect(),
        vec![],
        &emitters,
    );
    let mut st = settings(0.1, 16, 6);
    st.photons = 256;
    let sol = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    let total = sol.total();
    let expect = rho / (1.0 - rho);
    for p in 0..6 {
        let m = patch_mean(&sol, &total, p);
        assert!((m - expect).abs() < 0.02 * expect, "face {p}: {m} vs {expect}");
    }
}

/// A spot's cone on a floor meshed coarsely against it: the light the floor
/// passes on is its reflectance times all the spot emits (the closed form of
/// `light_power`), to 0.6 % (0.5 % seen), wherever the beam's edges cut the
/// elements. With the irradiance at the vertices alone it was off by up to 5.4 %
/// here (0.970, 1.003, 0.946 and 0.996 of it). The same with the floor made of
/// triangles a fifth of an element's side, whose pieces take fewer points each
/// (`project::points_on`).
#[test]
fn a_spot_on_a_coarse_floor_passes_on_the_power_it_brings() {
    let rho = 0.6;
    let corners = [
        v(-3.0, -3.0, 0.0),
        v(3.0, -3.0, 0.0),
        v(3.0, 3.0, 0.0),
        v(-3.0, 3.0, 0.0),
    ];
    for (name, floor) in [
        ("grid", quad(corners)),
        ("lattice", crate::testutil::split_quad(corners, 6)),
        ("small triangles", crate::testutil::split_quad(corners, 100)),
    ] {
        for (x, y, h) in [(0.37, 0.11, 1.0), (-0.9, 0.6, 1.7)] {
            let lights = vec![Light::Spot {
                position: v(x, y, h),
                direction: v(0.0, 0.0, -1.0),
                intensity: Vec3::splat(10.0),
                cutoff_angle: 0.5,
                beam_width: 0.35,
            }];
            let s = scene(vec![(floor.clone(), Vec3::splat(rho))], lights, &[]);
            let st = settings(0.3, 16, 0);
            let sol = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
            // What is left unshot (the residual is of the reference power, itself
            // what the floor received) against the closed form: rho times all the
            // spot emits, its whole cone being on the floor.
            let unshot = sol.stats.residual * sol.stats.reference_power;
            let passed = unshot / (f64::from(rho) * sol.stats.emitted_power);
            assert!(
                (passed - 1.0).abs() < 0.006,
                "{name} at ({x}, {y}, {h}): {passed}"
            );
        }
    }
}

/// A kept shot sends what the patch's cells now hold through the form factors and
/// visibility of its first shot: in a closed empty box (everything visible) the same
/// as shooting again, and with a box inside, the same up to the visibility noise of
/// one ray per cell.
#[test]
fn a_kept_shot_sends_what_a_new_shot_would() {
    let rho = 0.7;
    let room = || box_inside(Vec3::ZERO, Vec3::new(2.5, 1.6, 2.0));
    let light = Light::Spot {
        position: Vec3::new(1.2, 1.5, 1.0),
        direction: -Vec3::Y,
        intensity: Vec3::splat(5.0),
        cutoff_angle: 0.6,
        beam_width: 0.45,
    };
    let mut st = settings(0.25, 64, 40);
    st.tolerance = 0.002;
    let empty = scene(
        room().into_iter().map(|f| (f, Vec3::splat(rho))).collect(),
        vec![light.clone()],
        &[],
    );
    let bvh = Bvh::build(&empty);
    let kept = solve_keeping(&empty, &bvh, &st, transfer::BUDGET).unwrap();
    let fresh = solve_keeping(&empty, &bvh, &st, 0).unwrap();
    assert!(kept.stats.reused_shots > 10, "{:?}", kept.stats);
    assert_eq!(fresh.stats.reused_shots, 0);
    assert_eq!(kept.stats.patch_shots, fresh.stats.patch_shots);
    assert!(kept.stats.rays < fresh.stats.rays / 2);
    let (a, b) = (kept.total(), fresh.total());
    for (x, y) in a.iter().zip(&b) {
        assert!(
            (*x - *y).abs().max_element() <= 1e-4 * y.max_element().max(1e-3),
            "{x} vs {y}"
        );
    }

    let mut shapes = room();
    shapes.extend(box_outside(Vec3::new(0.8, 0.0, 0.5), Vec3::new(1.6, 0.7, 1.3)));
    let boxed = scene(
        shapes.into_iter().map(|f| (f, Vec3::splat(rho))).collect(),
        vec![light],
        &[],
    );
    let bvh = Bvh::build(&boxed);
    let kept = solve_keeping(&boxed, &bvh, &st, transfer::BUDGET).unwrap();
    let fresh = solve_keeping(&boxed, &bvh, &st, 0).unwrap();
    assert!(kept.stats.reused_shots > 10);
    let (a, b) = (kept.total(), fresh.total());
    // The ceiling (face 3 of the room) sees the lit floor past the box.
    let ceiling = 3;
    let (ma, mb) = (patch_mean(&kept, &a, ceiling), patch_mean(&fresh, &b, ceiling));
    assert!(mb > 0.05, "the ceiling is lit: {mb}");
    assert!(
        (ma / mb - 1.0).abs() < 0.01,
        "ceiling {ma} kept vs {mb} shot again"
    );
}

/// A kept shot takes a cell that a wall stands on piece by piece again: two rooms
/// whose floor, ceiling and side walls run on under a closed dividing wall, a green
/// light in the far room and a red one in the near room. The green that a kept shot
/// brings into the near room (along the dividing wall's edges, where receivers lie
/// millimetres from the cells the wall stands on) is what a shot cast anew brings.
/// Before, the first shot's one visibility per cell, times the cell's light read
/// plainly at a later shot, gave those vertices up to 3.4 times as much (see
/// `transfer`).
#[test]
fn a_kept_shot_takes_a_cell_a_wall_stands_on_anew() {
    let (lo, hi) = (Vec3::ZERO, Vec3::new(5.0, 2.5, 2.0));
    let mut shapes = box_inside(lo, hi);
    // Inside a shooting cell, not on a border between two.
    shapes.extend(box_outside(Vec3::new(2.15, 0.0, 0.0), Vec3::new(2.25, 2.5, 2.0)));
    let spot = |x: f32, intensity: Vec3| Light::Spot {
        position: Vec3::new(x, 2.3, 1.0),
        direction: -Vec3::Y,
        intensity,
        cutoff_angle: 1.2,
        beam_width: 1.0,
    };
    let two = scene(
        shapes.into_iter().map(|f| (f, Vec3::splat(0.7))).collect(),
        vec![
            spot(3.8, Vec3::new(0.0, 5.0, 0.0)),
            spot(1.2, Vec3::new(5.0, 0.0, 0.0)),
        ],
        &[],
    );
    let bvh = Bvh::build(&two);
    let mut st = settings(0.3, 64, 30);
    st.tolerance = 0.002;
    let kept = solve_keeping(&two, &bvh, &st, transfer::BUDGET).unwrap();
    let fresh = solve_keeping(&two, &bvh, &st, 0).unwrap();
    assert!(kept.stats.reused_shots > 10, "{:?}", kept.stats);
    let (a, b) = (kept.total(), fresh.total());
    let mut compared = 0;
    for ((v, x), y) in kept.mesh.vertices.iter().zip(&a).zip(&b) {
        if v.p.x < 2.151 && y.y > 0.005 {
            compared += 1;
            assert!(
                (x.y / y.y - 1.0).abs() < 0.05,
                "green at {} (normal {}): kept {}, shot anew {}",
                v.p,
                v.n,
                x.y,
                y.y
            );
        }
    }
    assert!(compared > 10, "{compared} near-room vertices with green");
    // The green room's light stays out of the red room: its brightest green vertex
    // (on the dividing wall's edge rows) holds 2.4 % of the green room's mean. A
    // read judged the far side's vertex by its mean over the channels, which the red
    // room's own light outweighed, and took its green: 10 %.
    let (mut lit, mut n, mut dark) = (0.0, 0, 0.0f32);
    for (v, t) in kept.mesh.vertices.iter().zip(&a) {
        if v.p.x > 2.249 {
            lit += t.y;
            n += 1;
        } else if v.p.x < 2.151 {
            dark = dark.max(t.y);
        }
    }
    let lit = lit / n as f32;
    assert!(
        dark < 0.04 * lit,
        "red room's brightest green {dark}, green room's mean {lit}"
    );
}

#[test]
fn cells_touch_where_they_share_a_corner() {
    let cell = |x: f32, y: f32| {
        let poly = [
            v(x, y, 0.),
            v(x + 1., y, 0.),
            v(x + 1., y + 1., 0.),
            v(x, y + 1., 0.),
        ];
        ShootPoint {
            p: poly[0],
            n: Vec3::Z,
            poly,
            len: 4,
            radiosity: Vec3::ONE,
            quarters: None,
            sixteenths: None,
            flat: true,
            far: None,
            parted: false,
            mixed: 0,
            cell_of: None,
        }
    };
    let cells = [cell(0., 0.), cell(1., 0.), cell(2., 1.), cell(5., 5.)];
    let t = Touching::new(&cells);
    assert_eq!(t.of(0), &[1]);
    assert_eq!(t.of(1), &[0, 2], "a shared corner is enough");
    assert_eq!(t.of(2), &[1]);
    assert_eq!(t.of(3), &[] as &[u32]);
    assert_eq!(t.of(9), &[] as &[u32], "no such cell");
}

/// Photons leave a curved patch from its surface, not from its elements' chords: a
/// closed two-sided Bezier teapot (its lid on) on a floor under a point light, meshed
/// coarsely (elements of about a third of its size), stays darker inside than out.
/// From the chords, which lie inside its convex parts, photons lit the inside more
/// brightly than the outside (area-weighted mean 1.23 times the outside's here, 1.52
/// in the paper room).
#[test]
fn photons_from_a_curved_patch_do_not_light_a_closed_objects_inside() {
    let teapot = crate::testutil::teapot_bpt();
    let text = format!(
        r#"<scene version="3.0.0">
  <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></bsdf>
  <shape type="rectangle"><transform name="to_world"><scale value="2"/></transform><ref id="white"/></shape>
  <shape type="bezier" id="teapot">
    <string name="filename" value="{}"/>
    <transform name="to_world"><scale value="0.1"/></transform>
    <ref id="white"/>
  </shape>
  <emitter type="point"><point name="position" x="0.4" y="0.3" z="1.2"/><rgb name="intensity" value="5"/></emitter>
  <sensor type="perspective"><transform name="to_world"><lookat origin="1, 1, 1" target="0, 0, 0" up="0, 0, 1"/></transform></sensor>
</scene>"#,
        teapot.display()
    );
    let s = crate::scene::xml::load_str(std::path::Path::new("teapot.xml"), &text, &[])
        .unwrap()
        .scene;
    let bvh = Bvh::build(&s);
    let st = SolveSettings {
        tolerance: 0.01,
        seed: 1,
        photons: 64,
        ..settings(0.1, 64, 40)
    };
    let sol = solve(&s, &bvh, &st, &crate::progress::Silent).unwrap();
    let total = sol.total();
    let m = &sol.mesh;
    let (mut outside, mut inside) = ((0.0f64, 0.0f64), (0.0f64, 0.0f64));
    for (v, vx) in m.vertices.iter().enumerate() {
        if m.patches[vx.patch as usize].shape != 1 {
            continue;
        }
        let side = if vx.patch >= m.front_patches {
            &mut inside
        } else {
            &mut outside
        };
        side.0 += f64::from(mean(total[v]) * vx.area);
        side.1 += f64::from(vx.area);
    }
    let ratio = (inside.0 / inside.1) / (outside.0 / outside.1);
    assert!(sol.stats.photons > 0 && outside.0 > 0.0);
    // (Measured 0.34; 1.23 from the chords. What is left is not all the lid's gap:
    // the shots alone leave the paper room's teapot at 0.016, photons at 0.14.)
    assert!(ratio < 0.6, "inside {ratio:.3} of the outside");
}

/// Under a sky dome (an emitting sphere, black inside, around a floor and a box)
/// most of the emitted power lands on the dome itself: the tolerance is a fraction
/// of the power that reaches the reflecting surfaces instead, so the floor's
/// reflected light is still shot deterministically, not all left to the photons.
#[test]
fn the_tolerance_is_a_fraction_of_the_power_reaching_reflecting_surfaces() {
    use crate::geometry::shapes;
    let mut dome = shapes::sphere(Vec3::ZERO, 20.0);
    dome.flip_normals();
    let s = scene(
        vec![
            (
                crate::testutil::square(-3.0, 3.0, -3.0, 3.0, 0.0, false),
                Vec3::splat(0.6),
            ),
            (
                box_outside(v(-0.5, -0.5, 0.0), v(0.5, 0.5, 1.0)).remove(4),
                Vec3::splat(0.6),
            ),
            (dome, Vec3::ZERO),
        ],
        Vec::new(),
        &[(2, Vec3::splat(1.0))],
    );
    let bvh = Bvh::build(&s);
    let mut st = settings(0.5, 16, 10);
    st.tolerance = 0.01;
    st.photons = 16;
    let sol = solve(&s, &bvh, &st, &Silent).unwrap();
    // The floor (36 m^2 of the dome's 5000) receives about pi x 36 W of the dome's
    // pi x 5027 W.
    let (reference, emitted) = (sol.stats.reference_power, sol.stats.emitted_power);
    assert!(
        (reference / (PI as f64 * 37.0) - 1.0).abs() < 0.1,
        "{reference} of {emitted}"
    );
    assert!(sol.stats.patch_shots >= 1, "{:?}", sol.stats);
}

/// Where a patch shot would cast far more rays for the power it carries than the
/// photon budget would (a fine mesh, a small `max_photons`), the photons carry all
/// that the light's shot leaves, and everything emitted is still absorbed, be it 30 %
/// of the power or 60 % (reflectances 0.3 and 0.6); with a budget of photons enough
/// for the mesh, or none, the patches shoot.
#[test]
fn patch_shots_give_way_to_photons_where_they_cost_far_more_rays() {
    let rho = 0.3;
    let s = lit_box(rho);
    let bvh = Bvh::build(&s);
    let mut st = settings(0.05, 32, 5);
    st.tolerance = 0.01;
    st.photons = 64;
    // About 5,600 vertices: a patch shot casts some 100 k rays for a sixth of the
    // power at most; 15 k photons cast some 30 k rays for all of it.
    st.max_photons = 15_000;
    let a = solve(&s, &bvh, &st, &Silent).unwrap();
    assert!(a.mesh.vertices.len() > 5000, "{}", a.mesh.vertices.len());
    assert_eq!((a.stats.light_shots, a.stats.patch_shots), (1, 0));
    assert_eq!(a.stats.photons, 15_000);
    assert_absorbs(&a, rho, 0.97, 1.03);
    // With a budget of 64 photons a vertex the shots cost no more per unit of power
    // than the photons, and with none (no cap) the rule is off: the patches shoot.
    st.max_photons = 64 * a.mesh.vertices.len() as u64;
    let b = solve(&s, &bvh, &st, &Silent).unwrap();
    assert_eq!(b.stats.patch_shots, 5);
    st.max_photons = 0;
    let b = solve(&s, &bvh, &st, &Silent).unwrap();
    assert_eq!(b.stats.patch_shots, 5);
    // Reflectance 0.6 (the same box, so the same BVH): 60 % left after the light's
    // shot, all of it carried by the photons.
    st.max_photons = 15_000;
    st.max_shots = 100;
    let c = solve(&lit_box(0.6), &bvh, &st, &Silent).unwrap();
    assert_eq!(c.stats.patch_shots, 0, "{:?}", c.stats);
    assert!(c.stats.residual > 0.5, "{:?}", c.stats);
    assert_absorbs(&c, 0.6, 0.97, 1.03);
}

/// A glossy metal floor in pass 1 (white furnace of its lobe): the lit box with its
/// floor a rough conductor of Fresnel 1 and GGX roughness 0.05, which keeps no
/// radiosity and passes on all it receives but the few per cent single scattering
/// loses. The light its lights' photons and the walls' photons bring there is
/// reflected by the lobe, not lost: the walls absorb what the light emits, less the
/// lobe's loss; with the floor black instead they absorb far less.
#[test]
fn a_glossy_floor_passes_its_light_on_in_pass_1() {
    use crate::scene::BsdfKind;
    let rho = 0.6;
    let (mut s, b) = lit_box_with_glossy_floor(rho);
    let bvh = Bvh::build(&s);
    let st = photon_settings(20, 64);
    let a = solve(&s, &bvh, &st, &Silent).unwrap();
    let emitted = a.stats.emitted_power;
    assert_absorbs(&a, rho, 0.95, 1.02);
    // A cap on the photons holds for the lights' and the shots' photons together as
    // well: at most twice it in all.
    let mut capped = st;
    capped.max_photons = 3000;
    let c = solve(&s, &bvh, &capped, &Silent).unwrap();
    assert!(c.stats.photons <= 6000 && c.stats.photons > 3000, "{:?}", c.stats);
    s.bsdfs[b].kind = BsdfKind::Diffuse {
        reflectance: Vec3::ZERO,
    };
    let black = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    assert!(absorbed_power(&black, rho) < 0.8 * emitted);
}

/// A solve cut short by its time budget still carries all the light: every kind of
/// photon (the patches', the lights' aimed at the glossy floor, the shots' that meet
/// it) is traced from the start, each scaled by its own share traced. Traced one
/// kind after the other, the first round held only the patches' photons, scaled up
/// to stand for the others' too.
#[test]
fn photons_cut_short_by_the_time_budget_still_conserve_energy() {
    let rho = 0.6;
    let (s, _) = lit_box_with_glossy_floor(rho);
    let bvh = Bvh::build(&s);
    let mut st = photon_settings(20, 256);
    // A budget already spent: no patch shot, and one round of photon chunks.
    st.time_limit = 1e-9;
    let a = solve(&s, &bvh, &st, &Silent).unwrap();
    assert!(a.stats.timed_out && a.stats.patch_shots == 0, "{:?}", a.stats);
    let rounds = (4 * rayon::current_num_threads()).max(8) as u64;
    assert!(a.stats.photons <= rounds * 1024, "{:?}", a.stats);
    assert_absorbs(&a, rho, 0.95, 1.05);
}

/// A thin pane of glass (`thindielectric`) between a point light and a floor dims
/// the floor behind it by the pane's transmittance at each ray's angle, and casts
/// no other shadow; beside it the floor gets the closed form.
#[test]
fn a_thin_pane_dims_the_floor_behind_it_by_its_transmittance() {
    use crate::bsdf::glass::thin_reflectance;
    use crate::scene::BsdfKind;
    let plane = crate::testutil::centred_square(4.0, 40);
    let (h, i0, rho) = (1.5f32, 2.0f32, 0.6f32);
    let lp = Vec3::new(0.3, -0.2, h);
    let light = Light::Point {
        position: lp,
        intensity: Vec3::splat(i0),
    };
    // The pane: x in [-1, 0.5], y in [-1, 1], at height 0.8.
    let pane = crate::testutil::square(-1.0, 0.5, -1.0, 1.0, 0.8, false);
    let glass = BsdfKind::Dielectric {
        eta: 1.5,
        specular_reflectance: Vec3::ONE,
        specular_transmittance: Vec3::ONE,
        thin: true,
        rough: None,
    };
    let floor = BsdfKind::Diffuse {
        reflectance: Vec3::splat(rho),
    };
    let s = crate::testutil::scene_with(vec![(plane, floor), (pane, glass)], vec![light], &[]);
    let sol = solve(&s, &Bvh::build(&s), &settings(0.5, 4, 0), &Silent).unwrap();
    let e = &sol.lists[0][0];
    let (mut dimmed, mut full) = (0, 0);
    for (v, b) in sol
        .mesh
        .vertices
        .iter()
        .zip(&e.occluded)
        .filter(|(v, _)| v.q.z == 0.0)
    {
        let d = lp - v.q;
        let r = d.length();
        let closed = rho * i0 * h / (r * r * r);
        // Where the ray to the light crosses the pane's plane.
        let c = v.q + d * (0.8 / h);
        let inside = c.x > -1.0 && c.x < 0.5 && c.y > -1.0 && c.y < 1.0;
        let margin = (c.x + 1.0)
            .abs()
            .min((c.x - 0.5).abs())
            .min((c.y.abs() - 1.0).abs());
        if margin < 0.15 {
            continue; // the vertex's pieces straddle the pane's edge
        }
        let expect = if inside {
            dimmed += 1;
            closed * (1.0 - thin_reflectance(h / r, 1.5))
        } else {
            full += 1;
            closed
        };
        assert!(
            (b.x - expect).abs() < 2e-3 * closed,
            "{:?}: {} vs {expect}",
            v.q,
            b.x
        );
    }
    assert!(dimmed >= 30 && full >= 10, "{dimmed} {full}");
}

/// A closed box split by a thin pane of glass (the light on one side): the walls on
/// both sides absorb all the light emitted (the pane neither absorbs nor loses any),
/// through the shots (which see through the pane), the light's photons aimed at it
/// (its reflection) and the photons of the rest.
#[test]
fn a_box_split_by_a_thin_pane_absorbs_all_the_light() {
    use crate::scene::BsdfKind;
    let rho = 0.6;
    let mut s = lit_box(rho);
    let b = s.bsdfs.len() as u32;
    s.bsdfs.push(crate::scene::Bsdf {
        name: "pane".into(),
        kind: BsdfKind::Dielectric {
            eta: 1.5,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
            thin: true,
            rough: None,
        },
        twosided: true,
        textures: Vec::new(),
    });
    // A pane across the box at x = 1.2 (the light is at x = 0.7).
    s.shapes.push(crate::scene::Shape {
        name: "pane".into(),
        mesh: quad([
            v(1.2, 0.0, 0.0),
            v(1.2, 1.0, 0.0),
            v(1.2, 1.0, 1.5),
            v(1.2, 0.0, 1.5),
        ]),
        bsdf: b,
        emitter: None,
    });
    let st = photon_settings(20, 64);
    let a = solve(&s, &Bvh::build(&s), &st, &Silent).unwrap();
    assert_absorbs(&a, rho, 0.97, 1.03);
}

/// A floor under a uniform sky of radiance L with a slab of thick glass (`dielectric`,
/// index 1.5, 2 cm thick, 12 x 12 m) a metre above it: the floor's centre gets the sky
/// through the slab's two faces, each passing 1 - F of the light at its angle, where
/// the slab covers the sky, and the open sky below its edge: the quadrature of L (1 -
/// F)^2 cos, and of L cos, over those directions. (Shadow rays stopped by thick glass
/// left it the low sky alone, 3 % of the light.)
#[test]
fn the_sky_reaches_a_floor_through_a_slab_of_thick_glass() {
    use crate::bsdf::fresnel_dielectric;
    use crate::scene::BsdfKind;
    let mut plane = crate::testutil::split_square(8.0, 0.0, 16);
    for p in &mut plane.positions {
        *p -= Vec3::new(4.0, 4.0, 0.0);
    }
    let (l, rho, half, h) = (0.8f32, 0.5f32, 6.0f32, 1.0f32);
    let mut shapes = vec![(
        plane,
        BsdfKind::Diffuse {
            reflectance: Vec3::splat(rho),
        },
    )];
    for f in box_outside(v(-half, -half, h), v(half, half, h + 0.02)) {
        shapes.push((f, BsdfKind::clear_glass(1.5, false)));
    }
    let sky = crate::testutil::uniform_sky(l);
    let s = crate::testutil::scene_with(shapes, vec![sky], &[]);
    let sol = solve(&s, &Bvh::build(&s), &settings(0.5, 64, 0), &Silent).unwrap();
    let got = floor_centre(&sol).x;
    // Quadrature over the upper hemisphere (uniform in cos theta and phi).
    let (nc, np) = (2000, 720);
    let mut e = 0.0f64;
    for a in 0..nc {
        for b in 0..np {
            let c = (a as f32 + 0.5) / nc as f32;
            let phi = (b as f32 + 0.5) / np as f32 * std::f32::consts::TAU;
            let sn = (1.0 - c * c).sqrt();
            // Where the direction meets the slab's height, and whether that is on it.
            let reach = h / c * sn;
            let on = (reach * phi.cos()).abs() <= half && (reach * phi.sin()).abs() <= half;
            let t = if on {
                (1.0 - fresnel_dielectric(c, 1.5)).powi(2)
            } else {
                1.0
            };
            e += f64::from(l * t * c);
        }
    }
    let want = rho * (e * std::f64::consts::TAU / (nc * np) as f64) as f32;
    let open = rho * PI * l;
    assert!(want < 0.95 * open && want > 0.85 * open, "{want} of {open}");
    assert!(
        (got - want).abs() < 0.03 * want,
        "{got} vs {want} (open sky: {open})"
    );
}

/// An open floor under a uniform sky of radiance L (`constant`): every vertex gets
/// irradiance pi L from the upper hemisphere's cells (their form factors sum to 1),
/// so radiosity rho pi L; beside a box the sky is partly hidden, never brighter.
#[test]
fn an_open_floor_under_a_uniform_sky_gets_pi_l() {
    let mut plane = crate::testutil::split_square(8.0, 0.0, 16);
    for p in &mut plane.positions {
        *p -= Vec3::new(4.0, 4.0, 0.0);
    }
    let (l, rho) = (0.8f32, 0.5f32);
    let mut meshes = vec![(plane, Vec3::splat(rho))];
    for f in box_outside(v(-0.5, -0.5, 0.0), v(0.5, 0.5, 1.0)) {
        meshes.push((f, Vec3::splat(rho)));
    }
    let sky = crate::testutil::uniform_sky(l);
    let s = scene(meshes, vec![sky], &[]);
    let sol = solve(&s, &Bvh::build(&s), &settings(0.5, 64, 0), &Silent).unwrap();
    let e = &sol.lists[0][0];
    let full = rho * PI * l;
    let (mut open, mut near) = (0, 0);
    for (vx, b) in sol
        .mesh
        .vertices
        .iter()
        .zip(&e.occluded)
        .filter(|(vx, _)| vx.q.z == 0.0)
    {
        let d = vx.q.x.abs().max(vx.q.y.abs());
        assert!(b.x <= full * 1.001, "{:?}: {} > {full}", vx.q, b.x);
        if d > 3.5 {
            open += 1;
            // The box hides at most a little of the sky from the floor's edge.
            assert!(b.x > 0.97 * full, "{:?}: {} vs {full}", vx.q, b.x);
        } else if d > 0.5 && d < 0.7 {
            near += 1;
            assert!(b.x < 0.9 * full, "{:?}: {} vs {full}", vx.q, b.x);
        }
    }
    assert!(open > 10 && near > 4, "{open} {near}");
}

/// The total radiosity of the upward floor vertex at height 0 nearest the origin.
fn floor_centre(sol: &Solution) -> Vec3 {
    let total = sol.total();
    let (i, _) = sol
        .mesh
        .vertices
        .iter()
        .enumerate()
        .filter(|(_, vx)| vx.q.z == 0.0 && vx.n.z > 0.0)
        .min_by(|a, b| a.1.q.truncate().length().total_cmp(&b.1.q.truncate().length()))
        .unwrap();
    total[i]
}

/// A floor of reflectance rho with shapes of thick glass (index 1.5) over it, lit
/// by `light`.
fn floor_under_glass(glass: Vec<TriMesh>, light: Light) -> Scene {
    use crate::scene::BsdfKind;
    let plane = crate::testutil::centred_square(4.0, 16);
    let mut shapes = vec![(
        plane,
        BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.5),
        },
    )];
    shapes.extend(glass.into_iter().map(|f| (f, BsdfKind::clear_glass(1.5, false))));
    crate::testutil::scene_with(shapes, vec![light], &[])
}

/// A lamp (a point light of intensity I, 1 m over the floor) in a glass bulb (a
/// box of `dielectric` with walls 1 cm thick): the floor below gets I / h^2 through
/// the bottom wall's two parallel faces, (1 - F)^2 = 0.96^2 of it, from the lamp's
/// shot, and the photons add only the light the bulb's faces reflect inside and
/// let out elsewhere (a few per cent), not the light that crossed straight again.
/// (Shadow rays stopped at the bulb left that light to the photons alone.)
#[test]
fn a_lamp_in_a_glass_bulb_lights_the_floor_through_its_walls_once() {
    let (i, h, rho) = (5.0f32, 1.0f32, 0.5f32);
    let mut bulb = box_outside(v(-0.06, -0.06, h - 0.06), v(0.06, 0.06, h + 0.06));
    bulb.extend(box_inside(v(-0.05, -0.05, h - 0.05), v(0.05, 0.05, h + 0.05)));
    let lamp = Light::Point {
        position: v(0.0, 0.0, h),
        intensity: Vec3::splat(i),
    };
    let s = floor_under_glass(bulb, lamp);
    let mut set = settings(0.25, 64, 0);
    (set.photons, set.max_photons) = (64, 400_000);
    let sol = solve(&s, &Bvh::build(&s), &set, &Silent).unwrap();
    let got = floor_centre(&sol).x;
    let want = rho * i / (h * h) * 0.96 * 0.96;
    assert!(got > 0.99 * want && got < 1.06 * want, "{got} vs {want}");
}

/// The sun (`directional`, irradiance E, 30 degrees from the zenith) over a floor
/// under a slab of thick glass 2 cm thick: the floor gets E cos 30 through the two
/// faces, each passing 1 - F(cos 30) (a window pane must not turn a sunlit room
/// dark); tilt the slab's lower face by 10 degrees and the sun's straight path is
/// gone (bent light is the photons' part, none here).
#[test]
fn the_sun_lights_a_floor_through_a_pane_of_thick_glass() {
    use crate::bsdf::fresnel_dielectric;
    let (e, rho) = (3.0f32, 0.5f32);
    let c = 30f32.to_radians().cos();
    let sun = Light::Directional {
        direction: -v(30f32.to_radians().sin(), 0.0, c),
        irradiance: Vec3::splat(e),
    };
    let pane = box_outside(v(-1.5, -1.5, 1.0), v(1.5, 1.5, 1.02));
    let s = floor_under_glass(pane.clone(), sun.clone());
    let sol = solve(&s, &Bvh::build(&s), &settings(0.25, 16, 0), &Silent).unwrap();
    let got = floor_centre(&sol).x;
    let want = rho * e * c * (1.0 - fresnel_dielectric(c, 1.5)).powi(2);
    assert!((got - want).abs() < 0.01 * want, "{got} vs {want}");
    // The wedge: the lower face (the box's face at z = 1, listed first) tilted
    // about the x axis through its centre.
    let mut wedge = pane;
    let tilt = glam::Mat3::from_rotation_x(10f32.to_radians());
    let low = wedge
        .iter()
        .position(|f| f.positions.iter().all(|p| p.z == 1.0))
        .unwrap();
    for p in &mut wedge[low].positions {
        *p = tilt * (*p - v(0.0, 0.0, 1.0)) + v(0.0, 0.0, 1.0);
    }
    let s = floor_under_glass(wedge, sun);
    let sol = solve(&s, &Bvh::build(&s), &settings(0.25, 16, 0), &Silent).unwrap();
    assert!(floor_centre(&sol).x < 0.01 * want, "{}", floor_centre(&sol).x);
}

/// A closed 4 x 4 x 3 m room (black walls) under a uniform sky of radiance L, with a
/// 1 x 1 m opening in its ceiling: each floor vertex gets pi L times its form factor
/// to the opening, which a few of the sky's cells cover, each in part. Averaged over
/// the floor, the shot gives that within 4 % (2.8 % dark): a sky cell is sampled
/// again at a shadow's edge where its touching cells disagree among themselves, not
/// with its own first ray, and all edge cells are sampled more, not only those their
/// edge rays found partly hidden (the rules that followed a cell's own rays left it
/// dark where they had missed: the floor 17.4 % dark here).
#[test]
fn the_sky_through_a_small_opening_is_not_darkened_by_the_edge_rule() {
    let (l, rho) = (1.2f32, 0.5f32);
    let floor = crate::testutil::centred_square(4.0, 16);
    let mut meshes = vec![(floor, Vec3::splat(rho))];
    let black = Vec3::ZERO;
    for f in box_inside(v(-2.0, -2.0, 0.0), v(2.0, 2.0, 3.0)) {
        let z: Vec<f32> = f.positions.iter().map(|p| p.z).collect();
        // The box's walls only: the floor is the split one, the ceiling has a hole.
        if z.iter().all(|&z| z == 0.0) || z.iter().all(|&z| z == 3.0) {
            continue;
        }
        meshes.push((f, black));
    }
    let sq = crate::testutil::square;
    for c in [
        sq(-2.0, 2.0, 0.5, 2.0, 3.0, true),
        sq(-2.0, 2.0, -2.0, -0.5, 3.0, true),
        sq(-2.0, -0.5, -0.5, 0.5, 3.0, true),
        sq(0.5, 2.0, -0.5, 0.5, 3.0, true),
    ] {
        meshes.push((c, black));
    }
    let sky = crate::testutil::uniform_sky(l);
    let s = scene(meshes, vec![sky], &[]);
    let sol = solve(&s, &Bvh::build(&s), &settings(0.25, 64, 0), &Silent).unwrap();
    let total = sol.total();
    let opening = [
        v(-0.5, -0.5, 3.0),
        v(0.5, -0.5, 3.0),
        v(0.5, 0.5, 3.0),
        v(-0.5, 0.5, 3.0),
    ];
    let (mut got, mut want, mut n) = (0.0f64, 0.0f64, 0);
    for (i, vx) in sol.mesh.vertices.iter().enumerate() {
        if vx.q.z == 0.0 && vx.n.z > 0.0 && vx.q.x.abs() < 1.9 && vx.q.y.abs() < 1.9 {
            got += f64::from(total[i].x);
            want += f64::from(rho * PI * l * point_polygon_form_factor(vx.q, Vec3::Z, &opening));
            n += 1;
        }
    }
    assert!(n > 100, "{n} floor vertices");
    assert!(
        (got - want).abs() < 0.04 * want,
        "mean over the floor {} vs {}",
        got / n as f64,
        want / n as f64
    );
}

/// Shadow coherence in pass 1 ([`coherence`]): under an area light that nothing
/// hides, every coarse floor vertex sees all of every cell, so every midpoint takes
/// the whole light from them and casts no ray; its light is still its own (the
/// form factors are computed at the midpoint). At a shadow's edge the midpoints
/// sample the cells their coarse vertices disagree on, as the two penumbra tests
/// above check (their floors are mostly midpoints).
#[test]
fn midpoints_cast_no_rays_where_their_coarse_vertices_see_all_of_the_light() {
    let floor = quad([v(-1., -1., 0.), v(1., -1., 0.), v(1., 1., 0.), v(-1., 1., 0.)]);
    let lamp = quad([
        v(-0.2, -0.2, 1.),
        v(-0.2, 0.2, 1.),
        v(0.2, 0.2, 1.),
        v(0.2, -0.2, 1.),
    ]);
    let s = scene(
        vec![(floor, Vec3::splat(0.5)), (lamp, Vec3::ZERO)],
        vec![],
        &[(1, Vec3::ONE)],
    );
    let sol = solve(&s, &Bvh::build(&s), &settings(0.05, 64, 0), &Silent).unwrap();
    let mid = crate::mesh::Midpoints::of(&sol.mesh);
    let floor = &sol.mesh.patches[0];
    let first = floor.first_vertex as usize;
    let vs = first..first + floor.vertex_count as usize;
    let coarse = vs.clone().filter(|&i| mid.of_vertex(i).is_none()).count();
    assert!(coarse * 3 < vs.len(), "{coarse} coarse of {}", vs.len());
    // At most the 64 cells' first rays at each coarse vertex, none at a midpoint.
    assert!(
        sol.stats.rays <= 64 * coarse as u64 && sol.stats.rays >= 4 * coarse as u64,
        "{} rays, {coarse} coarse vertices",
        sol.stats.rays
    );
    let e = &sol.lists[0][0];
    for i in vs {
        let (o, u) = (e.occluded[i - first].x, e.unoccluded[i - first].x);
        assert!(u > 0.0 && o == u, "vertex {i}: {o} of {u}");
        let exact =
            0.5 * point_polygon_form_factor(
                sol.mesh.vertices[i].q,
                Vec3::Z,
                &[
                    v(-0.2, -0.2, 1.),
                    v(-0.2, 0.2, 1.),
                    v(0.2, 0.2, 1.),
                    v(0.2, -0.2, 1.),
                ],
            ) * PI;
        assert!((u - exact).abs() < 0.02 * exact, "vertex {i}: {u} vs {exact}");
    }
}

/// Where a final gather will read the solution, a patch shot gives way to the photons
/// once it carries less power per ray than the photon budget would (without one, a
/// third of it): in the lit box the first patch shot costs between one and three
/// times the photons' rays for its power at a budget of 20 k photons, so it is shot
/// only for an ungathered solution; at 60 k both shoot. Either way the photons carry
/// what is left: the walls absorb what the light emits.
#[test]
fn a_gathered_solution_leaves_dearer_patch_shots_to_the_photons() {
    let rho = 0.6;
    let s = lit_box(rho);
    let bvh = Bvh::build(&s);
    let solved = |cap: u64, gathered: bool| {
        let mut st = photon_settings(20, 64);
        st.max_photons = cap;
        st.gathered = gathered;
        solve(&s, &bvh, &st, &Silent).unwrap()
    };
    let (plain, gathered) = (solved(20_000, false), solved(20_000, true));
    assert!(plain.stats.patch_shots > 0, "{:?}", plain.stats);
    assert_eq!(gathered.stats.patch_shots, 0, "{:?}", gathered.stats);
    assert!(solved(60_000, true).stats.patch_shots > 0);
    assert_absorbs(&plain, rho, 0.95, 1.02);
    assert_absorbs(&gathered, rho, 0.95, 1.02);
}
