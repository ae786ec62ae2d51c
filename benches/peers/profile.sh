#!/usr/bin/env bash
# Profiles of raylab and its peers on issue 29's target rows (benches/peers/PROFILE.md).
#
#   benches/peers/profile.sh [callgrind|perf|rates|report|all]   # default: all = callgrind perf report
#
# callgrind  instruction counts (and simulated cache misses and branch mispredictions, CACHE_SIM=1) of each renderer on the
#            same work, 1 thread: raylab's render loop (--toggle-collect='*render_passes*'), the
#            Embree 3 harness (single rays and 8-wide packets, the whole process; its trace is the
#            worker threads), Mitsuba 3 scalar_rgb and llvm_ad_rgb (one warm render: a process that
#            renders 3 times less one that renders twice), POV-Ray 3.7 (a render less an 8×6 one:
#            parsing and start-up cancel). Load-independent: fine on a busy machine.
# perf       `perf record -e cpu-clock` of the same commands, natively, 1 thread: where the time
#            goes, by function and by object (this VM has no PMU: cycles, IPC and cache counters
#            are not supported; the software clock is sampled). Shares are usable on a busy
#            machine, times are not.
# rates      the native CPU time of each trace (raylab's "CPU s", the harness's per-phase thread
#            CPU, Mitsuba's process time of its last render, POV-Ray's trace CPU-seconds), 1
#            thread, RUNS times (default 5), the median: divided into the callgrind counts it
#            gives instructions per CPU-nanosecond (IPC × clock; the same clock for all, so the
#            ratios are IPC ratios). Needs a quiet machine.
# report     the Markdown tables of PROFILE.md from the files above (profile_report.py).
#
# Sizes (callgrind counts are per ray or per sample, so smaller shots keep it short): the bunny
# shot 800×600 and the 1.1M-triangle shot 1024² at their own sizes, the 16-spp spheres at
# 200×150, dozen and whitted at 400×300 (prune_threshold 0, adc_bailout 0). Everything lands in
# OUT (default target/peers/profile). Environment as run.sh: RAYLAB, ASSETS, PEERS_VENV,
# DRJIT_LIBLLVM_PATH; ROWS (default "bunny big spheres dozen whitted"); JOBS (parallel valgrind
# runs, default 2); PEERS=0 profiles raylab alone (after a change to raylab: the peers' files in
# OUT stay). Takes ~60 min of CPU for callgrind (raylab's five: ~8 min), ~3 min for perf, ~3 min
# for rates.
set -euo pipefail

WHAT=${1:-all}
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
ASSETS=${ASSETS:-$ROOT/../shared/assets}
VENV=${PEERS_VENV:-$HOME/.cache/raylab-peers-venv}
OUT=${OUT:-$ROOT/target/peers/profile}
ROWS=${ROWS:-"bunny big spheres dozen whitted"}
JOBS=${JOBS:-2}
RUNS=${RUNS:-5}
CACHE_SIM=${CACHE_SIM:-1}
PEERS=${PEERS:-1}
BUNNY=$ASSETS/stanford-bunny/stanford-bunny.obj
BIG=$ASSETS/bunny-loop2-1M/bunny_loop2.obj
PY=$VENV/bin/python
export PYTHONHASHSEED=0

