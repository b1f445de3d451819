//! `radtrace bench`.

use super::args::BenchArgs;
use super::{load_scene, with_threads};
use crate::Result;

pub(super) fn cmd_bench(a: BenchArgs) -> Result<()> {
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
                .then(|| {
                    a.solve
                        .settings(&scene, &crate::accel::Bvh::build(&scene), a.seed, false)
                })
                .transpose()?,
            solve_scaling: a.solve_scaling,
            dump: a.dump.clone(),
        };
        let report = crate::experiments::bench::run(&scene, &plan, threads)?;
        if a.json {
            say!(
                "{}",
                serde_json::to_string_pretty(&report).expect("report serialises")
            );
        } else {
            print!("{}", crate::experiments::bench::table(&report));
        }
        Ok(())
    })
}
