#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Soak of the service: one coordinator on loopback and 2 worker daemons; JOBS
# small jobs (default 200) back to back (each submitted, waited for, fetched,
# deleted), and every 20 jobs the resident memory (VmRSS from /proc) of the
# three processes. Memory must stay flat: a process whose RSS at the end exceeds
# its RSS after warm-up (the first report) by more than 10% fails the soak.
# SOAK_EVERY=N reports every N jobs instead (for a short run on a loaded machine).
# Usage: bench/soak.sh [BUILD_DIR] [SURFACE] [JOBS] [MESH OPTIONS...]
# (SURFACE default: sphere966.stl of $PDRMESH_CORPUS, else bench/corpus: bench/fetch-corpus.sh)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
surface=${2:-${PDRMESH_CORPUS:-$root/bench/corpus}/sphere966.stl}
jobs=${3:-200}
shift $(( $# < 3 ? $# : 3 ))
options=("$@")
(( ${#options[@]} )) || options=(--depth 1)
pdrmesh=$build/client/pdrmesh
coordinator=$build/server/pdrmesh-coordinator
worker=$build/worker/pdrmesh-worker
for b in "$pdrmesh" "$coordinator" "$worker"; do [[ -x $b ]] || { echo "missing $b: build first"; exit 1; }; done
[[ -f $surface ]] || { echo "missing $surface (bench/fetch-corpus.sh)"; exit 1; }
every=${SOAK_EVERY:-20}

source "$root/tests/cli/coordinator_lib.sh"
bench_setup
export PDRMESH_TOKEN=tok-soak
echo "soak tok-soak" > "$tmp/tokens"
new_cluster_token
start_coordinator "$tmp/data" --worker-listen 127.0.0.1:0 --cluster-token-file "$tmp/cluster.token"
start_workers 2 --threads 1
names=(coordinator worker1 worker2)
pids=("$coord_pid" "${worker_pids[@]}")
rss_kb() { awk '/^VmRSS:/ {print $2}' "/proc/$1/status"; }

echo "machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)"
echo "soak: $jobs jobs of $(basename "$surface") ${options[*]} back to back, 1 coordinator + 2 workers"
printf '%6s %8s %16s %16s %16s\n' jobs seconds "${names[@]/%/ RSS KiB}"
declare -a first last
start=$(date +%s)
"$pdrmesh" run -q "$surface" "${options[@]}" -o "$tmp/run.meshb" > /dev/null 2>&1
for ((i = 1; i <= jobs; ++i)); do
  "$pdrmesh" submit "$surface" "${options[@]}" --wait --json --timeout 600 > "$tmp/job.json" 2> "$tmp/job.err" \
    || { echo "job $i failed:"; cat "$tmp/job.err"; exit 1; }
  id=$(json_field id < "$tmp/job.json")
  [[ $(json_field state < "$tmp/job.json") == succeeded ]] || { echo "job $i: $(cat "$tmp/job.json")"; exit 1; }
  "$pdrmesh" fetch "$id" -o "$tmp/job.meshb" > /dev/null 2>&1
  cmp -s "$tmp/job.meshb" "$tmp/run.meshb" || { echo "job $i ($id): bytes differ from pdrmesh run"; exit 1; }
  "$pdrmesh" delete "$id" > /dev/null
  if (( i % every == 0 )); then
    row=()
    for k in "${!pids[@]}"; do
      last[k]=$(rss_kb "${pids[k]}")
      [[ -n ${first[k]:-} ]] || first[k]=${last[k]}
      row+=("${last[k]}")
    done
    printf '%6d %8d %16s %16s %16s\n' "$i" $(( $(date +%s) - start )) "${row[@]}"
  fi
done
(( jobs >= every )) || { echo "fewer than $every jobs: no memory report"; exit 0; }
status=0
for k in "${!pids[@]}"; do
  growth=$(awk -v a="${first[k]}" -v b="${last[k]}" 'BEGIN {printf "%.1f", 100 * (b - a) / a}')
  if awk -v g="$growth" 'BEGIN {exit !(g > 10)}'; then
    echo "FAIL: ${names[k]} grew ${growth}% after warm-up (${first[k]} -> ${last[k]} KiB)"
    status=1
  else
    echo "flat: ${names[k]} ${growth}% after warm-up (${first[k]} -> ${last[k]} KiB)"
  fi
done
echo "$jobs jobs, each byte-identical to pdrmesh run; $( ((status)) && echo 'memory NOT flat' || echo 'memory flat (<= 10% growth after warm-up)')"
exit $status
