//! Image samples and their reconstruction into pixels with a filter.
//!
//! Samples are kept (position and radiance) and pixels are made afterwards as a
//! weighted average of the samples near each pixel centre, each sample weighted by the
//! filter and by its share of its own pixel (1 / the pixel's samples, so that pixels
//! the adaptive sampler refined do not outweigh their neighbours): the paper's
//! "weighted average of the samples within the pixel areas" is the `box` filter; the default
//! `gaussian` is Mitsuba's (standard deviation 0.5 pixel, radius 2 pixels), so that
//! images compare with Mitsuba's at edges.

use glam::Vec3;
use rayon::prelude::*;

use crate::image::Image;

/// One image sample: a film position in pixels and the radiance found there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilmSample {
    /// Film x in pixels (0 = left edge).
    pub x: f32,
    /// Film y in pixels (0 = top edge).
    pub y: f32,
    /// Radiance.
    pub value: Vec3,
}

/// Pixel reconstruction filter.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    /// Equal weights for the samples inside the pixel's square (the paper's).
    Box,
    /// Mitsuba's Gaussian: stddev 0.5 px, radius 2 px, shifted to reach 0 at the radius.
    #[default]
    Gaussian,
}

impl Filter {
    /// The name used on the command line and in the statistics.
    pub fn name(self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Gaussian => "gaussian",
        }
    }

    /// Half-width of the filter's support, in pixels.
    pub fn radius(self) -> f32 {
        match self {
            Filter::Box => 0.5,
            Filter::Gaussian => 2.0,
        }
    }

    /// 1D weight at offset `d` from the pixel centre; the 2D weight is separable.
    pub fn eval(self, d: f32) -> f32 {
        match self {
            Filter::Box => {
                if d.abs() <= 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Gaussian => {
                const STDDEV: f32 = 0.5;
                let alpha = -1.0 / (2.0 * STDDEV * STDDEV);
                let edge = (alpha * 4.0).exp(); // at radius 2
                ((alpha * d * d).exp() - edge).max(0.0)
            }
        }
    }
}

/// Samples grouped by the pixel they were taken in.
#[derive(Debug, Clone, Default)]
pub struct SampleBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `start[i]..start[i+1]` are pixel i's samples in `samples`.
    pub start: Vec<u32>,
    /// All samples.
    pub samples: Vec<FilmSample>,
}

impl SampleBuffer {
    /// Builds a buffer from per-row sample lists, grouping the samples by the pixel
    /// their film position falls in.
    pub fn from_rows(width: u32, height: u32, rows: Vec<Vec<FilmSample>>) -> Self {
        let total: usize = rows.iter().map(Vec::len).sum();
        let mut samples = Vec::with_capacity(total);
        for r in rows {
            samples.extend(r);
        }
        let n = (width * height) as usize;
        let mut start = vec![0u32; n + 1];
        for s in &samples {
            start[pixel_index(s, width, height) + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        // Stable placement by pixel (samples arrive row by row, mostly in order).
        let mut out = vec![
            FilmSample {
                x: 0.0,
                y: 0.0,
                value: Vec3::ZERO
            };
            samples.len()
        ];
        let mut fill = start.clone();
        for s in samples {
            let p = pixel_index(&s, width, height);
            out[fill[p] as usize] = s;
            fill[p] += 1;
        }
        SampleBuffer {
            width,
            height,
            start,
            samples: out,
        }
    }

    /// The samples taken in pixel `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> &[FilmSample] {
        let i = (y * self.width + x) as usize;
        &self.samples[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// Reconstructs the image with `filter`.
    pub fn reconstruct(&self, filter: Filter) -> Image {
        let (w, h) = (self.width, self.height);
        let reach = filter.radius().ceil() as i64;
        let mut img = Image::new(w, h);
        img.pixels
            .par_chunks_mut(w as usize)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, out) in row.iter_mut().enumerate() {
                    let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
                    let mut sum = Vec3::ZERO;
                    let mut wsum = 0.0;
                    for ny in (y as i64 - reach).max(0)..=(y as i64 + reach).min(h as i64 - 1) {
                        for nx in (x as i64 - reach).max(0)..=(x as i64 + reach).min(w as i64 - 1) {
                            let samples = self.pixel(nx as u32, ny as u32);
                            let share = 1.0 / samples.len().max(1) as f32;
                            for s in samples {
                                let wgt = filter.eval(s.x - cx) * filter.eval(s.y - cy) * share;
                                if wgt > 0.0 {
                                    sum += s.value * wgt;
                                    wsum += wgt;
                                }
                            }
                        }
                    }
                    *out = if wsum > 0.0 { sum / wsum } else { Vec3::ZERO };
                }
            });
        img
    }
}

