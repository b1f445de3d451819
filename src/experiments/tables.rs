//! The paper's Tables 1-3 for views of a scene (`radtrace tables`): each view is
//! rendered four times from one radiosity solution with the adaptive sampler — fully
//! sampled (`norm`), local selection, the shadow image buffer (`norm` with SIB) and
//! both — and each picture is compared with the fully sampled one (mean FLIP).
//!
//! [`run`] returns the figures as typed rows; the command line prints them as text
//! tables or JSON and writes the pictures.

use std::path::PathBuf;

use serde::Serialize;

use crate::accel::Bvh;
use crate::image::Image;
use crate::progress::Progress;
use crate::radiosity::Solution;
use crate::render::{Filter, LevelStats, Method, Output, Refine, Sampler, Settings};
use crate::scene::Scene;
use crate::selection::{SelectSettings, Selection};
use crate::stats::{percent_saved, source_names, table2_figures, RenderContext, RenderStats, Timings};
use crate::{Error, Result};

/// One of the four renders of a view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// Short name (file names, JSON keys).
    pub key: &'static str,
    /// The method.
    pub method: Method,
    /// Whether the shadow image buffer is on.
    pub sib: bool,
}

/// The four renders of each view, in the order they run; the first is the fully
/// sampled picture the others are compared with.
pub const RUNS: [Run; 4] = [
    Run {
        key: "norm",
        method: Method::Norm,
        sib: false,
    },
    Run {
        key: "local",
        method: Method::Local,
        sib: false,
    },
    Run {
        key: "norm-sib",
        method: Method::Norm,
        sib: true,
    },
    Run {
        key: "local-sib",
        method: Method::Local,
        sib: true,
    },
];

/// The paper's letter of view `v` (a, b, ...), as in "Fig. 8a".
pub fn letter(v: usize) -> char {
    char::from(b'a' + (v % 26) as u8)
}

/// What to render.
#[derive(Debug, Clone, PartialEq)]
pub struct TablesPlan {
    /// The views; empty: every view of the scene.
    pub views: Vec<usize>,
    /// Image width [default: each view's film].
    pub width: Option<u32>,
    /// Image height [default: each view's film].
    pub height: Option<u32>,
    /// Seed of all random choices.
    pub seed: u64,
    /// Sub-sources per area light.
    pub area_samples: u32,
    /// Mirror reflections followed at most.
    pub max_depth: u32,
    /// Rays per final gather (0: none).
    pub gather: u32,
    /// Reconstruction filter.
    pub filter: Filter,
    /// Highest level of the adaptive sampler.
    pub max_level: u32,
    /// Its difference criterion.
    pub contrast: f32,
    /// The source selection's settings.
    pub select: SelectSettings,
    /// Whether [`ViewFigures::images`] keeps the four pictures.
    pub keep_images: bool,
}

impl TablesPlan {
    /// The views to render: [`TablesPlan::views`], or every view of `scene`; an error
    /// if there is none.
    pub fn views(&self, scene: &Scene) -> Result<Vec<usize>> {
        let views: Vec<usize> = if self.views.is_empty() {
            (0..scene.sensors.len()).collect()
        } else {
            self.views.clone()
        };
        if views.is_empty() {
            return Err(Error::Usage(format!(
                "{}: the scene has no view (sensor)",
                scene.path.display()
            )));
        }
        Ok(views)
    }

    /// The render settings of `run` of `view`.
    pub fn settings(&self, scene: &Scene, view: usize, run: &Run) -> Result<Settings> {
        let sensor = scene.sensor(view)?;
        Ok(Settings {
            method: run.method,
            view,
            width: self.width.unwrap_or(sensor.width),
            height: self.height.unwrap_or(sensor.height),
            spp: sensor.spp.unwrap_or(16).clamp(1, 65536),
            seed: self.seed,
            area_samples: self.area_samples,
            max_depth: self.max_depth,
            gather: self.gather,
            filter: self.filter,
            sampler: Sampler::Adaptive,
            refine: Refine {
                max_level: self.max_level,
                contrast: self.contrast,
                exposure: 0.0,
                sib: run.sib,
                // The paper's method: every anti-aliasing sample traced in full.
                retexture: false,
            },
        })
    }
}

