#!/usr/bin/env bash
# Installs every Debian 12 package pdrmesh needs to build and test.
# Non-interactive and idempotent; run as root (or with sudo available).
#   scripts/install-deps.sh          build and test dependencies
#   scripts/install-deps.sh --bench  also the peers the benchmarks compare against
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libtet1.5-dev                               # TetGen 1.5: initial boundary-conforming mesh
  libgrpc++-dev protobuf-compiler-grpc        # service (find_package(gRPC CONFIG))
  libprotobuf-dev protobuf-compiler
  libtbb-dev libspdlog-dev libfmt-dev
  libcli11-dev nlohmann-json3-dev libsqlite3-dev
  zlib1g-dev                                  # compressed VTU (vtkZLibDataCompressor)
  libpng-dev                                  # pdrmesh view: PNG pictures
  libcgns-dev                                 # .cgns output (find_package(CGNS), cmake/FindCGNS.cmake)
  openfoam cgns-convert                       # tests/cli/openfoam_cgns.sh: checkMesh and cgnscheck
  libgtest-dev libgmock-dev
  python3-yaml                                # tests/deploy: the manifest check
  pybind11-dev python3-dev python3-numpy      # python/: the Python module pdrmesh
  python3-meshio                              # tests/python: Mesh.to_meshio
  clang-14 libclang-rt-14-dev                 # scripts/sanitize.sh: ASan/UBSan/TSan builds, libFuzzer
  curl dpkg-dev xz-utils                      # scripts/tsan-tbb.sh: oneTBB's Debian source, built with TSan
)
if [[ "${1:-}" == "--bench" ]]; then
  packages+=(tetgen gmsh time bc)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
