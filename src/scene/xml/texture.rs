//! Colours: reflectance and emission values (`<rgb>`, `<spectrum>`, a grey
//! `<float>`, a `<texture>`): spectra as the colours Mitsuba 3's RGB modes make of
//! them, textures as images or, where one colour must do, their mean.

use std::path::{Path, PathBuf};

use glam::{Affine2, Vec3};
use rayon::prelude::*;
use roxmltree::Node;

use super::document::{child_value as child, read_text, tag, Loader, Src};
use super::parse;
use super::properties::{Obj, Prop, Target, TexVal, Val};
use crate::error::{Error, Pos};
use crate::scene::spectrum::{self, Quantity};
use crate::scene::texture::{TexFilter, TexWrap, Texture};
use crate::scene::{luminance, mean, Rgb};
use crate::Result;

impl<'a, 'i> Obj<'a, 'i> {
    /// A colour: `<rgb>`, `<spectrum>`, a grey `<float>`, or a texture.
    fn color(&self, name: &str, default: f32) -> Result<Rgb> {
        match self.get(name) {
            None => Ok(Vec3::splat(default)),
            Some(p) => match p.val {
                Val::Rgb(c) => Ok(c),
                Val::Float(v) => Ok(Vec3::splat(v)),
                Val::Int(i) => Ok(Vec3::splat(i as f32)),
                Val::Texture(t) => Ok(t.mean.unwrap_or(Vec3::splat(default))),
                _ => Err(self.mismatch(p, "a colour (rgb, spectrum or float)")),
            },
        }
    }

    /// A reflectance: a colour with every channel in `[0, 1]`.
    pub(super) fn reflectance(&self, name: &str, default: f32) -> Result<Rgb> {
        let c = self.color(name, default)?;
        for (k, ch) in ["r", "g", "b"].into_iter().enumerate() {
            if !(0.0..=1.0).contains(&c[k]) {
                return Err(self.err_param(name, format!("channel {ch} = {} is outside [0, 1]", c[k])));
            }
        }
        Ok(c)
    }

    /// A colour with no negative channel (an index of refraction, an absorption).
    pub(super) fn nonnegative(&self, name: &str, default: f32) -> Result<Rgb> {
        let c = self.color(name, default)?;
        if c.min_element() < 0.0 {
            return Err(self.err_param(name, format!("is negative ({c})")));
        }
        Ok(c)
    }

    /// A radiance or intensity: a colour with no negative channel (1 by default).
    pub(super) fn emission(&self, name: &str) -> Result<Rgb> {
        self.nonnegative(name, 1.0)
    }

    /// A scalar that Mitsuba reads as a texture (`weight`), as its `eval_1` reads it: a
    /// float, a colour's mean (an `rgb` of (1, 0, 0) weighs 1/3), or the luminance of
    /// a bitmap's mean.
    pub(super) fn scalar(&self, name: &str) -> Result<Option<f32>> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => match p.val {
                Val::Float(v) => Ok(Some(v)),
                Val::Int(i) => Ok(Some(i as f32)),
                Val::Rgb(c) => Ok(Some(mean(c))),
                Val::Texture(TexVal { mean: Some(c), .. }) => Ok(Some(luminance(c))),
                Val::Texture(TexVal { mean: None, .. }) => Ok(None),
                _ => Err(self.mismatch(p, "a float")),
            },
        }
    }
}

/// Mitsuba 0.6's mipmapped bitmap filters (its default was `ewa`, anisotropic), which
/// Mitsuba 3 no longer has: read from a mipmap ([`TexFilter::Trilinear`]).
const MIPMAPPED: [&str; 2] = ["trilinear", "ewa"];

/// A Mitsuba 0.6 bitmap's `gamma` that reads its bytes as linear (their bump maps'
/// 1.0); -1 or 2.2 is sRGB, as there.
fn linear_gamma(g: f32) -> bool {
    (g - 1.0).abs() < 1e-6
}

impl Obj<'_, '_> {
    /// The image texture that gives parameter `name`, if one does (its index in the
    /// scene's textures).
    pub(super) fn texture_image(&self, name: &str) -> Option<u32> {
        let p = self.get(name)?;
        p.textured.set(true);
        match p.val {
            Val::Texture(t) => t.image,
            _ => None,
        }
    }
}

impl<'a, 'i> Obj<'a, 'i> {
    /// The first texture among the parameters, whatever its name (a `bumpmap`'s).
    pub(super) fn any_texture(&self) -> Option<(&Prop<'a, 'i>, TexVal)> {
        let (p, t) = self.props().find_map(|p| match p.val {
            Val::Texture(t) => Some((p, t)),
            _ => None,
        })?;
        p.textured.set(true);
        Some((p, t))
    }
}

