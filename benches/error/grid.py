#!/usr/bin/env python3
"""The denoiser's sub-pixel grid, over seeds: displayed RMSE and CPU seconds of `render --denoise`'s
way (the frame rendered on k × k sub-pixels of spp / k² samples, denoised there by `oidnDenoise`,
averaged back over each pixel) for any grid and sample count, not only the one `denoise::grid`
picks (benches/error/RESULTS.md, 2026-11-28).

    python3 benches/error/grid.py RAYLAB --ref REF.pfm [--size 64] [--seeds 1,2,3,4,5,6]
        [--scene scenes/path-cornell.toml] [--out target/error-grid] 4:128 2:256 1:384 …

Each `k:spp` renders the frame at k × --size with spp / k² samples and the layers the denoiser
reads (`--aov albedo,normal,emission`, cached in --out), denoises it as `render --denoise` does
(the emission left out of the filter and added back, clean guides, quality high), and prints the
RMS over the seeds of the displayed RMSE (as run.py) against REF, and the CPU seconds (user +
system) of one render and one denoising (the first seed). Needs numpy, OpenEXR and pyoidn.
"""
import argparse
import os
import resource
import subprocess
import sys

import numpy as np
import OpenEXR
import Imath

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from run import ROOT, display_rmse, pfm  # noqa: E402


def write_pfm(path, img):
    h, w, _ = img.shape
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def read_exr(path):
    f = OpenEXR.InputFile(path)
    dw = f.header()["dataWindow"]
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    pt = Imath.PixelType(Imath.PixelType.FLOAT)
    layer = lambda names: np.stack([np.frombuffer(f.channel(n, pt), dtype=np.float32).reshape(h, w) for n in names], -1)  # noqa: E731
    return {"color": layer("RGB"), "albedo": layer(["albedo.R", "albedo.G", "albedo.B"]),
            "normal": layer(["normal.X", "normal.Y", "normal.Z"]), "emission": layer(["emission.R", "emission.G", "emission.B"])}


def cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raylab")
    ap.add_argument("configs", nargs="+", help="k:spp, e.g. 4:128")
    ap.add_argument("--ref", required=True)
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes/path-cornell.toml"))
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--seeds", default="1,2,3,4,5,6")
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "error-grid"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    oidn = subprocess.run([sys.executable, "-c", "import os, pyoidn; print(os.path.join(os.path.dirname(pyoidn.__file__), 'oidn', 'bin', 'oidnDenoise'))"],
                          capture_output=True, text=True, check=True).stdout.strip()
    ref = pfm(a.ref)
    seeds = [int(s) for s in a.seeds.split(",")]
    tmp = lambda name: os.path.join(a.out, name)  # noqa: E731

    def render(k, spp, seed, path):
        cmd = [a.raylab, "render", a.scene, "--width", str(a.size * k), "--height", str(a.size * k), "--spp", str(spp // (k * k)),
               "--seed", str(seed), "--threads", "2", "-q", "-o", path, "--aov", "albedo,normal,emission"]
        subprocess.run(cmd, check=True, capture_output=True)

    def denoise(layers, k):
        write_pfm(tmp("c.pfm"), np.maximum(layers["color"] - layers["emission"], 0))
        write_pfm(tmp("a.pfm"), layers["albedo"])
        write_pfm(tmp("n.pfm"), layers["normal"])
        subprocess.run([oidn, "--hdr", tmp("c.pfm"), "--alb", tmp("a.pfm"), "--nrm", tmp("n.pfm"), "--clean_aux", "-o", tmp("o.pfm")],
                       check=True, capture_output=True)
        out = pfm(tmp("o.pfm")) + layers["emission"]
        h, w, _ = out.shape
        return out.reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3))

    print("| grid | spp | samples a sub-pixel | displayed RMSE, RMS over seeds | seeds | CPU s render | CPU s denoiser |")
    print("|---|---:|---:|---:|---|---:|---:|")
    for cfg in a.configs:
        k, spp = map(int, cfg.split(":"))
        if spp % (k * k):
            sys.exit(f"{cfg}: {spp} spp is not a multiple of {k * k}")
        errs, times = [], None
        for seed in seeds:
            path = tmp(f"{a.size}-{k}-{spp}-{seed}.exr")
            t0 = cpu()
            render(k, spp, seed, path)
            t1 = cpu()
            layers = read_exr(path)
            t2 = cpu()
            img = denoise(layers, k)
            t3 = cpu()
            times = times or (t1 - t0, t3 - t2)
            errs.append(display_rmse(img, ref))
        rms = float(np.sqrt(np.mean(np.square(errs))))
        print(f"| {k} × {k} | {spp} | {spp // (k * k)} | {rms:.5f} | {' '.join(f'{e:.5f}' for e in errs)} | {times[0]:.2f} | {times[1]:.2f} |", flush=True)


if __name__ == "__main__":
    main()
