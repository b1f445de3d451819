//! The `radtrace` command line.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;

use crate::accel::Bvh;
use crate::io::solution;
use crate::progress::Progress;
use crate::radiosity::{self, Solution, SolveSettings};
use crate::render::{self, Filter, Method, Refine, Sampler, Settings};
use crate::scene::{xml, Light, Scene};
use crate::selection::{self, SelectPer, SelectSettings, Selection, ViewScale};
use crate::stats::Timings;
use crate::{Error, Result};

/// radtrace: radiosity ray tracing with source selection and a shadow image buffer
/// (Kok, Jansen & Woodward 1993). Reads Mitsuba 3 scene files.
#[derive(Debug, Parser)]
#[command(name = "radtrace", version, about, long_about = None)]
pub struct Cli {
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a view of a scene to an image.
    Render(RenderArgs),
    /// Compute the view-independent radiosity solution (pass 1) and save it.
    Solve(SolveCmdArgs),
    /// Print what a scene contains (shapes, lights, views).
    Info(InfoArgs),
    /// Write a Bezier patch file (.bpt) as a triangle mesh (.obj), e.g. for Mitsuba.
    Tessellate(TessellateArgs),
    /// Compare two images: mean FLIP and RMSE.
    Compare(CompareArgs),
    /// Reproduce the paper's Tables 1-3 for every view of a scene: fully sampled,
    /// local selection, shadow image buffer, and both.
    Tables(TablesArgs),
    /// Measure ray throughput (camera, shadow, incoherent rays), BVH build, the
    /// radiosity solve and peak memory.
    Bench(BenchArgs),
}

/// Options shared by commands that load a scene.
#[derive(Debug, Args)]
pub struct SceneArgs {
    /// The scene file (Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Set a scene parameter declared with <default name=...> (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
}

/// Settings of the radiosity pass (pass 1).
#[derive(Debug, Args)]
pub struct SolveArgs {
    /// Largest radiosity element edge, in scene units [default: the scene's
    /// bounding-box diagonal / 40].
    #[arg(long, value_name = "SIZE", allow_negative_numbers = true)]
    mesh_size: Option<f32>,
    /// n: sources kept apart, per patch, from the general radiosity (lights are never
    /// evicted by radiant patches) [default: the number of lights, at least 4].
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=64))]
    sources_per_patch: Option<u32>,
    /// Sample cells per area light or shooting patch in each shot.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=4096))]
    shoot_samples: u32,
    /// Stop when the unshot power falls below this fraction of the emitted power.
    #[arg(long, default_value_t = 0.01, value_name = "FRACTION")]
    solve_tolerance: f32,
    /// Stop after this many patch shots at most.
    #[arg(long, default_value_t = 20000)]
    max_shots: u32,
}

impl SolveArgs {
    fn settings(&self, scene: &Scene, seed: u64) -> Result<SolveSettings> {
        let mesh_size = match self.mesh_size {
            Some(m) if m.is_finite() && m > 0.0 => m,
            Some(m) => {
                return Err(Error::Usage(format!(
                    "--mesh-size {m}: must be a positive length"
                )))
            }
            None => crate::mesh::default_mesh_size(scene),
        };
        if !(0.0..=1.0).contains(&self.solve_tolerance) {
            return Err(Error::Usage(format!(
                "--solve-tolerance {}: must be a fraction between 0 and 1",
                self.solve_tolerance
            )));
        }
        Ok(SolveSettings {
            mesh_size,
            sources_per_patch: self
                .sources_per_patch
                .unwrap_or((scene.lights.len() as u32).clamp(4, 64)),
            shoot_samples: self.shoot_samples,
            tolerance: self.solve_tolerance,
            max_shots: self.max_shots,
            seed,
        })
    }
}

