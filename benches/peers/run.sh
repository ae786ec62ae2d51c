#!/usr/bin/env bash
# raylab against its peers, side by side (issue 11). See benches/peers/README.md.
#
#   benches/peers/run.sh [RUNS]        # RUNS alternations per workload and thread count (default 3)
#   SCALE=0.1 benches/peers/run.sh 1   # every image at a tenth of its size: checks the script
#
# Builds raylab (release, --features mesh,bvh) and the Embree harness, then, for each workload and
# thread count, runs raylab and each peer one after the other, RUNS times, and prints the
# raylab ÷ peer rate ratios (> 1: raylab faster). Peers that are not installed are skipped with a
# message. Environment: PEERS_VENV (Python venv with embreex/mitsuba, default
# ~/.cache/raylab-peers-venv), ASSETS (default ../shared/assets beside the repository),
# DRJIT_LIBLLVM_PATH (found automatically under /usr/lib when unset), THREADS (default "1 2"),
# SCALE (default 1: each shot at its own size; smaller for a quick check that everything runs),
# RAYLAB (a raylab binary to measure instead of building one).
set -euo pipefail

RUNS=${1:-${RUNS:-3}}
THREADS=${THREADS:-"1 2"}
SCALE=${SCALE:-1}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
ASSETS=${ASSETS:-$ROOT/../shared/assets}
VENV=${PEERS_VENV:-$HOME/.cache/raylab-peers-venv}
BUNNY=$ASSETS/stanford-bunny/stanford-bunny.obj
BIG=$ASSETS/bunny-loop2-1M/bunny_loop2.obj
WORK=$(mktemp -d "${TMPDIR:-/tmp}/raylab-peers.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
RESULTS=$WORK/results.tsv
: >"$RESULTS"
T0=$(date +%s)

say() { printf '%s\n' "$*" >&2; }
die() { say "run.sh: $*"; exit 1; }
# record WORKLOAD THREADS RUN RENDERER METRIC VALUE
record() { printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$@" >>"$RESULTS"; }

[ -f "$BUNNY" ] || die "no Stanford bunny at $BUNNY (set ASSETS)"
[ -f "$BIG" ] || die "no 1.1M-triangle bunny at $BIG (set ASSETS)"
command -v g++ >/dev/null || die "g++ missing (benches/peers/setup.sh installs the peers)"
[ -f /usr/include/embree3/rtcore.h ] || die "Embree 3 headers missing: apt-get install libembree-dev"
[ -x /usr/bin/time ] || die "/usr/bin/time missing: apt-get install time"
PY=python3
HAVE_NUMPY=0 HAVE_EMBREEX=0 HAVE_MITSUBA=0 HAVE_LLVM=0 HAVE_POV=0
command -v povray >/dev/null && HAVE_POV=1 || say "run.sh: povray missing: POV-Ray rows skipped"
if [ -x "$VENV/bin/python" ]; then
    PY=$VENV/bin/python
    "$PY" -c 'import numpy, PIL' 2>/dev/null && HAVE_NUMPY=1
    "$PY" -c 'import embreex' 2>/dev/null && HAVE_EMBREEX=1 || say "run.sh: embreex missing: Embree 4 rows skipped"
    "$PY" -c 'import mitsuba' 2>/dev/null && HAVE_MITSUBA=1 || say "run.sh: mitsuba missing: Mitsuba rows skipped"
else
    say "run.sh: no venv at $VENV (benches/peers/setup.sh): embreex, Mitsuba and image checks skipped"
fi
if [ "$HAVE_MITSUBA" = 1 ]; then
    if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
        # Dr.Jit 1.x needs LLVM ≥ 16 (LLVM 14/15 abort on `fmaximum`); take the newest installed.
        for v in 21 20 19 18 17 16; do
            f=/usr/lib/x86_64-linux-gnu/libLLVM-$v.so
            if [ -e "$f" ]; then export DRJIT_LIBLLVM_PATH=$f; break; fi
        done
    fi
    if [ -n "${DRJIT_LIBLLVM_PATH:-}" ]; then HAVE_LLVM=1; else say "run.sh: no libLLVM ≥ 16 (apt-get install libllvm19): Mitsuba llvm_ad_rgb skipped"; fi
fi

if [ -n "${RAYLAB:-}" ]; then
    say "== using $RAYLAB; building the Embree harness"
else
    say "== building raylab (release, mesh,bvh) and the Embree harness"
    (cd "$ROOT" && nice -n 10 cargo build --release -q -p raylab-plugins --features mesh,bvh)
    RAYLAB=$ROOT/target/release/raylab
fi
mkdir -p "$ROOT/target/peers"
EMBREE=$ROOT/target/peers/bunny_embree
nice -n 10 g++ -O2 -std=c++17 -Wall -Wextra -o "$EMBREE" "$HERE/embree/bunny_embree.cpp" -lembree3 -lpthread

# Scenes read only files in their own folder: the bunny shot and the load test get folders of
# their own with copies of the meshes.
mkdir -p "$WORK/bunny" "$WORK/load" "$WORK/big" "$WORK/spheres"
cp "$HERE/bunny/bunny.toml" "$BUNNY" "$WORK/bunny/"
cp "$BIG" "$WORK/load/"
cp "$HERE/big/big.toml" "$WORK/big/" && ln "$WORK/load/bunny_loop2.obj" "$WORK/big/bunny_loop2.obj"
cp "$HERE/spheres/spheres.toml" "$WORK/spheres/"
# Image sizes: each shot's own, times SCALE.
scaled() { python3 -c "print(max(1, round($1 * $SCALE)))"; }
W=$(scaled 800) H=$(scaled 600)
cat >"$WORK/load/load.toml" <<'EOF'
# Load and build the 1.1M-triangle OBJ; the 8×6 render is negligible.
[render]
width = 8
height = 6
[camera]
position = [0.0740697, 0.1859125, 0.3014968]
look_at = [-0.0168405, 0.110154, -0.001537]
[[object]]
type = "mesh"
file = "bunny_loop2.obj"
EOF
read -r -a SHOT <<<"$(python3 "$HERE/shot.py" embree-args) --width $W --height $H"
# The same shot without the ground plane: `raylab bench`'s workload (camera fitted to the bunny).
NOPLANE=()
skip=0
for a in "${SHOT[@]}"; do
    if [ "$skip" = 1 ]; then skip=0; continue; fi
    if [ "$a" = --plane ]; then skip=1; continue; fi
    NOPLANE+=("$a")
done

# --- helpers that run one renderer once and record what it printed -----------------------------

# raylab render SCENE OUT THREADS [args…] → "trace_s rays" (the scene's size times SCALE)
raylab_render() {
    local scene=$1 out=$2 threads=$3; shift 3
    local w h
    w=$(sed -n 's/^width = \([0-9]*\)/\1/p' "$scene" | head -1) h=$(sed -n 's/^height = \([0-9]*\)/\1/p' "$scene" | head -1)
    if [ -n "$w" ]; then set -- --width "$(scaled "$w")" --height "$(scaled "$h")" "$@"; fi
    local log=$WORK/raylab.log
    "$RAYLAB" render "$scene" -o "$out" --threads "$threads" --stats -q "$@" >"$log" 2>&1 || { cat "$log" >&2; die "raylab failed"; }
    local trace rays
    trace=$(sed -n 's/.*: trace \([0-9.]*\) s [(o].*/\1/p' "$log" | head -1)
    rays=$(awk '/^  (camera|shadow|reflection|refraction) rays/ {s += $NF} END {print s}' "$log")
    echo "$trace $rays"
}

kv() { sed -n "s/.*\\b$2 \\([0-9.e+-]*\\).*/\\1/p" "$1" | head -1; }

bunny_round() { # RUN THREADS
    local i=$1 t=$2 r log
    read -r trace rays <<<"$(raylab_render "$WORK/bunny/bunny.toml" "$WORK/raylab-bunny.png" "$t")"
    record bunny "$t" "$i" raylab trace_s "$trace"
    record bunny "$t" "$i" raylab rays_per_s "$(python3 -c "print($rays / $trace)")"
    log=$WORK/embree.log
    "$EMBREE" render "$WORK/bunny/stanford-bunny.obj" "${SHOT[@]}" --threads "$t" --ppm "$WORK/embree-bunny.ppm" >"$log"
    record bunny "$t" "$i" embree3 rays_per_s "$(kv "$log" rays_per_s_wall)"
    record bunny "$t" "$i" embree3 trace_s "$(kv "$log" trace_s)"
    record bunny "$t" "$i" embree3 camera_per_s "$(kv "$log" camera_rays_per_s_cpu)"
    record bunny "$t" "$i" embree3 shadow_per_s "$(kv "$log" shadow_rays_per_s_cpu)"
    "$EMBREE" render "$WORK/bunny/stanford-bunny.obj" "${SHOT[@]}" --threads "$t" --robust >"$log"
    record bunny "$t" "$i" embree3-robust rays_per_s "$(kv "$log" rays_per_s_wall)"
    if [ "$HAVE_EMBREEX" = 1 ]; then
        (cd "$HERE" && "$PY" embreex_bunny.py "$WORK/bunny/stanford-bunny.obj" --threads "$t") >"$log"
        record bunny "$t" "$i" embreex4 rays_per_s "$(kv "$log" rays_per_s_wall)"
        record bunny "$t" "$i" embreex4-run-calls rays_per_s "$(kv "$log" all_rays_per_s_cpu)"
    fi
    if [ "$HAVE_MITSUBA" = 1 ]; then
        local variants=scalar_rgb pin=()
        [ "$HAVE_LLVM" = 1 ] && variants="scalar_rgb llvm_ad_rgb"
        # One thread: Dr.Jit's pool of 1 plus the calling thread, pinned to one core.
        [ "$t" = 1 ] && pin=(taskset -c 0)
        for v in $variants; do
            (cd "$HERE" && "${pin[@]}" "$PY" mitsuba_shot.py "$WORK/bunny/bunny.toml" --variant "$v" --threads "$t" --scale "$SCALE") >"$log" 2>&1 \
                || { tail -3 "$log" >&2; say "run.sh: mitsuba $v failed"; continue; }
            record bunny "$t" "$i" "mitsuba-$v" render_s "$(kv "$log" render_s)"
        done
    fi
}

mitsuba_round() { # SHOT RUN THREADS: raylab's render of big/ or spheres/ against Mitsuba's (own render times)
    local sc=$1 i=$2 t=$3 log=$WORK/mitsuba.log pin=() v
    read -r trace rays <<<"$(raylab_render "$WORK/$sc/$sc.toml" "$WORK/raylab-$sc.png" "$t")"
    record "$sc" "$t" "$i" raylab trace_s "$trace"
    record "$sc" "$t" "$i" raylab rays_per_s "$(python3 -c "print($rays / $trace)")"
    [ "$HAVE_MITSUBA" = 1 ] || return 0
    local variants=scalar_rgb
    [ "$HAVE_LLVM" = 1 ] && variants="scalar_rgb llvm_ad_rgb"
    [ "$t" = 1 ] && pin=(taskset -c 0)
    for v in $variants; do
        (cd "$HERE" && "${pin[@]}" "$PY" mitsuba_shot.py "$WORK/$sc/$sc.toml" --variant "$v" --threads "$t" --scale "$SCALE") >"$log" 2>&1 \
            || { tail -3 "$log" >&2; say "run.sh: mitsuba $v failed on $sc"; continue; }
        record "$sc" "$t" "$i" "mitsuba-$v" render_s "$(kv "$log" render_s)"
    done
}

whitted_round() { # SCENE RUN THREADS
    local sc=$1 i=$2 t=$3 log=$WORK/pov.log
    read -r trace rays <<<"$(raylab_render "$ROOT/scenes/$sc.toml" "$WORK/raylab-$sc.png" "$t" --set prune_threshold=0)"
    record "$sc" "$t" "$i" raylab trace_s "$trace"
    record "$sc" "$t" "$i" raylab rays "$rays"
    if [ "$HAVE_POV" = 1 ]; then
        (cd "$WORK" && povray "+I$ROOT/benches/povray/$sc.pov" "+W$W" "+H$H" -A "+O$WORK/pov-$sc.png" -D "+WT$t" Declare=Bailout=0) >/dev/null 2>"$log" || true
        tr '\r' '\n' <"$log" >"$log.txt"
        record "$sc" "$t" "$i" povray trace_s "$(sed -n 's/.*Trace Time:.*(\([0-9.]*\) seconds).*/\1/p' "$log.txt" | head -1)"
    fi
}

load_round() { # RUN
    local i=$1 log=$WORK/time.log
    /usr/bin/time -v "$RAYLAB" render "$WORK/load/load.toml" -o "$WORK/load.png" -q >"$WORK/load-raylab.log" 2>"$log"
    record load 2 "$i" raylab total_s "$(elapsed "$log")"
    record load 2 "$i" raylab peak_mib "$(maxrss "$log")"
    record load 2 "$i" raylab load_s "$(sed -n 's/.*(load \([0-9.]*\) s.*/\1/p' "$WORK/load-raylab.log" | head -1)"
    record load 2 "$i" raylab build_s "$(sed -n 's/.*BVH build \([0-9.]*\) s.*/\1/p' "$WORK/load-raylab.log" | head -1)"
    /usr/bin/time -v "$EMBREE" load "$WORK/load/bunny_loop2.obj" >"$WORK/load-embree.log" 2>"$log"
    record load 2 "$i" embree3 total_s "$(elapsed "$log")"
    record load 2 "$i" embree3 peak_mib "$(maxrss "$log")"
    record load 2 "$i" embree3 load_s "$(kv "$WORK/load-embree.log" load_s)"
    record load 2 "$i" embree3 build_s "$(kv "$WORK/load-embree.log" build_s)"
}
elapsed() { sed -n 's/.*Elapsed (wall clock) time.*: \([0-9]*\):\([0-9.]*\)$/\1 \2/p' "$1" | awk '{print $1 * 60 + $2}'; }
maxrss() { sed -n 's/.*Maximum resident set size (kbytes): \([0-9]*\)/\1/p' "$1" | awk '{printf "%.1f", $1 / 1024}'; }

bench_round() { # RUN THREADS
    local i=$1 t=$2 log=$WORK/bench.log
    (cd "$WORK/bunny" && "$RAYLAB" bench --sizes "" stanford-bunny.obj --threads "$t" --width "$W" --height "$H" --markdown) >"$log" 2>/dev/null
    # | mesh | triangles | index | load | build | cpu | primary | shadow | all | bytes | wall | busy |
    local row
    row=$(grep '^| stanford-bunny' "$log")
    record bench "$t" "$i" raylab camera_per_s "$(si "$(echo "$row" | awk -F'|' '{print $8}')")"
    record bench "$t" "$i" raylab shadow_per_s "$(si "$(echo "$row" | awk -F'|' '{print $9}')")"
    record bench "$t" "$i" raylab all_per_s "$(si "$(echo "$row" | awk -F'|' '{print $10}')")"
    "$EMBREE" render "$WORK/bunny/stanford-bunny.obj" "${NOPLANE[@]}" --threads "$t" >"$log"
    record bench "$t" "$i" embree3 camera_per_s "$(kv "$log" camera_rays_per_s_cpu)"
    record bench "$t" "$i" embree3 shadow_per_s "$(kv "$log" shadow_rays_per_s_cpu)"
    record bench "$t" "$i" embree3 all_per_s "$(kv "$log" all_rays_per_s_cpu)"
}
si() { echo "$1" | awk '{v = $1; if ($2 == "M") v *= 1e6; else if ($2 == "k") v *= 1e3; else if ($2 == "G") v *= 1e9; print v}'; }

# --- equal work: counts and images of one render each ----------------------------------------

say "== equal work (one render each)"
{
    echo "### Equal work"
    echo
    "$RAYLAB" render "$WORK/bunny/bunny.toml" -o "$WORK/raylab-bunny.png" --width "$W" --height "$H" --threads 2 --stats -q >"$WORK/check.log" 2>&1
    echo "bunny, raylab: $(awk '/^  (camera|shadow) rays/ {printf "%s %s %s; ", $1, $2, $NF}' "$WORK/check.log")"
    "$EMBREE" render "$WORK/bunny/stanford-bunny.obj" "${SHOT[@]}" --threads 2 --ppm "$WORK/embree-bunny.ppm" >"$WORK/check-embree.log"
    echo "bunny, Embree: $(grep '^camera_rays ' "$WORK/check-embree.log")"
    if [ "$HAVE_NUMPY" = 1 ]; then
        "$PY" "$HERE/shot.py" ppm-to-png "$WORK/embree-bunny.ppm" "$WORK/embree-bunny.png"
        echo "bunny images, raylab vs Embree: $("$PY" "$HERE/shot.py" compare "$WORK/raylab-bunny.png" "$WORK/embree-bunny.png")"
    fi
    if [ "$HAVE_MITSUBA" = 1 ]; then
        (cd "$HERE" && "$PY" mitsuba_shot.py "$WORK/bunny/bunny.toml" --threads 2 --scale "$SCALE" --png "$WORK/mitsuba-bunny.png") >/dev/null 2>&1
        echo "bunny images, raylab vs Mitsuba (jittered camera rays, no ambient: its shadows are black, so its non-background count is the hits less the occluded ones): $("$PY" "$HERE/shot.py" compare "$WORK/raylab-bunny.png" "$WORK/mitsuba-bunny.png")"
    fi
    if [ "$HAVE_POV" = 1 ]; then
        for sc in dozen whitted; do
            "$RAYLAB" render "$ROOT/scenes/$sc.toml" -o "$WORK/raylab-$sc.png" --width "$W" --height "$H" --stats -q --set prune_threshold=0 >"$WORK/check.log" 2>&1
            echo "$sc, raylab: $(awk '/^  (camera|shadow|reflection|refraction) rays/ {printf "%s %s; ", $1, $NF}' "$WORK/check.log")"
            (cd "$WORK" && povray "+I$ROOT/benches/povray/$sc.pov" "+W$W" "+H$H" -A "+O$WORK/pov-$sc.png" -D +WT2 Declare=Bailout=0) >/dev/null 2>"$WORK/pov.log" || true
            tr '\r' '\n' <"$WORK/pov.log" | awk '/^Rays:/ {r = $2} /^Shadow Ray Tests:/ {s = $4} /^Reflected Rays:/ {f = $3} /^Refracted Rays:/ {t = $3}
                END {printf "%s, POV-Ray: camera+reflected+refracted %s (reflected %s, refracted %s); shadow tests %s\n", "'"$sc"'", r, f, (t == "" ? 0 : t), s}'
            [ "$HAVE_NUMPY" = 1 ] && echo "$sc images, raylab vs POV-Ray: $("$PY" "$HERE/shot.py" compare "$WORK/raylab-$sc.png" "$WORK/pov-$sc.png")"
        done
    fi
    echo
} >"$WORK/equal.md"
if [ -n "${KEEP_IMAGES:-}" ]; then mkdir -p "$KEEP_IMAGES" && cp "$WORK"/*.png "$KEEP_IMAGES"/ && say "images kept in $KEEP_IMAGES"; fi

# CPU time of the whole machine and of this script with its children, in clock ticks: their
# difference is what other processes took (processes of other sandboxes on the same VM too, which
# `top` does not show). Before each round the script waits (up to QUIET_WAIT s, default 120) for
# a second in which others took < 2 % of one core, and it records what they took during the round.
machine_ticks() { awk '/^cpu / {print $2 + $3 + $4 + $7 + $8 + $9}' /proc/stat; }
own_ticks() { awk '{print $14 + $15 + $16 + $17}' "/proc/$$/stat"; }
HZ=$(getconf CLK_TCK)
QUIET_WAIT=${QUIET_WAIT:-120}
wait_quiet() {
    local start=$SECONDS m
    while :; do
        m=$(machine_ticks); sleep 1
        (( $(machine_ticks) - m < HZ / 50 + 1 )) && return 0
        if (( SECONDS - start > QUIET_WAIT )); then say "   (no quiet second within ${QUIET_WAIT} s: measuring anyway)"; return 0; fi
    done
}
# measured WORKLOAD THREADS RUN COMMAND…: a round after a quiet second, recording others' CPU-s.
measured() {
    local w=$1 t=$2 i=$3 m0 o0; shift 3
    wait_quiet
    m0=$(machine_ticks) o0=$(own_ticks)
    "$@"
    record "$w" "$t" "$i" others cpu_s "$(awk -v x="$(( $(machine_ticks) - m0 - ($(own_ticks) - o0) ))" -v hz="$HZ" 'BEGIN {print (x < 0 ? 0 : x) / hz}')"
}
say "== $RUNS alternating runs (load: $(cut -d' ' -f1-3 /proc/loadavg))"
for i in $(seq 1 "$RUNS"); do
    for t in $THREADS; do
        say "   run $i, $t thread(s): bunny"; measured bunny "$t" "$i" bunny_round "$i" "$t"
        say "   run $i, $t thread(s): raylab bench vs Embree (no plane)"; measured bench "$t" "$i" bench_round "$i" "$t"
        for sc in dozen whitted; do say "   run $i, $t thread(s): $sc"; measured "$sc" "$t" "$i" whitted_round "$sc" "$i" "$t"; done
        for sc in big spheres; do say "   run $i, $t thread(s): $sc (Mitsuba)"; measured "$sc" "$t" "$i" mitsuba_round "$sc" "$i" "$t"; done
    done
    say "   run $i: load + build of the 1.1M-triangle OBJ"; measured load 2 "$i" load_round "$i"
done
LOAD_END=$(cut -d' ' -f1-3 /proc/loadavg)

python3 "$HERE/summarize.py" "$RESULTS" "$WORK/equal.md" "$RUNS" "$(( $(date +%s) - T0 ))" "$LOAD_END"
if [ -n "${KEEP_RESULTS:-}" ]; then cp "$RESULTS" "$KEEP_RESULTS"; fi
