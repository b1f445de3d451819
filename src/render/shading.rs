//! Shading at ray hits: emission, direct light by shadow rays, mirror reflection.

use glam::Vec3;

use super::counters::Counters;
use super::gather::{self, Gather};
use super::glass;
use super::sib::{self, Lighting, SibQuery, NORMAL_AGREES};
use super::Settings;
use crate::accel::{Accel, Hit, Ray};
use crate::bsdf::microfacet::Frame;
use crate::camera::PixelScale;
use crate::emitters::{group_point, group_point_in, SampledLight};
use crate::interaction::{pane_transmittance, reflect, transmittance, SurfacePoint};
use crate::mesh::{Interp, RadiosityMesh};
use crate::radiosity::Parted;
use crate::sampling::{derive, stratum, uniform2, Stratum, Stream};
use crate::scene::{Bsdf, BsdfKind, Glossy, Rgb, Scene};
use crate::selection::{Pick, Selection};

/// Where the light of diffuse surfaces comes from.
enum Diffuse<'a> {
    /// Shadow rays to every light source (`--method direct`): these picks on every
    /// surface.
    Direct(Vec<Pick>),
    /// The radiosity solution's stored radiosity, interpolated, plus shadow rays to
    /// the sources a selection picked for the patch hit (`twopass`, `norm`, `local`,
    /// `global`).
    Selected {
        mesh: &'a RadiosityMesh,
        selection: &'a Selection<'a>,
    },
}

/// Follows rays through a scene and returns the radiance they carry back.
pub struct Tracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    /// The ray-traced sources: the scene's lights (`direct`) or the selection's.
    sources: std::borrow::Cow<'a, [SampledLight]>,
    /// Sub-sources per area source (and the most rays one is sampled with).
    area_samples: u32,
    max_depth: u32,
    diffuse: Diffuse<'a>,
    /// The final gather at first diffuse hits (`--gather`), if on.
    gather: Option<Gather>,
    /// How large lengths look on the camera's film (None: unknown): camera rays'
    /// footprints, over which mipmapped textures are read, are a pixel's width there.
    pixel_scale: Option<PixelScale>,
    /// With a solution: its total radiosity per vertex (what rays drawn from a glossy
    /// lobe or rough glass read where they land), and the pieces of its mesh that a
    /// wall stands on, where a hit reads the vertices it sees ([`Parted`]): at the
    /// eye, after a mirror or a glossy lobe, and at the gather's rays' ends.
    parted: Option<Parted>,
}

impl<'a> Tracer<'a> {
    /// A tracer for `scene` with the sampling counts of `settings` that computes
    /// direct light with shadow rays to every light.
    pub fn new(scene: &'a Scene, accel: &'a dyn Accel, settings: &Settings) -> Self {
        let sources = SampledLight::prepare_all(scene);
        let area_samples = settings.area_samples.max(1);
        let picks = sources
            .iter()
            .enumerate()
            .map(|(i, l)| Pick {
                source: i as u32,
                rays: if l.is_area() { area_samples } else { 1 },
            })
            .collect();
        Tracer {
            scene,
            accel,
            sources: sources.into(),
            area_samples,
            max_depth: settings.max_depth,
            diffuse: Diffuse::Direct(picks),
            gather: None,
            pixel_scale: None,
            parted: None,
        }
    }

    /// A tracer that shades diffuse surfaces from a radiosity solution with the
    /// sources `selection` picked ray traced.
    pub fn with_selection(
        scene: &'a Scene,
        accel: &'a dyn Accel,
        settings: &Settings,
        selection: &'a Selection<'a>,
    ) -> Self {
        Tracer {
            scene,
            accel,
            sources: selection.emitters.as_slice().into(),
            area_samples: settings.area_samples.max(1),
            max_depth: settings.max_depth,
            diffuse: Diffuse::Selected {
                mesh: &selection.solution.mesh,
                selection,
            },
            gather: None,
            pixel_scale: None,
            parted: Some(Parted::new(
                &selection.solution.mesh,
                accel,
                selection.solution.total(),
            )),
        }
    }

    /// The pieces of the solution's mesh that a wall stands on (with a solution).
    pub fn parted(&self) -> Option<&Parted> {
        self.parted.as_ref()
    }

    /// Interpolation weights at a hit on the solution's mesh: the vertices about it
    /// that it sees, where a wall stands between them ([`Parted`]).
    fn locate(&self, mesh: &RadiosityMesh, hit: &Hit, sp: &SurfacePoint) -> Interp {
        let mut w = mesh.locate(self.scene, hit, sp.p, sp.front);
        if let Some(parted) = &self.parted {
            parted.keep_visible(mesh, self.accel, &mut w, sp.p);
        }
        w
    }

    /// Gathers at first diffuse hits with `gather` (see [`gather`]).
    pub fn set_gather(&mut self, gather: Gather) {
        self.gather = Some(gather);
    }

    /// Camera rays (depth 0) read mipmapped textures at their hits over the width a
    /// pixel spans there.
    pub fn set_pixel_scale(&mut self, scale: PixelScale) {
        self.pixel_scale = Some(scale);
    }

    /// Number of ray-traced sources (the length of [`Counters::sources`]).
    pub fn source_count(&self) -> usize {
        self.sources.len()
    }

    /// The bounds of every shape that emits light (an area light's shape), which
    /// the camera may see.
    pub fn emitter_bounds(&self) -> Vec<(Vec3, Vec3)> {
        self.scene
            .shapes
            .iter()
            .filter(|s| s.emitter.is_some())
            .filter_map(|s| s.mesh.bounds())
            .collect()
    }

    /// Whether each ray-traced source is a point or spot light (one light point).
    pub fn point_sources(&self) -> Vec<bool> {
        self.sources.iter().map(|s| !s.is_area()).collect()
    }

    /// Radiance arriving along `ray` (towards its origin). `depth` counts mirror
    /// reflections so far; `seed` decorrelates the light samples of this path.
    pub fn radiance(&self, ray: &Ray, depth: u32, seed: u32, counters: &mut Counters) -> Rgb {
        self.trace(ray, depth, seed, counters, None, true)
    }

    /// Radiance along a primary ray whose first diffuse hit decides its shadow rays
    /// with the shadow image buffer `sib` (and fills its record); deeper diffuse hits
    /// (seen in mirrors) cast all their rays (paper Sect. 7).
    pub fn radiance_sib(&self, ray: &Ray, seed: u32, counters: &mut Counters, sib: &mut SibQuery) -> Rgb {
        self.trace(ray, 0, seed, counters, Some(sib), true)
    }

