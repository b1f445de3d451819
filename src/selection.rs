//! Source selection (paper Sect. 3 and 6): which of the sources kept apart on a patch
//! are ray traced when the patch is hit, and with how many shadow rays.
//!
//! The radiosity pass leaves on each patch a list of sources with their stored,
//! per-vertex contributions ([`crate::radiosity::ListEntry`]). A *selected* source is
//! sampled with shadow rays at render time; every other listed source adds its stored
//! contribution, interpolated. So each source reaches a point by exactly one route,
//! and the whole non-ray-traced part of a vertex's radiosity is one number,
//! [`Selection::stored`].
//!
//! The render methods are selections:
//! - `twopass`: nothing selected (paper Fig. 7);
//! - `norm`: every light selected on every patch at fixed counts, 1 ray per point or
//!   spot light and `--area-samples` per area light (Fig. 8);
//! - `local`: per patch (or per object), the listed sources that pass all five
//!   criteria of Sect. 3 (Fig. 9), see [`judge`];
//! - `global`: the `--global-sources` strongest sources, wherever they are listed.
//!
//! A selected radiant patch is sampled like an area light whose radiance is the
//! patch's radiosity / pi, interpolated over its elements.

use std::collections::BTreeMap;

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::{Camera, PixelScale};
use crate::emitters::light_power;
use crate::emitters::{AreaEmitter, SampledLight};
use crate::geometry::Subtense;
use crate::mesh::Interp;
use crate::radiosity::{ListEntry, Solution, SourceId};
use crate::scene::{mean, Light, Rgb, Scene};
use crate::{Error, Result};

/// How the direct light is computed (the paper's renderers as modes of one code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Exact direct light: shadow rays to every light source at every diffuse hit;
    /// no indirect light.
    #[default]
    Direct,
    /// Standard two-pass radiosity: shading from the radiosity mesh alone (Fig. 7).
    Twopass,
    /// Radiosity for indirect light, every light source ray traced at fixed counts:
    /// the fully sampled "norm" picture (Fig. 8).
    Norm,
    /// Per-patch source selection with the five criteria of Sect. 3 (Fig. 9).
    Local,
    /// The `--global-sources` strongest sources ray traced everywhere.
    Global,
}

impl Method {
    /// Every method, in the order of the paper's figures.
    pub const ALL: [Method; 5] = [
        Method::Direct,
        Method::Twopass,
        Method::Norm,
        Method::Local,
        Method::Global,
    ];

    /// Whether the method ray traces sources over a radiosity solution (`norm`,
    /// `local`, `global`): the pictures the paper's last step, the final gather,
    /// refines. `direct` has no solution, and `twopass` is the mesh alone (Fig. 7).
    pub fn ray_traces_over_solution(self) -> bool {
        matches!(self, Method::Norm | Method::Local | Method::Global)
    }

    /// The name used on the command line and in the statistics.
    pub fn name(self) -> &'static str {
        match self {
            Method::Direct => "direct",
            Method::Twopass => "twopass",
            Method::Norm => "norm",
            Method::Local => "local",
            Method::Global => "global",
        }
    }
}

/// The unit a local selection is made for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SelectPer {
    /// Each patch chooses its own sources.
    #[default]
    Patch,
    /// All patches of an object (a shape of the scene) share one choice: a source
    /// chosen on any of them is ray traced on all of them, so patch boundaries
    /// cannot show (paper Sect. 3).
    Object,
}

impl SelectPer {
    /// The name used on the command line and in the statistics.
    pub fn name(self) -> &'static str {
        match self {
            SelectPer::Patch => "patch",
            SelectPer::Object => "object",
        }
    }
}

