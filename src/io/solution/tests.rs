use super::*;
use crate::accel::Bvh;
use crate::geometry::{shapes, BezierPatch, TriMesh};
use crate::scene::{Bsdf, Sensor, Shape};
use glam::Vec3;
use proptest::prelude::*;
use std::fs;
use std::sync::OnceLock;

fn settings() -> SolveSettings {
    SolveSettings {
        mesh_size: 0.5,
        sources_per_patch: 2,
        shoot_samples: 4,
        tolerance: 0.05,
        max_shots: 50,
        seed: 1,
        photons: 0,
        max_photons: 0,
        time_limit: 0.0,
        gathered: false,
    }
}

/// A square of half-size `s` at height `z`, facing up (+z).
fn square(s: f32, z: f32) -> TriMesh {
    TriMesh {
        positions: vec![
            Vec3::new(-s, -s, z),
            Vec3::new(s, -s, z),
            Vec3::new(s, s, z),
            Vec3::new(-s, s, z),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        tri_patch: vec![0, 0],
        patches: vec![Patch::Polygon(vec![0, 1, 2, 3])],
        ..Default::default()
    }
}

/// A closed box `[-1,1]^3` facing inwards (six quads, grey), a small white
/// square table inside and a point light above it.
fn box_scene() -> Scene {
    let mut walls = shapes::cube();
    walls.flip_normals();
    Scene {
        path: "box.xml".into(),
        shapes: vec![
            Shape {
                name: "walls".into(),
                mesh: walls,
                bsdf: 0,
                emitter: None,
            },
            Shape {
                name: "table".into(),
                mesh: square(0.3, -0.5),
                bsdf: 1,
                emitter: None,
            },
        ],
        bsdfs: vec![
            Bsdf {
                name: "grey".into(),
                kind: BsdfKind::Diffuse {
                    reflectance: Vec3::new(0.5, 0.4, 0.3),
                },
                twosided: false,
                textures: Vec::new(),
            },
            Bsdf {
                name: "white".into(),
                kind: BsdfKind::Diffuse {
                    reflectance: Vec3::splat(0.8),
                },
                twosided: true,
                textures: Vec::new(),
            },
        ],
        lights: vec![Light::Point {
            position: Vec3::new(0.1, 0.2, 0.45),
            intensity: Vec3::new(3.0, 2.0, 1.0),
        }],
        light_ids: vec![],
        sensors: vec![],
        textures: vec![],
        sun_disk: None,
    }
}

fn load_for(path: &Path, scene: &Scene) -> Result<Solution> {
    load(path, scene, &Bvh::build(scene))
}

/// The box scene and its solution, computed once for all tests.
fn solved() -> &'static (Scene, Solution) {
    static SOLVED: OnceLock<(Scene, Solution)> = OnceLock::new();
    SOLVED.get_or_init(|| {
        let scene = box_scene();
        let sol = crate::radiosity::solve(&scene, &Bvh::build(&scene), &settings(), &crate::progress::Silent)
            .unwrap();
        (scene, sol)
    })
}

fn tmpdir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// The box solution saved to a fresh file: (dir, path, bytes).
fn saved(name: &str) -> (tempfile::TempDir, std::path::PathBuf, Vec<u8>) {
    let (scene, sol) = solved();
    let dir = tmpdir();
    let path = dir.path().join(name);
    save(sol, scene, &path).unwrap();
    let bytes = fs::read(&path).unwrap();
    (dir, path, bytes)
}

