#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# Fills the benchmark corpus folder with NAME.mesh and NAME.stl for the ten corpus surfaces
# (what bench/*.sh and the bench programs read; provenance and licences in tests/data/README.md):
#  * the eight small ones (sphere966 bunny_npm hinge elephant couplingdown knot2 fandisk
#    primitives13): tests/data/NAME.mesh, and its STL;
#  * armadillo: Debian package libcgal-demo (`apt-get download`), data/meshes/armadillo.off of its
#    /usr/share/doc/libcgal-dev/data.tar.gz, converted as is;
#  * frame: Debian package netgen-doc, /usr/share/doc/netgen/examples/frame.step, surface-meshed
#    by gmsh (2D, -clmax = 0.004 x the bounding-box diagonal of its curves) and oriented outward;
#    skipped, with a message, where gmsh is not installed. Debian's gmsh 4.8.4 gives 136,480
#    triangles here, not the 136,414 of the corpus's frame (tests/data/README.md): frame's figures
#    compare only between runs on the same fetched file.
# Conversions by bench/corpus_convert.py (python3). Idempotent: a surface whose two files are there
# is left alone; the downloaded packages stay in DIR/.download. Needs apt-get and network access to
# the Debian mirror for armadillo and frame only.
#   bench/fetch-corpus.sh [DIR]     (default: $PDRMESH_CORPUS, else bench/corpus, git-ignored)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dir=${1:-${PDRMESH_CORPUS:-$root/bench/corpus}}
convert=(python3 "$root/bench/corpus_convert.py")
mkdir -p "$dir"
download=$dir/.download

have() { [[ -s $dir/$1.mesh && -s $dir/$1.stl ]]; }

# deb PACKAGE: extracts the package (apt-get download, dpkg-deb -x) into $download/PACKAGE once.
deb() {
  local package=$1
  [[ -d $download/$package ]] && return 0
  mkdir -p "$download"
  (cd "$download" && rm -f "$package"_*.deb && apt-get download "$package")
  dpkg-deb -x "$download/$package"_*.deb "$download/$package.tmp"
  mv "$download/$package.tmp" "$download/$package"
}

for name in sphere966 bunny_npm hinge elephant couplingdown knot2 fandisk primitives13; do
  have "$name" && continue
  "${convert[@]}" "$root/tests/data/$name.mesh" "$dir/$name.mesh.tmp" "$dir/$name.stl.tmp"
  mv "$dir/$name.mesh.tmp" "$dir/$name.mesh" && mv "$dir/$name.stl.tmp" "$dir/$name.stl"
  echo "fetch-corpus: $name (tests/data)"
done

if ! have armadillo; then
  deb libcgal-demo
  tar -xzf "$download/libcgal-demo/usr/share/doc/libcgal-dev/data.tar.gz" -C "$download" data/meshes/armadillo.off
  "${convert[@]}" "$download/data/meshes/armadillo.off" "$dir/armadillo.mesh.tmp" "$dir/armadillo.stl.tmp"
  mv "$dir/armadillo.mesh.tmp" "$dir/armadillo.mesh" && mv "$dir/armadillo.stl.tmp" "$dir/armadillo.stl"
  echo "fetch-corpus: armadillo (libcgal-demo $(dpkg-deb -f "$download"/libcgal-demo_*.deb Version))"
fi

if have frame; then
  :
elif ! command -v gmsh > /dev/null; then
  echo "fetch-corpus: frame skipped: it is meshed from a STEP file by gmsh, which is not installed" \
       "(apt-get install gmsh)" >&2
else
  deb netgen-doc
  step=$download/netgen-doc/usr/share/doc/netgen/examples/frame.step
  gmsh "$step" -1 -format msh2 -o "$download/frame.curves.msh" > "$download/frame.gmsh.log"
  diag=$("${convert[@]}" --diagonal "$download/frame.curves.msh")
  clmax=$(python3 -c "print(0.004 * $diag)")
  gmsh "$step" -2 -clmax "$clmax" -format msh2 -o "$download/frame.msh" >> "$download/frame.gmsh.log"
  "${convert[@]}" --orient "$download/frame.msh" "$dir/frame.mesh.tmp" "$dir/frame.stl.tmp"
  mv "$dir/frame.mesh.tmp" "$dir/frame.mesh" && mv "$dir/frame.stl.tmp" "$dir/frame.stl"
  echo "fetch-corpus: frame (netgen-doc $(dpkg-deb -f "$download"/netgen-doc_*.deb Version), gmsh $(gmsh --version 2>&1), -clmax $clmax)"
fi
echo "fetch-corpus: $dir"
