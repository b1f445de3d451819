//! Pass 1 (paper Sect. 6): progressive-refinement radiosity ("shooting", Cohen et
//! al. 1988) that keeps the strongest sources apart.
//!
//! Light sources shoot first, strongest first; then the patch with the most unshot
//! power, while one patch holds at least `tolerance` of the power the lights brought
//! to reflecting surfaces (or of the emitted power, if less). Every shot
//! goes from cells on the source to every mesh vertex with an exact form factor per
//! cell and shadow rays to it (Wallace et al. 1989); a vertex takes as many cells as
//! the solid angle it sees the source under asks for (`Levels`), so its rays follow
//! the source's size and distance, at least two rays to a light, sixteen where a
//! source of few cells is partly hidden, and four or sixteen to each cell at a
//! shadow's edge across a source of many (module `shot`; the form factor in
//! `form_factor`). A patch shot again
//! reuses the form factors and visibility of its first shot and casts no rays
//! (module `transfer`). What the shots leave unshot is carried by photons (module
//! `photons`), whose cost follows the rays they cast. Each patch keeps a list of at most `n` sources whose
//! contributions it stores separately, per vertex, both occluded and unoccluded; all
//! other light goes into the vertex's *general radiosity*. A source that drops out of a
//! list is folded into the general radiosity of that patch, so every source reaches a
//! vertex by exactly one route. Further shooting always uses the total.
//!
//! Lights are pinned in the lists: a radiant patch never evicts a light. With `n` at
//! least the number of lights, every light's contribution stays apart on every patch
//! it reaches, which the render methods `norm`, `local` and `global` rely on.

use std::collections::BTreeSet;
use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::accel::Accel;
use crate::emitters::{light_power, SampledLight};
use crate::mesh::{Midpoints, Piece, RadiosityMesh};
use crate::progress::Progress;
use crate::sampling::{derive, Alias, Stream};
use crate::scene::{mean, Light, Rgb, Scene};
use crate::{Error, Result};

mod coherence;
mod form_factor;
mod noise;
mod parted;
pub use parted::Parted;
mod photons;
mod project;
mod shot;
mod transfer;

pub use form_factor::quarter_form_factors;
/// The sky is cut into this many times `--shoot-samples` cells (it surrounds every
/// receiver: coarser cells leave blotches where a window shows a few of them).
const SKY_CELLS_PER_SAMPLE: u32 = 4;

use coherence::{Ends, Seen};
use shot::{sky_cells, Found, Levels, Receiver, ShootPoint, Touching, FIRST_LIGHT_RAYS};

/// What a ray of a deterministic patch shot is worth in photon rays: a patch shot that
/// casts rays goes ahead only while it carries at least 1 / `SHOT_RAY_WORTH` of the
/// power per ray that the photon budget (`--max-photons`, two rays a photon) would
/// carry per ray (all the unshot power over its rays), else the photons take the
/// rest. A shot leaves no noise and no deposit's bias, so it is worth more than a
/// photon's ray; but where every shot reaches a large mesh (the conference room's
/// 208 k vertices, 5-12 M rays a shot for 2-4 % of the power) the photons carry it
/// for a fiftieth of the rays. The budget, not the photons a level asks for, is the
/// yardstick: `draft`'s 16 photons a vertex would make photons look cheap where they
/// are only few (the Cornell box's `draft` lost its shots: FLIP 0.0283 -> 0.0463).
/// Shots' power per ray against the budget's at the time (the budget's over the shot's;
/// 2026-11-27, shots that cast rays): Cornell box 2.1 at most, hall 2.0, paper room 2.1
/// (2.9 at `final`), the other repository scenes under 1.5; the wooden staircase
/// 3.1-6.2 (60 k vertices, every surface a rough plastic); the conference room 15-40.
/// So 3 keeps every shot of the first and none of the last two. At 8 the staircase shot
/// 9 patches, 5 s of its 12 s solve, and the room before its arch, lit through the
/// arch, came out 7-11 % darker than Mitsuba's (its photons alone: within 0-4 %). A
/// third of that is a bias of the shots' rays: a patch's cell is sampled again only
/// where its own first ray disagrees with its neighbours', so a partly seen cell among
/// hidden ones keeps p^2 of its light for its p (see `Solver::gather`), and a hall seen
/// through an opening has many such; 16 rays a cell, no edge rule, no coherence, took
/// back 2-3 % of it; the rest was not found. Staircase FLIP against Mitsuba 0.0680 /
/// 0.0687 -> 0.0635 / 0.0635 (render seeds 0 / 1; Mitsuba's 64 spp 0.0650), the whole
/// render 28 -> 23 s. Conference at 8: solve 11.6 s -> 2.5 s, FLIP 0.0331 -> 0.0340
/// (its shots' ratio was measured 15-40 then too). No budget (`--max-photons 0`), no
/// rule.
///
/// However much of the light the lights' shots leave: the classroom (229 k vertices,
/// 64 % left after its three spots) shot 11 dear patches for 6.8 s of its 15 s solve
/// while photons carried it for FLIP within seed noise (0.0809 / 0.0815 -> 0.0816 /
/// 0.0810), and the Cornell box at `--mesh-size 0.025` (101 k vertices, 48 % left)
/// 0.0245 / 0.0250 -> 0.0247 / 0.0250 in 4.2 -> 2.4 s. (Until 2026-11-27 the photons
/// took over only once a third was left: with the gather reading them they had lit
/// that box's ceiling 30 % too bright, FLIP 0.119, a bias since gone.) Without the
/// gather (`draft`), which reads the solution at the eye, that box is a little worse
/// (0.0359 -> 0.0386, 1.9 -> 1.75 s).
const SHOT_RAY_WORTH: f64 = 3.0;