/// Source selection (paper Sect. 3): thresholds of the five criteria, per patch or
/// per object, and the global selection's size.
#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Make the local selection per patch, or per object (shape) so that patch
    /// boundaries cannot show.
    #[arg(long, value_enum, default_value_t = SelectPer::Patch)]
    select_per: SelectPer,
    /// Radiance criterion: a source must bring at least this fraction of a patch's
    /// radiosity (unoccluded, where largest) to be ray traced there.
    #[arg(long, default_value_t = SelectSettings::default().radiance_threshold, value_name = "FRACTION")]
    radiance_threshold: f32,
    /// Reflectivity criterion: no shadow rays from patches whose diffuse reflectance
    /// (mean of RGB) is below this.
    #[arg(long, default_value_t = SelectSettings::default().reflectivity_threshold, value_name = "REFLECTANCE")]
    reflectivity_threshold: f32,
    /// Gradient criterion: a source must be partly visible across a patch (its
    /// visibility at the patch's vertices spreading by more than this) to be ray traced.
    #[arg(long, default_value_t = SelectSettings::default().gradient_threshold, value_name = "FRACTION")]
    gradient_threshold: f32,
    /// Solid-angle criterion: sources seen under a larger solid angle (steradians,
    /// mean over the patch) are left to the radiosity.
    #[arg(long, default_value_t = SelectSettings::default().max_solid_angle, value_name = "SR")]
    max_solid_angle: f32,
    /// Shadow rays for a whole hemisphere: an area source seen under solid angle
    /// Omega gets max(1, round(Omega / 2pi x this)) rays, at most --area-samples.
    #[arg(long, default_value_t = SelectSettings::default().hemisphere_rays, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    hemisphere_rays: u32,
    /// View criterion: patches whose mesh elements look smaller than this many
    /// pixels are left to the mesh.
    #[arg(long, default_value_t = SelectSettings::default().view_threshold, value_name = "PIXELS")]
    view_threshold: f32,
    /// Do not apply the view criterion (animation: the selection must not depend on
    /// the camera).
    #[arg(long)]
    no_view_criterion: bool,
    /// Sources ray traced everywhere by --method global.
    #[arg(long, default_value_t = SelectSettings::default().global_sources)]
    global_sources: u32,
}

impl SelectArgs {
    fn settings(&self, area_samples: u32) -> Result<SelectSettings> {
        let check = |name: &str, v: f32, lo: f32, hi: f32| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::Usage(format!(
                    "--{name} {v}: must be between {lo} and {hi}"
                )))
            }
        };
        check("radiance-threshold", self.radiance_threshold, 0.0, f32::MAX)?;
        check("reflectivity-threshold", self.reflectivity_threshold, 0.0, 1.0)?;
        check("gradient-threshold", self.gradient_threshold, 0.0, 1.0)?;
        check(
            "max-solid-angle",
            self.max_solid_angle,
            0.0,
            4.0 * std::f32::consts::PI,
        )?;
        check("view-threshold", self.view_threshold, 0.0, f32::MAX)?;
        Ok(SelectSettings {
            per: self.select_per,
            radiance_threshold: self.radiance_threshold,
            reflectivity_threshold: self.reflectivity_threshold,
            gradient_threshold: self.gradient_threshold,
            max_solid_angle: self.max_solid_angle,
            hemisphere_rays: self.hemisphere_rays,
            view_threshold: self.view_threshold,
            view_criterion: !self.no_view_criterion,
            area_samples,
            global_sources: self.global_sources,
        })
    }
}

/// Implements clap's `ValueEnum` for a core type from its `name()`, so that clap
/// stays in the CLI: `value_enum!(Type { Variant => "help", ... })`.
macro_rules! value_enum {
    ($t:ident { $($v:ident => $help:literal),+ $(,)? }) => {
        impl clap::ValueEnum for $t {
            fn value_variants<'a>() -> &'a [Self] {
                &[$($t::$v),+]
            }
            fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
                let help = match self {
                    $($t::$v => $help),+
                };
                Some(clap::builder::PossibleValue::new(self.name()).help(help))
            }
        }
    };
}

value_enum!(Method {
    Direct => "Exact direct light: shadow rays to every light at every diffuse hit; no indirect light",
    Twopass => "Standard two-pass radiosity: shading from the radiosity mesh alone (Fig. 7)",
    Norm => "Radiosity for indirect light, every light ray traced at fixed counts (Fig. 8)",
    Local => "Per-patch source selection with the five criteria of Sect. 3 (Fig. 9)",
    Global => "The --global-sources strongest sources ray traced everywhere",
});
value_enum!(Sampler {
    Adaptive => "The paper's adaptive refinement with the shadow image buffer",
    Uniform => "--spp jittered samples in every pixel, every shadow ray cast",
});
value_enum!(Filter {
    Box => "Equal weights for the samples inside the pixel's square (the paper's)",
    Gaussian => "Mitsuba's Gaussian: stddev 0.5 px, radius 2 px",
});
value_enum!(SelectPer {
    Patch => "Each patch chooses its own sources",
    Object => "All patches of an object share one choice (paper Sect. 3)",
});

/// On or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

/// The adaptive sampler (paper Sect. 5 and 6).
#[derive(Debug, Args)]
pub struct RefineArgs {
    /// Highest refinement level of the adaptive sampler: at most 4^N samples per
    /// pixel (level -1: one per 2x2 pixels; level 0: one per pixel).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=4))]
    max_level: u32,
    /// Difference criterion: refine where neighbouring samples' display values
    /// (sRGB, 0..1, after --exposure) differ by more than this in a channel.
    #[arg(long, default_value_t = 0.05, value_name = "DIFFERENCE")]
    contrast: f32,
}