impl Loader {
    /// `<spectrum>`: one value, wavelength:value pairs, a file of them, or a
    /// spectrum plugin (`type`), as the colour Mitsuba 3's RGB modes make of it
    /// ([`spectrum`]): what the colour is of (a reflectance, an emitter's radiance,
    /// an index of refraction) decides how it is weighed and clamped.
    pub(super) fn spectrum(&mut self, s: Src, c: Node) -> Result<Val> {
        let name = c.attribute("name").unwrap_or_default();
        let name = if s.legacy {
            parse::snake_case(name)
        } else {
            name.to_string()
        };
        let in_emitter = c.parent_element().is_some_and(|p| tag(p) == "emitter");
        let quantity = Quantity::of(&name, in_emitter);
        if c.attribute("type").is_some() {
            return self.spectrum_plugin(s, c, quantity);
        }
        self.check_attrs(s, c, &["name", "value", "filename"]);
        let value = self.attr(s, c, "value")?;
        let file = self.attr(s, c, "filename")?;
        let pairs: Vec<(f32, f32)> = match (value, file) {
            (Some(v), None) => {
                let toks = parse::tokens(&v);
                let at = |m: String| s.err_attr(c, "value", format!("<spectrum>: {m}"));
                if toks.len() == 1 && !toks[0].contains(':') {
                    let v = parse::number(toks[0]).map_err(at)?;
                    return Ok(Val::Rgb(spectrum::flat(v, quantity)));
                }
                let mut out = Vec::new();
                for t in toks {
                    let Some((w, val)) = t.split_once(':') else {
                        return Err(at(format!(
                            "expected one value or wavelength:value pairs, found '{t}'"
                        )));
                    };
                    out.push((parse::number(w).map_err(at)?, parse::number(val).map_err(at)?));
                }
                out
            }
            (None, Some(f)) => {
                let path = self.resolve(s, &f);
                let text = read_text(&path)?;
                let mut out = Vec::new();
                for (k, line) in text.lines().enumerate() {
                    let line = line.split('#').next().unwrap_or("").trim();
                    if line.is_empty() {
                        continue;
                    }
                    let nums = parse::numbers(line)
                        .ok()
                        .filter(|n| n.len() == 2)
                        .ok_or_else(|| {
                            Error::input(
                                &path,
                                Some(Pos {
                                    line: k as u32 + 1,
                                    col: 0,
                                }),
                                "expected 'wavelength value'",
                            )
                        })?;
                    out.push((nums[0], nums[1]));
                }
                out
            }
            _ => return Err(s.err(c, "<spectrum> needs exactly one of 'value' and 'filename'")),
        };
        self.spectrum_colour(s, c, &pairs, quantity).map(Val::Rgb)
    }

    /// The colour of a spectrum given by `(wavelength, value)` pairs, with a warning
    /// where it is out of gamut (clamped, as Mitsuba clamps it).
    fn spectrum_colour(&mut self, s: Src, c: Node, pairs: &[(f32, f32)], quantity: Quantity) -> Result<Rgb> {
        let Some(colour) = spectrum::colour(pairs, quantity) else {
            return Err(s.err(
                c,
                format!(
                    "<spectrum> needs at least two wavelength:value pairs with increasing wavelengths (found {})",
                    pairs.iter().map(|(w, v)| format!("{w}:{v}")).collect::<Vec<_>>().join(", ")
                ),
            ));
        };
        if colour.clamped {
            self.warn(
                s,
                c,
                format!(
                    "<spectrum> is outside sRGB's gamut: clamped to ({}, {}, {})",
                    colour.rgb.x, colour.rgb.y, colour.rgb.z
                ),
            );
        }
        Ok(colour.rgb)
    }

