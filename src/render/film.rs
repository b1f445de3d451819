//! Image samples and their reconstruction into pixels with a filter.
//!
//! Each pixel is a weighted average of the samples near its centre, each sample
//! weighted by the filter and by its share of its own pixel (1 / the pixel's samples, so
//! that pixels the adaptive sampler refined do not outweigh their neighbours): the
//! paper's "weighted average of the samples within the pixel areas" is the `box` filter;
//! the default `gaussian` is Mitsuba's (standard deviation 0.5 pixel, radius 2 pixels),
//! so that images compare with Mitsuba's at edges. Samples are splatted into a [`Film`]
//! of weighted sums as they come ([`film_rows`]), so memory follows the pixels, not the
//! samples.

use std::f32::consts::PI;

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

pub use crate::scene::Filter;

impl Filter {
    /// Half-width of the filter's support, in pixels.
    pub fn radius(self) -> f32 {
        match self {
            Filter::Box => 0.5,
            Filter::Tent => 1.0,
            Filter::Gaussian | Filter::Mitchell | Filter::Catmullrom => 2.0,
            Filter::Lanczos => 3.0,
        }
    }

    /// Whether some weights are below 0.
    pub fn dips(self) -> bool {
        matches!(self, Filter::Mitchell | Filter::Catmullrom | Filter::Lanczos)
    }

    /// 1D weight at offset `d` from the pixel centre; the 2D weight is separable.
    /// Mitchell's, Catmull and Rom's and Lanczos's dip below 0 (they sharpen).
    pub fn eval(self, d: f32) -> f32 {
        let x = d.abs();
        if x > self.radius() {
            return 0.0;
        }
        match self {
            Filter::Box => 1.0,
            Filter::Tent => 1.0 - x,
            Filter::Gaussian => {
                const STDDEV: f32 = 0.5;
                let alpha = -1.0 / (2.0 * STDDEV * STDDEV);
                let edge = (alpha * 4.0).exp(); // at radius 2
                ((alpha * x * x).exp() - edge).max(0.0)
            }
            Filter::Mitchell => cubic(x, 1.0 / 3.0, 1.0 / 3.0),
            Filter::Catmullrom => cubic(x, 0.0, 0.5),
            Filter::Lanczos => {
                if x < f32::EPSILON {
                    return 1.0;
                }
                let (a, b) = (PI * x, PI * x / 3.0);
                a.sin() * b.sin() / (a * b)
            }
        }
    }
}

/// Mitchell and Netravali's cubic of parameters `b` and `c` at `x` in [0, 2].
fn cubic(x: f32, b: f32, c: f32) -> f32 {
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else {
        (-b - 6.0 * c) * x3 + (6.0 * b + 30.0 * c) * x2 + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c)
    };
    v / 6.0
}

/// Filter-weighted sums of samples for rows `first_row..first_row + rows` of a
/// `width`-pixel image: a sample splats onto the pixels within the filter's reach of its
/// own pixel, weighted by the filter and its `share` of its pixel.
#[derive(Debug, Clone)]
pub struct Film {
    width: u32,
    first_row: i64,
    rows: u32,
    filter: Filter,
    sum: Vec<Vec3>,
    weight: Vec<f32>,
    /// With a filter that dips below 0: the sums of the positive weights alone, which
    /// a pixel falls back to where its negative weights nearly cancel the rest (few
    /// samples about it, all in a lobe); empty otherwise.
    positive: Vec<(Vec3, f32)>,
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
            positive: if filter.dips() {
                vec![(Vec3::ZERO, 0.0); n]
            } else {
                Vec::new()
            },
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
                let i = row + x as usize;
                if wgt != 0.0 {
                    self.sum[i] += s.value * wgt;
                    self.weight[i] += wgt;
                }
                if wgt > 0.0 {
                    if let Some(p) = self.positive.get_mut(i) {
                        p.0 += s.value * wgt;
                        p.1 += wgt;
                    }
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
                if let (Some(p), Some(q)) = (self.positive.get_mut(a + x), other.positive.get(b + x)) {
                    p.0 += q.0;
                    p.1 += q.1;
                }
            }
        }
    }

    /// The pixels: weighted sums over weights (black where no sample reached). With
    /// a filter that dips below 0, a pixel whose weights add up to under half its
    /// positive ones takes the positive ones alone.
    pub fn image(&self) -> Image {
        let mut img = Image::new(self.width, self.rows);
        for (i, (px, (s, &w))) in img
            .pixels
            .iter_mut()
            .zip(self.sum.iter().zip(&self.weight))
            .enumerate()
        {
            *px = match self.positive.get(i) {
                Some(&(ps, pw)) if !(w > 0.5 * pw) => {
                    if pw > 0.0 {
                        ps / pw
                    } else {
                        Vec3::ZERO
                    }
                }
                _ if w > 0.0 => *s / w,
                _ => Vec3::ZERO,
            };
        }
        img
    }
}

