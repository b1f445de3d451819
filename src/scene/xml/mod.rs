//! Mitsuba 3 XML scene reader (the subset documented in README.md).
//!
//! The reader walks the document once, in document order, as Mitsuba does:
//! `<default>` declares a `$name` parameter from there on, `<ref>` refers to an
//! object declared earlier, `<include>` reads another file in place. Everything it
//! cannot represent is a warning naming the file and line; everything wrong is an
//! [`Error::Input`] naming the file, line and column.
//!
//! Supported: shapes `obj`, `ply`, `rectangle`, `cube`, `sphere`, `disk` and the
//! radtrace extension `bezier` (a `.bpt` file); BSDFs `diffuse`, `conductor`,
//! `plastic`, `twosided`, `blendbsdf` (rough variants become their smooth
//! counterparts); emitters `point`, `spot` and `area` (inside a shape); sensors
//! `perspective` with `hdrfilm` and a `sampler`.

mod parse;
#[cfg(test)]
mod tests;

use std::cell::Cell;
use std::collections::{HashMap, HashSet};
use std::fmt::Display;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec3};
use roxmltree::{Document, Node};

use crate::error::{Error, Pos};
use crate::geometry::{bezier, obj, ply, shapes, TriMesh};
use crate::scene::{Bsdf, BsdfKind, FovAxis, Light, Rgb, Scene, Sensor, Shape};
use crate::Result;

/// A loaded scene and the warnings met on the way (unknown plugins or parameters),
/// each naming the file and line.
#[derive(Debug)]
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// One line per warning.
    pub warnings: Vec<String>,
}

/// Loads a Mitsuba 3 scene file; `defines` set `$name` parameters (`-D name=value`).
///
/// Defines override the scene's `<default>`s; a define the scene never declares is a
/// warning (Mitsuba would refuse it).
pub fn load(path: &Path, defines: &[(String, String)]) -> Result<Loaded> {
    load_with(path, None, defines)
}

/// [`load`] of a scene given as text: `path` names it in errors, and files it refers
/// to (meshes, includes) are looked for beside `path`.
pub fn load_str(path: &Path, text: &str, defines: &[(String, String)]) -> Result<Loaded> {
    load_with(path, Some(text), defines)
}

fn load_with(path: &Path, text: Option<&str>, defines: &[(String, String)]) -> Result<Loaded> {
    let mut l = Loader::new(path);
    for (k, v) in defines {
        if k.is_empty() || k.contains('$') {
            return Err(Error::Usage(format!(
                "-D {k}={v}: a parameter name must be non-empty and without '$'"
            )));
        }
        l.params.insert(k.clone(), v.clone());
    }
    match text {
        Some(text) => l.load_text(path, text, true)?,
        None => l.load_file(path, true)?,
    }
    for (k, _) in defines {
        if !l.declared.contains(k) {
            l.warnings.push(format!(
                "{}: parameter '{k}' given with -D is not declared by a <default> in the \
                 scene (Mitsuba would refuse it)",
                path.display()
            ));
        }
    }
    Ok(Loaded {
        scene: l.scene,
        warnings: l.warnings,
    })
}

/// Maximum depth of nested `<include>`s.
const MAX_INCLUDE_DEPTH: usize = 16;

/// Integrators whose presence is normal in a Mitsuba scene: accepted silently.
const KNOWN_INTEGRATORS: &[&str] = &[
    "path",
    "direct",
    "volpath",
    "volpathmis",
    "prb",
    "prb_basic",
    "direct_projective",
    "prb_projective",
    "ptracer",
];

/// Where a node is: one file and its parsed document.
#[derive(Clone, Copy)]
struct Src<'a, 'i> {
    path: &'a Path,
    doc: &'a Document<'i>,
}

impl<'a, 'i> Src<'a, 'i> {
    fn pos_at(&self, byte: usize) -> Pos {
        let p = self.doc.text_pos_at(byte);
        Pos {
            line: p.row,
            col: p.col,
        }
    }

    /// Position of an element (its `<`).
    fn pos(&self, n: Node<'a, 'i>) -> Pos {
        self.pos_at(n.range().start)
    }

    /// Position of an attribute's value, or of the element without that attribute.
    fn attr_pos(&self, n: Node<'a, 'i>, attr: &str) -> Pos {
        match n.attributes().find(|a| a.name() == attr) {
            Some(a) => self.pos_at(a.range_value().start),
            None => self.pos(n),
        }
    }

    fn err(&self, n: Node<'a, 'i>, msg: impl Into<String>) -> Error {
        Error::input(self.path, Some(self.pos(n)), msg)
    }

    fn err_attr(&self, n: Node<'a, 'i>, attr: &str, msg: impl Into<String>) -> Error {
        Error::input(self.path, Some(self.attr_pos(n, attr)), msg)
    }
}

/// What an `id` names.
#[derive(Debug, Clone)]
enum Target {
    Bsdf(Bsdf),
    /// A texture reduced to one colour, or `None` (the parameter keeps its default).
    Texture(Option<Rgb>),
    Other(&'static str),
}

impl Target {
    fn kind(&self) -> &'static str {
        match self {
            Target::Bsdf(_) => "bsdf",
            Target::Texture(_) => "texture",
            Target::Other(k) => k,
        }
    }
}

/// A parsed property value.
#[derive(Debug, Clone)]
enum Val {
    Float(f32),
    Int(i64),
    Bool(bool),
    Str(String),
    Rgb(Rgb),
    Vec3(Vec3),
    Transform(Mat4),
    Texture(Option<Rgb>),
}

