#!/usr/bin/env python3
"""Side-by-side comparison of radtrace with the peers a user would pick instead.

1. Ray queries: radtrace's BVH against Embree's single-ray API (pip package
   `embreex`: its `EmbreeScene.run` loops over the rays calling rtcIntersect1 /
   rtcOccluded1 one ray at a time, in one thread) on the same triangles and exactly the
   same rays: camera (closest hit), shadow (occlusion) and incoherent (closest hit)
   rays, made and dumped by `radtrace bench --dump`. Both are timed on 1 thread, and on
   N threads (radtrace: N rayon workers; Embree: N processes, each tracing 1/N of the
   rays, since `run` holds the GIL). The answers are checked against each other (same
   triangle or occluded flag for > 99.9% of the rays, same distance where both hit the
   same triangle) before any figure is printed.
2. Time to equal quality against Mitsuba 3 (path tracer) on the same scene file: one
   high-sample Mitsuba reference (--reference-spp, cached), Mitsuba at --mitsuba-spp
   (its render time and mean FLIP against the reference), and radtrace's render at the
   quality dial's lowest level, `--quality draft` (the whole process, solve included),
   with its FLIP against the same reference; if radtrace's FLIP is worse it is re-run at
   the next level (`good`, then `final`) until it is not. The figure is
   Mitsuba's time / radtrace's time (issue 6: at least 5 on the Cornell box). Default
   scenes: the Cornell box and the conference room; a scene may get a ladder of its own
   (RADTRACE_EFFORT, empty now), and Mitsuba the -D
   parameters it needs (the paper room's teapot as an OBJ: mitsuba_defines).

Ratios, not absolute times, are the figures: the machine is shared and noisy. Each
figure is the best of --rounds rounds (alternating the two tracers) of --repeats runs; 1-thread figures are per second of the thread's
CPU time (both tracers), N-thread figures per wall second. The load average is
printed: N-thread figures mean little when it is above the core count.

Usage (from the repository root):
    python3 tools/compare-peers.py                      # Cornell box, paper room, conference
    python3 tools/compare-peers.py --no-rays --mitsuba-scenes scenes/conference/conference.xml \
        --reference /path/to/conference-path-1024.exr   # an existing 1024 spp reference
    python3 tools/compare-peers.py --scenes scenes/cornell-box/cornell-box.xml --json out.json

The script re-runs itself in a virtual environment (default ~/.cache/radtrace-peers)
with `embreex` and `numpy` installed on first use. CI does not run it.
"""