/// Thresholds of the selection criteria (paper Sect. 3) and ray counts.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SelectSettings {
    /// Per patch or per object.
    pub per: SelectPer,
    /// Radiance criterion: the source's unoccluded reflected radiosity must reach
    /// this fraction of the patch's total radiosity (at the vertex where each is
    /// largest). A shadow of a weaker source has less contrast than this.
    pub radiance_threshold: f32,
    /// Reflectivity criterion: the patch's diffuse reflectance (mean of RGB) must
    /// reach this.
    pub reflectivity_threshold: f32,
    /// Gradient criterion: the source's visibility (occluded / unoccluded, 0 where it
    /// does not reach) must vary across the patch's vertices by more than this.
    pub gradient_threshold: f32,
    /// Solid-angle criterion: a source seen under more than this solid angle
    /// (steradians, area-weighted mean over the patch's vertices) is left to the
    /// radiosity.
    pub max_solid_angle: f32,
    /// Rays for a hemisphere: an area source seen under solid angle Omega gets
    /// max(1, round(Omega / 2pi x this)) rays, at most `area_samples`.
    pub hemisphere_rays: u32,
    /// View criterion: a patch whose elements project to fewer pixels than this
    /// (seen from the camera at its nearest vertex) is left to the mesh.
    pub view_threshold: f32,
    /// Whether the view criterion is applied (off for animation: selections must
    /// not change between frames).
    pub view_criterion: bool,
    /// Rays per area light in `norm` and `global`, and the most `local` casts.
    pub area_samples: u32,
    /// Sources ray traced by `global`.
    pub global_sources: u32,
}

impl SelectSettings {
    /// Checks the thresholds and ray counts; the error names the command line's flag.
    pub fn validate(&self) -> Result<()> {
        let check = |name: &str, v: f32, lo: f32, hi: f32| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(Error::Usage(format!(
                    "--{name} {v}: must be between {lo} and {hi}"
                )))
            }
        };
        check("radiance-threshold", self.radiance_threshold, 0.0, f32::MAX)?;
        check("reflectivity-threshold", self.reflectivity_threshold, 0.0, 1.0)?;
        check("gradient-threshold", self.gradient_threshold, 0.0, 1.0)?;
        check(
            "max-solid-angle",
            self.max_solid_angle,
            0.0,
            4.0 * std::f32::consts::PI,
        )?;
        check("view-threshold", self.view_threshold, 0.0, f32::MAX)?;
        crate::error::at_least_one("hemisphere-rays", self.hemisphere_rays)?;
        crate::error::at_least_one("area-samples", self.area_samples)
    }
}

impl Default for SelectSettings {
    fn default() -> Self {
        SelectSettings {
            per: SelectPer::Patch,
            radiance_threshold: 0.1,
            reflectivity_threshold: 0.05,
            gradient_threshold: 0.02,
            max_solid_angle: 0.25,
            hemisphere_rays: 4096,
            view_threshold: 2.0,
            view_criterion: true,
            area_samples: 64,
            global_sources: 4,
        }
    }
}

/// Where the view criterion looks from: the camera's eye and how large lengths look
/// on its film.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewScale {
    /// The eye.
    pub eye: Vec3,
    pub scale: PixelScale,
}

impl ViewScale {
    /// The view scale of a camera.
    pub fn of(camera: &Camera) -> Self {
        ViewScale {
            eye: camera.eye(),
            scale: camera.pixel_scale(),
        }
    }
}

/// The five criteria's verdicts for one source on one patch, with the measures
/// they were made from.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Criteria {
    /// Radiance: the source brings enough light.
    pub radiance: bool,
    /// Reflectivity: the patch reflects enough diffusely.
    pub reflectivity: bool,
    /// Gradient: the source is partly visible across the patch (a shadow edge).
    pub gradient: bool,
    /// Solid angle: the source is small enough to be sampled with rays.
    pub solid_angle: bool,
    /// View: the patch's elements are large on screen.
    pub view: bool,
    /// Shadow rays per hit if selected.
    pub rays: u32,
    /// Largest unoccluded contribution / largest total radiosity on the patch.
    pub share: f32,
    /// Spread of the visibility over the patch's vertices (0..1).
    pub visibility_spread: f32,
    /// Solid angle of the source (steradians), area-weighted mean over the vertices.
    pub solid_angle_sr: f32,
    /// Element size on screen (pixels); infinite without a view.
    pub element_pixels: f32,
    /// How far the elements' interpolation of the source's unoccluded light strays
    /// from its exact value, as a share of the total radiosity (lights on flat
    /// patches, asked only where it can still decide; see [`judge`]).
    pub falloff_error: f32,
}

impl Criteria {
    /// Whether all criteria select the source.
    pub fn selected(&self) -> bool {
        self.radiance && self.reflectivity && self.gradient && self.solid_angle && self.view
    }
}

/// A source ray traced on a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pick {
    /// Index into [`Selection::sources`].
    pub source: u32,
    /// Shadow rays per hit.
    pub rays: u32,
}

