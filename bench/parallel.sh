#!/usr/bin/env bash
# Serial `pdrmesh mesh` beside the parallel `pdrmesh run` (native kernel, 1 and 2 workers) on
# corpus surfaces: tets, ratio of parallel to serial tets, dihedral extremes and the share of tets
# under 10 degrees, wall time, speedup of 2 workers over 1, tets per second.
#   bench/parallel.sh [DEPTH] [SURFACE...]     (default: depth 2, the small corpus surfaces)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${CORPUS:-$root/../shared/corpus}
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
depth=${1:-2}; shift || true
names=("$@"); ((${#names[@]})) || names=(sphere966 bunny_npm hinge elephant couplingdown knot2 fandisk primitives13)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

field() { sed -n "s/.*\"$1\":\([-0-9.e+]*\).*/\1/p" "$2"; }
measure() {  # measure OUT_PREFIX command...: wall seconds into $1.s, quality json into $1.q
  local prefix=$1; shift
  local t0=$(date +%s.%N)
  "$@" >/dev/null 2>"$prefix.err" || { echo "failed: $* ($(tail -1 "$prefix.err"))" >&2; return 1; }
  awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }' >"$prefix.s"
  "$pdrmesh" quality --json "$prefix.meshb" >"$prefix.q"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%F)"
echo "serial: pdrmesh mesh; parallel: pdrmesh run --kernel native --depth $depth (interface round and optimization on)"
printf '%-13s %9s %7s %6s %6s | %9s %6s %6s %6s %7s %6s %6s %7s %8s\n' surface ser_tets ser_s min max \
  par_tets ratio min max under10 w1_s w2_s speedup tets/s
for n in "${names[@]}"; do
  s=$corpus/$n.stl
  measure "$tmp/ser" "$pdrmesh" mesh -q "$s" -o "$tmp/ser.meshb" || continue
  measure "$tmp/w1" "$pdrmesh" run -q "$s" -o "$tmp/w1.meshb" --depth "$depth" --workers 1 || continue
  measure "$tmp/w2" "$pdrmesh" run -q "$s" -o "$tmp/w2.meshb" --depth "$depth" --workers 2 || continue
  cmp -s "$tmp/w1.meshb" "$tmp/w2.meshb" || echo "WARNING: $n: 1 and 2 workers differ" >&2
  st=$(field tets "$tmp/ser.q"); pt=$(field tets "$tmp/w2.q")
  awk -v n="$n" -v st="$st" -v ss="$(cat "$tmp/ser.s")" -v smin="$(field min_dihedral "$tmp/ser.q")" \
      -v smax="$(field max_dihedral "$tmp/ser.q")" -v pt="$pt" -v pmin="$(field min_dihedral "$tmp/w2.q")" \
      -v pmax="$(field max_dihedral "$tmp/w2.q")" -v u10="$(field share_below_10 "$tmp/w2.q")" \
      -v w1="$(cat "$tmp/w1.s")" -v w2="$(cat "$tmp/w2.s")" \
      'BEGIN { printf "%-13s %9d %7.2f %6.2f %6.2f | %9d %6.2f %6.2f %6.2f %5.3f%% %6.2f %6.2f %6.2f %8.0f\n",
               n, st, ss, smin, smax, pt, pt / st, pmin, pmax, 100 * u10, w1, w2, w1 / w2, pt / w2 }'
done
