//! Pieces of the mesh that an obstacle stands on between their vertices: a wall on a
//! floor, ceiling or wall that runs on under it into the next room. The radiosity
//! interpolated over such a piece mixes the two rooms' light, so a point on it reads
//! the light of the vertices it sees ([`keep_visible`]), where a photon leaves it and
//! where the render reads the solution ([`Parted`]), and where a patch shot's cell
//! that a wall stands on is read ([`ShotParting`]).
//!
//! `scenes/two-rooms` (a room lit only through a door ajar, its floor, ceiling and
//! side walls running on under the wall into the lit room), FLIP against Mitsuba on
//! render seeds 0 / 1: 0.0350 / 0.0336 before; 0.0314 / 0.0300 with the photons so;
//! 0.0233 / 0.0226 with the render's reads too (Mitsuba's 64 spp: 0.0272). Reads
//! that dropped every hidden vertex, also the darker one under a column, lost the
//! shade where the hall's columns meet its ceiling (FLIP 0.0281 -> 0.0291); now
//! 0.0282. The Cornell box, paper room, glass window, frosted room and staircase
//! within 0.0003, the classroom 0.0805 -> 0.0808 (6,868 parted vertex sets among its
//! 1.95 M pieces: 0.3 s to find, 2026-11-27).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{Accel, Ray};
use crate::mesh::{Interp, Parting, Piece, RadiosityMesh};
use crate::scene::{mean, Rgb};

/// How far above a piece's surface, in its side's lengths, the rays between a point
/// and a vertex pass: an obstacle they meet stands on the piece.
const LIFT: f32 = 0.05;

/// A piece's vertices whose light differs by more than this factor may stand on
/// either side of an obstacle: only such pieces are tested ([`parted_pieces`]).
const CONTRAST: f32 = 2.0;

/// A vertex hidden from a read is another room's light, which the read drops, where
/// its light is more than this factor times what the seen vertices give there
/// ([`keep_seen`]); a dimmer one is the far side of a post or a chair's leg, round
/// which the light reaches. Conference room (render seeds 0 / 1), two rooms: any
/// brighter vertex dropped 0.0355 / 0.0364, 0.0233 / 0.0226; 2x 0.0343 / 0.0352,
/// 0.0234 / 0.0226; 4x 0.0329 / 0.0338, 0.0235 / 0.0227; 8x 0.0324 / 0.0333, 0.0239 /
/// 0.0229 (Mitsuba's 64 spp: 0.0365, 0.0272).
const OTHER_SIDE: f32 = 4.0;

/// The least and greatest light, per channel, of `lights`.
fn spread(lights: impl Iterator<Item = Rgb>) -> (Rgb, Rgb) {
    lights.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), f| {
        (lo.min(f), hi.max(f))
    })
}

/// Whether `lights` differ enough for a set of vertices with those lights to be
/// tested for `drop`: by more than [`CONTRAST`] in the mean over the channels (the
/// reads), or by more than [`OTHER_SIDE`] in some channel (the deposits, which
/// [`Drop::Apart`] changes only then; the margin covers the rounding of the seen
/// vertices' weighted mean). Never true of fewer lights than of more.
fn differ(drop: Drop, lights: impl Iterator<Item = Rgb>) -> bool {
    match drop {
        Drop::Brighter => {
            let (lo, hi) = lights
                .map(mean)
                .fold((f32::INFINITY, 0.0f32), |(lo, hi), l| (lo.min(l), hi.max(l)));
            hi > CONTRAST * lo
        }
        Drop::Apart => {
            let (lo, hi) = spread(lights);
            hi.cmpgt(OTHER_SIDE * (1.0 - 1e-5) * lo).any()
        }
    }
}

/// Which of the vertices an obstacle hides from a point [`keep_seen`] drops.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drop {
    /// Those whose light is more than [`OTHER_SIDE`] times the seen ones' (a read,
    /// or a photon leaving: the darker far side of a post keeps its weight).
    Brighter,
    /// Those whose light differs from the seen ones' by more than that factor either
    /// way (a photon's deposit: it is the other room's, lit or dark).
    Apart,
}

