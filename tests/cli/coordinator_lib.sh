# Sourced by the service CLI tests, bench/load.sh and bench/soak.sh: start and stop a real
# pdrmesh-coordinator (and workers) on loopback. Needs $tmp (a scratch directory) and
# $coordinator (the binary).

# service_test_setup "$@" (the test's arguments PDRMESH COORDINATOR SURFACE
# [MESH OPTIONS...]): sets pdrmesh, coordinator, surface, options and tmp (removed,
# with the coordinator stopped, on exit); fails when the surface is absent; no
# client config or token from the caller's environment leaks in.
service_test_setup() {
  pdrmesh=$1 coordinator=$2 surface=$3
  options=("${@:4}")
  [[ -f $surface ]] || { echo "test surface $surface not found"; exit 1; }
  tmp=$(mktemp -d)
  trap 'stop_coordinator; rm -rf "$tmp"' EXIT
  unset PDRMESH_TOKEN PDRMESH_TOKEN_FILE PDRMESH_CONFIG PDRMESH_TLS_CA
  export XDG_CONFIG_HOME=$tmp/config
}

# bench_setup: for the bench scripts: sets tmp (removed, with the workers and the coordinator
# stopped, on exit) and an empty worker_pids; no client config or token from the caller's
# environment leaks in.
bench_setup() {
  tmp=$(mktemp -d)
  worker_pids=()
  trap 'stop_workers; stop_coordinator; rm -rf "$tmp"' EXIT
  unset PDRMESH_CONFIG PDRMESH_TOKEN PDRMESH_TOKEN_FILE
  export XDG_CONFIG_HOME=$tmp/config
}

# start_coordinator DATA_DIR [FLAGS...]: starts it in the background with the
# tokens file $tmp/tokens, logging at ${coord_log_level:-warn} to $tmp/coordinator.err;
# sets coord_pid and PDRMESH_SERVER (exported).
start_coordinator() {
  local data=$1; shift
  : > "$tmp/coordinator.out"
  "$coordinator" --listen 127.0.0.1:0 --data-dir "$data" --tokens "$tmp/tokens" --log-level "${coord_log_level:-warn}" "$@" \
    > "$tmp/coordinator.out" 2>> "$tmp/coordinator.err" &
  coord_pid=$!
  for _ in $(seq 200); do
    grep -q '^listening on ' "$tmp/coordinator.out" && break
    kill -0 "$coord_pid" 2> /dev/null || { echo "the coordinator died:"; cat "$tmp/coordinator.err"; return 1; }
    sleep 0.05
  done
  PDRMESH_SERVER=$(sed -n 's/^listening on //p' "$tmp/coordinator.out")
  [[ -n $PDRMESH_SERVER ]] || { echo "the coordinator did not start"; cat "$tmp/coordinator.err"; return 1; }
  export PDRMESH_SERVER
}

stop_coordinator() {
  if [[ -n ${coord_pid:-} ]]; then
    kill "$coord_pid" 2> /dev/null || true
    wait "$coord_pid" 2> /dev/null || true
    coord_pid=
  fi
}

# start_workers N [FLAGS...]: N pdrmesh-worker daemons ($worker) in the background, registering with
# the coordinator that start_coordinator started with --worker-listen 127.0.0.1:0 and
# --cluster-token-file $tmp/cluster.token (new_cluster_token writes it); their pids go to worker_pids.
new_cluster_token() { head -c 32 /dev/urandom | base64 > "$tmp/cluster.token"; }
start_workers() {
  local n=$1 wport i; shift
  wport=$(sed -n 's/^workers on //p' "$tmp/coordinator.out")
  for ((i = 1; i <= n; ++i)); do
    "$worker" --coordinator "$wport" --cluster-token-file "$tmp/cluster.token" --log-level warn "$@" \
      > "$tmp/worker$i.out" 2>> "$tmp/worker$i.err" &
    worker_pids+=($!)
  done
}
stop_workers() {
  local p
  for p in "${worker_pids[@]}"; do kill "$p" 2> /dev/null || true; done
  for p in "${worker_pids[@]}"; do wait "$p" 2> /dev/null || true; done
  worker_pids=()
}

# json_field FIELD: prints FIELD of the JSON object on stdin (dots for nesting).
json_field() {
  python3 -c 'import json,sys
v=json.load(sys.stdin)
for k in sys.argv[1].split("."): v=v[k]
print(v)' "$1"
}
