//! Bicubic Bezier patches (the Newell teapot): evaluation and tessellation.
//!
//! Orientation rule: the front of a patch is the side `dp/du x dp/dv` points to
//! (negated when `flipped`), and tessellated triangles wind counter-clockwise seen
//! from that side. With `ctrl[4 * i + j]` read as row `i` along v and column `j`
//! along u, the Newell teapot's 32 patches (`teapot.bpt`) all come out consistently
//! oriented with this normal pointing OUTWARD (body, lid, spout, handle, bottom;
//! the rim's inner face points towards the axis), so no flip is needed for it.

use std::path::Path;

use glam::{DVec3, Vec2, Vec3};

use crate::error::Pos;
use crate::geometry::text::{parse_coord, text_lines, tokens};
use crate::geometry::{Patch, TriMesh};
use crate::{Error, Result};

/// A bicubic Bezier patch: a 4x4 control net, row by row (`ctrl[4 * i + j]`, row i
/// along v, column j along u), so `p(u, v) = sum B_i(v) B_j(u) ctrl[4 * i + j]` and
/// the corners are `p(0,0) = ctrl[0]`, `p(1,0) = ctrl[3]`, `p(0,1) = ctrl[12]`,
/// `p(1,1) = ctrl[15]`. Its normal is `dp/du x dp/dv` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BezierPatch {
    /// Control points.
    pub ctrl: [Vec3; 16],
    /// True when the surface's normal is to be taken reversed (after `flip_normals`).
    pub flipped: bool,
}

/// Cubic Bernstein basis and its derivative at `t`.
fn bernstein(t: f64) -> ([f64; 4], [f64; 4]) {
    let s = 1.0 - t;
    (
        [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t],
        [
            -3.0 * s * s,
            3.0 * s * s - 6.0 * t * s,
            6.0 * t * s - 3.0 * t * t,
            3.0 * t * t,
        ],
    )
}

/// Point and partial derivatives in f64: no visible rounding noise, so a collapsed
/// edge evaluates to exactly one point and a zero derivative.
fn eval64(b: &BezierPatch, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
    let (bu, du) = bernstein(u);
    let (bv, dv) = bernstein(v);
    let mut p = DVec3::ZERO;
    let mut pu = DVec3::ZERO;
    let mut pv = DVec3::ZERO;
    for i in 0..4 {
        for j in 0..4 {
            let c = b.ctrl[4 * i + j].as_dvec3();
            p += bv[i] * bu[j] * c;
            pu += bv[i] * du[j] * c;
            pv += dv[i] * bu[j] * c;
        }
    }
    (p, pu, pv)
}

impl BezierPatch {
    /// Point and partial derivatives `(p, dp/du, dp/dv)` at `(u, v)` in `[0,1]^2`.
    pub fn eval(&self, u: f32, v: f32) -> (Vec3, Vec3, Vec3) {
        let (p, pu, pv) = eval64(self, u.into(), v.into());
        (p.as_vec3(), pu.as_vec3(), pv.as_vec3())
    }
}

impl BezierPatch {
    /// Unit shading normal at `(u, v)`: `normalize(dp/du x dp/dv)`, negated when
    /// [`flipped`](Self::flipped). For the Newell teapot data this points outward.
    ///
    /// Where the surface is degenerate (a whole edge collapsed to a point, as at the
    /// teapot's lid top and bottom centre, so one derivative vanishes) the normal is
    /// taken at a parameter moved towards the patch centre by 1e-4 (then 1e-3, 1e-2,
    /// 1e-1 if still degenerate). A patch degenerate everywhere gets `+z`. The result
    /// is always finite and of unit length.
    pub fn normal(&self, u: f32, v: f32) -> Vec3 {
        let (lo, hi) = self
            .ctrl
            .iter()
            .fold((self.ctrl[0], self.ctrl[0]), |(lo, hi), c| {
                (lo.min(*c), hi.max(*c))
            });
        let ext = (hi - lo).as_dvec3().length();
        let tiny = 1e-10 * ext * ext;
        let (u, v) = (f64::from(u), f64::from(v));
        let toward_centre = |t: f64, d: f64| if t < 0.5 { t + d } else { t - d };
        let mut n = None;
        for d in [0.0, 1e-4, 1e-3, 1e-2, 1e-1] {
            let (_, pu, pv) = eval64(self, toward_centre(u, d), toward_centre(v, d));
            let c = pu.cross(pv);
            let len = c.length();
            if len.is_finite() && len > tiny {
                n = Some((c / len).as_vec3());
                break;
            }
        }
        let n = n.unwrap_or(Vec3::Z);
        if self.flipped {
            -n
        } else {
            n
        }
    }
}

