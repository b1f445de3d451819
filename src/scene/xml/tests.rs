use std::f32::consts::PI;
use std::fs;
use std::path::PathBuf;

use glam::{DVec3, Mat4, Vec2, Vec3, Vec4};
use tempfile::TempDir;

use super::*;
use crate::geometry::Patch;
use crate::scene::sunsky::{self, SunSky};
use crate::scene::{Bsdf, BsdfKind, FovAxis, Light};

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="45"/></sensor>"#;

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

fn mat_close(a: Mat4, b: Mat4) -> bool {
    a.abs_diff_eq(b, 1e-5)
}

/// Writes `scene.xml` (and returns the folder, which must outlive the test).
fn write_scene(xml: &str) -> (TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    (dir, path)
}

/// A scene whose line 1 is `<scene>`, line 2 a sensor, and `lines` from line 3 on.
fn scene(lines: &[&str]) -> String {
    let mut s = format!("<scene version=\"3.0.0\">\n{SENSOR}\n");
    for l in lines {
        s.push_str(l);
        s.push('\n');
    }
    s.push_str("</scene>\n");
    s
}

fn load_raw(xml: &str, defines: &[(&str, &str)]) -> Result<Loaded> {
    let (_dir, path) = write_scene(xml);
    let defines: Vec<(String, String)> = defines
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    load(&path, &defines)
}

fn ok(lines: &[&str]) -> Loaded {
    match load_raw(&scene(lines), &[]) {
        Ok(l) => l,
        Err(e) => panic!("unexpected error: {e}"),
    }
}

/// Loads a scene that must fail at `line`; returns the message.
fn err_at(xml: &str, line: u32) -> String {
    let msg = match load_raw(xml, &[]) {
        Ok(_) => panic!("expected an error at line {line}:\n{xml}"),
        Err(e) => e.to_string(),
    };
    assert!(
        msg.contains(&format!("scene.xml:{line}:")),
        "error should name scene.xml:{line}: but is: {msg}"
    );
    assert!(!msg.contains('\n'), "one line: {msg}");
    msg
}

fn err(lines: &[&str], line: u32) -> String {
    err_at(&scene(lines), line)
}

fn has_warning(l: &Loaded, line: u32, text: &str) -> bool {
    l.warnings
        .iter()
        .any(|w| w.contains(&format!("scene.xml:{line}:")) && w.contains(text))
}

fn sensor_with(transform: &str) -> Loaded {
    let xml = format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\
         <transform name=\"to_world\">{transform}</transform></sensor>\n</scene>"
    );
    match load_raw(&xml, &[]) {
        Ok(l) => l,
        Err(e) => panic!("{e}"),
    }
}

// ------------------------------------------------------------- transforms

