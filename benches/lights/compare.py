#!/usr/bin/env python3
"""raylab's path tracer side by side with Mitsuba 3's `path` integrator, on scenes lit the ways
issue 27 is about: an emissive rectangle, an emissive mesh, many small emitters, a constant
environment and an image environment (scenes/assets/sky.hdr).

Each scene is written once here and given to both renderers (raylab as TOML, Mitsuba as a
dict): the same camera, two-sided diffuse surfaces (Mitsuba's `diffuse` wrapped in `twosided`),
area emitters on their normal's side only (raylab's `emission_sides = "front"`), the same
environment (Mitsuba's `envmap` is turned 180° about +y: its image's centre column looks along
+z, raylab's along −z; and it is given the image with its rows re-spaced, as Mitsuba places rows
pole to pole where raylab places them at texel centres: see `mitsuba_rows`), a box pixel filter, at most the same number of bounces
(Mitsuba's max_depth = raylab's max_bounces + 2).

For each scene it prints:

- the ratio of the two images' means (raylab ÷ Mitsuba), from `--spp` samples × `--seeds` seeds;
- per-block differences against the noise: the frame cut into 8 × 8 blocks, each block's
  difference of means divided by its standard error (from the spread of the seeds' images);
  printed as the RMS of these z-scores (≈ 1 when the images agree to within noise) and the
  count of blocks beyond 4;
- samples to equal RMSE: each renderer's RMSE against a high-sample reference (Mitsuba, LLVM,
  `--ref-spp`, the reference's own noise subtracted: see `reference`), and raylab's samples per pixel for Mitsuba's RMSE at the same spp, as a ratio
  (MSE falls as 1/spp, so the ratio is the seeds' mean MSE raylab ÷ Mitsuba; < 1: raylab needs
  fewer samples; before 2026-11-28 it was the square of the ratio of the seeds' mean RMSEs, which
  weighs a seed with fireflies less), with its 90 % interval over the seeds (a bootstrap: see
  `spread`) and each renderer's spread of the seeds' MSEs (std ÷ mean). Where a scene's error is a
  few fireflies (the image environment with glass: caustics of the sun) 4 seeds pin the ratio
  down to within ~2×; `--only "image environment, glass" --seeds 64 --ref-spp 65536` to within
  ~±15 % (see RESULTS.md);
- CPU seconds (user + system, all threads) and wall time per render of each, raylab's from its
  process, Mitsuba's from `mi.render` (its scene built and its kernels compiled beforehand); the
  CPU time per sample, past what a 1-spp render costs (raylab's process start and scene loading,
  Mitsuba's launch); and the CPU time to equal RMSE: the samples ratio times that per-sample
  ratio. CPU time is less sensitive than wall time to a shared machine's load, but not
  immune (caches, hyper-threads): on a loaded machine these are indications, not benchmarks.

Scenes: the five lightings, then each again with a glass ball and a mirror ball in view (glossy
materials are left out: raylab's lobes have no exact Mitsuba 3 counterpart). `--only` picks
scenes by a part of their name, `--variant scalar_rgb` compares with Mitsuba's scalar build,
`--mitsuba-sampler multijitter` (or `stratified`, `orthogonal`, `ldsampler`) gives Mitsuba a
stratified sampler instead of its `independent` one, `--raylab-set stratify=false` gives raylab's
path tracer independent numbers (it stratifies them across a pixel's samples by default).

Setup: python3 -m venv venv && venv/bin/pip install mitsuba numpy; Mitsuba's LLVM variant needs
libLLVM (Debian: apt-get install libllvm19). Build raylab with `cargo build --release --features
mesh,bvh,exr`. Run from the top of the checkout:

    venv/bin/python benches/lights/compare.py [--spp 64] [--seeds 4] [--ref-spp 4096] [--size 64]
"""
import argparse
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SKY = os.path.join(ROOT, "scenes", "assets", "sky.hdr")


# ---------------------------------------------------------------------------------------------
# Scenes: lists of parts that both writers understand.