/// A film that accumulates filter-weighted sums of samples as they come (the uniform
/// sampler's), so that memory follows the pixels, not the samples: rows
/// `first_row..first_row + rows` of a `width`-pixel image. A sample splats onto the
/// pixels within the filter's reach of its own pixel, with the weights
/// [`SampleBuffer::reconstruct`] would give it (for `share`, its pixel's samples).
#[derive(Debug, Clone)]
pub struct Film {
    width: u32,
    first_row: i64,
    rows: u32,
    filter: Filter,
    sum: Vec<Vec3>,
    weight: Vec<f32>,
}

impl Film {
    /// An empty film for rows `first_row..first_row + rows` (rows outside the image
    /// are kept too, and dropped when merged).
    pub fn new(width: u32, first_row: i64, rows: u32, filter: Filter) -> Self {
        let n = (width * rows) as usize;
        Film {
            width,
            first_row,
            rows,
            filter,
            sum: vec![Vec3::ZERO; n],
            weight: vec![0.0; n],
        }
    }

    /// The strip of rows that the samples taken in image rows `y0..y1` reach.
    pub fn for_rows(width: u32, y0: u32, y1: u32, filter: Filter) -> Self {
        let reach = filter.radius().ceil() as i64;
        Film::new(width, y0 as i64 - reach, (y1 - y0) + 2 * reach as u32, filter)
    }

    /// Adds sample `s`, whose pixel holds `1 / share` samples, within an image of
    /// `height` rows.
    pub fn add(&mut self, s: &FilmSample, share: f32, height: u32) {
        let reach = self.filter.radius().ceil() as i64;
        let px = (s.x.max(0.0) as i64).min(self.width as i64 - 1);
        let py = (s.y.max(0.0) as i64).min(height as i64 - 1);
        let y_lo = (py - reach).max(0).max(self.first_row);
        let y_hi = (py + reach)
            .min(height as i64 - 1)
            .min(self.first_row + self.rows as i64 - 1);
        for y in y_lo..=y_hi {
            let wy = self.filter.eval(s.y - (y as f32 + 0.5));
            let row = ((y - self.first_row) * self.width as i64) as usize;
            for x in (px - reach).max(0)..=(px + reach).min(self.width as i64 - 1) {
                let wgt = self.filter.eval(s.x - (x as f32 + 0.5)) * wy * share;
                if wgt > 0.0 {
                    self.sum[row + x as usize] += s.value * wgt;
                    self.weight[row + x as usize] += wgt;
                }
            }
        }
    }

    /// Adds the sums of `other` (a strip of the same width) where the rows overlap.
    pub fn merge(&mut self, other: &Film) {
        let w = self.width as usize;
        for r in 0..other.rows as i64 {
            let y = other.first_row + r;
            if y < self.first_row || y >= self.first_row + self.rows as i64 {
                continue;
            }
            let (a, b) = (((y - self.first_row) as usize) * w, r as usize * w);
            for x in 0..w {
                self.sum[a + x] += other.sum[b + x];
                self.weight[a + x] += other.weight[b + x];
            }
        }
    }

    /// The pixels: weighted sums over weights (black where no sample reached).
    pub fn image(&self) -> Image {
        let mut img = Image::new(self.width, self.rows);
        for (px, (s, &w)) in img.pixels.iter_mut().zip(self.sum.iter().zip(&self.weight)) {
            *px = if w > 0.0 { *s / w } else { Vec3::ZERO };
        }
        img
    }
}

