//! Mitsuba's built-in shapes as triangle meshes in object space.

use glam::Vec3;

use crate::geometry::TriMesh;

/// Mitsuba's `rectangle`: `[-1,1]^2` in the z = 0 plane, normal +z; one patch.
pub fn rectangle() -> TriMesh {
    todo!("helper: scene")
}

/// Mitsuba's `cube`: `[-1,1]^3`, normals outward; six patches.
pub fn cube() -> TriMesh {
    todo!("helper: scene")
}

/// Mitsuba's `sphere`, tessellated finely with smooth normals, normals outward.
pub fn sphere(_center: Vec3, _radius: f32) -> TriMesh {
    todo!("helper: scene")
}

/// Mitsuba's `disk`: unit disk in the z = 0 plane, normal +z.
pub fn disk() -> TriMesh {
    todo!("helper: scene")
}