/// Loading `bytes` (written to a file named `name`) for the box scene must fail;
/// returns the message after checking that it names the file.
fn load_err(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    fs::write(&path, bytes).unwrap();
    let Err(err) = load_for(&path, &solved().0) else {
        panic!("{name} was accepted");
    };
    assert!(matches!(err, Error::Input { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.starts_with(&format!("{}: ", path.display())), "{msg}");
    msg
}

/// A payload encoded as `save` does, from parts (to forge files in tests).
fn payload(
    settings: &SolveSettings,
    general: &[Rgb],
    lists: &[Vec<ListEntry>],
    stats: &SolveStats,
    vertex_count: u64,
    patch_vertex_counts: Vec<u32>,
) -> Vec<u8> {
    codec(u64::MAX)
        .serialize(&PayloadOut {
            settings,
            general,
            caustic: &[],
            lists,
            stats,
            vertex_count,
            patch_vertex_counts,
        })
        .unwrap()
}

fn counts(sol: &Solution) -> Vec<u32> {
    sol.mesh.patches.iter().map(|p| p.vertex_count).collect()
}

/// A well-formed file for the box scene with the given payload.
fn forged(payload: &[u8]) -> Vec<u8> {
    encode_file(FORMAT_VERSION, scene_fingerprint(&solved().0), payload)
}

#[test]
fn the_test_solution_is_not_trivial() {
    let (scene, sol) = solved();
    // 6 walls of 2x2 at mesh size 0.5: 4x4 quads, 25 vertices each, but the floor,
    // which holds the table half a metre over it, at half the size: 8x8 quads, 81
    // vertices (see `mesh::contact`); the table
    // (0.6 wide) 2x2 quads, 9 vertices.
    // The table is two-sided, so it has a back twin with 9 more vertices.
    assert_eq!(sol.mesh.patches.len(), 8);
    assert_eq!(sol.mesh.vertices.len(), 5 * 25 + 81 + 9 + 9);
    assert_eq!(sol.general.len(), 224);
    assert_eq!(sol.stats.light_shots, 1);
    assert!(sol.stats.patch_shots > 0);
    assert!(sol.lists.iter().all(|l| !l.is_empty() && l.len() <= 2));
    assert!(sol.lists.iter().flatten().any(|e| e.source == SourceId::Light(0)));
    assert!(sol.general.iter().any(|c| c.x > 0.0));
    assert_eq!(scene.lights.len(), 1);
}

#[test]
fn round_trip_gives_the_same_solution() {
    let (scene, sol) = solved();
    let (_dir, path, bytes) = saved("box.rts");
    let back = load_for(&path, scene).unwrap();
    assert_eq!(back.settings, sol.settings);
    assert_eq!(back.stats, sol.stats);
    assert_eq!(back.lists, sol.lists);
    assert_eq!(back.general.len(), sol.general.len());
    for (a, b) in back.general.iter().zip(&sol.general) {
        assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
    }
    assert_eq!(back.mesh, sol.mesh);
    assert_eq!(back.total(), sol.total());
    assert_eq!(back.caustic, sol.caustic);

    // The header, field by field.
    assert_eq!(&bytes[..18], b"RADTRACE-SOLUTION\n");
    assert_eq!(&bytes[18..22], &[8, 0, 0, 0]);
    assert_eq!(
        u64::from_le_bytes(bytes[22..30].try_into().unwrap()),
        scene_fingerprint(scene)
    );
    let len = u64::from_le_bytes(bytes[30..38].try_into().unwrap());
    assert_eq!(len as usize, bytes.len() - 42);
    let mut crc = crc32fast::Hasher::new();
    crc.update(&bytes[18..38]);
    crc.update(&bytes[42..]);
    assert_eq!(
        u32::from_le_bytes(bytes[38..42].try_into().unwrap()),
        crc.finalize()
    );
    // The payload opens with the settings: mesh size 0.5 as f32 bits, n = 2...
    assert_eq!(&bytes[42..46], &0.5f32.to_le_bytes());
    assert_eq!(&bytes[46..50], &2u32.to_le_bytes());
    // ...followed (after the 45 bytes of settings) by the vertex count of general.
    assert_eq!(&bytes[87..95], &224u64.to_le_bytes());

    // Saving again replaces the file with the same bytes (deterministic).
    save(sol, scene, &path).unwrap();
    assert_eq!(fs::read(&path).unwrap(), bytes);
}

#[test]
fn fingerprint_is_stable_and_sees_what_matters() {
    let scene = box_scene();
    let fp = scene_fingerprint(&scene);
    assert_eq!(fp, scene_fingerprint(&scene.clone()));
    assert_eq!(fp, scene_fingerprint(&box_scene()));
    // Pinned (on a scene made here only, so other modules' shapes can't move it)
    // so that an accidental change to the hashing, which would refuse every
    // existing file, is noticed.
    let mut small = scene.clone();
    small.shapes.remove(0);
    small.shapes[0].bsdf = 0;
    small.bsdfs.truncate(1);
    // (The light where the box had it when the value was pinned.)
    small.lights = vec![Light::Point {
        position: Vec3::new(0.1, 0.2, 0.6),
        intensity: Vec3::new(3.0, 2.0, 1.0),
    }];
    assert_eq!(
        scene_fingerprint(&small),
        16_009_516_134_389_156_963,
        "the fingerprint function changed"
    );

    // Names, the path, shading normals and views do not matter.
    let mut same = scene.clone();
    same.path = "elsewhere/other.xml".into();
    same.shapes[0].name = "renamed".into();
    same.bsdfs[1].name = "renamed".into();
    same.shapes[1].mesh.normals = vec![Vec3::Z; 4];
    same.sensors.push(Sensor {
        to_world: glam::Mat4::IDENTITY,
        projection: crate::scene::Projection::Perspective,
        fov: 45.0,
        fov_axis: crate::scene::FovAxis::X,
        width: 8,
        height: 8,
        near_clip: 0.01,
        far_clip: 100.0,
        spp: None,
        filter: None,
        crop: None,
        lens: None,
    });
    assert_eq!(scene_fingerprint(&same), fp);

    let differs = |f: &dyn Fn(&mut Scene)| {
        let mut s = scene.clone();
        f(&mut s);
        let g = scene_fingerprint(&s);
        assert_ne!(g, fp);
        g
    };
    let mut all = vec![
        differs(&|s| s.shapes[0].mesh.positions[5].y += 1e-3),
        differs(&|s| {
            s.shapes[1].mesh.positions[0].x = f32::from_bits(s.shapes[1].mesh.positions[0].x.to_bits() + 1)
        }),
        differs(&|s| s.shapes[0].mesh.indices[3].swap(0, 1)),
        differs(&|s| s.shapes[0].mesh.tri_patch[0] = 1),
        differs(&|s| {
            if let Patch::Polygon(v) = &mut s.shapes[0].mesh.patches[2] {
                v.rotate_left(1);
            }
        }),
        differs(&|s| {
            s.bsdfs[0].kind = BsdfKind::Diffuse {
                reflectance: Vec3::new(0.5, 0.4, 0.31),
            }
        }),
        differs(&|s| {
            s.bsdfs[0].kind = BsdfKind::Conductor {
                specular_reflectance: Vec3::new(0.5, 0.4, 0.3),
                fresnel: crate::scene::Fresnel::Schlick { f0: Vec3::ONE },
            }
        }),
        differs(&|s| s.bsdfs[1].twosided = false),
        differs(&|s| s.shapes[1].bsdf = 0),
        differs(&|s| {
            s.lights[0] = Light::Point {
                position: Vec3::new(0.1, 0.2, 0.6),
                intensity: Vec3::new(3.0, 2.0, 1.5),
            }
        }),
        differs(&|s| {
            s.lights[0] = Light::Point {
                position: Vec3::new(0.1, 0.2, 0.61),
                intensity: Vec3::new(3.0, 2.0, 1.0),
            }
        }),
        differs(&|s| {
            s.lights.push(Light::Area {
                shape: 1,
                radiance: Vec3::ONE,
                texture: None,
            });
            s.shapes[1].emitter = Some(1);
        }),
        // Moving a shape's data into another shape is a different scene too.
        differs(&|s| {
            let table = s.shapes.pop().unwrap();
            s.shapes[0].mesh.append(&table.mesh);
        }),
    ];
    // Bezier patches: control points and orientation.
    let mut bez = scene.clone();
    bez.shapes[1].mesh.bezier.push(BezierPatch {
        ctrl: [Vec3::ZERO; 16],
        flipped: false,
    });
    let base = scene_fingerprint(&bez);
    let mut moved = bez.clone();
    moved.shapes[1].mesh.bezier[0].ctrl[7].z = 0.25;
    let mut flipped = bez.clone();
    flipped.shapes[1].mesh.bezier[0].flipped = true;
    all.extend([base, scene_fingerprint(&moved), scene_fingerprint(&flipped)]);
    all.push(fp);
    let n = all.len();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), n, "two different scenes got one fingerprint");
}

