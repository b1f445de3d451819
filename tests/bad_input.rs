//! The bad-input corpus (`tests/data/bad/`): every file there is run through the
//! `radtrace` binary. Bad input gives exit code 2 and exactly one line on stderr,
//! `radtrace: error: FILE[:LINE[:COL]]: ...`, naming the file at fault (and the place);
//! harmless input (a degenerate triangle, a light that emits nothing) gives a warning
//! and a finite image. No case may panic, write an output or leave a temporary file.
//! Also: an existing output surviving a failed, killed or interrupted run.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bad(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/bad")
        .join(name)
}

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

fn radtrace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_radtrace"))
        .args(args)
        .output()
        .expect("runs radtrace")
}

/// A tiny render of `scene` into `out` (quiet, so stderr holds only errors).
fn render(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let (scene, out) = (s(scene), s(out));
    let mut args = vec![
        "render",
        &scene,
        "-o",
        &out,
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--area-samples",
        "2",
        "--mesh-size",
        "0.5",
        "-q",
    ];
    args.extend_from_slice(extra);
    radtrace(&args)
}

/// Names of the files in `dir`.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Checks a refusal: exit code 2, one stderr line naming `file` followed by `place`
/// (":LINE:COL" or ":LINE", or "" where the file has no place) and containing `what`.
fn assert_refused(o: &Output, case: &str, file: &Path, place: &str, what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{case}: {err}");
    assert!(!err.contains("panicked"), "{case}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{case}: one line expected, got {err}");
    let head = format!("radtrace: error: {}{place}: ", file.display());
    assert!(
        lines[0].starts_with(&head),
        "{case}: '{}' should start with '{head}'",
        lines[0]
    );
    assert!(
        lines[0].contains(what),
        "{case}: '{}' should say '{what}'",
        lines[0]
    );
}

/// (scene file, the file named in the error, its place, what the message says).
/// The file named is the scene unless the fault is in a file it refers to.
const REFUSED: &[(&str, &str, &str, &str)] = &[
    ("malformed.xml", "", ":3:1", "malformed XML"),
    ("empty.xml", "", ":1:1", "malformed XML"),
    ("random-bytes.xml", "", "", "not UTF-8"),
    ("not-a-scene.xml", "", ":2:1", "root element must be <scene>"),
    ("no-sensor.xml", "", ":1:1", "no sensor"),
    ("missing-mesh.xml", "", ":7:23", "no such file"),
    ("mesh-is-a-folder.xml", "", ":7:23", "is a directory"),
    ("mesh-not-utf8.xml", "not-utf8.obj", ":3:6", "not UTF-8"),
    (
        "obj-index-out-of-range.xml",
        "index-out-of-range.obj",
        ":5:7",
        "out of range",
    ),
    ("obj-nan.xml", "nan.obj", ":2:5", "not a finite number"),
    ("obj-inf.xml", "inf.obj", ":3:7", "not a finite number"),
    ("obj-huge.xml", "huge.obj", ":2:3", "absurdly large"),
    ("ply-nan.xml", "nan.ply", ":11", "1 0 nan"),
    ("ply-huge-count.xml", "huge-count.ply", "", "file too short"),
    ("ply-truncated.xml", "truncated.ply", "", "ends early"),
    (
        "serialized-truncated.xml",
        "truncated.serialized",
        "",
        "ends early",
    ),
    ("serialized-index.xml", "one-mesh.serialized", "", "holds 1 mesh"),
    ("bpt-truncated.xml", "truncated.bpt", ":8", "file ends early"),
    ("bpt-huge.xml", "huge.bpt", ":3:1", "absurdly large"),
    (
        "bezier-too-fine.xml",
        "",
        ":10:9",
        "would make 8589934592 triangles",
    ),
    ("zero-area-light.xml", "", ":8:9", "singular"),
    ("reflectance-negative.xml", "", ":8:30", "outside [0, 1]"),
    ("reflectance-above-one.xml", "", ":8:30", "outside [0, 1]"),
    ("spectrum-decreasing.xml", "", ":8:30", "increasing wavelengths"),
    (
        "spectrum-bad-file.xml",
        "bad.spd",
        ":3",
        "expected 'wavelength value'",
    ),
    ("film-zero.xml", "", ":4:30", "outside [1, 16384]"),
    ("film-negative.xml", "", ":4:63", "outside [1, 16384]"),
    ("film-absurd.xml", "", ":4:30", "outside [1, 16384]"),
    ("film-not-a-number.xml", "", ":4:59", "not an integer"),
    ("lookat-degenerate.xml", "", ":3:36", "origin and target coincide"),
    ("lookat-up-parallel.xml", "", ":3:36", "parallel"),
    ("unknown-ref.xml", "", ":7:38", "unknown id 'nowhere'"),
    ("float-not-a-number.xml", "", ":7:54", "not a number"),
    ("float-nan.xml", "", ":7:54", "not finite"),
    ("translate-inf.xml", "", ":7:70", "not finite"),
    ("include-itself.xml", "", ":7:24", "includes itself"),
    ("duplicate-id.xml", "", ":8:30", "duplicate id"),
    ("undefined-parameter.xml", "", ":7:54", "undefined parameter"),
];

