"""Bakes the irradiance of a glTF scene's lightmap atlas with Cycles, run inside Blender (headless):

  blender -b --factory-startup --python-exit-code 1 --python cycles_bake.py -- \
      --scene SCENE.gltf --samples N --seed S --out PREFIX [--resolution 256] [--threads 2] [--max-bounces 8]

Imports SCENE, joins its meshes into one object, makes every material Lambertian (a Diffuse BSDF, roughness 0, of the
imported base colour; an emissive material also emits its imported radiance, from its front side only, as kiln's
one-sided emitters do), and bakes Cycles' DIFFUSE pass (DIRECT and INDIRECT, COLOR off: irradiance over pi) into one
float image through the UV map imported from TEXCOORD_1. Writes PREFIX.npy (float32, RESOLUTION x RESOLUTION x 4,
rows top first as in kiln's EXRs; alpha -1 where no triangle covers a texel's centre, so Cycles baked nothing there)
and PREFIX.json (the bake operator's wall and CPU seconds, the settings, the materials as baked).
"""
import argparse
import json
import math
import sys
import time

import numpy

# Debian's Blender 3.4 runs on the system's numpy (1.24), which dropped the aliases its glTF importer still uses.
for _alias, _type in (("bool", bool), ("int", int), ("float", float), ("object", object)):
    if _alias not in numpy.__dict__:
        setattr(numpy, _alias, _type)

import bpy  # noqa: E402  (after the aliases: the importer is loaded with bpy's add-ons)

SENTINEL_ALPHA = -1.0  # what unbaked texels keep; a baked texel's alpha is 1


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles_bake.py")
    p.add_argument("--scene", required=True)
    p.add_argument("--samples", type=int, required=True)
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--out", required=True, help="prefix of the .npy and .json written")
    p.add_argument("--resolution", type=int, default=256)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--max-bounces", type=int, default=8)
    p.add_argument("--backfaces", action="store_true",
                   help="bake the fraction of each texel's hemisphere that sees back faces instead (no bounces)")
    args = p.parse_args(argv)
    if args.backfaces:
        args.max_bounces = 0
    return args


def import_scene(path):
    """The scene alone (no default cube, lamp or camera) as one mesh object, and its lightmap UV map's name."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    if not meshes:
        raise SystemExit(f"cycles_bake.py: {path} holds no mesh")
    if any(o.type == "LIGHT" for o in bpy.data.objects):
        raise SystemExit(f"cycles_bake.py: {path} holds punctual lights; the benchmark compares emissive meshes only")
    for o in bpy.data.objects:
        o.select_set(o.type == "MESH")
    bpy.context.view_layer.objects.active = meshes[0]
    if len(meshes) > 1:
        bpy.ops.object.join()
    obj = bpy.context.view_layer.objects.active
    uv_maps = [uv.name for uv in obj.data.uv_layers]
    if len(uv_maps) < 2:
        raise SystemExit(f"cycles_bake.py: {path} has no TEXCOORD_1 (UV maps: {uv_maps}); it is the lightmap's")
    return obj, uv_maps[1]  # the importer names TEXCOORD_n's map the n-th


def principled_values(material):
    """(base colour, emitted radiance) of an imported glTF material: its Principled BSDF's inputs."""
    node = next((n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
    if node is None:
        raise SystemExit(f"cycles_bake.py: material {material.name} has no Principled BSDF to read its colour from")
    for socket in ("Base Color", "Emission"):
        if node.inputs[socket].is_linked:
            raise SystemExit(f"cycles_bake.py: material {material.name}'s {socket} is a texture; only factors here")
    base = tuple(node.inputs["Base Color"].default_value[:3])
    strength = node.inputs["Emission Strength"].default_value
    emission = tuple(c * strength for c in node.inputs["Emission"].default_value[:3])
    return base, emission


def make_lambertian(material, image):
    """Replaces the material's nodes by a Diffuse BSDF (plus its emission, front side only) and an active image node
    (the bake's target)."""
    base, emission = principled_values(material)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*base, 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0  # Oren-Nayar with sigma 0: Lambert
    surface = diffuse.outputs["BSDF"]
    if max(emission) > 0:
        # Cycles' emission shader emits from both sides; kiln's emitters (glTF doubleSided false) from the front only.
        emit = nodes.new("ShaderNodeEmission")
        emit.inputs["Color"].default_value = (*emission, 1.0)
        emit.inputs["Strength"].default_value = 1.0
        front = nodes.new("ShaderNodeAddShader")
        links.new(diffuse.outputs["BSDF"], front.inputs[0])
        links.new(emit.outputs["Emission"], front.inputs[1])
        sides = nodes.new("ShaderNodeMixShader")
        links.new(nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], sides.inputs["Fac"])
        links.new(front.outputs["Shader"], sides.inputs[1])
        links.new(diffuse.outputs["BSDF"], sides.inputs[2])
        surface = sides.outputs["Shader"]
    links.new(surface, output.inputs["Surface"])
    target = nodes.new("ShaderNodeTexImage")
    target.image = image
    nodes.active = target
    return {"name": material.name, "base_color": base, "emission": emission}


def make_backface_emitter(material, image):
    """Replaces the material's nodes by a white Diffuse BSDF whose back side emits radiance 1: baked without bounces,
    a texel then holds the cosine-weighted fraction of its hemisphere that sees back faces (E/pi), the measure by
    which kiln decides that a sample point lies inside or behind geometry."""
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (1, 1, 1, 1)  # the receiver's colour, divided out by the bake
    emit = nodes.new("ShaderNodeEmission")
    links.new(nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], emit.inputs["Strength"])
    both = nodes.new("ShaderNodeAddShader")
    links.new(diffuse.outputs["BSDF"], both.inputs[0])
    links.new(emit.outputs["Emission"], both.inputs[1])
    links.new(both.outputs["Shader"], output.inputs["Surface"])
    target = nodes.new("ShaderNodeTexImage")
    target.image = image
    nodes.active = target
    return {"name": material.name, "base_color": (1, 1, 1), "emission": "1 on back faces"}


