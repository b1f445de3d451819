//! The rendering pass (the paper's second pass): primary rays through a camera,
//! shading at the hit points, specular reflection rays, and pixel reconstruction.
//!
//! Methods (`--method`) share this code and differ in where direct light comes from:
//! `direct` ray traces every light source at every diffuse hit (no radiosity); the
//! others shade from a radiosity solution and ray trace the sources a
//! [`crate::selection::Selection`] picked for the patch hit.

pub mod adaptive;
pub mod bsdf;
pub mod camera;
pub mod film;
pub mod lights;
pub mod shading;
pub mod sib;

use std::time::Instant;

use glam::Vec2;
use indicatif::ProgressBar;
use rayon::prelude::*;

use crate::accel::Accel;
use crate::io::Image;
use crate::scene::Scene;
use crate::selection::Selection;
use crate::stats::Counters;
use crate::{Error, Result};

pub use crate::stats::LevelStats;
pub use adaptive::{Refine, SampleSet};
pub use camera::Camera;
pub use film::{FilmSample, Filter, SampleBuffer};
pub use lights::SampledLight;
pub use shading::{SurfacePoint, Tracer};

/// How the direct light is computed (the paper's renderers as modes of one code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Exact direct light: shadow rays to every light source at every diffuse hit;
    /// no indirect light.
    #[default]
    Direct,
    /// Standard two-pass radiosity: shading from the radiosity mesh alone (Fig. 7).
    Twopass,
    /// Radiosity for indirect light, every light source ray traced at fixed counts:
    /// the fully sampled "norm" picture (Fig. 8).
    Norm,
    /// Per-patch source selection with the five criteria of Sect. 3 (Fig. 9).
    Local,
    /// The `--global-sources` strongest sources ray traced everywhere.
    Global,
}

impl Method {
    /// The name used on the command line.
    pub fn name(self) -> String {
        clap::ValueEnum::to_possible_value(&self)
            .map(|v| v.get_name().to_owned())
            .unwrap_or_default()
    }
}

/// How the image is sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Sampler {
    /// The paper's adaptive refinement (levels -1 to `--max-level`) with the shadow
    /// image buffer.
    #[default]
    Adaptive,
    /// `--spp` jittered samples in every pixel (Owen-scrambled Sobol), every shadow ray
    /// cast.
    Uniform,
}

/// Everything that controls one rendering of one view.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// The method.
    pub method: Method,
    /// Index of the sensor (view).
    pub view: usize,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of all random choices: the same seed gives the same image.
    pub seed: u64,
    /// Shadow rays per area light at each diffuse hit.
    pub area_samples: u32,
    /// Maximum number of mirror reflections followed.
    pub max_depth: u32,
    /// Pixel reconstruction filter.
    pub filter: Filter,
    /// The image sampler.
    pub sampler: Sampler,
    /// The adaptive sampler's levels, criteria and SIB switch (unused by `uniform`).
    pub refine: Refine,
}

/// What one rendering produces.
#[derive(Debug, Clone)]
pub struct Output {
    /// The reconstructed image (linear radiance).
    pub image: Image,
    /// Event counts.
    pub counters: Counters,
    /// Counts per level of the adaptive sampler (empty for `uniform`).
    pub levels: Vec<LevelStats>,
    /// The adaptive sampler's samples and shadow image buffer.
    pub samples: Option<SampleSet>,
    /// Pixels of the image that are NaN or infinite (0 unless something is wrong).
    pub non_finite_pixels: usize,
    /// Seconds spent tracing and shading.
    pub trace_s: f64,
    /// Seconds spent reconstructing pixels.
    pub reconstruct_s: f64,
}

