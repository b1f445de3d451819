//! Each built-in shape, loaded from a scene file and placed with `to_world`, is hit
//! where the closed form says.

use glam::Vec3;
use radtrace::accel::{Accel, Bvh, Ray};
use radtrace::scene::xml;

fn load(shapes: &str) -> radtrace::scene::Scene {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("s.xml");
    let text = format!(
        r#"<scene version="3.0.0">{shapes}
        <sensor type="perspective"><float name="fov" value="40"/></sensor></scene>"#
    );
    std::fs::write(&p, text).unwrap();
    xml::load(&p, &[]).unwrap().scene
}

fn hit_t(scene: &radtrace::scene::Scene, o: Vec3, d: Vec3) -> Option<f32> {
    Bvh::build(scene)
        .intersect(&Ray::new(o, d.normalize()))
        .map(|h| h.t)
}

#[test]
fn rectangle_is_hit_inside_its_transformed_bounds_only() {
    // Unit rectangle scaled by 2 and lifted to z = 1.
    let s = load(
        r#"<shape type="rectangle"><transform name="to_world">
           <scale value="2"/><translate z="1"/></transform></shape>"#,
    );
    let t = hit_t(&s, Vec3::new(1.9, -1.9, 5.0), -Vec3::Z).unwrap();
    assert!((t - 4.0).abs() < 1e-5);
    assert!(hit_t(&s, Vec3::new(2.1, 0.0, 5.0), -Vec3::Z).is_none());
}

#[test]
fn cube_faces_are_at_plus_minus_one_times_scale() {
    let s = load(
        r#"<shape type="cube"><transform name="to_world"><scale x="1" y="2" z="3"/></transform></shape>"#,
    );
    for (o, d, t) in [
        (Vec3::new(10.0, 0.3, 0.2), -Vec3::X, 9.0),
        (Vec3::new(0.1, -10.0, 0.2), Vec3::Y, 8.0),
        (Vec3::new(0.1, 0.3, 10.0), -Vec3::Z, 7.0),
    ] {
        let got = hit_t(&s, o, d).unwrap();
        assert!((got - t).abs() < 1e-5, "{o:?}: {got} vs {t}");
    }
}

#[test]
fn sphere_is_hit_at_its_radius_within_the_tessellation_tolerance() {
    let s = load(
        r#"<shape type="sphere"><point name="center" x="1" y="2" z="3"/><float name="radius" value="0.5"/></shape>"#,
    );
    let c = Vec3::new(1.0, 2.0, 3.0);
    // Rays from many directions towards the centre enter at distance 10 - r (to within
    // the chord error of a 64 x 32 tessellation: r (1 - cos(pi/32)) ~ 0.0024 r).
    for k in 0..50 {
        let a = k as f32 * 0.7;
        let b = (k as f32 * 0.37).sin();
        let dir = Vec3::new(a.cos() * (1.0 - b * b).sqrt(), a.sin() * (1.0 - b * b).sqrt(), b);
        let t = hit_t(&s, c + dir * 10.0, -dir).unwrap();
        assert!(
            (9.5 - 1e-4..=9.5 + 0.005 * 0.5 + 1e-4).contains(&t),
            "dir {dir:?}: t {t}"
        );
    }
    // A ray passing just outside misses.
    assert!(hit_t(&s, c + Vec3::new(0.51, 0.0, 10.0), -Vec3::Z).is_none());
}

#[test]
fn disk_is_a_unit_circle_in_its_plane() {
    let s = load(
        r#"<shape type="disk"><transform name="to_world"><rotate x="1" angle="90"/><translate y="-1"/></transform></shape>"#,
    );
    // Rotated 90 degrees about x, the disk lies in the y = -1 plane (normal -y).
    let t = hit_t(&s, Vec3::new(0.6, 5.0, 0.6), -Vec3::Y).unwrap();
    assert!((t - 6.0).abs() < 1e-5);
    assert!(
        hit_t(&s, Vec3::new(0.72, 5.0, 0.72), -Vec3::Y).is_none(),
        "outside radius 1"
    );
}

#[test]
fn tessellate_writes_an_obj_that_loads_back_as_the_same_surface() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("teapot.obj");
    let bpt = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/paper-room/teapot.bpt");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_radtrace"))
        .args([
            "tessellate",
            bpt.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--coarse",
            "2",
            "--fine",
            "4",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mesh = radtrace::geometry::obj::read_obj(&out, false).unwrap();
    // 32 patches x (2*4)^2 quads x 2 triangles.
    assert_eq!(mesh.triangle_count(), 32 * 64 * 2);
    assert_eq!(mesh.normals.len(), mesh.positions.len());
    let (lo, hi) = mesh.bounds().unwrap();
    assert!(lo.z.abs() < 1e-4 && (hi.z - 3.15).abs() < 1e-3, "{lo:?} {hi:?}");
}