    fn trace(
        &self,
        ray: &Ray,
        depth: u32,
        seed: u32,
        counters: &mut Counters,
        mut sib: Option<&mut SibQuery>,
        emit: bool,
    ) -> Rgb {
        let Some(hit) = self.accel.intersect(ray) else {
            // The sky (its light is never sampled at a glossy hit: the lobe's rays
            // find it), and the sun's disk where rays that see emitters meet it (its
            // light at a surface is the sun's, sampled).
            let sun = if emit {
                self.scene.sun_seen(ray.dir)
            } else {
                Vec3::ZERO
            };
            return self.scene.sky(ray.dir) + sun;
        };
        if let Some(q) = sib.as_deref_mut() {
            q.object = hit.shape;
        }
        let mut sp = SurfacePoint::new(self.scene, ray, &hit);
        if depth == 0 {
            if let Some(scale) = self.pixel_scale {
                sp = sp.with_footprint(scale.length(1.0, hit.t * ray.dir.length()));
            }
        }
        let mut l = Vec3::ZERO;
        if sp.front && emit {
            l += sp.emitted(self.scene).unwrap_or(Vec3::ZERO);
        }
        let (bsdf, kind) = sp.material(self.scene);
        if let Some((on, through)) = self.through_mask(&sp, bsdf, ray, seed) {
            // Through a mask's open part, as if the surface were not there.
            return self.trace(&through, depth, on, counters, sib, emit);
        }
        let sp = sp.bumped(self.scene, bsdf, -ray.dir);
        if kind.is_glass() {
            if let Some(rough) = self.rough_glass(&kind, &sp, ray, depth, seed, counters) {
                return l + rough;
            }
            return l + self.through_glass(&kind, &sp, ray, depth, seed, counters, |t, r, s, c| {
                t.trace(r, depth + 1, s, c, None, true)
            });
        }
        if !sp.front && !bsdf.twosided {
            return l; // the back of a one-sided material is black, as in Mitsuba
        }
        let wo = -ray.dir;
        let cos_v = sp.ns.dot(wo);
        if cos_v <= 0.0 {
            return l;
        }
        // A retextured sample's first hit on an object whose light it was given,
        // facing the way that light was found: that light through this hit's texel,
        // and the rest as given (nothing more is traced) or traced anew. Elsewhere
        // (another object, another material, the surface turned) the sample is
        // traced in full.
        let given = sib
            .as_ref()
            .and_then(|q| q.given.iter().flatten().find(|g| g.object == hit.shape).copied())
            .filter(|g| {
                depth == 0
                    && l == Vec3::ZERO
                    && g.normal.dot(sp.ns) >= NORMAL_AGREES
                    && Lighting::applies(bsdf, &kind)
            });
        if let Some(g) = given {
            counters.retextured += 1;
            let diffuse = kind.diffuse_albedo() * g.per_albedo;
            l += diffuse;
            if let Some(q) = sib.as_deref_mut() {
                q.lighting = Lighting::new(kind.diffuse_albedo(), diffuse, sp.ns);
            }
            if let Some(rest) = g.rest {
                return l + rest;
            }
        } else if kind.has_diffuse() {
            counters.diffuse_hits += 1;
            let before = l;
            let shade = Shade {
                sp: &sp,
                kind: &kind,
                cos_v,
                seed,
            };
            let usable = sib.as_ref().is_some_and(|q| q.usable(hit.shape));
            l += match &self.diffuse {
                Diffuse::Direct(picks) => {
                    let mut sum = Vec3::ZERO;
                    for pick in picks {
                        sum += self.sample_source(*pick, &shade, counters, sib.as_deref_mut(), usable);
                    }
                    sum
                }
                Diffuse::Selected { mesh, selection } => {
                    // Diffuse radiance L = B / pi, B interpolated from the mesh
                    // vertices, plus the ray-traced sources of the patch.
                    let interp = self.locate(mesh, &hit, &sp);
                    let patch = mesh.vertices[interp.vertices[0] as usize].patch;
                    let textured = texture_ratio(bsdf, &kind, mesh, &interp);
                    // The solution's radiosity is the diffuse part's mean over the view
                    // directions; behind a coating it depends on the view.
                    let seen = kind.diffuse_seen(cos_v);
                    let mut sum = match (&self.gather, depth) {
                        // The paper's last step: the gather replaces the general
                        // radiosity but its caustic part (see `gather` for the one
                        // route per source), and the lights folded there are sampled.
                        (Some(g), 0) => {
                            let ctx = gather::Context {
                                scene: self.scene,
                                accel: self.accel,
                                solution: selection.solution,
                                lights: &self.sources[..self.scene.lights.len()],
                                area_samples: self.area_samples,
                                parted: self.parted.as_ref(),
                            };
                            let stratum = sib.as_ref().map_or(Stratum::WHOLE, |q| q.stratum);
                            // On a bumped surface the gather's rays find how the
                            // tilted normal sees the room (weighed by the terminator
                            // term); the solution's light kept beside them, found at
                            // the untilted normal, is taken as arriving evenly
                            // (`hemisphere_share`).
                            let e = g.irradiance(&ctx, &sp, patch, seed, stratum, counters);
                            let mut sum = (g.kept(&interp) * textured * seen * sp.hemisphere_share()
                                + kind.diffuse_albedo_at(cos_v) * e)
                                * std::f32::consts::FRAC_1_PI;
                            for &l in g.folded(patch) {
                                let rays = if self.sources[l as usize].is_area() {
                                    gather::FOLDED_AREA_RAYS
                                } else {
                                    1
                                };
                                sum += self.sample_source(
                                    Pick { source: l, rays },
                                    &shade,
                                    counters,
                                    None,
                                    false,
                                );
                            }
                            sum
                        }
                        _ => {
                            interp.apply(&selection.stored)
                                * textured
                                * seen
                                * (std::f32::consts::FRAC_1_PI * sp.hemisphere_share())
                        }
                    };
                    for pick in selection.picks(patch) {
                        sum += self.sample_source(*pick, &shade, counters, sib.as_deref_mut(), usable);
                    }
                    sum
                }
            };
            // What the texture multiplies, for the anti-aliasing samples that take
            // this sample's light (`SibQuery::given`).
            if let Some(q) = sib.filter(|_| depth == 0 && before == Vec3::ZERO) {
                q.lighting = Lighting::of(bsdf, &kind, l, sp.ns);
            }
        }
        if depth < self.max_depth {
            if let Some(lobe) = kind.glossy() {
                l += self.glossy(&lobe, &sp, wo, depth, seed, counters);
            }
            let m = kind.mirror(cos_v);
            if m.max_element() > 0.0 {
                let dir = reflect(ray.dir, sp.ns).normalize();
                if dir.dot(sp.ng) > 0.0 {
                    counters.reflection_rays += 1;
                    let refl = sp.spawn(dir, f32::INFINITY);
                    l += m
                        * sp.terminator(dir)
                        * self.trace(
                            &refl,
                            depth + 1,
                            derive(seed, Stream::Reflection),
                            counters,
                            None,
                            true,
                        );
                }
            }
        }
        l
    }

