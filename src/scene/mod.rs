//! The scene: shapes with their materials, light sources and views (sensors).
//!
//! A [`Scene`] is immutable once loaded (see [`xml::load`]); every later stage reads it.

pub mod hdr_sun;
pub mod spectrum;
pub mod sunsky;
pub mod texture;
pub mod xml;

use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use glam::{Mat4, Vec2, Vec3};

pub use texture::Texture;

use crate::geometry::TriMesh;

/// Linear RGB triplet (reflectance, radiance, intensity...).
pub type Rgb = Vec3;

/// The mean of a colour's three channels: the one scalar value of a colour wherever
/// one is needed (power, ranks, Russian roulette, thresholds).
pub fn mean(c: Rgb) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// A colour's luminance, with Mitsuba 3's weights (`mi.luminance`, Rec. 709): the value
/// a texture gives where Mitsuba reads one channel of it (`eval_1`: a blend's weight, a
/// mask's opacity, a bump map's height), 1 for white, the value itself for grey.
pub fn luminance(c: Rgb) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// A material, reduced to what the paper's reflection model needs: a diffuse
/// (Lambertian) part and a perfect mirror part.
#[derive(Debug, Clone, PartialEq)]
pub enum BsdfKind {
    /// Lambertian reflector (`diffuse`).
    Diffuse {
        /// Diffuse reflectance rho.
        reflectance: Rgb,
    },
    /// Smooth mirror (`conductor`): `specular_reflectance` times its Fresnel term at
    /// the angle of incidence (1 for Mitsuba's `material="none"`).
    Conductor {
        /// Scale of the reflection.
        specular_reflectance: Rgb,
        /// The Fresnel term.
        fresnel: Fresnel,
    },
    /// Diffuse base under a smooth dielectric coating (`plastic`), as in Mitsuba 3.
    Plastic {
        /// Diffuse reflectance of the base.
        diffuse_reflectance: Rgb,
        /// Scale of the coating's Fresnel reflection.
        specular_reflectance: Rgb,
        /// Relative index of refraction `int_ior / ext_ior`.
        eta: f32,
        /// Mitsuba's `nonlinear` flag (internal scattering darkens colours).
        nonlinear: bool,
    },
    /// Diffuse base under a rough dielectric coating (`roughplastic`), as in Mitsuba 3.
    RoughPlastic {
        /// Diffuse reflectance of the base.
        diffuse_reflectance: Rgb,
        /// The coating's reflection: an isotropic lobe whose Fresnel term is
        /// [`Fresnel::Dielectric`] (its `eta` is `int_ior / ext_ior`) and whose scale
        /// is `specular_reflectance`.
        lobe: Glossy,
        /// Mitsuba's `nonlinear` flag (internal scattering darkens colours).
        nonlinear: bool,
        /// The coating's transmittance by angle, computed from `lobe` on first use.
        coating: CoatingCell,
        /// Mitsuba 3's `pplastic` (its polarised plastic, as its RGB variants render
        /// it): the diffuse part is the base's reflectance over pi times the smooth
        /// interface's two Fresnel transmittances, one per direction, with no light
        /// reflected back inside and no `eta^2` dilution; the lobe may be anisotropic.
        pplastic: bool,
    },
    /// A rough conductor (`roughconductor`): a glossy lobe of microfacets.
    RoughConductor {
        /// The lobe.
        lobe: Glossy,
    },
    /// Glass: a smooth interface that reflects and refracts (`dielectric`), or a thin
    /// pane that reflects and lets light through unbent (`thindielectric`), as in
    /// Mitsuba 3.
    Dielectric {
        /// Relative index of refraction `int_ior / ext_ior` (inside over outside).
        eta: f32,
        /// Scale of the reflection (`specular_reflectance`).
        specular_reflectance: Rgb,
        /// Scale of the transmission (`specular_transmittance`).
        specular_transmittance: Rgb,
        /// A thin pane (`thindielectric`): light passes straight through, with the
        /// reflections between its two faces summed.
        thin: bool,
        /// A rough interface (`roughdielectric`): its microfacet distribution (at
        /// render time; pass 1 lets light through it as through smooth glass).
        rough: Option<Microfacet>,
    },
    /// `(1 - weight) * a + weight * b` (`blendbsdf`).
    Blend {
        /// Weight of `b`.
        weight: f32,
        /// First BSDF.
        a: Box<BsdfKind>,
        /// Second BSDF.
        b: Box<BsdfKind>,
    },
}

