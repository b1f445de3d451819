use super::*;
use crate::accel::{Accel, Bvh, Ray};
use crate::geometry::TriMesh;
use crate::scene::Rgb;
use crate::testutil::{box_inside, quad, scene, split_quad, split_square, v};

fn tri_scene() -> Scene {
    let v = Vec3::new;
    let mut tri = quad([v(0., 0., 0.), v(2., 0., 0.), v(0., 2., 0.), v(0., 2., 0.)]);
    tri.patches = vec![Patch::Polygon(vec![0, 1, 2])];
    tri.indices = vec![[0, 1, 2]];
    tri.tri_patch = vec![0];
    let q = quad([v(0., 0., 1.), v(3., 0., 1.), v(3.5, 1., 1.), v(0., 1., 1.)]);
    scene(vec![(tri, Vec3::ONE), (q, Vec3::ONE)], vec![], &[])
}

#[test]
fn elements_respect_the_mesh_size_and_vertex_areas_sum_to_the_patch_area() {
    let s = tri_scene();
    let m = RadiosityMesh::build(&s, 0.25);
    assert_eq!(m.patches.len(), 2);
    // Triangle: longest edge 2.83 -> 12 divisions -> 144 elements.
    assert_eq!(m.patches[0].element_count, 144);
    assert_eq!(m.patches[0].vertex_count, 13 * 14 / 2);
    // Quad: 3.5 / 0.25 = 14 by 1.118 / 0.25 -> 5.
    assert_eq!((m.patches[1].grids[0].n, m.patches[1].grids[0].m), (14, 5));
    for p in &m.patches {
        let vs = &m.vertices[p.first_vertex as usize..(p.first_vertex + p.vertex_count) as usize];
        let sum: f32 = vs.iter().map(|v| v.area).sum();
        assert!((sum - p.area).abs() < 1e-4 * p.area, "{sum} vs {}", p.area);
    }
    assert!((m.patches[0].area - 2.0).abs() < 1e-5);
    assert!((m.patches[1].area - 3.25).abs() < 1e-4);
}

/// Element triangles tile the patch: their areas sum to its area, and they face
/// like its vertices, on both sides of a two-sided patch.
#[test]
fn element_triangles_tile_the_patch_and_face_its_normal() {
    let mut s = tri_scene();
    s.bsdfs[1].twosided = true;
    let m = RadiosityMesh::build(&s, 0.3);
    assert_eq!(m.patches.len(), 3, "quad has a back twin");
    for (pi, p) in m.patches.iter().enumerate() {
        let tris = m.element_triangles(pi as u32);
        assert_eq!(
            tris.len() as u32,
            if pi == 0 {
                p.element_count
            } else {
                2 * p.element_count
            }
        );
        let mut area = 0.0;
        for t in &tris {
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            assert!(t.iter().all(|&i| m.vertices[i as usize].patch == pi as u32));
            let n = (b.p - a.p).cross(c.p - a.p);
            area += 0.5 * n.length();
            assert!(n.normalize().dot(a.n) > 0.999, "patch {pi}");
        }
        assert!((area - p.area).abs() < 1e-4 * p.area, "{area} vs {}", p.area);
    }
}

/// The outline of a planar patch is its elements' union: the same area, normal
/// and solid angle; a curved Bezier piece's outline sees nearly the same solid
/// angle as its elements.
#[test]
fn outline_triangles_stand_for_the_elements() {
    use crate::geometry::triangle_solid_angle;
    let sa = |m: &RadiosityMesh, tris: &[[u32; 3]], x: Vec3| -> f32 {
        tris.iter()
            .map(|t| triangle_solid_angle(x, &t.map(|i| m.vertices[i as usize].p)))
            .sum()
    };
    let mut s = tri_scene();
    s.bsdfs[1].twosided = true;
    let m = RadiosityMesh::build(&s, 0.3);
    for (pi, p) in m.patches.iter().enumerate() {
        let outline = m.outline_triangles(pi as u32);
        assert_eq!(outline.len(), if pi == 0 { 1 } else { 2 });
        let mut area = 0.0;
        for t in &outline {
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            let n = (b.p - a.p).cross(c.p - a.p);
            area += 0.5 * n.length();
            assert!(n.normalize().dot(a.n) > 0.999, "patch {pi}");
        }
        assert!((area - p.area).abs() < 1e-4 * p.area, "{area} vs {}", p.area);
        let x = m.vertices[p.first_vertex as usize].p
            + m.vertices[p.first_vertex as usize].n * 0.7
            + Vec3::splat(0.2);
        let (o, e) = (sa(&m, &outline, x), sa(&m, &m.element_triangles(pi as u32), x));
        assert!((o - e).abs() < 1e-4 * e.max(1e-3), "patch {pi}: {o} vs {e}");
    }
    let patches = crate::geometry::bezier::read_bpt(&crate::testutil::teapot_bpt()).unwrap();
    let teapot = crate::geometry::bezier::tessellate(&patches, 4, 8);
    let s = crate::testutil::scene(vec![(teapot, Vec3::splat(0.5))], vec![], &[]);
    let m = RadiosityMesh::build(&s, 0.05);
    let x = Vec3::new(0.0, 6.0, 4.0);
    let (mut checked, mut rel_sum) = (0, 0.0);
    for pi in 0..m.patches.len() as u32 {
        let outline = m.outline_triangles(pi);
        assert!(outline.len() <= 8);
        let e = sa(&m, &m.element_triangles(pi), x);
        if e > 1e-3 {
            let rel = (sa(&m, &outline, x) - e).abs() / e;
            assert!(rel < 0.1, "patch {pi}: {rel}");
            rel_sum += rel;
            checked += 1;
        }
    }
    assert!(checked > 20, "{checked}");
    assert!(
        rel_sum / (checked as f32) < 0.02,
        "mean {}",
        rel_sum / checked as f32
    );
}

/// Gouraud interpolation of a linear function of position is exact, at any hit.
#[test]
fn locate_interpolates_linear_functions_exactly() {
    let s = tri_scene();
    let m = RadiosityMesh::build(&s, 0.3);
    let f = |p: Vec3| Vec3::new(1.0 + 2.0 * p.x - p.y, 0.5 * p.x + 3.0 * p.y, 2.0);
    let values: Vec<Rgb> = m.vertices.iter().map(|v| f(v.p)).collect();
    let bvh = Bvh::build(&s);
    let mut hits = 0;
    for (k, (x, y)) in [
        (0.3f32, 0.2f32),
        (1.2, 0.7),
        (0.05, 1.9),
        (2.9, 0.5),
        (3.3, 0.9),
        (1.7, 0.1),
    ]
    .iter()
    .enumerate()
    {
        for z in [0.5f32, 2.0] {
            let ray = Ray::new(Vec3::new(*x, *y, z), -Vec3::Z);
            let Some(hit) = bvh.intersect(&ray) else { continue };
            let p = ray.at(hit.t);
            let got = m.locate(&s, &hit, p, true).apply(&values);
            assert!(
                (got - f(p)).abs().max_element() < 1e-3,
                "case {k}: {got} vs {}",
                f(p)
            );
            hits += 1;
        }
    }
    assert_eq!(hits, 10, "rays that hit the triangle or the quad");
}

