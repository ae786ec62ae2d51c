#!/usr/bin/env python3
"""Render to an error (issue 30): how honest the error estimate is, what adaptive sampling buys at
equal error, and what the denoiser buys and where it stops paying (its bias floor).

    python3 benches/error/run.py RAYLAB [--scenes path-cornell,pbr-spheres,environment,quality]
        [--scale 1] [--ref-spp N] [--max-spp 1024] [--no-targets] [--out target/error-bench]
        [--plot docs/error-trade.png]

For each scene (small sizes: a loaded machine), against a high-sample reference rendered once and
cached in --out:

- uniform renders at 1, 2, 4, … --max-spp samples per pixel, each also with `--denoise`;
- renders to error targets (`--target-error`, `--spp` 4 × --max-spp as the cap), each with
  `--target-seeds` seeds, and the first seed's also with `--denoise` (adaptive sampling and the
  denoiser together): the estimate's honesty under a target is the RMS over seeds of the
  estimate against the RMS of the true error (on a scene lit by rare bright paths one render's
  true error is itself a noisy number).

The reference is rendered a second time with another seed: half the mean squared difference of the
two is the reference's own squared error, which the true errors of tables (a) and (b) have removed
(on environment it is most of a tight target's measured error). The denoised rows are measured
against the reference as is.

Errors are taken against the reference three ways: the relative RMSE of luminance (linear HDR, the
quantity the error estimate predicts, table (a)); the RMSE of displayed values (clamped,
sRGB-encoded, as `raylab sweep` measures: in HDR the light's own pixels, far brighter than the
rest, decide alone, and a denoiser that softens their edges loses by them whatever it does
elsewhere); and mean ꟻLIP (LDR, on the same displayed values; the `flip-evaluator` package,
NVIDIA's reference implementation). Work is measured in samples per
pixel (camera rays; the mean under a target) and in CPU seconds of the whole command (user +
system of raylab and the denoiser it runs, from getrusage: other processes on a busy machine do
not inflate them, though a loaded machine's caches do a little). "Uniform spp at that error"
interpolates the uniform curve log-log between its measured points.

Needs numpy, flip-evaluator and matplotlib; the denoised rows need `oidnDenoise`
(`pip install pyoidn`). Prints markdown tables; writes rows.json and the plot.
"""
import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
L = np.array([0.2126, 0.7152, 0.0722])

# name: (scene file, width, height, reference spp, what it is)
SCENES = {
    "path-cornell": ("scenes/path-cornell.toml", 64, 64, 16384, "path tracer, the Cornell box"),
    "pbr-spheres": ("scenes/pbr-spheres.toml", 96, 40, 8192, "path tracer, metal/glass/plastic spheres"),
    "environment": ("scenes/environment.toml", 96, 54, 8192, "path tracer, an environment light"),
    "quality": ("scenes/quality.toml", 80, 50, 8192, "phong, soft shadows (area lights) and glossy rays"),
}

# Error targets (`--target-error`): under the target's proportional allocation a pixel's samples
# grow as 1 / E, so halving E doubles them; these span about 16 … 2000 spp on path-cornell.
TARGETS = [0.2, 0.1, 0.05, 0.025, 0.0125, 0.006, 0.003, 0.0015]


def pfm(path):
    b = open(path, "rb").read()
    magic, size, scale, data = b.split(b"\n", 3)
    w, h = map(int, size.split())
    return np.frombuffer(data, dtype="<f4").reshape(h, w, 3)[::-1]


def srgb(img):
    c = np.clip(img, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055).astype(np.float32)


