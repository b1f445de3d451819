//! The diffuse albedo pass 1 gives each patch: its material's, or, for a textured
//! material, the texture's mean over the patch's own (u, v) (Sect. 6's radiosity
//! stays per patch; the render puts the texture's detail back, texel over this mean);
//! and the share of the patch a `mask` leaves.

use glam::{Vec2, Vec3};

use crate::geometry::TriMesh;
use crate::scene::{Bsdf, Rgb, TexField, Texture};

/// Whether `bsdf`'s diffuse albedo or opacity varies over a surface (a texture on its
/// diffuse reflectance, on a blend's weight, or a `mask`).
pub fn textured_albedo(bsdf: &Bsdf) -> bool {
    bsdf.textures
        .iter()
        .any(|t| matches!(t.field, TexField::Diffuse | TexField::Weight | TexField::Opacity))
}

/// The mean diffuse albedo of `bsdf` over the part of triangles `tris` of `mesh` that
/// its `mask` leaves, and that part's share of their area (1 without a mask); areas
/// weigh the triangles. Each triangle's (u, v) is sampled at the centroids of k x k
/// sub-triangles, k from 2 to 8 as the texels it covers grow. `bsdf`'s own albedo when
/// untextured or when nothing is left.
pub fn mean_albedo(
    mesh: &TriMesh,
    tris: impl Iterator<Item = u32>,
    bsdf: &Bsdf,
    textures: &[Texture],
) -> (Rgb, f32) {
    if !textured_albedo(bsdf) {
        return (bsdf.kind.diffuse_albedo(), 1.0);
    }
    let masked = bsdf.masked();
    // The largest texture sets the sampling density.
    let texels = bsdf
        .textures
        .iter()
        .filter_map(|t| textures.get(t.texture as usize))
        .map(|t| {
            let (w, h) = t.size();
            f64::from(w) * f64::from(h)
        })
        .fold(1.0, f64::max);
    let mut sum = Vec3::ZERO.as_dvec3();
    let (mut present, mut total) = (0.0f64, 0.0f64);
    for tri in tris {
        let Some(&[a, b, c]) = mesh.indices.get(tri as usize) else {
            continue;
        };
        let p = |i: u32| mesh.positions[i as usize];
        let area = f64::from((p(b) - p(a)).cross(p(c) - p(a)).length() * 0.5);
        if !(area > 0.0) {
            continue;
        }
        let uv = |b: Vec2| mesh.uv_at(tri, b);
        let (u0, u1, u2) = (uv(Vec2::ZERO), uv(Vec2::X), uv(Vec2::Y));
        let uv_area = f64::from((u1 - u0).perp_dot(u2 - u0).abs() * 0.5);
        let k = ((uv_area * texels).sqrt() / 4.0).clamp(2.0, 8.0) as u32;
        let (mut tri_sum, mut tri_present) = (Vec3::ZERO, 0.0f32);
        for_each_centroid(k, |bary| {
            let at = uv(bary);
            let opacity = if masked {
                bsdf.opacity_at(at, textures)
            } else {
                1.0
            };
            tri_sum += bsdf.kind_at(at, textures).diffuse_albedo() * opacity;
            tri_present += opacity;
        });
        let per = area / f64::from(k * k);
        sum += tri_sum.as_dvec3() * per;
        present += f64::from(tri_present) * per;
        total += area;
    }
    if present > 0.0 {
        ((sum / present).as_vec3(), (present / total) as f32)
    } else if total > 0.0 {
        (bsdf.kind.diffuse_albedo(), 0.0)
    } else {
        (bsdf.kind.diffuse_albedo(), 1.0)
    }
}

/// Calls `f` with the barycentrics (of the second and third corners) of the centroids
/// of the k^2 congruent sub-triangles of a triangle split k times along each edge.
fn for_each_centroid(k: u32, mut f: impl FnMut(Vec2)) {
    let s = 1.0 / k as f32;
    for i in 0..k {
        for j in 0..k - i {
            let (x, y) = (i as f32, j as f32);
            // The upright sub-triangle with corner (i, j), and the inverted one beside it.
            f(Vec2::new(x + 1.0 / 3.0, y + 1.0 / 3.0) * s);
            if i + j + 1 < k {
                f(Vec2::new(x + 2.0 / 3.0, y + 2.0 / 3.0) * s);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centroids_cover_the_triangle_evenly() {
        for k in 1..6 {
            let mut n = 0;
            let mut mean = Vec2::ZERO;
            for_each_centroid(k, |b| {
                assert!(b.x > 0.0 && b.y > 0.0 && b.x + b.y < 1.0, "{b}");
                n += 1;
                mean += b;
            });
            assert_eq!(n, k * k);
            // The sub-triangles' centroids average to the triangle's.
            assert!((mean / n as f32 - Vec2::splat(1.0 / 3.0)).length() < 1e-5);
        }
    }
}
