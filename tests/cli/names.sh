#!/usr/bin/env bash
# Boundary names end to end: STL solids, OBJ groups and a --names file on a
# Medit surface reach the SU2 marker tags and the .mapbc beside a UGRID file,
# through `pdrmesh mesh` and `pdrmesh run --workers 2` alike (1 and 2 workers:
# the same bytes); unnamed ids stay "surface_<id>"; a bad names file is an
# error naming its line.
# Usage: names.sh PDRMESH
set -euo pipefail
pdrmesh=$1
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# The unit box's six faces as quads (outward), two triangles each: q NAME x y z ... (4 corners).
faces=(
  "0 0 0  0 0 1  0 1 1  0 1 0"   # x=0
  "1 0 0  1 1 0  1 1 1  1 0 1"   # x=1
  "0 0 0  1 0 0  1 0 1  0 0 1"   # y=0
  "0 1 0  0 1 1  1 1 1  1 1 0"   # y=1
  "0 0 1  1 0 1  1 1 1  0 1 1"   # z=1
  "0 0 0  0 1 0  1 1 0  1 0 0"   # z=0
)
# box.stl: solids inlet (x=0), outlet (x=1), sides (y=0 and y=1), top (z=1), and an unnamed one (z=0).
solid_of=(inlet outlet sides sides top "")
facet() { printf 'facet normal 0 0 0\nouter loop\nvertex %s %s %s\nvertex %s %s %s\nvertex %s %s %s\nendloop\nendfacet\n' "$@"; }
{
  prev=unset
  for f in 0 1 2 3 4 5; do
    name=${solid_of[$f]}
    if [[ $name != "$prev" ]]; then
      [[ $prev == unset ]] || echo "endsolid"
      echo "solid $name"
      prev=$name
    fi
    read -r a0 a1 a2 b0 b1 b2 c0 c1 c2 d0 d1 d2 <<<"${faces[$f]}"
    facet "$a0" "$a1" "$a2" "$b0" "$b1" "$b2" "$c0" "$c1" "$c2"
    facet "$a0" "$a1" "$a2" "$c0" "$c1" "$c2" "$d0" "$d1" "$d2"
  done
  echo "endsolid"
} >"$tmp/box.stl"

tags() { grep '^MARKER_TAG=' "$1" | awk '{print $2}' | paste -sd' '; }
expect_tags() {  # FILE "TAGS..."
  local got; got=$(tags "$1")
  [[ $got == "$2" ]] || fail "$1: marker tags '$got', expected '$2'"
}
expect_file() {  # FILE CONTENT
  local got; got=$(cat "$1")
  [[ $got == "$2" ]] || fail "$1: got
$got
expected
$2"
}
mapbc_box=$'5\n1 3000 inlet\n2 3000 outlet\n3 3000 sides\n4 3000 top\n5 3000 surface_5'

# STL solids, serial and parallel.
"$pdrmesh" mesh -q "$tmp/box.stl" --size 0.2 -o "$tmp/m.su2"
expect_tags "$tmp/m.su2" "inlet outlet sides top surface_5"
"$pdrmesh" validate "$tmp/m.su2" --surface "$tmp/box.stl" >/dev/null
"$pdrmesh" mesh -q "$tmp/box.stl" --size 0.2 -o "$tmp/m.ugrid"
expect_file "$tmp/m.mapbc" "$mapbc_box"
"$pdrmesh" validate "$tmp/m.ugrid" --surface "$tmp/box.stl" >/dev/null
for w in 1 2; do
  "$pdrmesh" run -q "$tmp/box.stl" --size 0.2 --depth 1 --workers $w -o "$tmp/r$w.su2"
  "$pdrmesh" run -q "$tmp/box.stl" --size 0.2 --depth 1 --workers $w -o "$tmp/r$w.lb8.ugrid"
done
cmp "$tmp/r1.su2" "$tmp/r2.su2"
cmp "$tmp/r1.lb8.ugrid" "$tmp/r2.lb8.ugrid"
expect_tags "$tmp/r2.su2" "inlet outlet sides top surface_5"
expect_file "$tmp/r2.mapbc" "$mapbc_box"
"$pdrmesh" validate "$tmp/r2.su2" --surface "$tmp/box.stl" >/dev/null
# The .mapbc comes back with its grid: converted, the names are the SU2 tags.
"$pdrmesh" convert "$tmp/r2.lb8.ugrid" "$tmp/c.su2"
expect_tags "$tmp/c.su2" "inlet outlet sides top surface_5"

