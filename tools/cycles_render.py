"""Renders a Mitsuba 3 scene file with Blender Cycles (the `bpy` module), for
tools/compare-peers.py: the same scene, read by Mitsuba's own loader, rebuilt in Cycles.

    python cycles_render.py SCENE.xml OUT.exr --spp N [--denoise] [--threads T]
                            [--seed S] [--sensor K] [-D NAME=VALUE ...]

Prints one JSON line: the render call's wall time (`render_s`, OpenImageDenoise
included when on), the samples, and Blender's version.

What it carries over: triangle meshes (Mitsuba merges the meshes of one BSDF; that
changes nothing), `diffuse` reflectance (also inside `twosided`; a one-sided diffuse
surface is black from behind, as in Mitsuba), a `blendbsdf` of a `diffuse` and a smooth
`conductor` of constant reflectance (Cycles' mix of a diffuse and a sharp glossy BSDF;
the conductor's Fresnel term is left out, so it is exact for `material="none"`),
`area` emitters (radiance, front side only, as in Mitsuba), `spot` lights (intensity
in W/sr as a Cycles spot of power 4 pi I with no radius; Mitsuba's falloff, linear in
the angle from `beam_width` to `cutoff_angle`, as Cycles' spot size and blend, which
ramp the same transition by a smoothstep in the cosine), and the perspective sensor
`--sensor` (`to_world`, `x_fov`, film size).
No world light. Anything else (other BSDFs, textures, analytic shapes, other emitters)
is refused with a message: the comparison would not be of the same scene.
Path length is unbounded in effect (1024 bounces), as Mitsuba's `max_depth` -1.
"""

import argparse
import json
import sys
import time

import numpy as np


def rgb(value) -> list:
    """Three floats of a Mitsuba colour parameter (a uniform spectrum holds one)."""
    v = [float(x) for x in np.array(value).reshape(-1)[:3]]
    return v * 3 if len(v) == 1 else v


def spot(mi, e):
    """A Mitsuba spot light: its to_world, intensity (W/sr) and angles (degrees)."""
    ep = mi.traverse(e)
    if "intensity.value" not in ep:
        sys.exit("cycles_render: a spot light's intensity is not a constant colour")
    return {"to_world": np.array(ep["to_world"].matrix, dtype=np.float64).reshape(4, 4),
            "intensity": rgb(ep["intensity.value"]),
            "cutoff": float(ep["cutoff_angle"]), "beam": float(ep["beam_width"])}


def read_scene(path: str, defines: dict, sensor_index: int = 0):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    scene = mi.load_file(path, **defines)
    shapes = []
    for sh in scene.shapes():
        name = sh.id() or "shape"
        if not sh.is_mesh():
            sys.exit(f"cycles_render: {path}: shape '{name}' ({type(sh).__name__}) is not a triangle mesh")
        pos = np.array(sh.vertex_positions_buffer(), dtype=np.float64).reshape(-1, 3)
        faces = np.array(sh.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        bsdf = sh.bsdf()
        text = str(bsdf)
        bp = mi.traverse(bsdf)
        twosided = text.startswith("TwoSided")
        pre = "brdf_0." if twosided else ""
        mirror = None
        if "BlendBSDF" in text and text.count("SmoothDiffuse") >= 1 and "SmoothConductor" in text \
                and f"{pre}bsdf_1.specular_reflectance.value" in bp and f"{pre}bsdf_0.reflectance.value" in bp:
            rho = rgb(bp[f"{pre}bsdf_0.reflectance.value"])
            mirror = {"weight": float(np.array(bp[f"{pre}weight.value"]).reshape(-1)[0]),
                      "reflectance": rgb(bp[f"{pre}bsdf_1.specular_reflectance.value"])}
        elif (twosided or text.startswith("SmoothDiffuse")) and "BlendBSDF" not in text and f"{pre}reflectance.value" in bp:
            rho = rgb(bp[f"{pre}reflectance.value"])
        else:
            kind = text.split("[")[0]
            sys.exit(f"cycles_render: {path}: shape '{name}': BSDF {kind} is not carried over (a diffuse one of a "
                     "constant colour, or a blend of one and a smooth conductor)")
        radiance = None
        if sh.emitter() is not None:
            ep = mi.traverse(sh.emitter())
            if "radiance.value" not in ep:
                sys.exit(f"cycles_render: {path}: shape '{name}': emitter radiance is not a constant colour")
            radiance = rgb(ep["radiance.value"])
        shapes.append({"name": name, "pos": pos, "faces": faces, "rho": rho, "twosided": twosided,
                       "radiance": radiance, "mirror": mirror})
    spots = [spot(mi, e) for e in scene.emitters() if str(e).startswith("SpotLight")]
    others = [e for e in scene.emitters() if not str(e).startswith(("AreaLight", "SpotLight"))]
    if others:
        sys.exit(f"cycles_render: {path}: {len(others)} emitter(s) not on a shape and not spot lights (point, envmap ...) are not carried over")
    if not 0 <= sensor_index < len(scene.sensors()):
        sys.exit(f"cycles_render: {path}: no sensor {sensor_index} (it has {len(scene.sensors())})")
    sensor = scene.sensors()[sensor_index]
    sp = mi.traverse(sensor)
    to_world = np.array(sp["to_world"].matrix, dtype=np.float64).reshape(4, 4)
    size = [int(x) for x in sensor.film().size()]
    return shapes, spots, {"to_world": to_world, "x_fov": float(sp["x_fov"][0] if hasattr(sp["x_fov"], "__len__") else sp["x_fov"]), "size": size}


def material(bpy, s):
    """Diffuse (black from behind unless two-sided), plus front-side emission."""
    m = bpy.data.materials.new(s["name"])
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diffuse = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*s["rho"], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    surface = diffuse.outputs["BSDF"]
    if s["mirror"] is not None:
        # Mitsuba's blendbsdf: (1 - weight) diffuse + weight mirror.
        glossy = nt.nodes.new("ShaderNodeBsdfGlossy")
        glossy.distribution = "SHARP" if "SHARP" in [i.identifier for i in glossy.bl_rna.properties["distribution"].enum_items] else "GGX"
        glossy.inputs["Color"].default_value = (*s["mirror"]["reflectance"], 1.0)
        glossy.inputs["Roughness"].default_value = 0.0
        mixed = nt.nodes.new("ShaderNodeMixShader")
        mixed.inputs["Fac"].default_value = s["mirror"]["weight"]
        nt.links.new(surface, mixed.inputs[1])
        nt.links.new(glossy.outputs["BSDF"], mixed.inputs[2])
        surface = mixed.outputs["Shader"]
    if not s["twosided"]:
        black = nt.nodes.new("ShaderNodeBsdfDiffuse")
        black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
        nt.links.new(surface, mix.inputs[1])
        nt.links.new(black.outputs["BSDF"], mix.inputs[2])
        surface = mix.outputs["Shader"]
    if s["radiance"] is not None:
        emit = nt.nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = (*s["radiance"], 1.0)
        emit.inputs["Strength"].default_value = 1.0
        none = nt.nodes.new("ShaderNodeBsdfTransparent")
        front = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geo.outputs["Backfacing"], front.inputs["Fac"])
        nt.links.new(emit.outputs["Emission"], front.inputs[1])
        # (Transparent with a zero colour: nothing, and no light through.)
        none.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        nt.links.new(none.outputs["BSDF"], front.inputs[2])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(surface, add.inputs[0])
        nt.links.new(front.outputs["Shader"], add.inputs[1])
        surface = add.outputs["Shader"]
    nt.links.new(surface, out.inputs["Surface"])
    return m


