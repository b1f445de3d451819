//! Plugin properties: their values (`<float>`, `<integer>`, `<boolean>`,
//! `<string>`, `<rgb>`, `<spectrum>`, `<point>`, `<vector>`, `<transform>`,
//! `<texture>`), `<ref>`s to earlier objects, and a plugin's properties and nested
//! objects ([`Obj`]) with the bookkeeping that finds parameters nobody asked for.

use std::cell::Cell;
use std::fmt::Display;
use std::path::PathBuf;

use glam::{Mat4, Vec3};
use roxmltree::Node;

use super::document::{tag, Loader, Src};
use super::parse;
use crate::error::Error;
use crate::scene::{Bsdf, Rgb};
use crate::Result;

/// What an `id` names.
#[derive(Debug, Clone)]
pub(super) enum Target {
    Bsdf(Bsdf),
    Texture(TexVal),
    Other(&'static str),
}

/// A `<texture>` as a parameter's value: its mean colour (`None`: the parameter keeps
/// its default) and, for an image, its index in the scene's textures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TexVal {
    pub(super) mean: Option<Rgb>,
    pub(super) image: Option<u32>,
}

impl Target {
    pub(super) fn kind(&self) -> &'static str {
        match self {
            Target::Bsdf(_) => "bsdf",
            Target::Texture(_) => "texture",
            Target::Other(k) => k,
        }
    }
}

/// A parsed property value.
#[derive(Debug, Clone)]
pub(super) enum Val {
    Float(f32),
    Int(i64),
    Bool(bool),
    Str(String),
    Rgb(Rgb),
    Vec3(Vec3),
    Transform(Mat4),
    Texture(TexVal),
}

impl Val {
    pub(super) fn kind(&self) -> &'static str {
        match self {
            Val::Float(_) => "a float",
            Val::Int(_) => "an integer",
            Val::Bool(_) => "a boolean",
            Val::Str(_) => "a string",
            Val::Rgb(_) => "a colour",
            Val::Vec3(_) => "a point/vector",
            Val::Transform(_) => "a transform",
            Val::Texture(_) => "a texture",
        }
    }
}

pub(super) struct Prop<'a, 'i> {
    pub(super) name: String,
    pub(super) val: Val,
    pub(super) node: Node<'a, 'i>,
    used: Cell<bool>,
    /// An image texture given here was taken as one (not only as its mean).
    pub(super) textured: Cell<bool>,
}

/// A nested object of a plugin: an element, or a `<ref>` already resolved.
pub(super) enum Child<'a, 'i> {
    Elem(Node<'a, 'i>),
    Ref {
        node: Node<'a, 'i>,
        id: String,
        target: Target,
    },
}

/// A plugin's properties and nested objects, with the bookkeeping that finds
/// parameters nobody asked for.
pub(super) struct Obj<'a, 'i> {
    pub(super) src: Src<'a, 'i>,
    pub(super) node: Node<'a, 'i>,
    /// E.g. "shape 'sphere'", for messages.
    pub(super) what: String,
    props: Vec<Prop<'a, 'i>>,
    pub(super) children: Vec<Child<'a, 'i>>,
}

impl<'a, 'i> Obj<'a, 'i> {
    /// The property `name`, marked as used.
    pub(super) fn get(&self, name: &str) -> Option<&Prop<'a, 'i>> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    /// Every property, each marked as used.
    pub(super) fn props(&self) -> impl Iterator<Item = &Prop<'a, 'i>> {
        self.props.iter().inspect(|p| p.used.set(true))
    }

    pub(super) fn mark_all(&self) {
        for p in &self.props {
            p.used.set(true);
        }
    }

    /// An error about parameter `name` (at its element, or at the object's).
    pub(super) fn err_param(&self, name: &str, msg: impl Display) -> Error {
        let node = self
            .props
            .iter()
            .find(|p| p.name == name)
            .map_or(self.node, |p| p.node);
        self.src
            .err(node, format!("{}: parameter '{name}' {msg}", self.what))
    }

