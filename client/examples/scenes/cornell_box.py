#!/usr/bin/python3
"""Writes the bundled Cornell-box-like scene as glTF 2.0 (one self-contained .gltf file, buffer embedded).

The box is 2 m on a side: x in [-1, 1], y (up) in [0, 2], z in [-1, 1], open towards +z. White floor, ceiling and
back wall, a red left wall, a green right wall, a short and a tall block, and a square emissive patch under the
ceiling (its material emits; glTF's emissiveFactor is at most 1, so KHR_materials_emissive_strength scales it).
Every mesh has TEXCOORD_0 (per-face 0..1, for textures) and TEXCOORD_1 (lightmap UVs: each planar face a chart of the
mesh's own atlas, charts separated by a margin so that dilation by a few texels at 64^2 and above cannot bleed one
chart into another). Reflectances are those of the classic scene, rounded.

With --atlas the same box is one lightmap atlas: one glTF mesh, `cornell_box`, with a primitive per material, whose
TEXCOORD_1 together hold every planar face of the box as a chart, all at the same texel density, ATLAS_MARGIN apart
(4 texels at 256^2). kiln names a lightmap after its mesh (the primitives of one mesh share it), so the whole box bakes
into one lightmap, `cornell_box`, as it does in a baker with one atlas per object (Cycles, with the meshes joined).

Usage: cornell_box.py [--atlas] OUTPUT.gltf
"""
import base64
import json
import math
import struct
import sys

MARGIN = 1.0 / 16  # of the atlas, around and between charts: 4 texels at 64^2, 32 at 512^2
ATLAS_MARGIN = 1.0 / 64  # the single atlas's: 4 texels at 256^2, so that no texel a chart covers touches another


def quad(p0, p1, p2, p3):
    """A planar face p0 p1 p2 p3, counter-clockwise seen from its front."""
    return [p0, p1, p2, p3]


def rotate_y(p, degrees, centre):
    a = math.radians(degrees)
    x, y, z = p[0] - centre[0], p[1], p[2] - centre[2]
    return (centre[0] + math.cos(a) * x + math.sin(a) * z, y, centre[2] - math.sin(a) * x + math.cos(a) * z)


def block(cx, cz, sx, sy, sz, degrees):
    """Five faces (no bottom) of a box standing on the floor, rotated about its vertical axis."""
    x0, x1, z0, z1 = cx - sx / 2, cx + sx / 2, cz - sz / 2, cz + sz / 2
    faces = [
        quad((x0, sy, z1), (x1, sy, z1), (x1, sy, z0), (x0, sy, z0)),  # top, facing +y
        quad((x0, 0, z1), (x1, 0, z1), (x1, sy, z1), (x0, sy, z1)),    # front, +z
        quad((x1, 0, z0), (x0, 0, z0), (x0, sy, z0), (x1, sy, z0)),    # back, -z
        quad((x0, 0, z0), (x0, 0, z1), (x0, sy, z1), (x0, sy, z0)),    # left, -x
        quad((x1, 0, z1), (x1, 0, z0), (x1, sy, z0), (x1, sy, z1)),    # right, +x
    ]
    return [[rotate_y(p, degrees, (cx, 0, cz)) for p in f] for f in faces]


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(v):
    n = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return (v[0] / n, v[1] / n, v[2] / n)


def dist(a, b):
    d = sub(a, b)
    return math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)


def atlas(faces):
    """Lightmap UV rectangles for the faces: a grid of cells, each face scaled uniformly (texel density equal across
    the faces of one mesh) and centred in its cell, MARGIN between cells and at the border."""
    n = len(faces)
    cols = math.ceil(math.sqrt(n))
    rows = math.ceil(n / cols)
    cell_w = (1 - MARGIN * (cols + 1)) / cols
    cell_h = (1 - MARGIN * (rows + 1)) / rows
    sizes = [(dist(f[0], f[1]), dist(f[1], f[2])) for f in faces]  # (width, height) in metres
    scale = min(min(cell_w / w, cell_h / h) for w, h in sizes)
    rects = []
    for i, (w, h) in enumerate(sizes):
        c, r = i % cols, i // cols
        u0 = MARGIN + c * (cell_w + MARGIN) + (cell_w - w * scale) / 2
        v0 = MARGIN + r * (cell_h + MARGIN) + (cell_h - h * scale) / 2
        rects.append((u0, v0, u0 + w * scale, v0 + h * scale))
    return rects


def shelf_pack(sizes, scale):
    """Rectangles of sizes (metres) times scale packed in shelves (tallest first) into the unit square, ATLAS_MARGIN
    around and between them; None if they do not fit."""
    order = sorted(range(len(sizes)), key=lambda i: -sizes[i][1])
    rects = [None] * len(sizes)
    u, v, shelf = ATLAS_MARGIN, ATLAS_MARGIN, 0.0
    for i in order:
        w, h = sizes[i][0] * scale, sizes[i][1] * scale
        if u + w + ATLAS_MARGIN > 1:  # the next shelf
            u, v, shelf = ATLAS_MARGIN, v + shelf + ATLAS_MARGIN, 0.0
        if u + w + ATLAS_MARGIN > 1 or v + h + ATLAS_MARGIN > 1:
            return None
        rects[i] = (u, v, u + w, v + h)
        u, shelf = u + w + ATLAS_MARGIN, max(shelf, h)
    return rects


