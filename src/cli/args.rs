//! The command line's arguments (clap) and their conversion to the core's settings.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::radiosity::SolveSettings;
use crate::render::{Filter, Method, Refine, Sampler, Settings};
use crate::scene::Scene;
use crate::selection::{SelectPer, SelectSettings};
use crate::Result;

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
    /// Set a scene parameter declared with <default name=...> (repeatable; a name the
    /// scene does not declare is an error, as in Mitsuba 3).
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub defines: Vec<(String, String)>,
}

/// The quality dial: one flag that sets the effort of both passes. Each flag it sets
/// can still be given on its own, and then wins.
///
/// | level | `--shoot-samples` | `--solve-tolerance` | `--photons` | `--max-level` | `--gather` |
/// |---|---|---|---|---|---|
/// | draft | 32 | 0.03 | 16 | 1 | 0 |
/// | good | 64 | 0.01 | 64 | 2 | 128 |
/// | final | 128 | 0.005 | 256 | 3 | 1024 |
///
/// Chosen by measurement (README, "The quality dial"): `draft` is the quickest
/// picture, `good` gathers with half the rays of `final` and already passes Mitsuba
/// 3's 256-spp FLIP on the Cornell box and the paper room's view a, and its 64-spp
/// FLIP on the conference room.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Quality {
    /// The quickest picture: coarser shots, few photons, up to 4 samples per pixel.
    Draft,
    /// The default: the paper's last step with 128 gather rays.
    #[default]
    Good,
    /// The paper's last step with 1024 gather rays, finer shots carrying
    /// more of the light, 4x the photons, up to 64 samples per pixel.
    Final,
}

impl Quality {
    /// Most cells of a shooting source (`--shoot-samples`).
    pub fn shoot_samples(self) -> u32 {
        [32, 64, 128][self as usize]
    }

    /// Fraction of the lights' power the deterministic shots leave to the photons
    /// (`--solve-tolerance`). Photons leave their power on the vertices of the element
    /// they hit, an average over one element, so near a concave corner, where the light
    /// falls off, they overshoot: `final` leaves them half as much (Cornell box, the
    /// corners a few per cent bright: FLIP 0.0176 -> 0.0160 for 0.15 s; the paper room
    /// unchanged, 0.0272 -> 0.0273 and 0.0391 -> 0.0390; `good` is not better for it,
    /// 0.0244 -> 0.0251 on the Cornell box).
    ///
    /// `draft` stops its shots at 3 %: its FLIP has room to spare against Mitsuba's 64
    /// spp, its time little (whole process, against Mitsuba's 1024-spp references;
    /// 0.01 -> 0.03): paper room view b 3.51 s / 0.0453 -> 3.16 s / 0.0510, view a
    /// 2.33 s / 0.0410 -> 2.01 s / 0.0416, Cornell box 1.39 s / 0.0316 -> 1.41 s /
    /// 0.0349 (Mitsuba at 64 spp: 18.7 s / 0.0578, 15.3 s / 0.0558, 16.8 s / 0.0367).
    pub fn solve_tolerance(self) -> f32 {
        [0.03, 0.01, 0.005][self as usize]
    }

    /// Photons per mesh vertex (`--photons`).
    pub fn photons(self) -> u32 {
        [16, 64, 256][self as usize]
    }

    /// Highest level of the adaptive sampler (`--max-level`).
    pub fn max_level(self) -> u32 {
        [1, 2, 3][self as usize]
    }

    /// Final-gather rays (`--gather`).
    pub fn gather(self) -> u32 {
        // `final`: the Cornell box's record noise is most of what is left there
        // (0.0157 at 256 rays, 0.0149 at 512 against an 8192-spp reference, for
        // 0.45 s; the paper room 0.0274 -> 0.0272 for 1.2 s). 1024: against a single
        // 4096-spp reference, render seeds 0 and 1 give 0.0152 / 0.0148 at 512 rays,
        // 0.0148 / 0.0144 at 1024 (+0.5 s), 0.0145 / 0.0142 at 2048 (+4 s); two
        // seeds' images at 512 rays are 0.0113 apart, as far as two 4096-spp
        // references (0.0116). The paper room's view a: 0.0269 -> 0.0268, +3.4 s.
        [0, 128, 1024][self as usize]
    }

