//! The sun of a sky photograph. An `envmap` whose brightest texels are a small patch of
//! the sky holding a large share of its light is split in two, as `sunsky` is split:
//! a sky without those texels' excess, and a directional light that carries it, with a
//! disk that camera, mirror and glass rays see ([`super::SunDisk`]). The selection then
//! ray traces the sun like any small source, so its shadows are sharp but for the
//! disk's penumbrae ([`super::Scene::sun_solid_angle`]), and leaves the
//! sky's soft light to the radiosity. Kept whole, the map is one source seen under the
//! whole sphere, and the solid-angle criterion leaves all of it, sun included, to the
//! radiosity: the sun's shadows came out a mesh cell wide, and contact shadows were lost
//! (FLIP 0.1151 against Mitsuba's 64 spp 0.0332 on an open-air test scene).

use glam::{Vec2, Vec3};

use super::texture::Texture;
use super::{environment_dir, luminance, Rgb};

/// Texels brighter than this share of the brightest are the sun's (their excess over
/// it). A photographed sun is 10^3 to 10^5 times its sky, so this takes its core and
/// the glow round it, and leaves the sky.
const SUN_CUTOFF: f32 = 0.01;

/// The sun's texels all lie within this angle of their mean direction (degrees): a
/// brighter patch that is larger, or several apart (lamps in an indoor photograph), is
/// left in the map.
const SUN_MAX_ANGLE: f32 = 10.0;

/// The sun's excess must hold at least this share of the map's light (the sum of
/// luminance times solid angle), or splitting it off would gain nothing.
const SUN_SHARE: f32 = 0.2;

/// A sky photograph's sun ([`split`]).
pub struct Sun {
    /// Towards the sun, in the map's frame ([`environment_dir`]'s).
    pub towards: Vec3,
    /// The sun's irradiance across its direction, in the map's units (before its
    /// `scale`).
    pub irradiance: Rgb,
    /// The solid angle of its texels.
    pub solid_angle: f32,
    /// Its share of the map's light.
    pub share: f32,
}

/// The texels of `map` in order, row by row: colour, luminance, solid angle and the
/// (u, v) it looks along. Texel (x, y) looks along [`environment_dir`] of (x /
/// width, y / (height - 1)), as [`Texture::eval_lat_long`] reads it, and stands for the
/// solid angle (2 pi / width) (pi / (height - 1)) sin(theta). Read again by each pass,
/// so that a large map costs no copy of its texels.
fn texels(map: &Texture) -> impl Iterator<Item = (Rgb, f32, f32, Vec2)> + '_ {
    let (w, h) = map.size();
    let dphi = 2.0 * std::f32::consts::PI / w as f32;
    let dtheta = std::f32::consts::PI / (h - 1) as f32;
    (0..h).flat_map(move |y| {
        let omega = dphi * dtheta * (dtheta * y as f32).sin().max(0.0);
        (0..w).map(move |x| {
            let c = map.texel(i64::from(x), i64::from(y));
            let uv = Vec2::new(x as f32 / w as f32, y as f32 / (h - 1) as f32);
            (c, luminance(c), omega, uv)
        })
    })
}

