"""Lightmap jobs from Python: meshes packed in the kiln mesh layout, and a JobSpec from keyword arguments.

Python has no Assimp, so scenes come as plain lists: kiln.mesh() packs positions, indices and UVs into the bytes of
the layout kiln.proto documents ("Lightmap jobs"; client/import/mesh_blob.cpp writes the same bytes in C++), and
kiln.lightmap_job() builds the kiln.pb.JobSpec around such meshes with instances, materials, textures, lights and an
environment given as dicts that mirror the proto's messages. (`kiln bake lightmap scene.gltf` is the way in for
glTF, OBJ and FBX files.)

    floor = kiln.mesh("floor", positions=[(0, 0, 0), (1, 0, 0), (1, 0, -1), (0, 0, -1)],
                      indices=[0, 1, 2, 0, 2, 3], lightmap_uv=[(0, 0), (1, 0), (1, 1), (0, 1)])
    job = kiln.lightmap_job([floor], environment=1.0, resolution=64, target_error=0.01,
                            lights=[{"name": "lamp", "color": 10, "point": {"position": (0.5, 2, -0.5)}}])
    with kiln.Client() as c:
        c.upload_blob(floor.data)
        c.run(job, out_dir="out/floor")     # floor_irradiance.exr, floor_validity.exr, ..., report.json
"""

import array
import sys

from . import kiln_pb2 as pb
from .digests import _as_digest, digest_of
from .fields import _fill, _set_color
from .jobs import _set_quality_and_effects

MAGIC = b"KILNMSH1"
# The layout's bound on vertices and on triangles (kiln.proto).
MAX_COUNT = 1 << 24

_FLAG_NORMALS, _FLAG_UV, _FLAG_LIGHTMAP_UV, _FLAG_MATERIALS = 1, 2, 4, 8


class Mesh:
    """A mesh in the kiln mesh layout: `name`, its bytes `data` (upload them with Client.upload_blob before
    submitting) and their `digest`, by which the job refers to them; `vertex_count` and `triangle_count`."""

    def __init__(self, name, data, vertex_count, triangle_count):
        self.name = name
        self.data = data
        self.digest = digest_of(data)
        self.vertex_count = vertex_count
        self.triangle_count = triangle_count

    def __repr__(self):
        return "kiln.Mesh(%r, %d vertices, %d triangles, sha256 %s)" % (
            self.name, self.vertex_count, self.triangle_count, self.digest.sha256[:12])


def _flat(values, width, what):
    """Plain floats from [(x, y, z), ...] or [x, y, z, ...]; ValueError naming `what` if the length is wrong."""
    values = list(values)
    if values and isinstance(values[0], (tuple, list)):
        for i, v in enumerate(values):
            if len(v) != width:
                raise ValueError("%s[%d]: %d components, expected %d" % (what, i, len(v), width))
        values = [c for v in values for c in v]
    if len(values) % width:
        raise ValueError("%s: %d numbers is not a multiple of %d" % (what, len(values), width))
    return values


def _little_endian(typecode, values, what):
    try:
        a = array.array(typecode, values)
    except (OverflowError, TypeError) as e:
        raise ValueError("%s: %s" % (what, e)) from None
    if sys.byteorder != "little":
        a.byteswap()
    return a.tobytes()


