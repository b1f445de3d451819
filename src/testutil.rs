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

/// The six faces of the box `[lo, hi]`, facing outwards (a closed object).
pub fn box_outside(lo: Vec3, hi: Vec3) -> Vec<TriMesh> {
    let mut faces = box_inside(lo, hi);
    for f in &mut faces {
        f.flip_normals();
    }
    faces
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
        textures: vec![],
        sun_disk: None,
    };
    for (i, (mesh, kind)) in shapes.into_iter().enumerate() {
        s.bsdfs.push(Bsdf {
            name: format!("b{i}"),
            kind,
            twosided: false,
            textures: Vec::new(),
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
            texture: None,
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
        projection: crate::scene::Projection::Perspective,
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
        filter: None,
        crop: None,
        lens: None,
    }
}

pub fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// A floor-level square `[x0,x1] x [y0,y1]` at height z, facing up (or down).
pub fn square(x0: f32, x1: f32, y0: f32, y1: f32, z: f32, down: bool) -> crate::geometry::TriMesh {
    let mut m = quad([v(x0, y0, z), v(x1, y0, z), v(x1, y1, z), v(x0, y1, z)]);
    if down {
        m.flip_normals();
    }
    m
}

/// A closed box lit by a point light and a small ceiling lamp, with a table that
/// casts shadows from both onto the floor; a camera looking down at the table.
pub fn room() -> Scene {
    let lo = v(0.0, 0.0, 0.0);
    let hi = v(2.0, 2.0, 2.0);
    let mut shapes: Vec<(crate::geometry::TriMesh, Rgb)> = box_inside(lo, hi)
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

/// An open scene: a floor and a one-sided table top, both lit by a point light and
/// a lamp above; nothing else reflects onto them, so their lists hold only lights.
pub fn open_scene() -> Scene {
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

/// A square `[0, s]^2` at height `z` facing +z, cut into `k x k` cells of two
/// triangles each, every triangle its own scene patch.
pub fn split_square(s: f32, z: f32, k: u32) -> crate::geometry::TriMesh {
    split_quad([v(0.0, 0.0, z), v(s, 0.0, z), v(s, s, z), v(0.0, s, z)], k)
}

/// A uniform sky (`constant`) of radiance `l` in every channel.
pub fn uniform_sky(l: f32) -> Light {
    Light::Environment {
        radiance: Vec3::splat(l),
        texture: None,
        to_local: glam::Mat3::IDENTITY,
    }
}

/// [`split_square`] at height 0, centred on the origin: `[-s/2, s/2]^2`.
pub fn centred_square(s: f32, k: u32) -> crate::geometry::TriMesh {
    let mut m = split_square(s, 0.0, k);
    for p in &mut m.positions {
        *p -= v(0.5 * s, 0.5 * s, 0.0);
    }
    m
}

/// The parallelogram with corners `c` (counter-clockwise seen from the front) cut
/// into `k x k` cells of two triangles each, every triangle its own scene patch (so
/// the radiosity mesh merges them back into one).
pub fn split_quad(c: [Vec3; 4], k: u32) -> crate::geometry::TriMesh {
    let mut m = crate::geometry::TriMesh::default();
    let (du, dv) = ((c[1] - c[0]) / k as f32, (c[3] - c[0]) / k as f32);
    for j in 0..=k {
        for i in 0..=k {
            m.positions.push(c[0] + du * i as f32 + dv * j as f32);
        }
    }
    let at = |i: u32, j: u32| j * (k + 1) + i;
    for j in 0..k {
        for i in 0..k {
            for t in [
                [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
            ] {
                m.tri_patch.push(m.patches.len() as u32);
                m.patches.push(crate::geometry::Patch::Polygon(t.to_vec()));
                m.indices.push(t);
            }
        }
    }
    m
}

/// Mitsuba's `roughplastic` of diffuse reflectance `diffuse`: GGX of roughness
/// `alpha`, a coating of index 1.5, `nonlinear` as given.
pub fn rough_plastic(diffuse: Rgb, alpha: f32, nonlinear: bool) -> BsdfKind {
    use crate::scene::{CoatingCell, Fresnel, Glossy, Microfacet};
    BsdfKind::RoughPlastic {
        diffuse_reflectance: diffuse,
        lobe: Glossy {
            distribution: Microfacet {
                alpha_u: alpha,
                alpha_v: alpha,
                beckmann: false,
            },
            fresnel: Fresnel::Dielectric { eta: 1.5 },
            scale: Vec3::ONE,
        },
        nonlinear,
        coating: CoatingCell::default(),
        pplastic: false,
    }
}

/// A material's reading of texture `texture` as its `field` (factor 1, no path).
pub fn slot(field: crate::scene::TexField, texture: u32) -> crate::scene::TexSlot {
    crate::scene::TexSlot {
        path: Vec::new(),
        field,
        texture,
        factor: Vec3::ONE,
    }
}

/// Adds texture `t` to the scene, read by material `bsdf` as its `field`.
pub fn texture_on(s: &mut Scene, bsdf: usize, field: crate::scene::TexField, t: crate::scene::Texture) {
    s.textures.push(t);
    let k = s.textures.len() as u32 - 1;
    s.bsdfs[bsdf].textures.push(slot(field, k));
}

/// What a horizontal lamp of radiance `le` over `[x0, x1] x [y0, y1]` at height `z`,
/// facing down, sends from the origin towards `wo` by `brdf(wi, wo)`: Le x brdf x cos x
/// cos / r^2 over the lamp, by the midpoint rule on 400 x 400 cells.
pub fn lamp_integral(rect: [f32; 4], z: f32, le: f32, wo: Vec3, brdf: impl Fn(Vec3, Vec3) -> f32) -> f32 {
    let [x0, x1, y0, y1] = rect;
    let m = 400;
    let mut want = 0.0f64;
    for i in 0..m {
        for j in 0..m {
            let p = Vec3::new(
                x0 + (x1 - x0) * (i as f32 + 0.5) / m as f32,
                y0 + (y1 - y0) * (j as f32 + 0.5) / m as f32,
                z,
            );
            let r2 = p.length_squared();
            let wi = p / r2.sqrt();
            want += f64::from(brdf(wi, wo) * le * wi.z * wi.z / r2);
        }
    }
    want as f32 * (x1 - x0) * (y1 - y0) / (m * m) as f32
}