/// A microfacet distribution of normals: GGX (Trowbridge-Reitz) or Beckmann, with
/// roughness `alpha_u` along the local x axis and `alpha_v` along y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Microfacet {
    /// Roughness along x.
    pub alpha_u: f32,
    /// Roughness along y.
    pub alpha_v: f32,
    /// Beckmann instead of GGX.
    pub beckmann: bool,
}

/// How a conductor's reflectance depends on the angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fresnel {
    /// From its complex index per channel (`eta`, `k`).
    Conductor {
        /// Real part.
        eta: Rgb,
        /// Imaginary part.
        k: Rgb,
    },
    /// Schlick's curve from the reflectance at normal incidence: 1 for Mitsuba's
    /// `none`, a `principled` metal's base colour.
    Schlick {
        /// Reflectance at normal incidence.
        f0: Rgb,
    },
    /// A dielectric's (unpolarised, the same in every channel): a rough plastic's
    /// coating.
    Dielectric {
        /// Relative index of refraction `int_ior / ext_ior`.
        eta: f32,
    },
}

/// Entries of [`Coating::external`]: Mitsuba 3's `MI_ROUGH_TRANSMITTANCE_RES`.
pub const COATING_RES: usize = 64;

/// What light a rough dielectric coating lets through, as Mitsuba 3's `roughplastic`
/// precomputes it (the numbers are made by the bsdf layer).
#[derive(Debug, Clone, PartialEq)]
pub struct Coating {
    /// Transmittance into the coating of light from outside at cosine
    /// `i / (COATING_RES - 1)`, `i` the index (linearly interpolated in between).
    pub external: [f32; COATING_RES],
    /// Mean reflectance of the coating from inside, to diffuse light.
    pub internal_reflectance: f32,
    /// Cosine-weighted hemispherical mean of `external`, `2 * integral t(mu) mu dmu`.
    pub mean_external: f32,
}

/// A [`Coating`] computed once, on first use, and shared by the clones of the
/// material. It depends only on the other parameters of the material, so it takes
/// no part in comparisons.
#[derive(Clone, Default)]
pub struct CoatingCell(Arc<OnceLock<Coating>>);

impl CoatingCell {
    /// The coating, made by `make` the first time.
    pub fn get_or_init(&self, make: impl FnOnce() -> Coating) -> &Coating {
        self.0.get_or_init(make)
    }
}

impl PartialEq for CoatingCell {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for CoatingCell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.get().is_some() {
            "CoatingCell(computed)"
        } else {
            "CoatingCell(pending)"
        })
    }
}

/// A rough conductor's lobe: `specular_reflectance` times the microfacet model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Glossy {
    /// The distribution of microfacet normals.
    pub distribution: Microfacet,
    /// The Fresnel term.
    pub fresnel: Fresnel,
    /// Mitsuba's `specular_reflectance` (a scale).
    pub scale: Rgb,
}

/// A material as used by shapes.
#[derive(Debug, Clone, PartialEq)]
pub struct Bsdf {
    /// The `id` in the scene file, or a generated name.
    pub name: String,
    /// The reflection model, its textured parameters at their textures' means (what
    /// the radiosity pass uses).
    pub kind: BsdfKind,
    /// Reflects on both sides (`twosided`); otherwise the back side is black.
    pub twosided: bool,
    /// The parameters of `kind` that textures give, point by point.
    pub textures: Vec<TexSlot>,
}

