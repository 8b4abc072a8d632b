#!/usr/bin/env bash
# Two regions end to end: a solid box ("body") inside a fluid box ("fluid"),
# both with outward normals, from an OBJ with two groups. `check` names the
# regions; `mesh` and `run` (1 and 2 workers: the same bytes) mesh them with
# a conforming interface; `validate`, `quality` and the polyMesh's cellZones
# report them; prism layers grow on the body's walls on the fluid's side
# (--layers-in); the inner box turned inward is a cavity again (one region).
# Usage: regions.sh PDRMESH
set -euo pipefail
pdrmesh=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# The unit box's faces as outward quads of corner numbers x + 2y + 4z (1-based in the OBJ).
quads=("1 5 7 3" "2 4 8 6" "1 2 6 5" "3 7 8 4" "5 6 8 7" "1 3 4 2")
# box LO HI FIRST [reverse]: the OBJ lines of the box [LO, HI]^3, its corners numbered from FIRST.
box() {
  local lo=$1 hi=$2 first=$3 reverse=${4:-}
  for c in 0 1 2 3 4 5 6 7; do
    printf 'v %s %s %s\n' "$( ((c & 1)) && echo "$hi" || echo "$lo")" "$( ((c & 2)) && echo "$hi" || echo "$lo")" \
      "$( ((c & 4)) && echo "$hi" || echo "$lo")"
  done
  for q in "${quads[@]}"; do
    read -r a b c d <<<"$q"
    if [[ -n $reverse ]]; then
      echo "f $((a + first - 1)) $((d + first - 1)) $((c + first - 1)) $((b + first - 1))"
    else
      echo "f $((a + first - 1)) $((b + first - 1)) $((c + first - 1)) $((d + first - 1))"
    fi
  done
}
{ echo "g fluid"; box 0 4 1; echo "g body"; box 1.5 2.5 9; } >"$tmp/two.obj"
{ echo "g fluid"; box 0 4 1; echo "g hole"; box 1.5 2.5 9 reverse; } >"$tmp/cavity.obj"

out=$("$pdrmesh" check "$tmp/two.obj")
grep -q "2 regions" <<<"$out" || fail "check does not report two regions: $out"
grep -q "region 2 body" <<<"$out" || fail "check does not name region 2 body: $out"
"$pdrmesh" check --json "$tmp/two.obj" | grep -q '"regions":\[{"id":1,"name":"fluid"' || fail "check --json: no regions"

"$pdrmesh" mesh -q "$tmp/two.obj" --size 0.4 -o "$tmp/m.vtu"
out=$("$pdrmesh" validate "$tmp/m.vtu" --surface "$tmp/two.obj")
grep -q "regions 2  interface faces 12" <<<"$out" || fail "validate: $out"
grep -q "^valid" <<<"$out" || fail "validate: $out"
out=$("$pdrmesh" quality "$tmp/m.vtu")
grep -q "regions: 1 fluid: [0-9]* tets, 2 body: [0-9]* tets" <<<"$out" || fail "quality: $out"

for w in 1 2; do
  "$pdrmesh" run -q "$tmp/two.obj" --size 0.4 --workers $w --depth 1 -o "$tmp/r$w.vtu"
  "$pdrmesh" run -q "$tmp/two.obj" --size 0.4 --workers $w --depth 1 -o "$tmp/r$w.msh"
done
cmp -s "$tmp/r1.vtu" "$tmp/r2.vtu" || fail "run: 1 and 2 workers differ (.vtu)"
cmp -s "$tmp/r1.msh" "$tmp/r2.msh" || fail "run: 1 and 2 workers differ (.msh)"
"$pdrmesh" validate "$tmp/r2.msh" --surface "$tmp/two.obj" | grep -q "regions 2  interface faces 12" ||
  fail "run's mesh does not validate with its interface"
grep -q '^3 2 "body"' "$tmp/r1.msh" || fail "no physical volume body in the .msh"

mkdir -p "$tmp/case/constant"
"$pdrmesh" convert "$tmp/m.vtu" "$tmp/case/constant/polyMesh"
grep -q "^    body$" "$tmp/case/constant/polyMesh/cellZones" || fail "no cellZone body"

# Prism layers on the body's walls, on the fluid's side only (--layers-in), serial and parallel.
if "$pdrmesh" mesh -q "$tmp/two.obj" --size 0.4 --layers 3 --first-height 0.02 --layers-on body \
    -o "$tmp/l.msh" 2>"$tmp/err"; then
  fail "layers on two regions without --layers-in were accepted"
fi
grep -q "fluid (1), body (2).*--layers-in" "$tmp/err" || fail "the refusal names no regions: $(cat "$tmp/err")"
"$pdrmesh" mesh -q "$tmp/two.obj" --size 0.4 --layers 3 --first-height 0.02 --layers-on body --layers-in fluid \
  -o "$tmp/l.msh"
out=$("$pdrmesh" validate "$tmp/l.msh" --surface "$tmp/two.obj")
grep -q "^valid" <<<"$out" || fail "layered regions: $out"
grep -q "regions 2  interface faces 12" <<<"$out" || fail "layered regions' interface: $out"
grep -q "prisms 36 " <<<"$out" || fail "not 3 layers on the body's 12 triangles: $out"
for w in 1 2; do
  "$pdrmesh" run -q "$tmp/two.obj" --size 0.4 --workers $w --depth 1 --layers 3 --first-height 0.02 \
    --layers-on body --layers-in fluid -o "$tmp/lr$w.vtu"
done
cmp -s "$tmp/lr1.vtu" "$tmp/lr2.vtu" || fail "layered run: 1 and 2 workers differ"
"$pdrmesh" validate "$tmp/lr2.vtu" --surface "$tmp/two.obj" | grep -q "^valid" || fail "layered run does not validate"
out=$("$pdrmesh" quality "$tmp/lr2.vtu")
grep -q "regions: 1 fluid: [0-9]* tets and 36 prisms, 2 body: [0-9]* tets$" <<<"$out" || fail "quality's regions: $out"
"$pdrmesh" convert "$tmp/lr2.vtu" "$tmp/case/constant/polyMesh"
grep -q "^    fluid$" "$tmp/case/constant/polyMesh/cellZones" || fail "no cellZone fluid in the layered polyMesh"

# The inner box inward: a cavity, one region, no region data.
out=$("$pdrmesh" check "$tmp/cavity.obj")
grep -q "regions" <<<"$out" && fail "a cavity makes regions: $out"
"$pdrmesh" mesh -q "$tmp/cavity.obj" --size 0.4 -o "$tmp/c.vtu"
grep -q 'Name="region"' "$tmp/c.vtu" && fail "a one-region mesh carries region data"
echo "regions: OK"
