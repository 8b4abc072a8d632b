#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks, builds, and runs the whole test suite; then the
# sanitizer and fuzz stage (scripts/sanitize.sh: ASan+UBSan suite, short fuzz runs, TSan on the
# threaded tests). PDRMESH_SANITIZERS=0 skips that stage.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
(cd "${BUILD_DIR:-$root/build}" && ctest --output-on-failure --parallel "$(nproc)" --timeout 600)
if [[ ${PDRMESH_SANITIZERS:-1} != 0 ]]; then
  "$root/scripts/sanitize.sh"
fi
