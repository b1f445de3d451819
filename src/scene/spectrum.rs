//! Spectra given by wavelength (`<spectrum>` in a scene file) as the linear sRGB
//! colours that Mitsuba 3's RGB modes make of them, so that a file written for a
//! spectral renderer renders in the colours Mitsuba shows:
//!
//! - wavelength:value pairs (or a `.spd` file of them) are integrated, linearly
//!   interpolated, against the CIE 1931 colour matching functions at 1,000 even steps
//!   from 360 to 830 nm, and the XYZ colour taken to linear sRGB;
//! - a reflectance is seen under the D65 illuminant (so a flat spectrum stays grey)
//!   and clamped into [0, 1]; an emitter's radiance is weighed evenly (a flat
//!   spectrum is the equal-energy white, a little pink against sRGB's D65 white) and
//!   only its negative channels are clamped; an index of refraction or absorption
//!   (`eta`, `k`, `int_ior`, `ext_ior`, `sigma_t`) is seen under D65 and clamped
//!   below only;
//! - one value alone is that grey, except an emitter's, which is the equal-energy
//!   white that bright.
//!
//! Checked against Mitsuba 3.9's `spectrum_list_to_srgb` and its renders (see the
//! tests).

use glam::{DVec3, Vec3};

/// Every 5 nm from 360 to 830 nm: the CIE 1931 2-degree standard observer's colour
/// matching functions x, y, z and the CIE standard illuminant D65's relative
/// spectral power (CIE 015:2018's tables).
const CIE: [[f64; 4]; 95] = [
    [0.0001299, 3.917e-06, 0.0006061, 46.6383],   // 360
    [0.0002321, 6.965e-06, 0.001086, 49.3637],    // 365
    [0.0004149, 1.239e-05, 0.001946, 52.0891],    // 370
    [0.0007416, 2.202e-05, 0.003486, 51.0323],    // 375
    [0.001368, 3.9e-05, 0.006450001, 49.9755],    // 380
    [0.002236, 6.4e-05, 0.01054999, 52.3118],     // 385
    [0.004243, 0.00012, 0.02005001, 54.6482],     // 390
    [0.00765, 0.000217, 0.03621, 68.7015],        // 395
    [0.01431, 0.000396, 0.06785001, 82.7549],     // 400
    [0.02319, 0.00064, 0.1102, 87.1204],          // 405
    [0.04351, 0.00121, 0.2074, 91.486],           // 410
    [0.07763, 0.00218, 0.3713, 92.4589],          // 415
    [0.13438, 0.004, 0.6456, 93.4318],            // 420
    [0.21477, 0.0073, 1.03905, 90.057],           // 425
    [0.2839, 0.0116, 1.3856, 86.6823],            // 430
    [0.3285, 0.01684, 1.62296, 95.7736],          // 435
    [0.34828, 0.023, 1.74706, 104.865],           // 440
    [0.34806, 0.0298, 1.7826, 110.936],           // 445
    [0.3362, 0.038, 1.77211, 117.008],            // 450
    [0.3187, 0.048, 1.7441, 117.41],              // 455
    [0.2908, 0.06, 1.6692, 117.812],              // 460
    [0.2511, 0.0739, 1.5281, 116.336],            // 465
    [0.19536, 0.09098, 1.28764, 114.861],         // 470
    [0.1421, 0.1126, 1.0419, 115.392],            // 475
    [0.09564, 0.13902, 0.8129501, 115.923],       // 480
    [0.05795001, 0.1693, 0.6162, 112.367],        // 485
    [0.03201, 0.20802, 0.46518, 108.811],         // 490
    [0.0147, 0.2586, 0.3533, 109.082],            // 495
    [0.0049, 0.323, 0.272, 109.354],              // 500
    [0.0024, 0.4073, 0.2123, 108.578],            // 505
    [0.0093, 0.503, 0.1582, 107.802],             // 510
    [0.0291, 0.6082, 0.1117, 106.296],            // 515
    [0.06327, 0.71, 0.07824999, 104.79],          // 520
    [0.1096, 0.7932, 0.05725001, 106.239],        // 525
    [0.1655, 0.862, 0.04216, 107.689],            // 530
    [0.2257499, 0.9148501, 0.02984, 106.047],     // 535
    [0.2904, 0.954, 0.0203, 104.405],             // 540
    [0.3597, 0.9803, 0.0134, 104.225],            // 545
    [0.4334499, 0.9949501, 0.008749999, 104.046], // 550
    [0.5120501, 1.0, 0.005749999, 102.023],       // 555
    [0.5945, 0.995, 0.0039, 100.0],               // 560
    [0.6784, 0.9786, 0.002749999, 98.1671],       // 565
    [0.7621, 0.952, 0.0021, 96.3342],             // 570
    [0.8425, 0.9154, 0.0018, 96.0611],            // 575
    [0.9163, 0.87, 0.001650001, 95.788],          // 580
    [0.9786, 0.8163, 0.0014, 92.2368],            // 585
    [1.0263, 0.757, 0.0011, 88.6856],             // 590
    [1.0567, 0.6949, 0.001, 89.3459],             // 595
    [1.0622, 0.631, 0.0008, 90.0062],             // 600
    [1.0456, 0.5668, 0.0006, 89.8026],            // 605
    [1.0026, 0.503, 0.00034, 89.5991],            // 610
    [0.9384, 0.4412, 0.00024, 88.6489],           // 615
    [0.8544499, 0.381, 0.00019, 87.6987],         // 620
    [0.7514, 0.321, 0.0001, 85.4936],             // 625
    [0.6424, 0.265, 4.999999e-05, 83.2886],       // 630
    [0.5419, 0.217, 3e-05, 83.4939],              // 635
    [0.4479, 0.175, 2e-05, 83.6992],              // 640
    [0.3608, 0.1382, 1e-05, 81.863],              // 645
    [0.2835, 0.107, 0.0, 80.0268],                // 650
    [0.2187, 0.0816, 0.0, 80.1207],               // 655
    [0.1649, 0.061, 0.0, 80.2146],                // 660
    [0.1212, 0.04458, 0.0, 81.2462],              // 665
    [0.0874, 0.032, 0.0, 82.2778],                // 670
    [0.0636, 0.0232, 0.0, 80.281],                // 675
    [0.04677, 0.017, 0.0, 78.2842],               // 680
    [0.0329, 0.01192, 0.0, 74.0027],              // 685
    [0.0227, 0.00821, 0.0, 69.7213],              // 690
    [0.01584, 0.005723, 0.0, 70.6652],            // 695
    [0.01135916, 0.004102, 0.0, 71.6091],         // 700
    [0.008110916, 0.002929, 0.0, 72.979],         // 705
    [0.005790346, 0.002091, 0.0, 74.349],         // 710
    [0.004109457, 0.001484, 0.0, 67.9765],        // 715
    [0.002899327, 0.001047, 0.0, 61.604],         // 720
    [0.00204919, 0.00074, 0.0, 65.7448],          // 725
    [0.001439971, 0.00052, 0.0, 69.8856],         // 730
    [0.0009999493, 0.0003611, 0.0, 72.4863],      // 735
    [0.0006900786, 0.0002492, 0.0, 75.087],       // 740
    [0.0004760213, 0.0001719, 0.0, 69.3398],      // 745
    [0.0003323011, 0.00012, 0.0, 63.5927],        // 750
    [0.0002348261, 8.48e-05, 0.0, 55.0054],       // 755
    [0.0001661505, 6e-05, 0.0, 46.4182],          // 760
    [0.000117413, 4.24e-05, 0.0, 56.6118],        // 765
    [8.307527e-05, 3e-05, 0.0, 66.8054],          // 770
    [5.870652e-05, 2.12e-05, 0.0, 65.0941],       // 775
    [4.150994e-05, 1.499e-05, 0.0, 63.3828],      // 780
    [2.935326e-05, 1.06e-05, 0.0, 63.8434],       // 785
    [2.067383e-05, 7.4657e-06, 0.0, 64.304],      // 790
    [1.455977e-05, 5.2578e-06, 0.0, 61.8779],     // 795
    [1.025398e-05, 3.7029e-06, 0.0, 59.4519],     // 800
    [7.221456e-06, 2.6078e-06, 0.0, 55.7054],     // 805
    [5.085868e-06, 1.8366e-06, 0.0, 51.959],      // 810
    [3.581652e-06, 1.2934e-06, 0.0, 54.6998],     // 815
    [2.522525e-06, 9.1093e-07, 0.0, 57.4406],     // 820
    [1.776509e-06, 6.4153e-07, 0.0, 58.8765],     // 825
    [1.251141e-06, 4.5181e-07, 0.0, 60.3125],     // 830
];

