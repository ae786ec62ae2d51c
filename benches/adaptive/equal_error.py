#!/usr/bin/env python3
"""Equal-error timing of raylab's and POV-Ray's adaptive anti-aliasing (issue 16).

Renders each renderer's converged reference once (cached in the output folder), then runs every
setting of both renderers in alternation, `--rounds` times, and measures each image against its own
renderer's reference on the 8-bit image: RMSE (in 8-bit levels, 0..255) and mean FLIP (LDR,
67 pixels per degree). Times are each renderer's own trace time: CPU seconds of all threads (POV-Ray's
"CPU-seconds total", raylab's "CPU s"; other processes on a busy machine do not inflate them) and
wall seconds; the median over the rounds is kept.

For each metric and each renderer, the Pareto front (no other setting both faster and better)
gives time as a function of error, interpolated log-log between neighbouring points of the
front. The equal-error ratio at error E is raylab's time ÷ POV-Ray's time at E. The targets run
from POV-Ray's default (+A0.3 +AM2 +R3) error down to its +A0.3 +AM2 +R4 error, and on to the
lowest error POV-Ray reaches in the sweep.

Needs: povray (Debian package `povray`, 3.7), python3 with numpy, Pillow, matplotlib and
flip-evaluator (`pip install numpy pillow matplotlib flip-evaluator`), and a release build of
raylab (`cargo build --release`).

    benches/adaptive/equal_error.py --scenes dozen,quality --rounds 3 --out target/adaptive-bench \
        --plot-dir docs

`--size` and `--ref-spp` make a cheaper run (raylab's quality reference at 256 spp and 640×400
takes many minutes on two cores); the reference cache key includes both.

The plot (`adaptive-<scene>.png`) shows both renderers' settings, error against CPU time on log
axes, with each front drawn as a line.
"""

import argparse
import csv
import hashlib
import json
import math
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# raylab settings: (label, extra args). Depth d is a 2^d sub-grid per pixel side (edges are
# located to 1/2^d of a pixel).
RAYLAB_DOZEN = [("no AA", [])] + [
    (f"t{t} d{d}", ["--aa", "adaptive", "--aa-threshold", str(t), "--aa-depth", str(d)])
    for d in (3, 4)
    for t in (0.25, 0.16, 0.12, 0.09, 0.06, 0.04, 0.03, 0.02, 0.015, 0.01)
] + [
    # Coarse levels c: blocks of 2^c pixels whose corners agree are interpolated.
    (f"t{t} d3 c{c}", ["--aa", "adaptive", "--aa-threshold", str(t), "--aa-depth", "3", "--aa-coarse", str(c)])
    for c in (1, 2)
    for t in (0.12, 0.06, 0.04, 0.03, 0.02, 0.01)
]
# POV-Ray settings: +AM2 with +R n subdivides n − 1 times (a 2^(n−1) sub-grid); +J jitters the
# subdivision samples (POV-Ray's default), -J does not.
POV_DOZEN = [("-A", ["-A"])] + [
    (f"+A{a} +R{r}{j}", [f"+A{a}", "+AM2", f"+R{r}"] + ([] if j == "" else ["-J"]))
    for r in (2, 3, 4, 5)
    for a in (0.5, 0.3, 0.2, 0.1, 0.05)
    for j in ("", " -J")
]

# The quality scene (soft shadows, glossy floor, frosted glass; no depth of field: POV-Ray's
# twin has none): fewer settings, each render costs more.
RAYLAB_QUALITY = [("no AA", ["--aa", "stratified", "--spp", "1"])] + [
    (f"t{t} d{d}", ["--aa", "adaptive", "--aa-threshold", str(t), "--aa-depth", str(d)])
    for d, ts in ((3, (0.12, 0.06, 0.03, 0.02, 0.01)), (4, (0.06, 0.03, 0.02, 0.01)))
    for t in ts
] + [
    (f"t{t} d3 c{c}", ["--aa", "adaptive", "--aa-threshold", str(t), "--aa-depth", "3", "--aa-coarse", str(c)])
    for c in (1, 2)
    for t in (0.25, 0.12, 0.06, 0.03)
]
POV_QUALITY = [("-A", ["-A"])] + [
    (f"+A{a} +R{r}", [f"+A{a}", "+AM2", f"+R{r}"]) for r in (2, 3, 4) for a in (0.3, 0.2, 0.1, 0.05)
]

