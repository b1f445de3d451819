//! Mitsuba's built-in shapes as triangle meshes in object space.
//!
//! Each follows Mitsuba 3's object-space definition (`rectangle`, `cube`, `sphere`,
//! `disk`, `cylinder`); triangles are counter-clockwise seen from the front, so the geometric
//! normal `(b - a) x (c - a)` agrees with the shading normal.

use std::f32::consts::{PI, TAU};

use glam::{Mat4, Vec2, Vec3};

use crate::geometry::{Patch, Quadric, QuadricKind, TriMesh};

/// Pieces along each side of a sphere's cube face or a disk's square: the radiosity
/// patches (a sphere has 6 x 4, a disk 4).
pub const QUADRIC_PIECES: u32 = 2;
/// Cells along each side of a piece in the tessellation (two triangles each): a
/// sphere has 3072 triangles, a disk 512.
pub const QUADRIC_CELLS: u32 = 8;

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

/// Mitsuba's `cube`: `[-1,1]^3`, normals outward; six patches. Its faces' corners and
/// (u, v) are Mitsuba 3's, corner for corner (`mi.traverse` of a `cube`: per face four
/// corners running round it counter-clockwise seen from outside, split along the
/// diagonal from the first to the third), so a texture or an anisotropic lobe lies on
/// each face as Mitsuba lays it.
pub fn cube() -> TriMesh {
    // Per face: its outward normal, then its corners with their (u, v).
    type Corner = ([i8; 3], [u8; 2]);
    const FACES: [([i8; 3], [Corner; 4]); 6] = [
        (
            [0, -1, 0],
            [
                ([1, -1, -1], [0, 1]),
                ([1, -1, 1], [1, 1]),
                ([-1, -1, 1], [1, 0]),
                ([-1, -1, -1], [0, 0]),
            ],
        ),
        (
            [0, 1, 0],
            [
                ([1, 1, -1], [0, 1]),
                ([-1, 1, -1], [1, 1]),
                ([-1, 1, 1], [1, 0]),
                ([1, 1, 1], [0, 0]),
            ],
        ),
        (
            [1, 0, 0],
            [
                ([1, -1, -1], [0, 1]),
                ([1, 1, -1], [1, 1]),
                ([1, 1, 1], [1, 0]),
                ([1, -1, 1], [0, 0]),
            ],
        ),
        (
            [0, 0, 1],
            [
                ([1, -1, 1], [0, 1]),
                ([1, 1, 1], [1, 1]),
                ([-1, 1, 1], [1, 0]),
                ([-1, -1, 1], [0, 0]),
            ],
        ),
        (
            [-1, 0, 0],
            [
                ([-1, -1, 1], [0, 1]),
                ([-1, 1, 1], [1, 1]),
                ([-1, 1, -1], [1, 0]),
                ([-1, -1, -1], [0, 0]),
            ],
        ),
        (
            [0, 0, -1],
            [
                ([1, 1, -1], [0, 1]),
                ([1, -1, -1], [1, 1]),
                ([-1, -1, -1], [1, 0]),
                ([-1, 1, -1], [0, 0]),
            ],
        ),
    ];
    let v3 = |a: [i8; 3]| Vec3::new(a[0].into(), a[1].into(), a[2].into());
    let mut m = TriMesh::default();
    for (f, (n, corners)) in FACES.into_iter().enumerate() {
        let base = m.positions.len() as u32;
        for (p, uv) in corners {
            m.positions.push(v3(p));
            m.normals.push(v3(n));
            m.uvs.push(Vec2::new(uv[0].into(), uv[1].into()));
        }
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base + 3, base, base + 2]);
        m.tri_patch.extend([f as u32; 2]);
        m.patches
            .push(Patch::Polygon(vec![base, base + 1, base + 2, base + 3]));
    }
    m
}

/// Mitsuba's `sphere`: the exact surface ([`Quadric`]), normals outward, over its
/// tessellation.
///
/// The radiosity patches are pieces of the six cube faces the surface is
/// parameterised by (see [`crate::geometry::quadric`]), meshed on the exact surface;
/// the tessellation cuts each piece into a grid of triangles with vertices on the
/// surface, radial normals and Mitsuba's `u = phi / 2pi`, `v = theta / pi`. Rays meet
/// the exact sphere and name the triangle under the hit ([`Quadric::triangle_at`]).
pub fn sphere(center: Vec3, radius: f32) -> TriMesh {
    quadric_mesh(Quadric::new(
        QuadricKind::Sphere,
        Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius)),
    ))
}

/// Mitsuba's `disk`: the exact unit disk in the z = 0 plane ([`Quadric`]), normal
/// +z, over its tessellation: as [`sphere`], of one square face (the concentric map),
/// with Mitsuba's `u = r`, `v = phi / 2pi`.
pub fn disk() -> TriMesh {
    quadric_mesh(Quadric::new(QuadricKind::Disk, Mat4::IDENTITY))
}

