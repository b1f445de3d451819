//! Shadow coherence over the mesh (the paper's Sect. 4 idea, in pass 1): a shot
//! computes the coarse vertices of every grid first (every other node along both
//! parameters, [`crate::mesh::Midpoints`]), and a midpoint then takes a cell's
//! visibility from the vertices about it where all of them found it alike: all of
//! the cell seen (undimmed), or none of it. As the shadow image buffer takes a light
//! point's visibility from the neighbouring samples on the screen. Only the cells
//! where they disagree (a shadow's edge between them, glass dimming, or one of them
//! turned away) are sampled at the midpoint. The form factors are the midpoint's
//! own: only visibility is taken.
//!
//! A midpoint must take the same set of cells as its ends (the sets differ with the
//! distance to the source, [`super::shot::Levels`]); one that takes another set is
//! computed as before.

/// What one coarse vertex found of each cell of the set it took: which it saw all
/// of, undimmed, and which none of, after all of its rays (first and at edges).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Seen {
    /// The index of the set's first cell among all the shot's cells (its identity).
    base: u32,
    /// Per cell, a bit: seen whole.
    lit: Vec<u64>,
    /// Per cell, a bit: hidden whole.
    dark: Vec<u64>,
}

impl Seen {
    /// Nothing known yet of the `cells` cells of the set starting at `base`.
    pub(super) fn new(base: u32, cells: usize) -> Self {
        let words = cells.div_ceil(64);
        Seen {
            base,
            lit: vec![0; words],
            dark: vec![0; words],
        }
    }

    /// Records cell `k`'s visibility (the share of its light that reached the
    /// vertex): only 1 and 0 are kept.
    pub(super) fn set(&mut self, k: usize, visibility: f32) {
        let (w, bit) = (k / 64, 1u64 << (k % 64));
        if visibility == 1.0 {
            self.lit[w] |= bit;
        } else if visibility == 0.0 {
            self.dark[w] |= bit;
        }
    }
}

/// The coarse vertices a midpoint lies between, as they found the cells.
pub(super) struct Ends<'a> {
    pub(super) seen: [Option<&'a Seen>; 4],
}

impl Ends<'_> {
    /// Cell `k`'s visibility (1 or 0) in the set starting at `base`, where every
    /// end took that set and found the cell alike; `None` where it must be sampled.
    pub(super) fn visibility(&self, base: u32, k: usize) -> Option<f32> {
        let (w, bit) = (k / 64, 1u64 << (k % 64));
        let (mut lit, mut dark) = (true, true);
        let mut any = false;
        for s in self.seen.iter().flatten() {
            if s.base != base {
                return None;
            }
            any = true;
            let (l, d) = (s.lit.get(w)?, s.dark.get(w)?);
            lit &= l & bit != 0;
            dark &= d & bit != 0;
            if !(lit || dark) {
                return None;
            }
        }
        match (any, lit, dark) {
            (true, true, _) => Some(1.0),
            (true, false, true) => Some(0.0),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cell is known at a midpoint only where every end took the same set and saw
    /// all of it (1) or none of it (0); a share between, a disagreement, another
    /// set or no ends at all leave it to be sampled.
    #[test]
    fn a_midpoint_knows_a_cell_only_where_its_ends_agree() {
        let mut a = Seen::new(8, 100);
        let mut b = Seen::new(8, 100);
        for (k, va, vb) in [
            (0, 1.0, 1.0),
            (1, 0.0, 0.0),
            (2, 1.0, 0.0),
            (3, 0.5, 0.5),
            (70, 0.0, 0.0),
            (71, 1.0, 1.0),
        ] {
            a.set(k, va);
            b.set(k, vb);
        }
        let ends = Ends {
            seen: [Some(&a), Some(&b), None, None],
        };
        assert_eq!(ends.visibility(8, 0), Some(1.0));
        assert_eq!(ends.visibility(8, 1), Some(0.0));
        assert_eq!(ends.visibility(8, 2), None, "the ends disagree");
        assert_eq!(ends.visibility(8, 3), None, "partly seen");
        assert_eq!(ends.visibility(8, 70), Some(0.0));
        assert_eq!(ends.visibility(8, 71), Some(1.0));
        assert_eq!(ends.visibility(8, 50), None, "never reached");
        assert_eq!(ends.visibility(0, 0), None, "another set");
        let other = Seen::new(0, 100);
        let mixed = Ends {
            seen: [Some(&a), Some(&other), None, None],
        };
        assert_eq!(mixed.visibility(8, 0), None, "one end took another set");
        let none = Ends { seen: [None; 4] };
        assert_eq!(none.visibility(8, 0), None);
    }
}