import argparse
import json
import multiprocessing as mp
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_VENV = Path.home() / ".cache" / "radtrace-peers"
PIP_PACKAGES = ["embreex==4.4.0.post1", "numpy", "mitsuba==3.9.*"]
LLVM = Path("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
KINDS = ["camera", "shadow", "incoherent"]
DEFAULT_SCENES = [
    "scenes/cornell-box/cornell-box.xml",
    "scenes/paper-room/paper-room.xml",
    "scenes/conference/conference.xml",
]


def ensure_venv(venv: Path) -> None:
    """Re-executes this script in `venv` (created and filled on demand) unless the
    packages are importable here already."""
    try:
        import embreex  # noqa: F401
        import mitsuba  # noqa: F401
        import numpy  # noqa: F401

        return
    except ImportError:
        pass
    py = venv / "bin" / "python"
    if os.environ.get("RADTRACE_PEERS_VENV") == str(venv):
        sys.exit(f"compare-peers: error: {venv} has no working embreex/numpy")
    if not py.exists():
        print(f"compare-peers: creating {venv}", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    check = subprocess.run([str(py), "-c", "import embreex, numpy, mitsuba"], capture_output=True)
    if check.returncode != 0:
        print(f"compare-peers: installing {' '.join(PIP_PACKAGES)}", file=sys.stderr)
        subprocess.run([str(py), "-m", "pip", "install", "-q", *PIP_PACKAGES], check=True)
    env = dict(os.environ, RADTRACE_PEERS_VENV=str(venv))
    os.execve(str(py), [str(py), __file__, *sys.argv[1:]], env)


def load_rays(dump: Path, kind: str):
    import numpy as np

    o = np.load(dump / f"{kind}_origins.npy")
    d = np.load(dump / f"{kind}_dirs.npy")
    tmax = np.load(dump / f"{kind}_tmax.npy")
    return o, d, tmax


def embree_scene(dump: Path):
    import numpy as np
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    tris = np.load(dump / "triangles.npy")
    t = time.perf_counter()
    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, tris)
    one = np.zeros((1, 3), np.float32)
    scene.run(one, one + np.float32(1.0))  # the first run commits (builds the BVH)
    return scene, time.perf_counter() - t


def embree_trace(scene, o, d, tmax, kind):
    """One pass of Embree's single-ray API over the rays; returns the answers."""
    query = "OCCLUDED" if kind == "shadow" else "INTERSECT"
    return scene.run(o, d, dists=tmax.copy(), query=query)


def _worker(dump, kind, lo, hi, repeats, barrier, out):
    scene, _ = embree_scene(Path(dump))
    o, d, tmax = load_rays(Path(dump), kind)
    o, d, tmax = o[lo:hi].copy(), d[lo:hi].copy(), tmax[lo:hi].copy()
    times = []
    for _ in range(repeats):
        barrier.wait()
        t = time.perf_counter()
        embree_trace(scene, o, d, tmax, kind)
        times.append(time.perf_counter() - t)
    out.put(times)


def embree_parallel(dump: Path, kind: str, n_rays: int, procs: int, repeats: int) -> float:
    """Best wall time of `procs` processes tracing 1/procs of the rays each, started
    together (a barrier before every repeat)."""
    ctx = mp.get_context("spawn")
    barrier = ctx.Barrier(procs)
    out = ctx.Queue()
    bounds = [n_rays * i // procs for i in range(procs + 1)]
    ps = [
        ctx.Process(target=_worker, args=(str(dump), kind, bounds[i], bounds[i + 1], repeats, barrier, out))
        for i in range(procs)
    ]
    for p in ps:
        p.start()
    per_proc = [out.get() for _ in ps]
    for p in ps:
        p.join()
    # Repeat r ends when its slowest process ends.
    return min(max(ts[r] for ts in per_proc) for r in range(repeats))


def check_agreement(dump: Path, scene, kind: str):
    """Compares radtrace's answers with Embree's on every ray of `kind`."""
    import numpy as np

    o, d, tmax = load_rays(dump, kind)
    if kind == "shadow":
        ours = np.load(dump / "shadow_occluded.npy").astype(bool)
        theirs = embree_trace(scene, o, d, tmax, kind) != -1
        same = ours == theirs
        return {"rays": len(ours), "agree": float(same.mean()) if len(ours) else 1.0, "max_rel_t": 0.0}
    prim = np.load(dump / f"{kind}_prim.npy")
    t = np.load(dump / f"{kind}_t.npy")
    r = scene.run(o, d, dists=tmax.copy(), output=1)
    eprim, et = r["primID"], r["tfar"]
    both = (prim >= 0) & (eprim >= 0)
    same_tri = prim == eprim
    # A different triangle at the same distance is a tie (an edge shared by two
    # triangles, or coplanar ones): both answers are right.
    tie = both & ~same_tri & (np.abs(t - et) <= 1e-4 * np.maximum(1.0, np.abs(et)))
    agree = same_tri | tie
    hit_same = both & same_tri
    rel = np.abs(t[hit_same] - et[hit_same]) / np.maximum(1.0, np.abs(et[hit_same]))
    return {
        "rays": len(prim),
        "agree": float(agree.mean()) if len(prim) else 1.0,
        "same_triangle": float(same_tri.mean()) if len(prim) else 1.0,
        "max_rel_t": float(rel.max()) if len(rel) else 0.0,
    }


def radtrace_binary(args) -> Path:
    if args.radtrace:
        return Path(args.radtrace)
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=REPO, check=True)
    return REPO / "target" / "release" / "radtrace"


def compare_scene(args, exe: Path, scene_path: Path):
    with tempfile.TemporaryDirectory(prefix="radtrace-peers-") as tmp:
        dump = Path(tmp)
        cmd = [
            str(exe), "bench", str(scene_path), "--json", "--no-solve", "-q",
            "--threads", str(args.threads), "--repeats", str(args.repeats),
            "--width", str(args.width), "--height", str(args.height),
        ]
        ours = json.loads(subprocess.run(cmd + ["--dump", str(dump)], check=True, capture_output=True,
                                         text=True).stdout)
        scene, build_s = embree_scene(dump)
        rays = {k: load_rays(dump, k) for k in KINDS}
        rows = {}
        for fig in ours["rays"]:
            kind = fig["kind"]
            rows[kind] = {
                "kind": kind, "query": fig["query"], "rays": fig["rays"],
                "radtrace_1t": 0.0, "embree_1t": 0.0, "radtrace_nt": 0.0, "embree_nt": 0.0,
                "agreement": check_agreement(dump, scene, kind),
            }
        bvh_ms = float("inf")
        # Rounds alternate the two tracers, so that both see the same spells of load;
        # each keeps its best.
        for rnd in range(args.rounds):
            if rnd > 0:
                ours = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
                build_s = min(build_s, embree_scene(dump)[1])
            bvh_ms = min(bvh_ms, ours["bvh_build_s"] * 1e3)
            for fig in ours["rays"]:
                row = rows[fig["kind"]]
                row["radtrace_1t"] = max(row["radtrace_1t"], fig["mrays_1t"])
                row["radtrace_nt"] = max(row["radtrace_nt"], fig["mrays_nt"])
            for kind, row in rows.items():
                o, d, tmax = rays[kind]
                n = len(o)
                if n == 0:
                    continue
                # Thread CPU time, as radtrace's 1-thread figure (a loaded machine
                # takes the CPU away from both without counting it).
                best = float("inf")
                for _ in range(args.repeats):
                    t = time.thread_time()
                    embree_trace(scene, o, d, tmax, kind)
                    best = min(best, time.thread_time() - t)
                row["embree_1t"] = max(row["embree_1t"], n / best / 1e6)
                par = embree_parallel(dump, kind, n, args.threads, args.repeats)
                row["embree_nt"] = max(row["embree_nt"], n / par / 1e6)
        return {
            "scene": str(scene_path),
            "triangles": ours["triangles"],
            "threads": args.threads,
            "bvh_build_ms": {"radtrace": bvh_ms, "embree": build_s * 1e3},
            "rays": [rows[k] for k in KINDS if k in rows],
        }


def ratio(a, b):
    return a / b if b > 0 else float("nan")


def print_table(results, threads):
    n = threads
    print()
    print("Ray queries, Mrays/s (best of the repeats); ratio = radtrace / Embree single-ray API")
    head = (f"{'scene':<13} {'rays':<11} {'count':>8}  {'radtrace 1t':>11} {'Embree 1t':>10} {'ratio':>6}"
            f"  {f'radtrace {n}t':>11} {f'Embree {n}p':>10} {'ratio':>6}  {'agree':>8}")
    print(head)
    print("-" * len(head))
    ok = True
    for res in results:
        name = Path(res["scene"]).stem
        for r in res["rays"]:
            a = r["agreement"]["agree"]
            ok &= a >= 0.999
            print(f"{name:<13} {r['kind']:<11} {r['rays']:>8}  {r['radtrace_1t']:>11.2f} {r['embree_1t']:>10.2f} "
                  f"{ratio(r['radtrace_1t'], r['embree_1t']):>5.2f}x  {r['radtrace_nt']:>11.2f} {r['embree_nt']:>10.2f} "
                  f"{ratio(r['radtrace_nt'], r['embree_nt']):>5.2f}x  {100 * a:>7.3f}%")
    print()
    print(f"{'BVH build, ms':<24} {'radtrace':>10} {'Embree':>10} {'Embree/radtrace':>16}   (both on all threads)")
    for res in results:
        b = res["bvh_build_ms"]
        print(f"{Path(res['scene']).stem + ' (' + str(res['triangles']) + ' tris)':<24} {b['radtrace']:>10.2f} "
              f"{b['embree']:>10.2f} {ratio(b['embree'], b['radtrace']):>15.2f}x")
    print(f"\n1t: per thread-CPU second; {n}t/{n}p: per wall second, Embree on {n} processes (its run() holds "
          "the GIL); agree: same triangle (or a tie at the same distance) or occluded flag")
    try:
        print(f"load average at the end: {open('/proc/loadavg').read().split()[0]} ({os.cpu_count()} cores)")
    except OSError:
        pass
    return ok


# ---------------------------------------------------------------------------------
# Time to equal quality against Mitsuba 3.
# ---------------------------------------------------------------------------------
MITSUBA_RENDER = r"""
import json, os, sys, time
import mitsuba as mi
scene_file, out, spp, seed, defines = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), json.loads(sys.argv[5])
sensor = int(sys.argv[6]) if len(sys.argv) > 6 else 0
for v in (["llvm_ad_rgb", "scalar_rgb"] if os.environ.get("DRJIT_LIBLLVM_PATH") else ["scalar_rgb"]):
    try:
        mi.set_variant(v)
        break
    except Exception:
        pass
scene = mi.load_file(scene_file, **defines)
# A path tracer with the scene's own path length limit (its <integrator>'s max_depth;
# Mitsuba's default, unlimited, when it names none): radtrace's radiosity carries every
# bounce, and a limit of 8 leaves a room of 0.8-reflectance walls 5 % darker.
import re
depth = re.search(r"max_depth = (\d+)", str(scene.integrator()))
depth = int(depth.group(1)) if depth else -1
depth = -1 if depth >= 2**31 else depth
t = time.perf_counter()
img = mi.render(scene, integrator=mi.load_dict({"type": "path", "max_depth": depth}), spp=spp, seed=seed,
                sensor=scene.sensors()[sensor])
bmp = mi.Bitmap(img)
wall = time.perf_counter() - t
bmp.write(out)
print(json.dumps({"variant": mi.variant(), "render_s": wall}))
"""


def mitsuba_env():
    """Mitsuba's LLVM backend needs Debian's libllvm19 (older ones crash it); installed
    on demand when running as root, as tools/mitsuba-reference does.
    Without it Mitsuba falls back to its much slower scalar variant."""
    if not LLVM.exists() and os.geteuid() == 0:
        print("compare-peers: installing libllvm19 for Mitsuba's LLVM backend", file=sys.stderr)
        subprocess.run(["apt-get", "install", "-y", "-q", "libllvm19"], capture_output=True)
    env = dict(os.environ)
    if LLVM.exists():
        env["DRJIT_LIBLLVM_PATH"] = str(LLVM)
    return env


def mitsuba_render(scene: Path, out: Path, spp: int, seed: int, defines: dict, sensor: int = 0) -> dict:
    """Renders sensor `sensor` with Mitsuba's path tracer in a fresh process; returns its
    render time (as tools/mitsuba-reference --time reports it) and the process's."""
    t = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-c", MITSUBA_RENDER, str(scene), str(out), str(spp), str(seed), json.dumps(defines),
         str(sensor)],
        capture_output=True, text=True, env=mitsuba_env(),
    )
    if r.returncode != 0:
        sys.exit(f"compare-peers: error: Mitsuba failed on {scene}:\n{r.stderr[-2000:]}")
    doc = json.loads(r.stdout.strip().splitlines()[-1])
    doc["process_s"] = time.perf_counter() - t
    return doc


