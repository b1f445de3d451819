//! Emitter plugins: `point`, `spot`, `directional`, `constant`, `envmap`, `sunsky`, and
//! `area` (nested inside a shape).

use glam::{Mat4, Vec3};
use roxmltree::Node;

use super::document::{Loader, Src};
use super::properties::Target;
use crate::scene::sunsky::{self, SunPlace, SunSky};
use crate::scene::{Light, Rgb};
use crate::Result;

impl Loader {
    /// An `<emitter>` inside a shape: the radiance of an `area` emitter (a texture's
    /// mean) and the texture, if it has one, or `None` (with a warning) for any other
    /// type.
    pub(super) fn area_emitter(&mut self, s: Src, c: Node) -> Result<Option<(Rgb, Option<u32>)>> {
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
        let texture = obj.texture_image("radiance");
        self.finish_emitter(&obj);
        Ok(Some((radiance, texture)))
    }

    /// [`Loader::finish`] for an emitter: Mitsuba 3's `sampling_weight`, which every
    /// emitter takes and which changes how Mitsuba samples the lights, not what it
    /// renders, is accepted.
    fn finish_emitter(&mut self, obj: &super::properties::Obj) {
        obj.get("sampling_weight");
        self.finish(obj);
    }

    /// Adds `light` with its `id` (for tables and messages).
    fn add_light(&mut self, light: Light, id: Option<String>) {
        self.scene.lights.push(light);
        let i = self.scene.lights.len() - 1;
        self.scene.light_ids.resize(i, None);
        self.scene.light_ids.push(id);
    }

