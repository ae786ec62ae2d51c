#!/usr/bin/env python3
"""Samples for equal error of raylab against raylab, load-independent: two settings (integrator
parameters, `--a` and `--b`) or two builds (`--binary-a`, `--binary-b`) at equal samples per
pixel, on compare.py's scenes and bundled ones, with how far the figure can be trusted.

Both settings must be unbiased (same means): an image's mean squared error is then its
variance, estimated per pixel from the spread of `--seeds` renders with different seeds (ddof 1)
and averaged over the pixels and channels; no reference is needed. Printed per scene:

- each setting's relative RMSE (RMSE ÷ the image's mean) and the MSE ratio B ÷ A, which is the
  ratio of samples for equal error (< 1: B needs fewer samples), with its 90 % interval from a
  bootstrap over the seeds (paired: seed k of A and of B resampled together);
- where A's error sits: the share of its MSE in the 1 % of pixels with the most (near 1: a few
  fireflies, and a ratio that needs many seeds), and in the pixels whose camera ray meets a purely
  specular object (`--specular`, compare.py's scenes only: its glass and mirror balls; the sun
  seen through or in them, and what they show of the floor's caustics);
- the means' ratio B ÷ A (≈ 1 within the noise, or one of them is biased).

Build raylab first (`cargo build --release --features mesh,bvh,exr`); from the top of the
checkout:

    python3 benches/lights/variance.py --b caustics=0.5 [--a stratify=2] [--seeds 24] [--spp 64]
        [--size 48] [--only "glass"] [--bundled environment,path-cornell]
    python3 benches/lights/variance.py --binary-a ../before/target/release/raylab --only image
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare  # noqa: E402

ROOT = compare.ROOT

# Resamplings of the seeds for the MSE ratio's interval.
BOOTSTRAP = 1000


def render(binary, scene_path, size, spp, seed, sets):
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "out.pfm")
        cmd = [binary, "render", scene_path, "-o", out, "--threads", "2", "--seed", str(seed), "--spp", str(spp),
               "--width", str(size), "--height", str(size)] + [x for kv in sets for x in ("--set", kv)]
        subprocess.run(cmd, check=True, capture_output=True)
        return compare.read_pfm(out)


def renders(binary, scene_path, size, spp, seeds, sets):
    """`seeds` renders with seeds 1, 2, …, integrator parameters `sets` (KEY=VALUE): an array
    (seed, row, column, channel)."""
    return np.array([render(binary, scene_path, size, spp, 1 + k, sets) for k in range(seeds)])


def scene_jobs(folder, only, bundled, size, bounces):
    """The scenes to compare: compare.py's whose name contains `only` (all without it), written as
    raylab scenes under `folder`, then the bundled ones named in `bundled` (comma-separated). A
    list of (name, scene file, compare.py's scene or None)."""
    jobs = []
    for name, s in compare.scenes().items():
        if only and only not in name:
            continue
        sub = os.path.join(folder, f"s{len(jobs)}")
        os.mkdir(sub)
        path = os.path.join(sub, "scene.toml")
        with open(path, "w") as f:
            f.write(compare.raylab_scene(s, sub, size, 1, bounces))
        jobs.append((name, path, s))
    for b in filter(None, bundled.split(",")):
        jobs.append((b, os.path.join(ROOT, "scenes", b + ".toml"), None))
    return jobs


def mse_of(imgs):
    return float(imgs.var(axis=0, ddof=1).mean())


def interval(a, b, rng):
    """The 90 % interval of mse(b) ÷ mse(a) over resamplings of the seeds, the same seeds for both
    (the two settings' renders of one seed are paired: where they share numbers, their errors
    do too)."""
    n = len(a)
    ratios = []
    for _ in range(BOOTSTRAP):
        i = rng.integers(0, n, n)
        ratios.append(mse_of(b[i]) / max(mse_of(a[i]), 1e-300))
    return float(np.percentile(ratios, 5)), float(np.percentile(ratios, 95))


def specular_mask(binary, s, size):
    """Pixels whose camera ray (through the pixel's centre region) meets one of compare.py's
    glass or mirror balls: the scene rendered with `depth` of the balls only, every other part
    left out."""
    only = dict(s, parts=[p for p in s["parts"] if p[0] in compare.SPECULAR], env=None)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "scene.toml")
        with open(path, "w") as f:
            f.write(compare.raylab_scene(only, d, size, 1, 0))
        out = os.path.join(d, "out.pfm")
        subprocess.run([binary, "render", path, "-o", out, "--threads", "2", "--integrator", "normals", "--spp", "4"],
                       check=True, capture_output=True)
        return np.abs(compare.read_pfm(out)).sum(axis=2) > 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    default = os.path.join(ROOT, "target", "release", "raylab")
    ap.add_argument("--binary-a", default=default)
    ap.add_argument("--binary-b", default=default)
    ap.add_argument("--a", action="append", default=[], metavar="KEY=VALUE", help="an integrator parameter of setting A (repeatable)")
    ap.add_argument("--b", action="append", default=[], metavar="KEY=VALUE", help="an integrator parameter of setting B (repeatable)")
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--only", default=None, help="compare.py's scenes whose name contains this ('none': none of them)")
    ap.add_argument("--bundled", default="", help="bundled scenes (comma-separated names under scenes/)")
    ap.add_argument("--specular", action="store_true", help="also the share of A's MSE in pixels that see a glass or mirror ball")
    args = ap.parse_args()
    rng = np.random.default_rng(27)
    print(f"{args.size}², {args.spp} spp, {args.seeds} seeds; A: {args.binary_a} {' '.join(args.a)}; B: {args.binary_b} {' '.join(args.b)}")
    print("| scene | rel. RMSE A | rel. RMSE B | MSE B ÷ A | 90 % interval | A's MSE in its top 1 % pixels |"
          + (" A's MSE through the balls |" if args.specular else "") + " mean B ÷ A |")
    print("|---|---:|---:|---:|---:|---:|" + ("---:|" if args.specular else "") + "---:|")
    with tempfile.TemporaryDirectory() as folder:
        for name, path, s in scene_jobs(folder, args.only, args.bundled, args.size, args.bounces):
            a = renders(args.binary_a, path, args.size, args.spp, args.seeds, args.a)
            b = renders(args.binary_b, path, args.size, args.spp, args.seeds, args.b)
            ma, mb = mse_of(a), mse_of(b)
            lo, hi = interval(a, b, rng)
            mean = max(float(a.mean()), 1e-12)
            per_pixel = a.var(axis=0, ddof=1).mean(axis=2)
            ranked = np.sort(per_pixel.ravel())[::-1]
            top = ranked[: max(1, ranked.size // 100)].sum() / max(ranked.sum(), 1e-300)
            row = f"| {name} | {np.sqrt(ma) / mean:.4f} | {np.sqrt(mb) / mean:.4f} | {mb / max(ma, 1e-300):.3f} | {lo:.3f}–{hi:.3f} | {top:.2f} |"
            if args.specular:
                row += f" {per_pixel[specular_mask(args.binary_a, s, args.size)].sum() / max(per_pixel.sum(), 1e-300):.2f} |" if s else " — |"
            print(row + f" {b.mean() / mean:.4f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
