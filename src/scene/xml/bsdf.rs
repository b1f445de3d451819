//! BSDF plugins: `diffuse`, `conductor`, `roughconductor`, `plastic`, `roughplastic`,
//! `dielectric`, `thindielectric`, `roughdielectric` (`roughdiffuse` becomes
//! `diffuse`), `twosided`, `blendbsdf`, `bumpmap`, `normalmap`, `null`; the
//! unsupported ones become diffuse or their nested bsdf.

use glam::Vec3;
use roxmltree::Node;

use super::document::{tag, Loader, Src};
use super::parse;
use super::properties::{Child, Obj, Target, Val};
use crate::scene::{Bsdf, BsdfKind, BumpRules, Fresnel, Glossy, Microfacet, Rgb, TexField, TexSlot};
use crate::Result;

/// The parameters that give a microfacet lobe's roughness.
const ALPHAS: [&str; 3] = ["alpha", "alpha_u", "alpha_v"];

impl Loader {
    /// Parses a `<bsdf>` (registering its id).
    pub(super) fn bsdf(&mut self, s: Src, c: Node) -> Result<Bsdf> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let obj = self.collect(s, c, format!("bsdf '{ty}'"))?;
        let mut textures = Vec::new();
        // The image that gives parameter `name` as `field`, if one does.
        let mut slot = |name: &str, field: TexField, factor: Vec3| {
            if let Some(texture) = obj.texture_image(name) {
                textures.push(TexSlot {
                    path: Vec::new(),
                    field,
                    texture,
                    factor,
                });
            }
        };
        let (kind, twosided) = match ty.as_str() {
            "diffuse" | "roughdiffuse" => {
                if ty == "roughdiffuse" {
                    self.rough(s, c, &ty, "diffuse");
                    obj.get("alpha");
                    obj.get("use_fast_approx");
                }
                let reflectance = obj.reflectance("reflectance", 0.5)?;
                slot("reflectance", TexField::Diffuse, Vec3::ONE);
                (BsdfKind::Diffuse { reflectance }, false)
            }
            "roughconductor" => {
                let lobe = self.rough_conductor(s, c, &obj)?;
                slot("specular_reflectance", TexField::Specular, Vec3::ONE);
                (BsdfKind::RoughConductor { lobe }, false)
            }
            "conductor" => {
                let kind = self.conductor(s, c, &obj)?;
                slot("specular_reflectance", TexField::Specular, Vec3::ONE);
                (kind, false)
            }
            "plastic" | "roughplastic" | "pplastic" => {
                // `pplastic`: Mitsuba 3's polarised plastic, as its RGB variants render
                // it (a lobe that may be anisotropic; no `nonlinear`).
                let pplastic = ty == "pplastic";
                let distribution = match ty.as_str() {
                    "roughplastic" => {
                        self.roughness_maps(s, &obj, &ALPHAS);
                        Some(rough_plastic(&obj)?)
                    }
                    "pplastic" => Some(self.microfacet(s, &obj)?),
                    _ => None,
                };
                let diffuse_reflectance = obj.reflectance("diffuse_reflectance", 0.5)?;
                let specular_reflectance = obj.reflectance("specular_reflectance", 1.0)?;
                let int_ior = ior(&obj, "int_ior", 1.49)?;
                let ext_ior = ior(&obj, "ext_ior", 1.000277)?;
                let nonlinear = !pplastic && obj.boolean("nonlinear", false)?;
                slot("diffuse_reflectance", TexField::Diffuse, Vec3::ONE);
                slot("specular_reflectance", TexField::Specular, Vec3::ONE);
                let kind = match distribution {
                    Some(distribution) => BsdfKind::RoughPlastic {
                        diffuse_reflectance,
                        lobe: Glossy {
                            distribution,
                            fresnel: Fresnel::Dielectric {
                                eta: int_ior / ext_ior,
                            },
                            scale: specular_reflectance,
                        },
                        nonlinear,
                        coating: Default::default(),
                        pplastic,
                    },
                    None => BsdfKind::Plastic {
                        diffuse_reflectance,
                        specular_reflectance,
                        eta: int_ior / ext_ior,
                        nonlinear,
                    },
                };
                (kind, false)
            }
            "dielectric" | "thindielectric" | "roughdielectric" => {
                let rough = if ty == "roughdielectric" {
                    Some(self.microfacet(s, &obj)?)
                } else {
                    None
                };
                let int_ior = ior(&obj, "int_ior", 1.5046)?;
                let ext_ior = ior(&obj, "ext_ior", 1.000277)?;
                let specular_reflectance = obj.reflectance("specular_reflectance", 1.0)?;
                let specular_transmittance = obj.reflectance("specular_transmittance", 1.0)?;
                slot("specular_reflectance", TexField::Specular, Vec3::ONE);
                let kind = BsdfKind::Dielectric {
                    eta: int_ior / ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                    thin: ty == "thindielectric",
                    rough,
                };
                // Glass has two sides by nature.
                (kind, true)
            }
            "twosided" => {
                let inner = self.nested_bsdfs(&obj)?;
                match inner.len() {
                    0 => return Err(s.err(c, "bsdf 'twosided' needs a nested bsdf")),
                    1 => {}
                    2 => self.warn(
                        s,
                        c,
                        "twosided with a different back-side bsdf: the front one is used on \
                         both sides",
                    ),
                    n => {
                        return Err(s.err(
                            c,
                            format!("bsdf 'twosided' takes one or two nested bsdfs, found {n}"),
                        ))
                    }
                }
                textures = inner[0].textures.clone();
                (inner[0].kind.clone(), true)
            }
            "blendbsdf" => {
                let Some(weight) = obj.scalar("weight")? else {
                    return Err(s.err(c, "bsdf 'blendbsdf' needs a 'weight'"));
                };
                if !(0.0..=1.0).contains(&weight) {
                    return Err(obj.err_param("weight", format!("= {weight} is outside [0, 1]")));
                }
                let inner = self.nested_bsdfs(&obj)?;
                let [a, b] = <[Bsdf; 2]>::try_from(inner).map_err(|v| {
                    s.err(
                        c,
                        format!(
                            "bsdf 'blendbsdf' needs exactly two nested bsdfs, found {}",
                            v.len()
                        ),
                    )
                })?;
                if a.twosided != b.twosided {
                    self.warn(
                        s,
                        c,
                        "blendbsdf of a one-sided and a two-sided bsdf: the blend is two-sided",
                    );
                }
                let twosided = a.twosided || b.twosided;
                slot("weight", TexField::Weight, Vec3::ONE);
                for (side, inner) in [(false, &a), (true, &b)] {
                    textures.extend(inner.textures.iter().map(|t| TexSlot {
                        path: [side].into_iter().chain(t.path.iter().copied()).collect(),
                        ..t.clone()
                    }));
                }
                let kind = BsdfKind::Blend {
                    weight,
                    a: Box::new(a.kind),
                    b: Box::new(b.kind),
                };
                (kind, twosided)
            }
            "bumpmap" | "normalmap" => {
                let inner = self.nested_bsdfs(&obj)?;
                let Some(first) = inner.into_iter().next() else {
                    return Err(s.err(c, format!("bsdf '{ty}' needs a nested bsdf")));
                };
                let rules = BumpRules {
                    flip: obj.boolean("flip_invalid_normals", true)?,
                    shadowing: obj.boolean("use_shadowing_function", true)?,
                };
                let (field, scale, name) = if ty == "bumpmap" {
                    let scale = obj.float("scale")?.unwrap_or(1.0);
                    if !scale.is_finite() {
                        return Err(obj.err_param("scale", format!("= {scale} is not a number")));
                    }
                    let name = obj.any_texture().map(|(p, _)| p.name.clone());
                    (TexField::Bump(rules), scale, name)
                } else {
                    (TexField::Normal(rules), 1.0, Some("normalmap".to_string()))
                };
                let image = name.as_deref().and_then(|n| obj.texture_image(n));
                match image {
                    Some(texture) => {
                        textures = first.textures.clone();
                        textures.push(TexSlot {
                            path: Vec::new(),
                            field,
                            texture,
                            factor: Vec3::splat(scale),
                        });
                    }
                    None => {
                        textures = first.textures.clone();
                        self.warn(
                            s,
                            c,
                            format!("bsdf '{ty}' without a bitmap texture: its nested bsdf is used alone"),
                        );
                    }
                }
                (first.kind, first.twosided)
            }
            "mask" => {
                let inner = self.nested_bsdfs(&obj)?;
                let Some(first) = inner.into_iter().next() else {
                    return Err(s.err(c, "bsdf 'mask' needs a nested bsdf"));
                };
                // The opacity: a bitmap, or a number (a one-texel image of it).
                let texture = match obj.texture_image("opacity") {
                    Some(t) => t,
                    None => {
                        let o = obj.scalar("opacity")?.unwrap_or(0.5);
                        if !(0.0..=1.0).contains(&o) {
                            return Err(obj.err_param("opacity", format!("= {o} is outside [0, 1]")));
                        }
                        let t = crate::scene::Texture::from_linear("opacity", 1, 1, vec![[o; 3]])
                            .map_err(|m| obj.err_param("opacity", m))?;
                        self.scene.textures.push(t);
                        self.scene.textures.len() as u32 - 1
                    }
                };
                textures = first.textures.clone();
                textures.push(TexSlot {
                    path: Vec::new(),
                    field: TexField::Opacity,
                    texture,
                    factor: Vec3::ONE,
                });
                (first.kind, first.twosided)
            }
            "principled" => {
                let p = self.principled(s, c, &obj)?;
                // The base colour tints the plastic's diffuse base and the metal.
                let base = obj.texture_image("base_color");
                let metal_scale = if base.is_some() { p.base } else { Vec3::ONE };
                let coated = |diffuse_reflectance: Rgb| BsdfKind::RoughPlastic {
                    diffuse_reflectance,
                    lobe: Glossy {
                        distribution: p.distribution,
                        fresnel: Fresnel::Dielectric { eta: p.eta },
                        scale: Vec3::ONE,
                    },
                    nonlinear: false,
                    coating: Default::default(),
                    pplastic: false,
                };
                // Mitsuba's principled diffuse is not dimmed by its specular layer:
                // the plastic's base is raised so that its diffuse albedo is the base
                // colour (at most 1 per channel). Its share for a white base:
                let white = crate::scene::mean(coated(Vec3::ONE).diffuse_albedo()).max(1e-3);
                let lift = 1.0 / white;
                let plastic = coated((p.base * lift).min(Vec3::ONE));
                let metal = BsdfKind::RoughConductor {
                    lobe: Glossy {
                        distribution: p.distribution,
                        fresnel: Fresnel::Schlick {
                            f0: if base.is_some() { Vec3::ONE } else { p.base },
                        },
                        scale: metal_scale,
                    },
                };
                let blend = p.metallic_map || (p.metallic > 0.0 && p.metallic < 1.0);
                let mut maps = Vec::new();
                let mut add = |path: Vec<bool>, field: TexField, image: Option<u32>| {
                    if let Some(texture) = image {
                        maps.push(TexSlot {
                            path,
                            field,
                            texture,
                            factor: Vec3::ONE,
                        });
                    }
                };
                let kind = if blend {
                    add(vec![false], TexField::Diffuse, base);
                    add(vec![true], TexField::Specular, base);
                    add(Vec::new(), TexField::Weight, obj.texture_image("metallic"));
                    // Between: the base colour's diffuse and the metal, by `metallic`
                    // (Mitsuba's diffuse weight; its specular Fresnel, which mixes the
                    // dielectric's few per cent in, is the metal's alone here: a blend
                    // renders one glossy lobe).
                    BsdfKind::Blend {
                        weight: p.metallic,
                        a: Box::new(BsdfKind::Diffuse { reflectance: p.base }),
                        b: Box::new(metal),
                    }
                } else if p.metallic >= 1.0 {
                    add(Vec::new(), TexField::Specular, base);
                    metal
                } else {
                    add(Vec::new(), TexField::Diffuse, base);
                    for m in &mut maps {
                        m.factor = Vec3::splat(lift);
                    }
                    plastic
                };
                textures.extend(maps);
                (kind, false)
            }
            "principledthin" => {
                obj.mark_all();
                let reflectance = obj.reflectance("base_color", 0.5)?;
                slot("base_color", TexField::Diffuse, Vec3::ONE);
                self.warn(
                    s,
                    c,
                    format!("bsdf '{ty}' is not supported: rendered as diffuse with its base_color"),
                );
                (BsdfKind::Diffuse { reflectance }, false)
            }
            "null" => {
                // An invisible surface (see `Loader::shape`); black where an
                // emitter keeps it.
                if let Some(id) = self.attr(s, c, "id")? {
                    self.null_bsdfs.insert(id);
                }
                (
                    BsdfKind::Diffuse {
                        reflectance: Vec3::ZERO,
                    },
                    false,
                )
            }
            t => {
                obj.mark_all();
                self.warn(
                    s,
                    c,
                    format!("bsdf '{t}' is not supported: rendered as diffuse 0.5"),
                );
                (Bsdf::default().kind, false)
            }
        };
        self.finish(&obj);
        let id = self.attr(s, c, "id")?;
        let b = Bsdf {
            name: id.unwrap_or(ty),
            kind,
            twosided,
            textures,
        };
        self.register(s, c, Target::Bsdf(b.clone()))?;
        Ok(b)
    }

    fn rough(&mut self, s: Src, c: Node, ty: &str, smooth: &str) {
        self.warn(
            s,
            c,
            format!("bsdf '{ty}' is rendered as the smooth '{smooth}' (roughness ignored)"),
        );
    }

    /// A rough conductor's lobe (Mitsuba 3's `roughconductor`: `distribution`
    /// `beckmann` (the default) or `ggx`, `alpha` or `alpha_u`/`alpha_v` (0.1), the
    /// Fresnel term from `eta`/`k` or a named `material`, `specular_reflectance`;
    /// Mitsuba 0.6's `ext_eta` divides both).
    fn rough_conductor(&mut self, s: Src, c: Node, obj: &Obj) -> Result<Glossy> {
        let distribution = self.microfacet(s, obj)?;
        let scale = obj.reflectance("specular_reflectance", 1.0)?;
        let fresnel = Self::conductor_fresnel(s, c, obj)?;
        Ok(Glossy {
            distribution,
            fresnel,
            scale,
        })
    }

    /// The microfacet distribution of `roughconductor` and `roughdielectric`
    /// (`distribution`, `alpha` or `alpha_u`/`alpha_v`, 0.1 by default). An
    /// anisotropic lobe's `alpha_u` lies along the surface's dp/du, as in Mitsuba
    /// ([`crate::interaction::SurfacePoint::dpdu`]).
    fn microfacet(&mut self, s: Src, obj: &Obj) -> Result<Microfacet> {
        self.roughness_maps(s, obj, &ALPHAS);
        let (beckmann, [alpha, u, v]) = distribution(obj)?;
        let (alpha_u, alpha_v) = match alpha {
            Some(a) => (a, a),
            None => (u.unwrap_or(0.1), v.unwrap_or(0.1)),
        };
        Ok(Microfacet {
            alpha_u,
            alpha_v,
            beckmann,
        })
    }

    /// Warns of a roughness (parameters `names`) given by a texture: the lobe takes
    /// its mean, the same everywhere.
    fn roughness_maps(&mut self, s: Src, obj: &Obj, names: &[&str]) {
        for &name in names {
            let Some(p) = obj.get(name) else { continue };
            if let Val::Texture(t) = p.val {
                // Warned about here, not again by `finish`.
                p.textured.set(true);
                let mean = t
                    .mean
                    .map_or(String::new(), |m| format!(" ({:.3})", m.element_sum() / 3.0));
                let node = p.node;
                self.warn(
                    s,
                    node,
                    format!("a texture as '{name}': the roughness is its mean{mean} everywhere"),
                );
            }
        }
    }

    /// Mitsuba 3's `principled` (Burley's model), read as a blend by `metallic` of a
    /// rough plastic (its diffuse `base_color` under a GGX coating of index `eta`, or
    /// that which `specular` gives, 2 / (1 - sqrt(0.08 specular)) - 1) and a rough
    /// metal (Schlick's curve from `base_color`), both of GGX roughness `roughness`
    /// squared (`anisotropic` stretches it as Mitsuba does). Its sheen, clearcoat,
    /// transmission and specular tint are not rendered: a warning where they are
    /// non-zero. Textures: `base_color` and `metallic` per point, `roughness` by its
    /// mean (a warning).
    fn principled(&mut self, s: Src, c: Node, obj: &Obj) -> Result<Principled> {
        let base = obj.reflectance("base_color", 0.5)?;
        let unit = |name: &str, default: f32| -> Result<f32> {
            let v = obj.scalar(name)?.unwrap_or(default);
            if !(0.0..=1.0).contains(&v) {
                return Err(obj.err_param(name, format!("= {v} is outside [0, 1]")));
            }
            Ok(v)
        };
        self.roughness_maps(s, obj, &["roughness"]);
        let roughness = unit("roughness", 0.5)?;
        let metallic = unit("metallic", 0.0)?;
        let metallic_map = obj.texture_image("metallic").is_some();
        let anisotropic = unit("anisotropic", 0.0)?;
        let specular = obj.scalar("specular")?.unwrap_or(0.5);
        if !(0.0..12.5).contains(&specular) {
            return Err(obj.err_param("specular", format!("= {specular} must be in [0, 12.5)")));
        }
        let eta = match obj.scalar("eta")? {
            Some(e) if e > 0.0 && e.is_finite() => e,
            Some(e) => return Err(obj.err_param("eta", format!("= {e} must be positive"))),
            None => 2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0,
        };
        let mut ignored = Vec::new();
        for name in [
            "spec_trans",
            "clearcoat",
            "sheen",
            "spec_tint",
            "diff_trans",
            "flatness",
        ] {
            if obj.scalar(name)?.is_some_and(|v| v != 0.0) {
                ignored.push(name);
            }
        }
        for name in [
            "clearcoat_gloss",
            "sheen_tint",
            "main_specular_sampling_rate",
            "clearcoat_sampling_rate",
            "diffuse_reflectance_sampling_rate",
            "spec_srate",
            "clearcoat_srate",
            "diff_refl_srate",
        ] {
            obj.get(name);
        }
        if !ignored.is_empty() {
            self.warn(
                s,
                c,
                format!(
                    "bsdf 'principled': {} not rendered (its diffuse base, metal and specular \
                     lobe are)",
                    ignored.join(", ")
                ),
            );
        }
        // Mitsuba's principled: alpha = roughness^2 (at least 1e-3), stretched by the
        // aspect sqrt(1 - 0.9 anisotropic).
        let aspect = (1.0 - 0.9 * anisotropic).sqrt();
        let a = roughness * roughness;
        Ok(Principled {
            base,
            metallic,
            metallic_map,
            eta,
            distribution: Microfacet {
                alpha_u: (a / aspect).max(1e-3),
                alpha_v: (a * aspect).max(1e-3),
                beckmann: false,
            },
        })
    }

    /// A conductor's Fresnel term, as `conductor` and `roughconductor` read it: from
    /// `eta` and `k` per channel, or those of a named `material` as Mitsuba 3's RGB
    /// variants read them (Mitsuba 0.6's `ext_eta` divides both), or 1 for `none`,
    /// the default. A name Mitsuba has no data for fails, as in Mitsuba.
    fn conductor_fresnel(s: Src, c: Node, obj: &Obj) -> Result<Fresnel> {
        let ext = match obj.scalar("ext_eta")? {
            Some(e) if e > 0.0 => e,
            Some(e) => return Err(obj.err_param("ext_eta", format!("= {e} must be positive"))),
            None => 1.0,
        };
        let material = obj.string("material")?;
        if obj.get("eta").is_some() || obj.get("k").is_some() {
            if material.as_deref().is_some_and(|m| m != "none") {
                return Err(s.err(
                    c,
                    format!("{}: give either 'material' or 'eta'/'k', not both", obj.what),
                ));
            }
            return Ok(Fresnel::Conductor {
                eta: obj.nonnegative("eta", 0.0)? / ext,
                k: obj.nonnegative("k", 1.0)? / ext,
            });
        }
        Ok(match material.as_deref().unwrap_or("none") {
            "none" => Fresnel::Schlick { f0: Vec3::ONE },
            m => {
                let (eta, k) = parse::conductor_ior(m).ok_or_else(|| {
                    obj.err_param(
                        "material",
                        format!(
                            "= '{m}' is not a conductor Mitsuba knows (e.g. 'Au', 'Cu', 'Al', 'Ag', 'Cr')"
                        ),
                    )
                })?;
                Fresnel::Conductor {
                    eta: eta / ext,
                    k: k / ext,
                }
            }
        })
    }

    /// A smooth conductor: a mirror of `specular_reflectance` times its Fresnel term
    /// at the angle of incidence, as Mitsuba 3's `conductor`.
    fn conductor(&mut self, s: Src, c: Node, obj: &Obj) -> Result<BsdfKind> {
        let specular_reflectance = obj.reflectance("specular_reflectance", 1.0)?;
        let fresnel = Self::conductor_fresnel(s, c, obj)?;
        Ok(BsdfKind::Conductor {
            specular_reflectance,
            fresnel,
        })
    }

    /// The nested bsdfs (elements or refs) of `obj`, in order; other nested
    /// elements are warned about.
    fn nested_bsdfs(&mut self, obj: &Obj) -> Result<Vec<Bsdf>> {
        let mut out = Vec::new();
        for ch in &obj.children {
            match ch {
                Child::Elem(n) if tag(*n) == "bsdf" => out.push(self.bsdf(obj.src, *n)?),
                Child::Ref {
                    target: Target::Bsdf(b),
                    ..
                } => out.push(b.clone()),
                Child::Ref { node, id, target } => {
                    return Err(obj.src.err_attr(
                        *node,
                        "id",
                        format!("id '{id}' names a {}, not a bsdf", target.kind()),
                    ))
                }
                Child::Elem(n) => {
                    let msg = format!("<{}> inside {} ignored", tag(*n), obj.what);
                    self.warn(obj.src, *n, msg);
                }
            }
        }
        Ok(out)
    }

    /// The index of `b` in the scene's BSDFs (one entry per id).
    pub(super) fn add_bsdf(&mut self, b: Bsdf, id: Option<&str>) -> u32 {
        if let Some(i) = id.and_then(|id| self.bsdf_index.get(id)) {
            return *i;
        }
        let i = self.scene.bsdfs.len() as u32;
        match id {
            Some(id) => {
                self.bsdf_index.insert(id.to_string(), i);
                self.scene.bsdfs.push(b);
            }
            None => self.scene.bsdfs.push(Bsdf {
                name: format!("{}#{i}", b.name),
                ..b
            }),
        }
        i
    }

    /// The material of a shape that names none: Mitsuba's default, a diffuse of
    /// reflectance 0.5, or, on an area emitter (`emitter`), a black one (Mitsuba 3
    /// gives an emitting shape without a BSDF reflectance 0). One of each, shared.
    pub(super) fn default_bsdf(&mut self, emitter: bool) -> u32 {
        let k = usize::from(emitter);
        if let Some(i) = self.default_bsdf[k] {
            return i;
        }
        let i = self.scene.bsdfs.len() as u32;
        let mut b = Bsdf::default();
        if emitter {
            b.name = "default-emitter".into();
            b.kind = BsdfKind::Diffuse {
                reflectance: Vec3::ZERO,
            };
        }
        self.scene.bsdfs.push(b);
        self.default_bsdf[k] = Some(i);
        i
    }
}

