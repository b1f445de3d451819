//! `radtrace solve`.

use std::time::Instant;

use serde_json::json;

use super::args::SolveCmdArgs;
use super::{load_scene, run_solve, solve_json, with_threads};
use crate::accel::Bvh;
use crate::io::solution;
use crate::stats::Timings;
use crate::Result;

pub(super) fn cmd_solve(a: SolveCmdArgs) -> Result<()> {
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
