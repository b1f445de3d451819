//! Mitsuba's built-in shapes as triangle meshes in object space.
//!
//! Each follows Mitsuba 3's object-space definition (`rectangle`, `cube`, `sphere`,
//! `disk`); triangles are counter-clockwise seen from the front, so the geometric
//! normal `(b - a) x (c - a)` agrees with the shading normal.

use std::f32::consts::{PI, TAU};

use glam::{Mat4, Vec2, Vec3};

use crate::geometry::{Patch, Quadric, QuadricKind, TriMesh};

/// Segments around the axis of the tessellated `sphere` and `disk`.
pub const SEGMENTS: u32 = 64;
/// Rings from pole to pole of the tessellated `sphere`.
pub const RINGS: u32 = 32;
/// A sphere's radiosity patches: pieces of this many segments by as many rings.
const SPHERE_PIECE: u32 = 8;
/// A disk's radiosity patches: sectors of this many segments.
const DISK_PIECE: u32 = 16;

/// Mitsuba's `rectangle`: `[-1,1]^2` in the z = 0 plane, normal +z; one patch.
pub fn rectangle() -> TriMesh {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    TriMesh {
        positions,
        normals: vec![Vec3::Z; 4],
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        tri_patch: vec![0, 0],
        patches: vec![Patch::Polygon(vec![0, 1, 2, 3])],
        bezier: Vec::new(),
        quadric: None,
    }
}

/// Mitsuba's `cube`: `[-1,1]^3`, normals outward; six patches.
pub fn cube() -> TriMesh {
    // For each face: its outward normal n and two axes u, v with u x v = n, so the
    // corners -u-v, +u-v, +u+v, -u+v run counter-clockwise seen from outside.
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ];
    let mut m = TriMesh::default();
    for (f, (n, u, v)) in faces.into_iter().enumerate() {
        let base = m.positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push(n + su * u + sv * v);
            m.normals.push(n);
            m.uvs.push(Vec2::new(0.5 * (su + 1.0), 0.5 * (sv + 1.0)));
        }
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base + 2, base + 3]);
        m.tri_patch.extend([f as u32; 2]);
        m.patches
            .push(Patch::Polygon(vec![base, base + 1, base + 2, base + 3]));
    }
    m
}

/// Mitsuba's `sphere`: the exact surface ([`Quadric`]), normals outward, over its
/// tessellation.
///
/// The tessellation is a UV sphere of [`SEGMENTS`] x [`RINGS`] with vertices on the
/// true surface, radial normals and Mitsuba's parametrisation `u = phi / 2pi`,
/// `v = theta / pi`; rays meet the exact sphere and name the triangle under the hit
/// ([`Quadric::triangle_at`]). The radiosity patches are pieces of the parameter
/// square, 8 segments by 8 rings each, meshed on the exact surface.
pub fn sphere(center: Vec3, radius: f32) -> TriMesh {
    let (ns, nr) = (SEGMENTS, RINGS);
    let mut m = TriMesh {
        quadric: Some(Quadric::new(
            QuadricKind::Sphere,
            Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius)),
        )),
        ..TriMesh::default()
    };
    let (pu, pv) = (ns / SPHERE_PIECE, nr / SPHERE_PIECE);
    for pi in 0..pv {
        for pj in 0..pu {
            let f = |k: u32, n: u32| {
                [
                    (k * SPHERE_PIECE) as f32 / n as f32,
                    ((k + 1) * SPHERE_PIECE) as f32 / n as f32,
                ]
            };
            m.patches.push(Patch::Quadric {
                u: f(pj, ns),
                v: f(pi, nr),
            });
        }
    }
    for i in 0..=nr {
        let theta = PI * i as f32 / nr as f32;
        let (st, ct) = theta.sin_cos();
        for j in 0..=ns {
            let phi = TAU * j as f32 / ns as f32;
            let (sp, cp) = phi.sin_cos();
            // Exact poles, so that all the pole's copies coincide.
            let dir = if i == 0 {
                Vec3::Z
            } else if i == nr {
                Vec3::NEG_Z
            } else {
                Vec3::new(st * cp, st * sp, ct)
            };
            m.positions.push(center + radius * dir);
            m.normals.push(dir);
            m.uvs.push(Vec2::new(j as f32 / ns as f32, i as f32 / nr as f32));
        }
    }
    let at = |i: u32, j: u32| i * (ns + 1) + j;
    for i in 0..nr {
        for j in 0..ns {
            // a (theta, phi), b (theta+, phi), c (theta+, phi+), d (theta, phi+):
            // d_theta x d_phi points outward.
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            let patch = (i / SPHERE_PIECE) * pu + j / SPHERE_PIECE;
            if i == 0 {
                m.indices.push([a, b, c]);
                m.tri_patch.push(patch);
            } else if i == nr - 1 {
                m.indices.push([a, c, d]);
                m.tri_patch.push(patch);
            } else {
                m.indices.push([a, b, c]);
                m.indices.push([a, c, d]);
                m.tri_patch.extend([patch; 2]);
            }
        }
    }
    m
}