def flip(exe: str, ref: Path, img: Path) -> float:
    r = subprocess.run([exe, "compare", str(ref), str(img), "--json"], capture_output=True, text=True, check=True)
    return json.loads(r.stdout)["flip"]


def mitsuba_defines(exe: str, scene: Path, work: Path) -> dict:
    """Scene parameters (-D) Mitsuba needs: the paper room's Bezier teapot as an OBJ.
    radtrace renders every scene with its defaults; the Cornell box and the conference
    room need none (both load their meshes as they are)."""
    if "teapot_type" not in scene.read_text():
        return {}
    obj = work / "teapot.obj"
    subprocess.run([exe, "tessellate", str(scene.parent / "teapot.bpt"), "-o", str(obj)], check=True, capture_output=True)
    return {"teapot_type": "obj", "teapot_file": str(obj)}


# radtrace settings tried in turn until its FLIP is no worse than Mitsuba's: the
# levels of the quality dial, least effort first.
EFFORT = [["--quality", q] for q in ("draft", "good", "final")]
# Scenes (by file stem) with a ladder of their own. None now: since pass 1 merges
# polygons into lattice patches and carries the tail by photons, the conference room
# (331,185 triangles) renders with the defaults in about 25 s on 2 cores.
RADTRACE_EFFORT: dict = {}


