#!/usr/bin/env bash
# The service end to end with real processes on loopback (a coordinator, no
# workers: leaves run in its process): `pdrmesh submit --wait -o` gives the same
# bytes as `pdrmesh run` with the same options; every format fetched validates
# against the surface; CGNS and polyMesh fetched are run's files, names and regions
# kept; --json parses; --farfield and --layers as in run; the client config file, the
# environment and flags in their order of precedence; delete; exit codes.
# Usage: service.sh PDRMESH COORDINATOR SURFACE [MESH OPTIONS...]
set -euo pipefail
source "$(dirname "$0")/coordinator_lib.sh"
service_test_setup "$@"
printf 'alice tok-alice\nbob tok-bob\n' > "$tmp/tokens"
start_coordinator "$tmp/data" --leaf-threads 2

expect_exit() {  # expect_exit CODE COMMAND...
  local want=$1; shift
  set +e; "$@" > "$tmp/out" 2> "$tmp/err"; local got=$?; set -e
  [[ $got == "$want" ]] || { echo "expected exit $want, got $got: $*"; cat "$tmp/err"; exit 1; }
}

# The token from a config file (token_file), the server from the environment.
echo tok-alice > "$tmp/alice.token"
printf '{"token_file": "%s", "timeout_s": 60}\n' "$tmp/alice.token" > "$tmp/client.json"
export PDRMESH_CONFIG=$tmp/client.json

"$pdrmesh" submit "$surface" "${options[@]}" --wait -o "$tmp/job.meshb" --json > "$tmp/submit.json"
[[ $(json_field state < "$tmp/submit.json") == succeeded ]]
id=$(json_field id < "$tmp/submit.json")
"$pdrmesh" run -q "$surface" "${options[@]}" -o "$tmp/run.meshb"
cmp "$tmp/job.meshb" "$tmp/run.meshb"
echo "ok: job $id is byte-identical to pdrmesh run ${options[*]}"

for suffix in vtu mesh ugrid lb8.ugrid b8.ugrid msh su2; do
  "$pdrmesh" fetch "$id" -o "$tmp/job.$suffix" --json > "$tmp/fetch.json"
  [[ $(json_field bytes < "$tmp/fetch.json") == $(stat -c %s "$tmp/job.$suffix") ]]
  "$pdrmesh" validate "$tmp/job.$suffix" --surface "$surface" > /dev/null
done
echo "ok: every format fetched validates against the surface"

# Boundary names (--names): the job's SU2 markers and .mapbc carry them, as pdrmesh run's do.
printf '1 body\n' > "$tmp/names.txt"
named_id=$("$pdrmesh" submit "$surface" "${options[@]}" --names "$tmp/names.txt" --wait -o "$tmp/named.su2" 2>/dev/null)
"$pdrmesh" run -q "$surface" "${options[@]}" --names "$tmp/names.txt" -o "$tmp/run-named.su2"
cmp "$tmp/named.su2" "$tmp/run-named.su2"
grep -qx 'MARKER_TAG= body' "$tmp/named.su2"
"$pdrmesh" fetch "$named_id" -o "$tmp/named.ugrid" > /dev/null 2>&1
[[ $(cat "$tmp/named.mapbc") == $'1\n1 3000 body' ]]
printf '1 two words\n' > "$tmp/bad-names.txt"
expect_exit 65 "$pdrmesh" submit "$surface" --names "$tmp/bad-names.txt"
grep -q 'bad-names.txt:1:' "$tmp/err"
"$pdrmesh" delete "$named_id" > /dev/null
echo "ok: names reach the job's SU2 markers and .mapbc"

# External flow (--farfield): the coordinator makes the same domain as pdrmesh run.
far=(--farfield 3 --farfield-shape sphere)
far_id=$("$pdrmesh" submit "$surface" "${options[@]}" "${far[@]}" --wait -o "$tmp/far.su2" 2>/dev/null)
"$pdrmesh" run -q "$surface" "${options[@]}" "${far[@]}" -o "$tmp/run-far.su2"
cmp "$tmp/far.su2" "$tmp/run-far.su2"
[[ $(grep '^MARKER_TAG=' "$tmp/far.su2" | paste -sd' ') == "MARKER_TAG= wall MARKER_TAG= farfield" ]]
"$pdrmesh" status "$far_id" --json | python3 -c '
import json, sys
o = json.load(sys.stdin)["options"]
assert o["farfield"] == 3 and o["farfield_shape"] == "sphere", o'
"$pdrmesh" delete "$far_id" > /dev/null
expect_exit 64 "$pdrmesh" submit "$surface" --farfield 0.5
echo "ok: a --farfield job is byte-identical to pdrmesh run --farfield"

