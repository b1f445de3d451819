//! The stochastic part of pass 1: the power the deterministic shots leave unshot is
//! carried by photons (particle tracing, "stochastic shooting": Neumann et al. 1995,
//! Bekaert's collision estimator), whose cost follows the rays cast, not vertices x
//! shots.
//!
//! Photons leave the radiant patches in proportion to their unshot radiosity (and,
//! when the scene has mirrors, the light sources, aimed at the mirrors ([`Aim`]):
//! light -> mirror -> diffuse paths, paper Sect. 6). At every diffuse hit a photon
//! leaves its reflected power on the vertices of the element hit, in proportion to
//! their interpolation weights and
//! inversely to their areas, so a smooth field is estimated without bias; then it is
//! reflected diffusely or specularly, or absorbed (Russian roulette on the
//! reflectance). Light that comes straight from a source listed on the patch hit goes
//! to that list entry, everything else to the general radiosity: one route per source.
//!
//! Photons are traced in fixed chunks whose deposits are added in chunk order, so the
//! result depends on the seed alone, never on the threads.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use crate::accel::{Accel, Ray};
use crate::bsdf::microfacet::Frame;
use crate::emitters::{Emission, SampledLight};
use crate::interaction::{offset_from, reflect, SurfacePoint, PARALLEL_FACES};
use crate::mesh::{point_in_polygon, Piece, RadiosityMesh};
use crate::sampling::{
    cone_direction, cosine_direction, derive, in_cone, shot_seed, sphere_cone, uniform3, Alias, Stream,
};
use crate::scene::{mean, Glossy, Rgb, Scene};
use std::f32::consts::PI;

use super::SourceId;

/// Photons in one chunk (the unit of determinism).
const CHUNK: u64 = 1024;
/// Bounces followed at most.
const MAX_BOUNCES: u32 = 32;
/// Seeds of photons start here, clear of the shots' seeds.
const SEED_BASE: u64 = 1 << 40;

/// Where a deposit goes: vertex `vertex`, into list slot `slot` of its patch, or the
/// general radiosity (`slot` = `u8::MAX`); `source` is what it came straight from.
#[derive(Debug, Clone, Copy)]
pub struct Deposit {
    pub vertex: u32,
    pub slot: u8,
    pub source: Option<SourceId>,
    pub value: Rgb,
    /// Light by way of mirrors only (light -> mirror(s) -> here): see
    /// [`super::Solution::caustic`].
    pub caustic: bool,
}

/// What the photons read: the scene, its mesh, the lists (to route deposits) and
/// the unshot radiosity they carry.
pub struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a dyn Accel,
    pub mesh: &'a RadiosityMesh,
    pub lists: &'a [Vec<super::ListEntry>],
    pub unshot: &'a [Rgb],
    pub seed: u64,
    /// Surface pieces with unshot light, drawn by their power.
    pub emit: Vec<Piece>,
    /// Per piece of `emit`, whether an obstacle parts its vertices
    /// ([`super::parted::parted_pieces`]).
    pub emit_parted: Vec<bool>,
    pub emit_pick: Option<Alias>,
    /// The shot radiosity, and the pieces that hold it, drawn by their power.
    pub shot: &'a [Rgb],
    pub shot_emit: Vec<Piece>,
    /// Per piece of `shot_emit`, as `emit_parted`.
    pub shot_parted: Vec<bool>,
    pub shot_pick: Option<Alias>,
    /// Photons from patches, from lights and from the shots (the last two only with
    /// mirrors in the scene).
    pub patch_photons: u64,
    pub light_photons: u64,
    pub shot_photons: u64,
    /// The lights, prepared, and where their photons go.
    pub lights: Vec<SampledLight>,
    pub aim: Aim,
    /// Deposit buffers handed back ([`Self::recycle`]) for the next chunks: a
    /// chunk's deposits take a few hundred kB, which the system allocator would map
    /// and zero afresh for each of the thousands of chunks (a tenth of the glass
    /// window's whole render went to the kernel clearing those pages).
    pub spare: std::sync::Mutex<Vec<Vec<Deposit>>>,
    /// The pieces a wall stands on, by the light of the deterministic shots: a
    /// photon landing on one deposits only to the vertices on its side
    /// ([`super::Parted::keep_apart`]).
    pub parted: Option<&'a super::Parted>,
}

impl<'a> Tracer<'a> {
    /// The radiant pieces of every patch with unshot light
    /// ([`RadiosityMesh::pieces`]), and a bound on each one's power: its area times the
    /// largest unshot radiosity of the vertices that weigh in at its corners and
    /// centre (pieces are no bigger than a cell, so no lit cell inside a large input
    /// triangle is left without photons: that light would be lost).
    pub fn emitters(mesh: &RadiosityMesh, unshot: &[Rgb]) -> (Vec<Piece>, Vec<f64>) {
        let mut emit = Vec::new();
        let mut power = Vec::new();
        for (p, mp) in mesh.patches.iter().enumerate() {
            let first = mp.first_vertex as usize;
            let any = unshot[first..first + mp.vertex_count as usize]
                .iter()
                .any(|u| u.max_element() > 0.0);
            if !any {
                continue;
            }
            for e in mesh.pieces(p as u32) {
                let c = e.corners;
                let hi = [c[0], c[1], c[2], (c[0] + c[1] + c[2]) / 3.0]
                    .iter()
                    .map(|&x| {
                        let w = mesh.weights_on(&e, x);
                        (0..4)
                            .map(|k| mean(unshot[w.vertices[k] as usize]))
                            .fold(0.0, f32::max)
                    })
                    .fold(0.0, f32::max);
                let area = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
                let w = f64::from(area * hi.max(0.0));
                if w > 0.0 {
                    emit.push(e);
                    power.push(w);
                }
            }
        }
        (emit, power)
    }