    /// The level's name, as on the command line.
    pub fn name(self) -> &'static str {
        ["draft", "good", "final"][self as usize]
    }
}

/// Settings of the radiosity pass (pass 1).
#[derive(Debug, Args)]
pub struct SolveArgs {
    /// Quality dial: `draft`, `good` or `final` set --shoot-samples (32/64/128),
    /// --solve-tolerance (0.03/0.01/0.005), --photons (16/64/256), --max-level (1/2/3)
    /// and --gather (0/128/1024) at once; any of those flags given on its own wins.
    /// (`radtrace solve` shoots patches as for that level's gather.)
    #[arg(long, value_enum, default_value_t = Quality::Good)]
    pub(super) quality: Quality,
    /// Largest radiosity element edge, in scene units [default: the bounding-box
    /// diagonal / 40 of the surfaces with diffuse reflectance].
    #[arg(long, value_name = "SIZE", allow_negative_numbers = true)]
    pub(super) mesh_size: Option<f32>,
    /// n: sources kept apart, per patch, from the general radiosity (lights are never
    /// evicted by radiant patches) [default: the number of lights, at least 4].
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub(super) sources_per_patch: Option<u32>,
    /// Most cells per area light or shooting patch in a shot (for a vertex that sees
    /// it under the whole hemisphere; fewer as it looks smaller) [default: by
    /// --quality, 64 for good].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub(super) shoot_samples: Option<u32>,
    /// Deterministic shots stop when the unshot power falls below this fraction of the
    /// power the lights brought to reflecting surfaces (of the emitted power, if
    /// less), or (with photons) when no patch holds this fraction [default: by
    /// --quality, 0.01 for good, 0.005 for final].
    #[arg(long, value_name = "FRACTION")]
    pub(super) solve_tolerance: Option<f32>,
    /// Deterministic patch shots at most.
    #[arg(long, default_value_t = 20000)]
    pub(super) max_shots: u32,
    /// Photons per mesh vertex, at most, that carry the light the deterministic shots
    /// leave unshot (0: none; the rest stays unshot); they stop sooner once their
    /// light has settled (two halves of them within 2 % of the light, on the mean
    /// over the surfaces) [default: by --quality, 64 for good].
    #[arg(long, value_name = "N")]
    pub(super) photons: Option<u32>,
    /// Photons from the patches at most, whatever --photons asks for a large mesh (0:
    /// no cap); in a scene with mirrors, the lights' photons aimed at them and the
    /// shots' come beside them (the lights' a sixteenth to four times as many, by the
    /// power the mirrors take), both together at most this many again.
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    pub(super) max_photons: u64,
    /// Time budget of the solve in seconds: deterministic shots stop at half of it,
    /// photons at all of it (the residual reached is reported) [default: none].
    #[arg(long, value_name = "SECONDS")]
    pub(super) solve_time: Option<f32>,
}

impl SolveArgs {
    /// The settings for `scene`; `gathered`: the solution will be read through a
    /// final gather.
    pub(super) fn settings(
        &self,
        scene: &Scene,
        accel: &dyn crate::accel::Accel,
        seed: u64,
        gathered: bool,
    ) -> Result<SolveSettings> {
        let mesh_size = self
            .mesh_size
            .unwrap_or_else(|| crate::mesh::default_mesh_size(scene, accel));
        let settings = SolveSettings {
            mesh_size,
            sources_per_patch: self
                .sources_per_patch
                .unwrap_or((scene.lights.len() as u32).clamp(4, 64)),
            shoot_samples: self.shoot_samples.unwrap_or(self.quality.shoot_samples()),
            tolerance: self.solve_tolerance.unwrap_or(self.quality.solve_tolerance()),
            max_shots: self.max_shots,
            seed,
            photons: self.photons.unwrap_or(self.quality.photons()),
            max_photons: self.max_photons,
            time_limit: self.solve_time.unwrap_or(0.0),
            gathered,
        };
        settings.validate()?;
        Ok(settings)
    }
}

