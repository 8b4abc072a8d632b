#!/usr/bin/env bash
# Times `pdrmesh check` and the serial initial mesh (`pdrmesh mesh`, TetGen
# boundary-conforming, no interior points) on every surface of the corpus and
# prints a table with the machine it ran on.
#   bench/foundation.sh [CORPUS_DIR]     (default: $PDRMESH_CORPUS, else bench/corpus: bench/fetch-corpus.sh)
# Needs GNU time (Debian package `time`; scripts/install-deps.sh --bench).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${1:-${PDRMESH_CORPUS:-$root/bench/corpus}}
[[ -d $corpus ]] || { echo "no corpus in $corpus: run bench/fetch-corpus.sh" >&2; exit 1; }
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
[[ -x $pdrmesh ]] || { echo "build first: scripts/build.sh" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "needs /usr/bin/time: scripts/install-deps.sh --bench" >&2; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

echo "machine: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "pdrmesh: $($pdrmesh --version), corpus: $corpus, $(date -u +%F)"
printf '%-14s %10s %9s %9s %10s %9s %10s\n' surface triangles check_s check_MB tets mesh_s mesh_MB
for f in "$corpus"/*.stl; do
  name=$(basename "$f" .stl)
  tris=$($pdrmesh check --json "$f" | sed -n 's/.*"triangles":\([0-9]*\).*/\1/p' | head -1)
  /usr/bin/time -f '%e %M' -o "$tmp/check" "$pdrmesh" check "$f" >/dev/null || true
  read -r cs ckb <"$tmp/check"
  /usr/bin/time -f "%e %M" -o "$tmp/mesh" "$pdrmesh" mesh -q --no-refine "$f" -o "$tmp/out.meshb" || true
  read -r ms mkb < <(tail -1 "$tmp/mesh")
  tets=$($pdrmesh quality --json "$tmp/out.meshb" 2>/dev/null | sed -n 's/.*"tets":\([0-9]*\).*/\1/p')
  awk -v n="$name" -v t="${tris:-?}" -v cs="$cs" -v ckb="$ckb" -v tets="${tets:-failed}" -v ms="$ms" -v mkb="$mkb" \
    'BEGIN { printf "%-14s %10s %9.2f %9.1f %10s %9.2f %10.1f\n", n, t, cs, ckb / 1024, tets, ms, mkb / 1024 }'
  rm -f "$tmp/out.meshb"
done
echo "check: read + full surface check incl. exact self-intersections; mesh: read + check + TetGen -pYzQMJF + validate against the surface + write .meshb"
echo "peak memory is the maximum resident set of the process (TetGen runs in a child process; GNU time reports the larger)"
