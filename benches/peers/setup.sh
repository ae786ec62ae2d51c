#!/usr/bin/env bash
# Installs the peers of benches/peers/run.sh (see README.md there): POV-Ray 3.7 and Embree 3.13
# from Debian, LLVM 19's shared library for Mitsuba's llvm variants, and a Python venv with
# embreex (Embree 4), Mitsuba 3, numpy and Pillow. Needs root for apt-get.
set -euo pipefail

VENV=${PEERS_VENV:-$HOME/.cache/raylab-peers-venv}

apt-get update -qq
apt-get install -y -qq povray libembree-dev g++ time libllvm19 python3-venv >/dev/null
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
"$VENV/bin/pip" install -q numpy pillow
# Optional peers: a failure here only drops them from run.sh's table.
"$VENV/bin/pip" install -q embreex || echo "setup: embreex did not install; run.sh skips Embree 4" >&2
"$VENV/bin/pip" install -q mitsuba || echo "setup: mitsuba did not install; run.sh skips Mitsuba 3" >&2
"$VENV/bin/pip" list 2>/dev/null | grep -i -E '^(embreex|mitsuba|drjit|numpy|pillow) '
povray --version 2>&1 | head -1 || true
dpkg-query -W -f='${Package} ${Version}\n' libembree-dev povray libllvm19
