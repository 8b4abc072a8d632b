#!/usr/bin/env bash
# `pdrmesh run` (the parallel method in one process) on one corpus surface:
# the mesh validates against the surface, and 1 and 2 workers write the same bytes.
# Usage: run_workers.sh PDRMESH SURFACE DEPTH KERNEL [compare|single]
#   single: the 2-worker run alone, validated (the sanitizer builds: no byte comparison).
set -euo pipefail
pdrmesh=$1 surface=$2 depth=$3 kernel=$4 mode=${5:-compare}
[[ -f $surface ]] || { echo "test surface $surface not found"; exit 1; }
[[ $mode == compare || $mode == single ]] || { echo "mode must be compare or single, got '$mode'"; exit 2; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$pdrmesh" run -q "$surface" -o "$tmp/w2.meshb" --workers 2 --depth "$depth" --kernel "$kernel"
"$pdrmesh" validate "$tmp/w2.meshb" --surface "$surface"
if [[ $mode == single ]]; then
  echo "ok: $surface depth $depth ($kernel): 2 workers give a valid mesh"
  exit 0
fi
"$pdrmesh" run -q "$surface" -o "$tmp/w1.meshb" --workers 1 --depth "$depth" --kernel "$kernel"
cmp "$tmp/w1.meshb" "$tmp/w2.meshb"
echo "ok: $surface depth $depth ($kernel): 1 and 2 workers give identical bytes"
