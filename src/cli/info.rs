//! `radtrace info`.

use super::args::InfoArgs;
use super::load_scene;
use crate::scene::Light;
use crate::Result;

pub(super) fn cmd_info(a: InfoArgs) -> Result<()> {
    let scene = load_scene(&a.scene, false)?;
    // Spheres and disks are exact: their tessellation only indexes their records.
    let exact = scene.shapes.iter().filter(|s| s.mesh.quadric.is_some()).count();
    let tris: usize = scene
        .shapes
        .iter()
        .filter(|s| s.mesh.quadric.is_none())
        .map(|s| s.mesh.triangle_count())
        .sum();
    let patches: usize = scene.shapes.iter().map(|s| s.mesh.patches.len()).sum();
    say!("scene    {}", scene.path.display());
    say!(
        "shapes   {} ({} triangles, {} exact spheres and disks, {} patches)",
        scene.shapes.len(),
        tris,
        exact,
        patches
    );
    for (i, s) in scene.shapes.iter().enumerate() {
        let b = &scene.bsdfs[s.bsdf as usize];
        let size = match s.mesh.quadric {
            Some(_) => format!("{:>13}", "exact"),
            None => format!("{:>8} tris", s.mesh.triangle_count()),
        };
        say!(
            "  [{i}] {:<32} {size} {:>6} patches  bsdf {}{}",
            s.name,
            s.mesh.patches.len(),
            b.name,
            if s.emitter.is_some() { "  (emitter)" } else { "" }
        );
    }
    say!("lights   {}", scene.lights.len());
    for (i, l) in scene.lights.iter().enumerate() {
        match l {
            Light::Point { position, intensity } => {
                say!("  [{i}] point at {position:.3} intensity {intensity:.3}")
            }
            Light::Spot { position, direction, intensity, cutoff_angle, .. } => say!(
                "  [{i}] spot at {position:.3} towards {direction:.3} intensity {intensity:.3} cutoff {:.1} deg",
                cutoff_angle.to_degrees()
            ),
            Light::Area { shape, radiance, .. } => say!(
                "  [{i}] area on '{}' (area {:.4}) radiance {radiance:.3}",
                scene.shapes[*shape as usize].name,
                scene.shapes[*shape as usize].mesh.area()
            ),
            Light::Directional { direction, irradiance } => {
                say!("  [{i}] directional towards {direction:.3} irradiance {irradiance:.3}")
            }
            Light::Environment { radiance, texture, .. } => match texture {
                Some(t) => say!(
                    "  [{i}] envmap '{}' scale {:.3}",
                    scene.textures[*t as usize].name,
                    radiance.x
                ),
                None => say!("  [{i}] constant sky radiance {radiance:.3}"),
            },
        }
    }
    say!("views    {}", scene.sensors.len());
    for (i, s) in scene.sensors.iter().enumerate() {
        let o = s.to_world.transform_point3(glam::Vec3::ZERO);
        let d = s.to_world.transform_vector3(glam::Vec3::Z);
        say!(
            "  [{i}] {}x{} fov {:.1} ({:?}) from {o:.3} looking {d:.3}{}",
            s.width,
            s.height,
            s.fov,
            s.fov_axis,
            s.spp.map(|n| format!(", {n} spp")).unwrap_or_default()
        );
    }
    Ok(())
}
