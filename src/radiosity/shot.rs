//! The cells of a shot and what a vertex receives from them: the sets of cells at
//! 1, 4, 16 ... cells (`Levels`), which cells touch (`Touching`), and the shadow rays
//! that sample each cell's visibility from a vertex, more where a shadow's edge
//! crosses the cells (`Solver::gather`).

use glam::{Vec2, Vec3};

use super::coherence::{Ends, Seen};
use super::{transfer, AtVertex, Solver};
use crate::emitters::SampledLight;
use crate::geometry::{point_polygon_form_factor, polygon_vector_form_factor};
use crate::interaction::{ray_epsilon, shadow_ray, transmittance};
use crate::mesh::{point_in_polygon, quarter, quarter_of_sixteenth, sixteenth_of, vector_area, MeshVertex};
use crate::sampling::stratum;
use crate::scene::{mean, Rgb};

/// Shadow rays per vertex to a light at least (see `Solver::gather`). Only where
/// they disagree is the light sampled again, so in a penumbra a vertex whose first
/// rays all see the light passes for lit: with two, one with a tenth of the light
/// hidden did four times in five, and those vertices moved with the seed. Two -> four:
/// the images of two solve seeds (one render seed) 0.0064 -> 0.0039 FLIP apart on the
/// Cornell box, 0.0049 -> 0.0042 on the paper room, 0.0061 -> 0.0047 on the hall, for
/// 0.1-0.3 % more solve rays there (the conference room: 0.77 M, 39 %, more shot rays;
/// FLIP against Mitsuba 0.0335 -> 0.0331).
pub(super) const FIRST_LIGHT_RAYS: u32 = 4;
/// Shadow rays per vertex to a source of few cells that the first rays found partly
/// hidden (see `Solver::gather`).
pub(super) const REFINE_RAYS: u32 = 16;
/// Shadow rays to a cell at a shadow's edge (see `Solver::gather`). One ray per
/// cell left the visibility of a patch's light a coin toss in every cell a shadow's
/// edge crosses: blotches of a few per cent from vertex to vertex, which moved with
/// the seed (paper room: the images of two seeds' solves 0.024 FLIP apart; 0.017 with
/// four rays, 0.016 with eight at half again the rays).
pub(super) const EDGE_RAYS: u32 = 4;
/// Only a cell that brings a vertex at least this share of the source's light there
/// is sampled again at a shadow's edge (a 64-cell set brings 1/64 a cell on average):
/// 15 % fewer rays in the paper room, none of the gain lost.
pub(super) const EDGE_SHARE: f32 = 0.01;
/// Where the edge cells' four rays leave a standard error over this fraction of what
/// the source brings a vertex, the partly hidden ones are sampled again with
/// [`EDGE_RAYS_MORE`] rays (paper room: FLIP against Mitsuba 0.046 -> 0.042 at 37 %
/// more shot rays, the gain spread over the ceiling, the walls and the bookcase; two
/// seeds' solves 0.018 -> 0.017 apart; 0.005 gains 0.0004 more at 3 % more rays).
pub(super) const EDGE_ERROR: f32 = 0.01;
/// See [`EDGE_ERROR`].
pub(super) const EDGE_RAYS_MORE: u32 = 16;

/// The cells of one shot at several resolutions, and the source's bounds: a vertex
/// takes the coarsest set with as many cells as the solid angle it sees the source
/// under asks for (its rays follow the source's solid angle and distance).
pub(super) struct Levels {
    pub(super) sets: Vec<Vec<ShootPoint>>,
    /// Per set, which of its cells touch.
    pub(super) touching: Vec<Touching>,
    /// The shot's seed (receivers derive where they aim from it).
    pub(super) seed: u32,
    pub(super) centre: Vec3,
    pub(super) radius: f32,
    pub(super) area: f32,
    /// A patch shot's field as its cells were cut (the unshot radiosity per vertex),
    /// which near receivers read at the points of parted cells; empty for a light.
    pub(super) field: Vec<Rgb>,
}

impl Levels {
    /// The set a vertex at `x` starts with: a source seen under solid angle w
    /// (estimated as area / distance^2 from its bounding sphere, at most 2 pi) asks
    /// for `w / 2pi * max` cells; the coarsest set with that many is taken.
    ///
    /// Returns the set with which of its cells touch, and the index of its first
    /// cell among all the sets' cells, one set after the other.
    pub(super) fn for_vertex(&self, x: Vec3, max: u32) -> Cells<'_> {
        let d = (x - self.centre).length() - self.radius;
        let want = if d > 0.0 {
            let omega = (self.area / (d * d)).min(2.0 * std::f32::consts::PI);
            omega / (2.0 * std::f32::consts::PI) * max as f32
        } else {
            f32::INFINITY
        };
        let mut base = 0;
        for (i, s) in self.sets.iter().enumerate() {
            if s.len() as f32 >= want || i + 1 == self.sets.len() {
                return Cells {
                    base,
                    points: s,
                    touching: &self.touching[i],
                    field: &self.field,
                };
            }
            base += s.len() as u32;
        }
        Cells {
            base: 0,
            points: &[],
            touching: Touching::NONE,
            field: &[],
        }
    }

    /// Cell `index` among all the sets' cells, one set after the other, and its
    /// index in its set.
    pub(super) fn cell(&self, index: u32) -> Option<(&ShootPoint, u32)> {
        let mut k = index as usize;
        for s in &self.sets {
            if k < s.len() {
                return Some((&s[k], k as u32));
            }
            k -= s.len();
        }
        None
    }

    /// The radiosity of every cell of every set, one set after the other.
    pub(super) fn radiosity(&self) -> Vec<Rgb> {
        self.sets.iter().flatten().map(|sp| sp.radiosity).collect()
    }

    /// The radiosity of every cell's quarters, as [`Self::radiosity`].
    pub(super) fn quarters(&self) -> Vec<[Rgb; 4]> {
        self.sets
            .iter()
            .flatten()
            .map(|sp| sp.quarters.unwrap_or([sp.radiosity; 4]))
            .collect()
    }
}