/// Source selection (paper Sect. 3): thresholds of the five criteria, per patch or
/// per object, and the global selection's size.
#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Make the local selection per patch, or per object (shape) so that patch
    /// boundaries cannot show.
    #[arg(long, value_enum, default_value_t = SelectPer::Patch)]
    pub(super) select_per: SelectPer,
    /// Radiance criterion: a source must bring at least this fraction of a patch's
    /// radiosity (unoccluded, where largest) to be ray traced there.
    #[arg(long, default_value_t = SelectSettings::default().radiance_threshold, value_name = "FRACTION")]
    pub(super) radiance_threshold: f32,
    /// Reflectivity criterion: no shadow rays from patches whose diffuse reflectance
    /// (mean of RGB) is below this.
    #[arg(long, default_value_t = SelectSettings::default().reflectivity_threshold, value_name = "REFLECTANCE")]
    pub(super) reflectivity_threshold: f32,
    /// Gradient criterion: a source must be partly visible across a patch (its
    /// visibility at the patch's vertices spreading by more than this) to be ray traced.
    #[arg(long, default_value_t = SelectSettings::default().gradient_threshold, value_name = "FRACTION")]
    pub(super) gradient_threshold: f32,
    /// Solid-angle criterion: sources seen under a larger solid angle (steradians,
    /// mean over the patch) are left to the radiosity.
    #[arg(long, default_value_t = SelectSettings::default().max_solid_angle, value_name = "SR")]
    pub(super) max_solid_angle: f32,
    /// Shadow rays for a whole hemisphere: an area source seen under solid angle
    /// Omega gets max(1, round(Omega / 2pi x this)) rays, at most --area-samples.
    #[arg(long, default_value_t = SelectSettings::default().hemisphere_rays, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub(super) hemisphere_rays: u32,
    /// View criterion: patches whose mesh elements look smaller than this many
    /// pixels are left to the mesh.
    #[arg(long, default_value_t = SelectSettings::default().view_threshold, value_name = "PIXELS")]
    pub(super) view_threshold: f32,
    /// Do not apply the view criterion (animation: the selection must not depend on
    /// the camera).
    #[arg(long)]
    pub(super) no_view_criterion: bool,
    /// Sources ray traced everywhere by --method global.
    #[arg(long, default_value_t = SelectSettings::default().global_sources)]
    pub(super) global_sources: u32,
}

impl SelectArgs {
    pub(super) fn settings(&self, area_samples: u32) -> Result<SelectSettings> {
        let settings = SelectSettings {
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
        };
        settings.validate()?;
        Ok(settings)
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
    Tent => "Mitsuba's tent: 1 - |x| out to 1 px",
    Gaussian => "Mitsuba's Gaussian: stddev 0.5 px, radius 2 px",
    Mitchell => "Mitsuba's Mitchell-Netravali cubic (B = C = 1/3), radius 2 px",
    Catmullrom => "Mitsuba's Catmull-Rom cubic, radius 2 px",
    Lanczos => "Mitsuba's Lanczos sinc, 3 lobes",
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
    /// pixel (level -1: one per 2x2 pixels; level 0: one per pixel) [default: by
    /// --quality, 2 for good].
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=4))]
    pub(super) max_level: Option<u32>,
    /// Difference criterion: refine where neighbouring samples' display values
    /// (sRGB, 0..1, after --exposure) differ by more than this in a channel (through a
    /// `thinlens` sensor's lens: wherever they differ at all, since blur is noise).
    #[arg(long, default_value_t = 0.05, value_name = "DIFFERENCE")]
    pub(super) contrast: f32,
}