/// The choice of ray-traced sources for every patch of a radiosity solution.
pub struct Selection<'a> {
    /// The solution chosen from.
    pub solution: &'a Solution,
    /// The method it implements.
    pub method: Method,
    /// The ray-traced sources: every light of the scene first (index = light index),
    /// then the radiant patches selected anywhere.
    pub sources: Vec<SourceId>,
    /// The sources prepared for sampling, as `sources`.
    pub emitters: Vec<SampledLight>,
    /// Per vertex: the radiosity not ray traced (general radiosity plus the stored
    /// contributions of the listed sources not selected on its patch).
    pub stored: Vec<Rgb>,
    /// Per patch, offsets into `picks`.
    offsets: Vec<u32>,
    picks: Vec<Pick>,
    /// For `local`: per patch, the verdicts on each listed source.
    pub criteria: Vec<Vec<(SourceId, Criteria)>>,
}

impl<'a> Selection<'a> {
    /// The sources ray traced on patch `p`.
    pub fn picks(&self, p: u32) -> &[Pick] {
        let (a, b) = (self.offsets[p as usize], self.offsets[p as usize + 1]);
        &self.picks[a as usize..b as usize]
    }

    /// The sources ray traced on patch `p`, by their ids.
    pub fn picked(&self, p: u32) -> impl Iterator<Item = SourceId> + '_ {
        self.picks(p).iter().map(|k| self.sources[k.source as usize])
    }

    /// Per vertex, the stored (occluded) contributions of the sources listed on its
    /// patch that `which` accepts there (given the patch and the list entry) and that
    /// the patch does not ray trace: the part of [`Selection::stored`] that they make up.
    pub fn unpicked_stored(&self, which: impl Fn(u32, &ListEntry) -> bool) -> Vec<Rgb> {
        let sol = self.solution;
        let mut out = vec![Rgb::ZERO; sol.general.len()];
        for (p, list) in sol.lists.iter().enumerate() {
            let first = sol.mesh.patches[p].first_vertex as usize;
            for e in list {
                if which(p as u32, e) && !self.picked(p as u32).any(|s| s == e.source) {
                    for (o, c) in out[first..].iter_mut().zip(&e.occluded) {
                        *o += *c;
                    }
                }
            }
        }
        out
    }

    /// Shadow rays per hit on patch `p` (all sources together).
    pub fn rays(&self, p: u32) -> u32 {
        self.picks(p).iter().map(|k| k.rays).sum()
    }

    /// A name for ray-traced source `i`.
    pub fn source_name(&self, scene: &Scene, i: usize) -> String {
        match self.sources[i] {
            SourceId::Light(l) => scene.light_name(l as usize),
            SourceId::Patch(p) => patch_name(scene, self.solution, p),
        }
    }

    /// Number of (patch, source) pairs ray traced.
    pub fn pick_count(&self) -> usize {
        self.picks.len()
    }

    /// The ray-traced sources (indices into `sources`) that some patch picks, the
    /// strongest first (by [`source_power`]; ties by index).
    pub fn ranked(&self, scene: &Scene) -> Vec<u32> {
        let total = self.solution.total();
        let mut used: Vec<u32> = self.picks.iter().map(|k| k.source).collect();
        used.sort_unstable();
        used.dedup();
        let mut ranked: Vec<(f64, u32)> = used
            .into_iter()
            .map(|i| {
                (
                    source_power(scene, self.solution, &total, self.sources[i as usize]),
                    i,
                )
            })
            .collect();
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        ranked.into_iter().map(|(_, i)| i).collect()
    }

    /// The same selection with only the sources in `keep` (indices into `sources`)
    /// ray traced: every other pick's light comes from the solution instead (its
    /// stored, occluded contribution, as for a listed source the criteria turned
    /// down), so each source still reaches a point by one route. The paper's
    /// progressive display (Sect. 3) shows these in turn, strongest sources first.
    /// It carries no `criteria`: they are the full selection's.
    pub fn only(&self, keep: &[u32]) -> Selection<'a> {
        let mesh = &self.solution.mesh;
        let mut stored = self.stored.clone();
        let mut offsets = Vec::with_capacity(self.offsets.len());
        let mut picks = Vec::new();
        for p in 0..mesh.patches.len() {
            offsets.push(picks.len() as u32);
            let first = mesh.patches[p].first_vertex as usize;
            for k in self.picks(p as u32) {
                if keep.contains(&k.source) {
                    picks.push(*k);
                    continue;
                }
                let source = self.sources[k.source as usize];
                if let Some(e) = self.solution.lists[p].iter().find(|e| e.source == source) {
                    for (i, c) in e.occluded.iter().enumerate() {
                        stored[first + i] += *c;
                    }
                }
            }
        }
        offsets.push(picks.len() as u32);
        Selection {
            solution: self.solution,
            method: self.method,
            sources: self.sources.clone(),
            emitters: self.emitters.clone(),
            stored,
            offsets,
            picks,
            // (The criteria's verdicts are the full selection's; a render reads none.)
            criteria: Vec::new(),
        }
    }
}