#[test]
fn any_damaged_byte_is_refused() {
    let (dir, _path, bytes) = saved("box.rts");
    let n = bytes.len();
    // Every byte of the header after the magic, and a spread of payload bytes
    // including the first and the last.
    let mut at: Vec<usize> = (18..42).collect();
    at.extend((42..n).step_by(97));
    at.push(n - 1);
    for i in at {
        let mut b = bytes.clone();
        b[i] ^= 0x10;
        let msg = load_err(dir.path(), "flipped.rts", &b);
        let expected = match i {
            18..=21 => "made by another version",
            30..=37 => "damaged",
            _ => "damaged: checksum mismatch",
        };
        assert!(msg.contains(expected), "byte {i}: {msg}");
    }
}

#[test]
fn truncated_or_extended_files_are_refused() {
    let (dir, _path, bytes) = saved("box.rts");
    let n = bytes.len();
    for cut in [5, 18, 20, 22, 30, 41, 42, 43, n / 2, n - 1] {
        let msg = load_err(dir.path(), "cut.rts", &bytes[..cut]);
        assert!(msg.contains("damaged: truncated"), "cut at {cut}: {msg}");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    let msg = load_err(dir.path(), "long.rts", &longer);
    assert!(msg.contains("damaged: longer than its header says"), "{msg}");
}

#[test]
fn other_files_are_not_solution_files() {
    let dir = tmpdir();
    for (name, bytes) in [
        ("empty.rts", &b""[..]),
        ("png.rts", &[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a][..]),
        ("text.rts", &b"<scene version=\"3.0.0\"/>\n"[..]),
        ("lower.rts", &b"radtrace-solution\n\x01\0\0\0"[..]),
    ] {
        let msg = load_err(dir.path(), name, bytes);
        assert!(msg.ends_with("not a radtrace solution file"), "{msg}");
    }
    // Another magic in front of an otherwise valid file.
    let (dir, _path, mut bytes) = saved("box.rts");
    bytes[9] = b'X';
    let msg = load_err(dir.path(), "magic.rts", &bytes);
    assert!(msg.ends_with(": not a radtrace solution file"), "{msg}");
}

#[test]
fn another_version_is_refused_by_number() {
    let (dir, _path, mut bytes) = saved("box.rts");
    // Version 3 files (covered vertices interpolated like the rest) are refused.
    bytes[18..22].copy_from_slice(&3u32.to_le_bytes());
    let msg = load_err(dir.path(), "v3.rts", &bytes);
    assert!(
        msg.ends_with("made by another version of radtrace (format 3, this one reads 8)"),
        "{msg}"
    );
    // Even with nothing after the version field.
    let msg = load_err(dir.path(), "v9.rts", &[&MAGIC[..], &9u32.to_le_bytes()].concat());
    assert!(msg.contains("(format 9, this one reads 8)"), "{msg}");
}

#[test]
fn a_file_for_another_scene_is_refused() {
    let (_dir, path, _bytes) = saved("box.rts");
    let mut other = box_scene();
    other.shapes[0].mesh.positions[0].x -= 0.01;
    let err = load_for(&path, &other).unwrap_err();
    let msg = err.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
    assert!(
        msg.ends_with(
            "was computed for another scene (or the scene changed since): run `radtrace solve` again"
        ),
        "{msg}"
    );
    // A wholly different scene.
    let mut b = box_scene();
    b.shapes.truncate(1);
    b.lights[0] = Light::Point {
        position: Vec3::ZERO,
        intensity: Vec3::ONE,
    };
    assert!(load_for(&path, &b)
        .unwrap_err()
        .to_string()
        .contains("another scene"));
}

#[test]
fn a_file_on_another_mesh_is_refused() {
    let (_, sol) = solved();
    let dir = tmpdir();
    let (st, g, l, ss) = (&sol.settings, &sol.general, &sol.lists, &sol.stats);
    // The same values, claimed for mesh size 0.25: the rebuilt mesh is finer.
    let finer = SolveSettings {
        mesh_size: 0.25,
        ..*st
    };
    let msg = load_err(
        dir.path(),
        "finer.rts",
        &forged(&payload(&finer, g, l, ss, 224, counts(sol))),
    );
    assert!(
        msg.contains("was computed on another radiosity mesh (224 vertices in")
            && msg.contains("this radtrace makes 726 vertices")
            && msg.contains("run `radtrace solve` again"),
        "{msg}"
    );
    // Per-patch counts that do not match (the total does).
    let mut c = counts(sol);
    c[0] += 1;
    c[1] -= 1;
    let mut lists = l.clone();
    for (k, list) in lists.iter_mut().enumerate().take(2) {
        for e in list {
            e.occluded.resize(c[k] as usize, Vec3::ZERO);
            e.unoccluded.resize(c[k] as usize, Vec3::ZERO);
        }
    }
    let msg = load_err(
        dir.path(),
        "shifted.rts",
        &forged(&payload(st, g, &lists, ss, 224, c)),
    );
    assert!(msg.contains("another radiosity mesh"), "{msg}");
    // The values do not fit the counts the file itself gives.
    let msg = load_err(
        dir.path(),
        "short.rts",
        &forged(&payload(st, &g[1..], l, ss, 224, counts(sol))),
    );
    assert!(msg.contains("damaged: the radiosity values do not fit"), "{msg}");
    let msg = load_err(
        dir.path(),
        "lists.rts",
        &forged(&payload(st, g, &l[1..], ss, 224, counts(sol))),
    );
    assert!(msg.contains("damaged: the radiosity values do not fit"), "{msg}");
}

#[test]
fn bad_values_are_damage() {
    let (_, sol) = solved();
    let dir = tmpdir();
    let (st, g, l, ss) = (&sol.settings, &sol.general, &sol.lists, &sol.stats);
    let mut nan = g.clone();
    nan[17].y = f32::NAN;
    let msg = load_err(
        dir.path(),
        "nan.rts",
        &forged(&payload(st, &nan, l, ss, 224, counts(sol))),
    );
    assert!(
        msg.ends_with("damaged: a non-finite general radiosity at vertex 17"),
        "{msg}"
    );
    let mut inf = l.clone();
    inf[3][0].unoccluded[2].x = f32::INFINITY;
    let msg = load_err(
        dir.path(),
        "inf.rts",
        &forged(&payload(st, g, &inf, ss, 224, counts(sol))),
    );
    assert!(
        msg.ends_with("damaged: a non-finite value in the source list of patch 3"),
        "{msg}"
    );
    let stats = SolveStats {
        residual: f64::NAN,
        ..*ss
    };
    let msg = load_err(
        dir.path(),
        "stats.rts",
        &forged(&payload(st, g, l, &stats, 224, counts(sol))),
    );
    assert!(msg.contains("damaged: a non-finite statistic"), "{msg}");
    for size in [0.0, -0.5, f32::NAN, f32::INFINITY] {
        let s = SolveSettings {
            mesh_size: size,
            ..*st
        };
        let msg = load_err(
            dir.path(),
            "size.rts",
            &forged(&payload(&s, g, l, ss, 224, counts(sol))),
        );
        assert!(msg.contains("damaged: invalid mesh size"), "{msg}");
    }
    let mut src = l.clone();
    src[5][0].source = SourceId::Light(1);
    let msg = load_err(
        dir.path(),
        "light.rts",
        &forged(&payload(st, g, &src, ss, 224, counts(sol))),
    );
    assert!(
        msg.contains("the source list of patch 5 names a source the scene does not have"),
        "{msg}"
    );
    src[5][0].source = SourceId::Patch(8);
    let msg = load_err(
        dir.path(),
        "patch.rts",
        &forged(&payload(st, g, &src, ss, 224, counts(sol))),
    );
    assert!(msg.contains("patch 5 names a source"), "{msg}");
    // Trailing bytes inside the payload, and a payload cut short.
    let mut p = payload(st, g, l, ss, 224, counts(sol));
    p.push(0);
    let msg = load_err(dir.path(), "trail.rts", &forged(&p));
    assert!(msg.contains("damaged: cannot decode"), "{msg}");
    p.truncate(p.len() - 9);
    let msg = load_err(dir.path(), "cut.rts", &forged(&p));
    assert!(msg.contains("damaged: cannot decode"), "{msg}");
}

#[test]
fn absurd_lengths_are_refused_without_allocating() {
    let dir = tmpdir();
    let st = solved().1.settings;
    // Settings, then a general radiosity "of 2^60 vertices".
    let mut p = codec(u64::MAX).serialize(&st).unwrap();
    p.extend_from_slice(&(1u64 << 60).to_le_bytes());
    p.extend_from_slice(&[0; 64]);
    let msg = load_err(dir.path(), "huge.rts", &forged(&p));
    assert!(msg.contains("damaged: cannot decode"), "{msg}");
    // A header claiming an exabyte of payload, with a few bytes of it.
    let mut f = forged(&[1, 2, 3]);
    f[30..38].copy_from_slice(&(1u64 << 60).to_le_bytes());
    let msg = load_err(dir.path(), "exa.rts", &f);
    assert!(
        msg.contains("damaged: truncated (payload is 3 bytes of the 1152921504606846976"),
        "{msg}"
    );
}

#[test]
fn io_errors_name_the_file() {
    let (scene, sol) = solved();
    let dir = tmpdir();
    let missing = dir.path().join("missing.rts");
    let err = load_for(&missing, scene).unwrap_err();
    assert!(matches!(err, Error::Io { .. }));
    assert!(err.to_string().contains("missing.rts"));
    let nowhere = dir.path().join("no/such/dir/x.rts");
    let err = save(sol, scene, &nowhere).unwrap_err();
    assert!(matches!(err, Error::Output { .. }));
    assert!(err.to_string().contains("no/such/dir/x.rts"));
    // A directory is not a solution file either.
    assert!(load_for(dir.path(), scene).is_err());
}

#[test]
fn a_solution_with_non_finite_values_is_not_saved() {
    let (scene, sol) = solved();
    let dir = tmpdir();
    let path = dir.path().join("nan.rts");
    let mut bad = sol.clone();
    bad.general[3].z = f32::NAN;
    let err = save(&bad, scene, &path).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("nan.rts") && msg.contains("non-finite general radiosity at vertex 3"),
        "{msg}"
    );
    assert!(!path.exists());
    let mut short = sol.clone();
    short.lists[2][0].occluded.pop();
    let msg = save(&short, scene, &path).unwrap_err().to_string();
    assert!(
        msg.contains("nan.rts") && msg.contains("values do not fit its mesh"),
        "{msg}"
    );
    assert!(!path.exists());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    /// Random bytes, bare or behind the magic and version, are refused.
    #[test]
    fn random_bytes_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..600), prefix in 0..3u8) {
        let dir = tmpdir();
        let file = match prefix {
            0 => bytes.clone(),
            1 => [&MAGIC[..], &1u32.to_le_bytes(), &bytes].concat(),
            _ => forged(&bytes),
        };
        let path = dir.path().join("random.rts");
        fs::write(&path, &file).unwrap();
        let err = load_for(&path, &solved().0).unwrap_err();
        prop_assert!(err.to_string().contains("random.rts"));
    }

    /// Random damage to a real file (a few bytes overwritten) is refused.
    #[test]
    fn random_damage_is_refused(edits in proptest::collection::vec((any::<prop::sample::Index>(), 1..=255u8), 1..4)) {
        let (dir, _path, mut bytes) = saved("box.rts");
        let original = bytes.clone();
        for (i, x) in edits {
            let k = 18 + i.index(bytes.len() - 18);
            bytes[k] ^= x;
        }
        prop_assume!(bytes != original);
        let path = dir.path().join("edited.rts");
        fs::write(&path, &bytes).unwrap();
        prop_assert!(load_for(&path, &solved().0).is_err());
    }
}
