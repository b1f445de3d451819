//! The modules of radtrace are layers that run one way (src/lib.rs, DESIGN.md §2):
//! a module may use only itself and the modules listed before it in [`ORDER`]. This
//! test reads every `crate::` path in the sources (code and tests alike; comments are
//! skipped, so doc links may point anywhere) and fails on any that points later.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// The top-level modules, lowest first. Layer 1: shared ground; layer 2: shared
/// concepts of both passes; layer 3: the method (mesh -> radiosity -> selection ->
/// render); layer 4: files, statistics, experiments and the command line.
const ORDER: &[&str] = &[
    // 1
    "error",
    "progress",
    "sampling",
    "image",
    "geometry",
    "scene",
    // Fixtures for the tests of every module; they use only what is above them.
    "testutil",
    "accel",
    // 2
    "bsdf",
    "emitters",
    "interaction",
    "camera",
    // 3
    "mesh",
    "radiosity",
    "selection",
    "render",
    // 4
    "io",
    "stats",
    "compare",
    "experiments",
    "cli",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The top-level module a source file belongs to (`None` for lib.rs and main.rs).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?.to_owned();
    match first.as_str() {
        "lib.rs" | "main.rs" => None,
        name => Some(name.trim_end_matches(".rs").to_owned()),
    }
}

/// The top-level modules named by `crate::` paths in `code` (comments removed),
/// including each name of a grouped `crate::{a, b::c}` import.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        // Not part of a longer identifier such as `$crate::` or `mycrate::`.
        let before = rest[..i].chars().last();
        rest = &rest[i + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = matching_brace(group);
            let mut depth = 0;
            let mut start = 0;
            let items = &group[..end];
            for (k, c) in items.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        names.insert(first_ident(&items[start..k]));
                        start = k + 1;
                    }
                    _ => {}
                }
            }
            names.insert(first_ident(&items[start..]));
        } else {
            names.insert(first_ident(rest));
        }
    }
    names.remove("");
    names
}

fn matching_brace(s: &str) -> usize {
    let mut depth = 1;
    for (k, c) in s.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return k;
                }
            }
            _ => {}
        }
    }
    s.len()
}

fn first_ident(s: &str) -> String {
    s.trim_start()
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect()
}

fn strip_comments(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn modules_import_only_from_their_own_layer_or_below() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let rank = |m: &str| ORDER.iter().position(|&o| o == m);
    let mut wrong = Vec::new();
    let mut seen_modules = BTreeSet::new();
    for file in &files {
        let Some(module) = module_of(&src, file) else {
            continue;
        };
        seen_modules.insert(module.clone());
        let Some(own) = rank(&module) else {
            wrong.push(format!("{}: module '{module}' is not in ORDER", file.display()));
            continue;
        };
        let code = strip_comments(&fs::read_to_string(file).unwrap());
        for used in crate_paths(&code) {
            // `crate::Error` and `crate::Result` are re-exports of `error`.
            let used = match used.as_str() {
                "Error" | "Result" => "error".to_owned(),
                _ => used,
            };
            match rank(&used) {
                Some(_) if used == "testutil" => {}
                Some(r) if r > own => wrong.push(format!(
                    "{}: '{module}' uses crate::{used}, a module of a higher layer",
                    file.display()
                )),
                Some(_) => {}
                None => wrong.push(format!(
                    "{}: crate::{used} is not a module in ORDER",
                    file.display()
                )),
            }
        }
    }
    // Every module in ORDER exists (so the list cannot silently rot).
    for m in ORDER {
        if !seen_modules.contains(*m) {
            wrong.push(format!("ORDER names '{m}', which has no source file"));
        }
    }
    assert!(wrong.is_empty(), "layer order broken:\n{}", wrong.join("\n"));
}

#[test]
fn the_check_sees_grouped_and_nested_imports() {
    let code = "use crate::{accel::{Bvh, Ray}, render::Tracer};\nlet x = crate::cli::run();\n$crate::no::y";
    let names: Vec<String> = crate_paths(code).into_iter().collect();
    assert_eq!(names, ["accel", "cli", "render"]);
    assert!(crate_paths(&strip_comments("// see crate::cli\nuse crate::image::Image;")).len() == 1);
}
