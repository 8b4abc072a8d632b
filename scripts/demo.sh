#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks, builds, and runs the main job, the parallel
# method in one process with one worker per core (`pdrmesh run`), on the embedded default
# surface (examples/bunny.mesh), writing and validating out/bunny.vtu.
# Pass another surface and output to mesh your own: scripts/demo.sh SURFACE OUT
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
surface=${1:-$root/examples/bunny.mesh}
output=${2:-$root/out/bunny.vtu}
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
mkdir -p "$(dirname "$output")"
"${BUILD_DIR:-$root/build}/client/pdrmesh" run "$surface" -o "$output" --workers "$(nproc)" --profile
"${BUILD_DIR:-$root/build}/client/pdrmesh" validate "$output" --surface "$surface"