/// [`SHOT_RAY_WORTH`] where the solution is read through a final gather: a shot's ray
/// is worth a photon's. The gather's rays (128 in `good`) read the solution at many
/// points round each gather point, so the photons' noise, which the worth above
/// guards against where the eye reads the solution directly, is mostly averaged
/// away. 2026-11-28, FLIP against Mitsuba (render seeds 0 / 1) and whole-process
/// seconds, worth 3 -> 1: Cornell box 0.0225 / 0.0224 -> 0.0234 / 0.0230, 0.95 ->
/// 0.45 s; paper room (256 x 256) 0.0304 / 0.0310 -> 0.0308 / 0.0311, 2.75 -> 1.12 s;
/// the hall 0.0255 / 0.0255 -> 0.0263 / 0.0263, 1.9 -> 1.4 s; two lamps 0.0262 /
/// 0.0285 -> 0.0243 / 0.0238, 1.0 -> 0.86 s; the desk hall 0.0549 / 0.0549 -> 0.0549 /
/// 0.0553, 1.7 -> 1.33 s; the other scenes in `scenes/` shoot the same patches (their
/// shots are cheap) or none. At 0.5 the two rooms' wall lost its shots (0.0195 ->
/// 0.0220) and the glass window too (0.0416 -> 0.0450). Without a gather (`draft`)
/// the Cornell box at worth 1 fell from 0.0313 / 0.0300 to 0.0456 / 0.0450.
const GATHERED_SHOT_RAY_WORTH: f64 = 1.0;

/// The photon budget that [`SHOT_RAY_WORTH`] weighs a patch shot against is
/// `--max-photons`, but at most this many: so a cap above it buys photons without
/// moving which shots are dear (with the budget itself as the yardstick, the
/// conference room could not take more photons without more patch shots elsewhere).
const SHOT_YARDSTICK_PHOTONS: u64 = 1_000_000;

/// The lights' photons (in a scene with mirrors) at least and at most, as multiples
/// of the patches' (see `Solver::photons`).
const MIN_LIGHT_PHOTONS: f64 = 1.0 / 16.0;
/// See [`MIN_LIGHT_PHOTONS`].
const MAX_LIGHT_PHOTONS: f64 = 4.0;

/// What shot light: a light source of the scene or a radiant patch of the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub enum SourceId {
    /// Index into [`Scene::lights`].
    Light(u32),
    /// Index into [`RadiosityMesh::patches`].
    Patch(u32),
}

/// Settings of the radiosity pass.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolveSettings {
    /// Largest element edge (world units).
    pub mesh_size: f32,
    /// n: sources kept apart per patch.
    pub sources_per_patch: u32,
    /// Most cells of an area light or a shooting patch in a shot (for a vertex that
    /// sees it under the whole hemisphere).
    pub shoot_samples: u32,
    /// Deterministic shots stop when the unshot power falls below this fraction of
    /// the emitted power, or, with photons, when no patch holds this fraction.
    pub tolerance: f32,
    /// Deterministic patch shots at most.
    pub max_shots: u32,
    /// Seed for the sample points.
    pub seed: u64,
    /// Photons per mesh vertex that carry what the deterministic shots leave unshot
    /// (0: it stays unshot).
    #[serde(default)]
    pub photons: u32,
    /// Photons from the patches at most (0: no cap): on a model of hundreds of
    /// thousands of vertices the photons per vertex would cost more than the rest of
    /// the render. In a scene with mirrors the lights' photons come beside them (a
    /// sixteenth to four times as many; see `Solver::photons`).
    #[serde(default)]
    pub max_photons: u64,
    /// Wall-clock budget in seconds (0: none): the deterministic shots stop at half of
    /// it, the photons at all of it (those traced then stand for all).
    #[serde(default)]
    pub time_limit: f32,
    /// The solution is read through a final gather (the render's `--gather` above 0),
    /// which averages the photons' noise over its rays: a dear patch shot then gives
    /// way to photons sooner ([`GATHERED_SHOT_RAY_WORTH`]).
    #[serde(default)]
    pub gathered: bool,
}

impl SolveSettings {
    /// Checks the settings; the error names the command line's flag.
    pub fn validate(&self) -> Result<()> {
        if !(self.mesh_size.is_finite() && self.mesh_size > 0.0) {
            return Err(Error::Usage(format!(
                "--mesh-size {}: must be a positive length",
                self.mesh_size
            )));
        }
        if !(0.0..=1.0).contains(&self.tolerance) {
            return Err(Error::Usage(format!(
                "--solve-tolerance {}: must be a fraction between 0 and 1",
                self.tolerance
            )));
        }
        if self.sources_per_patch > 64 {
            return Err(Error::Usage(format!(
                "--sources-per-patch {}: must be at most 64",
                self.sources_per_patch
            )));
        }
        if !(self.time_limit.is_finite() && self.time_limit >= 0.0) {
            return Err(Error::Usage(format!(
                "--solve-time {}: must be a number of seconds, 0 or more",
                self.time_limit
            )));
        }
        if self.photons > 1_000_000 {
            return Err(Error::Usage(format!(
                "--photons {}: must be at most 1000000 per vertex",
                self.photons
            )));
        }
        if self.shoot_samples < 1 {
            return Err(Error::Usage(format!(
                "--shoot-samples {}: must be at least 1",
                self.shoot_samples
            )));
        }
        Ok(())
    }
}

/// One source kept apart on a patch: its contribution at each of the patch's vertices.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ListEntry {
    /// The source.
    pub source: SourceId,
    /// Reflected radiosity from this source at each vertex, with visibility.
    pub occluded: Vec<Rgb>,
    /// The same without visibility (as if nothing were in the way).
    pub unoccluded: Vec<Rgb>,
    /// Power (unoccluded, reflected) this source brings to the patch: its rank.
    pub power: f32,
}

/// Figures of a solve.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct SolveStats {
    /// Shots from light sources.
    pub light_shots: u64,
    /// Shots from patches.
    pub patch_shots: u64,
    /// Patch shots that reused the form factors and visibility of the patch's first
    /// shot (see `transfer`): no rays.
    #[serde(default)]
    pub reused_shots: u64,
    /// Rays cast (shadow rays between shooting points and vertices).
    pub rays: u64,
    /// Mesh elements.
    pub elements: u64,
    /// Mesh vertices.
    pub vertices: u64,
    /// Patches.
    pub patches: u64,
    /// Patches meshed finer than the mesh size: they hold a small object, or lie
    /// near a small light.
    #[serde(default)]
    pub refined_patches: u64,
    /// Power emitted by all light sources (mean of RGB, W).
    pub emitted_power: f64,
    /// Unshot power left, as a fraction of the reference power.
    pub residual: f64,
    /// What `residual` is a fraction of: the power the lights brought to reflecting
    /// surfaces, or the emitted power if less.
    #[serde(default)]
    pub reference_power: f64,
    /// Wall seconds.
    pub time_s: f64,
    /// Photons traced in the stochastic part.
    #[serde(default)]
    pub photons: u64,
    /// Rays the photons cast.
    #[serde(default)]
    pub photon_rays: u64,
    /// Whether the time budget cut the solve short.
    #[serde(default)]
    pub timed_out: bool,
}

