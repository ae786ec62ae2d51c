#!/usr/bin/env bash
# Every bundled scene rendered at 1 and 16 spp: trace time, rays and rays/s as a Markdown table
# (docs/performance.md, "Every bundled scene").
#
#   benches/scenes.sh [THREADS]     # default 2; builds raylab (release, mesh,bvh) first
#
# Each scene at its own size; the showcase with `--aa stratified` (its own setting is adaptive, so
# `--spp` would not apply); the ray budget lifted (`--max-rays`), so that no scene's worst-case
# bound stops the table. One run: the figures are as noisy as the machine; compare ratios from
# one run.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
THREADS=${1:-2}
(cd "$ROOT" && nice -n 10 cargo build --release -q -p raylab-plugins --features mesh,bvh)
RAYLAB=$ROOT/target/release/raylab
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

# "trace T s ... N rays, R rays/s" from raylab's summary line → "T|N|R"
figures() {
    sed -n 's/.*trace \([0-9.]*\) s.* on [0-9]* threads\?, \([0-9.]* [kMG]\?\) rays, \([0-9.]* [kMG]\?\) rays\/s.*/\1|\2|\3/p' "$1" | head -1
}

echo "| scene | 1 spp: trace s | rays | rays/s | 16 spp: trace s | rays | rays/s |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for scene in "$ROOT"/scenes/*.toml "$ROOT"/scenes/*.xml; do
    name=$(basename "$scene")
    row="| \`$name\`"
    for spp in 1 16; do
        args=(--spp "$spp" --threads "$THREADS" --max-rays 1000000000000 -q)
        [ "$name" = showcase.toml ] && args+=(--aa stratified)
        "$RAYLAB" render "$scene" -o "$OUT/$name.png" "${args[@]}" >"$OUT/log" 2>&1 || { cat "$OUT/log" >&2; exit 1; }
        IFS='|' read -r t n r <<<"$(figures "$OUT/log")"
        row="$row | $t | $n | $r"
    done
    echo "$row |"
done
