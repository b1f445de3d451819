//! Text-level helpers of the XML reader: `$name` substitution, numbers and lists,
//! Mitsuba's transform operations and named indices of refraction.
//!
//! Errors are plain messages; the caller adds the file and position.

use std::collections::HashMap;

use crate::scene::texture::srgb_to_linear;
use glam::{Mat4, Vec3, Vec4};

/// A scene file's `version` attribute as (major, minor, patch). Err: the message.
pub fn version(v: &str) -> Result<(u32, u32, u32), String> {
    let parts: Vec<&str> = v.trim().split('.').collect();
    let num = |p: &str| p.parse::<u32>().ok();
    match parts[..] {
        [a, b, c] => match (num(a), num(b), num(c)) {
            (Some(a), Some(b), Some(c)) => Ok((a, b, c)),
            _ => Err(format!("version '{v}' is not three numbers major.minor.patch")),
        },
        _ => Err(format!("version '{v}' is not three numbers major.minor.patch")),
    }
}

/// A Mitsuba 0.6 parameter name in Mitsuba 3's spelling, as Mitsuba 3's in-memory
/// upgrade makes it: an underscore between a lower-case letter and the upper-case
/// run that follows it, which becomes lower case (`toWorld` -> `to_world`, `intIOR`
/// -> `int_ior`, `kNN` -> `k_nn`); other names stay as they are. As there, the
/// letter right after an upper-case run starts no underscore (`aBcD` -> `a_bcD`).
pub fn snake_case(name: &str) -> String {
    let c: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < c.len() {
        out.push(c[i]);
        if c[i].is_ascii_lowercase() && c.get(i + 1).is_some_and(char::is_ascii_uppercase) {
            out.push('_');
            i += 1;
            while i < c.len() && c[i].is_ascii_uppercase() {
                out.push(c[i].to_ascii_lowercase());
                i += 1;
            }
            if let Some(&next) = c.get(i) {
                out.push(next);
                i += 1;
            }
            continue;
        }
        i += 1;
    }
    out
}

/// Replaces every `$name` in `s`, telling `used` each name replaced. As Mitsuba
/// does, the longest declared name that follows the `$` wins. Err: the name after an
/// unresolved `$`.
pub fn substitute(
    s: &str,
    params: &HashMap<String, String>,
    used: &mut dyn FnMut(&str),
) -> Result<String, String> {
    if !s.contains('$') {
        return Ok(s.to_string());
    }
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(k) = rest.find('$') {
        out.push_str(&rest[..k]);
        let after = &rest[k + 1..];
        let best = params
            .iter()
            .filter(|(name, _)| !name.is_empty() && after.starts_with(name.as_str()))
            .max_by_key(|(name, _)| name.len());
        match best {
            Some((name, value)) => {
                used(name);
                out.push_str(value);
                rest = &after[name.len()..];
            }
            None => {
                let ident: String = after
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                return Err(ident);
            }
        }
    }
    out.push_str(rest);
    Ok(out)
}

/// One finite number (stored as f32 later, so it must fit one).
pub fn number(s: &str) -> Result<f32, String> {
    let t = s.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() && (v as f32).is_finite() => Ok(v as f32),
        Ok(_) => Err(format!("number '{t}' is not finite (or out of range)")),
        Err(_) => Err(format!("'{t}' is not a number")),
    }
}

/// An integer.
pub fn integer(s: &str) -> Result<i64, String> {
    let t = s.trim();
    t.parse::<i64>().map_err(|_| format!("'{t}' is not an integer"))
}

/// A boolean, `true` or `false` (any case, as Mitsuba).
pub fn boolean(s: &str) -> Result<bool, String> {
    match s.trim().to_ascii_lowercase().as_str() {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(format!("'{}' is not a boolean (true or false)", s.trim())),
    }
}

/// Splits a list on commas and/or whitespace.
pub fn tokens(s: &str) -> Vec<&str> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect()
}

/// A list of finite numbers separated by commas and/or whitespace.
pub fn numbers(s: &str) -> Result<Vec<f32>, String> {
    tokens(s).into_iter().map(number).collect()
}