    /// `<spectrum type="...">`: Mitsuba 3's spectrum plugins in its RGB modes
    /// (`uniform`, `d65`, `srgb`), and `regular` and `irregular`, which those modes
    /// reject, taken as their wavelength:value pairs would be.
    fn spectrum_plugin(&mut self, s: Src, c: Node, quantity: Quantity) -> Result<Val> {
        self.check_attrs(s, c, &["type", "name", "id"]);
        let ty = self.attr_req(s, c, "type")?;
        let obj = self.collect(s, c, format!("spectrum '{ty}'"))?;
        let numbers = |name: &str| -> Result<Vec<f32>> {
            let v = obj
                .string(name)?
                .ok_or_else(|| obj.err_param(name, "is missing"))?;
            parse::numbers(&v).map_err(|m| obj.err_param(name, format!("= '{v}': {m}")))
        };
        let rgb = match ty.as_str() {
            "uniform" => Vec3::splat(obj.float("value")?.unwrap_or(1.0)),
            "d65" => obj.color("color", 1.0)? * obj.float("scale")?.unwrap_or(1.0),
            "srgb" => obj.color("color", 1.0)?,
            "regular" | "irregular" => {
                let values = numbers("values")?;
                let wavelengths = if ty == "regular" {
                    let lo = obj.float("wavelength_min")?.ok_or_else(|| obj.err_param("wavelength_min", "is missing"))?;
                    let hi = obj.float("wavelength_max")?.ok_or_else(|| obj.err_param("wavelength_max", "is missing"))?;
                    let n = values.len().max(2) - 1;
                    (0..values.len()).map(|i| lo + (hi - lo) * i as f32 / n as f32).collect()
                } else {
                    numbers("wavelengths")?
                };
                if wavelengths.len() != values.len() {
                    return Err(obj.err_param(
                        "values",
                        format!("has {} values for {} wavelengths", values.len(), wavelengths.len()),
                    ));
                }
                if let Some(n) = obj.int("size")? {
                    if n != values.len() as i64 {
                        return Err(obj.err_param("size", format!("= {n}, but {} values are given", values.len())));
                    }
                }
                let pairs: Vec<(f32, f32)> = wavelengths.into_iter().zip(values).collect();
                self.spectrum_colour(s, c, &pairs, quantity)?
            }
            "blackbody" => {
                return Err(s.err(
                    c,
                    "spectrum 'blackbody' needs spectral rendering (Mitsuba 3's RGB modes reject it too): give the colour as <rgb>",
                ))
            }
            t => {
                return Err(s.err_attr(
                    c,
                    "type",
                    format!("unknown spectrum type '{t}' (radtrace reads uniform, d65, srgb, regular and irregular)"),
                ))
            }
        };
        self.finish(&obj);
        Ok(Val::Rgb(rgb))
    }