    /// Traces chunk `c` (see [`Self::order`]) and returns its deposits and the
    /// rays cast. A photon's seed is its index among all the photons, kind after
    /// kind, so the photons are the same in whatever order the chunks are traced.
    pub fn chunk(&self, c: Chunk) -> (Vec<Deposit>, u64) {
        let mut out = self
            .spare
            .lock()
            .map(|mut s| s.pop())
            .ok()
            .flatten()
            .unwrap_or_default();
        out.clear();
        let mut rays = 0;
        for i in self.photons(c) {
            let seed = shot_seed(self.seed, SEED_BASE + i);
            let mut next = draws(seed, 1);
            let patch = i < self.patch_photons;
            let light = !patch && i < self.patch_photons + self.light_photons;
            let (origin, normal, dir, power, source, start) = if !light {
                let (table, pieces, parted, field, count) = if patch {
                    (
                        &self.emit_pick,
                        &self.emit,
                        &self.emit_parted,
                        self.unshot,
                        self.patch_photons,
                    )
                } else {
                    (
                        &self.shot_pick,
                        &self.shot_emit,
                        &self.shot_parted,
                        self.shot,
                        self.shot_photons,
                    )
                };
                let Some(table) = table else { continue };
                let [a, b, cc] = next();
                let k = table.pick(a, b, cc);
                let e = &pieces[k];
                let [b, cc, _] = next();
                let x = point_in_polygon(&e.corners, Vec2::new(b, cc));
                let n = (e.corners[1] - e.corners[0]).cross(e.corners[2] - e.corners[0]);
                let area = 0.5 * n.length();
                let n = n.normalize_or(Vec3::Z);
                // A curved patch's piece is a chord of its surface: photons leave from
                // the surface, not from inside a closed object.
                let (x_out, n_out) = self.mesh.surface_at(e, x).unwrap_or((x, n));
                let prob = table.probability(k);
                let mut w = self.mesh.weights_on(e, x);
                if parted.get(k).copied().unwrap_or(false) {
                    rays += super::parted::keep_visible(self.mesh, self.accel, field, &mut w, x, area);
                }
                let b = w.apply(field);
                // Radiosity B over area A sends B A; per photon over its probability.
                let power = b * (area / (prob as f32 * count as f32));
                let [u, v, _] = next();
                (
                    x_out,
                    n_out,
                    cosine_direction(n_out, Vec2::new(u, v)),
                    power,
                    Some(SourceId::Patch(e.patch)),
                    if patch { Start::Patch } else { Start::Shot },
                )
            } else {
                let Some((e, prob)) = self.aim.emit(&self.lights, &mut next) else {
                    continue;
                };
                let count = self.light_photons as f32 * prob as f32;
                (
                    e.origin,
                    e.normal.unwrap_or(Vec3::ZERO),
                    e.dir,
                    e.power / count,
                    None,
                    Start::Light,
                )
            };
            if !(power.max_element() > 0.0) {
                continue;
            }
            self.trace(
                origin, normal, dir, power, source, start, &mut next, &mut out, &mut rays,
            );
        }
        (out, rays)
    }

    #[allow(clippy::too_many_arguments)]
    fn trace(
        &self,
        mut origin: Vec3,
        mut normal: Vec3,
        mut dir: Vec3,
        mut power: Rgb,
        mut source: Option<SourceId>,
        start: Start,
        next: &mut impl FnMut() -> [f32; 3],
        out: &mut Vec<Deposit>,
        rays: &mut u64,
    ) {
        // Light the deterministic shots delivered: only mirrors and glossy metals pass
        // it on.
        let mut first = start != Start::Patch;
        // Still on a light -> mirror(s) path.
        let mut caustic = start == Start::Light;
        let mut inside = InGlass::Out;
        for _ in 0..MAX_BOUNCES {
            let ray = Ray {
                origin: if normal == Vec3::ZERO {
                    origin
                } else {
                    offset_from(origin, normal, dir)
                },
                dir,
                tmin: 0.0,
                tmax: f32::INFINITY,
            };
            *rays += 1;
            let Some(hit) = self.accel.intersect(&ray) else {
                return;
            };
            let sp = SurfacePoint::new(self.scene, &ray, &hit);
            let bsdf = &self.scene.bsdfs[self.scene.shapes[hit.shape as usize].bsdf as usize];
            if !sp.front && !bsdf.twosided {
                return;
            }
            if bsdf.masked() {
                let [u, _, _] = next();
                if sp.passes(self.scene, bsdf, u) {
                    // Through a mask's open part, as shadow rays go (the state kept).
                    origin = sp.p;
                    normal = sp.ng;
                    continue;
                }
            }
            let outward = if sp.front { sp.ns } else { -sp.ns };
            if let Some(g) = bsdf.kind.split(-dir, outward) {
                // Glass: reflected or transmitted by their shares of the power.
                let (pr, pt) = (mean(g.reflect).min(1.0), mean(g.power).min(1.0));
                let [u, _, _] = next();
                let thick = bsdf.kind.is_thick_glass();
                // Shadow rays cross thin panes, and thick glass between parallel
                // faces (`pane_transmittance`): a photon that crosses them so is
                // still what the shots deliver, as it was before.
                let mut crossed = false;
                if u < pr {
                    power *= g.reflect / pr;
                    dir = reflect(dir, sp.ns);
                    if !reflects(dir, sp.ng) {
                        return;
                    }
                    if inside != InGlass::Out {
                        inside = InGlass::Reflected;
                    }
                } else if u < pr + pt {
                    power *= g.power / pt;
                    dir = g.dir;
                    if dir.dot(sp.ng) >= 0.0 {
                        return;
                    }
                    crossed = !thick;
                    if thick {
                        match std::mem::replace(&mut inside, InGlass::Out) {
                            // Leaving glass it started in (a lamp inside a solid
                            // glass globe): the shots' shadow rays end inside that
                            // glass and count the crossing, so the photon keeps
                            // what they hold (it counted the lamp's light twice).
                            InGlass::Out if !sp.front => crossed = true,
                            InGlass::Out => {
                                inside = InGlass::Entered {
                                    face: sp.ng,
                                    first,
                                    source,
                                }
                            }
                            InGlass::Entered {
                                face,
                                first: f,
                                source: s,
                            } if face.dot(sp.ng).abs() >= PARALLEL_FACES => {
                                (first, source) = (f, s);
                                crossed = true;
                            }
                            _ => {}
                        }
                    }
                } else {
                    return;
                }
                if !crossed {
                    first = false;
                    source = None;
                }
                origin = sp.p;
                normal = sp.ng;
                continue;
            }
            // Straight from a light or a shot, the deterministic shots hold the light
            // a diffuse surface takes: only the mirrors and glossy metals pass it on.
            // Later, the albedo its vertices interpolate to there (their texture's
            // mean, as the shots use).
            let q = (!first)
                .then(|| self.mesh.patch_at(self.scene, &hit, sp.front))
                .filter(|&q| self.mesh.patches[q as usize].reflectance.max_element() > 0.0);
            let w = q.map(|q| self.mesh.locate_on(self.scene, q, &hit, sp.p));
            let rho = w.as_ref().map_or(Vec3::ZERO, |w| self.mesh.albedo_at(w));
            let cos = (-dir).dot(sp.ns).max(0.0);
            let spec = bsdf.kind.mirror(cos);
            let glossy = bsdf.kind.glossy();
            // A glossy lobe passes a photon on with the probability of its reflectance
            // at normal incidence, then weighs it by the lobe's sampling weight over
            // that (the lobe reflects at most that fraction, nearly, at any angle).
            let pg = glossy.map_or(0.0, |g| mean(g.scale * g.fresnel.f0()).clamp(0.0, 1.0));
            if let (Some(q), Some(w)) = (q.filter(|_| rho.max_element() > 0.0), &w) {
                let mut w = *w;
                if let Some(parted) = self.parted {
                    *rays += parted.keep_apart(self.mesh, self.accel, &mut w, sp.p);
                }
                let slot = source
                    .and_then(|s| self.lists[q as usize].iter().position(|e| e.source == s))
                    .map_or(u8::MAX, |k| k as u8);
                for k in 0..4 {
                    if w.weights[k] > 0.0 {
                        let v = w.vertices[k];
                        let area = self.mesh.vertices[v as usize].area;
                        if area > 0.0 {
                            out.push(Deposit {
                                vertex: v,
                                slot,
                                source,
                                value: self.mesh.albedo(v) * power * (w.weights[k] / area),
                                caustic,
                            });
                        }
                    }
                }
            }
            let pd = if first { 0.0 } else { mean(rho).min(1.0) };
            let ps = mean(spec).min(1.0);
            first = false;
            let [u, a, b] = next();
            if u < pd {
                power *= rho / pd;
                dir = cosine_direction(sp.ns, Vec2::new(a, b));
                if dir.dot(sp.ng) <= 0.0 {
                    return;
                }
                source = q.map(SourceId::Patch);
                caustic = false;
            } else if u < pd + ps && ps > 0.0 {
                power *= spec / ps;
                dir = reflect(dir, sp.ns);
                if !reflects(dir, sp.ng) {
                    return;
                }
                source = None;
            } else if u < pd + ps + pg {
                let Some((d, w)) =
                    glossy.and_then(|g| glossy_bounce(self.scene, &g, &sp, dir, Vec2::new(a, b)))
                else {
                    return;
                };
                dir = d;
                power *= w / pg;
                source = None;
            } else {
                return;
            }
            origin = sp.p;
            normal = sp.ng;
        }
    }