const FIRST_NM: f64 = 360.0;
const LAST_NM: f64 = 830.0;

/// The sum of y over the integration steps times their width (Mitsuba's constant):
/// a spectrum of 1 everywhere has luminance 1.
const Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;

/// The scale of the D65 table under which reflectances are seen (Mitsuba's
/// constant: a reflectance of 1 everywhere gives 0.999).
const D65_NORMALIZATION: f64 = 0.010_101_273_599_490_354;

/// Steps of the integration over [`FIRST_NM`, `LAST_NM`], both ends included.
const STEPS: usize = 1000;

/// XYZ to linear sRGB (ITU-R BT.709 primaries, D65 white).
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240479, -1.537150, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];

/// What a spectrum gives: how it is weighed and clamped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// A reflectance or other fraction: seen under D65, clamped into [0, 1].
    Reflectance,
    /// An emitter's radiance or intensity: weighed evenly, clamped below 0 only.
    Emission,
    /// An index of refraction or absorption: seen under D65, clamped below 0 only.
    Unbounded,
}

impl Quantity {
    /// What parameter `name` gives, directly inside an emitter or not (Mitsuba 3's
    /// rule: the parameter's name and the element it is in).
    pub fn of(name: &str, in_emitter: bool) -> Quantity {
        if matches!(name, "eta" | "k" | "int_ior" | "ext_ior" | "sigma_t") {
            Quantity::Unbounded
        } else if in_emitter {
            Quantity::Emission
        } else {
            Quantity::Reflectance
        }
    }
}