def cpu_of(cmd, env):
    """Runs `cmd`; its stdout and the CPU seconds it and its children took."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    text = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env, cwd=ROOT).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return text, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def rays(text):
    m = re.search(r"([0-9.]+) ?([kMG]?) rays,", text)
    if not m:
        return float("nan")
    return float(m.group(1)) * {"": 1, "k": 1e3, "M": 1e6, "G": 1e9}[m.group(2)]


class Bench:
    def __init__(self, raylab, out, env):
        self.raylab, self.out, self.env = raylab, out, env

    def render(self, scene, w, h, path, *extra, seed=1):
        cmd = [self.raylab, "render", scene, "--width", str(w), "--height", str(h), "-o", path, "-q", "--seed", str(seed), "--threads", "2", *extra]
        text, cpu = cpu_of(cmd, self.env)
        # No estimate below two samples a pixel (its halves need one each).
        est = re.search(r"relative RMSE ([0-9.]+) %.*?([0-9.]+) spp on average", text, re.S)
        return {
            "estimate": float(est.group(1)) / 100 if est else None,
            "mean_spp": float(est.group(2)) if est else None,
            "cpu": cpu,
            "rays": rays(text),
        }


def rel_rmse(img, ref):
    a, r = img @ L, ref @ L
    return float(np.sqrt(np.mean((a - r) ** 2)) / np.mean(r))


def display_rmse(img, ref):
    """RMSE of displayed values (clamped, sRGB-encoded, not quantised), as `raylab sweep`: the
    light's own pixels, far brighter than the rest, do not decide it alone."""
    return float(np.sqrt(np.mean((srgb(img) - srgb(ref)) ** 2)))


def flip(img, ref):
    import flip_evaluator

    _, f, _ = flip_evaluator.evaluate(srgb(ref), srgb(img), "LDR", applyMagma=False)
    return float(f)


def loglog(points, x=None, y=None):
    """Log-log interpolation on the (spp, value) points: the value at spp `x`, or the spp at
    value `y` (on the first segment that brackets it; extrapolated along the end segments)."""
    pts = sorted(points)
    segs = list(zip(pts, pts[1:]))
    i = 0 if x is not None else 1
    want = x if x is not None else y
    seg = next(((p, q) for p, q in segs if min(p[i], q[i]) <= want <= max(p[i], q[i])), None)
    if seg is None:
        seg = segs[0] if (want < pts[0][0] if x is not None else want > pts[0][1]) else segs[-1]
    (s0, v0), (s1, v1) = seg
    if min(s0, s1, v0, v1) <= 0 or (y is not None and v0 == v1):
        return float("nan")
    if x is not None:
        t = (math.log(x) - math.log(s0)) / (math.log(s1) - math.log(s0))
        return math.exp(math.log(v0) + t * (math.log(v1) - math.log(v0)))
    t = (math.log(y) - math.log(v0)) / (math.log(v1) - math.log(v0))
    return math.exp(math.log(s0) + t * (math.log(s1) - math.log(s0)))


def spp_at(points, err):
    """The uniform samples per pixel at which the error `err` is reached."""
    return loglog(points, y=err)


def value_at(points, spp):
    """A measured quantity (CPU seconds) of the uniform renders at `spp`."""
    return loglog(points, x=spp)


def reference(b, name, scene, w, h, ref_spp, seed):
    """The reference image of seed `seed` (rendered once, cached in --out)."""
    suffix = "" if seed == 12345 else f"-seed{seed}"
    ref_path = os.path.join(b.out, f"{name}-{w}x{h}-ref{ref_spp}{suffix}.pfm")
    if not os.path.exists(ref_path):
        print(f"[{name}] reference: {ref_spp} spp, seed {seed} …", file=sys.stderr, flush=True)
        cmd = [b.raylab, "render", scene, "--width", str(w), "--height", str(h), "--spp", str(ref_spp), "--seed", str(seed),
               "-o", ref_path + ".tmp.pfm", "-q", "--threads", "2", "--max-rays", str(2**63)]
        cpu_of(cmd, b.env)
        os.rename(ref_path + ".tmp.pfm", ref_path)
    return pfm(ref_path)


