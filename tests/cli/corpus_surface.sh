#!/usr/bin/env bash
# End-to-end test of the serial path on one corpus surface:
#   pdrmesh check SURFACE            (exit 0)
#   pdrmesh mesh SURFACE -o OUT      (OUT in the format given)
#   pdrmesh validate OUT --surface SURFACE
#   pdrmesh quality OUT --json       (tets > 0)
# Usage: corpus_surface.sh PDRMESH SURFACE FORMAT_SUFFIX [MESH_OPTIONS...]
set -euo pipefail
pdrmesh=$1 surface=$2 suffix=$3
shift 3
[[ -f $surface ]] || { echo "test surface $surface not found"; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
out="$tmp/out$suffix"

"$pdrmesh" check "$surface"
"$pdrmesh" mesh -q "$@" "$surface" -o "$out"
"$pdrmesh" validate "$out" --surface "$surface"
json=$("$pdrmesh" quality --json "$out")
tets=$(sed -n 's/.*"tets":\([0-9]*\).*/\1/p' <<<"$json")
[[ ${tets:-0} -gt 0 ]] || { echo "no tets in $out: $json"; exit 1; }
echo "ok: $surface -> $tets tets ($suffix)"