/// Which parameter of a [`BsdfKind`] a texture gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TexField {
    /// `diffuse`'s `reflectance`, `plastic`'s and `roughplastic`'s `diffuse_reflectance`.
    Diffuse,
    /// `conductor`'s, `roughconductor`'s, `plastic`'s and `roughplastic`'s `specular_reflectance`.
    Specular,
    /// `blendbsdf`'s `weight` (the texture's first channel).
    Weight,
    /// A height field that tilts the shading normal (`bumpmap`; its gradient times
    /// the slot's `factor.x`, Mitsuba's `scale`), under its rules.
    Bump(BumpRules),
    /// The shading normal in the surface's tangent frame, 2 x texel - 1
    /// (`normalmap`), under its rules.
    Normal(BumpRules),
    /// How opaque the surface is (`mask`'s `opacity`, the first channel): rays pass
    /// through the rest.
    Opacity,
}

impl TexField {
    /// The rules of a bump or normal map; `None` for any other field.
    pub fn bump_rules(self) -> Option<BumpRules> {
        match self {
            TexField::Bump(rules) | TexField::Normal(rules) => Some(rules),
            _ => None,
        }
    }
}

/// The two rules Mitsuba 3 (since 3.7.1) applies to a `bumpmap` or `normalmap`, both
/// on unless the file turns them off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BumpRules {
    /// `flip_invalid_normals`: a tilted normal the arriving ray would see from behind
    /// is mirrored about the untilted one.
    pub flip: bool,
    /// `use_shadowing_function`: reflection is weighed by the microfacet terminator
    /// term ([`crate::interaction::terminator`]).
    pub shadowing: bool,
}

impl Default for BumpRules {
    fn default() -> Self {
        BumpRules {
            flip: true,
            shadowing: true,
        }
    }
}

/// A textured parameter of a material: where in the (blended) model it sits, which
/// texture gives it, times what.
#[derive(Debug, Clone, PartialEq)]
pub struct TexSlot {
    /// The way down nested blends from the outermost: `false` its `a`, `true` its `b`.
    pub path: Vec<bool>,
    /// The parameter.
    pub field: TexField,
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// The value is the texture times this (a conductor's reflectance at normal
    /// incidence, for instance).
    pub factor: Rgb,
}

impl Bsdf {
    /// Whether a `mask` makes parts of the surface open.
    pub fn masked(&self) -> bool {
        self.textures.iter().any(|t| t.field == TexField::Opacity)
    }

    /// Whether a `bumpmap` or `normalmap` tilts the shading normal.
    pub fn bumped(&self) -> bool {
        self.textures.iter().any(|t| t.field.bump_rules().is_some())
    }

    /// How opaque the surface is at surface parameters `uv` (its `mask`'s opacity, the
    /// texture's [`luminance`] in [0, 1], as Mitsuba reads it; 1 without a mask).
    pub fn opacity_at(&self, uv: Vec2, textures: &[Texture]) -> f32 {
        self.textures
            .iter()
            .find(|t| t.field == TexField::Opacity)
            .and_then(|t| textures.get(t.texture as usize))
            .map_or(1.0, |t| luminance(t.eval(uv)).clamp(0.0, 1.0))
    }