def box_walls():
    """The open-fronted box of raylab's path-emitters scene: floor, ceiling, back, red and green
    walls, two-sided diffuse."""
    w, r, g = (0.75, 0.75, 0.75), (0.63, 0.065, 0.05), (0.14, 0.45, 0.091)
    return [
        ("quad", [(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)], w, None),
        ("quad", [(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], w, None),
        ("quad", [(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], w, None),
        ("quad", [(-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1)], r, None),
        ("quad", [(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], g, None),
    ]


BOX_CAMERA = dict(position=(0, 1, 3.7), look_at=(0, 0.92, 0), fov=37)
OPEN_CAMERA = dict(position=(0, 1.3, 5.6), look_at=(0, 0.65, 0), fov=34)


def icosphere(center, radius, subdivisions=2):
    """Triangles of an icosphere, outward winding."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
         (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache, nf = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / n for x in p))
                cache[key] = len(v) - 1
            return cache[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    pts = [tuple(center[i] + radius * p[i] for i in range(3)) for p in v]
    return [(pts[a], pts[b], pts[c]) for a, b, c in f]


def many_small(n_side=40):
    """n_side² small triangles spread over the ceiling, facing down (10⁻⁴ of its area each)."""
    tris, rng = [], np.random.default_rng(5)
    s = 2.0 / n_side
    for i in range(n_side):
        for j in range(n_side):
            x, z = -1 + (i + 0.5) * s, -1 + (j + 0.5) * s
            x, z = x + rng.uniform(-0.3, 0.3) * s, z + rng.uniform(-0.3, 0.3) * s
            e = 0.25 * s
            # Winding so the normal points down (−y).
            tris.append(((x - e, 1.999, z - e), (x + e, 1.999, z - e), (x, 1.999, z + e)))
    return tris


def scenes():
    white = (0.8, 0.8, 0.8)
    floor = ("quad", [(-4, 0, 4), (4, 0, 4), (4, 0, -4), (-4, 0, -4)], (0.55, 0.5, 0.45), None)
    ball = ("sphere", ((-0.6, 0.6, 0.0), 0.6), white, None)
    glossy_free = ("sphere", ((0.7, 0.5, 0.3), 0.5), (0.3, 0.5, 0.7), None)
    out = {
        "emissive rectangle": dict(
            camera=BOX_CAMERA,
            parts=box_walls() + [
                # Wound so its normal, the side it emits on, faces down into the room.
                ("quad", [(-0.25, 1.999, -0.25), (0.25, 1.999, -0.25), (0.25, 1.999, 0.25), (-0.25, 1.999, 0.25)], (0, 0, 0), (17, 12, 4)),
                ("sphere", ((-0.4, 0.35, -0.2), 0.35), white, None),
            ],
            env=None,
        ),
        "emissive mesh": dict(
            camera=BOX_CAMERA,
            parts=box_walls() + [("mesh", icosphere((0.2, 1.3, -0.2), 0.18), (0, 0, 0), (12, 10, 8)), ("sphere", ((-0.4, 0.35, -0.2), 0.35), white, None)],
            env=None,
        ),
        "many small emitters": dict(
            camera=BOX_CAMERA,
            parts=box_walls()[:1] + box_walls()[2:] + [("mesh", many_small(), (0, 0, 0), (40, 36, 30)), ("sphere", ((-0.4, 0.35, -0.2), 0.35), white, None)],
            env=None,
        ),
        "constant environment": dict(camera=OPEN_CAMERA, parts=[floor, ball, glossy_free], env=("constant", (0.6, 0.7, 0.9))),
        "image environment": dict(camera=OPEN_CAMERA, parts=[floor, ball, glossy_free], env=("image", SKY)),
    }
    # Each lighting again with a glass ball and a mirror ball in view: the specular materials whose
    # models the two renderers share (raylab's `kt` + `ior`: a smooth dielectric with exact Fresnel,
    # Mitsuba's `dielectric`; its `kr` = 1: a perfect mirror, Mitsuba's `conductor` of material
    # "none"). raylab's glossy lobes (normalised Phong, the glTF BRDF's Schlick Fresnel) have no
    # exact Mitsuba 3 counterpart, so no glossy ball.
    inside = [("glass", ((0.45, 0.3, 0.35), 0.3)), ("mirror", ((0.5, 0.25, -0.55), 0.25))]
    outside = [("glass", ((0.0, 0.35, 1.1), 0.35)), ("mirror", ((1.35, 0.4, -0.9), 0.4))]
    for name in list(out):
        s = out[name]
        extra = inside if s["camera"] is BOX_CAMERA else outside
        out[name + ", glass and mirror"] = dict(s, parts=s["parts"] + [(kind, geo, None, None) for kind, geo in extra])
    return out


# ---------------------------------------------------------------------------------------------
# raylab


def raylab_scene(s, folder, size, spp, bounces):
    out = [f"background = 0\n[render]\nwidth = {size}\nheight = {size}\nspp = {spp}\n"]
    c = s["camera"]
    out.append(f"[camera]\nposition = {list(c['position'])}\nlook_at = {list(c['look_at'])}\nfov = {c['fov']}\n")
    out.append(f"[integrator]\ntype = \"path\"\nmax_bounces = {bounces}\n")
    for i, (kind, geo, kd, emission) in enumerate(s["parts"]):
        if kind in SPECULAR:
            out.append(f"[[object]]\ntype = \"sphere\"\ncenter = {list(geo[0])}\nradius = {geo[1]}\nmaterial = {SPECULAR[kind]}\n")
            continue
        mat = f"{{ kd = {list(kd)}, ks = 0" + (f", emission = {list(emission)} }}" if emission else " }")
        sides = "emission_sides = \"front\"\n" if emission else ""
        if kind == "quad":
            p = geo
            out.append(f"[[object]]\ntype = \"quadrangle\"\np0 = {list(p[0])}\np1 = {list(p[1])}\np2 = {list(p[2])}\np3 = {list(p[3])}\nmaterial = {mat}\n{sides}")
        elif kind == "sphere":
            out.append(f"[[object]]\ntype = \"sphere\"\ncenter = {list(geo[0])}\nradius = {geo[1]}\nmaterial = {mat}\n{sides}")
        elif kind == "mesh":
            path = os.path.join(folder, f"mesh{i}.obj")
            write_obj(path, geo)
            out.append(f"[[object]]\ntype = \"mesh\"\nfile = \"mesh{i}.obj\"\nnormals = \"flat\"\nmaterial = {mat}\n{sides}")
    if s["env"]:
        kind, value = s["env"]
        if kind == "constant":
            out.append(f"[[light]]\ntype = \"environment\"\ncolor = {list(value)}\n")
        else:
            shutil.copy(value, os.path.join(folder, "sky.hdr"))
            out.append("[[light]]\ntype = \"environment\"\nfile = \"sky.hdr\"\n")
    return "\n".join(out)


# raylab's materials of the specular balls (see `scenes`).
SPECULAR = {"glass": "{ kd = 0, ks = 0, kt = 1, ior = 1.5 }", "mirror": "{ kd = 0, ks = 0, kr = 1 }"}


def write_obj(path, tris):
    with open(path, "w") as f:
        for t in tris:
            for p in t:
                f.write("v %r %r %r\n" % p)
        for i in range(len(tris)):
            f.write("f %d %d %d\n" % (3 * i + 1, 3 * i + 2, 3 * i + 3))


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    channels = 3 if kind == b"PF" else 1
    return np.flipud(data.reshape(h, w, channels)).astype(np.float64)


def render_raylab(binary, s, size, spp, seed, bounces, sets=()):
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "scene.toml"), "w") as f:
            f.write(raylab_scene(s, d, size, spp, bounces))
        out = os.path.join(d, "out.pfm")
        t, cpu = time.perf_counter(), children_cpu()
        subprocess.run([binary, "render", os.path.join(d, "scene.toml"), "-o", out, "--threads", "2", "--seed", str(seed)] + [x for kv in sets for x in ("--set", kv)], check=True, capture_output=True)
        return read_pfm(out), time.perf_counter() - t, children_cpu() - cpu


def children_cpu():
    """CPU seconds (user + system) of the finished child processes so far."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


# ---------------------------------------------------------------------------------------------
# Mitsuba


def build_mitsuba(mi, s, size, bounces, sampler="independent"):
    """The Mitsuba scene of `s`, its pixels sampled by `sampler` (a Mitsuba sampler plugin); flat
    shapes and meshes as OBJ files in a temporary folder."""
    T = mi.ScalarTransform4f
    c = s["camera"]
    folder = tempfile.mkdtemp(prefix="raylab-mi-")
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": bounces + 2},
        "sensor": {
            "type": "perspective",
            "fov": c["fov"],
            "fov_axis": "y",
            "to_world": T().look_at(origin=c["position"], target=c["look_at"], up=(0, 1, 0)),
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": sampler},
        },
    }
    for i, (kind, geo, kd, emission) in enumerate(s["parts"]):
        if kind == "glass":
            d[f"shape{i}"] = {"type": "sphere", "center": list(geo[0]), "radius": geo[1], "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}}
            continue
        if kind == "mirror":
            d[f"shape{i}"] = {"type": "sphere", "center": list(geo[0]), "radius": geo[1], "bsdf": {"type": "conductor", "material": "none"}}
            continue
        bsdf = {"type": "twosided", "material": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(kd)}}}
        if kind == "sphere":
            obj = {"type": "sphere", "center": list(geo[0]), "radius": geo[1], "bsdf": bsdf}
        else:
            tris = [(geo[0], geo[1], geo[2]), (geo[0], geo[2], geo[3])] if kind == "quad" else geo
            path = os.path.join(folder, f"m{i}.obj")
            write_obj(path, tris)
            obj = {"type": "obj", "filename": path, "face_normals": True, "bsdf": bsdf}
        if emission:
            obj["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": list(emission)}}
        d[f"shape{i}"] = obj
    if s["env"]:
        kind, value = s["env"]
        if kind == "constant":
            d["env"] = {"type": "constant", "radiance": {"type": "rgb", "value": list(value)}}
        else:
            d["env"] = {"type": "envmap", "bitmap": mitsuba_rows(mi, value), "to_world": T().rotate([0, 1, 0], 180)}
    return mi.load_dict(d)


