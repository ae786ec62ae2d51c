#!/usr/bin/env python3
"""What any per-pixel sample allocation can gain over uniform sampling on a scene, and what the
error target's rules gain, in a model (issue 30; docs/error-targets.md, `--target-error E`).

    python3 benches/error/allocation.py RAYLAB [--scene scenes/path-cornell.toml] [--size 64]
        [--seeds 16] [--spp 64] [--out target/allocation]

Renders the scene `--seeds` times at `--spp` with distinct seeds and takes each pixel's
per-sample deviation `σᵢ` of luminance from the spread of its means. A pixel with `nᵢ` samples
then has squared error `aᵢ² / nᵢ`, with `aᵢ = σᵢ` for the relative RMSE in linear HDR and
`aᵢ = σᵢ · g'(meanᵢ)` for the RMSE of displayed values (`g`: clamp, then sRGB). Uniform sampling
needs `P · Σ aᵢ² / MSE` samples for an MSE; the best allocation (`nᵢ ∝ aᵢ`, every `σᵢ` known,
counts continuous) `(Σ aᵢ)² / MSE`: their ratio `(mean a)² / mean(a²)` bounds what any
per-pixel allocation can do. The rules are then simulated on the same `σᵢ` (tests at 16 spp and
each doubling, cap 4096, no estimation noise): a pixel's error `σᵢ / √n` over `max(mean, 0.01)`
(relative), over `√max(mean, 0.01)` (√-relative, the target's) or as is (absolute), stopped by a
fixed threshold `E` or by the proportional rule `E · √(n / 16)`. Each is printed as
"mean spp: samples ÷ uniform's at equal MSE" over a range of `E`, for both errors.

Needs numpy. Prints a table.
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
    return np.frombuffer(data, dtype="<f4").reshape(h, w, 3)[::-1]


def display_slope(m):
    """The slope of clamped sRGB encoding at linear value `m` (0 where it clamps)."""
    m = np.maximum(m, 1e-6)
    d = np.where(m <= 0.0031308, 12.92, 1.055 / 2.4 * np.power(m, 1 / 2.4 - 1))
    return np.where(m >= 1.0, 0.0, d)


def simulate(a, crit, e, proportional, min_spp=16, cap=4096, floor=0.0):
    """Samples per pixel under a rule with error `max(crit, floor) / √n` and target `e` (`floor`:
    the least per-sample deviation a pixel is taken to have, `ErrorTarget::FLOOR`)."""
    n = np.full_like(a, float(min_spp))
    crit = np.maximum(crit, floor)
    while True:
        allowed = e * np.sqrt(n / min_spp) if proportional else e
        more = (crit / np.sqrt(n) > allowed) & (n < cap)
        if not more.any():
            return n
        n = np.where(more, n * 2, n)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raylab")
    ap.add_argument("--scene", default="scenes/path-cornell.toml")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "allocation"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    means = []
    for seed in range(a.seeds):
        path = os.path.join(a.out, f"seed{seed}.pfm")
        cmd = [a.raylab, "render", os.path.join(ROOT, a.scene), "--width", str(a.size), "--height", str(a.size),
               "--spp", str(a.spp), "--seed", str(1000 + seed), "-o", path, "-q", "--threads", "2"]
        subprocess.run(cmd, check=True, capture_output=True)
        means.append(pfm(path) @ L)
    means = np.array(means).reshape(a.seeds, -1)
    mu = means.mean(axis=0)
    sigma = np.sqrt(means.var(axis=0, ddof=1) * a.spp)
    print(f"# {a.scene} at {a.size}², σ from {a.seeds} seeds × {a.spp} spp\n")
    for name, w in [("HDR RMSE", sigma), ("displayed RMSE", sigma * display_slope(mu))]:
        print(f"{name}: best allocation (mean a)² / mean(a²) = {w.mean() ** 2 / (w ** 2).mean():.3f}")
    print("\n| error | rule | mean spp: samples ÷ uniform's at equal HDR MSE / displayed MSE |\n|---|---|---|")
    sqrt_rel = sigma / np.sqrt(np.maximum(mu, 0.01))
    crits = {"relative": sigma / np.maximum(mu, 0.01), "√-relative": sqrt_rel, "absolute": sigma,
             # The deviation of the displayed value: the optimum's own weights for displayed RMSE.
             "displayed": sigma * display_slope(mu)}
    rules = [(c, p, 0.0) for c in crits for p in (False, True)]
    # The error target's rule with the floor on the deviation (`ErrorTarget::FLOOR`), and
    # stronger ones: what the floor costs when every deviation is known.
    rules += [("√-relative", True, f) for f in (0.25, 0.5, 1.0)]
    for cname, proportional, floor in rules:
        crit = crits[cname]
        cells = []
        pos = crit[crit > 0]
        for e in np.geomspace(np.percentile(pos, 5) / 64, np.percentile(pos, 95) / 2, 10):
            n = simulate(a=sigma, crit=crit, e=e, proportional=proportional, floor=floor)
            if not 20 < n.mean() < 2000:
                continue
            ratios = []
            for w in (sigma, sigma * display_slope(mu)):
                mse = (w ** 2 / n).sum()
                ratios.append(n.sum() / (len(w) * (w ** 2).sum() / mse))
            cells.append(f"{n.mean():.0f}: {ratios[0]:.2f} / {ratios[1]:.2f}")
        rule = ("proportional" if proportional else "threshold") + (f", floor {floor}" if floor else "")
        print(f"| {cname} | {rule} | {', '.join(cells)} |")


if __name__ == "__main__":
    main()
