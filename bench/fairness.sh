#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Fairness bench of the service: a coordinator on loopback with 2 workers (1 thread each).
# First a small job (about 50K tets) of user bob alone on the idle service; then a big job
# (about 5M tets) of user alice, and once its leaves are being refined, the same small job of
# bob. Prints the small job's time both ways and their ratio (the goal: within three times),
# and the big job's own time (FAIRNESS_CANCEL_BIG=1: the big job is cancelled once the small
# one is done, and its tets so far are printed).
# Usage: bench/fairness.sh [BUILD_DIR] [SURFACE] [BIG_SIZE] [SMALL_SIZE]
# (defaults: build, examples/bunny.mesh, 0.074 and 0.34: about 5M and 50K tets of the bunny)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
surface=${2:-$root/examples/bunny.mesh}
big=${3:-0.074}
small=${4:-0.34}
pdrmesh=$build/client/pdrmesh
coordinator=$build/server/pdrmesh-coordinator
worker=$build/worker/pdrmesh-worker
for b in "$pdrmesh" "$coordinator" "$worker"; do [[ -x $b ]] || { echo "missing $b: build first"; exit 1; }; done

source "$root/tests/cli/coordinator_lib.sh"
bench_setup
printf 'alice tok-alice\nbob tok-bob\n' > "$tmp/tokens"
new_cluster_token
coord_log_level=info start_coordinator "$tmp/data" --worker-listen 127.0.0.1:0 --cluster-token-file "$tmp/cluster.token"
start_workers 2 --threads 1
for _ in $(seq 100); do  # both workers registered
  grep -c 'registered' "$tmp/coordinator.err" 2>/dev/null | grep -q 2 && break
  sleep 0.1
done
sleep 1

now() { date +%s.%N; }
small_job() {  # small_job NAME: bob's small job, waited for; prints its seconds
  local t0 t1
  t0=$(now)
  PDRMESH_TOKEN=tok-bob "$pdrmesh" submit "$surface" --size "$small" --wait -o "$tmp/$1.meshb" --timeout 3600 \
    > "$tmp/$1.out" 2> "$tmp/$1.err" || { echo "bob's job failed:"; cat "$tmp/$1.err"; exit 1; }
  t1=$(now)
  echo "$t1 - $t0" | bc
}

echo "machine: $(nproc) cores, $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)"
echo "service: 1 coordinator, 2 workers of 1 thread on loopback; surface $(basename "$surface")"
idle=$(small_job idle)

t0=$(now)
id=$(PDRMESH_TOKEN=tok-alice "$pdrmesh" submit "$surface" --size "$big")
# Wait until the big job's leaves are being refined: then it holds the workers.
for _ in $(seq 6000); do
  phase=$(PDRMESH_TOKEN=tok-alice "$pdrmesh" status "$id" --output json | json_field phase)
  [[ $phase == refinement || $phase == "interface round" || $phase == optimization ]] && break
  sleep 0.1
done
loaded=$(small_job loaded)
if [[ ${FAIRNESS_CANCEL_BIG:-0} == 1 ]]; then  # the small job's figures only: stop the big one here
  status=$(PDRMESH_TOKEN=tok-alice "$pdrmesh" cancel "$id" --output json)
  big_s="cancelled"
else
  PDRMESH_TOKEN=tok-alice "$pdrmesh" watch "$id" > /dev/null 2>&1 || true
  big_s=$(echo "$(now) - $t0" | bc)
  status=$(PDRMESH_TOKEN=tok-alice "$pdrmesh" status "$id" --output json)
fi
big_tets=$(json_field tets <<<"$status")
small_tets=$(PDRMESH_TOKEN=tok-bob "$pdrmesh" status "$(head -n 1 "$tmp/loaded.out")" --output json | json_field tets)

printf '%-34s %10s %12s\n' "job" "tets" "seconds"
printf '%-34s %10s %12.2f\n' "bob's small job, idle service" "$small_tets" "$idle"
printf '%-34s %10s %12.2f\n' "bob's small job, beside alice's" "$small_tets" "$loaded"
printf '%-34s %10s %12s\n' "alice's big job" "$big_tets" "$big_s"  # cancelled: its tets so far
ratio=$(echo "scale=2; $loaded / $idle" | bc)
echo "small job beside the big one / alone: ${ratio}x (goal: at most 3x)"
