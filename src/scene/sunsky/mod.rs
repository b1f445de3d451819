//! Mitsuba 3's `sunsky`: the Hosek–Wilkie sky (2012) and sun (2013) in RGB.
//!
//! The scene reader turns a `sunsky` into the two lights radtrace already has: the sky
//! becomes a latitude-longitude image ([`SunSky::bake`], an `envmap`), and the sun a
//! `directional` light of the disk's irradiance ([`SunSky::sun_irradiance`]). So pass 1
//! shoots the sky from its far cells and the sun as a point at infinity, the selection
//! treats the sun like any other source (its patches get sharp ray-traced shadows), and
//! the render samples both as it samples an `envmap` and a `directional`.
//!
//! The model's coefficients are the public RGB datasets of Hosek and Wilkie
//! (BSD-3-Clause, `LICENSE.txt` beside this file), as Mitsuba 3 ships them
//! (`SOURCE.md`). The values follow Mitsuba 3.9 in `rgb` variants:
//! - the sky: coefficients interpolated linearly in turbidity (1-10) and per channel in
//!   ground albedo (0-1), then by the quintic Bezier in the cube root of the sun's
//!   elevation; radiance `(1 + A exp(B / (cos theta + 0.01))) (C + D exp(E gamma) +
//!   F cos^2 gamma + G chi(H, gamma) + I sqrt(cos theta)) L_M`, zero below the horizon;
//! - the sun: Mitsuba's default (not `complex_sun`) disk of uniform radiance carries the
//!   limb-darkened model's mean over the disk, and its irradiance does not change with
//!   `sun_aperture`;
//! - a sun below the horizon turns both off, as in Mitsuba (the loader warns).

use glam::{DVec3, Mat3, Vec2, Vec3};

use super::{environment_dir, Rgb, Texture};

/// Mitsuba 3.9's `MI_CIE_Y_NORMALIZATION`: the model's spectral units to RGB.
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Mitsuba's factor from the sun model's spectral radiance to RGB.
const SUN_SPECTRAL_TO_RGB: f64 = 467.069_280_386;
/// The sun's aperture (degrees across) the models were fitted for, and Mitsuba's
/// default `sun_aperture`.
pub const SUN_APERTURE: f64 = 0.5358;
/// Half of [`SUN_APERTURE`], in radians.
pub const SUN_HALF_APERTURE: f64 = std::f64::consts::PI * (0.5 * SUN_APERTURE) / 180.0;

const TURBIDITIES: usize = 10;
const ALBEDOS: usize = 2;
const SKY_CTRL: usize = 6;
const SKY_PARAMS: usize = 9;
const SUN_SEGMENTS: usize = 45;
const SUN_CTRL: usize = 4;
const SUN_LD: usize = 6;

const SKY_PARAMS_LEN: usize = TURBIDITIES * ALBEDOS * SKY_CTRL * 3 * SKY_PARAMS;
const SKY_RAD_LEN: usize = TURBIDITIES * ALBEDOS * SKY_CTRL * 3;
const SUN_LEN: usize = TURBIDITIES * SUN_SEGMENTS * 3 * SUN_CTRL * SUN_LD;

/// The datasets, little-endian f64: sky parameters [turbidity][albedo][control][rgb][9],
/// sky radiance [turbidity][albedo][control][rgb], sun [turbidity][segment][rgb][4][6].
const DATA: &[u8] = include_bytes!("hosek-wilkie-rgb.f64");
const _: () = assert!(DATA.len() == 8 * (SKY_PARAMS_LEN + SKY_RAD_LEN + SUN_LEN));

fn data(i: usize) -> f64 {
    let b = &DATA[8 * i..8 * i + 8];
    f64::from_le_bytes(b.try_into().expect("8 bytes"))
}

/// The sky and sun of one `sunsky`, in its own frame (+z up).
#[derive(Debug, Clone)]
pub struct SunSky {
    /// Unit direction towards the sun (+z up).
    sun: DVec3,
    /// Per channel: the nine parameters A..I of the sky's formula.
    params: [[f64; SKY_PARAMS]; 3],
    /// Per channel: the sky's mean radiance L_M.
    radiance: [f64; 3],
    /// Per channel: the sun's coefficients at this turbidity, [segment][k][j].
    sun_coefs: [Vec<f64>; 3],
}

