//! The `radtrace` command line.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;

use crate::accel::Bvh;
use crate::render::{self, Filter, Method, Settings};
use crate::scene::{xml, Light, Scene};
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
    /// Print what a scene contains (shapes, lights, views).
    Info(InfoArgs),
    /// Write a Bezier patch file (.bpt) as a triangle mesh (.obj), e.g. for Mitsuba.
    Tessellate(TessellateArgs),
    /// Compare two images: mean FLIP and RMSE.
    Compare(CompareArgs),
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

/// `radtrace render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output image: .exr (linear radiance) or .png (8-bit sRGB).
    #[arg(short, long)]
    output: PathBuf,
    /// How direct light is computed.
    #[arg(long, value_enum, default_value_t = Method::Direct)]
    method: Method,
    /// Which view (sensor) of the scene, from 0.
    #[arg(long, default_value_t = 0)]
    view: usize,
    /// Samples per pixel [default: the scene's sampler, else 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp: Option<u32>,
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
    /// Shadow rays per area light at each diffuse hit.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    area_samples: u32,
    /// Maximum number of mirror reflections followed.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(0..=64))]
    max_depth: u32,
    /// Pixel reconstruction filter.
    #[arg(long, value_enum, default_value_t = Filter::Gaussian)]
    filter: Filter,
    /// Exposure in stops applied to PNG output (EXR is always written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Write statistics (rays, hits, timings) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    stats: Option<PathBuf>,
    /// No progress bar and no warnings on stderr.
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

fn parse_define(s: &str) -> std::result::Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE, got '{s}'")),
    }
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
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
        Command::Info(a) => cmd_info(a),
        Command::Tessellate(a) => cmd_tessellate(a),
        Command::Compare(a) => cmd_compare(a),
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

fn progress_bar(len: u64, label: &str, quiet: bool) -> ProgressBar {
    let pb = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr())
    };
    pb.set_style(
        ProgressStyle::with_template("{prefix:>8} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    pb.set_prefix(label.to_string());
    pb
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    let total = Instant::now();
    check_output_ext(&a.output, &["exr", "png"])?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0) as usize)
        .build()
        .map_err(|e| Error::Usage(format!("cannot start worker threads: {e}")))?;
    let threads = pool.current_num_threads();
    pool.install(|| {
        let mut t = Timings::default();
        let scene = t.time("load", || load_scene(&a.scene, a.quiet))?;
        let sensor = scene.sensors.get(a.view).ok_or_else(|| {
            Error::Usage(format!(
                "--view {}: {} has {} view(s), numbered from 0",
                a.view,
                scene.path.display(),
                scene.sensors.len()
            ))
        })?;
        let settings = Settings {
            method: a.method,
            view: a.view,
            width: a.width.unwrap_or(sensor.width),
            height: a.height.unwrap_or(sensor.height),
            spp: a.spp.or(sensor.spp).unwrap_or(16).clamp(1, 65536),
            seed: a.seed,
            area_samples: a.area_samples,
            max_depth: a.max_depth,
            filter: a.filter,
        };
        let bvh = t.time("accel", || Bvh::build(&scene));
        if bvh.skipped > 0 && !a.quiet {
            eprintln!("radtrace: warning: {} degenerate triangle(s) ignored", bvh.skipped);
        }
        let pb = progress_bar(settings.height as u64, "render", a.quiet);
        let out = render::render(&scene, &bvh, &settings, Some(&pb))?;
        pb.finish_and_clear();
        t.add("render", out.trace_s);
        t.add("reconstruct", out.reconstruct_s);
        t.time("output", || crate::io::write_image(&out.image, &a.output, a.exposure))?;
        let c = out.counters;
        if !a.quiet {
            eprintln!(
                "radtrace: {} view {} {}x{} {} spp, {} method: {:.2} s, {} shadow rays, {} diffuse hits -> {}",
                scene.path.display(),
                a.view,
                settings.width,
                settings.height,
                settings.spp,
                a.method.name(),
                total.elapsed().as_secs_f64(),
                c.shadow_rays,
                c.diffuse_hits,
                a.output.display()
            );
        }
        if let Some(path) = &a.stats {
            let per_hit = if c.diffuse_hits > 0 { c.shadow_rays as f64 / c.diffuse_hits as f64 } else { 0.0 };
            let doc = json!({
                "scene": scene.path,
                "view": a.view,
                "method": a.method,
                "width": settings.width,
                "height": settings.height,
                "spp": settings.spp,
                "seed": settings.seed,
                "area_samples": settings.area_samples,
                "max_depth": settings.max_depth,
                "filter": settings.filter,
                "threads": threads,
                "triangles": bvh.triangle_count(),
                "lights": scene.lights.len(),
                "primary_rays": c.primary_rays,
                "shadow_rays": c.shadow_rays,
                "diffuse_hits": c.diffuse_hits,
                "reflection_rays": c.reflection_rays,
                "shadow_rays_per_hit": per_hit,
                "time_s": t.to_json(total.elapsed().as_secs_f64()),
            });
            let text = serde_json::to_string_pretty(&doc).expect("stats serialise") + "\n";
            crate::io::write_atomic(path, text.as_bytes())?;
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
    let mesh = crate::geometry::bezier::tessellate(&patches, a.coarse, a.fine);
    crate::geometry::meshfile::write_obj(&mesh, &a.output)?;
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