impl Val {
    fn kind(&self) -> &'static str {
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

struct Prop<'a, 'i> {
    name: String,
    val: Val,
    node: Node<'a, 'i>,
    used: Cell<bool>,
}

/// A nested object of a plugin: an element, or a `<ref>` already resolved.
enum Child<'a, 'i> {
    Elem(Node<'a, 'i>),
    Ref {
        node: Node<'a, 'i>,
        id: String,
        target: Target,
    },
}

/// A plugin's properties and nested objects, with the bookkeeping that finds
/// parameters nobody asked for.
struct Obj<'a, 'i> {
    src: Src<'a, 'i>,
    node: Node<'a, 'i>,
    /// E.g. "shape 'sphere'", for messages.
    what: String,
    props: Vec<Prop<'a, 'i>>,
    children: Vec<Child<'a, 'i>>,
}

impl<'a, 'i> Obj<'a, 'i> {
    /// The property `name`, marked as used.
    fn get(&self, name: &str) -> Option<&Prop<'a, 'i>> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    fn mark_all(&self) {
        for p in &self.props {
            p.used.set(true);
        }
    }

    /// An error about parameter `name` (at its element, or at the object's).
    fn err_param(&self, name: &str, msg: impl Display) -> Error {
        let node = self
            .props
            .iter()
            .find(|p| p.name == name)
            .map_or(self.node, |p| p.node);
        self.src
            .err(node, format!("{}: parameter '{name}' {msg}", self.what))
    }