say() { printf '%s\n' "$*" >&2; }
die() { say "profile.sh: $*"; exit 1; }
[ -f "$BUNNY" ] && [ -f "$BIG" ] || die "meshes missing under $ASSETS (set ASSETS)"
[ -x "$PY" ] || die "no peers venv at $VENV (benches/peers/setup.sh)"
if [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
    for v in 21 20 19 18 17 16; do
        f=/usr/lib/x86_64-linux-gnu/libLLVM-$v.so
        if [ -e "$f" ]; then export DRJIT_LIBLLVM_PATH=$f; break; fi
    done
fi
mkdir -p "$OUT"

if [ -z "${RAYLAB:-}" ]; then
    say "== building raylab (release, mesh,bvh) and the Embree harness"
    (cd "$ROOT" && nice -n 10 cargo build --release -q -p raylab-plugins --features mesh,bvh)
    RAYLAB=$ROOT/target/release/raylab
fi
EMBREE=$ROOT/target/peers/bunny_embree
mkdir -p "$ROOT/target/peers"
if [ ! -x "$EMBREE" ] || [ "$HERE/embree/bunny_embree.cpp" -nt "$EMBREE" ]; then
    nice -n 10 g++ -O2 -std=c++17 -Wall -Wextra -o "$EMBREE" "$HERE/embree/bunny_embree.cpp" -lembree3 -lpthread
fi
git -C "$ROOT" log -1 --format='%H %cd' --date=iso-strict >"$OUT/commit.txt"

# The scenes, in folders of their own with their meshes (scenes read only their own folder).
S=$OUT/scenes
mkdir -p "$S/bunny" "$S/big" "$S/spheres"
cp "$HERE/bunny/bunny.toml" "$S/bunny/" && cp -n "$BUNNY" "$S/bunny/" 2>/dev/null || true
# (a hard link or a copy: raylab refuses a symbolic link that leads out of the scene's folder)
cp "$HERE/big/big.toml" "$S/big/" && { [ -e "$S/big/bunny_loop2.obj" ] || ln "$BIG" "$S/big/bunny_loop2.obj" 2>/dev/null || cp "$BIG" "$S/big/"; }
cp "$HERE/spheres/spheres.toml" "$S/spheres/"
read -r -a SHOT <<<"$(python3 "$HERE/shot.py" embree-args)"

# Each row: the commands, by name. raylab_NAME / embree_NAME / mitsuba_NAME / pov_NAME are arrays.
raylab_cmd() { # ROW → the raylab command (1 thread)
    case $1 in
        bunny) echo "$RAYLAB render $S/bunny/bunny.toml -o $OUT/raylab-bunny.png -q --threads 1 --stats" ;;
        big) echo "$RAYLAB render $S/big/big.toml -o $OUT/raylab-big.png -q --threads 1 --stats" ;;
        spheres) echo "$RAYLAB render $S/spheres/spheres.toml -o $OUT/raylab-spheres.png -q --threads 1 --stats --width 200 --height 150" ;;
        dozen | whitted) echo "$RAYLAB render $ROOT/scenes/$1.toml -o $OUT/raylab-$1.png -q --threads 1 --stats --width 400 --height 300 --set prune_threshold=0" ;;
    esac
}
embree_cmd() { # ROW PACKET [extra…]
    local row=$1 p=$2; shift 2
    case $row in
        bunny) echo "$EMBREE render $S/bunny/stanford-bunny.obj ${SHOT[*]} --threads 1 --packet $p $*" ;;
        big) echo "$EMBREE render $S/big/bunny_loop2.obj ${SHOT[*]} --width 1024 --height 1024 --threads 1 --packet $p $*" ;;
    esac
}
mitsuba_cmd() { # ROW VARIANT RENDERS
    local scale=1
    [ "$1" = spheres ] && scale=0.25
    echo "$PY $HERE/mitsuba_shot.py $S/$1/$1.toml --variant $2 --threads 1 --scale $scale --renders $3"
}
pov_cmd() { # ROW W H (-F: no image file, whose PNG encoding would otherwise be counted)
    echo "povray +I$ROOT/benches/povray/$1.pov +W$2 +H$3 -A -F -D +WT1 Declare=Bailout=0"
}

# --- callgrind --------------------------------------------------------------------------------
cg_jobs=()
cg() { # NAME [valgrind options…] -- COMMAND…: one callgrind run in the background (JOBS at a time)
    local name=$1; shift
    local opts=()
    while [ "$1" != -- ]; do opts+=("$1"); shift; done
    shift
    # This machine's caches (AMD EPYC, Zen 5: L1i 32 KiB 8-way, L1d 48 KiB 12-way, L3 32 MiB 16-way;
    # valgrind's own guess for the last level was a 512 MiB cache that holds everything).
    # --branch-sim=yes: callgrind's simple predictor's mispredictions (conditional and indirect).
    [ "$CACHE_SIM" = 1 ] && opts+=(--cache-sim=yes --I1=32768,8,64 --D1=49152,12,64 --LL=33554432,16,64 --branch-sim=yes)
    while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do sleep 1; done
    say "   callgrind: $name"
    # Dr.Jit's kernel cache: an empty one per run, so that both Mitsuba runs of a pair compile
    # their kernels (the difference is then one warm render).
    rm -rf "$OUT/drjit-cache-$name" && mkdir -p "$OUT/drjit-cache-$name"
    (cd "$OUT" && DRJIT_CACHE_DIR="$OUT/drjit-cache-$name" nice -n 10 valgrind --tool=callgrind --dump-instr=yes "${opts[@]}" \
        --callgrind-out-file="$OUT/$name.cg" "$@" >"$OUT/$name.log" 2>&1 || say "profile.sh: $name failed (see $OUT/$name.log)"
     rm -rf "$OUT/drjit-cache-$name") &
}

