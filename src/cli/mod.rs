//! The `radtrace` command line: [`args`] defines the flags, one module per command
//! runs it; this module holds what the commands share (scene loading, progress bars,
//! the statistics JSON).

mod args;
mod bench;
mod compare;
mod info;
mod render;
mod solve;
mod tables;
mod tessellate;

use std::path::Path;

use clap::Parser;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;

use crate::accel::Bvh;
use crate::io::solution;
use crate::progress::Progress;
use crate::radiosity::{self, Solution, SolveSettings};
use crate::render::{Method, Sampler, Settings};
use crate::scene::{xml, Scene};
use crate::selection::{self, SelectSettings, Selection, ViewScale};
use crate::stats::Timings;
use crate::{Error, Result};

pub use args::*;

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    // Ctrl-C: stop at once, but let an output being written be finished and renamed,
    // so that no partial or temporary file is left. 130 = 128 + SIGINT.
    let _ = ctrlc::set_handler(|| {
        eprintln!("radtrace: interrupted");
        crate::io::exit_after_writes(130)
    });
    match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("radtrace: error: {e}");
            e.exit_code()
        }
    }
}

/// Runs a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => render::cmd_render(a),
        Command::Solve(a) => solve::cmd_solve(a),
        Command::Info(a) => info::cmd_info(a),
        Command::Tessellate(a) => tessellate::cmd_tessellate(a),
        Command::Compare(a) => compare::cmd_compare(a),
        Command::Tables(a) => tables::cmd_tables(a),
        Command::Bench(a) => bench::cmd_bench(a),
    }
}

/// Loads a scene, printing its warnings unless `quiet`.
fn load_scene(args: &SceneArgs, quiet: bool) -> Result<Scene> {
    let loaded = xml::load(&args.scene, &args.defines)?;
    if !quiet {
        for w in &loaded.warnings {
            eprintln!("radtrace: warning: {w}");
        }
    }
    Ok(loaded.scene)
}

/// Progress drawn on stderr by indicatif, one bar per stage ([`Progress`]); nothing
/// when quiet.
struct Bars {
    quiet: bool,
    bar: std::sync::Mutex<Option<ProgressBar>>,
}

impl Bars {
    fn new(quiet: bool) -> Self {
        Bars {
            quiet,
            bar: std::sync::Mutex::new(None),
        }
    }

    fn with_bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Some(pb) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            f(pb);
        }
    }
}

impl Progress for Bars {
    fn start(&self, label: &str, total: u64) {
        let pb = if self.quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
        };
        pb.set_style(
            ProgressStyle::with_template("{prefix:>8} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        pb.set_prefix(label.to_string());
        if let Some(old) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).replace(pb) {
            old.finish_and_clear();
        }
    }

    fn advance(&self, units: u64) {
        self.with_bar(|pb| pb.inc(units));
    }

    fn set(&self, done: u64) {
        self.with_bar(|pb| pb.set_position(done));
    }

    fn finish(&self) {
        if let Some(pb) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            pb.finish_and_clear();
        }
    }
}

/// A loaded scene with its BVH and (for methods other than `direct`) its radiosity
/// solution: what every view shares.
struct Loaded {
    scene: Scene,
    bvh: Bvh,
    solution: Option<Solution>,
}

/// Loads the scene, builds the BVH, and loads or computes the solution if `solve`.
fn load_all(
    scene: &SceneArgs,
    solution: Option<&Path>,
    solve: Option<(&SolveArgs, u64)>,
    quiet: bool,
    t: &mut Timings,
) -> Result<Loaded> {
    let scene = t.time("load", || load_scene(scene, quiet))?;
    let bvh = t.time("accel", || Bvh::build(&scene));
    if bvh.skipped > 0 && !quiet {
        eprintln!(
            "radtrace: warning: {} degenerate triangle(s) ignored",
            bvh.skipped
        );
    }
    let solution = match (solve, solution) {
        (None, _) => None,
        (Some(_), Some(path)) => Some(t.time("load_solution", || solution::load(path, &scene))?),
        (Some((args, seed)), None) => {
            let st = args.settings(&scene, seed)?;
            Some(t.time("solve", || run_solve(&scene, &bvh, &st, quiet)))
        }
    };
    Ok(Loaded { scene, bvh, solution })
}

