#!/usr/bin/env python3
"""Where an error target's estimate reads low (issue 30): which pixels hold the true error it
misses, and the summary's "may read low" share.

    python3 benches/error/honesty.py RAYLAB [--scenes environment,path-cornell,pbr-spheres,quality]
        [--targets 0.2,0.1,0.05,0.025,0.0125] [--seeds 3] [--out target/error-bench]

For each scene at `run.py`'s size, against `run.py`'s two references (rendered and cached in --out
as `run.py` does; their mean is the reference here, and its own squared error, a quarter of their
mean squared difference, is removed from the true error), renders each target with each seed
(`--aov error`) and prints:

- the RMS over seeds of the summary's estimate and of the true relative RMSE, and their ratio;
- per sample count a pixel stopped at: how many pixels, their share of the true squared error,
  and their true squared error ÷ their estimated one (`error` layer²): pixels that stopped at the
  first possible stop reading far below 1 are the ones whose own samples missed what lights them;
- the share of the estimated variance in pixels lit by samples rarer than one per first possible
  stop (`ShareSums::rare_light_share`, from the `error` and `spp` layers here), and whether the
  summary line said the estimate may read low;
- each seed's estimate ÷ its own true error, and how many of the readings outside a factor
  `HONEST` = 1.5 of it went unflagged (the summary's flag, checked against the EXR header's
  `raylab.estimate_may_read`, which must say the same). The last line says whether every reading
  outside 1.5× was flagged; the exit status is 1 if one was not.

Needs numpy and OpenEXR (the Python package).
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

FLOOR = 0.25  # ErrorTarget::FLOOR
MIN_SPP = 16  # target_min_spp's default
HONEST = 1.5  # issue 30: the estimate within this factor of the true error, or it says it is not


def header_flag(path):
    """The EXR header's `raylab.estimate_may_read` (high, low or no)."""
    import OpenEXR

    with OpenEXR.File(path) as f:
        return str(f.header().get("raylab.estimate_may_read"))


def exr(path):
    import OpenEXR

    with OpenEXR.File(path) as f:
        return {k: np.asarray(c.pixels).astype(np.float64) for k, c in f.channels().items()}


def floor_spp(error, m=MIN_SPP):
    """ErrorTarget::floor_spp: the first sample count at which a pixel may stop."""
    n = m
    while FLOOR / math.sqrt(n) > error * math.sqrt(n / m):
        n *= 2
    return n


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raylab")
    ap.add_argument("--scenes", default="environment,path-cornell,pbr-spheres,quality")
    ap.add_argument("--targets", default="0.2,0.1,0.05,0.025,0.0125")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(run.ROOT, "target", "error-bench"))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    b = run.Bench(os.path.abspath(a.raylab), a.out, dict(os.environ))
    out = os.path.join(a.out, "honesty.exr")
    unflagged = []
    for name in a.scenes.split(","):
        file, w, h, ref_spp, _ = run.SCENES[name]
        scene = os.path.join(run.ROOT, file)
        r1 = run.reference(b, name, scene, w, h, ref_spp, 12345) @ run.L
        r2 = run.reference(b, name, scene, w, h, ref_spp, 54321) @ run.L
        ref, noise2 = (r1 + r2) / 2, (r1 - r2) ** 2 / 4
        mu = float(ref.mean())
        print(f"\n## {name} {w}×{h} (reference: two seeds × {ref_spp} spp)\n")
        print("| target | first stop | mean spp | estimated | true | est. ÷ true | per seed | rare share | flagged | outside 1.5×, unflagged | per stop count: pixels, share of true sq. error, true ÷ estimated |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for target in [float(t) for t in a.targets.split(",")]:
            est2, true2, spp, shares, flags, ratios, missed = [], [], [], [], 0, [], 0
            classes = {}
            first = floor_spp(target)
            for seed in range(1, a.seeds + 1):
                cmd = [b.raylab, "render", scene, "--width", str(w), "--height", str(h), "--spp", "4096", "--target-error", str(target),
                       "--seed", str(seed), "-o", out, "--aov", "error", "--threads", "2", "--max-rays", str(2**63)]
                text = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=run.ROOT).stdout
                line = next(l for l in text.splitlines() if "estimated error" in l)
                est = float(re.search(r"relative RMSE ([0-9.]+) %", line).group(1)) / 100
                said = "low" if "may read low" in line else "high" if "may read high" in line else "no"
                if header_flag(out) != said:
                    sys.exit(f"{name} E = {target} seed {seed}: the EXR header says {header_flag(out)!r}, the summary {said!r}")
                flags += said == "low"
                d = exr(out)
                y, n, se2 = d["RGB"] @ run.L, d["spp"], np.nan_to_num(d["error"] ** 2)
                err2 = (y - ref) ** 2 - noise2
                est2.append(est * est)
                true2.append(max(float(err2.mean()), 0.0) / mu**2)
                ratio = est / math.sqrt(true2[-1]) if true2[-1] > 0 else math.inf
                ratios.append(ratio)
                outside = not (1 / HONEST <= ratio <= HONEST)
                # A reading outside 1.5× must be flagged, and the way it errs.
                if outside and said != ("low" if ratio < 1 else "high"):
                    missed += 1
                    unflagged.append(f"{name} E = {target} seed {seed}: {ratio:.2f}, flagged {said!r}")
                spp.append(float(n.mean()))
                # ShareSums::rare_light_share from the layers: mean square = mean² + s²(n − 1)/n.
                ms = y**2 + se2 * n * (n - 1) / n
                carriers = np.where(ms > 0, first * y**2 / np.where(ms > 0, ms, 1.0), np.inf)
                shares.append(float(se2[carriers < 1].sum() / max(se2.sum(), 1e-300)))
                for k in np.unique(n):
                    m = n == k
                    c = classes.setdefault(int(k), [0, 0.0, 0.0])
                    c[0] += int(m.sum())
                    c[1] += float(err2[m].sum())
                    c[2] += float(se2[m].sum())
            est, true = math.sqrt(np.mean(est2)), math.sqrt(np.mean(true2))
            total = sum(c[1] for c in classes.values())
            per = "; ".join(f"{k}: {c[0] / a.seeds:.0f}, {c[1] / total:.2f}, {c[1] / max(c[2], 1e-300):.1f}" for k, c in sorted(classes.items())
                            if c[1] / total >= 0.01)
            print(f"| {target} | {first} | {np.mean(spp):.1f} | {est:.4f} | {true:.4f} | {est / true:.2f} | "
                  f"{' '.join(f'{r:.2f}' for r in ratios)} | {' '.join(f'{s:.3f}' for s in shares)} | {flags}/{a.seeds} | {missed} | {per} |",
                  flush=True)
    print(f"\nEvery reading outside {HONEST}× of the true error flagged: " + ("yes" if not unflagged else "no: " + "; ".join(unflagged)))
    sys.exit(1 if unflagged else 0)


if __name__ == "__main__":
    main()