/// The vertices a piece interpolates from (at its centre), sorted, unused slots
/// `u32::MAX`.
type Set = [u32; 4];

/// Whether an obstacle hides `b` from `a`, both lifted by `up`.
fn hidden(accel: &dyn Accel, a: Vec3, b: Vec3, up: Vec3) -> bool {
    let (a, b) = (a + up, b + up);
    accel.occluded(&Ray {
        origin: a,
        dir: b - a,
        tmin: 0.0,
        tmax: 1.0,
    })
}

/// The vertex set of piece `e` and its lift off the surface (along its vertices'
/// normal, [`LIFT`] of the piece's side).
fn piece_set(mesh: &RadiosityMesh, e: &Piece) -> (Set, f32) {
    let c = e.corners;
    let w = mesh.weights_on(e, (c[0] + c[1] + c[2]) / 3.0);
    let mut set = [u32::MAX; 4];
    for (slot, k) in set.iter_mut().zip((0..4).filter(|&k| w.weights[k] > 0.0)) {
        *slot = w.vertices[k];
    }
    set.sort_unstable();
    let side = (0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length()).sqrt();
    (set, (LIFT * side).max(1e-4))
}

/// Whether an obstacle stands between the vertices of `set` (lifted by `lift`), if
/// their light in `field` differs enough for `drop`: by more than [`CONTRAST`] in the
/// mean over the channels (for reads), or by more than [`OTHER_SIDE`] in some
/// channel (for deposits, which [`Drop::Apart`] changes only then); and the rays
/// cast.
fn set_parted(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    set: &Set,
    lift: f32,
    drop: Drop,
) -> (bool, u64) {
    let vs: Vec<u32> = set.iter().copied().filter(|&v| v != u32::MAX).collect();
    if vs.len() < 2 || !differ(drop, vs.iter().map(|&v| field[v as usize])) {
        return (false, 0);
    }
    let pts: Vec<Vec3> = vs.iter().map(|&v| mesh.vertices[v as usize].p).collect();
    any_pair_hidden(accel, &pts, mesh.vertices[vs[0] as usize].n * lift)
}

/// Whether an obstacle stands between some two of the points `pts` (each ray `up`
/// above them), and the rays cast: the test of a vertex set here and of a patch
/// shot's cell (`ShootPoint::from_patch_cell`).
pub(super) fn any_pair_hidden(accel: &dyn Accel, pts: &[Vec3], up: Vec3) -> (bool, u64) {
    let mut rays = 0;
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            rays += 1;
            if hidden(accel, pts[i], pts[j], up) {
                return (true, rays);
            }
        }
    }
    (false, rays)
}

/// The parted vertex sets among `sets` (each tested once, however many pieces share
/// it), with their lifts; and the rays cast.
fn parted_sets(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    mut sets: Vec<(Set, f32)>,
    drop: Drop,
) -> (HashMap<Set, f32>, u64) {
    sets.par_sort_unstable_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
    sets.dedup_by_key(|s| s.0);
    let found: Vec<(Option<(Set, f32)>, u64)> = sets
        .par_iter()
        .with_min_len(256)
        .map(|&(set, lift)| {
            let (parted, rays) = set_parted(mesh, accel, field, &set, lift, drop);
            (parted.then_some((set, lift)), rays)
        })
        .collect();
    let rays = found.iter().map(|f| f.1).sum();
    (found.into_iter().filter_map(|f| f.0).collect(), rays)
}

/// Per piece, whether an obstacle stands on it between its vertices: its vertices'
/// light in `field` differs by more than [`CONTRAST`] and a ray between two of them,
/// [`LIFT`] of its side above it, meets something. Returns the flags and the rays
/// cast.
pub(super) fn parted_pieces(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    pieces: &[Piece],
) -> (Vec<bool>, u64) {
    let sets: Vec<(Set, f32)> = pieces.par_iter().map(|e| piece_set(mesh, e)).collect();
    let (parted, rays) = parted_sets(mesh, accel, field, sets.clone(), Drop::Brighter);
    (sets.iter().map(|s| parted.contains_key(&s.0)).collect(), rays)
}

