#!/usr/bin/env bash
# The whole chain with real processes on loopback: a coordinator and worker
# daemons that register with it. A job's leaves go to the workers; the fetched
# mesh is byte-identical to `pdrmesh run` with the same options and every format
# validates against the surface. Then faults in the middle of a job: one worker
# killed with SIGKILL, another stopped with SIGSTOP past the leaf deadline; the
# job still completes with the same bytes. Last, a worker that registers in the
# middle of a job widens it (two leaf tasks at once) and takes leaves.
# Usage: service_workers.sh PDRMESH COORDINATOR WORKER SURFACE [MESH OPTIONS...]
set -euo pipefail
worker_bin=$3
set -- "$1" "$2" "${@:4}"
source "$(dirname "$0")/coordinator_lib.sh"
service_test_setup "$@"
trap 'stop_workers; stop_coordinator; rm -rf "$tmp"' EXIT
printf 'alice tok-alice\n' > "$tmp/tokens"
head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$tmp/cluster-token"
export PDRMESH_TOKEN=tok-alice
start_coordinator "$tmp/data" --worker-listen 127.0.0.1:0 --cluster-token-file "$tmp/cluster-token" \
  --leaf-deadline 3
registry=$(sed -n 's/^workers on //p' "$tmp/coordinator.out")
[[ -n $registry ]] || { echo "the coordinator printed no worker port"; cat "$tmp/coordinator.out"; exit 1; }

worker_pids=()
start_worker() {  # start_worker NAME [ENV=VALUE...]: registers with the coordinator
  local name=$1; shift
  env "$@" "$worker_bin" --listen 127.0.0.1:0 --coordinator "$registry" --threads 1 \
    --cluster-token-file "$tmp/cluster-token" --log-level debug > "$tmp/$name.out" 2> "$tmp/$name.err" &
  worker_pids+=($!)
}
stop_workers() {
  for pid in "${worker_pids[@]}"; do kill -CONT "$pid" 2> /dev/null || true; kill -9 "$pid" 2> /dev/null || true; done
  for pid in "${worker_pids[@]}"; do wait "$pid" 2> /dev/null || true; done
  worker_pids=()
}
# wait_for COMMAND...: polls COMMAND for up to 30 s.
wait_for() {
  for _ in $(seq 300); do "$@" && return 0; sleep 0.1; done
  echo "timed out waiting for: $*"; cat "$tmp/coordinator.err"; return 1
}
registered() {  # registered NAME...: each has registered with the coordinator
  for name; do grep -q 'registered with the coordinator' "$tmp/$name.err" || return 1; done
}

"$pdrmesh" run -q "$surface" "${options[@]}" -o "$tmp/run.meshb"

# Fault-free: two workers.
start_worker w1
start_worker w2
wait_for registered w1 w2
"$pdrmesh" submit "$surface" "${options[@]}" --wait -o "$tmp/job.meshb" --json > "$tmp/submit.json"
[[ $(json_field state < "$tmp/submit.json") == succeeded ]]
id=$(json_field id < "$tmp/submit.json")
cmp "$tmp/job.meshb" "$tmp/run.meshb"
echo "ok: job $id, refined by 2 workers, is byte-identical to pdrmesh run ${options[*]}"
# Both kinds of leaf task went to the workers: refinement and optimization (at
# depth 2 the optimization is its one final task).
# (grep reads the files itself: `cat | grep -q` under pipefail fails whenever
# grep stops at a match before cat has written everything, cat then dying of
# SIGPIPE; it failed so once, with both kinds of task in the logs.)
for kernel in native optimize-final; do
  grep -q "($kernel kernel)" "$tmp/w1.err" "$tmp/w2.err" ||
    { echo "no worker ran a $kernel leaf task"; cat "$tmp/w1.err" "$tmp/w2.err"; exit 1; }
done
echo "ok: the workers ran the refinement's and the optimization's leaf tasks"
for suffix in vtu mesh ugrid msh su2; do
  "$pdrmesh" fetch "$id" -o "$tmp/job.$suffix" > /dev/null
  "$pdrmesh" validate "$tmp/job.$suffix" --surface "$surface" > /dev/null
done
echo "ok: every format fetched validates against the surface"

# Faults: three slow workers (each leaf waits 150 ms first: a test-only knob);
# once leaves are being merged, w3 is killed and w4 stopped past the deadline.
stop_workers
start_worker w3 PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150
start_worker w4 PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150
start_worker w5 PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150
w3=${worker_pids[0]} w4=${worker_pids[1]}
wait_for registered w3 w4 w5
"$pdrmesh" submit "$surface" "${options[@]}" --json > "$tmp/submit2.json"
id2=$(json_field id < "$tmp/submit2.json")
leaves_done() { [[ $("$pdrmesh" status "$1" --json | json_field leaves_done) -ge 2 ]]; }  # JOB_ID
wait_for leaves_done "$id2"
kill -9 "$w3"
kill -STOP "$w4"
"$pdrmesh" watch "$id2" > /dev/null 2>&1 || true
"$pdrmesh" status "$id2" --json > "$tmp/status2.json"
[[ $(json_field state < "$tmp/status2.json") == succeeded ]] || { cat "$tmp/status2.json"; exit 1; }
"$pdrmesh" fetch "$id2" -o "$tmp/job2.meshb" > /dev/null
cmp "$tmp/job2.meshb" "$tmp/run.meshb"
kill -CONT "$w4"
# The coordinator saw the faults: a worker taken out after a failed call,
# forgotten after missed heartbeats, or a leaf given to another worker.
grep -Eq 'taken out|missed [0-9]+ heartbeats|giving the leaf to another worker' "$tmp/coordinator.err" ||
  { echo "the coordinator noticed no fault"; cat "$tmp/coordinator.err"; exit 1; }
echo "ok: job $id2 survived a SIGKILLed and a SIGSTOPped worker with the same bytes"

# A worker joining mid-job: the job starts on one slow worker; once leaves are
# being merged a second registers, and the job runs two leaf tasks at once. A
# fresh coordinator (logging at info), so that no worker killed above still
# counts until its heartbeats are missed.
stop_workers
stop_coordinator
: > "$tmp/coordinator.err"
coord_log_level=info start_coordinator "$tmp/data3" --worker-listen 127.0.0.1:0 \
  --cluster-token-file "$tmp/cluster-token" --leaf-deadline 3
registry=$(sed -n 's/^workers on //p' "$tmp/coordinator.out")
start_worker w6 PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150
wait_for registered w6
"$pdrmesh" submit "$surface" "${options[@]}" --json > "$tmp/submit3.json"
id3=$(json_field id < "$tmp/submit3.json")
wait_for leaves_done "$id3"
start_worker w7 PDRMESH_WORKER_TEST_LEAF_DELAY_MS=150
wait_for registered w7
"$pdrmesh" watch "$id3" > /dev/null 2>&1 || true
"$pdrmesh" fetch "$id3" -o "$tmp/job3.meshb" > /dev/null
cmp "$tmp/job3.meshb" "$tmp/run.meshb"
grep -q "job $id3: 2 leaf task(s) at once, 1 before" "$tmp/coordinator.err" ||
  { echo "job $id3 did not widen to the new worker"; grep "job $id3" "$tmp/coordinator.err"; exit 1; }
grep -Eq '\((native|optimize|optimize-final) kernel\)' "$tmp/w7.err" || { echo "the worker that joined ran no leaf"; exit 1; }
echo "ok: job $id3 widened to a worker that registered during it, with the same bytes"
