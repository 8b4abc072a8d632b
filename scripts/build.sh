#!/usr/bin/env bash
# Configures and builds pdrmesh into ./build (override with BUILD_DIR).
# Extra arguments go to cmake's configure step, e.g. -DCMAKE_BUILD_TYPE=Debug.
# A unity build (CMake batches the sources of a target, 8 to a compiler run): a quicker whole
# build, which is what a fresh machine and CI do. For editing, a per-file build rebuilds
# less: pass -DCMAKE_UNITY_BUILD=OFF. The code compiles either way.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${BUILD_DIR:-$root/build}
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_UNITY_BUILD=ON "$@" >/dev/null
cmake --build "$build" --parallel "$(nproc)"
