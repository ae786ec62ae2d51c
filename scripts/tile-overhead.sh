#!/usr/bin/env bash
# Measures what splitting a frame into tiles costs: renders SCENE at WIDTH×HEIGHT as one process,
# then as 4 and as 16 tiles (separate processes, JOBS at a time, one thread each), merges each set,
# checks the merged image is byte-identical to the single render, and prints wall and CPU seconds
# (CPU time is what a farm pays; it is also steady on a machine shared with other work).
# Usage: scripts/tile-overhead.sh   (RAYLAB, SCENE, WIDTH, HEIGHT, JOBS, OUT in the environment)
set -euo pipefail
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
RAYLAB=${RAYLAB:-$REPO/target/release/raylab}
SCENE=${SCENE:-$REPO/scenes/quality.toml}
WIDTH=${WIDTH:-3840}
HEIGHT=${HEIGHT:-2160}
JOBS=${JOBS:-2}
OUT=${OUT:-$(mktemp -d)}
command -v parallel >/dev/null || { echo "needs GNU parallel (apt-get install parallel)" >&2; exit 1; }
SIZE=(--width "$WIDTH" --height "$HEIGHT" --max-rays 10000000000000)
# Runs "$@" and prints "wall_seconds cpu_seconds" (user + system time of it and its children).
timed() {
  local out
  out=$(mktemp)
  /usr/bin/time -f "%e %U %S" -o "$out" "$@" >/dev/null
  awk '{printf "%.1f %.1f\n", $1, $2 + $3}' "$out"
  rm -f "$out"
}
echo "raylab $("$RAYLAB" --version | cut -d' ' -f2), $(basename "$SCENE") at ${WIDTH}×${HEIGHT}, $(nproc) cores, $JOBS processes at a time"
printf '| split | wall s | CPU s | CPU ÷ one process | merge s |\n|---|---:|---:|---:|---:|\n'
read -r w1 c1 < <(timed "$RAYLAB" render "$SCENE" "${SIZE[@]}" -q -o "$OUT/single.pfm")
printf '| one process, %s threads | %s | %s | 1.00 | — |\n' "$(nproc)" "$w1" "$c1"
for n in 4 16; do
  read -r w c < <(timed parallel -j "$JOBS" "$RAYLAB" render "$SCENE" "${SIZE[@]}" -q --threads 1 --tile {}/"$n" -o "$OUT/t$n-{}.exr" ::: $(seq 0 $((n - 1))))
  parts=(); for ((i = 0; i < n; i++)); do parts+=("$OUT/t$n-$i.exr"); done
  read -r wm _ < <(timed "$RAYLAB" merge "${parts[@]}" -o "$OUT/merged$n.pfm")
  cmp -s "$OUT/merged$n.pfm" "$OUT/single.pfm" || { echo "merged $n tiles differ from the single render" >&2; exit 1; }
  printf '| %s tiles | %s | %s | %.2f | %s |\n' "$n" "$w" "$c" "$(awk -v a="$c" -v b="$c1" 'BEGIN{print a/b}')" "$wm"
done
echo "merged images byte-identical to the single render; files in $OUT"