#[test]
fn transform_ops_compose_in_document_order() {
    let l = sensor_with(r#"<scale value="2"/><rotate z="1" angle="90"/><translate x="1" y="2" z="3"/>"#);
    let m = l.scene.sensors[0].to_world;
    let expected = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_rotation_z(PI / 2.0)
        * Mat4::from_scale(Vec3::splat(2.0));
    assert!(mat_close(m, expected));
    // By hand: (1,0,0) -> scale (2,0,0) -> rotate (0,2,0) -> translate (1,4,3).
    assert!(close(m.transform_point3(Vec3::X), Vec3::new(1.0, 4.0, 3.0)));
    // Reversed order gives another matrix: translate first, then rotate and scale.
    let l = sensor_with(
        r#"<translate value="1, 2, 3"/><rotate value="0 0 1" angle="90"/><scale x="2" y="2" z="2"/>"#,
    );
    let m = l.scene.sensors[0].to_world;
    // (0,0,0) -> (1,2,3) -> (-2,1,3) -> (-4,2,6).
    assert!(close(m.transform_point3(Vec3::ZERO), Vec3::new(-4.0, 2.0, 6.0)));
}

#[test]
fn scale_with_defaults_and_three_values() {
    let m = sensor_with(r#"<scale x="3"/>"#).scene.sensors[0].to_world;
    assert!(mat_close(m, Mat4::from_scale(Vec3::new(3.0, 1.0, 1.0))));
    let m = sensor_with(r#"<scale value="1 2 3"/>"#).scene.sensors[0].to_world;
    assert!(mat_close(m, Mat4::from_scale(Vec3::new(1.0, 2.0, 3.0))));
}

#[test]
fn lookat_gives_mitsuba_columns() {
    let l = sensor_with(r#"<lookat origin="1, 2, 10" target="1, 2, 0" up="0, 1, 0"/>"#);
    let m = l.scene.sensors[0].to_world;
    // dir = -z, left = normalize(up x dir) = -x, up' = dir x left = +y.
    assert_eq!(m.x_axis, Vec4::new(-1.0, 0.0, 0.0, 0.0));
    assert_eq!(m.y_axis, Vec4::new(0.0, 1.0, 0.0, 0.0));
    assert_eq!(m.z_axis, Vec4::new(0.0, 0.0, -1.0, 0.0));
    assert_eq!(m.w_axis, Vec4::new(1.0, 2.0, 10.0, 1.0));
    // An oblique camera: columns orthonormal, z towards the target.
    let l = sensor_with(r#"<lookat origin="0, 0, 0" target="1, 1, 0" up="0, 0, 1"/>"#);
    let m = l.scene.sensors[0].to_world;
    let s = 0.5f32.sqrt();
    assert!(close(m.z_axis.truncate(), Vec3::new(s, s, 0.0)));
    assert!(close(m.x_axis.truncate(), Vec3::new(-s, s, 0.0)));
    assert!(close(m.y_axis.truncate(), Vec3::Z));
}

#[test]
fn matrix_is_row_major() {
    let l = sensor_with(r#"<matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/>"#);
    let m = l.scene.sensors[0].to_world;
    assert_eq!(m.w_axis, Vec4::new(5.0, 6.0, 7.0, 1.0));
    assert!(close(m.transform_point3(Vec3::ONE), Vec3::new(6.0, 7.0, 8.0)));
}

#[test]
fn degenerate_lookat_is_an_error() {
    let m = err(
        &[
            r#"<emitter type="spot"><transform name="to_world">"#,
            r#"<lookat origin="1,1,1" target="1,1,1" up="0,1,0"/>"#,
            "</transform></emitter>",
        ],
        4,
    );
    assert!(m.contains("coincide"), "{m}");
    let m = err(
        &[
            r#"<emitter type="spot"><transform name="to_world">"#,
            r#"<lookat origin="0,0,0" target="0,5,0" up="0,1,0"/>"#,
            "</transform></emitter>",
        ],
        4,
    );
    assert!(m.contains("parallel"), "{m}");
}

// ------------------------------------------------------------- parameters

const PARAM_SCENE: &str = r#"<scene version="3.0.0">
<default name="spp" value="16"/>
<default name="res" value="256"/>
<sensor type="perspective">
  <float name="fov" value="40"/>
  <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
  <film type="hdrfilm">
    <integer name="width" value="$res"/><integer name="height" value="$res"/>
  </film>
</sensor>
</scene>"#;

#[test]
fn parameters_take_defaults() {
    let l = load_raw(PARAM_SCENE, &[]).unwrap();
    let s = &l.scene.sensors[0];
    assert_eq!((s.spp, s.width, s.height), (Some(16), 256, 256));
}

#[test]
fn defines_override_defaults_and_unknown_defines_are_errors() {
    let l = load_raw(PARAM_SCENE, &[("spp", "64")]).unwrap();
    let s = &l.scene.sensors[0];
    assert_eq!((s.spp, s.width), (Some(64), 256));
    assert!(!l.warnings.iter().any(|w| w.contains("spp")), "{:?}", l.warnings);
    // A define the scene neither declares nor uses: Mitsuba 3's "unused parameters".
    let e = load_raw(PARAM_SCENE, &[("spp", "64"), ("colour", "red"), ("hue", "1")])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("scene.xml") && e.contains("-D colour, -D hue") && !e.contains("-D spp"),
        "{e}"
    );
}

#[test]
fn undefined_parameter_is_an_error_with_place() {
    let m = err(
        &[r#"<shape type="sphere"><float name="radius" value="$size"/></shape>"#],
        3,
    );
    assert!(m.contains("$size"), "{m}");
    // With a define it loads.
    let l = load_raw(
        &scene(&[r#"<shape type="sphere"><float name="radius" value="$size"/></shape>"#]),
        &[("size", "2")],
    )
    .unwrap();
    let b = l.scene.shapes[0].mesh.bounds().unwrap();
    assert!((b.1.x - 2.0).abs() < 1e-5);
}

// ------------------------------------------------------------- values

/// The radiance of each area light, in shape order.
fn radiances(l: &Loaded) -> Vec<Vec3> {
    l.scene
        .lights
        .iter()
        .filter_map(|light| match light {
            Light::Area { radiance, .. } => Some(*radiance),
            _ => None,
        })
        .collect()
}

/// Spectra as Mitsuba 3.9's RGB modes take them (its renders and
/// `spectrum_list_to_srgb`): in an emitter, one value is the equal-energy white and
/// pairs are weighed evenly; the plugins `uniform`, `d65` and `srgb` are what they
/// say; `regular` and `irregular` as their pairs; and a reflectance's pairs are seen
/// under D65 (a flat one stays grey).
#[test]
fn spectra_in_emitters_and_spectrum_plugins() {
    let light =
        |body: &str| format!(r#"<shape type="rectangle"><emitter type="area">{body}</emitter></shape>"#);
    let l = ok(&[
        &light(r#"<spectrum name="radiance" value="0.5"/>"#),
        &light(r#"<spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/>"#),
        &light(r#"<spectrum name="radiance" type="uniform"><float name="value" value="0.5"/></spectrum>"#),
        &light(r#"<spectrum name="radiance" type="d65"><float name="scale" value="2"/></spectrum>"#),
        &light(
            r#"<spectrum name="radiance" type="srgb"><rgb name="color" value="0.2, 0.4, 0.6"/></spectrum>"#,
        ),
        &light(
            r#"<spectrum name="radiance" type="irregular"><string name="wavelengths" value="400, 500, 600, 700"/><string name="values" value="0, 8, 15.6, 18.4"/></spectrum>"#,
        ),
        &light(
            r#"<spectrum name="radiance" type="regular"><float name="wavelength_min" value="400"/><float name="wavelength_max" value="700"/><string name="values" value="0, 8, 15.6, 18.4"/></spectrum>"#,
        ),
        r#"<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.5, 700:0.5"/></bsdf></shape>"#,
    ]);
    let r = radiances(&l);
    let cbox = Vec3::new(20.710821, 10.854642, 2.771151);
    let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 1e-5 * b.max_element().max(1.0);
    assert!(
        near(r[0], Vec3::new(0.60239697, 0.47414547, 0.45445794)),
        "{}",
        r[0]
    );
    assert!(near(r[1], cbox), "{}", r[1]);
    assert_eq!(r[2], Vec3::splat(0.5));
    assert_eq!(r[3], Vec3::splat(2.0));
    assert!(close(r[4], Vec3::new(0.2, 0.4, 0.6)));
    assert!(near(r[5], cbox), "{}", r[5]);
    assert!(near(r[6], cbox), "{}", r[6]);
    let grey = match &l.scene.bsdfs[l.scene.shapes[7].bsdf as usize].kind {
        BsdfKind::Diffuse { reflectance } => *reflectance,
        k => panic!("{k:?}"),
    };
    // Mitsuba's `spectrum_list_to_srgb`: (0.497671, 0.499878, 0.497455).
    assert!(near(grey, Vec3::new(0.497671, 0.499878, 0.497455)), "{grey}");
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
}

/// A `null` bsdf is an invisible surface, as in Mitsuba: its shape is left out,
/// whether the bsdf is nested or named by id; an emitter on one keeps its shape
/// (black), with a warning.
#[test]
fn a_null_bsdf_leaves_its_shape_out() {
    let l = ok(&[
        r#"<bsdf type="null" id="nothing"/>"#,
        r#"<shape type="cube"><bsdf type="null"/></shape>"#,
        r#"<shape type="sphere"><ref id="nothing"/></shape>"#,
        r#"<shape type="rectangle"><bsdf type="diffuse"/></shape>"#,
        r#"<shape type="disk"><ref id="nothing"/><emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>"#,
    ]);
    assert_eq!(l.scene.shapes.len(), 2);
    assert!(
        l.scene.shapes[0].name.starts_with("rectangle"),
        "{}",
        l.scene.shapes[0].name
    );
    assert_eq!(l.scene.lights.len(), 1);
    assert!(matches!(
        l.scene.bsdfs[l.scene.shapes[1].bsdf as usize].kind,
        BsdfKind::Diffuse { reflectance } if reflectance == Vec3::ZERO
    ));
    assert!(has_warning(&l, 7, "'null' bsdf"), "{:?}", l.warnings);
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
}

/// A reflectance out of gamut is clamped with a warning naming the line; a spectrum
/// that cannot be read gives one error line.
#[test]
fn bad_spectra_warn_or_fail_at_their_line() {
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="500:0.2, 520:0.9, 540:0.1"/></bsdf></shape>"#,
    ]);
    assert!(has_warning(&l, 3, "gamut"), "{:?}", l.warnings);
    let bsdf = |spec: &str| format!(r#"<shape type="cube"><bsdf type="diffuse">{spec}</bsdf></shape>"#);
    let m = err(&[&bsdf(r#"<spectrum name="reflectance" value="500:0.5"/>"#)], 3);
    assert!(m.contains("two wavelength:value pairs"), "{m}");
    let m = err(
        &[&bsdf(
            r#"<spectrum name="reflectance" value="600:0.5, 500:0.5"/>"#,
        )],
        3,
    );
    assert!(m.contains("increasing"), "{m}");
    let m = err(
        &[&bsdf(
            r#"<spectrum name="reflectance" type="blackbody"><float name="temperature" value="3000"/></spectrum>"#,
        )],
        3,
    );
    assert!(m.contains("blackbody"), "{m}");
    let m = err(
        &[&bsdf(r#"<spectrum name="reflectance" type="fluorescent"/>"#)],
        3,
    );
    assert!(m.contains("unknown spectrum type"), "{m}");
    let m = err(
        &[&bsdf(
            r#"<spectrum name="reflectance" type="irregular"><string name="wavelengths" value="400, 500"/><string name="values" value="0.5"/></spectrum>"#,
        )],
        3,
    );
    assert!(m.contains("1 values for 2 wavelengths"), "{m}");
}

#[test]
fn rgb_spectrum_and_points() {
    let l = ok(&[
        r#"<bsdf type="diffuse" id="a"><rgb name="reflectance" value="0.2, 0.4 0.6"/></bsdf>"#,
        r#"<bsdf type="diffuse" id="b"><rgb name="reflectance" value="0.3"/></bsdf>"#,
        r#"<bsdf type="diffuse" id="c"><spectrum name="reflectance" value="0.25"/></bsdf>"#,
        r#"<bsdf type="diffuse" id="d"><spectrum name="reflectance" value="400:0.1, 700:0.3"/></bsdf>"#,
        r#"<bsdf type="diffuse" id="e"><float name="reflectance" value="0.7"/></bsdf>"#,
        r#"<shape type="cube"><ref id="a"/></shape>"#,
        r#"<shape type="cube"><ref id="b"/></shape>"#,
        r#"<shape type="cube"><ref id="c"/></shape>"#,
        r#"<shape type="cube"><ref id="d"/></shape>"#,
        r#"<shape type="cube"><ref name="bsdf" id="e"/></shape>"#,
        r#"<emitter type="point"><point name="position" value="1, 2, 3"/></emitter>"#,
        r#"<emitter type="point"><point name="position" x="4" z="6"/><rgb name="intensity" value="5"/></emitter>"#,
    ]);
    let refl: Vec<Vec3> = l
        .scene
        .shapes
        .iter()
        .map(|s| match &l.scene.bsdfs[s.bsdf as usize].kind {
            BsdfKind::Diffuse { reflectance } => *reflectance,
            k => panic!("{k:?}"),
        })
        .collect();
    assert!(close(refl[0], Vec3::new(0.2, 0.4, 0.6)));
    assert!(close(refl[1], Vec3::splat(0.3)));
    assert!(close(refl[2], Vec3::splat(0.25)));
    // Mitsuba 3.9's colour for the spectrum (its `spectrum_list_to_srgb`).
    assert!(
        close(refl[3], Vec3::new(0.260364, 0.195267, 0.126699)),
        "{}",
        refl[3]
    );
    assert!(close(refl[4], Vec3::splat(0.7)));
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert_eq!(
        l.scene.lights,
        vec![
            Light::Point {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: Vec3::ONE
            },
            Light::Point {
                position: Vec3::new(4.0, 0.0, 6.0),
                intensity: Vec3::splat(5.0)
            },
        ]
    );
}

#[test]
fn point_light_from_to_world() {
    let l = ok(&[
        r#"<emitter type="point"><transform name="to_world"><translate x="1" y="5"/></transform><rgb name="intensity" value="1 2 3"/></emitter>"#,
    ]);
    assert_eq!(
        l.scene.lights[0],
        Light::Point {
            position: Vec3::new(1.0, 5.0, 0.0),
            intensity: Vec3::new(1.0, 2.0, 3.0)
        }
    );
}

// ------------------------------------------------------------- emitters

#[test]
fn spot_angles_in_radians_and_default_beam() {
    let l = ok(&[
        r#"<emitter type="spot"><transform name="to_world"><lookat origin="0, 4, 0" target="0, 0, 0" up="0, 0, 1"/></transform>"#,
        r#"<float name="cutoff_angle" value="30"/><rgb name="intensity" value="10"/></emitter>"#,
        r#"<emitter type="spot"><float name="cutoff_angle" value="40"/><float name="beam_width" value="10"/></emitter>"#,
        r#"<emitter type="spot"/>"#,
    ]);
    let Light::Spot {
        position,
        direction,
        intensity,
        cutoff_angle,
        beam_width,
    } = l.scene.lights[0]
    else {
        panic!()
    };
    assert!(close(position, Vec3::new(0.0, 4.0, 0.0)));
    assert!(close(direction, Vec3::NEG_Y));
    assert_eq!(intensity, Vec3::splat(10.0));
    assert!((cutoff_angle - 30f32.to_radians()).abs() < 1e-6);
    assert!((beam_width - 22.5f32.to_radians()).abs() < 1e-6);
    let Light::Spot {
        cutoff_angle,
        beam_width,
        ..
    } = l.scene.lights[1]
    else {
        panic!()
    };
    assert!((cutoff_angle - 40f32.to_radians()).abs() < 1e-6);
    assert!((beam_width - 10f32.to_radians()).abs() < 1e-6);
    let Light::Spot {
        position,
        direction,
        intensity,
        cutoff_angle,
        beam_width,
    } = l.scene.lights[2]
    else {
        panic!()
    };
    assert_eq!((position, direction, intensity), (Vec3::ZERO, Vec3::Z, Vec3::ONE));
    assert!((cutoff_angle - 20f32.to_radians()).abs() < 1e-6);
    assert!((beam_width - 15f32.to_radians()).abs() < 1e-6);
}

#[test]
fn area_emitter_links_shape_and_light() {
    let l = ok(&[
        r#"<shape type="rectangle" id="lamp">"#,
        r#"  <emitter type="area"><rgb name="radiance" value="10, 8, 6"/></emitter>"#,
        "</shape>",
        r#"<shape type="cube"/>"#,
        r#"<emitter type="point"/>"#,
    ]);
    assert_eq!(l.scene.shapes.len(), 2);
    assert_eq!(l.scene.shapes[0].name, "lamp");
    assert_eq!(l.scene.shapes[0].emitter, Some(0));
    assert_eq!(l.scene.shapes[1].emitter, None);
    assert_eq!(
        l.scene.lights[0],
        Light::Area {
            shape: 0,
            radiance: Vec3::new(10.0, 8.0, 6.0),
            texture: None,
        }
    );
    assert!(matches!(l.scene.lights[1], Light::Point { .. }));
    // Neither names a BSDF: the lamp gets Mitsuba's black default for emitters, the
    // cube the diffuse 0.5.
    let kind = |s: usize| &l.scene.bsdfs[l.scene.shapes[s].bsdf as usize].kind;
    assert_eq!(
        *kind(0),
        BsdfKind::Diffuse {
            reflectance: Vec3::ZERO
        }
    );
    assert_eq!(*kind(1), Bsdf::default().kind);
    assert_eq!(l.scene.bsdfs.len(), 2);
}

#[test]
fn unsupported_emitters_warn() {
    let l = ok(&[
        r#"<emitter type="projector"/>"#,
        r#"<emitter type="point"><rgb name="intensity" value="0"/></emitter>"#,
    ]);
    assert_eq!(l.scene.lights.len(), 1);
    assert!(has_warning(&l, 3, "'projector'"));
    assert!(has_warning(&l, 4, "zero intensity"));
}

/// An image texture where radtrace takes only its mean warns, naming the line: a
/// dielectric's transmittance. A diffuse reflectance texture, read texel by texel,
/// does not, nor an area light's radiance (a checkerboard of 4 and 2 shines 3, its
/// mean, and shows its squares where seen: a note says so).
#[test]
fn textures_taken_as_their_mean_warn() {
    let checker = |name: &str| {
        format!(
            r#"<texture type="checkerboard" name="{name}"><rgb name="color0" value="0.8"/><rgb name="color1" value="0.4"/></texture>"#
        )
    };
    let (radiance, glass, diffuse) = (
        checker("radiance"),
        checker("specular_transmittance"),
        checker("reflectance"),
    );
    let l = ok(&[
        r#"<shape type="rectangle"><emitter type="area">"#,
        &radiance.replace("0.8", "4").replace("0.4", "2"),
        r#"</emitter></shape>"#,
        r#"<shape type="cube"><bsdf type="dielectric">"#,
        &glass,
        r#"</bsdf></shape>"#,
        r#"<shape type="cube"><bsdf type="diffuse">"#,
        &diffuse,
        r#"</bsdf></shape>"#,
    ]);
    assert!(
        l.notes
            .iter()
            .any(|n| n.contains("scene.xml:3:") && n.contains("mean (3.0000")),
        "{:?}",
        l.notes
    );
    assert!(has_warning(
        &l,
        7,
        "a texture as 'specular_transmittance' is not supported"
    ));
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
    match &l.scene.lights[..] {
        [Light::Area { radiance, .. }] => assert_eq!(*radiance, Vec3::splat(3.0)),
        other => panic!("{other:?}"),
    }
}

/// The sun and the sky: `directional` from `direction` or `to_world` (+z), `constant`,
/// and `envmap` (an image beside the scene, its `scale` and `to_world`); a missing
/// image, a second sky and both `direction` and `to_world` are errors naming the line.
#[test]
fn daylight_emitters_read_as_mitsuba_and_bad_ones_fail_with_their_line() {
    let l = ok(&[
        r#"<emitter type="directional"><vector name="direction" value="0, -2, 0"/><rgb name="irradiance" value="3, 2, 1"/></emitter>"#,
        r#"<emitter type="directional"><transform name="to_world"><lookat origin="0,0,0" target="1,0,0" up="0,1,0"/></transform></emitter>"#,
        r#"<emitter type="constant"><rgb name="radiance" value="0.5, 0.6, 0.7"/></emitter>"#,
    ]);
    assert!(
        !l.warnings.iter().any(|w| w.contains("emitter")),
        "{:?}",
        l.warnings
    );
    match &l.scene.lights[..] {
        [Light::Directional {
            direction: d0,
            irradiance,
        }, Light::Directional {
            direction: d1,
            irradiance: e1,
        }, Light::Environment {
            radiance,
            texture: None,
            ..
        }] => {
            assert!(close(*d0, -Vec3::Y) && close(*irradiance, Vec3::new(3.0, 2.0, 1.0)));
            assert!(close(*d1, Vec3::X) && close(*e1, Vec3::ONE));
            assert!(close(*radiance, Vec3::new(0.5, 0.6, 0.7)));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(l.scene.sky(Vec3::X), Vec3::new(0.5, 0.6, 0.7));

    // An envmap: a 2 x 3 image, rotated 90 degrees about y; row 0 (the zenith) red.
    let dir = tempfile::tempdir().unwrap();
    exr::prelude::write_rgb_file(dir.path().join("sky.exr"), 2, 3, |_, y| {
        if y == 0 {
            (4.0f32, 0.0f32, 0.0f32)
        } else {
            (0.0, 0.0, 1.0)
        }
    })
    .unwrap();
    let xml = format!(
        "<scene version=\"3.0.0\">\n{SENSOR}\n<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/>\
         <float name=\"scale\" value=\"2\"/><transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/></transform></emitter>\n</scene>"
    );
    let path = dir.path().join("scene.xml");
    fs::write(&path, &xml).unwrap();
    let l = load(&path, &[]).unwrap();
    assert!(close(l.scene.sky(Vec3::Y), Vec3::new(8.0, 0.0, 0.0)));
    assert!(close(l.scene.sky(-Vec3::Y), Vec3::new(0.0, 0.0, 2.0)));
    // Halfway down, the middle row: blue, whichever way (the rotation keeps y).
    assert!(close(l.scene.sky(Vec3::X), Vec3::new(0.0, 0.0, 2.0)));

    let e = err(
        &[r#"<emitter type="envmap"><string name="filename" value="nowhere.exr"/></emitter>"#],
        3,
    );
    assert!(e.contains("filename") && e.contains("nowhere.exr"), "{e}");
    let e = err(
        &[r#"<emitter type="constant"/>"#, r#"<emitter type="constant"/>"#],
        4,
    );
    assert!(e.contains("at most one"), "{e}");
    let e = err(
        &[
            r#"<emitter type="directional"><vector name="direction" value="0,0,1"/><transform name="to_world"/></emitter>"#,
        ],
        3,
    );
    assert!(e.contains("not both"), "{e}");
    let e = err(
        &[r#"<emitter type="directional"><vector name="direction" value="0,0,0"/></emitter>"#],
        3,
    );
    assert!(e.contains("direction"), "{e}");
}

/// An `envmap` whose sun (one texel 10^5 times its sky) holds most of its light: the
/// sun becomes a directional light along its texel's direction (turned by `to_world`),
/// with a disk that rays see, and a note naming the line; the sky keeps only the
/// texel's share under the cutoff. A map with no such sun stays whole.
#[test]
fn an_envmaps_sun_becomes_a_directional_light() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, sun: f32| {
        exr::prelude::write_rgb_file(dir.path().join(name), 64, 33, |x, y| {
            if (x, y) == (16, 8) {
                (sun, sun, sun)
            } else {
                (1.0f32, 1.0f32, 1.0f32)
            }
        })
        .unwrap();
    };
    write("sun.exr", 1.0e5);
    write("flat.exr", 1.0);
    let load_sky = |file: &str| {
        let xml = format!(
            "<scene version=\"3.0.0\">\n{SENSOR}\n<emitter type=\"envmap\"><string name=\"filename\" value=\"{file}\"/>\
             <float name=\"scale\" value=\"2\"/><transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/></transform></emitter>\n</scene>"
        );
        let path = dir.path().join("scene.xml");
        fs::write(&path, &xml).unwrap();
        load(&path, &[]).unwrap()
    };
    let l = load_sky("sun.exr");
    assert!(
        l.notes
            .iter()
            .any(|n| n.contains("scene.xml:3:") && n.contains("its sun")),
        "{:?}",
        l.notes
    );
    let suns: Vec<_> = l
        .scene
        .lights
        .iter()
        .filter_map(|x| match x {
            Light::Directional {
                direction,
                irradiance,
            } => Some((*direction, *irradiance)),
            _ => None,
        })
        .collect();
    assert_eq!(suns.len(), 1);
    let (d, e) = suns[0];
    // Texel (16, 8) looks along (0.707, 0.707, 0) in the map; turned 90 degrees about
    // y, (0, 0.707, -0.707): the light travels the other way.
    let want = Vec3::new(0.0, -1.0, 1.0).normalize();
    assert!((d - want).length() < 1e-3, "{d}");
    // Its excess over the cutoff (1 % of the peak) times the texel's solid angle and
    // the scale.
    let omega = (2.0 * PI / 64.0) * (PI / 32.0) * (PI / 4.0).sin();
    let want_e = 2.0 * (1.0e5 - 1.0e3) * omega;
    assert!((e.x - want_e).abs() < 1e-3 * want_e, "{e} vs {want_e}");
    assert!(l.scene.sun_seen(-d).x > 1.0e4);
    assert!(l.scene.sky(-d).x <= 2.0 * 1.0e3 * 1.001, "{}", l.scene.sky(-d));
    let l = load_sky("flat.exr");
    assert!(l.notes.is_empty(), "{:?}", l.notes);
    assert!(!l
        .scene
        .lights
        .iter()
        .any(|x| matches!(x, Light::Directional { .. })));
}

/// `sunsky`: a sky image and a sun, in the emitter's frame (+z up, here turned to +y
/// by `to_world`), the sun placed by `sun_direction` (world space, as Mitsuba) or by
/// date, time and place; bad values and a sun below the horizon are reported with
/// their line.
#[test]
fn sunsky_reads_as_a_sky_image_and_a_sun() {
    let l = ok(&[
        r#"<emitter type="sunsky" id="day"><float name="turbidity" value="4"/><vector name="sun_direction" value="1, 1, 0"/>"#,
        r#"<float name="sky_scale" value="2"/><transform name="to_world"><rotate x="1" angle="-90"/></transform></emitter>"#,
    ]);
    assert!(
        !l.warnings.iter().any(|w| w.contains("sunsky")),
        "{:?}",
        l.warnings
    );
    let model = SunSky::new(4.0, [0.3; 3], DVec3::new(1.0, 0.0, 1.0));
    match &l.scene.lights[..] {
        [Light::Environment { radiance, .. }, Light::Directional {
            direction,
            irradiance,
        }] => {
            assert_eq!(*radiance, Vec3::splat(2.0));
            assert!(
                close(*direction, -Vec3::new(1.0, 1.0, 0.0).normalize()),
                "{direction}"
            );
            assert!(close(*irradiance, sunsky::rgb(model.sun_irradiance())));
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        l.scene.light_ids,
        [Some("day".to_string()), Some("day (sun)".to_string())]
    );
    // World +y is the model's zenith; world -z its -y; below the floor, black.
    let zenith = sunsky::rgb(model.sky_radiance(DVec3::Z)) * 2.0;
    assert!((l.scene.sky(Vec3::Y) - zenith).abs().max_element() < 1e-4 * zenith.max_element());
    let side = sunsky::rgb(model.sky_radiance(DVec3::new(0.0, -1.0, 0.3).normalize())) * 2.0;
    let got = l.scene.sky(Vec3::new(0.0, 0.3, 1.0).normalize());
    assert!(
        (got - side).abs().max_element() < 0.01 * side.max_element(),
        "{got} {side}"
    );
    assert_eq!(l.scene.sky(-Vec3::Y), Vec3::ZERO);
    // The sun's disk (Mitsuba's default aperture, 0.5358 degrees across), seen along
    // its direction with its irradiance over its solid angle, and not 0.3 degrees off.
    let disk = l.scene.sun_disk.expect("a sunsky's sun has a disk");
    assert_eq!(disk.light, 1);
    let radius = 2.0 * (disk.solid_angle / (4.0 * std::f32::consts::PI)).sqrt().asin();
    assert!((radius.to_degrees() - 0.2679).abs() < 1e-3);
    let towards = Vec3::new(1.0, 1.0, 0.0).normalize();
    let omega = disk.solid_angle;
    assert!(close(
        l.scene.sun_seen(towards) * omega,
        sunsky::rgb(model.sun_irradiance())
    ));
    let off = glam::Quat::from_rotation_z(0.3f32.to_radians()) * towards;
    assert_eq!(l.scene.sun_seen(off), Vec3::ZERO);
    let wide = ok(&[
        r#"<emitter type="sunsky"><vector name="sun_direction" value="0, 0, 1"/><float name="sun_aperture" value="2"/></emitter>"#,
    ]);
    let disk = wide.scene.sun_disk.unwrap();
    let one_degree = std::f32::consts::TAU * (1.0 - 1f64.to_radians().cos()) as f32;
    assert!((disk.solid_angle - one_degree).abs() < 1e-4 * one_degree);
    // A plain `directional` has no disk.
    let plain = ok(&[r#"<emitter type="directional"><vector name="direction" value="0, 0, -1"/></emitter>"#]);
    assert_eq!(plain.scene.sun_disk, None);

    // By date and place (Paris, a winter morning): the sun as the model places it.
    let l = ok(&[
        r#"<emitter type="sunsky"><float name="latitude" value="48.85"/><float name="longitude" value="2.35"/>"#,
        r#"<float name="timezone" value="1"/><integer name="year" value="2024"/><integer name="month" value="12"/>"#,
        r#"<integer name="day" value="21"/><float name="hour" value="10.5"/><float name="sky_scale" value="0"/></emitter>"#,
    ]);
    match &l.scene.lights[..] {
        [Light::Directional { direction, .. }] => {
            let want = -Vec3::new(0.829_574_7, -0.522_584_9, 0.196_750_7);
            assert!(direction.angle_between(want).to_degrees() < 0.05, "{direction}");
        }
        other => panic!("{other:?}"),
    }

    let e = err(
        &[r#"<emitter type="sunsky"><float name="turbidity" value="12"/></emitter>"#],
        3,
    );
    assert!(e.contains("turbidity") && e.contains("[1, 10]"), "{e}");
    let e = err(
        &[
            r#"<emitter type="sunsky"><vector name="sun_direction" value="0,0,1"/><float name="hour" value="9"/></emitter>"#,
        ],
        3,
    );
    assert!(e.contains("'hour'") && e.contains("sun_direction"), "{e}");
    let e = err(
        &[r#"<emitter type="sunsky"><integer name="month" value="13"/></emitter>"#],
        3,
    );
    assert!(e.contains("month"), "{e}");
    let e = err(
        &[r#"<emitter type="constant"/>"#, r#"<emitter type="sunsky"/>"#],
        4,
    );
    assert!(e.contains("at most one"), "{e}");
    let l = ok(&[r#"<emitter type="sunsky"><vector name="sun_direction" value="0.3, 0, -1"/></emitter>"#]);
    assert!(l.scene.lights.is_empty());
    assert!(has_warning(&l, 3, "below the horizon"));
}

// ------------------------------------------------------------- sensors

#[test]
fn sensor_fov_film_sampler() {
    let xml = r#"<scene version="3.0.0">
<sensor type="perspective">
  <float name="fov" value="39.3"/>
  <string name="fov_axis" value="smaller"/>
  <float name="near_clip" value="0.1"/>
  <float name="far_clip" value="100"/>
  <transform name="to_world"><translate z="-5"/></transform>
  <film type="hdrfilm"><integer name="width" value="640"/><integer name="height" value="480"/>
    <rfilter type="gaussian"/><string name="pixel_format" value="rgb"/></film>
  <sampler type="independent"><integer name="sample_count" value="128"/></sampler>
</sensor>
<sensor type="perspective"><string name="focal_length" value="35mm"/></sensor>
<sensor type="thinlens"><float name="fov" value="60"/><float name="aperture_radius" value="0.1"/></sensor>
</scene>"#;
    let l = load_raw(xml, &[]).unwrap();
    let s = &l.scene.sensors;
    assert_eq!(s.len(), 3);
    assert_eq!(s[0].fov, 39.3);
    assert_eq!(s[0].fov_axis, FovAxis::Smaller);
    assert_eq!((s[0].width, s[0].height, s[0].spp), (640, 480, Some(128)));
    assert_eq!((s[0].near_clip, s[0].far_clip), (0.1, 100.0));
    assert_eq!(s[0].to_world.w_axis, Vec4::new(0.0, 0.0, -5.0, 1.0));
    // 35 mm lens on 35 mm film: the diagonal field of view.
    let diag = 2.0 * (43.266615f32 / 70.0).atan().to_degrees();
    assert!((s[1].fov - diag).abs() < 1e-3, "{}", s[1].fov);
    assert_eq!(s[1].fov_axis, FovAxis::Diagonal);
    assert_eq!((s[1].width, s[1].height, s[1].spp), (768, 576, None));
    assert_eq!((s[1].near_clip, s[1].far_clip), (0.01, 10000.0));
    // The film's rfilter: named, or none (the render then takes Mitsuba's default).
    assert_eq!(
        (s[0].filter, s[1].filter),
        (Some(crate::scene::Filter::Gaussian), None)
    );
    assert_eq!(s[2].fov, 60.0);
    assert_eq!(s[2].lens.map(|l| l.radius), Some(0.1));
    assert!(
        !l.warnings
            .iter()
            .any(|w| w.contains("thinlens") || w.contains("depth of field")),
        "{:?}",
        l.warnings
    );
    // No warning for the film's own keys or the rfilter.
    assert!(!l
        .warnings
        .iter()
        .any(|w| w.contains("pixel_format") || w.contains("rfilter")));
}

/// A film's `rfilter` is read: a box stays a box (Mitsuba's 0.6 scenes often ask for
/// one: the wooden staircase, the classroom), `tent`, `mitchell`, `catmullrom` and
/// `lanczos` as Mitsuba has them; other parameters than Mitsuba's defaults are read
/// as those, and a filter Mitsuba lacks as the Gaussian, with a warning naming the line.
#[test]
fn a_films_rfilter_is_read() {
    let film = |inner: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective">
<film type="hdrfilm">{inner}</film></sensor></scene>"#
        )
    };
    let f = |inner: &str| {
        let l = load_raw(&film(inner), &[]).unwrap();
        (l.scene.sensors[0].filter, l.warnings.clone())
    };
    let (box_, w) = f(r#"<rfilter type="box"/>"#);
    assert_eq!(box_, Some(crate::scene::Filter::Box));
    assert!(!w.iter().any(|w| w.contains("rfilter")), "{w:?}");
    let (g, w) = f(r#"<rfilter type="gaussian"><float name="stddev" value="0.5"/></rfilter>"#);
    assert_eq!(g, Some(crate::scene::Filter::Gaussian));
    assert!(!w.iter().any(|w| w.contains("rfilter")), "{w:?}");
    use crate::scene::Filter;
    for (inner, filter) in [
        (r#"<rfilter type="tent"/>"#, Filter::Tent),
        (
            r#"<rfilter type="tent"><float name="radius" value="1"/></rfilter>"#,
            Filter::Tent,
        ),
        (r#"<rfilter type="mitchell"/>"#, Filter::Mitchell),
        (r#"<rfilter type="catmullrom"/>"#, Filter::Catmullrom),
        (
            r#"<rfilter type="lanczos"><integer name="lobes" value="3"/></rfilter>"#,
            Filter::Lanczos,
        ),
    ] {
        let (g, w) = f(inner);
        assert_eq!(g, Some(filter));
        assert!(!w.iter().any(|w| w.contains("rfilter")), "{w:?}");
    }
    for (inner, filter, says) in [
        (
            r#"<rfilter type="sinc"/>"#,
            Filter::Gaussian,
            "rfilter 'sinc' read as 'gaussian'",
        ),
        (
            r#"<rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>"#,
            Filter::Gaussian,
            "stddev 0.25 read with Mitsuba's default, 0.5",
        ),
        (
            r#"<rfilter type="lanczos"><integer name="lobes" value="2"/></rfilter>"#,
            Filter::Lanczos,
            "lobes 2 read with Mitsuba's default, 3",
        ),
    ] {
        let (g, w) = f(inner);
        assert_eq!(g, Some(filter));
        assert!(w.iter().any(|w| w.contains(":2:") && w.contains(says)), "{w:?}");
    }
    // A Mitsuba 0.6 file's box filter, as the staircase's.
    let l = load_raw(
        r#"<scene version="0.6.0"><sensor type="perspective"><film type="hdrfilm">
<float name="gamma" value="2.2"/><rfilter type="box"/></film></sensor></scene>"#,
        &[],
    )
    .unwrap();
    assert_eq!(l.scene.sensors[0].filter, Some(crate::scene::Filter::Box));
}

/// An `orthographic` sensor is read as one, its `to_world` may scale (the film's
/// extent), not shear.
#[test]
fn an_orthographic_sensor_keeps_its_scale() {
    let sensor = |t: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="orthographic">
<transform name="to_world">{t}<lookat origin="0, 0, 5" target="0, 0, 0"/></transform></sensor></scene>"#
        )
    };
    let l = load_raw(&sensor(r#"<scale x="2" y="2"/>"#), &[]).unwrap();
    let s = &l.scene.sensors[0];
    assert_eq!(s.projection, crate::scene::Projection::Orthographic);
    assert!((s.to_world.x_axis.length() - 2.0).abs() < 1e-6);
    assert!(
        !l.warnings.iter().any(|w| w.contains("sensor")),
        "{:?}",
        l.warnings
    );
    let m = err_at(
        &sensor(r#"<matrix value="1 0.5 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/>"#),
        1,
    );
    assert!(m.contains("shear"), "{m}");
}

/// A film's crop window makes the image the window's size, placed on the film; a
/// window that leaves the film is an error at the film.
#[test]
fn a_films_crop_window_is_read() {
    let film = |crop: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective">
<film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>{crop}</film></sensor></scene>"#
        )
    };
    let l = load_raw(
        &film(r#"<integer name="crop_offset_x" value="8"/><integer name="crop_offset_y" value="4"/><integer name="crop_width" value="32"/><integer name="crop_height" value="20"/>"#),
        &[],
    )
    .unwrap();
    let s = &l.scene.sensors[0];
    assert_eq!((s.width, s.height), (32, 20));
    assert_eq!(
        s.crop,
        Some(crate::scene::Crop {
            film_width: 64,
            film_height: 48,
            x: 8,
            y: 4
        })
    );
    let l = load_raw(&film(""), &[]).unwrap();
    assert_eq!((l.scene.sensors[0].width, l.scene.sensors[0].crop), (64, None));
    let m = err_at(
        &film(r#"<integer name="crop_offset_x" value="40"/><integer name="crop_width" value="32"/>"#),
        2,
    );
    assert!(m.contains("leaves the 64 x 48 film"), "{m}");
}

#[test]
fn default_sensor_is_a_50mm_lens() {
    let l = load_raw(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"/></scene>",
        &[],
    )
    .unwrap();
    let s = &l.scene.sensors[0];
    let diag = 2.0 * (43.266615f32 / 100.0).atan().to_degrees();
    assert!((s.fov - diag).abs() < 1e-3);
    assert_eq!(s.fov_axis, FovAxis::Diagonal);
}

// ------------------------------------------------------------- BSDFs

#[test]
fn refs_reuse_one_bsdf_entry() {
    let l = ok(&[
        r#"<bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.8"/></bsdf>"#,
        r#"<bsdf type="diffuse" id="unused"/>"#,
        r#"<shape type="cube"><ref id="white"/></shape>"#,
        r#"<shape type="rectangle"><ref name="bsdf" id="white"/></shape>"#,
        r#"<shape type="disk"><bsdf type="conductor"/></shape>"#,
    ]);
    let sh = &l.scene.shapes;
    assert_eq!(sh[0].bsdf, sh[1].bsdf);
    assert_ne!(sh[0].bsdf, sh[2].bsdf);
    assert_eq!(l.scene.bsdfs.len(), 2);
    assert_eq!(l.scene.bsdfs[sh[0].bsdf as usize].name, "white");
    assert_eq!(
        l.scene.bsdfs[sh[2].bsdf as usize].kind,
        BsdfKind::Conductor {
            specular_reflectance: Vec3::ONE,
            fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
        }
    );
    assert_eq!(
        sh.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
        ["cube#0", "rectangle#1", "disk#2"]
    );
}

#[test]
fn unknown_ref_is_an_error() {
    let m = err(
        &[r#"<shape type="cube">"#, r#"  <ref id="nope"/>"#, "</shape>"],
        4,
    );
    assert!(m.contains("'nope'"), "{m}");
    // A ref that names something that is not a BSDF.
    let m = err(
        &[
            r#"<shape type="cube" id="box"/>"#,
            r#"<shape type="cube"><ref id="box"/></shape>"#,
        ],
        4,
    );
    assert!(m.contains("not a bsdf"), "{m}");
}

#[test]
fn twosided_blend_and_plastic() {
    let l = ok(&[
        r#"<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8 0.1 0.1"/></bsdf>"#,
        r#"<bsdf type="twosided" id="ts"><ref id="red"/></bsdf>"#,
        r#"<bsdf type="twosided" id="tsp"><bsdf type="plastic">"#,
        r#"  <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/><float name="int_ior" value="1.5"/>"#,
        r#"  <boolean name="nonlinear" value="true"/></bsdf></bsdf>"#,
        r#"<bsdf type="plastic" id="p2"><string name="int_ior" value="bk7"/><string name="ext_ior" value="air"/></bsdf>"#,
        r#"<bsdf type="blendbsdf" id="mix"><float name="weight" value="0.25"/>"#,
        r#"  <ref id="red"/><bsdf type="conductor"><rgb name="specular_reflectance" value="0.9"/></bsdf></bsdf>"#,
        r#"<shape type="cube"><ref id="ts"/></shape>"#,
        r#"<shape type="cube"><ref id="tsp"/></shape>"#,
        r#"<shape type="cube"><ref id="p2"/></shape>"#,
        r#"<shape type="cube"><ref id="mix"/></shape>"#,
        r#"<emitter type="point"/>"#,
    ]);
    let b = |i: usize| &l.scene.bsdfs[l.scene.shapes[i].bsdf as usize];
    let red = BsdfKind::Diffuse {
        reflectance: Vec3::new(0.8, 0.1, 0.1),
    };
    assert_eq!(
        *b(0),
        Bsdf {
            name: "ts".into(),
            kind: red.clone(),
            twosided: true,
            textures: Vec::new(),
        }
    );
    assert!(b(1).twosided);
    assert_eq!(
        b(1).kind,
        BsdfKind::Plastic {
            diffuse_reflectance: Vec3::new(0.1, 0.2, 0.3),
            specular_reflectance: Vec3::ONE,
            eta: 1.5 / 1.000277,
            nonlinear: true
        }
    );
    let BsdfKind::Plastic {
        eta,
        diffuse_reflectance,
        nonlinear,
        ..
    } = b(2).kind
    else {
        panic!()
    };
    assert!((eta - 1.5046 / 1.000277).abs() < 1e-6);
    assert_eq!((diffuse_reflectance, nonlinear), (Vec3::splat(0.5), false));
    assert!(!b(2).twosided);
    assert_eq!(
        b(3).kind,
        BsdfKind::Blend {
            weight: 0.25,
            a: Box::new(red),
            b: Box::new(BsdfKind::Conductor {
                specular_reflectance: Vec3::splat(0.9),
                fresnel: crate::scene::Fresnel::Schlick { f0: glam::Vec3::ONE },
            })
        }
    );
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
}

#[test]
fn plastic_defaults() {
    let l = ok(&[r#"<shape type="cube"><bsdf type="plastic"/></shape>"#]);
    let BsdfKind::Plastic {
        eta,
        specular_reflectance,
        diffuse_reflectance,
        nonlinear,
    } = l.scene.bsdfs[0].kind
    else {
        panic!()
    };
    assert!((eta - 1.49 / 1.000277).abs() < 1e-6);
    assert_eq!(specular_reflectance, Vec3::ONE);
    assert_eq!(diffuse_reflectance, Vec3::splat(0.5));
    assert!(!nonlinear);
}

#[test]
fn rough_and_unsupported_bsdfs_warn() {
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="roughplastic"><float name="alpha" value="0.1"/></bsdf></shape>"#,
        r#"<shape type="cube"><bsdf type="roughconductor"/></shape>"#,
        r#"<shape type="cube"><bsdf type="measured"/></shape>"#,
        r#"<shape type="cube"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>"#,
    ]);
    assert!(
        !l.warnings.iter().any(|w| w.contains(":3:") || w.contains(":4:")),
        "{:?}",
        l.warnings
    );
    assert!(has_warning(&l, 5, "'measured'"));
    assert!(!l.warnings.iter().any(|w| w.contains("'Au'")), "{:?}", l.warnings);
    assert!(!l.warnings.iter().any(|w| w.contains("'alpha'")));
    let kinds: Vec<&BsdfKind> = l.scene.bsdfs.iter().map(|b| &b.kind).collect();
    assert!(matches!(kinds[0], BsdfKind::RoughPlastic { .. }));
    // Mitsuba 3's defaults: Beckmann, alpha 0.1, a perfect reflector.
    let BsdfKind::RoughConductor { lobe } = kinds[1] else {
        panic!("{:?}", kinds[1])
    };
    assert!(lobe.distribution.beckmann);
    assert_eq!((lobe.distribution.alpha_u, lobe.distribution.alpha_v), (0.1, 0.1));
    assert_eq!(lobe.fresnel, crate::scene::Fresnel::Schlick { f0: Vec3::ONE });
    assert_eq!(*kinds[2], Bsdf::default().kind);
    let BsdfKind::Conductor { fresnel, .. } = kinds[3] else {
        panic!()
    };
    // Gold, by its complex index as Mitsuba 3's RGB variants read it: at normal
    // incidence ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2) per channel.
    let (n, k) = (
        Vec3::new(0.143036, 0.375307, 1.44205),
        Vec3::new(3.983, 2.38556, 1.60336),
    );
    assert_eq!(*fresnel, crate::scene::Fresnel::Conductor { eta: n, k });
    let f0 = ((n - 1.0) * (n - 1.0) + k * k) / ((n + 1.0) * (n + 1.0) + k * k);
    assert!(
        (fresnel.f0() - f0).abs().max_element() < 1e-5,
        "{} vs {f0}",
        fresnel.f0()
    );
    // Mitsuba 3.9's `fresnel_conductor` for these indices at cosines 1 and 0.5.
    for (c, want) in [
        (1.0, Vec3::new(0.966_679, 0.802_011, 0.324_121)),
        (0.5, Vec3::new(0.962_210, 0.804_371, 0.371_175)),
    ] {
        assert!(
            (fresnel.at(c) - want).abs().max_element() < 2e-5,
            "{c}: {} vs {want}",
            fresnel.at(c)
        );
    }
}

#[test]
fn a_conductor_material_mitsuba_does_not_know_fails_with_its_line() {
    let e = err(
        &[
            r#"<shape type="cube">"#,
            r#"  <bsdf type="roughconductor"><string name="material" value="Fe"/></bsdf>"#,
            r#"</shape>"#,
        ],
        4,
    );
    assert!(e.contains("'Fe' is not a conductor Mitsuba knows"), "{e}");
    // Mitsuba 0.6's extEta divides a named material's index too.
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="conductor"><string name="material" value="Cu"/><float name="ext_eta" value="2"/></bsdf></shape>"#,
    ]);
    let BsdfKind::Conductor { fresnel, .. } = &l.scene.bsdfs[0].kind else {
        panic!("{:?}", l.scene.bsdfs[0].kind)
    };
    let (n, k) = (
        Vec3::new(0.201005, 0.92375, 1.10222),
        Vec3::new(3.91326, 2.45305, 2.14209),
    );
    assert_eq!(
        *fresnel,
        crate::scene::Fresnel::Conductor {
            eta: n / 2.0,
            k: k / 2.0
        }
    );
}

#[test]
fn glass_reads_named_indices_as_mitsuba_and_bad_ones_fail_with_their_line() {
    let l = ok(&[
        r#"<bsdf type="thindielectric" id="pane"><string name="int_ior" value="bk7"/><string name="ext_ior" value="air"/></bsdf>"#,
        r#"<bsdf type="dielectric" id="water"><float name="int_ior" value="1.33"/><rgb name="specular_transmittance" value="0.9, 0.95, 1"/></bsdf>"#,
        r#"<bsdf type="dielectric" id="default"/>"#,
        r#"<shape type="cube"><ref id="pane"/></shape>"#,
        r#"<shape type="cube"><ref id="water"/></shape>"#,
        r#"<shape type="cube"><ref id="default"/></shape>"#,
    ]);
    assert!(!l.warnings.iter().any(|w| w.contains("bsdf")), "{:?}", l.warnings);
    let kinds: Vec<&BsdfKind> = l.scene.bsdfs.iter().map(|b| &b.kind).collect();
    let glass = |k: &BsdfKind| match *k {
        BsdfKind::Dielectric {
            eta,
            specular_transmittance,
            thin,
            ..
        } => (eta, specular_transmittance, thin),
        _ => panic!("{k:?}"),
    };
    // Mitsuba's table: bk7 1.5046, air 1.000277; its defaults are those two.
    let (eta, _, thin) = glass(kinds[0]);
    assert!((eta - 1.5046 / 1.000277).abs() < 1e-6 && thin);
    let (eta, t, thin) = glass(kinds[1]);
    assert!((eta - 1.33 / 1.000277).abs() < 1e-6 && !thin);
    assert_eq!(t, Vec3::new(0.9, 0.95, 1.0));
    assert!((glass(kinds[2]).0 - 1.5046 / 1.000277).abs() < 1e-6);
    assert!(l.scene.bsdfs.iter().all(|b| b.twosided));
    // Shadow rays may pass both (how much: `pane_transmittance`'s).
    assert!(l.scene.passes_shadows(0) && l.scene.passes_shadows(1));

    let e = err(
        &[
            r#"<shape type="cube">"#,
            r#"<bsdf type="dielectric"><string name="int_ior" value="glas"/></bsdf>"#,
            "</shape>",
        ],
        4,
    );
    assert!(e.contains("int_ior") && e.contains("'glas'"), "{e}");
    let e = err(
        &[r#"<bsdf type="thindielectric" id="x"><float name="ext_ior" value="-1"/></bsdf>"#],
        3,
    );
    assert!(e.contains("ext_ior"), "{e}");
}

/// `roughdielectric`: Mitsuba 3's defaults (Beckmann, alpha 0.1, bk7 in air) and its
/// parameters, without a warning; a roughness map is read as its mean, with a
/// warning; a bad distribution fails with its line.
#[test]
fn rough_glass_reads_its_distribution_and_roughness() {
    let l = ok(&[
        r#"<bsdf type="roughdielectric" id="frosted"><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/><float name="int_ior" value="1.33"/></bsdf>"#,
        r#"<bsdf type="roughdielectric" id="default"/>"#,
        r#"<shape type="cube"><ref id="frosted"/></shape>"#,
        r#"<shape type="cube"><ref id="default"/></shape>"#,
    ]);
    assert!(!l.warnings.iter().any(|w| w.contains("bsdf")), "{:?}", l.warnings);
    let rough = |k: &BsdfKind| match *k {
        BsdfKind::Dielectric {
            eta,
            thin,
            rough: Some(d),
            ..
        } => (eta, thin, d),
        _ => panic!("{k:?}"),
    };
    let (eta, thin, d) = rough(&l.scene.bsdfs[0].kind);
    assert!((eta - 1.33 / 1.000277).abs() < 1e-6 && !thin);
    assert_eq!((d.alpha_u, d.alpha_v, d.beckmann), (0.3, 0.3, false));
    let (eta, _, d) = rough(&l.scene.bsdfs[1].kind);
    assert!((eta - 1.5046 / 1.000277).abs() < 1e-6);
    assert_eq!((d.alpha_u, d.alpha_v, d.beckmann), (0.1, 0.1, true));
    assert!(l.scene.passes_shadows(0));
    // A roughness map: its mean, with a warning naming it.
    let l = ok(&[
        r#"<bsdf type="roughdielectric" id="map"><texture type="checkerboard" name="alpha"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.4"/></texture></bsdf>"#,
        r#"<shape type="cube"><ref id="map"/></shape>"#,
    ]);
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("texture as 'alpha'") && w.contains("(0.250)")),
        "{:?}",
        l.warnings
    );
    assert_eq!(rough(&l.scene.bsdfs[0].kind).2.alpha_u, 0.25);
    let e = err(
        &[r#"<bsdf type="roughdielectric" id="x"><string name="distribution" value="phong"/></bsdf>"#],
        3,
    );
    assert!(e.contains("distribution") && e.contains("'phong'"), "{e}");
}

// ------------------------------------------------------------- shapes

/// `shapegroup` and `instance`: each instance adds the group's shapes moved by its own
/// `to_world` (after each shape's own), with the group's materials; the group itself
/// adds nothing. An emitter in a group, an instance without a group or naming a bsdf
/// are errors naming their line.
#[test]
fn instances_copy_their_shapegroup_moved_by_their_to_world() {
    let l = ok(&[
        r#"<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>"#,
        r#"<shape type="shapegroup" id="g"><shape type="rectangle"><ref id="red"/><transform name="to_world"><translate z="1"/></transform></shape><shape type="cube"/></shape>"#,
        r#"<shape type="instance"><ref id="g"/><transform name="to_world"><translate x="5"/></transform></shape>"#,
        r#"<shape type="instance"><ref id="g"/><transform name="to_world"><scale value="2"/></transform></shape>"#,
    ]);
    let shapes = &l.scene.shapes;
    assert_eq!(shapes.len(), 4);
    let red = l.scene.bsdfs[shapes[0].bsdf as usize].kind.diffuse_albedo();
    assert!(close(red, Vec3::new(0.8, 0.1, 0.1)));
    assert_eq!(shapes[0].bsdf, shapes[2].bsdf);
    assert_eq!(
        shapes[0].mesh.bounds(),
        Some((Vec3::new(4.0, -1.0, 1.0), Vec3::new(6.0, 1.0, 1.0)))
    );
    assert_eq!(
        shapes[3].mesh.bounds(),
        Some((Vec3::splat(-2.0), Vec3::splat(2.0)))
    );
    assert!((shapes[1].mesh.area() - 24.0).abs() < 1e-4 && (shapes[3].mesh.area() - 96.0).abs() < 1e-3);

    let e = err(
        &[r#"<shape type="shapegroup" id="g"><shape type="cube"><emitter type="area"/></shape></shape>"#],
        3,
    );
    assert!(e.contains("emitter"), "{e}");
    let e = err(&[r#"<shape type="instance"/>"#], 3);
    assert!(e.contains("shapegroup"), "{e}");
    let e = err(
        &[
            r#"<bsdf type="diffuse" id="b"/>"#,
            r#"<shape type="instance"><ref id="b"/></shape>"#,
        ],
        4,
    );
    assert!(e.contains("not a shapegroup"), "{e}");
}

/// `merge` (Mitsuba 3's joining of meshes, for speed): its nested shapes load as the
/// same shapes written at the top level, materials and area emitters with them; other
/// children are ignored with a warning naming their line.
#[test]
fn a_merge_loads_its_shapes_as_written_apart() {
    let red = r#"<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>"#;
    let a = r#"<shape type="rectangle"><ref id="red"/><transform name="to_world"><translate z="1"/></transform></shape>"#;
    let b = r#"<shape type="cube"><emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>"#;
    let merged = format!(r#"<shape type="merge">{a}{b}<bsdf type="conductor"/></shape>"#);
    let l = ok(&[red, &merged]);
    let apart = ok(&[red, a, b]);
    assert_eq!(l.scene.shapes.len(), 2);
    for (m, s) in l.scene.shapes.iter().zip(&apart.scene.shapes) {
        assert_eq!(m.mesh.bounds(), s.mesh.bounds());
        assert_eq!(
            l.scene.bsdfs[m.bsdf as usize].kind.diffuse_albedo(),
            apart.scene.bsdfs[s.bsdf as usize].kind.diffuse_albedo()
        );
    }
    assert!(close(
        l.scene.bsdfs[l.scene.shapes[0].bsdf as usize]
            .kind
            .diffuse_albedo(),
        Vec3::new(0.8, 0.1, 0.1)
    ));
    assert_eq!(l.scene.lights.len(), 1);
    assert!(
        has_warning(&l, 4, "<bsdf> inside shape 'merge' ignored"),
        "{:?}",
        l.warnings
    );
    assert!(!apart.warnings.iter().any(|w| w.contains("merge")));
}

/// `checkerboard`: `color0` where u and v fall in the same half of their unit square,
/// `color1` elsewhere, after `to_uv`; its mean is pass 1's value.
#[test]
fn a_checkerboard_is_mitsubas_pattern() {
    let l = ok(&[
        r#"<bsdf type="diffuse" id="c"><texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.8, 0.6, 0.4"/>"#,
        r#"<float name="color1" value="0.1"/><transform name="to_uv"><scale x="2" y="2"/></transform></texture></bsdf>"#,
        r#"<shape type="cube"><ref id="c"/></shape>"#,
    ]);
    assert!(
        !l.warnings.iter().any(|w| w.contains("checkerboard")),
        "{:?}",
        l.warnings
    );
    let b = &l.scene.bsdfs[l.scene.shapes[0].bsdf as usize];
    let (c0, c1) = (Vec3::new(0.8, 0.6, 0.4), Vec3::splat(0.1));
    assert!(close(b.kind.diffuse_albedo(), (c0 + c1) * 0.5));
    let at = |u: f32, v: f32| {
        b.kind_at(Vec2::new(u, v), 0.0, &l.scene.textures)
            .diffuse_albedo()
    };
    // Scaled by 2: cells of a quarter.
    assert!(close(at(0.1, 0.1), c0) && close(at(0.3, 0.1), c1) && close(at(0.1, 0.3), c1));
    assert!(close(at(0.3, 0.3), c0) && close(at(0.6, 0.1), c0) && close(at(-0.1, 0.1), c1));
}

/// `cylinder`: Mitsuba's `p0`, `p1` (defaults 0 and +z) and `radius` (1), then
/// `to_world`; a tube of no radius is an error naming its line.
#[test]
fn cylinders_read_their_axis_and_radius() {
    let l = ok(&[
        r#"<shape type="cylinder"><point name="p1" value="0, 0, 2"/><float name="radius" value="0.5"/><transform name="to_world"><translate x="3"/></transform></shape>"#,
        r#"<shape type="cylinder"/>"#,
    ]);
    let (a, b) = (&l.scene.shapes[0].mesh, &l.scene.shapes[1].mesh);
    let exact = 2.0 * PI * 0.5 * 2.0;
    assert!((a.area() / exact - 1.0).abs() < 1e-3, "{}", a.area());
    let (lo, hi) = a.bounds().unwrap();
    assert!(
        close(lo, Vec3::new(2.5, -0.5, 0.0)) && close(hi, Vec3::new(3.5, 0.5, 2.0)),
        "{lo} {hi}"
    );
    assert!((b.area() / (2.0 * PI) - 1.0).abs() < 1e-3, "{}", b.area());
    let e = err(
        &[r#"<shape type="cylinder"><float name="radius" value="0"/></shape>"#],
        3,
    );
    assert!(e.contains("radius"), "{e}");
}

#[test]
fn spheres_and_disks_are_exact_and_a_stretched_sphere_stays_a_sphere_as_in_mitsuba() {
    let l = ok(&[
        r#"<shape type="sphere"><transform name="to_world"><scale value="0.5"/><rotate z="1" angle="30"/><translate x="1"/></transform></shape>"#,
        r#"<shape type="sphere"><float name="radius" value="2"/><transform name="to_world"><scale x="0.5" y="1" z="3"/><translate y="4"/></transform></shape>"#,
        r#"<shape type="disk"><transform name="to_world"><scale x="2" y="0.5"/></transform></shape>"#,
    ]);
    let sh = &l.scene.shapes;
    let q = sh[0].mesh.quadric.expect("an exact sphere");
    assert!((q.area() - std::f32::consts::PI).abs() < 1e-5);
    let (p, n) = q.project(Vec3::new(3.0, 0.0, 0.0));
    assert!((p - Vec3::new(1.5, 0.0, 0.0)).length() < 1e-5 && (n - Vec3::X).length() < 1e-5);
    // Mitsuba: the radius times the scale along x, about the moved centre.
    assert!(
        has_warning(&l, 4, "radius 1 (the scale along x)"),
        "{:?}",
        l.warnings
    );
    let q = sh[1].mesh.quadric.expect("an exact sphere");
    assert!(q.is_similarity(1e-5));
    let (p, _) = q.project(Vec3::new(0.0, 14.0, 0.0));
    assert!((p - Vec3::new(0.0, 5.0, 0.0)).length() < 1e-5, "{p}");
    // A disk may be stretched into an ellipse.
    let q = sh[2].mesh.quadric.expect("an exact disk");
    assert!((q.area() - std::f32::consts::PI).abs() < 1e-5);
    assert!(q
        .intersect(Vec3::new(1.9, 0.0, 1.0), Vec3::NEG_Z, 0.0, 2.0)
        .is_some());
    assert!(q
        .intersect(Vec3::new(0.0, 0.6, 1.0), Vec3::NEG_Z, 0.0, 2.0)
        .is_none());
}

#[test]
fn shapes_with_transforms_and_flip() {
    let l = ok(&[
        r#"<shape type="rectangle"><transform name="to_world"><scale value="2"/><translate z="1"/></transform></shape>"#,
        r#"<shape type="rectangle"><boolean name="flip_normals" value="true"/></shape>"#,
        r#"<shape type="sphere"><point name="center" value="1 0 0"/><float name="radius" value="0.5"/>"#,
        r#"  <transform name="to_world"><translate y="2"/></transform></shape>"#,
        r#"<shape type="cube" id="box"><transform name="to_world"><scale x="-1"/></transform></shape>"#,
    ]);
    let sh = &l.scene.shapes;
    let r = &sh[0].mesh;
    assert!((r.area() - 16.0).abs() < 1e-4);
    assert!(r.positions.iter().all(|p| p.z == 1.0));
    let [a, b, c] = r.triangle(0);
    assert!((b - a).cross(c - a).z > 0.0);
    let [a, b, c] = sh[1].mesh.triangle(0);
    assert!((b - a).cross(c - a).z < 0.0);
    assert!(sh[1].mesh.normals.iter().all(|n| *n == Vec3::NEG_Z));
    let (lo, hi) = sh[2].mesh.bounds().unwrap();
    assert!(close(lo, Vec3::new(0.5, 1.5, -0.5)) || (lo - Vec3::new(0.5, 1.5, -0.5)).length() < 1e-3);
    assert!((hi - Vec3::new(1.5, 2.5, 0.5)).length() < 1e-3);
    // A mirroring to_world keeps the cube's normals outward.
    let cube = &sh[3].mesh;
    assert_eq!(sh[3].name, "box");
    for t in 0..cube.triangle_count() {
        let [a, b, c] = cube.triangle(t);
        assert!((b - a).cross(c - a).dot((a + b + c) / 3.0) > 0.0);
    }
    assert!(matches!(cube.patches[0], Patch::Polygon(_)));
}

#[test]
fn mesh_files_need_a_filename_and_an_existing_file() {
    let m = err(&[r#"<shape type="obj"/>"#], 3);
    assert!(m.contains("filename"), "{m}");
    let m = err(
        &[
            r#"<shape type="ply">"#,
            r#"<string name="filename" value="nothere.ply"/></shape>"#,
        ],
        4,
    );
    assert!(m.contains("nothere.ply"), "{m}");
    // A directory.
    let m = err(
        &[r#"<shape type="bezier"><string name="filename" value="."/></shape>"#],
        3,
    );
    assert!(m.contains("directory"), "{m}");
}

// ------------------------------------------------------------- includes

#[test]
fn include_reads_relative_files() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("parts")).unwrap();
    fs::write(
        dir.path().join("parts/mat.xml"),
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"grey\"><rgb name=\"reflectance\" value=\"0.3\"/></bsdf>\n</scene>",
    )
    .unwrap();
    fs::write(
        dir.path().join("parts/bad.xml"),
        "<scene version=\"3.0.0\">\n\n<shape type=\"sphere\"><float name=\"radius\" value=\"0\"/></shape>\n</scene>",
    )
    .unwrap();
    let main = dir.path().join("scene.xml");
    fs::write(
        &main,
        scene(&[
            r#"<include filename="parts/mat.xml"/>"#,
            r#"<shape type="cube"><ref id="grey"/></shape>"#,
        ]),
    )
    .unwrap();
    let l = load(&main, &[]).unwrap();
    assert_eq!(
        l.scene.bsdfs[0].kind,
        BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.3)
        }
    );
    // An error inside an included file names that file and line.
    fs::write(&main, scene(&[r#"<include filename="parts/bad.xml"/>"#])).unwrap();
    let m = load(&main, &[]).unwrap_err().to_string();
    assert!(m.contains("bad.xml:3:"), "{m}");
    // A file including itself.
    fs::write(&main, scene(&[r#"<include filename="scene.xml"/>"#])).unwrap();
    let m = load(&main, &[]).unwrap_err().to_string();
    assert!(m.contains("scene.xml:3:"), "{m}");
}

// ------------------------------------------------------------- warnings

#[test]
fn unknown_plugins_and_parameters_warn_with_line() {
    let l = ok(&[
        r#"<shape type="cube">"#,
        r#"  <float name="radius" value="2"/>"#,
        "</shape>",
        r#"<shape type="teapotahedron"/>"#,
        r#"<frobnicate/>"#,
        r#"<integrator type="path"/>"#,
        r#"<integrator type="aov"/>"#,
        r#"<bsdf type="diffuse" id="x"><rgb name="reflectanse" value="0.5"/></bsdf>"#,
        r#"<integrator type="sppm"/>"#,
        r#"<bsdf type="diffuse"/>"#,
    ]);
    // Mitsuba 0.6's photon mapper renders the same picture: silent. A top-level
    // material without an id is a note (Mitsuba loads it silently; nothing uses it).
    assert!(!l
        .warnings
        .iter()
        .any(|w| w.contains("sppm") || w.contains("<bsdf>")));
    assert!(
        l.notes.len() == 1 && l.notes[0].contains(":12:") && l.notes[0].contains("without an id"),
        "{:?}",
        l.notes
    );
    assert!(has_warning(&l, 4, "'radius'"));
    assert!(has_warning(&l, 6, "'teapotahedron'"));
    assert!(has_warning(&l, 7, "<frobnicate>"));
    assert!(!l.warnings.iter().any(|w| w.contains("'path'")));
    assert!(has_warning(&l, 9, "'aov'"));
    assert!(has_warning(&l, 10, "'reflectanse'"));
    assert_eq!(l.scene.shapes.len(), 1);
}

// ------------------------------------------------------------- errors

#[test]
fn malformed_inputs_are_errors_with_place() {
    // Not XML at all / malformed XML: roxmltree's position.
    err_at("this is not xml", 1);
    err_at(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n</scene>",
        3,
    );
    // Root not <scene>.
    let m = err_at("<?xml version=\"1.0\"?>\n<shape type=\"cube\"/>", 2);
    assert!(m.contains("<scene>"), "{m}");
    // Numbers.
    err(
        &[r#"<shape type="sphere"><float name="radius" value="abc"/></shape>"#],
        3,
    );
    err(
        &[r#"<shape type="sphere"><float name="radius" value="inf"/></shape>"#],
        3,
    );
    err(
        &[r#"<shape type="sphere"><float name="radius" value="NaN"/></shape>"#],
        3,
    );
    err(
        &[r#"<emitter type="point"><point name="position" value="1 2"/></emitter>"#],
        3,
    );
    err(
        &[
            r#"<shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="1 2 3 4"/></bsdf></shape>"#,
        ],
        3,
    );
    err(
        &[
            "<shape type=\"cube\"><transform name=\"to_world\">",
            "<matrix value=\"1 0 0 0 1 0\"/>",
            "</transform></shape>",
        ],
        4,
    );
    err(
        &[
            "<shape type=\"cube\"><transform name=\"to_world\">",
            "<rotate x=\"1\"/>",
            "</transform></shape>",
        ],
        4,
    );
    // Film size.
    for (w, h) in [("0", "10"), ("-5", "10"), ("10", "20000")] {
        let xml = format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\">\n\
             <integer name=\"width\" value=\"{w}\"/><integer name=\"height\" value=\"{h}\"/>\n\
             </film></sensor>\n</scene>"
        );
        err_at(&xml, 3);
    }
    err_at(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<float name=\"width\" value=\"5.5\"/></film></sensor>\n</scene>",
        3,
    );
    // Reflectance out of range, with the channel named.
    let m = err(
        &[
            r#"<shape type="cube"><bsdf type="diffuse">"#,
            r#"<rgb name="reflectance" value="0.5, 1.2, 0.5"/></bsdf></shape>"#,
        ],
        4,
    );
    assert!(m.contains("channel g"), "{m}");
    err(
        &[r#"<bsdf type="plastic" id="p"><rgb name="diffuse_reflectance" value="-0.1"/></bsdf>"#],
        3,
    );
    // Negative radiance / intensity.
    err(
        &[
            r#"<shape type="cube"><emitter type="area"><rgb name="radiance" value="1 -1 1"/></emitter></shape>"#,
        ],
        3,
    );
    err(
        &[r#"<emitter type="spot"><rgb name="intensity" value="-2"/></emitter>"#],
        3,
    );
    // Radius.
    let m = err(
        &[r#"<shape type="sphere"><float name="radius" value="0"/></shape>"#],
        3,
    );
    assert!(m.contains("radius"), "{m}");
    // Unknown IOR name, bad boolean, wrong type.
    err(
        &[r#"<bsdf type="plastic" id="p"><string name="int_ior" value="kryptonite"/></bsdf>"#],
        3,
    );
    err(
        &[r#"<shape type="cube"><boolean name="flip_normals" value="yes"/></shape>"#],
        3,
    );
    err(
        &[r#"<shape type="sphere"><string name="radius" value="1"/></shape>"#],
        3,
    );
    // Structural problems.
    err(&[r#"<emitter type="area"/>"#], 3);
    err(
        &[r#"<shape type="cube"><bsdf type="diffuse"/><bsdf type="diffuse"/></shape>"#],
        3,
    );
    err(
        &[
            r#"<bsdf type="diffuse" id="a"/>"#,
            r#"<bsdf type="diffuse" id="a"/>"#,
        ],
        4,
    );
    err(
        &[r#"<bsdf type="blendbsdf" id="b"><float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf>"#],
        3,
    );
    err(&[r#"<bsdf type="twosided" id="t"/>"#], 3);
    err(&[r#"<shape/>"#], 3);
    err(
        &[r#"<shape type="cube"><transform name="to_world"><scale z="0"/></transform></shape>"#],
        3,
    );
    err(
        &[
            r#"<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="20"/></emitter>"#,
        ],
        3,
    );
    err(&[r#"<include filename="missing.xml"/>"#], 3);
    err_at(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><float name=\"fov\" value=\"180\"/></sensor>\n</scene>",
        2,
    );
    err_at(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/><float name=\"focal_length\" value=\"40\"/></sensor>\n</scene>",
        2,
    );
}

#[test]
fn no_sensor_is_an_error() {
    let m = err_at("<scene version=\"3.0.0\">\n<shape type=\"cube\"/>\n</scene>", 1);
    assert!(m.contains("no sensor"), "{m}");
}

#[test]
fn unreadable_paths_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let m = load(dir.path(), &[]).unwrap_err().to_string();
    assert!(m.contains("directory"), "{m}");
    let m = load(&dir.path().join("none.xml"), &[]).unwrap_err().to_string();
    assert!(m.contains("none.xml"), "{m}");
    let bin = dir.path().join("bin.xml");
    fs::write(&bin, [0xff, 0xfe, 0x00, 0x41]).unwrap();
    let m = load(&bin, &[]).unwrap_err().to_string();
    assert!(m.contains("bin.xml"), "{m}");
}

/// `<path>` adds a folder searched for the files the scene names, before the
/// scene's own folder, as Mitsuba's file resolver does; a missing folder is an error
/// at its line.
#[test]
fn a_path_element_adds_a_folder_to_search() {
    let (dir, path) = write_scene(&scene(&[
        r#"<path value="meshes"/>"#,
        r#"<shape type="obj"><string name="filename" value="tri.obj"/></shape>"#,
    ]));
    fs::create_dir(dir.path().join("meshes")).unwrap();
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    fs::write(dir.path().join("meshes/tri.obj"), tri).unwrap();
    // A file of the same name beside the scene comes after the searched folder.
    fs::write(dir.path().join("tri.obj"), "v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n").unwrap();
    let l = load(&path, &[]).unwrap();
    assert_eq!(l.scene.shapes.len(), 1);
    let b = l.scene.shapes[0].mesh.bounds().unwrap();
    assert!((b.1.x - 1.0).abs() < 1e-6, "{b:?}");
    assert!(!l.warnings.iter().any(|w| w.contains("path")), "{:?}", l.warnings);
    let m = err(&[r#"<path value="nowhere"/>"#], 3);
    assert!(m.contains("folder 'nowhere' not found"), "{m}");
}

// ------------------------------------------------------------- fixture

/// The repository's spectral Cornell box loads with no warning, its light in the
/// colour Mitsuba 3.9 gives those pairs and its green wall read from its `.spd` file.
#[test]
fn the_spectral_cornell_box_loads_in_mitsubas_colours() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/cornell-box-spectral.xml");
    let l = load(&path, &[]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let r = radiances(&l);
    assert!(
        (r[0] - Vec3::new(20.710821, 10.854642, 2.771151))
            .abs()
            .max_element()
            < 1e-3,
        "{}",
        r[0]
    );
    let wall = l.scene.shapes.iter().find(|s| s.name == "rightwall").unwrap();
    let green = match &l.scene.bsdfs[wall.bsdf as usize].kind {
        BsdfKind::Diffuse { reflectance } => *reflectance,
        k => panic!("{k:?}"),
    };
    // Mitsuba 3.9's `spectrum_list_to_srgb` of green.spd's pairs.
    assert!(
        (green - Vec3::new(0.0837918, 0.403466, 0.115484))
            .abs()
            .max_element()
            < 1e-5,
        "{green}"
    );
}

#[test]
fn fixture_box_loads_completely() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/xml/box.xml");
    let l = load(&path, &[("res".into(), "64".into())]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let sc = &l.scene;
    assert_eq!(sc.sensors.len(), 2);
    assert_eq!((sc.sensors[0].width, sc.sensors[0].spp), (64, Some(16)));
    assert_eq!((sc.sensors[1].width, sc.sensors[1].height), (160, 120));
    assert_eq!(sc.sensors[1].fov_axis, FovAxis::Y);
    let names: Vec<&str> = sc.shapes.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        ["floor", "ceiling", "back", "left", "right", "light", "sphere#6", "cube#7"]
    );
    // Walls face into the box.
    for s in &sc.shapes[..5] {
        let [a, b, c] = s.mesh.triangle(0);
        let n = (b - a).cross(c - a);
        assert!(n.dot(-(a + b + c) / 3.0) > 0.0, "{} faces outward", s.name);
    }
    // The light faces down and is the first light.
    let [a, b, c] = sc.shapes[5].mesh.triangle(0);
    assert!((b - a).cross(c - a).y < 0.0);
    assert!((sc.shapes[5].mesh.area() - 0.25).abs() < 1e-5);
    assert_eq!(sc.shapes[5].emitter, Some(0));
    assert_eq!(
        sc.lights[0],
        Light::Area {
            shape: 5,
            radiance: Vec3::new(15.0, 12.0, 9.0),
            texture: None,
        }
    );
    assert!(matches!(sc.lights[1], Light::Spot { .. }));
    assert!(matches!(sc.lights[2], Light::Point { .. }));
    // Materials from the included file, shared by id.
    assert_eq!(sc.shapes[0].bsdf, sc.shapes[1].bsdf);
    assert_eq!(sc.bsdfs[sc.shapes[0].bsdf as usize].name, "white");
    let red = &sc.bsdfs[sc.shapes[3].bsdf as usize];
    assert!(red.twosided);
    assert_eq!(sc.bsdfs.len(), 6);
    let (lo, hi) = sc.shapes[6].mesh.bounds().unwrap();
    assert!(((lo + hi) / 2.0 - Vec3::new(-0.4, -0.65, -0.2)).length() < 1e-3);
}

#[test]
fn text_loads_like_the_file_and_resolves_beside_its_path() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/xml/box.xml");
    let text = fs::read_to_string(&path).unwrap();
    let defines = [("res".to_string(), "64".to_string())];
    let from_file = load(&path, &defines).unwrap();
    let from_text = load_str(&path, &text, &defines).unwrap();
    assert_eq!(from_text.scene.shapes.len(), 8);
    assert_eq!(from_text.scene.shapes, from_file.scene.shapes);
    assert_eq!(from_text.scene.lights, from_file.scene.lights);
    // Errors name the given path; the include is looked for beside it.
    let elsewhere = Path::new("/nonexistent/box.xml");
    let e = load_str(elsewhere, &text, &defines).unwrap_err().to_string();
    assert!(e.starts_with("/nonexistent/box.xml:8:24: "), "{e}");
    assert!(e.contains("/nonexistent/materials.xml"), "{e}");
}

/// Mitsuba 3's upgrade of Mitsuba 0.6 names: camelCase to snake_case, an upper-case
/// run lowered as one word, and (as there) no new underscore right after a run.
#[test]
fn legacy_names_become_snake_case_as_mitsuba_3_makes_them() {
    for (old, new) in [
        ("toWorld", "to_world"),
        ("intIOR", "int_ior"),
        ("extIOR", "ext_ior"),
        ("kNN", "k_nn"),
        ("diffuseReflectance", "diffuse_reflectance"),
        ("highQualityEdges", "high_quality_edges"),
        ("alphaU", "alpha_u"),
        ("aBcD", "a_bcD"),
        ("radiance", "radiance"),
        ("to_world", "to_world"),
        ("URL", "URL"),
    ] {
        assert_eq!(parse::snake_case(old), new, "{old}");
    }
    assert_eq!(parse::version("0.6.0"), Ok((0, 6, 0)));
    assert_eq!(parse::version(" 3.10.2 "), Ok((3, 10, 2)));
    assert!(parse::version("0.6").is_err());
    assert!(parse::version("a.b.c").is_err());
}

/// A Mitsuba 0.6 scene: camelCase names, `lookAt`, space-separated colours, a
/// diffuse BSDF's `diffuseReflectance`, a `$parameter` whose name is camelCase (it
/// stays so), an included file without a version of its own.
const LEGACY_SCENE: &str = r#"<scene version="0.6.0">
  <default name="fovValue" value="40"/>
  <sensor type="perspective">
    <float name="fov" value="$fovValue"/>
    <string name="fovAxis" value="smaller"/>
    <transform name="toWorld"><lookAt origin="0 1 5" target="0 1 0" up="0 1 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
  </sensor>
  <bsdf type="diffuse" id="wall"><rgb name="diffuseReflectance" value="0.5 0.4 0.3"/></bsdf>
  <bsdf type="plastic" id="shiny">
    <float name="intIOR" value="1.6"/>
    <rgb name="diffuseReflectance" value="0.2 0.3 0.4"/>
  </bsdf>
  <shape type="rectangle">
    <transform name="toWorld"><scale value="2"/><rotate x="1" angle="-90"/></transform>
    <ref id="wall"/>
  </shape>
  <include filename="ball.xml"/>
  <shape type="rectangle">
    <transform name="toWorld"><translate y="2"/><rotate x="1" angle="90"/></transform>
    <emitter type="area"><rgb name="radiance" value="5 5 5"/></emitter>
  </shape>
  <emitter type="spot">
    <transform name="toWorld"><lookAt origin="0 2 0" target="0 0 0" up="0 0 1"/></transform>
    <rgb name="intensity" value="3"/>
    <float name="cutoffAngle" value="30"/>
    <float name="beamWidth" value="20"/>
  </emitter>
</scene>
"#;

const LEGACY_BALL: &str = r#"<shape type="sphere">
  <point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/><ref id="shiny"/>
  <transform name="toWorld"><translate x="0.25"/></transform>
</shape>
"#;

/// The same scene written for Mitsuba 3 by hand.
const CURRENT_SCENE: &str = r#"<scene version="3.0.0">
  <default name="fovValue" value="40"/>
  <sensor type="perspective">
    <float name="fov" value="$fovValue"/>
    <string name="fov_axis" value="smaller"/>
    <transform name="to_world"><lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
  </sensor>
  <bsdf type="diffuse" id="wall"><rgb name="reflectance" value="0.5, 0.4, 0.3"/></bsdf>
  <bsdf type="plastic" id="shiny">
    <float name="int_ior" value="1.6"/>
    <rgb name="diffuse_reflectance" value="0.2, 0.3, 0.4"/>
  </bsdf>
  <shape type="rectangle">
    <transform name="to_world"><scale value="2"/><rotate x="1" angle="-90"/></transform>
    <ref id="wall"/>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/><ref id="shiny"/>
    <transform name="to_world"><translate x="0.25"/></transform>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><translate y="2"/><rotate x="1" angle="90"/></transform>
    <emitter type="area"><rgb name="radiance" value="5, 5, 5"/></emitter>
  </shape>
  <emitter type="spot">
    <transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
    <rgb name="intensity" value="3"/>
    <float name="cutoff_angle" value="30"/>
    <float name="beam_width" value="20"/>
  </emitter>
</scene>
"#;

#[test]
fn a_mitsuba_0_6_scene_and_its_mitsuba_3_twin_load_to_the_same_scene() {
    let dir = tempfile::tempdir().unwrap();
    let old_path = dir.path().join("old.xml");
    fs::write(&old_path, LEGACY_SCENE).unwrap();
    fs::write(dir.path().join("ball.xml"), LEGACY_BALL).unwrap();
    let new_path = dir.path().join("new.xml");
    fs::write(&new_path, CURRENT_SCENE).unwrap();
    let old = load(&old_path, &[]).unwrap();
    let new = load(&new_path, &[]).unwrap();
    assert!(old.warnings.is_empty(), "{:?}", old.warnings);
    assert!(new.warnings.is_empty(), "{:?}", new.warnings);
    // One notice, naming the file and its version; none for the twin.
    assert_eq!(old.notes.len(), 1, "{:?}", old.notes);
    assert!(
        old.notes[0].contains("old.xml") && old.notes[0].contains("0.6.0"),
        "{}",
        old.notes[0]
    );
    assert!(new.notes.is_empty());
    let mut old_scene = old.scene;
    old_scene.path = new.scene.path.clone();
    assert_eq!(old_scene, new.scene);
    // And the upgrade did something: the camera sits at z = 5, the diffuse wall has
    // its reflectance, the sphere its offset, the spot its cone.
    let s = &new.scene;
    assert_eq!(s.shapes.len(), 3);
    assert_eq!(s.lights.len(), 2);
    assert!(s.bsdfs.iter().any(|b| format!("{b:?}").contains("0.4")));
}

/// Mitsuba 3 names in a file that says it is Mitsuba 0.6 are not upgraded twice; a
/// 0.6 `uoffset`/`uscale` pair becomes one `to_uv` transform, uv' = scale (uv +
/// offset) (a cube reads none, so the warning names `to_uv` alone); a version that is
/// not three numbers is a warning naming the file and line.
#[test]
fn legacy_upgrade_edge_cases() {
    let l = load_raw(
        "<scene version=\"0.5.0\">\n<sensor type=\"perspective\"><transform name=\"to_world\">\
         <lookat origin=\"0 0 5\" target=\"0 0 0\"/></transform></sensor>\n</scene>",
        &[],
    )
    .unwrap();
    let unknown = |l: &Loaded| -> Vec<String> {
        l.warnings
            .iter()
            .filter(|w| w.contains("unknown"))
            .cloned()
            .collect()
    };
    assert!(unknown(&l).is_empty(), "{:?}", l.warnings);
    assert!(close(
        l.scene.sensors[0].to_world.w_axis.truncate(),
        Vec3::new(0.0, 0.0, 5.0)
    ));
    assert_eq!(l.notes.len(), 1);
    let l = load_raw(
        &format!(
            "<scene version=\"0.6.0\">\n{SENSOR}\n<shape type=\"cube\">\
             <float name=\"uscale\" value=\"4\"/><float name=\"voffset\" value=\"0.5\"/></shape>\n</scene>"
        ),
        &[],
    )
    .unwrap();
    let unknown = unknown(&l);
    assert_eq!(unknown.len(), 1, "{:?}", l.warnings);
    assert!(unknown[0].contains("'to_uv'"), "{:?}", l.warnings);
    // Mitsuba 0.6's mipmapped filters are read from a mipmap in a 0.6 file, and
    // refused in a Mitsuba 3 file, as Mitsuba 3 refuses them.
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [1, 2, 3], [4, 5, 6]);
    for (version, ok) in [("0.6.0", true), ("3.0.0", false)] {
        let xml = format!(
            "<scene version=\"{version}\">\n{SENSOR}\n<bsdf type=\"diffuse\" id=\"a\">\
             <texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"t.png\"/>\
             <string name=\"filter_type\" value=\"trilinear\"/></texture></bsdf>\n</scene>"
        );
        let path = dir.path().join("scene.xml");
        fs::write(&path, xml).unwrap();
        match (load(&path, &[]), ok) {
            (Ok(l), true) => assert!(
                !l.warnings.iter().any(|w| w.contains("'trilinear'"))
                    && l.scene.textures[0].filter == crate::scene::texture::TexFilter::Trilinear,
                "{:?}",
                l.warnings
            ),
            (Err(e), false) => assert!(e.to_string().contains("'trilinear'"), "{e}"),
            (r, _) => panic!("{version}: {:?}", r.map(|l| l.warnings)),
        }
    }
    let m = properties::legacy_to_uv([0.25, 0.5, 4.0, 2.0]);
    assert!(close(m.transform_point3(Vec3::ZERO), Vec3::new(1.0, 1.0, 0.0)));
    assert!(close(
        m.transform_point3(Vec3::new(1.0, 1.0, 0.0)),
        Vec3::new(5.0, 3.0, 0.0)
    ));
    let l = load_raw(&format!("<scene version=\"zero\">\n{SENSOR}\n</scene>"), &[]).unwrap();
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("scene.xml:1:") && w.contains("'zero'")),
        "{:?}",
        l.warnings
    );
    assert!(l.notes.is_empty());
}

/// Mitsuba 0.6's `<srgb>`: `#rrggbb` or numbers, gamma-encoded, read as the linear
/// colour (0x80 -> 0.2158605, 0.5 -> 0.2140411, as Mitsuba decodes 8-bit sRGB); a bad
/// value is an error naming its line; a Mitsuba 3 file, whose Mitsuba has no `<srgb>`,
/// keeps the warning that names the element.
#[test]
fn a_mitsuba_0_6_srgb_colour_is_read_linear() {
    let reflectance = |version: &str, value: &str| {
        load_raw(
            &format!(
                "<scene version=\"{version}\">\n{SENSOR}\n<shape type=\"cube\"><bsdf type=\"diffuse\">\
                 <srgb name=\"reflectance\" value=\"{value}\"/></bsdf></shape>\n</scene>"
            ),
            &[],
        )
        .map(|l| {
            let k = &l.scene.bsdfs[l.scene.shapes[0].bsdf as usize].kind;
            (k.diffuse_albedo(), l.warnings)
        })
    };
    let (rho, warnings) = reflectance("0.6.0", "#80ff00").unwrap();
    assert!(close(rho, Vec3::new(0.2158605, 1.0, 0.0)), "{rho}");
    assert!(!warnings.iter().any(|w| w.contains("srgb")), "{warnings:?}");
    let (rho, _) = reflectance("0.5.0", "0.5").unwrap();
    assert!(close(rho, Vec3::splat(0.2140411)), "{rho}");
    for bad in ["#80ff0", "#gg0000", "0.5, 0.5"] {
        let e = reflectance("0.6.0", bad).unwrap_err().to_string();
        assert!(e.contains("scene.xml:3:") && e.contains("<srgb>"), "{bad}: {e}");
    }
    let (rho, warnings) = reflectance("3.0.0", "#80ff00").unwrap();
    assert!(close(rho, Vec3::splat(0.5)), "{rho}");
    assert!(warnings.iter().any(|w| w.contains("<srgb>")), "{warnings:?}");
}

/// Writes a 2 x 1 PNG beside the scene: texel 0 (left) bytes `a`, texel 1 `b`.
fn write_png(dir: &std::path::Path, name: &str, a: [u8; 3], b: [u8; 3]) {
    let img = image::RgbImage::from_fn(2, 1, |x, _| image::Rgb(if x == 0 { a } else { b }));
    img.save(dir.join(name)).unwrap();
}

/// A `bitmap` reflectance: the PNG's bytes sRGB-decoded (128 -> 0.2158605), the
/// material's reflectance their mean (what pass 1 uses), each point its texel; one
/// file read once for two materials; `raw` reads the bytes as linear; an OBJ's v
/// runs up the image (Mitsuba's `flip_tex_coords`).
#[test]
fn a_bitmap_texture_gives_the_reflectance_texel_by_texel() {
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [255, 0, 0], [0, 128, 255]);
    fs::write(
        dir.path().join("m.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let xml = scene(&[
        r#"<texture type="bitmap" id="wood"><string name="filename" value="t.png"/>"#,
        r#"<string name="filter_type" value="nearest"/></texture>"#,
        r#"<bsdf type="diffuse" id="a"><ref name="reflectance" id="wood"/></bsdf>"#,
        r#"<bsdf type="plastic" id="b"><texture type="bitmap" name="diffuse_reflectance">"#,
        r#"<string name="filename" value="t.png"/><boolean name="raw" value="true"/></texture></bsdf>"#,
        r#"<shape type="obj"><string name="filename" value="m.obj"/><ref id="a"/></shape>"#,
        r#"<shape type="rectangle"><ref id="b"/></shape>"#,
    ]);
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    let l = load(&path, &[]).unwrap();
    let unknown: Vec<&String> = l.warnings.iter().filter(|w| !w.contains("light")).collect();
    assert!(unknown.is_empty(), "{unknown:?}");
    let s = &l.scene;
    assert_eq!(s.textures.len(), 2, "{:?}", s.textures);
    let g = 0.215_860_5;
    let a = &s.bsdfs[s.shapes[0].bsdf as usize];
    match a.kind {
        BsdfKind::Diffuse { reflectance } => assert!(close(reflectance, Vec3::new(0.5, 0.5 * g, 0.5))),
        ref k => panic!("{k:?}"),
    }
    let at = |b: &Bsdf, u: f32, v: f32| -> Vec3 {
        match b.kind_at(glam::Vec2::new(u, v), 0.0, &s.textures).into_owned() {
            BsdfKind::Diffuse { reflectance } => reflectance,
            BsdfKind::Plastic {
                diffuse_reflectance, ..
            } => diffuse_reflectance,
            k => panic!("{k:?}"),
        }
    };
    assert!(close(at(a, 0.2, 0.5), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(at(a, 0.7, 0.5), Vec3::new(0.0, g, 1.0)));
    let b = &s.bsdfs[s.shapes[1].bsdf as usize];
    assert!(close(at(b, 0.25, 0.5), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(at(b, 0.75, 0.5), Vec3::new(0.0, 128.0 / 255.0, 1.0)));
    // The OBJ's (u, v) = (0, 1) is the image's top left: v flipped to 0.
    assert_eq!(s.shapes[0].mesh.uvs[2], glam::Vec2::new(0.0, 0.0));
    assert_eq!(s.shapes[0].mesh.uvs[0], glam::Vec2::new(0.0, 1.0));
}

/// Mesh files are read ahead of the walk only where the file and `face_normals` are
/// written out, once per file however many shapes name it; where a `$` parameter
/// gives either, the walk reads the file itself. Both ways give the same meshes,
/// and a shape named thrice (its last one moved) gets three whole copies. A broken
/// file named twice fails with the walk's own error, naming the file and line.
#[test]
fn meshes_read_ahead_or_in_the_walk_are_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                vn 0 0 1\nvn 0 0 1\nvn 0 -0.4 1\nvn 0 -0.4 1\nf 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n";
    fs::write(dir.path().join("m.obj"), quad).unwrap();
    let obj = |file: &str, face_normals: &str, moved: bool| {
        format!(
            r#"<shape type="obj"><string name="filename" value="{file}"/><boolean name="face_normals" value="{face_normals}"/>{}</shape>"#,
            if moved {
                r#"<transform name="to_world"><translate x="2"/></transform>"#
            } else {
                ""
            }
        )
    };
    let shapes = [
        obj("m.obj", "false", false),
        obj("$f", "false", false),
        obj("m.obj", "$n", false),
        obj("m.obj", "true", false),
        obj("m.obj", "false", true),
    ];
    let mut lines = vec![
        r#"<default name="f" value="m.obj"/>"#,
        r#"<default name="n" value="true"/>"#,
        r#"<emitter type="point"/>"#,
    ];
    lines.extend(shapes.iter().map(String::as_str));
    let path = dir.path().join("scene.xml");
    fs::write(&path, scene(&lines)).unwrap();
    let s = load(&path, &[]).unwrap().scene;
    let mesh = |k: usize| &s.shapes[k].mesh;
    assert_eq!(mesh(0).positions.len(), 4);
    assert_eq!(mesh(0).normals.len(), 4, "smooth normals from the file");
    assert_eq!(mesh(0), mesh(1));
    assert_eq!(mesh(2), mesh(3));
    assert!(mesh(3).normals.is_empty(), "face_normals: flat");
    let moved: Vec<Vec3> = mesh(0).positions.iter().map(|p| *p + Vec3::X * 2.0).collect();
    assert_eq!(mesh(4).positions, moved);
    assert_eq!(mesh(4).uvs, mesh(0).uvs);

    // A broken file, named twice: the same error as the walk's alone.
    fs::write(dir.path().join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let error = |first: &str| {
        let shapes = [obj(first, "false", false), obj("bad.obj", "false", false)];
        let mut lines = vec![r#"<default name="f" value="bad.obj"/>"#];
        lines.extend(shapes.iter().map(String::as_str));
        fs::write(&path, scene(&lines)).unwrap();
        match load(&path, &[]) {
            Ok(_) => panic!("a broken mesh file fails"),
            Err(e) => e.to_string(),
        }
    };
    let (ahead, walk) = (error("bad.obj"), error("$f"));
    assert_eq!(ahead, walk);
    assert!(ahead.contains("bad.obj") && ahead.contains(":4"), "{ahead}");
}

/// Images are read ahead of the walk only where the file and `raw` are written out;
/// where a `$` parameter gives either, the walk reads the image itself. Both ways
/// give the same texels: the byte 128 sRGB-decoded (0.2158605) unless `raw`
/// (128 / 255), though the read ahead guessed `raw` false for `$r`.
#[test]
fn images_read_ahead_or_in_the_walk_are_the_same() {
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [128, 128, 128], [128, 128, 128]);
    let bitmap = |file: &str, raw: &str| {
        format!(
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="{file}"/><boolean name="raw" value="{raw}"/></texture></bsdf>"#
        )
    };
    let shapes: Vec<String> = [
        ("t.png", "false"),
        ("$f", "false"),
        ("t.png", "$r"),
        ("$f", "true"),
    ]
    .iter()
    .map(|(f, r)| format!(r#"<shape type="rectangle">{}</shape>"#, bitmap(f, r)))
    .collect();
    let mut lines = vec![
        r#"<default name="f" value="t.png"/>"#,
        r#"<default name="r" value="true"/>"#,
    ];
    lines.extend(shapes.iter().map(String::as_str));
    let path = dir.path().join("scene.xml");
    fs::write(&path, scene(&lines)).unwrap();
    let s = load(&path, &[]).unwrap().scene;
    let reflectance = |k: usize| match s.bsdfs[s.shapes[k].bsdf as usize].kind {
        BsdfKind::Diffuse { reflectance } => reflectance.x,
        ref k => panic!("{k:?}"),
    };
    for (k, want) in [
        (0, 0.215_860_5),
        (1, 0.215_860_5),
        (2, 128.0 / 255.0),
        (3, 128.0 / 255.0),
    ] {
        assert!(
            (reflectance(k) - want).abs() < 1e-6,
            "shape {k}: {} vs {want}",
            reflectance(k)
        );
    }
    // One texture for each of the two ways to read the file.
    assert_eq!(s.textures.len(), 2);
}

/// Bad textures: a file that is no image, a missing file, an unknown wrap mode or
/// filter: one error naming the scene file and the line of the parameter.
#[test]
fn bad_textures_are_errors_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [1, 2, 3], [4, 5, 6]);
    fs::write(dir.path().join("fake.png"), "not an image").unwrap();
    for (line, want) in [
        (r#"<string name="filename" value="fake.png"/>"#, "cannot decode"),
        (r#"<string name="filename" value="gone.jpg"/>"#, "no such file"),
        (
            r#"<string name="filename" value="t.png"/><string name="wrap_mode" value="tile"/>"#,
            "'tile' is not 'repeat', 'mirror' or 'clamp'",
        ),
        (
            r#"<string name="filename" value="t.png"/><string name="filter_type" value="cubic"/>"#,
            "'cubic' is not 'bilinear' or 'nearest'",
        ),
    ] {
        let xml = scene(&[
            r#"<bsdf type="diffuse" id="a"><texture type="bitmap" name="reflectance">"#,
            line,
            "</texture></bsdf>",
        ]);
        let path = dir.path().join("scene.xml");
        fs::write(&path, xml).unwrap();
        let e = load(&path, &[]).unwrap_err().to_string();
        assert!(e.contains("scene.xml:4:"), "{e}");
        assert!(e.contains(want), "{e}");
    }
}

/// A rough conductor's bad parameters: one error naming the file, the line and the
/// parameter; anisotropic roughness is read without a warning, on metal and on rough
/// glass (its axes follow the surface's dp/du).
#[test]
fn bad_rough_conductors_are_errors_naming_the_parameter() {
    for (param, want) in [
        (
            r#"<float name="alpha" value="-0.1"/>"#,
            "'alpha' = -0.1 must be a positive roughness",
        ),
        (
            r#"<string name="distribution" value="phong"/>"#,
            "'phong' is not 'beckmann' or 'ggx'",
        ),
        (r#"<rgb name="eta" value="-1, 1, 1"/>"#, "'eta' is negative"),
        (
            r#"<string name="material" value="Au"/><float name="eta" value="1.5"/>"#,
            "either 'material' or 'eta'/'k'",
        ),
    ] {
        let xml = scene(&[
            r#"<shape type="cube">"#,
            r#"<bsdf type="roughconductor">"#,
            param,
            "</bsdf></shape>",
        ]);
        let m = match load_raw(&xml, &[]) {
            Ok(_) => panic!("{param}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(m.contains("scene.xml:"), "{m}");
        assert!(m.contains(want), "{param}: {m}");
    }
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="roughconductor"><float name="alpha_u" value="0.1"/>"#,
        r#"<float name="alpha_v" value="0.3"/></bsdf></shape>"#,
    ]);
    assert!(
        !l.warnings.iter().any(|w| w.contains("anisotropic")),
        "{:?}",
        l.warnings
    );
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/>"#,
        r#"<float name="alpha_v" value="0.3"/></bsdf></shape>"#,
    ]);
    assert!(
        !l.warnings.iter().any(|w| w.contains("anisotropic")),
        "{:?}",
        l.warnings
    );
}

/// `bumpmap` (its texture under any name, `scale`) and `normalmap` keep their nested
/// bsdf and add the map as a slot, with Mitsuba 3.7.1's two rules on unless turned
/// off (`flip_invalid_normals`, `use_shadowing_function`); without an image, the
/// nested bsdf alone, warned.
#[test]
fn bump_and_normal_maps_wrap_their_nested_bsdf() {
    use crate::scene::TexField;
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "h.png", [0, 0, 0], [255, 255, 255]);
    let xml = format!(
        "<scene version=\"3.0.0\">\n{SENSOR}\n\
         <bsdf type=\"bumpmap\" id=\"b\"><texture type=\"bitmap\" name=\"arbitrary\"><string name=\"filename\" value=\"h.png\"/><boolean name=\"raw\" value=\"true\"/></texture>\
         <float name=\"scale\" value=\"0.5\"/><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.3\"/></bsdf></bsdf>\n\
         <bsdf type=\"normalmap\" id=\"n\"><texture type=\"bitmap\" name=\"normalmap\"><string name=\"filename\" value=\"h.png\"/><boolean name=\"raw\" value=\"true\"/></texture>\
         <boolean name=\"use_shadowing_function\" value=\"false\"/><bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></bsdf>\n\
         <bsdf type=\"bumpmap\" id=\"c\"><bsdf type=\"diffuse\"/></bsdf>\n\
         <shape type=\"cube\"><ref id=\"b\"/></shape><shape type=\"cube\"><ref id=\"n\"/></shape><shape type=\"cube\"><ref id=\"c\"/></shape>\n</scene>"
    );
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    let l = load(&path, &[]).unwrap();
    let b = &l.scene.bsdfs;
    assert_eq!(
        b[0].kind,
        BsdfKind::Diffuse {
            reflectance: Vec3::splat(0.3)
        }
    );
    assert_eq!(
        (b[0].textures[0].field, b[0].textures[0].factor.x),
        (
            TexField::Bump(crate::scene::BumpRules {
                flip: true,
                shadowing: true
            }),
            0.5
        )
    );
    assert!(b[1].twosided);
    assert_eq!(
        b[1].textures[0].field,
        TexField::Normal(crate::scene::BumpRules {
            flip: true,
            shadowing: false
        })
    );
    assert!(b[2].textures.is_empty());
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains(":5:") && w.contains("without a bitmap")),
        "{:?}",
        l.warnings
    );
    assert!(
        !l.warnings.iter().any(|w| w.contains("not supported")),
        "{:?}",
        l.warnings
    );
}

/// `roughplastic`: a microfacet lobe with a dielectric Fresnel term over a diffuse
/// base, no warning; Mitsuba 3's defaults (Beckmann, alpha 0.1, int_ior 1.49
/// (polypropylene), ext_ior 1.000277 (air), diffuse 0.5, specular 1, linear), and
/// every parameter read, named IORs included.
#[test]
fn roughplastic_is_a_dielectric_lobe_over_a_diffuse_base() {
    use crate::scene::{Fresnel, Glossy, Microfacet};
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="roughplastic"/></shape>"#,
        r#"<shape type="cube"><bsdf type="roughplastic"><string name="distribution" value="ggx"/>"#,
        r#"<float name="alpha" value="0.3"/><string name="int_ior" value="bk7"/><float name="ext_ior" value="1.2"/>"#,
        r#"<rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/><rgb name="specular_reflectance" value="0.5"/>"#,
        r#"<boolean name="nonlinear" value="true"/><boolean name="sample_visible" value="false"/></bsdf></shape>"#,
        r#"<emitter type="point"/>"#,
    ]);
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let lobe = |beckmann, alpha, eta, scale| Glossy {
        distribution: Microfacet {
            alpha_u: alpha,
            alpha_v: alpha,
            beckmann,
        },
        fresnel: Fresnel::Dielectric { eta },
        scale,
    };
    assert_eq!(
        l.scene.bsdfs[0].kind,
        BsdfKind::RoughPlastic {
            diffuse_reflectance: Vec3::splat(0.5),
            lobe: lobe(true, 0.1, 1.49 / 1.000277, Vec3::ONE),
            nonlinear: false,
            coating: Default::default(),
            pplastic: false,
        }
    );
    assert_eq!(
        l.scene.bsdfs[1].kind,
        BsdfKind::RoughPlastic {
            diffuse_reflectance: Vec3::new(0.1, 0.2, 0.3),
            lobe: lobe(false, 0.3, 1.5046 / 1.2, Vec3::splat(0.5)),
            nonlinear: true,
            coating: Default::default(),
            pplastic: false,
        }
    );
    // Equal alpha_u and alpha_v are one alpha.
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="roughplastic"><float name="alpha_u" value="0.2"/>"#,
        r#"<float name="alpha_v" value="0.2"/></bsdf></shape>"#,
    ]);
    let BsdfKind::RoughPlastic { lobe, .. } = l.scene.bsdfs[0].kind else {
        panic!()
    };
    assert_eq!((lobe.distribution.alpha_u, lobe.distribution.alpha_v), (0.2, 0.2));
}

/// Mitsuba 3's `pplastic` loads without a warning, with its defaults (Beckmann, alpha
/// 0.1, polypropylene in air, diffuse 0.5) and an anisotropic lobe where it has one; a
/// textured diffuse reflectance is read per point. Before, it was "not supported" and
/// rendered as diffuse 0.5.
#[test]
fn pplastic_loads_with_mitsubas_defaults() {
    use crate::scene::{Fresnel, Glossy, Microfacet};
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="pplastic"/></shape>"#,
        r#"<shape type="cube"><bsdf type="pplastic"><string name="distribution" value="ggx"/>"#,
        r#"<float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/><float name="int_ior" value="1.6"/>"#,
        r#"<texture type="checkerboard" name="diffuse_reflectance"/><rgb name="specular_reflectance" value="0.5"/>"#,
        r#"</bsdf></shape>"#,
        r#"<emitter type="point"/>"#,
    ]);
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert_eq!(
        l.scene.bsdfs[0].kind,
        BsdfKind::RoughPlastic {
            diffuse_reflectance: Vec3::splat(0.5),
            lobe: Glossy {
                distribution: Microfacet {
                    alpha_u: 0.1,
                    alpha_v: 0.1,
                    beckmann: true,
                },
                fresnel: Fresnel::Dielectric { eta: 1.49 / 1.000277 },
                scale: Vec3::ONE,
            },
            nonlinear: false,
            coating: Default::default(),
            pplastic: true,
        }
    );
    let BsdfKind::RoughPlastic { lobe, pplastic, .. } = l.scene.bsdfs[1].kind else {
        panic!("{:?}", l.scene.bsdfs[1].kind)
    };
    assert!(pplastic);
    assert_eq!(
        (
            lobe.distribution.alpha_u,
            lobe.distribution.alpha_v,
            lobe.distribution.beckmann
        ),
        (0.05, 0.3, false)
    );
    assert_eq!(lobe.scale, Vec3::splat(0.5));
    assert_eq!(l.scene.bsdfs[1].textures.len(), 1);
}

/// A rough plastic's bad roughness, distribution or IOR: one error naming the file,
/// the line and the parameter.
#[test]
fn bad_rough_plastics_are_errors_naming_the_parameter() {
    for (param, want) in [
        (
            r#"<float name="alpha" value="0"/>"#,
            "'alpha' = 0 must be a positive roughness",
        ),
        (
            r#"<float name="alpha" value="-0.5"/>"#,
            "'alpha' = -0.5 must be a positive roughness",
        ),
        (
            r#"<string name="distribution" value="phong"/>"#,
            "'phong' is not 'beckmann' or 'ggx'",
        ),
        (
            r#"<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>"#,
            "'roughplastic' is isotropic",
        ),
        (
            r#"<string name="int_ior" value="unobtainium"/>"#,
            "'unobtainium' is not a known material",
        ),
        (
            r#"<float name="ext_ior" value="-1"/>"#,
            "'ext_ior' = -1 must be positive",
        ),
    ] {
        let xml = scene(&[
            r#"<shape type="cube"><bsdf type="roughplastic">"#,
            param,
            "</bsdf></shape>",
        ]);
        let m = err_at(&xml, 4);
        assert!(m.contains(want), "{param}: {m}");
    }
}

/// Textures on a rough plastic: `diffuse_reflectance` gives the base's reflectance
/// and `specular_reflectance` the lobe's scale, texel by texel.
#[test]
fn a_rough_plastic_takes_its_reflectances_from_bitmaps() {
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [255, 0, 0], [0, 128, 255]);
    let xml = scene(&[
        r#"<bsdf type="roughplastic" id="r"><texture type="bitmap" name="diffuse_reflectance">"#,
        r#"<string name="filename" value="t.png"/><boolean name="raw" value="true"/></texture>"#,
        r#"<texture type="bitmap" name="specular_reflectance"><string name="filename" value="t.png"/>"#,
        r#"<boolean name="raw" value="true"/><string name="filter_type" value="nearest"/></texture></bsdf>"#,
        r#"<shape type="rectangle"><ref id="r"/></shape>"#,
    ]);
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    let l = load(&path, &[]).unwrap();
    let s = &l.scene;
    let b = &s.bsdfs[s.shapes[0].bsdf as usize];
    assert_eq!(b.textures.len(), 2);
    let at = |u: f32| match b.kind_at(glam::Vec2::new(u, 0.5), 0.0, &s.textures).into_owned() {
        BsdfKind::RoughPlastic {
            diffuse_reflectance,
            lobe,
            ..
        } => (diffuse_reflectance, lobe.scale),
        k => panic!("{k:?}"),
    };
    let (red, blue) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 128.0 / 255.0, 1.0));
    assert!(close(at(0.25).0, red) && close(at(0.25).1, red), "{:?}", at(0.25));
    assert!(
        close(at(0.75).0, blue) && close(at(0.75).1, blue),
        "{:?}",
        at(0.75)
    );
}

/// A colour bitmap where Mitsuba reads one value (`eval_1`: a `blendbsdf`'s weight, a
/// `mask`'s opacity) gives its texel's luminance, as Mitsuba 3 does (a pure red texel
/// 0.212671, not its red channel 1; the known answer from Mitsuba 3.9's `eval_1` of such
/// a bitmap).
#[test]
fn a_colour_bitmap_read_as_one_value_gives_its_luminance() {
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [255, 0, 0], [0, 128, 255]);
    let bitmap = r#"<texture type="bitmap" name="NAME"><string name="filename" value="t.png"/><boolean name="raw" value="true"/><string name="filter_type" value="nearest"/></texture>"#;
    let xml = scene(&[
        r#"<bsdf type="blendbsdf" id="b">"#,
        &bitmap.replace("NAME", "weight"),
        r#"<bsdf type="diffuse"/><bsdf type="conductor"/></bsdf>"#,
        r#"<bsdf type="mask" id="m">"#,
        &bitmap.replace("NAME", "opacity"),
        r#"<bsdf type="diffuse"/></bsdf>"#,
        r#"<shape type="rectangle"><ref id="b"/></shape>"#,
        r#"<shape type="rectangle"><ref id="m"/></shape>"#,
    ]);
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    let l = load(&path, &[]).unwrap();
    let s = &l.scene;
    let blend = &s.bsdfs[s.shapes[0].bsdf as usize];
    let mask = &s.bsdfs[s.shapes[1].bsdf as usize];
    let red = 0.212671;
    let blue = 0.715160 * 128.0 / 255.0 + 0.072169;
    for (u, want) in [(0.25, red), (0.75, blue)] {
        let uv = glam::Vec2::new(u, 0.5);
        match blend.kind_at(uv, 0.0, &s.textures).into_owned() {
            BsdfKind::Blend { weight, .. } => assert!((weight - want).abs() < 1e-5, "{u}: {weight}"),
            k => panic!("{k:?}"),
        }
        let o = mask.opacity_at(uv, &s.textures);
        assert!((o - want).abs() < 1e-5, "{u}: {o}");
    }
}

/// `mask`: its opacity (a number, as a one-texel image, or a bitmap) over its nested
/// bsdf; shadow rays pass masked shapes (dimmed by the open share); an opacity
/// outside [0, 1] is an error naming its line.
#[test]
fn a_mask_keeps_its_bsdf_and_its_opacity() {
    use crate::scene::TexField;
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf></shape>"#,
    ]);
    assert!(!l.warnings.iter().any(|w| w.contains("mask")), "{:?}", l.warnings);
    let b = &l.scene.bsdfs[l.scene.shapes[0].bsdf as usize];
    assert!(b.masked() && b.textures[0].field == TexField::Opacity);
    assert!((l.scene.textures[b.textures[0].texture as usize].mean.x - 0.3).abs() < 1e-6);
    assert!(l.scene.passes_shadows(0));
    let e = err(
        &[
            r#"<shape type="cube"><bsdf type="mask"><float name="opacity" value="1.5"/><bsdf type="diffuse"/></bsdf></shape>"#,
        ],
        3,
    );
    assert!(e.contains("opacity"), "{e}");
}

/// Mitsuba 3's `principled`: a rough plastic (GGX of alpha = roughness^2, the index
/// that `specular` gives, 2 / (1 - sqrt(0.08 s)) - 1: 1.5 for 0.5; its diffuse albedo
/// the base colour) at `metallic` 0, a
/// rough metal (Schlick's curve from the base colour) at 1, the base colour's diffuse
/// and the metal blended by `metallic` between; `eta` wins over `specular`;
/// `anisotropic` stretches the roughness as Mitsuba does; a clearcoat warns; a
/// roughness outside [0, 1] fails with its line.
#[test]
fn principled_reads_as_a_plastic_a_metal_or_their_blend() {
    use crate::scene::{Fresnel, Glossy};
    let l = ok(&[
        r#"<shape type="cube"><bsdf type="principled"><rgb name="base_color" value="0.6, 0.2, 0.1"/><float name="roughness" value="0.3"/></bsdf></shape>"#,
        r#"<shape type="cube"><bsdf type="principled"><rgb name="base_color" value="0.9, 0.7, 0.3"/><float name="metallic" value="1"/><float name="eta" value="1.33"/></bsdf></shape>"#,
        r#"<shape type="cube"><bsdf type="principled"><float name="metallic" value="0.25"/><float name="anisotropic" value="0.5"/><float name="clearcoat" value="0.4"/></bsdf></shape>"#,
    ]);
    let base = Vec3::new(0.6, 0.2, 0.1);
    match &l.scene.bsdfs[0].kind {
        BsdfKind::RoughPlastic {
            diffuse_reflectance,
            lobe:
                Glossy {
                    distribution,
                    fresnel: Fresnel::Dielectric { eta },
                    ..
                },
            ..
        } => {
            // Raised so that its diffuse albedo is the base colour (Mitsuba's diffuse
            // is not dimmed by the coat).
            assert!(diffuse_reflectance.x > base.x);
            let albedo = l.scene.bsdfs[0].kind.diffuse_albedo();
            assert!((albedo - base).abs().max_element() < 1e-4, "{albedo}");
            assert!((distribution.alpha_u - 0.09).abs() < 1e-6 && !distribution.beckmann);
            assert!((eta - 1.5).abs() < 1e-3, "{eta}");
        }
        k => panic!("{k:?}"),
    }
    match &l.scene.bsdfs[1].kind {
        BsdfKind::RoughConductor {
            lobe:
                Glossy {
                    distribution,
                    fresnel: Fresnel::Schlick { f0 },
                    ..
                },
        } => {
            assert_eq!(*f0, Vec3::new(0.9, 0.7, 0.3));
            assert!((distribution.alpha_u - 0.25).abs() < 1e-6);
        }
        k => panic!("{k:?}"),
    }
    match &l.scene.bsdfs[2].kind {
        BsdfKind::Blend { weight, a, b } => {
            assert_eq!(*weight, 0.25);
            assert_eq!(
                **a,
                BsdfKind::Diffuse {
                    reflectance: Vec3::splat(0.5)
                }
            );
            let BsdfKind::RoughConductor { lobe } = &**b else {
                panic!("{b:?}")
            };
            // alpha 0.25 over and by the aspect sqrt(1 - 0.45).
            let aspect = 0.55f32.sqrt();
            assert!((lobe.distribution.alpha_u - 0.25 / aspect).abs() < 1e-5);
            assert!((lobe.distribution.alpha_v - 0.25 * aspect).abs() < 1e-5);
        }
        k => panic!("{k:?}"),
    }
    assert!(has_warning(&l, 5, "clearcoat"), "{:?}", l.warnings);
    assert!(
        !l.warnings.iter().any(|w| w.contains("not supported")),
        "{:?}",
        l.warnings
    );
    let m = err(
        &[r#"<bsdf type="principled" id="p"><float name="roughness" value="1.5"/></bsdf>"#],
        3,
    );
    assert!(m.contains("'roughness'"), "{m}");
}

/// An integrator's `max_depth` that cuts light off (here 3, or 4 in an integrator
/// nested in another, or a parameter) is noted with its line, since radtrace renders
/// every bounce; no limit (-1) or a deep one (65, as Bitterli's scenes give) is not.
/// Mitsuba's `direct` integrator, which renders direct light alone, is noted too.
#[test]
fn a_short_max_depth_or_a_direct_integrator_is_noted() {
    // The notes that name `about`.
    let notes_on = |integrator: &str, about: &str| {
        load_raw(
            &format!("<scene version=\"3.0.0\">\n<default name=\"d\" value=\"5\"/>\n{SENSOR}\n{integrator}\n</scene>"),
            &[],
        )
        .unwrap()
        .notes
        .into_iter()
        .filter(|n| n.contains(about))
        .collect::<Vec<_>>()
    };
    let notes = |integrator: &str| notes_on(integrator, "max_depth");
    let n = notes(r#"<integrator type="path"><integer name="max_depth" value="3"/></integrator>"#);
    assert!(
        n.len() == 1 && n[0].contains("scene.xml:4:") && n[0].contains("max_depth 3"),
        "{n:?}"
    );
    let n = notes(
        r#"<integrator type="adaptive"><integrator type="volpath"><integer name="max_depth" value="4"/></integrator></integrator>"#,
    );
    assert!(n.len() == 1 && n[0].contains("max_depth 4"), "{n:?}");
    let n = notes(r#"<integrator type="path"><integer name="max_depth" value="$d"/></integrator>"#);
    assert!(n.len() == 1 && n[0].contains("max_depth 5"), "{n:?}");
    for deep in ["-1", "65"] {
        let n = notes(&format!(
            r#"<integrator type="path"><integer name="max_depth" value="{deep}"/></integrator>"#
        ));
        assert!(n.is_empty(), "{deep}: {n:?}");
    }
    // Mitsuba's `direct` integrator (here or nested) renders direct light alone.
    let direct = |integrator: &str| notes_on(integrator, "'direct'");
    let n = direct(r#"<integrator type="direct"/>"#);
    assert!(n.len() == 1 && n[0].contains("direct light alone"), "{n:?}");
    let n = direct(r#"<integrator type="aov"><integrator type="direct"/></integrator>"#);
    assert_eq!(n.len(), 1, "{n:?}");
    assert!(direct(r#"<integrator type="path"/>"#).is_empty());
}

/// An area light's `bitmap` radiance is kept as its texture (shown where the light is
/// seen), its mean the light's radiance; a note says so, and no warning.
#[test]
fn a_bitmap_radiance_of_an_area_light_is_its_texture() {
    let dir = tempfile::tempdir().unwrap();
    write_png(dir.path(), "t.png", [255, 0, 0], [0, 0, 255]);
    let xml = scene(&[
        r#"<shape type="rectangle"><emitter type="area"><texture type="bitmap" name="radiance">"#,
        r#"<string name="filename" value="t.png"/></texture></emitter></shape>"#,
    ]);
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    let l = load(&path, &[]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    assert!(
        l.notes
            .iter()
            .any(|n| n.contains("scene.xml:3:") && n.contains("radiance texture")),
        "{:?}",
        l.notes
    );
    match &l.scene.lights[..] {
        [Light::Area {
            radiance,
            texture: Some(t),
            ..
        }] => {
            assert!(close(*radiance, Vec3::new(0.5, 0.0, 0.5)), "{radiance}");
            let tex = &l.scene.textures[*t as usize];
            assert!(
                close(tex.eval(glam::Vec2::new(0.25, 0.5)), Vec3::X),
                "{}",
                tex.eval(glam::Vec2::new(0.25, 0.5))
            );
        }
        other => panic!("{other:?}"),
    }
}

/// Parameters of Mitsuba 3's emitters that choose how Mitsuba samples the lights, not
/// what it renders (`sampling_weight` on any emitter, an envmap's `mis_compensation`),
/// are accepted without a warning; a misspelt one still warns.
#[test]
fn emitter_sampling_parameters_are_accepted() {
    let l = ok(&[
        r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/><float name="sampling_weight" value="2"/></emitter></shape>"#,
        r#"<emitter type="point"><float name="sampling_weight" value="0.5"/></emitter>"#,
        r#"<emitter type="constant"><float name="sampling_weight" value="1"/><float name="sampling_weigth" value="1"/></emitter>"#,
    ]);
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
    assert!(has_warning(&l, 5, "'sampling_weigth'"), "{:?}", l.warnings);
    let dir = tempfile::tempdir().unwrap();
    exr::prelude::write_rgb_file(dir.path().join("sky.exr"), 8, 5, |_, _| (1.0f32, 1.0f32, 1.0f32)).unwrap();
    let xml = scene(&[
        r#"<emitter type="envmap"><string name="filename" value="sky.exr"/><boolean name="mis_compensation" value="true"/></emitter>"#,
        r#"<shape type="rectangle"/>"#,
    ]);
    let path = dir.path().join("scene.xml");
    fs::write(&path, xml).unwrap();
    let l = load(&path, &[]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
}

/// Mitsuba's `thinlens`: its `aperture_radius` (required, as Mitsuba requires it) and
/// `focus_distance` (the far clip plane unless given, as Mitsuba's) make the sensor's
/// lens, without a warning; a radius of 0 is a pinhole; a bad value is an error naming
/// the line.
#[test]
fn a_thinlens_sensor_reads_its_lens() {
    use crate::scene::Lens;
    let lens = |params: &str| {
        load_raw(
            &format!(
                "<scene version=\"3.0.0\">\n<sensor type=\"thinlens\">{params}</sensor>\n<shape type=\"rectangle\"/><emitter type=\"constant\"/>\n</scene>"
            ),
            &[],
        )
        .map(|l| (l.scene.sensors[0].lens, l.warnings))
    };
    let (l, w) =
        lens(r#"<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="4"/>"#)
            .unwrap();
    assert_eq!(
        l,
        Some(Lens {
            radius: 0.1,
            focus: 4.0
        })
    );
    assert!(w.is_empty(), "{w:?}");
    let (l, _) =
        lens(r#"<float name="aperture_radius" value="0.1"/><float name="far_clip" value="50"/>"#).unwrap();
    assert_eq!(
        l,
        Some(Lens {
            radius: 0.1,
            focus: 50.0
        })
    );
    assert_eq!(
        lens(r#"<float name="aperture_radius" value="0"/>"#).unwrap().0,
        None
    );
    for (params, want) in [
        ("", "'aperture_radius'"),
        (r#"<float name="aperture_radius" value="-1"/>"#, "aperture_radius"),
        (
            r#"<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="0"/>"#,
            "focus_distance",
        ),
    ] {
        let e = lens(params).unwrap_err().to_string();
        assert!(e.contains("scene.xml:2:") && e.contains(want), "{params}: {e}");
    }
}
