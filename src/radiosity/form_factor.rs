//! The form factors from a point to the four quarters of a shooting cell, by
//! shared edges of Lambert's formula ([`crate::geometry::point_polygon_form_factor`]).

use glam::Vec3;

use crate::geometry::edge_term;

/// The form factors from `x` (unit normal `n`) to the four quarters of the triangle
/// or quadrilateral `poly` ([`crate::mesh::quarter`], in its order), or `None` where
/// a corner lies on or below the plane of `x` (then each quarter needs clipping:
/// [`crate::geometry::point_polygon_form_factor`]). The quarters share their inner edges, whose
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::point_polygon_form_factor;

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
}
