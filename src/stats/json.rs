//! The statistics files as typed documents: `radtrace render --stats` ([`RenderStats`])
//! and `radtrace solve --stats` ([`SolveStatsFile`]). README.md ("Statistics")
//! documents the keys; the field names here are those keys.
//!
//! [`to_json_text`] writes them as they have always been written: pretty-printed, the
//! keys of every object in alphabetical order (serde_json's map), one newline at the end.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use crate::radiosity::{Solution, SourceId};
use crate::render::{Filter, LevelStats, Method, Output, Sampler, Settings};
use crate::scene::Scene;
use crate::selection::{SelectSettings, Selection};

/// A statistics document as text: pretty JSON with sorted keys and a final newline.
pub fn to_json_text<T: Serialize>(doc: &T) -> String {
    // Through `Value`, whose objects sort their keys, so that the files keep the key
    // order they had when they were built with `json!`.
    let value = serde_json::to_value(doc).expect("statistics serialise");
    serde_json::to_string_pretty(&value).expect("statistics serialise") + "\n"
}

/// "spot", "area", ... or "patch" for a radiant patch.
pub fn source_kind(scene: &Scene, s: SourceId) -> String {
    match s {
        SourceId::Light(l) => scene.lights[l as usize].kind().to_string(),
        SourceId::Patch(_) => "patch".to_string(),
    }
}

/// Name and kind of each of the `count` ray-traced sources of a render (the scene's
/// lights without a selection).
pub fn source_names(scene: &Scene, selection: Option<&Selection>, count: usize) -> Vec<(String, String)> {
    (0..count)
        .map(|i| match selection {
            Some(sel) => (sel.source_name(scene, i), source_kind(scene, sel.sources[i])),
            None => (scene.light_name(i), scene.lights[i].kind().to_string()),
        })
        .collect()
}

/// Pass 1's figures: the `solve` object of both statistics files.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolveFigures {
    /// Largest element edge.
    pub mesh_size: f32,
    /// Sources kept apart per patch.
    pub sources_per_patch: u32,
    /// Sample cells per shot.
    pub shoot_samples: u32,
    /// The stopping fraction of unshot power.
    pub tolerance: f32,
    /// Patches.
    pub patches: u64,
    /// Patches meshed finer than the mesh size (they hold a small object, or lie
    /// near a small light).
    pub refined_patches: u64,
    /// Mesh elements.
    pub elements: u64,
    /// Mesh vertices.
    pub vertices: u64,
    /// Light and patch shots.
    pub shots: u64,
    /// Shots from lights.
    pub light_shots: u64,
    /// Shots from patches.
    pub patch_shots: u64,
    /// Patch shots that reused the patch's first shot (no rays).
    pub reused_shots: u64,
    /// Rays cast.
    pub rays: u64,
    /// Power emitted by the lights.
    pub emitted_power: f64,
    /// What `residual` and the tolerance are fractions of: the power the lights
    /// brought to reflecting surfaces, or `emitted_power` if less.
    pub reference_power: f64,
    /// Unshot fraction left.
    pub residual: f64,
    /// Wall seconds of the solve.
    pub time_s: f64,
    /// Photons per vertex asked for.
    pub photons_per_vertex: u32,
    /// Photons traced (they carry what the shots left: `residual`).
    pub photons: u64,
    /// Rays the photons cast.
    pub photon_rays: u64,
    /// Whether `--solve-time` cut the solve short.
    pub timed_out: bool,
}

impl SolveFigures {
    /// The figures of `sol`.
    pub fn of(sol: &Solution) -> Self {
        let s = &sol.stats;
        SolveFigures {
            mesh_size: sol.settings.mesh_size,
            sources_per_patch: sol.settings.sources_per_patch,
            shoot_samples: sol.settings.shoot_samples,
            tolerance: sol.settings.tolerance,
            patches: s.patches,
            refined_patches: s.refined_patches,
            elements: s.elements,
            vertices: s.vertices,
            shots: s.light_shots + s.patch_shots,
            light_shots: s.light_shots,
            patch_shots: s.patch_shots,
            reused_shots: s.reused_shots,
            rays: s.rays,
            emitted_power: s.emitted_power,
            reference_power: s.reference_power,
            residual: s.residual,
            time_s: s.time_s,
            photons_per_vertex: sol.settings.photons,
            photons: s.photons,
            photon_rays: s.photon_rays,
            timed_out: s.timed_out,
        }
    }
}