fn pixel_index(s: &FilmSample, width: u32, height: u32) -> usize {
    let x = (s.x.max(0.0) as u32).min(width - 1);
    let y = (s.y.max(0.0) as u32).min(height - 1);
    (y * width + x) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_reaches_zero_at_its_radius_and_peaks_at_the_centre() {
        let f = Filter::Gaussian;
        assert_eq!(f.eval(2.0), 0.0);
        assert_eq!(f.eval(3.0), 0.0);
        assert!(f.eval(0.0) > f.eval(0.5) && f.eval(0.5) > f.eval(1.0) && f.eval(1.0) > 0.0);
        assert_eq!(Filter::Box.eval(0.49), 1.0);
        assert_eq!(Filter::Box.eval(0.51), 0.0);
    }

    #[test]
    fn constant_samples_reconstruct_to_the_constant_with_either_filter() {
        let (w, h) = (7, 5);
        let rows: Vec<Vec<FilmSample>> = (0..h)
            .map(|y| {
                (0..w)
                    .flat_map(|x| {
                        [(0.25, 0.25), (0.75, 0.6)].map(|(dx, dy)| FilmSample {
                            x: x as f32 + dx,
                            y: y as f32 + dy,
                            value: Vec3::new(0.2, 0.4, 0.8),
                        })
                    })
                    .collect()
            })
            .collect();
        let buf = SampleBuffer::from_rows(w, h, rows);
        assert_eq!(buf.pixel(3, 2).len(), 2);
        for f in [Filter::Box, Filter::Gaussian] {
            let img = buf.reconstruct(f);
            for p in &img.pixels {
                assert!((*p - Vec3::new(0.2, 0.4, 0.8)).length() < 1e-6);
            }
        }
    }

    #[test]
    fn box_filter_averages_only_the_pixels_own_samples() {
        let rows = vec![vec![
            FilmSample {
                x: 0.2,
                y: 0.5,
                value: Vec3::ONE,
            },
            FilmSample {
                x: 0.4,
                y: 0.5,
                value: Vec3::ZERO,
            },
            FilmSample {
                x: 1.5,
                y: 0.5,
                value: Vec3::splat(4.0),
            },
        ]];
        let img = SampleBuffer::from_rows(2, 1, rows).reconstruct(Filter::Box);
        assert_eq!(img.pixels, vec![Vec3::splat(0.5), Vec3::splat(4.0)]);
    }

    /// The film's running sums give the image the kept samples give, strip by strip
    /// as the uniform sampler merges them (varied values, both filters, 3 per pixel).
    #[test]
    fn film_strips_sum_to_the_reconstruction_of_the_kept_samples() {
        let (w, h, spp) = (9u32, 6u32, 3u32);
        let sample = |x: u32, y: u32, k: u32| {
            let t = (x * 7 + y * 13 + k * 5) as f32;
            FilmSample {
                x: x as f32 + (0.1 + 0.37 * k as f32).fract(),
                y: y as f32 + (0.8 - 0.29 * k as f32).rem_euclid(1.0),
                value: Vec3::new(t.sin().abs(), (0.3 * t).cos().abs(), 0.01 * t),
            }
        };
        let rows: Vec<Vec<FilmSample>> = (0..h)
            .map(|y| {
                (0..w)
                    .flat_map(|x| (0..spp).map(move |k| sample(x, y, k)))
                    .collect()
            })
            .collect();
        for f in [Filter::Box, Filter::Gaussian] {
            let want = SampleBuffer::from_rows(w, h, rows.clone()).reconstruct(f);
            let mut film = Film::new(w, 0, h, f);
            for (y, row) in rows.iter().enumerate() {
                let mut strip = Film::for_rows(w, y as u32, y as u32 + 1, f);
                for s in row {
                    strip.add(s, 1.0 / spp as f32, h);
                }
                film.merge(&strip);
            }
            let got = film.image();
            for (a, b) in got.pixels.iter().zip(&want.pixels) {
                assert!((*a - *b).abs().max_element() < 1e-5, "{f:?}: {a} vs {b}");
            }
        }
    }
}