/// "shape name, patch k" for patch `p` of the solution's mesh.
pub fn patch_name(scene: &Scene, sol: &Solution, p: u32) -> String {
    let mp = &sol.mesh.patches[p as usize];
    let side = if p >= sol.mesh.front_patches {
        " (back)"
    } else {
        ""
    };
    format!(
        "{} patch {}{side}",
        scene.shapes[mp.shape as usize].name, mp.local
    )
}

/// The triangles of a source (empty for point and spot lights); a radiant patch as its
/// outline (the solid angle of its elements together).
fn source_triangles(scene: &Scene, sol: &Solution, s: SourceId) -> Vec<[Vec3; 3]> {
    match s {
        SourceId::Light(l) => match scene.lights[l as usize] {
            Light::Area { shape, .. } => {
                let m = &scene.shapes[shape as usize].mesh;
                (0..m.triangle_count()).map(|t| m.triangle(t)).collect()
            }
            _ => Vec::new(),
        },
        SourceId::Patch(p) => sol
            .mesh
            .outline_triangles(p)
            .iter()
            .map(|t| t.map(|v| sol.mesh.vertices[v as usize].p))
            .collect(),
    }
}

/// The power a source sends: a light's emitted power, a radiant patch's reflected
/// power (its total radiosity over its area). `total` is [`Solution::total`].
fn source_power(scene: &Scene, sol: &Solution, total: &[Rgb], s: SourceId) -> f64 {
    match s {
        SourceId::Light(l) => light_power(scene, &scene.lights[l as usize]),
        SourceId::Patch(p) => {
            let mp = &sol.mesh.patches[p as usize];
            let first = mp.first_vertex as usize;
            (first..first + mp.vertex_count as usize)
                .map(|v| mean(total[v]) as f64 * sol.mesh.vertices[v].area as f64)
                .sum()
        }
    }
}

/// How much a source's unoccluded light may vary over a curved patch before the
/// gradient criterion ray traces it (see [`judge`]).
const CURVED_SPREAD: f32 = 0.2;

/// Whether a source is a point (point or spot light: one ray, no solid angle).
fn is_point(scene: &Scene, s: SourceId) -> bool {
    matches!(s, SourceId::Light(l) if !matches!(scene.lights[l as usize], Light::Area { .. } | Light::Environment { .. }))
}

/// Whether a source is the sky (seen under the whole hemisphere).
fn is_sky(scene: &Scene, s: SourceId) -> bool {
    matches!(s, SourceId::Light(l) if matches!(scene.lights[l as usize], Light::Environment { .. }))
}

/// What the criteria are judged against: the scene, the solution with its total
/// radiosity per vertex, the thresholds and the camera (for the view criterion).
pub struct Judge<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// The radiosity solution.
    pub sol: &'a Solution,
    /// Total radiosity per vertex ([`Solution::total`]).
    pub total: &'a [Rgb],
    /// Thresholds.
    pub settings: &'a SelectSettings,
    /// The camera, for the view criterion (none: the criterion passes).
    pub view: Option<&'a ViewScale>,
    /// The scene's lights, prepared ([`SampledLight::prepare_all`]).
    pub lights: &'a [SampledLight],
}

