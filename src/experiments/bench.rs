//! `radtrace bench`: ray throughput of the BVH for the rays a render casts, BVH build
//! time, the radiosity solve and peak memory, printed as a table (or JSON).
//!
//! Three ray sets are made from a view of the scene, all with `tmin = 0` (camera rays
//! start at the near clip plane), so that another ray tracer (Embree, in
//! `tools/compare-peers.py`) can trace exactly the same rays:
//!
//! - **camera**: one ray through the centre of every pixel, row by row (coherent);
//!   closest hit.
//! - **shadow**: from the camera rays' hits to points on the lights (cycling through
//!   the lights, a uniform point on an area light), on the side of the surface the
//!   light is on; occlusion (early exit). Light points behind the surface get no ray,
//!   as in the renderer.
//! - **incoherent**: cosine-distributed directions about the geometric normal at the
//!   camera rays' hits (diffuse bounces); closest hit, no `tmax`.
//!
//! `--dump DIR` writes the scene's triangles, each ray set and radtrace's answers as
//! little-endian `.npy` files (see [`dump`]).

use std::path::Path;
use std::time::Instant;

use glam::Vec2;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::Serialize;

use crate::accel::{Accel, Bvh, Ray};
use crate::camera::Camera;
use crate::emitters::SampledLight;
use crate::interaction::SurfacePoint;
use crate::scene::Scene;
use crate::{Error, Result};

/// How the ray sets are made and measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Which view (sensor) the camera rays come from.
    pub view: usize,
    /// Image width (camera rays per row).
    pub width: u32,
    /// Image height (rows).
    pub height: u32,
    /// Shadow rays per camera-ray hit.
    pub shadow_per_hit: u32,
    /// Incoherent (bounce) rays per camera-ray hit.
    pub bounce_per_hit: u32,
    /// Seed of the light points and bounce directions.
    pub seed: u64,
}

/// The three ray sets.
#[derive(Debug, Clone, Default)]
pub struct RaySets {
    /// Primary rays, row by row; closest hit.
    pub camera: Vec<Ray>,
    /// Rays to light points; occlusion.
    pub shadow: Vec<Ray>,
    /// Cosine-distributed rays from the primary hits; closest hit.
    pub incoherent: Vec<Ray>,
}

/// The kinds of ray, in table order.
pub const KINDS: [&str; 3] = ["camera", "shadow", "incoherent"];

impl RaySets {
    /// The set of a kind (one of [`KINDS`]).
    pub fn get(&self, kind: &str) -> &[Ray] {
        match kind {
            "camera" => &self.camera,
            "shadow" => &self.shadow,
            _ => &self.incoherent,
        }
    }

    /// Whether rays of this kind ask for occlusion only (else the closest hit).
    pub fn is_occlusion(kind: &str) -> bool {
        kind == "shadow"
    }
}

/// Makes the ray sets of `opts` for `scene` (using `accel` for the primary hits).
pub fn ray_sets(scene: &Scene, accel: &dyn Accel, opts: &Options) -> Result<RaySets> {
    let sensor = scene.sensor(opts.view)?;
    let camera = Camera::new(sensor, opts.width, opts.height);
    let mut sets = RaySets::default();
    for y in 0..opts.height {
        for x in 0..opts.width {
            let r = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            // Start at the near clip plane so that tmin = 0 (Embree's run() has no tnear).
            sets.camera.push(Ray {
                origin: r.at(r.tmin),
                dir: r.dir,
                tmin: 0.0,
                tmax: r.tmax - r.tmin,
            });
        }
    }
    let lights = SampledLight::prepare_all(scene);
    let mut rng = rand_pcg::Pcg32::seed_from_u64(opts.seed);
    let mut next_light = 0;
    // Secondary rays leave the hits as the renderer's do (SurfacePoint::shadow_ray and
    // spawn: the one offset rule of `interaction`).
    for ray in &sets.camera {
        let Some(hit) = accel.intersect(ray) else {
            continue;
        };
        let sp = SurfacePoint::new(scene, ray, &hit);
        if !lights.is_empty() {
            for _ in 0..opts.shadow_per_hit {
                let light = &lights[next_light % lights.len()];
                next_light += 1;
                let u = Vec2::new(rng.random(), rng.random());
                let Some(s) = light.sample(sp.p, u) else {
                    continue;
                };
                if s.dir.dot(sp.ng) <= 0.0 {
                    continue;
                }
                sets.shadow.push(sp.shadow_ray(s.point, s.normal));
            }
        }
        for _ in 0..opts.bounce_per_hit {
            let u = Vec2::new(rng.random(), rng.random());
            sets.incoherent
                .push(sp.spawn(crate::sampling::cosine_direction(sp.ng, u), f32::INFINITY));
        }
    }
    Ok(sets)
}