    /// What a glossy lobe at `sp` reflects towards `wo`: the lights by light
    /// sampling (a point or spot light one shadow ray, an area light
    /// [`GLOSSY_LIGHT_SAMPLES`] at a primary hit and one deeper), and the rest by rays
    /// drawn from the lobe ([`GLOSSY_RAYS`] at a primary hit, one at the next, none
    /// from [`GLOSSY_DEPTH`] on: classroom 27.1 -> 19.8 s, FLIP against Mitsuba 0.153
    /// -> 0.157, within its 256-spp reference's noise), each reading what it meets
    /// ([`Self::reflected`]: the solution's light, further mirrors and lobes). An area
    /// light the lobe's rays meet counts too: its light samples and those rays are
    /// weighed against each other by the power heuristic (multiple importance
    /// sampling, Veach 1995), so a small bright light in a wide lobe and a large one
    /// in a sharp lobe are both found. Every light arrives by one route.
    fn glossy(
        &self,
        lobe: &Glossy,
        sp: &SurfacePoint,
        wo: Vec3,
        depth: u32,
        seed: u32,
        counters: &mut Counters,
    ) -> Rgb {
        let frame = Frame::of_lobe(lobe, sp.ns, || sp.dpdu(self.scene));
        let wo_l = frame.local(wo);
        let n = match depth {
            0 => GLOSSY_RAYS,
            d if d < GLOSSY_DEPTH => 1,
            _ => 0,
        };
        // The lobe's rays see area lights only where they read the solution (else
        // the full shading behind them leaves emitters out): then the two are weighed.
        let mis = n > 0 && self.parted.is_some();
        let lights = &self.sources[..self.scene.lights.len()];
        let samples = |light: &SampledLight| match (light.is_area(), depth) {
            (false, _) | (true, 1..) => 1,
            (true, 0) => GLOSSY_LIGHT_SAMPLES.min(self.area_samples),
        };
        let seed = derive(seed, Stream::Reflection);
        let mut l = Vec3::ZERO;
        for k in 0..n {
            let Some((wi_l, w)) = lobe.sample(wo_l, stratum(seed, 0, k, n)) else {
                continue;
            };
            let wi = frame.world(wi_l);
            if wi.dot(sp.ng) <= 0.0 {
                continue;
            }
            counters.reflection_rays += 1;
            let ray = sp.spawn(wi, f32::INFINITY);
            let (radiance, emitter) =
                self.reflected(&ray, depth + 1, derive(seed, Stream::Sample(k)), false, counters);
            let mut got = radiance;
            if let (true, Some((li, le, p_l))) = (mis, emitter) {
                let p_b = lobe.pdf(wo_l, wi_l);
                let r = samples(&lights[li as usize]) as f32;
                got += le * power_heuristic(n as f32 * p_b, r * p_l);
            }
            l += w * got * (sp.terminator(wi) / n as f32);
        }
        // The light samples' BSDF and the lobe's density towards them (the sky's light
        // is left to the lobe's rays).
        l += self.light_samples(sp, seed, mis, &samples, counters, |dir| {
            if sp.ns.dot(dir) <= 0.0 || sp.ng.dot(dir) <= 0.0 {
                return None;
            }
            let wi_l = frame.local(dir);
            let (f, pdf) = lobe.eval_pdf(wi_l, wo_l);
            Some((f * sp.terminator(dir), n as f32 * pdf))
        });
        l
    }

    /// Where a ray meeting a `mask`ed surface at `sp` goes on through its open part
    /// (drawn by its opacity): the ray on, and its seed.
    fn through_mask(&self, sp: &SurfacePoint, bsdf: &Bsdf, ray: &Ray, seed: u32) -> Option<(u32, Ray)> {
        if !bsdf.masked() {
            return None;
        }
        let on = derive(seed, Stream::Transmission);
        sp.passes(self.scene, bsdf, uniform2(on).x)
            .then(|| (on, sp.spawn(ray.dir, f32::INFINITY)))
    }

    /// What glass at `sp` passes back along `ray`: its reflected and transmitted rays
    /// ([`glass::rays`]), each followed by `follow` and weighted, within the depth limit.
    #[allow(clippy::too_many_arguments)]
    fn through_glass(
        &self,
        kind: &BsdfKind,
        sp: &SurfacePoint,
        ray: &Ray,
        depth: u32,
        seed: u32,
        counters: &mut Counters,
        mut follow: impl FnMut(&Self, &Ray, u32, &mut Counters) -> Rgb,
    ) -> Rgb {
        let mut l = Vec3::ZERO;
        if depth < self.max_depth {
            let dpdu = kind.glass_dpdu(|| sp.dpdu(self.scene));
            for (r, w, s) in glass::rays(kind, sp, dpdu, ray.dir, depth, seed) {
                counters.reflection_rays += 1;
                l += w * follow(self, &r, s, counters);
            }
        }
        l
    }

    /// Direct light at `sp` from light samples of every light but the sky (whose
    /// light rays drawn from the BSDF find): `samples(light)` of each, a sample
    /// towards `dir` bringing `bsdf(dir)`'s value (`None` or zero: none, and no shadow
    /// ray) times the cosine, weighed with `mis` by the power heuristic against the
    /// density per steradian of the BSDF's rays towards it, which `bsdf` gives too.
    fn light_samples(
        &self,
        sp: &SurfacePoint,
        seed: u32,
        mis: bool,
        samples: &dyn Fn(&SampledLight) -> u32,
        counters: &mut Counters,
        bsdf: impl Fn(Vec3) -> Option<(Rgb, f32)>,
    ) -> Rgb {
        let mut l = Vec3::ZERO;
        for (i, light) in self.sources[..self.scene.lights.len()].iter().enumerate() {
            if light.sky().is_some() {
                continue;
            }
            let r = samples(light);
            let light_seed = derive(seed, Stream::Light(i as u32));
            let mut cast = 0;
            for g in 0..r {
                let (_, _, uv) = group_point(g, r, r, light_seed);
                let Some(s) = light.sample(sp.p, uv) else { continue };
                let Some((f, p_b)) = bsdf(s.dir) else { continue };
                if f.max_element() <= 0.0 {
                    continue;
                }
                // The light sample's density per steradian, against the BSDF's rays'.
                let weight = match (mis, s.normal.and_then(|nl| light.density(sp.p, s.point, nl))) {
                    (true, Some(p_l)) => power_heuristic(r as f32 * p_l, p_b),
                    _ => 1.0,
                };
                cast += 1;
                let t = transmittance(self.scene, self.accel, &sp.shadow_ray(s.point, s.normal));
                if t > 0.0 {
                    l += f * s.value * (sp.ns.dot(s.dir).abs() * weight * t / r as f32);
                }
            }
            counters.count_source(i, cast, 0);
        }
        l
    }

    /// What rough glass (`roughdielectric`) at `sp` passes back along `ray` near the
    /// eye (with a solution, within [`glass::GLASS_SPLIT_DEPTH`] bounces), as a glossy
    /// lobe's is: its reflected and transmitted rays about one facet
    /// ([`glass::rays_about`]; [`glass::PRIMARY_FACETS`] stratified facets at a
    /// primary hit) read the solution where they land ([`Self::reflected`]), and
    /// the lights' direct light through it or off it comes from light samples
    /// ([`GLOSSY_LIGHT_SAMPLES`] of an area light, one of a point), the two weighed
    /// against each other by the power heuristic. Without this, the one ray drawn per
    /// hit found a lamp behind frosted glass only by chance: sparkles. `None`
    /// elsewhere (smooth glass, deeper hits): [`Self::through_glass`].
    fn rough_glass(
        &self,
        kind: &BsdfKind,
        sp: &SurfacePoint,
        ray: &Ray,
        depth: u32,
        seed: u32,
        counters: &mut Counters,
    ) -> Option<Rgb> {
        if !kind.is_rough_glass()
            || depth >= glass::GLASS_SPLIT_DEPTH
            || depth >= self.max_depth
            || self.parted.is_none()
        {
            return None;
        }
        let wo = -ray.dir;
        let outward = if sp.front { sp.ns } else { -sp.ns };
        let lights = &self.sources[..self.scene.lights.len()];
        let samples = |light: &SampledLight| {
            if light.is_area() {
                GLOSSY_LIGHT_SAMPLES.min(self.area_samples)
            } else {
                1
            }
        };
        let mut l = Vec3::ZERO;
        let dpdu = kind.glass_dpdu(|| sp.dpdu(self.scene));
        let facets = if depth == 0 { glass::PRIMARY_FACETS } else { 1 };
        for k in 0..facets {
            let u = stratum(derive(seed, Stream::Transmission), 1, k, facets);
            let fs = derive(seed, Stream::Sample(k));
            for (r, w, s) in glass::rays_about(kind, sp, dpdu, ray.dir, depth, fs, u) {
                counters.reflection_rays += 1;
                let (radiance, emitter) = self.reflected(&r, depth + 1, s, false, counters);
                let mut got = radiance;
                if let Some((li, le, p_l)) = emitter {
                    let p_b = kind
                        .rough_glass_eval(wo, r.dir, outward, dpdu)
                        .map_or(0.0, |x| x.1);
                    got += le * power_heuristic(p_b, samples(&lights[li as usize]) as f32 * p_l);
                }
                l += w * got / facets as f32;
            }
        }
        let seed = derive(seed, Stream::Reflection);
        l += self.light_samples(sp, seed, true, &samples, counters, |dir| {
            // The same side of the surface by both normals.
            if (dir.dot(sp.ng) > 0.0) != (dir.dot(sp.ns) > 0.0) {
                return None;
            }
            kind.rough_glass_eval(wo, dir, outward, dpdu)
        });
        Some(l)
    }

