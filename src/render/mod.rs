//! The rendering pass (the paper's second pass): primary rays through a camera,
//! shading at the hit points, specular reflection rays, and pixel reconstruction.
//!
//! Methods (`--method`) share this code and differ in where direct light comes from:
//! `direct` ray traces every light source at every diffuse hit (no radiosity); the
//! others shade from a radiosity solution and ray trace the sources a
//! [`crate::selection::Selection`] picked for the patch hit.

pub mod adaptive;
pub mod black;
pub mod counters;
pub mod debug;
pub mod film;
pub mod gather;
pub mod glass;
pub mod shading;
pub mod sib;

use std::time::Instant;

use glam::Vec2;

use crate::accel::Accel;
use crate::camera::Camera;
use crate::image::Image;
use crate::progress::Progress;
use crate::sampling::{derive, pixel_seed, uniform2, Stream};
use crate::scene::Scene;
use crate::selection::Selection;
use crate::{Error, Result};
pub use counters::{Counters, LevelStats};

pub use crate::selection::Method;
pub use adaptive::{Refine, SampleSet};
pub use film::{film_rows, Film, FilmSample, Filter};
pub use gather::Gather;
pub use shading::Tracer;

/// How the image is sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, Default)]
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

impl Sampler {
    /// The name used on the command line and in the statistics.
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Adaptive => "adaptive",
            Sampler::Uniform => "uniform",
        }
    }
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
    /// Rays of the final gather at each gather point (0: none; [`gather`]).
    pub gather: u32,
    /// Pixel reconstruction filter.
    pub filter: Filter,
    /// The image sampler.
    pub sampler: Sampler,
    /// The adaptive sampler's levels, criteria and SIB switch (unused by `uniform`).
    pub refine: Refine,
}

impl Settings {
    /// Checks the image size, sample counts and (for every sampler, as the command
    /// line does) [`Refine::validate`]; the error names the command line's flag.
    pub fn validate(&self) -> Result<()> {
        use crate::error::at_least_one;
        at_least_one("width", self.width)?;
        at_least_one("height", self.height)?;
        at_least_one("spp", self.spp)?;
        at_least_one("area-samples", self.area_samples)?;
        self.refine.validate()
    }
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

/// Renders one view of `scene`. `progress` hears of each
/// stage (each level of the adaptive sampler; image rows for the uniform one).
/// `selection` (made by [`crate::selection::select`] from a radiosity solution) is
/// required by every method but `direct`, which ignores it.
pub fn render(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &Settings,
    selection: Option<&Selection>,
    progress: &dyn Progress,
) -> Result<Output> {
    settings.validate()?;
    if settings.gather > 0 && settings.method == Method::Direct {
        return Err(Error::Usage(
            "--gather reads a radiosity solution, and --method direct has none: use another method or drop --gather"
                .into(),
        ));
    }
    let mut tracer = match (settings.method, selection) {
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
    tracer.set_pixel_scale(camera.pixel_scale());
    let start = Instant::now();
    let mut first = Counters::with_sources(tracer.source_count());
    if let (true, Some(sel)) = (settings.gather > 0, selection) {
        let ctx = gather::Context {
            scene,
            accel,
            solution: sel.solution,
            lights: &sel.emitters[..scene.lights.len()],
            area_samples: settings.area_samples,
            parted: tracer.parted(),
        };
        let mut g = Gather::new(&ctx, settings.gather, sel);
        first += g.record(&ctx, &camera, settings);
        tracer.set_gather(g);
    }
    let mut out = match settings.sampler {
        Sampler::Adaptive => {
            // Through a thin lens the blur is noise that the difference criterion
            // cannot tell from an edge: pixels are refined wherever neighbouring
            // samples differ at all (to the highest level where the blur is).
            let refine = match sensor.lens {
                Some(_) => adaptive::Refine {
                    contrast: 0.0,
                    ..settings.refine
                },
                None => settings.refine,
            };
            let out = adaptive::render_adaptive(&tracer, &camera, settings, &refine, progress);
            let trace_s = start.elapsed().as_secs_f64();
            let start = Instant::now();
            let image = out.set.reconstruct(settings.filter);
            Output {
                non_finite_pixels: image.non_finite_pixels(),
                image,
                counters: out.counters,
                levels: out.levels,
                samples: Some(out.set),
                trace_s,
                reconstruct_s: start.elapsed().as_secs_f64(),
            }
        }
        Sampler::Uniform => {
            let mut out = render_uniform(&tracer, &camera, settings, progress);
            out.trace_s = start.elapsed().as_secs_f64();
            out
        }
    };
    first += std::mem::take(&mut out.counters);
    out.counters = first;
    Ok(out)
}

/// `settings.spp` jittered samples in every pixel.
fn render_uniform(tracer: &Tracer, camera: &Camera, settings: &Settings, progress: &dyn Progress) -> Output {
    let (w, h) = (settings.width, settings.height);
    progress.start("render", h as u64);
    // Each row's samples go straight into the film (memory follows the pixels,
    // whatever the samples per pixel).
    let share = 1.0 / settings.spp.max(1) as f32;
    let (image, rows) = film_rows(w, h, settings.filter, |y, strip| {
        let mut counters = Counters::with_sources(tracer.source_count());
        for x in 0..w {
            let pixel_seed = pixel_seed(settings.seed, settings.view as u64, x, y);
            for k in 0..settings.spp {
                let jitter = Vec2::new(
                    sobol_burley::sample(k, 0, pixel_seed),
                    sobol_burley::sample(k, 1, pixel_seed),
                );
                let (fx, fy) = (x as f32 + jitter.x, y as f32 + jitter.y);
                let path_seed = derive(pixel_seed, Stream::Sample(k));
                let ray = camera.ray_through_lens(fx, fy, uniform2(derive(path_seed, Stream::Lens)));
                counters.primary_rays += 1;
                let value = tracer.radiance(&ray, 0, path_seed, &mut counters);
                strip.add(&FilmSample { x: fx, y: fy, value }, share, h);
            }
        }
        progress.advance(1);
        counters
    });
    progress.finish();
    let mut counters = Counters::with_sources(tracer.source_count());
    for c in rows {
        counters += c;
    }
    Output {
        non_finite_pixels: image.non_finite_pixels(),
        image,
        counters,
        levels: Vec::new(),
        samples: None,
        // (Timed by `render`, with the gather's records.)
        trace_s: 0.0,
        // (The film is made as the samples come: no separate reconstruction.)
        reconstruct_s: 0.0,
    }
}

#[cfg(test)]
impl Settings {
    /// One sample of the direct method, `area_samples` per area light, mirrors and
    /// glass followed `max_depth` bounces (the shading tests' settings).
    pub(crate) fn direct_test(area_samples: u32, max_depth: u32) -> Settings {
        Settings {
            method: Method::Direct,
            view: 0,
            width: 1,
            height: 1,
            spp: 1,
            seed: 0,
            area_samples,
            max_depth,
            gather: 0,
            filter: Filter::Box,
            sampler: Sampler::Uniform,
            refine: Refine::default(),
        }
    }
}

#[cfg(test)]
mod tests;
