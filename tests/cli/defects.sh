#!/usr/bin/env bash
# The CLI refuses broken input with exit 65 and a message that names the
# problem and where, and `mesh` writes nothing then.
# Usage: defects.sh PDRMESH
set -uo pipefail
pdrmesh=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
failures=0
expect() {  # expect CODE PATTERN -- command...
  local code=$1 pattern=$2; shift 3
  local out rc
  out=$("$@" 2>&1); rc=$?
  if [[ $rc -ne $code ]] || ! grep -qiE -- "$pattern" <<<"$out"; then
    echo "FAIL: '$*' gave exit $rc (want $code), output must match /$pattern/:"; echo "$out"
    failures=$((failures + 1))
  else
    echo "ok: $* -> $rc"
  fi
}

# A tetrahedron's surface with one triangle missing: three open edges.
cat >"$tmp/open.off" <<'END_OFF'
OFF
4 3 0
0 0 0
1 0 0
0 1 0
0 0 1
3 0 2 1
3 0 1 3
3 1 2 3
END_OFF
expect 65 "open" -- "$pdrmesh" check "$tmp/open.off"
expect 65 "open" -- "$pdrmesh" mesh "$tmp/open.off" -o "$tmp/open.vtu"
[[ ! -e $tmp/open.vtu ]] || { echo "FAIL: mesh wrote output for a broken surface"; failures=$((failures + 1)); }

# The same tetrahedron with all normals inward.
cat >"$tmp/inward.off" <<'END_OFF'
OFF
4 4 0
0 0 0
1 0 0
0 1 0
0 0 1
3 0 1 2
3 0 3 1
3 1 3 2
3 0 2 3
END_OFF
expect 65 "inward|orient" -- "$pdrmesh" check "$tmp/inward.off"

# A NaN coordinate: the reader names the file and the line.
cat >"$tmp/nan.off" <<'END_OFF'
OFF
4 4 0
0 0 0
1 nan 0
0 1 0
0 0 1
3 0 2 1
3 0 1 3
3 1 2 3
3 0 3 2
END_OFF
expect 65 "nan.off:4" -- "$pdrmesh" check "$tmp/nan.off"
expect 66 "no such|not found|cannot open" -- "$pdrmesh" check "$tmp/missing.stl"
expect 64 "suffix|format|unsupported" -- "$pdrmesh" check "$tmp/open.xyz"
expect 64 "" -- "$pdrmesh" mesh
[[ $failures -eq 0 ]] && echo "all defect cases passed" && exit 0
exit 1