/// The inverse bilinear map recovers (s, t) across the Cornell box's tall block top
/// (a rotated square whose bilinear term is rounding noise: the textbook quadratic
/// formula put points a fifth of the way off there), across a trapezoid and a
/// general quadrilateral.
#[test]
fn inverse_bilinear_recovers_the_parameters_of_near_parallelograms_too() {
    let top = [
        v(-0.53, 1.2, 0.09),
        v(0.04, 1.2, -0.09),
        v(-0.14, 1.2, -0.67),
        v(-0.71, 1.2, -0.49),
    ];
    let trapezoid = [
        v(0.0, 0.0, 0.0),
        v(2.0, 0.0, 0.0),
        v(1.5, 1.0, 0.0),
        v(0.5, 1.0, 0.0),
    ];
    let general = [
        v(0.0, 0.0, 1.0),
        v(2.0, 0.3, 1.0),
        v(2.4, 1.7, 1.0),
        v(-0.2, 1.0, 1.0),
    ];
    for q in [top, trapezoid, general] {
        for i in 0..=10 {
            for j in 0..=10 {
                let (s, t) = (i as f32 / 10.0, j as f32 / 10.0);
                let p = q[0] * ((1.0 - s) * (1.0 - t))
                    + q[1] * (s * (1.0 - t))
                    + q[2] * (s * t)
                    + q[3] * ((1.0 - s) * t);
                let st = inverse_bilinear(q, p);
                assert!(
                    (st - Vec2::new(s, t)).abs().max_element() < 1e-4,
                    "{q:?} at ({s}, {t}): {st}"
                );
            }
        }
    }
}

#[test]
fn shoot_cells_tile_the_patch() {
    let s = tri_scene();
    let m = RadiosityMesh::build(&s, 0.3);
    for p in 0..2 {
        let cells = m.shoot_cells(p, 16, |_| Vec2::splat(0.5), &[], None);
        let area: f32 = cells
            .iter()
            .map(|c| {
                let q = c.polygon();
                (1..q.len() - 1)
                    .map(|k| 0.5 * (q[k] - q[0]).cross(q[k + 1] - q[0]).length())
                    .sum::<f32>()
            })
            .sum();
        assert!(
            (area - m.patches[p as usize].area).abs() < 1e-3,
            "patch {p}: {area}"
        );
        assert!(cells.len() >= 9 && cells.len() <= 16, "{}", cells.len());
    }
}

/// What a shooting cell carries is the mean of the field over the cell, the same
/// wherever its point was jittered: for a linear field on a triangle the cells' power
/// sums to the exact integral; on a merged plane of 10k triangles it is the same for
/// two jitters and within 1 % of the integral.
#[test]
fn shoot_cells_carry_the_fields_mean_whatever_the_jitter() {
    let linear = |m: &RadiosityMesh| -> Vec<Rgb> {
        m.vertices
            .iter()
            .map(|v| Vec3::splat(1.0 + v.p.x + 2.0 * v.p.y))
            .collect()
    };
    let power = |cells: &[ShootCell]| -> f32 {
        cells
            .iter()
            .map(|c| {
                let q = c.polygon();
                let a: f32 = (1..q.len() - 1)
                    .map(|k| 0.5 * (q[k] - q[0]).cross(q[k + 1] - q[0]).length())
                    .sum();
                c.value.x * a * c.weight
            })
            .sum()
    };
    // Triangle (0,0), (2,0), (0,2): area 2, centroid (2/3, 2/3): integral 2 * 3.
    let s = tri_scene();
    let m = RadiosityMesh::build(&s, 0.25);
    let f = linear(&m);
    let a = m.shoot_cells(0, 16, |_| Vec2::splat(0.1), &f, None);
    let b = m.shoot_cells(0, 16, |_| Vec2::splat(0.9), &f, None);
    assert!(a.iter().zip(&b).all(|(x, y)| x.value == y.value));
    assert!((power(&a) - 6.0).abs() < 1e-3, "{}", power(&a));
    // Plane 2 x 2: integral of 1 + x + 2y = 4 + 4 + 8 = 16.
    let s = scene(vec![(split_square(2.0, 0.0, 71), Vec3::splat(0.5))], vec![], &[]);
    let m = RadiosityMesh::build(&s, 0.25);
    let f = linear(&m);
    for count in [4, 64] {
        let a = m.shoot_cells(0, count, |_| Vec2::splat(0.1), &f, None);
        let b = m.shoot_cells(0, count, |i| Vec2::new(0.9, (i % 7) as f32 / 7.0), &f, None);
        assert!(a
            .iter()
            .zip(&b)
            .all(|(x, y)| x.value == y.value && x.weight == y.weight));
        assert!((power(&a) - 16.0).abs() < 0.16, "{count} cells: {}", power(&a));
    }
    // Each quarter carries the field's mean over it: for a linear field, the field at
    // the quarter's centroid; the quarters' mean is the cell's.
    let s = tri_scene();
    let m = RadiosityMesh::build(&s, 0.25);
    let f = linear(&m);
    for c in m.shoot_cells(0, 4, |_| Vec2::splat(0.3), &f, None) {
        for k in 0..4 {
            let (corners, len) = crate::mesh::quarter(c.polygon(), k);
            let centroid = corners[..len].iter().sum::<Vec3>() / len as f32;
            let want = 1.0 + centroid.x + 2.0 * centroid.y;
            assert!(
                (c.quarters[k].x - want).abs() < 1e-4 * want,
                "quarter {k}: {} vs {want}",
                c.quarters[k].x
            );
        }
        let mean = c.quarters.iter().sum::<Vec3>() / 4.0;
        assert!((mean - c.value).abs().max_element() < 1e-5 * c.value.x);
    }
}

#[test]
fn twosided_patches_get_a_back_twin_with_its_own_vertices() {
    let mut s = tri_scene();
    s.bsdfs[1].twosided = true;
    let m = RadiosityMesh::build(&s, 0.5);
    assert_eq!(m.front_patches, 2);
    assert_eq!(m.patches.len(), 3);
    let twin = &m.patches[m.patches[1].twin.unwrap() as usize];
    let front = &m.patches[1];
    assert_eq!(twin.vertex_count, front.vertex_count);
    let (a, b) = (
        &m.vertices[front.first_vertex as usize],
        &m.vertices[twin.first_vertex as usize],
    );
    assert_eq!(a.p, b.p);
    assert_eq!(a.n, -b.n);
}