    pub(super) fn mismatch(&self, p: &Prop, want: &str) -> Error {
        self.err_param(&p.name, format!("must be {want}, not {}", p.val.kind()))
    }

    /// Property `name` if present, as the type `pick` accepts (`want` names it in
    /// the error when the property has another type).
    fn typed<T>(&self, name: &str, want: &str, pick: impl Fn(&Val) -> Option<T>) -> Result<Option<T>> {
        match self.get(name) {
            None => Ok(None),
            Some(p) => pick(&p.val).map(Some).ok_or_else(|| self.mismatch(p, want)),
        }
    }

    pub(super) fn float(&self, name: &str) -> Result<Option<f32>> {
        self.typed(name, "a float", |v| match *v {
            Val::Float(f) => Some(f),
            Val::Int(i) => Some(i as f32),
            _ => None,
        })
    }

    pub(super) fn int(&self, name: &str) -> Result<Option<i64>> {
        self.typed(name, "an integer", |v| match *v {
            Val::Int(i) => Some(i),
            _ => None,
        })
    }

    pub(super) fn boolean(&self, name: &str, default: bool) -> Result<bool> {
        let b = self.typed(name, "a boolean", |v| match *v {
            Val::Bool(b) => Some(b),
            _ => None,
        })?;
        Ok(b.unwrap_or(default))
    }

    pub(super) fn string(&self, name: &str) -> Result<Option<String>> {
        self.typed(name, "a string", |v| match v {
            Val::Str(s) => Some(s.clone()),
            _ => None,
        })
    }

    pub(super) fn vec3(&self, name: &str) -> Result<Option<Vec3>> {
        self.typed(name, "a point", |v| match *v {
            Val::Vec3(p) => Some(p),
            _ => None,
        })
    }

    pub(super) fn transform(&self, name: &str) -> Result<Option<Mat4>> {
        self.typed(name, "a transform", |v| match *v {
            Val::Transform(m) => Some(m),
            _ => None,
        })
    }
}

impl Loader {
    /// Reads the properties and nested objects of a plugin element.
    pub(super) fn collect<'a, 'i>(
        &mut self,
        s: Src<'a, 'i>,
        node: Node<'a, 'i>,
        what: String,
    ) -> Result<Obj<'a, 'i>> {
        let mut obj = Obj {
            src: s,
            node,
            what,
            props: Vec::new(),
            children: Vec::new(),
        };
        for c in node.children().filter(Node::is_element) {
            let t = tag(c);
            match t {
                "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point" | "vector"
                | "transform" => {
                    let name = self.prop_name(s, c, node)?;
                    let val = self.value(s, c, t)?;
                    push_prop(&mut obj, name, val, c)?;
                }
                // Mitsuba 0.6's gamma-encoded colour (Mitsuba 3 has no such element).
                "srgb" if s.legacy => {
                    self.check_attrs(s, c, &["name", "value"]);
                    let name = self.prop_name(s, c, node)?;
                    let v = self.attr_req(s, c, "value")?;
                    let rgb = parse::srgb(&v).map_err(|m| s.err_attr(c, "value", format!("<srgb>: {m}")))?;
                    push_prop(&mut obj, name, Val::Rgb(rgb), c)?;
                }
                "texture" => {
                    let name = self.prop_name(s, c, node)?;
                    let v = self.texture(s, c)?;
                    push_prop(&mut obj, name, Val::Texture(v), c)?;
                }
                "ref" => {
                    self.check_attrs(s, c, &["id", "name"]);
                    let id = self.attr_req(s, c, "id")?;
                    let Some((target, _)) = self.ids.get(&id).cloned() else {
                        return Err(s.err_attr(
                            c,
                            "id",
                            format!("unknown id '{id}' (a <ref> must follow the object it names)"),
                        ));
                    };
                    match target {
                        Target::Texture(v) => {
                            if c.attribute("name").is_none() {
                                return Err(s.err(
                                    c,
                                    format!("<ref> to texture '{id}' needs a 'name' (the parameter)"),
                                ));
                            }
                            let name = self.prop_name(s, c, node)?;
                            push_prop(&mut obj, name, Val::Texture(v), c)?;
                        }
                        target => obj.children.push(Child::Ref { node: c, id, target }),
                    }
                }
                "default" => self.default(s, c)?,
                "bsdf" | "emitter" | "shape" | "sensor" | "film" | "sampler" | "rfilter" | "medium"
                | "phase" | "integrator" | "volume" => obj.children.push(Child::Elem(c)),
                "include" => self.warn(
                    s,
                    c,
                    "<include> is only supported directly inside <scene>; ignored",
                ),
                t => {
                    let what = obj.what.clone();
                    self.warn(s, c, format!("unknown element <{t}> in {what} ignored"));
                }
            }
        }
        if s.legacy {
            legacy_uv(&mut obj)?;
        }
        Ok(obj)
    }