/// The five criteria of Sect. 3 for the listed source `entry` on patch `p`; `tris`
/// are the source's triangles (empty for point and spot lights).
/// `points` holds the patch's falloff points once some source of it asks for them
/// (one per patch, shared by its sources).
pub fn judge(j: &Judge, p: u32, entry: &ListEntry, tris: &Subtense, points: &FalloffPoints) -> Criteria {
    let (scene, sol, total, settings, view) = (j.scene, j.sol, j.total, j.settings, j.view);
    let mp = &sol.mesh.patches[p as usize];
    let first = mp.first_vertex as usize;
    let verts = &sol.mesh.vertices[first..first + mp.vertex_count as usize];
    let mut c = Criteria::default();

    // Radiance: the source's light against the patch's, where each is largest.
    let max_total = total[first..first + verts.len()]
        .iter()
        .map(|t| mean(*t))
        .fold(0.0, f32::max);
    let max_unocc = entry.unoccluded.iter().map(|u| mean(*u)).fold(0.0, f32::max);
    c.share = if max_total > 0.0 {
        max_unocc / max_total
    } else if max_unocc > 0.0 {
        f32::INFINITY
    } else {
        0.0
    };
    c.radiance = max_unocc > 0.0 && c.share >= settings.radiance_threshold;

    // Reflectivity.
    c.reflectivity = mean(mp.reflectance) >= settings.reflectivity_threshold;

    // Gradient: partial visibility across the vertices. A point or spot light that
    // does not reach a vertex at all counts as invisible there (a spot's cone edge
    // crossing the patch is as sharp as a shadow); an area source's horizon crossing
    // the patch is a smooth falloff the mesh represents, so such vertices are skipped.
    let point = is_point(scene, entry.source);
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (o, u) in entry.occluded.iter().zip(&entry.unoccluded) {
        let u = mean(*u);
        let v = if u > 1e-3 * max_unocc {
            (mean(*o) / u).clamp(0.0, 1.0)
        } else if point {
            0.0
        } else {
            continue;
        };
        lo = lo.min(v);
        hi = hi.max(v);
    }
    c.visibility_spread = if hi >= lo { hi - lo } else { 0.0 };
    c.gradient = c.visibility_spread > settings.gradient_threshold;
    // On a curved patch (a sphere, a Bezier piece) the source's unoccluded light
    // follows the turning normal, which the elements' linear interpolation flattens
    // (a small sphere's top under a lamp comes out 5-8% dark): a source whose
    // unoccluded light varies by more than CURVED_SPREAD over such a patch passes too.
    let bends = mp.surface().is_some_and(|s| s.bends());
    // A bump or normal map turns the shading normal within every element, which the
    // solution's light at the vertices (found at the flat surface's normal) cannot
    // show: a light that can be ray traced at all is, so the bumps show in its light
    // as in Mitsuba's picture (they were flat before).
    let shape = &scene.shapes[mp.shape as usize];
    if scene.bsdfs[shape.bsdf as usize].bumped() {
        c.gradient = true;
    }
    if !c.gradient && bends {
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        for u in &entry.unoccluded {
            let u = mean(*u);
            lo = lo.min(u);
            hi = hi.max(u);
        }
        c.gradient = hi > 0.0 && lo < (1.0 - CURVED_SPREAD) * hi;
    }

    // Solid angle: its mean over the patch decides and sets the ray count.
    if point {
        c.solid_angle = true;
        c.rays = 1;
    } else {
        let (mut sum, mut area, mut max) = (0.0f32, 0.0f32, 0.0f32);
        for v in verts {
            let w = tris.from(v.q);
            sum += w * v.area;
            area += v.area;
            max = max.max(w);
        }
        c.solid_angle_sr = if is_sky(scene, entry.source) {
            2.0 * std::f32::consts::PI
        } else if area > 0.0 {
            sum / area
        } else {
            max
        };
        c.solid_angle = c.solid_angle_sr <= settings.max_solid_angle;
        let rays =
            (c.solid_angle_sr / (2.0 * std::f32::consts::PI) * settings.hemisphere_rays as f32).round();
        c.rays = (rays as u32).clamp(1, settings.area_samples.max(1));
    }

    // View: the size of the patch's elements on screen.
    c.element_pixels = f32::INFINITY;
    if let Some(vs) = view {
        let tri_grid = matches!(
            mp.grids.first().map(|g| &g.domain),
            Some(crate::mesh::Domain::Tri(_))
        );
        let per = mp.area / mp.element_count.max(1) as f32;
        let edge = (if tri_grid { 2.0 * per } else { per }).sqrt();
        let d = verts
            .iter()
            .map(|v| (v.p - vs.eye).length())
            .fold(f32::INFINITY, f32::min);
        c.element_pixels = vs.scale.pixels(edge, d);
    }
    c.view = !settings.view_criterion || view.is_none() || c.element_pixels >= settings.view_threshold;

    // A shading boundary with no shadow (paper Sect. 6: "if these contributions show
    // large differences, then some kind of shadow or shading boundary appears"): a
    // light close to a flat patch lights a spot smaller than its elements (a lamp
    // beside a wall), which the elements' interpolation blurs. Asked only where it can
    // still decide.
    if c.radiance && c.reflectivity && c.solid_angle && c.view && !c.gradient && !bends {
        if let SourceId::Light(l) = entry.source {
            let points = points.0.get_or_init(|| falloff_points(j, p));
            c.falloff_error = falloff_error(points, entry, &j.lights[l as usize], mp.first_vertex);
            c.gradient = c.falloff_error > FALLOFF_ERROR;
        }
    }
    c
}

