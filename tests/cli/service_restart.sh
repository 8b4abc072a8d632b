#!/usr/bin/env bash
# A coordinator killed with SIGKILL in the middle of a job and restarted on the
# same data directory goes on from the job's last round checkpoint and finishes
# it with the same bytes as `pdrmesh run`; a job finished before the kill keeps
# its result.
# Usage: service_restart.sh PDRMESH COORDINATOR SURFACE [MESH OPTIONS...]
set -euo pipefail
source "$(dirname "$0")/coordinator_lib.sh"
service_test_setup "$@"
export PDRMESH_TOKEN=tok-alice
printf 'alice tok-alice\n' > "$tmp/tokens"
# The first coordinator's jobs wait after each round checkpoint (a test-only
# knob), so that the kill below finds one standing however fast the job is.
PDRMESH_COORDINATOR_TEST_CHECKPOINT_DELAY_MS=3000 start_coordinator "$tmp/data" --leaf-threads 1

# A finished job first (initial mesh alone: quick).
done_id=$("$pdrmesh" submit "$surface" --max-volume 1e9 -o "$tmp/before.meshb" --json 2> /dev/null | json_field id)

id=$("$pdrmesh" submit "$surface" "${options[@]}")
# Kill it once the job has stored the checkpoint of its first round.
checkpoint=$tmp/data/jobs/$id/checkpoint.pdrck
for _ in $(seq 1200); do
  [[ -f $checkpoint ]] && break
  sleep 0.025
done
[[ -f $checkpoint ]] || { echo "the job stored no round checkpoint"; "$pdrmesh" status "$id"; exit 1; }
kill -9 "$coord_pid"
wait "$coord_pid" 2> /dev/null || true
coord_pid=
echo "killed the coordinator after the job's first round"

: > "$tmp/coordinator.err"
coord_log_level=info start_coordinator "$tmp/data" --leaf-threads 1
"$pdrmesh" watch "$id" > /dev/null 2>&1
grep -q "job $id: resuming after its round" "$tmp/coordinator.err" ||
  { echo "the restarted coordinator did not resume from the checkpoint:"; cat "$tmp/coordinator.err"; exit 1; }
[[ ! -e $checkpoint ]] || { echo "the finished job's checkpoint was not removed"; exit 1; }
"$pdrmesh" fetch "$id" -o "$tmp/job.meshb" 2> /dev/null
"$pdrmesh" run -q "$surface" "${options[@]}" -o "$tmp/run.meshb"
cmp "$tmp/job.meshb" "$tmp/run.meshb"
"$pdrmesh" fetch "$done_id" -o "$tmp/after.meshb" 2> /dev/null
cmp "$tmp/before.meshb" "$tmp/after.meshb"
echo "ok: the restarted coordinator went on from job $id's checkpoint and finished it with the bytes of pdrmesh run;" \
  "the finished job kept its result"
