#!/usr/bin/env python3
"""Writes pyramids.gltf (buffer as a data: URI) and pyramids.glb (binary), raylab's own small
glTF test scene: one closed pyramid mesh used by two nodes (one a child of a transformed parent),
a perspective camera, a KHR_lights_punctual point light and a smooth gold material.
Public domain (CC0), written for raylab's tests. Run: python3 make_gltf.py"""
import base64, json, struct

# Pyramid: square base (y = 0, side 2) and apex (0, 1.5, 0); counter-clockwise seen from outside.
pos = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1), (0, 1.5, 0)]
idx = [0, 1, 2, 0, 2, 3,  # base, facing -y
       3, 2, 4, 2, 1, 4, 1, 0, 4, 0, 3, 4]
pbytes = b"".join(struct.pack("<3f", *p) for p in pos)
ibytes = b"".join(struct.pack("<H", i) for i in idx)
ibytes += b"\0" * ((-len(ibytes)) % 4)
buf = pbytes + ibytes
doc = {
    "asset": {"version": "2.0", "generator": "raylab tests/assets/make_gltf.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 3, 4]}],
    "nodes": [
        {"name": "left", "mesh": 0, "translation": [-1.5, 0, 0]},
        {"name": "parent", "translation": [1.5, 0, 0], "scale": [1, 2, 1], "children": [2]},
        {"name": "right", "mesh": 0, "rotation": [0, 0.3826834, 0, 0.9238795]},
        {"name": "camera", "camera": 0, "translation": [0, 1.5, 8]},
        {"name": "lamp", "translation": [0, 5, 4], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.1}}],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 30}]}},
    "meshes": [{"name": "pyramid", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
    "materials": [{"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1, 0.78, 0.34, 1], "metallicFactor": 1, "roughnessFactor": 0.1}}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 1.5, 1]},
        {"bufferView": 1, "componentType": 5123, "count": 18, "type": "SCALAR"},
    ],
    "bufferViews": [
        {"buffer": 0, "byteOffset": 0, "byteLength": len(pbytes)},
        {"buffer": 0, "byteOffset": len(pbytes), "byteLength": 36},
    ],
    "buffers": [{"byteLength": len(buf)}],
}
text = dict(doc, buffers=[{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}])
open("pyramids.gltf", "w").write(json.dumps(text, indent=1) + "\n")
js = json.dumps(doc, separators=(",", ":")).encode()
js += b" " * ((-len(js)) % 4)
glb = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(buf))
glb += struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(buf), b"BIN\0") + buf
open("pyramids.glb", "wb").write(glb)
