//! Tests of the BVH and of the watertight triangle test.

use super::triangle::Tri4;
use super::*;
use obvhs::ray::Ray as BvhRay;
use obvhs::rt_triangle::RtTriangle;

fn bvh_of(tris: &[[Vec3; 3]]) -> Bvh {
    let refs = (0..tris.len()).map(|t| TriRef {
        shape: 0,
        tri: t as u32,
    });
    Bvh::from_triangles(tris.to_vec(), refs.collect(), 0)
}

/// A stack of unit triangles at z = 0, 1, ..., n-1.
fn stack(n: usize) -> Bvh {
    let tris: Vec<_> = (0..n)
        .map(|k| {
            let z = k as f32;
            [
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(0.0, 1.0, z),
            ]
        })
        .collect();
    bvh_of(&tris)
}

#[test]
fn closest_hit_is_the_nearest_triangle_and_barycentrics_reconstruct_the_point() {
    let bvh = stack(50);
    let ray = Ray::new(Vec3::new(0.2, 0.3, 100.0), Vec3::new(0.0, 0.0, -1.0));
    let hit = bvh.intersect(&ray).expect("hits the stack");
    assert_eq!(hit.tri, 49);
    assert!((hit.t - 51.0).abs() < 1e-4, "t = {}", hit.t);
    // b1 weights the second corner (1,0,z), b2 the third (0,1,z).
    assert!(
        (hit.bary - Vec2::new(0.2, 0.3)).abs().max_element() < 1e-5,
        "{:?}",
        hit.bary
    );
}

#[test]
fn segments_respect_tmin_and_tmax() {
    let bvh = stack(10);
    let mut ray = Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z);
    ray.tmin = 3.5;
    ray.tmax = 6.5;
    assert_eq!(bvh.intersect(&ray).map(|h| h.tri), Some(3));
    assert!(bvh.occluded(&ray));
    ray.tmin = 3.2;
    ray.tmax = 3.8;
    assert!(bvh.intersect(&ray).is_none());
    assert!(!bvh.occluded(&ray));
}

#[test]
fn axis_aligned_rays_with_negative_zero_components_hit() {
    // A flat scene hit by rays whose zero components are -0.0 (regression: obvhs
    // missed every triangle for such rays).
    let tris: Vec<_> = (0..9)
        .map(|k| {
            let x = 30.0 * k as f32;
            [
                Vec3::new(x - 10.0, -10.0, 0.0),
                Vec3::new(x + 10.0, -10.0, 0.0),
                Vec3::new(x + 10.0, 10.0, 0.0),
            ]
        })
        .collect();
    let bvh = bvh_of(&tris);
    for dir in [-Vec3::Z, Vec3::new(-0.0, 0.0, -1.0), Vec3::new(0.0, -0.0, -1.0)] {
        let ray = Ray::new(Vec3::new(5.0, -5.0, 1.0), dir);
        assert_eq!(bvh.intersect(&ray).map(|h| h.tri), Some(0), "{dir:?}");
        assert!(bvh.occluded(&ray));
    }
    let up = Ray::new(Vec3::new(35.0, -5.0, -1.0), -(-Vec3::Z));
    assert_eq!(bvh.intersect(&up).map(|h| h.tri), Some(1));
}

#[test]
fn misses_and_empty_scenes() {
    let bvh = stack(5);
    let ray = Ray::new(Vec3::new(2.0, 2.0, -1.0), Vec3::Z);
    assert!(bvh.intersect(&ray).is_none());
    assert!(!bvh.occluded(&ray));
    let empty = bvh_of(&[]);
    assert!(empty.intersect(&ray).is_none());
    assert!(!empty.occluded(&ray));
}

/// The closest hit and any hit in the ray's segment by testing every triangle
/// with the same triangle test, one triangle at a time.
fn brute(tris: &[[Vec3; 3]], ray: &Ray) -> (Option<(usize, f32)>, bool) {
    let r = PreparedRay::new(ray);
    let mut best: Option<(usize, f32)> = None;
    for (i, tri) in tris.iter().enumerate() {
        let block = Tri4::pack(&[*tri]);
        let (hit, t, _, _) = block[0].intersect(&r, 0b1, ray.tmax);
        if hit != 0 && best.is_none_or(|(_, bt)| t.x < bt) {
            best = Some((i, t.x));
        }
    }
    (best, best.is_some())
}