    /// Photons of each kind (indexed by [`Chunk::kind`]): from the patches, from
    /// the lights, from the shots.
    pub fn counts(&self) -> [u64; KINDS] {
        [self.patch_photons, self.light_photons, self.shot_photons]
    }

    /// The chunks in the order they are traced ([`interleave`]).
    pub fn order(&self) -> Vec<Chunk> {
        interleave(self.counts())
    }

    /// The photons of chunk `c`, by their index among all the photons, kind after
    /// kind (a photon's seed).
    pub fn photons(&self, c: Chunk) -> std::ops::Range<u64> {
        let counts = self.counts();
        let first: u64 = counts[..c.kind as usize].iter().sum();
        let n = counts[c.kind as usize];
        first + (c.index * CHUNK).min(n)..first + ((c.index + 1) * CHUNK).min(n)
    }

    /// Hands a chunk's deposit buffer back for the next chunks.
    pub fn recycle(&self, deposits: Vec<Deposit>) {
        if let Ok(mut spare) = self.spare.lock() {
            spare.push(deposits);
        }
    }

    /// Traces `chunks` in parallel; their deposits and rays in the same order.
    pub fn trace_chunks(&self, chunks: &[Chunk]) -> Vec<(Vec<Deposit>, u64)> {
        chunks.par_iter().map(|&c| self.chunk(c)).collect()
    }
}

/// The chunks of photons of each kind (`counts`) in the order they are traced:
/// each kind's first chunk, then each kind's chunks spread evenly among the others'
/// (chunk j of a kind of c chunks comes at j / c of the way), so that any first part
/// of them holds every kind in about its share. A solve cut short by `--solve-time`
/// then still carries every kind's light, each scaled by the share of its own
/// photons traced (`noise::Halves::traced`). Traced kind after kind, a glass bulb cut
/// short had traced only its patches' photons, scaled up to stand for its light's
/// too: FLIP 0.030 -> 0.082 at a second's budget.
pub fn interleave(counts: [u64; KINDS]) -> Vec<Chunk> {
    let mut order: Vec<(f64, Chunk)> = Vec::new();
    for (kind, n) in counts.into_iter().enumerate() {
        let c = n.div_ceil(CHUNK);
        for index in 0..c {
            let at = index as f64 / c as f64;
            order.push((
                at,
                Chunk {
                    kind: kind as u8,
                    index,
                },
            ));
        }
    }
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.kind.cmp(&b.1.kind)));
    order.into_iter().map(|(_, c)| c).collect()
}

/// Kinds of photons: from the patches' unshot light, from the lights (aimed at
/// mirrors), from the shots' light that meets a mirror.
pub const KINDS: usize = 3;

/// A chunk of photons of one kind: its `index`-th [`CHUNK`] photons.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chunk {
    pub kind: u8,
    pub index: u64,
}

/// Mirror groups at most: the photons of a light pick one, then a direction in the
/// cone that holds it, and their density sums over every group's cone.
const MAX_TARGETS: usize = 64;
/// Rays per light and group, at most, that find how much of the light sent into the
/// group's cone meets a mirror first; fewer when there are many lights and groups
/// (at most [`AIM_RAYS`] in all, at least 16 a pair).
const AIM_SAMPLES: u32 = 256;
/// See [`AIM_SAMPLES`].
const AIM_RAYS: u32 = 1 << 18;
/// A light and group keep at least this share of the power sent into the group's
/// cone as their weight, whatever the rays found: a mirror the rays missed (a thin
/// one, or one a spot's cone grazes) is still reached, and no photon's weight is
/// more than 1 / AIM_DEFENSIVE times the cone's power over its density.
const AIM_DEFENSIVE: f64 = 0.05;

/// Where the lights' photons go: only light that a mirror passes on is traced from
/// the lights (the deterministic shots hold the rest), so photons leave each light
/// towards the bounding spheres of groups of mirror triangles, not over all its
/// directions (Jensen's projection maps, with cones instead of maps). A light and a
/// group are chosen by the power that meets a mirror first, found by a few rays
/// from each light into each group's cone: a loose group (thin metal tubes spread
/// over a room) gets the photons that its mirrors take, not those its sphere takes.
pub struct Aim {
    /// Bounding spheres (centre, radius) of groups of mirror triangles.
    spheres: Vec<(Vec3, f32)>,
    /// The same spheres four at a time, for the density's test ([`SphereLanes`]).
    lanes: Vec<SphereLanes>,
    /// Per light: the chance of aiming at each sphere.
    per_light: Vec<Option<Alias>>,
    /// Per point or spot light: the cone from it round each sphere.
    cones: Vec<Option<Vec<Option<Cone>>>>,
    /// Per light: the chance of choosing it.
    pub light_pick: Option<Alias>,
    /// The lights' power that meets a mirror first (a pilot's estimate).
    pub met: f64,
    /// The mean share of an aimed photon's power that the mirror it meets first
    /// passes on (the pilot's, [`mirror_share`]): 1 for a mirror, the reflected share
    /// for glass crossed between parallel faces.
    pub success: f64,
}