impl RefineArgs {
    pub(super) fn refine(
        &self,
        sib: bool,
        retexture: bool,
        exposure: f32,
        quality: Quality,
    ) -> Result<Refine> {
        let refine = Refine {
            max_level: self.max_level.unwrap_or(quality.max_level()),
            contrast: self.contrast,
            exposure,
            sib,
            retexture,
        };
        refine.validate()?;
        Ok(refine)
    }
}

/// `radtrace solve`.
#[derive(Debug, Args)]
pub struct SolveCmdArgs {
    #[command(flatten)]
    pub(super) scene: SceneArgs,
    /// The solution file to write.
    #[arg(short, long)]
    pub(super) output: PathBuf,
    #[command(flatten)]
    pub(super) solve: SolveArgs,
    /// Seed for the shooting samples.
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub(super) threads: Option<u32>,
    /// Write the solve's figures as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub(super) stats: Option<PathBuf>,
    /// No progress bar and no warnings on stderr.
    #[arg(short, long)]
    pub(super) quiet: bool,
}

/// `radtrace render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub(super) scene: SceneArgs,
    /// Output image: .exr (linear radiance) or .png (8-bit sRGB).
    #[arg(short, long)]
    pub(super) output: PathBuf,
    /// How direct light is computed.
    #[arg(long, value_enum, default_value_t = Method::Local)]
    pub(super) method: Method,
    /// Which view (sensor) of the scene, from 0.
    #[arg(long, default_value_t = 0)]
    pub(super) view: usize,
    /// Image sampler: `adaptive` (the paper's refinement from level -1 to
    /// --max-level, with the shadow image buffer) or `uniform` (--spp samples in every
    /// pixel) [default: adaptive; uniform when --spp is given].
    #[arg(long, value_enum)]
    pub(super) sampler: Option<Sampler>,
    /// Samples per pixel of the uniform sampler [default: the scene's sampler, else 16].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub(super) spp: Option<u32>,
    #[command(flatten)]
    pub(super) refine: RefineArgs,
    /// Shadow image buffer: `on` takes a light point's visibility from the
    /// neighbouring samples where they agree, `off` casts every shadow ray (the fully
    /// sampled picture) [default: on for local and global, off otherwise].
    #[arg(long, value_enum)]
    pub(super) sib: Option<OnOff>,
    /// Retextured anti-aliasing samples: `on`, where a refined pixel's samples on an
    /// object (with its neighbours' there) agree on their light once their texels are
    /// set alike (a texture varies, or an object's edge crosses the pixel), its new
    /// samples that hit that object facing the same way take the light of its nearest
    /// sample there and look up only their own texel (where only the glossy part
    /// differs, they take the diffuse light and trace the glossy part anew); `off`
    /// traces every sample in full.
    #[arg(long, value_enum, default_value = "on")]
    pub(super) retexture: OnOff,
    /// Write pictures of the method to this folder: the shadow image of each
    /// ray-traced source (sib-NN-NAME.png), samples per pixel (density.png) and shadow
    /// rays per pixel (rays.png). Adaptive sampler only.
    #[arg(long, value_name = "DIR")]
    pub(super) sib_images: Option<PathBuf>,
    #[command(flatten)]
    pub(super) image: ImageArgs,
    /// Exposure in stops applied to PNG output (EXR is always written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub(super) exposure: f32,
    /// Progressive display (paper Sect. 3): write the image after each step, the
    /// radiosity solution alone first, then the selected sources ray traced, strongest
    /// first (1, 2, 4 ...), then the final render (with its gather); the last image is
    /// the render without this flag. Ctrl-C leaves the last finished step's image.
    #[arg(long)]
    pub(super) progressive: bool,
    /// Stream the image to the tev HDR viewer listening at HOST:PORT (tev's default
    /// port is 14158): every step of --progressive, and the final image.
    #[arg(long, value_name = "HOST:PORT")]
    pub(super) display_server: Option<String>,
    /// Write statistics (rays, hits, timings) as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub(super) stats: Option<PathBuf>,
    /// No progress bar and no warnings on stderr.
    #[arg(short, long)]
    pub(super) quiet: bool,
    /// Print the statistics as a text table in the layout of the paper's Table 1
    /// (diffuse hits, shadow rays, rays per hit; per source below).
    #[arg(long)]
    pub(super) stats_table: bool,
    /// A --stats file of a fully sampled render (--method norm) of the same view: the
    /// table then shows both rows and the shadow rays saved.
    #[arg(long, value_name = "FILE")]
    pub(super) baseline: Option<PathBuf>,
    /// Write a picture of the selection (PNG): each patch coloured by the sources ray
    /// traced on it, brighter for more shadow rays per hit.
    #[arg(long, value_name = "FILE")]
    pub(super) selection_map: Option<PathBuf>,
    /// Reuse a radiosity solution saved by `radtrace solve` instead of solving.
    #[arg(long, value_name = "FILE")]
    pub(super) solution: Option<PathBuf>,
    #[command(flatten)]
    pub(super) solve: SolveArgs,
    #[command(flatten)]
    pub(super) select: SelectArgs,
}

