//! Adaptive image refinement with the shadow image buffer (paper Sect. 5 and 6).
//!
//! Samples are taken level by level on a hierarchy of cells, each jittered in its cell:
//!
//! - level -1: one sample per 2 x 2 pixel block; every shadow ray is cast;
//! - level 0: every pixel that has no sample yet gets one, non-adaptively (so small
//!   objects are not missed); shadow rays only where the SIB neighbours (the level -1
//!   samples of the four nearest blocks) disagree;
//! - level L >= 1 (up to `max_level`): in the pixels the refinement criteria select,
//!   every cell of `2^-L` pixels that has no sample yet gets one, so a pixel holds
//!   `4^L` samples. These are anti-aliasing samples: they read the SIB of the level 0
//!   samples of the four nearest pixels but store nothing. With the SIB on they cast
//!   `1 / 4^L` of the shadow rays per hit to an area source (at least four), so a
//!   pixel's new samples at a level take about a level-0 sample's shadow rays between
//!   them, not `4^L` times (with the SIB off, the fully sampled picture, every sample
//!   casts all). They share them in strata ([`crate::sampling::Stratum`]): each takes
//!   its own stretch of every group of light points, so that together they cover the
//!   source as one sample's rays do. Wooden staircase (one large area light, 62 % of
//!   its samples at level 2): at `1 / 2^L` (no strata), render 17.1 -> 12.4 s, FLIP
//!   against Mitsuba 0.0621 -> 0.0619. `1 / 4^L` without strata lost the penumbrae
//!   (28 % RMS from the closed form in
//!   `anti_aliasing_samples_share_the_shadow_rays_of_a_penumbra_without_losing_it`,
//!   13.7 % at `1 / 2^L`, 16 groups); in strata and at least four, 13.8 % (64 groups:
//!   7.9 %, 7.3 % at `1 / 2^L`). 2026-11-28: the staircase's shadow rays 11.0 M ->
//!   8.3 M, render 9.1-9.7 -> 8.0-8.5 s, FLIP (seeds 0 / 1) 0.0538 / 0.0545 ->
//!   0.0540 / 0.0546; the conference room's 5.0 M -> 3.8 M, render 2.84 -> 2.66 s.
//!
//! Retextured samples (not in the paper; `Refine::retexture`): where a refined pixel's
//! samples on one object, with its eight neighbours' stored samples there, differ by
//! their texels alone (`texture_alone`: a diffuse or plastic model, untextured or
//! textured on its diffuse reflectance only, and the criteria quiet once every texel
//! is set alike), its new samples that hit that object take the light of its nearest
//! sample there ([`Lighting`], handed to the shading as `SibQuery::given`) and trace
//! only their primary ray; where the criteria are quiet on the diffuse light alone,
//! they take that and trace the glossy and mirror parts anew. Each of the first two
//! objects of a pixel is judged alone (`relightable`), so a pixel across an object's
//! edge, refined for its coverage, traces in full only the samples on a side whose
//! light varies; a hit whose surface faces another way than where the light was found
//! traces in full too ([`sib::NORMAL_AGREES`]: a box's side takes nothing from its
//! top). Wooden staircase: textures alone, 422 k + 257 k of 1.18 M anti-aliasing
//! samples, render 6.7-7.1 -> 5.7-5.8 s, FLIP 0.0539 / 0.0546 -> 0.0546 / 0.0552;
//! with edges and untextured surfaces too, 898 k, render 5.25 -> 4.71 s, FLIP 0.0548
//! / 0.0554.
//!
//! Refinement criteria (Sect. 6): *object* (samples hit different objects), *shadow*
//! (a real point light is lit at one sample and shadowed at the other, read from the
//! SIB) and *difference* (the display values differ by more than `contrast`, or,
//! where they are white, the radiance by [`HDR_RATIO`] times: a light's image
//! smaller than a pixel in a white surround). Level 1
//! compares each pixel's sample with those of its eight neighbours; level L > 1
//! compares the samples inside a pixel refined at level L - 1.
//!
//! A level reads only coarser levels, so its samples are computed in parallel, and the
//! image of a seed does not depend on the number of threads. Pixels are reconstructed
//! with the filter as a weighted average in which each sample counts in proportion to
//! its share of its pixel (`1 / samples in the pixel`), so densely refined pixels do
//! not outweigh their neighbours: with the box filter this is the paper's "weighted
//! average of the samples within the pixel areas".

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::counters::{Counters, LevelStats};
use super::film::film_rows;
use super::sib::{self, Entry, Given, Lighting, Neighbour, SibQuery, NO_OBJECT};
use super::{FilmSample, Settings, Tracer};
use crate::camera::Camera;
use crate::image::{srgb_encode, Image};
use crate::progress::Progress;
use crate::sampling::{cell_seed, derive, uniform2, Stratum, Stream};
use crate::scene::Rgb;
use crate::{Error, Result};

