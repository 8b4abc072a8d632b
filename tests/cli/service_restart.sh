#!/usr/bin/env bash
# A coordinator killed with SIGKILL in the middle of a job and restarted on the
# same data directory finishes the job with the same bytes as `pdrmesh run`;
# a job finished before the kill keeps its result.
# Usage: service_restart.sh PDRMESH COORDINATOR SURFACE [MESH OPTIONS...]
set -euo pipefail
source "$(dirname "$0")/coordinator_lib.sh"
service_test_setup "$@"
export PDRMESH_TOKEN=tok-alice
printf 'alice tok-alice\n' > "$tmp/tokens"
start_coordinator "$tmp/data" --leaf-threads 1

# A finished job first (initial mesh alone: quick).
done_id=$("$pdrmesh" submit "$surface" --max-volume 1e9 -o "$tmp/before.meshb" --output json 2> /dev/null | json_field id)

id=$("$pdrmesh" submit "$surface" "${options[@]}")
# Kill it once the job is in its leaf rounds.
for _ in $(seq 600); do
  phase=$("$pdrmesh" status "$id" --output json | json_field phase)
  [[ $phase == refinement || $phase == "interface round" ]] && break
  sleep 0.05
done
[[ $phase == refinement || $phase == "interface round" ]] || { echo "the job never reached its leaf rounds ($phase)"; exit 1; }
kill -9 "$coord_pid"
wait "$coord_pid" 2> /dev/null || true
coord_pid=
echo "killed the coordinator during the job's $phase"

start_coordinator "$tmp/data" --leaf-threads 1
"$pdrmesh" watch "$id" > /dev/null 2>&1
"$pdrmesh" fetch "$id" -o "$tmp/job.meshb" 2> /dev/null
"$pdrmesh" run -q "$surface" "${options[@]}" -o "$tmp/run.meshb"
cmp "$tmp/job.meshb" "$tmp/run.meshb"
"$pdrmesh" fetch "$done_id" -o "$tmp/after.meshb" 2> /dev/null
cmp "$tmp/before.meshb" "$tmp/after.meshb"
echo "ok: the restarted coordinator finished job $id with the bytes of pdrmesh run; the finished job kept its result"
