"""Prints run.sh's tables from its results file (workload, threads, run, renderer, metric, value).

Ratios are formed per run (raylab and the peer ran one after the other) and summarised as the
median with the range over runs: `0.28 (0.27–0.29)`. Rate ratios are raylab ÷ peer (> 1: raylab
is faster); for times of equal work the ratio is peer time ÷ raylab time, the same thing.
"""

import statistics
import sys
from collections import defaultdict

# Rounds in which other processes took at most this much CPU time count as quiet.
QUIET_CPU_S = 0.1


def main():
    results, equal, runs, seconds, load_end = sys.argv[1:6]
    v = defaultdict(dict)  # (workload, threads, renderer, metric) -> {run: value}
    for line in open(results):
        w, t, i, r, m, x = line.rstrip("\n").split("\t")
        if x == "":
            continue
        v[(w, int(t), r, m)][int(i)] = float(x)

    def med(key):
        xs = list(v.get(key, {}).values())
        return statistics.median(xs) if xs else None

    def quiet(key, i):
        return v.get((key[0], key[1], "others", "cpu_s"), {}).get(i, 0.0) <= QUIET_CPU_S

    def ratio(a, b, invert=False):
        """Per-run a/b (or b/a), as 'median (min–max)'; when some rounds were disturbed by other
        processes, also the median over the quiet rounds alone."""
        A, B = v.get(a, {}), v.get(b, {})
        runs_ = [i for i in A if i in B and A[i] > 0 and B[i] > 0]
        rs = {i: (B[i] / A[i]) if invert else (A[i] / B[i]) for i in runs_}
        if not rs:
            return "–"
        xs = list(rs.values())
        m = statistics.median(xs)
        text = f"**{m:.2f}** ({min(xs):.2f}–{max(xs):.2f})" if len(xs) > 1 else f"**{m:.2f}**"
        calm = [rs[i] for i in runs_ if quiet(a, i)]
        if 0 < len(calm) < len(xs):
            text += f"; quiet rounds {statistics.median(calm):.2f} [{len(calm)}/{len(xs)}]"
        return text

    def fmt(x, unit=""):
        if x is None:
            return "–"
        if unit == "M":
            return f"{x / 1e6:.2f} M"
        if unit == "s":
            return f"{x:.3f}"
        return f"{x:.1f}"

    threads = sorted({k[1] for k in v if k[0] == "bunny"})
    out = []
    p = out.append
    others = {k: d for k, d in v.items() if k[2] == "others"}
    total = sum(x for d in others.values() for x in d.values())
    worst = max(((x, k[0], k[1], i) for k, d in others.items() for i, x in d.items()), default=None)
    p(f"{runs} runs per row, alternating; whole run {int(seconds) // 60} min {int(seconds) % 60} s; load average at the end {load_end}.")
    if worst:
        p(
            f"Other processes on the machine took {total:.1f} CPU-s during the rounds in all; the most in one round "
            f"{worst[0]:.2f} CPU-s ({worst[1]}, {worst[2]} thread(s), run {worst[3]}). Each round waited for a quiet second first; "
            f"where some rounds of a row were disturbed (others > {QUIET_CPU_S} CPU-s), the median of the quiet ones follows as `quiet rounds R [n/N]`."
        )
    p("")
    p(open(equal).read().rstrip())
    p("")
    p("### Bunny shot: a real render (camera ray + shadow ray per hit pixel, shading included), rays/s from wall-clock trace time")
    p("")
    p("| threads | peer | raylab rays/s | peer rays/s (or render s) | raylab ÷ peer (rate) |")
    p("|---:|---|---:|---:|---:|")
    peers = [
        ("embree3", "Embree 3.13 C++, rtcIntersect1/rtcOccluded1, default build (medium quality, not robust)"),
        ("embree3-robust", "Embree 3.13 C++, same, RTC_SCENE_FLAG_ROBUST (watertight like raylab)"),
        ("embreex4", "Embree 4 via embreex (single rays in Cython, numpy glue; wall)"),
    ]
    for t in threads:
        rl = ("bunny", t, "raylab", "rays_per_s")
        for key, name in peers:
            pk = ("bunny", t, key, "rays_per_s")
            if pk in v:
                p(f"| {t} | {name} | {fmt(med(rl), 'M')} | {fmt(med(pk), 'M')} | {ratio(rl, pk)} |")
        for var in ("scalar_rgb", "llvm_ad_rgb"):
            pk = ("bunny", t, f"mitsuba-{var}", "render_s")
            if pk in v:
                p(
                    f"| {t} | Mitsuba 3 `direct`, {var} (render s vs raylab trace s {fmt(med(('bunny', t, 'raylab', 'trace_s')), 's')}) | "
                    f"{fmt(med(rl), 'M')} | {fmt(med(pk), 's')} s | {ratio(('bunny', t, 'raylab', 'trace_s'), pk, invert=True)} |"
                )
    for t in threads:
        pk = ("bunny", t, "embreex4-run-calls", "rays_per_s")
        if pk in v:
            p(f"| {t} | (embreex's `run` calls alone, without the numpy glue, from CPU time: {fmt(med(pk), 'M')} rays/s) | | | |")
    for t in threads:
        a, b = ("bunny", t, "embree3", "camera_per_s"), ("bunny", t, "embree3", "shadow_per_s")
        if a in v:
            p(f"| {t} | (Embree 3 per phase, CPU time: camera {fmt(med(a), 'M')}, shadow {fmt(med(b), 'M')} rays/s; shadow ÷ camera {ratio(b, a)}) | | | |")
    p("")
    p("### Against Mitsuba 3: own render time (raylab's trace time, Mitsuba's second `mi.render`), load excluded")
    p("")
    p("| shot | threads | raylab trace s | raylab rays/s | Mitsuba 3 scalar_rgb s | raylab ÷ scalar (rate) | Mitsuba 3 llvm_ad_rgb s | raylab ÷ LLVM (rate) |")
    p("|---|---:|---:|---:|---:|---:|---:|---:|")
    shots = (("bunny", "bunny 69k triangles + plane, 1 spp"), ("big", "1.1M triangles + plane, 1024², 1 spp"), ("spheres", "24 spheres + plane, 16 spp"))
    for w, name in shots:
        for t in threads:
            a = (w, t, "raylab", "trace_s")
            if a not in v:
                continue
            sc, ll = (w, t, "mitsuba-scalar_rgb", "render_s"), (w, t, "mitsuba-llvm_ad_rgb", "render_s")
            p(
                f"| {name} | {t} | {fmt(med(a), 's')} | {fmt(med((w, t, 'raylab', 'rays_per_s')), 'M')} | {fmt(med(sc), 's')} | "
                f"{ratio(a, sc, invert=True)} | {fmt(med(ll), 's')} | {ratio(a, ll, invert=True)} |"
            )
    p("")
    p("### `raylab bench` on the bunny (no ground plane) against the Embree harness on the same shot, rays/s from the threads' CPU time")
    p("")
    p("| threads | rays | raylab bench | Embree 3 | raylab ÷ Embree | raylab shadow ÷ camera | Embree shadow ÷ camera |")
    p("|---:|---|---:|---:|---:|---:|---:|")
    for t in threads:
        for m, name in (("camera_per_s", "camera"), ("shadow_per_s", "shadow"), ("all_per_s", "all")):
            a, b = ("bench", t, "raylab", m), ("bench", t, "embree3", m)
            extra = ""
            if m == "camera_per_s":
                extra = " | " + ratio(("bench", t, "raylab", "shadow_per_s"), a) + " | " + ratio(("bench", t, "embree3", "shadow_per_s"), b)
            else:
                extra = " | | "
            p(f"| {t} | {name} | {fmt(med(a), 'M')} | {fmt(med(b), 'M')} | {ratio(a, b)}{extra} |")
    p("")
    p("### Whitted scenes against POV-Ray 3.7 (trace time; prune_threshold 0 / adc_bailout 0: every ray to depth 5)")
    p("")
    p("| scene | threads | raylab trace s | POV-Ray trace s | raylab ÷ POV-Ray (rate) |")
    p("|---|---:|---:|---:|---:|")
    for sc in ("dozen", "whitted"):
        for t in threads:
            a, b = (sc, t, "raylab", "trace_s"), (sc, t, "povray", "trace_s")
            if a in v:
                p(f"| {sc} | {t} | {fmt(med(a), 's')} | {fmt(med(b), 's')} | {ratio(a, b, invert=True)} |")
    p("")
    if len(threads) > 1:
        t1, t2 = threads[0], threads[-1]
        p(f"### Threads: {t1} → {t2} speed-up (median times or rates)")
        p("")
        p("| work | raylab | peer |")
        p("|---|---:|---:|")

        def speed(key_base, metric, rate):
            a, b = med(key_base(t1) + (metric,)), med(key_base(t2) + (metric,))
            if a is None or b is None:
                return "–"
            return f"{(b / a) if rate else (a / b):.2f}×"

        p(f"| bunny (Embree 3) | {speed(lambda t: ('bunny', t, 'raylab'), 'rays_per_s', True)} | {speed(lambda t: ('bunny', t, 'embree3'), 'rays_per_s', True)} |")
        for sc in ("dozen", "whitted"):
            p(f"| {sc} (POV-Ray) | {speed(lambda t: (sc, t, 'raylab'), 'trace_s', False)} | {speed(lambda t: (sc, t, 'povray'), 'trace_s', False)} |")
        p("")
    p("### Load + build of the 1.1M-triangle OBJ (`bunny_loop2.obj`, whole process under /usr/bin/time -v)")
    p("")
    p("| | raylab | Embree 3 | raylab ÷ Embree (time or memory: > 1 is worse) |")
    p("|---|---:|---:|---:|")
    for m, name, unit in (("total_s", "wall time s", "s"), ("load_s", "parse s (own report)", "s"), ("build_s", "BVH build s (own report)", "s"), ("peak_mib", "peak RSS MiB", "")):
        a, b = ("load", 2, "raylab", m), ("load", 2, "embree3", m)
        p(f"| {name} | {fmt(med(a), unit)} | {fmt(med(b), unit)} | {ratio(a, b)} |")
    print("\n".join(out))


if __name__ == "__main__":
    main()
