//! The solution-file loader on any bytes, for a small fixed scene. Half of the inputs
//! (first byte even) are loaded as they are; the other half get a valid header first
//! (magic, version, this scene's fingerprint, the true payload length and checksum),
//! so that the decoder and the checks behind the checksum see fuzzed payloads too.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;
use std::sync::OnceLock;

use radtrace::io::solution::{scene_fingerprint, FORMAT_VERSION, MAGIC};
use radtrace::scene::Scene;

/// The scene of the seed corpus (fuzz/seeds/solution/roomlet.sol was solved for it).
const ROOMLET: &str = include_str!("../seeds/roomlet.xml");

fn scene() -> &'static Scene {
    &world().0
}

/// The scene and its BVH (the loader rebuilds the mesh with it).
fn world() -> &'static (Scene, radtrace::accel::Bvh) {
    static WORLD: OnceLock<(Scene, radtrace::accel::Bvh)> = OnceLock::new();
    WORLD.get_or_init(|| {
        let scene = radtrace::scene::xml::load_str(Path::new("roomlet.xml"), ROOMLET, &[])
            .expect("the roomlet loads")
            .scene;
        let bvh = radtrace::accel::Bvh::build(&scene);
        (scene, bvh)
    })
}

/// `payload` behind a header that passes every check before decoding.
fn sealed(payload: &[u8]) -> Vec<u8> {
    let mut head = Vec::with_capacity(42 + payload.len());
    head.extend_from_slice(MAGIC);
    head.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    head.extend_from_slice(&scene_fingerprint(scene()).to_le_bytes());
    head.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    let mut crc = crc32fast::Hasher::new();
    crc.update(&head[MAGIC.len()..]);
    crc.update(payload);
    head.extend_from_slice(&crc.finalize().to_le_bytes());
    head.extend_from_slice(payload);
    head
}

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.sol");
    let bytes = match data.first() {
        Some(b) if b % 2 == 1 => {
            // The payload of a real file starts at byte 42: skip a header if present.
            let rest = &data[1..];
            sealed(if rest.starts_with(MAGIC) && rest.len() >= 42 {
                &rest[42..]
            } else {
                rest
            })
        }
        _ => data.to_vec(),
    };
    if let Ok(sol) = radtrace::io::solution::load_from(path, &bytes[..], scene(), &world().1) {
        assert!(sol.general.iter().all(|c| c.is_finite()));
        assert_eq!(sol.lists.len(), sol.mesh.patches.len());
    }
});