/// What a `principled` material is read as ([`Loader::principled`]).
struct Principled {
    base: Rgb,
    metallic: f32,
    /// `metallic` is a texture (its mean above).
    metallic_map: bool,
    eta: f32,
    distribution: Microfacet,
}

/// A rough plastic's distribution of normals (Mitsuba 3's `roughplastic`:
/// `distribution` `beckmann` (the default) or `ggx`, one positive `alpha` (0.1;
/// `alpha_u` and `alpha_v` only if equal: the model is isotropic),
/// `sample_visible` accepted).
fn rough_plastic(obj: &Obj) -> Result<Microfacet> {
    let (beckmann, [alpha, u, v]) = distribution(obj)?;
    let alpha = match alpha {
        Some(a) => a,
        None => {
            if u != v {
                return Err(obj.err_param(
                    if u.is_some() { "alpha_u" } else { "alpha_v" },
                    "differs from the other: 'roughplastic' is isotropic (give one 'alpha')",
                ));
            }
            u.unwrap_or(0.1)
        }
    };
    Ok(Microfacet {
        alpha_u: alpha,
        alpha_v: alpha,
        beckmann,
    })
}

/// A microfacet distribution's parameters as the rough plugins read them:
/// `distribution` (`beckmann`, the default, or `ggx`: Beckmann or not) and
/// `alpha`, `alpha_u`, `alpha_v` where given (positive; as in Mitsuba, no less than
/// 1e-4); `sample_visible` accepted.
fn distribution(obj: &Obj) -> Result<(bool, [Option<f32>; 3])> {
    let beckmann = match obj.string("distribution")?.as_deref().unwrap_or("beckmann") {
        "beckmann" => true,
        "ggx" => false,
        d => return Err(obj.err_param("distribution", format!("= '{d}' is not 'beckmann' or 'ggx'"))),
    };
    obj.get("sample_visible");
    let rough = |name: &str| -> Result<Option<f32>> {
        match obj.scalar(name)? {
            Some(a) if !(a.is_finite() && a > 0.0) => {
                Err(obj.err_param(name, format!("= {a} must be a positive roughness")))
            }
            a => Ok(a.map(|a| a.max(1e-4))),
        }
    };
    Ok((beckmann, [rough("alpha")?, rough("alpha_u")?, rough("alpha_v")?]))
}

/// An index of refraction: a number or one of Mitsuba's named materials.
fn ior(obj: &Obj, name: &str, default: f32) -> Result<f32> {
    let v = match obj.get(name).map(|p| p.val.clone()) {
        None => default,
        Some(Val::Float(v)) => v,
        Some(Val::Int(i)) => i as f32,
        Some(Val::Rgb(c)) => c.element_sum() / 3.0,
        Some(Val::Str(t)) => parse::named_ior(&t).ok_or_else(|| {
            obj.err_param(
                name,
                format!("= '{t}' is not a known material (e.g. 'bk7', 'acrylic glass', 'air')"),
            )
        })?,
        Some(v) => return Err(obj.err_param(name, format!("must be a number or a name, not {}", v.kind()))),
    };
    if v <= 0.0 {
        return Err(obj.err_param(name, format!("= {v} must be positive")));
    }
    Ok(v)
}