/// "No sample".
const NONE: u32 = u32::MAX;

/// Samples per parallel work item.
const CHUNK: usize = 256;

/// One image sample of the adaptive sampler.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Film position in pixels.
    pub pos: Vec2,
    /// Radiance found.
    pub value: Rgb,
    /// The object (shape) the primary ray hit, or [`NO_OBJECT`].
    pub object: u32,
    /// The level it was taken at (-1 ..= max level).
    pub level: i8,
    /// Shadow rays this sample cast (all its hits), at most `u16::MAX` (for the
    /// picture of rays per pixel; the counts in the stats are exact).
    pub rays: u16,
    /// Shadow rays it did not cast because its SIB neighbours agreed, at most
    /// `u16::MAX`.
    pub saved: u16,
    /// Its first hit's diffuse light, where the texture alone scales it (what a
    /// retextured sample near it takes).
    pub lighting: Option<Lighting>,
}

// A sample's size sets the sampler's memory (6.9 M samples on the wooden
// staircase at 720 x 1280): 48 bytes, with the kept light's normal.
const _: () = assert!(std::mem::size_of::<Sample>() <= 48);

/// Everything the adaptive sampler took: the samples, the shadow image buffer of the
/// stored (level -1 and 0) samples, and which sample is each pixel's stored one.
#[derive(Debug, Clone)]
pub struct SampleSet {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// All samples, level by level; the first `width * height` are the stored ones.
    pub samples: Vec<Sample>,
    /// Per pixel, its stored sample.
    pub base: Vec<u32>,
    /// Words per sample of [`SampleSet::point_bits`]: 2 x ceil(point lights / 64).
    point_words: usize,
    /// Per sample, which point and spot lights are known there and which are lit
    /// (for the shadow criterion), in [`SampleSet::point_bits`]'s layout.
    point: Vec<u64>,
    /// SIB records of the stored samples: sample i's is
    /// `entries[first[i]..first[i + 1]]`.
    first: Vec<u32>,
    entries: Vec<Entry>,
    /// Per pixel, offsets into `by_pixel`.
    pixel_start: Vec<u32>,
    /// Sample indices grouped by pixel.
    by_pixel: Vec<u32>,
}

impl SampleSet {
    /// The SIB record of stored sample `i` (empty for other samples).
    pub fn record(&self, i: u32) -> &[Entry] {
        let i = i as usize;
        if i + 1 < self.first.len() {
            &self.entries[self.first[i] as usize..self.first[i + 1] as usize]
        } else {
            &[]
        }
    }

    /// Which point and spot lights sample `i` knows and which of those are lit: bit
    /// `k % 64` of word `k / 64` for the k-th point or spot light among the ray-traced
    /// sources; the known words, then as many lit words.
    pub fn point_bits(&self, i: u32) -> &[u64] {
        let n = self.point_words;
        &self.point[i as usize * n..(i as usize + 1) * n]
    }

    /// A sample with its point bits, for [`differ`].
    fn with_bits(&self, i: u32) -> (&Sample, &[u64]) {
        (&self.samples[i as usize], self.point_bits(i))
    }

    /// The samples of pixel `p`.
    pub fn pixel(&self, p: u32) -> &[u32] {
        let p = p as usize;
        &self.by_pixel[self.pixel_start[p] as usize..self.pixel_start[p + 1] as usize]
    }

    fn pixel_of(&self, pos: Vec2) -> u32 {
        let x = (pos.x.max(0.0) as u32).min(self.width - 1);
        let y = (pos.y.max(0.0) as u32).min(self.height - 1);
        y * self.width + x
    }

