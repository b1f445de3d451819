//! Small scenes built in code, for tests.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::geometry::{Patch, TriMesh};
use crate::scene::{Bsdf, BsdfKind, Light, Rgb, Scene, Shape};

/// A quadrilateral patch with corners `c` (counter-clockwise seen from the front).
pub fn quad(c: [Vec3; 4]) -> TriMesh {
    TriMesh {
        positions: c.to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        tri_patch: vec![0, 0],
        patches: vec![Patch::Polygon(vec![0, 1, 2, 3])],
        ..Default::default()
    }
}

/// The six faces of the box `[lo, hi]`, facing inwards.
pub fn box_inside(lo: Vec3, hi: Vec3) -> Vec<TriMesh> {
    let p = |x: usize, y: usize, z: usize| Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    vec![
        quad([p(0, 0, 0), p(1, 0, 0), p(1, 1, 0), p(0, 1, 0)]), // z = lo, facing +z
        quad([p(0, 0, 1), p(0, 1, 1), p(1, 1, 1), p(1, 0, 1)]), // z = hi, facing -z
        quad([p(0, 0, 0), p(0, 0, 1), p(1, 0, 1), p(1, 0, 0)]), // y = lo, facing +y
        quad([p(0, 1, 0), p(1, 1, 0), p(1, 1, 1), p(0, 1, 1)]), // y = hi, facing -y
        quad([p(0, 0, 0), p(0, 1, 0), p(0, 1, 1), p(0, 0, 1)]), // x = lo, facing +x
        quad([p(1, 0, 0), p(1, 0, 1), p(1, 1, 1), p(1, 1, 0)]), // x = hi, facing -x
    ]
}

/// A scene of diffuse shapes (mesh, reflectance) and lights; `emitters` lists
/// (shape, radiance) pairs made area lights.
pub fn scene(shapes: Vec<(TriMesh, Rgb)>, lights: Vec<Light>, emitters: &[(usize, Rgb)]) -> Scene {
    let shapes = shapes
        .into_iter()
        .map(|(m, rho)| (m, BsdfKind::Diffuse { reflectance: rho }))
        .collect();
    scene_with(shapes, lights, emitters)
}

/// A scene of shapes with one-sided materials of the given kinds, and lights;
/// `emitters` lists (shape, radiance) pairs made area lights.
pub fn scene_with(
    shapes: Vec<(TriMesh, BsdfKind)>,
    mut lights: Vec<Light>,
    emitters: &[(usize, Rgb)],
) -> Scene {
    let mut s = Scene {
        path: "test.xml".into(),
        shapes: vec![],
        bsdfs: vec![],
        lights: vec![],
        light_ids: vec![],
        sensors: vec![],
    };
    for (i, (mesh, kind)) in shapes.into_iter().enumerate() {
        s.bsdfs.push(Bsdf {
            name: format!("b{i}"),
            kind,
            twosided: false,
        });
        s.shapes.push(Shape {
            name: format!("s{i}"),
            mesh,
            bsdf: i as u32,
            emitter: None,
        });
    }
    for &(shape, radiance) in emitters {
        s.shapes[shape].emitter = Some(lights.len() as u32);
        lights.push(Light::Area {
            shape: shape as u32,
            radiance,
        });
    }
    s.lights = lights;
    s
}

/// A fixture file under `tests/data/mesh/`.
pub fn mesh_data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/mesh")
        .join(name)
}

/// The Newell teapot as the paper room uses it.
pub fn teapot_bpt() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/paper-room/teapot.bpt")
}

/// A perspective sensor at `origin` looking at `target` (up +y, or +z when looking
/// along y), horizontal field of view `fov` degrees, `w x h` pixels.
pub fn looking(origin: glam::Vec3, target: glam::Vec3, fov: f32, w: u32, h: u32) -> crate::scene::Sensor {
    use glam::{Mat4, Vec3};
    let dir = (target - origin).normalize();
    let up = if dir.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
    let left = up.cross(dir).normalize();
    let up = dir.cross(left);
    crate::scene::Sensor {
        to_world: Mat4::from_cols(
            left.extend(0.0),
            up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        ),
        fov,
        fov_axis: crate::scene::FovAxis::X,
        width: w,
        height: h,
        near_clip: 1e-3,
        far_clip: 1e4,
        spp: None,
    }
}
