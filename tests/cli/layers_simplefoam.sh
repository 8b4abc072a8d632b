#!/usr/bin/env bash
# Prism layers in a viscous solver: the sphere (20 long) in a far-field box with
# 20 layers, first height 1e-4 of its length, growth ratio 1.2, written as a
# polyMesh; checkMesh says Mesh OK and OpenFOAM's simpleFoam (laminar, Re 100
# on the diameter) runs 50 iterations without diverging: every residual finite,
# the run ends, and the velocity stays within a few times the inflow's.
# Skipped (exit 77) without OpenFOAM.
# Usage: layers_simplefoam.sh PDRMESH SPHERE.mesh
set -euo pipefail
pdrmesh=$1 sphere=$2
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

source "$(dirname "$0")/openfoam_lib.sh"
openfoam_env
missing=()
for program in checkMesh simpleFoam; do command -v $program >/dev/null || missing+=("$program"); done
if ((${#missing[@]} > 0)); then
  echo "SKIP: not installed: ${missing[*]} (Debian package openfoam; scripts/install-deps.sh installs it)"
  exit 77
fi

case=$tmp/case
"$pdrmesh" mesh "$sphere" --farfield 2 --growth 1.5 --layers 20 --first-height 2e-3 --growth-ratio 1.2 \
  -o "$case/constant/polyMesh" --json >"$tmp/mesh.json" 2>"$tmp/mesh.log" || { cat "$tmp/mesh.log"; fail "mesh"; }
python3 - "$tmp/mesh.json" <<'PY' || fail "layers: $(cat "$tmp/mesh.json")"
import json, sys
layers = json.load(open(sys.argv[1]))["layers"]
if layers["prisms"] != 20 * 1848 or layers["min_layers"] != 20:
    sys.exit(f"{layers['prisms']} prisms, {layers['min_layers']} layers at least: not 20 on each of 1848 triangles")
PY

checkmesh_case "$case"
checkMesh -case "$case" -noFunctionObjects >"$tmp/checkMesh.log" 2>&1 || { cat "$tmp/checkMesh.log"; fail "checkMesh failed"; }
grep -q "^Mesh OK\." "$tmp/checkMesh.log" || { cat "$tmp/checkMesh.log"; fail "checkMesh: not 'Mesh OK.'"; }

# Uniform flow along +x from the inlet, p = 0 at the outlet, slip sides, no-slip
# sphere; nu = 0.2 with U = 1 and a diameter of 20 is Re 100 (steady, laminar).
cat >"$case/system/controlDict" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object controlDict; }
application simpleFoam; startFrom startTime; startTime 0; stopAt endTime; endTime 50;
deltaT 1; writeControl timeStep; writeInterval 50; writeFormat ascii; writePrecision 8;
DICT
cat >"$case/system/fvSchemes" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object fvSchemes; }
ddtSchemes { default steadyState; }
gradSchemes { default Gauss linear; grad(U) cellLimited Gauss linear 1; }
divSchemes { default none; div(phi,U) bounded Gauss linearUpwind grad(U); div((nuEff*dev2(T(grad(U))))) Gauss linear; }
laplacianSchemes { default Gauss linear limited corrected 0.33; }
interpolationSchemes { default linear; }
snGradSchemes { default limited corrected 0.33; }
DICT
cat >"$case/system/fvSolution" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object fvSolution; }
solvers
{
    p { solver GAMG; smoother GaussSeidel; tolerance 1e-7; relTol 0.1; }
    U { solver smoothSolver; smoother symGaussSeidel; tolerance 1e-7; relTol 0.1; }
}
SIMPLE { nNonOrthogonalCorrectors 1; consistent yes; }
relaxationFactors { equations { U 0.9; } fields { p 1; } }
DICT
cat >"$case/constant/transportProperties" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object transportProperties; }
transportModel Newtonian; nu 0.2;
DICT
cat >"$case/constant/turbulenceProperties" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object turbulenceProperties; }
simulationType laminar;
DICT
flow_fields "$case" wall noSlip "(1 0 0)"

simpleFoam -case "$case" -noFunctionObjects >"$tmp/simpleFoam.log" 2>&1 ||
  { tail -40 "$tmp/simpleFoam.log"; fail "simpleFoam failed"; }
python3 - "$tmp/simpleFoam.log" "$case/50/U" <<'PY' || { tail -40 "$tmp/simpleFoam.log"; fail "simpleFoam diverged"; }
import math, re, sys
log = open(sys.argv[1]).read()
residuals = [float(r) for r in re.findall(r"Initial residual = ([^,\s]+)", log)]
times = re.findall(r"^Time = (\d+)$", log, re.M)
if len(times) != 50 or not log.rstrip().endswith("End"):
    sys.exit(f"{len(times)} iterations, expected 50 and the End line")
if not residuals or not all(math.isfinite(r) for r in residuals):
    sys.exit("a residual is not finite")
field = open(sys.argv[2]).read()
body = field[field.index("internalField"):field.index("boundaryField")]
speeds = [math.sqrt(sum(float(c) ** 2 for c in v.split())) for v in re.findall(r"\(([^()]+)\)", body)]
if not speeds or not all(math.isfinite(s) and s < 5 for s in speeds):
    sys.exit(f"the velocity reaches {max(speeds, default=float('nan'))}, inflow 1")
print(f"50 iterations, last initial residuals {residuals[-4:]}, largest speed {max(speeds):.3g}")
PY
echo "layers_simplefoam: ok"