/// One set of a shot's cells as a vertex takes it: the index of its first cell
/// among all the sets' cells, the cells, and which of them touch.
pub(super) struct Cells<'a> {
    pub(super) base: u32,
    pub(super) points: &'a [ShootPoint],
    pub(super) touching: &'a Touching,
    /// See [`Levels::field`].
    pub(super) field: &'a [Rgb],
}

/// Which cells of a set touch (share a corner). Where two touching cells disagree
/// about whether a receiver sees them, a shadow's edge crosses them (or passes
/// close), and their visibility is sampled again (`Solver::gather`).
pub(super) struct Touching {
    /// Cell k's neighbours are `list[start[k]..start[k + 1]]`.
    pub(super) start: Vec<u32>,
    pub(super) list: Vec<u32>,
}

impl Touching {
    pub(super) const NONE: &'static Touching = &Touching {
        start: Vec::new(),
        list: Vec::new(),
    };

    /// Cells touch when a corner of one is bit for bit a corner of the other: cells
    /// cut from one surface compute a shared corner from the same parameters.
    pub(super) fn new(cells: &[ShootPoint]) -> Self {
        let mut at: std::collections::HashMap<[u32; 3], Vec<u32>> = Default::default();
        for (i, c) in cells.iter().enumerate() {
            for q in &c.poly[..c.len as usize] {
                at.entry(q.to_array().map(f32::to_bits))
                    .or_default()
                    .push(i as u32);
            }
        }
        let mut near: Vec<Vec<u32>> = vec![Vec::new(); cells.len()];
        for group in at.values().filter(|g| g.len() > 1) {
            for &a in group {
                near[a as usize].extend(group.iter().filter(|&&b| b != a));
            }
        }
        let mut t = Touching {
            start: Vec::with_capacity(cells.len() + 1),
            list: Vec::new(),
        };
        for mut n in near {
            n.sort_unstable();
            n.dedup();
            t.start.push(t.list.len() as u32);
            t.list.extend(n);
        }
        t.start.push(t.list.len() as u32);
        t
    }

    /// The cells that touch cell `k`.
    pub(super) fn of(&self, k: usize) -> &[u32] {
        match (self.start.get(k), self.start.get(k + 1)) {
            (Some(&a), Some(&b)) => &self.list[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// Where a shot comes from: a point light, or a cell of an emitting or reflecting
/// surface with the radiosity it sends.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShootPoint {
    /// The light's position, or the jittered point in the cell (shadow rays aim here).
    pub(super) p: Vec3,
    /// The cell's normal (unused for point lights).
    pub(super) n: Vec3,
    /// The cell's corner polygon (`len` 0 for point lights).
    pub(super) poly: [Vec3; 4],
    pub(super) len: u8,
    /// Radiosity the cell emits (for point lights: the intensity).
    pub(super) radiosity: Rgb,
    /// The radiosity of the cell's quarters ([`crate::mesh::quarter`]), for a
    /// patch's cell: a receiver takes each quarter's form factor with its own
    /// radiosity ([`quarter_form_factors_near`]). `None` for a cell that sends alike
    /// from all of it (a light's, the sky's), whose quarters would sum to the
    /// cell's form factor times its radiosity.
    pub(super) quarters: Option<[Rgb; 4]>,
    /// A patch's quadrilateral cell: its light's luminance over its 4 x 4 sixteenths
    /// ([`crate::mesh::ShootCell::sixteenths`]), where a parted cell's rays aim.
    pub(super) sixteenths: Option<[f32; 16]>,
    /// Every point of `poly` is on the surface: each receiver aims at a point of its
    /// own in the cell, not at `p`.
    pub(super) flat: bool,
    /// A cell of the sky ([`sky_cells`]): so large a part of the sphere that its
    /// points are not alike to a receiver, so each ray's visibility counts by the
    /// receiver's kernel there (cosines over squared distance), not equally. It holds
    /// the cell's vector form factor ([`polygon_vector_form_factor`]): so far off, the
    /// cell looks alike from every receiver, and one wholly above a receiver's horizon
    /// has the form factor of its dot product with the receiver's normal (the exact
    /// clipped polygon was a quarter of a daylit room's whole render).
    pub(super) far: Option<Vec3>,
    /// An obstacle stands on the cell (a wall on a floor that runs under it into the
    /// next room, see `parted::ShotParting`): its field was read from the vertices each
    /// point sees, and a receiver takes its light piece by piece
    /// ([`Solver::parted_light`]).
    pub(super) parted: bool,
    /// Of a parted cell, its pieces whose light differs across the obstacle
    /// ([`crate::mesh::ShootCell::mixed`]).
    pub(super) mixed: u16,
    /// A patch's cell: the patch and the grid of it the cell lies on, and what its
    /// light counts for ([`crate::mesh::ShootCell::weight`]).
    pub(super) cell_of: Option<(u32, u32, f32)>,
}

impl ShootPoint {
    /// A cell carrying the field it was cut with (its mean, and its quarters').
    pub(super) fn from_cell(c: &crate::mesh::ShootCell) -> Self {
        ShootPoint {
            p: c.p,
            n: c.n,
            poly: c.corners,
            len: c.len,
            radiosity: c.value * c.weight,
            quarters: Some(c.quarters.map(|q| q * c.weight)),
            sixteenths: c.sixteenths,
            flat: c.flat && c.len >= 3,
            far: None,
            parted: c.parted,
            mixed: c.mixed,
            cell_of: None,
        }
    }

    /// A cell of uniform radiosity (an area light's).
    pub(super) fn uniform(c: &crate::mesh::ShootCell, radiosity: Rgb) -> Self {
        ShootPoint {
            radiosity: radiosity * c.weight,
            quarters: None,
            sixteenths: None,
            ..Self::from_cell(c)
        }
    }

    pub(super) fn point(p: Vec3, intensity: Rgb) -> Self {
        ShootPoint {
            p,
            n: Vec3::ZERO,
            poly: [Vec3::ZERO; 4],
            len: 0,
            radiosity: intensity,
            quarters: None,
            sixteenths: None,
            flat: false,
            far: None,
            parted: false,
            mixed: 0,
            cell_of: None,
        }
    }
}

/// The sky's shooting cells: about `count` squares of a cube about the scene, so far
/// off (10^4 of its radius) that each stands for the directions it covers, facing
/// in, with pi times the sky's mean radiance over those directions as radiosity (a
/// receiver's form factor to a cell is then its solid angle times the cosine over
/// pi). Shadow rays aim at points of their own in each cell, as at an area light's.
pub fn sky_cells(scene: &crate::scene::Scene, count: u32) -> Vec<ShootPoint> {
    if scene.environment().is_none() {
        return Vec::new();
    }
    let (c, r) = crate::emitters::infinite::scene_sphere(scene);
    let d = 1e4 * r;
    let k = ((count as f32 / 6.0).sqrt().round() as u32).max(1);
    let mut out = Vec::with_capacity(6 * (k * k) as usize);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            // The face at `sign` along `axis`, spanned by the other two axes (wound so
            // that its normal points back in).
            let n = Vec3::from_array(std::array::from_fn(|i| if i == axis { sign } else { 0.0 }));
            let (a, b) = (
                Vec3::from_array(std::array::from_fn(|i| f32::from(u8::from(i == (axis + 1) % 3)))),
                Vec3::from_array(std::array::from_fn(|i| f32::from(u8::from(i == (axis + 2) % 3)))),
            );
            let (a, b) = if sign > 0.0 { (b, a) } else { (a, b) };
            for j in 0..k {
                for i in 0..k {
                    let at = |s: f32, t: f32| {
                        c + (n + a * (2.0 * s / k as f32 - 1.0) + b * (2.0 * t / k as f32 - 1.0)) * d
                    };
                    let (s0, t0) = (i as f32, j as f32);
                    let poly = [
                        at(s0, t0),
                        at(s0 + 1.0, t0),
                        at(s0 + 1.0, t0 + 1.0),
                        at(s0, t0 + 1.0),
                    ];
                    // The mean radiance over the cell's directions (a 4 x 4 grid).
                    let mut l = Vec3::ZERO;
                    for q in 0..16 {
                        let (fs, ft) = ((q % 4) as f32 + 0.5, (q / 4) as f32 + 0.5);
                        let p = at(s0 + fs / 4.0, t0 + ft / 4.0);
                        l += scene.sky((p - c).normalize());
                    }
                    let radiosity = l / 16.0 * std::f32::consts::PI;
                    out.push(ShootPoint {
                        p: at(s0 + 0.5, t0 + 0.5),
                        n: -n,
                        poly,
                        len: 4,
                        radiosity,
                        quarters: None,
                        sixteenths: None,
                        flat: true,
                        far: Some(polygon_vector_form_factor(c, &poly)),
                        parted: false,
                        mixed: 0,
                        cell_of: None,
                    });
                }
            }
        }
    }
    out
}