def mitsuba_rows(mi, path):
    """The equirectangular image `path` as a Mitsuba bitmap that shows the same sky.

    raylab (like pbrt and Blender) puts row j's centre at polar angle θ = (j + ½)/h · π and holds
    the first and last rows out to the poles; Mitsuba's `envmap` puts row j at θ = j/(h − 1) · π,
    pole to pole, so the file as it is would be stretched: at 128 × 64 the sun 0.6° higher and its
    solid angle 1 % larger (the floor 2–4 % brighter, the sky's blocks off by 18σ). Columns agree
    (centres at (i + ½)/w, wrapped). The image given to Mitsuba has 2h + 1 rows at θ = k/(2h) · π:
    the odd ones are the file's rows, the even ones their means, the poles the first and last rows;
    Mitsuba's linear interpolation between them is then exactly raylab's bilinear one."""
    img = np.array(mi.Bitmap(path), dtype=np.float32)[:, :, :3]
    h = img.shape[0]
    out = np.empty((2 * h + 1,) + img.shape[1:], dtype=np.float32)
    out[1::2] = img
    out[2:-1:2] = 0.5 * (img[:-1] + img[1:])
    out[0], out[-1] = img[0], img[-1]
    return mi.Bitmap(out)


def reference(mi, scene, spp):
    """A Mitsuba render at `spp` as the mean of two halves of different seeds, and the mean
    squared error of that mean against the exact image, estimated from the halves' difference
    (mean((A − B)²) / 4): subtracted from each measured MSE, so the reference's own noise does not
    count as the renderers' error (at 4096 spp it was most of raylab's MSE on the emitter scenes)."""
    # In passes of at most REF_PASS spp (one LLVM wavefront holds every sample of a pass).
    halves = []
    for h in range(2):
        n = max(1, math.ceil(spp / 2 / REF_PASS))
        halves.append(np.mean([render_mitsuba(mi, scene, max(1, spp // (2 * n)), 1000 + 2 * k + h)[0] for k in range(n)], axis=0))
    a, b = halves
    return 0.5 * (a + b), float(np.mean((a - b) ** 2)) / 4.0


# Most samples per pixel of one reference render (see `reference`).
REF_PASS = 4096


def rmse_against(ref, ref_mse):
    """The RMSE of an image against the exact one, from its MSE against `ref` less `ref`'s own."""
    return lambda x: float(np.sqrt(max(np.mean((x - ref) ** 2) - ref_mse, 0.0)))


def mse_against(ref, ref_mse):
    """The MSE of an image against the exact one: its MSE against `ref` less `ref`'s own."""
    return lambda x: max(float(np.mean((x - ref) ** 2)) - ref_mse, 0.0)


# Resamplings of the seeds for the spread of a samples ratio (see `spread`), and its interval.
BOOTSTRAP = 4000
INTERVAL = 0.9


def spread(m_r, m_m):
    """The `INTERVAL` (90 %) interval of the samples ratio mean(m_r) ÷ mean(m_m) (per-seed MSEs of
    raylab and Mitsuba), by a bootstrap over each renderer's seeds: where a scene's error is a few
    fireflies (caustics), one seed's MSE can be several times another's, and 4 seeds tell a
    ratio to within a factor of ~2 only. A fixed generator: the same images give the same interval."""
    rng = np.random.default_rng(27)
    r = rng.choice(m_r, size=(BOOTSTRAP, len(m_r))).mean(axis=1)
    m = rng.choice(m_m, size=(BOOTSTRAP, len(m_m))).mean(axis=1)
    ratios = r / np.maximum(m, 1e-300)
    tail = 50 * (1 - INTERVAL)
    return float(np.percentile(ratios, tail)), float(np.percentile(ratios, 100 - tail))


def render_mitsuba(mi, scene, spp, seed):
    t, cpu = time.perf_counter(), time.process_time()
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)[:, :, :3]
    return img, time.perf_counter() - t, time.process_time() - cpu


# ---------------------------------------------------------------------------------------------


def blocks(img, n=8):
    h, w = img.shape[:2]
    return img[: h - h % n, : w - w % n].reshape(n, h // n, n, w // n, -1).mean(axis=(1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "raylab"))
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument(
        "--mitsuba-sampler",
        default="independent",
        help="Mitsuba's sampler for its renders and its reference: independent (the default, as its docs' examples), or a "
        "stratified one (stratified, multijitter, orthogonal, ldsampler: per-pixel sets of a known count; use a --spp they accept, "
        "a square or a power of two); raylab's path tracer stratifies its numbers across the pixel's samples unless given "
        "--raylab-set stratify=false",
    )
    ap.add_argument("--raylab-set", action="append", default=[], metavar="KEY=VALUE", help="an integrator parameter for raylab's renders (repeatable)")
    ap.add_argument("--only", default=None, help="run only scenes whose name contains this")
    ap.add_argument("--exclude", default=None, help="skip scenes whose name contains this")
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant(args.variant)
    print(f"raylab {args.binary} {' '.join(args.raylab_set)} vs Mitsuba {mi.__version__} {args.variant} ({args.mitsuba_sampler} sampler); {args.size}², {args.spp} spp × {args.seeds} seeds, reference {args.ref_spp} spp (Mitsuba)")
    print("wall times are measured under load (a shared 2-core machine): not benchmarks\n")
    rows = []
    for name, s in scenes().items():
        if (args.only and args.only not in name) or (args.exclude and args.exclude in name):
            continue
        scene = build_mitsuba(mi, s, args.size, args.bounces, args.mitsuba_sampler)
        ref, ref_mse = reference(mi, scene, args.ref_spp)
        # One sample per pixel, for each renderer's cost outside its samples (raylab's process and
        # scene loading; Mitsuba's first render compiles its kernels, so it is done twice).
        render_mitsuba(mi, scene, 1, 0)
        c1_m = render_mitsuba(mi, scene, 1, 0)[2]
        c1_r = render_raylab(args.binary, s, args.size, 1, 0, args.bounces, args.raylab_set)[2]
        rl, mt, t_r, t_m, c_r, c_m = [], [], 0.0, 0.0, 0.0, 0.0
        for k in range(args.seeds):
            a, ta, ca = render_raylab(args.binary, s, args.size, args.spp, k + 1, args.bounces, args.raylab_set)
            b, tb, cb = render_mitsuba(mi, scene, args.spp, k + 1)
            rl.append(a)
            mt.append(b)
            t_r, t_m, c_r, c_m = t_r + ta, t_m + tb, c_r + ca, c_m + cb
        R, M = np.mean(rl, axis=0), np.mean(mt, axis=0)
        ratio = R.mean() / M.mean()
        br = np.array([blocks(x) for x in rl])
        bm = np.array([blocks(x) for x in mt])
        se = np.sqrt(br.var(axis=0, ddof=1) / args.seeds + bm.var(axis=0, ddof=1) / args.seeds)
        # Blocks without noise (only the environment in view) are judged at 10⁻⁴ of their value:
        # the two renderers store it in different precisions.
        z = (br.mean(axis=0) - bm.mean(axis=0)) / np.maximum(se, 1e-4 * np.abs(bm.mean(axis=0)) + 1e-12)
        rms_z, beyond = float(np.sqrt(np.mean(z * z))), int(np.sum(np.abs(z) > 4))
        mse = mse_against(ref, ref_mse)
        m_r, m_m = np.array([mse(x) for x in rl]), np.array([mse(x) for x in mt])
        e_r, e_m = float(np.sqrt(m_r.mean())), float(np.sqrt(m_m.mean()))
        spp_ratio = m_r.mean() / m_m.mean()
        lo, hi = spread(m_r, m_m)
        ref_ratio = R.mean() / ref.mean()
        # CPU seconds per sample per pixel beyond the fixed cost (at least a tenth of the whole).
        per_sample = lambda c, c1: max(c / args.seeds - c1, 0.1 * c / args.seeds) / (args.spp - 1)
        cpu_ratio = per_sample(c_r, c1_r) / per_sample(c_m, c1_m)
        cv = lambda m: float(m.std(ddof=1) / max(m.mean(), 1e-300)) if len(m) > 1 else float("nan")
        rows.append((name, ratio, ref_ratio, rms_z, beyond, z.size, e_r, e_m, spp_ratio, t_r / t_m, cpu_ratio, lo, hi))
        print(f"{name}: mean ratio {ratio:.4f} (vs reference {ref_ratio:.4f}); block z RMS {rms_z:.2f}, {beyond}/{z.size} beyond 4; "
              f"RMSE at {args.spp} spp raylab {e_r:.4g} Mitsuba {e_m:.4g} (seeds' MSE spread, std ÷ mean: {cv(m_r):.2f}, {cv(m_m):.2f}): "
              f"samples for equal error {spp_ratio:.2f}× Mitsuba's ({INTERVAL:.0%}: {lo:.2f}–{hi:.2f}); "
              f"per render {t_r / t_m:.2f}× Mitsuba's wall time, {c_r / args.seeds:.2f} s vs {c_m / args.seeds:.2f} s CPU (1 spp: {c1_r:.2f} s vs {c1_m:.2f} s); "
              f"CPU per sample {cpu_ratio:.2f}× Mitsuba's (under load); CPU time to equal error {spp_ratio * cpu_ratio:.2f}× "
              f"({INTERVAL:.0%}: {lo * cpu_ratio:.2f}–{hi * cpu_ratio:.2f})", flush=True)
    print(f"\n| scene | mean ratio raylab ÷ Mitsuba | block z RMS (≈1: noise) | blocks beyond 4σ | samples for equal RMSE (raylab ÷ Mitsuba) | "
          f"its {INTERVAL:.0%} interval (seeds) | CPU time per sample | CPU time to equal RMSE | its {INTERVAL:.0%} interval | wall time per render |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, ratio, _, rms_z, beyond, nb, _, _, spp_ratio, tr, cr, lo, hi in rows:
        print(f"| {name} | {ratio:.4f} | {rms_z:.2f} | {beyond}/{nb} | {spp_ratio:.2f} | {lo:.2f}–{hi:.2f} | {cr:.2f} | {spp_ratio * cr:.2f} | "
              f"{lo * cr:.2f}–{hi * cr:.2f} | {tr:.2f} |")


if __name__ == "__main__":
    sys.exit(main())