def reference_key(scene: Path, defines: dict) -> str:
    """Cache key of a Mitsuba reference: the scene file, the files it names (meshes,
    textures: the conference's PLYs changed without its XML having to) and the -D
    parameters given to Mitsuba."""
    import hashlib
    import re

    # The path length rule is part of the key: references made with a limit of 8
    # must not be reused.
    h = hashlib.sha256(b"path-scene-max-depth\0" + scene.read_bytes())
    for name in sorted(set(re.findall(r'name="filename"\s+value="([^"$]+)"', scene.read_text()))):
        f = scene.parent / name
        if f.is_file():
            h.update(name.encode() + b"\0" + f.read_bytes())
    for k, v in sorted(defines.items()):
        # The value may be a temporary path (the teapot OBJ): key on its contents.
        h.update(f"{k}=".encode() + (Path(v).read_bytes() if Path(v).is_file() else v.encode()))
    return h.hexdigest()[:12]


def reference(args, scene: Path, defines: dict, given=None, sensor: int = 0) -> Path:
    """The Mitsuba reference of `scene`'s sensor `sensor`: `given`, else one rendered at
    --reference-spp and cached in the venv by the scene's contents."""
    if given:
        return Path(given)
    cache = args.venv / "references"
    cache.mkdir(parents=True, exist_ok=True)
    view = f"-view{sensor}" if sensor else ""
    ref = cache / f"{scene.stem}{view}-{reference_key(scene, defines)}-{args.reference_spp}spp.exr"
    if not ref.exists():
        print(f"compare-peers: Mitsuba reference, {args.reference_spp} spp (cached in {ref})", file=sys.stderr)
        mitsuba_render(scene, ref, args.reference_spp, 0, defines, sensor)
    return ref