SCENES = {
    "dozen": {
        "raylab": "scenes/dozen.toml",
        "pov": "benches/povray/dozen.pov",
        "size": (800, 600),
        # Stratified (correlated multi-jitter) box filter: 32 × 32 strata per pixel.
        "raylab_ref": ["--spp", "1024"],
        # 4 × 4 pixels per final pixel, each supersampled 6 × 6 jittered + its centre: 24 × 24
        # strata per pixel after the box downsample.
        "pov_ref": {"scale": 4, "args": ["+A0.0", "+AM1", "+R6", "+J"]},
        "raylab_settings": RAYLAB_DOZEN,
        "pov_settings": POV_DOZEN,
        "pov_default": "+A0.3 +R3",
        "pov_r4": "+A0.3 +R4",
    },
    "quality": {
        "raylab": "scenes/quality.toml",
        "raylab_args": ["--aperture", "0"],
        "pov": "benches/povray/quality.pov",
        "size": (640, 400),
        # 16 × 16 strata per pixel (each with the scene's glossy and shadow rays).
        "raylab_ref": ["--aa", "stratified", "--spp", "256"],
        # 2 × 2 pixels per final pixel, each supersampled 4 × 4 jittered + its centre.
        "pov_ref": {"scale": 2, "args": ["+A0.0", "+AM1", "+R4", "+J"]},
        "raylab_settings": RAYLAB_QUALITY,
        "pov_settings": POV_QUALITY,
        "pov_default": "+A0.3 +R3",
        "pov_r4": "+A0.3 +R4",
    },
}


def run(cmd, **kw):
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {shlex.join(cmd)}\n{p.stdout[-2000:]}\n{p.stderr[-4000:]}")
    return p


def raylab_render(exe, scene, out, args, threads, size):
    w, h = size
    cmd = [str(exe), "render", str(ROOT / scene), "-q", "--threads", str(threads), "--max-rays", str(10**15), "--stats", "--width", str(w), "--height", str(h), "-o", str(out)] + args
    p = run(cmd)
    m = re.search(r"trace ([0-9.]+) s \(([0-9.]+) CPU s\)", p.stdout)
    if not m:
        sys.exit(f"no trace time in raylab's output:\n{p.stdout}")
    cam = re.search(r"camera rays\s+(\d+)", p.stdout)
    return {"wall": float(m.group(1)), "cpu": float(m.group(2)), "camera_rays": int(cam.group(1)) if cam else None}


def pov_render(scene, out, w, h, args, threads):
    fmt = [] if any(x.startswith("+F") for x in args) else ["+FN"]
    cmd = ["povray", f"+I{ROOT / scene}", f"+W{w}", f"+H{h}", f"+O{out}", "-D", f"+WT{threads}"] + fmt + args
    p = run(cmd, cwd=out.parent)
    text = p.stdout + p.stderr
    m = re.search(r"Trace Time:.*?\(([0-9.]+) seconds\)\s+using \d+ thread\(s\) with ([0-9.]+) CPU-seconds", text, re.S)
    if not m:
        sys.exit(f"no trace time in POV-Ray's output:\n{text[-3000:]}")
    px = re.search(r"Pixels:\s+(\d+)\s+Samples:\s+(\d+)", text)
    return {"wall": float(m.group(1)), "cpu": float(m.group(2)), "camera_rays": int(px.group(1)) + int(px.group(2)) if px else None}


def load8(path):
    import numpy as np
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def errors(img, ref):
    import flip_evaluator as flip
    import numpy as np

    rmse = float(np.sqrt(np.mean((img - ref) ** 2)))
    _, f, _ = flip.evaluate(ref / 255.0, img / 255.0, "LDR", applyMagma=False)
    return {"rmse": rmse, "flip": float(f)}


def key(parts):
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:12]