/// Image and sampling options shared by `render` and `tables`.
#[derive(Debug, Args)]
pub struct ImageArgs {
    /// Seed for all random choices; the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub(super) threads: Option<u32>,
    /// Image width in pixels [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub(super) width: Option<u32>,
    /// Image height in pixels [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub(super) height: Option<u32>,
    /// Sub-sources of each area light (and selected radiant patch): the shadow rays
    /// `norm` casts to it at each diffuse hit, and the most `local` casts.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub(super) area_samples: u32,
    /// Maximum number of mirror reflections followed.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub(super) max_depth: u32,
    /// Final gather (the paper's last step): at the first diffuse hit of a camera ray,
    /// the light not ray traced from the patch's sources is gathered with this many
    /// cosine-distributed rays that read the radiosity solution, at a grid of the
    /// screen every 4 pixels and anew where those records do not reach (0: interpolate
    /// the solution at the hit) [default: by --quality, 128 for good; 0 for --method
    /// direct and twopass].
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=4096))]
    pub(super) gather: Option<u32>,
    /// Pixel reconstruction filter [default: the scene film's `rfilter`, else
    /// gaussian, Mitsuba's default].
    #[arg(long, value_enum)]
    pub(super) filter: Option<Filter>,
}

/// `radtrace tables`.
#[derive(Debug, Args)]
pub struct TablesArgs {
    #[command(flatten)]
    pub(super) scene: SceneArgs,
    /// Views (sensors) to render, e.g. `0,1` [default: every view of the scene].
    #[arg(long, value_delimiter = ',')]
    pub(super) views: Vec<usize>,
    /// Write each view's four images (viewK-RUN.exr) and statistics (viewK-RUN.json)
    /// to this folder.
    #[arg(short, long, value_name = "DIR")]
    pub(super) output: Option<PathBuf>,
    /// Print the figures as JSON instead of tables.
    #[arg(long)]
    pub(super) json: bool,
    #[command(flatten)]
    pub(super) image: ImageArgs,
    #[command(flatten)]
    pub(super) refine: RefineArgs,
    /// Reuse a radiosity solution saved by `radtrace solve` instead of solving.
    #[arg(long, value_name = "FILE")]
    pub(super) solution: Option<PathBuf>,
    #[command(flatten)]
    pub(super) solve: SolveArgs,
    #[command(flatten)]
    pub(super) select: SelectArgs,
    /// No progress bars and no warnings on stderr.
    #[arg(short, long)]
    pub(super) quiet: bool,
}