# The box's 8 corners (x + 2y + 4z + 1) and its faces by corner numbers, for OBJ and Medit.
corners() { for k in 0 1; do for j in 0 1; do for i in 0 1; do echo "$1$i $j $k$2"; done; done; done; }
quad() {  # FACE -> its four corner numbers
  read -r a0 a1 a2 b0 b1 b2 c0 c1 c2 d0 d1 d2 <<<"${faces[$1]}"
  echo "$((a0 + 2 * a1 + 4 * a2 + 1)) $((b0 + 2 * b1 + 4 * b2 + 1)) $((c0 + 2 * c1 + 4 * c2 + 1)) $((d0 + 2 * d1 + 4 * d2 + 1))"
}

# OBJ groups (faces before any group: unnamed).
{
  corners "v " ""
  echo "f $(quad 5)"                # z=0, before any group
  echo "g front";  echo "f $(quad 0)"
  echo "g back";   echo "f $(quad 1)"
  echo "o walls";  echo "f $(quad 2)"; echo "f $(quad 3)"; echo "f $(quad 4)"
} >"$tmp/box.obj"
"$pdrmesh" mesh -q "$tmp/box.obj" --size 0.2 -o "$tmp/o.su2"
expect_tags "$tmp/o.su2" "surface_1 front back walls"

# A Medit surface (ids, no names) named by --names, ids that are not 1..k included.
{
  echo "MeshVersionFormatted 2"; echo "Dimension 3"; echo "Vertices"; echo 8
  corners "" " 0"
  echo "Quadrilaterals"; echo 6
  refs=(10 20 30 30 0 40)
  for f in 0 1 2 3 4 5; do echo "$(quad $f) ${refs[$f]}"; done
  echo "End"
} >"$tmp/box.mesh"
printf '# id name\n10 inlet\n20 outlet\n30 sides\n0 lid   # the top\n' >"$tmp/names.txt"
"$pdrmesh" mesh -q "$tmp/box.mesh" --names "$tmp/names.txt" --size 0.2 -o "$tmp/n.su2"
expect_tags "$tmp/n.su2" "lid inlet outlet sides surface_40"
"$pdrmesh" run -q "$tmp/box.mesh" --names "$tmp/names.txt" --size 0.2 --depth 1 --workers 2 -o "$tmp/n.ugrid"
expect_file "$tmp/n.mapbc" $'5\n0 3000 lid\n10 3000 inlet\n20 3000 outlet\n30 3000 sides\n40 3000 surface_40'
# Medit volume output holds no names; --names gives them back on conversion.
"$pdrmesh" mesh -q "$tmp/box.mesh" --size 0.2 -o "$tmp/v.mesh"
[[ ! -e "$tmp/v.mapbc" ]] || fail "a .mesh output wrote a .mapbc"
"$pdrmesh" convert "$tmp/v.mesh" "$tmp/v.ugrid" --names "$tmp/names.txt"
expect_file "$tmp/v.mapbc" $'5\n0 3000 lid\n10 3000 inlet\n20 3000 outlet\n30 3000 sides\n40 3000 surface_40'

# Bad names files: exit 65, the file and line named; nothing written.
expect_error() {  # NAMES-TEXT MESSAGE
  printf '%s' "$1" >"$tmp/bad.txt"
  local rc=0
  "$pdrmesh" mesh -q "$tmp/box.mesh" --names "$tmp/bad.txt" -o "$tmp/bad.su2" 2>"$tmp/err" || rc=$?
  [[ $rc == 65 ]] || fail "names '$1': exit $rc, expected 65: $(cat "$tmp/err")"
  grep -qF -- "$2" "$tmp/err" || fail "names '$1': '$2' not in: $(cat "$tmp/err")"
  [[ ! -e "$tmp/bad.su2" ]] || fail "names '$1': a mesh was written"
}
expect_error $'10 inlet\n20 out let\n' "bad.txt:2: unexpected 'let' after the name 'out'"
expect_error $'10 inlet\n\n20 3d\n' "bad.txt:3: '3d' starts with '3'"
expect_error $'10 inlet\n20 inlet\n' "bad.txt:2: 'inlet' names id 20 here and id 10 on line 1"
expect_error $'10 inlet\n7 outlet\n' "id 7 ('outlet') is not a surface id here (the ids are 0, 10, 20, 30, 40)"
rc=0; "$pdrmesh" mesh -q "$tmp/box.mesh" --names "$tmp/missing.txt" -o "$tmp/x.su2" 2>/dev/null || rc=$?
[[ $rc == 64 ]] || fail "a missing --names file: exit $rc, expected 64 (usage)"
echo "ok: names reach SU2 and .mapbc from STL, OBJ and --names, serial and parallel"