run_callgrind() {
    say "== callgrind (1 thread) into $OUT"
    for row in $ROWS; do
        # shellcheck disable=SC2046
        cg "raylab-$row" --toggle-collect='*render_passes*' -- $(raylab_cmd "$row")
        [ "$PEERS" = 1 ] || continue
        case $row in
            bunny | big)
                # shellcheck disable=SC2046
                cg "embree1-$row" -- $(embree_cmd "$row" 1)
                # shellcheck disable=SC2046
                cg "embree8-$row" -- $(embree_cmd "$row" 8)
                # The frame twice, less the runs above: one frame's instructions by address (the
                # instruction mix of the trace alone, without the OBJ reader and the build).
                # shellcheck disable=SC2046
                cg "embree1-$row-r2" -- $(embree_cmd "$row" 1 --repeat 2)
                # shellcheck disable=SC2046
                cg "embree8-$row-r2" -- $(embree_cmd "$row" 8 --repeat 2)
                ;;
        esac
        case $row in
            bunny | big | spheres)
                for v in scalar_rgb llvm_ad_rgb; do
                    # shellcheck disable=SC2046
                    cg "mitsuba-$v-$row-r2" -- $(mitsuba_cmd "$row" "$v" 2)
                    # shellcheck disable=SC2046
                    cg "mitsuba-$v-$row-r3" -- $(mitsuba_cmd "$row" "$v" 3)
                done
                ;;
            dozen | whitted)
                # shellcheck disable=SC2046
                cg "pov-$row" -- $(pov_cmd "$row" 400 300)
                # shellcheck disable=SC2046
                cg "pov-$row-tiny" -- $(pov_cmd "$row" 8 6)
                ;;
        esac
    done
    wait
}

# --- perf record --------------------------------------------------------------------------------
pf() { # NAME N COMMAND…: perf record of the command run N times, then its reports by symbol and by object
    local name=$1 n=$2; shift 2
    local graph=()
    # raylab: with call chains (DWARF: the binary has no frame pointers), so that the samples of
    # its render loop can be told from those of loading and building (profile_report.py).
    case $name in raylab-*) graph=(--call-graph dwarf,16384) ;; esac
    say "   perf: $name"
    # shellcheck disable=SC2016
    (cd "$OUT" && perf record -q -e cpu-clock -F 4000 "${graph[@]}" -o "$OUT/$name.perf.data" -- \
        sh -c 'n=$1; shift; for i in $(seq "$n"); do "$@" || exit 1; done' sh "$n" "$@" >"$OUT/$name.perf.log" 2>&1) \
        || { say "profile.sh: perf $name failed (see $OUT/$name.perf.log)"; return 0; }
    if [ ${#graph[@]} -gt 0 ]; then
        perf script -i "$OUT/$name.perf.data" -F ip,sym,dso 2>/dev/null >"$OUT/$name.perf.script"
        python3 "$HERE/profile_report.py" --perf-render "$OUT/$name.perf.script" "$OUT/$name.perf.sym.txt"
        rm -f "$OUT/$name.perf.script"
    else
        perf report -i "$OUT/$name.perf.data" --no-children --sort dso,sym --stdio --percent-limit 0.3 2>/dev/null \
            | grep -v '^#' | grep -v '^$' >"$OUT/$name.perf.sym.txt" || true
    fi
    perf report -i "$OUT/$name.perf.data" --no-children --sort dso --stdio 2>/dev/null \
        | grep -v '^#' | grep -v '^$' >"$OUT/$name.perf.dso.txt" || true
    rm -f "$OUT/$name.perf.data.old" "$OUT/$name.perf.data"
}

run_perf() {
    command -v perf >/dev/null || die "perf missing (apt-get install linux-perf)"
    say "== perf record (cpu-clock, 1 thread) into $OUT"
    for row in $ROWS; do
        # shellcheck disable=SC2046
        # raylab has no repeat option: the process 10 times (3 for the 1.1M mesh, whose load is long);
        # the report's parts leave the load, the build and the writing out.
        local n=10
        [ "$row" = big ] && n=3
        # shellcheck disable=SC2046
        pf "raylab-$row" "$n" $(raylab_cmd "$row")
        [ "$PEERS" = 1 ] || continue
        case $row in
            bunny | big)
                # shellcheck disable=SC2046
                pf "embree1-$row" 1 $(embree_cmd "$row" 1 --repeat 20)
                # shellcheck disable=SC2046
                pf "embree8-$row" 1 $(embree_cmd "$row" 8 --repeat 20)
                ;;
        esac
        case $row in
            bunny | big | spheres)
                for v in scalar_rgb llvm_ad_rgb; do
                    # shellcheck disable=SC2046
                    pf "mitsuba-$v-$row" 1 $(mitsuba_cmd "$row" "$v" 12)
                done
                ;;
            dozen | whitted)
                # shellcheck disable=SC2046
                pf "pov-$row" 10 $(pov_cmd "$row" 400 300)
                ;;
        esac
    done
}

