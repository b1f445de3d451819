//! The vertices that lie midway between others of their grid: at every other node
//! of a grid along one parameter (between two vertices), or along both (amid four).
//!
//! A shot can take what such a vertex sees of a source from the vertices about it
//! where those agree, as the shadow image buffer takes a light point's visibility
//! from the neighbouring samples on the screen (see `radiosity::coherence`). The
//! nodes at even places along both parameters are the coarse grid, which is always
//! computed; a grid's last node on a side is coarse too, so that every midpoint has
//! its vertices on both sides, and the ends of every midpoint are coarse.

use super::{tri_vertex, Domain, Grid, RadiosityMesh};

/// The vertices a midpoint lies between: two (along one parameter) or four (the
/// corners of the coarse element it is the centre of), each of weight 1 / `len`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Between {
    pub ends: [u32; 4],
    pub len: u8,
}

impl Between {
    /// The vertices it lies between.
    pub fn ends(&self) -> &[u32] {
        &self.ends[..self.len as usize]
    }
}

/// Per vertex of a mesh, the vertices it lies midway between, if it is a midpoint.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Midpoints {
    between: Vec<Option<Between>>,
    count: usize,
}

impl Midpoints {
    /// The midpoints of every grid of `mesh`. A vertex that is covered (see
    /// [`RadiosityMesh::build_covered`]), or one whose vertices about it are not all
    /// there and uncovered (at a lattice's ragged rim), is not a midpoint: it is
    /// computed.
    pub fn of(mesh: &RadiosityMesh) -> Self {
        let mut between = vec![None; mesh.vertices.len()];
        for patch in &mesh.patches {
            for grid in &patch.grids {
                grid_midpoints(grid, &mut between);
            }
        }
        let count = between.iter().filter(|b| b.is_some()).count();
        Midpoints { between, count }
    }

    /// What vertex `v` lies between, if it is a midpoint.
    pub fn of_vertex(&self, v: usize) -> Option<&Between> {
        self.between.get(v).and_then(Option::as_ref)
    }

    /// How many vertices are midpoints.
    pub fn count(&self) -> usize {
        self.count
    }
}

/// Whether node `i` of `n + 1` lies between two coarse nodes: odd and not the last.
fn mid(i: u32, n: u32) -> bool {
    i % 2 == 1 && i < n
}

/// The nodes a node (i, j) of a square grid of n x m elements lies between, if it
/// is a midpoint (as node pairs).
fn square_ends(i: u32, j: u32, n: u32, m: u32) -> Option<Vec<(u32, u32)>> {
    match (mid(i, n), mid(j, m)) {
        (false, false) => None,
        (true, false) => Some(vec![(i - 1, j), (i + 1, j)]),
        (false, true) => Some(vec![(i, j - 1), (i, j + 1)]),
        (true, true) => Some(vec![
            (i - 1, j - 1),
            (i + 1, j - 1),
            (i + 1, j + 1),
            (i - 1, j + 1),
        ]),
    }
}

/// The nodes a node (i, j) of a triangular grid of k subdivisions (i + j <= k) lies
/// between: the midpoint of an edge of the coarse triangles, whose ends are both
/// even along both parameters.
fn tri_ends(i: u32, j: u32, k: u32) -> Option<Vec<(u32, u32)>> {
    let ends = match (i % 2 == 1, j % 2 == 1) {
        (false, false) => return None,
        (true, false) => vec![(i - 1, j), (i + 1, j)],
        (false, true) => vec![(i, j - 1), (i, j + 1)],
        (true, true) => vec![(i - 1, j + 1), (i + 1, j - 1)],
    };
    ends.iter().all(|&(a, b)| a + b <= k).then_some(ends)
}