#[test]
fn a_plane_of_ten_thousand_triangles_is_one_patch_with_vertices_by_area() {
    // 2 x 2 m in 71 x 71 cells: 10,082 triangles; mesh size 0.25 -> 8 x 8 elements.
    let s = scene(vec![(split_square(2.0, 0.0, 71), Vec3::splat(0.5))], vec![], &[]);
    assert!(s.shapes[0].mesh.indices.len() >= 10_000);
    let m = RadiosityMesh::build(&s, 0.25);
    assert_eq!(m.patches.len(), 1);
    assert_eq!(m.patches[0].element_count, 64);
    assert_eq!(m.vertices.len(), 81);
    let sum: f32 = m.vertices.iter().map(|v| v.area).sum();
    assert!((sum - 4.0).abs() < 1e-3, "{sum}");
    assert!((m.patches[0].area - 4.0).abs() < 1e-3);
    // Every vertex lies on the surface, and a hit anywhere is located on it with
    // weights that reproduce a linear function.
    for v in &m.vertices {
        assert!(
            v.p.z.abs() < 1e-6 && v.p.x >= -1e-5 && v.p.x <= 2.0 + 1e-5,
            "{:?}",
            v.p
        );
    }
    let f: Vec<Rgb> = m
        .vertices
        .iter()
        .map(|v| Vec3::splat(1.0 + v.p.x + 2.0 * v.p.y))
        .collect();
    for (x, y) in [(0.3, 0.7), (1.9, 0.1), (1.0, 1.0), (0.01, 1.99)] {
        let lat = match &m.patches[0].grids[0].domain {
            Domain::Lattice(l) => l,
            d => panic!("{d:?}"),
        };
        let w = lat.interp(0, Vec3::new(x, y, 0.0));
        let got = w.apply(&f).x;
        assert!((got - (1.0 + x + 2.0 * y)).abs() < 1e-3, "({x}, {y}): {got}");
    }
}

#[test]
fn a_cube_of_twelve_triangles_is_six_patches() {
    let faces = crate::testutil::box_inside(Vec3::ZERO, Vec3::splat(3.0));
    // One mesh of 12 triangles, each its own scene patch.
    let mut m = crate::geometry::TriMesh::default();
    for f in &faces {
        let base = m.positions.len() as u32;
        m.positions.extend(&f.positions);
        for t in &f.indices {
            m.tri_patch.push(m.patches.len() as u32);
            let t = t.map(|i| base + i);
            m.patches.push(Patch::Polygon(t.to_vec()));
            m.indices.push(t);
        }
    }
    let s = scene(vec![(m, Vec3::splat(0.5))], vec![], &[]);
    let mesh = RadiosityMesh::build(&s, 1.0);
    assert_eq!(mesh.patches.len(), 6);
    for p in &mesh.patches {
        assert!((p.area - 9.0).abs() < 1e-3, "{}", p.area);
        assert_eq!(p.element_count, 9);
    }
}

#[test]
fn coplanar_faces_of_different_materials_stay_apart() {
    let v = Vec3::new;
    let a = quad([v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]);
    let b = quad([v(1., 0., 0.), v(2., 0., 0.), v(2., 1., 0.), v(1., 1., 0.)]);
    let s = scene(vec![(a, Vec3::splat(0.5)), (b, Vec3::splat(0.8))], vec![], &[]);
    let m = RadiosityMesh::build(&s, 0.1);
    assert_eq!(m.patches.len(), 2);
    assert_ne!(m.patches[0].reflectance, m.patches[1].reflectance);
}

#[test]
fn a_mirror_keeps_no_radiosity() {
    let v = Vec3::new;
    let mirror = crate::scene::BsdfKind::Conductor {
        specular_reflectance: Vec3::ONE,
        fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
    };
    let floor = quad([v(0., 0., 0.), v(4., 0., 0.), v(4., 4., 0.), v(0., 4., 0.)]);
    let s = crate::testutil::scene_with(vec![(floor, mirror)], vec![], &[]);
    let m = RadiosityMesh::build(&s, 0.1);
    assert_eq!(m.vertices.len(), 4, "one element, whatever the mesh size");
}

#[test]
fn a_black_sky_dome_neither_sets_the_mesh_size_nor_gets_fine_elements() {
    // A 4 x 4 floor and a sphere of radius 50 around it, emitting, black (as Mitsuba
    // makes an emitter without a BSDF).
    let mut dome = crate::geometry::shapes::sphere(Vec3::ZERO, 50.0);
    dome.flip_normals();
    let floor = quad([v(0., 0., 0.), v(4., 0., 0.), v(4., 4., 0.), v(0., 4., 0.)]);
    let s = scene(
        vec![(floor, Rgb::splat(0.5)), (dome, Rgb::ZERO)],
        vec![],
        &[(1, Rgb::ONE)],
    );
    let size = default_mesh_size(&s, &crate::accel::Bvh::build(&s));
    assert!((size - 32f32.sqrt() / 40.0).abs() < 1e-6, "{size}");
    let m = RadiosityMesh::build(&s, size);
    // The dome keeps its 24 patches (its light is shot from them), one element each.
    let first = m.shape_first_patch[1] as usize;
    let dome_patches = &m.patches[first..first + 24];
    assert!(
        dome_patches.iter().all(|p| p.element_count == 1),
        "{:?}",
        dome_patches.iter().map(|p| p.element_count).collect::<Vec<_>>()
    );
    // Without the dome the floor alone sets it; with a reflecting dome, the dome does.
    let mut white = s.clone();
    white.bsdfs[white.shapes[1].bsdf as usize].kind = crate::scene::BsdfKind::Diffuse {
        reflectance: Rgb::splat(0.5),
    };
    assert!(default_mesh_size(&white, &crate::accel::Bvh::build(&white)) > 2.0);
}

