//! Lights at infinity: the sun (`directional`) and the sky (`constant`, `envmap`).
//! Seen from the scene they are directions, not points: a shadow ray towards one
//! ends beyond the scene's bounding sphere, and light leaving one for the scene (a
//! photon) starts on a disk that covers that sphere across the direction, as in
//! pbrt-v4 and Mitsuba 3.

use glam::{Mat3, Vec2, Vec3};

use super::{Emission, LightSample};
use crate::scene::{environment_dir, environment_uv, mean, Light, Rgb, Scene, Texture};

/// The scene's bounding sphere (centre, radius) over all shapes.
pub fn scene_sphere(scene: &Scene) -> (Vec3, f32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for s in &scene.shapes {
        if let Some((a, b)) = s.mesh.bounds() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    if lo.x > hi.x {
        return (Vec3::ZERO, 1.0);
    }
    ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-3))
}

/// How far from `p` a point "at infinity" is put: beyond the bounding sphere.
fn far(p: Vec3, centre: Vec3, radius: f32) -> f32 {
    2.0 * (radius + (p - centre).length()) + 1.0
}

/// A point of the disk of radius `r` about `c` across unit direction `d`, from `u`
/// (uniform by area).
fn disk_point(c: Vec3, d: Vec3, r: f32, u: Vec2) -> Vec3 {
    let (t, b) = d.any_orthonormal_pair();
    let (rho, phi) = (r * u.x.sqrt(), 2.0 * std::f32::consts::PI * u.y);
    c + t * (rho * phi.cos()) + b * (rho * phi.sin())
}

/// The sun: parallel light of one irradiance, from one direction or from the
/// directions of a small disk ([`Scene::sun_solid_angle`]).
#[derive(Debug, Clone)]
pub struct Sun {
    /// Unit direction the light travels in (the disk's centre).
    pub direction: Vec3,
    /// Irradiance on a surface facing it.
    pub irradiance: Rgb,
    /// The disk's solid angle (0: a direction alone).
    solid_angle: f32,
    centre: Vec3,
    radius: f32,
}

impl Sun {
    /// Directional light `light` of `scene`, travelling along `direction`.
    pub fn new(scene: &Scene, light: u32, direction: Vec3, irradiance: Rgb) -> Self {
        let (centre, radius) = scene_sphere(scene);
        Sun {
            direction,
            irradiance,
            solid_angle: scene.sun_solid_angle(light),
            centre,
            radius,
        }
    }

    /// The sun seen from `p`: a point beyond the scene against its light, towards a
    /// direction of its disk drawn uniformly by `u` (the disk's radiance is uniform,
    /// so the irradiance over the shading cosine of that direction is unbiased).
    pub fn sample(&self, p: Vec3, u: Vec2) -> LightSample {
        let dir = if self.solid_angle > 0.0 {
            crate::sampling::cone_direction(-self.direction, self.solid_angle, u)
        } else {
            -self.direction
        };
        let dist = far(p, self.centre, self.radius);
        LightSample {
            point: p + dir * dist,
            dir,
            dist,
            value: self.irradiance,
            normal: None,
        }
    }

    /// A ray of sunlight into the scene: from the disk across the bounding sphere
    /// (`u` places it), carrying the irradiance times the disk's area.
    pub fn emit(&self, u: Vec2) -> Emission {
        let r = self.radius * 1.01;
        Emission {
            origin: disk_point(self.centre - self.direction * (2.0 * r), self.direction, r, u),
            normal: None,
            dir: self.direction,
            power: self.irradiance * (std::f32::consts::PI * r * r),
        }
    }
}

/// The sky: radiance from every direction, uniform or from a latitude-longitude
/// image, with a table that draws directions by the image's brightness (times the
/// sine of the polar angle: the solid angle of its rows).
#[derive(Debug, Clone)]
pub struct Sky {
    /// Scale of the image, or the uniform radiance.
    pub radiance: Rgb,
    texture: Option<Texture>,
    to_local: Mat3,
    to_world: Mat3,
    /// Cumulative row weights (`h + 1` entries from 0 to 1).
    rows: Vec<f32>,
    /// Per row, cumulative weights of its cells (`w + 1` entries from 0 to 1).
    cols: Vec<Vec<f32>>,
    /// Per cell, its density over the map's (u, v) square.
    density: Vec<f32>,
    /// Cells of the table, across and down.
    size: (usize, usize),
    /// The mean square of its brightness over the square of its mean, over the
    /// sphere (1 without an image): how far the sky is from uniform. A cosine-weighted
    /// estimate of its irradiance from n rays in the open has a relative variance of
    /// about (spread - 1) / n.
    pub spread: f32,
    centre: Vec3,
    radius: f32,
}

