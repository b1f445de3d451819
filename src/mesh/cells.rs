//! The cells a patch shoots from: the patch cut into about as many cells as a shot
//! asks for, each with its corner polygon, a jittered point in it and the mean of the
//! unshot radiosity over it.

use glam::{Vec2, Vec3};

use super::{Domain, RadiosityMesh};
use crate::scene::Rgb;

impl RadiosityMesh {
    /// The patch cut into about `count` cells for shooting from it (stratified:
    /// cells of a regular grid over each of the patch's grids, in proportion to
    /// area), each with a point jittered inside it by `u` (`u(g << 16 | k)` for cell
    /// `k` of grid `g`) and the mean of `field` (per vertex; may be empty) over it.
    pub fn shoot_cells(
        &self,
        patch: u32,
        count: u32,
        u: impl Fn(u32) -> Vec2,
        field: &[Rgb],
    ) -> Vec<ShootCell> {
        let p = &self.patches[patch as usize];
        let total = p.area;
        let mut out = Vec::with_capacity(count as usize);
        if !(total > 0.0) {
            return out;
        }
        for (g, grid) in p.grids.iter().enumerate() {
            if let Domain::Lattice(l) = &grid.domain {
                // The surface of a back twin is wound for the back already.
                let base = grid.first_vertex;
                let value = |q: Vec3| {
                    if field.is_empty() {
                        Vec3::ZERO
                    } else {
                        l.interp(base, q).apply(field)
                    }
                };
                if let Some(blocks) = l.blocks(count) {
                    out.extend(block_cells(&blocks, p.area, &u, self.mesh_size, value));
                } else {
                    out.extend(surface_cells(&l.surface, count, &u, self.mesh_size, value));
                }
                continue;
            }
            let k = (count as f32 * grid.area / total).max(1.0);
            let side = (k.sqrt().round() as u32).max(1);
            let base = (g as u32) << 16;
            // Points of the field's mean: about two per element along each side.
            let q = (2 * grid.n.max(grid.m)).div_ceil(side).clamp(1, 16);
            let mut push = |corners: &[(f32, f32)], idx: u32| {
                let tri = corners.len() == 3;
                // Local coordinates in the cell (barycentrics of corners 1 and 2 of a
                // triangle; [0, 1]^2 over a parallelogram) to the grid's parameters.
                let at = |a: f32, b: f32| {
                    let c = corners;
                    if tri {
                        (
                            c[0].0 + (c[1].0 - c[0].0) * a + (c[2].0 - c[0].0) * b,
                            c[0].1 + (c[1].1 - c[0].1) * a + (c[2].1 - c[0].1) * b,
                        )
                    } else {
                        (c[0].0 + (c[1].0 - c[0].0) * a, c[0].1 + (c[3].1 - c[0].1) * b)
                    }
                };
                // Uniform point in the cell.
                let r = u(base + idx);
                let (s, t) = if tri {
                    let q = r.x.sqrt();
                    at(q * (1.0 - r.y), q * r.y)
                } else {
                    at(r.x, r.y)
                };
                let (pos, n) = grid.eval(s, t);
                let mut poly = [Vec3::ZERO; 4];
                for (c, &(cs, ct)) in corners.iter().enumerate() {
                    poly[c] = grid.eval(cs, ct).0;
                }
                let (value, quarters, sixteenths) = if field.is_empty() {
                    (Vec3::ZERO, [Vec3::ZERO; 4], None)
                } else {
                    cell_mean(q, tri, |a, b| {
                        let (s, t) = at(a, b);
                        grid.interp(s, t).apply(field)
                    })
                };
                // A curved cell's corner polygon has straight edges where the cell's
                // are curved (a disk's rim: a quarter disk's cells of two segments
                // lose 10% of its light). What a cell sends a point at a distance
                // follows the vector area of its boundary (half the loop integral of
                // x dx; the surface inside does not matter): its light is scaled by
                // the true boundary's vector area (8 points an edge, on the surface)
                // over the polygon's. On a sphere the two nearly agree; the cell's
                // larger area would overcount it.
                let curved = matches!(grid.domain, Domain::Curved { .. });
                let weight = if curved && !tri {
                    const K: usize = 8;
                    let mut loop_pts = Vec::with_capacity(4 * K);
                    for e in 0..4 {
                        let (a, b) = (corners[e], corners[(e + 1) % 4]);
                        for k in 0..K {
                            let f = k as f32 / K as f32;
                            loop_pts.push(grid.eval(a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f).0);
                        }
                    }
                    let chord = vector_area(&poly);
                    let edge = vector_area(&loop_pts);
                    if chord > 0.0 && edge.is_finite() {
                        edge / chord
                    } else {
                        1.0
                    }
                } else {
                    1.0
                };
                out.push(ShootCell {
                    corners: poly,
                    len: corners.len() as u8,
                    p: pos,
                    n,
                    value,
                    quarters,
                    sixteenths,
                    weight,
                    flat: !curved,
                });
            };
            match grid.domain {
                Domain::Tri(_) => {
                    let m = side;
                    let f = |i: u32, j: u32| (i as f32 / m as f32, j as f32 / m as f32);
                    let mut idx = 0;
                    for j in 0..m {
                        for i in 0..m - j {
                            push(&[f(i, j), f(i + 1, j), f(i, j + 1)], idx);
                            idx += 1;
                            if i + j + 1 < m {
                                push(&[f(i + 1, j + 1), f(i, j + 1), f(i + 1, j)], idx);
                                idx += 1;
                            }
                        }
                    }
                }
                _ => {
                    let f = |i: u32, j: u32| (i as f32 / side as f32, j as f32 / side as f32);
                    for j in 0..side {
                        for i in 0..side {
                            push(
                                &[f(i, j), f(i + 1, j), f(i + 1, j + 1), f(i, j + 1)],
                                j * side + i,
                            );
                        }
                    }
                }
            }
        }
        // A masked surface sends light from the part of it that is there.
        if p.opacity < 1.0 {
            for c in &mut out {
                c.weight *= p.opacity;
            }
        }
        out
    }
}