impl RefineArgs {
    fn refine(&self, sib: bool, exposure: f32) -> Result<Refine> {
        if !(self.contrast >= 0.0 && self.contrast <= 1.0) {
            return Err(Error::Usage(format!(
                "--contrast {}: must be between 0 and 1",
                self.contrast
            )));
        }
        Ok(Refine {
            max_level: self.max_level,
            contrast: self.contrast,
            exposure,
            sib,
        })
    }
}

/// `radtrace solve`.
#[derive(Debug, Args)]
pub struct SolveCmdArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// The solution file to write.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    solve: SolveArgs,
    /// Seed for the shooting samples.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Write the solve's figures as JSON to this file.
    #[arg(long, value_name = "FILE")]
    stats: Option<PathBuf>,
    /// No progress bar and no warnings on stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// `radtrace render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output image: .exr (linear radiance) or .png (8-bit sRGB).
    #[arg(short, long)]
    output: PathBuf,
    /// How direct light is computed.
    #[arg(long, value_enum, default_value_t = Method::Local)]
    method: Method,
    /// Which view (sensor) of the scene, from 0.
    #[arg(long, default_value_t = 0)]
    view: usize,
    /// Image sampler: `adaptive` (the paper's refinement from level -1 to
    /// --max-level, with the shadow image buffer) or `uniform` (--spp samples in every
    /// pixel) [default: adaptive; uniform when --spp is given].
    #[arg(long, value_enum)]
    sampler: Option<Sampler>,
    /// Samples per pixel of the uniform sampler [default: the scene's sampler, else 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp: Option<u32>,
    #[command(flatten)]
    refine: RefineArgs,
    /// Shadow image buffer: `on` takes a light point's visibility from the
    /// neighbouring samples where they agree, `off` casts every shadow ray (the fully
    /// sampled picture) [default: on for local and global, off otherwise].
    #[arg(long, value_enum)]
    sib: Option<OnOff>,
    /// Write pictures of the method to this folder: the shadow image of each
    /// ray-traced source (sib-NN-NAME.png), samples per pixel (density.png) and shadow
    /// rays per pixel (rays.png). Adaptive sampler only.
    #[arg(long, value_name = "DIR")]
    sib_images: Option<PathBuf>,
    #[command(flatten)]
    image: ImageArgs,
    /// Exposure in stops applied to PNG output (EXR is always written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Write statistics (rays, hits, timings) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    stats: Option<PathBuf>,
    /// No progress bar and no warnings on stderr.
    #[arg(short, long)]
    quiet: bool,
    /// Print the statistics as a text table in the layout of the paper's Table 1
    /// (diffuse hits, shadow rays, rays per hit; per source below).
    #[arg(long)]
    stats_table: bool,
    /// A --stats file of a fully sampled render (--method norm) of the same view: the
    /// table then shows both rows and the shadow rays saved.
    #[arg(long, value_name = "FILE")]
    baseline: Option<PathBuf>,
    /// Write a picture of the selection (PNG): each patch coloured by the sources ray
    /// traced on it, brighter for more shadow rays per hit.
    #[arg(long, value_name = "FILE")]
    selection_map: Option<PathBuf>,
    /// Reuse a radiosity solution saved by `radtrace solve` instead of solving.
    #[arg(long, value_name = "FILE")]
    solution: Option<PathBuf>,
    #[command(flatten)]
    solve: SolveArgs,
    #[command(flatten)]
    select: SelectArgs,
}

/// Image and sampling options shared by `render` and `tables`.
#[derive(Debug, Args)]
pub struct ImageArgs {
    /// Seed for all random choices; the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Image width in pixels [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Image height in pixels [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// Sub-sources of each area light (and selected radiant patch): the shadow rays
    /// `norm` casts to it at each diffuse hit, and the most `local` casts.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    area_samples: u32,
    /// Maximum number of mirror reflections followed.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(0..=64))]
    max_depth: u32,
    /// Pixel reconstruction filter.
    #[arg(long, value_enum, default_value_t = Filter::Gaussian)]
    filter: Filter,
}

/// `radtrace tables`.
#[derive(Debug, Args)]
pub struct TablesArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Views (sensors) to render, e.g. `0,1` [default: every view of the scene].
    #[arg(long, value_delimiter = ',')]
    views: Vec<usize>,
    /// Write each view's four images (viewK-RUN.exr) and statistics (viewK-RUN.json)
    /// to this folder.
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
    /// Print the figures as JSON instead of tables.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    image: ImageArgs,
    #[command(flatten)]
    refine: RefineArgs,
    /// Reuse a radiosity solution saved by `radtrace solve` instead of solving.
    #[arg(long, value_name = "FILE")]
    solution: Option<PathBuf>,
    #[command(flatten)]
    solve: SolveArgs,
    #[command(flatten)]
    select: SelectArgs,
    /// No progress bars and no warnings on stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// `radtrace info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    scene: SceneArgs,
}