/// Selects the sources for `settings.method` (with the view's camera) and renders.
fn render_view<'a>(
    l: &'a Loaded,
    settings: &Settings,
    select: &SelectSettings,
    quiet: bool,
    t: &mut Timings,
) -> Result<(crate::render::Output, Option<Selection<'a>>)> {
    let sensor = l.scene.sensor(settings.view)?;
    let camera = crate::camera::Camera::new(sensor, settings.width, settings.height);
    let selection = match (&l.solution, settings.method) {
        (_, Method::Direct) | (None, _) => None,
        (Some(sol), method) => {
            let view = ViewScale::of(&camera);
            Some(t.time("select", || {
                selection::select(&l.scene, sol, method, select, Some(&view))
            })?)
        }
    };
    if let (Some(sel), false) = (&selection, quiet) {
        if settings.method == Method::Local {
            print_selection_summary(sel);
        }
    }
    let out = crate::render::render(&l.scene, &l.bvh, settings, selection.as_ref(), &Bars::new(quiet))?;
    t.add("render", out.trace_s);
    t.add("reconstruct", out.reconstruct_s);
    Ok((out, selection))
}

/// Name and kind of each ray-traced source of a render.
fn source_names(scene: &Scene, selection: Option<&Selection>, count: usize) -> Vec<(String, String)> {
    (0..count)
        .map(|i| match selection {
            Some(sel) => (sel.source_name(scene, i), source_kind(scene, sel.sources[i])),
            None => (scene.light_name(i), scene.lights[i].kind().to_string()),
        })
        .collect()
}

/// The statistics JSON of one render.
#[allow(clippy::too_many_arguments)]
fn render_json(
    l: &Loaded,
    settings: &Settings,
    out: &crate::render::Output,
    selection: Option<&Selection>,
    select: &SelectSettings,
    names: &[(String, String)],
    threads: usize,
    time_s: serde_json::Value,
) -> serde_json::Value {
    let c = &out.counters;
    let per_hit = |rays: u64| {
        if c.diffuse_hits > 0 {
            rays as f64 / c.diffuse_hits as f64
        } else {
            0.0
        }
    };
    let sources: Vec<serde_json::Value> = c
        .sources
        .iter()
        .zip(names)
        .map(|(s, (name, kind))| {
            json!({
                "name": name,
                "kind": kind,
                "hits": s.hits,
                "shadow_rays": s.shadow_rays,
                "rays_per_hit": per_hit(s.shadow_rays),
            })
        })
        .collect();
    let adaptive = settings.sampler == Sampler::Adaptive;
    json!({
        "scene": l.scene.path,
        "view": settings.view,
        "method": settings.method,
        "sampler": settings.sampler,
        "width": settings.width,
        "height": settings.height,
        "spp": if adaptive { serde_json::Value::Null } else { json!(settings.spp) },
        "max_level": if adaptive { json!(settings.refine.max_level) } else { serde_json::Value::Null },
        "contrast": if adaptive { json!(settings.refine.contrast) } else { serde_json::Value::Null },
        "sib": adaptive && settings.refine.sib,
        "seed": settings.seed,
        "area_samples": settings.area_samples,
        "max_depth": settings.max_depth,
        "filter": settings.filter,
        "threads": threads,
        "triangles": l.bvh.triangle_count(),
        "lights": l.scene.lights.len(),
        "primary_rays": c.primary_rays,
        "shadow_rays": c.shadow_rays,
        "shadow_rays_saved": c.shadow_rays_saved,
        "diffuse_hits": c.diffuse_hits,
        "reflection_rays": c.reflection_rays,
        "shadow_rays_per_hit": c.rays_per_hit(),
        "non_finite_pixels": out.non_finite_pixels,
        "levels": out.levels,
        "sources": sources,
        "solve": l.solution.as_ref().filter(|_| settings.method != Method::Direct).map(solve_json),
        "selection": selection.map(|sel| selection_json(sel, select)),
        "time_s": time_s,
    })
}

fn write_json(path: &Path, doc: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(doc).expect("stats serialise") + "\n";
    crate::io::write_atomic(path, text.as_bytes())
}

/// "spot", "area", ... or "patch" for a radiant patch.
fn source_kind(scene: &Scene, s: radiosity::SourceId) -> String {
    match s {
        radiosity::SourceId::Light(l) => scene.lights[l as usize].kind().to_string(),
        radiosity::SourceId::Patch(_) => "patch".to_string(),
    }
}