/// A piece of a patch that shoots light: its corner polygon (for the exact
/// unoccluded form factor) and a jittered point in it (for visibility and for the
/// radiosity it carries).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShootCell {
    /// Corners, counter-clockwise seen from the front; `len` of them are used.
    pub corners: [Vec3; 4],
    /// 3 or 4.
    pub len: u8,
    /// The jittered point.
    pub p: Vec3,
    /// Unit normal at the point (front).
    pub n: Vec3,
    /// The mean over the cell of the field it was cut with (zero without one): a
    /// quadrature of points about half an element apart, so what a cell carries does
    /// not depend on where its point was jittered.
    pub value: Rgb,
    /// The means over the cell's quarters ([`ShootCell::quarter`]), by the same points.
    pub quarters: [Rgb; 4],
    /// Of a quadrilateral carrying a field, the field's luminance over its 4 x 4
    /// sixteenths in local coordinates (sixteenth i + 4 j spans [i/4, (i+1)/4] x
    /// [j/4, (j+1)/4]), by the same points: where a parted cell's rays aim
    /// ([`point_by_light`]).
    pub sixteenths: Option<[f32; 16]>,
    /// What the cell's light counts for: 1, or (area of the surface) / (area of the
    /// cells drawn) when the cells are a sample of a surface of more pieces than cells.
    pub weight: f32,
    /// The cell is flat: every point of its corner polygon lies on the surface (not
    /// so for a piece of a curved Bezier surface).
    pub flat: bool,
}