# Prism layers: the coordinator grows them as pdrmesh run does (the y+ and the walls resolved
# there); the CGNS the client writes from the job's VTU is run's, names included.
lay=(--farfield 3 --layers 3 --first-height yplus:1 --reynolds 1e5 --growth-ratio 1.3)
lay_id=$("$pdrmesh" submit "$surface" "${options[@]}" "${lay[@]}" --wait -o "$tmp/layers.cgns" 2>/dev/null)
"$pdrmesh" run -q "$surface" "${options[@]}" "${lay[@]}" -o "$tmp/run-layers.cgns"
cmp "$tmp/layers.cgns" "$tmp/run-layers.cgns"
"$pdrmesh" fetch "$lay_id" -o "$tmp/layers.meshb"
"$pdrmesh" validate "$tmp/layers.meshb" | grep -q "prisms 5544" || { echo "no 5544 prisms in the job's .meshb"; exit 1; }
"$pdrmesh" delete "$lay_id" > /dev/null
expect_exit 64 "$pdrmesh" submit "$surface" --layers 3
expect_exit 65 "$pdrmesh" submit "$surface" --layers 3 --first-height 0.01 --layers-on wing
grep -q "wing names no surface" "$tmp/err" || { echo "layers-on: $(cat "$tmp/err")"; exit 1; }
echo "ok: a --layers job is byte-identical to pdrmesh run --layers"

# CGNS and polyMesh, which the client writes from the job's VTU: the files pdrmesh run writes,
# with the names and the regions, on two regions (the OBJ groups fluid and body: a box in a box).
python3 - "$tmp/two.obj" <<'PY'
import sys
quads = [(0, 4, 6, 2), (1, 3, 7, 5), (0, 1, 5, 4), (2, 6, 7, 3), (4, 5, 7, 6), (0, 2, 3, 1)]
with open(sys.argv[1], "w") as out:
    for k, (name, lo, hi) in enumerate((("fluid", 0, 4), ("body", 1.5, 2.5))):
        out.write(f"g {name}\n")
        out.writelines(f"v {hi if c & 1 else lo} {hi if c & 2 else lo} {hi if c & 4 else lo}\n" for c in range(8))
        out.writelines("f " + " ".join(str(8 * k + i + 1) for i in q) + "\n" for q in quads)
PY
two=(--size 0.5 --depth 1)
two_id=$("$pdrmesh" submit "$tmp/two.obj" "${two[@]}" --wait -o "$tmp/two-job.cgns" 2>/dev/null)
"$pdrmesh" fetch "$two_id" -o "$tmp/job/constant/polyMesh" --json > "$tmp/fetch.json"
[[ $(json_field bytes < "$tmp/fetch.json") -gt 0 ]]
"$pdrmesh" run -q "$tmp/two.obj" "${two[@]}" -o "$tmp/two-run.cgns"
"$pdrmesh" run -q "$tmp/two.obj" "${two[@]}" -o "$tmp/run/constant/polyMesh"
cmp "$tmp/two-job.cgns" "$tmp/two-run.cgns"
diff -r "$tmp/job/constant/polyMesh" "$tmp/run/constant/polyMesh"
[[ $(sed -n 's/^    \([a-z]\+\)$/\1/p' "$tmp/job/constant/polyMesh/cellZones" | paste -sd' ') == "fluid body" ]]
[[ $(sed -n 's/^    \([a-z]\+\)$/\1/p' "$tmp/job/constant/polyMesh/boundary" | paste -sd' ') == fluid ]]  # body: internal faces
[[ $(ls -A "$tmp/job/constant") == polyMesh ]]  # the VTU it was written from is gone
expect_exit 64 "$pdrmesh" fetch "$two_id" -o "$tmp/two.xyz"
"$pdrmesh" delete "$two_id" > /dev/null
echo "ok: fetch -o .cgns and -o polyMesh give pdrmesh run's files, regions and names included"

"$pdrmesh" status "$id" --json | json_field leaves_total > /dev/null
"$pdrmesh" list --json | python3 -c 'import json,sys; j=json.load(sys.stdin); assert len(j["jobs"])==1, j'

# Precedence: a flag beats the environment, which beats the config file.
expect_exit 77 "$pdrmesh" list --token tok-wrong
PDRMESH_TOKEN=tok-wrong expect_exit 77 "$pdrmesh" list
PDRMESH_TOKEN=tok-wrong expect_exit 0 "$pdrmesh" list --token tok-alice
printf '{"server": "127.0.0.1:1", "token": "tok-alice"}\n' > "$tmp/other.json"
expect_exit 0 "$pdrmesh" list --config "$tmp/other.json"        # PDRMESH_SERVER beats the file's server
(unset PDRMESH_SERVER; expect_exit 69 "$pdrmesh" list --config "$tmp/other.json")  # nothing listens there
(unset PDRMESH_SERVER PDRMESH_CONFIG; expect_exit 64 "$pdrmesh" list)             # no server anywhere
expect_exit 64 "$pdrmesh" list --config "$tmp/missing.json"
expect_exit 77 "$pdrmesh" list --json --token tok-wrong
[[ $(json_field error.code < "$tmp/out") == UNAUTHENTICATED ]]

# Another user's job is not found; a broken surface is bad input.
expect_exit 66 "$pdrmesh" status "$id" --token tok-bob
printf 'solid x\nendsolid x\n' > "$tmp/empty.stl"
expect_exit 65 "$pdrmesh" submit "$tmp/empty.stl"

"$pdrmesh" delete "$id" --json | json_field id > /dev/null
expect_exit 66 "$pdrmesh" status "$id"
[[ ! -e $tmp/data/jobs/$id ]]
echo "ok: json output, config precedence, exit codes, delete"