def less_noise(err, noise):
    """An error measured against a reference with its own error `noise` (independent), without it."""
    return math.sqrt(max(err * err - noise * noise, 0.0))


def measure(b, name, cfg, max_spp, scale, target_seeds=3, denoise=True, targets=TARGETS, ref_spp=None):
    file, w, h, scene_ref_spp, _ = cfg
    ref_spp = ref_spp or scene_ref_spp
    w, h = w * scale, h * scale
    scene = os.path.join(ROOT, file)
    ref = reference(b, name, scene, w, h, ref_spp, 12345)
    other = reference(b, name, scene, w, h, ref_spp, 54321)
    # Each reference's own error: the two differ by √2 times it.
    noise = {"rmse": rel_rmse(other, ref) / math.sqrt(2), "disp": display_rmse(other, ref) / math.sqrt(2)}
    out = os.path.join(b.out, f"{name}-x.pfm")
    rows = {"uniform": [], "denoised": [], "target": []}
    spps = [2**k for k in range(int(math.log2(max_spp)) + 1)]
    for spp in spps:
        print(f"[{name}] {spp} spp …", file=sys.stderr, flush=True)
        r = b.render(scene, w, h, out, "--spp", str(spp))
        img = pfm(out)
        rows["uniform"].append(dict(r, spp=spp, mean_spp=spp, rmse=rel_rmse(img, ref), disp=display_rmse(img, ref), flip=flip(img, ref)))
        if denoise and b.env.get("RAYLAB_OIDN"):
            r = b.render(scene, w, h, out, "--spp", str(spp), "--denoise")
            img = pfm(out)
            rows["denoised"].append(dict(r, spp=spp, mean_spp=spp, rmse=rel_rmse(img, ref), disp=display_rmse(img, ref), flip=flip(img, ref)))
    for target in targets:
        print(f"[{name}] target {target} …", file=sys.stderr, flush=True)
        r = b.render(scene, w, h, out, "--spp", str(4 * max_spp), "--target-error", str(target), "--max-rays", str(2**63))
        img = pfm(out)
        row = dict(r, target=target, rmse=rel_rmse(img, ref), disp=display_rmse(img, ref), flip=flip(img, ref))
        # The same target with other seeds: the estimate's honesty over seeds.
        seeds = [{"seed": 1, "estimate": r["estimate"], "mean_spp": r["mean_spp"], "rmse": row["rmse"]}]
        for seed in range(2, target_seeds + 1):
            rs = b.render(scene, w, h, out, "--spp", str(4 * max_spp), "--target-error", str(target), "--max-rays", str(2**63), seed=seed)
            seeds.append({"seed": seed, "estimate": rs["estimate"], "mean_spp": rs["mean_spp"], "rmse": rel_rmse(pfm(out), ref)})
        row["seeds"] = seeds
        rows["target"].append(row)
        if denoise and b.env.get("RAYLAB_OIDN"):
            # Adaptive sampling and the denoiser together (seed 1), as production renderers use
            # them: the target spends its samples where the noise is, the denoiser removes the rest.
            r = b.render(scene, w, h, out, "--spp", str(4 * max_spp), "--target-error", str(target), "--max-rays", str(2**63), "--denoise")
            img = pfm(out)
            rows.setdefault("target_denoised", []).append(dict(r, target=target, rmse=rel_rmse(img, ref), disp=display_rmse(img, ref), flip=flip(img, ref)))
    return {"scene": name, "file": file, "size": [w, h], "ref_spp": ref_spp, "ref_noise": noise, "rows": rows}