    /// Groups the samples by pixel again (after a level added some).
    fn index_pixels(&mut self) {
        let n = (self.width * self.height) as usize;
        let mut start = vec![0u32; n + 1];
        for s in &self.samples {
            start[self.pixel_of(s.pos) as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut by = vec![0u32; self.samples.len()];
        for (i, s) in self.samples.iter().enumerate() {
            let p = self.pixel_of(s.pos) as usize;
            by[fill[p] as usize] = i as u32;
            fill[p] += 1;
        }
        self.pixel_start = start;
        self.by_pixel = by;
    }

    /// The image: each pixel a filtered average of the samples near it, every sample
    /// weighted by its share of its pixel.
    pub fn reconstruct(&self, filter: super::Filter) -> Image {
        let w = self.width;
        film_rows(w, self.height, filter, |y, strip| {
            for p in y * w..(y + 1) * w {
                let samples = self.pixel(p);
                let share = 1.0 / samples.len().max(1) as f32;
                for &i in samples {
                    let s = &self.samples[i as usize];
                    let sample = FilmSample {
                        x: s.pos.x,
                        y: s.pos.y,
                        value: s.value,
                    };
                    strip.add(&sample, share, self.height);
                }
            }
        })
        .0
    }
}

/// What the adaptive sampler produces.
#[derive(Debug, Clone)]
pub struct AdaptiveOutput {
    /// The samples and their shadow image buffer.
    pub set: SampleSet,
    /// Counts per level, from -1.
    pub levels: Vec<LevelStats>,
    /// All counts.
    pub counters: Counters,
}

/// A sample to take.
#[derive(Debug, Clone, Copy)]
struct Task {
    pos: Vec2,
    seed: u32,
    /// Stored samples whose SIB it reads.
    neighbours: [u32; 4],
    /// Which of its pixel's new samples at an anti-aliasing level it is.
    stratum: Stratum,
    /// Per object its pixel's samples hit (up to two), the sample whose light it
    /// takes on a hit there, retextured, and what it takes; [`NO_RELIGHT`]: traced
    /// in full.
    relight: [(u32, Takes); 2],
}

/// A task that takes no sample's light.
const NO_RELIGHT: [(u32, Takes); 2] = [(NONE, Takes::Nothing); 2];

/// What a retextured sample takes from the sample near it, its own texel put in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Takes {
    /// Nothing: traced in full.
    Nothing,
    /// The diffuse light; the glossy and mirror parts are traced anew.
    Diffuse,
    /// All its light: only the primary ray is traced.
    All,
}

/// Parameters of the adaptive sampler beyond the render settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refine {
    /// Highest level (`4^max_level` samples per pixel at most).
    pub max_level: u32,
    /// Difference criterion: refine where display values (sRGB, after `exposure`)
    /// differ by more than this in a channel.
    pub contrast: f32,
    /// Exposure in stops for the difference criterion.
    pub exposure: f32,
    /// Whether the SIB's neighbours are reused (off: every shadow ray is cast).
    pub sib: bool,
    /// Whether anti-aliasing samples on an object whose light agrees across their
    /// pixel (only its texture varies, or an object's edge crosses the pixel) take
    /// the light of the pixel's nearest sample on it and look up only their own texel.
    pub retexture: bool,
}

impl Refine {
    /// The highest level allowed (`4^4` = 256 samples per pixel at most).
    pub const MAX_LEVEL: u32 = 4;

    /// Checks the levels and the difference criterion; the error names the command
    /// line's flag.
    pub fn validate(&self) -> Result<()> {
        if !(self.contrast >= 0.0 && self.contrast <= 1.0) {
            return Err(Error::Usage(format!(
                "--contrast {}: must be between 0 and 1",
                self.contrast
            )));
        }
        if self.max_level > Self::MAX_LEVEL {
            return Err(Error::Usage(format!(
                "--max-level {}: must be at most {}",
                self.max_level,
                Self::MAX_LEVEL
            )));
        }
        Ok(())
    }
}

impl Default for Refine {
    /// The command line's defaults: level 2 (16 samples per pixel at most), contrast
    /// 0.05, exposure 0, SIB on.
    fn default() -> Self {
        Refine {
            max_level: 2,
            contrast: 0.05,
            exposure: 0.0,
            sib: true,
            retexture: true,
        }
    }
}