/// The view-independent result of pass 1.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The mesh the values live on.
    pub mesh: RadiosityMesh,
    /// The settings it was computed with.
    pub settings: SolveSettings,
    /// General radiosity per vertex: everything not kept apart.
    pub general: Vec<Rgb>,
    /// The part of `general` that came from a light by way of mirrors only (light ->
    /// mirror -> this vertex), per vertex; empty without such light. A final gather
    /// cannot find it from a point or spot light, so it keeps it
    /// ([`crate::render::gather`]).
    pub caustic: Vec<Rgb>,
    /// Per patch, the sources kept apart.
    pub lists: Vec<Vec<ListEntry>>,
    /// Figures.
    pub stats: SolveStats,
}

impl Solution {
    /// Total reflected radiosity per vertex: general plus every listed source.
    pub fn total(&self) -> Vec<Rgb> {
        total_radiosity(&self.mesh, &self.general, &self.lists)
    }
}

/// Per vertex, the general radiosity plus the occluded light of every source its
/// patch keeps apart: all the light the vertex has.
fn total_radiosity(mesh: &RadiosityMesh, general: &[Rgb], lists: &[Vec<ListEntry>]) -> Vec<Rgb> {
    let mut t = general.to_vec();
    for (p, list) in lists.iter().enumerate() {
        let first = mesh.patches[p].first_vertex as usize;
        for e in list {
            for (k, c) in e.occluded.iter().enumerate() {
                t[first + k] += *c;
            }
        }
    }
    t
}

/// Runs pass 1. `progress` hears the shot fraction of power, in thousandths.
pub fn solve(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &SolveSettings,
    progress: &dyn Progress,
) -> Result<Solution> {
    Ok(solve_inner(scene, accel, settings, progress, false, transfer::BUDGET)?.0)
}

/// [`solve`], also returning for each patch the sources whose light went into its
/// general radiosity (for checking that no source reaches a patch by two routes).
#[cfg(test)]
pub(crate) fn solve_traced(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &SolveSettings,
    progress: &dyn Progress,
) -> Result<(Solution, Vec<BTreeSet<SourceId>>)> {
    solve_inner(scene, accel, settings, progress, true, transfer::BUDGET)
}

/// [`solve`] keeping patch shots within `budget` bytes (0: none kept; see
/// `transfer`).
#[cfg(test)]
pub(crate) fn solve_keeping(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &SolveSettings,
    budget: usize,
) -> Result<Solution> {
    Ok(solve_inner(scene, accel, settings, &crate::progress::Silent, false, budget)?.0)
}

fn solve_inner(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &SolveSettings,
    progress: &dyn Progress,
    trace: bool,
    keep_bytes: usize,
) -> Result<(Solution, Vec<BTreeSet<SourceId>>)> {
    settings.validate()?;
    let start = Instant::now();
    let mesh = RadiosityMesh::build_covered(scene, settings.mesh_size, accel);
    let nv = mesh.vertices.len();
    progress.start("solve", 1000);
    let mut s = Solver {
        scene,
        accel,
        settings,
        general: vec![Vec3::ZERO; nv],
        caustic: Vec::new(),
        unshot: vec![Vec3::ZERO; nv],
        shot: vec![Vec3::ZERO; nv],
        lists: vec![Vec::new(); mesh.patches.len()],
        folded: vec![BTreeSet::new(); mesh.patches.len()],
        kept: transfer::Kept::new(mesh.patches.len(), keep_bytes),
        midpoints: Midpoints::of(&mesh),
        cell_rays: Default::default(),
        stats: SolveStats {
            elements: mesh.element_count() as u64,
            vertices: nv as u64,
            patches: mesh.patches.len() as u64,
            refined_patches: u64::from(mesh.refined),
            ..Default::default()
        },
        mesh,
    };
    let power: Vec<f64> = scene.lights.iter().map(|l| light_power(scene, l)).collect();
    let emitted: f64 = power.iter().sum();
    s.stats.emitted_power = emitted;

    // Lights first, strongest first.
    let mut order: Vec<usize> = (0..scene.lights.len()).collect();
    order.sort_by(|&a, &b| power[b].total_cmp(&power[a]));
    for l in order {
        let levels = s.levels(|s, k| s.light_points(l as u32, k));
        s.shoot(SourceId::Light(l as u32), &levels);
        s.stats.light_shots += 1;
    }
    let budget = f64::from(settings.time_limit);
    let shots_budget = if settings.photons > 0 {
        budget / 2.0
    } else {
        budget
    };

    // Then radiant patches, the most unshot power first.
    let mut patch_power: Vec<f64> = (0..s.mesh.patches.len()).map(|p| s.unshot_power(p)).collect();
    // What the tolerance is a fraction of: the power the lights brought to the
    // surfaces that reflect (their reflected power over their reflectance), or the
    // emitted power if less. The same in a closed room; far less under a sky dome,
    // an emitting sphere that sends most of its power to its own black inside, which
    // would otherwise leave the whole of the scene's reflected light to the photons.
    let received: f64 = patch_power
        .iter()
        .zip(&s.mesh.patches)
        .map(|(w, p)| {
            let rho = f64::from(mean(p.reflectance));
            if rho > 0.0 {
                w / rho
            } else {
                0.0
            }
        })
        .sum();
    let reference = if received > 0.0 {
        emitted.min(received)
    } else {
        emitted
    };
    s.stats.reference_power = reference;
    // What the photon budget costs (two rays a photon, about), and what a shot cost
    // per receiving vertex last time.
    let receiving = s.receiving();
    let photon_rays = if settings.photons > 0 {
        2.0 * settings.max_photons.min(SHOT_YARDSTICK_PHOTONS) as f64
    } else {
        0.0
    };
    let mut rays_per_receiver: Option<f64> = None;
    let worth = match settings.gathered {
        true => GATHERED_SHOT_RAY_WORTH,
        false => SHOT_RAY_WORTH,
    };
    loop {
        let total: f64 = patch_power.iter().sum();
        s.stats.residual = if reference > 0.0 { total / reference } else { 0.0 };
        progress.set(((1.0 - s.stats.residual).clamp(0.0, 1.0) * 1000.0) as u64);
        let (best, best_power) = patch_power
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, p)| (i, *p))
            .unwrap_or((0, 0.0));
        // `!(>)`: a NaN residual (which valid scenes cannot give) stops too. With
        // photons to carry the rest, deterministic shots go on only while one patch
        // holds at least `tolerance` of the reference power.
        let out_of_time = budget > 0.0 && start.elapsed().as_secs_f64() > shots_budget;
        let weak = settings.photons > 0 && !(best_power > settings.tolerance as f64 * reference);
        // A shot that casts rays (not one that reuses its kept first shot) must carry
        // at least 1 / `worth` of the power per ray that the photon budget would:
        // where it would cost far more, the photons take the rest.
        let reuses = s.kept.get(best).is_some();
        let rays_before = rays_per_receiver.unwrap_or(settings.shoot_samples as f64) * receiving as f64;
        let dear = photon_rays > 0.0 && !reuses && best_power * photon_rays * worth < total * rays_before;
        if !(s.stats.residual > settings.tolerance as f64)
            || s.stats.patch_shots >= settings.max_shots as u64
            || weak
            || dear
            || out_of_time
        {
            s.stats.timed_out |= out_of_time;
            break;
        }
        let mut levels = s.levels(|s, k| s.patch_points(best as u32, k));
        if levels.sets.iter().flatten().any(|sp| sp.parted) {
            levels.field = s.unshot.clone();
        }
        let first = s.mesh.patches[best].first_vertex as usize;
        let count = s.mesh.patches[best].vertex_count as usize;
        for (u, shot) in s.unshot[first..first + count]
            .iter_mut()
            .zip(&mut s.shot[first..first + count])
        {
            *shot += *u;
            *u = Vec3::ZERO;
        }
        let rays = s.stats.rays;
        let touched = s.shoot_patch(best, &levels);
        if !reuses {
            rays_per_receiver = Some((s.stats.rays - rays) as f64 / receiving.max(1) as f64);
        }
        s.stats.patch_shots += 1;
        patch_power[best] = 0.0;
        for p in touched {
            patch_power[p] = s.unshot_power(p);
        }
    }
    if settings.photons > 0 && (s.stats.residual > 0.0 || photons::has_mirrors(scene)) {
        s.photons(receiving, start, budget, progress, trace);
    }
    progress.finish();
    s.stats.rays += s.cell_rays.into_inner();
    s.stats.time_s = start.elapsed().as_secs_f64();
    let solution = Solution {
        mesh: s.mesh,
        settings: *settings,
        general: s.general,
        caustic: s.caustic,
        lists: s.lists,
        stats: s.stats,
    };
    Ok((solution, s.folded))
}

