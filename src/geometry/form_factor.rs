//! The exact unoccluded form factor from a point to a polygon (Lambert's formula),
//! which the radiosity pass's shots and the render's analytic light term share.

use glam::Vec3;

/// The exact form factor from a differential area at `x` with unit normal `n` to a
/// polygon (Lambert's formula), after clipping the polygon to the hemisphere above
/// `x`. Unoccluded.
pub fn point_polygon_form_factor(x: Vec3, n: Vec3, poly: &[Vec3]) -> f32 {
    // Clip against the plane n . (y - x) >= 0 (Sutherland-Hodgman, one plane).
    let mut clipped = [Vec3::ZERO; 8];
    let mut len = 0;
    let m = poly.len();
    for i in 0..m {
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        let (da, db) = (n.dot(a - x), n.dot(b - x));
        if da >= 0.0 {
            clipped[len] = a;
            len += 1;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            clipped[len] = a + (b - a) * t;
            len += 1;
        }
    }
    if len < 3 {
        return 0.0;
    }
    // The unit vectors to the corners, each normalised once.
    let mut r = [Vec3::ZERO; 8];
    for (ri, c) in r.iter_mut().zip(&clipped[..len]) {
        *ri = (*c - x).normalize_or_zero();
    }
    let sum: f32 = (0..len).map(|i| edge_term(n, r[i], r[(i + 1) % len])).sum();
    sum.abs() / (2.0 * std::f32::consts::PI)
}

/// The vector form factor of a polygon from a point at `x` (Lambert's formula
/// without a receiver): its dot product with a unit normal `n` is the form factor
/// [`point_polygon_form_factor`] gives (up to sign, by the polygon's winding) where
/// the whole polygon is above the plane through `x` normal to `n`. The sky's cells,
/// so far off that every receiver sees each one alike, take it once for all.
pub fn polygon_vector_form_factor(x: Vec3, poly: &[Vec3]) -> Vec3 {
    let m = poly.len();
    let r: Vec<Vec3> = poly.iter().map(|c| (*c - x).normalize_or_zero()).collect();
    (0..m)
        .filter_map(|i| edge(r[i], r[(i + 1) % m]))
        .map(|(axis, angle)| axis * angle)
        .sum::<Vec3>()
        / (2.0 * std::f32::consts::PI)
}

/// The polygon edge from unit vector `a` to unit vector `b` (seen from the
/// receiver): the unit normal of its plane and its angle; `None` for an edge of no
/// angle.
fn edge(a: Vec3, b: Vec3) -> Option<(Vec3, f32)> {
    let c = a.cross(b);
    let l = c.length();
    (l > 1e-12).then(|| (c / l, angle(l, a.dot(b))))
}

/// Lambert's signed term of the polygon edge from unit vector `a` to unit vector `b`
/// (seen from the receiver, normal `n`): the edge's angle times the cosine of its
/// plane's normal with `n`.
pub fn edge_term(n: Vec3, a: Vec3, b: Vec3) -> f32 {
    edge(a, b).map_or(0.0, |(axis, angle)| n.dot(axis) * angle)
}

/// `atan2(s, c)` for `s >= 0`: the angle between two unit vectors from the sine and
/// cosine of it, in `[0, pi]`. Cephes' `atanf` polynomial after reduction to
/// `|x| <= tan(pi/8)`: within 3e-7 (an f32 ulp of pi) of the exact angle, and cheaper
/// than libm's `atan2f`, which was a fifth of the solve's instructions.
fn angle(s: f32, c: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (a, b) = (s, c.abs());
    // r = min / max in [0, 1]; the angle of (max, min) is atan(r).
    let (lo, hi) = if a > b { (b, a) } else { (a, b) };
    if !(hi > 0.0) {
        return 0.0;
    }
    let r = lo / hi;
    let (base, x) = if r > 0.414_213_57 {
        (FRAC_PI_4, (r - 1.0) / (r + 1.0))
    } else {
        (0.0, r)
    };
    let z = x * x;
    let p = (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * x + x;
    let t = base + p;
    // Undo the swap (angle above pi/4) and the reflection (negative cosine).
    let t = if a > b { FRAC_PI_2 - t } else { t };
    if c < 0.0 {
        PI - t
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// Dotted with a receiver's normal, the vector form factor is the clipped
    /// polygon's form factor wherever the polygon is wholly above the receiver.
    #[test]
    fn the_vector_form_factor_gives_the_form_factor_above_the_horizon() {
        let poly = [
            Vec3::new(-1.0, -0.5, 2.0),
            Vec3::new(1.5, -0.5, 2.5),
            Vec3::new(1.0, 1.0, 2.0),
            Vec3::new(-0.5, 1.2, 1.8),
        ];
        let x = Vec3::new(0.1, 0.2, 0.0);
        let phi = polygon_vector_form_factor(x, &poly);
        let mut checked = 0;
        for k in 0..64 {
            let (t, p) = (k as f32 * 0.37, k as f32 * 0.11);
            let n = Vec3::new(t.cos() * p.sin(), t.sin() * p.sin(), p.cos()).normalize();
            if poly.iter().all(|c| n.dot(*c - x) > 0.0) {
                let exact = point_polygon_form_factor(x, n, &poly);
                assert!(
                    (n.dot(phi).abs() - exact).abs() < 1e-6 * exact.max(1.0),
                    "{n}: {} vs {exact}",
                    n.dot(phi)
                );
                assert!(exact > 0.01);
                checked += 1;
            }
        }
        assert!(checked > 10, "{checked}");
    }

    #[test]
    fn angle_matches_atan2_to_about_one_ulp_of_pi() {
        let mut worst = 0.0f64;
        for i in 0..=2000 {
            let th = std::f64::consts::PI * i as f64 / 2000.0;
            for scale in [1e-3f64, 1.0, 7.5] {
                let (s, c) = ((th.sin() * scale) as f32, (th.cos() * scale) as f32);
                let exact = (s as f64).atan2(c as f64);
                worst = worst.max((angle(s, c) as f64 - exact).abs());
            }
        }
        assert!(worst < 3e-7, "{worst}");
        assert_eq!(angle(0.0, 0.0), 0.0);
        assert_eq!(angle(0.0, 2.0), 0.0);
        assert!((angle(0.0, -2.0) - PI).abs() < 1e-6);
        assert!((angle(3.0, 0.0) - PI / 2.0).abs() < 1e-6);
    }
}