/// `radtrace info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub(super) scene: SceneArgs,
}

/// `radtrace tessellate`.
#[derive(Debug, Args)]
pub struct TessellateArgs {
    /// Bezier patch file (.bpt).
    pub(super) input: PathBuf,
    /// Output mesh (.obj).
    #[arg(short, long)]
    pub(super) output: PathBuf,
    /// Radiosity patches per Bezier patch side.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(super) coarse: u32,
    /// Quads per radiosity patch side (ray-tracing resolution).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(super) fine: u32,
}

/// `radtrace compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Reference image (.exr or .png).
    pub(super) reference: PathBuf,
    /// Test image (.exr or .png).
    pub(super) test: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub(super) json: bool,
    /// Write the FLIP error map (magma colours) to this PNG.
    #[arg(long, value_name = "FILE")]
    pub(super) error_map: Option<PathBuf>,
}

/// `radtrace bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub(super) scene: SceneArgs,
    /// Which view (sensor) the camera rays come from, from 0.
    #[arg(long, default_value_t = 0)]
    pub(super) view: usize,
    /// Camera rays per row [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub(super) width: Option<u32>,
    /// Rows of camera rays [default: the scene's film].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub(super) height: Option<u32>,
    /// Shadow rays per camera-ray hit (to points on the lights, in turn).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub(super) shadow_rays: u32,
    /// Incoherent (cosine-distributed bounce) rays per camera-ray hit.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub(super) bounce_rays: u32,
    /// Times each measurement is repeated; the best is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub(super) repeats: u32,
    /// Seed of the light points and bounce directions (and of the solve).
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// Worker threads of the "all threads" figures [default: all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub(super) threads: Option<u32>,
    /// Skip the radiosity solve (and the renders of the views, which need it).
    #[arg(long)]
    pub(super) no_solve: bool,
    /// Also solve and render on one thread, for the 1-vs-all-threads scaling.
    #[arg(long, conflicts_with = "no_solve")]
    pub(super) solve_scaling: bool,
    #[command(flatten)]
    pub(super) solve: SolveArgs,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub(super) json: bool,
    /// Write the triangles, the ray sets and radtrace's answers to this directory as
    /// .npy files (for tools/compare-peers.py).
    #[arg(long, value_name = "DIR")]
    pub(super) dump: Option<PathBuf>,
    /// No warnings on stderr.
    #[arg(short, long)]
    pub(super) quiet: bool,
}

pub(super) fn parse_define(s: &str) -> std::result::Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE, got '{s}'")),
    }
}

impl ImageArgs {
    /// Final-gather rays: the flag's, else the quality level's for the methods that
    /// ray trace sources over the solution ([`Method::ray_traces_over_solution`]).
    pub(super) fn gather(&self, quality: Quality, method: Method) -> u32 {
        let dial = if method.ray_traces_over_solution() {
            quality.gather()
        } else {
            0
        };
        self.gather.unwrap_or(dial)
    }
}

impl RenderArgs {
    /// The render settings for the view of `scene` (the uniform sampler's `--spp` and
    /// the adaptive sampler's `refine` as given).
    pub(super) fn settings(&self, scene: &Scene, sampler: Sampler, refine: Refine) -> Result<Settings> {
        let sensor = scene.sensor(self.view)?;
        let image = &self.image;
        Ok(Settings {
            method: self.method,
            view: self.view,
            width: image.width.unwrap_or(sensor.width),
            height: image.height.unwrap_or(sensor.height),
            spp: self.spp.or(sensor.spp).unwrap_or(16).clamp(1, 65536),
            seed: image.seed,
            area_samples: image.area_samples,
            max_depth: image.max_depth,
            gather: image.gather(self.solve.quality, self.method),
            filter: image.filter.or(sensor.filter).unwrap_or_default(),
            sampler,
            refine,
        })
    }
}