/// What a pass over a ray set found: hits (or occluded rays) and the sum of their
/// distances (so the work cannot be optimised away, and to compare runs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Tally {
    /// Rays that hit something (occlusion: that are occluded).
    pub hits: u64,
    /// Sum of the hit distances (0 for occlusion).
    pub t_sum: f64,
}

impl std::ops::Add for Tally {
    type Output = Tally;
    fn add(self, o: Tally) -> Tally {
        Tally {
            hits: self.hits + o.hits,
            t_sum: self.t_sum + o.t_sum,
        }
    }
}

/// Traces `rays` on the calling thread: closest hits, or occlusion if `occlusion`.
pub fn trace<A: Accel + ?Sized>(accel: &A, rays: &[Ray], occlusion: bool) -> Tally {
    if occlusion {
        trace_occluded(accel, rays)
    } else {
        trace_closest(accel, rays)
    }
}

// Not inlined, so that a profiler can count them apart (callgrind --toggle-collect).
#[inline(never)]
fn trace_occluded<A: Accel + ?Sized>(accel: &A, rays: &[Ray]) -> Tally {
    let mut tally = Tally::default();
    for r in rays {
        tally.hits += accel.occluded(r) as u64;
    }
    tally
}

#[inline(never)]
fn trace_closest<A: Accel + ?Sized>(accel: &A, rays: &[Ray]) -> Tally {
    let mut tally = Tally::default();
    for r in rays {
        if let Some(h) = accel.intersect(r) {
            tally.hits += 1;
            tally.t_sum += h.t as f64;
        }
    }
    tally
}

/// [`trace`] on all threads of the current rayon pool, in chunks.
pub fn trace_parallel<A: Accel + ?Sized>(accel: &A, rays: &[Ray], occlusion: bool) -> Tally {
    rays.par_chunks(1024)
        .with_max_len(1)
        .map(|c| trace(accel, c, occlusion))
        .reduce(Tally::default, |a, b| a + b)
}

/// The best (shortest) of `repeats` timings of `f`, in seconds, and its last result.
fn best_of<T>(repeats: u32, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("at least one run"))
}

/// The best of `repeats` timings of `f` on the current pool and, with `one`, the best of
/// as many on that pool, the two runs alternating; and the last result of the former.
fn best_of_interleaved<T: Send>(
    repeats: u32,
    one: Option<&rayon::ThreadPool>,
    f: impl Fn() -> T + Sync,
) -> (f64, Option<f64>, T) {
    let mut best = f64::INFINITY;
    let mut best_one = one.map(|_| f64::INFINITY);
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        out = Some(f());
        best = best.min(t.elapsed().as_secs_f64());
        if let (Some(pool), Some(b)) = (one, best_one.as_mut()) {
            let t = Instant::now();
            pool.install(&f);
            *b = b.min(t.elapsed().as_secs_f64());
        }
    }
    (best, best_one, out.expect("at least one run"))
}

/// Seconds the calling thread has run on a CPU (Linux: /proc/thread-self/schedstat,
/// in nanoseconds); `None` elsewhere.
pub fn thread_cpu_s() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// The best of `repeats` runs of `f` on the calling thread, timed by the thread's CPU
/// time where the system tells it (a loaded machine then takes the CPU away without
/// counting), else by the wall clock; and whether it was CPU time.
fn best_cpu_of<T>(repeats: u32, mut f: impl FnMut() -> T) -> (f64, bool, T) {
    if thread_cpu_s().is_none() {
        let (t, r) = best_of(repeats, f);
        return (t, false, r);
    }
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let t0 = thread_cpu_s().unwrap_or(0.0);
        let r = f();
        best = best.min(thread_cpu_s().unwrap_or(0.0) - t0);
        out = Some(r);
    }
    (best, true, out.expect("at least one run"))
}

/// Throughput of one ray set.
#[derive(Debug, Clone, Serialize)]
pub struct RayFigures {
    /// `camera`, `shadow` or `incoherent`.
    pub kind: &'static str,
    /// `closest` or `occlusion`.
    pub query: &'static str,
    /// Rays in the set.
    pub rays: usize,
    /// Hits (occluded rays for occlusion).
    pub hits: u64,
    /// Million rays per second on one thread (best of the repeats), per second of
    /// the thread's CPU time where the system tells it (`timer_1t`).
    pub mrays_1t: f64,
    /// `thread-cpu` or `wall`: how `mrays_1t` was timed.
    pub timer_1t: &'static str,
    /// Million rays per second on all threads (best of the repeats, wall clock).
    pub mrays_nt: f64,
}

