//! The document walk: where a node is ([`Src`]), the loader's state ([`Loader`]),
//! attributes with `$name` substitution, ids, file resolution, and the top-level
//! elements: `<default>`, `<include>`, `<alias>`, `<integrator>` and the plugins.

use std::collections::{HashMap, HashSet};
use std::fmt::Display;
use std::path::{Path, PathBuf};

use roxmltree::{Document, Node};

use super::parse;
use super::properties::Target;
use crate::error::{Error, Pos};
use crate::scene::Scene;
use crate::Result;

/// An integrator's `max_depth` below this is noted: its paths miss a share of the
/// light that radtrace's solution holds (of the order of the reflectance to the power
/// of the bounces left out: 0.7^19 = 0.1 % at this depth).
const MAX_DEPTH_NOTED: i64 = 20;

/// Maximum depth of nested `<include>`s.
const MAX_INCLUDE_DEPTH: usize = 16;

/// Integrators whose presence is normal in a Mitsuba scene: accepted silently. They
/// render the scene's light transport (Mitsuba 3's, and Mitsuba 0.6's global
/// illumination methods, `sppm` and the rest, with `adaptive` and `irrcache`, which
/// wrap one of them), the picture radtrace renders with its own method; those that
/// render something else (`aov`, `depth`, `ao`, ...) are warned about.
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
    "volpath_simple",
    "bdpt",
    "pssmlt",
    "mlt",
    "erpt",
    "photonmapper",
    "ppm",
    "sppm",
    "vpl",
    "adaptive",
    "irrcache",
];

/// Where a node is: one file and its parsed document.
#[derive(Clone, Copy)]
pub(super) struct Src<'a, 'i> {
    path: &'a Path,
    pub(super) doc: &'a Document<'i>,
    /// The file is a Mitsuba 0.6 (or older) scene: its names are upgraded as Mitsuba
    /// 3 upgrades them ([`Loader::prop_name`]).
    pub(super) legacy: bool,
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

    pub(super) fn err(&self, n: Node<'a, 'i>, msg: impl Into<String>) -> Error {
        Error::input(self.path, Some(self.pos(n)), msg)
    }

    pub(super) fn err_attr(&self, n: Node<'a, 'i>, attr: &str, msg: impl Into<String>) -> Error {
        Error::input(self.path, Some(self.attr_pos(n, attr)), msg)
    }
}

/// The loader's state while it walks one scene (and its includes).
pub(super) struct Loader {
    main_dir: PathBuf,
    pub(super) params: HashMap<String, String>,
    pub(super) declared: HashSet<String>,
    /// The parameters substituted somewhere (a `-D` neither declared nor used is an
    /// error, as Mitsuba's "unused parameters").
    pub(super) used: std::cell::RefCell<HashSet<String>>,
    pub(super) warnings: Vec<String>,
    pub(super) scene: Scene,
    pub(super) ids: HashMap<String, (Target, String)>,
    pub(super) bsdf_index: HashMap<String, u32>,
    /// The ids of `null` bsdfs: a shape that names one is invisible.
    pub(super) null_bsdfs: HashSet<String>,
    /// The shapes of each `shapegroup`, by id, in the group's own space.
    pub(super) groups: HashMap<String, Vec<crate::scene::Shape>>,
    pub(super) default_bsdf: [Option<u32>; 2],
    include_stack: Vec<PathBuf>,
    /// Whether the file being read is a Mitsuba 0.6 scene (an included file without
    /// a version of its own inherits it).
    legacy: bool,
    /// One line per file upgraded from Mitsuba 0.6.
    pub(super) notes: Vec<String>,
    /// Image files read, with their `raw` flag: their index in the scene's textures.
    pub(super) images: HashMap<(PathBuf, bool), u32>,
    /// Image files read ahead, in parallel, before the walk reaches them
    /// ([`Loader::read_images_ahead`]), by path and `raw` flag.
    pub(super) read_ahead:
        HashMap<(PathBuf, bool), std::result::Result<crate::scene::texture::Texture, String>>,
    /// Mesh files read ahead, in parallel ([`Loader::read_meshes_ahead`]), with the
    /// number of shapes still to take each.
    pub(super) meshes_ahead: HashMap<super::shape::MeshKey, (Result<crate::geometry::TriMesh>, u32)>,
    /// Folders that `<path>` elements named, the latest first: searched for files
    /// before the scene's own folders, as Mitsuba's file resolver does.
    search: Vec<PathBuf>,
}