def mitsuba_time_to_quality(args, exe: str):
    rows = []
    if args.reference and len(args.mitsuba_scenes) != 1:
        sys.exit("compare-peers: error: --reference needs exactly one scene in --mitsuba-scenes")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for entry in args.mitsuba_scenes:
            path, _, view = entry.partition(":")
            scene = Path(path) if Path(path).is_absolute() else REPO / path
            view = int(view or 0)
            if view != 0:
                sys.exit("compare-peers: error: the Mitsuba comparison renders sensor 0 only")
            defines = mitsuba_defines(exe, scene, work)
            ref = reference(args, scene, defines, args.reference)
            print(f"compare-peers: Mitsuba {args.mitsuba_spp} spp on {scene.name}", file=sys.stderr)
            best_m = None
            for _ in range(args.rounds):
                m = mitsuba_render(scene, work / "m.exr", args.mitsuba_spp, 1, defines)
                if best_m is None or m["render_s"] < best_m["render_s"]:
                    best_m = m
            f_m = flip(exe, ref, work / "m.exr")
            for effort in RADTRACE_EFFORT.get(scene.stem, EFFORT):
                print(f"compare-peers: radtrace {' '.join(effort) or '(default)'} on {scene.name}", file=sys.stderr)
                t_r = None
                for _ in range(args.rounds):
                    t = time.perf_counter()
                    subprocess.run([exe, "render", str(scene), "-o", str(work / "r.exr"), "-q", *effort], check=True)
                    t_r = min(t_r or 1e30, time.perf_counter() - t)
                f_r = flip(exe, ref, work / "r.exr")
                if f_r <= f_m:
                    break
            rows.append({
                "scene": scene.name, "reference_spp": args.reference_spp, "mitsuba_spp": args.mitsuba_spp,
                "mitsuba_variant": best_m["variant"], "mitsuba_render_s": best_m["render_s"],
                "mitsuba_process_s": best_m["process_s"], "mitsuba_flip": f_m,
                "radtrace_args": effort, "radtrace_process_s": t_r, "radtrace_flip": f_r,
                "ratio": best_m["render_s"] / t_r, "equal_quality": f_r <= f_m,
            })
    print()
    print(f"time to equal quality (mean FLIP against Mitsuba path {args.reference_spp} spp; load average {os.getloadavg()[0]:.2f})")
    print(f"{'scene':<20} {'Mitsuba':>8} {'render s':>9} {'FLIP':>7}   {'radtrace':<28} {'process s':>9} {'FLIP':>7}  {'Mitsuba/radtrace':>16}")
    for r in rows:
        label = " ".join(r["radtrace_args"]) or "default"
        print(f"{r['scene']:<20} {str(r['mitsuba_spp']) + ' spp':>8} {r['mitsuba_render_s']:9.2f} {r['mitsuba_flip']:7.4f}   "
              f"{label:<28} {r['radtrace_process_s']:9.2f} {r['radtrace_flip']:7.4f}  {r['ratio']:15.1f}x"
              + ("" if r["equal_quality"] else "  (radtrace's FLIP stayed worse)"))
    print("(Mitsuba: the time of mi.render (kernel compilation included, as mitsuba-reference --time), best of --rounds,")
    print(" Python start-up and scene loading excluded;")
    print(" radtrace: the whole process, scene loading, BVH and radiosity solve included, best of --rounds)")
    return rows