/// Harmless input: a warning naming the file, exit 0 and a finite, lit image.
const HARMLESS: &[(&str, &str)] = &[
    ("degenerate-triangle.xml", "1 degenerate triangle(s) ignored"),
    ("zero-power-light.xml", "zero radiance"),
];

/// Data files of the corpus that the scenes above refer to (not scenes themselves),
/// and the solution-file cases, run by `bad_solution_files_are_refused`.
const REFERRED: &[&str] = &[
    "degenerate.obj",
    "huge-count.ply",
    "huge.bpt",
    "one-patch.bpt",
    "huge.obj",
    "index-out-of-range.obj",
    "inf.obj",
    "nan.obj",
    "nan.ply",
    "not-utf8.obj",
    "truncated.bpt",
    "truncated.ply",
    "truncated.serialized",
    "one-mesh.serialized",
    "good.xml",
    "other.xml",
    "damaged.sol",
    "not-a-solution.sol",
    "bad.spd",
];

#[test]
fn every_corpus_file_is_a_case() {
    let named: Vec<&str> = REFUSED
        .iter()
        .map(|c| c.0)
        .chain(HARMLESS.iter().map(|c| c.0))
        .chain(REFERRED.iter().copied())
        .collect();
    for f in listing(&bad("")) {
        assert!(
            named.contains(&f.as_str()),
            "tests/data/bad/{f} is not run by any test"
        );
    }
    for f in &named {
        assert!(bad(f).exists(), "tests/data/bad/{f} is missing");
    }
}

#[test]
fn bad_scenes_give_one_error_line_naming_the_file_and_place() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out.exr");
    for &(scene, file, place, what) in REFUSED {
        let at_fault = bad(if file.is_empty() { scene } else { file });
        let o = render(&bad(scene), &out, &["--method", "direct"]);
        assert_refused(&o, scene, &at_fault, place, what);
    }
    assert!(listing(d.path()).is_empty(), "no output, no temporary file");
}

#[test]
fn a_missing_file_or_a_folder_as_the_scene_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out.exr");
    let missing = bad("no-such-scene.xml");
    let o = render(&missing, &out, &[]);
    assert_refused(&o, "missing", &missing, "", "No such file");
    let folder = bad("");
    let o = render(&folder, &out, &[]);
    assert_refused(&o, "folder", &folder, "", "directory");
    assert!(listing(d.path()).is_empty());
}

