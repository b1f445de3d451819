//! The renderer's debug pictures, in display values (0..1): the selection map (which
//! sources are ray traced on each patch), the shadow image of each ray-traced source
//! (the paper's Figs. 4 and 5), samples per pixel and shadow rays per pixel.

use glam::Vec3;
use rayon::prelude::*;

use super::adaptive::SampleSet;
use crate::accel::Accel;
use crate::camera::Camera;
use crate::image::Image;
use crate::scene::{Rgb, Scene};
use crate::selection::Selection;

/// A distinct colour for ray-traced source `i` (golden-angle hues).
pub fn source_colour(i: usize) -> Rgb {
    let h = (i as f32 * 0.381_966).fract() * 6.0;
    let x = 1.0 - ((h % 2.0) - 1.0).abs();
    match h as u32 {
        0 => Vec3::new(1.0, x, 0.0),
        1 => Vec3::new(x, 1.0, 0.0),
        2 => Vec3::new(0.0, 1.0, x),
        3 => Vec3::new(0.0, x, 1.0),
        4 => Vec3::new(x, 0.0, 1.0),
        _ => Vec3::new(1.0, 0.0, x),
    }
}

/// A picture of the selection seen through `camera` (`width x height`, one ray per
/// pixel centre): each patch in the mean colour of the sources ray traced on it
/// ([`source_colour`]), brighter the more shadow rays per hit it casts (log scale up
/// to the most any patch casts); dark grey where nothing is ray traced; patch
/// boundaries drawn dark. Returns the image in display values (0..1).
pub fn selection_map(
    scene: &Scene,
    accel: &dyn Accel,
    camera: &Camera,
    sel: &Selection,
    width: u32,
    height: u32,
) -> Image {
    let mesh = &sel.solution.mesh;
    let max_rays = (0..mesh.patches.len() as u32)
        .map(|p| sel.rays(p))
        .max()
        .unwrap_or(0);
    let patch_ids: Vec<Option<u32>> = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            accel.intersect(&ray).map(|hit| {
                let front = {
                    let m = &scene.shapes[hit.shape as usize].mesh;
                    let [a, b, c] = m.triangle(hit.tri as usize);
                    (b - a).cross(c - a).dot(ray.dir) < 0.0
                };
                mesh.patch_at(scene, &hit, front)
            })
        })
        .collect();
    let mut img = Image::new(width, height);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let Some(p) = patch_ids[i] else { continue };
            let picks = sel.picks(p);
            let mut c = if picks.is_empty() {
                Vec3::splat(0.15)
            } else {
                let hue = picks
                    .iter()
                    .map(|k| source_colour(k.source as usize))
                    .sum::<Vec3>()
                    / picks.len() as f32;
                let r = sel.rays(p) as f32;
                let level = (1.0 + r).ln() / (1.0 + max_rays.max(1) as f32).ln();
                hue * (0.3 + 0.7 * level)
            };
            let edge = (x + 1 < width && patch_ids[i + 1] != Some(p))
                || (y + 1 < height && patch_ids[i + width as usize] != Some(p));
            if edge {
                c *= 0.35;
            }
            img.pixels[i] = c;
        }
    }
    img
}

/// Pictures of the method (the paper's Figs. 4 and 5), in display values (0..1).
impl SampleSet {
    /// The shadow image of ray-traced source `source`: per
    /// pixel, from its stored sample, white where every known light point is lit,
    /// black where all are shadowed, grey in between (the lit fraction), and dark red
    /// where none is known (not ray traced there, facing away, or nothing hit).
    pub fn shadow_image(&self, source: u32) -> Image {
        let mut img = Image::new(self.width, self.height);
        for (p, px) in img.pixels.iter_mut().enumerate() {
            let (mut known, mut lit) = (0u32, 0u32);
            for e in self.record(self.base[p]).iter().filter(|e| e.source == source) {
                known += e.known.count_ones();
                lit += (e.known & e.lit).count_ones();
            }
            *px = if known == 0 {
                Vec3::new(0.35, 0.05, 0.05)
            } else {
                Vec3::splat(lit as f32 / known as f32)
            };
        }
        img
    }

    /// Samples per pixel: black for one sample (levels -1 and 0), then blue, green
    /// and white for 4, 16 and more.
    pub fn density_image(&self) -> Image {
        let mut img = Image::new(self.width, self.height);
        for (p, px) in img.pixels.iter_mut().enumerate() {
            *px = match self.pixel(p as u32).len() {
                0 | 1 => Vec3::ZERO,
                2..=4 => Vec3::new(0.1, 0.2, 0.9),
                5..=16 => Vec3::new(0.2, 0.9, 0.2),
                _ => Vec3::ONE,
            };
        }
        img
    }

    /// Shadow rays cast per pixel (all its samples and their reflections), on a log
    /// scale from black (none) to white (the most any pixel cast).
    pub fn rays_image(&self) -> Image {
        let per: Vec<u64> = (0..self.width * self.height)
            .map(|p| {
                self.pixel(p)
                    .iter()
                    .map(|&i| self.samples[i as usize].rays as u64)
                    .sum()
            })
            .collect();
        let max = per.iter().copied().max().unwrap_or(0).max(1) as f32;
        let mut img = Image::new(self.width, self.height);
        for (px, &r) in img.pixels.iter_mut().zip(&per) {
            *px = Vec3::splat((1.0 + r as f32).ln() / (1.0 + max).ln());
        }
        img
    }
}
