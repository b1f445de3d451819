//! `<transform>`: its operations (`translate`, `scale`, `rotate`, `matrix`,
//! `lookat`) composed in document order.

use glam::{Mat4, Vec3};
use roxmltree::Node;

use super::document::{tag, Loader, Src};
use super::parse;
use crate::Result;

impl Loader {
    /// A `<transform>`: its operations composed in document order, each applied after
    /// the previous ones (`M = op * M`), as Mitsuba does.
    pub(super) fn transform(&mut self, s: Src, c: Node) -> Result<Mat4> {
        let mut m = Mat4::IDENTITY;
        for op in c.children().filter(Node::is_element) {
            // Mitsuba 0.6 spelled it `lookAt`.
            let t = match tag(op) {
                "lookAt" if s.legacy => "lookat",
                t => t,
            };
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
}