impl Aim {
    /// The mirror groups' spheres, and for each light the power it sends into each
    /// one's cone that meets a mirror first (stratified samples, one ray each), which
    /// weighs its choice of group; then, per light, the power its photons so drawn
    /// bring to mirrors (a pilot), which weighs the choice of light.
    pub fn new(scene: &Scene, accel: &dyn Accel, lights: &[SampledLight]) -> Aim {
        let spheres = mirror_spheres(scene);
        let pairs = (lights.len() * spheres.len()).max(1) as u32;
        let side = ((AIM_RAYS / pairs).clamp(16, AIM_SAMPLES) as f32).sqrt() as u32;
        let n = side * side;
        let found: Vec<Vec<(f64, f64)>> = lights
            .par_iter()
            .map(|light| {
                spheres
                    .iter()
                    .map(|&(c, r)| {
                        let (mut sent, mut met) = (0.0f64, 0.0f64);
                        for k in 0..n {
                            let (i, j) = (k % side, k / side);
                            let u = Vec2::new((i as f32 + 0.5) / side as f32, (j as f32 + 0.5) / side as f32);
                            // The same stratum picks the origin and the direction, in
                            // transposed order, so that both sweep their ranges.
                            let v = Vec2::new(u.y, u.x);
                            let e = match light {
                                SampledLight::Sky(sky) => sky.emit_at(u, v, c, r),
                                _ => light.emit_towards(u, |x| Some(cone_towards(x, c, r, v))),
                            };
                            let Some(e) = e else {
                                continue;
                            };
                            let power = f64::from(mean(e.power));
                            sent += power;
                            met += power * mirror_share(scene, accel, &e);
                        }
                        (met / f64::from(n), sent / f64::from(n))
                    })
                    .collect()
            })
            .collect();
        let weights: Vec<Vec<f64>> = found
            .iter()
            .map(|f| {
                f.iter()
                    .map(|&(met, sent)| met.max(AIM_DEFENSIVE * sent))
                    .collect()
            })
            .collect();
        let mut aim = Aim {
            per_light: weights.iter().map(|w| Alias::new(w)).collect(),
            cones: lights
                .iter()
                .map(|l| match l {
                    SampledLight::Point { position, .. } | SampledLight::Spot { position, .. } => Some(
                        spheres
                            .iter()
                            .map(|&(c, r)| sphere_cone(*position, c, r))
                            .collect(),
                    ),
                    SampledLight::Area(_) | SampledLight::Sun(_) | SampledLight::Sky(_) => None,
                })
                .collect(),
            light_pick: None,
            met: 0.0,
            success: 0.0,
            lanes: SphereLanes::of(&spheres),
            spheres,
        };
        // Each light is drawn by the power it sends to mirrors, as its photons are
        // drawn (a pilot per light): not by its pairs' sum, which counts light in
        // overlapping cones once per cone, and the sun's (whose photons cover the
        // whole scene whatever the aim) once per group.
        let per_light = (AIM_PILOT / lights.len().max(1) as u32).clamp(256, AIM_PILOT);
        let weights: Vec<f64> = (0..lights.len())
            .into_par_iter()
            .map(|l| {
                let seed = derive(AIM_PILOT_SEED, Stream::Light(l as u32));
                let (mut met, mut sent) = (0.0f64, 0.0f64);
                for i in 0..per_light {
                    if let Some(e) = aim.emit_from(l, lights, &mut draws(seed, 3 * i)) {
                        let power = f64::from(mean(e.power));
                        sent += power;
                        met += power * mirror_share(scene, accel, &e);
                    }
                }
                met.max(AIM_DEFENSIVE * sent) / f64::from(per_light)
            })
            .collect();
        aim.light_pick = Alias::new(&weights);
        // The groups' cones overlap, so the pairs' figures do not add up: a pilot of
        // photons drawn as the tracer draws them finds the power that meets mirrors
        // and the share of photons that count.
        let (mut met, mut hits) = (0.0f64, 0.0f64);
        for i in 0..AIM_PILOT {
            if let Some((e, prob)) = aim.emit(lights, &mut draws(AIM_PILOT_SEED, 4 * i)) {
                let share = mirror_share(scene, accel, &e);
                met += f64::from(mean(e.power)) / prob * share;
                hits += share;
            }
        }
        aim.met = met / f64::from(AIM_PILOT);
        aim.success = hits / f64::from(AIM_PILOT);
        aim
    }

    /// A light photon drawn with the numbers `next` gives: a light picked by its
    /// weight, a point on it, and a direction towards a mirror group. Returns the
    /// light that leaves (its power over the direction's density) and the chance of
    /// that light: divide by it, and by the number of photons.
    pub fn emit(
        &self,
        lights: &[SampledLight],
        next: &mut impl FnMut() -> [f32; 3],
    ) -> Option<(Emission, f64)> {
        let table = self.light_pick.as_ref()?;
        let [a, b, c] = next();
        let l = table.pick(a, b, c);
        let e = self.emit_from(l, lights, next)?;
        Some((e, table.probability(l)))
    }

    /// A photon of light `l` drawn with the numbers `next` gives: a point on it and a
    /// direction towards a mirror group, carrying its power over the direction's
    /// density.
    fn emit_from(
        &self,
        l: usize,
        lights: &[SampledLight],
        next: &mut impl FnMut() -> [f32; 3],
    ) -> Option<Emission> {
        let [u, v, _] = next();
        let t = next();
        let [c, d, _] = next();
        if let SampledLight::Sky(sky) = &lights[l] {
            // Parallel rays from the sky: a group, a direction by the sky's
            // brightness, then a place on the disk across the group's sphere; the
            // density per area across the rays is the mixture's over every group
            // whose sphere the ray's line crosses.
            let pick = self.per_light.get(l)?.as_ref()?;
            let (gc, gr) = self.spheres[pick.pick(t[0], t[1], t[2])];
            let e = sky.emit_at(Vec2::new(u, v), Vec2::new(c, d), gc, gr)?;
            let density: f64 = SphereLanes::holding_all(&self.lanes, e.origin, e.dir)
                .map(|k| pick.probability(k) / (std::f64::consts::PI * f64::from(self.spheres[k].1).powi(2)))
                .sum();
            if !(density > 0.0) {
                return None;
            }
            // The emission carries the picked disk's area; over the mixture's density.
            let scale = 1.0 / (PI * gr * gr * density as f32);
            return Some(Emission {
                power: e.power * scale,
                ..e
            });
        }
        lights[l].emit_towards(Vec2::new(u, v), |x| self.direction(l, x, t, Vec2::new(c, d)))
    }