#[test]
fn a_block_tests_only_the_lanes_asked_for_and_padding_lanes_never_hit() {
    let tri = |z: f32| {
        [
            Vec3::new(0.0, 0.0, z),
            Vec3::new(1.0, 0.0, z),
            Vec3::new(0.0, 1.0, z),
        ]
    };
    let blocks = Tri4::pack(&[tri(1.0), tri(2.0), tri(3.0), tri(4.0), tri(5.0)]);
    assert_eq!(blocks.len(), 2);
    let r = PreparedRay::new(&Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z));
    let (hit, t, u, v) = blocks[0].intersect(&r, 0b1111, f32::INFINITY);
    assert_eq!(hit, 0b1111);
    assert_eq!(t.to_array(), [1.0, 2.0, 3.0, 4.0]);
    assert_eq!((u.x, v.x), (0.25, 0.25));
    assert_eq!(blocks[0].intersect(&r, 0b0110, f32::INFINITY).0, 0b0110);
    assert_eq!(blocks[0].intersect(&r, 0b1111, 2.5).0, 0b0011);
    // Block 1 holds one triangle and three zero lanes.
    assert_eq!(blocks[1].intersect(&r, 0b1111, f32::INFINITY).0, 0b0001);
    let miss = PreparedRay::new(&Ray::new(Vec3::new(0.75, 0.75, 0.0), Vec3::Z));
    assert_eq!(blocks[0].intersect(&miss, 0b1111, f32::INFINITY).0, 0);
}

/// Checks `bvh` against [`brute`] on `rays`; returns the number of hits.
fn check_against_brute(bvh: &Bvh, tris: &[[Vec3; 3]], rays: &[Ray]) -> usize {
    let mut hits = 0;
    for ray in rays {
        let (best, any) = brute(tris, ray);
        let hit = bvh.intersect(ray);
        assert_eq!(bvh.occluded(ray), any, "{ray:?}");
        match (hit, best) {
            (None, None) => {}
            (Some(h), Some((i, t))) => {
                hits += 1;
                assert_eq!(h.t, t, "{ray:?}");
                // Another triangle at exactly the same distance is as right.
                if h.tri as usize != i {
                    let (other, _) = brute(&tris[h.tri as usize..=h.tri as usize], ray);
                    assert_eq!(other.map(|o| o.1), Some(t), "{ray:?}");
                }
                let [a, b, c] = tris[h.tri as usize];
                let p = a * (1.0 - h.bary.x - h.bary.y) + b * h.bary.x + c * h.bary.y;
                assert!((p - ray.at(h.t)).length() < 1e-3 * (1.0 + ray.at(h.t).length()));
            }
            (h, b) => panic!("{ray:?}: BVH {h:?}, brute force {b:?}"),
        }
    }
    hits
}

fn random_rays(rng: &mut rand_pcg::Pcg32, n: usize, lo: f32, hi: f32) -> Vec<Ray> {
    use rand::Rng;
    (0..n)
        .map(|k| {
            let o = Vec3::new(rng.random(), rng.random(), rng.random()) * (hi - lo) + Vec3::splat(lo);
            let mut d = (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5).normalize();
            // Every fourth ray axis-aligned, with +-0.0 in the other components.
            if k % 4 == 0 {
                let a = (k / 4) % 3;
                let s = if k % 8 == 0 { 1.0 } else { -1.0 };
                let z = if k % 3 == 0 { -0.0 } else { 0.0 };
                d = Vec3::splat(z);
                d[a] = s;
            }
            let mut ray = Ray::new(o, d);
            if k % 3 == 1 {
                ray.tmin = rng.random::<f32>() * 2.0;
                ray.tmax = ray.tmin + rng.random::<f32>() * 6.0;
            }
            ray
        })
        .collect()
}

