#!/usr/bin/env bash
# External flow end to end, on a sphere (the body):
#   --farfield 10 (a box): `mesh` to .su2 and `run --workers 1|2` to .su2 (the
#     same bytes) and polyMesh, patches wall inlet outlet sides in that order;
#     the tet count printed, and modest
#   --farfield 10 --farfield-shape sphere: `mesh` to .msh, physical names wall
#     and farfield
#   --size 20% with --farfield 1: 20% of the body's bounding-box diagonal
#   an STL with four named solids (the sphere reversed in a box whose faces are
#     the solids inlet, outlet and sides, written here): its names are the patches
#   refused with a clear message: a distance of 0.5 or 2000 body lengths, a bad
#     shape, a shape without --farfield (usage, exit 64), an open body (exit 65)
# With --openfoam instead: both polyMesh cases (--farfield 10 from `mesh`, the
# four solids from `run`'s parallel method) pass checkMesh with the names as
# patch names and potentialFoam converges on them (skipped, exit 77, without
# OpenFOAM: scripts/install-deps.sh installs Debian's openfoam).
# Usage: farfield.sh PDRMESH SPHERE_STL [--openfoam]
set -euo pipefail
pdrmesh=$1 sphere=$2 mode=${3:-}
[[ -f $sphere ]] || { echo "test surface $sphere not found"; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# The sphere reversed (a cavity) as the solid "sphere", in a cube two sphere
# diameters away from it, whose faces are the solids inlet (-x), outlet (+x)
# and sides, each face a 5 x 5 grid of squares cut in two triangles.
python3 - "$sphere" "$tmp/four.stl" <<'PY'
import sys
facets = []
tri = []
for line in open(sys.argv[1]):
    w = line.split()
    if w and w[0] == "vertex":
        tri.append(" ".join(w[1:]))
        if len(tri) == 3:
            facets.append(("sphere", [tri[0], tri[2], tri[1]]))
            tri = []
coords = [float(x) for f in facets for p in f[1] for x in p.split()]
lo, hi = min(coords), max(coords)
n, lo, hi = 5, lo - 2 * (hi - lo), hi + 2 * (hi - lo)
def c(i): return lo + (hi - lo) * i / n
for axis in range(3):
    u, v = (axis + 1) % 3, (axis + 2) % 3
    for side, name in ((0, "inlet" if axis == 0 else "sides"), (1, "outlet" if axis == 0 else "sides")):
        for i in range(n):
            for j in range(n):
                def p(di, dj):
                    x = [0.0, 0.0, 0.0]
                    x[axis] = hi if side else lo
                    x[u], x[v] = c(i + di), c(j + dj)
                    return " ".join(repr(t) for t in x)
                quad = [p(0, 0), p(1, 0), p(1, 1), p(0, 1)]
                if not side:
                    quad = [quad[0], quad[3], quad[2], quad[1]]
                facets.append((name, [quad[0], quad[1], quad[2]]))
                facets.append((name, [quad[0], quad[2], quad[3]]))
with open(sys.argv[2], "w") as out:
    for name in ("sphere", "inlet", "outlet", "sides"):
        out.write(f"solid {name}\n")
        for _, t in (f for f in facets if f[0] == name):
            out.write("facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {p}\n" for p in t) + "endloop\nendfacet\n")
        out.write(f"endsolid {name}\n")
PY

patches() { sed -n 's/^    \([^ {}]\+\)$/\1/p' "$1/boundary" | paste -sd' '; }

