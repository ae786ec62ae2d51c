#!/usr/bin/env python3
"""The figure of docs/gltf-materials.md: a row of glTF spheres from rough to smooth, as the glTF
specification's BRDF shows them and as raylab renders them through its PBR → Phong mapping.

    python3 scripts/gltf-materials-figure.py --raylab target/release/raylab [--before OLD_RAYLAB] -o docs/gltf-materials.png
    python3 scripts/gltf-materials-figure.py --raylab target/release/raylab --path -o docs/pbr-vs-spec.png

Writes a glTF file with two rows of six UV spheres (roughness 0, 0.2, …, 1; a red dielectric and
a gold metal), a scene placing it under one directional light, renders it with each raylab binary
given, and evaluates the reference per pixel: the glTF 2.0 BRDF of the specification's Appendix B
(Lambert diffuse, GGX distribution, height-correlated Smith visibility, Schlick Fresnel, mixed by
metallic) for the same camera and light, lit with irradiance π·I so that its diffuse term equals
raylab's `kd·(n·l)·I`. No ambient and no environment: only the light's direct reflection, which is
what the mapping decides. Needs numpy and Pillow.

With --path, the figure is the reference beside raylab's path tracer on the same glTF file (the
`pbr` model: the specification's BRDF itself, lit by the same light; 256 samples per pixel), both
on a black background that lights nothing: the difference left is the path tracer's light from
the neighbouring spheres (and its noise).
"""
import argparse
import json
import math
import os
import struct
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image, ImageDraw

ROUGHNESS = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
MATERIALS = [("red dielectric", (0.8, 0.12, 0.06), 0.0), ("gold metal", (1.0, 0.78, 0.34), 1.0)]
SPACING, RADIUS = 2.2, 1.0
WIDTH, HEIGHT = 720, 260
CAMERA = dict(position=(0.0, 0.0, 14.0), look_at=(0.0, 0.0, 0.0), fov=22.0)
LIGHT_DIR = np.array([-0.5, -0.6, -1.0]) / np.linalg.norm([-0.5, -0.6, -1.0])  # the direction light travels
LIGHT = 1.0
BACKGROUND = 0.12


def centres():
    out = []
    for row in range(len(MATERIALS)):
        for col in range(len(ROUGHNESS)):
            out.append(((col - (len(ROUGHNESS) - 1) / 2) * SPACING, (0.5 - row) * SPACING * 1.05, 0.0))
    return out