/// The vertex a shot's light is gathered at: the vertex, its seed (which chooses
/// where in each flat cell its shadow rays aim), and for a midpoint, what the
/// coarse vertices about it found ([`super::coherence`]).
pub(super) struct Receiver<'a> {
    pub(super) v: &'a MeshVertex,
    pub(super) seed: u32,
    pub(super) ends: Option<&'a Ends<'a>>,
}

/// What a gather records beside the light: a kept shot's links, and a coarse
/// vertex's visibility of each cell ([`super::coherence`]).
pub(super) struct Found<'a> {
    pub(super) links: Option<&'a mut Vec<transfer::Link>>,
    pub(super) seen: Option<&'a mut Seen>,
}

impl Solver<'_> {
    /// Light from the cells of a shot at a receiver: (occluded, unoccluded)
    /// irradiance and rays.
    ///
    /// The form factor of each cell is exact; its visibility is sampled with
    /// coherence, as the shadow image buffer does it on the screen: `first_rays` over
    /// the set's cells at least (one per cell for patches, [`FIRST_LIGHT_RAYS`] for
    /// lights), stratified within the cells, and more only where they disagree (the
    /// source partly hidden): a source of fewer than [`REFINE_RAYS`] cells is sampled
    /// again with that many stratified rays; in a source of more, a cell that a
    /// touching cell disagrees with (a shadow's edge crosses one of them) is sampled
    /// again with [`EDGE_RAYS`] if it brings at least [`EDGE_SHARE`] of the source's
    /// light, and with [`EDGE_RAYS_MORE`] where those leave a standard error over
    /// [`EDGE_ERROR`] of the source's light at the vertex. A vertex that sees all or none of a source pays the
    /// first rays only.
    ///
    /// At a midpoint, a cell that the coarse vertices about it found alike takes
    /// their visibility and casts no ray, and is not sampled again at an edge
    /// ([`super::coherence`]).
    ///
    /// From a patch, `links` (if given) receives each cell's form factor and
    /// visibility found, with the cell's index in the set plus `base`; `seen` (if
    /// given) which cells the vertex saw whole or not at all.
    pub(super) fn gather(
        &self,
        Cells {
            base,
            points,
            touching,
            field,
        }: Cells<'_>,
        Receiver { v, seed, ends }: Receiver<'_>,
        light: Option<&SampledLight>,
        first_rays: u32,
        Found { mut links, seen }: Found<'_>,
    ) -> AtVertex {
        let (x, n) = (v.q, v.n);
        // Rays through of `per` to cell `k` (one at a point: a light in space, or a
        // curved cell's point), with the one shadow-ray rule of both passes: to a light
        // point in space, or to a point of the shooting cell's surface.
        // Returns the rays that reached the cell, the light they bring (their thin
        // panes' transmittances summed: the hits' count without panes) and `per`.
        let through = |k: usize, per: u32, salt: u32| -> (u32, f32, u32) {
            let sp = &points[k];
            let per = if sp.flat { per } else { 1 };
            let normal = if light.is_some() { None } else { Some(sp.n) };
            let (mut hits, mut light, mut weights) = (0, 0.0, 0.0);
            for j in 0..per {
                let target = if sp.flat {
                    let u = stratum(seed, (k as u32) << 9 | salt << 7, j, per);
                    point_in_polygon(&sp.poly[..sp.len as usize], u)
                } else {
                    sp.p
                };
                let w = if sp.far.is_some() {
                    let d = target - x;
                    let r2 = d.length_squared();
                    (n.dot(d).max(0.0) * (-sp.n.dot(d)).max(0.0) / (r2 * r2)).max(0.0)
                } else {
                    1.0
                };
                weights += w;
                let ray = shadow_ray(x, n, target, normal);
                let t = transmittance(self.scene, self.accel, &ray);
                if t > 0.0 {
                    hits += 1;
                    light += t * w;
                }
            }
            // A sky cell's kernel-weighted share, as a count of `per` rays.
            let light = match (sp.far.is_some(), weights > 0.0) {
                (false, _) => light,
                (true, true) => light / weights * per as f32,
                (true, false) => 0.0,
            };
            (hits, light, per)
        };
        let (mut occ, mut unocc, mut rays) = (Vec3::ZERO, Vec3::ZERO, 0u64);
        let (mut lit, mut hidden) = (false, false);
        // The cells that reach the vertex: each one's index, what it brings, and the
        // visibility its first rays found (the share of them that reached it, and the
        // share of its light they bring: less through thin glass).
        let mut reached: Vec<(usize, Vec3, f32, f32)> = Vec::with_capacity(points.len());
        // Per reached cell, whether the coarse vertices about a midpoint settled it
        // ([`super::coherence`]): no ray is cast to it.
        let mut settled: Vec<bool> = Vec::with_capacity(points.len());
        let per = first_rays
            .div_ceil(points.len().max(1) as u32)
            .next_power_of_two();
        for (k, sp) in points.iter().enumerate() {
            let d = sp.p - x;
            if !(d.length_squared() > 0.0) {
                continue;
            }
            let mut f = 0.0;
            let mut quarter_fs = None;
            // Radiosity is one-sided: a vertex receives on its front (two-sided
            // surfaces have a back twin with the reversed normal).
            let e = if let Some(l) = light {
                match l.point_light_at(x, n) {
                    Some((e, _)) => e,
                    None => continue,
                }
            } else {
                // The cell emits from its front. A receiver in (or within rounding of)
                // the cell's plane sees it edge-on: nothing.
                let h = sp.n.dot(x - sp.p);
                let margin = 4.0 * (ray_epsilon(x) + ray_epsilon(sp.p));
                if h <= margin {
                    continue;
                }
                quarter_fs = quarter_form_factors_near(sp, x, n);
                let poly = &sp.poly[..sp.len as usize];
                f = match (quarter_fs, sp.far) {
                    (Some(q), _) => q.iter().sum(),
                    (None, Some(phi)) if poly.iter().all(|c| n.dot(*c - x) > 0.0) => n.dot(phi).abs(),
                    (None, _) => point_polygon_form_factor(x, n, poly),
                };
                if !(f > 0.0) {
                    continue;
                }
                match (quarter_fs, sp.quarters) {
                    (Some(q), Some(b)) => b.iter().zip(q).map(|(b, f)| *b * f).sum(),
                    _ => sp.radiosity * f,
                }
            };
            let parted = sp.parted && sp.flat && light.is_none();
            // What the cell brings (such that it times `val` is what got through), its
            // visibility, and whether no ray need be cast to it again.
            let (e, vis, val, settles) = if parted {
                // Taken piece by piece, and never sampled again.
                let (e_all, e_seen, vis, cast) = self.parted_light(sp, field, x, n, f, seed, k as u32);
                rays += cast;
                unocc += e_all;
                occ += e_seen;
                let val = if mean(e_all) > 0.0 {
                    mean(e_seen) / mean(e_all)
                } else {
                    0.0
                };
                (if val > 0.0 { e_seen / val } else { e_all }, vis, val, true)
            } else {
                unocc += e;
                let known = ends.and_then(|ends| ends.visibility(base, k));
                let (vis, val) = match known {
                    Some(v) => (v, v),
                    None => {
                        let (hits, light, per) = through(k, per, 0);
                        rays += u64::from(per);
                        (hits as f32 / per as f32, light / per as f32)
                    }
                };
                occ += e * val;
                (e, vis, val, known.is_some())
            };
            lit |= vis > 0.0;
            hidden |= vis < 1.0;
            reached.push((k, e, vis, val));
            settled.push(settles);
            if let Some(l) = links.as_deref_mut() {
                l.push(transfer::Link {
                    cell: base + k as u32,
                    f,
                    vis: val,
                    quarters: quarter_fs,
                    parted,
                });
            }
        }
        // A coarse vertex records the cells it found whole or hidden: every cell
        // where all of them agree, else those inside a lit or a hidden region (its
        // touching cells found alike). A cell at a shadow's edge has a share that
        // its few rays only estimate: an estimate that the midpoints took wherever
        // their coarse vertices' draws agreed would be pulled towards 0 or 1. So
        // is a parted cell's (an obstacle stands on it), whatever its neighbours
        // found: its ray sees the lit side or not by where it was drawn, and a
        // midpoint that took two coarse vertices' agreement would see the cell with
        // odds p^2 (3 - 2p) for their p (half as often at p = 0.2). No change seen on
        // the repository's scenes (the staircase within its seeds' spread).
        let record = |calm: &dyn Fn(usize) -> bool| {
            if let Some(seen) = seen {
                *seen = Seen::new(base, points.len());
                for (i, r) in reached.iter().enumerate() {
                    if calm(i) && !points[r.0].parted {
                        seen.set(r.0, r.3);
                    }
                }
            }
        };
        // The sky's cells (a set is all of them or none).
        let sky = points.first().is_some_and(|p| p.far.is_some());
        if !(lit && hidden) {
            // A vertex whose first rays found none of the sky records nothing: its
            // one ray a cell misses an opening narrower than the cell with odds 1 - p,
            // and its midpoints, which took "hidden" where both coarse vertices had
            // missed (odds (1 - p)^2) and cast no ray, kept a share of the light
            // through it well under p. A room lit through a 0.8 x 0.8 m window by the
            // sky alone came out 10-20 % dark (384 x 256: FLIP against Mitsuba 0.0954
            // / 0.0770 -> 0.0650 / 0.0579, render seeds 0 / 1; the mean of what does
            // not see the sky 0.931 -> 0.982 of Mitsuba's over seeds 0-2; its sky
            // shot's rays 0.82 -> 1.10 M; the test in `tests/cli.rs` on
            // `tests/data/sky-window`); through a 3 x 1.8 m window 0.0494 / 0.0468 ->
            // 0.0505 / 0.0481; the daylit room, the glass window, the brushed room,
            // open ground under a sky and a sunsky room unchanged, at the same time.
            if lit || !sky {
                record(&|_| true);
            }
            return (occ, unocc, rays);
        }
        if reached.len() >= REFINE_RAYS as usize {
            // Many cells: only those at a shadow's edge, where touching cells
            // disagree, are sampled again. `reached` is in cell order, so a touching
            // cell's first visibility is found by a search (if it reached the vertex).
            let first_vis = |j: u32| {
                reached
                    .binary_search_by_key(&(j as usize), |r| r.0)
                    .ok()
                    .map(|s| reached[s].2)
            };
            // Samples the cell of `reached[i]` again with `per` rays of ray set
            // `salt`: the light it brings replaces `old` in the sum and in the link.
            // Returns the share of rays that reached it, the light's and the rays.
            let mut again = |i: usize, old: f32, per: u32, salt: u32, occ: &mut Vec3| {
                let (hits, light, per) = through(reached[i].0, per, salt);
                let now = light / per as f32;
                *occ += reached[i].1 * (now - old);
                if let Some(l) = links.as_deref_mut() {
                    l[i].vis = now;
                }
                (hits as f32 / per as f32, now, u64::from(per))
            };
            let least = mean(unocc) * EDGE_SHARE;
            record(&|i| {
                let (k, _, vis, _) = reached[i];
                touching
                    .of(k)
                    .iter()
                    .all(|&j| first_vis(j).is_none_or(|w| w == vis))
            });
            // The edge cells: index in `reached`, the share of rays that reached it and
            // its light's after their edge rays.
            let mut edges: Vec<(usize, f32, f32)> = Vec::new();
            for (i, &(k, e, vis, val)) in reached.iter().enumerate() {
                // A sky cell is an edge where its touching cells disagree among
                // themselves, whatever its own first ray found: a decision that
                // followed that ray sampled a partly seen cell again only where the ray
                // had got through, and left it dark where it had not (a floor under a
                // 1 m opening in a 3 m ceiling took 17 % too little of the sky).
                // The sky's cells are many and small against what an opening shows; a
                // patch's cells keep the rule they were tuned with, biased as it is
                // (a partly seen cell among hidden ones keeps p^2 of its light for its
                // p, among seen ones p (2 - p)): the sky's rule for them too took back
                // 2 % of the 7-11 % the wooden staircase's room before its arch lacked
                // (seen through the arch, the hall's cells), but left the cells it no
                // longer samples again to one ray's coin toss: FLIP against Mitsuba,
                // paper room 0.0318 -> 0.0325, hall 0.0281 -> 0.0298 (2026-11-27).
                let edge = points[k].flat
                    && !settled[i]
                    && mean(e) > least
                    && if sky {
                        let mut seen_vis = touching.of(k).iter().filter_map(|&j| first_vis(j));
                        seen_vis.next().is_some_and(|v0| seen_vis.any(|w| w != v0))
                    } else {
                        touching
                            .of(k)
                            .iter()
                            .any(|&j| first_vis(j).is_some_and(|w| w != vis))
                    };
                if edge {
                    let (now, light, cast) = again(i, val, EDGE_RAYS, 1, &mut occ);
                    rays += cast;
                    edges.push((i, now, light));
                }
            }
            // The variance the edge cells' rays leave (a fraction p of n rays hit: p (1 -
            // p) / n per cell): where it is over EDGE_ERROR of what the vertex gets,
            // the partly hidden edge cells are sampled again, more densely.
            let var: f32 = edges
                .iter()
                .map(|&(i, p, _)| mean(reached[i].1).powi(2) * p * (1.0 - p) / EDGE_RAYS as f32)
                .sum();
            if var > (EDGE_ERROR * mean(occ)).powi(2) {
                // All of the sky's edge cells, for the same reason: the partly hidden
                // ones alone would leave dark a cell whose edge rays all missed.
                for &(i, _, light) in edges.iter().filter(|e| sky || (e.1 > 0.0 && e.1 < 1.0)) {
                    rays += again(i, light, EDGE_RAYS_MORE, 2, &mut occ).2;
                }
            }
            return (occ, unocc, rays);
        }
        let per = REFINE_RAYS.div_ceil(reached.len() as u32).next_power_of_two();
        let mut refined = Vec3::ZERO;
        for (i, &(k, e, _, val)) in reached.iter().enumerate() {
            if settled[i] {
                refined += e * val;
                continue;
            }
            let (_, light, per) = through(k, per, 1);
            rays += u64::from(per);
            let val = light / per as f32;
            refined += e * val;
            if let Some(l) = links.as_deref_mut() {
                l[i].vis = val;
            }
        }
        // A source of few cells, partly hidden: nothing recorded.
        record(&|_| false);
        (refined, unocc, rays)
    }
}