#[test]
fn a_planar_lattice_shoots_from_blocks_that_tile_it_and_face_its_front() {
    // A 3 x 2 parallelogram tilted out of every axis plane, facing down-ish, cut into
    // 2 x 30 x 30 triangles: one lattice patch.
    let (o, a, b) = (v(0.5, 0.2, 1.0), v(3.0, 0.0, 0.6), v(0.0, 2.0, -0.3));
    let c = [o, o + b, o + a + b, o + a];
    let front = (c[1] - c[0]).cross(c[3] - c[0]).normalize();
    let s = scene(vec![(split_quad(c, 30), Vec3::splat(0.5))], vec![], &[]);
    let m = RadiosityMesh::build(&s, 0.2);
    assert_eq!(m.patches.len(), 1);
    let Domain::Lattice(l) = &m.patches[0].grids[0].domain else {
        panic!("not a lattice")
    };
    let area = a.cross(b).length();
    for count in [1, 16, 64] {
        let blocks = l.blocks(count).expect("planar");
        assert!(
            !blocks.is_empty() && blocks.len() <= count as usize,
            "{count}: {}",
            blocks.len()
        );
        let mut sum = 0.0;
        for q in &blocks {
            let n = (q[2] - q[0]).cross(q[3] - q[1]);
            assert!(n.normalize().dot(front) > 0.9999, "{count}: a block faces {n}");
            // Every corner on the plane, within the parallelogram's bounding box.
            for p in q {
                assert!((*p - o).dot(front).abs() < 1e-4, "{p} off the plane");
            }
            sum += 0.5 * n.length();
        }
        // The blocks cover the parallelogram (and, cut to its bounding box in the
        // lattice plane, no more than that box).
        assert!(sum >= area * 0.999, "{count}: {sum} < {area}");
        assert!(sum <= area * 1.3, "{count}: {sum} against {area}");
        // The cells carry the surface's power: weight x covered area = area.
        let cells = m.shoot_cells(0, count, |_| Vec2::splat(0.5), &[], None);
        let carried: f32 = cells
            .iter()
            .map(|c| {
                0.5 * (c.corners[2] - c.corners[0])
                    .cross(c.corners[3] - c.corners[1])
                    .length()
                    * c.weight
            })
            .sum();
        assert!((carried - area).abs() < 1e-3 * area, "{carried} against {area}");
    }
    // A bent cluster (a shallow roof of small triangles) has no plane: no blocks.
    let mut roof = split_quad(
        [
            v(0.0, 0.0, 0.0),
            v(0.5, 0.0, 0.05),
            v(0.5, 0.5, 0.05),
            v(0.0, 0.5, 0.0),
        ],
        4,
    );
    let other = split_quad(
        [
            v(0.5, 0.0, 0.05),
            v(1.0, 0.0, 0.0),
            v(1.0, 0.5, 0.0),
            v(0.5, 0.5, 0.05),
        ],
        4,
    );
    let base = roof.positions.len() as u32;
    roof.positions.extend(&other.positions);
    for (t, p) in other.indices.iter().zip(&other.patches) {
        roof.tri_patch.push(roof.patches.len() as u32);
        roof.indices.push(t.map(|i| i + base));
        let Patch::Polygon(ix) = p else { unreachable!() };
        roof.patches
            .push(Patch::Polygon(ix.iter().map(|i| i + base).collect()));
    }
    let s = scene(vec![(roof, Vec3::splat(0.5))], vec![], &[]);
    let m = RadiosityMesh::build(&s, 0.25);
    let bent = m.patches.iter().find_map(|p| match &p.grids[0].domain {
        Domain::Lattice(l) if l.surface.len() > 32 => Some(l),
        _ => None,
    });
    let bent = bent.expect("the roof's halves merge as small polygons");
    assert!(bent.blocks(16).is_none());
}

/// A baseboard on a wall covers the vertices behind it, and they no longer darken
/// the visible wall above it: a field that is one wherever the wall is uncovered
/// (zero behind the baseboard, as the shots leave it) interpolates to one everywhere
/// on the visible wall, where before the row of covered vertices pulled the cell above
/// the baseboard down. A panel half a metre in front of the wall (beyond the reach of
/// half a cell) covers nothing, and the area shares still sum to the wall's area.
/// Both for a wall of many triangles (a lattice patch) and of one quadrilateral (a
/// grid patch).
#[test]
fn a_baseboard_covers_the_vertices_behind_it_and_leaves_the_wall_above_unshaded() {
    let corners = [
        v(0.0, 0.0, 0.0),
        v(4.0, 0.0, 0.0),
        v(4.0, 2.0, 0.0),
        v(0.0, 2.0, 0.0),
    ];
    for (name, wall) in [("lattice", split_quad(corners, 4)), ("grid", quad(corners))] {
        let mut shapes = vec![(wall, Vec3::splat(0.6))];
        // A closed baseboard 0.13 high and 0.03 deep resting on the wall.
        shapes.extend(
            box_inside(v(-0.1, 0.0, 0.0), v(4.1, 0.13, 0.03))
                .into_iter()
                .map(|m| (m, Vec3::splat(0.1))),
        );
        // A panel 0.5 in front of the wall.
        shapes.push((
            quad([
                v(1.0, 1.0, 0.5),
                v(3.0, 1.0, 0.5),
                v(3.0, 1.8, 0.5),
                v(1.0, 1.8, 0.5),
            ]),
            Vec3::splat(0.5),
        ));
        let s = scene(shapes, vec![], &[]);
        let cell = 0.25;
        let bare = RadiosityMesh::build(&s, cell);
        let mesh = RadiosityMesh::build_covered(&s, cell, &Bvh::build(&s));
        let wall = &mesh.patches[0];
        let base = wall.first_vertex;
        let g = &wall.grids[0];
        let covered = match &g.domain {
            Domain::Lattice(l) => l.covered.clone(),
            Domain::Quad(_) => g.covered.clone(),
            _ => panic!("{name}: the wall is neither a lattice nor a quadrilateral grid"),
        };
        let interp = |grid: &Grid, p: Vec3| match &grid.domain {
            Domain::Lattice(l) => l.interp(base, p),
            Domain::Quad(q) => {
                let st = inverse_bilinear(*q, p);
                grid.interp(st.x, st.y)
            }
            _ => unreachable!(),
        };
        let verts = &mesh.vertices[base as usize..(base + wall.vertex_count) as usize];
        for (k, vx) in verts.iter().enumerate() {
            let c = covered.get(k).copied().unwrap_or(false);
            if vx.q.y < 0.1 {
                assert!(
                    c,
                    "{name}: vertex at {} behind the baseboard is not covered",
                    vx.q
                );
            }
            if vx.q.y > 0.3 {
                assert!(!c, "{name}: vertex at {} in the open is covered", vx.q);
            }
        }
        assert!(covered.iter().any(|&c| c), "{name}");
        let sum: f32 = verts.iter().map(|v| v.area).sum();
        assert!((sum - 8.0).abs() < 1e-3, "{name}: area shares sum to {sum}");
        // Each share is the integral of its vertex's weight over the wall (so
        // deposits in proportion to the weights over the shares are unbiased).
        let mut integral = vec![0.0f64; verts.len()];
        let (nx, ny) = (400, 200);
        for j in 0..ny {
            for i in 0..nx {
                let p = v(
                    4.0 * (i as f32 + 0.5) / nx as f32,
                    2.0 * (j as f32 + 0.5) / ny as f32,
                    0.0,
                );
                let w = interp(g, p);
                for k in 0..4 {
                    integral[(w.vertices[k] - base) as usize] +=
                        f64::from(w.weights[k]) * 8.0 / (nx * ny) as f64;
                }
            }
        }
        for (k, vx) in verts.iter().enumerate() {
            let d = (integral[k] - f64::from(vx.area)).abs();
            assert!(
                d < 0.02 * 0.0625,
                "{name}: vertex {k} at {}: share {} against {}",
                vx.q,
                vx.area,
                integral[k]
            );
        }

        // One on the uncovered vertices, zero on the covered ones.
        let field: Vec<Rgb> = (0..mesh.vertices.len())
            .map(|i| {
                let k = i.wrapping_sub(base as usize);
                if k < covered.len() && covered[k] {
                    Vec3::ZERO
                } else {
                    Vec3::ONE
                }
            })
            .collect();
        let mut darkest_before = 1.0f32;
        for i in 0..40 {
            for y in [0.14, 0.2, 0.26, 0.32] {
                let p = v(0.05 + 0.1 * i as f32, y, 0.0);
                let now = interp(g, p).apply(&field).x;
                assert!((now - 1.0).abs() < 1e-5, "{name}: {now} at {p}");
                darkest_before = darkest_before.min(interp(&bare.patches[0].grids[0], p).apply(&field).x);
            }
        }
        // The rule matters: without it the band above the baseboard was darker.
        assert!(darkest_before < 0.9, "{name}: {darkest_before}");
    }
}