def build(bpy, shapes, spots, cam, args):
    import mathutils

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for s in shapes:
        mesh = bpy.data.meshes.new(s["name"])
        mesh.from_pydata(s["pos"].tolist(), [], s["faces"].tolist())
        mesh.update()
        obj = bpy.data.objects.new(s["name"], mesh)
        obj.data.materials.append(material(bpy, s))
        scene.collection.objects.link(obj)
    for i, sl in enumerate(spots):
        # Mitsuba's spot shines along its +z, Blender's along its -z.
        peak = max(max(sl["intensity"]), 1e-12)
        light = bpy.data.lights.new(f"spot{i}", type="SPOT")
        light.color = [c / peak for c in sl["intensity"]]
        light.energy = 4.0 * np.pi * peak
        light.shadow_soft_size = 0.0
        if hasattr(light, "use_soft_falloff"):
            light.use_soft_falloff = False
        cutoff, beam = np.radians(sl["cutoff"]), np.radians(sl["beam"])
        light.spot_size = 2.0 * cutoff
        light.spot_blend = float((np.cos(beam) - np.cos(cutoff)) / (1.0 - np.cos(cutoff)))
        obj = bpy.data.objects.new(f"spot{i}", light)
        obj.matrix_world = mathutils.Matrix((sl["to_world"] @ np.diag([1.0, -1.0, -1.0, 1.0])).tolist())
        scene.collection.objects.link(obj)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.angle = np.radians(cam["x_fov"])
    cam_obj = bpy.data.objects.new("camera", cam_data)
    # Mitsuba's camera looks along +z with +x to the left; Blender's along -z, +x right.
    m = cam["to_world"] @ np.diag([-1.0, 1.0, -1.0, 1.0])
    cam_obj.matrix_world = mathutils.Matrix(m.tolist())
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y = cam["size"]
    r.resolution_percentage = 100
    r.threads_mode = "FIXED"
    r.threads = args.threads
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    c = scene.cycles
    c.device = "CPU"
    c.samples = args.spp
    c.use_adaptive_sampling = False
    c.seed = args.seed
    c.use_denoising = args.denoise
    c.denoiser = "OPENIMAGEDENOISE"
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 1024
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    return scene


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--denoise", action="store_true")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sensor", type=int, default=0, help="which sensor (view) of the scene")
    ap.add_argument("-D", action="append", default=[], metavar="NAME=VALUE")
    args = ap.parse_args()
    defines = dict(d.split("=", 1) for d in args.D)
    shapes, spots, cam = read_scene(args.scene, defines, args.sensor)
    import bpy

    scene = build(bpy, shapes, spots, cam, args)
    scene.render.filepath = args.out
    t = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    wall = time.perf_counter() - t
    bpy.data.images["Render Result"].save_render(args.out)
    print(json.dumps({"render_s": wall, "spp": args.spp, "denoise": args.denoise,
                      "blender": bpy.app.version_string}))


if __name__ == "__main__":
    main()