/// `radtrace tessellate`.
#[derive(Debug, Args)]
pub struct TessellateArgs {
    /// Bezier patch file (.bpt).
    input: PathBuf,
    /// Output mesh (.obj).
    #[arg(short, long)]
    output: PathBuf,
    /// Radiosity patches per Bezier patch side.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    coarse: u32,
    /// Quads per radiosity patch side (ray-tracing resolution).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    fine: u32,
}

/// `radtrace compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Reference image (.exr or .png).
    reference: PathBuf,
    /// Test image (.exr or .png).
    test: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Write the FLIP error map (magma colours) to this PNG.
    #[arg(long, value_name = "FILE")]
    error_map: Option<PathBuf>,
}

/// `radtrace bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Which view (sensor) the camera rays come from, from 0.
    #[arg(long, default_value_t = 0)]
    view: usize,
    /// Camera rays per row [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: Option<u32>,
    /// Rows of camera rays [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: Option<u32>,
    /// Shadow rays per camera-ray hit (to points on the lights, in turn).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(0..=1024))]
    shadow_rays: u32,
    /// Incoherent (cosine-distributed bounce) rays per camera-ray hit.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=1024))]
    bounce_rays: u32,
    /// Times each measurement is repeated; the best is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// Seed of the light points and bounce directions (and of the solve).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads of the "all threads" figures [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    threads: Option<u32>,
    /// Skip the radiosity solve (and the renders of the views, which need it).
    #[arg(long)]
    no_solve: bool,
    /// Also solve and render on one thread, for the 1-vs-all-threads scaling.
    #[arg(long, conflicts_with = "no_solve")]
    solve_scaling: bool,
    #[command(flatten)]
    solve: SolveArgs,
    /// Print JSON instead of the table.
    #[arg(long)]
    json: bool,
    /// Write the triangles, the ray sets and radtrace's answers to this directory as
    /// .npy files (for tools/compare-peers.py).
    #[arg(long, value_name = "DIR")]
    dump: Option<PathBuf>,
    /// No warnings on stderr.
    #[arg(short, long)]
    quiet: bool,
}

fn parse_define(s: &str) -> std::result::Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE, got '{s}'")),
    }
}

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
        Command::Render(a) => cmd_render(a),
        Command::Solve(a) => cmd_solve(a),
        Command::Info(a) => cmd_info(a),
        Command::Tessellate(a) => cmd_tessellate(a),
        Command::Compare(a) => cmd_compare(a),
        Command::Tables(a) => cmd_tables(a),
        Command::Bench(a) => cmd_bench(a),
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
) -> Result<(render::Output, Option<Selection<'a>>)> {
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
    let out = render::render(&l.scene, &l.bvh, settings, selection.as_ref(), &Bars::new(quiet))?;
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
    out: &render::Output,
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

/// Writes the pictures of `--sib-images` to `dir`.
fn write_sib_images(dir: &Path, set: &render::SampleSet, names: &[(String, String)]) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (i, (name, _)) in names.iter().enumerate() {
        let safe: String = name
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let img = set.shadow_image(i as u32);
        crate::io::write_image(&img, &dir.join(format!("sib-{i:02}-{safe}.png")), 0.0)?;
    }
    crate::io::write_image(&set.density_image(), &dir.join("density.png"), 0.0)?;
    crate::io::write_image(&set.rays_image(), &dir.join("rays.png"), 0.0)
}