/// A spectrum's colour, and whether it was clamped into the range its quantity
/// allows (an out-of-gamut colour).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Colour {
    pub rgb: Vec3,
    pub clamped: bool,
}

/// The colour of the flat spectrum `value`: that grey, or for an emitter the
/// equal-energy white that bright.
pub fn flat(value: f32, quantity: Quantity) -> Vec3 {
    match quantity {
        Quantity::Emission => value * xyz_to_srgb(DVec3::ONE).as_vec3(),
        _ => Vec3::splat(value),
    }
}

/// The colour of the spectrum through `(wavelength in nm, value)` pairs, their
/// wavelengths increasing, linear between them and 0 outside them. None with fewer
/// than two pairs or wavelengths that do not increase.
pub fn colour(pairs: &[(f32, f32)], quantity: Quantity) -> Option<Colour> {
    if pairs.len() < 2 || pairs.windows(2).any(|w| !(w[1].0 > w[0].0)) {
        return None;
    }
    let d65 = quantity != Quantity::Emission;
    let (first, last) = (f64::from(pairs[0].0), f64::from(pairs[pairs.len() - 1].0));
    let mut xyz = DVec3::ZERO;
    let mut k = 0;
    for i in 0..STEPS {
        let nm = FIRST_NM + (LAST_NM - FIRST_NM) * i as f64 / (STEPS - 1) as f64;
        if nm < first || nm > last {
            continue;
        }
        while k + 2 < pairs.len() && f64::from(pairs[k + 1].0) <= nm {
            k += 1;
        }
        let ((w0, v0), (w1, v1)) = (pairs[k], pairs[k + 1]);
        let (w0, v0, w1, v1) = (f64::from(w0), f64::from(v0), f64::from(w1), f64::from(v1));
        let v = v0 + (v1 - v0) * (nm - w0) / (w1 - w0);
        let [x, y, z, d] = cie(nm);
        let weight = if d65 { d * D65_NORMALIZATION } else { 1.0 };
        xyz += DVec3::new(x, y, z) * (v * weight);
    }
    xyz *= (LAST_NM - FIRST_NM) / STEPS as f64 * Y_NORMALIZATION;
    let rgb = xyz_to_srgb(xyz);
    let kept = match quantity {
        Quantity::Reflectance => rgb.clamp(DVec3::ZERO, DVec3::ONE),
        _ => rgb.max(DVec3::ZERO),
    };
    Some(Colour {
        rgb: kept.as_vec3(),
        clamped: kept != rgb,
    })
}

/// The table's columns at `nm` (in [`FIRST_NM`, `LAST_NM`]), linearly
/// interpolated.
fn cie(nm: f64) -> [f64; 4] {
    let t = (nm - FIRST_NM) / 5.0;
    let i = (t.max(0.0) as usize).min(CIE.len() - 2);
    let f = t - i as f64;
    let (a, b) = (CIE[i], CIE[i + 1]);
    [0, 1, 2, 3].map(|c| a[c] + (b[c] - a[c]) * f)
}

