//! The stochastic part of pass 1: the power the deterministic shots leave unshot is
//! carried by photons (particle tracing, "stochastic shooting": Neumann et al. 1995,
//! Bekaert's collision estimator), whose cost follows the rays cast, not vertices x
//! shots.
//!
//! Photons leave the radiant patches in proportion to their unshot radiosity (and,
//! when the scene has mirrors, the light sources: light -> mirror -> diffuse paths,
//! paper Sect. 6). At every diffuse hit a photon leaves its reflected power on the
//! vertices of the element hit, in proportion to their interpolation weights and
//! inversely to their areas, so a smooth field is estimated without bias; then it is
//! reflected diffusely or specularly, or absorbed (Russian roulette on the
//! reflectance). Light that comes straight from a source listed on the patch hit goes
//! to that list entry, everything else to the general radiosity: one route per source.
//!
//! Photons are traced in fixed chunks whose deposits are added in chunk order, so the
//! result depends on the seed alone, never on the threads.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::accel::{Accel, Ray};
use crate::emitters::SampledLight;
use crate::interaction::{offset_from, reflect, SurfacePoint};
use crate::mesh::{point_in_polygon, Piece, RadiosityMesh};
use crate::sampling::{cosine_direction, shot_seed, uniform3, Alias};
use crate::scene::{mean, Rgb, Scene};

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
    pub emit_pick: Option<Alias>,
    /// Photons from patches, and from lights (only with mirrors in the scene).
    pub patch_photons: u64,
    pub light_photons: u64,
    /// The lights, prepared, drawn by their powers.
    pub lights: Vec<SampledLight>,
    pub light_pick: Option<Alias>,
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

    /// Traces chunk `c` and returns its deposits and the rays cast.
    pub fn chunk(&self, c: u64) -> (Vec<Deposit>, u64) {
        let mut out = Vec::new();
        let mut rays = 0;
        let total = self.total();
        for i in c * CHUNK..((c + 1) * CHUNK).min(total) {
            let seed = shot_seed(self.seed, SEED_BASE + i);
            let mut draw = 0u32;
            let mut next = || {
                draw += 1;
                uniform3(seed, draw)
            };
            let (origin, normal, dir, power, source, from_light) = if i < self.patch_photons {
                let Some(table) = &self.emit_pick else { continue };
                let [a, b, cc] = next();
                let k = table.pick(a, b, cc);
                let e = &self.emit[k];
                let [b, cc, _] = next();
                let x = point_in_polygon(&e.corners, Vec2::new(b, cc));
                let n = (e.corners[1] - e.corners[0]).cross(e.corners[2] - e.corners[0]);
                let area = 0.5 * n.length();
                let n = n.normalize_or(Vec3::Z);
                // A curved patch's piece is a chord of its surface: photons leave from
                // the surface, not from inside a closed object.
                let (x_out, n_out) = self.mesh.surface_at(e, x).unwrap_or((x, n));
                let prob = table.probability(k);
                let w = self.mesh.weights_on(e, x);
                let b_unshot = w.apply(self.unshot);
                // Radiosity B over area A sends B A; per photon over its probability.
                let power = b_unshot * (area / (prob as f32 * self.patch_photons as f32));
                let [u, v, _] = next();
                (
                    x_out,
                    n_out,
                    cosine_direction(n_out, Vec2::new(u, v)),
                    power,
                    Some(SourceId::Patch(e.patch)),
                    false,
                )
            } else {
                let Some(table) = &self.light_pick else { continue };
                let [a, b, c] = next();
                let l = table.pick(a, b, c);
                let count = self.light_photons as f32 * table.probability(l) as f32;
                let [u, v, _] = next();
                let [c, d, _] = next();
                match self.lights[l].emit([u, v, c, d]) {
                    Some(e) => (
                        e.origin,
                        e.normal.unwrap_or(Vec3::ZERO),
                        e.dir,
                        e.power / count,
                        None,
                        true,
                    ),
                    None => continue,
                }
            };
            if !(power.max_element() > 0.0) {
                continue;
            }
            self.trace(
                origin, normal, dir, power, source, from_light, &mut next, &mut out, &mut rays,
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
        from_light: bool,
        next: &mut impl FnMut() -> [f32; 3],
        out: &mut Vec<Deposit>,
        rays: &mut u64,
    ) {
        let mut first = from_light;
        // Still on a light -> mirror(s) path.
        let mut caustic = from_light;
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
            let rho = bsdf.kind.diffuse_albedo();
            let cos = (-dir).dot(sp.ns).max(0.0);
            let spec = bsdf.kind.mirror(cos);
            if first {
                // Straight from a light: the deterministic shots hold that; only the
                // mirrors pass it on.
                first = false;
                let ps = mean(spec).min(1.0);
                let [u, _, _] = next();
                if !(ps > 0.0) || u >= ps {
                    return;
                }
                dir = reflect(dir, sp.ns);
                if !reflects(dir, sp.ng) {
                    return;
                }
                power *= spec / ps;
                origin = sp.p;
                normal = sp.ng;
                source = None;
                continue;
            }
            let q = self.mesh.patch_at(self.scene, &hit, sp.front);
            if rho.max_element() > 0.0 {
                let w = self.mesh.locate_on(self.scene, q, &hit, sp.p);
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
                                value: rho * power * (w.weights[k] / area),
                                caustic,
                            });
                        }
                    }
                }
            }
            let (pd, ps) = (mean(rho).min(1.0), mean(spec).min(1.0));
            let [u, a, b] = next();
            if u < pd {
                power *= rho / pd;
                dir = cosine_direction(sp.ns, Vec2::new(a, b));
                if dir.dot(sp.ng) <= 0.0 {
                    return;
                }
                source = Some(SourceId::Patch(q));
                caustic = false;
            } else if u < pd + ps && ps > 0.0 {
                power *= spec / ps;
                dir = reflect(dir, sp.ns);
                if !reflects(dir, sp.ng) {
                    return;
                }
                source = None;
            } else {
                return;
            }
            origin = sp.p;
            normal = sp.ng;
        }
    }

    /// Photons in all.
    pub fn total(&self) -> u64 {
        self.patch_photons + self.light_photons
    }

    /// Number of chunks.
    pub fn chunks(&self) -> u64 {
        self.total().div_ceil(CHUNK)
    }

    /// Photons in the first `chunks` chunks.
    pub fn photons_in(&self, chunks: u64) -> u64 {
        (chunks * CHUNK).min(self.total())
    }

    /// Traces chunks `range` in parallel; their deposits in chunk order.
    pub fn trace_chunks(&self, range: std::ops::Range<u64>) -> Vec<(Vec<Deposit>, u64)> {
        range.into_par_iter().map(|c| self.chunk(c)).collect()
    }
}

/// Whether `dir`, a mirror reflection about the shading normal, leaves on the side of
/// the surface it came from (`ng` faces that side). Where the shading normal leans away
/// from the geometric one (smooth normals on a curved tessellated surface, at grazing
/// angles) it may not; the photon would then be offset to the far side and pass through
/// the surface into a closed object (the renderer drops such reflections too).
fn reflects(dir: Vec3, ng: Vec3) -> bool {
    dir.dot(ng) > 0.0
}

/// Whether any surface of the scene reflects like a mirror.
pub fn has_mirrors(scene: &Scene) -> bool {
    scene.bsdfs.iter().any(|b| b.kind.has_mirror())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{scene, split_quad, v};

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
}