    /// The `name` of property element `c` of plugin `owner`; in a Mitsuba 0.6 file,
    /// spelled as Mitsuba 3's upgrade spells it: snake_case, and a `diffuse` BSDF's
    /// `diffuse_reflectance` is its `reflectance`.
    fn prop_name(&self, s: Src, c: Node, owner: Node) -> Result<String> {
        let name = self.attr_req(s, c, "name")?;
        if !s.legacy {
            return Ok(name);
        }
        let name = parse::snake_case(&name);
        let diffuse = tag(owner) == "bsdf" && self.attr(s, owner, "type")?.as_deref() == Some("diffuse");
        Ok(if diffuse && name == "diffuse_reflectance" {
            "reflectance".to_string()
        } else {
            name
        })
    }

    /// Warns about the parameters `obj` did not read, and about image textures that
    /// it read only as their mean (a roughness map, a glass's transmittance map, a
    /// light's radiance): those are the same all over the surface here.
    pub(super) fn finish(&mut self, obj: &Obj) {
        for p in &obj.props {
            if !p.used.get() {
                self.warn(
                    obj.src,
                    p.node,
                    format!("unknown parameter '{}' of {} ignored", p.name, obj.what),
                );
            } else if let (
                Val::Texture(TexVal {
                    image: Some(_),
                    mean: Some(m),
                }),
                false,
            ) = (&p.val, p.textured.get())
            {
                self.warn(
                    obj.src,
                    p.node,
                    format!(
                        "{}: a texture as '{}' is not supported: its mean ({:.4}, {:.4}, {:.4}) is used all over",
                        obj.what, p.name, m.x, m.y, m.z
                    ),
                );
            }
        }
    }

    /// Parses a property element's value.
    fn value(&mut self, s: Src, c: Node, t: &str) -> Result<Val> {
        let at = |msg: String| s.err_attr(c, "value", format!("<{t}>: {msg}"));
        match t {
            "float" | "integer" | "boolean" | "string" | "rgb" => {
                self.check_attrs(s, c, &["name", "value"]);
                let v = self.attr_req(s, c, "value")?;
                Ok(match t {
                    "float" => Val::Float(parse::number(&v).map_err(at)?),
                    "integer" => Val::Int(parse::integer(&v).map_err(at)?),
                    "boolean" => Val::Bool(parse::boolean(&v).map_err(at)?),
                    "string" => Val::Str(v),
                    _ => Val::Rgb(parse::one_or_three(&v).map_err(at)?),
                })
            }
            "spectrum" => self.spectrum(s, c),
            "point" | "vector" => {
                self.check_attrs(s, c, &["name", "value", "x", "y", "z"]);
                Ok(Val::Vec3(self.xyz(s, c, 0.0)?))
            }
            _ => {
                self.check_attrs(s, c, &["name"]);
                Ok(Val::Transform(self.transform(s, c)?))
            }
        }
    }

