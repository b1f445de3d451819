//! Text-level helpers of the XML reader: `$name` substitution, numbers and lists,
//! Mitsuba's transform operations and named indices of refraction.
//!
//! Errors are plain messages; the caller adds the file and position.

use std::collections::HashMap;

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

/// Replaces every `$name` in `s`. As Mitsuba does, the longest declared name that
/// follows the `$` wins. Err: the name after an unresolved `$`.
pub fn substitute(s: &str, params: &HashMap<String, String>) -> Result<String, String> {
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

/// Approximate normal-incidence reflectance (linear RGB) of Mitsuba's conductor
/// materials, from the usual real-time rendering tables.
pub fn conductor_f0(material: &str) -> Option<Vec3> {
    const TABLE: &[(&str, [f32; 3])] = &[
        ("Ag", [0.972, 0.960, 0.915]),
        ("Al", [0.913, 0.922, 0.924]),
        ("Au", [1.000, 0.782, 0.344]),
        ("Cu", [0.955, 0.638, 0.538]),
        ("Cr", [0.549, 0.556, 0.554]),
        ("Hg", [0.781, 0.780, 0.778]),
        ("Ni_palik", [0.660, 0.609, 0.526]),
        ("Ti", [0.542, 0.497, 0.449]),
        ("Fe", [0.562, 0.565, 0.578]),
    ];
    TABLE
        .iter()
        .find(|(k, _)| *k == material.trim())
        .map(|(_, v)| Vec3::from_array(*v))
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
        assert_eq!(substitute("$x_", &p).unwrap(), "1_");
        assert_eq!(substitute("$xy $x", &p).unwrap(), "2 1");
        assert_eq!(substitute("a$x,b", &p).unwrap(), "a1,b");
        assert_eq!(substitute("no dollars", &p).unwrap(), "no dollars");
        assert_eq!(substitute("$spp", &p), Err("spp".into()));
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
        assert!(conductor_f0("Au").unwrap().x > 0.99);
    }
}