    /// A direction from `x` on light `l` and its density per steradian: a sphere
    /// picked by `u`, then a direction uniform in its cone by `v`; the density is the
    /// mixture's over every sphere whose cone holds the direction.
    fn direction(&self, l: usize, x: Vec3, u: [f32; 3], v: Vec2) -> Option<(Vec3, f32)> {
        let pick = self.per_light.get(l)?.as_ref()?;
        let (c, r) = self.spheres[pick.pick(u[0], u[1], u[2])];
        let (dir, _) = cone_towards(x, c, r, v);
        // The cones from a point or spot light are the same for all its photons.
        let mut pdf = 0.0f64;
        let Some(fixed) = self.cones.get(l).and_then(Option::as_ref) else {
            // From an area light, the sun or the sky: only the cones that hold the
            // direction are built (building all 64 from every photon's origin was
            // most of the time of an area light's photons).
            for k in SphereLanes::holding_all(&self.lanes, x, dir) {
                let p = pick.probability(k);
                if p > 0.0 {
                    let (c, r) = self.spheres[k];
                    pdf += match sphere_cone(x, c, r) {
                        Some((_, omega)) => p / f64::from(omega),
                        None => p / (4.0 * std::f64::consts::PI),
                    };
                }
            }
            return (pdf > 0.0).then_some((dir, pdf as f32));
        };
        for (k, cone) in fixed.iter().enumerate() {
            let p = pick.probability(k);
            if p == 0.0 {
                continue;
            }
            pdf += match *cone {
                Some((axis, omega)) => {
                    if in_cone(axis, omega, dir) {
                        p / f64::from(omega)
                    } else {
                        0.0
                    }
                }
                None => p / (4.0 * std::f64::consts::PI),
            };
        }
        (pdf > 0.0).then_some((dir, pdf as f32))
    }
}

/// Four spheres (centres and squared radii; an unused lane has radius squared -1),
/// tested together for whether a direction from a point lies in the cone from that
/// point round each.
#[derive(Debug, Clone, Copy)]
struct SphereLanes {
    cx: Vec4,
    cy: Vec4,
    cz: Vec4,
    r2: Vec4,
}

impl SphereLanes {
    /// `spheres` four at a time.
    fn of(spheres: &[(Vec3, f32)]) -> Vec<SphereLanes> {
        spheres
            .chunks(4)
            .map(|four| {
                let lane = |k: usize, f: &dyn Fn(Vec3, f32) -> f32, none: f32| {
                    four.get(k).map_or(none, |&(c, r)| f(c, r))
                };
                let v = |f: &dyn Fn(Vec3, f32) -> f32, none: f32| {
                    Vec4::new(
                        lane(0, f, none),
                        lane(1, f, none),
                        lane(2, f, none),
                        lane(3, f, none),
                    )
                };
                SphereLanes {
                    cx: v(&|c, _| c.x, 0.0),
                    cy: v(&|c, _| c.y, 0.0),
                    cz: v(&|c, _| c.z, 0.0),
                    r2: v(&|_, r| r * r, -1.0),
                }
            })
            .collect()
    }

    /// The lanes (bits 0-3) whose cone from `x` holds the unit direction `dir`: its
    /// line passes the centre within the radius, ahead of `x` (without a root, a
    /// division, or cancellation in narrow cones), or `x` is inside the sphere
    /// (every direction meets it).
    #[inline]
    fn holding(&self, x: Vec3, dir: Vec3) -> u32 {
        let (ax, ay, az) = (self.cx - x.x, self.cy - x.y, self.cz - x.z);
        let t = ax * dir.x + ay * dir.y + az * dir.z;
        let (px, py, pz) = (ax - t * dir.x, ay - t * dir.y, az - t * dir.z);
        let perp2 = px * px + py * py + pz * pz;
        let dist2 = ax * ax + ay * ay + az * az;
        let ahead = t.cmpgt(Vec4::ZERO) & perp2.cmple(self.r2);
        (ahead | dist2.cmple(self.r2)).bitmask()
    }

    /// The indices of the spheres in `lanes` whose cones from `x` hold `dir`
    /// ([`SphereLanes::holding`]), in order. From a point beyond the scene they are the
    /// spheres the ray's line crosses.
    fn holding_all(lanes: &[SphereLanes], x: Vec3, dir: Vec3) -> impl Iterator<Item = usize> + '_ {
        lanes.iter().enumerate().flat_map(move |(g, four)| {
            let hits = four.holding(x, dir);
            (0..4)
                .filter(move |j| hits & (1 << j) != 0)
                .map(move |j| 4 * g + j)
        })
    }
}

/// Where a photon is with respect to thick glass.
#[derive(Debug, Clone, Copy, PartialEq)]
enum InGlass {
    Out,
    /// Inside, entered by the face of normal `face` with the state it had before:
    /// leaving by a parallel face it is that light again.
    Entered {
        face: Vec3,
        first: bool,
        source: Option<SourceId>,
    },
    /// Inside, reflected there: it leaves by another way.
    Reflected,
}

/// The numbers of stream `seed` from `from` on, three at a time: a photon's draws.
fn draws(seed: u32, from: u32) -> impl FnMut() -> [f32; 3] {
    let mut k = from;
    move || {
        k += 1;
        uniform3(seed, k - 1)
    }
}

/// Photons of the pilot that measures how much light meets mirrors (see [`Aim`]).
const AIM_PILOT: u32 = 4096;
/// Their seed (any fixed one: the pilot only shares the photons out).
const AIM_PILOT_SEED: u32 = 0x41_494d;

/// The share of light leaving as `e` that the surface it meets first passes on as a
/// mirror does, which the deterministic shots cannot: all of it on a mirror or
/// glossy metal, none on a diffuse surface. A plastic's coating (smooth or glossy)
/// counts whole too, though the tracer passes on only its Fresnel share: counted at
/// that share (2026-11-29), the wooden staircase's aimed photons fell from 1 M to
/// 0.49 M for no solve time measured, and FLIP against Mitsuba went 0.0548 / 0.0554
/// -> 0.0566 / 0.0577 there (two lamps 0.0244 / 0.0258 -> 0.0258 / 0.0274; the metal
/// floor 0.0507 -> 0.0499): the photons the whole share buys light its walls through
/// its wood's coating. Glass passes on what it reflects, and
/// what it bends (a solid glass object's caustic); what crosses it between parallel
/// faces (a window pane, a bulb's wall) is the shots' light
/// ([`crate::interaction::pane_transmittance`]); and what such a pane reflects
/// lights nothing where it leaves the scene (the sky's light off a window's outer
/// face): the glass window traced 290 k such photons for nothing (0.07 s).
fn mirror_share(scene: &Scene, accel: &dyn Accel, e: &Emission) -> f64 {
    let ray = crate::interaction::emission_ray(e);
    let Some(h) = accel.intersect(&ray) else {
        return 0.0;
    };
    let bsdf = &scene.bsdfs[scene.shapes[h.shape as usize].bsdf as usize];
    let kind = &bsdf.kind;
    if !kind.has_mirror() {
        return 0.0;
    }
    let sp = SurfacePoint::new(scene, &ray, &h);
    // The back of a one-sided material passes nothing on, as the tracer finds.
    if !sp.front && !bsdf.twosided {
        return 0.0;
    }
    if !kind.is_glass() || crate::interaction::pane_transmittance(scene, accel, &ray) == 0.0 {
        return 1.0;
    }
    let d = ray.dir.normalize();
    let out = sp.spawn(reflect(d, sp.ng), f32::INFINITY);
    if accel.intersect(&out).is_none() {
        return 0.0;
    }
    let cos = sp.ng.dot(d).abs();
    f64::from(mean(kind.mirror(cos)).clamp(0.0, 1.0))
}