    /// `x`/`y`/`z` attributes (missing ones take `default`) or `value` (1 or 3
    /// numbers), as Mitsuba's points, vectors and transform operations.
    pub(super) fn xyz(&self, s: Src, c: Node, default: f32) -> Result<Vec3> {
        if let Some(v) = self.attr(s, c, "value")? {
            if ["x", "y", "z"].iter().any(|a| c.attribute(*a).is_some()) {
                return Err(s.err(
                    c,
                    format!("<{}>: give either 'value' or 'x'/'y'/'z', not both", tag(c)),
                ));
            }
            return parse::one_or_three(&v).map_err(|m| s.err_attr(c, "value", format!("<{}>: {m}", tag(c))));
        }
        let mut out = Vec3::splat(default);
        for (k, a) in ["x", "y", "z"].into_iter().enumerate() {
            if let Some(v) = self.attr(s, c, a)? {
                out[k] = parse::number(&v).map_err(|m| s.err_attr(c, a, format!("<{}>: {m}", tag(c))))?;
            }
        }
        Ok(out)
    }

    /// A path parameter (`filename`) that must name an existing file.
    pub(super) fn file_param(&self, obj: &Obj, name: &str) -> Result<(PathBuf, String)> {
        let Some(fname) = obj.string(name)? else {
            return Err(obj.src.err(obj.node, format!("{}: missing '{name}'", obj.what)));
        };
        let path = self.resolve(obj.src, &fname);
        if path.is_dir() {
            return Err(obj.err_param(name, format!("= '{fname}' is a directory, not a file")));
        }
        if !path.exists() {
            return Err(obj.err_param(name, format!("= '{fname}': no such file ({})", path.display())));
        }
        Ok((path, fname))
    }
}

/// Mitsuba 0.6's `uoffset`, `voffset`, `uscale` and `vscale` of a plugin become one
/// `to_uv` transform, as Mitsuba 3's upgrade makes them: the offset, then the scale.
fn legacy_uv(obj: &mut Obj) -> Result<()> {
    const NAMES: [&str; 4] = ["uoffset", "voffset", "uscale", "vscale"];
    let mut v = [0.0, 0.0, 1.0, 1.0];
    let mut node = None;
    for (k, name) in NAMES.into_iter().enumerate() {
        let Some(i) = obj.props.iter().position(|p| p.name == name) else {
            continue;
        };
        v[k] = match obj.props[i].val {
            Val::Float(f) => f,
            Val::Int(n) => n as f32,
            _ => return Err(obj.mismatch(&obj.props[i], "a float")),
        };
        node.get_or_insert(obj.props[i].node);
        obj.props.remove(i);
    }
    let Some(node) = node else {
        return Ok(());
    };
    push_prop(obj, "to_uv".to_string(), Val::Transform(legacy_to_uv(v)), node)
}

/// The `to_uv` of Mitsuba 0.6's `[uoffset, voffset, uscale, vscale]`: uv' = scale
/// (uv + offset).
pub(super) fn legacy_to_uv([ou, ov, su, sv]: [f32; 4]) -> Mat4 {
    Mat4::from_scale(Vec3::new(su, sv, 1.0)) * Mat4::from_translation(Vec3::new(ou, ov, 0.0))
}

/// Adds a property, refusing a second one of the same name.
fn push_prop<'a, 'i>(obj: &mut Obj<'a, 'i>, name: String, val: Val, node: Node<'a, 'i>) -> Result<()> {
    if obj.props.iter().any(|p| p.name == name) {
        return Err(obj
            .src
            .err(node, format!("{}: parameter '{name}' given twice", obj.what)));
    }
    obj.props.push(Prop {
        name,
        val,
        node,
        used: Cell::new(false),
        textured: Cell::new(false),
    });
    Ok(())
}