/// The `radtrace solve --stats` file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolveStatsFile {
    /// The scene file.
    pub scene: PathBuf,
    /// Pass 1's figures.
    pub solve: SolveFigures,
    /// Wall seconds per pass and `total`.
    pub time_s: BTreeMap<String, f64>,
}

/// How many (patch, listed source) pairs each criterion turned down.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Rejections {
    /// By the radiance criterion.
    pub radiance: u64,
    /// By the reflectivity criterion.
    pub reflectivity: u64,
    /// By the gradient criterion.
    pub gradient: u64,
    /// By the solid-angle criterion.
    pub solid_angle: u64,
    /// By the view criterion.
    pub view: u64,
}

/// The local selection's criteria at work: the `criteria` object.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Criteria {
    /// (patch, listed source) pairs considered.
    pub listed: u64,
    /// Pairs every criterion let through.
    pub selected: u64,
    /// Pairs each criterion turned down.
    pub rejected_by: Rejections,
}

impl Criteria {
    /// The counts of `sel`.
    pub fn of(sel: &Selection) -> Self {
        let mut c = Criteria::default();
        for (_, k) in sel.criteria.iter().flatten() {
            c.listed += 1;
            c.selected += k.selected() as u64;
            let r = &mut c.rejected_by;
            r.radiance += !k.radiance as u64;
            r.reflectivity += !k.reflectivity as u64;
            r.gradient += !k.gradient as u64;
            r.solid_angle += !k.solid_angle as u64;
            r.view += !k.view as u64;
        }
        c
    }
}

/// The `selection` object of the render statistics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SelectionStats {
    /// The method selected for.
    pub method: Method,
    /// The thresholds.
    pub settings: SelectSettings,
    /// (patch, source) pairs ray traced.
    pub picks: usize,
    /// Patches of the mesh.
    pub patches: usize,
    /// Patches with at least one source ray traced.
    pub patches_with_rays: usize,
    /// Radiant patches among the ray-traced sources.
    pub radiant_patches_sampled: usize,
    /// For `local` only: the criteria's counts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub criteria: Option<Criteria>,
}

impl SelectionStats {
    /// The figures of `sel`, made with `settings`.
    pub fn of(sel: &Selection, settings: &SelectSettings) -> Self {
        let mesh = &sel.solution.mesh;
        let lights = sel
            .sources
            .iter()
            .filter(|s| matches!(s, SourceId::Light(_)))
            .count();
        SelectionStats {
            method: sel.method,
            settings: *settings,
            picks: sel.pick_count(),
            patches: mesh.patches.len(),
            patches_with_rays: (0..mesh.patches.len() as u32)
                .filter(|&p| !sel.picks(p).is_empty())
                .count(),
            radiant_patches_sampled: sel.sources.len() - lights,
            criteria: (sel.method == Method::Local).then(|| Criteria::of(sel)),
        }
    }
}

/// One ray-traced source in the render statistics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SourceStats {
    /// The `id` in the scene file, or the shape's name.
    pub name: String,
    /// `point`, `spot`, `area` or `patch`.
    pub kind: String,
    /// Diffuse hits that sampled it.
    pub hits: u64,
    /// Shadow rays cast to it.
    pub shadow_rays: u64,
    /// Its shadow rays per diffuse hit (of all diffuse hits).
    pub rays_per_hit: f64,
}

