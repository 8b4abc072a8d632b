#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Prism boundary layers against Gmsh's, per body in a far-field box: 20 layers, the first 1e-4 of
# the body length L high, ratio 1.2, the box 5 L from the body on every side.
#   bench/layers.sh [BODY...]   BODY: sphere966, wing (sphere966 scaled 1 x 3 x 0.15: a thin,
#                               wing-like body) or a corpus name (default: sphere966 wing fandisk)
# pdrmesh: `pdrmesh mesh BODY.stl --farfield 5 --layers 20 --first-height H --growth-ratio 1.2`,
# written as an OpenFOAM polyMesh. Gmsh: its boundary-layer extrusion of the same STL along the
# surface normals (Extrude { Surface{1}; Layers{...}; Recombine; }), the box around it meshed with
# tets, converted by gmshToFoam. Both are checked by OpenFOAM's checkMesh.
# Columns: cells, prisms, tets, wall seconds; layers reached (the share of wall triangles, and of
# the smooth ones, whose stacks keep all 20 layers at full thickness: pdrmesh's report; Gmsh
# extrudes every face the full height, so it reaches 100% where its mesh is valid); checkMesh's
# verdict, smallest cell volume, largest non-orthogonality and skewness.
# Needs gmsh and OpenFOAM (scripts/install-deps.sh --bench, and the openfoam package); a tool that
# is missing leaves its columns as "-". Surfaces from $PDRMESH_CORPUS (default bench/corpus:
# bench/fetch-corpus.sh).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}
[[ -d $corpus ]] || { echo "no corpus in $corpus: run bench/fetch-corpus.sh" >&2; exit 1; }
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
source "$root/tests/cli/openfoam_lib.sh"
openfoam_env
names=("$@"); ((${#names[@]})) || names=(sphere966 wing fandisk)
tmp=${KEEP_DIR:-$(mktemp -d)}; [[ -n ${KEEP_DIR:-} ]] || trap 'rm -rf "$tmp"' EXIT; mkdir -p "$tmp"
have() { command -v "$1" >/dev/null; }

# body NAME OUT.stl: the body as an ASCII STL; prints its length L (longest bounding-box side).
body() {
  local src=$corpus/$1.mesh scale="1 1 1"
  [[ $1 == wing ]] && src=$corpus/sphere966.mesh && scale="1 3 0.15"
  python3 - "$src" "$2" $scale <<'PY'
import sys
src, out, s = sys.argv[1], sys.argv[2], [float(v) for v in sys.argv[3:6]]
tok = open(src).read().split()
pts, tris, i = [], [], 0
while i < len(tok):
    if tok[i] == "Vertices":
        n = int(tok[i + 1]); i += 2
        pts = [[float(tok[i + 4 * k + j]) * s[j] for j in range(3)] for k in range(n)]; i += 4 * n
    elif tok[i] == "Triangles":
        n = int(tok[i + 1]); i += 2
        tris = [[int(tok[i + 4 * k + j]) - 1 for j in range(3)] for k in range(n)]; i += 4 * n
    else:
        i += 1
with open(out, "w") as f:
    f.write("solid body\n")
    for t in tris:
        f.write("facet normal 0 0 0\nouter loop\n")
        for v in t:
            f.write("vertex %.17g %.17g %.17g\n" % tuple(pts[v]))
        f.write("endloop\nendfacet\n")
    f.write("endsolid body\n")
print(max(max(p[j] for p in pts) - min(p[j] for p in pts) for j in range(3)))
PY
}

# gmsh_geo STL L H OUT.geo: the STL extruded along its normals into 20 layers, and a box of tets
# around them (5 L from the body's bounding box, points spaced 1.25 L as pdrmesh's far field).
gmsh_geo() {
  python3 - "$@" <<'PY'
import sys
stl, L, H, out = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
tok = open(stl).read().split()
xs = [[float(tok[i + 1 + j]) for j in range(3)] for i, t in enumerate(tok) if t == "vertex"]
lo = [min(p[j] for p in xs) - 5 * L for j in range(3)]
hi = [max(p[j] for p in xs) + 5 * L for j in range(3)]
heights, d, t = [], H, 0.0
for _ in range(20):
    t += d; heights.append(t); d *= 1.2
lc = 1.25 * L
c = [(hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2]) for k in range(8)]
g = ['Merge "%s";' % stl,
     "out[] = Extrude{ Surface{1}; Layers{ {%s}, {%s} }; Recombine; };" %
     (",".join("1" for _ in heights), ",".join("%.17g" % h for h in heights))]
g += ["Point(%d) = {%.17g, %.17g, %.17g, %.17g};" % (1001 + k, *c[k], lc) for k in range(8)]
edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)]
g += ["Line(%d) = {%d, %d};" % (2001 + i, 1001 + a, 1001 + b) for i, (a, b) in enumerate(edges)]
def line(a, b):
    i = edges.index((min(a, b), max(a, b)))
    return (2001 + i) if a < b else -(2001 + i)
faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
for i, f in enumerate(faces):
    g.append("Curve Loop(%d) = {%s}; Plane Surface(%d) = {%d};" %
             (3001 + i, ", ".join(str(line(f[k], f[(k + 1) % 4])) for k in range(4)), 4001 + i, 3001 + i))
g += ["Surface Loop(5001) = {4001:4006};", "Surface Loop(5002) = {out[0]};", "Volume(6001) = {5001, 5002};",
      'Physical Volume("fluid") = {6001, out[1]};', 'Physical Surface("wall") = {1};',
      'Physical Surface("farfield") = {4001:4006};']
open(out, "w").write("\n".join(g) + "\n")
PY
}