/// The table's cells at most, across (and half that down): finer images are read
/// in blocks (their brightness summed), which the image's own lookups then refine.
const TABLE_WIDTH: usize = 512;

impl Sky {
    pub fn new(scene: &Scene, radiance: Rgb, texture: Option<u32>, to_local: Mat3) -> Self {
        let (centre, radius) = scene_sphere(scene);
        let texture = texture.and_then(|t| scene.textures.get(t as usize)).cloned();
        let mut sky = Sky {
            radiance,
            to_world: to_local.inverse(),
            to_local,
            rows: vec![0.0, 1.0],
            cols: vec![vec![0.0, 1.0]],
            density: vec![1.0],
            size: (1, 1),
            spread: 1.0,
            texture: None,
            centre,
            radius,
        };
        if let Some(t) = texture {
            let (tw, th) = t.size();
            let w = (tw as usize).clamp(1, TABLE_WIDTH);
            let h = (th as usize).clamp(1, TABLE_WIDTH / 2);
            // Each cell's weight: its brightness, sampled at a few points, times the
            // solid angle of its row; a floor keeps every direction drawable.
            let mut weight = vec![0.0f32; w * h];
            let sub = 2;
            for y in 0..h {
                let theta = (y as f32 + 0.5) / h as f32 * std::f32::consts::PI;
                for x in 0..w {
                    let mut b = 0.0;
                    for j in 0..sub {
                        for i in 0..sub {
                            let uv = Vec2::new(
                                (x as f32 + (i as f32 + 0.5) / sub as f32) / w as f32,
                                (y as f32 + (j as f32 + 0.5) / sub as f32) / h as f32,
                            );
                            b += mean(t.eval_lat_long(uv)).max(0.0);
                        }
                    }
                    weight[y * w + x] = b / (sub * sub) as f32 * theta.sin();
                }
            }
            let total: f64 = weight.iter().map(|&x| f64::from(x)).sum();
            // The brightness's mean square over its mean's square, over the sphere
            // (cells weighed by their solid angle, the sine of their row).
            let (mut s1, mut s2, mut sines) = (0.0f64, 0.0f64, 0.0f64);
            for y in 0..h {
                let sin = f64::from(((y as f32 + 0.5) / h as f32 * std::f32::consts::PI).sin()).max(1e-9);
                for &x in &weight[y * w..(y + 1) * w] {
                    let b = f64::from(x) / sin;
                    s1 += b * sin;
                    s2 += b * b * sin;
                    sines += sin;
                }
            }
            if s1 > 0.0 {
                sky.spread = (s2 * sines / (s1 * s1)) as f32;
            }
            let floor = (1e-3 * total / (w * h) as f64).max(1e-12) as f32;
            for x in &mut weight {
                *x += floor;
            }
            let total: f64 = weight.iter().map(|&x| f64::from(x)).sum();
            let mut rows = vec![0.0f32];
            let mut cols = Vec::with_capacity(h);
            let mut acc = 0.0f64;
            for y in 0..h {
                let row = &weight[y * w..(y + 1) * w];
                let sum: f64 = row.iter().map(|&x| f64::from(x)).sum();
                let mut c = vec![0.0f32];
                let mut a = 0.0f64;
                for &x in row {
                    a += f64::from(x);
                    c.push((a / sum) as f32);
                }
                *c.last_mut().unwrap() = 1.0;
                cols.push(c);
                acc += sum;
                rows.push((acc / total) as f32);
            }
            *rows.last_mut().unwrap() = 1.0;
            sky.density = weight
                .iter()
                .map(|&x| (f64::from(x) / total * (w * h) as f64) as f32)
                .collect();
            sky.rows = rows;
            sky.cols = cols;
            sky.size = (w, h);
            sky.texture = Some(t);
        }
        sky
    }

    /// The radiance arriving from world direction `d` (unit).
    pub fn radiance_towards(&self, d: Vec3) -> Rgb {
        match &self.texture {
            Some(t) => self.radiance * t.eval_lat_long(environment_uv(self.to_local * d)),
            None => self.radiance,
        }
    }