def mesh(name, positions, indices, lightmap_uv=None, normals=None, uv=None, materials=None):
    """A Mesh packed in the kiln mesh layout from plain lists (no numpy needed).

    positions: [(x, y, z), ...] or a flat [x, y, z, ...]; indices: three per triangle, counter-clockwise seen from
    the front (flat, or [(a, b, c), ...]); lightmap_uv: one (u, v) per vertex, v = 0 at the top of the lightmap
    (without them the mesh casts shadows but cannot be baked); normals: one per vertex, or None for face normals;
    uv: texture UVs, one per vertex; materials: one index into the job's materials per triangle. Numbers are stored
    as float32 and uint32. ValueError if a length does not match, indices are not whole triangles or the counts
    exceed 2^24. Index values are not checked here: the daemon reports a triangle whose indices are out of range,
    with its mesh, and bakes the rest.
    """
    if not isinstance(name, str) or not name:
        raise ValueError("mesh name: a non-empty string, got %r" % (name,))
    pos = _flat(positions, 3, "mesh %s positions" % name)
    v = len(pos) // 3
    idx = _flat(indices, 3, "mesh %s indices" % name)
    t = len(idx) // 3
    if v > MAX_COUNT or t > MAX_COUNT:
        raise ValueError("mesh %s: %d vertices, %d triangles (at most %d each; split the mesh)" % (name, v, t, MAX_COUNT))
    optional = []
    flags = 0
    for flag, values, width, count, what in ((_FLAG_NORMALS, normals, 3, v, "normals"),
                                             (_FLAG_UV, uv, 2, v, "uv"),
                                             (_FLAG_LIGHTMAP_UV, lightmap_uv, 2, v, "lightmap_uv")):
        if values is None:
            continue
        flat = _flat(values, width, "mesh %s %s" % (name, what))
        if len(flat) // width != count:
            raise ValueError("mesh %s %s: %d entries for %d vertices" % (name, what, len(flat) // width, count))
        flags |= flag
        optional.append(_little_endian("f", flat, "mesh %s %s" % (name, what)))
    mats = None
    if materials is not None:
        mats = list(materials)
        if len(mats) != t:
            raise ValueError("mesh %s materials: %d entries for %d triangles" % (name, len(mats), t))
        flags |= _FLAG_MATERIALS
    uint32 = "I" if array.array("I").itemsize == 4 else "L"
    parts = [MAGIC, _little_endian(uint32, [v, t, flags], "mesh header"),
             _little_endian("f", pos, "mesh %s positions" % name)]
    parts += optional
    parts.append(_little_endian(uint32, idx, "mesh %s indices (each in [0, 2^32))" % name))
    if mats is not None:
        parts.append(_little_endian(uint32, mats, "mesh %s materials (each in [0, 2^32))" % name))
    return Mesh(name, b"".join(parts), v, t)


def _index_of(value, names, what, path):
    """An index given as a number or by name."""
    if isinstance(value, str):
        if value not in names:
            raise ValueError("%s: no %s named %r (%s)" % (path, what, value, ", ".join(names) or "none given"))
        return names.index(value)
    return value


def lightmap_job(meshes, *, instances=None, materials=None, textures=None, lights=None, environment=None,
                 material_overrides=None, lightmaps=None, media=None, name="", samples=None, target_error=None,
                 time_limit_seconds=None, seed=None, force_effects=None, **settings):
    """A kiln.pb.JobSpec for a lightmap bake, from keyword arguments that mirror kiln.proto's LightmapJob.

    meshes: kiln.Mesh objects (from kiln.mesh(); upload each one's .data first), or (name, digest) pairs for mesh
    blobs already on the server. The other arguments are LightmapJob's fields, as dicts of the proto's field names
    (colors as a number, (r, g, b) or a kiln.pb.Color; vectors as (x, y, z); digests as Client.upload_* returns them;
    enums by short name; a Brdf as {"model": "ggx", "alpha": 0.2, ...}):
      instances: [{"mesh": index or mesh name, "transform": 12 numbers (row-major 3x4) or 3 rows of 4,
                   "lightmap": atlas name, "bake": bool, "lightmap_scale_offset": (su, sv, ou, ov), "name",
                   "texel_density": its own, "own_page": bool (the last two with texel_density)}, ...];
                 None: each mesh once, untransformed.
      materials: [{"name", "bsdf": {"diffuse": Brdf, "specular": Brdf, "combine", "specular_weight"},
                   "base_color", "base_color_texture": index or texture name, "emission", "two_sided"}, ...]
      textures: [{"name", "image": digest, "color_space"}, ...]
      lights: [{"name", "color", and one of "point": {"position"}, "spot": {"position", "direction",
                "inner_cone_angle", "outer_cone_angle"}, "directional": {"direction", "angular_diameter"},
                "rect": {"center", "u", "v", "two_sided"}, "disk": {"center", "normal", "radius", "two_sided"}}, ...]
                (point/spot color: intensity in W/sr; directional: irradiance in W/m²; rect/disk: radiance)
      environment: a radiance (number, (r, g, b) or kiln.pb.Color) for a constant sky, an image's digest, or
                   {"constant" or "image", "color_space", "rotation_degrees", "intensity"}
      material_overrides: [{"name", "bsdf", "base_color", "emission"}, ...]
      lightmaps: {lightmap name: resolution} or [{"name", "resolution"}, ...]
      media: participating media, [{"name", "sigma_a", "sigma_s" (colors, per metre; for a VDB per unit density),
              "g" (Henyey-Greenstein asymmetry), "emission", and one of "fog": True (everywhere),
              "box": {"lo", "hi"}, "vdb": {"file": digest of an uploaded .vdb file, "density_grid",
              "emission_grid", "transform": 12 numbers or 3 rows of 4}}, ...] (docs/MEDIA.md)
      resolution, padding, max_bounces, radiance, ao, directional, preview, denoise, stitch_seams, error_metric
      ("lightmap", the default: errors relative to the lightmap's brightness, or "texel": relative to each texel's
      value): as in kiln.proto.
      generate_uvs: "auto" (the default: kilnd generates lightmap UVs for meshes without usable ones: none, outside
      [0, 1], or overlapping), "always" (every mesh) or "never"; each mesh that got them comes back as MESH_uv.bin
      (the kiln mesh layout of kiln.proto, as kiln.mesh() writes it) and in report.json's generated_uvs.
      texel_density (texels per metre), page_size, max_pages, uniform_pages: atlas pages, as in kiln.proto: every
      instance's chart packed into pages page0, page1, ... at that density, each page the smallest square that holds
      its charts unless uniform_pages; the outputs are per page, with lightmaps.json (each page's size, each
      instance's page, scale and offset).
      memory_limit_bytes: the most memory the bake may hold (at most the server's --memory-limit); a bake larger
      than that samples its lightmaps a tile at a time.
    samples, target_error, time_limit_seconds and seed go into the job's quality; force_effects forces planner
    effects on or off by name. None leaves a field to its default. TypeError/ValueError name the field's path
    ("job.lightmap.lights[0].point.position") when something does not fit.
    """
    spec = pb.JobSpec(name=name)
    job = spec.lightmap
    mesh_names = []
    for i, m in enumerate(meshes):
        path = "job.lightmap.meshes[%d]" % i
        out = job.meshes.add()
        if isinstance(m, Mesh):
            out.name, digest = m.name, m.digest
        elif isinstance(m, (tuple, list)) and len(m) == 2 and isinstance(m[0], str):
            out.name, digest = m[0], _as_digest(m[1])
        else:
            raise TypeError("%s: expected a kiln.Mesh or (name, digest), got %r" % (path, m))
        out.geometry.CopyFrom(digest)
        mesh_names.append(out.name)
    if not mesh_names:
        raise ValueError("job.lightmap.meshes: at least one mesh")

    texture_names = [t.get("name", "") if isinstance(t, dict) else "" for t in (textures or [])]
    for i, t in enumerate(textures or []):
        _fill(job.textures.add(), t, "job.lightmap.textures[%d]" % i)
    for i, m in enumerate(materials or []):
        path = "job.lightmap.materials[%d]" % i
        m = dict(m)
        if "base_color_texture" in m:
            m["base_color_texture"] = _index_of(m["base_color_texture"], texture_names, "texture",
                                                path + ".base_color_texture")
        _fill(job.materials.add(), m, path)
    for i, inst in enumerate(instances or []):
        path = "job.lightmap.instances[%d]" % i
        inst = dict(inst)
        if "mesh" in inst:
            inst["mesh"] = _index_of(inst["mesh"], mesh_names, "mesh", path + ".mesh")
        transform = inst.get("transform")
        if transform is not None and len(transform) == 3 and all(isinstance(r, (tuple, list)) for r in transform):
            inst["transform"] = [x for row in transform for x in row]  # 3 rows of 4
        _fill(job.instances.add(), inst, path)
    for i, light in enumerate(lights or []):
        _fill(job.lights.add(), light, "job.lightmap.lights[%d]" % i)
    for i, o in enumerate(material_overrides or []):
        _fill(job.material_overrides.add(), o, "job.lightmap.material_overrides[%d]" % i)
    for i, m in enumerate(media or []):
        m = dict(m)
        vdb = m.get("vdb")
        if isinstance(vdb, dict):
            vdb = dict(vdb)
            transform = vdb.get("transform")
            if transform is not None and len(transform) == 3 and all(isinstance(r, (tuple, list)) for r in transform):
                vdb["transform"] = [x for row in transform for x in row]  # 3 rows of 4
            m["vdb"] = vdb
        _fill(job.media.add(), m, "job.lightmap.media[%d]" % i)
    if isinstance(lightmaps, dict):
        lightmaps = [{"name": k, "resolution": v} for k, v in lightmaps.items()]
    for i, s in enumerate(lightmaps or []):
        _fill(job.lightmaps.add(), s, "job.lightmap.lightmaps[%d]" % i)
    if environment is not None:
        env = job.environment
        if isinstance(environment, dict):
            _fill(env, environment, "job.lightmap.environment")
        elif isinstance(environment, (pb.Digest, pb.Output)):
            env.image.CopyFrom(_as_digest(environment))
        else:
            _set_color(env.constant, environment, "job.lightmap.environment.constant")
    _fill(job, settings, "job.lightmap")
    _set_quality_and_effects(spec, {"samples": samples, "target_error": target_error,
                                    "time_limit_seconds": time_limit_seconds, "seed": seed}, force_effects)
    return spec


def probes_job(meshes, *, spacing, max_distance=None, max_probes=None, regions=None, preview=None, **scene):
    """A kiln.pb.JobSpec for a light probe bake (a ProbesJob, docs/PROBES.md).

    meshes and the other keywords describe the scene exactly as lightmap_job's do (instances, materials, textures,
    lights, environment, material_overrides, media, max_bounces, error_metric, samples, target_error,
    time_limit_seconds, seed, force_effects, name; errors name their path under "job.lightmap"); the scene's
    lightmap settings are not read. The probes: spacing (scene units between neighbouring probes, required),
    max_distance (from the nearest triangle; default 2 x spacing), max_probes, preview, and regions: boxes to fill,
    each (lo, hi) with lo and hi as (x, y, z) or {"lo": ..., "hi": ...}; None: the scene's bounds grown by
    max_distance. A lightmap job bakes probes too with lightmap_job(..., probes={"spacing": 0.5, ...}).
    """
    spec = lightmap_job(meshes, **scene)
    boxes = []
    for i, r in enumerate(regions or []):
        if isinstance(r, dict):
            boxes.append(r)
        elif isinstance(r, (tuple, list)) and len(r) == 2:
            boxes.append({"lo": r[0], "hi": r[1]})
        else:
            raise TypeError("job.probes.volume.regions[%d]: expected (lo, hi) or {\"lo\", \"hi\"}, got %r" % (i, r))
    volume = {"spacing": spacing, "max_distance": max_distance, "max_probes": max_probes, "preview": preview,
              "regions": boxes or None}
    job = pb.ProbesJob()
    job.scene.CopyFrom(spec.lightmap)
    _fill(job.volume, volume, "job.probes.volume")
    spec.probes.CopyFrom(job)  # the oneof: the lightmap job is cleared
    return spec