pub(super) fn tag<'a>(n: Node<'a, '_>) -> &'a str {
    n.tag_name().name()
}

/// The `value` of the first child element `<kind name=...>` of `n` with one of
/// `names`, as written (for reading files ahead of the walk).
pub(super) fn child_value<'a>(n: Node<'a, '_>, kind: &str, names: &[&str]) -> Option<&'a str> {
    n.children()
        .find(|c| tag(*c) == kind && c.attribute("name").is_some_and(|a| names.contains(&a)))
        .and_then(|c| c.attribute("value"))
}

/// Reads a text file; a directory or non-UTF-8 content is an input error.
pub(super) fn read_text(path: &Path) -> Result<String> {
    if path.is_dir() {
        return Err(Error::input(path, None, "is a directory, not a file"));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    String::from_utf8(bytes).map_err(|_| Error::input(path, None, "is not UTF-8 text"))
}

impl Loader {
    pub(super) fn new(path: &Path) -> Self {
        Loader {
            main_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            params: HashMap::new(),
            declared: HashSet::new(),
            used: Default::default(),
            warnings: Vec::new(),
            scene: Scene {
                path: path.to_path_buf(),
                shapes: Vec::new(),
                bsdfs: Vec::new(),
                lights: Vec::new(),
                light_ids: Vec::new(),
                sensors: Vec::new(),
                textures: Vec::new(),
                sun_disk: None,
            },
            ids: HashMap::new(),
            bsdf_index: HashMap::new(),
            null_bsdfs: HashSet::new(),
            groups: HashMap::new(),
            default_bsdf: [None; 2],
            include_stack: vec![path.canonicalize().unwrap_or(path.to_path_buf())],
            legacy: false,
            notes: Vec::new(),
            images: HashMap::new(),
            read_ahead: HashMap::new(),
            meshes_ahead: HashMap::new(),
            search: Vec::new(),
        }
    }

    pub(super) fn warn(&mut self, s: Src, n: Node, msg: impl Display) {
        self.warnings
            .push(format!("{}:{}: {msg}", s.path.display(), s.pos(n)));
    }

    /// A notice (not a warning: nothing is left out) naming the file and line.
    pub(super) fn note(&mut self, s: Src, n: Node, msg: impl Display) {
        self.notes
            .push(format!("{}:{}: {msg}", s.path.display(), s.pos(n)));
    }

    /// Attribute `name` with `$parameters` substituted.
    pub(super) fn attr(&self, s: Src, n: Node, name: &str) -> Result<Option<String>> {
        let Some(raw) = n.attribute(name) else {
            return Ok(None);
        };
        let mut used = |name: &str| {
            self.used.borrow_mut().insert(name.to_string());
        };
        parse::substitute(raw, &self.params, &mut used)
            .map(Some)
            .map_err(|p| {
                s.err_attr(
                    n,
                    name,
                    format!("undefined parameter '${p}' (no <default name=\"{p}\"> and no -D {p}=...)"),
                )
            })
    }

    pub(super) fn attr_req(&self, s: Src, n: Node, name: &str) -> Result<String> {
        self.attr(s, n, name)?
            .ok_or_else(|| s.err(n, format!("<{}> is missing the attribute '{name}'", tag(n))))
    }

    /// Warns about attributes outside `allowed`.
    pub(super) fn check_attrs(&mut self, s: Src, n: Node, allowed: &[&str]) {
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
    pub(super) fn register(&mut self, s: Src, n: Node, target: Target) -> Result<()> {
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

    /// A path named in file `s`: in a folder a `<path>` named, else relative to that
    /// file's folder, else to the main scene's folder (as Mitsuba's file resolver),
    /// else as given.
    pub(super) fn resolve(&self, s: Src, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        if let Some(found) = self.search.iter().map(|d| d.join(p)).find(|f| f.exists()) {
            return found;
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

    pub(super) fn load_file(&mut self, path: &Path, top: bool) -> Result<()> {
        let text = read_text(path)?;
        self.load_text(path, &text, top)
    }

    pub(super) fn load_text(&mut self, path: &Path, text: &str, top: bool) -> Result<()> {
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
        let root = doc.root_element();
        let version = (tag(root) == "scene")
            .then(|| root.attribute("version"))
            .flatten();
        let legacy = match version {
            None => self.legacy,
            Some(v) => match parse::version(v) {
                Ok(v) => v < (2, 0, 0),
                Err(m) => {
                    let s = Src {
                        path,
                        doc: &doc,
                        legacy: false,
                    };
                    self.warn(s, root, format!("{m}; read as a Mitsuba 3 scene"));
                    false
                }
            },
        };
        if let (true, Some(v)) = (legacy, version) {
            self.notes.push(format!(
                "{}: a Mitsuba {v} scene, upgraded in memory as Mitsuba 3 does (camelCase \
                 names to snake_case, lookAt to lookat, uoffset/uscale to to_uv)",
                path.display()
            ));
        }
        let outer = std::mem::replace(&mut self.legacy, legacy);
        let s = Src {
            path,
            doc: &doc,
            legacy,
        };
        self.read_images_ahead(s);
        self.read_meshes_ahead(s);
        let r = self.load_root(s, top);
        self.legacy = outer;
        if top {
            // Files read ahead that the walk did not take (an included file's
            // walk leaves those of the files around it).
            self.read_ahead.clear();
            self.meshes_ahead.clear();
        }
        r
    }

    fn load_root(&mut self, s: Src, top: bool) -> Result<()> {
        let root = s.doc.root_element();
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
                    // Mitsuba loads it too, silently, and nothing can use it.
                    self.notes.push(format!(
                        "{}:{}: a top-level <bsdf> without an id is used by nothing (as in Mitsuba)",
                        s.path.display(),
                        s.pos(c)
                    ));
                }
                Ok(())
            }
            "texture" => self.texture(s, c).map(|_| ()),
            "shape" => self.shape(s, c),
            "emitter" => self.emitter(s, c),
            "sensor" => self.sensor(s, c),
            "integrator" => self.integrator(s, c),
            "alias" => self.alias(s, c),
            "path" => self.search_path(s, c),
            t @ ("float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point" | "vector"
            | "transform" | "ref") => {
                self.warn(s, c, format!("<{t}> directly inside <scene> ignored"));
                Ok(())
            }
            t @ ("medium" | "phase" | "volume" | "film" | "sampler" | "rfilter") => {
                self.warn(s, c, format!("unsupported element <{t}> ignored"));
                Ok(())
            }
            t => {
                self.warn(s, c, format!("unknown element <{t}> ignored"));
                Ok(())
            }
        }
    }

    /// `<path value="folder"/>`: a folder searched for the files the scene names
    /// (relative to the file that names it), before the scene's own, as in Mitsuba.
    fn search_path(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["value"]);
        let value = self.attr_req(s, c, "value")?;
        let given = Path::new(&value);
        let dir = if given.is_absolute() {
            given.to_path_buf()
        } else {
            s.path.parent().unwrap_or(Path::new("")).join(given)
        };
        if !dir.is_dir() {
            return Err(s.err_attr(c, "value", format!("<path>: folder '{value}' not found")));
        }
        self.search.insert(0, dir);
        Ok(())
    }

    pub(super) fn default(&mut self, s: Src, c: Node) -> Result<()> {
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
        // Mitsuba's `direct` (here or nested) renders direct light alone.
        if let Some(n) = std::iter::once(c)
            .chain(c.descendants().filter(|n| tag(*n) == "integrator"))
            .find(|n| n.attribute("type") == Some("direct"))
        {
            self.note(
                s,
                n,
                "the 'direct' integrator renders direct light alone; radtrace renders every \
                 bounce of light, so Mitsuba's image of this file lacks light that radtrace's \
                 has (`--method direct` renders radtrace's direct light alone)",
            );
        }
        // A limit on path length (here or in a nested integrator) that cuts light off:
        // radtrace's solution holds every bounce, so it says so.
        for n in c.descendants().filter(|n| tag(*n) == "integer") {
            let name = n.attribute("name").unwrap_or_default();
            if name != "max_depth" && !(s.legacy && name == "maxDepth") {
                continue;
            }
            let Some(v) = self.attr(s, n, "value")? else {
                continue;
            };
            if let Ok(d @ 1..MAX_DEPTH_NOTED) = parse::integer(&v) {
                let msg = format!(
                    "the integrator stops paths at max_depth {d}; radtrace renders every bounce of \
                     light, so Mitsuba's image of this file lacks light that radtrace's has"
                );
                self.note(s, n, msg);
            }
        }
        Ok(())
    }
}