/// How many (patch, listed source) pairs each criterion turned down.
fn rejections(sel: &Selection) -> serde_json::Value {
    let mut listed = 0;
    let mut selected = 0;
    let mut r = [0u64; 5];
    for (_, c) in sel.criteria.iter().flatten() {
        listed += 1;
        selected += c.selected() as u64;
        for (k, ok) in [c.radiance, c.reflectivity, c.gradient, c.solid_angle, c.view]
            .into_iter()
            .enumerate()
        {
            r[k] += !ok as u64;
        }
    }
    json!({
        "listed": listed,
        "selected": selected,
        "rejected_by": {
            "radiance": r[0], "reflectivity": r[1], "gradient": r[2], "solid_angle": r[3], "view": r[4],
        },
    })
}

fn print_selection_summary(sel: &Selection) {
    let r = rejections(sel);
    let by = &r["rejected_by"];
    eprintln!(
        "radtrace: local selection: {} of {} listed (patch, source) pairs ray traced; turned down by radiance {}, reflectivity {}, gradient {}, solid angle {}, view {}",
        sel.pick_count(),
        r["listed"],
        by["radiance"],
        by["reflectivity"],
        by["gradient"],
        by["solid_angle"],
        by["view"]
    );
}

/// The `selection` object of the statistics JSON.
fn selection_json(sel: &Selection, st: &SelectSettings) -> serde_json::Value {
    let mesh = &sel.solution.mesh;
    let patches_with_rays = (0..mesh.patches.len() as u32)
        .filter(|&p| !sel.picks(p).is_empty())
        .count();
    let mut doc = json!({
        "method": sel.method,
        "settings": st,
        "picks": sel.pick_count(),
        "patches": mesh.patches.len(),
        "patches_with_rays": patches_with_rays,
        "radiant_patches_sampled": sel.sources.len() - sel.sources.iter().filter(|s| matches!(s, radiosity::SourceId::Light(_))).count(),
    });
    if sel.method == Method::Local {
        doc["criteria"] = rejections(sel);
    }
    doc
}

/// Runs pass 1 with a progress bar.
fn run_solve(scene: &Scene, bvh: &Bvh, st: &SolveSettings, quiet: bool) -> Solution {
    let sol = radiosity::solve(scene, bvh, st, &Bars::new(quiet));
    if !quiet {
        let s = &sol.stats;
        eprintln!(
            "radtrace: solved: {} patches, {} elements, {} vertices (mesh size {:.4}); {} light + {} patch shots, {} rays, {:.2}% unshot, {:.2} s",
            s.patches,
            s.elements,
            s.vertices,
            st.mesh_size,
            s.light_shots,
            s.patch_shots,
            s.rays,
            100.0 * s.residual,
            s.time_s
        );
    }
    sol
}

/// The `solve` object of the statistics JSON.
fn solve_json(sol: &Solution) -> serde_json::Value {
    let s = &sol.stats;
    json!({
        "mesh_size": sol.settings.mesh_size,
        "sources_per_patch": sol.settings.sources_per_patch,
        "shoot_samples": sol.settings.shoot_samples,
        "tolerance": sol.settings.tolerance,
        "patches": s.patches,
        "elements": s.elements,
        "vertices": s.vertices,
        "shots": s.light_shots + s.patch_shots,
        "light_shots": s.light_shots,
        "patch_shots": s.patch_shots,
        "rays": s.rays,
        "emitted_power": s.emitted_power,
        "residual": s.residual,
        "time_s": s.time_s,
    })
}
/// Runs `f` on a pool of `threads` workers (all cores when `None`), passing the
/// number of workers.
fn with_threads<T: Send>(threads: Option<u32>, f: impl FnOnce(usize) -> Result<T> + Send) -> Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0) as usize)
        .build()
        .map_err(|e| Error::Usage(format!("cannot start worker threads: {e}")))?;
    let n = pool.current_num_threads();
    pool.install(|| f(n))
}

fn check_output_ext(path: &Path, allowed: &[&str]) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext {
        Some(e) if allowed.contains(&e.as_str()) => Ok(()),
        _ => Err(Error::Usage(format!(
            "cannot write '{}': the output must end in {}",
            path.display(),
            allowed
                .iter()
                .map(|e| format!(".{e}"))
                .collect::<Vec<_>>()
                .join(" or ")
        ))),
    }
}