if [[ $mode == --openfoam ]]; then
  source "$(dirname "$0")/openfoam_lib.sh"
  openfoam_env
  missing=()
  command -v checkMesh >/dev/null || missing+=("checkMesh")
  command -v potentialFoam >/dev/null || missing+=("potentialFoam")
  if ((${#missing[@]} > 0)); then
    echo "SKIP: not installed: ${missing[*]} (Debian package openfoam; scripts/install-deps.sh installs it)"
    exit 77
  fi
  # A potential-flow case: uniform flow along +x from the inlet, p = 0 at the
  # outlet, the sides and the body slip.  case_for DIR BODY_PATCH
  case_for() {
    local dir=$1 body=$2
    mkdir -p "$dir/system"
    cat >"$dir/system/controlDict" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object controlDict; }
application potentialFoam; startFrom startTime; startTime 0; stopAt endTime; endTime 1;
deltaT 1; writeControl timeStep; writeInterval 1; writeFormat ascii;
DICT
    cat >"$dir/system/fvSchemes" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object fvSchemes; }
ddtSchemes { default steadyState; }
gradSchemes { default Gauss linear; }
divSchemes { default none; div(phi,U) Gauss linear; div(div(phi,U)) Gauss linear; }
laplacianSchemes { default Gauss linear limited corrected 0.5; }
interpolationSchemes { default linear; }
snGradSchemes { default limited corrected 0.5; }
DICT
    cat >"$dir/system/fvSolution" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object fvSolution; }
solvers
{
    Phi { solver GAMG; smoother DIC; tolerance 1e-08; relTol 0; }
    p { solver GAMG; smoother DIC; tolerance 1e-08; relTol 0; }
}
potentialFlow { nNonOrthogonalCorrectors 3; }
DICT
    flow_fields "$dir" "$body" slip "(0 0 0)"
  }
  # foam_check DIR BODY_PATCH: checkMesh says Mesh OK and reports the patches by
  # name; potentialFoam ends, its last Phi solve within the tolerance.
  foam_check() {
    local dir=$1 body=$2
    case_for "$dir" "$body"
    [[ $(patches "$dir/constant/polyMesh") == "$body inlet outlet sides" ]] ||
      fail "$dir: patches '$(patches "$dir/constant/polyMesh")', expected '$body inlet outlet sides'"
    checkMesh -case "$dir" -noFunctionObjects >"$dir/checkMesh.log" 2>&1 || { cat "$dir/checkMesh.log"; fail "checkMesh failed"; }
    grep -q "^Mesh OK\." "$dir/checkMesh.log" || { cat "$dir/checkMesh.log"; fail "$dir: checkMesh: not 'Mesh OK.'"; }
    for p in $body inlet outlet sides; do
      grep -Eq "^ +$p +[0-9]+ +[0-9]+ " "$dir/checkMesh.log" || { cat "$dir/checkMesh.log"; fail "patch $p is not in checkMesh's report"; }
    done
    potentialFoam -case "$dir" -writep -noFunctionObjects >"$dir/potentialFoam.log" 2>&1 ||
      { cat "$dir/potentialFoam.log"; fail "$dir: potentialFoam failed"; }
    python3 - "$dir/potentialFoam.log" <<'PY' || { cat "$dir/potentialFoam.log"; fail "$dir: potentialFoam did not converge"; }
import re, sys
log = open(sys.argv[1]).read()
solves = re.findall(r"Solving for Phi, Initial residual = (\S+), Final residual = (\S+), No Iterations (\d+)", log)
if not solves or "\nEnd" not in log:
    sys.exit("no Phi solve, or no End")
initial, final, iterations = float(solves[-1][0].rstrip(",")), float(solves[-1][1].rstrip(",")), int(solves[-1][2])
if not (final <= 1e-8 and iterations < 1000):
    sys.exit(f"last Phi solve: final residual {final}, {iterations} iterations")
continuity = re.search(r"Continuity error = (\S+)", log)
if not continuity or not float(continuity.group(1)) < 1e-6:
    sys.exit(f"continuity error: {continuity.group(1) if continuity else 'not printed'}")
print(f"potentialFoam: {len(solves)} Phi solves, the last from {initial:.3g} to {final:.3g} in {iterations} "
      f"iterations; continuity error {continuity.group(1)}")
PY
  }
  "$pdrmesh" mesh -q "$sphere" --farfield 10 -o "$tmp/far/constant/polyMesh"
  foam_check "$tmp/far" wall
  "$pdrmesh" run -q "$sphere" --farfield 10 --workers 2 --depth 1 -o "$tmp/far_run/constant/polyMesh"
  foam_check "$tmp/far_run" wall  # the parallel method
  "$pdrmesh" run -q "$tmp/four.stl" --workers 2 --depth 1 -o "$tmp/four/constant/polyMesh"
  foam_check "$tmp/four" sphere
  echo "ok: checkMesh says Mesh OK and potentialFoam converges on --farfield 10 (mesh and run) and on four named solids"
  exit 0
fi

# A box at 10 body lengths: serial to SU2, tags in id order; the tet count.
"$pdrmesh" mesh "$sphere" --farfield 10 -o "$tmp/box.su2" --json >"$tmp/box.json" 2>"$tmp/box.log" ||
  { cat "$tmp/box.log"; fail "mesh --farfield 10"; }
grep -q "far field: a box 10 body lengths" "$tmp/box.log" || { cat "$tmp/box.log"; fail "no far-field line"; }
grep -q "boundary names\|validated" "$tmp/box.log" || { cat "$tmp/box.log"; fail "not validated"; }
tags=$(grep '^MARKER_TAG=' "$tmp/box.su2" | awk '{print $2}' | paste -sd' ')
[[ $tags == "wall inlet outlet sides" ]] || fail "box.su2: marker tags '$tags'"
tets=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["tets"])' "$tmp/box.json")
echo "sphere in a box at 10 body lengths: $tets tets"
((tets > 1000 && tets < 300000)) || fail "box at 10 body lengths: $tets tets"
"$pdrmesh" validate "$tmp/box.su2" >/dev/null

