//! Sensor plugins (`perspective`, `thinlens`, `orthographic`; others as perspective) with their
//! film and sampler.

use glam::{Mat3, Mat4};
use roxmltree::Node;

use super::document::{tag, Loader, Src};
use super::parse;
use super::properties::{Child, Target, Val};
use crate::scene::{Crop, Filter, FovAxis, Lens, Projection, Sensor};
use crate::Result;

impl Loader {
    pub(super) fn sensor(&mut self, s: Src, c: Node) -> Result<()> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        self.register(s, c, Target::Other("sensor"))?;
        let obj = self.collect(s, c, format!("sensor '{ty}'"))?;
        let projection = match ty.as_str() {
            "perspective" => Projection::Perspective,
            "orthographic" => Projection::Orthographic,
            "thinlens" => Projection::Perspective,
            t => {
                obj.mark_all();
                self.warn(
                    s,
                    c,
                    format!("sensor '{t}' is not supported: treated as 'perspective'"),
                );
                Projection::Perspective
            }
        };
        let to_world = obj.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let l = Mat3::from_mat4(to_world);
        // An orthographic sensor's scale sets the film's extent; its axes must still
        // be orthogonal (and none of length 0). A perspective one's should not scale.
        let axes = [l.x_axis, l.y_axis, l.z_axis].map(|a| a.normalize_or_zero());
        let orthogonal = axes.iter().all(|a| *a != glam::Vec3::ZERO)
            && [(0, 1), (0, 2), (1, 2)]
                .iter()
                .all(|&(i, j)| axes[i].dot(axes[j]).abs() < 1e-3);
        let unit = [l.x_axis, l.y_axis, l.z_axis]
            .iter()
            .all(|a| (a.length() - 1.0).abs() < 1e-3);
        if projection == Projection::Orthographic && !orthogonal {
            return Err(s.err(
                c,
                "sensor 'orthographic': to_world must not shear or flatten the view",
            ));
        }
        if !(orthogonal && unit) && projection == Projection::Perspective {
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
        // Mitsuba's thin lens: the aperture is required, the focus at the far clip
        // plane unless given.
        let lens = if ty == "thinlens" {
            let Some(radius) = obj.float("aperture_radius")? else {
                return Err(s.err(c, "sensor 'thinlens' needs an 'aperture_radius'"));
            };
            if !(radius.is_finite() && radius >= 0.0) {
                return Err(obj.err_param(
                    "aperture_radius",
                    format!("= {radius} must be a nonnegative number"),
                ));
            }
            let focus = obj.float("focus_distance")?.unwrap_or(far_clip);
            if !(focus.is_finite() && focus > 0.0) {
                return Err(obj.err_param("focus_distance", format!("= {focus} must be a positive distance")));
            }
            (radius > 0.0).then_some(Lens { radius, focus })
        } else {
            None
        };
        for p in ["focus_distance", "shutter_open", "shutter_close", "srf"] {
            obj.get(p);
        }
        for p in ["principal_point_offset_x", "principal_point_offset_y"] {
            if obj.float(p)?.is_some_and(|v| v != 0.0) {
                self.warn(s, c, format!("sensor '{p}' is not supported; ignored"));
            }
        }

        let (mut width, mut height, mut spp, mut filter, mut crop) = (768, 576, None, None, None);
        let (mut film_seen, mut sampler_seen) = (false, false);
        for ch in &obj.children {
            match ch {
                Child::Elem(n) if tag(*n) == "film" => {
                    if film_seen {
                        return Err(s.err(*n, "a sensor takes one <film>"));
                    }
                    film_seen = true;
                    (width, height, filter, crop) = self.film(s, *n)?;
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
            projection,
            fov,
            fov_axis,
            width,
            height,
            near_clip,
            far_clip,
            spp,
            filter,
            crop,
            lens,
        });
        Ok(())
    }

    /// The film's size and its `rfilter`; its other settings are Mitsuba's business.
    fn film(&mut self, s: Src, c: Node) -> Result<(u32, u32, Option<Filter>, Option<Crop>)> {
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
        // A crop window (Mitsuba's: the offsets 0 and the size the film's by default,
        // the window within the film).
        let offset = |name: &str, film: u32| -> Result<u32> {
            let v = obj.int(name)?.unwrap_or(0);
            if !(0..i64::from(film)).contains(&v) {
                return Err(obj.err_param(name, format!("= {v} is outside the film's [0, {film})")));
            }
            Ok(v as u32)
        };
        let (x, y) = (offset("crop_offset_x", w)?, offset("crop_offset_y", h)?);
        let (cw, ch) = (
            size("crop_width", i64::from(w - x))?,
            size("crop_height", i64::from(h - y))?,
        );
        if x + cw > w || y + ch > h {
            return Err(s.err(
                c,
                format!("film '{ty}': the crop window {cw} x {ch} at ({x}, {y}) leaves the {w} x {h} film"),
            ));
        }
        let cropped = (x, y, cw, ch) != (0, 0, w, h);
        let crop = cropped.then_some(Crop {
            film_width: w,
            film_height: h,
            x,
            y,
        });
        let (w, h) = (cw, ch);
        let mut filter = None;
        for ch in &obj.children {
            if let Child::Elem(n) = ch {
                if tag(*n) == "rfilter" {
                    filter = Some(self.rfilter(s, *n)?);
                }
            }
        }
        obj.mark_all();
        Ok((w, h, filter, crop))
    }

    /// A film's reconstruction filter: Mitsuba's `box`, `tent`, `gaussian`,
    /// `mitchell`, `catmullrom` and `lanczos`, at Mitsuba's default parameters; other
    /// parameters are read as the defaults, with a warning.
    fn rfilter(&mut self, s: Src, c: Node) -> Result<Filter> {
        self.check_attrs(s, c, &["type", "id", "name"]);
        let ty = self.attr_req(s, c, "type")?;
        let obj = self.collect(s, c, format!("rfilter '{ty}'"))?;
        let filter = match Filter::ALL.into_iter().find(|f| f.name() == ty) {
            Some(f) => f,
            None => {
                let names: Vec<String> = Filter::ALL.iter().map(|f| format!("'{}'", f.name())).collect();
                self.warn(
                    s,
                    c,
                    format!(
                        "rfilter '{ty}' read as 'gaussian': radtrace has {}",
                        names.join(", ")
                    ),
                );
                Filter::Gaussian
            }
        };
        // Mitsuba's parameters of each, and their defaults (the only values read).
        let params: &[(&str, f32)] = match filter {
            Filter::Box | Filter::Catmullrom => &[],
            Filter::Tent => &[("radius", 1.0)],
            Filter::Gaussian => &[("stddev", 0.5)],
            Filter::Mitchell => &[("B", 1.0 / 3.0), ("C", 1.0 / 3.0)],
            Filter::Lanczos => &[("lobes", 3.0)],
        };
        for &(name, default) in params {
            if let Some(v) = obj.float(name)?.filter(|v| (v - default).abs() > 1e-6) {
                self.warn(
                    s,
                    c,
                    format!("rfilter '{ty}' with {name} {v} read with Mitsuba's default, {default}"),
                );
            }
        }
        obj.mark_all();
        Ok(filter)
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