impl ImageArgs {
    /// The render settings for `view` of `scene` with `method` (the uniform sampler's
    /// `spp` and the adaptive sampler's `refine` as given).
    fn settings(
        &self,
        scene: &Scene,
        view: usize,
        method: Method,
        sampler: Sampler,
        spp: Option<u32>,
        refine: Refine,
    ) -> Result<Settings> {
        let sensor = scene.sensor(view)?;
        Ok(Settings {
            method,
            view,
            width: self.width.unwrap_or(sensor.width),
            height: self.height.unwrap_or(sensor.height),
            spp: spp.or(sensor.spp).unwrap_or(16).clamp(1, 65536),
            seed: self.seed,
            area_samples: self.area_samples,
            max_depth: self.max_depth,
            filter: self.filter,
            sampler,
            refine,
        })
    }
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    let total = Instant::now();
    check_output_ext(&a.output, &["exr", "png"])?;
    if let Some(map) = &a.selection_map {
        check_output_ext(map, &["png"])?;
        if a.method == Method::Direct {
            return Err(Error::Usage(
                "--selection-map needs a method with a radiosity solution (not --method direct)".into(),
            ));
        }
    }
    let sampler = a.sampler.unwrap_or(if a.spp.is_some() {
        Sampler::Uniform
    } else {
        Sampler::Adaptive
    });
    if sampler == Sampler::Adaptive && a.spp.is_some() {
        return Err(Error::Usage(
            "--spp sets the uniform sampler's samples per pixel; the adaptive sampler takes up to 4^--max-level per pixel (use --sampler uniform with --spp)".into(),
        ));
    }
    if a.sib_images.is_some() && sampler != Sampler::Adaptive {
        return Err(Error::Usage(
            "--sib-images needs the adaptive sampler (the shadow image buffer)".into(),
        ));
    }
    if a.sib == Some(OnOff::On) && sampler != Sampler::Adaptive {
        return Err(Error::Usage(
            "--sib on needs the adaptive sampler: the shadow image buffer reuses the shadows of coarser samples".into(),
        ));
    }
    let sib = match a.sib {
        Some(v) => v == OnOff::On,
        None => matches!(a.method, Method::Local | Method::Global),
    };
    let refine = a.refine.refine(sib, a.exposure)?;
    let select_settings = a.select.settings(a.image.area_samples)?;
    let baseline = a.baseline.as_deref().map(read_baseline).transpose()?;
    with_threads(a.image.threads, |threads| {
        let mut t = Timings::default();
        let solve = (a.method != Method::Direct).then_some((&a.solve, a.image.seed));
        let l = load_all(&a.scene, a.solution.as_deref(), solve, a.quiet, &mut t)?;
        let settings = a
            .image
            .settings(&l.scene, a.view, a.method, sampler, a.spp, refine)?;
        let (out, selection) = render_view(&l, &settings, &select_settings, a.quiet, &mut t)?;
        if let (Some(path), Some(sel)) = (&a.selection_map, &selection) {
            let camera = crate::camera::Camera::new(l.scene.sensor(a.view)?, settings.width, settings.height);
            let img = t.time("selection_map", || {
                render::debug::selection_map(&l.scene, &l.bvh, &camera, sel, settings.width, settings.height)
            });
            crate::io::write_image(&img, path, 0.0)?;
            if !a.quiet {
                eprintln!(
                    "radtrace: selection map -> {} (colours per source:)",
                    path.display()
                );
                for i in 0..sel.sources.len().min(16) {
                    let c = render::debug::source_colour(i);
                    eprintln!(
                        "  {:<28} rgb({:.0}, {:.0}, {:.0})",
                        sel.source_name(&l.scene, i),
                        255.0 * c.x,
                        255.0 * c.y,
                        255.0 * c.z
                    );
                }
            }
        }
        t.time("output", || {
            crate::io::write_image(&out.image, &a.output, a.exposure)
        })?;
        let c = &out.counters;
        if out.non_finite_pixels > 0 && !a.quiet {
            eprintln!(
                "radtrace: warning: {} pixel(s) are not finite (NaN or infinite)",
                out.non_finite_pixels
            );
        }
        let names = source_names(&l.scene, selection.as_ref(), c.sources.len());
        if let (Some(dir), Some(set)) = (&a.sib_images, &out.samples) {
            write_sib_images(dir, set, &names)?;
        }
        let sampling = match sampler {
            Sampler::Adaptive => format!(
                "adaptive to level {}, SIB {}",
                refine.max_level,
                if refine.sib { "on" } else { "off" }
            ),
            Sampler::Uniform => format!("{} spp", settings.spp),
        };
        if !a.quiet {
            eprintln!(
                "radtrace: {} view {} {}x{} {}, {} method: {:.2} s, {} samples, {} shadow rays ({} saved by the SIB), {} diffuse hits ({:.1} per hit) -> {}",
                l.scene.path.display(),
                a.view,
                settings.width,
                settings.height,
                sampling,
                a.method.name(),
                total.elapsed().as_secs_f64(),
                c.primary_rays,
                c.shadow_rays,
                c.shadow_rays_saved,
                c.diffuse_hits,
                c.rays_per_hit(),
                a.output.display()
            );
        }
        if a.stats_table {
            let title = format!(
                "{}, view {}, {}x{}, {}",
                l.scene.path.display(),
                a.view,
                settings.width,
                settings.height,
                sampling
            );
            print!(
                "{}",
                crate::stats::table1(&title, &a.method.name(), c, &names, baseline.as_ref())
            );
            if !out.levels.is_empty() {
                let rows: Vec<Vec<String>> = crate::stats::table2_rows(&out.levels)
                    .into_iter()
                    .map(|r| r.to_vec())
                    .collect();
                println!();
                print!(
                    "{}",
                    crate::stats::format_table(
                        &format!("Table 2. Shadow image buffer per level: {title}"),
                        &TABLE2_HEADERS[1..],
                        &rows
                    )
                );
            }
        }
        if let Some(path) = &a.stats {
            let doc = render_json(
                &l,
                &settings,
                &out,
                selection.as_ref(),
                &select_settings,
                &names,
                threads,
                json!(t.to_json(total.elapsed().as_secs_f64())),
            );
            write_json(path, &doc)?;
        }
        Ok(())
    })
}

