//! The diffuse albedo pass 1 gives each patch and each vertex: its material's, or,
//! for a textured material, the texture's mean over the patch's own (u, v), and over
//! the surface each vertex stands for ([`RadiosityMesh::albedo`]): a vertex's
//! radiosity is its irradiance times that mean, and the render puts the texture's
//! detail back, texel over the mean the vertices interpolate to there. Also the share
//! of the patch a `mask` leaves.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::{Interp, RadiosityMesh};
use crate::accel::Hit;
use crate::geometry::TriMesh;
use crate::sampling::{derive, uniform3, Stream};
use crate::scene::{Bsdf, Rgb, Scene, TexField, Texture};

/// Samples of the texture per element's area (about; at least one per triangle).
const SAMPLES_PER_ELEMENT: f32 = 8.0;

/// Halvings of a triangle at most while it is sampled finer than its elements.
const MAX_HALVINGS: u32 = 16;

/// Triangles per parallel job of [`RadiosityMesh::vertex_albedo`].
const JOB: usize = 256;

impl RadiosityMesh {
    /// The diffuse albedo vertex `v`'s radiosity is made with: the mean of its
    /// material's texture over the surface around it, or its patch's reflectance.
    pub fn albedo(&self, v: u32) -> Rgb {
        match self.albedo.get(v as usize) {
            Some(&a) => a,
            None => self.patches[self.vertices[v as usize].patch as usize].reflectance,
        }
    }

    /// The albedo the vertices of `w` interpolate to (the weights' mean of
    /// [`Self::albedo`]): what the radiosity interpolated with `w` is over the
    /// irradiance.
    pub fn albedo_at(&self, w: &Interp) -> Rgb {
        let (mut sum, mut total) = (Vec3::ZERO, 0.0);
        for k in 0..4 {
            if w.weights[k] > 0.0 {
                sum += self.albedo(w.vertices[k]) * w.weights[k];
                total += w.weights[k];
            }
        }
        if total > 0.0 {
            sum / total
        } else {
            self.albedo(w.vertices[0])
        }
    }

    /// Per vertex, the mean diffuse albedo of its material (a textured one's texels,
    /// over the part a `mask` leaves) over the surface its interpolation weights
    /// cover: each triangle of a textured shape is halved until its pieces are an
    /// eighth of an element (of the patch at the piece's centre), a jittered point of
    /// each piece read, and its albedo spread over the vertices by the weights the
    /// render interpolates with there ([`Self::locate_on`]). Empty when no material is
    /// textured. Deterministic (fixed jitter, sums in a fixed order), as a solution
    /// file's mesh must be rebuilt the same.
    pub(super) fn vertex_albedo(&self, scene: &Scene) -> Vec<Rgb> {
        let textured: Vec<u32> = (0..scene.shapes.len() as u32)
            .filter(|&s| {
                let shape = &scene.shapes[s as usize];
                textured_albedo(&scene.bsdfs[shape.bsdf as usize])
            })
            .collect();
        if textured.is_empty() {
            return Vec::new();
        }
        // The element's area of each front patch.
        let element: Vec<f32> = self.patches[..self.front_patches as usize]
            .iter()
            .map(|p| p.area / p.element_count.max(1) as f32)
            .collect();
        let jobs: Vec<(u32, usize)> = textured
            .iter()
            .flat_map(|&s| {
                let n = scene.shapes[s as usize].mesh.triangle_count();
                (0..n).step_by(JOB).map(move |t| (s, t))
            })
            .collect();
        let parts: Vec<Vec<(u32, Vec3, f32)>> = jobs
            .par_iter()
            .map(|&(s, first)| {
                let mesh = &scene.shapes[s as usize].mesh;
                let last = (first + JOB).min(mesh.triangle_count());
                let mut out = Vec::new();
                for t in first..last {
                    self.sample_albedo(scene, s, t as u32, &element, &mut out);
                }
                // One entry per vertex, in a fixed order.
                out.sort_by_key(|d| d.0);
                let mut merged: Vec<(u32, Vec3, f32)> = Vec::with_capacity(out.len() / 4);
                for d in out {
                    match merged.last_mut() {
                        Some(m) if m.0 == d.0 => {
                            m.1 += d.1;
                            m.2 += d.2;
                        }
                        _ => merged.push(d),
                    }
                }
                merged
            })
            .collect();
        let nv = self.vertices.len();
        let mut sum = vec![Vec3::ZERO; nv];
        let mut weight = vec![0.0f32; nv];
        for (v, a, w) in parts.into_iter().flatten() {
            sum[v as usize] += a;
            weight[v as usize] += w;
        }
        let mut albedo: Vec<Rgb> = (0..nv)
            .map(|v| {
                if weight[v] > 0.0 {
                    sum[v] / weight[v]
                } else {
                    self.patches[self.vertices[v].patch as usize].reflectance
                }
            })
            .collect();
        // A back twin's vertices (in its front's order) take its front's.
        for front in &self.patches[..self.front_patches as usize] {
            let Some(twin) = front.twin.map(|t| &self.patches[t as usize]) else {
                continue;
            };
            let (from, to) = (front.first_vertex as usize, twin.first_vertex as usize);
            let n = (twin.vertex_count as usize).min(front.vertex_count as usize);
            albedo.copy_within(from..from + n, to);
        }
        albedo
    }