# --- native CPU time of each trace --------------------------------------------------------------
run_rates() {
    say "== native CPU time of each trace, 1 thread, $RUNS runs (quiet machine!) into $OUT/rates.tsv"
    local f=$OUT/rates.tsv
    : >"$f"
    for i in $(seq 1 "$RUNS"); do
        for row in $ROWS; do
            # raylab: "trace T s (C CPU s)"
            # shellcheck disable=SC2046
            c=$($(raylab_cmd "$row") 2>&1 | sed -n 's/.*: trace [0-9.]* s (\([0-9.]*\) CPU s).*/\1/p' | head -1)
            printf '%s\traylab\t%s\t%s\n' "$row" "$i" "$c" >>"$f"
            [ "$PEERS" = 1 ] || continue
            case $row in
                bunny | big)
                    for p in 1 8; do
                        # The harness's own CPU time of the trace (both phases), with Embree held to
                        # AVX2 (what valgrind runs) and at its default (AVX-512 here).
                        for isa in avx2 default; do
                            local dev=()
                            [ "$isa" = avx2 ] && dev=(--device max_isa=avx2)
                            # shellcheck disable=SC2046
                            c=$($(embree_cmd "$row" "$p") "${dev[@]}" | awk '/^camera_rays / {n = $2 + $8} /all_rays_per_s_cpu/ {r = $6} END {printf "%.6f", n / r}')
                            printf '%s\tembree%s-%s\t%s\t%s\n' "$row" "$p" "$isa" "$i" "$c" >>"$f"
                        done
                    done
                    ;;
            esac
            case $row in
                bunny | big | spheres)
                    for v in scalar_rgb llvm_ad_rgb; do
                        # shellcheck disable=SC2046
                        c=$($(mitsuba_cmd "$row" "$v" 2) 2>/dev/null | sed -n 's/.*render_cpu_s \([0-9.]*\).*/\1/p')
                        printf '%s\tmitsuba-%s\t%s\t%s\n' "$row" "$v" "$i" "$c" >>"$f"
                    done
                    ;;
                dozen | whitted)
                    # shellcheck disable=SC2046
                    c=$($(pov_cmd "$row" 400 300) 2>&1 | tr '\r' '\n' | awk '/Trace Time:/ {t = 1} t && /CPU-seconds/ {print $(NF - 2); exit}')
                    printf '%s\tpovray\t%s\t%s\n' "$row" "$i" "$c" >>"$f"
                    ;;
            esac
        done
    done
}

case $WHAT in
    callgrind) run_callgrind ;;
    perf) run_perf ;;
    rates) run_rates ;;
    report) ;;
    all) run_callgrind; run_perf ;;
    *) die "usage: profile.sh [callgrind|perf|rates|report|all]" ;;
esac
python3 "$HERE/profile_report.py" "$OUT" >"$OUT/PROFILE-tables.md"
say "tables in $OUT/PROFILE-tables.md"
