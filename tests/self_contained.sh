#!/usr/bin/env bash
# SPDX-License-Identifier: AGPL-3.0-or-later
# The tests need nothing outside the repository: no file under tests/ and no CMake file names a
# path beside the checkout (../shared, or the source directory's parent). Their surfaces are in
# tests/data; the benchmarks' large ones come from bench/fetch-corpus.sh.
# Usage: self_contained.sh SOURCE_DIR
set -euo pipefail
cd "$1"
pattern='\.\./shared|SOURCE_DIR\}/\.\./|\$root/\.\./'
# The repository's files (tracked or not ignored) in a git checkout; otherwise all but build trees.
if git rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  mapfile -t files < <(git ls-files --cached --others --exclude-standard -- tests '*CMakeLists.txt' '*.cmake')
else
  mapfile -t files < <(find . \( -path './build*' -o -path './.git' \) -prune -o -type f \
                              \( -path './tests/*' -o -name CMakeLists.txt -o -name '*.cmake' \) -print)
fi
if hits=$(grep -nIE "$pattern" "${files[@]}" | sed 's|^\./||' | grep -v '^tests/self_contained.sh:'); then
  echo "paths outside the repository:"
  echo "$hits"
  exit 1
fi
echo "ok: tests/ and the CMake files name no path outside the repository"
