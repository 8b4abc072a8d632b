#!/usr/bin/env bash
# How the refinement and the final optimization scale with the mesh: each
# surface at size = bounding-box diagonal / 100, / 200, / 300 through the serial steps of
# `pdrmesh_bench_refine` (one run at a time: the finest meshes take several GB). Per run: tets,
# refinement and optimization CPU seconds and microseconds per tet, the bad tets (outside the
# optimizer's targets) when the optimization starts and ends, the dihedral extremes over all tets
# and over the interior tets (no boundary point), the interior tets outside [15, 150].
# Last, per surface, the optimization's microseconds per tet at the finest size over the coarsest
# (a linear cost gives about 1).
#   bench/optimize_scaling.sh [SURFACE...]     (default: armadillo fandisk frame)
#   environment: PDRMESH_CORPUS (the surfaces' folder, NAME.stl; default bench/corpus),
#   DIVISORS="100 200 300", BUILD_DIR (default build), BENCH (the pdrmesh_bench_refine binary).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}
bench=${BENCH:-${BUILD_DIR:-$root/build}/bench/pdrmesh_bench_refine}
read -r -a divisors <<<"${DIVISORS:-100 200 300}"
names=("$@"); ((${#names[@]})) || names=(armadillo fandisk frame)

cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
echo "machine: $(nproc) CPUs, ${cpu:-unknown CPU}; load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "corpus: $corpus   bench: $bench"
printf '%-10s %6s %10s %8s %8s %9s %9s %8s %8s %7s %7s %7s %7s %6s\n' surface size tets ref_s opt_s \
  ref_us/t opt_us/t bad_in bad_out dmin dmax idmin idmax i_out
summary=()
for name in "${names[@]}"; do
  first=""
  last=""
  for d in "${divisors[@]}"; do
    # pdrmesh_bench_refine's row: name size tets pass ref_s opt_s wall_s tets/cpu_s band(3)
    # dmin dmax idmin idmax i[15,150] i_out <10deg validate.
    # The verbose line "optimize: ... bad A -> B, ..." on stderr gives the bad tets.
    out=$(PDRMESH_BENCH_VERBOSE=1 PDRMESH_BENCH_SIZES=d100 PDRMESH_BENCH_DIVISOR="$d" "$bench" "$corpus" "$name" 2>&1)
    row=$(grep -v '^ ' <<<"$out" | tail -n 1)
    bad=$(sed -n 's/.*optimize:.* bad \([0-9]*\) -> \([0-9]*\),.*/\1 \2/p' <<<"$out")
    line=$(awk -v d="$d" -v bad="${bad:-- -}" '{
      tets = $3; if (tets + 0 == 0) { print "FAILED " $0; exit }
      split(bad, b, " ")
      printf "%-10s %6s %10d %8.2f %8.2f %9.2f %9.2f %8s %8s %7.2f %7.2f %7.2f %7.2f %6s %s\n", $1, "d/" d, tets,
        $5, $6, 1e6 * $5 / tets, 1e6 * $6 / tets, b[1], b[2], $12, $13, $14, $15, $17, ($19 == "valid" ? "" : $19)
    }' <<<"$row")
    echo "$line"
    us=$(awk '{print $7}' <<<"$line")
    [[ -n $first ]] || first=$us
    last=$us
  done
  summary+=("$(awk -v n="$name" -v a="$first" -v b="$last" -v lo="${divisors[0]}" -v hi="${divisors[-1]}" \
    'BEGIN { printf "%-10s optimization us/tet d/%s over d/%s: %.2f\n", n, hi, lo, (a > 0 ? b / a : 0) }')")
done
printf '%s\n' "${summary[@]}"