/// The `radtrace render --stats` file (and each `viewK-RUN.json` of `radtrace tables`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RenderStats {
    /// The scene file.
    pub scene: PathBuf,
    /// The view.
    pub view: usize,
    /// The method.
    pub method: Method,
    /// The image sampler.
    pub sampler: Sampler,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel (uniform sampler; else none).
    pub spp: Option<u32>,
    /// Highest level (adaptive sampler; else none).
    pub max_level: Option<u32>,
    /// Difference criterion (adaptive sampler; else none).
    pub contrast: Option<f32>,
    /// Whether the shadow image buffer was on.
    pub sib: bool,
    /// Seed.
    pub seed: u64,
    /// Sub-sources per area light.
    pub area_samples: u32,
    /// Mirror reflections followed at most.
    pub max_depth: u32,
    /// Reconstruction filter.
    pub filter: Filter,
    /// Worker threads.
    pub threads: usize,
    /// Triangles in the BVH.
    pub triangles: usize,
    /// Light sources of the scene.
    pub lights: usize,
    /// Camera rays.
    pub primary_rays: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Shadow rays the SIB saved.
    pub shadow_rays_saved: u64,
    /// Diffuse hits.
    pub diffuse_hits: u64,
    /// Mirror reflection rays.
    pub reflection_rays: u64,
    /// Rays per final gather (0: none).
    pub gather: u32,
    /// Final gather rays cast.
    pub gather_rays: u64,
    /// Final gather records at the screen's grid.
    pub gather_records: u64,
    /// Diffuse hits that took their gather from the records.
    pub gather_reused: u64,
    /// Anti-aliasing samples that took a nearby sample's light through their own
    /// texel (`--retexture`): all of it, or its diffuse part.
    pub retextured: u64,
    /// `shadow_rays / diffuse_hits`.
    pub shadow_rays_per_hit: f64,
    /// Pixels that are NaN or infinite.
    pub non_finite_pixels: usize,
    /// Counts per level of the adaptive sampler.
    pub levels: Vec<LevelStats>,
    /// Counts per ray-traced source.
    pub sources: Vec<SourceStats>,
    /// Pass 1's figures (none for `direct`).
    pub solve: Option<SolveFigures>,
    /// The selection's figures (none for `direct`).
    pub selection: Option<SelectionStats>,
    /// Wall seconds per pass and `total`.
    pub time_s: BTreeMap<String, f64>,
}

/// What a render ran on, beside its settings and output (for [`RenderStats::new`]).
#[derive(Debug, Clone, Copy)]
pub struct RenderContext<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Triangles in the BVH.
    pub triangles: usize,
    /// The radiosity solution, if any.
    pub solution: Option<&'a Solution>,
    /// Worker threads.
    pub threads: usize,
}

impl RenderStats {
    /// The statistics of `out`, rendered with `settings` (and `selection`, made with
    /// `select`); `names` from [`source_names`]; `time_s` from
    /// [`crate::stats::Timings::to_json`].
    pub fn new(
        ctx: &RenderContext,
        settings: &Settings,
        out: &Output,
        selection: Option<&Selection>,
        select: &SelectSettings,
        names: &[(String, String)],
        time_s: BTreeMap<String, f64>,
    ) -> Self {
        let c = &out.counters;
        let per_hit = |rays: u64| {
            if c.diffuse_hits > 0 {
                rays as f64 / c.diffuse_hits as f64
            } else {
                0.0
            }
        };
        let sources = c
            .sources
            .iter()
            .zip(names)
            .map(|(s, (name, kind))| SourceStats {
                name: name.clone(),
                kind: kind.clone(),
                hits: s.hits,
                shadow_rays: s.shadow_rays,
                rays_per_hit: per_hit(s.shadow_rays),
            })
            .collect();
        let adaptive = settings.sampler == Sampler::Adaptive;
        RenderStats {
            scene: ctx.scene.path.clone(),
            view: settings.view,
            method: settings.method,
            sampler: settings.sampler,
            width: settings.width,
            height: settings.height,
            spp: (!adaptive).then_some(settings.spp),
            max_level: adaptive.then_some(settings.refine.max_level),
            contrast: adaptive.then_some(settings.refine.contrast),
            sib: adaptive && settings.refine.sib,
            seed: settings.seed,
            area_samples: settings.area_samples,
            max_depth: settings.max_depth,
            filter: settings.filter,
            threads: ctx.threads,
            triangles: ctx.triangles,
            lights: ctx.scene.lights.len(),
            primary_rays: c.primary_rays,
            shadow_rays: c.shadow_rays,
            shadow_rays_saved: c.shadow_rays_saved,
            diffuse_hits: c.diffuse_hits,
            reflection_rays: c.reflection_rays,
            gather: settings.gather,
            gather_rays: c.gather_rays,
            gather_records: c.gather_records,
            gather_reused: c.gather_reused,
            retextured: c.retextured,
            shadow_rays_per_hit: c.rays_per_hit(),
            non_finite_pixels: out.non_finite_pixels,
            levels: out.levels.clone(),
            sources,
            solve: ctx
                .solution
                .filter(|_| settings.method != Method::Direct)
                .map(SolveFigures::of),
            selection: selection.map(|sel| SelectionStats::of(sel, select)),
            time_s,
        }
    }
}
