//! The cells a patch shoots from: the patch cut into about as many cells as a shot
//! asks for, each with its corner polygon, a jittered point in it and the mean of the
//! unshot radiosity over it.

use glam::{Vec2, Vec3};

use super::{Domain, Interp, RadiosityMesh};
use crate::scene::Rgb;

/// A shot's care over cells that an obstacle stands on (a wall on a floor that runs
/// on under it into the next room): which cells it parts, and the field read at a
/// point of such a cell from the vertices that point sees, not from all those it
/// interpolates (which mix the two rooms' light).
pub trait Parting: Sync {
    /// Whether an obstacle stands on the flat cell `poly` facing `n`.
    fn parts(&self, poly: &[Vec3], n: Vec3) -> bool;
    /// The field at point `x` of a parted cell, whose vertices' weights are `w`, and
    /// whether the obstacle hides one of them from `x` (or `x` lies in it).
    fn read(&self, w: Interp, x: Vec3) -> (Rgb, bool);
}

impl RadiosityMesh {
    /// The patch cut into about `count` cells for shooting from it (stratified:
    /// cells of a regular grid over each of the patch's grids, in proportion to
    /// area), each with a point jittered inside it by `u` (`u(g << 16 | k)` for cell
    /// `k` of grid `g`) and the mean of `field` (per vertex; may be empty) over it,
    /// read with `parting`'s care over the cells it parts ([`ShootCell::parted`]).
    pub fn shoot_cells(
        &self,
        patch: u32,
        count: u32,
        u: impl Fn(u32) -> Vec2,
        field: &[Rgb],
        parting: Option<&dyn Parting>,
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
                let field = Field {
                    values: field,
                    parting,
                    at: |q: Vec3| l.interp(base, q),
                };
                let cells: Vec<ShootCell> = if let Some(blocks) = l.blocks(count) {
                    block_cells(&blocks, p.area, &u, self.mesh_size, field).collect()
                } else {
                    surface_cells(&l.surface, count, &u, self.mesh_size, field).collect()
                };
                out.extend(cells.into_iter().map(|c| ShootCell { grid: g as u32, ..c }));
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
                let flat = !matches!(grid.domain, Domain::Curved { .. });
                let parting =
                    parting.filter(|pt| flat && !field.is_empty() && pt.parts(&poly[..corners.len()], n));
                let ((value, quarters, sixteenths), mixed) = read_cell(
                    q,
                    tri,
                    field,
                    parting,
                    |a, b| {
                        let (s, t) = at(a, b);
                        grid.interp(s, t)
                    },
                    |a, b| {
                        let (s, t) = at(a, b);
                        grid.eval(s, t).0
                    },
                );
                let cell = ShootCell {
                    corners: poly,
                    len: corners.len() as u8,
                    p: pos,
                    n,
                    value,
                    quarters,
                    sixteenths,
                    weight: 1.0,
                    flat,
                    parted: mixed.is_some(),
                    mixed: mixed.unwrap_or(0),
                    grid: g as u32,
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
                out.push(ShootCell { weight, ..cell });
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
    /// [j/4, (j+1)/4]), by the same points: the light of a parted cell's pieces.
    pub sixteenths: Option<[f32; 16]>,
    /// What the cell's light counts for: 1, or (area of the surface) / (area of the
    /// cells drawn) when the cells are a sample of a surface of more pieces than cells.
    pub weight: f32,
    /// The cell is flat: every point of its corner polygon lies on the surface (not
    /// so for a piece of a curved Bezier surface).
    pub flat: bool,
    /// An obstacle stands on the cell ([`Parting::parts`]): its field was read with
    /// care ([`Parting::read`]). Only where a field was read.
    pub parted: bool,
    /// Of a parted cell, the pieces (bit k: sixteenth k of a quadrilateral, quarter k
    /// of a triangle) where the obstacle hid a vertex from one of the points read:
    /// it stands on them or beside them, so their light may differ from one side of it
    /// to the other.
    pub mixed: u16,
    /// The index of the grid it lies on among its patch's grids (see
    /// [`RadiosityMesh::flat_interp`]).
    pub grid: u32,
}

/// A per-vertex field as the cells of a triangle mesh read it: the weights at a
/// point of the surface (`at`), and the care a shot takes over the cells it parts.
struct Field<'a, F> {
    values: &'a [Rgb],
    parting: Option<&'a dyn Parting>,
    at: F,
}

/// A cell's field: its mean, its quarters' means, a quadrilateral's sixteenths'
/// luminance (as [`ShootCell`] holds them).
type Means = (Rgb, [Rgb; 4], Option<[f32; 16]>);

/// The piece of a cell that local point (a, b) falls in: of a quadrilateral its
/// sixteenth (i + 4 j, [`ShootCell::sixteenths`]), of a triangle (barycentrics of
/// corners 1 and 2) its quarter (corner 0's, 1's, 2's, then the middle one).
fn piece_of(tri: bool, a: f32, b: f32) -> usize {
    if tri {
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
        bin(a) + 4 * bin(b)
    }
}

/// The mean of `f` over a cell, by `q` x `q` points, and its means over the cell's
/// quarters ([`ShootCell::quarter`]): on a square's grid of cell centres (`tri`
/// false; local coordinates in [0, 1]^2), or at the centroids of a triangle cut into
/// q^2 (`tri` true; barycentrics of corners 1 and 2). An odd `q` is taken one
/// higher, so that the points fall evenly into the quarters. A quadrilateral's third
/// result is the luminance over its 4 x 4 sixteenths ([`ShootCell::sixteenths`]).
fn cell_mean(q: u32, tri: bool, f: impl Fn(f32, f32) -> Rgb) -> Means {
    let q = q + q % 2;
    let qf = q as f32;
    let mut quarters = [Vec3::ZERO; 4];
    let (mut fine, mut fine_n) = ([0.0f32; 16], [0u32; 16]);
    let mut add = |a: f32, b: f32| {
        let v = f(a, b);
        let k = if tri {
            piece_of(true, a, b)
        } else {
            let i = piece_of(false, a, b);
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
    field: Field<'a, impl Fn(Vec3) -> Interp + 'a>,
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
        flat_cell(&t, point_in_polygon(&t, u(k as u32)), weight, mesh_size, &field)
    })
}

/// A shooting cell on the triangle or planar quadrilateral `poly` with point `p` and
/// weight `weight`, holding the mean of `field` over it (points about half of
/// `mesh_size` apart).
fn flat_cell(
    poly: &[Vec3],
    p: Vec3,
    weight: f32,
    mesh_size: f32,
    field: &Field<'_, impl Fn(Vec3) -> Interp>,
) -> ShootCell {
    let tri = poly.len() == 3;
    // Twice the area along the normal: edges of a triangle, diagonals of a quadrilateral.
    let n = if tri {
        (poly[1] - poly[0]).cross(poly[2] - poly[0])
    } else {
        (poly[2] - poly[0]).cross(poly[3] - poly[1])
    };
    let side = (0.5 * n.length()).sqrt();
    let q = ((2.0 * side / mesh_size.max(1e-30)).ceil() as u32).clamp(1, 16);
    let point = |a: f32, b: f32| {
        if tri {
            poly[0] + (poly[1] - poly[0]) * a + (poly[2] - poly[0]) * b
        } else {
            point_in_polygon(poly, Vec2::new(a, b))
        }
    };
    let n = n.normalize_or(Vec3::Z);
    let parting = field
        .parting
        .filter(|pt| !field.values.is_empty() && pt.parts(poly, n));
    let ((value, quarters, sixteenths), mixed) = read_cell(
        q,
        tri,
        field.values,
        parting,
        |a, b| (field.at)(point(a, b)),
        point,
    );
    let mut corners = [Vec3::ZERO; 4];
    corners[..poly.len()].copy_from_slice(poly);
    ShootCell {
        corners,
        len: poly.len() as u8,
        p,
        n,
        value,
        quarters,
        sixteenths,
        weight,
        flat: true,
        parted: mixed.is_some(),
        mixed: mixed.unwrap_or(0),
        grid: 0,
    }
}

/// The means over a cell of the per-vertex field `values` (as [`cell_mean`] gives
/// them, zero for no field) by `q` x `q` points, local point (a, b) of which has the
/// vertices' weights `weights(a, b)` and lies at `point(a, b)`: read plainly, or where
/// `parting` parts the cell, with its care ([`Parting::read`]), and then with the
/// pieces where a vertex was hidden from a point read ([`ShootCell::mixed`]).
fn read_cell(
    q: u32,
    tri: bool,
    values: &[Rgb],
    parting: Option<&dyn Parting>,
    weights: impl Fn(f32, f32) -> Interp,
    point: impl Fn(f32, f32) -> Vec3,
) -> (Means, Option<u16>) {
    if values.is_empty() {
        return ((Vec3::ZERO, [Vec3::ZERO; 4], None), None);
    }
    let Some(parting) = parting else {
        return (cell_mean(q, tri, |a, b| weights(a, b).apply(values)), None);
    };
    let mixed = std::cell::Cell::new(0u16);
    let means = cell_mean(q, tri, |a, b| {
        let (v, hid) = parting.read(weights(a, b), point(a, b));
        mixed.set(mixed.get() | u16::from(hid) << piece_of(tri, a, b));
        v
    });
    (means, Some(mixed.get()))
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
    field: Field<'a, impl Fn(Vec3) -> Interp + 'a>,
) -> impl Iterator<Item = ShootCell> + 'a {
    let quad_area = |b: &[Vec3; 4]| 0.5 * (b[2] - b[0]).cross(b[3] - b[1]).length();
    let tiled: f32 = blocks.iter().map(quad_area).sum();
    let weight = if tiled > 0.0 { area / tiled } else { 1.0 };
    blocks
        .iter()
        .enumerate()
        .map(move |(k, b)| flat_cell(b, point_in_polygon(b, u(k as u32)), weight, mesh_size, &field))
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

/// Sixteenth `m` of quarter `k` of a quadrilateral ([`quarter`] of [`quarter`]) is
/// sixteenth `sixteenth_of(k, m)` of the whole (i + 4 j, as [`ShootCell::sixteenths`]).
pub fn sixteenth_of(k: usize, m: usize) -> usize {
    2 * (k % 2) + m % 2 + 4 * (2 * (k / 2) + m / 2)
}

/// The quarter `k` and its quarter `m` that sixteenth `i` is ([`sixteenth_of`]'s
/// inverse).
pub fn quarter_of_sixteenth(i: usize) -> (usize, usize) {
    (2 * (i / 8) + (i % 4) / 2, 2 * ((i / 4) % 2) + i % 2)
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