    /// The reflection model at surface parameters `uv`: `kind` with its textured
    /// parameters looked up there, over a footprint `width` wide in (u, v) (0: a
    /// point; [`Texture::eval_over`]), `kind` itself when none is textured.
    pub fn kind_at(&self, uv: Vec2, width: f32, textures: &[Texture]) -> Cow<'_, BsdfKind> {
        if self.textures.is_empty() {
            return Cow::Borrowed(&self.kind);
        }
        let mut kind = self.kind.clone();
        for slot in &self.textures {
            let Some(t) = textures.get(slot.texture as usize) else {
                continue;
            };
            let value = t.eval_over(uv, width) * slot.factor;
            let mut k = &mut kind;
            for &b in &slot.path {
                match k {
                    BsdfKind::Blend { a, b: bb, .. } => k = if b { bb } else { a },
                    _ => break,
                }
            }
            match (k, slot.field) {
                (BsdfKind::Diffuse { reflectance }, TexField::Diffuse) => {
                    *reflectance = value.clamp(Vec3::ZERO, Vec3::ONE)
                }
                (
                    BsdfKind::Plastic {
                        diffuse_reflectance, ..
                    }
                    | BsdfKind::RoughPlastic {
                        diffuse_reflectance, ..
                    },
                    TexField::Diffuse,
                ) => *diffuse_reflectance = value.clamp(Vec3::ZERO, Vec3::ONE),
                (
                    BsdfKind::Conductor {
                        specular_reflectance, ..
                    },
                    TexField::Specular,
                )
                | (
                    BsdfKind::Plastic {
                        specular_reflectance, ..
                    }
                    | BsdfKind::Dielectric {
                        specular_reflectance, ..
                    },
                    TexField::Specular,
                ) => *specular_reflectance = value.max(Vec3::ZERO),
                (BsdfKind::RoughConductor { lobe }, TexField::Specular)
                | (BsdfKind::RoughPlastic { lobe, .. }, TexField::Specular) => {
                    lobe.scale = value.max(Vec3::ZERO)
                }
                (BsdfKind::Blend { weight, .. }, TexField::Weight) => {
                    *weight = luminance(value).clamp(0.0, 1.0)
                }
                _ => {}
            }
        }
        Cow::Owned(kind)
    }
}

impl Default for Bsdf {
    /// Mitsuba's default: a one-sided diffuse of reflectance 0.5.
    fn default() -> Self {
        Bsdf {
            name: "default".into(),
            kind: BsdfKind::Diffuse {
                reflectance: Vec3::splat(0.5),
            },
            twosided: false,
            textures: Vec::new(),
        }
    }
}

/// A light source.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity I (W/sr).
        intensity: Rgb,
    },
    /// Spot light as Mitsuba's `spot`: shines along the local +z of `to_world`.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit direction of the beam's axis.
        direction: Vec3,
        /// Radiant intensity on the axis (W/sr).
        intensity: Rgb,
        /// Full cutoff angle (radians): no light beyond it.
        cutoff_angle: f32,
        /// Angle (radians) up to which the intensity is full; falls off linearly in
        /// angle from there to the cutoff.
        beam_width: f32,
    },
    /// Diffuse area emitter on a shape's front side.
    Area {
        /// Index of the shape in [`Scene::shapes`].
        shape: u32,
        /// Emitted radiance Le (a texture's mean, where `texture` gives it).
        radiance: Rgb,
        /// A texture of the radiance over the surface (index into
        /// [`Scene::textures`]): what a ray that meets the light sees there. Its mean,
        /// `radiance`, is what the light sends to the scene (pass 1 and shadow rays).
        texture: Option<u32>,
    },
    /// Light from infinitely far along one direction (`directional`: the sun).
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Irradiance on a surface facing it (W/m^2).
        irradiance: Rgb,
    },
    /// Light from infinitely far in every direction: a uniform sky (`constant`) or a
    /// latitude-longitude image (`envmap`, Mitsuba's mapping: +y up).
    Environment {
        /// The radiance (`constant`), or the image's scale (`envmap`).
        radiance: Rgb,
        /// Index into [`Scene::textures`] of the image, if any.
        texture: Option<u32>,
        /// World to the map's own frame (the inverse of its `to_world`'s rotation).
        to_local: glam::Mat3,
    },
}