/// Films an image of `width x height` row by row, in parallel, one row per task (rayon's
/// larger pieces unbalance the threads when rows cost differently): `row(y, strip)`
/// adds the samples taken in pixel row `y` to `strip` (the rows its filter reaches) and
/// returns whatever else the row made. The strips are added in row order, so the image
/// does not depend on the threads.
pub fn film_rows<T: Send>(
    width: u32,
    height: u32,
    filter: Filter,
    row: impl Fn(u32, &mut Film) -> T + Sync,
) -> (Image, Vec<T>) {
    let strips: Vec<(Film, T)> = (0..height)
        .into_par_iter()
        .with_max_len(1)
        .map(|y| {
            let mut strip = Film::for_rows(width, y, y + 1, filter);
            let made = row(y, &mut strip);
            (strip, made)
        })
        .collect();
    let mut film = Film::new(width, 0, height, filter);
    let mut made = Vec::with_capacity(strips.len());
    for (strip, m) in strips {
        film.merge(&strip);
        made.push(m);
    }
    (film.image(), made)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Films `samples` (each with its pixel's sample count) on a `w x h` image.
    fn film(w: u32, h: u32, f: Filter, samples: &[(FilmSample, u32)]) -> Image {
        film_rows(w, h, f, |y, strip| {
            for (s, n) in samples.iter().filter(|(s, _)| s.y as u32 == y) {
                strip.add(s, 1.0 / *n as f32, h);
            }
        })
        .0
    }

    /// Closed forms: the tent's line, Mitchell and Netravali's cubic (B = C = 1/3:
    /// 16/18 at 0, 1/18 at 1; Catmull-Rom interpolates, 1 at 0 and 0 at 1), Lanczos
    /// at 1/2: sin(pi/2) sin(pi/6) / (pi^2/12). Each is 0 at its radius, and the
    /// names are Mitsuba's.
    #[test]
    fn filters_have_their_closed_forms() {
        let near = |a: f32, b: f32| (a - b).abs() < 1e-6;
        assert!(near(Filter::Tent.eval(0.25), 0.75) && near(Filter::Tent.eval(-0.5), 0.5));
        assert!(near(Filter::Mitchell.eval(0.0), 16.0 / 18.0));
        assert!(near(Filter::Mitchell.eval(1.0), 1.0 / 18.0));
        assert!(Filter::Mitchell.eval(1.5) < 0.0);
        assert!(near(Filter::Catmullrom.eval(0.0), 1.0) && near(Filter::Catmullrom.eval(1.0), 0.0));
        assert!(near(Filter::Lanczos.eval(0.0), 1.0) && near(Filter::Lanczos.eval(2.0), 0.0));
        assert!(near(Filter::Lanczos.eval(0.5), 0.5 / (PI * PI / 12.0)));
        for f in Filter::ALL {
            assert!(near(f.eval(f.radius()), 0.0) || f == Filter::Box, "{f:?}");
            assert_eq!(f.eval(f.radius() + 0.01), 0.0);
            assert_eq!(f.dips(), (0..300).any(|k| f.eval(k as f32 * 0.01) < 0.0), "{f:?}");
        }
        let names: Vec<&str> = Filter::ALL.iter().map(|f| f.name()).collect();
        assert_eq!(
            names,
            ["box", "tent", "gaussian", "mitchell", "catmullrom", "lanczos"]
        );
    }

    /// A pixel whose only samples lie in a filter's negative lobes still gets their
    /// light, not a black, negative or blown-up value.
    #[test]
    fn a_pixel_reached_only_by_negative_lobes_takes_the_positive_weights() {
        // One sample, 1.5 px right of pixel 0's centre: Mitchell's weight is below 0
        // there for pixel 0 and above 0 for pixels 1 and 2.
        let s = FilmSample {
            x: 2.0,
            y: 0.5,
            value: Vec3::splat(3.0),
        };
        assert!(Filter::Mitchell.eval(1.5) < 0.0);
        let img = film(4, 1, Filter::Mitchell, &[(s, 1)]);
        for p in &img.pixels {
            assert!(p.is_finite() && p.min_element() >= 0.0, "{p}");
        }
        assert_eq!(img.pixels[1], Vec3::splat(3.0));
        assert_eq!(img.pixels[0], Vec3::ZERO);
    }

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
        let samples: Vec<(FilmSample, u32)> = (0..h)
            .flat_map(|y| {
                (0..w).flat_map(move |x| {
                    [(0.25, 0.25), (0.75, 0.6)].map(|(dx, dy)| {
                        let s = FilmSample {
                            x: x as f32 + dx,
                            y: y as f32 + dy,
                            value: Vec3::new(0.2, 0.4, 0.8),
                        };
                        (s, 2)
                    })
                })
            })
            .collect();
        for f in Filter::ALL {
            let img = film(w, h, f, &samples);
            for p in &img.pixels {
                assert!((*p - Vec3::new(0.2, 0.4, 0.8)).length() < 1e-6);
            }
        }
    }

    #[test]
    fn box_filter_averages_only_the_pixels_own_samples() {
        let at = |x: f32, v: f32, n: u32| {
            let s = FilmSample {
                x,
                y: 0.5,
                value: Vec3::splat(v),
            };
            (s, n)
        };
        let img = film(
            2,
            1,
            Filter::Box,
            &[at(0.2, 1.0, 2), at(0.4, 0.0, 2), at(1.5, 4.0, 1)],
        );
        assert_eq!(img.pixels, vec![Vec3::splat(0.5), Vec3::splat(4.0)]);
    }

    /// A refined pixel does not outweigh its neighbour: pixel 0 has one sample (1) at
    /// its centre, pixel 1 four samples (0) at its centre; with the Gaussian, pixel 0 is
    /// g(0) / (g(0) + g(1)) (the four count as one), whatever the threads.
    #[test]
    fn each_pixel_weighs_as_one_sample_and_threads_do_not_matter() {
        let centre = |x: f32, v: f32, n: u32| {
            let s = FilmSample {
                x,
                y: 0.5,
                value: Vec3::splat(v),
            };
            (s, n)
        };
        let mut samples = vec![centre(0.5, 1.0, 1)];
        samples.extend((0..4).map(|_| centre(1.5, 0.0, 4)));
        let f = Filter::Gaussian;
        let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
        let one = pool(1).install(|| film(2, 1, f, &samples));
        let two = pool(2).install(|| film(2, 1, f, &samples));
        assert_eq!(one, two);
        let (g0, g1) = (f.eval(0.0), f.eval(1.0));
        assert!(
            (one.pixels[0].x - g0 / (g0 + g1)).abs() < 1e-6,
            "{}",
            one.pixels[0]
        );
        assert!(
            (one.pixels[1].x - g1 / (g1 + g0)).abs() < 1e-6,
            "{}",
            one.pixels[1]
        );
    }
}
