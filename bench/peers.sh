#!/usr/bin/env bash
# pdrmesh beside two peers from Debian at matched sizes, per corpus surface:
#   pdrmesh mesh (default spacing)                    -> T tets, mesh volume V
#   TetGen 1.5:  tetgen -pYq1.414 -a<A>     (A: twice the mean tet volume V/T, then rescaled once)
#   Gmsh 4.8 HXT: gmsh -3 -nt 1 -setnumber Mesh.Algorithm3D 10 -setnumber Mesh.Optimize 1
#                 -setnumber Mesh.MeshSizeMax H, H = edge of the regular tet of volume V/T,
#                 then rescaled once by the cube root of the tet-count ratio,
#                 on a .geo that merges the STL and declares the volume
# Columns: tets, wall seconds, tets per second, peak memory, min/max dihedral over all tets and over
# the tets with no boundary vertex (imin/imax), share of tets with an angle under 10 degrees, and
# pdrmesh's ratios to each peer (tets per second, minimum angle); then the same rows as a Markdown table.
#   bench/peers.sh [SURFACE...]     (default: the small corpus surfaces; needs install-deps.sh --bench)
#   PEERS_SIZE=diag100 bench/peers.sh ...   pdrmesh at --size = bounding-box diagonal / 100 (the
#                                           second size of the quality goals; the peers follow its count)
#   PEERS_TIMEOUT=S                         seconds each run may take (default 1800)
#   PDRMESH_CORPUS=DIR                      the surfaces (default bench/corpus: bench/fetch-corpus.sh)
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
corpus=${PDRMESH_CORPUS:-$root/bench/corpus}  # bench/fetch-corpus.sh fills it
[[ -d $corpus ]] || { echo "no corpus in $corpus: run bench/fetch-corpus.sh" >&2; exit 1; }
pdrmesh=${PDRMESH:-$root/build/client/pdrmesh}
names=("$@"); ((${#names[@]})) || names=(sphere966 bunny_npm hinge elephant couplingdown knot2 fandisk primitives13)
size=${PEERS_SIZE:-default}
limit=${PEERS_TIMEOUT:-1800}
[[ $size == default || $size == diag100 ]] || { echo "PEERS_SIZE: default or diag100" >&2; exit 1; }
for tool in tetgen gmsh /usr/bin/time; do
  command -v "$tool" >/dev/null || { echo "needs $tool: scripts/install-deps.sh --bench" >&2; exit 1; }
done
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

field() { sed -n "s/.*\"$1\":\([-0-9.e+]*\).*/\1/p" "$2"; }
# run NAME TIMEOUT command...: wall seconds and peak KiB into $tmp/NAME.time
run() {
  local name=$1 limit=$2; shift 2
  /usr/bin/time -f '%e %M' -o "$tmp/$name.time" timeout "$limit" "$@" >"$tmp/$name.log" 2>&1
}
row() {  # row SURFACE TOOL MESHFILE
  local q="$tmp/$2.q"
  if [[ ! -s $3 ]] || ! "$pdrmesh" quality --json "$3" >"$q" 2>/dev/null || [[ $(field tets "$q") == 0 ]]; then
    printf '%-13s %-8s %10s\n' "$1" "$2" "failed: no tets ($(tail -1 "$tmp/$2.log" | cut -c1-60))"
    echo "| $1 | $2 | no mesh | | | | | |" >>"$tmp/table.md"
    return 1
  fi
  read -r secs kib <"$tmp/$2.time"
  awk -v s="$1" -v t="$2" -v n="$(field tets "$q")" -v sec="$secs" -v kib="$kib" -v lo="$(field min_dihedral "$q")" \
      -v hi="$(field max_dihedral "$q")" -v ilo="$(field interior_min_dihedral "$q")" \
      -v ihi="$(field interior_max_dihedral "$q")" -v u="$(field share_below_10 "$q")" -v md="$tmp/table.md" \
      'BEGIN { printf "%-13s %-8s %10d %8.2f %9.0f %8.1f %7.2f %7.2f %7.2f %7.2f %8.3f%%\n", s, t, n, sec, n / sec, kib / 1024, lo, hi, ilo, ihi, 100 * u
               inner = (ilo == 0 && ihi == 0) ? "none" : sprintf("%.2f / %.2f", ilo, ihi)
               printf "| %s | %s | %d | %.2f | %.0f | %.2f / %.2f | %s | %.3f%% |\n", s, t, n, sec, kib / 1024, lo, hi, inner, 100 * u >> md }'
  echo "$(field tets "$q") $secs $(field min_dihedral "$q")" >"$tmp/$2.sum"
}

echo "pdrmesh size: $size"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'); $(date -u +%F)"
echo "versions: $("$pdrmesh" --version), TetGen 1.5 (Debian tetgen), Gmsh $(gmsh --version 2>&1 | head -1)"
printf '%-13s %-8s %10s %8s %9s %8s %7s %7s %7s %7s %9s\n' surface tool tets seconds tets/s peak_MB min max imin imax under10
for n in "${names[@]}"; do
  stl=$corpus/$n.stl
  size_args=()
  if [[ $size == diag100 ]]; then  # the diagonal of the points' bounding box, from the .mesh twin
    size_args=(--size "$(awk '/^Vertices/ { getline n; for (i = 0; i < n; ++i) { getline; for (k = 1; k <= 3; ++k) {
      if (i == 0 || $k < lo[k]) lo[k] = $k; if (i == 0 || $k > hi[k]) hi[k] = $k } } exit }
      END { printf "%.17g", sqrt((hi[1]-lo[1])^2 + (hi[2]-lo[2])^2 + (hi[3]-lo[3])^2) / 100 }' "$corpus/$n.mesh")")
  fi
  run pdrmesh "$limit" "$pdrmesh" mesh -q "$stl" "${size_args[@]}" -o "$tmp/p.meshb"
  row "$n" pdrmesh "$tmp/p.meshb" || continue
  tets=$(field tets "$tmp/pdrmesh.q"); vol=$(field volume "$tmp/pdrmesh.q")
  a=$(awk -v v="$vol" -v t="$tets" 'BEGIN { printf "%.6g", 2 * v / t }')
  h=$(awk -v v="$vol" -v t="$tets" 'BEGIN { printf "%.6g", (6 * sqrt(2) * v / t) ^ (1 / 3) }')
  cp "$stl" "$tmp/s.stl"
  printf 'Merge "s.stl";\nSurface Loop(1) = {1};\nVolume(1) = {1};\n' >"$tmp/s.geo"
  # Each peer runs twice: the second time with its size scaled by the tet count the first run
  # gave, so that its tet count matches pdrmesh's (within a few per cent).
  for pass in 1 2; do
    rm -f "$tmp"/s.1.* "$tmp/g.msh"
    run tetgen "$limit" tetgen -pYq1.414a"$a"gQ "$tmp/s.stl"
    (cd "$tmp" && run gmsh-hxt "$limit" gmsh -3 -nt 1 -setnumber Mesh.Algorithm3D 10 -setnumber Mesh.Optimize 1 \
       -setnumber Mesh.MeshSizeMax "$h" s.geo -o g.msh -format msh41)
    [[ $pass == 2 ]] && break
    tt=$("$pdrmesh" quality --json "$tmp/s.1.mesh" 2>/dev/null | sed -n 's/.*"tets":\([0-9]*\).*/\1/p')
    gt=$("$pdrmesh" quality --json "$tmp/g.msh" 2>/dev/null | sed -n 's/.*"tets":\([0-9]*\).*/\1/p')
    [[ -n $tt ]] && a=$(awk -v a="$a" -v got="$tt" -v want="$tets" 'BEGIN { printf "%.6g", a * got / want }')
    [[ -n $gt ]] && h=$(awk -v h="$h" -v got="$gt" -v want="$tets" 'BEGIN { printf "%.6g", h * (got / want) ^ (1 / 3) }')
  done
  row "$n" tetgen "$tmp/s.1.mesh"
  row "$n" gmsh-hxt "$tmp/g.msh"
  for peer in tetgen gmsh-hxt; do
    [[ -s $tmp/$peer.sum ]] || continue
    read -r pt ps pmin <"$tmp/$peer.sum"; read -r mt ms mmin <"$tmp/pdrmesh.sum"
    awk -v s="$n" -v p="$peer" -v pt="$pt" -v ps="$ps" -v pm="$pmin" -v mt="$mt" -v ms="$ms" -v mm="$mmin" \
      'BEGIN { printf "%-13s %-8s pdrmesh/peer: tets %.2f, tets/s %.2f, min angle %.2f\n", s, p, mt / pt, (mt / ms) / (pt / ps), mm / pm }'
    rm -f "$tmp/$peer.sum"
  done
done
echo "pdrmesh: check + TetGen initial mesh + refinement + optimization + validation + write .meshb (one core)"
echo
echo "| surface | tool | tets | seconds | peak MB | min / max dihedral | interior min / max | tets under 10 degrees |"
echo "|---|---|---|---|---|---|---|---|"
cat "$tmp/table.md" 2>/dev/null