# check CASE: checkMesh's verdict, smallest volume, largest non-orthogonality and skewness.
check() {
  have checkMesh || { echo "- - - -"; return; }
  checkmesh_case "$1"
  checkMesh -case "$1" -noFunctionObjects >"$1/checkMesh.log" 2>&1 || true
  local verdict=failed
  grep -q "^Mesh OK\." "$1/checkMesh.log" && verdict=OK
  local vmin nonorth skew
  vmin=$(sed -n 's/.*Min volume = \([^.]*\.[^ ]*\)\. .*/\1/p' "$1/checkMesh.log" | head -1)
  nonorth=$(sed -n 's/.*non-orthogonality Max: \([0-9.e+-]*\).*/\1/p' "$1/checkMesh.log" | head -1)
  skew=$(sed -n 's/.*Max skewness = \([0-9.e+-]*\).*/\1/p' "$1/checkMesh.log" | head -1)
  echo "$verdict ${vmin:--} ${nonorth:--} ${skew:--}"
}

# cells CASE: cells, prisms, tets as checkMesh counts them.
cells() {
  local log=$1/checkMesh.log
  [[ -s $log ]] || { echo "- - -"; return; }
  local n p t
  n=$(sed -n 's/^ *cells: *\([0-9]*\)$/\1/p' "$log" | head -1)
  p=$(sed -n 's/^ *prisms: *\([0-9]*\)$/\1/p' "$log" | head -1)
  t=$(sed -n 's/^ *tetrahedra: *\([0-9]*\)$/\1/p' "$log" | head -1)
  echo "${n:--} ${p:-0} ${t:-0}"
}

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%F)"
echo "20 layers, first height 1e-4 L, ratio 1.2, far-field box 5 L away; pdrmesh mesh against Gmsh $(have gmsh && gmsh --version 2>&1 | tail -1 || echo '(not installed)')"
printf '%-10s %-7s %9s %8s %8s %7s %7s %7s %-7s %10s %8s %8s\n' body mesher cells prisms tets wall_s reached smooth \
  checkMesh min_volume nonorth skew
for n in "${names[@]}"; do
  stl=$tmp/$n.stl
  L=$(body "$n" "$stl")
  H=$(python3 -c "print($L * 1e-4)")
  # pdrmesh
  case=$tmp/$n.pdrmesh
  if /usr/bin/time -f '%e' -o "$tmp/t" "$pdrmesh" mesh -q "$stl" --farfield 5 --layers 20 --first-height "$H" \
      --growth-ratio 1.2 -o "$case/constant/polyMesh" --json >"$tmp/report.json" 2>"$tmp/err"; then
    read -r reached smooth < <(python3 -c "import json,sys; l=json.load(open(sys.argv[1]))['layers']; print('%.1f%% %.1f%%' % (l['full_thickness_share'], l['smooth_full_thickness_share']))" "$tmp/report.json")
    read -r verdict vmin nonorth skew < <(check "$case")
    read -r nc np nt < <(cells "$case")
    printf '%-10s %-7s %9s %8s %8s %7.2f %7s %7s %-7s %10s %8s %8s\n' "$n" pdrmesh "$nc" "$np" "$nt" "$(cat "$tmp/t")" \
      "$reached" "$smooth" "$verdict" "$vmin" "$nonorth" "$skew"
  else
    printf '%-10s %-7s failed: %s\n' "$n" pdrmesh "$(tail -1 "$tmp/err")"
  fi
  # Gmsh
  have gmsh || continue
  case=$tmp/$n.gmsh
  mkdir -p "$case"
  have checkMesh && checkmesh_case "$case"  # gmshToFoam reads its system/controlDict
  gmsh_geo "$stl" "$L" "$H" "$case/layers.geo"
  if /usr/bin/time -f '%e' -o "$tmp/t" timeout 1800 gmsh -3 "$case/layers.geo" -format msh2 -o "$case/layers.msh" \
      >"$case/gmsh.log" 2>&1 && have gmshToFoam && (cd "$case" && gmshToFoam layers.msh -case . >gmshToFoam.log 2>&1); then
    read -r verdict vmin nonorth skew < <(check "$case")
    read -r nc np nt < <(cells "$case")
    reached=-
    [[ $verdict == OK ]] && reached=100.0%
    printf '%-10s %-7s %9s %8s %8s %7.2f %7s %7s %-7s %10s %8s %8s\n' "$n" gmsh "$nc" "$np" "$nt" "$(cat "$tmp/t")" \
      "$reached" "$reached" "$verdict" "$vmin" "$nonorth" "$skew"
  else
    printf '%-10s %-7s failed: %s\n' "$n" gmsh "$(grep -m1 -E 'Error|error' "$case/gmsh.log" || tail -1 "$case/gmsh.log")"
  fi
done