impl Light {
    /// The kind as a word: "point", "spot" or "area".
    pub fn kind(&self) -> &'static str {
        match self {
            Light::Point { .. } => "point",
            Light::Spot { .. } => "spot",
            Light::Area { .. } => "area",
            Light::Directional { .. } => "directional",
            Light::Environment { texture: None, .. } => "constant",
            Light::Environment { .. } => "envmap",
        }
    }

    /// The radiance an environment sends along `-dir` (seen looking along `dir`,
    /// world space); zero for other lights. Mitsuba's mapping: u = atan2(x, -z) / 2pi,
    /// v = acos(y) / pi in the map's frame.
    pub fn environment_radiance(&self, dir: Vec3, textures: &[Texture]) -> Rgb {
        let Light::Environment {
            radiance,
            texture,
            to_local,
        } = self
        else {
            return Vec3::ZERO;
        };
        match texture.and_then(|t| textures.get(t as usize)) {
            Some(t) => *radiance * t.eval_lat_long(environment_uv(*to_local * dir)),
            None => *radiance,
        }
    }
}

/// The latitude-longitude map's (u, v) of unit direction `d` in its own frame
/// (Mitsuba 3's `envmap`).
pub fn environment_uv(d: Vec3) -> Vec2 {
    let d = d.normalize_or(Vec3::Y);
    let mut u = d.x.atan2(-d.z) * (0.5 * std::f32::consts::FRAC_1_PI);
    if u < 0.0 {
        u += 1.0;
    }
    Vec2::new(u, d.y.clamp(-1.0, 1.0).acos() * std::f32::consts::FRAC_1_PI)
}

/// The unit direction (in the map's frame) of the latitude-longitude map's (u, v):
/// the inverse of [`environment_uv`].
pub fn environment_dir(uv: Vec2) -> Vec3 {
    let (sp, cp) = (uv.x * 2.0 * std::f32::consts::PI).sin_cos();
    let (st, ct) = (uv.y * std::f32::consts::PI).sin_cos();
    Vec3::new(sp * st, ct, -cp * st)
}

/// A shape instance: its world-space mesh, material and (optional) area emitter.
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// The `id` in the scene file, or a name made from the plugin and file.
    pub name: String,
    /// World-space triangles and patches.
    pub mesh: TriMesh,
    /// Index into [`Scene::bsdfs`].
    pub bsdf: u32,
    /// Index into [`Scene::lights`] when the shape is an area emitter.
    pub emitter: Option<u32>,
}

/// Pixel reconstruction filter (a film's `rfilter`; its weights are the render's).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    /// Equal weights for the samples inside the pixel's square (the paper's).
    Box,
    /// Mitsuba's `tent`: 1 - |x| out to 1 px.
    Tent,
    /// Mitsuba's Gaussian: stddev 0.5 px, radius 2 px, shifted to reach 0 at the radius.
    #[default]
    Gaussian,
    /// Mitsuba's `mitchell`: the Mitchell-Netravali cubic of B = C = 1/3, radius 2 px.
    Mitchell,
    /// Mitsuba's `catmullrom`: the Mitchell-Netravali cubic of B = 0, C = 1/2.
    Catmullrom,
    /// Mitsuba's `lanczos`: the sinc windowed by a sinc, three lobes (radius 3 px).
    Lanczos,
}

impl Filter {
    /// Every filter, in the order the help lists them.
    pub const ALL: [Filter; 6] = [
        Filter::Box,
        Filter::Tent,
        Filter::Gaussian,
        Filter::Mitchell,
        Filter::Catmullrom,
        Filter::Lanczos,
    ];

    /// The name used on the command line, in scene files (Mitsuba's) and in the
    /// statistics.
    pub fn name(self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Tent => "tent",
            Filter::Gaussian => "gaussian",
            Filter::Mitchell => "mitchell",
            Filter::Catmullrom => "catmullrom",
            Filter::Lanczos => "lanczos",
        }
    }
}

/// How a sensor's film maps to rays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Projection {
    /// Mitsuba's `perspective` (and `thinlens`, its depth of field ignored): rays from
    /// the eye through the film.
    #[default]
    Perspective,
    /// Mitsuba's `orthographic`: parallel rays along local +z from the film, which
    /// spans local x in [-1, 1] and y in [-1, 1] / aspect (`to_world` scales it).
    Orthographic,
}