/// The figures of one render of a view (the JSON of `radtrace tables --json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunFigures {
    /// Diffuse hits.
    pub diffuse_hits: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Shadow rays per diffuse hit.
    pub shadow_rays_per_hit: f64,
    /// % of the fully sampled picture's shadow rays saved.
    pub shadow_rays_saved_percent: f64,
    /// Mean FLIP against the fully sampled picture.
    pub flip_vs_norm: f32,
    /// Counts per level of the adaptive sampler.
    pub levels: Vec<LevelStats>,
}

/// The four renders of one view.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ViewFigures {
    /// The view.
    pub view: usize,
    /// Image width.
    #[serde(skip)]
    pub width: u32,
    /// Image height.
    #[serde(skip)]
    pub height: u32,
    /// Fully sampled.
    pub norm: RunFigures,
    /// Local selection.
    pub local: RunFigures,
    /// Fully sampled with the shadow image buffer.
    #[serde(rename = "norm-sib")]
    pub norm_sib: RunFigures,
    /// Local selection with the shadow image buffer.
    #[serde(rename = "local-sib")]
    pub local_sib: RunFigures,
    /// The four pictures in [`RUNS`] order, if [`TablesPlan::keep_images`].
    #[serde(skip)]
    pub images: Vec<Image>,
}

/// A row of Table 1 (and of Table 3): one picture against the fully sampled one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table1Row {
    /// "a fully sampled", "a local", ...
    pub figure: String,
    /// Diffuse hits.
    pub diffuse_hits: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Shadow rays per diffuse hit.
    pub shadow_rays_per_hit: f64,
    /// % of the fully sampled picture's shadow rays saved.
    pub shadow_rays_saved_percent: f64,
    /// Mean FLIP against the fully sampled picture.
    pub flip_vs_fully_sampled: f32,
}

/// A row of Table 3: Table 1's columns for the local selection with the SIB.
pub type Table3Row = Table1Row;

/// A row of Table 2: one level of the SIB picture, or (`level` none) all levels
/// against the fully sampled picture.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table2Row {
    /// "a SIB", ...
    pub figure: String,
    /// The level; none for the row of all levels.
    pub level: Option<i32>,
    /// Diffuse hits.
    pub diffuse_hits: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Shadow rays the SIB saved.
    pub shadow_rays_saved: u64,
    /// % of the level's shadow rays saved (none for all levels).
    pub saved_percent: Option<f64>,
    /// % saved over the levels so far; for all levels, % of the fully sampled
    /// picture's shadow rays saved.
    pub saved_cumulative_percent: f64,
}

/// The result of [`run`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tables {
    /// The scene file.
    pub scene: PathBuf,
    /// Per view, the four renders.
    pub views: Vec<ViewFigures>,
    /// Table 1: fully sampled and local selection.
    pub table1: Vec<Table1Row>,
    /// Table 2: the shadow image buffer per level.
    pub table2: Vec<Table2Row>,
    /// Table 3: fully sampled and local selection with the SIB.
    pub table3: Vec<Table3Row>,
}

/// One finished render, as handed to [`Observer::finished`].
#[derive(Debug)]
pub struct RunDone<'a> {
    /// The render's output (the picture, counts).
    pub output: &'a Output,
    /// Its statistics (the `--stats` document of `radtrace render`).
    pub stats: &'a RenderStats,
}

/// Hears of each render as it happens (the command line prints and writes files).
pub trait Observer {
    /// `run` of `view` is about to start.
    fn starting(&mut self, _view: usize, _run: &Run) {}
    /// The sources of a render that has them are selected.
    fn selected(&mut self, _run: &Run, _selection: &Selection) {}
    /// `run` of `view` is done.
    fn finished(&mut self, _view: usize, _run: &Run, _done: &RunDone) -> Result<()> {
        Ok(())
    }
}

/// Hears nothing.
impl Observer for () {}