/// Most patches a `.bpt` file may declare.
const MAX_BPT_PATCHES: u64 = 1_000_000;

/// Reads a `.bpt` file (see data/teapot/SOURCE.md for the format).
///
/// The format is line based: the patch count, then per patch a line `3 3` (the
/// degrees; only bicubic patches are supported) and 16 lines `x y z`, the control
/// net row by row (row `i` along v, column `j` along u: `ctrl[4 * i + j]`). Blank
/// lines and lines starting with `#` are skipped. Anything other than blank lines
/// or comments after the last patch is an error (it usually means the count is
/// wrong). Errors name the file and line (and column for bad numbers).
pub fn read_bpt(path: &Path) -> Result<Vec<BezierPatch>> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_bpt(path, &bytes)
}

/// [`read_bpt`] on the file's contents; `path` only names the file in errors.
pub fn parse_bpt(path: &Path, bytes: &[u8]) -> Result<Vec<BezierPatch>> {
    let lines = text_lines(path, bytes)?;
    let mut it = lines
        .iter()
        .filter(|(_, l)| {
            let t = l.trim_start();
            !t.is_empty() && !t.starts_with('#')
        })
        .peekable();
    let last_line = lines.len().max(1) as u32;
    let eof = |what: &str| {
        Error::input(
            path,
            Some(Pos {
                line: last_line,
                col: 0,
            }),
            format!("file ends early: expected {what}"),
        )
    };

    let &(line, text) = it.next().ok_or_else(|| eof("the patch count"))?;
    let toks = tokens(text);
    if toks.len() != 1 {
        return Err(Error::input(
            path,
            Some(Pos { line, col: 1 }),
            format!(
                "expected the patch count alone on the first line, found {} values",
                toks.len()
            ),
        ));
    }
    let (col, tok) = toks[0];
    let count: u64 = tok.parse().map_err(|_| {
        Error::input(
            path,
            Some(Pos { line, col }),
            format!("patch count '{tok}' is not a whole number"),
        )
    })?;
    if count == 0 {
        return Err(Error::input(
            path,
            Some(Pos { line, col }),
            "patch count is 0: no patches",
        ));
    }
    if count > MAX_BPT_PATCHES {
        return Err(Error::input(
            path,
            Some(Pos { line, col }),
            format!("patch count {count} is absurd (more than {MAX_BPT_PATCHES})"),
        ));
    }

    let mut patches = Vec::with_capacity(count.min(4096) as usize);
    for k in 0..count {
        let &(line, text) = it
            .next()
            .ok_or_else(|| eof(&format!("patch {} of {count}", k + 1)))?;
        let toks = tokens(text);
        let degrees: Vec<&str> = toks.iter().map(|t| t.1).collect();
        if degrees != ["3", "3"] {
            return Err(Error::input(
                path,
                Some(Pos { line, col: 1 }),
                format!(
                    "patch {}: expected degrees '3 3' (only bicubic patches are supported), found '{}'",
                    k + 1,
                    degrees.join(" ")
                ),
            ));
        }
        let mut ctrl = [Vec3::ZERO; 16];
        for (c, slot) in ctrl.iter_mut().enumerate() {
            let &(line, text) = it.next().ok_or_else(|| {
                eof(&format!(
                    "control point {} of 16 of patch {} of {count}",
                    c + 1,
                    k + 1
                ))
            })?;
            let toks = tokens(text);
            if toks.len() != 3 {
                return Err(Error::input(
                    path,
                    Some(Pos { line, col: 1 }),
                    format!(
                        "patch {}, control point {}: expected 3 numbers 'x y z', found {}",
                        k + 1,
                        c + 1,
                        toks.len()
                    ),
                ));
            }
            let mut xyz = [0.0f32; 3];
            for (x, &(col, tok)) in xyz.iter_mut().zip(&toks) {
                *x = parse_coord(path, line, col, tok)?;
            }
            *slot = Vec3::from_array(xyz);
        }
        patches.push(BezierPatch { ctrl, flipped: false });
    }
    if let Some(&(line, _)) = it.next() {
        return Err(Error::input(
            path,
            Some(Pos { line, col: 1 }),
            format!("unexpected data after the last of the {count} patches"),
        ));
    }
    Ok(patches)
}

