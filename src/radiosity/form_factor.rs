//! The exact unoccluded form factor from a point to a polygon (Lambert's formula).

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

/// Lambert's signed term of the polygon edge from unit vector `a` to unit vector `b`
/// (seen from the receiver, normal `n`): the edge's angle times the cosine of its
/// plane's normal with `n`.
fn edge_term(n: Vec3, a: Vec3, b: Vec3) -> f32 {
    let c = a.cross(b);
    let l = c.length();
    if l > 1e-12 {
        n.dot(c / l) * angle(l, a.dot(b))
    } else {
        0.0
    }
}

/// The form factors from `x` (unit normal `n`) to the four quarters of the triangle
/// or quadrilateral `poly` ([`crate::mesh::quarter`], in its order), or `None` where
/// a corner lies on or below the plane of `x` (then each quarter needs clipping:
/// [`point_polygon_form_factor`]). The quarters share their inner edges, whose
/// Lambert terms cancel pairwise, so 12 edge terms serve a quadrilateral's quarters
/// and 9 a triangle's, against 16 and 12 quarter by quarter.
pub fn quarter_form_factors(x: Vec3, n: Vec3, poly: &[Vec3]) -> Option<[f32; 4]> {
    if poly.iter().any(|c| !(n.dot(*c - x) > 0.0)) {
        return None;
    }
    let unit = |c: Vec3| (c - x).normalize_or_zero();
    let term = |a: Vec3, b: Vec3| edge_term(n, a, b);
    let k = 1.0 / (2.0 * std::f32::consts::PI);
    let q = match *poly {
        [c0, c1, c2] => {
            let (r0, r1, r2) = (unit(c0), unit(c1), unit(c2));
            let (m01, m12, m02) = (
                unit((c0 + c1) * 0.5),
                unit((c1 + c2) * 0.5),
                unit((c0 + c2) * 0.5),
            );
            // Inner edges.
            let (a, b, c) = (term(m01, m02), term(m12, m01), term(m02, m12));
            [
                term(r0, m01) + a + term(m02, r0),
                term(m01, r1) + term(r1, m12) + b,
                c + term(m12, r2) + term(r2, m02),
                -b - c - a,
            ]
        }
        [c0, c1, c2, c3] => {
            let (r0, r1, r2, r3) = (unit(c0), unit(c1), unit(c2), unit(c3));
            let centre = unit(crate::mesh::point_in_polygon(poly, glam::Vec2::splat(0.5)));
            let mid = |a: Vec3, b: Vec3| unit((a + b) * 0.5);
            let (m01, m12, m23, m30) = (mid(c0, c1), mid(c1, c2), mid(c2, c3), mid(c3, c0));
            // Inner edges, each from an edge's midpoint to the centre.
            let (ia, ib, ic, id) = (
                term(m01, centre),
                term(m12, centre),
                term(m23, centre),
                term(m30, centre),
            );
            [
                term(r0, m01) + ia - id + term(m30, r0),
                term(m01, r1) + term(r1, m12) + ib - ia,
                id - ic + term(m23, r3) + term(r3, m30),
                -ib + term(m12, r2) + term(r2, m23) + ic,
            ]
        }
        _ => return None,
    };
    Some(q.map(|v| v.abs() * k))
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

    /// The quarters' form factors by shared edges equal each quarter's own, clipped
    /// form factor and sum to the whole polygon's, for a quadrilateral and a
    /// triangle seen from near and far, straight on and askew; a polygon that
    /// crosses the receiver's plane is left to the clipped form.
    #[test]
    fn quarter_form_factors_are_each_quarters_and_sum_to_the_whole() {
        let quad = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.2, 0.8, 0.0),
            Vec3::new(-0.1, 1.0, 0.0),
        ];
        let tri = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.2, 0.9, 0.0),
        ];
        for poly in [&quad[..], &tri[..]] {
            // Receivers above the polygon (in z = 0) facing it.
            for (x, n) in [
                (Vec3::new(0.3, 0.2, 0.05), Vec3::new(0.0, 0.0, -1.0)),
                (Vec3::new(0.5, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0)),
                (Vec3::new(-0.5, 0.4, 0.3), Vec3::new(0.6, 0.0, -0.8)),
            ] {
                let q = quarter_form_factors(x, n, poly).expect("all corners above");
                let whole = point_polygon_form_factor(x, n, poly);
                assert!((q.iter().sum::<f32>() - whole).abs() < 1e-5, "{q:?} vs {whole}");
                for (k, f) in q.iter().enumerate() {
                    let (c, len) = crate::mesh::quarter(poly, k);
                    let own = point_polygon_form_factor(x, n, &c[..len]);
                    assert!((f - own).abs() < 1e-5, "quarter {k}: {f} vs {own}");
                }
            }
        }
        let across = (Vec3::new(0.5, 0.5, 0.0), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(quarter_form_factors(across.0, across.1, &quad), None);
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
