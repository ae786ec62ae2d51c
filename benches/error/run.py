#!/usr/bin/env python3
"""Render to an error: how honest the error estimate is, and what adaptive sampling and the
denoiser buy, on one scene (issue 30). Measured in samples per pixel and camera-ray work, which do
not depend on how busy the machine is; time follows them (the path tracer's time per sample is
about constant), and the script prints CPU seconds too.

    python3 benches/error/run.py RAYLAB SCENE [--size 128] [--ref-spp 4096] [--out DIR]

Needs numpy; the denoiser rows need `oidnDenoise` (`pip install pyoidn`).
"""
import argparse, os, re, subprocess, sys
import numpy as np

L = np.array([0.2126, 0.7152, 0.0722])


def pfm(path):
    b = open(path, "rb").read()
    magic, size, scale, data = b.split(b"\n", 3)
    w, h = map(int, size.split())
    return np.frombuffer(data, dtype="<f4").reshape(h, w, 3)[::-1]


def render(raylab, scene, size, out, *extra):
    cmd = [raylab, "render", scene, "--width", str(size), "--height", str(size), "-o", out, "-q", "--seed", "1", *extra]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    est = re.search(r"relative RMSE ([0-9.]+) %.*?([0-9.]+) spp on average", text, re.S)
    cpu = re.search(r"\(([0-9.]+) CPU s\)", text)
    return float(est.group(1)) / 100, float(est.group(2)), float(cpu.group(1)) if cpu else float("nan")


def rel_rmse(img, ref):
    a, r = img @ L, ref @ L
    return float(np.sqrt(np.mean((a - r) ** 2)) / np.mean(r))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("raylab")
    ap.add_argument("scene")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--out", default="target/error-bench")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    name = os.path.splitext(os.path.basename(a.scene))[0]
    ref_path = os.path.join(a.out, f"{name}-{a.size}-ref{a.ref_spp}.pfm")
    if not os.path.exists(ref_path):
        subprocess.run([a.raylab, "render", a.scene, "--width", str(a.size), "--height", str(a.size), "--spp", str(a.ref_spp),
                        "--seed", "12345", "-o", ref_path, "-q"], check=True, capture_output=True)
    ref = pfm(ref_path)
    out = os.path.join(a.out, "x.pfm")
    print(f"# {name}, {a.size}×{a.size}, reference {a.ref_spp} spp (its own error is about √(spp/{a.ref_spp}) of a row's)")
    print("\n## (a) estimated against true relative RMSE (luminance), uniform sampling")
    print("| spp | estimated | true | ratio |\n|---|---|---|---|")
    uniform = []
    for spp in [4, 16, 64, 256]:
        est, mean_spp, cpu = render(a.raylab, a.scene, a.size, out, "--spp", str(spp))
        true = rel_rmse(pfm(out), ref)
        uniform.append((mean_spp, true, cpu))
        print(f"| {spp} | {est:.4f} | {true:.4f} | {est / true:.2f} |")
    print("\n## (b) adaptive sampling to a target: samples for the error it reaches")
    print("| target | mean spp | estimated | true | uniform spp for that true error | saving |\n|---|---|---|---|---|---|")
    # Uniform error against spp follows c/√spp: fitted on the uniform rows.
    c = np.exp(np.mean([np.log(t) + 0.5 * np.log(s) for s, t, _ in uniform[1:]]))
    for target in [0.2, 0.1, 0.05]:
        est, mean_spp, cpu = render(a.raylab, a.scene, a.size, out, "--spp", "1024", "--target-error", str(target))
        true = rel_rmse(pfm(out), ref)
        need = (c / true) ** 2
        print(f"| {target} | {mean_spp:.1f} | {est:.4f} | {true:.4f} | {need:.0f} | {need / mean_spp:.2f}× |")
    print("\n## (c) the denoiser: true error of the denoised image, and the uniform spp the noisy render needs for it")
    print("| spp | noisy | denoised | uniform spp for the denoised error | saving |\n|---|---|---|---|---|")
    try:
        for spp in [1, 4, 16, 64, 256]:
            render(a.raylab, a.scene, a.size, out, "--spp", str(spp), "--denoise")
            true = rel_rmse(pfm(out), ref)
            need = (c / true) ** 2
            noisy = c / np.sqrt(spp)
            print(f"| {spp} | {noisy:.4f} | {true:.4f} | {need:.0f} | {need / spp:.1f}× |")
    except subprocess.CalledProcessError as e:
        print(f"(denoiser rows skipped: {e.stderr.strip()})")


if __name__ == "__main__":
    main()
