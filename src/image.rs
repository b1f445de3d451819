//! Images in memory: linear RGB pixels, and the sRGB transfer function that turns
//! them into display values. Reading and writing files is [`crate::io`]'s.

use glam::Vec3;

/// A linear RGB image, row-major from the top-left.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; (width * height) as usize],
        }
    }

    /// The number of pixels with at least one non-finite channel.
    pub fn non_finite_pixels(&self) -> usize {
        self.pixels.iter().filter(|p| !p.is_finite()).count()
    }
}

/// The exact sRGB transfer function (IEC 61966-2-1): linear -> encoded.
///
/// No clamping: values outside `[0, 1]` follow the formula (negative values stay on
/// the linear segment), NaN stays NaN. [`to_srgb8`] clamps before encoding.
pub fn srgb_encode(linear: f32) -> f32 {
    let x = f64::from(linear);
    let v = if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    v as f32
}

/// The exact inverse of [`srgb_encode`]: encoded sRGB -> linear.
pub fn srgb_decode(v: f32) -> f32 {
    let v = f64::from(v);
    let x = if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    };
    x as f32
}

/// One linear value to an 8-bit sRGB code: scaled by `scale`, NaN -> 0, clamped to
/// `[0, 1]` (so +Inf -> 255), encoded, rounded to nearest.
fn to_srgb8_value(v: f32, scale: f32) -> u8 {
    let x = v * scale;
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    (srgb_encode(x) * 255.0).round() as u8
}

/// The image as tightly packed 8-bit sRGB bytes (RGB, row-major from the top-left),
/// after multiplying by `2^exposure` and clamping to `[0, 1]`. NaN becomes 0 and
/// +Inf becomes 255.
pub fn to_srgb8(img: &Image, exposure: f32) -> Vec<u8> {
    let scale = exposure.exp2();
    let mut out = Vec::with_capacity(img.pixels.len() * 3);
    for p in &img.pixels {
        out.push(to_srgb8_value(p.x, scale));
        out.push(to_srgb8_value(p.y, scale));
        out.push(to_srgb8_value(p.z, scale));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_known_values() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-7);
        assert!((srgb_encode(0.5) - 0.735_356_9).abs() < 1e-6);
        assert!((srgb_encode(0.214_041) - 0.5).abs() < 1e-5);
        assert!((srgb_decode(0.5) - 0.214_041_14).abs() < 1e-6);
        // Linear segment and its boundary: both pieces agree there (to ~1e-7).
        assert!((srgb_encode(0.001) - 0.01292).abs() < 1e-9);
        let below = srgb_encode(0.003_130_8);
        let above = srgb_encode(0.003_130_9);
        assert!((below - 0.040_449_936).abs() < 1e-6, "{below}");
        assert!(above > below && above - below < 1e-5);
        assert!((srgb_decode(0.04045) - 0.04045 / 12.92).abs() < 1e-9);
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            let back = srgb_decode(srgb_encode(x));
            assert!((back - x).abs() < 1e-6, "{x} -> {back}");
            let back = srgb_encode(srgb_decode(x));
            assert!((back - x).abs() < 1e-6, "{x} -> {back}");
        }
    }

    #[test]
    fn srgb8_codes_round_trip_through_decode() {
        // Every 8-bit code decoded to linear and encoded again gives itself back.
        for b in 0..=255u8 {
            let img = Image {
                width: 1,
                height: 1,
                pixels: vec![Vec3::splat(srgb_decode(f32::from(b) / 255.0))],
            };
            assert_eq!(to_srgb8(&img, 0.0), vec![b; 3]);
        }
    }

    #[test]
    fn srgb8_exposure_clamp_and_non_finite() {
        let img = Image {
            width: 5,
            height: 1,
            pixels: vec![
                Vec3::new(f32::NAN, f32::INFINITY, f32::NEG_INFINITY),
                Vec3::new(-1.0, 2.0, 0.5),
                Vec3::new(0.25, 0.25, 0.25),
                Vec3::new(0.0031308, 1.0, 0.0),
                Vec3::splat(f32::MAX),
            ],
        };
        let out = to_srgb8(&img, 0.0);
        assert_eq!(&out[0..3], &[0, 255, 0]);
        assert_eq!(&out[3..6], &[0, 255, 188]); // 0.7353569 * 255 = 187.5 -> 188
        assert_eq!(&out[6..9], &[137, 137, 137]);
        assert_eq!(&out[9..12], &[10, 255, 0]);
        assert_eq!(&out[12..15], &[255, 255, 255]);
        // Exposure +1 doubles: 0.25 -> 0.5.
        let out = to_srgb8(&img, 1.0);
        assert_eq!(&out[6..9], &[188, 188, 188]);
        assert_eq!(&out[0..3], &[0, 255, 0]);
    }
}