/// A panel a centimetre in front of a wall, facing away from it (a window or a light
/// fitting: one-sided), covers the wall vertices behind it up to its edge: a vertex
/// 1.7 cm inside the edge sees out only through the gap at grazing angles, and was
/// left uncovered when every ray had to be shut (its near-zero light then darkened the
/// visible wall an element wide beside the panel: the paper room's window and ceiling
/// light). Vertices beside the panel, and in the wall's corners with the floor and
/// the side walls, stay uncovered.
#[test]
fn a_panel_a_centimetre_off_a_wall_covers_the_vertices_behind_it_to_its_edge() {
    let cell = 0.25;
    let (x0, x1, y0, y1) = (1.233, 2.767, 0.733, 1.267);
    let mut shapes: Vec<(TriMesh, Rgb)> = box_inside(v(0.0, 0.0, 0.0), v(4.0, 2.0, 3.0))
        .into_iter()
        .map(|m| (m, Vec3::splat(0.6)))
        .collect();
    let wall = shapes
        .iter()
        .position(|(m, _)| (0..3).all(|k| m.triangle(0)[k].z == 0.0))
        .expect("the box has a wall at z = 0");
    shapes.push((
        quad([v(x0, y0, 0.01), v(x1, y0, 0.01), v(x1, y1, 0.01), v(x0, y1, 0.01)]),
        Vec3::splat(0.5),
    ));
    let s = scene(shapes, vec![], &[]);
    let mesh = RadiosityMesh::build_covered(&s, cell, &Bvh::build(&s));
    let patch = &mesh.patches[wall];
    let g = &patch.grids[0];
    let covered = match &g.domain {
        Domain::Lattice(l) => l.covered.clone(),
        _ => g.covered.clone(),
    };
    let verts =
        &mesh.vertices[patch.first_vertex as usize..(patch.first_vertex + patch.vertex_count) as usize];
    let mut behind = 0;
    for (k, vx) in verts.iter().enumerate() {
        let c = covered.get(k).copied().unwrap_or(false);
        let inside = vx.q.x > x0 + 0.015 && vx.q.x < x1 - 0.015 && vx.q.y > y0 + 0.015 && vx.q.y < y1 - 0.015;
        let outside = vx.q.x < x0 || vx.q.x > x1 || vx.q.y < y0 || vx.q.y > y1;
        if inside {
            behind += 1;
            assert!(c, "vertex at {} behind the panel is not covered", vx.q);
        }
        if outside {
            assert!(!c, "vertex at {} beside the panel is covered", vx.q);
        }
    }
    // Three rows of seven vertices, the outer ones 1.7 cm inside the edges.
    assert_eq!(behind, 21);
}

/// A vertical blind: 40 curved slats 2 cm apart along x, each an arc of four facets
/// (normals within 40 degrees of +x), 1 m tall in ten rows. Projected along x, the
/// slats lie on top of one another: one lattice for all of them would light the
/// slats at one end with vertices placed on the slats at the other.
fn blind() -> TriMesh {
    let mut m = TriMesh::default();
    for k in 0..40 {
        let x0 = 0.02 * k as f32;
        // Arc points in the xz plane: angle from -40 to 40 degrees about +x.
        let arc: Vec<Vec3> = (0..5)
            .map(|i| {
                let a = (-40.0f32 + 20.0 * i as f32).to_radians();
                // Facing +x: the arc bulges towards +x.
                v(x0 + 0.03 * a.cos(), 0.0, 0.03 * a.sin())
            })
            .collect();
        for row in 0..10 {
            let (y0, y1) = (0.1 * row as f32, 0.1 * (row + 1) as f32);
            for i in 0..4 {
                let (a, b) = (arc[i], arc[i + 1]);
                let base = m.positions.len() as u32;
                // Wound to face +x (out of the arc).
                m.positions
                    .extend([v(a.x, y0, a.z), v(a.x, y1, a.z), v(b.x, y1, b.z), v(b.x, y0, b.z)]);
                let patch = m.patches.len() as u32;
                m.patches.push(Patch::Polygon((base..base + 4).collect()));
                m.indices.push([base, base + 1, base + 2]);
                m.indices.push([base, base + 2, base + 3]);
                m.tri_patch.extend([patch, patch]);
            }
        }
    }
    m
}