    /// Radiance along a ray drawn from a glossy lobe, without emitters' radiance:
    /// with a solution, the total radiosity where it lands (scaled by a texture
    /// there), and mirrors and lobes followed; without one, the full shading. With
    /// a solution, also the area light it lands on, if it does (on its front): the
    /// light's index, its radiance and the density per steradian of that light's own
    /// samples at the point.
    ///
    /// `specular`: the ray was reflected by a mirror or smooth glass on the way from
    /// the lobe, where no light sample goes: an area light it meets and the sun's
    /// disk count whole (light -> mirror -> lobe: a lamp's image in a mirror, seen in
    /// a glossy floor).
    fn reflected(
        &self,
        ray: &Ray,
        depth: u32,
        seed: u32,
        specular: bool,
        counters: &mut Counters,
    ) -> (Rgb, Option<(u32, Rgb, f32)>) {
        let (Diffuse::Selected { mesh, .. }, Some(total)) =
            (&self.diffuse, self.parted.as_ref().map(Parted::field))
        else {
            return (self.trace(ray, depth, seed, counters, None, false), None);
        };
        let Some(hit) = self.accel.intersect(ray) else {
            let sun = if specular {
                self.scene.sun_seen(ray.dir)
            } else {
                Vec3::ZERO
            };
            return (self.scene.sky(ray.dir) + sun, None);
        };
        let sp = SurfacePoint::new(self.scene, ray, &hit);
        let emitter = match (sp.front, self.scene.shapes[hit.shape as usize].emitter) {
            (true, Some(e)) => match (
                &self.scene.lights[e as usize],
                self.sources[e as usize].density(ray.origin, sp.p, sp.ng),
            ) {
                (crate::scene::Light::Area { .. }, Some(p_l)) => sp.emitted(self.scene).map(|l| (e, l, p_l)),
                _ => None,
            },
            _ => None,
        };
        let (bsdf, kind) = sp.material(self.scene);
        if let Some((on, through)) = self.through_mask(&sp, bsdf, ray, seed) {
            return self.reflected(&through, depth, on, specular, counters);
        }
        let sp = sp.bumped(self.scene, bsdf, -ray.dir);
        if kind.is_glass() {
            if let Some(l) = self.rough_glass(&kind, &sp, ray, depth, seed, counters) {
                return (l, emitter);
            }
            // Light reflected by smooth glass, as by a mirror, no light sample finds.
            // Through it, shadow rays cross a thin pane (and thick glass between
            // parallel faces), so the light samples count what lies beyond, unless a
            // mirror came first; rough glass so deep keeps to the solution's light.
            let smooth = !kind.is_rough_glass();
            let l = self.through_glass(&kind, &sp, ray, depth, seed, counters, |t, r, s, c| {
                let back = r.dir.dot(sp.ng) * ray.dir.dot(sp.ng) < 0.0;
                if smooth && (back || specular) {
                    t.reflected_whole(r, depth + 1, s, c)
                } else {
                    t.reflected(r, depth + 1, s, false, c).0
                }
            });
            return (l, emitter);
        }
        let wo = -ray.dir;
        let cos_v = sp.ns.dot(wo);
        if (!sp.front && !bsdf.twosided) || cos_v <= 0.0 {
            return (Vec3::ZERO, emitter);
        }
        let mut l = Vec3::ZERO;
        if kind.has_diffuse() {
            let interp = self.locate(mesh, &hit, &sp);
            let textured = texture_ratio(bsdf, &kind, mesh, &interp);
            l += interp.apply(total) * textured * (std::f32::consts::FRAC_1_PI * sp.hemisphere_share());
        }
        if depth < self.max_depth {
            if let Some(lobe) = kind.glossy() {
                l += self.glossy(&lobe, &sp, wo, depth, seed, counters);
            }
            let m = kind.mirror(cos_v);
            let dir = reflect(ray.dir, sp.ns).normalize();
            if m.max_element() > 0.0 && dir.dot(sp.ng) > 0.0 {
                counters.reflection_rays += 1;
                let refl = sp.spawn(dir, f32::INFINITY);
                l += m
                    * sp.terminator(dir)
                    * self.reflected_whole(&refl, depth + 1, derive(seed, Stream::Reflection), counters);
            }
        }
        (l, emitter)
    }

    /// [`Self::reflected`] past a mirror or smooth glass: the area light it meets
    /// counts whole, with what it reflects.
    fn reflected_whole(&self, ray: &Ray, depth: u32, seed: u32, counters: &mut Counters) -> Rgb {
        let (l, emitter) = self.reflected(ray, depth, seed, true, counters);
        l + emitter.map_or(Vec3::ZERO, |(_, radiance, _)| radiance)
    }