/// Which axis `fov` spans (Mitsuba's `fov_axis`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FovAxis {
    /// Horizontal (Mitsuba's default).
    X,
    /// Vertical.
    Y,
    /// The image diagonal.
    Diagonal,
    /// The smaller image side.
    Smaller,
    /// The larger image side.
    Larger,
}

/// A pinhole camera (Mitsuba's `perspective` sensor) with its film.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Camera-to-world: local +z looks forward, +y is up, +x is the image's left.
    /// An orthographic sensor's may scale: the film spans local x in [-1, 1].
    pub to_world: Mat4,
    /// How the film maps to rays.
    pub projection: Projection,
    /// Field of view in degrees along `fov_axis`.
    pub fov: f32,
    /// Which axis `fov` spans.
    pub fov_axis: FovAxis,
    /// Image width in pixels (a cropped film's window: [`Sensor::crop`]).
    pub width: u32,
    /// Film height in pixels.
    pub height: u32,
    /// Near clip distance.
    pub near_clip: f32,
    /// Far clip distance.
    pub far_clip: f32,
    /// Samples per pixel from the scene's `sampler`, if it names one.
    pub spp: Option<u32>,
    /// The film's `rfilter`, if it names one (Mitsuba's default is its Gaussian).
    pub filter: Option<Filter>,
    /// Where the image lies on the whole film, if the film is cropped.
    pub crop: Option<Crop>,
    /// A thin lens (`thinlens`): depth of field; `None` for a pinhole.
    pub lens: Option<Lens>,
}

/// Mitsuba's thin lens: rays leave a disk of `radius` round the eye (in the lens
/// plane, scene units) and meet at the plane `focus` in front of it, where the image
/// is sharp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lens {
    /// The aperture's radius (`aperture_radius`).
    pub radius: f32,
    /// The distance to the plane in focus along the view axis (`focus_distance`).
    pub focus: f32,
}

/// A film's crop window (Mitsuba's `crop_offset_x`, `crop_offset_y`, `crop_width`,
/// `crop_height`): the image is the window's pixels of the whole film.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crop {
    /// The whole film's size in pixels.
    pub film_width: u32,
    pub film_height: u32,
    /// The window's top-left pixel on the film.
    pub x: u32,
    pub y: u32,
}

impl Sensor {
    /// Tangents of the half field of view along x and y.
    pub fn tan_half_fov(&self) -> (f32, f32) {
        let aspect = self.width as f32 / self.height as f32;
        let t = (self.fov.to_radians() * 0.5).tan();
        let tx = match self.fov_axis {
            FovAxis::X => t,
            FovAxis::Y => t * aspect,
            FovAxis::Diagonal => t * aspect / (1.0 + aspect * aspect).sqrt(),
            FovAxis::Smaller => {
                if aspect > 1.0 {
                    t * aspect
                } else {
                    t
                }
            }
            FovAxis::Larger => {
                if aspect > 1.0 {
                    t
                } else {
                    t * aspect
                }
            }
        };
        (tx, tx / aspect)
    }
}

impl Scene {
    /// The environment light (sky) and its index, if the scene has one.
    pub fn environment(&self) -> Option<(usize, &Light)> {
        self.lights
            .iter()
            .enumerate()
            .find(|(_, l)| matches!(l, Light::Environment { .. }))
    }

    /// The radiance of the sky seen looking along `dir` (black without one).
    pub fn sky(&self, dir: Vec3) -> Rgb {
        self.environment()
            .map_or(Vec3::ZERO, |(_, l)| l.environment_radiance(dir, &self.textures))
    }

    /// The sun's disk seen looking along `dir` ([`SunDisk`]; black outside it and
    /// without one). Only camera, mirror and glass rays see it: the sun's light at a
    /// surface is the directional light's, sampled.
    pub fn sun_seen(&self, dir: Vec3) -> Rgb {
        let Some(disk) = self.sun_disk else {
            return Vec3::ZERO;
        };
        let Some(Light::Directional {
            direction,
            irradiance,
        }) = self.lights.get(disk.light as usize)
        else {
            return Vec3::ZERO;
        };
        if !crate::sampling::in_cone(-*direction, disk.solid_angle, dir.normalize()) {
            return Vec3::ZERO;
        }
        *irradiance / disk.solid_angle
    }

