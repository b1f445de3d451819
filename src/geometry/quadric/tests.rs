use std::f32::consts::PI;

use glam::{Mat4, Quat, Vec2, Vec3};

use super::*;
use crate::geometry::{shapes, Patch};

fn sphere(c: Vec3, r: f32) -> Quadric {
    shapes::sphere(c, r).quadric.expect("exact sphere")
}

/// A small deterministic generator of numbers in [0, 1).
fn rng(seed: u32) -> impl FnMut() -> f32 {
    let mut s = seed.wrapping_mul(747_796_405).wrapping_add(1);
    move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        (s >> 8) as f32 / (1u32 << 24) as f32
    }
}

#[test]
fn a_ray_through_a_spheres_centre_meets_it_at_distance_minus_radius() {
    let (c, r) = (Vec3::new(1.0, -2.0, 0.5), 0.75);
    let q = sphere(c, r);
    let o = c + Vec3::new(0.0, 0.0, 5.0);
    let (t, at) = q.intersect(o, Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
    assert!((t - (5.0 - r)).abs() < 1e-5, "t {t}");
    // The middle of the cube's +z face.
    assert_eq!(at.face, 4);
    assert!((at.uv - Vec2::splat(0.5)).length() < 1e-5, "{at:?}");
    let (p, n) = q.project(o + Vec3::NEG_Z * t);
    assert!((p - (c + Vec3::Z * r)).length() < 1e-5);
    assert!((n - Vec3::Z).length() < 1e-5);
    // A direction of any length: t is in its units.
    let (t2, _) = q.intersect(o, Vec3::NEG_Z * 2.0, 0.0, f32::INFINITY).unwrap();
    assert!((t2 - t / 2.0).abs() < 1e-5);
    // The segment must reach the surface; tmin skips the first hit.
    assert!(q.intersect(o, Vec3::NEG_Z, 0.0, 4.0).is_none());
    let (far, _) = q.intersect(o, Vec3::NEG_Z, t + 0.01, f32::INFINITY).unwrap();
    assert!((far - (5.0 + r)).abs() < 1e-5, "far {far}");
    // Pointing away: no hit.
    assert!(q.intersect(o, Vec3::Z, 0.0, f32::INFINITY).is_none());
}

#[test]
fn random_rays_meet_a_transformed_sphere_on_its_surface_and_nowhere_before() {
    let (c, r) = (Vec3::new(-0.3, 0.8, 2.0), 1.3);
    // The same sphere made by a rotation, a scale and a translation.
    let m = Mat4::from_scale_rotation_translation(Vec3::splat(r), Quat::from_rotation_y(0.7), c);
    let mut q = Quadric::new(QuadricKind::Sphere, Mat4::IDENTITY);
    q.transform(&m);
    assert!(q.is_similarity(1e-5));
    assert!((q.area() - 4.0 * PI * r * r).abs() < 1e-4);
    let mut u = rng(7);
    let (mut hits, mut misses) = (0, 0);
    for _ in 0..2000 {
        let o = c + Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 8.0;
        // Aimed near the sphere, so that about half hit (some from inside).
        let d = c + Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) * (3.0 * r) - o;
        // The closed form: the nearest root of |o + t d - c|^2 = r^2 with t > 0.
        let (oc, a) = ((o - c).as_dvec3(), d.as_dvec3());
        let b = oc.dot(a);
        let disc = b * b - a.length_squared() * (oc.length_squared() - (r as f64).powi(2));
        let want = (disc >= 0.0)
            .then(|| {
                let s = disc.sqrt();
                [(-b - s) / a.length_squared(), (-b + s) / a.length_squared()]
                    .into_iter()
                    .find(|&t| t > 0.0)
            })
            .flatten();
        match (q.intersect(o, d, 0.0, f32::INFINITY), want) {
            (Some((t, at)), Some(w)) => {
                hits += 1;
                assert!((t as f64 - w).abs() < 1e-4 * (1.0 + w), "t {t} want {w}");
                let p = o + d * t;
                assert!(((p - c).length() - r).abs() < 1e-4);
                // The parameters give back the point.
                let (e, _, _) = q.eval(at.face, at.uv.x, at.uv.y);
                assert!((e - p).length() < 1e-3, "{e} {p}");
            }
            (None, None) => misses += 1,
            (got, want) => panic!("got {got:?}, want {want:?} for {o} {d}"),
        }
    }
    assert!(hits > 200 && misses > 200, "{hits} hits, {misses} misses");
}