/// A receiver takes a cell's light by quarters within this many of the cell's
/// diagonals of its centre (see [`quarter_form_factors_near`]).
const QUARTERS_WITHIN: f32 = 3.0;

/// The form factors from a receiver at `x` (normal `n`) to the quarters of a flat
/// cell within [`QUARTERS_WITHIN`] of it (their sum is the cell's), else `None`.
/// Such a receiver takes the cell's light as the sum over its quarters of each one's
/// radiosity times its form factor (and a kept shot's links keep the four), not the
/// mean radiosity times the cell's form factor, since it sees the cell's parts under
/// very different angles. In a concave corner, where the light falls off into the
/// edge, the mean lit the next wall's edge too brightly (Cornell box: the ceiling 1 cm
/// from the back wall 20 % bright against a path-traced estimate). Cornell box FLIP
/// against Mitsuba: `draft` 0.0357 -> 0.0282, `good` 0.0244 -> 0.0208; paper room view
/// a `draft` 0.0430 -> 0.0404, `good` 0.0388 -> 0.0380; for 3-10 % more time, the
/// conference room's solve 12.0 -> 14.2 s. Within 8 diagonals: 0.0269, 0.0198,
/// 0.0391, 0.0362, but the conference's solve 15.8 s.
fn quarter_form_factors_near(sp: &ShootPoint, x: Vec3, n: Vec3) -> Option<[f32; 4]> {
    // The cell's geometry alone decides (not its light, nor its jittered point), so
    // that a kept shot's links stay valid for the patch's next shots. A light's or
    // the sky's cell sends alike from all of it: its quarters would change nothing
    // but the cost (the sky's far cells all counted as near, and took four clipped
    // form factors each).
    if !sp.flat || sp.quarters.is_none() {
        return None;
    }
    let poly = &sp.poly[..sp.len as usize];
    if !within_diagonals(poly, x, QUARTERS_WITHIN) {
        return None;
    }
    Some(super::quarter_form_factors(x, n, poly).unwrap_or_else(|| {
        std::array::from_fn(|k| {
            let (corners, len) = crate::mesh::quarter(poly, k);
            point_polygon_form_factor(x, n, &corners[..len])
        })
    }))
}

