#!/usr/bin/env bash
# The service commands' output with a real coordinator on loopback: --json
# prints numbers as numbers and states as the text output names them
# ("succeeded"); `list` prints a header row and an AGE column; -o/--output is
# the file in submit and fetch; --size 1% is resolved in the client; a
# cancelled job reports no counts (tets and points agree); every mesh fetched
# validates against the surface.
# Usage: service_json.sh PDRMESH COORDINATOR SURFACE
set -euo pipefail
source "$(dirname "$0")/coordinator_lib.sh"
service_test_setup "$@"
export PDRMESH_TOKEN=tok-alice
printf 'alice tok-alice\n' > "$tmp/tokens"
start_coordinator "$tmp/data" --leaf-threads 1

"$pdrmesh" submit "$surface" --size 2% --depth 1 --wait --output "$tmp/job.meshb" --json > "$tmp/submit.json" 2> "$tmp/submit.err"
grep -q "^size: .* (2% of the bounding-box diagonal" "$tmp/submit.err" || { cat "$tmp/submit.err"; exit 1; }
"$pdrmesh" validate "$tmp/job.meshb" --surface "$surface" > /dev/null
id=$(json_field id < "$tmp/submit.json")
"$pdrmesh" fetch "$id" --output "$tmp/job.vtu" --json > "$tmp/fetch.json"
"$pdrmesh" validate "$tmp/job.vtu" --surface "$surface" > /dev/null
"$pdrmesh" status "$id" --json > "$tmp/status.json"
"$pdrmesh" list --json > "$tmp/list.json"
python3 - "$tmp" <<'PY'
import json, sys
tmp = sys.argv[1]
submit = json.load(open(f"{tmp}/submit.json"))
status = json.load(open(f"{tmp}/status.json"))
jobs = json.load(open(f"{tmp}/list.json"))["jobs"]
fetch = json.load(open(f"{tmp}/fetch.json"))
for j in [submit, status] + jobs:
    assert j["state"] == "succeeded", j
    for k in ("tets", "points", "input_bytes", "created_unix_ms", "started_unix_ms", "finished_unix_ms",
              "leaves_done", "leaves_total"):
        assert type(j[k]) is int, (k, j[k])
    assert j["tets"] > 0 and j["points"] > 0, j
    assert isinstance(j["options"]["size"], float) and j["options"]["depth"] == 1, j["options"]
assert type(fetch["bytes"]) is int and fetch["bytes"] > 0, fetch
print("ok: JSON numbers are numbers, states as in the text output")
PY

"$pdrmesh" list > "$tmp/list.txt"
head -1 "$tmp/list.txt" | grep -qE '^JOB +STATE +PHASE +PROGRESS +AGE +TETS +INPUT$' || { cat "$tmp/list.txt"; exit 1; }
sed -n 2p "$tmp/list.txt" | grep -qE "^$id +succeeded +done +100% +[0-9]+[smhd] +[0-9]+ +" || { cat "$tmp/list.txt"; exit 1; }
echo "ok: list has a header and an AGE column"

# A job cancelled while it meshes: no counts of a mesh that does not exist.
id2=$("$pdrmesh" submit "$surface" --size 0.4% --depth 2)
for _ in $(seq 400); do
  [[ $("$pdrmesh" status "$id2" --json | json_field tets) -gt 0 ]] && break
  sleep 0.05
done
"$pdrmesh" cancel "$id2" > /dev/null
set +e; "$pdrmesh" watch "$id2" 2> /dev/null; set -e
"$pdrmesh" status "$id2" --json > "$tmp/cancelled.json"
python3 - "$tmp/cancelled.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
if j["state"] == "cancelled":
    assert j["tets"] == 0 and j["points"] == 0, j
    print("ok: the cancelled job reports no tets and no points")
else:  # it finished before the cancel reached it
    assert j["state"] == "succeeded" and j["tets"] > 0 and j["points"] > 0, j
    print("ok (the job finished before the cancel): tets and points both set")
PY
