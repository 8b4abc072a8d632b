#!/usr/bin/env bash
# Prism layers end to end: `pdrmesh mesh --layers` on the sphere writes a mixed
# mesh that validates against the surface, `quality` prints the layer figures,
# with --farfield the layers grow from the body alone, `run --layers` keeps
# mesh's layer cells, and the option checks refuse what cannot work before any
# meshing.
# With --openfoam instead: the far-field case with layers written as a polyMesh
# passes checkMesh, and as CGNS cgnscheck (skipped, exit 77, without them).
# Usage: layers.sh PDRMESH SPHERE.mesh [--openfoam]
set -euo pipefail
pdrmesh=$1
sphere=$2
mode=${3:-}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

if [[ $mode == --openfoam ]]; then
  source "$(dirname "$0")/openfoam_lib.sh"
  openfoam_env
  missing=()
  command -v checkMesh >/dev/null || missing+=("checkMesh (Debian package openfoam)")
  command -v cgnscheck >/dev/null || missing+=("cgnscheck (Debian package cgns-convert)")
  if ((${#missing[@]} > 0)); then
    echo "SKIP: not installed: ${missing[*]}; scripts/install-deps.sh installs them"
    exit 77
  fi
  foam_case=$tmp/case
  "$pdrmesh" mesh -q "$sphere" --farfield 5 --layers 3 --first-height 0.05 -o "$foam_case/constant/polyMesh"
  checkmesh_case "$foam_case"
  checkMesh -case "$foam_case" -noFunctionObjects >"$tmp/checkMesh.log" 2>&1 || { cat "$tmp/checkMesh.log"; fail "checkMesh failed"; }
  grep -q "^Mesh OK\." "$tmp/checkMesh.log" || { cat "$tmp/checkMesh.log"; fail "checkMesh: not 'Mesh OK.'"; }
  grep -Eq "^ +prisms: +5544$" "$tmp/checkMesh.log" || { cat "$tmp/checkMesh.log"; fail "checkMesh: not 5544 prisms"; }
  # The same mesh as CGNS: a PENTA_6 section of the prisms that cgnscheck accepts.
  "$pdrmesh" mesh -q "$sphere" --farfield 5 --layers 3 --first-height 0.05 -o "$tmp/far.cgns"
  cgnscheck -v "$tmp/far.cgns" >"$tmp/cgnscheck.log" 2>&1 || { cat "$tmp/cgnscheck.log"; fail "cgnscheck failed"; }
  if grep -qi "error" "$tmp/cgnscheck.log"; then cat "$tmp/cgnscheck.log"; fail "cgnscheck reports an error"; fi
  grep -q "Element Set Type=PENTA_6" "$tmp/cgnscheck.log" || { cat "$tmp/cgnscheck.log"; fail "cgnscheck: no PENTA_6 section"; }
  echo "ok: checkMesh says Mesh OK on the far-field case with three prism layers; cgnscheck reads its CGNS"
  exit 0
fi

expect_exit() {  # CODE COMMAND...
  local want=$1; shift
  local got=0
  "$@" >"$tmp/out" 2>"$tmp/err" || got=$?
  [[ $got == "$want" ]] || fail "$* exited $got, expected $want: $(cat "$tmp/err")"
}

"$pdrmesh" mesh "$sphere" -o "$tmp/s.mesh" --layers 4 --first-height 0.05 --growth-ratio 1.3 2>"$tmp/log"
grep -q "prism layers: 1848 wall triangles with 4 to 4 layers" "$tmp/log" || fail "no layer summary: $(cat "$tmp/log")"
grep -q "all 4 layers at full thickness on 100.0% of the wall triangles" "$tmp/log" || fail "no layers reached: $(cat "$tmp/log")"
"$pdrmesh" validate "$tmp/s.mesh" --surface "$sphere" | grep -q "prisms 7392" || fail "validate: no 7392 prisms"
# Binary Medit holds the prisms too: the same cells as the ASCII file.
"$pdrmesh" mesh -q "$sphere" -o "$tmp/s.meshb" --layers 4 --first-height 0.05 --growth-ratio 1.3
"$pdrmesh" validate "$tmp/s.meshb" --surface "$sphere" | grep -q "prisms 7392" || fail "validate: no 7392 prisms in .meshb"
"$pdrmesh" quality "$tmp/s.mesh" >"$tmp/q"
grep -q "height ratio between layers 1.3" "$tmp/q" || fail "quality: $(cat "$tmp/q")"
"$pdrmesh" quality --json "$tmp/s.mesh" | grep -q '"max_layers":4' || fail "quality --json: no layers"
"$pdrmesh" mesh -q "$sphere" -o "$tmp/s.su2" --layers 2 --first-height 0.1 --layers-on surface_1
grep -q "^NELEM=" "$tmp/s.su2" || fail "no SU2 file"

# With --farfield the layers grow from the body's walls into the fluid, none on
# the far field: 3 layers on each of the sphere's 1848 triangles, all stacks full
# and at their full thickness.
"$pdrmesh" mesh "$sphere" --farfield 5 --layers 3 --first-height 0.05 -o "$tmp/far.mesh" --json >"$tmp/far.json" \
  2>"$tmp/log" || { cat "$tmp/log"; fail "mesh --farfield --layers"; }
python3 - "$tmp/far.json" <<'PY' || fail "far field with layers: $(cat "$tmp/far.json")"
import json, sys
layers = json.load(open(sys.argv[1]))["layers"]
want = {"prisms": 3 * 1848, "wall_triangles": 1848, "full_stacks": 1848, "min_layers": 3, "max_layers": 3,
        "full_thickness_faces": 1848, "smooth_faces": 1848, "full_thickness_share": 100.0}
got = {k: layers[k] for k in want}
sys.exit(0 if got == want else f"layers {got}, expected {want}")
PY
"$pdrmesh" validate "$tmp/far.mesh" | grep -q "prisms 5544" || fail "validate far.mesh: no 5544 prisms"

# `run --layers`: the layers made serially as `mesh` makes them, the tets by the
# parallel method; the prisms and the points under them are mesh's, byte for byte.
"$pdrmesh" mesh -q "$sphere" -o "$tmp/ser.mesh" --layers 3 --first-height 0.05
"$pdrmesh" run -q "$sphere" -o "$tmp/par.mesh" --layers 3 --first-height 0.05 --workers 2 --depth 1
"$pdrmesh" validate "$tmp/par.mesh" --surface "$sphere" | grep -q "prisms 5544" || fail "run --layers: no 5544 prisms"
python3 - "$tmp/ser.mesh" "$tmp/par.mesh" <<'PY' || fail "run --layers: layer cells differ from mesh's"
import sys
def sections(path):
    lines, out, i = open(path).read().split("\n"), {}, 0
    while i < len(lines):
        if lines[i] in ("Vertices", "Prisms"):
            n = int(lines[i + 1])
            out[lines[i]] = lines[i + 2:i + 2 + n]
            i += 2 + n
        else:
            i += 1
    return out
ser, par = sections(sys.argv[1]), sections(sys.argv[2])
if ser["Prisms"] != par["Prisms"] or len(ser["Prisms"]) != 5544:
    sys.exit("the Prisms sections differ")
under = max(int(v) for line in ser["Prisms"] for v in line.split()[:6])
if ser["Vertices"][:under] != par["Vertices"][:under]:
    sys.exit(f"the first {under} vertices differ")
PY

# Refused before meshing (64), or at the surface (65).
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --first-height 0.1
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height 0.1 --growth-ratio 0.5
expect_exit 65 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height 0.1 --layers-on inlet
grep -q "inlet names no surface" "$tmp/err" || fail "layers-on: $(cat "$tmp/err")"
# The first height as a y+: yplus:Y needs --reynolds, --reynolds needs yplus:Y, bad values are named.
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height yplus:1
grep -q "give the Reynolds number with --reynolds" "$tmp/err" || fail "yplus without --reynolds: $(cat "$tmp/err")"
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height yplus:-1 --reynolds 1e6
grep -q "first-height.*yplus:-1" "$tmp/err" || fail "yplus:-1: $(cat "$tmp/err")"
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height yplus:one --reynolds 1e6
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height 0.1 --reynolds 1e6
grep -q -- "--reynolds: only with --first-height yplus:Y" "$tmp/err" || fail "--reynolds alone: $(cat "$tmp/err")"
expect_exit 64 "$pdrmesh" mesh "$sphere" -o "$tmp/x.vtu" --layers 3 --first-height yplus:1 --reynolds -5
grep -q -- "--reynolds.*-5" "$tmp/err" || fail "--reynolds -5: $(cat "$tmp/err")"
# y+ 1 at Re 1e6 on the sphere's length, 20: 20 / (1e6 sqrt(0.026 / 1e6^(1/7) / 2)) = 4.706e-4.
"$pdrmesh" mesh -q "$sphere" -o "$tmp/y.mesh" --layers 2 --first-height yplus:1 --reynolds 1e6 --json >"$tmp/y.json"
python3 - "$tmp/y.json" <<'PY' || fail "yplus:1: $(cat "$tmp/y.json")"
import json, sys
layers = json.load(open(sys.argv[1]))["layers"]
h = (layers["first_height_min"], layers["first_height_max"])
sys.exit(0 if 4.6e-4 < h[0] <= h[1] < 4.9e-4 else f"first height {h}, expected about 4.706e-4")
PY
echo "layers: ok"
