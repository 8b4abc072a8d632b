#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Multi-host faults in network namespaces made here: the coordinator and three
# worker daemons each in their own namespace, joined by veth pairs to a bridge
# in a fifth namespace, on loopback-range addresses (127.77.0.0/24, with
# route_localnet so the kernel routes them over the veths). During jobs whose
# leaves are slowed by the test-only knob PDRMESH_WORKER_TEST_LEAF_DELAY_MS:
# w1's link is cut then restored, w2 gets 150 ms delay and 10% loss (tc
# netem), w3 is killed with SIGKILL. Every job must succeed with the same bytes
# as a fault-free `pdrmesh run`, and the coordinator's debug log must show each
# leaf of each job accepted exactly once (no leaf merged twice).
# Skips (exit 77) where namespaces cannot be made (not root, no ip/tc, a
# container without CAP_NET_ADMIN).
# Usage: netns_faults.sh PDRMESH COORDINATOR WORKER SURFACE [MESH OPTIONS...]
set -euo pipefail
pdrmesh=$1 coordinator=$2 worker_bin=$3 surface=$4
options=("${@:5}")
[[ -f $surface ]] || { echo "test surface $surface not found"; exit 1; }
for tool in ip tc; do
  command -v "$tool" > /dev/null || { echo "no '$tool' command: namespace fault test skipped"; exit 77; }
done

tag=pdr$$
ns_br=$tag-br ns_c=$tag-c
names=(c w1 w2 w3)
declare -A addr=([c]=127.77.0.2 [w1]=127.77.0.11 [w2]=127.77.0.12 [w3]=127.77.0.13)
tmp=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -9 "$pid" 2> /dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2> /dev/null || true; done
  for n in "${names[@]}" br; do  # anything still inside our namespaces is ours
    for pid in $(ip netns pids "$tag-$n" 2> /dev/null); do kill -9 "$pid" 2> /dev/null || true; done
    ip netns del "$tag-$n" 2> /dev/null || true
  done
  rm -rf "$tmp"
}
trap cleanup EXIT

if ! ip netns add "$ns_br" 2> "$tmp/netns.err"; then
  echo "cannot create a network namespace ($(cat "$tmp/netns.err")): namespace fault test skipped"
  exit 77
fi
# setup_ns NAME: namespace $tag-NAME, veth v-NAME (inside) <-> b-NAME (on the bridge).
setup_ns() {
  local n=$1 ns=$tag-$1
  ip netns add "$ns"
  ip link add "v$tag$n" netns "$ns" type veth peer name "b$n" netns "$ns_br"
  ip -n "$ns" link set "v$tag$n" name eth0
  ip -n "$ns" link set lo up
  # lo owns all of 127/8 by default: keep only 127.0.0.1 so 127.77/24 goes over eth0.
  ip -n "$ns" addr del 127.0.0.1/8 dev lo
  ip -n "$ns" addr add 127.0.0.1/32 dev lo
  for conf in all default eth0; do ip netns exec "$ns" sysctl -qw "net.ipv4.conf.$conf.route_localnet=1"; done
  ip -n "$ns" addr add "${addr[$n]}/24" dev eth0
  ip -n "$ns" link set eth0 up
  ip -n "$ns_br" link set "b$n" master br0 up
}
if ! { ip -n "$ns_br" link add br0 type bridge && ip -n "$ns_br" link set br0 up; } 2> "$tmp/netns.err"; then
  echo "cannot create a bridge in a namespace ($(cat "$tmp/netns.err")): namespace fault test skipped"
  exit 77
fi
for n in "${names[@]}"; do setup_ns "$n"; done
in_ns() { local n=$1; shift; ip netns exec "$tag-$n" "$@"; }
echo "ok: namespaces $tag-{c,w1,w2,w3,br} on 127.77.0.0/24"

printf 'alice tok-alice\n' > "$tmp/tokens"
head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$tmp/cluster-token"
unset PDRMESH_TOKEN_FILE PDRMESH_CONFIG PDRMESH_TLS_CA
export XDG_CONFIG_HOME=$tmp/config PDRMESH_TOKEN=tok-alice
# Daemons are started with exec, so that $! is the daemon itself (ip netns exec execs it).
(exec ip netns exec "$ns_c" "$coordinator" --listen "${addr[c]}:7000" --data-dir "$tmp/data" --tokens "$tmp/tokens" \
  --worker-listen "${addr[c]}:7001" --cluster-token-file "$tmp/cluster-token" --leaf-deadline 4 \
  --log-level debug > "$tmp/coordinator.out" 2> "$tmp/coordinator.err") &
pids+=($!)
export PDRMESH_SERVER=${addr[c]}:7000
declare -A wpid
start_worker() {  # start_worker NAME
  (exec ip netns exec "$tag-$1" env PDRMESH_WORKER_TEST_LEAF_DELAY_MS=200 "$worker_bin" --listen "${addr[$1]}:7100" \
    --coordinator "${addr[c]}:7001" --threads 1 --cluster-token-file "$tmp/cluster-token" --log-level info \
    > "$tmp/$1.out" 2>> "$tmp/$1.err") &
  pids+=($!)
  wpid[$1]=$!
}
wait_for() {  # wait_for COMMAND...: polls COMMAND for up to 60 s
  for _ in $(seq 600); do "$@" && return 0; sleep 0.1; done
  echo "timed out waiting for: $*"; tail -30 "$tmp/coordinator.err"; return 1
}
registered() { for n; do grep -q 'registered with the coordinator' "$tmp/$n.err" || return 1; done; }
client() { in_ns c "$pdrmesh" "$@"; }
for n in w1 w2 w3; do start_worker "$n"; done
wait_for registered w1 w2 w3