impl SunSky {
    /// The model for `turbidity` in [1, 10], ground `albedo` in [0, 1] per channel and the
    /// unit direction `sun` towards the sun (+z up). Below the horizon the sky is
    /// evaluated at elevation zero; [`SunSky::sky_radiance`] is zero then.
    pub fn new(turbidity: f64, albedo: [f64; 3], sun: DVec3) -> Self {
        let sun = sun.normalize();
        let t = (turbidity.clamp(1.0, 10.0) - 1.0).min((TURBIDITIES - 1) as f64);
        let t0 = (t.floor() as usize).min(TURBIDITIES - 1);
        let t1 = (t0 + 1).min(TURBIDITIES - 1);
        let wt = t - t0 as f64;
        // Bezier weights in the cube root of the sun's elevation over pi/2.
        let eta = sun.z.clamp(0.0, 1.0).asin();
        let x = (eta * 2.0 / std::f64::consts::PI).cbrt().min(1.0 - 1e-7);
        const BINOMIAL: [f64; SKY_CTRL] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        let bezier: [f64; SKY_CTRL] = std::array::from_fn(|k| {
            BINOMIAL[k] * x.powi(k as i32) * (1.0 - x).powi((SKY_CTRL - 1 - k) as i32)
        });
        // Trilinear in turbidity and albedo, then the Bezier over the control points.
        let blend = |c: usize, at: &dyn Fn(usize, usize, usize) -> f64| -> f64 {
            let a = albedo[c].clamp(0.0, 1.0);
            (0..SKY_CTRL)
                .map(|k| {
                    let at_t = |ti: usize| at(ti, 0, k) * (1.0 - a) + at(ti, 1, k) * a;
                    bezier[k] * (at_t(t0) * (1.0 - wt) + at_t(t1) * wt)
                })
                .sum()
        };
        let params = std::array::from_fn(|c| {
            std::array::from_fn(|p| {
                blend(c, &|ti, ai, k| {
                    data((((ti * ALBEDOS + ai) * SKY_CTRL + k) * 3 + c) * SKY_PARAMS + p)
                })
            })
        });
        let radiance = std::array::from_fn(|c| {
            blend(c, &|ti, ai, k| {
                data(SKY_PARAMS_LEN + ((ti * ALBEDOS + ai) * SKY_CTRL + k) * 3 + c)
            })
        });
        let per_segment = SUN_CTRL * SUN_LD;
        let sun_coefs = std::array::from_fn(|c| {
            let mut v = Vec::with_capacity(SUN_SEGMENTS * per_segment);
            for s in 0..SUN_SEGMENTS {
                for i in 0..per_segment {
                    let at = |ti: usize| {
                        data(
                            SKY_PARAMS_LEN
                                + SKY_RAD_LEN
                                + ((ti * SUN_SEGMENTS + s) * 3 + c) * per_segment
                                + i,
                        )
                    };
                    v.push(at(t0) * (1.0 - wt) + at(t1) * wt);
                }
            }
            v
        });
        SunSky {
            sun,
            params,
            radiance,
            sun_coefs,
        }
    }

    /// Unit direction towards the sun (+z up).
    pub fn sun_direction(&self) -> DVec3 {
        self.sun
    }

    /// Whether the sun is above the horizon (else the whole model is dark).
    pub fn sun_up(&self) -> bool {
        self.sun.z >= 0.0
    }

    /// The sky's RGB radiance seen looking along unit `d` (+z up); zero below the horizon
    /// or when the sun is down.
    pub fn sky_radiance(&self, d: DVec3) -> [f64; 3] {
        let cos_theta = d.z;
        if cos_theta < 0.0 || !self.sun_up() {
            return [0.0; 3];
        }
        let cos_gamma = d.dot(self.sun).clamp(-1.0, 1.0);
        let gamma = cos_gamma.acos();
        std::array::from_fn(|c| {
            // The datasets' order: A, B, C, D, E, F, G, I, H.
            let [a, b, cc, dd, e, f, g, i, h] = self.params[c];
            let chi = (1.0 + cos_gamma * cos_gamma) / (1.0 + h * h - 2.0 * h * cos_gamma).powf(1.5);
            let c1 = 1.0 + a * (b / (cos_theta + 0.01)).exp();
            let c2 = cc + dd * (e * gamma).exp() + f * cos_gamma * cos_gamma + g * chi + i * cos_theta.sqrt();
            c1 * c2 * self.radiance[c] * CIE_Y_NORMALIZATION
        })
    }