    /// A `<texture>`: an image (`bitmap`), or one reduced to one colour when that
    /// makes sense.
    pub(super) fn texture(&mut self, s: Src, c: Node) -> Result<TexVal> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let obj = self.collect(s, c, format!("texture '{ty}'"))?;
        let v = match ty.as_str() {
            "bitmap" => {
                let t = self.bitmap(&obj)?;
                self.finish(&obj);
                t
            }
            "checkerboard" => {
                let t = self.checkerboard(&obj)?;
                self.finish(&obj);
                t
            }
            t => {
                obj.mark_all();
                self.warn(
                    s,
                    c,
                    format!("texture '{t}' is not supported: the parameter keeps its default"),
                );
                TexVal {
                    mean: None,
                    image: None,
                }
            }
        };
        self.register(s, c, Target::Texture(v))?;
        Ok(v)
    }

    /// A `bitmap` texture (Mitsuba 3's parameters: `filename`, `filter_type`,
    /// `wrap_mode`, `raw`, `to_uv`), added to the scene's textures; one file read
    /// once however many bitmaps name it with the same settings.
    fn bitmap(&mut self, obj: &Obj) -> Result<TexVal> {
        let (path, fname) = self.file_param(obj, "filename")?;
        let raw = obj.boolean("raw", false)?;
        let filter = match obj.string("filter_type")?.as_deref().unwrap_or("bilinear") {
            "bilinear" => TexFilter::Bilinear,
            "nearest" => TexFilter::Nearest,
            // Read from a mipmap over the camera rays' footprints.
            f if obj.src.legacy && MIPMAPPED.contains(&f) => TexFilter::Trilinear,
            f => return Err(obj.err_param("filter_type", format!("= '{f}' is not 'bilinear' or 'nearest'"))),
        };
        let wrap = match obj.string("wrap_mode")?.as_deref().unwrap_or("repeat") {
            "repeat" => TexWrap::Repeat,
            "mirror" => TexWrap::Mirror,
            "clamp" => TexWrap::Clamp,
            w => {
                return Err(obj.err_param(
                    "wrap_mode",
                    format!("= '{w}' is not 'repeat', 'mirror' or 'clamp'"),
                ))
            }
        };
        let to_uv = to_uv(obj)?;
        // Mitsuba 0.6 files may still say `gamma`.
        let raw = obj.float("gamma")?.is_some_and(linear_gamma) || raw;
        let key = (path.clone(), raw);
        let i = match self.images.get(&key) {
            Some(&base) => {
                let textures = &mut self.scene.textures;
                let first = &textures[base as usize];
                if first.filter == filter && first.wrap == wrap && first.to_uv == to_uv {
                    base
                } else {
                    let mut t = first.clone();
                    (t.filter, t.wrap, t.to_uv) = (filter, wrap, to_uv);
                    if filter == TexFilter::Trilinear {
                        t.build_mipmap();
                    }
                    textures.push(t);
                    textures.len() as u32 - 1
                }
            }
            None => {
                let mut t = self
                    .image(&path, raw)
                    .map_err(|m| obj.err_param("filename", format!("= '{fname}': {m}")))?;
                (t.filter, t.wrap, t.to_uv) = (filter, wrap, to_uv);
                if filter == TexFilter::Trilinear {
                    t.build_mipmap();
                }
                self.scene.textures.push(t);
                let i = self.scene.textures.len() as u32 - 1;
                self.images.insert(key, i);
                i
            }
        };
        let t = &self.scene.textures[i as usize];
        Ok(TexVal {
            mean: Some(t.mean),
            image: Some(i),
        })
    }

    /// The image file at `path` as a texture (8-bit values sRGB-encoded unless
    /// `raw`): read ahead, or read now.
    pub(super) fn image(&mut self, path: &Path, raw: bool) -> std::result::Result<Texture, String> {
        self.read_ahead
            .remove(&(path.to_path_buf(), raw))
            .unwrap_or_else(|| Texture::load(path, raw))
    }

    /// Reads the image files that the `bitmap` textures and `envmap` emitters of
    /// file `s` name, all at once and in parallel, before the walk (which meets
    /// them one after another) takes them. Decoding them is most of the time a
    /// textured scene takes to load (the wooden staircase: 12 JPEGs, 0.83 s to
    /// load one at a time). Only names without `$` parameters are read ahead, with
    /// `raw` and the 0.6 files' `gamma` as written there; the walk reads whatever
    /// else it needs, and errors are reported where the walk meets them.
    pub(super) fn read_images_ahead(&mut self, s: Src) {
        let mut want: Vec<((PathBuf, bool), bool)> = Vec::new();
        for n in s.doc.descendants().filter(Node::is_element) {
            let raw = match (tag(n), n.attribute("type")) {
                ("texture", Some("bitmap")) => {
                    child(n, "boolean", &["raw"]).is_some_and(|v| parse::boolean(v) == Ok(true))
                        || child(n, "float", &["gamma"])
                            .is_some_and(|v| parse::number(v).is_ok_and(linear_gamma))
                }
                ("emitter", Some("envmap")) => false,
                _ => continue,
            };
            let Some(name) = child(n, "string", &["filename"]).filter(|f| !f.contains('$')) else {
                continue;
            };
            let mips = s.legacy
                && child(n, "string", &["filter_type", "filterType"]).is_some_and(|f| MIPMAPPED.contains(&f));
            let key = (self.resolve(s, name), raw);
            if key.0.is_file()
                && !self.images.contains_key(&key)
                && !self.read_ahead.contains_key(&key)
                && !want.iter().any(|(k, _)| *k == key)
            {
                want.push((key, mips));
            }
        }
        let read: Vec<_> = want
            .par_iter()
            .map(|((path, raw), mips)| {
                let mut t = Texture::load(path, *raw)?;
                if *mips {
                    t.build_mipmap();
                }
                Ok(t)
            })
            .collect();
        self.read_ahead.extend(want.into_iter().map(|(k, _)| k).zip(read));
    }

    /// Mitsuba's `checkerboard` (`color0`, 0.4, and `color1`, 0.2, `to_uv`): in each unit
    /// square of (u, v), `color0` where u and v are both below or both above one half,
    /// `color1` elsewhere. That is exactly a 2 x 2 image looked up by nearest texel and
    /// repeated, which is what it becomes (a colour given as a texture takes its mean).
    fn checkerboard(&mut self, obj: &Obj) -> Result<TexVal> {
        let (c0, c1) = (obj.color("color0", 0.4)?, obj.color("color1", 0.2)?);
        let (a, b) = (c0.to_array(), c1.to_array());
        let mut t = Texture::from_linear("checkerboard", 2, 2, vec![a, b, b, a])
            .map_err(|m| obj.err_param("color0", m))?;
        (t.filter, t.wrap, t.to_uv) = (TexFilter::Nearest, TexWrap::Repeat, to_uv(obj)?);
        let mean = t.mean;
        self.scene.textures.push(t);
        Ok(TexVal {
            mean: Some(mean),
            image: Some(self.scene.textures.len() as u32 - 1),
        })
    }
}

/// A texture's `to_uv`: the 2D part of the 4x4 transform (x and y, the translation in
/// the last column); the identity without one.
fn to_uv(obj: &Obj) -> Result<Affine2> {
    Ok(match obj.transform("to_uv")? {
        Some(m) => Affine2::from_cols(
            m.x_axis.truncate().truncate(),
            m.y_axis.truncate().truncate(),
            m.w_axis.truncate().truncate(),
        ),
        None => Affine2::IDENTITY,
    })
}