#[test]
fn grazing_rays_hit_inside_the_silhouette_and_miss_outside() {
    let (c, r) = (Vec3::new(3.0, 1.0, -2.0), 0.5);
    let q = sphere(c, r);
    for eps in [1e-2, 1e-3, 1e-4] {
        let inside = c + Vec3::new(-10.0, r * (1.0 - eps), 0.0);
        let outside = c + Vec3::new(-10.0, r * (1.0 + eps), 0.0);
        let (t, _) = q
            .intersect(inside, Vec3::X, 0.0, f32::INFINITY)
            .expect("inside the silhouette");
        // The chord at height y = r (1 - eps): half length r sqrt(1 - (1 - eps)^2).
        let half = r * (1.0 - (1.0 - eps) * (1.0 - eps)).sqrt();
        assert!(
            (t - (10.0 - half)).abs() < 2e-4,
            "eps {eps}: t {t} want {}",
            10.0 - half
        );
        assert!(
            q.intersect(outside, Vec3::X, 0.0, f32::INFINITY).is_none(),
            "eps {eps}"
        );
    }
    // A disk seen edge on is missed; one a hair off edge on is hit.
    let d = shapes::disk().quadric.unwrap();
    assert!(d
        .intersect(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 0.0, f32::INFINITY)
        .is_none());
    let (t, at) = d
        .intersect(
            Vec3::new(-5.0, 0.0, 1e-3),
            Vec3::new(1.0, 0.0, -2e-4),
            0.0,
            f32::INFINITY,
        )
        .expect("nearly edge on");
    // Near the centre, the middle of the concentric map's square.
    assert!(
        (t - 5.0).abs() < 1e-3 && (at.uv - Vec2::splat(0.5)).length() < 1e-3,
        "t {t} {at:?}"
    );
}

#[test]
fn rays_from_inside_a_sphere_meet_it_once_at_the_radius() {
    let (c, r) = (Vec3::new(0.0, 2.0, 0.0), 2.5);
    let mut q = sphere(c, r);
    let mut u = rng(3);
    for _ in 0..200 {
        let d = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
        let (t, _) = q.intersect(c, d, 0.0, f32::INFINITY).expect("from the centre");
        assert!((t - r).abs() < 1e-5);
        // Its normal points outward, so a ray from inside arrives on its back...
        let (_, n) = q.project(c + d * t);
        assert!(n.dot(d) > 0.99);
    }
    // ... unless it is flipped (a dome lit from inside).
    q.flipped = true;
    let (_, n) = q.project(c + Vec3::X * r);
    assert!((n + Vec3::X).length() < 1e-5);
    // From a point off centre: the one hit ahead.
    let o = c + Vec3::new(1.5, 0.0, 0.0);
    let (t, _) = q.intersect(o, Vec3::X, 0.0, f32::INFINITY).unwrap();
    assert!((t - 1.0).abs() < 1e-5);
    let (t, _) = q.intersect(o, Vec3::NEG_X, 0.0, f32::INFINITY).unwrap();
    assert!((t - 4.0).abs() < 1e-5);
}