    /// The limb-darkened sun's RGB radiance seen along unit `d` at angle `gamma` from the
    /// disk's centre (inside the disk; zero below the horizon).
    fn sun_radiance_at(&self, d: DVec3, gamma: f64) -> [f64; 3] {
        if d.z < 0.0 {
            return [0.0; 3];
        }
        let elevation = d.z.clamp(0.0, 1.0).asin();
        let pos = (((2.0 * elevation / std::f64::consts::PI).cbrt() * SUN_SEGMENTS as f64) as usize)
            .min(SUN_SEGMENTS - 1);
        let x = elevation - 0.5 * std::f64::consts::PI * (pos as f64 / SUN_SEGMENTS as f64).powi(3);
        let sin_ratio = gamma.sin() / SUN_HALF_APERTURE.sin();
        let cos_psi = (1.0 - sin_ratio * sin_ratio).max(0.0).sqrt();
        std::array::from_fn(|c| {
            let coefs = &self.sun_coefs[c][pos * SUN_CTRL * SUN_LD..(pos + 1) * SUN_CTRL * SUN_LD];
            let mut sum = 0.0;
            let mut xk = 1.0;
            for k in 0..SUN_CTRL {
                let mut psi_j = 1.0;
                for j in 0..SUN_LD {
                    sum += xk * psi_j * coefs[k * SUN_LD + j];
                    psi_j *= cos_psi;
                }
                xk *= x;
            }
            sum * SUN_SPECTRAL_TO_RGB * CIE_Y_NORMALIZATION
        })
    }

    /// The sun's RGB irradiance on a surface facing it: the limb-darkened model's
    /// radiance integrated over the disk (Mitsuba's uniform disk carries its mean).
    /// Zero when the sun is down.
    pub fn sun_irradiance(&self) -> [f64; 3] {
        if !self.sun_up() {
            return [0.0; 3];
        }
        const N: usize = 48;
        let (t1, t2) = self.sun.any_orthonormal_pair();
        let mut sum = [0.0; 3];
        let mut weight = 0.0;
        for a in 0..N {
            let gamma = SUN_HALF_APERTURE * (a as f64 + 0.5) / N as f64;
            let (sg, cg) = gamma.sin_cos();
            for b in 0..N {
                let phi = std::f64::consts::TAU * (b as f64 + 0.5) / N as f64;
                let d = cg * self.sun + sg * (phi.cos() * t1 + phi.sin() * t2);
                let l = self.sun_radiance_at(d, gamma);
                for c in 0..3 {
                    sum[c] += l[c] * sg;
                }
                weight += sg;
            }
        }
        let solid_angle = std::f64::consts::TAU * (1.0 - SUN_HALF_APERTURE.cos());
        sum.map(|s| s / weight * solid_angle)
    }

    /// The sky as a `width` x `height` latitude-longitude image in the `envmap` frame
    /// (+y up; [`environment_dir`]), whose +y is this model's +z:
    /// an `envmap` direction e is the model's (e.x, -e.z, e.y).
    pub fn bake(&self, width: u32, height: u32) -> Result<Texture, String> {
        let mut texels = Vec::with_capacity((width * height) as usize);
        for y in 0..height {
            for x in 0..width {
                let uv = Vec2::new(x as f32 / width as f32, y as f32 / (height.max(2) - 1) as f32);
                let d = from_envmap_frame(environment_dir(uv)).as_dvec3();
                texels.push(self.sky_radiance(d).map(|v| v.max(0.0) as f32));
            }
        }
        Texture::from_linear("sunsky", width, height, texels)
    }
}