#[test]
fn closest_hits_and_occlusion_match_testing_every_triangle() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(11);
    // Small and large triangles, some axis-aligned (boxes of zero thickness).
    let mut tris: Vec<[Vec3; 3]> = (0..3000)
        .map(|k| {
            let c = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
            let size = if k % 50 == 0 { 4.0 } else { 0.3 };
            let mut d = || (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5) * size;
            let (d1, d2) = (d(), d());
            if k % 7 == 0 {
                // Parallel to the xy plane: a box of zero thickness.
                return [c, c + Vec3::new(d1.x, d1.y, 0.0), c + Vec3::new(d2.x, d2.y, 0.0)];
            }
            [c, c + d1, c + d2]
        })
        .collect();
    // A closed box around it all, so that most rays hit something.
    for f in crate::testutil::box_inside(Vec3::splat(-1.0), Vec3::splat(11.0)) {
        for t in 0..f.triangle_count() {
            tris.push(f.triangle(t));
        }
    }
    let bvh = bvh_of(&tris);
    assert!(bvh.depth <= 17, "a random scene is shallow ({})", bvh.depth);
    let rays = random_rays(&mut rng, 4000, 0.0, 10.0);
    let hits = check_against_brute(&bvh, &tris, &rays);
    assert!(hits > 3000, "most rays should hit ({hits})");
    // The quicker build of scenes with many triangles per pixel (obvhs's medium
    // preset, see `QUICK_BUILD_TRIANGLES_PER_PIXEL`) answers the same.
    let refs = (0..tris.len()).map(|t| TriRef {
        shape: 0,
        tri: t as u32,
    });
    let quick = Bvh::from_triangles_with(
        tris.clone(),
        refs.collect(),
        0,
        obvhs::BvhBuildParams::medium_build(),
    );
    assert_eq!(check_against_brute(&quick, &tris, &rays), hits);
    // The same answers with the larger stacks of deep trees.
    for depth in [40, 1000] {
        let deep = Bvh {
            depth,
            ..bvh_of(&tris)
        };
        for ray in &rays[..500] {
            assert_eq!(deep.intersect(ray), bvh.intersect(ray));
            assert_eq!(deep.occluded(ray), bvh.occluded(ray));
        }
    }
}

#[test]
fn a_deep_tree_is_traversed_completely() {
    use rand::SeedableRng;
    // Triangles at exponentially growing distances along x: an unbalanced tree
    // deeper than the small traversal stack.
    let tris: Vec<[Vec3; 3]> = (0..300)
        .map(|k| {
            let x = 1.15f32.powi(k);
            let s = 0.2 * x;
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + s, s, 0.0),
                Vec3::new(x, s, s),
            ]
        })
        .collect();
    let bvh = bvh_of(&tris);
    assert!(bvh.depth > 17, "the tree should be deep ({})", bvh.depth);
    let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
    let mut rays = random_rays(&mut rng, 500, -1.0, 2.0);
    // Rays along the row, hitting triangles far out.
    for (k, t) in tris.iter().enumerate().step_by(3) {
        let target = (t[0] + t[1] + t[2]) / 3.0;
        let o = Vec3::new(target.x, target.y, -1.0 - k as f32);
        rays.push(Ray::new(o, (target - o).normalize()));
    }
    let hits = check_against_brute(&bvh, &tris, &rays);
    // (Far out, at 1e18, f32 loses some of them, in both.)
    assert!(hits > 60, "{hits}");
}

#[test]
fn occlusion_agrees_with_closest_hit_on_random_rays() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
    let tris: Vec<_> = (0..500)
        .map(|_| {
            let c = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
            let mut d = || (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5) * 2.0;
            let (d1, d2) = (d(), d());
            [c, c + d1, c + d2]
        })
        .collect();
    let bvh = bvh_of(&tris);
    let brute = |ray: &Ray| {
        tris.iter()
            .filter_map(|[a, b, c]| {
                let t = RtTriangle::new((*a).into(), (*b).into(), (*c).into()).intersect(&BvhRay::new(
                    ray.origin.into(),
                    ray.dir.into(),
                    ray.tmin,
                    ray.tmax,
                ));
                t.is_finite().then_some(t)
            })
            .fold(f32::INFINITY, f32::min)
    };
    let mut hits = 0;
    for _ in 0..2000 {
        let o = Vec3::new(rng.random(), rng.random(), rng.random()) * 12.0 - 1.0;
        let d = (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5).normalize();
        let mut ray = Ray::new(o, d);
        ray.tmax = rng.random::<f32>() * 8.0;
        let t = brute(&ray);
        let hit = bvh.intersect(&ray);
        assert_eq!(hit.is_some(), t.is_finite());
        assert_eq!(bvh.occluded(&ray), t.is_finite());
        if let Some(h) = hit {
            hits += 1;
            assert!((h.t - t).abs() < 1e-4);
        }
    }
    assert!(hits > 100, "the test should exercise hits too ({hits})");
}

