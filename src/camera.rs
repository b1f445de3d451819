//! The pinhole camera of a Mitsuba `perspective` sensor.

use glam::{Mat4, Vec3};

use crate::accel::Ray;
use crate::scene::Sensor;

/// Generates primary rays through film positions.
#[derive(Debug, Clone)]
pub struct Camera {
    to_world: Mat4,
    origin: Vec3,
    tan_x: f32,
    tan_y: f32,
    width: f32,
    height: f32,
    near: f32,
    far: f32,
}

impl Camera {
    /// A camera for `sensor` with a film of `width x height` pixels (which may differ
    /// from the sensor's own film; the field of view is re-derived for the new aspect).
    pub fn new(sensor: &Sensor, width: u32, height: u32) -> Self {
        let mut s = sensor.clone();
        s.width = width;
        s.height = height;
        let (tan_x, tan_y) = s.tan_half_fov();
        Camera {
            to_world: s.to_world,
            origin: s.to_world.transform_point3(Vec3::ZERO),
            tan_x,
            tan_y,
            width: width as f32,
            height: height as f32,
            near: s.near_clip,
            far: s.far_clip,
        }
    }

    /// The ray through film position `(x, y)` in pixels (`(0, 0)` = top-left corner
    /// of the image, `(width, height)` = bottom-right). Its direction has unit
    /// length; `tmin`/`tmax` are the near and far clip planes.
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        // Mitsuba's camera space: +z forward, +y up, +x towards the image's left.
        let cx = (1.0 - 2.0 * x / self.width) * self.tan_x;
        let cy = (1.0 - 2.0 * y / self.height) * self.tan_y;
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

    /// The eye (centre of projection).
    pub fn eye(&self) -> Vec3 {
        self.origin
    }

    /// Pixels per unit length at unit distance in front of the eye, on the optical
    /// axis: how large something looks on the film.
    pub fn pixels_per_radian(&self) -> f32 {
        0.5 * self.height / self.tan_y
    }

    /// Projects a world point to film coordinates in pixels; `None` behind the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let local = self.to_world.inverse().transform_point3(p);
        if local.z <= 0.0 {
            return None;
        }
        let x = (1.0 - local.x / (local.z * self.tan_x)) * 0.5 * self.width;
        let y = (1.0 - local.y / (local.z * self.tan_y)) * 0.5 * self.height;
        Some((x, y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::FovAxis;

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
            fov,
            fov_axis: axis,
            width: w,
            height: h,
            near_clip: 0.01,
            far_clip: 1e4,
            spp: None,
            filter: None,
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
