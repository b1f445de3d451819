//! What a patch's shot sends to each vertex, kept for the patch's next shot.
//!
//! Progressive refinement shoots the large patches of a room again and again: each
//! time the others have sent them more light (the paper room's walls are shot three
//! or four times, 14 of its 20 patch shots). The cells of a patch, their form factors
//! to every vertex and the visibility its rays found do not change between those
//! shots; only the radiosity on the cells does. So the first shot of a patch keeps,
//! per receiving vertex, each cell's form factor and the visibility its rays found,
//! and a later shot of the patch is a sum of products over them
//! (no rays). One kind of link is taken anew instead: a cell that an obstacle stands
//! on (a wall on a floor or ceiling running on into the next room) is taken piece by
//! piece, each piece's light read from the vertices its point sees
//! (`Solver::parted_light`), and that light depends on the cell's field as it is at
//! each shot. A single visibility kept from the first shot, times the cell's light read
//! plainly, passed the far room's light on to a receiver on the near side: two rooms'
//! dividing wall held 0.16 along its top, a hundred times the row below, after 30
//! reused shots (0.0001 with none kept). So such a link keeps its form factor only, and
//! the later shot takes the cell again ([`Transfer::receive`]'s `parted`).
//! A kept shot costs 8 bytes per link from a cell to a vertex; shots are
//! kept until the first that does not fit in what is left of [`BUDGET`] bytes, so
//! memory stays bounded whatever the scene (the paper room keeps its shots in 16 MB),
//! no later shot records links only to drop them, and a patch shot after that casts
//! its rays as before.

/// Bytes all kept shots may take together.
pub const BUDGET: usize = 256 << 20;

/// One cell as one vertex saw it, as the shot finds it.
#[derive(Debug, Clone, Copy)]
pub struct Link {
    /// The cell: its index in the shot's sets of cells, one after the other.
    pub cell: u32,
    /// Its unoccluded form factor to the vertex.
    pub f: f32,
    /// The fraction of its shadow rays that reached it.
    pub vis: f32,
    /// Where the vertex took the cell's light by quarters: their form factors
    /// (`f` is then unused).
    pub quarters: Option<[f32; 4]>,
    /// The cell is taken piece by piece (an obstacle stands on it): a later shot
    /// takes it anew, and `vis` is not kept.
    pub parted: bool,
}

/// A link as kept: the visibility in units of 2^-15 (exact for the fractions of up
/// to 2^15 rays a shot casts to a cell).
#[derive(Debug, Clone, Copy)]
struct Packed {
    /// The form factor, or for a link by quarters (`cell`'s top bit set) the index
    /// of its quarters' form factors.
    f: f32,
    cell: u16,
    vis: u16,
}

/// The top bit of [`Packed::cell`]: the link takes the cell by quarters.
const BY_QUARTERS: u16 = 1 << 15;

const VIS_ONE: f32 = 32768.0;

/// [`Packed::vis`] of a parted link ([`Link::parted`]): above any visibility.
const PARTED: u16 = u16::MAX;

/// The links of one shot, per vertex.
pub struct Transfer {
    /// Vertex `i`'s links are `links[start[i]..start[i + 1]]`.
    start: Vec<u32>,
    links: Vec<Packed>,
    quarters: Vec<[f32; 4]>,
}

impl Transfer {
    /// Gathers the links of each vertex (in vertex order). `None` when the shot has
    /// more links than a `u32` counts or more cells than 15 bits do.
    pub fn new(per_vertex: impl ExactSizeIterator<Item = Vec<Link>>) -> Option<Self> {
        let mut start = Vec::with_capacity(per_vertex.len() + 1);
        start.push(0);
        let mut links = Vec::new();
        let mut quarters = Vec::new();
        for v in per_vertex {
            for l in v {
                let cell = u16::try_from(l.cell).ok().filter(|c| c & BY_QUARTERS == 0)?;
                let (f, cell) = match l.quarters {
                    Some(q) => {
                        quarters.push(q);
                        (
                            f32::from_bits(u32::try_from(quarters.len() - 1).ok()?),
                            cell | BY_QUARTERS,
                        )
                    }
                    None => (l.f, cell),
                };
                links.push(Packed {
                    f,
                    cell,
                    vis: if l.parted {
                        PARTED
                    } else {
                        (l.vis.clamp(0.0, 1.0) * VIS_ONE).round() as u16
                    },
                });
            }
            start.push(u32::try_from(links.len()).ok()?);
        }
        Some(Transfer {
            start,
            links,
            quarters,
        })
    }