    /// [`Self::vertex_albedo`]'s samples of triangle `t` of shape `s`: (vertex,
    /// albedo times weight, weight), the weights being the interpolation weights times
    /// the sample's area and the opacity there.
    fn sample_albedo(&self, scene: &Scene, s: u32, t: u32, element: &[f32], out: &mut Vec<(u32, Vec3, f32)>) {
        let shape = &scene.shapes[s as usize];
        let mesh = &shape.mesh;
        let bsdf = &scene.bsdfs[shape.bsdf as usize];
        let [a, b, c] = mesh.triangle(t as usize);
        let at = |bary: Vec2| a + (b - a) * bary.x + (c - a) * bary.y;
        let area = 0.5 * (b - a).cross(c - a).length();
        if !(area > 0.0) {
            return;
        }
        let hit = |bary: Vec2| Hit {
            t: 0.0,
            shape: s,
            tri: t,
            bary,
        };
        let seed = derive(derive(0, Stream::Texel(s)), Stream::Texel(t));
        let masked = bsdf.masked();
        let mut draws = 0u32;
        // Pieces as barycentric corners, with their halvings.
        let mut todo = vec![([Vec2::ZERO, Vec2::X, Vec2::Y], 0u32)];
        while let Some((q, depth)) = todo.pop() {
            let piece_area = area / 4f32.powi(depth as i32);
            let centre = (q[0] + q[1] + q[2]) / 3.0;
            let p = self.patch_of(scene, &hit(centre)) as usize;
            let fine = element.get(p).copied().unwrap_or(f32::INFINITY) / SAMPLES_PER_ELEMENT;
            if piece_area > fine && depth < MAX_HALVINGS {
                let m = [(q[0] + q[1]) * 0.5, (q[1] + q[2]) * 0.5, (q[2] + q[0]) * 0.5];
                todo.extend([
                    ([q[0], m[0], m[2]], depth + 1),
                    ([m[0], q[1], m[1]], depth + 1),
                    ([m[2], m[1], q[2]], depth + 1),
                    ([m[0], m[1], m[2]], depth + 1),
                ]);
                continue;
            }
            let [u, v, _] = uniform3(seed, draws);
            draws += 1;
            // A uniform point of the piece.
            let r = u.sqrt();
            let bary = q[0] * (1.0 - r) + q[1] * (r * (1.0 - v)) + q[2] * (r * v);
            let h = hit(bary);
            let uv = mesh.uv_at(t, bary);
            let opacity = if masked {
                bsdf.opacity_at(uv, &scene.textures)
            } else {
                1.0
            };
            if !(opacity > 0.0) {
                continue;
            }
            let rho = bsdf.kind_at(uv, 0.0, &scene.textures).diffuse_albedo();
            let p = self.patch_of(scene, &h);
            let w = self.locate_on(scene, p, &h, at(bary));
            for k in 0..4 {
                let wk = w.weights[k] * piece_area * opacity;
                if wk > 0.0 {
                    out.push((w.vertices[k], rho * wk, wk));
                }
            }
        }
    }
}

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
            tri_sum += bsdf.kind_at(at, 0.0, textures).diffuse_albedo() * opacity;
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