fn xyz_to_srgb(xyz: DVec3) -> DVec3 {
    let m = XYZ_TO_SRGB;
    DVec3::from_array(m.map(|row| row[0] * xyz.x + row[1] * xyz.y + row[2] * xyz.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pairs(s: &[(f32, f32)]) -> Vec<(f32, f32)> {
        s.to_vec()
    }

    fn near(a: Vec3, b: [f32; 3], tol: f32) -> bool {
        (a - Vec3::from(b)).abs().max_element() <= tol * Vec3::from(b).abs().max_element().max(1.0)
    }

    /// Known answers: Mitsuba 3.9.1's `spectrum_list_to_srgb` (scalar_rgb) for the
    /// same spectra; the first is the light of Mitsuba's classic Cornell box.
    #[test]
    fn spectra_give_mitsubas_colours() {
        let light = pairs(&[(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)]);
        let c = colour(&light, Quantity::Emission).unwrap();
        assert!(near(c.rgb, [20.710821, 10.854642, 2.771151], 2e-6), "{c:?}");
        assert!(!c.clamped);
        let white = pairs(&[(400.0, 0.343), (500.0, 0.747), (600.0, 0.740), (700.0, 0.737)]);
        let c = colour(&white, Quantity::Reflectance).unwrap();
        assert!(near(c.rgb, [0.7227536, 0.75958776, 0.5354979], 2e-6), "{c:?}");
        let wide = pairs(&[(300.0, 0.3), (900.0, 0.6)]);
        let c = colour(&wide, Quantity::Unbounded).unwrap();
        assert!(near(c.rgb, [0.470734, 0.42102495, 0.36997062], 2e-6), "{c:?}");
        let c = colour(&wide, Quantity::Emission).unwrap();
        assert!(near(c.rgb, [0.5634125, 0.400019, 0.3352704], 2e-6), "{c:?}");
        let c = colour(
            &pairs(&[(400.0, 0.9), (550.0, 0.5), (700.0, 0.1)]),
            Quantity::Unbounded,
        )
        .unwrap();
        assert!(near(c.rgb, [0.25248876, 0.5186168, 0.7865841], 2e-6), "{c:?}");
    }

    /// A flat reflectance stays grey (D65 is sRGB's white); a flat emission is the
    /// equal-energy white, as Mitsuba's renders show it: 0.5 gives (0.6024, 0.4741,
    /// 0.4545) on an area light.
    #[test]
    fn a_flat_spectrum_is_grey_as_a_reflectance_and_pink_as_a_light() {
        let flat1 = pairs(&[(360.0, 1.0), (830.0, 1.0)]);
        let c = colour(&flat1, Quantity::Reflectance).unwrap();
        assert!(near(c.rgb, [0.99898344, 0.9988723, 0.9988022], 2e-6), "{c:?}");
        let c = colour(&flat1, Quantity::Emission).unwrap();
        assert!(near(c.rgb, [1.2048826, 0.9482289, 0.90926677], 2e-6), "{c:?}");
        assert!(near(
            flat(0.5, Quantity::Emission),
            [0.60239697, 0.47414547, 0.45445794],
            1e-6
        ));
        assert_eq!(flat(0.5, Quantity::Reflectance), Vec3::splat(0.5));
        assert_eq!(flat(1.5, Quantity::Unbounded), Vec3::splat(1.5));
    }

    /// A narrow green band is out of sRGB's gamut: its negative red and blue are
    /// clamped to 0 (Mitsuba: (0, 0.25336727, 0)), and a reflectance over 1 to 1.
    #[test]
    fn out_of_gamut_colours_are_clamped_as_mitsuba_clamps_them() {
        let green = pairs(&[(500.0, 0.2), (520.0, 0.9), (540.0, 0.1)]);
        let c = colour(&green, Quantity::Reflectance).unwrap();
        assert!(c.clamped);
        assert!(near(c.rgb, [0.0, 0.25336727, 0.0], 2e-6), "{c:?}");
        let bright = pairs(&[(400.0, 0.0), (500.0, 8.0), (600.0, 15.6), (700.0, 18.4)]);
        let c = colour(&bright, Quantity::Reflectance).unwrap();
        assert!(c.clamped);
        assert_eq!(c.rgb, Vec3::ONE);
    }

    #[test]
    fn a_spectrum_needs_two_increasing_wavelengths() {
        assert_eq!(colour(&pairs(&[(500.0, 1.0)]), Quantity::Reflectance), None);
        assert_eq!(
            colour(&pairs(&[(500.0, 1.0), (400.0, 1.0)]), Quantity::Reflectance),
            None
        );
        assert_eq!(
            colour(&pairs(&[(500.0, 1.0), (500.0, 1.0)]), Quantity::Emission),
            None
        );
        assert_eq!(Quantity::of("eta", true), Quantity::Unbounded);
        assert_eq!(Quantity::of("radiance", true), Quantity::Emission);
        assert_eq!(Quantity::of("reflectance", false), Quantity::Reflectance);
    }
}