// The watertight triangle test.

/// The triangles of an indexed mesh (shared corners bit-identical, as in the scene's
/// meshes).
fn mesh(positions: &[Vec3], indices: &[[usize; 3]]) -> Vec<[Vec3; 3]> {
    indices
        .iter()
        .map(|&[a, b, c]| [positions[a], positions[b], positions[c]])
        .collect()
}

/// The 12 triangles of the cube `[0, 1]^3` with its corners mapped by `f` (each
/// corner mapped once), each face split along the diagonal from its first corner.
fn cube(f: impl Fn(Vec3) -> Vec3) -> (Vec<Vec3>, Vec<[Vec3; 3]>) {
    let p: Vec<Vec3> = (0..8)
        .map(|i| f(Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2) as f32)))
        .collect();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let idx: Vec<[usize; 3]> = faces
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    let tris = mesh(&p, &idx);
    (p, tris)
}

/// A UV sphere of radius 1 about the origin: `nu` segments around, `nv` rings from
/// pole to pole, one vertex at each pole.
fn uv_sphere(nu: usize, nv: usize) -> (Vec<Vec3>, Vec<[Vec3; 3]>) {
    use std::f32::consts::PI;
    let mut p = vec![Vec3::Z];
    for j in 1..nv {
        let th = PI * j as f32 / nv as f32;
        for i in 0..nu {
            let ph = 2.0 * PI * i as f32 / nu as f32;
            p.push(Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()));
        }
    }
    p.push(-Vec3::Z);
    let ring = |j: usize, i: usize| 1 + (j - 1) * nu + i % nu;
    let south = p.len() - 1;
    let mut idx = Vec::new();
    for i in 0..nu {
        idx.push([0, ring(1, i), ring(1, i + 1)]);
        for j in 1..nv - 1 {
            let (a, b, c, d) = (ring(j, i), ring(j + 1, i), ring(j + 1, i + 1), ring(j, i + 1));
            idx.push([a, b, c]);
            idx.push([a, c, d]);
        }
        idx.push([ring(nv - 1, i), south, ring(nv - 1, i + 1)]);
    }
    let tris = mesh(&p, &idx);
    (p, tris)
}

/// Rays from points `inside()` of the closed mesh `tris` (corners `verts`), in random
/// directions and aimed exactly at its vertices and at points of its edges: every
/// one hits, closest hit and occlusion (unbounded) alike.
fn never_escapes(
    verts: &[Vec3],
    tris: &[[Vec3; 3]],
    inside: impl Fn(&mut rand_pcg::Pcg32) -> Vec3,
    n: usize,
) {
    use rand::{Rng, SeedableRng};
    let bvh = bvh_of(tris);
    let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
    for k in 0..n {
        let o = inside(&mut rng);
        let target = match k % 4 {
            0 => o + (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5),
            1 => verts[rng.random_range(0..verts.len())],
            _ => {
                // A point of an edge (its midpoint every other time).
                let t = tris[rng.random_range(0..tris.len())];
                let e = rng.random_range(0..3);
                let s = if k % 4 == 2 { 0.5 } else { rng.random::<f32>() };
                t[e] + s * (t[(e + 1) % 3] - t[e])
            }
        };
        let ray = Ray::new(o, target - o);
        let hit = bvh.intersect(&ray);
        assert!(
            hit.is_some_and(|h| h.t > 0.0 && h.t.is_finite()),
            "{k}: {ray:?} escaped ({hit:?})"
        );
        assert!(bvh.occluded(&ray), "{k}: {ray:?} escaped the occlusion query");
    }
}

