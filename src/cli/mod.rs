//! The `radtrace` command line: [`args`] defines the flags, one module per command
//! runs it; this module holds what the commands share (scene loading, progress bars,
//! the statistics JSON).

/// `println!` for the commands' output: a reader that stops reading (`radtrace info
/// scene.xml | head`) ends the process quietly, as it would a C tool, instead of a
/// panic; any other failure to write is one line and exit code 1.
macro_rules! say {
    () => {
        $crate::cli::say(format_args!(""))
    };
    ($($t:tt)*) => {
        $crate::cli::say(format_args!($($t)*))
    };
}

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

use crate::accel::Bvh;
use crate::io::solution;
use crate::progress::Progress;
use crate::radiosity::{self, Solution, SolveSettings};
use crate::render::{Method, Settings};
use crate::scene::{xml, Scene};
use crate::selection::{SelectSettings, Selection};
use crate::stats::Timings;
use crate::{Error, Result};

pub use args::*;

/// Writes one line of the commands' output to standard output (see `say!`).
pub(crate) fn say(args: std::fmt::Arguments) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.write_all(b"\n")) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            // 141 = 128 + SIGPIPE, what a shell reports for a tool the pipe ended.
            crate::io::exit_after_writes(141)
        }
        eprintln!("radtrace: error: writing to standard output: {e}");
        crate::io::exit_after_writes(1)
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
        for n in &loaded.notes {
            eprintln!("radtrace: note: {n}");
        }
        for w in collapse_warnings(&loaded.warnings) {
            eprintln!("radtrace: warning: {w}");
        }
    }
    Ok(loaded.scene)
}

/// The warnings to print: of warnings that say the same thing at different places
/// (`FILE:LINE:COL: message`), the first [`SAME_WARNINGS`], then one line counting the
/// rest (a scene of 700 meshes with one unknown parameter each would bury the others).
fn collapse_warnings(warnings: &[String]) -> Vec<String> {
    const SAME_WARNINGS: usize = 3;
    let what = |w: &str| w.split_once(": ").map_or(w, |(_, m)| m).to_string();
    let mut count: std::collections::HashMap<String, usize> = Default::default();
    for w in warnings {
        *count.entry(what(w)).or_default() += 1;
    }
    let mut shown: std::collections::HashMap<String, usize> = Default::default();
    let mut out = Vec::new();
    for w in warnings {
        let key = what(w);
        let k = shown.entry(key.clone()).or_default();
        *k += 1;
        if *k <= SAME_WARNINGS {
            out.push(w.clone());
        }
        if *k == SAME_WARNINGS && count[&key] > SAME_WARNINGS {
            out.push(format!(
                "... and {} more of the same: {key}",
                count[&key] - SAME_WARNINGS
            ));
        }
    }
    out
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

/// Loads the scene, builds the BVH (for a render of `pixels(scene)` pixels, if
/// known: [`Bvh::build_for`]), and loads or computes the solution if `solve` (its
/// flags, its seed, and whether a final gather will read it).
fn load_all(
    scene: &SceneArgs,
    solution: Option<&Path>,
    solve: Option<(&SolveArgs, u64, bool)>,
    pixels: impl Fn(&Scene) -> Option<u64>,
    quiet: bool,
    t: &mut Timings,
) -> Result<Loaded> {
    let scene = t.time("load", || load_scene(scene, quiet))?;
    let bvh = t.time("accel", || Bvh::build_for(&scene, pixels(&scene)));
    if bvh.skipped > 0 && !quiet {
        eprintln!(
            "radtrace: warning: {} degenerate triangle(s) ignored",
            bvh.skipped
        );
    }
    let solution = match (solve, solution) {
        (None, _) => None,
        (Some(_), Some(path)) => Some(t.time("load_solution", || solution::load(path, &scene, &bvh))?),
        (Some((args, seed, gathered)), None) => {
            let st = args.settings(&scene, &bvh, seed, gathered)?;
            Some(t.time("solve", || run_solve(&scene, &bvh, &st, quiet))?)
        }
    };
    Ok(Loaded { scene, bvh, solution })
}

/// Selects the sources for `settings.method` (with the view's camera) and renders.
fn render_view<'a>(
    l: &'a Loaded,
    settings: &Settings,
    select: &SelectSettings,
    steps: Option<crate::experiments::StepSink>,
    quiet: bool,
    t: &mut Timings,
) -> Result<(crate::render::Output, Option<Selection<'a>>)> {
    let mut selected = |sel: &Selection| {
        if !quiet && settings.method == Method::Local {
            print_selection_summary(sel);
        }
    };
    crate::experiments::select_and_render(
        &l.scene,
        &l.bvh,
        l.solution.as_ref(),
        settings,
        select,
        &mut selected,
        steps,
        &Bars::new(quiet),
        t,
    )
}

