#!/usr/bin/env bash
# The parallel mesher against the serial one, per corpus surface: `pdrmesh mesh` beside
# `pdrmesh run` with 1 and 2 workers, at pdrmesh's default octree depth and one deeper.
#   bench/parallel.sh [SIZE] [SURFACE...]   SIZE: "default" (the surface's own spacing, the default)
#                                           or a --size value such as 1% (diagonal / 100)
# Columns: serial tets, wall and CPU seconds, thousand tets per CPU second (the serial mesher's
# speed on one core: its CPU time is the whole run's, validation and writing included), all-tet
# and interior (no boundary point) dihedral extremes; then per depth: tets, parallel/serial tet
# ratio, the same extremes, wall seconds of 1 and 2 workers, CPU seconds of 1 worker, speedup
# (serial wall / 2-worker wall), work (1-worker CPU / serial CPU), the optimization's seconds in
# `mesh` and in the 1-worker run (its rounds with their selections and merges) and their ratio,
# and "=" when 1 and 2 workers wrote the same bytes.
# Needs GNU time (scripts/install-deps.sh --bench). PROFILE_DIR=DIR keeps each 2-worker run's
# profile (pdrmesh_bench_replay projects it to more workers). FARFIELD=D meshes the space
# between each surface and a box D body lengths away instead (--farfield D: external flow);
# ARGS="..." adds options to every mesh and run (e.g. prism layers: ARGS="--layers 20
# --first-height 1e-4 --growth-ratio 1.2"; the tet columns then count the fill's tets).
# Surfaces from $PDRMESH_CORPUS (default bench/corpus: bench/fetch-corpus.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}
[[ -d $corpus ]] || { echo "no corpus in $corpus: run bench/fetch-corpus.sh" >&2; exit 1; }
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
size=${1:-default}; shift || true
size_args=(); [[ $size == default ]] || size_args=(--size "$size")
[[ -z ${FARFIELD:-} ]] || size_args+=(--farfield "$FARFIELD")
[[ -z ${ARGS:-} ]] || read -r -a extra <<<"$ARGS" && size_args+=("${extra[@]}")
names=("$@"); ((${#names[@]})) || names=(sphere966 bunny_npm hinge elephant couplingdown knot2 fandisk primitives13)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

measure() {  # measure PREFIX command...: wall and CPU seconds into PREFIX.s, PREFIX.cpu; quality JSON PREFIX.q
  local prefix=$1; shift
  /usr/bin/time -f '%e %U %S' -o "$prefix.t" "$@" >/dev/null 2>"$prefix.err" ||
    { echo "failed: $* ($(tail -1 "$prefix.err"))" >&2; return 1; }
  awk '{ printf "%.2f", $1 > p ".s"; printf "%.2f", $2 + $3 > p ".cpu" }' p="$prefix" "$prefix.t"
  "$pdrmesh" quality --json "$prefix.meshb" >"$prefix.q"
}
angles() {  # angles PREFIX: tets, min, max, interior min, interior max
  python3 -c "import json,sys; q=json.load(open(sys.argv[1])); print(q['tets'], '%.2f %.2f %.2f %.2f' % (q['min_dihedral'], q['max_dihedral'], q['interior_min_dihedral'], q['interior_max_dihedral']))" "$1.q"
}
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%F); load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "size: $size${FARFIELD:+; far field $FARFIELD body lengths away}${ARGS:+; options $ARGS}; serial: pdrmesh mesh; parallel: pdrmesh run --workers 1|2 [--depth D]; seconds are wall unless named CPU"
printf '%-13s %9s %6s %6s %7s %13s %13s | %5s %9s %6s %13s %13s %6s %6s %6s %6s %5s %6s %6s %5s %s\n' surface ser_tets ser_s \
  ser_cpu ser_kt/s ser_min/max ser_int depth tets ratio min/max int_min/max w1_s w1_cpu w2_s speedup work opt_s opt_w1 opt_r same
for n in "${names[@]}"; do
  s=$corpus/$n.stl
  measure "$tmp/ser" "$pdrmesh" mesh "$s" -o "$tmp/ser.meshb" "${size_args[@]}" || continue
  ser_opt=$(sed -n 's/.*refined: .*optimization \([0-9.]*\) s).*/\1/p' "$tmp/ser.err")
  ser_opt=${ser_opt:--}  # a layered run does not report it
  read -r st smin smax simin simax < <(angles "$tmp/ser")
  depth=
  for deeper in 0 1; do
    d_args=(); [[ -n $depth ]] && d_args=(--depth $((depth + deeper)))
    measure "$tmp/w2" "$pdrmesh" run -q "$s" -o "$tmp/w2.meshb" "${size_args[@]}" "${d_args[@]}" --workers 2 \
      --profile-json "$tmp/w2.json" || continue
    [[ -n $depth ]] || depth=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['depth'])" "$tmp/w2.json")
    d=$((depth + deeper))
    measure "$tmp/w1" "$pdrmesh" run -q "$s" -o "$tmp/w1.meshb" "${size_args[@]}" --depth "$d" --workers 1 \
      --profile-json "$tmp/w1.json" || continue
    w1_opt=$(python3 -c "import json,sys; print('%.2f' % json.load(open(sys.argv[1]))['phases']['optimization'])" "$tmp/w1.json")
    same="no"; cmp -s "$tmp/w1.meshb" "$tmp/w2.meshb" && same="="
    [[ -n ${PROFILE_DIR:-} ]] && cp "$tmp/w2.json" "$PROFILE_DIR/$n.$size.d$d.json"
    read -r pt pmin pmax pimin pimax < <(angles "$tmp/w2")
    printf '%-13s %9d %6.2f %6.2f %7.0f %6.2f/%6.2f %6.2f/%6.2f | %5d %9d %6s %6.2f/%6.2f %6.2f/%6.2f %6.2f %6.2f %6.2f %6s %5s %6s %6s %5s %s\n' \
      "$n" "$st" "$(cat "$tmp/ser.s")" "$(cat "$tmp/ser.cpu")" "$(awk -v a="$st" -v b="$(cat "$tmp/ser.cpu")" 'BEGIN { print a / b / 1000 }')" "$smin" "$smax" "$simin" "$simax" "$d" "$pt" \
      "$(awk -v a="$pt" -v b="$st" 'BEGIN { printf "%.3f", a / b }')" "$pmin" "$pmax" "$pimin" "$pimax" \
      "$(cat "$tmp/w1.s")" "$(cat "$tmp/w1.cpu")" "$(cat "$tmp/w2.s")" "$(ratio "$(cat "$tmp/ser.s")" "$(cat "$tmp/w2.s")")" \
      "$(ratio "$(cat "$tmp/w1.cpu")" "$(cat "$tmp/ser.cpu")")" "$ser_opt" "$w1_opt" \
      "$([[ $ser_opt == - ]] && echo - || ratio "$w1_opt" "$ser_opt")" "$same"
  done
done