#[test]
fn rays_from_inside_an_axis_aligned_cube_never_escape() {
    use rand::Rng;
    let (verts, tris) = cube(|p| p * 2.0 - 1.0);
    assert_eq!(tris.len(), 12);
    never_escapes(
        &verts,
        &tris,
        |rng| (Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0) * 0.999,
        20_000,
    );
    // Axis-aligned rays through the faces' diagonals and corners, from points whose
    // coordinates are equal (x = y = z at the diagonals' ends).
    let bvh = bvh_of(&tris);
    for s in [-0.75, -0.5, -0.3, 0.0, 0.3, 0.5, 0.75] {
        for a in 0..3 {
            for sign in [1.0, -1.0] {
                let mut d = Vec3::ZERO;
                d[a] = sign;
                let ray = Ray::new(Vec3::splat(s), d);
                assert!(bvh.intersect(&ray).is_some(), "{ray:?}");
                assert!(bvh.occluded(&ray), "{ray:?}");
            }
        }
    }
}

#[test]
fn rays_from_inside_a_rotated_cube_never_escape() {
    use rand::Rng;
    let rot = glam::Quat::from_axis_angle(Vec3::new(0.3, -0.7, 0.5).normalize(), 0.77);
    let map = move |p: Vec3| rot * (p * 3.0 - 1.5) + Vec3::new(0.25, -4.0, 7.0);
    let (verts, tris) = cube(map);
    never_escapes(
        &verts,
        &tris,
        |rng| map(Vec3::splat(0.0005) + Vec3::new(rng.random(), rng.random(), rng.random()) * 0.999),
        20_000,
    );
}

#[test]
fn rays_from_inside_a_tessellated_sphere_never_escape() {
    use rand::Rng;
    let (verts, tris) = uv_sphere(64, 32);
    assert_eq!(tris.len(), 2 * 64 * 31);
    // (The chords of the sphere's facets come within 1 - cos(pi / 32) = 0.5% of the
    // centre's distance 1.)
    never_escapes(
        &verts,
        &tris,
        |rng| loop {
            let p = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
            if p.length() < 0.99 {
                return p;
            }
        },
        20_000,
    );
}

/// `n` rays aimed exactly at points `target(rng)` of a flat patch with normal
/// `normal`, from random points 1-3 away on either side: those that `bvh` lets
/// through (no closest hit, or not occluded).
fn leaks(
    bvh: &Bvh,
    normal: Vec3,
    n: usize,
    mut target: impl FnMut(&mut rand_pcg::Pcg32) -> Vec3,
) -> Vec<Ray> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(n as u64);
    let mut leaked = Vec::new();
    for k in 0..n {
        let p = target(&mut rng);
        let side = if k % 2 == 0 { 2.0 } else { -2.0 };
        let o = p + side * normal + 2.0 * (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5);
        let ray = Ray::new(o, p - o);
        if bvh.intersect(&ray).is_none() || !bvh.occluded(&ray) {
            leaked.push(ray);
        }
    }
    leaked
}

/// Maps of the plane z = 0: the identity and turns, scales and moves.
fn placements() -> Vec<Box<dyn Fn(Vec3) -> Vec3>> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(23);
    let mut maps: Vec<Box<dyn Fn(Vec3) -> Vec3>> = vec![Box::new(|p| p)];
    for _ in 0..4 {
        let a: [f32; 3] = rng.random();
        let rot = glam::Quat::from_euler(glam::EulerRot::XYZ, 6.0 * a[0], 6.0 * a[1], 6.0 * a[2]);
        let scale = 0.1 + 10.0 * rng.random::<f32>();
        let shift = (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5) * 20.0;
        maps.push(Box::new(move |p| rot * p * scale + shift));
    }
    maps
}

