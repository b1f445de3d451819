//! `radtrace solve`.

use std::time::Instant;

use super::args::SolveCmdArgs;
use super::{load_scene, run_solve, with_threads, write_json};
use crate::accel::Bvh;
use crate::io::solution;
use crate::stats::{SolveFigures, SolveStatsFile, Timings};
use crate::Result;

pub(super) fn cmd_solve(a: SolveCmdArgs) -> Result<()> {
    let total = Instant::now();
    with_threads(a.threads, |_| {
        let mut t = Timings::default();
        let scene = t.time("load", || load_scene(&a.scene, a.quiet))?;
        let bvh = t.time("accel", || Bvh::build(&scene));
        // Renders read it through the quality level's gather unless told otherwise.
        let st = a
            .solve
            .settings(&scene, &bvh, a.seed, a.solve.quality.gather() > 0)?;
        let sol = t.time("solve", || run_solve(&scene, &bvh, &st, a.quiet))?;
        t.time("output", || solution::save(&sol, &scene, &a.output))?;
        if let Some(path) = &a.stats {
            let doc = SolveStatsFile {
                scene: scene.path.clone(),
                solve: SolveFigures::of(&sol),
                time_s: t.to_json(total.elapsed().as_secs_f64()),
            };
            write_json(path, &doc)?;
        }
        if !a.quiet {
            eprintln!("radtrace: solution -> {}", a.output.display());
        }
        Ok(())
    })
}