#[test]
fn slats_lying_on_one_another_along_the_lattice_axis_do_not_share_vertices_across_the_blind() {
    let mesh_size = 0.25;
    let s = scene(vec![(blind(), Vec3::splat(0.6))], vec![], &[]);
    let m = RadiosityMesh::build(&s, mesh_size);
    let mut checked = 0;
    for p in &m.patches {
        for g in &p.grids {
            let Domain::Lattice(lat) = &g.domain else { continue };
            for t in &lat.surface {
                let c = (t[0] + t[1] + t[2]) / 3.0;
                let w = lat.interp(g.first_vertex, c);
                for k in 0..4 {
                    if w.weights[k] == 0.0 {
                        continue;
                    }
                    let q = m.vertices[w.vertices[k] as usize].p;
                    // A point takes its light from vertices within its own cell
                    // (a mesh size in the plane) and within one slab of a quarter mesh
                    // size along the axis (plus the slats' own depth).
                    assert!(
                        (q.x - c.x).abs() < 0.25 * mesh_size + 0.08,
                        "a point at x = {} takes the light of a vertex at x = {}",
                        c.x,
                        q.x
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 1000, "{checked}");
    // Vertices still follow the area, not the 1600 facets: 1.7 m^2 of slats is
    // about 27 elements of the mesh size (130 vertices, their corners).
    assert!(m.vertices.len() < 300, "{}", m.vertices.len());
}

/// A texture atlas: one shape of two separate quads (two patches), the first mapped on
/// the texture's left half (dark), the second on its right (light). Each patch takes
/// the texture's mean over its own (u, v), not the whole texture's mean, which the
/// material's own albedo holds; an untextured shape keeps its albedo.
#[test]
fn a_textured_patch_takes_its_texture_mean_over_its_own_uv() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{TexField, Texture};
    let (dark, light) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.9, 0.7, 0.5));
    let mut atlas = quad([v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]);
    let far = quad([v(3., 0., 2.), v(4., 0., 2.), v(4., 1., 2.), v(3., 1., 2.)]);
    atlas.positions.extend(&far.positions);
    atlas.indices.extend(far.indices.iter().map(|t| t.map(|i| i + 4)));
    atlas.tri_patch = vec![0, 0, 1, 1];
    atlas.patches.push(Patch::Polygon(vec![4, 5, 6, 7]));
    // Left half (u in [0.05, 0.45]) for the first quad, right half for the second.
    let (a, b) = (0.05f32, 0.45f32);
    atlas.uvs = vec![
        Vec2::new(a, 0.1),
        Vec2::new(b, 0.1),
        Vec2::new(b, 0.9),
        Vec2::new(a, 0.9),
        Vec2::new(1.0 - b, 0.1),
        Vec2::new(1.0 - a, 0.1),
        Vec2::new(1.0 - a, 0.9),
        Vec2::new(1.0 - b, 0.9),
    ];
    let plain = quad([v(0., 3., 0.), v(1., 3., 0.), v(1., 4., 0.), v(0., 4., 0.)]);
    let mut s = scene(
        vec![(atlas, (dark + light) * 0.5), (plain, Vec3::splat(0.4))],
        vec![],
        &[],
    );
    let mut t = Texture::from_linear("atlas", 2, 1, vec![dark.to_array(), light.to_array()]).unwrap();
    t.filter = TexFilter::Nearest;
    let b = s.shapes[0].bsdf as usize;
    crate::testutil::texture_on(&mut s, b, TexField::Diffuse, t);
    let m = RadiosityMesh::build(&s, 0.3);
    let of = |shape: usize| -> Vec<Rgb> {
        m.patches
            .iter()
            .filter(|p| p.shape as usize == shape)
            .map(|p| p.reflectance)
            .collect()
    };
    let atlas_patches = of(0);
    assert_eq!(atlas_patches.len(), 2, "{atlas_patches:?}");
    assert!(
        atlas_patches
            .iter()
            .any(|r| (*r - dark).abs().max_element() < 1e-6),
        "{atlas_patches:?}"
    );
    assert!(
        atlas_patches
            .iter()
            .any(|r| (*r - light).abs().max_element() < 1e-6),
        "{atlas_patches:?}"
    );
    assert_eq!(of(1), vec![Vec3::splat(0.4)]);
}

/// A floor 40 x 20 m, too large for one patch (cut into pieces), of a two-sided
/// material whose texture is dark on its left half (x < 20) and light on its right:
/// every vertex more than an element from the seam takes its half's texel exactly
/// (the texture's mean about it, not its patch's), the seam's lie between, and each
/// back twin's vertex takes its front's.
#[test]
fn each_vertex_takes_its_textures_mean_about_it() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{TexField, Texture};
    let (dark, light) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.9, 0.7, 0.5));
    let mut floor = quad([v(0., 0., 0.), v(40., 0., 0.), v(40., 20., 0.), v(0., 20., 0.)]);
    floor.uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
    ];
    let mut s = scene(vec![(floor, (dark + light) * 0.5)], vec![], &[]);
    let mut t = Texture::from_linear("halves", 2, 1, vec![dark.to_array(), light.to_array()]).unwrap();
    t.filter = TexFilter::Nearest;
    s.bsdfs[0].twosided = true;
    crate::testutil::texture_on(&mut s, 0, TexField::Diffuse, t);
    let size = 0.25;
    let m = RadiosityMesh::build_covered(&s, size, &Bvh::build(&s));
    assert!(!m.splits.is_empty(), "the floor is cut");
    assert_eq!(m.albedo.len(), m.vertices.len());
    let (mut left, mut right, mut seam) = (0, 0, 0);
    for (i, vx) in m.vertices.iter().enumerate() {
        let a = m.albedo(i as u32);
        let off = vx.p.x - 20.0;
        if off < -size * 1.01 {
            assert!((a - dark).abs().max_element() < 1e-5, "{} {a}", vx.p);
            left += 1;
        } else if off > size * 1.01 {
            assert!((a - light).abs().max_element() < 1e-5, "{} {a}", vx.p);
            right += 1;
        } else {
            assert!(
                a.cmpge(dark - 1e-5).all() && a.cmple(light + 1e-5).all(),
                "{} {a}",
                vx.p
            );
            seam += 1;
        }
    }
    assert!(left > 1000 && right > 1000 && seam > 0, "{left} {right} {seam}");
    // Twins: the same albedo at the same place.
    let mut twins = 0;
    for front in &m.patches[..m.front_patches as usize] {
        let twin = &m.patches[front.twin.expect("two-sided") as usize];
        for k in 0..front.vertex_count {
            let (f, b) = (front.first_vertex + k, twin.first_vertex + k);
            assert_eq!(m.vertices[f as usize].p, m.vertices[b as usize].p);
            assert_eq!(m.albedo(f), m.albedo(b));
            twins += 1;
        }
    }
    assert_eq!(twins * 2, m.vertices.len());
}