/// Segments round a `cylinder`: flat quads whose area falls short of the true tube's by
/// 1 - sin(pi/n) / (pi/n) = 0.04 %.
pub const CYLINDER_SEGMENTS: u32 = 64;

/// Mitsuba's `cylinder`: the open tube (no caps) of `radius` round the segment from
/// `p0` to `p1`, facing outwards, as [`CYLINDER_SEGMENTS`] flat quads (one patch each)
/// with radial shading normals; u runs round the axis (phi / 2 pi), v along it (0 at
/// `p0`). `None` for a zero radius or length.
pub fn cylinder(p0: Vec3, p1: Vec3, radius: f32) -> Option<TriMesh> {
    let axis = p1 - p0;
    let a = axis.try_normalize()?;
    if !(radius > 0.0 && radius.is_finite()) {
        return None;
    }
    let (t1, t2) = a.any_orthonormal_pair();
    let n = CYLINDER_SEGMENTS;
    let mut mesh = TriMesh::default();
    for i in 0..=n {
        let phi = TAU * i as f32 / n as f32;
        let radial = t1 * phi.cos() + t2 * phi.sin();
        for (h, v) in [(Vec3::ZERO, 0.0), (axis, 1.0)] {
            mesh.positions.push(p0 + radial * radius + h);
            mesh.normals.push(radial);
            mesh.uvs.push(Vec2::new(i as f32 / n as f32, v));
        }
    }
    for i in 0..n {
        let (b0, t0, b1, t1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        mesh.patches.push(Patch::Polygon(vec![b0, b1, t1, t0]));
        mesh.indices.push([b0, b1, t1]);
        mesh.indices.push([b0, t1, t0]);
        mesh.tri_patch.extend([i, i]);
    }
    Some(mesh)
}

/// The patches and tessellation of `q`, laid out as [`Quadric::triangle_at`] reads
/// them: face by face, piece by piece (rows along v), cell by cell.
fn quadric_mesh(q: Quadric) -> TriMesh {
    let (m, c) = (QUADRIC_PIECES, QUADRIC_CELLS);
    let mut mesh = TriMesh {
        quadric: Some(q),
        ..TriMesh::default()
    };
    let local = q.to_world().inverse();
    for face in 0..q.kind.faces() {
        for pj in 0..m {
            for pi in 0..m {
                let range = |k: u32| [k as f32 / m as f32, (k + 1) as f32 / m as f32];
                let (u, v) = (range(pi), range(pj));
                let patch = mesh.patches.len() as u32;
                mesh.patches.push(Patch::Quadric { face, u, v });
                let base = mesh.positions.len() as u32;
                for j in 0..=c {
                    for i in 0..=c {
                        let uu = u[0] + (u[1] - u[0]) * i as f32 / c as f32;
                        let vv = v[0] + (v[1] - v[0]) * j as f32 / c as f32;
                        let (p, _, _) = q.eval(face, uu, vv);
                        mesh.positions.push(p);
                        mesh.normals.push(q.normal(face, uu, vv));
                        let l = local.transform_point3(p);
                        let phi = l.y.atan2(l.x).rem_euclid(TAU) / TAU;
                        mesh.uvs.push(match q.kind {
                            QuadricKind::Sphere => Vec2::new(phi, l.z.clamp(-1.0, 1.0).acos() / PI),
                            QuadricKind::Disk => Vec2::new(l.truncate().length(), phi),
                        });
                    }
                }
                let at = |i: u32, j: u32| base + j * (c + 1) + i;
                for j in 0..c {
                    for i in 0..c {
                        let (a, b, cc, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                        mesh.indices.push([a, b, cc]);
                        mesh.indices.push([a, cc, d]);
                        mesh.tri_patch.extend([patch; 2]);
                    }
                }
            }
        }
    }
    mesh
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
    fn assert_patches_cover(m: &TriMesh) {
        for (t, tri) in m.indices.iter().enumerate() {
            match &m.patches[m.tri_patch[t] as usize] {
                Patch::Polygon(poly) => assert!(tri.iter().all(|i| poly.contains(i))),
                Patch::Quadric { face, u, v } => {
                    // Its corners' parameters lie in its piece's (a corner on the
                    // face's edge may be named by the next face).
                    let q = m.quadric.unwrap();
                    for &i in tri {
                        let at = q.param_of(m.positions[i as usize]);
                        let inside = |x: f32, r: [f32; 2]| x >= r[0] - 1e-4 && x <= r[1] + 1e-4;
                        let edge = at.face != *face;
                        assert!(
                            edge || (inside(at.uv.x, *u) && inside(at.uv.y, *v)),
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

    /// The cube's (u, v) as Mitsuba 3 lays them (its `cube` read with `mi.traverse`):
    /// on the +z face u runs along +y and v along +x, on the top (+y) face u along -x
    /// and v along -z, on the -x face u along +y and v along +z; corner (1, -1, 1) of
    /// the +z face is (0, 1). Textures and anisotropic lobes lie on it as Mitsuba's.
    #[test]
    fn cube_faces_have_mitsubas_uv() {
        let m = cube();
        let axes = |n: Vec3| {
            let t = (0..m.triangle_count())
                .find(|&t| (geometric_normal(&m, t).normalize() - n).length() < 1e-6)
                .unwrap();
            let [a, b, c] = m.indices[t].map(|i| i as usize);
            let (dp1, dp2) = (m.positions[b] - m.positions[a], m.positions[c] - m.positions[a]);
            let (du1, du2) = (m.uvs[b] - m.uvs[a], m.uvs[c] - m.uvs[a]);
            let det = du1.x * du2.y - du1.y * du2.x;
            let dpdu = (dp1 * du2.y - dp2 * du1.y) / det;
            let dpdv = (dp2 * du1.x - dp1 * du2.x) / det;
            (dpdu, dpdv)
        };
        for (n, u, v) in [
            (Vec3::Z, Vec3::Y, Vec3::X),
            (Vec3::Y, Vec3::NEG_X, Vec3::NEG_Z),
            (Vec3::NEG_X, Vec3::Y, Vec3::Z),
        ] {
            let (dpdu, dpdv) = axes(n);
            assert!((dpdu - 2.0 * u).length() < 1e-6, "{n}: dp/du {dpdu}");
            assert!((dpdv - 2.0 * v).length() < 1e-6, "{n}: dp/dv {dpdv}");
        }
        let corner = (0..m.positions.len())
            .find(|&i| m.positions[i] == Vec3::new(1.0, -1.0, 1.0) && m.normals[i] == Vec3::Z)
            .unwrap();
        assert_eq!(m.uvs[corner], Vec2::new(0.0, 1.0));
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

    /// Mitsuba's `cylinder`: an open tube round p0-p1 whose facets cover 2 pi r L
    /// within 0.05 %, every facet facing away from the axis with its shading normals,
    /// patches covering the triangles; no tube without a radius or a length.
    #[test]
    fn cylinder_is_an_open_tube_facing_outwards() {
        let (p0, p1, r) = (Vec3::new(1.0, 2.0, 0.0), Vec3::new(1.0, 2.0, 3.0) + Vec3::X, 0.4);
        let m = cylinder(p0, p1, r).unwrap();
        m.validate().unwrap();
        let exact = TAU * r * (p1 - p0).length();
        assert!(
            (m.area() / exact - 1.0).abs() < 5e-4,
            "area {} of {exact}",
            m.area()
        );
        let axis = (p1 - p0).normalize();
        for t in 0..m.triangle_count() {
            let c = centroid(&m, t);
            let off = c - p0 - axis * (c - p0).dot(axis);
            assert!(
                geometric_normal(&m, t).dot(off) > 0.0,
                "triangle {t} faces inward"
            );
        }
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let off = *p - p0 - axis * (*p - p0).dot(axis);
            assert!((off.length() - r).abs() < 1e-5 && (*n - off / r).length() < 1e-5);
        }
        assert_consistent(&m);
        assert_patches_cover(&m);
        assert!(cylinder(p0, p0, r).is_none() && cylinder(p0, p1, 0.0).is_none());
    }

    #[test]
    fn sphere_area_and_outward_normals() {
        let (c, r) = (Vec3::new(1.0, -2.0, 0.5), 2.5);
        let m = sphere(c, r);
        m.validate().unwrap();
        let exact = 4.0 * PI * r * r;
        assert!((m.area() - exact).abs() / exact < 1e-5, "area {}", m.area());
        // The facets (chords) cover it within 1%, no facet more than 1.5x another.
        let tess: f32 = (0..m.triangle_count()).map(|t| m.triangle_area(t)).sum();
        assert!((tess / exact - 1.0).abs() < 0.01, "facets {tess}");
        let (lo, hi) = (0..m.triangle_count())
            .map(|t| m.triangle_area(t))
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), a| (lo.min(a), hi.max(a)));
        assert!(hi < 1.6 * lo, "facets from {lo} to {hi}");
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
        // Six faces of 2 x 2 pieces of 8 x 8 cells of two triangles.
        assert_eq!(m.patches.len(), 24);
        assert_eq!(m.triangle_count(), 24 * 128);
    }

    #[test]
    fn disk_area_and_normal() {
        let m = disk();
        m.validate().unwrap();
        assert!((m.area() - PI).abs() / PI < 1e-6, "area {}", m.area());
        assert_eq!((m.patches.len(), m.triangle_count()), (4, 512));
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