/// The mean of `f` over a cell, by `q` x `q` points, and its means over the cell's
/// quarters ([`ShootCell::quarter`]): on a square's grid of cell centres (`tri`
/// false; local coordinates in [0, 1]^2), or at the centroids of a triangle cut into
/// q^2 (`tri` true; barycentrics of corners 1 and 2). An odd `q` is taken one
/// higher, so that the points fall evenly into the quarters. A quadrilateral's third
/// result is the luminance over its 4 x 4 sixteenths ([`ShootCell::sixteenths`]).
fn cell_mean(q: u32, tri: bool, f: impl Fn(f32, f32) -> Rgb) -> (Rgb, [Rgb; 4], Option<[f32; 16]>) {
    let q = q + q % 2;
    let qf = q as f32;
    let mut quarters = [Vec3::ZERO; 4];
    let (mut fine, mut fine_n) = ([0.0f32; 16], [0u32; 16]);
    let mut add = |a: f32, b: f32| {
        let v = f(a, b);
        let k = if tri {
            // Corner 0's, corner 1's, corner 2's, then the middle triangle.
            if a + b < 0.5 {
                0
            } else if a > 0.5 {
                1
            } else if b > 0.5 {
                2
            } else {
                3
            }
        } else {
            let bin = |t: f32| ((t * 4.0) as usize).min(3);
            let i = bin(a) + 4 * bin(b);
            fine[i] += v.element_sum();
            fine_n[i] += 1;
            usize::from(a > 0.5) + 2 * usize::from(b > 0.5)
        };
        quarters[k] += v;
    };
    for j in 0..q {
        if tri {
            for i in 0..q - j {
                let (i, jf) = (i as f32, j as f32);
                add((i + 1.0 / 3.0) / qf, (jf + 1.0 / 3.0) / qf);
                if i + jf + 1.0 < qf {
                    add((i + 2.0 / 3.0) / qf, (jf + 2.0 / 3.0) / qf);
                }
            }
        } else {
            for i in 0..q {
                add((i as f32 + 0.5) / qf, (j as f32 + 0.5) / qf);
            }
        }
    }
    let per = (q * q / 4) as f32;
    let quarters = quarters.map(|v| v / per);
    // A sixteenth no point fell in (fewer than 4 x 4 points) takes its quarter's.
    let sixteenths = (!tri).then(|| {
        std::array::from_fn(|i| match fine_n[i] {
            0 => quarters[(i % 4) / 2 + 2 * ((i / 4) / 2)].element_sum(),
            n => fine[i] / n as f32,
        })
    });
    (quarters.iter().copied().sum::<Rgb>() / 4.0, quarters, sixteenths)
}

/// About `count` shooting cells over the triangles `tris` (the exact surface, wound to
/// face its front), each with a point jittered by `u` and the mean of `value` over it
/// (points about half of `mesh_size` apart). With fewer triangles than `count`, each is
/// cut into a triangular grid in proportion to its area; with more, `count` of them
/// stand for equal shares of the cumulative area (the triangle at each share's middle:
/// no choice depends on the seed).
fn surface_cells<'a>(
    tris: &'a [[Vec3; 3]],
    count: u32,
    u: &'a impl Fn(u32) -> Vec2,
    mesh_size: f32,
    value: impl Fn(Vec3) -> Rgb + 'a,
) -> impl Iterator<Item = ShootCell> + 'a {
    let areas: Vec<f32> = tris
        .iter()
        .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
        .collect();
    let total: f32 = areas.iter().sum();
    let count = count.max(1);
    let mut pieces: Vec<([Vec3; 3], f32)> = Vec::new();
    if total > 0.0 && tris.len() as u32 <= count {
        for (t, a) in tris.iter().zip(&areas) {
            let k = ((count as f32 * a / total).sqrt().round() as u32).max(1);
            pieces.extend(crate::geometry::triangle_pieces(*t, k).map(|q| (q, 1.0)));
        }
    } else if total > 0.0 {
        let mut cdf = Vec::with_capacity(tris.len());
        let mut acc = 0.0f64;
        for a in &areas {
            acc += f64::from(*a);
            cdf.push(acc);
        }
        for c in 0..count {
            let x = (f64::from(c) + 0.5) / f64::from(count) * acc;
            let i = cdf.partition_point(|&v| v < x).min(tris.len() - 1);
            pieces.push((tris[i], total / (count as f32 * areas[i].max(1e-30))));
        }
    }
    pieces.into_iter().enumerate().map(move |(k, (t, weight))| {
        flat_cell(&t, point_in_polygon(&t, u(k as u32)), weight, mesh_size, &value)
    })
}

