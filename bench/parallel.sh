#!/usr/bin/env bash
# Serial `pdrmesh mesh` beside the parallel `pdrmesh run` on corpus surfaces:
#  * native kernel with the interface rounds, 1 and 2 workers: tets, parallel/serial tet ratio,
#    dihedral extremes, share under 10 degrees, wall time, the speedup of 2 workers over the serial
#    mesher (serial wall / 2-worker wall), the work ratio (CPU seconds of 1 worker / of the serial
#    mesher), tets/s,
#    and the profile shares of the 2-worker run in percent of its whole wall time (initial mesh,
#    decomposition, fix-ups, leaf refinement, interface rounds, optimization, serial share);
#  * the same figures (2 workers) for the native kernel without the interface rounds and for the
#    TetGen kernel, so that the gain of the interface rounds is visible.
#   bench/parallel.sh [DEPTH] [SURFACE...]     (default: DEPTH "auto", pdrmesh's own default depth per
#                                               surface; the small corpus surfaces)
#   VARIANTS="native" bench/parallel.sh ...    (a subset of: native no-iface tetgen)
# Needs GNU time (scripts/install-deps.sh --bench).
# Each run also writes its profile JSON; pdrmesh_bench_replay projects it to P workers.
# Surfaces from $PDRMESH_CORPUS (default bench/corpus: bench/fetch-corpus.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}  # bench/fetch-corpus.sh fills it
[[ -d $corpus ]] || { echo "no corpus in $corpus: run bench/fetch-corpus.sh" >&2; exit 1; }
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
replay=${REPLAY:-$root/build/bench/pdrmesh_bench_replay}
depth=${1:-auto}; shift || true
depth_args=(); [[ $depth == auto ]] || depth_args=(--depth "$depth")
names=("$@"); ((${#names[@]})) || names=(sphere966 bunny_npm hinge elephant couplingdown knot2 fandisk primitives13)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

field() { sed -n "s/.*\"$1\":\([-0-9.e+]*\).*/\1/p" "$2"; }
measure() {  # measure OUT_PREFIX command...: wall and CPU seconds into $1.s and $1.cpu, quality json into $1.q
  local prefix=$1; shift
  /usr/bin/time -f '%e %U %S' -o "$prefix.t" "$@" >/dev/null 2>"$prefix.err" ||
    { echo "failed: $* ($(tail -1 "$prefix.err"))" >&2; return 1; }
  awk '{ printf "%.2f", $1 > p ".s"; printf "%.2f", $2 + $3 > p ".cpu" }' p="$prefix" "$prefix.t"
  "$pdrmesh" quality --json "$prefix.meshb" >"$prefix.q"
}
share() {  # share JSON PHASE: percentage of the run's whole wall time (read to write)
  python3 -c "import json,sys; p=json.load(open(sys.argv[1]))['phases']; print('%.0f' % (100*p[sys.argv[2]]/p['wall']))" "$1" "$2"
}
serial_share() {  # the share of the wall time outside the rounds of leaf tasks
  python3 -c "import json,sys; j=json.load(open(sys.argv[1])); t=j['phases']['wall']; print('%.0f' % (100*max(0,t-sum(r['wall_s'] for r in j['rounds']))/t))" "$1"
}
quality() {  # quality PREFIX SERIAL_TETS: tets ratio min max under10
  awk -v t="$(field tets "$1.q")" -v st="$2" -v mn="$(field min_dihedral "$1.q")" -v mx="$(field max_dihedral "$1.q")" \
      -v u="$(field share_below_10 "$1.q")" 'BEGIN { printf "%9d %5.3f %6.2f %6.2f %6.3f%%", t, t / st, mn, mx, 100 * u }'
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%F); load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "serial: pdrmesh mesh; parallel: pdrmesh run ${depth_args[*]:-(default depth)} (optimization on); timings are wall seconds on a shared machine"
printf '%-13s %9s %6s %6s %6s | %-8s %9s %5s %6s %6s %7s %6s %6s %6s %5s %7s | %s\n' surface ser_tets ser_s min max \
  run tets ratio min max under10 w1_s w2_s vs_ser work tets/s "shares: init decomp fixup leaves iface opt serial"
for n in "${names[@]}"; do
  s=$corpus/$n.stl
  measure "$tmp/ser" "$pdrmesh" mesh -q "$s" -o "$tmp/ser.meshb" || continue
  st=$(field tets "$tmp/ser.q")
  ser=$(printf '%-13s %9d %6.2f %6.2f %6.2f' "$n" "$st" "$(cat "$tmp/ser.s")" "$(field min_dihedral "$tmp/ser.q")" \
        "$(field max_dihedral "$tmp/ser.q")")
  for variant in ${VARIANTS:-native no-iface tetgen}; do
    args=("${depth_args[@]}" --kernel native); [[ $variant == no-iface ]] && args+=(--no-interface-round)
    [[ $variant == tetgen ]] && args=("${depth_args[@]}" --kernel tetgen)
    measure "$tmp/w2" "$pdrmesh" run -q "$s" -o "$tmp/w2.meshb" "${args[@]}" --workers 2 --profile-json "$tmp/w2.json" ||
      { printf '%s | %-8s failed\n' "$ser" "$variant"; continue; }
    w1=-; work=-
    spd=$(awk -v a="$(cat "$tmp/ser.s")" -v b="$(cat "$tmp/w2.s")" 'BEGIN { printf "%.2f", a / b }')
    if [[ $variant == native ]]; then
      measure "$tmp/w1" "$pdrmesh" run -q "$s" -o "$tmp/w1.meshb" "${args[@]}" --workers 1 || continue
      cmp -s "$tmp/w1.meshb" "$tmp/w2.meshb" || echo "WARNING: $n: 1 and 2 workers differ" >&2
      w1=$(cat "$tmp/w1.s")
      work=$(awk -v a="$(cat "$tmp/w1.cpu")" -v b="$(cat "$tmp/ser.cpu")" 'BEGIN { printf "%.2f", a / b }')
      cp "$tmp/w2.json" "${PROFILE_DIR:-$tmp}/$n.d$depth.json" 2>/dev/null || true
    fi
    j=$tmp/w2.json
    printf '%s | %-8s %s %6s %6.2f %6s %5s %7.0f | %s %s %s %s %s %s %s\n' "$ser" "$variant" "$(quality "$tmp/w2" "$st")" \
      "$w1" "$(cat "$tmp/w2.s")" "$spd" "$work" "$(awk -v t="$(field tets "$tmp/w2.q")" -v s="$(cat "$tmp/w2.s")" 'BEGIN { print t / s }')" \
      "$(share "$j" initial)" "$(share "$j" decomposition)" "$(share "$j" fixups)" "$(share "$j" leaves)" \
      "$(share "$j" interface_round)" "$(share "$j" optimization)" "$(serial_share "$j")"
  done
done