/// A cone of directions: its unit axis and solid angle (see [`sphere_cone`]).
type Cone = (Vec3, f32);

/// A triangle's centroid and corners.
type CentredTriangle = (Vec3, [Vec3; 3]);

/// A direction uniform in the cone from `x` that holds the sphere (`c`, `r`), chosen
/// by `v`, and its density; over the whole sphere of directions where `x` is inside.
fn cone_towards(x: Vec3, c: Vec3, r: f32, v: Vec2) -> (Vec3, f32) {
    let (axis, omega) = sphere_cone(x, c, r).unwrap_or((Vec3::Z, 4.0 * PI));
    (cone_direction(axis, omega, v), 1.0 / omega)
}

/// Bounding spheres of the triangles whose material reflects like a mirror, in at
/// most [`MAX_TARGETS`] groups: the group of the largest sphere is split in two at
/// the median of its triangles' centroids along their widest spread, until there
/// are that many; each group is bounded by a sphere round its triangles' corners.
fn mirror_spheres(scene: &Scene) -> Vec<(Vec3, f32)> {
    // Each triangle: its centroid and corners.
    let mut tris: Vec<CentredTriangle> = Vec::new();
    for shape in &scene.shapes {
        if !scene.bsdfs[shape.bsdf as usize].kind.has_mirror() {
            continue;
        }
        let m = &shape.mesh;
        for t in &m.indices {
            let c = t.map(|i| m.positions[i as usize]);
            tris.push(((c[0] + c[1] + c[2]) / 3.0, c));
        }
    }
    let sphere = |g: &[CentredTriangle]| {
        let centre = g.iter().map(|t| t.0).sum::<Vec3>() / g.len() as f32;
        let radius = g
            .iter()
            .flat_map(|t| t.1)
            .map(|p| (p - centre).length())
            .fold(0.0, f32::max);
        (centre, radius)
    };
    let mut groups: Vec<(&mut [CentredTriangle], (Vec3, f32))> = Vec::new();
    if !tris.is_empty() {
        let s = sphere(&tris);
        groups.push((tris.as_mut_slice(), s));
    }
    while groups.len() < MAX_TARGETS {
        let Some(i) = (0..groups.len())
            .filter(|&i| groups[i].0.len() > 1)
            .max_by(|&a, &b| groups[a].1 .1.total_cmp(&groups[b].1 .1))
        else {
            break;
        };
        let (g, _) = groups.swap_remove(i);
        let (lo, hi) = g
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), t| {
                (lo.min(t.0), hi.max(t.0))
            });
        let axis = (hi - lo).max_position();
        let mid = g.len() / 2;
        g.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
        let (a, b) = g.split_at_mut(mid);
        let (sa, sb) = (sphere(a), sphere(b));
        groups.push((a, sa));
        groups.push((b, sb));
    }
    groups.into_iter().map(|(_, s)| s).collect()
}

/// Whether `dir`, a mirror reflection about the shading normal, leaves on the side of
/// the surface it came from (`ng` faces that side). Where the shading normal leans away
/// from the geometric one (smooth normals on a curved tessellated surface, at grazing
/// angles) it may not; the photon would then be offset to the far side and pass through
/// the surface into a closed object (the renderer drops such reflections too).
fn reflects(dir: Vec3, ng: Vec3) -> bool {
    dir.dot(ng) > 0.0
}

/// Where a photon starts: the unshot light of a patch, a light (aimed at the
/// mirrors), or the light a patch's shots sent (see [`Tracer::shot`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Start {
    Patch,
    Light,
    Shot,
}

/// The share of the scene's surface area that reflects like a mirror or a glossy
/// metal.
pub fn specular_area_share(scene: &Scene) -> f64 {
    let (mut all, mut spec) = (0.0f64, 0.0f64);
    for shape in &scene.shapes {
        let m = &shape.mesh;
        let a: f64 = (0..m.triangle_count())
            .map(|t| {
                let [p, q, r] = m.triangle(t);
                f64::from(0.5 * (q - p).cross(r - p).length())
            })
            .sum();
        all += a;
        if scene.bsdfs[shape.bsdf as usize].kind.has_mirror() {
            spec += a;
        }
    }
    if all > 0.0 {
        spec / all
    } else {
        0.0
    }
}

/// A photon arriving along `dir` at `sp` reflected by a glossy lobe drawn from `u`:
/// its new direction and the lobe's weight (`eval * cos / pdf`); `None` if it leaves
/// below the surface.
fn glossy_bounce(scene: &Scene, lobe: &Glossy, sp: &SurfacePoint, dir: Vec3, u: Vec2) -> Option<(Vec3, Rgb)> {
    let frame = Frame::of_lobe(lobe, sp.ns, || sp.dpdu(scene));
    let (wi, w) = lobe.sample_in(&frame, -dir, u)?;
    reflects(wi, sp.ng).then_some((wi, w))
}