/// Renders the four pictures of every view of `plan` from `solution` and collects the
/// paper's Tables 1-3. `progress` hears of each render's stages.
pub fn run(
    scene: &Scene,
    bvh: &Bvh,
    solution: &Solution,
    plan: &TablesPlan,
    progress: &dyn Progress,
    observer: &mut dyn Observer,
) -> Result<Tables> {
    let views = plan.views(scene)?;
    let ctx = RenderContext {
        scene,
        triangles: bvh.triangle_count(),
        solution: Some(solution),
        threads: rayon::current_num_threads(),
    };
    let mut tables = Tables {
        scene: scene.path.clone(),
        views: Vec::new(),
        table1: Vec::new(),
        table2: Vec::new(),
        table3: Vec::new(),
    };
    for &view in &views {
        let mut runs: Vec<(Output, f32)> = Vec::new();
        let (mut width, mut height) = (0, 0);
        for run in &RUNS {
            let settings = plan.settings(scene, view, run)?;
            (width, height) = (settings.width, settings.height);
            observer.starting(view, run);
            let mut t = Timings::default();
            let (out, selection) = super::select_and_render(
                scene,
                bvh,
                Some(solution),
                &settings,
                &plan.select,
                &mut |sel| observer.selected(run, sel),
                None,
                progress,
                &mut t,
            )?;
            let flip = match runs.first() {
                Some((full, _)) => crate::compare::compare(&full.image, &out.image, false)?.0.flip,
                None => 0.0,
            };
            let names = source_names(scene, selection.as_ref(), out.counters.sources.len());
            let stats = RenderStats::new(
                &ctx,
                &settings,
                &out,
                selection.as_ref(),
                &plan.select,
                &names,
                t.to_json(t.get("render").unwrap_or(0.0)),
            );
            observer.finished(
                view,
                run,
                &RunDone {
                    output: &out,
                    stats: &stats,
                },
            )?;
            runs.push((out, flip));
        }
        add_view(&mut tables, view, width, height, runs, plan.keep_images);
    }
    Ok(tables)
}

/// Adds the rows and figures of one view's four renders (in [`RUNS`] order).
fn add_view(
    tables: &mut Tables,
    view: usize,
    width: u32,
    height: u32,
    runs: Vec<(Output, f32)>,
    keep_images: bool,
) {
    let fig = letter(view);
    let base = runs[0].0.counters.shadow_rays;
    let row = |label: String, k: usize| {
        let c = &runs[k].0.counters;
        Table1Row {
            figure: label,
            diffuse_hits: c.diffuse_hits,
            shadow_rays: c.shadow_rays,
            shadow_rays_per_hit: c.rays_per_hit(),
            shadow_rays_saved_percent: percent_saved(c.shadow_rays, base),
            flip_vs_fully_sampled: runs[k].1,
        }
    };
    tables.table1.push(row(format!("{fig} fully sampled"), 0));
    tables.table1.push(row(format!("{fig} local"), 1));
    for l in table2_figures(&runs[2].0.levels) {
        tables.table2.push(Table2Row {
            figure: format!("{fig} SIB"),
            level: Some(l.level),
            diffuse_hits: l.diffuse_hits,
            shadow_rays: l.shadow_rays,
            shadow_rays_saved: l.shadow_rays_saved,
            saved_percent: Some(l.saved_percent),
            saved_cumulative_percent: l.saved_cumulative_percent,
        });
    }
    let c = &runs[2].0.counters;
    tables.table2.push(Table2Row {
        figure: format!("{fig} SIB"),
        level: None,
        diffuse_hits: c.diffuse_hits,
        shadow_rays: c.shadow_rays,
        shadow_rays_saved: c.shadow_rays_saved,
        saved_percent: None,
        saved_cumulative_percent: percent_saved(c.shadow_rays, base),
    });
    tables.table3.push(row(format!("{fig} fully sampled"), 0));
    tables.table3.push(row(format!("{fig} local and SIB"), 3));
    let figures = |(out, flip): &(Output, f32)| {
        let c = &out.counters;
        RunFigures {
            diffuse_hits: c.diffuse_hits,
            shadow_rays: c.shadow_rays,
            shadow_rays_per_hit: c.rays_per_hit(),
            shadow_rays_saved_percent: percent_saved(c.shadow_rays, base),
            flip_vs_norm: *flip,
            levels: out.levels.clone(),
        }
    };
    let [norm, local, norm_sib, local_sib] = [0, 1, 2, 3].map(|k| figures(&runs[k]));
    tables.views.push(ViewFigures {
        view,
        width,
        height,
        norm,
        local,
        norm_sib,
        local_sib,
        images: if keep_images {
            runs.into_iter().map(|(out, _)| out.image).collect()
        } else {
            Vec::new()
        },
    });
}

/// The document of `radtrace tables --json`.
#[derive(Debug, Clone, Serialize)]
pub struct TablesJson<'a> {
    /// The scene file.
    pub scene: &'a std::path::Path,
    /// Per view, the four renders.
    pub views: &'a [ViewFigures],
    /// Wall seconds of the whole command.
    pub time_s: f64,
}