/// What one patch received from a shot: occluded and unoccluded radiosity per
/// vertex, and the rays cast.
type Received = (Vec<Rgb>, Vec<Rgb>, u64);

/// What one vertex received from a shot: occluded and unoccluded radiosity, and the
/// rays cast.
type AtVertex = (Rgb, Rgb, u64);

/// What one vertex received from a shot, and the links a kept shot keeps of it.
type Gathered = (AtVertex, Vec<transfer::Link>);

/// What photons of one kind deposit, per vertex: in the general radiosity (and of
/// it, the caustic part), and in each list slot. Filled as the deposits come.
struct Deposits {
    general: Vec<Rgb>,
    caustic: Vec<Rgb>,
    slots: Vec<Option<Vec<Rgb>>>,
}

impl Deposits {
    fn new(slots: usize) -> Self {
        Deposits {
            general: Vec::new(),
            caustic: Vec::new(),
            slots: vec![None; slots],
        }
    }

    fn add(&mut self, d: &photons::Deposit, nv: usize) {
        let v = d.vertex as usize;
        if d.slot == u8::MAX {
            self.general.resize(nv, Vec3::ZERO);
            self.general[v] += d.value;
            if d.caustic {
                self.caustic.resize(nv, Vec3::ZERO);
                self.caustic[v] += d.value;
            }
        } else if let Some(slot) = self.slots.get_mut(d.slot as usize) {
            slot.get_or_insert_with(|| vec![Vec3::ZERO; nv])[v] += d.value;
        }
    }
}

struct Solver<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    settings: &'a SolveSettings,
    mesh: RadiosityMesh,
    general: Vec<Rgb>,
    /// See [`Solution::caustic`].
    caustic: Vec<Rgb>,
    unshot: Vec<Rgb>,
    /// Per vertex, the radiosity its patch's shots sent (what the shot photons draw
    /// from: the part of it that meets a mirror or glossy metal first).
    shot: Vec<Rgb>,
    lists: Vec<Vec<ListEntry>>,
    /// Per patch, the sources already folded into its general radiosity: they may
    /// never enter its list again (one route per source).
    folded: Vec<BTreeSet<SourceId>>,
    /// Patch shots kept for the patch's next shot.
    kept: transfer::Kept,
    /// The grids' midpoints, which shots take from the coarse vertices about them
    /// where those agree ([`coherence`]).
    midpoints: Midpoints,
    /// Rays that found the parted cells of patch shots and read their fields
    /// ([`parted::ShotParting`]), added to the stats at the end.
    cell_rays: std::sync::atomic::AtomicU64,
    stats: SolveStats,
}