/// A shooting cell on the triangle or planar quadrilateral `poly` with point `p` and
/// weight `weight`, holding the mean of `value` over it (points about half of
/// `mesh_size` apart).
fn flat_cell(poly: &[Vec3], p: Vec3, weight: f32, mesh_size: f32, value: impl Fn(Vec3) -> Rgb) -> ShootCell {
    let tri = poly.len() == 3;
    // Twice the area along the normal: edges of a triangle, diagonals of a quadrilateral.
    let n = if tri {
        (poly[1] - poly[0]).cross(poly[2] - poly[0])
    } else {
        (poly[2] - poly[0]).cross(poly[3] - poly[1])
    };
    let side = (0.5 * n.length()).sqrt();
    let q = ((2.0 * side / mesh_size.max(1e-30)).ceil() as u32).clamp(1, 16);
    let (value, quarters, sixteenths) = cell_mean(q, tri, |a, b| {
        value(if tri {
            poly[0] + (poly[1] - poly[0]) * a + (poly[2] - poly[0]) * b
        } else {
            point_in_polygon(poly, Vec2::new(a, b))
        })
    });
    let mut corners = [Vec3::ZERO; 4];
    corners[..poly.len()].copy_from_slice(poly);
    ShootCell {
        corners,
        len: poly.len() as u8,
        p,
        n: n.normalize_or(Vec3::Z),
        value,
        quarters,
        sixteenths,
        weight,
        flat: true,
    }
}

/// Shooting cells on the planar quadrilaterals `blocks` that tile a surface of area
/// `area`, each with a point jittered by `u` and the mean of `value` over it (points
/// about half of `mesh_size` apart); their weight makes the blocks' power that of the
/// surface where the blocks' outline overreaches it.
fn block_cells<'a>(
    blocks: &'a [[Vec3; 4]],
    area: f32,
    u: &'a impl Fn(u32) -> Vec2,
    mesh_size: f32,
    value: impl Fn(Vec3) -> Rgb + 'a,
) -> impl Iterator<Item = ShootCell> + 'a {
    let quad_area = |b: &[Vec3; 4]| 0.5 * (b[2] - b[0]).cross(b[3] - b[1]).length();
    let tiled: f32 = blocks.iter().map(quad_area).sum();
    let weight = if tiled > 0.0 { area / tiled } else { 1.0 };
    blocks
        .iter()
        .enumerate()
        .map(move |(k, b)| flat_cell(b, point_in_polygon(b, u(k as u32)), weight, mesh_size, &value))
}

impl ShootCell {
    /// The corner polygon.
    pub fn polygon(&self) -> &[Vec3] {
        &self.corners[..self.len as usize]
    }
}

/// Quarter `k` of the cell polygon `poly` (3 or 4 corners, counter-clockwise), as
/// [`ShootCell::quarters`] are taken: of a quadrilateral, the one at local (a, b) in
/// [0, 1/2] or [1/2, 1] each (k = [a > 1/2] + 2 [b > 1/2]); of a triangle, the corner
/// triangles of corners 0, 1, 2 and the middle one. Wound as `poly`; (corners, len).
pub fn quarter(poly: &[Vec3], k: usize) -> ([Vec3; 4], usize) {
    if let [c0, c1, c2] = *poly {
        let (m01, m12, m02) = ((c0 + c1) * 0.5, (c1 + c2) * 0.5, (c0 + c2) * 0.5);
        let t = match k {
            0 => [c0, m01, m02],
            1 => [m01, c1, m12],
            2 => [m02, m12, c2],
            _ => [m01, m12, m02],
        };
        return ([t[0], t[1], t[2], Vec3::ZERO], 3);
    }
    let at = |a: f32, b: f32| point_in_polygon(poly, Vec2::new(a, b));
    let (a, b) = ((k % 2) as f32 * 0.5, (k / 2) as f32 * 0.5);
    (
        [at(a, b), at(a + 0.5, b), at(a + 0.5, b + 0.5), at(a, b + 0.5)],
        4,
    )
}