    /// Direct light at a diffuse hit from the picked source: `pick.rays` (over the
    /// SIB query's `ray_divisor`, at least one) groups of its
    /// `area_samples` sub-sources, one shadow ray to a jittered point of each (a point
    /// or spot light is one light point). With a SIB whose neighbours are `usable`, a
    /// group the neighbours agree on takes their value instead of a ray; the record
    /// gets every group's result. Light points behind the surface get neither.
    ///
    /// Where the source's unoccluded light has a closed form (a polygonal area light
    /// on a Lambertian surface), the groups only say how much of it is occluded: the
    /// closed form times the visible share of the sampled light (the ratio estimator
    /// of Heitz et al. 2018, exact where the source is wholly visible, consistent in
    /// penumbrae). Where the neighbours agree on every group of an area light, no
    /// light point is sampled: the closed form (or nothing, all occluded) stands.
    fn sample_source(
        &self,
        pick: Pick,
        h: &Shade,
        counters: &mut Counters,
        mut sib: Option<&mut SibQuery>,
        usable: bool,
    ) -> Rgb {
        let li = pick.source as usize;
        let light = &self.sources[li];
        let divisor = sib.as_ref().map_or(1, |q| q.ray_divisor.max(1));
        let stratum = sib.as_ref().map_or(Stratum::WHOLE, |q| q.stratum);
        let (n, r) = if light.is_area() {
            (
                self.area_samples,
                (pick.rays / divisor)
                    .max(pick.rays.min(MIN_SHARED_GROUPS))
                    .clamp(1, self.area_samples),
            )
        } else {
            (1, 1)
        };
        let sp = h.sp;
        // (On a bumped surface the terminator term weighs each light sample.)
        let closed = if n > 1 && !sp.is_bumped() {
            h.kind
                .lambertian()
                .and_then(|f| Some(f * light.unoccluded_irradiance(sp.p, sp.ns)?))
        } else {
            None
        };
        let light_seed = derive(h.seed, Stream::Light(pick.source));
        if let Some(q) = sib.as_deref_mut().filter(|_| usable && n > 1) {
            if let Some(lit) = sib::agree(q.neighbours, pick.source, 0, n) {
                let value = match (lit, closed) {
                    (false, _) => Some(Vec3::ZERO),
                    (true, Some(c)) => Some(match self.accel.panes() {
                        None => c,
                        // Dimmed by the glass and masks on the way: a few of the
                        // light's points stand for all.
                        Some(_) => c * self.pane_share(light, sp, r.min(PANE_PROBES), n, light_seed),
                    }),
                    (true, None) => None,
                };
                if let Some(value) = value {
                    sib::set(q.record, pick.source, 0, n, lit);
                    counters.count_source(li, 0, u64::from(r));
                    return value;
                }
            }
        }
        let (mut acc, mut unoccluded) = (Vec3::ZERO, Vec3::ZERO);
        let (mut cast, mut saved) = (0, 0);
        for g in 0..r {
            let (a, b, uv) = group_point_in(g, r, n, light_seed, stratum);
            let Some(s) = light.sample(sp.p, uv) else { continue };
            if !sp.faces(s.dir) {
                continue;
            }
            let cos_l = sp.ns.dot(s.dir);
            let reused = match &sib {
                Some(q) if usable => sib::agree(q.neighbours, pick.source, a, b),
                _ => None,
            };
            let visible = match reused {
                Some(v) => {
                    saved += 1;
                    v
                }
                None => {
                    cast += 1;
                    !self.accel.occluded(&sp.shadow_ray(s.point, s.normal))
                }
            };
            if let Some(q) = sib.as_deref_mut() {
                sib::set(q.record, pick.source, a, b, visible);
            }
            let share = (b - a) as f32 / n as f32;
            let f = h.kind.diffuse_brdf(cos_l, h.cos_v) * s.value * (cos_l * share * sp.terminator(s.dir));
            unoccluded += f;
            if visible {
                // Dimmed by the thin panes on the way (the ray made again only if
                // the scene has any).
                acc += match self.accel.panes() {
                    Some(_) => {
                        f * pane_transmittance(self.scene, self.accel, &sp.shadow_ray(s.point, s.normal))
                    }
                    None => f,
                };
            }
        }
        counters.count_source(li, cast, saved);
        match closed {
            Some(c) if unoccluded.element_sum() > 0.0 => c * (acc.element_sum() / unoccluded.element_sum()),
            _ => acc,
        }
    }

    /// The mean share of the light glass and masks let through from `k` points of
    /// `light` (one in each of `k` groups of its `n` sub-sources) to `sp`, for light
    /// the shadow image buffer found unoccluded: the panes' dimming varies little
    /// across a light, and tracing them for every light point cost the staircase 9 %
    /// of its render.
    fn pane_share(&self, light: &SampledLight, sp: &SurfacePoint, k: u32, n: u32, seed: u32) -> f32 {
        let (mut sum, mut count) = (0.0, 0u32);
        for g in 0..k {
            let (_, _, uv) = group_point(g, k, n, seed);
            let Some(s) = light.sample(sp.p, uv) else { continue };
            if sp.faces(s.dir) {
                sum += pane_transmittance(self.scene, self.accel, &sp.shadow_ray(s.point, s.normal));
                count += 1;
            }
        }
        if count > 0 {
            sum / count as f32
        } else {
            1.0
        }
    }
}

/// An anti-aliasing sample casts at least this many of the selection's shadow rays
/// to an area source (or all, if fewer), whatever the level's divisor: with its
/// pixel's other samples it spreads them over the source, but below four a
/// penumbra's pixels go noisy (see [`super::adaptive`]).
const MIN_SHARED_GROUPS: u32 = 4;

/// Light points whose panes stand for the rest where the shadow image buffer finds
/// an area light wholly visible ([`Tracer::pane_share`]).
const PANE_PROBES: u32 = 4;

/// What the direct light at one diffuse hit is computed for.
struct Shade<'s> {
    sp: &'s SurfacePoint,
    /// The material at the point (textures looked up).
    kind: &'s BsdfKind,
    cos_v: f32,
    seed: u32,
}

/// Rays drawn from a glossy lobe at a primary hit (one at deeper hits). Two since
/// 2026-11-27 (four before): the adaptive sampler refines a noisy glossy pixel
/// anyway, up to 16 samples. Classroom (rough metal chairs): reflection rays 3.1 M ->
/// 1.6 M, render 3.7 -> 2.5 s, FLIP against Mitsuba 0.0808 -> 0.0839 (its 64 spp:
/// 0.0960); wooden staircase (rough plastics): 5.0 M -> 2.8 M, 0.0635 / 0.0632 ->
/// 0.0639 / 0.0638 (render seeds 0 / 1; Mitsuba 0.0650). One ray: the staircase
/// 0.0656. Drawing 1, 2 or 4 by the lobe's share of the surface's reflectance
/// (Fresnel term over it and the diffuse albedo) kept the classroom's metals at four
/// rays (0.0808, no saving there) and gave the staircase 3.2 M rays for 0.0638.
pub const GLOSSY_RAYS: u32 = 2;
/// Lobes seen through this many lobes or mirrors take the lights alone, no rays.
pub const GLOSSY_DEPTH: u32 = 2;
/// Light samples of an area light at a primary glossy hit (weighed against the
/// lobe's rays that meet the light). Two since 2026-11-27 (four before): they are
/// cast at every sample of a refined pixel, where the diffuse hits' shadow rays are
/// shared (see [`super::adaptive`]). Wooden staircase: shadow rays 9.8 M -> 8.3 M,
/// FLIP 0.0639 either way; frosted room 1.37 M -> 1.04 M, 0.0336 either way; one
/// sample: the staircase 0.0725 (the lamp's highlight on its glossy floor).
pub const GLOSSY_LIGHT_SAMPLES: u32 = 2;

/// Per channel, the diffuse albedo of `kind` (`bsdf`'s model with its textures looked
/// up at a point) over `mean`, the albedo the solution was computed with there (the
/// patch's: its texture's mean over the patch). 1 for an untextured material, and where
/// that albedo is 0: nothing was stored there to scale.
/// The power heuristic's weight (Veach 1997, beta 2) of a sample drawn with density
/// `a` against another strategy's `b` (each times its sample count).
fn power_heuristic(a: f32, b: f32) -> f32 {
    if a > 0.0 {
        a * a / (a * a + b * b)
    } else {
        0.0
    }
}