# A sphere at 10 body lengths, to Gmsh.
"$pdrmesh" mesh "$sphere" --farfield 10 --farfield-shape sphere -o "$tmp/sphere.msh" --json >"$tmp/sphere.json" 2>/dev/null
tets=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["tets"])' "$tmp/sphere.json")
echo "sphere in a sphere at 10 body lengths: $tets tets"
((tets > 1000 && tets < 300000)) || fail "sphere at 10 body lengths: $tets tets"
names=$(sed -n '/^\$PhysicalNames/,/^\$EndPhysicalNames/p' "$tmp/sphere.msh" | grep -o '"[^"]*"' | tr -d '"' | paste -sd' ')
[[ $names == *wall* && $names == *farfield* ]] || fail "sphere.msh: physical names '$names'"
"$pdrmesh" validate "$tmp/sphere.msh" >/dev/null

# The parallel method: 1 and 2 workers give the same bytes; polyMesh patches.
for w in 1 2; do
  "$pdrmesh" run -q "$sphere" --farfield 10 --depth 1 --workers $w -o "$tmp/r$w.su2"
done
cmp "$tmp/r1.su2" "$tmp/r2.su2" || fail "run --farfield: 1 and 2 workers differ"
"$pdrmesh" convert "$tmp/r2.su2" "$tmp/case/constant/polyMesh"
[[ $(patches "$tmp/case/constant/polyMesh") == "wall inlet outlet sides" ]] ||
  fail "polyMesh patches '$(patches "$tmp/case/constant/polyMesh")'"

# --size P% is a share of the body's bounding-box diagonal, not of the far field's.
"$pdrmesh" mesh "$sphere" --farfield 1 --size 20% -o "$tmp/pct.meshb" --json >"$tmp/pct.json" 2>"$tmp/pct.log" ||
  { cat "$tmp/pct.log"; fail "mesh --farfield 1 --size 20%"; }
grep -q "(20% of the body's bounding-box diagonal" "$tmp/pct.log" || { cat "$tmp/pct.log"; fail "no body size line"; }
python3 - "$tmp/pct.json" "$sphere" <<'PY' || fail "--size 20% with --farfield is not 20% of the body's diagonal"
import json, math, sys
size = json.load(open(sys.argv[1]))["size"]
pts = [[float(x) for x in line.split()[1:]] for line in open(sys.argv[2]) if line.split()[:1] == ["vertex"]]
diag = math.dist([min(p[a] for p in pts) for a in range(3)], [max(p[a] for p in pts) for a in range(3)])
assert abs(size - 0.2 * diag) <= 1e-9 * diag, (size, diag)
PY
"$pdrmesh" validate "$tmp/pct.meshb" >/dev/null

# Four named solids: their names are the patches.
"$pdrmesh" mesh -q "$tmp/four.stl" -o "$tmp/four.su2"
tags=$(grep '^MARKER_TAG=' "$tmp/four.su2" | awk '{print $2}' | paste -sd' ')
[[ $tags == "sphere inlet outlet sides" ]] || fail "four.su2: marker tags '$tags'"

# Refusals, each with a message that names the problem.
refused() {  # EXIT_CODE TEXT ARGS...
  local code=$1 text=$2; shift 2
  local rc=0
  "$pdrmesh" "$@" >"$tmp/out.txt" 2>&1 || rc=$?
  [[ $rc == "$code" ]] || { cat "$tmp/out.txt"; fail "'$*': exit $rc, expected $code"; }
  grep -q -- "$text" "$tmp/out.txt" || { cat "$tmp/out.txt"; fail "'$*': no '$text' in the message"; }
}
refused 64 "--farfield: must be a distance in body lengths over 0.5" mesh "$sphere" --farfield 0.5 -o "$tmp/x.vtu"
refused 64 "--farfield: must be a distance in body lengths over 0.5 and at most 1000" \
  run "$sphere" --farfield 2000 -o "$tmp/x.vtu"
refused 64 "--farfield-shape" mesh "$sphere" --farfield 10 --farfield-shape cone -o "$tmp/x.vtu"
refused 64 "--farfield-shape requires --farfield" mesh "$sphere" --farfield-shape sphere -o "$tmp/x.vtu"
python3 -c 'import re, sys; print(re.sub(r"facet.*?endfacet\s*", "", open(sys.argv[1]).read(), count=1, flags=re.S))' \
  "$sphere" >"$tmp/open.stl"  # the first facet gone
refused 65 "--farfield needs a closed, outward body" mesh "$tmp/open.stl" --farfield 10 -o "$tmp/x.vtu"
echo "ok: --farfield box and sphere through mesh and run, four named solids, refusals"