    pub(super) fn emitter(&mut self, s: Src, c: Node) -> Result<()> {
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
                self.finish_emitter(&obj);
                if intensity == Vec3::ZERO {
                    self.warn(s, c, "point light with zero intensity");
                }
                self.add_light(
                    Light::Point { position, intensity },
                    c.attribute("id").map(str::to_owned),
                );
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
                self.finish_emitter(&obj);
                if intensity == Vec3::ZERO {
                    self.warn(s, c, "spot light with zero intensity");
                }
                self.add_light(
                    Light::Spot {
                        position,
                        direction,
                        intensity,
                        cutoff_angle: cutoff.to_radians(),
                        beam_width: beam.to_radians(),
                    },
                    c.attribute("id").map(str::to_owned),
                );
            }
            "area" => {
                return Err(s.err(c, "an 'area' emitter must be nested inside a <shape>"));
            }
            "directional" => {
                let obj = self.collect(s, c, "emitter 'directional'".into())?;
                let dir = match (obj.vec3("direction")?, obj.transform("to_world")?) {
                    (Some(_), Some(_)) => {
                        return Err(s.err(
                            c,
                            "emitter 'directional': give either 'direction' or 'to_world', not both",
                        ))
                    }
                    (Some(d), None) => d,
                    (None, Some(m)) => m.transform_vector3(Vec3::Z),
                    (None, None) => Vec3::Z,
                };
                let direction = dir
                    .try_normalize()
                    .ok_or_else(|| obj.err_param("direction", "is the zero vector"))?;
                let irradiance = obj.emission("irradiance")?;
                self.finish_emitter(&obj);
                if irradiance == Vec3::ZERO {
                    self.warn(s, c, "directional light with zero irradiance");
                }
                self.add_light(
                    Light::Directional {
                        direction,
                        irradiance,
                    },
                    c.attribute("id").map(str::to_owned),
                );
            }
            "constant" | "envmap" => {
                if self.scene.environment().is_some() {
                    return Err(s.err(
                        c,
                        "a scene has at most one environment emitter ('constant' or 'envmap')",
                    ));
                }
                let obj = self.collect(s, c, format!("emitter '{ty}'"))?;
                // A sky photograph's sun, split off ([`hdr_sun`]).
                let mut sun = None;
                let (radiance, texture) = if ty == "constant" {
                    (obj.emission("radiance")?, None)
                } else {
                    let (path, fname) = self.file_param(&obj, "filename")?;
                    let scale = obj.float("scale")?.unwrap_or(1.0);
                    if !(scale.is_finite() && scale >= 0.0) {
                        return Err(obj.err_param("scale", format!("= {scale} must be a nonnegative number")));
                    }
                    // Mitsuba 0.6's parameters that change nothing here, and Mitsuba 3's
                    // choice of how to sample the map (not what it renders).
                    for p in ["gamma", "cache", "mis_compensation"] {
                        obj.get(p);
                    }
                    let t = self
                        .image(&path, false)
                        .map_err(|m| obj.err_param("filename", format!("= '{fname}': {m}")))?;
                    let (w, h) = t.size();
                    if w < 2 || h < 3 {
                        return Err(obj.err_param(
                            "filename",
                            format!(
                                "= '{fname}': an environment map needs at least 2 x 3 pixels, not {w} x {h}"
                            ),
                        ));
                    }
                    // A sky photograph's sun becomes a directional light beside it
                    // (see `hdr_sun`), unless the scene already has a sun.
                    let split = if self.scene.sun_disk.is_none() && scale > 0.0 {
                        crate::scene::hdr_sun::split(&t)
                    } else {
                        None
                    };
                    let t = match split {
                        Some((sky, found)) => {
                            sun = Some(crate::scene::hdr_sun::Sun {
                                irradiance: found.irradiance * scale,
                                ..found
                            });
                            sky
                        }
                        None => t,
                    };
                    self.scene.textures.push(t);
                    (Vec3::splat(scale), Some(self.scene.textures.len() as u32 - 1))
                };
                let rot = rotation(&obj)?;
                let to_local = rot.inverse();
                self.finish_emitter(&obj);
                let id = c.attribute("id").map(str::to_owned);
                self.add_light(
                    Light::Environment {
                        radiance,
                        texture,
                        to_local,
                    },
                    id.clone(),
                );
                if let Some(sun) = sun {
                    self.add_sun(
                        -(rot * sun.towards).normalize(),
                        sun.irradiance,
                        sun.solid_angle,
                        Some(id.as_deref().unwrap_or("envmap")),
                    );
                    self.note(
                        s,
                        c,
                        format!(
                            "envmap: its sun ({:.0} % of its light, {:.1e} sr) is a \
                             directional light, so that its shadows are ray traced",
                            100.0 * sun.share,
                            sun.solid_angle
                        ),
                    );
                }
            }
            "sunsky" => self.sunsky(s, c)?,
            t => self.warn(s, c, format!("emitter '{t}' is not supported; ignored")),
        }
        Ok(())
    }

    /// `sunsky`: the Hosek-Wilkie sky becomes an `envmap` ([`SunSky::bake`]) and its sun
    /// a `directional` light of the disk's irradiance, both in the emitter's frame
    /// (+z up, `to_world`).
    fn sunsky(&mut self, s: Src, c: Node) -> Result<()> {
        if self.scene.environment().is_some() {
            return Err(s.err(
                c,
                "a scene has at most one environment emitter ('constant', 'envmap' or 'sunsky')",
            ));
        }
        let obj = self.collect(s, c, "emitter 'sunsky'".into())?;
        let turbidity = obj.float("turbidity")?.unwrap_or(3.0);
        if !(1.0..=10.0).contains(&turbidity) {
            return Err(obj.err_param("turbidity", format!("= {turbidity} is outside [1, 10]")));
        }
        let albedo = obj.reflectance("albedo", 0.3)?;
        let scale = |name: &str| -> Result<f32> {
            let v = obj.float(name)?.unwrap_or(1.0);
            if !(v.is_finite() && v >= 0.0) {
                return Err(obj.err_param(name, format!("= {v} must be a nonnegative number")));
            }
            Ok(v)
        };
        let (sun_scale, sky_scale) = (scale("sun_scale")?, scale("sky_scale")?);
        // The disk's size changes neither its irradiance nor (here) its shadows: the sun
        // is a directional light. It sets the disk that camera and mirror rays see, of
        // that irradiance over its solid angle. `complex_sun` changes only the disk's
        // look (limb darkening), not its mean.
        let aperture = obj.float("sun_aperture")?.unwrap_or(sunsky::SUN_APERTURE as f32);
        if !(aperture > 0.0 && aperture < 180.0) {
            return Err(obj.err_param(
                "sun_aperture",
                format!("= {aperture} degrees is outside (0, 180)"),
            ));
        }
        obj.boolean("complex_sun", false)?;
        let rot = rotation(&obj)?;
        const PLACE: [&str; 9] = [
            "latitude",
            "longitude",
            "timezone",
            "year",
            "month",
            "day",
            "hour",
            "minute",
            "second",
        ];
        let sun_local = match obj.vec3("sun_direction")? {
            Some(d) => {
                if let Some(p) = PLACE.iter().find(|p| obj.get(p).is_some()) {
                    return Err(obj.err_param(
                        p,
                        "cannot be given with 'sun_direction' (the sun is placed by one or the other)",
                    ));
                }
                let d = d
                    .try_normalize()
                    .ok_or_else(|| obj.err_param("sun_direction", "is the zero vector"))?;
                (rot.inverse() * d).normalize().as_dvec3()
            }
            None => {
                let mut place = SunPlace::default();
                let float = |name: &str, v: &mut f64| -> Result<()> {
                    if let Some(f) = obj.float(name)? {
                        *v = f64::from(f);
                    }
                    Ok(())
                };
                float("latitude", &mut place.latitude)?;
                float("longitude", &mut place.longitude)?;
                float("timezone", &mut place.timezone)?;
                float("hour", &mut place.hour)?;
                float("minute", &mut place.minute)?;
                float("second", &mut place.second)?;
                for (name, v, range) in [
                    ("year", &mut place.year, -4000..=10000),
                    ("month", &mut place.month, 1..=12),
                    ("day", &mut place.day, 1..=31),
                ] {
                    if let Some(i) = obj.int(name)? {
                        if !range.contains(&i) {
                            return Err(obj.err_param(name, format!("= {i} is outside {range:?}")));
                        }
                        *v = i;
                    }
                }
                if !(-90.0..=90.0).contains(&place.latitude) {
                    return Err(
                        obj.err_param("latitude", format!("= {} is outside [-90, 90]", place.latitude))
                    );
                }
                place.sun_direction()
            }
        };
        if s.legacy {
            self.warn(
                s,
                c,
                "Mitsuba 0.6's 'sunsky' had +y up; it is read as Mitsuba 3 reads it, with +z up \
                 (turn it with 'to_world')",
            );
        }
        self.finish_emitter(&obj);
        let model = SunSky::new(f64::from(turbidity), albedo.to_array().map(f64::from), sun_local);
        if !model.sun_up() {
            self.warn(
                s,
                c,
                format!(
                    "the sun is {:.1} degrees below the horizon: the sunsky emits nothing (as in Mitsuba)",
                    -sun_local.z.asin().to_degrees()
                ),
            );
            return Ok(());
        }
        let id = c.attribute("id").map(str::to_owned);
        if sky_scale > 0.0 {
            let sky = model
                .bake(SKY_IMAGE_WIDTH, SKY_IMAGE_WIDTH / 2 + 1)
                .map_err(|m| s.err(c, format!("emitter 'sunsky': {m}")))?;
            self.scene.textures.push(sky);
            let sky = Light::Environment {
                radiance: Vec3::splat(sky_scale),
                texture: Some(self.scene.textures.len() as u32 - 1),
                to_local: sunsky::to_envmap_frame() * rot.inverse(),
            };
            self.add_light(sky, id.clone());
        }
        // Mitsuba leaves the sun's RGB unclamped; a low sun can go slightly negative in
        // blue, which no light here can carry.
        let irradiance = sunsky::rgb(model.sun_irradiance()).max(Vec3::ZERO) * sun_scale;
        if irradiance != Vec3::ZERO {
            let towards = (rot * sun_local.as_vec3()).normalize();
            let solid_angle = crate::sampling::cone_solid_angle((0.5 * aperture).to_radians());
            self.add_sun(-towards, irradiance, solid_angle, id.as_deref());
        }
        Ok(())
    }

    /// A sun (`sunsky`'s, or a sky photograph's): a directional light travelling
    /// along `direction`, named after the emitter `id` as "ID (sun)", and the disk of
    /// `solid_angle` that camera, mirror and glass rays see ([`crate::scene::SunDisk`]).
    fn add_sun(&mut self, direction: Vec3, irradiance: Vec3, solid_angle: f32, id: Option<&str>) {
        self.add_light(
            Light::Directional {
                direction,
                irradiance,
            },
            id.map(|i| format!("{i} (sun)")),
        );
        self.scene.sun_disk = Some(crate::scene::SunDisk {
            light: self.scene.lights.len() as u32 - 1,
            solid_angle,
        });
    }
}

/// The width of the image a `sunsky`'s sky is baked into (0.35 degrees a texel).
const SKY_IMAGE_WIDTH: u32 = 1024;

/// The rotation part of an infinite emitter's `to_world` (the identity without one); an
/// error when it is singular.
fn rotation(obj: &super::properties::Obj) -> Result<glam::Mat3> {
    let rot = glam::Mat3::from_mat4(obj.transform("to_world")?.unwrap_or(Mat4::IDENTITY));
    if rot.determinant().abs() <= 1e-12 {
        return Err(obj.err_param("to_world", "is singular"));
    }
    Ok(rot)
}