/// Drops from `w` (the weights at `x`) the vertices that an obstacle hides from `x`
/// (the rays `lift` above the surface) where their light in `field` is more than
/// [`OTHER_SIDE`] times what the seen ones give there in some channel (judged by the
/// mean over the channels, a green room's light passed into a red-lit room next to
/// it: 10 % of the green room's level on the wall's edge rows, 2.4 % so; the
/// repository's scenes within 0.0002 FLIP), and scales the rest back to one:
/// a point on the dark side of a wall does not take the lit side's light, one beside
/// a column keeps the shade of the vertex under it, and one beside a chair's leg the
/// light of the vertex beyond it, which the light reaches round the leg. (Dropping
/// every brighter hidden vertex made the conference room's floor and ceiling 1 %
/// darker: FLIP 0.0308 -> 0.0354 / 0.0364 on render seeds 0 / 1.) With
/// [`Drop::Apart`], a hidden vertex that many times darker goes too. Keeps `w` where
/// it sees none.
/// Returns the rays cast, and whether any vertex was hidden.
fn keep_seen(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    w: &mut Interp,
    x: Vec3,
    lift: f32,
    drop: Drop,
) -> (u64, bool) {
    let mut seen = [true; 4];
    let mut rays = 0;
    let mut up = Vec3::ZERO;
    for (k, seen) in seen.iter_mut().enumerate() {
        if w.weights[k] > 0.0 {
            let v = &mesh.vertices[w.vertices[k] as usize];
            if up == Vec3::ZERO {
                up = v.n * lift;
            }
            rays += 1;
            *seen = !hidden(accel, x, v.p, up);
        }
    }
    let sum: f32 = (0..4).filter(|&k| seen[k]).map(|k| w.weights[k]).sum();
    if seen.iter().all(|&s| s) {
        return (rays, false);
    }
    if !(sum > 0.0) {
        return (rays, true);
    }
    let there: Rgb = (0..4)
        .filter(|&k| seen[k] && w.weights[k] > 0.0)
        .map(|k| w.weights[k] * field[w.vertices[k] as usize])
        .sum::<Rgb>()
        / sum;
    let mut kept = *w;
    for k in 0..4 {
        let hid = field[w.vertices[k] as usize];
        let far = hid.cmpgt(OTHER_SIDE * there).any()
            || (drop == Drop::Apart && there.cmpgt(OTHER_SIDE * hid).any());
        if !seen[k] && far {
            kept.weights[k] = 0.0;
        }
    }
    let total: f32 = kept.weights.iter().sum();
    kept.weights.iter_mut().for_each(|x| *x /= total);
    *w = kept;
    (rays, true)
}

/// [`keep_seen`] at point `x` of a piece of area `area`, for a photon leaving it.
pub(super) fn keep_visible(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    w: &mut Interp,
    x: Vec3,
    area: f32,
) -> u64 {
    keep_seen(
        mesh,
        accel,
        field,
        w,
        x,
        (LIFT * area.sqrt()).max(1e-4),
        Drop::Brighter,
    )
    .0
}

/// The vertices of a whole mesh's parted sets, by the contrast of a field, for
/// reading the field at a point ([`Parted::keep_visible`]).
pub struct Parted {
    /// Per vertex, the lift of the parted sets it is in (0: none).
    lift: Vec<f32>,
    /// The field the sets were found with (what [`keep_seen`] weighs the hidden
    /// vertices' light against, and what the render reads: the total radiosity).
    field: Vec<Rgb>,
}

impl Parted {
    /// The parted sets among every patch's pieces by the contrast of `field`, which
    /// it keeps for the reads ([`Parted::field`]).
    pub fn new(mesh: &RadiosityMesh, accel: &dyn Accel, field: Vec<Rgb>) -> Self {
        Self::found(mesh, accel, field, Drop::Brighter)
    }