#[test]
fn rays_aimed_at_a_shared_diagonal_hit() {
    use rand::Rng;
    // A square of two triangles sharing the diagonal p0-p2, hit from both sides at the
    // diagonal's midpoint and at random points of it; the triangles' corners in every
    // cyclic order (which corner is first matters to Moeller-Trumbore).
    for (m, f) in placements().iter().enumerate() {
        let p = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
        .map(f);
        let normal = (p[1] - p[0]).cross(p[3] - p[0]).normalize();
        let mid = p[0] + 0.5 * (p[2] - p[0]);
        for (ra, rb) in (0..9).map(|k| (k / 3, k % 3)) {
            let (mut a, mut b) = ([p[0], p[1], p[2]], [p[0], p[2], p[3]]);
            a.rotate_left(ra);
            b.rotate_left(rb);
            let bvh = bvh_of(&[a, b]);
            for (what, leaked) in [
                ("midpoint", leaks(&bvh, normal, 500, |_| mid)),
                (
                    "point",
                    leaks(&bvh, normal, 1000, |rng| {
                        p[0] + rng.random::<f32>() * (p[2] - p[0])
                    }),
                ),
            ] {
                assert!(
                    leaked.is_empty(),
                    "square {m} {ra}{rb} {what}: {} leaked: {:?}",
                    leaked.len(),
                    leaked[0]
                );
            }
        }
    }
    // Axis-aligned rays through the plain square's diagonal, both ways.
    let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let bvh = bvh_of(&[[p[0], p[1], p[2]], [p[2], p[3], p[0]]]);
    for s in [0.5f32, 0.25, 0.3, 0.7, 0.9] {
        for d in [Vec3::Z, -Vec3::Z] {
            let ray = Ray::new(Vec3::new(s, s, 0.0) - d, d);
            assert!(bvh.intersect(&ray).is_some(), "{ray:?} missed");
            assert!(bvh.occluded(&ray), "{ray:?} not occluded");
        }
    }
}

#[test]
fn rays_aimed_at_the_shared_vertex_of_a_fan_hit() {
    // A fan of six triangles about a centre vertex (a hexagon), hit from both sides by
    // rays aimed at the centre; the centre is each triangle's first, second or third
    // corner, or each in turn.
    for (m, f) in placements().iter().enumerate() {
        let centre = f(Vec3::ZERO);
        let rim: Vec<Vec3> = (0..6)
            .map(|i| {
                let a = std::f32::consts::PI / 3.0 * i as f32 + 0.1;
                f(Vec3::new(a.cos(), a.sin(), 0.0))
            })
            .collect();
        let normal = (rim[0] - centre).cross(rim[1] - centre).normalize();
        for r in 0..4 {
            let tris: Vec<[Vec3; 3]> = (0..6)
                .map(|i| {
                    let mut t = [centre, rim[i], rim[(i + 1) % 6]];
                    t.rotate_left(if r == 3 { i % 3 } else { r });
                    t
                })
                .collect();
            let leaked = leaks(&bvh_of(&tris), normal, 2000, |_| centre);
            assert!(
                leaked.is_empty(),
                "fan {m}/{r}: {} of 2000 leaked: {:?}",
                leaked.len(),
                leaked[0]
            );
        }
    }
}

