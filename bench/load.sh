#!/usr/bin/env bash
# Load bench of the service: starts a coordinator on loopback (and 2 workers
# when build/worker/pdrmesh-worker exists; otherwise the coordinator refines
# the leaves itself), submits JOBS jobs (default 20) from 4 users at once, waits
# for all, and prints jobs per minute, tets per second and each user's wait
# (submission to start) and turnaround (submission to end), with the machine.
# Usage: bench/load.sh [BUILD_DIR] [SURFACE] [JOBS] [MESH OPTIONS...]
# (SURFACE default: sphere966.stl of $PDRMESH_CORPUS, else bench/corpus: bench/fetch-corpus.sh)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
surface=${2:-${PDRMESH_CORPUS:-$root/bench/corpus}/sphere966.stl}
jobs=${3:-20}
shift $(( $# < 3 ? $# : 3 ))
options=("$@")
pdrmesh=$build/client/pdrmesh
coordinator=$build/server/pdrmesh-coordinator
worker=$build/worker/pdrmesh-worker
for b in "$pdrmesh" "$coordinator"; do [[ -x $b ]] || { echo "missing $b: build first"; exit 1; }; done
[[ -f $surface ]] || { echo "missing $surface (bench/fetch-corpus.sh)"; exit 1; }

source "$root/tests/cli/coordinator_lib.sh"
bench_setup
users=(ana ben cho dev)
for u in "${users[@]}"; do echo "$u tok-$u"; done > "$tmp/tokens"
limits=(--max-queued-jobs "$jobs" --max-running-jobs "$jobs" --threads 4)

if [[ -x $worker ]]; then
  new_cluster_token
  start_coordinator "$tmp/data" "${limits[@]}" --worker-listen 127.0.0.1:0 --cluster-token-file "$tmp/cluster.token"
  start_workers 2
  dispatch="2 workers (pdrmesh-worker) on loopback"
else
  start_coordinator "$tmp/data" "${limits[@]}"
  dispatch="local dispatch (no pdrmesh-worker in $build: leaves run in the coordinator)"
fi

echo "machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)"
echo "dispatch: $dispatch"
echo "load: $jobs jobs of $(basename "$surface") ${options[*]} from ${#users[@]} users at once"
start=$(date +%s.%N)
pids=()
for ((i = 0; i < jobs; ++i)); do
  u=${users[i % ${#users[@]}]}
  PDRMESH_TOKEN=tok-$u "$pdrmesh" submit "$surface" "${options[@]}" --wait --json --timeout 600 \
    > "$tmp/job$i.json" 2> "$tmp/job$i.err" &
  pids+=($!)
done
failed=0
for p in "${pids[@]}"; do wait "$p" || failed=$((failed + 1)); done
end=$(date +%s.%N)
[[ $failed == 0 ]] || { echo "$failed job(s) failed:"; cat "$tmp"/job*.err | grep -v '^\[' | head; exit 1; }

python3 - "$tmp" "$jobs" "$start" "$end" <<'PY'
import json, sys, collections
tmp, n, t0, t1 = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
jobs = [json.load(open(f"{tmp}/job{i}.json")) for i in range(n)]
assert all(j["state"] == "succeeded" for j in jobs), [j["state"] for j in jobs]
wall = t1 - t0
tets = sum(int(j["tets"]) for j in jobs)
print(f"all {n} jobs succeeded in {wall:.1f} s: {60 * n / wall:.1f} jobs/minute, {tets / wall:,.0f} tets/second "
      f"({tets:,} tets in all)")
per = collections.defaultdict(list)
for j in jobs:
    c, s, f = (int(j[k]) for k in ("created_unix_ms", "started_unix_ms", "finished_unix_ms"))
    per[j["user"]].append(((s - c) / 1000, (f - c) / 1000))
for user in sorted(per):
    w = [a for a, _ in per[user]]
    t = [b for _, b in per[user]]
    print(f"  {user}: {len(w)} jobs, wait mean {sum(w) / len(w):6.2f} s max {max(w):6.2f} s, "
          f"turnaround mean {sum(t) / len(t):6.2f} s max {max(t):6.2f} s")
PY
