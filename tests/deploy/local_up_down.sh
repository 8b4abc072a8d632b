#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# deploy/local/up.sh and down.sh against stand-in daemons (shell scripts that print the address
# lines the real ones print and record their arguments): up.sh starts a coordinator and N workers
# with the agreed flags, wired to each other, prints export lines that eval, and down.sh stops
# them with SIGTERM, or SIGKILL for one that ignores SIGTERM. The real daemons: tests/service.
# Usage: local_up_down.sh REPO_ROOT
# shellcheck disable=SC2016,SC2317  # bash -c bodies expand their own arguments; check calls functions
set -uo pipefail
root=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
export TMPDIR=$tmp  # up.sh's default state directory and its "last" pointer land here
failures=0
checks=0
check() {  # check DESCRIPTION COMMAND...
  local what=$1; shift
  checks=$((checks + 1))
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; failures=$((failures + 1)); fi
}

mkdir -p "$tmp/bin/server" "$tmp/bin/worker"
# A stand-in daemon (#!/bin/bash, so that its process name is its file name): records its arguments, prints its address lines, waits for SIGTERM
# (or ignores it when its arguments file's name is in $STUB_IGNORE_TERM).
stub() {  # stub PATH LINES
  cat >"$1" <<END_STUB
#!/bin/bash
args="\$(dirname "\$0")/args.\$\$"
printf '%s\n' "\$@" >"\$args"
if [[ " \${STUB_IGNORE_TERM:-} " == *" \$(basename "\$0") "* ]]; then trap '' TERM; else trap 'exit 0' TERM; fi
$2
while :; do sleep 0.05; done
END_STUB
  chmod +x "$1"
}
stub "$tmp/bin/server/pdrmesh-coordinator" \
  'echo "listening on 127.0.0.1:4$$"; echo "workers on 127.0.0.1:5$$"'
stub "$tmp/bin/worker/pdrmesh-worker" 'echo "listening on 127.0.0.1:6$$"'
export PDRMESH_BIN_DIR=$tmp/bin

up=$root/deploy/local/up.sh
down=$root/deploy/local/down.sh

# Missing binary: a clear message naming it.
out=$(PDRMESH_BIN_DIR=$tmp/nothing "$up" 1 2>&1); rc=$?
check "up.sh without binaries fails naming the binary" \
  bash -c '[[ $0 -ne 0 && $1 == *"pdrmesh-coordinator not found"* ]]' "$rc" "$out"

# Two workers.
exports=$("$up" 2 --threads 3 2>"$tmp/up.err"); rc=$?
check "up.sh 2 succeeds" test "$rc" -eq 0
cat "$tmp/up.err"
unset PDRMESH_SERVER PDRMESH_TOKEN PDRMESH_LOCAL_DIR
eval "$exports"
check "stdout is only export lines" bash -c '! grep -qv "^export PDRMESH_[A-Z_]*=" <<<"$0"' "$exports"
check "PDRMESH_SERVER is the coordinator's client address" \
  bash -c '[[ $0 =~ ^127\.0\.0\.1:4[0-9]+$ ]]' "${PDRMESH_SERVER:-}"
dir=${PDRMESH_LOCAL_DIR:-/nonexistent}
check "PDRMESH_TOKEN is the generated token of the tokens file" \
  bash -c '[[ ${#1} -eq 64 ]] && grep -qE "^[A-Za-z0-9._-]+ $1\$" "$0/tokens"' "$dir" "${PDRMESH_TOKEN:-}"
check "the cluster token is 64 hex digits" grep -qxE '[0-9a-f]{64}' "$dir/cluster-token"
check "secrets are private to the user" bash -c '[[ $(stat -c %a "$0/tokens") == 600 ]]' "$dir"
coordinator_pid=$(cat "$dir/run/coordinator.pid")
check "the coordinator got the agreed flags" bash -c '
  a=$(cat "$0"); grep -qx -- "--worker-listen" <<<"$a" && grep -qx -- "127.0.0.1:0" <<<"$a" &&
  grep -qx -- "$1/data" <<<"$a" && grep -qx -- "$1/tokens" <<<"$a" &&
  grep -qx -- "--cluster-token-file" <<<"$a" && grep -qx -- "$1/cluster-token" <<<"$a"' \
  "$tmp/bin/server/args.$coordinator_pid" "$dir"