/// Most triangles a tessellation may make (about 2 GB of mesh).
pub const MAX_TESSELLATED_TRIANGLES: u64 = 20_000_000;

/// Triangles [`tessellate`]`(patches, coarse, fine)` makes: `2 (coarse fine)^2` per
/// patch.
pub fn tessellated_triangles(patches: usize, coarse: u32, fine: u32) -> u64 {
    let n = u64::from(coarse.max(1)) * u64::from(fine.max(1));
    (patches as u64).saturating_mul(2 * n * n)
}

/// Tessellates `patches` into a mesh with smooth normals and per-vertex (u, v):
/// each patch becomes `coarse x coarse` radiosity patches (`Patch::Bezier`), each
/// of those `fine x fine` quads split into two triangles.
///
/// Each Bezier patch gets its own `(coarse * fine + 1)^2` grid of vertices (shared
/// by its triangles, not with neighbouring patches), with `uvs` its (u, v) and
/// `normals` from [`BezierPatch::normal`]. Triangles wind counter-clockwise in
/// (u, v), so their geometric normal agrees with `dp/du x dp/dv`; a `flipped`
/// patch has its winding reversed and normals negated. The teapot comes out with
/// outward normals. Collapsed edges give zero-area triangles, which are kept.
/// `coarse` and `fine` of 0 are taken as 1. `mesh.bezier` holds copies of
/// `patches`, in order.
pub fn tessellate(patches: &[BezierPatch], coarse: u32, fine: u32) -> TriMesh {
    let coarse = coarse.max(1);
    let fine = fine.max(1);
    let n = coarse * fine;
    let row = n + 1;
    let mut mesh = TriMesh {
        bezier: patches.to_vec(),
        ..TriMesh::default()
    };
    let nverts = patches.len() * (row * row) as usize;
    mesh.positions.reserve(nverts);
    mesh.normals.reserve(nverts);
    mesh.uvs.reserve(nverts);
    for (s, b) in patches.iter().enumerate() {
        let base = mesh.positions.len() as u32;
        for iv in 0..=n {
            let v = iv as f32 / n as f32;
            for iu in 0..=n {
                let u = iu as f32 / n as f32;
                let (p, _, _) = b.eval(u, v);
                mesh.positions.push(p);
                mesh.normals.push(b.normal(u, v));
                mesh.uvs.push(Vec2::new(u, v));
            }
        }
        let vid = |iu: u32, iv: u32| base + iv * row + iu;
        for cv in 0..coarse {
            for cu in 0..coarse {
                let pid = mesh.patches.len() as u32;
                mesh.patches.push(Patch::Bezier {
                    surface: s as u32,
                    u: [cu as f32 / coarse as f32, (cu + 1) as f32 / coarse as f32],
                    v: [cv as f32 / coarse as f32, (cv + 1) as f32 / coarse as f32],
                });
                for iv in cv * fine..(cv + 1) * fine {
                    for iu in cu * fine..(cu + 1) * fine {
                        let (a, b_, c, d) =
                            (vid(iu, iv), vid(iu + 1, iv), vid(iu + 1, iv + 1), vid(iu, iv + 1));
                        let (t0, t1) = if b.flipped {
                            ([a, c, b_], [a, d, c])
                        } else {
                            ([a, b_, c], [a, c, d])
                        };
                        mesh.indices.push(t0);
                        mesh.indices.push(t1);
                        mesh.tri_patch.push(pid);
                        mesh.tri_patch.push(pid);
                    }
                }
            }
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    use crate::testutil::teapot_bpt;

    fn teapot() -> Vec<BezierPatch> {
        read_bpt(&teapot_bpt()).expect("teapot reads")
    }

    /// A patch whose control points are a regular grid on z = 0 over `[0,2]x[0,3]`.
    fn flat() -> BezierPatch {
        let mut ctrl = [Vec3::ZERO; 16];
        for i in 0..4 {
            for j in 0..4 {
                ctrl[4 * i + j] = Vec3::new(2.0 * j as f32 / 3.0, 3.0 * i as f32 / 3.0, 0.0);
            }
        }
        BezierPatch { ctrl, flipped: false }
    }

    fn angle(a: Vec3, b: Vec3) -> f32 {
        a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos()
    }

    #[test]
    fn corners_are_corner_control_points() {
        for b in teapot().iter().chain([flat()].iter()) {
            assert_eq!(b.eval(0.0, 0.0).0, b.ctrl[0]);
            assert_eq!(b.eval(1.0, 0.0).0, b.ctrl[3]);
            assert_eq!(b.eval(0.0, 1.0).0, b.ctrl[12]);
            assert_eq!(b.eval(1.0, 1.0).0, b.ctrl[15]);
        }
    }

    #[test]
    fn flat_patch_is_the_bilinear_map() {
        let b = flat();
        for &(u, v) in &[(0.0, 0.0), (0.25, 0.5), (0.7, 0.1), (1.0, 0.6), (0.5, 1.0)] {
            let (p, pu, pv) = b.eval(u, v);
            assert!((p - Vec3::new(2.0 * u, 3.0 * v, 0.0)).length() < 1e-6, "{p}");
            assert!((pu - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5, "{pu}");
            assert!((pv - Vec3::new(0.0, 3.0, 0.0)).length() < 1e-5, "{pv}");
            assert_eq!(b.normal(u, v), Vec3::Z);
        }
        let mut f = b;
        f.flipped = true;
        assert_eq!(f.normal(0.3, 0.3), -Vec3::Z);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let h = 1e-3;
        for b in teapot() {
            for &(u, v) in &[(0.3, 0.4), (0.8, 0.15), (0.5, 0.9)] {
                let (_, pu, pv) = b.eval(u, v);
                let fu = (b.eval(u + h, v).0 - b.eval(u - h, v).0) / (2.0 * h);
                let fv = (b.eval(u, v + h).0 - b.eval(u, v - h).0) / (2.0 * h);
                assert!((pu - fu).length() < 1e-2 * (1.0 + pu.length()), "{pu} {fu}");
                assert!((pv - fv).length() < 1e-2 * (1.0 + pv.length()), "{pv} {fv}");
            }
        }
    }

    #[test]
    fn teapot_reads() {
        let t = teapot();
        assert_eq!(t.len(), 32);
        assert_eq!(t[0].ctrl[0], Vec3::new(1.4, 0.0, 2.4));
        assert_eq!(t[0].ctrl[15], Vec3::new(0.0, -1.5, 2.4));
        assert!(t.iter().all(|b| !b.flipped));
    }

    #[test]
    fn teapot_tessellation_counts_and_bounds() {
        let m = tessellate(&teapot(), 4, 8);
        assert_eq!(m.patches.len(), 32 * 16);
        assert_eq!(m.triangle_count(), 32 * 2 * 32 * 32);
        assert_eq!(m.positions.len(), 32 * 33 * 33);
        assert_eq!(m.normals.len(), m.positions.len());
        assert_eq!(m.uvs.len(), m.positions.len());
        assert_eq!(m.bezier, teapot());
        m.validate().unwrap();
        let (lo, hi) = m.bounds().unwrap();
        assert!(lo.z.abs() < 1e-6 && (hi.z - 3.15).abs() < 1e-5, "{lo} {hi}");
        // Every radiosity patch has fine^2 * 2 triangles and the right parameter range.
        let mut per = vec![0; m.patches.len()];
        for &p in &m.tri_patch {
            per[p as usize] += 1;
        }
        assert!(per.iter().all(|&n| n == 128));
        assert_eq!(
            m.patches[16 + 4 * 2 + 3],
            Patch::Bezier {
                surface: 1,
                u: [0.75, 1.0],
                v: [0.5, 0.75]
            }
        );
        // The triangles of a radiosity patch have their uvs inside its range.
        for (t, tri) in m.indices.iter().enumerate() {
            let Patch::Bezier { u, v, .. } = m.patches[m.tri_patch[t] as usize] else {
                panic!("not a Bezier patch");
            };
            for &i in tri {
                let uv = m.uvs[i as usize];
                assert!(uv.x >= u[0] && uv.x <= u[1] && uv.y >= v[0] && uv.y <= v[1]);
            }
        }
    }

    #[test]
    fn teapot_vertices_and_normals_lie_on_the_surface() {
        let pot = teapot();
        let m = tessellate(&pot, 2, 5);
        let per_patch = m.positions.len() / pot.len();
        let mut checked = 0;
        for (i, (&p, (&n, &uv))) in m.positions.iter().zip(m.normals.iter().zip(&m.uvs)).enumerate() {
            let b = &pot[i / per_patch];
            let (q, pu, pv) = b.eval(uv.x, uv.y);
            assert!((p - q).length() < 1e-5);
            assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-5, "{n}");
            let c = pu.cross(pv);
            if c.length() > 1e-3 {
                assert!(angle(n, c) < 1e-3, "vertex {i}: {n} vs {c}");
                checked += 1;
            }
        }
        // Only the collapsed edges are skipped.
        assert!(checked > m.positions.len() * 9 / 10, "{checked}");
    }

    #[test]
    fn teapot_degenerate_points_get_the_pole_normal() {
        let pot = teapot();
        // Lid top (patches 20..24) and bottom centre (28..32): the v = 0 edge collapses.
        for (s, want) in [(20, Vec3::Z), (28, -Vec3::Z)] {
            for k in 0..4 {
                let b = &pot[s + k];
                assert!(b.eval(0.3, 0.0).1.length() < 1e-5);
                for u in [0.0, 0.5, 1.0] {
                    let n = b.normal(u, 0.0);
                    assert!(angle(n, want) < 0.01, "patch {}: {n}", s + k);
                }
            }
        }
    }

    #[test]
    fn teapot_normals_point_outward_and_agree_with_winding() {
        let pot = teapot();
        let m = tessellate(&pot, 4, 8);
        let per_patch = m.positions.len() / pot.len();
        // Body (patches 4..12) and lid (20..28): normal away from the z axis.
        let (mut out, mut all) = (0, 0);
        for i in 0..m.positions.len() {
            let s = i / per_patch;
            if (4..12).contains(&s) || (20..28).contains(&s) {
                let p = m.positions[i];
                let d = p - Vec3::new(0.0, 0.0, p.z);
                if d.length() > 1e-3 {
                    all += 1;
                    out += usize::from(m.normals[i].dot(d) > 0.0);
                }
            }
        }
        assert!(out as f64 > 0.99 * all as f64, "{out} of {all}");
        // Lid top up, bottom down, at and around the poles.
        let mut near_pole = 0;
        for (p, n) in m.positions.iter().zip(&m.normals) {
            if p.x.hypot(p.y) < 0.1 {
                near_pole += 1;
                assert!(n.z.abs() > 0.95 && (n.z > 0.0) == (p.z > 1.0), "{p} {n}");
            }
        }
        assert!(near_pole > 2 * 4 * 33, "{near_pole}");
        // Winding agrees with the shading normals.
        let mut degenerate = 0;
        for (t, tri) in m.indices.iter().enumerate() {
            let [a, b, c] = m.triangle(t);
            let g = (b - a).cross(c - a);
            if g == Vec3::ZERO {
                degenerate += 1;
                continue;
            }
            let n: Vec3 = tri.iter().map(|&i| m.normals[i as usize]).sum();
            assert!(g.dot(n) > 0.0, "triangle {t}");
        }
        // Zero-area triangles only along the 8 collapsed edges: one per quad there.
        assert_eq!(degenerate, 8 * 32);
        // Closed-ish outward surface: positive enclosed volume.
        let vol: f32 = (0..m.triangle_count())
            .map(|t| {
                let [a, b, c] = m.triangle(t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        assert!(vol > 0.0, "{vol}");
    }

    #[test]
    fn teapot_patches_are_consistently_oriented() {
        // Weld vertices by position; an edge shared by two triangles must be used in
        // opposite directions.
        let m = tessellate(&teapot(), 1, 6);
        let key = |p: Vec3| (p * 1e4).round().as_ivec3().to_array();
        let mut ids = std::collections::HashMap::new();
        let weld: Vec<usize> = m
            .positions
            .iter()
            .map(|&p| {
                let n = ids.len();
                *ids.entry(key(p)).or_insert(n)
            })
            .collect();
        let mut edges = std::collections::HashMap::<(usize, usize), i32>::new();
        for (t, tri) in m.indices.iter().enumerate() {
            if m.triangle_area(t) == 0.0 {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (weld[tri[k] as usize], weld[tri[(k + 1) % 3] as usize]);
                *edges.entry((a, b)).or_default() += 1;
            }
        }
        let pos_of: std::collections::HashMap<usize, Vec3> =
            weld.iter().zip(&m.positions).map(|(&w, &p)| (w, p)).collect();
        let same: Vec<_> = edges
            .iter()
            .filter(|&(_, &n)| n > 1)
            .map(|(&(a, b), _)| (pos_of[&a], pos_of[&b]))
            .collect();
        assert!(
            same.is_empty(),
            "edges used twice in the same direction: {same:?}"
        );
        let shared = edges
            .keys()
            .filter(|&&(a, b)| edges.contains_key(&(b, a)))
            .count();
        assert!(shared > edges.len() / 2);
    }

    #[test]
    fn flipped_patches_reverse_winding_and_normals() {
        let mut pot = teapot();
        let m = tessellate(&pot, 2, 2);
        for b in &mut pot {
            b.flipped = true;
        }
        let f = tessellate(&pot, 2, 2);
        let mut g = m.clone();
        g.flip_normals();
        assert_eq!(f.positions, g.positions);
        assert_eq!(f.normals, g.normals);
        assert_eq!(f.bezier, g.bezier);
        for (a, b) in f.indices.iter().zip(&g.indices) {
            // Same triangle, same orientation (possibly rotated).
            let rot = |t: [u32; 3], k: usize| [t[k], t[(k + 1) % 3], t[(k + 2) % 3]];
            assert!((0..3).any(|k| rot(*a, k) == *b), "{a:?} {b:?}");
        }
    }

    #[test]
    fn zero_subdivision_is_taken_as_one() {
        let m = tessellate(&[flat()], 0, 0);
        assert_eq!(m.patches.len(), 1);
        assert_eq!(m.triangle_count(), 2);
        assert!((m.area() - 6.0).abs() < 1e-5);
        assert!(tessellate(&[], 3, 3).positions.is_empty());
    }

    fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn err(p: &Path) -> String {
        read_bpt(p).expect_err("should fail").to_string()
    }

    #[test]
    fn bpt_errors() {
        let dir = tempfile::tempdir().unwrap();
        let text = std::fs::read_to_string(teapot_bpt()).unwrap();
        let lines: Vec<&str> = text.lines().collect();

        // Truncated: data runs out at the last line kept.
        let p = write(&dir, "trunc.bpt", &(lines[..100].join("\n") + "\n"));
        let e = err(&p);
        assert!(
            e.starts_with(&format!("{}:100: file ends early", p.display())),
            "{e}"
        );
        assert!(e.contains("patch 6"), "{e}");

        // A control point line cut short.
        let p = write(&dir, "short.bpt", &(lines[..99].join("\n") + "\n1.5 0\n"));
        let e = err(&p);
        assert!(e.starts_with(&format!("{}:100:1: ", p.display())), "{e}");
        assert!(e.contains("expected 3 numbers"), "{e}");

        // Non-numeric and non-finite values, with line and column.
        let mut l = lines.clone();
        l[3] = "1.4 -0.78x4 2.4";
        let p = write(&dir, "nan.bpt", &l.join("\n"));
        let e = err(&p);
        assert!(e.starts_with(&format!("{}:4:5: ", p.display())), "{e}");
        assert!(e.contains("'-0.78x4' is not a number"), "{e}");
        l[3] = "1.4 0 inf";
        let p = write(&dir, "inf.bpt", &l.join("\n"));
        assert!(err(&p).contains(":4:7: 'inf' is not a finite number"));
        l[3] = "1.4 0 NaN";
        let p = write(&dir, "nan2.bpt", &l.join("\n"));
        assert!(err(&p).contains(":4:7: 'NaN' is not a finite number"));

        // Degrees other than 3 3.
        let mut l = lines.clone();
        l[1] = "2 3";
        let p = write(&dir, "deg.bpt", &l.join("\n"));
        let e = err(&p);
        assert!(e.starts_with(&format!("{}:2:1: ", p.display())), "{e}");
        assert!(e.contains("only bicubic"), "{e}");

        // Counts.
        let mut l = lines.clone();
        for (c, want) in [
            ("0", "no patches"),
            ("2000000", "absurd"),
            ("-3", "not a whole number"),
            ("3.5", "not a whole number"),
        ] {
            l[0] = c;
            let p = write(&dir, "count.bpt", &l.join("\n"));
            let e = err(&p);
            assert!(e.contains(":1:1: ") && e.contains(want), "{e}");
        }
        // Count smaller than the data: trailing patches are an error.
        l[0] = "31";
        let p = write(&dir, "more.bpt", &l.join("\n"));
        let e = err(&p);
        assert!(
            e.contains(&format!(":{}:1: unexpected data after", 2 + 31 * 17)),
            "{e}"
        );
        // Count larger than the data: ends early.
        l[0] = "33";
        let p = write(&dir, "less.bpt", &l.join("\n"));
        assert!(err(&p).contains("file ends early: expected patch 33 of 33"));

        // Empty, binary junk, missing file.
        let p = write(&dir, "empty.bpt", "");
        assert!(err(&p).contains("file ends early"));
        let p = dir.path().join("junk.bpt");
        std::fs::write(&p, [0xff, 0xfe, 0x00, 0x41]).unwrap();
        assert!(err(&p).contains(":1:1: not UTF-8"));
        let p = dir.path().join("missing.bpt");
        let e = err(&p);
        assert!(
            e.starts_with(&p.display().to_string()) && matches!(read_bpt(&p), Err(Error::Io { .. })),
            "{e}"
        );

        // Comments, blank lines and CRLF are fine.
        let p = write(
            &dir,
            "crlf.bpt",
            &("# teapot\r\n\r\n".to_string() + &lines.join("\r\n") + "\r\n\r\n"),
        );
        assert_eq!(read_bpt(&p).unwrap(), teapot());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        #[test]
        fn bpt_never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
            let dir = tempfile::tempdir().unwrap();
            let p = dir.path().join("x.bpt");
            std::fs::write(&p, &bytes).unwrap();
            let _ = read_bpt(&p);
        }

        #[test]
        fn bpt_mutated_never_panics(cut in 0usize..3000, junk in "[0-9a-z .\\-\n]{0,20}") {
            let text = std::fs::read_to_string(teapot_bpt()).unwrap();
            let cut = cut.min(text.len());
            let dir = tempfile::tempdir().unwrap();
            let p = dir.path().join("x.bpt");
            std::fs::write(&p, format!("{}{junk}{}", &text[..cut], &text[cut..])).unwrap();
            if let Ok(v) = read_bpt(&p) {
                proptest::prop_assert!(!v.is_empty());
                let m = tessellate(&v, 1, 2);
                proptest::prop_assert!(m.validate().is_ok());
            }
        }
    }
}