#[test]
fn an_ellipse_is_hit_within_its_axes_with_its_true_normal_and_area() {
    // Mitsuba's disk under a non-uniform scale and a tilt: an ellipse of half axes
    // 0.6 and 0.4.
    let m = Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0))
        * Mat4::from_rotation_x(-0.5)
        * Mat4::from_scale(Vec3::new(0.6, 0.4, 1.0));
    let mut d = shapes::disk();
    d.transform(&m);
    let q = d.quadric.unwrap();
    assert!((q.area() - PI * 0.6 * 0.4).abs() < 1e-5);
    assert!((d.area() - q.area()).abs() < 1e-6);
    let n = Mat4::from_rotation_x(-0.5).transform_vector3(Vec3::Z);
    let centre = Vec3::new(0.0, 1.0, 0.0);
    let (ax, ay) = (Vec3::X, Mat4::from_rotation_x(-0.5).transform_vector3(Vec3::Y));
    for (point, hit) in [
        (centre + ax * 0.59, true),
        (centre + ax * 0.61, false),
        (centre + ay * 0.39, true),
        (centre + ay * 0.41, false),
        (centre + (ax * 0.6 + ay * 0.4) * 0.7, true),
        (centre + (ax * 0.6 + ay * 0.4) * 0.72, false),
    ] {
        let o = point + n * 2.0;
        let got = q.intersect(o, -n, 0.0, f32::INFINITY);
        assert_eq!(got.is_some(), hit, "{point}");
        if let Some((t, _)) = got {
            assert!((t - 2.0).abs() < 1e-5);
            let (p, nn) = q.project(o - n * t);
            assert!((p - point).length() < 1e-5 && (nn - n).length() < 1e-5);
        }
    }
    // Parallel to its plane: never.
    assert!(q.intersect(centre + n, ax, 0.0, f32::INFINITY).is_none());
}

#[test]
fn parameters_map_both_ways_and_name_the_triangle_and_patch_under_them() {
    let mut u = rng(11);
    for m in [shapes::sphere(Vec3::new(0.5, 0.0, -1.0), 2.0), shapes::disk()] {
        let q = m.quadric.unwrap();
        for _ in 0..2000 {
            let at = Param {
                face: (u() * f32::from(q.kind.faces())) as u8,
                uv: Vec2::new(u(), u()),
            };
            let (p, du, dv) = q.eval(at.face, at.uv.x, at.uv.y);
            // Back to the same parameters (but on a disk's centre, where all meet).
            let back = q.param_of(p);
            assert!(
                back.face == at.face && (back.uv - at.uv).length() < 1e-4,
                "{at:?} -> {back:?}"
            );
            // d/du x d/dv along the front normal.
            assert!(
                du.cross(dv).dot(q.normal(at.face, at.uv.x, at.uv.y)) > 0.0,
                "{at:?}"
            );
            // The named triangle: in the patch of the parameters' piece, and its
            // barycentrics put the point within a cell (1/16 of the square) of it.
            let (tri, b) = q.triangle_at(at);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6, "{b}");
            let Patch::Quadric { face, u: pu, v: pv } = &m.patches[m.tri_patch[tri as usize] as usize] else {
                panic!("not a quadric piece");
            };
            let within = |x: f32, r: &[f32; 2]| x >= r[0] - 1e-6 && x <= r[1] + 1e-6;
            assert!(*face == at.face && within(at.uv.x, pu) && within(at.uv.y, pv));
            let [ia, ib, ic] = m.indices[tri as usize].map(|i| i as usize);
            let w = [1.0 - b.x - b.y, b.x, b.y];
            let chord = m.positions[ia] * w[0] + m.positions[ib] * w[1] + m.positions[ic] * w[2];
            assert!((chord - p).length() < 0.06, "{at:?}: {chord} vs {p}");
        }
    }
}

#[test]
fn samples_are_uniform_by_area_with_outward_normals() {
    let (c, r) = (Vec3::new(1.0, 1.0, 1.0), 0.3);
    let q = sphere(c, r);
    let n = 64;
    // Stratified: the fraction above z = c.z + r/2 is a quarter (Archimedes).
    let mut above = 0;
    for i in 0..n {
        for j in 0..n {
            let s = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let (p, nn) = q.sample(s);
            assert!(((p - c).length() - r).abs() < 1e-5);
            assert!(((p - c) / r - nn).length() < 1e-4);
            above += usize::from(p.z > c.z + r / 2.0);
        }
    }
    let frac = above as f32 / (n * n) as f32;
    assert!((frac - 0.25).abs() < 0.01, "{frac}");
    let d = shapes::disk().quadric.unwrap();
    let mut inner = 0;
    for i in 0..n {
        for j in 0..n {
            let s = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let (p, nn) = d.sample(s);
            assert_eq!(nn, Vec3::Z);
            inner += usize::from(p.length() < 0.5);
        }
    }
    let frac = inner as f32 / (n * n) as f32;
    assert!((frac - 0.25).abs() < 0.01, "{frac}");
}