#[test]
fn harmless_input_warns_and_renders_a_finite_image() {
    let d = tempfile::tempdir().unwrap();
    for &(scene, warning) in HARMLESS {
        for method in ["direct", "twopass", "local"] {
            let out = d.path().join(format!("{method}.exr"));
            let (scene_s, out_s) = (s(&bad(scene)), s(&out));
            let o = radtrace(&[
                "render",
                &scene_s,
                "-o",
                &out_s,
                "--spp",
                "1",
                "--area-samples",
                "2",
                "--method",
                method,
                "--mesh-size",
                "0.5",
            ]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(o.status.success(), "{scene} {method}: {err}");
            assert!(
                err.contains("radtrace: warning: ") && err.contains(warning),
                "{scene} {method}: {err}"
            );
            let img = radtrace::io::read_image(&out).unwrap();
            assert!(img.pixels.iter().all(|p| p.is_finite()), "{scene} {method}");
            // The scene's floor is lit by its point light (1 W/sr, 1 m above): the
            // centre pixel shows it (the degenerate triangle takes nothing away).
            let centre = img.pixels[(4 * img.width + 4) as usize];
            assert!(centre.x > 0.01, "{scene} {method}: centre {centre}");
        }
    }
}

#[test]
fn bad_solution_files_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let (good, other) = (bad("good.xml"), bad("other.xml"));
    let sol = d.path().join("good.sol");
    let o = radtrace(&["solve", &s(&good), "-o", &s(&sol), "--mesh-size", "0.5", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = d.path().join("out.exr");
    let with = |scene: &Path, solution: &Path| {
        render(scene, &out, &["--method", "twopass", "--solution", &s(solution)])
    };
    // The file works for its own scene...
    assert!(with(&good, &sol).status.success());
    std::fs::remove_file(&out).unwrap();
    // ...but not for another one, and damaged ones never.
    assert_refused(&with(&other, &sol), "other scene", &sol, "", "another scene");
    let damaged = bad("damaged.sol");
    assert_refused(
        &with(&good, &damaged),
        "damaged",
        &damaged,
        "",
        "damaged: truncated",
    );
    let png = bad("not-a-solution.sol");
    assert_refused(
        &with(&good, &png),
        "not a solution",
        &png,
        "",
        "not a radtrace solution file",
    );
    let folder = bad("");
    assert_refused(&with(&good, &folder), "folder", &folder, "", "directory");
    let missing = d.path().join("missing.sol");
    assert_refused(&with(&good, &missing), "missing", &missing, "", "No such file");
    // Truncated anywhere, or one byte changed anywhere: refused as damaged.
    let bytes = std::fs::read(&sol).unwrap();
    let cut = d.path().join("cut.sol");
    for n in [10, 30, 41, 42, bytes.len() / 2, bytes.len() - 1] {
        std::fs::write(&cut, &bytes[..n]).unwrap();
        assert_refused(&with(&good, &cut), &format!("cut at {n}"), &cut, "", "damaged");
    }
    for at in [20, 25, 33, 39, 50, bytes.len() - 3] {
        let mut b = bytes.clone();
        b[at] ^= 0x10;
        std::fs::write(&cut, &b).unwrap();
        assert_refused(&with(&good, &cut), &format!("byte {at}"), &cut, "", "");
    }
    assert!(!out.exists());
}

/// An existing output is replaced only by a complete one: a run that fails, or is
/// killed while rendering, leaves it as it was and no temporary file beside it.
#[test]
fn an_existing_output_survives_a_failed_or_killed_run() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("keep.exr");
    let stats = d.path().join("keep.json");
    std::fs::write(&out, b"the old image").unwrap();
    std::fs::write(&stats, b"the old stats").unwrap();
    let stats_flag = ["--stats", &s(&stats)];
    let o = render(&bad("film-zero.xml"), &out, &stats_flag);
    assert_eq!(o.status.code(), Some(2));
    // Killed mid-render (a long render of the good scene).
    let child = Command::new(env!("CARGO_BIN_EXE_radtrace"))
        .args([
            "render",
            &s(&bad("good.xml")),
            "-o",
            &s(&out),
            "--stats",
            &s(&stats),
        ])
        .args([
            "--method", "direct", "--width", "512", "--height", "512", "--spp", "65536", "-q",
        ])
        .spawn();
    let mut child = child.unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the render should still be running"
    );
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(std::fs::read(&out).unwrap(), b"the old image");
    assert_eq!(std::fs::read(&stats).unwrap(), b"the old stats");
    assert_eq!(listing(d.path()), ["keep.exr", "keep.json"]);
    // A complete run replaces both.
    let o = render(
        &bad("good.xml"),
        &out,
        &["--method", "direct", "--stats", &s(&stats)],
    );
    assert!(o.status.success());
    assert_eq!(radtrace::io::read_image(&out).unwrap().width, 8);
    assert!(std::fs::read_to_string(&stats)
        .unwrap()
        .contains("\"primary_rays\": 64"));
    assert_eq!(listing(d.path()), ["keep.exr", "keep.json"]);
}

/// Ctrl-C (SIGINT) during a render: exit code 130, the existing output and stats as
/// they were, no temporary file.
#[test]
fn ctrl_c_stops_a_render_and_leaves_the_old_output() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("keep.png");
    let stats = d.path().join("keep.json");
    std::fs::write(&out, b"the old image").unwrap();
    std::fs::write(&stats, b"the old stats").unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_radtrace"))
        .args([
            "render",
            &s(&bad("good.xml")),
            "-o",
            &s(&out),
            "--stats",
            &s(&stats),
        ])
        .args([
            "--method", "direct", "--width", "512", "--height", "512", "--spp", "65536", "-q",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&o.stderr), "radtrace: interrupted\n");
    assert_eq!(std::fs::read(&out).unwrap(), b"the old image");
    assert_eq!(std::fs::read(&stats).unwrap(), b"the old stats");
    assert_eq!(listing(d.path()), ["keep.json", "keep.png"]);
}