def report(results, max_spp):
    names = ", ".join(f"{r['scene']} {r['size'][0]}×{r['size'][1]} (reference {r['ref_spp']} spp)" for r in results)
    print(f"# Render to an error: {names}\n")
    print("## (a) estimated against true relative RMSE (uniform sampling)\n")
    print("True: against the reference; then without the reference's own error (its noise, from a second seed).\n")
    print("| scene | spp | estimated | true | true, reference noise removed | estimated ÷ that |\n|---|---|---|---|---|---|")
    for res in results:
        noise = res.get("ref_noise", {"rmse": 0.0, "disp": 0.0})
        for r in res["rows"]["uniform"]:
            if r["estimate"] is not None and r["spp"] >= 4:
                t = less_noise(r["rmse"], noise["rmse"])
                print(f"| {res['scene']} | {r['spp']} | {r['estimate']:.4f} | {r['rmse']:.4f} | {t:.4f} | {r['estimate'] / t:.2f} |")
    if any(r.get("seeds") for res in results for r in res["rows"]["target"]):
        print("\n## (a′) estimated against true relative RMSE under error targets\n")
        print("Over the seeds of each target: the RMS of the estimates and of the true errors (reference noise removed).\n")
        print("| scene | target | seeds | mean spp | estimated | true | estimated ÷ true |\n|---|---|---|---|---|---|---|")
        for res in results:
            noise = res.get("ref_noise", {"rmse": 0.0})["rmse"]
            for r in res["rows"]["target"]:
                sd = r.get("seeds") or []
                if not sd:
                    continue
                est = math.sqrt(sum(x["estimate"] ** 2 for x in sd) / len(sd))
                true = less_noise(math.sqrt(sum(x["rmse"] ** 2 for x in sd) / len(sd)), noise)
                spp = sum(x["mean_spp"] for x in sd) / len(sd)
                r["honesty"] = est / true
                print(f"| {res['scene']} | {r['target']} | {len(sd)} | {spp:.1f} | {est:.4f} | {true:.4f} | {est / true:.2f} |")
    print("\n## (b) adaptive sampling to a target against uniform sampling, at equal error\n")
    print("Ratios are the target's work ÷ uniform sampling's at the same error (below 1: adaptive wins); RMSE with the "
          "reference's noise removed from both (seed 1 of each).\n")
    print("| scene | target | mean spp | rel. RMSE (HDR) | spp ratio | RMSE (displayed) | uniform spp at it | spp ratio | CPU ratio | ꟻLIP | uniform spp at it | spp ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for res in results:
        u = res["rows"]["uniform"]
        cpu = [(r["spp"], r["cpu"]) for r in u]
        noise = res.get("ref_noise", {})
        clean = lambda row, key: less_noise(row[key], noise.get(key, 0.0))  # noqa: E731
        for r in res["rows"]["target"]:
            for key in ("rmse", "disp", "flip"):
                r[f"uniform_spp_{key}"] = spp_at([(x["spp"], clean(x, key)) for x in u], clean(r, key))
                r[f"spp_ratio_{key}"] = r["mean_spp"] / r[f"uniform_spp_{key}"]
            s = r["uniform_spp_disp"]
            r["cpu_ratio_disp"] = r["cpu"] / value_at(cpu, s) if s == s else float("nan")
            print(f"| {res['scene']} | {r['target']} | {r['mean_spp']:.1f} | {clean(r, 'rmse'):.4f} | {r['spp_ratio_rmse']:.2f} | {clean(r, 'disp'):.4f} | "
                  f"{s:.1f} | {r['spp_ratio_disp']:.2f} | {r['cpu_ratio_disp']:.2f} | {r['flip']:.4f} | {r['uniform_spp_flip']:.1f} | {r['spp_ratio_flip']:.2f} |")
    if not any(res["rows"]["denoised"] for res in results):
        print("\n(no denoiser: the denoised rows were skipped)")
        return
    print("\n## (c) the denoiser: error of the denoised image, and the uniform spp the noisy render needs for it\n")
    print("| scene | spp | RMSE noisy | RMSE denoised | saving (RMSE) | ꟻLIP noisy | ꟻLIP denoised | saving (ꟻLIP) | CPU s noisy | CPU s denoised |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for res in results:
        u, d = res["rows"]["uniform"], res["rows"]["denoised"]
        for n, r in zip(u, d):
            for key in ("disp", "flip"):
                r[f"saving_{key}"] = spp_at([(x["spp"], x[key]) for x in u], r[key]) / r["spp"]
            print(f"| {res['scene']} | {r['spp']} | {n['disp']:.4f} | {r['disp']:.4f} | {r['saving_disp']:.1f}× | {n['flip']:.4f} | "
                  f"{r['flip']:.4f} | {r['saving_flip']:.1f}× | {n['cpu']:.2f} | {r['cpu']:.2f} |")
    print(f"\n### Bias floor, and the error of a {max_spp}-spp render\n")
    print("The bias floor: the spp from which the noisy render is at least as good as the denoised one at the same spp "
          f"(from there on, denoising loses). Then the fewest spp whose denoised image is as good as the noisy {max_spp}-spp "
          "render, and its CPU seconds (render and denoiser) ÷ the noisy render's.\n")
    print("| scene | bias floor (RMSE) | bias floor (ꟻLIP) | denoised spp at the noisy RMSE | CPU ratio | denoised spp at the noisy ꟻLIP | CPU ratio |")
    print("|---|---|---|---|---|---|---|")
    for res in results:
        u, d = res["rows"]["uniform"], res["rows"]["denoised"]
        cells = [res["scene"]]
        for key in ("disp", "flip"):
            wins = [n["spp"] for n, r in zip(u, d) if n[key] <= r[key]]
            cells.append(f"{wins[0]} spp" if wins else f"> {max_spp} spp")
        summary = {}
        for key in ("disp", "flip"):
            goal = u[-1][key]
            hit = next((r for r in d if r[key] <= goal), None)
            if hit is None:
                cells += ["not reached", "—"]
                summary[key] = None
            else:
                ratio = hit["cpu"] / u[-1]["cpu"]
                cells += [f"{hit['spp']} spp", f"{ratio:.3f}"]
                summary[key] = {"spp": hit["spp"], "cpu_ratio": ratio}
        res["denoise_target"] = summary
        print("| " + " | ".join(cells) + " |")
    print(f"\n### The spp at the noisy {max_spp}-spp error, interpolated\n")
    print(f"Log-log between the measured counts: the samples per pixel (the mean, under a target) at which each way reaches the "
          f"noisy {max_spp}-spp render's error, ÷ {max_spp}; then the CPU seconds (render and denoiser) interpolated the same way "
          f"at that count, ÷ the noisy {max_spp}-spp render's (the target of issue 30: ≤ 0.2×).\n")
    print("| scene | by | uniform + denoiser | ratio | CPU ratio | error target + denoiser | ratio | CPU ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for res in results:
        u, d, td = res["rows"]["uniform"], res["rows"]["denoised"], res["rows"].get("target_denoised", [])
        res["denoise_crossing"] = {}
        for key in ("disp", "flip"):
            goal = u[-1][key]
            cells = [res["scene"], {"disp": "RMSE", "flip": "ꟻLIP"}[key]]
            crossing = {}
            for name, rows, x in (("uniform", d, "spp"), ("target", td, "mean_spp")):
                pts = [(r[x], r[key]) for r in rows]
                reached = len(pts) >= 2 and min(v for _, v in pts) <= goal
                spp = spp_at(pts, goal) if reached else float("nan")
                crossing[name] = spp if spp == spp else None
                cpu = value_at([(r[x], r["cpu"]) for r in rows], spp) / u[-1]["cpu"] if spp == spp else float("nan")
                if spp == spp:
                    crossing[f"{name}_cpu_ratio"] = cpu
                cells += [f"{spp:.0f} spp", f"{spp / max_spp:.2f}", f"{cpu:.2f}"] if spp == spp else ["not reached" if pts else "—", "—", "—"]
            res["denoise_crossing"][key] = crossing
            print("| " + " | ".join(cells) + " |")


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(3.4 * len(results), 3.3), squeeze=False)
    for ax, res in zip(axes[0], results):
        u, d, t = res["rows"]["uniform"], res["rows"]["denoised"], res["rows"]["target"]
        ax.loglog([r["spp"] for r in u], [r["disp"] for r in u], "o-", color="#444", ms=3, label="uniform")
        if d:
            ax.loglog([r["spp"] for r in d], [r["disp"] for r in d], "s-", color="#2a7", ms=3, label="uniform + denoiser")
        ax.loglog([r["mean_spp"] for r in t], [r["disp"] for r in t], "^--", color="#c42", ms=4, label="error target (mean spp)")
        td = res["rows"].get("target_denoised", [])
        if td:
            ax.loglog([r["mean_spp"] for r in td], [r["disp"] for r in td], "v--", color="#27c", ms=4, label="error target + denoiser")
        ax.set_title(f"{res['scene']} ({res['size'][0]}×{res['size'][1]})", fontsize=9)
        ax.set_xlabel("samples per pixel (camera rays)", fontsize=8)
        ax.tick_params(which="both", labelsize=7)
        ax.grid(True, which="both", alpha=0.25)
    axes[0][0].set_ylabel("RMSE of displayed values", fontsize=8)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("raylab")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--scale", type=int, default=1, help="multiply every scene's size by this")
    ap.add_argument("--max-spp", type=int, default=1024)
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "error-bench"))
    ap.add_argument("--plot", help="write the plot here (PNG)")
    ap.add_argument("--from-json", help="report and plot the rows.json of an earlier run instead of rendering")
    ap.add_argument("--target-seeds", type=int, default=3, help="seeds of each error target, for the estimate's honesty (table (a′))")
    ap.add_argument("--no-denoise", action="store_true", help="skip the denoised renders")
    ap.add_argument("--no-targets", action="store_true", help="skip the error targets (tables (a′) and (b)): uniform and denoised rows only")
    ap.add_argument("--ref-spp", type=int, help="the references' samples per pixel instead of each scene's own (e.g. 8192 at --scale 2)")
    ap.add_argument("--keep", help="a rows.json whose denoised rows to keep for scenes this run does not denoise")
    a = ap.parse_args()
    if a.from_json:
        with open(a.from_json) as f:
            results = json.load(f)
        report(results, a.max_spp)
        if a.plot:
            plot(results, a.plot)
        return
    os.makedirs(a.out, exist_ok=True)
    env = dict(os.environ)
    try:
        # Found once, so the denoised commands do not each ask python3 where it is.
        path = subprocess.run([sys.executable, "-c", "import os, pyoidn; print(os.path.join(os.path.dirname(pyoidn.__file__), 'oidn', 'bin', 'oidnDenoise'))"],
                              capture_output=True, text=True, check=True).stdout.strip()
        env.setdefault("RAYLAB_OIDN", path)
    except subprocess.CalledProcessError:
        print("no pyoidn: the denoised rows are skipped (pip install pyoidn)", file=sys.stderr)
    b = Bench(os.path.abspath(a.raylab), a.out, env)
    targets = [] if a.no_targets else TARGETS
    results = [measure(b, n, SCENES[n], a.max_spp, a.scale, a.target_seeds, not a.no_denoise, targets, a.ref_spp) for n in a.scenes.split(",")]
    if a.keep:
        with open(a.keep) as f:
            kept = {r["scene"]: r for r in json.load(f)}
        for r in results:
            if not r["rows"]["denoised"] and r["scene"] in kept:
                r["rows"]["denoised"] = kept[r["scene"]]["rows"]["denoised"]
    report(results, a.max_spp)
    with open(os.path.join(a.out, "rows.json"), "w") as f:
        json.dump(results, f, indent=1)
    if a.plot:
        plot(results, a.plot)


if __name__ == "__main__":
    main()