    /// The direction `u` draws (uniform over the sphere without an image, else by the
    /// table) and its density per steradian.
    pub fn direction(&self, u: Vec2) -> (Vec3, f32) {
        let Some(_) = &self.texture else {
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            return (
                Vec3::new(r * phi.cos(), r * phi.sin(), z),
                0.25 * std::f32::consts::FRAC_1_PI,
            );
        };
        let (w, h) = self.size;
        let (y, fy) = invert(&self.rows, u.y);
        let (x, fx) = invert(&self.cols[y], u.x);
        let uv = Vec2::new((x as f32 + fx) / w as f32, (y as f32 + fy) / h as f32);
        let local = environment_dir(uv);
        let sin = (uv.y * std::f32::consts::PI).sin().max(1e-6);
        let pdf = self.density[y * w + x] / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin);
        ((self.to_world * local).normalize(), pdf)
    }

    /// The density per steradian with which [`Sky::direction`] draws world direction
    /// `d` (the tests' check of the draws).
    #[cfg(test)]
    fn pdf(&self, d: Vec3) -> f32 {
        if self.texture.is_none() {
            return 0.25 * std::f32::consts::FRAC_1_PI;
        }
        let (w, h) = self.size;
        let uv = environment_uv(self.to_local * d);
        let x = ((uv.x * w as f32) as usize).min(w - 1);
        let y = ((uv.y * h as f32) as usize).min(h - 1);
        let sin = (uv.y * std::f32::consts::PI).sin().max(1e-6);
        self.density[y * w + x] / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin)
    }

    /// A ray of skylight (a photon) aimed at the sphere (`c`, `r`) inside the scene:
    /// from the direction `u` draws ([`Sky::direction`]), leaving the disk across
    /// that sphere beyond the scene (`v` places it), carrying the radiance from there
    /// over the direction's density times the disk's area. `None` where the sky is
    /// black.
    pub fn emit_at(&self, u: Vec2, v: Vec2, c: Vec3, r: f32) -> Option<Emission> {
        let (dir, pdf) = self.direction(u);
        let value = self.radiance_towards(dir);
        if !(pdf > 0.0) || !(value.max_element() > 0.0) {
            return None;
        }
        // Beyond the scene's bounding sphere, whatever the sphere's place in it.
        let back = 2.02 * self.radius + (c - self.centre).length();
        Some(Emission {
            origin: disk_point(c + dir * back, -dir, r, v),
            normal: None,
            dir: -dir,
            power: value * (std::f32::consts::PI * r * r / pdf),
        })
    }

    /// The sky seen from `p` in the direction `u` draws.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let (dir, pdf) = self.direction(u);
        if !(pdf > 0.0) {
            return None;
        }
        let dist = far(p, self.centre, self.radius);
        Some(LightSample {
            point: p + dir * dist,
            dir,
            dist,
            value: self.radiance_towards(dir) / pdf,
            normal: None,
        })
    }
}

/// The cell `u` falls in of cumulative table `cdf` (0 first, 1 last) and where in
/// it, in [0, 1).
fn invert(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let i = cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
    let (lo, hi) = (cdf[i], cdf[i + 1]);
    let f = if hi > lo {
        ((u - lo) / (hi - lo)).clamp(0.0, 0.999_999)
    } else {
        0.5
    };
    (i, f)
}

