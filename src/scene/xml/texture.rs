//! Colours: reflectance and emission values (`<rgb>`, `<spectrum>`, a grey
//! `<float>`, a `<texture>`), spectra and textures, each reduced to one RGB colour.

use glam::Vec3;
use roxmltree::Node;

use super::document::{read_text, Loader, Src};
use super::parse;
use super::properties::{Obj, Target, Val};
use crate::error::{Error, Pos};
use crate::scene::Rgb;
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
                Val::Texture(t) => Ok(t.unwrap_or(Vec3::splat(default))),
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

    /// A radiance or intensity: a colour with no negative channel.
    pub(super) fn emission(&self, name: &str) -> Result<Rgb> {
        let c = self.color(name, 1.0)?;
        if c.min_element() < 0.0 {
            return Err(self.err_param(name, format!("is negative ({c})")));
        }
        Ok(c)
    }

    /// A scalar that Mitsuba reads as a texture (`weight`): a float, or the mean of a
    /// colour or texture.
    pub(super) fn scalar(&self, name: &str) -> Result<Option<f32>> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => match p.val {
                Val::Float(v) => Ok(Some(v)),
                Val::Int(i) => Ok(Some(i as f32)),
                Val::Rgb(c) | Val::Texture(Some(c)) => Ok(Some(c.element_sum() / 3.0)),
                Val::Texture(None) => Ok(None),
                _ => Err(self.mismatch(p, "a float")),
            },
        }
    }
}

impl Loader {
    /// `<spectrum>`: a uniform value; wavelength:value pairs or a file become their
    /// mean, with a warning.
    pub(super) fn spectrum(&mut self, s: Src, c: Node) -> Result<Val> {
        self.check_attrs(s, c, &["name", "value", "filename"]);
        let value = self.attr(s, c, "value")?;
        let file = self.attr(s, c, "filename")?;
        let values: Vec<f32> = match (value, file) {
            (Some(v), None) => {
                let toks = parse::tokens(&v);
                let at = |m: String| s.err_attr(c, "value", format!("<spectrum>: {m}"));
                if toks.len() == 1 && !toks[0].contains(':') {
                    return Ok(Val::Rgb(Vec3::splat(parse::number(toks[0]).map_err(at)?)));
                }
                let mut out = Vec::new();
                for t in toks {
                    let Some((_, val)) = t.split_once(':') else {
                        return Err(at(format!(
                            "expected one value or wavelength:value pairs, found '{t}'"
                        )));
                    };
                    out.push(parse::number(val).map_err(at)?);
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
                    out.push(nums[1]);
                }
                out
            }
            _ => return Err(s.err(c, "<spectrum> needs exactly one of 'value' and 'filename'")),
        };
        if values.is_empty() {
            return Err(s.err(c, "<spectrum> has no values"));
        }
        let mean = values.iter().sum::<f32>() / values.len() as f32;
        self.warn(
            s,
            c,
            format!("non-uniform <spectrum> replaced by its mean value {mean}"),
        );
        Ok(Val::Rgb(Vec3::splat(mean)))
    }

    /// A `<texture>`, reduced to one colour when that makes sense.
    pub(super) fn texture(&mut self, s: Src, c: Node) -> Result<Option<Rgb>> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let obj = self.collect(s, c, format!("texture '{ty}'"))?;
        obj.mark_all();
        let v = match ty.as_str() {
            "checkerboard" => {
                let mean = 0.5 * (obj.color("color0", 0.4)? + obj.color("color1", 0.2)?);
                self.warn(
                    s,
                    c,
                    format!("checkerboard texture replaced by its mean colour {mean}"),
                );
                Some(mean)
            }
            t => {
                self.warn(
                    s,
                    c,
                    format!("texture '{t}' is not supported: the parameter keeps its default"),
                );
                None
            }
        };
        self.register(s, c, Target::Texture(v))?;
        Ok(v)
    }
}