def references(cfg, name, exe, out, threads):
    """Both renderers' converged references as 8-bit images, rendered once and cached."""
    import numpy as np
    from PIL import Image

    w, h = cfg["size"]
    # Keyed by the scene and the settings, not the binary: stratified sampling does not change
    # when the adaptive scheme does. Delete the file to render it again.
    rl_key = key([cfg["raylab"], (ROOT / cfg["raylab"]).read_text(), cfg.get("raylab_args", []) + cfg["raylab_ref"], w, h])
    rl = out / f"ref-raylab-{name}-{rl_key}.pfm"
    if not rl.exists():
        print(f"[{name}] raylab reference: {shlex.join(cfg['raylab_ref'])} …", flush=True)
        tmp = out / f"tmp-{rl.name}"
        raylab_render(exe, cfg["raylab"], tmp, cfg.get("raylab_args", []) + cfg["raylab_ref"], threads, (w, h))
        tmp.rename(rl)
    pr = cfg["pov_ref"]
    pov_key = key([cfg["pov"], (ROOT / cfg["pov"]).read_text(), pr, w, h, "ppm16"])
    pov = out / f"ref-pov-{name}-{pov_key}.png"
    if not pov.exists():
        s = pr["scale"]
        print(f"[{name}] POV-Ray reference: {w * s}×{h * s} {shlex.join(pr['args'])}, box-downsampled ×{s} …", flush=True)
        big = out / f"tmp-big-{name}.ppm"
        # 16-bit PPM: averaging 8-bit values would round twice, and the reference's rounding
        # contours would not match the renders' (FLIP sees them).
        pov_render(cfg["pov"], big, w * s, h * s, pr["args"] + ["+FP16"], threads)
        # Downsample in linear light, then encode back to sRGB (POV-Ray writes sRGB) and round
        # as POV-Ray does.
        a = read_ppm16(big)
        lin = np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)
        lin = lin.reshape(h, s, w, s, 3).mean(axis=(1, 3))
        enc = np.where(lin <= 0.0031308, lin * 12.92, 1.055 * lin ** (1 / 2.4) - 0.055)
        Image.fromarray(np.clip(np.floor(enc * 255.0 + 0.5), 0, 255).astype(np.uint8)).save(pov)
        big.unlink()
    return srgb8(read_pfm(rl)), load8(pov)


def read_ppm16(path):
    """A 16-bit binary PPM (POV-Ray's +FP16) as values in [0, 1]."""
    import numpy as np

    data = path.read_bytes()
    m = re.match(rb"P6\s+(?:#[^\n]*\n\s*)*(\d+)\s+(?:#[^\n]*\n\s*)*(\d+)\s+(?:#[^\n]*\n\s*)*(\d+)\s", data)
    w, h, mx = map(int, m.groups())
    assert mx == 65535, f"{path}: not a 16-bit PPM"
    return np.frombuffer(data[m.end():], dtype=">u2", count=w * h * 3).reshape(h, w, 3) / 65535.0


def read_pfm(path):
    """A colour PFM as a float array, top row first."""
    import numpy as np

    data = path.read_bytes()
    parts = data.split(maxsplit=4)
    assert parts[0] == b"PF", f"{path}: not a colour PFM"
    w, h, scale = int(parts[1]), int(parts[2]), float(parts[3])
    header = len(b" ".join(parts[:4])) + 1
    a = np.frombuffer(data[header:], dtype="<f4" if scale < 0 else ">f4", count=w * h * 3)
    return a.reshape(h, w, 3)[::-1].astype(np.float64)


def srgb8(lin):
    """Linear values as raylab writes them to 8 bits: clamped, sRGB-encoded, rounded."""
    import numpy as np

    v = np.clip(np.nan_to_num(lin), 0.0, 1.0)
    enc = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
    return np.floor(enc * 255.0 + 0.5)


def front(points):
    """The Pareto front of (time, error) points: ascending time, strictly falling error."""
    pts = sorted(points)
    out = []
    for t, e, label in pts:
        if not out or e < out[-1][1]:
            out.append((t, e, label))
    return out