def configure_cycles(args):
    """Every setting that changes the estimate, explicit (the factory defaults clamp, adapt and denoise)."""
    scene = bpy.context.scene
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.render.engine = "CYCLES"
    scene.render.threads_mode = "FIXED"
    scene.render.threads = args.threads
    c = scene.cycles
    settings = {
        "device": "CPU", "samples": args.samples, "seed": args.seed, "use_animated_seed": False,
        "sampling_pattern": "PROGRESSIVE_MULTI_JITTER", "scrambling_distance": 1.0, "auto_scrambling_distance": False,
        "use_adaptive_sampling": False, "use_denoising": False, "use_guiding": False, "use_fast_gi": False,
        "max_bounces": args.max_bounces, "diffuse_bounces": args.max_bounces, "glossy_bounces": args.max_bounces,
        "transmission_bounces": args.max_bounces, "transparent_max_bounces": args.max_bounces,
        "volume_bounces": 0, "min_light_bounces": 0, "min_transparent_bounces": 0,
        "sample_clamp_direct": 0.0, "sample_clamp_indirect": 0.0, "light_sampling_threshold": 0.0,
        "caustics_reflective": True, "caustics_refractive": True,
        "direct_light_sampling_type": "MULTIPLE_IMPORTANCE_SAMPLING",
    }
    for name, value in settings.items():
        setattr(c, name, value)
        taken = getattr(c, name)
        if taken != value and not (isinstance(value, float) and math.isclose(taken, value)):
            raise SystemExit(f"cycles_bake.py: Cycles did not take {name} = {value!r}")
    settings["threads"] = scene.render.threads
    return settings


def bake(obj, uv_map, image):
    """Cycles' DIFFUSE bake, DIRECT and INDIRECT without COLOR: E/pi; timed around the operator alone."""
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    wall, cpu = time.perf_counter(), time.process_time()  # process_time counts every thread of Blender
    result = bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, margin=0, use_clear=False,
                                 uv_layer=uv_map, target="IMAGE_TEXTURES", use_selected_to_active=False)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    if result != {"FINISHED"}:
        raise SystemExit(f"cycles_bake.py: the bake ended {result}")
    return wall, cpu


def main():
    args = parse_args()
    obj, uv_map = import_scene(args.scene)
    n = args.resolution
    image = bpy.data.images.new("lightmap", n, n, alpha=True, float_buffer=True)
    image.pixels.foreach_set(numpy.tile(numpy.array([0, 0, 0, SENTINEL_ALPHA], numpy.float32), n * n))
    make = make_backface_emitter if args.backfaces else make_lambertian
    materials = [make(m, image) for m in bpy.data.materials if m.users and m.node_tree]
    settings = configure_cycles(args)
    wall, cpu = bake(obj, uv_map, image)
    pixels = numpy.empty(n * n * 4, numpy.float32)
    image.pixels.foreach_get(pixels)
    # Blender's rows start at the bottom; its glTF importer flips v (v_blender = 1 - v_gltf): reversing the rows gives
    # the image in glTF's orientation, kiln's.
    numpy.save(args.out + ".npy", pixels.reshape(n, n, 4)[::-1])
    baked = int((pixels.reshape(-1, 4)[:, 3] != SENTINEL_ALPHA).sum())
    info = {"wall_seconds": wall, "cpu_seconds": cpu, "blender": bpy.app.version_string, "uv_map": uv_map,
            "resolution": n, "baked_texels": baked, "settings": settings, "materials": materials}
    with open(args.out + ".json", "w") as f:
        json.dump(info, f, indent=1)
    print(f"cycles_bake.py: {args.samples} samples, seed {args.seed}: {wall:.2f} s wall, {cpu:.2f} s CPU, "
          f"{baked} texels baked")


main()