worker_pids=()
for i in 1 2; do
  pid=$(cat "$dir/run/worker-$i.pid")
  worker_pids+=("$pid")
  check "worker-$i runs and registers at the coordinator's worker address" bash -c '
    kill -0 "$0" && a=$(cat "$1") && grep -qx -- "--coordinator" <<<"$a" &&
    grep -qx "127.0.0.1:5$2" <<<"$a" && grep -qx -- "--threads" <<<"$a" && grep -qx 3 <<<"$a"' \
    "$pid" "$tmp/bin/worker/args.$pid" "$coordinator_pid"
done
check "a second up.sh into the same directory is refused" bash -c '! "$0" 1 --data-dir "$1" 2>/dev/null' "$up" "$dir"

# down.sh with no argument: the last one started (here, through PDRMESH_LOCAL_DIR too).
report=$("$down" 2>&1); rc=$?
echo "$report"
check "down.sh succeeds" test "$rc" -eq 0
check "down.sh reports each process stopped by SIGTERM" \
  bash -c '[[ $(grep -c "stopped by SIGTERM" <<<"$0") -eq 3 ]]' "$report"
running() {  # running PID: alive and not a zombie (nothing may reap orphans here)
  local stat
  stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
  stat=${stat##*) }
  [[ ${stat%% *} != Z ]]
}
export -f running
nothing_left() {
  local f
  for f in "$dir"/run/*.pid; do [[ ! -e $f ]] || { echo "left: $f"; return 1; }; done
  ! running "$coordinator_pid" || { echo "coordinator $coordinator_pid still runs"; return 1; }
  for f in "${worker_pids[@]}"; do ! running "$f" || { echo "worker $f still runs"; return 1; }; done
}
check "nothing is left running" nothing_left
check "the state directory is kept" test -f "$dir/tokens"

# A worker that ignores SIGTERM is killed after the timeout; --rm deletes the directory.
unset PDRMESH_LOCAL_DIR
eval "$(STUB_IGNORE_TERM=pdrmesh-worker "$up" 1 --data-dir "$tmp/second" 2>/dev/null)"
check "up.sh --data-dir uses that directory" test "${PDRMESH_LOCAL_DIR:-}" = "$tmp/second"
report=$("$down" "$tmp/second" --timeout 1 --rm 2>&1); rc=$?
echo "$report"
check "down.sh kills a worker that ignores SIGTERM" \
  bash -c '[[ $1 -eq 0 && $0 == *"worker-1"*"killed with SIGKILL"* && $0 == *"removed"* ]]' "$report" "$rc"
check "down.sh --rm removed the directory" test ! -e "$tmp/second"

# A worker that exits right after printing its address (say, refused at registration): up.sh
# fails naming it and stops the coordinator it had started.
cat >"$tmp/bin/worker/pdrmesh-worker" <<'END_STUB'
#!/bin/bash
echo "listening on 127.0.0.1:7"
echo "error: UNAUTHENTICATED: wrong cluster token" >&2
exit 1
END_STUB
out=$("$up" 1 --data-dir "$tmp/fourth" 2>&1); rc=$?
check "up.sh reports a worker that exits after starting" \
  bash -c '[[ $1 -ne 0 && $0 == *"worker-1 exited after starting"* && $0 == *"wrong cluster token"* ]]' "$out" "$rc"
check "up.sh stopped the coordinator it had started" bash -c '! running "$0"' "$(cat "$tmp/fourth/run/coordinator.pid")"

# A coordinator that dies at start: up.sh fails, shows its log and leaves nothing running.
cat >"$tmp/bin/server/pdrmesh-coordinator" <<'END_STUB'
#!/bin/bash
echo "error: --worker-listen: unknown option" >&2
exit 2
END_STUB
out=$("$up" 1 --data-dir "$tmp/third" 2>&1); rc=$?
check "up.sh reports a coordinator that exits at start, with its log" \
  bash -c '[[ $1 -ne 0 && $0 == *"exited before printing"* && $0 == *"unknown option"* ]]' "$out" "$rc"

echo "$((checks - failures)) passed, $failures failed"
exit $((failures > 0))