def time_at(fr, e):
    """Time the front needs for error `e` (log-log interpolation); None outside its range."""
    if not fr or e > fr[0][1] * (1 + 1e-12):
        return fr[0][0] if fr and e >= fr[0][1] else None
    for (t1, e1, _), (t2, e2, _) in zip(fr, fr[1:]):
        if e2 <= e <= e1:
            if e1 == e2 or e <= 0:
                return t1
            a = (math.log(e) - math.log(e1)) / (math.log(e2) - math.log(e1))
            return math.exp(math.log(t1) + a * (math.log(t2) - math.log(t1)))
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--raylab", default=str(ROOT / "target/release/raylab"))
    ap.add_argument("--scenes", default="dozen")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "target/adaptive-bench"))
    ap.add_argument("--plot-dir", default=None, help="where adaptive-<scene>.png goes (default: --out)")
    ap.add_argument("--raylab-only", default=None, help="comma-separated labels: run only these raylab settings")
    ap.add_argument("--time", choices=["cpu", "wall"], default="cpu", help="which time the fronts use")
    ap.add_argument("--size", default=None, help="WxH: render at this size instead of the scene's (keep its aspect ratio: POV-Ray's twins fix it)")
    ap.add_argument("--ref-spp", type=int, default=None, help="samples per pixel of raylab's stratified reference instead of the scene's default")
    a = ap.parse_args()
    exe = Path(a.raylab).resolve()
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    for name in a.scenes.split(","):
        cfg = dict(SCENES[name])
        if a.size:
            m = re.fullmatch(r"([1-9][0-9]{0,4})x([1-9][0-9]{0,4})", a.size.lower())
            if not m:
                ap.error(f"--size {a.size!r}: expected WxH, e.g. 320x200")
            size = (int(m.group(1)), int(m.group(2)))
            if size[0] * cfg["size"][1] != size[1] * cfg["size"][0]:
                ap.error(f"--size {a.size}: {name} is {cfg['size'][0]}×{cfg['size'][1]}; keep its aspect ratio")
            cfg["size"] = size
        if a.ref_spp:
            i = cfg["raylab_ref"].index("--spp")
            cfg["raylab_ref"] = cfg["raylab_ref"][:i + 1] + [str(a.ref_spp)] + cfg["raylab_ref"][i + 2:]
        w, h = cfg["size"]
        ref_rl, ref_pov = references(cfg, name, exe, out, a.threads)
        rl_settings = cfg["raylab_settings"]
        if a.raylab_only:
            keep = set(a.raylab_only.split(","))
            rl_settings = [s for s in rl_settings if s[0] in keep]
        jobs = []
        for i in range(max(len(rl_settings), len(cfg["pov_settings"]))):
            if i < len(rl_settings):
                jobs.append(("raylab", *rl_settings[i]))
            if i < len(cfg["pov_settings"]):
                jobs.append(("povray", *cfg["pov_settings"][i]))
        results = {}
        load = os.getloadavg()
        print(f"[{name}] {len(jobs)} settings × {a.rounds} rounds, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", flush=True)
        t0 = time.time()
        for r in range(a.rounds):
            for renderer, label, args in jobs:
                img = out / f"{name}-{renderer}-{key([label, args])}.png"
                if renderer == "raylab":
                    m = raylab_render(exe, cfg["raylab"], img, cfg.get("raylab_args", []) + args, a.threads, (w, h))
                else:
                    m = pov_render(cfg["pov"], img, w, h, args, a.threads)
                res = results.setdefault((renderer, label), {"renderer": renderer, "label": label, "args": args, "cpu": [], "wall": [], "image": str(img)})
                res["cpu"].append(m["cpu"])
                res["wall"].append(m["wall"])
                res["camera_rays"] = m["camera_rays"]
                if r == 0:
                    res.update(errors(load8(img), ref_rl if renderer == "raylab" else ref_pov))
            print(f"  round {r + 1}/{a.rounds} done ({time.time() - t0:.0f} s)", flush=True)
        load = os.getloadavg()
        rows = list(results.values())
        for row in rows:
            for k in ("cpu", "wall"):
                v = sorted(row[k])
                row[k + "_median"] = v[len(v) // 2]
        report(name, cfg, rows, out, Path(a.plot_dir).resolve() if a.plot_dir else out, a.time, load)


def report(name, cfg, rows, out, plot_dir, tkey, load):
    tk = tkey + "_median"
    by = {(r["renderer"], r["label"]): r for r in rows}
    with open(out / f"{name}-results.csv", "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["renderer", "setting", "cpu_s", "wall_s", "camera_rays", "rmse_8bit", "flip"])
        for r in sorted(rows, key=lambda r: (r["renderer"], r[tk])):
            wr.writerow([r["renderer"], r["label"], f"{r['cpu_median']:.4f}", f"{r['wall_median']:.4f}", r["camera_rays"], f"{r['rmse']:.4f}", f"{r['flip']:.5f}"])
    (out / f"{name}-results.json").write_text(json.dumps(rows, indent=1))
    print(f"\n## {name} (times: median {tkey} seconds of the rounds; load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f})\n")
    print("| renderer | setting | CPU s | wall s | camera rays/px | RMSE (8-bit) | FLIP |")
    print("|---|---|---:|---:|---:|---:|---:|")
    w, h = cfg["size"]
    for r in sorted(rows, key=lambda r: (r["renderer"], r[tk])):
        cr = f"{r['camera_rays'] / (w * h):.2f}" if r["camera_rays"] else "?"
        print(f"| {r['renderer']} | {r['label']} | {r['cpu_median']:.3f} | {r['wall_median']:.3f} | {cr} | {r['rmse']:.3f} | {r['flip']:.5f} |")
    summary = {}
    for metric in ("rmse", "flip"):
        fr = {rd: front([(r[tk], r[metric], r["label"]) for r in rows if r["renderer"] == rd]) for rd in ("raylab", "povray")}
        d, r4 = by[("povray", cfg["pov_default"])][metric], by[("povray", cfg["pov_r4"])][metric]
        lo = fr["povray"][-1][1]
        targets = [("POV default", d), ("POV +R4", r4)]
        if lo < r4:
            targets += [("between", math.sqrt(r4 * lo)), ("POV best", lo)]
        print(f"\n{metric.upper()}: fronts — raylab: {', '.join(l for _, _, l in fr['raylab'])}; POV-Ray: {', '.join(l for _, _, l in fr['povray'])}\n")
        print(f"| target | {metric} | raylab {tkey} s | POV-Ray {tkey} s | raylab ÷ POV-Ray |")
        print("|---|---:|---:|---:|---:|")
        summary[metric] = []
        for label, e in targets:
            tr, tp = time_at(fr["raylab"], e), time_at(fr["povray"], e)
            ratio = tr / tp if tr and tp else None
            summary[metric].append({"target": label, "error": e, "raylab": tr, "povray": tp, "ratio": ratio})
            f = lambda v: "n/a" if v is None else f"{v:.3f}"
            print(f"| {label} | {e:.4g} | {f(tr)} | {f(tp)} | {f(ratio)} |")
    (out / f"{name}-ratios.json").write_text(json.dumps(summary, indent=1))
    plot(name, rows, plot_dir, tk, tkey, summary)


def plot(name, rows, plot_dir, tk, tkey, summary):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    style = {"raylab": ("tab:blue", "o"), "povray": ("tab:red", "s")}
    for ax, metric in zip(axes, ("rmse", "flip")):
        for rd, (c, mk) in style.items():
            pts = [(r[tk], r[metric]) for r in rows if r["renderer"] == rd]
            ax.scatter([p[0] for p in pts], [p[1] for p in pts], color=c, marker=mk, s=14, alpha=0.45)
            fr = front([(r[tk], r[metric], r["label"]) for r in rows if r["renderer"] == rd])
            ax.plot([p[0] for p in fr], [p[1] for p in fr], color=c, lw=1.6, label=("raylab adaptive" if rd == "raylab" else "POV-Ray 3.7 +AM2") + " (front)")
        for s in summary[metric][:2]:
            ax.axhline(s["error"], color="grey", lw=0.7, ls=":")
            ax.annotate(s["target"], (ax.get_xlim()[0] if False else 0, s["error"]), xycoords=("axes fraction", "data"), fontsize=7, color="grey", va="bottom")
        ax.set_xscale("log")
        ax.set_yscale("log")
        # Plain numbers on the time axis, minor ticks labelled at 2 and 5 only (all overlap).
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}" if round(v / 10 ** math.floor(math.log10(v))) in (2, 5) else ""))
        ax.set_xlabel(f"trace time, {tkey} seconds (2 threads)")
        ax.set_ylabel("RMSE, 8-bit levels" if metric == "rmse" else "mean FLIP")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=8)
    fig.suptitle(f"{name}: error against own converged reference vs time")
    fig.tight_layout()
    plot_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(plot_dir / f"adaptive-{name}.png", dpi=110)
    print(f"\nplot: {plot_dir / f'adaptive-{name}.png'}")


if __name__ == "__main__":
    main()