    /// The parted sets for [`Parted::keep_apart`]: only those whose vertices' light
    /// in `field` differs by more than [`OTHER_SIDE`] in some channel, since the
    /// deposits change nothing elsewhere. (Listed from every piece and found by
    /// [`CONTRAST`], as the reads' once were, they took 0.31 s of the classroom's
    /// solve, 0.37 s of the staircase's.)
    pub fn for_deposits(mesh: &RadiosityMesh, accel: &dyn Accel, field: Vec<Rgb>) -> Self {
        Self::found(mesh, accel, field, Drop::Apart)
    }

    fn found(mesh: &RadiosityMesh, accel: &dyn Accel, field: Vec<Rgb>, drop: Drop) -> Self {
        // A patch whose vertices' light does not differ enough has no set that does
        // (a set is some of its vertices): its pieces are not listed.
        let differs = |p: u32| {
            let mp = &mesh.patches[p as usize];
            let first = mp.first_vertex as usize;
            let light = field.get(first..first + mp.vertex_count as usize).unwrap_or(&[]);
            differ(drop, light.iter().copied())
        };
        let sets: Vec<(Set, f32)> = (0..mesh.patches.len() as u32)
            .into_par_iter()
            .filter(|&p| differs(p))
            .flat_map_iter(|p| mesh.pieces(p).into_iter().map(|e| piece_set(mesh, &e)))
            .filter(|(set, _)| {
                let light = set.iter().filter(|&&v| v != u32::MAX).map(|&v| field[v as usize]);
                differ(drop, light)
            })
            .collect();
        let (sets, _) = parted_sets(mesh, accel, &field, sets, drop);
        let mut lift = vec![0.0f32; mesh.vertices.len()];
        for (set, &l) in &sets {
            for &v in set.iter().filter(|&&v| v != u32::MAX) {
                lift[v as usize] = lift[v as usize].max(l);
            }
        }
        Parted { lift, field }
    }

    /// The field the sets were found with, per vertex.
    pub fn field(&self) -> &[Rgb] {
        &self.field
    }

    /// Drops from `w` (the weights at `x`) the vertices an obstacle hides from `x`, as
    /// [`keep_seen`] does, where one of them is in a parted set (a read's vertices
    /// need not be a piece's: a grid's reads take a quad, its pieces are triangles).
    /// Returns the rays cast.
    pub fn keep_visible(&self, mesh: &RadiosityMesh, accel: &dyn Accel, w: &mut Interp, x: Vec3) -> u64 {
        self.keep(mesh, accel, w, x, Drop::Brighter)
    }

    /// The weights a photon landing at `x` deposits by: `w` less the vertices an
    /// obstacle hides from `x` whose light in the field differs from the seen ones'
    /// by more than [`OTHER_SIDE`] either way (the other room's, lit or dark), scaled
    /// back to one; as [`Parted::keep_visible`], only where a vertex of `w` is in a
    /// parted set. A deposit by the plain weights sent the light of a photon landing
    /// on a wall that runs on under another wall into the next room to a vertex on
    /// the far side, whose reads (on its own side) took it: a room lit through a door
    /// ajar, its side wall running on into the lit room, showed a band 60 % too
    /// bright along the corner (`scenes/ajar-room`: FLIP against Mitsuba 0.0677 /
    /// 0.0672 -> 0.0592 / 0.0598 on render seeds 0 / 1; with that wall cut at the
    /// corner, as good as this).
    /// Returns the rays cast.
    pub fn keep_apart(&self, mesh: &RadiosityMesh, accel: &dyn Accel, w: &mut Interp, x: Vec3) -> u64 {
        self.keep(mesh, accel, w, x, Drop::Apart)
    }