impl Solver<'_> {
    fn unshot_power(&self, p: usize) -> f64 {
        let patch = &self.mesh.patches[p];
        let first = patch.first_vertex as usize;
        (first..first + patch.vertex_count as usize)
            .map(|v| mean(self.unshot[v]) as f64 * self.mesh.vertices[v].area as f64)
            .sum()
    }

    /// The jitter of cell `piece << 16 | k` of a shot: point `k` of a Sobol-Burley
    /// sequence (indexed below 2^16) scrambled for the piece (a grid of the patch, a
    /// patch of an area light).
    fn jitter(&self, shot: u64) -> impl Fn(u32) -> Vec2 {
        let seed = crate::sampling::shot_seed(self.settings.seed, shot);
        move |i| {
            let (piece, k) = (i >> 16, i & 0xFFFF);
            let s = if piece == 0 {
                seed
            } else {
                derive(seed, Stream::Cells(piece))
            };
            Vec2::new(sobol_burley::sample(k, 0, s), sobol_burley::sample(k, 1, s))
        }
    }

    /// The shooting cells of a source at 1, 4, 16 ... up to `shoot_samples` cells
    /// (`points(self, count)` makes one set), with the bounds that choose among them.
    fn levels(&self, points: impl Fn(&Self, u32) -> Vec<ShootPoint>) -> Levels {
        let max = self.settings.shoot_samples.max(1);
        let mut sets = Vec::new();
        let mut k = 1;
        loop {
            let k_now = k.min(max);
            let set = points(self, k_now);
            // A point light, or a source whose cells do not get finer: one set.
            let done = k_now == max || set.len() <= 1 && set.first().is_some_and(|p| p.len == 0);
            sets.push(set);
            if done {
                break;
            }
            k *= 4;
        }
        let finest = sets.last().map(Vec::as_slice).unwrap_or(&[]);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut area = 0.0;
        for sp in finest {
            for c in &sp.poly[..sp.len.max(1) as usize] {
                let c = if sp.len == 0 { sp.p } else { *c };
                lo = lo.min(c);
                hi = hi.max(c);
            }
            if sp.len >= 3 {
                let poly = &sp.poly[..sp.len as usize];
                let mut n = Vec3::ZERO;
                for i in 1..poly.len() - 1 {
                    n += (poly[i] - poly[0]).cross(poly[i + 1] - poly[0]);
                }
                area += 0.5 * n.length();
            }
        }
        let (centre, radius) = if lo.x <= hi.x {
            ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
        } else {
            (Vec3::ZERO, 0.0)
        };
        let shot = self.stats.light_shots + self.stats.patch_shots;
        Levels {
            touching: sets.iter().map(|s| Touching::new(s)).collect(),
            sets,
            seed: crate::sampling::shot_seed(self.settings.seed, 1 << 63 | shot),
            centre,
            radius,
            area,
            field: Vec::new(),
        }
    }

    /// Shooting points of light `l`: about `count` cells over an area light's surface.
    fn light_points(&self, l: u32, count: u32) -> Vec<ShootPoint> {
        match self.scene.lights[l as usize] {
            Light::Point { position, intensity } => vec![ShootPoint::point(position, intensity)],
            Light::Spot {
                position, intensity, ..
            } => vec![ShootPoint::point(position, intensity)],
            Light::Area { shape, radiance, .. } => {
                let first = self.mesh.shape_first_patch[shape as usize] as usize;
                let last = self
                    .mesh
                    .shape_first_patch
                    .get(shape as usize + 1)
                    .map(|&x| x as usize)
                    .unwrap_or(self.mesh.front_patches as usize);
                let area: f32 = self.mesh.patches[first..last].iter().map(|p| p.area).sum();
                let jitter = self.jitter(u64::from(l) << 32 | u64::from(count));
                let mut pts = Vec::new();
                for p in first..last {
                    let share = self.mesh.patches[p].area / area;
                    let k = ((count as f32 * share).round() as u32).max(1);
                    let base = ((p - first) as u32) << 16;
                    for c in self
                        .mesh
                        .shoot_cells(p as u32, k, |i| jitter(base.wrapping_add(i)), &[], None)
                    {
                        pts.push(ShootPoint::uniform(&c, radiance * std::f32::consts::PI));
                    }
                }
                pts
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                // A point far along the light (the shots' shadow rays aim there; the
                // light each vertex gets is the sun's own rule, `point_light_at`).
                let (c, r) = crate::emitters::infinite::scene_sphere(self.scene);
                vec![ShootPoint::point(c - direction * (1e4 * r), irradiance)]
            }
            Light::Environment { .. } => sky_cells(self.scene, count * SKY_CELLS_PER_SAMPLE),
        }
    }

    /// About `count` shooting cells of patch `p`, carrying its unshot radiosity. The
    /// cells are the same at every shot of the patch (only the points in them move),
    /// dark ones included, so a kept shot's links stay valid (see `transfer`).
    fn patch_points(&self, p: u32, count: u32) -> Vec<ShootPoint> {
        let jitter = self.jitter((self.stats.patch_shots + 1) | u64::from(count) << 48);
        let parting = parted::ShotParting::new(&self.mesh, self.accel, &self.unshot);
        let cells = self
            .mesh
            .shoot_cells(p, count, jitter, &self.unshot, Some(&parting));
        self.cell_rays
            .fetch_add(parting.rays(), std::sync::atomic::Ordering::Relaxed);
        cells
            .iter()
            .map(|c| ShootPoint {
                cell_of: Some((p, c.grid, c.weight)),
                ..ShootPoint::from_cell(c)
            })
            .collect()
    }

    /// Vertices of surfaces that reflect.
    fn receiving(&self) -> u64 {
        self.mesh
            .vertices
            .iter()
            .filter(|v| self.mesh.patches[v.patch as usize].reflectance.max_element() > 0.0)
            .count() as u64
    }

    /// The stochastic part: photons carry what the deterministic shots left unshot
    /// (see [`photons`]), `--photons` per receiving vertex (`receiving` of them), at
    /// most `--max-photons`, and the lights' photons aimed at mirrors. `trace` records
    /// the sources folded into general radiosity.
    fn photons(&mut self, receiving: u64, start: Instant, budget: f64, progress: &dyn Progress, trace: bool) {
        let nv = self.mesh.vertices.len();
        let mut n = u64::from(self.settings.photons) * receiving;
        if self.settings.max_photons > 0 {
            n = n.min(self.settings.max_photons);
        }
        let (emit, emit_power) = photons::Tracer::emitters(&self.mesh, &self.unshot);
        let lights = SampledLight::prepare_all(self.scene);
        let aim = photons::Aim::new(self.scene, self.accel, &lights);
        // The lights' photons, beside the patches' n: in proportion to the power that
        // meets mirrors over the patches' unshot power, divided by the square root of
        // the share of aimed photons that meet a mirror (Neyman's allocation: the
        // fewest photons for a given variance where a miss carries nothing), between
        // a sixteenth and four times n (it was n / 4). Classroom (metal chairs and a
        // mirror ball, 23 % of the lamps' power meets them): 4 n, two photon seeds'
        // images 0.0203 -> 0.0102 FLIP apart, the solve 1.3 -> 2.6 s. Paper room (a
        // teapot, under 1 %): 0.08 n, 69 k photons, of which 80 % meet the teapot;
        // the solve back to its time before the aim, two solve seeds 0.0043 apart.
        // (No mirror that a light reaches: no light to pick.)
        let light_photons = if aim.light_pick.is_some() {
            let unshot: f64 = (0..self.mesh.patches.len()).map(|p| self.unshot_power(p)).sum();
            let light = aim.met / aim.success.max(1e-3).sqrt();
            let share = if emit.is_empty() || !(unshot > 0.0) {
                MAX_LIGHT_PHOTONS
            } else {
                light / unshot
            };
            (n as f64 * share.clamp(MIN_LIGHT_PHOTONS, MAX_LIGHT_PHOTONS)) as u64
        } else {
            0
        };
        let patch_photons = if emit.is_empty() { 0 } else { n };
        // The patch shots' light that meets a mirror or a glossy metal first: the shots
        // deliver only to the vertices that reflect diffusely, so photons from the
        // shot radiosity carry that part on (those meeting a diffuse surface first
        // are dropped: the shots hold it). As many as the specular share of the
        // surface area asks: four times it, between a sixteenth and all of n.
        let (shot_emit, shot_power) = if aim.light_pick.is_some() || photons::has_mirrors(self.scene) {
            photons::Tracer::emitters(&self.mesh, &self.shot)
        } else {
            (Vec::new(), Vec::new())
        };
        let shot_photons = if shot_emit.is_empty() {
            0
        } else {
            let share = photons::specular_area_share(self.scene);
            (n as f64 * (4.0 * share).clamp(MIN_LIGHT_PHOTONS, 1.0)) as u64
        };
        // The lights' and the shots' photons together stay within `--max-photons`
        // too (both shrunk alike): a scene of many mirrors at the cap would otherwise
        // trace up to six times it (the wooden staircase: 12 M photons, a 146 s solve).
        let (light_photons, shot_photons) = match self.settings.max_photons {
            0 => (light_photons, shot_photons),
            cap if light_photons + shot_photons > cap => {
                let f = cap as f64 / (light_photons + shot_photons) as f64;
                (
                    (light_photons as f64 * f) as u64,
                    (shot_photons as f64 * f) as u64,
                )
            }
            _ => (light_photons, shot_photons),
        };
        // Which of the pieces photons will leave a wall stands on (none tested for
        // a kind that sends no photons).
        let parted = |field: &[Rgb], pieces: &[Piece], photons: u64| match photons {
            0 => (Vec::new(), 0),
            _ => parted::parted_pieces(&self.mesh, self.accel, field, pieces),
        };
        // The light of the shots, per vertex: where a wall parts it, deposits keep to
        // their side; and against it the photons' noise is judged ([`noise`]).
        let shot_total = total_radiosity(&self.mesh, &self.general, &self.lists);
        let shot_light: Vec<f32> = shot_total.iter().map(|b| mean(*b)).collect();
        let deposit_parted = Parted::for_deposits(&self.mesh, self.accel, shot_total);
        let (emit_parted, parted_rays) = parted(&self.unshot, &emit, patch_photons);
        let (shot_parted, shot_parted_rays) = parted(&self.shot, &shot_emit, shot_photons);
        self.stats.rays += parted_rays + shot_parted_rays;
        let tracer = photons::Tracer {
            scene: self.scene,
            accel: self.accel,
            mesh: &self.mesh,
            lists: &self.lists,
            unshot: &self.unshot,
            seed: self.settings.seed,
            patch_photons,
            emit,
            emit_parted,
            emit_pick: Alias::new(&emit_power),
            shot: &self.shot,
            shot_emit,
            shot_parted,
            shot_pick: Alias::new(&shot_power),
            shot_photons,
            light_photons,
            lights,
            aim,
            spare: Default::default(),
            parted: Some(&deposit_parted),
        };
        let order = tracer.order();
        let chunks = order.len() as u64;
        // What each kind's photons deposit, apart: each is scaled by the share of its
        // own photons traced.
        let slots = self.settings.sources_per_patch as usize;
        let mut sums: Vec<Deposits> = (0..photons::KINDS).map(|_| Deposits::new(slots)).collect();
        // When the photons' noise is judged first.
        let area: Vec<f32> = self.mesh.vertices.iter().map(|v| v.area).collect();
        let mut halves = noise::Halves::new(nv);
        let mut judge_at = noise::FIRST_PER_VERTEX * receiving;
        progress.start("photons", chunks);
        let round = (4 * rayon::current_num_threads()).max(8);
        let mut done = 0;
        while done < order.len() {
            let end = (done + round).min(order.len());
            let traced = tracer.trace_chunks(&order[done..end]);
            for (chunk, (deposits, rays)) in order[done..end].iter().zip(traced) {
                self.stats.photon_rays += rays;
                let photons = tracer.photons(*chunk);
                halves.add(*chunk, photons.end - photons.start, &deposits);
                let sum = &mut sums[chunk.kind as usize];
                for d in &deposits {
                    sum.add(d, nv);
                    if trace && d.slot == u8::MAX {
                        if let Some(src) = d.source {
                            self.folded[self.mesh.vertices[d.vertex as usize].patch as usize].insert(src);
                        }
                    }
                }
                tracer.recycle(deposits);
            }
            done = end;
            progress.set(done as u64);
            if budget > 0.0 && start.elapsed().as_secs_f64() > budget && done < order.len() {
                self.stats.timed_out = true;
                break;
            }
            // Settled: the photons so far stand for all of them.
            let so_far: u64 = halves.traced().iter().sum();
            if so_far >= judge_at && done < order.len() {
                judge_at = so_far + so_far / 4;
                let n = halves.noise(tracer.counts(), &shot_light, &area);
                if n.is_some_and(|n| n < noise::SETTLED) {
                    break;
                }
            }
        }
        progress.finish();
        let traced = halves.traced();
        self.stats.photons = traced.iter().sum();
        // The photons traced of each kind stand for all of that kind.
        for ((sum, n), t) in sums.into_iter().zip(tracer.counts()).zip(traced) {
            if t == 0 {
                continue;
            }
            let scale = n as f32 / t as f32;
            for (g, b) in self.general.iter_mut().zip(&sum.general) {
                *g += *b * scale;
            }
            if !sum.caustic.is_empty() {
                self.caustic.resize(nv, Vec3::ZERO);
                for (c, b) in self.caustic.iter_mut().zip(&sum.caustic) {
                    *c += *b * scale;
                }
            }
            for (k, b) in sum.slots.iter().enumerate() {
                let Some(b) = b else { continue };
                for (p, list) in self.lists.iter_mut().enumerate() {
                    let Some(e) = list.get_mut(k) else { continue };
                    let first = self.mesh.patches[p].first_vertex as usize;
                    for (i, (o, u)) in e.occluded.iter_mut().zip(e.unoccluded.iter_mut()).enumerate() {
                        let add = b[first + i] * scale;
                        // Photons see no occluders they missed: the stochastic light counts
                        // as unoccluded too.
                        *o += add;
                        *u += add;
                    }
                }
            }
        }
        for u in &mut self.unshot {
            *u = Vec3::ZERO;
        }
    }

    /// Shoots from `points` of `source` to every vertex not on the source itself and
    /// files the light in the lists or general radiosity. Returns the patches that
    /// received light.
    fn shoot(&mut self, source: SourceId, levels: &Levels) -> Vec<usize> {
        if levels.sets.iter().all(Vec::is_empty) {
            return Vec::new();
        }
        let max = self.settings.shoot_samples;
        let skip_patch = match source {
            SourceId::Patch(p) => Some(p),
            SourceId::Light(_) => None,
        };
        let sampled = match source {
            SourceId::Light(l) => match &self.scene.lights[l as usize] {
                Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } => {
                    Some(SampledLight::prepare(self.scene, l))
                }
                Light::Area { .. } | Light::Environment { .. } => None,
            },
            SourceId::Patch(_) => None,
        };
        // An exact sphere's cells (pieces of its surface, cut by chords) fall short of
        // its light near the limb, where a cell is partly turned away: a small bulb
        // meshed as a few elements sent 9 % too little. Its unoccluded light at each
        // vertex has a closed form, which the cells' sum is scaled to; their
        // visibility still weighs them.
        // (Only an exact shape's emitter is prepared: a tessellated light's would be
        // built for nothing.)
        let sphere = match source {
            SourceId::Light(l) => match &self.scene.lights[l as usize] {
                Light::Area { shape, .. } if self.scene.shapes[*shape as usize].mesh.quadric.is_some() => {
                    match SampledLight::prepare(self.scene, l) {
                        SampledLight::Area(e) if e.is_sphere() => Some(e),
                        _ => None,
                    }
                }
                _ => None,
            },
            SourceId::Patch(_) => None,
        };
        // Per vertex, in parallel over all receiving vertices (not per patch: one
        // large patch would keep one thread busy while the others wait), then
        // gathered per patch. The sums per vertex are the same either way. At most 16
        // vertices per task: the cost of a vertex varies a lot (visible or not, near or
        // far), and finer tasks balance the threads (paper room: 1.68x -> 1.84x on 2).
        // A light's visibility is sampled more densely than a patch's: its light is
        // what the selection's gradient criterion reads, and what every later shot
        // passes on. More first rays from patches cost the conference room 1.5 M rays
        // for no change seen in the Cornell box or the paper room.
        let first_rays = match source {
            SourceId::Light(_) => FIRST_LIGHT_RAYS,
            SourceId::Patch(_) => 1,
        };
        // A patch's first shot is kept for its next ones while there is room.
        let keep = skip_patch.filter(|_| self.kept.has_room());
        let mesh = &self.mesh;
        // What vertex `i` receives (`ends`: a midpoint's coarse vertices), with a
        // kept shot's links; `seen` records what a coarse vertex found.
        let receive = |i: usize, ends: Option<&Ends>, seen: Option<&mut Seen>| -> Gathered {
            let v = &mesh.vertices[i];
            let mut links = Vec::new();
            if !self.receives(source, v.patch as usize) {
                return ((Vec3::ZERO, Vec3::ZERO, 0), links);
            }
            let rho = mesh.albedo(i as u32);
            let seed = derive(levels.seed, Stream::Receiver(i as u32));
            let (o, u, r) = self.gather(
                levels.for_vertex(v.q, max),
                Receiver { v, seed, ends },
                sampled.as_ref(),
                first_rays,
                Found {
                    links: keep.is_some().then_some(&mut links),
                    seen,
                },
            );
            let (o, u) = match sphere.as_ref().and_then(|e| e.sphere_irradiance(v.q, v.n)) {
                Some(exact) if mean(u) > 0.0 => (o * (mean(exact) / mean(u)), exact),
                _ => (o, u),
            };
            ((o * rho, u * rho, r), links)
        };
        // The coarse vertices first, recording what they found; then the midpoints,
        // taking the cells their coarse vertices agree on ([`coherence`]). Not from
        // a light at a point (a point, spot or directional light): its one point,
        // seen from two vertices, says nothing of a thin occluder that hides it
        // from the midpoint (the classroom's spots under its chairs: FLIP against
        // Mitsuba 0.0810 / 0.0815 -> 0.0829 / 0.0822 with them, 0.0809 / 0.0815
        // without), and its four rays a vertex cost little.
        let midpoints = &self.midpoints;
        let coherent = sampled.is_none();
        let (coarse, seen): (Vec<Gathered>, Vec<Option<Seen>>) = (0..mesh.vertices.len())
            .into_par_iter()
            .with_max_len(16)
            .map(|i| {
                if !coherent {
                    return (receive(i, None, None), None);
                }
                if midpoints.of_vertex(i).is_some() {
                    return (((Vec3::ZERO, Vec3::ZERO, 0), Vec::new()), None);
                }
                let mut seen = Seen::default();
                let out = receive(i, None, Some(&mut seen));
                (out, Some(seen))
            })
            .unzip();
        let (mut per_vertex, mut links): (Vec<AtVertex>, Vec<Vec<transfer::Link>>) =
            coarse.into_iter().unzip();
        let mids: Vec<(usize, Gathered)> = (0..mesh.vertices.len())
            .into_par_iter()
            .with_max_len(16)
            .filter_map(|i| {
                let between = midpoints.of_vertex(i).filter(|_| coherent)?;
                let mut ends = Ends { seen: [None; 4] };
                for (slot, &e) in ends.seen.iter_mut().zip(between.ends()) {
                    *slot = seen.get(e as usize).and_then(Option::as_ref);
                }
                Some((i, receive(i, Some(&ends), None)))
            })
            .collect();
        for (i, (at, l)) in mids {
            per_vertex[i] = at;
            links[i] = l;
        }
        if let Some(p) = keep {
            if let Some(t) = transfer::Transfer::new(links.into_iter()) {
                self.kept.keep(p as usize, t);
            }
        }
        // What a point or spot light's shot passes on: the mean over each vertex's
        // surface where its pieces are mixed (see [`project`]).
        let passed = match &sampled {
            Some(l) => {
                let point: Vec<Rgb> = per_vertex.iter().map(|x| x.0).collect();
                let (out, rays) = project::project_all(
                    self.scene,
                    &self.mesh,
                    self.accel,
                    l,
                    |p| self.receives(source, p),
                    &point,
                    levels.seed,
                );
                self.stats.rays += rays;
                out
            }
            None => Vec::new(),
        };
        self.deliver(source, &per_vertex, passed)
    }

    /// Whether patch `p` receives light from `source`: not the source itself, and it
    /// reflects.
    fn receives(&self, source: SourceId, p: usize) -> bool {
        source != SourceId::Patch(p as u32) && self.mesh.patches[p].reflectance.max_element() > 0.0
    }

    /// Shoots patch `p` from its cells `levels`: through its kept first shot if it
    /// has one (what every vertex receives from the cells as they now are, with the
    /// form factors and visibility found then; no rays), else with rays
    /// ([`Self::shoot`]). Returns the patches that received light.
    fn shoot_patch(&mut self, p: usize, levels: &Levels) -> Vec<usize> {
        let Some(kept) = self.kept.get(p) else {
            return self.shoot(SourceId::Patch(p as u32), levels);
        };
        let source = SourceId::Patch(p as u32);
        let (radiosity, quarters) = (levels.radiosity(), levels.quarters());
        let mesh = &self.mesh;
        let per_vertex: Vec<AtVertex> = mesh
            .vertices
            .par_iter()
            .enumerate()
            .with_min_len(256)
            .map(|(i, v)| {
                if !self.receives(source, v.patch as usize) {
                    return (Vec3::ZERO, Vec3::ZERO, 0);
                }
                let rho = mesh.albedo(i as u32);
                let seed = derive(levels.seed, Stream::Receiver(i as u32));
                let mut rays = 0;
                // A cell an obstacle stands on, taken piece by piece with its field as
                // it is now (see `transfer`).
                let parted = |cell: u32, f: f32| match levels.cell(cell) {
                    Some((sp, k)) if sp.flat => {
                        let (all, seen, _, cast) = self.parted_light(sp, &levels.field, v.q, v.n, f, seed, k);
                        rays += cast;
                        (seen, all)
                    }
                    // A parted link is kept only for a flat cell, and the cells are
                    // the same at every shot of the patch: not reached.
                    _ => (Vec3::ZERO, Vec3::ZERO),
                };
                let (o, u) = kept.receive(i, &radiosity, &quarters, parted);
                (o * rho, u * rho, rays)
            })
            .collect();
        self.stats.reused_shots += 1;
        self.deliver(source, &per_vertex, Vec::new())
    }

    /// Files what each vertex received from `source` (occluded, unoccluded, rays
    /// cast) in the lists or general radiosity and adds it to the unshot radiosity,
    /// or `passed` on where a point light's projection gave it. Returns the patches
    /// that received light.
    fn deliver(
        &mut self,
        source: SourceId,
        per_vertex: &[AtVertex],
        mut passed: Vec<Option<Vec<Rgb>>>,
    ) -> Vec<usize> {
        let results: Vec<Option<Received>> = (0..self.mesh.patches.len())
            .map(|p| {
                if !self.receives(source, p) {
                    return None;
                }
                let patch = &self.mesh.patches[p];
                let first = patch.first_vertex as usize;
                let vs = &per_vertex[first..first + patch.vertex_count as usize];
                let occ: Vec<Rgb> = vs.iter().map(|x| x.0).collect();
                let unocc: Vec<Rgb> = vs.iter().map(|x| x.1).collect();
                Some((occ, unocc, vs.iter().map(|x| x.2).sum::<u64>()))
            })
            .collect();
        let mut touched = Vec::new();
        for (p, r) in results.into_iter().enumerate() {
            let Some((occ, unocc, rays)) = r else { continue };
            self.stats.rays += rays;
            let patch = &self.mesh.patches[p];
            let first = patch.first_vertex as usize;
            let power: f32 = unocc
                .iter()
                .zip(&self.mesh.vertices[first..])
                .map(|(c, v)| mean(*c) * v.area)
                .sum();
            if !(power > 0.0) {
                continue;
            }
            touched.push(p);
            let onward = passed.get_mut(p).and_then(Option::take);
            for (k, c) in onward.as_deref().unwrap_or(&occ).iter().enumerate() {
                self.unshot[first + k] += *c;
            }
            self.file(p, source, occ, unocc, power);
        }
        touched
    }

    /// Puts a source's contribution to patch `p` in its list or its general radiosity.
    fn file(&mut self, p: usize, source: SourceId, occ: Vec<Rgb>, unocc: Vec<Rgb>, power: f32) {
        let first = self.mesh.patches[p].first_vertex as usize;
        let n = self.settings.sources_per_patch as usize;
        let list = &mut self.lists[p];
        let folded = &mut self.folded[p];
        let general = &mut self.general;
        let fold = |general: &mut Vec<Rgb>, values: &[Rgb]| {
            for (k, c) in values.iter().enumerate() {
                general[first + k] += *c;
            }
        };
        if let Some(e) = list.iter_mut().find(|e| e.source == source) {
            for k in 0..occ.len() {
                e.occluded[k] += occ[k];
                e.unoccluded[k] += unocc[k];
            }
            e.power += power;
            return;
        }
        if !folded.contains(&source) {
            if list.len() < n {
                list.push(ListEntry {
                    source,
                    occluded: occ,
                    unoccluded: unocc,
                    power,
                });
                return;
            }
            // Lights are pinned: a radiant patch never evicts a light, so with n at
            // least the number of lights every light stays apart on every patch it
            // reaches (what `--method norm` needs).
            let patch_source = matches!(source, SourceId::Patch(_));
            let weakest = list
                .iter()
                .enumerate()
                .filter(|(_, e)| !(patch_source && matches!(e.source, SourceId::Light(_))))
                .min_by(|a, b| a.1.power.total_cmp(&b.1.power));
            if let Some((i, e)) = weakest {
                if power > e.power {
                    let entry = ListEntry {
                        source,
                        occluded: occ,
                        unoccluded: unocc,
                        power,
                    };
                    let old = std::mem::replace(&mut list[i], entry);
                    fold(general, &old.occluded);
                    folded.insert(old.source);
                    return;
                }
            }
        }
        fold(general, &occ);
        folded.insert(source);
    }
}

#[cfg(test)]
mod tests;
