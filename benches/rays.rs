//! `cargo bench`: BVH build and ray throughput for the rays `radtrace bench` makes
//! (camera: closest hit, coherent; shadow: occlusion to points on the lights;
//! incoherent: closest hit of cosine-distributed bounces) on the repository's scenes,
//! at 128 x 128 camera rays to keep the run short. `radtrace bench` prints the same
//! figures as a table, and `tools/compare-peers.py` sets them beside Embree's.

use std::path::PathBuf;
use std::sync::OnceLock;

use divan::counter::ItemsCount;
use divan::Bencher;
use radtrace::accel::Bvh;
use radtrace::experiments::bench::{ray_sets, trace, Options, RaySets};
use radtrace::scene::{xml, Scene};

fn main() {
    divan::main();
}

/// The scenes benchmarked (those present in the checkout).
const SCENES: &[&str] = &["cornell-box", "paper-room", "conference"];

struct Loaded {
    name: &'static str,
    scene: Scene,
    bvh: Bvh,
    rays: RaySets,
}

fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}/{name}.xml"))
}

fn present() -> Vec<&'static str> {
    SCENES
        .iter()
        .copied()
        .filter(|s| scene_path(s).exists())
        .collect()
}

fn loaded(name: &str) -> &'static Loaded {
    static ALL: OnceLock<Vec<Loaded>> = OnceLock::new();
    let all = ALL.get_or_init(|| {
        present()
            .into_iter()
            .map(|name| {
                let scene = xml::load(&scene_path(name), &[]).expect("scene loads").scene;
                let bvh = Bvh::build(&scene);
                let opts = Options {
                    view: 0,
                    width: 128,
                    height: 128,
                    shadow_per_hit: 4,
                    bounce_per_hit: 2,
                    seed: 0,
                };
                let rays = ray_sets(&scene, &bvh, &opts).expect("ray sets");
                Loaded {
                    name,
                    scene,
                    bvh,
                    rays,
                }
            })
            .collect()
    });
    all.iter().find(|l| l.name == name).expect("a present scene")
}

#[divan::bench(args = present(), sample_count = 10)]
fn bvh_build(bencher: Bencher, name: &str) {
    let l = loaded(name);
    bencher.bench(|| Bvh::build(&l.scene));
}

fn rays(bencher: Bencher, name: &str, kind: &str) {
    let l = loaded(name);
    let set = l.rays.get(kind);
    let occlusion = RaySets::is_occlusion(kind);
    bencher
        .counter(ItemsCount::new(set.len()))
        .bench(|| trace(&l.bvh, set, occlusion));
}

#[divan::bench(args = present(), sample_count = 20)]
fn camera(bencher: Bencher, name: &str) {
    rays(bencher, name, "camera");
}

#[divan::bench(args = present(), sample_count = 20)]
fn shadow(bencher: Bencher, name: &str) {
    rays(bencher, name, "shadow");
}

#[divan::bench(args = present(), sample_count = 20)]
fn incoherent(bencher: Bencher, name: &str) {
    rays(bencher, name, "incoherent");
}