#[test]
fn hit_distance_and_barycentrics_are_those_of_the_closed_form() {
    use glam::DVec3;
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(17);
    let tri = [
        Vec3::new(1.0, -2.0, 0.5),
        Vec3::new(3.0, 1.0, -1.0),
        Vec3::new(-0.5, 2.5, 2.0),
    ];
    // o + t d = a + b1 (b - a) + b2 (c - a), solved by Cramer's rule in f64.
    let exact = |ray: &Ray, [a, b, c]: [Vec3; 3]| {
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let (e1, e2, s) = (
            b.as_dvec3() - a.as_dvec3(),
            c.as_dvec3() - a.as_dvec3(),
            o - a.as_dvec3(),
        );
        let det = DVec3::dot(-d, e1.cross(e2));
        let t = s.dot(e1.cross(e2)) / det;
        let b1 = (-d).dot(s.cross(e2)) / det;
        let b2 = (-d).dot(e1.cross(s)) / det;
        (t, b1, b2)
    };
    let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
    let mut hits = 0;
    for k in 0..3000 {
        let (b1, b2) = (rng.random::<f32>(), rng.random::<f32>());
        let (b1, b2) = if b1 + b2 > 1.0 {
            (1.0 - b1, 1.0 - b2)
        } else {
            (b1, b2)
        };
        let p = tri[0] + b1 * (tri[1] - tri[0]) + b2 * (tri[2] - tri[0]);
        // Directions mostly along each axis in turn (each permutation of the test), of
        // any length, from either side.
        let mut d = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
        d[k % 3] = if k % 2 == 0 { 2.0 } else { -2.0 };
        d *= 0.1 + 3.0 * rng.random::<f32>();
        let ray = Ray::new(p - (0.5 + 4.0 * rng.random::<f32>()) * d, d);
        // (Grazing rays' t is ill-conditioned: a rounding of the origin moves it far.)
        if d.normalize().dot(normal).abs() < 0.25 {
            continue;
        }
        // Both windings: swapping corners 1 and 2 swaps the barycentrics.
        for (m, corners) in [tri, [tri[0], tri[2], tri[1]]].into_iter().enumerate() {
            let (t, b1, b2) = exact(&ray, corners);
            let r = PreparedRay::new(&ray);
            let (hit, ht, u, v) = Tri4::pack(&[corners])[0].intersect(&r, 1, f32::INFINITY);
            // (Points within rounding of an edge may go either way.)
            if b1.min(b2).min(1.0 - b1 - b2) < 1e-5 {
                continue;
            }
            hits += 1;
            assert_eq!(hit, 1, "{k}/{m}: {ray:?} {b1} {b2}");
            assert!((ht.x as f64 - t).abs() < 1e-5 * t, "{k}/{m}: t = {} vs {t}", ht.x);
            let err = (u.x as f64 - b1).abs().max((v.x as f64 - b2).abs());
            assert!(err < 1e-5, "{k}/{m}: {u} {v} vs {b1} {b2}");
        }
    }
    assert!(hits > 3000, "{hits}");
    // One by hand: the triangle (0,0,0), (2,0,0), (0,4,0) hit at (0.5, 1, 0) from
    // (0.5, 1, 3) along -z at half speed: t = 6, b1 = 0.25, b2 = 0.25.
    let bvh = bvh_of(&[[Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 4.0, 0.0)]]);
    let hit = bvh
        .intersect(&Ray::new(Vec3::new(0.5, 1.0, 3.0), Vec3::new(0.0, 0.0, -0.5)))
        .expect("hits");
    assert_eq!((hit.t, hit.bary, hit.tri), (6.0, Vec2::new(0.25, 0.25), 0));
}

