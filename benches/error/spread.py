#!/usr/bin/env python3
"""The error estimate of uniform (stratified) renders against the spread between seeds (issue 30):
how honest the summary's `estimated error` is at each sample count, without a reference.

    python3 benches/error/spread.py RAYLAB [--scenes path-cornell,pbr-spheres,environment]
        [--spp 2,4,8,16,32,64] [--seeds 12] [--out target/error-bench]

For each scene at `run.py`'s size and each count, renders `--seeds` seeds and prints the mean of the
summary's estimates, the spread between the seeds (the RMS over pixels of each pixel's unbiased
standard deviation of luminance across seeds, relative to the image's mean luminance: the true
relative RMSE of one render, as `tests/error_estimate.rs` measures it), their ratio, and whether
the summary said the estimate may read high or low (how many of the seeds' lines did).
Needs numpy.
"""
import argparse
import math
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raylab")
    ap.add_argument("--scenes", default="path-cornell,pbr-spheres,environment")
    ap.add_argument("--spp", default="2,4,8,16,32,64")
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--extra", default="", help="more arguments for every render, space-separated")
    ap.add_argument("--out", default=os.path.join(run.ROOT, "target", "error-bench"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    out = os.path.join(a.out, "spread.pfm")
    print("| scene | spp | estimated | spread between seeds | est. ÷ spread | flagged high | flagged low |")
    print("|---|---|---|---|---|---|---|")
    for name in a.scenes.split(","):
        file, w, h, _, _ = run.SCENES[name]
        scene = os.path.join(run.ROOT, file)
        for spp in [int(s) for s in a.spp.split(",")]:
            images, est, high, low = [], [], 0, 0
            for seed in range(a.seeds):
                cmd = [os.path.abspath(a.raylab), "render", scene, "--width", str(w), "--height", str(h), "--spp", str(spp),
                       "--seed", str(seed), "-o", out, "--threads", "2", "--max-rays", str(2**63), *a.extra.split()]
                text = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=run.ROOT).stdout
                line = next(l for l in text.splitlines() if "estimated error" in l)
                est.append(float(re.search(r"relative RMSE ([0-9.]+) %", line).group(1)) / 100)
                high += "may read high" in line
                low += "may read low" in line
                images.append(run.pfm(out) @ run.L)
            stack = np.stack(images)
            spread = math.sqrt(float(stack.var(axis=0, ddof=1).mean())) / float(stack.mean())
            e = float(np.mean(est))
            print(f"| {name} | {spp} | {e:.4f} | {spread:.4f} | {e / spread:.2f} | {high}/{a.seeds} | {low}/{a.seeds} |", flush=True)


if __name__ == "__main__":
    main()