/// The radiosity solve's figures.
#[derive(Debug, Clone, Serialize)]
pub struct SolveFigures {
    /// Wall seconds on all threads.
    pub time_s: f64,
    /// Wall seconds on one thread, if measured (`--solve-scaling`).
    pub time_1t_s: Option<f64>,
    /// Shadow rays cast.
    pub rays: u64,
    /// Shots (lights and patches).
    pub shots: u64,
    /// Mesh vertices.
    pub vertices: u64,
    /// Million shadow rays per second (form factors included) on all threads.
    pub mrays: f64,
}

/// One view rendered with the default method (local selection, adaptive sampling with
/// the shadow image buffer) from the solve.
#[derive(Debug, Clone, Serialize)]
pub struct RenderFigures {
    /// The view.
    pub view: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples (primary rays).
    pub samples: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Wall seconds on all threads: selection, sampling and reconstruction.
    pub time_s: f64,
    /// The same on one thread, if measured (`--solve-scaling`).
    pub time_1t_s: Option<f64>,
}

/// Everything `radtrace bench` measured.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The scene file.
    pub scene: String,
    /// Triangles in the BVH.
    pub triangles: usize,
    /// Image size of the camera rays.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Worker threads of the "all threads" figures.
    pub threads: usize,
    /// Timing repeats (the best is reported).
    pub repeats: u32,
    /// BVH build, seconds (best of the repeats; on all threads).
    pub bvh_build_s: f64,
    /// Per ray kind.
    pub rays: Vec<RayFigures>,
    /// The radiosity solve (null with `--no-solve`).
    pub solve: Option<SolveFigures>,
    /// Each view rendered with the default method from the solve (empty with
    /// `--no-solve`).
    pub renders: Vec<RenderFigures>,
    /// Peak resident memory (VmHWM), MiB; null where /proc is missing.
    pub peak_rss_mib: Option<f64>,
    /// The 1-minute load average when the measurement ended (how busy the machine
    /// was); null where /proc is missing.
    pub load_avg: Option<f64>,
}

/// What to measure besides the rays.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Ray sets.
    pub options: Options,
    /// Timing repeats.
    pub repeats: u32,
    /// Solve settings, or `None` to skip the solve.
    pub solve: Option<crate::radiosity::SolveSettings>,
    /// Also solve and render on one thread.
    pub solve_scaling: bool,
    /// Write triangles, rays and answers here.
    pub dump: Option<std::path::PathBuf>,
}

/// Runs the benchmark in the current rayon pool (`threads` workers).
pub fn run(scene: &Scene, plan: &Plan, threads: usize) -> Result<Report> {
    let (bvh_build_s, bvh) = best_of(plan.repeats, || Bvh::build(scene));
    let sets = ray_sets(scene, &bvh, &plan.options)?;
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| Error::Usage(format!("cannot start a worker thread: {e}")))?;
    let mut rays = Vec::new();
    for kind in KINDS {
        let set = sets.get(kind);
        let occ = RaySets::is_occlusion(kind);
        let (t1, cpu, tally1) = one.install(|| best_cpu_of(plan.repeats, || trace(&bvh, set, occ)));
        let (tn, tally_n) = best_of(plan.repeats, || trace_parallel(&bvh, set, occ));
        debug_assert_eq!(tally1.hits, tally_n.hits);
        let mrays = |t: f64| if t > 0.0 { set.len() as f64 / t / 1e6 } else { 0.0 };
        rays.push(RayFigures {
            kind,
            query: if occ { "occlusion" } else { "closest" },
            rays: set.len(),
            hits: tally1.hits,
            mrays_1t: mrays(t1),
            timer_1t: if cpu { "thread-cpu" } else { "wall" },
            mrays_nt: mrays(tn),
        });
    }
    if let Some(dir) = &plan.dump {
        dump(dir, scene, &bvh, &sets)?;
    }
    let mut renders = Vec::new();
    let solve = match &plan.solve {
        None => None,
        Some(st) => {
            // The best of the repeats, for the scaling too: on a shared or virtual
            // machine a single run may lose a core for a while.
            // The 1-thread runs alternate with the all-threads runs, so that a slow
            // spell of the machine falls on both.
            let one_pool = plan.solve_scaling.then_some(&one);
            st.validate()?;
            let (solve_s, solve_1t_s, sol) = best_of_interleaved(plan.repeats, one_pool, || {
                crate::radiosity::solve(scene, &bvh, st, &crate::progress::Silent)
                    .expect("settings validated")
            });
            for view in 0..scene.sensors.len() {
                let render = || render_view(scene, &bvh, &sol, view, plan);
                let (time_s, time_1t_s, (samples, shadow_rays)) =
                    best_of_interleaved(plan.repeats, one_pool, render);
                let sensor = &scene.sensors[view];
                renders.push(RenderFigures {
                    view,
                    width: sensor.width,
                    height: sensor.height,
                    samples,
                    shadow_rays,
                    time_s,
                    time_1t_s,
                });
            }
            let s = sol.stats;
            Some(SolveFigures {
                time_s: solve_s,
                time_1t_s: solve_1t_s,
                rays: s.rays,
                shots: s.light_shots + s.patch_shots,
                vertices: s.vertices,
                mrays: if solve_s > 0.0 {
                    s.rays as f64 / solve_s / 1e6
                } else {
                    0.0
                },
            })
        }
    };
    Ok(Report {
        scene: scene.path.display().to_string(),
        triangles: bvh.triangle_count(),
        width: plan.options.width,
        height: plan.options.height,
        threads,
        repeats: plan.repeats,
        bvh_build_s,
        rays,
        solve,
        renders,
        peak_rss_mib: peak_rss_mib(),
        load_avg: std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|l| l.split_whitespace().next()?.parse().ok()),
    })
}

