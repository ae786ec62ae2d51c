"""Mitsuba 3 (PyPI `mitsuba`) render of one of raylab's peer shots with the `direct` integrator.

    python mitsuba_shot.py SCENE.toml --variant scalar_rgb|llvm_ad_rgb --threads N [--scale S] [--png OUT.png]
                           [--renders R] [--kernels]

SCENE.toml is one of the shots of this folder (`bunny/bunny.toml`, `big/big.toml`,
`spheres/spheres.toml`), read as raylab reads it: its camera, `[render]` size and samples per
pixel, its `mesh`, `sphere` and `plane` objects with their `kd`, and its directional light. Mesh
files are found beside the scene file. `--scale` multiplies the image size (run.sh's SCALE).

`direct` with emitter_samples = 1 and bsdf_samples = 0 traces one camera ray per sample and one
shadow ray per hit toward the directional light: the work of raylab's Phong integrator on these
shots. Differences: the camera ray is jittered inside the pixel (Mitsuba's samplers have no
pixel-centre mode; several samples per pixel use its `stratified` sampler, as raylab stratifies),
a plane is a rectangle 10⁴ scene units wide (Mitsuba has no infinite plane: a few pixels at the
horizon may differ), there is no ambient term, and meshes are shaded flat (`face_normals`), as
raylab does for an OBJ without normals. Irradiance π makes Mitsuba's diffuse (albedo/π) as bright
as raylab's kd·(n·l).

The render is timed twice in one process; the second time is reported as `render_s` (for the
llvm variant the first includes compiling the kernel; `first_render_s` shows it). `--renders R`
(default 2) renders R times in all, the last one reported: `profile.sh` counts the instructions of
R = 3 and R = 2 and takes the difference, one warm render. `--kernels` (llvm variants) prints the
Dr.Jit kernels the last render launched: their sizes, IR operation counts, execution times and
SIMD width (from the kernel's LLVM IR).
"""

import argparse
import math
import os
import sys
import time
import tomllib

PLANE_SIZE = 1e4


def grey(material, default=0.8):
    kd = (material or {}).get("kd", default)
    return [float(kd)] * 3 if not isinstance(kd, list) else [float(x) for x in kd]


def scene_dict(mi, path, scale):
    with open(path, "rb") as f:
        s = tomllib.load(f)
    here = os.path.dirname(os.path.abspath(path))
    r, cam = s["render"], s["camera"]
    width, height = max(1, round(r["width"] * scale)), max(1, round(r["height"] * scale))
    spp = int(r.get("spp", 1))
    sampler = {"type": "independent", "sample_count": 1} if spp == 1 else {"type": "stratified", "sample_count": spp}
    d = {
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {
            "type": "perspective",
            "fov": float(cam.get("fov", 45)),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": sampler,
        },
    }
    for i, o in enumerate(s.get("object", [])):
        bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": grey(o.get("material"))}}
        if o["type"] == "mesh":
            d[f"object{i}"] = {"type": "obj", "filename": os.path.join(here, o["file"]), "face_normals": True, "bsdf": bsdf}
        elif o["type"] == "sphere":
            d[f"object{i}"] = {"type": "sphere", "center": [float(x) for x in o.get("center", [0, 0, 0])], "radius": float(o.get("radius", 1)), "bsdf": bsdf}
        elif o["type"] == "plane":
            if [float(x) for x in o.get("normal", [0, 1, 0])] != [0.0, 1.0, 0.0]:
                sys.exit(f"{path}: only planes with normal +y are translated")
            y = float(o.get("point", [0, 0, 0])[1])
            d[f"object{i}"] = {
                "type": "rectangle",
                "to_world": mi.ScalarTransform4f().translate([0, y, 0])
                @ mi.ScalarTransform4f().rotate([1, 0, 0], -90)
                @ mi.ScalarTransform4f().scale([PLANE_SIZE, PLANE_SIZE, 1]),
                "bsdf": bsdf,
            }
        else:
            sys.exit(f"{path}: object type {o['type']} is not translated")
    for i, l in enumerate(s.get("light", [])):
        if l["type"] == "directional":
            c = l.get("color", 1)
            c = [float(c)] * 3 if not isinstance(c, list) else [float(x) for x in c]
            d[f"light{i}"] = {"type": "directional", "direction": [float(x) for x in l["direction"]], "irradiance": {"type": "rgb", "value": [math.pi * x for x in c]}}
        elif l["type"] != "ambient":
            sys.exit(f"{path}: light type {l['type']} is not translated")
    return d, spp


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--png")
    ap.add_argument("--renders", type=int, default=2)
    ap.add_argument("--kernels", action="store_true")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    dr.set_thread_count(a.threads)
    mi.set_variant(a.variant)
    t0 = time.perf_counter()
    d, spp = scene_dict(mi, a.scene, a.scale)
    scene = mi.load_dict(d)
    t1 = time.perf_counter()
    img = mi.render(scene, spp=spp)
    dr.eval(img)
    dr.sync_thread()
    t_first = time.perf_counter()
    if a.kernels:
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        dr.kernel_history()  # empties the history: only the last render's kernels are printed
    for seed in range(1, max(2, a.renders)):
        if a.kernels:
            dr.kernel_history()
        t2 = time.perf_counter()
        c2 = time.process_time()
        img = mi.render(scene, spp=spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        t3 = time.perf_counter()
        c3 = time.process_time()
    if a.kernels:
        import re

        for k in dr.kernel_history():
            ir = k.get("ir", "")
            ir = ir.read() if hasattr(ir, "read") else str(ir)
            widths = sorted({int(w) for w in re.findall(r"<(\d+) x float>", ir)})
            print(
                f"kernel type={str(k['type']).split('.')[-1]} size={k.get('size')} ops={k.get('operation_count', '')} "
                f"execution_ms={k.get('execution_time', 0):.3f} float_vector_widths={widths}"
            )
    print(f"mitsuba {mi.__version__} variant={a.variant} threads={a.threads}")
    print(f"load_s {t1 - t0:.4f} first_render_s {t_first - t1:.4f} render_s {t3 - t2:.4f} render_cpu_s {c3 - c2:.4f}")
    if a.png:
        mi.util.write_bitmap(a.png, img)


if __name__ == "__main__":
    sys.exit(main())
