#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Stops a service that deploy/local/up.sh started: the workers first (SIGTERM: they finish or
# hand back their leaves), then the coordinator; whatever still runs after the timeout gets
# SIGKILL. Reports each process. Keeps the state directory (jobs, results, logs) unless --rm.
# Usage: down.sh [DIR] [--timeout SECONDS] [--rm]
#   DIR        the state directory (default: $PDRMESH_LOCAL_DIR, else the last one up.sh started)
#   --timeout  seconds to wait after SIGTERM, per group (default 20)
#   --rm       delete the state directory afterwards
set -euo pipefail

me=down.sh
say() { echo "$me: $*" >&2; }
die() { say "error: $*"; exit 1; }
usage() { sed -n 's/^# \{0,1\}//; 6,9p' "${BASH_SOURCE[0]}" >&2; exit "${1:-64}"; }

dir=""
timeout=20
remove=0
while (($#)); do
  case $1 in
    -h | --help) usage 0 ;;
    --timeout) (($# >= 2)) || die "--timeout needs seconds"; timeout=$2; shift 2 ;;
    --timeout=*) timeout=${1#*=}; shift ;;
    --rm) remove=1; shift ;;
    -*) say "unknown option '$1'"; usage ;;
    *) [[ -z $dir ]] || { say "one directory only"; usage; }; dir=$1; shift ;;
  esac
done
[[ $timeout =~ ^(0|[1-9][0-9]*)$ ]] || die "--timeout must be whole seconds, got '$timeout'"
last="${TMPDIR:-/tmp}/pdrmesh-local.$(id -u).last"
if [[ -z $dir ]]; then dir=${PDRMESH_LOCAL_DIR:-}; fi
if [[ -z $dir && -f $last ]]; then dir=$(<"$last"); fi
[[ -n $dir ]] || die "which service? give its state directory (up.sh printed it as PDRMESH_LOCAL_DIR)"
[[ -d $dir/run ]] || die "$dir is not a state directory of up.sh (no run/ in it)"
dir=$(cd "$dir" && pwd)

alive() {  # alive PID BINARY: PID runs and is BINARY (not a zombie, not a reused pid)
  local stat state comm
  stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
  state=${stat##*) }
  [[ ${state%% *} != Z ]] || return 1
  comm=$(cat "/proc/$1/comm" 2>/dev/null) || return 1
  [[ $comm == "${2:0:15}" ]]  # the kernel keeps 15 characters of the name
}

now_ms() { echo $(($(date +%s%N) / 1000000)); }
seconds_since() { local ms=$(($(now_ms) - $1)); printf '%d.%d' $((ms / 1000)) $((ms % 1000 / 100)); }
failed=0
stop_group() {  # stop_group BINARY NAME...: SIGTERM to all, wait, SIGKILL the rest, report
  local binary=$1; shift
  local name pid names=() pids=()
  for name in "$@"; do
    pid=$(<"$dir/run/$name.pid")
    if [[ $pid =~ ^[1-9][0-9]*$ ]] && alive "$pid" "$binary"; then
      kill -TERM "$pid" 2>/dev/null || true
      names+=("$name"); pids+=("$pid")
    else
      say "$name (pid $pid): was not running"
      rm -f "$dir/run/$name.pid"
    fi
  done
  ((${#pids[@]})) || return 0
  local start left i
  start=$(now_ms)
  while :; do
    left=0
    for i in "${!pids[@]}"; do
      [[ -n ${pids[$i]} ]] || continue
      if alive "${pids[$i]}" "$binary"; then
        left=$((left + 1))
      else
        say "${names[$i]} (pid ${pids[$i]}): stopped by SIGTERM after $(seconds_since "$start") s"
        rm -f "$dir/run/${names[$i]}.pid"
        pids[i]=""
      fi
    done
    ((left > 0)) || return 0
    (($(now_ms) - start < timeout * 1000)) || break
    sleep 0.1
  done
  for i in "${!pids[@]}"; do
    [[ -n ${pids[$i]} ]] || continue
    kill -KILL "${pids[$i]}" 2>/dev/null || true
    sleep 0.2
    if alive "${pids[$i]}" "$binary"; then
      say "${names[$i]} (pid ${pids[$i]}): still running after SIGKILL"
      failed=1
    else
      say "${names[$i]} (pid ${pids[$i]}): killed with SIGKILL, still running ${timeout} s after SIGTERM"
      rm -f "$dir/run/${names[$i]}.pid"
    fi
  done
}

workers=()
for f in "$dir"/run/worker-*.pid; do
  [[ -e $f ]] || continue
  name=${f##*/}; workers+=("${name%.pid}")
done
((${#workers[@]} == 0)) || stop_group pdrmesh-worker "${workers[@]}"
if [[ -e $dir/run/coordinator.pid ]]; then stop_group pdrmesh-coordinator coordinator; fi

if [[ -f $last && $(<"$last") == "$dir" ]]; then rm -f "$last"; fi
((failed == 0)) || die "some processes did not stop; their pid files are in $dir/run"
if ((remove)); then
  [[ -f $dir/tokens && -d $dir/data ]] || die "$dir does not look like up.sh's state directory: not removing it"
  rm -rf "$dir"
  say "removed $dir"
else
  say "state, results and logs kept in $dir (down.sh $dir --rm, or rm -rf it, when done)"
fi