def single_atlas(faces):
    """Lightmap UV rectangles for the faces of the whole scene in one atlas: one scale (texel density) for all, the
    largest at which they pack (bisection over the scale)."""
    sizes = [(dist(f[0], f[1]), dist(f[1], f[2])) for f in faces]
    low, high = 0.0, 1.0 / max(max(w, h) for w, h in sizes)
    for _ in range(50):
        mid = (low + high) / 2
        low, high = (mid, high) if shelf_pack(sizes, mid) else (low, mid)
    return shelf_pack(sizes, low)


def mesh_arrays(faces, rects=None):
    positions, normals, uv0, uv1, indices = [], [], [], [], []
    for face, (u0, v0, u1, v1) in zip(faces, rects or atlas(faces)):
        n = normalize(cross(sub(face[1], face[0]), sub(face[2], face[0])))
        base = len(positions)
        corners = [(0, 1), (1, 1), (1, 0), (0, 0)]  # glTF UVs: v = 0 at the top of the image
        for p, (s, t) in zip(face, corners):
            positions.append(p)
            normals.append(n)
            uv0.append((s, t))
            uv1.append((u0 + s * (u1 - u0), v0 + t * (v1 - v0)))
        indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    return positions, normals, uv0, uv1, indices


def primitives_in_one_atlas(meshes):
    """The meshes' faces grouped by material (in order of first use), each face with its rectangle in one atlas."""
    by_material = {}
    for material, faces in meshes.values():
        by_material.setdefault(material, []).extend(faces)
    rects = iter(single_atlas([f for faces in by_material.values() for f in faces]))
    return [(material, faces, [next(rects) for _ in faces]) for material, faces in by_material.items()]


def build(one_atlas=False):
    meshes = {
        "floor": ("white", [quad((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))]),
        "ceiling": ("white", [quad((-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1))]),
        "back_wall": ("white", [quad((-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1))]),
        "left_wall": ("red", [quad((-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1))]),
        "right_wall": ("green", [quad((1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1))]),
        "short_block": ("white", block(0.33, 0.37, 0.6, 0.6, 0.6, -17)),
        "tall_block": ("white", block(-0.33, -0.3, 0.6, 1.2, 0.6, 18)),
        # Just below the ceiling so that it does not coincide with it; faces down.
        "light": ("light", [quad((-0.25, 1.99, -0.25), (0.25, 1.99, -0.25), (0.25, 1.99, 0.25), (-0.25, 1.99, 0.25))]),
    }
    materials = [
        {"name": "white", "pbrMetallicRoughness": {"baseColorFactor": [0.73, 0.73, 0.73, 1], "metallicFactor": 0,
                                                    "roughnessFactor": 1}},
        {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.63, 0.065, 0.05, 1], "metallicFactor": 0,
                                                  "roughnessFactor": 1}},
        {"name": "green", "pbrMetallicRoughness": {"baseColorFactor": [0.14, 0.45, 0.091, 1], "metallicFactor": 0,
                                                    "roughnessFactor": 1}},
        {"name": "light", "pbrMetallicRoughness": {"baseColorFactor": [0.78, 0.78, 0.78, 1], "metallicFactor": 0,
                                                    "roughnessFactor": 1},
         "emissiveFactor": [1.0, 0.71, 0.24],
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 17.0}}},
    ]
    material_index = {m["name"]: i for i, m in enumerate(materials)}

    blob = bytearray()
    buffer_views, accessors, gltf_meshes, nodes = [], [], [], []

    def add(data, fmt, count, kind, component, target, minmax=False):
        while len(blob) % 4:
            blob.append(0)
        offset = len(blob)
        for item in data:
            blob.extend(struct.pack(fmt, *(item if isinstance(item, tuple) else (item,))))
        buffer_views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob) - offset, "target": target})
        acc = {"bufferView": len(buffer_views) - 1, "componentType": component, "count": count, "type": kind}
        if minmax:
            acc["min"] = [min(p[k] for p in data) for k in range(3)]
            acc["max"] = [max(p[k] for p in data) for k in range(3)]
        accessors.append(acc)
        return len(accessors) - 1

    def primitive(material, faces, rects=None):
        positions, normals, uv0, uv1, indices = mesh_arrays(faces, rects)
        n = len(positions)
        attributes = {
            "POSITION": add(positions, "<3f", n, "VEC3", 5126, 34962, minmax=True),
            "NORMAL": add(normals, "<3f", n, "VEC3", 5126, 34962),
            "TEXCOORD_0": add(uv0, "<2f", n, "VEC2", 5126, 34962),
            "TEXCOORD_1": add(uv1, "<2f", n, "VEC2", 5126, 34962),
        }
        idx = add(indices, "<I", len(indices), "SCALAR", 5125, 34963)
        return {"attributes": attributes, "indices": idx, "material": material_index[material]}

    if one_atlas:
        placed = [("cornell_box", [primitive(material, faces, rects)
                                   for material, faces, rects in primitives_in_one_atlas(meshes)])]
    else:
        placed = [(name, [primitive(material, faces)]) for name, (material, faces) in meshes.items()]
    for name, primitives in placed:
        gltf_meshes.append({"name": name, "primitives": primitives})
        nodes.append({"name": name, "mesh": len(gltf_meshes) - 1})

    return {
        "asset": {"version": "2.0", "generator": "kiln client/examples/scenes/cornell_box.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "cornell_box", "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": gltf_meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": buffer_views,
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
    }


def main():
    args = sys.argv[1:]
    one_atlas = "--atlas" in args
    args = [a for a in args if a != "--atlas"]
    if len(args) != 1 or args[0].startswith("-"):
        sys.stderr.write(__doc__)
        return 2
    with open(args[0], "w") as f:
        json.dump(build(one_atlas), f, indent=1)
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