/// How far the interpolated unoccluded light of a listed light may stray from its
/// exact value at an element's centre, as a share of the total radiosity there,
/// before the gradient criterion ray traces the light (see [`falloff_error`]). In
/// `scenes/hall` a light 0.5 m from a wall of 0.6 m elements left the eighth of the
/// image round its spot 13 % dark; hall FLIP against Mitsuba by this threshold: none
/// 0.0291, 0.2 0.0272, 0.1 0.0267, 0.05 0.0263, 0.02 0.0255 (for 2.1, 2.5, 2.7, 3.0,
/// 3.5 M shadow rays; measured on a first version of the hall).
const FALLOFF_ERROR: f32 = 0.05;

/// The points of a patch where the falloff test compares a listed light's
/// interpolated light with its exact one ([`judge`]), made once per patch.
#[derive(Default)]
pub struct FalloffPoints(std::cell::OnceCell<Vec<FalloffPoint>>);

/// The centre of a piece of a patch ([`crate::mesh::RadiosityMesh::pieces`], no bigger
/// than an element), its normal on the patch's side, its interpolation weights over
/// the patch's own vertices (summing to 1), the interpolated total radiosity there and
/// the albedo the vertices' radiosity interpolates over.
struct FalloffPoint {
    x: Vec3,
    n: Vec3,
    w: Interp,
    total: f32,
    rho: Rgb,
}

fn falloff_points(j: &Judge, p: u32) -> Vec<FalloffPoint> {
    let mesh = &j.sol.mesh;
    let mp = &mesh.patches[p as usize];
    let own = mp.first_vertex..mp.first_vertex + mp.vertex_count;
    let mut out = Vec::new();
    for piece in mesh.pieces(p) {
        let [a, b, c] = piece.corners;
        let x = (a + b + c) / 3.0;
        // Weights over the patch's own vertices only (a lattice piece may weigh in a
        // neighbouring patch's vertex at a seam), as covered vertices drop out.
        let w = mesh.weights_on(&piece, x).uncover(|v| !own.contains(&v));
        let n = (b - a).cross(c - a).normalize_or_zero();
        if (0..4).any(|k| w.weights[k] > 0.0 && !own.contains(&w.vertices[k])) || n == Vec3::ZERO {
            continue;
        }
        let front: Vec3 = (0..4)
            .map(|k| mesh.vertices[w.vertices[k] as usize].n * w.weights[k])
            .sum();
        let total = mean(w.apply(j.total));
        if total > 0.0 {
            let n = if n.dot(front) < 0.0 { -n } else { n };
            let rho = mesh.albedo_at(&w);
            out.push(FalloffPoint { x, n, w, total, rho });
        }
    }
    out
}

/// The largest error of the elements' linear interpolation of `entry`'s unoccluded
/// light at a patch's falloff `points` against the light's exact unoccluded
/// irradiance there times the albedo there, as a share of the total
/// radiosity at the point. 0 for a light with no closed form (an exact sphere, a
/// finely tessellated emitter). `first` is the patch's first vertex.
fn falloff_error(points: &[FalloffPoint], entry: &ListEntry, light: &SampledLight, first: u32) -> f32 {
    let mut worst = 0.0f32;
    for pt in points {
        let Some(exact) = unoccluded_irradiance(light, pt.x, pt.n) else {
            return 0.0;
        };
        let stored: Rgb = (0..4)
            .filter(|&k| pt.w.weights[k] > 0.0)
            .map(|k| entry.unoccluded[(pt.w.vertices[k] - first) as usize] * pt.w.weights[k])
            .sum();
        worst = worst.max((mean(exact * pt.rho) - mean(stored)).abs() / pt.total);
    }
    worst
}

