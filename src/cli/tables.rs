//! `radtrace tables`.

use std::time::Instant;

use serde_json::json;

use super::args::TablesArgs;
use super::render::TABLE2_HEADERS;
use super::{load_all, render_json, render_view, source_names, with_threads, write_json};
use crate::render::{self, Method, Sampler};
use crate::stats::Timings;
use crate::{Error, Result};

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

pub(super) fn cmd_tables(a: TablesArgs) -> Result<()> {
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