/// Renders `view` with the defaults of `radtrace render` (local selection, adaptive
/// sampling to level 2 with the shadow image buffer): (samples, shadow rays).
fn render_view(
    scene: &Scene,
    bvh: &Bvh,
    sol: &crate::radiosity::Solution,
    view: usize,
    plan: &Plan,
) -> (u64, u64) {
    use crate::render::{Filter, Method, Refine, Sampler, Settings};
    use crate::selection::{select, SelectSettings, ViewScale};
    let sensor = &scene.sensors[view];
    let camera = Camera::new(sensor, sensor.width, sensor.height);
    let settings = Settings {
        method: Method::Local,
        view,
        width: sensor.width,
        height: sensor.height,
        spp: 1,
        seed: plan.options.seed,
        area_samples: 64,
        max_depth: 6,
        gather: 0,
        filter: Filter::Gaussian,
        sampler: Sampler::Adaptive,
        refine: Refine::default(),
    };
    let sel = select(
        scene,
        sol,
        Method::Local,
        &SelectSettings::default(),
        Some(&ViewScale::of(&camera)),
    )
    .expect("local selection of a solution made here");
    let out = crate::render::render(scene, bvh, &settings, Some(&sel), &crate::progress::Silent)
        .expect("the bench's own settings render");
    (out.counters.primary_rays, out.counters.shadow_rays)
}

/// Peak resident memory of this process (VmHWM of /proc/self/status), MiB.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// The report as a text table.
pub fn table(r: &Report) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "radtrace bench: {} ({} triangles), {}x{} camera rays, best of {}",
        r.scene, r.triangles, r.width, r.height, r.repeats
    );
    let _ = writeln!(s, "BVH build {:>29.2} ms", r.bvh_build_s * 1e3);
    let nt = format!("{} threads", r.threads);
    let _ = writeln!(
        s,
        "{:<11} {:<9} {:>9} {:>9} {:>10} {:>10} {:>7}",
        "rays", "query", "count", "hits", "1 thread", nt, "scaling"
    );
    for f in &r.rays {
        let _ = writeln!(
            s,
            "{:<11} {:<9} {:>9} {:>9} {:>10.2} {:>10.2} {:>6.2}x",
            f.kind,
            f.query,
            f.rays,
            f.hits,
            f.mrays_1t,
            f.mrays_nt,
            if f.mrays_1t > 0.0 {
                f.mrays_nt / f.mrays_1t
            } else {
                0.0
            }
        );
    }
    let _ = writeln!(
        s,
        "{:<41} (Mrays/s; 1 thread per CPU second, {} threads per wall second)",
        "", r.threads
    );
    if let Some(v) = &r.solve {
        let _ = write!(
            s,
            "radiosity solve {:>8.2} s ({} threads), {} shots, {} rays, {:.2} Mrays/s",
            v.time_s, r.threads, v.shots, v.rays, v.mrays
        );
        if let Some(t1) = v.time_1t_s {
            let _ = write!(s, "; 1 thread {:.2} s, scaling {:.2}x", t1, t1 / v.time_s);
        }
        s.push('\n');
    }
    for v in &r.renders {
        let _ = write!(
            s,
            "render view {} {:>8.2} s ({} threads), {}x{}, local + SIB: {} samples, {} shadow rays",
            v.view, v.time_s, r.threads, v.width, v.height, v.samples, v.shadow_rays
        );
        if let Some(t1) = v.time_1t_s {
            let _ = write!(s, "; 1 thread {:.2} s, scaling {:.2}x", t1, t1 / v.time_s);
        }
        s.push('\n');
    }
    if let Some(m) = r.peak_rss_mib {
        let _ = writeln!(s, "peak memory {m:>25.1} MiB");
    }
    if let Some(l) = r.load_avg {
        let _ = writeln!(s, "load average {l:>24.2}");
    }
    s
}