/// A direction in the `envmap` frame (+y up) in the sunsky's frame (+z up).
pub fn from_envmap_frame(e: Vec3) -> Vec3 {
    Vec3::new(e.x, -e.z, e.y)
}

/// The rotation from the sunsky's frame (+z up) to the `envmap` frame (+y up).
pub fn to_envmap_frame() -> Mat3 {
    Mat3::from_cols(Vec3::X, -Vec3::Z, Vec3::Y)
}

/// Where and when the sun is seen: Mitsuba's `latitude`, `longitude`, `timezone`,
/// `year`, `month`, `day`, `hour`, `minute` and `second` (defaults: Tokyo, 10 July 2010,
/// 15:00).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPlace {
    /// Degrees north.
    pub latitude: f64,
    /// Degrees east.
    pub longitude: f64,
    /// Hours ahead of UTC.
    pub timezone: f64,
    /// Calendar year.
    pub year: i64,
    /// Month, 1-12.
    pub month: i64,
    /// Day of the month.
    pub day: i64,
    /// Local hour.
    pub hour: f64,
    /// Minutes.
    pub minute: f64,
    /// Seconds.
    pub second: f64,
}

impl Default for SunPlace {
    fn default() -> Self {
        SunPlace {
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
            year: 2010,
            month: 7,
            day: 10,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
        }
    }
}

impl SunPlace {
    /// The unit direction towards the sun (+z up, azimuth measured as Mitsuba's frame
    /// measures it), by the PSA algorithm of Blanco-Muriel et al., "Computing the solar
    /// vector", Solar Energy 70(5), 2001, with its parallax correction.
    pub fn sun_direction(&self) -> DVec3 {
        use std::f64::consts::{PI, TAU};
        let dec_hours = self.hour - self.timezone + (self.minute + self.second / 60.0) / 60.0;
        let aux1 = (self.month - 14) / 12;
        let aux2 = (1461 * (self.year + 4800 + aux1)) / 4 + (367 * (self.month - 2 - 12 * aux1)) / 12
            - (3 * ((self.year + 4900 + aux1) / 100)) / 4
            + self.day
            - 32075;
        let julian = aux2 as f64 - 0.5 + dec_hours / 24.0;
        let n = julian - 2_451_545.0;

        let omega = 2.1429 - 0.001_039_459_4 * n;
        let mean_longitude = 4.895_063 + 0.017_202_791_698 * n;
        let anomaly = 6.240_06 + 0.017_201_969_9 * n;
        let ecliptic_longitude =
            mean_longitude + 0.033_416_07 * anomaly.sin() + 0.000_348_94 * (2.0 * anomaly).sin()
                - 0.000_113_4
                - 0.000_020_3 * omega.sin();
        let obliquity = 0.409_092_8 - 6.214e-9 * n + 0.000_039_6 * omega.cos();

        let sin_lon = ecliptic_longitude.sin();
        let mut right_ascension = (obliquity.cos() * sin_lon).atan2(ecliptic_longitude.cos());
        if right_ascension < 0.0 {
            right_ascension += TAU;
        }
        let declination = (obliquity.sin() * sin_lon).asin();

        let gmst = 6.697_424_324_2 + 0.065_709_828_3 * n + dec_hours;
        let lmst = (gmst * 15.0 + self.longitude).to_radians();
        let lat = self.latitude.to_radians();
        let hour_angle = lmst - right_ascension;
        let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos() + declination.sin() * lat.sin())
            .clamp(-1.0, 1.0)
            .acos();
        let mut azimuth =
            (-hour_angle.sin()).atan2(declination.tan() * lat.cos() - lat.sin() * hour_angle.cos());
        if azimuth < 0.0 {
            azimuth += TAU;
        }
        const EARTH_RADIUS_KM: f64 = 6371.01;
        const AU_KM: f64 = 149_597_890.0;
        zenith += EARTH_RADIUS_KM / AU_KM * zenith.sin();
        let phi = azimuth - PI;
        DVec3::new(zenith.sin() * phi.cos(), zenith.sin() * phi.sin(), zenith.cos())
    }
}

/// Rgb of an f64 triple.
pub fn rgb(v: [f64; 3]) -> Rgb {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

#[cfg(test)]
mod tests;