const TABLE2_HEADERS: [&str; 7] = [
    "Figure",
    "Level",
    "No. of diffuse hits",
    "No. of shadow rays",
    "No. of shadow rays saved",
    "% Shadow rays saved",
    "% Shadow rays saved cumulatively",
];

/// One of the four renders of a view in `radtrace tables`.
struct Run {
    /// Short name (file names, JSON keys).
    key: &'static str,
    method: Method,
    sib: bool,
}

const RUNS: [Run; 4] = [
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

fn cmd_tables(a: TablesArgs) -> Result<()> {
    let total = Instant::now();
    let select_settings = a.select.settings(a.image.area_samples)?;
    a.refine.refine(false, 0.0)?;
    with_threads(a.image.threads, |threads| {
        let mut t = Timings::default();
        let l = load_all(
            &a.scene,
            a.solution.as_deref(),
            Some((&a.solve, a.image.seed)),
            a.quiet,
            &mut t,
        )?;
        let views: Vec<usize> = if a.views.is_empty() {
            (0..l.scene.sensors.len()).collect()
        } else {
            a.views.clone()
        };
        if views.is_empty() {
            return Err(Error::Usage(format!(
                "{}: the scene has no view (sensor)",
                l.scene.path.display()
            )));
        }
        if let Some(dir) = &a.output {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let letter = |v: usize| char::from(b'a' + (v % 26) as u8);
        let mut results = Vec::new();
        for &view in &views {
            let mut runs: Vec<(render::Output, f32)> = Vec::new();
            for run in &RUNS {
                let refine = a.refine.refine(run.sib, 0.0)?;
                let settings =
                    a.image
                        .settings(&l.scene, view, run.method, Sampler::Adaptive, None, refine)?;
                if !a.quiet {
                    eprintln!("radtrace: view {view} ({}): {}", letter(view), run.key);
                }
                let mut rt = Timings::default();
                let (out, selection) = render_view(&l, &settings, &select_settings, a.quiet, &mut rt)?;
                let flip = match runs.first() {
                    Some((full, _)) => crate::compare::compare(&full.image, &out.image, false)?.0.flip,
                    None => 0.0,
                };
                if let Some(dir) = &a.output {
                    let stem = format!("view{view}-{}", run.key);
                    crate::io::write_image(&out.image, &dir.join(format!("{stem}.exr")), 0.0)?;
                    let names = source_names(&l.scene, selection.as_ref(), out.counters.sources.len());
                    let doc = render_json(
                        &l,
                        &settings,
                        &out,
                        selection.as_ref(),
                        &select_settings,
                        &names,
                        threads,
                        json!(rt.to_json(rt.get("render").unwrap_or(0.0))),
                    );
                    write_json(&dir.join(format!("{stem}.json")), &doc)?;
                }
                runs.push((out, flip));
            }
            results.push((view, runs));
        }
        let saved = |rays: u64, base: u64| crate::stats::percent_saved(rays, base);
        if a.json {
            let doc: Vec<serde_json::Value> = results
                .iter()
                .map(|(view, runs)| {
                    let base = runs[0].0.counters.shadow_rays;
                    let mut v = json!({ "view": view });
                    for (run, (out, flip)) in RUNS.iter().zip(runs) {
                        let c = &out.counters;
                        v[run.key] = json!({
                            "diffuse_hits": c.diffuse_hits,
                            "shadow_rays": c.shadow_rays,
                            "shadow_rays_per_hit": c.rays_per_hit(),
                            "shadow_rays_saved_percent": saved(c.shadow_rays, base),
                            "flip_vs_norm": flip,
                            "levels": out.levels,
                        });
                    }
                    v
                })
                .collect();
            println!(
                "{}",
                serde_json::to_string_pretty(&json!({
                    "scene": l.scene.path,
                    "views": doc,
                    "time_s": total.elapsed().as_secs_f64(),
                }))
                .expect("json")
            );
            return Ok(());
        }
        let mut t1 = Vec::new();
        let mut t2 = Vec::new();
        let mut t3 = Vec::new();
        for (view, runs) in &results {
            let fig = letter(*view);
            let base = runs[0].0.counters.shadow_rays;
            // A row of Tables 1 and 3: run `k` against the fully sampled run 0.
            let row = |label: String, k: usize| {
                let c = &runs[k].0.counters;
                vec![
                    label,
                    c.diffuse_hits.to_string(),
                    c.shadow_rays.to_string(),
                    format!("{:.1}", c.rays_per_hit()),
                    format!("{:.0}", saved(c.shadow_rays, base)),
                    format!("{:.4}", runs[k].1),
                ]
            };
            t1.push(row(format!("{fig} fully sampled"), 0));
            t1.push(row(format!("{fig} local"), 1));
            for r in crate::stats::table2_rows(&runs[2].0.levels) {
                let mut row = vec![format!("{fig} SIB")];
                row.extend(r);
                t2.push(row);
            }
            let c = &runs[2].0.counters;
            t2.push(vec![
                format!("{fig} SIB"),
                "all".into(),
                c.diffuse_hits.to_string(),
                c.shadow_rays.to_string(),
                c.shadow_rays_saved.to_string(),
                String::new(),
                format!("{:.0}", saved(c.shadow_rays, base)),
            ]);
            t3.push(row(format!("{fig} fully sampled"), 0));
            t3.push(row(format!("{fig} local and SIB"), 3));
        }
        let sizes: Vec<String> = results
            .iter()
            .map(|(v, runs)| {
                let img = &runs[0].0.image;
                format!("view {v} = {}: {}x{}", letter(*v), img.width, img.height)
            })
            .collect();
        println!(
            "{} (adaptive to level {}, contrast {}, seed {}; {})\n",
            l.scene.path.display(),
            a.refine.max_level,
            a.refine.contrast,
            a.image.seed,
            sizes.join(", ")
        );
        print!(
            "{}",
            crate::stats::format_table(
                "Table 1. Results for norm and local selection pictures",
                &[
                    "Figure",
                    "No. of diffuse hits",
                    "No. of shadow rays",
                    "Shadow rays per hit",
                    "% Shadow rays saved",
                    "FLIP vs fully sampled"
                ],
                &t1
            )
        );
        println!();
        print!("{}", crate::stats::format_table("Table 2. Shadow image buffer results (norm with SIB; 'all': saved against the fully sampled picture)", &TABLE2_HEADERS, &t2));
        println!();
        print!(
            "{}",
            crate::stats::format_table(
                "Table 3. Combined local selection and shadow image buffer results",
                &[
                    "Figure",
                    "No. of diffuse hits",
                    "No. of shadow rays",
                    "No. of shadow rays per hit",
                    "% Shadow rays saved",
                    "FLIP vs fully sampled"
                ],
                &t3
            )
        );
        let sib_flips: Vec<String> = results
            .iter()
            .map(|(v, runs)| format!("{}: {:.4}", letter(*v), runs[2].1))
            .collect();
        println!(
            "\nFLIP of norm with SIB vs fully sampled: {}",
            sib_flips.join(", ")
        );
        if !a.quiet {
            eprintln!("radtrace: tables in {:.1} s", total.elapsed().as_secs_f64());
        }
        Ok(())
    })
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

/// Reads the baseline of `--baseline`: a `--stats` file.
fn read_baseline(path: &Path) -> Result<crate::stats::Baseline> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        Error::input(
            path,
            Some(crate::error::Pos {
                line: e.line() as u32,
                col: e.column() as u32,
            }),
            format!("not a JSON statistics file: {e}"),
        )
    })?;
    let get = |k: &str| {
        v.get(k)
            .and_then(|x| x.as_u64())
            .ok_or_else(|| Error::input(path, None, format!("no '{k}' count: not a radtrace --stats file")))
    };
    Ok(crate::stats::Baseline {
        method: v
            .get("method")
            .and_then(|m| m.as_str())
            .unwrap_or("baseline")
            .to_string(),
        diffuse_hits: get("diffuse_hits")?,
        shadow_rays: get("shadow_rays")?,
    })
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

fn cmd_solve(a: SolveCmdArgs) -> Result<()> {
    let total = Instant::now();
    with_threads(a.threads, |_| {
        let mut t = Timings::default();
        let scene = t.time("load", || load_scene(&a.scene, a.quiet))?;
        let st = a.solve.settings(&scene, a.seed)?;
        let bvh = t.time("accel", || Bvh::build(&scene));
        let sol = t.time("solve", || run_solve(&scene, &bvh, &st, a.quiet));
        t.time("output", || solution::save(&sol, &scene, &a.output))?;
        if let Some(path) = &a.stats {
            let doc = json!({
                "scene": scene.path,
                "solve": solve_json(&sol),
                "time_s": t.to_json(total.elapsed().as_secs_f64()),
            });
            crate::io::write_atomic(
                path,
                (serde_json::to_string_pretty(&doc).expect("json") + "\n").as_bytes(),
            )?;
        }
        if !a.quiet {
            eprintln!("radtrace: solution -> {}", a.output.display());
        }
        Ok(())
    })
}

fn cmd_info(a: InfoArgs) -> Result<()> {
    let scene = load_scene(&a.scene, false)?;
    let tris: usize = scene.shapes.iter().map(|s| s.mesh.triangle_count()).sum();
    let patches: usize = scene.shapes.iter().map(|s| s.mesh.patches.len()).sum();
    println!("scene    {}", scene.path.display());
    println!(
        "shapes   {} ({} triangles, {} patches)",
        scene.shapes.len(),
        tris,
        patches
    );
    for (i, s) in scene.shapes.iter().enumerate() {
        let b = &scene.bsdfs[s.bsdf as usize];
        println!(
            "  [{i}] {:<32} {:>8} tris {:>6} patches  bsdf {}{}",
            s.name,
            s.mesh.triangle_count(),
            s.mesh.patches.len(),
            b.name,
            if s.emitter.is_some() { "  (emitter)" } else { "" }
        );
    }
    println!("lights   {}", scene.lights.len());
    for (i, l) in scene.lights.iter().enumerate() {
        match l {
            Light::Point { position, intensity } => {
                println!("  [{i}] point at {position:.3} intensity {intensity:.3}")
            }
            Light::Spot { position, direction, intensity, cutoff_angle, .. } => println!(
                "  [{i}] spot at {position:.3} towards {direction:.3} intensity {intensity:.3} cutoff {:.1} deg",
                cutoff_angle.to_degrees()
            ),
            Light::Area { shape, radiance } => println!(
                "  [{i}] area on '{}' (area {:.4}) radiance {radiance:.3}",
                scene.shapes[*shape as usize].name,
                scene.shapes[*shape as usize].mesh.area()
            ),
        }
    }
    println!("views    {}", scene.sensors.len());
    for (i, s) in scene.sensors.iter().enumerate() {
        let o = s.to_world.transform_point3(glam::Vec3::ZERO);
        let d = s.to_world.transform_vector3(glam::Vec3::Z);
        println!(
            "  [{i}] {}x{} fov {:.1} ({:?}) from {o:.3} looking {d:.3}{}",
            s.width,
            s.height,
            s.fov,
            s.fov_axis,
            s.spp.map(|n| format!(", {n} spp")).unwrap_or_default()
        );
    }
    Ok(())
}

fn cmd_tessellate(a: TessellateArgs) -> Result<()> {
    check_output_ext(&a.output, &["obj"])?;
    let patches = crate::geometry::bezier::read_bpt(&a.input)?;
    let tris = crate::geometry::bezier::tessellated_triangles(patches.len(), a.coarse, a.fine);
    if tris > crate::geometry::bezier::MAX_TESSELLATED_TRIANGLES {
        return Err(Error::Usage(format!(
            "--coarse {} --fine {}: {} patches would make {tris} triangles (at most {})",
            a.coarse,
            a.fine,
            patches.len(),
            crate::geometry::bezier::MAX_TESSELLATED_TRIANGLES
        )));
    }
    let mesh = crate::geometry::bezier::tessellate(&patches, a.coarse, a.fine);
    crate::io::write_obj(&mesh, &a.output)?;
    eprintln!(
        "radtrace: {} Bezier patches -> {} triangles, {} vertices -> {}",
        patches.len(),
        mesh.triangle_count(),
        mesh.positions.len(),
        a.output.display()
    );
    Ok(())
}

fn cmd_compare(a: CompareArgs) -> Result<()> {
    let c = crate::compare::compare_files(&a.reference, &a.test, a.error_map.as_deref())?;
    if a.json {
        println!(
            "{}",
            json!({ "reference": a.reference, "test": a.test, "flip": c.flip, "rmse": c.rmse })
        );
    } else {
        println!("mean FLIP {:.4}  RMSE {:.5}", c.flip, c.rmse);
    }
    Ok(())
}

fn cmd_bench(a: BenchArgs) -> Result<()> {
    with_threads(a.threads, |threads| {
        let scene = load_scene(&a.scene, a.quiet)?;
        let sensor = scene.sensor(a.view)?;
        let plan = crate::experiments::bench::Plan {
            options: crate::experiments::bench::Options {
                view: a.view,
                width: a.width.unwrap_or(sensor.width),
                height: a.height.unwrap_or(sensor.height),
                shadow_per_hit: a.shadow_rays,
                bounce_per_hit: a.bounce_rays,
                seed: a.seed,
            },
            repeats: a.repeats,
            solve: (!a.no_solve)
                .then(|| a.solve.settings(&scene, a.seed))
                .transpose()?,
            solve_scaling: a.solve_scaling,
            dump: a.dump.clone(),
        };
        let report = crate::experiments::bench::run(&scene, &plan, threads)?;
        if a.json {
            println!(
                "{}",
                serde_json::to_string_pretty(&report).expect("report serialises")
            );
        } else {
            print!("{}", crate::experiments::bench::table(&report));
        }
        Ok(())
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
