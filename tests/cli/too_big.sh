#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# A size that would exhaust the machine is refused before meshing: `mesh` and `run` with
# --size 1e-9 on the bunny exit 65 within two seconds (a generous bound: the estimate
# itself takes milliseconds) and under 200 MB resident (under a 1 GB address-space cap),
# with the estimate and the smallest sensible --size; an explicit --max-tets refuses a
# size the machine's memory would allow, and a size at the suggestion is accepted.
# Usage: too_big.sh PDRMESH SURFACE
set -uo pipefail
pdrmesh=$1 surface=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# refused NAME MAX_SECONDS PATTERN -- command...: exit 65, stderr matching PATTERN, no output file,
# within MAX_SECONDS and (with GNU time) under 200 MB resident.
refused() {
  local name=$1 max_s=$2 pattern=$3; shift 4
  local start end rc
  start=$(date +%s.%N)
  # The address-space cap keeps a broken guard from taking the machine down; a sanitizer's
  # runtime reserves terabytes of address space for its shadow memory, so it runs without.
  local cap=1048576
  [[ -n ${ASAN_OPTIONS:-}${TSAN_OPTIONS:-} ]] && cap=unlimited
  if [[ -x /usr/bin/time ]]; then
    (ulimit -v $cap; /usr/bin/time -f '%M' -o "$tmp/$name.rss" "$@") >"$tmp/$name.out" 2>"$tmp/$name.err"; rc=$?
  else
    (ulimit -v $cap; "$@") >"$tmp/$name.out" 2>"$tmp/$name.err"; rc=$?
  fi
  end=$(date +%s.%N)
  local wall; wall=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')
  [[ $rc -eq 65 ]] || fail "$name: exit $rc, want 65"
  grep -qE -- "$pattern" "$tmp/$name.err" || { fail "$name: stderr does not match /$pattern/:"; cat "$tmp/$name.err"; }
  [[ ! -e $tmp/$name.vtu ]] || fail "$name: wrote an output file"
  awk -v w="$wall" -v m="$max_s" 'BEGIN { exit !(w < m) }' || fail "$name: took $wall s (bound $max_s s)"
  if [[ -s $tmp/$name.rss ]]; then
    local kb; kb=$(tail -n 1 "$tmp/$name.rss")
    ((kb < 200 * 1024)) || fail "$name: $kb kB resident (bound 200 MB)"
    echo "$name: exit $rc in $wall s, $kb kB resident"
  else
    echo "$name: exit $rc in $wall s"
  fi
  cat "$tmp/$name.err"
}

suggestion='use --size [0-9.e+-]+ or larger'
refused mesh 2 "--size 1e-09 would make about [0-9.e+]+ tets \(about [0-9.e+]+ bytes\); the limit is [0-9,]+ tets \(--max-tets, from this machine's memory\); $suggestion" \
  -- "$pdrmesh" mesh "$surface" -o "$tmp/mesh.vtu" --size 1e-9 --time-limit 5
refused run 2 "--size 1e-09 would make about .*$suggestion" \
  -- "$pdrmesh" run "$surface" -o "$tmp/run.vtu" --size 1e-9 --depth 0
# An explicit limit: the default sizing of the bunny is tens of thousands of tets.
refused limit 10 "the default sizing would make about .* the limit is 1,000 tets \(--max-tets\); $suggestion" \
  -- "$pdrmesh" mesh "$surface" -o "$tmp/limit.vtu" --max-tets 1000
# The suggested size meshes under the limit (checked by mesh's own validation).
size=$(grep -oE 'use --size [0-9.e+-]+' "$tmp/limit.err" | awk '{print $3}')
if [[ -n $size ]]; then
  "$pdrmesh" mesh "$surface" -o "$tmp/ok.vtu" --size "$size" --max-tets 1000 -q >"$tmp/ok.out" 2>&1 ||
    { fail "mesh at the suggested --size $size under --max-tets 1000 failed:"; cat "$tmp/ok.out"; }
else
  fail "no suggested size in the refusal"
fi

((failures == 0)) || { echo "$failures failure(s)"; exit 1; }
echo "ok: too big sizes are refused up front"