/// Renders with the adaptive sampler. `progress(label, samples)` makes a progress bar
/// for each level.
pub fn render_adaptive(
    tracer: &Tracer,
    camera: &Camera,
    settings: &Settings,
    refine: &Refine,
    progress: &dyn Progress,
) -> AdaptiveOutput {
    let (w, h) = (settings.width, settings.height);
    let mut point_count = 0;
    let point: Vec<Option<u32>> = tracer
        .point_sources()
        .into_iter()
        .map(|is_point| {
            is_point.then(|| {
                point_count += 1;
                point_count as u32 - 1
            })
        })
        .collect();
    let ctx = LevelCtx {
        tracer,
        camera,
        refine,
        point,
        point_count,
        nsrc: tracer.source_count(),
        progress,
    };
    let nsrc = ctx.nsrc;
    let mut set = SampleSet {
        width: w,
        height: h,
        samples: Vec::new(),
        base: vec![NONE; (w * h) as usize],
        point_words: 2 * ctx.point_count.div_ceil(64),
        point: Vec::new(),
        first: vec![0],
        entries: Vec::new(),
        pixel_start: Vec::new(),
        by_pixel: Vec::new(),
    };
    let mut levels = Vec::new();
    let seed_of =
        |level: i32, cx: u32, cy: u32| cell_seed(settings.seed, settings.view as u64, level, cx, cy);
    let jitter = uniform2;

    // Level -1: one sample per 2 x 2 block, every shadow ray cast.
    let (bw, bh) = (w.div_ceil(2), h.div_ceil(2));
    let tasks: Vec<Task> = (0..bw * bh)
        .into_par_iter()
        .map(|b| {
            let (bx, by) = (b % bw, b / bw);
            let seed = seed_of(-1, bx, by);
            let ext = Vec2::new((w - 2 * bx).min(2) as f32, (h - 2 * by).min(2) as f32);
            Task {
                pos: in_cell(Vec2::new(2.0 * bx as f32, 2.0 * by as f32), ext, jitter(seed)),
                seed,
                neighbours: [NONE; 4],
                stratum: Stratum::WHOLE,
                relight: NO_RELIGHT,
            }
        })
        .collect();
    let block_first = set.samples.len() as u32;
    ctx.run_level(&mut set, &mut levels, -1, &tasks, Store::Base);

    // Level 0: every pixel without a sample; SIB neighbours are the samples of the
    // four blocks nearest to the pixel's centre.
    let tasks: Vec<Task> = (0..w * h)
        .into_par_iter()
        .filter(|&p| set.base[p as usize] == NONE)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            let seed = seed_of(0, x, y);
            // Blocks whose centres (2 b + 1) bracket the pixel's centre (x + 0.5).
            let (bx, by) = ((x as i64 - 1).div_euclid(2), (y as i64 - 1).div_euclid(2));
            Task {
                pos: in_cell(Vec2::new(x as f32, y as f32), Vec2::ONE, jitter(seed)),
                seed,
                neighbours: four_from(bx, by, bw, bh, |bx, by| block_first + by * bw + bx),
                stratum: Stratum::WHOLE,
                relight: NO_RELIGHT,
            }
        })
        .collect();
    ctx.run_level(&mut set, &mut levels, 0, &tasks, Store::Base);
    set.index_pixels();

    // Levels 1..: refine where the criteria say, and always where a small light's
    // image may be.
    let small = small_light_pixels(camera, &tracer.emitter_bounds(), w, h);
    let mut marked: Vec<u32> = Vec::new();
    for level in 1..=refine.max_level as i32 {
        let stored = |x: u32, y: u32| set.with_bits(set.base[(y * w + x) as usize]);
        marked = if level == 1 {
            // Each pixel's stored sample against those of its eight neighbours.
            (0..w * h)
                .into_par_iter()
                .filter(|&p| {
                    let (x, y) = (p % w, p / w);
                    let a = stored(x, y);
                    (y.saturating_sub(1)..=(y + 1).min(h - 1)).any(|ny| {
                        (x.saturating_sub(1)..=(x + 1).min(w - 1))
                            .any(|nx| (nx, ny) != (x, y) && differ([a, stored(nx, ny)], refine))
                    })
                })
                .collect()
        } else {
            // The samples inside each pixel refined at the level before.
            marked
                .into_par_iter()
                .filter(|&p| differ(set.pixel(p).iter().map(|&i| set.with_bits(i)), refine))
                .collect()
        };
        if !small.is_empty() {
            marked.extend_from_slice(&small);
            marked.sort_unstable();
            marked.dedup();
        }
        if marked.is_empty() {
            break;
        }
        let cells = 1u32 << level;
        let size = 1.0 / cells as f32;
        let tasks: Vec<Task> = marked
            .par_iter()
            .flat_map_iter(|&p| {
                let (x, y) = (p % w, p / w);
                // Where this pixel's samples and its neighbours' stored ones on one
                // object differ by their texels alone, the new ones that hit that
                // object take their light and look up only their own texel.
                let takes = match refine.retexture {
                    false => [(NO_OBJECT, Takes::Nothing); 2],
                    true => {
                        let own: Vec<_> = set.pixel(p).iter().map(|&i| set.with_bits(i)).collect();
                        let around: Vec<_> = (y.saturating_sub(1)..=(y + 1).min(h - 1))
                            .flat_map(|ny| {
                                (x.saturating_sub(1)..=(x + 1).min(w - 1))
                                    .filter(move |&nx| (nx, ny) != (x, y))
                                    .map(move |nx| stored(nx, ny))
                            })
                            .collect();
                        relightable(&own, &around, refine)
                    }
                };
                let mut taken = vec![false; (cells * cells) as usize];
                for &i in set.pixel(p) {
                    let s = set.samples[i as usize].pos;
                    let cx = (((s.x - x as f32) * cells as f32) as u32).min(cells - 1);
                    let cy = (((s.y - y as f32) * cells as f32) as u32).min(cells - 1);
                    taken[(cy * cells + cx) as usize] = true;
                }
                let set = &set;
                // The new cells, in the order of their stretches of the light.
                let mut new: Vec<u32> = (0..cells * cells).filter(|&c| !taken[c as usize]).collect();
                new.sort_by_key(|&c| cell_stratum(level as u32, c % cells, c / cells));
                let count = new.len() as u32;
                new.into_iter().enumerate().map(move |(rank, c)| {
                    let (cx, cy) = (x * cells + c % cells, y * cells + c / cells);
                    let seed = seed_of(level, cx, cy);
                    let pos = in_cell(
                        Vec2::new(cx as f32, cy as f32) * size,
                        Vec2::splat(size),
                        jitter(seed),
                    );
                    // The pixel's nearest sample on each such object lends its light.
                    let relight = takes.map(|(object, takes)| match takes {
                        Takes::Nothing => (NONE, Takes::Nothing),
                        _ => (nearest_in(set, p, pos, object), takes),
                    });
                    Task {
                        pos,
                        seed,
                        neighbours: nearest_stored(set, pos),
                        stratum: Stratum {
                            index: rank as u32,
                            count,
                        },
                        relight,
                    }
                })
            })
            .collect();
        ctx.run_level(&mut set, &mut levels, level, &tasks, Store::No);
        set.index_pixels();
    }

    let mut counters = Counters::with_sources(nsrc);
    for (_, c) in levels.iter() {
        counters += c.clone();
    }
    AdaptiveOutput {
        set,
        levels: levels
            .into_iter()
            .map(|(level, c): (i32, Counters)| LevelStats {
                level,
                samples: c.primary_rays,
                diffuse_hits: c.diffuse_hits,
                shadow_rays: c.shadow_rays,
                shadow_rays_saved: c.shadow_rays_saved,
            })
            .collect(),
        counters,
    }
}