/// A receiver within this many of a parted cell's diagonals of its centre takes the
/// cell piece by piece with a ray each (see `Solver::parted_light`). Two rooms, the
/// same with a lamp in each room, the frosted room (FLIP against Mitsuba, render seeds
/// 0 / 1): within 0.5 0.0236 / 0.0207, 0.0289 / 0.0299, 0.0316 / 0.0325; 1 0.0237 /
/// 0.0207, 0.0289 / 0.0300, 0.0316 / 0.0325; 3 0.0236 / 0.0207, 0.0288 / 0.0299,
/// 0.0315 / 0.0326, the two rooms' solve 1.31 M -> 1.70 M shadow rays (the near receivers' reads
/// not counted; with them, at 1, 1.53 M).
const PARTED_NEAR: f32 = 1.0;

/// Whether `x` lies within `k` of the cell `poly`'s diagonals (corner 0 to 2) of its
/// centre.
fn within_diagonals(poly: &[Vec3], x: Vec3, k: f32) -> bool {
    let diagonal = (poly[2] - poly[0]).length_squared();
    let centre = poly.iter().sum::<Vec3>() / poly.len() as f32;
    (centre - x).length_squared() <= k * k * diagonal
}

/// Shadow rays from a receiver farther than [`PARTED_NEAR`] to a parted cell (see
/// `Solver::parted_light`).
const PARTED_FAR_RAYS: u32 = 4;