fn grid_midpoints(grid: &Grid, between: &mut [Option<Between>]) {
    let base = grid.first_vertex;
    let covered = |offset: u32| grid.covered.get(offset as usize).copied().unwrap_or(false);
    // Per node, its vertex offset in the grid (if it is a vertex) and its ends.
    let mut set = |offset: u32,
                   ends: Option<Vec<(u32, u32)>>,
                   vertex: &dyn Fn(u32, u32) -> Option<u32>,
                   covered: &dyn Fn(u32) -> bool| {
        let Some(ends) = ends else { return };
        if covered(offset) {
            return;
        }
        let mut out = Between {
            ends: [0; 4],
            len: ends.len() as u8,
        };
        for (slot, &(a, b)) in out.ends.iter_mut().zip(&ends) {
            match vertex(a, b) {
                Some(o) if !covered(o) => *slot = base + o,
                _ => return,
            }
        }
        if let Some(b) = between.get_mut((base + offset) as usize) {
            *b = Some(out);
        }
    };
    match &grid.domain {
        Domain::Tri(_) => {
            let k = grid.n;
            for j in 0..=k {
                for i in 0..=k - j {
                    set(
                        tri_vertex(k, i, j),
                        tri_ends(i, j, k),
                        &|a, b| Some(tri_vertex(k, a, b)),
                        &covered,
                    );
                }
            }
        }
        Domain::Lattice(l) => {
            let covered = |offset: u32| l.covered.get(offset as usize).copied().unwrap_or(false);
            for &(key, offset) in &l.nodes {
                let (i, j) = (key % (l.n + 1), key / (l.n + 1));
                set(
                    offset,
                    square_ends(i, j, l.n, l.m),
                    &|a, b| l.node(a, b),
                    &covered,
                );
            }
        }
        Domain::Quad(_) | Domain::Curved { .. } => {
            let (n, m) = (grid.n, grid.m);
            for j in 0..=m {
                for i in 0..=n {
                    set(
                        j * (n + 1) + i,
                        square_ends(i, j, n, m),
                        &|a, b| Some(b * (n + 1) + a),
                        &covered,
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Patch, TriMesh};
    use crate::testutil::{quad, scene, split_quad, v};
    use glam::Vec3;

    /// Which nodes are midpoints, and of what: along one parameter between its two
    /// neighbours, along both amid the four corners, never the last node of an odd
    /// side; in a triangle, the midpoints of the coarse triangles' edges.
    #[test]
    fn midpoints_lie_between_coarse_nodes() {
        assert_eq!(square_ends(0, 0, 4, 4), None);
        assert_eq!(square_ends(1, 0, 4, 4), Some(vec![(0, 0), (2, 0)]));
        assert_eq!(square_ends(2, 3, 4, 4), Some(vec![(2, 2), (2, 4)]));
        assert_eq!(
            square_ends(1, 1, 4, 4),
            Some(vec![(0, 0), (2, 0), (2, 2), (0, 2)])
        );
        // A side of 3 elements: node 3 is the last (coarse), node 1 lies between 0
        // and 2, and node 2 is coarse.
        assert_eq!(square_ends(3, 0, 3, 2), None);
        assert_eq!(square_ends(2, 0, 3, 2), None);
        assert_eq!(tri_ends(1, 0, 4), Some(vec![(0, 0), (2, 0)]));
        assert_eq!(tri_ends(1, 1, 4), Some(vec![(0, 2), (2, 0)]));
        assert_eq!(tri_ends(2, 2, 4), None);
        // The hypotenuse's midpoint of a triangle of 3 subdivisions would need node
        // (0, 4), outside it.
        assert_eq!(tri_ends(1, 2, 3), None);
    }

    /// On a mesh of a merged floor (a lattice), a lone triangle and a lone
    /// quadrilateral, every midpoint sits at the mean of its ends, which are coarse
    /// vertices of its own patch, and a fair share of the vertices are midpoints.
    #[test]
    fn every_midpoint_is_the_mean_of_its_coarse_ends() {
        let floor = split_quad([v(0., 0., 0.), v(2., 0., 0.), v(2., 2., 0.), v(0., 2., 0.)], 4);
        let tri = TriMesh {
            positions: vec![v(3., 0., 0.), v(4., 0., 0.), v(3., 1., 0.5)],
            indices: vec![[0, 1, 2]],
            tri_patch: vec![0],
            patches: vec![Patch::Polygon(vec![0, 1, 2])],
            ..Default::default()
        };
        let wall = quad([v(0., 3., 0.), v(0., 3., 1.5), v(2., 3., 1.5), v(2., 3., 0.)]);
        let s = scene(
            vec![
                (floor, Vec3::splat(0.5)),
                (tri, Vec3::splat(0.5)),
                (wall, Vec3::splat(0.5)),
            ],
            vec![],
            &[],
        );
        let mesh = RadiosityMesh::build(&s, 0.1);
        let mid = Midpoints::of(&mesh);
        let n = mesh.vertices.len();
        assert!(mid.count() * 3 > n && mid.count() < n, "{} of {n}", mid.count());
        let mut shapes = [0; 3];
        for i in 0..n {
            let Some(b) = mid.of_vertex(i) else { continue };
            let mean = b
                .ends()
                .iter()
                .map(|&e| mesh.vertices[e as usize].p)
                .sum::<Vec3>()
                / b.len as f32;
            let p = mesh.vertices[i].p;
            assert!(
                (mean - p).length() < 1e-5,
                "vertex {i} at {p} between {:?}",
                b.ends()
            );
            for &e in b.ends() {
                assert!(
                    mid.of_vertex(e as usize).is_none(),
                    "end {e} of {i} is a midpoint"
                );
                assert_eq!(mesh.vertices[e as usize].patch, mesh.vertices[i].patch);
            }
            shapes[mesh.patches[mesh.vertices[i].patch as usize].shape as usize] += 1;
        }
        assert!(shapes.iter().all(|&c| c > 10), "midpoints per shape {shapes:?}");
    }
}