    /// The solid angle of the disk that light `light` (a directional one) shines
    /// from: its [`SunDisk`]'s if it is the sun of a `sunsky` or of a sky photograph,
    /// whose shadows then have the disk's penumbrae (as in Mitsuba, where such a sun
    /// is its texels or its disk); 0 for a plain `directional`, a direction alone.
    pub fn sun_solid_angle(&self, light: u32) -> f32 {
        self.sun_disk
            .filter(|disk| disk.light == light)
            .map_or(0.0, |disk| disk.solid_angle)
    }

    /// Whether shadow rays may pass through shape `s`: glass (a thin pane,
    /// `thindielectric`, which light crosses unbent, so its shadow is only a dimming;
    /// thick glass where its faces are parallel, as a window pane's), or a `mask`ed
    /// surface, where it is not opaque. How much passes is
    /// [`crate::interaction::pane_transmittance`]'s.
    pub fn passes_shadows(&self, s: u32) -> bool {
        self.shapes
            .get(s as usize)
            .and_then(|shape| self.bsdfs.get(shape.bsdf as usize))
            .is_some_and(|b| b.kind.is_glass() || b.masked())
    }

    /// A name for light `i` in tables and messages: its `id` in the scene file, the
    /// name of its shape for an area light, else its kind and index.
    pub fn light_name(&self, i: usize) -> String {
        if let Some(Some(id)) = self.light_ids.get(i) {
            return id.clone();
        }
        match self.lights.get(i) {
            Some(Light::Area { shape, .. }) => self.shapes[*shape as usize].name.clone(),
            Some(l) => format!("{} {i}", l.kind()),
            None => format!("light {i}"),
        }
    }

    /// View (sensor) number `view`, or a usage error naming the scene and its views.
    pub fn sensor(&self, view: usize) -> crate::Result<&Sensor> {
        self.sensors.get(view).ok_or_else(|| {
            crate::Error::Usage(format!(
                "--view {view}: {} has {} view(s), numbered from 0",
                self.path.display(),
                self.sensors.len()
            ))
        })
    }
}

/// A loaded scene, ready to be rendered.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The file it was loaded from.
    pub path: PathBuf,
    /// All shapes.
    pub shapes: Vec<Shape>,
    /// All materials; shapes refer to them by index.
    pub bsdfs: Vec<Bsdf>,
    /// All light sources (point, spot, and one per emitting shape).
    pub lights: Vec<Light>,
    /// The `id` of each point or spot light in the scene file, where it has one
    /// (indexed like `lights`; may be shorter). See [`Scene::light_name`].
    pub light_ids: Vec<Option<String>>,
    /// Views, in file order.
    pub sensors: Vec<Sensor>,
    /// Image textures that materials refer to ([`TexSlot::texture`]).
    pub textures: Vec<Texture>,
    /// The sun's disk, where camera, mirror and glass rays see it (a `sunsky`'s sun).
    pub sun_disk: Option<SunDisk>,
}

/// The disk of a sun that rays see: a `sunsky`'s sun, whose light is the
/// [`Light::Directional`] `light`, seen as a disk of uniform radiance (its irradiance
/// over its solid angle, as Mitsuba's default sun) in the cone of `solid_angle` about
/// its direction; its light samples take directions of the disk
/// ([`Scene::sun_solid_angle`]). A plain `directional` has none: no ray sees it, as
/// in Mitsuba, and its shadows are hard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunDisk {
    /// Index into [`Scene::lights`] of the sun's directional light.
    pub light: u32,
    /// The disk's solid angle ([`crate::sampling::cone_solid_angle`] of half the
    /// `sun_aperture`).
    pub solid_angle: f32,
}
