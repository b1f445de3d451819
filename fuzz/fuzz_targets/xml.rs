//! The scene reader on any bytes, and a tiny direct render of every scene it accepts:
//! an error, or an image with finite pixels; never a panic or a hang.
//!
//! Files the scene names are looked for in a temporary folder holding `tri.obj`,
//! `tri.ply`, `patch.bpt` and `inc.xml` (a bsdf with id `inc`), so fuzzed scenes can
//! load meshes, Bezier patches and includes.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

use radtrace::render::{Filter, Method, Refine, Sampler, Settings};

fn folder() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("radtrace-fuzz-xml-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp folder");
        let files: [(&str, &str); 4] = [
            ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            (
                "tri.ply",
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                 end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            ),
            (
                "patch.bpt",
                "1\n3 3\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n0 1 0\n1 1 1\n2 1 1\n3 1 0\n\
                 0 2 0\n1 2 1\n2 2 1\n3 2 0\n0 3 0\n1 3 0\n2 3 0\n3 3 0\n",
            ),
            (
                "inc.xml",
                "<bsdf type=\"diffuse\" id=\"inc\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf>\n",
            ),
        ];
        for (name, text) in files {
            std::fs::write(dir.join(name), text).expect("fixture");
        }
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = folder().join("scene.xml");
    let Ok(loaded) = radtrace::scene::xml::load_str(&path, text, &[]) else {
        return;
    };
    let scene = loaded.scene;
    for shape in &scene.shapes {
        assert!(shape.mesh.validate().is_ok());
    }
    let bvh = radtrace::accel::Bvh::build(&scene);
    let settings = Settings {
        method: Method::Direct,
        view: 0,
        width: 3,
        height: 2,
        spp: 1,
        seed: 1,
        area_samples: 2,
        max_depth: 2,
        gather: 0,
        filter: Filter::Box,
        sampler: Sampler::Uniform,
        refine: Refine::default(),
    };
    let quiet = &radtrace::progress::Silent;
    if let Ok(out) = radtrace::render::render(&scene, &bvh, &settings, None, quiet) {
        assert!(out.image.pixels.iter().all(|p| p.is_finite()), "non-finite pixel");
    }
});
