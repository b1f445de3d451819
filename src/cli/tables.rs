//! `radtrace tables`: runs [`crate::experiments::tables`] and prints its rows.

use std::path::PathBuf;
use std::time::Instant;

use super::args::TablesArgs;
use super::{load_all, print_selection_summary, with_threads, write_json, Bars};
use crate::experiments::tables::{
    self, letter, Observer, Run, RunDone, Table1Row, Tables, TablesJson, TablesPlan,
};
use crate::render::Method;
use crate::selection::Selection;
use crate::stats::{format_table, Timings, TABLE2_HEADERS};
use crate::{Error, Result};

/// Prints what runs (unless quiet) and writes each picture and its statistics to
/// `--output`.
struct Cli {
    quiet: bool,
    output: Option<PathBuf>,
}

impl Observer for Cli {
    fn starting(&mut self, view: usize, run: &Run) {
        if !self.quiet {
            eprintln!("radtrace: view {view} ({}): {}", letter(view), run.key);
        }
    }

    fn selected(&mut self, run: &Run, selection: &Selection) {
        if !self.quiet && run.method == Method::Local {
            print_selection_summary(selection);
        }
    }

    fn finished(&mut self, view: usize, run: &Run, done: &RunDone) -> Result<()> {
        if let Some(dir) = &self.output {
            let stem = format!("view{view}-{}", run.key);
            crate::io::write_image(&done.output.image, &dir.join(format!("{stem}.exr")), 0.0)?;
            write_json(&dir.join(format!("{stem}.json")), done.stats)?;
        }
        Ok(())
    }
}

pub(super) fn cmd_tables(a: TablesArgs) -> Result<()> {
    let total = Instant::now();
    let select = a.select.settings(a.image.area_samples)?;
    let refine = a.refine.refine(false, false, 0.0, a.solve.quality)?;
    // The paper's tables are of its method before the last step: a gather only when
    // asked for (and the solve shoots patches for it).
    let gather = a.image.gather.unwrap_or(0);
    with_threads(a.image.threads, |_| {
        let mut t = Timings::default();
        let l = load_all(
            &a.scene,
            a.solution.as_deref(),
            Some((&a.solve, a.image.seed, gather > 0)),
            // Several views and renders each: as many rays as may come.
            |_| None,
            a.quiet,
            &mut t,
        )?;
        let solution = l.solution.as_ref().expect("tables always solves");
        let plan = TablesPlan {
            views: a.views.clone(),
            width: a.image.width,
            height: a.image.height,
            seed: a.image.seed,
            area_samples: a.image.area_samples,
            max_depth: a.image.max_depth,
            gather,
            filter: (a.image.filter)
                .or_else(|| a.views.first().and_then(|&v| l.scene.sensors.get(v)?.filter))
                .unwrap_or_default(),
            max_level: refine.max_level,
            contrast: a.refine.contrast,
            select,
            keep_images: false,
        };
        // The scene has views (the same error as the run's, before the folder is made).
        plan.views(&l.scene)?;
        if let Some(dir) = &a.output {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let mut observer = Cli {
            quiet: a.quiet,
            output: a.output.clone(),
        };
        let result = tables::run(
            &l.scene,
            &l.bvh,
            solution,
            &plan,
            &Bars::new(a.quiet),
            &mut observer,
        )?;
        if a.json {
            let doc = TablesJson {
                scene: &result.scene,
                views: &result.views,
                time_s: total.elapsed().as_secs_f64(),
            };
            print!("{}", crate::stats::to_json_text(&doc));
            return Ok(());
        }
        print_tables(&result, &plan);
        if !a.quiet {
            eprintln!("radtrace: tables in {:.1} s", total.elapsed().as_secs_f64());
        }
        Ok(())
    })
}

/// A row of Table 1 or 3 as text.
fn table1_cells(r: &Table1Row) -> Vec<String> {
    vec![
        r.figure.clone(),
        r.diffuse_hits.to_string(),
        r.shadow_rays.to_string(),
        format!("{:.1}", r.shadow_rays_per_hit),
        format!("{:.0}", r.shadow_rays_saved_percent),
        format!("{:.4}", r.flip_vs_fully_sampled),
    ]
}

/// Prints the three tables and the FLIP of the SIB pictures.
fn print_tables(result: &Tables, plan: &TablesPlan) {
    let sizes: Vec<String> = result
        .views
        .iter()
        .map(|v| format!("view {} = {}: {}x{}", v.view, letter(v.view), v.width, v.height))
        .collect();
    say!(
        "{} (adaptive to level {}, contrast {}, seed {}; {})\n",
        result.scene.display(),
        plan.max_level,
        plan.contrast,
        plan.seed,
        sizes.join(", ")
    );
    let t1: Vec<Vec<String>> = result.table1.iter().map(table1_cells).collect();
    print!(
        "{}",
        format_table(
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
    say!();
    let t2: Vec<Vec<String>> = result
        .table2
        .iter()
        .map(|r| {
            vec![
                r.figure.clone(),
                r.level.map_or_else(|| "all".to_string(), |l| l.to_string()),
                r.diffuse_hits.to_string(),
                r.shadow_rays.to_string(),
                r.shadow_rays_saved.to_string(),
                r.saved_percent.map(|p| format!("{p:.0}")).unwrap_or_default(),
                format!("{:.0}", r.saved_cumulative_percent),
            ]
        })
        .collect();
    print!("{}", format_table("Table 2. Shadow image buffer results (norm with SIB; 'all': saved against the fully sampled picture)", &TABLE2_HEADERS, &t2));
    say!();
    let t3: Vec<Vec<String>> = result.table3.iter().map(table1_cells).collect();
    print!(
        "{}",
        format_table(
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
    let sib_flips: Vec<String> = result
        .views
        .iter()
        .map(|v| format!("{}: {:.4}", letter(v.view), v.norm_sib.flip_vs_norm))
        .collect();
    say!(
        "\nFLIP of norm with SIB vs fully sampled: {}",
        sib_flips.join(", ")
    );
}
