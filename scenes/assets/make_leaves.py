#!/usr/bin/env python3
"""Writes the cut-out test asset of raylab's bundled scenes (CC0; needs Pillow).
Run: python3 make_leaves.py

- leaves.png: a 256 x 256 RGBA texture of leaves: green leaf blades (opaque) on a fully
  transparent background (alpha 0), each blade with a lighter midrib.
- leaves.obj, leaves.mtl: a unit quad in the xy plane (corners (-1, -1) to (1, 1), facing +z)
  with `vt` over [0, 1]^2, and a material with `map_Kd leaves.png` and `map_d leaves.png`
  (the alpha channel cuts the quad away between the leaves).
- leaves.gltf: the same quad as glTF 2.0 (buffer as a data URI), material
  alphaMode = MASK, alphaCutoff = 0.5, baseColorTexture leaves.png.
"""
import base64
import json
import math
import struct

from PIL import Image, ImageDraw

N = 256
SS = 4  # supersampled, then reduced: smooth leaf edges in the alpha
big = Image.new("RGBA", (N * SS, N * SS), (0, 0, 0, 0))
d = ImageDraw.Draw(big)


def leaf(cx, cy, length, width, angle, colour):
    """A leaf blade: a pointed ellipse along `angle` (degrees), centred at (cx, cy), in texels."""
    a = math.radians(angle)
    ux, uy = math.cos(a), math.sin(a)
    vx, vy = -uy, ux
    pts = []
    for k in range(41):
        t = -1 + 2 * k / 40
        w = width * (1 - t * t) ** 0.8
        pts.append((cx + ux * t * length, cy + uy * t * length, w))
    outline = [(x + vx * w, y + vy * w) for x, y, w in pts] + [(x - vx * w, y - vy * w) for x, y, w in reversed(pts)]
    d.polygon([(x * SS, y * SS) for x, y in outline], fill=colour + (255,))
    light = tuple(min(255, c + 60) for c in colour)
    d.line([((cx - ux * length) * SS, (cy - uy * length) * SS), ((cx + ux * length) * SS, (cy + uy * length) * SS)], fill=light + (255,), width=SS * 2)


LEAVES = [
    (64, 60, 52, 18, 35, (60, 130, 40)),
    (180, 70, 56, 20, -30, (80, 150, 45)),
    (120, 140, 60, 22, 80, (50, 115, 35)),
    (60, 200, 50, 17, -50, (90, 160, 50)),
    (196, 196, 54, 19, 20, (70, 140, 40)),
]
for args in LEAVES:
    leaf(*args)
img = big.resize((N, N), Image.LANCZOS)
img.save("leaves.png", optimize=True)

with open("leaves.mtl", "w") as f:
    f.write("# A leaf cut-out: the alpha of leaves.png cuts the quad away between the leaves.\n")
    f.write("newmtl leaves\nKd 1 1 1\nKs 0 0 0\nmap_Kd leaves.png\nmap_d leaves.png\n")
with open("leaves.obj", "w") as f:
    f.write("# A unit quad facing +z with texture coordinates; material: leaves.mtl (a cut-out).\n")
    f.write("mtllib leaves.mtl\n")
    for x, y in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
        f.write(f"v {x} {y} 0\n")
    for u, v in [(0, 0), (1, 0), (1, 1), (0, 1)]:
        f.write(f"vt {u} {v}\n")
    f.write("vn 0 0 1\nusemtl leaves\nf 1/1/1 2/2/1 3/3/1 4/4/1\n")

# leaves.gltf: positions, normals, texcoords (v down in glTF), indices.
pos = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
uv = [(0, 1), (1, 1), (1, 0), (0, 0)]
idx = [0, 1, 2, 0, 2, 3]
blob = b"".join(struct.pack("<3f", *p) for p in pos)
blob += b"".join(struct.pack("<3f", 0, 0, 1) for _ in pos)
blob += b"".join(struct.pack("<2f", *t) for t in uv)
blob += struct.pack("<6H", *idx)
doc = {
    "asset": {"version": "2.0", "generator": "raylab make_leaves.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
    "materials": [{
        "name": "leaves",
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 0.6},
        "alphaMode": "MASK",
        "alphaCutoff": 0.5,
        "doubleSided": True,
    }],
    "textures": [{"source": 0}],
    "images": [{"uri": "leaves.png"}],
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 48},
        {"buffer": 0, "byteOffset": 48, "byteLength": 48},
        {"buffer": 0, "byteOffset": 96, "byteLength": 32},
        {"buffer": 0, "byteOffset": 128, "byteLength": 12},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ],
}
with open("leaves.gltf", "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