    fn mismatch(&self, p: &Prop, want: &str) -> Error {
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

    fn float(&self, name: &str) -> Result<Option<f32>> {
        self.typed(name, "a float", |v| match *v {
            Val::Float(f) => Some(f),
            Val::Int(i) => Some(i as f32),
            _ => None,
        })
    }

    fn int(&self, name: &str) -> Result<Option<i64>> {
        self.typed(name, "an integer", |v| match *v {
            Val::Int(i) => Some(i),
            _ => None,
        })
    }

    fn boolean(&self, name: &str, default: bool) -> Result<bool> {
        let b = self.typed(name, "a boolean", |v| match *v {
            Val::Bool(b) => Some(b),
            _ => None,
        })?;
        Ok(b.unwrap_or(default))
    }

    fn string(&self, name: &str) -> Result<Option<String>> {
        self.typed(name, "a string", |v| match v {
            Val::Str(s) => Some(s.clone()),
            _ => None,
        })
    }

    fn vec3(&self, name: &str) -> Result<Option<Vec3>> {
        self.typed(name, "a point", |v| match *v {
            Val::Vec3(p) => Some(p),
            _ => None,
        })
    }

    fn transform(&self, name: &str) -> Result<Option<Mat4>> {
        self.typed(name, "a transform", |v| match *v {
            Val::Transform(m) => Some(m),
            _ => None,
        })
    }

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
    fn reflectance(&self, name: &str, default: f32) -> Result<Rgb> {
        let c = self.color(name, default)?;
        for (k, ch) in ["r", "g", "b"].into_iter().enumerate() {
            if !(0.0..=1.0).contains(&c[k]) {
                return Err(self.err_param(name, format!("channel {ch} = {} is outside [0, 1]", c[k])));
            }
        }
        Ok(c)
    }

    /// A radiance or intensity: a colour with no negative channel.
    fn emission(&self, name: &str) -> Result<Rgb> {
        let c = self.color(name, 1.0)?;
        if c.min_element() < 0.0 {
            return Err(self.err_param(name, format!("is negative ({c})")));
        }
        Ok(c)
    }

    /// A scalar that Mitsuba reads as a texture (`weight`): a float, or the mean of a
    /// colour or texture.
    fn scalar(&self, name: &str) -> Result<Option<f32>> {
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

/// The loader's state while it walks one scene (and its includes).
struct Loader {
    main_dir: PathBuf,
    params: HashMap<String, String>,
    declared: HashSet<String>,
    warnings: Vec<String>,
    scene: Scene,
    ids: HashMap<String, (Target, String)>,
    bsdf_index: HashMap<String, u32>,
    default_bsdf: Option<u32>,
    include_stack: Vec<PathBuf>,
}

fn tag<'a>(n: Node<'a, '_>) -> &'a str {
    n.tag_name().name()
}

/// Reads a text file; a directory or non-UTF-8 content is an input error.
fn read_text(path: &Path) -> Result<String> {
    if path.is_dir() {
        return Err(Error::input(path, None, "is a directory, not a file"));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    String::from_utf8(bytes).map_err(|_| Error::input(path, None, "is not UTF-8 text"))
}

impl Loader {
    fn new(path: &Path) -> Self {
        Loader {
            main_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            params: HashMap::new(),
            declared: HashSet::new(),
            warnings: Vec::new(),
            scene: Scene {
                path: path.to_path_buf(),
                shapes: Vec::new(),
                bsdfs: Vec::new(),
                lights: Vec::new(),
                light_ids: Vec::new(),
                sensors: Vec::new(),
            },
            ids: HashMap::new(),
            bsdf_index: HashMap::new(),
            default_bsdf: None,
            include_stack: vec![path.canonicalize().unwrap_or(path.to_path_buf())],
        }
    }

    fn warn(&mut self, s: Src, n: Node, msg: impl Display) {
        self.warnings
            .push(format!("{}:{}: {msg}", s.path.display(), s.pos(n)));
    }

    /// Attribute `name` with `$parameters` substituted.
    fn attr(&self, s: Src, n: Node, name: &str) -> Result<Option<String>> {
        let Some(raw) = n.attribute(name) else {
            return Ok(None);
        };
        parse::substitute(raw, &self.params).map(Some).map_err(|p| {
            s.err_attr(
                n,
                name,
                format!("undefined parameter '${p}' (no <default name=\"{p}\"> and no -D {p}=...)"),
            )
        })
    }

    fn attr_req(&self, s: Src, n: Node, name: &str) -> Result<String> {
        self.attr(s, n, name)?
            .ok_or_else(|| s.err(n, format!("<{}> is missing the attribute '{name}'", tag(n))))
    }

    /// Warns about attributes outside `allowed`.
    fn check_attrs(&mut self, s: Src, n: Node, allowed: &[&str]) {
        let bad: Vec<String> = n
            .attributes()
            .filter(|a| !allowed.contains(&a.name()))
            .map(|a| a.name().to_string())
            .collect();
        for a in bad {
            self.warn(
                s,
                n,
                format!("unexpected attribute '{a}' on <{}> ignored", tag(n)),
            );
        }
    }

    /// Records the element's `id` (if any) as naming `target`.
    fn register(&mut self, s: Src, n: Node, target: Target) -> Result<()> {
        let Some(id) = self.attr(s, n, "id")? else {
            return Ok(());
        };
        let here = format!("{}:{}", s.path.display(), s.pos(n));
        if let Some((_, first)) = self.ids.get(&id) {
            return Err(s.err_attr(n, "id", format!("duplicate id '{id}' (first at {first})")));
        }
        self.ids.insert(id, (target, here));
        Ok(())
    }

    /// A path named in file `s`: relative to that file's folder, else to the main
    /// scene's folder (as Mitsuba's file resolver), else as given.
    fn resolve(&self, s: Src, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        let here = s.path.parent().unwrap_or(Path::new("")).join(p);
        if here.exists() {
            return here;
        }
        let main = self.main_dir.join(p);
        if main.exists() {
            main
        } else {
            here
        }
    }

    // ----------------------------------------------------------------- files

    fn load_file(&mut self, path: &Path, top: bool) -> Result<()> {
        let text = read_text(path)?;
        self.load_text(path, &text, top)
    }

    fn load_text(&mut self, path: &Path, text: &str, top: bool) -> Result<()> {
        let doc = Document::parse(text).map_err(|e| {
            let p = e.pos();
            let msg = e.to_string().replace(&format!(" at {p}"), "");
            Error::input(
                path,
                Some(Pos {
                    line: p.row,
                    col: p.col,
                }),
                format!("malformed XML: {msg}"),
            )
        })?;
        let s = Src { path, doc: &doc };
        let root = doc.root_element();
        if tag(root) != "scene" {
            if top {
                return Err(s.err(
                    root,
                    format!("the root element must be <scene>, not <{}>", tag(root)),
                ));
            }
            // An included file may hold one object.
            return self.top_element(s, root);
        }
        self.check_attrs(s, root, &["version"]);
        for c in root.children().filter(Node::is_element) {
            self.top_element(s, c)?;
        }
        if top {
            if self.scene.sensors.is_empty() {
                return Err(s.err(root, "no sensor: the scene needs a <sensor> (a view)"));
            }
            if self.scene.shapes.is_empty() {
                self.warn(s, root, "the scene has no shapes");
            }
            if self.scene.lights.is_empty() {
                self.warn(s, root, "the scene has no (supported) light sources");
            }
        }
        Ok(())
    }

    fn top_element(&mut self, s: Src, c: Node) -> Result<()> {
        match tag(c) {
            "default" => self.default(s, c),
            "include" => self.include(s, c),
            "bsdf" => {
                self.bsdf(s, c)?;
                if c.attribute("id").is_none() {
                    self.warn(s, c, "a top-level <bsdf> without an id cannot be used; ignored");
                }
                Ok(())
            }
            "texture" => self.texture(s, c).map(|_| ()),
            "shape" => self.shape(s, c),
            "emitter" => self.emitter(s, c),
            "sensor" => self.sensor(s, c),
            "integrator" => self.integrator(s, c),
            "alias" => self.alias(s, c),
            t @ ("float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point" | "vector"
            | "transform" | "ref") => {
                self.warn(s, c, format!("<{t}> directly inside <scene> ignored"));
                Ok(())
            }
            t @ ("medium" | "phase" | "volume" | "film" | "sampler" | "rfilter" | "path") => {
                self.warn(s, c, format!("unsupported element <{t}> ignored"));
                Ok(())
            }
            t => {
                self.warn(s, c, format!("unknown element <{t}> ignored"));
                Ok(())
            }
        }
    }

    fn default(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["name", "value"]);
        let name = self.attr_req(s, c, "name")?;
        if name.is_empty() || name.contains('$') {
            return Err(s.err_attr(c, "name", "<default>: the name must be non-empty"));
        }
        let value = self.attr_req(s, c, "value")?;
        self.declared.insert(name.clone());
        self.params.entry(name).or_insert(value);
        Ok(())
    }

    fn include(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["filename"]);
        let name = self.attr_req(s, c, "filename")?;
        let path = self.resolve(s, &name);
        if path.is_dir() {
            return Err(s.err_attr(c, "filename", format!("included '{name}' is a directory")));
        }
        if !path.exists() {
            return Err(s.err_attr(
                c,
                "filename",
                format!("included file '{}' not found", path.display()),
            ));
        }
        let canon = path.canonicalize().unwrap_or(path.clone());
        if self.include_stack.contains(&canon) {
            return Err(s.err_attr(c, "filename", format!("'{name}' includes itself")));
        }
        if self.include_stack.len() > MAX_INCLUDE_DEPTH {
            return Err(s.err(c, "<include>s nested too deeply"));
        }
        self.include_stack.push(canon);
        let r = self.load_file(&path, false);
        self.include_stack.pop();
        r
    }

    fn alias(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["id", "as"]);
        let id = self.attr_req(s, c, "id")?;
        let to = self.attr_req(s, c, "as")?;
        let Some((target, _)) = self.ids.get(&id).cloned() else {
            return Err(s.err_attr(c, "id", format!("unknown id '{id}'")));
        };
        if let Some((_, first)) = self.ids.get(&to) {
            return Err(s.err_attr(c, "as", format!("duplicate id '{to}' (first at {first})")));
        }
        let here = format!("{}:{}", s.path.display(), s.pos(c));
        self.ids.insert(to, (target, here));
        Ok(())
    }

    fn integrator(&mut self, s: Src, c: Node) -> Result<()> {
        let ty = self.attr(s, c, "type")?.unwrap_or_default();
        self.register(s, c, Target::Other("integrator"))?;
        if !KNOWN_INTEGRATORS.contains(&ty.as_str()) {
            self.warn(
                s,
                c,
                format!("integrator '{ty}' ignored: radtrace renders with its own method"),
            );
        }
        Ok(())
    }

    // ------------------------------------------------------------ properties

    /// Reads the properties and nested objects of a plugin element.
    fn collect<'a, 'i>(&mut self, s: Src<'a, 'i>, node: Node<'a, 'i>, what: String) -> Result<Obj<'a, 'i>> {
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
                    let name = self.attr_req(s, c, "name")?;
                    let val = self.value(s, c, t)?;
                    push_prop(&mut obj, name, val, c)?;
                }
                "texture" => {
                    let name = self.attr_req(s, c, "name")?;
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
                            let Some(name) = self.attr(s, c, "name")? else {
                                return Err(s.err(
                                    c,
                                    format!("<ref> to texture '{id}' needs a 'name' (the parameter)"),
                                ));
                            };
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
        Ok(obj)
    }

    /// Warns about every parameter of `obj` that no one read.
    fn finish(&mut self, obj: &Obj) {
        for p in &obj.props {
            if !p.used.get() {
                self.warn(
                    obj.src,
                    p.node,
                    format!("unknown parameter '{}' of {} ignored", p.name, obj.what),
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
    fn xyz(&self, s: Src, c: Node, default: f32) -> Result<Vec3> {
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

    /// A `<transform>`: its operations composed in document order, each applied after
    /// the previous ones (`M = op * M`), as Mitsuba does.
    fn transform(&mut self, s: Src, c: Node) -> Result<Mat4> {
        let mut m = Mat4::IDENTITY;
        for op in c.children().filter(Node::is_element) {
            let t = tag(op);
            let bad = |msg: String| s.err(op, format!("<{t}>: {msg}"));
            let step = match t {
                "translate" => {
                    self.check_attrs(s, op, &["x", "y", "z", "value"]);
                    Mat4::from_translation(self.xyz(s, op, 0.0)?)
                }
                "scale" => {
                    self.check_attrs(s, op, &["x", "y", "z", "value"]);
                    Mat4::from_scale(self.xyz(s, op, 1.0)?)
                }
                "rotate" => {
                    self.check_attrs(s, op, &["x", "y", "z", "value", "angle"]);
                    let axis = self.xyz(s, op, 0.0)?;
                    let angle = self.attr_req(s, op, "angle")?;
                    let angle = parse::number(&angle)
                        .map_err(|m| s.err_attr(op, "angle", format!("<rotate>: {m}")))?;
                    parse::rotation(axis, angle).map_err(bad)?
                }
                "matrix" => {
                    self.check_attrs(s, op, &["value"]);
                    let v = self.attr_req(s, op, "value")?;
                    parse::matrix(&v).map_err(|m| s.err_attr(op, "value", format!("<matrix>: {m}")))?
                }
                "lookat" => {
                    self.check_attrs(s, op, &["origin", "target", "up"]);
                    let get = |name: &str| -> Result<Option<Vec3>> {
                        match self.attr(s, op, name)? {
                            None => Ok(None),
                            Some(v) => parse::triple(&v)
                                .map(Some)
                                .map_err(|m| s.err_attr(op, name, format!("<lookat> '{name}': {m}"))),
                        }
                    };
                    let origin = get("origin")?;
                    let target = get("target")?;
                    let up = get("up")?;
                    let (Some(origin), Some(target)) = (origin, target) else {
                        return Err(bad("needs 'origin' and 'target'".into()));
                    };
                    parse::look_at(origin, target, up).map_err(|m| s.err(op, m))?
                }
                _ => return Err(bad("cannot appear inside <transform>".into())),
            };
            m = step * m;
        }
        if !m.is_finite() {
            return Err(s.err(c, "<transform> is not finite"));
        }
        Ok(m)
    }

    /// `<spectrum>`: a uniform value; wavelength:value pairs or a file become their
    /// mean, with a warning.
    fn spectrum(&mut self, s: Src, c: Node) -> Result<Val> {
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
    fn texture(&mut self, s: Src, c: Node) -> Result<Option<Rgb>> {
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

    /// A path parameter (`filename`) that must name an existing file.
    fn file_param(&self, obj: &Obj, name: &str) -> Result<(PathBuf, String)> {
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

    // ----------------------------------------------------------------- BSDFs

    /// Parses a `<bsdf>` (registering its id).
    fn bsdf(&mut self, s: Src, c: Node) -> Result<Bsdf> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let obj = self.collect(s, c, format!("bsdf '{ty}'"))?;
        let (kind, twosided) = match ty.as_str() {
            "diffuse" | "roughdiffuse" => {
                if ty == "roughdiffuse" {
                    self.rough(s, c, &ty, "diffuse");
                    obj.get("alpha");
                    obj.get("use_fast_approx");
                }
                let reflectance = obj.reflectance("reflectance", 0.5)?;
                (BsdfKind::Diffuse { reflectance }, false)
            }
            "conductor" | "roughconductor" => {
                if ty == "roughconductor" {
                    self.rough(s, c, &ty, "conductor");
                    for p in ["alpha", "alpha_u", "alpha_v", "distribution", "sample_visible"] {
                        obj.get(p);
                    }
                }
                (self.conductor(s, c, &obj)?, false)
            }
            "plastic" | "roughplastic" => {
                if ty == "roughplastic" {
                    self.rough(s, c, &ty, "plastic");
                    for p in ["alpha", "distribution", "sample_visible"] {
                        obj.get(p);
                    }
                }
                let diffuse_reflectance = obj.reflectance("diffuse_reflectance", 0.5)?;
                let specular_reflectance = obj.reflectance("specular_reflectance", 1.0)?;
                let int_ior = ior(&obj, "int_ior", 1.49)?;
                let ext_ior = ior(&obj, "ext_ior", 1.000277)?;
                let nonlinear = obj.boolean("nonlinear", false)?;
                let kind = BsdfKind::Plastic {
                    diffuse_reflectance,
                    specular_reflectance,
                    eta: int_ior / ext_ior,
                    nonlinear,
                };
                (kind, false)
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
                let kind = BsdfKind::Blend {
                    weight,
                    a: Box::new(a.kind),
                    b: Box::new(b.kind),
                };
                (kind, twosided)
            }
            "mask" | "bumpmap" | "normalmap" => {
                obj.mark_all();
                let inner = self.nested_bsdfs(&obj)?;
                let Some(first) = inner.into_iter().next() else {
                    return Err(s.err(c, format!("bsdf '{ty}' needs a nested bsdf")));
                };
                self.warn(
                    s,
                    c,
                    format!("bsdf '{ty}' is not supported: its nested bsdf is used alone"),
                );
                (first.kind, first.twosided)
            }
            "principled" | "principledthin" => {
                obj.mark_all();
                let reflectance = obj.reflectance("base_color", 0.5)?;
                self.warn(
                    s,
                    c,
                    format!("bsdf '{ty}' is not supported: rendered as diffuse with its base_color"),
                );
                (BsdfKind::Diffuse { reflectance }, false)
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

    /// A conductor as a mirror of constant reflectance.
    fn conductor(&mut self, s: Src, c: Node, obj: &Obj) -> Result<BsdfKind> {
        let scale = obj.reflectance("specular_reflectance", 1.0)?;
        let material = obj.string("material")?;
        let eta = obj.scalar("eta")?;
        let k = obj.scalar("k")?;
        let f0 = if eta.is_some() || k.is_some() {
            if material.as_deref().is_some_and(|m| m != "none") {
                return Err(s.err(
                    c,
                    "bsdf 'conductor': give either 'material' or 'eta'/'k', not both",
                ));
            }
            let f = parse::fresnel_f0(eta.unwrap_or(0.0), k.unwrap_or(1.0));
            self.warn(
                s,
                c,
                format!(
                    "conductor with eta/k rendered as a mirror of constant reflectance {f} \
                     (its value at normal incidence)"
                ),
            );
            Vec3::splat(f)
        } else {
            match material.as_deref().unwrap_or("none") {
                "none" => Vec3::ONE,
                m => match parse::conductor_f0(m) {
                    Some(f0) => {
                        self.warn(
                            s,
                            c,
                            format!(
                                "conductor material '{m}' rendered as a mirror of constant \
                                 reflectance {f0} (its value at normal incidence)"
                            ),
                        );
                        f0
                    }
                    None => {
                        self.warn(
                            s,
                            c,
                            format!(
                                "conductor material '{m}' is not known to radtrace: rendered \
                                 as a perfect mirror (reflectance 1)"
                            ),
                        );
                        Vec3::ONE
                    }
                },
            }
        };
        Ok(BsdfKind::Conductor {
            specular_reflectance: scale * f0,
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
    fn add_bsdf(&mut self, b: Bsdf, id: Option<&str>) -> u32 {
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

    fn default_bsdf(&mut self) -> u32 {
        if let Some(i) = self.default_bsdf {
            return i;
        }
        let i = self.scene.bsdfs.len() as u32;
        self.scene.bsdfs.push(Bsdf::default());
        self.default_bsdf = Some(i);
        i
    }

    // ---------------------------------------------------------------- shapes

    fn shape(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let id = self.attr(s, c, "id")?;
        self.register(s, c, Target::Other("shape"))?;
        let index = self.scene.shapes.len();
        let obj = self.collect(s, c, format!("shape '{ty}'"))?;
        let (mut mesh, auto_name): (TriMesh, String) = match ty.as_str() {
            "obj" | "ply" => {
                let (path, fname) = self.file_param(&obj, "filename")?;
                let face_normals = obj.boolean("face_normals", false)?;
                obj.get("flip_tex_coords");
                let mesh = if ty == "obj" {
                    obj::read_obj(&path, face_normals)?
                } else {
                    ply::read_ply(&path, face_normals)?
                };
                (mesh, format!("{ty}:{fname}"))
            }
            "bezier" => {
                let (path, fname) = self.file_param(&obj, "filename")?;
                let level = |name: &str, default: i64| -> Result<u32> {
                    let v = obj.int(name)?.unwrap_or(default);
                    if !(1..=256).contains(&v) {
                        return Err(obj.err_param(name, format!("= {v} is outside [1, 256]")));
                    }
                    Ok(v as u32)
                };
                let coarse = level("coarse", 4)?;
                let fine = level("fine", 8)?;
                let patches = bezier::read_bpt(&path)?;
                let tris = bezier::tessellated_triangles(patches.len(), coarse, fine);
                if tris > bezier::MAX_TESSELLATED_TRIANGLES {
                    return Err(obj.err_param(
                        "fine",
                        format!(
                            "{} patches at coarse {coarse} x fine {fine} would make {tris} triangles \
                             (at most {})",
                            patches.len(),
                            bezier::MAX_TESSELLATED_TRIANGLES
                        ),
                    ));
                }
                (
                    bezier::tessellate(&patches, coarse, fine),
                    format!("bezier:{fname}"),
                )
            }
            "rectangle" => (shapes::rectangle(), format!("rectangle#{index}")),
            "cube" => (shapes::cube(), format!("cube#{index}")),
            "disk" => (shapes::disk(), format!("disk#{index}")),
            "sphere" => {
                let center = obj.vec3("center")?.unwrap_or(Vec3::ZERO);
                let radius = obj.float("radius")?.unwrap_or(1.0);
                if radius <= 0.0 {
                    return Err(obj.err_param("radius", format!("= {radius} must be positive")));
                }
                (shapes::sphere(center, radius), format!("sphere#{index}"))
            }
            t => {
                obj.mark_all();
                self.warn(s, c, format!("unknown shape type '{t}' ignored"));
                return Ok(());
            }
        };
        let name = id.clone().unwrap_or(auto_name);

        if let Some(m) = obj.transform("to_world")? {
            let l = Mat3::from_mat4(m);
            let det = l.determinant();
            if det == 0.0 || !det.is_finite() {
                return Err(obj.err_param("to_world", "is singular (it flattens the shape)"));
            }
            if ty == "sphere" {
                let (x, y, z) = (l.x_axis, l.y_axis, l.z_axis);
                let tol = 1e-4 * x.length();
                let uniform = (x.length() - y.length()).abs() <= tol
                    && (x.length() - z.length()).abs() <= tol
                    && x.dot(y).abs() <= tol * x.length()
                    && x.dot(z).abs() <= tol * x.length()
                    && y.dot(z).abs() <= tol * x.length();
                if !uniform {
                    self.warn(
                        s,
                        c,
                        "sphere with a non-uniform to_world: radtrace renders an ellipsoid, \
                         Mitsuba a sphere",
                    );
                }
            }
            mesh.transform(&m);
        }
        if obj.boolean("flip_normals", false)? {
            mesh.flip_normals();
        }
        mesh.validate()
            .map_err(|e| s.err(c, format!("shape '{name}': invalid mesh: {e}")))?;
        if mesh.triangle_count() == 0 {
            self.warn(s, c, format!("shape '{name}' has no triangles"));
        }

        let mut bsdf = None;
        let mut emitter: Option<(Rgb, Node)> = None;
        for ch in &obj.children {
            match ch {
                Child::Elem(n) if tag(*n) == "bsdf" => {
                    if bsdf.is_some() {
                        return Err(s.err(*n, format!("shape '{name}' has more than one bsdf")));
                    }
                    let b = self.bsdf(s, *n)?;
                    let bid = self.attr(s, *n, "id")?;
                    bsdf = Some(self.add_bsdf(b, bid.as_deref()));
                }
                Child::Ref {
                    node,
                    id,
                    target: Target::Bsdf(b),
                } => {
                    if bsdf.is_some() {
                        return Err(s.err(*node, format!("shape '{name}' has more than one bsdf")));
                    }
                    bsdf = Some(self.add_bsdf(b.clone(), Some(id)));
                }
                Child::Ref { node, id, target } => {
                    return Err(s.err_attr(
                        *node,
                        "id",
                        format!("id '{id}' names a {}, not a bsdf", target.kind()),
                    ))
                }
                Child::Elem(n) if tag(*n) == "emitter" => {
                    if let Some(r) = self.area_emitter(s, *n)? {
                        if emitter.is_some() {
                            return Err(s.err(*n, format!("shape '{name}' has more than one area emitter")));
                        }
                        emitter = Some((r, *n));
                    }
                }
                Child::Elem(n) => {
                    let msg = format!("<{}> inside shape '{name}' ignored", tag(*n));
                    self.warn(s, *n, msg);
                }
            }
        }
        self.finish(&obj);

        let bsdf = match bsdf {
            Some(b) => b,
            None => self.default_bsdf(),
        };
        let light = match emitter {
            None => None,
            Some((radiance, n)) => {
                let area = mesh.area();
                if !(area > 0.0 && area.is_finite()) {
                    return Err(s.err(n, format!("area emitter on shape '{name}', which has zero area")));
                }
                if radiance == Vec3::ZERO {
                    self.warn(s, n, format!("area emitter on '{name}' has zero radiance"));
                }
                self.scene.lights.push(Light::Area {
                    shape: index as u32,
                    radiance,
                });
                Some(self.scene.lights.len() as u32 - 1)
            }
        };
        self.scene.shapes.push(Shape {
            name,
            mesh,
            bsdf,
            emitter: light,
        });
        Ok(())
    }

    /// An `<emitter>` inside a shape: the radiance of an `area` emitter, or `None`
    /// (with a warning) for any other type.
    fn area_emitter(&mut self, s: Src, c: Node) -> Result<Option<Rgb>> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        self.register(s, c, Target::Other("emitter"))?;
        if ty != "area" {
            self.warn(
                s,
                c,
                format!("emitter '{ty}' inside a shape ignored (only 'area' belongs there)"),
            );
            return Ok(None);
        }
        let obj = self.collect(s, c, "emitter 'area'".into())?;
        let radiance = obj.emission("radiance")?;
        self.finish(&obj);
        Ok(Some(radiance))
    }

    // -------------------------------------------------------------- emitters

    /// Records the `id` of the light just pushed (for tables and messages).
    fn name_light(&mut self, c: Node) {
        let i = self.scene.lights.len() - 1;
        self.scene.light_ids.resize(i, None);
        self.scene.light_ids.push(c.attribute("id").map(str::to_owned));
    }

    fn emitter(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        self.register(s, c, Target::Other("emitter"))?;
        match ty.as_str() {
            "point" => {
                let obj = self.collect(s, c, "emitter 'point'".into())?;
                let pos = obj.vec3("position")?;
                let to_world = obj.transform("to_world")?;
                let position = match (pos, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(s.err(
                            c,
                            "emitter 'point': give either 'position' or 'to_world', not both",
                        ))
                    }
                    (Some(p), None) => p,
                    (None, Some(m)) => m.transform_point3(Vec3::ZERO),
                    (None, None) => Vec3::ZERO,
                };
                let intensity = obj.emission("intensity")?;
                self.finish(&obj);
                if intensity == Vec3::ZERO {
                    self.warn(s, c, "point light with zero intensity");
                }
                self.scene.lights.push(Light::Point { position, intensity });
                self.name_light(c);
            }
            "spot" => {
                let obj = self.collect(s, c, "emitter 'spot'".into())?;
                let m = obj.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                let position = m.transform_point3(Vec3::ZERO);
                let axis = m.transform_vector3(Vec3::Z);
                let direction = axis
                    .try_normalize()
                    .ok_or_else(|| obj.err_param("to_world", "maps the spot's axis (+z) to nothing"))?;
                let intensity = obj.emission("intensity")?;
                let cutoff = obj.float("cutoff_angle")?.unwrap_or(20.0);
                if !(cutoff > 0.0 && cutoff <= 180.0) {
                    return Err(
                        obj.err_param("cutoff_angle", format!("= {cutoff} degrees is outside (0, 180]"))
                    );
                }
                let beam = obj.float("beam_width")?.unwrap_or(cutoff * 0.75);
                if !(0.0..=cutoff).contains(&beam) {
                    return Err(obj.err_param(
                        "beam_width",
                        format!("= {beam} degrees is outside [0, cutoff_angle = {cutoff}]"),
                    ));
                }
                if obj.get("texture").is_some() {
                    self.warn(s, c, "spot light 'texture' is not supported; ignored");
                }
                self.finish(&obj);
                if intensity == Vec3::ZERO {
                    self.warn(s, c, "spot light with zero intensity");
                }
                self.scene.lights.push(Light::Spot {
                    position,
                    direction,
                    intensity,
                    cutoff_angle: cutoff.to_radians(),
                    beam_width: beam.to_radians(),
                });
                self.name_light(c);
            }
            "area" => {
                return Err(s.err(c, "an 'area' emitter must be nested inside a <shape>"));
            }
            t => self.warn(s, c, format!("emitter '{t}' is not supported; ignored")),
        }
        Ok(())
    }

    // --------------------------------------------------------------- sensors

    fn sensor(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        self.register(s, c, Target::Other("sensor"))?;
        let obj = self.collect(s, c, format!("sensor '{ty}'"))?;
        match ty.as_str() {
            "perspective" => {}
            "thinlens" => {
                obj.get("aperture_radius");
                self.warn(
                    s,
                    c,
                    "sensor 'thinlens' rendered as 'perspective' (depth of field is ignored)",
                );
            }
            t => {
                obj.mark_all();
                self.warn(
                    s,
                    c,
                    format!("sensor '{t}' is not supported: treated as 'perspective'"),
                );
            }
        }
        let to_world = obj.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let l = Mat3::from_mat4(to_world);
        let orthonormal = (l.transpose() * l - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|v| v.abs() < 1e-3);
        if !orthonormal {
            self.warn(
                s,
                c,
                "the sensor's to_world scales or shears (Mitsuba refuses this)",
            );
        }

        let (fov, fov_axis) = match (obj.get("fov").is_some(), obj.get("focal_length").is_some()) {
            (true, true) => return Err(s.err(c, "sensor: give either 'fov' or 'focal_length', not both")),
            (true, false) => {
                let fov = obj.float("fov")?.unwrap_or(0.0);
                let axis = obj.string("fov_axis")?.unwrap_or_else(|| "x".into());
                let axis = match axis.to_ascii_lowercase().as_str() {
                    "x" => FovAxis::X,
                    "y" => FovAxis::Y,
                    "diagonal" => FovAxis::Diagonal,
                    "smaller" => FovAxis::Smaller,
                    "larger" => FovAxis::Larger,
                    _ => {
                        return Err(obj.err_param(
                            "fov_axis",
                            format!("= '{axis}': expected x, y, diagonal, smaller or larger"),
                        ))
                    }
                };
                (fov, axis)
            }
            (false, _) => {
                // Mitsuba's default is a 50 mm lens on 35 mm film, along the diagonal.
                let f = match obj.get("focal_length").map(|p| p.val.clone()) {
                    None => 50.0,
                    Some(Val::Float(v)) => v,
                    Some(Val::Int(i)) => i as f32,
                    Some(Val::Str(t)) => {
                        let t = t.trim();
                        parse::number(t.strip_suffix("mm").unwrap_or(t)).map_err(|_| {
                            obj.err_param(
                                "focal_length",
                                format!("= '{t}': expected a length such as '50mm'"),
                            )
                        })?
                    }
                    Some(v) => {
                        return Err(obj.err_param(
                            "focal_length",
                            format!("must be a string such as '50mm', not {}", v.kind()),
                        ))
                    }
                };
                if f <= 0.0 {
                    return Err(obj.err_param("focal_length", "must be positive"));
                }
                obj.get("fov_axis");
                let diag = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
                ((diag / (2.0 * f)).atan().to_degrees() * 2.0, FovAxis::Diagonal)
            }
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(obj.err_param("fov", format!("= {fov} degrees is outside (0, 180)")));
        }
        let near_clip = obj.float("near_clip")?.unwrap_or(0.01);
        let far_clip = obj.float("far_clip")?.unwrap_or(10000.0);
        if near_clip <= 0.0 {
            return Err(obj.err_param("near_clip", "must be positive"));
        }
        if near_clip >= far_clip {
            return Err(obj.err_param("near_clip", "must be smaller than far_clip"));
        }
        for p in ["focus_distance", "shutter_open", "shutter_close", "srf"] {
            obj.get(p);
        }
        for p in ["principal_point_offset_x", "principal_point_offset_y"] {
            if obj.float(p)?.is_some_and(|v| v != 0.0) {
                self.warn(s, c, format!("sensor '{p}' is not supported; ignored"));
            }
        }

        let (mut width, mut height, mut spp) = (768, 576, None);
        let (mut film_seen, mut sampler_seen) = (false, false);
        for ch in &obj.children {
            match ch {
                Child::Elem(n) if tag(*n) == "film" => {
                    if film_seen {
                        return Err(s.err(*n, "a sensor takes one <film>"));
                    }
                    film_seen = true;
                    (width, height) = self.film(s, *n)?;
                }
                Child::Elem(n) if tag(*n) == "sampler" => {
                    if sampler_seen {
                        return Err(s.err(*n, "a sensor takes one <sampler>"));
                    }
                    sampler_seen = true;
                    spp = self.sampler(s, *n)?;
                }
                Child::Elem(n) => {
                    let msg = format!("<{}> inside sensor ignored", tag(*n));
                    self.warn(s, *n, msg);
                }
                Child::Ref { node, id, .. } => {
                    let msg = format!("<ref id=\"{id}\"> inside sensor ignored");
                    self.warn(s, *node, msg);
                }
            }
        }
        self.finish(&obj);
        self.scene.sensors.push(Sensor {
            to_world,
            fov,
            fov_axis,
            width,
            height,
            near_clip,
            far_clip,
            spp,
        });
        Ok(())
    }

    /// The film's size; its other settings are Mitsuba's business.
    fn film(&mut self, s: Src, c: Node) -> Result<(u32, u32)> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        self.register(s, c, Target::Other("film"))?;
        if ty != "hdrfilm" {
            self.warn(s, c, format!("film '{ty}': only its width and height are used"));
        }
        let obj = self.collect(s, c, format!("film '{ty}'"))?;
        let size = |name: &str, default: i64| -> Result<u32> {
            let v = obj.int(name)?.unwrap_or(default);
            if !(1..=16384).contains(&v) {
                return Err(obj.err_param(name, format!("= {v} is outside [1, 16384]")));
            }
            Ok(v as u32)
        };
        let w = size("width", 768)?;
        let h = size("height", 576)?;
        obj.mark_all();
        Ok((w, h))
    }

    fn sampler(&mut self, s: Src, c: Node) -> Result<Option<u32>> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        self.register(s, c, Target::Other("sampler"))?;
        let obj = self.collect(s, c, "sampler".into())?;
        let spp = match obj.int("sample_count")? {
            None => None,
            Some(n) if (1..=u32::MAX as i64).contains(&n) => Some(n as u32),
            Some(n) => return Err(obj.err_param("sample_count", format!("= {n} must be positive"))),
        };
        obj.mark_all();
        Ok(spp)
    }
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
    });
    Ok(())
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
