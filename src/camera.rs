//! The cameras of Mitsuba's `perspective` sensor (a pinhole), `thinlens` one (a
//! pinhole's rays leaving a lens disk) and `orthographic` one (parallel rays).

use glam::{Mat4, Vec2, Vec3};

use crate::accel::Ray;
use crate::sampling::concentric_disk;
use crate::scene::{Lens, Projection, Sensor};

/// How large lengths look on the film: pixels per unit length at unit distance
/// from the eye (a perspective camera) or at any distance (parallel rays).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelScale {
    pub per_unit: f32,
    pub parallel: bool,
}

impl PixelScale {
    /// Pixels that a length `len` at distance `d` from the eye spans (unbounded at
    /// the eye of a perspective camera).
    pub fn pixels(&self, len: f32, d: f32) -> f32 {
        if self.parallel {
            len * self.per_unit
        } else if d > 0.0 {
            len * self.per_unit / d
        } else {
            f32::INFINITY
        }
    }

    /// The length that spans `pixels` pixels at distance `d` from the eye (the
    /// inverse of [`PixelScale::pixels`]; 0 at the eye of a perspective camera).
    pub fn length(&self, pixels: f32, d: f32) -> f32 {
        if self.parallel {
            pixels / self.per_unit
        } else {
            pixels * d.max(0.0) / self.per_unit
        }
    }
}

/// Generates primary rays through film positions.
#[derive(Debug, Clone)]
pub struct Camera {
    to_world: Mat4,
    /// Orthographic: the film's local extent is [-1, 1] x [-1, 1] / aspect, rays
    /// parallel along local +z.
    parallel: bool,
    /// The view direction (local +z in the world) and its length there (how
    /// `to_world` scales the clip distances); the film's scale along local x.
    axis: Vec3,
    axis_len: f32,
    x_len: f32,
    origin: Vec3,
    /// Perspective: tangents of the half field of view; orthographic: the film's
    /// half extent in local units (1 and 1 / aspect).
    tan_x: f32,
    tan_y: f32,
    /// The whole film's size in pixels, and where the image's top-left pixel lies
    /// on it (a cropped film: [`Sensor::crop`]).
    width: f32,
    height: f32,
    offset: (f32, f32),
    near: f32,
    far: f32,
    /// A thin lens (depth of field), if the sensor has one.
    lens: Option<Lens>,
}

impl Camera {
    /// A camera for `sensor` with an image of `width x height` pixels (which may differ
    /// from the sensor's own; the field of view is re-derived for the new aspect). A
    /// cropped film's image is its window, scaled with the image.
    pub fn new(sensor: &Sensor, width: u32, height: u32) -> Self {
        let mut s = sensor.clone();
        let (sx, sy) = (
            width as f32 / sensor.width as f32,
            height as f32 / sensor.height as f32,
        );
        let (film, offset) = match sensor.crop {
            Some(c) => (
                (
                    (c.film_width as f32 * sx).round().max(1.0),
                    (c.film_height as f32 * sy).round().max(1.0),
                ),
                (c.x as f32 * sx, c.y as f32 * sy),
            ),
            None => ((width as f32, height as f32), (0.0, 0.0)),
        };
        s.width = film.0 as u32;
        s.height = film.1 as u32;
        let (width, height) = (s.width, s.height);
        let parallel = s.projection == Projection::Orthographic;
        let (tan_x, tan_y) = if parallel {
            (1.0, height as f32 / width as f32)
        } else {
            s.tan_half_fov()
        };
        let z = s.to_world.transform_vector3(Vec3::Z);
        Camera {
            to_world: s.to_world,
            parallel,
            axis: z.normalize_or(Vec3::Z),
            axis_len: z.length(),
            x_len: s.to_world.transform_vector3(Vec3::X).length(),
            origin: s.to_world.transform_point3(Vec3::ZERO),
            tan_x,
            tan_y,
            width: width as f32,
            height: height as f32,
            offset,
            near: s.near_clip,
            far: s.far_clip,
            lens: if parallel { None } else { s.lens },
        }
    }