    /// Bytes it takes.
    pub fn bytes(&self) -> usize {
        self.start.len() * std::mem::size_of::<u32>()
            + self.links.len() * std::mem::size_of::<Packed>()
            + self.quarters.len() * std::mem::size_of::<[f32; 4]>()
    }

    /// What vertex `i` receives when the cells send `radiosity`, and their quarters
    /// `quarters` (both indexed as [`Link::cell`]): (occluded, unoccluded) irradiance.
    /// A parted link's cell is taken by `parted(cell, form factor)`, which gives the
    /// same pair.
    pub fn receive(
        &self,
        i: usize,
        radiosity: &[glam::Vec3],
        quarters: &[[glam::Vec3; 4]],
        mut parted: impl FnMut(u32, f32) -> (glam::Vec3, glam::Vec3),
    ) -> (glam::Vec3, glam::Vec3) {
        let links = &self.links[self.start[i] as usize..self.start[i + 1] as usize];
        links
            .iter()
            .fold((glam::Vec3::ZERO, glam::Vec3::ZERO), |(o, u), l| {
                let cell = l.cell & !BY_QUARTERS;
                let by_quarters = (l.cell & BY_QUARTERS != 0).then(|| self.quarters[l.f.to_bits() as usize]);
                if l.vis == PARTED {
                    let f = by_quarters.map_or(l.f, |q| q.iter().sum());
                    let (po, pu) = parted(u32::from(cell), f);
                    return (o + po, u + pu);
                }
                let bf = match by_quarters {
                    Some(fq) => quarters[cell as usize].iter().zip(fq).map(|(b, f)| *b * f).sum(),
                    None => radiosity[cell as usize] * l.f,
                };
                (o + bf * (f32::from(l.vis) / VIS_ONE), u + bf)
            })
    }
}

/// The kept shots, per patch, within [`BUDGET`].
pub struct Kept {
    shots: Vec<Option<Transfer>>,
    bytes: usize,
    budget: usize,
}

impl Kept {
    /// Room for the shots of `patches` patches within `budget` bytes.
    pub fn new(patches: usize, budget: usize) -> Self {
        Kept {
            shots: (0..patches).map(|_| None).collect(),
            bytes: 0,
            budget,
        }
    }

    /// The kept shot of patch `p`.
    pub fn get(&self, p: usize) -> Option<&Transfer> {
        self.shots.get(p).and_then(Option::as_ref)
    }

    /// Whether a shot can still be kept at all.
    pub fn has_room(&self) -> bool {
        self.bytes < self.budget
    }