/// The sun of the latitude-longitude map `map`, if it has one (see the module text),
/// and the map without it; `None` otherwise.
pub fn split(map: &Texture) -> Option<(Texture, Sun)> {
    let (w, h) = map.size();
    if w < 2 || h < 3 {
        return None;
    }
    let (mut total, mut peak) = (0.0f64, 0.0f32);
    for (c, l, omega, _) in texels(map) {
        if !(l.is_finite() && c.is_finite()) {
            return None;
        }
        total += f64::from(l * omega);
        if omega > 0.0 {
            peak = peak.max(l);
        }
    }
    if !(total > 0.0 && peak > 0.0) {
        return None;
    }
    let cutoff = peak * SUN_CUTOFF;
    // A texel of the sun, and its excess over the cutoff (its colour kept).
    let in_sun = |l: f32, omega: f32| l > cutoff && omega > 0.0;
    let excess = |c: Rgb, l: f32| c * (1.0 - cutoff / l);
    let (mut towards, mut irradiance, mut solid_angle) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
    for (c, l, omega, uv) in texels(map) {
        if in_sun(l, omega) {
            let e = excess(c, l) * omega;
            towards += environment_dir(uv) * luminance(e);
            irradiance += e;
            solid_angle += omega;
        }
    }
    let towards = towards.try_normalize()?;
    let share = (f64::from(luminance(irradiance)) / total) as f32;
    let cos_max = SUN_MAX_ANGLE.to_radians().cos();
    let compact = texels(map)
        .filter(|&(_, l, omega, _)| in_sun(l, omega))
        .all(|(_, _, _, uv)| environment_dir(uv).dot(towards) >= cos_max);
    if !(compact && share >= SUN_SHARE) {
        return None;
    }
    let sky: Vec<[f32; 3]> = texels(map)
        .map(|(c, l, omega, _)| {
            if in_sun(l, omega) {
                (c - excess(c, l)).to_array()
            } else {
                c.to_array()
            }
        })
        .collect();
    let sun = Sun {
        towards,
        irradiance,
        solid_angle,
        share,
    };
    Some((Texture::from_linear(&map.name, w, h, sky).ok()?, sun))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map of a uniform sky with a bright patch: `sun` texels of radiance `l` round
    /// texel (sx, sy).
    fn map(w: u32, h: u32, sky: f32, at: (u32, u32), size: u32, l: f32) -> Texture {
        let mut t = vec![[sky; 3]; (w * h) as usize];
        for y in at.1..at.1 + size {
            for x in at.0..at.0 + size {
                t[(y * w + x) as usize] = [l; 3];
            }
        }
        Texture::from_linear("t", w, h, t).unwrap()
    }

    /// A 2 x 2-texel sun 10^4 times its sky on a 256 x 129 map: split off, pointing at
    /// its texels' centre, carrying their excess over the cutoff times their solid
    /// angle; the sky keeps the cutoff there and is unchanged elsewhere.
    #[test]
    fn a_photographed_sun_is_split_off() {
        let (w, h) = (256, 129);
        let t = map(w, h, 1.0, (40, 30), 2, 1.0e4);
        let (sky, s) = split(&t).expect("a sun");
        let dphi = 2.0 * std::f32::consts::PI / w as f32;
        let dtheta = std::f32::consts::PI / (h - 1) as f32;
        let omega = |y: u32| dphi * dtheta * (dtheta * y as f32).sin();
        let want_omega = 2.0 * (omega(30) + omega(31));
        assert!((s.solid_angle - want_omega).abs() < 1e-4 * want_omega);
        let want_e = (1.0e4 - 100.0) * want_omega;
        assert!(
            (s.irradiance.x - want_e).abs() < 1e-3 * want_e,
            "{}",
            s.irradiance
        );
        let centre = environment_dir(Vec2::new(40.5 / w as f32, 30.5 / (h - 1) as f32));
        assert!(s.towards.dot(centre) > 0.9999, "{} vs {centre}", s.towards);
        assert!((sky.texel(40, 30).x - 100.0).abs() < 1e-2);
        assert_eq!(sky.texel(100, 60).x, 1.0);
        assert!(s.share > 0.5 && s.share < 1.0, "{}", s.share);
    }

    /// No split: a uniform sky; a bright patch too large (30 degrees); one too dim to
    /// matter (5 % of the light); two lamps far apart.
    #[test]
    fn skies_without_a_compact_bright_sun_stay_whole() {
        assert!(split(&map(64, 33, 1.0, (0, 0), 1, 1.0)).is_none());
        // 24 x 24 texels of a 256-wide map: 34 degrees across.
        assert!(split(&map(256, 129, 1.0, (40, 30), 24, 1.0e3)).is_none());
        // A 2 x 2 sun 200 times the sky: 3 % of the light.
        assert!(split(&map(256, 129, 1.0, (40, 30), 2, 200.0)).is_none());
        let mut t = vec![[1.0f32; 3]; 256 * 129];
        for (x, y) in [(40, 30), (170, 40)] {
            t[y * 256 + x] = [1.0e5; 3];
        }
        let two = Texture::from_linear("t", 256, 129, t).unwrap();
        assert!(split(&two).is_none());
    }
}