/// The power of a light at infinity (mean over RGB): what enters the scene's
/// bounding sphere, pi r^2 times the irradiance (the sun) or times the radiance's
/// integral over the sphere (the sky, by a 256 x 128 grid of directions).
pub fn power(scene: &Scene, light: &Light) -> f64 {
    let (_, r) = scene_sphere(scene);
    let disk = std::f64::consts::PI * f64::from(r) * f64::from(r);
    match *light {
        Light::Directional { irradiance, .. } => disk * f64::from(mean(irradiance)),
        Light::Environment { to_local, .. } => {
            let to_world = to_local.inverse();
            let (w, h) = (256usize, 128usize);
            let mut s = 0.0f64;
            for y in 0..h {
                let v = (y as f32 + 0.5) / h as f32;
                let sin = f64::from((v * std::f32::consts::PI).sin());
                for x in 0..w {
                    let d = to_world * environment_dir(Vec2::new((x as f32 + 0.5) / w as f32, v));
                    s += f64::from(mean(light.environment_radiance(d, &scene.textures))) * sin;
                }
            }
            disk * s * (2.0 * std::f64::consts::PI / w as f64) * (std::f64::consts::PI / h as f64)
        }
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The map's (u, v) and directions invert each other, and Mitsuba's axes: +y is
    /// the top row, u = 0.5 looks along +z... (u = 0 along -z).
    #[test]
    fn lat_long_mapping_is_mitsubas_and_inverts() {
        assert!((environment_dir(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
        assert!((environment_dir(Vec2::new(0.0, 0.5)) - Vec3::NEG_Z).length() < 1e-6);
        assert!((environment_dir(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
        for uv in [Vec2::new(0.1, 0.2), Vec2::new(0.7, 0.9), Vec2::new(0.5, 0.5)] {
            assert!((environment_uv(environment_dir(uv)) - uv).length() < 1e-5, "{uv}");
        }
    }

    /// A sky's spread (its brightness's mean square over its mean's square): 1 for a
    /// uniform sky, with or without an image; 2 for a sky bright over its upper half
    /// and black below (mean 1/2, mean square 1/2).
    #[test]
    fn a_skys_spread_is_its_mean_square_over_its_square_mean() {
        let mut scene = crate::testutil::scene(vec![], vec![], &[]);
        let (w, h) = (64u32, 32u32);
        let half: Vec<[f32; 3]> = (0..w * h)
            .map(|i| [f32::from(u8::from(i / w < h / 2)); 3])
            .collect();
        scene
            .textures
            .push(Texture::from_linear("half", w, h, half).unwrap());
        scene
            .textures
            .push(Texture::from_linear("even", w, h, vec![[0.7; 3]; (w * h) as usize]).unwrap());
        let spread = |t: Option<u32>| Sky::new(&scene, Vec3::ONE, t, Mat3::IDENTITY).spread;
        assert_eq!(spread(None), 1.0);
        assert!((spread(Some(1)) - 1.0).abs() < 1e-4, "{}", spread(Some(1)));
        assert!((spread(Some(0)) - 2.0).abs() < 0.05, "{}", spread(Some(0)));
    }

    /// A sky image: drawn directions' radiance over their density averages to the
    /// radiance's integral over the sphere (the estimator is unbiased), and the
    /// density the draw reports is the one `pdf` gives for the direction.
    #[test]
    fn sky_directions_are_drawn_with_the_density_they_report() {
        let (w, h) = (16u32, 8u32);
        // A bright blob near the top and a dim rest.
        let px: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (3..6).contains(&x) && (1..3).contains(&y) {
                    [20.0, 10.0, 5.0]
                } else {
                    [0.2, 0.3, 0.5]
                }
            })
            .collect();
        let mut scene = crate::testutil::scene(vec![], vec![], &[]);
        scene
            .textures
            .push(Texture::from_linear("sky", w, h, px).unwrap());
        let sky = Sky::new(&scene, Vec3::ONE, Some(0), Mat3::IDENTITY);
        // The integral by a fine grid over the sphere.
        let n = 400;
        let mut exact = 0.0f64;
        for j in 0..n {
            let v = (j as f32 + 0.5) / n as f32;
            for i in 0..2 * n {
                let uv = Vec2::new((i as f32 + 0.5) / (2 * n) as f32, v);
                exact += f64::from(mean(sky.radiance_towards(environment_dir(uv))))
                    * f64::from((v * std::f32::consts::PI).sin());
            }
        }
        exact *= (2.0 * std::f64::consts::PI / (2 * n) as f64) * (std::f64::consts::PI / n as f64);
        let m = 256;
        let mut est = 0.0f64;
        for j in 0..m {
            for i in 0..m {
                let u = Vec2::new((i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32);
                let (d, pdf) = sky.direction(u);
                let p2 = sky.pdf(d);
                assert!((pdf - p2).abs() <= 1e-3 * pdf, "{u}: {pdf} vs {p2}");
                est += f64::from(mean(sky.radiance_towards(d)) / pdf);
            }
        }
        est /= f64::from(m * m);
        assert!((est - exact).abs() < 0.01 * exact, "{est} vs {exact}");
        // The power: pi r^2 times that integral.
        let r = f64::from(sky.radius);
        let light = Light::Environment {
            radiance: Vec3::ONE,
            texture: Some(0),
            to_local: Mat3::IDENTITY,
        };
        let p = power(&scene, &light);
        assert!((p - std::f64::consts::PI * r * r * exact).abs() < 0.01 * p);
    }
}