CYCLES = Path(__file__).resolve().parent / "cycles_render.py"
# Blender as a Python module; 5.0.1 is the release the comparison was checked with.
CYCLES_PACKAGE = "bpy==5.0.1"
QUALITY = ["draft", "good", "final"]


def ensure_package(module: str, package: str) -> None:
    """Installs `package` into this (the venv's) Python when `module` is missing."""
    try:
        __import__(module)
    except ImportError:
        print(f"compare-peers: installing {package}", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", package], check=True)


def cycles_render(args, scene: Path, out: Path, spp: int, denoise: bool, defines: dict, sensor: int = 0) -> dict:
    """Renders with Blender Cycles (tools/cycles_render.py) in a fresh process: the
    render call's time and the process's, or the reason the scene cannot be carried
    over (`error`)."""
    cmd = [sys.executable, str(CYCLES), str(scene), str(out), "--spp", str(spp),
           "--threads", str(args.threads), "--seed", "1", "--sensor", str(sensor)] + (["--denoise"] if denoise else [])
    for k, v in defines.items():
        cmd += ["-D", f"{k}={v}"]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return {"error": (r.stderr.strip().splitlines() or ["failed"])[-1]}
    doc = json.loads(r.stdout.strip().splitlines()[-1])
    doc["process_s"] = time.perf_counter() - t
    return doc


def mean_ratio(ref: Path, img: Path) -> float:
    """Mean of `img` over the mean of `ref` (all channels)."""
    import mitsuba as mi
    import numpy as np

    mi.set_variant("scalar_rgb")
    a = np.array(mi.Bitmap(str(ref)))[..., :3]
    b = np.array(mi.Bitmap(str(img)))[..., :3]
    return float(b.mean() / a.mean())


def best_of(n: int, run):
    """The run (a dict with `process_s`) of the least time out of `n`."""
    best = None
    for _ in range(n):
        r = run()
        if "error" in r:
            return r
        if best is None or r["process_s"] < best["process_s"]:
            best = r
    return best


def curves(args, exe: str):
    """FLIP against seconds (whole process, --threads each) for radtrace's quality dial,
    Mitsuba 3 at --curve-mitsuba-spp and Blender Cycles with OpenImageDenoise at
    --cycles-spp, on each of --curve-scenes; the Cycles scene is first checked against
    the Mitsuba reference (its mean within 3 % at --cycles-check-spp, undenoised)."""
    cycles = not args.no_cycles
    if cycles:
        ensure_package("bpy", CYCLES_PACKAGE)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for entry in args.curve_scenes:
            # SCENE or SCENE:K, sensor (view) K.
            path, sensor = entry, 0
            if ":" in entry and entry.rsplit(":", 1)[1].isdigit():
                path, sensor = entry.rsplit(":", 1)[0], int(entry.rsplit(":", 1)[1])
            scene = Path(path) if Path(path).is_absolute() else REPO / path
            title = scene.name + (f", view {sensor}" if sensor else "")
            defines = mitsuba_defines(exe, scene, work)
            ref = reference(args, scene, defines, sensor=sensor)
            points = []
            for q in QUALITY:
                print(f"compare-peers: radtrace --quality {q} on {title}", file=sys.stderr)

                def run():
                    t = time.perf_counter()
                    subprocess.run([exe, "render", str(scene), "-o", str(work / "r.exr"), "-q", "--quality", q,
                                    "--threads", str(args.threads), "--view", str(sensor)], check=True)
                    return {"process_s": time.perf_counter() - t}
                r = best_of(args.rounds, run)
                points.append({"renderer": "radtrace", "setting": q, "seconds": r["process_s"],
                               "flip": flip(exe, ref, work / "r.exr")})
            for spp in args.curve_mitsuba_spp:
                print(f"compare-peers: Mitsuba {spp} spp on {title}", file=sys.stderr)
                r = best_of(args.rounds, lambda: mitsuba_render(scene, work / "m.exr", spp, 1, defines, sensor))
                points.append({"renderer": "Mitsuba 3", "setting": f"{spp} spp", "seconds": r["process_s"],
                               "render_s": r["render_s"], "flip": flip(exe, ref, work / "m.exr")})
            check = None
            if cycles:
                print(f"compare-peers: Cycles check, {args.cycles_check_spp} spp on {title}", file=sys.stderr)
                c = cycles_render(args, scene, work / "c.exr", args.cycles_check_spp, False, defines, sensor)
                if "error" in c:
                    check = {"skipped": c["error"]}
                else:
                    check = {"spp": args.cycles_check_spp, "flip": flip(exe, ref, work / "c.exr"),
                             "mean_ratio": mean_ratio(ref, work / "c.exr"), "blender": c["blender"]}
                    if abs(check["mean_ratio"] - 1.0) > 0.03:
                        check["skipped"] = f"its mean is {check['mean_ratio']:.3f} of Mitsuba's: not the same scene"
                print(f"compare-peers: Cycles check: {check}", file=sys.stderr)
                if "skipped" not in check:
                    for spp in args.cycles_spp:
                        print(f"compare-peers: Cycles + OIDN {spp} spp on {title}", file=sys.stderr)
                        r = best_of(args.rounds,
                                    lambda: cycles_render(args, scene, work / "c.exr", spp, True, defines, sensor))
                        points.append({"renderer": "Cycles + OIDN", "setting": f"{spp} spp",
                                       "seconds": r["process_s"], "render_s": r["render_s"],
                                       "flip": flip(exe, ref, work / "c.exr")})
            rows.append({"scene": title, "reference_spp": args.reference_spp, "points": points,
                         "cycles_check": check})
    print()
    print(f"FLIP against seconds (whole process, {args.threads} threads; mean FLIP against Mitsuba path "
          f"{args.reference_spp} spp; load average {os.getloadavg()[0]:.2f})")
    print(f"{'scene':<20} {'renderer':<15} {'setting':<9} {'seconds':>8} {'FLIP':>7}")
    for row in rows:
        for p in row["points"]:
            print(f"{row['scene']:<20} {p['renderer']:<15} {p['setting']:<9} {p['seconds']:8.2f} {p['flip']:7.4f}")
        if row["cycles_check"]:
            print(f"{row['scene']:<20} Cycles check: {row['cycles_check']}")
    if args.plot:
        plot(rows, args.plot, args.threads)
    return rows


def min_s(row) -> float:
    return min(p["seconds"] for p in row["points"])


def max_s(row) -> float:
    return max(p["seconds"] for p in row["points"])


def plot(rows, path: Path, threads: int) -> None:
    """One panel per scene: FLIP against seconds, a line per renderer."""
    ensure_package("matplotlib", "matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, len(rows), figsize=(5.2 * len(rows), 4.2), squeeze=False)
    styles = {"radtrace": ("C3", "o"), "Mitsuba 3": ("C0", "s"), "Cycles + OIDN": ("C2", "^")}
    for ax, row in zip(axes[0], rows):
        for name, (colour, marker) in styles.items():
            pts = [p for p in row["points"] if p["renderer"] == name]
            if not pts:
                continue
            ax.plot([p["seconds"] for p in pts], [p["flip"] for p in pts], marker=marker, color=colour, label=name)
            for p in pts:
                ax.annotate(p["setting"], (p["seconds"], p["flip"]), textcoords="offset points", xytext=(4, 4),
                            fontsize=7, color=colour)
        ax.set_xscale("log")
        ticks = [t for t in (1, 2, 5, 10, 20, 50, 100, 200, 500) if 0.5 * min_s(row) <= t <= 2 * max_s(row)]
        ax.set_xticks(ticks, [str(t) for t in ticks])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel(f"seconds, whole process, {threads} threads")
        ax.set_ylabel("mean FLIP against the reference")
        ax.set_title(row["scene"])
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"compare-peers: plot -> {path}", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=None, help="scene files (default: the repository's)")
    ap.add_argument("--radtrace", help="radtrace binary (default: cargo build --release)")
    ap.add_argument("--threads", type=int, default=2, help="threads (radtrace) / processes (Embree) of the parallel figures")
    ap.add_argument("--repeats", type=int, default=3, help="timing repeats in a round; the best is reported")
    ap.add_argument("--rounds", type=int, default=3, help="rounds alternating radtrace and Embree")
    ap.add_argument("--width", type=int, default=512)
    ap.add_argument("--height", type=int, default=512)
    ap.add_argument("--venv", type=Path, default=DEFAULT_VENV)
    ap.add_argument("--json", type=Path, help="also write the results as JSON")
    ap.add_argument("--no-rays", action="store_true", help="skip the ray comparison with Embree")
    ap.add_argument("--no-mitsuba", action="store_true", help="skip the time-to-quality comparison with Mitsuba")
    ap.add_argument("--mitsuba-scenes", nargs="+",
                    default=["scenes/cornell-box/cornell-box.xml", "scenes/conference/conference.xml"],
                    help="scenes of the Mitsuba comparison (sensor 0)")
    ap.add_argument("--mitsuba-spp", type=int, default=64, help="Mitsuba's samples per pixel to match")
    ap.add_argument("--reference-spp", type=int, default=1024, help="samples per pixel of the Mitsuba reference")
    ap.add_argument("--reference", help="an existing Mitsuba reference EXR to use (one scene)")
    ap.add_argument("--curves", action="store_true",
                    help="FLIP against seconds for radtrace's quality dial, Mitsuba and denoised Cycles")
    ap.add_argument("--curve-scenes", nargs="+",
                    default=["scenes/cornell-box/cornell-box.xml", "scenes/paper-room/paper-room.xml",
                             "scenes/paper-room/paper-room.xml:1"],
                    help="scenes of --curves; SCENE:K renders sensor (view) K")
    ap.add_argument("--curve-mitsuba-spp", type=int, nargs="+", default=[16, 64, 256])
    ap.add_argument("--cycles-spp", type=int, nargs="+", default=[4, 16, 64],
                    help="samples per pixel of Cycles (with OpenImageDenoise) in --curves")
    ap.add_argument("--cycles-check-spp", type=int, default=64,
                    help="samples per pixel of the undenoised Cycles render checked against the reference")
    ap.add_argument("--no-cycles", action="store_true", help="leave Cycles out of --curves")
    ap.add_argument("--plot", type=Path, help="with --curves: write the plot (PNG) here")
    ap.add_argument("--replot", type=Path, metavar="JSON",
                    help="draw --plot from the curves of an earlier --json file, measuring nothing")
    args = ap.parse_args()
    ensure_venv(args.venv)
    if args.replot:
        if not args.plot:
            sys.exit("compare-peers: error: --replot needs --plot FILE")
        doc = json.loads(args.replot.read_text())
        plot(doc["curves"], args.plot, doc.get("threads", args.threads))
        return

    scenes = [Path(s) for s in args.scenes] if args.scenes else [
        REPO / s for s in DEFAULT_SCENES if (REPO / s).exists()
    ]
    exe = radtrace_binary(args)
    results = []
    ok = True
    if not args.no_rays:
        for s in scenes:
            print(f"compare-peers: {s}", file=sys.stderr)
            results.append(compare_scene(args, exe, s))
        ok = print_table(results, args.threads)
    mitsuba = None if args.no_mitsuba else mitsuba_time_to_quality(args, exe)
    curve_rows = curves(args, exe) if args.curves else None
    if args.json:
        args.json.write_text(json.dumps({"rays": results, "mitsuba": mitsuba, "curves": curve_rows,
                                          "threads": args.threads}, indent=2) + "\n")
    if not ok:
        print("compare-peers: error: radtrace and Embree disagree on more than 0.1% of some ray set", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
