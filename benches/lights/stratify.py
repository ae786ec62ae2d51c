#!/usr/bin/env python3
"""What stratifying the path's numbers across a pixel's samples buys (issue 27): the path
tracer's `stratify` (the vertices whose light, emitter, BSDF and roulette numbers come from padded,
Owen-scrambled Sobol sequences over the pixel's samples: those after fewer than N diffuse or
glossy bounces; 2 by default, 1024 = all) against
independent numbers (`--set stratify=0`), at equal samples per pixel.

Both estimators are unbiased, so an image's mean squared error is its variance: for each pixel,
the variance of its value over `--seeds` renders with different seeds (ddof 1, an unbiased
estimate), averaged over the image and the channels. No reference is needed, and none of it
depends on the machine's load. Printed per scene and sample count: each setting's relative RMSE
(RMSE ÷ the image's mean) and the MSE ratio stratified ÷ independent, which is the ratio of
samples for equal error where error falls as 1/√spp (< 1: stratification pays).

Scenes: compare.py's ten (written the same way) and bundled ones (`--bundled`, e.g.
path-cornell,environment,path-emitters). Build raylab first (`cargo build --release --features
mesh,bvh,exr`); from the top of the checkout:

    python3 benches/lights/stratify.py [--spp 16,64] [--seeds 8] [--size 48] [--only NAME]
        [--bundled path-cornell,environment,path-emitters] [--stratify 2,1024]
"""
import argparse
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare  # noqa: E402
import variance  # noqa: E402

ROOT = compare.ROOT


def mse(binary, scene_path, size, spp, seeds, stratify):
    imgs = variance.renders(binary, scene_path, size, spp, seeds, [f"stratify={stratify}"])
    return float(imgs.var(axis=0, ddof=1).mean()), float(imgs.mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "target", "release", "raylab"))
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--spp", default="16,64")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--stratify", default="2,1024", help="values of `stratify` (stratified vertices) to compare with 0 (comma-separated)")
    ap.add_argument("--only", default=None, help="compare.py's scenes whose name contains this ('none': none of them)")
    ap.add_argument("--bundled", default="", help="bundled scenes (comma-separated names under scenes/)")
    args = ap.parse_args()
    spps = [int(x) for x in args.spp.split(",")]
    settings = [int(x) for x in args.stratify.split(",")]
    print(f"{args.size}², {args.seeds} seeds; MSE from the seeds' spread; ratios: `stratify` = N ÷ 0 (independent)")
    print("| scene | spp | rel. RMSE, stratify 0 | " + " | ".join(f"rel. RMSE, {n}" for n in settings) + " | "
          + " | ".join(f"MSE ratio {n} ÷ 0" for n in settings) + " | mean ratio " + " | ".join(str(n) for n in settings) + " |")
    print("|---|---:|---:|" + "---:|" * (3 * len(settings)))
    with tempfile.TemporaryDirectory() as folder:
        for name, path, _ in variance.scene_jobs(folder, args.only, args.bundled, args.size, args.bounces):
            for spp in spps:
                m_i, mean = mse(args.binary, path, args.size, spp, args.seeds, 0)
                rest = [mse(args.binary, path, args.size, spp, args.seeds, n) for n in settings]
                rel = lambda m: np.sqrt(m) / max(mean, 1e-12)
                print(f"| {name} | {spp} | {rel(m_i):.4f} | " + " | ".join(f"{rel(m):.4f}" for m, _ in rest) + " | "
                      + " | ".join(f"{m / max(m_i, 1e-300):.3f}" for m, _ in rest) + " | " + " | ".join(f"{mu / mean:.4f}" for _, mu in rest) + " |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