/// Writes a statistics document (see [`crate::stats::to_json_text`]).
fn write_json(path: &Path, doc: &impl serde::Serialize) -> Result<()> {
    crate::io::write_atomic(path, crate::stats::to_json_text(doc).as_bytes())
}

/// The one line on the local selection's criteria.
fn print_selection_summary(sel: &Selection) {
    let r = crate::stats::Criteria::of(sel);
    let by = &r.rejected_by;
    eprintln!(
        "radtrace: local selection: {} of {} listed (patch, source) pairs ray traced; turned down by radiance {}, reflectivity {}, gradient {}, solid angle {}, view {}",
        sel.pick_count(),
        r.listed,
        by.radiance,
        by.reflectivity,
        by.gradient,
        by.solid_angle,
        by.view
    );
}

/// Runs pass 1 with a progress bar.
fn run_solve(scene: &Scene, bvh: &Bvh, st: &SolveSettings, quiet: bool) -> Result<Solution> {
    let sol = radiosity::solve(scene, bvh, st, &Bars::new(quiet))?;
    if !quiet {
        let s = &sol.stats;
        eprintln!(
            "radtrace: solved: {} patches{}, {} elements, {} vertices (mesh size {:.4}); {} light + {} patch shots ({} reusing their first), {} rays, {:.2}% left to {} photons ({} rays); {:.2} s{}",
            s.patches,
            match s.refined_patches {
                0 => String::new(),
                n => format!(" ({n} meshed finer: holding an object or near a small light)"),
            },
            s.elements,
            s.vertices,
            st.mesh_size,
            s.light_shots,
            s.patch_shots,
            s.reused_shots,
            s.rays,
            100.0 * s.residual,
            s.photons,
            s.photon_rays,
            s.time_s,
            if s.timed_out {
                " (cut short by --solve-time)"
            } else {
                ""
            },
        );
    }
    Ok(sol)
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

#[cfg(test)]
mod tests {
    use super::collapse_warnings;

    /// Of warnings saying the same thing at many places, three are shown and one line
    /// counts the rest; different warnings all stay, in order.
    #[test]
    fn warnings_repeated_over_many_places_are_counted_not_repeated() {
        let mut w: Vec<String> = (1..=700)
            .map(|k| format!("s.xml:{k}:3: unknown parameter 'x' of shape 'obj' ignored"))
            .collect();
        w.insert(1, "s.xml:2:1: texture 'bitmap' is not supported".into());
        w.push("m.xml: the scene has no shapes".into());
        let out = collapse_warnings(&w);
        assert_eq!(out.len(), 6, "{out:?}");
        assert!(out[1].contains("bitmap"));
        assert_eq!(
            out[4],
            "... and 697 more of the same: unknown parameter 'x' of shape 'obj' ignored"
        );
        assert_eq!(out[5], "m.xml: the scene has no shapes");
        assert_eq!(collapse_warnings(&w[..3]), w[..3].to_vec());
    }
}
