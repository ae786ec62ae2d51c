"""Mitsuba 3 (PyPI `mitsuba`) render of the bunny shot with the `direct` integrator.

    python mitsuba_bunny.py MESH.obj --variant scalar_rgb|llvm_ad_rgb --threads N [--png OUT.png]

`direct` with emitter_samples = 1 and bsdf_samples = 0 traces one camera ray per pixel and one
shadow ray per hit toward the directional light: the work of raylab's bunny scene. Differences:
the camera ray is jittered inside the pixel (Mitsuba's samplers have no pixel-centre mode), the
ground is a rectangle 10⁴ bunny sizes wide (Mitsuba has no infinite plane: a few pixels at the
horizon may differ), there is no ambient term, and the bunny is shaded flat (`face_normals`),
as raylab does for an OBJ without normals. Irradiance π makes Mitsuba's diffuse (albedo/π)
as bright as raylab's kd·(n·l).

The render is timed twice in one process; the second time is reported as `render_s` (for the
llvm variant the first includes compiling the kernel; `first_render_s` shows it).
"""

import argparse
import math
import os
import sys
import time

import shot as shotmod


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--png")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    dr.set_thread_count(a.threads)
    mi.set_variant(a.variant)
    s = shotmod.load()
    size = 1e4 * 0.25
    t0 = time.perf_counter()
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
            "sensor": {
                "type": "perspective",
                "fov": s["fov"],
                "fov_axis": "y",
                "to_world": mi.ScalarTransform4f().look_at(origin=s["position"], target=s["look_at"], up=[0, 1, 0]),
                "film": {"type": "hdrfilm", "width": s["width"], "height": s["height"], "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                "sampler": {"type": "independent", "sample_count": 1},
            },
            "bunny": {
                "type": "obj",
                "filename": os.path.abspath(a.mesh),
                "face_normals": True,
                "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [s["kd_mesh"]] * 3}},
            },
            "ground": {
                "type": "rectangle",
                "to_world": mi.ScalarTransform4f().translate([0, s["plane_y"], 0])
                @ mi.ScalarTransform4f().rotate([1, 0, 0], -90)
                @ mi.ScalarTransform4f().scale([size, size, 1]),
                "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [s["kd_plane"]] * 3}},
            },
            "sun": {"type": "directional", "direction": s["light_dir"], "irradiance": {"type": "rgb", "value": [math.pi * s["light"]] * 3}},
        }
    )
    t1 = time.perf_counter()
    img = mi.render(scene, spp=1)
    dr.eval(img)
    dr.sync_thread()
    t2 = time.perf_counter()
    c2 = time.process_time()
    img = mi.render(scene, spp=1, seed=1)
    dr.eval(img)
    dr.sync_thread()
    t3 = time.perf_counter()
    c3 = time.process_time()
    print(f"mitsuba {mi.__version__} variant={a.variant} threads={a.threads}")
    print(f"load_s {t1 - t0:.4f} first_render_s {t2 - t1:.4f} render_s {t3 - t2:.4f} render_cpu_s {c3 - c2:.4f}")
    if a.png:
        mi.util.write_bitmap(a.png, img)


if __name__ == "__main__":
    sys.exit(main())