impl Solver<'_> {
    /// The light of a parted cell `sp` (number `k` of its set) at a receiver at `x`
    /// facing `n`, whose form factor to the whole cell is `f`: (the light the receiver
    /// gets unoccluded, the light that gets through, the share of shadow rays that got
    /// through, the rays cast, shadow rays and reads').
    ///
    /// Piece by piece (a quadrilateral's 4 x 4 sixteenths, a triangle's quarters):
    /// each piece's light times its form factor, seen through shadow rays to points of
    /// the pieces in front of the receiver. Rays drawn over the whole cell by its
    /// light found the receiver's own side of the obstacle as seldom as the far side's
    /// light outweighs the near side's, and where both sides were lit left the near
    /// side's receivers too little (two rooms each with its own lamp, floor and
    /// ceiling running under the wall between them: 5 % dark over the near room,
    /// 10-14 % on its ceiling). Within [`PARTED_NEAR`] every piece takes a ray,
    /// its exact form factor (clipped to the receiver's horizon), and where the
    /// obstacle stands on it ([`ShootPoint::mixed`]) its light read at the ray's point
    /// from the vertices that point sees (`field`, [`super::parted::keep_visible`]): a
    /// receiver beside the obstacle's foot sees the near side's sliver of a piece
    /// whose mean light is much the far side's. Farther, the pieces' form factors as
    /// discs ([`disc_form_factor`]) scaled to `f`, and [`PARTED_FAR_RAYS`] rays drawn
    /// over the pieces by their light times form factor, stratified, each bringing the
    /// light read at its point where the obstacle stands on its piece (the two rooms'
    /// near side came out bright by the mean of such pieces otherwise: FLIP 0.0313 /
    /// 0.0290 -> 0.0223 / 0.0200).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn parted_light(
        &self,
        sp: &ShootPoint,
        field: &[Rgb],
        x: Vec3,
        n: Vec3,
        f: f32,
        seed: u32,
        k: u32,
    ) -> (Rgb, Rgb, f32, u64) {
        let poly = &sp.poly[..sp.len as usize];
        let pieces = if poly.len() == 4 { 16 } else { 4 };
        let near = within_diagonals(poly, x, PARTED_NEAR);
        let b = sp.quarters.unwrap_or([sp.radiosity; 4]);
        let margin = 4.0 * (ray_epsilon(x) + ray_epsilon(sp.p));
        // Each piece's light as the cell was read and its form factor.
        let mut light = [Rgb::ZERO; 16];
        let mut ff = [0.0f32; 16];
        for i in 0..pieces {
            let (piece, len) = piece_polygon(poly, i);
            let piece = &piece[..len];
            ff[i] = if near {
                point_polygon_form_factor(x, n, piece)
            } else {
                let centre = piece.iter().sum::<Vec3>() / len as f32;
                disc_form_factor(x, n, sp.n, vector_area(piece), centre)
            };
            light[i] = match sp.sixteenths.filter(|_| pieces == 16) {
                Some(six) => {
                    let (q, _) = quarter_of_sixteenth(i);
                    let sum: f32 = (0..4).map(|m| six[sixteenth_of(q, m)].max(0.0)).sum();
                    if sum > 0.0 {
                        b[q] * (4.0 * six[i].max(0.0) / sum)
                    } else {
                        b[q]
                    }
                }
                None => b[i % 4],
            };
        }
        // A point of piece `i` in front of the receiver (of the piece cut off by its
        // horizon, uniformly) at draw `t`: none in eight draws leaves a sliver out.
        let front = |i: usize, t: u32| {
            (0..8u32)
                .map(|a| {
                    piece_point(
                        poly,
                        i,
                        stratum(seed, (k << 4 | i as u32) << 13 | t << 10 | a << 7, 0, 1),
                    )
                })
                .find(|y| n.dot(*y - x) > margin)
        };
        // The light at point `y` of piece `i`: where the obstacle stands on the piece,
        // read from the vertices `y` sees.
        let read_rays = std::cell::Cell::new(0u64);
        let read = |i: usize, y: Vec3| match sp.cell_of {
            Some((patch, grid, weight)) if !field.is_empty() && sp.mixed & 1 << i != 0 => {
                match self.mesh.flat_interp(patch, grid, y) {
                    Some(w) => {
                        let (l, _, rays) = super::parted::read_seen(&self.mesh, self.accel, field, w, y);
                        read_rays.set(read_rays.get() + rays);
                        l * weight
                    }
                    None => light[i],
                }
            }
            _ => light[i],
        };
        let through = |y: Vec3| transmittance(self.scene, self.accel, &shadow_ray(x, n, y, Some(sp.n)));
        let (mut all, mut seen, mut hits, mut cast) = (Rgb::ZERO, Rgb::ZERO, 0u32, 0u64);
        if near {
            for i in (0..pieces).filter(|&i| ff[i] > 0.0) {
                let Some(y) = front(i, 0) else {
                    continue;
                };
                let light = read(i, y);
                all += light * ff[i];
                cast += 1;
                let t = through(y);
                if t > 0.0 {
                    hits += 1;
                    seen += light * (ff[i] * t);
                }
            }
        } else {
            let w: [f32; 16] = std::array::from_fn(|i| mean(light[i]).max(0.0) * ff[i]);
            let total: f32 = w.iter().sum();
            let sum_ff: f32 = ff.iter().sum();
            if !(total > 0.0) || !(sum_ff > 0.0) {
                return (Rgb::ZERO, Rgb::ZERO, 0.0, 0);
            }
            all = (0..pieces).map(|i| light[i] * ff[i]).sum::<Rgb>();
            // Systematic draws over the pieces' weights.
            let start = stratum(seed, k << 17 | 7 << 10, 0, 1).x;
            let (mut i, mut below) = (0, 0.0);
            for j in 0..PARTED_FAR_RAYS {
                let at = (j as f32 + start) / PARTED_FAR_RAYS as f32 * total;
                while i + 1 < pieces && below + w[i] <= at {
                    below += w[i];
                    i += 1;
                }
                cast += 1;
                let Some(y) = front(i, j + 1).filter(|_| w[i] > 0.0) else {
                    continue;
                };
                let t = through(y);
                if t > 0.0 {
                    hits += 1;
                    // The piece's light over its chance, per ray.
                    seen += read(i, y) * (ff[i] * t * total / (w[i] * PARTED_FAR_RAYS as f32));
                }
            }
            all *= f / sum_ff;
            seen *= f / sum_ff;
        }
        let vis = if cast > 0 { hits as f32 / cast as f32 } else { 0.0 };
        (all, seen, vis, cast + read_rays.get())
    }
}