/// Writes a little-endian `.npy` file (format 1.0) of `shape` and numpy type `descr`
/// (`<f4`, `<i4` or `|u1`) from raw little-endian bytes.
fn write_npy(path: &Path, descr: &str, shape: &[usize], data: &[u8]) -> Result<()> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + length (2) + header + '\n', padded to 64 bytes.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = Vec::with_capacity(10 + header.len() + data.len());
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(data);
    std::fs::write(path, out).map_err(|e| Error::output(path, e))
}

fn f32_bytes(v: impl IntoIterator<Item = f32>) -> Vec<u8> {
    v.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// Writes into `dir`:
/// - `triangles.npy`: every triangle of every shape, in scene order, `(T, 3, 3)` f32
///   (degenerate ones included; neither tracer can hit them);
/// - per ray kind K: `K_origins.npy` and `K_dirs.npy` `(N, 3)` f32, `K_tmax.npy`
///   `(N,)` f32 (tmin is 0);
/// - radtrace's answers: for closest-hit kinds `K_prim.npy` `(N,)` i32 (index into
///   `triangles.npy`, -1 for a miss) and `K_t.npy` `(N,)` f32 (inf for a miss); for
///   occlusion `K_occluded.npy` `(N,)` u8.
pub fn dump(dir: &Path, scene: &Scene, accel: &dyn Accel, sets: &RaySets) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut offsets = Vec::with_capacity(scene.shapes.len());
    let mut tris = Vec::new();
    for shape in &scene.shapes {
        offsets.push(tris.len() as i32 / 9);
        for t in 0..shape.mesh.triangle_count() {
            for v in shape.mesh.triangle(t) {
                tris.extend_from_slice(&v.to_array());
            }
        }
    }
    let n_tris = tris.len() / 9;
    write_npy(
        &dir.join("triangles.npy"),
        "<f4",
        &[n_tris, 3, 3],
        &f32_bytes(tris),
    )?;
    for kind in KINDS {
        let rays = sets.get(kind);
        let n = rays.len();
        let file = |suffix: &str| dir.join(format!("{kind}_{suffix}.npy"));
        let o = f32_bytes(rays.iter().flat_map(|r| r.origin.to_array()));
        write_npy(&file("origins"), "<f4", &[n, 3], &o)?;
        let d = f32_bytes(rays.iter().flat_map(|r| r.dir.to_array()));
        write_npy(&file("dirs"), "<f4", &[n, 3], &d)?;
        write_npy(
            &file("tmax"),
            "<f4",
            &[n],
            &f32_bytes(rays.iter().map(|r| r.tmax)),
        )?;
        if RaySets::is_occlusion(kind) {
            let occ: Vec<u8> = rays.iter().map(|r| accel.occluded(r) as u8).collect();
            write_npy(&file("occluded"), "|u1", &[n], &occ)?;
        } else {
            let hits: Vec<_> = rays.iter().map(|r| accel.intersect(r)).collect();
            let prim: Vec<u8> = hits
                .iter()
                .flat_map(|h| {
                    h.map_or(-1, |h| offsets[h.shape as usize] + h.tri as i32)
                        .to_le_bytes()
                })
                .collect();
            write_npy(&file("prim"), "<i4", &[n], &prim)?;
            let t = f32_bytes(hits.iter().map(|h| h.map_or(f32::INFINITY, |h| h.t)));
            write_npy(&file("t"), "<f4", &[n], &t)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_padded_to_64_bytes_and_holds_the_shape() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.npy");
        write_npy(&path, "<f4", &[2, 3], &f32_bytes([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + hlen) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + hlen]).unwrap();
        assert!(header.contains("'shape': (2, 3)"), "{header}");
        assert!(header.ends_with('\n'));
        assert_eq!(bytes.len(), 10 + hlen + 24);
        assert_eq!(
            f32::from_le_bytes(bytes[10 + hlen + 20..].try_into().unwrap()),
            6.0
        );
    }
}