    /// The ray through film position `(x, y)` in pixels (`(0, 0)` = top-left corner
    /// of the image, `(width, height)` = bottom-right). Its direction has unit
    /// length; `tmin`/`tmax` are the near and far clip planes.
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let Vec2 { x: cx, y: cy } = self.film_point(x, y);
        if self.parallel {
            // From the near plane, along local +z; the clip planes are local
            // distances, scaled with the rest.
            return Ray {
                origin: self.to_world.transform_point3(Vec3::new(cx, cy, self.near)),
                dir: self.axis,
                tmin: 0.0,
                tmax: (self.far - self.near) * self.axis_len,
            };
        }
        let local = Vec3::new(cx, cy, 1.0);
        let inv_len = local.length_recip();
        let dir = self.to_world.transform_vector3(local * inv_len).normalize();
        // Clip planes are distances along the optical axis.
        Ray {
            origin: self.origin,
            dir,
            tmin: self.near / inv_len,
            tmax: self.far / inv_len,
        }
    }

    /// Where film position `(x, y)` (pixels, as [`Camera::ray`] takes it) lies in
    /// camera space: on the plane z = 1 (perspective) or the film's own extent
    /// (orthographic). Mitsuba's camera space: +z forward, +y up, +x towards the
    /// image's left.
    fn film_point(&self, x: f32, y: f32) -> Vec2 {
        let (x, y) = (x + self.offset.0, y + self.offset.1);
        Vec2::new(
            (1.0 - 2.0 * x / self.width) * self.tan_x,
            (1.0 - 2.0 * y / self.height) * self.tan_y,
        )
    }

    /// [`Camera::ray`] through a thin lens, from `u` in [0, 1)^2 (where on the lens:
    /// Mitsuba's `thinlens`): it leaves the lens disk at the concentric map of `u`
    /// and passes the point of the pinhole ray at the focus distance (along the view
    /// axis), so the plane in focus is sharp and the rest blurs. A pinhole camera
    /// gives [`Camera::ray`].
    pub fn ray_through_lens(&self, x: f32, y: f32, u: Vec2) -> Ray {
        let Some(lens) = self.lens else {
            return self.ray(x, y);
        };
        let focus = self.film_point(x, y).extend(1.0) * lens.focus;
        let on_lens = (concentric_disk(u) * lens.radius).extend(0.0);
        let local = (focus - on_lens).normalize();
        // Clip planes are distances along the optical axis.
        Ray {
            origin: self.to_world.transform_point3(on_lens),
            dir: self.to_world.transform_vector3(local).normalize(),
            tmin: self.near / local.z,
            tmax: self.far / local.z,
        }
    }

    /// The eye (centre of projection; an orthographic camera's film centre).
    pub fn eye(&self) -> Vec3 {
        self.origin
    }

    /// How large lengths look on the film (on the optical axis).
    pub fn pixel_scale(&self) -> PixelScale {
        PixelScale {
            per_unit: if self.parallel {
                0.5 * self.width / (self.tan_x * self.x_len)
            } else {
                0.5 * self.height / self.tan_y
            },
            parallel: self.parallel,
        }
    }

    /// Projects a world point to film coordinates in pixels; `None` behind the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let local = self.to_world.inverse().transform_point3(p);
        let depth = if self.parallel { 1.0 } else { local.z };
        if local.z <= 0.0 {
            return None;
        }
        let x = (1.0 - local.x / (depth * self.tan_x)) * 0.5 * self.width;
        let y = (1.0 - local.y / (depth * self.tan_y)) * 0.5 * self.height;
        Some((x - self.offset.0, y - self.offset.1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::FovAxis;
    use crate::scene::Projection;

    fn sensor(fov: f32, axis: FovAxis, w: u32, h: u32) -> Sensor {
        // Mitsuba lookat from (0,0,5) to the origin, up +y.
        let origin = Vec3::new(0.0, 0.0, 5.0);
        let dir = (Vec3::ZERO - origin).normalize();
        let left = Vec3::Y.cross(dir).normalize();
        let up = dir.cross(left);
        let to_world = Mat4::from_cols(
            left.extend(0.0),
            up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        );
        Sensor {
            to_world,
            projection: crate::scene::Projection::Perspective,
            fov,
            fov_axis: axis,
            width: w,
            height: h,
            near_clip: 0.01,
            far_clip: 1e4,
            spp: None,
            filter: None,
            crop: None,
            lens: None,
        }
    }

    #[test]
    fn centre_ray_looks_at_the_target_and_corners_span_the_fov() {
        let cam = Camera::new(&sensor(90.0, FovAxis::X, 200, 100), 200, 100);
        let r = cam.ray(100.0, 50.0);
        assert!((r.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Left edge of the image at 45 degrees: with the camera looking down -z and
        // up +y, image-left is world -x.
        let l = cam.ray(0.0, 50.0);
        assert!(
            (l.dir - Vec3::new(-1.0, 0.0, -1.0).normalize()).length() < 1e-6,
            "{:?}",
            l.dir
        );
        // Top edge: half the horizontal tangent (aspect 2).
        let t = cam.ray(100.0, 0.0);
        assert!(
            (t.dir - Vec3::new(0.0, 0.5, -1.0).normalize()).length() < 1e-6,
            "{:?}",
            t.dir
        );
    }

    #[test]
    fn fov_axis_y_fixes_the_vertical_angle() {
        let cam = Camera::new(&sensor(90.0, FovAxis::Y, 200, 100), 200, 100);
        let t = cam.ray(100.0, 0.0);
        assert!((t.dir - Vec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-6);
    }

    /// Mitsuba's orthographic camera: parallel rays along the view from the near
    /// plane, the film spanning local x in [-1, 1] and y in [-1, 1] / aspect, scaled
    /// by `to_world`; a unit length spans width / (2 scale) pixels at any distance.
    #[test]
    fn an_orthographic_camera_casts_parallel_rays_over_its_scaled_film() {
        let mut s = sensor(45.0, FovAxis::X, 200, 100);
        s.projection = Projection::Orthographic;
        s.to_world *= Mat4::from_scale(Vec3::splat(3.0));
        let cam = Camera::new(&s, 200, 100);
        let centre = cam.ray(100.0, 50.0);
        assert!((centre.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        assert!((centre.origin - Vec3::new(0.0, 0.0, 5.0 - 3.0 * 0.01)).length() < 1e-5);
        // Top-left corner: local (1, 0.5) (x is the image's left), scaled by 3; the
        // camera looks down -z, so local +x is world -x.
        let corner = cam.ray(0.0, 0.0);
        assert!((corner.dir - centre.dir).length() < 1e-6);
        let off = corner.origin - centre.origin;
        assert!((off - Vec3::new(-3.0, 1.5, 0.0)).length() < 1e-5, "{off}");
        assert!((cam.pixel_scale().pixels(1.0, 1.0) - 200.0 / 6.0).abs() < 1e-3);
        assert_eq!(
            cam.pixel_scale().pixels(1.0, 1.0),
            cam.pixel_scale().pixels(1.0, 50.0)
        );
        let (px, py) = cam.project(corner.at(4.0)).unwrap();
        assert!(px.abs() < 1e-3 && py.abs() < 1e-3, "{px} {py}");
    }

    /// A cropped film's image is its window: the cropped camera's pixel (x, y) is the
    /// whole film's (x + offset, y + offset), at the image's size or scaled with it.
    #[test]
    fn a_cropped_film_renders_its_window() {
        let full = sensor(50.0, FovAxis::X, 64, 48);
        let whole = Camera::new(&full, 64, 48);
        let mut cropped = full.clone();
        (cropped.width, cropped.height) = (20, 10);
        cropped.crop = Some(crate::scene::Crop {
            film_width: 64,
            film_height: 48,
            x: 30,
            y: 12,
        });
        let cam = Camera::new(&cropped, 20, 10);
        for (x, y) in [(0.5, 0.5), (19.5, 9.5), (7.25, 3.0)] {
            let (a, b) = (cam.ray(x, y), whole.ray(x + 30.0, y + 12.0));
            assert!((a.dir - b.dir).length() < 1e-6 && (a.origin - b.origin).length() < 1e-6);
        }
        // Twice the size: the window of a film twice as large.
        let twice = Camera::new(&cropped, 40, 20);
        let big = Camera::new(&full, 128, 96);
        let (a, b) = (twice.ray(3.0, 5.0), big.ray(63.0, 29.0));
        assert!((a.dir - b.dir).length() < 1e-6);
        assert!((cam.pixel_scale().pixels(1.0, 2.0) - whole.pixel_scale().pixels(1.0, 2.0)).abs() < 1e-4);
    }

    #[test]
    fn project_inverts_ray() {
        let cam = Camera::new(&sensor(40.0, FovAxis::X, 64, 48), 64, 48);
        for &(x, y) in &[(3.5, 7.25), (60.0, 40.0), (32.0, 24.0)] {
            let r = cam.ray(x, y);
            let (px, py) = cam.project(r.at(3.0)).unwrap();
            assert!(
                (px - x).abs() < 1e-3 && (py - y).abs() < 1e-3,
                "{px},{py} vs {x},{y}"
            );
        }
        assert!(cam.project(Vec3::new(0.0, 0.0, 10.0)).is_none());
    }

    #[test]
    fn near_clip_is_a_plane() {
        let mut s = sensor(90.0, FovAxis::X, 100, 100);
        s.near_clip = 1.0;
        let cam = Camera::new(&s, 100, 100);
        let r = cam.ray(0.0, 50.0);
        // The point at tmin lies on the plane one unit in front of the camera.
        assert!((r.at(r.tmin).z - 4.0).abs() < 1e-5);
    }
}

#[cfg(test)]
mod lens_tests {
    use super::*;
    use crate::scene::{FovAxis, Projection};

    /// A `thinlens` camera at (0, 0, 5) looking at the origin, 200 x 100 pixels.
    fn camera(lens: Option<Lens>) -> Camera {
        let to_world = Mat4::from_cols(
            Vec3::NEG_X.extend(0.0),
            Vec3::Y.extend(0.0),
            Vec3::NEG_Z.extend(0.0),
            Vec3::new(0.0, 0.0, 5.0).extend(1.0),
        );
        let sensor = Sensor {
            to_world,
            projection: Projection::Perspective,
            fov: 40.0,
            fov_axis: FovAxis::X,
            width: 200,
            height: 100,
            near_clip: 0.01,
            far_clip: 100.0,
            spp: None,
            filter: None,
            crop: None,
            lens,
        };
        Camera::new(&sensor, 200, 100)
    }

    /// Every ray of a pixel through a thin lens leaves the lens disk (radius r round
    /// the eye, in the plane facing the view) and passes the point that the pinhole's
    /// ray of that pixel meets at the focus distance along the view axis; without a
    /// lens the rays are the pinhole's.
    #[test]
    fn thin_lens_rays_leave_the_disk_and_meet_in_the_plane_of_focus() {
        let (r, focus) = (0.2, 3.0);
        let lensed = camera(Some(Lens { radius: r, focus }));
        let pinhole = camera(None);
        for (x, y) in [(100.0, 50.0), (13.5, 87.25), (190.0, 4.0)] {
            let p = pinhole.ray(x, y);
            // The pinhole ray's point in the plane z = 5 - focus.
            let sharp = p.origin + p.dir * (focus / -p.dir.z);
            let mut spread = 0.0f32;
            for k in 0..16 {
                let u = Vec2::new((k % 4) as f32 / 4.0 + 0.1, (k / 4) as f32 / 4.0 + 0.2);
                let ray = lensed.ray_through_lens(x, y, u);
                let off = ray.origin - Vec3::new(0.0, 0.0, 5.0);
                assert!(off.z.abs() < 1e-6 && off.length() <= r + 1e-5, "{off}");
                spread = spread.max(off.length());
                let at = ray.origin + ray.dir * (focus / -ray.dir.z);
                assert!((at - sharp).length() < 1e-4, "{at} vs {sharp}");
                assert!((ray.dir.length() - 1.0).abs() < 1e-5);
            }
            assert!(spread > 0.5 * r, "the lens samples stay near the eye: {spread}");
            let same = pinhole.ray_through_lens(x, y, Vec2::new(0.3, 0.7));
            assert_eq!((same.origin, same.dir), (p.origin, p.dir));
        }
    }
}