/// A `mask` leaving 3/4 of a quad (an untextured quad reads its barycentrics as
/// (u, v): u < 0.5, the open texel, on 3/4 of each triangle): the patch keeps its
/// albedo, and sends light from 3/4 of its area (its vertices' areas and its shooting
/// cells' weights), so a masked leaf does not reflect as a whole one.
#[test]
fn a_masked_patch_sends_light_from_the_part_that_is_there() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{TexField, Texture};
    let leaf = quad([v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]);
    let rho = Vec3::new(0.2, 0.6, 0.3);
    let mut s = scene(vec![(leaf, rho)], vec![], &[]);
    let mut t = Texture::from_linear("mask", 2, 1, vec![[1.0; 3], [0.0; 3]]).unwrap();
    t.filter = TexFilter::Nearest;
    crate::testutil::texture_on(&mut s, 0, TexField::Opacity, t);
    let m = RadiosityMesh::build(&s, 0.25);
    let p = &m.patches[0];
    assert!(
        (p.reflectance - rho).abs().max_element() < 1e-6,
        "{}",
        p.reflectance
    );
    assert!((p.opacity - 0.75).abs() < 1e-6, "{}", p.opacity);
    let areas: f32 = m.vertices.iter().filter(|x| x.patch == 0).map(|x| x.area).sum();
    assert!((areas - 0.75 * p.area).abs() < 1e-4, "{areas} of {}", p.area);
    let cells = m.shoot_cells(0, 16, |_| Vec2::splat(0.5), &[], None);
    assert!(!cells.is_empty() && cells.iter().all(|c| (c.weight - 0.75).abs() < 1e-6));
}

/// The same masked quad with a closed box resting on a quarter of it: the vertices
/// under the box are covered and the shares are recomputed without them, still
/// times the mask's open share (cover's recompute once dropped it: the areas summed
/// to the whole quad's).
#[test]
fn a_masked_patch_with_covered_vertices_keeps_its_open_share() {
    use crate::scene::texture::TexFilter;
    use crate::scene::{TexField, Texture};
    let leaf = quad([v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]);
    let mut shapes = vec![(leaf, Vec3::splat(0.5))];
    for f in crate::testutil::box_outside(v(0.0, 0.0, 0.0), v(0.5, 0.5, 0.3)) {
        shapes.push((f, Vec3::splat(0.5)));
    }
    let mut s = scene(shapes, vec![], &[]);
    let mut t = Texture::from_linear("mask", 2, 1, vec![[1.0; 3], [0.0; 3]]).unwrap();
    t.filter = TexFilter::Nearest;
    crate::testutil::texture_on(&mut s, 0, TexField::Opacity, t);
    let m = RadiosityMesh::build_covered(&s, 0.125, &Bvh::build(&s));
    let p = &m.patches[0];
    assert!((p.opacity - 0.75).abs() < 1e-6, "{}", p.opacity);
    let covered = p.grids.iter().any(|g| match &g.domain {
        Domain::Lattice(l) => l.covered.iter().any(|&c| c),
        _ => g.covered.iter().any(|&c| c),
    });
    assert!(covered, "the box covers some of the quad's vertices");
    let areas: f32 = m.vertices.iter().filter(|x| x.patch == 0).map(|x| x.area).sum();
    assert!((areas - 0.75 * p.area).abs() < 1e-4, "{areas} of {}", p.area);
}

#[test]
fn a_small_patch_holding_an_object_is_meshed_at_half_the_mesh_size() {
    // A 1.2 x 0.8 table top at a mesh size of 0.2: 6 x 4 elements, 35 vertices.
    let corners = [
        v(-0.6, -0.4, 0.0),
        v(0.6, -0.4, 0.0),
        v(0.6, 0.4, 0.0),
        v(-0.6, 0.4, 0.0),
    ];
    let grey = Vec3::splat(0.5);
    let table_with = |table: TriMesh, object: Option<(Vec3, Vec3)>| {
        let mut shapes = vec![(table, grey)];
        if let Some((lo, hi)) = object {
            shapes.extend(
                crate::testutil::box_outside(lo, hi)
                    .into_iter()
                    .map(|m| (m, grey)),
            );
        }
        let s = scene(shapes, vec![], &[]);
        let mesh = RadiosityMesh::build_covered(&s, 0.2, &Bvh::build(&s));
        (
            mesh.patches[0].element_count,
            mesh.patches[0].vertex_count,
            mesh.refined,
        )
    };
    let teapot = Some((v(-0.15, -0.15, 0.0), v(0.15, 0.15, 0.3)));
    // A box a quarter of the table wide resting on it (9 % of its area): half size.
    assert_eq!(table_with(quad(corners), teapot), (96, 117, 1));
    // Merged from many triangles (a lattice) alike: four times the cells.
    let (bare, _, _) = table_with(split_quad(corners, 4), None);
    let (fine, _, refined) = table_with(split_quad(corners, 4), teapot);
    assert_eq!((fine, refined), (4 * bare, 1), "lattice: {bare} -> {fine} cells");
    // Nothing on it, or the box higher than a mesh size above it: unchanged.
    assert_eq!(table_with(quad(corners), None), (24, 35, 0));
    assert_eq!(
        table_with(quad(corners), Some((v(-0.15, -0.15, 0.25), v(0.15, 0.15, 0.5)))),
        (24, 35, 0)
    );
    // A crumb (a 4 cm cube, 0.2 % of the area): unchanged.
    assert_eq!(
        table_with(quad(corners), Some((v(0.0, 0.0, 0.0), v(0.04, 0.04, 0.04)))),
        (24, 35, 0)
    );
    // Covered wholly (a lid lying on it, a hidden face): unchanged.
    assert_eq!(
        table_with(quad(corners), Some((v(-0.7, -0.5, 0.0), v(0.7, 0.5, 0.1)))),
        (24, 35, 0)
    );
    // A floor 4 x 4 (400 elements) under the same box: its elements are small beside
    // it already.
    let floor = quad([
        v(-2.0, -2.0, 0.0),
        v(2.0, -2.0, 0.0),
        v(2.0, 2.0, 0.0),
        v(-2.0, 2.0, 0.0),
    ]);
    assert_eq!(table_with(floor, teapot), (400, 441, 0));
}

/// A room of 4 x 3 x 4 m (walls, ceiling, a point light) standing on a ground plane
/// 200 m across: the default element size follows the room the light lights, not
/// the ground plane's bounds (diagonal 283 m: 7 m elements), and the ground plane is
/// cut into patches of at most 32 elements a side, coarser far from the room.
fn room_on_a_ground_plane() -> Scene {
    let mut shapes: Vec<(TriMesh, Rgb)> = box_inside(v(-2., 0., -2.), v(2., 4., 1.))
        .into_iter()
        .skip(1)
        .map(|m| (m, Rgb::splat(0.6)))
        .collect();
    // The ground plane at z = -2 (the room's floor is part of it), facing up.
    let ground = quad([
        v(-100., -100., -2.),
        v(100., -100., -2.),
        v(100., 100., -2.),
        v(-100., 100., -2.),
    ]);
    shapes.insert(0, (ground, Rgb::splat(0.5)));
    let light = crate::scene::Light::Point {
        position: v(0., 2., 0.),
        intensity: Rgb::splat(10.0),
    };
    scene(shapes, vec![light], &[])
}

