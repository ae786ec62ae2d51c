#!/usr/bin/env python3
"""Writes the normal- and bump-mapped test assets of raylab's bundled scenes (CC0; needs Pillow
and NumPy). Run: python3 make_tiles.py

The surface: a 4 x 4 grid of tiles over texture coordinates [0, 1]^2, each a flat top with
bevelled edges (grooves between tiles) and a round boss in its middle.

- tiles-height.png: the height field, 8-bit grey (1 = a tile's top; 0 = the bottom of a groove).
- tiles-normal.png: its tangent-space normal map (glTF / OpenGL convention: red along +u, green
  along +v, i.e. up the image, blue out of the surface; 0.5 is zero), of the heights times
  RELIEF (in units of the texture's width: a tile of relief 0.03 on a face one unit wide).
- tiles.gltf: a UV sphere of radius 1 (48 x 24 quads; TEXCOORD_0 tiling the map 4 x 2 times
  around it) with NORMALs but no TANGENTs (a renderer makes MikkTSpace tangents), material
  normalTexture tiles-normal.png with scale 1, a light grey dielectric.
- tiles.obj, tiles.mtl: a quad 2 x 2 in the xz plane (facing +y) with `vt` over [0, 1]^2, its
  material with `bump -bm 0.03 tiles-height.png` (heights of 0.03 scene units).
"""
import base64
import json
import math
import struct

import numpy as np
from PIL import Image

N = 512
TILES = 4
RELIEF = 0.03  # height of a tile top over a groove, in texture widths (normal map)


def height(u, v):
    """The height field in [0, 1] at texture coordinates (u, v) (arrays)."""
    fu, fv = (u * TILES) % 1.0, (v * TILES) % 1.0
    edge = np.minimum(np.minimum(fu, 1 - fu), np.minimum(fv, 1 - fv))
    t = np.clip((edge - 0.02) / 0.1, 0, 1)
    bevel = t * t * (3 - 2 * t)
    r2 = ((fu - 0.5) ** 2 + (fv - 0.5) ** 2) / 0.22**2
    boss = np.sqrt(np.clip(1 - r2, 0, 1))
    return bevel * (0.6 + 0.4 * boss)

# Texel centres: column c at u = (c + 0.5)/N, row r at v = 1 - (r + 0.5)/N (v up, row 0 on top).
c = (np.arange(N) + 0.5) / N
u, v = np.meshgrid(c, 1 - c)
h = height(u, v)
Image.fromarray(np.round(h * 255).astype(np.uint8), "L").save("tiles-height.png", optimize=True)

e = 0.25 / N
dhdu = (height(u + e, v) - height(u - e, v)) / (2 * e) * RELIEF
dhdv = (height(u, v + e) - height(u, v - e)) / (2 * e) * RELIEF
n = np.stack([-dhdu, -dhdv, np.ones_like(h)], axis=-1)
n /= np.linalg.norm(n, axis=-1, keepdims=True)
rgb = np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)
Image.fromarray(rgb, "RGB").save("tiles-normal.png", optimize=True)

with open("tiles.mtl", "w") as f:
    f.write("# Tiles: a bump map of bevelled tiles with round bosses (heights 0.03 scene units).\n")
    f.write("newmtl tiles\nKd 0.75 0.7 0.62\nKs 0.25 0.25 0.25\nNs 40\nbump -bm 0.03 tiles-height.png\n")
with open("tiles.obj", "w") as f:
    f.write("# A 2 x 2 quad in the xz plane facing +y, texture coordinates over [0, 1]^2; material: tiles.mtl.\n")
    f.write("mtllib tiles.mtl\n")
    for x, z in [(-1, 1), (1, 1), (1, -1), (-1, -1)]:
        f.write(f"v {x} 0 {z}\n")
    for a, b in [(0, 0), (1, 0), (1, 1), (0, 1)]:
        f.write(f"vt {a} {b}\n")
    f.write("vn 0 1 0\nusemtl tiles\nf 1/1/1 2/2/1 3/3/1 4/4/1\n")

# tiles.gltf: a UV sphere (longitude around +y, seam at the back), uv in glTF's v-down convention.
SEG, RINGS = 48, 24
pos, nor, tex = [], [], []
for i in range(RINGS + 1):
    lat = -math.pi / 2 + math.pi * i / RINGS
    for j in range(SEG + 1):
        lon = 2 * math.pi * j / SEG
        p = (math.cos(lat) * math.sin(lon), math.sin(lat), math.cos(lat) * math.cos(lon))
        pos.append(p)
        nor.append(p)
        tex.append((2 * j / SEG, 1 - i / RINGS))  # 2 x 1 around: square-ish tiles; glTF v down
idx = []
for i in range(RINGS):
    for j in range(SEG):
        a, b = i * (SEG + 1) + j, i * (SEG + 1) + j + 1
        c_, d = a + SEG + 1, b + SEG + 1
        if i > 0:
            idx += [a, b, d]
        if i < RINGS - 1:
            idx += [a, d, c_]
blob = b"".join(struct.pack("<3f", *p) for p in pos)
blob += b"".join(struct.pack("<3f", *p) for p in nor)
blob += b"".join(struct.pack("<2f", *t) for t in tex)
blob += b"".join(struct.pack("<I", k) for k in idx)
nv = len(pos)
doc = {
    "asset": {"version": "2.0", "generator": "raylab make_tiles.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
    "materials": [{
        "name": "tiles",
        "pbrMetallicRoughness": {"baseColorFactor": [0.75, 0.7, 0.62, 1], "metallicFactor": 0, "roughnessFactor": 0.35},
        "normalTexture": {"index": 0, "scale": 1},
    }],
    "textures": [{"source": 0}],
    "images": [{"uri": "tiles-normal.png"}],
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": 12 * nv},
        {"buffer": 0, "byteOffset": 12 * nv, "byteLength": 12 * nv},
        {"buffer": 0, "byteOffset": 24 * nv, "byteLength": 8 * nv},
        {"buffer": 0, "byteOffset": 32 * nv, "byteLength": 4 * len(idx)},
    ],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]},
        {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": nv, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
    ],
}
with open("tiles.gltf", "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
