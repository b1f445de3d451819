//! `radtrace render`.

use std::path::Path;
use std::time::Instant;

use super::args::{OnOff, RenderArgs};
use super::{check_output_ext, load_all, render_view, with_threads, write_json};
use crate::io::display::Display;
use crate::render::{self, Method, Sampler};
use crate::stats::{source_names, RenderContext, RenderStats, Timings};
use crate::{Error, Result};

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

pub(super) fn cmd_render(a: RenderArgs) -> Result<()> {
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
    if a.progressive && a.method == Method::Direct {
        return Err(Error::Usage(
            "--progressive shows the radiosity solution first and then ray traces the sources into it; --method direct has no solution: use another method or drop --progressive".into(),
        ));
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
    let refine = a
        .refine
        .refine(sib, a.retexture == OnOff::On, a.exposure, a.solve.quality)?;
    let select_settings = a.select.settings(a.image.area_samples)?;
    let baseline = a.baseline.as_deref().map(read_baseline).transpose()?;
    with_threads(a.image.threads, |threads| {
        let mut t = Timings::default();
        let gathered = a.image.gather(a.solve.quality, a.method) > 0;
        let solve = (a.method != Method::Direct).then_some((&a.solve, a.image.seed, gathered));
        // The BVH's build follows the image size the render's settings will have.
        let pixels = |scene: &crate::scene::Scene| {
            let s = a.settings(scene, sampler, refine).ok()?;
            Some(u64::from(s.width) * u64::from(s.height))
        };
        let l = load_all(&a.scene, a.solution.as_deref(), solve, pixels, a.quiet, &mut t)?;
        let settings = a.settings(&l.scene, sampler, refine)?;
        let mut display = match &a.display_server {
            Some(addr) => Some(Display::connect(
                addr,
                &a.output.display().to_string(),
                settings.width,
                settings.height,
            )?),
            None => None,
        };
        // The progressive display's steps: each image replaces the last (atomically).
        let mut step = 0;
        let mut write_step = |label: &str, out: &render::Output| -> Result<()> {
            step += 1;
            crate::io::write_image(&out.image, &a.output, a.exposure)?;
            show(&mut display, &out.image, a.quiet);
            if !a.quiet {
                eprintln!(
                    "radtrace: step {step}, {label}: {:.2} s -> {}",
                    total.elapsed().as_secs_f64(),
                    a.output.display()
                );
            }
            Ok(())
        };
        let steps = a
            .progressive
            .then_some(&mut write_step as crate::experiments::StepSink);
        let (out, selection) = render_view(&l, &settings, &select_settings, steps, a.quiet, &mut t)?;
        show(&mut display, &out.image, a.quiet);
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
        if !a.quiet {
            let camera = crate::camera::Camera::new(l.scene.sensor(a.view)?, settings.width, settings.height);
            if let Some(why) = render::black::why_black(&out.image, &l.scene, &l.bvh, &camera) {
                eprintln!("radtrace: warning: {}: {why}", a.output.display());
            }
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
                crate::stats::table1(&title, a.method.name(), c, &names, baseline.as_ref())
            );
            if !out.levels.is_empty() {
                let rows: Vec<Vec<String>> = crate::stats::table2_rows(&out.levels)
                    .into_iter()
                    .map(|r| r.to_vec())
                    .collect();
                say!();
                print!(
                    "{}",
                    crate::stats::format_table(
                        &format!("Table 2. Shadow image buffer per level: {title}"),
                        &crate::stats::TABLE2_HEADERS[1..],
                        &rows
                    )
                );
            }
        }
        if let Some(path) = &a.stats {
            let ctx = RenderContext {
                scene: &l.scene,
                triangles: l.bvh.triangle_count(),
                solution: l.solution.as_ref(),
                threads,
            };
            let doc = RenderStats::new(
                &ctx,
                &settings,
                &out,
                selection.as_ref(),
                &select_settings,
                &names,
                t.to_json(total.elapsed().as_secs_f64()),
            );
            write_json(path, &doc)?;
        }
        Ok(())
    })
}

/// Sends `image` to the display server, if any; a display that stopped listening is
/// dropped with one warning (the render and its files go on).
fn show(display: &mut Option<Display>, image: &crate::image::Image, quiet: bool) {
    if let Some(d) = display {
        if let Err(e) = d.update(image) {
            if !quiet {
                eprintln!("radtrace: warning: --display-server: {e}; no more updates sent");
            }
            *display = None;
        }
    }
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
