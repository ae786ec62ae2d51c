#!/usr/bin/env python3
"""raylab's materials beside Mitsuba 3's BSDFs where the models match (issue 28): a sphere on a
diffuse floor under scenes/assets/sky.hdr, the sphere made of

- `diffuse`: raylab's `phong` `kd` and `pbr` with `specular = 0` (its dielectric without a
  specular layer: Lambert alone) against Mitsuba's `twosided` `diffuse`;
- `metal`: `pbr` with `metallic = 1` and a white base colour (Schlick's Fresnel is then exactly 1)
  against Mitsuba's `roughconductor`, GGX, `material = "none"` (Fresnel 1), α = roughness²,
  visible-normal sampling;
- `plastic`: `pbr` dielectric (ior 1.5) against Mitsuba's `roughplastic`, GGX, α = roughness²,
  `int_ior = 1.5`, `nonlinear = false`: the closest Mitsuba has, not the same model (see
  RESULTS.md: the diffuse base is weighed differently).

Each scene is written once and given to both renderers (raylab as TOML, Mitsuba as a dict): the
same camera, environment (Mitsuba's `envmap` turned 180° about +y and given the image's rows
re-spaced, as benches/lights/compare.py does), box pixel filter and bounce limit (Mitsuba's
max_depth = raylab's max_bounces + 2). For each scene it prints the ratio of the image means
(raylab ÷ Mitsuba) over the whole frame and over the sphere's pixels, from `--spp` samples ×
`--seeds` seeds, and the per-block differences against the noise: 8 × 8 blocks, each block's
difference of means over its standard error (from the spread of the seeds' images), as the RMS
of these z-scores (≈ 1 when the images agree within noise) and the count beyond 4.

Setup: benches/peers/setup.sh (a venv with mitsuba and numpy). Build raylab with `cargo build
--release --features mesh,bvh,exr`. From the top of the checkout:

    ~/.cache/raylab-peers-venv/bin/python benches/materials/compare.py [--spp 64] [--seeds 4] [--size 64] [--variant scalar_rgb]
"""
import argparse
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The lights comparison's helpers (its OBJ writer, PFM reader, blocks and environment rows).
_spec = importlib.util.spec_from_file_location("lights_compare", os.path.join(ROOT, "benches", "lights", "compare.py"))
lights = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(lights)
blocks, mitsuba_rows, read_pfm, write_obj = lights.blocks, lights.mitsuba_rows, lights.read_pfm, lights.write_obj

SKY = os.path.join(ROOT, "scenes", "assets", "sky.hdr")
CAMERA = dict(position=(0.0, 1.2, 3.6), look_at=(0.0, 0.75, 0.0), fov=30)
SPHERE = ((0.0, 0.75, 0.0), 0.75)
FLOOR = ([(-4, 0, 4), (4, 0, 4), (4, 0, -4), (-4, 0, -4)], (0.5, 0.5, 0.5))
RED = (0.6, 0.2, 0.1)


def scenes(mi):
    """name → (raylab material TOML, Mitsuba BSDF dict) of the sphere."""
    out = {}
    c = list(RED)
    diffuse = {"type": "twosided", "material": {"type": "diffuse", "reflectance": {"type": "rgb", "value": c}}}
    out["diffuse, phong kd"] = (f"{{ kd = {c}, ks = 0 }}", diffuse)
    out["diffuse, pbr specular 0"] = (f'{{ type = "pbr", base_color = {c}, metallic = 0, roughness = 0.5, specular = 0 }}', diffuse)
    for r in (0.2, 0.5, 0.8):
        out[f"metal, roughness {r}"] = (
            f'{{ type = "pbr", base_color = 1, metallic = 1, roughness = {r} }}',
            {"type": "roughconductor", "distribution": "ggx", "alpha": r * r, "material": "none", "sample_visible": True},
        )
    for r in (0.3, 0.6):
        plastic = lambda diffuse: {
            "type": "roughplastic",
            "distribution": "ggx",
            "alpha": r * r,
            "int_ior": 1.5,
            "ext_ior": 1.0,
            "nonlinear": False,
            "sample_visible": True,
            "diffuse_reflectance": {"type": "rgb", "value": diffuse},
        }
        material = f'{{ type = "pbr", base_color = {c}, metallic = 0, roughness = {r}, ior = 1.5 }}'
        out[f"plastic, roughness {r}"] = (material, plastic(c))
        # Mitsuba's diffuse term is c·t_i·t_o / (π·η²·(1 − F_dr)), F_dr the rough interface's
        # internal reflectance; its factor 1 / (η²·(1 − F_dr)) divided out of the colour leaves
        # the two models' weightings of the base (t_i·t_o against glTF's 1 − F(v·h)).
        k = diffuse_normalisation(mi, plastic([1.0, 1.0, 1.0]), r * r)
        out[f"plastic, roughness {r}, Mitsuba's diffuse normalisation divided out (×{k:.3f})"] = (material, plastic([x * k for x in c]))
    return out