/// Exactly three numbers.
pub fn triple(s: &str) -> Result<Vec3, String> {
    let v = numbers(s)?;
    if v.len() != 3 {
        return Err(format!("expected 3 numbers, found {} in '{}'", v.len(), s.trim()));
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// One number (all three the same) or three.
pub fn one_or_three(s: &str) -> Result<Vec3, String> {
    let v = numbers(s)?;
    match v.len() {
        1 => Ok(Vec3::splat(v[0])),
        3 => Ok(Vec3::new(v[0], v[1], v[2])),
        n => Err(format!("expected 1 or 3 numbers, found {n} in '{}'", s.trim())),
    }
}

/// Mitsuba 0.6's `<srgb>` value, gamma-encoded sRGB as `#rrggbb` (hex bytes) or 1 or 3
/// numbers in [0, 1], as the linear colour it stands for (the sRGB curve undone per
/// channel, as Mitsuba 0.6 reads it).
pub fn srgb(s: &str) -> Result<Vec3, String> {
    let t = s.trim();
    let encoded = match t.strip_prefix('#') {
        Some(hex) => {
            let bits = (hex.len() == 6 && hex.bytes().all(|b| b.is_ascii_hexdigit()))
                .then(|| u32::from_str_radix(hex, 16).ok())
                .flatten()
                .ok_or_else(|| format!("'{t}' is not a colour '#rrggbb' of hex digits"))?;
            Vec3::new(
                (bits >> 16) as f32,
                (bits >> 8 & 0xff) as f32,
                (bits & 0xff) as f32,
            ) / 255.0
        }
        None => one_or_three(t)?,
    };
    if !encoded.is_finite() || encoded.min_element() < 0.0 {
        return Err(format!("'{t}' is not a colour of nonnegative numbers"));
    }
    Ok(encoded.map(srgb_to_linear))
}

/// A 4x4 matrix from 16 numbers in row-major order, or a 3x3 linear part from 9.
pub fn matrix(s: &str) -> Result<Mat4, String> {
    let v = numbers(s)?;
    match v.len() {
        16 => Ok(Mat4::from_cols_array(&v.try_into().expect("16 numbers")).transpose()),
        9 => {
            let r = |i: usize| Vec4::new(v[3 * i], v[3 * i + 1], v[3 * i + 2], 0.0);
            Ok(Mat4::from_cols(r(0), r(1), r(2), Vec4::W).transpose())
        }
        n => Err(format!("a matrix needs 16 (or 9) numbers, found {n}")),
    }
}

/// Mitsuba's `rotate`: `angle` degrees about `axis` (right-handed).
pub fn rotation(axis: Vec3, angle_deg: f32) -> Result<Mat4, String> {
    let a = axis.normalize_or_zero();
    if a == Vec3::ZERO {
        return Err("rotation axis is zero".into());
    }
    Ok(Mat4::from_axis_angle(a, angle_deg.to_radians()))
}

/// Mitsuba's `lookat`: columns `(left, up', dir, origin)` with
/// `dir = normalize(target - origin)`, `left = normalize(up x dir)`,
/// `up' = dir x left`. Without `up`, Mitsuba picks one perpendicular to `dir`.
pub fn look_at(origin: Vec3, target: Vec3, up: Option<Vec3>) -> Result<Mat4, String> {
    let d = target - origin;
    if d.length() <= 1e-12 * origin.length().max(1.0) {
        return Err("lookat: origin and target coincide".into());
    }
    let dir = d.normalize();
    let up = match up {
        Some(u) if u != Vec3::ZERO => u,
        _ => dir.any_orthonormal_pair().0,
    };
    let c = up.cross(dir);
    if c.length() <= 1e-6 * up.length() {
        return Err("lookat: 'up' is parallel to the viewing direction".into());
    }
    let left = c.normalize();
    let new_up = dir.cross(left);
    Ok(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// Mitsuba's table of named indices of refraction (case-insensitive).
pub fn named_ior(name: &str) -> Option<f32> {
    const TABLE: &[(&str, f32)] = &[
        ("vacuum", 1.0),
        ("helium", 1.000036),
        ("hydrogen", 1.000132),
        ("air", 1.000277),
        ("carbon dioxide", 1.00045),
        ("water", 1.3330),
        ("acetone", 1.36),
        ("ethanol", 1.361),
        ("carbon tetrachloride", 1.461),
        ("glycerol", 1.4729),
        ("benzene", 1.501),
        ("silicone oil", 1.52045),
        ("bromine", 1.661),
        ("water ice", 1.31),
        ("fused quartz", 1.458),
        ("pyrex", 1.470),
        ("acrylic glass", 1.49),
        ("polypropylene", 1.49),
        ("bk7", 1.5046),
        ("sodium chloride", 1.544),
        ("amber", 1.55),
        ("pet", 1.5750),
        ("diamond", 2.419),
    ];
    let n = name.trim().to_ascii_lowercase();
    TABLE.iter().find(|(k, _)| *k == n).map(|(_, v)| *v)
}

/// The complex index of refraction (`eta`, `k`, linear RGB) of a conductor
/// `material` Mitsuba 3 names, as its RGB variants read it (the spectral data of
/// its `data/ior` files integrated to sRGB); `None` for a name Mitsuba does not know
/// (it fails to load such a file). Names are case-sensitive, as Mitsuba's file
/// names; the `_palik` entries are the same data under another name.
pub fn conductor_ior(material: &str) -> Option<(Vec3, Vec3)> {
    type Entry = (&'static str, [f32; 3], [f32; 3]);
    #[rustfmt::skip]
    const TABLE: &[Entry] = &[
        ("a-C", [2.94405, 2.22714, 1.96816], [0.887465, 0.799299, 0.81529]),
        ("Ag", [0.155276, 0.116728, 0.138388], [4.82835, 3.12222, 2.1469]),
        ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
        ("AlAs", [3.6053, 3.23294, 2.21632], [0.000679437, 0.0, 0.00751271]),
        ("AlSb", [0.0, 4.13937, 4.66925], [0.0, 0.0940091, 1.30057]),
        ("Au", [0.143036, 0.375307, 1.44205], [3.983, 2.38556, 1.60336]),
        ("Be", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
        ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
        ("CsI", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
        ("Cu", [0.201005, 0.92375, 1.10222], [3.91326, 2.45305, 2.14209]),
        ("Cu_palik", [0.213229, 0.919715, 1.10241], [3.92187, 2.45733, 2.13658]),
        ("Cu2O", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
        ("CuO", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
        ("d-C", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
        ("Hg", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
        ("HgTe", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
        ("Ir", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
        ("K", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
        ("Li", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
        ("MgO", [2.08958, 1.65072, 1.59488], [4.3327e-12, 0.0, 2.49865e-11]),
        ("Mo", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
        ("Na_palik", [0.0602694, 0.0561409, 0.0619884], [3.17927, 2.11249, 1.57904]),
        ("Nb", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
        ("Ni_palik", [2.3673, 1.66337, 1.46708], [4.49881, 3.05015, 2.34544]),
        ("Rh", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
        ("Se", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
        ("Se-e", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
        ("SiC", [3.17234, 2.52597, 2.47937], [7.53766e-07, 0.0, 1.01925e-05]),
        ("SnTe", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
        ("Ta", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
        ("Te", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
        ("Te-e", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
        ("ThF4", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
        ("TiC", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
        ("TiN", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
        ("TiO2", [3.45661, 2.80174, 2.90517], [0.000105265, 0.0, 0.000652887]),
        ("TiO2-e", [3.10656, 2.51317, 2.58244], [2.97516e-05, 0.0, 0.000182698]),
        ("V_palik", [4.27758, 3.51295, 2.76107], [3.4913, 2.88945, 3.11152]),
        ("VC", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
        ("VN", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
        ("W", [4.37082, 3.30025, 2.99841], [3.50064, 2.60487, 2.27323]),
    ];
    // Mitsuba's `_palik` files repeat the plain names' data (but copper's).
    const ALIASES: &[&str] = &[
        "a-C", "AlAs", "AlSb", "Be", "CsI", "Cu2O", "CuO", "d-C", "Hg", "HgTe", "Ir", "K", "Li", "MgO", "Mo",
        "Nb", "Rh", "Se", "Se-e", "SiC", "SnTe", "Ta", "Te", "Te-e", "ThF4", "TiC", "TiN", "TiO2", "TiO2-e",
        "VC", "VN",
    ];
    let m = material.trim();
    let name = match m.strip_suffix("_palik") {
        Some(base) if ALIASES.contains(&base) => base,
        _ => m,
    };
    TABLE
        .iter()
        .find(|(k, _, _)| *k == name)
        .map(|(_, eta, k)| (Vec3::from_array(*eta), Vec3::from_array(*k)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(kv: &[(&str, &str)]) -> HashMap<String, String> {
        kv.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()
    }

    #[test]
    fn substitution_prefers_longest_name() {
        let p = params(&[("x", "1"), ("xy", "2")]);
        assert_eq!(substitute("$x_", &p, &mut |_| {}).unwrap(), "1_");
        assert_eq!(substitute("$xy $x", &p, &mut |_| {}).unwrap(), "2 1");
        assert_eq!(substitute("a$x,b", &p, &mut |_| {}).unwrap(), "a1,b");
        assert_eq!(substitute("no dollars", &p, &mut |_| {}).unwrap(), "no dollars");
        assert_eq!(substitute("$spp", &p, &mut |_| {}), Err("spp".into()));
    }

    #[test]
    fn numbers_and_lists() {
        assert_eq!(numbers("1, 2 3,4").unwrap(), vec![1.0, 2.0, 3.0, 4.0]);
        assert_eq!(number(" -2.5e1 ").unwrap(), -25.0);
        assert!(number("nan").is_err());
        assert!(number("inf").is_err());
        assert!(number("1e300").is_err());
        assert!(number("abc").is_err());
        assert_eq!(one_or_three("0.5").unwrap(), Vec3::splat(0.5));
        assert_eq!(one_or_three("1 2 3").unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert!(one_or_three("1 2").is_err());
        assert!(triple("1").is_err());
        assert_eq!(integer("42").unwrap(), 42);
        assert!(integer("4.2").is_err());
        assert!(boolean("TRUE").unwrap());
        assert!(boolean("yes").is_err());
    }

    #[test]
    fn matrix_is_row_major() {
        let m = matrix("1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1").unwrap();
        assert_eq!(m.transform_point3(Vec3::ZERO), Vec3::new(5.0, 6.0, 7.0));
        let m = matrix("0 -1 0 0 1 0 0 0 0 0 1 0 0 0 0 1").unwrap();
        // Row-major: first row (0, -1, 0) gives x' = -y.
        assert_eq!(m.transform_point3(Vec3::Y), Vec3::new(-1.0, 0.0, 0.0));
        let m3 = matrix("2 0 0 0 3 0 0 0 4").unwrap();
        assert_eq!(m3.transform_point3(Vec3::ONE), Vec3::new(2.0, 3.0, 4.0));
        assert!(matrix("1 2 3").is_err());
    }

    #[test]
    fn look_at_columns() {
        // Camera at (0,0,5) looking at the origin, up +y.
        let m = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Some(Vec3::Y)).unwrap();
        // dir = -z; left = normalize(y x -z) = -x; up' = -z x -x = y.
        assert!((m.x_axis.truncate() - Vec3::NEG_X).length() < 1e-6);
        assert!((m.y_axis.truncate() - Vec3::Y).length() < 1e-6);
        assert!((m.z_axis.truncate() - Vec3::NEG_Z).length() < 1e-6);
        assert_eq!(m.w_axis, glam::Vec4::new(0.0, 0.0, 5.0, 1.0));
        assert!(look_at(Vec3::ONE, Vec3::ONE, Some(Vec3::Y)).is_err());
        assert!(look_at(Vec3::ZERO, Vec3::Y, Some(Vec3::Y)).is_err());
        // Without up: some perpendicular frame, still orthonormal.
        let m = look_at(Vec3::ZERO, Vec3::X, None).unwrap();
        assert!((m.z_axis.truncate() - Vec3::X).length() < 1e-6);
        assert!(m.y_axis.truncate().dot(Vec3::X).abs() < 1e-6);
    }

    #[test]
    fn rotation_is_right_handed() {
        let r = rotation(Vec3::new(0.0, 0.0, 2.0), 90.0).unwrap();
        assert!((r.transform_point3(Vec3::X) - Vec3::Y).length() < 1e-6);
        assert!(rotation(Vec3::ZERO, 10.0).is_err());
    }

    #[test]
    fn iors_and_metals() {
        assert_eq!(named_ior("BK7"), Some(1.5046));
        assert_eq!(named_ior("acrylic glass"), Some(1.49));
        assert_eq!(named_ior("air"), Some(1.000277));
        assert_eq!(named_ior("unobtainium"), None);
        // Mitsuba 3.9's RGB figures; the `_palik` names as Mitsuba's files alias them.
        let (eta, k) = conductor_ior("Au").unwrap();
        assert_eq!(eta, Vec3::new(0.143036, 0.375307, 1.44205));
        assert_eq!(k, Vec3::new(3.983, 2.38556, 1.60336));
        assert_eq!(conductor_ior("Hg_palik"), conductor_ior("Hg"));
        assert_ne!(conductor_ior("Cu_palik"), conductor_ior("Cu"));
        assert_eq!(conductor_ior("Ni_palik").unwrap().1.x, 4.49881);
        // Names Mitsuba has no file for.
        for bad in ["Fe", "Ti", "Au_palik", "au", "Ni", "none"] {
            assert_eq!(conductor_ior(bad), None, "{bad}");
        }
    }
}