/// How far out the tessellated disk's rim lies: its polygon then has the unit
/// disk's area, pi.
pub fn disk_rim() -> f32 {
    let n = SEGMENTS;
    let polygon_area = 0.5 * n as f32 * (TAU / n as f32).sin();
    (PI / polygon_area).sqrt()
}

/// Mitsuba's `disk`: the exact unit disk in the z = 0 plane ([`Quadric`]), normal
/// +z, over its tessellation.
///
/// The tessellation is a fan of [`SEGMENTS`] triangles around the centre, the rim
/// pushed out slightly so that the polygon's area is exactly pi. Mitsuba's
/// parametrisation: `u = r`, `v = phi / 2pi`. The radiosity patches are four
/// quarter disks, meshed on the exact surface.
pub fn disk() -> TriMesh {
    let n = SEGMENTS;
    let rim = disk_rim();
    let mut m = TriMesh {
        quadric: Some(Quadric::new(QuadricKind::Disk, Mat4::IDENTITY)),
        ..TriMesh::default()
    };
    for k in 0..n / DISK_PIECE {
        m.patches.push(Patch::Quadric {
            u: [0.0, 1.0],
            v: [
                (k * DISK_PIECE) as f32 / n as f32,
                ((k + 1) * DISK_PIECE) as f32 / n as f32,
            ],
        });
    }
    m.positions.push(Vec3::ZERO);
    m.normals.push(Vec3::Z);
    m.uvs.push(Vec2::ZERO);
    for j in 0..n {
        let phi = TAU * j as f32 / n as f32;
        let (sp, cp) = phi.sin_cos();
        m.positions.push(Vec3::new(rim * cp, rim * sp, 0.0));
        m.normals.push(Vec3::Z);
        m.uvs.push(Vec2::new(1.0, j as f32 / n as f32));
    }
    for j in 0..n {
        let a = 1 + j;
        let b = 1 + (j + 1) % n;
        m.indices.push([0, a, b]);
        m.tri_patch.push(j / DISK_PIECE);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometric_normal(m: &TriMesh, t: usize) -> Vec3 {
        let [a, b, c] = m.triangle(t);
        (b - a).cross(c - a)
    }

    fn centroid(m: &TriMesh, t: usize) -> Vec3 {
        let [a, b, c] = m.triangle(t);
        (a + b + c) / 3.0
    }

    /// Every triangle's geometric normal agrees with its vertices' shading normals.
    fn assert_consistent(m: &TriMesh) {
        for t in 0..m.triangle_count() {
            let g = geometric_normal(m, t);
            for &i in &m.indices[t] {
                assert!(g.dot(m.normals[i as usize]) > 0.0, "triangle {t}");
            }
        }
    }

    /// Each triangle's corners are among its patch's polygon's corners.
    /// (Of a sphere or disk: its corners' parameters lie in its piece's, but for the
    /// disk's centre, which lies in every sector.)
    fn assert_patches_cover(m: &TriMesh) {
        for (t, tri) in m.indices.iter().enumerate() {
            match &m.patches[m.tri_patch[t] as usize] {
                Patch::Polygon(poly) => assert!(tri.iter().all(|i| poly.contains(i))),
                Patch::Quadric { u, v } => {
                    for &i in tri {
                        let uv = m.uvs[i as usize];
                        let inside = |x: f32, r: [f32; 2]| x >= r[0] - 1e-6 && x <= r[1] + 1e-6;
                        assert!(inside(uv.x, *u), "triangle {t}");
                        // (The disk's seam at v = 0 is also v = 1.)
                        assert!(
                            uv.x == 0.0 || inside(uv.y, *v) || inside(uv.y + 1.0, *v),
                            "triangle {t}"
                        );
                    }
                }
                p => panic!("unexpected patch {p:?}"),
            }
        }
    }

    #[test]
    fn rectangle_is_two_triangles_one_patch() {
        let m = rectangle();
        m.validate().unwrap();
        assert!((m.area() - 4.0).abs() < 1e-6);
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.patches, vec![Patch::Polygon(vec![0, 1, 2, 3])]);
        for t in 0..2 {
            let n = geometric_normal(&m, t).normalize();
            assert!((n - Vec3::Z).length() < 1e-6);
        }
        assert_consistent(&m);
        assert_patches_cover(&m);
        // Counter-clockwise seen from +z: positive signed area in the xy plane.
        let p: Vec<Vec3> = [0, 1, 2, 3].map(|i| m.positions[i]).to_vec();
        let signed: f32 = (0..4)
            .map(|k| {
                let (a, b) = (p[k], p[(k + 1) % 4]);
                a.x * b.y - b.x * a.y
            })
            .sum();
        assert!(signed > 0.0);
        assert_eq!(
            m.bounds(),
            Some((Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)))
        );
    }

    #[test]
    fn rectangle_flip_normals_reverses_it() {
        let mut m = rectangle();
        m.flip_normals();
        m.validate().unwrap();
        for t in 0..2 {
            let n = geometric_normal(&m, t).normalize();
            assert!((n + Vec3::Z).length() < 1e-6);
        }
        assert!(m.normals.iter().all(|n| *n == Vec3::NEG_Z));
        assert_eq!(m.patches, vec![Patch::Polygon(vec![3, 2, 1, 0])]);
    }

    #[test]
    fn cube_is_outward_with_six_patches() {
        let m = cube();
        m.validate().unwrap();
        assert!((m.area() - 24.0).abs() < 1e-5);
        assert_eq!(m.triangle_count(), 12);
        assert_eq!(m.patches.len(), 6);
        for t in 0..m.triangle_count() {
            let g = geometric_normal(&m, t);
            assert!(g.dot(centroid(&m, t)) > 0.0, "triangle {t} faces inward");
            // Each face lies on one side of the cube.
            let n = g.normalize();
            assert!((n.abs().max_element() - 1.0).abs() < 1e-6);
        }
        assert_consistent(&m);
        assert_patches_cover(&m);
        assert_eq!(m.bounds(), Some((Vec3::splat(-1.0), Vec3::splat(1.0))));
    }

    #[test]
    fn sphere_area_and_outward_normals() {
        let (c, r) = (Vec3::new(1.0, -2.0, 0.5), 2.5);
        let m = sphere(c, r);
        m.validate().unwrap();
        let exact = 4.0 * PI * r * r;
        assert!((m.area() - exact).abs() / exact < 0.01, "area {}", m.area());
        for t in 0..m.triangle_count() {
            assert!(m.triangle_area(t) > 0.0, "degenerate triangle {t}");
            let g = geometric_normal(&m, t);
            assert!(g.dot(centroid(&m, t) - c) > 0.0, "triangle {t} faces inward");
        }
        for (p, n) in m.positions.iter().zip(&m.normals) {
            assert!(((*p - c).length() - r).abs() < 1e-4);
            assert!((n.length() - 1.0).abs() < 1e-5);
            assert!(((*p - c) / r - *n).length() < 1e-5);
        }
        assert_consistent(&m);
        assert_patches_cover(&m);
        assert_eq!(m.uvs.len(), m.positions.len());
        // Pieces of 8 x 8 quads; 2 pole rows of triangles, the rest quads.
        assert_eq!(m.patches.len(), (SEGMENTS * RINGS / 64) as usize);
        assert_eq!(m.triangle_count(), (2 * SEGMENTS * (RINGS - 1)) as usize);
    }

    #[test]
    fn disk_area_and_normal() {
        let m = disk();
        m.validate().unwrap();
        assert!((m.area() - PI).abs() / PI < 0.01, "area {}", m.area());
        for t in 0..m.triangle_count() {
            let n = geometric_normal(&m, t);
            assert!(n.z > 0.0 && n.x.abs() < 1e-6 && n.y.abs() < 1e-6);
        }
        assert_consistent(&m);
        assert_patches_cover(&m);
        let mut f = disk();
        f.flip_normals();
        assert!(geometric_normal(&f, 0).z < 0.0);
    }
}