/// Whether any surface of the scene reflects like a mirror.
pub fn has_mirrors(scene: &Scene) -> bool {
    scene.bsdfs.iter().any(|b| b.kind.has_mirror())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{scene, split_quad, v};

    /// Every chunk of every kind comes once; each kind's first chunk comes within
    /// the first three; and at every point of the order each kind has had its share
    /// of its chunks, to within one over and one per kind under (the kinds' first
    /// chunks come first).
    #[test]
    fn chunks_of_every_kind_come_in_their_share_all_along() {
        for counts in [
            [130 * CHUNK, 9 * CHUNK, 3 * CHUNK - 5],
            [5, 40 * CHUNK, 0],
            [0, 0, 7 * CHUNK],
        ] {
            let order = interleave(counts);
            let chunks: Vec<u64> = counts.iter().map(|n| n.div_ceil(CHUNK)).collect();
            assert_eq!(order.len() as u64, chunks.iter().sum::<u64>());
            let mut seen = std::collections::HashSet::new();
            assert!(order.iter().all(|c| seen.insert((c.kind, c.index))));
            for (k, &c) in chunks.iter().enumerate() {
                if c > 0 {
                    let first = order.iter().position(|x| x.kind as usize == k).unwrap();
                    assert!(first < KINDS, "{counts:?}: kind {k} first at {first}");
                }
            }
            let mut had = [0u64; KINDS];
            for (i, c) in order.iter().enumerate() {
                had[c.kind as usize] += 1;
                let done = (i + 1) as f64 / order.len() as f64;
                for k in 0..KINDS {
                    let share = done * chunks[k] as f64;
                    let d = had[k] as f64 - share;
                    assert!(
                        d <= 1.0 + 1e-9 && d >= -(KINDS as f64) - 1e-9,
                        "{counts:?} at {i}: kind {k} {} vs {share}",
                        had[k]
                    );
                }
            }
        }
    }

    /// Photons leave a merged patch wherever it holds unshot light, even in a corner of
    /// a large input triangle far from its centre: the density bound summed over the
    /// pieces (area x largest nearby vertex) is at least the patch's unshot power.
    #[test]
    fn photons_leave_every_lit_cell_of_a_large_triangle() {
        // A 4 x 4 square of two triangles: one lattice patch of 0.25 cells.
        let c = [
            v(0.0, 0.0, 0.0),
            v(4.0, 0.0, 0.0),
            v(4.0, 4.0, 0.0),
            v(0.0, 4.0, 0.0),
        ];
        let s = scene(vec![(split_quad(c, 1), Vec3::splat(0.5))], vec![], &[]);
        let mesh = RadiosityMesh::build(&s, 0.25);
        assert!(matches!(
            mesh.patches[0].grids[0].domain,
            crate::mesh::Domain::Lattice(_)
        ));
        // Unshot light only at the vertex nearest the corner (4, 0).
        let corner = (0..mesh.vertices.len())
            .min_by(|&a, &b| {
                let d = |i: usize| (mesh.vertices[i].p - v(4.0, 0.0, 0.0)).length();
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        let mut unshot = vec![Vec3::ZERO; mesh.vertices.len()];
        unshot[corner] = Vec3::ONE;
        let power = f64::from(mesh.vertices[corner].area);
        let (emit, power_bound) = Tracer::emitters(&mesh, &unshot);
        let bound: f64 = power_bound.iter().sum();
        assert!(
            !emit.is_empty() && bound >= power,
            "bound {bound} < power {power}"
        );
        // And the bound stays local: pieces near the corner only (not the whole square).
        assert!(bound < 8.0 * power, "bound {bound} against {power}");
    }

    /// Photons aimed at mirrors carry to each mirror the power the light sends it:
    /// I times the solid angle the mirror cube is seen under, for two mirror cubes
    /// whose groups' cones overlap (the density is the mixture's over all the groups'
    /// cones): from a point light (whose cones are built once), and from a small
    /// glowing ball of the same intensity (whose cones are tested from each photon's
    /// origin). A spot whose cone meets no mirror gets no photons.
    #[test]
    fn photons_aimed_at_mirrors_carry_the_power_each_one_receives() {
        use crate::accel::Bvh;
        use crate::geometry::front_solid_angle;
        use crate::scene::{BsdfKind, Light};
        use crate::testutil::{box_outside, scene_with};
        let mirror = BsdfKind::Conductor {
            specular_reflectance: Vec3::ONE,
            fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
        };
        let cube = |c: Vec3, h: f32| {
            let mut faces = box_outside(c - Vec3::splat(h), c + Vec3::splat(h));
            let mut m = faces.remove(0);
            for f in faces {
                m.append(&f);
            }
            m
        };
        let diffuse = BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.5),
        };
        let cubes = vec![
            (cube(v(3.0, 0.0, 0.0), 0.3), mirror.clone()),
            (cube(v(3.0, 0.75, 0.0), 0.2), mirror),
            (cube(v(-3.0, 0.0, 0.0), 0.5), diffuse.clone()),
        ];
        let spot = Light::Spot {
            position: Vec3::ZERO,
            direction: Vec3::Y,
            intensity: Vec3::splat(2.0),
            cutoff_angle: 0.3,
            beam_width: 0.2,
        };
        let point = Light::Point {
            position: Vec3::ZERO,
            intensity: Vec3::splat(2.0),
        };
        // A ball of radius b and radiance L has intensity L pi b^2 every way.
        let b = 0.02f32;
        let mut with_ball = cubes.clone();
        with_ball.push((crate::geometry::shapes::sphere(Vec3::ZERO, b), diffuse));
        let ball_radiance = Vec3::splat(2.0 / (PI * b * b));
        // (Half the ball's points face away from the mirrors: fewer photons count.)
        for (s, spot_index, success) in [
            (scene_with(cubes, vec![point, spot.clone()], &[]), 1, 0.5),
            (scene_with(with_ball, vec![spot], &[(3, ball_radiance)]), 0, 0.2),
        ] {
            let accel = Bvh::build(&s);
            let lights = SampledLight::prepare_all(&s);
            let aim = Aim::new(&s, &accel, &lights);
            assert!(aim.spheres.len() > 2, "{} groups", aim.spheres.len());
            let table = aim.light_pick.as_ref().unwrap();
            assert_eq!(table.probability(spot_index), 0.0);
            let n = 400_000u32;
            let mut got = [0.0f64; 4];
            for i in 0..n {
                let Some((e, prob)) = aim.emit(&lights, &mut draws(0x5eed, 4 * i)) else {
                    continue;
                };
                assert_eq!(prob, 1.0);
                let ray = crate::interaction::emission_ray(&e);
                if let Some(h) = accel.intersect(&ray) {
                    got[h.shape as usize] += f64::from(e.power.x) / f64::from(n);
                }
            }
            for (k, shape) in s.shapes.iter().enumerate().take(2) {
                let m = &shape.mesh;
                let tris: Vec<[Vec3; 3]> = m
                    .indices
                    .iter()
                    .map(|t| t.map(|i| m.positions[i as usize]))
                    .collect();
                let want = 2.0 * f64::from(front_solid_angle(Vec3::ZERO, &tris));
                assert!(
                    (got[k] - want).abs() < 0.02 * want,
                    "{:?}, mirror {k}: {} vs {want}",
                    s.lights[0],
                    got[k]
                );
            }
            assert_eq!(got[2], 0.0);
            // The pilot finds the power that meets mirrors, and most aimed photons
            // count (the groups are single triangles' spheres here).
            let want: f64 = got[..2].iter().sum();
            assert!((aim.met - want).abs() < 0.05 * want, "{} vs {want}", aim.met);
            assert!(aim.success > success, "{}", aim.success);
        }
    }

    /// A thin pane of clear glass (1 x 1 m, facing up) seen by a sky: what it
    /// reflects leaves the scene, so its photons would light nothing and none count
    /// as meeting a mirror (what crosses it is the shots' light). Under a lamp in a
    /// closed room, what it reflects stays in the room and counts: the reflected
    /// share of the light that meets it (a thin pane's, 8 % at normal incidence).
    #[test]
    fn a_panes_reflection_counts_only_where_it_stays_in_the_scene() {
        use crate::accel::Bvh;
        use crate::scene::BsdfKind;
        use crate::testutil::{box_inside, quad, scene_with, v};
        let pane = || {
            let q = quad([
                v(-0.5, -0.5, 1.0),
                v(0.5, -0.5, 1.0),
                v(0.5, 0.5, 1.0),
                v(-0.5, 0.5, 1.0),
            ]);
            vec![(q, BsdfKind::clear_glass(1.5, true))]
        };
        let met = |s: &Scene| {
            let accel = Bvh::build(s);
            let lights = SampledLight::prepare_all(s);
            Aim::new(s, &accel, &lights).met
        };
        let open = scene_with(pane(), vec![crate::testutil::uniform_sky(1.0)], &[]);
        assert_eq!(met(&open), 0.0);
        let mut shapes = pane();
        let white = BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.5),
        };
        shapes.extend(
            box_inside(v(-2., -2., 0.), v(2., 2., 3.))
                .into_iter()
                .map(|f| (f, white.clone())),
        );
        let i = 2.0f32;
        let lamp = crate::scene::Light::Point {
            position: v(0.0, 0.0, 2.5),
            intensity: Vec3::splat(i),
        };
        let room = scene_with(shapes, vec![lamp], &[]);
        // The light that meets the pane: i times its solid angle from the lamp,
        // 4 asin(a b / sqrt((a^2 + 4 d^2)(b^2 + 4 d^2))) = 4 asin(1 / 10) sr (a = b =
        // 1, d = 1.5).
        let meets = 4.0 * 0.1f64.asin() * f64::from(i);
        let got = met(&room);
        assert!(got > 0.05 * meets && got < 0.12 * meets, "{got} of {meets}");
    }

    /// A one-sided 2 x 2 m mirror floor at z = 0, facing up, cut into 8 x 8 squares
    /// (many mirror groups), and its material.
    fn mirror_floor() -> (crate::geometry::TriMesh, crate::scene::BsdfKind) {
        use crate::testutil::square;
        let mut floor = square(-1.0, -0.75, -1.0, -0.75, 0.0, false);
        floor.indices.clear();
        floor.positions.clear();
        for j in 0..8 {
            for i in 0..8 {
                let (x, y) = (-1.0 + 0.25 * i as f32, -1.0 + 0.25 * j as f32);
                floor.append(&square(x, x + 0.25, y, y + 0.25, 0.0, false));
            }
        }
        let mirror = crate::scene::BsdfKind::Conductor {
            specular_reflectance: Vec3::ONE,
            fresnel: crate::scene::Fresnel::Schlick { f0: Vec3::ONE },
        };
        (floor, mirror)
    }

    /// The sun's photons do not follow the aim at mirror groups, so it is weighed once
    /// among the lights, not once per group: with the sun and a point light over a
    /// mirror cut into many groups, each light is drawn in proportion to the power it
    /// sends the mirror (the sun: its irradiance times the mirror's area; the point:
    /// I times the mirror's solid angle).
    #[test]
    fn the_sun_is_weighed_once_against_a_lamp_among_the_lights_aimed_at_mirrors() {
        use crate::accel::Bvh;
        use crate::scene::Light;
        use crate::testutil::scene_with;
        // The lamp 1 above the mirror floor's centre.
        let (floor, mirror) = mirror_floor();
        let (e, i) = (3.0f32, 2.0f32);
        let s = scene_with(
            vec![(floor, mirror)],
            vec![
                Light::Directional {
                    direction: -Vec3::Z,
                    irradiance: Vec3::splat(e),
                },
                Light::Point {
                    position: Vec3::new(0.0, 0.0, 1.0),
                    intensity: Vec3::splat(i),
                },
            ],
            &[],
        );
        let accel = Bvh::build(&s);
        let lights = SampledLight::prepare_all(&s);
        let aim = Aim::new(&s, &accel, &lights);
        assert!(aim.spheres.len() >= 16, "{} groups", aim.spheres.len());
        let table = aim.light_pick.as_ref().unwrap();
        // The solid angle of an a x b rectangle from d above its centre is
        // 4 asin(a b / sqrt((a^2 + 4 d^2) (b^2 + 4 d^2))): here 4 asin(1/2). Before,
        // the lights were drawn by their pairs' sums: the sun 0.99 of the time.
        let sun = f64::from(e) * 4.0;
        let lamp = f64::from(i) * 4.0 * 0.5f64.asin();
        let want = sun / (sun + lamp);
        let got = table.probability(0);
        assert!(
            (got - want).abs() < 0.05 * want,
            "the sun drawn {got}, want {want}"
        );
    }

    /// The sky's photons are parallel rays aimed at the mirror groups' spheres (the
    /// density per area across the rays is the mixture's over the spheres each line
    /// crosses): under a uniform sky of radiance L, those that meet the front of a
    /// one-sided 2 x 2 m mirror floor of 64 squares (many overlapping groups) carry
    /// L pi A, what the sky sends it; those from below meet its back, which passes
    /// nothing on, and the pilot does not count them.
    #[test]
    fn sky_photons_aimed_at_a_mirror_floor_carry_what_the_sky_sends_it() {
        use crate::accel::Bvh;
        use crate::testutil::scene_with;
        let (floor, mirror) = mirror_floor();
        let l = 1.5f32;
        let s = scene_with(vec![(floor, mirror)], vec![crate::testutil::uniform_sky(l)], &[]);
        let accel = Bvh::build(&s);
        let lights = SampledLight::prepare_all(&s);
        let aim = Aim::new(&s, &accel, &lights);
        assert!(aim.spheres.len() >= 16, "{} groups", aim.spheres.len());
        let want = f64::from(l) * std::f64::consts::PI * 4.0;
        let n = 200_000u32;
        let (mut front, mut back) = (0.0f64, 0u32);
        for i in 0..n {
            let Some((e, prob)) = aim.emit(&lights, &mut draws(0x5eed, 4 * i)) else {
                continue;
            };
            assert_eq!(prob, 1.0);
            assert!(e.origin.length() > 1.4, "photons come from beyond the scene");
            if accel.intersect(&crate::interaction::emission_ray(&e)).is_some() {
                if e.dir.z < 0.0 {
                    front += f64::from(e.power.x) / f64::from(n);
                } else {
                    back += 1;
                }
            }
        }
        assert!((front - want).abs() < 0.02 * want, "{front} vs {want}");
        assert!(back > n / 10, "{back} photons from below");
        assert!(
            (aim.met - want).abs() < 0.05 * want,
            "the pilot: {} vs {want}",
            aim.met
        );
    }
}
