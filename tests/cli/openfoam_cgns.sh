#!/usr/bin/env bash
# The OpenFOAM and CGNS outputs checked by the programs their users run, on one
# corpus surface:
#   pdrmesh mesh SURFACE -o m.meshb; pdrmesh validate m.meshb --surface SURFACE
#   pdrmesh convert m.meshb case/constant/polyMesh; checkMesh -case case
#       "Mesh OK.", every patch of the boundary file in its report, and (with
#       --compare-quality) its non-orthogonality and skewness equal to those
#       of `pdrmesh quality --json`
#   pdrmesh convert m.meshb m.cgns; cgnscheck m.cgns: no error
# checkMesh (Debian: openfoam) and cgnscheck (cgns-convert) come from
# scripts/install-deps.sh; without either the test is skipped (exit 77).
# Usage: openfoam_cgns.sh PDRMESH SURFACE [--compare-quality]
set -euo pipefail
pdrmesh=$1 surface=$2 compare=${3:-}
[[ -f $surface ]] || { echo "test surface $surface not found"; exit 1; }
missing=()
command -v checkMesh >/dev/null || missing+=("checkMesh (Debian package openfoam)")
command -v cgnscheck >/dev/null || missing+=("cgnscheck (Debian package cgns-convert)")
if ((${#missing[@]} > 0)); then
  echo "SKIP: not installed: ${missing[*]}; scripts/install-deps.sh installs them"
  exit 77
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$pdrmesh" mesh -q "$surface" -o "$tmp/m.meshb"
"$pdrmesh" validate "$tmp/m.meshb" --surface "$surface"

# OpenFOAM: checkMesh reads system/controlDict, fvSchemes and fvSolution besides
# constant/polyMesh, and its own etc/ through the environment of OpenFOAM's bashrc.
"$pdrmesh" convert "$tmp/m.meshb" "$tmp/case/constant/polyMesh"
source "$(dirname "$0")/openfoam_lib.sh"
checkmesh_case "$tmp/case"
openfoam_env
checkMesh -case "$tmp/case" -noFunctionObjects >"$tmp/checkMesh.log" 2>&1 || {
  cat "$tmp/checkMesh.log"; echo "checkMesh failed"; exit 1; }
grep -q "^Mesh OK\." "$tmp/checkMesh.log" || { cat "$tmp/checkMesh.log"; echo "checkMesh: not 'Mesh OK.'"; exit 1; }
patches=$(sed -n 's/^    \([^ {}]\+\)$/\1/p' "$tmp/case/constant/polyMesh/boundary")
[[ -n $patches ]] || { echo "no patches in the boundary file"; exit 1; }
for p in $patches; do
  grep -Eq "^ +$p +[0-9]+ +[0-9]+ " "$tmp/checkMesh.log" || {
    cat "$tmp/checkMesh.log"; echo "patch $p is not in checkMesh's report"; exit 1; }
done

if [[ $compare == --compare-quality ]]; then
  "$pdrmesh" quality --json "$tmp/m.meshb" >"$tmp/quality.json"
  python3 - "$tmp/checkMesh.log" "$tmp/quality.json" <<'PY'
import json, re, sys
log = open(sys.argv[1]).read()
ours = json.load(open(sys.argv[2]))["openfoam"]
theirs = {
    "max_non_orthogonality": float(re.search(r"non-orthogonality Max: (\S+)", log).group(1)),
    "mean_non_orthogonality": float(re.search(r"non-orthogonality Max: \S+ average: (\S+)", log).group(1)),
    "max_skewness": float(re.search(r"Max skewness = ([^ ,]+)", log).group(1)),
}
severe = re.search(r"severely non-orthogonal \(> 70 degrees\) faces: (\d+)", log)
failed = []
for key, value in theirs.items():
    # checkMesh prints 6 significant digits.
    if abs(ours[key] - value) > 1e-5 * max(1.0, abs(value)):
        failed.append(f"{key}: pdrmesh {ours[key]}, checkMesh {value}")
ours_severe = ours["faces_over_70"] - ours["faces_over_90"]
if (int(severe.group(1)) if severe else 0) != ours_severe:
    failed.append(f"faces over 70 degrees: pdrmesh {ours_severe}, checkMesh {severe.group(1) if severe else 0}")
if failed:
    sys.exit("quality figures differ from checkMesh's:\n  " + "\n  ".join(failed))
print("quality figures match checkMesh:", theirs, "faces over 70:", ours_severe)
PY
fi

"$pdrmesh" convert "$tmp/m.meshb" "$tmp/m.cgns"
cgnscheck "$tmp/m.cgns" >"$tmp/cgnscheck.log" 2>&1 || { cat "$tmp/cgnscheck.log"; echo "cgnscheck failed"; exit 1; }
if grep -qi "error" "$tmp/cgnscheck.log"; then cat "$tmp/cgnscheck.log"; echo "cgnscheck reports an error"; exit 1; fi
echo "ok: $surface: checkMesh says Mesh OK (patches: $(echo $patches)), cgnscheck reports no error"