#[test]
fn rays_in_or_parallel_to_the_plane_of_a_triangle_miss_without_nan() {
    let tri = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
    let bvh = bvh_of(&[tri]);
    let block = Tri4::pack(&[tri]);
    for (o, d) in [
        // In the plane, across the triangle (through its interior, an edge, a corner).
        (Vec3::new(-1.0, 0.5, 0.0), Vec3::X),
        (Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        (Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
        (Vec3::new(3.0, 0.5, 0.0), Vec3::new(-1.0, 0.25, 0.0)),
        // Parallel to it, above and below.
        (Vec3::new(-1.0, 0.5, 1.0), Vec3::X),
        (Vec3::new(0.5, -1.0, -0.25), Vec3::new(0.1, 1.0, 0.0)),
    ] {
        let ray = Ray::new(o, d);
        assert_eq!(bvh.intersect(&ray), None, "{ray:?}");
        assert!(!bvh.occluded(&ray), "{ray:?}");
        let (hit, ..) = block[0].intersect(&PreparedRay::new(&ray), 1, f32::INFINITY);
        assert_eq!(hit, 0, "{ray:?}");
    }
    // A zero direction hits nothing either.
    assert_eq!(
        bvh.intersect(&Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::ZERO)),
        None
    );
}

#[test]
fn a_ray_from_a_point_of_a_triangle_does_not_hit_it_at_t_0() {
    // t must be surely positive: an origin exactly on the triangle gives t = 0, no
    // hit, whichever side the ray leaves by (Moeller-Trumbore reported t = 0).
    let tri = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
    let bvh = bvh_of(&[tri]);
    for d in [
        Vec3::new(0.3, 0.2, 1.0),
        Vec3::new(0.3, 0.2, -1.0),
        Vec3::new(1.0, 0.1, 0.05),
    ] {
        let ray = Ray::new(Vec3::new(0.25, 0.5, 0.0), d);
        assert_eq!(bvh.intersect(&ray), None, "{ray:?}");
        assert!(!bvh.occluded(&ray), "{ray:?}");
    }
    // Just off it, it is hit.
    let ray = Ray::new(Vec3::new(0.25, 0.5, 1e-3), -Vec3::Z);
    assert!(bvh.intersect(&ray).is_some_and(|h| (h.t - 1e-3).abs() < 1e-9));
}

#[test]
fn spheres_and_disks_are_met_exactly_among_triangles() {
    use crate::geometry::shapes;
    use crate::testutil::{scene, square};
    // A floor, a sphere of radius 0.5 resting on it, a disk facing up beside it, and
    // a square in front of part of the sphere.
    let mut disk = shapes::disk();
    disk.transform(&glam::Mat4::from_scale_rotation_translation(
        Vec3::splat(0.3),
        glam::Quat::IDENTITY,
        Vec3::new(2.0, 0.0, 0.2),
    ));
    let s = scene(
        vec![
            (square(-3.0, 3.0, -3.0, 3.0, 0.0, false), Vec3::splat(0.5)),
            (shapes::sphere(Vec3::new(0.0, 0.0, 0.5), 0.5), Vec3::splat(0.5)),
            (disk, Vec3::splat(0.5)),
            (square(-0.2, 0.2, -2.2, -1.8, 0.5, false), Vec3::splat(0.5)),
        ],
        Vec::new(),
        &[],
    );
    let bvh = Bvh::build(&s);
    assert_eq!((bvh.quadric_count(), bvh.triangle_count()), (2, 4));
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 5.0), Vec3::NEG_Z);
    // Straight down onto the sphere: its top at 1, not a facet below it.
    let h = bvh.intersect(&down(0.0, 0.0)).unwrap();
    assert_eq!(h.shape, 1);
    assert!((h.t - 4.0).abs() < 1e-5);
    // Off centre by 0.3: the sphere at 0.5 + 0.4.
    let h = bvh.intersect(&down(0.3, 0.0)).unwrap();
    assert!((h.t - (5.0 - 0.9)).abs() < 1e-5, "t {}", h.t);
    // Just outside its silhouette: the floor.
    assert_eq!(bvh.intersect(&down(0.501, 0.0)).unwrap().shape, 0);
    // Inside the silhouette of the 64-gon's true circle, where facets miss.
    let h = bvh.intersect(&down(0.4995, 0.0)).unwrap();
    assert_eq!(h.shape, 1);
    // The disk at 0.2, within its radius 0.3 but past its facets' corners.
    let h = bvh
        .intersect(&down(
            2.0 + 0.2995 * std::f32::consts::FRAC_1_SQRT_2,
            0.2995 * std::f32::consts::FRAC_1_SQRT_2,
        ))
        .unwrap();
    assert_eq!((h.shape, (h.t - 4.8).abs() < 1e-5), (2, true));
    assert_eq!(bvh.intersect(&down(2.301, 0.0)).unwrap().shape, 0);
    // Sideways, above the square (at z 0.5) and through it at the sphere's edge.
    let side = Ray::new(Vec3::new(0.0, -5.0, 0.55), Vec3::Y);
    assert_eq!(bvh.intersect(&side).unwrap().shape, 1);
    let h = bvh.intersect(&Ray::new(Vec3::new(0.0, -2.0, 0.45), Vec3::Y));
    assert!(h.is_some_and(|h| h.shape == 1 && (h.t - (2.0 - (0.25f32 - 0.0025).sqrt())).abs() < 1e-4));
    // Occlusion: segments that end before the sphere are free.
    let mut seg = down(0.0, 0.0);
    seg.tmax = 3.9;
    assert!(!bvh.occluded(&seg));
    seg.tmax = 4.1;
    assert!(bvh.occluded(&seg));
    // From inside the sphere: its far side.
    let inside = Ray::new(Vec3::new(0.0, 0.0, 0.5), Vec3::X);
    let h = bvh.intersect(&inside).unwrap();
    assert_eq!(h.shape, 1);
    assert!((h.t - 0.5).abs() < 1e-5);
}