def ggx_reflectance(mu, alpha, eta, n=256):
    """Directional albedo of a rough dielectric interface's reflection (GGX, separable Smith G as
    Mitsuba's, exact Fresnel of relative index `eta`, total internal reflection included) for a
    view at cosine `mu`, by quadrature over the hemisphere."""
    th = (np.arange(n) + 0.5) / n * np.pi / 2
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    wi = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1)
    wo = np.array([math.sqrt(1 - mu * mu), 0.0, mu])
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    a2 = alpha * alpha
    d = a2 / (np.pi * (h[..., 2] ** 2 * (a2 - 1) + 1) ** 2)
    lam = lambda c: (-1 + np.sqrt(1 + a2 * (1 - c * c) / np.maximum(c * c, 1e-12))) / 2
    g = 1 / ((1 + lam(wi[..., 2])) * (1 + lam(mu)))
    c = np.clip((h * wo).sum(-1), 0, 1)
    s2 = (1 - c * c) / eta**2
    ct = np.sqrt(np.maximum(1 - s2, 0))
    f = np.where(s2 >= 1, 1.0, 0.5 * (((eta * c - ct) / (eta * c + ct)) ** 2 + ((c - eta * ct) / (c + eta * ct)) ** 2))
    dw = np.sin(T) * (np.pi / 2 / n) * (np.pi / n)
    return float((f * d * g / (4 * mu) * dw).sum())


def diffuse_normalisation(mi, bsdf, alpha):
    """η²·(1 − F_dr) of a white `roughplastic` as Mitsuba computes it: its diffuse component at
    normal incidence and exitance is t(1)² / (π·η²·(1 − F_dr)), t(1) = 1 − R(1) the rough
    interface's transmittance (by quadrature, `ggx_reflectance`)."""
    b = mi.load_dict(bsdf)
    si = mi.SurfaceInteraction3f()
    si.wi, si.n = mi.Vector3f(0, 0, 1), mi.Normal3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    ctx = mi.BSDFContext()
    ctx.component = 1
    value = float(b.eval(ctx, si, mi.Vector3f(0, 0, 1))[0])
    t = 1 - ggx_reflectance(0.999, alpha, 1.5)
    return t * t / (math.pi * value)


def raylab_scene(material, folder, size, spp, bounces):
    c = CAMERA
    shutil.copy(SKY, os.path.join(folder, "sky.hdr"))
    p = FLOOR[0]
    return (
        f"background = 0\n[render]\nwidth = {size}\nheight = {size}\nspp = {spp}\n\n"
        f"[camera]\nposition = {list(c['position'])}\nlook_at = {list(c['look_at'])}\nfov = {c['fov']}\n\n"
        f'[integrator]\ntype = "path"\nmax_bounces = {bounces}\n\n'
        f'[[object]]\ntype = "quadrangle"\np0 = {list(p[0])}\np1 = {list(p[1])}\np2 = {list(p[2])}\np3 = {list(p[3])}\n'
        f"material = {{ kd = {list(FLOOR[1])}, ks = 0 }}\n\n"
        f'[[object]]\ntype = "sphere"\ncenter = {list(SPHERE[0])}\nradius = {SPHERE[1]}\nmaterial = {material}\n\n'
        '[[light]]\ntype = "environment"\nfile = "sky.hdr"\n'
    )


def render_raylab(binary, material, size, spp, seed, bounces):
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "scene.toml"), "w") as f:
            f.write(raylab_scene(material, d, size, spp, bounces))
        out = os.path.join(d, "out.pfm")
        subprocess.run([binary, "render", os.path.join(d, "scene.toml"), "-o", out, "--threads", "2", "--seed", str(seed)], check=True, capture_output=True)
        return read_pfm(out)