/// A light's unoccluded irradiance at `x` (unit normal `n`): a point or spot light's
/// by the rule of pass 1's shots ([`SampledLight::point_light_at`]), an area light's
/// in closed form where it has one.
fn unoccluded_irradiance(light: &SampledLight, x: Vec3, n: Vec3) -> Option<Rgb> {
    if light.is_area() {
        return light.unoccluded_irradiance(x, n);
    }
    Some(light.point_light_at(x, n).map_or(Vec3::ZERO, |(e, _)| e))
}

/// Chooses the ray-traced sources of `method` (`twopass`, `norm`, `local` or
/// `global`) on every patch of `sol`. `view` is the camera for the view criterion.
/// Settings outside the command line's ranges are refused ([`SelectSettings::validate`]).
pub fn select<'a>(
    scene: &Scene,
    sol: &'a Solution,
    method: Method,
    settings: &SelectSettings,
    view: Option<&ViewScale>,
) -> Result<Selection<'a>> {
    settings.validate()?;
    select_unchecked(scene, sol, method, settings, view)
}

/// [`select`] without [`SelectSettings::validate`], for tests that push a criterion
/// past its range (a negative gradient threshold lets every source through).
pub(crate) fn select_unchecked<'a>(
    scene: &Scene,
    sol: &'a Solution,
    method: Method,
    settings: &SelectSettings,
    view: Option<&ViewScale>,
) -> Result<Selection<'a>> {
    let mesh = &sol.mesh;
    let np = mesh.patches.len();
    let nl = scene.lights.len();
    let total = sol.total();
    let area_rays = |s: SourceId| {
        if is_point(scene, s) {
            1
        } else {
            settings.area_samples.max(1)
        }
    };
    let all_lights: Vec<(SourceId, u32)> = (0..nl as u32)
        .map(|l| (SourceId::Light(l), area_rays(SourceId::Light(l))))
        .collect();
    let mut criteria = Vec::new();
    let chosen: Vec<Vec<(SourceId, u32)>> = match method {
        Method::Direct => {
            return Err(Error::Usage(
                "--method direct uses no radiosity solution and no selection".into(),
            ))
        }
        Method::Twopass => vec![Vec::new(); np],
        Method::Norm => {
            let n = sol.settings.sources_per_patch as usize;
            if n < nl {
                return Err(Error::Usage(format!(
                    "--method norm needs every light kept apart from the general radiosity, but the solution keeps {n} sources per patch and the scene has {nl} lights: solve with --sources-per-patch {nl} or more"
                )));
            }
            vec![all_lights; np]
        }
        Method::Global => {
            // Rank lights by emitted power and radiant patches by reflected power.
            let mut ranked: Vec<(f64, SourceId)> = (0..nl as u32)
                .map(SourceId::Light)
                .chain((0..np as u32).map(SourceId::Patch))
                .map(|s| (source_power(scene, sol, &total, s), s))
                .filter(|&(w, s)| w > 0.0 || matches!(s, SourceId::Light(_)))
                .collect();
            ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            ranked.truncate(settings.global_sources as usize);
            let lights: Vec<(SourceId, u32)> = ranked
                .iter()
                .filter(|(_, s)| matches!(s, SourceId::Light(_)))
                .map(|&(_, s)| (s, area_rays(s)))
                .collect();
            // Only where the solve kept a source apart: where it was folded into the
            // general radiosity, its light is already there (one route per source).
            (0..np)
                .map(|p| {
                    let listed = |s: SourceId| sol.lists[p].iter().any(|e| e.source == s);
                    let mut v: Vec<(SourceId, u32)> =
                        lights.iter().copied().filter(|&(s, _)| listed(s)).collect();
                    for e in &sol.lists[p] {
                        if matches!(e.source, SourceId::Patch(_)) && ranked.iter().any(|r| r.1 == e.source) {
                            v.push((e.source, area_rays(e.source)));
                        }
                    }
                    v
                })
                .collect()
        }
        Method::Local => {
            let mut tris: BTreeMap<SourceId, Subtense> = BTreeMap::new();
            for e in sol.lists.iter().flatten() {
                tris.entry(e.source)
                    .or_insert_with(|| Subtense::new(source_triangles(scene, sol, e.source)));
            }
            let lights = SampledLight::prepare_all(scene);
            let judge_ctx = Judge {
                scene,
                sol,
                total: &total,
                settings,
                view,
                lights: &lights,
            };
            criteria = (0..np)
                .into_par_iter()
                .with_max_len(64)
                .map(|p| {
                    let points = FalloffPoints::default();
                    sol.lists[p]
                        .iter()
                        .map(|e| {
                            let c = judge(&judge_ctx, p as u32, e, &tris[&e.source], &points);
                            (e.source, c)
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            let mut chosen: Vec<Vec<(SourceId, u32)>> = criteria
                .iter()
                .map(|cs| {
                    cs.iter()
                        .filter(|(_, c)| c.selected())
                        .map(|(s, c)| (*s, c.rays))
                        .collect()
                })
                .collect();
            if settings.per == SelectPer::Object {
                // A source selected on any patch of a shape is selected on all its
                // patches that list it, with the most rays any of them wanted.
                let mut per_shape: BTreeMap<(u32, SourceId), u32> = BTreeMap::new();
                for (p, ch) in chosen.iter().enumerate() {
                    for &(s, r) in ch {
                        let k = per_shape.entry((mesh.patches[p].shape, s)).or_insert(0);
                        *k = (*k).max(r);
                    }
                }
                for (p, ch) in chosen.iter_mut().enumerate() {
                    let shape = mesh.patches[p].shape;
                    *ch = sol.lists[p]
                        .iter()
                        .filter_map(|e| per_shape.get(&(shape, e.source)).map(|&r| (e.source, r)))
                        .collect();
                }
            }
            chosen
        }
    };

    // Ray-traced sources: all lights, then the radiant patches chosen anywhere.
    let mut sources: Vec<SourceId> = (0..nl as u32).map(SourceId::Light).collect();
    let mut patch_sources: Vec<u32> = chosen
        .iter()
        .flatten()
        .filter_map(|(s, _)| match s {
            SourceId::Patch(p) => Some(*p),
            _ => None,
        })
        .collect();
    patch_sources.sort_unstable();
    patch_sources.dedup();
    sources.extend(patch_sources.iter().map(|&p| SourceId::Patch(p)));
    let index = |s: SourceId| match s {
        SourceId::Light(l) => l,
        SourceId::Patch(p) => nl as u32 + patch_sources.binary_search(&p).expect("collected above") as u32,
    };

    let mut offsets = Vec::with_capacity(np + 1);
    let mut picks = Vec::new();
    let mut stored = sol.general.clone();
    for (p, ch) in chosen.iter().enumerate() {
        offsets.push(picks.len() as u32);
        for &(s, rays) in ch {
            picks.push(Pick {
                source: index(s),
                rays,
            });
        }
        let first = mesh.patches[p].first_vertex as usize;
        for e in &sol.lists[p] {
            if !ch.iter().any(|(s, _)| *s == e.source) {
                for (k, c) in e.occluded.iter().enumerate() {
                    stored[first + k] += *c;
                }
            }
        }
    }
    offsets.push(picks.len() as u32);

    let emitters = sources
        .iter()
        .map(|&s| match s {
            SourceId::Light(l) => SampledLight::prepare(scene, l),
            SourceId::Patch(p) => {
                let tris = mesh.element_triangles(p);
                let corners = tris
                    .iter()
                    .map(|t| t.map(|v| total[v as usize] * std::f32::consts::FRAC_1_PI))
                    .collect();
                let pos = tris.iter().map(|t| t.map(|v| mesh.vertices[v as usize].p));
                SampledLight::Area(AreaEmitter::new(pos, Vec3::ZERO, corners))
            }
        })
        .collect();
    Ok(Selection {
        solution: sol,
        method,
        sources,
        emitters,
        stored,
        offsets,
        picks,
        criteria,
    })
}

#[cfg(test)]
pub(crate) mod tests;