def write_gltf(path):
    """Twelve UV spheres (one mesh each, its own material), smooth normals."""
    nu, nv = 64, 32
    pos, nrm, idx = [], [], []
    for j in range(nv + 1):
        th = math.pi * j / nv
        for i in range(nu + 1):
            ph = 2 * math.pi * i / nu
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            nrm.append(n)
            pos.append(tuple(RADIUS * c for c in n))
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, j * (nu + 1) + i + 1
            c, d = a + nu + 1, b + nu + 1
            idx += [a, b, c, b, d, c]
    pos_b = b"".join(struct.pack("<3f", *p) for p in pos)
    nrm_b = b"".join(struct.pack("<3f", *n) for n in nrm)
    idx_b = b"".join(struct.pack("<I", i) for i in idx)
    buf = pos_b + nrm_b + idx_b
    open(path.replace(".gltf", ".bin"), "wb").write(buf)
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    materials, meshes, nodes = [], [], []
    for row, (_, base, metallic) in enumerate(MATERIALS):
        for col, r in enumerate(ROUGHNESS):
            k = len(materials)
            materials.append({"pbrMetallicRoughness": {"baseColorFactor": [*base, 1.0], "metallicFactor": metallic, "roughnessFactor": r}})
            meshes.append({"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": k}]})
            nodes.append({"mesh": k, "translation": list(centres()[k])})
    doc = {
        "asset": {"version": "2.0", "generator": "raylab scripts/gltf-materials-figure.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "buffers": [{"byteLength": len(buf), "uri": os.path.basename(path.replace(".gltf", ".bin"))}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos_b)},
            {"buffer": 0, "byteOffset": len(pos_b), "byteLength": len(nrm_b)},
            {"buffer": 0, "byteOffset": len(pos_b) + len(nrm_b), "byteLength": len(idx_b)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5126, "count": len(nrm), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
    }
    json.dump(doc, open(path, "w"))


def write_scene(path, background):
    p, l = CAMERA["position"], CAMERA["look_at"]
    open(path, "w").write(
        f"""background = {background}
[render]
width = {WIDTH}
height = {HEIGHT}
spp = 4
[camera]
position = [{p[0]}, {p[1]}, {p[2]}]
look_at = [{l[0]}, {l[1]}, {l[2]}]
fov = {CAMERA['fov']}
[[object]]
type = "mesh"
file = "spheres.gltf"
normals = "smooth"
[[light]]
type = "directional"
direction = [{LIGHT_DIR[0]}, {LIGHT_DIR[1]}, {LIGHT_DIR[2]}]
color = {LIGHT}
"""
    )


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def reference(background):
    """The glTF BRDF per pixel (2 × 2 samples), sRGB-encoded, as an H × W × 3 array in [0, 1]."""
    pos, at = np.array(CAMERA["position"]), np.array(CAMERA["look_at"])
    fwd = (at - pos) / np.linalg.norm(at - pos)
    right = np.cross(fwd, [0, 1, 0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    h = math.tan(math.radians(CAMERA["fov"]) / 2)
    acc = np.zeros((HEIGHT, WIDTH, 3))
    for sy, sx in [(0.25, 0.25), (0.25, 0.75), (0.75, 0.25), (0.75, 0.75)]:
        ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH]
        u = (2 * (xs + sx) / WIDTH - 1) * h * WIDTH / HEIGHT
        v = (1 - 2 * (ys + sy) / HEIGHT) * h
        d = fwd + u[..., None] * right + v[..., None] * up
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        colour = np.full((HEIGHT, WIDTH, 3), background)
        best = np.full((HEIGHT, WIDTH), np.inf)
        for k, c in enumerate(centres()):
            f = pos - np.array(c)
            b = (d * f).sum(-1)
            disc = b * b - (f * f).sum() + RADIUS * RADIUS
            t = -b - np.sqrt(np.maximum(disc, 0))
            hit = (disc > 0) & (t > 0) & (t < best)
            if not hit.any():
                continue
            best = np.where(hit, t, best)
            n = (pos + t[..., None] * d - np.array(c)) / RADIUS
            _, base, metallic = MATERIALS[k // len(ROUGHNESS)]
            colour[hit] = gltf_brdf(n[hit], -d[hit], np.array(base), metallic, ROUGHNESS[k % len(ROUGHNESS)])
        acc += colour
    return srgb(acc / 4)


def gltf_brdf(n, v, base, metallic, roughness):
    """Radiance under the light: the specification's BRDF × irradiance π·I × (n·l)."""
    l = -LIGHT_DIR
    nl = np.clip((n * l).sum(-1), 0, 1)
    nv = np.clip((n * v).sum(-1), 1e-4, 1)
    hv = l + v
    hv /= np.linalg.norm(hv, axis=-1, keepdims=True)
    nh = np.clip((n * hv).sum(-1), 0, 1)
    vh = np.clip((v * hv).sum(-1), 0, 1)
    a2 = max(roughness**2, 1e-3) ** 2
    dist = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2)
    vis_den = nl * np.sqrt(nv * nv * (1 - a2) + a2) + nv * np.sqrt(nl * nl * (1 - a2) + a2)
    vis = np.where(vis_den > 0, 0.5 / np.maximum(vis_den, 1e-12), 0)
    spec = (vis * dist)[..., None]
    schlick = ((1 - vh) ** 5)[..., None]
    f_dielectric = 0.04 + 0.96 * schlick
    dielectric = (1 - f_dielectric) * base / math.pi + f_dielectric * spec
    f_metal = base + (1 - base) * schlick
    metal = f_metal * spec
    brdf = (1 - metallic) * dielectric + metallic * metal
    return brdf * (math.pi * LIGHT) * nl[..., None]


def render(raylab, scene, *extra):
    out = scene.replace(".toml", f"-{abs(hash((raylab, extra)))}.png")
    subprocess.run([raylab, "render", scene, "-o", out, "--threads", "2", *extra], check=True, capture_output=True)
    return np.asarray(Image.open(out).convert("RGB"), dtype=np.float64) / 255


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--raylab", required=True, help="the raylab binary (built with --features mesh)")
    ap.add_argument("--before", help="an older raylab binary, for a row with its mapping")
    ap.add_argument("--path", action="store_true", help="the reference beside the path tracer (the pbr model), on black")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        write_gltf(os.path.join(tmp, "spheres.gltf"))
        scene = os.path.join(tmp, "scene.toml")
        background = 0.0 if a.path else BACKGROUND
        write_scene(scene, background)
        images = [("glTF BRDF", reference(background))]
        if a.path:
            images.append(("raylab path", render(a.raylab, scene, "--integrator", "path", "--spp", "256")))
        else:
            if a.before:
                images.append(("raylab before", render(a.before, scene)))
            images.append(("raylab", render(a.raylab, scene)))
    if a.path:
        # Each sphere's mean (linear) in its cell of the frame, path tracer ÷ reference.
        linear = lambda x: np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
        ref, path = (linear(img) for _, img in images)
        scale = WIDTH / (2 * math.tan(math.radians(CAMERA["fov"]) / 2) * CAMERA["position"][2] * WIDTH / HEIGHT)
        for row, (name, _, _) in enumerate(MATERIALS):
            ratios = []
            for col in range(len(ROUGHNESS)):
                x = WIDTH / 2 + (col - (len(ROUGHNESS) - 1) / 2) * SPACING * scale
                cell = (slice(row * HEIGHT // 2, (row + 1) * HEIGHT // 2), slice(int(x - SPACING * scale / 2), int(x + SPACING * scale / 2)))
                ratios.append(path[cell].mean() / ref[cell].mean())
            print(f"{name}: path ÷ reference per sphere, roughness {ROUGHNESS[0]} to {ROUGHNESS[-1]}: " + ", ".join(f"{r:.3f}" for r in ratios))
    # Each material's row of spheres from each image, one under the other, labelled.
    half = HEIGHT // 2
    label_w, pad = 150, 4
    rows = [(f"{name}\n{label}", img[r * half:(r + 1) * half]) for r, (name, _, _) in enumerate(MATERIALS) for label, img in images]
    sheet = Image.new("RGB", (label_w + WIDTH, len(rows) * (half + pad) + 24), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    for i, r in enumerate(ROUGHNESS):
        x = label_w + WIDTH / 2 + (i - (len(ROUGHNESS) - 1) / 2) * SPACING * WIDTH / (2 * math.tan(math.radians(CAMERA["fov"]) / 2) * CAMERA["position"][2] * WIDTH / HEIGHT)
        draw.text((x - 30, 6), f"roughness {r:.1f}", fill=(0, 0, 0))
    for k, (label, img) in enumerate(rows):
        y = 24 + k * (half + pad)
        sheet.paste(Image.fromarray((img * 255 + 0.5).astype(np.uint8)), (label_w, y))
        draw.multiline_text((6, y + half // 2 - 12), label, fill=(0, 0, 0))
    sheet.save(a.output, optimize=True)
    print(f"wrote {a.output}", file=sys.stderr)


if __name__ == "__main__":
    main()