def build_mitsuba(mi, bsdf, size, bounces, folder):
    T = mi.ScalarTransform4f
    c = CAMERA
    p = FLOOR[0]
    path = os.path.join(folder, "floor.obj")
    write_obj(path, [(p[0], p[1], p[2]), (p[0], p[2], p[3])])
    return mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": bounces + 2},
            "sensor": {
                "type": "perspective",
                "fov": c["fov"],
                "fov_axis": "y",
                "to_world": T().look_at(origin=c["position"], target=c["look_at"], up=(0, 1, 0)),
                "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                "sampler": {"type": "independent"},
            },
            "floor": {
                "type": "obj",
                "filename": path,
                "face_normals": True,
                "bsdf": {"type": "twosided", "material": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(FLOOR[1])}}},
            },
            "ball": {"type": "sphere", "center": list(SPHERE[0]), "radius": SPHERE[1], "bsdf": bsdf},
            "env": {"type": "envmap", "bitmap": mitsuba_rows(mi, SKY), "to_world": T().rotate([0, 1, 0], 180)},
        }
    )


def sphere_mask(size):
    """Pixels whose centre's camera ray meets the sphere (raylab's pinhole: vertical fov, y up)."""
    c = CAMERA
    eye, target = np.array(c["position"], float), np.array(c["look_at"], float)
    fwd = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    t = math.tan(math.radians(c["fov"]) / 2)
    j, i = np.mgrid[0:size, 0:size] + 0.5
    x, y = (2 * i / size - 1) * t, (1 - 2 * j / size) * t
    d = fwd + x[..., None] * right + y[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    oc = eye - np.array(SPHERE[0])
    b = d @ oc
    disc = b * b - (oc @ oc - SPHERE[1] ** 2)
    return disc > 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "raylab"))
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--only", default=None, help="run only scenes whose name contains this")
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant(args.variant)
    print(f"raylab {args.binary} vs Mitsuba {mi.__version__} {args.variant}; {args.size}², {args.spp} spp × {args.seeds} seeds\n")
    mask = sphere_mask(args.size)
    rows = []
    for name, (material, bsdf) in scenes(mi).items():
        if args.only and args.only not in name:
            continue
        with tempfile.TemporaryDirectory() as folder:
            scene = build_mitsuba(mi, bsdf, args.size, args.bounces, folder)
            rl = [render_raylab(args.binary, material, args.size, args.spp, k + 1, args.bounces) for k in range(args.seeds)]
            mt = [np.array(mi.render(scene, spp=args.spp, seed=k + 1), dtype=np.float64)[:, :, :3] for k in range(args.seeds)]
        R, M = np.mean(rl, axis=0), np.mean(mt, axis=0)
        ratio, ball = R.mean() / M.mean(), R[mask].mean() / M[mask].mean()
        # The sphere's mean per seed: its spread gives the ratio's standard error.
        sr, sm = np.array([x[mask].mean() for x in rl]), np.array([x[mask].mean() for x in mt])
        ball_se = ball * math.sqrt(sr.var(ddof=1) / args.seeds / sr.mean() ** 2 + sm.var(ddof=1) / args.seeds / sm.mean() ** 2)
        br, bm = np.array([blocks(x) for x in rl]), np.array([blocks(x) for x in mt])
        se = np.sqrt(br.var(axis=0, ddof=1) / args.seeds + bm.var(axis=0, ddof=1) / args.seeds)
        # Blocks without noise (only the environment in view) are judged at 10⁻⁴ of their value.
        z = (br.mean(axis=0) - bm.mean(axis=0)) / np.maximum(se, 1e-4 * np.abs(bm.mean(axis=0)) + 1e-12)
        rms_z, beyond = float(np.sqrt(np.mean(z * z))), int(np.sum(np.abs(z) > 4))
        rows.append((name, ratio, ball, ball_se, rms_z, beyond, z.size))
        print(f"{name}: image mean ratio {ratio:.4f}; sphere {ball:.4f} ± {ball_se:.4f}; block z RMS {rms_z:.2f}, {beyond}/{z.size} beyond 4", flush=True)
    print("\n| sphere | image mean ratio raylab ÷ Mitsuba | sphere's pixels | block z RMS (≈1: noise) | blocks beyond 4σ |")
    print("|---|---:|---:|---:|---:|")
    for name, ratio, ball, ball_se, rms_z, beyond, nb in rows:
        print(f"| {name} | {ratio:.4f} | {ball:.4f} ± {ball_se:.4f} | {rms_z:.2f} | {beyond}/{nb} |")


if __name__ == "__main__":
    sys.exit(main())
