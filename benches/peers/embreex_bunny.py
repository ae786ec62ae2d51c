"""Embree 4 (PyPI `embreex`) peer of the bunny shot: the same work as embree/bunny_embree.cpp.

    python embreex_bunny.py MESH.obj --threads N [--png OUT.png] [--robust]

embreex hands Embree arrays of rays ("vectorised" from Python), but inside `EmbreeScene.run` it
loops over them with rtcIntersect1 / rtcOccluded1, one ray at a time, without the GIL. So: camera
rays of the whole image (generated with numpy before timing, as raylab's camera would), then the
shadow rays of the hits, each batch split into bands of 8 rows taken by N Python threads. The
wall-clock frame is the `run` calls and the numpy glue between the two passes (ray generation
is not timed; the C++ harness times it); the per-phase rates are the `run` calls alone. embreex's scenes are robust (watertight) by default; this
script turns that off unless --robust, to match the C++ harness's Embree default.

The ground plane is raylab's infinite plane, intersected in numpy (the camera rays' tfar is the
plane's distance), as in the C++ harness. embreex has no `tnear`: a shadow ray starts at the hit
point moved along the ray by the C++ harness's tnear.
"""

import argparse
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import shot as shotmod


def read_obj(path):
    """`v` and `f` lines only (triangles; `a/b/c` forms allowed), as float32 and int32 arrays."""
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append(line.split()[1:4])
            elif line.startswith("f "):
                idx = [int(t.split("/")[0]) for t in line.split()[1:]]
                for k in range(1, len(idx) - 1):
                    faces.append((idx[0], idx[k], idx[k + 1]))
    v = np.array(verts, dtype=np.float32)
    i = np.array(faces, dtype=np.int64)
    i = np.where(i > 0, i - 1, len(v) + i).astype(np.int32)
    return v, i


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--png")
    ap.add_argument("--robust", action="store_true")
    a = ap.parse_args()

    import embreex
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    s = shotmod.load()
    W, H = s["width"], s["height"]
    verts, idx = read_obj(a.mesh)
    t0 = time.perf_counter()
    scene = rtcore_scene.EmbreeScene(robust=a.robust)
    TriangleMesh(scene, verts, idx)
    t1 = time.perf_counter()
    # The BVH is built at the first query.
    scene.run(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))
    t2 = time.perf_counter()

    pos = np.array(s["position"])
    dirs = shotmod.camera_rays(s)
    to_light = -np.array(s["light_dir"])
    to_light /= np.linalg.norm(to_light)
    with np.errstate(divide="ignore", invalid="ignore"):
        tp = (s["plane_y"] - pos[1]) / dirs[:, 1]
    tplane = np.where(tp > 0, tp, np.inf).astype(np.float32)
    origins = np.broadcast_to(pos.astype(np.float32), dirs.shape).copy()
    dirs32 = dirs.astype(np.float32)
    dist = np.linalg.norm(np.array(s["look_at"]) - pos)
    tnear = np.float32(1e-5 * dist)
    light32 = to_light.astype(np.float32)[None, :]
    band = 8 * W
    bands = [(k, min(k + band, W * H)) for k in range(0, W * H, band)]
    image = np.zeros(W * H, np.float64)

    def do_band(rng):
        lo, hi = rng
        c0 = time.thread_time()
        r = scene.run(origins[lo:hi], dirs32[lo:hi], dists=tplane[lo:hi].copy(), output=1)
        cg = time.thread_time()
        mesh = r["geomID"] >= 0
        plane = ~mesh & np.isfinite(tplane[lo:hi])
        hit = mesh | plane
        t = r["tfar"][hit]
        p = origins[lo:hi][hit] + t[:, None] * dirs32[lo:hi][hit]
        ng = np.where(mesh[hit, None], r["Ng"][hit], np.array([0, 1, 0], np.float32))
        ng = ng / np.linalg.norm(ng, axis=1)[:, None]
        ng = np.where((ng * dirs32[lo:hi][hit]).sum(1)[:, None] > 0, -ng, ng)
        nl = ng @ to_light
        so = p + tnear * light32
        so = so.astype(np.float32)
        c1 = time.thread_time()
        occ = scene.run(so, light32, query="OCCLUDED") >= 0
        c2 = time.thread_time()
        kd = np.where(mesh[hit], s["kd_mesh"], s["kd_plane"])
        image[lo:hi][hit] = s["ambient"] + np.where(~occ & (nl > 0), kd * nl * s["light"], 0.0)
        return hi - lo, int(mesh.sum()), int(plane.sum()), len(occ), int(occ.sum()), cg - c0, c2 - c1, c1 - cg

    f0 = time.perf_counter()
    with ThreadPoolExecutor(a.threads) as ex:
        res = list(ex.map(do_band, bands))
    frame = time.perf_counter() - f0
    cam, hm, hp, sh, occ, ccpu, scpu, gcpu = (sum(x) for x in zip(*res))
    T = a.threads
    print(f"embreex {getattr(embreex, '__version__', '?')} robust={int(a.robust)} threads={T} triangles={len(idx)}")
    print(f"copy_s {t1 - t0:.4f} build_s {t2 - t1:.4f}")
    print(f"trace_s {frame:.4f}")
    print(f"camera_rays {cam} hits_mesh {hm} hits_plane {hp} shadow_rays {sh} occluded {occ}")
    print(f"rays_per_s_wall {(cam + sh) / frame:.0f}")
    # Per-phase rates of the `run` calls alone (Embree's loop), from the threads' CPU time, and
    # the share of CPU time spent in the numpy glue between them.
    print(f"camera_rays_per_s_cpu {cam / (ccpu / T):.0f} shadow_rays_per_s_cpu {sh / (scpu / T):.0f}")
    print(f"all_rays_per_s_cpu {(cam + sh) / ((ccpu + scpu) / T):.0f} glue_cpu_share {gcpu / (ccpu + scpu + gcpu):.2f}")
    if a.png:
        from PIL import Image

        v = np.clip(image, 0, 1)
        v = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
        img = (v * 255 + 0.5).astype(np.uint8).reshape(H, W)
        Image.fromarray(np.stack([img] * 3, axis=2)).save(a.png)


if __name__ == "__main__":
    sys.exit(main())
