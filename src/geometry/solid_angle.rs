//! Solid angles of triangles and of sets of them.

use glam::Vec3;

/// Solid angle of triangle `t` seen from `x` (Van Oosterom & Strackee 1983).
pub fn triangle_solid_angle(x: Vec3, t: &[Vec3; 3]) -> f32 {
    let (a, b, c) = (t[0] - x, t[1] - x, t[2] - x);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// Solid angle under which `x` sees the fronts of `tris` (counter-clockwise seen from
/// their fronts), triangle by triangle.
pub fn front_solid_angle(x: Vec3, tris: &[[Vec3; 3]]) -> f32 {
    tris.iter()
        .filter(|t| area_vector(t).dot(x - t[0]) > 0.0)
        .map(|t| triangle_solid_angle(x, t))
        .sum()
}

/// A point at least this many bounding radii from a group's centre sees it in the far
/// field: area x cosine / distance^2, within about 2 % of the exact solid angle
/// (a disc on its axis at 6 radii: 0.0873 against 0.0855 sr).
const FAR: f32 = 6.0;

/// Triangles in the group of a leaf, at most.
const LEAF: usize = 8;

/// A set of triangles whose front faces' solid angle is asked from many points (a
/// light or a radiant patch seen from every vertex that lists it). The triangles are
/// grouped into spatially compact leaves; a leaf far from the point counts by its area
/// vectors (no trigonometry), a near one triangle by triangle, exactly.
#[derive(Debug, Clone, Default)]
pub struct Subtense {
    tris: Vec<[Vec3; 3]>,
    leaves: Vec<Leaf>,
}

#[derive(Debug, Clone, Copy)]
struct Leaf {
    centre: Vec3,
    radius_sq: f32,
    /// Sum of the triangles' area vectors (area x unit normal).
    area: Vec3,
    /// Every triangle faces the way of `area` (within about 8 degrees): the leaf's
    /// front is seen as a whole or not at all from far away.
    flat: bool,
    range: (u32, u32),
}

impl Subtense {
    /// Groups `tris` (counter-clockwise seen from their fronts).
    pub fn new(mut tris: Vec<[Vec3; 3]>) -> Self {
        let mut leaves = Vec::new();
        let n = tris.len();
        split(&mut tris, 0, n, &mut leaves);
        Subtense { tris, leaves }
    }

    /// Solid angle under which `x` sees the fronts of the triangles.
    pub fn from(&self, x: Vec3) -> f32 {
        let mut w = 0.0;
        for l in &self.leaves {
            let tris = &self.tris[l.range.0 as usize..l.range.1 as usize];
            let d = x - l.centre;
            let d2 = d.length_squared();
            if d2 >= FAR * FAR * l.radius_sq {
                if l.flat {
                    w += far_field(d, l.area);
                } else {
                    w += tris
                        .iter()
                        .map(|t| far_field(x - centroid(t), area_vector(t)))
                        .sum::<f32>();
                }
            } else {
                w += front_solid_angle(x, tris);
            }
        }
        w
    }
}

/// Solid angle of a small area `a` (area x unit normal) at offset `d` from the point.
fn far_field(d: Vec3, a: Vec3) -> f32 {
    let d2 = d.length_squared();
    d.dot(a).max(0.0) / (d2 * d2.sqrt())
}

fn area_vector(t: &[Vec3; 3]) -> Vec3 {
    0.5 * (t[1] - t[0]).cross(t[2] - t[0])
}

fn centroid(t: &[Vec3; 3]) -> Vec3 {
    (t[0] + t[1] + t[2]) / 3.0
}

/// Splits `tris[lo..hi]` at the median of the centroids along the widest axis until
/// a group holds at most [`LEAF`] triangles.
fn split(tris: &mut [[Vec3; 3]], lo: usize, hi: usize, leaves: &mut Vec<Leaf>) {
    if hi <= lo {
        return;
    }
    let group = &mut tris[lo..hi];
    if group.len() > LEAF {
        let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in group.iter() {
            let c = centroid(t);
            min = min.min(c);
            max = max.max(c);
        }
        let axis = (max - min).max_position();
        let mid = group.len() / 2;
        group.select_nth_unstable_by(mid, |a, b| centroid(a)[axis].total_cmp(&centroid(b)[axis]));
        split(tris, lo, lo + mid, leaves);
        split(tris, lo + mid, hi, leaves);
        return;
    }
    // The far field is expanded about the area centroid: its first-order error vanishes.
    let (mut area, mut moment, mut total) = (Vec3::ZERO, Vec3::ZERO, 0.0);
    for t in group.iter() {
        let a = area_vector(t);
        area += a;
        moment += a.length() * centroid(t);
        total += a.length();
    }
    let centre = if total > 0.0 {
        moment / total
    } else {
        centroid(&group[0])
    };
    let radius_sq = group
        .iter()
        .flatten()
        .map(|p| (*p - centre).length_squared())
        .fold(0.0, f32::max);
    let along = area.normalize_or_zero();
    let flat = group.iter().all(|t| {
        let a = area_vector(t);
        a.dot(along) >= 0.99 * a.length()
    });
    leaves.push(Leaf {
        centre,
        radius_sq,
        area,
        flat,
        range: (lo as u32, hi as u32),
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w` x `h` rectangle in the plane z = 0, facing +z, split into n x n squares.
    fn plane(w: f32, h: f32, n: usize) -> Vec<[Vec3; 3]> {
        let p = |i: usize, j: usize| Vec3::new(w * i as f32 / n as f32, h * j as f32 / n as f32, 0.0);
        (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                [
                    [p(i, j), p(i + 1, j), p(i + 1, j + 1)],
                    [p(i, j), p(i + 1, j + 1), p(i, j + 1)],
                ]
            })
            .collect()
    }

    #[test]
    fn a_split_square_subtends_its_closed_form() {
        // A unit square seen from above its corner at height h: the solid angle of a
        // rectangle a x b from above a corner is atan(ab / (h sqrt(a^2+b^2+h^2))).
        let s = Subtense::new(plane(1.0, 1.0, 40));
        for h in [0.05f32, 0.3, 1.0, 4.0, 20.0] {
            let want = (1.0 / (h * (2.0 + h * h).sqrt())).atan();
            let got = s.from(Vec3::new(0.0, 0.0, h));
            assert!((got - want).abs() <= 0.02 * want, "h {h}: {got} against {want}");
        }
        // From behind, nothing.
        assert_eq!(s.from(Vec3::new(0.5, 0.5, -1.0)), 0.0);
    }

    #[test]
    fn grouped_solid_angles_stay_within_two_percent_of_the_sum_over_triangles() {
        // A box's six faces (not flat as a whole) and a long strip, seen from points
        // near, far and grazing.
        let mut tris = Vec::new();
        for (o, a, b) in [
            (Vec3::ZERO, Vec3::Y, Vec3::X),
            (Vec3::Z, Vec3::X, Vec3::Y),
            (Vec3::ZERO, Vec3::X, Vec3::Z),
            (Vec3::Y, Vec3::Z, Vec3::X),
            (Vec3::ZERO, Vec3::Z, Vec3::Y),
            (Vec3::X, Vec3::Y, Vec3::Z),
        ] {
            let n = 6;
            let p = |i: usize, j: usize| o + a * (i as f32 / n as f32) + b * (j as f32 / n as f32);
            for j in 0..n {
                for i in 0..n {
                    tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                    tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
                }
            }
        }
        tris.extend(
            plane(30.0, 0.5, 60)
                .iter()
                .map(|t| t.map(|p| p + Vec3::new(-10.0, 3.0, -1.0))),
        );
        let s = Subtense::new(tris.clone());
        for x in [
            Vec3::new(0.5, 0.5, 1.5),
            Vec3::new(3.0, 2.0, 4.0),
            Vec3::new(-2.0, 0.3, 0.2),
            Vec3::new(40.0, 30.0, -20.0),
            Vec3::new(2.0, 3.25, 0.01),
            Vec3::new(-9.0, 3.2, 2.0),
        ] {
            let want = front_solid_angle(x, &tris);
            let got = s.from(x);
            assert!(
                want > 0.0 && (got - want).abs() <= 0.02 * want,
                "{x}: {got} against {want}"
            );
        }
    }
}