#[test]
fn the_default_element_size_follows_the_lit_room_not_a_ground_plane_around_it() {
    let s = room_on_a_ground_plane();
    let size = default_mesh_size(&s, &Bvh::build(&s));
    // The room's diagonal is sqrt(4^2 + 4^2 + 3^2) = 6.40 m: 0.16 m elements, where
    // the whole scene's bounds give 283 / 40 = 7.1 m. (The lit region is the 5th to
    // 95th percentile of the light's hits, a little inside the room.)
    assert!(size > 0.10 && size <= 6.41 / 40.0, "{size}");
    // With a floor of the room's size instead, its bounds give the same size.
    let mut alone = s.clone();
    alone.shapes[0].mesh = quad([v(-2., 0., -2.), v(2., 0., -2.), v(2., 4., -2.), v(-2., 4., -2.)]);
    let alone_size = default_mesh_size(&alone, &Bvh::build(&alone));
    assert!(
        (alone_size - (4f32 * 4. + 4. * 4. + 3. * 3.).sqrt() / 40.0).abs() < 1e-4,
        "{alone_size}"
    );
}

/// A glass bulb round the lamp (a closed box of `dielectric`, 10 cm a side) leaves
/// the default element size as it was: the light rays that find the lit region go
/// on through glass (they stopped at the bulb, and the elements came out a hundredth
/// of the scene's diagonal wide).
#[test]
fn a_glass_bulb_round_the_lamp_leaves_the_element_size_as_it_was() {
    let bare = room_on_a_ground_plane();
    let size = default_mesh_size(&bare, &Bvh::build(&bare));
    let mut bulb = bare.clone();
    let glass = bulb.bsdfs.len() as u32;
    bulb.bsdfs.push(crate::scene::Bsdf {
        name: "glass".into(),
        kind: crate::scene::BsdfKind::clear_glass(1.5, false),
        twosided: true,
        textures: Vec::new(),
    });
    for f in crate::testutil::box_outside(v(-0.05, 1.95, -0.05), v(0.05, 2.05, 0.05)) {
        let mut shape = bulb.shapes[0].clone();
        shape.mesh = f;
        shape.bsdf = glass;
        shape.emitter = None;
        bulb.shapes.push(shape);
    }
    let with = default_mesh_size(&bulb, &Bvh::build(&bulb));
    assert!(
        (with - size).abs() < 0.05 * size,
        "{with} with the bulb, {size} without"
    );
}

#[test]
fn a_surface_too_large_for_one_patch_is_cut_into_patches_found_by_position() {
    let s = room_on_a_ground_plane();
    let bvh = Bvh::build(&s);
    let size = default_mesh_size(&s, &bvh);
    let m = RadiosityMesh::build(&s, size);
    let first = m.shape_first_patch[0] as usize;
    let last = m.shape_first_patch[1] as usize;
    let cut = m.splits.get(&(first as u32)).expect("the ground plane is cut");
    assert_eq!(last - first, cut.piece.iter().filter(|&&p| p != u32::MAX).count());
    // The pieces tile the plane: their areas sum to 200 x 200 m.
    let area: f32 = m.patches[first..last].iter().map(|p| p.area).sum();
    assert!((area - 40_000.0).abs() < 1.0, "{area}");
    // No piece has more than 32 elements a side (at most 32 x 32 elements), and the
    // pieces under the room keep the mesh size while those far off are coarser.
    let max_elements = m.patches[first..last]
        .iter()
        .map(|p| p.element_count)
        .max()
        .unwrap();
    assert!(
        max_elements <= (SPLIT_SIDE + 1) * (SPLIT_SIDE + 1),
        "{max_elements}"
    );
    let elements: u32 = m.patches[first..last].iter().map(|p| p.element_count).sum();
    assert!(
        (elements as f32) < 0.05 * 40_000.0 / (size * size),
        "{elements} elements where a uniform mesh has {}",
        40_000.0 / (size * size)
    );
    // A ray down onto the floor inside the room, and one far out, each find the piece
    // whose vertices lie about the hit point.
    for (x, y) in [(0.5, -0.3), (-1.7, 1.8), (60.0, -75.0)] {
        let hit = bvh.intersect(&Ray::new(v(x, y, 0.5), v(0., 0., -1.))).unwrap();
        assert_eq!(hit.shape, 0);
        let p = m.patch_of(&s, &hit) as usize;
        assert!((first..last).contains(&p));
        let patch = &m.patches[p];
        let verts =
            &m.vertices[patch.first_vertex as usize..(patch.first_vertex + patch.vertex_count) as usize];
        let (lo, hi) = verts
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q.p), hi.max(q.p))
            });
        let at = v(x, y, -2.);
        assert!(
            at.cmpge(lo - Vec3::splat(1e-3)).all() && at.cmple(hi + Vec3::splat(1e-3)).all(),
            "({x}, {y}) outside its piece {lo} .. {hi}"
        );
        // Inside the room the piece keeps the mesh size (a cap on the whole plane's
        // divisions once made it 200 / 256 = 0.78 m: blotchy, and its room 7 % dark).
        if x.abs() < 2.0 {
            let Domain::Lattice(l) = &patch.grids[0].domain else {
                panic!("a cut piece is meshed by a lattice")
            };
            assert!(
                (l.cell - size).abs() < 1e-6,
                "cell {} at ({x}, {y}), mesh size {size}",
                l.cell
            );
        }
        // Interpolation there uses that piece's vertices only.
        let w = m.locate(&s, &hit, at, true);
        for (k, &vtx) in w.vertices.iter().enumerate() {
            if w.weights[k] > 0.0 {
                assert_eq!(m.vertices[vtx as usize].patch as usize, p);
            }
        }
    }
}

/// Sixteenth `m` of quarter `k` of a square (its quarter's quarter) is the
/// sixteenth `sixteenth_of(k, m)` names (i + 4 j by its local coordinates).
#[test]
fn a_quarter_of_a_quarter_is_the_sixteenth_sixteenth_of_names() {
    use crate::mesh::{quarter, quarter_of_sixteenth, sixteenth_of};
    let square = [
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 2.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    ];
    let of_sixteenth = |p: Vec3| ((p.x * 2.0) as usize).min(3) + 4 * ((p.y * 2.0) as usize).min(3);
    let mut seen = [false; 16];
    for k in 0..4 {
        let (c, _) = quarter(&square, k);
        for m in 0..4 {
            let (cc, _) = quarter(&c[..4], m);
            let centre = cc.iter().sum::<Vec3>() / 4.0;
            assert_eq!(
                of_sixteenth(centre),
                sixteenth_of(k, m),
                "quarter {k}, its quarter {m}"
            );
            seen[sixteenth_of(k, m)] = true;
            assert_eq!(quarter_of_sixteenth(sixteenth_of(k, m)), (k, m));
        }
    }
    assert!(seen.iter().all(|&s| s), "every sixteenth once: {seen:?}");
}