/// An emitter whose image on the film has a bounding box of at most this many
/// square pixels is small: its pixels are refined at every level, whatever the
/// criteria say. (A larger image holds several pixels' level-0 samples; one that
/// meets it has the criteria refine round it.)
pub const SMALL_LIGHT_PIXELS: f32 = 16.0;

/// The pixels (sorted) within a pixel of the image of each small emitter (its
/// bounds, `emitters`, projected; [`SMALL_LIGHT_PIXELS`]). A light whose image is a
/// pixel or two across is met by a pixel's one level-0 sample only by chance, and
/// the criteria refine only where a sample met it: a 16 cm downlight 7 m away on a
/// 256 x 144 film (4 x 1.3 pixels, seen from below) came out at a fifth of its light
/// (render seeds 0-2) or two thirds (seed 3), where Mitsuba's 64 samples a pixel
/// find it; now at 0.91-1.08 of Mitsuba's 1024-spp image's light there. Refined to
/// every level, each of its pixels takes 4^max_level samples: a few hundred samples
/// per light.
fn small_light_pixels(camera: &Camera, emitters: &[(Vec3, Vec3)], w: u32, h: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for &(lo, hi) in emitters {
        let corners = (0..8).map(|k| {
            Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let Some(px) = corners.map(|c| camera.project(c)).collect::<Option<Vec<_>>>() else {
            continue;
        };
        let (a, b) = px.iter().fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(a, b), p| {
            let p = Vec2::new(p.0, p.1);
            (a.min(p), b.max(p))
        });
        let ((x0, y0), (x1, y1)) = ((a.x, a.y), (b.x, b.y));
        if !((x1 - x0) * (y1 - y0) <= SMALL_LIGHT_PIXELS) {
            continue;
        }
        if x1 < -1.0 || y1 < -1.0 || x0 > w as f32 + 1.0 || y0 > h as f32 + 1.0 {
            continue;
        }
        let clamp = |v: f32, n: u32| (v.max(0.0) as u32).min(n - 1);
        for y in clamp(y0 - 1.0, h)..=clamp(y1 + 1.0, h) {
            for x in clamp(x0 - 1.0, w)..=clamp(x1 + 1.0, w) {
                out.push(y * w + x);
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The point `jitter` (in [0, 1)^2) of the cell at `origin` of size `size`, kept
/// strictly inside the cell (in f32, `511 + 0.99999994` rounds to 512).
fn in_cell(origin: Vec2, size: Vec2, jitter: Vec2) -> Vec2 {
    let hi = origin + size;
    let inside = |o: f32, h: f32, p: f32| p.clamp(o, h - h.abs().max(1.0) * f32::EPSILON);
    let p = origin + jitter * size;
    Vec2::new(inside(origin.x, hi.x, p.x), inside(origin.y, hi.y, p.y))
}

/// The sample of pixel `p` on `object` nearest to `pos`.
fn nearest_in(set: &SampleSet, p: u32, pos: Vec2, object: u32) -> u32 {
    set.pixel(p)
        .iter()
        .copied()
        .filter(|&i| set.samples[i as usize].object == object)
        .min_by(|&a, &b| {
            let d = |i: u32| set.samples[i as usize].pos.distance_squared(pos);
            d(a).total_cmp(&d(b))
        })
        .unwrap_or(NONE)
}

/// Samples of one object fewer than this, in a pixel and around it, are too few to
/// tell its light from its texels: a pixel's samples across an object's edge hand
/// their light on only where the object holds this many.
const GROUP_SAMPLES: usize = 3;

/// For each object (the first two) among a refined pixel's samples `own`: whether
/// its samples there and among `around` (the neighbours' stored samples) differ by
/// their texels alone ([`texture_alone`]), if they are at least [`GROUP_SAMPLES`].
/// Across an object's edge, each side's light is judged on its own: the object
/// criterion refines the edge for its coverage, and the new samples that hit a side
/// whose light agrees take it.
fn relightable(
    own: &[(&Sample, &[u64])],
    around: &[(&Sample, &[u64])],
    refine: &Refine,
) -> [(u32, Takes); 2] {
    let mut out = [(NO_OBJECT, Takes::Nothing); 2];
    let mut k = 0;
    for (i, (s, _)) in own.iter().enumerate() {
        if k == out.len() {
            break;
        }
        let object = s.object;
        if object == NO_OBJECT || own[..i].iter().any(|(f, _)| f.object == object) {
            continue;
        }
        let group = || {
            own.iter()
                .chain(around)
                .filter(|(s, _)| s.object == object)
                .copied()
        };
        let takes = match group().count() >= GROUP_SAMPLES {
            true => texture_alone(group(), refine),
            false => Takes::Nothing,
        };
        out[k] = (object, takes);
        k += 1;
    }
    out
}

/// Whether `samples` (each with its point bits) differ by their texels alone: all on
/// one object whose texture alone scales their diffuse light ([`Lighting`]), and
/// with every sample's texel replaced by the first's, the refinement criteria
/// ([`differ`]) no longer fire: then new samples there may take all the light of the
/// nearest of them. If the criteria fire only by the glossy and mirror parts (a
/// glossy lobe's noise), the new samples take its diffuse light alone.
fn texture_alone<'s>(samples: impl IntoIterator<Item = (&'s Sample, &'s [u64])>, refine: &Refine) -> Takes {
    let mut kept: Vec<(&Sample, Lighting, &[u64])> = Vec::with_capacity(13);
    for (s, bits) in samples {
        let Some(l) = s.lighting else {
            return Takes::Nothing;
        };
        if kept.first().is_some_and(|(f, _, _)| f.object != s.object) {
            return Takes::Nothing;
        }
        kept.push((s, l, bits));
    }
    let Some(albedo) = kept.first().map(|(_, l, _)| l.albedo()) else {
        return Takes::Nothing;
    };
    let relit = |part: &dyn Fn(&Sample, &Lighting) -> Rgb| -> Vec<(Sample, &[u64])> {
        kept.iter()
            .map(|(s, l, bits)| {
                let value = part(s, l) + albedo * l.per_albedo();
                (Sample { value, ..**s }, *bits)
            })
            .collect()
    };
    let quiet = |v: &[(Sample, &[u64])]| !differ(v.iter().map(|(s, b)| (s, *b)), refine);
    if quiet(&relit(&|s, l| s.value - l.diffuse())) {
        Takes::All
    } else if quiet(&relit(&|_, _| Vec3::ZERO)) {
        Takes::Diffuse
    } else {
        Takes::Nothing
    }
}

/// The stored samples of the (up to) four pixels whose centres surround `pos`.
fn nearest_stored(set: &SampleSet, pos: Vec2) -> [u32; 4] {
    let (x0, y0) = ((pos.x - 0.5).floor() as i64, (pos.y - 0.5).floor() as i64);
    four_from(x0, y0, set.width, set.height, |x, y| {
        set.base[(y * set.width + x) as usize]
    })
}

/// `at(x, y)` of the cells `(x0..=x0 + 1, y0..=y0 + 1)` inside a `w` x `h` grid, packed
/// at the front; the rest [`NONE`].
fn four_from(x0: i64, y0: i64, w: u32, h: u32, at: impl Fn(u32, u32) -> u32) -> [u32; 4] {
    let mut nb = [NONE; 4];
    let mut k = 0;
    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let (x, y) = (x0 + dx, y0 + dy);
        if x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
            nb[k] = at(x as u32, y as u32);
            k += 1;
        }
    }
    nb
}

/// Which stretch of each group of light points the sample in cell `(x, y)` of its
/// pixel's `2^L x 2^L` takes at anti-aliasing level `level` (see [`Stratum`]). At
/// level 2 the light's quarters (the index's top bits) are laid out as a Latin
/// square of the cells: every row, column and quarter of the pixel meets all four,
/// and the quarter of the pixel picks the stretch within them. Row by row elsewhere.
fn cell_stratum(level: u32, x: u32, y: u32) -> u32 {
    match level {
        2 => {
            let quarter = (x & 1 ^ y >> 1) | (y & 1 ^ x >> 1) << 1;
            quarter << 2 | x >> 1 | (y >> 1) << 1
        }
        _ => (y << level) + x,
    }
}

/// Samples both white on the display differ when one has this many times the other's
/// radiance (largest channel, before the exposure): the clipped display values cannot
/// tell them apart.
const HDR_RATIO: f32 = 16.0;

/// Whether the refinement criteria fire among `samples` (each with its point bits,
/// [`SampleSet::point_bits`]): object, shadow (a point or spot light lit at one,
/// shadowed at another, whatever the number of lights) or difference.
fn differ<'s, I>(samples: I, refine: &Refine) -> bool
where
    I: IntoIterator<Item = (&'s Sample, &'s [u64])> + Clone,
{
    let (mut object, mut words) = (None, 0);
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    // Radiance, where the display values are white: the brightest sample's and the
    // dimmest's (largest channel).
    let (mut dim, mut bright) = (f32::INFINITY, 0.0f32);
    for (s, bits) in samples.clone() {
        if *object.get_or_insert(s.object) != s.object {
            return true;
        }
        words = bits.len() / 2;
        let shown = exposed(s.value, refine.exposure);
        lo = lo.min(shown);
        hi = hi.max(shown);
        let v = s.value.max_element();
        dim = dim.min(v);
        bright = bright.max(v);
    }
    // The display's encoding rises with the radiance, so the lowest and highest
    // display values per channel are those of the lowest and highest radiance: two
    // encodings per comparison, not one per sample (level 1 compares every pixel
    // with its eight neighbours).
    let (lo, hi) = (encode(lo), encode(hi));
    let white = hi.max_element() >= 1.0;
    // Among samples white on the display, one many times brighter than another: a
    // light's image smaller than the pixel (the sun in a mirror ball), which one
    // sample would otherwise carry to the whole pixel.
    if white && bright > HDR_RATIO * dim {
        return true;
    }
    (0..words).any(|j| {
        let (mut lit, mut dark) = (0u64, 0u64);
        for (_, bits) in samples.clone() {
            let (known, on) = (bits[j], bits[words + j]);
            lit |= known & on;
            dark |= known & !on;
        }
        lit & dark != 0
    }) || (hi - lo).max_element() > refine.contrast
}

/// Radiance `v` with `exposure` stops, clipped to 0..1: what the display encodes.
fn exposed(v: Rgb, exposure: f32) -> Vec3 {
    let v = if exposure == 0.0 { v } else { v * exposure.exp2() };
    v.clamp(Vec3::ZERO, Vec3::ONE)
}

/// The display (sRGB) encoding of exposed radiance `v`.
fn encode(v: Vec3) -> Vec3 {
    Vec3::from_array(v.to_array().map(srgb_encode))
}

/// The samples of one work item of a level, with their SIB records (record lengths
/// and entries, if stored) and counts.
struct Chunk {
    samples: Vec<Sample>,
    /// The samples' point bits, [`SampleSet::point_bits`]'s layout.
    point: Vec<u64>,
    lens: Vec<u32>,
    entries: Vec<Entry>,
    counters: Counters,
}

/// What every level of one render shares.
struct LevelCtx<'a> {
    tracer: &'a Tracer<'a>,
    camera: &'a Camera,
    refine: &'a Refine,
    /// Per ray-traced source, its place among the point and spot lights (the shadow
    /// criterion's bit), or `None` for other sources.
    point: Vec<Option<u32>>,
    /// The number of point and spot lights.
    point_count: usize,
    nsrc: usize,
    progress: &'a dyn Progress,
}

/// Whether a level's samples are stored in the SIB.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Store {
    /// Levels -1 and 0: each sample is its pixel's stored sample, with its record.
    Base,
    /// Anti-aliasing levels: the samples read the SIB but store nothing.
    No,
}

