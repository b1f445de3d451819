//! Image comparison: mean FLIP (NVIDIA's perceptual metric, LDR) and RMSE.
//!
//! FLIP is computed by `nv-flip` on the two images converted to 8-bit sRGB at exposure
//! 0 (clipped to `[0, 1]`), at its default pixels per degree. RMSE is over the linear
//! values of all pixels and the three channels.
//!
//! Non-finite values (NaN, ±Inf) are refused: an image containing them is a bug in
//! whatever made it, and neither number would mean anything, so [`compare`] returns an
//! error counting them rather than a NaN RMSE.

use std::path::Path;

use glam::Vec3;

use crate::image::{srgb_decode, to_srgb8, Image};
use crate::io::{read_image, write_image};
use crate::{Error, Result};

/// The result of comparing two images.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Comparison {
    /// Mean LDR FLIP error of the sRGB-clipped images (0 = identical).
    pub flip: f32,
    /// Root mean square error of the linear radiance, over all channels.
    pub rmse: f32,
}

/// Root mean square difference over all pixels and the three channels (f64 sums).
fn rmse(a: &[Vec3], b: &[Vec3]) -> f32 {
    if a.is_empty() {
        return 0.0;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            let d = (*p - *q).as_dvec3();
            d.dot(d)
        })
        .sum();
    (sum / (3 * a.len()) as f64).sqrt() as f32
}

/// Checks that `img` has exactly `width * height` pixels and only finite values.
fn check_image(img: &Image, which: &str) -> Result<()> {
    if img.pixels.len() as u64 != u64::from(img.width) * u64::from(img.height) {
        return Err(Error::Usage(format!(
            "cannot compare: {which} image is {}x{} but has {} pixels",
            img.width,
            img.height,
            img.pixels.len()
        )));
    }
    let bad = img.non_finite_pixels();
    if bad > 0 {
        return Err(Error::Usage(format!(
            "cannot compare: {which} image has {bad} non-finite pixel{}",
            if bad == 1 { "" } else { "s" }
        )));
    }
    Ok(())
}

/// Compares `test` against `reference`; the images must have the same size.
/// With `error_map`, also returns the FLIP error map coloured with the magma map, as
/// linear values (written as PNG it reproduces the map's sRGB colours exactly).
///
/// Errors: different sizes, or non-finite values in either image (see module docs).
pub fn compare(reference: &Image, test: &Image, error_map: bool) -> Result<(Comparison, Option<Image>)> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(Error::Usage(format!(
            "cannot compare images of different sizes: reference is {}x{}, test is {}x{}",
            reference.width, reference.height, test.width, test.height
        )));
    }
    check_image(reference, "reference")?;
    check_image(test, "test")?;
    let (w, h) = (reference.width, reference.height);
    let rmse = rmse(&reference.pixels, &test.pixels);
    if reference.pixels.is_empty() {
        let map = error_map.then(|| Image::new(w, h));
        return Ok((Comparison { flip: 0.0, rmse }, map));
    }

    let ref_flip = nv_flip::FlipImageRgb8::with_data(w, h, &to_srgb8(reference, 0.0));
    let test_flip = nv_flip::FlipImageRgb8::with_data(w, h, &to_srgb8(test, 0.0));
    let err = nv_flip::flip(ref_flip, test_flip, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let values = err.to_vec();
    let flip = (values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64) as f32;

    let map = error_map.then(|| {
        let lut: Vec<f32> = (0..=255u8).map(|v| srgb_decode(f32::from(v) / 255.0)).collect();
        let rgb = err.apply_color_lut(&nv_flip::magma_lut()).to_vec();
        let pixels = rgb
            .chunks_exact(3)
            .map(|c| {
                Vec3::new(
                    lut[usize::from(c[0])],
                    lut[usize::from(c[1])],
                    lut[usize::from(c[2])],
                )
            })
            .collect();
        Image {
            width: w,
            height: h,
            pixels,
        }
    });
    Ok((Comparison { flip, rmse }, map))
}