"$pdrmesh" run -q "$surface" "${options[@]}" -o "$tmp/run.meshb"

jobs=()
submit() { client submit "$surface" "${options[@]}" --json | json_field id; }
json_field() {
  python3 -c 'import json,sys
v=json.load(sys.stdin)
for k in sys.argv[1].split("."): v=v[k]
print(v)' "$1"
}
leaves_done() { [[ $(client status "$1" --json | json_field leaves_done) -ge $2 ]]; }
finish() {  # finish ID: waits for the job; it must succeed with the bytes of pdrmesh run
  client watch "$1" > /dev/null 2>&1 || true
  client status "$1" --json > "$tmp/status.json"
  [[ $(json_field state < "$tmp/status.json") == succeeded ]] || { cat "$tmp/status.json"; tail -40 "$tmp/coordinator.err"; exit 1; }
  client fetch "$1" -o "$tmp/$1.meshb" > /dev/null
  cmp "$tmp/$1.meshb" "$tmp/run.meshb"
  jobs+=("$1")
}
faults=0
# impair NAME: delay and loss on NAME's link with tc netem; where the kernel lacks
# netem (CONFIG_NET_SCH_NETEM unset), a tbf rate limit whose short queue delays
# and drops packets instead (said so in the output).
impair() {
  if in_ns "$1" tc qdisc add dev eth0 root netem delay 150ms 30ms loss 10% 2> /dev/null; then
    impairment="tc netem: 150 ms +- 30 ms delay, 10% loss on $1"
  else
    in_ns "$1" tc qdisc add dev eth0 root tbf rate 2mbit burst 8kb latency 100ms
    impairment="tc tbf (no netem in this kernel): 2 Mbit/s, packets queued up to 100 ms then dropped, on $1"
  fi
  echo "impaired: $impairment"
}

# Job 0: fault-free, the reference for which leaves a job merges.
finish "$(submit)"
echo "ok: fault-free job ${jobs[0]} on 3 workers in namespaces, same bytes as pdrmesh run"

# Job 1: w1's link cut (past the leaf deadline) then restored; w2 delayed and lossy.
id=$(submit)
wait_for leaves_done "$id" 2
ip -n "$ns_br" link set bw1 down
impair w2
faults=$((faults + 2))
sleep 6
ip -n "$ns_br" link set bw1 up
finish "$id"
echo "ok: job $id survived w1's link cut for 6 s and $impairment, same bytes"

# Job 2: w3 killed mid-job (w2 still lossy; w1 back after its backoff).
id=$(submit)
wait_for leaves_done "$id" 2
kill -9 "${wpid[w3]}"
wait "${wpid[w3]}" 2> /dev/null || true
faults=$((faults + 1))
finish "$id"
echo "ok: job $id survived SIGKILL of w3, same bytes"

# Job 3: the network healed (impairment off), w3 back; w1's link cut again briefly (under the deadline).
in_ns w2 tc qdisc del dev eth0 root
start_worker w3
id=$(submit)
wait_for leaves_done "$id" 1
ip -n "$ns_br" link set bw1 down
sleep 1.5
ip -n "$ns_br" link set bw1 up
faults=$((faults + 1))
finish "$id"
echo "ok: job $id survived a 1.5 s cut of w1's link, same bytes"

# No leaf merged twice: the coordinator logs (debug) one 'accepted' line per leaf
# result it merges. A job's decomposition is deterministic, so each faulted job
# must merge exactly the leaves of the fault-free job 0, as many times each
# (leaf numbers repeat across the two rounds and the fix-up sweeps).
accepted() {
  grep -o "job $1 leaf [0-9]*: result from .* accepted" "$tmp/coordinator.err" | awk '{print $4}' | sort -n | uniq -c
}
accepted "${jobs[0]}" > "$tmp/accepted.ref"
[[ -s $tmp/accepted.ref ]] || { echo "no accepted leaf in the coordinator's log"; exit 1; }
for j in "${jobs[@]:1}"; do
  accepted "$j" > "$tmp/accepted.$j"
  diff "$tmp/accepted.ref" "$tmp/accepted.$j" > /dev/null || {
    echo "job $j merged leaves differently from the fault-free job (count leaf):"
    diff "$tmp/accepted.ref" "$tmp/accepted.$j"; exit 1; }
done
echo "ok: every faulted job merged the fault-free job's $(awk '{n+=$1} END {print n}' "$tmp/accepted.ref") leaf results, none twice"
retries=$(grep -c 'giving the leaf to another worker' "$tmp/coordinator.err" || true)
echo "ok: ${#jobs[@]} jobs (3 faulted), $faults faults injected, $retries leaf attempts retried elsewhere, 0 bytes lost"