/// The point at `u` in the cell polygon `poly` (as [`point_in_polygon`]), drawn in
/// proportion to the field over its pieces: a quadrilateral's `sixteenths` if given
/// (as [`ShootCell::sixteenths`]), else its `quarters` (as [`ShootCell::quarters`]).
/// `u.x` picks a piece by its share of their sum (luminance) and, stretched back to
/// [0, 1), places the point in it with `u.y`. A uniform `u` then gives points of
/// density proportional to the field at the pieces' scale, and a piece of no light
/// gets none. With no light in any piece, uniform.
pub fn point_by_light(poly: &[Vec3], quarters: &[Rgb; 4], sixteenths: Option<&[f32; 16]>, u: Vec2) -> Vec3 {
    if let (Some(w), 4) = (sixteenths, poly.len()) {
        return match pick(w, u.x) {
            Some((k, a)) => {
                let (i, j) = ((k % 4) as f32, (k / 4) as f32);
                point_in_polygon(poly, Vec2::new((i + a) / 4.0, (j + u.y) / 4.0))
            }
            None => point_in_polygon(poly, u),
        };
    }
    match pick(&quarters.map(|q| q.element_sum()), u.x) {
        Some((k, a)) => {
            let (c, len) = quarter(poly, k);
            point_in_polygon(&c[..len], Vec2::new(a, u.y))
        }
        None => point_in_polygon(poly, u),
    }
}

/// The piece of weights `w` (negatives as none) that `x` in [0, 1) falls in by its
/// share of their sum, and where in the piece's share it fell, in [0, 1); `None`
/// when no piece has weight.
fn pick(w: &[f32], x: f32) -> Option<(usize, f32)> {
    let n = w.len();
    let w = |k: usize| w[k].max(0.0);
    let sum: f32 = (0..n).map(w).sum();
    if !(sum > 0.0) || !sum.is_finite() {
        return None;
    }
    let mut x = x * sum;
    let mut k = 0;
    while k + 1 < n && (x >= w(k) || w(k) <= 0.0) {
        x -= w(k);
        k += 1;
    }
    // The rounding of the last subtraction may leave `k` at an empty piece.
    while w(k) <= 0.0 {
        k -= 1;
    }
    Some((k, (x / w(k)).clamp(0.0, 1.0 - f32::EPSILON)))
}

/// The length of the vector area of the closed loop `pts` (half the sum of the
/// cross products of its fan from the first point): a planar polygon's area.
pub fn vector_area(pts: &[Vec3]) -> f32 {
    let Some(&o) = pts.first() else {
        return 0.0;
    };
    (1..pts.len().saturating_sub(1))
        .map(|k| (pts[k] - o).cross(pts[k + 1] - o))
        .sum::<Vec3>()
        .length()
        * 0.5
}

/// The point at `u` in the triangle or (planar) quadrilateral `poly`: barycentric,
/// uniform in area, for a triangle; bilinear in the corners for a quadrilateral.
pub fn point_in_polygon(poly: &[Vec3], u: Vec2) -> Vec3 {
    match poly {
        [a, b, c] => {
            let q = u.x.sqrt();
            *a + (*b - *a) * (q * (1.0 - u.y)) + (*c - *a) * (q * u.y)
        }
        [a, b, c, d] => (*a * (1.0 - u.x) + *b * u.x) * (1.0 - u.y) + (*d * (1.0 - u.x) + *c * u.x) * u.y,
        _ => poly.first().copied().unwrap_or(Vec3::ZERO),
    }
}