/// Renders one view of `scene`. `progress(label, work)` makes a progress bar for each
/// stage (each level of the adaptive sampler; image rows for the uniform one).
/// `selection` (made by [`crate::selection::select`] from a radiosity solution) is
/// required by every method but `direct`, which ignores it.
pub fn render(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &Settings,
    selection: Option<&Selection>,
    progress: &dyn Fn(&str, u64) -> ProgressBar,
) -> Result<Output> {
    let tracer = match (settings.method, selection) {
        (Method::Direct, _) => Tracer::new(scene, accel, settings),
        (_, Some(sel)) => Tracer::with_selection(scene, accel, settings, sel),
        (m, None) => {
            return Err(Error::Usage(format!(
                "--method {} needs a radiosity solution and a source selection",
                m.name()
            )))
        }
    };
    let sensor = scene.sensor(settings.view)?;
    let camera = Camera::new(sensor, settings.width, settings.height);
    match settings.sampler {
        Sampler::Adaptive => {
            let start = Instant::now();
            let out = adaptive::render_adaptive(&tracer, &camera, settings, &settings.refine, progress);
            let trace_s = start.elapsed().as_secs_f64();
            let start = Instant::now();
            let image = out.set.reconstruct(settings.filter);
            Ok(Output {
                non_finite_pixels: image.non_finite_pixels(),
                image,
                counters: out.counters,
                levels: out.levels,
                samples: Some(out.set),
                trace_s,
                reconstruct_s: start.elapsed().as_secs_f64(),
            })
        }
        Sampler::Uniform => Ok(render_uniform(&tracer, &camera, settings, progress)),
    }
}

/// `settings.spp` jittered samples in every pixel.
fn render_uniform(
    tracer: &Tracer,
    camera: &Camera,
    settings: &Settings,
    progress: &dyn Fn(&str, u64) -> ProgressBar,
) -> Output {
    let (w, h) = (settings.width, settings.height);
    let pb = progress("render", h as u64);
    let start = Instant::now();
    // One row per task (see adaptive.rs: rayon's larger pieces unbalance the threads).
    let rows: Vec<(Vec<FilmSample>, Counters)> = (0..h)
        .into_par_iter()
        .with_max_len(1)
        .map(|y| {
            let mut counters = Counters::with_sources(tracer.source_count());
            let mut samples = Vec::with_capacity((w * settings.spp) as usize);
            for x in 0..w {
                let pixel_seed = pixel_seed(settings.seed, settings.view as u64, x, y);
                for k in 0..settings.spp {
                    let jitter = Vec2::new(
                        sobol_burley::sample(k, 0, pixel_seed),
                        sobol_burley::sample(k, 1, pixel_seed),
                    );
                    let (fx, fy) = (x as f32 + jitter.x, y as f32 + jitter.y);
                    let ray = camera.ray(fx, fy);
                    counters.primary_rays += 1;
                    let path_seed = hash32(pixel_seed ^ k.wrapping_mul(0x9E37_79B9));
                    let value = tracer.radiance(&ray, 0, path_seed, &mut counters);
                    samples.push(FilmSample { x: fx, y: fy, value });
                }
            }
            pb.inc(1);
            (samples, counters)
        })
        .collect();
    pb.finish_and_clear();
    let trace_s = start.elapsed().as_secs_f64();

    let mut counters = Counters::with_sources(tracer.source_count());
    let mut sample_rows = Vec::with_capacity(rows.len());
    for (s, c) in rows {
        counters += c;
        sample_rows.push(s);
    }
    let start = Instant::now();
    let image = SampleBuffer::from_rows(w, h, sample_rows).reconstruct(settings.filter);
    Output {
        non_finite_pixels: image.non_finite_pixels(),
        image,
        counters,
        levels: Vec::new(),
        samples: None,
        trace_s,
        reconstruct_s: start.elapsed().as_secs_f64(),
    }
}

/// A progress-bar maker for [`render`] that shows nothing.
pub fn no_progress(_: &str, _: u64) -> ProgressBar {
    ProgressBar::hidden()
}

/// A 32-bit seed for pixel `(x, y)` of a view, from the user's seed.
fn pixel_seed(seed: u64, view: u64, x: u32, y: u32) -> u32 {
    fold32(splitmix64(
        seed ^ splitmix64(view << 48 ^ (y as u64) << 24 ^ x as u64),
    ))
}

/// Folds a 64-bit hash into 32 bits (for sample seeds).
pub(crate) fn fold32(h: u64) -> u32 {
    (h ^ (h >> 32)) as u32
}

/// SplitMix64's finaliser: a good 64-bit mixing function.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Mixes a 32-bit value (for deriving independent sample seeds).
pub(crate) fn hash32(x: u32) -> u32 {
    fold32(splitmix64(x as u64))
}