/// Piece `i` of a parted cell `poly` (see `Solver::parted_light`): a quadrilateral's
/// sixteenth `i` (as [`crate::mesh::ShootCell::sixteenths`]), a triangle's quarter.
pub(super) fn piece_polygon(poly: &[Vec3], i: usize) -> ([Vec3; 4], usize) {
    if poly.len() == 4 {
        let (q, m) = quarter_of_sixteenth(i);
        let (c, _) = quarter(poly, q);
        quarter(&c, m)
    } else {
        quarter(poly, i)
    }
}

/// The point at draw `u` of piece `i` of a parted cell `poly` ([`piece_polygon`]).
pub(super) fn piece_point(poly: &[Vec3], i: usize, u: Vec2) -> Vec3 {
    if poly.len() == 4 {
        let (col, row) = ((i % 4) as f32, (i / 4) as f32);
        point_in_polygon(poly, Vec2::new((col + u.x) / 4.0, (row + u.y) / 4.0))
    } else {
        let (c, _) = quarter(poly, i);
        point_in_polygon(&c[..3], u)
    }
}

/// The form factor from a receiver at `x` facing `n` to a piece of area `area` about
/// `y` facing `ny`, as a disc's seen along its axis: cos cos area / (pi r^2 + area),
/// bounded as the receiver comes close.
fn disc_form_factor(x: Vec3, n: Vec3, ny: Vec3, area: f32, y: Vec3) -> f32 {
    let d = y - x;
    let r2 = d.length_squared();
    let cos_cos = n.dot(d).max(0.0) * (-ny.dot(d)).max(0.0) / r2.max(f32::MIN_POSITIVE);
    cos_cos * area / (std::f32::consts::PI * r2 + area)
}