    /// Keeps `t` as patch `p`'s shot if it fits in what is left of the budget; if
    /// it does not, no shot is kept any more (the next ones are as large, and
    /// recording their links would be work thrown away).
    pub fn keep(&mut self, p: usize, t: Transfer) {
        let b = t.bytes();
        if self.bytes + b <= self.budget && p < self.shots.len() {
            self.bytes += b;
            self.shots[p] = Some(t);
        } else {
            self.budget = self.bytes;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn link(cell: u32, f: f32, vis: f32) -> Link {
        Link {
            cell,
            f,
            vis,
            quarters: None,
            parted: false,
        }
    }

    #[test]
    fn a_vertex_receives_the_sum_over_its_own_links() {
        let t = Transfer::new(
            vec![
                vec![link(0, 0.5, 0.5), link(2, 0.1, 1.0)],
                vec![],
                vec![link(1, 0.2, 0.0)],
            ]
            .into_iter(),
        )
        .unwrap();
        let b = [Vec3::splat(2.0), Vec3::new(1.0, 2.0, 3.0), Vec3::splat(10.0)];
        let qs = b.map(|x| [x; 4]);
        // 2 * 0.25 + 10 * 0.1 = 1.5 occluded; 2 * 0.5 + 10 * 0.1 = 2 unoccluded.
        assert_eq!(
            t.receive(0, &b, &qs, no_parted),
            (Vec3::splat(1.5), Vec3::splat(2.0))
        );
        assert_eq!(t.receive(1, &b, &qs, no_parted), (Vec3::ZERO, Vec3::ZERO));
        assert_eq!(
            t.receive(2, &b, &qs, no_parted),
            (Vec3::ZERO, Vec3::new(0.2, 0.4, 0.6))
        );
        assert_eq!(t.bytes(), 4 * 4 + 3 * 8);
        assert!(Transfer::new(vec![vec![link(1 << 15, 0.1, 1.0)]].into_iter()).is_none());
        // A link by quarters takes each quarter's radiosity with its form factor.
        let q = Link {
            quarters: Some([0.1, 0.2, 0.3, 0.4]),
            ..link(1, 0.0, 0.5)
        };
        let t = Transfer::new(vec![vec![q, link(0, 0.5, 1.0)]].into_iter()).unwrap();
        let qs = [[Vec3::ONE; 4], [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE]];
        let got = t.receive(0, &b[..2], &qs, no_parted);
        let by_quarters = Vec3::new(0.1 + 0.4, 0.2 + 0.4, 0.3 + 0.4);
        assert_eq!(got.1, by_quarters + Vec3::splat(1.0));
        assert_eq!(got.0, by_quarters * 0.5 + Vec3::splat(1.0));
        assert_eq!(t.bytes(), 2 * 4 + 2 * 8 + 16);
    }

    fn no_parted(cell: u32, _: f32) -> (Vec3, Vec3) {
        panic!("cell {cell} taken as parted")
    }

    /// A parted link's cell comes from the shot's own reading, with the form factor
    /// kept (the quarters' sum for a link by quarters); the other links as kept.
    #[test]
    fn a_parted_link_is_taken_anew() {
        let parted = |cell, f| Link {
            parted: true,
            ..link(cell, f, 0.25)
        };
        let by_quarters = Link {
            quarters: Some([0.1, 0.2, 0.3, 0.4]),
            ..parted(2, 0.0)
        };
        let t =
            Transfer::new(vec![vec![parted(0, 0.5), link(1, 0.5, 0.5), by_quarters]].into_iter()).unwrap();
        let b = [Vec3::splat(100.0), Vec3::splat(2.0), Vec3::splat(100.0)];
        let qs = b.map(|x| [x; 4]);
        let mut asked = Vec::new();
        let got = t.receive(0, &b, &qs, |cell, f| {
            asked.push((cell, f));
            (Vec3::splat(f), Vec3::splat(10.0 * f))
        });
        assert_eq!(asked, vec![(0, 0.5), (2, 1.0)]);
        // Cell 1: 2 * 0.5 unoccluded, half of it seen; cells 0 and 2 as the closure said.
        assert_eq!(got.0, Vec3::splat(0.5 + 0.5 + 1.0));
        assert_eq!(got.1, Vec3::splat(5.0 + 1.0 + 10.0));
    }

    #[test]
    fn shots_are_kept_only_within_the_budget() {
        let one = || Transfer::new(vec![vec![link(0, 1.0, 1.0)]].into_iter()).unwrap();
        let size = one().bytes();
        let mut kept = Kept::new(3, 2 * size);
        kept.keep(0, one());
        kept.keep(1, one());
        assert!(!kept.has_room());
        kept.keep(2, one());
        assert!(kept.get(0).is_some() && kept.get(1).is_some());
        assert!(kept.get(2).is_none(), "a third shot is past the budget");

        // Room left, but not enough for the next shot: none is kept after it.
        let mut kept = Kept::new(3, size + size / 2);
        kept.keep(0, one());
        assert!(kept.has_room());
        kept.keep(1, one());
        assert!(kept.get(1).is_none() && !kept.has_room());
    }
}
