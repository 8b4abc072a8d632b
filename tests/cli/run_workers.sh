#!/usr/bin/env bash
# `pdrmesh run` (the parallel method in one process) on one corpus surface:
# the mesh validates against the surface, and 1 and 2 workers write the same bytes.
# Usage: run_workers.sh PDRMESH SURFACE DEPTH KERNEL
# Exits 77 (skipped) when the corpus is not beside the project.
set -euo pipefail
pdrmesh=$1 surface=$2 depth=$3 kernel=$4
[[ -f $surface ]] || { echo "corpus surface $surface not found: skipped"; exit 77; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$pdrmesh" run -q "$surface" -o "$tmp/w1.meshb" --workers 1 --depth "$depth" --kernel "$kernel"
"$pdrmesh" run -q "$surface" -o "$tmp/w2.meshb" --workers 2 --depth "$depth" --kernel "$kernel"
"$pdrmesh" validate "$tmp/w2.meshb" --surface "$surface"
cmp "$tmp/w1.meshb" "$tmp/w2.meshb"
echo "ok: $surface depth $depth ($kernel): 1 and 2 workers give identical bytes"