/// Reads both images, compares them, and writes the FLIP error map to `error_map`
/// when given (`.png` for the magma colours; `.exr` gets the same colours as linear
/// values). Problems with an image name its file.
pub fn compare_files(reference: &Path, test: &Path, error_map: Option<&Path>) -> Result<Comparison> {
    let ref_img = read_image(reference)?;
    let test_img = read_image(test)?;
    for (img, path) in [(&ref_img, reference), (&test_img, test)] {
        let bad = img.non_finite_pixels();
        if bad > 0 {
            return Err(Error::input(
                path,
                None,
                format!(
                    "image has {bad} non-finite pixel{}; cannot compare",
                    if bad == 1 { "" } else { "s" }
                ),
            ));
        }
    }
    if (ref_img.width, ref_img.height) != (test_img.width, test_img.height) {
        return Err(Error::Usage(format!(
            "cannot compare images of different sizes: '{}' is {}x{}, '{}' is {}x{}",
            reference.display(),
            ref_img.width,
            ref_img.height,
            test.display(),
            test_img.width,
            test_img.height
        )));
    }
    let (cmp, map) = compare(&ref_img, &test_img, error_map.is_some())?;
    if let (Some(path), Some(map)) = (error_map, map) {
        write_image(&map, path, 0.0)?;
    }
    Ok(cmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth, textured test image with values in `[0, 1]`.
    fn scene(w: u32, h: u32) -> Image {
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
                img.pixels[(y * w + x) as usize] = Vec3::new(
                    0.5 + 0.4 * (6.0 * u).sin() * (4.0 * v).cos(),
                    0.3 + 0.25 * u,
                    0.2 + 0.6 * v * v,
                );
            }
        }
        img
    }

    fn constant(w: u32, h: u32, c: f32) -> Image {
        Image {
            width: w,
            height: h,
            pixels: vec![Vec3::splat(c); (w * h) as usize],
        }
    }

    /// `img` with a deterministic per-pixel perturbation of amplitude `amp` (linear).
    fn perturbed(img: &Image, amp: f32) -> Image {
        let mut out = img.clone();
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for p in &mut out.pixels {
            for c in 0..3 {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let r = (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0;
                p[c] = (p[c] + amp * r).max(0.0);
            }
        }
        out
    }

    #[test]
    fn identical_images_have_zero_error() {
        let img = scene(64, 48);
        let (cmp, map) = compare(&img, &img, true).unwrap();
        assert_eq!(cmp.flip, 0.0);
        assert_eq!(cmp.rmse, 0.0);
        // The map is the LUT's first colour everywhere.
        let map = map.unwrap();
        assert_eq!((map.width, map.height), (64, 48));
        let first = nv_flip::magma_lut().to_vec();
        let expect = Vec3::new(
            srgb_decode(f32::from(first[0]) / 255.0),
            srgb_decode(f32::from(first[1]) / 255.0),
            srgb_decode(f32::from(first[2]) / 255.0),
        );
        assert!(map.pixels.iter().all(|&p| p == expect));
    }

    #[test]
    fn known_rmse() {
        let a = constant(16, 8, 0.3);
        let b = constant(16, 8, 0.4);
        let (cmp, _) = compare(&a, &b, false).unwrap();
        assert!((cmp.rmse - 0.1).abs() < 1e-6, "{}", cmp.rmse);
        // One channel of one pixel off by 3 in a 2x1 image: sqrt(9 / 6).
        let a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        b.pixels[1].y = 3.0;
        let (cmp, _) = compare(&a, &b, false).unwrap();
        assert!((cmp.rmse - 1.5f32.sqrt()).abs() < 1e-6);
        // RMSE is on linear values, beyond the clipping range FLIP sees.
        let (cmp, _) = compare(&constant(4, 4, 2.0), &constant(4, 4, 5.0), false).unwrap();
        assert!((cmp.rmse - 3.0).abs() < 1e-6);
        assert_eq!(cmp.flip, 0.0);
    }

    #[test]
    fn black_vs_white_is_near_one() {
        let (cmp, _) = compare(&constant(32, 32, 0.0), &constant(32, 32, 1.0), false).unwrap();
        assert!(cmp.flip > 0.9, "{}", cmp.flip);
        assert!(cmp.flip <= 1.0);
        assert!((cmp.rmse - 1.0).abs() < 1e-6);
    }

    #[test]
    fn flip_grows_with_the_perturbation() {
        let img = scene(96, 64);
        let flips: Vec<f32> = [0.002, 0.01, 0.05, 0.2]
            .iter()
            .map(|&amp| compare(&img, &perturbed(&img, amp), false).unwrap().0.flip)
            .collect();
        assert!(flips[0] > 0.0 && flips[0] < 0.05, "{flips:?}");
        for pair in flips.windows(2) {
            assert!(pair[0] < pair[1], "{flips:?}");
        }
        assert!(flips[3] > 0.1, "{flips:?}");
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let err = compare(&Image::new(4, 3), &Image::new(3, 4), false).unwrap_err();
        assert!(matches!(err, Error::Usage(_)));
        let msg = err.to_string();
        assert!(msg.contains("4x3") && msg.contains("3x4"), "{msg}");
    }

    #[test]
    fn non_finite_pixels_are_an_error() {
        let a = scene(8, 8);
        let mut b = a.clone();
        b.pixels[3].x = f32::NAN;
        b.pixels[5].z = f32::INFINITY;
        let err = compare(&a, &b, false).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("test image has 2 non-finite pixels"), "{msg}");
        let err = compare(&b, &a, false).unwrap_err();
        assert!(err.to_string().contains("reference image"));
    }

    #[test]
    fn tiny_and_empty_images() {
        for (w, h) in [(1, 1), (2, 1), (1, 5), (3, 3)] {
            let (cmp, map) = compare(&constant(w, h, 0.2), &constant(w, h, 0.8), true).unwrap();
            assert!(cmp.flip > 0.0 && cmp.flip <= 1.0, "{w}x{h}: {}", cmp.flip);
            assert_eq!(map.unwrap().pixels.len(), (w * h) as usize);
        }
        let (cmp, map) = compare(&Image::new(0, 0), &Image::new(0, 0), true).unwrap();
        assert_eq!((cmp.flip, cmp.rmse), (0.0, 0.0));
        assert!(map.unwrap().pixels.is_empty());
    }

    #[test]
    fn error_map_png_reproduces_the_lut_colours() {
        let dir = tempfile::tempdir().unwrap();
        let reference = scene(40, 30);
        let test = perturbed(&reference, 0.3);
        let (rp, tp, mp) = (
            dir.path().join("ref.exr"),
            dir.path().join("test.png"),
            dir.path().join("map.png"),
        );
        write_image(&reference, &rp, 0.0).unwrap();
        write_image(&test, &tp, 0.0).unwrap();
        let cmp = compare_files(&rp, &tp, Some(&mp)).unwrap();
        assert!(cmp.flip > 0.0 && cmp.rmse > 0.0);

        // Same numbers as comparing the images in memory (the PNG is 8-bit quantised).
        let test_back = read_image(&tp).unwrap();
        let (direct, _) = compare(&reference, &test_back, false).unwrap();
        assert_eq!(cmp, direct);

        // The written map's bytes are exactly the LUT colours of the FLIP values.
        let ref_flip = nv_flip::FlipImageRgb8::with_data(40, 30, &to_srgb8(&reference, 0.0));
        let test_flip = nv_flip::FlipImageRgb8::with_data(40, 30, &to_srgb8(&test_back, 0.0));
        let err = nv_flip::flip(ref_flip, test_flip, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
        let expect = err.apply_color_lut(&nv_flip::magma_lut()).to_vec();
        let written = image::open(&mp).unwrap().into_rgb8().into_raw();
        assert_eq!(written, expect);
        // The pool's mean agrees with ours.
        let pool = nv_flip::FlipPool::from_image(&err);
        assert!((pool.mean() - cmp.flip).abs() < 1e-5);
    }

    #[test]
    fn compare_files_errors_name_the_files() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.exr");
        let b = dir.path().join("b.exr");
        write_image(&constant(4, 4, 0.5), &a, 0.0).unwrap();
        write_image(&constant(5, 4, 0.5), &b, 0.0).unwrap();
        let msg = compare_files(&a, &b, None).unwrap_err().to_string();
        assert!(
            msg.contains("a.exr") && msg.contains("4x4") && msg.contains("5x4"),
            "{msg}"
        );
        let mut nan = constant(4, 4, 0.5);
        nan.pixels[0].y = f32::NAN;
        write_image(&nan, &b, 0.0).unwrap();
        let msg = compare_files(&a, &b, None).unwrap_err().to_string();
        assert!(
            msg.contains("b.exr") && msg.contains("1 non-finite pixel"),
            "{msg}"
        );
        let missing = dir.path().join("missing.exr");
        let msg = compare_files(&a, &missing, None).unwrap_err().to_string();
        assert!(msg.contains("missing.exr"), "{msg}");
    }
}
