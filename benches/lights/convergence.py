#!/usr/bin/env python3
"""The README's convergence figure: RMSE against a high-sample reference, by samples per pixel
and by CPU time, of raylab's path tracer and Mitsuba 3's `path` (its scalar and LLVM builds) on
one scene of benches/lights/compare.py (the box lit by an emissive rectangle, by default).

The scene, both renderers' settings and the timing are compare.py's (see its docstring): raylab
at 2 threads, CPU seconds (user + system, all threads) of its process; Mitsuba's CPU seconds of
`mi.render`, its scene built and kernels compiled beforehand. The reference is Mitsuba LLVM at
`--ref-spp` (compare.py's `reference`: two halves of their own seeds, whose difference gives the
reference's own noise, subtracted from each MSE). Each point is the mean over `--seeds` seeds of the RMSE and of the
CPU time of one render at that spp. RMSE does not depend on the machine's load; CPU time does,
somewhat (a shared machine's caches and hyper-threads): the right-hand panel is an indication.

    venv/bin/python benches/lights/convergence.py --json benches/lights/convergence.json --plot docs/lights-convergence.png
    python3 benches/lights/convergence.py --from-json benches/lights/convergence.json --plot docs/lights-convergence.png

Needs numpy and Mitsuba 3 (pip `mitsuba`; the LLVM variant needs libLLVM, Debian's libllvm19) to
measure, matplotlib to plot (`--from-json` redraws without Mitsuba).
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare  # noqa: E402  (the scenes and both renderers' drivers)

LABELS = {"raylab": "raylab path", "scalar_rgb": "Mitsuba 3 scalar", "llvm_ad_rgb": "Mitsuba 3 LLVM"}
STYLES = {"raylab": ("C3", "o"), "scalar_rgb": ("C0", "s"), "llvm_ad_rgb": ("C2", "^")}


def measure(args):
    import mitsuba as mi

    s = compare.scenes()[args.scene]
    spps = [int(x) for x in args.spp.split(",")]
    mi.set_variant("llvm_ad_rgb")
    ref, ref_mse = compare.reference(mi, compare.build_mitsuba(mi, s, args.size, args.bounces), args.ref_spp)
    rmse = compare.rmse_against(ref, ref_mse)
    print(f"reference: {args.ref_spp} spp, its own RMSE {ref_mse ** 0.5:.3g} (subtracted)", flush=True)
    curves = {}

    def run(name, render):
        points = []
        for spp in spps:
            e, c = [], []
            for k in range(args.seeds):
                img, _, cpu = render(spp, k + 1)
                e.append(rmse(img))
                c.append(cpu)
            points.append({"spp": spp, "rmse": float(np.mean(e)), "cpu": float(np.mean(c))})
            print(f"{LABELS[name]}: {spp} spp, RMSE {points[-1]['rmse']:.4g}, CPU {points[-1]['cpu']:.3f} s", flush=True)
        curves[name] = points

    run("raylab", lambda spp, seed: compare.render_raylab(args.binary, s, args.size, spp, seed, args.bounces))
    for variant in ("scalar_rgb", "llvm_ad_rgb"):
        mi.set_variant(variant)
        scene = compare.build_mitsuba(mi, s, args.size, args.bounces)
        for spp in spps:  # compile each spp's kernels before timing (LLVM); warm caches (scalar)
            compare.render_mitsuba(mi, scene, spp, 0)
        run(variant, lambda spp, seed: compare.render_mitsuba(mi, scene, spp, seed))
    return {
        "scene": args.scene,
        "size": args.size,
        "seeds": args.seeds,
        "ref_spp": args.ref_spp,
        "mitsuba": mi.__version__,
        "note": "one run on a shared 2-core machine under load; CPU times are indications",
        "curves": curves,
    }


def plot(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(8.4, 3.4))
    for name, points in data["curves"].items():
        color, marker = STYLES[name]
        spp = [p["spp"] for p in points]
        err = [p["rmse"] for p in points]
        cpu = [p["cpu"] for p in points]
        a.loglog(spp, err, marker=marker, color=color, label=LABELS[name])
        b.loglog(cpu, err, marker=marker, color=color, label=LABELS[name])
    a.set_xlabel("samples per pixel")
    b.set_xlabel("CPU seconds per render (loaded machine)")
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    for ax in (a, b):
        ax.set_ylabel("RMSE")
        ax.grid(True, which="both", alpha=0.3)
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(ScalarFormatter())
            axis.set_minor_formatter(NullFormatter())
    a.xaxis.set_major_locator(LogLocator(base=4))
    a.legend()
    fig.suptitle(
        f"{data['scene']}, {data['size']}², against Mitsuba LLVM at {data['ref_spp']} spp (mean of {data['seeds']} seeds)", fontsize=10
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", default=os.path.join(compare.ROOT, "target", "release", "raylab"))
    ap.add_argument("--scene", default="emissive rectangle", help="a scene name of compare.py")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", default="4,16,64,256", help="comma-separated samples per pixel")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ref-spp", type=int, default=65536)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--json", help="write the measured curves here")
    ap.add_argument("--from-json", help="read the curves from here instead of measuring")
    ap.add_argument("--plot", help="draw the figure here (PNG)")
    args = ap.parse_args()
    if args.from_json:
        with open(args.from_json) as f:
            data = json.load(f)
    else:
        data = measure(args)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(data, f, indent=1)
                f.write("\n")
    if args.plot:
        plot(data, args.plot)


if __name__ == "__main__":
    sys.exit(main())
