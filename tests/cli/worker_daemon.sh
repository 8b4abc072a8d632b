#!/usr/bin/env bash
# The daemons' worker flags from the outside: --help documents every agreed
# flag; a worker refuses to start without its cluster token or in plaintext on
# a non-loopback address; a coordinator with --worker-listen prints its worker
# port, a worker registers there, and SIGTERM stops both with exit status 0.
# Usage: worker_daemon.sh PDRMESH_WORKER PDRMESH_COORDINATOR
set -euo pipefail
worker=$1 coordinator=$2
tmp=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done; rm -rf "$tmp"; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; for f in "$tmp"/*.log; do echo "== $f"; cat "$f"; done; exit 1; }

whelp=$("$worker" --help)
for flag in --listen --advertise --coordinator --threads --cluster-token-file --tls-cert --tls-key --tls-ca \
            --allow-insecure --drain-timeout --log-level; do
  grep -q -- "$flag" <<<"$whelp" || fail "pdrmesh-worker --help does not document $flag"
done
chelp=$("$coordinator" --help)
for flag in --worker-listen --workers --cluster-token-file --worker-tls-cert --worker-tls-key --worker-tls-ca \
            --leaf-deadline; do
  grep -q -- "$flag" <<<"$chelp" || fail "pdrmesh-coordinator --help does not document $flag"
done

printf 'cluster-secret-%s\n' "$RANDOM$RANDOM$RANDOM" > "$tmp/cluster"
printf 'alice tok-alice\n' > "$tmp/tokens"
if "$worker" --listen 127.0.0.1:0 >/dev/null 2>&1; then fail "worker started without --cluster-token-file"; fi
if "$worker" --listen 0.0.0.0:0 --cluster-token-file "$tmp/cluster" >/dev/null 2>"$tmp/refuse.log"; then
  fail "worker served plaintext on 0.0.0.0 without --allow-insecure"
fi
grep -q "refusing" "$tmp/refuse.log" || fail "no reason given for refusing plaintext"
if "$coordinator" --data-dir "$tmp/data" --tokens "$tmp/tokens" --workers 127.0.0.1:1 >/dev/null 2>&1; then
  fail "coordinator started with --workers but no --cluster-token-file"
fi

# Reads fd 3 up to a line "LABEL HOST:PORT" (30 s at most); prints HOST:PORT.
read_line() {
  local line
  while IFS= read -r -t 30 line <&3; do
    if [[ $line == "$1 "* ]]; then echo "${line#"$1 "}"; return 0; fi
  done
  return 1
}
mkfifo "$tmp/c.out"
"$coordinator" --data-dir "$tmp/data" --tokens "$tmp/tokens" --worker-listen 127.0.0.1:0 \
  --cluster-token-file "$tmp/cluster" --log-level info >"$tmp/c.out" 2>"$tmp/coordinator.log" &
cpid=$!; pids+=("$cpid")
exec 3<"$tmp/c.out"
read_line "listening on" >/dev/null || fail "coordinator did not print 'listening on'"
waddr=$(read_line "workers on") || fail "coordinator did not print 'workers on'"

mkfifo "$tmp/w.out"
"$worker" --listen 127.0.0.1:0 --threads 2 --coordinator "$waddr" --cluster-token-file "$tmp/cluster" \
  >"$tmp/w.out" 2>"$tmp/worker.log" &
wpid=$!; pids+=("$wpid")
exec 3<"$tmp/w.out"
read_line "listening on" >/dev/null || fail "worker did not print 'listening on'"
for _ in $(seq 100); do grep -q "registered from" "$tmp/coordinator.log" && break; sleep 0.1; done
grep -q "registered from" "$tmp/coordinator.log" || fail "the worker did not register"

kill -TERM "$wpid"
wait "$wpid" || fail "worker exited with $? on SIGTERM"
grep -q "leaves" "$tmp/coordinator.log" || fail "the coordinator did not hear the worker leave"
kill -TERM "$cpid"
wait "$cpid" || fail "coordinator exited with $? on SIGTERM"
echo "ok: worker flags, registration and graceful stop"
