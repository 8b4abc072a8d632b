#!/usr/bin/env bash
# A large job: `pdrmesh run` on one surface at a fine size, with its wall time, peak memory
# (max RSS), bytes per tet, the profile's phases and pdrmesh_bench_replay's projection of the
# run to more workers.
#   bench/large.sh [SIZE] [SURFACE] [WORKERS]   defaults: 0.12% (about 107 million tets on
#                                               armadillo), armadillo, 2
# Needs GNU time, the corpus (bench/fetch-corpus.sh) and disk for the mesh (about 3 GB at
# 100 million tets, written to a temporary folder and removed). KEEP=DIR keeps the profile.
# MAX_TETS=N passes --max-tets N (the default refuses what this machine's available memory
# would not hold at the estimate's calibrated bytes per tet).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
replay=${REPLAY:-$root/build/bench/pdrmesh_bench_replay}
size=${1:-0.12%}
name=${2:-armadillo}
workers=${3:-2}
surface=$corpus/$name.stl
[[ -f $surface ]] || { echo "no $surface: run bench/fetch-corpus.sh" >&2; exit 1; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdrmesh-large.XXXXXX"); trap 'rm -rf "$tmp"' EXIT

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(awk '/MemTotal/ { printf "%.1f GiB", $2 / 1048576 }' /proc/meminfo); $(date -u +%F)"
echo "command: pdrmesh run $name.stl --size $size --workers $workers"
/usr/bin/time -f '%e %M' -o "$tmp/time" "$pdrmesh" run -q "$surface" -o "$tmp/mesh.meshb" --size "$size" \
  --workers "$workers" ${MAX_TETS:+--max-tets "$MAX_TETS"} --profile-json "$tmp/profile.json" --json >"$tmp/result.json"
read -r wall rss_kb <"$tmp/time"
python3 - "$tmp/result.json" "$tmp/profile.json" "$wall" "$rss_kb" <<'PY'
import json, sys
result, profile = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
wall, rss = float(sys.argv[3]), int(sys.argv[4]) * 1024
tets = result["tets"]
q = result.get("quality", {})
print(f"tets {tets:,}  points {result['points']:,}  wall {wall:.1f} s  max RSS {rss / 2**30:.2f} GiB  "
      f"{rss / tets:.1f} bytes/tet  dihedral {q.get('min_dihedral', float('nan')):.2f} to "
      f"{q.get('max_dihedral', float('nan')):.2f}")
phases = {k: v for k, v in profile["phases"].items() if isinstance(v, (int, float)) and v >= 0.05}
print("phases (s): " + ", ".join(f"{k} {v:.1f}" for k, v in sorted(phases.items(), key=lambda kv: -kv[1])))
PY
[[ -n ${KEEP:-} ]] && mkdir -p "$KEEP" && cp "$tmp/profile.json" "$KEEP/large.$name.$size.json"
if [[ -x $replay ]]; then "$replay" "$tmp/profile.json"; fi