/// What the radiosity `interp` reads from `mesh` is scaled by at a hit on `bsdf`
/// (of model `kind` there): its texel over the albedo the vertices interpolate to
/// (1 for an untextured material, which pays no lookup).
fn texture_ratio(bsdf: &Bsdf, kind: &BsdfKind, mesh: &RadiosityMesh, interp: &Interp) -> Rgb {
    if bsdf.textures.is_empty() {
        return Vec3::ONE;
    }
    let mean = mesh.albedo_at(interp);
    Vec3::select(
        mean.cmpgt(Vec3::ZERO),
        kind.diffuse_albedo() / mean.max(Vec3::splat(f32::MIN_POSITIVE)),
        Vec3::ONE,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Bvh;
    use crate::geometry::{Patch, TriMesh};
    use crate::scene::{BsdfKind, Light, Scene};
    use std::f32::consts::PI;

    /// A square `[-s,s]^2` at height z, facing +z (or -z when `down`).
    fn square(s: f32, z: f32, down: bool) -> TriMesh {
        let p = vec![
            Vec3::new(-s, -s, z),
            Vec3::new(s, -s, z),
            Vec3::new(s, s, z),
            Vec3::new(-s, s, z),
        ];
        let mut m = TriMesh {
            positions: p,
            indices: vec![[0, 1, 2], [0, 2, 3]],
            tri_patch: vec![0, 0],
            patches: vec![Patch::Polygon(vec![0, 1, 2, 3])],
            ..Default::default()
        };
        if down {
            m.flip_normals();
        }
        m
    }

    /// A disk of radius r at height z facing down, as a fan of `n` triangles.
    fn disk_down(r: f32, z: f32, n: u32) -> TriMesh {
        let mut positions = vec![Vec3::new(0.0, 0.0, z)];
        for k in 0..n {
            let a = 2.0 * PI * k as f32 / n as f32;
            positions.push(Vec3::new(r * a.cos(), r * a.sin(), z));
        }
        let indices: Vec<[u32; 3]> = (0..n).map(|k| [0, 1 + (k + 1) % n, 1 + k]).collect();
        TriMesh {
            positions,
            tri_patch: vec![0; n as usize],
            patches: vec![Patch::Polygon((1..=n).rev().collect())],
            indices,
            ..Default::default()
        }
    }

    fn scene(shapes: Vec<(TriMesh, BsdfKind)>, lights: Vec<Light>) -> Scene {
        crate::testutil::scene_with(shapes, lights, &[])
    }

    /// A rough silver lobe (GGX, alpha 0.3), its reflection scaled by `scale`.
    fn rough_silver(scale: f32) -> crate::scene::Glossy {
        use crate::scene::{Fresnel, Glossy, Microfacet};
        Glossy {
            distribution: Microfacet {
                alpha_u: 0.3,
                alpha_v: 0.3,
                beckmann: false,
            },
            fresnel: Fresnel::Conductor {
                eta: Vec3::new(1.66, 0.88, 0.52),
                k: Vec3::new(9.2, 6.3, 4.8),
            },
            scale: Vec3::splat(scale),
        }
    }

    /// `floor` under `lamp`, a black area light of radiance `le`, nothing else.
    fn under_lamp(floor: (TriMesh, BsdfKind), lamp: TriMesh, le: f32) -> Scene {
        let black = BsdfKind::Diffuse {
            reflectance: Vec3::ZERO,
        };
        let mut s = scene(
            vec![floor, (lamp, black)],
            vec![Light::Area {
                shape: 1,
                radiance: Vec3::splat(le),
                texture: None,
            }],
        );
        s.shapes[1].emitter = Some(0);
        s
    }

    fn settings(area_samples: u32) -> Settings {
        Settings::direct_test(area_samples, 4)
    }

    const RHO: f32 = 0.5;

    fn floor() -> (TriMesh, BsdfKind) {
        (
            square(10.0, 0.0, false),
            BsdfKind::Diffuse {
                reflectance: Vec3::splat(RHO),
            },
        )
    }

    /// Radiance seen looking straight down at floor point (x, 0, 0).
    fn look_down(scene: &Scene, x: f32, area_samples: u32) -> (Rgb, Counters) {
        let bvh = Bvh::build(scene);
        let tracer = Tracer::new(scene, &bvh, &settings(area_samples));
        let mut c = Counters::default();
        let ray = Ray::new(Vec3::new(x, 0.0, 0.5), -Vec3::Z);
        (tracer.radiance(&ray, 0, 1, &mut c), c)
    }

    /// A retextured hit is the hit traced in full: a floor of Mitsuba's nonlinear
    /// rough plastic (whose base is not linear in the texel, but whose diffuse light
    /// is linear in the diffuse albedo the shading keeps) in stripes of two colours,
    /// under a point light. The light and the glossy part kept at one stripe, put
    /// through the other stripe's texel 1 mm away, give that stripe's radiance traced
    /// in full within 0.2 %; kept as it was (no texel put in), they miss it by 40 %.
    /// Light found where the surface faced 15 degrees away is not taken.
    #[test]
    fn a_retextured_hit_is_the_hit_traced_in_full_behind_a_nonlinear_coating() {
        use crate::render::sib::Given;
        use crate::scene::texture::TexFilter;
        use crate::scene::{TexField, Texture};
        let mut mesh = square(10.0, 0.0, false);
        mesh.uvs = vec![
            glam::Vec2::new(0.0, 0.0),
            glam::Vec2::new(1.0, 0.0),
            glam::Vec2::new(1.0, 1.0),
            glam::Vec2::new(0.0, 1.0),
        ];
        let kind = crate::testutil::rough_plastic(Vec3::splat(0.5), 0.2, true);
        let mut sc = scene(
            vec![(mesh, kind)],
            vec![Light::Point {
                position: Vec3::new(0.3, 0.2, 2.0),
                intensity: Vec3::splat(10.0),
            }],
        );
        // 2000 stripes across the 20-unit floor, 1 cm each; the two rays below meet
        // it 1 mm apart, either side of the edge at x = 0.3 (stripes 1029 and 1030).
        let texels = (0..2000)
            .map(|i| match i % 2 {
                0 => [0.9, 0.6, 0.3],
                _ => [0.1, 0.3, 0.2],
            })
            .collect();
        let mut t = Texture::from_linear("stripes", 2000, 1, texels).unwrap();
        t.filter = TexFilter::Nearest;
        crate::testutil::texture_on(&mut sc, 0, TexField::Diffuse, t);
        let bvh = Bvh::build(&sc);
        let tracer = Tracer::new(&sc, &bvh, &settings(1));
        let full = |x: f32| {
            let mut record = Vec::new();
            let mut q = SibQuery::new(false, &[], &mut record);
            let ray = Ray::new(Vec3::new(x, 0.0, 1.0), Vec3::new(0.3, 0.1, -1.0).normalize());
            let v = tracer.radiance_sib(&ray, 1, &mut Counters::default(), &mut q);
            (
                ray,
                v,
                q.lighting.expect("a textured diffuse hit keeps its light"),
            )
        };
        let (_, va, la) = full(-0.0005);
        let (ray_b, vb, lb) = full(0.0005);
        assert!(
            (la.albedo() - lb.albedo()).abs().max_element() > 0.1,
            "two stripes"
        );
        // Ray b given a's light on `object`, with a's rest or without it (traced anew).
        let given = |object: u32, rest: Option<Vec3>, normal: Vec3| {
            let mut record = Vec::new();
            let mut q = SibQuery::new(false, &[], &mut record);
            q.given[1] = Some(Given {
                object,
                per_albedo: la.per_albedo(),
                normal,
                rest,
            });
            let mut c = Counters::default();
            let v = tracer.radiance_sib(&ray_b, 1, &mut c, &mut q);
            (v, q.lighting, c)
        };
        let rest = va - la.diffuse();
        let up = la.normal();
        assert!(up.dot(Vec3::Z) > 0.9999, "{up}");
        let (v, l, c) = given(0, Some(rest), up);
        assert!(((v - vb) / vb).abs().max_element() < 2e-3, "{v} against {vb}");
        let l = l.unwrap();
        assert!(((l.albedo() - lb.albedo()) / lb.albedo()).abs().max_element() < 1e-3);
        assert_eq!((c.retextured, c.diffuse_hits, c.reflection_rays), (1, 0, 0));
        assert!(((va - vb) / vb).abs().max_element() > 0.4, "{va} {vb}");
        // Given the diffuse light alone, the glossy part traced anew: the same.
        let (v, _, c) = given(0, None, up);
        assert!(((v - vb) / vb).abs().max_element() < 2e-3, "{v} against {vb}");
        assert_eq!((c.retextured, c.diffuse_hits), (1, 0));
        // Given the light of another object: traced in full.
        let (v, _, c) = given(1, Some(rest), up);
        assert_eq!(v, vb);
        assert_eq!((c.retextured, c.diffuse_hits), (0, 1));
        // Given light found where the surface faced 15 degrees away: traced in full.
        let turned = Vec3::new(15f32.to_radians().sin(), 0.0, 15f32.to_radians().cos());
        let (v, _, c) = given(0, Some(rest), turned);
        assert_eq!(v, vb);
        assert_eq!((c.retextured, c.diffuse_hits), (0, 1));
        // At 5 degrees, taken.
        let near = Vec3::new(5f32.to_radians().sin(), 0.0, 5f32.to_radians().cos());
        assert_eq!(given(0, Some(rest), near).2.retextured, 1);
    }

    /// A rough conductor floor under a point light, nothing else: the radiance seen
    /// straight down is the lobe's BRDF times I / r^2 times the cosine (Mitsuba's
    /// roughconductor, closed form), by one shadow ray; with the light beside a
    /// blocker, none. The drawn rays meet nothing, so bring nothing.
    #[test]
    fn a_glossy_floor_reflects_a_point_light_by_its_lobe() {
        let lobe = rough_silver(0.9);
        let (h, i) = (2.0f32, 10.0f32);
        let s = scene(
            vec![(square(10.0, 0.0, false), BsdfKind::RoughConductor { lobe })],
            vec![Light::Point {
                position: Vec3::new(0.0, 0.0, h),
                intensity: Vec3::splat(i),
            }],
        );
        for x in [0.0f32, 0.5, 1.5] {
            let (l, c) = look_down(&s, x, 1);
            let r2 = h * h + x * x;
            let wi = Vec3::new(-x, 0.0, h) / r2.sqrt();
            let expect = lobe.eval(wi, Vec3::Z) * (i / r2 * wi.z);
            assert!(
                (l - expect).abs().max_element() < 1e-4 * expect.max_element(),
                "x {x}: {l} vs {expect}"
            );
            assert!(expect.max_element() > 0.01);
            assert_eq!(c.shadow_rays, 1);
            // A drawn ray that would leave below the floor is not cast.
            assert!((1..=u64::from(GLOSSY_RAYS)).contains(&c.reflection_rays));
        }
    }

    /// A rough conductor floor under a square light, one light sample per hit
    /// (`--area-samples 1`): the samples of many seeds average to the light's
    /// reflection integrated over the square (its corner's, every time, before a
    /// single sample was jittered over the light).
    #[test]
    fn one_light_sample_at_a_glossy_hit_covers_the_whole_light() {
        let lobe = rough_silver(1.0);
        let (h, s_half, le) = (1.0f32, 0.25f32, 4.0f32);
        let s = under_lamp(
            (square(10.0, 0.0, false), BsdfKind::RoughConductor { lobe }),
            square(s_half, h, true),
            le,
        );
        // Looking straight down at the origin: f(wi, z) Le cos_i cos_l / d^2 over
        // the square.
        let expect =
            crate::testutil::lamp_integral([-s_half, s_half, -s_half, s_half], h, le, Vec3::Z, |wi, wo| {
                lobe.eval(wi, wo).x
            });
        let bvh = Bvh::build(&s);
        let tracer = Tracer::new(&s, &bvh, &settings(1));
        let ray = Ray::new(Vec3::new(0.0, 0.0, 0.5), -Vec3::Z);
        let seeds = 4096;
        let mut sum = 0.0f64;
        for seed in 0..seeds {
            let mut c = Counters::default();
            sum += f64::from(tracer.radiance(&ray, 0, seed, &mut c).x);
            assert_eq!(c.shadow_rays, 1);
        }
        let mean = sum / f64::from(seeds);
        assert!(
            (mean / f64::from(expect) - 1.0).abs() < 0.03,
            "{mean} vs {expect}"
        );
    }

    #[test]
    fn point_light_irradiance_on_a_plane_is_the_closed_form() {
        let (h, i) = (2.0f32, 10.0f32);
        let s = scene(
            vec![floor()],
            vec![Light::Point {
                position: Vec3::new(0.0, 0.0, h),
                intensity: Vec3::splat(i),
            }],
        );
        for x in [0.0f32, 1.0, 3.0] {
            let (l, c) = look_down(&s, x, 1);
            let r2 = h * h + x * x;
            let e = i * (h / r2.sqrt()) / r2;
            let expect = RHO / PI * e;
            assert!(
                (l.x - expect).abs() < 1e-5 * expect.max(1.0),
                "x {x}: {} vs {expect}",
                l.x
            );
            assert_eq!((c.shadow_rays, c.diffuse_hits), (1, 1));
        }
    }

    #[test]
    fn spot_light_uses_mitsubas_falloff() {
        // Spot 2 above the origin pointing down, cutoff 40, beam 20 degrees.
        let (h, i) = (2.0f32, 10.0f32);
        let spot = Light::Spot {
            position: Vec3::new(0.0, 0.0, h),
            direction: -Vec3::Z,
            intensity: Vec3::splat(i),
            cutoff_angle: 40f32.to_radians(),
            beam_width: 20f32.to_radians(),
        };
        let s = scene(vec![floor()], vec![spot]);
        // At 30 degrees off axis the falloff is (40-30)/(40-20) = 0.5.
        let x = h * 30f32.to_radians().tan();
        let (l, _) = look_down(&s, x, 1);
        let r2 = h * h + x * x;
        let expect = RHO / PI * i * 0.5 * (h / r2.sqrt()) / r2;
        assert!((l.x - expect).abs() < 1e-3 * expect, "{} vs {expect}", l.x);
        // Outside the cone: no light and no shadow ray.
        let (l, c) = look_down(&s, h * 45f32.to_radians().tan(), 1);
        assert_eq!(l, Vec3::ZERO);
        assert_eq!(c.shadow_rays, 0);
    }

    #[test]
    fn disk_area_light_on_axis_matches_the_closed_form() {
        let (r, h, le) = (0.5f32, 1.0f32, 3.0f32);
        let s = under_lamp(floor(), disk_down(r, h, 512), le);
        let (l, c) = look_down(&s, 0.0, 4096);
        let e = PI * le * r * r / (h * h + r * r);
        let expect = RHO / PI * e;
        assert!((l.x - expect).abs() < 0.01 * expect, "{} vs {expect}", l.x);
        assert_eq!(c.shadow_rays, 4096);
    }

    /// A square light over a Lambertian floor: where it is wholly visible the render
    /// gives the closed form to rounding, with 4 or 64 rays alike (the rays only say
    /// that nothing occludes it); with a blocker hiding part of it, the light lies
    /// strictly between none and the closed form and converges, as the rays grow, to
    /// the visible part's closed form.
    #[test]
    fn a_polygon_light_gives_its_closed_form_times_the_visible_share() {
        let (h, s_half, le) = (1.0f32, 0.25f32, 4.0f32);
        let lamp = (
            square(s_half, h, true),
            BsdfKind::Diffuse {
                reflectance: Vec3::ZERO,
            },
        );
        let light = Light::Area {
            shape: 1,
            radiance: Vec3::splat(le),
            texture: None,
        };
        // Lambert's formula for a square of half side s centred at height h above
        // the point: four corner rectangles, each F = (1/2pi)(a/sqrt(1+a^2)
        // atan(b/sqrt(1+a^2)) + b/sqrt(1+b^2) atan(a/sqrt(1+b^2))), a = b = s/h.
        let t = s_half / h;
        let k = t / (1.0 + t * t).sqrt();
        let f = 4.0 * (2.0 * k * (t / (1.0 + t * t).sqrt()).atan()) / (2.0 * PI);
        let expect = RHO / PI * (PI * le * f);
        let mut open = scene(vec![floor(), lamp.clone()], vec![light.clone()]);
        open.shapes[1].emitter = Some(0);
        for rays in [4, 64] {
            let (l, c) = look_down(&open, 0.0, rays);
            assert!(
                (l.x / expect - 1.0).abs() < 1e-4,
                "{rays} rays: {} vs {expect}",
                l.x
            );
            assert_eq!(c.shadow_rays, rays as u64);
        }
        // A blocker at half height over the half x > 0.05 of the light's footprint.
        let mut slab = square(1.0, 0.5, true);
        for q in &mut slab.positions {
            q.x = if q.x < 0.0 { 0.05 } else { 1.0 };
        }
        let blocker = (
            slab,
            BsdfKind::Diffuse {
                reflectance: Vec3::splat(0.5),
            },
        );
        let mut part = scene(vec![floor(), lamp, blocker], vec![light]);
        part.shapes[1].emitter = Some(0);
        // Seen from the origin the blocker's edge at x = 0.05, z = 0.5 hides the light
        // beyond x = 0.1: visible is the strip -0.25 < x < 0.1 of the square.
        let strip = [
            Vec3::new(-s_half, -s_half, h),
            Vec3::new(0.1, -s_half, h),
            Vec3::new(0.1, s_half, h),
            Vec3::new(-s_half, s_half, h),
        ];
        let visible =
            RHO / PI * (PI * le * crate::geometry::point_polygon_form_factor(Vec3::ZERO, Vec3::Z, &strip));
        let (coarse, _) = look_down(&part, 0.0, 16);
        assert!(coarse.x > 0.0 && coarse.x < expect, "{} of {expect}", coarse.x);
        let (fine, _) = look_down(&part, 0.0, 4096);
        assert!((fine.x / visible - 1.0).abs() < 0.02, "{} vs {visible}", fine.x);
    }

    #[test]
    fn occluders_cast_shadows_and_lights_behind_a_surface_cast_no_rays() {
        let light = Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Vec3::splat(10.0),
        };
        let blocker = (
            square(0.2, 1.0, true),
            BsdfKind::Diffuse {
                reflectance: Vec3::splat(0.5),
            },
        );
        let s = scene(vec![floor(), blocker], vec![light.clone()]);
        let (l, c) = look_down(&s, 0.0, 1);
        assert_eq!(l, Vec3::ZERO);
        assert_eq!(c.shadow_rays, 1);
        // Light below the floor: backfacing, so no ray at all.
        let below = Light::Point {
            position: Vec3::new(0.0, 0.0, -2.0),
            intensity: Vec3::splat(10.0),
        };
        let (l, c) = look_down(&scene(vec![floor()], vec![below]), 0.0, 1);
        assert_eq!((l, c.shadow_rays, c.diffuse_hits), (Vec3::ZERO, 0, 1));
    }

    #[test]
    fn a_mirror_shows_the_emitter_it_faces_scaled_by_its_reflectance() {
        // Mirror floor, emitting square above facing down.
        let mirror = (
            square(10.0, 0.0, false),
            BsdfKind::Conductor {
                specular_reflectance: Vec3::splat(0.8),
                fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
            },
        );
        let lamp = (
            square(1.0, 1.0, true),
            BsdfKind::Diffuse {
                reflectance: Vec3::ZERO,
            },
        );
        let mut s = scene(
            vec![mirror, lamp],
            vec![Light::Area {
                shape: 1,
                radiance: Vec3::new(1.0, 2.0, 3.0),
                texture: None,
            }],
        );
        s.shapes[1].emitter = Some(0);
        let bvh = Bvh::build(&s);
        let tracer = Tracer::new(&s, &bvh, &settings(4));
        let mut c = Counters::default();
        // From below the lamp, looking down at the mirror at a slant.
        let ray = Ray::new(Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.3, 0.0, -1.0).normalize());
        let l = tracer.radiance(&ray, 0, 1, &mut c);
        assert!((l - Vec3::new(0.8, 1.6, 2.4)).length() < 1e-5, "{l:?}");
        assert_eq!((c.reflection_rays, c.diffuse_hits), (1, 0));
        // With no reflections allowed the mirror is black.
        let mut st = settings(4);
        st.max_depth = 0;
        let tracer = Tracer::new(&s, &bvh, &st);
        assert_eq!(tracer.radiance(&ray, 0, 1, &mut c), Vec3::ZERO);
    }

    #[test]
    fn the_back_of_a_one_sided_material_is_black_and_twosided_reflects() {
        let light = Light::Point {
            position: Vec3::new(0.0, 0.0, -2.0),
            intensity: Vec3::splat(10.0),
        };
        let mut s = scene(vec![floor()], vec![light]);
        let bvh = Bvh::build(&s);
        // Exactly through the diagonal shared by the floor's two triangles.
        let ray = Ray::new(Vec3::new(0.3, 0.3, -0.5), Vec3::Z);
        let mut c = Counters::default();
        assert_eq!(
            Tracer::new(&s, &bvh, &settings(1)).radiance(&ray, 0, 1, &mut c),
            Vec3::ZERO
        );
        s.bsdfs[0].twosided = true;
        let l = Tracer::new(&s, &bvh, &settings(1)).radiance(&ray, 0, 1, &mut c);
        let r2 = 4.0f32 + 0.18;
        let expect = RHO / PI * 10.0 * (2.0 / r2.sqrt()) / r2;
        assert!((l.x - expect).abs() < 1e-5, "{l:?} {c:?}");
    }
}
