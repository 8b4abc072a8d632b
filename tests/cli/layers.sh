#!/usr/bin/env bash
# Prism layers end to end: `pdrmesh mesh --layers` on the sphere writes a mixed
# mesh that validates against the surface, `quality` prints the layer figures,
# and the option checks refuse what cannot work before any meshing.
# Usage: layers.sh PDRMESH SPHERE.mesh
set -euo pipefail
pdrmesh=$1
sphere=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
expect_exit() {  # CODE COMMAND...
  local want=$1; shift
  local got=0
  "$@" >"$tmp/out" 2>"$tmp/err" || got=$?
  [[ $got == "$want" ]] || fail "$* exited $got, expected $want: $(cat "$tmp/err")"
}

"$pdrmesh" mesh "$sphere" -o "$tmp/s.mesh" --layers 4 --first-height 0.05 --growth-ratio 1.3 2>"$tmp/log"
grep -q "prism layers: 1848 wall triangles with 4 to 4 layers" "$tmp/log" || fail "no layer summary: $(cat "$tmp/log")"
"$pdrmesh" validate "$tmp/s.mesh" --surface "$sphere" | grep -q "prisms 7392" || fail "validate: no 7392 prisms"
"$pdrmesh" quality "$tmp/s.mesh" >"$tmp/q"
grep -q "height ratio between layers 1.3" "$tmp/q" || fail "quality: $(cat "$tmp/q")"
"$pdrmesh" quality --json "$tmp/s.mesh" | grep -q '"max_layers":4' || fail "quality --json: no layers"
"$pdrmesh" mesh -q "$sphere" -o "$tmp/s.su2" --layers 2 --first-height 0.1 --layers-on surface_1
grep -q "^NELEM=" "$tmp/s.su2" || fail "no SU2 file"

# Refused before meshing (64), or at the surface (65).
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.meshb" --layers 3 --first-height 0.1
grep -q "cannot hold prisms" "$tmp/err" || fail "meshb: $(cat "$tmp/err")"
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --first-height 0.1
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height 0.1 --growth-ratio 0.5
expect_exit 65 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height 0.1 --layers-on inlet
grep -q "inlet names no surface" "$tmp/err" || fail "layers-on: $(cat "$tmp/err")"
echo "layers: ok"