impl LevelCtx<'_> {
    /// Takes the samples `tasks` of one level in parallel and appends them to `set`
    /// (as their pixels' stored samples, with SIB records, if `store` is `Base`), and
    /// the level's counts to `levels`.
    fn run_level(
        &self,
        set: &mut SampleSet,
        levels: &mut Vec<(i32, Counters)>,
        level: i32,
        tasks: &[Task],
        store: Store,
    ) {
        let (tracer, camera, refine, point, nsrc) =
            (self.tracer, self.camera, self.refine, &self.point, self.nsrc);
        let first_sample = set.samples.len() as u32;
        let store = store == Store::Base;
        self.progress
            .start(&format!("level {level:>2}"), tasks.len() as u64);
        let read: &SampleSet = set;
        // Every chunk a task of its own: rayon otherwise runs a quarter of the level
        // as one piece on one thread, and samples' costs vary so much (mirrors, shadow
        // edges) that the other thread then waits (view b: level 2 took 0.62 s on one
        // thread and 0.94 s on the other; now 0.79 s each).
        let chunks: Vec<Chunk> = tasks
            .par_chunks(CHUNK)
            .with_max_len(1)
            .map(|chunk| {
                let mut counters = Counters::with_sources(nsrc);
                let mut samples = Vec::with_capacity(chunk.len());
                let words = 2 * self.point_count.div_ceil(64);
                let mut point_bits = Vec::with_capacity(chunk.len() * words);
                let mut lens = Vec::with_capacity(if store { chunk.len() } else { 0 });
                let mut entries = Vec::new();
                let mut record = Vec::new();
                for t in chunk {
                    let mut ns = [Neighbour {
                        object: NO_OBJECT,
                        record: &[],
                    }; 4];
                    let mut k = 0;
                    for &i in t.neighbours.iter().filter(|&&i| i != NONE) {
                        ns[k] = Neighbour {
                            object: read.samples[i as usize].object,
                            record: read.record(i),
                        };
                        k += 1;
                    }
                    let mut q = SibQuery::new(refine.sib, &ns[..k], &mut record);
                    if !store && refine.sib {
                        // Each of the pixel's 4^L cells' sample casts 1 / 4^L of
                        // the rays, its stretch of each group of light points.
                        q.ray_divisor = 1 << (2 * level);
                        q.stratum = t.stratum;
                    }
                    let ray =
                        camera.ray_through_lens(t.pos.x, t.pos.y, uniform2(derive(t.seed, Stream::Lens)));
                    counters.primary_rays += 1;
                    // A retextured sample: the light of the samples it takes it from.
                    q.given = t.relight.map(|(i, takes)| {
                        let f = read.samples.get(i as usize)?;
                        let l = f.lighting?;
                        Some(Given {
                            object: f.object,
                            per_albedo: l.per_albedo(),
                            normal: l.normal(),
                            rest: (takes == Takes::All).then(|| f.value - l.diffuse()),
                        })
                    });
                    let (cast_before, saved_before) = (counters.shadow_rays, counters.shadow_rays_saved);
                    let value =
                        tracer.radiance_sib(&ray, derive(t.seed, Stream::Path), &mut counters, &mut q);
                    let object = q.object;
                    let at = point_bits.len();
                    point_bits.resize(at + words, 0);
                    sib::point_bits(q.record, point, &mut point_bits[at..]);
                    samples.push(Sample {
                        pos: t.pos,
                        value,
                        object,
                        level: level as i8,
                        rays: (counters.shadow_rays - cast_before).min(u16::MAX.into()) as u16,
                        saved: (counters.shadow_rays_saved - saved_before).min(u16::MAX.into()) as u16,
                        lighting: q.lighting,
                    });
                    if store {
                        lens.push(record.len() as u32);
                        entries.extend_from_slice(&record);
                    }
                }
                self.progress.advance(chunk.len() as u64);
                Chunk {
                    samples,
                    point: point_bits,
                    lens,
                    entries,
                    counters,
                }
            })
            .collect();
        self.progress.finish();
        let mut total = Counters::with_sources(nsrc);
        for Chunk {
            samples,
            point: point_bits,
            lens,
            entries,
            counters,
        } in chunks
        {
            set.samples.extend(samples);
            set.point.extend(point_bits);
            if store {
                let mut at = *set.first.last().expect("first has a start");
                for l in lens {
                    at += l;
                    set.first.push(at);
                }
                set.entries.extend(entries);
            }
            total += counters;
        }
        if store {
            for s in first_sample..set.samples.len() as u32 {
                let p = set.pixel_of(set.samples[s as usize].pos);
                set.base[p as usize] = s;
            }
        }
        levels.push((level, total));
    }
}

#[cfg(test)]
mod tests;
