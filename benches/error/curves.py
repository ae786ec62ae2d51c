#!/usr/bin/env python3
"""Uniform sampling's error curve over seeds, and what any per-pixel allocation could gain at each
sample count (issue 30; benches/error/RESULTS.md, "sixth round").

    python3 benches/error/curves.py RAYLAB [--seeds 8] [--max-spp 2048] [--sobol]
        [--out target/error-bench]

Renders path-cornell at 64² `--seeds` times (seeds 100, 101, …) at 16, 32, … `--max-spp` samples
per pixel (with `--sobol` as an error target's pixels take them: every pixel at `n`, Sobol film
positions), against the mean of `run.py`'s two 16384-spp references in `--out` (run `run.py
--scenes path-cornell` once first), and prints per `n`: the relative RMSE of luminance (HDR) and
the RMSE of displayed values, each the RMS over seeds with the references' own noise removed; and
the bound on any per-pixel allocation at `n`, `(mean a)² / mean(a²)` with `aᵢ² = n · MSEᵢ(n)`
(each pixel's squared error at `n` over the seeds; samples ÷ uniform's at equal MSE with every
pixel's error known and falling as `1/√n` from there), and the share of the MSE in the worst 1 %
of pixels. About 4100 spp × 4096 pixels per seed.
"""
import argparse
import os
import subprocess

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
L = np.array([0.2126, 0.7152, 0.0722])


def pfm(path):
    b = open(path, "rb").read()
    _, size, _, data = b.split(b"\n", 3)
    w, h = map(int, size.split())
    return np.frombuffer(data, dtype="<f4").reshape(h, w, 3)[::-1].astype(np.float64)


def srgb(img):
    c = np.clip(img, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raylab")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--max-spp", type=int, default=2048)
    ap.add_argument("--sobol", action="store_true", help="every pixel at n as under an error target (Sobol positions)")
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "error-bench"))
    a = ap.parse_args()
    r1 = pfm(os.path.join(a.out, "path-cornell-64x64-ref16384.pfm"))
    r2 = pfm(os.path.join(a.out, "path-cornell-64x64-ref16384-seed54321.pfm"))
    ref = (r1 + r2) / 2
    # Each pixel's squared error of the references' mean: a quarter of their squared difference.
    noise_h = ((r1 - r2) @ L) ** 2 / 4
    noise_d = ((srgb(r1) - srgb(r2)) ** 2).mean(axis=-1) / 4
    scale = np.mean(ref @ L)
    path = os.path.join(a.out, "curves-x.pfm")
    print(f"# path-cornell 64², {a.seeds} seeds, {'Sobol (error-target) positions' if a.sobol else 'stratified sets'}\n")
    print("| spp | rel. RMSE (HDR) | RMSE (displayed) | bound HDR | bound displayed | worst 1 % of pixels: HDR / displayed share |")
    print("|---:|---:|---:|---:|---:|---|")
    n = 16
    while n <= a.max_spp:
        eh, ed = [], []
        for s in range(a.seeds):
            extra = ["--target-error", "1e-9", "--target-min-spp", str(n)] if a.sobol else []
            subprocess.run([a.raylab, "render", os.path.join(ROOT, "scenes/path-cornell.toml"), "--width", "64", "--height", "64",
                            "--spp", str(n), "--seed", str(100 + s), "-o", path, "-q", "--threads", "2", "--max-rays", str(2**63 - 1),
                            *extra], check=True, capture_output=True)
            img = pfm(path)
            eh.append(((img - ref) @ L) ** 2 - noise_h)
            ed.append(((srgb(img) - srgb(ref)) ** 2).mean(axis=-1) - noise_d)
        cells = [str(n)]
        for e, unit in ((np.mean(eh, axis=0).ravel(), scale), (np.mean(ed, axis=0).ravel(), 1.0)):
            cells.append(f"{np.sqrt(max(e.mean(), 0.0)) / unit:.5f}")
        bounds, shares = [], []
        for e in (np.mean(eh, axis=0).ravel(), np.mean(ed, axis=0).ravel()):
            a2 = np.maximum(e, 0.0) * n
            bounds.append(f"{np.sqrt(a2).mean() ** 2 / a2.mean():.3f}")
            worst = np.sort(a2)[::-1]
            shares.append(f"{worst[: max(1, len(worst) // 100)].sum() / worst.sum():.2f}")
        print("| " + " | ".join(cells + bounds + [" / ".join(shares)]) + " |", flush=True)
        n *= 2


if __name__ == "__main__":
    main()