    /// [`keep_seen`] by `drop`, where a vertex of `w` is in a parted set and their
    /// light differs by more than [`OTHER_SIDE`] in some channel: where it does not,
    /// no hidden vertex could go, and no ray is cast. (That skip halves the deposits'
    /// rays on the wooden staircase, whose balusters part many sets: 1.09 M -> 0.54 M,
    /// beside its photons' own 2.84 M.)
    fn keep(&self, mesh: &RadiosityMesh, accel: &dyn Accel, w: &mut Interp, x: Vec3, drop: Drop) -> u64 {
        let used = || {
            (0..4)
                .filter(|&k| w.weights[k] > 0.0)
                .map(|k| w.vertices[k] as usize)
        };
        let lift = used()
            .map(|v| self.lift.get(v).copied().unwrap_or(0.0))
            .fold(0.0f32, f32::max);
        if !(lift > 0.0) {
            return 0;
        }
        if differ(Drop::Apart, used().filter_map(|v| self.field.get(v).copied())) {
            keep_seen(mesh, accel, &self.field, w, x, lift, drop).0
        } else {
            0
        }
    }
}

/// A patch shot's care over its cells ([`Parting`]). A cell is parted where segments
/// between its quarters' centres, a tenth of the cell's side above the surface, meet
/// something: an obstacle (a wall, not a picture frame) stands on it. A shadow ray
/// from a receiver to a point drawn uniformly in such a cell finds the part on its own
/// side of the obstacle and takes it for the cell's light; where a wall stands on a
/// floor, ceiling or wall that runs on into the next room, the dark side then passed
/// the lit side's light through the wall (`scenes/two-rooms` came out 5 to 30 times
/// too bright: FLIP against Mitsuba 0.196). So a receiver takes a parted cell's light
/// piece by piece (`Solver::parted_light`), and the cell's field is read at each
/// point from the vertices that point sees ([`keep_seen`]): interpolated over an
/// element that the wall stands on, the near side's points took the far side's light.
/// Which pieces had a vertex hidden from a point read is kept
/// ([`crate::mesh::ShootCell::mixed`]): there a receiver reads the field at the points its rays
/// reach.
pub(super) struct ShotParting<'a> {
    mesh: &'a RadiosityMesh,
    accel: &'a dyn Accel,
    field: &'a [Rgb],
    rays: AtomicU64,
}

impl<'a> ShotParting<'a> {
    pub(super) fn new(mesh: &'a RadiosityMesh, accel: &'a dyn Accel, field: &'a [Rgb]) -> Self {
        ShotParting {
            mesh,
            accel,
            field,
            rays: AtomicU64::new(0),
        }
    }

    /// The rays cast so far.
    pub(super) fn rays(&self) -> u64 {
        self.rays.load(Ordering::Relaxed)
    }
}

impl Parting for ShotParting<'_> {
    fn parts(&self, poly: &[Vec3], n: Vec3) -> bool {
        if poly.len() < 3 {
            return false;
        }
        let centre = |k: usize| {
            let (q, len) = crate::mesh::quarter(poly, k);
            q[..len].iter().sum::<Vec3>() / len as f32
        };
        let centres = [centre(0), centre(1), centre(2), centre(3)];
        let lift = n * (0.1 * crate::mesh::vector_area(poly).sqrt()).max(1e-4);
        let (parted, rays) = any_pair_hidden(self.accel, &centres, lift);
        self.rays.fetch_add(rays, Ordering::Relaxed);
        parted
    }

    fn read(&self, w: Interp, x: Vec3) -> (Rgb, bool) {
        let (light, hid, rays) = read_seen(self.mesh, self.accel, self.field, w, x);
        self.rays.fetch_add(rays, Ordering::Relaxed);
        (light, hid)
    }
}

/// `field` at point `x` of a patch shot's parted cell, whose vertices' weights are
/// `w`, read from the vertices `x` sees ([`keep_seen`], the rays a twentieth of the
/// mesh size above the surface): the light, whether a vertex was hidden, the rays.
pub(super) fn read_seen(
    mesh: &RadiosityMesh,
    accel: &dyn Accel,
    field: &[Rgb],
    mut w: Interp,
    x: Vec3,
) -> (Rgb, bool, u64) {
    let lift = (LIFT * mesh.mesh_size).max(1e-4);
    let (rays, hid) = keep_seen(mesh, accel, field, &mut w, x, lift, Drop::Brighter);
    (w.apply(field), hid, rays)
}
